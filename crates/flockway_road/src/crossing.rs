//! Roads that cross without meeting: on the ground plan their centre lines cross, or their
//! surfaces overlap by more than [`OVERLAP_M`], but no junction or link joins them. In a network drawn in the editor that is a bridge; in one
//! netconvert wrote from OpenStreetMap it is most often a bridge or a tunnel left flat (OSM's
//! `layer` tags give no height unless netconvert is asked for it). Either way cars on the one
//! pass over or under cars on the other, so their bodies must not touch.

use crate::{RoadGeometry, RoadId};
use glam::DVec2;
use std::collections::{BTreeMap, BTreeSet};

/// Longest piece of a centre line tested for crossings, m.
const PIECE_M: f64 = 4.0;
/// Side of a cell of the grid the pieces are sorted into, m.
const CELL_M: f64 = 32.0;
/// How far two roads' surfaces must overlap side by side to be at different levels, m (more
/// than kerbs drawn a little apart; a ramp netconvert drew flat along the motorway it leaves
/// overlaps it by metres).
pub(crate) const OVERLAP_M: f64 = 1.0;

/// One road for [`crossings`]: its id, geometry and the places it belongs to (a junction's
/// paths with its roads in and out are one place, two linked roads another: roads of one place
/// meet there).
pub(crate) struct CrossingRoad<'a> {
    pub id: RoadId,
    pub geometry: &'a RoadGeometry,
    pub places: Vec<u32>,
}

/// The pairs of roads (smaller id first, sorted) whose centre lines cross on the ground plan, or
/// whose surfaces overlap by more than [`OVERLAP_M`], although they share no place. Pieces are sorted into a grid, so the cost grows with the
/// length of road, not with its square.
pub(crate) fn crossings(roads: &[CrossingRoad]) -> Vec<(RoadId, RoadId)> {
    // Every road's centre line in pieces of at most PIECE_M, on the ground plan.
    // Each piece: its road, ends and the road's half width over it.
    let mut pieces: Vec<(usize, DVec2, DVec2, f64)> = Vec::new();
    for (r, road) in roads.iter().enumerate() {
        let g = road.geometry;
        let points: Vec<(DVec2, f64)> = g
            .stations(PIECE_M)
            .into_iter()
            .map(|s| {
                let frame = g.frame_at(s);
                (frame.pos.truncate(), 0.5 * frame.width_m)
            })
            .collect();
        for w in points.windows(2) {
            pieces.push((r, w[0].0, w[1].0, w[0].1.max(w[1].1)));
        }
    }
    let cell =
        |p: DVec2| -> (i64, i64) { ((p.x / CELL_M).floor() as i64, (p.y / CELL_M).floor() as i64) };
    // Ordered, so that the pieces are compared in the same order every run.
    let mut grid: BTreeMap<(i64, i64), Vec<usize>> = BTreeMap::new();
    for (k, &(_, a, b, half)) in pieces.iter().enumerate() {
        let (lo, hi) = (
            cell(a.min(b) - DVec2::splat(half)),
            cell(a.max(b) + DVec2::splat(half)),
        );
        for x in lo.0..=hi.0 {
            for y in lo.1..=hi.1 {
                grid.entry((x, y)).or_default().push(k);
            }
        }
    }
    let meet = |a: usize, b: usize| -> bool {
        a == b || roads[a].places.iter().any(|p| roads[b].places.contains(p))
    };
    let mut found: BTreeSet<(RoadId, RoadId)> = BTreeSet::new();
    for members in grid.values() {
        for (i, &p) in members.iter().enumerate() {
            for &q in &members[i + 1..] {
                let ((ra, a0, a1, ha), (rb, b0, b1, hb)) = (pieces[p], pieces[q]);
                if meet(ra, rb) {
                    continue;
                }
                let pair = if roads[ra].id < roads[rb].id {
                    (roads[ra].id, roads[rb].id)
                } else {
                    (roads[rb].id, roads[ra].id)
                };
                if !found.contains(&pair)
                    && (segments_cross(a0, a1, b0, b1)
                        || segment_distance(a0, a1, b0, b1) < ha + hb - OVERLAP_M)
                {
                    found.insert(pair);
                }
            }
        }
    }
    found.into_iter().collect()
}

/// The shortest distance between the segments `a0`–`a1` and `b0`–`b1` on the ground plan, m:
/// 0 where they cross or touch.
pub fn segments_apart_m(a0: DVec2, a1: DVec2, b0: DVec2, b1: DVec2) -> f64 {
    if segments_cross(a0, a1, b0, b1) {
        0.0
    } else {
        segment_distance(a0, a1, b0, b1)
    }
}

/// Whether the segments `a0`–`a1` and `b0`–`b1` cross (touching at an end counts).
fn segments_cross(a0: DVec2, a1: DVec2, b0: DVec2, b1: DVec2) -> bool {
    let side = |o: DVec2, p: DVec2, q: DVec2| (p - o).perp_dot(q - o);
    let (d1, d2) = (side(b0, b1, a0), side(b0, b1, a1));
    let (d3, d4) = (side(a0, a1, b0), side(a0, a1, b1));
    d1 * d2 <= 0.0 && d3 * d4 <= 0.0 && (d1 != 0.0 || d2 != 0.0) && (d3 != 0.0 || d4 != 0.0)
}

/// The shortest distance between the segments `a0`–`a1` and `b0`–`b1` that do not cross.
fn segment_distance(a0: DVec2, a1: DVec2, b0: DVec2, b1: DVec2) -> f64 {
    let to_segment = |p: DVec2, s0: DVec2, s1: DVec2| {
        let d = s1 - s0;
        let t = if d.length_squared() > 0.0 {
            ((p - s0).dot(d) / d.length_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        p.distance(s0 + t * d)
    };
    to_segment(a0, b0, b1)
        .min(to_segment(a1, b0, b1))
        .min(to_segment(b0, a0, a1))
        .min(to_segment(b1, a0, a1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RoadSpec;
    use glam::DVec3;

    fn road(name: &str, from: (f64, f64), to: (f64, f64)) -> RoadGeometry {
        let spec = RoadSpec::through(
            name,
            2,
            50.0,
            &[DVec3::new(from.0, from.1, 0.0), DVec3::new(to.0, to.1, 0.0)],
        );
        RoadGeometry::new(&spec).expect("a road")
    }

    #[test]
    fn roads_that_cross_without_a_place_in_common_are_found_once() {
        let over = road("over", (-100.0, 0.0), (100.0, 0.0));
        let under = road("under", (0.0, -100.0), (0.0, 100.0));
        let beside = road("beside", (-100.0, 20.0), (100.0, 20.0));
        let joined = road("joined", (50.0, -50.0), (50.0, 50.0));
        let roads = [
            CrossingRoad {
                id: RoadId(0),
                geometry: &over,
                places: vec![7],
            },
            CrossingRoad {
                id: RoadId(1),
                geometry: &under,
                places: vec![],
            },
            CrossingRoad {
                id: RoadId(2),
                geometry: &beside,
                places: vec![],
            },
            // Crosses `over` and `beside`, but meets `over` at a junction there.
            CrossingRoad {
                id: RoadId(3),
                geometry: &joined,
                places: vec![7],
            },
        ];
        assert_eq!(
            crossings(&roads),
            [
                (RoadId(0), RoadId(1)),
                (RoadId(1), RoadId(2)),
                (RoadId(2), RoadId(3))
            ]
        );
    }

    #[test]
    fn roads_whose_surfaces_overlap_side_by_side_are_at_different_levels() {
        // Two-lane roads 6 m wide: 4 m apart they overlap by 2 m; 6.5 m apart they do not touch.
        let main = road("main", (-100.0, 0.0), (100.0, 0.0));
        let ramp = road("ramp", (-50.0, -4.0), (50.0, -4.0));
        let kerb = road("kerb", (-50.0, 6.5), (50.0, 6.5));
        let roads = [&main, &ramp, &kerb].map(|g| CrossingRoad {
            id: RoadId(0),
            geometry: g,
            places: vec![],
        });
        let roads: Vec<CrossingRoad> = roads
            .into_iter()
            .enumerate()
            .map(|(i, r)| CrossingRoad {
                id: RoadId(i as u32),
                ..r
            })
            .collect();
        assert_eq!(crossings(&roads), [(RoadId(0), RoadId(1))]);
    }

    #[test]
    fn segments_cross_only_where_they_do() {
        let p = |x, y| DVec2::new(x, y);
        assert!(segments_cross(
            p(0.0, 0.0),
            p(2.0, 2.0),
            p(0.0, 2.0),
            p(2.0, 0.0)
        ));
        assert!(!segments_cross(
            p(0.0, 0.0),
            p(1.0, 1.0),
            p(2.0, 0.0),
            p(3.0, 1.0)
        ));
        // Parallel and on one line: not a crossing.
        assert!(!segments_cross(
            p(0.0, 0.0),
            p(2.0, 0.0),
            p(1.0, 0.0),
            p(3.0, 0.0)
        ));
    }
}

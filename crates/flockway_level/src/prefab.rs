//! Pieces of road network placed whole: what the editor's Roundabout and Crossroads tools drop
//! where they are clicked.

use flockway_road::{ConnectionSpec, Control, ControlPoint, JunctionSpec, RoadSpec};
use glam::DVec3;

/// Roads and the junctions between them, placed together.
#[derive(Debug, Clone, PartialEq)]
pub struct Prefab {
    /// The roads, in the order they join the level.
    pub roads: Vec<RoadSpec>,
    /// The junctions, in the order they join the level.
    pub junctions: Vec<JunctionSpec>,
}

/// Radius of a roundabout's ring, to its lane's centre, m.
pub const RING_RADIUS_M: f64 = 24.0;
/// How far either side of an arm's axis its entry and exit meet the ring, degrees.
const ARM_SPREAD_DEG: f64 = 35.0;
/// Where an arm's roads end at the ring side, m from the centre.
const ARM_NEAR_M: f64 = 38.0;
/// Where they end away from it, m from the centre.
const ARM_FAR_M: f64 = 100.0;
/// How far each of an arm's two roads runs from its axis, m (a lane each way).
const ARM_OFFSET_M: f64 = 1.75;
/// The ring's speed limit, km/h.
const RING_KMH: f64 = 30.0;
/// The arms' speed limit, km/h.
const ARM_KMH: f64 = 50.0;
/// The arms, by the compass, counter-clockwise from the east (the ring's direction).
const ARMS: [(&str, f64); 4] = [
    ("east", 0.0),
    ("north", 90.0),
    ("west", 180.0),
    ("south", 270.0),
];

/// A single-lane, four-arm roundabout centred on `centre`, its names starting with `name`
/// (`NAME east in`, `NAME ring east-north`, junction `NAME east`, …; no prefix when `name` is
/// empty): a ring driven counter-clockwise, each arm a road in and a road out, and at each arm a
/// junction where the entry gives way to the ring (the ring through, the entry merging onto the
/// ring, the exit leaving it) — the layout of `levels/roundabout.ron`. A car without a route
/// leaves at the first exit it comes to.
pub fn roundabout(name: &str, centre: DVec3) -> Prefab {
    let named = |what: String| prefixed(name, &what);
    let mut roads: Vec<RoadSpec> = ARMS
        .iter()
        .flat_map(|&(arm, deg)| arm_roads(name, centre, arm, deg, ARM_NEAR_M))
        .collect();
    for (i, (arm, deg)) in ARMS.iter().enumerate() {
        let (next, _) = ARMS[(i + 1) % ARMS.len()];
        let (from, to) = (
            (deg + ARM_SPREAD_DEG).to_radians(),
            (deg + 90.0 - ARM_SPREAD_DEG).to_radians(),
        );
        let points = (0..=4)
            .map(|k| {
                let a = from + (to - from) * f64::from(k) / 4.0;
                let (s, c) = (libm::sin(a), libm::cos(a));
                flat_point(
                    centre + DVec3::new(c, s, 0.0) * RING_RADIUS_M,
                    Some(DVec3::new(-s, c, 0.0)),
                )
            })
            .collect();
        roads.push(one_lane(
            &named(format!("ring {arm}-{next}")),
            RING_KMH,
            points,
        ));
    }
    let junctions = ARMS
        .iter()
        .enumerate()
        .map(|(i, (arm, _))| {
            let (prev, _) = ARMS[(i + ARMS.len() - 1) % ARMS.len()];
            let (next, _) = ARMS[(i + 1) % ARMS.len()];
            let ring_in = named(format!("ring {prev}-{arm}"));
            let ring_out = named(format!("ring {arm}-{next}"));
            let connect = |from: &str, to: String| ConnectionSpec {
                from: from.to_owned(),
                from_lane: 0,
                to,
                to_lane: 0,
            };
            JunctionSpec {
                name: named((*arm).to_owned()),
                control: Control::Priority {
                    major: vec![ring_in.clone()],
                    stop: false,
                },
                // The exit first: a car without a route takes the first link it finds, so
                // it leaves at the next exit rather than circling for ever.
                connections: vec![
                    connect(&ring_in, named(format!("{arm} out"))),
                    connect(&ring_in, ring_out.clone()),
                    connect(&named(format!("{arm} in")), ring_out),
                ],
                signal: None,
            }
        })
        .collect();
    Prefab { roads, junctions }
}

/// Where a crossroads' roads end, m from its centre.
const CROSSROADS_NEAR_M: f64 = 10.0;
/// The arms of a crossroads, in the order its connections list them.
const CROSSROADS_ARMS: [(&str, f64); 4] = [
    ("west", 180.0),
    ("east", 0.0),
    ("south", 270.0),
    ("north", 90.0),
];

/// A four-arm signalised crossroads centred on `centre` (a lane each way, 50 km/h), named
/// `name` (`crossroads` when empty; its roads `NAME west in`, …): per arm straight on, left and
/// right, under a fixed-time two-phase signal with permitted left turns (35 s green, 3 s amber,
/// 2 s all-red for east–west, then north–south) — the layout of `levels/crossroads_signal.ron`.
/// A car without a route goes straight on.
pub fn crossroads(name: &str, centre: DVec3) -> Prefab {
    let named = |what: &str| prefixed(name, what);
    let roads: Vec<RoadSpec> = CROSSROADS_ARMS
        .iter()
        .flat_map(|&(arm, deg)| arm_roads(name, centre, arm, deg, CROSSROADS_NEAR_M))
        .collect();
    // Each arm's exits by the compass: straight on is the arm opposite (180° round), left the
    // arm 270° round (counter-clockwise), right the one 90° round.
    let arm_at = |deg: f64| {
        CROSSROADS_ARMS
            .iter()
            .find(|(_, d)| (d - deg.rem_euclid(360.0)).abs() < 1e-9)
            .map_or("", |(a, _)| a)
    };
    let mut connections = Vec::new();
    for (arm, deg) in CROSSROADS_ARMS {
        for turn in [180.0, 270.0, 90.0] {
            connections.push(ConnectionSpec {
                from: named(&format!("{arm} in")),
                from_lane: 0,
                to: named(&format!("{} out", arm_at(deg + turn))),
                to_lane: 0,
            });
        }
    }
    let phase = |duration_s: f64, state: &str| flockway_road::Phase {
        duration_s,
        state: state.to_owned(),
    };
    let junction = JunctionSpec {
        name: if name.is_empty() {
            "crossroads".to_owned()
        } else {
            name.to_owned()
        },
        control: Control::Signal,
        connections,
        signal: Some(flockway_road::SignalProgram {
            offset_s: 0.0,
            phases: vec![
                phase(35.0, "GgGGgGrrrrrr"),
                phase(3.0, "yyyyyyrrrrrr"),
                phase(2.0, "rrrrrrrrrrrr"),
                phase(35.0, "rrrrrrGgGGgG"),
                phase(3.0, "rrrrrryyyyyy"),
                phase(2.0, "rrrrrrrrrrrr"),
            ],
        }),
    };
    Prefab {
        roads,
        junctions: vec![junction],
    }
}

/// `what`, after `name` and a space when there is a name.
fn prefixed(name: &str, what: &str) -> String {
    if name.is_empty() {
        what.to_owned()
    } else {
        format!("{name} {what}")
    }
}

/// A control point at `pos` without guardrails (junctions and their arms are open).
fn flat_point(pos: DVec3, tangent: Option<DVec3>) -> ControlPoint {
    ControlPoint {
        guardrail_left: false,
        guardrail_right: false,
        tangent,
        ..ControlPoint::at(pos)
    }
}

/// A one-lane road through `points`.
fn one_lane(name: &str, kmh: f64, points: Vec<ControlPoint>) -> RoadSpec {
    RoadSpec {
        points,
        ..RoadSpec::through(name, 1, kmh, &[DVec3::ZERO, DVec3::X])
    }
}

/// An arm at compass angle `deg` of a junction centred on `centre`: `NAME ARM in` towards the
/// centre (on the right of a car heading there) and `NAME ARM out` away from it, both straight
/// from [`ARM_FAR_M`] to `near_m` from the centre.
fn arm_roads(name: &str, centre: DVec3, arm: &str, deg: f64, near_m: f64) -> [RoadSpec; 2] {
    let a = deg.to_radians();
    let u = DVec3::new(libm::cos(a), libm::sin(a), 0.0);
    let n = DVec3::new(-u.y, u.x, 0.0) * ARM_OFFSET_M;
    let at = |d: f64, side: DVec3| flat_point(centre + u * d + side, None);
    [
        one_lane(
            &prefixed(name, &format!("{arm} in")),
            ARM_KMH,
            vec![at(ARM_FAR_M, n), at(near_m, n)],
        ),
        one_lane(
            &prefixed(name, &format!("{arm} out")),
            ARM_KMH,
            vec![at(near_m, -n), at(ARM_FAR_M, -n)],
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{load_level, validate};
    use flockway_road::RoadNetwork;
    use std::path::Path;

    /// The level has the prefab's roads, the same where they meet the junction (their far ends
    /// may differ: a level's arms are longer).
    fn assert_same_roads_at_the_junction(level: &crate::Level, p: &Prefab, tolerance_m: f64) {
        let near = |r: &RoadSpec| {
            if r.name.ends_with(" in") {
                r.points[r.points.len() - 1].pos
            } else {
                r.points[0].pos
            }
        };
        for road in &p.roads {
            let shipped = level
                .roads
                .iter()
                .find(|r| r.name == road.name)
                .expect("the same roads");
            assert!(
                (near(shipped) - near(road)).length() < tolerance_m,
                "{}",
                road.name
            );
        }
    }

    #[test]
    fn a_roundabout_builds_every_entry_giving_way_by_merging_onto_the_ring() {
        let p = roundabout("r1", DVec3::new(100.0, -50.0, 0.0));
        assert_eq!((p.roads.len(), p.junctions.len()), (12, 4));
        let net = RoadNetwork::build_with(&p.roads, &p.junctions).expect("it builds");
        for j in net.junctions() {
            // The entry (connection 2) merges with the ring through (connection 1) and gives
            // way to it; the exit (0) leaves from the ring's lane, beside the through path.
            let entry = &j.paths[2];
            let merge = entry
                .conflicts
                .iter()
                .find(|c| c.other == 1)
                .expect("the entry meets the ring");
            assert!(merge.merge);
            assert!(j.gives_way(2, 1, None) && !j.gives_way(1, 2, None));
            assert!(j.paths[0].siblings.iter().any(|(o, _)| *o == 1));
        }
        // It sits where it was put.
        let ring = RoadNetwork::build_with(&p.roads, &p.junctions)
            .expect("it builds")
            .id("r1 ring east-north")
            .expect("the ring");
        let g = net.get(ring).expect("geometry");
        let mid = g.pos_at(0.5 * g.length_m());
        let centre = DVec3::new(100.0, -50.0, 0.0);
        assert!(
            ((mid - centre).length() - RING_RADIUS_M).abs() < 0.2,
            "{mid}"
        );
    }

    #[test]
    fn the_shipped_roundabout_level_has_the_prefab_layout() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../levels/roundabout.ron");
        let level = load_level(&path).expect("the shipped level");
        let p = roundabout("", DVec3::ZERO);
        // The same junctions (the level lists each one's connections in another order).
        assert_eq!(level.junctions.len(), p.junctions.len());
        for (shipped, j) in level.junctions.iter().zip(&p.junctions) {
            assert_eq!((&shipped.name, &shipped.control), (&j.name, &j.control));
            let mut a = shipped.connections.clone();
            let mut b = j.connections.clone();
            a.sort_by(|x, y| (&x.from, &x.to).cmp(&(&y.from, &y.to)));
            b.sort_by(|x, y| (&x.from, &x.to).cmp(&(&y.from, &y.to)));
            assert_eq!(a, b, "{}", j.name);
        }
        assert_same_roads_at_the_junction(&level, &p, 0.01);
        let mut level = level;
        level.roads = p.roads;
        level.spawners.clear();
        level.destroyers.clear();
        assert!(validate(&level).is_empty(), "{:?}", validate(&level));
    }

    #[test]
    fn the_shipped_signalised_crossroads_has_the_prefab_layout() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../levels/crossroads_signal.ron");
        let level = load_level(&path).expect("the shipped level");
        let p = crossroads("", DVec3::ZERO);
        assert_eq!(level.junctions, p.junctions);
        assert_same_roads_at_the_junction(&level, &p, 1e-9);
        let q = crossroads("x 1", DVec3::new(-300.0, 40.0, 0.0));
        RoadNetwork::build_with(&q.roads, &q.junctions).expect("it builds anywhere");
        assert_eq!(q.junctions[0].name, "x 1");
    }

    #[test]
    fn a_two_phase_program_serves_the_crossroads_axes_in_turn_with_permitted_lefts() {
        let p = crossroads("x", DVec3::new(12.0, -7.0, 0.0));
        let net = RoadNetwork::build_with(&p.roads, &p.junctions).expect("it builds");
        let made = net.junctions()[0].two_phase_program();
        let shipped = p.junctions[0].signal.as_ref().expect("a signal");
        let states = |q: &flockway_road::SignalProgram| -> Vec<String> {
            q.phases.iter().map(|ph| ph.state.clone()).collect()
        };
        // The same letters as the prefab's hand-made program; 30 s greens instead of 35.
        assert_eq!(states(&made), states(shipped));
        let durations: Vec<f64> = made.phases.iter().map(|ph| ph.duration_s).collect();
        assert_eq!(durations, [30.0, 3.0, 2.0, 30.0, 3.0, 2.0]);
        // Arms on one axis only (a road through, nothing crossing): always green.
        let mut straight = p.junctions[0].clone();
        straight.connections.retain(|c| {
            (c.from.ends_with("west in") && c.to.ends_with("east out"))
                || (c.from.ends_with("east in") && c.to.ends_with("west out"))
        });
        straight.signal = None;
        straight.control = flockway_road::Control::RightBeforeLeft;
        let net = RoadNetwork::build_with(&p.roads, &[straight]).expect("it builds");
        let made = net.junctions()[0].two_phase_program();
        assert_eq!(states(&made), ["GG"]);
    }
}

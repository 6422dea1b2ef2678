//! Joining roads in the editor: a road's end dropped onto another road's start links the two
//! lane by lane; dropped onto another road's side, it becomes an on-ramp whose lanes run on as
//! acceleration lanes beside the road and end into its rightmost lane.
//!
//! Both edits only change the level's specs (points, links, markers, routes), so the level file
//! they give is one a user could have written by hand, and `flockway run` loads it unchanged.

use flockway_level::{DestroyerPlaceSpec, Level};
use flockway_road::{ControlPoint, LinkSpec, RoadFrame, RoadGeometry, RoadSpec};
use glam::DVec3;

/// Length of the acceleration lane a side join builds, metres (where the road allows it).
pub const ACCELERATION_LANE_M: f64 = 250.0;
/// Shortest acceleration lane a side join accepts, metres.
pub const MIN_ACCELERATION_LANE_M: f64 = 60.0;
/// Length of the taper at the end of the acceleration lane with no guardrail, metres: a car
/// that could not merge stops at the lane's end, not against the rail's end.
const TAPER_M: f64 = 60.0;
/// Closest a side join may come to the road's start, metres.
const MIN_UPSTREAM_M: f64 = 10.0;
/// Control points closer than this to a cut are left out (the cut point replaces them), metres.
const NEAR_CUT_M: f64 = 2.0;

/// Why a join cannot be made; its text is the status line's.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum JoinError {
    /// A road's points do not make a road.
    #[error("road `{road}` cannot be built: {reason}")]
    Unbuilt {
        /// The road.
        road: String,
        /// Why, from the road's geometry.
        reason: String,
    },
    /// No road has this name.
    #[error("there is no road named `{0}`")]
    NoRoadNamed(String),
    /// No road has this index.
    #[error("there is no road {0}")]
    NoRoad(usize),
    /// A road's end dropped onto its own start.
    #[error("a road cannot lead onto itself: close it into a loop instead")]
    OntoItself,
    /// A road's start dropped onto its own side.
    #[error("a road cannot leave itself")]
    LeavesItself,
    /// A loop has neither end nor start.
    #[error("a loop has no end or start to join: open it first")]
    Loop,
    /// The two roads are linked already.
    #[error("`{from}` already leads onto `{to}`{}", if *.on_end { ": its lanes are in the inspector" } else { "" })]
    Linked {
        /// The road that leads on.
        from: String,
        /// The road it leads onto.
        to: String,
        /// Whether an end was joined (the inspector shows its lanes).
        on_end: bool,
    },
    /// An on-ramp placed where no acceleration lane fits.
    #[error(
        "`{onto}` is {length_m:.0} m long: a road joins its side between {MIN_UPSTREAM_M:.0} m \
         from its start and {:.0} m before its end (room for an acceleration lane)",
        MIN_ACCELERATION_LANE_M + TAPER_M + 20.0
    )]
    NoRoomToMerge {
        /// The road joined.
        onto: String,
        /// Its length, metres.
        length_m: f64,
    },
    /// An exit placed too near the road's ends.
    #[error(
        "`{onto}` is {length_m:.0} m long: a road leaves its side at least {MIN_UPSTREAM_M:.0} m \
         from either end"
    )]
    NoRoomToLeave {
        /// The road left.
        onto: String,
        /// Its length, metres.
        length_m: f64,
    },
    /// A road with no points (it has no end or start).
    #[error("a road with no points has no end or start")]
    NoPoints,
}

fn geometry(spec: &RoadSpec) -> Result<RoadGeometry, JoinError> {
    RoadGeometry::new(spec).map_err(|e| JoinError::Unbuilt {
        road: spec.name.clone(),
        reason: e.to_string(),
    })
}

fn index_of(level: &Level, name: &str) -> Result<usize, JoinError> {
    level
        .roads
        .iter()
        .position(|r| r.name == name)
        .ok_or_else(|| JoinError::NoRoadNamed(name.to_owned()))
}

/// Checks that `road` may lead onto `onto`: two different open roads, not linked yet.
fn check_pair(level: &Level, road: usize, onto: &str) -> Result<(), JoinError> {
    let from = level.roads.get(road).ok_or(JoinError::NoRoad(road))?;
    let to = &level.roads[index_of(level, onto)?];
    if from.name == to.name {
        return Err(JoinError::OntoItself);
    }
    if from.closed || to.closed {
        return Err(JoinError::Loop);
    }
    if from.outgoing().iter().any(|l| l.to == to.name) {
        return Err(JoinError::Linked {
            from: from.name.clone(),
            to: to.name.clone(),
            on_end: true,
        });
    }
    Ok(())
}

/// A control point at a cut, `lateral_m` left of the centre line: heading as the road heads,
/// with its bank, and `extra_m` wider where `template` sets the width.
fn cut_point(
    frame: &RoadFrame,
    template: &ControlPoint,
    lateral_m: f64,
    extra_m: f64,
) -> ControlPoint {
    ControlPoint {
        pos: round_mm(frame.offset(lateral_m)),
        width_m: template.width_m.map(|w| w + extra_m),
        bank_deg: round_mm_f(frame.bank_rad.to_degrees()),
        tangent: Some(round_unit(frame.tangent)),
        ..template.clone()
    }
}

fn round_mm_f(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
}

fn round_mm(p: DVec3) -> DVec3 {
    DVec3::new(round_mm_f(p.x), round_mm_f(p.y), round_mm_f(p.z))
}

fn round_unit(t: DVec3) -> DVec3 {
    let r = DVec3::new(
        (t.x * 1e6).round() / 1e6,
        (t.y * 1e6).round() / 1e6,
        (t.z * 1e6).round() / 1e6,
    );
    if r.length() > 0.0 { r } else { t }
}

/// Links `road`'s end onto `onto`'s start, lanes by position from the right: the end point
/// moves onto the start, so the rightmost lanes line up, and heads the way `onto` starts.
pub fn join_end(level: &mut Level, road: usize, onto: &str) -> Result<(), JoinError> {
    check_pair(level, road, onto)?;
    let to = &level.roads[index_of(level, onto)?];
    let start = geometry(to)?.frame_at(0.0);
    let from = &level.roads[road];
    let (width, own_w) = (
        to.width_at_point(0),
        from.lane_width_m * f64::from(from.lanes),
    );
    // Right edges together: lane i continues on lane i.
    let lateral = -0.5 * width + 0.5 * own_w.min(width);
    let to_lanes = to.lanes;
    let spec = &mut level.roads[road];
    let last = spec.points.last_mut().ok_or(JoinError::NoPoints)?;
    last.pos = round_mm(start.offset(lateral));
    last.tangent = Some(round_unit(start.tangent));
    let link = if lateral.abs() < 1e-9 {
        LinkSpec::to(onto)
    } else {
        // Centre lines apart: lane by lane, lane i onto lane i; lanes beyond the other road's
        // lane count end there (the lanes beside them take their traffic).
        LinkSpec {
            to: onto.to_owned(),
            lanes: (0..spec.lanes.min(to_lanes)).map(|i| (i, i)).collect(),
        }
    };
    if spec.next.is_none() && spec.links.is_empty() && link.lanes.is_empty() {
        spec.next = Some(onto.to_owned());
    } else {
        spec.links.push(link);
    }
    spec.closed = false;
    Ok(())
}

/// A piece of road `spec` (geometry `g`) between arc positions `a` and `b`, its centre line
/// moved `shift_m` to the left and `extra_m` wider where the original sets its width.
fn piece(
    spec: &RoadSpec,
    g: &RoadGeometry,
    (a, b): (f64, f64),
    shift_m: f64,
    extra_m: f64,
) -> Vec<ControlPoint> {
    let template = |s: f64| {
        // The properties of the point that starts the segment holding `s`.
        let i = (0..spec.points.len())
            .rev()
            .find(|&i| g.point_s(i).is_some_and(|p| p <= s + 1e-9))
            .unwrap_or(0);
        spec.points[i].clone()
    };
    let mut points = vec![cut_point(&g.frame_at(a), &template(a), shift_m, extra_m)];
    for (i, p) in spec.points.iter().enumerate() {
        let Some(s) = g.point_s(i) else { continue };
        if s > a + NEAR_CUT_M && s < b - NEAR_CUT_M {
            let f = g.frame_at(s);
            points.push(ControlPoint {
                pos: round_mm(f.offset(shift_m)),
                width_m: p.width_m.map(|w| w + extra_m),
                ..p.clone()
            });
        }
    }
    points.push(cut_point(&g.frame_at(b), &template(b), shift_m, extra_m));
    points
}

/// A road name from `base` that neither the level nor `taken` has yet.
fn unique_name(level: &Level, base: &str, taken: &[&str]) -> String {
    let free = |n: &str| level.road(n).is_none() && !taken.contains(&n);
    if free(base) {
        return base.to_owned();
    }
    (2..)
        .map(|n| format!("{base} {n}"))
        .find(|n| free(n))
        .unwrap_or_default()
}

/// Joins `road`'s end onto the side of `onto` at arc position `s_m`, as an on-ramp: `onto` is cut
/// there into itself (up to the join), a merge stretch where `road`'s lanes run on as
/// acceleration lanes on the right for [`ACCELERATION_LANE_M`] (less where the road is shorter)
/// and end, and the rest of `onto`. Markers beyond the cut move onto the piece they stand on;
/// routes through `onto` go through the new pieces. Returns the two new roads' names.
pub fn join_side(
    level: &mut Level,
    road: usize,
    onto: &str,
    s_m: f64,
) -> Result<(String, String), JoinError> {
    check_pair(level, road, onto)?;
    let m = index_of(level, onto)?;
    let main = level.roads[m].clone();
    let g = geometry(&main)?;
    let len = g.length_m();
    let accel = ACCELERATION_LANE_M.min(len - s_m - TAPER_M - 20.0);
    if !s_m.is_finite() || s_m < MIN_UPSTREAM_M || accel < MIN_ACCELERATION_LANE_M {
        return Err(JoinError::NoRoomToMerge {
            onto: onto.to_owned(),
            length_m: len,
        });
    }
    let (cut1, cut2) = (round_mm_f(s_m), round_mm_f(s_m + accel));
    let ramp_lanes = level.roads[road].lanes;
    let lane_w = main.lane_width_m;
    let added_m = f64::from(ramp_lanes) * lane_w;
    let merge_name = unique_name(level, &format!("{onto} merge"), &[]);
    let rest_name = unique_name(level, &format!("{onto} on"), &[&merge_name]);

    // The three pieces.
    let mut up = main.clone();
    up.points = piece(&main, &g, (0.0, cut1), 0.0, 0.0);
    up.next = None;
    up.links = vec![LinkSpec {
        to: merge_name.clone(),
        lanes: (0..main.lanes).map(|i| (i, i + ramp_lanes)).collect(),
    }];
    let mut merge = main.clone();
    merge.name = merge_name.clone();
    merge.lanes = main.lanes + ramp_lanes;
    merge.points = piece(&main, &g, (cut1, cut2), -0.5 * added_m, added_m);
    for p in &mut merge.points {
        p.guardrail_right = true;
    }
    merge.next = None;
    merge.links = vec![LinkSpec {
        to: rest_name.clone(),
        lanes: (0..main.lanes).map(|i| (i + ramp_lanes, i)).collect(),
    }];
    let mut rest = main.clone();
    rest.name = rest_name.clone();
    let taper_end = (cut2 + TAPER_M).min(len - 1.0);
    rest.points = piece(&main, &g, (cut2, len), 0.0, 0.0);
    // The taper: no rail on the right until the acceleration lane's width has gone.
    if taper_end < len - NEAR_CUT_M {
        let f = g.frame_at(taper_end);
        let at = rest
            .points
            .iter()
            .position(|p| g.project(p.pos).s_m > taper_end)
            .unwrap_or(rest.points.len() - 1);
        if (g.project(rest.points[at - 1].pos).s_m - taper_end).abs() > NEAR_CUT_M {
            let mut p = rest.points[at - 1].clone();
            p.pos = round_mm(f.pos);
            p.tangent = None;
            rest.points.insert(at, p);
        }
    }
    rest.points[0].guardrail_right = false;

    // The ramp's end on the acceleration lanes' start, heading along the road.
    let start = g.frame_at(cut1);
    let ramp = &mut level.roads[road];
    let ramp_centre = -0.5 * start.width_m - 0.5 * added_m;
    let last = ramp.points.last_mut().ok_or(JoinError::NoPoints)?;
    last.pos = round_mm(start.offset(ramp_centre));
    last.tangent = Some(round_unit(start.tangent));
    last.guardrail_left = false;
    ramp.links.push(LinkSpec {
        to: merge_name.clone(),
        lanes: (0..ramp_lanes).map(|i| (i, i)).collect(),
    });
    // Beside the road just before the join, the two roads' rails would stand in each other's way.
    let n = ramp.points.len();
    if n >= 2 {
        ramp.points[n - 2].guardrail_left = false;
    }
    if let Some(p) = up.points.iter_mut().rev().nth(1) {
        p.guardrail_right = false;
    }

    // What lay beyond the cut follows its piece; routes go through the pieces.
    let pieces = [
        (onto.to_owned(), 0.0, 0),
        (merge_name.clone(), cut1, ramp_lanes),
        (rest_name.clone(), cut2, 0),
    ];
    follow_pieces(level, onto, len, &pieces);
    // (Nothing above reorders the roads: `onto` is still at `m`.)
    level.roads[m] = up;
    level.roads.insert(m + 1, merge);
    level.roads.insert(m + 2, rest);
    Ok((merge_name, rest_name))
}

/// Moves what stood on road `onto` (of length `len`) onto the pieces it was cut into — each
/// `(name, start on the old road, lanes added on its right)`, in order — and makes routes
/// through it go through every piece (a spawner moved onto a later piece starts its routes
/// there; a destination becomes the last piece).
fn follow_pieces(level: &mut Level, onto: &str, len: f64, pieces: &[(String, f64, u32)]) {
    let place = |s: f64| -> (String, f64, u32, f64) {
        let k = pieces.iter().rposition(|p| s >= p.1).unwrap_or(0);
        let end = pieces.get(k + 1).map_or(len, |p| p.1);
        let (name, start, lanes) = &pieces[k];
        (name.clone(), s - start, *lanes, end - start)
    };
    for s in level.spawners.iter_mut().filter(|s| s.road == onto) {
        let (r, at, lanes, _) = place(s.s_m);
        (s.road, s.s_m, s.lane) = (r, round_mm_f(at), s.lane + lanes);
    }
    for d in &mut level.destroyers {
        if let DestroyerPlaceSpec::OnRoad { road: r, s_m } = &mut d.place
            && r == onto
        {
            let (to, at, _, _) = place(*s_m);
            (*r, *s_m) = (to, round_mm_f(at));
        }
    }
    for t in level.triggers.iter_mut().filter(|t| t.road == onto) {
        let (r, from, lanes, piece_len) = place(t.from_m);
        let shift = t.from_m - from;
        t.to_m = round_mm_f((t.to_m - shift).min(piece_len));
        (t.road, t.from_m) = (r, round_mm_f(from));
        if let Some(ls) = &mut t.lanes {
            ls.iter_mut().for_each(|l| *l += lanes);
        }
    }
    for v in level.vehicles.iter_mut().filter(|v| v.road == onto) {
        let (r, from, lanes, piece_len) = place(v.from_m);
        let shift = v.from_m - from;
        v.to_m = Some(round_mm_f((v.to_m.unwrap_or(len) - shift).min(piece_len)));
        (v.road, v.from_m, v.lane) = (r, round_mm_f(from), v.lane + lanes);
    }
    let later: Vec<String> = pieces.iter().skip(1).map(|p| p.0.clone()).collect();
    for s in &mut level.spawners {
        for route in &mut s.routes {
            if let Some(k) = route.roads.iter().position(|r| r == onto) {
                route.roads.splice(k + 1..k + 1, later.iter().cloned());
            }
            // A spawner moved onto a later piece starts its routes there.
            if let Some(k) = route.roads.iter().position(|r| *r == s.road) {
                route.roads.drain(..k);
            }
        }
        if s.destination.as_deref() == Some(onto) {
            s.destination = later.last().cloned();
        }
    }
}

/// Joins `road`'s start onto the side of `onto` at arc position `s_m`, as an exit: `onto` is cut
/// there into itself and the rest (`NAME on`), and its rightmost lanes lead both straight on and
/// onto `road`, whose start moves to the cut (right edges together, heading along the road).
/// Markers beyond the cut move onto the rest; routes through `onto` go on through it. Returns
/// the rest's name.
pub fn join_exit(
    level: &mut Level,
    road: usize,
    onto: &str,
    s_m: f64,
) -> Result<String, JoinError> {
    let exit = level
        .roads
        .get(road)
        .ok_or(JoinError::NoRoad(road))?
        .clone();
    let m = index_of(level, onto)?;
    let main = level.roads[m].clone();
    if exit.name == main.name {
        return Err(JoinError::LeavesItself);
    }
    if exit.closed || main.closed {
        return Err(JoinError::Loop);
    }
    if main.outgoing().iter().any(|l| l.to == exit.name) {
        return Err(JoinError::Linked {
            from: onto.to_owned(),
            to: exit.name.clone(),
            on_end: false,
        });
    }
    let g = geometry(&main)?;
    let len = g.length_m();
    if !s_m.is_finite() || s_m < MIN_UPSTREAM_M || s_m > len - MIN_UPSTREAM_M {
        return Err(JoinError::NoRoomToLeave {
            onto: onto.to_owned(),
            length_m: len,
        });
    }
    let cut = round_mm_f(s_m);
    let rest_name = unique_name(level, &format!("{onto} on"), &[]);
    let mut up = main.clone();
    up.points = piece(&main, &g, (0.0, cut), 0.0, 0.0);
    up.next = None;
    let shared = exit.lanes.min(main.lanes);
    up.links = vec![
        LinkSpec::to(&rest_name),
        LinkSpec {
            to: exit.name.clone(),
            lanes: (0..shared).map(|i| (i, i)).collect(),
        },
    ];
    let mut rest = main.clone();
    rest.name = rest_name.clone();
    rest.points = piece(&main, &g, (cut, len), 0.0, 0.0);
    // The exit's start on the cut, its right edge on the road's, heading along the road.
    let f = g.frame_at(cut);
    let exit_w = exit.lane_width_m * f64::from(exit.lanes);
    let first = level.roads[road]
        .points
        .first_mut()
        .ok_or(JoinError::NoPoints)?;
    first.pos = round_mm(f.offset(-0.5 * f.width_m + 0.5 * exit_w));
    first.tangent = Some(round_unit(f.tangent));
    first.guardrail_left = false;
    let pieces = [(onto.to_owned(), 0.0, 0), (rest_name.clone(), cut, 0)];
    follow_pieces(level, onto, len, &pieces);
    level.roads[m] = up;
    level.roads.insert(m + 1, rest);
    Ok(rest_name)
}

#[cfg(test)]
mod tests {
    use super::*;
    use flockway_level::{
        RouteSpec, SpawnerSpec, level_to_string, mixed_shares, parse_level, reference_profiles,
        reference_vehicle_types, validate, warnings,
    };
    use flockway_road::RoadNetwork;
    use std::path::Path;

    fn level_with(roads: Vec<RoadSpec>) -> Level {
        let mut level = Level::new(1, 60.0);
        level.roads = roads;
        level.vehicle_types = reference_vehicle_types();
        level.driver_profiles = reference_profiles();
        level
    }

    fn straight(name: &str, lanes: u32, a: DVec3, b: DVec3) -> RoadSpec {
        RoadSpec::through(name, lanes, 100.0, &[a, 0.5 * (a + b), b])
    }

    #[test]
    fn an_end_dropped_on_a_start_links_lanes_and_lines_them_up() {
        let mut level = level_with(vec![
            straight("a", 2, DVec3::ZERO, DVec3::new(200.0, 3.0, 0.0)),
            straight(
                "b",
                3,
                DVec3::new(210.0, 0.0, 0.0),
                DVec3::new(400.0, 0.0, 0.0),
            ),
        ]);
        join_end(&mut level, 0, "b").expect("joins");
        let a = &level.roads[0];
        assert_eq!(
            a.links,
            [LinkSpec {
                to: "b".to_owned(),
                lanes: vec![(0, 0), (1, 1)]
            }]
        );
        // Right edges together: a (two 3 m lanes) centred 1.5 m right of b's (three) centre.
        let end = a.points.last().expect("points").pos;
        assert!(
            (end - DVec3::new(210.0, -1.5, 0.0)).length() < 1e-3,
            "{end}"
        );
        let net = RoadNetwork::build(&level.roads).expect("a network");
        let (ia, ib) = (net.id("a").expect("a"), net.id("b").expect("b"));
        assert_eq!(net.lane_next(ia, 1, None), Some((ib, 1)));
        // Lane 1 of `a` ends where lane 1 of `b` starts.
        let (ga, gb) = (net.get(ia).expect("a"), net.get(ib).expect("b"));
        let gap = ga.lane_point(1, ga.length_m()) - gb.lane_point(1, 0.0);
        assert!(gap.length() < 1e-3, "{gap}");
        assert!(
            matches!(join_end(&mut level, 0, "b"), Err(JoinError::Linked { .. })),
            "linked twice"
        );
        assert_eq!(join_end(&mut level, 0, "a"), Err(JoinError::OntoItself));
        // A second link makes a split.
        level.roads.push(straight(
            "c",
            1,
            DVec3::new(210.0, -30.0, 0.0),
            DVec3::new(300.0, -90.0, 0.0),
        ));
        join_end(&mut level, 0, "c").expect("a split");
        assert_eq!(level.roads[0].outgoing().len(), 2);
    }

    #[test]
    fn an_end_dropped_on_a_side_builds_an_on_ramp_that_loads_and_routes() {
        let mut level = level_with(vec![
            straight("main", 2, DVec3::ZERO, DVec3::new(1000.0, 0.0, 0.0)),
            straight(
                "ramp",
                1,
                DVec3::new(200.0, -80.0, 0.0),
                DVec3::new(380.0, -10.0, 0.0),
            ),
        ]);
        level.roads[0].points[1].width_m = None;
        let every = flockway_level::Range { min: 2.0, max: 3.0 };
        level.spawners.push(SpawnerSpec {
            routes: vec![RouteSpec {
                name: "through".to_owned(),
                roads: vec!["main".to_owned()],
                weight: 1.0,
            }],
            ..SpawnerSpec::new("late", "main", 1, 500.0, every, mixed_shares(&level))
        });
        level.destroyers.push(flockway_level::DestroyerSpec {
            name: "end".to_owned(),
            place: DestroyerPlaceSpec::OnRoad {
                road: "main".to_owned(),
                s_m: 950.0,
            },
            arrivals_only: false,
        });
        let (merge, rest) = join_side(&mut level, 1, "main", 400.0).expect("joins");
        assert_eq!((merge.as_str(), rest.as_str()), ("main merge", "main on"));
        let net = RoadNetwork::build(&level.roads).expect("a network");
        let id = |n: &str| net.id(n).expect(n);
        let (main, ramp, m, r) = (id("main"), id("ramp"), id(&merge), id(&rest));
        assert!((net.get(main).expect("main").length_m() - 400.0).abs() < 0.5);
        assert!((net.get(m).expect("merge").length_m() - ACCELERATION_LANE_M).abs() < 0.5);
        assert_eq!(net.get(m).expect("merge").lanes(), 3);
        // The motorway's lanes run straight through; the ramp's lane becomes lane 0 and ends.
        assert_eq!(net.lane_next(main, 0, None), Some((m, 1)));
        assert_eq!(net.lane_next(ramp, 0, None), Some((m, 0)));
        assert_eq!(net.lane_next(m, 2, None), Some((r, 1)));
        assert_eq!(net.lane_next(m, 0, None), None);
        for (from, lane, to, to_lane) in [(main, 0, m, 1), (ramp, 0, m, 0), (m, 1, r, 0)] {
            let (a, b) = (net.get(from).expect("from"), net.get(to).expect("to"));
            let gap = a.lane_point(lane, a.length_m()) - b.lane_point(to_lane, 0.0);
            assert!(
                gap.length() < 0.01,
                "{from:?}/{lane} → {to:?}/{to_lane}: {gap}"
            );
        }
        // Markers and routes beyond the cut follow.
        assert_eq!(level.spawners[0].road, merge);
        assert_eq!(level.spawners[0].lane, 2);
        assert!((level.spawners[0].s_m - 100.0).abs() < 1e-6);
        assert_eq!(
            level.spawners[0].routes[0].roads,
            [merge.clone(), rest.clone()]
        );
        match &level.destroyers[0].place {
            DestroyerPlaceSpec::OnRoad { road, s_m } => {
                assert_eq!(road, &rest);
                assert!((s_m - 300.0).abs() < 1e-6);
            }
            other => panic!("{other:?}"),
        }
        // The level is one `flockway run` takes, and reads back the same.
        let issues: Vec<String> = validate(&level)
            .into_iter()
            .chain(warnings(&level))
            .map(|i| i.describe(&level))
            .collect();
        // The ramp's start leads from nothing, which is fine; nothing else may be wrong.
        assert!(issues.is_empty(), "{issues:?}");
        let text = level_to_string(&level).expect("writes");
        assert_eq!(
            parse_level(&text, Path::new("joined.ron")).expect("reads"),
            level
        );
    }

    #[test]
    fn a_start_dropped_on_a_side_builds_an_exit_that_routes() {
        let mut level = level_with(vec![
            straight("main", 3, DVec3::ZERO, DVec3::new(800.0, 0.0, 0.0)),
            straight(
                "exit",
                1,
                DVec3::new(420.0, -20.0, 0.0),
                DVec3::new(600.0, -120.0, 0.0),
            ),
        ]);
        level.destroyers.push(flockway_level::DestroyerSpec {
            name: "end".to_owned(),
            place: DestroyerPlaceSpec::OnRoad {
                road: "main".to_owned(),
                s_m: 700.0,
            },
            arrivals_only: false,
        });
        let rest = join_exit(&mut level, 1, "main", 400.0).expect("joins");
        assert_eq!(rest, "main on");
        let net = RoadNetwork::build(&level.roads).expect("a network");
        let id = |n: &str| net.id(n).expect(n);
        let (main, exit, r) = (id("main"), id("exit"), id(&rest));
        // Lane 0 goes on or leaves; the others go on.
        assert_eq!(net.lane_next(main, 0, Some(exit)), Some((exit, 0)));
        assert_eq!(net.lane_next(main, 0, Some(r)), Some((r, 0)));
        assert_eq!(net.lane_next(main, 2, Some(exit)), Some((r, 2)));
        let (a, b) = (net.get(main).expect("main"), net.get(exit).expect("exit"));
        let gap = a.lane_point(0, a.length_m()) - b.lane_point(0, 0.0);
        assert!(gap.length() < 0.01, "{gap}");
        assert_eq!(net.shortest_path(main, exit), Some(vec![main, exit]));
        match &level.destroyers[0].place {
            DestroyerPlaceSpec::OnRoad { road, s_m } => {
                assert_eq!(road, &rest);
                assert!((s_m - 300.0).abs() < 1e-6);
            }
            other => panic!("{other:?}"),
        }
        assert!(join_exit(&mut level, 1, "main", 100.0).is_err(), "twice");
    }

    #[test]
    fn a_side_join_too_near_an_end_is_refused_with_the_room_it_needs() {
        let mut level = level_with(vec![
            straight("main", 2, DVec3::ZERO, DVec3::new(300.0, 0.0, 0.0)),
            straight(
                "ramp",
                1,
                DVec3::new(0.0, -50.0, 0.0),
                DVec3::new(200.0, -10.0, 0.0),
            ),
        ]);
        let before = level.clone();
        let e = join_side(&mut level, 1, "main", 250.0).expect_err("no room");
        assert!(matches!(e, JoinError::NoRoomToMerge { .. }), "{e:?}");
        assert!(e.to_string().contains("before its end"), "{e}");
        assert_eq!(level, before);
        assert!(join_side(&mut level, 1, "main", 5.0).is_err());
        assert!(join_side(&mut level, 1, "ramp", 50.0).is_err());
    }
}

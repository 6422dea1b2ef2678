//! The level made from the network Flockway drives: a road per edge, links where lanes continue
//! one another, a junction per node with its right of way and signal program, and traffic where
//! the network is open.

use super::net::{At, Connection, Edge, Junction, Net, Program, signal_letter};
use super::network::{Fringe, main_road};
use super::{ImportError, LaneMaps};
use crate::expect::Expectation;
use crate::schema::{
    DestroyerPlaceSpec, DestroyerSpec, Level, ProfileShare, Range, RouteSpec, SpawnerSpec,
};
use crate::template::{AUTONOMOUS_PROFILE, reference_profiles, reference_vehicle_types};
use flockway_road::{ConnectionSpec, Control, JunctionSpec, LinkSpec, RoadSpec, SignalProgram};
use glam::DVec3;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Two lanes a connection joins whose ends are closer than this, m, continue one another (a
/// simple join, a lane added or dropped along a road): the roads are linked, not a junction.
const JOIN_GAP_M: f64 = 1.0;
/// The largest turn, rad, from one lane into the next at a join that is still linked (10°):
/// a link turns at a point, and a car cannot, so at a sharper kink it ran wide into the lane
/// beside (the oncoming one, on a street of two one-way edges); joined at a junction instead,
/// the two lanes are met by a curved path and their ends pulled back for it as at any turn.
const MAX_LINK_KINK_RAD: f64 = 10.0 * std::f64::consts::PI / 180.0;
/// The least length, m, of both lanes of a kinked join for it to become a junction's path: each
/// road gives up to [`MAX_TRIM_M`] of an end to the path, keeping [`KEEP_SHARE`] of itself.
const MIN_KINKED_ROAD_M: f64 = 10.0;
/// The radius, m, of the bend a kinked join's path is given room for (up to [`MAX_TRIM_M`] of
/// each road).
const KINK_RADIUS_M: f64 = 20.0;
/// The least each road's end is pulled back for a kinked join, m: even scaled down to keep
/// [`KEEP_SHARE`] of a road, the path's two ends stay further apart than a junction allows.
const MIN_KINK_TRIM_M: f64 = 1.5;
/// Seconds between vehicles a spawner of an imported network draws from, per lane.
const SPAWN_INTERVAL_S: Range = Range {
    min: 8.0,
    max: 12.0,
};
/// How far along its edge a spawner stands, m (half way along an edge shorter than twice this).
const SPAWN_AT_M: f64 = 5.0;
/// The time gap the imported level's autonomous cars keep, s (city traffic, queues at lights).
const AUTONOMOUS_TIME_GAP_S: f64 = 1.8;
/// How far before the end of an exit edge its destroyer stands, m.
const DESTROYER_BEFORE_END_M: f64 = 10.0;
/// Simulated time an imported level runs for, s.
const DURATION_S: f64 = 600.0;

/// The level named `name` for the network `net` as read from `path`, with the connections among
/// its car lanes `connections` (after the network is made drivable); validated, an invalid one
/// being an error at the element it came from.
pub(super) fn level(
    net: &Net,
    connections: &[Connection],
    path: &Path,
    name: &str,
    demand: bool,
) -> Result<(Level, LaneMaps), ImportError> {
    let mut level = Level::new(1, DURATION_S);
    level.name = name.to_owned();
    level.description = format!("Imported from the SUMO network {}.", super::file_name(path));
    level.vehicle_types = reference_vehicle_types();
    level.driver_profiles = reference_profiles();
    // The autonomous cars, keeping a time gap (the human-like profile is there to assign; its
    // reaction delay makes rear-end contacts in queues at lights).
    for p in &mut level.driver_profiles {
        if p.model == crate::DriverModel::FlockLanes {
            p.set.insert("time_gap_s".to_owned(), AUTONOMOUS_TIME_GAP_S);
        }
    }
    level.roads = net.edges.iter().map(road_of).collect();

    let by_id: BTreeMap<&str, &Edge> = net.edges.iter().map(|e| (e.id.as_str(), e)).collect();
    let (links, at_node) = links_and_junctions(&by_id, connections);
    trim_for_turns(&mut level.roads, &at_node, &links, &by_id);
    for ((from, to), lanes) in links {
        if let Some(road) = level.roads.iter_mut().find(|r| r.name == from) {
            road.links.push(LinkSpec { to, lanes });
        }
    }
    for (node, conns) in at_node {
        level
            .junctions
            .push(junction(node, conns, &by_id, net, path)?);
    }

    let fringe = Fringe::of(&net.edges, connections);
    // A demand's vehicles leave on their own routes, in place of the fringe's spawners.
    if fringe.sources.is_empty() && !demand {
        return Err(net.at.error(
            path,
            "the network has no entry: every edge is reached from another, so no traffic can \
             come in; give it fringe edges (netgenerate `--grid.attach-length 100` or \
             `--spider.attach-length 100`, or a road that starts at a dead end), or SUMO demand \
             whose vehicles leave on their own routes"
                .to_owned(),
        ));
    }
    lengthen_short_sources(&mut level, &fringe);
    add_traffic(&mut level, &fringe);
    level.telemetry.stats_from_s = 60.0;
    level.expect = ["collisions == 0", "vehicles_spawned > 0"]
        .iter()
        .filter_map(|t| Expectation::parse(t).ok())
        .collect();
    if let Some(issue) = crate::validate(&level).first() {
        let at = issue_at(issue, &level, net).unwrap_or(net.at);
        return Err(at.error(
            path,
            format!(
                "the network does not make a valid level: {}: {}",
                issue.subject(&level),
                issue.message
            ),
        ));
    }
    // Every edge is a road of the same name.
    let lane_maps = net
        .edges
        .iter()
        .map(|e| (e.id.clone(), e.lane_map.clone()))
        .collect();
    Ok((level, lane_maps))
}

/// Lane pairs to link per (from, to) edge pair, and the connections of each junction by the
/// node they cross: a connection whose lanes continue one another (within [`JOIN_GAP_M`]) is a
/// link, the rest are grouped by the node their edge ends at.
#[allow(clippy::type_complexity)]
fn links_and_junctions<'c>(
    by_id: &BTreeMap<&str, &Edge>,
    connections: &'c [Connection],
) -> (
    BTreeMap<(String, String), Vec<(u32, u32)>>,
    BTreeMap<String, Vec<&'c Connection>>,
) {
    let mut links: BTreeMap<(String, String), Vec<(u32, u32)>> = BTreeMap::new();
    let mut at_node: BTreeMap<String, Vec<&Connection>> = BTreeMap::new();
    let mut kinked = Vec::new();
    for conn in connections {
        let (from, to) = (by_id[conn.from.as_str()], by_id[conn.to.as_str()]);
        let (before, after) = (
            &from.lanes[conn.from_lane as usize].shape,
            &to.lanes[conn.to_lane as usize].shape,
        );
        let joined = matches!((before.last(), after.first()), (Some(a), Some(b))
            if a.distance(*b) < JOIN_GAP_M);
        // Joined lanes are linked even under a traffic light (a light where a road simply goes
        // on, for a crossing the importer leaves out): a link has no signal, so that light is
        // left out for them.
        if joined
            && kink_rad(before, after) > MAX_LINK_KINK_RAD
            && polyline_length(before) >= MIN_KINKED_ROAD_M
            && polyline_length(after) >= MIN_KINKED_ROAD_M
        {
            kinked.push(conn);
        } else if joined {
            links
                .entry((conn.from.clone(), conn.to.clone()))
                .or_default()
                .push((conn.from_lane, conn.to_lane));
        } else {
            at_node.entry(from.to.clone()).or_default().push(conn);
        }
    }
    // A kinked join becomes a junction's path only where its roads' ends can be pulled back for
    // it: not where either end also goes on by a link. A kinked join kept a link links its roads
    // in turn, so this is repeated until no more are kept.
    loop {
        let linked_from: BTreeSet<&str> = links.keys().map(|(f, _)| f.as_str()).collect();
        let linked_to: BTreeSet<&str> = links.keys().map(|(_, t)| t.as_str()).collect();
        let (kept, rest): (Vec<&Connection>, Vec<&Connection>) =
            kinked.into_iter().partition(|c| {
                linked_from.contains(c.from.as_str()) || linked_to.contains(c.to.as_str())
            });
        kinked = rest;
        if kept.is_empty() {
            break;
        }
        for conn in kept {
            links
                .entry((conn.from.clone(), conn.to.clone()))
                .or_default()
                .push((conn.from_lane, conn.to_lane));
        }
    }
    for conn in kinked {
        let node = by_id[conn.from.as_str()].to.clone();
        at_node.entry(node).or_default().push(conn);
    }
    (links, at_node)
}

/// The turn, rad, between the last stretch of the lane shape `before` and the first of `after`
/// (0 where either has no length).
fn kink_rad(before: &[DVec3], after: &[DVec3]) -> f64 {
    let (Some(a), Some(b)) = (
        direction_from_first(before.iter().rev()),
        direction_from_first(after.iter()),
    ) else {
        return 0.0;
    };
    // `a` points back along `before`: the kink is the angle off straight on.
    (-a).angle_between(b)
}

/// The direction, in the plane, from the first of `points` to the next that is apart from it.
fn direction_from_first<'p>(mut points: impl Iterator<Item = &'p DVec3>) -> Option<DVec3> {
    let first = points.next()?.truncate();
    points
        .map(|p| p.truncate() - first)
        .find(|d| d.length() > 1.0e-3)
        .map(|d| d.extend(0.0))
}

/// The junction at the node `node` with the connections `conns` across it: its control from the
/// SUMO junction's type, at a traffic light its program with a letter per connection.
fn junction(
    node: String,
    mut conns: Vec<&Connection>,
    by_id: &BTreeMap<&str, &Edge>,
    net: &Net,
    path: &Path,
) -> Result<JunctionSpec, ImportError> {
    let kind = net
        .junctions
        .get(&node)
        .map_or("priority", |j| j.kind.as_str());
    let signal = conns.iter().find_map(|c| c.tl.clone());
    // At a traffic light, the connections in link-index order (the phases' letters).
    if signal.is_some() {
        conns.sort_by_key(|c| c.link_index.unwrap_or(usize::MAX));
    }
    let incoming: BTreeSet<&str> = conns.iter().map(|c| c.from.as_str()).collect();
    let top = incoming
        .iter()
        .filter_map(|e| by_id.get(e).map(|e| e.priority))
        .max()
        .unwrap_or(0);
    let tied: Vec<&Edge> = incoming
        .iter()
        .filter_map(|e| by_id.get(e).copied())
        .filter(|e| e.priority == top)
        .collect();
    let major = main_road(&tied);
    let (control, program) = match (kind, &signal) {
        (k, Some(tl)) if k.starts_with("traffic_light") => {
            let program = net.programs.get(tl).ok_or_else(|| {
                conns[0].at.error(
                    path,
                    format!("connection under traffic light `{tl}`, which has no <tlLogic>"),
                )
            })?;
            (
                Control::Signal,
                Some(signal_program(tl, program, &conns, path)?),
            )
        }
        ("right_before_left" | "left_before_right", _) => (Control::RightBeforeLeft, None),
        ("allway_stop", _) => (Control::AllWayStop, None),
        ("priority_stop", _) => (Control::Priority { major, stop: true }, None),
        _ => (Control::Priority { major, stop: false }, None),
    };
    Ok(JunctionSpec {
        name: node,
        control,
        connections: conns
            .iter()
            .map(|c| ConnectionSpec {
                from: c.from.clone(),
                from_lane: c.from_lane,
                to: c.to.clone(),
                to_lane: c.to_lane,
            })
            .collect(),
        signal: program,
    })
}

/// The traffic light `tl`'s program for a junction whose connections are `conns` (in
/// link-index order): each phase's state a letter per connection, read at its link index.
fn signal_program(
    tl: &str,
    sumo: &Program,
    conns: &[&Connection],
    path: &Path,
) -> Result<SignalProgram, ImportError> {
    let mut program = sumo.program.clone();
    for (phase, states) in program.phases.iter_mut().zip(&sumo.states) {
        let letters: Vec<char> = states.chars().collect();
        let mut state = String::with_capacity(conns.len());
        for c in conns {
            // A connection the light does not control (no `tl`, as older networks write for a
            // slip road at a signalised node): always green, giving way unless SUMO made it a
            // major link (`state="M"`).
            if c.tl.is_none() {
                state.push(if c.major { 'G' } else { 'g' });
                continue;
            }
            let k = c.link_index.ok_or_else(|| {
                c.at.error(
                    path,
                    "a connection under a traffic light needs a `linkIndex`".to_owned(),
                )
            })?;
            let letter = letters.get(k).copied().ok_or_else(|| {
                sumo.at.error(
                    path,
                    format!(
                        "a phase of `{tl}` has {} letters, but a connection has link index {k}",
                        letters.len()
                    ),
                )
            })?;
            state.push(signal_letter(letter).unwrap_or('r'));
        }
        phase.state = state;
    }
    Ok(program)
}

/// The shortest a road that traffic enters the network by is made, m: a car created on it
/// stands before the line at its end with room to stop there. A map's street cut a few metres
/// (or, between two nodes netconvert left apart, centimetres) before a junction would otherwise
/// have its cars created with their fronts in the junction.
const SOURCE_MIN_M: f64 = 12.0;

/// Lengthens each source road shorter than [`SOURCE_MIN_M`] backwards, along its first
/// stretch's direction, where the added stretch keeps clear of every other road's surface (no
/// car comes onto a source from anywhere, so its start can move back).
fn lengthen_short_sources(level: &mut Level, fringe: &Fringe) {
    let half_width = |r: &RoadSpec| 0.5 * f64::from(r.lanes) * r.lane_width_m;
    for e in &fringe.sources {
        let roads = &level.roads;
        let Some(i) = roads.iter().position(|r| r.name == e.id) else {
            continue;
        };
        // The roads it leads onto meet its end, not the stretch added at its start.
        let onto: BTreeSet<&str> = roads[i]
            .links
            .iter()
            .map(|l| l.to.as_str())
            .chain(
                level
                    .junctions
                    .iter()
                    .flat_map(|j| &j.connections)
                    .filter(|c| c.from == e.id)
                    .map(|c| c.to.as_str()),
            )
            .collect();
        let length = road_length_m(&roads[i]);
        let (p0, p1) = (roads[i].points[0].pos, roads[i].points[1].pos);
        let dir = (p1 - p0).normalize_or_zero();
        if length >= SOURCE_MIN_M || dir == DVec3::ZERO {
            continue;
        }
        let start = p0 - dir * (SOURCE_MIN_M - length);
        let (a0, a1) = (start.truncate(), p0.truncate());
        let half = half_width(&roads[i]);
        let clear = roads.iter().enumerate().all(|(j, r)| {
            j == i
                || onto.contains(r.name.as_str())
                || r.points.windows(2).all(|w| {
                    flockway_road::segments_apart_m(
                        a0,
                        a1,
                        w[0].pos.truncate(),
                        w[1].pos.truncate(),
                    ) >= half + half_width(r) - 0.1
                })
        });
        if clear {
            let road = &mut level.roads[i];
            let first = road.points[0].clone();
            road.points.insert(
                0,
                flockway_road::ControlPoint {
                    pos: start,
                    tangent: None,
                    ..first
                },
            );
        }
    }
}

/// Traffic where the network is open: a spawner on every lane of each source, its vehicles
/// routed to every sink it reaches (the fewest edges there), and a destroyer near the end of
/// each sink.
fn add_traffic(level: &mut Level, fringe: &Fringe) {
    let shares = vec![ProfileShare {
        profile: AUTONOMOUS_PROFILE.to_owned(),
        weight: 1.0,
    }];
    for e in &fringe.sources {
        let routes: Vec<RouteSpec> = fringe
            .routes_from(&e.id)
            .into_iter()
            .map(|roads| RouteSpec {
                name: roads.last().cloned().unwrap_or_default(),
                roads,
                weight: 1.0,
            })
            .collect();
        for lane in 0..e.lanes.len() as u32 {
            let name = if e.lanes.len() > 1 {
                format!("{} lane {lane}", e.id)
            } else {
                e.id.clone()
            };
            // Along the road as lengthened, where it was.
            let length = level
                .roads
                .iter()
                .find(|r| r.name == e.id)
                .map(road_length_m)
                .unwrap_or_else(|| polyline_length(&e.lanes[lane as usize].shape));
            let s_m = SPAWN_AT_M.min(0.5 * length);
            level.spawners.push(SpawnerSpec {
                routes: routes.clone(),
                ..SpawnerSpec::new(&name, &e.id, lane, s_m, SPAWN_INTERVAL_S, shares.clone())
            });
        }
    }
    for sink in &fringe.sinks {
        let length = polyline_length(&sink.lanes[0].shape);
        level.destroyers.push(DestroyerSpec {
            name: sink.id.clone(),
            place: DestroyerPlaceSpec::OnRoad {
                road: sink.id.clone(),
                s_m: (length - DESTROYER_BEFORE_END_M).max(0.5 * length),
            },
            arrivals_only: false,
        });
    }
}

/// The place in the file a validation issue comes from, where it can be told: the edge of a
/// road, the junction element of a junction.
fn issue_at(issue: &crate::Issue, level: &Level, net: &Net) -> Option<At> {
    use crate::PathStep;
    match issue.path.as_slice() {
        [PathStep::Field("roads"), PathStep::Index(i), ..] => {
            let name = &level.roads.get(*i)?.name;
            net.edges.iter().find(|e| &e.id == name).map(|e| e.at)
        }
        [PathStep::Field("junctions"), PathStep::Index(i), ..] => net
            .junctions
            .get(&level.junctions.get(*i)?.name)
            .map(|j: &Junction| j.at),
        _ => None,
    }
}

/// The length of a polyline, m.
pub(super) fn polyline_length(points: &[DVec3]) -> f64 {
    points.windows(2).map(|w| w[0].distance(w[1])).sum()
}

/// The length of a road's polyline through its points, m.
fn road_length_m(road: &RoadSpec) -> f64 {
    road.points
        .windows(2)
        .map(|w| w[0].pos.distance(w[1].pos))
        .sum()
}

/// A road for an edge: its centre line midway between its outer lanes (SUMO gives each lane's
/// centre line), its speed limit the fastest lane's.
fn road_of(e: &Edge) -> RoadSpec {
    let n = e.lanes.len();
    let (right, left) = (&e.lanes[0].shape, &e.lanes[n - 1].shape);
    let centre: Vec<DVec3> = if right.len() == left.len() {
        right.iter().zip(left).map(|(a, b)| 0.5 * (a + b)).collect()
    } else {
        // Lanes drawn with different points: the right lane's line, moved to the centre.
        let half = 0.5 * (n as f64 - 1.0) * e.lanes[0].width_m;
        offset_left(right, half)
    };
    let centre = dedup(centre);
    let speed = e.lanes.iter().map(|l| l.speed_mps).fold(0.0, f64::max);
    let mut road = RoadSpec::through(&e.id, n as u32, speed * 3.6, &centre);
    road.lane_width_m = e.lanes.iter().map(|l| l.width_m).sum::<f64>() / n as f64;
    for p in &mut road.points {
        p.guardrail_left = false;
        p.guardrail_right = false;
    }
    road
}

/// The radius a turn across a junction needs, m: a sedan at full lock turns its centre on
/// 4.1 m, and a driver's steering turns into a bend about a metre late.
const TURN_RADIUS_M: f64 = 5.0;
/// The most a road's end (or start) is pulled back for a turn, m, and the least of it left.
const MAX_TRIM_M: f64 = 4.0;
/// The least pull-back worth making, m (a turn a little tighter than [`TURN_RADIUS_M`] is still
/// well within full lock).
const MIN_TRIM_M: f64 = 0.5;
/// The least length a road keeps when its ends are pulled back, as a share of its length.
const KEEP_SHARE: f64 = 0.6;

/// Pulls the ends of the roads back from a junction where one of its turns is tighter than a
/// car can drive: netconvert ends lanes at the junction's edge, and at a small junction (one-lane
/// streets meeting at a corner) a right turn from one lane end to the other is a bend of
/// 1.5–2.5 m radius. A car can only drive that wide, into the oncoming lanes. With the road
/// before the turn ending earlier and the one after it starting later, the turn across the
/// junction gets room for a [`TURN_RADIUS_M`] arc (pulled back [`MAX_TRIM_M`] at most, and
/// never below [`KEEP_SHARE`] of a road's length). Ends where a road simply goes on (a link)
/// stay.
fn trim_for_turns(
    roads: &mut [RoadSpec],
    at_node: &BTreeMap<String, Vec<&Connection>>,
    links: &BTreeMap<(String, String), Vec<(u32, u32)>>,
    by_id: &BTreeMap<&str, &Edge>,
) {
    // The pull-back each road's end and start needs, m.
    let mut end: BTreeMap<&str, f64> = BTreeMap::new();
    let mut start: BTreeMap<&str, f64> = BTreeMap::new();
    let flat = |v: DVec3| DVec3::new(v.x, v.y, 0.0);
    let cross = |a: DVec3, b: DVec3| a.x * b.y - a.y * b.x;
    for c in at_node.values().flatten().filter(|c| !c.turn_back) {
        let (Some(from), Some(to)) = (by_id.get(c.from.as_str()), by_id.get(c.to.as_str())) else {
            continue;
        };
        let (a, b) = (
            &from.lanes[c.from_lane as usize].shape,
            &to.lanes[c.to_lane as usize].shape,
        );
        let (Some(&p0), Some(&p1)) = (a.last(), b.first()) else {
            continue;
        };
        if a.len() < 2 || b.len() < 2 {
            continue;
        }
        let t0 = flat(p0 - a[a.len() - 2]).normalize_or_zero();
        let t1 = flat(b[1] - p1).normalize_or_zero();
        let turn = libm::atan2(cross(t0, t1), t0.dot(t1)).abs();
        if p0.distance(p1) < JOIN_GAP_M {
            // A kinked join: both ends pulled back for a gentle bend.
            let need = (KINK_RADIUS_M * libm::tan(0.5 * turn)).clamp(MIN_KINK_TRIM_M, MAX_TRIM_M);
            let e = end.entry(c.from.as_str()).or_default();
            *e = e.max(need);
            let e = start.entry(c.to.as_str()).or_default();
            *e = e.max(need);
            continue;
        }
        // Nearly straight on, or turning back: no bend to make room for.
        if !(0.5..=2.6).contains(&turn) {
            continue;
        }
        // The corner where the lane lines meet: `a` along the lane before, `b` to the lane
        // after.
        let d = flat(p1 - p0);
        let along_in = cross(d, t1) / cross(t0, t1);
        let along_out = cross(t0, d) / cross(t0, t1);
        if along_in < 0.0 || along_out < 0.0 {
            continue;
        }
        let need = TURN_RADIUS_M * libm::tan(0.5 * turn);
        if need - along_in > MIN_TRIM_M {
            let e = end.entry(c.from.as_str()).or_default();
            *e = e.max(need - along_in);
        }
        if need - along_out > MIN_TRIM_M {
            let e = start.entry(c.to.as_str()).or_default();
            *e = e.max(need - along_out);
        }
    }
    let linked_from: BTreeSet<&str> = links.keys().map(|(f, _)| f.as_str()).collect();
    let linked_to: BTreeSet<&str> = links.keys().map(|(_, t)| t.as_str()).collect();
    for road in roads.iter_mut() {
        let name = road.name.as_str();
        let mut cut_end = if linked_from.contains(name) {
            0.0
        } else {
            end.get(name).copied().unwrap_or(0.0)
        };
        let mut cut_start = if linked_to.contains(name) {
            0.0
        } else {
            start.get(name).copied().unwrap_or(0.0)
        };
        if cut_end <= 0.0 && cut_start <= 0.0 {
            continue;
        }
        let points: Vec<DVec3> = road.points.iter().map(|p| p.pos).collect();
        let length: f64 = points.windows(2).map(|w| w[0].distance(w[1])).sum();
        cut_end = cut_end.min(MAX_TRIM_M);
        cut_start = cut_start.min(MAX_TRIM_M);
        let most = (1.0 - KEEP_SHARE) * length;
        if cut_end + cut_start > most {
            let scale = most / (cut_end + cut_start);
            cut_end *= scale;
            cut_start *= scale;
        }
        let kept = cut_polyline(&points, cut_start, length - cut_end);
        if kept.len() < 2 {
            continue;
        }
        let template = road.points[0].clone();
        road.points = kept
            .into_iter()
            .map(|pos| flockway_road::ControlPoint {
                pos,
                ..template.clone()
            })
            .collect();
    }
}

/// The part of polyline `points` from `from_m` to `to_m` along it, its points closer than
/// 10 cm to a cut dropped.
fn cut_polyline(points: &[DVec3], from_m: f64, to_m: f64) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(points.len());
    let mut at = 0.0;
    for w in points.windows(2) {
        let len = w[0].distance(w[1]);
        let (a, b) = (at, at + len);
        let point = |s: f64| w[0] + (w[1] - w[0]) * ((s - a) / len.max(1e-9));
        if out.is_empty() && from_m < b {
            out.push(point(from_m.max(a)));
        }
        if !out.is_empty() {
            if to_m <= b {
                out.push(point(to_m));
                break;
            }
            out.push(w[1]);
        }
        at = b;
    }
    dedup(out)
}

/// A polyline moved `d` metres to its left.
fn offset_left(points: &[DVec3], d: f64) -> Vec<DVec3> {
    (0..points.len())
        .map(|i| {
            let a = points[i.saturating_sub(1)];
            let b = points[(i + 1).min(points.len() - 1)];
            let t = (b - a).truncate().normalize_or_zero();
            points[i] + d * DVec3::new(-t.y, t.x, 0.0)
        })
        .collect()
}

/// Points closer than 10 cm to the one before dropped (a spline needs distinct points).
fn dedup(points: Vec<DVec3>) -> Vec<DVec3> {
    let mut out: Vec<DVec3> = Vec::with_capacity(points.len());
    for p in points {
        if out.last().is_none_or(|q| q.distance(p) > 0.1) {
            out.push(p);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::{net, network};
    use super::*;

    /// The level for the network of `body` inside a `<net>` element.
    fn import(body: &str) -> Result<Level, ImportError> {
        let path = Path::new("t.net.xml");
        let mut net = net::read(&format!("<net>\n{body}\n</net>\n"), path)?;
        let mut conns = network::car_connections(&net, path)?;
        network::close_simple_nodes(&mut net.edges, &mut conns);
        level(&net, &conns, path, "t", false).map(|(level, _)| level)
    }

    /// An edge `id` from node `a` to node `b` with `lanes` lanes, 3.2 m apart, from `p` to `q`.
    fn edge(id: &str, a: &str, b: &str, lanes: u32, p: (f64, f64), q: (f64, f64)) -> String {
        let (dx, dy) = (q.0 - p.0, q.1 - p.1);
        let len = dx.hypot(dy);
        // Lane k lies 3.2 k m to the left of lane 0.
        let (lx, ly) = (-dy / len * 3.2, dx / len * 3.2);
        let lanes: String = (0..lanes)
            .map(|k| {
                let (ox, oy) = (lx * f64::from(k), ly * f64::from(k));
                format!(
                    r#"<lane index="{k}" speed="13.89" shape="{},{} {},{}"/>"#,
                    p.0 + ox,
                    p.1 + oy,
                    q.0 + ox,
                    q.1 + oy
                )
            })
            .collect();
        format!(r#"<edge id="{id}" from="{a}" to="{b}" priority="1">{lanes}</edge>"#)
    }

    /// A tee: `w` → `e` straight on and `w` → `s` turning right, under traffic light `J` when
    /// `tl`, link indices 1 and 0.
    fn tee(kind: &str, tl: bool) -> String {
        let tl = |k: u32| {
            if tl {
                format!(r#" tl="J" linkIndex="{k}""#)
            } else {
                String::new()
            }
        };
        [
            edge("w", "W", "J", 1, (0.0, -1.6), (93.0, -1.6)),
            edge("e", "J", "E", 1, (107.0, -1.6), (200.0, -1.6)),
            edge("s", "J", "S", 1, (101.6, -7.0), (101.6, -100.0)),
            format!(r#"<junction id="J" type="{kind}" x="100" y="0"/>"#),
            r#"<tlLogic id="J" type="static" offset="0"><phase duration="30" state="rG"/><phase duration="3" state="ry"/><phase duration="20" state="Gr"/></tlLogic>"#.to_owned(),
            format!(r#"<connection from="w" to="e" fromLane="0" toLane="0" dir="s"{}/>"#, tl(1)),
            format!(r#"<connection from="w" to="s" fromLane="0" toLane="0" dir="r"{}/>"#, tl(0)),
        ]
        .join("\n")
    }

    #[test]
    fn roads_end_back_from_a_corner_whose_right_turn_is_tighter_than_a_car_can_turn() {
        // One-lane streets at a corner as netgenerate draws them: lanes end 3.2 m from the
        // corner, so the right turn from `a` into `b` is a 1.6 m bend; `a` also goes straight
        // on into `c`.
        let body = [
            edge("a", "A", "J", 1, (100.0, 1.6), (3.2, 1.6)),
            edge("b", "J", "B", 1, (1.6, 3.2), (1.6, 100.0)),
            edge("c", "J", "C", 1, (-3.2, 1.6), (-100.0, 1.6)),
            r#"<junction id="J" type="priority" x="0" y="0"/>"#.to_owned(),
            r#"<connection from="a" to="b" fromLane="0" toLane="0" dir="r"/>"#.to_owned(),
            r#"<connection from="a" to="c" fromLane="0" toLane="0" dir="s"/>"#.to_owned(),
        ]
        .join("\n");
        let level = import(&body).expect("imports");
        let road = |name: &str| level.road(name).expect("the road");
        // Room for a 5 m arc: each side pulled back 5 − 1.6 = 3.4 m; the straight on's road
        // stays where it was.
        let end = road("a").points.last().expect("points").pos;
        assert!((end.x - 6.6).abs() < 1e-9, "{end}");
        let start = road("b").points[0].pos;
        assert!((start.y - 6.6).abs() < 1e-9, "{start}");
        assert_eq!(road("c").points[0].pos.x, -3.2);
        // The turn is a bend a sedan can drive (its centre turns on 4.1 m at full lock).
        let network = flockway_road::RoadNetwork::build_with(&level.roads, &level.junctions)
            .expect("a network");
        let k = level.junctions[0]
            .connections
            .iter()
            .position(|c| c.to == "b")
            .expect("the turn");
        let turn = network
            .get(network.path_road(0, k).expect("a path"))
            .expect("its road");
        let tightest = (0..=100)
            .map(|i| {
                turn.curvature_at(turn.length_m() * f64::from(i) / 100.0)
                    .abs()
            })
            .fold(0.0, f64::max);
        assert!(tightest < 1.0 / 4.1, "{tightest}");
    }

    #[test]
    fn a_junction_keeps_its_right_of_way_and_signal_letters_in_link_index_order() {
        let signal = import(&tee("traffic_light", true)).expect("imports");
        let j = &signal.junctions[0];
        assert_eq!(j.name, "J");
        assert_eq!(j.control, Control::Signal);
        // Link index 0 (w → s) first: each phase's letters read in that order.
        let order: Vec<&str> = j.connections.iter().map(|c| c.to.as_str()).collect();
        assert_eq!(order, ["s", "e"]);
        let states: Vec<&str> = j
            .signal
            .as_ref()
            .expect("a program")
            .phases
            .iter()
            .map(|p| p.state.as_str())
            .collect();
        assert_eq!(states, ["rG", "ry", "Gr"]);
        for (kind, control) in [
            ("right_before_left", Control::RightBeforeLeft),
            ("allway_stop", Control::AllWayStop),
            (
                "priority_stop",
                Control::Priority {
                    major: vec!["w".to_owned()],
                    stop: true,
                },
            ),
            (
                "priority",
                Control::Priority {
                    major: vec!["w".to_owned()],
                    stop: false,
                },
            ),
        ] {
            let level = import(&tee(kind, false)).expect("imports");
            assert_eq!(level.junctions[0].control, control, "{kind}");
            assert!(level.junctions[0].signal.is_none());
        }
    }

    #[test]
    fn a_link_the_light_does_not_control_is_always_green() {
        // An older network's slip road at a signalised node: no `tl`, no `linkIndex`.
        let mut body = tee("traffic_light", true);
        body = body.replace(
            r#"dir="r" tl="J" linkIndex="0"/>"#,
            r#"dir="r" state="M"/>"#,
        );
        body = body.replace(
            r#"dir="s" tl="J" linkIndex="1""#,
            r#"dir="s" tl="J" linkIndex="0""#,
        );
        body = body.replace(r#"state="rG""#, r#"state="G""#);
        body = body.replace(r#"state="ry""#, r#"state="y""#);
        body = body.replace(r#"state="Gr""#, r#"state="r""#);
        let level = import(&body).expect("imports");
        let states: Vec<&str> = level.junctions[0]
            .signal
            .as_ref()
            .expect("a program")
            .phases
            .iter()
            .map(|p| p.state.as_str())
            .collect();
        // w → e at link index 0 reads the program; w → s, uncontrolled and major, is green.
        let order: Vec<&str> = level.junctions[0]
            .connections
            .iter()
            .map(|c| c.to.as_str())
            .collect();
        assert_eq!(order, ["e", "s"]);
        assert_eq!(states, ["GG", "yG", "rG"]);
        let minor = import(&body.replace(r#"state="M""#, r#"state="m""#)).expect("imports");
        let first = &minor.junctions[0]
            .signal
            .as_ref()
            .expect("a program")
            .phases[0];
        assert_eq!(first.state, "Gg");
    }

    #[test]
    fn a_short_entry_edge_is_lengthened_back_so_that_its_cars_start_before_its_end() {
        let level = import(
            &[
                edge("a", "A", "J", 1, (0.0, 0.0), (3.0, 0.0)),
                edge("b", "J", "B", 1, (3.0, 0.0), (100.0, 0.0)),
                r#"<connection from="a" to="b" fromLane="0" toLane="0" dir="s"/>"#.to_owned(),
            ]
            .join("\n"),
        )
        .expect("imports");
        let a = level.road("a").expect("the road");
        assert_eq!(a.points[0].pos, DVec3::new(3.0 - SOURCE_MIN_M, 0.0, 0.0));
        assert_eq!(
            a.points.last().map(|p| p.pos),
            Some(DVec3::new(3.0, 0.0, 0.0))
        );
        assert_eq!(level.spawners[0].s_m, SPAWN_AT_M);
    }

    #[test]
    fn a_short_entry_edge_stays_as_it_is_where_lengthened_it_would_cross_another_road() {
        // `c` runs north-south 5 m behind `a`'s start: `a` stays 3 m long, its spawner half
        // way along it.
        let level = import(
            &[
                edge("a", "A", "J", 1, (0.0, 0.0), (3.0, 0.0)),
                edge("b", "J", "B", 1, (3.0, 0.0), (100.0, 0.0)),
                edge("c", "C", "D", 1, (-5.0, -50.0), (-5.0, 50.0)),
                r#"<connection from="a" to="b" fromLane="0" toLane="0" dir="s"/>"#.to_owned(),
            ]
            .join("\n"),
        )
        .expect("imports");
        let a = level.road("a").expect("the road");
        assert_eq!(a.points.len(), 2);
        let spawner = level
            .spawners
            .iter()
            .find(|s| s.road == "a")
            .expect("a spawner");
        assert_eq!(spawner.s_m, 1.5);
    }

    #[test]
    fn a_join_that_turns_sharply_is_a_bend_across_a_junction_and_a_straight_one_a_link() {
        // A one-way road `a` whose lane goes on into `b` turning 21.8° at a point (as where two
        // one-way edges become a street's two directions); beside it, `c` goes on straight
        // into `d` (a node is only left as it is with more than one way through it).
        let body = [
            edge("a", "A", "J", 1, (0.0, -40.0), (100.0, 0.0)),
            edge("b", "J", "B", 1, (100.0, 0.0), (200.0, 0.0)),
            edge("c", "C", "J", 1, (200.0, 3.2), (100.0, 3.2)),
            edge("d", "J", "D", 1, (100.0, 3.2), (0.0, 3.2)),
            r#"<junction id="J" type="priority" x="100" y="1.6"/>"#.to_owned(),
            r#"<connection from="a" to="b" fromLane="0" toLane="0" dir="s"/>"#.to_owned(),
            r#"<connection from="c" to="d" fromLane="0" toLane="0" dir="s"/>"#.to_owned(),
        ]
        .join("\n");
        let level = import(&body).expect("imports");
        let road = |name: &str| level.road(name).expect("the road");
        assert_eq!(road("c").links[0].to, "d");
        assert!(road("a").links.is_empty());
        let j = &level.junctions[0];
        assert_eq!(j.connections.len(), 1);
        assert_eq!(
            (j.connections[0].from.as_str(), j.connections[0].to.as_str()),
            ("a", "b")
        );
        // Each end pulled back for a 20 m bend: 20 tan(10.9°) = 3.85 m.
        let (a_end, b_start) = (
            road("a").points.last().expect("a point").pos,
            road("b").points[0].pos,
        );
        assert!(
            (a_end.distance(DVec3::new(100.0, 0.0, 0.0)) - 3.85).abs() < 0.01,
            "{a_end}"
        );
        assert!((b_start.x - 103.85).abs() < 0.01, "{b_start}");
        assert_eq!(road("c").points.last().expect("a point").pos.x, 100.0);
    }

    #[test]
    fn a_kinked_join_stays_a_link_when_its_road_goes_on_by_a_link_made_of_another_kinked_one() {
        // Both lanes of `a` go on turning 21.8°, lane 0 into `b` and lane 1 into `c`; `d` goes
        // straight on into `c`, so `a` into `c` stays a link, `a`'s end cannot be pulled back,
        // and `a` into `b` must stay a link too (as a junction's path its lanes would meet).
        let body = [
            edge("a", "A", "J", 2, (0.0, -40.0), (100.0, 0.0)),
            edge("b", "J", "B", 1, (100.0, 0.0), (200.0, 0.0)),
            edge("c", "J", "C", 1, (98.81, 2.97), (200.0, 2.97)),
            edge("d", "D", "J", 1, (0.0, 2.97), (98.81, 2.97)),
            r#"<junction id="J" type="priority" x="100" y="1.5"/>"#.to_owned(),
            r#"<connection from="a" to="b" fromLane="0" toLane="0" dir="s"/>"#.to_owned(),
            r#"<connection from="a" to="c" fromLane="1" toLane="0" dir="s"/>"#.to_owned(),
            r#"<connection from="d" to="c" fromLane="0" toLane="0" dir="s"/>"#.to_owned(),
        ]
        .join("\n");
        let level = import(&body).expect("imports");
        let road = |name: &str| level.road(name).expect("the road");
        let mut linked: Vec<&str> = road("a").links.iter().map(|l| l.to.as_str()).collect();
        linked.sort_unstable();
        assert_eq!(linked, ["b", "c"]);
        assert!(
            level.junctions.iter().all(|j| j.connections.is_empty()),
            "{:?}",
            level.junctions
        );
    }

    #[test]
    fn a_signal_connection_that_the_program_does_not_reach_is_an_error() {
        let short = tee("traffic_light", true).replace("state=\"rG\"", "state=\"r\"");
        let e = import(&short).expect_err("a phase too short");
        assert!(
            e.message
                .contains("has 1 letters, but a connection has link index 1"),
            "{}",
            e.message
        );
        let unknown = tee("traffic_light", true).replace("tlLogic id=\"J\"", "tlLogic id=\"K\"");
        let e = import(&unknown).expect_err("no program");
        assert!(
            e.message.contains("which has no <tlLogic>"),
            "{}",
            e.message
        );
    }

    #[test]
    fn roads_that_go_on_are_linked_and_open_ends_get_spawners_and_destroyers() {
        // Two lanes going on as two across a node with no gap: a link, no junction.
        let level = import(
            &[
                edge("a", "A", "J", 2, (0.0, 0.0), (100.0, 0.0)),
                edge("b", "J", "B", 2, (100.0, 0.0), (200.0, 0.0)),
                r#"<connection from="a" to="b" fromLane="0" toLane="0" dir="s"/>"#.to_owned(),
                r#"<connection from="a" to="b" fromLane="1" toLane="1" dir="s"/>"#.to_owned(),
            ]
            .join("\n"),
        )
        .expect("imports");
        assert!(level.junctions.is_empty());
        assert_eq!(level.roads[0].links[0].to, "b");
        assert_eq!(level.roads[0].links[0].lanes, [(0, 0), (1, 1)]);
        let spawners: Vec<(&str, u32)> = level
            .spawners
            .iter()
            .map(|s| (s.name.as_str(), s.lane))
            .collect();
        assert_eq!(spawners, [("a lane 0", 0), ("a lane 1", 1)]);
        assert_eq!(level.spawners[0].routes[0].roads, ["a", "b"]);
        assert_eq!(level.destroyers.len(), 1);
        assert_eq!(level.destroyers[0].name, "b");
        assert_eq!(
            level.destroyers[0].place,
            DestroyerPlaceSpec::OnRoad {
                road: "b".to_owned(),
                s_m: 90.0
            }
        );
        let expected: Vec<String> = level.expect.iter().map(|e| e.to_string()).collect();
        assert_eq!(expected, ["collisions == 0", "vehicles_spawned > 0"]);
    }

    #[test]
    fn a_network_with_no_way_in_is_an_error_that_says_so() {
        let e = import(
            &[
                edge("a", "A", "B", 1, (0.0, 0.0), (100.0, 0.0)),
                edge("b", "B", "C", 1, (100.0, 0.0), (50.0, 80.0)),
                edge("c", "C", "A", 1, (50.0, 80.0), (0.0, 0.0)),
                r#"<connection from="a" to="b" fromLane="0" toLane="0" dir="l"/>"#.to_owned(),
                r#"<connection from="b" to="c" fromLane="0" toLane="0" dir="l"/>"#.to_owned(),
                r#"<connection from="c" to="a" fromLane="0" toLane="0" dir="l"/>"#.to_owned(),
            ]
            .join("\n"),
        )
        .expect_err("a closed loop");
        assert_eq!((e.line, e.column), (1, 1));
        assert!(
            e.message.contains("the network has no entry"),
            "{}",
            e.message
        );
    }

    #[test]
    fn an_invalid_level_is_an_error_at_the_edge_it_came_from() {
        // A lane 40 m wide is more than a road may have.
        let wide = edge("a", "A", "B", 1, (0.0, 0.0), (100.0, 0.0))
            .replace("speed=\"13.89\"", "speed=\"13.89\" width=\"40\"");
        let e = import(&format!("<junction id=\"A\" type=\"dead_end\"/>\n{wide}"))
            .expect_err("too wide");
        assert_eq!((e.line, e.column), (3, 1), "{}", e.message);
        assert!(
            e.message
                .contains("the network does not make a valid level: road `a`"),
            "{}",
            e.message
        );
    }
}

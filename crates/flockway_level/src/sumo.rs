//! SUMO networks in: a `.net.xml` (as `netconvert` writes it, from OpenStreetMap, OpenDRIVE or
//! plain node and edge files) becomes a level that runs.
//!
//! - Every edge that is not internal becomes a road of the same name, its lanes (SUMO's lane 0 is
//!   the rightmost, as ours), width, speed limit and centre line taken from its lanes' shapes.
//! - Every junction with connections becomes a junction of the same name: its connections (in
//!   SUMO's link-index order at a traffic light, so each phase's state reads letter for letter),
//!   its right of way (`traffic_light` → `Signal` with the `tlLogic` program, `priority` and
//!   `priority_stop` → `Priority` with the incoming edges of the highest priority as major,
//!   `right_before_left` → `RightBeforeLeft`, `allway_stop` → `AllWayStop`).
//! - Where the network is open, traffic comes and goes: a spawner on every lane of each edge
//!   nothing leads onto, its vehicles routed to every edge that leads nowhere (the shortest way
//!   there), and a destroyer near the end of each of those.

use crate::expect::Expectation;
use crate::schema::{
    DestroyerPlaceSpec, DestroyerSpec, Level, ProfileShare, Range, RouteSpec, SpawnerSpec,
};
use crate::template::{AUTONOMOUS_PROFILE, reference_profiles, reference_vehicle_types};
use flockway_road::{ConnectionSpec, Control, JunctionSpec, Phase, RoadSpec, SignalProgram};
use glam::DVec3;
use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::path::{Path, PathBuf};

/// Why a SUMO network could not be imported: where in the file, and what was expected.
#[derive(Debug, thiserror::Error)]
#[error("{}:{line}:{column}: {message}", path.display())]
pub struct ImportError {
    /// The network file.
    pub path: PathBuf,
    /// Line, from 1.
    pub line: u32,
    /// Column, from 1.
    pub column: u32,
    /// What is wrong, and what was expected.
    pub message: String,
}

/// SUMO's lane width where a lane does not give one, m.
const SUMO_LANE_WIDTH_M: f64 = 3.2;
/// Seconds between vehicles a spawner of an imported network draws from, per lane.
const SPAWN_INTERVAL_S: Range = Range {
    min: 8.0,
    max: 12.0,
};
/// The time gap the imported level's autonomous cars keep, s (city traffic, queues at lights).
const AUTONOMOUS_TIME_GAP_S: f64 = 1.8;
/// How far before the end of an exit edge its destroyer stands, m.
const DESTROYER_BEFORE_END_M: f64 = 10.0;
/// Simulated time an imported level runs for, s.
const DURATION_S: f64 = 600.0;

/// One edge as read.
struct Edge {
    id: String,
    to: String,
    priority: i64,
    lanes: Vec<Lane>,
}

/// One lane as read.
struct Lane {
    speed_mps: f64,
    width_m: f64,
    shape: Vec<DVec3>,
}

/// One connection between two edges' lanes as read.
struct Connection {
    from: String,
    to: String,
    from_lane: u32,
    to_lane: u32,
    link_index: Option<usize>,
    tl: Option<String>,
}

/// Reads a SUMO network file into a level named `name`.
pub fn import_sumo_net(text: &str, path: &Path, name: &str) -> Result<Level, ImportError> {
    let options = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    let doc = roxmltree::Document::parse_with_options(text, options).map_err(|e| {
        let pos = e.pos();
        ImportError {
            path: path.to_owned(),
            line: pos.row,
            column: pos.col,
            message: format!("not a well-formed XML file: {e}"),
        }
    })?;
    let at = |node: roxmltree::Node, message: String| {
        let pos = doc.text_pos_at(node.range().start);
        ImportError {
            path: path.to_owned(),
            line: pos.row,
            column: pos.col,
            message,
        }
    };
    let root = doc.root_element();
    if root.tag_name().name() != "net" {
        return Err(at(
            root,
            format!(
                "expected a SUMO network (a <net> root element, as netconvert writes), found <{}>",
                root.tag_name().name()
            ),
        ));
    }
    let attr = |node: roxmltree::Node, key: &str| -> Result<String, ImportError> {
        node.attribute(key).map(str::to_owned).ok_or_else(|| {
            at(
                node,
                format!("<{}> needs a `{key}` attribute", node.tag_name().name()),
            )
        })
    };
    let number = |node: roxmltree::Node, key: &str| -> Result<f64, ImportError> {
        let text = attr(node, key)?;
        text.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| at(node, format!("`{key}` must be a number, found {text:?}")))
    };
    let mut edges: Vec<Edge> = Vec::new();
    let mut edge_nodes: BTreeMap<String, roxmltree::Node> = BTreeMap::new();
    let mut connections: Vec<(Connection, roxmltree::Node)> = Vec::new();
    let mut junction_kinds: BTreeMap<String, (String, roxmltree::Node)> = BTreeMap::new();
    let mut programs: BTreeMap<String, (SignalProgram, Vec<String>, roxmltree::Node)> =
        BTreeMap::new();
    for node in root.children().filter(roxmltree::Node::is_element) {
        match node.tag_name().name() {
            "edge" => {
                if node.attribute("function").is_some_and(|f| f != "normal") {
                    continue;
                }
                let id = attr(node, "id")?;
                let mut lanes: Vec<(u32, Lane)> = Vec::new();
                for lane in node.children().filter(|n| n.has_tag_name("lane")) {
                    let index = number(lane, "index")?;
                    if index < 0.0 || index.fract() != 0.0 {
                        return Err(at(
                            lane,
                            format!("`index` must be a lane number, found {index}"),
                        ));
                    }
                    let shape = parse_shape(&attr(lane, "shape")?)
                        .ok_or_else(|| at(lane, "`shape` must be at least two points `x,y` (or `x,y,z`) separated by spaces".to_owned()))?;
                    lanes.push((
                        index as u32,
                        Lane {
                            speed_mps: number(lane, "speed")?,
                            width_m: lane
                                .attribute("width")
                                .and_then(|w| w.parse().ok())
                                .unwrap_or(SUMO_LANE_WIDTH_M),
                            shape,
                        },
                    ));
                }
                if lanes.is_empty() {
                    return Err(at(node, format!("edge `{id}` has no <lane>")));
                }
                lanes.sort_by_key(|(i, _)| *i);
                if lanes.iter().enumerate().any(|(k, (i, _))| *i != k as u32) {
                    return Err(at(
                        node,
                        format!("edge `{id}`'s lanes must be numbered 0, 1, … without gaps"),
                    ));
                }
                edge_nodes.insert(id.clone(), node);
                edges.push(Edge {
                    to: attr(node, "to")?,
                    priority: node
                        .attribute("priority")
                        .and_then(|p| p.parse().ok())
                        .unwrap_or(0),
                    id,
                    lanes: lanes.into_iter().map(|(_, l)| l).collect(),
                });
            }
            "connection" => {
                let from = attr(node, "from")?;
                // Connections from internal lanes (`:JUNCTION_…`) are SUMO's own inner links.
                if from.starts_with(':') {
                    continue;
                }
                let lane = |key: &str| -> Result<u32, ImportError> {
                    let v = number(node, key)?;
                    if v < 0.0 || v.fract() != 0.0 {
                        return Err(at(
                            node,
                            format!("`{key}` must be a lane number, found {v}"),
                        ));
                    }
                    Ok(v as u32)
                };
                let link_index = match node.attribute("linkIndex") {
                    Some(_) => Some(number(node, "linkIndex")? as usize),
                    None => None,
                };
                connections.push((
                    Connection {
                        to: attr(node, "to")?,
                        from_lane: lane("fromLane")?,
                        to_lane: lane("toLane")?,
                        link_index,
                        tl: node.attribute("tl").map(str::to_owned),
                        from,
                    },
                    node,
                ));
            }
            "junction" => {
                let id = attr(node, "id")?;
                if node.attribute("type") == Some("internal") {
                    continue;
                }
                junction_kinds.insert(id, (attr(node, "type")?, node));
            }
            "tlLogic" => {
                let id = attr(node, "id")?;
                let mut phases = Vec::new();
                let mut states = Vec::new();
                for phase in node.children().filter(|n| n.has_tag_name("phase")) {
                    let duration_s = number(phase, "duration")?;
                    if duration_s < 0.0 {
                        return Err(at(
                            phase,
                            format!("`duration` must not be negative, found {duration_s}"),
                        ));
                    }
                    let state = attr(phase, "state")?;
                    if let Some(bad) = state.chars().find(|c| signal_letter(*c).is_none()) {
                        return Err(at(
                            phase,
                            format!(
                                "unknown signal state letter {bad:?}: expected one of G g y Y r R u o O s"
                            ),
                        ));
                    }
                    states.push(state);
                    phases.push(Phase {
                        duration_s,
                        state: String::new(),
                    });
                }
                if phases.is_empty() {
                    return Err(at(node, format!("traffic light `{id}` has no <phase>")));
                }
                let cycle: f64 = phases.iter().map(|p| p.duration_s).sum();
                let sumo_offset = node
                    .attribute("offset")
                    .and_then(|o| o.parse::<f64>().ok())
                    .unwrap_or(0.0);
                // SUMO starts the program `offset` seconds early... its position at time 0 is
                // −offset in the cycle; ours is where the cycle is at time 0.
                let offset_s = if cycle > 0.0 {
                    (-sumo_offset).rem_euclid(cycle)
                } else {
                    0.0
                };
                programs.insert(id, (SignalProgram { offset_s, phases }, states, node));
            }
            _ => {}
        }
    }
    if edges.is_empty() {
        return Err(at(
            root,
            "the network has no (non-internal) <edge>".to_owned(),
        ));
    }
    let by_id: BTreeMap<&str, &Edge> = edges.iter().map(|e| (e.id.as_str(), e)).collect();

    let mut level = Level::new(1, DURATION_S);
    level.name = name.to_owned();
    level.description = format!("Imported from the SUMO network {}.", file_name(path));
    level.vehicle_types = reference_vehicle_types();
    level.driver_profiles = reference_profiles();
    // The autonomous cars, keeping a time gap (the human-like profile is there to assign; its
    // reaction delay makes rear-end contacts in queues at lights).
    for p in &mut level.driver_profiles {
        if p.model == crate::DriverModel::FlockLanes {
            p.set.insert("time_gap_s".to_owned(), AUTONOMOUS_TIME_GAP_S);
        }
    }
    let shares = vec![ProfileShare {
        profile: AUTONOMOUS_PROFILE.to_owned(),
        weight: 1.0,
    }];
    for e in &edges {
        level.roads.push(road_of(e));
    }

    // Junctions: the connections out of each edge's end, grouped by the node it ends at.
    let mut at_node: BTreeMap<&str, Vec<&(Connection, roxmltree::Node)>> = BTreeMap::new();
    for c in &connections {
        let (conn, node) = c;
        let from = by_id.get(conn.from.as_str()).ok_or_else(|| {
            at(
                *node,
                format!("connection from unknown edge `{}`", conn.from),
            )
        })?;
        let to = by_id
            .get(conn.to.as_str())
            .ok_or_else(|| at(*node, format!("connection to unknown edge `{}`", conn.to)))?;
        if conn.from_lane as usize >= from.lanes.len() || conn.to_lane as usize >= to.lanes.len() {
            return Err(at(
                *node,
                format!(
                    "connection {} lane {} → {} lane {}: a lane the edge does not have",
                    conn.from, conn.from_lane, conn.to, conn.to_lane
                ),
            ));
        }
        at_node.entry(from.to.as_str()).or_default().push(c);
    }
    for (node_id, mut conns) in at_node {
        let kind = junction_kinds
            .get(node_id)
            .map_or("priority", |(k, _)| k.as_str());
        let signal = conns.iter().find_map(|(c, _)| c.tl.clone());
        // At a traffic light, the connections in link-index order (the phases' letters).
        if signal.is_some() {
            conns.sort_by_key(|(c, _)| c.link_index.unwrap_or(usize::MAX));
        }
        let incoming: BTreeSet<&str> = conns.iter().map(|(c, _)| c.from.as_str()).collect();
        let top = incoming
            .iter()
            .filter_map(|e| by_id.get(e).map(|e| e.priority))
            .max()
            .unwrap_or(0);
        let major: Vec<String> = incoming
            .iter()
            .filter(|e| by_id.get(*e).is_some_and(|e| e.priority == top))
            .map(|e| (*e).to_owned())
            .collect();
        let (control, program) = match (kind, &signal) {
            (k, Some(tl)) if k.starts_with("traffic_light") => {
                let (program, states, tl_node) = programs.get(tl).ok_or_else(|| {
                    at(
                        conns[0].1,
                        format!("connection under traffic light `{tl}`, which has no <tlLogic>"),
                    )
                })?;
                let mut program = program.clone();
                for (phase, sumo) in program.phases.iter_mut().zip(states) {
                    let letters: Vec<char> = sumo.chars().collect();
                    let mut state = String::with_capacity(conns.len());
                    for (c, node) in &conns {
                        let k = c.link_index.ok_or_else(|| {
                            at(
                                *node,
                                "a connection under a traffic light needs a `linkIndex`".to_owned(),
                            )
                        })?;
                        let letter = letters.get(k).copied().ok_or_else(|| {
                            at(*tl_node, format!(
                                "a phase of `{tl}` has {} letters, but a connection has link index {k}",
                                letters.len()
                            ))
                        })?;
                        state.push(signal_letter(letter).unwrap_or('r'));
                    }
                    phase.state = state;
                }
                (Control::Signal, Some(program))
            }
            ("right_before_left" | "left_before_right", _) => (Control::RightBeforeLeft, None),
            ("allway_stop", _) => (Control::AllWayStop, None),
            ("priority_stop", _) => (Control::Priority { major, stop: true }, None),
            _ => (Control::Priority { major, stop: false }, None),
        };
        level.junctions.push(JunctionSpec {
            name: node_id.to_owned(),
            control,
            connections: conns
                .iter()
                .map(|(c, _)| ConnectionSpec {
                    from: c.from.clone(),
                    from_lane: c.from_lane,
                    to: c.to.clone(),
                    to_lane: c.to_lane,
                })
                .collect(),
            signal: program,
        });
    }

    // Where the network is open: sources (nothing leads onto them) and sinks (lead nowhere).
    let mut next: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    let mut fed: BTreeSet<&str> = BTreeSet::new();
    for (c, _) in &connections {
        next.entry(c.from.as_str())
            .or_default()
            .insert(c.to.as_str());
        fed.insert(c.to.as_str());
    }
    let sinks: Vec<&Edge> = edges
        .iter()
        .filter(|e| next.get(e.id.as_str()).is_none_or(BTreeSet::is_empty))
        .collect();
    for e in &edges {
        if fed.contains(e.id.as_str()) {
            continue;
        }
        let routes: Vec<RouteSpec> = sinks
            .iter()
            .filter_map(|sink| shortest(&next, &e.id, &sink.id))
            .filter(|roads| roads.len() > 1)
            .map(|roads| RouteSpec {
                name: roads.last().cloned().unwrap_or_default(),
                roads,
                weight: 1.0,
            })
            .collect();
        for lane in 0..e.lanes.len() as u32 {
            level.spawners.push(SpawnerSpec {
                name: if e.lanes.len() > 1 {
                    format!("{} lane {lane}", e.id)
                } else {
                    e.id.clone()
                },
                road: e.id.clone(),
                lane,
                s_m: 5.0,
                interval_s: SPAWN_INTERVAL_S,
                profiles: shares.clone(),
                speed_kmh: None,
                active: true,
                max_vehicles: None,
                routes: routes.clone(),
                destination: None,
                schedule: Vec::new(),
                arrivals: Default::default(),
            });
        }
    }
    for sink in &sinks {
        let length = polyline_length(&sink.lanes[0].shape);
        level.destroyers.push(DestroyerSpec {
            name: sink.id.clone(),
            place: DestroyerPlaceSpec::OnRoad {
                road: sink.id.clone(),
                s_m: (length - DESTROYER_BEFORE_END_M).max(0.5 * length),
            },
        });
    }
    level.telemetry.stats_from_s = 60.0;
    level.expect = ["collisions == 0"]
        .iter()
        .filter_map(|t| Expectation::parse(t).ok())
        .collect();
    let issues = crate::validate(&level);
    if let Some(issue) = issues.first() {
        let node = issue_node(issue, &level, &edge_nodes, &junction_kinds).unwrap_or(root);
        return Err(at(
            node,
            format!(
                "the network does not make a valid level: {}: {}",
                issue.subject(&level),
                issue.message
            ),
        ));
    }
    Ok(level)
}

/// The XML element a validation issue comes from, where it can be told.
fn issue_node<'a, 'i>(
    issue: &crate::Issue,
    level: &Level,
    edges: &BTreeMap<String, roxmltree::Node<'a, 'i>>,
    junctions: &BTreeMap<String, (String, roxmltree::Node<'a, 'i>)>,
) -> Option<roxmltree::Node<'a, 'i>> {
    use crate::PathStep;
    match issue.path.as_slice() {
        [PathStep::Field("roads"), PathStep::Index(i), ..] => {
            edges.get(&level.roads.get(*i)?.name).copied()
        }
        [PathStep::Field("junctions"), PathStep::Index(i), ..] => junctions
            .get(&level.junctions.get(*i)?.name)
            .map(|(_, n)| *n),
        _ => None,
    }
}

/// Our letter for a SUMO signal state letter: `G`, `g` as they are; amber `y`/`Y`; red, and
/// red-amber `u`, as red; off (`o`, `O`) and the stop-sign-like `s` as a green that gives way.
fn signal_letter(c: char) -> Option<char> {
    match c {
        'G' => Some('G'),
        'g' | 'o' | 'O' | 's' => Some('g'),
        'y' | 'Y' => Some('y'),
        'r' | 'R' | 'u' => Some('r'),
        _ => None,
    }
}

/// `x,y[,z] x,y[,z] …` as points (at least two).
fn parse_shape(text: &str) -> Option<Vec<DVec3>> {
    let points = text
        .split_whitespace()
        .map(|p| {
            let v: Vec<f64> = p
                .split(',')
                .map(|c| c.parse::<f64>().ok().filter(|x| x.is_finite()))
                .collect::<Option<_>>()?;
            match v.as_slice() {
                [x, y] => Some(DVec3::new(*x, *y, 0.0)),
                [x, y, z] => Some(DVec3::new(*x, *y, *z)),
                _ => None,
            }
        })
        .collect::<Option<Vec<_>>>()?;
    (points.len() >= 2).then_some(points)
}

fn polyline_length(points: &[DVec3]) -> f64 {
    points.windows(2).map(|w| w[0].distance(w[1])).sum()
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

/// The fewest edges from `from` to `to` through the connections (breadth first, in name order,
/// so the same network always gives the same routes).
fn shortest(next: &BTreeMap<&str, BTreeSet<&str>>, from: &str, to: &str) -> Option<Vec<String>> {
    let mut back: BTreeMap<&str, &str> = BTreeMap::new();
    let mut queue = VecDeque::from([from]);
    let mut seen = BTreeSet::from([from]);
    while let Some(e) = queue.pop_front() {
        if e == to {
            let mut path = vec![to.to_owned()];
            let mut at = to;
            while let Some(&p) = back.get(at) {
                path.push(p.to_owned());
                at = p;
            }
            path.reverse();
            return Some(path);
        }
        for &n in next.get(e).into_iter().flatten() {
            if seen.insert(n) {
                back.insert(n, e);
                queue.push_back(n);
            }
        }
    }
    None
}

fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sumo_signal_letters_map_onto_ours() {
        let mapped: String = "GgyYrRuoOs".chars().filter_map(signal_letter).collect();
        assert_eq!(mapped, "Ggyyrrrggg");
        assert_eq!(signal_letter('x'), None);
    }

    #[test]
    fn shapes_are_two_points_or_more_in_two_or_three_dimensions() {
        assert_eq!(
            parse_shape("0,0 10,0.5,2"),
            Some(vec![DVec3::ZERO, DVec3::new(10.0, 0.5, 2.0)])
        );
        assert_eq!(parse_shape("0,0"), None);
        assert_eq!(parse_shape("0,0 1"), None);
        assert_eq!(parse_shape("0,0 nan,1"), None);
    }

    #[test]
    fn routes_take_the_fewest_edges_and_the_same_way_every_time() {
        let mut next: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
        next.insert("a", BTreeSet::from(["b", "c"]));
        next.insert("b", BTreeSet::from(["d"]));
        next.insert("c", BTreeSet::from(["d"]));
        assert_eq!(
            shortest(&next, "a", "d"),
            Some(vec!["a".to_owned(), "b".to_owned(), "d".to_owned()])
        );
        assert_eq!(shortest(&next, "d", "a"), None);
    }
}

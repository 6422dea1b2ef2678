//! SUMO networks in: a `.net.xml` (as `netconvert` writes it, from OpenStreetMap, OpenDRIVE or
//! plain node and edge files) becomes a level that runs.
//!
//! - Every edge that is not internal becomes a road of the same name, its lanes (SUMO's lane 0 is
//!   the rightmost, as ours), width, speed limit and centre line taken from its lanes' shapes.
//! - Every junction with connections becomes a junction of the same name: its connections (in
//!   SUMO's link-index order at a traffic light, so each phase's state reads letter for letter),
//!   its right of way (`traffic_light` → `Signal` with the `tlLogic` program, `priority` and
//!   `priority_stop` → `Priority` with the incoming edges of the highest priority as major (the
//!   two that arrive most nearly head-on when more tie),
//!   `right_before_left` → `RightBeforeLeft`, `allway_stop` → `AllWayStop`).
//! - Where one edge simply goes on as another (a lane added or dropped: a motorway's
//!   acceleration and deceleration lanes), or two lanes meet, the roads are linked rather than
//!   joined through a junction.
//! - Where the network is open, traffic comes and goes: a spawner on every lane of each edge
//!   nothing leads onto, its vehicles routed to every edge that leads nowhere (the shortest way
//!   there), and a destroyer near the end of each of those.

use crate::expect::Expectation;
use crate::schema::{
    DestroyerPlaceSpec, DestroyerSpec, Level, ProfileShare, Range, RouteSpec, SpawnerSpec,
};
use crate::template::{AUTONOMOUS_PROFILE, reference_profiles, reference_vehicle_types};
use flockway_road::{
    ConnectionSpec, Control, JunctionSpec, LinkSpec, Phase, RoadSpec, SignalProgram,
};
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

/// A SUMO XML file (DTDs allowed), or an error at the place it stops being well-formed.
pub(crate) fn parse_xml<'t>(
    text: &'t str,
    path: &Path,
) -> Result<roxmltree::Document<'t>, ImportError> {
    let options = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    roxmltree::Document::parse_with_options(text, options).map_err(|e| {
        let pos = e.pos();
        ImportError {
            path: path.to_owned(),
            line: pos.row,
            column: pos.col,
            message: format!("not a well-formed XML file: {e}"),
        }
    })
}

/// An import error at `node` of the file `path`.
pub(crate) fn error_at(path: &Path, node: roxmltree::Node, message: String) -> ImportError {
    let pos = node.document().text_pos_at(node.range().start);
    ImportError {
        path: path.to_owned(),
        line: pos.row,
        column: pos.col,
        message,
    }
}

/// SUMO's lane width where a lane does not give one, m.
const SUMO_LANE_WIDTH_M: f64 = 3.2;
/// Two lanes a connection joins whose ends are closer than this, m, continue one another (a
/// simple join, a lane added or dropped along a road): the roads are linked, not a junction.
const JOIN_GAP_M: f64 = 1.0;
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

/// One edge as read: its car lanes only (a sidewalk, a bike or a bus lane is left out).
struct Edge {
    id: String,
    from: String,
    to: String,
    priority: i64,
    lanes: Vec<Lane>,
    /// The car lane each of SUMO's lane indices became (`None`: not a car lane).
    lane_map: Vec<Option<u32>>,
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
    /// SUMO's direction `t`: a turn back.
    turn_back: bool,
}

/// Reads a SUMO network file into a level named `name`.
pub fn import_sumo_net(text: &str, path: &Path, name: &str) -> Result<Level, ImportError> {
    import_net(text, path, name).map(|(level, _)| level)
}

/// For each imported edge, the car lane each of SUMO's lane indices became (`None`: a lane cars
/// may not use, left out).
pub(crate) type LaneMaps = BTreeMap<String, Vec<Option<u32>>>;

/// [`import_sumo_net`], with the lane numbering of each edge it kept.
pub(crate) fn import_net(
    text: &str,
    path: &Path,
    name: &str,
) -> Result<(Level, LaneMaps), ImportError> {
    let doc = parse_xml(text, path)?;
    let at = |node: roxmltree::Node, message: String| error_at(path, node, message);
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
    let mut skipped_edges: BTreeSet<String> = BTreeSet::new();
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
                let mut lanes: Vec<(u32, bool, Lane)> = Vec::new();
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
                        allows_cars(lane.attribute("allow"), lane.attribute("disallow")),
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
                lanes.sort_by_key(|(i, ..)| *i);
                if lanes.iter().enumerate().any(|(k, (i, ..))| *i != k as u32) {
                    return Err(at(
                        node,
                        format!("edge `{id}`'s lanes must be numbered 0, 1, … without gaps"),
                    ));
                }
                // Only the lanes cars may use become lanes; an edge with none (a footpath, a
                // cycleway, a railway) is left out, and so are its connections.
                let mut lane_map = Vec::with_capacity(lanes.len());
                let mut car_lanes = Vec::new();
                for (_, cars, lane) in lanes {
                    if cars {
                        lane_map.push(Some(car_lanes.len() as u32));
                        car_lanes.push(lane);
                    } else {
                        lane_map.push(None);
                    }
                }
                if car_lanes.is_empty() {
                    skipped_edges.insert(id);
                    continue;
                }
                edge_nodes.insert(id.clone(), node);
                edges.push(Edge {
                    from: attr(node, "from")?,
                    to: attr(node, "to")?,
                    priority: node
                        .attribute("priority")
                        .and_then(|p| p.parse().ok())
                        .unwrap_or(0),
                    id,
                    lanes: car_lanes,
                    lane_map,
                });
            }
            "connection" => {
                let from = attr(node, "from")?;
                // Connections from or to internal edges (`:JUNCTION_…`: SUMO's own inner links,
                // walking areas, crossings) are not between roads.
                if from.starts_with(':') || attr(node, "to")?.starts_with(':') {
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
                        turn_back: node.attribute("dir") == Some("t"),
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

    // The connections among car lanes, in car-lane numbers: a connection of an edge left out,
    // or of a lane cars may not use, is not one.
    let mut car_connections: Vec<(Connection, roxmltree::Node)> = Vec::new();
    for (conn, node) in connections {
        if skipped_edges.contains(&conn.from) || skipped_edges.contains(&conn.to) {
            continue;
        }
        let from = by_id.get(conn.from.as_str()).ok_or_else(|| {
            at(
                node,
                format!("connection from unknown edge `{}`", conn.from),
            )
        })?;
        let to = by_id
            .get(conn.to.as_str())
            .ok_or_else(|| at(node, format!("connection to unknown edge `{}`", conn.to)))?;
        let (Some(from_lane), Some(to_lane)) = (
            from.lane_map.get(conn.from_lane as usize),
            to.lane_map.get(conn.to_lane as usize),
        ) else {
            return Err(at(
                node,
                format!(
                    "connection {} lane {} → {} lane {}: a lane the edge does not have",
                    conn.from, conn.from_lane, conn.to, conn.to_lane
                ),
            ));
        };
        let (Some(from_lane), Some(to_lane)) = (*from_lane, *to_lane) else {
            continue;
        };
        // A turn back onto the edge the other way (SUMO writes one at most nodes): no route
        // here takes it, and its tight path would only cross the junction's others.
        if conn.turn_back || (from.from == to.to && from.to == to.from) {
            continue;
        }
        car_connections.push((
            Connection {
                from_lane,
                to_lane,
                ..conn
            },
            node,
        ));
    }
    drop(by_id);
    let mut connections = car_connections;
    close_simple_nodes(&mut edges, &mut connections);
    let by_id: BTreeMap<&str, &Edge> = edges.iter().map(|e| (e.id.as_str(), e)).collect();
    for e in &edges {
        level.roads.push(road_of(e));
    }

    // Junctions: the connections out of each edge's end, grouped by the node it ends at. A
    // connection whose lanes continue one another (within `JOIN_GAP_M`) is a link instead.
    let mut links: BTreeMap<(String, String), Vec<(u32, u32)>> = BTreeMap::new();
    let mut at_node: BTreeMap<&str, Vec<&(Connection, roxmltree::Node)>> = BTreeMap::new();
    for c in &connections {
        let (conn, _) = c;
        let (from, to) = (by_id[conn.from.as_str()], by_id[conn.to.as_str()]);
        let end = from.lanes[conn.from_lane as usize].shape.last().copied();
        let start = to.lanes[conn.to_lane as usize].shape.first().copied();
        let joined = matches!((end, start), (Some(a), Some(b)) if a.distance(b) < JOIN_GAP_M);
        // Joined lanes are linked even under a traffic light (a light where a road simply goes
        // on, for a crossing the importer leaves out): a link has no signal, so that light is
        // left out for them.
        if joined {
            links
                .entry((conn.from.clone(), conn.to.clone()))
                .or_default()
                .push((conn.from_lane, conn.to_lane));
        } else {
            at_node.entry(from.to.as_str()).or_default().push(c);
        }
    }
    for ((from, to), lanes) in links {
        if let Some(road) = level.roads.iter_mut().find(|r| r.name == from) {
            road.links.push(LinkSpec { to, lanes });
        }
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
        let tied: Vec<&Edge> = incoming
            .iter()
            .filter_map(|e| by_id.get(e).copied())
            .filter(|e| e.priority == top)
            .collect();
        let major = main_road(&tied);
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

    // Where the network is open: sources (nothing leads onto them, turns back left out: a
    // dead end) and sinks (they lead nowhere).
    let mut next: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    let mut fed: BTreeSet<&str> = BTreeSet::new();
    let mut leads_on: BTreeSet<&str> = BTreeSet::new();
    for (c, _) in &connections {
        next.entry(c.from.as_str())
            .or_default()
            .insert(c.to.as_str());
        fed.insert(c.to.as_str());
        leads_on.insert(c.from.as_str());
    }
    let sinks: Vec<&Edge> = edges
        .iter()
        .filter(|e| !leads_on.contains(e.id.as_str()))
        .collect();
    if edges.iter().all(|e| fed.contains(e.id.as_str())) {
        return Err(at(
            root,
            "the network has no entry: every edge is reached from another, so no traffic can \
             come in; give it fringe edges (netgenerate `--grid.attach-length 100` or \
             `--spider.attach-length 100`, or a road that starts at a dead end)"
                .to_owned(),
        ));
    }
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
                departures: Vec::new(),
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
            arrivals_only: false,
        });
    }
    level.telemetry.stats_from_s = 60.0;
    level.expect = ["collisions == 0", "vehicles_spawned > 0"]
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
    let lane_maps = edges
        .iter()
        .filter(|e| level.road(&e.id).is_some())
        .map(|e| (e.id.clone(), e.lane_map.clone()))
        .collect();
    Ok((level, lane_maps))
}

/// The major road of a priority junction among the incoming edges `tied` at the highest
/// priority: all of them when two or fewer, else the two that arrive most nearly head-on (as
/// netconvert chooses its main road: in a grid of equal streets one street goes through, the
/// other gives way, rather than every arm giving way to every other).
fn main_road(tied: &[&Edge]) -> Vec<String> {
    let heading = |e: &Edge| -> Option<DVec3> {
        let lane = e.lanes.first()?;
        let [.., p, q] = lane.shape.as_slice() else {
            return None;
        };
        DVec3::new(q.x - p.x, q.y - p.y, 0.0).try_normalize()
    };
    let mut best: Option<(f64, usize, usize)> = None;
    if tied.len() > 2 {
        for i in 0..tied.len() {
            for j in i + 1..tied.len() {
                if let (Some(a), Some(b)) = (heading(tied[i]), heading(tied[j])) {
                    // −1 for two edges that arrive head-on.
                    let facing = a.dot(b);
                    if best.is_none_or(|(f, ..)| facing < f) {
                        best = Some((facing, i, j));
                    }
                }
            }
        }
    }
    let mut major: Vec<String> = match best {
        Some((_, i, j)) => vec![tied[i].id.clone(), tied[j].id.clone()],
        None => tied.iter().map(|e| e.id.clone()).collect(),
    };
    major.sort();
    major
}

/// How far apart the ends of two edges one node simply joins may be, m, to be drawn as one road
/// going on: netconvert leaves a short gap (its junction's area) where a lane is added or
/// dropped.
const SIMPLE_NODE_GAP_M: f64 = 30.0;
/// How far sideways the lanes a connection at such a node joins may be, m, to continue one
/// another.
const SIMPLE_NODE_SIDEWAYS_M: f64 = 0.5;

/// Where one edge simply goes on as another (every connection at a node from one edge onto one
/// other: a lane added or dropped, a change of speed, a light for a crossing left out): the two are drawn to meet
/// halfway across the gap netconvert leaves between them, so that the lanes that continue one
/// another are linked instead of joined through a junction of short sideways jinks; a lane that
/// only a connection sideways reached (a lane fanned out into two) is entered by a lane change
/// instead, and that connection is left out.
fn close_simple_nodes(edges: &mut [Edge], connections: &mut Vec<(Connection, roxmltree::Node)>) {
    let index: BTreeMap<String, usize> = edges
        .iter()
        .enumerate()
        .map(|(k, e)| (e.id.clone(), k))
        .collect();
    // Per node: the edges connections come from and go to there.
    let mut nodes: BTreeMap<String, (BTreeSet<usize>, BTreeSet<usize>)> = BTreeMap::new();
    for (c, _) in connections.iter() {
        let (Some(&a), Some(&b)) = (index.get(&c.from), index.get(&c.to)) else {
            continue;
        };
        let entry = nodes.entry(edges[a].to.clone()).or_default();
        entry.0.insert(a);
        entry.1.insert(b);
    }
    let mut dropped: BTreeSet<(usize, u32, usize, u32)> = BTreeSet::new();
    for (from, to) in nodes.values() {
        if from.len() != 1 || to.len() != 1 {
            continue;
        }
        let (Some(&a), Some(&b)) = (from.first(), to.first()) else {
            continue;
        };
        if a == b {
            continue;
        }
        let pairs: Vec<(u32, u32)> = connections
            .iter()
            .filter(|(c, _)| index.get(&c.from) == Some(&a) && index.get(&c.to) == Some(&b))
            .map(|(c, _)| (c.from_lane, c.to_lane))
            .collect();
        let aligned: Vec<((u32, u32), DVec3)> = pairs
            .iter()
            .filter_map(|&(la, lb)| {
                let gap = lane_gap(&edges[a].lanes[la as usize], &edges[b].lanes[lb as usize])?;
                Some(((la, lb), gap))
            })
            .collect();
        if aligned.is_empty() {
            continue;
        }
        let mean = aligned.iter().map(|(_, d)| *d).sum::<DVec3>() / aligned.len() as f64;
        // `lane_gap` bounds the gap on the ground only: not across a climb this steep.
        if mean.length() > 2.0 * SIMPLE_NODE_GAP_M {
            continue;
        }
        if mean.length() > 0.2 {
            let half = 0.5 * mean;
            for lane in &mut edges[a].lanes {
                if let Some(&end) = lane.shape.last() {
                    lane.shape.push(end + half);
                }
            }
            for lane in &mut edges[b].lanes {
                if let Some(&start) = lane.shape.first() {
                    lane.shape.insert(0, start - half);
                }
            }
        }
        for &(la, lb) in &pairs {
            if !aligned.iter().any(|(p, _)| *p == (la, lb)) {
                dropped.insert((a, la, b, lb));
            }
        }
    }
    connections.retain(|(c, _)| {
        let (Some(&a), Some(&b)) = (index.get(&c.from), index.get(&c.to)) else {
            return true;
        };
        !dropped.contains(&(a, c.from_lane, b, c.to_lane))
    });
}

/// The gap from the end of lane `a` to the start of lane `b` when `b` goes straight on from `a`
/// (ahead of it, within [`SIMPLE_NODE_GAP_M`], within [`SIMPLE_NODE_SIDEWAYS_M`] sideways of its
/// line and heading within 30° of it); `None` otherwise.
fn lane_gap(a: &Lane, b: &Lane) -> Option<DVec3> {
    let [.., p, end] = a.shape.as_slice() else {
        return None;
    };
    let [start, q, ..] = b.shape.as_slice() else {
        return None;
    };
    let flat = |v: DVec3| DVec3::new(v.x, v.y, 0.0);
    let along_a = flat(*end - *p).try_normalize()?;
    let along_b = flat(*q - *start).try_normalize()?;
    let gap = *start - *end;
    let ahead = flat(gap).dot(along_a);
    let sideways = (flat(gap) - ahead * along_a).length();
    let straight = along_a.dot(along_b) >= 30f64.to_radians().cos();
    (ahead > -0.5 && ahead < SIMPLE_NODE_GAP_M && sideways < SIMPLE_NODE_SIDEWAYS_M && straight)
        .then_some(gap)
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

/// Whether a lane with these `allow` and `disallow` lists (SUMO vehicle classes, space
/// separated) takes passenger cars: by default yes; `allow` must name `passenger` (or `all`),
/// `disallow` must not.
fn allows_cars(allow: Option<&str>, disallow: Option<&str>) -> bool {
    let names = |list: &str, class: &str| list.split_whitespace().any(|c| c == class);
    match (allow, disallow) {
        (Some(a), _) => names(a, "passenger") || names(a, "all"),
        (None, Some(d)) => !(names(d, "passenger") || names(d, "all")),
        (None, None) => true,
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

    /// An edge named `id` whose one lane arrives along `from` → `to`.
    fn arriving(id: &str, from: (f64, f64), to: (f64, f64)) -> Edge {
        Edge {
            id: id.to_owned(),
            from: String::new(),
            to: "J".to_owned(),
            priority: 1,
            lanes: vec![Lane {
                speed_mps: 13.9,
                width_m: SUMO_LANE_WIDTH_M,
                shape: vec![DVec3::new(from.0, from.1, 0.0), DVec3::new(to.0, to.1, 0.0)],
            }],
            lane_map: vec![Some(0)],
        }
    }

    #[test]
    fn of_equal_streets_the_two_that_arrive_head_on_are_the_main_road() {
        let west = arriving("w", (-100.0, -1.6), (-7.0, -1.6));
        let east = arriving("e", (100.0, 1.6), (7.0, 1.6));
        let south = arriving("s", (1.6, -100.0), (1.6, -7.0));
        let bent = arriving("n", (-30.0, 100.0), (-1.6, 7.0));
        // A crossroads of a straight street and a bent one: the straight one goes through.
        assert_eq!(main_road(&[&bent, &east, &south, &west]), ["e", "w"]);
        // A tee of equal streets: the two arms that line up.
        assert_eq!(main_road(&[&south, &east, &west]), ["e", "w"]);
        // Two or fewer tied: all of them.
        assert_eq!(main_road(&[&south, &east]), ["e", "s"]);
    }

    #[test]
    fn sumo_signal_letters_map_onto_ours() {
        let mapped: String = "GgyYrRuoOs".chars().filter_map(signal_letter).collect();
        assert_eq!(mapped, "Ggyyrrrggg");
        assert_eq!(signal_letter('x'), None);
    }

    #[test]
    fn only_lanes_passenger_cars_may_use_are_car_lanes() {
        assert!(allows_cars(None, None));
        assert!(allows_cars(Some("passenger bus"), None));
        assert!(!allows_cars(Some("pedestrian"), None));
        assert!(!allows_cars(Some("bicycle"), None));
        assert!(allows_cars(None, Some("pedestrian bicycle")));
        assert!(!allows_cars(None, Some("all")));
        assert!(!allows_cars(None, Some("passenger taxi")));
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

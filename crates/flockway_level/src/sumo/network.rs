//! The network Flockway drives, made from the network as read: connections among car lanes only
//! (in car-lane numbers, turns back left out), nodes where one edge simply goes on as another
//! closed, the main road of each priority junction, and where traffic comes in and leaves.

use super::ImportError;
use super::net::{Connection, Edge, Lane, Net};
use glam::DVec3;
use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::path::Path;

/// How far apart the ends of two edges one node simply joins may be, m, to be drawn as one road
/// going on: netconvert leaves a short gap (its junction's area) where a lane is added or
/// dropped.
const SIMPLE_NODE_GAP_M: f64 = 30.0;
/// How far sideways the lanes a connection at such a node joins may be, m, to continue one
/// another.
const SIMPLE_NODE_SIDEWAYS_M: f64 = 0.5;

/// The connections of `net` among car lanes, in car-lane numbers: a connection of an edge left
/// out, or of a lane cars may not use, is not one, nor is a turn back onto the edge the other way
/// (SUMO writes one at most nodes: no route here takes it, and its tight path would only cross
/// the junction's others). A connection naming an edge or a lane the network does not have is
/// an error at it.
pub(super) fn car_connections(net: &Net, path: &Path) -> Result<Vec<Connection>, ImportError> {
    let by_id: BTreeMap<&str, &Edge> = net.edges.iter().map(|e| (e.id.as_str(), e)).collect();
    let mut kept = Vec::new();
    for conn in &net.connections {
        if net.skipped_edges.contains(&conn.from) || net.skipped_edges.contains(&conn.to) {
            continue;
        }
        let from = by_id.get(conn.from.as_str()).ok_or_else(|| {
            conn.at.error(
                path,
                format!("connection from unknown edge `{}`", conn.from),
            )
        })?;
        let to = by_id.get(conn.to.as_str()).ok_or_else(|| {
            conn.at
                .error(path, format!("connection to unknown edge `{}`", conn.to))
        })?;
        let (Some(from_lane), Some(to_lane)) = (
            from.lane_map.get(conn.from_lane as usize),
            to.lane_map.get(conn.to_lane as usize),
        ) else {
            return Err(conn.at.error(
                path,
                format!(
                    "connection {} lane {} → {} lane {}: a lane the edge does not have",
                    conn.from, conn.from_lane, conn.to, conn.to_lane
                ),
            ));
        };
        let (Some(from_lane), Some(to_lane)) = (*from_lane, *to_lane) else {
            continue;
        };
        if conn.turn_back || (from.from == to.to && from.to == to.from) {
            continue;
        }
        kept.push(Connection {
            from_lane,
            to_lane,
            ..conn.clone()
        });
    }
    Ok(kept)
}

/// Where one edge simply goes on as another (every connection at a node from one edge onto one
/// other: a lane added or dropped, a change of speed, a light for a crossing left out): the two
/// are drawn to meet halfway across the gap netconvert leaves between them, so that the lanes
/// that continue one another are linked instead of joined through a junction of short sideways
/// jinks; a lane that only a connection sideways reached (a lane fanned out into two) is entered
/// by a lane change instead, and that connection is left out.
pub(super) fn close_simple_nodes(edges: &mut [Edge], connections: &mut Vec<Connection>) {
    let index: BTreeMap<String, usize> = edges
        .iter()
        .enumerate()
        .map(|(k, e)| (e.id.clone(), k))
        .collect();
    // Per node: the edges connections come from and go to there.
    let mut nodes: BTreeMap<String, (BTreeSet<usize>, BTreeSet<usize>)> = BTreeMap::new();
    for c in connections.iter() {
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
            .filter(|c| index.get(&c.from) == Some(&a) && index.get(&c.to) == Some(&b))
            .map(|c| (c.from_lane, c.to_lane))
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
    connections.retain(|c| {
        let (Some(&a), Some(&b)) = (index.get(&c.from), index.get(&c.to)) else {
            return true;
        };
        !dropped.contains(&(a, c.from_lane, b, c.to_lane))
    });
}

/// An edge between two junctions whose lanes are all shorter than this, m, lies inside one
/// junction: OpenStreetMap draws a crossing as several nodes a few metres apart (a cycle
/// track's crossing, a dual carriageway's two halves), and a car on the first's path could not
/// stop short of the second's line.
const INSIDE_JUNCTION_M: f64 = 3.0;

/// Makes one junction of two joined by an edge shorter than [`INSIDE_JUNCTION_M`]: each
/// connection onto the edge followed by one off it (lane to the same lane) becomes one
/// connection across both, the edge is left out, and the nodes are one (the one with the traffic
/// light, else the second; the short edge the other way then lies inside it too). Not where
/// lights at both ends control it. The ids of the edges left out, in the order they were.
pub(super) fn merge_close_junctions(
    net: &mut Net,
    connections: &mut Vec<Connection>,
) -> Vec<String> {
    let mut merged = Vec::new();
    loop {
        let mut ins: BTreeMap<&str, Vec<usize>> = BTreeMap::new();
        let mut outs: BTreeMap<&str, Vec<usize>> = BTreeMap::new();
        for (k, c) in connections.iter().enumerate() {
            ins.entry(c.to.as_str()).or_default().push(k);
            outs.entry(c.from.as_str()).or_default().push(k);
        }
        let controlled = |ks: &[usize]| ks.iter().any(|&k| connections[k].tl.is_some());
        let found = net.edges.iter().position(|e| {
            let (Some(i), Some(o)) = (ins.get(e.id.as_str()), outs.get(e.id.as_str())) else {
                return false;
            };
            !e.lanes.is_empty()
                && e.lanes
                    .iter()
                    .all(|l| polyline_length(&l.shape) < INSIDE_JUNCTION_M)
                && !(controlled(i) && controlled(o))
        });
        let Some(at) = found else {
            break;
        };
        let edge = net.edges.remove(at);
        let (into, out_of) = (&ins[edge.id.as_str()], &outs[edge.id.as_str()]);
        let (keep, gone) = if controlled(into) {
            (edge.from.clone(), edge.to.clone())
        } else {
            (edge.to.clone(), edge.from.clone())
        };
        let ends: BTreeMap<&str, (&str, &str)> = net
            .edges
            .iter()
            .map(|e| (e.id.as_str(), (e.from.as_str(), e.to.as_str())))
            .collect();
        let mut across = Vec::new();
        for &a in into {
            for &b in out_of {
                let (c1, c2) = (&connections[a], &connections[b]);
                let (Some(from), Some(to)) = (ends.get(c1.from.as_str()), ends.get(c2.to.as_str()))
                else {
                    continue;
                };
                // Lane to the same lane, and not back the way it came.
                if c1.to_lane != c2.from_lane
                    || c1.from == c2.to
                    || (from.0 == to.1 && from.1 == to.0)
                {
                    continue;
                }
                let light = if c1.tl.is_some() { c1 } else { c2 };
                across.push(Connection {
                    from: c1.from.clone(),
                    from_lane: c1.from_lane,
                    to: c2.to.clone(),
                    to_lane: c2.to_lane,
                    link_index: light.link_index,
                    tl: light.tl.clone(),
                    turn_back: false,
                    major: c1.major && c2.major,
                    at: c1.at,
                });
            }
        }
        connections.retain(|c| c.from != edge.id && c.to != edge.id);
        for c in across {
            let same = |d: &Connection| {
                (d.from.as_str(), d.from_lane, d.to.as_str(), d.to_lane)
                    == (c.from.as_str(), c.from_lane, c.to.as_str(), c.to_lane)
            };
            if !connections.iter().any(same) {
                connections.push(c);
            }
        }
        for e in &mut net.edges {
            if e.from == gone {
                e.from.clone_from(&keep);
            }
            if e.to == gone {
                e.to.clone_from(&keep);
            }
        }
        merged.push(edge.id);
    }
    merged
}

/// The length of a polyline, m.
fn polyline_length(points: &[DVec3]) -> f64 {
    points.windows(2).map(|w| w[0].distance(w[1])).sum()
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

/// The major road of a priority junction among the incoming edges `tied` at the highest
/// priority: all of them when two or fewer, else the two that arrive most nearly head-on (as
/// netconvert chooses its main road: in a grid of equal streets one street goes through, the
/// other gives way, rather than every arm giving way to every other).
pub(super) fn main_road(tied: &[&Edge]) -> Vec<String> {
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

/// Where the network is open: sources (nothing leads onto them; turns back are already left
/// out, so a dead end's road out is one) and sinks (they lead nowhere), in the edges' order.
pub(super) struct Fringe<'n> {
    pub sources: Vec<&'n Edge>,
    pub sinks: Vec<&'n Edge>,
    /// The edges each edge leads onto.
    next: BTreeMap<&'n str, BTreeSet<&'n str>>,
}

impl<'n> Fringe<'n> {
    /// The fringe of `edges` joined by `connections`.
    pub fn of(edges: &'n [Edge], connections: &'n [Connection]) -> Fringe<'n> {
        let mut next: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
        let mut fed: BTreeSet<&str> = BTreeSet::new();
        for c in connections {
            next.entry(c.from.as_str())
                .or_default()
                .insert(c.to.as_str());
            fed.insert(c.to.as_str());
        }
        Fringe {
            sources: edges
                .iter()
                .filter(|e| !fed.contains(e.id.as_str()))
                .collect(),
            sinks: edges
                .iter()
                .filter(|e| !next.contains_key(e.id.as_str()))
                .collect(),
            next,
        }
    }

    /// The way from `source` to each sink it reaches, by the fewest edges (a sink that is the
    /// source itself is no way), in the sinks' order.
    pub fn routes_from(&self, source: &str) -> Vec<Vec<String>> {
        let back = breadth_first(&self.next, source);
        self.sinks
            .iter()
            .filter_map(|sink| {
                let mut at = back.get(sink.id.as_str()).map(|_| sink.id.as_str())?;
                let mut path = vec![at.to_owned()];
                while let Some(&Some(p)) = back.get(at) {
                    path.push(p.to_owned());
                    at = p;
                }
                path.reverse();
                Some(path)
            })
            .filter(|roads| roads.len() > 1)
            .collect()
    }
}

/// Every edge reachable from `from` through the connections by the fewest edges, with the edge
/// it is reached from (`None` for `from`): breadth first, in name order, so the same network
/// always gives the same routes.
fn breadth_first<'a>(
    next: &BTreeMap<&'a str, BTreeSet<&'a str>>,
    from: &'a str,
) -> BTreeMap<&'a str, Option<&'a str>> {
    let mut back = BTreeMap::from([(from, None)]);
    let mut queue = VecDeque::from([from]);
    while let Some(e) = queue.pop_front() {
        for &n in next.get(e).into_iter().flatten() {
            if let std::collections::btree_map::Entry::Vacant(v) = back.entry(n) {
                v.insert(Some(e));
                queue.push_back(n);
            }
        }
    }
    back
}

#[cfg(test)]
mod tests {
    use super::super::net;
    use super::*;

    /// `body` inside a `<net>` element, read.
    fn read_body(body: &str) -> Net {
        net::read(&format!("<net>\n{body}\n</net>\n"), Path::new("t.net.xml")).expect("reads")
    }

    /// An edge `id` from node `a` to node `b`, its lanes (`(allow, y)` each, `x` from `x0` to
    /// `x1`) one per entry.
    fn edge(id: &str, a: &str, b: &str, x0: f64, x1: f64, lanes: &[(&str, f64)]) -> String {
        let lanes: String = lanes
            .iter()
            .enumerate()
            .map(|(k, (allow, y))| {
                format!(
                    r#"<lane index="{k}" speed="13.89" allow="{allow}" shape="{x0},{y} {x1},{y}"/>"#
                )
            })
            .collect();
        format!(r#"<edge id="{id}" from="{a}" to="{b}">{lanes}</edge>"#)
    }

    fn connection(from: &str, to: &str, lanes: (u32, u32), dir: &str) -> String {
        format!(
            r#"<connection from="{from}" to="{to}" fromLane="{}" toLane="{}" dir="{dir}"/>"#,
            lanes.0, lanes.1
        )
    }

    /// An edge named `id` whose one lane arrives along `from` → `to`.
    fn arriving(id: &str, from: (f64, f64), to: (f64, f64)) -> Edge {
        Edge {
            id: id.to_owned(),
            from: String::new(),
            to: "J".to_owned(),
            priority: 1,
            lanes: vec![Lane {
                speed_mps: 13.9,
                width_m: 3.2,
                shape: vec![DVec3::new(from.0, from.1, 0.0), DVec3::new(to.0, to.1, 0.0)],
            }],
            lane_map: vec![Some(0)],
            at: Default::default(),
        }
    }

    #[test]
    fn connections_are_among_car_lanes_in_car_lane_numbers_without_turns_back() {
        let net = read_body(
            &[
                edge(
                    "a",
                    "A",
                    "J",
                    0.0,
                    100.0,
                    &[("pedestrian", -2.0), ("all", 0.0)],
                ),
                edge(
                    "b",
                    "J",
                    "B",
                    110.0,
                    200.0,
                    &[("pedestrian", -2.0), ("all", 0.0)],
                ),
                edge("ba", "B", "J", 200.0, 110.0, &[("all", 3.0)]),
                edge("walk", "J", "W", 110.0, 200.0, &[("pedestrian", -9.0)]),
                connection("a", "b", (1, 1), "s"),
                connection("a", "b", (0, 0), "s"),
                connection("a", "walk", (1, 0), "r"),
                connection("ba", "a", (0, 1), "t"),
                connection("b", "ba", (1, 0), "s"),
            ]
            .join("\n"),
        );
        let kept = car_connections(&net, Path::new("t.net.xml")).expect("known edges");
        let pairs: Vec<(&str, u32, &str, u32)> = kept
            .iter()
            .map(|c| (c.from.as_str(), c.from_lane, c.to.as_str(), c.to_lane))
            .collect();
        // The sidewalks' connection and the footpath are not cars'; `ba` → `a` is a turn back
        // (so marked), `b` → `ba` one by its ends.
        assert_eq!(pairs, [("a", 0, "b", 0)]);
    }

    #[test]
    fn a_connection_to_what_the_network_lacks_is_an_error_at_it() {
        let lanes = [("all", 0.0)];
        let unknown = read_body(
            &[
                edge("a", "A", "J", 0.0, 100.0, &lanes),
                connection("a", "nowhere", (0, 0), "s"),
            ]
            .join("\n"),
        );
        let e = car_connections(&unknown, Path::new("t.net.xml")).expect_err("unknown edge");
        assert_eq!((e.line, e.column), (3, 1));
        assert!(e.message.contains("connection to unknown edge `nowhere`"));
        let lane = read_body(
            &[
                edge("a", "A", "J", 0.0, 100.0, &lanes),
                edge("b", "J", "B", 110.0, 200.0, &lanes),
                connection("a", "b", (0, 2), "s"),
            ]
            .join("\n"),
        );
        let e = car_connections(&lane, Path::new("t.net.xml")).expect_err("no lane 2");
        assert!(e.message.contains("→ b lane 2"), "{}", e.message);
        assert!(e.message.contains("a lane the edge does not have"));
    }

    #[test]
    fn where_a_lane_is_added_the_edges_meet_halfway_and_the_fanned_lane_is_left_out() {
        // One lane going on as two: lane 0 goes straight on into lane 0, and netconvert also
        // fans it out sideways into the added lane 1.
        let mut net = read_body(
            &[
                edge("a", "A", "J", 0.0, 100.0, &[("all", 0.0)]),
                edge("b", "J", "B", 110.0, 200.0, &[("all", 0.0), ("all", 3.2)]),
                connection("a", "b", (0, 0), "s"),
                connection("a", "b", (0, 1), "s"),
            ]
            .join("\n"),
        );
        let mut conns = car_connections(&net, Path::new("t.net.xml")).expect("known");
        close_simple_nodes(&mut net.edges, &mut conns);
        assert_eq!(conns.len(), 1);
        assert_eq!((conns[0].from_lane, conns[0].to_lane), (0, 0));
        let end = *net.edges[0].lanes[0].shape.last().expect("points");
        let start = net.edges[1].lanes[0].shape[0];
        assert_eq!(end, DVec3::new(105.0, 0.0, 0.0));
        assert_eq!(start, end);
        assert_eq!(net.edges[1].lanes[1].shape[0], DVec3::new(105.0, 3.2, 0.0));
    }

    /// Junction `J1` (where `a` meets side road `c`) and `J2` (where `d` joins), half a metre
    /// apart along `a` → `s` → `b`, the connection onto `s` written as `onto_s`.
    fn close_pair(onto_s: &str) -> Net {
        let lanes = [("all", 0.0)];
        read_body(
            &[
                edge("a", "A", "J1", 0.0, 100.0, &lanes),
                edge("s", "J1", "J2", 104.0, 104.5, &lanes),
                edge("b", "J2", "B", 110.0, 200.0, &lanes),
                edge("c", "J1", "C", 104.0, 200.0, &[("all", 20.0)]),
                edge("d", "D", "J2", 0.0, 100.0, &[("all", -20.0)]),
                onto_s.to_owned(),
                connection("a", "c", (0, 0), "l"),
                connection("s", "b", (0, 0), "s"),
                connection("d", "b", (0, 0), "r"),
            ]
            .join("\n"),
        )
    }

    #[test]
    fn junctions_a_car_cannot_stop_between_are_one() {
        let mut net = close_pair(&connection("a", "s", (0, 0), "s"));
        let mut conns = car_connections(&net, Path::new("t.net.xml")).expect("known");
        let merged = merge_close_junctions(&mut net, &mut conns);
        assert_eq!(merged, ["s"]);
        assert!(net.edges.iter().all(|e| e.id != "s"));
        let pairs: Vec<(&str, &str)> = conns
            .iter()
            .map(|c| (c.from.as_str(), c.to.as_str()))
            .collect();
        assert_eq!(pairs, [("a", "c"), ("d", "b"), ("a", "b")]);
        // One node: the second's, as no light controls either.
        let ends = |id: &str| {
            let e = net.edges.iter().find(|e| e.id == id).expect("kept");
            (e.from.clone(), e.to.clone())
        };
        assert_eq!(ends("a").1, "J2");
        assert_eq!(ends("c").0, "J2");
        assert_eq!(ends("d").1, "J2");
    }

    #[test]
    fn merged_junctions_keep_the_light_and_its_link_index() {
        let mut net = close_pair(
            r#"<connection from="a" to="s" fromLane="0" toLane="0" dir="s" tl="J1" linkIndex="3"/>"#,
        );
        let mut conns = car_connections(&net, Path::new("t.net.xml")).expect("known");
        merge_close_junctions(&mut net, &mut conns);
        let across = conns
            .iter()
            .find(|c| c.from == "a" && c.to == "b")
            .expect("across");
        assert_eq!(
            (across.tl.as_deref(), across.link_index),
            (Some("J1"), Some(3))
        );
        // The node with the light is the one kept.
        let b = net.edges.iter().find(|e| e.id == "b").expect("kept");
        assert_eq!(b.from, "J1");
    }

    #[test]
    fn a_real_junction_is_not_closed() {
        let lanes = [("all", 0.0)];
        let mut net = read_body(
            &[
                edge("a", "A", "J", 0.0, 100.0, &lanes),
                edge("b", "J", "B", 110.0, 200.0, &lanes),
                edge("c", "J", "C", 110.0, 200.0, &[("all", 20.0)]),
                connection("a", "b", (0, 0), "s"),
                connection("a", "c", (0, 0), "l"),
            ]
            .join("\n"),
        );
        let mut conns = car_connections(&net, Path::new("t.net.xml")).expect("known");
        close_simple_nodes(&mut net.edges, &mut conns);
        assert_eq!(conns.len(), 2);
        assert_eq!(net.edges[0].lanes[0].shape.len(), 2);
    }

    #[test]
    fn the_fringe_is_where_nothing_leads_on_or_in_and_routes_go_the_fewest_edges() {
        let lanes = [("all", 0.0)];
        let net = read_body(
            &[
                edge("in", "A", "J", 0.0, 100.0, &lanes),
                edge("mid", "J", "K", 100.0, 200.0, &lanes),
                edge("out", "K", "B", 200.0, 300.0, &lanes),
                edge("side", "J", "C", 100.0, 200.0, &lanes),
                connection("in", "mid", (0, 0), "s"),
                connection("in", "side", (0, 0), "r"),
                connection("mid", "out", (0, 0), "s"),
            ]
            .join("\n"),
        );
        let conns = car_connections(&net, Path::new("t.net.xml")).expect("known");
        let fringe = Fringe::of(&net.edges, &conns);
        let ids = |edges: &[&Edge]| edges.iter().map(|e| e.id.clone()).collect::<Vec<_>>();
        assert_eq!(ids(&fringe.sources), ["in"]);
        assert_eq!(ids(&fringe.sinks), ["out", "side"]);
        assert_eq!(
            fringe.routes_from("in"),
            [vec!["in", "mid", "out"], vec!["in", "side"]]
        );
        assert!(fringe.routes_from("out").is_empty());
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
    fn routes_take_the_fewest_edges_and_the_same_way_every_time() {
        let mut next: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
        next.insert("a", BTreeSet::from(["b", "c"]));
        next.insert("b", BTreeSet::from(["d"]));
        next.insert("c", BTreeSet::from(["d"]));
        // d is reached from b, the first in name order at the same depth as c.
        let back = breadth_first(&next, "a");
        assert_eq!(back.get("d"), Some(&Some("b")));
        assert_eq!(back.get("a"), Some(&None));
        assert_eq!(breadth_first(&next, "d").get("a"), None);
    }
}

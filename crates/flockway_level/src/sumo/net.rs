//! The network file as read: SUMO's elements with what the import uses of them, each with the
//! place in the file it came from, before anything is decided about the level.
//!
//! Internal edges (`function="internal"`: SUMO's paths across junctions, walking areas,
//! crossings) and internal junctions are skipped, and so are connections from or to them; lanes
//! cars may not use are marked, and an edge with none is left out with its connections.

use super::{ImportError, parse_xml};
use flockway_road::{Phase, SignalProgram};
use glam::DVec3;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// SUMO's lane width where a lane does not give one, m.
const SUMO_LANE_WIDTH_M: f64 = 3.2;

/// A place in the network file: line and column, from 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(super) struct At {
    pub line: u32,
    pub column: u32,
}

impl At {
    /// An import error here in the file `path`.
    pub fn error(self, path: &Path, message: String) -> ImportError {
        ImportError {
            path: path.to_owned(),
            line: self.line,
            column: self.column,
            message,
        }
    }
}

/// The network as read.
pub(super) struct Net {
    /// The `<net>` element.
    pub at: At,
    /// The edges with a lane cars may use, in file order.
    pub edges: Vec<Edge>,
    /// Edges no car may use (footpaths, cycleways, railways), left out with their connections.
    pub skipped_edges: BTreeSet<String>,
    /// Connections between two edges that are not internal, in file order, in SUMO's lane
    /// numbers.
    pub connections: Vec<Connection>,
    /// Junctions that are not internal, by id.
    pub junctions: BTreeMap<String, Junction>,
    /// Traffic-light programs, by traffic light id (the last read where one has several).
    pub programs: BTreeMap<String, Program>,
    /// What the level will not do as SUMO would (each once).
    pub warnings: Vec<String>,
}

/// One edge as read: its car lanes only (a sidewalk, a bike or a bus lane is left out).
pub(super) struct Edge {
    pub id: String,
    pub from: String,
    pub to: String,
    pub priority: i64,
    pub lanes: Vec<Lane>,
    /// The car lane each of SUMO's lane indices became (`None`: not a car lane).
    pub lane_map: Vec<Option<u32>>,
    pub at: At,
}

/// One lane as read.
pub(super) struct Lane {
    pub speed_mps: f64,
    pub width_m: f64,
    /// Its centre line, `z` kept.
    pub shape: Vec<DVec3>,
}

/// One connection between two edges' lanes as read.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Connection {
    pub from: String,
    pub to: String,
    pub from_lane: u32,
    pub to_lane: u32,
    pub link_index: Option<usize>,
    pub tl: Option<String>,
    /// SUMO's direction `t`: a turn back.
    pub turn_back: bool,
    /// SUMO's link state `M`: a major link no light controls.
    pub major: bool,
    pub at: At,
}

/// One junction as read.
pub(super) struct Junction {
    /// SUMO's type: `priority`, `traffic_light`, `right_before_left`, `allway_stop`, …
    pub kind: String,
    pub at: At,
}

/// One traffic-light program as read.
pub(super) struct Program {
    /// The cycle, each phase's state still empty (it is written per junction, connection by
    /// connection, from `states`).
    pub program: SignalProgram,
    /// Each phase's SUMO state, a letter per link index.
    pub states: Vec<String>,
    pub at: At,
}

/// Reads the network file `text` (at `path`, for errors).
pub(super) fn read(text: &str, path: &Path) -> Result<Net, ImportError> {
    let doc = parse_xml(text, path)?;
    let root = doc.root_element();
    let here = Reader {
        path,
        text,
        line_starts: std::iter::once(0)
            .chain(text.match_indices('\n').map(|(k, _)| k + 1))
            .collect(),
    };
    if root.tag_name().name() != "net" {
        return Err(here.error(
            root,
            format!(
                "expected a SUMO network (a <net> root element, as netconvert writes), found <{}>",
                root.tag_name().name()
            ),
        ));
    }
    let mut net = Net {
        at: here.at(root),
        edges: Vec::new(),
        skipped_edges: BTreeSet::new(),
        connections: Vec::new(),
        junctions: BTreeMap::new(),
        programs: BTreeMap::new(),
        warnings: Vec::new(),
    };
    let mut kinds_run_fixed: BTreeSet<String> = BTreeSet::new();
    for node in root.children().filter(roxmltree::Node::is_element) {
        match node.tag_name().name() {
            "edge" => {
                if node.attribute("function").is_some_and(|f| f != "normal") {
                    continue;
                }
                match here.edge(node)? {
                    Some(edge) => net.edges.push(edge),
                    None => {
                        net.skipped_edges.insert(here.attr(node, "id")?);
                    }
                }
            }
            "connection" => {
                if let Some(c) = here.connection(node)? {
                    net.connections.push(c);
                }
            }
            "junction" => {
                let id = here.attr(node, "id")?;
                if node.attribute("type") == Some("internal") {
                    continue;
                }
                let kind = here.attr(node, "type")?;
                net.junctions.insert(
                    id,
                    Junction {
                        kind,
                        at: here.at(node),
                    },
                );
            }
            "tlLogic" => {
                let (id, program) = here.program(node)?;
                let kind = node.attribute("type").unwrap_or("static");
                if kind != "static" {
                    kinds_run_fixed.insert(kind.to_owned());
                }
                net.programs.insert(id, program);
            }
            _ => {}
        }
    }
    for kind in kinds_run_fixed {
        net.warnings.push(format!(
            "traffic lights with `{kind}` programs run here as fixed-time programs: each phase \
             lasts its `duration` (SUMO's default for that phase; `minDur`, `maxDur` and \
             detectors are not modelled)"
        ));
    }
    if net.edges.is_empty() {
        let message = if net.skipped_edges.is_empty() {
            "the network has no (non-internal) <edge>".to_owned()
        } else {
            format!(
                "the network has no edge passenger cars may use: its {} edges are for other \
                 vehicle classes only (`allow`/`disallow` on their lanes: rail, footpaths, \
                 cycleways, or a class such as `vip`)",
                net.skipped_edges.len()
            )
        };
        return Err(net.at.error(path, message));
    }
    Ok(net)
}

/// Reads elements of the file at `path`, with errors placed in it.
struct Reader<'p> {
    path: &'p Path,
    text: &'p str,
    /// Where each line of `text` starts (byte offsets), so that an element's place is found
    /// without counting the lines before it each time.
    line_starts: Vec<usize>,
}

impl Reader<'_> {
    /// Where `node` starts in the file.
    fn at(&self, node: roxmltree::Node) -> At {
        let offset = node.range().start;
        let line = self.line_starts.partition_point(|&k| k <= offset).max(1);
        let start = self.line_starts[line - 1];
        let column = self
            .text
            .get(start..offset)
            .map_or(0, |t| t.chars().count());
        At {
            line: line as u32,
            column: column as u32 + 1,
        }
    }

    fn error(&self, node: roxmltree::Node, message: String) -> ImportError {
        self.at(node).error(self.path, message)
    }

    /// The attribute `key` of `node`, which must be there.
    fn attr(&self, node: roxmltree::Node, key: &str) -> Result<String, ImportError> {
        node.attribute(key).map(str::to_owned).ok_or_else(|| {
            self.error(
                node,
                format!("<{}> needs a `{key}` attribute", node.tag_name().name()),
            )
        })
    }

    /// The attribute `key` of `node` as a finite number.
    fn number(&self, node: roxmltree::Node, key: &str) -> Result<f64, ImportError> {
        let text = self.attr(node, key)?;
        text.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| self.error(node, format!("`{key}` must be a number, found {text:?}")))
    }

    /// The attribute `key` of `node` as a lane number (0, 1, …).
    fn lane_number(&self, node: roxmltree::Node, key: &str) -> Result<u32, ImportError> {
        let v = self.number(node, key)?;
        if v < 0.0 || v.fract() != 0.0 || v > f64::from(u32::MAX) {
            return Err(self.error(node, format!("`{key}` must be a lane number, found {v}")));
        }
        Ok(v as u32)
    }

    /// An `<edge>` that is not internal: `None` when no car may use any of its lanes.
    fn edge(&self, node: roxmltree::Node) -> Result<Option<Edge>, ImportError> {
        let id = self.attr(node, "id")?;
        let mut lanes: Vec<(u32, bool, Lane)> = Vec::new();
        for lane in node.children().filter(|n| n.has_tag_name("lane")) {
            let index = self.lane_number(lane, "index")?;
            let shape = parse_shape(&self.attr(lane, "shape")?).ok_or_else(|| {
                self.error(
                    lane,
                    "`shape` must be at least two points `x,y` (or `x,y,z`) separated by spaces"
                        .to_owned(),
                )
            })?;
            lanes.push((
                index,
                allows_cars(lane.attribute("allow"), lane.attribute("disallow")),
                Lane {
                    speed_mps: self.number(lane, "speed")?,
                    width_m: lane
                        .attribute("width")
                        .and_then(|w| w.parse().ok())
                        .unwrap_or(SUMO_LANE_WIDTH_M),
                    shape,
                },
            ));
        }
        if lanes.is_empty() {
            return Err(self.error(node, format!("edge `{id}` has no <lane>")));
        }
        lanes.sort_by_key(|(i, ..)| *i);
        if lanes.iter().enumerate().any(|(k, (i, ..))| *i != k as u32) {
            return Err(self.error(
                node,
                format!("edge `{id}`'s lanes must be numbered 0, 1, … without gaps"),
            ));
        }
        // Only the lanes cars may use become lanes.
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
            return Ok(None);
        }
        Ok(Some(Edge {
            from: self.attr(node, "from")?,
            to: self.attr(node, "to")?,
            priority: node
                .attribute("priority")
                .and_then(|p| p.parse().ok())
                .unwrap_or(0),
            id,
            lanes: car_lanes,
            lane_map,
            at: self.at(node),
        }))
    }

    /// A `<connection>`: `None` when it is from or to an internal edge (`:JUNCTION_…`: SUMO's
    /// own inner links, walking areas, crossings), which is not between roads.
    fn connection(&self, node: roxmltree::Node) -> Result<Option<Connection>, ImportError> {
        let from = self.attr(node, "from")?;
        if from.starts_with(':') {
            return Ok(None);
        }
        let to = self.attr(node, "to")?;
        if to.starts_with(':') {
            return Ok(None);
        }
        let link_index = match node.attribute("linkIndex") {
            Some(_) => Some(self.number(node, "linkIndex")? as usize),
            None => None,
        };
        Ok(Some(Connection {
            from_lane: self.lane_number(node, "fromLane")?,
            to_lane: self.lane_number(node, "toLane")?,
            link_index,
            tl: node.attribute("tl").map(str::to_owned),
            turn_back: node.attribute("dir") == Some("t"),
            major: node.attribute("state") == Some("M"),
            from,
            to,
            at: self.at(node),
        }))
    }

    /// A `<tlLogic>`: its id and program.
    fn program(&self, node: roxmltree::Node) -> Result<(String, Program), ImportError> {
        let id = self.attr(node, "id")?;
        let mut phases = Vec::new();
        let mut states = Vec::new();
        for phase in node.children().filter(|n| n.has_tag_name("phase")) {
            let duration_s = self.number(phase, "duration")?;
            if duration_s < 0.0 {
                return Err(self.error(
                    phase,
                    format!("`duration` must not be negative, found {duration_s}"),
                ));
            }
            let state = self.attr(phase, "state")?;
            if let Some(bad) = state.chars().find(|c| signal_letter(*c).is_none()) {
                return Err(self.error(
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
            return Err(self.error(node, format!("traffic light `{id}` has no <phase>")));
        }
        let cycle: f64 = phases.iter().map(|p| p.duration_s).sum();
        let sumo_offset = node
            .attribute("offset")
            .and_then(|o| o.parse::<f64>().ok())
            .unwrap_or(0.0);
        // SUMO starts the program `offset` seconds early... its position at time 0 is −offset
        // in the cycle; ours is where the cycle is at time 0.
        let offset_s = if cycle > 0.0 {
            (-sumo_offset).rem_euclid(cycle)
        } else {
            0.0
        };
        Ok((
            id,
            Program {
                program: SignalProgram { offset_s, phases },
                states,
                at: self.at(node),
            },
        ))
    }
}

/// Our letter for a SUMO signal state letter: `G`, `g` as they are; amber `y`/`Y`; red, and
/// red-amber `u`, as red; off (`o`, `O`) and the stop-sign-like `s` as a green that gives way.
pub(super) fn signal_letter(c: char) -> Option<char> {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// `body` inside a `<net>` element, read as `t.net.xml`.
    fn read_body(body: &str) -> Result<Net, ImportError> {
        read(
            &format!("<net version=\"1.20\">\n{body}\n</net>\n"),
            Path::new("t.net.xml"),
        )
    }

    /// An edge `id` from node `a` to node `b` with one lane along x from 0 to 100.
    fn edge(id: &str, a: &str, b: &str) -> String {
        format!(
            r#"<edge id="{id}" from="{a}" to="{b}" priority="2"><lane id="{id}_0" index="0" speed="13.89" shape="0,0 100,0"/></edge>"#
        )
    }

    #[test]
    fn edges_keep_their_car_lanes_in_order_and_leave_out_internal_and_carless_edges() {
        let net = read_body(concat!(
            r#"<edge id=":J_0" function="internal"><lane id=":J_0_0" index="0" speed="9" shape="0,0 1,0"/></edge>"#,
            "\n",
            r#"<edge id="main" from="A" to="B" priority="3">"#,
            r#"<lane id="main_1" index="1" speed="13.89" width="3.5" shape="0,3.5,2 100,3.5,4"/>"#,
            r#"<lane id="main_0" index="0" speed="13.89" allow="pedestrian" shape="0,0 100,0"/>"#,
            r#"<lane id="main_2" index="2" speed="20" disallow="bicycle" shape="0,7 100,7"/>"#,
            "</edge>\n",
            r#"<edge id="path" from="A" to="B"><lane id="path_0" index="0" speed="2" allow="pedestrian bicycle" shape="0,-5 100,-5"/></edge>"#,
        ))
        .expect("reads");
        assert_eq!(net.edges.len(), 1);
        let main = &net.edges[0];
        assert_eq!((main.id.as_str(), main.priority), ("main", 3));
        // The sidewalk (SUMO lane 0) is left out; lanes 1 and 2 become car lanes 0 and 1.
        assert_eq!(main.lane_map, [None, Some(0), Some(1)]);
        assert_eq!(main.lanes[0].width_m, 3.5);
        assert_eq!(main.lanes[1].width_m, SUMO_LANE_WIDTH_M);
        assert_eq!(main.lanes[1].speed_mps, 20.0);
        // Elevation is kept.
        assert_eq!(main.lanes[0].shape[1], DVec3::new(100.0, 3.5, 4.0));
        assert_eq!(main.at, At { line: 3, column: 1 });
        assert_eq!(net.skipped_edges, BTreeSet::from(["path".to_owned()]));
    }

    #[test]
    fn a_bad_edge_is_an_error_at_its_element() {
        let gap = read_body(concat!(
            r#"<edge id="e" from="A" to="B">"#,
            "\n",
            r#"<lane index="0" speed="9" shape="0,0 1,0"/><lane index="2" speed="9" shape="0,3 1,3"/></edge>"#,
        ))
        .err()
        .expect("lanes with a gap");
        assert_eq!((gap.line, gap.column), (2, 1));
        assert!(gap.message.contains("numbered 0, 1"), "{}", gap.message);
        let no_lane = read_body(r#"<edge id="e" from="A" to="B"/>"#)
            .err()
            .expect("no lane");
        assert!(no_lane.message.contains("has no <lane>"));
        let shape = read_body(
            r#"<edge id="e" from="A" to="B"><lane index="0" speed="9" shape="0,0"/></edge>"#,
        )
        .err()
        .expect("a one-point shape");
        assert_eq!((shape.line, shape.column), (2, 30));
        let index = read_body(
            r#"<edge id="e" from="A" to="B"><lane index="-1" speed="9" shape="0,0 1,0"/></edge>"#,
        )
        .err()
        .expect("a negative index");
        assert!(index.message.contains("`index` must be a lane number"));
        let none =
            read_body(&edge(":J_0", "A", "B").replace("<edge", "<edge function=\"internal\""))
                .err()
                .expect("no edge");
        assert!(none.message.contains("no (non-internal) <edge>"));
    }

    #[test]
    fn a_network_no_car_may_use_is_an_error_that_says_why() {
        let rail = r#"<edge id="r" from="A" to="B"><lane index="0" speed="40" allow="rail" shape="0,0 100,0"/></edge>"#;
        let e = read_body(rail).err().expect("no car edge");
        assert!(
            e.message
                .contains("no edge passenger cars may use: its 1 edges are for other"),
            "{}",
            e.message
        );
    }

    #[test]
    fn connections_between_roads_are_read_and_internal_ones_skipped() {
        let net = read_body(&format!(
            "{}\n{}\n{}\n{}\n{}",
            edge("a", "A", "J"),
            edge("b", "J", "B"),
            r#"<connection from="a" to="b" fromLane="0" toLane="0" via=":J_0_0" tl="J" linkIndex="3" dir="s" state="O"/>"#,
            r#"<connection from=":J_0" to="b" fromLane="0" toLane="0" dir="s" state="M"/>"#,
            r#"<connection from="b" to="a" fromLane="0" toLane="0" dir="t" state="m"/>"#,
        ))
        .expect("reads");
        assert_eq!(net.connections.len(), 2);
        let c = &net.connections[0];
        assert_eq!(
            (
                c.from.as_str(),
                c.to.as_str(),
                c.link_index,
                c.tl.as_deref()
            ),
            ("a", "b", Some(3), Some("J"))
        );
        assert!(!c.turn_back);
        assert!(net.connections[1].turn_back);
        let bad = read_body(&format!(
            "{}\n{}",
            edge("a", "A", "J"),
            r#"<connection from="a" to="b" fromLane="0.5" toLane="0"/>"#
        ))
        .err()
        .expect("a fractional lane");
        assert_eq!((bad.line, bad.column), (3, 1));
        assert!(
            bad.message
                .contains("`fromLane` must be a lane number, found 0.5")
        );
    }

    #[test]
    fn junctions_are_read_by_id_with_internal_ones_skipped() {
        let net = read_body(&format!(
            "{}\n{}\n{}",
            edge("a", "A", "J"),
            r#"<junction id="J" type="traffic_light" x="0" y="0" incLanes="a_0" intLanes="" shape=""/>"#,
            r#"<junction id=":J_0_0" type="internal" x="0" y="0" incLanes="" intLanes=""/>"#,
        ))
        .expect("reads");
        assert_eq!(net.junctions.len(), 1);
        assert_eq!(net.junctions["J"].kind, "traffic_light");
        assert_eq!(net.junctions["J"].at, At { line: 3, column: 1 });
    }

    #[test]
    fn programs_keep_their_phases_and_where_sumo_starts_the_cycle() {
        let net = read_body(&format!(
            "{}\n{}",
            edge("a", "A", "J"),
            r#"<tlLogic id="J" type="static" programID="0" offset="10">
                <phase duration="30" state="GGrr"/>
                <phase duration="3" state="yyrr"/>
                <phase duration="30" state="rrGG"/>
                <phase duration="3" state="rryy"/>
            </tlLogic>"#,
        ))
        .expect("reads");
        let p = &net.programs["J"];
        assert_eq!(p.states, ["GGrr", "yyrr", "rrGG", "rryy"]);
        let durations: Vec<f64> = p.program.phases.iter().map(|p| p.duration_s).collect();
        assert_eq!(durations, [30.0, 3.0, 30.0, 3.0]);
        // SUMO's offset 10 starts the cycle 10 s in: 66 − 10 = 56 s before the cycle's end.
        assert_eq!(p.program.offset_s, 56.0);
        assert!(net.warnings.is_empty());
    }

    #[test]
    fn actuated_programs_run_fixed_time_with_one_warning_per_kind() {
        let program = |id: &str, kind: &str| {
            format!(
                r#"<tlLogic id="{id}" type="{kind}" programID="0" offset="0"><phase duration="31" minDur="5" maxDur="50" state="G"/></tlLogic>"#
            )
        };
        let net = read_body(&format!(
            "{}\n{}\n{}\n{}",
            edge("a", "A", "J"),
            program("J", "actuated"),
            program("K", "actuated"),
            program("L", "delay_based"),
        ))
        .expect("reads");
        assert_eq!(net.programs["K"].program.phases[0].duration_s, 31.0);
        assert_eq!(net.warnings.len(), 2, "{:?}", net.warnings);
        assert!(net.warnings[0].contains("`actuated` programs run here as fixed-time"));
        assert!(net.warnings[1].contains("`delay_based`"));
    }

    #[test]
    fn a_bad_program_is_an_error_at_its_phase() {
        let letter = read_body(&format!(
            "{}\n{}",
            edge("a", "A", "J"),
            "<tlLogic id=\"J\">\n  <phase duration=\"3\" state=\"Gx\"/></tlLogic>",
        ))
        .err()
        .expect("an unknown letter");
        assert_eq!((letter.line, letter.column), (4, 3));
        assert!(letter.message.contains("unknown signal state letter 'x'"));
        let none = read_body(&format!(
            "{}\n{}",
            edge("a", "A", "J"),
            r#"<tlLogic id="J"/>"#
        ))
        .err()
        .expect("no phase");
        assert!(none.message.contains("traffic light `J` has no <phase>"));
    }

    #[test]
    fn another_root_element_is_not_a_network() {
        let e = read("<routes/>", Path::new("r.xml"))
            .err()
            .expect("not a net");
        assert!(e.message.contains("expected a SUMO network"));
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
}

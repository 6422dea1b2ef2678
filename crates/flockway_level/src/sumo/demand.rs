//! SUMO demand (`.rou.xml`) on an imported network: vehicle types become driver profiles,
//! vehicles, trips and flows become spawners' timetables, so the same vehicles leave at the same
//! times on the same routes as in SUMO.
//!
//! What is read: `vType` (`id`, `vClass`, `carFollowModel` or a `carFollowing-*` child, `accel`,
//! `decel`, `tau`, `minGap`, `delta`, `speedFactor` as a number or `norm(mean,dev)`/
//! `normc(mean,dev,min,max)`, `speedDev`, `length`, `maxSpeed`), `route` (`id`, `edges`),
//! `vehicle` (`id`, `type`, `route` or a `route` child or `from`/`to`/`via`, `depart`,
//! `departLane`, `departPos`, `departSpeed`), `trip` (the same with `from`/`to`/`via`) and `flow`
//! (`begin`, `end`, and one of `vehsPerHour`, `period`, `probability`, `number`),
//! `routeDistribution` and `vTypeDistribution` (members as child elements, each with its
//! `probability`, or referred to by `refId`, or listed in `routes`/`vTypes` with
//! `probabilities`): a vehicle whose `route` or `type` names one draws a member for itself, with
//! the level's seed.

use super::{ImportError, LaneMaps, error_at, parse_xml};
use crate::schema::{
    DepartureSpec, DestroyerPlaceSpec, DestroyerSpec, DriverModel, DriverProfileSpec, Level,
    ProfileShare, Range, RouteSpec, SpawnerSpec,
};
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};
use std::collections::{BTreeMap, BTreeSet, BinaryHeap};
use std::path::{Path, PathBuf};

/// How near a route's next edge must start to where its edge ends, and end to where it starts,
/// m, for a step between them no connection makes to be a turn back (the two directions of a
/// street, their ends a few lanes apart at each node).
const TURN_BACK_M: f64 = 20.0;

/// The vehicle classes driven as the level's sedan; other classes are skipped and counted.
const CAR_CLASSES: [&str; 6] = [
    "passenger",
    "private",
    "taxi",
    "delivery",
    "evehicle",
    "emergency",
];
/// SUMO's default vehicle type.
const DEFAULT_VTYPE: &str = "DEFAULT_VEHTYPE";
/// Where a departure with SUMO's default position (`base`) starts on its edge, m.
const DEPART_S_M: f64 = 5.0;
/// A route whose first edge is shorter than this, m, starts on its next edge.
const SHORTEST_DEPART_EDGE_M: f64 = 10.0;
/// Time a run goes on after the last departure, s (for the last vehicles to arrive).
const AFTER_LAST_S: f64 = 300.0;
/// The shortest run a level with demand gets, s.
const LEAST_DURATION_S: f64 = 600.0;
/// The longest stretch of demand expanded, s (a flow with no end runs for a day in SUMO).
const LONGEST_S: f64 = 86_400.0;
/// How far before the end of the edge a route ends on a vehicle arrives, m.
const ARRIVE_BEFORE_END_M: f64 = 2.0;

/// What an import did, for the command to report: what the demand added, and what the level
/// does not do as SUMO would (the network's warnings first, then the demand's).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DemandReport {
    /// Vehicles in the timetables.
    pub vehicles: usize,
    /// Vehicles left out, by vehicle class (classes the sedan does not stand for).
    pub skipped: BTreeMap<String, usize>,
    /// Things read but not modelled as SUMO would (each once): the network's, then the demand's.
    pub warnings: Vec<String>,
}

/// A vehicle type as read.
#[derive(Debug, Clone)]
struct VType {
    class: String,
    model: String,
    attrs: BTreeMap<String, String>,
}

/// One vehicle to depart.
struct Trip {
    time_s: f64,
    vtype: String,
    route: String,
    lane: DepartLane,
    pos_m: Option<f64>,
    speed_kmh: Option<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum DepartLane {
    /// A lane that leads on along the route (SUMO's `best`, `best_prob` - its default -,
    /// `free`, `allowed`).
    Best,
    /// The rightmost (SUMO's `first`).
    First,
    /// One drawn at random.
    Random,
    /// This car lane.
    Index(u32),
}

/// The demand being read: across files, types and routes are shared.
struct Reader<'a> {
    level: &'a Level,
    lane_maps: &'a LaneMaps,
    /// Edges the import left out inside junctions: routes pass over them.
    inside_junctions: &'a BTreeSet<String>,
    vtypes: BTreeMap<String, VType>,
    routes: BTreeMap<String, Vec<String>>,
    /// Route distributions: member route ids with their probabilities.
    route_dists: BTreeMap<String, Vec<(String, f64)>>,
    /// Vehicle type distributions: member type ids with their probabilities.
    type_dists: BTreeMap<String, Vec<(String, f64)>>,
    trips: Vec<Trip>,
    report: DemandReport,
    rng: ChaCha8Rng,
    /// The file being read.
    file: PathBuf,
    /// Trips and flows left out because their destination cannot be reached or their route
    /// turns back.
    unroutable: usize,
    /// Routes defined on their own that turn back, which imported levels leave out: why.
    turning_back: BTreeMap<String, String>,
}

/// Reads a SUMO network and the demand in `routes` (each file's path and text, read in order:
/// types and routes before the vehicles that use them) into a level named `name`.
pub fn import_sumo(
    net: &str,
    net_path: &Path,
    name: &str,
    routes: &[(PathBuf, String)],
) -> Result<(Level, DemandReport), ImportError> {
    let super::Imported {
        mut level,
        lane_maps,
        warnings: net_warnings,
        inside_junctions,
    } = super::import_net(net, net_path, name, !routes.is_empty())?;
    if routes.is_empty() {
        let report = DemandReport {
            warnings: net_warnings,
            ..DemandReport::default()
        };
        return Ok((level, report));
    }
    let mut report = apply_demand(&mut level, &lane_maps, &inside_junctions, routes)?;
    report.warnings.splice(0..0, net_warnings);
    let names: Vec<String> = routes
        .iter()
        .map(|(p, _)| {
            p.file_name().map_or_else(
                || p.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            )
        })
        .collect();
    level.description = format!(
        "{} With the SUMO demand {}: its {} vehicles leave at their times on their routes.",
        level.description,
        names.join(", "),
        report.vehicles
    );
    Ok((level, report))
}

/// Puts the demand in `files` (path and text, read in order) on `level`, imported from a
/// network with these lane maps and these edges left out inside junctions: its spawners are
/// replaced by timetables, its profiles by the demand's vehicle types.
pub(crate) fn apply_demand(
    level: &mut Level,
    lane_maps: &LaneMaps,
    inside_junctions: &BTreeSet<String>,
    files: &[(PathBuf, String)],
) -> Result<DemandReport, ImportError> {
    let mut reader = Reader {
        level,
        lane_maps,
        inside_junctions,
        vtypes: BTreeMap::new(),
        routes: BTreeMap::new(),
        route_dists: BTreeMap::new(),
        type_dists: BTreeMap::new(),
        trips: Vec::new(),
        report: DemandReport::default(),
        rng: ChaCha8Rng::seed_from_u64(level.seed),
        file: PathBuf::new(),
        unroutable: 0,
        turning_back: BTreeMap::new(),
    };
    reader.vtypes.insert(
        DEFAULT_VTYPE.to_owned(),
        VType {
            class: "passenger".to_owned(),
            model: "Krauss".to_owned(),
            attrs: BTreeMap::new(),
        },
    );
    for (path, text) in files {
        reader.file(path, text)?;
    }
    let Reader {
        vtypes,
        routes,
        mut trips,
        mut report,
        mut rng,
        unroutable,
        ..
    } = reader;
    if unroutable > 1 {
        report
            .warnings
            .push(format!("{unroutable} trips and flows left out in all"));
    }
    if trips.is_empty() {
        let path = files.first().map_or_else(PathBuf::new, |(p, _)| p.clone());
        return Err(ImportError {
            path,
            line: 1,
            column: 1,
            message: "the demand has no vehicle a car can drive (no <vehicle>, <trip> or <flow> \
                      of class passenger, taxi or delivery)"
                .to_owned(),
        });
    }
    trips.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    report.vehicles = trips.len();
    // Profiles: one per vehicle type used, named as the type.
    let used: BTreeSet<&str> = trips.iter().map(|t| t.vtype.as_str()).collect();
    level.driver_profiles = used
        .iter()
        .filter_map(|id| Some(profile(id, vtypes.get(*id)?, &mut report.warnings)))
        .collect();
    // Spawners: one per edge, lane and position departures use.
    let mut spawners: BTreeMap<(String, u32, u64), SpawnerSpec> = BTreeMap::new();
    let mut arrivals: BTreeSet<String> = BTreeSet::new();
    let mut best_turns: BTreeMap<String, usize> = BTreeMap::new();
    let sinks: BTreeSet<String> = level
        .destroyers
        .iter()
        .filter_map(|d| match &d.place {
            DestroyerPlaceSpec::OnRoad { road, .. } => Some(road.clone()),
            DestroyerPlaceSpec::Volume { .. } => None,
        })
        .collect();
    for trip in &trips {
        // Every trip's route was read (and checked against the level) before it was made.
        let Some(route) = routes.get(&trip.route) else {
            continue;
        };
        let mut roads = route.as_slice();
        // A stub of an edge (a joined cluster leaves some under a metre long) has no room for a
        // car: such a route starts on the next edge.
        while roads.len() > 1
            && level
                .road(&roads[0])
                .is_some_and(|r| road_length(r) < SHORTEST_DEPART_EDGE_M)
        {
            roads = &roads[1..];
        }
        let roads = roads.to_vec();
        let (Some(first), Some(last)) = (roads.first(), roads.last()) else {
            continue;
        };
        let Some(road) = level.road(first) else {
            continue;
        };
        let lanes = road.lanes;
        let lane = match trip.lane {
            DepartLane::Index(k) => k.min(lanes.saturating_sub(1)),
            DepartLane::First => 0,
            DepartLane::Random => (rng.next_u64() % u64::from(lanes.max(1))) as u32,
            DepartLane::Best => {
                let leading = leading_lanes(level, first, roads.get(1).map(String::as_str));
                // In turn over the lanes that lead on, as SUMO's `best` and `free` fill the
                // emptiest of them.
                let turn = best_turns.entry(first.clone()).or_insert(0);
                *turn += 1;
                leading[(*turn - 1) % leading.len()]
            }
        };
        let length = road_length(road);
        let start = DEPART_S_M.min(0.5 * length);
        let s_m = trip
            .pos_m
            .map_or(start, |p| p.clamp(start, (length - 1.0).max(start)));
        let key = (first.clone(), lane, (s_m * 100.0).round() as u64);
        let sp = spawners.entry(key).or_insert_with(|| {
            let name = if s_m == start {
                format!("{first} lane {lane}")
            } else {
                format!("{first} lane {lane} at {s_m} m")
            };
            let every = Range { min: 1.0, max: 1.0 };
            SpawnerSpec::new(&name, first, lane, s_m, every, Vec::new())
        });
        if !sp.profiles.iter().any(|p| p.profile == trip.vtype) {
            sp.profiles.push(ProfileShare {
                profile: trip.vtype.clone(),
                weight: 1.0,
            });
        }
        if !sp.routes.iter().any(|r| r.name == trip.route) {
            sp.routes.push(RouteSpec {
                name: trip.route.clone(),
                roads: roads.clone(),
                weight: 1.0,
            });
        }
        sp.departures.push(DepartureSpec {
            time_s: trip.time_s,
            profile: trip.vtype.clone(),
            route: Some(trip.route.clone()),
            speed_kmh: trip.speed_kmh,
        });
        if !sinks.contains(last) {
            arrivals.insert(last.clone());
        }
    }
    level.spawners = spawners.into_values().collect();
    for road in arrivals {
        let length = level.road(&road).map_or(0.0, road_length);
        level.destroyers.push(DestroyerSpec {
            name: format!("arrive {road}"),
            place: DestroyerPlaceSpec::OnRoad {
                road,
                s_m: (length - ARRIVE_BEFORE_END_M).max(0.5 * length),
            },
            arrivals_only: true,
        });
    }
    let last = trips.last().map_or(0.0, |t| t.time_s);
    level.duration_s = (last + AFTER_LAST_S).max(LEAST_DURATION_S);
    // Every vehicle counts, from the first: the demand starts the run as it starts SUMO's.
    level.telemetry.stats_from_s = 0.0;
    Ok(report)
}

impl Reader<'_> {
    fn file(&mut self, path: &Path, text: &str) -> Result<(), ImportError> {
        self.file = path.to_owned();
        let doc = parse_xml(text, path)?;
        let at = |node: roxmltree::Node, message: String| error_at(path, node, message);
        let root = doc.root_element();
        if !matches!(root.tag_name().name(), "routes" | "additional") {
            return Err(at(
                root,
                format!(
                    "expected SUMO demand (a <routes> root element, as a .rou.xml has), found <{}>",
                    root.tag_name().name()
                ),
            ));
        }
        for node in root.children().filter(roxmltree::Node::is_element) {
            match node.tag_name().name() {
                "vType" => self.vtype(node).map_err(|m| at(node, m))?,
                "route" => {
                    let id = need(node, "id").map_err(|m| at(node, m))?;
                    let edges = self.known_route_edges(node).map_err(|m| at(node, m))?;
                    // The vehicles on a route that turns back are left out where they name it.
                    match self.undrivable(&edges) {
                        Some(Ok(why)) => {
                            self.turning_back.insert(id.to_owned(), why);
                        }
                        Some(Err(why)) => return Err(at(node, why)),
                        None => {
                            self.routes.insert(id.to_owned(), edges);
                        }
                    }
                }
                "vehicle" | "trip" => self.vehicle(node).map_err(|m| at(node, m))?,
                "flow" => self.flow(node).map_err(|m| at(node, m))?,
                "routeDistribution" => {
                    self.route_distribution(node, &at)?;
                }
                "vTypeDistribution" => {
                    self.type_distribution(node, &at)?;
                }
                "person" | "personFlow" | "container" | "containerFlow" => {
                    *self
                        .report
                        .skipped
                        .entry(node.tag_name().name().to_owned())
                        .or_insert(0) += 1;
                }
                // Stops, parameters, intervals of other tools: nothing a car's trip needs.
                _ => {}
            }
        }
        Ok(())
    }

    /// A `<routeDistribution>`: its routes (defined inside, or `refId`s of routes defined
    /// before, or listed in `routes`) with their probabilities.
    fn route_distribution(
        &mut self,
        node: roxmltree::Node,
        at: &dyn Fn(roxmltree::Node, String) -> ImportError,
    ) -> Result<(), ImportError> {
        let id = need(node, "id").map_err(|m| at(node, m))?.to_owned();
        let mut members = listed(node, "routes").map_err(|m| at(node, m))?;
        for (k, child) in node
            .children()
            .filter(|n| n.has_tag_name("route"))
            .enumerate()
        {
            let probability = probability(child).map_err(|m| at(child, m))?;
            let route = match child.attribute("refId") {
                Some(r) => r.to_owned(),
                None => {
                    let edges = self.route_edges(child).map_err(|m| at(child, m))?;
                    // SUMO names a member without an id after the distribution.
                    let own = child
                        .attribute("id")
                        .map_or_else(|| format!("{id}#{k}"), str::to_owned);
                    self.routes.insert(own.clone(), edges);
                    own
                }
            };
            members.push((route, probability));
        }
        check_members("routeDistribution", &id, "route", &members, |r| {
            self.routes.contains_key(r)
        })
        .map_err(|m| at(node, m))?;
        self.route_dists.insert(id, members);
        Ok(())
    }

    /// A `<vTypeDistribution>`: its types (defined inside, or listed in `vTypes`) with their
    /// probabilities.
    fn type_distribution(
        &mut self,
        node: roxmltree::Node,
        at: &dyn Fn(roxmltree::Node, String) -> ImportError,
    ) -> Result<(), ImportError> {
        let id = need(node, "id").map_err(|m| at(node, m))?.to_owned();
        let mut members = listed(node, "vTypes").map_err(|m| at(node, m))?;
        for child in node.children().filter(|n| n.has_tag_name("vType")) {
            let probability = probability(child).map_err(|m| at(child, m))?;
            self.vtype(child).map_err(|m| at(child, m))?;
            members.push((
                need(child, "id").map_err(|m| at(child, m))?.to_owned(),
                probability,
            ));
        }
        check_members("vTypeDistribution", &id, "vType", &members, |t| {
            self.vtypes.contains_key(t)
        })
        .map_err(|m| at(node, m))?;
        self.type_dists.insert(id, members);
        Ok(())
    }

    /// The type one vehicle of type `vtype` has: itself, or drawn from the distribution of
    /// that name; `None` (counted) when the type drawn is not a car's.
    fn draw_type(&mut self, vtype: &str) -> Option<String> {
        let Some(members) = self.type_dists.get(vtype) else {
            return Some(vtype.to_owned());
        };
        let drawn = draw(members, &mut self.rng);
        let class = self.vtypes.get(&drawn).map(|t| t.class.clone())?;
        if CAR_CLASSES.contains(&class.as_str()) {
            Some(drawn)
        } else {
            *self.report.skipped.entry(class).or_insert(0) += 1;
            None
        }
    }

    fn vtype(&mut self, node: roxmltree::Node) -> Result<(), String> {
        let id = need(node, "id")?.to_owned();
        let mut attrs: BTreeMap<String, String> = node
            .attributes()
            .map(|a| (a.name().to_owned(), a.value().to_owned()))
            .collect();
        let mut model = attrs
            .get("carFollowModel")
            .cloned()
            .unwrap_or_else(|| "Krauss".to_owned());
        for child in node.children().filter(roxmltree::Node::is_element) {
            if let Some(m) = child.tag_name().name().strip_prefix("carFollowing-") {
                model = m.to_owned();
                for a in child.attributes() {
                    attrs.insert(a.name().to_owned(), a.value().to_owned());
                }
            }
        }
        for key in [
            "accel", "decel", "tau", "minGap", "delta", "length", "maxSpeed", "speedDev",
        ] {
            if let Some(v) = attrs.get(key)
                && v.trim()
                    .parse::<f64>()
                    .ok()
                    .is_none_or(|x| !x.is_finite() || x < 0.0)
            {
                return Err(format!(
                    "vType `{id}`: `{key}` must be a number ≥ 0, found {v:?}"
                ));
            }
        }
        if let Some(f) = attrs.get("speedFactor") {
            speed_factor(f).ok_or_else(|| {
                format!(
                    "vType `{id}`: `speedFactor` must be a number or norm(mean,dev) or \
                     normc(mean,dev,min,max), found {f:?}"
                )
            })?;
        }
        let class = attrs
            .get("vClass")
            .cloned()
            .unwrap_or_else(|| "passenger".to_owned());
        self.vtypes.insert(
            id,
            VType {
                class,
                model,
                attrs,
            },
        );
        Ok(())
    }

    /// A route element's edges, checked: each known and leading onto the next.
    fn route_edges(&self, node: roxmltree::Node) -> Result<Vec<String>, String> {
        let edges = self.known_route_edges(node)?;
        match self.unconnected(&edges) {
            Some(why) => Err(format!("{why} (imported levels leave out turns back)")),
            None => Ok(edges),
        }
    }

    /// Where a route's edges first do not lead one onto the next, said; `None` when each
    /// leads onto the next.
    fn unconnected(&self, edges: &[String]) -> Option<String> {
        edges
            .windows(2)
            .find(|pair| !self.level.leads_to(&pair[0]).contains(&pair[1].as_str()))
            .map(|pair| {
                format!(
                    "edge `{}` does not lead onto `{}`: no connection between their car lanes",
                    pair[0], pair[1]
                )
            })
    }

    /// Whether a route's edges that do not lead one onto the next ([`Self::unconnected`]) only
    /// turn back, and why it cannot be driven: `Some(Ok(why))` when it turns back (SUMO turns
    /// there; the vehicles are left out), `Some(Err(why))` when it jumps between edges that do
    /// not meet (a mistake in the demand), `None` when it can be driven.
    fn undrivable(&self, edges: &[String]) -> Option<Result<String, String>> {
        let why = self.unconnected(edges)?;
        Some(if self.only_turns_back(edges) {
            Ok(format!(
                "{why} (it turns back there, which imported levels leave out)"
            ))
        } else {
            Err(why)
        })
    }

    /// Whether every step of `edges` that no connection makes goes back the way it came (the
    /// next edge runs from about where this one ends to about where it starts): SUMO turns
    /// there, the imported level cannot. A step between edges that do not meet at all is a
    /// mistake in the demand, not a turn.
    fn only_turns_back(&self, edges: &[String]) -> bool {
        let ends = |name: &str| {
            let points = &self.level.road(name)?.points;
            Some((points.first()?.pos, points.last()?.pos))
        };
        edges
            .windows(2)
            .filter(|pair| !self.level.leads_to(&pair[0]).contains(&pair[1].as_str()))
            .all(|pair| match (ends(&pair[0]), ends(&pair[1])) {
                (Some((a0, a1)), Some((b0, b1))) => {
                    a1.distance(b0) < TURN_BACK_M && b1.distance(a0) < TURN_BACK_M
                }
                _ => false,
            })
    }

    /// A route element's edges, each known.
    fn known_route_edges(&self, node: roxmltree::Node) -> Result<Vec<String>, String> {
        let edges: Vec<String> = need(node, "edges")?
            .split_whitespace()
            .filter(|e| !self.inside_junctions.contains(*e))
            .map(str::to_owned)
            .collect();
        if edges.is_empty() {
            return Err("a route needs at least one edge in `edges`".to_owned());
        }
        for e in &edges {
            self.known_edge(e)?;
        }
        Ok(edges)
    }

    fn known_edge(&self, e: &str) -> Result<(), String> {
        // The lane maps name exactly the level's roads, and are a map.
        if self.lane_maps.contains_key(e) {
            Ok(())
        } else if self.inside_junctions.contains(e) {
            Err(format!(
                "edge `{e}` lies inside a junction of the imported level (it is shorter than \
                 3 m between two junctions): start or end the trip on an edge before or after it"
            ))
        } else {
            Err(format!(
                "unknown edge `{e}`: it is not in the network, or it has no lane cars may use"
            ))
        }
    }

    /// The route a vehicle, trip or flow takes: its `route` (an id, or a child element), or
    /// the quickest path from `from` through each of `via` to `to`. Named after `own` when it
    /// is its own.
    /// `Ok(Err(why))` when the imported network cannot take it: a trip's destination cannot be
    /// reached, or its route turns back.
    fn route_of(
        &mut self,
        node: roxmltree::Node,
        own: &str,
    ) -> Result<Result<String, String>, String> {
        if let Some(child) = node.children().find(|n| n.has_tag_name("route")) {
            let edges = self.known_route_edges(child)?;
            if let Some(why) = self.undrivable(&edges) {
                return why.map(Err);
            }
            self.routes.insert(own.to_owned(), edges);
            return Ok(Ok(own.to_owned()));
        }
        if let Some(id) = node.attribute("route") {
            if let Some(why) = self.turning_back.get(id) {
                return Ok(Err(format!("route `{id}`: {why}")));
            }
            return if self.routes.contains_key(id) || self.route_dists.contains_key(id) {
                Ok(Ok(id.to_owned()))
            } else {
                Err(format!(
                    "unknown route `{id}` (routes must be defined before use)"
                ))
            };
        }
        let (Some(from), Some(to)) = (node.attribute("from"), node.attribute("to")) else {
            return Err(format!(
                "<{}> needs a `route`, a <route> inside it, or `from` and `to` edges",
                node.tag_name().name()
            ));
        };
        let mut stops = vec![from];
        stops.extend(
            node.attribute("via")
                .into_iter()
                .flat_map(str::split_whitespace),
        );
        stops.push(to);
        for e in &stops {
            self.known_edge(e)?;
        }
        let mut edges: Vec<String> = vec![from.to_owned()];
        for pair in stops.windows(2) {
            let Some(leg) = quickest(self.level, pair[0], pair[1]) else {
                return Ok(Err(
                    "its destination cannot be reached from where it departs on the imported \
                     network (SUMO's way may turn back, which imported levels leave out)"
                        .to_owned(),
                ));
            };
            edges.extend(leg.into_iter().skip(1));
        }
        self.routes.insert(own.to_owned(), edges);
        Ok(Ok(own.to_owned()))
    }

    /// Counts a trip or flow the imported network cannot take (`why`: its destination cannot
    /// be reached, its route turns back), naming the first in a warning.
    fn unroutable(&mut self, node: roxmltree::Node, id: &str, why: &str) {
        self.unroutable += 1;
        if self.unroutable == 1 {
            let place = error_at(
                &self.file,
                node,
                format!("`{id}`: {why}; such trips are left out"),
            );
            self.report.warnings.push(place.to_string());
        }
    }

    /// The vehicle type `node` names (SUMO's default if none); `None` when its class is not
    /// a car's (counted).
    fn type_of(&mut self, node: roxmltree::Node) -> Result<Option<String>, String> {
        let id = node.attribute("type").unwrap_or(DEFAULT_VTYPE);
        // A distribution: each vehicle draws its type (`draw_type`).
        if self.type_dists.contains_key(id) {
            return Ok(Some(id.to_owned()));
        }
        let Some(t) = self.vtypes.get(id) else {
            return Err(format!(
                "unknown vType `{id}` (types must be defined before use)"
            ));
        };
        if CAR_CLASSES.contains(&t.class.as_str()) {
            Ok(Some(id.to_owned()))
        } else {
            *self.report.skipped.entry(t.class.clone()).or_insert(0) += 1;
            Ok(None)
        }
    }

    fn vehicle(&mut self, node: roxmltree::Node) -> Result<(), String> {
        let id = need(node, "id")?.to_owned();
        let Some(vtype) = self.type_of(node)? else {
            return Ok(());
        };
        let time_s = time(need(node, "depart")?)
            .ok_or_else(|| format!("vehicle `{id}`: `depart` must be a time in seconds"))?;
        let route = match self.route_of(node, &id)? {
            Ok(route) => route,
            Err(why) => {
                self.unroutable(node, &id, &why);
                return Ok(());
            }
        };
        if let Some(vtype) = self.draw_type(&vtype) {
            let trip = self.trip(node, time_s, vtype, route)?;
            self.trips.push(trip);
        }
        Ok(())
    }

    fn flow(&mut self, node: roxmltree::Node) -> Result<(), String> {
        let id = need(node, "id")?.to_owned();
        let Some(vtype) = self.type_of(node)? else {
            return Ok(());
        };
        let number_attr = |key: &str| -> Result<Option<f64>, String> {
            node.attribute(key)
                .map(|v| {
                    time(v).filter(|x| *x >= 0.0).ok_or_else(|| {
                        format!("flow `{id}`: `{key}` must be a number ≥ 0, found {v:?}")
                    })
                })
                .transpose()
        };
        let begin = number_attr("begin")?.unwrap_or(0.0);
        let end = number_attr("end")?;
        let number = number_attr("number")?;
        let route = match self.route_of(node, &id)? {
            Ok(route) => route,
            Err(why) => {
                self.unroutable(node, &id, &why);
                return Ok(());
            }
        };
        let rates: Vec<&str> = ["vehsPerHour", "period", "probability", "number"]
            .into_iter()
            .filter(|k| node.attribute(*k).is_some())
            .collect();
        let end = end.unwrap_or(LONGEST_S).min(begin + LONGEST_S);
        if end < begin {
            return Err(format!(
                "flow `{id}`: `end` {end} is before `begin` {begin}"
            ));
        }
        let mut times = Vec::new();
        let first = rates.first().copied();
        let one_rate = rates.len() == 1 || number.is_some();
        let exp_rate = node
            .attribute("period")
            .and_then(|t| t.trim().strip_prefix("exp(")?.strip_suffix(')'));
        match first {
            Some("period") if one_rate && exp_rate.is_some() => {
                let text = exp_rate.unwrap_or_default();
                let rate: f64 = text
                    .trim()
                    .parse()
                    .ok()
                    .filter(|r: &f64| *r > 0.0)
                    .ok_or_else(|| {
                        format!("flow `{id}`: `period` exp(rate) needs a rate > 0, found {text:?}")
                    })?;
                // Poisson arrivals: exponential gaps with mean 1 / rate.
                let mut t = begin;
                loop {
                    t += -libm::log(1.0 - uniform(&mut self.rng)) / rate;
                    if t >= end || number.is_some_and(|n| times.len() as f64 >= n) {
                        break;
                    }
                    times.push(t);
                }
            }
            Some("vehsPerHour") | Some("period") if one_rate => {
                let period = if first == Some("vehsPerHour") {
                    let vph = number_attr("vehsPerHour")?.unwrap_or(0.0);
                    if vph <= 0.0 {
                        return Ok(());
                    }
                    3600.0 / vph
                } else {
                    number_attr("period")?
                        .filter(|p| *p > 0.0)
                        .ok_or_else(|| format!("flow `{id}`: `period` must be > 0"))?
                };
                let mut k = 0.0;
                while begin + k * period < end && number.is_none_or(|n| k < n) {
                    times.push(begin + k * period);
                    k += 1.0;
                }
            }
            Some("probability") if one_rate => {
                let p = number_attr("probability")?.unwrap_or(0.0);
                if !(0.0..=1.0).contains(&p) {
                    return Err(format!("flow `{id}`: `probability` must be from 0 to 1"));
                }
                // One draw per second, as SUMO inserts such a flow.
                let mut t = begin;
                while t < end && number.is_none_or(|n| (times.len() as f64) < n) {
                    if uniform(&mut self.rng) < p {
                        times.push(t);
                    }
                    t += 1.0;
                }
            }
            Some("number") => {
                let n = number.unwrap_or(0.0).floor();
                if node.attribute("end").is_none() {
                    return Err(format!(
                        "flow `{id}`: `number` alone needs `end` (vehicles spread evenly over begin..end)"
                    ));
                }
                let period = (end - begin) / n.max(1.0);
                for k in 0..n as u64 {
                    times.push(begin + k as f64 * period);
                }
            }
            _ => {
                return Err(format!(
                    "flow `{id}` needs one of `vehsPerHour`, `period`, `probability` or `number` \
                     (found {})",
                    if rates.is_empty() {
                        "none".to_owned()
                    } else {
                        rates.join(", ")
                    }
                ));
            }
        }
        for t in times {
            if let Some(vtype) = self.draw_type(&vtype) {
                let trip = self.trip(node, t, vtype, route.clone())?;
                self.trips.push(trip);
            }
        }
        Ok(())
    }

    /// A departure's lane, position and speed from SUMO's `departLane`, `departPos` and
    /// `departSpeed`.
    fn trip(
        &mut self,
        node: roxmltree::Node,
        time_s: f64,
        vtype: String,
        route: String,
    ) -> Result<Trip, String> {
        let route = match self.route_dists.get(&route) {
            Some(members) => draw(members, &mut self.rng),
            None => route,
        };
        let Some(first) = self.routes.get(&route).and_then(|r| r.first()).cloned() else {
            return Err(format!("unknown route `{route}`"));
        };
        // Without the attribute a vehicle departs as SUMO (1.28) departs it by default
        // (`--default.departlane best_prob`, `--default.departspeed avg`): on a lane that leads
        // on, at the speed the traffic there allows.
        let lane = match node.attribute("departLane") {
            Some("first") => DepartLane::First,
            None | Some("best" | "free" | "allowed" | "best_prob" | "first_allowed") => {
                DepartLane::Best
            }
            Some("random") => DepartLane::Random,
            Some(v) => {
                let k: usize = v.trim().parse().map_err(|_| {
                    format!("`departLane` must be a lane index, best, free, allowed, first or random, found {v:?}")
                })?;
                let map = self.lane_maps.get(&first).cloned().unwrap_or_default();
                match map.get(k) {
                    Some(Some(car)) => DepartLane::Index(*car),
                    _ => {
                        return Err(format!(
                            "`departLane` {k}: edge `{first}` has no such lane cars may use"
                        ));
                    }
                }
            }
        };
        let pos_m = match node.attribute("departPos") {
            None | Some("base" | "free" | "random_free" | "last" | "stop") => None,
            Some("random") => {
                let length = self.level.road(&first).map_or(0.0, road_length);
                Some(uniform(&mut self.rng) * length)
            }
            Some(v) => Some(v.trim().parse::<f64>().ok().filter(|x| x.is_finite()).ok_or_else(
                || format!("`departPos` must be a position in metres, base, random or free, found {v:?}"),
            )?),
        };
        let speed_kmh = match node.attribute("departSpeed") {
            None | Some("max" | "desired" | "speedLimit" | "last" | "avg" | "random") => None,
            Some(v) => Some(
                v.trim()
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite() && *x >= 0.0)
                    .ok_or_else(|| {
                        format!("`departSpeed` must be a speed in m/s, max or desired, found {v:?}")
                    })?
                    * 3.6,
            ),
        };
        Ok(Trip {
            time_s,
            vtype,
            route,
            lane,
            pos_m,
            speed_kmh,
        })
    }
}

/// A member's `probability` (1 when not given), a number ≥ 0.
fn probability(node: roxmltree::Node) -> Result<f64, String> {
    match node.attribute("probability") {
        None => Ok(1.0),
        Some(v) => v
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|p| p.is_finite() && *p >= 0.0)
            .ok_or_else(|| format!("`probability` must be a number ≥ 0, found {v:?}")),
    }
}

/// The members a distribution lists in its attribute `key` (`routes` or `vTypes`), with their
/// `probabilities` (each 1 when not given).
fn listed(node: roxmltree::Node, key: &str) -> Result<Vec<(String, f64)>, String> {
    let Some(ids) = node.attribute(key) else {
        return Ok(Vec::new());
    };
    let ids: Vec<&str> = ids.split([' ', ',']).filter(|s| !s.is_empty()).collect();
    let probabilities: Vec<f64> = match node.attribute("probabilities") {
        None => vec![1.0; ids.len()],
        Some(list) => list
            .split([' ', ','])
            .filter(|s| !s.is_empty())
            .map(|v| v.parse::<f64>().ok().filter(|p| p.is_finite() && *p >= 0.0))
            .collect::<Option<Vec<f64>>>()
            .ok_or_else(|| format!("`probabilities` must be numbers ≥ 0, found {list:?}"))?,
    };
    if probabilities.len() != ids.len() {
        return Err(format!(
            "`{key}` lists {} and `probabilities` {}: one each",
            ids.len(),
            probabilities.len()
        ));
    }
    Ok(ids
        .into_iter()
        .map(str::to_owned)
        .zip(probabilities)
        .collect())
}

/// Checks the members of the distribution `<kind id>`, each a `what`: every one `known`
/// (defined before use), at least one with a probability above 0.
fn check_members(
    kind: &str,
    id: &str,
    what: &str,
    members: &[(String, f64)],
    known: impl Fn(&str) -> bool,
) -> Result<(), String> {
    if let Some((member, _)) = members.iter().find(|(m, _)| !known(m)) {
        return Err(format!(
            "{kind} `{id}`: unknown {what} `{member}` ({what}s must be defined before use)"
        ));
    }
    if members.iter().all(|(_, p)| *p <= 0.0) {
        return Err(format!(
            "{kind} `{id}` needs a {what} with a probability > 0"
        ));
    }
    Ok(())
}

/// A member drawn from `members` in proportion to their probabilities.
fn draw(members: &[(String, f64)], rng: &mut ChaCha8Rng) -> String {
    let total: f64 = members.iter().map(|(_, p)| p.max(0.0)).sum();
    let mut x = uniform(rng) * total;
    for (id, p) in members {
        x -= p.max(0.0);
        if x < 0.0 {
            return id.clone();
        }
    }
    // Rounding at the very top: the last member with weight.
    members
        .iter()
        .rev()
        .find(|(_, p)| *p > 0.0)
        .map_or_else(String::new, |(id, _)| id.clone())
}

/// An attribute that must be there.
fn need<'a>(node: roxmltree::Node<'a, '_>, key: &str) -> Result<&'a str, String> {
    node.attribute(key)
        .ok_or_else(|| format!("<{}> needs a `{key}` attribute", node.tag_name().name()))
}

/// A SUMO time: seconds, or `h:m:s` / `d:h:m:s`.
fn time(text: &str) -> Option<f64> {
    let parts: Vec<f64> = text
        .trim()
        .split(':')
        .map(|p| p.parse().ok())
        .collect::<Option<_>>()?;
    let value = match parts.as_slice() {
        [s] => *s,
        [h, m, s] => h * 3_600.0 + m * 60.0 + s,
        [d, h, m, s] => d * 86_400.0 + h * 3_600.0 + m * 60.0 + s,
        _ => return None,
    };
    (value.is_finite() && value >= 0.0).then_some(value)
}

/// A `speedFactor`: the mean and, for a distribution, the deviation and bounds.
#[derive(Debug, Clone, Copy, PartialEq)]
struct SpeedFactor {
    mean: f64,
    dev: Option<f64>,
    bounds: Option<(f64, f64)>,
}

/// Reads a `speedFactor`: a number, `norm(mean,dev)` or `normc(mean,dev,min,max)`.
fn speed_factor(text: &str) -> Option<SpeedFactor> {
    let factor = |mean, dev, bounds| SpeedFactor { mean, dev, bounds };
    let t = text.trim();
    let args = |inner: &str| -> Option<Vec<f64>> {
        inner
            .split(',')
            .map(|p| p.trim().parse::<f64>().ok())
            .collect()
    };
    if let Some(inner) = t.strip_prefix("normc(").and_then(|r| r.strip_suffix(')')) {
        let a = args(inner)?;
        return (a.len() == 4).then(|| factor(a[0], Some(a[1]), Some((a[2], a[3]))));
    }
    if let Some(inner) = t.strip_prefix("norm(").and_then(|r| r.strip_suffix(')')) {
        let a = args(inner)?;
        return (a.len() == 2).then(|| factor(a[0], Some(a[1]), None));
    }
    let v: f64 = t.parse().ok()?;
    (v.is_finite() && v > 0.0).then(|| factor(v, None, None))
}

/// A uniform draw in [0, 1).
fn uniform(rng: &mut ChaCha8Rng) -> f64 {
    (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64
}

/// The driver profile a vehicle type becomes: SUMO's car-following model mapped to the nearest
/// built-in one, with its parameters where the two share them.
fn profile(id: &str, t: &VType, warnings: &mut Vec<String>) -> DriverProfileSpec {
    let num = |key: &str| t.attrs.get(key).and_then(|v| v.trim().parse::<f64>().ok());
    let SpeedFactor { mean, dev, bounds } = t
        .attrs
        .get("speedFactor")
        .and_then(|f| speed_factor(f))
        .unwrap_or(SpeedFactor {
            mean: 1.0,
            dev: None,
            bounds: None,
        });
    // SUMO's default spread of desired speeds is 0.1 for cars.
    let dev = dev.or(num("speedDev")).unwrap_or(0.1);
    let mut set = BTreeMap::new();
    let (model, params) = match t.model.as_str() {
        "IDM" | "IIDM" | "EIDM" => {
            set.insert("time_headway_s".to_owned(), num("tau").unwrap_or(1.0));
            set.insert("min_gap_m".to_owned(), num("minGap").unwrap_or(2.5));
            set.insert("max_accel_mps2".to_owned(), num("accel").unwrap_or(2.6));
            set.insert(
                "comfortable_decel_mps2".to_owned(),
                num("decel").unwrap_or(4.5),
            );
            set.insert("delta".to_owned(), num("delta").unwrap_or(4.0));
            (DriverModel::Idm, "drivers/idm.ron")
        }
        other => {
            if !matches!(
                other,
                "Krauss" | "KraussOrig1" | "KraussPS" | "ACC" | "CACC"
            ) {
                warnings.push(format!(
                    "vType `{id}`: carFollowModel {other} is driven as Krauss is, by the \
                     lane-keeping car"
                ));
            }
            // Krauss is a safe-speed model: it never closes on the car ahead faster than it can
            // stop, which the lane-keeping car's braking envelope guarantees too; `tau` is the
            // time gap both keep (ACC's desired gap as well).
            set.insert("time_gap_s".to_owned(), num("tau").unwrap_or(1.0));
            (DriverModel::FlockLanes, "drivers/flock_lanes.ron")
        }
    };
    set.insert("speed_factor.mean".to_owned(), mean);
    set.insert("speed_factor.dev".to_owned(), dev);
    let (lo, hi) = bounds.unwrap_or((0.2, 2.0));
    set.insert("speed_factor.min".to_owned(), lo);
    set.insert("speed_factor.max".to_owned(), hi.max(lo));
    if let Some(length) = num("length")
        && (length - 4.6).abs() > 1.0
    {
        warnings.push(format!(
            "vType `{id}`: length {length} m is driven as the 4.6 m sedan"
        ));
    }
    if num("maxSpeed").is_some() {
        warnings.push(format!(
            "vType `{id}`: maxSpeed is not modelled; its vehicles drive at speedFactor × the limit"
        ));
    }
    DriverProfileSpec {
        name: id.to_owned(),
        model,
        vehicle: "sedan".to_owned(),
        params: Some(params.to_owned()),
        set,
    }
}

/// A road's length along its control points, m.
fn road_length(road: &flockway_road::RoadSpec) -> f64 {
    road.points
        .windows(2)
        .map(|w| w[0].pos.distance(w[1].pos))
        .sum()
}

/// The lanes of road `from` that lead onto road `to` (all its lanes when `to` is `None` or no
/// lane pair says).
fn leading_lanes(level: &Level, from: &str, to: Option<&str>) -> Vec<u32> {
    let Some(road) = level.road(from) else {
        return vec![0];
    };
    let all: Vec<u32> = (0..road.lanes.max(1)).collect();
    let Some(to) = to else { return all };
    let mut lanes: BTreeSet<u32> = BTreeSet::new();
    for link in road.outgoing().iter().filter(|l| l.to == to) {
        let to_lanes = level.road(to).map_or(1, |r| r.lanes);
        lanes.extend(link.lane_pairs(road.lanes, to_lanes).iter().map(|p| p.0));
    }
    for c in level
        .junctions
        .iter()
        .flat_map(|j| &j.connections)
        .filter(|c| c.from == from && c.to == to)
    {
        lanes.insert(c.from_lane);
    }
    if lanes.is_empty() {
        all
    } else {
        lanes.into_iter().collect()
    }
}

/// The quickest way from road `from` to road `to` at the speed limits, as road names (both
/// ends included); Dijkstra over the roads' lengths, ties broken by name so it never varies.
fn quickest(level: &Level, from: &str, to: &str) -> Option<Vec<String>> {
    let cost = |name: &str| {
        level.road(name).map_or(f64::INFINITY, |r| {
            road_length(r) / (r.speed_limit_kmh / 3.6).max(0.1)
        })
    };
    let mut best: BTreeMap<String, f64> = BTreeMap::from([(from.to_owned(), 0.0)]);
    let mut back: BTreeMap<String, String> = BTreeMap::new();
    // Max-heap on the negated time in integer microseconds, then on the name.
    let mut heap = BinaryHeap::from([(0i64, std::cmp::Reverse(from.to_owned()))]);
    while let Some((neg, std::cmp::Reverse(at))) = heap.pop() {
        let t = -neg as f64 / 1e6;
        if at == to {
            let mut path = vec![to.to_owned()];
            let mut cur = to.to_owned();
            while let Some(prev) = back.get(&cur) {
                path.push(prev.clone());
                cur = prev.clone();
            }
            path.reverse();
            return Some(path);
        }
        if best.get(&at).is_some_and(|b| t > *b + 1e-6) {
            continue;
        }
        for next in level.leads_to(&at) {
            let nt = t + cost(next);
            if best.get(next).is_none_or(|b| nt < *b - 1e-9) {
                best.insert(next.to_owned(), nt);
                back.insert(next.to_owned(), at.clone());
                heap.push((-(nt * 1e6) as i64, std::cmp::Reverse(next.to_owned())));
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two junctions half a metre apart along `a` → `s` → `b` (side roads `c` out of the first,
    /// `d` into the second): the import makes them one and leaves `s` out.
    const CLOSE_PAIR: &str = r#"<net>
<edge id="a" from="A" to="J1"><lane index="0" speed="13.89" shape="0,0 100,0"/></edge>
<edge id="s" from="J1" to="J2"><lane index="0" speed="13.89" shape="104,0 104.5,0"/></edge>
<edge id="b" from="J2" to="B"><lane index="0" speed="13.89" shape="110,0 200,0"/></edge>
<edge id="c" from="J1" to="C"><lane index="0" speed="13.89" shape="104,20 200,20"/></edge>
<edge id="d" from="D" to="J2"><lane index="0" speed="13.89" shape="0,-20 100,-20"/></edge>
<connection from="a" to="s" fromLane="0" toLane="0" dir="s"/>
<connection from="a" to="c" fromLane="0" toLane="0" dir="l"/>
<connection from="s" to="b" fromLane="0" toLane="0" dir="s"/>
<connection from="d" to="b" fromLane="0" toLane="0" dir="r"/>
</net>"#;

    /// A loop of three one-lane edges, every edge reached from another: no way in.
    const LOOP: &str = r#"<net>
<edge id="a" from="A" to="B"><lane index="0" speed="13.89" shape="0,0 100,0"/></edge>
<edge id="b" from="B" to="C"><lane index="0" speed="13.89" shape="100,0 50,80"/></edge>
<edge id="c" from="C" to="A"><lane index="0" speed="13.89" shape="50,80 0,0"/></edge>
<connection from="a" to="b" fromLane="0" toLane="0" dir="l"/>
<connection from="b" to="c" fromLane="0" toLane="0" dir="l"/>
<connection from="c" to="a" fromLane="0" toLane="0" dir="l"/>
</net>"#;

    #[test]
    fn a_network_with_no_way_in_runs_a_demand() {
        let net = Path::new("t.net.xml");
        let e = import_sumo(LOOP, net, "t", &[]).expect_err("no traffic could come in");
        assert!(e.message.contains("or SUMO demand"), "{e}");
        let rou = r#"<routes>
<vehicle id="v" depart="2"><route edges="a b"/></vehicle>
</routes>"#;
        let files = [(PathBuf::from("t.rou.xml"), rou.to_owned())];
        let (level, report) = import_sumo(LOOP, net, "t", &files).expect("imports");
        assert_eq!(report.vehicles, 1);
        let on: Vec<&str> = level.spawners.iter().map(|s| s.road.as_str()).collect();
        assert_eq!(on, ["a"]);
        let arrive: Vec<&DestroyerSpec> = level.destroyers.iter().collect();
        assert_eq!(arrive.len(), 1);
        assert!(arrive[0].arrivals_only);
        assert!(crate::validate(&level).is_empty());
    }

    /// A two-lane edge `a` whose left lane alone goes on to `b`, its right lane to `c`.
    const FORK: &str = r#"<net>
<edge id="a" from="A" to="J"><lane index="0" speed="13.89" shape="0,-1.6 100,-1.6"/>
<lane index="1" speed="13.89" shape="0,1.6 100,1.6"/></edge>
<edge id="b" from="J" to="B"><lane index="0" speed="13.89" shape="110,0 200,0"/></edge>
<edge id="c" from="J" to="C"><lane index="0" speed="13.89" shape="105,-8 105,-100"/></edge>
<connection from="a" to="b" fromLane="1" toLane="0" dir="s"/>
<connection from="a" to="c" fromLane="0" toLane="0" dir="r"/>
</net>"#;

    /// Without `departLane` and `departSpeed` a vehicle departs as SUMO departs it by default:
    /// on a lane that leads on along its route, at the speed the road allows; `first` and a
    /// speed given keep lane 0 and that speed.
    #[test]
    fn a_vehicle_departs_by_default_on_a_lane_that_leads_on_at_speed() {
        let rou = r#"<routes>
<trip id="plain" depart="0" from="a" to="b"/>
<trip id="given" depart="5" from="a" to="b" departLane="first" departSpeed="0"/>
</routes>"#;
        let files = [(PathBuf::from("t.rou.xml"), rou.to_owned())];
        let (level, report) =
            import_sumo(FORK, Path::new("t.net.xml"), "t", &files).expect("imports");
        assert_eq!(report.vehicles, 2);
        let departs: Vec<(u32, f64, Option<f64>)> = level
            .spawners
            .iter()
            .flat_map(|s| {
                s.departures
                    .iter()
                    .map(move |d| (s.lane, d.time_s, d.speed_kmh))
            })
            .collect();
        assert_eq!(departs.len(), 2, "{departs:?}");
        assert!(departs.contains(&(1, 0.0, None)), "{departs:?}");
        assert!(departs.contains(&(0, 5.0, Some(0.0))), "{departs:?}");
    }

    #[test]
    fn a_route_passes_over_an_edge_left_out_inside_a_junction() {
        let rou = r#"<routes>
<route id="through" edges="a s b"/>
<vehicle id="v" route="through" depart="1"/>
</routes>"#;
        let files = [(PathBuf::from("t.rou.xml"), rou.to_owned())];
        let (level, report) =
            import_sumo(CLOSE_PAIR, Path::new("t.net.xml"), "t", &files).expect("imports");
        assert!(level.road("s").is_none());
        assert_eq!(report.vehicles, 1);
        let route = level
            .spawners
            .iter()
            .flat_map(|s| &s.routes)
            .find(|r| r.name == "through")
            .expect("the route");
        assert_eq!(route.roads, ["a", "b"]);
        // A trip that starts on it is told why it cannot.
        let trip = r#"<routes><trip id="t" from="s" to="b" depart="0"/></routes>"#;
        let files = [(PathBuf::from("t.rou.xml"), trip.to_owned())];
        let Err(e) = import_sumo(CLOSE_PAIR, Path::new("t.net.xml"), "t", &files) else {
            panic!("a trip from inside a junction is an error");
        };
        assert!(e.message.contains("lies inside a junction"), "{e}");
    }

    #[test]
    fn times_read_as_seconds_or_clock_times() {
        assert_eq!(time("12.5"), Some(12.5));
        assert_eq!(time("1:00:00"), Some(3600.0));
        assert_eq!(time("0:01:30"), Some(90.0));
        assert_eq!(time("1:00:00:10"), Some(86_410.0));
        assert_eq!(time("-1"), None);
        assert_eq!(time("soon"), None);
        assert_eq!(time("1:00"), None);
    }

    #[test]
    fn speed_factors_read_as_numbers_or_distributions() {
        let read = |t: &str| speed_factor(t).map(|f| (f.mean, f.dev, f.bounds));
        assert_eq!(read("1.1"), Some((1.1, None, None)));
        assert_eq!(read("norm(1,0.1)"), Some((1.0, Some(0.1), None)));
        assert_eq!(
            read("normc(1, 0.1, 0.2, 2)"),
            Some((1.0, Some(0.1), Some((0.2, 2.0))))
        );
        assert_eq!(read("norm(1)"), None);
        assert_eq!(read("fast"), None);
    }
}

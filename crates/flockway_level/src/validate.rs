//! Semantic checks of a parsed level: references, ranges and counts, each tied to the place in
//! the file it concerns.

use crate::expect::{Qualifier, metric_info};
use crate::locate::PathStep::{self, Field, Index};
use crate::schema::*;
use flockway_road::{RoadError, RoadGeometry};
use std::collections::{BTreeMap, BTreeSet};

/// Most vehicles a level may place at the start, over all groups.
pub const MAX_INITIAL_VEHICLES: u64 = 100_000;
/// Longest run a level may ask for, in simulated seconds (one week).
pub const MAX_DURATION_S: f64 = 7.0 * 24.0 * 3600.0;
/// Closest that initial vehicles may be placed, centre to centre, in metres.
pub const MIN_INITIAL_SPACING_M: f64 = 5.0;
/// Shortest spawn interval, in seconds.
pub const MIN_SPAWN_INTERVAL_S: f64 = 0.1;
/// Most entries of any one list (roads, spawners, …) in a level.
pub const MAX_LIST_LEN: usize = 10_000;

/// A problem found in a level, with the path of the value it concerns.
#[derive(Debug, Clone, PartialEq)]
pub struct Issue {
    /// Path from the level root to the offending value.
    pub path: Vec<PathStep>,
    /// What is wrong, and what was expected.
    pub message: String,
}

impl Issue {
    /// What the issue concerns, in the words of someone editing the level: `spawner `in``,
    /// `road `main` point 3`, `driver profile `human``, `expectation 2`, …
    pub fn subject(&self, level: &Level) -> String {
        let index = |k: usize| match self.path.get(k) {
            Some(Index(i)) => Some(*i),
            _ => None,
        };
        let named = |kind: &str, name: Option<&str>| match name {
            Some(n) if !n.trim().is_empty() => format!("{kind} `{n}`"),
            _ => kind.to_owned(),
        };
        let Some(Field(top)) = self.path.first() else {
            return "the level".to_owned();
        };
        let i = index(1);
        match *top {
            "roads" => {
                let road = named(
                    "road",
                    i.and_then(|i| level.roads.get(i)).map(|r| r.name.as_str()),
                );
                match (self.path.get(2), index(3)) {
                    (Some(Field("points")), Some(k)) => format!("{road} point {k}"),
                    _ => road,
                }
            }
            "spawners" => named(
                "spawner",
                i.and_then(|i| level.spawners.get(i))
                    .map(|s| s.name.as_str()),
            ),
            "destroyers" => named(
                "destroyer",
                i.and_then(|i| level.destroyers.get(i))
                    .map(|d| d.name.as_str()),
            ),
            "triggers" => named(
                "trigger",
                i.and_then(|i| level.triggers.get(i))
                    .map(|t| t.name.as_str()),
            ),
            "detectors" => named(
                "detector",
                i.and_then(|i| level.detectors.get(i))
                    .map(|d| d.name.as_str()),
            ),
            "driver_profiles" => named(
                "driver profile",
                i.and_then(|i| level.driver_profiles.get(i))
                    .map(|d| d.name.as_str()),
            ),
            "vehicle_types" => named(
                "vehicle type",
                i.and_then(|i| level.vehicle_types.get(i))
                    .map(|v| v.name.as_str()),
            ),
            "vehicles" => i.map_or("the initial vehicles".to_owned(), |i| {
                format!("vehicle group {}", i + 1)
            }),
            "expect" => i
                .and_then(|i| level.expect.get(i))
                .map_or("an expectation".to_owned(), |e| {
                    format!("expectation `{e}`")
                }),
            "telemetry" => "telemetry".to_owned(),
            "score" => "the score".to_owned(),
            "duration_s" => "the level's duration".to_owned(),
            _ => "the level".to_owned(),
        }
    }

    /// The issue as one sentence for a status line: its subject, then what is wrong.
    pub fn describe(&self, level: &Level) -> String {
        format!("{}: {}", self.subject(level), self.message)
    }
}

struct Checker<'a> {
    level: &'a Level,
    roads: Vec<Option<RoadGeometry>>,
    issues: Vec<Issue>,
    /// Where each road leads ([`Level::successors`]), found once.
    next: BTreeMap<&'a str, Vec<&'a str>>,
    /// The roads' names, for the many routes that name them.
    names: BTreeSet<&'a str>,
}

/// Checks everything that parsing alone cannot; returns every problem found, in file order.
pub fn validate(level: &Level) -> Vec<Issue> {
    let mut c = Checker {
        level,
        roads: Vec::new(),
        issues: Vec::new(),
        next: level.successors(),
        names: level.roads.iter().map(|r| r.name.as_str()).collect(),
    };
    c.run();
    c.issues
}

/// What is allowed but likely wrong in a valid level's network: a road that leads nowhere and
/// has no destroyer (vehicles stop at its end), a road whose links take none of its lanes.
/// `flockway check` and `flockway run` print these; the editor shows them without refusing the
/// edit (a road is drawn before its destroyer).
pub fn warnings(level: &Level) -> Vec<Issue> {
    let mut out = Vec::new();
    let next = level.successors();
    for (i, spec) in level.roads.iter().enumerate() {
        if spec.closed {
            continue;
        }
        let Ok(g) = RoadGeometry::new(spec) else {
            continue;
        };
        let last = spec.points.len().saturating_sub(1);
        let end = g.pos_at(g.length_m());
        let destroyed = level.destroyers.iter().any(|d| match &d.place {
            DestroyerPlaceSpec::OnRoad { road, .. } => *road == spec.name,
            DestroyerPlaceSpec::Volume { min, max } => {
                // Within a car length of the end is close enough: vehicles drive into it.
                let (lo, hi) = (
                    *min - glam::DVec3::splat(5.0),
                    *max + glam::DVec3::splat(5.0),
                );
                end.cmpge(lo).all() && end.cmple(hi).all()
            }
        });
        let outgoing = spec.outgoing();
        if outgoing.is_empty() && next.get(spec.name.as_str()).is_none_or(Vec::is_empty) {
            if !destroyed {
                out.push(Issue {
                    path: vec![Field("roads"), Index(i), Field("points"), Index(last)],
                    message: format!("road `{}` leads nowhere and has no destroyer: vehicles stop at its end; link it onto another road or put a destroyer on it", spec.name),
                });
            }
            continue;
        }
        let through = level
            .junctions
            .iter()
            .any(|j| j.connections.iter().any(|c| c.from == spec.name));
        let any_lane = through
            || outgoing
                .iter()
                .any(|l| l.lanes.is_empty() || l.lanes.iter().any(|(a, _)| *a < spec.lanes));
        if !any_lane && !destroyed {
            out.push(Issue {
                path: vec![Field("roads"), Index(i), Field("links")],
                message: format!("no lane of road `{}` leads on: every lane ends with no lane to merge into; add lane pairs to its links", spec.name),
            });
        }
    }
    out
}

fn finite_in(x: f64, lo: f64, hi: f64) -> bool {
    x.is_finite() && x >= lo && x <= hi
}

impl Checker<'_> {
    fn issue(&mut self, path: Vec<PathStep>, message: impl Into<String>) {
        self.issues.push(Issue {
            path,
            message: message.into(),
        });
    }

    fn run(&mut self) {
        let l = self.level;
        if l.version != CURRENT_VERSION {
            self.issue(
                vec![Field("version")],
                format!(
                    "unsupported level version {}; this Flockway reads version {CURRENT_VERSION}",
                    l.version
                ),
            );
            return;
        }
        if !finite_in(l.duration_s, 1.0 / 120.0, MAX_DURATION_S) {
            self.issue(vec![Field("duration_s")], format!("duration_s is {}; expected a number of seconds from 1/120 to {MAX_DURATION_S} (one week)", l.duration_s));
        }
        for (field, len) in [
            ("roads", l.roads.len()),
            ("junctions", l.junctions.len()),
            ("vehicle_types", l.vehicle_types.len()),
            ("driver_profiles", l.driver_profiles.len()),
            ("spawners", l.spawners.len()),
            ("destroyers", l.destroyers.len()),
            ("triggers", l.triggers.len()),
            ("detectors", l.detectors.len()),
            ("vehicles", l.vehicles.len()),
            ("expect", l.expect.len()),
        ] {
            if len > MAX_LIST_LEN {
                self.issue(
                    vec![Field(field)],
                    format!("{len} entries in `{field}`; at most {MAX_LIST_LEN} are allowed"),
                );
                return;
            }
        }
        self.roads();
        self.junctions();
        self.vehicle_types();
        self.driver_profiles();
        self.spawners();
        self.destroyers();
        self.triggers();
        self.detectors();
        self.initial_vehicles();
        self.telemetry();
        self.expectations();
    }

    fn unique<'n>(&mut self, list: &'static str, names: impl Iterator<Item = &'n str>) {
        let mut seen = BTreeSet::new();
        for (i, name) in names.enumerate() {
            if name.trim().is_empty() {
                self.issue(
                    vec![Field(list), Index(i), Field("name")],
                    "a name must not be empty",
                );
            } else if !seen.insert(name) {
                self.issue(
                    vec![Field(list), Index(i), Field("name")],
                    format!("duplicate name `{name}` in `{list}`; names must be unique"),
                );
            }
        }
    }

    fn roads(&mut self) {
        let l = self.level;
        self.unique("roads", l.roads.iter().map(|r| r.name.as_str()));
        for (i, spec) in l.roads.iter().enumerate() {
            let at = |rest: &[PathStep]| {
                let mut p = vec![Field("roads"), Index(i)];
                p.extend_from_slice(rest);
                p
            };
            match RoadGeometry::new(spec) {
                Ok(g) => self.roads.push(Some(g)),
                Err(e) => {
                    let path = match &e {
                        RoadError::EmptyName => at(&[Field("name")]),
                        RoadError::TooFewPoints { .. } | RoadError::TooManyPoints { .. } => {
                            at(&[Field("points")])
                        }
                        RoadError::Lanes { .. } => at(&[Field("lanes")]),
                        RoadError::LaneWidth { .. } => at(&[Field("lane_width_m")]),
                        RoadError::SpeedLimit { .. } => at(&[Field("speed_limit_kmh")]),
                        RoadError::ClosedWithNext { .. } => {
                            at(&[Field(if spec.next.is_some() { "next" } else { "links" })])
                        }
                        RoadError::Position { point, .. } => {
                            at(&[Field("points"), Index(*point), Field("pos")])
                        }
                        RoadError::Width { point, .. }
                            if spec.points.get(*point).is_some_and(|p| p.width_m.is_some()) =>
                        {
                            at(&[Field("points"), Index(*point), Field("width_m")])
                        }
                        RoadError::Width { .. } => at(&[Field("lane_width_m")]),
                        RoadError::Bank { point, .. } => {
                            at(&[Field("points"), Index(*point), Field("bank_deg")])
                        }
                        RoadError::Tangent { point, .. } => {
                            at(&[Field("points"), Index(*point), Field("tangent")])
                        }
                        RoadError::PointsTooClose { b, .. } | RoadError::PointsTooFar { b, .. } => {
                            at(&[Field("points"), Index(*b)])
                        }
                    };
                    self.issue(path, e.to_string());
                    self.roads.push(None);
                }
            }
        }
        let mut found: Vec<(Vec<PathStep>, String)> = Vec::new();
        for (i, spec) in l.roads.iter().enumerate() {
            let mut targets = BTreeSet::new();
            let links = spec.next.iter().map(|n| (None, n.as_str(), &[][..])).chain(
                spec.links
                    .iter()
                    .enumerate()
                    .map(|(k, link)| (Some(k), link.to.as_str(), link.lanes.as_slice())),
            );
            for (k, next, lanes) in links {
                let base = match k {
                    None => vec![Field("roads"), Index(i)],
                    Some(k) => vec![Field("roads"), Index(i), Field("links"), Index(k)],
                };
                let at = |f: &'static str| {
                    let mut p = base.clone();
                    p.push(Field(if k.is_none() { "next" } else { f }));
                    p
                };
                let Some(j) = l.roads.iter().position(|r| r.name == next) else {
                    found.push((
                        at("to"),
                        format!("unknown road `{next}`; {}", self.road_names()),
                    ));
                    continue;
                };
                if !targets.insert(j) {
                    found.push((at("to"), format!("road `{}` already leads onto `{next}`; give all the lane pairs of one link together", spec.name)));
                    continue;
                }
                let (a, b) = (&self.roads[i], &self.roads[j]);
                if lanes.is_empty() {
                    if let (Some(a), Some(b)) = (a, b) {
                        let gap = (b.pos_at(0.0) - a.pos_at(a.length_m())).length();
                        if gap > flockway_road::MAX_CONNECTION_GAP_M {
                            let msg = format!(
                                "road `{}` ends {gap:.2} m from the start of `{next}`; a connection needs them within 1 m",
                                spec.name
                            );
                            found.push((at("to"), msg));
                        }
                    }
                    continue;
                }
                let to_lanes = l.roads[j].lanes;
                for (m, &(la, lb)) in lanes.iter().enumerate() {
                    let mut path = base.clone();
                    path.extend([Field("lanes"), Index(m)]);
                    if la >= spec.lanes {
                        found.push((path, format!("lane {la} is out of range: road `{}` has {} lane(s), numbered 0 to {}", spec.name, spec.lanes, spec.lanes.saturating_sub(1))));
                    } else if lb >= to_lanes {
                        found.push((path, format!("lane {lb} is out of range: road `{next}` has {to_lanes} lane(s), numbered 0 to {}", to_lanes.saturating_sub(1))));
                    } else if let (Some(a), Some(b)) = (a, b) {
                        let gap = (b.lane_point(lb, 0.0) - a.lane_point(la, a.length_m())).length();
                        if gap > flockway_road::MAX_CONNECTION_GAP_M {
                            found.push((path, format!("lane {la} of `{}` ends {gap:.2} m from the start of lane {lb} of `{next}`; linked lanes must meet within 1 m", spec.name)));
                        }
                    }
                }
            }
        }
        for (path, message) in found {
            self.issue(path, message);
        }
    }

    fn road_names(&self) -> String {
        if self.level.roads.is_empty() {
            "the level has no roads".to_owned()
        } else {
            let names: Vec<String> = self
                .level
                .roads
                .iter()
                .map(|r| format!("`{}`", r.name))
                .collect();
            format!("the level's roads are {}", names.join(", "))
        }
    }

    /// Checks a reference to a road and a lane; returns the road's geometry when both are fine.
    fn road_lane(
        &mut self,
        base: &[PathStep],
        road: &str,
        lane: Option<(u32, &'static str)>,
    ) -> Option<usize> {
        let path = |f: &'static str| {
            let mut p = base.to_vec();
            p.push(Field(f));
            p
        };
        let Some(i) = self.level.roads.iter().position(|r| r.name == road) else {
            let msg = format!("unknown road `{road}`; {}", self.road_names());
            self.issue(path("road"), msg);
            return None;
        };
        if let Some((lane, field)) = lane {
            let lanes = self.level.roads[i].lanes;
            if lane >= lanes {
                self.issue(path(field), format!("lane {lane} is out of range: road `{road}` has {lanes} lane(s), numbered 0 to {}", lanes.saturating_sub(1)));
                return None;
            }
        }
        self.roads[i].as_ref().map(|_| i)
    }

    fn arc(&mut self, path: Vec<PathStep>, road: usize, s: f64, what: &str) {
        let Some(g) = &self.roads[road] else { return };
        let len = g.length_m();
        if !finite_in(s, 0.0, len) {
            self.issue(
                path,
                format!(
                    "{what} {s} m is outside road `{}`, which is {len:.1} m long",
                    g.name()
                ),
            );
        }
    }

    fn asset_path(&mut self, path: Vec<PathStep>, p: &str) {
        let bad = p.is_empty()
            || p.starts_with('/')
            || p.starts_with('\\')
            || p.contains(':')
            || p.split(['/', '\\']).any(|c| c == "..")
            || !p.ends_with(".ron");
        if bad {
            self.issue(path, format!("`{p}` is not a path inside assets/: expected a relative path to a .ron file, without `..`, e.g. \"vehicles/sedan.ron\""));
        }
    }

    fn vehicle_types(&mut self) {
        let l = self.level;
        self.unique(
            "vehicle_types",
            l.vehicle_types.iter().map(|v| v.name.as_str()),
        );
        for (i, v) in l.vehicle_types.iter().enumerate() {
            self.asset_path(
                vec![Field("vehicle_types"), Index(i), Field("path")],
                &v.path,
            );
        }
    }

    fn driver_profiles(&mut self) {
        let l = self.level;
        self.unique(
            "driver_profiles",
            l.driver_profiles.iter().map(|d| d.name.as_str()),
        );
        for (i, d) in l.driver_profiles.iter().enumerate() {
            let base = [Field("driver_profiles"), Index(i)];
            if !l.vehicle_types.iter().any(|v| v.name == d.vehicle) {
                let known: Vec<String> = l
                    .vehicle_types
                    .iter()
                    .map(|v| format!("`{}`", v.name))
                    .collect();
                let list = if known.is_empty() {
                    "the level defines no vehicle_types".to_owned()
                } else {
                    format!("known: {}", known.join(", "))
                };
                self.issue(
                    [&base[..], &[Field("vehicle")]].concat(),
                    format!("unknown vehicle type `{}`; {list}", d.vehicle),
                );
            }
            if let Some(p) = &d.params {
                self.asset_path([&base[..], &[Field("params")]].concat(), p);
            }
            if let DriverModel::Custom(name) = &d.model
                && name.trim().is_empty()
            {
                self.issue(
                    [&base[..], &[Field("model")]].concat(),
                    "a custom driver model needs a name",
                );
            }
            for (k, v) in &d.set {
                if k.trim().is_empty() || !v.is_finite() {
                    self.issue(
                        [&base[..], &[Field("set")]].concat(),
                        format!("parameter `{k}` = {v}: expected a named, finite number"),
                    );
                }
            }
        }
    }

    fn profile_ref(&mut self, path: Vec<PathStep>, name: &str) {
        if !self.level.driver_profiles.iter().any(|d| d.name == name) {
            let known: Vec<String> = self
                .level
                .driver_profiles
                .iter()
                .map(|d| format!("`{}`", d.name))
                .collect();
            let list = if known.is_empty() {
                "the level defines no driver_profiles".to_owned()
            } else {
                format!("known: {}", known.join(", "))
            };
            self.issue(path, format!("unknown driver profile `{name}`; {list}"));
        }
    }

    fn speed(&mut self, path: Vec<PathStep>, kmh: Option<f64>) {
        if let Some(v) = kmh
            && !finite_in(v, 0.0, 400.0)
        {
            self.issue(
                path,
                format!("speed {v} km/h: expected a number from 0 to 400"),
            );
        }
    }

    fn spawners(&mut self) {
        let l = self.level;
        self.unique("spawners", l.spawners.iter().map(|s| s.name.as_str()));
        for (i, s) in l.spawners.iter().enumerate() {
            let base = vec![Field("spawners"), Index(i)];
            let p = |f: &'static str| [&base[..], &[Field(f)]].concat();
            if let Some(r) = self.road_lane(&base, &s.road, Some((s.lane, "lane"))) {
                self.arc(p("s_m"), r, s.s_m, "spawn position");
            }
            let iv = s.interval_s;
            if !(finite_in(iv.min, MIN_SPAWN_INTERVAL_S, 86_400.0)
                && finite_in(iv.max, iv.min, 86_400.0))
            {
                self.issue(p("interval_s"), format!("interval_s (min: {}, max: {}): expected {MIN_SPAWN_INTERVAL_S} ≤ min ≤ max ≤ 86400 seconds", iv.min, iv.max));
            }
            if s.profiles.is_empty() {
                self.issue(p("profiles"), "a spawner needs at least one driver profile");
            }
            let mut total = 0.0;
            for (k, share) in s.profiles.iter().enumerate() {
                self.profile_ref(
                    [&base[..], &[Field("profiles"), Index(k), Field("profile")]].concat(),
                    &share.profile,
                );
                if !finite_in(share.weight, 0.0, 1e9) {
                    self.issue(
                        [&base[..], &[Field("profiles"), Index(k), Field("weight")]].concat(),
                        format!("weight {}: expected a finite number ≥ 0", share.weight),
                    );
                } else {
                    total += share.weight;
                }
            }
            if !s.profiles.is_empty() && total <= 0.0 {
                self.issue(
                    p("profiles"),
                    "the profile weights sum to 0; at least one must be positive",
                );
            }
            self.speed(p("speed_kmh"), s.speed_kmh);
            self.spawner_routes(i, s);
            self.departures(i, s);
        }
    }

    /// A spawner's timetable: times, profiles, its own routes and speeds that exist.
    fn departures(&mut self, i: usize, s: &SpawnerSpec) {
        for (k, d) in s.departures.iter().enumerate() {
            let at = |f: &'static str| {
                vec![
                    Field("spawners"),
                    Index(i),
                    Field("departures"),
                    Index(k),
                    Field(f),
                ]
            };
            if !finite_in(d.time_s, 0.0, 1e9) {
                self.issue(
                    at("time_s"),
                    format!("time_s {}: expected a finite time ≥ 0 s", d.time_s),
                );
            }
            self.profile_ref(at("profile"), &d.profile);
            if let Some(route) = &d.route {
                let known = s.routes.iter().any(|r| r.name == *route)
                    || s.destination.as_ref() == Some(route);
                if !known {
                    let names: Vec<String> =
                        s.routes.iter().map(|r| format!("`{}`", r.name)).collect();
                    let list = if names.is_empty() {
                        "the spawner has no routes".to_owned()
                    } else {
                        format!("its routes are {}", names.join(", "))
                    };
                    self.issue(
                        at("route"),
                        format!("`{route}` is not a route of this spawner; {list}"),
                    );
                }
            }
            self.speed(at("speed_kmh"), d.speed_kmh);
        }
    }

    /// Whether road `a` leads onto road `b` at its end.
    /// Each junction: unique names, connections between lanes that exist and do not meet, a
    /// control that fits them, paths whose names no road takes.
    fn junctions(&mut self) {
        let l = self.level;
        self.unique("junctions", l.junctions.iter().map(|j| j.name.as_str()));
        for (i, spec) in l.junctions.iter().enumerate() {
            let at = |rest: &[PathStep]| [&[Field("junctions"), Index(i)][..], rest].concat();
            let built = flockway_road::Junction::build(spec, |name| {
                let k = l.roads.iter().position(|r| r.name == name)?;
                self.roads.get(k)?.as_ref().map(|g| (k as u32, g))
            });
            match built {
                Ok(junction) => {
                    for p in &junction.paths {
                        if l.road(&p.spec.name).is_some() {
                            let msg = format!(
                                "a road is named `{}`, the name of this junction's path; rename the road or the junction",
                                p.spec.name
                            );
                            self.issue(at(&[Field("name")]), msg);
                        }
                    }
                }
                Err(e) => {
                    use flockway_road::JunctionError as E;
                    let path = match &e {
                        E::UnknownRoad { k, road, .. } => {
                            let c = &spec.connections[*k];
                            let f = if c.from == *road { "from" } else { "to" };
                            at(&[Field("connections"), Index(*k), Field(f)])
                        }
                        E::Lane { k, road, lane, .. } => {
                            let c = &spec.connections[*k];
                            let f = if c.from == *road && c.from_lane == *lane {
                                "from_lane"
                            } else {
                                "to_lane"
                            };
                            at(&[Field("connections"), Index(*k), Field(f)])
                        }
                        E::Closed { k, .. } | E::Meets { k, .. } | E::Duplicate { k, .. } => {
                            at(&[Field("connections"), Index(*k)])
                        }
                        E::Major { .. } | E::NoSignal { .. } => at(&[Field("control")]),
                        E::SignalUnused { .. } => at(&[Field("signal")]),
                        E::Signal { phase, .. } => {
                            at(&[Field("signal"), Field("phases"), Index(*phase)])
                        }
                    };
                    // A road that failed to build was reported with the roads.
                    let unbuilt =
                        matches!(&e, E::UnknownRoad { road, .. } if l.road(road).is_some());
                    if !unbuilt {
                        self.issue(path, e.to_string());
                    }
                }
            }
        }
    }

    fn leads_onto(&self, a: &str, b: &str) -> bool {
        self.next.get(a).is_some_and(|n| n.contains(&b))
    }

    fn spawner_routes(&mut self, i: usize, s: &SpawnerSpec) {
        let base = [Field("spawners"), Index(i)];
        if !s.routes.is_empty() && s.destination.is_some() {
            self.issue(
                [&base[..], &[Field("destination")]].concat(),
                "a spawner has either routes or a destination, not both",
            );
        }
        let mut total = 0.0;
        for (k, route) in s.routes.iter().enumerate() {
            let at = |rest: &[PathStep]| [&base[..], &[Field("routes"), Index(k)], rest].concat();
            if !finite_in(route.weight, 0.0, 1e9) {
                self.issue(
                    at(&[Field("weight")]),
                    format!("weight {}: expected a finite number ≥ 0", route.weight),
                );
            } else {
                total += route.weight;
            }
            if route.roads.is_empty() {
                self.issue(at(&[Field("roads")]), "a route needs at least one road");
            }
            let mut prev = s.road.as_str();
            for (m, name) in route.roads.iter().enumerate() {
                let path = at(&[Field("roads"), Index(m)]);
                if !self.names.contains(name.as_str()) {
                    let msg = format!("unknown road `{name}`; {}", self.road_names());
                    self.issue(path, msg);
                    break;
                }
                if m == 0 && name == &s.road {
                    continue;
                }
                if !self.leads_onto(prev, name) {
                    self.issue(path, format!("road `{prev}` does not lead onto `{name}`: each road of a route must be linked to the one before it (the first is the spawner's road `{}`)", s.road));
                    break;
                }
                prev = name;
            }
        }
        if !s.routes.is_empty() && total <= 0.0 {
            self.issue(
                [&base[..], &[Field("routes")]].concat(),
                "the route weights sum to 0; at least one must be positive",
            );
        }
        if let Some(dest) = &s.destination {
            let path = [&base[..], &[Field("destination")]].concat();
            if !self.names.contains(dest.as_str()) {
                let msg = format!("unknown road `{dest}`; {}", self.road_names());
                self.issue(path, msg);
            } else if !self.reachable(&s.road, dest) {
                self.issue(path, format!("road `{dest}` cannot be reached from the spawner's road `{}` along the roads' links", s.road));
            }
        }
        let mut last = 0.0;
        for (k, step) in s.schedule.iter().enumerate() {
            let at =
                |f: &'static str| [&base[..], &[Field("schedule"), Index(k), Field(f)]].concat();
            if !finite_in(step.from_s, last, MAX_DURATION_S) {
                self.issue(at("from_s"), format!("from_s {}: expected a time in seconds, at or after the step before ({last})", step.from_s));
            } else {
                last = step.from_s;
            }
            let iv = step.interval_s;
            if !(finite_in(iv.min, MIN_SPAWN_INTERVAL_S, 86_400.0)
                && finite_in(iv.max, iv.min, 86_400.0))
            {
                self.issue(at("interval_s"), format!("interval_s (min: {}, max: {}): expected {MIN_SPAWN_INTERVAL_S} ≤ min ≤ max ≤ 86400 seconds", iv.min, iv.max));
            }
        }
    }

    /// Whether road `to` can be reached from road `from` along links.
    fn reachable(&self, from: &str, to: &str) -> bool {
        let mut seen = BTreeSet::from([from.to_owned()]);
        let mut todo = vec![from.to_owned()];
        while let Some(r) = todo.pop() {
            if r == to {
                return true;
            }
            for &to in self.next.get(r.as_str()).into_iter().flatten() {
                if seen.insert(to.to_owned()) {
                    todo.push(to.to_owned());
                }
            }
        }
        false
    }

    fn destroyers(&mut self) {
        let l = self.level;
        self.unique("destroyers", l.destroyers.iter().map(|d| d.name.as_str()));
        for (i, d) in l.destroyers.iter().enumerate() {
            let base = vec![Field("destroyers"), Index(i), Field("place")];
            match &d.place {
                DestroyerPlaceSpec::OnRoad { road, s_m } => {
                    if let Some(r) = self.road_lane(&base, road, None) {
                        self.arc(
                            [&base[..], &[Field("s_m")]].concat(),
                            r,
                            *s_m,
                            "destroyer position",
                        );
                    }
                }
                DestroyerPlaceSpec::Volume { min, max } => {
                    if !(min.is_finite() && max.is_finite() && min.cmplt(*max).all()) {
                        self.issue(
                            base,
                            "a destroyer volume needs finite corners with min < max on every axis",
                        );
                    }
                }
            }
        }
    }

    fn triggers(&mut self) {
        let l = self.level;
        self.unique("triggers", l.triggers.iter().map(|t| t.name.as_str()));
        for (i, t) in l.triggers.iter().enumerate() {
            let base = vec![Field("triggers"), Index(i)];
            let p = |f: &'static str| [&base[..], &[Field(f)]].concat();
            if let Some(r) = self.road_lane(&base, &t.road, None) {
                self.arc(p("from_m"), r, t.from_m, "trigger start");
                self.arc(p("to_m"), r, t.to_m, "trigger end");
                let closed = l.roads[r].closed;
                if !closed && t.to_m <= t.from_m {
                    self.issue(
                        p("to_m"),
                        format!(
                            "trigger ends at {} m, not after its start at {} m",
                            t.to_m, t.from_m
                        ),
                    );
                }
                let lanes = l.roads[r].lanes;
                for (k, lane) in t.lanes.iter().flatten().enumerate() {
                    if *lane >= lanes {
                        self.issue([&base[..], &[Field("lanes"), Index(k)]].concat(), format!("lane {lane} is out of range: road `{}` has {lanes} lane(s), numbered 0 to {}", t.road, lanes - 1));
                    }
                }
            }
            match t.effect {
                TriggerEffectSpec::SpeedLimit { kmh } if !finite_in(kmh, 1.0, 400.0) => {
                    self.issue(
                        p("effect"),
                        format!("speed limit {kmh} km/h: expected a number from 1 to 400"),
                    );
                }
                TriggerEffectSpec::Friction { scale }
                    if !(scale.is_finite() && scale > 0.0 && scale <= 2.0) =>
                {
                    self.issue(
                        p("effect"),
                        format!("friction scale {scale}: expected a number above 0 and at most 2"),
                    );
                }
                _ => {}
            }
        }
    }

    fn detectors(&mut self) {
        let l = self.level;
        self.unique("detectors", l.detectors.iter().map(|d| d.name.as_str()));
        for (i, d) in l.detectors.iter().enumerate() {
            let base = vec![Field("detectors"), Index(i)];
            let p = |f: &'static str| [&base[..], &[Field(f)]].concat();
            if let Some(r) = self.road_lane(&base, &d.road, None) {
                self.arc(p("s_m"), r, d.s_m, "detector");
                let lanes = l.roads[r].lanes;
                let mut seen = BTreeSet::new();
                for (k, lane) in d.lanes.iter().flatten().enumerate() {
                    let at = [&base[..], &[Field("lanes"), Index(k)]].concat();
                    if *lane >= lanes {
                        self.issue(at, format!("lane {lane} is out of range: road `{}` has {lanes} lane(s), numbered 0 to {}", d.road, lanes - 1));
                    } else if !seen.insert(*lane) {
                        self.issue(at, format!("lane {lane} is listed twice"));
                    }
                }
                if d.lanes.as_ref().is_some_and(Vec::is_empty) {
                    self.issue(
                        p("lanes"),
                        "no lanes: list at least one, or leave `lanes` out for all".to_owned(),
                    );
                }
            }
            if !finite_in(d.period_s, 1.0 / 120.0, MAX_DURATION_S) {
                self.issue(
                    p("period_s"),
                    format!(
                        "period_s is {}; expected a number of seconds from 1/120 to {MAX_DURATION_S}",
                        d.period_s
                    ),
                );
            }
        }
    }

    fn initial_vehicles(&mut self) {
        let l = self.level;
        let mut total: u64 = 0;
        let mut group_too_large = false;
        for (i, v) in l.vehicles.iter().enumerate() {
            let base = vec![Field("vehicles"), Index(i)];
            let p = |f: &'static str| [&base[..], &[Field(f)]].concat();
            total += u64::from(v.count);
            if u64::from(v.count) > MAX_INITIAL_VEHICLES {
                self.issue(p("count"), format!("{} vehicles in one group; a level may place at most {MAX_INITIAL_VEHICLES} at the start", v.count));
                group_too_large = true;
                continue;
            }
            self.profile_ref(p("profile"), &v.profile);
            self.speed(p("speed_kmh"), v.speed_kmh);
            if !finite_in(v.jitter_m, 0.0, 1e6) {
                self.issue(
                    p("jitter_m"),
                    format!("jitter_m {}: expected a finite number ≥ 0", v.jitter_m),
                );
            }
            let Some(r) = self.road_lane(&base, &v.road, Some((v.lane, "lane"))) else {
                continue;
            };
            self.arc(p("from_m"), r, v.from_m, "group start");
            if let Some(to) = v.to_m {
                self.arc(p("to_m"), r, to, "group end");
            }
            let Some(g) = &self.roads[r] else { continue };
            let span = match v.to_m {
                Some(to) if g.is_closed() => (to - v.from_m).rem_euclid(g.length_m()),
                Some(to) => to - v.from_m,
                None if g.is_closed() => g.length_m(),
                None => g.length_m() - v.from_m,
            };
            if v.count > 0 {
                let spacing = if g.is_closed() && v.to_m.is_none() {
                    span / f64::from(v.count)
                } else {
                    span / f64::from(v.count.max(2) - 1).max(1.0)
                };
                if v.count > 1 && spacing < MIN_INITIAL_SPACING_M {
                    self.issue(p("count"), format!("{} vehicles on {span:.1} m of lane are {spacing:.2} m apart; they need at least {MIN_INITIAL_SPACING_M} m each", v.count));
                } else if v.jitter_m.is_finite() && v.count > 1 && v.jitter_m > 0.25 * spacing {
                    self.issue(p("jitter_m"), format!("jitter_m {} could make neighbours overlap: at most a quarter of the {spacing:.2} m spacing is allowed", v.jitter_m));
                }
            }
        }
        if total > MAX_INITIAL_VEHICLES && !group_too_large {
            self.issue(
                vec![Field("vehicles")],
                format!(
                    "{total} initial vehicles in all; at most {MAX_INITIAL_VEHICLES} are allowed"
                ),
            );
        }
    }

    fn telemetry(&mut self) {
        let t = &self.level.telemetry;
        let ticks = t.period_s * 120.0;
        if !(finite_in(t.period_s, 1.0 / 120.0, 3600.0) && (ticks - ticks.round()).abs() < 1e-6) {
            self.issue(vec![Field("telemetry"), Field("period_s")], format!("period_s {}: expected a multiple of the 1/120 s step between 1/120 s and 1 hour (e.g. 0.5)", t.period_s));
        }
        if !finite_in(t.stats_from_s, 0.0, MAX_DURATION_S) {
            self.issue(
                vec![Field("telemetry"), Field("stats_from_s")],
                format!(
                    "stats_from_s {}: expected a number of seconds ≥ 0",
                    t.stats_from_s
                ),
            );
        }
        let ssm = self.level.ssm;
        for (name, value, unit) in [
            ("ttc_s", ssm.ttc_s, "s"),
            ("pet_s", ssm.pet_s, "s"),
            ("drac_mps2", ssm.drac_mps2, "m/s²"),
        ] {
            if !finite_in(value, 1.0e-3, 1.0e3) {
                self.issue(
                    vec![Field("ssm"), Field(name)],
                    format!("{name} {value}: expected a threshold above 0 and at most 1000 {unit}"),
                );
            }
        }
    }

    /// Why `metric.q` names nothing in the level (`None`: it names a thing of the right kind,
    /// or the metric is unknown, which parsing reports).
    fn unknown_qualifier(&self, metric: &str, q: &str) -> Option<String> {
        let l = self.level;
        let info = metric_info(metric)?;
        let (known, kind) = match info.qualifier {
            Qualifier::Road => (l.roads.iter().any(|r| r.name == q), "road"),
            Qualifier::Destroyer => (l.destroyers.iter().any(|d| d.name == q), "destroyer"),
            Qualifier::Profile => (
                l.driver_profiles.iter().any(|p| p.name == q),
                "driver profile",
            ),
            Qualifier::Junction => (l.junctions.iter().any(|j| j.name == q), "junction"),
            Qualifier::None => (true, ""),
        };
        (!known).then(|| format!("`{metric}.{q}` names unknown {kind} `{q}`"))
    }

    fn expectations(&mut self) {
        let l = self.level;
        for (i, e) in l.expect.iter().enumerate() {
            let Some(q) = &e.qualifier else { continue };
            if let Some(message) = self.unknown_qualifier(e.metric.name(), q) {
                self.issue(vec![Field("expect"), Index(i)], message);
            }
        }
        if let Some(score) = &l.score {
            for key in score.formula.keys() {
                let Some((metric, q)) = key.split_once('.') else {
                    continue;
                };
                if let Some(message) = self.unknown_qualifier(metric, q) {
                    self.issue(
                        vec![Field("score"), Field("formula")],
                        format!("score formula: {message}"),
                    );
                }
            }
            if !score.thresholds_in_order() {
                let m = score.medals;
                let order = match score.better {
                    crate::score::Better::Higher => "bronze ≤ silver ≤ gold (higher is better)",
                    crate::score::Better::Lower => "bronze ≥ silver ≥ gold (lower is better)",
                };
                self.issue(
                    vec![Field("score"), Field("medals")],
                    format!(
                        "medals (bronze: {}, silver: {}, gold: {}): expected finite thresholds with {order}",
                        m.bronze, m.silver, m.gold
                    ),
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::parse_level;
    use std::path::Path;

    const BASE: &str = r#"(
    version: 1,
    seed: 1,
    duration_s: 10.0,
    roads: [(name: "main", lanes: 2, speed_limit_kmh: 60.0, points: [(pos: (0.0, 0.0, 0.0)), (pos: (100.0, 0.0, 0.0))])],
    vehicle_types: [(name: "sedan", path: "vehicles/sedan.ron")],
    driver_profiles: [(name: "auto", model: FlockLanes, vehicle: "sedan")],
    EXTRA
)"#;

    /// The messages a level with `extra` fields gives, as "line:col: message".
    fn problems(extra: &str) -> Vec<String> {
        match parse_level(&BASE.replace("EXTRA", extra), Path::new("t.ron")) {
            Ok(_) => Vec::new(),
            Err(e) => e.diagnostics().iter().map(|d| d.to_string()).collect(),
        }
    }

    #[test]
    fn a_consistent_level_has_no_problems() {
        assert!(problems("").is_empty());
        assert!(problems(r#"score: (formula: "mean_speed_kmh.auto - 2 * collisions", unit: "km/h", medals: (bronze: 1.0, silver: 2.0, gold: 3.0)),"#).is_empty());
        assert!(problems(r#"triggers: [(name: "t", road: "main", from_m: 10.0, to_m: 20.0, effect: SpeedLimit(kmh: 100.0))],"#).is_empty());
        assert!(problems(r#"detectors: [(name: "d", road: "main", s_m: 50.0), (name: "e", road: "main", s_m: 90.0, lanes: [1], period_s: 0.5)],"#).is_empty());
    }

    #[test]
    fn each_inconsistency_is_reported_where_it_is() {
        let cases = [
            (
                r#"spawners: [(name: "s", road: "main", lane: 0, interval_s: (min: 2.0, max: 1.0), profiles: [(profile: "auto", weight: 1.0)])],"#,
                "8:63: interval_s",
            ),
            (
                r#"spawners: [(name: "s", road: "main", interval_s: (min: 1.0, max: 2.0), profiles: [(profile: "robot", weight: 1.0)])],"#,
                "unknown driver profile `robot`; known: `auto`",
            ),
            (
                r#"spawners: [(name: "s", road: "main", s_m: 500.0, interval_s: (min: 1.0, max: 2.0), profiles: [(profile: "auto", weight: 0.0)])],"#,
                "spawn position 500 m is outside road `main`",
            ),
            (
                r#"destroyers: [(name: "d", place: OnRoad(road: "side", s_m: 1.0))],"#,
                "unknown road `side`",
            ),
            (
                r#"triggers: [(name: "t", road: "main", from_m: 20.0, to_m: 10.0, effect: Friction(scale: 5.0))],"#,
                "not after its start",
            ),
            (
                r#"triggers: [(name: "t", road: "main", from_m: 10.0, to_m: 20.0, lanes: [0, 3], effect: SpeedLimit(kmh: 90.0))],"#,
                "lane 3 is out of range",
            ),
            (
                r#"vehicles: [(road: "main", count: 50, profile: "auto")],"#,
                "50 vehicles on 100.0 m of lane are 2.04 m apart",
            ),
            (
                r#"vehicles: [(road: "main", count: 5, profile: "auto", jitter_m: 10.0)],"#,
                "jitter_m 10 could make neighbours overlap",
            ),
            (
                r#"detectors: [(name: "d", road: "side", s_m: 50.0)],"#,
                "8:35: unknown road `side`",
            ),
            (
                r#"detectors: [(name: "d", road: "main", s_m: 150.0)],"#,
                "detector 150 m is outside road `main`, which is 100.0 m long",
            ),
            (
                r#"detectors: [(name: "d", road: "main", s_m: 50.0, lanes: [0, 2])],"#,
                "lane 2 is out of range: road `main` has 2 lane(s)",
            ),
            (
                r#"detectors: [(name: "d", road: "main", s_m: 50.0, lanes: [1, 1])],"#,
                "lane 1 is listed twice",
            ),
            (
                r#"detectors: [(name: "d", road: "main", s_m: 50.0, lanes: [])],"#,
                "no lanes",
            ),
            (
                r#"detectors: [(name: "d", road: "main", s_m: 50.0, period_s: 0.0)],"#,
                "period_s is 0; expected a number of seconds from 1/120",
            ),
            (
                r#"detectors: [(name: "d", road: "main", s_m: 5.0), (name: "d", road: "main", s_m: 9.0)],"#,
                "`d`",
            ),
            (r#"telemetry: (period_s: 0.3333),"#, "period_s 0.3333"),
            (
                r#"ssm: (ttc_s: 0.0, drac_mps2: 3.0),"#,
                "ttc_s 0: expected a threshold above 0",
            ),
            (
                r#"ssm: (pet_s: 5000.0),"#,
                "pet_s 5000: expected a threshold",
            ),
            (
                r#"expect: ["road_length_m.side > 1"],"#,
                "unknown road `side`",
            ),
            (
                r#"expect: ["flow_veh_per_h.exit > 1"],"#,
                "unknown destroyer `exit`",
            ),
            (
                r#"score: (formula: "mean_speed_kmh.robot", medals: (bronze: 1.0, silver: 2.0, gold: 3.0)),"#,
                "8:22: score formula: `mean_speed_kmh.robot` names unknown driver profile `robot`",
            ),
            (
                r#"score: (formula: "collisions", better: Lower, medals: (bronze: 1.0, silver: 2.0, gold: 3.0)),"#,
                "expected finite thresholds with bronze ≥ silver ≥ gold (lower is better)",
            ),
            (
                r#"score: (formula: "collisions +", medals: (bronze: 1.0, silver: 2.0, gold: 3.0)),"#,
                "score formula, character 13: the formula ends too early",
            ),
        ];
        for (extra, needle) in cases {
            let found = problems(extra);
            assert!(
                found.iter().any(|p| p.contains(needle)),
                "`{extra}` should report `{needle}`, got {found:?}"
            );
            assert!(
                found.iter().all(|p| p.starts_with("8:")),
                "`{extra}` should point into line 8: {found:?}"
            );
        }
        // Zero total weight is its own problem, besides the position one.
        let found = problems(
            r#"spawners: [(name: "s", road: "main", s_m: 500.0, interval_s: (min: 1.0, max: 2.0), profiles: [(profile: "auto", weight: 0.0)])],"#,
        );
        assert!(
            found.iter().any(|p| p.contains("weights sum to 0")),
            "{found:?}"
        );
    }

    #[test]
    fn duplicate_names_and_bad_asset_paths_are_reported() {
        let found = problems(
            r#"destroyers: [(name: "d", place: OnRoad(road: "main", s_m: 1.0)), (name: "d", place: OnRoad(road: "main", s_m: 2.0))],"#,
        );
        assert!(
            found.iter().any(|p| p.contains("duplicate name `d`")),
            "{found:?}"
        );
        let text = BASE
            .replace(r#""vehicles/sedan.ron""#, r#""../../etc/passwd""#)
            .replace("EXTRA", "");
        let err = parse_level(&text, Path::new("t.ron")).expect_err("path escapes assets/");
        assert!(
            err.to_string().contains("not a path inside assets/"),
            "{err}"
        );
    }

    #[test]
    fn a_newer_version_is_named_as_such() {
        let err = parse_level(
            &BASE
                .replace("version: 1", "version: 2")
                .replace("EXTRA", "future_field: 3,"),
            Path::new("t.ron"),
        )
        .expect_err("version 2");
        assert_eq!(
            err.diagnostics()[0].to_string(),
            "2:14: unsupported level version 2; this Flockway reads version 1"
        );
    }

    #[test]
    fn absurd_durations_are_rejected() {
        let err = parse_level(
            &BASE
                .replace("duration_s: 10.0", "duration_s: 1e12")
                .replace("EXTRA", ""),
            Path::new("t.ron"),
        )
        .expect_err("too long");
        assert!(
            err.to_string()
                .starts_with("t.ron:4:17: duration_s is 1000000000000"),
            "{err}"
        );
    }
    /// A three-lane road `a` ending at x = 100 and two roads starting there: `b` (one lane, at
    /// the right lane's end) and `c` (two lanes, at the left lanes' ends), with `LINKS` as
    /// `a`'s links and `EXTRA` appended.
    const NET: &str = r#"(
    version: 1,
    seed: 1,
    duration_s: 10.0,
    roads: [
        (name: "a", lanes: 3, lane_width_m: 3.5, speed_limit_kmh: 60.0, links: LINKS,
            points: [(pos: (0.0, 0.0, 0.0)), (pos: (100.0, 0.0, 0.0))]),
        (name: "b", lanes: 1, lane_width_m: 3.5, speed_limit_kmh: 60.0,
            points: [(pos: (100.0, -3.5, 0.0)), (pos: (200.0, -3.5, 0.0))]),
        (name: "c", lanes: 2, lane_width_m: 3.5, speed_limit_kmh: 60.0,
            points: [(pos: (100.0, 1.75, 0.0)), (pos: (200.0, 1.75, 0.0))]),
    ],
    vehicle_types: [(name: "sedan", path: "vehicles/sedan.ron")],
    driver_profiles: [(name: "auto", model: FlockLanes, vehicle: "sedan")],
    destroyers: [(name: "b", place: OnRoad(road: "b", s_m: 90.0)), (name: "c", place: OnRoad(road: "c", s_m: 90.0))],
    EXTRA
)"#;

    fn net(links: &str, extra: &str) -> String {
        NET.replace("LINKS", links).replace("EXTRA", extra)
    }

    fn net_problems(links: &str, extra: &str) -> Vec<String> {
        match parse_level(&net(links, extra), Path::new("t.ron")) {
            Ok(_) => Vec::new(),
            Err(e) => e.diagnostics().iter().map(|d| d.to_string()).collect(),
        }
    }

    const SPLIT: &str = r#"[(to: "b", lanes: [(0, 0)]), (to: "c", lanes: [(1, 0), (2, 1)])]"#;

    #[test]
    fn a_split_with_routes_is_consistent() {
        let routes = r#"spawners: [(name: "s", road: "a", interval_s: (min: 1.0, max: 2.0), profiles: [(profile: "auto", weight: 1.0)],
            routes: [(name: "b", roads: ["a", "b"], weight: 0.3), (name: "c", roads: ["a", "c"], weight: 0.7)])],"#;
        assert_eq!(net_problems(SPLIT, routes), Vec::<String>::new());
        let level = parse_level(&net(SPLIT, routes), Path::new("t.ron")).expect("valid");
        assert!(super::warnings(&level).is_empty());
    }

    #[test]
    fn a_timetable_names_its_spawner_s_routes_and_known_profiles() {
        let ok = r#"spawners: [(name: "s", road: "a", interval_s: (min: 1.0, max: 1.0), profiles: [(profile: "auto", weight: 1.0)],
            routes: [(name: "b", roads: ["a", "b"])],
            departures: [(time_s: 0.0, profile: "auto", route: "b"), (time_s: 2.5, profile: "auto", speed_kmh: 0.0)])],"#;
        assert_eq!(net_problems(SPLIT, ok), Vec::<String>::new());
        let bad = r#"spawners: [(name: "s", road: "a", interval_s: (min: 1.0, max: 1.0), profiles: [(profile: "auto", weight: 1.0)],
            routes: [(name: "b", roads: ["a", "b"])],
            departures: [(time_s: -1.0, profile: "robot", route: "c", speed_kmh: 900.0)])],"#;
        let problems = net_problems(SPLIT, bad).join("\n");
        for expected in [
            "time_s -1: expected a finite time ≥ 0 s",
            "unknown driver profile `robot`",
            "`c` is not a route of this spawner; its routes are `b`",
            "speed 900 km/h",
        ] {
            assert!(problems.contains(expected), "{expected}: {problems}");
        }
    }

    #[test]
    fn each_network_error_is_reported_where_it_is() {
        let cases = [
            (
                r#"[(to: "b", lanes: [(0, 1)])]"#,
                "",
                "6:",
                "lane 1 is out of range: road `b` has 1 lane(s)",
            ),
            (
                r#"[(to: "b", lanes: [(3, 0)])]"#,
                "",
                "6:",
                "lane 3 is out of range: road `a` has 3 lane(s)",
            ),
            (
                r#"[(to: "b", lanes: [(2, 0)])]"#,
                "",
                "6:",
                "lane 2 of `a` ends 7.00 m from the start of lane 0 of `b`",
            ),
            (
                r#"[(to: "b", lanes: [(0, 0)]), (to: "b", lanes: [(1, 0)])]"#,
                "",
                "6:",
                "road `a` already leads onto `b`",
            ),
            (
                r#"[(to: "d", lanes: [(0, 0)])]"#,
                "",
                "6:",
                "unknown road `d`; the level's roads are `a`, `b`, `c`",
            ),
            (
                SPLIT,
                r#"spawners: [(name: "s", road: "a", interval_s: (min: 1.0, max: 2.0), profiles: [(profile: "auto", weight: 1.0)], routes: [(name: "x", roads: ["a", "c", "b"], weight: 1.0)])],"#,
                "16:",
                "road `c` does not lead onto `b`",
            ),
            (
                SPLIT,
                r#"spawners: [(name: "s", road: "b", interval_s: (min: 1.0, max: 2.0), profiles: [(profile: "auto", weight: 1.0)], destination: "c")],"#,
                "16:",
                "road `c` cannot be reached from the spawner's road `b`",
            ),
        ];
        for (links, extra, line, needle) in cases {
            let found = net_problems(links, extra);
            assert!(
                found
                    .iter()
                    .any(|p| p.starts_with(line) && p.contains(needle)),
                "links `{links}` / `{extra}` should report `{needle}` at line {line}, got {found:?}"
            );
        }
    }

    /// Road `a` ending 16 m before `b` starts and 8 m short of where `c` starts to the left:
    /// a signalised junction `j` takes `a` on to both; `CONNECTIONS`, `SIGNAL` and `ROUTES`
    /// filled in by each test.
    const JUNCTION: &str = r#"(
    version: 1,
    seed: 1,
    duration_s: 10.0,
    roads: [
        (name: "a", speed_limit_kmh: 50.0, points: [(pos: (0.0, 0.0, 0.0)), (pos: (100.0, 0.0, 0.0))]),
        (name: "b", speed_limit_kmh: 50.0, points: [(pos: (116.0, 0.0, 0.0)), (pos: (200.0, 0.0, 0.0))]),
        (name: "c", speed_limit_kmh: 50.0, points: [(pos: (108.0, 8.0, 0.0)), (pos: (108.0, 100.0, 0.0))]),
    ],
    junctions: [
        (name: "j", control: Signal,
            connections: CONNECTIONS,
            signal: (offset_s: 5.0, phases: SIGNAL)),
    ],
    vehicle_types: [(name: "sedan", path: "vehicles/sedan.ron")],
    driver_profiles: [(name: "auto", model: FlockLanes, vehicle: "sedan")],
    spawners: [(name: "s", road: "a", interval_s: (min: 1.0, max: 2.0), profiles: [(profile: "auto", weight: 1.0)],
        routes: ROUTES)],
    destroyers: [(name: "b", place: OnRoad(road: "b", s_m: 80.0)), (name: "c", place: OnRoad(road: "c", s_m: 80.0))],
)"#;

    fn junction_level(connections: &str, signal: &str, routes: &str) -> String {
        JUNCTION
            .replace("CONNECTIONS", connections)
            .replace("SIGNAL", signal)
            .replace("ROUTES", routes)
    }

    const BOTH: &str = r#"[(from: "a", to: "b"), (from: "a", to: "c")]"#;
    const PHASES: &str = r#"[(duration_s: 30.0, state: "Gg"), (duration_s: 3.0, state: "yy"), (duration_s: 20.0, state: "rr")]"#;
    const ROUTES: &str =
        r#"[(name: "b", roads: ["a", "b"], weight: 1.0), (name: "c", roads: ["c"], weight: 1.0)]"#;

    #[test]
    fn a_junction_level_reads_back_and_routes_go_through_it() {
        let src = junction_level(BOTH, PHASES, ROUTES);
        let level = parse_level(&src, Path::new("t.ron")).expect("a valid junction level");
        assert!(
            super::warnings(&level).is_empty(),
            "{:?}",
            super::warnings(&level)
        );
        let j = &level.junctions[0];
        assert_eq!(j.control, flockway_road::Control::Signal);
        assert_eq!(j.connections[1].to, "c");
        assert_eq!(j.signal.as_ref().map(|s| s.offset_s), Some(5.0));
        assert_eq!(level.leads_to("a"), vec!["b", "c"]);
        // All roads at once, the same way.
        let all = level.successors();
        for road in &level.roads {
            let next = all.get(road.name.as_str()).cloned().unwrap_or_default();
            assert_eq!(next, level.leads_to(&road.name), "{}", road.name);
        }
        // Written back and read again, the same level.
        let again = parse_level(
            &crate::level_to_string(&level).expect("ron"),
            Path::new("t.ron"),
        )
        .expect("reads back");
        assert_eq!(again.junctions, level.junctions);
    }

    #[test]
    fn each_junction_error_is_reported_where_it_is() {
        let cases = [
            (
                r#"[(from: "a", to: "b"), (from: "a", to: "d")]"#,
                PHASES,
                "12:",
                "junction `j` connection 1: there is no road named `d`",
            ),
            (
                r#"[(from: "a", to: "b"), (from: "a", to: "c", to_lane: 1)]"#,
                PHASES,
                "12:",
                "road `c` has 1 lane(s), numbered 0 to 0, not lane 1",
            ),
            (
                BOTH,
                r#"[(duration_s: 30.0, state: "G")]"#,
                "13:",
                "signal phase 0: state `G` has 1 letter(s) for 2 connection(s)",
            ),
            (
                r#"[(from: "a", to: "b")]"#,
                PHASES,
                "18:",
                "road `a` does not lead onto `c`",
            ),
        ];
        for (connections, signal, line, needle) in cases {
            let src = junction_level(connections, signal, ROUTES);
            let found = match parse_level(&src, Path::new("t.ron")) {
                Ok(_) => Vec::new(),
                Err(e) => e.diagnostics().iter().map(|d| d.to_string()).collect(),
            };
            assert!(
                found
                    .iter()
                    .any(|p| p.starts_with(line) && p.contains(needle)),
                "`{connections}` / `{signal}` should report `{needle}` at line {line}, got {found:?}"
            );
        }
    }

    #[test]
    fn a_road_leading_nowhere_without_a_destroyer_is_a_warning_not_an_error() {
        // Road `c`'s destroyer removed: its end leads nowhere (pointed at its last point).
        let src =
            net(SPLIT, "").replace(r#", (name: "c", place: OnRoad(road: "c", s_m: 90.0))"#, "");
        let level = parse_level(&src, Path::new("t.ron")).expect("valid, with a warning");
        let warned = crate::level_warnings(&level, &src, Path::new("t.ron"));
        assert_eq!(warned.len(), 1, "{warned:?}");
        assert!(
            warned[0].starts_with("t.ron:11:")
                && warned[0].contains("road `c` leads nowhere and has no destroyer"),
            "{warned:?}"
        );
    }
}

//! The same scenario side by side in SUMO and Flockway: vehicles departed and arrived, travel
//! time, speed and time lost overall and per route, throughput at the network's fringe, and the
//! GEH statistic of every edge's vehicle count — the calibration measure of traffic engineering
//! practice (a model is taken to match counts when GEH < 5 on at least 85 % of them).
//!
//! Each side is a [`ScenarioRun`]: Flockway's from its trip log, SUMO's read from its
//! `--tripinfo-output`, `--edgedata-output` and `--statistic-output` files
//! ([`ScenarioRun::from_sumo`]). [`compare`] puts them together; the [`Comparison`] prints as a
//! table and serialises to JSON.

use crate::AnalysisError;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// GEH below which a count is taken to match.
pub const GEH_MATCH: f64 = 5.0;
/// Share of edge counts that must match for the scenario to match.
pub const GEH_SHARE: f64 = 0.85;
/// Largest relative difference in vehicles departed or arrived.
pub const COUNT_TOLERANCE: f64 = 0.05;
/// Largest relative difference in the mean travel time.
pub const TRAVEL_TIME_TOLERANCE: f64 = 0.25;

/// One finished trip.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Trip {
    /// When it departed, s.
    pub depart_s: f64,
    /// The edge (road) it departed on.
    pub depart_edge: String,
    /// When it arrived, s.
    pub arrival_s: f64,
    /// The edge it arrived on.
    pub arrival_edge: String,
    /// The distance it drove, m.
    pub length_m: f64,
    /// Its time lost to driving below its ideal speed, s.
    pub time_loss_s: f64,
}

impl Trip {
    /// Its travel time, s.
    pub fn duration_s(&self) -> f64 {
        self.arrival_s - self.depart_s
    }
}

/// How many vehicles an edge saw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct EdgeCounts {
    /// Vehicles that departed on it.
    pub departed: u64,
    /// Vehicles that came onto it from another edge.
    pub entered: u64,
    /// Vehicles that arrived on it.
    pub arrived: u64,
}

impl EdgeCounts {
    /// Every vehicle that used the edge: those that departed on it and those that came onto it.
    pub fn vehicles(&self) -> u64 {
        self.departed + self.entered
    }
}

/// What one tool measured on a scenario.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ScenarioRun {
    /// Vehicles that departed (were inserted).
    pub departed: u64,
    /// Vehicles due that had not found room to depart at the end.
    pub waiting: u64,
    /// Vehicles still on the roads at the end.
    pub running: u64,
    /// Vehicle–vehicle collisions (contacts in Flockway).
    pub collisions: u64,
    /// Vehicles teleported out of a jam (SUMO only; Flockway never teleports).
    pub teleports: Option<u64>,
    /// Finished trips.
    pub trips: Vec<Trip>,
    /// Counts per edge.
    pub edges: BTreeMap<String, EdgeCounts>,
}

/// The XML document in `text`, or an error naming `path`, line and column.
fn parse<'a>(text: &'a str, path: &Path) -> Result<roxmltree::Document<'a>, AnalysisError> {
    roxmltree::Document::parse(text).map_err(|e| AnalysisError::Sumo {
        path: path.to_owned(),
        message: format!("{}:{}: {e}", e.pos().row, e.pos().col),
    })
}

/// A number attribute of `node`: absent reads as 0; one that does not parse is an error with its
/// place.
fn number(
    doc: &roxmltree::Document,
    node: roxmltree::Node,
    name: &str,
    path: &Path,
) -> Result<f64, AnalysisError> {
    let Some(text) = node.attribute(name) else {
        return Ok(0.0);
    };
    text.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            let pos = doc.text_pos_at(node.range().start);
            AnalysisError::Sumo {
                path: path.to_owned(),
                message: format!(
                    "{}:{}: <{}> {name}=\"{text}\": expected a number",
                    pos.row,
                    pos.col,
                    node.tag_name().name()
                ),
            }
        })
}

/// The edge of a SUMO lane id (`EDGE_INDEX`).
fn lane_edge(lane: &str) -> &str {
    match lane.rsplit_once('_') {
        Some((edge, index)) if !index.is_empty() && index.bytes().all(|b| b.is_ascii_digit()) => {
            edge
        }
        _ => lane,
    }
}

/// A count attribute (SUMO writes whole numbers; aggregated edge data may be fractional).
fn count(v: f64) -> u64 {
    v.max(0.0).round() as u64
}

impl ScenarioRun {
    /// What SUMO measured, from the text of its `--tripinfo-output`, `--edgedata-output` and
    /// `--statistic-output` files (each with its path, for errors).
    pub fn from_sumo(
        tripinfo: (&str, &Path),
        edgedata: (&str, &Path),
        statistics: (&str, &Path),
    ) -> Result<ScenarioRun, AnalysisError> {
        let mut run = ScenarioRun::default();
        let (text, path) = tripinfo;
        let doc = parse(text, path)?;
        for node in doc.descendants().filter(|n| n.has_tag_name("tripinfo")) {
            if node.attribute("vaporized").is_some_and(|v| !v.is_empty()) {
                continue;
            }
            let lane = |name| node.attribute(name).map_or("", lane_edge).to_owned();
            run.trips.push(Trip {
                depart_s: number(&doc, node, "depart", path)?,
                depart_edge: lane("departLane"),
                arrival_s: number(&doc, node, "arrival", path)?,
                arrival_edge: lane("arrivalLane"),
                length_m: number(&doc, node, "routeLength", path)?,
                time_loss_s: number(&doc, node, "timeLoss", path)?,
            });
        }
        let (text, path) = edgedata;
        let doc = parse(text, path)?;
        for node in doc.descendants().filter(|n| n.has_tag_name("edge")) {
            let Some(id) = node.attribute("id") else {
                continue;
            };
            let counts = run.edges.entry(id.to_owned()).or_default();
            counts.departed += count(number(&doc, node, "departed", path)?);
            counts.entered += count(number(&doc, node, "entered", path)?);
            counts.arrived += count(number(&doc, node, "arrived", path)?);
        }
        let (text, path) = statistics;
        let doc = parse(text, path)?;
        let one = |tag: &str| doc.descendants().find(|n| n.has_tag_name(tag));
        let Some(vehicles) = one("vehicles") else {
            return Err(AnalysisError::Sumo {
                path: path.to_owned(),
                message: "no <vehicles> element: expected SUMO's --statistic-output".to_owned(),
            });
        };
        run.departed = count(number(&doc, vehicles, "inserted", path)?);
        run.waiting = count(number(&doc, vehicles, "waiting", path)?);
        run.running = count(number(&doc, vehicles, "running", path)?);
        if let Some(t) = one("teleports") {
            run.teleports = Some(count(number(&doc, t, "total", path)?));
        }
        if let Some(s) = one("safety") {
            run.collisions = count(number(&doc, s, "collisions", path)?);
        }
        Ok(run)
    }
}

/// A scenario's figures in one tool.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Totals {
    /// Vehicles departed.
    pub departed: u64,
    /// Vehicles arrived.
    pub arrived: u64,
    /// Vehicles due but not yet departed at the end.
    pub waiting: u64,
    /// Vehicles still on the roads at the end.
    pub running: u64,
    /// Mean travel time of the arrived, s.
    pub mean_travel_time_s: Option<f64>,
    /// Mean of their trip speeds (distance over travel time), km/h.
    pub mean_speed_kmh: Option<f64>,
    /// Mean time lost, s.
    pub mean_time_loss_s: Option<f64>,
    /// Vehicle–vehicle collisions.
    pub collisions: u64,
    /// Vehicles teleported (SUMO).
    pub teleports: Option<u64>,
}

/// The mean of `values`, if there are any.
fn mean(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (n, sum) = values.fold((0u64, 0.0), |(n, s), v| (n + 1, s + v));
    (n > 0).then(|| sum / n as f64)
}

impl Totals {
    fn of(run: &ScenarioRun) -> Totals {
        let trips = &run.trips;
        Totals {
            departed: run.departed,
            arrived: trips.len() as u64,
            waiting: run.waiting,
            running: run.running,
            mean_travel_time_s: mean(trips.iter().map(Trip::duration_s)),
            mean_speed_kmh: mean(
                trips
                    .iter()
                    .filter(|t| t.duration_s() > 0.0)
                    .map(|t| t.length_m / t.duration_s() * 3.6),
            ),
            mean_time_loss_s: mean(trips.iter().map(|t| t.time_loss_s)),
            collisions: run.collisions,
            teleports: run.teleports,
        }
    }
}

/// One value in each tool.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Pair<T> {
    /// SUMO's.
    pub sumo: T,
    /// Flockway's.
    pub flockway: T,
}

/// Trips from one edge to another.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RouteRow {
    /// The edge they departed on.
    pub from: String,
    /// The edge they arrived on.
    pub to: String,
    /// How many arrived.
    pub arrived: Pair<u64>,
    /// Their mean travel time, s.
    pub mean_travel_time_s: Pair<Option<f64>>,
}

/// Departures and arrivals at one edge where vehicles enter or leave the network.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FringeRow {
    /// The edge.
    pub edge: String,
    /// Vehicles that departed on it.
    pub departed: Pair<u64>,
    /// Vehicles that arrived on it.
    pub arrived: Pair<u64>,
}

/// One edge's vehicle count.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EdgeRow {
    /// The edge.
    pub edge: String,
    /// Vehicles that used it (departed on it or came onto it).
    pub vehicles: Pair<u64>,
    /// The same as hourly flows over the compared time, vehicles/h.
    pub flow_veh_h: Pair<f64>,
    /// GEH of Flockway's hourly flow against SUMO's.
    pub geh: f64,
}

/// Whether the scenario matches, by the usual calibration criteria.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verdict {
    /// Vehicles departed within [`COUNT_TOLERANCE`] of SUMO's.
    pub departed: bool,
    /// Vehicles arrived within [`COUNT_TOLERANCE`].
    pub arrived: bool,
    /// Mean travel time within [`TRAVEL_TIME_TOLERANCE`].
    pub travel_time: bool,
    /// GEH < [`GEH_MATCH`] on at least [`GEH_SHARE`] of the edge counts.
    pub geh: bool,
    /// All of them.
    pub all: bool,
}

/// A scenario run in both tools, side by side.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Comparison {
    /// Simulated seconds compared.
    pub seconds: f64,
    /// The scenario's figures.
    pub totals: Pair<Totals>,
    /// Per route (departure edge to arrival edge), the busiest first.
    pub routes: Vec<RouteRow>,
    /// Per edge where vehicles depart or arrive.
    pub fringe: Vec<FringeRow>,
    /// Per edge that either tool's vehicles used, in edge order.
    pub edges: Vec<EdgeRow>,
    /// Share of edge counts with GEH < [`GEH_MATCH`] (1 when there are none).
    pub geh_match_share: f64,
    /// The criteria.
    pub verdict: Verdict,
}

/// The GEH statistic of a modelled hourly flow `m` against a counted one `c`:
/// √(2 (m − c)² / (m + c)); 0 when both are 0.
pub fn geh(m: f64, c: f64) -> f64 {
    if m + c <= 0.0 {
        0.0
    } else {
        (2.0 * (m - c) * (m - c) / (m + c)).sqrt()
    }
}

/// Whether `value` is within `tolerance` (a share) of `reference`.
fn within(value: f64, reference: f64, tolerance: f64) -> bool {
    (value - reference).abs() <= tolerance * reference.abs().max(f64::MIN_POSITIVE)
        || value == reference
}

/// `sumo` and `flockway`, both run for `seconds`, side by side.
pub fn compare(sumo: &ScenarioRun, flockway: &ScenarioRun, seconds: f64) -> Comparison {
    let totals = Pair {
        sumo: Totals::of(sumo),
        flockway: Totals::of(flockway),
    };
    let mut routes: BTreeMap<(String, String), Pair<Vec<f64>>> = BTreeMap::new();
    for (is_sumo, run) in [(true, sumo), (false, flockway)] {
        for t in &run.trips {
            let key = (t.depart_edge.clone(), t.arrival_edge.clone());
            let times = routes.entry(key).or_insert_with(|| Pair {
                sumo: Vec::new(),
                flockway: Vec::new(),
            });
            let side = if is_sumo {
                &mut times.sumo
            } else {
                &mut times.flockway
            };
            side.push(t.duration_s());
        }
    }
    let mut routes: Vec<RouteRow> = routes
        .into_iter()
        .map(|((from, to), times)| RouteRow {
            from,
            to,
            arrived: Pair {
                sumo: times.sumo.len() as u64,
                flockway: times.flockway.len() as u64,
            },
            mean_travel_time_s: Pair {
                sumo: mean(times.sumo.into_iter()),
                flockway: mean(times.flockway.into_iter()),
            },
        })
        .collect();
    routes.sort_by(|a, b| {
        (b.arrived.sumo + b.arrived.flockway)
            .cmp(&(a.arrived.sumo + a.arrived.flockway))
            .then_with(|| (&a.from, &a.to).cmp(&(&b.from, &b.to)))
    });
    let edge_names: std::collections::BTreeSet<&String> =
        sumo.edges.keys().chain(flockway.edges.keys()).collect();
    let zero = EdgeCounts::default();
    let per_hour = 3600.0 / seconds.max(f64::MIN_POSITIVE);
    let mut fringe = Vec::new();
    let mut edges = Vec::new();
    for name in edge_names {
        let s = sumo.edges.get(name).unwrap_or(&zero);
        let f = flockway.edges.get(name).unwrap_or(&zero);
        if s.departed + f.departed + s.arrived + f.arrived > 0 {
            fringe.push(FringeRow {
                edge: name.clone(),
                departed: Pair {
                    sumo: s.departed,
                    flockway: f.departed,
                },
                arrived: Pair {
                    sumo: s.arrived,
                    flockway: f.arrived,
                },
            });
        }
        if s.vehicles() + f.vehicles() > 0 {
            let flow = Pair {
                sumo: s.vehicles() as f64 * per_hour,
                flockway: f.vehicles() as f64 * per_hour,
            };
            edges.push(EdgeRow {
                edge: name.clone(),
                vehicles: Pair {
                    sumo: s.vehicles(),
                    flockway: f.vehicles(),
                },
                flow_veh_h: flow,
                geh: geh(flow.flockway, flow.sumo),
            });
        }
    }
    let geh_match_share = if edges.is_empty() {
        1.0
    } else {
        edges.iter().filter(|e| e.geh < GEH_MATCH).count() as f64 / edges.len() as f64
    };
    let (s, f) = (&totals.sumo, &totals.flockway);
    let departed = within(f.departed as f64, s.departed as f64, COUNT_TOLERANCE);
    let arrived = within(f.arrived as f64, s.arrived as f64, COUNT_TOLERANCE);
    let travel_time = match (f.mean_travel_time_s, s.mean_travel_time_s) {
        (Some(f), Some(s)) => within(f, s, TRAVEL_TIME_TOLERANCE),
        (None, None) => true,
        _ => false,
    };
    let geh_ok = geh_match_share >= GEH_SHARE;
    Comparison {
        seconds,
        verdict: Verdict {
            departed,
            arrived,
            travel_time,
            geh: geh_ok,
            all: departed && arrived && travel_time && geh_ok,
        },
        totals,
        routes,
        fringe,
        edges,
        geh_match_share,
    }
}

/// Rows of a table printed at most, in each section (the JSON has them all).
const TABLE_ROWS: usize = 25;

/// `v` with `decimals`, or `–` for none.
fn opt(v: Option<f64>, decimals: usize) -> String {
    v.map_or_else(|| "–".to_owned(), |v| format!("{v:.decimals$}"))
}

/// Flockway's value against SUMO's, as a signed percentage (blank when SUMO's is 0 or absent).
fn diff(f: Option<f64>, s: Option<f64>) -> String {
    match (f, s) {
        (Some(f), Some(s)) if s != 0.0 => format!("{:+.1} %", (f - s) / s * 100.0),
        _ => String::new(),
    }
}

/// `yes`, or `NO`.
fn yes(ok: bool) -> &'static str {
    if ok { "yes" } else { "NO" }
}

impl Comparison {
    /// The comparison as a text table: the scenario's figures, the routes and fringe edges (the
    /// busiest 25), the edge counts that do not match, and the verdict.
    pub fn table(&self) -> String {
        let mut out = String::new();
        let (s, f) = (&self.totals.sumo, &self.totals.flockway);
        let _ = writeln!(
            out,
            "{:<28} {:>10} {:>10} {:>9}",
            "scenario", "SUMO", "Flockway", "diff"
        );
        let n = |v: u64| Some(v as f64);
        let rows: [(&str, Option<f64>, Option<f64>, usize); 8] = [
            ("vehicles departed", n(s.departed), n(f.departed), 0),
            ("vehicles arrived", n(s.arrived), n(f.arrived), 0),
            ("waiting to depart at end", n(s.waiting), n(f.waiting), 0),
            ("on the roads at end", n(s.running), n(f.running), 0),
            (
                "mean travel time, s",
                s.mean_travel_time_s,
                f.mean_travel_time_s,
                1,
            ),
            (
                "mean trip speed, km/h",
                s.mean_speed_kmh,
                f.mean_speed_kmh,
                1,
            ),
            (
                "mean time lost, s",
                s.mean_time_loss_s,
                f.mean_time_loss_s,
                1,
            ),
            ("collisions", n(s.collisions), n(f.collisions), 0),
        ];
        for (label, sv, fv, decimals) in rows {
            let d = if decimals > 0 || label.starts_with("vehicles") {
                diff(fv, sv)
            } else {
                String::new()
            };
            let _ = writeln!(
                out,
                "{label:<28} {:>10} {:>10} {d:>9}",
                opt(sv, decimals),
                opt(fv, decimals)
            );
        }
        if let Some(t) = s.teleports {
            let _ = writeln!(out, "{:<28} {t:>10} {:>10}", "teleports", "–");
        }
        let _ = writeln!(
            out,
            "\n{:<40} {:>6} {:>8} {:>9} {:>9}",
            "route (departure edge → arrival edge)", "SUMO", "Flockway", "time SUMO", "Flockway"
        );
        for r in self.routes.iter().take(TABLE_ROWS) {
            let _ = writeln!(
                out,
                "{:<40} {:>6} {:>8} {:>9} {:>9}",
                format!("{} → {}", r.from, r.to),
                r.arrived.sumo,
                r.arrived.flockway,
                opt(r.mean_travel_time_s.sumo, 1),
                opt(r.mean_travel_time_s.flockway, 1)
            );
        }
        if self.routes.len() > TABLE_ROWS {
            let _ = writeln!(
                out,
                "… {} more routes (--json lists them all)",
                self.routes.len() - TABLE_ROWS
            );
        }
        let _ = writeln!(
            out,
            "\n{:<28} {:>10} {:>10} {:>10} {:>10}",
            "fringe edge", "departed", "", "arrived", ""
        );
        let _ = writeln!(
            out,
            "{:<28} {:>10} {:>10} {:>10} {:>10}",
            "", "SUMO", "Flockway", "SUMO", "Flockway"
        );
        let mut fringe: Vec<&FringeRow> = self.fringe.iter().collect();
        fringe.sort_by_key(|r| {
            std::cmp::Reverse(r.departed.sumo + r.arrived.sumo + r.departed.flockway)
        });
        for r in fringe.iter().take(TABLE_ROWS) {
            let _ = writeln!(
                out,
                "{:<28} {:>10} {:>10} {:>10} {:>10}",
                r.edge, r.departed.sumo, r.departed.flockway, r.arrived.sumo, r.arrived.flockway
            );
        }
        if fringe.len() > TABLE_ROWS {
            let _ = writeln!(out, "… {} more fringe edges", fringe.len() - TABLE_ROWS);
        }
        let matched = self.edges.iter().filter(|e| e.geh < GEH_MATCH).count();
        let _ = writeln!(
            out,
            "\nedge counts: GEH < {GEH_MATCH} on {matched} of {} ({:.0} %), hourly flows over {} s",
            self.edges.len(),
            self.geh_match_share * 100.0,
            self.seconds
        );
        let mut worst: Vec<&EdgeRow> = self.edges.iter().filter(|e| e.geh >= GEH_MATCH).collect();
        worst.sort_by(|a, b| b.geh.total_cmp(&a.geh));
        if !worst.is_empty() {
            let _ = writeln!(
                out,
                "{:<28} {:>10} {:>10} {:>6}",
                "edge with GEH ≥ 5", "SUMO", "Flockway", "GEH"
            );
        }
        for e in worst.iter().take(TABLE_ROWS) {
            let _ = writeln!(
                out,
                "{:<28} {:>10} {:>10} {:>6.1}",
                e.edge, e.vehicles.sumo, e.vehicles.flockway, e.geh
            );
        }
        if worst.len() > TABLE_ROWS {
            let _ = writeln!(out, "… {} more", worst.len() - TABLE_ROWS);
        }
        let v = &self.verdict;
        let _ = writeln!(
            out,
            "\ndeparted within {:.0} %: {}; arrived within {:.0} %: {}; mean travel time within {:.0} %: {}; \
             GEH < {GEH_MATCH} on ≥ {:.0} % of edge counts: {}",
            COUNT_TOLERANCE * 100.0,
            yes(v.departed),
            COUNT_TOLERANCE * 100.0,
            yes(v.arrived),
            TRAVEL_TIME_TOLERANCE * 100.0,
            yes(v.travel_time),
            GEH_SHARE * 100.0,
            yes(v.geh)
        );
        out
    }
}

/// The three SUMO output files a comparison reads, in a directory.
#[derive(Debug, Clone)]
pub struct SumoOutputs {
    /// `--tripinfo-output`.
    pub tripinfo: PathBuf,
    /// `--edgedata-output`.
    pub edgedata: PathBuf,
    /// `--statistic-output`.
    pub statistics: PathBuf,
}

impl SumoOutputs {
    /// The files' paths in `dir`.
    pub fn in_dir(dir: &Path) -> SumoOutputs {
        SumoOutputs {
            tripinfo: dir.join("tripinfo.xml"),
            edgedata: dir.join("edgedata.xml"),
            statistics: dir.join("statistics.xml"),
        }
    }

    /// SUMO's options that write them.
    pub fn args(&self) -> Vec<std::ffi::OsString> {
        let mut args = Vec::new();
        for (option, path) in [
            ("--tripinfo-output", &self.tripinfo),
            ("--edgedata-output", &self.edgedata),
            ("--statistic-output", &self.statistics),
        ] {
            args.push(option.into());
            args.push(path.clone().into_os_string());
        }
        args
    }

    /// Reads what SUMO wrote.
    pub fn read(&self) -> Result<ScenarioRun, AnalysisError> {
        let read = |path: &PathBuf| {
            std::fs::read_to_string(path).map_err(|source| AnalysisError::Io {
                path: path.clone(),
                source,
            })
        };
        let (t, e, s) = (
            read(&self.tripinfo)?,
            read(&self.edgedata)?,
            read(&self.statistics)?,
        );
        ScenarioRun::from_sumo(
            (&t, &self.tripinfo),
            (&e, &self.edgedata),
            (&s, &self.statistics),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRIPINFO: &str = r#"<tripinfos>
    <tripinfo id="0" depart="1.00" departLane="A_0" arrival="21.00" arrivalLane="B_x_1" routeLength="200.00" timeLoss="3.50"/>
    <tripinfo id="1" depart="5.00" departLane="A_1" arrival="35.00" arrivalLane="C_0" routeLength="300.00" timeLoss="6.50"/>
</tripinfos>"#;
    const EDGEDATA: &str = r#"<meandata><interval begin="0" end="100" id="e">
    <edge id="A" departed="2" entered="0" arrived="0"/>
    <edge id="B_x" entered="1" arrived="1"/>
    <edge id="C" entered="1" arrived="1"/>
    <edge id="D" sampledSeconds="0"/>
</interval></meandata>"#;
    const STATISTICS: &str = r#"<statistics><vehicles loaded="3" inserted="2" running="0" waiting="1"/>
    <teleports total="0"/><safety collisions="0" emergencyStops="0"/></statistics>"#;

    fn sumo() -> ScenarioRun {
        let p = Path::new("x.xml");
        ScenarioRun::from_sumo((TRIPINFO, p), (EDGEDATA, p), (STATISTICS, p)).expect("reads")
    }

    #[test]
    fn reads_sumo_s_trips_edges_and_statistics() {
        let run = sumo();
        assert_eq!(run.trips.len(), 2);
        assert_eq!(run.trips[0].depart_edge, "A");
        assert_eq!(
            run.trips[0].arrival_edge, "B_x",
            "an edge id with an underscore"
        );
        assert_eq!(run.trips[1].duration_s(), 30.0);
        assert_eq!(run.trips[1].time_loss_s, 6.5);
        assert_eq!(run.edges["A"].vehicles(), 2);
        assert_eq!(run.edges["C"].arrived, 1);
        assert_eq!(run.edges["D"].vehicles(), 0);
        assert_eq!((run.departed, run.waiting, run.running), (2, 1, 0));
        assert_eq!(run.teleports, Some(0));
    }

    #[test]
    fn a_bad_number_names_its_place() {
        let bad = r#"<tripinfos>
  <tripinfo depart="soon"/></tripinfos>"#;
        let p = Path::new("t.xml");
        let e = ScenarioRun::from_sumo((bad, p), (EDGEDATA, p), (STATISTICS, p))
            .expect_err("a bad depart");
        assert_eq!(
            e.to_string(),
            "t.xml: 2:3: <tripinfo> depart=\"soon\": expected a number"
        );
        let e = ScenarioRun::from_sumo((TRIPINFO, p), (EDGEDATA, p), ("<x/>", p))
            .expect_err("not statistics");
        assert!(e.to_string().contains("--statistic-output"), "{e}");
    }

    #[test]
    fn geh_is_the_textbook_formula() {
        assert_eq!(geh(0.0, 0.0), 0.0);
        // 1 100 veh/h modelled against 1 000 counted: √(2·100²/2100) ≈ 3.09.
        assert!((geh(1100.0, 1000.0) - 3.086).abs() < 1e-3);
        assert_eq!(geh(100.0, 100.0), 0.0);
        assert!((geh(50.0, 0.0) - 10.0).abs() < 1e-12);
    }

    #[test]
    fn equal_runs_match_and_a_missing_route_does_not() {
        let s = sumo();
        let c = compare(&s, &s, 100.0);
        assert!(c.verdict.all, "{c:#?}");
        assert_eq!(c.geh_match_share, 1.0);
        assert_eq!(c.routes.len(), 2);
        assert_eq!(
            c.routes[0].arrived,
            Pair {
                sumo: 1,
                flockway: 1
            }
        );
        assert_eq!(c.fringe.len(), 3);
        assert_eq!(c.edges.len(), 3, "edge D saw no vehicle");

        let mut f = s.clone();
        f.trips.pop();
        f.edges.remove("C");
        let c = compare(&s, &f, 100.0);
        assert!(!c.verdict.arrived);
        assert!(!c.verdict.all);
        let edge_c = c.edges.iter().find(|e| e.edge == "C").expect("C");
        assert_eq!(
            edge_c.vehicles,
            Pair {
                sumo: 1,
                flockway: 0
            }
        );
        // None against 36 veh/h: √(2·36²/36) = √72.
        assert!((edge_c.geh - 72f64.sqrt()).abs() < 1e-9);
        let table = c.table();
        assert!(table.contains("arrived within 5 %: NO"), "{table}");
        assert!(table.contains("A → C"), "{table}");
        let json = serde_json::to_value(&c).expect("serialises");
        assert_eq!(json["totals"]["sumo"]["arrived"], 2);
        assert_eq!(json["totals"]["flockway"]["arrived"], 1);
        assert_eq!(json["verdict"]["all"], false);
    }
}

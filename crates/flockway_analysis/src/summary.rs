//! The run summary contract: what `flockway run --summary` writes and every reader of it reads.
//!
//! [`Summary`] is the one definition of the JSON: its keys cannot drift from what is written,
//! because they are its fields. Keys are only ever added, never renamed; fields are in
//! alphabetical order, as the file lists them.

use crate::AnalysisError;
use crate::plot::PlotInfo;
use crate::trace::Trace;
use crate::wave::{Wave, WaveSettings, measure_wave};
use serde::{Deserialize, Deserializer, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The outcome of one expectation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExpectationResult {
    /// The expectation as written in the level.
    pub name: String,
    /// Whether it held.
    pub passed: bool,
    /// The measured value; `None` if the run did not measure that metric.
    pub value: Option<f64>,
}

/// A capacity sample counts toward the model errors (and is plotted) when its lane had a vehicle
/// ready at the line this share of the window at least (capacity is what a saturated approach
/// gets through).
pub const SATURATED_SHARE: f64 = 0.9;

/// The capacity of one yielding approach lane of a junction over one window of the run (a demand
/// step), against the two reference models.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CapacitySample {
    /// The junction.
    pub junction: String,
    /// The approach road.
    pub approach: String,
    /// Its lane.
    pub lane: u32,
    /// The window, s from the start.
    pub from_s: f64,
    /// Its end, s.
    pub to_s: f64,
    /// Share of the window with a vehicle ready at the line (1: saturated throughout).
    pub saturated_share: f64,
    /// Vehicles from the lane entering the junction per hour of saturated time.
    pub capacity_veh_per_h: f64,
    /// Vehicles per hour entering the paths it gives way to.
    pub conflicting_veh_per_h: f64,
    /// Mean critical gap of the vehicles that entered, s.
    pub critical_gap_s: f64,
    /// Mean follow-up time of the vehicles that entered, s.
    pub follow_up_s: f64,
    /// The gap-acceptance formula c = q·e^(−q·t_c) / (1 − e^(−q·t_f)), veh/h.
    pub gap_model_veh_per_h: f64,
    /// The HCM 6 single-lane roundabout entry c = 1 380·e^(−0.00102·v_c), veh/h.
    pub hcm_model_veh_per_h: f64,
}

/// What a run measured: the summary JSON of `flockway run --summary`, a documented contract.
///
/// Reading tolerates keys it does not know: a newer Flockway's summary reads in an older one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Vehicles removed after hitting a guardrail.
    pub collisions_guardrail: Option<f64>,
    /// Vehicle–vehicle contacts, one per pair per episode of contact.
    pub collisions_vehicle: Option<f64>,
    /// Each expectation's outcome, in level order.
    pub expectations: Vec<ExpectationResult>,
    /// Per destroyer: vehicles removed after the warm-up, per hour.
    pub flow_veh_per_h: BTreeMap<String, f64>,
    /// The level's name (its `name`, or the file stem).
    pub level: String,
    /// Mean travel time above free-flow travel time of the vehicles removed after the warm-up,
    /// s.
    #[serde(default)]
    pub mean_delay_s: Option<f64>,
    /// Mean of the sampled speeds after the warm-up, km/h.
    pub mean_speed_kmh: Option<f64>,
    /// Mean time from creation to a destroyer of the vehicles removed after the warm-up, s.
    pub mean_travel_time_s: Option<f64>,
    /// The medal the score earned (`bronze`, `silver`, `gold`); `None` without a score or
    /// below bronze.
    #[serde(default)]
    pub medal: Option<String>,
    /// Every measured metric by key (`metric` or `metric.name`; see `flockway_level::Metric`).
    pub metrics: BTreeMap<String, f64>,
    /// Times a vehicle missed the exit its route took.
    #[serde(default)]
    pub missed_exits: Option<f64>,
    /// Whether every expectation held.
    pub passed: bool,
    /// Simulated seconds per wall second (`null` in the file when the run took no time).
    #[serde(deserialize_with = "number_or_null")]
    pub realtime_factor: f64,
    /// The level's score (a challenge's), from its formula over `metrics`; `None` when the
    /// level has none or the run did not measure what it reads.
    #[serde(default)]
    pub score: Option<f64>,
    /// The seed used.
    pub seed: u64,
    /// Simulated seconds (`ticks / 120`).
    pub sim_seconds: f64,
    /// Standard deviation of the sampled speeds after the warm-up, km/h.
    pub speed_std_kmh: Option<f64>,
    /// Start of the measured part of the run (the level's `telemetry.stats_from_s`), s.
    pub stats_from_s: f64,
    /// Fixed steps simulated.
    pub ticks: u64,
    /// Sum over steps of vehicles alive.
    pub vehicle_steps: u64,
    /// Mean vehicles alive per step.
    pub vehicles_alive_mean: Option<f64>,
    /// Vehicles removed by destroyers.
    pub vehicles_destroyed: Option<f64>,
    /// Vehicles created (spawners and initial vehicles).
    pub vehicles_spawned: Option<f64>,
    /// Wall-clock seconds spent stepping.
    pub wall_seconds: f64,
    /// Whether a stop-and-go wave was found; `None` when no road held two vehicles.
    pub wave_detected: Option<bool>,
    /// The wave's period at a fixed point, s; `None` without a wave or when it does not repeat.
    pub wave_period_s: Option<f64>,
    /// The wave's propagation speed, km/h (negative: against the traffic); `None` without one.
    pub wave_speed_kmh: Option<f64>,
    /// Capacity of each yielding approach lane per demand step, for levels with priority
    /// junctions (absent otherwise).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub capacity: Vec<CapacitySample>,
}

/// JSON has no infinity: serde_json writes it as `null`, which reads back as infinity.
fn number_or_null<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::INFINITY))
}

impl Summary {
    /// The summary's keys, in the order the file lists them (for documentation and tests).
    pub fn keys() -> Vec<String> {
        let example = Summary {
            collisions_guardrail: None,
            collisions_vehicle: None,
            expectations: Vec::new(),
            flow_veh_per_h: BTreeMap::new(),
            level: String::new(),
            mean_delay_s: None,
            mean_speed_kmh: None,
            mean_travel_time_s: None,
            medal: None,
            metrics: BTreeMap::new(),
            missed_exits: None,
            passed: true,
            realtime_factor: 0.0,
            score: None,
            seed: 0,
            sim_seconds: 0.0,
            speed_std_kmh: None,
            stats_from_s: 0.0,
            ticks: 0,
            vehicle_steps: 0,
            vehicles_alive_mean: None,
            vehicles_destroyed: None,
            vehicles_spawned: None,
            wall_seconds: 0.0,
            wave_detected: None,
            wave_period_s: None,
            wave_speed_kmh: None,
            capacity: Vec::new(),
        };
        match serde_json::to_value(example) {
            Ok(serde_json::Value::Object(map)) => map.keys().cloned().collect(),
            _ => Vec::new(),
        }
    }

    /// The summary as JSON text, as `flockway run --summary` writes it (pretty, ending in a
    /// newline).
    pub fn to_json_text(&self) -> Result<String, serde_json::Error> {
        let mut text = serde_json::to_string_pretty(self)?;
        text.push('\n');
        Ok(text)
    }

    /// Reads a summary JSON written by `flockway run --summary`.
    pub fn read(path: &Path) -> Result<Summary, AnalysisError> {
        let bad = |message: String| AnalysisError::Summary {
            path: path.to_owned(),
            message,
        };
        let text = std::fs::read_to_string(path).map_err(|source| AnalysisError::Io {
            path: path.to_owned(),
            source,
        })?;
        let value: serde_json::Value = serde_json::from_str(&text)
            .map_err(|e| bad(format!("{}:{}: not JSON: {e}", e.line(), e.column())))?;
        // The keys that tell a summary from other JSON, checked first for a clear message.
        for key in ["level", "seed", "metrics"] {
            if value.get(key).is_none() {
                return Err(bad(format!(
                    "missing key `{key}`: expected the JSON of `flockway run --summary`"
                )));
            }
        }
        serde_json::from_value(value).map_err(|e| {
            bad(format!(
                "{e}: expected the JSON of `flockway run --summary`"
            ))
        })
    }

    /// Plot titles and road lengths from this summary (its level, seed and road lengths).
    pub fn plot_info(&self) -> PlotInfo {
        PlotInfo {
            level: self.level.clone(),
            seed: Some(self.seed),
            road_lengths: self
                .metrics
                .iter()
                .filter_map(|(k, v)| Some((k.strip_prefix("road_length_m.")?.to_owned(), *v)))
                .collect(),
            destroyers: Some(!self.flow_veh_per_h.is_empty()),
            capacity: self.capacity.clone(),
        }
    }

    /// The summary as text lines for a terminal.
    pub fn to_text(&self) -> String {
        let mut out = String::new();
        out.push_str(&format!("level            {}\n", self.level));
        out.push_str(&format!("seed             {}\n", self.seed));
        out.push_str(&format!("ticks            {}\n", self.ticks));
        out.push_str(&format!("simulated        {:.3} s\n", self.sim_seconds));
        out.push_str(&format!("wall             {:.3} s\n", self.wall_seconds));
        out.push_str(&format!(
            "speed-up         {:.1}× real time\n",
            self.realtime_factor
        ));
        out.push_str(&format!("vehicle-steps    {}\n", self.vehicle_steps));
        let traffic = [
            ("spawned", "vehicles_spawned"),
            ("destroyed", "vehicles_destroyed"),
            ("alive (mean)", "vehicles_alive_mean"),
            ("guardrail hits", "collisions_guardrail"),
            ("vehicle contacts", "collisions_vehicle"),
            ("mean speed km/h", "mean_speed_kmh"),
            ("speed std km/h", "speed_std_kmh"),
            ("travel time s", "mean_travel_time_s"),
            ("wave detected", "wave_detected"),
            ("wave speed km/h", "wave_speed_kmh"),
            ("wave period s", "wave_period_s"),
        ];
        for (label, key) in traffic {
            if let Some(v) = self.metrics.get(key) {
                out.push_str(&format!("{label:<17}{}\n", fmt_value(*v)));
            }
        }
        for (d, v) in &self.flow_veh_per_h {
            // A space after the name however long it is.
            out.push_str(&format!("flow {d:<11} {} veh/h\n", fmt_value(*v)));
        }
        // Each junction's measures, on one line.
        let junctions = self
            .metrics
            .keys()
            .filter_map(|k| k.strip_prefix("junction_flow_veh_per_h."));
        for j in junctions {
            let mut line = format!("junction {j:<8} ");
            for (key, label, unit) in [
                ("junction_flow_veh_per_h", "", " veh/h"),
                ("junction_delay_s", ", delay ", " s"),
                ("max_queue_m", ", longest queue ", " m"),
                ("discharge_headway_s", ", discharge headway ", " s"),
                ("red_entries", ", entered on red ", ""),
                ("deadlocks", ", deadlocks broken ", ""),
            ] {
                if let Some(v) = self.metrics.get(&format!("{key}.{j}")) {
                    line.push_str(&format!("{label}{}{unit}", fmt_value(*v)));
                }
            }
            out.push_str(&line);
            out.push('\n');
        }
        if !self.expectations.is_empty() {
            out.push_str("expectations\n");
            for e in &self.expectations {
                let value = e.value.map_or("not measured".to_owned(), |v| {
                    format!("measured {}", fmt_value(v))
                });
                out.push_str(&format!(
                    "  {} {}  ({value})\n",
                    if e.passed { "PASS" } else { "FAIL" },
                    e.name
                ));
            }
            let failed = self.expectations.iter().filter(|e| !e.passed).count();
            out.push_str(&format!(
                "{} passed, {} failed\n",
                self.expectations.len() - failed,
                failed
            ));
        }
        out
    }
}

fn fmt_value(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{v:.0}")
    } else {
        format!("{v:.3}")
    }
}

/// Plot titles and road lengths for a run's CSV: from its summary if given, else the file name.
pub fn plot_info(csv: &Path, summary: Option<&Summary>) -> PlotInfo {
    match summary {
        Some(s) => s.plot_info(),
        None => PlotInfo {
            level: csv
                .file_stem()
                .map_or_else(|| "run".to_owned(), |s| s.to_string_lossy().into_owned()),
            ..PlotInfo::default()
        },
    }
}

/// The stop-and-go wave of a run read back from its CSV: measured after the summary's warm-up
/// (`stats_from_s`), or over the second half of the run without a summary.
pub fn wave_of(trace: &Trace, info: &PlotInfo, summary: Option<&Summary>) -> Option<Wave> {
    let from_s = summary.map_or(0.5 * trace.end_s(), |s| s.stats_from_s);
    let settings = WaveSettings {
        from_s,
        ..WaveSettings::default()
    };
    measure_wave(trace, &info.road_lengths, &settings)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_keys_are_the_documented_contract_in_file_order() {
        let keys = Summary::keys();
        let mut sorted = keys.clone();
        sorted.sort();
        assert_eq!(
            keys, sorted,
            "fields stay in alphabetical order, as the file lists them"
        );
        for k in [
            "level",
            "seed",
            "ticks",
            "passed",
            "expectations",
            "metrics",
            "wave_speed_kmh",
        ] {
            assert!(keys.iter().any(|x| x == k), "{k}");
        }
    }

    #[test]
    fn a_summary_reads_back_what_was_written_with_an_infinite_speed_up() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("s.json");
        let mut s: Summary = serde_json::from_str(&format!(
            "{{{}}}",
            Summary::keys()
                .iter()
                .map(|k| format!(
                    "\"{k}\": {}",
                    match k.as_str() {
                        "expectations" => "[]",
                        "flow_veh_per_h" | "metrics" => "{}",
                        "level" => "\"x\"",
                        "passed" => "true",
                        "realtime_factor" => "null",
                        "seed" | "ticks" | "vehicle_steps" | "sim_seconds" | "stats_from_s"
                        | "wall_seconds" => "1",
                        _ => "null",
                    }
                ))
                .collect::<Vec<_>>()
                .join(",")
        ))
        .expect("parses");
        assert_eq!(s.realtime_factor, f64::INFINITY);
        s.metrics.insert("road_length_m.ring".into(), 230.0);
        std::fs::write(&path, s.to_json_text().expect("json")).expect("write");
        assert_eq!(Summary::read(&path).expect("reads"), s);
        assert_eq!(s.plot_info().road_lengths["ring"], 230.0);
        std::fs::write(&path, "{\"level\": 1}").expect("write");
        let e = Summary::read(&path).expect_err("not a summary");
        assert!(e.to_string().contains("flockway run --summary"), "{e}");
    }
}

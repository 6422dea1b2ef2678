//! Expectations: checks a level states about its own runs, written as short strings.
//!
//! Grammar: `METRIC[.NAME] OP VALUE` with OP one of `==`, `!=`, `<`, `<=`, `>`, `>=`, or
//! `METRIC[.NAME] in LOW..HIGH` (both ends included). VALUE is a number, `true` or `false`.
//! `NAME` picks a road or destroyer for metrics measured per road or per destroyer.

use serde::{Deserialize, Serialize};
use std::fmt;

/// What a metric's qualifier names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Qualifier {
    /// The metric takes no qualifier.
    None,
    /// The qualifier is a road name (required).
    Road,
    /// The qualifier is a destroyer name (required).
    Destroyer,
    /// Optionally a driver profile name: the metric over that profile's vehicles only.
    Profile,
    /// The qualifier is a junction name (required).
    Junction,
}

/// A metric that expectations may test, with its unit and meaning.
#[derive(Debug, Clone, Copy)]
pub struct MetricInfo {
    /// Name as written in expectations and in the summary JSON.
    pub name: &'static str,
    /// What the qualifier after the dot names.
    pub qualifier: Qualifier,
    /// Unit, for messages and documentation.
    pub unit: &'static str,
    /// What it measures.
    pub description: &'static str,
}

/// Every metric a run measures and a level's expectations may test: the one table the
/// expectation parser, the runner and the documentation all use. A run that does not measure a
/// metric (no vehicles, no destroyers) fails an expectation on it with "not measured".
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Metric {
    /// Fixed steps simulated (steps).
    Ticks,
    /// Simulated time (s).
    SimSeconds,
    /// Sum over steps of vehicles alive (vehicle-steps).
    VehicleSteps,
    /// Centre-line length of a road (m).
    RoadLengthM,
    /// Vehicles created (initial and spawned) (vehicles).
    VehiclesSpawned,
    /// Vehicles removed by destroyers (vehicles).
    VehiclesDestroyed,
    /// Mean vehicles alive per step (vehicles).
    VehiclesAliveMean,
    /// Timetabled vehicles due that had not found room to depart at the end (vehicles).
    InsertionBacklog,
    /// Guardrail plus vehicle-vehicle collisions (events).
    Collisions,
    /// Vehicles removed after hitting a guardrail (events).
    CollisionsGuardrail,
    /// Vehicle-vehicle contact episodes (events).
    CollisionsVehicle,
    /// Mean sampled speed after the warm-up (km/h).
    MeanSpeedKmh,
    /// Standard deviation of sampled speeds after the warm-up (km/h).
    SpeedStdKmh,
    /// Vehicles reaching a destroyer per hour (veh/h).
    FlowVehPerH,
    /// Mean speed of vehicles as destroyers remove them (after the warm-up) (km/h).
    FinalSpeedKmh,
    /// Share of vehicles leaving at 95 % of their speed limit or faster (after the warm-up) (share 0-1).
    FinalLimitShare,
    /// Mean time from creation to a destroyer (s).
    MeanTravelTimeS,
    /// Mean travel time above free-flow travel time, of vehicles reaching a destroyer (s).
    MeanDelayS,
    /// Vehicles that missed the exit their route took and were sent another way (vehicles).
    MissedExits,
    /// Whether a stop-and-go wave was found (bool).
    WaveDetected,
    /// Propagation speed of the wave (negative: against traffic) (km/h).
    WaveSpeedKmh,
    /// Period of the wave at a fixed point (s).
    WavePeriodS,
    /// Mean delay of the vehicles through a junction (s).
    JunctionDelayS,
    /// Longest queue waiting at a junction (m).
    MaxQueueM,
    /// Vehicles entering a junction per hour (veh/h).
    JunctionFlowVehPerH,
    /// Mean headway of queued vehicles crossing a signal's line, from the fifth on (s).
    DischargeHeadwayS,
    /// Vehicles that entered a junction against a red signal.
    RedEntries,
    /// Deadlocks broken at a junction.
    Deadlocks,
    /// Largest relative difference between a yielding approach's capacity and the
    /// gap-acceptance formula.
    GapModelError,
    /// Largest relative difference between a yielding approach's capacity and the HCM 6
    /// single-lane roundabout model.
    HcmModelError,
    /// Distance driven (veh-km).
    VehKm,
    /// Follower–leader conflict episodes with a time to collision below the threshold (episodes).
    ConflictsTtc,
    /// Follower–leader conflict episodes with a deceleration rate to avoid the crash above the
    /// threshold (episodes).
    ConflictsDrac,
    /// Crossings at a junction with a post-encroachment time below the threshold (conflicts).
    ConflictsPet,
    /// Lowest time to collision of a vehicle closing on the one ahead (s).
    MinTtcS,
    /// Highest deceleration rate to avoid a crash (m/s²).
    MaxDracMps2,
    /// Conflicts (episodes and PET conflicts) per million vehicle-kilometres.
    ConflictsPerMillionVehKm,
}

impl Metric {
    /// Every metric, in the order the documentation lists them.
    pub const ALL: [Metric; 37] = [
        Metric::Ticks,
        Metric::SimSeconds,
        Metric::VehicleSteps,
        Metric::RoadLengthM,
        Metric::VehiclesSpawned,
        Metric::VehiclesDestroyed,
        Metric::VehiclesAliveMean,
        Metric::InsertionBacklog,
        Metric::Collisions,
        Metric::CollisionsGuardrail,
        Metric::CollisionsVehicle,
        Metric::MeanSpeedKmh,
        Metric::SpeedStdKmh,
        Metric::FlowVehPerH,
        Metric::FinalSpeedKmh,
        Metric::FinalLimitShare,
        Metric::MeanTravelTimeS,
        Metric::MeanDelayS,
        Metric::MissedExits,
        Metric::WaveDetected,
        Metric::WaveSpeedKmh,
        Metric::WavePeriodS,
        Metric::JunctionDelayS,
        Metric::MaxQueueM,
        Metric::JunctionFlowVehPerH,
        Metric::DischargeHeadwayS,
        Metric::RedEntries,
        Metric::Deadlocks,
        Metric::GapModelError,
        Metric::HcmModelError,
        Metric::VehKm,
        Metric::ConflictsTtc,
        Metric::ConflictsDrac,
        Metric::ConflictsPet,
        Metric::MinTtcS,
        Metric::MaxDracMps2,
        Metric::ConflictsPerMillionVehKm,
    ];

    /// Its name, unit, qualifier and meaning.
    pub const fn info(self) -> MetricInfo {
        match self {
            Metric::Ticks => MetricInfo {
                name: "ticks",
                qualifier: Qualifier::None,
                unit: "steps",
                description: "fixed steps simulated",
            },
            Metric::SimSeconds => MetricInfo {
                name: "sim_seconds",
                qualifier: Qualifier::None,
                unit: "s",
                description: "simulated time",
            },
            Metric::VehicleSteps => MetricInfo {
                name: "vehicle_steps",
                qualifier: Qualifier::None,
                unit: "vehicle-steps",
                description: "sum over steps of vehicles alive",
            },
            Metric::RoadLengthM => MetricInfo {
                name: "road_length_m",
                qualifier: Qualifier::Road,
                unit: "m",
                description: "centre-line length of a road",
            },
            Metric::VehiclesSpawned => MetricInfo {
                name: "vehicles_spawned",
                qualifier: Qualifier::None,
                unit: "vehicles",
                description: "vehicles created (initial and spawned)",
            },
            Metric::VehiclesDestroyed => MetricInfo {
                name: "vehicles_destroyed",
                qualifier: Qualifier::None,
                unit: "vehicles",
                description: "vehicles removed by destroyers",
            },
            Metric::InsertionBacklog => MetricInfo {
                name: "insertion_backlog",
                qualifier: Qualifier::None,
                unit: "vehicles",
                description: "vehicles of a spawner's timetable that were due but had not found room to depart when the run ended (only for levels with timetables)",
            },
            Metric::VehiclesAliveMean => MetricInfo {
                name: "vehicles_alive_mean",
                qualifier: Qualifier::None,
                unit: "vehicles",
                description: "mean vehicles alive per step",
            },
            Metric::Collisions => MetricInfo {
                name: "collisions",
                qualifier: Qualifier::None,
                unit: "events",
                description: "guardrail plus vehicle-vehicle collisions",
            },
            Metric::CollisionsGuardrail => MetricInfo {
                name: "collisions_guardrail",
                qualifier: Qualifier::Profile,
                unit: "events",
                description: "vehicles removed after hitting a guardrail",
            },
            Metric::CollisionsVehicle => MetricInfo {
                name: "collisions_vehicle",
                qualifier: Qualifier::None,
                unit: "events",
                description: "vehicle-vehicle contact episodes",
            },
            Metric::MeanSpeedKmh => MetricInfo {
                name: "mean_speed_kmh",
                qualifier: Qualifier::Profile,
                unit: "km/h",
                description: "mean sampled speed after the warm-up",
            },
            Metric::SpeedStdKmh => MetricInfo {
                name: "speed_std_kmh",
                qualifier: Qualifier::Profile,
                unit: "km/h",
                description: "standard deviation of sampled speeds after the warm-up",
            },
            Metric::FlowVehPerH => MetricInfo {
                name: "flow_veh_per_h",
                qualifier: Qualifier::Destroyer,
                unit: "veh/h",
                description: "vehicles reaching a destroyer per hour",
            },
            Metric::FinalSpeedKmh => MetricInfo {
                name: "final_speed_kmh",
                qualifier: Qualifier::Profile,
                unit: "km/h",
                description: "mean speed of vehicles as destroyers remove them (after the warm-up)",
            },
            Metric::FinalLimitShare => MetricInfo {
                name: "final_limit_share",
                qualifier: Qualifier::Profile,
                unit: "share 0-1",
                description: "share of vehicles leaving at 95 % of their speed limit or faster (after the warm-up)",
            },
            Metric::MeanTravelTimeS => MetricInfo {
                name: "mean_travel_time_s",
                qualifier: Qualifier::None,
                unit: "s",
                description: "mean time from creation to a destroyer",
            },
            Metric::MeanDelayS => MetricInfo {
                name: "mean_delay_s",
                qualifier: Qualifier::Profile,
                unit: "s",
                description: "mean travel time above free-flow travel time (the distance at the speed limits in force) of vehicles reaching a destroyer after the warm-up",
            },
            Metric::MissedExits => MetricInfo {
                name: "missed_exits",
                qualifier: Qualifier::Profile,
                unit: "vehicles",
                description: "times a vehicle left its route because it could not reach a lane leading on along it (it then takes the quickest way to its destination, if any)",
            },
            Metric::WaveDetected => MetricInfo {
                name: "wave_detected",
                qualifier: Qualifier::None,
                unit: "bool",
                description: "whether a stop-and-go wave was found",
            },
            Metric::WaveSpeedKmh => MetricInfo {
                name: "wave_speed_kmh",
                qualifier: Qualifier::None,
                unit: "km/h",
                description: "propagation speed of the wave (negative: against traffic)",
            },
            Metric::WavePeriodS => MetricInfo {
                name: "wave_period_s",
                qualifier: Qualifier::None,
                unit: "s",
                description: "period of the wave at a fixed point",
            },
            Metric::JunctionDelayS => MetricInfo {
                name: "junction_delay_s",
                qualifier: Qualifier::Junction,
                unit: "s",
                description: "mean delay of the vehicles entering a junction after the warm-up: time from 150 m before its line to the line above that stretch at the speed limit",
            },
            Metric::MaxQueueM => MetricInfo {
                name: "max_queue_m",
                qualifier: Qualifier::Junction,
                unit: "m",
                description: "longest queue at a junction after the warm-up, on any approach lane: from the line to the back of the queue's last car (cars below 2 m/s one behind the other within 150 m of the line, the first within 20 m of it, each within 10 m of the one before)",
            },
            Metric::JunctionFlowVehPerH => MetricInfo {
                name: "junction_flow_veh_per_h",
                qualifier: Qualifier::Junction,
                unit: "veh/h",
                description: "vehicles entering a junction per hour after the warm-up",
            },
            Metric::DischargeHeadwayS => MetricInfo {
                name: "discharge_headway_s",
                qualifier: Qualifier::Junction,
                unit: "s",
                description: "mean time between queued vehicles crossing a signal's line on one lane in one green, from the fifth of the queue on, where both go straight on (3 600 / it is the lane's saturation flow for through traffic)",
            },
            Metric::RedEntries => MetricInfo {
                name: "red_entries",
                qualifier: Qualifier::Junction,
                unit: "",
                description: "vehicles whose front crossed a signal's line on red after the warm-up (amber is not red)",
            },
            Metric::Deadlocks => MetricInfo {
                name: "deadlocks",
                qualifier: Qualifier::Junction,
                unit: "",
                description: "vehicles at a junction without a signal that went after waiting 20 s at the line with nothing in their way moving (the deadlock rule), over the whole run",
            },
            Metric::GapModelError => MetricInfo {
                name: "gap_model_error",
                qualifier: Qualifier::Junction,
                unit: "",
                description: "largest relative difference between measured and model capacity (either way) over the demand steps and yielding approach lanes (saturated 90 % of the step or more) of a priority junction, the model the gap-acceptance formula c = q·e^(−q·t_c) / (1 − e^(−q·t_f)) with the entering drivers' critical gap and follow-up time",
            },
            Metric::HcmModelError => MetricInfo {
                name: "hcm_model_error",
                qualifier: Qualifier::Junction,
                unit: "",
                description: "the same against the HCM 6 single-lane roundabout entry capacity c = 1 380·e^(−0.00102·v_c), v_c the flow it gives way to",
            },
            Metric::VehKm => MetricInfo {
                name: "veh_km",
                qualifier: Qualifier::Profile,
                unit: "veh-km",
                description: "distance the vehicles drove, over the whole run",
            },
            Metric::ConflictsTtc => MetricInfo {
                name: "conflicts_ttc",
                qualifier: Qualifier::Profile,
                unit: "episodes",
                description: "conflict episodes of a follower behind the vehicle ahead of its body whose time to collision (gap over closing speed) fell below `ssm.ttc_s` (default 1.5 s); breaks shorter than 1 s are one episode; with a profile, the episodes a vehicle of the profile took part in (either vehicle)",
            },
            Metric::ConflictsDrac => MetricInfo {
                name: "conflicts_drac",
                qualifier: Qualifier::Profile,
                unit: "episodes",
                description: "conflict episodes whose deceleration rate to avoid the crash (closing speed² over twice the gap) rose above `ssm.drac_mps2` (default 3 m/s²)",
            },
            Metric::ConflictsPet => MetricInfo {
                name: "conflicts_pet",
                qualifier: Qualifier::Junction,
                unit: "conflicts",
                description: "vehicles entering a junction's crossing conflict area less than `ssm.pet_s` (default 1 s) after a vehicle on the crossing path left it (post-encroachment time), over the whole run",
            },
            Metric::MinTtcS => MetricInfo {
                name: "min_ttc_s",
                qualifier: Qualifier::Profile,
                unit: "s",
                description: "lowest time to collision of a vehicle closing on the vehicle ahead of its body (with a profile: either vehicle of it), over the whole run",
            },
            Metric::MaxDracMps2 => MetricInfo {
                name: "max_drac_mps2",
                qualifier: Qualifier::Profile,
                unit: "m/s²",
                description: "highest deceleration rate to avoid a crash of a vehicle closing on the one ahead (with a profile: either vehicle of it), over the whole run",
            },
            Metric::ConflictsPerMillionVehKm => MetricInfo {
                name: "conflicts_per_million_veh_km",
                qualifier: Qualifier::Profile,
                unit: "1/(10⁶ veh-km)",
                description: "conflict episodes (TTC or DRAC) and PET conflicts per million vehicle-kilometres driven; with a profile, those its vehicles took part in per million of their vehicle-kilometres",
            },
        }
    }

    /// Its name, as expectations and the summary write it.
    pub const fn name(self) -> &'static str {
        self.info().name
    }

    /// The summary key of an unqualified measurement (`vehicles_spawned`).
    pub fn key(self) -> String {
        self.name().to_owned()
    }

    /// The summary key of a measurement of one road, destroyer or profile
    /// (`flow_veh_per_h.exit`).
    pub fn key_for(self, name: &str) -> String {
        format!("{}.{name}", self.name())
    }

    /// The metric with this name.
    pub fn from_name(name: &str) -> Option<Metric> {
        Metric::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// Every metric's [`MetricInfo`], in [`Metric::ALL`] order.
pub const METRICS: [MetricInfo; Metric::ALL.len()] = {
    let mut out = [Metric::Ticks.info(); Metric::ALL.len()];
    let mut i = 0;
    while i < out.len() {
        out[i] = Metric::ALL[i].info();
        i += 1;
    }
    out
};

/// Looks a metric up by name.
pub fn metric_info(name: &str) -> Option<&'static MetricInfo> {
    METRICS.iter().find(|m| m.name == name)
}

/// The comparison an expectation makes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Check {
    /// Equal (within 1e-9 relative).
    Eq(f64),
    /// Not equal.
    Ne(f64),
    /// Less than.
    Lt(f64),
    /// At most.
    Le(f64),
    /// Greater than.
    Gt(f64),
    /// At least.
    Ge(f64),
    /// Within `[low, high]`.
    In(f64, f64),
}

/// One check a run must pass.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct Expectation {
    /// The metric.
    pub metric: Metric,
    /// Road or destroyer name, for metrics that need one.
    pub qualifier: Option<String>,
    /// The comparison.
    pub check: Check,
}

impl Expectation {
    /// The key of the measured value: `metric` or `metric.qualifier`.
    pub fn key(&self) -> String {
        match &self.qualifier {
            Some(q) => self.metric.key_for(q),
            None => self.metric.key(),
        }
    }

    /// Whether a measured value passes.
    pub fn holds(&self, value: f64) -> bool {
        let eq = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0);
        match self.check {
            Check::Eq(x) => eq(value, x),
            Check::Ne(x) => !eq(value, x),
            Check::Lt(x) => value < x,
            Check::Le(x) => value <= x,
            Check::Gt(x) => value > x,
            Check::Ge(x) => value >= x,
            Check::In(lo, hi) => value >= lo && value <= hi,
        }
    }

    /// Parses `METRIC[.NAME] OP VALUE`.
    pub fn parse(text: &str) -> Result<Expectation, String> {
        let text = text.trim();
        let key_end = text
            .find(|c: char| c.is_whitespace() || "=!<>".contains(c))
            .unwrap_or(text.len());
        let (key, rest) = text.split_at(key_end);
        if key.is_empty() {
            return Err(format!(
                "expected `METRIC OP VALUE` (e.g. `collisions == 0`), found `{text}`"
            ));
        }
        let (metric, qualifier) = match key.split_once('.') {
            Some((m, q)) => (m, Some(q.to_owned())),
            None => (key, None),
        };
        let found = Metric::from_name(metric).ok_or_else(|| {
            let names: Vec<&str> = METRICS.iter().map(|m| m.name).collect();
            format!(
                "unknown metric `{metric}`; known metrics: {}",
                names.join(", ")
            )
        })?;
        match (found.info().qualifier, &qualifier) {
            (Qualifier::None, Some(q)) => return Err(format!("metric `{metric}` takes no `.{q}`")),
            (Qualifier::Road, None) => {
                return Err(format!("metric `{metric}` needs a road: `{metric}.ROAD`"));
            }
            (Qualifier::Destroyer, None) => {
                return Err(format!(
                    "metric `{metric}` needs a destroyer: `{metric}.DESTROYER`"
                ));
            }
            (Qualifier::Junction, None) => {
                return Err(format!(
                    "metric `{metric}` needs a junction: `{metric}.JUNCTION`"
                ));
            }
            (_, Some(q)) if q.is_empty() => return Err(format!("empty name after `{metric}.`")),
            _ => {}
        }
        let rest = rest.trim_start();
        let number = |s: &str| -> Result<f64, String> {
            let s = s.trim();
            let v = match s {
                "true" => 1.0,
                "false" => 0.0,
                _ => s
                    .parse::<f64>()
                    .map_err(|_| format!("expected a number, `true` or `false`, found `{s}`"))?,
            };
            if v.is_finite() {
                Ok(v)
            } else {
                Err(format!("expected a finite number, found `{s}`"))
            }
        };
        let check = if let Some(range) = rest
            .strip_prefix("in")
            .filter(|r| r.starts_with(char::is_whitespace))
        {
            let (lo, hi) = range
                .trim()
                .split_once("..")
                .ok_or_else(|| format!("expected `in LOW..HIGH`, found `in{range}`"))?;
            let (lo, hi) = (number(lo)?, number(hi)?);
            if lo > hi {
                return Err(format!(
                    "empty range {lo}..{hi}: the low end must not exceed the high end"
                ));
            }
            Check::In(lo, hi)
        } else {
            type Make = fn(f64) -> Check;
            let ops: [(&str, Make); 6] = [
                ("==", Check::Eq),
                ("!=", Check::Ne),
                ("<=", Check::Le),
                (">=", Check::Ge),
                ("<", Check::Lt),
                (">", Check::Gt),
            ];
            let (op, make) = ops
                .iter()
                .find(|(op, _)| rest.starts_with(op))
                .ok_or_else(|| {
                    format!("expected one of == != < <= > >= or `in` after `{key}`, found `{rest}`")
                })?;
            make(number(&rest[op.len()..])?)
        };
        Ok(Expectation {
            metric: found,
            qualifier,
            check,
        })
    }
}

impl fmt::Display for Expectation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let key = self.key();
        match self.check {
            Check::Eq(x) => write!(f, "{key} == {x}"),
            Check::Ne(x) => write!(f, "{key} != {x}"),
            Check::Lt(x) => write!(f, "{key} < {x}"),
            Check::Le(x) => write!(f, "{key} <= {x}"),
            Check::Gt(x) => write!(f, "{key} > {x}"),
            Check::Ge(x) => write!(f, "{key} >= {x}"),
            Check::In(lo, hi) => write!(f, "{key} in {lo}..{hi}"),
        }
    }
}

impl TryFrom<String> for Expectation {
    type Error = String;
    fn try_from(s: String) -> Result<Expectation, String> {
        Expectation::parse(&s)
    }
}

impl From<Expectation> for String {
    fn from(e: Expectation) -> String {
        e.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_form() {
        let e = Expectation::parse("mean_speed_kmh in 57..63").expect("parses");
        assert_eq!(e.check, Check::In(57.0, 63.0));
        assert!(e.holds(57.0) && e.holds(63.0) && !e.holds(63.1));
        let e = Expectation::parse("collisions==0").expect("parses");
        assert!(e.holds(0.0) && !e.holds(1.0));
        let e = Expectation::parse("road_length_m.ring >= 229.5").expect("parses");
        assert_eq!(e.key(), "road_length_m.ring");
        assert!(
            Expectation::parse("wave_detected == true")
                .expect("parses")
                .holds(1.0)
        );
        assert!(
            Expectation::parse("wave_speed_kmh in -25..-12")
                .expect("parses")
                .holds(-20.0)
        );
        for (text, check) in [
            ("ticks < 5", Check::Lt(5.0)),
            ("ticks <= 5", Check::Le(5.0)),
            ("ticks > 5", Check::Gt(5.0)),
            ("ticks != 5", Check::Ne(5.0)),
        ] {
            assert_eq!(Expectation::parse(text).expect("parses").check, check);
        }
    }

    #[test]
    fn display_round_trips() {
        for text in [
            "mean_speed_kmh in 57..63.5",
            "collisions == 0",
            "flow_veh_per_h.exit >= 1000",
            "wave_speed_kmh in -25..-12",
        ] {
            let e = Expectation::parse(text).expect("parses");
            assert_eq!(e.to_string(), text);
            assert_eq!(Expectation::parse(&e.to_string()).expect("reparses"), e);
        }
    }

    #[test]
    fn rejects_nonsense_with_reasons() {
        for (text, needle) in [
            ("", "expected `METRIC OP VALUE`"),
            ("speed == 3", "unknown metric `speed`"),
            ("collisions ~ 3", "expected one of"),
            ("collisions == fast", "expected a number"),
            ("collisions == NaN", "finite"),
            ("mean_speed_kmh in 63..57", "empty range"),
            ("mean_speed_kmh in 57", "LOW..HIGH"),
            ("road_length_m == 3", "needs a road"),
            ("flow_veh_per_h > 3", "needs a destroyer"),
            ("collisions.main == 0", "takes no"),
        ] {
            let err = Expectation::parse(text).expect_err(text);
            assert!(err.contains(needle), "`{text}`: {err}");
        }
    }
}

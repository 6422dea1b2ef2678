//! The level file format, version 1. Every field a level can hold is defined here, including
//! those whose systems arrive later, so the format is settled before files exist in the wild.

use crate::expect::Expectation;
use crate::score::ScoreSpec;
use flockway_road::{JunctionSpec, RoadSpec};
use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The level format version this build reads and writes.
pub const CURRENT_VERSION: u32 = 1;

/// A saved level: roads, traffic, telemetry settings and what a good run must show.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Level {
    /// Format version; must be 1.
    pub version: u32,
    /// Human-readable name (defaults to the file name when empty).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub name: String,
    /// What the level shows, for people reading it.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub description: String,
    /// Seed of every random stream in the run (overridable with `--seed`).
    pub seed: u64,
    /// Simulated duration of a run, in seconds.
    pub duration_s: f64,
    /// Roads, in id order (road `i` has id `i`).
    #[serde(default)]
    pub roads: Vec<RoadSpec>,
    /// Junctions: where links cross or meet inside an area, with right of way by rule or
    /// signal. Their paths are roads named `JUNCTION#k`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub junctions: Vec<JunctionSpec>,
    /// Vehicle types by name, each a vehicle definition file under `assets/`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub vehicle_types: Vec<VehicleTypeSpec>,
    /// Driver profiles by name: a driver model, its parameters and the vehicle it drives.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub driver_profiles: Vec<DriverProfileSpec>,
    /// Places that add vehicles during the run.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub spawners: Vec<SpawnerSpec>,
    /// Places that remove vehicles that reach them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub destroyers: Vec<DestroyerSpec>,
    /// Stretches of road that change vehicles entering them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub triggers: Vec<TriggerSpec>,
    /// Vehicles present at the start, in groups spaced evenly along a lane.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub vehicles: Vec<InitialVehiclesSpec>,
    /// Induction loops: points on a road's lanes that count the vehicles passing, how long
    /// they are covered and how fast vehicles pass, per period (`STEM.detectors.csv`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub detectors: Vec<DetectorSpec>,
    /// What is recorded, and how often.
    #[serde(default, skip_serializing_if = "TelemetrySpec::is_default")]
    pub telemetry: TelemetrySpec,
    /// The thresholds of the surrogate safety measures (conflicts by TTC, PET and DRAC).
    #[serde(default, skip_serializing_if = "SsmSpec::is_default")]
    pub ssm: SsmSpec,
    /// Checks a run must pass, e.g. `"collisions == 0"`, `"mean_speed_kmh in 57..63"`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub expect: Vec<Expectation>,
    /// The score a run earns, with medal thresholds: a level with one is a challenge.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub score: Option<ScoreSpec>,
}

impl Level {
    /// An empty level with the given seed and duration.
    pub fn new(seed: u64, duration_s: f64) -> Level {
        Level {
            version: CURRENT_VERSION,
            name: String::new(),
            description: String::new(),
            seed,
            duration_s,
            roads: Vec::new(),
            junctions: Vec::new(),
            vehicle_types: Vec::new(),
            driver_profiles: Vec::new(),
            spawners: Vec::new(),
            destroyers: Vec::new(),
            triggers: Vec::new(),
            detectors: Vec::new(),
            vehicles: Vec::new(),
            telemetry: TelemetrySpec::default(),
            ssm: SsmSpec::default(),
            expect: Vec::new(),
            score: None,
        }
    }

    /// The roads traffic at the end of road `name` continues onto: its links' and its junction
    /// connections' (a junction's path in between), in that order, each once.
    pub fn leads_to(&self, name: &str) -> Vec<&str> {
        let mut out: Vec<&str> = Vec::new();
        let links = self.road(name).map(|r| r.outgoing()).unwrap_or_default();
        let through = self
            .junctions
            .iter()
            .flat_map(|j| &j.connections)
            .filter(|c| c.from == name)
            .map(|c| c.to.as_str());
        for to in links
            .iter()
            .filter_map(|l| self.road(&l.to).map(|r| r.name.as_str()))
            .chain(through)
        {
            if !out.contains(&to) {
                out.push(to);
            }
        }
        out
    }

    /// [`Level::leads_to`] of every road that leads anywhere, found in one pass over the
    /// links and junctions (a city's network asks it of thousands of roads).
    pub fn successors(&self) -> BTreeMap<&str, Vec<&str>> {
        let names: std::collections::BTreeSet<&str> =
            self.roads.iter().map(|r| r.name.as_str()).collect();
        let mut pairs: Vec<(&str, &str)> = Vec::new();
        for road in &self.roads {
            let Some(&from) = names.get(road.name.as_str()) else {
                continue;
            };
            // As `RoadSpec::outgoing` orders them: `next`, then the links.
            if let Some(&to) = road.next.as_deref().and_then(|n| names.get(n)) {
                pairs.push((from, to));
            }
            for link in &road.links {
                if let Some(&to) = names.get(link.to.as_str()) {
                    pairs.push((from, to));
                }
            }
        }
        for c in self.junctions.iter().flat_map(|j| &j.connections) {
            if let Some(&from) = names.get(c.from.as_str()) {
                pairs.push((from, c.to.as_str()));
            }
        }
        let mut out: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
        for (from, to) in pairs {
            let list = out.entry(from).or_default();
            if !list.contains(&to) {
                list.push(to);
            }
        }
        out
    }

    /// The road with this name.
    pub fn road(&self, name: &str) -> Option<&RoadSpec> {
        self.roads.iter().find(|r| r.name == name)
    }
}

/// A named vehicle type: a vehicle definition file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleTypeSpec {
    /// Name that driver profiles refer to.
    pub name: String,
    /// Path of the vehicle definition, relative to `assets/` (e.g. `"vehicles/sedan.ron"`).
    pub path: String,
}

/// The driver models Flockway provides, plus any a plugin registers.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub enum DriverModel {
    /// Reynolds flocking: speed matching, road following and collision avoidance.
    Flock,
    /// Flocking that keeps to its lane: avoidance only along the lane (the default autonomous car).
    FlockLanes,
    /// Human-like: shorter range, reaction delay, harsher inputs, a desired speed of its own.
    Human,
    /// The Intelligent Driver Model (Treiber 2000), as a reference.
    Idm,
    /// The wave-damping autonomous car: drives at the flow's mean speed with a gap that absorbs
    /// stop-and-go waves (after Stern et al. 2018).
    WaveDamper,
    /// A driver a plugin registers under this name.
    Custom(String),
}

/// A named driver profile: which model, with which parameters, in which vehicle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriverProfileSpec {
    /// Name that spawners and initial vehicles refer to.
    pub name: String,
    /// The driver model.
    pub model: DriverModel,
    /// Name of the vehicle type this driver drives.
    pub vehicle: String,
    /// Parameter file relative to `assets/` (e.g. `"drivers/flock_lanes.ron"`); `None` uses the
    /// model's built-in defaults.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub params: Option<String>,
    /// Parameter overrides by name, in the units the name states (e.g. `"target_speed_kmh": 60`).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub set: BTreeMap<String, f64>,
}

/// A uniform range `[min, max]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Range {
    /// Lower bound.
    pub min: f64,
    /// Upper bound (at least `min`).
    pub max: f64,
}

/// One driver profile's share of a spawner's vehicles.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProfileShare {
    /// Driver profile name.
    pub profile: String,
    /// Relative weight (shares need not sum to 1).
    pub weight: f64,
}

/// Adds a vehicle every T seconds, T uniform in `interval_s`, at a point of a lane.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpawnerSpec {
    /// Unique name (shown in the HUD and in the summary).
    pub name: String,
    /// Road to spawn on.
    pub road: String,
    /// Lane to spawn in (0 is the rightmost).
    #[serde(default)]
    pub lane: u32,
    /// Arc position of the spawn point, in metres.
    #[serde(default)]
    pub s_m: f64,
    /// Seconds between spawns, drawn uniformly from this range for each vehicle.
    pub interval_s: Range,
    /// Which driver profiles to spawn, by weight.
    pub profiles: Vec<ProfileShare>,
    /// Initial speed in km/h; `None` means the road's speed limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_kmh: Option<f64>,
    /// Whether the spawner starts active.
    #[serde(default = "yes", skip_serializing_if = "is_true")]
    pub active: bool,
    /// Stop after this many vehicles; `None` for no limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_vehicles: Option<u32>,
    /// Where its vehicles go: each vehicle takes one of these routes, chosen by weight. Empty
    /// (and no `destination`): vehicles follow their lane's links.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub routes: Vec<RouteSpec>,
    /// Or: the road its vehicles are bound for, reached by the quickest path at free flow.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub destination: Option<String>,
    /// Demand over time: from each step's time on, the interval is that step's (before the
    /// first step, `interval_s`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub schedule: Vec<DemandStep>,
    /// How intervals are drawn from their range.
    #[serde(default, skip_serializing_if = "Arrivals::is_uniform")]
    pub arrivals: Arrivals,
    /// A timetable: when given, the spawner makes exactly these vehicles, each when it is due
    /// (its interval, schedule and profile shares are not used). A vehicle whose spot is not
    /// clear waits, and those behind it wait too, as a demand file's vehicles wait to be
    /// inserted (counted in `insertion_backlog`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub departures: Vec<DepartureSpec>,
}

impl SpawnerSpec {
    /// A spawner of `profiles` on `lane` of `road`, `s_m` along it, every `interval_s`, with
    /// every other field as a level file that leaves it out has it: active, no limit, no routes
    /// or destination, no schedule or timetable, uniform intervals, the road's speed.
    pub fn new(
        name: &str,
        road: &str,
        lane: u32,
        s_m: f64,
        interval_s: Range,
        profiles: Vec<ProfileShare>,
    ) -> SpawnerSpec {
        SpawnerSpec {
            name: name.to_owned(),
            road: road.to_owned(),
            lane,
            s_m,
            interval_s,
            profiles,
            speed_kmh: None,
            active: true,
            max_vehicles: None,
            routes: Vec::new(),
            destination: None,
            schedule: Vec::new(),
            arrivals: Arrivals::default(),
            departures: Vec::new(),
        }
    }
}

/// One vehicle of a spawner's timetable.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DepartureSpec {
    /// When it is due, s from the start.
    pub time_s: f64,
    /// Its driver profile.
    pub profile: String,
    /// The name of the spawner's route it takes; `None`: one drawn by weight, as for the
    /// spawner's other vehicles.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub route: Option<String>,
    /// Its speed when created, km/h; `None`: the spawner's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_kmh: Option<f64>,
}

/// How a spawner draws the interval before its next vehicle from a range `(min, max)`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Arrivals {
    /// Uniformly in the range.
    #[default]
    Uniform,
    /// At random: `min` plus an exponential draw with mean `(max - min) / 2`, so the mean
    /// interval is the range's and the stream is a Poisson one with a minimum headway (free
    /// traffic; gap-acceptance capacity formulas assume it).
    Random,
}

impl Arrivals {
    fn is_uniform(&self) -> bool {
        *self == Arrivals::Uniform
    }
}

/// One route a spawner gives its vehicles: the roads in driving order, from the spawner's road.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RouteSpec {
    /// Name (the telemetry's `route` column).
    pub name: String,
    /// Road names in driving order; the first is the spawner's road (it may be left out).
    pub roads: Vec<String>,
    /// Relative probability.
    #[serde(default = "one_f64")]
    pub weight: f64,
}

/// A change of a spawner's demand at a time of the run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DemandStep {
    /// When it takes effect, s from the start.
    pub from_s: f64,
    /// Seconds between spawns from then on, drawn uniformly from this range.
    pub interval_s: Range,
}

/// Where a destroyer removes vehicles.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum DestroyerPlaceSpec {
    /// Vehicles that pass this arc position of a road (all lanes).
    OnRoad {
        /// Road name.
        road: String,
        /// Arc position in metres.
        s_m: f64,
    },
    /// Vehicles whose centre enters this axis-aligned box (world metres).
    Volume {
        /// Lower corner.
        min: DVec3,
        /// Upper corner.
        max: DVec3,
    },
}

/// Removes vehicles that reach it and records their travel times.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DestroyerSpec {
    /// Unique name (keys the flow figures in the summary).
    pub name: String,
    /// Where it acts.
    pub place: DestroyerPlaceSpec,
    /// Removes only vehicles whose route ends on its road (where a demand's routes end inside
    /// the network, traffic going on past the same point is left alone).
    #[serde(default, skip_serializing_if = "is_false")]
    pub arrivals_only: bool,
}

/// What a trigger does to a vehicle entering it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum TriggerEffectSpec {
    /// Sets the vehicle's speed limit.
    SpeedLimit {
        /// New limit in km/h.
        kmh: f64,
    },
    /// Scales tyre friction while the vehicle is inside (e.g. 0.6 for wet asphalt).
    Friction {
        /// Multiplier on the tyres' friction, in (0, 2].
        scale: f64,
    },
}

/// A stretch of road that changes vehicles entering it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TriggerSpec {
    /// Unique name.
    pub name: String,
    /// Road it lies on.
    pub road: String,
    /// Arc position where it starts, in metres.
    pub from_m: f64,
    /// Arc position where it ends, in metres (on a loop it may be below `from_m`: it wraps).
    pub to_m: f64,
    /// Lanes it covers; `None` for all.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lanes: Option<Vec<u32>>,
    /// What it does.
    pub effect: TriggerEffectSpec,
}

/// An induction loop: a point across some lanes of a road that measures, per period, the
/// vehicles whose front passes it, the share of time a vehicle covers it and their speeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DetectorSpec {
    /// Unique name (the detectors CSV's `detector` column).
    pub name: String,
    /// Road it lies across.
    pub road: String,
    /// Arc position, metres.
    pub s_m: f64,
    /// Lanes it covers (one loop each); `None` for all.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lanes: Option<Vec<u32>>,
    /// Length of a measuring period, s (a row per lane and period).
    #[serde(
        default = "default_detector_period_s",
        skip_serializing_if = "is_default_detector_period"
    )]
    pub period_s: f64,
}

/// A detector's period unless the level gives one, s: traffic counts are usually kept by the
/// minute.
pub const DEFAULT_DETECTOR_PERIOD_S: f64 = 60.0;

fn default_detector_period_s() -> f64 {
    DEFAULT_DETECTOR_PERIOD_S
}

fn is_default_detector_period(p: &f64) -> bool {
    *p == DEFAULT_DETECTOR_PERIOD_S
}

/// `count` vehicles present at the start, evenly spaced along one lane.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialVehiclesSpec {
    /// Road to place them on.
    pub road: String,
    /// Lane to place them in.
    #[serde(default)]
    pub lane: u32,
    /// How many.
    pub count: u32,
    /// Driver profile name.
    pub profile: String,
    /// First vehicle's arc position, in metres.
    #[serde(default)]
    pub from_m: f64,
    /// End of the stretch they fill, in metres; `None` for the road's end (on a loop, the whole
    /// loop, spaced length/count apart).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub to_m: Option<f64>,
    /// Initial speed in km/h; `None` for standing still.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_kmh: Option<f64>,
    /// Each vehicle is moved along the lane by a uniform amount in ±this many metres, drawn from
    /// the group's own random stream (breaks the symmetry of a perfectly even ring).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub jitter_m: f64,
}

/// Telemetry settings: how often vehicles are sampled, and the warm-up left out of statistics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TelemetrySpec {
    /// Sampling period of the speed CSV in simulated seconds (a multiple of 1/120 s).
    #[serde(default = "half_second")]
    pub period_s: f64,
    /// Samples before this simulated time are not used for the summary statistics (warm-up).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub stats_from_s: f64,
}

impl Default for TelemetrySpec {
    fn default() -> TelemetrySpec {
        TelemetrySpec {
            period_s: 0.5,
            stats_from_s: 0.0,
        }
    }
}

impl TelemetrySpec {
    fn is_default(&self) -> bool {
        *self == TelemetrySpec::default()
    }
}

/// The thresholds of the surrogate safety measures: a follower–leader pair is in conflict while
/// its time to collision is below `ttc_s` or its deceleration rate to avoid the crash above
/// `drac_mps2`; two vehicles through a junction's crossing less than `pet_s` apart are a
/// conflict.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SsmSpec {
    /// Time-to-collision threshold, s.
    pub ttc_s: f64,
    /// Post-encroachment-time threshold, s.
    pub pet_s: f64,
    /// Deceleration-rate-to-avoid-a-crash threshold, m/s².
    pub drac_mps2: f64,
}

impl Default for SsmSpec {
    /// TTC 1.5 s, PET 1.0 s, DRAC 3.0 m/s².
    fn default() -> SsmSpec {
        SsmSpec {
            ttc_s: 1.5,
            pet_s: 1.0,
            drac_mps2: 3.0,
        }
    }
}

impl SsmSpec {
    fn is_default(&self) -> bool {
        *self == SsmSpec::default()
    }
}

fn one_f64() -> f64 {
    1.0
}

fn yes() -> bool {
    true
}
fn is_false(b: &bool) -> bool {
    !*b
}

fn is_true(b: &bool) -> bool {
    *b
}
fn is_zero(x: &f64) -> bool {
    *x == 0.0
}
fn half_second() -> f64 {
    0.5
}

//! The runner: level → world → fixed steps → telemetry, summary and expectations.

use crate::telemetry::{TelemetryRow, TelemetryWriter};
use flockway_analysis::{PlotFormat, PlotInfo, Trace, Wave, WaveSettings, measure_wave};
use flockway_core::{IdKind, RngStreams, RunStats, Sim, StableId, TICKS_PER_SECOND};
use flockway_drivers::{BuiltinModel, DriverSpec, DriversPlugin};
use flockway_level::DriverModel;
use flockway_level::{Expectation, Level, LevelError};
use flockway_road::{Road, RoadId, RoadNetwork, RoadNetworkError, RoadPlugin};
use flockway_traffic::{
    Destroyer, DestroyerPlace, SpawnChoice, Spawner, TelemetrySamples, TelemetrySettings,
    TrafficPlugin, TrafficStats, Trigger, TriggerEffect, spawn_driven,
};
use flockway_vehicle::VehicleSpawn;
use flockway_vehicle::{VehicleParams, VehicleParamsError, VehiclePlugin, VehicleType};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Why a run could not be set up or completed.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The level file is unreadable or invalid.
    #[error(transparent)]
    Level(#[from] LevelError),
    /// The level's roads do not form a network.
    #[error("{level}: {message}")]
    Roads {
        /// Level name.
        level: String,
        /// What is wrong.
        message: String,
    },
    /// The systems of the step conflict (a bug in a plugin, not in the level).
    #[error("the simulation step cannot be built: {0}")]
    Schedule(String),
    /// A vehicle definition the level names is missing or invalid.
    #[error("{level}: vehicle type `{name}`: {source}")]
    Vehicle {
        /// Level name.
        level: String,
        /// The vehicle type's name in the level.
        name: String,
        /// What is wrong with its file.
        source: VehicleParamsError,
    },
    /// A driver profile the level defines has a bad parameter file or override.
    #[error("{level}: driver profile `{name}`: {message}")]
    Driver {
        /// Level name.
        level: String,
        /// The profile's name in the level.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// An output file could not be written.
    #[error("{}: {source}", path.display())]
    Output {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A command-line value is out of range.
    #[error("{0}")]
    Argument(String),
    /// The run's plots could not be made.
    #[error(transparent)]
    Analysis(#[from] flockway_analysis::AnalysisError),
}

/// Longest run the command line accepts, in simulated seconds (one week).
pub const MAX_RUN_SECONDS: f64 = flockway_level::MAX_DURATION_S;

/// How to run a level.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Simulated seconds to run instead of the level's `duration_s`.
    pub seconds: Option<f64>,
    /// Seed to use instead of the level's.
    pub seed: Option<u64>,
    /// Where to stream the telemetry CSV.
    pub csv: Option<PathBuf>,
    /// A directory for one telemetry CSV per vehicle.
    pub per_vehicle: Option<PathBuf>,
    /// The `assets/` directory that level asset paths are relative to; `None` finds it with
    /// [`find_assets_dir`].
    pub assets: Option<PathBuf>,
    /// A directory to write the run's plots into at the end, and their format.
    pub plots: Option<(PathBuf, PlotFormat)>,
}

/// Environment variable that overrides where `assets/` is.
pub const ASSETS_ENV: &str = "FLOCKWAY_ASSETS";

/// Finds the `assets/` directory for a level: `$FLOCKWAY_ASSETS` if set, else the nearest
/// `assets/` in the level's directory or one of its parents, else `./assets`, else the one in
/// the source tree this program was built from.
pub fn find_assets_dir(level_path: Option<&Path>) -> PathBuf {
    if let Some(dir) = std::env::var_os(ASSETS_ENV) {
        return PathBuf::from(dir);
    }
    if let Some(path) = level_path {
        let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_owned());
        for dir in abs.ancestors().skip(1) {
            let candidate = dir.join("assets");
            if candidate.is_dir() {
                return candidate;
            }
        }
    }
    let cwd = PathBuf::from("assets");
    if cwd.is_dir() {
        return cwd;
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets")
}

/// Loads and validates every vehicle type a level names, by name.
pub fn load_vehicle_types(
    level: &Level,
    level_name: &str,
    assets: &Path,
) -> Result<BTreeMap<String, Arc<VehicleType>>, RunError> {
    level
        .vehicle_types
        .iter()
        .map(|v| {
            let params =
                VehicleParams::load(&assets.join(&v.path)).map_err(|source| RunError::Vehicle {
                    level: level_name.to_owned(),
                    name: v.name.clone(),
                    source,
                })?;
            Ok((v.name.clone(), Arc::new(VehicleType::new(params))))
        })
        .collect()
}

/// The outcome of one expectation.
#[derive(Debug, Clone, PartialEq)]
pub struct ExpectationResult {
    /// The expectation as written in the level.
    pub name: String,
    /// Whether it held.
    pub passed: bool,
    /// The measured value; `None` if the run did not measure that metric.
    pub value: Option<f64>,
}

/// The keys every summary JSON has: a documented contract, only ever extended.
pub const SUMMARY_KEYS: [&str; 22] = [
    "level",
    "seed",
    "ticks",
    "sim_seconds",
    "wall_seconds",
    "realtime_factor",
    "vehicle_steps",
    "passed",
    "expectations",
    "vehicles_spawned",
    "vehicles_destroyed",
    "vehicles_alive_mean",
    "collisions_guardrail",
    "collisions_vehicle",
    "mean_speed_kmh",
    "speed_std_kmh",
    "flow_veh_per_h",
    "mean_travel_time_s",
    "wave_detected",
    "wave_speed_kmh",
    "wave_period_s",
    "stats_from_s",
];

/// What a run measured. Its JSON form is a documented contract (see the README).
#[derive(Debug, Clone, PartialEq)]
pub struct RunReport {
    /// Level name.
    pub level: String,
    /// Seed used.
    pub seed: u64,
    /// Fixed steps simulated.
    pub ticks: u64,
    /// Simulated seconds (ticks / 120).
    pub sim_seconds: f64,
    /// Wall-clock seconds spent stepping.
    pub wall_seconds: f64,
    /// Simulated seconds per wall second.
    pub realtime_factor: f64,
    /// Sum over steps of vehicles alive.
    pub vehicle_steps: u64,
    /// Every measured metric by key (`metric` or `metric.name`).
    pub metrics: BTreeMap<String, f64>,
    /// Each expectation's outcome, in level order.
    pub expectations: Vec<ExpectationResult>,
    /// Whether every expectation held.
    pub passed: bool,
    /// Start of the measured part of the run (after the warm-up), simulated seconds.
    pub stats_from_s: f64,
}

impl RunReport {
    /// The summary JSON: the contract keys, plus `metrics` with every measured value.
    pub fn to_json(&self) -> Value {
        let metric = |k: &str| self.metrics.get(k).copied();
        let flows: BTreeMap<&str, f64> = self
            .metrics
            .iter()
            .filter_map(|(k, v)| k.strip_prefix("flow_veh_per_h.").map(|d| (d, *v)))
            .collect();
        let mut out = json!({
            "level": self.level,
            "seed": self.seed,
            "ticks": self.ticks,
            "sim_seconds": self.sim_seconds,
            "wall_seconds": self.wall_seconds,
            "realtime_factor": self.realtime_factor,
            "vehicle_steps": self.vehicle_steps,
            "passed": self.passed,
            "expectations": self.expectations.iter().map(|e| json!({
                "name": e.name,
                "passed": e.passed,
                "value": e.value,
            })).collect::<Vec<_>>(),
            "metrics": self.metrics,
            "stats_from_s": self.stats_from_s,
        });
        // The traffic keys (issue 6's contract), next to the foundation's.
        if let Some(obj) = out.as_object_mut() {
            obj.insert("vehicles_spawned".into(), json!(metric("vehicles_spawned")));
            obj.insert(
                "vehicles_destroyed".into(),
                json!(metric("vehicles_destroyed")),
            );
            obj.insert(
                "vehicles_alive_mean".into(),
                json!(metric("vehicles_alive_mean")),
            );
            obj.insert(
                "collisions_guardrail".into(),
                json!(metric("collisions_guardrail")),
            );
            obj.insert(
                "collisions_vehicle".into(),
                json!(metric("collisions_vehicle")),
            );
            obj.insert("mean_speed_kmh".into(), json!(metric("mean_speed_kmh")));
            obj.insert("speed_std_kmh".into(), json!(metric("speed_std_kmh")));
            obj.insert("flow_veh_per_h".into(), json!(flows));
            obj.insert(
                "mean_travel_time_s".into(),
                json!(metric("mean_travel_time_s")),
            );
            // Issue 8's wave keys: null when no road was shared by two vehicles, or no wave.
            obj.insert(
                "wave_detected".into(),
                json!(metric("wave_detected").map(|v| v != 0.0)),
            );
            obj.insert("wave_speed_kmh".into(), json!(metric("wave_speed_kmh")));
            obj.insert("wave_period_s".into(), json!(metric("wave_period_s")));
        }
        out
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
        for (k, v) in &self.metrics {
            if let Some(d) = k.strip_prefix("flow_veh_per_h.") {
                out.push_str(&format!("flow {d:<12}{} veh/h\n", fmt_value(*v)));
            }
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

/// Builds every driver profile a level defines, by name: the built-in model's parameters from
/// the profile's file under `assets/` (or the model's defaults) with its `set` overrides.
/// Profiles of plugin models (`Custom`) are left to their plugin and not listed.
pub fn load_driver_profiles(
    level: &Level,
    level_name: &str,
    assets: &Path,
) -> Result<BTreeMap<String, DriverSpec>, RunError> {
    let mut out = BTreeMap::new();
    for profile in &level.driver_profiles {
        let model = match &profile.model {
            DriverModel::Flock => BuiltinModel::Flock,
            DriverModel::FlockLanes => BuiltinModel::FlockLanes,
            DriverModel::Human => BuiltinModel::Human,
            DriverModel::Idm => BuiltinModel::Idm,
            DriverModel::WaveDamper => BuiltinModel::WaveDamper,
            DriverModel::Custom(_) => continue,
        };
        let fail = |message: String| RunError::Driver {
            level: level_name.to_owned(),
            name: profile.name.clone(),
            message,
        };
        let text = match &profile.params {
            Some(rel) => {
                let path = assets.join(rel);
                let text = std::fs::read_to_string(&path)
                    .map_err(|e| fail(format!("{}: {e}", path.display())))?;
                Some((path.display().to_string(), text))
            }
            None => None,
        };
        let spec = DriverSpec::build(
            model,
            text.as_ref().map(|(p, t)| (p.as_str(), t.as_str())),
            &profile.set,
        )
        .map_err(|e| fail(e.to_string()))?;
        out.insert(profile.name.clone(), spec);
    }
    Ok(out)
}

/// The level's driver profiles, built, by name.
#[derive(bevy_ecs::resource::Resource, Debug, Clone, Default)]
pub struct DriverProfiles(pub BTreeMap<String, DriverSpec>);

/// The level's vehicle types, loaded from `assets/`, by name.
#[derive(bevy_ecs::resource::Resource, Debug, Clone, Default)]
pub struct VehicleTypes(pub BTreeMap<String, Arc<VehicleType>>);

/// Builds the world of a level: every plugin, and the level's entities, ready to step.
pub fn build_sim(level: &Level, seed: u64) -> Result<Sim, RunError> {
    let mut sim = Sim::new(seed);
    sim.add_plugin(RoadPlugin);
    sim.add_plugin(VehiclePlugin);
    sim.add_plugin(DriversPlugin);
    sim.add_plugin(TrafficPlugin);
    for (i, spec) in level.roads.iter().enumerate() {
        sim.world_mut().spawn((
            RoadId(i as u32),
            StableId::new(IdKind::Road, i as u32),
            Road(spec.clone()),
        ));
    }
    sim.prepare().map_err(RunError::Schedule)?;
    Ok(sim)
}

/// Puts a level's traffic into a world built by [`build_sim`]: telemetry settings, spawners,
/// destroyers, triggers and the initial vehicles (spawned now, on the level's roads).
pub fn populate(
    sim: &mut Sim,
    level: &Level,
    level_name: &str,
    types: &BTreeMap<String, Arc<VehicleType>>,
    profiles: &BTreeMap<String, DriverSpec>,
) -> Result<(), RunError> {
    let fail = |message: String| RunError::Roads {
        level: level_name.to_owned(),
        message,
    };
    let network = RoadNetwork::build(&level.roads).map_err(|e| fail(e.to_string()))?;
    let road = |name: &str| {
        network
            .id(name)
            .ok_or_else(|| fail(format!("unknown road `{name}`")))
    };
    let ticks_of = |s: f64| (s * f64::from(TICKS_PER_SECOND)).round().max(0.0) as u64;
    let choice = |profile: &str, weight: f64| -> Result<SpawnChoice, RunError> {
        let driver = profiles.get(profile).cloned().ok_or_else(|| {
            fail(format!(
                "driver profile `{profile}` has a model no plugin of this program provides"
            ))
        })?;
        let p = level
            .driver_profiles
            .iter()
            .find(|p| p.name == profile)
            .ok_or_else(|| fail(format!("unknown driver profile `{profile}`")))?;
        let vehicle = types
            .get(&p.vehicle)
            .cloned()
            .ok_or_else(|| fail(format!("unknown vehicle type `{}`", p.vehicle)))?;
        Ok(SpawnChoice {
            profile: Arc::from(profile),
            weight,
            vehicle,
            driver,
        })
    };
    let world = sim.world_mut();
    world.insert_resource(TelemetrySettings {
        period_ticks: ticks_of(level.telemetry.period_s).max(1),
        stats_from_tick: ticks_of(level.telemetry.stats_from_s),
    });
    let streams = *world.resource::<RngStreams>();
    for (i, sp) in level.spawners.iter().enumerate() {
        let choices = sp
            .profiles
            .iter()
            .map(|c| choice(&c.profile, c.weight))
            .collect::<Result<Vec<_>, _>>()?;
        let spawner = Spawner::new(
            sp.name.clone(),
            road(&sp.road)?,
            sp.lane,
            sp.s_m,
            (sp.interval_s.min, sp.interval_s.max),
            choices,
            sp.speed_kmh.map(|k| (k / 3.6) as f32),
            sp.active,
            sp.max_vehicles,
            streams.stream(StableId::new(IdKind::Spawner, i as u32)),
        );
        world.spawn((spawner, StableId::new(IdKind::Spawner, i as u32)));
    }
    for (i, d) in level.destroyers.iter().enumerate() {
        let place = match &d.place {
            flockway_level::DestroyerPlace::OnRoad { road: r, s_m } => DestroyerPlace::OnRoad {
                road: road(r)?,
                s_m: *s_m,
            },
            flockway_level::DestroyerPlace::Volume { min, max } => DestroyerPlace::Volume {
                min: min.as_vec3(),
                max: max.as_vec3(),
            },
        };
        world.spawn((
            Destroyer {
                name: d.name.clone(),
                place,
            },
            StableId::new(IdKind::Destroyer, i as u32),
        ));
    }
    for (i, t) in level.triggers.iter().enumerate() {
        let effect = match t.effect {
            flockway_level::TriggerEffect::SpeedLimit { kmh } => {
                TriggerEffect::SpeedLimit(kmh as f32)
            }
            flockway_level::TriggerEffect::Friction { scale } => {
                TriggerEffect::Friction(scale as f32)
            }
        };
        world.spawn((
            Trigger {
                name: t.name.clone(),
                road: road(&t.road)?,
                from_m: t.from_m,
                to_m: t.to_m,
                lanes: t.lanes.clone(),
                effect,
            },
            StableId::new(IdKind::Trigger, i as u32),
        ));
    }
    // Initial vehicles need the network now, before the first step builds it (to the same
    // result) from the road components.
    world.insert_resource(network.clone());
    for (gi, group) in level.vehicles.iter().enumerate() {
        let id = road(&group.road)?;
        let Some(g) = network.get(id) else { continue };
        let c = choice(&group.profile, 1.0)?;
        let mut rng = streams.stream(StableId::new(IdKind::InitialVehicles, gi as u32));
        let from = group.from_m;
        let span = match group.to_m {
            Some(to) => to - from,
            None if g.is_closed() => g.length_m(),
            None => g.length_m() - from,
        };
        let count = f64::from(group.count.max(1));
        let width = g.frame_at(from).width_m;
        let lateral = flockway_road::lane_offset(width, g.lanes(), group.lane);
        let speed = group.speed_kmh.unwrap_or(0.0) as f32 / 3.6;
        for k in 0..group.count {
            let jitter = if group.jitter_m > 0.0 {
                rng.uniform(-group.jitter_m, group.jitter_m)
            } else {
                0.0
            };
            let s = g.normalize_s(from + span * f64::from(k) / count + jitter);
            let spawn = VehicleSpawn::new(c.vehicle.clone(), id, s)
                .lateral(lateral)
                .speed(speed);
            spawn_driven(world, spawn, &c.driver, group.lane, c.profile.clone())
                .map_err(|e| fail(e.to_string()))?;
        }
    }
    Ok(())
}

/// A run in progress: step it in chunks (for progress reporting), then finish it for the report.
pub struct Runner {
    sim: Sim,
    level: Level,
    name: String,
    total_ticks: u64,
    csv: Option<TelemetryWriter>,
    per_vehicle: Option<PerVehicleFiles>,
    plots: Option<(PathBuf, PlotFormat)>,
    trace: Trace,
    stepping: Duration,
}

/// One CSV per vehicle in a directory (`vehicle_<id>.csv`, the same columns), each closed when
/// its vehicle is gone.
struct PerVehicleFiles {
    dir: PathBuf,
    open: BTreeMap<u32, TelemetryWriter>,
}

impl PerVehicleFiles {
    fn write_sample(&mut self, rows: &[TelemetryRow]) -> Result<(), RunError> {
        let present: std::collections::BTreeSet<u32> = rows.iter().map(|r| r.vehicle_id).collect();
        let gone: Vec<u32> = self
            .open
            .keys()
            .filter(|id| !present.contains(id))
            .copied()
            .collect();
        for id in gone {
            if let Some(w) = self.open.remove(&id) {
                let path = w.path().to_owned();
                w.finish()
                    .map_err(|source| RunError::Output { path, source })?;
            }
        }
        for r in rows {
            if !self.open.contains_key(&r.vehicle_id) {
                let path = self.dir.join(format!("vehicle_{:06}.csv", r.vehicle_id));
                let w = TelemetryWriter::create(&path)
                    .map_err(|source| RunError::Output { path, source })?;
                self.open.insert(r.vehicle_id, w);
            }
            if let Some(w) = self.open.get_mut(&r.vehicle_id) {
                w.write_sample(std::slice::from_ref(r))
                    .map_err(|source| RunError::Output {
                        path: w.path().to_owned(),
                        source,
                    })?;
            }
        }
        Ok(())
    }

    fn finish(self) -> Result<(), RunError> {
        for (_, w) in self.open {
            let path = w.path().to_owned();
            w.finish()
                .map_err(|source| RunError::Output { path, source })?;
        }
        Ok(())
    }
}

impl Runner {
    /// Sets up a run of `level` (named `name` in reports).
    pub fn new(level: Level, name: &str, options: &RunOptions) -> Result<Runner, RunError> {
        let seconds = options.seconds.unwrap_or(level.duration_s);
        if !(seconds.is_finite() && seconds > 0.0 && seconds <= MAX_RUN_SECONDS) {
            return Err(RunError::Argument(format!(
                "--seconds {seconds}: expected a number of seconds above 0 and at most {MAX_RUN_SECONDS}"
            )));
        }
        let total_ticks = (seconds * f64::from(TICKS_PER_SECOND)).round().max(1.0) as u64;
        let seed = options.seed.unwrap_or(level.seed);
        let assets = options
            .assets
            .clone()
            .unwrap_or_else(|| find_assets_dir(None));
        let mut sim = build_sim(&level, seed)?;
        let types = load_vehicle_types(&level, name, &assets)?;
        let profiles = load_driver_profiles(&level, name, &assets)?;
        populate(&mut sim, &level, name, &types, &profiles)?;
        sim.world_mut().insert_resource(VehicleTypes(types));
        sim.world_mut().insert_resource(DriverProfiles(profiles));
        let csv = match &options.csv {
            Some(path) => {
                Some(
                    TelemetryWriter::create(path).map_err(|source| RunError::Output {
                        path: path.clone(),
                        source,
                    })?,
                )
            }
            None => None,
        };
        let per_vehicle = match &options.per_vehicle {
            Some(dir) => {
                std::fs::create_dir_all(dir).map_err(|source| RunError::Output {
                    path: dir.clone(),
                    source,
                })?;
                Some(PerVehicleFiles {
                    dir: dir.clone(),
                    open: BTreeMap::new(),
                })
            }
            None => None,
        };
        Ok(Runner {
            sim,
            level,
            name: name.to_owned(),
            total_ticks,
            csv,
            per_vehicle,
            plots: options.plots.clone(),
            trace: Trace::new(),
            stepping: Duration::ZERO,
        })
    }

    /// Ticks the whole run takes.
    pub fn total_ticks(&self) -> u64 {
        self.total_ticks
    }

    /// Ticks done so far.
    pub fn ticks_done(&self) -> u64 {
        self.sim.tick().0
    }

    /// The world being run.
    pub fn sim(&self) -> &Sim {
        &self.sim
    }

    /// The world being run, for tools that query it (the renderer).
    pub fn sim_mut(&mut self) -> &mut Sim {
        &mut self.sim
    }

    /// The level being run.
    pub fn level(&self) -> &Level {
        &self.level
    }

    /// Runs up to `max_ticks` more steps (fewer at the end of the run); returns how many ran.
    pub fn step(&mut self, max_ticks: u64) -> Result<u64, RunError> {
        let n = max_ticks.min(self.total_ticks - self.ticks_done());
        for _ in 0..n {
            // Wall-clock time is measured for the report only; it never reaches the simulation.
            let started = Instant::now();
            self.sim.step();
            self.stepping += started.elapsed();
            if self.sim.tick().0 == 1 {
                self.check_roads()?;
            }
            self.write_samples()?;
        }
        Ok(n)
    }

    /// Streams the samples taken this tick to the CSV files (flushed per sample time, so a run
    /// stopped at any moment leaves everything sampled so far).
    fn write_samples(&mut self) -> Result<(), RunError> {
        let pending = std::mem::take(
            &mut self
                .sim
                .world_mut()
                .resource_mut::<TelemetrySamples>()
                .pending,
        );
        if pending.is_empty() {
            return Ok(());
        }
        let names: BTreeMap<RoadId, String> = self
            .sim
            .world()
            .resource::<RoadNetwork>()
            .iter()
            .map(|(id, g)| (id, g.name().to_owned()))
            .collect();
        for (tick, samples) in pending {
            let time_s = tick as f64 / f64::from(TICKS_PER_SECOND);
            let rows: Vec<TelemetryRow> = samples
                .iter()
                .map(|r| TelemetryRow {
                    time_s,
                    vehicle_id: r.vehicle_id,
                    driver: r.driver.to_string(),
                    road: names.get(&r.road).cloned().unwrap_or_default(),
                    lane: r.lane,
                    s_m: r.s_m,
                    pos_m: r.position.as_dvec3().to_array(),
                    speed_kmh: f64::from(r.speed_kmh),
                    accel_mps2: f64::from(r.accel_mps2),
                    throttle: f64::from(r.throttle),
                    steering: f64::from(r.steering),
                    gear: i32::from(r.gear),
                    rpm: f64::from(r.rpm),
                })
                .collect();
            // Kept as the CSV writes them (3 decimals), so analysing the run or its CSV agrees.
            let round = |v: f64| (v * 1000.0).round() / 1000.0;
            for r in &rows {
                self.trace.push(
                    round(r.time_s),
                    r.vehicle_id,
                    &r.driver,
                    &r.road,
                    r.lane,
                    round(r.s_m),
                    round(r.speed_kmh),
                );
            }
            if let Some(csv) = &mut self.csv {
                csv.write_sample(&rows).map_err(|source| RunError::Output {
                    path: csv.path().to_owned(),
                    source,
                })?;
            }
            if let Some(dir) = &mut self.per_vehicle {
                dir.write_sample(&rows)?;
            }
        }
        Ok(())
    }

    /// The stop-and-go wave over the measured part of the run (after the warm-up).
    fn wave(&self, road_lengths: &BTreeMap<String, f64>, from_tick: u64) -> Option<Wave> {
        let settings = WaveSettings {
            from_s: from_tick as f64 / f64::from(TICKS_PER_SECOND),
            ..WaveSettings::default()
        };
        measure_wave(&self.trace, road_lengths, &settings)
    }

    /// The telemetry sampled so far, as analysis reads it.
    pub fn trace(&self) -> &Trace {
        &self.trace
    }

    /// Road edits are validated at load time; a network that still fails to build is reported.
    fn check_roads(&self) -> Result<(), RunError> {
        match &self.sim.world().resource::<RoadNetworkError>().0 {
            Some(e) => Err(RunError::Roads {
                level: self.name.clone(),
                message: e.to_string(),
            }),
            None => Ok(()),
        }
    }

    /// Runs to the end, then measures and checks the expectations.
    pub fn finish(mut self) -> Result<RunReport, RunError> {
        while self.ticks_done() < self.total_ticks {
            self.step(u64::MAX)?;
        }
        if let Some(csv) = self.csv.take() {
            let path = csv.path().to_owned();
            csv.finish()
                .map_err(|source| RunError::Output { path, source })?;
        }
        if let Some(files) = self.per_vehicle.take() {
            files.finish()?;
        }
        let world = self.sim.world();
        let ticks = self.sim.tick().0;
        let stats = *world.resource::<RunStats>();
        let mut metrics = BTreeMap::new();
        metrics.insert("ticks".to_owned(), ticks as f64);
        metrics.insert("sim_seconds".to_owned(), self.sim.tick().seconds());
        metrics.insert("vehicle_steps".to_owned(), stats.vehicle_steps as f64);
        metrics.insert(
            "vehicles_alive_mean".to_owned(),
            stats.vehicle_steps as f64 / ticks.max(1) as f64,
        );
        for (_, road) in world.resource::<RoadNetwork>().iter() {
            metrics.insert(format!("road_length_m.{}", road.name()), road.length_m());
        }
        let traffic = world.resource::<TrafficStats>().clone();
        let settings = *world.resource::<TelemetrySettings>();
        metrics.insert("vehicles_spawned".to_owned(), traffic.spawned as f64);
        metrics.insert("vehicles_destroyed".to_owned(), traffic.destroyed as f64);
        metrics.insert(
            "collisions_guardrail".to_owned(),
            traffic.collisions_guardrail as f64,
        );
        metrics.insert(
            "collisions_vehicle".to_owned(),
            traffic.collisions_vehicle as f64,
        );
        metrics.insert(
            "collisions".to_owned(),
            (traffic.collisions_guardrail + traffic.collisions_vehicle) as f64,
        );
        if let Some(v) = traffic.mean_speed_kmh() {
            metrics.insert("mean_speed_kmh".to_owned(), v);
        }
        if let Some(v) = traffic.speed_std_kmh() {
            metrics.insert("speed_std_kmh".to_owned(), v);
        }
        for (profile, st) in &traffic.speed_by_profile {
            if let (Some(m), Some(sd)) = (st.mean(), st.std()) {
                metrics.insert(format!("mean_speed_kmh.{profile}"), m);
                metrics.insert(format!("speed_std_kmh.{profile}"), sd);
            }
        }
        if let Some(v) = traffic.final_speed.mean() {
            metrics.insert("final_speed_kmh".to_owned(), v);
        }
        for (profile, st) in &traffic.final_speed_by_profile {
            if let Some(m) = st.mean() {
                metrics.insert(format!("final_speed_kmh.{profile}"), m);
            }
        }
        if let Some(v) = traffic.final_at_limit.share() {
            metrics.insert("final_limit_share".to_owned(), v);
        }
        for (profile, st) in &traffic.final_at_limit_by_profile {
            if let Some(v) = st.share() {
                metrics.insert(format!("final_limit_share.{profile}"), v);
            }
        }
        if let Some(v) = traffic.mean_travel_time_s() {
            metrics.insert("mean_travel_time_s".to_owned(), v);
        }
        // Flow through each destroyer over the measured part of the run.
        let measured_s =
            (ticks.saturating_sub(settings.stats_from_tick)) as f64 / f64::from(TICKS_PER_SECOND);
        for d in &self.level.destroyers {
            let n = traffic.destroyed_by.get(&d.name).copied().unwrap_or(0);
            let flow = if measured_s > 0.0 {
                n as f64 * 3600.0 / measured_s
            } else {
                0.0
            };
            metrics.insert(format!("flow_veh_per_h.{}", d.name), flow);
        }
        let road_lengths: BTreeMap<String, f64> = world
            .resource::<RoadNetwork>()
            .iter()
            .map(|(_, r)| (r.name().to_owned(), r.length_m()))
            .collect();
        let wave = self.wave(&road_lengths, settings.stats_from_tick);
        if let Some(w) = &wave {
            metrics.insert("wave_detected".to_owned(), f64::from(u8::from(w.detected)));
            if let Some(c) = w.speed_kmh() {
                metrics.insert("wave_speed_kmh".to_owned(), c);
            }
            if let Some(p) = w.period_s() {
                metrics.insert("wave_period_s".to_owned(), p);
            }
        }
        if let Some((dir, format)) = &self.plots {
            let info = PlotInfo {
                level: self.name.clone(),
                seed: Some(self.sim.seed()),
                road_lengths,
                destroyers: Some(!self.level.destroyers.is_empty()),
            };
            flockway_analysis::write_plots(&self.trace, &info, dir, *format)?;
        }
        let expectations: Vec<ExpectationResult> = self
            .level
            .expect
            .iter()
            .map(|e| evaluate(e, &metrics))
            .collect();
        let wall_seconds = self.stepping.as_secs_f64();
        let sim_seconds = self.sim.tick().seconds();
        Ok(RunReport {
            level: self.name,
            seed: self.sim.seed(),
            ticks,
            sim_seconds,
            wall_seconds,
            realtime_factor: if wall_seconds > 0.0 {
                sim_seconds / wall_seconds
            } else {
                f64::INFINITY
            },
            vehicle_steps: stats.vehicle_steps,
            passed: expectations.iter().all(|e| e.passed),
            stats_from_s: settings.stats_from_tick as f64 / f64::from(TICKS_PER_SECOND),
            metrics,
            expectations,
        })
    }
}

fn evaluate(e: &Expectation, metrics: &BTreeMap<String, f64>) -> ExpectationResult {
    let value = metrics.get(&e.key()).copied();
    ExpectationResult {
        name: e.to_string(),
        passed: value.is_some_and(|v| e.holds(v)),
        value,
    }
}

/// Reads a summary JSON written by `flockway run --summary`.
pub fn read_summary(path: &Path) -> Result<Value, flockway_analysis::AnalysisError> {
    let bad = |message: String| flockway_analysis::AnalysisError::Summary {
        path: path.to_owned(),
        message,
    };
    let text =
        std::fs::read_to_string(path).map_err(|source| flockway_analysis::AnalysisError::Io {
            path: path.to_owned(),
            source,
        })?;
    let value: Value = serde_json::from_str(&text)
        .map_err(|e| bad(format!("{}:{}: not JSON: {e}", e.line(), e.column())))?;
    for key in ["level", "seed", "metrics"] {
        if value.get(key).is_none() {
            return Err(bad(format!(
                "missing key `{key}`: expected the JSON of `flockway run --summary`"
            )));
        }
    }
    Ok(value)
}

/// Plot titles and road lengths for a run's CSV: from its summary if given, else the file name.
pub fn plot_info(csv: &Path, summary: Option<&Value>) -> PlotInfo {
    let stem = csv
        .file_stem()
        .map_or_else(|| "run".to_owned(), |s| s.to_string_lossy().into_owned());
    let Some(summary) = summary else {
        return PlotInfo {
            level: stem,
            ..PlotInfo::default()
        };
    };
    let metrics = summary.get("metrics").and_then(Value::as_object);
    PlotInfo {
        level: summary
            .get("level")
            .and_then(Value::as_str)
            .map_or(stem, str::to_owned),
        seed: summary.get("seed").and_then(Value::as_u64),
        road_lengths: metrics
            .into_iter()
            .flatten()
            .filter_map(|(k, v)| Some((k.strip_prefix("road_length_m.")?.to_owned(), v.as_f64()?)))
            .collect(),
        destroyers: summary
            .get("flow_veh_per_h")
            .and_then(Value::as_object)
            .map(|flows| !flows.is_empty()),
    }
}

/// The stop-and-go wave of a run read back from its CSV: measured after the summary's warm-up
/// (`stats_from_s`), or over the second half of the run without a summary.
pub fn wave_of(trace: &Trace, info: &PlotInfo, summary: Option<&Value>) -> Option<Wave> {
    let from_s = summary
        .and_then(|s| s.get("stats_from_s"))
        .and_then(Value::as_f64)
        .unwrap_or(0.5 * trace.end_s());
    let settings = WaveSettings {
        from_s,
        ..WaveSettings::default()
    };
    measure_wave(trace, &info.road_lengths, &settings)
}

/// The name a level is reported under: its `name`, or the file stem.
pub fn level_name(level: &Level, path: &Path) -> String {
    if level.name.trim().is_empty() {
        path.file_stem()
            .map_or_else(|| "level".to_owned(), |s| s.to_string_lossy().into_owned())
    } else {
        level.name.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use flockway_road::RoadSpec;
    use glam::DVec3;

    #[test]
    fn a_road_level_runs_and_measures_its_roads() {
        let mut level = Level::new(1, 2.0);
        level
            .roads
            .push(RoadSpec::ring("ring", 1, 30.0, DVec3::ZERO, 36.606, 12));
        level
            .expect
            .push(Expectation::parse("road_length_m.ring in 229.5..230.5").expect("parses"));
        level
            .expect
            .push(Expectation::parse("mean_speed_kmh > 0").expect("parses"));
        let report = Runner::new(level, "t", &RunOptions::default())
            .expect("runner")
            .finish()
            .expect("runs");
        assert_eq!(report.ticks, 240);
        assert_eq!(report.sim_seconds, 2.0);
        assert!(report.expectations[0].passed);
        // A metric this run cannot measure fails rather than passing silently.
        assert_eq!(
            report.expectations[1],
            ExpectationResult {
                name: "mean_speed_kmh > 0".into(),
                passed: false,
                value: None
            }
        );
        assert!(!report.passed);
        let json = report.to_json();
        for key in SUMMARY_KEYS {
            assert!(json.get(key).is_some(), "missing {key}");
        }
    }

    #[test]
    fn vehicle_types_load_from_assets_and_bad_ones_are_named() {
        let dir = tempfile::tempdir().expect("temp dir");
        std::fs::create_dir_all(dir.path().join("vehicles")).expect("mkdir");
        std::fs::write(
            dir.path().join("vehicles/light.ron"),
            "(name: \"light\", chassis: (mass_kg: 1000.0))",
        )
        .expect("write");
        std::fs::write(
            dir.path().join("vehicles/bad.ron"),
            "(\n  chassis: (mass_kg: true),\n)",
        )
        .expect("write");
        let mut level = Level::new(1, 10.0);
        level.vehicle_types = vec![flockway_level::VehicleType {
            name: "light".into(),
            path: "vehicles/light.ron".into(),
        }];
        let types = load_vehicle_types(&level, "t", dir.path()).expect("loads");
        assert_eq!(types["light"].params.chassis.mass_kg, 1000.0);
        let options = RunOptions {
            assets: Some(dir.path().to_owned()),
            ..RunOptions::default()
        };
        let runner = Runner::new(level.clone(), "t", &options).expect("runner");
        assert!(
            runner
                .sim()
                .world()
                .resource::<VehicleTypes>()
                .0
                .contains_key("light")
        );

        level.vehicle_types[0].path = "vehicles/bad.ron".into();
        let err = load_vehicle_types(&level, "t", dir.path()).expect_err("bad file");
        let text = err.to_string();
        assert!(
            text.contains("vehicle type `light`") && text.contains("bad.ron:2:"),
            "{text}"
        );
        level.vehicle_types[0].path = "vehicles/missing.ron".into();
        let err = load_vehicle_types(&level, "t", dir.path()).expect_err("missing file");
        assert!(err.to_string().contains("missing.ron"), "{err}");
    }

    #[test]
    fn driver_profiles_build_from_assets_with_overrides_and_name_bad_ones() {
        let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets");
        let mut level = Level::new(1, 10.0);
        level.vehicle_types = vec![flockway_level::VehicleType {
            name: "sedan".into(),
            path: "vehicles/sedan.ron".into(),
        }];
        let mut set = BTreeMap::new();
        set.insert("target_speed_kmh".to_owned(), 70.0);
        level.driver_profiles = vec![flockway_level::DriverProfile {
            name: "auto".into(),
            model: DriverModel::FlockLanes,
            vehicle: "sedan".into(),
            params: Some("drivers/flock_lanes.ron".into()),
            set,
        }];
        let profiles = load_driver_profiles(&level, "t", &assets).expect("valid");
        let DriverSpec::FlockLanes(p) = &profiles["auto"] else {
            panic!("wrong model")
        };
        assert_eq!(p.target_speed_kmh, Some(70.0));
        level.driver_profiles[0]
            .set
            .insert("speed_wieght".into(), 1.0);
        let err = load_driver_profiles(&level, "t", &assets).expect_err("typo");
        assert!(
            err.to_string()
                .contains("driver profile `auto`: `speed_wieght`"),
            "{err}"
        );
        level.driver_profiles[0].params = Some("drivers/none.ron".into());
        let err = load_driver_profiles(&level, "t", &assets).expect_err("missing file");
        assert!(err.to_string().contains("none.ron"), "{err}");
    }

    #[test]
    fn the_shipped_assets_are_found_from_a_level_path() {
        let level = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../levels/dense_road.ron");
        let assets = find_assets_dir(Some(&level));
        assert!(
            assets.join("vehicles/sedan.ron").is_file(),
            "{}",
            assets.display()
        );
    }

    #[test]
    fn options_override_seed_and_duration() {
        let level = Level::new(1, 10.0);
        let options = RunOptions {
            seconds: Some(0.5),
            seed: Some(99),
            ..RunOptions::default()
        };
        let report = Runner::new(level.clone(), "t", &options)
            .expect("runner")
            .finish()
            .expect("runs");
        assert_eq!((report.ticks, report.seed), (60, 99));
        let bad = RunOptions {
            seconds: Some(f64::NAN),
            ..Default::default()
        };
        assert!(matches!(
            Runner::new(level, "t", &bad),
            Err(RunError::Argument(_))
        ));
    }
}

//! A run in progress: a level's world stepped at the fixed step, its telemetry streamed to CSV,
//! and at the end its summary measured and its expectations checked.

use crate::assets::{
    DriverProfiles, VehicleTypes, builtin_model, find_assets_dir, load_vehicle_types,
};
use crate::summary::measure;
use crate::world::{build_sim, populate};
use flockway_analysis::compare::{EdgeCounts, ScenarioRun, Trip};
use flockway_analysis::{NamedSample, PlotFormat, Summary, TelemetryRow, TelemetryWriter, Trace};
use flockway_core::{Sim, TICKS_PER_SECOND};
use flockway_drivers::BuiltinModel;
use flockway_level::{Level, LevelError};
use flockway_road::{RoadId, RoadNetwork, RoadNetworkError};
use flockway_traffic::{Conflicts, SsmThresholds, TelemetrySamples, TrafficStats, TripLog};
use flockway_vehicle::VehicleParamsError;
use std::collections::BTreeMap;
use std::path::PathBuf;
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
    /// Where to stream the telemetry CSV (and, for a level with signals, `STEM.signals.csv`
    /// beside it).
    pub csv: Option<PathBuf>,
    /// A directory for one telemetry CSV per vehicle.
    pub per_vehicle: Option<PathBuf>,
    /// Where to stream the conflicts CSV: a row per conflict the surrogate safety measures find
    /// ([`CONFLICT_COLUMNS`](crate::CONFLICT_COLUMNS)).
    pub conflicts: Option<PathBuf>,
    /// The `assets/` directory that level asset paths are relative to; `None` finds it with
    /// [`find_assets_dir`].
    pub assets: Option<PathBuf>,
    /// A directory to write the run's plots into at the end, and their format.
    pub plots: Option<(PathBuf, PlotFormat)>,
    /// Drive the level's custom-model profiles from outside the step
    /// ([`flockway_drivers::External`]); without it a level that uses one is refused.
    pub external: bool,
    /// Driver profiles to drive with a built-in model instead of the level's (its parameter
    /// file, the default one, and no `set` overrides): how a challenge's custom profile is run
    /// with a built-in driver, whose score is the bar to beat.
    pub drivers: BTreeMap<String, BuiltinModel>,
    /// Keep every vehicle's trip and every road's counts ([`Runner::scenario_run`]): what a
    /// comparison with SUMO reads.
    pub trips: bool,
    /// Every driver profile's action step, s, instead of its own (`action_step_s`; 0 decides
    /// every tick): SUMO's `--default.action-step-length`.
    pub action_step_s: Option<f32>,
}

/// Gives each profile named in `drivers` — by its name, or by its custom model's name (every
/// profile of `Custom(NAME)`) — the built-in model, with that model's default parameter file and
/// no overrides; a name that matches no profile is an error that lists the level's.
pub fn assign_models(
    level: &mut Level,
    drivers: &BTreeMap<String, BuiltinModel>,
) -> Result<(), RunError> {
    for (name, model) in drivers {
        let matches = |p: &flockway_level::DriverProfileSpec| {
            &p.name == name
                || matches!(&p.model, flockway_level::DriverModel::Custom(m) if m == name)
        };
        if !level.driver_profiles.iter().any(matches) {
            let known: Vec<&str> = level
                .driver_profiles
                .iter()
                .map(|p| p.name.as_str())
                .collect();
            return Err(RunError::Argument(format!(
                "driver `{name}={}`: the level has no driver profile or custom model `{name}`; \
                 its profiles are {}",
                model.name(),
                known.join(", ")
            )));
        }
        for p in level.driver_profiles.iter_mut().filter(|p| matches(p)) {
            p.model = crate::assets::level_model(*model);
            p.params = Some(model.default_params_path().to_owned());
            p.set.clear();
        }
    }
    Ok(())
}

/// Sets every driver profile's action step to `step_s` seconds (an override in its `set`, by
/// the name its model gives the parameter); a step that is not a whole number of ticks up to
/// [`MAX_ACTION_STEP_S`](flockway_drivers::MAX_ACTION_STEP_S) is an error.
pub fn assign_action_step(level: &mut Level, step_s: f32) -> Result<(), RunError> {
    flockway_drivers::ActionStep::ticks_of(step_s)
        .map_err(|message| RunError::Argument(format!("--action-step {step_s}: {message}")))?;
    for p in &mut level.driver_profiles {
        // A custom model's parameters are the lane-keeping car's.
        let model = builtin_model(&p.model).unwrap_or(BuiltinModel::FlockLanes);
        p.set
            .insert(model.action_step_parameter().to_owned(), f64::from(step_s));
    }
    Ok(())
}

/// Parses `PROFILE=MODEL` (a built-in model's name, as levels write it).
pub fn parse_driver(text: &str) -> Result<(String, BuiltinModel), String> {
    let models: Vec<&str> = BuiltinModel::ALL.iter().map(|m| m.name()).collect();
    let (profile, model) = text
        .split_once('=')
        .filter(|(p, _)| !p.trim().is_empty())
        .ok_or_else(|| {
            format!("expected PROFILE=MODEL (e.g. controller=WaveDamper), found `{text}`")
        })?;
    let model = BuiltinModel::from_name(model.trim()).ok_or_else(|| {
        format!(
            "`{}` is not a built-in driver model; the models are {}",
            model.trim(),
            models.join(", ")
        )
    })?;
    Ok((profile.trim().to_owned(), model))
}

/// A run in progress: step it in chunks (for progress reporting), then finish it for the report.
pub struct Runner {
    sim: Sim,
    level: Level,
    name: String,
    total_ticks: u64,
    csv: Option<TelemetryWriter>,
    /// Beside the CSV, when the level has signals: every change of a signal's states.
    signals: Option<crate::signals::SignalsWriter>,
    /// Beside the CSV, when the level has detectors: a row per loop and period.
    detectors: Option<crate::detectors::DetectorsWriter>,
    /// The conflicts CSV, when asked for.
    conflicts: Option<crate::conflicts::ConflictsWriter>,
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
    pub fn new(mut level: Level, name: &str, options: &RunOptions) -> Result<Runner, RunError> {
        assign_models(&mut level, &options.drivers)?;
        if let Some(step_s) = options.action_step_s {
            assign_action_step(&mut level, step_s)?;
        }
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
        if options.trips {
            sim.world_mut().insert_resource(TripLog::default());
        }
        if options.external {
            sim.add_plugin(flockway_drivers::ExternalPlugin);
        }
        let types = load_vehicle_types(&level, name, &assets)?;
        let profiles = crate::assets::load_profiles(&level, name, &assets, options.external)?;
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
        let has_signals = level
            .junctions
            .iter()
            .any(|j| j.control == flockway_road::Control::Signal);
        let signals = match &options.csv {
            Some(csv) if has_signals => {
                let path = crate::signals::signals_path(csv);
                Some(
                    crate::signals::SignalsWriter::create(&path)
                        .map_err(|source| RunError::Output { path, source })?,
                )
            }
            _ => None,
        };
        let detectors = match &options.csv {
            Some(csv) if !level.detectors.is_empty() => {
                let path = crate::detectors::detectors_path(csv);
                Some(
                    crate::detectors::DetectorsWriter::create(&path)
                        .map_err(|source| RunError::Output { path, source })?,
                )
            }
            _ => None,
        };
        let conflicts = match &options.conflicts {
            Some(path) => Some(crate::conflicts::ConflictsWriter::create(path).map_err(
                |source| RunError::Output {
                    path: path.clone(),
                    source,
                },
            )?),
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
            signals,
            detectors,
            conflicts,
            per_vehicle,
            plots: options.plots.clone(),
            trace: Trace::new(),
            stepping: Duration::ZERO,
        })
    }

    /// What the run measured so far as a scenario to compare with another tool's: vehicles
    /// departed, waiting and running, contacts, every finished trip and the counts of every road
    /// of the level (not the junctions' inner paths), by road name. `None` unless the run keeps trips ([`RunOptions::trips`]).
    pub fn scenario_run(&mut self) -> Option<ScenarioRun> {
        let world = self.sim.world_mut();
        let running = world
            .query::<&flockway_traffic::VehicleId>()
            .iter(world)
            .count() as u64;
        let log = world.get_resource::<TripLog>()?;
        let network = world.resource::<RoadNetwork>();
        let stats = world.resource::<TrafficStats>();
        let name = |road: RoadId| network.get(road).map_or("?", |g| g.name()).to_owned();
        Some(ScenarioRun {
            departed: stats.spawned,
            waiting: stats.insertion_backlog,
            running,
            collisions: stats.collisions_vehicle,
            teleports: None,
            trips: log
                .trips
                .iter()
                .map(|t| Trip {
                    depart_s: t.depart_s,
                    depart_edge: name(t.depart_road),
                    arrival_s: t.arrival_s,
                    arrival_edge: name(t.arrival_road),
                    length_m: t.length_m,
                    time_loss_s: t.time_loss_s,
                })
                .collect(),
            // Roads as the level has them: a junction's inner paths are not edges.
            edges: log
                .roads
                .iter()
                .filter(|(road, _)| network.junction_path(**road).is_none())
                .map(|(&road, c)| {
                    let counts = EdgeCounts {
                        departed: c.departed,
                        entered: c.entered,
                        arrived: c.arrived,
                    };
                    (name(road), counts)
                })
                .collect(),
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
            // Wall-clock time is measured for the report only (the summary's `wall_seconds` and
            // `realtime_factor`, which the golden outputs leave out); it never reaches the
            // simulation or the CSV.
            let started = Instant::now();
            self.sim.step();
            self.stepping += started.elapsed();
            if self.sim.tick().0 == 1 {
                self.check_roads()?;
            }
            if let Some(signals) = &mut self.signals {
                // The states the step's vehicles saw (the clock advances after the step).
                let time_s = (self.sim.tick().0 - 1) as f64 / f64::from(TICKS_PER_SECOND);
                let world = self.sim.world();
                signals
                    .record(
                        world.resource::<RoadNetwork>(),
                        world.resource::<flockway_drivers::Signals>(),
                        time_s,
                    )
                    .map_err(|source| RunError::Output {
                        path: signals.path().to_owned(),
                        source,
                    })?;
            }
            self.write_detectors()?;
            self.write_samples()?;
            self.write_conflicts()?;
        }
        Ok(n)
    }

    /// Streams the detector readings closed this tick to the detectors CSV, if one is written
    /// (otherwise they are kept in the [`flockway_traffic::Detectors`] resource only).
    fn write_detectors(&mut self) -> Result<(), RunError> {
        let Some(writer) = &mut self.detectors else {
            return Ok(());
        };
        let world = self.sim.world();
        writer
            .record(
                world.resource::<RoadNetwork>(),
                world.resource::<flockway_traffic::Detectors>(),
            )
            .map_err(|source| RunError::Output {
                path: writer.path().to_owned(),
                source,
            })
    }

    /// Streams the conflicts finished this tick to the conflicts CSV, if one is being written
    /// (otherwise they are only counted).
    fn write_conflicts(&mut self) -> Result<(), RunError> {
        let world = self.sim.world_mut();
        let records = world.resource_mut::<Conflicts>().take_finished();
        let Some(writer) = &mut self.conflicts else {
            return Ok(());
        };
        writer
            .write(world.resource::<RoadNetwork>(), &records)
            .map_err(|source| RunError::Output {
                path: writer.path().to_owned(),
                source,
            })
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
        let writing = self.csv.is_some() || self.per_vehicle.is_some();
        for (tick, samples) in pending {
            let time_s = tick as f64 / f64::from(TICKS_PER_SECOND);
            // Kept as the CSV writes them, so analysing the run or its CSV agrees.
            for r in &samples {
                self.trace.push_as_written(NamedSample {
                    time_s,
                    vehicle_id: r.vehicle_id,
                    driver: &r.driver,
                    road: names.get(&r.road).map_or("", String::as_str),
                    lane: r.lane,
                    s_m: r.s_m,
                    speed_kmh: f64::from(r.speed_kmh),
                    model: &r.model,
                });
            }
            if !writing {
                continue;
            }
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
                    model: r.model.to_string(),
                    route: r.route.to_string(),
                })
                .collect();
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

    /// Wall-clock time spent stepping so far (for reports only; never part of the results).
    pub fn stepping(&self) -> Duration {
        self.stepping
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
    pub fn finish(mut self) -> Result<Summary, RunError> {
        while self.ticks_done() < self.total_ticks {
            self.step(u64::MAX)?;
        }
        // Conflict episodes still open at the end are over: counted, and written.
        {
            let world = self.sim.world_mut();
            let thresholds = world
                .get_resource::<SsmThresholds>()
                .copied()
                .unwrap_or_default();
            let time_s = world.resource::<flockway_core::SimClock>().seconds();
            world
                .resource_mut::<Conflicts>()
                .close_episodes(&thresholds, time_s, None);
        }
        self.write_conflicts()?;
        if let Some(w) = self.conflicts.take() {
            let path = w.path().to_owned();
            w.finish()
                .map_err(|source| RunError::Output { path, source })?;
        }
        if let Some(csv) = self.csv.take() {
            let path = csv.path().to_owned();
            csv.finish()
                .map_err(|source| RunError::Output { path, source })?;
        }
        if let Some(files) = self.per_vehicle.take() {
            files.finish()?;
        }
        if let Some(mut detectors) = self
            .sim
            .world_mut()
            .get_resource_mut::<flockway_traffic::Detectors>()
        {
            // The last period ends with the run.
            detectors.close_all();
        }
        self.write_detectors()?;
        if let Some(detectors) = self.detectors.take() {
            let path = detectors.path().to_owned();
            detectors
                .finish()
                .map_err(|source| RunError::Output { path, source })?;
        }
        if let Some(signals) = self.signals.take() {
            let path = signals.path().to_owned();
            signals
                .finish()
                .map_err(|source| RunError::Output { path, source })?;
        }
        let summary = measure(
            &self.sim,
            &self.level,
            &self.name,
            &self.trace,
            self.stepping,
        );
        if let Some((dir, format)) = &self.plots {
            flockway_analysis::write_plots(&self.trace, &summary.plot_info(), dir, *format)?;
        }
        Ok(summary)
    }
}

//! Play mode: a level run by the same [`Runner`] as `flockway run`, stepped at the fixed step
//! as real time passes (1×, 2×, 5× or as fast as the frame budget allows), with the poses of
//! the last two steps kept for smooth drawing between them.

use flockway_core::{DT_S, RunStats};
use flockway_drivers::Route;
use flockway_level::Level;
use flockway_render::{ColourBy, VehicleFrame, palette};
use flockway_road::{RoadId, RoadNetwork};
use flockway_runner::{MAX_RUN_SECONDS, RunError, RunOptions, Runner};
use flockway_traffic::{Spawner, SpawnerRate, TrafficStats};
use flockway_vehicle::Motion;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// How fast play runs, relative to real time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlaySpeed {
    /// Real time.
    #[default]
    X1,
    /// Twice real time.
    X2,
    /// Five times real time.
    X5,
    /// As many steps as fit in each frame.
    Max,
}

impl PlaySpeed {
    /// The factor, or `None` for as fast as possible.
    pub fn factor(self) -> Option<f64> {
        match self {
            PlaySpeed::X1 => Some(1.0),
            PlaySpeed::X2 => Some(2.0),
            PlaySpeed::X5 => Some(5.0),
            PlaySpeed::Max => None,
        }
    }

    /// Its label on the HUD.
    pub fn label(self) -> &'static str {
        match self {
            PlaySpeed::X1 => "1×",
            PlaySpeed::X2 => "2×",
            PlaySpeed::X5 => "5×",
            PlaySpeed::Max => "max",
        }
    }
}

/// The figures the HUD shows.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HudStats {
    /// Simulated seconds.
    pub sim_s: f64,
    /// Simulated seconds per wall second over the last frames.
    pub realtime_factor: f64,
    /// Vehicles on the roads.
    pub alive: u64,
    /// Vehicles spawned per second so far.
    pub spawned_per_s: f64,
    /// Mean speed of the vehicles on the roads, km/h.
    pub mean_speed_kmh: f64,
    /// Guardrail hits so far.
    pub collisions_guardrail: u64,
    /// Vehicle–vehicle contacts so far.
    pub collisions_vehicle: u64,
}

/// A level being played.
pub struct PlaySession {
    runner: Runner,
    /// Poses after the step before the last.
    pub prev: VehicleFrame,
    /// Poses after the last step.
    pub next: VehicleFrame,
    accumulator_s: f64,
    /// Play speed.
    pub speed: PlaySpeed,
    /// Whether time stands still.
    pub paused: bool,
    colour_by: ColourBy,
    csv_path: PathBuf,
    /// `(sim seconds, mean, slowest and fastest speed km/h, vehicles)` once per simulated half
    /// second, for the chart.
    pub history: Vec<[f64; 5]>,
    rtf_window: (f64, Duration),
    realtime_factor: f64,
    /// The last score shown (value, medal), the step and wall time it was measured at.
    score: Option<(u64, Instant, (String, String))>,
}

/// Steps between chart points.
const HALF_SECOND_TICKS: u64 = flockway_core::TICKS_PER_SECOND as u64 / 2;

/// Wall time play may spend stepping per frame, so the window stays responsive.
pub const FRAME_BUDGET: Duration = Duration::from_millis(12);

impl PlaySession {
    /// Starts playing `level` (named `name`, with assets under `assets`), streaming telemetry
    /// to `csv` exactly as `flockway run --csv` would.
    pub fn start(
        level: Level,
        name: &str,
        assets: &Path,
        csv: &Path,
    ) -> Result<PlaySession, RunError> {
        // A challenge's custom profile plays as its untold car does (a lane-keeping flocking
        // car), so its score shows the bar a controller starts from.
        let external = level
            .driver_profiles
            .iter()
            .any(|p| matches!(p.model, flockway_level::DriverModel::Custom(_)));
        let options = RunOptions {
            seconds: Some(MAX_RUN_SECONDS),
            csv: Some(csv.to_owned()),
            assets: Some(assets.to_owned()),
            external,
            ..RunOptions::default()
        };
        let mut runner = Runner::new(level, name, &options)?;
        let mut next = VehicleFrame::default();
        next.capture(runner.sim_mut().world_mut());
        Ok(PlaySession {
            runner,
            prev: next.clone(),
            next,
            accumulator_s: 0.0,
            speed: PlaySpeed::X1,
            paused: false,
            colour_by: ColourBy::Driver,
            csv_path: csv.to_owned(),
            history: Vec::new(),
            rtf_window: (0.0, Duration::ZERO),
            realtime_factor: 0.0,
            score: None,
        })
    }

    /// The HUD's score for a level with a score: its value (`7.12 km/h`, or when it will be
    /// measured) and its medal (`silver (gold from 8)`); remeasured once 2 simulated seconds
    /// have passed and either half a wall second or 30 simulated seconds (the summary's metrics
    /// take a moment on long runs). `None` for a level without one.
    pub fn score(&mut self) -> Option<(String, String)> {
        let spec = self.runner.level().score.clone()?;
        let tick = self.runner.ticks_done();
        let second = u64::from(flockway_core::TICKS_PER_SECOND);
        let fresh = self.score.as_ref().is_some_and(|(at, when, _)| {
            let advanced = tick.saturating_sub(*at);
            advanced < 2 * second
                || (advanced < 30 * second && when.elapsed() < Duration::from_millis(500))
        });
        if !fresh {
            let from_s = self.runner.level().telemetry.stats_from_s;
            let shown = if self.sim_s() < from_s {
                (format!("measured from {from_s:.0} s"), String::new())
            } else {
                let summary = flockway_runner::measure(
                    self.runner.sim(),
                    self.runner.level(),
                    "play",
                    self.runner.trace(),
                    Duration::ZERO,
                );
                match spec.formula.evaluate(&summary.metrics) {
                    Ok(v) => (spec.value_text(v), spec.medal_text(v)),
                    Err(e) => ("none".to_owned(), e.to_string()),
                }
            };
            self.score = Some((tick, Instant::now(), shown));
        }
        self.score.as_ref().map(|(_, _, shown)| shown.clone())
    }

    /// What the cars' paint tells.
    pub fn colour_by(&self) -> ColourBy {
        self.colour_by
    }

    /// Paints the cars by driver or by destination, from the frame shown now on.
    pub fn set_colour_by(&mut self, by: ColourBy) {
        self.colour_by = by;
        let world = self.runner.sim_mut().world_mut();
        self.next.capture_by(world, by);
        let colours: std::collections::BTreeMap<_, _> = self
            .next
            .ids
            .iter()
            .zip(&self.next.instances)
            .map(|(e, i)| (*e, i.colour))
            .collect();
        for (e, i) in self.prev.ids.iter().zip(&mut self.prev.instances) {
            if let Some(c) = colours.get(e) {
                i.colour = *c;
            }
        }
    }

    /// The roads vehicles on the roads are bound for, with how many are bound for each and
    /// their paint (`None`: vehicles with no destination), for the legend.
    pub fn destinations(&mut self) -> Vec<(Option<String>, usize, [f32; 4])> {
        let world = self.runner.sim_mut().world_mut();
        let mut counts: std::collections::BTreeMap<Option<RoadId>, usize> = Default::default();
        let mut query = world.query::<&Route>();
        for route in query.iter(world) {
            *counts.entry(route.destination()).or_default() += 1;
        }
        let network = world.resource::<RoadNetwork>();
        counts
            .into_iter()
            .map(|(road, n)| {
                let name = road
                    .and_then(|r| network.get(r))
                    .map(|g| g.name().to_owned());
                (name, n, palette::destination(road))
            })
            .collect()
    }

    /// The runner (for tools that inspect the world).
    pub fn runner(&self) -> &Runner {
        &self.runner
    }

    /// The runner, mutably (the HUD edits spawners live).
    pub fn runner_mut(&mut self) -> &mut Runner {
        &mut self.runner
    }

    /// Simulated seconds so far.
    pub fn sim_s(&self) -> f64 {
        self.runner.ticks_done() as f64 * DT_S
    }

    /// How far between the last two steps the frame is drawn (0 to 1).
    pub fn alpha(&self) -> f32 {
        (self.accumulator_s / DT_S).clamp(0.0, 1.0) as f32
    }

    /// Runs exactly `ticks` steps.
    pub fn step_ticks(&mut self, ticks: u64) -> Result<(), RunError> {
        let mut left = ticks;
        while left > 0 {
            // Up to the next half second, so the chart gets a point every half second.
            let to_half = HALF_SECOND_TICKS - self.runner.ticks_done() % HALF_SECOND_TICKS;
            let chunk = left.min(to_half);
            if chunk == left {
                // The last chunk: keep the poses of its last two steps for drawing.
                if chunk > 1 {
                    self.runner.step(chunk - 1)?;
                }
                self.prev
                    .capture_by(self.runner.sim_mut().world_mut(), self.colour_by);
                self.runner.step(1)?;
                self.next
                    .capture_by(self.runner.sim_mut().world_mut(), self.colour_by);
            } else {
                self.runner.step(chunk)?;
            }
            left -= chunk;
            self.record();
        }
        Ok(())
    }

    /// Advances by `wall_s` seconds of real time at the play speed, within `budget` of wall
    /// time. Returns the steps run.
    pub fn advance(&mut self, wall_s: f64, budget: Duration) -> Result<u64, RunError> {
        if self.paused {
            return Ok(0);
        }
        let started = Instant::now();
        let wanted = match self.speed.factor() {
            Some(f) => {
                self.accumulator_s += wall_s.max(0.0) * f;
                // Never fall more than a quarter second behind: drop the rest.
                self.accumulator_s = self.accumulator_s.min(0.25 * f);
                (self.accumulator_s / DT_S).floor() as u64
            }
            None => u64::MAX,
        };
        let mut done = 0;
        while done < wanted && started.elapsed() < budget {
            let chunk = (wanted - done).min(8);
            self.step_ticks(chunk)?;
            done += chunk;
        }
        if self.speed.factor().is_some() {
            self.accumulator_s -= done as f64 * DT_S;
            if done < wanted {
                // Behind: draw the latest step rather than catching up over several frames.
                self.accumulator_s = self.accumulator_s.min(DT_S);
            }
        } else {
            self.accumulator_s = DT_S;
        }
        let w = &mut self.rtf_window;
        w.0 += done as f64 * DT_S;
        w.1 += started
            .elapsed()
            .max(Duration::from_secs_f64(wall_s.max(0.0)));
        if w.1 > Duration::from_millis(500) {
            self.realtime_factor = w.0 / w.1.as_secs_f64();
            *w = (0.0, Duration::ZERO);
        }
        Ok(done)
    }

    fn record(&mut self) {
        let t = self.sim_s();
        if self.history.last().is_some_and(|h| t - h[0] < 0.5 - 1e-9) {
            return;
        }
        let stats = self.stats();
        let world = self.runner.sim_mut().world_mut();
        let mut q = world.query::<&Motion>();
        let (lo, hi) = q.iter(world).fold((f64::INFINITY, 0.0f64), |(lo, hi), m| {
            let v = f64::from(m.forward_mps) * 3.6;
            (lo.min(v), hi.max(v))
        });
        let lo = if lo.is_finite() { lo } else { 0.0 };
        self.history
            .push([t, stats.mean_speed_kmh, lo, hi, stats.alive as f64]);
    }

    /// The HUD's figures now.
    pub fn stats(&mut self) -> HudStats {
        let sim_s = self.sim_s();
        let world = self.runner.sim_mut().world_mut();
        let mut q = world.query::<&Motion>();
        let (mut n, mut sum) = (0u64, 0.0);
        for m in q.iter(world) {
            n += 1;
            sum += f64::from(m.forward_mps) * 3.6;
        }
        let traffic = world.resource::<TrafficStats>();
        HudStats {
            sim_s,
            realtime_factor: self.realtime_factor,
            alive: world.resource::<RunStats>().vehicles_alive.max(n),
            spawned_per_s: world.resource::<SpawnerRate>().per_s,
            mean_speed_kmh: if n > 0 { sum / n as f64 } else { 0.0 },
            collisions_guardrail: traffic.collisions_guardrail,
            collisions_vehicle: traffic.collisions_vehicle,
        }
    }

    /// Every spawner's name, interval range (s) and autonomous share (0–1), for the HUD.
    pub fn spawners(&mut self) -> Vec<(String, f64, f64, f64)> {
        let world = self.runner.sim_mut().world_mut();
        let mut q = world.query::<&Spawner>();
        let mut out: Vec<_> = q
            .iter(world)
            .map(|s| {
                let total: f64 = s.choices.iter().map(|c| c.weight).sum();
                let human: f64 = s
                    .choices
                    .iter()
                    .filter(|c| matches!(c.driver, flockway_drivers::DriverSpec::Human(_)))
                    .map(|c| c.weight)
                    .sum();
                let auto = if total > 0.0 {
                    1.0 - human / total
                } else {
                    1.0
                };
                (s.name.clone(), s.interval_min_s, s.interval_max_s, auto)
            })
            .collect();
        out.sort_by(|a, b| a.0.cmp(&b.0));
        out
    }

    /// Sets a spawner's interval range and autonomous share, live (thesis §3.5).
    pub fn set_spawner(&mut self, name: &str, min_s: f64, max_s: f64, autonomous_share: f64) {
        let world = self.runner.sim_mut().world_mut();
        let mut q = world.query::<&mut Spawner>();
        for mut s in q.iter_mut(world) {
            if s.name != name {
                continue;
            }
            s.interval_min_s = min_s.max(0.05);
            s.interval_max_s = max_s.max(s.interval_min_s);
            let share = autonomous_share.clamp(0.0, 1.0);
            let humans = s
                .choices
                .iter()
                .filter(|c| matches!(c.driver, flockway_drivers::DriverSpec::Human(_)))
                .count();
            let autos = s.choices.len() - humans;
            for c in s.choices.iter_mut() {
                let human = matches!(c.driver, flockway_drivers::DriverSpec::Human(_));
                c.weight = match (human, humans, autos) {
                    (true, h, _) if h > 0 => (1.0 - share) / h as f64,
                    (false, _, a) if a > 0 => share / a as f64,
                    _ => c.weight,
                };
            }
        }
    }

    /// Copies the telemetry streamed so far (flushed at every sample) to `to`, for a level
    /// with signals the signals CSV beside it (`STEM.signals.csv`, as `flockway run` writes)
    /// and for a level with detectors their periods closed so far (`STEM.detectors.csv`).
    /// Returns whether there was a signals CSV.
    pub fn export_csv(&self, to: &Path) -> std::io::Result<bool> {
        std::fs::copy(&self.csv_path, to)?;
        let detectors = flockway_runner::detectors_path(&self.csv_path);
        if detectors.exists() {
            std::fs::copy(&detectors, flockway_runner::detectors_path(to))?;
        }
        let signals = flockway_runner::signals_path(&self.csv_path);
        if !signals.exists() {
            return Ok(false);
        }
        std::fs::copy(&signals, flockway_runner::signals_path(to))?;
        Ok(true)
    }

    /// The file the telemetry streams to.
    pub fn csv_path(&self) -> &Path {
        &self.csv_path
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use flockway_level::load_level;

    #[test]
    fn cars_painted_by_destination_show_where_each_is_bound() {
        let level = load_level(Path::new("../../levels/exit_split.ron")).expect("shipped level");
        let dir = tempfile::tempdir().expect("tempdir");
        let mut p = PlaySession::start(
            level,
            "exit_split",
            Path::new("../../assets"),
            &dir.path().join("t.csv"),
        )
        .expect("play starts");
        p.step_ticks(60 * 120).expect("steps");
        let by_driver = p.next.instances.clone();
        p.set_colour_by(ColourBy::Destination);
        let legend = p.destinations();
        let mut bound: Vec<&str> = legend.iter().filter_map(|(r, ..)| r.as_deref()).collect();
        bound.sort_unstable();
        assert_eq!(bound, ["north", "south"], "{legend:?}");
        let world = p.runner.sim_mut().world_mut();
        for (e, i) in p.next.ids.iter().zip(&p.next.instances) {
            let dest = world.get::<Route>(*e).and_then(Route::destination);
            assert_eq!(i.colour, palette::destination(dest));
        }
        // The two destinations have paints of their own, and the poses did not change.
        assert_ne!(legend[0].2, legend[1].2);
        for (a, b) in by_driver.iter().zip(&p.next.instances) {
            assert_eq!(a.translation, b.translation);
        }
        p.step_ticks(10).expect("steps");
        assert!(
            p.next
                .instances
                .iter()
                .all(|i| legend.iter().any(|(_, _, c)| *c == i.colour)
                    || i.colour == palette::destination(None)),
            "new frames keep the destination paint"
        );
    }
}

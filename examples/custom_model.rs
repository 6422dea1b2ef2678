//! A driver model in one file: Gipps' car-following model (Gipps 1981, "A behavioural
//! car-following model for computer simulation", Transp. Res. B 15) as a [`DrivingModel`].
//! The model supplies only its speed law; the pipeline every built-in model goes through gives
//! it the rest — its route's lane changes with gap acceptance, merging at a lane's end, making
//! room for others, junction rules, the road ahead — and the safety layer holds it to its
//! braking envelope. Here it drives the ramp cars (profile `merger`, `Custom("merger")`) of
//! `levels/challenges/merge_smoothly.ron` and prints the run's summary as JSON.
//!
//! ```text
//! cargo run --release --example custom_model -- levels/challenges/merge_smoothly.ron --seed 1
//! ```
//!
//! Options: `--seed N`, `--seconds S`, `--model NAME` (the custom profile's model, default
//! `merger`), `--csv FILE` (stream the telemetry).

use bevy_ecs::prelude::*;
use flockway::core::{Sim, SimPlugin};
use flockway::drivers::{
    DrivingModel, FlockParams, LaneStyle, Longitudinal, Proposal, Seen, Situation, add_custom_model,
};
use flockway::level::load_level;
use flockway::run::{RunOptions, Runner, find_assets_dir, level_name};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Gipps' model: the speed it will drive at a reaction time from now is the lesser of what it
/// can reach accelerating freely and what still lets it stop behind its leader, should the
/// leader brake as hard as it believes it would.
#[derive(Component, Debug, Clone)]
struct Gipps {
    /// Maximum acceleration a, m/s².
    accel_mps2: f32,
    /// The braking it is prepared to use, b, m/s².
    decel_mps2: f32,
    /// The braking it expects of its leader, b̂, m/s².
    leader_decel_mps2: f32,
    /// Reaction time τ, s.
    reaction_s: f32,
    /// The bumper gap it stops at, s₀, m.
    min_gap_m: f32,
    /// How far ahead it looks for its leader, m.
    range_m: f64,
    /// Lane keeping and changing, as the profile's flocking parameters have it.
    style: LaneStyle,
}

impl Gipps {
    /// Gipps' published parameters, with the profile's lane style.
    fn new(base: &FlockParams) -> Gipps {
        Gipps {
            accel_mps2: 1.7,
            decel_mps2: 3.4,
            leader_decel_mps2: 3.2,
            reaction_s: 2.0 / 3.0,
            min_gap_m: 2.0,
            range_m: 150.0,
            style: base.lane_style(true),
        }
    }

    /// The speed a reaction time ahead, m/s, at speed `v` wanting `v_desired`, behind a leader
    /// at bumper gap `gap_m` driving at `v_leader`, if any.
    fn speed_mps(&self, v: f32, v_desired: f32, leader: Option<(f32, f32)>) -> f32 {
        let (a, b, tau) = (self.accel_mps2, self.decel_mps2, self.reaction_s);
        let v = v.max(0.0);
        let share = (v / v_desired.max(0.1)).min(1.0);
        let free = v + 2.5 * a * tau * (1.0 - share) * (0.025 + share).sqrt();
        let safe = leader.map_or(f32::INFINITY, |(gap, v_leader)| {
            let room = 2.0 * (gap - self.min_gap_m) - v * tau
                + v_leader * v_leader / self.leader_decel_mps2;
            -b * tau + (b * b * tau * tau + b * room).max(0.0).sqrt()
        });
        free.min(safe).min(v_desired.max(0.0)).max(0.0)
    }
}

impl DrivingModel for Gipps {
    fn cruise_kmh(&self) -> Option<f32> {
        None
    }

    fn style(&self) -> LaneStyle {
        self.style
    }

    fn decide(&mut self, at: &Situation, _seen: &mut Vec<Seen>) -> Proposal {
        let leader = at.leader(self.range_m);
        Proposal {
            longitudinal: Longitudinal::Speed(self.speed_mps(at.v, at.v_desired, leader)),
            steer_by: None,
        }
    }
}

/// Drives the custom profile `model` with Gipps' model.
struct GippsPlugin(String);

impl SimPlugin for GippsPlugin {
    fn build(&self, sim: &mut Sim) {
        add_custom_model(sim, &self.0, Gipps::new);
    }
}

/// Runs `level` with its custom profile `model` driven by Gipps' model: the run's summary.
fn run(
    level: &Path,
    model: &str,
    (seed, seconds): (Option<u64>, Option<f64>),
    csv: Option<PathBuf>,
) -> Result<flockway::run::Summary, String> {
    let loaded = load_level(level).map_err(|e| e.to_string())?;
    let name = level_name(&loaded, level);
    let options = RunOptions {
        seconds,
        seed,
        csv,
        assets: Some(find_assets_dir(Some(level))),
        // Custom profiles are driven from outside the built-in models: here, by the plugin.
        external: true,
        ..RunOptions::default()
    };
    let mut runner = Runner::new(loaded, &name, &options).map_err(|e| e.to_string())?;
    runner.sim_mut().add_plugin(GippsPlugin(model.to_owned()));
    runner.finish().map_err(|e| e.to_string())
}

fn main() -> ExitCode {
    let usage = "usage: custom_model LEVEL [--seed N] [--seconds S] [--model NAME] [--csv FILE]";
    let mut args = std::env::args().skip(1);
    let Some(level) = args.next() else {
        eprintln!("error: {usage}");
        return ExitCode::from(2);
    };
    let (mut seed, mut seconds, mut model, mut csv) = (None, None, "merger".to_owned(), None);
    while let Some(flag) = args.next() {
        let value = args.next().unwrap_or_default();
        let ok = match flag.as_str() {
            "--seed" => value.parse().map(|s| seed = Some(s)).is_ok(),
            "--seconds" => value.parse().map(|s| seconds = Some(s)).is_ok(),
            "--csv" => {
                csv = Some(PathBuf::from(&value));
                !value.is_empty()
            }
            "--model" => {
                model = value.clone();
                !value.is_empty()
            }
            _ => false,
        };
        if !ok {
            eprintln!("error: {flag} {value}: {usage}");
            return ExitCode::from(2);
        }
    }
    match run(&PathBuf::from(level), &model, (seed, seconds), csv)
        .and_then(|s| s.to_json_text().map_err(|e| e.to_string()))
    {
        Ok(json) => {
            print!("{json}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

#[test]
fn gipps_drives_the_ramp_cars_through_the_pipeline() {
    let level = Path::new(env!("CARGO_MANIFEST_DIR")).join("levels/challenges/merge_smoothly.ron");
    let summary = run(&level, "merger", (Some(3), Some(240.0)), None).expect("the run completes");
    let get = |k: &str| summary.metrics.get(k).copied().unwrap_or(f64::NAN);
    // Ramp cars came, merged through the pipeline's gap acceptance and left the motorway.
    assert!(get("veh_km.merger") > 10.0, "{:?}", summary.metrics);
    assert!(get("mean_speed_kmh.merger") > 60.0, "{:?}", summary.metrics);
    assert_eq!(get("missed_exits.merger"), 0.0);
    assert_eq!(get("collisions_vehicle"), 0.0);
    assert_eq!(get("collisions_guardrail"), 0.0);
    assert!(get("mean_delay_s.merger").is_finite());
}

#[test]
fn gipps_free_and_safe_speeds() {
    let g = Gipps::new(&FlockParams::default());
    // From a standstill on a free road: 2.5 a τ √0.025 = 0.448 m/s a reaction time later.
    assert!((g.speed_mps(0.0, 20.0, None) - 0.448).abs() < 0.01);
    // At the desired speed it stays there.
    assert!((g.speed_mps(20.0, 20.0, None) - 20.0).abs() < 1e-4);
    // Behind a stopped car at s₀ it stays stopped; far behind a car at its speed it keeps it.
    assert_eq!(g.speed_mps(0.0, 20.0, Some((2.0, 0.0))), 0.0);
    assert!((g.speed_mps(20.0, 20.0, Some((200.0, 20.0))) - 20.0).abs() < 1e-4);
    // Closing fast on a stopped car: well below its speed.
    assert!(g.speed_mps(20.0, 20.0, Some((40.0, 0.0))) < 13.0);
}

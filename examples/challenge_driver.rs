//! A challenge played by a driver written in Rust: "gap keeper" drives the `controller` cars of
//! `levels/challenges/damp_the_wave.ron` (any level with a `Custom` profile, with `--model`),
//! the same law as the Python `GapKeeper` of the docs, and the run's summary — its score and
//! medal among it — is printed as JSON.
//!
//! ```text
//! cargo run --release --example challenge_driver -- levels/challenges/damp_the_wave.ron --seed 1
//! ```
//!
//! Options: `--seed N`, `--seconds S`, `--model NAME` (default `controller`), `--gap S` (the
//! time gap kept, default 1.5 s), `--csv FILE` (stream the telemetry).

use bevy_ecs::prelude::*;
use flockway::core::{Sim, SimPlugin};
use flockway::drivers::{External, ExternalCommand, LaneIndex, add_external_driver};
use flockway::level::load_level;
use flockway::road::RoadNetwork;
use flockway::run::{LEADER_RANGE_M, RunOptions, Runner, find_assets_dir, level_name};
use flockway::vehicle::{Motion, RoadTrack, VehicleModel};
use std::path::PathBuf;
use std::process::ExitCode;

/// The driver's settings, a resource: the custom model it drives and the time gap it keeps.
#[derive(Resource, Clone)]
struct GapKeeper {
    model: String,
    gap_s: f64,
}

/// Each tick, for every vehicle of the model: the speed that closes the gap beyond 2 m plus
/// `gap_s` of its own speed in 2 s, between 0 and the speed limit. Reckoned in f64 from the same
/// figures `Sim.observe` gives a Python driver, so both drive alike.
fn keep_gap(
    keeper: Res<GapKeeper>,
    network: Res<RoadNetwork>,
    index: Res<LaneIndex>,
    mut cars: Query<(Entity, &mut External, &RoadTrack, &Motion, &VehicleModel)>,
) {
    for (me, mut external, track, motion, model) in &mut cars {
        if *external.model != *keeper.model {
            continue;
        }
        let Some(road) = network.get(track.road) else {
            continue;
        };
        let limit = road.speed_limit_kmh() / 3.6;
        let own = f64::from(model.0.params.chassis.length_m);
        let (lead, gap) = match index.leader(
            track.road,
            track.lane,
            track.s_m,
            me,
            LEADER_RANGE_M,
            track.next_road,
        ) {
            Some(l) => (
                f64::from(l.entry.speed_mps),
                l.gap_m - 0.5 * (own + f64::from(l.entry.length_m)),
            ),
            None => (limit, f64::INFINITY),
        };
        let v = f64::from(motion.forward_mps);
        let want = lead + (gap - 2.0 - keeper.gap_s * v) / 2.0;
        external.command = Some(ExternalCommand::Target {
            speed_mps: want.clamp(0.0, limit) as f32,
            lane: None,
        });
    }
}

/// Registers the driver: no engine code changes.
struct GapKeeperPlugin(GapKeeper);

impl SimPlugin for GapKeeperPlugin {
    fn build(&self, sim: &mut Sim) {
        sim.world_mut().insert_resource(self.0.clone());
        add_external_driver(sim, keep_gap);
    }
}

/// The command line: the level, then `--flag value` pairs.
struct Args {
    level: PathBuf,
    seed: Option<u64>,
    seconds: Option<f64>,
    csv: Option<PathBuf>,
    keeper: GapKeeper,
}

fn parse_args() -> Result<Args, String> {
    let mut args = std::env::args().skip(1);
    let usage = "usage: challenge_driver LEVEL [--seed N] [--seconds S] [--model NAME] [--gap S] [--csv FILE]";
    let level = args.next().ok_or(usage)?;
    let mut out = Args {
        level: PathBuf::from(level),
        seed: None,
        seconds: None,
        csv: None,
        keeper: GapKeeper {
            model: "controller".to_owned(),
            gap_s: 1.5,
        },
    };
    while let Some(flag) = args.next() {
        let value = args
            .next()
            .ok_or(format!("{flag} needs a value; {usage}"))?;
        let number = |v: &str| {
            v.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or(format!("{flag} {v}: expected a number"))
        };
        match flag.as_str() {
            "--seed" => {
                out.seed = Some(
                    value
                        .parse()
                        .map_err(|_| format!("--seed {value}: expected a whole number"))?,
                );
            }
            "--seconds" => out.seconds = Some(number(&value)?),
            "--model" => out.keeper.model = value,
            "--gap" => out.keeper.gap_s = number(&value)?,
            "--csv" => out.csv = Some(PathBuf::from(value)),
            _ => return Err(format!("unknown option {flag}; {usage}")),
        }
    }
    Ok(out)
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let level = match load_level(&args.level) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let name = level_name(&level, &args.level);
    let options = RunOptions {
        seconds: args.seconds,
        seed: args.seed,
        csv: args.csv,
        assets: Some(find_assets_dir(Some(&args.level))),
        // Custom profiles are driven from outside the step: here, by the plugin.
        external: true,
        ..RunOptions::default()
    };
    let outcome = Runner::new(level, &name, &options).and_then(|mut runner| {
        runner.sim_mut().add_plugin(GapKeeperPlugin(args.keeper));
        runner.finish()
    });
    match outcome.map(|s| s.to_json_text()) {
        Ok(Ok(json)) => {
            print!("{json}");
            ExitCode::SUCCESS
        }
        Ok(Err(e)) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

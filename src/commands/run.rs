//! `flockway run`: one level headless, with a progress bar, the summary and the expectations.

use super::fail;
use crate::cli::RunArgs;
use flockway::analysis::PlotFormat;
use flockway::level::{load_level, write_atomic};
use flockway::run::{RunError, RunOptions, Runner, level_name};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::process::ExitCode;

pub fn run(args: RunArgs) -> ExitCode {
    let level = match load_level(&args.level) {
        Ok(l) => l,
        Err(e) => return fail(e),
    };
    super::print_warnings(&level, &args.level);
    let name = level_name(&level, &args.level);
    let options = RunOptions {
        seconds: args.seconds,
        seed: args.seed,
        csv: args.csv.clone(),
        per_vehicle: args.per_vehicle.clone(),
        conflicts: args.conflicts.clone(),
        assets: Some(flockway::run::find_assets_dir(Some(&args.level))),
        plots: args
            .plots
            .clone()
            .map(|dir| (dir, PlotFormat::from(args.plot_format))),
        external: false,
        drivers: args.drivers.iter().cloned().collect(),
        trips: false,
        action_step_s: args.action_step,
    };
    let score = level.score.clone();
    let mut runner = match Runner::new(level, &name, &options) {
        Ok(r) => r,
        Err(e) => return fail(e),
    };
    let total = runner.total_ticks();
    let interactive = !args.quiet && std::io::stderr().is_terminal();
    let bar = interactive.then(|| {
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template("{prefix} [{bar:40}] {percent:>3}% {msg} (eta {eta})")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar.set_prefix(name.clone());
        bar
    });
    // Steps in chunks of one simulated second, so progress updates without slowing the run.
    let mut next_line = 1;
    while runner.ticks_done() < total {
        if let Err(e) = runner.step(120) {
            return fail(e);
        }
        let done = runner.ticks_done();
        if let Some(bar) = &bar {
            bar.set_position(done);
            bar.set_message(format!(
                "{:.0}/{:.0} s",
                done as f64 / 120.0,
                total as f64 / 120.0
            ));
        } else if !args.quiet && done * 10 >= next_line * total {
            eprintln!(
                "{name}: {}% ({:.1} of {:.1} simulated s)",
                done * 100 / total,
                done as f64 / 120.0,
                total as f64 / 120.0
            );
            next_line = done * 10 / total + 1;
        }
    }
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    let report = match runner.finish() {
        Ok(r) => r,
        Err(e) => return fail(e),
    };
    // A run with no vehicle at all measured nothing: say so, whatever its expectations say.
    if report.vehicle_steps == 0 {
        eprintln!(
            "warning: {}: no vehicle drove in this run (nothing spawned, nothing placed): every \
             figure is empty; give the level spawners or vehicles",
            args.level.display()
        );
    }
    if let Some(path) = &args.summary {
        let text = match report.to_json_text() {
            Ok(t) => t,
            Err(e) => return fail(e),
        };
        if let Err(e) = write_atomic(path, text.as_bytes()) {
            return fail(RunError::Level(e));
        }
    }
    if !args.quiet {
        out!("{}", report.to_text());
        if let Some(spec) = &score {
            let outcome = spec.formula.evaluate(&report.metrics);
            outln!("score            {}", spec.describe(&outcome));
        }
    }
    if report.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

//! The `flockway` command: run, check and (in later releases) edit and plot levels.

use clap::{Args, Parser, Subcommand};
use flockway::run::{RunError, RunOptions, Runner, level_name};
use flockway_level::{load_level, write_atomic};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

/// Flockway: a deterministic traffic sandbox with rigid-body cars and flocking drivers.
///
/// Levels are RON files (see levels/ for examples). Every run with the same level and seed gives
/// the same results, byte for byte.
#[derive(Parser)]
#[command(name = "flockway", version, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a level headless and check its expectations.
    ///
    /// Exit status: 0 if every expectation held, 1 if one failed, 2 if the level or an argument
    /// is invalid.
    Run(RunArgs),
    /// Check that level files load and validate, without running them.
    ///
    /// Prints each problem as FILE:LINE:COLUMN: message. Exit status: 0 if all are valid, 2 if not.
    Check {
        /// Level files to check.
        #[arg(required = true, value_name = "LEVEL")]
        levels: Vec<PathBuf>,
    },
}

#[derive(Args)]
struct RunArgs {
    /// The level file to run (e.g. levels/dense_road.ron).
    #[arg(value_name = "LEVEL")]
    level: PathBuf,
    /// Simulated seconds to run, instead of the level's duration_s.
    #[arg(long, value_name = "S")]
    seconds: Option<f64>,
    /// Seed for every random stream, instead of the level's seed.
    #[arg(long, value_name = "N")]
    seed: Option<u64>,
    /// Stream per-vehicle telemetry to this CSV file as the run goes.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Write the run summary as JSON to this file (keys documented in the README).
    #[arg(long, value_name = "FILE")]
    summary: Option<PathBuf>,
    /// Print nothing but errors; the exit status tells the outcome.
    #[arg(long, short)]
    quiet: bool,
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("FLOCKWAY_LOG")
                .unwrap_or_else(|_| "warn".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let cli = Cli::parse();
    match cli.command {
        Command::Run(args) => run(args),
        Command::Check { levels } => check(&levels),
    }
}

fn fail(e: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(2)
}

fn check(levels: &[PathBuf]) -> ExitCode {
    let mut bad = 0;
    for path in levels {
        match load_level(path) {
            Ok(level) => println!(
                "ok    {} ({}, {} road(s))",
                path.display(),
                level_name(&level, path),
                level.roads.len()
            ),
            Err(e) => {
                bad += 1;
                eprintln!("error: {e}");
            }
        }
    }
    if bad == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(2)
    }
}

fn run(args: RunArgs) -> ExitCode {
    let level = match load_level(&args.level) {
        Ok(l) => l,
        Err(e) => return fail(e),
    };
    let name = level_name(&level, &args.level);
    let options = RunOptions {
        seconds: args.seconds,
        seed: args.seed,
        csv: args.csv.clone(),
    };
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
    if let Some(path) = &args.summary {
        let mut text = match serde_json::to_string_pretty(&report.to_json()) {
            Ok(t) => t,
            Err(e) => return fail(e),
        };
        text.push('\n');
        if let Err(e) = write_atomic(path, text.as_bytes()) {
            return fail(RunError::Level(e));
        }
    }
    if !args.quiet {
        print!("{}", report.to_text());
    }
    if report.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

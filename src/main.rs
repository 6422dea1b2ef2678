//! The `flockway` command: parses the command line (`cli`) and hands each command to its
//! module in `commands`. Exit status: 0 all good, 1 an expectation failed, 2 bad input.

/// `print!` that gives up quietly when standard output is gone (`flockway run … | head`): the
/// command still finishes, writes its files and exits with its own status.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout(), $($arg)*);
    }};
}

/// `println!` that gives up quietly when standard output is gone, as [`out!`].
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

mod cli;
mod commands;

use clap::Parser;
use cli::{Cli, Command};
use std::process::ExitCode;

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("FLOCKWAY_LOG")
                .unwrap_or_else(|_| "warn".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let cli = Cli::parse();
    // A bad thread count, parallel threshold or split choice is bad input, said before anything
    // runs.
    if let Err(message) = flockway::core::threads_from_env() {
        return commands::fail(message);
    }
    if let Err(message) = flockway::core::parallel_min_from_env() {
        return commands::fail(message);
    }
    if let Err(message) = flockway::core::split_always_from_env() {
        return commands::fail(message);
    }
    match cli.command {
        Command::Run(args) => commands::run::run(args),
        Command::New { level, template } => commands::new::new_level(&level, template.into()),
        Command::Check { levels } => commands::check::check(&levels),
        Command::Import {
            net,
            output,
            routes,
        } => commands::import::import(&net, &output, &routes),
        Command::Compare {
            level,
            sumo,
            net,
            routes,
            seconds,
            seed,
            sumo_bin,
            json,
        } => {
            let scenario = match (sumo, net) {
                (Some(cfg), _) => commands::compare::Scenario::Config(cfg),
                (None, Some(net)) => commands::compare::Scenario::NetRoutes(net, routes),
                (None, None) => {
                    return commands::fail(
                        "give the SUMO scenario: --sumo SCENARIO.sumocfg, or --net NET.net.xml --routes A.rou.xml",
                    );
                }
            };
            commands::compare::compare_with_sumo(&commands::compare::CompareArgs {
                level,
                scenario,
                seconds,
                seed,
                sumo_bin,
                json,
            })
        }
        Command::Dyno { vehicle, json } => commands::dyno::dyno(vehicle.as_deref(), json),
        Command::Test {
            paths,
            seeds,
            seed_list,
            seconds,
            jobs,
            summaries,
            drivers,
        } => commands::test::test(
            &paths,
            seeds,
            seed_list,
            &flockway::run::batch::BatchSettings {
                seconds,
                drivers: drivers.into_iter().collect(),
            },
            jobs,
            summaries.as_deref(),
        ),
        Command::Plot {
            csv,
            output,
            format,
            summary,
            size,
        } => commands::analysis::plot(&csv, &output, format.into(), summary.as_deref(), size),
        Command::Report {
            csv,
            output,
            summary,
        } => commands::analysis::report(&csv, &output, summary.as_deref()),
        Command::Edit {
            level: Some(level),
            apply: Some(edits),
            output,
        } => commands::edit::apply(&level, &edits, output.as_deref()),
        Command::Edit { level, .. } => commands::window::window(level.as_deref(), false),
        Command::Play { level } => commands::window::window(Some(&level), true),
        Command::Render {
            level,
            output,
            at,
            size,
            camera,
            seed,
            region,
        } => commands::window::render(&level, &output, at, size, camera, seed, region),
    }
}

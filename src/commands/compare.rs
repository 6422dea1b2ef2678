//! `flockway compare`: a level and the SUMO scenario it was imported from, run side by side.

use super::fail;
use flockway::analysis::compare::{Comparison, ScenarioRun, SumoOutputs, compare};
use flockway::level::load_level;
use flockway::run::{RunOptions, Runner, level_name};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

/// The SUMO scenario to run: a configuration, or a network with demand files.
pub enum Scenario {
    /// `sumo -c FILE`.
    Config(PathBuf),
    /// `sumo -n NET -r ROUTES`.
    NetRoutes(PathBuf, Vec<PathBuf>),
}

/// What `flockway compare` was asked.
pub struct CompareArgs {
    pub level: PathBuf,
    pub scenario: Scenario,
    pub seconds: Option<f64>,
    pub seed: Option<u64>,
    pub sumo_bin: Option<PathBuf>,
    pub json: bool,
}

pub fn compare_with_sumo(args: &CompareArgs) -> ExitCode {
    let level = match load_level(&args.level) {
        Ok(l) => l,
        Err(e) => return fail(e),
    };
    let seconds = args.seconds.unwrap_or(level.duration_s);
    let seed = args.seed.unwrap_or(level.seed);
    let name = level_name(&level, &args.level);
    let sumo = match run_sumo(args, seconds, seed) {
        Ok(run) => run,
        Err(e) => return fail(e),
    };
    eprintln!("running {name} in Flockway for {seconds} s…");
    let options = RunOptions {
        seconds: Some(seconds),
        seed: Some(seed),
        assets: Some(flockway::run::find_assets_dir(Some(&args.level))),
        trips: true,
        ..RunOptions::default()
    };
    let mut runner = match Runner::new(level, &name, &options) {
        Ok(r) => r,
        Err(e) => return fail(e),
    };
    while runner.ticks_done() < runner.total_ticks() {
        if let Err(e) = runner.step(u64::MAX) {
            return fail(e);
        }
    }
    let Some(flockway) = runner.scenario_run() else {
        return fail("the run kept no trips");
    };
    let comparison = compare(&sumo, &flockway, seconds);
    if args.json {
        match serde_json::to_string_pretty(&comparison) {
            Ok(text) => outln!("{text}"),
            Err(e) => return fail(e),
        }
    } else {
        outln!(
            "{name}: SUMO and Flockway side by side over {seconds} s, seed {seed}\n\n{}",
            comparison.table()
        );
    }
    verdict(&comparison)
}

/// Exit status 0 when the scenario matches by every criterion, 1 when not.
fn verdict(c: &Comparison) -> ExitCode {
    if c.verdict.all {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

/// The `sumo` program: `--sumo-bin` (the program or its directory), `$SUMO_HOME/bin/sumo`, or
/// `sumo` on the PATH.
fn sumo_program(sumo_bin: Option<&Path>) -> PathBuf {
    let exe = format!("sumo{}", std::env::consts::EXE_SUFFIX);
    if let Some(p) = sumo_bin {
        return if p.is_dir() {
            p.join(&exe)
        } else {
            p.to_owned()
        };
    }
    if let Some(home) = std::env::var_os("SUMO_HOME") {
        let p = Path::new(&home).join("bin").join(&exe);
        if p.is_file() {
            return p;
        }
    }
    PathBuf::from(exe)
}

/// Runs the scenario in SUMO for `seconds` with `seed` and reads what it measured.
fn run_sumo(args: &CompareArgs, seconds: f64, seed: u64) -> Result<ScenarioRun, String> {
    let program = sumo_program(args.sumo_bin.as_deref());
    let dir = tempfile::tempdir().map_err(|e| format!("a scratch directory for SUMO: {e}"))?;
    let outputs = SumoOutputs::in_dir(dir.path());
    let mut cmd = Command::new(&program);
    match &args.scenario {
        Scenario::Config(cfg) => {
            check_exists(cfg)?;
            cmd.arg("-c").arg(cfg);
        }
        Scenario::NetRoutes(net, routes) => {
            check_exists(net)?;
            for r in routes {
                check_exists(r)?;
            }
            let list: Vec<String> = routes.iter().map(|r| r.display().to_string()).collect();
            cmd.arg("-n").arg(net).arg("-r").arg(list.join(","));
        }
    }
    cmd.args(["--no-step-log", "--end", &seconds.to_string()])
        .args(["--seed", &seed.to_string()])
        .args(outputs.args());
    eprintln!("running the scenario in SUMO ({})…", program.display());
    let out = cmd.output().map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            format!(
                "{}: SUMO's `sumo` was not found: install it (python3 -m pip install \
                 eclipse-sumo) and give --sumo-bin, set SUMO_HOME, or put it on the PATH",
                program.display()
            )
        } else {
            format!("{}: {e}", program.display())
        }
    })?;
    if !out.status.success() {
        return Err(format!(
            "SUMO failed ({}):\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim_end()
        ));
    }
    outputs.read().map_err(|e| e.to_string())
}

/// An error naming `path` when it is not there (before SUMO says it its own way).
fn check_exists(path: &Path) -> Result<(), String> {
    if path.exists() {
        Ok(())
    } else {
        Err(format!("{}: no such file", path.display()))
    }
}

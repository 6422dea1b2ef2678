//! What the integration tests that run shipped levels share.

use flockway::level::{Level, load_level};
use flockway::run::{RunOptions, Runner, find_assets_dir};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A shipped level, loaded, and its path.
pub fn shipped(name: &str) -> (Level, PathBuf) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("levels")
        .join(name);
    (load_level(&path).expect("a shipped level"), path)
}

/// Runs `level` (loaded from `path`) with `seed` for `seconds` (`None`: its whole duration);
/// the summary's metrics, and the telemetry CSV at `csv` if asked for.
pub fn run(
    level: Level,
    path: &Path,
    seed: u64,
    seconds: Option<f64>,
    csv: Option<PathBuf>,
) -> BTreeMap<String, f64> {
    let options = RunOptions {
        seconds,
        seed: Some(seed),
        csv,
        assets: Some(find_assets_dir(Some(path))),
        ..RunOptions::default()
    };
    let name = level.name.clone();
    Runner::new(level, &name, &options)
        .expect("the level builds")
        .finish()
        .expect("the run completes")
        .metrics
}

/// Where SUMO's tool `name` is: in `FLOCKWAY_SUMO_BIN`, else on `PATH`; `None` (and a note on
/// stderr) when it cannot be run.
#[allow(
    dead_code,
    reason = "only the tests that bring SUMO networks in use it"
)]
pub fn sumo_tool(name: &str) -> Option<PathBuf> {
    let path = match std::env::var_os("FLOCKWAY_SUMO_BIN") {
        Some(dir) => Path::new(&dir).join(name),
        None => PathBuf::from(name),
    };
    let works = Command::new(&path)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !works {
        // Past the test harness's capture, so the skip shows in a passing run.
        let _ = writeln!(
            std::io::stderr(),
            "skipped: SUMO's `{name}` cannot be run (install it with `pip install \
             eclipse-sumo==1.28.0` and put its bin directory on PATH, or set FLOCKWAY_SUMO_BIN)"
        );
    }
    works.then_some(path)
}

//! What the integration tests that run shipped levels share.

use flockway::level::{Level, load_level};
use flockway::run::{RunOptions, Runner, find_assets_dir};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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

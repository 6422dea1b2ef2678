//! Many runs at once, as `flockway test` makes them: levels × seeds on the machine's cores, each
//! run the same as `flockway run` would make it.

use crate::assets::find_assets_dir;
use crate::runner::{RunError, RunOptions, Runner};
use crate::summary::level_name;
use flockway_analysis::Summary;
use flockway_drivers::BuiltinModel;
use flockway_level::load_level;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The level files named by `paths`: files as given, and every `.ron` file of a directory, in
/// name order.
pub fn level_files(paths: &[PathBuf]) -> Result<Vec<PathBuf>, RunError> {
    let mut files = Vec::new();
    for p in paths {
        if p.is_dir() {
            files.extend(ron_files_in(p)?);
        } else {
            files.push(p.clone());
        }
    }
    Ok(files)
}

/// The `.ron` files of a directory, in name order.
pub fn ron_files_in(dir: &Path) -> Result<Vec<PathBuf>, RunError> {
    let entries = std::fs::read_dir(dir).map_err(|source| RunError::Output {
        path: dir.to_owned(),
        source,
    })?;
    let mut found: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|f| f.extension().is_some_and(|x| x == "ron"))
        .collect();
    found.sort();
    Ok(found)
}

/// Which seeds each level runs for.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Seeds {
    /// The level's own seed.
    #[default]
    Level,
    /// The level's seed and the `n − 1` after it.
    Count(u64),
    /// These seeds.
    List(Vec<u64>),
}

/// One run of a batch: a level file and a seed (`None`: the level's own).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BatchRun {
    /// The level file.
    pub path: PathBuf,
    /// The seed, or `None` for the level's.
    pub seed: Option<u64>,
}

/// The runs for `files` × `seeds`, in file order then seed order. Every file is loaded (and
/// validated) first, so a bad file is reported before anything runs.
pub fn plan(files: &[PathBuf], seeds: &Seeds) -> Result<Vec<BatchRun>, RunError> {
    let mut runs = Vec::new();
    for f in files {
        let level = load_level(f)?;
        let list: Vec<Option<u64>> = match seeds {
            Seeds::List(list) => list.iter().map(|s| Some(*s)).collect(),
            Seeds::Count(n) => (0..(*n).max(1))
                .map(|k| Some(level.seed.wrapping_add(k)))
                .collect(),
            Seeds::Level => vec![None],
        };
        runs.extend(list.into_iter().map(|seed| BatchRun {
            path: f.clone(),
            seed,
        }));
    }
    Ok(runs)
}

/// What every run of a batch shares.
#[derive(Debug, Clone, Default)]
pub struct BatchSettings {
    /// Simulated seconds per run instead of each level's duration.
    pub seconds: Option<f64>,
    /// Profiles driven by a built-in model instead of the level's ([`RunOptions::drivers`]).
    pub drivers: BTreeMap<String, BuiltinModel>,
}

/// One run of a batch, to the end: the same as `flockway run` on the file with that seed.
pub fn run_one(run: &BatchRun, settings: &BatchSettings) -> Result<Summary, RunError> {
    let level = load_level(&run.path)?;
    let name = level_name(&level, &run.path);
    let options = RunOptions {
        seconds: settings.seconds,
        seed: run.seed,
        assets: Some(find_assets_dir(Some(&run.path))),
        drivers: settings.drivers.clone(),
        ..RunOptions::default()
    };
    Runner::new(level, &name, &options)?.finish()
}

/// Runs every run on `jobs` threads (at least one, at most one per run), calling `done` as each
/// finishes (in whatever order they finish), and returns the outcomes in the order of `runs`.
pub fn run_all(
    runs: &[BatchRun],
    settings: &BatchSettings,
    jobs: usize,
    done: impl Fn(&BatchRun, &Result<Summary, RunError>) + Sync,
) -> Vec<Result<Summary, RunError>> {
    let workers = jobs.clamp(1, runs.len().max(1));
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<(usize, Result<Summary, RunError>)>> = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(run) = runs.get(i) else { break };
                    let outcome = run_one(run, settings);
                    done(run, &outcome);
                    if let Ok(mut all) = results.lock() {
                        all.push((i, outcome));
                    }
                }
            });
        }
    });
    let mut results = results.into_inner().unwrap_or_else(|e| e.into_inner());
    results.sort_by_key(|(i, _)| *i);
    results.into_iter().map(|(_, r)| r).collect()
}

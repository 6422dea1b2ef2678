//! `flockway test`: many levels and seeds in parallel, a line per run, the failed expectations,
//! and `N passed, N failed`.

use super::fail;
use flockway::run::batch::{self, Seeds};
use std::path::PathBuf;
use std::process::ExitCode;

/// Runs `paths` (files or directories of levels) for the chosen seeds on `jobs` threads; writes
/// the summaries, a JSON line per run, to `summaries` when given.
pub fn test(
    paths: &[PathBuf],
    seeds: Option<u64>,
    seed_list: Option<Vec<u64>>,
    seconds: Option<f64>,
    jobs: Option<usize>,
    summaries: Option<&std::path::Path>,
) -> ExitCode {
    let files = match batch::level_files(paths) {
        Ok(f) if f.is_empty() => return fail("no level files found"),
        Ok(f) => f,
        Err(e) => return fail(e),
    };
    let seeds = match (seed_list, seeds) {
        (Some(list), _) => Seeds::List(list),
        (None, Some(n)) => Seeds::Count(n),
        (None, None) => Seeds::Level,
    };
    let runs = match batch::plan(&files, &seeds) {
        Ok(r) => r,
        Err(e) => return fail(e),
    };
    let jobs = jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let results = batch::run_all(&runs, seconds, jobs, |run, outcome| match outcome {
        Ok(r) => println!(
            "{} {} seed {} ({:.0} s simulated in {:.1} s)",
            if r.passed { "PASS" } else { "FAIL" },
            run.path.display(),
            r.seed,
            r.sim_seconds,
            r.wall_seconds
        ),
        Err(e) => println!("ERROR {}: {e}", run.path.display()),
    });
    let (mut passed, mut failed, mut errors) = (0, 0, 0);
    for (run, r) in runs.iter().zip(&results) {
        match r {
            Ok(summary) if summary.passed => passed += 1,
            Ok(summary) => {
                failed += 1;
                for e in summary.expectations.iter().filter(|e| !e.passed) {
                    let value = e
                        .value
                        .map_or("not measured".to_owned(), |v| format!("{v:.3}"));
                    println!(
                        "  {} seed {}: {} (measured {value})",
                        run.path.display(),
                        summary.seed,
                        e.name
                    );
                }
            }
            Err(_) => errors += 1,
        }
    }
    if let Some(path) = summaries {
        let mut lines = String::new();
        for summary in results.iter().flatten() {
            match serde_json::to_string(summary) {
                Ok(json) => {
                    lines.push_str(&json);
                    lines.push('\n');
                }
                Err(e) => return fail(e),
            }
        }
        if let Err(e) = flockway::level::write_atomic(path, lines.as_bytes()) {
            return fail(e);
        }
    }
    println!("{passed} passed, {} failed", failed + errors);
    if errors > 0 {
        ExitCode::from(2)
    } else if failed > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

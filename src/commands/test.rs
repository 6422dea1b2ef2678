//! `flockway test`: many levels and seeds in parallel, a line per run, the failed expectations,
//! and `N passed, N failed`.

use super::fail;
use flockway::run::Summary;
use flockway::run::batch::{self, BatchSettings, Seeds};
use std::path::PathBuf;
use std::process::ExitCode;

/// Runs `paths` (files or directories of levels) for the chosen seeds on `jobs` threads; writes
/// the summaries, a JSON line per run, to `summaries` when given.
pub fn test(
    paths: &[PathBuf],
    seeds: Option<u64>,
    seed_list: Option<Vec<u64>>,
    settings: &BatchSettings,
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
    let results = batch::run_all(&runs, settings, jobs, |run, outcome| match outcome {
        Ok(r) => outln!(
            "{} {} seed {} ({:.0} s simulated in {:.1} s){}",
            if r.passed { "PASS" } else { "FAIL" },
            run.path.display(),
            r.seed,
            r.sim_seconds,
            r.wall_seconds,
            score_note(r)
        ),
        Err(e) => outln!("ERROR {}: {e}", run.path.display()),
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
                    outln!(
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
    print_scores(&runs, &results);
    outln!("{passed} passed, {} failed", failed + errors);
    if errors > 0 {
        ExitCode::from(2)
    } else if failed > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

/// ` score 7.12 (silver)` for a run of a level with a score; nothing otherwise.
fn score_note(r: &Summary) -> String {
    match (r.score, &r.medal) {
        (Some(s), Some(m)) => format!(" score {s:.2} ({m})"),
        (Some(s), None) => format!(" score {s:.2} (no medal)"),
        _ => String::new(),
    }
}

/// For each level with a score run on several seeds: the mean score over them.
fn print_scores(runs: &[batch::BatchRun], results: &[Result<Summary, flockway::run::RunError>]) {
    let mut by_level: Vec<(&std::path::Path, Vec<f64>)> = Vec::new();
    for (run, r) in runs.iter().zip(results) {
        let Some(score) = r.as_ref().ok().and_then(|s| s.score) else {
            continue;
        };
        match by_level.iter_mut().find(|(p, _)| *p == run.path.as_path()) {
            Some((_, scores)) => scores.push(score),
            None => by_level.push((&run.path, vec![score])),
        }
    }
    for (path, scores) in by_level.iter().filter(|(_, s)| s.len() > 1) {
        let mean = scores.iter().sum::<f64>() / scores.len() as f64;
        let (lo, hi) = scores
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), s| {
                (lo.min(*s), hi.max(*s))
            });
        outln!(
            "score {}: mean {mean:.2} over {} seeds ({lo:.2} to {hi:.2})",
            path.display(),
            scores.len()
        );
    }
}

//! Golden simulation outputs: every shipped level, run past its warm-up, must give exactly the
//! CSV (by its SHA-256) and the summary checked in under `tests/golden/sim/`. A change of
//! behaviour that stays inside a level's expectations still fails here.
//!
//! To accept a deliberate change, run once with `FLOCKWAY_BLESS=1`: it rewrites the files (and
//! the golden pictures of the other tests) and then fails, so it can never be left on.

use flockway::level::load_level;
use flockway::run::{RunOptions, Runner, find_assets_dir, level_name};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// Simulated seconds each golden run measures after the level's warm-up (`stats_from_s`), so
/// its statistics, flows and waves are in the record too.
const MEASURED_S: f64 = 20.0;

fn shipped_levels() -> Vec<PathBuf> {
    let mut levels: Vec<PathBuf> = std::fs::read_dir("levels")
        .expect("levels/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "ron"))
        .collect();
    levels.sort();
    levels
}

/// The SHA-256 of `bytes`, in hex.
fn sha256(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The golden record of one level: the run's length, its CSV digest and its summary without
/// the wall-clock figures.
fn record(level: &Path, dir: &Path) -> serde_json::Value {
    let csv = dir.join("run.csv");
    // The directory is shared: no earlier level's detectors file may pass for this one's.
    let _ = std::fs::remove_file(dir.join("run.detectors.csv"));
    let loaded = load_level(level).expect("the level loads");
    let name = level_name(&loaded, level);
    let seconds = loaded.telemetry.stats_from_s + MEASURED_S;
    let options = RunOptions {
        seconds: Some(seconds),
        csv: Some(csv.clone()),
        assets: Some(find_assets_dir(Some(level))),
        ..RunOptions::default()
    };
    let summary = Runner::new(loaded, &name, &options)
        .expect("the level runs")
        .finish()
        .expect("the run finishes");
    let bytes = std::fs::read(&csv).expect("the csv");
    let digest = sha256(&bytes);
    let mut summary = serde_json::to_value(&summary).expect("json");
    if let Some(obj) = summary.as_object_mut() {
        obj.remove("wall_seconds");
        obj.remove("realtime_factor");
    }
    let mut record = serde_json::json!({
        "seconds": seconds,
        "csv_bytes": bytes.len(),
        "csv_sha256": digest,
        "summary": summary,
    });
    // A level with detectors: their CSV too (the run ends mid-period, so its last rows are the
    // shorter period closed at the end).
    if let Ok(detectors) = std::fs::read(dir.join("run.detectors.csv")) {
        record["detectors_csv_sha256"] = serde_json::Value::String(sha256(&detectors));
    }
    record
}

#[test]
fn every_shipped_level_gives_its_golden_csv_and_summary() {
    let bless = std::env::var_os("FLOCKWAY_BLESS").is_some();
    let golden = Path::new("tests/golden/sim");
    let dir = tempfile::tempdir().expect("tempdir");
    let mut changed = Vec::new();
    for level in shipped_levels() {
        let stem = level
            .file_stem()
            .expect("a name")
            .to_string_lossy()
            .into_owned();
        let got = record(&level, dir.path());
        let path = golden.join(format!("{stem}.json"));
        if bless {
            std::fs::create_dir_all(golden).expect("golden dir");
            let text = serde_json::to_string_pretty(&got).expect("json") + "\n";
            std::fs::write(&path, text).expect("write the golden record");
            continue;
        }
        let want: serde_json::Value = std::fs::read_to_string(&path)
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok())
            .unwrap_or_else(|| {
                panic!(
                    "{}: no golden record; run with FLOCKWAY_BLESS=1 to write it",
                    path.display()
                )
            });
        if got != want {
            changed.push(format!(
                "{stem}: expected {}\n  got {}",
                serde_json::to_string(&want["csv_sha256"]).unwrap_or_default(),
                serde_json::to_string(&got["csv_sha256"]).unwrap_or_default()
            ));
            for key in got["summary"]
                .as_object()
                .into_iter()
                .flatten()
                .map(|(k, _)| k)
            {
                if want["summary"].get(key).is_none() {
                    changed.push(format!("  summary `{key}`: a new key"));
                } else if got["summary"][key] != want["summary"][key] {
                    changed.push(format!(
                        "  summary `{key}`: {} → {}",
                        want["summary"][key], got["summary"][key]
                    ));
                }
            }
        }
    }
    assert!(
        !bless,
        "FLOCKWAY_BLESS is set: the golden records were rewritten; look at the diff, commit \
         them, and run again without it"
    );
    assert!(
        changed.is_empty(),
        "the simulation's behaviour changed (rerun with FLOCKWAY_BLESS=1 if that is \
         deliberate):\n{}",
        changed.join("\n")
    );
}

//! Drivers deciding at an action step (`action_step_s` in a driver file or a profile's `set`,
//! `flockway run --action-step S` for every profile) instead of every tick: every shipped level,
//! with its own driver profiles deciding every 1/30 s (a challenge's own driver replaced by the
//! lane-keeping car), meets its expectations without a vehicle contact or a guardrail hit over
//! its whole duration, on a seed it was not tuned on; deciding every 0.1 s (SUMO's usual step)
//! it still has no contact and no guardrail hit (but where [`BOLD_IN_BENDS`] says). The controller,
//! the junction gates and the safety layer act every tick whatever the step, which is what
//! keeps a held decision safe.

use flockway::drivers::BuiltinModel;
use flockway::level::{DriverModel, load_level};
use flockway::run::{RunOptions, Runner, find_assets_dir};
use std::path::{Path, PathBuf};

/// Levels whose expectations let human-like drivers lose cars to a guardrail (bolder in
/// `hairpin.ron`'s 20 m hairpins than their grip, whatever their step): there the 0.1 s runs
/// are held to no contact only, the 1/30 s runs to the level's own expectations.
const BOLD_IN_BENDS: [&str; 1] = ["hairpin.ron"];

/// Every shipped level, relative to `levels/`.
fn shipped_levels() -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("levels");
    let mut out = Vec::new();
    for dir in ["", "challenges"] {
        for entry in std::fs::read_dir(root.join(dir)).expect("levels/") {
            let path = entry.expect("an entry").path();
            if path.extension().is_some_and(|e| e == "ron") {
                let rel = path.strip_prefix(&root).expect("under levels/");
                out.push(rel.to_string_lossy().into_owned());
            }
        }
    }
    out.sort();
    out
}

/// One run of `name` with every profile deciding every `step_s`: (whether its expectations
/// held, the ones that failed, vehicle contacts, guardrail hits, vehicles spawned).
fn run(name: &str, step_s: f32, seed: u64) -> (bool, Vec<String>, f64, f64, f64) {
    // One thread per run: the harness runs a level per core.
    flockway::core::init_task_pool(Some(1));
    let path: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("levels")
        .join(name);
    let level = load_level(&path).expect("a shipped level");
    // A challenge's own driver comes from outside: the lane-keeping car stands in for it.
    let drivers = level
        .driver_profiles
        .iter()
        .filter(|p| matches!(p.model, DriverModel::Custom(_)))
        .map(|p| (p.name.clone(), BuiltinModel::FlockLanes))
        .collect();
    let options = RunOptions {
        seed: Some(seed),
        assets: Some(find_assets_dir(Some(&path))),
        action_step_s: Some(step_s),
        drivers,
        ..RunOptions::default()
    };
    let label = level.name.clone();
    let summary = Runner::new(level, &label, &options)
        .expect("the level builds")
        .finish()
        .expect("the run completes");
    let failed = summary
        .expectations
        .iter()
        .filter(|e| !e.passed)
        .map(|e| format!("{} (measured {:?})", e.name, e.value))
        .collect();
    let get = |k: &str| summary.metrics.get(k).copied().unwrap_or(f64::NAN);
    (
        summary.passed,
        failed,
        get("collisions_vehicle"),
        get("collisions_guardrail"),
        get("vehicles_spawned"),
    )
}

/// Runs every shipped level whose name `keep` accepts (one half of them per test, so that the
/// harness keeps both cores busy), and names every one that failed.
fn every_level(keep: impl Fn(usize) -> bool) {
    let mut failures = Vec::new();
    for (i, name) in shipped_levels()
        .iter()
        .enumerate()
        .filter(|(i, _)| keep(*i))
    {
        let (passed, failed, contacts, guardrail, spawned) = run(name, 1.0 / 30.0, 7);
        if spawned <= 0.0 {
            failures.push(format!("{name} at 1/30 s: nothing ran"));
        }
        let bold = BOLD_IN_BENDS.contains(&name.as_str());
        if !passed || contacts != 0.0 || (guardrail != 0.0 && !bold) {
            failures.push(format!(
                "{name} at 1/30 s, seed 7: {contacts} contacts, {guardrail} guardrail hits, \
                 failed {failed:?}"
            ));
        }
        let (_, _, contacts, guardrail, _) = run(name, 0.1, 12 + i as u64);
        if contacts != 0.0 || (guardrail != 0.0 && !BOLD_IN_BENDS.contains(&name.as_str())) {
            failures.push(format!(
                "{name} at 0.1 s: {contacts} contacts, {guardrail} guardrail hits"
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_first_half_of_the_levels_drive_safely_and_meet_their_expectations_at_an_action_step() {
    every_level(|i| i % 2 == 0);
}

#[test]
fn the_second_half_of_the_levels_drive_safely_and_meet_their_expectations_at_an_action_step() {
    every_level(|i| i % 2 == 1);
}

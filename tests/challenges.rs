//! Challenges: levels with a score and medals, played by a built-in driver from the command
//! line. The built-in drivers' medals are the bar the shipped thresholds were set against
//! (seeds 1-5); these runs use other seeds.

use flockway::level::{Medal, load_level};
use std::path::Path;
use std::process::{Command, Output};

fn flockway(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_flockway"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the flockway binary runs")
}

/// `flockway run LEVEL --seed SEED --driver DRIVER --summary …`: the summary's score and medal
/// and what the command printed.
fn play(level: &str, seed: u64, driver: &str) -> (f64, Option<String>, String) {
    let dir = tempfile::tempdir().expect("tempdir");
    let summary = dir.path().join("summary.json");
    let seed = seed.to_string();
    let out = flockway(&[
        "run",
        level,
        "--seed",
        &seed,
        "--driver",
        driver,
        "--summary",
        summary.to_str().expect("utf-8"),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&summary).expect("summary")).expect("JSON");
    let score = json["score"]
        .as_f64()
        .expect("a challenge's summary has a score");
    let medal = json["medal"].as_str().map(str::to_owned);
    (score, medal, stdout)
}

#[test]
fn every_challenge_has_a_score_with_ordered_medals_and_a_custom_profile() {
    for name in ["damp_the_wave", "merge_smoothly"] {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("levels/challenges/{name}.ron"));
        let level = load_level(&path).unwrap_or_else(|e| panic!("{e}"));
        let score = level.score.as_ref().expect("a challenge has a score");
        assert!(score.thresholds_in_order(), "{name}");
        assert!(
            level
                .driver_profiles
                .iter()
                .any(|p| matches!(p.model, flockway::level::DriverModel::Custom(_))),
            "{name} has a profile for the player's controller"
        );
    }
}

#[test]
fn the_wave_damper_earns_silver_on_damp_the_wave_and_plain_cars_no_medal() {
    let level = "levels/challenges/damp_the_wave.ron";
    let (score, medal, stdout) = play(level, 11, "controller=WaveDamper");
    assert_eq!(
        medal.as_deref(),
        Some(Medal::Silver.name()),
        "score {score}"
    );
    // The report names the score, the medal and what the next one takes.
    assert!(
        stdout.contains(&format!(
            "score            {score:.2} km/h, silver (gold from 8)"
        )),
        "{stdout}"
    );
    let (plain, medal, _) = play(level, 11, "controller=FlockLanes");
    assert_eq!(medal, None, "score {plain}");
    assert!(
        score > plain + 5.0,
        "WaveDamper {score}, FlockLanes {plain}"
    );
}

#[test]
fn merge_smoothly_gives_default_flocking_mergers_silver_and_idm_ones_no_medal() {
    let level = "levels/challenges/merge_smoothly.ron";
    let (flock, medal, _) = play(level, 12, "merger=FlockLanes");
    assert_eq!(
        medal.as_deref(),
        Some(Medal::Silver.name()),
        "score {flock}"
    );
    let (idm, medal, _) = play(level, 12, "merger=Idm");
    assert_eq!(medal, None, "score {idm}");
    assert!(
        idm > flock,
        "lower is better: IDM {idm}, FlockLanes {flock}"
    );
}

#[test]
fn a_challenge_without_a_driver_says_how_to_give_it_one_and_test_prints_scores() {
    let out = flockway(&[
        "run",
        "levels/challenges/damp_the_wave.ron",
        "--seconds",
        "1",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("--driver controller=") && stderr.contains("Python"),
        "{stderr}"
    );
    let out = flockway(&[
        "run",
        "levels/challenges/damp_the_wave.ron",
        "--driver",
        "nobody=Idm",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("no driver profile or custom model `nobody`")
            && stderr.contains("controller, human"),
        "{stderr}"
    );
    let out = flockway(&[
        "test",
        "levels/challenges/damp_the_wave.ron",
        "--seed-list",
        "21,22",
        "--seconds",
        "160",
        "--driver",
        "controller=WaveDamper",
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    assert_eq!(stdout.matches(") score ").count(), 2, "{stdout}");
    assert!(
        stdout.contains("score levels/challenges/damp_the_wave.ron: mean "),
        "{stdout}"
    );
}

//! The surrogate safety measures on shipped levels: human-like drivers show their harshness as
//! conflicts (not contacts), and `flockway run --conflicts` streams one row per conflict with the
//! documented columns, agreeing with the summary's counts.

mod common;

use std::process::Command;

/// TTC conflicts per vehicle-kilometre of `profile`.
fn ttc_rate(m: &std::collections::BTreeMap<String, f64>, profile: &str) -> f64 {
    let get = |k: &str| {
        *m.get(&format!("{k}.{profile}"))
            .unwrap_or_else(|| panic!("{k}.{profile} is measured"))
    };
    get("conflicts_ttc") / get("veh_km")
}

#[test]
fn human_like_drivers_have_more_ttc_conflicts_per_km_than_autonomous_ones() {
    for seed in 1..=5u64 {
        let (level, path) = common::shipped("dense_road_mixed.ron");
        let m = common::run(level, &path, seed, None, None);
        let human = ttc_rate(&m, "human");
        let auto = ttc_rate(&m, "autonomous");
        eprintln!(
            "seed {seed}: TTC conflicts per veh-km human {human:.3}, autonomous {auto:.3}; \
             min TTC human {:?} autonomous {:?}",
            m.get("min_ttc_s.human"),
            m.get("min_ttc_s.autonomous")
        );
        assert!(m["veh_km.human"] > 1.0, "seed {seed}: the humans drove");
        assert!(
            human > auto,
            "seed {seed}: human {human:.3} vs autonomous {auto:.3} TTC conflicts per veh-km"
        );
        assert_eq!(m["collisions_vehicle"], 0.0, "seed {seed}");
    }
}

#[test]
fn the_conflicts_csv_has_its_columns_and_one_row_per_counted_conflict() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let csv = dir.path().join("conflicts.csv");
    let summary = dir.path().join("summary.json");
    let out = Command::new(env!("CARGO_BIN_EXE_flockway"))
        .args([
            "run",
            "levels/crossroads_priority.ron",
            "--seconds",
            "120",
            "--seed",
            "7",
        ])
        .arg("--conflicts")
        .arg(&csv)
        .arg("--summary")
        .arg(&summary)
        .arg("--driver")
        .arg("major=Human")
        .arg("--driver")
        .arg("minor=Human")
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the flockway binary runs");
    // Expectations written for the autonomous drivers may fail; the run itself must complete.
    assert!(
        matches!(out.status.code(), Some(0 | 1)),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut reader = csv::Reader::from_path(&csv).expect("the conflicts CSV exists");
    let header: Vec<String> = reader
        .headers()
        .expect("a header")
        .iter()
        .map(str::to_owned)
        .collect();
    assert_eq!(header, flockway::run::CONFLICT_COLUMNS);
    let rows: Vec<csv::StringRecord> = reader
        .records()
        .map(|r| r.expect("a well-formed row"))
        .collect();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&summary).expect("the summary"))
            .expect("JSON");
    let metric = |k: &str| json["metrics"][k].as_f64().unwrap_or(f64::NAN);
    let pet_rows = rows.iter().filter(|r| &r[1] == "pet").count();
    let episode_rows = rows.iter().filter(|r| &r[1] != "pet").count();
    assert_eq!(pet_rows as f64, metric("conflicts_pet"), "{rows:?}");
    assert!(
        episode_rows as f64 >= metric("conflicts_ttc"),
        "{episode_rows} episodes, {} by TTC",
        metric("conflicts_ttc")
    );
    assert!(!rows.is_empty(), "a two-minute junction run has conflicts");
    for r in &rows {
        let kind = &r[1];
        assert!(["ttc", "drac", "pet"].contains(&kind), "{r:?}");
        let time: f64 = r[0].parse().expect("time_s");
        assert!((0.0..=120.0).contains(&time), "{r:?}");
        assert!(
            !r[4].is_empty() && !r[5].is_empty() && !r[6].is_empty(),
            "{r:?}"
        );
        match kind {
            "pet" => {
                let pet: f64 = r[9].parse().expect("pet_s");
                assert!((0.0..1.0).contains(&pet), "{r:?}");
                assert_eq!(&r[7], "tee", "{r:?}");
            }
            "ttc" => {
                let ttc: f64 = r[8].parse().expect("min_ttc_s");
                assert!((0.0..1.5).contains(&ttc), "{r:?}");
            }
            _ => {
                let drac: f64 = r[10].parse().expect("max_drac_mps2");
                assert!(drac > 3.0, "{r:?}");
            }
        }
        let _: f64 = r[11].parse().expect("x_m");
        let _: f64 = r[12].parse().expect("y_m");
    }
}

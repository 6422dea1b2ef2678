//! Shipped levels: load → save → load is lossless, and saving is atomic.

use flockway::level::{level_to_string, load_level, parse_level, save_level};
use std::path::Path;

#[test]
fn load_save_load_is_identical_for_every_shipped_level() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut count = 0;
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("levels");
    let dirs = [root.clone(), root.join("challenges")];
    for entry in dirs
        .iter()
        .flat_map(|d| std::fs::read_dir(d).expect("levels/ and levels/challenges/"))
    {
        let path = entry.expect("entry").path();
        if path.extension().is_none_or(|e| e != "ron") {
            continue;
        }
        count += 1;
        let first = load_level(&path).unwrap_or_else(|e| panic!("{e}"));
        let saved = dir.path().join(path.file_name().expect("file name"));
        save_level(&first, &saved).expect("save");
        let second = load_level(&saved).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(first, second, "{} changed through save", path.display());
        // The saved text is a fixed point: saving again writes the same bytes.
        assert_eq!(
            std::fs::read_to_string(&saved).expect("read"),
            level_to_string(&second).expect("text")
        );
    }
    assert!(count >= 5);
}

#[test]
fn a_saved_level_keeps_every_optional_part() {
    // A level using every part of the schema, to prove nothing is dropped on save.
    let text = r#"(
        version: 1,
        name: "everything",
        description: "uses every field",
        seed: 18446744073709551615,
        duration_s: 12.5,
        roads: [
            (name: "a", lanes: 2, lane_width_m: 3.5, speed_limit_kmh: 80.0, next: "b",
             points: [(pos: (0.0, 0.0, 1.0), width_m: 8.0, bank_deg: 2.5, guardrail_left: false, tangent: (1.0, 0.1, 0.0)),
                      (pos: (100.0, 0.0, 1.0), guardrail_right: false)]),
            (name: "b", closed: false, lanes: 2, speed_limit_kmh: 80.0, points: [(pos: (100.0, 0.0, 1.0)), (pos: (200.0, 50.0, 0.0))]),
        ],
        vehicle_types: [(name: "sedan", path: "vehicles/sedan.ron")],
        driver_profiles: [
            (name: "auto", model: FlockLanes, vehicle: "sedan", params: "drivers/flock_lanes.ron", set: {"target_speed_kmh": 70.0}),
            (name: "mine", model: Custom("pid_follower"), vehicle: "sedan"),
        ],
        spawners: [(name: "in", road: "a", lane: 1, s_m: 5.0, interval_s: (min: 0.5, max: 1.5),
                    profiles: [(profile: "auto", weight: 3.0), (profile: "mine", weight: 1.0)], speed_kmh: 50.0, active: false, max_vehicles: 10)],
        destroyers: [(name: "out", place: OnRoad(road: "b", s_m: 100.0)), (name: "box", place: Volume(min: (0.0, 0.0, 0.0), max: (1.0, 1.0, 1.0)))],
        triggers: [(name: "fast", road: "b", from_m: 10.0, to_m: 20.0, lanes: [0], effect: SpeedLimit(kmh: 100.0)),
                   (name: "wet", road: "a", from_m: 10.0, to_m: 20.0, effect: Friction(scale: 0.6))],
        detectors: [(name: "loop", road: "a", s_m: 50.0, lanes: [1], period_s: 30.0), (name: "all", road: "b", s_m: 5.0)],
        vehicles: [(road: "a", lane: 0, count: 3, profile: "auto", from_m: 10.0, to_m: 60.0, speed_kmh: 30.0, jitter_m: 1.0)],
        telemetry: (period_s: 0.25, stats_from_s: 5.0),
        expect: ["collisions == 0", "flow_veh_per_h.out >= 100", "road_length_m.a in 99..101"],
    )"#;
    let level = parse_level(text, Path::new("everything.ron")).unwrap_or_else(|e| panic!("{e}"));
    let saved = level_to_string(&level).expect("text");
    let again =
        parse_level(&saved, Path::new("saved.ron")).unwrap_or_else(|e| panic!("{e}\n{saved}"));
    assert_eq!(level, again, "{saved}");
}

#[test]
fn saving_replaces_the_file_atomically() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("level.ron");
    std::fs::write(&path, "old contents").expect("write");
    let level = load_level(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/levels/sugiyama_ring.ron"
    )))
    .expect("load");
    save_level(&level, &path).expect("save");
    assert_eq!(load_level(&path).expect("reload"), level);
    // No temporary file is left behind.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .expect("dir")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("level.ron")]);
    // Saving into a missing directory fails cleanly and leaves nothing.
    assert!(save_level(&level, &dir.path().join("missing/level.ron")).is_err());
}

#[test]
fn errors_in_a_saved_level_point_at_the_right_line() {
    // Saved levels start with an `#![enable(implicit_some)]` attribute: positions must still be right.
    let level = load_level(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/levels/dense_road.ron"
    )))
    .expect("load");
    let text = level_to_string(&level).expect("text");
    assert!(text.starts_with("#![enable(implicit_some)]"), "{text}");
    let broken = text.replace("lanes: 4", "lanes: 0");
    let line = broken
        .lines()
        .position(|l| l.contains("lanes: 0"))
        .expect("edited line")
        + 1;
    let err = parse_level(&broken, Path::new("saved.ron")).expect_err("0 lanes");
    let d = &err.diagnostics()[0];
    assert_eq!(d.pos.line, line, "{err}");
    assert!(d.message.contains("0 lanes"), "{err}");
}

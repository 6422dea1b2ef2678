//! The runner's unit tests: assets found and loaded, a level run and measured, options.

use crate::*;
use flockway_drivers::DriverSpec;
use flockway_level::{DriverModel, Expectation, Level};
use flockway_road::RoadSpec;
use glam::DVec3;
use std::collections::BTreeMap;
use std::path::Path;

#[test]
fn a_road_level_runs_and_measures_its_roads() {
    let mut level = Level::new(1, 2.0);
    level
        .roads
        .push(RoadSpec::ring("ring", 1, 30.0, DVec3::ZERO, 36.606, 12));
    level
        .expect
        .push(Expectation::parse("road_length_m.ring in 229.5..230.5").expect("parses"));
    level
        .expect
        .push(Expectation::parse("mean_speed_kmh > 0").expect("parses"));
    let report = Runner::new(level, "t", &RunOptions::default())
        .expect("runner")
        .finish()
        .expect("runs");
    assert_eq!(report.ticks, 240);
    assert_eq!(report.sim_seconds, 2.0);
    assert!(report.expectations[0].passed);
    // A metric this run cannot measure fails rather than passing silently.
    assert_eq!(
        report.expectations[1],
        ExpectationResult {
            name: "mean_speed_kmh > 0".into(),
            passed: false,
            value: None
        }
    );
    assert!(!report.passed);
    let json = serde_json::to_value(&report).expect("json");
    for key in Summary::keys() {
        assert!(json.get(&key).is_some(), "missing {key}");
    }
}

#[test]
fn vehicle_types_load_from_assets_and_bad_ones_are_named() {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::create_dir_all(dir.path().join("vehicles")).expect("mkdir");
    std::fs::write(
        dir.path().join("vehicles/light.ron"),
        "(name: \"light\", chassis: (mass_kg: 1000.0))",
    )
    .expect("write");
    std::fs::write(
        dir.path().join("vehicles/bad.ron"),
        "(\n  chassis: (mass_kg: true),\n)",
    )
    .expect("write");
    let mut level = Level::new(1, 10.0);
    level.vehicle_types = vec![flockway_level::VehicleTypeSpec {
        name: "light".into(),
        path: "vehicles/light.ron".into(),
    }];
    let types = load_vehicle_types(&level, "t", dir.path()).expect("loads");
    assert_eq!(types["light"].params.chassis.mass_kg, 1000.0);
    let options = RunOptions {
        assets: Some(dir.path().to_owned()),
        ..RunOptions::default()
    };
    let runner = Runner::new(level.clone(), "t", &options).expect("runner");
    assert!(
        runner
            .sim()
            .world()
            .resource::<VehicleTypes>()
            .0
            .contains_key("light")
    );

    level.vehicle_types[0].path = "vehicles/bad.ron".into();
    let err = load_vehicle_types(&level, "t", dir.path()).expect_err("bad file");
    let text = err.to_string();
    assert!(
        text.contains("vehicle type `light`") && text.contains("bad.ron:2:"),
        "{text}"
    );
    level.vehicle_types[0].path = "vehicles/missing.ron".into();
    let err = load_vehicle_types(&level, "t", dir.path()).expect_err("missing file");
    assert!(err.to_string().contains("missing.ron"), "{err}");
}

#[test]
fn driver_profiles_build_from_assets_with_overrides_and_name_bad_ones() {
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets");
    let mut level = Level::new(1, 10.0);
    level.vehicle_types = vec![flockway_level::VehicleTypeSpec {
        name: "sedan".into(),
        path: "vehicles/sedan.ron".into(),
    }];
    let mut set = BTreeMap::new();
    set.insert("target_speed_kmh".to_owned(), 70.0);
    level.driver_profiles = vec![flockway_level::DriverProfileSpec {
        name: "auto".into(),
        model: DriverModel::FlockLanes,
        vehicle: "sedan".into(),
        params: Some("drivers/flock_lanes.ron".into()),
        set,
    }];
    let profiles = load_driver_profiles(&level, "t", &assets).expect("valid");
    let DriverSpec::FlockLanes(p) = &profiles["auto"] else {
        panic!("wrong model")
    };
    assert_eq!(p.target_speed_kmh, Some(70.0));
    level.driver_profiles[0]
        .set
        .insert("speed_wieght".into(), 1.0);
    let err = load_driver_profiles(&level, "t", &assets).expect_err("typo");
    assert!(
        err.to_string()
            .contains("driver profile `auto`: `speed_wieght`"),
        "{err}"
    );
    level.driver_profiles[0].params = Some("drivers/none.ron".into());
    let err = load_driver_profiles(&level, "t", &assets).expect_err("missing file");
    assert!(err.to_string().contains("none.ron"), "{err}");
}

#[test]
fn the_shipped_assets_are_found_from_a_level_path() {
    let level = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../levels/dense_road.ron");
    let assets = find_assets_dir(Some(&level));
    assert!(
        assets.join("vehicles/sedan.ron").is_file(),
        "{}",
        assets.display()
    );
}

#[test]
fn options_override_seed_and_duration() {
    let level = Level::new(1, 10.0);
    let options = RunOptions {
        seconds: Some(0.5),
        seed: Some(99),
        ..RunOptions::default()
    };
    let report = Runner::new(level.clone(), "t", &options)
        .expect("runner")
        .finish()
        .expect("runs");
    assert_eq!((report.ticks, report.seed), (60, 99));
    let bad = RunOptions {
        seconds: Some(f64::NAN),
        ..Default::default()
    };
    assert!(matches!(
        Runner::new(level, "t", &bad),
        Err(RunError::Argument(_))
    ));
}

//! Drivers read the road ahead: whatever the limit says, autonomous cars take bends within their
//! comfort and slippery stretches within their grip, and stay on the road.

mod common;

use common::{run, shipped};
use flockway::level::{TriggerEffectSpec, TriggerSpec};
use flockway::road::{RoadGeometry, lane_offset};

#[test]
fn the_dense_road_with_a_250_kmh_limit_keeps_every_autonomous_car_on_the_road() {
    let (mut level, path) = shipped("dense_road.ron");
    level.roads[0].speed_limit_kmh = 250.0;
    // Before drivers read the road ahead, about half the cars hit the guardrail in the bend.
    let m = run(level, &path, 20_261, Some(90.0), None);
    assert_eq!(m["collisions_guardrail.autonomous"], 0.0, "{m:#?}");
    assert_eq!(m["collisions_vehicle"], 0.0, "{m:#?}");
    // They do use the limit where the road allows: faster than the 60 km/h level on average.
    assert!(m["mean_speed_kmh"] > 66.0, "{m:#?}");
}

#[test]
fn a_wet_switchback_gets_no_autonomous_car_into_the_guardrail() {
    let (mut level, path) = shipped("hairpin.ron");
    // Wet all along (friction 0.35), in every lane.
    level.triggers.push(TriggerSpec {
        name: "rain".to_owned(),
        road: "pass".to_owned(),
        from_m: 0.0,
        to_m: 1_000.0,
        lanes: None,
        effect: TriggerEffectSpec::Friction { scale: 0.35 },
    });
    let m = run(level, &path, 90_210, Some(200.0), None);
    assert_eq!(m["collisions_guardrail.autonomous"], 0.0, "{m:#?}");
    assert!(m["vehicles_destroyed"] > 5.0, "traffic got through: {m:#?}");
}

#[test]
fn autonomous_cars_take_each_hairpin_within_their_comfortable_lateral_acceleration() {
    let (level, path) = shipped("hairpin.ron");
    let road = RoadGeometry::new(&level.roads[0]).expect("the road builds");
    let dir = tempfile::tempdir().expect("tempdir");
    let csv_path = dir.path().join("hairpin.csv");
    let m = run(level, &path, 4_242, Some(180.0), Some(csv_path.clone()));
    assert_eq!(m["collisions_guardrail.autonomous"], 0.0, "{m:#?}");
    let mut reader = csv::Reader::from_path(&csv_path).expect("the CSV");
    let headers = reader.headers().expect("headers").clone();
    let col = |name: &str| headers.iter().position(|h| h == name).expect(name);
    let (driver, lane, s, speed) = (col("driver"), col("lane"), col("s_m"), col("speed_kmh"));
    let (mut worst, mut samples) = (0.0f64, 0);
    for row in reader.records() {
        let row = row.expect("a row");
        if &row[driver] != "autonomous" {
            continue;
        }
        let s_m: f64 = row[s].parse().expect("s_m");
        // The curvature under the car: the lane's, averaged over its length (a car does not
        // follow the brief peaks a spline has where a hairpin meets a straight).
        let k = (-3..=3)
            .map(|i| road.curvature_at(s_m + f64::from(i)))
            .sum::<f64>()
            / 7.0;
        // Only in the hairpins (radius under 25 m), where the limit is far above what they allow.
        if k.abs() < 1.0 / 25.0 {
            continue;
        }
        let lane: u32 = row[lane].parse().expect("lane");
        let width = road.frame_at(s_m).width_m;
        let radius = (1.0 / k - lane_offset(width, road.lanes(), lane)).abs();
        let v = row[speed].parse::<f64>().expect("speed") / 3.6;
        worst = worst.max(v * v / radius);
        samples += 1;
    }
    assert!(samples > 200, "{samples} samples in the hairpins");
    // Their comfort limit is 2 m/s²; the speed control follows its target within 5 %.
    assert!(worst <= 2.1, "{worst:.2} m/s² in a hairpin");
}

//! Road networks, checked on exported data: the on-ramp merge runs free at low demand and breaks
//! down into a queue at the top, and at a split every vehicle takes the branch its route says.

mod common;

use common::{run, shipped};
use std::path::Path;

/// Mean speed, km/h, of the telemetry rows that `keep(time_s, road, s_m)` selects, and how many.
fn mean_speed_kmh(csv_path: &Path, keep: impl Fn(f64, &str, f64) -> bool) -> (f64, usize) {
    let mut reader = csv::Reader::from_path(csv_path).expect("the CSV");
    let headers = reader.headers().expect("headers").clone();
    let col = |name: &str| headers.iter().position(|h| h == name).expect(name);
    let (time, road, s, speed) = (col("time_s"), col("road"), col("s_m"), col("speed_kmh"));
    let (mut sum, mut n) = (0.0, 0);
    for row in reader.records() {
        let row = row.expect("a row");
        let t: f64 = row[time].parse().expect("time_s");
        let s_m: f64 = row[s].parse().expect("s_m");
        if keep(t, &row[road], s_m) {
            sum += row[speed].parse::<f64>().expect("speed_kmh");
            n += 1;
        }
    }
    (sum / n.max(1) as f64, n)
}

#[test]
fn the_on_ramp_flows_near_the_limit_at_low_demand_and_queues_upstream_at_the_top() {
    let (level, path) = shipped("on_ramp.ron");
    let dir = tempfile::tempdir().expect("tempdir");
    let csv_path = dir.path().join("on_ramp.csv");
    let m = run(level, &path, 31_337, None, Some(csv_path.clone()));
    assert_eq!(m["collisions"], 0.0, "{m:#?}");
    assert_eq!(m["missed_exits"], 0.0, "{m:#?}");
    // Low demand (1 800 + 360 veh/h, before the first step at 150 s): through the acceleration
    // lane and the merge at close to the 100 km/h limit.
    let (merge, n) = mean_speed_kmh(&csv_path, |t, road, _| {
        (60.0..150.0).contains(&t) && road == "merge"
    });
    assert!(n > 500, "{n} samples on the merge");
    assert!(
        merge > 85.0,
        "{merge:.1} km/h through the merge at low demand"
    );
    // Top demand (3 600 + 900 veh/h from 420 s): more arrives than the merge lets through, and
    // the last 500 m before it fill with a slow queue.
    let (queue, n) = mean_speed_kmh(&csv_path, |t, road, s| {
        t >= 540.0 && road == "upstream" && s > 700.0
    });
    assert!(n > 500, "{n} samples in the queue");
    assert!(
        queue < 50.0,
        "{queue:.1} km/h before the merge at the top demand"
    );
    // The flow downstream of the bottleneck is measured, well below the demand.
    let flow = m["flow_veh_per_h.end"];
    assert!(
        (2_000.0..3_300.0).contains(&flow),
        "{flow} veh/h got through"
    );
}

#[test]
fn at_the_split_each_branch_gets_its_routes_share_and_no_autonomous_car_misses_its_exit() {
    let (level, path) = shipped("exit_split.ron");
    let stats_from = level.telemetry.stats_from_s;
    let counted_s = level.duration_s - stats_from;
    let m = run(level, &path, 27_182, None, None);
    assert_eq!(m["missed_exits.autonomous"], 0.0, "{m:#?}");
    assert_eq!(m["collisions_guardrail"], 0.0, "{m:#?}");
    // Vehicles through each branch while counted; the share bound for the south branch is a
    // binomial draw with p = 0.3 (the route weights 0.3 / 0.7).
    let south = m["flow_veh_per_h.south"] * counted_s / 3_600.0;
    let north = m["flow_veh_per_h.north"] * counted_s / 3_600.0;
    let n = south + north;
    assert!(n > 250.0, "{n} vehicles counted");
    let share = south / n;
    let sigma = (0.3 * 0.7 / n).sqrt();
    assert!(
        (share - 0.3).abs() <= 3.0 * sigma,
        "south share {share:.3} of {n} vehicles, 0.3 ± {:.3}",
        3.0 * sigma
    );
}

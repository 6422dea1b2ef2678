//! Junctions, checked on exported data: a car arriving at a red light stops before the line and
//! drives through the junction's path onto the road beyond when the light turns green.

#[allow(dead_code, reason = "shared with the tests that run shipped levels")]
mod common;

use common::run;
use std::path::Path;

/// A 200 m road `a` at 50 km/h ending 16 m before `b` starts; junction `j` between them with a
/// signal red for the first 40 s of each 70 s cycle; eight cars from a spawner on `a`, 3 s
/// apart, that queue at the red light and leave on green.
const SIGNAL: &str = r#"(
    version: 1,
    name: "signal",
    seed: 1,
    duration_s: 70.0,
    roads: [
        (name: "a", speed_limit_kmh: 50.0, points: [(pos: (0.0, 0.0, 0.0), guardrail_left: false, guardrail_right: false), (pos: (200.0, 0.0, 0.0))]),
        (name: "b", speed_limit_kmh: 50.0, points: [(pos: (216.0, 0.0, 0.0), guardrail_left: false, guardrail_right: false), (pos: (400.0, 0.0, 0.0))]),
    ],
    junctions: [
        (name: "j", control: Signal, connections: [(from: "a", to: "b")],
            signal: (phases: [(duration_s: 40.0, state: "r"), (duration_s: 30.0, state: "G")])),
    ],
    vehicle_types: [(name: "sedan", path: "vehicles/sedan.ron")],
    driver_profiles: [(name: "autonomous", model: FlockLanes, vehicle: "sedan", params: "drivers/flock_lanes.ron")],
    spawners: [(name: "s", road: "a", s_m: 5.0, interval_s: (min: 3.0, max: 3.0), profiles: [(profile: "autonomous", weight: 1.0)],
        speed_kmh: 40.0, schedule: [(from_s: 23.0, interval_s: (min: 1000.0, max: 1000.0))])],
    destroyers: [(name: "b", place: OnRoad(road: "b", s_m: 170.0))],
    telemetry: (period_s: 0.1),
    expect: ["junction_flow_veh_per_h.j > 0", "max_queue_m.j > 40", "discharge_headway_s.j in 1..3"],
)"#;

#[test]
fn a_car_stops_at_a_red_light_and_goes_through_the_junction_on_green() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("levels/signal.ron");
    let level = flockway_level::parse_level(SIGNAL, &path).expect("a valid level");
    let dir = tempfile::tempdir().expect("tempdir");
    let csv_path = dir.path().join("signal.csv");
    let m = run(level, &path, 1, None, Some(csv_path.clone()));
    assert_eq!(m["collisions"], 0.0, "{m:#?}");
    // All eight through in the 70 s; the queue of eight cars reached back about 50 m; the
    // fifth to eighth left the line at a steady headway; each waited for the green.
    assert!(
        (m["junction_flow_veh_per_h.j"] - 8.0 * 3600.0 / 70.0).abs() < 1e-6,
        "{m:#?}"
    );
    assert!((40.0..70.0).contains(&m["max_queue_m.j"]), "{m:#?}");
    assert!((1.0..3.0).contains(&m["discharge_headway_s.j"]), "{m:#?}");
    assert!(m["junction_delay_s.j"] > 10.0, "{m:#?}");
    let mut reader = csv::Reader::from_path(&csv_path).expect("the CSV");
    let headers = reader.headers().expect("headers").clone();
    let col = |name: &str| headers.iter().position(|h| h == name).expect(name);
    let (time, id, road, s, speed) = (
        col("time_s"),
        col("vehicle_id"),
        col("road"),
        col("s_m"),
        col("speed_kmh"),
    );
    let mut cars = std::collections::BTreeSet::new();
    let (mut stopped_at_line, mut through, mut on_red) = (0, 0, 0);
    for row in reader.records() {
        let row = row.expect("a row");
        let t: f64 = row[time].parse().expect("time_s");
        let s_m: f64 = row[s].parse().expect("s_m");
        let v: f64 = row[speed].parse().expect("speed_kmh");
        cars.insert(row[id].to_owned());
        match &row[road] {
            // Front bumper (half the 4.6 m body ahead of the centre) short of the line.
            "a" if t < 40.0 => {
                assert!(
                    s_m + 2.3 <= 200.0,
                    "past the line on red at {t} s: s = {s_m}"
                );
                if v < 0.5 && s_m > 180.0 {
                    stopped_at_line += 1;
                }
            }
            "j#0" if t < 40.0 => on_red += 1,
            "b" => through += 1,
            _ => {}
        }
    }
    assert_eq!(cars.len(), 8, "eight cars: {cars:?}");
    // Beside the CSV, the signal's states from the start and each change.
    let signals = std::fs::read_to_string(dir.path().join("signal.signals.csv")).expect("signals");
    assert_eq!(
        signals,
        "time_s,junction,connection,from,from_lane,to,to_lane,state\n\
         0.000,j,0,a,0,b,0,r\n\
         40.000,j,0,a,0,b,0,G\n"
    );
    assert_eq!(on_red, 0, "rows inside the junction on red");
    assert!(stopped_at_line > 0, "the first car waits at the line");
    assert!(through > 0, "the cars drive on after green");
}

/// A major road `m in` → `m out` (west to east, 50 km/h) with a car every 7 s until 50 s, and a
/// minor road
/// `s in` from the south whose cars turn right onto `m out`, giving way to the major road; the
/// minor drivers' `critical_gap_s` is `GAP` and `follow_up_s` `FOLLOW`; two minor cars, 2 s
/// apart, from 25 s.
const PRIORITY: &str = r#"(
    version: 1,
    name: "priority",
    seed: 1,
    duration_s: 100.0,
    roads: [
        (name: "m in", speed_limit_kmh: 50.0, points: [(pos: (-300.0, -1.75, 0.0), guardrail_left: false, guardrail_right: false), (pos: (-8.0, -1.75, 0.0))]),
        (name: "m out", speed_limit_kmh: 50.0, points: [(pos: (8.0, -1.75, 0.0), guardrail_left: false, guardrail_right: false), (pos: (300.0, -1.75, 0.0))]),
        (name: "s in", speed_limit_kmh: 50.0, points: [(pos: (1.75, -200.0, 0.0), guardrail_left: false, guardrail_right: false), (pos: (1.75, -8.0, 0.0))]),
    ],
    junctions: [
        (name: "t", control: Priority(major: ["m in"]),
            connections: [(from: "m in", to: "m out"), (from: "s in", to: "m out")]),
    ],
    vehicle_types: [(name: "sedan", path: "vehicles/sedan.ron")],
    driver_profiles: [
        (name: "major", model: FlockLanes, vehicle: "sedan", params: "drivers/flock_lanes.ron", set: {"time_gap_s": 1.5}),
        (name: "minor", model: FlockLanes, vehicle: "sedan", params: "drivers/flock_lanes.ron", set: {"time_gap_s": 1.5, "critical_gap_s": GAP, "follow_up_s": FOLLOW}),
    ],
    spawners: [
        (name: "major", road: "m in", s_m: 5.0, interval_s: (min: 7.0, max: 7.0), profiles: [(profile: "major", weight: 1.0)], speed_kmh: 50.0,
            schedule: [(from_s: 50.0, interval_s: (min: 1000.0, max: 1000.0))]),
        (name: "minor", road: "s in", s_m: 5.0, interval_s: (min: 25.0, max: 25.0), profiles: [(profile: "minor", weight: 1.0)], speed_kmh: 40.0,
            schedule: [(from_s: 25.0, interval_s: (min: 2.0, max: 2.0)), (from_s: 26.5, interval_s: (min: 1000.0, max: 1000.0))]),
    ],
    destroyers: [(name: "out", place: OnRoad(road: "m out", s_m: 280.0))],
    telemetry: (period_s: 0.1),
)"#;

/// When the first minor car entered the junction, s, the shortest time, s, any major car then
/// needed to reach the line at its speed, and when the second minor car entered; `None` if the
/// first never did.
fn minor_entry(gap_s: f64, follow_up_s: f64) -> Option<(f64, f64, Option<f64>)> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("levels/priority.ron");
    let text = PRIORITY
        .replace("GAP", &format!("{gap_s:.1}"))
        .replace("FOLLOW", &format!("{follow_up_s:.1}"));
    let level = flockway_level::parse_level(&text, &path).expect("a valid level");
    let dir = tempfile::tempdir().expect("tempdir");
    let csv_path = dir.path().join("priority.csv");
    let m = run(level, &path, 1, None, Some(csv_path.clone()));
    assert_eq!(m["collisions"], 0.0, "{m:#?}");
    let mut reader = csv::Reader::from_path(&csv_path).expect("the CSV");
    let headers = reader.headers().expect("headers").clone();
    let col = |name: &str| headers.iter().position(|h| h == name).expect(name);
    let (time, id, driver, road, s, speed) = (
        col("time_s"),
        col("vehicle_id"),
        col("driver"),
        col("road"),
        col("s_m"),
        col("speed_kmh"),
    );
    let mut rows: Vec<(f64, String, String, f64, f64)> = Vec::new();
    let mut entries: Vec<(String, f64)> = Vec::new();
    for row in reader.records() {
        let row = row.expect("a row");
        if &row[driver] == "minor"
            && row[road].starts_with("t#")
            && !entries.iter().any(|(v, _)| v == &row[id])
        {
            entries.push((row[id].to_owned(), row[time].parse().expect("time")));
        }
        rows.push((
            row[time].parse().expect("time"),
            row[driver].to_owned(),
            row[road].to_owned(),
            row[s].parse().expect("s"),
            row[speed].parse::<f64>().expect("speed") / 3.6,
        ));
    }
    let entry = entries.first()?.1;
    // The major cars at the sample before: time to the line (292 m along `m in`).
    let before = entry - 0.1;
    let nearest = rows
        .iter()
        .filter(|r| (r.0 - before).abs() < 1e-6 && r.1 == "major" && r.2 == "m in")
        .map(|r| (292.0 - r.3) / r.4.max(0.1))
        .fold(f64::INFINITY, f64::min);
    Some((entry, nearest, entries.get(1).map(|e| e.1)))
}

#[test]
fn a_yielding_car_waits_for_a_gap_of_at_least_its_critical_gap() {
    // The minor car (from 25 s) reaches the line after about 40 s, in a stream of major cars one every 7 s,
    // each in the junction for about a second and a half: gaps of about 5.5 s. It takes one
    // that leaves the nearest major car at least its critical gap from the conflict (a little
    // less from the line, the conflict being a few metres beyond it; samples every 0.1 s).
    let (entry, gap, _) = minor_entry(4.5, 2.5).expect("the minor car goes");
    assert!((40.0..68.0).contains(&entry), "entered at {entry} s");
    assert!(gap > 4.0, "the nearest major car was {gap} s from the line");
    // A driver asking 7.5 s finds no such gap in the stream: it goes once the stream has
    // passed (the last major car, from 49 s, reaches the junction at about 70 s).
    let (cautious, gap, _) = minor_entry(7.5, 2.5).expect("the cautious car goes");
    assert!(
        cautious > 68.0,
        "entered at {cautious} s, {gap} s before a major car"
    );
    assert!(gap > 7.0, "the nearest major car was {gap} s from the line");
}

#[test]
fn a_yielding_car_follows_the_one_before_it_no_sooner_than_its_follow_up_time() {
    // Two minor cars queue at the line; once the stream has passed they go one after the
    // other, the second no sooner than its follow-up time after the first.
    for follow_up_s in [2.5, 6.0] {
        let (first, _, second) = minor_entry(7.5, follow_up_s).expect("the minor cars go");
        let second = second.expect("the second minor car goes");
        assert!(
            second - first >= follow_up_s - 0.1,
            "follow-up {follow_up_s} s: {first} s then {second} s"
        );
    }
}

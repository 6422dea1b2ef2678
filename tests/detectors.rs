//! Induction loops measured against what the telemetry says independently: their counts equal
//! the vehicles whose front crossed the point, occupancy agrees with flow, length and speed
//! (occupancy = flow × length / space-mean speed, Edie's relation), a queue standing over a
//! stop-line loop shows as occupancy, and the detectors CSV is the same bytes on every run.

mod common;

use flockway::level::DetectorSpec;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One row of the detectors CSV.
#[derive(Debug, Clone, serde::Deserialize)]
struct Reading {
    begin_s: f64,
    end_s: f64,
    detector: String,
    road: String,
    lane: u32,
    count: u32,
    flow_veh_h: f64,
    occupancy_pct: f64,
    mean_speed_kmh: Option<f64>,
    harmonic_speed_kmh: Option<f64>,
    mean_length_m: Option<f64>,
}

fn read(path: &Path) -> Vec<Reading> {
    csv::Reader::from_path(path)
        .expect("the detectors csv")
        .deserialize()
        .collect::<Result<_, _>>()
        .expect("rows of the detectors contract")
}

/// Runs `level` with `detectors` added, for `seconds`, writing into `dir`; the run's CSV path.
fn run_with(
    name: &str,
    detectors: Vec<DetectorSpec>,
    seed: u64,
    seconds: f64,
    dir: &Path,
) -> PathBuf {
    let (mut level, path) = common::shipped(name);
    level.detectors = detectors;
    let csv = dir.join("run.csv");
    common::run(level, &path, seed, Some(seconds), Some(csv.clone()));
    csv
}

fn detector(
    name: &str,
    road: &str,
    s_m: f64,
    lanes: Option<Vec<u32>>,
    period_s: f64,
) -> DetectorSpec {
    DetectorSpec {
        name: name.into(),
        road: road.into(),
        s_m,
        lanes,
        period_s,
    }
}

/// Each vehicle's front positions on `road` by time, from the telemetry (sampled every
/// `telemetry.period_s`): how many fronts went from before `s_m` to at or past it.
fn crossings_in_telemetry(csv: &Path, road: &str, s_m: f64, half_length_m: f64) -> u32 {
    let mut reader = csv::Reader::from_path(csv).expect("the telemetry");
    let headers = reader.headers().expect("a header").clone();
    let col = |n: &str| {
        headers
            .iter()
            .position(|h| h == n)
            .unwrap_or_else(|| panic!("column {n}"))
    };
    let (id, r, s) = (col("vehicle_id"), col("road"), col("s_m"));
    let mut last: BTreeMap<u32, f64> = BTreeMap::new();
    let mut crossed = 0;
    for row in reader.records() {
        let row = row.expect("a row");
        if &row[r] != road {
            continue;
        }
        let v: u32 = row[id].parse().expect("an id");
        let front = row[s].parse::<f64>().expect("s_m") + half_length_m;
        if let Some(before) = last.insert(v, front)
            && before < s_m
            && front >= s_m
        {
            crossed += 1;
        }
    }
    crossed
}

#[test]
fn counts_equal_the_fronts_that_cross_and_occupancy_follows_flow_over_speed() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    // Seed 7: not the level's own seed.
    let csv = run_with(
        "dense_road.ron",
        vec![
            detector("loop150", "main", 150.0, None, 30.0),
            detector("loop600", "main", 600.0, Some(vec![3, 0]), 45.0),
        ],
        7,
        100.0,
        dir.path(),
    );
    let rows = read(&dir.path().join("run.detectors.csv"));
    // Periods: 30 s for loop150 (the last one 10 s, ending with the run), 45 s for loop600;
    // a row per lane, lanes ascending.
    let spans = |name: &str| -> Vec<(f64, f64, u32)> {
        rows.iter()
            .filter(|r| r.detector == name)
            .map(|r| (r.begin_s, r.end_s, r.lane))
            .collect()
    };
    let loop150 = spans("loop150");
    assert_eq!(loop150.len(), 4 * 4, "{loop150:?}");
    assert_eq!(
        &loop150[..4],
        &[
            (0.0, 30.0, 0),
            (0.0, 30.0, 1),
            (0.0, 30.0, 2),
            (0.0, 30.0, 3)
        ]
    );
    assert_eq!(loop150.last(), Some(&(90.0, 100.0, 3)));
    assert_eq!(
        spans("loop600"),
        [
            (0.0, 45.0, 0),
            (0.0, 45.0, 3),
            (45.0, 90.0, 0),
            (45.0, 90.0, 3),
            (90.0, 100.0, 0),
            (90.0, 100.0, 3)
        ]
    );
    assert!(rows.iter().all(|r| r.road == "main"));

    // Counts against the telemetry (every 0.5 s): the same fronts crossed, but for those still
    // between two samples when the run ends (one per lane at most).
    let half = 0.5 * rows[0].mean_length_m.expect("vehicles passed");
    let counted: u32 = rows
        .iter()
        .filter(|r| r.detector == "loop150")
        .map(|r| r.count)
        .sum();
    let seen = crossings_in_telemetry(&csv, "main", 150.0, half);
    assert!(counted > 300, "{counted} vehicles at 4 per second");
    assert!(
        counted >= seen && counted <= seen + 4,
        "the loop counted {counted}, the telemetry shows {seen} fronts crossing"
    );

    // Edie: occupancy = flow × mean length / harmonic mean speed, for every full period (a
    // vehicle over the loop as a period ends counts in one period and covers both: up to
    // one vehicle's passage, 0.28 s in 30 s, off).
    for r in rows
        .iter()
        .filter(|r| r.end_s - r.begin_s >= 30.0 && r.count >= 20)
    {
        let (Some(v), Some(l)) = (r.harmonic_speed_kmh, r.mean_length_m) else {
            panic!("speeds and lengths with vehicles: {r:?}");
        };
        let expected = 100.0 * r.flow_veh_h * l / (v * 1000.0);
        assert!(
            (r.occupancy_pct - expected).abs() <= 0.03 * expected + 1.0,
            "occupancy {} % against {expected:.2} % from flow, length and speed: {r:?}",
            r.occupancy_pct
        );
        let mean = r.mean_speed_kmh.expect("a mean speed");
        assert!((40.0..70.0).contains(&mean), "{r:?}");
        assert!(
            v <= mean + 1e-9,
            "a harmonic mean is at most the arithmetic one: {r:?}"
        );
    }
}

#[test]
fn a_stop_line_loop_shows_the_queue_and_an_advance_loop_the_arrivals() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    // The light's cycle is 60 s: a period each.
    run_with(
        "signal_queue.ron",
        vec![
            detector("stop_bar", "approach", 398.0, None, 60.0),
            detector("advance", "approach", 200.0, None, 60.0),
        ],
        11,
        600.0,
        dir.path(),
    );
    let rows = read(&dir.path().join("run.detectors.csv"));
    let of = |name: &str| -> Vec<&Reading> { rows.iter().filter(|r| r.detector == name).collect() };
    let (stop, advance) = (of("stop_bar"), of("advance"));
    assert_eq!((stop.len(), advance.len()), (10, 10));
    // After the first cycle, what arrives leaves: the counts agree over the run within a
    // queue's worth.
    let total = |rs: &[&Reading]| rs.iter().map(|r| r.count).sum::<u32>();
    assert!(total(&advance) >= 80, "{} arrivals", total(&advance));
    assert!(
        total(&advance).abs_diff(total(&stop)) <= 8,
        "{} vs {}",
        total(&advance),
        total(&stop)
    );
    // At the line, cars stand over the loop through the red: occupancy far above what their
    // flow at speed would give, and they pass slower than at the advance loop.
    for (s, a) in stop.iter().zip(&advance).skip(1) {
        assert!(s.occupancy_pct > 20.0, "{s:?}");
        assert!(s.occupancy_pct > 3.0 * a.occupancy_pct, "{s:?} vs {a:?}");
        assert!(
            s.mean_speed_kmh.expect("cars pass") < a.mean_speed_kmh.expect("cars pass"),
            "{s:?} vs {a:?}"
        );
    }
}

#[test]
fn the_detectors_csv_is_the_same_bytes_on_every_run() {
    let runs: Vec<Vec<u8>> = (0..2)
        .map(|_| {
            let dir = tempfile::tempdir().expect("a temporary directory");
            run_with(
                "crossroads_signal.ron",
                vec![detector("all", "west in", 150.0, None, 7.5)],
                5,
                60.0,
                dir.path(),
            );
            std::fs::read(dir.path().join("run.detectors.csv")).expect("the detectors csv")
        })
        .collect();
    assert!(runs[0].len() > 200, "{}", String::from_utf8_lossy(&runs[0]));
    assert_eq!(runs[0], runs[1]);
}

#[test]
fn a_level_without_detectors_writes_no_detectors_file() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    run_with("dense_road.ron", Vec::new(), 1, 2.0, dir.path());
    assert!(dir.path().join("run.csv").exists());
    assert!(!dir.path().join("run.detectors.csv").exists());
}

//! The end-of-run wave measurement on a run the size of a long level's: a 1 200 m open road
//! sampled every 0.5 s for 600 s (1 200 rows of 600 cells of 2 m), traffic that enters at one
//! end and leaves at the other, and a stop-and-go wave travelling against it at 18 km/h. The
//! measurement tries 262 propagation speeds at four lags each and the fixed-point
//! autocorrelation at 900 lags: it is what a run waits for after its last step.
//!
//! `FLOCKWAY_THREADS=1` measures it on one thread (by default the trial speeds and lags are
//! split over one thread per core).

use criterion::{Criterion, criterion_group, criterion_main};
use flockway_analysis::{Trace, WaveSettings, measure_wave};
use std::collections::BTreeMap;
use std::hint::black_box;

/// Road length, m.
const LENGTH_M: f64 = 1200.0;

/// A run's samples: vehicles 30 m apart at 50 km/h on average, slowed to 20 km/h where the
/// wave's trough passes (every 240 m, moving back at 18 km/h).
fn open_road_with_wave() -> Trace {
    let speed_at = |x: f64, t: f64| -> f64 {
        let trough = (-18.0 / 3.6 * t).rem_euclid(240.0);
        let phase = std::f64::consts::TAU * (x - trough) / 240.0;
        35.0 + 15.0 * phase.cos()
    };
    let mut trace = Trace::new();
    let mut vehicles: Vec<(u32, f64)> = (0..40).map(|i| (i, f64::from(i) * 30.0)).collect();
    let mut next_id = 40;
    let dt = 0.5;
    for k in 0..1200 {
        let t = f64::from(k) * dt;
        vehicles.sort_by(|a, b| a.1.total_cmp(&b.1));
        for &(id, x) in &vehicles {
            trace.push(t, id, "human", "main", 0, x, speed_at(x, t));
        }
        for v in &mut vehicles {
            v.1 += speed_at(v.1, t) / 3.6 * dt;
        }
        // Leaving at the far end, entering at the near one as soon as there is room.
        vehicles.retain(|v| v.1 < LENGTH_M);
        if vehicles.iter().all(|v| v.1 > 30.0) {
            vehicles.push((next_id, 0.0));
            next_id += 1;
        }
    }
    trace
}

fn bench(c: &mut Criterion) {
    let trace = open_road_with_wave();
    let lengths = BTreeMap::from([("main".to_owned(), LENGTH_M)]);
    let settings = WaveSettings::default();
    let wave = measure_wave(&trace, &lengths, &settings).expect("a wave to measure");
    assert!(!wave.closed && wave.detected, "{wave:?}");
    assert!((wave.best_speed_kmh + 18.0).abs() < 1.0, "{wave:?}");
    let mut group = c.benchmark_group("wave");
    group.sample_size(10);
    group.bench_function("open_road_1200m_600s", |b| {
        b.iter(|| measure_wave(black_box(&trace), &lengths, &settings))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! The whole step of the shipped `levels/dense_road.ron` (spawners, lane index, drivers, vehicle
//! forces, rapier, triggers, destroyers, telemetry sampling into the run's trace) in its steady
//! state, after 60 simulated seconds of warm-up. One iteration is one simulated second (120
//! steps); at the end the benchmark prints the vehicles alive on average and the cost per
//! vehicle-step over everything it measured.

use criterion::{Criterion, criterion_group, criterion_main};
use flockway::level::load_level;
use flockway::run::{RunOptions, Runner};
use std::path::Path;
use std::time::Duration;

const TICKS: u64 = 120;

#[path = "common/timed.rs"]
mod timed;

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("levels/dense_road.ron");
    let level = load_level(&path).unwrap_or_else(|e| panic!("{e}"));
    let options = RunOptions {
        // Long enough for every iteration criterion asks for; telemetry goes to the trace only.
        seconds: Some(100_000.0),
        ..RunOptions::default()
    };
    let mut runner = Runner::new(level, "dense_road", &options).unwrap_or_else(|e| panic!("{e}"));
    runner.step(60 * TICKS).unwrap_or_else(|e| panic!("{e}"));
    let mut timed = timed::Timed::default();
    let mut group = c.benchmark_group("dense_road");
    group.sample_size(20);
    group.measurement_time(Duration::from_secs(20));
    group.bench_function("simulated_second", |b| {
        b.iter_custom(|iters| {
            (0..iters * TICKS)
                .map(|_| timed.step(&mut runner))
                .sum::<Duration>()
        })
    });
    group.finish();
    println!(
        "dense_road: {:.1} vehicles alive on average, {:.2} µs per vehicle-step, \
         {:.1} simulated seconds per wall second ({} steps measured)",
        timed.mean_alive(),
        timed.us_per_vehicle_step(),
        timed.real_time_factor(),
        timed.steps,
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);

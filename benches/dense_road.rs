//! The whole step of the shipped `levels/dense_road.ron` (spawners, lane index, drivers, vehicle
//! forces, rapier, triggers, destroyers, telemetry sampling into the run's trace) in its steady
//! state, after 60 simulated seconds of warm-up. One iteration is one simulated second (120
//! steps); at the end the benchmark prints the vehicles alive on average and the cost per
//! vehicle-step over everything it measured.

use criterion::{Criterion, criterion_group, criterion_main};
use flockway::level::load_level;
use flockway::run::{RunOptions, Runner};
use flockway::vehicle::VehicleModel;
use std::path::Path;
use std::time::{Duration, Instant};

const TICKS: u64 = 120;

fn alive(runner: &mut Runner) -> u64 {
    let world = runner.sim_mut().world_mut();
    world.query::<&VehicleModel>().iter(world).count() as u64
}

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
    let (mut vehicle_steps, mut steps, mut spent) = (0u64, 0u64, Duration::ZERO);
    let mut group = c.benchmark_group("dense_road");
    group.sample_size(20);
    group.measurement_time(Duration::from_secs(20));
    group.bench_function("simulated_second", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                for _ in 0..TICKS {
                    let n = alive(&mut runner);
                    let started = Instant::now();
                    runner.step(1).unwrap_or_else(|e| panic!("{e}"));
                    let took = started.elapsed();
                    total += took;
                    spent += took;
                    vehicle_steps += n;
                    steps += 1;
                }
            }
            total
        })
    });
    group.finish();
    let mean_alive = vehicle_steps as f64 / steps as f64;
    let per_step = spent.as_secs_f64() / steps as f64;
    println!(
        "dense_road: {mean_alive:.1} vehicles alive on average, {:.2} µs per vehicle-step, \
         {:.1} simulated seconds per wall second ({steps} steps measured)",
        spent.as_secs_f64() * 1e6 / vehicle_steps as f64,
        1.0 / (per_step * 120.0),
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);

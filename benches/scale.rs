//! Scale: 250, 1 000 and 10 000 autonomous cars on a 4-lane ring (40 m apart per lane, 60 km/h;
//! 250 is below the count the per-car passes split over the task pool from), the whole step
//! (perception, drivers, physics, telemetry sampling); and a city: a 12 × 12 grid of signalised
//! junctions as netconvert writes one (imported: 552 streets of two lanes and 2 020 junction
//! paths, 3 124 lanes), every street lane started with a car every 30 m (4 416), the whole step
//! of the run (spawners, signals, junction rules, destroyers, telemetry into the trace) after 10
//! simulated seconds. Criterion reports the time per step; the real-time factor is 1/120 s
//! divided by it. The city prints its vehicles alive on average and µs per vehicle-step.
//! `ring_step_action_1_30s/10000` is the ring of 10 000 with its drivers deciding every 1/30 s
//! (their action step) instead of every tick.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
mod common;
#[path = "common/grid.rs"]
mod grid;
#[path = "common/timed.rs"]
mod timed;
use flockway::drivers::{BuiltinModel, DriverSpec};
use flockway::level::import_sumo_net;
use flockway::road::RoadNetwork;
use flockway::run::{RunOptions, Runner};
use flockway::traffic::spawn_driven;
use flockway::vehicle::{VehicleSpawn, VehicleType};
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

/// Junctions per side of the city.
const CITY_SIDE: usize = 12;
/// Spacing of the cars the city starts with along every street lane, m.
const CITY_SPACING_M: f64 = 30.0;
/// Junctions per side of the town.
const TOWN_SIDE: usize = 5;
/// Spacing of the cars the town starts with along every street lane, m.
const TOWN_SPACING_M: f64 = 60.0;

/// A grid of `side` × `side` signalised junctions, every street lane started with a car every
/// `spacing_m`, after 10 simulated seconds.
fn city(side: usize, spacing_m: f64) -> Runner {
    let net = grid::grid_net(side, true);
    let level =
        import_sumo_net(&net, Path::new("city.net.xml"), "city").unwrap_or_else(|e| panic!("{e}"));
    let options = RunOptions {
        seconds: Some(100_000.0),
        ..RunOptions::default()
    };
    let mut runner = Runner::new(level, "city", &options).unwrap_or_else(|e| panic!("{e}"));
    let world = runner.sim_mut().world_mut();
    let network = world.resource::<RoadNetwork>().clone();
    let model = Arc::new(VehicleType::default());
    let driver = DriverSpec::default_for(BuiltinModel::FlockLanes);
    // One name shared by every car, as a level's spawners share their profile's.
    let profile: Arc<str> = Arc::from("autonomous");
    for (id, g) in network.iter() {
        if network.junction_path(id).is_some() {
            continue;
        }
        let mut s = 10.0;
        while s < g.length_m() - 10.0 {
            for lane in 0..g.lanes() {
                let at = VehicleSpawn::new(model.clone(), id, s)
                    .lateral(g.lane_offset_m(lane, s))
                    .speed(8.0);
                spawn_driven(world, at, &driver, lane, profile.clone())
                    .unwrap_or_else(|e| panic!("{e}"));
            }
            s += spacing_m;
        }
    }
    runner.step(10 * 120).unwrap_or_else(|e| panic!("{e}"));
    runner
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("scale");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(10));
    for n in [250usize, 1000, 10_000] {
        let mut sim = common::ring(n, 120);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(BenchmarkId::new("ring_step", n), |b| b.iter(|| sim.step()));
    }
    // The 10 000 with their drivers deciding every 1/30 s (the action step) instead of every
    // tick: the physics, the controller and the safety layer still every tick.
    let set = BTreeMap::from([("action_step_s".to_owned(), 1.0 / 30.0)]);
    let driver =
        DriverSpec::build(BuiltinModel::FlockLanes, None, &set).unwrap_or_else(|e| panic!("{e}"));
    let mut sim = common::ring_driven(10_000, 120, &driver);
    group.throughput(Throughput::Elements(10_000));
    group.bench_function(BenchmarkId::new("ring_step_action_1_30s", 10_000), |b| {
        b.iter(|| sim.step());
    });
    group.finish();
    grid_step(c, "city", CITY_SIDE, CITY_SPACING_M);
    grid_step(c, "town", TOWN_SIDE, TOWN_SPACING_M);
}

/// Benchmark group `name`: one step of the grid [`city`] of `side` junctions a side with cars
/// every `spacing_m`, then its vehicles alive on average, µs per vehicle-step and real-time
/// factor.
fn grid_step(c: &mut Criterion, name: &str, side: usize, spacing_m: f64) {
    let mut group = c.benchmark_group(name);
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(10));
    // Set up only when the filter selects it (filling the streets takes a while).
    let mut runner: Option<Runner> = None;
    let mut timed = timed::Timed::default();
    group.bench_function("step", |b| {
        let runner = runner.get_or_insert_with(|| city(side, spacing_m));
        b.iter_custom(|iters| (0..iters).map(|_| timed.step(runner)).sum::<Duration>())
    });
    group.finish();
    if timed.steps == 0 {
        return;
    }
    println!(
        "{name}: {:.0} vehicles alive on average, {:.2} µs per vehicle-step, {:.2}× real time \
         ({} steps measured)",
        timed.mean_alive(),
        timed.us_per_vehicle_step(),
        timed.real_time_factor(),
        timed.steps,
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);

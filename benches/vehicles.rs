//! One physics step with 1, 100, 1000 and 5000 sedans on a four-lane road: our suspension, tyre
//! and drivetrain forces for every car, the rapier step and the read-back with road tracking.
//! Throughput is in vehicle-steps, so criterion's time per element is the cost per
//! vehicle-step. `driven_step` adds the drivers (lane index, flocking, PID) to the same step.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use flockway::core::{IdKind, RngStreams, Sim, StableId};
use flockway::drivers::{BuiltinModel, DriverSpec, DriversPlugin};
use flockway::road::{Road, RoadId, RoadSpec};
use flockway::vehicle::{Controls, VehiclePlugin, VehicleSpawn, VehicleType, spawn_vehicle};
use glam::DVec3;
use std::sync::Arc;
use std::time::Duration;

/// Cars per lane per kilometre: 40 m apart, a moderate motorway density.
const SPACING_M: f64 = 40.0;
const LANES: u32 = 4;

fn world(vehicles: usize, driven: bool) -> Sim {
    let per_lane = vehicles.div_ceil(LANES as usize);
    let length = per_lane as f64 * SPACING_M + 2000.0;
    let n = (length / 1000.0).ceil() as usize;
    let points: Vec<DVec3> = (0..=n)
        .map(|i| DVec3::new(length * i as f64 / n as f64, 0.0, 0.0))
        .collect();
    let mut sim = Sim::new(1);
    sim.add_plugin(VehiclePlugin);
    if driven {
        sim.add_plugin(DriversPlugin);
    }
    sim.world_mut().spawn((
        RoadId(0),
        Road(RoadSpec::through("bench", LANES, 100.0, &points)),
    ));
    sim.prepare().unwrap_or_else(|e| panic!("{e}"));
    sim.step();
    let model = Arc::new(VehicleType::default());
    for i in 0..vehicles {
        let lane = (i % LANES as usize) as f64;
        let spawn = VehicleSpawn {
            model: model.clone(),
            road: RoadId(0),
            s_m: 100.0 + (i / LANES as usize) as f64 * SPACING_M,
            lateral_m: (lane - 1.5) * 3.0,
            speed_mps: 20.0,
        };
        let car = spawn_vehicle(sim.world_mut(), spawn).unwrap_or_else(|e| panic!("{e}"));
        if driven {
            let mut rng = sim
                .world()
                .resource::<RngStreams>()
                .stream(StableId::new(IdKind::Vehicle, i as u32));
            let mut e = sim.world_mut().entity_mut(car);
            DriverSpec::default_for(BuiltinModel::FlockLanes).insert(
                &mut e,
                i as u32 % LANES,
                &mut rng,
            );
        } else if let Some(mut c) = sim.world_mut().get_mut::<Controls>(car) {
            // Enough to hold about 72 km/h: the drivetrain, not just coasting, is exercised.
            c.throttle = 0.35;
        }
    }
    // Let the suspension settle before measuring.
    sim.run_ticks(60);
    sim
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("vehicles");
    group.measurement_time(Duration::from_secs(6));
    for n in [1usize, 100, 1000, 5000] {
        let mut sim = world(n, false);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(BenchmarkId::new("step", n), |b| b.iter(|| sim.step()));
    }
    // The same step with every car driven by the default autonomous driver: perception,
    // decision and the shared controller on top of the physics.
    let n = 1000usize;
    let mut sim = world(n, true);
    group.throughput(Throughput::Elements(n as u64));
    group.bench_function(BenchmarkId::new("driven_step", n), |b| {
        b.iter(|| sim.step())
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! Scale: 1 000 and 10 000 autonomous cars on a 4-lane ring (40 m apart per lane, 60 km/h), the
//! whole step (perception, drivers, physics, telemetry sampling). Criterion reports the time per
//! step; the real-time factor is 1/120 s divided by it.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use flockway::core::Sim;
use flockway::drivers::{BuiltinModel, DriverSpec};
use flockway::road::{Road, RoadId, RoadSpec, lane_offset};
use flockway::traffic::{TrafficPlugin, spawn_driven};
use flockway::vehicle::{VehicleSpawn, VehicleType};
use glam::DVec3;
use std::sync::Arc;
use std::time::Duration;

fn ring(cars: usize) -> Sim {
    let length = cars as f64 / 4.0 * 40.0;
    let mut sim = Sim::new(1);
    sim.add_plugin(TrafficPlugin);
    let spec = RoadSpec::ring(
        "ring",
        4,
        60.0,
        DVec3::ZERO,
        length / std::f64::consts::TAU,
        64,
    );
    let network = flockway::road::RoadNetwork::build(std::slice::from_ref(&spec))
        .unwrap_or_else(|e| panic!("{e}"));
    sim.world_mut().spawn((RoadId(0), Road(spec)));
    sim.world_mut().insert_resource(network.clone());
    sim.prepare().unwrap_or_else(|e| panic!("{e}"));
    let g = network
        .get(RoadId(0))
        .unwrap_or_else(|| panic!("ring"))
        .clone();
    let model = Arc::new(VehicleType::default());
    let driver = DriverSpec::default_for(BuiltinModel::FlockLanes);
    for i in 0..cars {
        let lane = (i % 4) as u32;
        let s = (i / 4) as f64 * 40.0 + f64::from(lane) * 10.0;
        let lateral = lane_offset(g.frame_at(s).width_m, 4, lane);
        let at = VehicleSpawn::new(model.clone(), RoadId(0), s)
            .lateral(lateral)
            .speed(16.7);
        spawn_driven(sim.world_mut(), at, &driver, lane, Arc::from("autonomous"))
            .unwrap_or_else(|e| panic!("{e}"));
    }
    sim.run_ticks(120);
    sim
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("scale");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(10));
    for n in [1000usize, 10_000] {
        let mut sim = ring(n);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(BenchmarkId::new("ring_step", n), |b| b.iter(|| sim.step()));
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

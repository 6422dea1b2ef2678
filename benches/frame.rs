//! Frame preparation on the CPU with 5 000 vehicles (issue 7): capturing every vehicle's pose
//! from the world after a step, and blending the last two steps' poses for a frame between them.
//! Uploading the instances is one `write_buffer` of 56 bytes per vehicle, and drawing them is one
//! instanced draw call, so this is the per-frame work that grows with the traffic.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use flockway::app::{VehicleFrame, VehicleInstance};
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
    sim.run_ticks(2);
    sim
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("frame");
    group.sample_size(30);
    group.measurement_time(Duration::from_secs(5));
    let n = 5000usize;
    let mut sim = ring(n);
    let mut prev = VehicleFrame::default();
    prev.capture(sim.world_mut());
    sim.step();
    let mut next = VehicleFrame::default();
    next.capture(sim.world_mut());
    assert_eq!(next.instances.len(), n);
    group.throughput(Throughput::Elements(n as u64));
    group.bench_function(BenchmarkId::new("capture", n), |b| {
        b.iter(|| next.capture(sim.world_mut()))
    });
    let mut out: Vec<VehicleInstance> = Vec::with_capacity(n);
    group.bench_function(BenchmarkId::new("interpolate", n), |b| {
        b.iter(|| next.interpolate(&prev, 0.5, &mut out))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! Frame preparation on the CPU with 5 000 vehicles: capturing every vehicle's pose
//! from the world after a step, and blending the last two steps' poses for a frame between them.
//! Uploading the instances is one `write_buffer` of 56 bytes per vehicle, and drawing them is one
//! instanced draw call, so this is the per-frame work that grows with the traffic.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use flockway::app::{VehicleFrame, VehicleInstance};
mod common;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("frame");
    group.sample_size(30);
    group.measurement_time(Duration::from_secs(5));
    let n = 5000usize;
    let mut sim = common::ring(n, 2);
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

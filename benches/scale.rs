//! Scale: 1 000 and 10 000 autonomous cars on a 4-lane ring (40 m apart per lane, 60 km/h), the
//! whole step (perception, drivers, physics, telemetry sampling). Criterion reports the time per
//! step; the real-time factor is 1/120 s divided by it.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
mod common;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("scale");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(10));
    for n in [1000usize, 10_000] {
        let mut sim = common::ring(n, 120);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(BenchmarkId::new("ring_step", n), |b| b.iter(|| sim.step()));
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

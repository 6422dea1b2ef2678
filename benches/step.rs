//! The fixed step itself: the cost of the schedule with the shipped levels' roads and no traffic.
//! This is the floor every vehicle's cost is added to.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use flockway::level::load_level;
use flockway::run::build_sim;
use std::path::Path;

const TICKS: u64 = 1200;

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("step");
    group.throughput(Throughput::Elements(TICKS));
    for level in ["dense_road.ron", "sugiyama_ring.ron"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("levels")
            .join(level);
        let level_data = load_level(&path).unwrap_or_else(|e| panic!("{e}"));
        let mut sim = build_sim(&level_data, level_data.seed).unwrap_or_else(|e| panic!("{e}"));
        // The first step builds the road network; measure the steady state after it.
        sim.step();
        group.bench_function(BenchmarkId::new("empty", level), |b| {
            b.iter(|| sim.run_ticks(TICKS))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! The lane index: cost of one neighbour query (leader; everything within ±40 m on a lane) and
//! of the per-tick rebuild (vehicles scattered, and in the order a running simulation keeps),
//! from 100 to 10 000 vehicles at the same density (one car per 25 m of lane on a 4-lane ring
//! that grows with the count). A query should cost the same at every size: O(log n + k).

use bevy_ecs::prelude::*;
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use flockway::drivers::LaneIndex;
use flockway::road::{RoadId, RoadNetwork, RoadSpec, lane_offset};
use flockway::vehicle::RoadTrack;
use glam::DVec3;

const QUERIES: usize = 1000;

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("perception");
    for n in [100usize, 1000, 10_000] {
        let length = n as f64 / 4.0 * 25.0;
        let ring = RoadSpec::ring(
            "ring",
            4,
            60.0,
            DVec3::ZERO,
            length / std::f64::consts::TAU,
            32,
        );
        let network = RoadNetwork::build(&[ring]).unwrap_or_else(|e| panic!("{e}"));
        let g = network
            .get(RoadId(0))
            .unwrap_or_else(|| panic!("road"))
            .clone();
        let mut world = World::new();
        let cars: Vec<(Entity, RoadTrack)> = (0..n)
            .map(|i| {
                let lane = (i % 4) as u32;
                // Scattered, not in spawn order, so the rebuild really sorts.
                let s = ((i * 7919) % n) as f64 / n as f64 * g.length_m();
                let lateral = lane_offset(g.frame_at(s).width_m, 4, lane);
                let mut track = RoadTrack::new(RoadId(0), &g, s, lateral);
                track.speed_along_mps = 16.0;
                (world.spawn_empty().id(), track)
            })
            .collect();
        let mut index = LaneIndex::default();
        let entries = || cars.iter().map(|(e, t)| (*e, t, 4.6f32, 0i8));
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(BenchmarkId::new("rebuild", n), |b| {
            b.iter(|| index.rebuild(&network, entries()))
        });
        // As a running simulation hands them over: in the order they were spawned along the
        // ring, the tenth that has since passed the join (now at the smallest positions) last.
        let mut kept: Vec<&(Entity, RoadTrack)> = cars.iter().collect();
        let passed = 0.1 * g.length_m();
        kept.sort_by(|a, b| {
            let key = |t: &RoadTrack| (t.s_m + g.length_m() - passed) % g.length_m();
            key(&a.1).total_cmp(&key(&b.1))
        });
        group.bench_function(BenchmarkId::new("rebuild_kept_order", n), |b| {
            b.iter(|| {
                index.rebuild(&network, kept.iter().map(|(e, t)| (*e, t, 4.6f32, 0i8)));
            })
        });
        index.rebuild(&network, entries());
        group.throughput(Throughput::Elements(QUERIES.min(n) as u64));
        group.bench_function(BenchmarkId::new("leader", n), |b| {
            b.iter(|| {
                let mut found = 0usize;
                for (e, t) in cars.iter().take(QUERIES) {
                    found += usize::from(
                        index
                            .leader(RoadId(0), t.lane, t.s_m, *e, 200.0, None)
                            .is_some(),
                    );
                }
                found
            })
        });
        let mut seen = Vec::new();
        group.bench_function(BenchmarkId::new("within_40m", n), |b| {
            b.iter(|| {
                let mut found = 0usize;
                for (e, t) in cars.iter().take(QUERIES) {
                    seen.clear();
                    index.within(RoadId(0), t.lane, t.s_m, 40.0, 40.0, Some(*e), &mut seen);
                    found += seen.len();
                }
                found
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! Road queries on the hot path: closest point (global and hinted) and frame at an arc position.
//!
//! Each benchmark answers 10,000 queries, the order of magnitude one step of a large run needs
//! (four wheel contacts plus a lane query for each of 2,000 vehicles).

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use flockway::level::load_level;
use flockway::road::RoadGeometry;
use glam::DVec3;
use std::hint::black_box;
use std::path::Path;

const QUERIES: usize = 10_000;

fn road(level: &str) -> RoadGeometry {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("levels")
        .join(level);
    let level = load_level(&path).unwrap_or_else(|e| panic!("{e}"));
    RoadGeometry::new(&level.roads[0]).unwrap_or_else(|e| panic!("{e}"))
}

/// Positions on and beside the road (within its width, up to 1 m above), as vehicles would be.
fn positions(g: &RoadGeometry) -> Vec<(DVec3, f64)> {
    let mut state = 12345u64;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..QUERIES)
        .map(|_| {
            let s = next() * g.length_m();
            let f = g.frame_at(s);
            let lateral = (next() - 0.5) * f.width_m;
            (f.offset(lateral) + f.up * next(), s)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("road");
    group.throughput(Throughput::Elements(QUERIES as u64));
    for level in ["dense_road.ron", "sugiyama_ring.ron"] {
        let g = road(level);
        let pts = positions(&g);
        group.bench_with_input(BenchmarkId::new("project", level), &pts, |b, pts| {
            b.iter(|| {
                pts.iter()
                    .map(|(p, _)| black_box(g.project(*p)).s_m)
                    .sum::<f64>()
            })
        });
        group.bench_with_input(BenchmarkId::new("project_near", level), &pts, |b, pts| {
            b.iter(|| {
                pts.iter()
                    .map(|(p, s)| black_box(g.project_near(*p, *s + 1.5)).s_m)
                    .sum::<f64>()
            })
        });
        // A wheel's pattern: each position is projected from the cursor its last one left, 1.5 m
        // behind (the distance a car covers in ~5 steps at 100 km/h).
        let starts: Vec<_> = pts.iter().map(|(_, s)| g.cursor_at(s - 1.5)).collect();
        group.bench_with_input(
            BenchmarkId::new("project_tracked", level),
            &pts,
            |b, pts| {
                b.iter(|| {
                    pts.iter()
                        .zip(&starts)
                        .map(|((p, _), start)| {
                            let mut cursor = *start;
                            black_box(g.project_tracked(*p, &mut cursor)).s_m
                        })
                        .sum::<f64>()
                })
            },
        );
        group.bench_with_input(BenchmarkId::new("frame_at", level), &pts, |b, pts| {
            b.iter(|| {
                pts.iter()
                    .map(|(_, s)| black_box(g.frame_at(*s)).pos.x)
                    .sum::<f64>()
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

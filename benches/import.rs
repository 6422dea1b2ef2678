//! Importing a city-sized SUMO network: a generated grid written as netconvert writes one (two
//! lanes each way, priority junctions, every turn a connection with its internal lane), about
//! 10 MB of XML. `import` reads it into a level (parse, network model, level, validation);
//! `network` builds the level's road network from it (splines, junction paths and their
//! conflicts, roads that cross without meeting), as a run does before its first step.

use criterion::{Criterion, criterion_group, criterion_main};
use flockway::level::import_sumo_net;
use flockway::road::RoadNetwork;
use std::hint::black_box;
use std::path::Path;

/// Junctions per side of the grid.
const SIDE: usize = 43;

#[path = "common/grid.rs"]
mod grid;

fn bench(c: &mut Criterion) {
    let net = grid::grid_net(SIDE, false);
    let path = Path::new("grid.net.xml");
    let mut group = c.benchmark_group("import");
    group.sample_size(10);
    let mb = net.len() as f64 / 1.0e6;
    group.bench_function(format!("import/{mb:.1}MB"), |b| {
        b.iter(|| black_box(import_sumo_net(&net, path, "grid").expect("the grid imports")))
    });
    let level = import_sumo_net(&net, path, "grid").expect("the grid imports");
    group.bench_function(format!("network/{}roads", level.roads.len()), |b| {
        b.iter(|| {
            black_box(
                RoadNetwork::build_with(&level.roads, &level.junctions)
                    .expect("the grid's network builds"),
            )
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

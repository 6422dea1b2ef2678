//! Shared set-up of the benchmarks: a 4-lane ring full of driven autonomous cars.

use flockway::core::Sim;
use flockway::drivers::{BuiltinModel, DriverSpec};
use flockway::road::{Road, RoadId, RoadSpec, lane_offset};
use flockway::traffic::{TrafficPlugin, spawn_driven};
use flockway::vehicle::{VehicleSpawn, VehicleType};
use glam::DVec3;
use std::sync::Arc;

/// `cars` autonomous cars on a 4-lane ring, 40 m apart per lane at 60 km/h, after `ticks` steps.
pub fn ring(cars: usize, ticks: u64) -> Sim {
    ring_driven(
        cars,
        ticks,
        &DriverSpec::default_for(BuiltinModel::FlockLanes),
    )
}

/// The same ring with every car driven by `driver`.
pub fn ring_driven(cars: usize, ticks: u64, driver: &DriverSpec) -> Sim {
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
    // One name shared by every car, as a level's spawners share their profile's.
    let profile: Arc<str> = Arc::from("autonomous");
    for i in 0..cars {
        let lane = (i % 4) as u32;
        let s = (i / 4) as f64 * 40.0 + f64::from(lane) * 10.0;
        let lateral = lane_offset(g.frame_at(s).width_m, 4, lane);
        let at = VehicleSpawn::new(model.clone(), RoadId(0), s)
            .lateral(lateral)
            .speed(16.7);
        spawn_driven(sim.world_mut(), at, driver, lane, profile.clone())
            .unwrap_or_else(|e| panic!("{e}"));
    }
    sim.run_ticks(ticks);
    sim
}

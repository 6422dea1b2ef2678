//! A complete custom driver in one file: "gap keeper" holds a time gap to its leader, read from
//! the lane index, and lets the shared controller keep it in lane and turn its target speed into
//! throttle and steering. Run it with `cargo run --release --example custom_driver`.

use bevy_ecs::prelude::*;
use flockway::core::{Sim, SimPlugin};
use flockway::drivers::{DriveTarget, DriversPlugin, LaneIndex, SharedController, add_driver};
use flockway::level::load_level;
use flockway::road::{RoadId, RoadNetwork};
use flockway::run::build_sim;
use flockway::vehicle::{Motion, RoadTrack, VehicleSpawn, VehicleType, spawn_vehicle};
use std::sync::Arc;

/// The driver: its one parameter is the time gap it keeps, s.
#[derive(Component)]
struct GapKeeper {
    gap_s: f32,
}

/// Each tick: cruise at the limit, but never faster than closes the gap to the leader in 2 s.
fn keep_gap(
    network: Res<RoadNetwork>,
    index: Res<LaneIndex>,
    mut cars: Query<(Entity, &GapKeeper, &RoadTrack, &Motion, &mut DriveTarget)>,
) {
    for (me, driver, track, motion, mut target) in &mut cars {
        let Some(road) = network.get(track.road) else {
            continue;
        };
        let (limit, v) = (road.speed_limit_kmh() as f32 / 3.6, motion.forward_mps);
        let speed = match index.leader(
            track.road,
            track.lane,
            track.s_m,
            me,
            200.0,
            track.next_road,
        ) {
            Some(l) => l.entry.speed_mps + (l.gap_m as f32 - 6.0 - driver.gap_s * v) / 2.0,
            None => limit,
        };
        *target = DriveTarget::keep_lane(road, track, track.lane, v, speed.clamp(0.0, limit));
    }
}

/// Registers the driver: no engine code changes.
struct GapKeeperPlugin;
impl SimPlugin for GapKeeperPlugin {
    fn build(&self, sim: &mut Sim) {
        sim.add_plugin(DriversPlugin);
        add_driver(sim, keep_gap);
    }
}

/// Eight gap keepers on the shipped Sugiyama ring level for `seconds`: final speeds, km/h.
fn run(seconds: f32) -> Vec<f32> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/levels/sugiyama_ring.ron");
    let level = load_level(std::path::Path::new(path)).expect("a shipped level");
    let mut sim = build_sim(&level, level.seed).expect("the level builds");
    sim.add_plugin(GapKeeperPlugin);
    sim.step(); // builds the road network
    let model = Arc::new(VehicleType::default());
    let mut cars = Vec::new();
    for i in 0..8 {
        let at = VehicleSpawn::new(model.clone(), RoadId(0), 28.75 * f64::from(i)).speed(5.0);
        let car = spawn_vehicle(sim.world_mut(), at).expect("the ring exists");
        let driver = (GapKeeper { gap_s: 1.5 }, SharedController::default());
        cars.push(sim.world_mut().entity_mut(car).insert(driver).id());
    }
    sim.run_ticks((seconds * 120.0) as u64);
    let speed = |c: &Entity| sim.world().get::<Motion>(*c).map_or(0.0, |m| m.forward_mps);
    cars.iter().map(|c| speed(c) * 3.6).collect()
}

fn main() {
    for (i, kmh) in run(60.0).iter().enumerate() {
        println!("car {i}: {kmh:.1} km/h");
    }
}

#[test]
fn gap_keepers_cruise_near_the_limit() {
    for kmh in run(40.0) {
        assert!((25.0..=31.0).contains(&kmh), "{kmh} km/h (limit 30)");
    }
}

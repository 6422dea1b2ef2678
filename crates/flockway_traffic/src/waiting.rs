//! Waiting and delay as a controller observes them step by step (a signal-control agent's
//! reward): each vehicle's time standing on its current road, and each lane's time lost
//! against its speed limit. Kept only when the [`WaitingTimes`] resource is present, so runs
//! that do not ask pay nothing.

use bevy_ecs::prelude::*;
use flockway_core::DT_S;
use flockway_road::{RoadId, RoadNetwork};
use flockway_vehicle::{Motion, RoadTrack};
use std::collections::{BTreeMap, HashMap};

/// Below this speed a vehicle is halting, m/s (SUMO's threshold, which sumo-rl's rewards use).
pub const HALTING_MPS: f32 = 0.1;

/// Per vehicle, its waiting on the road it is on; per lane, the delay of every vehicle on it.
#[derive(Resource, Debug, Clone, Default, PartialEq)]
pub struct WaitingTimes {
    /// Per vehicle: the road it is on and how long it has halted there, s. Only ever looked
    /// up by entity and replaced whole, never iterated, so its hash order cannot reach a result.
    vehicles: HashMap<Entity, (RoadId, f64)>,
    /// Per road and lane: the time lost on it by every vehicle so far, s (driving below the
    /// speed limit counts its shortfall's share of each step).
    lane_delay_s: BTreeMap<(RoadId, u32), f64>,
}

impl WaitingTimes {
    /// How long `vehicle` has halted on the road it is on, s (0 for one not seen).
    pub fn waiting_s(&self, vehicle: Entity) -> f64 {
        self.vehicles.get(&vehicle).map_or(0.0, |&(_, w)| w)
    }

    /// The time lost on lane `lane` of `road` so far, s.
    pub fn lane_delay_s(&self, road: RoadId, lane: u32) -> f64 {
        self.lane_delay_s.get(&(road, lane)).copied().unwrap_or(0.0)
    }
}

/// Adds this step's waiting and time lost, when [`WaitingTimes`] is kept.
pub fn track_waiting(
    network: Res<RoadNetwork>,
    waiting: Option<ResMut<WaitingTimes>>,
    vehicles: Query<(Entity, &RoadTrack, &Motion)>,
) {
    let Some(mut waiting) = waiting else {
        return;
    };
    let waiting = &mut *waiting;
    let mut now = HashMap::with_capacity(waiting.vehicles.len());
    for (entity, track, motion) in &vehicles {
        let halted = motion.forward_mps.abs() < HALTING_MPS;
        let before = match waiting.vehicles.get(&entity) {
            Some(&(road, w)) if road == track.road => w,
            _ => 0.0,
        };
        now.insert(
            entity,
            (track.road, before + if halted { DT_S } else { 0.0 }),
        );
        let limit_mps = network
            .get(track.road)
            .map_or(0.0, |g| g.speed_limit_kmh() / 3.6);
        if limit_mps > 0.0 {
            let v = f64::from(motion.forward_mps.max(0.0));
            let lost = (1.0 - v / limit_mps).max(0.0) * DT_S;
            *waiting
                .lane_delay_s
                .entry((track.road, track.lane))
                .or_default() += lost;
        }
    }
    waiting.vehicles = now;
}

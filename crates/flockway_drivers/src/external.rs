//! Vehicles driven from outside the step: a level's `Custom(NAME)` profile run from a script or
//! a Python controller. Between steps the caller gives each such vehicle a command — a target
//! speed (and lane) for the shared controller, or the controls themselves — which holds until
//! it gives another. Until its first command (and after `clear`), the vehicle drives as a
//! lane-keeping flocking car, so a level with custom profiles runs sensibly on its own.

use crate::control::{DriveTarget, follow_targets};
use crate::pipeline::LaneChoice;
use crate::{DriverSystems, add_driver};
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::IntoScheduleConfigs;
use flockway_core::{Sim, SimPlugin};
use flockway_road::RoadNetwork;
use flockway_vehicle::{Controls, Motion, RoadTrack};
use std::sync::Arc;

/// What an externally driven vehicle was last told.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ExternalCommand {
    /// Drive at `speed_mps` in `lane` (its current lane when `None`) through the shared
    /// controller, which also stops it where a junction holds it, as for every driver.
    Target {
        /// Target speed, m/s (0 or more).
        speed_mps: f32,
        /// The lane to keep, counted on the road it is on (clamped to the road's lanes).
        lane: Option<u32>,
    },
    /// These controls, as given: no controller, no junction rules.
    Controls(Controls),
}

/// A vehicle driven from outside the step, by the model `model` (its profile's
/// `Custom(NAME)`).
#[derive(Component, Debug, Clone, PartialEq)]
pub struct External {
    /// The custom model's name.
    pub model: Arc<str>,
    /// The command in force; `None`: it drives as a lane-keeping flocking car.
    pub command: Option<ExternalCommand>,
}

impl External {
    /// A vehicle of model `model` with no command yet.
    pub fn new(model: Arc<str>) -> External {
        External {
            model,
            command: None,
        }
    }
}

/// Adds the systems that carry out external commands (needs the drivers plugin, added if
/// missing).
pub struct ExternalPlugin;

impl SimPlugin for ExternalPlugin {
    fn build(&self, sim: &mut Sim) {
        sim.add_plugin(crate::DriversPlugin);
        // After every model's driver (a command overrides whichever model drives the vehicle),
        // before the shared controller turns targets into controls.
        sim.schedule_mut().add_systems((
            follow_external_targets
                .before(follow_targets)
                .in_set(DriverSystems::Control),
            apply_external_controls
                .after(follow_targets)
                .in_set(DriverSystems::Control),
        ));
    }
}

/// Registers a Rust driver for externally driven vehicles — a plugin playing a level's
/// `Custom(NAME)` profile, as a Python driver would: `system` runs every tick after perception
/// (the [`LaneIndex`](crate::LaneIndex) is this tick's) and sets the [`External::command`] of
/// the vehicles of its model, which this tick carries out. Needs [`ExternalPlugin`].
pub fn add_external_driver<M>(
    sim: &mut Sim,
    system: impl IntoScheduleConfigs<bevy_ecs::system::ScheduleSystem, M>,
) {
    add_driver(sim, system.before(follow_external_targets));
}

/// Turns each target command into the vehicle's drive target: its lane kept at its speed.
fn follow_external_targets(
    network: Res<RoadNetwork>,
    mut vehicles: Query<(
        &External,
        &RoadTrack,
        &Motion,
        &mut LaneChoice,
        &mut DriveTarget,
    )>,
) {
    for (external, track, motion, mut flock, mut target) in &mut vehicles {
        let Some(ExternalCommand::Target { speed_mps, lane }) = external.command else {
            continue;
        };
        let Some(geometry) = network.get(track.road) else {
            continue;
        };
        let last = geometry.lanes().max(1) - 1;
        let lane = lane.unwrap_or(flock.lane).min(last);
        // The flocking driver keeps the lane it was given, should the command be cleared.
        if flock.lane != lane || flock.target_lane != lane {
            flock.lane = lane;
            flock.target_lane = lane;
        }
        *target = DriveTarget::keep_lane(
            geometry,
            track,
            lane,
            motion.forward_mps,
            speed_mps.max(0.0),
        );
    }
}

/// Writes each controls command over what the shared controller made of the vehicle's target.
fn apply_external_controls(mut vehicles: Query<(&External, &mut Controls)>) {
    for (external, mut controls) in &mut vehicles {
        if let Some(ExternalCommand::Controls(c)) = external.command {
            *controls = Controls {
                throttle: c.throttle.clamp(-1.0, 1.0),
                steering: c.steering.clamp(-1.0, 1.0),
                handbrake: c.handbrake,
            };
        }
    }
}

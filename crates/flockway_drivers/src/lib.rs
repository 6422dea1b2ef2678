//! Flockway's drivers: what a car sees, how it decides, and how you add your own.
//!
//! Each tick, in [`StepSet::Sense`], [`rebuild_lane_index`] sorts every vehicle into a
//! [`LaneIndex`] per road and lane, so a driver finds its leader, follower and neighbours in
//! O(log n + k), and [`RoadAhead`] holds each lane's speed envelope (the bends and slippery
//! stretches ahead, braked for in time), so a driver reads the road ahead in O(1). In
//! [`StepSet::Decide`] every built-in model goes through one pipeline, [`drive`] (route, lane
//! changes, desired speed, the model's law, courtesy and merging, human imperfections), which
//! writes a [`DriveTarget`] (a speed or an acceleration, and a heading): [`FlockDriver`]
//! (Reynolds flocking, free or keeping its lane, human-like with [`HumanDriver`]), [`IdmDriver`]
//! (the Intelligent Driver Model) and [`WaveDamper`]. Then [`follow_targets`] turns targets into
//! `Controls`, holding every car to its safety envelope. A driver may instead write `Controls`
//! itself.
//!
//! A new model is a component implementing [`DrivingModel`], registered with [`add_model`]; a
//! driver outside the pipeline is a system registered with [`add_driver`] (see
//! `examples/custom_driver.rs`).

mod ahead;
mod control;
mod external;
mod idm;
mod junction;
mod models;
mod perception;
mod pipeline;
mod profile;
mod route;
mod safety;
mod signals;
mod wave_damper;

pub use ahead::{
    ReadsRoad, RoadAhead, RoadAheadParams, RoadSurface, SurfaceStretch, update_road_ahead,
};
pub use control::{
    DriveTarget, HOLD_BRAKE, Pid, PidGains, STOP_BELOW_MPS, SharedController, TargetController,
    follow_targets, wrap_angle,
};
pub use external::{External, ExternalCommand, ExternalPlugin, add_external_driver};
pub use idm::{IdmDriver, IdmParams, idm_accel};
pub use junction::{
    AMBER_DECEL_MPS2, CRITICAL_GAP_S, DEADLOCK_S, FOLLOW_UP_S, GapAcceptance, JunctionGate,
    JunctionStats, STOP_LINE_DECEL_MPS2, STOP_LINE_MARGIN_M, gate_junctions,
};
pub use models::{
    FlockDriver, FlockParams, HumanDriver, HumanParams, SpeedFactor, SpeedFactorParams, SpeedLimit,
    carry_lane, flock_law, lane_following, update_speed_limits,
};
pub use perception::{LaneEntry, LaneIndex, LaneSignal, Seen, rebuild_lane_index};
pub use pipeline::{
    ActionStep, DrivingModel, LANE_END_DECEL_MPS2, LaneChoice, LaneStyle, Longitudinal,
    MAX_ACTION_STEP_S, Proposal, Situation, add_custom_model, add_model, desired_speed_mps, drive,
};
pub use profile::{BuiltinModel, DriverLabel, DriverParamsError, DriverSpec};
pub use route::{
    LANE_CHANGE_AHEAD_M, LANE_CHANGE_AHEAD_S, LANE_CHANGE_LEAST_GAP, LANE_END_MARGIN_M, LaneAsk,
    Route, RouteStats, follow_routes,
};
pub use safety::{
    Ahead, AheadMemo, OVER_SAFE_BRAKE_PER_MPS, SafetyParams, SafetyView, nearest_ahead,
    nearest_ahead_memo, safe_speed_mps,
};
pub use signals::{SignalController, SignalError, SignalMode, Signals, update_signals};
pub use wave_damper::{WaveDamper, WaveDamperParams};

use bevy_ecs::prelude::*;
use bevy_ecs::schedule::ScheduleConfigs;
use bevy_ecs::system::ScheduleSystem;
use flockway_core::{Sim, SimPlugin, StepSet};
use flockway_vehicle::VehiclePlugin;

/// The driver types most users need.
pub mod prelude {
    pub use crate::{
        DriveTarget, DriverSpec, DriversPlugin, DrivingModel, FlockDriver, HumanDriver, IdmDriver,
        LaneChoice, LaneIndex, ReadsRoad, RoadAhead, SharedController, SpeedFactor, SpeedLimit,
        TargetController, add_driver, add_model,
    };
}

/// The driver systems, for ordering against.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DriverSystems {
    /// Rebuilding the lane index and speed limits (in `Sense`).
    Perceive,
    /// Every driver deciding its target (in `Decide`).
    Decide,
    /// The shared controller turning targets into controls (in `Decide`, after the drivers).
    Control,
}

/// Adds perception, the built-in drivers and the shared controller. Needs the vehicle plugin
/// (added if missing).
pub struct DriversPlugin;

impl SimPlugin for DriversPlugin {
    fn build(&self, sim: &mut Sim) {
        sim.add_plugin(VehiclePlugin);
        sim.world_mut().init_resource::<LaneIndex>();
        sim.world_mut().init_resource::<RoadSurface>();
        sim.world_mut().init_resource::<RoadAhead>();
        sim.world_mut().init_resource::<RouteStats>();
        sim.world_mut().init_resource::<JunctionStats>();
        sim.world_mut().init_resource::<Signals>();
        sim.schedule_mut().configure_sets((
            DriverSystems::Perceive.in_set(StepSet::Sense),
            DriverSystems::Decide.in_set(StepSet::Decide),
            DriverSystems::Control
                .after(DriverSystems::Decide)
                .in_set(StepSet::Decide),
        ));
        sim.schedule_mut().add_systems((
            (
                follow_routes,
                (rebuild_lane_index, update_speed_limits, update_road_ahead),
                update_signals,
                gate_junctions,
            )
                .chain()
                .in_set(DriverSystems::Perceive),
            follow_targets.in_set(DriverSystems::Control),
        ));
        add_model::<FlockDriver>(sim);
        add_model::<IdmDriver>(sim);
        add_model::<WaveDamper>(sim);
    }
}

/// Registers a driver system: it runs every tick in [`DriverSystems::Decide`], after
/// perception and before the shared controller, and writes [`DriveTarget`] or `Controls` for the
/// vehicles that carry its component.
///
/// Driver systems write the same components for different vehicles (each vehicle carries one
/// driver component), so they are declared ambiguous with each other rather than ordered; the
/// single-threaded step still runs them in one fixed order, so results stay deterministic.
pub fn add_driver<M>(sim: &mut Sim, system: impl IntoScheduleConfigs<ScheduleSystem, M>) {
    let configs: ScheduleConfigs<ScheduleSystem> = system
        .into_configs()
        .in_set(DriverSystems::Decide)
        .ambiguous_with(DriverSystems::Decide);
    sim.schedule_mut().add_systems(configs);
}

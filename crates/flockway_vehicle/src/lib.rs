//! Flockway's sedan: a rapier3d rigid body driven by our own suspension, Pacejka tyres,
//! drivetrain and steering.
//!
//! rapier integrates the chassis and resolves body contacts (guardrails, other cars) while
//! anything is within reach of it; a chassis with nothing to touch is integrated here with
//! rapier's own operations ([`FreeBody`]). Everything between the chassis and the road is
//! ours. Each tick, in [`StepSet::Actuate`], [`drive_vehicles`] finds every wheel's contact by
//! an exact query of the road spline (a rapier ray cast only where no road is under a wheel),
//! computes spring–damper loads, combined-slip tyre forces, drag and the implicit
//! engine–clutch–wheel spin update, and replaces the body's forces. In [`StepSet::Physics`]
//! rapier steps once at 1/120 s, contacts become [`VehicleContact`] messages and
//! [`sync_vehicles`] reads [`Motion`] and [`RoadTrack`] back. Drivers write only [`Controls`].
//!
//! Modules: `components` (what a vehicle is made of), `spawn` (putting one into the world),
//! `forces` (one tick's forces in named stages, each on the four wheels at once through
//! `lanes`), `systems` (the per-tick systems), `gates` (which colliders rapier sees),
//! `free_body` (bodies integrated here while out of rapier), and the models they use: `tyre`,
//! `drivetrain`, `steering`, `params`, `physics`, and the `dyno`.
//!
//! Conventions: world x east, y north, z up; body x forward, y left, z up; wheels in the order
//! front left, front right, rear left, rear right.

mod components;
mod drivetrain;
mod dyno;
mod forces;
mod free_body;
mod gates;
mod lanes;
mod longitudinal;
mod params;
mod physics;
mod spawn;
mod steering;
mod systems;
mod tyre;

pub use components::{
    BodyForces, CONTACT_GATE_MARGIN_M, Chassis, ContactGate, Controls, Motion, OFF_ROAD_FRICTION,
    RAIL_GATE_MARGIN_M, RoadTrack, SHOULDER_M, VehicleModel, VehicleState, VehicleType,
    WHEEL_NAMES, WheelState,
};
pub use drivetrain::{
    Driveline, Gearbox, Pedals, RPM_TO_RAD_S, STANDSTILL_MPS, SpinInput, SpinOutput, apply_brake,
};
pub use dyno::{DynoReport, DynoSettings, run_dyno};
pub use free_body::FreeBody;
pub use gates::{CloseCars, find_close_cars, gate_colliders};
pub use longitudinal::LongitudinalModel;
pub use params::{
    BrakeParams, ChassisParams, ClutchParams, Differential, EngineParams, GearboxParams,
    MagicFormula, SteeringParams, SuspensionParams, TyreParams, VehicleParams, VehicleParamsError,
    WheelParams,
};
pub use physics::{
    BARE_END_CLEARANCE_M, ContactWith, GRAVITY, GROUND_GROUP, GUARDRAIL_GROUP,
    GUARDRAIL_THICKNESS_M, Physics, VEHICLE_GROUP, VehicleContact, rebuild_static_colliders,
    step_physics, update_contact_messages,
};
pub use spawn::{SpawnError, VehicleSpawn, rest_pose, spawn_vehicle};
pub use steering::{ackermann, slew};
pub use systems::{
    PARALLEL_MIN_VEHICLES, apply_body_forces, drive_vehicles, sync_vehicles, track_road,
};
pub use tyre::{CURVE_SAMPLES, SampledCurve, Tyre};

/// The rapier version the vehicles run on, for plugins that add their own bodies.
pub use rapier3d;

use bevy_ecs::prelude::*;
use flockway_core::{Sim, SimPlugin, StepSet};
use flockway_road::rebuild_roads;

/// The vehicle types most users need.
pub mod prelude {
    pub use crate::{
        Controls, Motion, Physics, RoadTrack, VehicleContact, VehicleModel, VehicleParams,
        VehiclePlugin, VehicleSpawn, VehicleState, VehicleType,
    };
}

/// Adds the rapier world, vehicle forces and the physics step. Needs the road plugin.
pub struct VehiclePlugin;

/// The vehicle systems, for ordering against: forces in `Actuate`, step and read-back in
/// `Physics`.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VehicleSystems {
    /// The contact gates' colliders in or out of rapier, then forces and drivetrain.
    Drive,
    /// rapier step.
    Step,
    /// Reading the new state back.
    Sync,
}

impl SimPlugin for VehiclePlugin {
    fn build(&self, sim: &mut Sim) {
        sim.add_plugin(flockway_road::RoadPlugin);
        sim.world_mut().init_resource::<Physics>();
        sim.world_mut().init_resource::<Messages<VehicleContact>>();
        sim.add_systems(
            StepSet::Prepare,
            (
                update_contact_messages,
                rebuild_static_colliders.after(rebuild_roads),
            ),
        );
        // The gates take the close-car search's answers just before the forces: the search
        // runs beside the serial work between the read-back and here.
        sim.add_systems(
            StepSet::Actuate,
            (gate_colliders, drive_vehicles, apply_body_forces)
                .chain()
                .in_set(VehicleSystems::Drive),
        );
        sim.add_systems(
            StepSet::Physics,
            (
                step_physics.in_set(VehicleSystems::Step),
                (sync_vehicles, find_close_cars)
                    .chain()
                    .in_set(VehicleSystems::Sync),
            )
                .chain(),
        );
    }
}

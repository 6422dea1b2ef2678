//! Putting a vehicle into the world: a rapier body and collider resting on its suspension at a
//! road position, with every component it runs on.

use crate::components::{
    BodyForces, Chassis, ContactGate, Controls, Motion, RoadTrack, VehicleModel, VehicleState,
    VehicleType, WheelState,
};
use crate::drivetrain::{Gearbox, Pedals};
use crate::free_body::FreeBody;
use crate::physics::{GROUND_GROUP, GUARDRAIL_GROUP, Physics, VEHICLE_GROUP, vehicle_tag};
use bevy_ecs::prelude::*;
use flockway_core::Vehicle;
use flockway_road::{RoadFrame, RoadId, RoadNetwork};
use glam::{Quat, Vec3};
use rapier3d::prelude::*;
use std::sync::Arc;

/// Where and how to spawn a vehicle.
#[derive(Debug, Clone)]
pub struct VehicleSpawn {
    /// Its type.
    pub model: Arc<VehicleType>,
    /// Road to place it on.
    pub road: RoadId,
    /// Arc position of its centre of mass, m.
    pub s_m: f64,
    /// Lateral offset from the road centre line, m (positive left).
    pub lateral_m: f64,
    /// Initial speed along the road, m/s.
    pub speed_mps: f32,
}

impl VehicleSpawn {
    /// A vehicle of type `model` at rest on the centre line of `road` at `s_m`.
    pub fn new(model: Arc<VehicleType>, road: RoadId, s_m: f64) -> VehicleSpawn {
        VehicleSpawn {
            model,
            road,
            s_m,
            lateral_m: 0.0,
            speed_mps: 0.0,
        }
    }

    /// The same, `lateral_m` left of the centre line.
    pub fn lateral(self, lateral_m: f64) -> VehicleSpawn {
        VehicleSpawn { lateral_m, ..self }
    }

    /// The same, rolling at `speed_mps`.
    pub fn speed(self, speed_mps: f32) -> VehicleSpawn {
        VehicleSpawn { speed_mps, ..self }
    }
}

/// Why a vehicle could not be spawned.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpawnError {
    /// The road id is not in the network.
    #[error("no road with id {0:?}")]
    NoSuchRoad(RoadId),
    /// The world has no [`Physics`] resource: add [`crate::VehiclePlugin`].
    #[error("the vehicle plugin is not installed")]
    NoPhysics,
}

/// Body pose of a vehicle at rest on a road frame: its centre of mass and orientation.
pub fn rest_pose(model: &VehicleType, frame: &RoadFrame, lateral_m: f64) -> (Vec3, Quat) {
    let rot = Quat::from_mat3(&glam::Mat3::from_cols(
        frame.tangent.as_vec3(),
        frame.left.as_vec3(),
        frame.up.as_vec3(),
    ))
    .normalize();
    let pos = frame.offset(lateral_m) + frame.up * f64::from(model.params.chassis.com_height_m);
    (pos.as_vec3(), rot)
}

/// Spawns a vehicle resting on its suspension at a road position, rolling at `speed_mps` in the
/// gear that suits that speed. Returns the new entity.
pub fn spawn_vehicle(world: &mut World, spawn: VehicleSpawn) -> Result<Entity, SpawnError> {
    let geometry = world
        .get_resource::<RoadNetwork>()
        .and_then(|n| n.get(spawn.road))
        .cloned()
        .ok_or(SpawnError::NoSuchRoad(spawn.road))?;
    if !world.contains_resource::<Physics>() {
        return Err(SpawnError::NoPhysics);
    }
    let model = spawn.model;
    let s_m = geometry.normalize_s(spawn.s_m);
    let frame = geometry.frame_at(s_m);
    let (pos, rot) = rest_pose(&model, &frame, spawn.lateral_m);
    let forward = rot * Vec3::X;
    let p = &model.params;
    let r = p.wheels.radius_m;
    let gearbox = Gearbox::for_speed(&p.gearbox, spawn.speed_mps, r);
    let wheel_omega = spawn.speed_mps / r;
    let engine_omega = (wheel_omega * gearbox.ratio(&p.gearbox))
        .clamp(model.driveline.idle_omega, model.driveline.max_omega);
    let mut wheels = [WheelState::default(); 4];
    for (i, w) in wheels.iter_mut().enumerate() {
        w.omega = wheel_omega;
        w.compression_m = model.rest_compression_m[i];
        w.grounded = true;
    }
    let state = VehicleState {
        wheels,
        gearbox,
        engine_omega,
        clutch: 1.0,
        steer: 0.0,
        pedals: Pedals::default(),
    };
    let motion = Motion {
        position: pos,
        rotation: rot,
        linvel: forward * spawn.speed_mps,
        angvel: Vec3::ZERO,
        forward_mps: spawn.speed_mps,
        accel_mps2: 0.0,
    };
    let mut track = RoadTrack::new(spawn.road, &geometry, s_m, spawn.lateral_m);
    track.speed_along_mps = spawn.speed_mps;
    let entity = world
        .spawn((
            Vehicle,
            Controls::default(),
            VehicleModel(model.clone()),
            state,
            motion,
            track,
            BodyForces::default(),
        ))
        .id();
    let c = &p.chassis;
    // The body box spans ground clearance to roof, placed relative to the centre of mass.
    let box_half_h = (c.height_m - c.ground_clearance_m) / 2.0;
    let box_centre_z = c.ground_clearance_m + box_half_h - c.com_height_m;
    let box_offset = Vec3::new(0.0, 0.0, box_centre_z);
    // All the mass is the body's: the collider carries exactly none, so switching it out of
    // rapier and back in (`ContactGate`) leaves the body's mass properties bit for bit as they
    // were. They are the sum rapier forms of a massless box at its offset and the chassis.
    let massless_box = Cuboid::new(Vec3::new(c.length_m / 2.0, c.width_m / 2.0, box_half_h))
        .mass_properties(0.0)
        .transform_by(&Pose::from_translation(box_offset));
    let mass = massless_box + MassProperties::new(Vec3::ZERO, c.mass_kg, model.inertia());
    let body = RigidBodyBuilder::dynamic()
        .pose(Pose::from_parts(pos, rot))
        .linvel(forward * spawn.speed_mps)
        .additional_mass_properties(mass)
        // Forces are set afresh every tick; a sleeping car would ignore its driver.
        .can_sleep(false)
        .build();
    let collider = ColliderBuilder::cuboid(c.length_m / 2.0, c.width_m / 2.0, box_half_h)
        .translation(box_offset)
        .mass_properties(MassProperties::new(Vec3::ZERO, 0.0, Vec3::ZERO))
        .friction(0.3)
        .collision_groups(InteractionGroups::new(
            VEHICLE_GROUP,
            VEHICLE_GROUP | GUARDRAIL_GROUP | GROUND_GROUP,
            InteractionTestMode::And,
        ))
        .active_events(ActiveEvents::COLLISION_EVENTS)
        .active_hooks(ActiveHooks::FILTER_CONTACT_PAIRS)
        .user_data(vehicle_tag(entity))
        .build();
    let Some(mut physics) = world.get_resource_mut::<Physics>() else {
        return Err(SpawnError::NoPhysics);
    };
    let (handle, collider) = physics.world.insert(body, collider);
    world.entity_mut(entity).insert((
        Chassis { body: handle },
        FreeBody::default(),
        ContactGate::new(
            collider,
            Vec3::new(c.length_m / 2.0, c.width_m / 2.0, box_half_h),
            box_centre_z,
        ),
    ));
    Ok(entity)
}

impl Command for VehicleSpawn {
    type Out = ();

    fn apply(self, world: &mut World) {
        // A command has nowhere to return an error; spawners check their road first, so this
        // only reports a bug.
        if let Err(e) = spawn_vehicle(world, self) {
            tracing::warn!("vehicle not spawned: {e}");
        }
    }
}

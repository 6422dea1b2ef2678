//! What a vehicle is made of in the ECS world: its type, body, inputs, internal state, motion
//! and place on the roads.

use crate::drivetrain::{Driveline, Gearbox, Pedals, RPM_TO_RAD_S};
use crate::params::VehicleParams;
use crate::physics::{GRAVITY, Physics};
use crate::tyre::Tyre;
use bevy_ecs::lifecycle::HookContext;
use bevy_ecs::prelude::*;
use bevy_ecs::world::DeferredWorld;
use flockway_road::{RoadCursor, RoadGeometry, RoadId};
use glam::{DVec3, Quat, Vec3};
use rapier3d::prelude::*;
use std::sync::Arc;

/// Wheel order everywhere: front left, front right, rear left, rear right.
pub const WHEEL_NAMES: [&str; 4] = ["front_left", "front_right", "rear_left", "rear_right"];

/// Friction scale on the ground off the road (grass, gravel).
pub const OFF_ROAD_FRICTION: f32 = 0.6;

/// How far past the painted edge the road surface still carries a wheel, m (the shoulder).
pub const SHOULDER_M: f64 = 0.5;

/// The driver's inputs: the only thing a driver writes.
#[derive(Component, Debug, Clone, Copy, Default, PartialEq)]
pub struct Controls {
    /// −1..1: positive accelerates, negative brakes, and from a standstill reverses.
    pub throttle: f32,
    /// −1..1: positive steers left.
    pub steering: f32,
    /// Locks the rear wheels.
    pub handbrake: bool,
}

/// A vehicle type ready to simulate: its parameters and the constants derived from them.
#[derive(Debug, Clone, PartialEq)]
pub struct VehicleType {
    /// The definition it came from.
    pub params: VehicleParams,
    /// Combined-slip tyre model.
    pub tyre: Tyre,
    /// Drivetrain constants.
    pub driveline: Driveline,
    /// Suspension mount of each wheel in chassis space (x forward, y left, z up, origin at the
    /// centre of mass), where the wheel centre sits at full extension plus one radius.
    pub mounts_cs: [Vec3; 4],
    /// Static spring compression of each wheel at rest, m.
    pub rest_compression_m: [f32; 4],
}

impl VehicleType {
    /// Derives a simulation-ready type from validated parameters.
    pub fn new(params: VehicleParams) -> VehicleType {
        let c = &params.chassis;
        let w = &params.wheels;
        let g = -GRAVITY.z;
        let half_base = w.wheelbase_m / 2.0;
        // Static axle loads from the centre of mass position along the wheelbase.
        let front_share = (half_base + c.com_forward_m) / w.wheelbase_m;
        let front_load = c.mass_kg * g * front_share / 2.0;
        let rear_load = c.mass_kg * g * (1.0 - front_share) / 2.0;
        let k = params.suspension.stiffness_n_per_m;
        let rest = [front_load / k, front_load / k, rear_load / k, rear_load / k];
        let x_front = half_base - c.com_forward_m;
        let x_rear = -half_base - c.com_forward_m;
        let y = w.track_m / 2.0;
        let travel = params.suspension.travel_m;
        // Mount height above the road at rest is radius + travel − static compression, so the
        // body sits level with the centre of mass at its stated height.
        let mount_z = |i: usize| w.radius_m + travel - rest[i] - c.com_height_m;
        let mounts_cs = [
            Vec3::new(x_front, y, mount_z(0)),
            Vec3::new(x_front, -y, mount_z(1)),
            Vec3::new(x_rear, y, mount_z(2)),
            Vec3::new(x_rear, -y, mount_z(3)),
        ];
        VehicleType {
            tyre: Tyre::new(&params.tyres),
            driveline: Driveline::new(&params),
            mounts_cs,
            rest_compression_m: rest,
            params,
        }
    }

    /// Principal moments of inertia of the body (a uniform box), kg·m².
    pub fn inertia(&self) -> Vec3 {
        let c = &self.params.chassis;
        let m = c.mass_kg;
        let (l, w, h) = (c.length_m, c.width_m, c.height_m);
        Vec3::new(
            m * (w * w + h * h) / 12.0,
            m * (l * l + h * h) / 12.0,
            m * (l * l + w * w) / 12.0,
        )
    }
}

impl Default for VehicleType {
    fn default() -> Self {
        VehicleType::new(VehicleParams::default())
    }
}

/// Which vehicle type an entity is.
#[derive(Component, Debug, Clone)]
pub struct VehicleModel(pub Arc<VehicleType>);

/// The rapier body of a vehicle. Removing this component (or despawning the entity) removes the
/// body and its collider from the physics world.
#[derive(Component, Debug, Clone, Copy, PartialEq)]
#[component(on_remove = remove_chassis)]
pub struct Chassis {
    /// The dynamic body.
    pub body: RigidBodyHandle,
}

/// Whether a vehicle's body is in rapier's collision detection, and with what. Cars touch
/// only in crashes, yet rapier refits every moving car's box in its broad phase and searches
/// the tree for the car's new pairs every step; and a car's box on a curve or a diagonal road
/// overlaps the guardrail pieces beside it, a pair rapier then updates every step (a quarter
/// of the step with 10 000 cars on a ring). So a car's collider leaves rapier while no other
/// car's body is within reach and it is clearly away from its road's edges, and leaves the
/// guardrails out of its filter while clear of them; each comes back before anything can
/// reach the box, with room for the distance the two can close in two steps and a margin.
/// While its collider is out, its body is out of rapier too and integrated in its
/// [`FreeBody`](crate::FreeBody), which then holds the body's state. Contacts and motion are
/// the same as without gates, bit for bit.
#[derive(Component, Debug, Clone, Copy, PartialEq)]
pub struct ContactGate {
    pub(crate) collider: ColliderHandle,
    /// The collider box's half extents (length, width, height), m.
    pub(crate) half_extents: Vec3,
    /// Height of the box's centre above the centre of mass, m.
    pub(crate) offset_z_m: f32,
    /// Whether guardrails are in the collider's filter now.
    pub(crate) rails_open: bool,
    /// Whether they should be from the next step.
    pub(crate) want_rails: bool,
    /// Whether the collider is in rapier now.
    pub(crate) enabled: bool,
    /// Whether another car's body was within reach at the last search.
    pub(crate) near: bool,
}

/// Margin kept between a car's box and its road's edge (the guardrail's inner face) before the
/// gate opens, on top of the distance the box can move in two steps, m.
pub const RAIL_GATE_MARGIN_M: f32 = 0.3;

/// How much further from the edge a car must be before an open gate closes again, m (so a car
/// driving along the threshold does not toggle its collider every step).
pub(crate) const RAIL_GATE_HYSTERESIS_M: f32 = 0.3;

/// Within this distance of an open road's ends the gate stays open: the next road's guardrails
/// are near, and the edge of the road the car tracks no longer bounds where it can go, m. At a
/// bare end ([`Physics::bare_ends`](crate::Physics::bare_ends)), with nothing of another road
/// near, it stays open only while the box reaches past the end.
pub(crate) const RAIL_GATE_END_M: f64 = 10.0;

/// Margin kept between two cars' boxes before both colliders go into rapier, on top of the
/// distance the two can close in two steps, m.
pub const CONTACT_GATE_MARGIN_M: f32 = 0.3;

/// How much further apart two cars must be before their colliders leave rapier again, m.
pub(crate) const CONTACT_GATE_HYSTERESIS_M: f32 = 0.5;

impl ContactGate {
    /// A gate for a body's collider box (half extents, its centre's height above the centre of
    /// mass), open: the collider in rapier with guardrails in its filter.
    pub fn new(collider: ColliderHandle, half_extents: Vec3, offset_z_m: f32) -> ContactGate {
        ContactGate {
            collider,
            half_extents,
            offset_z_m,
            rails_open: true,
            want_rails: true,
            enabled: true,
            near: true,
        }
    }

    /// Whether guardrails are in the collider's filter.
    pub fn rails_open(&self) -> bool {
        self.rails_open
    }

    /// Whether the collider is in rapier's collision detection.
    pub fn in_rapier(&self) -> bool {
        self.enabled
    }
}

fn remove_chassis(mut world: DeferredWorld, ctx: HookContext) {
    let Some(chassis) = world.get::<Chassis>(ctx.entity).copied() else {
        return;
    };
    if let Some(mut physics) = world.get_resource_mut::<Physics>() {
        physics.world.remove_body(chassis.body);
    }
}

/// One wheel's state, updated every tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelState {
    /// Spin speed, rad/s (positive rolls forward).
    pub omega: f32,
    /// Road-wheel steering angle, rad (positive left).
    pub steer_rad: f32,
    /// Spring compression, m (0 with the wheel hanging free).
    pub compression_m: f32,
    /// Load on the tyre, N.
    pub load_n: f32,
    /// Longitudinal slip ratio.
    pub slip_ratio: f32,
    /// Slip angle, rad.
    pub slip_angle_rad: f32,
    /// Longitudinal tyre force, N.
    pub force_long_n: f32,
    /// Lateral tyre force, N.
    pub force_lat_n: f32,
    /// Driveline torque on the wheel last tick, N·m.
    pub drive_torque_nm: f32,
    /// Friction multiplier set by the surface under the wheel (a wet-road trigger), 1 when dry.
    pub friction_scale: f32,
    /// Whether the tyre touches the road or ground.
    pub grounded: bool,
}

impl Default for WheelState {
    fn default() -> Self {
        WheelState {
            omega: 0.0,
            steer_rad: 0.0,
            compression_m: 0.0,
            load_n: 0.0,
            slip_ratio: 0.0,
            slip_angle_rad: 0.0,
            force_long_n: 0.0,
            force_lat_n: 0.0,
            drive_torque_nm: 0.0,
            friction_scale: 1.0,
            grounded: false,
        }
    }
}

/// The internal state of a vehicle: wheels, engine, gearbox and steering position.
#[derive(Component, Debug, Clone, PartialEq)]
pub struct VehicleState {
    /// Wheels in order FL, FR, RL, RR.
    pub wheels: [WheelState; 4],
    /// Gear and shift in progress.
    pub gearbox: Gearbox,
    /// Engine speed, rad/s.
    pub engine_omega: f32,
    /// Clutch engagement 0..1 last tick.
    pub clutch: f32,
    /// Steering position −1..1 after the rate limit.
    pub steer: f32,
    /// How the throttle axis was interpreted last tick.
    pub pedals: Pedals,
}

impl VehicleState {
    /// Engine speed, rpm.
    pub fn rpm(&self) -> f32 {
        self.engine_omega / RPM_TO_RAD_S
    }
}

/// Where a vehicle is and how it moves, read back from rapier after each step.
#[derive(Component, Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// Centre of mass, m.
    pub position: Vec3,
    /// Orientation (x forward, y left, z up in the body).
    pub rotation: Quat,
    /// Velocity, m/s.
    pub linvel: Vec3,
    /// Angular velocity, rad/s.
    pub angvel: Vec3,
    /// Speed along the body's forward axis, m/s (negative reversing).
    pub forward_mps: f32,
    /// Rate of change of `forward_mps` over the last step, m/s².
    pub accel_mps2: f32,
}

impl Motion {
    /// Unit forward axis of the body.
    pub fn forward(&self) -> Vec3 {
        self.rotation * Vec3::X
    }

    /// Unit left axis of the body.
    pub fn left(&self) -> Vec3 {
        self.rotation * Vec3::Y
    }

    /// Unit up axis of the body.
    pub fn up(&self) -> Vec3 {
        self.rotation * Vec3::Z
    }
}

/// A vehicle's place on the road network, updated after each physics step.
#[derive(Component, Debug, Clone, Copy, PartialEq)]
pub struct RoadTrack {
    /// The road it is on (or was last on).
    pub road: RoadId,
    /// Arc position of the centre of mass, m.
    pub s_m: f64,
    /// Lateral offset from the centre line, m (positive left).
    pub lateral_m: f64,
    /// Lane under the centre of mass.
    pub lane: u32,
    /// Whether the centre of mass is over the road surface.
    pub on_road: bool,
    /// Cosine of the angle between the body's forward axis and the road direction.
    pub heading_cos: f32,
    /// Unit road direction at `s_m`.
    pub tangent: Vec3,
    /// Unit vector across the road towards its left edge at `s_m` (banked with the road).
    pub left: Vec3,
    /// Road width at `s_m`, m.
    pub width_m: f32,
    /// Speed along the road direction, m/s (negative going backwards).
    pub speed_along_mps: f32,
    /// The road it means to take at this road's end (its route's next road), if it has a
    /// choice; otherwise it follows its lane's link.
    pub next_road: Option<RoadId>,
    pub(crate) cursor: RoadCursor,
}

impl RoadTrack {
    /// A track at an arc position of a road.
    pub fn new(road: RoadId, geometry: &RoadGeometry, s_m: f64, lateral_m: f64) -> RoadTrack {
        let frame = geometry.frame_at(s_m);
        RoadTrack {
            road,
            s_m,
            lateral_m,
            lane: geometry.lane_at_offset(lateral_m, frame.width_m),
            on_road: true,
            heading_cos: 1.0,
            tangent: frame.tangent.as_vec3(),
            left: frame.left.as_vec3(),
            width_m: frame.width_m as f32,
            speed_along_mps: 0.0,
            next_road: None,
            cursor: geometry.cursor_at(s_m),
        }
    }
}

impl RoadTrack {
    /// The road's unit tangent `ds_m` along the road from this track's position (on this road;
    /// `None` past the end of an open road), as [`RoadGeometry::frame_near`]'s frame has it.
    // Inlined into both builds (x86-64 and AVX2) of the per-car functions that call it.
    #[inline(always)]
    pub fn tangent_ahead(&self, geometry: &RoadGeometry, ds_m: f64) -> Option<DVec3> {
        geometry.tangent_near(&self.cursor, ds_m)
    }
}

/// The force and torque a vehicle puts on its rapier body this tick.
#[derive(Component, Debug, Clone, Copy, Default, PartialEq)]
pub struct BodyForces {
    /// Total force at the centre of mass, N (gravity excluded: rapier adds it).
    pub force: Vec3,
    /// Total torque about the centre of mass, N·m.
    pub torque: Vec3,
}

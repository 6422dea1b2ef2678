//! Vehicles in the ECS world: components, spawning, and the per-tick force and state systems.

use crate::drivetrain::{Driveline, Gearbox, Pedals, RPM_TO_RAD_S, SpinInput, apply_brake};
use crate::params::VehicleParams;
use crate::physics::{GRAVITY, GROUND_GROUP, GUARDRAIL_GROUP, Physics, VEHICLE_GROUP, vehicle_tag};
use crate::steering::{ackermann, slew};
use crate::tyre::Tyre;
use bevy_ecs::lifecycle::HookContext;
use bevy_ecs::prelude::*;
use bevy_ecs::world::DeferredWorld;
use flockway_core::{DT_S, Vehicle};
use flockway_road::{RoadCursor, RoadFrame, RoadGeometry, RoadId, RoadNetwork};
use glam::{DVec3, Quat, Vec3};
use rapier3d::prelude::*;
use std::sync::Arc;

/// Wheel order everywhere: front left, front right, rear left, rear right.
pub const WHEEL_NAMES: [&str; 4] = ["front_left", "front_right", "rear_left", "rear_right"];

/// Friction scale on the ground off the road (grass, gravel).
pub const OFF_ROAD_FRICTION: f32 = 0.6;

/// How far past the painted edge the road surface still carries a wheel, m (the shoulder).
pub const SHOULDER_M: f64 = 0.5;

/// Stiffness of the bump stop relative to the spring.
const BUMP_STOP_FACTOR: f32 = 10.0;

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

/// Whether a vehicle's body can touch guardrails in rapier. A car's bounding box on a curve or
/// a diagonal road overlaps the guardrail pieces beside it, and rapier then updates that pair
/// every step (a quarter of the step with 10 000 cars on a ring); so the car's collider ignores
/// guardrails while its box is clearly away from its road's edges, and takes them in again
/// before it can reach one. Contacts are the same: the gate opens with room for twice the
/// distance the box's side can move in one step.
#[derive(Component, Debug, Clone, Copy, PartialEq)]
pub struct RailGate {
    collider: ColliderHandle,
    half_length_m: f32,
    half_width_m: f32,
    /// Whether guardrails are in the collider's filter now.
    open: bool,
    /// Whether they should be from the next step.
    want_open: bool,
}

/// Margin kept between a car's box and its road's edge (the guardrail's inner face) before the
/// gate opens, on top of the distance the box can move in two steps, m.
pub const RAIL_GATE_MARGIN_M: f32 = 0.3;

/// How much further from the edge a car must be before an open gate closes again, m (so a car
/// driving along the threshold does not toggle its collider every step).
const RAIL_GATE_HYSTERESIS_M: f32 = 0.3;

/// Within this distance of an open road's ends the gate stays open: the next road's guardrails
/// are near, and the edge of the road the car tracks no longer bounds where it can go, m.
const RAIL_GATE_END_M: f64 = 10.0;

impl RailGate {
    /// A gate for a body's collider with the box's half length and width, open.
    pub fn new(collider: ColliderHandle, half_length_m: f32, half_width_m: f32) -> RailGate {
        RailGate {
            collider,
            half_length_m,
            half_width_m,
            open: true,
            want_open: true,
        }
    }

    /// Whether guardrails are in the collider's filter.
    pub fn is_open(&self) -> bool {
        self.open
    }

    /// Decides from the car's track and motion whether guardrails must be in its filter for the
    /// next step.
    fn decide(&mut self, network: &RoadNetwork, track: &RoadTrack, motion: &Motion) {
        let near_end = network.get(track.road).is_none_or(|g| {
            !g.is_closed()
                && (track.s_m < RAIL_GATE_END_M || track.s_m > g.length_m() - RAIL_GATE_END_M)
        });
        let upright = (motion.rotation * Vec3::Z).z > 0.8;
        if near_end || !track.on_road || !upright {
            self.want_open = true;
            return;
        }
        // The box's reach across the road: its half width and half length turned by the
        // heading, plus up to 0.1 m more at its corners on a curve of 26 m radius or wider.
        let cos = track.heading_cos.abs().min(1.0);
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let reach = self.half_length_m * sin + self.half_width_m * cos + 0.1;
        let edge = 0.5 * track.width_m + flockway_road::GUARDRAIL_OFFSET_M as f32;
        let clearance = edge - (track.lateral_m.abs() as f32 + reach);
        // How far the box's side can move in two steps: sliding across, and turning.
        let across = motion.linvel.dot(track.left).abs();
        let turning = motion.angvel.z.abs() * self.half_length_m;
        let moves = 2.0 * DT_S as f32 * (across + turning);
        let needed = moves + RAIL_GATE_MARGIN_M;
        self.want_open = if self.open {
            clearance < needed + RAIL_GATE_HYSTERESIS_M
        } else {
            clearance < needed
        };
    }
}

/// Puts guardrails into or out of each vehicle collider's filter as its [`RailGate`] decided.
pub fn gate_guardrails(mut physics: ResMut<Physics>, mut gates: Query<&mut RailGate>) {
    let gating = physics.rail_gates;
    for mut gate in &mut gates {
        let want_open = gate.want_open || !gating;
        if want_open == gate.open {
            continue;
        }
        let filter = if want_open {
            VEHICLE_GROUP | GUARDRAIL_GROUP | GROUND_GROUP
        } else {
            VEHICLE_GROUP | GROUND_GROUP
        };
        if let Some(collider) = physics.world.colliders.get_mut(gate.collider) {
            collider.set_collision_groups(InteractionGroups::new(
                VEHICLE_GROUP,
                filter,
                InteractionTestMode::And,
            ));
        }
        gate.open = want_open;
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
    cursor: RoadCursor,
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
            cursor: geometry.cursor_at(s_m),
        }
    }
}

impl RoadTrack {
    /// The exact road cross-section `ds_m` along the road from this track's position (on this
    /// road; `None` past the end of an open road).
    pub fn frame_ahead(&self, geometry: &RoadGeometry, ds_m: f64) -> Option<RoadFrame> {
        geometry.frame_near(&self.cursor, self.s_m, ds_m)
    }
}

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
    let body = RigidBodyBuilder::dynamic()
        .pose(Pose::from_parts(pos, rot))
        .linvel(forward * spawn.speed_mps)
        .additional_mass_properties(MassProperties::new(Vec3::ZERO, c.mass_kg, model.inertia()))
        // Forces are set afresh every tick; a sleeping car would ignore its driver.
        .can_sleep(false)
        .build();
    // The body box spans ground clearance to roof, placed relative to the centre of mass.
    let box_half_h = (c.height_m - c.ground_clearance_m) / 2.0;
    let box_centre_z = c.ground_clearance_m + box_half_h - c.com_height_m;
    let collider = ColliderBuilder::cuboid(c.length_m / 2.0, c.width_m / 2.0, box_half_h)
        .translation(Vec3::new(0.0, 0.0, box_centre_z))
        .density(0.0)
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
        RailGate::new(collider, c.length_m / 2.0, c.width_m / 2.0),
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

/// The road surface under one wheel: a point on it and its normal, with its friction.
#[derive(Debug, Clone, Copy)]
struct Surface {
    point: Vec3,
    normal: Vec3,
    friction: f32,
}

/// The exact road cross-section under an axle `offset_m` ahead of the centre of mass: stepped
/// from the vehicle's road cursor, or through a connection onto the next road near an end.
fn axle_frame(network: &RoadNetwork, track: &RoadTrack, offset_m: f32) -> Option<RoadFrame> {
    let ds = f64::from(offset_m * track.heading_cos);
    let geometry = network.get(track.road)?;
    if let Some(frame) = geometry.frame_near(&track.cursor, track.s_m, ds) {
        return Some(frame);
    }
    let (road, s) = network.advance(track.road, track.s_m, ds)?;
    Some(network.get(road)?.frame_at(s))
}

/// The force and torque on one vehicle's body this tick (suspension, tyres, drag), advancing
/// its wheels, engine, gearbox and steering. Reads the physics world only, so vehicles can be
/// computed in parallel; `None` if its body is gone.
fn vehicle_forces(
    physics: &Physics,
    network: &RoadNetwork,
    controls: &Controls,
    model: &VehicleModel,
    chassis: &Chassis,
    track: &RoadTrack,
    state: &mut VehicleState,
) -> Option<(Vec3, Vec3)> {
    let h = DT_S as f32;
    let body = physics.world.bodies.get(chassis.body)?;
    let t: &VehicleType = &model.0;
    let p = &t.params;
    let pose = *body.position();
    let com = pose.translation;
    let rot = pose.rotation;
    let v = body.linvel();
    let w = body.angvel();
    let fwd = rot * Vec3::X;
    let up = rot * Vec3::Z;
    let down = -up;
    let forward_mps = v.dot(fwd);

    // Gearbox and clutch. Shifts follow the wheels' speed through the gear, not the
    // (possibly slipping) engine.
    let shares = t.driveline.shares;
    let wbar: f32 = (0..4).map(|i| shares[i] * state.wheels[i].omega).sum();
    let ratio_now = state.gearbox.ratio(&p.gearbox);
    let input_rpm = (wbar * ratio_now).abs() / RPM_TO_RAD_S;
    let pedals = state
        .gearbox
        .update(&p.gearbox, controls.throttle, forward_mps, input_rpm, h);
    let ratio = state.gearbox.ratio(&p.gearbox);
    let input_rpm = (wbar * ratio).abs() / RPM_TO_RAD_S;
    let clutch = if state.gearbox.shifting() || ratio == 0.0 {
        0.0
    } else if input_rpm >= p.engine.idle_rpm {
        1.0
    } else {
        // Pulling away: the automatic clutch slips in proportion to the accelerator, and is
        // open with no accelerator, so a car at rest does not creep.
        pedals.accelerator
    };

    // Steering.
    state.steer = slew(state.steer, controls.steering, p.steering.rate_per_s, h);
    let centre = p
        .steering
        .center_angle_rad(state.steer, forward_mps.abs() * 3.6);
    let (steer_l, steer_r) = ackermann(centre, p.wheels.wheelbase_m, p.wheels.track_m);
    let steer = [steer_l, steer_r, 0.0, 0.0];

    // Road frames under the two axles (one exact spline evaluation each).
    let axle_x = [t.mounts_cs[0].x, t.mounts_cs[2].x];
    let frames = [
        axle_frame(network, track, axle_x[0]),
        axle_frame(network, track, axle_x[1]),
    ];

    // Suspension: spring, damper and bump stop along the surface normal.
    let travel = p.suspension.travel_m;
    let k = p.suspension.stiffness_n_per_m;
    let c = p.suspension.damping_n_s_per_m;
    let r = p.wheels.radius_m;
    let mut surfaces: [Option<Surface>; 4] = [None; 4];
    let mut compression = [0.0f32; 4];
    let mut spring = [0.0f32; 4];
    for i in 0..4 {
        let mount = com + rot * t.mounts_cs[i];
        let surface = match &frames[i / 2] {
            Some(frame) => {
                let origin = frame.pos.as_vec3();
                let n = frame.up.as_vec3();
                let dn = down.dot(n);
                let lateral = f64::from((mount - origin).dot(frame.left.as_vec3()));
                let dist = (origin - mount).dot(n) / dn;
                // A wheel far above or below this surface (a bridge overhead, a fall) is not
                // on it.
                if dn < -0.2
                    && lateral.abs() <= frame.width_m / 2.0 + SHOULDER_M
                    && (0.0..=travel + r + 0.5).contains(&dist)
                {
                    Some((
                        dist,
                        Surface {
                            point: mount + down * dist,
                            normal: n,
                            friction: 1.0,
                        },
                    ))
                } else {
                    None
                }
            }
            None => None,
        };
        // No road under this wheel: ask rapier for the ground (off-road, after a crash).
        let surface = surface.or_else(|| {
            physics
                .cast_ground(mount, down, travel + r + 0.5)
                .map(|(dist, n)| {
                    (
                        dist,
                        Surface {
                            point: mount + down * dist,
                            normal: n,
                            friction: OFF_ROAD_FRICTION,
                        },
                    )
                })
        });
        if let Some((dist, s)) = surface {
            let x = travel - (dist - r);
            if x > 0.0 {
                let vm = v + w.cross(mount - com);
                let x_dot = vm.dot(s.normal) / down.dot(s.normal);
                let mut f = k * x + c * x_dot;
                if x > travel {
                    f += BUMP_STOP_FACTOR * k * (x - travel);
                }
                spring[i] = f.max(0.0);
                compression[i] = x;
                surfaces[i] = Some(s);
            }
        }
    }
    // Anti-roll bars move load from the less to the more compressed side of an axle.
    for axle in 0..2 {
        let (l, rr) = (2 * axle, 2 * axle + 1);
        let arb = p.suspension.anti_roll_n_per_m * (compression[l] - compression[rr]);
        if surfaces[l].is_some() {
            spring[l] = (spring[l] + arb).max(0.0);
        }
        if surfaces[rr].is_some() {
            spring[rr] = (spring[rr] - arb).max(0.0);
        }
    }

    // Tyres: forces at the current slips, with the longitudinal one linearised in wheel
    // speed for the implicit spin update below.
    let mass = p.chassis.mass_kg;
    let iw = t.driveline.wheel_inertia;
    // A quarter of the car's mass moves with each contact patch.
    let m_eff = mass / 4.0;
    let mut long = [0.0f32; 4];
    let mut slope = [0.0f32; 4];
    let mut vx_at = [0.0f32; 4];
    let mut grip_at = [0.0f32; 4];
    let mut dirs = [(Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO); 4];
    // Longitudinal force that would hold each contact still this step.
    let mut hold_x = [0.0f32; 4];
    // Gravity along the road, summed over the grounded wheels' shares.
    let mut slope_pull = 0.0f32;
    let mut brake_nm = [0.0f32; 4];
    for i in 0..4 {
        let ws = &mut state.wheels[i];
        ws.steer_rad = steer[i];
        ws.compression_m = compression[i];
        ws.load_n = spring[i];
        let Some(s) = surfaces[i] else {
            ws.grounded = false;
            ws.slip_ratio = 0.0;
            ws.slip_angle_rad = 0.0;
            ws.force_long_n = 0.0;
            ws.force_lat_n = 0.0;
            continue;
        };
        ws.grounded = true;
        let n = s.normal;
        // The rear wheels never steer: no trigonometry for them.
        let heading = if steer[i] == 0.0 {
            fwd
        } else {
            rot * Vec3::new(libm::cosf(steer[i]), libm::sinf(steer[i]), 0.0)
        };
        let f_dir = (heading - n * heading.dot(n)).normalize_or_zero();
        let l_dir = n.cross(f_dir);
        let arm = s.point - com;
        let vc = v + w.cross(arm);
        let vx = vc.dot(f_dir);
        let vy = vc.dot(l_dir);
        let v_ref = vx.abs().max(p.tyres.low_speed_mps);
        let slip_ratio = (ws.omega * r - vx) / v_ref;
        // Lateral slip as the tangent of the slip angle: the same as the angle in radians to
        // within 2 % below 14°, and it needs no arctangent.
        let slip_angle = vy / v_ref;
        let (cx, cy, dcx) = t.tyre.forces(slip_ratio, slip_angle);
        let grip = ws.friction_scale * s.friction * ws.load_n;
        // The lateral force may stop the sideways slide within this step but not reverse it:
        // at low speed the tyre's slope is far too stiff for an explicit step. Near a
        // standstill the tyre holds like static friction: it stops the slide and carries the
        // wheel's share of gravity along the slope, so a parked car on a bank does not creep.
        let gravity_share = m_eff * GRAVITY;
        let fy = if vx.abs() < p.tyres.low_speed_mps {
            let peak = grip * t.tyre.friction;
            (-m_eff * vy / h - gravity_share.dot(l_dir)).clamp(-peak, peak)
        } else {
            clamp_towards(cy * grip, -vy * m_eff / h)
        };
        hold_x[i] = -m_eff * vx / h;
        slope_pull += gravity_share.dot(f_dir);
        ws.slip_ratio = slip_ratio;
        ws.slip_angle_rad = slip_angle;
        ws.force_lat_n = fy;
        long[i] = cx * grip;
        // Linearise with the steeper of the tangent and the secant to the zero-slip point:
        // past the peak the tangent is flat, and an update using it would carry the wheel
        // straight through rolling speed into the opposite slip.
        let tangent = grip * dcx * r / v_ref;
        let rolling_omega = vx / r;
        let secant = if (ws.omega - rolling_omega).abs() > 1.0e-6 {
            (cx * grip / (ws.omega - rolling_omega)).max(0.0)
        } else {
            0.0
        };
        slope[i] = tangent.max(secant);
        vx_at[i] = vx;
        grip_at[i] = grip * t.tyre.friction;
        dirs[i] = (n, f_dir, l_dir, arm);
    }

    // Brakes and rolling resistance act first (they hold a wheel, never spin it backwards),
    // then wheel spin, engine and clutch are solved implicitly together with the tyres.
    let omega_now = state.wheels.map(|w| w.omega);
    let mut omega_braked = omega_now;
    for i in 0..4 {
        let ws = &state.wheels[i];
        let mut brake = pedals.brake * p.brakes.max_brake_torque_nm;
        if p.brakes.abs && forward_mps.abs() > 1.0 {
            // ABS holds the slip near the tyre's peak: full torque up to 70 % of the peak
            // slip, released linearly to none at 130 %, and never more than the tyre can
            // pass to the road.
            let excess = (-ws.slip_ratio / t.tyre.peak_slip_ratio - 0.7) / 0.6;
            let release = 1.0 - excess.clamp(0.0, 1.0);
            brake = (brake * release).min(grip_at[i] * r);
        }
        if controls.handbrake && i >= 2 {
            brake += p.brakes.max_handbrake_torque_nm;
        }
        brake += p.chassis.rolling_resistance * ws.load_n * r;
        brake_nm[i] = brake;
        omega_braked[i] = apply_brake(omega_now[i], brake, iw, h);
    }
    let spin = t.driveline.spin(
        &p.engine,
        &SpinInput {
            omega: omega_braked,
            omega_tyre: omega_now,
            tyre_force_n: long,
            tyre_slope: slope,
            engine_omega: state.engine_omega,
            accelerator: if state.gearbox.shifting() {
                0.0
            } else {
                pedals.accelerator
            },
            ratio,
            clutch,
        },
        h,
    );
    state.engine_omega = spin.engine_omega;
    if state.gearbox.shifting() {
        // The gearbox synchronises the engine to the gear it is shifting into, so the clutch
        // closes without a jolt.
        let target_ratio = Gearbox::ratio_of(&p.gearbox, state.gearbox.target);
        let target = (wbar * target_ratio)
            .abs()
            .clamp(t.driveline.idle_omega, t.driveline.max_omega);
        let left = state.gearbox.shift_left_s.max(h);
        state.engine_omega += (target - state.engine_omega) * (h / left).min(1.0);
    }
    state.clutch = clutch;
    state.pedals = pedals;

    // Braked wheels at a standstill hold the car by static friction, sharing between them
    // the pull of gravity along the slope (the free-rolling wheels carry none of it).
    let mut holding: [bool; 4] = std::array::from_fn(|i| {
        state.wheels[i].grounded
            && vx_at[i].abs() < p.tyres.low_speed_mps
            && spin.omega[i].abs() * r < p.tyres.low_speed_mps
            && brake_nm[i] > spin.drive_torque_nm[i].abs()
    });
    let mut holders = 1.0f32;
    // A wheel whose brake cannot carry its share drops out and the others share more; four
    // rounds settle any combination of four wheels.
    for _ in 0..4 {
        holders = holding.iter().filter(|&&b| b).count().max(1) as f32;
        let before = holding;
        for i in 0..4 {
            let need = (hold_x[i] - slope_pull / holders).abs() * r;
            holding[i] &= need <= brake_nm[i] - spin.drive_torque_nm[i].abs();
        }
        if holding == before {
            break;
        }
    }
    let mut force = Vec3::ZERO;
    let mut torque = Vec3::ZERO;
    for i in 0..4 {
        let ws = &mut state.wheels[i];
        ws.drive_torque_nm = spin.drive_torque_nm[i];
        ws.omega = spin.omega[i];
        if !ws.grounded {
            continue;
        }
        let hold = hold_x[i] - slope_pull / holders;
        let (n, f_dir, l_dir, arm) = dirs[i];
        // Keep the longitudinal force inside the friction ellipse left by the lateral one,
        // and never let it push the car past the wheel's own rolling speed in one step.
        let peak = grip_at[i];
        let room = (peak * peak - ws.force_lat_n * ws.force_lat_n)
            .max(0.0)
            .sqrt();
        let linear = spin.tyre_force_n[i];
        let fx = if holding[i]
            && hold.abs() * r <= brake_nm[i] - spin.drive_torque_nm[i].abs()
            && hold.abs() <= room
        {
            ws.omega = 0.0;
            hold
        } else {
            let fx = clamp_towards(
                linear.clamp(-room, room),
                (ws.omega * r - vx_at[i]) * m_eff / h,
            );
            // What the wheel did not pass to the road stays in its spin.
            ws.omega += h * r * (linear - fx) / iw;
            fx
        };
        ws.force_long_n = fx;
        let f = n * ws.load_n + f_dir * fx + l_dir * ws.force_lat_n;
        force += f;
        torque += arm.cross(f);
    }
    // Aerodynamic drag at the centre of mass.
    let ch = &p.chassis;
    let speed = v.length();
    force -= v * (0.5 * ch.air_density_kg_m3 * ch.drag_coefficient * ch.frontal_area_m2 * speed);
    Some((force, torque))
}

/// The force and torque a vehicle puts on its rapier body this tick.
#[derive(Component, Debug, Clone, Copy, Default, PartialEq)]
pub struct BodyForces {
    /// Total force at the centre of mass, N (gravity excluded: rapier adds it).
    pub force: Vec3,
    /// Total torque about the centre of mass, N·m.
    pub torque: Vec3,
}

/// Below this many vehicles the force computation runs on one thread: spreading a handful of
/// cars over the task pool costs more than it saves.
pub const PARALLEL_MIN_VEHICLES: usize = 128;

/// Computes suspension, tyre, drag and drivetrain forces for every vehicle and advances wheel
/// spin, engine and gearbox. Each vehicle reads only the physics world and writes only its own
/// components, so they run in parallel on the task pool with results independent of threads.
pub fn drive_vehicles(
    physics: Res<Physics>,
    network: Res<RoadNetwork>,
    mut vehicles: Query<(
        &Controls,
        &VehicleModel,
        &Chassis,
        &RoadTrack,
        &mut VehicleState,
        &mut BodyForces,
    )>,
) {
    let physics: &Physics = &physics;
    let network: &RoadNetwork = &network;
    let run = |(controls, model, chassis, track, mut state, mut out): (
        &Controls,
        &VehicleModel,
        &Chassis,
        &RoadTrack,
        Mut<VehicleState>,
        Mut<BodyForces>,
    )| {
        let (force, torque) = vehicle_forces(
            physics, network, controls, model, chassis, track, &mut state,
        )
        .unwrap_or_default();
        *out = BodyForces { force, torque };
    };
    if physics.world.bodies.len() < PARALLEL_MIN_VEHICLES {
        vehicles.iter_mut().for_each(run);
    } else {
        vehicles.par_iter_mut().for_each(run);
    }
}

/// Replaces every vehicle body's forces with this tick's (rapier keeps user forces until they
/// are reset, so adding them each tick would accumulate).
pub fn apply_body_forces(mut physics: ResMut<Physics>, vehicles: Query<(&Chassis, &BodyForces)>) {
    for (chassis, f) in &vehicles {
        if let Some(body) = physics.world.bodies.get_mut(chassis.body) {
            body.reset_forces(false);
            body.reset_torques(false);
            body.add_force(f.force, false);
            body.add_torque(f.torque, false);
        }
    }
}

/// Clamps a tyre force to lie between zero and the force that would stop the slip.
fn clamp_towards(force: f32, stop: f32) -> f32 {
    if stop >= 0.0 {
        force.clamp(0.0, stop)
    } else {
        force.clamp(stop, 0.0)
    }
}

/// Reads every vehicle's pose and velocity back from rapier and tracks it along the roads (in
/// parallel: each vehicle writes only its own components).
pub fn sync_vehicles(
    physics: Res<Physics>,
    network: Res<RoadNetwork>,
    mut vehicles: Query<(&Chassis, &mut Motion, &mut RoadTrack, Option<&mut RailGate>)>,
) {
    let physics: &Physics = &physics;
    let network: &RoadNetwork = &network;
    type Item<'a> = (
        &'a Chassis,
        Mut<'a, Motion>,
        Mut<'a, RoadTrack>,
        Option<Mut<'a, RailGate>>,
    );
    let run = |(chassis, mut motion, mut track, gate): Item| {
        let Some(body) = physics.world.bodies.get(chassis.body) else {
            return;
        };
        let h = DT_S as f32;
        let pose = *body.position();
        let rot = pose.rotation;
        let linvel = body.linvel();
        let forward_mps = linvel.dot(rot * Vec3::X);
        *motion = Motion {
            position: pose.translation,
            rotation: rot,
            linvel,
            angvel: body.angvel(),
            forward_mps,
            accel_mps2: (forward_mps - motion.forward_mps) / h,
        };
        track_road(
            network,
            &mut track,
            pose.translation.as_dvec3(),
            rot * Vec3::X,
        );
        track.speed_along_mps = linvel.dot(track.tangent);
        if let Some(mut gate) = gate {
            gate.decide(network, &track, &motion);
        }
    };
    if physics.world.bodies.len() < PARALLEL_MIN_VEHICLES {
        vehicles.iter_mut().for_each(run);
    } else {
        vehicles.par_iter_mut().for_each(run);
    }
}

/// Updates a road track for a new position: follows the current road with its cursor, moves on
/// to the next road past the end of an open one, and searches the network when off every road.
pub fn track_road(network: &RoadNetwork, track: &mut RoadTrack, pos: DVec3, forward: Vec3) {
    let Some(geometry) = network.get(track.road) else {
        track.on_road = false;
        return;
    };
    let (mut proj, mut frame) = geometry.project_tracked_frame(pos, &mut track.cursor);
    if !geometry.is_closed()
        && proj.s_m >= geometry.length_m() - 1.0e-6
        && let Some(next) = network.next(track.road)
        && let Some(g2) = network.get(next)
    {
        let mut cursor = g2.cursor_at(0.0);
        let (p2, f2) = g2.project_tracked_frame(pos, &mut cursor);
        if p2.distance_m <= proj.distance_m + 1.0e-6 {
            track.road = next;
            track.cursor = cursor;
            proj = p2;
            frame = f2;
        }
    }
    if !proj.on_road
        && let Some((id, p)) = network.project(pos)
        && p.on_road
        && id != track.road
        && let Some(g) = network.get(id)
    {
        track.road = id;
        track.cursor = g.cursor_at(p.s_m);
        proj = p;
        frame = g.frame_at(p.s_m);
    }
    track.heading_cos = forward.dot(frame.tangent.as_vec3());
    track.tangent = frame.tangent.as_vec3();
    track.left = frame.left.as_vec3();
    track.width_m = frame.width_m as f32;
    track.s_m = proj.s_m;
    track.lateral_m = proj.lateral_m;
    track.lane = proj.lane;
    track.on_road = proj.on_road;
}

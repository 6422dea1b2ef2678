//! One vehicle's forces for one tick, in named stages: the gearbox and clutch decide, the
//! steering moves, each wheel finds its contact and spring load, the tyres' forces are taken at
//! the current slips, the brakes (with ABS) act, the driveline and wheels spin up together, the
//! braked wheels of a car at a standstill hold it, and the contact forces and drag add up to one
//! force and torque on the body.
//!
//! Every stage is a function of what the stages before it found, so each is tested on its own.

use crate::components::{
    Controls, OFF_ROAD_FRICTION, RoadTrack, SHOULDER_M, VehicleModel, VehicleState, VehicleType,
};
use crate::drivetrain::{Gearbox, Pedals, RPM_TO_RAD_S, SpinInput, SpinOutput};
use crate::lanes::{self, F4, Vec3x4};
use crate::params::VehicleParams;
use crate::physics::{GRAVITY, Physics};
use crate::steering::{ackermann, slew};
use flockway_core::DT_S;
use flockway_core::arrays::{array2, array4};
use flockway_road::{RoadFrame, RoadNetwork};
use glam::{Quat, Vec3};
use wide::f32x4;

/// Stiffness of the bump stop relative to the spring.
const BUMP_STOP_FACTOR: f32 = 10.0;

/// The body's pose and velocity this tick (from rapier, or its [`FreeBody`](crate::FreeBody)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Kinematics {
    /// Centre of mass, m.
    pub com: Vec3,
    /// Orientation.
    pub rot: Quat,
    /// Velocity, m/s.
    pub v: Vec3,
    /// Angular velocity, rad/s.
    pub w: Vec3,
}

impl Kinematics {
    fn forward(&self) -> Vec3 {
        self.rot * Vec3::X
    }

    fn down(&self) -> Vec3 {
        -(self.rot * Vec3::Z)
    }
}

/// What the gearbox and clutch decided for this tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Transmission {
    /// The throttle axis read as accelerator and brake.
    pub pedals: Pedals,
    /// Signed overall ratio in the gear now engaged (0 while shifting into neutral).
    pub ratio: f32,
    /// Clutch engagement, 0..1.
    pub clutch: f32,
    /// The wheels' spin speed as the driveline sees it (weighted by torque share), rad/s.
    pub driven_omega: f32,
}

/// Where each wheel touches, one array per quantity (wheel order as everywhere: front left,
/// front right, rear left, rear right). A wheel in the air has zeros in every field.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct WheelContacts {
    /// Whether the wheel is on a surface.
    pub grounded: [bool; 4],
    /// Where each suspension line meets its surface, m.
    pub point: Vec3x4,
    /// Each surface's unit normal.
    pub normal: Vec3x4,
    /// Each surface's friction relative to dry asphalt.
    pub friction: F4,
    /// Spring compression, m.
    pub compression_m: F4,
    /// Load on the tyre (spring, damper, bump stop, anti-roll), N.
    pub load_n: F4,
}

/// The tyres' state after the tyre stage, one array per quantity: their force directions and
/// what the later stages need of them. A wheel in the air has zeros in every field.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct TyrePatches {
    /// Surface normals.
    pub normal: Vec3x4,
    /// The tyres' forward directions in the surface.
    pub forward: Vec3x4,
    /// Their lateral directions in the surface.
    pub lateral: Vec3x4,
    /// The contacts' arms from the centre of mass, m.
    pub arm: Vec3x4,
    /// Longitudinal force at the current slip, N.
    pub long_n: F4,
    /// How fast that force grows with wheel speed, N·s/rad (for the implicit spin update).
    pub slope: F4,
    /// Contact point's speed along the tyre's forward direction, m/s.
    pub vx: F4,
    /// The most force the tyre can pass to the road, N.
    pub peak_n: F4,
    /// Longitudinal force that would hold the contact still this step, N.
    pub hold_n: F4,
}

/// Stage 1, gearbox and clutch: shifts follow the wheels' speed through the gear, not the
/// (possibly slipping) engine; pulling away, the clutch slips in proportion to the accelerator.
// Inlined into both builds (x86-64 and AVX2) of the force pass's per-car step.
#[inline(always)]
pub(crate) fn gearbox_and_clutch(
    t: &VehicleType,
    controls: &Controls,
    state: &mut VehicleState,
    forward_mps: f32,
    h: f32,
) -> Transmission {
    let p = &t.params;
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
    Transmission {
        pedals,
        ratio,
        clutch,
        driven_omega: wbar,
    }
}

/// Stage 2, steering: the wheel moves towards the input at the steering rate, and the road
/// wheels take their Ackermann angles (the rear wheels never steer).
// Inlined into both builds (x86-64 and AVX2) of the force pass's per-car step.
#[inline(always)]
pub(crate) fn steer_wheels(
    p: &VehicleParams,
    controls: &Controls,
    state: &mut VehicleState,
    forward_mps: f32,
    h: f32,
) -> [f32; 4] {
    state.steer = slew(state.steer, controls.steering, p.steering.rate_per_s, h);
    let centre = p
        .steering
        .center_angle_rad(state.steer, forward_mps.abs() * 3.6);
    let (steer_l, steer_r) = ackermann(centre, p.wheels.wheelbase_m, p.wheels.track_m);
    [steer_l, steer_r, 0.0, 0.0]
}

/// The exact road cross-sections under the axles `offsets_m` ahead of the centre of mass: stepped
/// from the vehicle's road cursor (the two together), or through a connection onto the next road
/// near an end.
// Inlined into both builds (x86-64 and AVX2) of the force pass's per-car step.
#[inline(always)]
fn axle_frames(
    network: &RoadNetwork,
    track: &RoadTrack,
    offsets_m: [f32; 2],
) -> [Option<RoadFrame>; 2] {
    let Some(geometry) = network.get(track.road) else {
        return [None, None];
    };
    let ds = array2(|i| f64::from(offsets_m[i] * track.heading_cos));
    let near = geometry.frames_near(&track.cursor, track.s_m, ds);
    array2(|i| {
        near[i].or_else(|| {
            let (road, s) = network.advance(track.road, track.s_m, ds[i])?;
            Some(network.get(road)?.frame_at(s))
        })
    })
}

/// Stage 3, wheel contact: the road cross-section under each axle (one exact spline evaluation
/// each), each wheel's suspension line meeting that banked, sloped surface, rapier's ground
/// where no road is under a wheel, and the spring, damper and bump stop along the surface normal,
/// with anti-roll bars moving load from the less to the more compressed side of an axle.
// Inlined into both builds (x86-64 and AVX2) of the force pass's per-car step.
#[inline(always)]
pub(crate) fn wheel_contact(
    physics: &Physics,
    network: &RoadNetwork,
    t: &VehicleType,
    track: &RoadTrack,
    body: &Kinematics,
    out: &mut WheelContacts,
) {
    let p = &t.params;
    let Kinematics { com, rot, v, w } = *body;
    let down = body.down();
    let frames = axle_frames(network, track, [t.mounts_cs[0].x, t.mounts_cs[2].x]);
    let travel = p.suspension.travel_m;
    let k = p.suspension.stiffness_n_per_m;
    let c = p.suspension.damping_n_s_per_m;
    let r = p.wheels.radius_m;
    // The geometry of all four wheels at once: mounts, their offsets from each axle's road
    // cross-section, and their velocities (a wheel off the road ignores its lanes).
    let com4 = Vec3x4::splat(com);
    let mounts = com4 + Vec3x4::from_fn(|i| t.mounts_cs[i]).rotated_by(rot);
    let on_frame = |f: fn(&RoadFrame) -> Vec3| {
        Vec3x4::from_fn(|i| frames[i / 2].as_ref().map_or(Vec3::ZERO, f))
    };
    let origin = on_frame(|f| f.pos.as_vec3());
    let up = on_frame(|f| f.up.as_vec3());
    let left = on_frame(|f| f.left.as_vec3());
    let dn = Vec3x4::splat(down).dot(up);
    let lateral = (mounts - origin).dot(left).to_array();
    let dist = (origin - mounts).dot(up) / dn;
    let velocity = Vec3x4::splat(v) + Vec3x4::splat(w).cross(mounts - com4);
    // A wheel far above or below the road's surface (a bridge overhead, a fall) is not on it:
    // on the road is facing its surface, within reach of it, and over the road's width (its
    // shoulders included).
    let reach = travel + r + 0.5;
    let facing_in_reach = (dn.simd_lt(f32x4::splat(-0.2))
        & dist.simd_ge(f32x4::ZERO)
        & dist.simd_le(f32x4::splat(reach)))
    .to_bitmask();
    let on_road: [bool; 4] = array4(|i| {
        facing_in_reach >> i & 1 != 0
            && frames[i / 2].as_ref().is_some_and(|frame| {
                f64::from(lateral[i]).abs() <= frame.width_m / 2.0 + SHOULDER_M
            })
    });
    // Each wheel's surface: the road's where the wheel is over it, else rapier's ground (off
    // the road, after a crash), else none.
    let (has_surface, dist, normal, friction) = if on_road == [true; 4] {
        ([true; 4], dist, up, [1.0f32; 4])
    } else {
        let dist = dist.to_array();
        let mut has_surface = [false; 4];
        let mut surface_dist = [0.0f32; 4];
        let mut normal = Vec3x4::default();
        let mut friction = [0.0f32; 4];
        for i in 0..4 {
            let surface = if on_road[i] {
                Some((dist[i], up.lane(i), 1.0))
            } else {
                physics
                    .cast_ground(mounts.lane(i), down, reach)
                    .map(|(dist, n)| (dist, n, OFF_ROAD_FRICTION))
            };
            if let Some((d, n, mu)) = surface {
                has_surface[i] = true;
                surface_dist[i] = d;
                normal.set(i, n);
                friction[i] = mu;
            }
        }
        (has_surface, f32x4::new(surface_dist), normal, friction)
    };
    // The springs, dampers and bump stops of all four at once.
    let (travel4, k4) = (f32x4::splat(travel), f32x4::splat(k));
    let x = travel4 - (dist - f32x4::splat(r));
    let compressed = x.simd_gt(f32x4::ZERO).to_bitmask();
    let grounded: [bool; 4] = array4(|i| has_surface[i] && compressed >> i & 1 != 0);
    let x_dot = velocity.dot(normal) / Vec3x4::splat(down).dot(normal);
    let f = k4 * x + f32x4::splat(c) * x_dot;
    let bump = f + f32x4::splat(BUMP_STOP_FACTOR * k) * (x - travel4);
    let f = x.simd_gt(travel4).select(bump, f).max(f32x4::ZERO);
    // Anti-roll bars: each moves load from the less to the more compressed side of its axle.
    let on = lanes::mask(grounded);
    let x = on.select(x, f32x4::ZERO);
    let xs = x.to_array();
    let arb: [f32; 2] = array2(|a| p.suspension.anti_roll_n_per_m * (xs[2 * a] - xs[2 * a + 1]));
    let shift = f32x4::new([arb[0], -arb[0], arb[1], -arb[1]]);
    let load = on.select((f + shift).max(f32x4::ZERO), f32x4::ZERO);
    *out = WheelContacts {
        grounded,
        point: (mounts + Vec3x4::splat(down) * dist).masked(grounded),
        normal: normal.masked(grounded),
        friction: on.select(f32x4::new(friction), f32x4::ZERO).to_array(),
        compression_m: xs,
        load_n: load.to_array(),
    };
}

/// A wheel's heading in the body's frame at steering angle `steer` (rad): +x unsteered.
// Inlined into both builds (x86-64 and AVX2) of the per-car functions that call it.
#[inline(always)]
fn steered_heading(steer: f32) -> Vec3 {
    if steer == 0.0 {
        Vec3::X
    } else {
        // One range reduction for both: every f32's sine and cosine from `sincosf` are `sinf`'s
        // and `cosf`'s bits (checked over all 2^32 inputs).
        let (sin, cos) = libm::sincosf(steer);
        Vec3::new(cos, sin, 0.0)
    }
}

/// Stage 4, tyre forces: each grounded tyre's slips and forces, the lateral one limited so it
/// stops a sideways slide within the step without reversing it (and near a standstill holding
/// like static friction against the slope), the longitudinal one linearised in wheel speed for
/// the implicit spin update. Returns each tyre's patch and gravity's pull along the road summed
/// over the grounded wheels' shares; writes each wheel's steer, load, slips and lateral force.
// Inlined into both builds (x86-64 and AVX2) of the force pass's per-car step.
#[inline(always)]
pub(crate) fn tyre_forces(
    t: &VehicleType,
    body: &Kinematics,
    contacts: &WheelContacts,
    steer: &[f32; 4],
    state: &mut VehicleState,
    h: f32,
    out: &mut TyrePatches,
) -> f32 {
    let p = &t.params;
    let Kinematics { com, rot, v, w } = *body;
    let r = p.wheels.radius_m;
    // A quarter of the car's mass moves with each contact patch.
    let m_eff = p.chassis.mass_kg / 4.0;
    let gravity_share = m_eff * GRAVITY;
    // The directions and slips of all four tyres at once (a wheel in the air has a zero
    // normal, and its lanes are dropped below). The rear wheels never steer: no trigonometry
    // for them.
    // (`rotated_by` has glam's bits: an unsteered wheel's heading is the body's forward axis.)
    // Four calls written out, not a closure over the lanes: the closure stayed a call.
    let steered = [
        steered_heading(steer[0]),
        steered_heading(steer[1]),
        steered_heading(steer[2]),
        steered_heading(steer[3]),
    ];
    let heading = Vec3x4::from_fn(|i| steered[i]).rotated_by(rot);
    let n = contacts.normal;
    let along = heading.dot(n);
    let f_dir = (heading - n * along).normalize_or_zero();
    let l_dir = n.cross(f_dir);
    let arm = contacts.point - Vec3x4::splat(com);
    let vc = Vec3x4::splat(v) + Vec3x4::splat(w).cross(arm);
    let vx = vc.dot(f_dir);
    let vy = vc.dot(l_dir);
    // The larger of |vx| and the floor (never NaN: the floor is a number).
    let v_ref = vx.abs().max(f32x4::splat(p.tyres.low_speed_mps));
    let omega = f32x4::new(array4(|i| state.wheels[i].omega));
    let slip_ratio = (omega * f32x4::splat(r) - vx) / v_ref;
    // Lateral slip as the tangent of the slip angle: the same as the angle in radians to
    // within 2 % below 14°, and it needs no arctangent.
    let slip_angle = vy / v_ref;
    let gravity = Vec3x4::splat(gravity_share);
    let pull_lat = gravity.dot(l_dir);
    let pull_long = gravity.dot(f_dir).to_array();
    let [cx, cy, dcx] = t.tyre.forces4(slip_ratio, slip_angle);
    let grip = f32x4::new(array4(|i| state.wheels[i].friction_scale))
        * f32x4::new(contacts.friction)
        * f32x4::new(contacts.load_n);
    let peak = grip * f32x4::splat(t.tyre.friction);
    let (m_eff4, h4, r4) = (f32x4::splat(m_eff), f32x4::splat(h), f32x4::splat(r));
    // The lateral force may stop the sideways slide within this step but not reverse it: at
    // low speed the tyre's slope is far too stiff for an explicit step. Near a standstill the
    // tyre holds like static friction: it stops the slide and carries the wheel's share of
    // gravity along the slope, so a parked car on a bank does not creep.
    let creeping = vx.abs().simd_lt(f32x4::splat(p.tyres.low_speed_mps));
    let hold_fy = lanes::clamp(-m_eff4 * vy / h4 - pull_lat, -peak, peak);
    let slide_fy = clamp_towards4(cy * grip, -vy * m_eff4 / h4);
    let fy = creeping.select(hold_fy, slide_fy);
    // Linearise with the steeper of the tangent and the secant to the zero-slip point: past
    // the peak the tangent is flat, and an update using it would carry the wheel straight
    // through rolling speed into the opposite slip. (`f32::max` lane by lane: ties of signed
    // zeros resolve as they do there.)
    let long_n = cx * grip;
    let behind = omega - vx / r4;
    let (tangent, ratio) = (
        (grip * dcx * r4 / v_ref).to_array(),
        (long_n / behind).to_array(),
    );
    let behind = behind.to_array();
    let slope: F4 = array4(|i| {
        let secant = if behind[i].abs() > 1.0e-6 {
            ratio[i].max(0.0)
        } else {
            0.0
        };
        tangent[i].max(secant)
    });
    let grounded = contacts.grounded;
    let on = lanes::mask(grounded);
    let zero = f32x4::ZERO;
    let keep = |v: f32x4| on.select(v, zero).to_array();
    *out = TyrePatches {
        // A wheel in the air has a zero normal already.
        normal: n,
        forward: f_dir.masked(grounded),
        lateral: l_dir.masked(grounded),
        arm: arm.masked(grounded),
        long_n: keep(long_n),
        slope: keep(f32x4::new(slope)),
        vx: keep(vx),
        peak_n: keep(peak),
        hold_n: keep(-m_eff4 * vx / h4),
    };
    let (slip_ratio, slip_angle, fy) = (keep(slip_ratio), keep(slip_angle), keep(fy));
    let mut slope_pull = 0.0f32;
    for (i, ws) in state.wheels.iter_mut().enumerate() {
        ws.steer_rad = steer[i];
        ws.compression_m = contacts.compression_m[i];
        ws.load_n = contacts.load_n[i];
        ws.grounded = grounded[i];
        ws.slip_ratio = slip_ratio[i];
        ws.slip_angle_rad = slip_angle[i];
        ws.force_lat_n = fy[i];
        if grounded[i] {
            slope_pull += pull_long[i];
        } else {
            ws.force_long_n = 0.0;
        }
    }
    slope_pull
}

/// Stage 5, brakes and ABS: the torque holding each wheel (brake, handbrake on the rear,
/// rolling resistance) and the wheel speeds after it, which brakes bring towards zero but never
/// past it. ABS holds the slip near the tyre's peak.
// Inlined into both builds (x86-64 and AVX2) of the force pass's per-car step.
#[inline(always)]
pub(crate) fn brakes_and_abs(
    t: &VehicleType,
    controls: &Controls,
    pedals: &Pedals,
    forward_mps: f32,
    state: &VehicleState,
    patches: &TyrePatches,
    h: f32,
) -> ([f32; 4], [f32; 4]) {
    let p = &t.params;
    let r = p.wheels.radius_m;
    let iw = t.driveline.wheel_inertia;
    // All four wheels at once, each lane in the scalar order of operations.
    let (zero, one) = (f32x4::ZERO, f32x4::ONE);
    let load = f32x4::new(array4(|i| state.wheels[i].load_n));
    let mut brake = f32x4::splat(pedals.brake * p.brakes.max_brake_torque_nm);
    if p.brakes.abs && forward_mps.abs() > 1.0 {
        // Full torque up to 70 % of the peak slip, released linearly to none at 130 %, and
        // never more than the tyre can pass to the road.
        let slip = f32x4::new(array4(|i| state.wheels[i].slip_ratio));
        let excess =
            (-slip / f32x4::splat(t.tyre.peak_slip_ratio) - f32x4::splat(0.7)) / f32x4::splat(0.6);
        let release = one - lanes::clamp(excess, zero, one);
        // `min` as `f32::min`: a NaN lane takes the other side. (A tie of signed zeros may
        // resolve otherwise, but the rolling resistance added below turns either into +0.)
        brake = (brake * release).min(f32x4::new(patches.peak_n) * f32x4::splat(r));
    }
    if controls.handbrake {
        let rear = lanes::mask([false, false, true, true]);
        brake = rear.select(
            brake + f32x4::splat(p.brakes.max_handbrake_torque_nm),
            brake,
        );
    }
    let brake = brake + (f32x4::splat(p.chassis.rolling_resistance) * load) * f32x4::splat(r);
    // `apply_brake` on each lane.
    let omega = f32x4::new(array4(|i| state.wheels[i].omega));
    let dw = brake.max(zero) * f32x4::splat(h) / f32x4::splat(iw);
    let braked = omega
        .simd_gt(dw)
        .select(omega - dw, omega.simd_lt(-dw).select(omega + dw, zero));
    (brake.to_array(), braked.to_array())
}

/// Stage 6, driveline: wheel spin, engine and clutch solved implicitly together with the
/// tyres; while shifting, the gearbox synchronises the engine to the gear it shifts into, so
/// the clutch closes without a jolt.
// Inlined into both builds (x86-64 and AVX2) of the force pass's per-car step.
#[inline(always)]
pub(crate) fn driveline(
    t: &VehicleType,
    transmission: &Transmission,
    state: &mut VehicleState,
    omega_braked: [f32; 4],
    patches: &TyrePatches,
    h: f32,
) -> SpinOutput {
    let p = &t.params;
    let omega_now = array4(|i| state.wheels[i].omega);
    let spin = t.driveline.spin(
        &p.engine,
        &SpinInput {
            omega: omega_braked,
            omega_tyre: omega_now,
            tyre_force_n: patches.long_n,
            tyre_slope: patches.slope,
            engine_omega: state.engine_omega,
            accelerator: if state.gearbox.shifting() {
                0.0
            } else {
                transmission.pedals.accelerator
            },
            ratio: transmission.ratio,
            clutch: transmission.clutch,
        },
        h,
    );
    state.engine_omega = spin.engine_omega;
    if state.gearbox.shifting() {
        let target_ratio = Gearbox::ratio_of(&p.gearbox, state.gearbox.target);
        let target = (transmission.driven_omega * target_ratio)
            .abs()
            .clamp(t.driveline.idle_omega, t.driveline.max_omega);
        let left = state.gearbox.shift_left_s.max(h);
        state.engine_omega += (target - state.engine_omega) * (h / left).min(1.0);
    }
    state.clutch = transmission.clutch;
    state.pedals = transmission.pedals;
    spin
}

/// Stage 7, standstill hold: which braked wheels of a car at a standstill hold it by static
/// friction, sharing between them the pull of gravity along the slope (the free-rolling wheels
/// carry none of it). A wheel whose brake cannot carry its share drops out and the others share
/// more; four rounds settle any combination of four wheels. Returns the holding wheels and how
/// many share the pull (at least one).
// Inlined into both builds (x86-64 and AVX2) of the force pass's per-car step.
#[inline(always)]
pub(crate) fn standstill_hold(
    p: &VehicleParams,
    state: &VehicleState,
    patches: &TyrePatches,
    spin: &SpinOutput,
    brake_nm: &[f32; 4],
    slope_pull: f32,
) -> ([bool; 4], f32) {
    let r = p.wheels.radius_m;
    let mut holding: [bool; 4] = array4(|i| {
        state.wheels[i].grounded
            && patches.vx[i].abs() < p.tyres.low_speed_mps
            && spin.omega[i].abs() * r < p.tyres.low_speed_mps
            && brake_nm[i] > spin.drive_torque_nm[i].abs()
    });
    if holding == [false; 4] {
        // What the rounds below would find: no wheel drops out, and one share.
        return (holding, 1.0);
    }
    let mut holders = 1.0f32;
    for _ in 0..4 {
        holders = holding.iter().filter(|&&b| b).count().max(1) as f32;
        let before = holding;
        for i in 0..4 {
            let need = (patches.hold_n[i] - slope_pull / holders).abs() * r;
            holding[i] &= need <= brake_nm[i] - spin.drive_torque_nm[i].abs();
        }
        if holding == before {
            break;
        }
    }
    (holding, holders)
}

/// What the hold stage decided, for the contact forces.
pub(crate) struct Hold {
    /// Which wheels hold the car.
    pub holding: [bool; 4],
    /// How many share gravity's pull along the road.
    pub holders: f32,
    /// That pull, N.
    pub slope_pull: f32,
}

/// Stage 8, contact forces: each grounded tyre's longitudinal force kept inside the friction
/// ellipse its lateral force leaves and never pushing the car past the wheel's own rolling speed
/// in one step (what the wheel did not pass to the road stays in its spin), or holding the
/// wheel still; the load, longitudinal and lateral forces summed into a force and a torque
/// about the centre of mass. Writes each wheel's final spin, drive torque and force.
// Inlined into both builds (x86-64 and AVX2) of the force pass's per-car step.
#[inline(always)]
pub(crate) fn contact_forces(
    t: &VehicleType,
    state: &mut VehicleState,
    patches: &TyrePatches,
    spin: &SpinOutput,
    brake_nm: &[f32; 4],
    hold: &Hold,
    h: f32,
) -> (Vec3, Vec3) {
    let p = &t.params;
    let r = p.wheels.radius_m;
    let iw = t.driveline.wheel_inertia;
    let m_eff = p.chassis.mass_kg / 4.0;
    // The rolling wheels' forces, all four at once, each lane in the scalar order of
    // operations; the lanes of wheels in the air are computed and dropped.
    let peak = f32x4::new(patches.peak_n);
    let fy = f32x4::new(array4(|i| state.wheels[i].force_lat_n));
    // Never -0 under the square root: a square is +0 at least, and x − x is +0.
    let room = (peak * peak - fy * fy).max(f32x4::ZERO).sqrt();
    let linear = f32x4::new(spin.tyre_force_n);
    let omega = f32x4::new(spin.omega);
    let r4 = f32x4::splat(r);
    let rolling_fx = clamp_towards4(
        lanes::clamp(linear, -room, room),
        ((omega * r4 - f32x4::new(patches.vx)) * f32x4::splat(m_eff)) / f32x4::splat(h),
    );
    let rolling_omega = omega + (f32x4::splat(h * r) * (linear - rolling_fx)) / f32x4::splat(iw);
    let (room, rolling_fx, rolling_omega) = (
        room.to_array(),
        rolling_fx.to_array(),
        rolling_omega.to_array(),
    );
    let mut fx = [0.0f32; 4];
    for i in 0..4 {
        let ws = &mut state.wheels[i];
        ws.drive_torque_nm = spin.drive_torque_nm[i];
        ws.omega = spin.omega[i];
        if !ws.grounded {
            continue;
        }
        // A holding wheel's test only where the hold stage found any.
        let held = hold.holding[i] && {
            let hold_n = patches.hold_n[i] - hold.slope_pull / hold.holders;
            hold_n.abs() * r <= brake_nm[i] - spin.drive_torque_nm[i].abs()
                && hold_n.abs() <= room[i]
        };
        fx[i] = if held {
            ws.omega = 0.0;
            patches.hold_n[i] - hold.slope_pull / hold.holders
        } else {
            ws.omega = rolling_omega[i];
            rolling_fx[i]
        };
        ws.force_long_n = fx[i];
    }
    // Each tyre's force and its moment about the centre of mass, all four at once, then summed
    // in wheel order over the grounded ones.
    // (The lateral forces are those read above: the loop does not change them.)
    let load = f32x4::new(array4(|i| state.wheels[i].load_n));
    let fx = f32x4::new(fx);
    let f = (patches.normal * load + patches.forward * fx) + patches.lateral * fy;
    let moment = patches.arm.cross(f);
    let mut force = Vec3::ZERO;
    let mut torque = Vec3::ZERO;
    for i in 0..4 {
        if state.wheels[i].grounded {
            force += f.lane(i);
            torque += moment.lane(i);
        }
    }
    (force, torque)
}

/// Stage 9, drag: ½ ρ Cd A v² against the velocity, at the centre of mass.
// Inlined into both builds (x86-64 and AVX2) of the force pass's per-car step.
#[inline(always)]
pub(crate) fn drag(p: &VehicleParams, v: Vec3) -> Vec3 {
    let ch = &p.chassis;
    let speed = v.length();
    -(v * (0.5 * ch.air_density_kg_m3 * ch.drag_coefficient * ch.frontal_area_m2 * speed))
}

/// The force and torque on one vehicle's body this tick (suspension, tyres, drag), advancing
/// its wheels, engine, gearbox and steering: the stages above, in order. Reads the physics world
/// only, so vehicles can be computed in parallel.
// Inlined into both builds (x86-64 and AVX2) of the force pass's per-car step.
#[inline(always)]
pub(crate) fn vehicle_forces(
    physics: &Physics,
    network: &RoadNetwork,
    controls: &Controls,
    model: &VehicleModel,
    kin: &Kinematics,
    track: &RoadTrack,
    state: &mut VehicleState,
) -> (Vec3, Vec3) {
    let h = DT_S as f32;
    let t: &VehicleType = &model.0;
    let kin = *kin;
    let forward_mps = kin.v.dot(kin.forward());
    let transmission = gearbox_and_clutch(t, controls, state, forward_mps, h);
    let steer = steer_wheels(&t.params, controls, state, forward_mps, h);
    // The arrays are written in place: returned by value they would be copied each tick.
    let mut contacts = WheelContacts::default();
    wheel_contact(physics, network, t, track, &kin, &mut contacts);
    let mut patches = TyrePatches::default();
    let slope_pull = tyre_forces(t, &kin, &contacts, &steer, state, h, &mut patches);
    let (brake_nm, omega_braked) = brakes_and_abs(
        t,
        controls,
        &transmission.pedals,
        forward_mps,
        state,
        &patches,
        h,
    );
    let spin = driveline(t, &transmission, state, omega_braked, &patches, h);
    let (holding, holders) =
        standstill_hold(&t.params, state, &patches, &spin, &brake_nm, slope_pull);
    let hold = Hold {
        holding,
        holders,
        slope_pull,
    };
    let (mut force, torque) = contact_forces(t, state, &patches, &spin, &brake_nm, &hold, h);
    force += drag(&t.params, kin.v);
    (force, torque)
}

/// Clamps each tyre force to lie between zero and the force that would stop its slip.
// Inlined into both builds (x86-64 and AVX2) of the force pass's per-car step.
#[inline(always)]
fn clamp_towards4(force: f32x4, stop: f32x4) -> f32x4 {
    let ahead = stop.simd_ge(f32x4::ZERO);
    lanes::clamp(
        force,
        ahead.select(f32x4::ZERO, stop),
        ahead.select(stop, f32x4::ZERO),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::components::WheelState;
    use crate::drivetrain::apply_brake;
    use crate::spawn::rest_pose;
    use flockway_road::{RoadId, RoadSpec};
    use glam::DVec3;

    /// A straight flat road along x, the reference sedan resting on it at 50 m, and a state at
    /// rest.
    fn parked() -> (
        Physics,
        RoadNetwork,
        VehicleType,
        RoadTrack,
        Kinematics,
        VehicleState,
    ) {
        let spec = RoadSpec::through("flat", 2, 50.0, &[DVec3::ZERO, DVec3::new(100.0, 0.0, 0.0)]);
        let network = RoadNetwork::build(&[spec]).expect("a road");
        let g = network.get(RoadId(0)).expect("road 0").clone();
        let t = VehicleType::default();
        let (com, rot) = rest_pose(&t, &g.frame_at(50.0), 0.0);
        let track = RoadTrack::new(RoadId(0), &g, 50.0, 0.0);
        let kin = Kinematics {
            com,
            rot,
            v: Vec3::ZERO,
            w: Vec3::ZERO,
        };
        let mut wheels = [WheelState::default(); 4];
        for (i, w) in wheels.iter_mut().enumerate() {
            w.compression_m = t.rest_compression_m[i];
        }
        let state = VehicleState {
            wheels,
            gearbox: Gearbox::for_speed(&t.params.gearbox, 0.0, t.params.wheels.radius_m),
            engine_omega: t.driveline.idle_omega,
            clutch: 0.0,
            steer: 0.0,
            pedals: Pedals::default(),
        };
        (Physics::default(), network, t, track, kin, state)
    }

    fn contacts_of(
        physics: &Physics,
        network: &RoadNetwork,
        t: &VehicleType,
        track: &RoadTrack,
        kin: &Kinematics,
    ) -> WheelContacts {
        let mut c = WheelContacts::default();
        wheel_contact(physics, network, t, track, kin, &mut c);
        c
    }

    fn patches_of(
        t: &VehicleType,
        kin: &Kinematics,
        contacts: &WheelContacts,
        state: &mut VehicleState,
    ) -> (TyrePatches, f32) {
        let mut p = TyrePatches::default();
        let pull = tyre_forces(t, kin, contacts, &[0.0; 4], state, 1.0 / 120.0, &mut p);
        (p, pull)
    }

    /// The wheel headings take sine and cosine from one `sincosf`, which must answer `sinf`'s
    /// and `cosf`'s bits. Every input was compared once; this keeps a sweep of the steering
    /// range and a stride through all 2^32 patterns, so a libm that changes either fails here.
    #[test]
    fn sincos_has_the_bits_of_sine_and_cosine() {
        let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        let steering = (-20_000..=20_000).map(|i| i as f32 * 1.0e-4);
        let strided = (0..=u32::MAX).step_by(4_099).map(f32::from_bits);
        let specials = [0.0, -0.0, f32::NAN, f32::INFINITY, -f32::INFINITY, 1.0e-40];
        let mut seen = 0;
        for x in steering.chain(strided).chain(specials) {
            let (sin, cos) = libm::sincosf(x);
            let bits = x.to_bits();
            assert!(same(sin, libm::sinf(x)), "sine of {x:e} ({bits:#x})");
            assert!(same(cos, libm::cosf(x)), "cosine of {x:e} ({bits:#x})");
            seen += 1;
        }
        assert!(seen > 1_000_000);
    }

    #[test]
    fn wheel_contact_at_rest_carries_the_static_axle_loads() {
        let (physics, network, t, track, kin, _) = parked();
        let c = contacts_of(&physics, &network, &t, &track, &kin);
        let g = -GRAVITY.z;
        let total: f32 = c.load_n.iter().sum();
        assert!(
            (total - t.params.chassis.mass_kg * g).abs() < 1.0,
            "the springs carry the car: {total} N"
        );
        assert!(c.grounded == [true; 4] && c.friction == [1.0; 4]);
        assert!(
            (c.load_n[0] - c.load_n[1]).abs() < 1e-3,
            "left and right alike"
        );
        for (i, x) in c.compression_m.iter().enumerate() {
            assert!((x - t.rest_compression_m[i]).abs() < 1e-4);
        }
        // Lifted a metre, no wheel reaches the road (and there is no ground collider here).
        let high = Kinematics {
            com: kin.com + Vec3::Z,
            ..kin
        };
        let c = contacts_of(&physics, &network, &t, &track, &high);
        assert_eq!(c, WheelContacts::default());
        // Rolled to the left: the anti-roll bar moves load to the more compressed right side.
        let rolled = Kinematics {
            rot: Quat::from_rotation_x(0.02) * kin.rot,
            ..kin
        };
        let c = contacts_of(&physics, &network, &t, &track, &rolled);
        assert!(c.compression_m[1] > c.compression_m[0] && c.load_n[1] > c.load_n[0]);
    }

    #[test]
    fn a_wheel_off_the_road_stands_on_rapier_s_ground_with_its_friction() {
        let (mut physics, network, t, track, kin, _) = parked();
        physics.rebuild_statics(&network);
        // A step brings the ground into rapier's scene queries.
        physics.step();
        // The same pose 30 m to the side of the road, down on the ground below it.
        let dz = physics.ground_z();
        let off = Kinematics {
            com: kin.com + Vec3::new(0.0, 30.0, dz),
            ..kin
        };
        let c = contacts_of(&physics, &network, &t, &track, &off);
        assert_eq!(c.grounded, [true; 4]);
        assert_eq!(c.friction, [OFF_ROAD_FRICTION; 4]);
        let total: f32 = c.load_n.iter().sum();
        let weight = t.params.chassis.mass_kg * -GRAVITY.z;
        assert!(
            (total - weight).abs() < 1.0,
            "the springs carry the car: {total} N"
        );
        for i in 0..4 {
            assert!((c.normal.lane(i) - Vec3::Z).length() < 1e-5);
            assert!((c.point.lane(i).z - dz).abs() < 1e-3, "{}", c.point.lane(i));
        }
        // Astride the road's right edge: the left wheels on the road, the right ones on the
        // ground beside it.
        let edge = network
            .get(RoadId(0))
            .expect("road 0")
            .frame_at(50.0)
            .width_m
            / 2.0;
        let astride = Kinematics {
            com: kin.com - Vec3::Y * (edge + SHOULDER_M) as f32,
            ..kin
        };
        let c = contacts_of(&physics, &network, &t, &track, &astride);
        assert_eq!(c.grounded, [true; 4]);
        let off = OFF_ROAD_FRICTION;
        assert_eq!(c.friction, [1.0, off, 1.0, off]);
    }

    #[test]
    fn tyre_forces_of_a_rolling_wheel_are_zero_and_a_slide_is_opposed() {
        let (physics, network, t, track, kin, mut state) = parked();
        let rolling = Kinematics {
            v: Vec3::new(20.0, 0.0, 0.0),
            ..kin
        };
        for w in &mut state.wheels {
            w.omega = 20.0 / t.params.wheels.radius_m;
        }
        let contacts = contacts_of(&physics, &network, &t, &track, &rolling);
        let (patches, slope_pull) = patches_of(&t, &rolling, &contacts, &mut state);
        for i in 0..4 {
            let long = patches.long_n[i];
            assert!(long.abs() < 1e-3, "wheel {i}: {long}");
            assert!(state.wheels[i].force_lat_n.abs() < 1e-3);
            assert!(patches.peak_n[i] > 0.0 && (patches.vx[i] - 20.0).abs() < 1e-4);
        }
        assert!(slope_pull.abs() < 1e-3, "flat road: no pull along it");
        // Sliding left at 1 m/s: every tyre pushes right, and no more than it can.
        let sliding = Kinematics {
            v: Vec3::new(20.0, 1.0, 0.0),
            ..kin
        };
        let (patches, _) = patches_of(&t, &sliding, &contacts, &mut state);
        for i in 0..4 {
            let fy = state.wheels[i].force_lat_n;
            assert!(fy < 0.0 && fy.abs() <= patches.peak_n[i], "wheel {i}: {fy}");
        }
        // Spinning faster than the road: a driving force, and a wheel in the air has none.
        state.wheels[2].omega *= 1.1;
        let mut airborne = contacts;
        airborne.grounded[3] = false;
        let (patches, _) = patches_of(&t, &rolling, &airborne, &mut state);
        assert!(patches.long_n[2] > 0.0);
        let fields = [
            patches.long_n,
            patches.slope,
            patches.vx,
            patches.peak_n,
            patches.hold_n,
        ];
        assert!(
            fields.iter().all(|f| f[3] == 0.0),
            "wheel 3 in the air: {patches:?}"
        );
        assert_eq!(patches.forward.lane(3), Vec3::ZERO);
        assert!(!state.wheels[3].grounded);
    }

    #[test]
    fn brakes_release_beyond_the_abs_slip_and_the_handbrake_holds_the_rear() {
        let (_, _, t, _, _, mut state) = parked();
        let patches = TyrePatches {
            peak_n: [4000.0; 4],
            ..TyrePatches::default()
        };
        let braking = Pedals {
            accelerator: 0.0,
            brake: 1.0,
        };
        let peak = t.tyre.peak_slip_ratio;
        for (i, w) in state.wheels.iter_mut().enumerate() {
            w.omega = 50.0;
            w.load_n = 3000.0;
            // Slips at 50 %, 100 %, 150 % of the peak, and none.
            w.slip_ratio = -peak * [0.5, 1.0, 1.5, 0.0][i];
        }
        let controls = Controls::default();
        let (brake, omega) =
            brakes_and_abs(&t, &controls, &braking, 25.0, &state, &patches, 1.0 / 120.0);
        let rolling = t.params.chassis.rolling_resistance * 3000.0 * t.params.wheels.radius_m;
        let full = (t.params.brakes.max_brake_torque_nm).min(4000.0 * t.params.wheels.radius_m);
        assert!((brake[0] - rolling - full).abs() < 1e-2, "below 70 %: full");
        assert!(
            brake[1] - rolling < full && brake[1] - rolling > 0.0,
            "released part way"
        );
        assert!((brake[2] - rolling).abs() < 1e-3, "past 130 %: released");
        assert!((brake[3] - rolling - full).abs() < 1e-2);
        assert!(
            omega.iter().all(|&w| (0.0..=50.0).contains(&w)),
            "never reversed"
        );
        // The handbrake acts on the rear wheels only.
        let hand = Controls {
            handbrake: true,
            ..Controls::default()
        };
        let coast = Pedals::default();
        let (brake, _) = brakes_and_abs(&t, &hand, &coast, 0.0, &state, &patches, 1.0 / 120.0);
        assert!((brake[0] - rolling).abs() < 1e-3 && (brake[1] - rolling).abs() < 1e-3);
        assert!((brake[2] - rolling - t.params.brakes.max_handbrake_torque_nm).abs() < 1e-2);
    }

    /// The brakes wheel by wheel, in scalar arithmetic: what the four-wide stage must reproduce
    /// bit for bit.
    fn brakes_per_wheel(
        t: &VehicleType,
        controls: &Controls,
        pedals: &Pedals,
        forward_mps: f32,
        state: &VehicleState,
        patches: &TyrePatches,
        h: f32,
    ) -> ([f32; 4], [f32; 4]) {
        let p = &t.params;
        let r = p.wheels.radius_m;
        let mut out = ([0.0f32; 4], [0.0f32; 4]);
        for i in 0..4 {
            let ws = &state.wheels[i];
            let mut brake = pedals.brake * p.brakes.max_brake_torque_nm;
            if p.brakes.abs && forward_mps.abs() > 1.0 {
                let excess = (-ws.slip_ratio / t.tyre.peak_slip_ratio - 0.7) / 0.6;
                let release = 1.0 - excess.clamp(0.0, 1.0);
                brake = (brake * release).min(patches.peak_n[i] * r);
            }
            if controls.handbrake && i >= 2 {
                brake += p.brakes.max_handbrake_torque_nm;
            }
            brake += p.chassis.rolling_resistance * ws.load_n * r;
            out.0[i] = brake;
            out.1[i] = apply_brake(ws.omega, brake, t.driveline.wheel_inertia, h);
        }
        out
    }

    #[test]
    fn the_four_wide_brakes_have_the_per_wheel_bits() {
        // Pedals of either sign of zero and part way, ABS on and off, the handbrake, slips
        // around the peak, wheels turning either way and stopped, loads and grips of zero.
        let (_, _, mut t, _, _, mut state) = parked();
        let mut next = crate::lanes::uniform(0x9e37_79b9);
        let peak = t.tyre.peak_slip_ratio;
        let mut checked = 0;
        for abs in [true, false] {
            t.params.brakes.abs = abs;
            for handbrake in [false, true] {
                let controls = Controls {
                    handbrake,
                    ..Controls::default()
                };
                for n in 0..200 {
                    let brake = [0.0, -0.0, 1.0, next(0.0, 1.0)][n % 4];
                    let pedals = Pedals {
                        accelerator: 0.0,
                        brake,
                    };
                    for w in &mut state.wheels {
                        w.omega = if n % 6 == 0 { 0.0 } else { next(-40.0, 120.0) };
                        w.slip_ratio = -peak * next(-0.5, 2.0);
                        w.load_n = if n % 5 == 0 { 0.0 } else { next(0.0, 9000.0) };
                    }
                    let patches = TyrePatches {
                        peak_n: array4(|_| if n % 3 == 0 { 0.0 } else { next(0.0, 9000.0) }),
                        ..TyrePatches::default()
                    };
                    let forward = next(-30.0, 30.0);
                    let h = 1.0 / 120.0;
                    let (brake, omega) =
                        brakes_and_abs(&t, &controls, &pedals, forward, &state, &patches, h);
                    let want =
                        brakes_per_wheel(&t, &controls, &pedals, forward, &state, &patches, h);
                    assert_eq!(brake.map(f32::to_bits), want.0.map(f32::to_bits));
                    assert_eq!(omega.map(f32::to_bits), want.1.map(f32::to_bits));
                    checked += 1;
                }
            }
        }
        assert_eq!(checked, 800);
    }

    #[test]
    fn a_braked_car_at_a_standstill_holds_on_a_slope_unless_the_brakes_are_too_weak() {
        let (_, _, t, _, _, mut state) = parked();
        for w in &mut state.wheels {
            w.grounded = true;
        }
        let patches = TyrePatches::default();
        let spin = SpinOutput {
            omega: [0.0; 4],
            tyre_force_n: [0.0; 4],
            engine_omega: 0.0,
            drive_torque_nm: [0.0; 4],
        };
        // A 4 % hill pulls 1500 kg × 9.81 × 0.04 ≈ 590 N along the road.
        let pull = 590.0;
        let (holding, holders) =
            standstill_hold(&t.params, &state, &patches, &spin, &[500.0; 4], pull);
        assert_eq!((holding, holders), ([true; 4], 4.0));
        // Only the rear brakes (the handbrake): they share the pull between two.
        let (holding, holders) = standstill_hold(
            &t.params,
            &state,
            &patches,
            &spin,
            &[0.0, 0.0, 500.0, 500.0],
            pull,
        );
        assert_eq!((holding, holders), ([false, false, true, true], 2.0));
        // Brakes too weak for their share: nobody holds, and the car rolls.
        let (holding, _) = standstill_hold(&t.params, &state, &patches, &spin, &[10.0; 4], pull);
        assert_eq!(holding, [false; 4]);
    }

    #[test]
    fn the_longitudinal_force_stays_inside_the_friction_ellipse() {
        let (_, _, t, _, _, mut state) = parked();
        for w in &mut state.wheels {
            w.grounded = true;
            w.load_n = 3600.0;
            w.omega = 30.0;
        }
        // Wheel 0 uses 3000 of its 5000 N for cornering: 4000 N are left along the tyre.
        state.wheels[0].force_lat_n = 3000.0;
        let patches = TyrePatches {
            normal: Vec3x4::splat(Vec3::Z),
            forward: Vec3x4::splat(Vec3::X),
            lateral: Vec3x4::splat(Vec3::Y),
            arm: Vec3x4::default(),
            peak_n: [5000.0; 4],
            vx: [10.0; 4],
            ..TyrePatches::default()
        };
        let spin = SpinOutput {
            omega: [30.0; 4],
            tyre_force_n: [9000.0; 4],
            engine_omega: 300.0,
            drive_torque_nm: [0.0; 4],
        };
        let hold = Hold {
            holding: [false; 4],
            holders: 1.0,
            slope_pull: 0.0,
        };
        let (force, torque) = contact_forces(
            &t,
            &mut state,
            &patches,
            &spin,
            &[0.0; 4],
            &hold,
            1.0 / 120.0,
        );
        assert!((state.wheels[0].force_long_n - 4000.0).abs() < 1e-2);
        assert!((state.wheels[1].force_long_n - 5000.0).abs() < 1e-2);
        // The force it could not pass to the road spins the wheel up.
        assert!(state.wheels[0].omega > 30.0);
        assert!((force.z - 4.0 * 3600.0).abs() < 1e-2 && torque == Vec3::ZERO);
        assert!(drag(&t.params, Vec3::new(30.0, 0.0, 0.0)).x < -300.0);
    }

    #[test]
    fn clamp_towards_never_reverses_a_slip() {
        let clamp = |force: f32, stop: f32| {
            let got = clamp_towards4(f32x4::splat(force), f32x4::splat(stop)).to_array();
            assert!(got.iter().all(|x| x.to_bits() == got[0].to_bits()));
            got[0]
        };
        assert_eq!(clamp(500.0, 200.0), 200.0);
        assert_eq!(clamp(-50.0, 200.0), 0.0);
        assert_eq!(clamp(-500.0, -200.0), -200.0);
        assert_eq!(clamp(100.0, -200.0), 0.0);
        // Scalar clamping between zero and the stop, with its signed zeros.
        for force in [-3.0f32, -0.0, 0.0, 2.5, 1.0e9] {
            for stop in [-2.0f32, -0.0, 0.0, 1.5] {
                let want = if stop >= 0.0 {
                    force.clamp(0.0, stop)
                } else {
                    force.clamp(stop, 0.0)
                };
                assert_eq!(
                    clamp(force, stop).to_bits(),
                    want.to_bits(),
                    "{force} {stop}"
                );
            }
        }
    }
}

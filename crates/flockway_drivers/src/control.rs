//! The shared controller: PID loops that turn a target speed and heading into `Controls`.

use crate::perception::{LaneIndex, LaneSignal};
use crate::safety::{AheadMemo, OVER_SAFE_BRAKE_PER_MPS, SafetyParams, SafetyView, safe_speed_mps};
use bevy_ecs::prelude::*;
use bevy_ecs::query::QueryItem;
use flockway_core::{DT_S, SimClock, Tick, for_each_car};
use flockway_road::RoadNetwork;
use flockway_vehicle::{
    Controls, LongitudinalModel, Motion, STANDSTILL_MPS, VehicleModel, VehicleState, VehicleType,
};
use serde::{Deserialize, Serialize};
use std::f32::consts::{PI, TAU};

/// PID gains.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PidGains {
    /// Proportional gain (output per unit error).
    pub kp: f32,
    /// Integral gain (output per unit error·second).
    pub ki: f32,
    /// Derivative gain (output per unit error/second).
    pub kd: f32,
}

/// A PID loop with output clamped to [-1, 1] and conditional integration (no wind-up).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Pid {
    integral: f32,
    last_error: Option<f32>,
}

impl Pid {
    /// One update with this error; returns the clamped output.
    pub fn update(&mut self, gains: &PidGains, error: f32, dt_s: f32) -> f32 {
        self.update_integrating(gains, error, dt_s, 1.0)
    }

    /// [`update`](Self::update) with the error integrated at `rate` (0..1) of the full rate:
    /// for a loop whose error the plant can only correct part of the time.
    pub fn update_integrating(
        &mut self,
        gains: &PidGains,
        error: f32,
        dt_s: f32,
        rate: f32,
    ) -> f32 {
        let error = if error.is_finite() { error } else { 0.0 };
        let derivative = self.last_error.map_or(0.0, |e| (error - e) / dt_s);
        self.last_error = Some(error);
        let unclamped = gains.kp * error + gains.ki * self.integral + gains.kd * derivative;
        // Integrate only while that does not push a saturated output further.
        let saturated = unclamped.abs() >= 1.0 && unclamped.signum() == error.signum();
        if !saturated {
            let rate = if rate.is_nan() {
                0.0
            } else {
                rate.clamp(0.0, 1.0)
            };
            self.integral += error * dt_s * rate;
        }
        (gains.kp * error + gains.ki * self.integral + gains.kd * derivative).clamp(-1.0, 1.0)
    }

    /// Forgets the integral and derivative history.
    pub fn reset(&mut self) {
        *self = Pid::default();
    }
}

/// Wraps an angle difference into (−π, π]: from −175° to 175° is a turn of −10°, not 350°.
pub fn wrap_angle(rad: f32) -> f32 {
    let w = flockway_core::wrap::rem_euclid_f32(rad + PI, TAU) - PI;
    if w <= -PI { w + TAU } else { w }
}

/// From this speed, m/s, the steering loop integrates its heading error at the full rate; slower,
/// in proportion, and not at all at a standstill. Steering turns a car only as it rolls, so an
/// error held while it waits (mid-turn at a junction, at a lane's end) is not the steering's to
/// remove: integrated over the wait, it would turn the wheels to full lock and the car would pull
/// away cutting across its path.
pub const STEER_INTEGRATE_FULL_MPS: f32 = 2.0;

/// Below this target speed, m/s, the controller only brakes (a stop, not a crawl).
pub const STOP_BELOW_MPS: f32 = 0.3;

/// Brake held by a stopping car on top of the proportional term, as a share of full braking.
pub const HOLD_BRAKE: f32 = 0.2;

/// How far the speed an acceleration-driven car should have reached by now (the asked-for
/// accelerations integrated) may run away from its actual speed, m/s: beyond it the car cannot
/// follow (full throttle, full brakes, a shift) and the reference waits for it rather than
/// winding up a correction it would overshoot with later.
pub const ACCEL_REFERENCE_BAND_MPS: f32 = 0.5;

/// How fast an acceleration-driven car is brought down to a speed cap (a junction's hold, the
/// safety envelope) it is above or about to pass, s: the acceleration asked for is at most the
/// cap's distance over this time.
pub const CAP_RESPONSE_S: f32 = 0.5;

/// The angle, rad, by which a car's centre of mass moves to the left of where its body points
/// when it drives steadily round a curve of `curvature_per_m` (positive left) at `speed_mps`:
/// `atan(κ · (l_r − v² / (μ B C g)))`, the linear single-track model's. At a crawl the body
/// turns about its rear axle, so the centre (`l_r` ahead of it) moves into the bend and the
/// nose must point out of it for the centre to keep to the path; faster, the rear tyres need
/// slip angle to hold the car in the bend (their cornering stiffness is `μ B C` times their
/// load, from the lateral magic formula), and the nose turns in. Steering the body's heading
/// onto the path's instead, a car turning at a junction cuts inside its path.
pub fn steady_sideslip_rad(vehicle: &VehicleType, speed_mps: f32, curvature_per_m: f32) -> f32 {
    if curvature_per_m == 0.0 {
        return 0.0;
    }
    let p = &vehicle.params;
    let behind_m = 0.5 * p.wheels.wheelbase_m + p.chassis.com_forward_m;
    let lateral = &p.tyres.lateral;
    let cornering =
        (p.tyres.friction * lateral.b * lateral.c * -flockway_vehicle::GRAVITY.z).max(1.0);
    // Bounded for a curvature no car drives (a lane's sharp kink seen over a short look-ahead).
    let slip = curvature_per_m * (behind_m - speed_mps * speed_mps / cornering);
    libm::atanf(slip.clamp(-MAX_SIDESLIP_TAN, MAX_SIDESLIP_TAN))
}

/// The largest tangent of [`steady_sideslip_rad`]'s angle (about 27°).
const MAX_SIDESLIP_TAN: f32 = 0.5;

/// What a driver wants: the speed along its heading and the heading, for the shared controller.
#[derive(Component, Debug, Clone, Copy, Default, PartialEq)]
#[require(crate::JunctionGate, crate::AheadMemo)]
pub struct DriveTarget {
    /// Target speed, m/s (never negative: drivers brake to a stop, they do not reverse).
    pub speed_mps: f32,
    /// Target heading: compass angle of the direction of travel in the ground plane, rad
    /// (0 = +x east, counter-clockwise).
    pub heading_rad: f32,
    /// Curvature of the path ahead, 1/m (positive turning left; 0 if unknown): the controller
    /// steers the matching Ackermann angle up front and leaves only corrections to the PID.
    pub curvature_per_m: f32,
    /// The acceleration along the heading asked for, m/s², by a driver whose law is an
    /// acceleration (the IDM): the controller then makes the car accelerate so, through the
    /// inverse of its drivetrain and brakes ([`LongitudinalModel`]) with the speed loop only
    /// correcting what that model misses, and `speed_mps` is where it is heading. `None`: the
    /// speed loop tracks `speed_mps`.
    pub accel_mps2: Option<f32>,
}

/// The shared controller of a vehicle: gains and the state of its two PID loops. Vehicles with a
/// [`DriveTarget`] and this component get their `Controls` from it.
#[derive(Component, Debug, Clone, Copy, PartialEq)]
pub struct TargetController {
    /// Throttle loop on speed error (m/s).
    pub throttle: PidGains,
    /// Steering loop on heading error (rad).
    pub steering: PidGains,
    throttle_pid: Pid,
    steering_pid: Pid,
    /// For acceleration targets: the speed the asked-for accelerations integrate to, m/s.
    reference_mps: Option<f32>,
}

impl TargetController {
    /// A controller with these gains and fresh loops.
    pub fn new(throttle: PidGains, steering: PidGains) -> TargetController {
        TargetController {
            throttle,
            steering,
            throttle_pid: Pid::default(),
            steering_pid: Pid::default(),
            reference_mps: None,
        }
    }

    /// The controls for one tick towards `target`, from the vehicle's motion, type and state.
    pub fn control(
        &mut self,
        target: &DriveTarget,
        motion: &Motion,
        vehicle: &VehicleType,
        state: &VehicleState,
    ) -> Controls {
        let h = DT_S as f32;
        let f = motion.forward();
        let heading = libm::atan2f(f.y, f.x);
        // The target is the way the car should go; its body points off that by its sideslip.
        let sideslip = steady_sideslip_rad(vehicle, motion.forward_mps, target.curvature_per_m);
        let heading_error = wrap_angle(target.heading_rad - sideslip - heading);
        let (throttle, stopped) = match target.accel_mps2 {
            Some(accel) => self.track_accel(accel, motion, vehicle, state),
            None => self.track_speed(target.speed_mps, motion),
        };
        let params = &vehicle.params;
        let lock = params
            .steering
            .center_angle_rad(1.0, motion.forward_mps.abs() * 3.6)
            .max(1.0e-3);
        let feed_forward = libm::atanf(params.wheels.wheelbase_m * target.curvature_per_m) / lock;
        let rolling = motion.forward_mps.abs() / STEER_INTEGRATE_FULL_MPS;
        let correction =
            self.steering_pid
                .update_integrating(&self.steering, heading_error, h, rolling);
        Controls {
            throttle,
            steering: (feed_forward + correction).clamp(-1.0, 1.0),
            handbrake: stopped,
        }
    }

    /// The throttle towards speed `speed_mps`, and whether the car is held at a standstill.
    fn track_speed(&mut self, speed_mps: f32, motion: &Motion) -> (f32, bool) {
        self.reference_mps = None;
        let speed_error = speed_mps.max(0.0) - motion.forward_mps;
        if speed_mps < STOP_BELOW_MPS {
            // Asked to stop: brake only. The integral remembers the throttle that cruising
            // needed, and would otherwise creep the car on into whatever it stopped for.
            self.throttle_pid.reset();
            if motion.forward_mps > STANDSTILL_MPS {
                (
                    (self.throttle.kp * speed_error - HOLD_BRAKE).clamp(-1.0, 0.0),
                    false,
                )
            } else {
                // Stopped: negative throttle would select reverse; hold with the handbrake.
                (0.0, true)
            }
        } else {
            let h = DT_S as f32;
            (
                self.throttle_pid.update(&self.throttle, speed_error, h),
                false,
            )
        }
    }

    /// The throttle that gives acceleration `accel`: the vehicle's inverse longitudinal model
    /// fed forward, and the speed loop on the gap between the speed the asked-for accelerations
    /// add up to and the actual one (what the model gets wrong: clutch slip, tyre slip, a
    /// shift). A car at a standstill asked not to move holds on the handbrake.
    fn track_accel(
        &mut self,
        accel: f32,
        motion: &Motion,
        vehicle: &VehicleType,
        state: &VehicleState,
    ) -> (f32, bool) {
        let h = DT_S as f32;
        let v = motion.forward_mps;
        let accel = if accel.is_finite() { accel } else { 0.0 };
        if v <= STANDSTILL_MPS && accel <= 0.0 {
            self.throttle_pid.reset();
            self.reference_mps = None;
            return (0.0, true);
        }
        let reference = self
            .reference_mps
            .unwrap_or(v)
            .clamp(v - ACCEL_REFERENCE_BAND_MPS, v + ACCEL_REFERENCE_BAND_MPS);
        let model = LongitudinalModel::new(vehicle, state, v, motion.forward().z);
        let feed_forward = model.throttle_for(accel);
        let correction = self.throttle_pid.update(&self.throttle, reference - v, h);
        self.reference_mps = Some(reference + accel * h);
        let mut throttle = (feed_forward + correction).clamp(-1.0, 1.0);
        if v <= STANDSTILL_MPS {
            // Negative throttle at a standstill selects reverse: pulling away only drives.
            throttle = throttle.max(0.0);
        }
        (throttle, false)
    }
}

impl Default for TargetController {
    /// The lane-keeping flocking car's gains.
    fn default() -> Self {
        let p = crate::FlockParams::default();
        TargetController::new(p.throttle, p.steering)
    }
}

/// What a custom driver puts on a vehicle besides its own component to be steered by the shared
/// controller: a [`DriveTarget`] to write, the [`TargetController`] that follows it, and the
/// vehicle's [`SpeedLimit`](crate::SpeedLimit).
#[derive(Bundle, Default)]
pub struct SharedController {
    /// The target the driver writes.
    pub target: DriveTarget,
    /// The PID loops that follow it.
    pub controller: TargetController,
    /// The limit the vehicle obeys.
    pub limit: crate::SpeedLimit,
}

/// Where a junction may hold a vehicle: its gate and where it is on its road.
type HeldAt = (
    &'static crate::JunctionGate,
    &'static flockway_vehicle::RoadTrack,
);

/// From this many vehicles [`follow_targets`] runs over the task pool: a car's share is one
/// search for the vehicle ahead and a PID update, lighter than the decisions' or the forces'.
const FOLLOW_PARALLEL_MIN: usize = 512;

/// What [`follow_targets`] reads and writes on one vehicle.
type Followed = (
    Entity,
    &'static DriveTarget,
    &'static Motion,
    &'static VehicleModel,
    &'static VehicleState,
    &'static mut TargetController,
    &'static mut Controls,
    Option<HeldAt>,
    (
        Option<&'static SafetyParams>,
        Option<&'static LaneSignal>,
        Option<&'static AheadMemo>,
    ),
);

/// Turns every vehicle's [`DriveTarget`] into [`Controls`] through its [`TargetController`],
/// within what a junction holding it allows and within its braking envelope
/// ([`SafetyParams`]; the defaults for a vehicle without one): whatever its driver asked for,
/// it never goes faster than lets it stop behind the vehicle ahead of it.
pub fn follow_targets(
    network: Res<RoadNetwork>,
    index: Res<LaneIndex>,
    clock: Res<SimClock>,
    mut vehicles: Query<Followed>,
) {
    let tick = clock.tick();
    let run = |_: &mut (), item: QueryItem<'_, '_, Followed>| {
        follow_one(&network, &index, tick, item);
    };
    // Each car reads the shared index and road network and writes only its own controller and
    // controls, so the answers are the same whichever thread finds them.
    for_each_car(&mut vehicles, FOLLOW_PARALLEL_MIN, || (), run);
}

/// One vehicle's controls for its target, capped as [`follow_targets`] says; the safety layer's
/// search reads the vehicle's [`AheadMemo`] of tick `tick` where it gives the answer (the
/// conflict measures leave one).
// Inlined into both loops of `follow_targets`: as a call per car, passing the item's many
// references cost more instructions than the loop's work saved (callgrind, `dense_road`).
#[inline(always)]
fn follow_one(
    network: &RoadNetwork,
    index: &LaneIndex,
    tick: Tick,
    item: QueryItem<'_, '_, Followed>,
) {
    let (
        me,
        target,
        motion,
        model,
        state,
        mut controller,
        mut controls,
        gate,
        (safety, signal, memo),
    ) = item;
    let chassis = &model.0.params.chassis;
    // A junction holding the vehicle: no faster than stops it at the line, whoever drives.
    let held = gate.map_or(f32::INFINITY, |(g, track)| {
        g.cap_mps(track.s_m, chassis.length_m)
    });
    let safe = gate.map_or(f32::INFINITY, |(_, track)| {
        let view = SafetyView::new(me, track, motion, model, signal);
        let params = safety.copied().unwrap_or_default();
        let memo = memo.map(|m| (m, tick));
        safe_speed_mps(network, index, &params, &view, memo)
    });
    let cap = held.min(safe);
    // One call for both cases, so that the controller can be inlined here.
    let target = if cap < target.speed_mps {
        DriveTarget {
            speed_mps: cap,
            accel_mps2: target
                .accel_mps2
                .map(|a| a.min((cap - motion.forward_mps) / CAP_RESPONSE_S)),
            ..*target
        }
    } else {
        *target
    };
    *controls = controller.control(&target, motion, &model.0, state);
    // Over the safe speed: brake at least in proportion, whatever the speed loop's integral
    // remembers of cruising.
    let over = motion.forward_mps - safe;
    if over > 0.0 && motion.forward_mps > STANDSTILL_MPS {
        let least = -(over * OVER_SAFE_BRAKE_PER_MPS).min(1.0);
        controls.throttle = controls.throttle.min(least);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heading_error_wraps() {
        let e = wrap_angle(175f32.to_radians() - (-175f32).to_radians());
        assert!((e.to_degrees() + 10.0).abs() < 1e-3, "{}", e.to_degrees());
        let e = wrap_angle((-175f32).to_radians() - 175f32.to_radians());
        assert!((e.to_degrees() - 10.0).abs() < 1e-3);
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-5);
        assert_eq!(wrap_angle(0.25), 0.25);
    }

    #[test]
    fn pid_output_is_clamped_and_does_not_wind_up() {
        let gains = PidGains {
            kp: 1.0,
            ki: 1.0,
            kd: 0.0,
        };
        let mut pid = Pid::default();
        for _ in 0..1000 {
            assert_eq!(pid.update(&gains, 10.0, 0.01), 1.0);
        }
        // After a long saturation the output comes off the stop as soon as the error turns.
        let out = pid.update(&gains, -0.5, 0.01);
        assert!(out < 0.0, "{out}");
        assert!(pid.update(&gains, f32::NAN, 0.01).is_finite());
    }

    #[test]
    fn pid_integrates_at_the_rate_it_is_given() {
        let gains = PidGains {
            kp: 0.1,
            ki: 0.5,
            kd: 0.0,
        };
        let (mut full, mut none, mut half) = (Pid::default(), Pid::default(), Pid::default());
        for _ in 0..100 {
            full.update_integrating(&gains, 0.2, 0.01, 1.0);
            none.update_integrating(&gains, 0.2, 0.01, 0.0);
            half.update_integrating(&gains, 0.2, 0.01, 0.5);
        }
        // Proportional 0.02 alone; with the integral of 0.2 over 1.01 s (or half of it) × 0.5.
        assert_eq!(none.update_integrating(&gains, 0.2, 0.01, 0.0), 0.1 * 0.2);
        let full_out = full.update_integrating(&gains, 0.2, 0.01, 1.0);
        let half_out = half.update_integrating(&gains, 0.2, 0.01, 0.5);
        assert!((full_out - (0.02 + 0.5 * 0.202)).abs() < 1e-4, "{full_out}");
        assert!((half_out - (0.02 + 0.5 * 0.101)).abs() < 1e-4, "{half_out}");
        // The full rate is `update` to the bit.
        let mut plain = Pid::default();
        let mut rated = Pid::default();
        for k in 0..50 {
            let e = (k as f32 * 0.37).sin();
            assert_eq!(
                plain.update(&gains, e, 0.01).to_bits(),
                rated.update_integrating(&gains, e, 0.01, 1.0).to_bits()
            );
        }
    }

    /// A car standing still with its heading off its target's (waiting mid-turn for oncoming
    /// traffic) keeps the steering it started with: the loop's integral does not creep it to
    /// full lock over the wait.
    #[test]
    fn a_waiting_car_does_not_wind_its_steering_up() {
        let vehicle = VehicleType::default();
        let state = VehicleState {
            wheels: Default::default(),
            gearbox: flockway_vehicle::Gearbox::for_speed(
                &vehicle.params.gearbox,
                0.0,
                vehicle.params.wheels.radius_m,
            ),
            engine_omega: 0.0,
            clutch: 0.0,
            steer: 0.0,
            pedals: Default::default(),
        };
        let motion = |speed: f32| Motion {
            position: glam::Vec3::ZERO,
            rotation: glam::Quat::IDENTITY,
            linvel: glam::Vec3::X * speed,
            angvel: glam::Vec3::ZERO,
            forward_mps: speed,
            accel_mps2: 0.0,
        };
        let target = DriveTarget {
            speed_mps: 0.0,
            heading_rad: 0.15,
            curvature_per_m: 0.0,
            accel_mps2: Some(0.0),
        };
        let mut waiting = TargetController::default();
        let first = waiting
            .control(&target, &motion(0.0), &vehicle, &state)
            .steering;
        let mut last = first;
        for _ in 0..(20 * 120) {
            last = waiting
                .control(&target, &motion(0.0), &vehicle, &state)
                .steering;
        }
        assert!(first > 0.0, "{first}");
        assert_eq!(last, first);
        // Rolling, the same error is integrated away as before.
        let mut rolling = TargetController::default();
        let start = rolling
            .control(&target, &motion(5.0), &vehicle, &state)
            .steering;
        for _ in 0..120 {
            last = rolling
                .control(&target, &motion(5.0), &vehicle, &state)
                .steering;
        }
        assert!(last > start + 0.01, "{start} -> {last}");
    }

    #[test]
    fn the_body_points_out_of_a_bend_at_a_crawl_and_into_it_fast() {
        let sedan = VehicleType::default();
        assert_eq!(steady_sideslip_rad(&sedan, 10.0, 0.0), 0.0);
        // Turning left at a junction (radius 10 m) at a crawl: the centre of mass, half the
        // wheelbase ahead of the rear axle, moves that far into the bend's angle.
        let half = 0.5 * sedan.params.wheels.wheelbase_m;
        let crawl = steady_sideslip_rad(&sedan, 0.0, 0.1);
        assert!((crawl - (half * 0.1).atan()).abs() < 1e-6, "{crawl}");
        assert_eq!(steady_sideslip_rad(&sedan, 0.0, -0.1), -crawl);
        // Fast, the rear tyres' slip angle turns the nose into the bend: on a 150 m curve at
        // 60 km/h, a few tenths of a degree.
        let fast = steady_sideslip_rad(&sedan, 60.0 / 3.6, 1.0 / 150.0);
        assert!(fast < 0.0 && fast > -0.01, "{fast}");
    }

    #[test]
    fn pid_integral_removes_a_steady_error() {
        let gains = PidGains {
            kp: 0.5,
            ki: 2.0,
            kd: 0.0,
        };
        let mut pid = Pid::default();
        // A plant that needs an output of 0.3 to hold zero error: y' = u - 0.3.
        let mut y = 0.0f32;
        for _ in 0..5000 {
            let u = pid.update(&gains, 1.0 - y, 0.01);
            y += (u - 0.3) * 0.01 * 5.0;
        }
        assert!((y - 1.0).abs() < 1e-3, "{y}");
    }
}

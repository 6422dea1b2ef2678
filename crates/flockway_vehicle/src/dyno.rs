//! The dyno: standard performance tests of a vehicle type on test tracks, in the full simulation.

use crate::VehiclePlugin;
use crate::{Controls, Motion, VehicleSpawn, VehicleType, spawn_vehicle};
use bevy_ecs::prelude::*;
use flockway_core::{Sim, TICKS_PER_SECOND};
use flockway_road::{ControlPoint, Road, RoadId, RoadSpec};
use glam::{DVec3, Vec3};
use serde::Serialize;
use std::sync::Arc;

/// 100 km/h in m/s.
const KMH_100: f32 = 100.0 / 3.6;

/// Limits of the dyno runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DynoSettings {
    /// Longest acceleration run, s (top speed is where speed stops rising, or the value then).
    pub max_accel_s: f32,
    /// Radius of the skid-pad circle, m.
    pub skidpad_radius_m: f64,
    /// Length of the standstill test, s.
    pub standstill_s: f32,
}

impl Default for DynoSettings {
    fn default() -> Self {
        DynoSettings {
            max_accel_s: 150.0,
            skidpad_radius_m: 50.0,
            standstill_s: 60.0,
        }
    }
}

/// What the dyno measured. Its JSON keys are a documented contract.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DynoReport {
    /// Time from rest to 100 km/h at full throttle, s (`null` if never reached).
    pub zero_to_100_kmh_s: Option<f64>,
    /// Highest speed at full throttle on the level straight, km/h.
    pub top_speed_kmh: f64,
    /// Distance to stop from 100 km/h with full brakes, m.
    pub braking_100_0_m: f64,
    /// Highest steady lateral acceleration on the skid-pad circle, in g.
    pub max_lateral_g: f64,
    /// Horizontal distance a parked car moves with no input, m.
    pub standstill_drift_m: f64,
}

/// A one-car world on one test road.
struct Track {
    sim: Sim,
    car: Entity,
}

impl Track {
    fn new(road: RoadSpec, model: &Arc<VehicleType>, s_m: f64, speed_mps: f32) -> Track {
        let mut sim = Sim::new(0);
        sim.add_plugin(VehiclePlugin);
        sim.world_mut().spawn((RoadId(0), Road(road)));
        // The step is built from plugins we control, so a conflict is a bug of ours.
        if let Err(e) = sim.prepare() {
            panic!("dyno schedule: {e}");
        }
        // One tick builds the network and the static colliders.
        sim.step();
        let car = match spawn_vehicle(
            sim.world_mut(),
            VehicleSpawn {
                model: model.clone(),
                road: RoadId(0),
                s_m,
                lateral_m: 0.0,
                speed_mps,
            },
        ) {
            Ok(e) => e,
            Err(e) => panic!("dyno spawn: {e}"),
        };
        Track { sim, car }
    }

    fn motion(&self) -> Motion {
        *self
            .sim
            .world()
            .get::<Motion>(self.car)
            .unwrap_or_else(|| panic!("the dyno car has no motion"))
    }

    fn drive(&mut self, controls: Controls) -> Motion {
        if let Some(mut c) = self.sim.world_mut().get_mut::<Controls>(self.car) {
            *c = controls;
        }
        self.sim.step();
        self.motion()
    }
}

/// A flat straight road along +x, `length_m` long and 12 m wide.
fn straight(length_m: f64) -> RoadSpec {
    let n = (length_m / 500.0).ceil() as usize;
    let points: Vec<DVec3> = (0..=n)
        .map(|i| DVec3::new(length_m * i as f64 / n as f64, 0.0, 0.0))
        .collect();
    let mut spec = RoadSpec::through("dyno_straight", 3, 200.0, &points);
    spec.lane_width_m = 4.0;
    spec
}

/// Steering that keeps a car on the road's centre line along +x (for long runs, where a
/// millimetre of asymmetry would otherwise add up over kilometres).
fn hold_line(m: &Motion) -> f32 {
    let heading = libm::atan2f(m.forward().y, m.forward().x);
    (-0.05 * m.position.y - 0.8 * heading).clamp(-0.2, 0.2)
}

/// Runs every dyno test of a vehicle type (in parallel where cores allow).
pub fn run_dyno(model: &Arc<VehicleType>, settings: &DynoSettings) -> DynoReport {
    std::thread::scope(|scope| {
        let accel = scope.spawn(|| acceleration(model, settings));
        let braking = scope.spawn(|| braking(model));
        let lateral = skidpad(model, settings);
        let drift = standstill(model, settings);
        let (zero_to_100, top) = accel
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e));
        let braking = braking
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e));
        DynoReport {
            zero_to_100_kmh_s: zero_to_100,
            top_speed_kmh: top,
            braking_100_0_m: braking,
            max_lateral_g: lateral,
            standstill_drift_m: drift,
        }
    })
}

/// Full throttle from rest: time to 100 km/h and the speed where acceleration dies out.
fn acceleration(model: &Arc<VehicleType>, settings: &DynoSettings) -> (Option<f64>, f64) {
    let max_s = f64::from(settings.max_accel_s);
    // Long enough for the whole run at any plausible top speed.
    let length = 60.0 * max_s + 200.0;
    let mut track = Track::new(straight(length), model, 20.0, 0.0);
    let ticks = (max_s * TICKS_PER_SECOND as f64) as u64;
    let mut t100 = None;
    let mut top = 0.0f32;
    let window = 10 * u64::from(TICKS_PER_SECOND);
    let mut window_start_speed = 0.0f32;
    for tick in 1..=ticks {
        let m = track.motion();
        let m = track.drive(Controls {
            throttle: 1.0,
            steering: hold_line(&m),
            handbrake: false,
        });
        if t100.is_none() && m.forward_mps >= KMH_100 {
            t100 = Some(tick as f64 / TICKS_PER_SECOND as f64);
        }
        top = top.max(m.forward_mps);
        if tick % window == 0 {
            // Speed is flat: less than 0.2 km/h gained in ten seconds.
            if tick > window && (m.forward_mps - window_start_speed) * 3.6 < 0.2 {
                break;
            }
            window_start_speed = m.forward_mps;
        }
    }
    (t100, f64::from(top) * 3.6)
}

/// Full brakes from 100 km/h on the straight: distance to a stop.
fn braking(model: &Arc<VehicleType>) -> f64 {
    let mut track = Track::new(straight(800.0), model, 50.0, KMH_100);
    // Settle for a second at 100 km/h (speed held by a simple controller).
    for _ in 0..TICKS_PER_SECOND {
        let m = track.motion();
        let throttle = (0.2 + 0.5 * (KMH_100 - m.forward_mps)).clamp(0.0, 1.0);
        track.drive(Controls {
            throttle,
            steering: hold_line(&m),
            handbrake: false,
        });
    }
    let start = track.motion();
    let v0 = start.forward_mps;
    let mut m = start;
    for _ in 0..(30 * TICKS_PER_SECOND) {
        m = track.drive(Controls {
            throttle: -1.0,
            steering: 0.0,
            handbrake: false,
        });
        if m.forward_mps <= 0.05 {
            break;
        }
    }
    let d = f64::from((m.position - start.position).length());
    // Scale to exactly 100 km/h (distance grows with the square of speed).
    d * f64::from(KMH_100 / v0).powi(2)
}

/// Circling a skid pad ever faster: the highest lateral acceleration held for a second on the
/// line.
fn skidpad(model: &Arc<VehicleType>, settings: &DynoSettings) -> f64 {
    let radius = settings.skidpad_radius_m;
    let mut spec = RoadSpec::ring("skidpad", 3, 200.0, DVec3::ZERO, radius, 24);
    spec.lane_width_m = 4.0;
    for p in &mut spec.points {
        *p = ControlPoint {
            guardrail_left: false,
            guardrail_right: false,
            ..p.clone()
        };
    }
    let start_speed = 8.0f32;
    let mut track = Track::new(spec, model, 0.0, start_speed);
    let wheelbase = model.params.wheels.wheelbase_m;
    let r = radius as f32;
    let mut target = start_speed;
    let mut best = 0.0f32;
    let window = TICKS_PER_SECOND as usize;
    let mut history: std::collections::VecDeque<(f32, bool)> =
        std::collections::VecDeque::with_capacity(window);
    let mut int_err = 0.0f32;
    for _ in 0..(180 * TICKS_PER_SECOND) {
        let m = track.motion();
        let pos = Vec3::new(m.position.x, m.position.y, 0.0);
        let dist = pos.length();
        let err = dist - r; // positive: outside the line
        let radial = pos / dist.max(1.0e-3);
        let tangent = Vec3::new(-radial.y, radial.x, 0.0); // counter-clockwise
        let fwd = m.forward();
        let heading_err = libm::atan2f(tangent.cross(fwd).z, tangent.dot(fwd)); // positive: pointing left
        let speed = m.linvel.truncate().length();
        int_err = (int_err + err / TICKS_PER_SECOND as f32).clamp(-5.0, 5.0);
        let share = model
            .params
            .steering
            .center_angle_rad(1.0, speed * 3.6)
            .max(1.0e-3);
        let feedforward = libm::atanf(wheelbase / r);
        let steer_angle = feedforward + 0.08 * err + 0.01 * int_err - 1.2 * heading_err;
        let steering = (steer_angle / share).clamp(-1.0, 1.0);
        let throttle = (0.3 + 0.6 * (target - m.forward_mps)).clamp(-1.0, 1.0);
        let m = track.drive(Controls {
            throttle,
            steering,
            handbrake: false,
        });
        let pos = Vec3::new(m.position.x, m.position.y, 0.0);
        let dist = pos.length();
        let speed = m.linvel.truncate().length();
        let on_line = (dist - r).abs() < 1.0;
        history.push_back((speed * speed / dist.max(1.0), on_line));
        if history.len() > window {
            history.pop_front();
        }
        if history.len() == window && history.iter().all(|h| h.1) {
            let mean = history.iter().map(|h| h.0).sum::<f32>() / window as f32;
            best = best.max(mean);
        }
        if (dist - r).abs() > 4.0 {
            break; // it has left the circle: the limit is behind us
        }
        target += 0.1 / TICKS_PER_SECOND as f32;
    }
    f64::from(best / -crate::GRAVITY.z)
}

/// A parked car with no input for a minute: how far it moves.
fn standstill(model: &Arc<VehicleType>, settings: &DynoSettings) -> f64 {
    let mut track = Track::new(straight(200.0), model, 100.0, 0.0);
    let start = track.motion().position;
    let ticks = (settings.standstill_s * TICKS_PER_SECOND as f32) as u64;
    let mut m = track.motion();
    for _ in 0..ticks {
        m = track.drive(Controls::default());
    }
    f64::from((m.position - start).truncate().length())
}

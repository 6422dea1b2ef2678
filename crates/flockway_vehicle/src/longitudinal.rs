//! The inverse of a vehicle's longitudinal dynamics: the throttle axis expected to give an
//! asked-for acceleration, for drivers that command accelerations rather than speeds (the IDM as
//! published). It is the steady-state model of the same drivetrain the step integrates — drag,
//! rolling resistance and grade, the engine's torque curve and losses through the viscous clutch
//! and the current gear, the rotating inertia the car drags along, the service brakes — so a
//! controller that feeds it forward has only the model's small errors left to correct.

use crate::components::{VehicleState, VehicleType};
use crate::drivetrain::{Gearbox, RPM_TO_RAD_S};
use crate::physics::GRAVITY;

/// The longitudinal forces on a vehicle at one moment, N along its heading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LongitudinalModel {
    /// Mass the wheels accelerate, the spinning wheels and (clutch engaged) engine included, kg.
    pub effective_mass_kg: f32,
    /// Drag, rolling resistance and grade together, N (positive holds the car back).
    pub resistance_n: f32,
    /// Drive force at zero throttle, N: engine braking with the clutch engaged (negative), 0 with
    /// it open.
    pub coast_n: f32,
    /// Drive force at full throttle, N.
    pub full_throttle_n: f32,
    /// Braking force at full service brake, N.
    pub full_brake_n: f32,
    engine: Option<EngineTerms>,
}

/// The engine seen through an engaged clutch: F(thr) = (g/r)·K·(thr·T − c(thr)·W)/(c(thr) + K),
/// c(thr) = c₀ + Δ·thr, the steady state of the engine's spin equation with the clutch slipping
/// in proportion to the torque it passes.
#[derive(Debug, Clone, Copy, PartialEq)]
struct EngineTerms {
    /// Overall ratio over wheel radius, 1/m.
    g_over_r: f32,
    /// Clutch strength K, N·m·s/rad.
    k: f32,
    /// Full-throttle torque T at the locked engine speed, N·m.
    torque: f32,
    /// Locked engine speed W = g·v/r, rad/s.
    omega: f32,
    /// Zero-throttle loss c₀, N·m·s/rad.
    c0: f32,
    /// Full-throttle loss less c₀, N·m·s/rad.
    dc: f32,
}

impl EngineTerms {
    fn force_n(&self, thr: f32) -> f32 {
        let c = self.c0 + self.dc * thr;
        self.g_over_r * self.k * (thr * self.torque - c * self.omega) / (c + self.k)
    }

    /// The throttle giving drive force `f` (between the zero- and full-throttle forces).
    fn throttle_for(&self, f: f32) -> f32 {
        let q = f / (self.g_over_r * self.k);
        let denom = self.torque - self.dc * self.omega - q * self.dc;
        if denom <= 0.0 {
            return 1.0;
        }
        ((self.c0 * self.omega + q * (self.c0 + self.k)) / denom).clamp(0.0, 1.0)
    }
}

impl LongitudinalModel {
    /// The model of vehicle type `t` in state `state`, moving at `forward_mps` on a slope whose
    /// rise per metre along its heading is `grade` (the forward axis' vertical component).
    pub fn new(t: &VehicleType, state: &VehicleState, forward_mps: f32, grade: f32) -> Self {
        let p = &t.params;
        let ch = &p.chassis;
        let r = t.driveline.radius_m.max(0.05);
        let v = forward_mps.max(0.0);
        let drag = 0.5 * ch.air_density_kg_m3 * ch.drag_coefficient * ch.frontal_area_m2 * v * v;
        let g = -GRAVITY.z;
        let cos = (1.0 - grade * grade).max(0.0).sqrt();
        let rolling = if v > 0.05 {
            ch.rolling_resistance * ch.mass_kg * g * cos
        } else {
            0.0
        };
        let resistance_n = drag + rolling + ch.mass_kg * g * grade;
        // The gear the car is in, or is shifting into (the clutch closes again within the shift
        // time, and a controller asking for the new gear's throttle avoids a jolt then).
        let gear = state.gearbox.target.max(state.gearbox.gear);
        let ratio = Gearbox::ratio_of(&p.gearbox, gear).abs();
        let omega = ratio * v / r;
        let wheels_inertia = 4.0 * t.driveline.wheel_inertia / (r * r);
        let engaged = !state.gearbox.shifting() && omega >= t.driveline.idle_omega;
        let engine = (ratio > 0.0).then(|| EngineTerms {
            g_over_r: ratio / r,
            k: t.driveline.clutch_strength.max(1.0e-3),
            torque: p
                .engine
                .torque_at(omega.max(t.driveline.idle_omega) / RPM_TO_RAD_S),
            omega: omega.max(t.driveline.idle_omega),
            c0: p.engine.damping_zero_throttle_clutch_engaged,
            dc: p.engine.damping_full_throttle - p.engine.damping_zero_throttle_clutch_engaged,
        });
        let (coast_n, full_throttle_n, engine_mass) = match engine {
            Some(e) if engaged => (
                e.force_n(0.0),
                e.force_n(1.0),
                t.driveline.engine_inertia * e.g_over_r * e.g_over_r,
            ),
            // Pulling away (the clutch slips in proportion to the accelerator) or shifting: no
            // engine braking, and about the launch torque at full throttle.
            Some(e) => (0.0, e.torque * e.g_over_r, 0.0),
            None => (0.0, 0.0, 0.0),
        };
        LongitudinalModel {
            effective_mass_kg: ch.mass_kg + wheels_inertia + engine_mass,
            resistance_n,
            coast_n,
            full_throttle_n,
            full_brake_n: 4.0 * p.brakes.max_brake_torque_nm / r,
            engine: engine.filter(|_| engaged),
        }
    }

    /// The throttle axis (−1 full brake … 1 full throttle) expected to give acceleration
    /// `accel_mps2` along the heading: drive through the engine where engine braking alone would
    /// slow the car too much, the service brakes beyond it.
    pub fn throttle_for(&self, accel_mps2: f32) -> f32 {
        let need = self.effective_mass_kg * accel_mps2 + self.resistance_n;
        if need >= self.coast_n {
            match &self.engine {
                Some(e) => e.throttle_for(need),
                None if self.full_throttle_n > 0.0 => (need / self.full_throttle_n).clamp(0.0, 1.0),
                None => 0.0,
            }
        } else {
            -((self.coast_n - need) / self.full_brake_n.max(1.0)).clamp(0.0, 1.0)
        }
    }

    /// The acceleration the model expects from throttle axis `throttle`, m/s² (the forward
    /// direction of [`LongitudinalModel::throttle_for`]).
    pub fn accel_for(&self, throttle: f32) -> f32 {
        let force = if throttle >= 0.0 {
            match &self.engine {
                Some(e) => e.force_n(throttle.min(1.0)),
                None => throttle.min(1.0) * self.full_throttle_n,
            }
        } else {
            self.coast_n + throttle.max(-1.0) * self.full_brake_n
        };
        (force - self.resistance_n) / self.effective_mass_kg
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::VehicleParams;

    fn sedan() -> VehicleType {
        VehicleType::new(VehicleParams::default())
    }

    fn in_gear(t: &VehicleType, v: f32) -> VehicleState {
        VehicleState {
            wheels: Default::default(),
            gearbox: Gearbox::for_speed(&t.params.gearbox, v, t.params.wheels.radius_m),
            engine_omega: 0.0,
            clutch: 1.0,
            steer: 0.0,
            pedals: Default::default(),
        }
    }

    #[test]
    fn the_throttle_for_an_acceleration_gives_that_acceleration_back() {
        let t = sedan();
        for v in [3.0f32, 8.0, 15.0, 25.0] {
            let m = LongitudinalModel::new(&t, &in_gear(&t, v), v, 0.0);
            for a in [-6.0f32, -2.0, -0.5, 0.0, 0.3, 1.0] {
                let thr = m.throttle_for(a);
                let back = m.accel_for(thr);
                // Within what full throttle or full brakes can give.
                let lo = m.accel_for(-1.0);
                let hi = m.accel_for(1.0);
                let want = a.clamp(lo, hi);
                assert!(
                    (back - want).abs() < 1.0e-3,
                    "v {v} a {a}: throttle {thr} gives {back}, range {lo}..{hi}"
                );
            }
        }
    }

    #[test]
    fn engine_braking_and_grade_shift_the_throttle() {
        let t = sedan();
        let v = 15.0;
        let flat = LongitudinalModel::new(&t, &in_gear(&t, v), v, 0.0);
        // Engaged, off throttle: the engine brakes the car harder than drag alone.
        assert!(flat.coast_n < 0.0, "{flat:?}");
        // Holding speed needs throttle (the engine's losses at part throttle are large); uphill
        // more.
        let cruise = flat.throttle_for(0.0);
        assert!(cruise > 0.0 && cruise < 1.0, "{cruise}");
        let uphill = LongitudinalModel::new(&t, &in_gear(&t, v), v, 0.05);
        assert!(uphill.throttle_for(0.0) > cruise);
        // Beyond engine braking, the brakes; beyond them, full brakes.
        let coast = flat.accel_for(0.0);
        assert!(flat.throttle_for(coast - 1.0) < 0.0);
        assert_eq!(flat.throttle_for(-30.0), -1.0);
    }
}

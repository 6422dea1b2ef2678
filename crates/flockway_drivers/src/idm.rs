//! The Intelligent Driver Model (Treiber, Hennecke & Helbing 2000): a driver model in one file.

use crate::ahead::RoadAheadParams;
use crate::control::PidGains;
use crate::models::{FlockParams, SpeedFactorParams};
use crate::perception::Seen;
use crate::pipeline::{DrivingModel, LaneStyle, Longitudinal, Proposal, Situation};
use crate::route::LANE_END_MARGIN_M;
use crate::safety::SafetyParams;
use bevy_ecs::prelude::*;
use serde::{Deserialize, Serialize};

/// Parameters of the Intelligent Driver Model (Treiber, Hennecke & Helbing 2000), with lane
/// keeping from the flocking driver's road following.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IdmParams {
    /// Desired speed v₀, km/h; `None` drives at the speed limit.
    pub target_speed_kmh: Option<f32>,
    /// Safe time headway T, s.
    pub time_headway_s: f32,
    /// Minimum bumper-to-bumper gap s₀, m.
    pub min_gap_m: f32,
    /// Maximum acceleration a, m/s².
    pub max_accel_mps2: f32,
    /// Comfortable deceleration b, m/s².
    pub comfortable_decel_mps2: f32,
    /// Acceleration exponent δ.
    pub delta: f32,
    /// How far ahead it looks for a leader, m.
    pub detection_range_m: f32,
    /// How soon a speed it must come down to (making room for a merging car, the merge it
    /// waits for) is reached, s: such a cap becomes the acceleration that reaches it in this
    /// time. The speed `v + a·horizon` is also what it shows as its target speed.
    pub accel_horizon_s: f32,
    /// Road following, as for the flocking driver (m/s per m).
    pub road_weight_per_s: f32,
    /// Largest sideways speed asked for, m/s.
    pub max_lateral_mps: f32,
    /// Lane direction look-ahead, s.
    pub lookahead_s: f32,
    /// Time gap needed ahead of and behind the car in the target lane before a lane change, s.
    pub lane_change_gap_s: f32,
    /// How hard it brakes, at most, to make room for a car signalling to merge in ahead of it,
    /// m/s² (0: it does not make room).
    pub courtesy_decel_mps2: f32,
    /// The least time, s, before a vehicle it gives way to at a junction reaches their
    /// conflict, that it accepts to go (its critical gap).
    pub critical_gap_s: f32,
    /// Where it gives way at a junction, the least time after the car before it entered the
    /// same path that it follows it through the same gap, s (its follow-up time).
    pub follow_up_s: f32,
    /// How often it decides, s (see [`FlockParams::action_step_s`]).
    pub action_step_s: f32,
    /// How it slows for bends and slippery stretches ahead.
    pub road_ahead: RoadAheadParams,
    /// Its braking envelope (see [`FlockParams::safety`]).
    pub safety: SafetyParams,
    /// Each driver's desired speed as a share of v₀, drawn once per vehicle.
    pub speed_factor: SpeedFactorParams,
    /// Throttle PID on speed error (per m/s).
    pub throttle: PidGains,
    /// Steering PID on heading error (per rad).
    pub steering: PidGains,
}

impl Default for IdmParams {
    fn default() -> Self {
        let flock = FlockParams::default();
        IdmParams {
            target_speed_kmh: None,
            time_headway_s: 1.5,
            min_gap_m: 2.0,
            max_accel_mps2: 1.0,
            comfortable_decel_mps2: 1.5,
            delta: 4.0,
            detection_range_m: 150.0,
            accel_horizon_s: 0.5,
            road_weight_per_s: flock.road_weight_per_s,
            max_lateral_mps: flock.max_lateral_mps,
            lookahead_s: flock.lookahead_s,
            lane_change_gap_s: flock.lane_change_gap_s,
            courtesy_decel_mps2: flock.courtesy_decel_mps2,
            critical_gap_s: flock.critical_gap_s,
            follow_up_s: flock.follow_up_s,
            action_step_s: flock.action_step_s,
            road_ahead: flock.road_ahead,
            safety: flock.safety,
            speed_factor: flock.speed_factor,
            throttle: PidGains {
                kp: 0.8,
                ki: 0.2,
                kd: 0.0,
            },
            steering: flock.steering,
        }
    }
}

/// The Intelligent Driver Model: its acceleration is the command.
#[derive(Component, Debug, Clone, PartialEq)]
pub struct IdmDriver {
    /// Its parameters; edits take effect at the next tick.
    pub params: IdmParams,
}

impl DrivingModel for IdmDriver {
    fn cruise_kmh(&self) -> Option<f32> {
        self.params.target_speed_kmh
    }

    fn style(&self) -> LaneStyle {
        let p = &self.params;
        LaneStyle {
            keep_lane: true,
            speed_weight: 1.0,
            road_weight_per_s: p.road_weight_per_s,
            max_lateral_mps: p.max_lateral_mps,
            lookahead_s: p.lookahead_s,
            lane_change_gap_s: p.lane_change_gap_s,
            courtesy_decel_mps2: p.courtesy_decel_mps2,
        }
    }

    /// The IDM acceleration behind its leader in its lane (across links), and behind the end
    /// of a lane it has not left yet as behind a standing car.
    fn decide(&mut self, at: &Situation, _seen: &mut Vec<Seen>) -> Proposal {
        let p = &self.params;
        let (track, v, length) = (at.track, at.v, at.size_m.0);
        let leader = at
            .leader(f64::from(p.detection_range_m))
            .map(|(gap, v_leader)| (gap, v - v_leader));
        let v0 = at.v_desired.min(at.leaving_cap_mps);
        let mut a = idm_accel(p, v, v0, leader);
        if let Some(r) = at.route {
            let end =
                r.lane_end_m(at.lane) - track.s_m - 0.5 * f64::from(length) - LANE_END_MARGIN_M;
            if end.is_finite() {
                a = a.min(idm_accel(p, v, v0, Some((end as f32, v))));
            }
        }
        Proposal {
            longitudinal: Longitudinal::Accel {
                accel_mps2: a,
                horizon_s: p.accel_horizon_s.max(0.1),
                max_mps2: p.max_accel_mps2,
            },
            steer_by: None,
        }
    }
}

/// The IDM acceleration, m/s², for speed `v`, desired speed `v0`, and a leader at bumper gap
/// `gap_m` closing at `dv` (own speed minus leader's), if any.
pub fn idm_accel(p: &IdmParams, v: f32, v0: f32, leader: Option<(f32, f32)>) -> f32 {
    let v = v.max(0.0);
    let free = 1.0 - libm::powf(v / v0.max(0.1), p.delta);
    let interaction = match leader {
        Some((gap, dv)) => {
            let s_star = p.min_gap_m
                + (v * p.time_headway_s
                    + v * dv / (2.0 * (p.max_accel_mps2 * p.comfortable_decel_mps2).sqrt()))
                .max(0.0);
            let s = gap.max(0.1);
            (s_star / s).powi(2)
        }
        None => 0.0,
    };
    p.max_accel_mps2 * (free - interaction)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn idm_matches_the_published_equation() {
        let p = IdmParams::default();
        // Free road at half the desired speed: a (1 − 0.5⁴) = 0.9375 a.
        assert!((idm_accel(&p, 10.0, 20.0, None) - 0.9375).abs() < 1e-6);
        // At the desired speed on a free road: zero.
        assert!(idm_accel(&p, 20.0, 20.0, None).abs() < 1e-6);
        // Standing behind a stopped leader at exactly s₀: free term 1, interaction (s₀/s₀)² = 1.
        assert!(idm_accel(&p, 0.0, 20.0, Some((2.0, 0.0))).abs() < 1e-6);
        // Following at 20 m/s, 30 m gap, same speed: s* = 2 + 30 = 32; a(1 − 1 − (32/30)²).
        let a = idm_accel(&p, 20.0, 20.0, Some((30.0, 0.0)));
        assert!((a + (32.0f32 / 30.0).powi(2)).abs() < 1e-5, "{a}");
        // Closing fast on a near leader: hard braking.
        assert!(idm_accel(&p, 20.0, 20.0, Some((15.0, 10.0))) < -5.0);
    }
}

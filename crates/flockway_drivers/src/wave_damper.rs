//! The wave-damping autonomous car (after Stern et al. 2018): a driver model in one file.

use crate::control::DriveTarget;
use crate::control::PidGains;
use crate::models::{FlockParams, flock_law};
use crate::perception::Seen;
use crate::pipeline::{DrivingModel, LaneStyle, Proposal, Situation};
use bevy_ecs::prelude::*;
use serde::{Deserialize, Serialize};

/// Parameters of the wave-damping autonomous car: lane following and a safety backstop from
/// the flocking driver, and a speed law after Stern et al.'s "PI controller with saturation"
/// (Transp. Res. C 89, 2018): it drives at the mean speed of the traffic it has been in,
/// estimated from its own speed, and leaves a gap that swallows the leader's stop-and-go.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WaveDamperParams {
    /// Lane following, controller gains and a short-range avoidance that only a car far too
    /// close triggers: its target speed is at most what this flocking driver would choose.
    pub flock: FlockParams,
    /// Time constant of the running mean of its own speed (the estimate of the flow's speed), s.
    pub average_time_s: f32,
    /// Bumper gap below which it does not speed up above the mean, m.
    pub gap_lower_m: f32,
    /// Bumper gap at which it speeds up by the whole catch-up speed, m.
    pub gap_upper_m: f32,
    /// How much faster than the mean it drives to close a long gap, m/s.
    pub catch_up_mps: f32,
    /// Smallest safe bumper gap, m.
    pub min_gap_m: f32,
    /// Safe gap per m/s it closes on its leader, s.
    pub closing_time_s: f32,
    /// Gap over which it blends from its leader's speed to its own target, m.
    pub blend_m: f32,
    /// How far ahead it looks for its leader, m (centre to centre).
    pub leader_range_m: f32,
}

impl Default for WaveDamperParams {
    fn default() -> Self {
        WaveDamperParams {
            flock: FlockParams {
                detection_range_m: 25.0,
                anticipation_s: 0.3,
                adjacent_range_m: 5.0,
                rear_weight: 0.0,
                throttle: PidGains {
                    kp: 0.3,
                    ki: 0.05,
                    kd: 0.0,
                },
                ..FlockParams::default()
            },
            average_time_s: 30.0,
            gap_lower_m: 18.0,
            gap_upper_m: 40.0,
            catch_up_mps: 0.3,
            min_gap_m: 4.0,
            closing_time_s: 2.0,
            blend_m: 2.0,
            leader_range_m: 100.0,
        }
    }
}

/// The wave-damping driver model: its speed law and memory (see [`WaveDamperParams`]), with
/// the flocking law of its `flock` parameters as its lane keeping and backstop.
#[derive(Component, Debug, Clone, PartialEq)]
pub struct WaveDamper {
    /// Its parameters; edits take effect at the next tick.
    pub params: WaveDamperParams,
    mean_mps: Option<f32>,
    command_mps: Option<f32>,
}

impl WaveDamper {
    /// A damper with no history yet (its mean starts at its first speed).
    pub fn new(params: WaveDamperParams) -> WaveDamper {
        WaveDamper {
            params,
            mean_mps: None,
            command_mps: None,
        }
    }

    /// The running mean of its speed, m/s, once it has one.
    pub fn mean_mps(&self) -> Option<f32> {
        self.mean_mps
    }

    /// This decision's speed command, m/s, for own speed `v`, at most `v_max`, behind a leader
    /// at bumper gap `gap_m` driving at `v_lead` (if any within range); `step_s` since the last
    /// (a tick, or its action step).
    pub fn command(&mut self, v: f32, v_max: f32, leader: Option<(f32, f32)>, step_s: f32) -> f32 {
        let p = &self.params;
        let dt = step_s;
        let mean = match self.mean_mps {
            Some(m) => m + (v - m) * (dt / p.average_time_s.max(dt)),
            None => v,
        };
        self.mean_mps = Some(mean);
        let previous = self.command_mps.unwrap_or(v);
        let command = match leader {
            None => v_max,
            Some((gap, v_lead)) => {
                let ramp = (p.gap_upper_m - p.gap_lower_m).max(0.01);
                let target = mean + p.catch_up_mps * ((gap - p.gap_lower_m) / ramp).clamp(0.0, 1.0);
                let safe = (p.closing_time_s * (v - v_lead).max(0.0)).max(p.min_gap_m);
                // alpha: 1 with room to spare (drive the target), 0 at the safe gap (match the
                // leader); beta keeps part of the last command (half with room to spare), which
                // smooths its own speed.
                let alpha = ((gap - safe) / p.blend_m.max(0.01)).clamp(0.0, 1.0);
                let beta = 1.0 - 0.5 * alpha;
                beta * (alpha * target + (1.0 - alpha) * v_lead) + (1.0 - beta) * previous
            }
        }
        .clamp(0.0, v_max.max(0.0));
        self.command_mps = Some(command);
        command
    }
}

impl DrivingModel for WaveDamper {
    fn cruise_kmh(&self) -> Option<f32> {
        self.params.flock.target_speed_kmh
    }

    fn style(&self) -> LaneStyle {
        self.params.flock.lane_style(true)
    }

    fn decide(&mut self, at: &Situation, seen: &mut Vec<Seen>) -> Proposal {
        flock_law(&self.params.flock, true, at, seen)
    }

    /// Its own law, with what the flocking law and the pipeline decided as the backstop: it
    /// brakes for a car far too close.
    fn finish(&mut self, at: &Situation, target: &mut DriveTarget) {
        let leader = at
            .leader(f64::from(self.params.leader_range_m))
            .map(|(gap, v_leader)| (gap.max(0.0), v_leader));
        let me_speed = at.motion.linvel.dot(at.track.tangent);
        let command = self.command(me_speed, at.v_target, leader, at.step_s);
        target.speed_mps = command.min(target.speed_mps);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One tick, s: the step of a driver deciding every tick.
    const DT: f32 = flockway_core::DT_S as f32;

    #[test]
    fn wave_damper_holds_the_mean_through_a_wave_and_matches_a_leader_too_close() {
        let mut d = WaveDamper::new(WaveDamperParams::default());
        // No leader: the limit.
        assert_eq!(d.command(3.0, 8.0, None, DT), 8.0);
        let mut d = WaveDamper::new(WaveDamperParams::default());
        // At the settled gap it drives the running mean of its own speed, which starts at 3.
        let v = d.command(3.0, 8.0, Some((18.0, 3.0)), DT);
        assert!((v - 3.0).abs() < 0.01, "{v}");
        // A long gap: at most catch_up faster than the mean, approached smoothly (half the
        // step each tick).
        let first = d.command(3.0, 8.0, Some((40.0, 3.0)), DT);
        assert!((first - 3.15).abs() < 0.01, "{first}");
        let mut v = first;
        for _ in 0..20 {
            v = d.command(3.0, 8.0, Some((40.0, 3.0)), DT);
        }
        assert!((v - 3.3).abs() < 0.01, "{v}");
        // The leader stops and starts (±2.8 m/s every 40 s) while the gap stays above the safe
        // gap: its own command barely moves, because it ignores the leader's speed there.
        let mut d = WaveDamper::new(WaveDamperParams::default());
        let (mut lo, mut hi) = (f32::MAX, f32::MIN);
        for tick in 0..120 * 120 {
            let t = tick as f32 / 120.0;
            let lead = 3.0 + 2.8 * (std::f32::consts::TAU * t / 40.0).sin();
            let gap = 18.0 + 17.8 * (1.0 - (std::f32::consts::TAU * t / 40.0).cos()) - 8.0;
            let v = d.command(3.0, 8.0, Some((gap, lead)), DT);
            if t > 60.0 {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        assert!(hi - lo < 0.35, "{lo}..{hi}");
        // Closer than the safe gap (4 m, or 2 s per m/s of closing): its leader's speed.
        let v = d.command(5.0, 8.0, Some((3.0, 1.0)), DT);
        assert!((v - 1.0).abs() < 1e-6, "{v}");
        let v = d.command(5.0, 8.0, Some((7.0, 1.0)), DT);
        assert!((v - 1.0).abs() < 1e-6, "closing at 4 m/s needs 8 m: {v}");
    }
}

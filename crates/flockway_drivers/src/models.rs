//! The built-in drivers: Reynolds flocking (free and lane-keeping), human-like, and the IDM.

use crate::ahead::{ReadsRoad, RoadAhead, RoadAheadParams};
use crate::control::{DriveTarget, PidGains};
use crate::perception::LaneSignal;
use crate::perception::{LaneIndex, Seen};
use crate::route::{LANE_END_MARGIN_M, Route};
use crate::safety::SafetyParams;
use bevy_ecs::prelude::*;
use flockway_core::{DT_S, EntityRng};
use flockway_road::{RoadGeometry, RoadId, RoadNetwork, lane_offset};
use flockway_vehicle::{Motion, PARALLEL_MIN_VEHICLES, RoadTrack, VehicleModel};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// Parameters of the flocking drivers (thesis §3.2.4–3.2.5). Units are in the names.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FlockParams {
    /// Cruising speed, km/h; `None` drives at the speed limit.
    pub target_speed_kmh: Option<f32>,
    /// Weight of speed matching: lane direction × target speed.
    pub speed_weight: f32,
    /// Road following: m/s of pull towards the lane centre per metre off it.
    pub road_weight_per_s: f32,
    /// Largest sideways speed the road-following pull asks for, m/s (sets how gently a lane
    /// change moves across).
    pub max_lateral_mps: f32,
    /// Collision avoidance strength, m²/s: the push away from a neighbour is
    /// `weight × (1/clearance − 1/range)` m/s, growing as the clearance between bumpers closes.
    pub avoid_weight_m2_per_s: f32,
    /// Detection range in the vehicle's own lane, m (centre to centre, ahead and behind).
    pub detection_range_m: f32,
    /// Avoidance looks at the clearance this far ahead in time at the current closing speed, s.
    pub anticipation_s: f32,
    /// Detection range in the adjacent lanes, m (flock with lanes only).
    pub adjacent_range_m: f32,
    /// Share of the avoidance push that vehicles behind exert (1: as strong as ahead, the
    /// flocking rule; 0: looks ahead only, as human drivers do).
    pub rear_weight: f32,
    /// How far ahead, in seconds at the current speed, the lane direction is taken.
    pub lookahead_s: f32,
    /// Time gap needed ahead of and behind the car in the target lane before a lane change, s.
    pub lane_change_gap_s: f32,
    /// How hard it brakes, at most, to make room for a car signalling to merge in ahead of it,
    /// m/s² (0: it does not make room).
    pub courtesy_decel_mps2: f32,
    /// Time gap it keeps to the car ahead in its lane, s, as adaptive cruise control does (0:
    /// none beyond what collision avoidance keeps, the flocking rule).
    pub time_gap_s: f32,
    /// The least time, s, before a vehicle it gives way to at a junction reaches their
    /// conflict, that it accepts to go (its critical gap).
    pub critical_gap_s: f32,
    /// Where it gives way at a junction, the least time after the car before it entered the
    /// same path that it follows it through the same gap, s (its follow-up time).
    pub follow_up_s: f32,
    /// How it slows for bends and slippery stretches ahead.
    pub road_ahead: RoadAheadParams,
    /// Its braking envelope: the safety layer never lets it close on a vehicle ahead faster
    /// than this lets it stop.
    pub safety: SafetyParams,
    /// Each driver's desired speed as a share of the limit, drawn once per vehicle.
    pub speed_factor: SpeedFactorParams,
    /// Throttle PID on speed error (per m/s).
    pub throttle: PidGains,
    /// Steering PID on heading error (per rad).
    pub steering: PidGains,
}

/// The distribution of drivers' desired-speed factors within a profile (as SUMO's
/// `speedFactor` and `speedDev`): normal with this mean and deviation, clipped to `min..=max`.
/// With no deviation every driver takes the mean and no random number is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SpeedFactorParams {
    /// Mean share of the limit (1: the limit).
    pub mean: f32,
    /// Standard deviation of the share.
    pub dev: f32,
    /// Smallest share drawn.
    pub min: f32,
    /// Largest share drawn.
    pub max: f32,
}

impl Default for SpeedFactorParams {
    fn default() -> Self {
        SpeedFactorParams {
            mean: 1.0,
            dev: 0.0,
            min: 0.2,
            max: 2.0,
        }
    }
}

impl SpeedFactorParams {
    /// One driver's factor, from its own stream (drawn only if `dev` is above zero).
    pub fn draw(&self, rng: &mut EntityRng) -> f32 {
        if self.dev > 0.0 {
            (self.mean + self.dev * rng.normal() as f32).clamp(self.min, self.max.max(self.min))
        } else {
            self.mean
        }
    }
}

/// A driver's desired speed as a share of the limit, drawn when it was spawned: every built-in
/// driver drives at `limit × factor` where the road ahead allows.
#[derive(Component, Debug, Clone, Copy, PartialEq)]
pub struct SpeedFactor(pub f32);

impl Default for SpeedFactor {
    fn default() -> Self {
        SpeedFactor(1.0)
    }
}

impl Default for FlockParams {
    fn default() -> Self {
        FlockParams {
            target_speed_kmh: None,
            speed_weight: 1.0,
            road_weight_per_s: 0.5,
            max_lateral_mps: 1.0,
            avoid_weight_m2_per_s: 60.0,
            detection_range_m: 40.0,
            anticipation_s: 2.0,
            adjacent_range_m: 8.0,
            rear_weight: 1.0,
            lookahead_s: 0.6,
            lane_change_gap_s: 1.0,
            courtesy_decel_mps2: 1.5,
            time_gap_s: 0.0,
            critical_gap_s: crate::junction::CRITICAL_GAP_S as f32,
            follow_up_s: crate::junction::FOLLOW_UP_S as f32,
            road_ahead: RoadAheadParams::default(),
            safety: SafetyParams::default(),
            speed_factor: SpeedFactorParams::default(),
            throttle: PidGains {
                kp: 0.5,
                ki: 0.2,
                kd: 0.0,
            },
            steering: PidGains {
                kp: 1.6,
                ki: 0.4,
                kd: 0.05,
            },
        }
    }
}

/// What makes a human-like driver (thesis §3.2.6) on top of its flocking parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HumanParams {
    /// Flocking behaviour: shorter ranges and harsher gains than the autonomous car.
    pub flock: FlockParams,
    /// Reaction delay: it acts on what it decided this long ago, s.
    pub reaction_time_s: f32,
    /// Spread of its desired speed around the limit: drawn once, uniform in ±this share.
    pub speed_spread: f32,
    /// How far its speed choice wanders from moment to moment (misjudged gaps, attention), km/h:
    /// the standard deviation of an Ornstein–Uhlenbeck process added to its target speed.
    pub speed_noise_kmh: f32,
    /// How long a wander lasts (the process's correlation time), s.
    pub noise_time_s: f32,
}

impl Default for HumanParams {
    fn default() -> Self {
        HumanParams {
            flock: FlockParams {
                detection_range_m: 25.0,
                anticipation_s: 0.3,
                adjacent_range_m: 5.0,
                avoid_weight_m2_per_s: 30.0,
                rear_weight: 0.0,
                courtesy_decel_mps2: 0.5,
                road_ahead: RoadAheadParams {
                    lateral_accel_mps2: 2.5,
                    ..RoadAheadParams::default()
                },
                // Later to react and harder on the brakes than the autonomous car.
                safety: SafetyParams {
                    reaction_time_s: 0.5,
                    decel_mps2: 6.5,
                    ..SafetyParams::default()
                },
                throttle: PidGains {
                    kp: 0.6,
                    ki: 0.05,
                    kd: 0.0,
                },
                ..FlockParams::default()
            },
            reaction_time_s: 0.7,
            speed_spread: 0.1,
            speed_noise_kmh: 0.0,
            noise_time_s: 4.0,
        }
    }
}

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

/// The speed law of a wave-damping car and its memory (see [`WaveDamperParams`]); the car's
/// [`FlockDriver`] keeps it in its lane and is its backstop.
#[derive(Component, Debug, Clone, PartialEq)]
pub struct WaveDamper {
    /// Its parameters; edits take effect at the next tick (the `flock` part is read from the
    /// vehicle's [`FlockDriver`], which was built from it).
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

    /// This tick's speed command, m/s, for own speed `v`, at most `v_max`, behind a leader at
    /// bumper gap `gap_m` driving at `v_lead` (if any within range).
    pub fn command(&mut self, v: f32, v_max: f32, leader: Option<(f32, f32)>) -> f32 {
        let p = &self.params;
        let dt = DT_S as f32;
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

/// The speed limit a vehicle obeys, km/h: its road's, until a trigger sets another.
#[derive(Component, Debug, Clone, Copy, PartialEq)]
pub struct SpeedLimit {
    /// Limit, km/h.
    pub kmh: f32,
    /// The road it was taken from; entering another road resets it to that road's limit.
    pub road: Option<RoadId>,
}

impl Default for SpeedLimit {
    fn default() -> Self {
        SpeedLimit {
            kmh: 50.0,
            road: None,
        }
    }
}

/// Sets each vehicle's limit from its road when it enters one (triggers overwrite `kmh` later).
pub fn update_speed_limits(
    network: Res<RoadNetwork>,
    mut vehicles: Query<(&RoadTrack, &mut SpeedLimit)>,
) {
    for (track, mut limit) in &mut vehicles {
        if limit.road != Some(track.road)
            && let Some(g) = network.get(track.road)
        {
            *limit = SpeedLimit {
                kmh: g.speed_limit_kmh() as f32,
                road: Some(track.road),
            };
        }
    }
}

/// Reynolds flocking: free (avoidance in any direction) or lane-keeping (avoidance only along
/// the lane, own and adjacent lanes with their own ranges, lane changes on command).
#[derive(Component, Debug, Clone, PartialEq)]
pub struct FlockDriver {
    /// Its parameters; edits take effect at the next tick.
    pub params: FlockParams,
    /// Lane-keeping (`FlockLanes`) or free (`Flock`).
    pub keep_lane: bool,
    /// The lane it follows now.
    pub lane: u32,
    /// The lane it wants: set this to change lanes; it moves over when the gap allows.
    pub target_lane: u32,
    /// The road its lane numbers count on (`None` until it first decides): when it drives onto
    /// another road its lanes carry over along the link.
    pub road: Option<RoadId>,
}

impl FlockDriver {
    /// A driver in `lane`.
    pub fn new(params: FlockParams, keep_lane: bool, lane: u32) -> FlockDriver {
        FlockDriver {
            params,
            keep_lane,
            lane,
            target_lane: lane,
            road: None,
        }
    }
}

/// The lane that lane `lane` of road `from` leads onto on road `to` (its link's lane pair), or
/// `on_track` (the lane under the car) when the link does not take it; `lane` itself while still
/// on `from` or with no road yet.
pub fn carry_lane(
    network: &RoadNetwork,
    from: Option<RoadId>,
    to: RoadId,
    lane: u32,
    on_track: u32,
) -> u32 {
    match from {
        Some(f) if f != to => network
            .link(f, to)
            .and_then(|l| l.lane_to(lane))
            .unwrap_or(on_track),
        _ => lane,
    }
}

/// Makes a flocking driver human-like: a wandering speed choice and a reaction delay (its own
/// desired speed is its [`SpeedFactor`]).
#[derive(Component, Debug, Clone, PartialEq)]
pub struct HumanDriver {
    /// Reaction delay, s.
    pub reaction_time_s: f32,
    /// Standard deviation of the wander added to its target speed, m/s.
    pub speed_noise_mps: f32,
    /// Correlation time of the wander, s.
    pub noise_time_s: f32,
    noise_mps: f32,
    rng: Option<EntityRng>,
    pending: VecDeque<DriveTarget>,
}

impl HumanDriver {
    /// A human with this reaction delay, whose speed choice does not wander.
    pub fn new(reaction_time_s: f32) -> HumanDriver {
        HumanDriver {
            reaction_time_s,
            speed_noise_mps: 0.0,
            noise_time_s: 4.0,
            noise_mps: 0.0,
            rng: None,
            pending: VecDeque::new(),
        }
    }

    /// Lets its speed choice wander by `sigma_mps` (standard deviation) over `time_s`, drawing
    /// from `rng` (its own stream) once per tick.
    pub fn with_noise(mut self, sigma_mps: f32, time_s: f32, rng: EntityRng) -> HumanDriver {
        self.speed_noise_mps = sigma_mps.max(0.0);
        self.noise_time_s = time_s.max(DT_S as f32);
        self.rng = (sigma_mps > 0.0).then_some(rng);
        self
    }

    /// Advances the wander by one tick and returns it, m/s. An Ornstein–Uhlenbeck step with a
    /// unit-variance uniform kick (cheaper than a Gaussian, the same variance).
    pub fn wander(&mut self) -> f32 {
        let Some(rng) = &mut self.rng else {
            return 0.0;
        };
        let dt = DT_S as f32;
        let kick = (rng.unit_f64() as f32 * 2.0 - 1.0) * 3f32.sqrt();
        let decay = dt / self.noise_time_s;
        self.noise_mps +=
            -self.noise_mps * decay + self.speed_noise_mps * (2.0 * decay).sqrt() * kick;
        self.noise_mps
    }

    /// Queues this tick's decision and returns the one made a reaction time ago (the oldest
    /// while the queue fills).
    pub fn react(&mut self, decided: DriveTarget) -> DriveTarget {
        let delay = (self.reaction_time_s.max(0.0) / DT_S as f32).round() as usize;
        self.pending.push_back(decided);
        while self.pending.len() > delay + 1 {
            self.pending.pop_front();
        }
        self.pending.front().copied().unwrap_or(decided)
    }
}

/// The Intelligent Driver Model with lane keeping.
#[derive(Component, Debug, Clone, PartialEq)]
pub struct IdmDriver {
    /// Its parameters; edits take effect at the next tick.
    pub params: IdmParams,
    /// The lane it follows.
    pub lane: u32,
    /// The road its lane number counts on (`None` until it first decides).
    pub road: Option<RoadId>,
}

/// Lane following for a car in `lane`: speed matching along the lane direction plus road
/// following towards the lane centre (the pull capped at `max_lateral_mps`), and the lane's
/// curvature a little ahead for the steering feed-forward. Returns
/// `(lane direction here, desired velocity without avoidance, curvature ahead in 1/m)`.
#[allow(clippy::too_many_arguments)]
pub fn lane_following(
    geometry: &RoadGeometry,
    track: &RoadTrack,
    lane: u32,
    speed_mps: f32,
    target_speed_mps: f32,
    speed_weight: f32,
    road_weight_per_s: f32,
    max_lateral_mps: f32,
    lookahead_s: f32,
) -> (Vec3, Vec3, f32) {
    let lanes = geometry.lanes().max(1);
    let centre = lane_offset(f64::from(track.width_m), lanes, lane.min(lanes - 1));
    let error = (centre - track.lateral_m) as f32;
    let (dir, left) = (track.tangent, track.left);
    // Curvature from the turn of the lane direction over the look-ahead distance (signed,
    // positive turning left), for the steering feed-forward: it steers into a bend as it
    // arrives instead of waiting for a heading error to build.
    let ahead = speed_mps.max(2.0) * lookahead_s;
    let curvature = match track.frame_ahead(geometry, f64::from(ahead)) {
        Some(f) if ahead > 0.1 => {
            let t2 = f.tangent.as_vec3();
            let turn = dir.x * t2.y - dir.y * t2.x;
            let along = dir.x * t2.x + dir.y * t2.y;
            libm::atan2f(turn, along) / ahead
        }
        _ => 0.0,
    };
    let pull = (error * road_weight_per_s).clamp(-max_lateral_mps, max_lateral_mps);
    (
        dir,
        dir * (target_speed_mps * speed_weight) + left * pull,
        curvature,
    )
}

impl DriveTarget {
    /// A target that drives at `target_speed_mps` along `lane`, kept in it the way the built-in
    /// drivers do (road following and curvature feed-forward with the flocking defaults), for a
    /// driver that only decides a speed.
    pub fn keep_lane(
        geometry: &RoadGeometry,
        track: &RoadTrack,
        lane: u32,
        speed_mps: f32,
        target_speed_mps: f32,
    ) -> DriveTarget {
        let p = FlockParams::default();
        let (dir, base, curvature) = lane_following(
            geometry,
            track,
            lane,
            speed_mps,
            target_speed_mps,
            1.0,
            p.road_weight_per_s,
            p.max_lateral_mps,
            p.lookahead_s,
        );
        to_target(dir * target_speed_mps, base, dir, curvature)
    }
}

/// The avoidance push from one seen vehicle, m/s, in the road's frame at the observer. The
/// clearance between bumpers is taken as it will be after `anticipation_s` at the current
/// closing speed, so a fast approach pushes as hard as a near one. Vehicles ahead push back and
/// vehicles behind push forward alike (thesis §3.2.4): in a platoon the two cancel, which is
/// what lets dense traffic hold the limit.
#[allow(clippy::too_many_arguments)]
fn avoid_push(
    seen: &Seen,
    me_lateral: f32,
    me_speed: f32,
    me_length: f32,
    range_m: f32,
    weight: f32,
    anticipation_s: f32,
    tangent: Vec3,
    left: Vec3,
) -> Vec3 {
    let along = seen.gap_m as f32;
    let across = seen.entry.lateral_m - me_lateral;
    let dist = (along * along + across * across).sqrt().max(1.0e-3);
    let half_lengths = 0.5 * (me_length + seen.entry.length_m);
    let closing = (me_speed - seen.entry.speed_mps) * along.signum() * (along.abs() / dist);
    let clearance = (dist - half_lengths - closing.max(0.0) * anticipation_s).max(0.3);
    let reach = (range_m - half_lengths).max(1.0);
    let strength = weight * (1.0 / clearance - 1.0 / reach).max(0.0);
    -(tangent * along + left * across) / dist * strength
}

/// Target speed and heading from a desired velocity: speed along the lane (never backwards);
/// heading along the desired velocity, or along the lane when avoidance has cancelled it.
fn to_target(desired: Vec3, steer_by: Vec3, dir: Vec3, curvature_per_m: f32) -> DriveTarget {
    let speed = desired.dot(dir).max(0.0);
    let h = if steer_by.truncate().length() > 1.0e-3 {
        steer_by
    } else {
        dir
    };
    DriveTarget {
        speed_mps: speed,
        heading_rad: libm::atan2f(h.y, h.x),
        curvature_per_m,
        accel_mps2: None,
    }
}

/// Decides every flocking (human-like, wave-damping) vehicle's target: speed matching + road
/// following + collision avoidance (thesis §3.2.4); a [`WaveDamper`] then caps the speed with its law.
#[allow(clippy::type_complexity)]
pub fn drive_flock(
    network: Res<RoadNetwork>,
    index: Res<LaneIndex>,
    ahead: Res<RoadAhead>,
    mut vehicles: Query<(
        Entity,
        &RoadTrack,
        &Motion,
        &VehicleModel,
        DesiredSpeed,
        &mut FlockDriver,
        Option<&mut HumanDriver>,
        Option<&mut WaveDamper>,
        &mut DriveTarget,
        Wayfinding,
    )>,
) {
    let run =
        |seen: &mut Vec<Seen>, item: FlockItem| flock_decide(&network, &index, &ahead, seen, item);
    // Each car reads the shared index and road network and writes only its own components,
    // so the decisions are the same whichever thread makes them.
    if vehicles.iter().len() < PARALLEL_MIN_VEHICLES {
        let mut seen = Vec::new();
        vehicles.iter_mut().for_each(|item| run(&mut seen, item));
    } else {
        vehicles.par_iter_mut().for_each_init(Vec::new, run);
    }
}

/// Where a vehicle is going and the lane change it signals.
type Wayfinding = (Option<&'static Route>, Option<&'static mut LaneSignal>);

/// What sets a vehicle's desired speed: the limit it obeys, its own share of it, and what the
/// road ahead allows.
type DesiredSpeed = (
    &'static SpeedLimit,
    Option<&'static SpeedFactor>,
    Option<&'static ReadsRoad>,
);

/// The speed a driver wants before traffic, m/s, and what the road ahead allows: its cruising
/// speed (the limit unless its parameters set one) times its factor, within the envelope of its
/// lane read [`RoadAheadParams::preview_s`] ahead of it at `track_speed`.
pub fn desired_speed_mps(
    cruise_kmh: Option<f32>,
    (limit, factor, reads): (&SpeedLimit, Option<&SpeedFactor>, Option<&ReadsRoad>),
    ahead: &RoadAhead,
    track: &RoadTrack,
    track_speed: f32,
    lane: u32,
) -> (f32, f32) {
    let factor = factor.map_or(1.0, |f| f.0);
    let free = cruise_kmh.unwrap_or(limit.kmh) * factor;
    let cap = reads.map_or(f32::INFINITY, |r| {
        // Ahead to brake in time; here too, so it does not speed up out of a bend early.
        let preview = f64::from(r.params.preview_s * track_speed.max(0.0));
        let next = track.next_road;
        ahead
            .speed_cap_mps(r, track.road, lane, track.s_m + preview, next)
            .min(ahead.speed_cap_mps(r, track.road, lane, track.s_m, next))
    });
    ((free.max(0.0) / 3.6).min(cap), cap)
}

/// What [`drive_flock`] reads and writes on one vehicle.
type FlockItem<'a> = (
    Entity,
    &'a RoadTrack,
    &'a Motion,
    &'a VehicleModel,
    (
        &'a SpeedLimit,
        Option<&'a SpeedFactor>,
        Option<&'a ReadsRoad>,
    ),
    Mut<'a, FlockDriver>,
    Option<Mut<'a, HumanDriver>>,
    Option<Mut<'a, WaveDamper>>,
    Mut<'a, DriveTarget>,
    (Option<&'a Route>, Option<Mut<'a, LaneSignal>>),
);

/// One flocking vehicle's decision; `seen` is scratch space for its neighbours.
fn flock_decide(
    network: &RoadNetwork,
    index: &LaneIndex,
    ahead: &RoadAhead,
    seen: &mut Vec<Seen>,
    (me, track, motion, model, desired, mut driver, human, damper, mut target, (route, signal)): FlockItem,
) {
    let Some(geometry) = network.get(track.road) else {
        return;
    };
    let lanes = geometry.lanes().max(1);
    let length = model.0.params.chassis.length_m;
    let v = motion.forward_mps;
    if driver.road != Some(track.road) {
        let lane = carry_lane(network, driver.road, track.road, driver.lane, track.lane);
        let target = carry_lane(network, driver.road, track.road, driver.target_lane, lane);
        driver.lane = lane;
        driver.target_lane = target;
        driver.road = Some(track.road);
    }

    // The route asks for a lane in good time before its lane ends or leads elsewhere.
    // The window opens by the limit's speed as well, so slowing while waiting does not close it.
    let window_mps = v.max(desired.0.kmh / 3.6);
    let wanted = route.and_then(|r| r.lane_change(driver.lane, track.s_m, window_mps));
    if driver.keep_lane
        && let Some(ask) = wanted
    {
        driver.target_lane =
            (i64::from(driver.lane) + i64::from(ask.dir)).clamp(0, i64::from(lanes) - 1) as u32;
    }
    // A lane change waits for room in the target lane: a time gap ahead and behind.
    let target_lane = driver.target_lane.min(lanes - 1);
    let mut signal_dir = 0;
    let mut gap_s = driver.params.lane_change_gap_s;
    if driver.keep_lane && target_lane != driver.lane {
        let step = if target_lane > driver.lane { 1 } else { -1 };
        let next = (driver.lane as i64 + step) as u32;
        gap_s *= wanted.map_or(1.0, |ask| ask.urgency());
        let cross_s = crossing_s(track, lanes, driver.params.max_lateral_mps);
        let change = LaneChange {
            lane: next,
            dir: step as i8,
            lanes,
            gap_s,
            left_m: wanted.map(|ask| ask.left_m),
            cross_s,
        };
        if change.accepted(index, track, me, v, length) {
            driver.lane = next;
        } else {
            signal_dir = step as i8;
        }
    }
    if driver.keep_lane {
        show_signal(signal, signal_dir, driver.lane, track.lane);
    }
    let lane = driver.lane.min(lanes - 1);
    let p = &driver.params;
    let (v_target, cap) = desired_speed_mps(p.target_speed_kmh, desired, ahead, track, v, lane);
    // A lane that ends is a wall ahead for whoever could not leave it yet.
    let cap = cap
        .min(route.map_or(f32::INFINITY, |r| {
            r.lane_end_cap_mps(lane, track.s_m, length, LANE_END_DECEL_MPS2)
        }))
        .min(leaving_lane_cap_mps(
            route,
            track,
            lane,
            crossing_s(track, lanes, p.max_lateral_mps),
        ));
    let v_target = v_target.min(cap);
    let (dir, base, curvature) = lane_following(
        geometry,
        track,
        lane,
        v,
        v_target,
        p.speed_weight,
        p.road_weight_per_s,
        p.max_lateral_mps,
        p.lookahead_s,
    );
    let me_lat = track.lateral_m as f32;
    let me_speed = motion.linvel.dot(track.tangent);
    let mut avoid = Vec3::ZERO;
    seen.clear();
    let own = f64::from(p.detection_range_m);
    index.within(track.road, lane, track.s_m, own, own, Some(me), seen);
    let own_count = seen.len();
    let adj = f64::from(p.adjacent_range_m);
    if lane > 0 {
        index.within(track.road, lane - 1, track.s_m, adj, adj, Some(me), seen);
    }
    if lane + 1 < lanes {
        index.within(track.road, lane + 1, track.s_m, adj, adj, Some(me), seen);
    }
    for (i, s) in seen.iter().enumerate() {
        let range = if i < own_count {
            p.detection_range_m
        } else {
            p.adjacent_range_m
        };
        let share = if s.gap_m < 0.0 { p.rear_weight } else { 1.0 };
        avoid += share
            * avoid_push(
                s,
                me_lat,
                me_speed,
                length,
                range,
                p.avoid_weight_m2_per_s,
                p.anticipation_s,
                track.tangent,
                track.left,
            );
    }
    if driver.keep_lane {
        // Brake or speed up, never swerve: only the part along the lane.
        avoid = dir * avoid.dot(dir);
    }
    let desired = if driver.keep_lane {
        base + avoid
    } else {
        within_edges(base + avoid, track, model.0.params.chassis.width_m)
    };
    let steer_by = if driver.keep_lane { base } else { desired };
    let mut decided = to_target(desired, steer_by, dir, curvature);
    // A push from a follower never takes it faster than the road ahead allows.
    decided.speed_mps = decided.speed_mps.min(cap);
    if driver.keep_lane && p.courtesy_decel_mps2 > 0.0 {
        let room = courtesy_speed_mps(
            index,
            track,
            (lane, lanes),
            v,
            length,
            (p.courtesy_decel_mps2, p.lane_change_gap_s),
            seen,
        );
        decided.speed_mps = decided.speed_mps.min(room);
    }
    if driver.keep_lane && p.time_gap_s > 0.0 {
        // Adaptive cruise control: close the gap beyond 2 m plus the time gap over 1.5 s.
        let range = f64::from(p.detection_range_m.max(v * p.time_gap_s * 2.0 + 50.0));
        if let Some(l) = index.leader(track.road, lane, track.s_m, me, range, track.next_road) {
            let bumper = l.gap_m as f32 - 0.5 * (length + l.entry.length_m);
            let keep = l.entry.speed_mps + (bumper - 2.0 - v.max(0.0) * p.time_gap_s) / 1.5;
            decided.speed_mps = decided.speed_mps.min(keep.max(0.0));
        }
    }
    if signal_dir != 0 {
        // Waiting to move over: line up with a gap in the target lane.
        let next = (i64::from(lane) + i64::from(signal_dir)) as u32;
        // Free: nothing in its own lane holds it below the speed it wants.
        let free = decided.speed_mps >= v_target - 0.5;
        match merge_speed(index, track, me, next, v, length, gap_s, free) {
            MergeSpeed::Cap(c) => decided.speed_mps = decided.speed_mps.min(c),
            MergeSpeed::Pull(pull) => {
                decided.speed_mps = decided
                    .speed_mps
                    .max(pull.min(v_target + MERGE_PULL_MPS).min(cap));
            }
        }
    }
    *target = match human {
        // The reaction delay is on the response to traffic (the speed); lane keeping is a
        // continuous skill and follows the road as it is now.
        Some(mut h) => {
            let wander = h.wander();
            let chosen = DriveTarget {
                speed_mps: (decided.speed_mps + wander).max(0.0),
                ..decided
            };
            // A bend is seen long before it is reached: what the road ahead allows binds
            // without the delay.
            DriveTarget {
                speed_mps: h.react(chosen).speed_mps.min(cap),
                ..decided
            }
        }
        None => decided,
    };
    if let Some(mut damper) = damper {
        let range = f64::from(damper.params.leader_range_m);
        let leader = index
            .leader(track.road, lane, track.s_m, me, range, track.next_road)
            .map(|l| {
                let bumpers = l.gap_m as f32 - 0.5 * (length + l.entry.length_m);
                (bumpers.max(0.0), l.entry.speed_mps)
            });
        let command = damper.command(me_speed, v_target, leader);
        // The flocking driver's choice is the backstop: it brakes for a car far too close.
        target.speed_mps = command.min(target.speed_mps);
    }
}

/// How long, s, a free-flocking car's sideways speed would take it to the road's edge at the
/// least: a push towards the edge is cut to what leaves it that long.
const EDGE_TIME_S: f32 = 1.5;

/// Room kept between a free-flocking car's side and the road's edge (a guardrail), m.
const EDGE_MARGIN_M: f32 = 0.4;

/// A free-flocking car's desired velocity with its sideways part cut to what keeps its body on
/// the road: avoidance may push it sideways, never off the road or into a guardrail (towards
/// an edge, no faster than covers the room left in [`EDGE_TIME_S`]).
fn within_edges(desired: Vec3, track: &RoadTrack, width_m: f32) -> Vec3 {
    let reach = 0.5 * track.width_m - 0.5 * width_m - EDGE_MARGIN_M;
    let lateral = track.lateral_m as f32;
    let most_left = (reach - lateral).max(0.0) / EDGE_TIME_S;
    let most_right = (reach + lateral).max(0.0) / EDGE_TIME_S;
    let across = desired.dot(track.left);
    let clamped = across.clamp(-most_right, most_left);
    desired + track.left * (clamped - across)
}

/// Braking towards the end of a lane that ends, m/s²: firm but not an emergency.
pub const LANE_END_DECEL_MPS2: f32 = 2.5;

/// Time a car takes to move over one lane, s: the pull towards the new lane's centre eases as
/// it nears it, and the car turns in with a lag, so it crosses at about 0.7 of its largest
/// sideways speed on average.
fn crossing_s(track: &RoadTrack, lanes: u32, max_lateral_mps: f32) -> f32 {
    track.width_m / lanes.max(1) as f32 / (0.7 * max_lateral_mps.max(0.1))
}

/// A lane change one lane over that a driver wants to make now.
struct LaneChange {
    /// The lane it moves into.
    lane: u32,
    /// +1 left, -1 right.
    dir: i8,
    /// Lanes of the road.
    lanes: u32,
    /// The time gap it wants ahead and behind, s.
    gap_s: f32,
    /// What is left of its lane, m, when it must leave it (`None`: a change by choice).
    left_m: Option<f64>,
    /// How long the crossing takes, s.
    cross_s: f32,
}

impl LaneChange {
    /// Whether it may go now: room to finish before its lane ends, a gap in the target lane,
    /// and nobody from the far side claiming the lane.
    fn accepted(
        &self,
        index: &LaneIndex,
        track: &RoadTrack,
        me: Entity,
        v: f32,
        length_m: f32,
    ) -> bool {
        self.left_m
            .is_none_or(|left| left >= crossing_m(v, self.cross_s, length_m))
            && lane_gap_accepted(index, track, me, self.lane, v, length_m, self.gap_s)
            && !lane_claimed(
                index, track, self.lane, self.dir, v, length_m, self.gap_s, self.lanes,
            )
    }
}

/// Shows the others what the driver is doing: `waiting` (±1) for a gap, ±2 while it is still
/// over its old lane (`on_track`) after moving to `lane`, 0 otherwise. Writes only on change.
fn show_signal(signal: Option<Mut<LaneSignal>>, waiting: i8, lane: u32, on_track: u32) {
    let shown = if waiting == 0 && on_track != lane {
        if lane > on_track { 2 } else { -2 }
    } else {
        waiting
    };
    if let Some(mut signal) = signal
        && signal.0 != shown
    {
        signal.0 = shown;
    }
}

/// Whether a car on the far side of `lane` (moving the other way, `-dir`) claims it near this
/// one: one already crossing into it always does; one waiting to does when this car moves left
/// (`dir` +1), so two cars waiting for the same lane from both sides never both go, nor both wait.
#[expect(
    clippy::too_many_arguments,
    reason = "the query's coordinates and the driver's"
)]
fn lane_claimed(
    index: &LaneIndex,
    track: &RoadTrack,
    lane: u32,
    dir: i8,
    v: f32,
    length_m: f32,
    gap_s: f32,
    lanes: u32,
) -> bool {
    let far = i64::from(lane) + i64::from(dir);
    if far < 0 || far >= i64::from(lanes) {
        return false;
    }
    let reach = f64::from(v.max(0.0) * gap_s + length_m + 2.0);
    let mut near = Vec::new();
    index.within(
        track.road, far as u32, track.s_m, reach, reach, None, &mut near,
    );
    near.iter()
        .any(|s| s.entry.signal == -2 * dir || (dir == 1 && s.entry.signal == -dir))
}

/// Distance a car at `v` needs to be mostly (0.8) across one lane taking `cross_s` for the whole
/// crossing, m, plus half its length.
fn crossing_m(v: f32, cross_s: f32, length_m: f32) -> f64 {
    f64::from(0.8 * v.max(0.0) * cross_s + 0.5 * length_m + 0.5)
}

/// While a car moves out of a lane that ends (it is still over `on_track`, its driver already
/// follows another lane), the speed that covers the rest of that lane in the time the crossing
/// takes, never below 3 m/s so it does not stop halfway; `INFINITY` otherwise.
fn leaving_lane_cap_mps(route: Option<&Route>, track: &RoadTrack, lane: u32, cross_s: f32) -> f32 {
    match route {
        Some(r) if track.lane != lane => {
            let left = r.lane_end_m(track.lane) - track.s_m;
            if left.is_finite() {
                ((left.max(0.0) as f32) / cross_s.max(0.1)).max(3.0)
            } else {
                f32::INFINITY
            }
        }
        _ => f32::INFINITY,
    }
}

/// Gap acceptance: whether a car of `length_m` at `v` may move into `lane` now, with the time
/// gap `gap_s` ahead of it (at the closing speed, plus half its own) and behind it (at the
/// follower's speed) in that lane, as it sees the cars there (across links too).
fn lane_gap_accepted(
    index: &LaneIndex,
    track: &RoadTrack,
    me: Entity,
    lane: u32,
    v: f32,
    length_m: f32,
    gap_s: f32,
) -> bool {
    let need = |speed: f32| f64::from((speed.max(0.0) * gap_s).max(0.0) + length_m + 2.0);
    let bumper = |s: &Seen| s.gap_m.abs() as f32 - 0.5 * (length_m + s.entry.length_m);
    // Neither car has to brake harder than firmly to keep its distance: the time gap alone
    // would let a fast car close on a slow one.
    let firm = LANE_CHANGE_ENVELOPE;
    let ahead_ok = index
        .leader(track.road, lane, track.s_m, me, 200.0, track.next_road)
        .is_none_or(|l| {
            l.gap_m >= need(v - l.entry.speed_mps + v * 0.5)
                && v <= firm.safe_speed_mps(bumper(&l), l.entry.speed_mps)
        });
    let behind_ok = index
        .follower(track.road, lane, track.s_m, me, 200.0)
        .is_none_or(|f| {
            -f.gap_m >= need(f.entry.speed_mps)
                && f.entry.speed_mps <= firm.safe_speed_mps(bumper(&f), v)
        });
    ahead_ok && behind_ok
}

/// The braking envelope a lane change leaves the two cars it moves between: neither has to
/// brake harder than this to keep 2 m from the other (the time gap is their time to react).
const LANE_CHANGE_ENVELOPE: SafetyParams = SafetyParams {
    reaction_time_s: 0.0,
    decel_mps2: 3.0,
    min_gap_m: 2.0,
};

/// The share of its usual lane-change time gap a courteous driver leaves a car merging in ahead
/// of it: more than that car insists on at its lane's very end
/// ([`LANE_CHANGE_LEAST_GAP`](crate::LANE_CHANGE_LEAST_GAP)).
const COURTESY_GAP_SHARE: f32 = 0.7;

/// How far ahead a driver looks for a car signalling to merge into its lane, m.
const COURTESY_RANGE_M: f64 = 80.0;

/// The speed that makes room for the nearest car ahead in a lane either side that signals into
/// `lane`: its speed, plus closing the bumper gap beyond what the merging car needs behind it
/// ([`COURTESY_GAP_SHARE`] of the lane-change time gap `gap_s`, at this speed, and 3 m) over
/// 1.5 s, braking at most
/// `decel_mps2` below `v`. `INFINITY` when nobody signals.
fn courtesy_speed_mps(
    index: &LaneIndex,
    track: &RoadTrack,
    (lane, lanes): (u32, u32),
    v: f32,
    length_m: f32,
    (decel_mps2, gap_s): (f32, f32),
    seen: &mut Vec<Seen>,
) -> f32 {
    if lanes < 2 || !index.any_signal() {
        return f32::INFINITY;
    }
    seen.clear();
    let behind = 0.5 * f64::from(length_m);
    if lane > 0 {
        index.within(
            track.road,
            lane - 1,
            track.s_m,
            behind,
            COURTESY_RANGE_M,
            None,
            seen,
        );
    }
    let right = seen.len();
    if lane + 1 < lanes {
        index.within(
            track.road,
            lane + 1,
            track.s_m,
            behind,
            COURTESY_RANGE_M,
            None,
            seen,
        );
    }
    // Only a car wholly ahead: one alongside falls in behind instead (were both to wait for
    // the other, neither would move).
    let bumper = |s: &Seen| s.gap_m as f32 - 0.5 * (length_m + s.entry.length_m);
    let merger = seen
        .iter()
        .enumerate()
        .filter(|(i, s)| {
            s.entry.signal.signum() == if *i < right { 1 } else { -1 } && bumper(s) > 0.0
        })
        .map(|(_, s)| s)
        .min_by(|a, b| a.gap_m.total_cmp(&b.gap_m));
    let Some(m) = merger else {
        return f32::INFINITY;
    };
    let bumper = bumper(m);
    let needed = COURTESY_GAP_SHARE * gap_s * v.max(0.0) + 3.0;
    (m.entry.speed_mps + (bumper - needed) / 1.5).max(v - decel_mps2)
}

/// How much faster than it would like a car waiting to change lane may go to pull ahead of a
/// car alongside in the target lane, m/s.
const MERGE_PULL_MPS: f32 = 2.5;

/// How far below its speed a car waiting to change lane sets its target at most, m/s: the speed
/// controllers (about 0.5 of full braking per m/s of error) then slow it at about 2.5 m/s², not
/// in an emergency stop that would catch out the driver behind.
const MERGE_SLOW_MPS: f32 = 0.5;

/// What a car waiting to change lane does with its speed to line up with a gap.
#[derive(Debug, Clone, Copy, PartialEq)]
enum MergeSpeed {
    /// Go no faster than this: fall in behind a car in the target lane.
    Cap(f32),
    /// Speed up to this (if nothing in its own lane holds it back): pull ahead of a car alongside.
    Pull(f32),
}

/// How a car of `length_m` at `v` waiting to change into `lane` lines up with a gap there, as
/// its gap acceptance (time gap `gap_s`) will judge it, never setting its target more than
/// [`MERGE_SLOW_MPS`] below its speed nor speeding up while something in its own lane holds it
/// back (`free` false):
/// - a gap between the cars ahead and behind there that is big enough: it moves to where the
///   gap leaves as much to spare ahead of it as behind, at the gap's speed;
/// - a car alongside or just behind that leaves too little room behind: it pulls ahead of it
///   when that is the shorter way (always when it is wholly ahead of it already: the other's
///   courtesy makes room for that) and the car ahead leaves room; it drops back behind it
///   otherwise;
/// - else it falls in behind the car ahead there, with half its time gap and 3 m between
///   bumpers, closed over 2 s.
#[expect(
    clippy::too_many_arguments,
    reason = "the query's coordinates and the driver's"
)]
fn merge_speed(
    index: &LaneIndex,
    track: &RoadTrack,
    me: Entity,
    lane: u32,
    v: f32,
    length_m: f32,
    gap_s: f32,
    free: bool,
) -> MergeSpeed {
    let leader = index.leader(track.road, lane, track.s_m, me, 100.0, track.next_road);
    let follower = index.follower(track.road, lane, track.s_m, me, 60.0);
    let floor = v - MERGE_SLOW_MPS;
    let towards = |speed: f32| {
        if speed < v {
            MergeSpeed::Cap(speed.max(floor))
        } else if free {
            MergeSpeed::Pull(speed)
        } else {
            MergeSpeed::Cap(f32::INFINITY)
        }
    };
    // What gap acceptance wants ahead and behind (centre to centre), with 1 m to spare.
    let need_ahead = |l: &Seen| (1.5 * v - l.entry.speed_mps).max(0.0) * gap_s + length_m + 3.0;
    let need_behind = |f: &Seen| f.entry.speed_mps.max(0.0) * gap_s + length_m + 3.0;
    if let (Some(l), Some(f)) = (&leader, &follower) {
        let spare_ahead = l.gap_m as f32 - need_ahead(l);
        let spare_behind = -f.gap_m as f32 - need_behind(f);
        if spare_ahead + spare_behind >= 0.0 {
            let forward = 0.5 * (spare_ahead - spare_behind);
            return towards(0.5 * (l.entry.speed_mps + f.entry.speed_mps) + forward / 2.0);
        }
    }
    if let Some(f) = &follower {
        let ahead_of_it = -f.gap_m as f32;
        let short = need_behind(f) - ahead_of_it;
        if short > 0.0 {
            let behind_it = ahead_of_it + 0.5 * gap_s * v.max(0.0) + length_m + 3.0;
            // Room ahead as gap acceptance will judge it: pulling ahead into less only trades
            // a gap too short behind for one too short ahead.
            let room = leader
                .as_ref()
                .map_or(f32::INFINITY, |l| l.gap_m as f32 - need_ahead(l));
            let wholly_ahead = ahead_of_it > 0.5 * (length_m + f.entry.length_m);
            return if free && room > short && (wholly_ahead || short < behind_it) {
                MergeSpeed::Pull(f.entry.speed_mps.max(v) + short / 2.0)
            } else {
                MergeSpeed::Cap((f.entry.speed_mps - LANE_END_DECEL_MPS2).max(floor))
            };
        }
    }
    leader.map_or(MergeSpeed::Cap(f32::INFINITY), |l| {
        let bumper = l.gap_m as f32 - 0.5 * (length_m + l.entry.length_m);
        let wanted = 0.5 * gap_s * v.max(0.0) + 3.0;
        MergeSpeed::Cap((l.entry.speed_mps + (bumper - wanted) / 2.0).max(floor))
    })
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

/// Decides every IDM vehicle's target: IDM acceleration behind its leader, lane keeping.
#[allow(clippy::type_complexity)]
pub fn drive_idm(
    network: Res<RoadNetwork>,
    index: Res<LaneIndex>,
    ahead: Res<RoadAhead>,
    mut vehicles: Query<(
        Entity,
        &RoadTrack,
        &Motion,
        &VehicleModel,
        DesiredSpeed,
        &mut IdmDriver,
        &mut DriveTarget,
        Wayfinding,
    )>,
) {
    let mut seen = Vec::new();
    for (me, track, motion, model, desired, mut driver, mut target, (route, signal)) in
        &mut vehicles
    {
        let Some(geometry) = network.get(track.road) else {
            continue;
        };
        let lanes = geometry.lanes().max(1);
        let length = model.0.params.chassis.length_m;
        let v = motion.forward_mps;
        if driver.road != Some(track.road) {
            driver.lane = carry_lane(&network, driver.road, track.road, driver.lane, track.lane);
            driver.road = Some(track.road);
        }
        // Lane changes only when its route asks, once the gap allows.
        let mut signal_dir = 0;
        let mut gap_s = driver.params.lane_change_gap_s;
        let window_mps = v.max(desired.0.kmh / 3.6);
        if let Some(ask) =
            route.and_then(|r| r.lane_change(driver.lane.min(lanes - 1), track.s_m, window_mps))
        {
            let next = (i64::from(driver.lane.min(lanes - 1)) + i64::from(ask.dir))
                .clamp(0, i64::from(lanes) - 1) as u32;
            gap_s *= ask.urgency();
            let change = LaneChange {
                lane: next,
                dir: ask.dir,
                lanes,
                gap_s,
                left_m: Some(ask.left_m),
                cross_s: crossing_s(track, lanes, driver.params.max_lateral_mps),
            };
            if change.accepted(&index, track, me, v, length) {
                driver.lane = next;
            } else {
                signal_dir = ask.dir;
            }
        }
        show_signal(signal, signal_dir, driver.lane.min(lanes - 1), track.lane);
        let p = &driver.params;
        let lane = driver.lane.min(lanes - 1);
        let (v0, _) = desired_speed_mps(
            p.target_speed_kmh,
            desired,
            &ahead,
            track,
            motion.forward_mps,
            lane,
        );
        let leader = index
            .leader(
                track.road,
                lane,
                track.s_m,
                me,
                f64::from(p.detection_range_m),
                track.next_road,
            )
            .map(|l| {
                let gap = l.gap_m as f32 - 0.5 * (length + l.entry.length_m);
                (gap, v - l.entry.speed_mps)
            });
        let v0 = v0.min(leaving_lane_cap_mps(
            route,
            track,
            lane,
            crossing_s(track, lanes, p.max_lateral_mps),
        ));
        let mut a = idm_accel(p, v, v0, leader);
        // The end of a lane it could not leave yet is a standing obstacle.
        if let Some(r) = route {
            let end = r.lane_end_m(lane) - track.s_m - 0.5 * f64::from(length) - LANE_END_MARGIN_M;
            if end.is_finite() {
                a = a.min(idm_accel(p, v, v0, Some((end as f32, v))));
            }
        }
        // Room for a car signalling to merge in ahead, braking at most its courtesy.
        if p.courtesy_decel_mps2 > 0.0 {
            let room = courtesy_speed_mps(
                &index,
                track,
                (lane, lanes),
                v,
                length,
                (p.courtesy_decel_mps2, p.lane_change_gap_s),
                &mut seen,
            );
            if room < v {
                a = a.min((room - v) / p.accel_horizon_s.max(0.1));
            }
        }
        if signal_dir != 0 {
            let next = (i64::from(lane) + i64::from(signal_dir)) as u32;
            let horizon = p.accel_horizon_s.max(0.1);
            // Free: nothing in its own lane holds it back.
            match merge_speed(&index, track, me, next, v, length, gap_s, a > -0.1) {
                MergeSpeed::Cap(c) if c < v => a = a.min((c - v) / horizon),
                MergeSpeed::Pull(pull) => {
                    let pull = pull.min(v0 + MERGE_PULL_MPS);
                    a = a.max(((pull - v) / horizon).min(p.max_accel_mps2));
                }
                _ => {}
            }
        }
        let speed = (v + a * p.accel_horizon_s).max(0.0);
        let (dir, base, curvature) = lane_following(
            geometry,
            track,
            lane,
            v,
            speed,
            1.0,
            p.road_weight_per_s,
            p.max_lateral_mps,
            p.lookahead_s,
        );
        // The IDM's acceleration itself is the command: the controller makes the car
        // accelerate so, as far as its drivetrain and brakes allow.
        *target = DriveTarget {
            accel_mps2: Some(a),
            ..to_target(dir * speed, base, dir, curvature)
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wave_damper_holds_the_mean_through_a_wave_and_matches_a_leader_too_close() {
        let mut d = WaveDamper::new(WaveDamperParams::default());
        // No leader: the limit.
        assert_eq!(d.command(3.0, 8.0, None), 8.0);
        let mut d = WaveDamper::new(WaveDamperParams::default());
        // At the settled gap it drives the running mean of its own speed, which starts at 3.
        let v = d.command(3.0, 8.0, Some((18.0, 3.0)));
        assert!((v - 3.0).abs() < 0.01, "{v}");
        // A long gap: at most catch_up faster than the mean, approached smoothly (half the
        // step each tick).
        let first = d.command(3.0, 8.0, Some((40.0, 3.0)));
        assert!((first - 3.15).abs() < 0.01, "{first}");
        let mut v = first;
        for _ in 0..20 {
            v = d.command(3.0, 8.0, Some((40.0, 3.0)));
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
            let v = d.command(3.0, 8.0, Some((gap, lead)));
            if t > 60.0 {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        assert!(hi - lo < 0.35, "{lo}..{hi}");
        // Closer than the safe gap (4 m, or 2 s per m/s of closing): its leader's speed.
        let v = d.command(5.0, 8.0, Some((3.0, 1.0)));
        assert!((v - 1.0).abs() < 1e-6, "{v}");
        let v = d.command(5.0, 8.0, Some((7.0, 1.0)));
        assert!((v - 1.0).abs() < 1e-6, "closing at 4 m/s needs 8 m: {v}");
    }

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

    #[test]
    fn a_humans_speed_wander_has_its_spread_and_memory_and_repeats() {
        let rng = || {
            flockway_core::RngStreams::new(5).stream(flockway_core::StableId::new(
                flockway_core::IdKind::Vehicle,
                1,
            ))
        };
        let mut h = HumanDriver::new(0.0).with_noise(1.0, 4.0, rng());
        let n = 120 * 4000;
        let xs: Vec<f32> = (0..n).map(|_| h.wander()).collect();
        let mean = xs.iter().map(|&x| f64::from(x)).sum::<f64>() / n as f64;
        let var = xs
            .iter()
            .map(|&x| (f64::from(x) - mean).powi(2))
            .sum::<f64>()
            / n as f64;
        assert!(mean.abs() < 0.1, "mean {mean}");
        assert!((var.sqrt() - 1.0).abs() < 0.1, "std {}", var.sqrt());
        // One second apart the wander remembers exp(−1/4) = 0.78 of itself.
        let lag = 120;
        let cov = (0..n - lag)
            .map(|i| (f64::from(xs[i]) - mean) * (f64::from(xs[i + lag]) - mean))
            .sum::<f64>()
            / (n - lag) as f64;
        assert!(
            (cov / var - 0.7788).abs() < 0.05,
            "autocorrelation {}",
            cov / var
        );
        // The same stream gives the same wander; no noise gives none.
        let mut again = HumanDriver::new(0.0).with_noise(1.0, 4.0, rng());
        assert!(xs.iter().take(1000).all(|&x| x == again.wander()));
        assert_eq!(HumanDriver::new(0.0).wander(), 0.0);
    }

    #[test]
    fn human_reacts_after_its_delay() {
        let mut h = HumanDriver::new(0.5);
        let t = |v: f32| DriveTarget {
            speed_mps: v,
            heading_rad: 0.0,
            curvature_per_m: 0.0,
            accel_mps2: None,
        };
        let delay = (0.5 / DT_S).round() as usize;
        for i in 0..delay {
            assert_eq!(h.react(t(i as f32 + 1.0)).speed_mps, 1.0);
        }
        // Tick `delay` returns what was decided `delay` ticks before.
        assert_eq!(h.react(t(100.0)).speed_mps, 1.0);
        assert_eq!(h.react(t(101.0)).speed_mps, 2.0);
    }
    use crate::perception::fixtures::split_with;
    use flockway_road::RoadId;

    const APPROACH: RoadId = RoadId(0);

    #[test]
    fn a_lane_change_waits_for_its_time_gap_ahead_and_behind_in_the_target_lane() {
        // Me in lane 0 at 500 m, 25 m/s; the target lane 1 holds a car ahead and one behind.
        let accepted = |ahead: f64, behind: f64, gap_s: f32| {
            let (_, index, cars) = split_with(&[
                (APPROACH, 0, 500.0, 25.0),
                (APPROACH, 1, 500.0 + ahead, 25.0),
                (APPROACH, 1, 500.0 - behind, 25.0),
            ]);
            let (me, track) = &cars[0];
            lane_gap_accepted(&index, track, *me, 1, 25.0, 4.6, gap_s)
        };
        // Ahead: 0.5 s at its speed (closing speed 0) and 6.6 m; behind: 1 s at 25 m/s and 6.6 m.
        assert!(accepted(20.0, 32.0, 1.0));
        assert!(!accepted(18.0, 32.0, 1.0));
        assert!(!accepted(20.0, 31.0, 1.0));
        // Near its lane's end a driver insists on less.
        assert!(accepted(16.0, 25.0, crate::LANE_CHANGE_LEAST_GAP));
        // A car alongside is never a gap.
        assert!(!accepted(2.0, 200.0, crate::LANE_CHANGE_LEAST_GAP));
    }

    #[test]
    fn a_car_waiting_to_change_lane_lines_up_with_a_gap() {
        let merge = |cars_there: &[(f64, f32)], free: bool| {
            let mut cars = vec![(APPROACH, 0, 500.0, 25.0)];
            cars.extend(cars_there.iter().map(|&(s, v)| (APPROACH, 1, s, v)));
            let (_, index, cars) = split_with(&cars);
            let (me, track) = &cars[0];
            merge_speed(&index, track, *me, 1, 25.0, 4.6, 1.0, free)
        };
        // A gap big enough, but this car sits too far forward in it: it eases back, never by
        // more than its gentle step.
        match merge(&[(530.0, 25.0), (480.0, 25.0)], true) {
            MergeSpeed::Cap(c) => assert!((c - (25.0 - MERGE_SLOW_MPS)).abs() < 1e-3, "{c}"),
            other => panic!("{other:?}"),
        }
        // Too far back in a big gap: it moves up, if nothing holds it back.
        assert!(matches!(
            merge(&[(560.0, 25.0), (460.0, 25.0)], true),
            MergeSpeed::Pull(p) if p > 25.0
        ));
        assert_eq!(
            merge(&[(560.0, 25.0), (460.0, 25.0)], false),
            MergeSpeed::Cap(f32::INFINITY)
        );
        // A car just behind, nobody ahead: pull ahead of it.
        assert!(matches!(merge(&[(490.0, 25.0)], true), MergeSpeed::Pull(p) if p > 25.0));
        // A car alongside with the way ahead blocked: drop back behind it.
        assert!(matches!(
            merge(&[(499.0, 25.0), (515.0, 25.0)], true),
            MergeSpeed::Cap(c) if c < 25.0
        ));
        // A car behind too close, a slower one ahead: pulling up would leave less ahead than
        // gap acceptance wants (15.5 m closing and 7.6 m there, 28 m given), so it drops back.
        assert!(matches!(
            merge(&[(475.0, 25.0), (528.0, 22.0)], true),
            MergeSpeed::Cap(c) if c < 25.0
        ));
        // Only a car ahead: fall in behind it.
        assert!(matches!(merge(&[(510.0, 25.0)], true), MergeSpeed::Cap(c) if c < 25.0));
        assert_eq!(merge(&[], true), MergeSpeed::Cap(f32::INFINITY));
    }
}

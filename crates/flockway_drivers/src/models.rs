//! The flocking driver (free and lane-keeping), what makes a driver human-like, and what every
//! built-in driver shares: its desired-speed factor, its speed limit, lane following.

use crate::ahead::RoadAheadParams;
use crate::control::{DriveTarget, PidGains};
use crate::perception::Seen;
use crate::pipeline::{DrivingModel, LaneStyle, Longitudinal, Proposal, Situation};
use crate::safety::SafetyParams;
use bevy_ecs::prelude::*;
use flockway_core::arrays::array4;
use flockway_core::{DT_S, EntityRng};
use flockway_road::{RoadGeometry, RoadId, RoadNetwork, lane_offset};
use flockway_vehicle::RoadTrack;
use glam::Vec3;
use multiversion::multiversion;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use wide::f32x4;

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
    /// How often it decides (its action step, as SUMO's `actionStepLength`), s: a whole number
    /// of ticks; 0 decides every tick. Between decisions it holds its target, while the
    /// controller, the junction gates and the safety layer still act every tick.
    pub action_step_s: f32,
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

impl FlockParams {
    /// The lane-keeping flocking car's defaults: as [`FlockParams::default`], with a firmer pull
    /// to the lane centre (1.5 m/s per m, capped as before), so that a car leaving a tight turn
    /// is back on its lane's centre within a car length or two instead of drifting across into
    /// the next lane.
    pub fn lanes() -> Self {
        FlockParams {
            road_weight_per_s: 1.5,
            ..FlockParams::default()
        }
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
            action_step_s: 0.0,
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
/// the lane, own and adjacent lanes with their own ranges, lane changes through the vehicle's
/// [`LaneChoice`](crate::LaneChoice)).
#[derive(Component, Debug, Clone, PartialEq)]
pub struct FlockDriver {
    /// Its parameters; edits take effect at the next tick.
    pub params: FlockParams,
    /// Lane-keeping (`FlockLanes`) or free (`Flock`).
    pub keep_lane: bool,
}

impl FlockDriver {
    /// A flocking driver, keeping its lane or free.
    pub fn new(params: FlockParams, keep_lane: bool) -> FlockDriver {
        FlockDriver { params, keep_lane }
    }
}

impl FlockParams {
    /// Its lateral style for the driving pipeline.
    pub fn lane_style(&self, keep_lane: bool) -> LaneStyle {
        LaneStyle {
            keep_lane,
            speed_weight: self.speed_weight,
            road_weight_per_s: self.road_weight_per_s,
            max_lateral_mps: self.max_lateral_mps,
            lookahead_s: self.lookahead_s,
            lane_change_gap_s: self.lane_change_gap_s,
            courtesy_decel_mps2: self.courtesy_decel_mps2,
        }
    }
}

impl DrivingModel for FlockDriver {
    fn cruise_kmh(&self) -> Option<f32> {
        self.params.target_speed_kmh
    }

    fn style(&self) -> LaneStyle {
        self.params.lane_style(self.keep_lane)
    }

    fn decide(&mut self, at: &Situation, seen: &mut Vec<Seen>) -> Proposal {
        flock_law(&self.params, self.keep_lane, at, seen)
    }
}

/// The flocking law (thesis §3.2.4): speed matching and road following (the pipeline's lane
/// following) plus collision avoidance — away from every vehicle within range in its own lane
/// and the lanes beside it, only along the lane when it keeps its lane — and, with a time gap
/// set, adaptive cruise control behind its leader. Free flocking steers along the result.
/// Built twice, for x86-64 and for AVX2 (taken at run time where the CPU has it; the same
/// answers to the bit).
#[multiversion(targets("x86_64+avx2"))]
pub fn flock_law(
    p: &FlockParams,
    keep_lane: bool,
    at: &Situation,
    seen: &mut Vec<Seen>,
) -> Proposal {
    let track = at.track;
    let (length, width) = at.size_m;
    let (lane, lanes, v, dir) = (at.lane, at.lanes, at.v, at.dir);
    let me_lat = track.lateral_m as f32;
    let me_speed = at.motion.linvel.dot(track.tangent);
    seen.clear();
    // Its own lane first, then the lanes right and left of it that there are.
    let adj = f64::from(p.adjacent_range_m);
    let mut windows = [(lane, f64::from(p.detection_range_m)); 3];
    let mut count = 1;
    for beside in [lane.checked_sub(1), Some(lane + 1).filter(|&l| l < lanes)]
        .into_iter()
        .flatten()
    {
        windows[count] = (beside, adj);
        count += 1;
    }
    let mut own_count = 0;
    at.index.visit_lanes(
        track.road,
        &windows[..count],
        track.s_m,
        Some(at.me),
        |k, s| {
            own_count += usize::from(k == 0);
            seen.push(s);
        },
    );
    let me = Observer {
        lateral_m: me_lat,
        speed_mps: me_speed,
        length_m: length,
        tangent: track.tangent,
        left: track.left,
    };
    let mut avoid = avoid_sum(p, &me, seen, own_count);
    // Free flocking swerves only between junctions: on a junction's path (crossing and merging
    // traffic, no room beside the path) it keeps to its path as the lane-keeping car does.
    let swerves = !keep_lane && at.network.junction_path(track.road).is_none();
    if swerves {
        // Sideways, no faster than its lane changes, and less as it slows: in a queue it
        // waits in line instead of squeezing past.
        let most = p.max_lateral_mps * (v / FREE_SWERVE_FULL_MPS).clamp(0.0, 1.0);
        let across = avoid.dot(track.left);
        let capped = across.clamp(-most, most);
        avoid += track.left * (capped - across);
    } else {
        // Brake or speed up, never swerve: only the part along the lane.
        avoid = dir * avoid.dot(dir);
    }
    let desired = if swerves {
        within_edges(at.base + avoid, track, width, seen, length)
    } else {
        at.base + avoid
    };
    let mut speed = desired.dot(dir).max(0.0);
    if keep_lane && p.time_gap_s > 0.0 {
        // Adaptive cruise control: close the gap beyond 2 m plus the time gap over 1.5 s.
        let range = f64::from(p.detection_range_m.max(v * p.time_gap_s * 2.0 + 50.0));
        if let Some((bumper, v_leader)) = at.leader(range) {
            let keep = v_leader + (bumper - 2.0 - v.max(0.0) * p.time_gap_s) / 1.5;
            speed = speed.min(keep.max(0.0));
        }
    }
    // Free flocking steers along its desired velocity's sideways part at the speed it drives
    // or would drive on an empty road, whichever is higher, as lane following does: braking
    // hard (a small desired speed along the lane), or waiting at a line, must not turn the same
    // sideways wish into a sharp turn.
    let steer_by = swerves.then(|| {
        let across = desired.dot(track.left);
        let along = v.max(at.base.dot(dir)).max(FREE_STEER_MIN_MPS);
        dir * along + track.left * across
    });
    Proposal {
        longitudinal: Longitudinal::Speed(speed),
        steer_by,
    }
}

/// The speed from which a free-flocking car swerves as fast as it changes lanes, m/s; slower,
/// in proportion.
const FREE_SWERVE_FULL_MPS: f32 = 10.0;

/// The least speed along the lane a free-flocking car's heading is reckoned at, m/s: at a
/// crawl it turns no more sharply than at this speed.
const FREE_STEER_MIN_MPS: f32 = 2.0;

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

    /// Advances the wander by one decision, `step_s` seconds (a tick, or the driver's action
    /// step), and returns it, m/s. An Ornstein–Uhlenbeck step with a unit-variance uniform kick
    /// (cheaper than a Gaussian, the same variance).
    pub fn wander(&mut self, step_s: f32) -> f32 {
        let Some(rng) = &mut self.rng else {
            return 0.0;
        };
        let kick = (rng.unit_f64() as f32 * 2.0 - 1.0) * 3f32.sqrt();
        // At most the whole way back to zero in one step, however long the step.
        let decay = (step_s / self.noise_time_s).min(1.0);
        self.noise_mps +=
            -self.noise_mps * decay + self.speed_noise_mps * (2.0 * decay).sqrt() * kick;
        self.noise_mps
    }

    /// Queues this decision (one every `step_s` seconds: a tick, or the driver's action step)
    /// and returns the one made a reaction time ago (the oldest while the queue fills).
    pub fn react(&mut self, decided: DriveTarget, step_s: f32) -> DriveTarget {
        let delay = (self.reaction_time_s.max(0.0) / step_s).round() as usize;
        self.pending.push_back(decided);
        while self.pending.len() > delay + 1 {
            self.pending.pop_front();
        }
        self.pending.front().copied().unwrap_or(decided)
    }
}

/// How far off its lane's centre a driver lets its car drift, m: beyond it, however gently it
/// keeps its lane (its `road_weight_per_s`), the pull back grows at least at
/// [`FIRM_ROAD_WEIGHT_PER_S`]. A gentle pull alone left a car swinging a metre out of a turn
/// drifting for seconds, into the oncoming lane of a two-way street; within the drift it still
/// weaves as gently as it likes (the spread of speeds in mixed traffic comes partly from that).
pub const LANE_DRIFT_M: f32 = 0.4;

/// The pull back towards its lane's centre, m/s per m, that every driver keeps to beyond
/// [`LANE_DRIFT_M`]: the lane-keeping car's (`flock_lanes.ron`).
pub const FIRM_ROAD_WEIGHT_PER_S: f32 = 1.5;

/// Lane following for a car in `lane`: speed matching along the lane direction plus road
/// following towards the lane centre (the pull capped at `max_lateral_mps`), and the lane's
/// curvature a little ahead for the steering feed-forward. Returns
/// `(lane direction here, desired velocity without avoidance, curvature ahead in 1/m)`. Built
/// twice, for x86-64 and for AVX2, like [`flock_law`].
#[allow(clippy::too_many_arguments)]
#[multiversion(targets("x86_64+avx2"))]
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
    let curvature = match track.tangent_ahead(geometry, f64::from(ahead)) {
        Some(t2) if ahead > 0.1 => {
            let t2 = t2.as_vec3();
            let turn = dir.x * t2.y - dir.y * t2.x;
            let along = dir.x * t2.x + dir.y * t2.y;
            libm::atan2f(turn, along) / ahead
        }
        _ => 0.0,
    };
    // Beyond its drift the pull grows as the lane-keeping car's does, whatever the driver's own.
    let firmer = FIRM_ROAD_WEIGHT_PER_S - road_weight_per_s;
    let drift = error.abs() - LANE_DRIFT_M;
    let back = if firmer > 0.0 && drift > 0.0 {
        firmer * drift * error.signum()
    } else {
        0.0
    };
    let pull = (error * road_weight_per_s + back).clamp(-max_lateral_mps, max_lateral_mps);
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

/// The vehicle that feels the avoidance pushes: where it is across the road, its speed along it,
/// its length, and the road's directions at it.
struct Observer {
    lateral_m: f32,
    speed_mps: f32,
    length_m: f32,
    tangent: Vec3,
    left: Vec3,
}

/// The avoidance pushes of every seen vehicle summed in their order, each [`avoid_push`] at the
/// range of its lane (the first `own_count` in the observer's own lane) and weighted by the rear
/// weight if it is behind. Four pushes at once ([`avoid_push4`]), summed one at a time in order:
/// the same bits as the scalar loop.
// Inlined into both builds of the flocking law.
#[inline(always)]
fn avoid_sum(p: &FlockParams, me: &Observer, seen: &[Seen], own_count: usize) -> Vec3 {
    let mut avoid = Vec3::ZERO;
    let mut fours = seen.chunks_exact(4);
    let mut first = 0;
    for four in &mut fours {
        add_pushes(&mut avoid, p, me, array4(|k| &four[k]), first, 4, own_count);
        first += 4;
    }
    // The last few in one more four, its spare lanes repeating the first of them, not summed.
    let rest = fours.remainder();
    if let Some(spare) = rest.first() {
        let four = array4(|k| rest.get(k).unwrap_or(spare));
        add_pushes(&mut avoid, p, me, four, first, rest.len(), own_count);
    }
    avoid
}

/// Adds to `avoid` the pushes of the first `count` of `four`, the seen vehicles from position
/// `first` on, in order.
// Inlined at both of its calls.
#[inline(always)]
fn add_pushes(
    avoid: &mut Vec3,
    p: &FlockParams,
    me: &Observer,
    four: [&Seen; 4],
    first: usize,
    count: usize,
    own_count: usize,
) {
    let range = array4(|k| {
        if first + k < own_count {
            p.detection_range_m
        } else {
            p.adjacent_range_m
        }
    });
    let share = array4(|k| {
        if four[k].gap_m < 0.0 {
            p.rear_weight
        } else {
            1.0
        }
    });
    let pushes = avoid_push4(four, me, f32x4::new(range), f32x4::new(share), p);
    for push in &pushes[..count] {
        *avoid += *push;
    }
}

/// Four seen vehicles' [`avoid_push`]es, each times its `share`, one per lane: each lane in the
/// scalar order of operations, `f32::max`, `signum` and `abs` as the scalar ones answer
/// (IEEE arithmetic and square root round a lane as they round a scalar).
#[inline(always)]
fn avoid_push4(
    seen: [&Seen; 4],
    me: &Observer,
    range_m: f32x4,
    share: f32x4,
    p: &FlockParams,
) -> [Vec3; 4] {
    let splat = f32x4::splat;
    let along = f32x4::new(array4(|k| seen[k].gap_m as f32));
    let across = f32x4::new(array4(|k| seen[k].entry.lateral_m)) - splat(me.lateral_m);
    let dist = (along * along + across * across).sqrt().max(splat(1.0e-3));
    let half_lengths =
        splat(0.5) * (splat(me.length_m) + f32x4::new(array4(|k| seen[k].entry.length_m)));
    // `f32::signum`: ±1 with the sign of zeros too, NaN for NaN.
    let sign_bit = splat(-0.0);
    let signum = along
        .is_nan()
        .select(splat(f32::NAN), splat(1.0) | (along & sign_bit));
    let closing = (splat(me.speed_mps) - f32x4::new(array4(|k| seen[k].entry.speed_mps)))
        * signum
        * (along.abs() / dist);
    let clearance =
        (dist - half_lengths - closing.max(f32x4::ZERO) * splat(p.anticipation_s)).max(splat(0.3));
    let reach = (range_m - half_lengths).max(splat(1.0));
    let strength = splat(p.avoid_weight_m2_per_s)
        * (splat(1.0) / clearance - splat(1.0) / reach).max(f32x4::ZERO);
    // glam's `-(t * along + l * across) / dist * strength`, one axis at a time, then the share.
    let axis = |t: f32, l: f32| {
        (share * ((-(splat(t) * along + splat(l) * across) / dist) * strength)).to_array()
    };
    let (t, l) = (me.tangent, me.left);
    let (x, y, z) = (axis(t.x, l.x), axis(t.y, l.y), axis(t.z, l.z));
    array4(|k| Vec3::new(x[k], y[k], z[k]))
}

/// The avoidance push from one seen vehicle, m/s, in the road's frame at the observer. The
/// clearance between bumpers is taken as it will be after `anticipation_s` at the current
/// closing speed, so a fast approach pushes as hard as a near one. Vehicles ahead push back and
/// vehicles behind push forward alike (thesis §3.2.4): in a platoon the two cancel, which is
/// what lets dense traffic hold the limit. The definition: the flocking law computes four at a
/// time ([`avoid_push4`]), held to this one's bits by a test.
#[cfg(test)]
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

/// How long, s, a free-flocking car's sideways speed would take it to the road's edge at the
/// least: a push towards the edge is cut to what leaves it that long.
const EDGE_TIME_S: f32 = 1.5;

/// Room kept between a free-flocking car's side and the road's edge (a guardrail), m.
const EDGE_MARGIN_M: f32 = 0.4;

/// A free-flocking car's desired velocity with its sideways part cut to what keeps its body on
/// the road and off the cars beside it: avoidance may push it sideways, never off the road, into
/// a guardrail, or into a car alongside (towards an edge or a car whose body overlaps its own
/// along the road, no faster than covers the room left in [`EDGE_TIME_S`]). `seen` holds the
/// cars around it.
fn within_edges(
    desired: Vec3,
    track: &RoadTrack,
    width_m: f32,
    seen: &[Seen],
    length_m: f32,
) -> Vec3 {
    let reach = 0.5 * track.width_m - 0.5 * width_m - EDGE_MARGIN_M;
    let lateral = track.lateral_m as f32;
    // Negative room (past where it may be) asks it back at once.
    let mut room_left = reach - lateral;
    let mut room_right = reach + lateral;
    for s in seen {
        // Alongside: their bodies overlap along the road (with a metre to spare).
        if (s.gap_m.abs() as f32) >= 0.5 * (length_m + s.entry.length_m) + 1.0 {
            continue;
        }
        let across = s.entry.lateral_m - lateral;
        // Room between the two sides (the other car taken as wide as this one).
        let room = across.abs() - width_m - EDGE_MARGIN_M;
        if across > 0.0 {
            room_left = room_left.min(room);
        } else {
            room_right = room_right.min(room);
        }
    }
    let across = desired.dot(track.left);
    let (lowest, highest) = (-room_right / EDGE_TIME_S, room_left / EDGE_TIME_S);
    // Squeezed from both sides: the middle of the two.
    let clamped = if lowest <= highest {
        across.clamp(lowest, highest)
    } else {
        0.5 * (lowest + highest)
    };
    desired + track.left * (clamped - across)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Within [`LANE_DRIFT_M`] of its lane's centre a gentle driver pulls back at its own
    /// weight; beyond it the pull grows as the lane-keeping car's does; a car as firm as that
    /// keeps its own pull, and the cap still holds.
    #[test]
    fn a_gentle_driver_pulls_back_firmly_once_it_has_drifted() {
        use flockway_road::{RoadId, RoadNetwork, RoadSpec};
        let road = RoadSpec::through(
            "a",
            2,
            50.0,
            &[glam::DVec3::ZERO, glam::DVec3::new(400.0, 0.0, 0.0)],
        );
        let network = RoadNetwork::build(&[road]).expect("valid road");
        let g = network.get(RoadId(0)).expect("road");
        let centre = lane_offset(g.frame_at(0.0).width_m, 2, 0);
        // The sideways part of the desired velocity of a car `off` metres left of lane 0's
        // centre, pulling at `weight` per second, capped at 5 m/s.
        let pull = |off: f64, weight: f32| {
            let track = RoadTrack::new(RoadId(0), g, 100.0, centre + off);
            let (_, base, _) = lane_following(g, &track, 0, 10.0, 10.0, 1.0, weight, 5.0, 0.6);
            base.dot(track.left)
        };
        let close = |a: f32, b: f32| (a - b).abs() < 1e-4;
        assert!(close(pull(0.3, 0.5), -0.15), "{}", pull(0.3, 0.5));
        // 0.5 × 1 m and (1.5 − 0.5) × the 0.6 m beyond the drift.
        assert!(close(pull(1.0, 0.5), -1.1), "{}", pull(1.0, 0.5));
        assert!(close(pull(-1.0, 0.5), 1.1), "{}", pull(-1.0, 0.5));
        assert!(close(pull(1.0, 1.5), -1.5), "{}", pull(1.0, 1.5));
        // 3 m off: 0.5 × 3 + 1 × 2.6, under the cap.
        assert!(close(pull(3.0, 0.5), -4.1), "{}", pull(3.0, 0.5));
    }

    /// The avoidance pushes four at a time sum to the scalar loop's bits (a NaN to a NaN), over
    /// neighbours of every count up to a few fours: ahead and behind, ±0 gaps, overlapping
    /// cars, closing and opening, far beyond the range, and non-finite gaps and offsets.
    #[test]
    fn avoidance_pushes_four_at_a_time_sum_to_the_scalar_loop_s_bits() {
        use crate::perception::LaneEntry;
        let mut state = 0x2545_f491_u32;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        };
        let special = [
            0.0,
            -0.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1.0e-30,
            3.0,
        ];
        let pick = |scale: f32, next: &mut dyn FnMut() -> u32| {
            let r = next();
            if r.is_multiple_of(23) {
                special[(r / 23) as usize % special.len()]
            } else {
                ((r >> 8) as f32 / (1 << 24) as f32 * 2.0 - 1.0) * scale
            }
        };
        let entity = Entity::from_raw_u32(7).expect("an entity");
        let mut scalar_bits = Vec::new();
        let mut four_bits = Vec::new();
        for case in 0..4000 {
            let p = FlockParams {
                rear_weight: 0.25 + (case % 3) as f32 * 0.5,
                ..FlockParams::default()
            };
            let me = Observer {
                lateral_m: pick(6.0, &mut next),
                speed_mps: pick(30.0, &mut next).abs(),
                length_m: 4.0 + pick(1.0, &mut next).abs(),
                tangent: Vec3::new(0.6, 0.8, pick(0.1, &mut next)),
                left: Vec3::new(-0.8, 0.6, 0.0),
            };
            let n = case % 14;
            let seen: Vec<Seen> = (0..n)
                .map(|_| Seen {
                    gap_m: f64::from(pick(80.0, &mut next)),
                    lane: 0,
                    entry: LaneEntry {
                        entity,
                        s_m: 0.0,
                        lateral_m: pick(6.0, &mut next),
                        speed_mps: pick(30.0, &mut next),
                        length_m: 4.0 + pick(1.0, &mut next).abs(),
                        signal: 0,
                    },
                })
                .collect();
            let own_count = (next() as usize) % (n + 1);
            let mut want = Vec3::ZERO;
            for (i, s) in seen.iter().enumerate() {
                let range = if i < own_count {
                    p.detection_range_m
                } else {
                    p.adjacent_range_m
                };
                let share = if s.gap_m < 0.0 { p.rear_weight } else { 1.0 };
                want += share
                    * avoid_push(
                        s,
                        me.lateral_m,
                        me.speed_mps,
                        me.length_m,
                        range,
                        p.avoid_weight_m2_per_s,
                        p.anticipation_s,
                        me.tangent,
                        me.left,
                    );
            }
            let got = avoid_sum(&p, &me, &seen, own_count);
            let bits = |v: Vec3| {
                v.to_array()
                    .map(|x| if x.is_nan() { u32::MAX } else { x.to_bits() })
            };
            scalar_bits.push(bits(want));
            four_bits.push(bits(got));
            assert_eq!(bits(got), bits(want), "case {case}: {got} against {want}");
        }
        // The cases reach every kind of answer: zero, finite pushes both ways, and NaN.
        let all: Vec<u32> = scalar_bits.iter().flatten().copied().collect();
        assert!(all.contains(&u32::MAX) && all.contains(&0));
        assert!(
            all.iter()
                .any(|&b| b != u32::MAX && f32::from_bits(b) > 0.1)
        );
        assert!(
            all.iter()
                .any(|&b| b != u32::MAX && f32::from_bits(b) < -0.1)
        );
        assert_eq!(scalar_bits, four_bits);
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
        let xs: Vec<f32> = (0..n).map(|_| h.wander(DT_S as f32)).collect();
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
        assert!(
            xs.iter()
                .take(1000)
                .all(|&x| x == again.wander(DT_S as f32))
        );
        assert_eq!(HumanDriver::new(0.0).wander(DT_S as f32), 0.0);
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
            assert_eq!(h.react(t(i as f32 + 1.0), DT_S as f32).speed_mps, 1.0);
        }
        // Tick `delay` returns what was decided `delay` ticks before.
        assert_eq!(h.react(t(100.0), DT_S as f32).speed_mps, 1.0);
        assert_eq!(h.react(t(101.0), DT_S as f32).speed_mps, 2.0);
    }
}

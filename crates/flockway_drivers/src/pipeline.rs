//! One driving pipeline for every model. A model supplies its longitudinal law (and its
//! lateral style); everything else is shared and applies to every model the same way:
//!
//! 1. its lanes carried over from road to road along the links;
//! 2. the route's strategic lane changes, gap acceptance, and the signal it shows;
//! 3. its desired speed — cruise × its own factor within what the road ahead allows — and the
//!    caps of a lane that ends or that it is leaving;
//! 4. lane following (the model's lateral style) → **the model's law** ([`DrivingModel`]);
//! 5. the caps of step 3, making room for a car signalling to merge in ahead (courtesy), and
//!    lining up with a gap while it waits to change lanes;
//! 6. human-like imperfections ([`HumanDriver`]: reaction delay, wandering speed choice), for
//!    any model that carries them; then the model's own last word ([`DrivingModel::finish`]).
//!
//! Junction gating and the safety layer follow in the shared controller, after every driver.
//! A model is a component implementing [`DrivingModel`], registered with [`add_model`].

use crate::DriverSystems;
use crate::ahead::{ReadsRoad, RoadAhead};
use crate::control::DriveTarget;
use crate::external::External;
use crate::models::{
    FlockDriver, FlockParams, HumanDriver, SpeedFactor, SpeedLimit, carry_lane, lane_following,
};
use crate::perception::{LaneIndex, LaneSignal, Seen};
use crate::route::{LaneAsk, Route, crossing_fit_mps, crossing_m};
use crate::safety::SafetyParams;
use bevy_ecs::component::Mutable;
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::ScheduleConfigs;
use bevy_ecs::system::ScheduleSystem;
use flockway_core::{DT_S, Sim, SimClock, Tick, for_each_car};
use flockway_road::{RoadGeometry, RoadId, RoadNetwork};
use flockway_vehicle::{Motion, PARALLEL_MIN_VEHICLES, RoadTrack, VehicleModel};
use glam::Vec3;
use std::marker::PhantomData;
use std::sync::Arc;

/// The lane a built-in driver follows and the one it wants, whatever its model.
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq)]
pub struct LaneChoice {
    /// The lane it follows now.
    pub lane: u32,
    /// The lane it wants: set this to change lanes; it moves over when the gap allows (a
    /// model that does not keep lanes ignores it).
    pub target_lane: u32,
    /// The road its lane numbers count on (`None` until it first decides): when it drives onto
    /// another road its lanes carry over along the link.
    pub road: Option<RoadId>,
}

impl LaneChoice {
    /// A driver in `lane`, wanting no other.
    pub fn new(lane: u32) -> LaneChoice {
        LaneChoice {
            lane,
            target_lane: lane,
            road: None,
        }
    }
}

/// How a model keeps to and changes lanes: its lateral style, which the pipeline applies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaneStyle {
    /// It keeps to its lane (false: its law may steer it across, as free flocking does; lane
    /// changes, signals and courtesy apply either way).
    pub keep_lane: bool,
    /// Weight of the lane direction × desired speed in the lane-following velocity.
    pub speed_weight: f32,
    /// Pull towards the lane centre, m/s per metre off it.
    pub road_weight_per_s: f32,
    /// Largest sideways speed the pull asks for, m/s.
    pub max_lateral_mps: f32,
    /// How far ahead, in seconds at its speed, the lane direction is taken.
    pub lookahead_s: f32,
    /// Time gap it wants ahead of and behind it in the target lane before a lane change, s.
    pub lane_change_gap_s: f32,
    /// How hard it brakes, at most, to make room for a car signalling to merge in ahead of it,
    /// m/s² (0: it does not make room).
    pub courtesy_decel_mps2: f32,
}

/// What a model's law asks of the car's speed: a speed target, or an acceleration (which the
/// shared controller feeds forward through the car's longitudinal dynamics).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Longitudinal {
    /// Drive at this speed, m/s.
    Speed(f32),
    /// Accelerate at this rate.
    Accel {
        /// The acceleration, m/s².
        accel_mps2: f32,
        /// How soon a speed the pipeline caps it at is reached, s: a cap `c` below its speed
        /// `v` becomes `a ≤ (c − v) / horizon`.
        horizon_s: f32,
        /// The most it accelerates to pull ahead into a gap, m/s².
        max_mps2: f32,
    },
}

impl Longitudinal {
    /// Never faster than `cap` (an acceleration law: reach it within its horizon if over it).
    pub fn cap(&mut self, v: f32, cap: f32) {
        match self {
            Longitudinal::Speed(s) => *s = s.min(cap),
            Longitudinal::Accel {
                accel_mps2,
                horizon_s,
                ..
            } => {
                if cap < v {
                    *accel_mps2 = accel_mps2.min((cap - v) / horizon_s.max(0.1));
                }
            }
        }
    }

    /// At least as fast as `speed` (an acceleration law: towards it, within its largest).
    pub fn pull(&mut self, v: f32, speed: f32) {
        match self {
            Longitudinal::Speed(s) => *s = s.max(speed),
            Longitudinal::Accel {
                accel_mps2,
                horizon_s,
                max_mps2,
            } => {
                *accel_mps2 = accel_mps2.max(((speed - v) / horizon_s.max(0.1)).min(*max_mps2));
            }
        }
    }

    /// Whether nothing holds it below the speed it wants, `v_target` (a speed within 0.5 m/s
    /// of it; an acceleration law not braking).
    pub fn free(&self, v_target: f32) -> bool {
        match self {
            Longitudinal::Speed(s) => *s >= v_target - 0.5,
            Longitudinal::Accel { accel_mps2, .. } => *accel_mps2 > -0.1,
        }
    }

    /// The speed it aims at from `v`, m/s (an acceleration held over its horizon).
    pub fn speed_mps(&self, v: f32) -> f32 {
        match *self {
            Longitudinal::Speed(s) => s,
            Longitudinal::Accel {
                accel_mps2,
                horizon_s,
                ..
            } => (v + accel_mps2 * horizon_s).max(0.0),
        }
    }

    /// The acceleration it asks for, if its law is one.
    pub fn accel_mps2(&self) -> Option<f32> {
        match *self {
            Longitudinal::Speed(_) => None,
            Longitudinal::Accel { accel_mps2, .. } => Some(accel_mps2),
        }
    }
}

/// Longest action step a driver may take, s: a decision held longer than this is no longer
/// driving.
pub const MAX_ACTION_STEP_S: f32 = 1.0;

/// How often a driver decides when not every tick (its action step, as SUMO's
/// `actionStepLength`): at the first tick it drives, then every `every` ticks, holding its
/// [`DriveTarget`] in between. Only the decision waits: the controller, the junction gates and
/// the safety layer act on the held target every tick.
#[derive(Component, Debug, Clone, Copy, PartialEq)]
pub struct ActionStep {
    every: u64,
    next: Option<Tick>,
    /// The speed its lane following aimed at when it last decided, m/s.
    v_target_mps: f32,
    /// Whether it last steered along its lane (not along a velocity of its law's own).
    lane_kept: bool,
}

impl ActionStep {
    /// A driver deciding every `every_ticks` ticks (at least 1).
    pub fn new(every_ticks: u32) -> ActionStep {
        ActionStep {
            every: u64::from(every_ticks.max(1)),
            next: None,
            v_target_mps: 0.0,
            lane_kept: false,
        }
    }

    /// The ticks of an action step of `step_s` seconds (0: every tick, 1), or why it is not
    /// one: a whole number of ticks from 0 to [`MAX_ACTION_STEP_S`].
    pub fn ticks_of(step_s: f32) -> Result<u32, String> {
        let ticks = f64::from(step_s) / DT_S;
        let whole = ticks.round();
        let fits = step_s.is_finite()
            && (0.0..=MAX_ACTION_STEP_S).contains(&step_s)
            && (ticks - whole).abs() <= 1.0e-3;
        if !fits {
            return Err(format!(
                "action_step_s must be 0 (every tick) or a whole number of {} s ticks up to {} s, \
                 not {step_s}",
                DT_S, MAX_ACTION_STEP_S
            ));
        }
        Ok((whole as u32).max(1))
    }

    /// Ticks between its decisions.
    pub fn every_ticks(&self) -> u64 {
        self.every
    }

    /// Whether it decides at `tick` (and if so, when next): at its step, or now if `now`.
    fn due(&mut self, tick: Tick, now: bool) -> bool {
        if !now && self.next.is_some_and(|next| tick < next) {
            return false;
        }
        self.next = Some(Tick(tick.0 + self.every));
        true
    }

    /// How long one decision holds, s.
    fn step_s(&self) -> f32 {
        (self.every as f64 * DT_S) as f32
    }
}

/// What a model's law decides this tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Proposal {
    /// Its speed or acceleration.
    pub longitudinal: Longitudinal,
    /// The velocity it steers along, in the world frame (`None`: its lane, as lane following
    /// gives it).
    pub steer_by: Option<Vec3>,
}

/// What one vehicle's law sees: where it is, what the road and the pipeline's shared stages
/// have made of its lane and speeds, and the lane index to find the others.
pub struct Situation<'a> {
    /// The vehicle.
    pub me: Entity,
    /// The road network.
    pub network: &'a RoadNetwork,
    /// Every vehicle by road and lane, this tick.
    pub index: &'a LaneIndex,
    /// The road it is on.
    pub geometry: &'a RoadGeometry,
    /// Where it is on it.
    pub track: &'a RoadTrack,
    /// How it moves.
    pub motion: &'a Motion,
    /// Where it is going, if it has a route.
    pub route: Option<&'a Route>,
    /// Its body's length and width, m.
    pub size_m: (f32, f32),
    /// The lane it follows (after this tick's lane change, if it made one).
    pub lane: u32,
    /// Lanes of its road.
    pub lanes: u32,
    /// Its speed along its heading, m/s.
    pub v: f32,
    /// Its desired speed: cruise × its factor, within what the road ahead allows, m/s.
    pub v_desired: f32,
    /// The speed that lets it leave a lane that ends while it crosses out of it, m/s (infinite
    /// when it is not).
    pub leaving_cap_mps: f32,
    /// The least of what the road ahead allows, the end of a lane it has not left yet, and
    /// `leaving_cap_mps`, m/s: the pipeline holds every law to it.
    pub cap_mps: f32,
    /// `v_desired` within `cap_mps`: what it would drive at on an empty road, m/s.
    pub v_target: f32,
    /// Its lane's direction here.
    pub dir: Vec3,
    /// Lane following's velocity: the lane direction × `v_target` × its speed weight, plus the
    /// pull towards the lane centre.
    pub base: Vec3,
    /// The lane's curvature a little ahead, 1/m.
    pub curvature_per_m: f32,
    /// How long this decision holds, s: one tick, or the driver's [`ActionStep`].
    pub step_s: f32,
}

impl Situation<'_> {
    /// Its leader in its lane within `range_m` (centre to centre; across links onto its next
    /// road): the bumper-to-bumper gap, m, and the leader's speed, m/s.
    pub fn leader(&self, range_m: f64) -> Option<(f32, f32)> {
        let t = self.track;
        self.index
            .leader(t.road, self.lane, t.s_m, self.me, range_m, t.next_road)
            .map(|l| {
                let gap = l.gap_m as f32 - 0.5 * (self.size_m.0 + l.entry.length_m);
                (gap, l.entry.speed_mps)
            })
    }
}

/// A driver model: a component whose law decides the car's speed (and may steer), driven by
/// the shared pipeline. Register it with [`add_model`].
pub trait DrivingModel: Component<Mutability = Mutable> {
    /// Its cruising speed, km/h (`None`: the speed limit); the pipeline multiplies it by the
    /// car's [`SpeedFactor`].
    fn cruise_kmh(&self) -> Option<f32>;

    /// How it keeps to and changes lanes.
    fn style(&self) -> LaneStyle;

    /// Its law: what it asks of the car's speed given `at`. `seen` is scratch space for
    /// [`LaneIndex::within`] queries.
    fn decide(&mut self, at: &Situation, seen: &mut Vec<Seen>) -> Proposal;

    /// Its last word on the target, after the shared stages and any human imperfections.
    fn finish(&mut self, _at: &Situation, _target: &mut DriveTarget) {}
}

/// Registers a driver model: [`drive`]`::<M>` runs every tick in the drivers' set for the
/// vehicles carrying `M` (and a [`LaneChoice`], a [`DriveTarget`], a [`SpeedLimit`]). Adding
/// a model twice adds it once.
pub fn add_model<M: DrivingModel>(sim: &mut Sim) {
    if sim.world().contains_resource::<Registered<M>>() {
        return;
    }
    sim.world_mut()
        .insert_resource(Registered::<M>(PhantomData));
    crate::add_driver(sim, drive::<M>);
}

/// Drives the vehicles of a level's `Custom(name)` profile with model `M` through the pipeline:
/// each gets `make(base)` — `base` being the profile's parameters, which it drove with as a
/// lane-keeping flocking car until told otherwise — in place of that flocking driver, before
/// its first decision. Registers `M` too (once per model: call [`add_model`] for no custom
/// profile, this for each custom name).
pub fn add_custom_model<M: DrivingModel>(
    sim: &mut Sim,
    name: &str,
    make: impl Fn(&FlockParams) -> M + Send + Sync + 'static,
) {
    let name: Arc<str> = Arc::from(name);
    let adopt = move |mut commands: Commands,
                      cars: Query<(Entity, &External, &FlockDriver), Without<M>>| {
        for (car, external, flock) in &cars {
            if external.model == name {
                commands
                    .entity(car)
                    .remove::<FlockDriver>()
                    .insert(make(&flock.params));
            }
        }
    };
    let configs: ScheduleConfigs<ScheduleSystem> = adopt
        .in_set(DriverSystems::Decide)
        .before(drive::<FlockDriver>)
        .before(drive::<M>)
        .ambiguous_with(DriverSystems::Decide)
        .into_configs();
    sim.schedule_mut().add_systems(configs);
    add_model::<M>(sim);
}

/// Marks model `M` as registered, so its pipeline is added once.
#[derive(Resource)]
struct Registered<M>(PhantomData<fn() -> M>);

/// Where a vehicle is going and the lane change it signals.
type Wayfinding = (Option<&'static Route>, Option<&'static mut LaneSignal>);

/// What sets a vehicle's desired speed: the limit it obeys, its own share of it, and what the
/// road ahead allows.
type DesiredSpeed = (
    &'static SpeedLimit,
    Option<&'static SpeedFactor>,
    Option<&'static ReadsRoad>,
);

/// What [`drive`] reads and writes on one vehicle.
type Item<'a, M> = (
    Entity,
    &'a RoadTrack,
    &'a Motion,
    &'a VehicleModel,
    (
        &'a SpeedLimit,
        Option<&'a SpeedFactor>,
        Option<&'a ReadsRoad>,
    ),
    Mut<'a, M>,
    Mut<'a, LaneChoice>,
    Option<Mut<'a, HumanDriver>>,
    Mut<'a, DriveTarget>,
    (Option<&'a Route>, Option<Mut<'a, LaneSignal>>),
    Option<Mut<'a, ActionStep>>,
);

/// The pipeline for every vehicle driven by model `M`: writes its [`DriveTarget`].
#[allow(clippy::type_complexity)]
pub fn drive<M: DrivingModel>(
    network: Res<RoadNetwork>,
    index: Res<LaneIndex>,
    ahead: Res<RoadAhead>,
    clock: Res<SimClock>,
    mut vehicles: Query<(
        Entity,
        &RoadTrack,
        &Motion,
        &VehicleModel,
        DesiredSpeed,
        &mut M,
        &mut LaneChoice,
        Option<&mut HumanDriver>,
        &mut DriveTarget,
        Wayfinding,
        Option<&mut ActionStep>,
    )>,
) {
    let tick = clock.tick();
    let run = |seen: &mut KeptSeen, item: Item<M>| {
        decide_one(&network, &index, &ahead, tick, &mut seen.0, item);
    };
    // Each car reads the shared index and road network and writes only its own components,
    // so the decisions are the same whichever thread makes them.
    for_each_car(&mut vehicles, PARALLEL_MIN_VEHICLES, KeptSeen::take, run);
}

thread_local! {
    /// Each thread's neighbours' list, kept from pass to pass with the room it grew to.
    static SEEN: std::cell::Cell<Vec<Seen>> = const { std::cell::Cell::new(Vec::new()) };
}

/// A thread's neighbours' list for one pass of [`drive`], given back to the thread at its end.
struct KeptSeen(Vec<Seen>);

impl KeptSeen {
    /// This thread's list (empty, with the room it had).
    fn take() -> KeptSeen {
        KeptSeen(SEEN.take())
    }
}

impl Drop for KeptSeen {
    fn drop(&mut self) {
        SEEN.set(std::mem::take(&mut self.0));
    }
}

/// One vehicle through the pipeline; `seen` is scratch space for its neighbours.
// Inlined into both loops of `drive`: called per car, the task pool's loop copied the item's
// many references into each call (a memcpy per car, about 2 % of the ring's parallel work).
#[inline(always)]
fn decide_one<M: DrivingModel>(
    network: &RoadNetwork,
    index: &LaneIndex,
    ahead: &RoadAhead,
    tick: Tick,
    seen: &mut Vec<Seen>,
    (
        me,
        track,
        motion,
        model,
        desired,
        mut law,
        mut choice,
        human,
        mut target,
        (route, signal),
        step,
    ): Item<M>,
) {
    let Some(geometry) = network.get(track.road) else {
        return;
    };
    let lanes = geometry.lanes().max(1);
    let chassis = &model.0.params.chassis;
    let length = chassis.length_m;
    let v = motion.forward_mps;
    let style = law.style();
    // Between its decisions a driver holds its target, but keeps its lane as the road is now
    // (lane keeping is a continuous skill); onto another road, it decides afresh.
    let mut step = step.filter(|s| s.every_ticks() > 1);
    if let Some(held) = step.as_mut()
        && !held.due(tick, choice.road != Some(track.road))
    {
        if held.lane_kept {
            let (dir, base, curvature) = lane_following(
                geometry,
                track,
                choice.lane.min(lanes - 1),
                v,
                held.v_target_mps,
                style.speed_weight,
                style.road_weight_per_s,
                style.max_lateral_mps,
                style.lookahead_s,
            );
            let heading = if base.truncate().length() > 1.0e-3 {
                base
            } else {
                dir
            };
            target.heading_rad = libm::atan2f(heading.y, heading.x);
            target.curvature_per_m = curvature;
        }
        return;
    }
    let step_s = step.as_ref().map_or(DT_S as f32, |s| s.step_s());
    if choice.road != Some(track.road) {
        let lane = carry_lane(network, choice.road, track.road, choice.lane, track.lane);
        let target = carry_lane(network, choice.road, track.road, choice.target_lane, lane);
        *choice = LaneChoice {
            lane,
            target_lane: target,
            road: Some(track.road),
        };
    }

    // The route asks for a lane in good time before its lane ends or leads elsewhere.
    // The window opens by the limit's speed as well, so slowing while waiting does not close it.
    let window_mps = v.max(desired.0.kmh / 3.6);
    let wanted = route.and_then(|r| r.lane_change(choice.lane, track.s_m, window_mps));
    if let Some(ask) = wanted {
        choice.target_lane =
            (i64::from(choice.lane) + i64::from(ask.dir)).clamp(0, i64::from(lanes) - 1) as u32;
    }
    // A lane change waits for room in the target lane: a time gap ahead and behind.
    let target_lane = choice.target_lane.min(lanes - 1);
    let mut signal_dir = 0;
    let mut gap_s = style.lane_change_gap_s;
    let cross_s = crossing_s(track, lanes, style.max_lateral_mps);
    if target_lane != choice.lane {
        let step = if target_lane > choice.lane { 1 } else { -1 };
        let next = (choice.lane as i64 + step) as u32;
        gap_s *= wanted.map_or(1.0, |ask| ask.urgency());
        let change = LaneChange {
            lane: next,
            dir: step as i8,
            lanes,
            gap_s,
            left_m: wanted.map(|ask| ask.left_m),
            cross_s,
        };
        if change.accepted(index, track, me, v, length) {
            choice.lane = next;
        } else {
            signal_dir = step as i8;
        }
    }
    show_signal(signal, signal_dir, choice.lane, track.lane);
    let lane = choice.lane.min(lanes - 1);

    let (v_desired, cap) = desired_speed_mps(law.cruise_kmh(), desired, ahead, track, v, lane);
    // A lane that ends is a wall ahead for whoever could not leave it yet.
    let leaving_cap_mps = leaving_lane_cap_mps(route, track, lane, cross_s);
    let cap = cap
        .min(route.map_or(f32::INFINITY, |r| {
            r.lane_end_cap_mps(lane, track.s_m, length, LANE_END_DECEL_MPS2)
                .min(r.prepare_cap_mps(
                    lane,
                    track.s_m,
                    geometry.length_m(),
                    (length, cross_s),
                    LANE_END_DECEL_MPS2,
                ))
        }))
        .min(leaving_cap_mps)
        .min(change_fit_cap_mps(
            wanted,
            target_lane != choice.lane,
            v,
            length,
            cross_s,
        ));
    let v_target = v_desired.min(cap);
    let (dir, base, curvature) = lane_following(
        geometry,
        track,
        lane,
        v,
        v_target,
        style.speed_weight,
        style.road_weight_per_s,
        style.max_lateral_mps,
        style.lookahead_s,
    );
    let at = Situation {
        me,
        network,
        index,
        geometry,
        track,
        motion,
        route,
        size_m: (length, chassis.width_m),
        lane,
        lanes,
        v,
        v_desired,
        leaving_cap_mps,
        cap_mps: cap,
        v_target,
        dir,
        base,
        curvature_per_m: curvature,
        step_s,
    };
    let proposal = law.decide(&at, seen);
    let mut command = proposal.longitudinal;
    // A push from a follower, or a law's own wish, never takes it faster than the caps.
    command.cap(v, cap);
    if style.courtesy_decel_mps2 > 0.0 {
        let room = courtesy_speed_mps(
            index,
            track,
            (lane, lanes),
            v,
            length,
            (style.courtesy_decel_mps2, style.lane_change_gap_s),
            seen,
        );
        command.cap(v, room);
    }
    if signal_dir != 0 {
        // Waiting to move over: line up with a gap in the target lane.
        let next = (i64::from(lane) + i64::from(signal_dir)) as u32;
        let free = command.free(v_target);
        match merge_speed(index, track, me, next, v, length, gap_s, free) {
            MergeSpeed::Cap(c) => command.cap(v, c),
            MergeSpeed::Pull(pull) => command.pull(v, pull.min(v_target + MERGE_PULL_MPS).min(cap)),
        }
    }
    if let Some(held) = step.as_mut() {
        held.v_target_mps = v_target;
        held.lane_kept = proposal.steer_by.is_none();
    }
    let steer_by = proposal
        .steer_by
        .unwrap_or_else(|| lane_kept_heading(base, dir));
    let heading = if steer_by.truncate().length() > 1.0e-3 {
        steer_by
    } else {
        dir
    };
    let decided = DriveTarget {
        speed_mps: command.speed_mps(v),
        heading_rad: libm::atan2f(heading.y, heading.x),
        curvature_per_m: curvature,
        accel_mps2: command.accel_mps2(),
    };
    *target = match human {
        // The reaction delay is on the response to traffic (the speed); lane keeping is a
        // continuous skill and follows the road as it is now.
        Some(mut h) => {
            let wander = h.wander(step_s);
            let chosen = DriveTarget {
                speed_mps: (decided.speed_mps + wander).max(0.0),
                ..decided
            };
            // A bend is seen long before it is reached: what the road ahead allows binds
            // without the delay.
            let reacted = h.react(chosen, step_s);
            DriveTarget {
                speed_mps: reacted.speed_mps.min(cap),
                accel_mps2: reacted.accel_mps2,
                ..decided
            }
        }
        None => decided,
    };
    law.finish(&at, &mut target);
}

/// The speed a driver wants before traffic, m/s, and what the road ahead allows: its cruising
/// speed (the limit unless its parameters set one) times its factor, within the envelope of its
/// lane read [`RoadAheadParams::preview_s`](crate::RoadAheadParams::preview_s) ahead of it at `track_speed`.
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
        ahead.lower_speed_cap_mps(r, track.road, lane, [track.s_m + preview, track.s_m], next)
    });
    ((free.max(0.0) / 3.6).min(cap), cap)
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

/// The slowest [`change_fit_cap_mps`] asks a car to go, m/s: one that cannot make its lane
/// change even at this speed goes on and misses its exit rather than stop in a running lane.
const CHANGE_FIT_FLOOR_MPS: f32 = 5.0;

/// While a car waits to make a lane change its route needs before `left_m` runs out, it goes
/// no faster than the speed at which the crossing still fits (slowing gently, at most
/// [`MERGE_SLOW_MPS`] below its speed): it would otherwise drive past the room it has left.
fn change_fit_cap_mps(
    wanted: Option<LaneAsk>,
    waiting: bool,
    v: f32,
    length_m: f32,
    cross_s: f32,
) -> f32 {
    match wanted {
        Some(ask) if waiting && ask.left_m.is_finite() => {
            crossing_fit_mps(ask.left_m, length_m, cross_s)
                .max(CHANGE_FIT_FLOOR_MPS)
                .max(v - MERGE_SLOW_MPS)
        }
        _ => f32::INFINITY,
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
    // A follower standing still (one that stopped to let this car in, as often as not) closes
    // on nothing: a car creeping in ahead of it needs only to be wholly ahead of it, where a
    // moving one is owed its time gap and 2 m. Insisting on the 2 m would leave both waiting
    // for the other for ever at a lane's end.
    let behind_ok = index
        .follower(track.road, lane, track.s_m, me, 200.0)
        .is_none_or(|f| {
            let standing = f.entry.speed_mps < STANDING_MPS && v < CREEP_MPS;
            if standing {
                bumper(&f) >= STANDING_FOLLOWER_GAP_M
            } else {
                -f.gap_m >= need(f.entry.speed_mps)
                    && f.entry.speed_mps <= firm.safe_speed_mps(bumper(&f), v)
            }
        });
    ahead_ok && behind_ok
}

/// Below this speed a car in the target lane counts as standing still, m/s.
const STANDING_MPS: f32 = 0.3;

/// Up to this speed a car may creep into a gap in front of a standing car, m/s.
const CREEP_MPS: f32 = 3.0;

/// The room between bumpers a car creeping in ahead of a standing one leaves it, m: wholly
/// ahead of it is enough, as the car moves away from it as it crosses.
const STANDING_FOLLOWER_GAP_M: f32 = 0.0;

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

/// The least speed along the lane, m/s, at which a lane-keeping car's pull towards its lane
/// centre is turned into a heading: slowing to a stop (a light, a conflict mid-turn), its
/// desired velocity is all pull, and taken as it is the heading would swing to across the lane.
pub const LANE_STEER_MIN_MPS: f32 = 2.0;

/// The velocity a lane-keeping car steers along: its desired velocity `base`, with the part
/// along its lane direction `dir` raised to [`LANE_STEER_MIN_MPS`] where it is less.
fn lane_kept_heading(base: Vec3, dir: Vec3) -> Vec3 {
    let along = base.dot(dir);
    if along < LANE_STEER_MIN_MPS {
        base + dir * (LANE_STEER_MIN_MPS - along)
    } else {
        base
    }
}

/// How far ahead a driver looks for a car signalling to merge into its lane, m.
const COURTESY_RANGE_M: f64 = 80.0;

/// The speed that makes room for the nearest car ahead in a lane either side that signals into
/// `lane`: its speed, plus closing the bumper gap beyond what the merging car needs behind it
/// ([`COURTESY_GAP_SHARE`] of the lane-change time gap `gap_s`, at this speed, and 3 m) over
/// 1.5 s, braking at most
/// `decel_mps2` below `v`. `INFINITY` when nobody signals.
// The test for anyone signalling inlined, the search not: mostly nobody signals, and the call
// to find that out cost more than the test.
#[inline(always)]
fn courtesy_speed_mps(
    index: &LaneIndex,
    track: &RoadTrack,
    (lane, lanes): (u32, u32),
    v: f32,
    length_m: f32,
    courtesy: (f32, f32),
    seen: &mut Vec<Seen>,
) -> f32 {
    if lanes < 2 || !index.any_signal() {
        return f32::INFINITY;
    }
    courtesy_room_mps(index, track, (lane, lanes), v, length_m, courtesy, seen)
}

/// [`courtesy_speed_mps`] once some vehicle signals.
#[inline(never)]
fn courtesy_room_mps(
    index: &LaneIndex,
    track: &RoadTrack,
    (lane, lanes): (u32, u32),
    v: f32,
    length_m: f32,
    (decel_mps2, gap_s): (f32, f32),
    seen: &mut Vec<Seen>,
) -> f32 {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lane_keeping_car_slowing_to_a_stop_heads_along_its_lane() {
        let (dir, left) = (Vec3::X, Vec3::Y);
        // Stopping 0.2 m right of its lane centre: the desired velocity is all pull.
        let pull = left * 0.2;
        let heading = lane_kept_heading(pull, dir);
        assert_eq!(heading, dir * LANE_STEER_MIN_MPS + pull);
        assert!(libm::atan2f(heading.y, heading.x) < 0.1);
        // Driving, the desired velocity is the heading as it is, to the bit.
        let base = dir * 12.5 + left * 0.2;
        assert_eq!(lane_kept_heading(base, dir), base);
    }
    use crate::perception::fixtures::split_with;
    use flockway_road::RoadId;

    #[test]
    fn an_action_step_is_a_whole_number_of_ticks_and_decides_once_per_step() {
        assert_eq!(ActionStep::ticks_of(0.0), Ok(1));
        assert_eq!(ActionStep::ticks_of((DT_S) as f32), Ok(1));
        // 1/30 s as a user writes it, and SUMO's usual steps.
        assert_eq!(ActionStep::ticks_of(0.033_333), Ok(4));
        assert_eq!(ActionStep::ticks_of(0.1), Ok(12));
        assert_eq!(ActionStep::ticks_of(1.0), Ok(120));
        for bad in [0.01, -0.1, 1.5, f32::NAN, f32::INFINITY] {
            let err = ActionStep::ticks_of(bad).expect_err("not a step");
            assert!(err.contains("action_step_s"), "{err}");
        }
        // The first tick it drives decides, then every fourth.
        let mut step = ActionStep::new(4);
        let decided: Vec<u64> = (10..24).filter(|&t| step.due(Tick(t), false)).collect();
        assert_eq!(decided, [10, 14, 18, 22]);
        // Told to decide now (onto another road), it counts its step from there.
        assert!(step.due(Tick(23), true));
        assert!(!step.due(Tick(26), false));
        assert!(step.due(Tick(27), false));
        assert_eq!(step.step_s(), (4.0 * DT_S) as f32);
        // Every tick: the step a driver without one takes, to the bit.
        assert_eq!(ActionStep::new(1).step_s(), DT_S as f32);
    }

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
    fn a_car_creeps_in_ahead_of_a_standing_car_it_is_wholly_ahead_of() {
        // Both nearly still (a lane's end, a courteous car stopped beside it): wholly ahead of
        // the standing car is enough; alongside, or the other still moving, is not.
        let accepted = |behind: f64, v_other: f32, v: f32| {
            let (_, index, cars) = split_with(&[
                (APPROACH, 0, 500.0, v),
                (APPROACH, 1, 500.0 - behind, v_other),
            ]);
            let (me, track) = &cars[0];
            lane_gap_accepted(&index, track, *me, 1, v, 4.6, 1.0)
        };
        assert!(accepted(4.7, 0.0, 0.0));
        assert!(!accepted(4.5, 0.0, 0.0));
        assert!(!accepted(4.7, 2.0, 0.0));
        assert!(!accepted(4.7, 0.0, 5.0));
        // A car moving behind is owed its time gap and 2 m.
        assert!(!accepted(6.0, 1.0, 1.0));
    }

    #[test]
    fn a_car_waiting_for_a_lane_its_route_needs_slows_to_where_the_crossing_fits() {
        let ask = |left_m: f64| LaneAsk {
            dir: 1,
            left_m,
            lanes: 1,
        };
        // 4 s to cross: 100 m left fits 30.4 m/s; 20 m fits only 5.5 m/s, approached gently.
        let fit = crossing_fit_mps(100.0, 4.6, 4.0);
        assert!((fit - 30.375).abs() < 1e-3, "{fit}");
        assert_eq!(
            change_fit_cap_mps(Some(ask(100.0)), true, 25.0, 4.6, 4.0),
            fit
        );
        assert_eq!(
            change_fit_cap_mps(Some(ask(20.0)), true, 25.0, 4.6, 4.0),
            25.0 - MERGE_SLOW_MPS
        );
        // Never below its floor: it goes on and misses its exit rather than stop.
        assert_eq!(
            change_fit_cap_mps(Some(ask(5.0)), true, 3.0, 4.6, 4.0),
            CHANGE_FIT_FLOOR_MPS
        );
        // Not waiting, or a change by choice: no cap.
        assert_eq!(
            change_fit_cap_mps(Some(ask(20.0)), false, 25.0, 4.6, 4.0),
            f32::INFINITY
        );
        assert_eq!(
            change_fit_cap_mps(None, true, 25.0, 4.6, 4.0),
            f32::INFINITY
        );
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

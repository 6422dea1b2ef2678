//! Right of way at junctions: before the drivers decide, every vehicle approaching a junction
//! learns whether it may enter its path or must stop at the line — by the signal, by the
//! priority rule and a gap in the conflicting streams, by the order of arrival at an all-way
//! stop — and nobody enters a path whose exit has no room. The shared controller holds a held
//! vehicle's speed to what stops it at the line, whatever its driver wants.

use crate::perception::{LaneIndex, Seen};
use crate::route::Route;
use bevy_ecs::prelude::*;
use bevy_ecs::query::ROQueryItem;
use flockway_core::{DT_S, SimClock, map_in_order, parallel_min};
use flockway_road::{CONFLICT_CLEARANCE_M, Conflict, RoadId, RoadNetwork, SignalState};
use flockway_vehicle::{Motion, PARALLEL_MIN_VEHICLES, RoadTrack, VehicleModel};
use std::collections::BTreeMap;

/// Braking a held vehicle plans to stop at the line with, m/s².
pub const STOP_LINE_DECEL_MPS2: f32 = 2.5;
/// Deceleration beyond which a vehicle at amber goes on rather than stops, m/s².
pub const AMBER_DECEL_MPS2: f32 = 3.5;
/// How far short of the line a held vehicle's front bumper stops, m.
pub const STOP_LINE_MARGIN_M: f64 = 1.0;
/// The time gap a yielding driver wants before a conflicting vehicle reaches the conflict, s.
pub const CRITICAL_GAP_S: f64 = 4.5;
/// The follow-up time of a driver whose file does not set one, s.
pub const FOLLOW_UP_S: f64 = 2.5;
/// How far ahead in time vehicles approaching a junction are followed, s: longer than any
/// critical gap a driver asks for.
pub const FOE_HORIZON_S: f64 = 12.0;
/// Bumper gap a held car keeps to the car ahead of it in the queue at the line, m.
pub const QUEUE_GAP_M: f64 = 2.0;
/// Speed above which a car that can no longer stop comfortably before the line is committed
/// to going through, m/s (below it, it creeps and can stop).
const COMMITTED_MPS: f32 = 3.0;
/// Speed below which a vehicle counts as stopped at a stop line, m/s.
const STOPPED_MPS: f32 = 0.3;
/// How close to the line a stop counts as a stop at it, m (front bumper).
const AT_LINE_M: f64 = 4.0;
/// How long a vehicle at the line waits with no conflicting vehicle moving before it goes
/// anyway (the deadlock rule), s.
pub const DEADLOCK_S: f64 = 20.0;
/// How far before the line a vehicle is considered approaching at the least, m.
const APPROACH_M: f64 = 30.0;

/// How a vehicle's driver takes gaps where it gives way at a junction. Vehicles without one use
/// [`CRITICAL_GAP_S`] and [`FOLLOW_UP_S`].
#[derive(Component, Debug, Clone, Copy, PartialEq)]
pub struct GapAcceptance {
    /// The least time before a vehicle it gives way to reaches their conflict that it accepts
    /// to go, s (its critical gap).
    pub critical_gap_s: f32,
    /// The least time after the car before it entered the same path that it follows it, s (its
    /// follow-up time).
    pub follow_up_s: f32,
}

impl GapAcceptance {
    /// A vehicle's critical gap and follow-up time, s: its own, or the defaults without one.
    pub fn seconds(of: Option<&GapAcceptance>) -> (f64, f64) {
        of.map_or((CRITICAL_GAP_S, FOLLOW_UP_S), |g| {
            (f64::from(g.critical_gap_s), f64::from(g.follow_up_s))
        })
    }
}

/// What the junction ahead lets a vehicle do; decided every tick before the drivers.
#[derive(Component, Debug, Clone, Copy, Default, PartialEq)]
pub struct JunctionGate {
    /// Where on its road its front bumper must stop, m; `None`: go.
    pub stop_at_m: Option<f64>,
    /// The junction path it is approaching.
    pub path: Option<RoadId>,
    /// The tick it came to a stop at the line, if it has (stop signs, all-way stops).
    pub stopped_tick: Option<u64>,
    /// The tick since which it has been held at the line with nothing in its way moving, if it
    /// is.
    pub held_since: Option<u64>,
    /// It is on the path (it entered): `stop_at_m` is then on the path, short of a conflict.
    pub inside: bool,
    /// Let go by the deadlock rule: until it enters, it no longer gives way.
    pub released: bool,
}

impl JunctionGate {
    /// The fastest it may go to stop at the line from `s_m` (centre) with a body of `length_m`;
    /// `INFINITY` when it may go.
    pub fn cap_mps(&self, s_m: f64, length_m: f32) -> f32 {
        match self.stop_at_m {
            Some(stop) => {
                let left = stop - s_m - 0.5 * f64::from(length_m);
                (2.0 * f64::from(STOP_LINE_DECEL_MPS2) * left.max(0.0)).sqrt() as f32
            }
            None => f32::INFINITY,
        }
    }
}

/// Junction events counted over a run.
#[derive(Resource, Debug, Clone, Default, PartialEq)]
pub struct JunctionStats {
    /// Deadlocks broken, per junction (by its index): vehicles that went after waiting
    /// [`DEADLOCK_S`] with nothing in their way moving.
    pub deadlocks: BTreeMap<usize, u64>,
    /// Per junction path: the tick the last vehicle entered it (for the follow-up time).
    pub last_entry: BTreeMap<RoadId, u64>,
    /// Per junction (by its index): the tick the deadlock rule last let a vehicle go.
    pub last_break: BTreeMap<usize, u64>,
}

/// One vehicle approaching a junction path, or on one, this tick.
#[derive(Debug, Clone, Copy)]
struct Approach {
    entity: Entity,
    junction: usize,
    path: usize,
    /// Front bumper to the line, m (negative once over it).
    to_line_m: f64,
    /// Half its body's length, m.
    half_m: f64,
    speed_mps: f32,
    /// Held on the tick before.
    held: bool,
    /// On the path already (it entered).
    inside: bool,
    /// The tick it stopped at the line, as its gate had it on the tick before.
    stopped_tick: Option<u64>,
    /// Behind a standing vehicle in its lane or at the start of a path from it: it cannot
    /// arrive before that one moves.
    blocked: bool,
}

/// What a tick's decisions share.
struct Scene<'a> {
    network: &'a RoadNetwork,
    index: &'a LaneIndex,
    approaches: &'a [Approach],
    signals: &'a [Option<Vec<SignalState>>],
    /// Per junction and path: the speed vehicles take through it, m/s ([`through_mps`]).
    through: &'a [Vec<f64>],
}

/// What holds a vehicle back from the next conflict it gives way to, if anything.
#[derive(Debug, Clone, Copy, Default)]
struct Blocked {
    /// Held (by a vehicle in the conflict or one arriving within the critical gap).
    hold: bool,
    /// By a vehicle that is moving (a wait that is not a deadlock).
    by_moving: bool,
    /// It gives way to a stream that may come (for the follow-up time).
    yields: bool,
}

impl Scene<'_> {
    /// Whether a vehicle on conflicting path `c.other` has its body in the conflict area now
    /// (whoever has the right of way, nobody drives into a car that is there), and whether one
    /// is on that path short of clearing the conflict.
    ///
    /// A foe going at speed that will have cleared the conflict before `a` can reach it (with a
    /// margin) is neither: it passes first. With when the last of those reached (or reaches)
    /// the conflict, s from now (negative: it is in it already).
    fn foes_on_path(&self, a: &Approach, c: &Conflict) -> (bool, bool, Option<f64>) {
        self.foes_on_path_from(a, c, false)
    }

    /// [`Scene::foes_on_path`] for a car not yet in the junction, which also waits for a foe
    /// clearing the junction after its green ended that cannot stop short of the conflict any
    /// more (whoever has the right of way now), and for one further off its path's
    /// centre than the clearance the conflicts were found with: its body sweeps more than they
    /// cover, so past the conflict's start it is in the way until it is off the path (a car
    /// already inside goes on rather than stop in that sweep).
    fn foes_on_path_at_line(&self, a: &Approach, c: &Conflict) -> bool {
        self.foes_on_path_from(a, c, true).0
    }

    fn foes_on_path_from(
        &self,
        a: &Approach,
        c: &Conflict,
        at_line: bool,
    ) -> (bool, bool, Option<f64>) {
        let j = a.junction;
        let mine_there = arrival_s(a.to_line_m + a.half_m + c.at_m, a.speed_mps);
        let Some(foe_road) = self.network.path_road(j, c.other) else {
            return (false, false, None);
        };
        let foe_clear = c.other_clear_m;
        let mut occupied = false;
        let mut short = false;
        let mut lead: Option<f64> = None;
        // Conflict positions are a body's centre's; only the cars on that path itself (not
        // those on paths overlapping it from the same lane).
        let through = self.through[j][c.other];
        // Its movement's green is over: a foe on it is clearing the junction.
        let clearing = self.signals[j].as_deref().is_some_and(|s| {
            matches!(
                s.get(c.other),
                None | Some(SignalState::Red | SignalState::Amber)
            )
        });
        for f in self.index.lane(foe_road, 0) {
            if f.speed_mps > PASSING_MPS
                && expected_arrival_s(0.0, foe_clear - f.s_m, f.speed_mps, through)
                    + PASSED_MARGIN_S
                    < mine_there
            {
                if f.s_m < foe_clear {
                    let at = if f.s_m > c.other_at_m {
                        -(f.s_m - c.other_at_m) / f64::from(f.speed_mps)
                    } else {
                        expected_arrival_s(0.0, c.other_at_m - f.s_m, f.speed_mps, through)
                    };
                    lead = Some(lead.map_or(at, |l: f64| l.max(at)));
                }
                continue;
            }
            let astray = at_line && f64::from(f.lateral_m.abs()) > CONFLICT_CLEARANCE_M;
            occupied |= f.s_m > c.other_at_m && (f.s_m < foe_clear + CONFLICT_MARGIN_M || astray);
            occupied |= at_line
                && clearing
                && f.s_m <= c.other_at_m
                && committed(f.speed_mps, c.other_at_m - f.s_m);
            short |= f.s_m < foe_clear;
        }
        // An area that reaches back over the other path's line (a turn driven wide across the
        // end of that lane): a car still before that line with its body in the area is in it
        // too, standing where its hold-back would have kept it clear had it been held in time.
        if c.other_at_m < 0.0 && !occupied {
            occupied = self.approaches.iter().any(|f| {
                f.junction == j
                    && f.path == c.other
                    && !f.inside
                    && -f.to_line_m - f.half_m > c.other_at_m
            });
        }
        (occupied, short, lead)
    }

    /// Whether a vehicle on conflicting path `c.other`, whose green has ended, still comes
    /// through conflict `c`: on the path and past the point of no return for it, or
    /// approaching and going on at amber (unable to stop comfortably where it waits). A car
    /// waiting inside the junction to complete a permitted turn lets these clear it first,
    /// whatever the signals now rank.
    fn foe_clearing(&self, a: &Approach, c: &Conflict) -> bool {
        let j = a.junction;
        let Some(state) = self.signals[j].as_deref().map(|s| s.get(c.other).copied()) else {
            return false;
        };
        if !matches!(state, None | Some(SignalState::Red | SignalState::Amber)) {
            return false;
        }
        let on_path = self.network.path_road(j, c.other).is_some_and(|foe_road| {
            self.index
                .lane(foe_road, 0)
                .iter()
                .any(|f| f.s_m <= c.other_at_m && committed(f.speed_mps, c.other_at_m - f.s_m))
        });
        let amber = state == Some(SignalState::Amber);
        let hold_back = self.network.junctions()[j].paths[c.other].hold_back_m;
        on_path
            || (amber
                && self.approaches.iter().any(|f| {
                    f.junction == j
                        && f.path == c.other
                        && !f.inside
                        && !f.held
                        && f64::from(f.speed_mps).powi(2)
                            > 2.0 * f64::from(AMBER_DECEL_MPS2) * (f.to_line_m - hold_back).max(0.1)
                }))
    }

    /// Whether vehicle `a` must wait for the streams it gives way to on conflicts `conflicts`
    /// of its path (the ones still ahead of it).
    fn gives_way_now<'c>(
        &self,
        a: &Approach,
        conflicts: impl Iterator<Item = &'c Conflict>,
        critical_gap_s: f64,
        all_way: Option<Option<u64>>,
    ) -> Blocked {
        let junction = &self.network.junctions()[a.junction];
        let states = self.signals[a.junction].as_deref();
        let mut out = Blocked::default();
        for c in conflicts {
            if !junction.gives_way(a.path, c.other, states) {
                continue;
            }
            // Inside the junction, short of clearing the conflict.
            let (_, short, mut lead) = self.foes_on_path(a, c);
            if short {
                out.hold = true;
                out.by_moving = true;
                return out;
            }
            // A foe on red is not coming (one already inside was seen above).
            let foe_state = states.map(|s| s.get(c.other).copied().unwrap_or(SignalState::Red));
            if matches!(foe_state, Some(SignalState::Red)) {
                continue;
            }
            out.yields = true;
            // Once going through a gap it took, it goes on unless a foe would now reach the
            // conflict before it has cleared it (a gap taken is not re-judged by the critical
            // gap every tick).
            let centre = -a.to_line_m - a.half_m;
            // Going: moving, let go, and too near to stop comfortably before its line any
            // more (or past it).
            let v = f64::from(a.speed_mps);
            let going = !a.held
                && a.speed_mps > STOPPED_MPS
                && a.to_line_m
                    < v * v / (2.0 * f64::from(STOP_LINE_DECEL_MPS2)) + STOP_LINE_MARGIN_M;
            let clear_by =
                going.then(|| arrival_s(c.clear_m - centre, a.speed_mps) + CLEARING_MARGIN_S);
            // Standing in the conflict already: a foe held at its line waits for it.
            let in_it = centre > c.at_m;
            // When it reaches its place at the line (now, when it waits there), and the
            // conflict.
            let mine = arrival_s((a.to_line_m - STOP_LINE_MARGIN_M).max(0.0), a.speed_mps);
            let mine_there = arrival_s(a.to_line_m + a.half_m + c.at_m, a.speed_mps);
            // The foes still coming: when they reach the conflict, how long they take through
            // it, their speed.
            let mut coming: Vec<(f64, f64, f32)> = Vec::new();
            for f in self
                .approaches
                .iter()
                .filter(|f| f.junction == a.junction && f.path == c.other && !f.inside)
            {
                if let Some(stopped_tick) = all_way.filter(|_| junction.must_stop(c.other)) {
                    // Both stop: order of arrival, the earlier stop goes first.
                    if f.stopped_tick.is_some_and(|t| {
                        stopped_tick.is_none_or(|mine| (t, f.entity) < (mine, a.entity))
                    }) {
                        out.hold = true;
                    }
                    continue;
                }
                // Stopping at its own line for amber, or behind a standing car: not coming.
                if f.blocked || (f.held && (in_it || foe_state == Some(SignalState::Amber))) {
                    continue;
                }
                // The gap it would take: from when it reaches the line to when the foe
                // reaches their conflict. A foe that will have cleared the conflict before it
                // gets there passes first.
                let through = self.through[a.junction][c.other];
                let eta =
                    expected_arrival_s(f.to_line_m, f.half_m + c.other_at_m, f.speed_mps, through);
                let foe_gone = expected_arrival_s(
                    f.to_line_m,
                    f.half_m + c.other_clear_m,
                    f.speed_mps,
                    through,
                );
                if f.speed_mps > PASSING_MPS && foe_gone + PASSED_MARGIN_S < mine_there {
                    lead = Some(lead.map_or(eta, |l| l.max(eta)));
                    continue;
                }
                coming.push((eta, foe_gone - eta, f.speed_mps));
            }
            for &(eta, through_s, speed) in &coming {
                // The critical gap is a headway, front to front: the foe's own time through
                // the conflict area is part of it; behind a foe that passes first, the gap is
                // from that one to this one.
                let gap_s = critical_gap_s - through_s.max(0.0);
                let needed_s = clear_by.map_or(gap_s, |c| gap_s.min(c));
                let behind_lead =
                    clear_by.is_none() && lead.is_some_and(|l| l < eta && eta - l < critical_gap_s);
                if eta - mine < needed_s || behind_lead {
                    out.hold = true;
                    out.by_moving |= speed > STOPPED_MPS;
                }
            }
            // Held by moving traffic: nothing more to learn. Held only by standing foes: the
            // other streams still say whether it waits for moving traffic (a wait behind a
            // standing foe that itself waits for a stream is no deadlock).
            if out.hold && out.by_moving {
                return out;
            }
        }
        out
    }
}

/// How far past the end of a conflict area a body still counts as in it, m.
const CONFLICT_MARGIN_M: f64 = 0.5;
/// How far short of a conflict's start a car waiting inside the junction stops its centre, m
/// (room for an overshoot: a car a little past it would be in the way).
const INSIDE_STOP_M: f64 = 1.5;
/// How far past a conflict's start a car's centre may be and still be waiting short of it
/// (an overshoot does not entitle it to go on; the others see it in their way), m.
const WAIT_TOLERANCE_M: f64 = 0.5;
/// Time a foe must have cleared a conflict before a car reaches it for the foe to pass first,
/// s.
const PASSED_MARGIN_S: f64 = 1.0;
/// Time a car going through a gap wants between clearing a conflict and a foe reaching it, s.
const CLEARING_MARGIN_S: f64 = 1.5;

/// The vehicles the junction rule decides for.
type Gated = (
    Entity,
    &'static RoadTrack,
    &'static Motion,
    &'static VehicleModel,
    &'static mut JunctionGate,
);

/// One vehicle as the junction rule reads it.
type GateItem<'w> = ROQueryItem<'w, 'w, Gated>;

/// Decides every approaching vehicle's [`JunctionGate`].
///
/// At the line: the signal, a stop sign, room on the exit lane, and the streams it gives way
/// to (a gap of its critical gap, its follow-up time behind the car before it). A permitted
/// movement under a signal (a green that must yield, like a left turn across oncoming traffic)
/// enters and waits inside, at the first conflict it must give way at, when the path is free.
/// Inside: it stops short of any conflict whose area a vehicle occupies, and of one it gives way
/// at while a stream it yields to leaves no gap — unless it is past the point of no return.
#[allow(clippy::type_complexity)]
#[expect(
    clippy::too_many_arguments,
    reason = "a system: the resources and queries it reads, and its cache of path speeds"
)]
pub fn gate_junctions(
    network: Res<RoadNetwork>,
    index: Res<LaneIndex>,
    clock: Res<SimClock>,
    signals: Res<crate::Signals>,
    mut stats: ResMut<JunctionStats>,
    mut vehicles: Query<Gated>,
    gaps: Query<&GapAcceptance>,
    routes: Query<&Route>,
    mut through: Local<Vec<Vec<f64>>>,
) {
    if network.junctions().is_empty() {
        return;
    }
    let tick = clock.tick().0;
    let signals: Vec<Option<Vec<SignalState>>> = (0..network.junctions().len())
        .map(|j| signals.states(j).map(<[SignalState]>::to_vec))
        .collect();
    // Who approaches which path (in the query's order, which the world fixes): by its route's
    // next road, or where its lane leads for a car that follows the links; and who is on one.
    // Each car's answer reads only shared state: found over the task pool, kept in order.
    let items: Vec<_> = vehicles.iter().collect();
    let found = map_in_order(
        &items,
        parallel_min(PARALLEL_MIN_VEHICLES),
        || (),
        |_, item| approach_of(&network, &index, &routes, item),
    );
    let mut approaches: Vec<Approach> = Vec::new();
    // The item each deciding approach belongs to.
    let mut owners: Vec<usize> = Vec::new();
    // Vehicles bound for a junction beyond the next one on their routes (foes only).
    let mut far: Vec<Approach> = Vec::new();
    for (i, (approach, beyond)) in found.into_iter().enumerate() {
        far.extend(beyond);
        if let Some(a) = approach {
            approaches.push(a);
            owners.push(i);
        }
    }
    let deciding = approaches.len();
    approaches.append(&mut far);
    // The paths' speeds change only with the network.
    if network.is_changed() || through.len() != network.junctions().len() {
        *through = (0..network.junctions().len())
            .map(|j| {
                (0..network.junctions()[j].paths.len())
                    .map(|k| {
                        network
                            .path_road(j, k)
                            .map_or(f64::INFINITY, |p| through_mps(&network, p))
                    })
                    .collect()
            })
            .collect();
    }
    let scene = Scene {
        network: &network,
        index: &index,
        approaches: &approaches,
        signals: &signals,
        through: through.as_slice(),
    };
    // Each car's decision reads the shared scene and its own state only: made over the task
    // pool, kept in order. What one car's decision does to the next's (one deadlock broken at
    // a time) is applied after, in order.
    let deciders: Vec<(&Approach, usize)> = approaches[..deciding].iter().zip(owners).collect();
    let stats_now: &JunctionStats = &stats;
    let made = map_in_order(
        &deciders,
        parallel_min(PARALLEL_MIN_VEHICLES),
        Vec::new,
        |seen, &(a, i)| {
            let (_, track, _, _, gate) = items[i];
            let (critical_gap_s, follow_up_s) = GapAcceptance::seconds(gaps.get(a.entity).ok());
            if a.inside {
                decide_inside(&scene, a, gate, critical_gap_s, tick)
            } else {
                decide_at_line(
                    &scene,
                    a,
                    track,
                    gate,
                    (critical_gap_s, follow_up_s),
                    stats_now,
                    tick,
                    seen,
                )
            }
        },
    );
    let mut decided: Vec<(Entity, JunctionGate, Option<usize>)> =
        Vec::with_capacity(approaches.len());
    let mut broken: Vec<usize> = Vec::new();
    for (&(a, i), (mut new, mut deadlock)) in deciders.iter().zip(made) {
        let (_, track, _, _, gate) = items[i];
        // One vehicle let go at a time: the others wait for it, and the rule lets the next go
        // no sooner than its wait later.
        let recent = stats
            .last_break
            .get(&a.junction)
            .is_some_and(|&t| (tick - t) as f64 * DT_S < DEADLOCK_S);
        if deadlock && (recent || broken.contains(&a.junction)) {
            deadlock = false;
            new.held_since = gate.held_since;
            new.released = false;
            if new.stop_at_m.is_none() {
                new.stop_at_m = Some(held_stop(&network, track, a));
            }
        }
        // Behind the car ahead of it in the queue there (a queue pressed from behind would
        // otherwise push its first car over the line).
        let new = JunctionGate {
            stop_at_m: new.stop_at_m.map(|stop| {
                let queue = index
                    .leader(
                        track.road,
                        track.lane,
                        track.s_m,
                        a.entity,
                        (stop - track.s_m).max(0.0),
                        None,
                    )
                    .filter(|l| track.s_m + l.gap_m < stop + 5.0)
                    .map_or(f64::INFINITY, |l| {
                        track.s_m + l.gap_m - 0.5 * f64::from(l.entry.length_m) - QUEUE_GAP_M
                    });
                stop.min(queue)
            }),
            ..new
        };
        decided.push((a.entity, new, deadlock.then_some(a.junction)));
        if deadlock {
            broken.push(a.junction);
        }
    }
    // Write the decisions (in the query's order, as they were made); a vehicle approaching no
    // junction is free.
    let mut d = decided.into_iter().peekable();
    for (entity, track, _, _, mut gate) in &mut vehicles {
        let (new, deadlock) = match d.next_if(|(e, _, _)| *e == entity) {
            Some((_, g, deadlock)) => (g, deadlock),
            None => (JunctionGate::default(), None),
        };
        // It was approaching this path and is on it now: it entered.
        if gate.path == Some(track.road) && !gate.inside {
            stats.last_entry.insert(track.road, tick);
        }
        if *gate != new {
            *gate = new;
        }
        if let Some(j) = deadlock {
            *stats.deadlocks.entry(j).or_default() += 1;
            stats.last_break.insert(j, tick);
        }
    }
}

/// One vehicle's approach this tick (the junction path it is on, or the one ahead of it within
/// its horizon), and the junctions further along its route within that horizon, where it is a
/// foe only.
fn approach_of(
    network: &RoadNetwork,
    index: &LaneIndex,
    routes: &Query<&Route>,
    &(entity, track, motion, model, gate): &GateItem,
) -> (Option<Approach>, Vec<Approach>) {
    let mut far = Vec::new();
    let half = 0.5 * f64::from(model.0.params.chassis.length_m);
    let v = motion.forward_mps.max(0.0);
    let held = gate.stop_at_m.is_some();
    // Near enough to be stopped at the line, or to be in the gap a yielding driver looks
    // for.
    let horizon = (APPROACH_M + f64::from(v * v / (2.0 * STOP_LINE_DECEL_MPS2)))
        .max(f64::from(v) * FOE_HORIZON_S);
    // Junctions further along its route within that distance (round a roundabout, the
    // next entry's drivers see it coming): foes there, held if it is held before.
    if let Ok(route) = routes.get(entity) {
        let mut to_m = network.get(track.road).map_or(0.0, |g| g.length_m()) - track.s_m - half;
        // The first path ahead of a car not yet in a junction is the one it approaches,
        // decided below; the others are foes' information only.
        let mut skip = network.junction_path(track.road).is_none();
        for &road in route.ahead().iter().skip(1) {
            if to_m > horizon {
                break;
            }
            if let Some((j, k)) = network.junction_path(road)
                && !std::mem::take(&mut skip)
            {
                far.push(Approach {
                    entity,
                    junction: j,
                    path: k,
                    to_line_m: to_m,
                    half_m: half,
                    speed_mps: v,
                    held: false,
                    inside: false,
                    stopped_tick: None,
                    blocked: held,
                });
            }
            to_m += network.get(road).map_or(f64::INFINITY, |g| g.length_m());
        }
    }
    if let Some((j, k)) = network.junction_path(track.road) {
        let on_path = Approach {
            entity,
            junction: j,
            path: k,
            to_line_m: -(track.s_m + half),
            half_m: half,
            speed_mps: v,
            held,
            inside: true,
            stopped_tick: None,
            blocked: false,
        };
        return (Some(on_path), far);
    }
    let approach = network
        .junction_ahead(track.road, track.lane, track.s_m, track.next_road, half)
        .filter(|ahead| ahead.to_line_m < horizon)
        .map(|ahead| Approach {
            entity,
            junction: ahead.junction,
            path: ahead.path,
            to_line_m: ahead.to_line_m,
            half_m: half,
            speed_mps: v,
            held,
            inside: false,
            stopped_tick: gate.stopped_tick,
            blocked: queued_behind(network, index, entity, track),
        });
    (approach, far)
}

/// Below this speed a car at the start of an exit lane that closes on a standing one is about
/// to stand there, m/s.
const EXIT_MOVING_MPS: f32 = 5.0;
/// Below this speed a car counts as standing in a queue, m/s.
const QUEUED_MPS: f32 = 2.0;
/// How close behind a standing car a slow one is joining its queue, m (centre to centre).
const JOINING_QUEUE_M: f64 = 15.0;

/// How far into a path a standing vehicle still blocks the lane it came from, m (its centre).
const BLOCKS_LANE_M: f64 = 10.0;

/// Whether a vehicle approaching a junction stands behind a standing vehicle: one ahead in its
/// lane before the line, or one at the start of any path from its lane (a turning car waiting
/// inside).
fn queued_behind(network: &RoadNetwork, index: &LaneIndex, me: Entity, track: &RoadTrack) -> bool {
    let to_end = network.get(track.road).map_or(0.0, |g| g.length_m()) - track.s_m;
    let standing = |speed: f32| speed < STOPPED_MPS;
    if index
        .leader(track.road, track.lane, track.s_m, me, to_end, None)
        .is_some_and(|l| l.gap_m <= to_end && standing(l.entry.speed_mps))
    {
        return true;
    }
    network
        .links(track.road)
        .iter()
        .filter(|l| l.lane_to(track.lane).is_some() && network.junction_path(l.to).is_some())
        .any(|l| {
            index
                .lane(l.to, 0)
                .iter()
                .any(|e| e.s_m < BLOCKS_LANE_M && standing(e.speed_mps))
        })
}

/// Speed above which a foe is taken to keep moving through (and may pass first), m/s: a
/// slower one may be about to stop.
const PASSING_MPS: f32 = 2.0;
/// Speed below which a vehicle is expected to speed up on its way to a conflict, m/s.
const STARTING_MPS: f32 = 5.0;
/// The acceleration a starting vehicle is expected to reach a conflict with, m/s².
const STARTING_ACCEL_MPS2: f64 = 2.0;

/// The acceleration a car waiting to follow up is expected to start with at most, m/s² (it
/// may go as soon as it could not arrive sooner than its follow-up time).
const OWN_START_ACCEL_MPS2: f64 = 3.0;

/// When a vehicle `d_m` from a point reaches it at `speed_mps`: a slow or standing one is
/// expected to speed up (a car held at its line a moment ago may be released now).
fn arrival_s(d_m: f64, speed_mps: f32) -> f64 {
    let v = f64::from(speed_mps.max(0.0));
    if speed_mps < STARTING_MPS {
        let a = STARTING_ACCEL_MPS2;
        (-v + (v * v + 2.0 * a * d_m.max(0.0)).sqrt()) / a
    } else {
        d_m.max(0.0) / v
    }
}

/// Comfortable lateral acceleration foes are expected to take a junction path's bends with,
/// m/s² (a driver reading the road ahead keeps to about this).
const THROUGH_LATERAL_MPS2: f64 = 2.0;
/// Deceleration foes are expected to slow for a junction path's bends with, m/s².
const THROUGH_DECEL_MPS2: f64 = 1.5;

/// The speed vehicles take through a junction path: its speed limit, or less where its
/// sharpest bend asks for less at a comfortable lateral acceleration, m/s.
fn through_mps(network: &RoadNetwork, path: RoadId) -> f64 {
    network.get(path).map_or(f64::INFINITY, |g| {
        let sharpest = g
            .curvature_bins()
            .iter()
            .fold(0.0_f64, |m, &k| m.max(f64::from(k.abs())));
        let bend = (THROUGH_LATERAL_MPS2 / sharpest.max(1e-6)).sqrt();
        (g.speed_limit_kmh() / 3.6).min(bend)
    })
}

/// When a foe `to_line_m` from the line of its path, at `speed_mps`, reaches a point
/// `inside_m` past it, going through the path at `through_mps`: a slower one speeds up to that
/// speed (from a stop, or out of a bend before it), a faster one slows to it by the line.
fn expected_arrival_s(to_line_m: f64, inside_m: f64, speed_mps: f32, through_mps: f64) -> f64 {
    let v = f64::from(speed_mps.max(0.0));
    let d = (to_line_m + inside_m).max(0.0);
    if v < through_mps {
        let a = STARTING_ACCEL_MPS2;
        let d_up = (through_mps * through_mps - v * v) / (2.0 * a);
        if d <= d_up {
            (-v + (v * v + 2.0 * a * d).sqrt()) / a
        } else {
            (through_mps - v) / a + (d - d_up) / through_mps
        }
    } else {
        // At its speed until it must brake, braking to the path's speed by the line, then
        // through at that speed.
        let b = THROUGH_DECEL_MPS2;
        let to_line = to_line_m.max(0.0);
        let d_brake = ((v * v - through_mps * through_mps) / (2.0 * b)).min(to_line);
        let v_line = (v * v - 2.0 * b * d_brake).max(0.0).sqrt();
        (to_line - d_brake) / v + (v - v_line) / b + (d - to_line) / v_line.max(0.1)
    }
}

/// Where a vehicle held where it is waits: at the line before entering, short of its next
/// conflict inside (front bumper, on its road).
fn held_stop(network: &RoadNetwork, track: &RoadTrack, a: &Approach) -> f64 {
    if !a.inside {
        let back = network.junctions()[a.junction].paths[a.path].hold_back_m;
        return network.get(track.road).map_or(0.0, |g| g.length_m()) - STOP_LINE_MARGIN_M - back;
    }
    network.junctions()[a.junction].paths[a.path]
        .conflicts
        .iter()
        .filter(|c| still_short_of(a, c))
        .map(|c| waiting_place(a, c))
        .fold(f64::INFINITY, f64::min)
}

/// Whether a vehicle's centre is short of conflict `c` (or only a little past it, an
/// overshoot that does not entitle it to go on).
fn still_short_of(a: &Approach, c: &Conflict) -> bool {
    -a.to_line_m - a.half_m < c.at_m + WAIT_TOLERANCE_M
}

/// Where on its path a vehicle waits short of conflict `c` (its front bumper), m.
fn waiting_place(a: &Approach, c: &Conflict) -> f64 {
    c.at_m + a.half_m - INSIDE_STOP_M
}

/// Whether a vehicle at `speed_mps` with `left_m` to a stop point is past the point of no
/// return: going, and unable to stop there without braking harder than at amber.
fn committed(speed_mps: f32, left_m: f64) -> bool {
    let need = f64::from(speed_mps).powi(2) / (2.0 * left_m.max(0.01));
    speed_mps > COMMITTED_MPS && left_m > 0.0 && need > f64::from(AMBER_DECEL_MPS2)
}

/// Whether a vehicle at `speed_mps` can stop within `left_m` braking no harder than for a
/// stop line.
fn can_stop(speed_mps: f32, left_m: f64) -> bool {
    left_m >= 0.0 && f64::from(speed_mps).powi(2) <= 2.0 * f64::from(STOP_LINE_DECEL_MPS2) * left_m
}

/// The nobody-waits-forever rule: since when it has been held here with nothing in its way
/// moving, and whether that is long enough, with no signal to wait for, to go anyway.
fn deadlock_rule(
    gate: &JunctionGate,
    path_road: Option<RoadId>,
    hold: bool,
    waiting_for_moving: bool,
    signal: bool,
    tick: u64,
) -> (Option<u64>, bool) {
    if !hold {
        return (None, false);
    }
    // The clock runs while nothing in its way moves: moving traffic starts it again.
    let since = if gate.path == path_road && !waiting_for_moving {
        gate.held_since.unwrap_or(tick)
    } else {
        tick
    };
    let broken = !waiting_for_moving && !signal && (tick - since) as f64 * DT_S > DEADLOCK_S;
    (Some(since), broken)
}

/// Where on its path (front bumper, m) a vehicle on or entering it must wait, short of the
/// first conflict ahead whose area a vehicle occupies or whose stream it gives way to leaves no
/// gap; `INFINITY` when it may go on. With whether what holds it is moving.
fn wait_inside(scene: &Scene, a: &Approach, critical_gap_s: f64, released: bool) -> (f64, bool) {
    let junction = &scene.network.junctions()[a.junction];
    // The stop is the front bumper's.
    let front = -a.to_line_m;
    let mut stop = f64::INFINITY;
    let mut occupied_stop = f64::INFINITY;
    let mut by_moving = false;
    // A car that has overshot its waiting place a little is still waiting there.
    for c in junction.paths[a.path]
        .conflicts
        .iter()
        .filter(|c| still_short_of(a, c))
    {
        let here = waiting_place(a, c);
        if scene.foes_on_path(a, c).0 {
            occupied_stop = occupied_stop.min(here);
            by_moving = true;
        }
        // Past the start of the conflict area it is in the streams' way: they wait for it
        // (they see the area occupied), so it goes on.
        if released || -a.to_line_m - a.half_m > c.at_m {
            continue;
        }
        let b = scene.gives_way_now(a, std::iter::once(c), critical_gap_s, None);
        let clearing = scene.foe_clearing(a, c);
        if b.hold || clearing {
            stop = stop.min(here);
            by_moving |= b.by_moving || clearing;
        }
    }
    // Past the point of no return for a stream's gap it goes on (stopping would leave it in
    // the way); a body in the conflict area stops it whatever it costs.
    // A car already past its waiting place (held only now, while going) is judged against the
    // area's start itself, the stop's `INSIDE_STOP_M` further on: if it cannot stop short of
    // that, braking would leave it creeping into the area in the stream's way.
    let left = stop - front;
    let left = if left > 0.0 {
        left
    } else {
        left + INSIDE_STOP_M
    };
    if stop.is_finite() && !a.held && committed(a.speed_mps, left) {
        stop = f64::INFINITY;
    }
    (
        keep_clear(
            a,
            &junction.paths[a.path].conflicts,
            stop.min(occupied_stop),
        ),
        by_moving,
    )
}

/// Where a vehicle that must stop at `stop` (front bumper, m) stops instead so that it does not
/// stand in or at the edge of an earlier conflict area: short of that conflict, while it can
/// still stop there. A body at the very start of an area is where a car passing a little off
/// its centre line touches it, and one standing in it blocks that stream for as long as it
/// waits for another.
fn keep_clear(a: &Approach, conflicts: &[Conflict], mut stop: f64) -> f64 {
    if !stop.is_finite() {
        return stop;
    }
    let front = -a.to_line_m;
    for _ in 0..conflicts.len() {
        let centre = stop - a.half_m;
        let earlier = conflicts
            .iter()
            .filter(|c| still_short_of(a, c))
            .filter(|c| centre > c.at_m - WAIT_TOLERANCE_M && centre < c.clear_m)
            .map(|c| waiting_place(a, c))
            .filter(|&place| place < stop && can_stop(a.speed_mps, place - front))
            .fold(f64::INFINITY, f64::min);
        if !earlier.is_finite() {
            break;
        }
        stop = earlier;
    }
    stop
}

/// The decision for a vehicle on its junction path: where it must stop, short of the next
/// conflict it may not cross yet.
fn decide_inside(
    scene: &Scene,
    a: &Approach,
    gate: &JunctionGate,
    critical_gap_s: f64,
    tick: u64,
) -> (JunctionGate, bool) {
    let path_road = scene.network.path_road(a.junction, a.path);
    let released = gate.released && gate.path == path_road;
    let (stop, by_moving) = wait_inside(scene, a, critical_gap_s, released);
    let hold = stop.is_finite();
    let signal = scene.signals[a.junction].is_some();
    let (held_since, deadlock) = deadlock_rule(gate, path_road, hold, by_moving, signal, tick);
    (
        JunctionGate {
            // The gate's stop is the front bumper's, on the path.
            stop_at_m: (hold && !deadlock).then_some(stop),
            path: path_road,
            stopped_tick: None,
            held_since: if deadlock { None } else { held_since },
            inside: true,
            released: released || deadlock,
        },
        deadlock,
    )
}

/// The decision for a vehicle approaching the line of its junction path.
#[expect(
    clippy::too_many_arguments,
    reason = "the tick's shared scene and this vehicle's own state"
)]
fn decide_at_line(
    scene: &Scene,
    a: &Approach,
    track: &RoadTrack,
    gate: &JunctionGate,
    (critical_gap_s, follow_up_s): (f64, f64),
    stats: &JunctionStats,
    tick: u64,
    seen: &mut Vec<Seen>,
) -> (JunctionGate, bool) {
    let network = scene.network;
    let junction = &network.junctions()[a.junction];
    let path = &junction.paths[a.path];
    let states = scene.signals[a.junction].as_deref();
    let path_road = network.path_road(a.junction, a.path);
    let stopped_tick = if gate.path == path_road {
        gate.stopped_tick
    } else {
        None
    };
    // At the line: as near it as it waits (short of it where another lane's path passes close).
    let at_line = a.to_line_m - path.hold_back_m < AT_LINE_M;
    let stopped_now = a.speed_mps < STOPPED_MPS && at_line;
    let stopped_tick = stopped_tick.or(stopped_now.then_some(tick));
    // Let go by the deadlock rule: it goes, the others wait for it.
    let released = gate.released && gate.path == path_road;
    let line = network.get(track.road).map_or(0.0, |g| g.length_m()) - STOP_LINE_MARGIN_M;
    // Its front is over the line already (it went at amber, or crept): it can no longer stop
    // before it, so it goes in and gives way inside, as a car on the path does.
    if a.to_line_m < -STOP_LINE_MARGIN_M {
        let (stop, _) = wait_inside(scene, a, critical_gap_s, released);
        return (
            JunctionGate {
                stop_at_m: stop.is_finite().then_some(line + STOP_LINE_MARGIN_M + stop),
                path: path_road,
                stopped_tick,
                held_since: None,
                inside: false,
                released,
            },
            false,
        );
    }
    let own = states.map(|s| s.get(a.path).copied().unwrap_or(SignalState::Red));
    let mut hold = false;
    // The signal.
    match own {
        Some(SignalState::Red) => hold = true,
        Some(SignalState::Amber) => {
            // Stop if it can do so comfortably where it waits (or was already stopping); else
            // go on. Short of the line but past where it waits (a tight corner's hold-back), it
            // would stand where another lane's turning cars swing by.
            let wait_m = a.to_line_m - path.hold_back_m;
            let need = f64::from(a.speed_mps).powi(2) / (2.0 * wait_m.max(0.1));
            hold = a.held || need <= f64::from(AMBER_DECEL_MPS2);
        }
        _ => {}
    }
    let signal_hold = hold;
    // A stop sign or an all-way stop: a full stop at the line first.
    if !hold && junction.must_stop(a.path) && stopped_tick.is_none() {
        hold = true;
    }
    // Room to leave: a slow car at the start of the exit lane leaves it no room for its own
    // length there (it would stop in the junction, in the way).
    let mut no_room = false;
    if !hold {
        let (to_road, to_lane) = path.to;
        // Its own length, and that of the cars in the junction bound for the same lane.
        let bound: f64 = junction
            .paths
            .iter()
            .enumerate()
            .filter(|(_, p)| p.to == path.to)
            .filter_map(|(k, _)| network.path_road(a.junction, k))
            .flat_map(|p| scene.index.lane(p, 0))
            .map(|e| f64::from(e.length_m) + QUEUE_GAP_M)
            .sum();
        let need = 2.0 * a.half_m + QUEUE_GAP_M + bound;
        seen.clear();
        let reach = need + JOINING_QUEUE_M + 10.0;
        scene
            .index
            .within(RoadId(to_road), to_lane, 0.0, 0.0, reach, None, seen);
        // Standing, or slow and closing on a standing car (joining a queue): it will not
        // move on out of the way. A slow car in free flow (round a tight curve) will.
        let standing = |s: &Seen| s.entry.speed_mps < QUEUED_MPS;
        no_room = seen.iter().any(|s| {
            let joining = s.entry.speed_mps < EXIT_MOVING_MPS
                && seen.iter().any(|o| {
                    o.gap_m > s.gap_m && o.gap_m - s.gap_m < JOINING_QUEUE_M && standing(o)
                });
            (standing(s) || joining) && s.gap_m - 0.5 * f64::from(s.entry.length_m) < need
        });
        hold = no_room;
    }
    // Nobody drives into a vehicle standing in a conflict area ahead, whoever has the right of
    // way.
    let mut occupied = false;
    if !hold {
        occupied = path
            .conflicts
            .iter()
            .any(|c| scene.foes_on_path_at_line(a, c));
        hold = occupied;
    }
    let mut blocked = Blocked::default();
    // Where inside it must wait, for a permitted movement (front bumper, on the path).
    let mut inside_stop = None;
    if !hold {
        if own == Some(SignalState::GreenYield) {
            // A permitted movement enters and waits inside at its conflict, one car at a time:
            // the path must be clear of a car still standing on it. Where it will wait is
            // known before it enters, so it arrives there at a speed it can stop from.
            if let Some(p) = path_road {
                let len = network.get(p).map_or(0.0, |g| g.length_m());
                hold = scene
                    .index
                    .lane(p, 0)
                    .iter()
                    .any(|e| e.s_m <= len && e.speed_mps < 2.0);
            }
            if !hold {
                let (stop, _) = wait_inside(scene, a, critical_gap_s, released);
                inside_stop = stop.is_finite().then_some(stop);
            }
        } else if !released {
            let all_way = junction.must_stop(a.path).then_some(stopped_tick);
            blocked = scene.gives_way_now(a, path.conflicts.iter(), critical_gap_s, all_way);
            hold = blocked.hold;
        }
    }
    // Through a gap it gives way for, it follows the car before it on its path no sooner
    // than its follow-up time.
    if !hold
        && blocked.yields
        && path_road.is_some_and(|p| {
            stats.last_entry.get(&p).is_some_and(|&t| {
                // It enters (its centre crosses the line, as the last one's did) that much
                // later: it need not stop to wait.
                let d = a.to_line_m.max(0.0) + a.half_m;
                let v = f64::from(a.speed_mps.max(0.0));
                let at_line =
                    (-v + (v * v + 2.0 * OWN_START_ACCEL_MPS2 * d).sqrt()) / OWN_START_ACCEL_MPS2;
                (tick - t) as f64 * DT_S + at_line < follow_up_s
            })
        })
    {
        hold = true;
    }
    // Past the point of no return: a car that was going and can no longer stop before the
    // line without braking harder than at amber goes on (stopping would leave it across
    // the line, in the way).
    if hold && !signal_hold && !occupied && !a.held && committed(a.speed_mps, a.to_line_m) {
        hold = false;
    }
    // Waiting for room on the exit is waiting for the traffic beyond, not a deadlock.
    let (held_since, deadlock) = deadlock_rule(
        gate,
        path_road,
        hold,
        blocked.by_moving || occupied || no_room,
        states.is_some(),
        tick,
    );
    let deadlock = deadlock && at_line;
    (
        JunctionGate {
            stop_at_m: if hold && !deadlock {
                Some(line - path.hold_back_m)
            } else {
                inside_stop.map(|stop| line + STOP_LINE_MARGIN_M + stop)
            },
            path: path_road,
            stopped_tick,
            held_since: if deadlock { None } else { held_since },
            inside: false,
            released: released || deadlock,
        },
        deadlock,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn approach_at(centre_m: f64, speed_mps: f32) -> Approach {
        let half_m = 2.3;
        Approach {
            entity: Entity::PLACEHOLDER,
            junction: 0,
            path: 0,
            to_line_m: -(centre_m + half_m),
            half_m,
            speed_mps,
            held: true,
            inside: true,
            stopped_tick: None,
            blocked: false,
        }
    }

    fn conflict(at_m: f64, clear_m: f64) -> Conflict {
        Conflict {
            other: 1,
            merge: false,
            at_m,
            other_at_m: 0.0,
            clear_m,
            other_clear_m: 0.0,
        }
    }

    #[test]
    fn a_car_waiting_inside_keeps_clear_of_an_earlier_conflict_area_while_it_can() {
        // It waits for the conflict at 3.6 m, 1.5 m short of it (centre at 2.1 m): at the very
        // edge of the one at 2.24 m, so it waits short of that one instead (centre 0.74 m).
        let earlier = conflict(2.24, 11.7);
        let later = conflict(3.6, 9.0);
        let conflicts = [earlier, later];
        let a = approach_at(-1.0, 0.0);
        let wait_later = waiting_place(&a, &later);
        let kept = keep_clear(&a, &conflicts, wait_later);
        assert!((kept - waiting_place(&a, &earlier)).abs() < 1e-12);
        assert!(kept - a.half_m < earlier.at_m - WAIT_TOLERANCE_M);
        // Too fast to stop short of it comfortably: it keeps the stop it had.
        let fast = approach_at(-1.0, 6.0);
        assert_eq!(keep_clear(&fast, &conflicts, wait_later), wait_later);
        // Already past where it would wait short of it: likewise.
        let past = approach_at(1.2, 0.0);
        assert_eq!(keep_clear(&past, &conflicts, wait_later), wait_later);
        // Waiting well clear of the earlier area (short of it, or past its end): no change.
        let clear = [conflict(6.0, 11.7), later];
        assert_eq!(keep_clear(&a, &clear, wait_later), wait_later);
        let behind = [conflict(-3.0, 1.0), later];
        assert_eq!(keep_clear(&a, &behind, wait_later), wait_later);
        // Free to go: nothing to move.
        assert_eq!(keep_clear(&a, &conflicts, f64::INFINITY), f64::INFINITY);
    }

    #[test]
    fn keeping_clear_steps_back_past_every_area_its_wait_would_reach() {
        // The place short of the second area is at the edge of the first: back past both.
        let first = conflict(0.9, 8.0);
        let second = conflict(2.24, 11.7);
        let later = conflict(3.6, 9.0);
        let a = approach_at(-3.0, 0.0);
        let kept = keep_clear(&a, &[later, second, first], waiting_place(&a, &later));
        assert!((kept - waiting_place(&a, &first)).abs() < 1e-12);
    }

    #[test]
    fn a_foe_is_expected_to_take_its_path_at_the_speed_the_path_allows() {
        // At the path's speed already: distance over speed.
        assert!((expected_arrival_s(40.0, 10.0, 10.0, 10.0) - 5.0).abs() < 1e-9);
        // Faster: at its speed until it must brake (at 1.5 m/s²) to the path's 6 m/s by the
        // line, then through at 6 m/s: 40 m − 21.33 m at 10 m/s, 2.67 s braking, 10 m at 6 m/s.
        let braking = (100.0 - 36.0) / 3.0;
        let t = (40.0 - braking) / 10.0 + 4.0 / 1.5 + 10.0 / 6.0;
        assert!((expected_arrival_s(40.0, 10.0, 10.0, 6.0) - t).abs() < 1e-9);
        // Slower (out of a bend before it, or standing): speeds up at 2 m/s² to the path's
        // speed, no further.
        let up = (36.0 - 4.0) / 4.0;
        let t = (6.0 - 2.0) / 2.0 + (30.0 - up) / 6.0;
        assert!((expected_arrival_s(20.0, 10.0, 2.0, 6.0) - t).abs() < 1e-9);
        // A short way from a stop, still speeding up when it gets there.
        assert!((expected_arrival_s(0.0, 4.0, 0.0, 6.0) - 2.0).abs() < 1e-9);
    }

    /// The corner of a grid of one-lane streets, as netgenerate draws it: `n` turns left into
    /// `e` round the corner on a 4.8 m radius (path 0); `w` turns right into `up` inside it on
    /// 1.6 m (path 1), which a sedan can only drive wide, across the end of `n`. Both are
    /// major: the right turn gives way to the left one. With each path's speed.
    fn grid_corner() -> (RoadNetwork, Vec<Vec<f64>>) {
        use flockway_road::Control;
        two_paths(
            [
                ("n", [-1.6, 100.0], [-1.6, 3.2]),
                ("e", [3.2, -1.6], [100.0, -1.6]),
                ("w", [100.0, 1.6], [3.2, 1.6]),
                ("up", [1.6, 3.2], [1.6, 100.0]),
            ],
            [("n", "e"), ("w", "up")],
            Control::Priority {
                major: vec!["n".into(), "w".into()],
                stop: false,
            },
            None,
        )
    }

    /// A junction `j` of four one-lane roads `(name, start, end)` and two connections (paths 0
    /// and 1) under `control`, with each path's speed.
    fn two_paths(
        roads: [(&str, [f64; 2], [f64; 2]); 4],
        connections: [(&str, &str); 2],
        control: flockway_road::Control,
        signal: Option<flockway_road::SignalProgram>,
    ) -> (RoadNetwork, Vec<Vec<f64>>) {
        use flockway_road::{ConnectionSpec, JunctionSpec, RoadSpec};
        use glam::DVec3;
        let roads = roads.map(|(name, a, b)| {
            RoadSpec::through(
                name,
                1,
                50.0,
                &[DVec3::new(a[0], a[1], 0.0), DVec3::new(b[0], b[1], 0.0)],
            )
        });
        let junction = JunctionSpec {
            name: "j".into(),
            control,
            connections: connections
                .iter()
                .map(|&(from, to)| ConnectionSpec {
                    from: from.into(),
                    from_lane: 0,
                    to: to.into(),
                    to_lane: 0,
                })
                .collect(),
            signal,
        };
        let network =
            RoadNetwork::build_with(&roads, std::slice::from_ref(&junction)).expect("a junction");
        let through = vec![
            (0..2)
                .map(|k| through_mps(&network, network.path_road(0, k).expect("a path")))
                .collect(),
        ];
        (network, through)
    }

    /// The conflict of path `k` of the network's junction with path `other`.
    fn conflict_of(network: &RoadNetwork, k: usize, other: usize) -> Conflict {
        *network.junctions()[0].paths[k]
            .conflicts
            .iter()
            .find(|c| c.other == other)
            .expect("the paths conflict")
    }

    /// A car of [`grid_corner`] approaching path `path`, not yet on it.
    fn corner_approach(path: usize, to_line_m: f64, speed_mps: f32, held: bool) -> Approach {
        Approach {
            entity: Entity::from_raw_u32(path as u32 + 1).expect("an entity"),
            junction: 0,
            path,
            to_line_m,
            half_m: 2.3,
            speed_mps,
            held,
            inside: false,
            stopped_tick: None,
            blocked: false,
        }
    }

    /// No car on any path, and no signal: a scene of [`grid_corner`] with only `approaches`.
    fn corner_scene<'a>(
        network: &'a RoadNetwork,
        approaches: &'a [Approach],
        through: &'a [Vec<f64>],
    ) -> Scene<'a> {
        const NO_SIGNAL: &[Option<Vec<SignalState>>] = &[None];
        static EMPTY: std::sync::LazyLock<LaneIndex> = std::sync::LazyLock::new(LaneIndex::default);
        Scene {
            network,
            index: &EMPTY,
            approaches,
            signals: NO_SIGNAL,
            through,
        }
    }

    #[test]
    fn a_car_standing_before_its_line_in_a_wide_turns_sweep_holds_the_turn_back() {
        // The left-turner from `n` has stopped at its line, where the right turn from `w`
        // runs wide: the right-turner waits, whoever has the right of way. Stopped at its
        // hold-back place instead, it is clear of the sweep and in nobody's way.
        let (network, through) = grid_corner();
        let corner = &network.junctions()[0];
        let turner = corner_approach(1, 0.2, 0.0, true);
        let occupied = |to_line_m: f64| {
            let approaches = [turner, corner_approach(0, to_line_m, 0.0, true)];
            let scene = corner_scene(&network, &approaches, &through);
            scene.foes_on_path_at_line(&turner, &conflict_of(&network, 1, 0))
        };
        let hold_back = corner.paths[0].hold_back_m;
        assert!(hold_back > 1.0, "{hold_back}");
        assert!(occupied(0.2));
        assert!(!occupied(hold_back + 0.5));
    }

    #[test]
    fn a_car_held_only_once_past_its_waiting_place_goes_on_if_it_cannot_stop_short_of_the_area() {
        // The right-turner is on its path, just past where it would wait short of the left
        // turn's area, when a left-turner it gives way to comes within its gap. Slow, or held
        // already, it stops short of the area; going at 4 m/s it cannot (5.7 m/s² over the
        // 1.4 m left), and braking would leave it creeping into the area as the foe arrives:
        // it goes on, and the foe sees it in the area.
        let (network, through) = grid_corner();
        let c = conflict_of(&network, 1, 0);
        let stop = |speed_mps: f32, held: bool| {
            let centre = c.at_m - INSIDE_STOP_M + 0.1;
            let turner = Approach {
                to_line_m: -(centre + 2.3),
                inside: true,
                ..corner_approach(1, 0.0, speed_mps, held)
            };
            let approaches = [turner, corner_approach(0, 12.0, 8.0, false)];
            let scene = corner_scene(&network, &approaches, &through);
            wait_inside(&scene, &turner, 4.5, false).0
        };
        assert!(stop(2.5, false).is_finite());
        assert!(stop(4.0, true).is_finite());
        assert_eq!(stop(4.0, false), f64::INFINITY);
    }

    /// A signalised crossing of one-lane streets: `w` straight on into `e_out` (path 0), and
    /// `e` turning left across it into `s_out` (path 1, a permitted turn). With each path's
    /// speed.
    fn permitted_left() -> (RoadNetwork, Vec<Vec<f64>>) {
        use flockway_road::{Control, Phase, SignalProgram};
        let phase = |duration_s: f64, state: &str| Phase {
            duration_s,
            state: state.into(),
        };
        two_paths(
            [
                ("w", [-100.0, -1.6], [-8.0, -1.6]),
                ("e_out", [8.0, -1.6], [100.0, -1.6]),
                ("e", [100.0, 1.6], [8.0, 1.6]),
                ("s_out", [-1.6, -8.0], [-1.6, -100.0]),
            ],
            [("w", "e_out"), ("e", "s_out")],
            Control::Signal,
            Some(SignalProgram {
                offset_s: 0.0,
                phases: vec![phase(30.0, "Gg"), phase(3.0, "yy"), phase(30.0, "rr")],
            }),
        )
    }

    #[test]
    fn a_car_waiting_inside_to_turn_lets_a_car_going_on_at_amber_clear_first() {
        // The left-turner waits inside, short of the straight path, when the straight on's
        // green ends: a car too near its line to stop at amber comes through all the same,
        // and the turner waits for it though the signals no longer rank it first. One that
        // stops (held, or far enough back to stop comfortably) does not hold it.
        let (network, through) = permitted_left();
        let c = conflict_of(&network, 1, 0);
        let turner = Approach {
            path: 1,
            ..approach_at(c.at_m - 3.0, 0.0)
        };
        let stop = |state: SignalState, to_line_m: f64, held: bool| {
            let foe = Approach {
                entity: Entity::from_raw_u32(1).expect("an entity"),
                path: 0,
                to_line_m,
                speed_mps: 12.0,
                held,
                inside: false,
                ..turner
            };
            let approaches = [turner, foe];
            let signals = [Some(vec![state, SignalState::GreenYield])];
            static EMPTY: std::sync::LazyLock<LaneIndex> =
                std::sync::LazyLock::new(LaneIndex::default);
            let scene = Scene {
                network: &network,
                index: &EMPTY,
                approaches: &approaches,
                signals: &signals,
                through: &through,
            };
            wait_inside(&scene, &turner, 4.5, false).0
        };
        assert!(stop(SignalState::Amber, 4.0, false).is_finite());
        assert_eq!(stop(SignalState::Amber, 4.0, true), f64::INFINITY);
        assert_eq!(stop(SignalState::Amber, 40.0, false), f64::INFINITY);
        assert_eq!(stop(SignalState::Red, 4.0, false), f64::INFINITY);
    }

    #[test]
    fn a_junction_path_is_taken_at_its_limit_or_its_bends_comfortable_speed() {
        use flockway_road::{ConnectionSpec, Control, JunctionSpec, RoadSpec};
        use glam::DVec3;
        // A straight on and a right turn of about 10 m radius, under a 50 km/h limit.
        let w = RoadSpec::through(
            "w",
            1,
            50.0,
            &[DVec3::new(-100.0, 0.0, 0.0), DVec3::new(-10.0, 0.0, 0.0)],
        );
        let e = RoadSpec::through(
            "e",
            1,
            50.0,
            &[DVec3::new(10.0, 0.0, 0.0), DVec3::new(100.0, 0.0, 0.0)],
        );
        let s = RoadSpec::through(
            "s",
            1,
            50.0,
            &[DVec3::new(0.0, -10.0, 0.0), DVec3::new(0.0, -100.0, 0.0)],
        );
        let from_w = |to: &str| ConnectionSpec {
            from: "w".into(),
            from_lane: 0,
            to: to.into(),
            to_lane: 0,
        };
        let junction = JunctionSpec {
            name: "j".into(),
            control: Control::RightBeforeLeft,
            connections: vec![from_w("e"), from_w("s")],
            signal: None,
        };
        let network = RoadNetwork::build_with(&[w, e, s], std::slice::from_ref(&junction))
            .expect("a junction");
        let straight = through_mps(&network, network.id("j#0").expect("straight"));
        let right = through_mps(&network, network.id("j#1").expect("right"));
        assert!((straight - 50.0 / 3.6).abs() < 1e-9, "{straight}");
        // √(2 m/s² × ~10 m) ≈ 4.5 m/s, well under the limit.
        assert!(right > 3.5 && right < 5.5, "{right}");
    }
}

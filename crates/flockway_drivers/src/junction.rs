//! Right of way at junctions: before the drivers decide, every vehicle approaching a junction
//! learns whether it may enter its path or must stop at the line — by the signal, by the
//! priority rule and a gap in the conflicting streams, by the order of arrival at an all-way
//! stop — and nobody enters a path whose exit has no room. The shared controller holds a held
//! vehicle's speed to what stops it at the line, whatever its driver wants.

use crate::perception::{LaneIndex, Seen};
use bevy_ecs::prelude::*;
use flockway_core::{DT_S, SimClock};
use flockway_road::{RoadId, RoadNetwork, SignalState};
use flockway_vehicle::{Motion, RoadTrack, VehicleModel};
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

/// What the junction ahead lets a vehicle do; decided every tick before the drivers.
#[derive(Component, Debug, Clone, Copy, Default, PartialEq)]
pub struct JunctionGate {
    /// Where on its road its front bumper must stop, m; `None`: go.
    pub stop_at_m: Option<f64>,
    /// The junction path it is approaching.
    pub path: Option<RoadId>,
    /// The tick it came to a stop at the line, if it has (stop signs, all-way stops).
    pub stopped_tick: Option<u64>,
    /// The tick since which it has been held at the line, if it is.
    pub held_since: Option<u64>,
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
    /// Deadlocks broken: vehicles that went after waiting [`DEADLOCK_S`] with nothing moving.
    pub deadlocks: u64,
    /// Per junction path: the tick the last vehicle entered it (for the follow-up time).
    pub last_entry: BTreeMap<RoadId, u64>,
}

/// One vehicle approaching a junction path this tick.
#[derive(Debug, Clone, Copy)]
struct Approach {
    entity: Entity,
    junction: usize,
    path: usize,
    /// Front bumper to the line, m.
    to_line_m: f64,
    speed_mps: f32,
    /// Held at the line on the tick before.
    held: bool,
}

/// Decides every approaching vehicle's [`JunctionGate`].
#[allow(clippy::type_complexity)]
pub fn gate_junctions(
    network: Res<RoadNetwork>,
    index: Res<LaneIndex>,
    clock: Res<SimClock>,
    mut stats: ResMut<JunctionStats>,
    mut vehicles: Query<(
        Entity,
        &RoadTrack,
        &Motion,
        &VehicleModel,
        &mut JunctionGate,
    )>,
    gaps: Query<&GapAcceptance>,
) {
    if network.junctions().is_empty() {
        return;
    }
    let tick = clock.tick().0;
    let t_s = clock.seconds();
    let signals: Vec<Option<Vec<SignalState>>> = network
        .junctions()
        .iter()
        .map(|j| j.signal_at(t_s))
        .collect();
    // Who approaches which path (in the query's order, which the world fixes): by its route's
    // next road, or where its lane leads for a car that follows the links.
    let mut approaches: Vec<Approach> = Vec::new();
    for (entity, track, motion, model, gate) in &vehicles {
        let half = 0.5 * f64::from(model.0.params.chassis.length_m);
        let Some(ahead) =
            network.junction_ahead(track.road, track.lane, track.s_m, track.next_road, half)
        else {
            continue;
        };
        let (j, k, to_line) = (ahead.junction, ahead.path, ahead.to_line_m);
        let v = motion.forward_mps.max(0.0);
        // Near enough to be stopped at the line, or to be in the gap a yielding driver looks
        // for.
        let horizon = (APPROACH_M + f64::from(v * v / (2.0 * STOP_LINE_DECEL_MPS2)))
            .max(f64::from(v) * FOE_HORIZON_S);
        if to_line < horizon {
            approaches.push(Approach {
                entity,
                junction: j,
                path: k,
                to_line_m: to_line,
                speed_mps: v,
                held: gate.stop_at_m.is_some(),
            });
        }
    }
    let mut seen: Vec<Seen> = Vec::new();
    let mut decided: Vec<(Entity, JunctionGate, bool)> = Vec::with_capacity(approaches.len());
    for a in &approaches {
        let junction = &network.junctions()[a.junction];
        let path = &junction.paths[a.path];
        let states = signals[a.junction].as_deref();
        let Ok((_, track, _, _, gate)) = vehicles.get(a.entity) else {
            continue;
        };
        let path_road = network.path_road(a.junction, a.path);
        let stopped_tick = if gate.path == path_road {
            gate.stopped_tick
        } else {
            None
        };
        let stopped_now = a.speed_mps < STOPPED_MPS && a.to_line_m < AT_LINE_M;
        let stopped_tick = stopped_tick.or(stopped_now.then_some(tick));
        let (critical_gap_s, follow_up_s) = gaps
            .get(a.entity)
            .map_or((CRITICAL_GAP_S, FOLLOW_UP_S), |g| {
                (f64::from(g.critical_gap_s), f64::from(g.follow_up_s))
            });
        let mut hold = false;
        // The signal.
        if let Some(states) = states {
            match states.get(a.path).copied().unwrap_or(SignalState::Red) {
                SignalState::Red => hold = true,
                SignalState::Amber => {
                    // Stop if it can do so comfortably (or was already stopping); else go on.
                    let need = f64::from(a.speed_mps).powi(2) / (2.0 * a.to_line_m.max(0.1));
                    hold = a.held || need <= f64::from(AMBER_DECEL_MPS2);
                }
                SignalState::Green | SignalState::GreenYield => {}
            }
        }
        let signal_hold = hold;
        // A stop sign or an all-way stop: a full stop at the line first.
        if !hold && junction.must_stop(a.path) && stopped_tick.is_none() {
            hold = true;
        }
        // Room to leave: no queue at the start of the exit lane.
        if !hold {
            let (to_road, to_lane) = path.to;
            seen.clear();
            index.within(RoadId(to_road), to_lane, 0.0, 0.0, 12.0, None, &mut seen);
            if seen.iter().any(|s| s.entry.speed_mps < 2.0) {
                hold = true;
            }
        }
        // Right of way: the conflicting streams it gives way to must leave it a gap.
        let mut blocked_by_moving = false;
        let mut yields = false;
        if !hold {
            for c in &path.conflicts {
                if !junction.gives_way(a.path, c.other, states) {
                    continue;
                }
                let foe_state = states.map(|s| s.get(c.other).copied().unwrap_or(SignalState::Red));
                let Some(foe_road) = network.path_road(a.junction, c.other) else {
                    continue;
                };
                // Inside the junction, short of clearing the conflict.
                seen.clear();
                let foe_len = network.get(foe_road).map_or(0.0, |g| g.length_m());
                index.within(foe_road, 0, 0.0, 0.0, foe_len, None, &mut seen);
                if seen
                    .iter()
                    .any(|s| s.gap_m <= foe_len && s.gap_m < c.other_at_m + 6.0)
                {
                    hold = true;
                    blocked_by_moving = true;
                    break;
                }
                // A foe on red is not coming (one already inside was seen above).
                if matches!(foe_state, Some(SignalState::Red)) {
                    continue;
                }
                yields = true;
                // Approaching: any foe bound for that path that reaches the conflict sooner than
                // the critical gap, and is not itself held at its line.
                let under_all_way = junction.must_stop(a.path) && junction.must_stop(c.other);
                for f in approaches
                    .iter()
                    .filter(|f| f.junction == a.junction && f.path == c.other)
                {
                    if under_all_way {
                        // Order of arrival: the earlier stop goes first.
                        let foe_stop = vehicles
                            .get(f.entity)
                            .ok()
                            .and_then(|(_, _, _, _, g)| g.stopped_tick);
                        if foe_stop.is_some_and(|t| {
                            stopped_tick.is_none_or(|mine| (t, f.entity) < (mine, a.entity))
                        }) {
                            hold = true;
                        }
                        continue;
                    }
                    if f.held {
                        continue;
                    }
                    let eta = (f.to_line_m + c.other_at_m) / f64::from(f.speed_mps.max(0.5));
                    if eta < critical_gap_s {
                        hold = true;
                        blocked_by_moving |= f.speed_mps > STOPPED_MPS;
                    }
                }
                if hold {
                    break;
                }
            }
        }
        // Through a gap it gives way for, it follows the car before it on its path no sooner
        // than its follow-up time.
        if !hold
            && yields
            && path_road.is_some_and(|p| {
                stats
                    .last_entry
                    .get(&p)
                    .is_some_and(|&t| (tick - t) as f64 * DT_S < follow_up_s)
            })
        {
            hold = true;
        }
        // Past the point of no return: a car that was going and can no longer stop before the
        // line without braking harder than at amber goes on (stopping would leave it across
        // the line, in the way).
        let need = f64::from(a.speed_mps).powi(2) / (2.0 * a.to_line_m.max(0.01));
        if hold
            && !signal_hold
            && !a.held
            && a.speed_mps > COMMITTED_MPS
            && a.to_line_m > 0.0
            && need > f64::from(AMBER_DECEL_MPS2)
        {
            hold = false;
        }
        // Nobody waits forever: held at the line this long with nothing in its way moving.
        let held_since = if gate.path == path_road {
            gate.held_since.or(Some(tick))
        } else {
            Some(tick)
        };
        let mut deadlock = false;
        if hold
            && !blocked_by_moving
            && states.is_none()
            && held_since.is_some_and(|t| (tick - t) as f64 * DT_S > DEADLOCK_S)
            && a.to_line_m < AT_LINE_M
        {
            hold = false;
            deadlock = true;
        }
        // Held: at the line, or behind the car ahead of it in the queue there (a queue pressed
        // from behind would otherwise push its first car over the line).
        let line = network.get(track.road).map_or(0.0, |g| g.length_m()) - STOP_LINE_MARGIN_M;
        let queue = index
            .leader(
                track.road,
                track.lane,
                track.s_m,
                a.entity,
                line - track.s_m,
                None,
            )
            .filter(|l| track.s_m + l.gap_m < line + 5.0)
            .map_or(f64::INFINITY, |l| {
                track.s_m + l.gap_m - 0.5 * f64::from(l.entry.length_m) - QUEUE_GAP_M
            });
        decided.push((
            a.entity,
            JunctionGate {
                stop_at_m: hold.then_some(line.min(queue)),
                path: path_road,
                stopped_tick,
                held_since: if hold { held_since } else { None },
            },
            deadlock,
        ));
    }
    // Write the decisions (in the query's order, as they were made); a vehicle approaching no
    // junction is free.
    let mut d = decided.into_iter().peekable();
    for (entity, track, _, _, mut gate) in &mut vehicles {
        let (new, deadlock) = match d.next_if(|(e, _, _)| *e == entity) {
            Some((_, g, deadlock)) => (g, deadlock),
            None => (JunctionGate::default(), false),
        };
        // It was approaching this path and is on it now: it entered.
        if gate.path == Some(track.road) {
            stats.last_entry.insert(track.road, tick);
        }
        if *gate != new {
            *gate = new;
        }
        stats.deadlocks += u64::from(deadlock);
    }
}

//! What each junction measures over the run: vehicles through, their delay, the longest queue,
//! and at a signal the headway at which a queue discharges.

use crate::stats::TelemetrySettings;
use bevy_ecs::prelude::*;
use flockway_core::{DT_S, SimClock};
use flockway_drivers::{GapAcceptance, Signals};
use flockway_road::{RoadId, RoadNetwork, SignalState, Turn};
use flockway_vehicle::{Motion, RoadTrack, VehicleModel};
use std::collections::BTreeMap;

/// How far before a junction's line its delay and queues are measured, m.
pub const APPROACH_ZONE_M: f64 = 150.0;
/// Below this speed a car in the zone counts as queued, m/s.
pub const QUEUED_MPS: f32 = 2.0;
/// A queue's first vehicle stands at most this far from the line, m (front bumper).
pub const QUEUE_FRONT_M: f64 = 20.0;
/// A queued vehicle stands at most this far behind the one before it, m (bumper to bumper).
pub const QUEUE_GAP_M: f64 = 10.0;

/// A vehicle on a lane into a junction, as its queue is measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OnApproach {
    /// From its front bumper to the line, m.
    pub to_line_m: f64,
    /// Its length, m.
    pub length_m: f64,
    /// Its speed, m/s.
    pub speed_mps: f64,
}

/// The queue at the line of a lane whose vehicles come nearest the line first: how many, and
/// how far back its last one's rear bumper is, m. A queue is the vehicles standing or creeping
/// (below [`QUEUED_MPS`]) one behind the other from the line back: the first within
/// [`QUEUE_FRONT_M`] of it, each within [`QUEUE_GAP_M`] of the one before. A slow vehicle
/// farther back with free road before it (one just setting off from a standstill where it
/// entered the network) is not in the queue.
pub fn queue_at_line(sorted: impl IntoIterator<Item = OnApproach>) -> (u32, f64) {
    let mut count = 0;
    // Where the queue ends so far: the line, then its last vehicle's rear bumper.
    let mut rear_m = 0.0;
    for v in sorted {
        let allowed_m = if count == 0 {
            QUEUE_FRONT_M
        } else {
            QUEUE_GAP_M
        };
        if !(v.speed_mps < f64::from(QUEUED_MPS) && v.to_line_m - rear_m <= allowed_m) {
            break;
        }
        count += 1;
        rear_m = v.to_line_m + v.length_m;
    }
    (count, rear_m.max(0.0))
}
/// The first vehicles of a queue leave at longer headways while they get going; the discharge
/// headway is measured from this one on (the Highway Capacity Manual's convention).
pub const DISCHARGE_FROM: u32 = 5;

/// One junction's totals after the warm-up.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct JunctionTotals {
    /// Vehicles that entered it.
    pub entered: u64,
    /// Sum of their delays, s (over the vehicles whose approach was measured whole).
    pub delay_sum_s: f64,
    /// How many delays were summed.
    pub delays: u64,
    /// Longest queue seen, m.
    pub max_queue_m: f64,
    /// Sum of discharge headways, s.
    pub headway_sum_s: f64,
    /// How many headways were summed.
    pub headways: u64,
    /// Vehicles whose front crossed the line on red.
    pub red_entries: u64,
}

impl JunctionTotals {
    /// Mean delay, s; `None` before any vehicle went through.
    pub fn mean_delay_s(&self) -> Option<f64> {
        (self.delays > 0).then(|| self.delay_sum_s / self.delays as f64)
    }

    /// Mean discharge headway, s; `None` when no queue of five or more discharged.
    pub fn discharge_headway_s(&self) -> Option<f64> {
        (self.headways > 0).then(|| self.headway_sum_s / self.headways as f64)
    }
}

/// A vehicle on its way to a junction's line.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Approach {
    junction: usize,
    /// Road and lane it approaches on.
    lane: (RoadId, u32),
    /// Tick it entered the zone and its distance to the line then, m (`None`: it started
    /// inside the zone, so its delay is not measured).
    entered: Option<(u64, f64)>,
    /// Whether it has been queued in the zone.
    queued: bool,
}

/// Per approach lane: the last queued vehicle to cross, in which cycle, its place, and whether
/// it went straight on.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Discharge {
    tick: u64,
    cycle: i64,
    place: u32,
    straight: bool,
}

/// A vehicle this close to the line (front bumper) keeps its approach lane saturated: the lane
/// always has one ready to go, m.
pub const SATURATED_M: f64 = 25.0;

/// The windows capacity is measured over, in ticks `[from, to)` (the runner takes them from the
/// level's demand steps).
#[derive(Resource, Debug, Clone, Default, PartialEq)]
pub struct CapacityWindows(pub Vec<(u64, u64)>);

impl CapacityWindows {
    /// The window `tick` falls in.
    fn at(&self, tick: u64) -> Option<usize> {
        self.0.iter().position(|&(a, b)| (a..b).contains(&tick))
    }
}

/// One approach lane of a junction over one capacity window.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LaneWindow {
    /// Ticks with a vehicle within [`SATURATED_M`] of the line.
    pub saturated_ticks: u64,
    /// Vehicles from the lane that entered the junction.
    pub entries: u64,
    /// Sum of their critical gaps, s.
    pub critical_gap_sum_s: f64,
    /// Sum of their follow-up times, s.
    pub follow_up_sum_s: f64,
}

/// Every junction's measures, and what is needed to take them.
#[derive(Resource, Debug, Clone, Default, PartialEq)]
pub struct JunctionMeasures {
    /// Per junction, in the level's order.
    pub totals: Vec<JunctionTotals>,
    /// Per junction, approach lane and capacity window.
    pub lane_windows: BTreeMap<(usize, RoadId, u32, usize), LaneWindow>,
    /// Per junction, path and capacity window: vehicles that entered the path.
    pub path_windows: BTreeMap<(usize, usize, usize), u64>,
    approaching: BTreeMap<Entity, Approach>,
    discharge: BTreeMap<(RoadId, u32), Discharge>,
}

/// Follows every vehicle through the junctions: counts the ones entering, their delay from the
/// zone's start to the line, the queue in the zone, and queued vehicles discharging at a signal.
#[allow(clippy::type_complexity)]
pub fn measure_junctions(
    network: Res<RoadNetwork>,
    clock: Res<SimClock>,
    settings: Res<TelemetrySettings>,
    windows: Res<CapacityWindows>,
    signals: Res<Signals>,
    mut measures: ResMut<JunctionMeasures>,
    vehicles: Query<(
        Entity,
        &RoadTrack,
        &Motion,
        &VehicleModel,
        Option<&GapAcceptance>,
    )>,
) {
    let junctions = network.junctions();
    if junctions.is_empty() {
        return;
    }
    let measures = &mut *measures;
    measures
        .totals
        .resize_with(junctions.len(), JunctionTotals::default);
    let tick = clock.tick().0;
    let counting = tick >= settings.stats_from_tick;
    // Each vehicle in a zone (when counting): junction, approach road and lane, and where it is.
    let mut in_zone: Vec<(usize, RoadId, u32, OnApproach)> = Vec::new();
    let window = windows.at(tick);
    let mut saturated: Vec<(usize, RoadId, u32)> = Vec::new();
    for (entity, track, motion, model, gaps) in &vehicles {
        let half = 0.5 * f64::from(model.0.params.chassis.length_m);
        if let Some((j, k)) = network.junction_path(track.road) {
            // Inside: it crossed the line since the last tick, if it was approaching.
            let Some(a) = measures.approaching.remove(&entity) else {
                continue;
            };
            if a.junction != j {
                continue;
            }
            if let Some(w) = window {
                *measures.path_windows.entry((j, k, w)).or_default() += 1;
                let lane = measures
                    .lane_windows
                    .entry((j, a.lane.0, a.lane.1, w))
                    .or_default();
                lane.entries += 1;
                let (t_c, t_f) = GapAcceptance::seconds(gaps);
                lane.critical_gap_sum_s += t_c;
                lane.follow_up_sum_s += t_f;
            }
            if !counting {
                continue;
            }
            let totals = &mut measures.totals[j];
            totals.entered += 1;
            if let Some((t0, zone_m)) = a.entered {
                let limit = network
                    .get(a.lane.0)
                    .map_or(1.0, |g| g.speed_limit_kmh() / 3.6);
                totals.delay_sum_s += ((tick - t0) as f64 * DT_S - zone_m / limit).max(0.0);
                totals.delays += 1;
            }
            if let Some(signal) = signals.get(j) {
                let t = tick as f64 * DT_S;
                // Its front crossed the line about half a body ago.
                let v = f64::from(motion.forward_mps.max(0.5));
                let entered_s = (t - track.s_m.max(0.0) / v - half / v).max(0.0);
                if signal.state_at(k, entered_s) == SignalState::Red {
                    totals.red_entries += 1;
                }
                let cycle = signal.cycle(t);
                let last = measures.discharge.get(&a.lane).copied();
                let place = match last {
                    Some(d) if a.queued && d.cycle == cycle => d.place + 1,
                    _ if a.queued => 1,
                    _ => 0,
                };
                // Saturation flow is a lane's rate for through traffic (a turning car is slower
                // through the corner, a permitted one may wait for a gap): a headway counts
                // when both vehicles went straight on.
                let straight = junctions[j].paths[k].turn == Turn::Straight;
                if let Some(d) = last
                    && place >= DISCHARGE_FROM
                    && d.place + 1 == place
                    && d.straight
                    && straight
                {
                    totals.headway_sum_s += (tick - d.tick) as f64 * DT_S;
                    totals.headways += 1;
                }
                if place > 0 {
                    measures.discharge.insert(
                        a.lane,
                        Discharge {
                            tick,
                            cycle,
                            place,
                            straight,
                        },
                    );
                } else {
                    measures.discharge.remove(&a.lane);
                }
            }
            continue;
        }
        // Before a junction: its next road is one of the junction's paths.
        let Some(ahead) =
            network.junction_ahead(track.road, track.lane, track.s_m, track.next_road, half)
        else {
            measures.approaching.remove(&entity);
            continue;
        };
        let (j, to_line) = (ahead.junction, ahead.to_line_m);
        if to_line > APPROACH_ZONE_M {
            measures.approaching.remove(&entity);
            continue;
        }
        let queued = motion.forward_mps < QUEUED_MPS;
        if to_line < SATURATED_M {
            saturated.push((j, track.road, track.lane));
        }
        let a = measures.approaching.entry(entity).or_insert(Approach {
            junction: j,
            lane: (track.road, track.lane),
            // Entered now if it was outside the zone a tick ago (not just spawned inside it).
            entered: (to_line > APPROACH_ZONE_M - 1.0).then_some((tick, to_line)),
            queued: false,
        });
        a.queued |= queued;
        a.lane = (track.road, track.lane);
        if counting {
            in_zone.push((
                j,
                track.road,
                track.lane,
                OnApproach {
                    to_line_m: to_line,
                    length_m: 2.0 * half,
                    speed_mps: f64::from(motion.forward_mps),
                },
            ));
        }
    }
    if let Some(w) = window {
        saturated.sort_unstable();
        saturated.dedup();
        for (j, road, lane) in saturated {
            measures
                .lane_windows
                .entry((j, road, lane, w))
                .or_default()
                .saturated_ticks += 1;
        }
    }
    // Vehicles gone (destroyed) are forgotten.
    measures.approaching.retain(|e, _| vehicles.contains(*e));
    // Each approach lane's queue, nearest the line first (a stable sort: vehicles level with
    // each other keep the query's order).
    in_zone.sort_by(|a, b| {
        (a.0, a.1, a.2)
            .cmp(&(b.0, b.1, b.2))
            .then(a.3.to_line_m.total_cmp(&b.3.to_line_m))
    });
    for lane in in_zone.chunk_by(|a, b| (a.0, a.1, a.2) == (b.0, b.1, b.2)) {
        let (_, queue_m) = queue_at_line(lane.iter().map(|v| v.3));
        let totals = &mut measures.totals[lane[0].0];
        totals.max_queue_m = totals.max_queue_m.max(queue_m);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(to_line_m: f64, speed_mps: f64) -> OnApproach {
        OnApproach {
            to_line_m,
            length_m: 4.5,
            speed_mps,
        }
    }

    #[test]
    fn a_queue_runs_from_the_line_back_while_slow_cars_stand_close_behind_each_other() {
        assert_eq!(queue_at_line([]), (0, 0.0));
        // Three standing or creeping one behind the other, then a gap of 30 m to a fourth.
        let (n, m) = queue_at_line([at(2.0, 0.0), at(8.5, 0.0), at(15.0, 1.9), at(49.5, 0.0)]);
        assert_eq!(n, 3);
        assert!((m - 19.5).abs() < 1e-9, "{m}");
        // Exactly at the limits: 20 m to the first, 10 m between bumpers.
        let (n, m) = queue_at_line([at(20.0, 0.0), at(34.5, 0.0)]);
        assert_eq!((n, m), (2, 39.0));
        // A moving car at the front ends it before it starts; so does one at 2 m/s.
        assert_eq!(queue_at_line([at(2.0, 8.0), at(8.5, 0.0)]), (0, 0.0));
        assert_eq!(queue_at_line([at(2.0, 2.0)]), (0, 0.0));
    }

    #[test]
    fn a_car_setting_off_far_from_the_line_is_not_a_queue() {
        // Where a route begins on the approach a car starts from a standstill 90 m from the
        // line with the road before it free: no queue, though it is the slowest car there.
        assert_eq!(queue_at_line([at(40.0, 13.0), at(90.0, 0.0)]), (0, 0.0));
        assert_eq!(queue_at_line([at(90.0, 0.0)]), (0, 0.0));
        // Behind a real queue it is not part of it either.
        assert_eq!(queue_at_line([at(1.0, 0.0), at(90.0, 0.0)]), (1, 5.5));
    }
}

//! Signals and junction approaches as a controller sees and sets them between steps: each
//! signal's program, phase and state, phase switches, held states and new programs, and per
//! lane into a junction its queue, halting and approaching vehicles, speed, waiting and delay.

use crate::session::{Session, SessionError};
use bevy_ecs::prelude::*;
use flockway_drivers::{SignalError, SignalMode, Signals};
use flockway_road::{RoadId, RoadNetwork, SignalProgram};
use flockway_traffic::{HALTING_MPS, OnApproach, WaitingTimes, queue_at_line};
pub use flockway_traffic::{QUEUE_FRONT_M, QUEUE_GAP_M};
use flockway_vehicle::{Motion, RoadTrack, VehicleModel};
use std::collections::BTreeMap;

/// How far before its line a vehicle counts as approaching a junction, m (front bumper).
pub const APPROACHING_M: f64 = 100.0;

/// One signalised junction as a controller sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct SignalView {
    /// The junction's name.
    pub junction: String,
    /// How it runs: `plan` (the level's program by the clock), `running` (a program from a
    /// phase switched to) or `held` (a state set from outside).
    pub mode: &'static str,
    /// Whether the program was set from outside.
    pub custom: bool,
    /// The phase showing (`None` while a state is held).
    pub phase: Option<usize>,
    /// How long the phase (or held state) has shown, s.
    pub time_in_phase_s: f64,
    /// What each connection shows, a letter each: `G`, `g`, `y`, `r`.
    pub state: String,
    /// The program in force: each phase's duration, s, and state.
    pub phases: Vec<(f64, String)>,
    /// Each connection: from road, from lane, to road, to lane.
    pub connections: Vec<(String, u32, String, u32)>,
}

/// Every lane leading into a junction, a column per quantity, in junction order then in the
/// order the junction's connections first name the lane.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ApproachColumns {
    /// The junction names the `junction` column indexes.
    pub junctions: Vec<String>,
    /// Junction, as an index into `junctions`.
    pub junction: Vec<u32>,
    /// Road, as an index into [`Session::road_names`].
    pub road: Vec<u32>,
    /// Lane of the road.
    pub lane: Vec<u32>,
    /// The road's length, m.
    pub length_m: Vec<f64>,
    /// Vehicles on the lane.
    pub vehicles: Vec<u32>,
    /// Vehicles on it within [`APPROACHING_M`] of the line.
    pub approaching: Vec<u32>,
    /// Vehicles on it slower than [`HALTING_MPS`].
    pub halting: Vec<u32>,
    /// Vehicles in the queue at the line: standing or creeping (below
    /// [`QUEUED_MPS`](flockway_traffic::QUEUED_MPS)) one behind the other from the line back
    /// (the first within [`QUEUE_FRONT_M`] of it, each within [`QUEUE_GAP_M`] of the one
    /// before).
    pub queue_vehicles: Vec<u32>,
    /// The queue's length from the line to its last vehicle's rear bumper, m.
    pub queue_m: Vec<f64>,
    /// Mean speed of the approaching vehicles, m/s (NaN with none).
    pub mean_speed_mps: Vec<f64>,
    /// Sum of the vehicles' waiting on the lane's road: each one's time below [`HALTING_MPS`]
    /// since it entered the road, s.
    pub waiting_s: Vec<f64>,
    /// Time lost on the lane so far by every vehicle that drove it: each step's shortfall
    /// below the speed limit as a share of the step, summed, s.
    pub delay_s: Vec<f64>,
}

/// A vehicle on an approach lane: distance from its front bumper to the line, its length and
/// speed, its waiting.
struct OnLane {
    to_line_m: f64,
    length_m: f64,
    speed_mps: f64,
    waiting_s: f64,
}

impl Session {
    fn signals_resource(&mut self) -> &mut Signals {
        let world = self.runner_mut().sim_mut().world_mut();
        world.resource_scope(|world, mut signals: Mut<Signals>| {
            signals.ensure(world.resource::<RoadNetwork>());
        });
        world.resource_mut::<Signals>().into_inner()
    }

    /// Every signalised junction now, in the level's order.
    pub fn signals(&mut self) -> Vec<SignalView> {
        let t_s = self.time_s();
        self.signals_resource();
        let world = self.runner().sim().world();
        let network = world.resource::<RoadNetwork>();
        let name = |id: u32| network.get(RoadId(id)).map_or("?", |g| g.name()).to_owned();
        world
            .resource::<Signals>()
            .iter()
            .map(|(j, c)| {
                let (phase, time_in_phase_s) = match c.phase(t_s) {
                    Some((i, t)) => (Some(i), t),
                    None => (None, c.unchanged_for_s(t_s)),
                };
                SignalView {
                    junction: c.junction.clone(),
                    mode: match c.mode {
                        SignalMode::Plan => "plan",
                        SignalMode::Running { .. } => "running",
                        SignalMode::Held { .. } => "held",
                    },
                    custom: c.custom,
                    phase,
                    time_in_phase_s,
                    state: c.state_string(),
                    phases: c
                        .program
                        .phases
                        .iter()
                        .map(|p| (p.duration_s, p.state.clone()))
                        .collect(),
                    connections: network.junctions()[j]
                        .paths
                        .iter()
                        .map(|p| (name(p.from.0), p.from.1, name(p.to.0), p.to.1))
                        .collect(),
                }
            })
            .collect()
    }

    /// Switches junction `junction`'s signal to phase `phase` of its program now; the program
    /// runs on from there.
    pub fn set_phase(&mut self, junction: &str, phase: usize) -> Result<(), SessionError> {
        let t_s = self.time_s();
        self.signals_resource()
            .by_name_mut(junction)?
            .set_phase(phase, t_s)
            .map_err(SessionError::from)
    }

    /// Shows `state` (a letter per connection) at junction `junction` now and holds it; with
    /// `amber_s` above 0 movements losing green show amber that long first, then (with
    /// `all_red_s`) every changing movement red that long.
    pub fn set_signal_state(
        &mut self,
        junction: &str,
        state: &str,
        amber_s: f64,
        all_red_s: f64,
    ) -> Result<(), SessionError> {
        let t_s = self.time_s();
        self.signals_resource()
            .by_name_mut(junction)?
            .set_state(state, amber_s, all_red_s, t_s)
            .map_err(SessionError::from)
    }

    /// Runs `program` at junction `junction` from its phase `phase` now; `None` goes back to
    /// the level's program by the clock.
    pub fn set_program(
        &mut self,
        junction: &str,
        program: Option<SignalProgram>,
        phase: usize,
    ) -> Result<(), SessionError> {
        let t_s = self.time_s();
        self.signals_resource()
            .by_name_mut(junction)?
            .set_program(program, phase, t_s)
            .map_err(SessionError::from)
    }

    /// Every lane into every junction now.
    pub fn approaches(&mut self) -> ApproachColumns {
        let world = self.runner_mut().sim_mut().world_mut();
        let mut vehicles: Vec<(RoadId, u32, OnLane)> = Vec::new();
        {
            let network = world.resource::<RoadNetwork>();
            let waiting = world.get_resource::<WaitingTimes>();
            let mut query = world.try_query::<(Entity, &RoadTrack, &Motion, &VehicleModel)>();
            if let Some(query) = query.as_mut() {
                for (entity, track, motion, model) in query.iter(world) {
                    let Some(g) = network.get(track.road) else {
                        continue;
                    };
                    let length_m = f64::from(model.0.params.chassis.length_m);
                    vehicles.push((
                        track.road,
                        track.lane,
                        OnLane {
                            to_line_m: g.length_m() - track.s_m - 0.5 * length_m,
                            length_m,
                            speed_mps: f64::from(motion.forward_mps),
                            waiting_s: waiting.map_or(0.0, |w| w.waiting_s(entity)),
                        },
                    ));
                }
            }
        }
        let network = world.resource::<RoadNetwork>();
        let delays = world.get_resource::<WaitingTimes>();
        // Each junction's approach lanes, once each, in the order its connections name them.
        let mut rows: Vec<(usize, RoadId, u32)> = Vec::new();
        for (j, junction) in network.junctions().iter().enumerate() {
            for path in &junction.paths {
                let lane = (j, RoadId(path.from.0), path.from.1);
                if !rows.contains(&lane) {
                    rows.push(lane);
                }
            }
        }
        let mut on: BTreeMap<(RoadId, u32), Vec<OnLane>> = rows
            .iter()
            .map(|&(_, road, lane)| ((road, lane), Vec::new()))
            .collect();
        for (road, lane, v) in vehicles {
            if let Some(list) = on.get_mut(&(road, lane)) {
                list.push(v);
            }
        }
        let mut out = ApproachColumns {
            junctions: network
                .junctions()
                .iter()
                .map(|j| j.spec.name.clone())
                .collect(),
            ..ApproachColumns::default()
        };
        for (j, road, lane) in rows {
            let list = on.get_mut(&(road, lane)).expect("every row has a list");
            list.sort_by(|a, b| a.to_line_m.total_cmp(&b.to_line_m));
            let approaching: Vec<&OnLane> = list
                .iter()
                .filter(|v| v.to_line_m <= APPROACHING_M)
                .collect();
            let (queue_vehicles, queue_m) = queue(list);
            out.junction.push(j as u32);
            out.road.push(road.0);
            out.lane.push(lane);
            out.length_m
                .push(network.get(road).map_or(0.0, |g| g.length_m()));
            out.vehicles.push(list.len() as u32);
            out.approaching.push(approaching.len() as u32);
            out.halting.push(
                list.iter()
                    .filter(|v| v.speed_mps.abs() < f64::from(HALTING_MPS))
                    .count() as u32,
            );
            out.queue_vehicles.push(queue_vehicles);
            out.queue_m.push(queue_m);
            out.mean_speed_mps.push(if approaching.is_empty() {
                f64::NAN
            } else {
                approaching.iter().map(|v| v.speed_mps).sum::<f64>() / approaching.len() as f64
            });
            out.waiting_s.push(list.iter().map(|v| v.waiting_s).sum());
            out.delay_s
                .push(delays.map_or(0.0, |d| d.lane_delay_s(road, lane)));
        }
        out
    }
}

/// The queue at the line of a lane whose vehicles are sorted nearest the line first: how many,
/// and how far back its last one's rear bumper is, m (the junctions' measure of it).
fn queue(sorted: &[OnLane]) -> (u32, f64) {
    queue_at_line(sorted.iter().map(|v| OnApproach {
        to_line_m: v.to_line_m,
        length_m: v.length_m,
        speed_mps: v.speed_mps,
    }))
}

impl From<SignalError> for SessionError {
    fn from(e: SignalError) -> SessionError {
        SessionError::Value(e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(to_line_m: f64, speed_mps: f64) -> OnLane {
        OnLane {
            to_line_m,
            length_m: 4.5,
            speed_mps,
            waiting_s: 0.0,
        }
    }

    #[test]
    fn a_queue_is_the_slow_vehicles_close_behind_each_other_from_the_line_back() {
        assert_eq!(queue(&[]), (0, 0.0));
        // Three standing, then a gap of 30 m to a fourth.
        let lane = [at(2.0, 0.0), at(8.5, 0.0), at(15.0, 0.5), at(49.5, 0.0)];
        let (n, m) = queue(&lane);
        assert_eq!(n, 3);
        assert!((m - 19.5).abs() < 1e-9, "{m}");
        // A moving first car: no queue.
        assert_eq!(queue(&[at(2.0, 8.0), at(8.5, 0.0)]).0, 0);
        // The first one too far from the line.
        assert_eq!(queue(&[at(25.0, 0.0)]).0, 0);
    }
}

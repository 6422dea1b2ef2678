//! Spawners and the vehicles they create.

use crate::stats::TrafficStats;
use crate::trips::TripLog;
use crate::zones::Travel;
use bevy_ecs::prelude::*;
use flockway_core::{EntityRng, IdKind, RngStreams, SimClock, StableId, TICKS_PER_SECOND};
use flockway_drivers::{
    DriverLabel, DriverSpec, LaneIndex, LaneSignal, Route, STOP_LINE_DECEL_MPS2, STOP_LINE_MARGIN_M,
};
use flockway_road::{Control, Junction, RoadId, RoadNetwork, lane_offset};
use flockway_vehicle::{SpawnError, VehicleSpawn, VehicleType, spawn_vehicle};
use std::collections::VecDeque;
use std::sync::Arc;

/// A vehicle's stable number: spawn order across the run, the same on every run of a level and
/// seed. Keys its random stream and its telemetry rows.
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct VehicleId(pub u32);

/// Hands out [`VehicleId`]s in spawn order.
#[derive(Resource, Debug, Clone, Default)]
pub struct VehicleIds {
    next: u32,
}

impl VehicleIds {
    /// The next id.
    pub fn allocate(&mut self) -> VehicleId {
        let id = VehicleId(self.next);
        self.next += 1;
        id
    }
}

/// One kind of vehicle a spawner can make: a driver profile in its vehicle, with a weight.
#[derive(Debug, Clone)]
pub struct SpawnChoice {
    /// Profile name (the CSV's `driver` column).
    pub profile: Arc<str>,
    /// Relative probability.
    pub weight: f64,
    /// The car.
    pub vehicle: Arc<VehicleType>,
    /// Its driver.
    pub driver: DriverSpec,
}

/// One route a spawner gives its vehicles.
#[derive(Debug, Clone, PartialEq)]
pub struct SpawnRoute {
    /// Name (the telemetry's `route` column).
    pub name: Arc<str>,
    /// Roads in driving order, the spawner's road first.
    pub roads: Vec<RoadId>,
    /// Relative probability.
    pub weight: f64,
}

/// One vehicle of a spawner's timetable.
#[derive(Debug, Clone, PartialEq)]
pub struct Departure {
    /// Tick it is due.
    pub tick: u64,
    /// Which of the spawner's choices it is.
    pub choice: usize,
    /// Which of the spawner's routes it takes; `None`: one drawn by weight.
    pub route: Option<usize>,
    /// Its speed when created, m/s; `None`: the spawner's.
    pub speed_mps: Option<f32>,
}

/// Spawns a vehicle every T seconds (T uniform in an interval, from its own random stream) on a
/// road and lane, choosing a profile by weight (and a route by weight, if it has several);
/// waits while the spot is occupied.
#[derive(Component, Debug, Clone)]
pub struct Spawner {
    /// Name (for the HUD and errors).
    pub name: String,
    /// Road.
    pub road: RoadId,
    /// Lane.
    pub lane: u32,
    /// Arc position, m.
    pub s_m: f64,
    /// Shortest interval, s.
    pub interval_min_s: f64,
    /// Longest interval, s.
    pub interval_max_s: f64,
    /// What it spawns.
    pub choices: Vec<SpawnChoice>,
    /// Initial speed, m/s; `None` for the road's speed limit.
    pub speed_mps: Option<f32>,
    /// Whether it spawns at all.
    pub active: bool,
    /// Stops after this many.
    pub max_vehicles: Option<u32>,
    /// How many it has spawned.
    pub spawned: u32,
    /// The routes its vehicles take; empty: they follow their lanes' links.
    pub routes: Vec<SpawnRoute>,
    /// Demand steps: `(from tick, shortest interval s, longest interval s)`, in time order.
    pub schedule: Vec<(u64, f64, f64)>,
    /// Ticks it has spent waiting for its spot to clear.
    pub waited_ticks: u64,
    /// Intervals random beyond the shortest (exponential, with the range's mean) rather than
    /// uniform in the range.
    pub random_arrivals: bool,
    /// Its timetable's vehicles not yet made, in the order due (see [`Spawner::with_timetable`]).
    pub departures: VecDeque<Departure>,
    /// Whether it runs a timetable (then it makes nothing else, even once the table is done).
    pub timetabled: bool,
    next_due: Option<u64>,
    rng: EntityRng,
}

impl Spawner {
    /// A spawner whose random stream is `rng` (use the spawner's own `StableId` stream).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: String,
        road: RoadId,
        lane: u32,
        s_m: f64,
        interval_s: (f64, f64),
        choices: Vec<SpawnChoice>,
        speed_mps: Option<f32>,
        active: bool,
        max_vehicles: Option<u32>,
        rng: EntityRng,
    ) -> Spawner {
        Spawner {
            name,
            road,
            lane,
            s_m,
            interval_min_s: interval_s.0,
            interval_max_s: interval_s.1,
            choices,
            speed_mps,
            active,
            max_vehicles,
            spawned: 0,
            routes: Vec::new(),
            schedule: Vec::new(),
            waited_ticks: 0,
            random_arrivals: false,
            departures: VecDeque::new(),
            timetabled: false,
            next_due: None,
            rng,
        }
    }

    /// Draws intervals at random beyond the shortest: the shortest plus an exponential draw
    /// whose mean makes the mean interval that of the range (arrivals of free traffic, as a
    /// Poisson stream with a minimum headway).
    pub fn with_random_arrivals(mut self, random: bool) -> Spawner {
        self.random_arrivals = random;
        self
    }

    /// Gives its vehicles these routes.
    pub fn with_routes(mut self, routes: Vec<SpawnRoute>) -> Spawner {
        self.routes = routes;
        self
    }

    /// Makes exactly these vehicles, each when due, in time order (those due at the same tick
    /// in the order given); one whose spot is not clear waits, with those behind it.
    pub fn with_timetable(mut self, mut departures: Vec<Departure>) -> Spawner {
        departures.sort_by_key(|d| d.tick);
        self.departures = departures.into();
        self.timetabled = true;
        self
    }

    /// How many of its timetable's vehicles are due by `tick` and not yet made.
    pub fn backlog(&self, tick: u64) -> u64 {
        self.departures
            .iter()
            .take_while(|d| d.tick <= tick)
            .count() as u64
    }

    /// Changes its interval at these ticks: `(from tick, shortest s, longest s)`.
    pub fn with_schedule(mut self, mut schedule: Vec<(u64, f64, f64)>) -> Spawner {
        schedule.sort_by_key(|step| step.0);
        self.schedule = schedule;
        self
    }

    /// The interval range at `tick`, s.
    fn interval_at(&self, tick: u64) -> (f64, f64) {
        self.schedule
            .iter()
            .rev()
            .find(|step| step.0 <= tick)
            .map_or((self.interval_min_s, self.interval_max_s), |step| {
                (step.1, step.2)
            })
    }

    fn draw_interval_ticks(&mut self, tick: u64) -> u64 {
        let (lo, hi) = self.interval_at(tick);
        let (lo, hi) = (lo.max(0.0), hi.max(0.0));
        let s = if hi <= lo {
            lo
        } else if self.random_arrivals {
            // Inverse transform of an exponential with mean (hi - lo) / 2 beyond `lo`.
            let u = self.rng.uniform(0.0, 1.0);
            lo - 0.5 * (hi - lo) * libm::log(1.0 - u)
        } else {
            self.rng.uniform(lo, hi)
        };
        (s * f64::from(TICKS_PER_SECOND)).round().max(1.0) as u64
    }
}

/// Vehicles spawned per second over the run so far, all spawners together.
#[derive(Resource, Debug, Clone, Copy, Default, PartialEq)]
pub struct SpawnerRate {
    /// Vehicles per second.
    pub per_s: f64,
}

/// Free length needed around a spawn point in the lane, m, beyond the car's own length.
const SPAWN_CLEARANCE_M: f64 = 4.0;

/// Sideways room a car beside a spawn point must leave, beyond a body's width between the two
/// centres, m.
const SPAWN_LATERAL_MARGIN_M: f64 = 0.3;

/// Extra time gap needed ahead of a spawn point at the spawn speed, s.
const SPAWN_GAP_S: f64 = 0.3;

/// Braking a spawned car is given to match a slower car ahead, m/s²: firm, well within grip.
const SPAWN_BRAKE_MPS2: f64 = 5.0;

/// Bumper gap a spawned car keeps when it has matched a slower car ahead, m.
const SPAWN_ROOM_M: f64 = 2.0;

/// The least time, s, a car is given to reach the car ahead of it when it is created at
/// speed: its time to collision (above the conflict threshold of the surrogate safety measures).
const INSERT_TTC_S: f64 = 1.5;

/// Speed below which a car ahead of a spawn point counts as standing in a queue, m/s.
const QUEUE_MPS: f32 = 5.0;

/// How far back, m, along the lanes that lead onto a spawner's lane it looks for a car coming.
const UPSTREAM_REACH_M: f64 = 60.0;

/// The time gap, s, a car coming onto a spawner's road from behind must still be away from the
/// spawn point (beyond the room the spawned car needs behind it).
const UPSTREAM_GAP_S: f64 = 2.0;

/// Whether a car on a lane leading onto `(road, lane)` (a junction's path, a linked road; up to
/// `depth` more roads back) is coming within [`UPSTREAM_GAP_S`] of a spawn point `back_m` from
/// the lane's start, or within `behind_m` of it: a car created there would be run into.
fn upstream_blocked(
    network: &RoadNetwork,
    index: &LaneIndex,
    (road, lane): (RoadId, u32),
    back_m: f64,
    behind_m: f64,
    depth: u32,
    near: &mut Vec<flockway_drivers::Seen>,
) -> bool {
    if back_m >= UPSTREAM_REACH_M {
        return false;
    }
    for &(prev, prev_lane) in network.lane_prev(road, lane) {
        let Some(g) = network.get(prev) else { continue };
        if prev == road || g.is_closed() {
            continue;
        }
        let length = g.length_m();
        near.clear();
        index.within(
            prev,
            prev_lane,
            length,
            UPSTREAM_REACH_M - back_m,
            0.0,
            None,
            near,
        );
        let coming = near.iter().any(|n| {
            let distance = back_m + (length - n.entry.s_m);
            distance < behind_m + UPSTREAM_GAP_S * f64::from(n.entry.speed_mps.max(0.0))
        });
        if coming
            || (depth > 0
                && upstream_blocked(
                    network,
                    index,
                    (prev, prev_lane),
                    back_m + length,
                    behind_m,
                    depth - 1,
                    near,
                ))
        {
            return true;
        }
    }
    false
}

/// Whether a car taking path `k` of `junction` may have to stop at its line: under a signal, at
/// an all-way stop, at a stop sign, or where it gives way to a path it crosses or merges with.
fn may_stop_at(junction: &Junction, k: usize) -> bool {
    match junction.spec.control {
        Control::Signal | Control::AllWayStop => true,
        _ => {
            junction.must_stop(k)
                || junction.paths.get(k).is_some_and(|p| {
                    p.conflicts
                        .iter()
                        .any(|c| junction.gives_way(k, c.other, None))
                })
        }
    }
}

/// Runs every spawner that is due: if its spot is clear, it spawns one vehicle (applied at the
/// end of the system, in spawner order) and draws its next interval; otherwise it waits.
pub fn run_spawners(
    clock: Res<SimClock>,
    index: Res<LaneIndex>,
    network: Res<RoadNetwork>,
    mut spawners: Query<&mut Spawner>,
    mut stats: ResMut<TrafficStats>,
    mut commands: Commands,
) {
    let tick = clock.tick().0;
    for mut sp in &mut spawners {
        if !sp.active || sp.max_vehicles.is_some_and(|m| sp.spawned >= m) || sp.choices.is_empty() {
            continue;
        }
        let timetabled = sp.timetabled.then(|| sp.departures.front().cloned());
        if let Some(next) = &timetabled {
            match next {
                Some(d) if d.tick <= tick && d.choice < sp.choices.len() => {}
                _ => continue,
            }
        }
        // Random arrivals have no memory: when the demand steps, the wait still drawn at the
        // old rate is drawn again at the new one (else a long wait drawn at a low demand would
        // delay the higher one).
        if sp.random_arrivals
            && let Some(due) = sp.next_due
            && sp.schedule.iter().any(|step| step.0 == tick)
            && due > tick
        {
            let redrawn = tick + sp.draw_interval_ticks(tick);
            sp.next_due = Some(redrawn);
        }
        let departure = timetabled.flatten();
        let (choice, speed_mps) = match &departure {
            Some(d) => (d.choice, d.speed_mps.or(sp.speed_mps)),
            None => {
                let due = match sp.next_due {
                    Some(t) => t,
                    None => {
                        let first = tick + sp.draw_interval_ticks(tick);
                        sp.next_due = Some(first);
                        first
                    }
                };
                if tick < due {
                    continue;
                }
                let weights: Vec<f64> = sp.choices.iter().map(|c| c.weight).collect();
                let Some(choice) = sp.rng.weighted_index(&weights) else {
                    continue;
                };
                (choice, sp.speed_mps)
            }
        };
        let length = f64::from(sp.choices[choice].vehicle.params.chassis.length_m);
        let mut near = Vec::new();
        let speed_guess = f64::from(speed_mps.unwrap_or(0.0));
        let behind = length + SPAWN_CLEARANCE_M;
        // Ahead, also a short time gap at the spawn speed: a car appearing right behind a
        // slower one would have no room to brake.
        let ahead = behind + SPAWN_GAP_S * speed_guess;
        index.within(sp.road, sp.lane, sp.s_m, behind, ahead, None, &mut near);
        // On a short road the spot reaches past its end: a car just gone on into the junction
        // (on any path from this lane) or the road beyond holds it too.
        let past_end = network
            .get(sp.road)
            .is_some_and(|g| g.length_m() - sp.s_m < ahead)
            && index
                .leader(sp.road, sp.lane, sp.s_m, Entity::PLACEHOLDER, ahead, None)
                .is_some();
        if !near.is_empty() || past_end {
            sp.waited_ticks += 1;
            continue;
        }
        if upstream_blocked(
            &network,
            &index,
            (sp.road, sp.lane),
            sp.s_m,
            behind,
            2,
            &mut near,
        ) {
            sp.waited_ticks += 1;
            continue;
        }
        near.clear();
        let Some(geometry) = network.get(sp.road) else {
            continue;
        };
        let width = geometry.frame_at(sp.s_m).width_m;
        let lateral = lane_offset(width, geometry.lanes(), sp.lane);
        // A car in a lane beside that is moving across into this one, or already partly in it,
        // holds the spot as well: a car created there would be cut in on.
        let body_width = f64::from(sp.choices[choice].vehicle.params.chassis.width_m);
        let mut beside = Vec::new();
        for (lane, towards) in [(sp.lane.checked_sub(1), 2i8), (Some(sp.lane + 1), -2)] {
            if let Some(lane) = lane.filter(|l| *l < geometry.lanes()) {
                index.within(sp.road, lane, sp.s_m, behind, ahead, None, &mut beside);
                beside.retain(|n| {
                    n.entry.signal == towards
                        || (f64::from(n.entry.lateral_m) - lateral).abs()
                            < body_width + SPAWN_LATERAL_MARGIN_M
                });
                if !beside.is_empty() {
                    break;
                }
            }
        }
        if !beside.is_empty() {
            sp.waited_ticks += 1;
            continue;
        }
        // A route is drawn only when there is a choice, so a spawner's stream stays as it was
        // for levels without routes.
        let route = match (departure.as_ref().and_then(|d| d.route), sp.routes.len()) {
            (Some(k), n) if k < n => Some(k),
            (_, 0) => None,
            (_, 1) => Some(0),
            _ => {
                let weights: Vec<f64> = sp.routes.iter().map(|r| r.weight).collect();
                sp.rng.weighted_index(&weights)
            }
        }
        .map(|k| Route::along(sp.routes[k].name.clone(), sp.routes[k].roads.clone()));
        let next = route.as_ref().and_then(Route::next_road);
        // Where the road ends at a junction the car may have to stop at, never faster than it
        // can stop at the line from, braking as for a stop line: a car created close before
        // it at the limit would be past the point of no return at once, and drive into the
        // junction without giving way.
        let line_cap = network
            .junction_ahead(sp.road, sp.lane, sp.s_m, next, 0.5 * length)
            .filter(|a| {
                network
                    .junctions()
                    .get(a.junction)
                    .is_some_and(|j| may_stop_at(j, a.path))
            })
            .map_or(f32::INFINITY, |a| {
                let room = (a.to_line_m - STOP_LINE_MARGIN_M).max(0.0);
                (2.0 * f64::from(STOP_LINE_DECEL_MPS2) * room).sqrt() as f32
            });
        let wanted = speed_mps
            .unwrap_or(geometry.speed_limit_kmh() as f32 / 3.6)
            .min(line_cap);
        // Behind a queue (a car ahead at 5 m/s or less), never faster than it
        // can brake from, firmly, to that car's speed before it reaches it: a spawner feeding a
        // queue would otherwise launch cars into it. A spawner with no speed of its own starts
        // its car at the highest speed its driver's braking envelope allows behind any car
        // ahead (up to the limit; as SUMO's `departSpeed="max"`), and so does one given a speed
        // whose car looks ahead only. A flocking car given a speed keeps it behind a moving
        // stream (the level asked for that speed): the car ahead of it is pushed on by it.
        near.clear();
        let v = f64::from(wanted);
        let reach = v * v / (2.0 * SPAWN_BRAKE_MPS2) + behind;
        index.within(sp.road, sp.lane, sp.s_m, 0.0, reach, None, &mut near);
        // Past the road's end too, along the car's route: on a short road the car ahead may
        // be on the junction's path or the road beyond already.
        if geometry.length_m() - sp.s_m < reach
            && let Some(beyond) =
                index.leader(sp.road, sp.lane, sp.s_m, Entity::PLACEHOLDER, reach, next)
            && near.last().is_none_or(|n| beyond.gap_m > n.gap_m)
        {
            near.push(beyond);
        }
        let c = sp.choices[choice].clone();
        let envelope =
            (speed_mps.is_none() || c.driver.rear_weight() <= 0.0).then(|| *c.driver.safety());
        let speed = near
            .iter()
            .filter(|n| n.gap_m > 0.0)
            .map(|n| {
                let bumper = n.gap_m - 0.5 * (length + f64::from(n.entry.length_m));
                let lead = f64::from(n.entry.speed_mps.max(0.0));
                let queue = if n.entry.speed_mps < QUEUE_MPS {
                    let room = bumper - SPAWN_ROOM_M;
                    (lead * lead + 2.0 * SPAWN_BRAKE_MPS2 * room.max(0.0)).sqrt() as f32
                } else {
                    f32::INFINITY
                };
                let safe = envelope.map_or(f32::INFINITY, |e| {
                    e.safe_speed_mps(bumper as f32, lead as f32)
                });
                // Never on a collision course: at least INSERT_TTC_S to reach the car ahead.
                let closing = (lead + bumper.max(0.0) / INSERT_TTC_S) as f32;
                queue.min(safe).min(closing)
            })
            .fold(wanted, f32::min);
        let (road, s_m, lane) = (sp.road, sp.s_m, sp.lane);
        commands.queue(move |world: &mut World| {
            let spawn = VehicleSpawn::new(c.vehicle, road, s_m)
                .lateral(lateral)
                .speed(speed);
            match spawn_driven(world, spawn, &c.driver, lane, c.profile) {
                Ok(e) => {
                    if let Some(route) = route {
                        world.entity_mut(e).insert(route);
                    }
                }
                Err(e) => tracing::warn!("spawner at {s_m} m: {e}"),
            }
        });
        sp.spawned += 1;
        if departure.is_some() {
            sp.departures.pop_front();
        } else {
            let next = tick + sp.draw_interval_ticks(tick);
            sp.next_due = Some(next);
        }
    }
    let backlog: u64 = spawners
        .iter()
        .filter(|sp| sp.active && sp.timetabled)
        .map(|sp| sp.backlog(tick))
        .sum();
    stats.insertion_backlog = backlog;
}

/// Spawns a driven vehicle: the body, its driver (a human draws its desired speed from the
/// vehicle's own stream), a fresh [`VehicleId`], its label, travel record, lane signal and a
/// route that follows the road (insert a [`Route`] to give it another). Counts it.
pub fn spawn_driven(
    world: &mut World,
    spawn: VehicleSpawn,
    driver: &DriverSpec,
    lane: u32,
    profile: Arc<str>,
) -> Result<Entity, SpawnError> {
    let (road, s_m) = (spawn.road, spawn.s_m);
    let entity = spawn_vehicle(world, spawn)?;
    let id = world.resource_mut::<VehicleIds>().allocate();
    let tick = world.resource::<SimClock>().tick().0;
    let mut rng = world
        .resource::<RngStreams>()
        .stream(StableId::new(IdKind::Vehicle, id.0));
    let mut e = world.entity_mut(entity);
    driver.insert(&mut e, lane, &mut rng);
    e.insert((
        id,
        DriverLabel::new(profile, driver.model_name()),
        Travel {
            spawned_tick: tick,
            road,
            s_m,
            free_flow_s: 0.0,
            depart_road: road,
            length_m: 0.0,
        },
        Route::follow_road(road),
        LaneSignal::default(),
    ));
    world.resource_mut::<TrafficStats>().spawned += 1;
    if let Some(mut log) = world.get_resource_mut::<TripLog>() {
        log.departed(road);
    }
    Ok(entity)
}

#[cfg(test)]
mod tests {
    use super::*;
    use flockway_core::{IdKind, RngStreams, StableId};

    fn spawner(random: bool) -> Spawner {
        let rng = RngStreams::new(7).stream(StableId::new(IdKind::Spawner, 0));
        Spawner::new(
            "s".into(),
            RoadId(0),
            0,
            0.0,
            (1.5, 10.5),
            Vec::new(),
            None,
            true,
            None,
            rng,
        )
        .with_random_arrivals(random)
    }

    #[test]
    fn random_arrivals_keep_the_mean_interval_and_the_shortest_but_spread_like_a_poisson_stream() {
        let n = 20_000;
        let draws = |random: bool| -> Vec<f64> {
            let mut sp = spawner(random);
            (0..n)
                .map(|_| sp.draw_interval_ticks(0) as f64 / f64::from(TICKS_PER_SECOND))
                .collect()
        };
        for random in [false, true] {
            let d = draws(random);
            let mean = d.iter().sum::<f64>() / n as f64;
            // Both have the range's mean, 6 s (the standard error is about 0.03 s).
            assert!((mean - 6.0).abs() < 0.1, "random {random}: mean {mean}");
            assert!(d.iter().all(|&x| x >= 1.5 - 1e-9), "random {random}");
        }
        // Uniform draws stay in the range; random ones beyond the shortest are exponential:
        // a share e^(−1) ≈ 0.37 of them exceed the shortest by more than their mean (4.5 s), and
        // some exceed the range's longest.
        let uniform = draws(false);
        assert!(uniform.iter().all(|&x| x <= 10.5 + 1e-9));
        let random = draws(true);
        let beyond = random.iter().filter(|&&x| x - 1.5 > 4.5).count() as f64 / n as f64;
        assert!((beyond - (-1.0f64).exp()).abs() < 0.02, "{beyond}");
        assert!(random.iter().any(|&x| x > 10.5));
    }
}

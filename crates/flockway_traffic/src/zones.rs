//! Places on the roads that act on vehicles: destroyers and triggers, and collision accounting.

use crate::VehicleId;
use crate::stats::{TelemetrySettings, TrafficStats};
use crate::trips::{TripLog, TripRecord};
use bevy_ecs::prelude::*;
use flockway_core::{SimClock, TICKS_PER_SECOND};
use flockway_drivers::{DriverLabel, RoadSurface, Route, SpeedLimit, SurfaceStretch};
use flockway_road::{RoadId, RoadNetwork};
use flockway_vehicle::{ContactWith, Motion, RoadTrack, VehicleContact, VehicleState};
use glam::Vec3;
use std::sync::Arc;

/// Where a destroyer acts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DestroyerPlace {
    /// Vehicles that pass this arc position of a road (all lanes).
    OnRoad {
        /// Road.
        road: RoadId,
        /// Arc position, m.
        s_m: f64,
    },
    /// Vehicles whose centre of mass is inside this box (world metres).
    Volume {
        /// Lower corner.
        min: Vec3,
        /// Upper corner.
        max: Vec3,
    },
}

/// Removes vehicles that reach it, recording their travel times and the flow through it.
#[derive(Component, Debug, Clone, PartialEq)]
pub struct Destroyer {
    /// Name (keys its flow in the summary).
    pub name: String,
    /// Where.
    pub place: DestroyerPlace,
    /// Removes only vehicles whose route ends on the road it is on.
    pub arrivals_only: bool,
}

/// When a vehicle appeared and where it was last tick (to see it pass a point).
#[derive(Component, Debug, Clone, Copy, PartialEq)]
pub struct Travel {
    /// Tick it was spawned.
    pub spawned_tick: u64,
    /// Road it was on last tick.
    pub road: RoadId,
    /// Arc position last tick, m.
    pub s_m: f64,
    /// Time the distance it drove so far takes at the speed limits in force, s.
    pub free_flow_s: f64,
    /// The road it was created on.
    pub depart_road: RoadId,
    /// The distance it drove so far along the roads, m.
    pub length_m: f64,
}

impl Travel {
    /// Its time on the road at `tick`, s.
    pub fn time_s(&self, tick: u64) -> f64 {
        (tick - self.spawned_tick) as f64 / f64::from(TICKS_PER_SECOND)
    }

    /// Its delay at `tick`: time on the road above the free-flow time, s.
    pub fn delay_s(&self, tick: u64) -> f64 {
        (self.time_s(tick) - self.free_flow_s).max(0.0)
    }

    /// How far it moved since last tick along the roads, to `track` (across a road's end onto
    /// the next road too), m.
    fn moved_m(&self, network: &RoadNetwork, track: &RoadTrack) -> f64 {
        if self.road == track.road {
            network
                .get(track.road)
                .map_or(0.0, |g| g.delta_s(self.s_m, track.s_m))
        } else {
            network
                .get(self.road)
                .map_or(0.0, |g| (g.length_m() - self.s_m).max(0.0))
                + track.s_m
        }
    }
}

/// What a trigger does to vehicles in it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TriggerEffect {
    /// A vehicle entering gets this speed limit, km/h (it keeps it after leaving).
    SpeedLimit(f32),
    /// Tyre friction is scaled by this while the vehicle is inside (wet asphalt).
    Friction(f32),
}

/// A stretch of road that changes the vehicles in it.
#[derive(Component, Debug, Clone, PartialEq)]
pub struct Trigger {
    /// Name.
    pub name: String,
    /// Road.
    pub road: RoadId,
    /// Start, m.
    pub from_m: f64,
    /// End, m (below `from_m` on a loop: it wraps).
    pub to_m: f64,
    /// Lanes it covers; `None` for all.
    pub lanes: Option<Vec<u32>>,
    /// Effect.
    pub effect: TriggerEffect,
}

impl Trigger {
    /// Whether a vehicle at `s_m` in `lane` of `road` is inside.
    pub fn contains(&self, road: RoadId, lane: u32, s_m: f64) -> bool {
        let along = if self.from_m <= self.to_m {
            (self.from_m..=self.to_m).contains(&s_m)
        } else {
            s_m >= self.from_m || s_m <= self.to_m
        };
        road == self.road && along && self.lanes.as_ref().is_none_or(|l| l.contains(&lane))
    }
}

/// Tells the drivers where the friction triggers are (the [`RoadSurface`] they read the road
/// ahead with), whenever a trigger is added, changed or removed.
pub fn sync_road_surface(
    triggers: Query<&Trigger>,
    changed: Query<(), Changed<Trigger>>,
    mut removed: RemovedComponents<Trigger>,
    mut surface: ResMut<RoadSurface>,
) {
    if changed.is_empty() && removed.read().count() == 0 {
        return;
    }
    let stretches: Vec<SurfaceStretch> = triggers
        .iter()
        .filter_map(|t| match t.effect {
            TriggerEffect::Friction(scale) => Some(SurfaceStretch {
                road: t.road,
                from_m: t.from_m,
                to_m: t.to_m,
                lanes: t.lanes.clone(),
                friction_scale: scale,
            }),
            TriggerEffect::SpeedLimit(_) => None,
        })
        .collect();
    if surface.stretches != stretches {
        surface.stretches = stretches;
    }
}

/// Applies every trigger to the vehicles inside it: speed limits stick, friction lasts while
/// inside.
pub fn apply_triggers(
    triggers: Query<&Trigger>,
    mut vehicles: Query<(&RoadTrack, &mut SpeedLimit, &mut VehicleState)>,
) {
    if triggers.is_empty() {
        return;
    }
    for (track, mut limit, mut state) in &mut vehicles {
        let mut friction = 1.0f32;
        for t in &triggers {
            if !t.contains(track.road, track.lane, track.s_m) {
                continue;
            }
            match t.effect {
                TriggerEffect::SpeedLimit(kmh) => {
                    if limit.kmh != kmh || limit.road != Some(track.road) {
                        *limit = SpeedLimit {
                            kmh,
                            road: Some(track.road),
                        };
                    }
                }
                TriggerEffect::Friction(scale) => friction *= scale,
            }
        }
        if state.wheels.iter().any(|w| w.friction_scale != friction) {
            for w in &mut state.wheels {
                w.friction_scale = friction;
            }
        }
    }
}

/// Counts contacts: a vehicle touching a guardrail is removed and counted (thesis §3.2.5); each
/// vehicle–vehicle contact is counted once when it begins.
pub fn count_collisions(
    mut contacts: MessageReader<VehicleContact>,
    labels: Query<&DriverLabel>,
    places: Query<(&crate::VehicleId, &RoadTrack)>,
    network: Res<RoadNetwork>,
    clock: Res<SimClock>,
    mut stats: ResMut<TrafficStats>,
    mut commands: Commands,
) {
    let mut removed: Vec<Entity> = Vec::new();
    for c in contacts.read() {
        if !c.started {
            continue;
        }
        match c.other {
            ContactWith::Guardrail(_) => {
                if !removed.contains(&c.vehicle) {
                    removed.push(c.vehicle);
                    stats.collisions_guardrail += 1;
                    if let Ok(label) = labels.get(c.vehicle) {
                        *stats
                            .guardrail_by_profile
                            .entry(label.profile.to_string())
                            .or_default() += 1;
                    }
                    if let Ok(mut e) = commands.get_entity(c.vehicle) {
                        e.despawn();
                    }
                }
            }
            ContactWith::Vehicle(other) => {
                stats.collisions_vehicle += 1;
                // Where it happened, for whoever tunes a level (`FLOCKWAY_LOG=debug`).
                let place = |e: Entity| {
                    places.get(e).map_or_else(
                        |_| String::from("?"),
                        |(id, t)| {
                            let road = network.get(t.road).map_or("?", |g| g.name());
                            format!(
                                "vehicle {} on {road:?} lane {} at {:.1} m ({:+.2} m across, {:.1} m/s)",
                                id.0, t.lane, t.s_m, t.lateral_m, t.speed_along_mps
                            )
                        },
                    )
                };
                tracing::debug!(
                    "contact at {:.2} s: {} and {}",
                    clock.seconds(),
                    place(c.vehicle),
                    place(other)
                );
            }
            ContactWith::Ground => {}
        }
    }
}

/// What a destroyer looks at on each vehicle.
type DestroyerView = (
    Entity,
    &'static RoadTrack,
    &'static Motion,
    &'static mut Travel,
    Option<&'static DriverLabel>,
    Option<&'static SpeedLimit>,
    Option<&'static Route>,
    Option<&'static VehicleId>,
);

/// Destroyers on each road and those that are volumes, as positions in their query's order, so
/// that a vehicle is measured against those that can take it, not against every destroyer.
/// Gathered each tick into buffers kept from tick to tick.
#[derive(Debug, Default)]
pub struct DestroyerPlaces {
    /// `(road, position)` of each destroyer on a road, sorted.
    on_road: Vec<(RoadId, usize)>,
    /// The positions of [`on_road`](Self::on_road) alone, in its order.
    on_road_at: Vec<usize>,
    /// The positions of those that are volumes, ascending.
    volumes: Vec<usize>,
    /// Where each road's destroyers are in [`on_road_at`](Self::on_road_at), by road id (up to
    /// the last road with one), so that a vehicle finds its road's in one look.
    by_road: Vec<(usize, usize)>,
}

impl DestroyerPlaces {
    /// Gathers the places of `all`, in their order.
    fn gather(&mut self, all: &[&Destroyer]) {
        self.on_road.clear();
        self.volumes.clear();
        for (k, d) in all.iter().enumerate() {
            match d.place {
                DestroyerPlace::OnRoad { road, .. } => self.on_road.push((road, k)),
                DestroyerPlace::Volume { .. } => self.volumes.push(k),
            }
        }
        // Stable: each road's positions stay ascending.
        self.on_road.sort_by_key(|&(road, _)| road);
        self.on_road_at.clear();
        self.on_road_at.extend(self.on_road.iter().map(|&(_, k)| k));
        self.by_road.clear();
        for (at, &(road, _)) in self.on_road.iter().enumerate() {
            let road = road.0 as usize;
            if self.by_road.len() <= road {
                self.by_road.resize(road + 1, (at, at));
            }
            self.by_road[road].1 = at + 1;
        }
    }

    /// The positions, ascending, of the destroyers on `road`.
    fn on(&self, road: RoadId) -> &[usize] {
        self.by_road
            .get(road.0 as usize)
            .map_or(&[], |&(from, to)| &self.on_road_at[from..to])
    }
}

/// The positions in two ascending lists, in ascending order.
fn merged<'a>(a: &'a [usize], b: &'a [usize]) -> impl Iterator<Item = usize> + 'a {
    let (mut i, mut j) = (0, 0);
    std::iter::from_fn(move || {
        let next = match (a.get(i), b.get(j)) {
            (Some(&x), Some(&y)) if x <= y => {
                i += 1;
                x
            }
            (_, Some(&y)) => {
                j += 1;
                y
            }
            (Some(&x), None) => {
                i += 1;
                x
            }
            (None, None) => return None,
        };
        Some(next)
    })
}

/// Removes vehicles that pass a destroyer's point or are inside its volume, recording their
/// travel time and the destroyer's count (after the warm-up), and their trips in the
/// [`TripLog`] when the run keeps one. Updates every vehicle's [`Travel`] position.
#[allow(clippy::too_many_arguments)] // a system: each argument is a resource or query it reads
pub fn run_destroyers(
    clock: Res<SimClock>,
    settings: Res<TelemetrySettings>,
    network: Res<RoadNetwork>,
    destroyers: Query<&Destroyer>,
    mut vehicles: Query<DestroyerView>,
    mut stats: ResMut<TrafficStats>,
    mut trips: Option<ResMut<TripLog>>,
    mut commands: Commands,
    mut places: Local<DestroyerPlaces>,
) {
    let tick = clock.tick().0;
    let all: Vec<&Destroyer> = destroyers.iter().collect();
    places.gather(&all);
    let places = &*places;
    // The query's fold walks its tables directly, and the step inlined into it makes each
    // vehicle's item in registers: fewer instructions a vehicle than the iterator's `next`.
    vehicles.iter_mut().fold(
        (),
        #[inline(always)]
        |(), (entity, track, motion, mut travel, label, limit, route, id)| {
            let passed = destroyer_taking(&all, places, &network, track, motion, &travel, route);
            if let Some(d) = passed {
                stats.destroyed += 1;
                if let Some(log) = trips.as_deref_mut() {
                    let seconds = |t: u64| t as f64 / f64::from(TICKS_PER_SECOND);
                    log.arrived(TripRecord {
                        vehicle: id.map_or(u32::MAX, |v| v.0),
                        profile: label.map_or_else(|| Arc::from(""), |l| l.profile.clone()),
                        route: route.map_or_else(|| Arc::from(""), |r| r.name.clone()),
                        depart_s: seconds(travel.spawned_tick),
                        depart_road: travel.depart_road,
                        arrival_s: seconds(tick),
                        arrival_road: track.road,
                        length_m: travel.length_m + travel.moved_m(&network, track).max(0.0),
                        time_loss_s: travel.delay_s(tick),
                    });
                }
                if tick >= settings.stats_from_tick {
                    *stats.destroyed_by.entry(d.name.clone()).or_insert(0) += 1;
                    stats.travel_times_s.push(travel.time_s(tick));
                    let delay_s = travel.delay_s(tick);
                    stats.delay.add(delay_s);
                    if let Some(l) = label {
                        stats
                            .delay_by_profile
                            .entry(l.profile.to_string())
                            .or_default()
                            .add(delay_s);
                    }
                    let kmh = f64::from(motion.forward_mps) * 3.6;
                    stats.final_speed.add(kmh);
                    let limit_kmh = f64::from(limit.map_or(f32::INFINITY, |l| l.kmh));
                    stats.final_at_limit.add(kmh, limit_kmh);
                    if let Some(l) = label {
                        stats
                            .final_speed_by_profile
                            .entry(l.profile.to_string())
                            .or_default()
                            .add(kmh);
                        stats
                            .final_at_limit_by_profile
                            .entry(l.profile.to_string())
                            .or_default()
                            .add(kmh, limit_kmh);
                    }
                }
                commands.entity(entity).despawn();
            } else {
                // The distance driven since last tick, at the limit in force, adds to the free-flow
                // time.
                let moved = travel.moved_m(&network, track);
                let limit_mps = f64::from(limit.map_or(f32::INFINITY, |l| l.kmh)) / 3.6;
                if moved > 0.0 && limit_mps > 0.0 {
                    travel.free_flow_s += moved / limit_mps;
                }
                if moved > 0.0 {
                    travel.length_m += moved;
                }
                if travel.road != track.road
                    && let Some(log) = trips.as_deref_mut()
                {
                    log.entered(track.road);
                }
                travel.road = track.road;
                travel.s_m = track.s_m;
            }
        },
    );
}

/// The first destroyer in the query's order that takes a vehicle this tick, as if every
/// destroyer were asked: those on its road and the volumes, in their order. A loop over the
/// positions, not an iterator's `find`, which stayed a call a vehicle where the walk inlines
/// its step.
#[inline(always)]
fn destroyer_taking<'d>(
    all: &[&'d Destroyer],
    places: &DestroyerPlaces,
    network: &RoadNetwork,
    track: &RoadTrack,
    motion: &Motion,
    travel: &Travel,
    route: Option<&Route>,
) -> Option<&'d Destroyer> {
    let on = places.on(track.road);
    // Most vehicles are on a road without a destroyer, and most levels have no volume.
    if on.is_empty() && places.volumes.is_empty() {
        return None;
    }
    let takes = |d: &Destroyer| match d.place {
        DestroyerPlace::OnRoad { road, s_m } => {
            if track.road != road
                || (d.arrivals_only && route.and_then(Route::destination) != Some(road))
            {
                return false;
            }
            let Some(g) = network.get(road) else {
                return false;
            };
            if travel.road == road {
                // Crossed between last tick and this one (forwards, across a loop's join too).
                let moved = g.delta_s(travel.s_m, track.s_m);
                let to_point = g.delta_s(travel.s_m, s_m);
                moved > 0.0 && to_point > 0.0 && to_point <= moved
            } else {
                // Came onto the road this tick already past the point.
                track.s_m >= s_m && g.delta_s(s_m, track.s_m) < 50.0
            }
        }
        DestroyerPlace::Volume { min, max } => {
            let p = motion.position;
            p.cmpge(min).all() && p.cmple(max).all()
        }
    };
    for k in merged(on, &places.volumes) {
        if takes(all[k]) {
            return Some(all[k]);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_road_has_its_destroyers_in_their_order_and_volumes_apart() {
        let on = |road: u32| Destroyer {
            name: format!("on {road}"),
            place: DestroyerPlace::OnRoad {
                road: RoadId(road),
                s_m: 10.0,
            },
            arrivals_only: false,
        };
        let volume = Destroyer {
            name: "volume".into(),
            place: DestroyerPlace::Volume {
                min: Vec3::ZERO,
                max: Vec3::ONE,
            },
            arrivals_only: false,
        };
        let all = [on(2), on(0), on(2), volume, on(1), on(2)];
        let mut places = DestroyerPlaces::default();
        places.gather(&all.iter().collect::<Vec<_>>());
        assert_eq!(places.on(RoadId(2)), &[0, 2, 5]);
        assert_eq!(places.on(RoadId(0)), &[1]);
        assert_eq!(places.on(RoadId(1)), &[4]);
        assert!(places.on(RoadId(3)).is_empty());
        assert_eq!(places.volumes, vec![3]);
        assert_eq!(
            merged(places.on(RoadId(2)), &places.volumes).collect::<Vec<_>>(),
            vec![0, 2, 3, 5]
        );
        // Gathered again, the last tick's places are gone.
        places.gather(&[&all[3]]);
        assert!(places.on(RoadId(2)).is_empty());
        assert_eq!(places.volumes, vec![0]);
    }

    #[test]
    fn triggers_cover_their_stretch_lanes_and_wrap() {
        let t = Trigger {
            name: "t".into(),
            road: RoadId(0),
            from_m: 100.0,
            to_m: 150.0,
            lanes: Some(vec![1]),
            effect: TriggerEffect::SpeedLimit(100.0),
        };
        assert!(t.contains(RoadId(0), 1, 120.0));
        assert!(!t.contains(RoadId(0), 0, 120.0));
        assert!(!t.contains(RoadId(1), 1, 120.0));
        assert!(!t.contains(RoadId(0), 1, 151.0));
        let wrap = Trigger {
            from_m: 200.0,
            to_m: 10.0,
            lanes: None,
            ..t
        };
        assert!(wrap.contains(RoadId(0), 3, 205.0) && wrap.contains(RoadId(0), 0, 5.0));
        assert!(!wrap.contains(RoadId(0), 0, 100.0));
    }
}

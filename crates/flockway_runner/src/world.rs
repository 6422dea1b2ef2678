//! A level turned into a world: the plugins, the roads, and the traffic the level places.

use crate::runner::RunError;
use flockway_core::{IdKind, RngStreams, Sim, StableId, TICKS_PER_SECOND};
use flockway_drivers::{DriverSpec, DriversPlugin};
use flockway_level::Level;
use flockway_road::{Junctions, Road, RoadId, RoadNetwork, RoadPlugin};
use flockway_traffic::{
    CapacityWindows, Departure, Destroyer, DestroyerPlace, Detector, Detectors, SpawnChoice,
    SpawnRoute, Spawner, SsmThresholds, TelemetrySettings, TrafficPlugin, Trigger, TriggerEffect,
    spawn_driven,
};
use flockway_vehicle::{VehiclePlugin, VehicleSpawn, VehicleType};
use std::collections::BTreeMap;
use std::sync::Arc;

/// Builds the world of a level: every plugin, and the level's entities, ready to step.
pub fn build_sim(level: &Level, seed: u64) -> Result<Sim, RunError> {
    let mut sim = Sim::new(seed);
    sim.add_plugin(RoadPlugin);
    sim.add_plugin(VehiclePlugin);
    sim.add_plugin(DriversPlugin);
    sim.add_plugin(TrafficPlugin);
    sim.world_mut()
        .insert_resource(Junctions(level.junctions.clone()));
    for (i, spec) in level.roads.iter().enumerate() {
        sim.world_mut().spawn((
            RoadId(i as u32),
            StableId::new(IdKind::Road, i as u32),
            Road(spec.clone()),
        ));
    }
    sim.prepare().map_err(RunError::Schedule)?;
    Ok(sim)
}

/// A route from road `start` along `roads` (which may repeat `start` first) as the vehicle
/// drives it: with the junction path between two roads that meet in a junction.
pub fn route_through(network: &RoadNetwork, start: RoadId, roads: &[RoadId]) -> Vec<RoadId> {
    let mut out = vec![start];
    for &road in roads {
        if out.len() == 1 && road == start {
            continue;
        }
        let last = out[out.len() - 1];
        if network.link(last, road).is_none()
            && let Some(path) = network.junction_path_between(last, road)
        {
            out.push(path);
        }
        out.push(road);
    }
    out
}

/// The routes a spawner's vehicles take: its routes resolved to road ids (the spawner's road
/// first), or the quickest path to its destination.
fn spawn_routes(
    sp: &flockway_level::SpawnerSpec,
    network: &RoadNetwork,
) -> Result<Vec<SpawnRoute>, String> {
    let id = |name: &str| {
        network
            .id(name)
            .ok_or_else(|| format!("spawner `{}`: unknown road `{name}`", sp.name))
    };
    let start = id(&sp.road)?;
    let mut routes = Vec::new();
    for r in &sp.routes {
        let names: Vec<RoadId> = r.roads.iter().map(|n| id(n)).collect::<Result<_, _>>()?;
        routes.push(SpawnRoute {
            name: Arc::from(r.name.as_str()),
            roads: route_through(network, start, &names),
            weight: r.weight,
        });
    }
    if let Some(dest) = &sp.destination {
        let roads = network
            .shortest_path(start, id(dest)?)
            .ok_or_else(|| format!("spawner `{}`: road `{dest}` cannot be reached", sp.name))?;
        routes.push(SpawnRoute {
            name: Arc::from(dest.as_str()),
            roads,
            weight: 1.0,
        });
    }
    Ok(routes)
}

/// Puts a level's traffic into a world built by [`build_sim`]: telemetry settings, spawners,
/// destroyers, triggers and the initial vehicles (spawned now, on the level's roads).
pub fn populate(
    sim: &mut Sim,
    level: &Level,
    level_name: &str,
    types: &BTreeMap<String, Arc<VehicleType>>,
    profiles: &BTreeMap<String, DriverSpec>,
) -> Result<(), RunError> {
    let fail = |message: String| RunError::Roads {
        level: level_name.to_owned(),
        message,
    };
    let network =
        RoadNetwork::build_with(&level.roads, &level.junctions).map_err(|e| fail(e.to_string()))?;
    let road = |name: &str| {
        network
            .id(name)
            .ok_or_else(|| fail(format!("unknown road `{name}`")))
    };
    let ticks_of = |s: f64| (s * f64::from(TICKS_PER_SECOND)).round().max(0.0) as u64;
    // One shared name per profile, whichever spawners draw it: the measures tell profiles
    // apart by pointer before they compare names.
    let names: BTreeMap<&str, Arc<str>> = level
        .driver_profiles
        .iter()
        .map(|p| (p.name.as_str(), Arc::from(p.name.as_str())))
        .collect();
    let choice = |profile: &str, weight: f64| -> Result<SpawnChoice, RunError> {
        let driver = profiles.get(profile).cloned().ok_or_else(|| {
            fail(format!(
                "driver profile `{profile}` has a custom model that this program does not \
                 provide: drive it from Python (flockway.Sim or flockway.run with drivers=) or \
                 give it a built-in model (--driver {profile}=WaveDamper, say)"
            ))
        })?;
        let p = level
            .driver_profiles
            .iter()
            .find(|p| p.name == profile)
            .ok_or_else(|| fail(format!("unknown driver profile `{profile}`")))?;
        let vehicle = types
            .get(&p.vehicle)
            .cloned()
            .ok_or_else(|| fail(format!("unknown vehicle type `{}`", p.vehicle)))?;
        Ok(SpawnChoice {
            profile: names
                .get(profile)
                .cloned()
                .unwrap_or_else(|| Arc::from(profile)),
            weight,
            vehicle,
            driver,
        })
    };
    let world = sim.world_mut();
    world.insert_resource(TelemetrySettings {
        period_ticks: ticks_of(level.telemetry.period_s).max(1),
        stats_from_tick: ticks_of(level.telemetry.stats_from_s),
    });
    world.insert_resource(capacity_windows(level));
    world.insert_resource(SsmThresholds {
        ttc_s: level.ssm.ttc_s,
        pet_s: level.ssm.pet_s,
        drac_mps2: level.ssm.drac_mps2,
    });
    let streams = *world.resource::<RngStreams>();
    for (i, sp) in level.spawners.iter().enumerate() {
        let mut choices = sp
            .profiles
            .iter()
            .map(|c| choice(&c.profile, c.weight))
            .collect::<Result<Vec<_>, _>>()?;
        let routes = spawn_routes(sp, &network).map_err(fail)?;
        // A timetable's vehicles name their profile and route; a profile the shares leave out
        // joins the choices with weight 0 (never drawn, only named).
        let mut departures = Vec::with_capacity(sp.departures.len());
        for d in &sp.departures {
            let k = match choices.iter().position(|c| *c.profile == *d.profile) {
                Some(k) => k,
                None => {
                    choices.push(choice(&d.profile, 0.0)?);
                    choices.len() - 1
                }
            };
            let route = match &d.route {
                Some(name) => Some(routes.iter().position(|r| *r.name == **name).ok_or_else(
                    || fail(format!("spawner `{}`: no route named `{name}`", sp.name)),
                )?),
                None => None,
            };
            departures.push(Departure {
                tick: ticks_of(d.time_s),
                choice: k,
                route,
                speed_mps: d.speed_kmh.map(|v| (v / 3.6) as f32),
            });
        }
        let mut spawner = Spawner::new(
            sp.name.clone(),
            road(&sp.road)?,
            sp.lane,
            sp.s_m,
            (sp.interval_s.min, sp.interval_s.max),
            choices,
            sp.speed_kmh.map(|k| (k / 3.6) as f32),
            sp.active,
            sp.max_vehicles,
            streams.stream(StableId::new(IdKind::Spawner, i as u32)),
        )
        .with_routes(routes)
        .with_schedule(
            sp.schedule
                .iter()
                .map(|step| {
                    (
                        ticks_of(step.from_s),
                        step.interval_s.min,
                        step.interval_s.max,
                    )
                })
                .collect(),
        )
        .with_random_arrivals(sp.arrivals == flockway_level::Arrivals::Random);
        if !departures.is_empty() {
            spawner = spawner.with_timetable(departures);
        }
        world.spawn((spawner, StableId::new(IdKind::Spawner, i as u32)));
    }
    for (i, d) in level.destroyers.iter().enumerate() {
        let place = match &d.place {
            flockway_level::DestroyerPlaceSpec::OnRoad { road: r, s_m } => DestroyerPlace::OnRoad {
                road: road(r)?,
                s_m: *s_m,
            },
            flockway_level::DestroyerPlaceSpec::Volume { min, max } => DestroyerPlace::Volume {
                min: min.as_vec3(),
                max: max.as_vec3(),
            },
        };
        world.spawn((
            Destroyer {
                name: d.name.clone(),
                place,
                arrivals_only: d.arrivals_only,
            },
            StableId::new(IdKind::Destroyer, i as u32),
        ));
    }
    for (i, t) in level.triggers.iter().enumerate() {
        let effect = trigger_effect(&t.effect);
        world.spawn((
            Trigger {
                name: t.name.clone(),
                road: road(&t.road)?,
                from_m: t.from_m,
                to_m: t.to_m,
                lanes: t.lanes.clone(),
                effect,
            },
            StableId::new(IdKind::Trigger, i as u32),
        ));
    }
    if !level.detectors.is_empty() {
        let mut list = Vec::with_capacity(level.detectors.len());
        for d in &level.detectors {
            let id = road(&d.road)?;
            let lanes = match &d.lanes {
                Some(lanes) => {
                    let mut lanes = lanes.clone();
                    lanes.sort_unstable();
                    lanes.dedup();
                    lanes
                }
                None => (0..network.get(id).map_or(1, |g| g.lanes())).collect(),
            };
            list.push(Detector {
                name: d.name.clone(),
                road: id,
                s_m: d.s_m,
                lanes,
                period_ticks: ticks_of(d.period_s).max(1),
            });
        }
        world.insert_resource(Detectors::new(list));
    }
    // Initial vehicles need the network now; the first step finds it built from the same road
    // components and keeps it.
    world.insert_resource(network.clone());
    for (gi, group) in level.vehicles.iter().enumerate() {
        let id = road(&group.road)?;
        let Some(g) = network.get(id) else { continue };
        let c = choice(&group.profile, 1.0)?;
        let mut rng = streams.stream(StableId::new(IdKind::InitialVehicles, gi as u32));
        let from = group.from_m;
        let span = match group.to_m {
            Some(to) => to - from,
            None if g.is_closed() => g.length_m(),
            None => g.length_m() - from,
        };
        let count = f64::from(group.count.max(1));
        let width = g.frame_at(from).width_m;
        let lateral = flockway_road::lane_offset(width, g.lanes(), group.lane);
        let speed = group.speed_kmh.unwrap_or(0.0) as f32 / 3.6;
        for k in 0..group.count {
            let jitter = if group.jitter_m > 0.0 {
                rng.uniform(-group.jitter_m, group.jitter_m)
            } else {
                0.0
            };
            let s = g.normalize_s(from + span * f64::from(k) / count + jitter);
            let spawn = VehicleSpawn::new(c.vehicle.clone(), id, s)
                .lateral(lateral)
                .speed(speed);
            spawn_driven(world, spawn, &c.driver, group.lane, c.profile.clone())
                .map_err(|e| fail(e.to_string()))?;
        }
    }
    Ok(())
}

/// How long after a change of demand capacity is not measured, s: the new stream has to reach
/// the junctions first.
pub const CAPACITY_SETTLE_S: f64 = 30.0;

/// The windows junction capacity is measured over: from the warm-up's end to the run's, split at
/// every demand step of every spawner, each from [`CAPACITY_SETTLE_S`] after its start.
pub fn capacity_windows(level: &Level) -> CapacityWindows {
    let start = level.telemetry.stats_from_s;
    let mut cuts: Vec<f64> = level
        .spawners
        .iter()
        .flat_map(|sp| sp.schedule.iter().map(|step| step.from_s))
        .filter(|&t| t > start && t < level.duration_s)
        .collect();
    cuts.push(start);
    cuts.push(level.duration_s);
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    let tick = |s: f64| (s * f64::from(TICKS_PER_SECOND)).round() as u64;
    CapacityWindows(
        cuts.windows(2)
            .filter(|w| w[1] - w[0] > CAPACITY_SETTLE_S)
            .map(|w| (tick(w[0] + CAPACITY_SETTLE_S), tick(w[1])))
            .collect(),
    )
}

/// A level file's trigger effect as the traffic crate applies it.
fn trigger_effect(spec: &flockway_level::TriggerEffectSpec) -> TriggerEffect {
    match *spec {
        flockway_level::TriggerEffectSpec::SpeedLimit { kmh } => {
            TriggerEffect::SpeedLimit(kmh as f32)
        }
        flockway_level::TriggerEffectSpec::Friction { scale } => {
            TriggerEffect::Friction(scale as f32)
        }
    }
}

//! The drivers in the full simulation: lane keeping, speed holding, car following, lane changes,
//! human-like speeds and determinism.

use bevy_ecs::prelude::*;
use flockway_core::{IdKind, RngStreams, Sim, StableId, TICKS_PER_SECOND};
use flockway_drivers::{BuiltinModel, DriverSpec, DriversPlugin};
use flockway_road::{Road, RoadId, RoadSpec, lane_offset};
use flockway_vehicle::{
    ContactWith, Motion, RoadTrack, VehicleContact, VehicleParams, VehicleSpawn, VehicleType,
    spawn_vehicle,
};
use glam::DVec3;
use std::path::Path;
use std::sync::Arc;

fn world_with(roads: Vec<RoadSpec>, seed: u64) -> Sim {
    let mut sim = Sim::new(seed);
    sim.add_plugin(DriversPlugin);
    for (i, spec) in roads.into_iter().enumerate() {
        sim.world_mut().spawn((RoadId(i as u32), Road(spec)));
    }
    sim.prepare().expect("the driver systems are unambiguous");
    sim.step();
    sim
}

fn ticks(seconds: f32) -> u64 {
    (seconds * TICKS_PER_SECOND as f32) as u64
}

/// Spawns a driven car in `lane` at `s_m`, moving at `kmh`.
fn car(sim: &mut Sim, model: BuiltinModel, lane: u32, s_m: f64, kmh: f32, id: u32) -> Entity {
    car_with(sim, DriverSpec::default_for(model), lane, s_m, kmh, id)
}

fn car_with(sim: &mut Sim, spec: DriverSpec, lane: u32, s_m: f64, kmh: f32, id: u32) -> Entity {
    let geometry = sim
        .world()
        .resource::<flockway_road::RoadNetwork>()
        .get(RoadId(0))
        .expect("road 0")
        .clone();
    let width = geometry.frame_at(s_m).width_m;
    let lateral = lane_offset(width, geometry.lanes(), lane);
    let vehicle = if spec.model() == BuiltinModel::Human {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/vehicles/sedan_human.ron");
        VehicleType::new(VehicleParams::load(&path).expect("sedan_human.ron"))
    } else {
        VehicleType::default()
    };
    let entity = spawn_vehicle(
        sim.world_mut(),
        VehicleSpawn {
            model: Arc::new(vehicle),
            road: RoadId(0),
            s_m,
            lateral_m: lateral,
            speed_mps: kmh / 3.6,
        },
    )
    .expect("spawns");
    let mut rng = sim
        .world()
        .resource::<RngStreams>()
        .stream(StableId::new(IdKind::Vehicle, id));
    let mut e = sim.world_mut().entity_mut(entity);
    spec.insert(&mut e, lane, &mut rng);
    entity
}

fn motion(sim: &Sim, e: Entity) -> Motion {
    *sim.world().get::<Motion>(e).expect("motion")
}

fn track(sim: &Sim, e: Entity) -> RoadTrack {
    *sim.world().get::<RoadTrack>(e).expect("track")
}

fn straight(lanes: u32, kmh: f64, length_m: f64) -> RoadSpec {
    let n = (length_m / 250.0).ceil() as usize;
    let pts: Vec<DVec3> = (0..=n)
        .map(|i| DVec3::new(length_m * i as f64 / n as f64, 0.0, 0.0))
        .collect();
    RoadSpec::through("straight", lanes, kmh, &pts)
}

/// A road with a 200 m radius quarter turn to the left between two straights.
fn curved(lanes: u32, kmh: f64) -> RoadSpec {
    let mut pts = vec![
        DVec3::new(-400.0, -200.0, 0.0),
        DVec3::new(-200.0, -200.0, 0.0),
    ];
    for i in 0..=8 {
        let a = -std::f64::consts::FRAC_PI_2 + std::f64::consts::FRAC_PI_2 * f64::from(i) / 8.0;
        pts.push(DVec3::new(200.0 * a.cos(), 200.0 * a.sin(), 0.0));
    }
    pts.push(DVec3::new(200.0, 200.0, 0.0));
    pts.push(DVec3::new(200.0, 500.0, 0.0));
    pts.push(DVec3::new(200.0, 900.0, 0.0));
    RoadSpec::through("curve", lanes, kmh, &pts)
}

fn lane_error(sim: &Sim, e: Entity, lane: u32) -> f64 {
    let t = track(sim, e);
    let geometry = sim
        .world()
        .resource::<flockway_road::RoadNetwork>()
        .get(t.road)
        .expect("road")
        .clone();
    (t.lateral_m - lane_offset(f64::from(t.width_m), geometry.lanes(), lane)).abs()
}

/// Ten lane-keeping cars on three lanes, spawned 0.15 m off their lane centres at 55 km/h:
/// the worst speed error (km/h) and lane-centre error (m) after `settle_s`, over `measure_s`.
fn ten_cars(road: RoadSpec, settle_s: f32, measure_s: f32) -> (f32, f64) {
    let mut sim = world_with(vec![road], 1);
    let cars: Vec<(Entity, u32)> = (0..10u32)
        .map(|i| {
            let lane = i % 3;
            let s = 120.0 + f64::from(i / 3) * 60.0 + f64::from(lane) * 13.0;
            let e = car(&mut sim, BuiltinModel::FlockLanes, lane, s, 55.0, i);
            (e, lane)
        })
        .collect();
    for (i, &(e, _)) in cars.iter().enumerate() {
        let off = if i % 2 == 0 { 0.15 } else { -0.15 };
        let body = sim
            .world()
            .get::<flockway_vehicle::Chassis>(e)
            .expect("chassis")
            .body;
        let mut physics = sim.world_mut().resource_mut::<flockway_vehicle::Physics>();
        if let Some(b) = physics.world.bodies.get_mut(body) {
            let mut pose = *b.position();
            pose.translation += pose.rotation * glam::Vec3::new(0.0, off, 0.0);
            b.set_position(pose, true);
        }
    }
    sim.run_ticks(ticks(settle_s));
    let (mut worst_speed, mut worst_lane) = (0.0f32, 0.0f64);
    for _ in 0..ticks(measure_s) {
        sim.step();
        for &(e, lane) in &cars {
            worst_speed = worst_speed.max((motion(&sim, e).forward_mps * 3.6 - 60.0).abs());
            worst_lane = worst_lane.max(lane_error(&sim, e, lane));
        }
    }
    (worst_speed, worst_lane)
}

#[test]
fn ten_lane_keeping_cars_hold_60_kmh_and_their_lanes_on_a_straight() {
    let (speed, lane) = ten_cars(straight(3, 60.0, 3000.0), 15.0, 30.0);
    eprintln!("straight: speed error {speed} km/h, lane error {lane} m");
    assert!(speed <= 1.0, "speed strayed {speed} km/h from 60");
    assert!(lane <= 0.3, "strayed {lane} m from the lane centre");
}

#[test]
fn ten_lane_keeping_cars_hold_their_lanes_through_a_curve() {
    // From the straight through the 200 m curve and onto the next straight.
    let (speed, lane) = ten_cars(curved(3, 60.0), 10.0, 40.0);
    eprintln!("curve: speed error {speed} km/h, lane error {lane} m");
    assert!(lane <= 0.5, "strayed {lane} m from the lane centre");
    assert!(speed <= 3.0, "speed strayed {speed} km/h from 60");
}

#[test]
fn a_driver_with_an_action_step_holds_its_speed_between_decisions_and_keeps_its_lane() {
    // An IDM car deciding every 0.1 s (12 ticks) through the 200 m curve: its asked-for
    // acceleration changes at most once per step, while its heading follows the lane each tick.
    let mut sim = world_with(vec![curved(3, 60.0)], 2);
    let set = std::collections::BTreeMap::from([("action_step_s".to_owned(), 0.1)]);
    let spec = DriverSpec::build(BuiltinModel::Idm, None, &set).expect("valid");
    let me = car_with(&mut sim, spec, 1, 100.0, 40.0, 0);
    let target = |sim: &Sim| {
        *sim.world()
            .get::<flockway_drivers::DriveTarget>(me)
            .expect("target")
    };
    let (mut accel_changes, mut heading_changes, mut worst_lane) = (0, 0, 0.0f64);
    let mut last = target(&sim);
    let n = ticks(40.0);
    for _ in 0..n {
        sim.step();
        let now = target(&sim);
        accel_changes += usize::from(now.accel_mps2 != last.accel_mps2);
        heading_changes += usize::from(now.heading_rad != last.heading_rad);
        worst_lane = worst_lane.max(lane_error(&sim, me, 1));
        last = now;
    }
    let steps = n as usize / 12;
    eprintln!(
        "action step: {accel_changes} speed decisions, {heading_changes} heading updates in {n} \
         ticks; lane error {worst_lane} m"
    );
    assert!(
        accel_changes <= steps + 1,
        "{accel_changes} changes of its decision in {steps} steps"
    );
    assert!(
        heading_changes > 5 * steps,
        "its heading held between decisions ({heading_changes} updates)"
    );
    assert!(
        worst_lane <= 0.5,
        "strayed {worst_lane} m from the lane centre"
    );
    assert!(
        (motion(&sim, me).forward_mps * 3.6 - 60.0).abs() < 3.0,
        "not at the limit"
    );
}

/// A scripted leader braking from 60 km/h to a stop at 6 m/s², and a follower driven by `model`
/// settled behind it: the smallest bumper gap (m) and whether the two bodies ever touched.
fn brake_test(model: BuiltinModel) -> (f32, bool, f32) {
    let mut sim = world_with(vec![straight(3, 60.0, 3000.0)], 3);
    let leader = car(&mut sim, BuiltinModel::FlockLanes, 1, 400.0, 60.0, 0);
    // The test drives the leader: remove its driver, keep the shared controller.
    sim.world_mut()
        .entity_mut(leader)
        .remove::<flockway_drivers::FlockDriver>();
    let follower = car(&mut sim, model, 1, 340.0, 60.0, 1);
    let set_leader = |sim: &mut Sim, kmh: f32| {
        let mut t = sim
            .world_mut()
            .get_mut::<flockway_drivers::DriveTarget>(leader)
            .expect("target");
        t.speed_mps = kmh / 3.6;
        t.heading_rad = 0.0;
    };
    for _ in 0..ticks(20.0) {
        set_leader(&mut sim, 60.0);
        sim.step();
    }
    let gap = |sim: &Sim| motion(sim, leader).position.x - motion(sim, follower).position.x - 4.6;
    let mut min_gap = gap(&sim);
    let mut touched = false;
    let settled_gap = min_gap;
    for i in 0..ticks(20.0) {
        let t = i as f32 / TICKS_PER_SECOND as f32;
        set_leader(&mut sim, (60.0 - 6.0 * 3.6 * t).max(0.0));
        sim.step();
        min_gap = min_gap.min(gap(&sim));
        let contacts = sim.world().resource::<Messages<VehicleContact>>();
        touched |= contacts.iter_current_update_messages().any(|c| {
            c.started
                && ((c.vehicle == follower && c.other == ContactWith::Vehicle(leader))
                    || (c.vehicle == leader && c.other == ContactWith::Vehicle(follower)))
        });
    }
    assert!(
        motion(&sim, leader).forward_mps.abs() < 0.2,
        "the leader stopped"
    );
    assert!(
        motion(&sim, follower).forward_mps.abs() < 0.5,
        "the follower stopped"
    );
    (min_gap, touched, settled_gap)
}

#[test]
fn a_flock_car_stops_behind_a_leader_braking_at_6_mps2() {
    let (min_gap, touched, settled) = brake_test(BuiltinModel::FlockLanes);
    eprintln!("flock: following gap {settled} m, smallest gap {min_gap} m");
    assert!(!touched && min_gap > 0.5, "gap fell to {min_gap} m");
}

#[test]
fn an_idm_car_stops_behind_a_leader_braking_at_6_mps2() {
    let (min_gap, touched, settled) = brake_test(BuiltinModel::Idm);
    eprintln!("idm: following gap {settled} m, smallest gap {min_gap} m");
    assert!(!touched && min_gap > 0.5, "gap fell to {min_gap} m");
}

#[test]
fn a_lane_change_on_command_completes_smoothly_and_yields_first() {
    let mut sim = world_with(vec![straight(3, 60.0, 3000.0)], 5);
    let me = car(&mut sim, BuiltinModel::FlockLanes, 0, 300.0, 60.0, 0);
    // A car level with it in the middle lane: it must wait for it to pass.
    let other = car(&mut sim, BuiltinModel::FlockLanes, 1, 302.0, 60.0, 1);
    sim.world_mut()
        .get_mut::<flockway_drivers::FlockDriver>(other)
        .expect("driver")
        .params
        .target_speed_kmh = Some(75.0);
    sim.run_ticks(ticks(2.0));
    sim.world_mut()
        .get_mut::<flockway_drivers::LaneChoice>(me)
        .expect("driver")
        .target_lane = 1;
    let width = f64::from(track(&sim, me).width_m);
    let centre = |lane| lane_offset(width, 3, lane) as f32;
    let mut started = None;
    let mut done = None;
    let mut widest = f32::MIN;
    let mut touched = false;
    for i in 0..ticks(20.0) {
        sim.step();
        let t = track(&sim, me);
        let lateral = t.lateral_m as f32;
        widest = widest.max(lateral);
        let lane_now = sim
            .world()
            .get::<flockway_drivers::LaneChoice>(me)
            .expect("driver")
            .lane;
        if lane_now == 1 && started.is_none() {
            started = Some(i);
            // It waited for the car alongside to get clear ahead.
            let gap = track(&sim, other).s_m - t.s_m;
            assert!(
                gap > 10.0,
                "it moved over with the other car only {gap} m ahead"
            );
        }
        if started.is_some() && done.is_none() && (lateral - centre(1)).abs() < 0.3 {
            done = Some(i);
        }
        let contacts = sim.world().resource::<Messages<VehicleContact>>();
        touched |= contacts
            .iter_current_update_messages()
            .any(|c| c.started && matches!(c.other, ContactWith::Vehicle(_)));
    }
    let (started, done) = (
        started.expect("it changed lane"),
        done.expect("it reached the lane"),
    );
    let seconds = (done - started) as f32 / TICKS_PER_SECOND as f32;
    eprintln!(
        "lane change: {seconds} s, furthest {widest} m (lane 1 centre {})",
        centre(1)
    );
    assert!(seconds < 6.0, "the lane change took {seconds} s");
    // Lane 2 starts 1.5 m past lane 1's centre: it never crosses into it.
    assert!(
        widest < centre(1) + 1.5 - 0.9,
        "it reached {widest} m, into lane 2"
    );
    assert!(!touched, "a contact during the lane change");
}

#[test]
fn human_desired_speeds_span_ten_percent_and_follow_the_seed() {
    let draw = |seed: u64| -> Vec<f32> {
        let mut world = World::new();
        let streams = RngStreams::new(seed);
        let spec = DriverSpec::default_for(BuiltinModel::Human);
        (0..1000u32)
            .map(|i| {
                let mut rng = streams.stream(StableId::new(IdKind::Vehicle, i));
                let mut e = world.spawn_empty();
                spec.insert(&mut e, 0, &mut rng);
                assert!(e.get::<flockway_drivers::HumanDriver>().is_some());
                e.get::<flockway_drivers::SpeedFactor>()
                    .expect("a speed factor")
                    .0
            })
            .collect()
    };
    let a = draw(7);
    let (lo, hi) = a
        .iter()
        .fold((f32::MAX, f32::MIN), |(lo, hi), &f| (lo.min(f), hi.max(f)));
    let mean = a.iter().sum::<f32>() / a.len() as f32;
    assert!(lo >= 0.9 && hi <= 1.1, "{lo}..{hi}");
    assert!(
        lo < 0.905 && hi > 1.095,
        "1000 draws should reach near both ends: {lo}..{hi}"
    );
    assert!((mean - 1.0).abs() < 0.01, "mean {mean}");
    assert_eq!(a, draw(7), "the same seed gives the same speeds");
    assert_ne!(a, draw(8), "another seed gives other speeds");
}

/// Ten mixed cars on a ring: final positions as bits.
fn mixed_ring(seed: u64) -> Vec<[u32; 3]> {
    let ring = RoadSpec::ring("ring", 2, 50.0, DVec3::ZERO, 120.0, 16);
    let mut sim = world_with(vec![ring], seed);
    let models = [
        BuiltinModel::FlockLanes,
        BuiltinModel::Human,
        BuiltinModel::Idm,
        BuiltinModel::Flock,
    ];
    let cars: Vec<Entity> = (0..10u32)
        .map(|i| {
            car(
                &mut sim,
                models[i as usize % 4],
                i % 2,
                f64::from(i) * 70.0,
                40.0,
                i,
            )
        })
        .collect();
    sim.run_ticks(ticks(20.0));
    cars.iter()
        .map(|&e| {
            let p = motion(&sim, e).position;
            [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
        })
        .collect()
}

#[test]
fn same_seed_same_trajectories_and_another_seed_differs() {
    let a = mixed_ring(11);
    assert_eq!(a, mixed_ring(11));
    assert_ne!(a, mixed_ring(12), "human desired speeds depend on the seed");
}

/// 22 cars of one model on the 230 m Sugiyama ring at a 30 km/h limit, spread evenly: after
/// `settle_s`, the mean over samples of the speed spread across cars and the lowest speed seen
/// (km/h).
fn sugiyama(model: BuiltinModel, settle_s: u32, measure_s: u32) -> (f32, f32) {
    let mut ring = RoadSpec::ring(
        "ring",
        1,
        30.0,
        DVec3::ZERO,
        230.0 / std::f64::consts::TAU,
        16,
    );
    ring.lane_width_m = 3.5;
    let mut sim = world_with(vec![ring], 2008);
    let cars: Vec<Entity> = (0..22u32)
        .map(|i| car(&mut sim, model, 0, f64::from(i) * 230.0 / 22.0, 25.0, i))
        .collect();
    sim.run_ticks(ticks(settle_s as f32));
    let (mut spread, mut lowest) = (0.0f32, f32::MAX);
    for _ in 0..measure_s {
        sim.run_ticks(ticks(1.0));
        let v: Vec<f32> = cars
            .iter()
            .map(|&c| motion(&sim, c).forward_mps * 3.6)
            .collect();
        let mean = v.iter().sum::<f32>() / v.len() as f32;
        spread += (v.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / v.len() as f32).sqrt();
        lowest = v.iter().fold(lowest, |a, &x| a.min(x));
    }
    (spread / measure_s as f32, lowest)
}

#[test]
fn human_drivers_form_stop_and_go_on_the_sugiyama_ring_and_autonomous_ones_do_not() {
    let (human_spread, human_lowest) = sugiyama(BuiltinModel::Human, 30, 40);
    let (auto_spread, auto_lowest) = sugiyama(BuiltinModel::FlockLanes, 30, 40);
    eprintln!(
        "sugiyama: human spread {human_spread} km/h, lowest {human_lowest}; \
         autonomous spread {auto_spread}, lowest {auto_lowest}"
    );
    assert!(
        human_spread > 5.0 && human_lowest < 5.0,
        "no stop-and-go: {human_spread}, {human_lowest}"
    );
    assert!(
        auto_spread < 1.0 && auto_lowest > 25.0,
        "autonomous cars jammed: {auto_spread}"
    );
}

#[test]
fn every_model_draws_its_speed_factor_from_its_profile_and_none_without_a_deviation() {
    let draw = |model: BuiltinModel, overrides: &[(&str, f64)], seed: u64| -> Vec<f32> {
        let mut world = World::new();
        let streams = RngStreams::new(seed);
        let set = overrides
            .iter()
            .map(|(k, v)| ((*k).to_owned(), *v))
            .collect();
        let spec = DriverSpec::build(model, None, &set).expect("valid overrides");
        (0..2000u32)
            .map(|i| {
                let mut rng = streams.stream(StableId::new(IdKind::Vehicle, i));
                let mut e = world.spawn_empty();
                spec.insert(&mut e, 0, &mut rng);
                e.get::<flockway_drivers::SpeedFactor>()
                    .expect("a speed factor")
                    .0
            })
            .collect()
    };
    let stats = |xs: &[f32]| {
        let n = xs.len() as f64;
        let mean = xs.iter().map(|&x| f64::from(x)).sum::<f64>() / n;
        let var = xs
            .iter()
            .map(|&x| (f64::from(x) - mean).powi(2))
            .sum::<f64>()
            / n;
        (mean, var.sqrt())
    };
    for (model, prefix) in [
        (BuiltinModel::Flock, ""),
        (BuiltinModel::FlockLanes, ""),
        (BuiltinModel::Idm, ""),
        (BuiltinModel::WaveDamper, "flock."),
    ] {
        // No deviation: everyone drives the mean, and no number is drawn from the stream.
        assert!(draw(model, &[], 1).iter().all(|&f| f == 1.0), "{model:?}");
        let mean = format!("{prefix}speed_factor.mean");
        let dev = format!("{prefix}speed_factor.dev");
        let max = format!("{prefix}speed_factor.max");
        let xs = draw(model, &[(&mean, 1.1), (&dev, 0.1), (&max, 1.25)], 3);
        let (m, sd) = stats(&xs);
        // Clipping at 1.5 σ above pulls the mean and the spread in a little (1.097 and 0.094).
        assert!((m - 1.097).abs() < 0.01, "{model:?}: mean {m}");
        assert!((sd - 0.094).abs() < 0.01, "{model:?}: deviation {sd}");
        assert!(xs.iter().all(|&f| (0.2..=1.25).contains(&f)), "{model:?}");
        assert!(xs.contains(&1.25), "{model:?}: the clip is reached");
        assert_eq!(
            xs,
            draw(model, &[(&mean, 1.1), (&dev, 0.1), (&max, 1.25)], 3)
        );
    }
    // A human's own spread multiplies the profile's factor.
    let xs = draw(
        BuiltinModel::Human,
        &[("flock.speed_factor.mean", 0.8), ("speed_spread", 0.1)],
        4,
    );
    let (lo, hi) = xs
        .iter()
        .fold((f32::MAX, f32::MIN), |(lo, hi), &f| (lo.min(f), hi.max(f)));
    assert!(
        lo >= 0.72 - 1e-6 && hi <= 0.88 + 1e-6 && lo < 0.73 && hi > 0.87,
        "{lo}..{hi}"
    );
}

//! The sedan in the full simulation: the dyno figures of the thesis's car (§3.2.2), straight-line and banked-curve
//! behaviour, parking, determinism and clean removal.

use bevy_ecs::prelude::*;
use flockway_core::{Sim, TICKS_PER_SECOND};
use flockway_road::{ControlPoint, Road, RoadId, RoadNetwork, RoadSpec};
use flockway_vehicle::{
    Controls, DynoSettings, Motion, Physics, RoadTrack, VehicleContact, VehicleParams,
    VehiclePlugin, VehicleSpawn, VehicleState, VehicleType, run_dyno, spawn_vehicle,
};
use glam::DVec3;
use std::path::Path;
use std::sync::Arc;

fn world_with(roads: Vec<RoadSpec>) -> Sim {
    let mut sim = Sim::new(7);
    sim.add_plugin(VehiclePlugin);
    for (i, spec) in roads.into_iter().enumerate() {
        sim.world_mut().spawn((RoadId(i as u32), Road(spec)));
    }
    sim.prepare()
        .expect("the vehicle plugin's systems are unambiguous");
    sim.step();
    sim
}

fn spawn(sim: &mut Sim, road: u32, s_m: f64, lateral_m: f64, speed_mps: f32) -> Entity {
    spawn_model(
        sim,
        Arc::new(VehicleType::default()),
        road,
        s_m,
        lateral_m,
        speed_mps,
    )
}

fn spawn_model(
    sim: &mut Sim,
    model: Arc<VehicleType>,
    road: u32,
    s_m: f64,
    lateral_m: f64,
    speed_mps: f32,
) -> Entity {
    spawn_vehicle(
        sim.world_mut(),
        VehicleSpawn {
            model,
            road: RoadId(road),
            s_m,
            lateral_m,
            speed_mps,
        },
    )
    .expect("road 0 exists")
}

fn set(sim: &mut Sim, car: Entity, controls: Controls) {
    *sim.world_mut()
        .get_mut::<Controls>(car)
        .expect("a vehicle has controls") = controls;
}

fn motion(sim: &Sim, car: Entity) -> Motion {
    *sim.world()
        .get::<Motion>(car)
        .expect("a vehicle has motion")
}

fn straight(length_m: f64) -> RoadSpec {
    let n = (length_m / 250.0).ceil() as usize;
    let pts: Vec<DVec3> = (0..=n)
        .map(|i| DVec3::new(length_m * i as f64 / n as f64, 0.0, 0.0))
        .collect();
    RoadSpec::through("straight", 3, 100.0, &pts)
}

/// Road `a` (100 m along x) leading onto road `b` (the next 100 m), both of `lanes` lanes at
/// 50 km/h.
fn end_to_start(lanes: u32) -> (RoadSpec, RoadSpec) {
    let mut a = RoadSpec::through(
        "a",
        lanes,
        50.0,
        &[DVec3::ZERO, DVec3::new(100.0, 0.0, 0.0)],
    );
    a.next = Some("b".into());
    let b = RoadSpec::through(
        "b",
        lanes,
        50.0,
        &[DVec3::new(100.0, 0.0, 0.0), DVec3::new(200.0, 0.0, 0.0)],
    );
    (a, b)
}

fn ticks(seconds: f32) -> u32 {
    (seconds * TICKS_PER_SECOND as f32) as u32
}

#[test]
fn the_reference_sedan_meets_the_spec_on_the_dyno() {
    let model = Arc::new(VehicleType::default());
    let r = run_dyno(&model, &DynoSettings::default());
    let t100 = r.zero_to_100_kmh_s.expect("the sedan reaches 100 km/h");
    assert!((9.0..=11.0).contains(&t100), "0-100 km/h in {t100} s");
    assert!(
        (168.0..=178.0).contains(&r.top_speed_kmh),
        "top speed {} km/h",
        r.top_speed_kmh
    );
    assert!(
        (33.0..=45.0).contains(&r.braking_100_0_m),
        "100-0 km/h in {} m",
        r.braking_100_0_m
    );
    assert!(
        (0.75..=1.0).contains(&r.max_lateral_g),
        "lateral grip {} g",
        r.max_lateral_g
    );
    assert!(
        r.standstill_drift_m < 0.01,
        "drift {} m",
        r.standstill_drift_m
    );
}

#[test]
fn shipped_vehicle_files_load_and_sedan_ron_is_the_reference_car() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/vehicles");
    let sedan = VehicleParams::load(&root.join("sedan.ron")).expect("sedan.ron is valid");
    assert_eq!(
        sedan,
        VehicleParams::default(),
        "sedan.ron and the defaults drifted apart"
    );
    let human = VehicleParams::load(&root.join("sedan_human.ron")).expect("sedan_human.ron");
    assert_eq!(human.name, "sedan_human");
    for rpm in [0.0, 500.0, 1000.0, 1500.0, 1900.0] {
        assert!(
            human.engine.torque_at(rpm) > sedan.engine.torque_at(rpm),
            "the human car has more torque at {rpm} rpm"
        );
    }
    assert_eq!(human.chassis, sedan.chassis);
}

#[test]
fn the_human_sedan_pulls_away_harder() {
    let run = |model: VehicleParams| {
        let mut sim = world_with(vec![straight(400.0)]);
        let car = spawn_model(
            &mut sim,
            Arc::new(VehicleType::new(model)),
            0,
            20.0,
            0.0,
            0.0,
        );
        // Part throttle from rest, as a driver pulls away: more low-rpm torque shows directly.
        set(
            &mut sim,
            car,
            Controls {
                throttle: 0.4,
                ..Controls::default()
            },
        );
        sim.run_ticks(u64::from(ticks(2.0)));
        motion(&sim, car).forward_mps
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/vehicles");
    let human = VehicleParams::load(&root.join("sedan_human.ron")).expect("valid");
    let (v_ref, v_human) = (run(VehicleParams::default()), run(human));
    assert!(
        v_human > v_ref * 1.1,
        "after 2 s: reference {v_ref} m/s, human {v_human} m/s"
    );
}

#[test]
fn held_straight_at_constant_throttle_it_stays_on_its_line_for_500_m() {
    let mut sim = world_with(vec![straight(800.0)]);
    let car = spawn(&mut sim, 0, 20.0, 1.5, 0.0);
    set(
        &mut sim,
        car,
        Controls {
            throttle: 0.6,
            ..Controls::default()
        },
    );
    let start = motion(&sim, car).position;
    let mut worst = 0.0f32;
    for _ in 0..ticks(120.0) {
        sim.step();
        let m = motion(&sim, car);
        worst = worst.max((m.position.y - start.y).abs());
        if m.position.x - start.x > 500.0 {
            break;
        }
    }
    let m = motion(&sim, car);
    assert!(m.position.x - start.x > 500.0, "it covered 500 m");
    assert!(worst < 0.05, "it strayed {worst} m from its line");
}

/// Drives one lap of a ring of `radius` at `v` with a line-holding controller around the
/// kinematic steering angle: (worst distance from the line after settling, mean steering
/// correction beyond the kinematic angle in degrees, mean total lateral tyre force in N).
fn lap(radius: f64, bank_deg: f64, v: f32) -> (f32, f32, f32) {
    let mut spec = RoadSpec::ring("ring", 2, 60.0, DVec3::ZERO, radius, 24);
    for p in &mut spec.points {
        *p = ControlPoint {
            bank_deg,
            ..p.clone()
        };
    }
    let mut sim = world_with(vec![spec]);
    let car = spawn(&mut sim, 0, 0.0, 0.0, v);
    let params = VehicleParams::default();
    let kinematic = (params.wheels.wheelbase_m / radius as f32).atan();
    let full_lock = params.steering.center_angle_rad(1.0, v * 3.6);
    let lap_ticks = ticks((std::f64::consts::TAU * radius) as f32 / v);
    let (mut worst, mut correction, mut lateral, mut n) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
    let mut integral = 0.0f32;
    for i in 0..lap_ticks {
        let m = motion(&sim, car);
        let track = *sim.world().get::<RoadTrack>(car).expect("track");
        // Lateral offset is positive towards the centre (left on a counter-clockwise ring).
        let angle = kinematic - 0.01 * track.lateral_m as f32;
        integral = (integral + (v - m.forward_mps) / TICKS_PER_SECOND as f32).clamp(-2.0, 2.0);
        let throttle = (0.15 + 0.5 * (v - m.forward_mps) + 0.5 * integral).clamp(-1.0, 1.0);
        set(
            &mut sim,
            car,
            Controls {
                throttle,
                steering: angle / full_lock,
                handbrake: false,
            },
        );
        sim.step();
        if i > ticks(3.0) {
            worst = worst.max(track.lateral_m.abs() as f32);
            correction += (angle - kinematic).to_degrees();
            let st = sim.world().get::<VehicleState>(car).expect("state");
            lateral += st.wheels.iter().map(|w| w.force_lat_n).sum::<f32>();
            n += 1.0;
        }
    }
    (worst, correction / n, lateral / n)
}

#[test]
fn on_a_banked_curve_at_its_balance_speed_it_holds_its_line_with_near_zero_steering() {
    // 4 % bank; the balance speed is where gravity along the bank supplies the centripetal
    // force: v² = g R tan θ. A counter-clockwise ring turns left, so its right edge rises:
    // negative bank.
    let radius = 120.0f64;
    let bank_deg = -0.04f64.atan().to_degrees();
    let v = (9.81 * radius * 0.04).sqrt() as f32;
    let (worst, correction, lateral) = lap(radius, bank_deg, v);
    // The line is the spline, whose radius wiggles a little between its 24 control points.
    assert!(worst < 0.25, "strayed {worst} m from the line");
    assert!(
        correction.abs() < 0.01,
        "steered {correction}° beyond the kinematic angle"
    );
    let needed_flat = 1500.0 * v * v / radius as f32;
    assert!(
        lateral.abs() < 0.05 * needed_flat,
        "cornering force {lateral} N on the bank, {needed_flat} N needed on the flat"
    );
    // On the flat, the same lap needs the full cornering force from the tyres.
    let (_, _, flat) = lap(radius, 0.0, v);
    assert!(
        (flat - needed_flat).abs() < 0.15 * needed_flat,
        "flat cornering force {flat} N, expected about {needed_flat} N"
    );
}

#[test]
fn a_parked_car_stays_still_on_the_flat_a_bank_and_a_slope() {
    // Flat, no input.
    let mut sim = world_with(vec![straight(200.0)]);
    let car = spawn(&mut sim, 0, 100.0, 0.0, 0.0);
    let start = motion(&sim, car).position;
    sim.run_ticks(u64::from(ticks(60.0)));
    let m = motion(&sim, car);
    assert!((m.position - start).truncate().length() < 0.01);
    assert!(m.linvel.length() < 1.0e-3, "jitter {:?}", m.linvel);

    // A 4 % cross slope (banked straight), no input: the tyres hold it sideways.
    let mut spec = straight(200.0);
    for p in &mut spec.points {
        *p = ControlPoint {
            bank_deg: 0.04f64.atan().to_degrees(),
            ..p.clone()
        };
    }
    let mut sim = world_with(vec![spec]);
    let car = spawn(&mut sim, 0, 100.0, 0.0, 0.0);
    sim.run_ticks(u64::from(ticks(1.0)));
    let start = motion(&sim, car).position;
    sim.run_ticks(u64::from(ticks(60.0)));
    let drift = (motion(&sim, car).position - start).length();
    assert!(drift < 0.01, "crept {drift} m sideways in a minute");

    // A 4 % uphill, handbrake on: it holds; released, it rolls back.
    let pts: Vec<DVec3> = (0..=4)
        .map(|i| DVec3::new(100.0 * f64::from(i), 0.0, 4.0 * f64::from(i)))
        .collect();
    let mut sim = world_with(vec![RoadSpec::through("hill", 2, 50.0, &pts)]);
    let car = spawn(&mut sim, 0, 200.0, 0.0, 0.0);
    set(
        &mut sim,
        car,
        Controls {
            handbrake: true,
            ..Controls::default()
        },
    );
    sim.run_ticks(u64::from(ticks(1.0)));
    let start = motion(&sim, car).position;
    sim.run_ticks(u64::from(ticks(60.0)));
    let drift = (motion(&sim, car).position - start).length();
    assert!(
        drift < 0.01,
        "crept {drift} m down the hill with the handbrake on"
    );
    set(&mut sim, car, Controls::default());
    sim.run_ticks(u64::from(ticks(5.0)));
    let m = motion(&sim, car);
    assert!(
        m.forward_mps < -0.5,
        "released, it rolls back ({} m/s)",
        m.forward_mps
    );
}

#[test]
fn a_car_rolling_to_a_stop_stops() {
    let mut sim = world_with(vec![straight(400.0)]);
    let car = spawn(&mut sim, 0, 20.0, 0.0, 8.0);
    sim.run_ticks(u64::from(ticks(40.0)));
    let m = motion(&sim, car);
    assert!(
        m.forward_mps.abs() < 0.01,
        "still moving at {} m/s",
        m.forward_mps
    );
    let x = m.position.x;
    sim.run_ticks(u64::from(ticks(10.0)));
    assert!((motion(&sim, car).position.x - x).abs() < 0.005);
}

#[test]
fn negative_throttle_brakes_then_reverses() {
    let mut sim = world_with(vec![straight(400.0)]);
    let car = spawn(&mut sim, 0, 200.0, 0.0, 10.0);
    set(
        &mut sim,
        car,
        Controls {
            throttle: -0.5,
            ..Controls::default()
        },
    );
    sim.run_ticks(u64::from(ticks(8.0)));
    let m = motion(&sim, car);
    assert!(m.forward_mps < -1.0, "it reverses ({} m/s)", m.forward_mps);
    let st = sim.world().get::<VehicleState>(car).expect("state");
    assert_eq!(st.gearbox.gear, -1);
}

/// A busy scene: several cars on a banked ring accelerating, braking, steering and bumping
/// (into each other and the guardrails), with or without gates. Returns every car's final
/// state's bits, the contacts with guardrails and with other cars that began, and how many
/// car-steps a collider spent out of rapier.
fn busy_run(gates: bool) -> (Vec<(u32, [u32; 13])>, usize, usize, usize) {
    let mut spec = RoadSpec::ring("ring", 2, 60.0, DVec3::new(30.0, -20.0, 2.0), 80.0, 16);
    for (i, p) in spec.points.iter_mut().enumerate() {
        *p = ControlPoint {
            bank_deg: -2.0 - (i % 3) as f64,
            ..p.clone()
        };
    }
    let starts: Vec<f64> = (0..8).map(|i| f64::from(i) * 12.0).collect();
    busy_run_on(spec, &starts, gates)
}

/// [`busy_run`] on road `spec` with a car starting at each of `starts_m` along it.
fn busy_run_on(
    spec: RoadSpec,
    starts_m: &[f64],
    gates: bool,
) -> (Vec<(u32, [u32; 13])>, usize, usize, usize) {
    let mut sim = world_with(vec![spec]);
    sim.world_mut().resource_mut::<Physics>().gates = gates;
    let mut rail_hits = 0;
    let mut car_hits = 0;
    let mut out_of_rapier = 0;
    let cars: Vec<Entity> = starts_m
        .iter()
        .enumerate()
        .map(|(i, &s)| spawn(&mut sim, 0, s, if i % 2 == 0 { -1.5 } else { 1.5 }, 8.0))
        .collect();
    for tick in 0..ticks(20.0) {
        for (i, &car) in cars.iter().enumerate() {
            let phase = (tick as f32 / 120.0 + i as f32) * 0.7;
            let controls = Controls {
                throttle: phase.sin(),
                steering: 0.25 + 0.2 * (phase * 1.3).cos(),
                handbrake: i == 3 && tick % 600 < 60,
            };
            set(&mut sim, car, controls);
        }
        sim.step();
        let messages = sim.world().resource::<Messages<VehicleContact>>();
        rail_hits += messages
            .iter_current_update_messages()
            .filter(|c| c.started && matches!(c.other, flockway_vehicle::ContactWith::Guardrail(_)))
            .count();
        car_hits += messages
            .iter_current_update_messages()
            .filter(|c| c.started && matches!(c.other, flockway_vehicle::ContactWith::Vehicle(_)))
            .count();
        out_of_rapier += cars
            .iter()
            .filter(|&&car| {
                sim.world()
                    .get::<flockway_vehicle::ContactGate>(car)
                    .is_some_and(|g| !g.in_rapier())
            })
            .count();
    }
    let states = cars
        .iter()
        .map(|&car| {
            let m = motion(&sim, car);
            let bits = [
                m.position.x,
                m.position.y,
                m.position.z,
                m.rotation.x,
                m.rotation.y,
                m.rotation.z,
                m.rotation.w,
                m.linvel.x,
                m.linvel.y,
                m.linvel.z,
                m.angvel.x,
                m.angvel.y,
                m.angvel.z,
            ]
            .map(f32::to_bits);
            (car.index_u32(), bits)
        })
        .collect();
    (states, rail_hits, car_hits, out_of_rapier)
}

#[test]
fn the_same_run_twice_is_bit_identical() {
    let a = busy_run(true);
    let b = busy_run(true);
    assert_eq!(a, b);
}

#[test]
fn gates_change_nothing_but_the_work() {
    // Colliders out of rapier while no car is within reach, guardrails out of their filters
    // while clear of them; or every car always in rapier with the rails: the same bits, crashes
    // into the rails and into each other included.
    gated_and_ungated_agree(busy_run, 1000);
}

/// `run` (a [`busy_run`]) with gates and without gives the same bits and contacts, the scene
/// has cars hitting the rails and each other, and colliders spent more than `least_out`
/// car-steps out of rapier.
fn gated_and_ungated_agree(
    run: impl Fn(bool) -> (Vec<(u32, [u32; 13])>, usize, usize, usize),
    least_out: usize,
) {
    let (gated, rail_hits, car_hits, out) = run(true);
    assert!(rail_hits > 0, "the scene has cars hitting the rails");
    assert!(car_hits > 0, "and cars hitting each other");
    assert!(out > least_out, "colliders left rapier ({out} car-steps)");
    let (ungated, rail_hits2, car_hits2, out2) = run(false);
    assert_eq!(out2, 0);
    assert_eq!(
        (gated, rail_hits, car_hits),
        (ungated, rail_hits2, car_hits2)
    );
}

#[test]
fn gates_change_nothing_at_a_bare_road_end_either() {
    // A short open road with nothing beyond its ends: cars start a few metres from its start,
    // where their gates close once their boxes are over the road, and run off its end onto the
    // ground. With gates or without, the same bits.
    let spec = RoadSpec::through(
        "short",
        2,
        60.0,
        &[
            DVec3::ZERO,
            DVec3::new(60.0, 10.0, 0.0),
            DVec3::new(120.0, 0.0, 0.0),
        ],
    );
    let starts = [4.0, 7.0, 12.0, 20.0, 30.0, 45.0];
    gated_and_ungated_agree(|gates| busy_run_on(spec.clone(), &starts, gates), 500);
}

#[test]
fn at_a_bare_road_end_a_car_is_out_of_rapier_only_while_its_box_is_over_the_road() {
    let mut sim = world_with(vec![straight(60.0)]);
    assert_eq!(
        sim.world().resource::<Physics>().bare_ends(RoadId(0)),
        [true, true]
    );
    let car = spawn(&mut sim, 0, 1.0, 0.0, 10.0);
    set(
        &mut sim,
        car,
        Controls {
            throttle: 0.6,
            ..Controls::default()
        },
    );
    let in_rapier = |sim: &Sim| {
        sim.world()
            .get::<flockway_vehicle::ContactGate>(car)
            .is_some_and(|g| g.in_rapier())
    };
    let mut left_at = None;
    let mut back_at = None;
    for _ in 0..ticks(8.0) {
        sim.step();
        let s = sim.world().get::<RoadTrack>(car).expect("a track").s_m;
        match (left_at, back_at, in_rapier(&sim)) {
            (None, _, false) => left_at = Some(s),
            (Some(_), None, true) => back_at = Some(s),
            _ => {}
        }
        // Within half its length (2.3 m) of either end, the box reaches past it.
        if !(2.3..=60.0 - 2.3).contains(&s) {
            assert!(in_rapier(&sim), "out of rapier at {s} m");
        }
    }
    // Out once its box, two steps' travel and a margin are past the start, well short of the
    // 10 m an end that is not bare keeps the gate open for; back in before the end.
    let s = left_at.expect("the car's collider left rapier");
    assert!((2.5..6.0).contains(&s), "left rapier at {s} m");
    let s = back_at.expect("the car's collider came back");
    assert!((54.0..57.7).contains(&s), "came back at {s} m");
}

#[test]
fn road_ends_with_a_road_near_or_leading_on_are_not_bare() {
    // a leads onto b; c runs alongside b's end, 12 m away; far is on its own.
    let (a, b) = end_to_start(2);
    let c = RoadSpec::through(
        "c",
        2,
        60.0,
        &[DVec3::new(150.0, 12.0, 0.0), DVec3::new(250.0, 12.0, 0.0)],
    );
    let far = RoadSpec::through(
        "far",
        2,
        60.0,
        &[DVec3::new(0.0, 500.0, 0.0), DVec3::new(100.0, 500.0, 0.0)],
    );
    let sim = world_with(vec![a, b, c, far]);
    let physics = sim.world().resource::<Physics>();
    let bare: Vec<[bool; 2]> = (0..4).map(|i| physics.bare_ends(RoadId(i))).collect();
    assert_eq!(
        bare,
        vec![[true, false], [false, false], [false, true], [true, true]]
    );
}

#[test]
fn removing_a_vehicle_removes_its_body_and_collider() {
    let mut sim = world_with(vec![straight(300.0)]);
    let statics = sim.world().resource::<Physics>().static_colliders();
    let a = spawn(&mut sim, 0, 50.0, 0.0, 5.0);
    let _b = spawn(&mut sim, 0, 80.0, 0.0, 5.0);
    sim.step();
    let physics = sim.world().resource::<Physics>();
    assert_eq!(physics.world.bodies.len(), 2);
    assert_eq!(physics.world.colliders.len(), statics + 2);
    sim.world_mut().despawn(a);
    sim.step();
    let physics = sim.world().resource::<Physics>();
    assert_eq!(physics.world.bodies.len(), 1);
    assert_eq!(physics.world.colliders.len(), statics + 1);
}

#[test]
fn contacts_with_guardrails_and_other_cars_become_messages() {
    let mut sim = world_with(vec![straight(300.0)]);
    // Two cars nose to tail, the rear one faster: they touch.
    let front = spawn(&mut sim, 0, 60.0, 0.0, 2.0);
    let rear = spawn(&mut sim, 0, 50.0, 0.0, 12.0);
    set(
        &mut sim,
        rear,
        Controls {
            throttle: 0.5,
            ..Controls::default()
        },
    );
    // A third steers hard into the right guardrail.
    let wild = spawn(&mut sim, 0, 150.0, 0.0, 15.0);
    set(
        &mut sim,
        wild,
        Controls {
            throttle: 0.3,
            steering: -1.0,
            handbrake: false,
        },
    );
    let mut seen = Vec::new();
    let gate = |sim: &Sim, car: Entity| {
        sim.world()
            .get::<flockway_vehicle::ContactGate>(car)
            .map(|g| g.rails_open())
    };
    let mut wild_gate_opened = false;
    for tick in 0..ticks(5.0) {
        sim.step();
        let messages = sim.world().resource::<Messages<VehicleContact>>();
        seen.extend(messages.iter_current_update_messages().copied());
        if tick == 2 {
            // Straight in the middle of the road, well clear of both rails: rapier does not
            // pair them with the guardrails.
            assert_eq!(gate(&sim, front), Some(false));
        }
        if gate(&sim, wild) == Some(true) && tick > 2 {
            wild_gate_opened = true;
        }
    }
    assert!(
        wild_gate_opened,
        "the car heading for the rail took the rails in again"
    );
    use flockway_vehicle::ContactWith;
    assert!(
        seen.iter().any(|c| c.started
            && ((c.vehicle == rear && c.other == ContactWith::Vehicle(front))
                || (c.vehicle == front && c.other == ContactWith::Vehicle(rear)))),
        "rear-end contact reported: {seen:?}"
    );
    assert!(
        seen.iter().any(|c| c.started
            && c.vehicle == wild
            && c.other == ContactWith::Guardrail(RoadId(0))),
        "guardrail contact reported: {seen:?}"
    );
}

#[test]
fn a_car_follows_a_connection_onto_the_next_road_and_tracks_it() {
    let (a, b) = end_to_start(1);
    let mut sim = world_with(vec![a, b]);
    let car = spawn(&mut sim, 0, 80.0, 0.0, 10.0);
    set(
        &mut sim,
        car,
        Controls {
            throttle: 0.3,
            ..Controls::default()
        },
    );
    sim.run_ticks(u64::from(ticks(4.0)));
    let track = *sim.world().get::<RoadTrack>(car).expect("track");
    let network = sim.world().resource::<RoadNetwork>();
    assert_eq!(Some(track.road), network.id("b"));
    assert!(track.on_road && track.s_m > 0.0 && track.s_m < 100.0);
    // Its wheels stayed on the surface across the join.
    let m = motion(&sim, car);
    assert!(
        (m.position.z - 0.45).abs() < 0.02,
        "height {}",
        m.position.z
    );
}

#[test]
fn cars_on_roads_that_cross_without_meeting_pass_without_touching() {
    // A bridge drawn flat: two roads cross with no junction between them.
    let ew = RoadSpec::through(
        "ew",
        1,
        50.0,
        &[DVec3::new(-100.0, 0.0, 0.0), DVec3::new(100.0, 0.0, 0.0)],
    );
    let ns = RoadSpec::through(
        "ns",
        1,
        50.0,
        &[DVec3::new(0.0, -100.0, 0.0), DVec3::new(0.0, 100.0, 0.0)],
    );
    let mut sim = world_with(vec![ew, ns]);
    assert_eq!(
        sim.world()
            .resource::<flockway_road::RoadNetwork>()
            .crossings(),
        [(RoadId(0), RoadId(1))]
    );
    // Both reach the crossing at the same moment (the two runs are mirror images), and are
    // past it after 3 s.
    let east = spawn(&mut sim, 0, 85.0, 0.0, 10.0);
    let north = spawn(&mut sim, 1, 85.0, 0.0, 10.0);
    for car in [east, north] {
        set(
            &mut sim,
            car,
            Controls {
                throttle: 0.3,
                ..Controls::default()
            },
        );
    }
    let mut seen = Vec::new();
    for _ in 0..ticks(3.0) {
        sim.step();
        let messages = sim.world().resource::<Messages<VehicleContact>>();
        seen.extend(messages.iter_current_update_messages().copied());
    }
    assert!(seen.is_empty(), "{seen:?}");
    assert!(
        motion(&sim, east).position.x > 3.0,
        "{:?}",
        motion(&sim, east)
    );
    assert!(
        motion(&sim, north).position.y > 3.0,
        "{:?}",
        motion(&sim, north)
    );
}

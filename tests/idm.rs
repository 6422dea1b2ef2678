//! The `Idm` model behaves as the published Intelligent Driver Model (Treiber, Hennecke &
//! Helbing 2000) on top of the vehicle physics: its cars follow the same IDM integrated as a
//! point mass at the same step, behind the same leader, within a few tenths of a metre per
//! second and half a metre; and a platoon's string stability is the ODE's on both sides of the
//! linear criterion (Treiber & Kesting, *Traffic Flow Dynamics*, §15.5: with the partial
//! derivatives of a(s, v, v_l), a platoon is string stable when f_v² − f_l² − 2 f_s ≥ 0).
//!
//! The leader is a custom-model car driven from outside the step with a scripted speed; the
//! point-mass followers are driven by its recorded trajectory, so only the followers' dynamics
//! are compared.

use bevy_ecs::prelude::*;
use flockway::drivers::{External, ExternalCommand, IdmDriver, IdmParams, idm_accel};
use flockway::level::parse_level;
use flockway::run::{RunOptions, Runner, find_assets_dir};
use flockway::vehicle::{Motion, RoadTrack};
use std::path::Path;

/// One tick, s.
const H: f64 = 1.0 / 120.0;
/// The sedan's body length, m.
const LENGTH_M: f64 = 4.6;
/// The road's speed limit, which is the IDM's desired speed v₀, km/h.
const LIMIT_KMH: f64 = 72.0;

/// The IDM parameter overrides of a follower profile, as a level's `set` map.
struct Idm {
    a: f64,
    b: f64,
    t: f64,
    s0: f64,
}

impl Idm {
    /// The published standard car: a 1 m/s², b 1.5 m/s², T 1.5 s, s₀ 2 m.
    const STANDARD: Idm = Idm {
        a: 1.0,
        b: 1.5,
        t: 1.5,
        s0: 2.0,
    };

    fn params(&self) -> IdmParams {
        IdmParams {
            max_accel_mps2: self.a as f32,
            comfortable_decel_mps2: self.b as f32,
            time_headway_s: self.t as f32,
            min_gap_m: self.s0 as f32,
            ..IdmParams::default()
        }
    }

    fn accel(&self, v: f64, gap: f64, v_lead: f64) -> f64 {
        f64::from(idm_accel(
            &self.params(),
            v as f32,
            (LIMIT_KMH / 3.6) as f32,
            Some((gap as f32, (v - v_lead) as f32)),
        ))
    }

    /// The uniform-flow gap at speed `v`: s_e = (s₀ + vT) / √(1 − (v/v₀)⁴).
    fn equilibrium_gap_m(&self, v: f64) -> f64 {
        (self.s0 + v * self.t) / (1.0 - (v / (LIMIT_KMH / 3.6)).powi(4)).sqrt()
    }

    /// The linear string-stability criterion f_v² − f_l² − 2 f_s at speed `v` (stable ≥ 0).
    fn string_stability(&self, v: f64) -> f64 {
        let s = self.equilibrium_gap_m(v);
        let e = 1.0e-3;
        let f_s = (self.accel(v, s + e, v) - self.accel(v, s - e, v)) / (2.0 * e);
        let f_v = (self.accel(v + e, s, v) - self.accel(v - e, s, v)) / (2.0 * e);
        let f_l = (self.accel(v, s, v + e) - self.accel(v, s, v - e)) / (2.0 * e);
        f_v * f_v - f_l * f_l - 2.0 * f_s
    }
}

/// A straight 2 km road; `followers` IDM cars spaced `spacing_m` apart (centre to centre) at
/// `speed_kmh`, the scripted leader `spacing_m` ahead of the first.
fn level(idm: &Idm, followers: u32, spacing_m: f64, speed_kmh: f64) -> String {
    let from = 20.0;
    let leader = from + f64::from(followers) * spacing_m;
    format!(
        r#"(
    version: 1,
    name: "idm_platoon",
    seed: 1,
    duration_s: 600.0,
    roads: [(name: "straight", lanes: 1, lane_width_m: 3.5, speed_limit_kmh: {LIMIT_KMH},
        points: [(pos: (0.0, 0.0, 0.0)), (pos: (1000.0, 0.0, 0.0)), (pos: (2000.0, 0.0, 0.0))])],
    vehicle_types: [(name: "sedan", path: "vehicles/sedan.ron")],
    driver_profiles: [
        (name: "leader", model: Custom("leader"), vehicle: "sedan"),
        (name: "idm", model: Idm, vehicle: "sedan", params: "drivers/idm.ron",
            set: {{"max_accel_mps2": {a}, "comfortable_decel_mps2": {b}, "time_headway_s": {t},
                   "min_gap_m": {s0}}}),
    ],
    vehicles: [
        (road: "straight", count: {followers}, profile: "idm", from_m: {from}, to_m: {leader},
            speed_kmh: {speed_kmh}),
        (road: "straight", count: 1, profile: "leader", from_m: {leader}, to_m: {end},
            speed_kmh: {speed_kmh}),
    ],
)"#,
        a = idm.a,
        b = idm.b,
        t = idm.t,
        s0 = idm.s0,
        end = leader + 1.0,
    )
}

/// Position along the road and speed of every car each tick: the leader first, then the
/// followers from the front. The leader is told `script(time)` as its target speed.
fn run(level_text: &str, seconds: f64, script: impl Fn(f64) -> f64) -> Vec<Vec<(f64, f64)>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = root.join("levels").join("idm_platoon.ron");
    let level = parse_level(level_text, &path).expect("the test level parses");
    let options = RunOptions {
        seconds: Some(seconds),
        assets: Some(find_assets_dir(Some(&path))),
        external: true,
        ..RunOptions::default()
    };
    let mut runner = Runner::new(level, "idm_platoon", &options).expect("the level builds");
    let ticks = (seconds / H).round() as u64;
    let mut trace = Vec::new();
    for k in 0..ticks {
        let world = runner.sim_mut().world_mut();
        let mut leader = world.query::<(&mut External, &RoadTrack, &Motion)>();
        let mut cars = Vec::new();
        for (mut external, track, motion) in leader.iter_mut(world) {
            external.command = Some(ExternalCommand::Target {
                speed_mps: script(k as f64 * H) as f32,
                lane: None,
            });
            cars.push((track.s_m, f64::from(motion.forward_mps)));
        }
        let mut followers: Vec<(f64, f64)> = world
            .query_filtered::<(&RoadTrack, &Motion), With<IdmDriver>>()
            .iter(world)
            .map(|(t, m)| (t.s_m, f64::from(m.forward_mps)))
            .collect();
        followers.sort_by(|a, b| b.0.total_cmp(&a.0));
        cars.extend(followers);
        trace.push(cars);
        runner.step(1).expect("a step");
    }
    trace
}

/// The followers of `trace` integrated as point masses under the IDM, ballistically at the
/// same step, each behind its real (for the first: the recorded leader) or point-mass leader.
fn point_masses(idm: &Idm, trace: &[Vec<(f64, f64)>]) -> Vec<Vec<(f64, f64)>> {
    let mut state = trace[0].clone();
    let mut out = vec![state.clone()];
    for now in &trace[1..] {
        let mut next = state.clone();
        next[0] = now[0];
        for i in 1..state.len() {
            let (x, v) = state[i];
            let (xl, vl) = state[i - 1];
            let a = idm.accel(v, xl - x - LENGTH_M, vl);
            let v2 = (v + a * H).max(0.0);
            next[i] = (x + 0.5 * (v + v2) * H, v2);
        }
        state = next;
        out.push(state.clone());
    }
    out
}

fn rms(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    (sum / n.max(1) as f64).sqrt()
}

/// Accelerates at 1.5 m/s² to 15 m/s, cruises, brakes at 4 m/s² to a stop, waits, restarts.
fn stop_and_go(t: f64) -> f64 {
    match t {
        t if t < 10.0 => 1.5 * t,
        t if t < 35.0 => 15.0,
        t if t < 38.75 => 15.0 - 4.0 * (t - 35.0),
        t if t < 50.0 => 0.0,
        t if t < 60.0 => 1.5 * (t - 50.0),
        _ => 15.0,
    }
}

#[test]
fn a_follower_drives_as_the_idm_integrated_as_a_point_mass() {
    let idm = Idm::STANDARD;
    let seconds = 80.0;
    let trace = run(&level(&idm, 1, 10.0, 0.0), seconds, stop_and_go);
    let ode = point_masses(&idm, &trace);
    // The scripted leader did what it was told: to 15 m/s and back to a stop.
    let top = trace.iter().map(|c| c[0].1).fold(0.0, f64::max);
    assert!((top - 15.0).abs() < 0.5, "leader's top speed {top}");
    let speed = rms(trace.iter().zip(&ode).map(|(c, o)| c[1].1 - o[1].1));
    let gap = rms(trace.iter().zip(&ode).map(|(c, o)| {
        let real = c[0].0 - c[1].0 - LENGTH_M;
        let model = o[0].0 - o[1].0 - LENGTH_M;
        real - model
    }));
    let closest = trace
        .iter()
        .map(|c| c[0].0 - c[1].0 - LENGTH_M)
        .fold(f64::INFINITY, f64::min);
    eprintln!("speed RMS {speed:.3} m/s, gap RMS {gap:.3} m, closest gap {closest:.2} m");
    assert!(speed <= 0.3, "speed RMS error {speed:.3} m/s");
    assert!(gap <= 0.5, "gap RMS error {gap:.3} m");
}

/// The largest speed deficit below `v` of each follower, first to last.
fn deficits(trace: &[Vec<(f64, f64)>], v: f64) -> Vec<f64> {
    let n = trace[0].len();
    (1..n)
        .map(|i| {
            trace
                .iter()
                .map(|c| v - c[i].1)
                .fold(f64::NEG_INFINITY, f64::max)
        })
        .collect()
}

/// Twelve cars at the equilibrium gap of 6 m/s; the leader drops to 4 m/s for 8 s. Returns the
/// growth of the speed dip from the first follower to the last, in the cars and in the ODE.
fn dip_growth(idm: &Idm) -> (f64, f64) {
    let v = 6.0;
    let spacing = idm.equilibrium_gap_m(v) + LENGTH_M;
    let script = |t: f64| match t {
        t if t < 20.0 => v,
        t if t < 22.0 => v - (t - 20.0),
        t if t < 28.0 => v - 2.0,
        t if t < 30.0 => v - 2.0 + (t - 28.0),
        _ => v,
    };
    let trace = run(&level(idm, 12, spacing, v * 3.6), 150.0, script);
    let ode = point_masses(idm, &trace);
    let cars = deficits(&trace, v);
    let model = deficits(&ode, v);
    eprintln!("cars' dips {cars:.2?}\nODE dips   {model:.2?}");
    (
        cars[cars.len() - 1] / cars[0],
        model[model.len() - 1] / model[0],
    )
}

#[test]
fn a_platoon_is_string_unstable_where_the_idm_is() {
    let idm = Idm {
        a: 0.3,
        t: 1.0,
        ..Idm::STANDARD
    };
    assert!(
        idm.string_stability(6.0) < 0.0,
        "the parameters are unstable"
    );
    let (cars, ode) = dip_growth(&idm);
    assert!(ode > 1.3, "the ODE's dip grows: {ode:.2}");
    assert!(
        cars > 1.3,
        "the cars' dip grows as the ODE's ({ode:.2}): {cars:.2}"
    );
}

#[test]
fn a_platoon_is_string_stable_where_the_idm_is() {
    let idm = Idm {
        a: 3.0,
        t: 1.0,
        ..Idm::STANDARD
    };
    assert!(idm.string_stability(6.0) > 0.0, "the parameters are stable");
    let (cars, ode) = dip_growth(&idm);
    assert!(ode < 0.85, "the ODE's dip dies out: {ode:.2}");
    assert!(
        cars < 0.85,
        "the cars' dip dies out as the ODE's ({ode:.2}): {cars:.2}"
    );
}

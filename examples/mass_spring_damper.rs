//! The thesis's §2.4.4 example, the Flockway way: a body on a spring and a damper, F = −k x − c ẋ,
//! as one component and one system acting on a rapier body. It shows how to add any physical
//! model to the step. Run it with `cargo run --release --example mass_spring_damper`.

use bevy_ecs::prelude::*;
use flockway::core::{DT_S, Sim, SimPlugin, StepSet};
use flockway::vehicle::rapier3d::prelude::*;
use flockway::vehicle::{Physics, VehiclePlugin, VehicleSystems};

/// A body held by a vertical spring and damper to an anchor height.
#[derive(Component)]
struct SpringDamper {
    body: RigidBodyHandle,
    /// Spring rate k, N/m.
    k: f32,
    /// Damping c, N·s/m.
    c: f32,
    /// Height where the spring is relaxed, m.
    anchor_z: f32,
}

/// Each tick, before rapier steps: the spring–damper force on the body. rapier keeps user forces
/// until they are reset, so the force is replaced, never added to last tick's.
fn apply_spring_damper(mut physics: ResMut<Physics>, springs: Query<&SpringDamper>) {
    for s in &springs {
        let Some(body) = physics.world.bodies.get_mut(s.body) else {
            continue;
        };
        let x = body.translation().z - s.anchor_z;
        let v = body.linvel().z;
        body.reset_forces(false);
        body.add_force(glam::Vec3::new(0.0, 0.0, -s.k * x - s.c * v), true);
    }
}

struct SpringDamperPlugin;
impl SimPlugin for SpringDamperPlugin {
    fn build(&self, sim: &mut Sim) {
        sim.add_plugin(VehiclePlugin); // the rapier world and its step
        // Both this and the vehicles' forces write the rapier world: give them an order (the
        // step refuses to build with two writers of the same data left unordered).
        sim.add_systems(
            StepSet::Actuate,
            apply_spring_damper.after(VehicleSystems::Drive),
        );
    }
}

/// A 10 kg mass released 0.1 m above its rest point (gravity off, as in the thesis): its height
/// every tick for `seconds`.
fn run(seconds: f64, k: f32, c: f32) -> Vec<f32> {
    let mut sim = Sim::new(0);
    sim.add_plugin(SpringDamperPlugin);
    sim.prepare().expect("no conflicting systems");
    let body = RigidBodyBuilder::dynamic()
        .translation(glam::Vec3::new(0.0, 0.0, 1.1))
        .gravity_scale(0.0)
        .additional_mass(10.0)
        .build();
    let handle = sim
        .world_mut()
        .resource_mut::<Physics>()
        .world
        .insert_body(body);
    sim.world_mut().spawn(SpringDamper {
        body: handle,
        k,
        c,
        anchor_z: 1.0,
    });
    (0..(seconds / DT_S) as usize)
        .map(|_| {
            sim.step();
            sim.world().resource::<Physics>().world.bodies[handle]
                .translation()
                .z
                - 1.0
        })
        .collect()
}

fn main() {
    for (i, x) in run(3.0, 400.0, 8.0).iter().enumerate().step_by(12) {
        println!("{:5.2} s  x = {:+.4} m", i as f64 * DT_S, x);
    }
}

#[test]
fn it_oscillates_and_decays_as_the_equation_says() {
    // m = 10 kg, k = 400 N/m, c = 8 N·s/m: ω₀ = √(k/m) = 6.3246 rad/s, ζ = c / (2√(km)) = 0.0632,
    // damped period 2π / (ω₀ √(1 − ζ²)) = 0.99545 s, and x(t) ≈ 0.1 e^(−ζω₀t) cos(ω_d t).
    let xs = run(5.0, 400.0, 8.0);
    let (zeta, w0) = (0.0632456f64, 6.3245553f64);
    let wd = w0 * (1.0 - zeta * zeta).sqrt();
    for (i, x) in xs.iter().enumerate() {
        let t = (i + 1) as f64 * DT_S;
        let exact =
            0.1 * (-zeta * w0 * t).exp() * ((wd * t).cos() + zeta * w0 / wd * (wd * t).sin());
        assert!(
            (f64::from(*x) - exact).abs() < 3e-3,
            "t = {t:.3}: {x} vs {exact}"
        );
    }
}

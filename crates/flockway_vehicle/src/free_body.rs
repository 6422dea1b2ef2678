//! Vehicle bodies integrated here while rapier has nothing for them to touch.
//!
//! A car whose collider is out of rapier (see [`ContactGate`](crate::ContactGate)) has no
//! contact to resolve, yet rapier would still carry its body through every stage of its step —
//! one thread reaching thousands of bodies scattered in memory, the largest serial part of a
//! step with 10 000 cars. So its rapier body is disabled as well and [`FreeBody`] integrates it
//! in the parallel force pass, with rapier's own operations in rapier's order: the same bits as
//! if rapier had stepped it.

use crate::components::Chassis;
use crate::lanes::{Quatx4, Vec3x4};
use crate::physics::Physics;
use bevy_ecs::prelude::*;
use flockway_core::arrays::array4;
use glam::{Mat3, Quat, Vec3};
use rapier3d::parry::utils::SdpMatrix3;
use rapier3d::prelude::*;
use wide::f32x4;

/// A vehicle's rigid-body state while its body is out of rapier and integrated here; while the
/// body is in rapier, rapier holds the state and this only waits.
#[derive(Component, Debug, Clone, Copy, PartialEq, Default)]
pub struct FreeBody {
    /// Whether the body is out of rapier and this is its state.
    pub(crate) free: bool,
    /// The body's pose (its origin is its centre of mass).
    pub(crate) pose: Pose,
    /// Linear velocity, m/s.
    pub(crate) linvel: Vec3,
    /// Angular velocity, rad/s.
    pub(crate) angvel: Vec3,
    /// The body's local mass properties, as rapier computed them.
    pub(crate) mass: MassProperties,
    /// The mass its inverse gives back, kg, on each axis (what gravity acts on), kept with it.
    pub(crate) mass_kg: Vec3,
    /// Its principal inertia (the inverse of `mass`'s inverse), kept with it.
    pub(crate) principal_inertia: Vec3,
}

/// The mass on each axis that inverse mass `inv_mass` gives back (none for none).
fn mass_of(inv_mass: f32) -> Vec3 {
    Vec3::splat(inv_mass).map(|x| if x != 0.0 { 1.0 / x } else { 0.0 })
}

/// What one step of integration needs from rapier's settings.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StepSettings {
    dt: f32,
    gravity: Vec3,
    max_linvel: f32,
    max_angvel: f32,
}

/// Largest rotation rapier lets a body make in one step, rad (its solver's own cap).
const MAX_ROTATION: f32 = std::f32::consts::FRAC_PI_4;

impl StepSettings {
    /// The settings of `physics`'s world.
    pub(crate) fn of(physics: &Physics) -> StepSettings {
        let params = &physics.world.integration_parameters;
        StepSettings {
            dt: params.dt,
            gravity: physics.world.gravity,
            max_linvel: params.max_linear_velocity(),
            max_angvel: MAX_ROTATION * params.inv_dt(),
        }
    }
}

impl FreeBody {
    /// Whether the body is out of rapier and integrated here.
    pub fn is_free(&self) -> bool {
        self.free
    }

    /// The body's pose, linear and angular velocity now: its own while free, else rapier's;
    /// `None` if rapier has no such body.
    // Inlined into both builds (x86-64 and AVX2) of the force pass's per-car step.
    #[inline(always)]
    pub(crate) fn state(&self, physics: &Physics, chassis: &Chassis) -> Option<(Pose, Vec3, Vec3)> {
        if self.free {
            return Some((self.pose, self.linvel, self.angvel));
        }
        let body = physics.world.bodies.get(chassis.body)?;
        Some((*body.position(), body.linvel(), body.angvel()))
    }

    /// Takes the body out of rapier: its state moves here and rapier's body is disabled.
    pub(crate) fn leave(&mut self, body: &mut RigidBody) {
        self.pose = *body.position();
        self.linvel = body.linvel();
        self.angvel = body.angvel();
        self.mass = body.mass_properties().local_mprops;
        self.mass_kg = mass_of(self.mass.inv_mass);
        self.principal_inertia = self.mass.principal_inertia();
        self.free = true;
        body.set_enabled(false);
    }

    /// Puts the body back into rapier with the state integrated here.
    pub(crate) fn enter(&mut self, body: &mut RigidBody) {
        body.set_position(self.pose, false);
        body.set_linvel(self.linvel, false);
        body.set_angvel(self.angvel, false);
        body.set_enabled(true);
        self.free = false;
    }

    /// Advances the body by one step under `force` and `torque` (at its centre of mass) and
    /// gravity, exactly as rapier's solver advances a dynamic body with no contacts and one
    /// substep: forces into velocities, rapier's gyroscopic correction, its speed caps, then
    /// the linearised rotation and the translation.
    // Inlined into both builds (x86-64 and AVX2) of the force pass's per-car step.
    #[inline(always)]
    pub(crate) fn step(&mut self, force: Vec3, torque: Vec3, settings: &StepSettings) {
        let m = &self.mass;
        let dt = settings.dt;
        // rapier's user forces accumulate from zero (which turns a -0 component into +0), and
        // gravity acts on the mass its inverse gives back.
        let inv_mass = Vec3::splat(m.inv_mass);
        let force = (Vec3::ZERO + force) + settings.gravity * self.mass_kg;
        let torque = Vec3::ZERO + torque;
        let inv_inertia = world_inv_inertia(m, self.pose.rotation);
        // The solver works on the pose of the centre of mass.
        let com = self.pose.prepend_translation(m.local_com);
        let mut linvel = self.linvel + force * inv_mass * dt;
        let mut angvel = self.angvel + inv_inertia * torque * dt;
        angvel = gyroscopic_corrected_angvel(
            angvel,
            com.rotation * m.principal_inertia_local_frame,
            self.principal_inertia,
            m.inv_principal_inertia,
            dt,
        );
        if settings.max_linvel != f32::MAX {
            let n = linvel.length();
            if n > settings.max_linvel {
                linvel *= settings.max_linvel / n;
            }
        }
        let n = angvel.length();
        if n > settings.max_angvel {
            angvel *= settings.max_angvel / n;
        }
        let half = angvel * (dt * 0.5);
        let rotation = (Quat::from_xyzw(half.x, half.y, half.z, 1.0) * com.rotation).normalize();
        let translation = com.translation + linvel * dt;
        let pose = Pose::from_parts(translation, rotation).prepend_translation(-m.local_com);
        if pose.is_finite() {
            self.pose = pose;
            self.linvel = linvel;
            self.angvel = angvel;
        } else {
            // As rapier does with a body whose pose went non-finite: it stays where it was, at
            // rest.
            self.linvel = Vec3::ZERO;
            self.angvel = Vec3::ZERO;
        }
    }
}

/// Four bodies' [`FreeBody::step`] at once, one a lane (`wide::f32x4`), each lane in the scalar
/// step's order of operations: the same bits. The branches (the speed caps, the gyroscopic
/// correction's zero momentum, a pose gone non-finite) are taken lane by lane as selections of
/// values computed both ways; a body without rotational inertia takes the scalar step, as the
/// four do then.
// Inlined into both builds (x86-64 and AVX2) of the free bodies' integration.
#[inline(always)]
pub(crate) fn step_four(
    bodies: [&mut FreeBody; 4],
    forces: [(Vec3, Vec3); 4],
    settings: &StepSettings,
) {
    if bodies
        .iter()
        .any(|b| b.mass.inv_principal_inertia == Vec3::ZERO)
    {
        for (body, (force, torque)) in bodies.into_iter().zip(forces) {
            body.step(force, torque, settings);
        }
        return;
    }
    let dt = f32x4::splat(settings.dt);
    let zero = Vec3x4::splat(Vec3::ZERO);
    let inv_mass = f32x4::new(array4(|i| bodies[i].mass.inv_mass));
    let local_com = Vec3x4::from_fn(|i| bodies[i].mass.local_com);
    let inv_principal = Vec3x4::from_fn(|i| bodies[i].mass.inv_principal_inertia);
    let principal = Vec3x4::from_fn(|i| bodies[i].principal_inertia);
    let rotation = Quatx4::from_fn(|i| bodies[i].pose.rotation);
    let translation = Vec3x4::from_fn(|i| bodies[i].pose.translation);
    let force = (zero + Vec3x4::from_fn(|i| forces[i].0))
        + Vec3x4::splat(settings.gravity).mul_lanes(Vec3x4::from_fn(|i| bodies[i].mass_kg));
    let torque = zero + Vec3x4::from_fn(|i| forces[i].1);
    // The world's principal axes: `world_inv_inertia`'s and the gyroscopic correction's.
    let axes = rotation.mul(Quatx4::from_fn(|i| {
        bodies[i].mass.principal_inertia_local_frame
    }));
    let inv_inertia = WorldInvInertia4::new(axes, inv_principal);
    let com = translation + rotation.rotate(local_com);
    let mut linvel = Vec3x4::from_fn(|i| bodies[i].linvel) + (force * inv_mass) * dt;
    let angvel = Vec3x4::from_fn(|i| bodies[i].angvel) + inv_inertia.mul(torque) * dt;
    // rapier's gyroscopic correction, lane by lane.
    let w = axes.conjugate().rotate(angvel);
    let momentum = principal.mul_lanes(w);
    let gyro_momentum = -w.cross(momentum) * dt;
    let total = momentum + gyro_momentum;
    let total_sq = total.dot(total);
    let capped = total * (momentum.dot(momentum) / total_sq).sqrt();
    let corrected = axes.rotate(inv_principal.mul_lanes(capped));
    let mut angvel = Vec3x4::select(total_sq.simd_ne(f32x4::ZERO), corrected, angvel);
    if settings.max_linvel != f32::MAX {
        let max = f32x4::splat(settings.max_linvel);
        let n = linvel.dot(linvel).sqrt();
        linvel = Vec3x4::select(n.simd_gt(max), linvel * (max / n), linvel);
    }
    let max = f32x4::splat(settings.max_angvel);
    let n = angvel.dot(angvel).sqrt();
    angvel = Vec3x4::select(n.simd_gt(max), angvel * (max / n), angvel);
    let half = angvel * (dt * f32x4::splat(0.5));
    let turn = Quatx4 {
        x: half.x,
        y: half.y,
        z: half.z,
        w: f32x4::ONE,
    };
    let rotation = turn.mul(rotation).normalize();
    let com = com + linvel * dt;
    let translation = com + rotation.rotate(-local_com);
    let finite = (rotation.is_finite() & translation.is_finite()).to_bitmask();
    for (i, body) in bodies.into_iter().enumerate() {
        if finite >> i & 1 != 0 {
            body.pose = Pose::from_parts(translation.lane(i), rotation.lane(i));
            body.linvel = linvel.lane(i);
            body.angvel = angvel.lane(i);
        } else {
            body.linvel = Vec3::ZERO;
            body.angvel = Vec3::ZERO;
        }
    }
}

/// [`world_inv_inertia`] in four lanes: the entries of the symmetric tensor, each as glam's
/// `Mat3` product orders it.
struct WorldInvInertia4 {
    m11: f32x4,
    m12: f32x4,
    m13: f32x4,
    m22: f32x4,
    m23: f32x4,
    m33: f32x4,
}

impl WorldInvInertia4 {
    /// The world-space inverse inertia of bodies whose principal axes are `axes` and inverse
    /// principal inertia `inv`.
    #[inline(always)]
    fn new(axes: Quatx4, inv: Vec3x4) -> WorldInvInertia4 {
        // glam's `Mat3::from_quat`: columns `a`, `b`, `c`.
        let (x2, y2, z2) = (axes.x + axes.x, axes.y + axes.y, axes.z + axes.z);
        let (xx, xy, xz) = (axes.x * x2, axes.x * y2, axes.x * z2);
        let (yy, yz, zz) = (axes.y * y2, axes.y * z2, axes.z * z2);
        let (wx, wy, wz) = (axes.w * x2, axes.w * y2, axes.w * z2);
        let one = f32x4::ONE;
        let a = [one - (yy + zz), xy + wz, xz - wy];
        let b = [xy - wz, one - (xx + zz), yz + wx];
        let c = [xz + wy, yz - wx, one - (xx + yy)];
        // The columns scaled by the inverse inertia, times the transpose: entry (i, j) is
        // row i of the scaled matrix against row j of the unscaled one.
        let (sa, sb, sc) = (
            a.map(|v| v * inv.x),
            b.map(|v| v * inv.y),
            c.map(|v| v * inv.z),
        );
        let entry = |i: usize, j: usize| sa[i] * a[j] + sb[i] * b[j] + sc[i] * c[j];
        WorldInvInertia4 {
            m11: entry(0, 0),
            m12: entry(0, 1),
            m13: entry(0, 2),
            m22: entry(1, 1),
            m23: entry(1, 2),
            m33: entry(2, 2),
        }
    }

    /// The tensor times `v`, as parry's `SdpMatrix3::mul_vec`.
    #[inline(always)]
    fn mul(&self, v: Vec3x4) -> Vec3x4 {
        Vec3x4 {
            x: self.m11 * v.x + self.m12 * v.y + self.m13 * v.z,
            y: self.m12 * v.x + self.m22 * v.y + self.m23 * v.z,
            z: self.m13 * v.x + self.m23 * v.y + self.m33 * v.z,
        }
    }
}

/// parry's `MassProperties::world_inv_inertia` (the world-space inverse inertia tensor at
/// orientation `rot`), its operations in its order, so that it inlines into the force pass's
/// builds: parry's own stayed an out-of-line baseline call from the AVX2 build.
#[inline(always)]
fn world_inv_inertia(m: &MassProperties, rot: Quat) -> SdpMatrix3<f32> {
    if m.inv_principal_inertia == Vec3::ZERO {
        return SdpMatrix3::zero();
    }
    let mut lhs = Mat3::from_quat(rot * m.principal_inertia_local_frame);
    let rhs = lhs.transpose();
    lhs.x_axis *= m.inv_principal_inertia.x;
    lhs.y_axis *= m.inv_principal_inertia.y;
    lhs.z_axis *= m.inv_principal_inertia.z;
    let inertia = lhs * rhs;
    SdpMatrix3::new(
        inertia.x_axis.x,
        inertia.y_axis.x,
        inertia.z_axis.x,
        inertia.y_axis.y,
        inertia.z_axis.y,
        inertia.z_axis.z,
    )
}

/// rapier's explicit gyroscopic correction of a world-space angular velocity (angular momentum
/// kept), in the world's principal-inertia frame `principal_axes`.
#[inline(always)]
fn gyroscopic_corrected_angvel(
    angvel: Vec3,
    principal_axes: Quat,
    principal_inertia: Vec3,
    inv_principal_inertia: Vec3,
    dt: f32,
) -> Vec3 {
    let w = principal_axes.inverse() * angvel;
    let momentum = principal_inertia * w;
    let gyro_momentum = -w.cross(momentum) * dt;
    let total = momentum + gyro_momentum;
    let total_sq = total.length_squared();
    if total_sq != 0.0 {
        let capped = total * (momentum.length_squared() / total_sq).sqrt();
        principal_axes * (inv_principal_inertia * capped)
    } else {
        angvel
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::systems::replace_forces;

    /// A box-shaped body like a car's chassis, its centre of mass off the box's centre, turned
    /// and moving; in a world with gravity stepped as the simulation steps it.
    fn world_with_body() -> (Physics, RigidBodyHandle) {
        let mut physics = Physics::default();
        let massless_box = Cuboid::new(Vec3::new(2.3, 0.9, 0.6))
            .mass_properties(0.0)
            .transform_by(&Pose::from_translation(Vec3::new(0.1, 0.0, 0.2)));
        let mass = massless_box
            + MassProperties::new(Vec3::ZERO, 1500.0, Vec3::new(600.0, 2400.0, 2700.0));
        let body = RigidBodyBuilder::dynamic()
            .pose(Pose::from_parts(
                Vec3::new(10.0, -4.0, 0.7),
                Quat::from_rotation_z(0.6) * Quat::from_rotation_x(0.03),
            ))
            .linvel(Vec3::new(20.0, 3.0, 0.1))
            .angvel(Vec3::new(0.05, -0.02, 0.3))
            .additional_mass_properties(mass)
            .can_sleep(false)
            .build();
        let collider = ColliderBuilder::cuboid(2.3, 0.9, 0.6)
            .translation(Vec3::new(0.1, 0.0, 0.2))
            .mass_properties(MassProperties::new(Vec3::ZERO, 0.0, Vec3::ZERO))
            .build();
        let (handle, _) = physics.world.insert(body, collider);
        (physics, handle)
    }

    /// Forces and torques that change every step, as a car's suspension and tyres give.
    fn load(step: u32) -> (Vec3, Vec3) {
        let t = step as f32 * 0.37;
        (
            Vec3::new(
                800.0 * t.sin(),
                -300.0 * (1.3 * t).cos(),
                14_700.0 + 90.0 * t.sin(),
            ),
            Vec3::new(
                40.0 * (0.7 * t).cos(),
                -25.0 * t.sin(),
                120.0 * (0.2 * t).sin(),
            ),
        )
    }

    fn bits(pose: &Pose, linvel: Vec3, angvel: Vec3) -> [u32; 13] {
        [
            pose.translation.x,
            pose.translation.y,
            pose.translation.z,
            pose.rotation.x,
            pose.rotation.y,
            pose.rotation.z,
            pose.rotation.w,
            linvel.x,
            linvel.y,
            linvel.z,
            angvel.x,
            angvel.y,
            angvel.z,
        ]
        .map(f32::to_bits)
    }

    #[test]
    fn a_free_body_moves_as_rapier_would_move_it_bit_for_bit() {
        // Two identical worlds: in one rapier steps the body throughout; in the other the body
        // is integrated here twice for 400 steps, between spells in rapier.
        let (mut rapier_only, a) = world_with_body();
        let (mut ours, b) = world_with_body();
        let settings = StepSettings::of(&ours);
        let mut free = FreeBody::default();
        let chassis = Chassis { body: b };
        for step in 0..1000 {
            let (force, torque) = load(step);
            let body = rapier_only.world.bodies.get_mut(a).expect("body a");
            replace_forces(body, force, torque);
            rapier_only.step();
            let spell = step % 500;
            if spell == 100 {
                free.leave(ours.world.bodies.get_mut(b).expect("body b"));
            } else if spell == 0 && free.is_free() {
                free.enter(ours.world.bodies.get_mut(b).expect("body b"));
            }
            if free.is_free() {
                free.step(force, torque, &settings);
            } else {
                replace_forces(ours.world.bodies.get_mut(b).expect("body b"), force, torque);
            }
            ours.step();
            let there = rapier_only.world.bodies.get(a).expect("body a");
            let (pose, linvel, angvel) = free.state(&ours, &chassis).expect("state");
            assert_eq!(
                bits(&pose, linvel, angvel),
                bits(there.position(), there.linvel(), there.angvel()),
                "step {step} (free: {})",
                free.is_free()
            );
        }
        assert!(free.is_free(), "the run ends with the body integrated here");
    }

    #[test]
    fn four_bodies_stepped_at_once_are_each_stepped_alone_to_the_bit() {
        let mut u = crate::lanes::uniform(0x5eed_f00d);
        let mut v3 = |lo: f32, hi: f32| Vec3::new(u(lo, hi), u(lo, hi), u(lo, hi));
        let unit = |v3: &mut dyn FnMut(f32, f32) -> Vec3| {
            let q = v3(-1.0, 1.0);
            Quat::from_xyzw(q.x, q.y, q.z, 0.7).normalize()
        };
        let mut bodies = Vec::new();
        let mut forces = Vec::new();
        for k in 0..400 {
            let mut mass = MassProperties {
                local_com: v3(-0.5, 0.5),
                inv_mass: 1.0 / (800.0 + 2000.0 * v3(0.0, 1.0).x),
                inv_principal_inertia: v3(1.0e-4, 2.0e-3),
                principal_inertia_local_frame: unit(&mut v3),
            };
            // Every few a body without rotational inertia (its four take the scalar step).
            if k % 37 == 5 {
                mass.inv_principal_inertia = Vec3::ZERO;
            }
            let body = FreeBody {
                free: true,
                pose: Pose::from_parts(v3(-500.0, 500.0), unit(&mut v3)),
                linvel: v3(-40.0, 40.0),
                // Some spin beyond rapier's cap on a step's rotation.
                angvel: v3(-1.0, 1.0) * if k % 5 == 0 { 150.0 } else { 2.0 },
                mass,
                mass_kg: mass_of(mass.inv_mass),
                principal_inertia: mass.principal_inertia(),
            };
            let (mut force, mut torque) = (v3(-2.0e4, 2.0e4), v3(-3.0e3, 3.0e3));
            match k % 23 {
                // No spin and no torque: the gyroscopic correction's zero momentum.
                3 => {
                    torque = Vec3::ZERO;
                    bodies.push(FreeBody {
                        angvel: Vec3::ZERO,
                        ..body
                    });
                    forces.push((force, torque));
                    continue;
                }
                // A force gone non-finite: the body stays where it was, at rest.
                7 => force.y = f32::NAN,
                11 => torque.z = f32::INFINITY,
                // Signed zeros.
                13 => (force, torque) = (Vec3::new(-0.0, 0.0, -0.0), Vec3::splat(-0.0)),
                _ => {}
            }
            bodies.push(body);
            forces.push((force, torque));
        }
        let physics = Physics::default();
        let settings = StepSettings::of(&physics);
        let capped = StepSettings {
            max_linvel: 30.0,
            ..settings
        };
        for settings in [settings, capped] {
            let mut alone = bodies.clone();
            let mut four = bodies.clone();
            for _ in 0..3 {
                for (b, &(f, t)) in alone.iter_mut().zip(&forces) {
                    b.step(f, t, &settings);
                }
                for (chunk, f) in four.chunks_exact_mut(4).zip(forces.chunks_exact(4)) {
                    let [a, b, c, d] = chunk else {
                        panic!("a chunk of four");
                    };
                    step_four([a, b, c, d], [f[0], f[1], f[2], f[3]], &settings);
                }
            }
            for (k, (a, b)) in alone.iter().zip(&four).enumerate() {
                assert_eq!(
                    bits(&a.pose, a.linvel, a.angvel),
                    bits(&b.pose, b.linvel, b.angvel),
                    "body {k}: {a:?} and {b:?}"
                );
            }
            // The cases are there: capped spins, bodies at rest after a non-finite step.
            assert!(alone.iter().any(|b| b.angvel.length() > 90.0));
            assert!(alone.iter().filter(|b| b.linvel == Vec3::ZERO).count() >= 10);
        }
    }

    #[test]
    fn the_world_inverse_inertia_is_parrys_to_the_bit() {
        let (physics, handle) = world_with_body();
        let body = physics.world.bodies.get(handle).expect("body");
        let m = body.mass_properties().local_mprops;
        for k in 0..200u32 {
            let a = k as f32 * 0.173;
            let axis = Vec3::new(libm::sinf(a), libm::cosf(1.7 * a), 0.3 + 0.1 * a).normalize();
            let rot = Quat::from_axis_angle(axis, a * 2.9);
            let (ours, parrys) = (world_inv_inertia(&m, rot), m.world_inv_inertia(&rot));
            let bits =
                |s: SdpMatrix3<f32>| [s.m11, s.m12, s.m13, s.m22, s.m23, s.m33].map(f32::to_bits);
            assert_eq!(bits(ours), bits(parrys), "orientation {k}");
        }
        let none = MassProperties::default();
        assert_eq!(world_inv_inertia(&none, Quat::IDENTITY), SdpMatrix3::zero());
    }

    #[test]
    fn a_non_finite_step_leaves_the_body_where_it_was_at_rest() {
        let (mut physics, handle) = world_with_body();
        physics.step();
        let settings = StepSettings::of(&physics);
        let mut free = FreeBody::default();
        free.leave(physics.world.bodies.get_mut(handle).expect("body"));
        let before = free.pose;
        free.step(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::ZERO, &settings);
        assert_eq!(free.pose, before);
        assert_eq!((free.linvel, free.angvel), (Vec3::ZERO, Vec3::ZERO));
    }
}

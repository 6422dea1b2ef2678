//! The per-tick vehicle systems: forces computed and applied before rapier steps, the new state
//! read back and tracked along the roads after it.

use crate::components::{
    BodyForces, Chassis, ContactGate, Controls, Motion, RoadTrack, VehicleModel, VehicleState,
};
use crate::forces::{Kinematics, vehicle_forces};
use crate::free_body::{FreeBody, StepSettings, step_four};
use crate::physics::Physics;
use bevy_ecs::prelude::*;
use flockway_core::{DT_S, for_each_car};
use flockway_road::RoadNetwork;
use glam::{DVec3, Vec3};
use multiversion::multiversion;
use rapier3d::prelude::RigidBody;

/// From this many vehicles the per-car passes (forces, read-back, decisions, the junction
/// rule's and the conflict measures' searches) go over the task pool. Handing a pass to it
/// (waking the pool's threads, waiting for the last part) costs about what a few hundred cars'
/// share saves (on a 2-core machine a ring of 250 cars stepped faster on one thread, 500 about
/// even, 1 000 faster over the pool: `cargo bench --bench scale -- ring_step`), so below it the
/// passes [`for_each_car`] runs are split by the join pool instead (from
/// [`flockway_core::JOIN_MIN_CARS`]) and the others run on one thread.
pub const PARALLEL_MIN_VEHICLES: usize = 512;

/// Computes suspension, tyre, drag and drivetrain forces for every vehicle and advances wheel
/// spin, engine and gearbox; a body out of rapier ([`FreeBody`]) is integrated under them in the
/// same pass, a few cars later. Each vehicle reads only the physics world and writes only its own
/// components, so they run in parallel on the task pool with results independent of threads.
pub fn drive_vehicles(
    physics: Res<Physics>,
    network: Res<RoadNetwork>,
    mut vehicles: Query<(
        &Controls,
        &VehicleModel,
        &Chassis,
        &RoadTrack,
        &mut VehicleState,
        &mut BodyForces,
        &mut FreeBody,
    )>,
) {
    let physics: &Physics = &physics;
    let network: &RoadNetwork = &network;
    let settings = StepSettings::of(physics);
    let settings = &settings;
    for_each_car(
        &mut vehicles,
        PARALLEL_MIN_VEHICLES,
        || Integrations::new(settings),
        |pending, item| {
            let (controls, model, chassis, track, mut state, mut out, body) = item;
            let car = Car {
                controls,
                model,
                chassis,
                track,
            };
            drive_one(physics, network, &car, &mut state, &mut out, &body);
            if body.free {
                pending.push(body, *out);
            }
        },
    );
}

/// How many free bodies wait for their integration at most. Any few bodies back to back let the
/// processor overlap one body's chain of dependent square roots and divisions with the next's (a
/// body integrated straight after its forces waits on each link of its chain): 4, 16 and 64 step
/// `dense_road` equally fast, on one thread and on two.
const INTEGRATIONS_WAITING: usize = 16;

/// The free bodies whose forces a part of the force pass has found, integrated one after another
/// when [`INTEGRATIONS_WAITING`] wait and when the part ends (dropped). Each body's integration
/// reads only its own forces and state, so the order makes no difference to any bit.
struct Integrations<'w, 's> {
    settings: &'s StepSettings,
    waiting: Vec<(Mut<'w, FreeBody>, BodyForces)>,
}

impl<'w, 's> Integrations<'w, 's> {
    fn new(settings: &'s StepSettings) -> Self {
        Integrations {
            settings,
            waiting: Vec::with_capacity(INTEGRATIONS_WAITING),
        }
    }

    fn push(&mut self, body: Mut<'w, FreeBody>, forces: BodyForces) {
        self.waiting.push((body, forces));
        if self.waiting.len() == INTEGRATIONS_WAITING {
            self.integrate();
        }
    }

    fn integrate(&mut self) {
        integrate_all(&mut self.waiting, self.settings);
        self.waiting.clear();
    }
}

impl Drop for Integrations<'_, '_> {
    fn drop(&mut self) {
        self.integrate();
    }
}

/// Each body's integration under its forces this tick, four bodies at once and the rest one by
/// one (the same bits either way). Built twice as [`drive_one`] is.
#[multiversion(targets("x86_64+avx2"))]
fn integrate_all<'w>(bodies: &mut [(Mut<'w, FreeBody>, BodyForces)], settings: &StepSettings) {
    let mut fours = bodies.chunks_exact_mut(4);
    for four in &mut fours {
        let forces = flockway_core::arrays::array4(|i| (four[i].1.force, four[i].1.torque));
        if let [a, b, c, d] = four {
            step_four(
                [&mut *a.0, &mut *b.0, &mut *c.0, &mut *d.0],
                forces,
                settings,
            );
        }
    }
    for (body, f) in fours.into_remainder() {
        body.step(f.force, f.torque, settings);
    }
}

/// What the force pass reads of one car.
struct Car<'a> {
    controls: &'a Controls,
    model: &'a VehicleModel,
    chassis: &'a Chassis,
    track: &'a RoadTrack,
}

/// One car's forces. Built twice, for x86-64 and for AVX2 (taken at run time where the CPU has
/// it; the same results to the bit: see `multiversion` in Cargo.toml), with the force stages and
/// the road frames under the axles inlined into each.
#[multiversion(targets("x86_64+avx2"))]
fn drive_one(
    physics: &Physics,
    network: &RoadNetwork,
    car: &Car,
    state: &mut VehicleState,
    out: &mut BodyForces,
    body: &FreeBody,
) {
    let Some((pose, v, w)) = body.state(physics, car.chassis) else {
        *out = BodyForces::default();
        return;
    };
    let kin = Kinematics {
        com: pose.translation,
        rot: pose.rotation,
        v,
        w,
    };
    let (force, torque) = vehicle_forces(
        physics,
        network,
        car.controls,
        car.model,
        &kin,
        car.track,
        state,
    );
    *out = BodyForces { force, torque };
}

/// Replaces the forces of every vehicle body in rapier with this tick's (rapier keeps user forces
/// until they are reset, so adding them each tick would accumulate).
pub fn apply_body_forces(
    mut physics: ResMut<Physics>,
    vehicles: Query<(&Chassis, &BodyForces, &FreeBody)>,
) {
    let physics = &mut *physics;
    let mut apply = |(chassis, f, free): (&Chassis, &BodyForces, &FreeBody)| {
        if !free.free
            && let Some(body) = physics.world.bodies.get_mut(chassis.body)
        {
            replace_forces(body, f.force, f.torque);
        }
    };
    // A list is used once, by the step whose gates made it.
    let gated = std::mem::replace(&mut physics.in_rapier.1, usize::MAX);
    if gated == vehicles.iter().len() {
        // Every car went through the gates: those they left in rapier are all there is to do,
        // and the free cars' state, which their threads have just written, is not read here.
        for car in &physics.in_rapier.0 {
            if let Ok(item) = vehicles.get(*car) {
                apply(item);
            }
        }
    } else {
        vehicles.iter().for_each(apply);
    }
}

/// Sets a rapier body's force and torque for the next step in place of the last ones.
pub(crate) fn replace_forces(body: &mut RigidBody, force: Vec3, torque: Vec3) {
    body.reset_forces(false);
    body.reset_torques(false);
    body.add_force(force, false);
    body.add_torque(torque, false);
}

/// Reads every vehicle's pose and velocity back (from rapier, or its [`FreeBody`]) and tracks
/// it along the roads (in parallel: each vehicle writes only its own components).
pub fn sync_vehicles(
    physics: Res<Physics>,
    network: Res<RoadNetwork>,
    mut vehicles: Query<(
        &Chassis,
        &FreeBody,
        &mut Motion,
        &mut RoadTrack,
        Option<&mut ContactGate>,
    )>,
) {
    let physics: &Physics = &physics;
    let network: &RoadNetwork = &network;
    type Item<'a> = (
        &'a Chassis,
        &'a FreeBody,
        Mut<'a, Motion>,
        Mut<'a, RoadTrack>,
        Option<Mut<'a, ContactGate>>,
    );
    let run = |(chassis, free, mut motion, mut track, gate): Item| {
        let Some((pose, linvel, angvel)) = free.state(physics, chassis) else {
            return;
        };
        let h = DT_S as f32;
        let rot = pose.rotation;
        let forward_mps = linvel.dot(rot * Vec3::X);
        *motion = Motion {
            position: pose.translation,
            rotation: rot,
            linvel,
            angvel,
            forward_mps,
            accel_mps2: (forward_mps - motion.forward_mps) / h,
        };
        track_road(
            network,
            &mut track,
            pose.translation.as_dvec3(),
            rot * Vec3::X,
        );
        track.speed_along_mps = linvel.dot(track.tangent);
        if let Some(mut gate) = gate {
            // Written only when it changes: the gates read every car's gate on the first thread,
            // and a line written here every step would cross back to this thread's core each time.
            let want = gate.rails_wanted(physics, network, &track, &motion);
            if gate.want_rails != want {
                gate.want_rails = want;
            }
        }
    };
    for_each_car(
        &mut vehicles,
        PARALLEL_MIN_VEHICLES,
        || (),
        move |_, item| run(item),
    );
}

/// How far from its junction path's centre line a car still counts as on that path, m.
const JUNCTION_HOLD_M: f64 = 6.0;

/// Updates a road track for a new position: follows the current road with its cursor, moves on
/// past the end of an open road along its lane's link (to the track's `next_road` where the lane
/// leads there), and searches the network when off every road.
pub fn track_road(network: &RoadNetwork, track: &mut RoadTrack, pos: DVec3, forward: Vec3) {
    let Some(geometry) = network.get(track.road) else {
        track.on_road = false;
        return;
    };
    let (mut proj, mut frame) = geometry.project_tracked_frame(pos, &mut track.cursor);
    if !geometry.is_closed()
        && proj.s_m >= geometry.length_m() - 1.0e-6
        && let Some(next) = network
            .lane_next(track.road, track.lane, track.next_road)
            .map(|(road, _)| road)
            .or(track
                .next_road
                .filter(|r| network.link(track.road, *r).is_some()))
            .or_else(|| network.next(track.road))
        && let Some(g2) = network.get(next)
    {
        let mut cursor = g2.cursor_at(0.0);
        let (p2, f2) = g2.project_tracked_frame(pos, &mut cursor);
        // On the next road's surface it is on that road, wherever its centre line runs (a
        // ramp leads into the outer lane of a wider road, whose centre line is lanes away).
        if p2.on_road || p2.distance_m <= proj.distance_m + 1.0e-6 {
            track.road = next;
            track.cursor = cursor;
            proj = p2;
            frame = f2;
        }
    }
    // Inside a junction the paths overlap: a car cutting a corner stays on its own path rather
    // than jumping onto whichever other path is nearer.
    let in_junction =
        network.junction_path(track.road).is_some() && proj.distance_m < JUNCTION_HOLD_M;
    if !proj.on_road
        && !in_junction
        && let Some((id, p)) = network.project(pos)
        && p.on_road
        && id != track.road
        && let Some(g) = network.get(id)
    {
        track.road = id;
        track.cursor = g.cursor_at(p.s_m);
        proj = p;
        frame = g.frame_at(p.s_m);
    }
    track.heading_cos = forward.dot(frame.tangent.as_vec3());
    track.tangent = frame.tangent.as_vec3();
    track.left = frame.left.as_vec3();
    track.width_m = frame.width_m as f32;
    track.s_m = proj.s_m;
    track.lateral_m = proj.lateral_m;
    track.lane = proj.lane;
    track.on_road = proj.on_road;
}

//! The rapier world: its settings, the static colliders built from the roads, and contacts as
//! ECS messages.

use bevy_ecs::prelude::*;
use flockway_core::DT_S;
use flockway_road::{GUARDRAIL_HEIGHT_M, RoadId, RoadNetwork};
use glam::{DVec3, Quat, Vec3};
use rapier3d::prelude::*;
use std::collections::BTreeSet;
use std::sync::Mutex;

/// Collision group of vehicle bodies.
pub const VEHICLE_GROUP: Group = Group::GROUP_1;
/// Collision group of guardrails.
pub const GUARDRAIL_GROUP: Group = Group::GROUP_2;
/// Collision group of the ground plane under the roads.
pub const GROUND_GROUP: Group = Group::GROUP_3;

/// Thickness of a guardrail collider, m: thick enough that a car at top speed (0.4 m per step)
/// cannot pass through it between two steps.
pub const GUARDRAIL_THICKNESS_M: f32 = 0.6;

/// Gravity, m/s² (z up).
pub const GRAVITY: Vec3 = Vec3::new(0.0, 0.0, -9.81);

/// rapier solver substeps per step.
pub const SOLVER_ITERATIONS: usize = 1;

/// How far below the lowest road point the ground lies, m.
pub const GROUND_BELOW_ROADS_M: f32 = 0.05;

/// How far the ground extends beyond the roads' bounding box, m.
pub const GROUND_MARGIN_M: f32 = 2000.0;

/// Thickness of the ground slab, m.
const GROUND_THICKNESS_M: f32 = 10.0;

/// Largest distance between a guardrail's polyline and its simplified collider pieces, m.
pub const GUARDRAIL_TOLERANCE_M: f64 = 0.02;

/// Longest guardrail collider piece, m.
pub const GUARDRAIL_PIECE_M: f64 = 50.0;

const TAG_SHIFT: u32 = 64;
const TAG_VEHICLE: u128 = 1;
const TAG_GUARDRAIL: u128 = 2;
const TAG_GROUND: u128 = 3;

/// What a vehicle touched.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactWith {
    /// Another vehicle.
    Vehicle(Entity),
    /// A guardrail of a road.
    Guardrail(RoadId),
    /// The ground plane (the body itself, not the wheels: a crash or a roll-over).
    Ground,
}

/// A vehicle body started or stopped touching something. A vehicle–vehicle pair gives one
/// message per change, naming either vehicle as `vehicle`.
#[derive(Message, Debug, Clone, Copy, PartialEq, Eq)]
pub struct VehicleContact {
    /// The vehicle.
    pub vehicle: Entity,
    /// What it touched.
    pub other: ContactWith,
    /// `true` when the contact began this step, `false` when it ended.
    pub started: bool,
}

/// Collects rapier's collision events during a step (rapier calls it through `&self`).
#[derive(Default)]
struct EventCollector(Mutex<Vec<CollisionEvent>>);

impl EventHandler for EventCollector {
    fn handle_collision_event(
        &self,
        _bodies: &RigidBodySet,
        _colliders: &ColliderSet,
        event: CollisionEvent,
        _contact_pair: Option<&ContactPair>,
    ) {
        if let Ok(mut events) = self.0.lock() {
            events.push(event);
        }
    }

    fn handle_contact_force_event(
        &self,
        _dt: Real,
        _bodies: &RigidBodySet,
        _colliders: &ColliderSet,
        _contact_pair: &ContactPair,
        _total_force_magnitude: Real,
    ) {
    }

    fn handle_soft_body_tear_event(&self, _soft_bodies: &SoftBodySet, _event: &SoftBodyTearEvent) {}
}

/// The rapier world of the simulation, stepped once per tick at 1/120 s with z up.
#[derive(Resource)]
pub struct Physics {
    /// Bodies, colliders and rapier's pipeline state.
    pub world: PhysicsWorld,
    /// Whether vehicle colliders leave rapier while no other car is within reach and the
    /// guardrails out of their filter while clearly away from them (see `ContactGate`; on by
    /// default). Off, every car is in rapier with the rails in its filter, as rapier alone would
    /// have it: the results are the same, only slower.
    pub gates: bool,
    events: EventCollector,
    statics: Vec<ColliderHandle>,
    ground_z: f32,
    /// Pairs of roads that cross without meeting ([`RoadNetwork::crossings`]): their cars
    /// pass without touching.
    crossings: BTreeSet<(u32, u32)>,
    /// The road each vehicle collider's car is on, by the collider's index (kept only while
    /// there are `crossings`).
    vehicle_roads: Vec<u32>,
    /// Per road, by id: whether its start and its end are bare ([`Physics::bare_ends`]).
    bare_ends: Vec<[bool; 2]>,
    /// The close-car search of the last read-back, whose answers the gates take before the
    /// next step.
    pub(crate) close_cars: crate::gates::CloseCarSearch,
    /// The cars whose bodies the gates left in rapier this step, listed as they went (so the
    /// forces are handed to rapier for these alone, without reading every car's [`FreeBody`]),
    /// and how many cars the gates saw.
    pub(crate) in_rapier: (Vec<Entity>, usize),
}

impl Default for Physics {
    fn default() -> Self {
        let mut world = PhysicsWorld::new();
        world.gravity = GRAVITY;
        world.integration_parameters.dt = DT_S as f32;
        // Bodies touch only in crashes (wheels are ours, not rapier contacts) and no body rests
        // on another, so one solver substep resolves those contacts; each substep integrates
        // every body, and rapier's default four cost 20 % of the whole step with 1000 cars.
        world.integration_parameters.num_solver_iterations = SOLVER_ITERATIONS;
        // No continuous collision detection: at 1/120 s even a car at 250 km/h moves 0.58 m per
        // step, less than the thinnest thing it can hit (a 0.6 m guardrail box, a 1.8 m car),
        // so nothing tunnels; rapier's automatic CCD of every fast body cost 5 % of the step.
        world.integration_parameters.max_ccd_substeps = 0;
        Physics {
            world,
            gates: true,
            events: EventCollector::default(),
            statics: Vec::new(),
            ground_z: 0.0,
            crossings: BTreeSet::new(),
            vehicle_roads: Vec::new(),
            bare_ends: Vec::new(),
            close_cars: crate::gates::CloseCarSearch::default(),
            in_rapier: (Vec::new(), usize::MAX),
        }
    }
}

impl Physics {
    /// Height of the ground plane, m.
    pub fn ground_z(&self) -> f32 {
        self.ground_z
    }

    /// Number of static colliders (guardrail pieces and the ground).
    pub fn static_colliders(&self) -> usize {
        self.statics.len()
    }

    /// Whether any two roads cross without meeting, so that cars' roads must be noted
    /// ([`Physics::note_vehicle_road`]).
    pub fn has_crossings(&self) -> bool {
        !self.crossings.is_empty()
    }

    /// Notes the road the car of vehicle collider `collider` is on, for the step's contacts:
    /// cars on two roads that cross without meeting do not touch.
    pub fn note_vehicle_road(&mut self, collider: ColliderHandle, road: RoadId) {
        let index = collider.into_raw_parts().0 as usize;
        if self.vehicle_roads.len() <= index {
            self.vehicle_roads.resize(index + 1, u32::MAX);
        }
        self.vehicle_roads[index] = road.0;
    }

    /// Whether road `road`'s start and its end (in that order) are bare: the road is open, leads
    /// nowhere from that end, and nothing of any other road (surface or guardrail) comes within
    /// [`BARE_END_CLEARANCE_M`] of the end. A car whose box is over such an end's stretch of road
    /// can touch there only what it could touch between the ends. Both `false` for a road the
    /// statics were not built with.
    pub fn bare_ends(&self, road: RoadId) -> [bool; 2] {
        self.bare_ends
            .get(road.0 as usize)
            .copied()
            .unwrap_or([false; 2])
    }

    /// Replaces the guardrail and ground colliders with ones built from `network`, and takes
    /// its roads that cross without meeting.
    pub fn rebuild_statics(&mut self, network: &RoadNetwork) {
        self.crossings = network
            .crossings()
            .iter()
            .map(|&(a, b)| (a.0, b.0))
            .collect();
        for h in self.statics.drain(..) {
            self.world.remove_collider(h);
        }
        let mut lo = DVec3::INFINITY;
        let mut hi = DVec3::NEG_INFINITY;
        // Each road's surface and guardrails, in a box, for its bare ends.
        let slots = network.iter().map(|(id, _)| id.0 as usize + 1).max();
        let mut boxes: Vec<Option<(DVec3, DVec3)>> = vec![None; slots.unwrap_or(0)];
        for (id, _) in network.iter() {
            let Some(meshes) = network.meshes(id) else {
                continue;
            };
            let surface = meshes
                .surface
                .positions
                .iter()
                .map(|p| DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])));
            let rails = meshes.guardrail_runs.iter().flat_map(|r| r.foot.iter());
            let (road_lo, road_hi) = surface
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |b, p| {
                    (b.0.min(p), b.1.max(p))
                });
            (lo, hi) = (lo.min(road_lo), hi.max(road_hi));
            let (rails_lo, rails_hi) =
                rails.fold((road_lo, road_hi), |b, &p| (b.0.min(p), b.1.max(p)));
            let pad = DVec3::splat(f64::from(GUARDRAIL_THICKNESS_M) + GUARDRAIL_HEIGHT_M);
            boxes[id.0 as usize] = rails_lo
                .is_finite()
                .then_some((rails_lo - pad, rails_hi + pad));
            for run in &meshes.guardrail_runs {
                for (i, j) in simplify(&run.foot, GUARDRAIL_TOLERANCE_M, GUARDRAIL_PIECE_M) {
                    let (a, b) = (run.foot[i], run.foot[j]);
                    let up = (run.up[i] + run.up[j]).normalize_or(DVec3::Z);
                    // Push the box outwards so its inner face lies on the rail line.
                    let left = (run.left[i] + run.left[j]).normalize_or_zero();
                    let outward = match run.side {
                        flockway_road::Side::Left => left,
                        flockway_road::Side::Right => -left,
                    };
                    let along = b - a;
                    let len = along.length();
                    if len < 1.0e-6 {
                        continue;
                    }
                    let x = along / len;
                    let z = (up - x * up.dot(x)).normalize_or(DVec3::Z);
                    let y = z.cross(x);
                    let thickness = f64::from(GUARDRAIL_THICKNESS_M);
                    let centre = (a + b) * 0.5
                        + z * (GUARDRAIL_HEIGHT_M * 0.5)
                        + outward * (thickness * 0.5);
                    let rot = Quat::from_mat3(&glam::Mat3::from_cols(
                        x.as_vec3(),
                        y.as_vec3(),
                        z.as_vec3(),
                    ));
                    // Overlap neighbouring pieces slightly so a car sliding along the rail never
                    // catches an edge between two of them.
                    let collider = ColliderBuilder::cuboid(
                        (len * 0.5) as f32 + 0.05,
                        GUARDRAIL_THICKNESS_M * 0.5,
                        (GUARDRAIL_HEIGHT_M * 0.5) as f32,
                    )
                    .position(Pose::from_parts(centre.as_vec3(), rot))
                    .collision_groups(InteractionGroups::new(
                        GUARDRAIL_GROUP,
                        VEHICLE_GROUP,
                        InteractionTestMode::And,
                    ))
                    .user_data(tag(TAG_GUARDRAIL, u64::from(id.0)))
                    .build();
                    self.statics
                        .push(self.world.insert_collider(collider, None));
                }
            }
        }
        if !lo.is_finite() {
            lo = DVec3::ZERO;
            hi = DVec3::ZERO;
        }
        self.bare_ends = bare_ends(network, &boxes);
        self.ground_z = lo.z as f32 - GROUND_BELOW_ROADS_M;
        // A slab, not a half-space: its bounding box ends at the surface, so cars on the roads
        // above it form no broad-phase pair with it until they come down to it.
        let centre = (lo + hi) * 0.5;
        let half = ((hi - lo) * 0.5).as_vec3() + Vec3::splat(GROUND_MARGIN_M);
        let ground = ColliderBuilder::cuboid(half.x, half.y, GROUND_THICKNESS_M / 2.0)
            .translation(Vec3::new(
                centre.x as f32,
                centre.y as f32,
                self.ground_z - GROUND_THICKNESS_M / 2.0,
            ))
            .collision_groups(InteractionGroups::new(
                GROUND_GROUP,
                VEHICLE_GROUP,
                InteractionTestMode::And,
            ))
            .user_data(tag(TAG_GROUND, 0))
            .build();
        self.statics.push(self.world.insert_collider(ground, None));
    }

    /// Steps rapier once and returns the contacts that began or ended, in rapier's order.
    pub fn step(&mut self) -> Vec<VehicleContact> {
        let hooks = SeparatedBoxes {
            crossings: &self.crossings,
            vehicle_roads: &self.vehicle_roads,
        };
        self.world.step_with_events(&hooks, &self.events);
        let events = match self.events.0.lock() {
            Ok(mut e) => std::mem::take(&mut *e),
            Err(_) => Vec::new(),
        };
        let mut out = Vec::with_capacity(events.len());
        for e in events {
            let (Some(a), Some(b)) = (
                self.world.colliders.get(e.collider1()).map(|c| c.user_data),
                self.world.colliders.get(e.collider2()).map(|c| c.user_data),
            ) else {
                continue;
            };
            let (a, b) = match (untag(a), untag(b)) {
                (Some(a), Some(b)) => (a, b),
                _ => continue,
            };
            let (vehicle, other) = match (a, b) {
                (Tagged::Vehicle(v), o) | (o, Tagged::Vehicle(v)) => (v, o),
                _ => continue,
            };
            let other = match other {
                Tagged::Vehicle(o) => ContactWith::Vehicle(o),
                Tagged::Guardrail(r) => ContactWith::Guardrail(r),
                Tagged::Ground => ContactWith::Ground,
            };
            out.push(VehicleContact {
                vehicle,
                other,
                started: e.started(),
            });
        }
        out
    }

    /// Casts a ray at the ground and guardrails: `(distance, normal)` of the first hit. Used
    /// for wheels with no road under them.
    pub fn cast_ground(&self, origin: Vec3, dir: Vec3, max_m: f32) -> Option<(f32, Vec3)> {
        let filter = QueryFilter::only_fixed().groups(InteractionGroups::new(
            VEHICLE_GROUP,
            GROUND_GROUP | GUARDRAIL_GROUP,
            InteractionTestMode::And,
        ));
        self.world
            .cast_ray_and_get_normal(&Ray::new(origin, dir), max_m, true, filter)
            .map(|(_, hit)| (hit.time_of_impact, hit.normal))
    }
}

/// Clearance beyond which two boxes are certainly not in contact for rapier, m: well above its
/// prediction distance (2 mm), so skipping such pairs changes no contact.
const SEPARATION_MARGIN_M: f32 = 0.05;

/// Physics hooks that skip rapier's contact computation for two boxes (car–car, car–guardrail)
/// that one of their face axes separates. A car's box on a curve or a diagonal road has a
/// bounding box that overlaps the guardrail pieces beside it (≈ 1.2 such pairs per car on a
/// ring), and rapier's pair update with its full box–box test took 20 % of the step with 10 000
/// cars (12 % with this filter); the test costs a few dozen multiplications and keeps every
/// pair closer than the margin, so the contacts are the same.
///
/// They also skip two cars on roads that cross without meeting (one passes over the other).
struct SeparatedBoxes<'a> {
    crossings: &'a BTreeSet<(u32, u32)>,
    vehicle_roads: &'a [u32],
}

impl SeparatedBoxes<'_> {
    /// Whether the cars of colliders `a` and `b` are on two roads that cross without meeting.
    fn on_crossing_roads(&self, a: ColliderHandle, b: ColliderHandle) -> bool {
        if self.crossings.is_empty() {
            return false;
        }
        let road = |h: ColliderHandle| {
            self.vehicle_roads
                .get(h.into_raw_parts().0 as usize)
                .copied()
        };
        match (road(a), road(b)) {
            (Some(ra), Some(rb)) => self.crossings.contains(&(ra.min(rb), ra.max(rb))),
            _ => false,
        }
    }
}

impl PhysicsHooks for SeparatedBoxes<'_> {
    fn filter_contact_pair(&self, context: &PairFilterContext) -> Option<SolverFlags> {
        let (Some(a), Some(b)) = (
            context.colliders.get(context.collider1),
            context.colliders.get(context.collider2),
        ) else {
            return Some(SolverFlags::default());
        };
        if a.user_data >> TAG_SHIFT == TAG_VEHICLE
            && b.user_data >> TAG_SHIFT == TAG_VEHICLE
            && self.on_crossing_roads(context.collider1, context.collider2)
        {
            return None;
        }
        match (a.shape().as_cuboid(), b.shape().as_cuboid()) {
            (Some(ca), Some(cb))
                if boxes_apart(
                    a.position(),
                    ca.half_extents,
                    b.position(),
                    cb.half_extents,
                    SEPARATION_MARGIN_M,
                ) =>
            {
                None
            }
            _ => Some(SolverFlags::default()),
        }
    }
}

/// Whether one of the six face normals of two oriented boxes separates them by more than
/// `margin_m` (a partial separating-axis test: `false` can still mean apart).
fn boxes_apart(a: &Pose, half_a: Vec3, b: &Pose, half_b: Vec3, margin_m: f32) -> bool {
    let axes_a = [
        a.rotation * Vec3::X,
        a.rotation * Vec3::Y,
        a.rotation * Vec3::Z,
    ];
    let axes_b = [
        b.rotation * Vec3::X,
        b.rotation * Vec3::Y,
        b.rotation * Vec3::Z,
    ];
    let d = b.translation - a.translation;
    let reach = |axes: &[Vec3; 3], half: Vec3, l: Vec3| {
        half.x * axes[0].dot(l).abs()
            + half.y * axes[1].dot(l).abs()
            + half.z * axes[2].dot(l).abs()
    };
    (0..3).any(|i| {
        let l = axes_a[i];
        d.dot(l).abs() > half_a[i] + reach(&axes_b, half_b, l) + margin_m
    }) || (0..3).any(|i| {
        let l = axes_b[i];
        d.dot(l).abs() > half_b[i] + reach(&axes_a, half_a, l) + margin_m
    })
}

/// Splits a polyline into pieces `(first, last)` of point indices, each as long as it can be
/// (up to `max_len_m`) while every point it skips lies within `tolerance_m` of its chord.
/// Guardrails are sampled every metre for drawing; as colliders, straight runs need few pieces.
pub fn simplify(points: &[DVec3], tolerance_m: f64, max_len_m: f64) -> Vec<(usize, usize)> {
    let mut pieces = Vec::new();
    let mut start = 0;
    while start + 1 < points.len() {
        let mut end = start + 1;
        while end + 1 < points.len() {
            let candidate = end + 1;
            let (a, b) = (points[start], points[candidate]);
            let chord = b - a;
            let len = chord.length();
            if len > max_len_m {
                break;
            }
            let fits = (start + 1..candidate).all(|k| {
                let p = points[k] - a;
                let t = if len > 0.0 {
                    p.dot(chord) / (len * len)
                } else {
                    0.0
                };
                (p - chord * t.clamp(0.0, 1.0)).length() <= tolerance_m
            });
            if !fits {
                break;
            }
            end = candidate;
        }
        pieces.push((start, end));
        start = end;
    }
    pieces
}

/// The user-data tag of a vehicle's collider.
pub(crate) fn vehicle_tag(entity: Entity) -> u128 {
    tag(TAG_VEHICLE, entity.to_bits())
}

fn tag(kind: u128, value: u64) -> u128 {
    (kind << TAG_SHIFT) | u128::from(value)
}

enum Tagged {
    Vehicle(Entity),
    Guardrail(RoadId),
    Ground,
}

fn untag(data: u128) -> Option<Tagged> {
    let value = data as u64;
    match data >> TAG_SHIFT {
        TAG_VEHICLE => Entity::try_from_bits(value).map(Tagged::Vehicle),
        TAG_GUARDRAIL => Some(Tagged::Guardrail(RoadId(value as u32))),
        TAG_GROUND => Some(Tagged::Ground),
        _ => None,
    }
}

/// Rebuilds the static colliders when the road network changes.
pub fn rebuild_static_colliders(network: Res<RoadNetwork>, mut physics: ResMut<Physics>) {
    if network.is_changed() {
        physics.rebuild_statics(&network);
    }
}

/// How far from a road's end anything of another road must stay for the end to be bare
/// ([`Physics::bare_ends`]), m: beyond the stretch near an end where a car's gate would
/// otherwise stay open, with room for the road's width.
pub const BARE_END_CLEARANCE_M: f64 = 25.0;

/// [`Physics::bare_ends`] for every road of `network`, by id, from each road's `boxes` (its
/// surface and guardrails, widened by a guardrail's thickness and height). An end with a link,
/// a road leading onto it or a junction is not bare; nor is one that another road's box comes
/// within [`BARE_END_CLEARANCE_M`] of. Only the dead ends are measured against the other roads.
fn bare_ends(network: &RoadNetwork, boxes: &[Option<(DVec3, DVec3)>]) -> Vec<[bool; 2]> {
    let size = boxes.len();
    let mut entered = vec![false; size];
    for (id, _) in network.iter() {
        for link in network.links(id) {
            if let Some(e) = entered.get_mut(link.to.0 as usize) {
                *e = true;
            }
        }
    }
    let mut out = vec![[false; 2]; size];
    for (id, g) in network.iter() {
        if g.is_closed() || network.junction_path(id).is_some() {
            continue;
        }
        let lanes = g.lanes();
        let leads_on =
            entered[id.0 as usize] || (0..lanes).any(|l| !network.lane_prev(id, l).is_empty());
        let leads_off = !network.links(id).is_empty();
        let ends = [(0.0, leads_on), (g.length_m(), leads_off)];
        out[id.0 as usize] = ends.map(|(s, leads)| {
            if leads {
                return false;
            }
            let at = g.frame_at(s).pos;
            network.iter().all(|(other, _)| {
                other == id
                    || boxes[other.0 as usize].is_none_or(|(lo, hi)| {
                        (lo - at).max(at - hi).max(DVec3::ZERO).length() > BARE_END_CLEARANCE_M
                    })
            })
        });
    }
    out
}

/// Steps rapier and publishes its contact changes.
pub fn step_physics(mut physics: ResMut<Physics>, mut contacts: MessageWriter<VehicleContact>) {
    let events = physics.step();
    contacts.write_batch(events);
}

/// Moves the contact message buffers on by one tick (messages live two ticks).
pub fn update_contact_messages(mut messages: ResMut<Messages<VehicleContact>>) {
    messages.update();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boxes_apart_only_when_a_face_axis_separates_them() {
        let car = Vec3::new(2.3, 0.9, 0.6);
        let rail = Vec3::new(5.0, 0.3, 0.4);
        let diagonal = Quat::from_rotation_z(std::f32::consts::FRAC_PI_4);
        let at = |x: f32, y: f32, rot: Quat| Pose::from_parts(Vec3::new(x, y, 0.0), rot);
        // A car beside a rail on a diagonal road, 0.85 m from it: the bounding boxes overlap,
        // the boxes do not.
        let offset = diagonal * Vec3::new(0.0, 0.9 + 0.3 + 0.85, 0.0);
        let (car_pose, rail_pose) = (at(0.0, 0.0, diagonal), at(offset.x, offset.y, diagonal));
        assert!(boxes_apart(&car_pose, car, &rail_pose, rail, 0.05));
        // Touching, and within the margin: kept for rapier.
        let close = diagonal * Vec3::new(0.0, 0.9 + 0.3 + 0.01, 0.0);
        let rail_close = at(close.x, close.y, diagonal);
        assert!(!boxes_apart(&car_pose, car, &rail_close, rail, 0.05));
        let overlapping = at(1.0, 0.5, Quat::IDENTITY);
        assert!(!boxes_apart(&car_pose, car, &overlapping, car, 0.05));
        // Nose to tail, 1 m apart; then corner to corner with one car turned.
        let origin = at(0.0, 0.0, Quat::IDENTITY);
        let ahead = at(2.3 * 2.0 + 1.0, 0.0, Quat::IDENTITY);
        assert!(boxes_apart(&origin, car, &ahead, car, 0.05));
        let turned = at(4.0, 3.0, diagonal);
        assert!(boxes_apart(&origin, car, &turned, car, 0.05));
    }

    #[test]
    fn simplify_keeps_straight_runs_in_few_pieces_and_curves_within_tolerance() {
        let line: Vec<DVec3> = (0..=200)
            .map(|i| DVec3::new(f64::from(i), 0.0, 0.0))
            .collect();
        let pieces = simplify(&line, 0.02, 50.0);
        assert_eq!(pieces, vec![(0, 50), (50, 100), (100, 150), (150, 200)]);
        let r = 30.0;
        let arc: Vec<DVec3> = (0..=90)
            .map(|i| {
                let a = f64::from(i).to_radians();
                DVec3::new(r * a.cos(), r * a.sin(), 0.0)
            })
            .collect();
        let pieces = simplify(&arc, 0.02, 50.0);
        assert!(pieces.len() > 5 && pieces.len() < 40, "{}", pieces.len());
        assert_eq!(pieces.first().map(|p| p.0), Some(0));
        assert_eq!(pieces.last().map(|p| p.1), Some(90));
        for w in pieces.windows(2) {
            assert_eq!(w[0].1, w[1].0, "pieces are contiguous");
        }
        // Sagitta of each piece within the tolerance.
        for (i, j) in pieces {
            let half_angle = ((j - i) as f64).to_radians() / 2.0;
            assert!(r * (1.0 - half_angle.cos()) <= 0.02 + 1e-9);
        }
    }
}

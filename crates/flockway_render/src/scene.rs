//! What the renderer draws, prepared on the CPU: the static scene (ground, roads, markings,
//! guardrails, markers) and one instance per vehicle.

use bevy_ecs::prelude::*;
use flockway_drivers::{FlockDriver, HumanDriver, Route, WaveDamper};
use flockway_level::{DestroyerPlaceSpec, Level, TriggerEffectSpec};
use flockway_road::{Mesh, RoadGeometry, RoadId, RoadNetwork, lane_offset};
use flockway_vehicle::{Motion, VehicleModel};
use glam::{DVec3, Quat, Vec3};

/// One vertex of the static scene.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Vertex {
    /// Position, metres, world space.
    pub position: [f32; 3],
    /// Unit normal.
    pub normal: [f32; 3],
    /// Linear RGBA colour.
    pub colour: [f32; 4],
}

/// One vehicle to draw: its pose, size and colour.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VehicleInstance {
    /// Body origin, metres, world space.
    pub translation: [f32; 3],
    /// Body rotation (x, y, z, w).
    pub rotation: [f32; 4],
    /// Length, width and height, metres.
    pub size: [f32; 3],
    /// Linear RGBA paint colour.
    pub colour: [f32; 4],
}

/// Colours of the scene, linear RGB.
pub mod palette {
    /// Grass around the roads.
    pub const GROUND: [f32; 4] = [0.16, 0.25, 0.12, 1.0];
    /// Asphalt.
    pub const ASPHALT: [f32; 4] = [0.055, 0.057, 0.062, 1.0];
    /// Painted lines.
    pub const MARKING: [f32; 4] = [0.85, 0.85, 0.82, 1.0];
    /// Guardrail steel.
    pub const GUARDRAIL: [f32; 4] = [0.45, 0.47, 0.5, 1.0];
    /// Autonomous (flocking) cars.
    pub const AUTONOMOUS: [f32; 4] = [0.05, 0.22, 0.8, 1.0];
    /// Human-like cars: red, as in the thesis.
    pub const HUMAN: [f32; 4] = [0.75, 0.04, 0.03, 1.0];
    /// Cars of other drivers (IDM, plugins).
    pub const OTHER: [f32; 4] = [0.85, 0.6, 0.02, 1.0];
    /// Spawner posts and pads.
    pub const SPAWNER: [f32; 4] = [0.1, 0.7, 0.15, 1.0];
    /// The arrow on a spawner's pad.
    pub const SPAWNER_ARROW: [f32; 4] = [0.85, 1.0, 0.85, 1.0];
    /// A signal showing green.
    pub const SIGNAL_GREEN: [f32; 4] = [0.05, 0.8, 0.1, 1.0];
    /// A signal showing a green that gives way.
    pub const SIGNAL_YIELD: [f32; 4] = [0.45, 0.9, 0.35, 1.0];
    /// A signal showing amber.
    pub const SIGNAL_AMBER: [f32; 4] = [1.0, 0.6, 0.0, 1.0];
    /// A signal showing red.
    pub const SIGNAL_RED: [f32; 4] = [0.9, 0.03, 0.02, 1.0];
    /// Ground grid lines every 10 m.
    pub const GRID: [f32; 4] = [0.2, 0.31, 0.16, 1.0];
    /// Ground grid lines every 100 m.
    pub const GRID_MAJOR: [f32; 4] = [0.27, 0.4, 0.22, 1.0];
    /// Destroyer gates.
    pub const DESTROYER: [f32; 4] = [0.8, 0.1, 0.6, 1.0];
    /// Cars bound for no particular road (they follow their lanes' links).
    pub const NO_DESTINATION: [f32; 4] = [0.45, 0.45, 0.45, 1.0];
    /// Cars by destination: distinct paints, by the destination road's id.
    pub const DESTINATIONS: [[f32; 4]; 8] = [
        [0.9, 0.45, 0.02, 1.0],
        [0.05, 0.55, 0.9, 1.0],
        [0.75, 0.05, 0.65, 1.0],
        [0.1, 0.7, 0.2, 1.0],
        [0.95, 0.85, 0.05, 1.0],
        [0.55, 0.25, 0.9, 1.0],
        [0.05, 0.8, 0.75, 1.0],
        [0.9, 0.1, 0.15, 1.0],
    ];

    /// The paint of a car bound for `road` (grey for none).
    pub fn destination(road: Option<super::RoadId>) -> [f32; 4] {
        road.map_or(NO_DESTINATION, |r| {
            DESTINATIONS[r.0 as usize % DESTINATIONS.len()]
        })
    }

    /// Link arrows in the editor: which lane leads onto which.
    pub const LINK: [f32; 4] = [0.15, 0.8, 0.95, 1.0];
    /// Detector loops: a rectangle on each lane a detector covers.
    pub const DETECTOR: [f32; 4] = [0.55, 0.9, 1.0, 1.0];
    /// Speed-limit trigger stretches (translucent).
    pub const SPEED_TRIGGER: [f32; 4] = [1.0, 0.55, 0.0, 0.35];
    /// Friction trigger stretches (translucent).
    pub const FRICTION_TRIGGER: [f32; 4] = [0.1, 0.5, 1.0, 0.35];
}

/// Half the side of the square an empty level's view frames, metres.
pub const EMPTY_VIEW_M: f32 = 150.0;

/// The scene that changes only when the level is edited, as one triangle list.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StaticScene {
    /// Vertices.
    pub vertices: Vec<Vertex>,
    /// Three indices per triangle; opaque triangles first, then [`StaticScene::translucent_from`].
    pub indices: Vec<u32>,
    /// Index where the translucent triangles (trigger stretches) begin.
    pub translucent_from: u32,
    /// Lowest corner of everything built on the ground, metres.
    pub min: Vec3,
    /// Highest corner.
    pub max: Vec3,
}

impl StaticScene {
    /// Builds the ground, every road's surface, markings and guardrails, and markers for the
    /// level's spawners, destroyers, detectors and triggers.
    pub fn build(network: &RoadNetwork, level: &Level) -> StaticScene {
        let mut scene = StaticScene {
            min: Vec3::splat(f32::INFINITY),
            max: Vec3::splat(f32::NEG_INFINITY),
            ..StaticScene::default()
        };
        for (id, _) in network.iter() {
            if let Some(m) = network.meshes(id) {
                scene.add_mesh(&m.surface, palette::ASPHALT);
                scene.add_mesh(&m.markings, palette::MARKING);
                scene.add_mesh(&m.guardrails, palette::GUARDRAIL);
            }
        }
        if !scene.min.is_finite() {
            // An empty level shows a few hundred metres: room to draw a road cars can use.
            scene.min = Vec3::new(-EMPTY_VIEW_M, -EMPTY_VIEW_M, 0.0);
            scene.max = Vec3::new(EMPTY_VIEW_M, EMPTY_VIEW_M, 0.0);
        }
        // Ground: a quad well beyond the roads, just under them.
        let pad = 0.5 * (scene.max - scene.min).truncate().max_element() + 50.0;
        let (lo, hi) = (scene.min.truncate() - pad, scene.max.truncate() + pad);
        let z = scene.min.z - 0.05;
        scene.quad(
            [
                Vec3::new(lo.x, lo.y, z),
                Vec3::new(hi.x, lo.y, z),
                Vec3::new(hi.x, hi.y, z),
                Vec3::new(lo.x, hi.y, z),
            ],
            Vec3::Z,
            palette::GROUND,
        );
        let road = |name: &str| network.id(name).and_then(|id| network.get(id));
        for s in &level.spawners {
            if let Some(g) = road(&s.road) {
                // A pad with an arrow on the lane it spawns in, and a post beside the road.
                let f = g.frame_at(s.s_m);
                let lane_w = f.width_m / f64::from(g.lanes().max(1));
                let centre = f.offset(lane_offset(f.width_m, g.lanes(), s.lane)) + f.up * 0.04;
                let (t, l, up) = (f.tangent, f.left, f.up);
                let (half_l, half_w) = (2.5, 0.5 * (lane_w - 0.5).max(0.8));
                let corner = |a: f64, b: f64| (centre + t * a + l * b).as_vec3();
                scene.quad(
                    [
                        corner(-half_l, -half_w),
                        corner(half_l, -half_w),
                        corner(half_l, half_w),
                        corner(-half_l, half_w),
                    ],
                    up.as_vec3(),
                    palette::SPAWNER,
                );
                let tip = centre + up * 0.02;
                let arrow = |a: f64, b: f64| (tip + t * a + l * b).as_vec3();
                scene.triangle(
                    [
                        arrow(-1.5, -0.7 * half_w),
                        arrow(2.0, 0.0),
                        arrow(-1.5, 0.7 * half_w),
                    ],
                    up.as_vec3(),
                    palette::SPAWNER_ARROW,
                );
                let side = f.offset(-0.5 * f.width_m - 1.2);
                scene.cuboid(
                    side.as_vec3(),
                    f.tangent.as_vec3(),
                    Vec3::new(0.8, 0.8, 3.0),
                    palette::SPAWNER,
                );
            }
        }
        for d in &level.destroyers {
            match &d.place {
                DestroyerPlaceSpec::OnRoad { road: name, s_m } => {
                    if let Some(g) = road(name) {
                        let f = g.frame_at(*s_m);
                        let t = f.tangent.as_vec3();
                        for side in [-1.0, 1.0] {
                            let foot = f.offset(side * (0.5 * f.width_m + 0.8)).as_vec3();
                            scene.cuboid(foot, t, Vec3::new(0.5, 0.5, 4.0), palette::DESTROYER);
                        }
                        let top = f.offset(0.0).as_vec3() + f.up.as_vec3() * 3.6;
                        scene.cuboid(
                            top,
                            t,
                            Vec3::new(0.4, f.width_m as f32 + 2.1, 0.4),
                            palette::DESTROYER,
                        );
                    }
                }
                DestroyerPlaceSpec::Volume { min, max } => {
                    let (a, b) = (min.as_vec3(), max.as_vec3());
                    let c = 0.5 * (a + b);
                    scene.cuboid(
                        Vec3::new(c.x, c.y, a.z),
                        Vec3::X,
                        (b - a).abs().max(Vec3::splat(0.1)),
                        [
                            palette::DESTROYER[0],
                            palette::DESTROYER[1],
                            palette::DESTROYER[2],
                            0.3,
                        ],
                    );
                }
            }
        }
        for d in &level.detectors {
            let Some(g) = road(&d.road) else { continue };
            let f = g.frame_at(d.s_m);
            let lane_w = f.width_m / f64::from(g.lanes().max(1));
            let all: Vec<u32> = (0..g.lanes()).collect();
            for &lane in d.lanes.as_deref().unwrap_or(&all) {
                let across = flockway_road::lane_offset(f.width_m, g.lanes(), lane);
                // A loop cut into the lane: 2 m along it, the lane's width less 0.6 m, just
                // above the asphalt.
                scene.cuboid(
                    f.offset(across).as_vec3(),
                    f.tangent.as_vec3(),
                    Vec3::new(2.0, (lane_w as f32 - 0.6).max(0.5), 0.04),
                    palette::DETECTOR,
                );
            }
        }
        scene.translucent_from = scene.indices.len() as u32;
        for t in &level.triggers {
            if let Some(g) = road(&t.road) {
                let colour = match t.effect {
                    TriggerEffectSpec::SpeedLimit { .. } => palette::SPEED_TRIGGER,
                    TriggerEffectSpec::Friction { .. } => palette::FRICTION_TRIGGER,
                };
                scene.strip(g, t.from_m, t.to_m, colour);
            }
        }
        scene
    }

    /// Lines on the ground every 10 m (stronger every 100 m), so distances can be judged; the
    /// editor draws them, `flockway render` does not.
    pub fn add_grid(&mut self) {
        if !(self.min.is_finite() && self.max.is_finite()) {
            return;
        }
        let pad = 0.5 * (self.max - self.min).truncate().max_element() + 50.0;
        let lo = ((self.min.truncate() - pad) / 10.0).floor() * 10.0;
        let hi = ((self.max.truncate() + pad) / 10.0).ceil() * 10.0;
        // At most ~400 lines a side: a huge level gets only its 100 m lines.
        let step = if (hi - lo).max_element() > 4000.0 {
            100.0
        } else {
            10.0
        };
        let z = self.min.z - 0.03;
        let mut opaque = StaticScene::default();
        let count = |a: f32, b: f32| ((b - a) / step).round() as i64;
        for k in 0..=count(lo.x, hi.x) {
            let x = lo.x + k as f32 * step;
            let major = (x / 100.0).round() * 100.0 == x;
            let w = if major { 0.35 } else { 0.12 };
            let c = if major {
                palette::GRID_MAJOR
            } else {
                palette::GRID
            };
            opaque.quad(
                [
                    Vec3::new(x - w, lo.y, z),
                    Vec3::new(x + w, lo.y, z),
                    Vec3::new(x + w, hi.y, z),
                    Vec3::new(x - w, hi.y, z),
                ],
                Vec3::Z,
                c,
            );
        }
        for k in 0..=count(lo.y, hi.y) {
            let y = lo.y + k as f32 * step;
            let major = (y / 100.0).round() * 100.0 == y;
            let w = if major { 0.35 } else { 0.12 };
            let c = if major {
                palette::GRID_MAJOR
            } else {
                palette::GRID
            };
            opaque.quad(
                [
                    Vec3::new(lo.x, y - w, z + 0.001),
                    Vec3::new(hi.x, y - w, z + 0.001),
                    Vec3::new(hi.x, y + w, z + 0.001),
                    Vec3::new(lo.x, y + w, z + 0.001),
                ],
                Vec3::Z,
                c,
            );
        }
        self.splice_opaque(opaque);
    }

    /// Adds `opaque`'s triangles before the translucent trigger stretches.
    fn splice_opaque(&mut self, opaque: StaticScene) {
        let at = self.translucent_from as usize;
        let base = self.vertices.len() as u32;
        self.vertices.extend(opaque.vertices);
        let indices: Vec<u32> = opaque.indices.iter().map(|i| base + i).collect();
        self.translucent_from += indices.len() as u32;
        self.indices.splice(at..at, indices);
    }

    /// An arrow on the road surface for every lane pair of every link, from the last metres of
    /// a lane across the joint onto the first metres of the lane it leads onto; the editor
    /// draws them, so which lane goes where can be seen.
    pub fn add_links(&mut self, network: &RoadNetwork) {
        let mut arrows = StaticScene::default();
        for (id, from) in network.iter() {
            for link in network.links(id) {
                let Some(to) = network.get(link.to) else {
                    continue;
                };
                for &(a, b) in &link.lanes {
                    let len = from.length_m();
                    let path = [
                        (from, a, (len - 9.0).max(0.5 * len)),
                        (from, a, len),
                        (to, b, 7.0f64.min(0.5 * to.length_m())),
                    ]
                    .map(|(g, lane, s)| {
                        let f = g.frame_at(s);
                        (f.offset(g.lane_offset_m(lane, s)) + f.up * 0.08).as_vec3()
                    });
                    arrows.arrow(&path, 0.35, 1.6, palette::LINK);
                }
            }
        }
        self.splice_opaque(arrows);
    }

    /// A flat arrow along `path` (lying on the ground), `width` wide with a head `head` long.
    fn arrow(&mut self, path: &[Vec3], width: f32, head: f32, colour: [f32; 4]) {
        let n = path.len();
        if n < 2 {
            return;
        }
        let tip = path[n - 1];
        let dir = (tip - path[n - 2])
            .truncate()
            .normalize_or(glam::Vec2::X)
            .extend(0.0);
        let neck = tip - dir * head;
        let side = |d: Vec3| Vec3::Z.cross(d).normalize_or(Vec3::Y);
        for k in 0..n - 1 {
            let (p, q) = (path[k], if k == n - 2 { neck } else { path[k + 1] });
            let d = q - p;
            if d.truncate().length() < 1e-3 {
                continue;
            }
            let l = side(d) * (0.5 * width);
            self.quad([p - l, q - l, q + l, p + l], Vec3::Z, colour);
        }
        let l = side(dir) * (1.6 * width);
        self.triangle([neck - l, tip, neck + l], Vec3::Z, colour);
    }

    fn triangle(&mut self, corners: [Vec3; 3], normal: Vec3, colour: [f32; 4]) {
        let base = self.vertices.len() as u32;
        for c in corners {
            self.vertices.push(Vertex {
                position: c.to_array(),
                normal: normal.to_array(),
                colour,
            });
        }
        self.indices.extend_from_slice(&[base, base + 1, base + 2]);
    }

    fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    fn add_mesh(&mut self, mesh: &Mesh, colour: [f32; 4]) {
        let base = self.vertices.len() as u32;
        for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
            self.grow(Vec3::from_array(*p));
            self.vertices.push(Vertex {
                position: *p,
                normal: *n,
                colour,
            });
        }
        self.indices.extend(mesh.indices.iter().map(|i| base + i));
    }

    fn quad(&mut self, corners: [Vec3; 4], normal: Vec3, colour: [f32; 4]) {
        let base = self.vertices.len() as u32;
        for c in corners {
            self.vertices.push(Vertex {
                position: c.to_array(),
                normal: normal.to_array(),
                colour,
            });
        }
        self.indices
            .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
    }

    /// A box standing on `foot`, its length along `forward` (flattened), of `size` (l, w, h).
    fn cuboid(&mut self, foot: Vec3, forward: Vec3, size: Vec3, colour: [f32; 4]) {
        let f = Vec3::new(forward.x, forward.y, 0.0).normalize_or(Vec3::X);
        let l = Vec3::Z.cross(f);
        let rot = Quat::from_mat3(&glam::Mat3::from_cols(f, l, Vec3::Z));
        let centre = foot + Vec3::Z * (0.5 * size.z);
        for (corners, normal) in box_faces(size) {
            let world = corners.map(|c| centre + rot * c);
            self.quad(world, rot * normal, colour);
        }
    }

    /// A translucent strip over the whole width of a road between two arc positions.
    fn strip(&mut self, road: &RoadGeometry, from_m: f64, to_m: f64, colour: [f32; 4]) {
        let len = road.delta_s(from_m, to_m).max(0.0);
        let steps = ((len / 2.0).ceil() as usize).max(1);
        let base = self.vertices.len() as u32;
        for k in 0..=steps {
            let s = from_m + len * k as f64 / steps as f64;
            let f = road.frame_at(s);
            let lift: DVec3 = f.up * 0.03;
            for lat in [-0.5 * f.width_m, 0.5 * f.width_m] {
                self.vertices.push(Vertex {
                    position: (f.offset(lat) + lift).as_vec3().to_array(),
                    normal: f.up.as_vec3().to_array(),
                    colour,
                });
            }
        }
        for k in 0..steps as u32 {
            let (r0, l0, r1, l1) = (
                base + 2 * k,
                base + 2 * k + 1,
                base + 2 * k + 2,
                base + 2 * k + 3,
            );
            self.indices.extend_from_slice(&[r0, r1, l1, r0, l1, l0]);
        }
    }
}

/// The six faces of a box of `size` centred on the origin: corners counter-clockwise seen from
/// outside, and the outward normal.
pub fn box_faces(size: Vec3) -> [([Vec3; 4], Vec3); 6] {
    let h = 0.5 * size;
    let c = |x: f32, y: f32, z: f32| Vec3::new(x * h.x, y * h.y, z * h.z);
    [
        (
            [
                c(1., -1., -1.),
                c(1., 1., -1.),
                c(1., 1., 1.),
                c(1., -1., 1.),
            ],
            Vec3::X,
        ),
        (
            [
                c(-1., 1., -1.),
                c(-1., -1., -1.),
                c(-1., -1., 1.),
                c(-1., 1., 1.),
            ],
            -Vec3::X,
        ),
        (
            [
                c(1., 1., -1.),
                c(-1., 1., -1.),
                c(-1., 1., 1.),
                c(1., 1., 1.),
            ],
            Vec3::Y,
        ),
        (
            [
                c(-1., -1., -1.),
                c(1., -1., -1.),
                c(1., -1., 1.),
                c(-1., -1., 1.),
            ],
            -Vec3::Y,
        ),
        (
            [
                c(-1., -1., 1.),
                c(1., -1., 1.),
                c(1., 1., 1.),
                c(-1., 1., 1.),
            ],
            Vec3::Z,
        ),
        (
            [
                c(-1., 1., -1.),
                c(1., 1., -1.),
                c(1., -1., -1.),
                c(-1., -1., -1.),
            ],
            -Vec3::Z,
        ),
    ]
}

/// One vertex of the vehicle mesh, in units of the vehicle's size.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CarVertex {
    /// Position as a share of (length, width, height), relative to the body origin.
    pub position: [f32; 3],
    /// Unit normal.
    pub normal: [f32; 3],
    /// Brightness factor (1 paint, lower for the glasshouse).
    pub shade: f32,
}

/// The car shape every vehicle instance scales: a body and a darker glasshouse, with the body
/// origin at the centre of mass height above the ground (as the physics body is).
pub fn car_mesh(com_height_share: f32) -> (Vec<CarVertex>, Vec<u16>) {
    let mut vertices = Vec::new();
    let mut indices = Vec::new();
    // (centre, size, shade) in units of the car's size; the body sits 0.14 above the ground.
    let parts = [
        (
            Vec3::new(0.0, 0.0, 0.14 + 0.25),
            Vec3::new(1.0, 1.0, 0.5),
            1.0,
        ),
        (
            Vec3::new(-0.06, 0.0, 0.64 + 0.18),
            Vec3::new(0.52, 0.88, 0.36),
            0.35,
        ),
    ];
    for (centre, size, shade) in parts {
        for (corners, normal) in box_faces(size) {
            let base = vertices.len() as u16;
            for c in corners {
                let p = centre + c - Vec3::Z * com_height_share;
                vertices.push(CarVertex {
                    position: p.to_array(),
                    normal: normal.to_array(),
                    shade,
                });
            }
            indices.extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
        }
    }
    (vertices, indices)
}

/// Share of a car's height at which its body origin (the centre of mass) sits above the ground.
pub const COM_HEIGHT_SHARE: f32 = 0.45 / 1.4;

/// Every vehicle of one fixed step: instances sorted by entity, with their entities.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VehicleFrame {
    /// The vehicles' entities, ascending.
    pub ids: Vec<Entity>,
    /// Their instances, in the same order.
    pub instances: Vec<VehicleInstance>,
    /// A bar across each signalised lane at its line, in the signal's colour for it now.
    pub signals: Vec<VehicleInstance>,
}

/// What a vehicle's paint tells.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ColourBy {
    /// Its driver: autonomous blue, human-like red, others amber.
    #[default]
    Driver,
    /// The road it is bound for ([`palette::destination`]); grey for none.
    Destination,
}

impl VehicleFrame {
    /// Collects every vehicle's instance from a simulation world, coloured by driver.
    pub fn capture(&mut self, world: &mut World) {
        self.capture_by(world, ColourBy::Driver);
    }

    /// Collects every vehicle's instance from a simulation world, coloured as `by` says.
    pub fn capture_by(&mut self, world: &mut World, by: ColourBy) {
        let mut query = world.query::<(
            Entity,
            &Motion,
            &VehicleModel,
            Option<&HumanDriver>,
            Has<FlockDriver>,
            Has<WaveDamper>,
            Option<&Route>,
        )>();
        let mut rows: Vec<_> = query
            .iter(world)
            .map(|(e, m, model, human, flock, damper, route)| {
                let c = &model.0.params.chassis;
                let colour = match (by, human, flock || damper) {
                    (ColourBy::Destination, ..) => {
                        palette::destination(route.and_then(Route::destination))
                    }
                    (_, Some(_), _) => palette::HUMAN,
                    (_, None, true) => palette::AUTONOMOUS,
                    _ => palette::OTHER,
                };
                (
                    e,
                    VehicleInstance {
                        translation: m.position.to_array(),
                        rotation: m.rotation.to_array(),
                        size: [c.length_m, c.width_m, c.height_m],
                        colour,
                    },
                )
            })
            .collect();
        rows.sort_by_key(|(e, _)| *e);
        self.ids.clear();
        self.instances.clear();
        for (e, i) in rows {
            self.ids.push(e);
            self.instances.push(i);
        }
        self.signals.clear();
        if let (Some(network), Some(signals)) = (
            world.get_resource::<RoadNetwork>(),
            world.get_resource::<flockway_drivers::Signals>(),
        ) {
            signal_bars(network, signals, &mut self.signals);
        }
    }

    /// Blends the previous step's poses into this step's for a frame between them (`alpha` 0
    /// is `prev`, 1 is `self`), matching vehicles by entity; a vehicle new in this step is drawn
    /// as it is.
    pub fn interpolate(&self, prev: &VehicleFrame, alpha: f32, out: &mut Vec<VehicleInstance>) {
        out.clear();
        let mut j = 0;
        for (id, n) in self.ids.iter().zip(&self.instances) {
            while j < prev.ids.len() && prev.ids[j] < *id {
                j += 1;
            }
            out.push(match prev.ids.get(j) {
                Some(pid) if pid == id => {
                    let p = &prev.instances[j];
                    let t = Vec3::from_array(p.translation)
                        .lerp(Vec3::from_array(n.translation), alpha);
                    let r = Quat::from_array(p.rotation).slerp(Quat::from_array(n.rotation), alpha);
                    VehicleInstance {
                        translation: t.to_array(),
                        rotation: r.to_array(),
                        ..*n
                    }
                }
                _ => *n,
            });
        }
        out.extend_from_slice(&self.signals);
    }
}

/// A bar across the end of every lane a signal controls, at its line, coloured by what the
/// signal shows that lane's movement (the first of its movements: lanes of one approach usually
/// share a state).
pub fn signal_bars(
    network: &RoadNetwork,
    signals: &flockway_drivers::Signals,
    out: &mut Vec<VehicleInstance>,
) {
    for (j, junction) in network.junctions().iter().enumerate() {
        let Some(states) = signals.states(j) else {
            continue;
        };
        let mut done: Vec<(u32, u32)> = Vec::new();
        for (path, &state) in junction.paths.iter().zip(states) {
            if done.contains(&path.from) {
                continue;
            }
            done.push(path.from);
            let Some(g) = network.get(RoadId(path.from.0)) else {
                continue;
            };
            // Just past the line, where the car held at it does not cover it.
            let s = g.length_m();
            let f = g.frame_at(s);
            let pos = f.offset(g.lane_offset_m(path.from.1, s)) + f.tangent * 0.6 + f.up * 0.02;
            let along =
                Vec3::new(f.tangent.x as f32, f.tangent.y as f32, 0.0).normalize_or(Vec3::X);
            let colour = match state {
                flockway_road::SignalState::Green => palette::SIGNAL_GREEN,
                flockway_road::SignalState::GreenYield => palette::SIGNAL_YIELD,
                flockway_road::SignalState::Amber => palette::SIGNAL_AMBER,
                flockway_road::SignalState::Red => palette::SIGNAL_RED,
            };
            let width = (f.width_m / f64::from(g.lanes().max(1))) as f32 - 0.4;
            out.push(VehicleInstance {
                translation: pos.as_vec3().to_array(),
                rotation: Quat::from_rotation_arc(Vec3::X, along).to_array(),
                size: [1.0, width, 0.12],
                colour,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn instance(x: f32) -> VehicleInstance {
        VehicleInstance {
            translation: [x, 0.0, 0.0],
            rotation: Quat::IDENTITY.to_array(),
            size: [4.6, 1.8, 1.4],
            colour: palette::HUMAN,
        }
    }

    #[test]
    fn interpolation_matches_vehicles_by_entity_across_spawns_and_despawns() {
        let mut world = World::new();
        let mut ids = [(); 3].map(|_| world.spawn_empty().id());
        // Frames hold entities ascending, whatever order the world hands them out in.
        ids.sort();
        let [a, b, c] = ids;
        let prev = VehicleFrame {
            ids: vec![a, b],
            instances: vec![instance(0.0), instance(10.0)],
            signals: Vec::new(),
        };
        // `a` left, `c` arrived: `b` blends with its own previous pose, `c` is drawn as is.
        let next = VehicleFrame {
            ids: vec![b, c],
            instances: vec![instance(12.0), instance(50.0)],
            signals: vec![instance(-5.0)],
        };
        let mut out = Vec::new();
        next.interpolate(&prev, 0.25, &mut out);
        // The vehicles, then the signal bars as they are.
        assert_eq!(out.len(), 3);
        assert_eq!(out[2], instance(-5.0));
        assert!((out[0].translation[0] - 10.5).abs() < 1e-6);
        assert_eq!(out[1].translation[0], 50.0);
    }

    #[test]
    fn box_faces_point_outwards_and_wind_counter_clockwise() {
        for (corners, normal) in box_faces(Vec3::new(2.0, 1.0, 0.5)) {
            let n = (corners[1] - corners[0])
                .cross(corners[2] - corners[0])
                .normalize();
            assert!((n - normal).length() < 1e-6, "{n} vs {normal}");
            let centre = corners.iter().copied().sum::<Vec3>() / 4.0;
            assert!(centre.dot(normal) > 0.0);
        }
    }

    #[test]
    fn each_detector_loop_is_a_rectangle_on_its_lane() {
        let mut level =
            flockway_level::load_level(std::path::Path::new("../../levels/dense_road.ron"))
                .expect("shipped level");
        let network = RoadNetwork::build_with(&level.roads, &level.junctions).expect("network");
        let painted = |scene: &StaticScene| {
            scene
                .vertices
                .iter()
                .filter(|v| v.colour == palette::DETECTOR)
                .map(|v| Vec3::from(v.position))
                .collect::<Vec<_>>()
        };
        assert!(painted(&StaticScene::build(&network, &level)).is_empty());
        level.detectors = vec![flockway_level::DetectorSpec {
            name: "loop".into(),
            road: "main".into(),
            s_m: 100.0,
            lanes: Some(vec![0, 3]),
            period_s: 60.0,
        }];
        let loops = painted(&StaticScene::build(&network, &level));
        // Two boxes of six faces, four corners each; 2 m along the straight at x = 100 m, on
        // lanes 0 and 3 (3 m wide, centred 4.5 m right and left of the centre line).
        assert_eq!(loops.len(), 2 * 6 * 4);
        assert!(loops.iter().all(|p| (p.x - 100.0).abs() <= 1.0 + 1e-3));
        let (right, left): (Vec<&Vec3>, Vec<&Vec3>) = loops.iter().partition(|p| p.y < 0.0);
        assert_eq!((right.len(), left.len()), (24, 24));
        assert!(right.iter().all(|p| (p.y + 4.5).abs() <= 1.2 + 1e-3));
        assert!(left.iter().all(|p| (p.y - 4.5).abs() <= 1.2 + 1e-3));
    }

    #[test]
    fn each_signalised_lane_gets_a_bar_at_its_line_in_the_colour_it_shows() {
        let level =
            flockway_level::load_level(std::path::Path::new("../../levels/signal_queue.ron"))
                .expect("shipped level");
        let network = RoadNetwork::build_with(&level.roads, &level.junctions).expect("network");
        let mut signals = flockway_drivers::Signals::from_network(&network);
        let mut bars = Vec::new();
        signals.update(10.0);
        signal_bars(&network, &signals, &mut bars);
        assert_eq!(bars.len(), 1);
        assert_eq!(bars[0].colour, palette::SIGNAL_GREEN);
        // Just past the line, 400 m along the approach, across its lane.
        assert!(
            (bars[0].translation[0] - 400.6).abs() < 0.01,
            "{:?}",
            bars[0]
        );
        assert!(bars[0].size[1] > 2.0);
        bars.clear();
        signals.update(28.0);
        signal_bars(&network, &signals, &mut bars);
        assert_eq!(bars[0].colour, palette::SIGNAL_AMBER);
        bars.clear();
        signals.update(45.0);
        signal_bars(&network, &signals, &mut bars);
        assert_eq!(bars[0].colour, palette::SIGNAL_RED);
    }
}

//! Triangle meshes of a road (surface, lane markings, guardrails), shared by physics and rendering.

use crate::geometry::{RoadFrame, RoadGeometry};
use glam::DVec3;

/// Spacing of mesh stations along the road, in metres.
pub const STATION_STEP_M: f64 = 1.0;
/// Width of a painted line, in metres.
pub const MARKING_WIDTH_M: f64 = 0.15;
/// Length of a dash between lanes, in metres.
pub const DASH_M: f64 = 3.0;
/// Gap between dashes, in metres.
pub const GAP_M: f64 = 6.0;
/// How far painted lines sit above the surface so they never z-fight with it, in metres.
pub const MARKING_LIFT_M: f64 = 0.01;
/// Distance of a guardrail outside the road edge, in metres.
pub const GUARDRAIL_OFFSET_M: f64 = 0.25;
/// Height of a guardrail above the surface, in metres.
pub const GUARDRAIL_HEIGHT_M: f64 = 0.8;

/// An indexed triangle list (counter-clockwise front faces) in world space.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions in metres.
    pub positions: Vec<[f32; 3]>,
    /// Unit vertex normals.
    pub normals: Vec<[f32; 3]>,
    /// Three indices per triangle.
    pub indices: Vec<u32>,
}

impl Mesh {
    fn vertex(&mut self, pos: DVec3, normal: DVec3) -> u32 {
        let i = self.positions.len() as u32;
        self.positions.push(pos.as_vec3().to_array());
        self.normals.push(normal.as_vec3().to_array());
        i
    }

    /// Two triangles `a b c`, `a c d` (counter-clockwise seen from the front).
    fn quad(&mut self, a: u32, b: u32, c: u32, d: u32) {
        self.indices.extend_from_slice(&[a, b, c, a, c, d]);
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }
}

/// Which side of the road a guardrail is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// The left edge (in the direction of travel).
    Left,
    /// The right edge.
    Right,
}

/// One continuous run of guardrail: the polyline of its foot, for colliders.
#[derive(Debug, Clone, PartialEq)]
pub struct GuardrailRun {
    /// Which edge it follows.
    pub side: Side,
    /// Arc position where it starts, in metres.
    pub from_s_m: f64,
    /// Arc position where it ends, in metres.
    pub to_s_m: f64,
    /// Foot of the rail at each station, world space.
    pub foot: Vec<DVec3>,
    /// Surface normal at each station (the rail rises along it).
    pub up: Vec<DVec3>,
    /// Unit vector across the road towards its left edge at each station.
    pub left: Vec<DVec3>,
}

/// Every mesh of one road, built from its geometry once per edit.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RoadMeshes {
    /// The drivable surface, one strip per lane.
    pub surface: Mesh,
    /// Painted lines: solid edges, dashed lane boundaries.
    pub markings: Mesh,
    /// Guardrail walls (both faces).
    pub guardrails: Mesh,
    /// Guardrail runs as polylines, for physics.
    pub guardrail_runs: Vec<GuardrailRun>,
}

impl RoadMeshes {
    /// Builds all meshes of a road.
    pub fn build(road: &RoadGeometry) -> RoadMeshes {
        let stations: Vec<RoadFrame> = road
            .stations(STATION_STEP_M)
            .into_iter()
            .map(|s| station_frame(road, s))
            .collect();
        let lanes = road.lanes();
        let mut out = RoadMeshes::default();

        // Surface: one vertex per lane boundary per station.
        let cols = lanes as usize + 1;
        for f in &stations {
            for b in 0..cols {
                let lat = -0.5 * f.width_m + f.width_m * b as f64 / f64::from(lanes);
                out.surface.vertex(f.offset(lat), f.up);
            }
        }
        for i in 0..stations.len().saturating_sub(1) {
            for b in 0..lanes as usize {
                let (r0, l0) = ((i * cols + b) as u32, (i * cols + b + 1) as u32);
                let (r1, l1) = (r0 + cols as u32, l0 + cols as u32);
                // Right edge to left edge is +left; forward is +tangent: (r0, r1, l1, l0) is CCW from above.
                out.surface.quad(r0, r1, l1, l0);
            }
        }

        // Markings: solid edges, dashed boundaries between lanes.
        for i in 0..stations.len().saturating_sub(1) {
            let (f0, f1) = (&stations[i], &stations[i + 1]);
            let mid_s = 0.5 * (f0.s_m + f1.s_m);
            let dash_on = mid_s.rem_euclid(DASH_M + GAP_M) < DASH_M;
            for b in 0..=lanes {
                let is_edge = b == 0 || b == lanes;
                if !is_edge && !dash_on {
                    continue;
                }
                let lat =
                    |f: &RoadFrame| -0.5 * f.width_m + f.width_m * f64::from(b) / f64::from(lanes);
                let inset = if b == 0 {
                    0.5
                } else if b == lanes {
                    -0.5
                } else {
                    0.0
                } * MARKING_WIDTH_M;
                let mut corner = |f: &RoadFrame, side: f64| {
                    let p = f.offset(lat(f) + inset + side * 0.5 * MARKING_WIDTH_M)
                        + f.up * MARKING_LIFT_M;
                    out.markings.vertex(p, f.up)
                };
                let (a, bb) = (corner(f0, -1.0), corner(f1, -1.0));
                let (c, d) = (corner(f1, 1.0), corner(f0, 1.0));
                out.markings.quad(a, bb, c, d);
            }
        }

        // Guardrails: a wall on each flagged edge, in continuous runs of flagged intervals.
        for side in [Side::Left, Side::Right] {
            let sign = if side == Side::Left { 1.0 } else { -1.0 };
            let mut run: Option<GuardrailRun> = None;
            let push = |run: &mut GuardrailRun, f: &RoadFrame| {
                run.foot
                    .push(f.offset(sign * (0.5 * f.width_m + GUARDRAIL_OFFSET_M)));
                run.up.push(f.up);
                run.left.push(f.left);
                run.to_s_m = f.s_m;
            };
            for pair in stations.windows(2) {
                let (gl, gr) = road.guardrails_at(0.5 * (pair[0].s_m + pair[1].s_m));
                let flagged = if side == Side::Left { gl } else { gr };
                if flagged {
                    let r = run.get_or_insert_with(|| {
                        let mut r = GuardrailRun {
                            side,
                            from_s_m: pair[0].s_m,
                            to_s_m: pair[0].s_m,
                            foot: vec![],
                            up: vec![],
                            left: vec![],
                        };
                        push(&mut r, &pair[0]);
                        r
                    });
                    push(r, &pair[1]);
                } else if let Some(r) = run.take() {
                    out.guardrail_runs.push(r);
                }
            }
            out.guardrail_runs.extend(run);
        }
        for r in &out.guardrail_runs {
            wall(&mut out.guardrails, r);
        }
        out
    }
}

/// The frame at station `s`, keeping `s` itself as its arc position: a closed loop's last station
/// (at the full length) evaluates at 0, but dash phasing and guardrail runs need it at the end.
fn station_frame(road: &RoadGeometry, s: f64) -> RoadFrame {
    let mut f = road.frame_at(s);
    f.s_m = s;
    f
}

/// Appends a two-sided wall along a guardrail run.
fn wall(mesh: &mut Mesh, run: &GuardrailRun) {
    let inward = if run.side == Side::Left { -1.0 } else { 1.0 };
    let n = run.foot.len() as u32;
    for face in [1.0, -1.0] {
        let base = mesh.positions.len() as u32;
        for k in 0..run.foot.len() {
            let normal = run.left[k] * inward * face;
            mesh.vertex(run.foot[k], normal);
            mesh.vertex(run.foot[k] + run.up[k] * GUARDRAIL_HEIGHT_M, normal);
        }
        // Each face is counter-clockwise seen from the side its normal points to.
        let faces_left = (run.side == Side::Left) == (face < 0.0);
        for k in 0..n.saturating_sub(1) {
            let (b0, t0, b1, t1) = (
                base + 2 * k,
                base + 2 * k + 1,
                base + 2 * k + 2,
                base + 2 * k + 3,
            );
            if faces_left {
                mesh.quad(b0, t0, t1, b1);
            } else {
                mesh.quad(b0, b1, t1, t0);
            }
        }
    }
}

//! A road's evaluated geometry: arc-length parameterisation, frames, lanes and projection.

use crate::RoadError;
use crate::grid::SegmentGrid;
use crate::spec::RoadSpec;
use crate::spline::{Cubic, centre_line};
use flockway_core::arrays::array2;
use glam::DVec3;
use multiversion::multiversion;
use wide::f64x2;

/// Longest stretch of centre line one arc-length table entry covers, in metres.
const TABLE_STEP_M: f64 = 2.0;
/// Most table entries one segment may have (a segment of over a kilometre is still fine).
const MAX_SUBDIVISIONS: usize = 1024;
/// Length of one bin of a road's curvature profile, m ([`RoadGeometry::curvature_bins`]).
pub const CURVATURE_BIN_M: f64 = 1.0;

/// The local frame of a road at one arc position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoadFrame {
    /// Arc position along the centre line, in metres.
    pub s_m: f64,
    /// Centre-line point, world space (metres).
    pub pos: DVec3,
    /// Unit direction of travel.
    pub tangent: DVec3,
    /// Unit vector across the surface towards the left edge (banked with the road).
    pub left: DVec3,
    /// Unit surface normal (banked with the road).
    pub up: DVec3,
    /// Bank angle in radians (positive raises the left edge).
    pub bank_rad: f64,
    /// Road width here, in metres.
    pub width_m: f64,
}

impl RoadFrame {
    /// The point `lateral_m` to the left of the centre line on the road surface (negative: right).
    pub fn offset(&self, lateral_m: f64) -> DVec3 {
        self.pos + self.left * lateral_m
    }
}

/// Where a world position lies relative to a road.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoadProjection {
    /// Arc position of the closest centre-line point, in metres.
    pub s_m: f64,
    /// Signed distance across the surface from the centre line, positive to the left, in metres.
    pub lateral_m: f64,
    /// Height above the (banked) surface plane, in metres.
    pub height_m: f64,
    /// Straight-line distance from the position to the closest centre-line point, in metres.
    pub distance_m: f64,
    /// The lane the lateral offset falls in, clamped to the road's lanes.
    pub lane: u32,
    /// Whether the lateral offset is within the road's edges.
    pub on_road: bool,
}

/// A remembered place on one road's spline: lets repeated projections of a moving point start
/// where the last one ended (see [`RoadGeometry::project_tracked`]). Only meaningful for the
/// road that made it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoadCursor {
    param: SplineParam,
    /// The arc position of `param`, so a tracked projection needs no arc-length evaluation to
    /// tell how far the answer moved.
    s_m: f64,
}

/// Where on the spline an arc position lies: segment index and local parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SplineParam {
    pub(crate) seg: usize,
    pub(crate) u: f64,
}

#[derive(Debug, Clone)]
struct SegmentData {
    cubic: Cubic,
    /// Arc position where this segment starts.
    s0: f64,
    /// Arc positions of the segment's table nodes at u = k / subdivisions, relative to `s0`.
    table: Vec<f64>,
    /// Parameter speed |dC/du| at each table node: with `table`, a cubic Hermite interpolant of
    /// s(u) and u(s) between nodes, so queries need no quadrature (no square roots).
    speeds: Vec<f64>,
    bank0_rad: f64,
    bank1_rad: f64,
    width0_m: f64,
    width1_m: f64,
}

impl SegmentData {
    fn subdivisions(&self) -> usize {
        self.table.len() - 1
    }

    fn len(&self) -> f64 {
        self.table[self.subdivisions()]
    }
}

/// A road ready for queries: centre line with an arc-length table, lanes, bank, width and a
/// spatial index for closest-point queries. Built once per edit from a [`RoadSpec`].
#[derive(Debug, Clone)]
pub struct RoadGeometry {
    spec: RoadSpec,
    segments: Vec<SegmentData>,
    length_m: f64,
    grid: SegmentGrid,
    /// A box the centre line stays within (min, max corners).
    bounds: (DVec3, DVec3),
    /// Per [`CURVATURE_BIN_M`] of centre line, the ground-plane curvature of largest magnitude
    /// in the bin, 1/m (signed, positive turning left).
    curvature: Vec<f32>,
}

impl RoadGeometry {
    /// Evaluates a road, after checking that its spec makes a drivable road.
    pub fn new(spec: &RoadSpec) -> Result<RoadGeometry, RoadError> {
        crate::validate::validate(spec)?;
        let n = spec.points.len();
        let cubics = centre_line(spec);
        let mut segments = Vec::with_capacity(cubics.len());
        let mut s0 = 0.0;
        for (i, cubic) in cubics.into_iter().enumerate() {
            let j = (i + 1) % n;
            let chord = (spec.points[j].pos - spec.points[i].pos).length();
            // Quadrature on ≤ 2 m pieces: the length error is far below a micrometre.
            let subdivisions =
                ((chord * 1.5 / TABLE_STEP_M).ceil() as usize).clamp(4, MAX_SUBDIVISIONS);
            let mut table = Vec::with_capacity(subdivisions + 1);
            let mut acc = 0.0;
            table.push(0.0);
            for k in 0..subdivisions {
                let (u0, u1) = (
                    k as f64 / subdivisions as f64,
                    (k + 1) as f64 / subdivisions as f64,
                );
                acc += cubic.length(u0, u1);
                table.push(acc);
            }
            let speeds = (0..=subdivisions)
                .map(|k| cubic.d1(k as f64 / subdivisions as f64).length())
                .collect();
            segments.push(SegmentData {
                cubic,
                s0,
                table,
                speeds,
                bank0_rad: spec.points[i].bank_deg.to_radians(),
                bank1_rad: spec.points[j].bank_deg.to_radians(),
                width0_m: spec.width_at_point(i),
                width1_m: spec.width_at_point(j),
            });
            s0 += acc;
        }
        let grid = SegmentGrid::build(
            &segments
                .iter()
                .map(|s| (&s.cubic, s.len()))
                .collect::<Vec<_>>(),
        );
        let bounds = segments.iter().map(|s| s.cubic.bounds()).fold(
            (DVec3::INFINITY, DVec3::NEG_INFINITY),
            |(lo, hi), (a, b)| (lo.min(a), hi.max(b)),
        );
        let mut road = RoadGeometry {
            spec: spec.clone(),
            segments,
            length_m: s0,
            grid,
            bounds,
            curvature: Vec::new(),
        };
        road.curvature = road.curvature_profile();
        Ok(road)
    }

    /// The curvature profile: each bin's sharpest of its start, middle and end (the curvature of
    /// a centripetal Catmull-Rom spline changes smoothly within a segment, so three samples per
    /// metre find its peaks to well within a percent).
    fn curvature_profile(&self) -> Vec<f32> {
        let bins = (self.length_m / CURVATURE_BIN_M).ceil().max(1.0) as usize;
        let at = |s: f64| self.curvature_at(s.min(self.length_m));
        let mut edge = at(0.0);
        (0..bins)
            .map(|i| {
                let s = i as f64 * CURVATURE_BIN_M;
                let mid = at(s + 0.5 * CURVATURE_BIN_M);
                let end = at(s + CURVATURE_BIN_M);
                let sharpest = [edge, mid, end]
                    .into_iter()
                    .fold(0.0f64, |a, k| if k.abs() > a.abs() { k } else { a });
                edge = end;
                sharpest as f32
            })
            .collect()
    }

    /// Curvature of the centre line seen from above at arc position `s_m`, 1/m: positive turning
    /// left, 0 on a straight. Elevation changes do not count (a crest is not a bend).
    pub fn curvature_at(&self, s_m: f64) -> f64 {
        let p = self.param_at(s_m);
        let c = &self.segments[p.seg].cubic;
        let (d1, d2) = (c.d1(p.u), c.d2(p.u));
        let speed2 = d1.x * d1.x + d1.y * d1.y;
        if speed2 < 1e-18 {
            return 0.0;
        }
        (d1.x * d2.y - d1.y * d2.x) / (speed2 * speed2.sqrt())
    }

    /// The road's curvature profile: bin `i` covers arc positions `i·CURVATURE_BIN_M` to
    /// `(i+1)·CURVATURE_BIN_M` and holds the centre line's sharpest curvature there, 1/m
    /// (signed, positive turning left). A lane `d` metres left of the centre line turns on a
    /// radius of `1/κ − d`.
    pub fn curvature_bins(&self) -> &[f32] {
        &self.curvature
    }

    /// The spec this geometry was built from.
    pub fn spec(&self) -> &RoadSpec {
        &self.spec
    }

    /// The road's name.
    pub fn name(&self) -> &str {
        &self.spec.name
    }

    /// Whether the road is a closed loop.
    pub fn is_closed(&self) -> bool {
        self.spec.closed
    }

    /// Number of lanes.
    pub fn lanes(&self) -> u32 {
        self.spec.lanes
    }

    /// Speed limit in km/h.
    pub fn speed_limit_kmh(&self) -> f64 {
        self.spec.speed_limit_kmh
    }

    /// Length of the centre line in metres.
    pub fn length_m(&self) -> f64 {
        self.length_m
    }

    /// Arc position of control point `i` (for a closed loop, point 0 is at 0 and also at the length).
    pub fn point_s(&self, i: usize) -> Option<f64> {
        if i < self.segments.len() {
            Some(self.segments[i].s0)
        } else if i == self.segments.len() && !self.spec.closed {
            Some(self.length_m)
        } else {
            None
        }
    }

    /// Brings an arc position into range: wrapped into [0, length) on a closed loop, clamped to
    /// [0, length] on an open road.
    #[inline]
    pub fn normalize_s(&self, s_m: f64) -> f64 {
        if self.spec.closed {
            let w = flockway_core::wrap::rem_euclid(s_m, self.length_m);
            // rem_euclid can round up to exactly the length.
            if w >= self.length_m { 0.0 } else { w }
        } else {
            s_m.clamp(0.0, self.length_m)
        }
    }

    /// Signed arc distance from `from_m` to `to_m` along the direction of travel; on a closed loop
    /// the shorter way round (in (−L/2, L/2]).
    #[inline]
    pub fn delta_s(&self, from_m: f64, to_m: f64) -> f64 {
        let d = to_m - from_m;
        if self.spec.closed {
            let l = self.length_m;
            let w = flockway_core::wrap::rem_euclid(d, l);
            if w > 0.5 * l { w - l } else { w }
        } else {
            d
        }
    }

    pub(crate) fn param_at(&self, s_m: f64) -> SplineParam {
        let s = self.normalize_s(s_m);
        let seg = self
            .segments
            .partition_point(|g| g.s0 <= s)
            .saturating_sub(1);
        let g = &self.segments[seg];
        let local = (s - g.s0).clamp(0.0, g.len());
        let n = g.subdivisions();
        let k = g
            .table
            .partition_point(|&t| t <= local)
            .saturating_sub(1)
            .min(n - 1);
        let (t0, t1) = (g.table[k], g.table[k + 1]);
        let du = 1.0 / n as f64;
        let u_k = k as f64 * du;
        let ds = t1 - t0;
        let (v0, v1) = (g.speeds[k], g.speeds[k + 1]);
        let u = if ds > 0.0 && v0 > 1e-12 && v1 > 1e-12 {
            // u(s) as a cubic Hermite between the nodes, with du/ds = 1/speed at each end.
            let t = (local - t0) / ds;
            u_k + du * hermite01(t, ds / (v0 * du), ds / (v1 * du))
        } else {
            u_k + du * if ds > 0.0 { (local - t0) / ds } else { 0.0 }
        };
        SplineParam {
            seg,
            u: u.clamp(u_k, u_k + du),
        }
    }

    #[cfg(test)]
    pub(crate) fn segment_cubic(&self, seg: usize) -> &Cubic {
        &self.segments[seg].cubic
    }

    // Inlined into both builds (x86-64 and AVX2) of the per-car functions that call it.
    #[inline(always)]
    pub(crate) fn s_of(&self, p: SplineParam) -> f64 {
        let g = &self.segments[p.seg];
        let n = g.subdivisions();
        // u is never negative, so truncation is floor (and needs no library call).
        let k = ((p.u * n as f64) as usize).min(n - 1);
        let du = 1.0 / n as f64;
        let t = (p.u - k as f64 * du) / du;
        let ds = g.table[k + 1] - g.table[k];
        if ds <= 0.0 {
            return g.s0 + g.table[k];
        }
        // s(u) as a cubic Hermite between the nodes, with ds/du = speed at each end.
        g.s0 + g.table[k] + ds * hermite01(t, g.speeds[k] * du / ds, g.speeds[k + 1] * du / ds)
    }

    // Inlined into both builds (x86-64 and AVX2) of the per-car functions that call it.
    #[inline(always)]
    fn frame_at_param(&self, p: SplineParam, s_m: f64) -> RoadFrame {
        let g = &self.segments[p.seg];
        let pos = g.cubic.pos(p.u);
        let tangent = g.cubic.d1(p.u).normalize_or(DVec3::X);
        let blend = smoothstep(p.u);
        let bank_rad = g.bank0_rad + (g.bank1_rad - g.bank0_rad) * blend;
        let width_m = g.width0_m + (g.width1_m - g.width0_m) * blend;
        let (left, up) = banked_axes(tangent, bank_rad);
        RoadFrame {
            s_m,
            pos,
            tangent,
            left,
            up,
            bank_rad,
            width_m,
        }
    }

    /// The road's frame at arc position `s_m` (wrapped or clamped into the road). O(log n).
    pub fn frame_at(&self, s_m: f64) -> RoadFrame {
        let s = self.normalize_s(s_m);
        self.frame_at_param(self.param_at(s), s)
    }

    /// Centre-line point at arc position `s_m`.
    pub fn pos_at(&self, s_m: f64) -> DVec3 {
        let p = self.param_at(s_m);
        self.segments[p.seg].cubic.pos(p.u)
    }

    /// Lateral offset of lane `lane`'s centre line from the road centre at `s_m`, positive left.
    pub fn lane_offset_m(&self, lane: u32, s_m: f64) -> f64 {
        let width = self.frame_at(s_m).width_m;
        lane_offset(width, self.spec.lanes, lane)
    }

    /// Point on lane `lane`'s centre line at arc position `s_m`.
    pub fn lane_point(&self, lane: u32, s_m: f64) -> DVec3 {
        let f = self.frame_at(s_m);
        f.offset(lane_offset(f.width_m, self.spec.lanes, lane))
    }

    /// The lane a lateral offset falls in (clamped to the road's lanes) at width `width_m`.
    pub fn lane_at_offset(&self, lateral_m: f64, width_m: f64) -> u32 {
        let lanes = self.spec.lanes;
        let lane_w = width_m / f64::from(lanes);
        let from_right = (lateral_m + 0.5 * width_m) / lane_w;
        (from_right.floor().max(0.0) as u32).min(lanes - 1)
    }

    /// The guardrails on the segment containing arc position `s_m`, as (left, right).
    pub fn guardrails_at(&self, s_m: f64) -> (bool, bool) {
        let seg = self.param_at(s_m).seg;
        let p = &self.spec.points[seg];
        (p.guardrail_left, p.guardrail_right)
    }

    /// A lower bound on [`project`](Self::project)'s `distance_m` for `pos` (its distance from a
    /// box the centre line stays within), for ruling a road out cheaply.
    pub fn distance_bound(&self, pos: DVec3) -> f64 {
        let (lo, hi) = self.bounds;
        let outside = (lo - pos).max(pos - hi).max(DVec3::ZERO);
        // Less a hair, so that rounding in the exact distance can never fall below it.
        (outside.length() - 1.0e-6).max(0.0)
    }

    /// The closest point of the road to a world position. Uses the spatial index, then refines on
    /// the exact spline: exact to well under a millimetre, O(1) for positions near the road.
    pub fn project(&self, pos: DVec3) -> RoadProjection {
        let start = self.grid.nearest(pos);
        self.refine(pos, start).0
    }

    /// A cursor at arc position `s_m`, for [`project_tracked`](Self::project_tracked).
    pub fn cursor_at(&self, s_m: f64) -> RoadCursor {
        let s_m = self.normalize_s(s_m);
        RoadCursor {
            param: self.param_at(s_m),
            s_m,
        }
    }

    /// The fastest projection, for something that moves a little each step (a wheel, a vehicle):
    /// starts from where the cursor was left and leaves it at the answer. Falls back to the
    /// spatial index when the position jumped more than 25 m along the road.
    pub fn project_tracked(&self, pos: DVec3, cursor: &mut RoadCursor) -> RoadProjection {
        self.project_tracked_frame(pos, cursor).0
    }

    /// [`project_tracked`](Self::project_tracked) that also returns the road's frame at the
    /// projected point (computed on the way, so it costs nothing extra).
    pub fn project_tracked_frame(
        &self,
        pos: DVec3,
        cursor: &mut RoadCursor,
    ) -> (RoadProjection, RoadFrame) {
        project_tracked_frame(self, pos, cursor)
    }

    /// The exact road cross-section about `ds_m` along the road from a cursor at arc position
    /// `cursor_s_m`, without an arc-length search: the parameter steps by `ds / |dP/du|` (twice,
    /// for accuracy), so the frame lies exactly on the surface, within millimetres of `ds_m` over
    /// a few metres. Its `s_m` is `cursor_s_m + ds_m`, wrapped. `None` past either end of an open
    /// road.
    // Inlined into both builds (x86-64 and AVX2) of the per-car functions that call it.
    #[inline(always)]
    pub fn frame_near(&self, cursor: &RoadCursor, cursor_s_m: f64, ds_m: f64) -> Option<RoadFrame> {
        let p = self.param_near(cursor, ds_m)?;
        Some(self.frame_at_param(p, self.normalize_s(cursor_s_m + ds_m)))
    }

    /// The road's unit tangent about `ds_m` along the road from a cursor, as
    /// [`frame_near`](Self::frame_near)'s frame has it (the same bits), without the rest of the
    /// frame. `None` past either end of an open road.
    // Inlined into both builds (x86-64 and AVX2) of the per-car functions that call it.
    #[inline(always)]
    pub fn tangent_near(&self, cursor: &RoadCursor, ds_m: f64) -> Option<DVec3> {
        let p = self.param_near(cursor, ds_m)?;
        Some(self.segments[p.seg].cubic.d1(p.u).normalize_or(DVec3::X))
    }

    /// [`frame_near`](Self::frame_near) at two distances from the same cursor (a car's two
    /// axles), the two frames' arithmetic two wide: the same frames to the bit.
    // Inlined into both builds (x86-64 and AVX2) of the per-car functions that call it.
    #[inline(always)]
    pub fn frames_near(
        &self,
        cursor: &RoadCursor,
        cursor_s_m: f64,
        ds_m: [f64; 2],
    ) -> [Option<RoadFrame>; 2] {
        // Two calls written out, not a closure over the two: a closure is built for the
        // baseline target, and this large one stayed a call from the AVX2 build.
        let params = [
            self.param_near(cursor, ds_m[0]),
            self.param_near(cursor, ds_m[1]),
        ];
        let s = array2(|i| self.normalize_s(cursor_s_m + ds_m[i]));
        match params {
            [Some(p0), Some(p1)] => {
                let [f0, f1] = self.frames_at_params([p0, p1], s);
                [Some(f0), Some(f1)]
            }
            _ => array2(|i| params[i].map(|p| self.frame_at_param(p, s[i]))),
        }
    }

    /// Two [`frame_at_param`](Self::frame_at_param)s at once, in its order of operations.
    // Inlined into both builds (x86-64 and AVX2) of the per-car functions that call it.
    #[inline(always)]
    fn frames_at_params(&self, p: [SplineParam; 2], s_m: [f64; 2]) -> [RoadFrame; 2] {
        let g = array2(|i| &self.segments[p[i].seg]);
        let k = array2(|i| g[i].cubic.coefficients());
        let coef = |j: usize| V2::from([k[0][j], k[1][j]]);
        let (a, b, c, d) = (coef(0), coef(1), coef(2), coef(3));
        let u = f64x2::new([p[0].u, p[1].u]);
        let pos = a + (b + (c + d * u) * u) * u;
        let two_c = c * f64x2::splat(2.0);
        let three_u = f64x2::splat(3.0) * u;
        let tangent = (b + (two_c + d * three_u) * u).normalize_or(DVec3::X);
        let blend = u * u * (f64x2::splat(3.0) - f64x2::splat(2.0) * u);
        let lerp = |a: [f64; 2], b: [f64; 2]| {
            let (a, b) = (f64x2::new(a), f64x2::new(b));
            (a + (b - a) * blend).to_array()
        };
        let bank = lerp(array2(|i| g[i].bank0_rad), array2(|i| g[i].bank1_rad));
        let width = lerp(array2(|i| g[i].width0_m), array2(|i| g[i].width1_m));
        // `banked_axes`: world up crossed with the tangent, as glam computes `Z.cross(t)`.
        let zero = f64x2::ZERO;
        let one = f64x2::splat(1.0);
        let left0 = V2 {
            x: zero * tangent.z - tangent.y * one,
            y: one * tangent.x - tangent.z * zero,
            z: zero * tangent.y - tangent.x * zero,
        }
        .normalize_or(DVec3::Y);
        let up0 = tangent.cross(left0);
        // Each frame by a function inlined into the caller's build (a closure would be built for
        // the baseline target and, this large, stay a call from the AVX2 build).
        #[inline(always)]
        fn frame(
            i: usize,
            s_m: f64,
            pos: &V2,
            tangent: &V2,
            axes: (&V2, &V2),
            bank: f64,
            width: f64,
        ) -> RoadFrame {
            let (left0, up0) = axes;
            let (left, up) = if bank == 0.0 {
                (left0.lane(i), up0.lane(i))
            } else {
                let (sin, cos) = libm::sincos(bank);
                let (l, u) = (left0.lane(i), up0.lane(i));
                (l * cos + u * sin, u * cos - l * sin)
            };
            RoadFrame {
                s_m,
                pos: pos.lane(i),
                tangent: tangent.lane(i),
                left,
                up,
                bank_rad: bank,
                width_m: width,
            }
        }
        let axes = (&left0, &up0);
        [
            frame(0, s_m[0], &pos, &tangent, axes, bank[0], width[0]),
            frame(1, s_m[1], &pos, &tangent, axes, bank[1], width[1]),
        ]
    }

    /// Where `ds_m` along the road from the cursor falls on the spline ([`frame_near`]'s
    /// stepping); `None` past either end of an open road.
    ///
    /// [`frame_near`]: Self::frame_near
    // Inlined into both builds (x86-64 and AVX2) of the per-car functions that call it.
    #[inline(always)]
    fn param_near(&self, cursor: &RoadCursor, ds_m: f64) -> Option<SplineParam> {
        let nseg = self.segments.len();
        let mut p = cursor.param;
        if p.seg >= nseg {
            return None;
        }
        let mut left = ds_m;
        for _ in 0..4 {
            let c = &self.segments[p.seg].cubic;
            let speed = c.d1(p.u).length().max(1e-9);
            let mut u = p.u + left / speed;
            let mut seg = p.seg;
            if u > 1.0 {
                left -= (1.0 - p.u) * speed;
                if seg + 1 < nseg {
                    seg += 1;
                } else if self.spec.closed {
                    seg = 0;
                } else {
                    return None;
                }
                p = SplineParam { seg, u: 0.0 };
                continue;
            }
            if u < 0.0 {
                left += p.u * speed;
                if seg > 0 {
                    seg -= 1;
                } else if self.spec.closed {
                    seg = nseg - 1;
                } else {
                    return None;
                }
                p = SplineParam { seg, u: 1.0 };
                continue;
            }
            // A second step with the speed at the midpoint brings the arc error to second order.
            let mid = c.d1(0.5 * (p.u + u)).length().max(1e-9);
            u = (p.u + left / mid).clamp(0.0, 1.0);
            return Some(SplineParam { seg, u });
        }
        None
    }

    /// Like [`project`](Self::project), starting from a known nearby arc position (a vehicle's
    /// last one): skips the index, and falls back to it if the hint is more than 25 m off.
    pub fn project_near(&self, pos: DVec3, s_hint_m: f64) -> RoadProjection {
        let (proj, _, _) = self.refine(pos, self.param_at(s_hint_m));
        if self.delta_s(s_hint_m, proj.s_m).abs() > 25.0 {
            self.project(pos)
        } else {
            proj
        }
    }

    /// Newton's method on the squared distance in the spline parameter, moving across segments.
    // Inlined into both builds (x86-64 and AVX2) of the per-car functions that call it.
    #[inline(always)]
    fn refine(&self, q: DVec3, start: SplineParam) -> (RoadProjection, SplineParam, RoadFrame) {
        let nseg = self.segments.len();
        let mut p = start;
        for _ in 0..16 {
            let c = &self.segments[p.seg].cubic;
            let (pos, d1, d2) = (c.pos(p.u), c.d1(p.u), c.d2(p.u));
            let r = pos - q;
            let grad = r.dot(d1);
            let hess = d1.length_squared() + r.dot(d2);
            // Where the distance function is not convex (beyond the centre of curvature) Newton
            // would climb; fall back to a gradient step scaled by the parameter speed.
            let step = if hess > 1e-9 * d1.length_squared() {
                grad / hess
            } else {
                grad / d1.length_squared().max(1e-12)
            };
            let mut u = p.u - step.clamp(-0.5, 0.5);
            let mut seg = p.seg;
            if u < 0.0 {
                if seg > 0 || self.spec.closed {
                    seg = (seg + nseg - 1) % nseg;
                    u = (1.0 + u).max(0.0);
                } else {
                    u = 0.0;
                }
            } else if u > 1.0 {
                if seg + 1 < nseg || self.spec.closed {
                    seg = (seg + 1) % nseg;
                    u = (u - 1.0).min(1.0);
                } else {
                    u = 1.0;
                }
            }
            let moved_m = if seg == p.seg {
                (u - p.u).abs() * d1.length()
            } else {
                f64::INFINITY
            };
            let stuck = seg == p.seg && u == p.u;
            p = SplineParam { seg, u };
            // Newton converges quadratically: after a step of 0.1 mm what is left is far below a
            // micrometre, so a further iteration only confirms it.
            if moved_m < 1e-4 || stuck {
                break;
            }
        }
        let s = self.normalize_s(self.s_of(p));
        let f = self.frame_at_param(p, s);
        let r = q - f.pos;
        let lateral_m = r.dot(f.left);
        let proj = RoadProjection {
            s_m: s,
            lateral_m,
            height_m: r.dot(f.up),
            distance_m: r.length(),
            lane: self.lane_at_offset(lateral_m, f.width_m),
            on_road: lateral_m.abs() <= 0.5 * f.width_m,
        };
        (proj, p, f)
    }

    /// Arc positions at which to place mesh stations: at most `step_m` apart, including every
    /// control point and both ends.
    pub fn stations(&self, step_m: f64) -> Vec<f64> {
        let mut out = Vec::new();
        for g in &self.segments {
            let n = (g.len() / step_m).ceil().max(1.0) as usize;
            for k in 0..n {
                out.push(g.s0 + g.len() * k as f64 / n as f64);
            }
        }
        out.push(self.length_m);
        out
    }
}

/// [`RoadGeometry::project_tracked_frame`], built twice, for x86-64 and for AVX2 (taken at run
/// time where the CPU has it; the same answers to the bit: see `multiversion` in Cargo.toml).
#[multiversion(targets("x86_64+avx2"))]
fn project_tracked_frame(
    road: &RoadGeometry,
    pos: DVec3,
    cursor: &mut RoadCursor,
) -> (RoadProjection, RoadFrame) {
    let (start, before) = if cursor.param.seg < road.segments.len() {
        (cursor.param, cursor.s_m)
    } else {
        (road.param_at(0.0), 0.0)
    };
    let (proj, p, frame) = road.refine(pos, start);
    let (proj, p, frame) = if road.delta_s(before, proj.s_m).abs() > 25.0 {
        road.refine(pos, road.grid.nearest(pos))
    } else {
        (proj, p, frame)
    };
    *cursor = RoadCursor {
        param: p,
        s_m: proj.s_m,
    };
    (proj, frame)
}

/// Lateral offset of a lane centre from the road centre (positive left); lane 0 is rightmost.
pub fn lane_offset(width_m: f64, lanes: u32, lane: u32) -> f64 {
    let lane_w = width_m / f64::from(lanes.max(1));
    -0.5 * width_m + (f64::from(lane) + 0.5) * lane_w
}

/// Two vectors stored by axis, for two road frames computed at once; every operation in glam's
/// `DVec3` order of operations, so each lane has the scalar code's bits.
#[derive(Clone, Copy)]
struct V2 {
    x: f64x2,
    y: f64x2,
    z: f64x2,
}

impl V2 {
    fn from(v: [DVec3; 2]) -> V2 {
        V2 {
            x: f64x2::new([v[0].x, v[1].x]),
            y: f64x2::new([v[0].y, v[1].y]),
            z: f64x2::new([v[0].z, v[1].z]),
        }
    }

    fn lane(&self, i: usize) -> DVec3 {
        DVec3::new(
            self.x.as_array()[i],
            self.y.as_array()[i],
            self.z.as_array()[i],
        )
    }

    fn dot(self, o: V2) -> f64x2 {
        (self.x * o.x) + (self.y * o.y) + (self.z * o.z)
    }

    fn cross(self, o: V2) -> V2 {
        V2 {
            x: self.y * o.z - o.y * self.z,
            y: self.z * o.x - o.z * self.x,
            z: self.x * o.y - o.x * self.y,
        }
    }

    /// glam's `normalize_or`: each lane scaled by the reciprocal of its length where that is
    /// finite and positive, else `fallback`.
    fn normalize_or(self, fallback: DVec3) -> V2 {
        let rcp = f64x2::splat(1.0) / self.dot(self).sqrt();
        let keep = rcp.is_finite() & rcp.simd_gt(f64x2::ZERO);
        V2 {
            x: keep.select(self.x * rcp, f64x2::splat(fallback.x)),
            y: keep.select(self.y * rcp, f64x2::splat(fallback.y)),
            z: keep.select(self.z * rcp, f64x2::splat(fallback.z)),
        }
    }
}

impl std::ops::Add for V2 {
    type Output = V2;
    fn add(self, o: V2) -> V2 {
        V2 {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }
}

/// Each lane scaled by its own factor.
impl std::ops::Mul<f64x2> for V2 {
    type Output = V2;
    fn mul(self, s: f64x2) -> V2 {
        V2 {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
}

/// The cubic through (0, 0) and (1, 1) with slopes `m0` and `m1` there, at `t`.
#[inline]
fn hermite01(t: f64, m0: f64, m1: f64) -> f64 {
    let (t2, t3) = (t * t, t * t * t);
    (t3 - 2.0 * t2 + t) * m0 + (-2.0 * t3 + 3.0 * t2) + (t3 - t2) * m1
}

fn smoothstep(u: f64) -> f64 {
    u * u * (3.0 - 2.0 * u)
}

/// The left and up axes of a surface banked by `bank_rad` about `tangent` (world up is +z).
// Inlined into both builds (x86-64 and AVX2) of the per-car functions that call it.
#[inline(always)]
fn banked_axes(tangent: DVec3, bank_rad: f64) -> (DVec3, DVec3) {
    let left0 = DVec3::Z.cross(tangent).normalize_or(DVec3::Y);
    let up0 = tangent.cross(left0);
    if bank_rad == 0.0 {
        // Most roads are flat: skip the trigonometry.
        return (left0, up0);
    }
    // libm, not the platform's maths library: identical bits on every machine.
    let (sin, cos) = libm::sincos(bank_rad);
    (left0 * cos + up0 * sin, up0 * cos - left0 * sin)
}

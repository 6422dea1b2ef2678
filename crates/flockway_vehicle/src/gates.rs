//! Gating vehicle colliders in and out of rapier's collision detection (see [`ContactGate`]):
//! each car decides from its track whether guardrails can be near, a grid search over every
//! car's box finds the cars another can reach, and [`gate_colliders`] applies both.

use crate::components::{
    CONTACT_GATE_HYSTERESIS_M, CONTACT_GATE_MARGIN_M, Chassis, ContactGate, Motion,
    RAIL_GATE_END_M, RAIL_GATE_HYSTERESIS_M, RAIL_GATE_MARGIN_M, RoadTrack,
};
use crate::free_body::FreeBody;
use crate::lanes::{Quatx4, Vec3x4};
use crate::physics::{GROUND_GROUP, GUARDRAIL_GROUP, Physics, VEHICLE_GROUP};
use bevy_ecs::prelude::*;
use flockway_core::arrays::array4;
use flockway_core::{
    Beside, DT_S, JOIN_MIN_CARS, beside, map_in_order, parallel_min, task_threads,
};
use flockway_road::RoadNetwork;
use glam::{Mat3, Quat, Vec2, Vec3};
use multiversion::multiversion;
use rapier3d::prelude::*;
use wide::f32x4;

impl ContactGate {
    /// Whether, from the car's track and motion, guardrails must be in its filter for the next
    /// step.
    pub(crate) fn rails_wanted(
        &self,
        physics: &Physics,
        network: &RoadNetwork,
        track: &RoadTrack,
        motion: &Motion,
    ) -> bool {
        let upright = (motion.rotation * Vec3::Z).z > 0.8;
        if !track.on_road || !upright {
            return true;
        }
        let (half_length, half_width) = (self.half_extents.x, self.half_extents.y);
        let cos = track.heading_cos.abs().min(1.0);
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let turning = motion.angvel.z.abs() * half_length;
        // Near an open road's end the gate stays open, unless the end is bare and the box,
        // with what it can move in two steps and a margin, lies over the road short of it:
        // there the road's edges bound it as anywhere between the ends.
        let near_end = network.get(track.road).is_none_or(|g| {
            let (s, length) = (track.s_m, g.length_m());
            let (at_start, at_end) = (s < RAIL_GATE_END_M, s > length - RAIL_GATE_END_M);
            if g.is_closed() || !(at_start || at_end) {
                return false;
            }
            let along = f64::from(
                half_length * cos
                    + half_width * sin
                    + 2.0 * DT_S as f32 * (motion.linvel.length() + turning)
                    + RAIL_GATE_MARGIN_M,
            );
            let bare = physics.bare_ends(track.road);
            (at_start && !(bare[0] && s >= along)) || (at_end && !(bare[1] && s <= length - along))
        });
        if near_end {
            return true;
        }
        // The box's reach across the road: its half width and half length turned by the
        // heading, plus up to 0.1 m more at its corners on a curve of 26 m radius or wider.
        let reach = half_length * sin + half_width * cos + 0.1;
        let edge = 0.5 * track.width_m + flockway_road::GUARDRAIL_OFFSET_M as f32;
        let clearance = edge - (track.lateral_m.abs() as f32 + reach);
        // How far the box's side can move in two steps: sliding across, and turning.
        let across = motion.linvel.dot(track.left).abs();
        let moves = 2.0 * DT_S as f32 * (across + turning);
        let needed = moves + RAIL_GATE_MARGIN_M;
        if self.rails_open {
            clearance < needed + RAIL_GATE_HYSTERESIS_M
        } else {
            clearance < needed
        }
    }
}

/// One car's collider box as the close-car search sees it: its footprint (the rectangle along
/// its flattened heading that holds the box's projection on the ground) and its vertical span.
#[derive(Debug, Clone, Copy)]
struct BoxNow {
    centre: Vec2,
    z: f32,
    /// Half the box's vertical extent, m.
    half_z: f32,
    /// The flattened heading, unit length.
    axis: Vec2,
    /// The footprint's half extents along `axis` and across it, m.
    half: Vec2,
    /// `half.length()`: the radius of the circle around the footprint, m (kept, for it is read
    /// at every pair tested).
    radius_m: f32,
    /// How far any point of the box can move in two steps, m.
    reach_m: f32,
    /// Whether it had a car within reach at the last search (which widens its threshold).
    was_near: bool,
}

impl BoxNow {
    // Inlined into `boxes_of`'s two builds.
    #[inline(always)]
    fn of(gate: &ContactGate, motion: &Motion) -> BoxNow {
        let m = Mat3::from_quat(motion.rotation);
        let h = gate.half_extents;
        let half_axes = [m.x_axis * h.x, m.y_axis * h.y, m.z_axis * h.z];
        let axis = m.x_axis.truncate().normalize_or(Vec2::X);
        let across = axis.perp();
        let along = |dir: Vec2| {
            half_axes
                .iter()
                .map(|a| a.truncate().dot(dir).abs())
                .sum::<f32>()
        };
        let centre = motion.position + m.z_axis * gate.offset_z_m;
        let half = Vec2::new(along(axis), along(across));
        BoxNow {
            centre: centre.truncate(),
            z: centre.z,
            half_z: half_axes.iter().map(|a| a.z.abs()).sum(),
            axis,
            half,
            radius_m: half.length(),
            reach_m: 2.0
                * DT_S as f32
                * (motion.linvel.length() + motion.angvel.length() * h.length()),
            was_near: gate.near,
        }
    }
}

/// Four cars' boxes at once: each lane in [`BoxNow::of`]'s scalar order of operations (glam's
/// `Mat3::from_quat`, `Vec2::normalize_or`, dot products and lengths as glam orders them, no
/// fused multiply–add), so each box has the bits of that car's `BoxNow::of`.
#[inline(always)]
fn boxes_of_four(cars: [(&ContactGate, &Motion); 4]) -> [BoxNow; 4] {
    let (zero, one) = (f32x4::ZERO, f32x4::ONE);
    let q = Quatx4::from_fn(|i| cars[i].1.rotation);
    let h = Vec3x4::from_fn(|i| cars[i].0.half_extents);
    let (x2, y2, z2) = (q.x + q.x, q.y + q.y, q.z + q.z);
    let (xx, xy, xz) = (q.x * x2, q.x * y2, q.x * z2);
    let (yy, yz, zz) = (q.y * y2, q.y * z2, q.z * z2);
    let (wx, wy, wz) = (q.w * x2, q.w * y2, q.w * z2);
    let x_axis = Vec3x4 {
        x: one - (yy + zz),
        y: xy + wz,
        z: xz - wy,
    };
    let y_axis = Vec3x4 {
        x: xy - wz,
        y: one - (xx + zz),
        z: yz + wx,
    };
    let z_axis = Vec3x4 {
        x: xz + wy,
        y: yz - wx,
        z: one - (xx + yy),
    };
    let half_axes = [x_axis * h.x, y_axis * h.y, z_axis * h.z];
    let rcp = one / (x_axis.x * x_axis.x + x_axis.y * x_axis.y).sqrt();
    let normal = rcp.is_finite() & rcp.simd_gt(zero);
    let axis = (
        normal.select(x_axis.x * rcp, one),
        normal.select(x_axis.y * rcp, zero),
    );
    let across = (-axis.1, axis.0);
    let along = |(dx, dy): (f32x4, f32x4)| {
        let [a, b, c] = half_axes.map(|v| (v.x * dx + v.y * dy).abs());
        a + b + c
    };
    let (half_along, half_across) = (along(axis), along(across));
    let radius = (half_along * half_along + half_across * half_across).sqrt();
    let [a, b, c] = half_axes.map(|v| v.z.abs());
    let half_z = a + b + c;
    let offset = f32x4::new(array4(|i| cars[i].0.offset_z_m));
    let centre = Vec3x4::from_fn(|i| cars[i].1.position) + z_axis * offset;
    let length = |v: Vec3x4| v.dot(v).sqrt();
    let linvel = Vec3x4::from_fn(|i| cars[i].1.linvel);
    let angvel = Vec3x4::from_fn(|i| cars[i].1.angvel);
    let reach = f32x4::splat(2.0 * DT_S as f32) * (length(linvel) + length(angvel) * length(h));
    let lane = |v: f32x4, i: usize| v.as_array()[i];
    array4(|i| BoxNow {
        centre: Vec2::new(lane(centre.x, i), lane(centre.y, i)),
        z: lane(centre.z, i),
        half_z: lane(half_z, i),
        axis: Vec2::new(lane(axis.0, i), lane(axis.1, i)),
        half: Vec2::new(lane(half_along, i), lane(half_across, i)),
        radius_m: lane(radius, i),
        reach_m: lane(reach, i),
        was_near: cars[i].0.near,
    })
}

/// A lower bound of the distance between two boxes: the largest gap between their footprints'
/// projections on each footprint's axes, or between their vertical spans (projecting never
/// lengthens a distance, and each footprint holds its box's projection).
fn gap_lower_bound(a: &BoxNow, b: &BoxNow) -> f32 {
    let d = b.centre - a.centre;
    let (ua, va, ub, vb) = (a.axis, a.axis.perp(), b.axis, b.axis.perp());
    let (uu, uv, vu, vv) = (
        ua.dot(ub).abs(),
        ua.dot(vb).abs(),
        va.dot(ub).abs(),
        va.dot(vb).abs(),
    );
    let vertical = (b.z - a.z).abs() - a.half_z - b.half_z;
    let on_ua = d.dot(ua).abs() - a.half.x - (b.half.x * uu + b.half.y * uv);
    let on_va = d.dot(va).abs() - a.half.y - (b.half.x * vu + b.half.y * vv);
    let on_ub = d.dot(ub).abs() - b.half.x - (a.half.x * uu + a.half.y * vu);
    let on_vb = d.dot(vb).abs() - b.half.y - (a.half.x * uv + a.half.y * vv);
    vertical.max(on_ua).max(on_va).max(on_ub).max(on_vb)
}

/// Whether two boxes are close enough that their colliders must be in rapier.
#[inline]
fn within_reach(a: &BoxNow, b: &BoxNow) -> bool {
    let hysteresis = if a.was_near || b.was_near {
        CONTACT_GATE_HYSTERESIS_M
    } else {
        0.0
    };
    let threshold = a.reach_m + b.reach_m + CONTACT_GATE_MARGIN_M + hysteresis;
    // Most pairs fail on the circles around the footprints already.
    let circles = a.radius_m + b.radius_m + threshold;
    (b.centre - a.centre).length_squared() < circles * circles && gap_lower_bound(a, b) < threshold
}

/// From this many cars the close-car search compares its cells over the task pool: a car's
/// share is a few box tests, so below a few thousand cars handing the parts out costs about
/// what it saves.
const CLOSE_CARS_PARALLEL_MIN: usize = 2048;

/// The close-car search's buffers, kept from step to step.
#[derive(Default)]
pub struct CloseCars {
    /// The car of each box.
    cars: Vec<Entity>,
    boxes: Vec<BoxNow>,
    /// `(grid cell, index into boxes)`, sorted.
    cells: Vec<(u64, u32)>,
    /// Each run of `cells` in one grid cell: its start and end.
    runs: Vec<(u32, u32)>,
    near: Vec<bool>,
    /// What a search over the grid on one thread found.
    found: Found,
    /// The pairs the last search over the grid found that can come within reach before the
    /// cars have moved far.
    kept: KeptPairs,
}

/// How much closer than their reach two cars' boxes may be before the close-car search keeps
/// them as a pair to test each step, m: until the cars have moved by about this much relative
/// to one another, the kept pairs hold every pair within reach, and the search tests them alone.
const CLOSE_CARS_SKIN_M: f32 = 2.0;

/// What the kept pairs' bound leaves for the rounding of the centres and extents it compares, m:
/// many times the largest rounding of a centre within [`KEPT_PAIRS_EXTENT_M`].
const KEPT_PAIRS_ROUNDING_M: f32 = 0.05;

/// How far from the origin every centre must be for the kept pairs to be tested alone, m (past
/// it, a centre's rounding nears the allowance for it).
const KEPT_PAIRS_EXTENT_M: f32 = 65_536.0;

/// A grid search's finds.
#[derive(Default)]
struct Found {
    /// Both boxes of each pair within reach.
    near: Vec<u32>,
    /// Each pair within reach and [`CLOSE_CARS_SKIN_M`]: the pairs to keep.
    kept: Vec<(u32, u32)>,
}

/// The pairs of boxes that the last search over the grid found within reach and
/// [`CLOSE_CARS_SKIN_M`] of each other, with what each box was then. No other pair can come
/// within reach while no two cars have moved closer by more than the skin: a pair's centres
/// close by at most how far apart the two cars' moves since are, and its reach grows by at most
/// the two boxes' growth in radius and reach. While that holds, testing the kept pairs finds
/// exactly what a search over the grid would: a Verlet list, as molecular dynamics keeps one.
#[derive(Default)]
struct KeptPairs {
    /// The car of each box at the search (the same cars in the same order, or none is kept).
    cars: Vec<Entity>,
    /// Each box's centre at the search.
    centres: Vec<Vec2>,
    /// Each box's radius and reach at the search, m.
    extents: Vec<f32>,
    /// The pairs, as indices into the boxes.
    pairs: Vec<(u32, u32)>,
}

impl KeptPairs {
    /// Keeps `pairs` for `boxes` of `cars`.
    fn keep(&mut self, cars: &[Entity], boxes: &[BoxNow], pairs: &[(u32, u32)]) {
        self.cars.clear();
        self.centres.clear();
        self.extents.clear();
        self.pairs.clear();
        if cars.len() != boxes.len() {
            return;
        }
        self.cars.extend_from_slice(cars);
        self.centres.extend(boxes.iter().map(|b| b.centre));
        self.extents
            .extend(boxes.iter().map(|b| b.radius_m + b.reach_m));
        self.pairs.extend_from_slice(pairs);
    }

    /// Whether the kept pairs still hold every pair of `boxes` (of `cars`) within reach: the
    /// same cars, each centre finite and within [`KEPT_PAIRS_EXTENT_M`], and the spread of
    /// their moves since (the diagonal of the box around them, which bounds how much closer any
    /// two have come) plus twice the largest growth of a box's radius and reach short of the
    /// skin.
    fn hold_for(&self, cars: &[Entity], boxes: &[BoxNow]) -> bool {
        if cars.is_empty() || cars.len() != boxes.len() || self.cars != cars {
            return false;
        }
        let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        let mut growth = 0.0_f32;
        let mut inside = true;
        for ((b, &was), &extent) in boxes.iter().zip(&self.centres).zip(&self.extents) {
            let moved = b.centre - was;
            let grown = b.radius_m + b.reach_m - extent;
            lo = lo.min(moved);
            hi = hi.max(moved);
            growth = growth.max(grown);
            // Each comparison false for a NaN too (which `min` and `max` pass over).
            inside &= b.centre.x.abs() < KEPT_PAIRS_EXTENT_M
                && b.centre.y.abs() < KEPT_PAIRS_EXTENT_M
                && moved.x.abs() < KEPT_PAIRS_EXTENT_M
                && moved.y.abs() < KEPT_PAIRS_EXTENT_M
                && grown < KEPT_PAIRS_EXTENT_M;
        }
        inside && (hi - lo).length() + 2.0 * growth < CLOSE_CARS_SKIN_M - KEPT_PAIRS_ROUNDING_M
    }
}

/// A grid cell's key: ordered by column, then row, so a column's neighbouring rows are adjacent
/// keys.
fn cell_key(x: i32, y: i32) -> u64 {
    (u64::from(x as u32 ^ 1 << 31) << 32) | u64::from(y as u32 ^ 1 << 31)
}

/// The column and row of a [`cell_key`].
fn cell_of_key(k: u64) -> (i32, i32) {
    (
        ((k >> 32) as u32 ^ 1 << 31) as i32,
        (k as u32 ^ 1 << 31) as i32,
    )
}

impl CloseCars {
    /// Marks in `near` every box with another box within reach. While the [`KeptPairs`] of the
    /// last search over the grid hold, only they are tested. Otherwise each box goes into the
    /// grid cell of its centre, cells as wide as the farthest two boxes can interact and the
    /// skin, so only neighbouring cells are compared: O(n log n), never every pair. The cells'
    /// comparisons are split over the task pool from [`CLOSE_CARS_PARALLEL_MIN`] boxes; what
    /// each part finds is only ever added to `near`, so the answer does not depend on the split.
    fn search(&mut self) {
        let n = self.boxes.len();
        self.near.clear();
        self.near.resize(n, false);
        if n < 2 {
            return;
        }
        if self.kept.hold_for(&self.cars, &self.boxes) {
            for &(i, j) in &self.kept.pairs {
                if within_reach(&self.boxes[i as usize], &self.boxes[j as usize]) {
                    self.near[i as usize] = true;
                    self.near[j as usize] = true;
                }
            }
            return;
        }
        let widest = self
            .boxes
            .iter()
            .map(|b| b.radius_m + b.reach_m)
            .fold(0.0_f32, f32::max);
        // Wide enough for every pair within reach and the skin to be in neighbouring cells.
        let side =
            2.0 * widest + CONTACT_GATE_MARGIN_M + CONTACT_GATE_HYSTERESIS_M + CLOSE_CARS_SKIN_M;
        // Rounded down by a plain conversion, not the C library's `floorf`, so the cells never
        // depend on the maths library. The conversion saturates far out (a box flung some
        // 10¹⁰ m), and so does the step down: the farthest boxes share the last cell.
        let per_side = 1.0 / side;
        let cell = |v: f32| {
            let q = v * per_side;
            let i = q as i32;
            i.saturating_sub(i32::from(q < i as f32))
        };
        let key_of = |b: &BoxNow| cell_key(cell(b.centre.x), cell(b.centre.y));
        if self.cells.len() == n {
            // The same number of cars as last step: their last order, keys renewed, is nearly
            // sorted still (a car changes cell every few dozen steps). Every `(cell, index)` is
            // distinct, so the sorted order is one whatever order the sort starts from.
            for c in &mut self.cells {
                c.0 = key_of(&self.boxes[c.1 as usize]);
            }
            sort_nearly_sorted(&mut self.cells);
        } else {
            self.cells.clear();
            self.cells.extend(
                self.boxes
                    .iter()
                    .enumerate()
                    .map(|(i, b)| (key_of(b), i as u32)),
            );
            self.cells.sort_unstable();
        }
        self.runs.clear();
        let mut start = 0;
        while start < self.cells.len() {
            let k = self.cells[start].0;
            let len = self.cells[start..].iter().take_while(|c| c.0 == k).count();
            self.runs.push((start as u32, (start + len) as u32));
            start += len;
        }
        let (cells, boxes) = (&self.cells, &self.boxes);
        if n < parallel_min(CLOSE_CARS_PARALLEL_MIN) {
            // On one thread: one pass over all the runs, into buffers kept from search to
            // search (parts would each make their own).
            let mut found = std::mem::take(&mut self.found);
            found.near.clear();
            found.kept.clear();
            pairs_among(cells, boxes, &self.runs, &mut found);
            for &i in &found.near {
                self.near[i as usize] = true;
            }
            self.kept.keep(&self.cars, boxes, &found.kept);
            self.found = found;
            return;
        }
        // About eight parts per thread; each part's finds.
        let threads = task_threads();
        let per_part = self.runs.len().div_ceil(8 * threads).max(1);
        let parts: Vec<&[(u32, u32)]> = self.runs.chunks(per_part).collect();
        let finds = map_in_order(
            &parts,
            2,
            || (),
            |(), runs| {
                let mut found = Found::default();
                pairs_among(cells, boxes, runs, &mut found);
                found
            },
        );
        let mut kept = Vec::new();
        for found in finds {
            for &i in &found.near {
                self.near[i as usize] = true;
            }
            kept.extend_from_slice(&found.kept);
        }
        self.kept.keep(&self.cars, boxes, &kept);
    }
}

/// The boxes within reach of one another from `runs` (consecutive runs of `cells`, in key
/// order) and the cells neighbouring them: [`pairs_from`] for each run, one walk over the next
/// column for them all. Built twice as [`boxes_of`] is.
#[multiversion(targets("x86_64+avx2"))]
fn pairs_among(cells: &[(u64, u32)], boxes: &[BoxNow], runs: &[(u32, u32)], found: &mut Found) {
    let mut next_column = NextColumn::default();
    for &run in runs {
        pairs_from(cells, boxes, run, &mut next_column, found);
    }
}

/// Sorts `v` by insertion, which takes one pass over a nearly sorted slice; past a few moves per
/// element on average it sorts the rest of the way with the general sort.
fn sort_nearly_sorted<T: Ord + Copy>(v: &mut [T]) {
    let mut budget = 8 * v.len();
    for i in 1..v.len() {
        let x = v[i];
        let mut j = i;
        while j > 0 && v[j - 1] > x {
            v[j] = v[j - 1];
            j -= 1;
        }
        v[j] = x;
        budget = budget.saturating_sub(i - j);
        if budget == 0 {
            v.sort_unstable();
            return;
        }
    }
}

/// Where the last run's neighbours in the next column began: the lowest key looked for and the
/// first cell at or past it. Runs come in key order, so each run's lowest key is past the last
/// one's and the search for it walks on from there: one pass over the cells for all runs, where
/// bisecting for each probed log₂ n cells a run.
#[derive(Default)]
struct NextColumn {
    lowest: u64,
    from: usize,
}

impl NextColumn {
    /// The first of `cells` at or after `end` whose key is `lowest` or more.
    fn find(&mut self, cells: &[(u64, u32)], end: usize, lowest: u64) -> usize {
        let from = if lowest >= self.lowest {
            let start = self.from.max(end);
            start + cells[start..].iter().take_while(|c| c.0 < lowest).count()
        } else {
            // Keys out of order only where a column's number wraps (a box some 10¹⁰ m out).
            end + cells[end..].partition_point(|c| c.0 < lowest)
        };
        (self.lowest, self.from) = (lowest, from);
        from
    }
}

/// The boxes within reach of one another among one run of `cells` (one grid cell) and the
/// cells after it that neighbour it: the one above it, and the three of the next column
/// (adjacent keys, found through `next_column`, the same for the whole pass over the runs).
/// Each pair of neighbouring cells is compared once over all runs. Pushes both boxes of each
/// pair within reach, and each pair within reach and the skin.
#[inline(always)]
fn pairs_from(
    cells: &[(u64, u32)],
    boxes: &[BoxNow],
    run: (u32, u32),
    next_column: &mut NextColumn,
    found: &mut Found,
) {
    let (start, end) = (run.0 as usize, run.1 as usize);
    let here = &cells[start..end];
    let k = here[0].0;
    // Inlined at each of its three uses (as a closure it stayed a call per pair).
    #[inline(always)]
    fn pair(boxes: &[BoxNow], found: &mut Found, i: u32, j: u32) {
        let (a, b) = (&boxes[i as usize], &boxes[j as usize]);
        if within_reach(a, b) {
            found.near.push(i);
            found.near.push(j);
            found.kept.push((i, j));
        } else {
            // Within reach at the widest (with the hysteresis) and the skin.
            let kept = a.radius_m
                + a.reach_m
                + (b.radius_m + b.reach_m)
                + (CONTACT_GATE_MARGIN_M + CONTACT_GATE_HYSTERESIS_M + CLOSE_CARS_SKIN_M);
            if (b.centre - a.centre).length_squared() < kept * kept {
                found.kept.push((i, j));
            }
        }
    }
    for (m, &(_, i)) in here.iter().enumerate() {
        for &(_, j) in &here[m + 1..] {
            pair(boxes, found, i, j);
        }
    }
    let (x, y) = cell_of_key(k);
    let above = cell_key(x, y.wrapping_add(1));
    for &(_, j) in cells[end..].iter().take_while(|c| c.0 == above) {
        for &(_, i) in here {
            pair(boxes, found, i, j);
        }
    }
    let x1 = x.wrapping_add(1);
    let (lo, hi) = (
        cell_key(x1, y.wrapping_sub(1)),
        cell_key(x1, y.wrapping_add(1)),
    );
    let from = next_column.find(cells, end, lo);
    for &(_, j) in cells[from..].iter().take_while(|c| c.0 <= hi) {
        for &(_, i) in here {
            pair(boxes, found, i, j);
        }
    }
}

/// The close-car search over the boxes of one step's read-back, when it goes on beside the
/// step: its answers go into the cars' gates before the next physics step
/// ([`gate_colliders`]).
#[derive(Debug, Default)]
pub(crate) enum CloseCarSearch {
    /// No search yet.
    #[default]
    Idle,
    /// The buffers, kept between searches.
    Kept(Box<CloseCars>),
    /// Searching beside the step; the gates take its answers.
    Searching(Beside<Box<CloseCars>>),
}

impl std::fmt::Debug for CloseCars {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CloseCars")
            .field("cars", &self.cars.len())
            .finish_non_exhaustive()
    }
}

impl CloseCarSearch {
    /// The answers of the search beside the step, if one is on its way: it is done by now.
    fn take_answers(&mut self) -> Option<Box<CloseCars>> {
        match std::mem::take(self) {
            CloseCarSearch::Searching(search) => Some(search.join()),
            kept => {
                *self = kept;
                None
            }
        }
    }

    /// The buffers for a new search (the answers of one never taken dropped).
    fn buffers(&mut self) -> Box<CloseCars> {
        match std::mem::take(self) {
            CloseCarSearch::Idle => Box::default(),
            CloseCarSearch::Kept(cars) => cars,
            CloseCarSearch::Searching(search) => search.join(),
        }
    }
}

/// Finds for every car whether another car's body is within reach of its own (so both
/// colliders must be in rapier for the next step). The boxes are made here, from the cars'
/// motion just read back. With two threads, from [`JOIN_MIN_CARS`] cars to 2 048 (from which
/// the search splits its cells over the task pool), the search goes on beside the serial work
/// that follows, on the other thread (idle there), and [`gate_colliders`] writes its answers
/// before the next physics step; otherwise they are written here. The search reads only its
/// boxes, so its answers are the same on whichever thread.
pub fn find_close_cars(
    mut physics: ResMut<Physics>,
    mut gates: Query<(Entity, &mut ContactGate, &Motion)>,
) {
    if !physics.gates {
        return;
    }
    let mut search = physics.close_cars.buffers();
    boxes_of(&mut search.boxes, &mut search.cars, &gates);
    let n = search.boxes.len();
    // From as many cars as a pass splits from: below, handing the search over costs about
    // what it saves.
    let beside_from = parallel_min(JOIN_MIN_CARS.min(CLOSE_CARS_PARALLEL_MIN));
    if task_threads() >= 2 && (beside_from..parallel_min(CLOSE_CARS_PARALLEL_MIN)).contains(&n) {
        physics.close_cars = CloseCarSearch::Searching(beside(move || {
            search.search();
            search
        }));
        return;
    }
    // On this thread (its cells' comparisons over the task pool from the threshold).
    search.search();
    for ((_, mut gate, _), &near) in gates.iter_mut().zip(&search.near) {
        if gate.near != near {
            gate.near = near;
        }
    }
    physics.close_cars = CloseCarSearch::Kept(search);
}

/// Every car's box now, in the query's order, in place of `boxes`, and the cars in place of
/// `cars`. Built twice, for x86-64 and for AVX2 (taken at run time where the CPU has it; the
/// same boxes to the bit: see `multiversion` in Cargo.toml).
#[multiversion(targets("x86_64+avx2"))]
fn boxes_of(
    boxes: &mut Vec<BoxNow>,
    cars: &mut Vec<Entity>,
    gates: &Query<(Entity, &mut ContactGate, &Motion)>,
) {
    boxes.clear();
    cars.clear();
    // Four cars at a time, the last few one by one. The query's fold walks its tables directly,
    // and the step inlined into it makes each car's item in registers: fewer instructions a car
    // than the iterator's `next`.
    let spare = (
        ContactGate::new(ColliderHandle::invalid(), Vec3::ZERO, 0.0),
        Motion {
            position: Vec3::ZERO,
            rotation: Quat::IDENTITY,
            linvel: Vec3::ZERO,
            angvel: Vec3::ZERO,
            forward_mps: 0.0,
            accel_mps2: 0.0,
        },
    );
    let mut held = [(&spare.0, &spare.1); 4];
    let last = gates.iter().fold(
        0,
        #[inline(always)]
        |k: usize, (car, gate, motion)| {
            cars.push(car);
            held[k & 3] = (gate, motion);
            if k == 3 {
                boxes.extend_from_slice(&boxes_of_four(held));
                0
            } else {
                k + 1
            }
        },
    );
    for (gate, motion) in &held[..last] {
        boxes.push(BoxNow::of(gate, motion));
    }
}

/// Puts each vehicle's collider into rapier or takes it out, and guardrails into or out of its
/// filter, as its [`ContactGate`] decided; and notes each car's road where roads cross without
/// meeting. A body whose collider is out leaves rapier too, its state kept and integrated in
/// its [`FreeBody`] until the collider comes back.
pub fn gate_colliders(
    mut physics: ResMut<Physics>,
    mut gates: Query<(
        Entity,
        &mut ContactGate,
        &RoadTrack,
        &Chassis,
        &mut FreeBody,
    )>,
) {
    let physics = &mut *physics;
    let gating = physics.gates;
    let crossings = physics.has_crossings();
    let answers = physics.close_cars.take_answers();
    let mut near_of = answers.as_deref().map(NearOf::new);
    let mut in_rapier = std::mem::take(&mut physics.in_rapier.0);
    in_rapier.clear();
    physics.in_rapier.1 = gates.iter().len();
    // The query's fold walks its tables directly, and the step inlined into it makes each car's
    // item in registers: fewer instructions a car than the iterator's `next`.
    gates.iter_mut().fold(
        (),
        #[inline(always)]
        |(), (car, mut gate, track, chassis, mut free)| {
            if let Some(near) = near_of.as_mut().and_then(|n| n.get(car))
                && gate.near != near
            {
                gate.near = near;
            }
            if crossings {
                physics.note_vehicle_road(gate.collider, track.road);
            }
            let rails = gate.want_rails || !gating;
            let enabled = rails || gate.near;
            if enabled {
                in_rapier.push(car);
            }
            if rails == gate.rails_open && enabled == gate.enabled {
                return;
            }
            if let Some(collider) = physics.world.colliders.get_mut(gate.collider) {
                if rails != gate.rails_open {
                    let filter = if rails {
                        VEHICLE_GROUP | GUARDRAIL_GROUP | GROUND_GROUP
                    } else {
                        VEHICLE_GROUP | GROUND_GROUP
                    };
                    collider.set_collision_groups(InteractionGroups::new(
                        VEHICLE_GROUP,
                        filter,
                        InteractionTestMode::And,
                    ));
                }
                if enabled != gate.enabled {
                    collider.set_enabled(enabled);
                    if let Some(body) = physics.world.bodies.get_mut(chassis.body) {
                        if enabled {
                            free.enter(body);
                        } else {
                            free.leave(body);
                        }
                    }
                }
            }
            gate.rails_open = rails;
            gate.enabled = enabled;
        },
    );
    physics.in_rapier.0 = in_rapier;
    if let Some(cars) = answers {
        physics.close_cars = CloseCarSearch::Kept(cars);
    }
}

/// Each searched car's answer, found by walking the search's cars in step with the gates' query
/// (the same order while no car came or went since), and by bisection past the first car out of
/// step.
struct NearOf<'a> {
    search: &'a CloseCars,
    next: usize,
    /// The answers by car, sorted, made at the first car out of step.
    sorted: Option<Vec<(Entity, bool)>>,
}

impl<'a> NearOf<'a> {
    fn new(search: &'a CloseCars) -> Self {
        NearOf {
            search,
            next: 0,
            sorted: None,
        }
    }

    /// Whether the search found another car within reach of `car`; `None` for a car it did
    /// not search (spawned since).
    fn get(&mut self, car: Entity) -> Option<bool> {
        let search = self.search;
        if search.cars.get(self.next) == Some(&car) {
            self.next += 1;
            return search.near.get(self.next - 1).copied();
        }
        let sorted = self.sorted.get_or_insert_with(|| {
            let mut by_car: Vec<(Entity, bool)> = search
                .cars
                .iter()
                .copied()
                .zip(search.near.iter().copied())
                .collect();
            by_car.sort_unstable_by_key(|&(car, _)| car);
            by_car
        });
        let k = sorted.binary_search_by_key(&car, |&(c, _)| c).ok()?;
        Some(sorted[k].1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;

    const HALF: Vec3 = Vec3::new(2.3, 0.9, 0.6);

    fn motion(x: f32, y: f32, heading: f32, speed: f32) -> Motion {
        // Pitched and rolled a little, as on a banked curve under braking.
        let rotation = Quat::from_rotation_z(heading)
            * Quat::from_rotation_y(0.05)
            * Quat::from_rotation_x(0.08);
        Motion {
            position: Vec3::new(x, y, 0.5),
            rotation,
            linvel: rotation * Vec3::X * speed,
            angvel: Vec3::ZERO,
            forward_mps: speed,
            accel_mps2: 0.0,
        }
    }

    fn boxed(x: f32, y: f32, heading: f32, speed: f32) -> BoxNow {
        let gate = ContactGate::new(ColliderHandle::invalid(), HALF, 0.2);
        let mut b = BoxNow::of(&gate, &motion(x, y, heading, speed));
        b.was_near = false;
        b
    }

    /// Each lane of four boxes at once has the bits of that car's scalar box (a NaN to a NaN),
    /// over random poses and motions with ±0, tiny, huge and non-finite components, and
    /// cars pointing straight up (no flattened heading).
    #[test]
    fn four_boxes_at_once_have_the_scalar_boxes_bits() {
        let mut uniform = crate::lanes::uniform(0x9e37_79b9);
        let special = [
            0.0,
            -0.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1.0e-30,
            1.0e30,
        ];
        // About one component in thirty awkward, the rest spread over ±scale.
        let mut pick = |scale: f32| {
            if uniform(0.0, 1.0) < 1.0 / 30.0 {
                special[(uniform(0.0, special.len() as f32) as usize).min(special.len() - 1)]
            } else {
                uniform(-scale, scale)
            }
        };
        let bits = |b: &BoxNow| {
            let f = [
                b.centre.x, b.centre.y, b.z, b.half_z, b.axis.x, b.axis.y, b.half.x, b.half.y,
                b.radius_m, b.reach_m,
            ];
            (
                f.map(|x| if x.is_nan() { u32::MAX } else { x.to_bits() }),
                b.was_near,
            )
        };
        for case in 0..4000 {
            let cars: [(ContactGate, Motion); 4] = array4(|i| {
                let mut gate = ContactGate::new(
                    ColliderHandle::invalid(),
                    Vec3::new(pick(3.0), pick(1.0), pick(1.0)),
                    pick(0.5),
                );
                gate.near = (case + i) % 3 == 0;
                let rotation = if (case + i) % 17 == 0 {
                    // Nose straight up, exactly (every component a half): the forward axis has
                    // no horizontal part, and the flattened heading falls back to +x.
                    Quat::from_xyzw(0.5, 0.5, 0.5, -0.5)
                } else {
                    Quat::from_xyzw(pick(1.0), pick(1.0), pick(1.0), pick(1.0)).normalize()
                };
                let motion = Motion {
                    position: Vec3::new(pick(1000.0), pick(1000.0), pick(10.0)),
                    rotation,
                    linvel: Vec3::new(pick(40.0), pick(40.0), pick(5.0)),
                    angvel: Vec3::new(pick(2.0), pick(2.0), pick(2.0)),
                    forward_mps: 0.0,
                    accel_mps2: 0.0,
                };
                (gate, motion)
            });
            let four = boxes_of_four(array4(|i| (&cars[i].0, &cars[i].1)));
            for (i, (gate, motion)) in cars.iter().enumerate() {
                assert_eq!(
                    bits(&four[i]),
                    bits(&BoxNow::of(gate, motion)),
                    "case {case}, lane {i}"
                );
                if (case + i) % 17 == 0 {
                    assert_eq!(four[i].axis, Vec2::X, "case {case}, lane {i}: nose up");
                }
            }
        }
    }

    /// The eight corners of the collider box.
    fn corners(m: &Motion) -> Vec<Vec3> {
        let centre = m.position + m.rotation * Vec3::new(0.0, 0.0, 0.2);
        let mut out = Vec::new();
        for sx in [-1.0, 1.0] {
            for sy in [-1.0, 1.0] {
                for sz in [-1.0, 1.0] {
                    out.push(centre + m.rotation * (HALF * Vec3::new(sx, sy, sz)));
                }
            }
        }
        out
    }

    #[test]
    fn the_gap_bound_is_nearly_exact_for_cars_side_by_side_and_nose_to_tail() {
        // Level cars would give 1.7 m and 5.4 m exactly; the pitch and roll widen each
        // footprint by a few centimetres.
        let a = boxed(0.0, 0.0, 0.0, 0.0);
        let side = gap_lower_bound(&a, &boxed(0.0, 3.5, 0.0, 0.0));
        assert!((1.6..1.7).contains(&side), "{side}");
        let tail = gap_lower_bound(&a, &boxed(10.0, 0.0, 0.0, 0.0));
        assert!((5.3..5.4).contains(&tail), "{tail}");
        // Overlapping boxes have a negative gap.
        assert!(gap_lower_bound(&a, &boxed(3.0, 0.5, 0.3, 0.0)) < 0.0);
    }

    #[test]
    fn the_gap_bound_never_exceeds_the_distance_between_the_boxes() {
        // Two boxes turned against each other at many headings and places: the bound stays
        // below the distance between their nearest corners, and below zero where a corner
        // of one is inside the other's footprint.
        for step in 0..72 {
            let heading = step as f32 * 5.0_f32.to_radians();
            for (x, y) in [(5.0, 3.0), (4.0, 0.0), (0.0, 2.6), (-3.5, -3.5)] {
                let (ma, mb) = (motion(0.0, 0.0, 0.0, 0.0), motion(x, y, heading, 0.0));
                let (a, b) = (boxed(0.0, 0.0, 0.0, 0.0), boxed(x, y, heading, 0.0));
                let nearest = corners(&ma)
                    .iter()
                    .flat_map(|p| corners(&mb).into_iter().map(move |q| p.distance(q)))
                    .fold(f32::INFINITY, f32::min);
                assert!(
                    gap_lower_bound(&a, &b) <= nearest + 1e-5,
                    "heading {heading} at {x},{y}"
                );
            }
        }
    }

    #[test]
    fn boxes_on_roads_that_cross_at_different_heights_are_not_close() {
        let a = boxed(0.0, 0.0, 0.0, 20.0);
        let mut b = boxed(0.0, 0.0, 1.57, 20.0);
        b.z += 6.0;
        assert!(!within_reach(&a, &b));
        b.z -= 5.0;
        assert!(within_reach(&a, &b));
    }

    /// Whether each box has another within reach, by testing every pair.
    fn every_pair(boxes: &[BoxNow]) -> Vec<bool> {
        let mut near = vec![false; boxes.len()];
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                if within_reach(&boxes[i], &boxes[j]) {
                    near[i] = true;
                    near[j] = true;
                }
            }
        }
        near
    }

    fn near_of(boxes: Vec<BoxNow>) -> Vec<bool> {
        let mut search = CloseCars {
            boxes,
            ..CloseCars::default()
        };
        search.search();
        search.near
    }

    #[test]
    fn the_grid_finds_the_same_close_cars_as_every_pair() {
        // Two threads, so the 2 500 cars' cells are compared in parts over the pool.
        flockway_core::init_task_pool(Some(2));
        // Cars scattered over many cells, some on cell borders, some in negative coordinates.
        let mut boxes = Vec::new();
        let mut seed = 7_u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1 << 24) as f32
        };
        for _ in 0..2_500 {
            boxes.push(boxed(
                next() * 500.0 - 250.0,
                next() * 150.0 - 75.0,
                next() * 6.3,
                next() * 40.0,
            ));
        }
        assert!(boxes.len() >= CLOSE_CARS_PARALLEL_MIN, "searched in parts");
        let brute = every_pair(&boxes);
        assert!(
            brute.iter().filter(|&&n| n).count() > 20,
            "the scene has close cars"
        );
        assert!(brute.iter().filter(|&&n| !n).count() > 20, "and lone ones");
        assert_eq!(near_of(boxes.clone()), brute);
        // Below the parallel threshold, on this thread: the pairs among the first 100.
        let few: Vec<BoxNow> = boxes[..100].to_vec();
        let brute = every_pair(&few);
        assert!(brute.contains(&true));
        assert_eq!(near_of(few), brute);
        // A second search over the same number of cars, moved: it starts from the first's
        // order of cells.
        let mut search = CloseCars {
            boxes: boxes.clone(),
            ..CloseCars::default()
        };
        search.search();
        for b in &mut search.boxes {
            b.centre += Vec2::new(next() * 12.0 - 6.0, next() * 12.0 - 6.0);
        }
        let moved = search.boxes.clone();
        search.search();
        assert_eq!(search.near, every_pair(&moved));
        // Boxes flung out past the grid's last column (its number saturates, the next column's
        // wraps to the first) among boxes in the first one and near the origin.
        let mut far = boxes[..40].to_vec();
        for (k, x) in [
            1.0e12,
            1.0e12 + 3.0,
            -1.0e12,
            -1.0e12 - 3.0,
            2.0e10,
            2.0e10 + 1.0,
        ]
        .into_iter()
        .enumerate()
        {
            far.push(boxed(x, k as f32, 0.0, 10.0));
        }
        let brute = every_pair(&far);
        assert!(
            brute[40..].iter().all(|&n| n),
            "the far boxes come in close pairs"
        );
        assert_eq!(near_of(far), brute);
    }

    #[test]
    fn the_gates_find_each_searched_car_s_answer_after_cars_came_and_went() {
        let car = |k: u32| Entity::from_raw_u32(k).expect("an entity");
        let search = CloseCars {
            cars: vec![car(1), car(2), car(3), car(4)],
            near: vec![true, false, true, false],
            ..CloseCars::default()
        };
        // In step while no car came or went.
        let mut near_of = NearOf::new(&search);
        let found: Vec<_> = [1, 2, 3, 4].map(|k| near_of.get(car(k))).into();
        assert_eq!(found, [Some(true), Some(false), Some(true), Some(false)]);
        // Car 2 gone (the last took its place in the table) and car 9 come since.
        let mut near_of = NearOf::new(&search);
        let found: Vec<_> = [1, 4, 3, 9].map(|k| near_of.get(car(k))).into();
        assert_eq!(found, [Some(true), Some(false), Some(true), None]);
    }

    #[test]
    fn a_nearly_sorted_sort_sorts_anything() {
        let mut seed = 11_u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            seed >> 8
        };
        // Sorted with a few moved, reversed (past the budget), random, empty, one.
        let mut cases: Vec<Vec<(u64, u32)>> = Vec::new();
        let mut nearly: Vec<(u64, u32)> = (0..2000).map(|i| (u64::from(i / 3), i)).collect();
        for _ in 0..40 {
            let (a, b) = (next() as usize % 2000, next() as usize % 2000);
            nearly[a].0 = nearly[b].0 + 1;
        }
        cases.push(nearly);
        cases.push((0..2000).rev().map(|i| (u64::from(i), i)).collect());
        cases.push((0..2000).map(|i| (u64::from(next() % 50), i)).collect());
        cases.push(Vec::new());
        cases.push(vec![(3, 1)]);
        for case in cases {
            let mut want = case.clone();
            want.sort_unstable();
            let mut got = case;
            sort_nearly_sorted(&mut got);
            assert_eq!(got, want);
        }
    }

    #[test]
    fn reach_grows_with_speed() {
        // Nose to tail 1 m apart: close when the rear one is fast enough to cover it in two
        // steps, not when both stand.
        let front = boxed(5.6, 0.0, 0.0, 0.0);
        assert_eq!(
            near_of(vec![boxed(0.0, 0.0, 0.0, 0.0), front]),
            [false, false]
        );
        assert_eq!(
            near_of(vec![boxed(0.0, 0.0, 0.0, 60.0), front]),
            [true, true]
        );
        assert_eq!(near_of(vec![boxed(0.0, 0.0, 0.0, 0.0)]), [false]);
    }

    /// A four-lane road's traffic, both ways, changing lanes and speed, searched step after
    /// step as the gates search it: each step's answer is every pair's, whether the kept pairs
    /// alone were tested or the grid searched.
    #[test]
    fn the_kept_pairs_find_the_same_close_cars_as_every_pair_while_cars_move() {
        let mut seed = 23_u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1 << 24) as f32
        };
        // (x, y, heading, speed, lateral speed) of each car.
        let mut cars: Vec<[f32; 5]> = (0..160)
            .map(|k| {
                let lane = (k % 4) as f32;
                let backwards = k % 4 >= 2;
                let heading = if backwards { std::f32::consts::PI } else { 0.0 };
                let x = (k / 4) as f32 * 12.0 + next() * 4.0;
                [x, lane * 3.6, heading, 5.0 + next() * 30.0, 0.0]
            })
            .collect();
        let entities: Vec<Entity> = (0..cars.len() as u32)
            .map(|k| Entity::from_raw_u32(k + 1).expect("an entity"))
            .collect();
        let mut search = CloseCars::default();
        let (mut kept, mut grid, mut close, mut lone) = (0, 0, 0, 0);
        let mut near = vec![false; cars.len()];
        for step in 0..720 {
            for c in &mut cars {
                let dir = if c[2] == 0.0 { 1.0 } else { -1.0 };
                c[0] += dir * c[3] * DT_S as f32;
                c[1] += c[4] * DT_S as f32;
                // Speeds and lane changes drift; now and then a car brakes hard.
                c[3] = (c[3] + (next() - 0.5) * 0.4).clamp(0.0, 40.0);
                if next() < 0.002 {
                    c[3] *= 0.5;
                }
                c[4] = if next() < 0.01 {
                    (next() - 0.5) * 4.0
                } else {
                    c[4]
                };
            }
            let boxes: Vec<BoxNow> = cars
                .iter()
                .zip(&near)
                .map(|(c, &was_near)| BoxNow {
                    was_near,
                    ..boxed(c[0], c[1], c[2], c[3])
                })
                .collect();
            search.boxes = boxes.clone();
            search.cars = entities.clone();
            if search.kept.hold_for(&search.cars, &search.boxes) {
                kept += 1;
            } else {
                grid += 1;
            }
            search.search();
            assert_eq!(search.near, every_pair(&boxes), "step {step}");
            near.clone_from(&search.near);
            close += near.iter().filter(|&&n| n).count();
            lone += near.iter().filter(|&&n| !n).count();
        }
        assert!(kept > 360 && grid > 20, "kept {kept}, grid {grid}");
        assert!(close > 7_200 && lone > 7_200, "close {close}, lone {lone}");
    }

    #[test]
    fn kept_pairs_hold_only_for_the_same_cars_while_they_have_not_moved_far() {
        let car = |k: u32| Entity::from_raw_u32(k).expect("an entity");
        let boxes = vec![boxed(0.0, 0.0, 0.0, 10.0), boxed(30.0, 0.0, 0.0, 10.0)];
        let cars = vec![car(1), car(2)];
        let mut kept = KeptPairs::default();
        kept.keep(&cars, &boxes, &[]);
        assert!(kept.hold_for(&cars, &boxes));
        // Both moved alike, however far: no closer to each other.
        let alike: Vec<BoxNow> = boxes
            .iter()
            .map(|b| BoxNow {
                centre: b.centre + Vec2::new(500.0, 3.0),
                ..*b
            })
            .collect();
        assert!(kept.hold_for(&cars, &alike));
        // One moved towards the other by the skin.
        let mut closer = boxes.clone();
        closer[0].centre.x += CLOSE_CARS_SKIN_M;
        assert!(!kept.hold_for(&cars, &closer));
        // Grown by half the skin: its reach.
        let mut grown = boxes.clone();
        grown[1].reach_m += 0.5 * CLOSE_CARS_SKIN_M;
        assert!(!kept.hold_for(&cars, &grown));
        // Other cars, or the same in another order, or one fewer.
        assert!(!kept.hold_for(&[car(1), car(3)], &boxes));
        assert!(!kept.hold_for(&[car(2), car(1)], &boxes));
        assert!(!kept.hold_for(&[car(1)], &boxes[..1]));
        // A box lost (NaN) or flung far out.
        for bad in [f32::NAN, 1.0e6] {
            let mut lost = boxes.clone();
            lost[1].centre.y = bad;
            assert!(!kept.hold_for(&cars, &lost));
        }
        let mut lost = boxes.clone();
        lost[0].radius_m = f32::NAN;
        assert!(!kept.hold_for(&cars, &lost));
        // Nothing kept for boxes without their cars.
        kept.keep(&[], &boxes, &[]);
        assert!(!kept.hold_for(&[], &boxes));
    }

    /// Two boxes kept as a pair only for the hysteresis' width (a third car near each, say,
    /// could widen their reach by it) are tested once they come within that reach.
    #[test]
    fn a_pair_within_the_skin_of_the_widest_reach_is_kept() {
        let car = |k: u32| Entity::from_raw_u32(k).expect("an entity");
        let half = Vec2::new(2.3, 0.9);
        let lone = |centre: Vec2| BoxNow {
            centre,
            z: 0.5,
            half_z: 0.6,
            axis: Vec2::X,
            half,
            radius_m: half.length(),
            reach_m: 0.1,
            was_near: false,
        };
        // Corner to corner along the first box's diagonal, where the footprints' circles bound
        // the gap closely; just within the skin of the reach the hysteresis widens.
        let widest = 2.0 * (half.length() + 0.1) + CONTACT_GATE_MARGIN_M;
        let widest = widest + CONTACT_GATE_HYSTERESIS_M;
        let dir = half.normalize();
        let mut search = CloseCars {
            cars: vec![car(1), car(2)],
            boxes: vec![
                lone(Vec2::ZERO),
                lone(dir * (widest + CLOSE_CARS_SKIN_M - 0.3)),
            ],
            ..CloseCars::default()
        };
        search.search();
        assert_eq!(search.near, [false, false]);
        // Closer by less than the skin, both with the hysteresis: within reach.
        search.boxes[1].centre = dir * (widest - 0.1);
        for b in &mut search.boxes {
            b.was_near = true;
        }
        assert!(search.kept.hold_for(&search.cars, &search.boxes));
        let boxes = search.boxes.clone();
        search.search();
        assert_eq!(search.near, [true, true]);
        assert_eq!(search.near, every_pair(&boxes));
    }
}

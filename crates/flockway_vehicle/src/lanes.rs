//! The four wheels' vectors held one array per axis, so that a force stage does each operation
//! on all four wheels at once: the compiler turns the four-wide loops into SIMD instructions.
//!
//! Every operation keeps glam's scalar order of operations (a dot product is
//! `(x·x + y·y) + z·z`, a rotation glam's `Quat * Vec3`, no fused multiply–add), and IEEE
//! addition, multiplication, division and square root round each lane as they round a scalar,
//! so the results are bit for bit those of the per-wheel `Vec3` code.

use glam::{Quat, Vec3};
use std::ops::{Add, Mul, Sub};

/// One `f32` per wheel.
pub(crate) type F4 = [f32; 4];

/// `f` of each lane.
#[inline(always)]
pub(crate) fn map(a: F4, f: impl Fn(f32) -> f32) -> F4 {
    [f(a[0]), f(a[1]), f(a[2]), f(a[3])]
}

/// `f` of each pair of lanes.
#[inline(always)]
pub(crate) fn zip(a: F4, b: F4, f: impl Fn(f32, f32) -> f32) -> F4 {
    [f(a[0], b[0]), f(a[1], b[1]), f(a[2], b[2]), f(a[3], b[3])]
}

/// Four vectors, one per wheel, stored by axis.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Vec3x4 {
    /// The four x components.
    pub x: F4,
    /// The four y components.
    pub y: F4,
    /// The four z components.
    pub z: F4,
}

impl Vec3x4 {
    /// Four zero vectors.
    pub const ZERO: Vec3x4 = Vec3x4 {
        x: [0.0; 4],
        y: [0.0; 4],
        z: [0.0; 4],
    };

    /// The same vector in every lane.
    #[inline(always)]
    pub fn splat(v: Vec3) -> Vec3x4 {
        Vec3x4 {
            x: [v.x; 4],
            y: [v.y; 4],
            z: [v.z; 4],
        }
    }

    /// Lane `i` from `f(i)`.
    #[inline(always)]
    pub fn from_fn(mut f: impl FnMut(usize) -> Vec3) -> Vec3x4 {
        let mut out = Vec3x4::ZERO;
        for i in 0..4 {
            out.set(i, f(i));
        }
        out
    }

    /// Lane `i` as a vector.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Vec3 {
        Vec3::new(self.x[i], self.y[i], self.z[i])
    }

    /// Sets lane `i`.
    #[inline(always)]
    pub fn set(&mut self, i: usize, v: Vec3) {
        self.x[i] = v.x;
        self.y[i] = v.y;
        self.z[i] = v.z;
    }

    /// Each lane's dot product with the same lane of `rhs`, as glam orders it.
    #[inline(always)]
    pub fn dot(self, rhs: Vec3x4) -> F4 {
        std::array::from_fn(|i| {
            (self.x[i] * rhs.x[i]) + (self.y[i] * rhs.y[i]) + (self.z[i] * rhs.z[i])
        })
    }

    /// Each lane's cross product with the same lane of `rhs`, as glam orders it.
    #[inline(always)]
    pub fn cross(self, rhs: Vec3x4) -> Vec3x4 {
        Vec3x4 {
            x: std::array::from_fn(|i| self.y[i] * rhs.z[i] - rhs.y[i] * self.z[i]),
            y: std::array::from_fn(|i| self.z[i] * rhs.x[i] - rhs.z[i] * self.x[i]),
            z: std::array::from_fn(|i| self.x[i] * rhs.y[i] - rhs.x[i] * self.y[i]),
        }
    }

    /// Each lane normalised, or zero where that is not finite (glam's `normalize_or_zero`).
    #[inline(always)]
    pub fn normalize_or_zero(self) -> Vec3x4 {
        let len = map(self.dot(self), f32::sqrt);
        let rcp = map(len, |l| 1.0 / l);
        let keep = map(rcp, |r| if r.is_finite() && r > 0.0 { r } else { 0.0 });
        let out = self * rcp;
        // A kept lane is the product; a dropped one is +0.0 in every component, as glam's
        // `Vec3::ZERO` (the product by zero could be −0.0 or NaN).
        Vec3x4 {
            x: zip(out.x, keep, |v, k| if k != 0.0 { v } else { 0.0 }),
            y: zip(out.y, keep, |v, k| if k != 0.0 { v } else { 0.0 }),
            z: zip(out.z, keep, |v, k| if k != 0.0 { v } else { 0.0 }),
        }
    }

    /// Each lane rotated by `q`, as glam's scalar `Quat * Vec3` computes it.
    #[inline(always)]
    pub fn rotated_by(self, q: Quat) -> Vec3x4 {
        let w = q.w;
        let b = Vec3::new(q.x, q.y, q.z);
        let b2 = b.dot(b);
        let bs = Vec3x4::splat(b);
        let along = map(self.dot(bs), |d| d * 2.0);
        (self * [w * w - b2; 4] + bs * along) + bs.cross(self) * [w * 2.0; 4]
    }
}

impl Add for Vec3x4 {
    type Output = Vec3x4;

    #[inline(always)]
    fn add(self, rhs: Vec3x4) -> Vec3x4 {
        Vec3x4 {
            x: zip(self.x, rhs.x, |a, b| a + b),
            y: zip(self.y, rhs.y, |a, b| a + b),
            z: zip(self.z, rhs.z, |a, b| a + b),
        }
    }
}

impl Sub for Vec3x4 {
    type Output = Vec3x4;

    #[inline(always)]
    fn sub(self, rhs: Vec3x4) -> Vec3x4 {
        Vec3x4 {
            x: zip(self.x, rhs.x, |a, b| a - b),
            y: zip(self.y, rhs.y, |a, b| a - b),
            z: zip(self.z, rhs.z, |a, b| a - b),
        }
    }
}

/// Each lane scaled by its own factor.
impl Mul<F4> for Vec3x4 {
    type Output = Vec3x4;

    #[inline(always)]
    fn mul(self, s: F4) -> Vec3x4 {
        Vec3x4 {
            x: zip(self.x, s, |a, b| a * b),
            y: zip(self.y, s, |a, b| a * b),
            z: zip(self.z, s, |a, b| a * b),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Awkward vectors: unit, tiny, huge, signed zeros, a zero vector.
    fn samples() -> Vec<Vec3> {
        vec![
            Vec3::new(0.3, -1.7, 2.9),
            Vec3::new(1.0e-20, -3.0e-21, 2.0e-22),
            Vec3::new(-4.0e18, 1.5e19, 3.3),
            Vec3::new(-0.0, 0.0, -0.0),
            Vec3::ZERO,
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(-0.61, 0.07, -0.79),
            Vec3::new(12.5, -0.001, 7.25),
        ]
    }

    fn bits(v: Vec3) -> [u32; 3] {
        [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]
    }

    /// Every four-wide operation gives glam's scalar bits in every lane, signed zeros included.
    #[test]
    fn each_lane_matches_glam_bit_for_bit() {
        let s = samples();
        let q = Quat::from_euler(glam::EulerRot::ZYX, 0.7, -0.2, 0.05);
        for window in s.windows(4) {
            let a = Vec3x4::from_fn(|i| window[i]);
            let b = Vec3x4::from_fn(|i| window[3 - i] * 1.3 - Vec3::splat(0.2));
            let k: F4 = std::array::from_fn(|i| window[i].y - 0.5);
            let (sum, diff, scaled) = (a + b, a - b, a * k);
            let (dot, cross, unit, turned) =
                (a.dot(b), a.cross(b), a.normalize_or_zero(), a.rotated_by(q));
            for i in 0..4 {
                let (u, v) = (a.lane(i), b.lane(i));
                assert_eq!(bits(sum.lane(i)), bits(u + v));
                assert_eq!(bits(diff.lane(i)), bits(u - v));
                assert_eq!(bits(scaled.lane(i)), bits(u * k[i]));
                assert_eq!(dot[i].to_bits(), u.dot(v).to_bits());
                assert_eq!(bits(cross.lane(i)), bits(u.cross(v)));
                assert_eq!(bits(unit.lane(i)), bits(u.normalize_or_zero()), "{u}");
                assert_eq!(bits(turned.lane(i)), bits(q * u));
            }
        }
        assert_eq!(Vec3x4::splat(Vec3::X).lane(2), Vec3::X);
    }
}

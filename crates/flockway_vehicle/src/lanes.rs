//! The four wheels' vectors held one SIMD register per axis ([`wide::f32x4`]), so that a force
//! stage does each operation on all four wheels at once.
//!
//! Every operation keeps glam's scalar order of operations (a dot product is
//! `(x·x + y·y) + z·z`, a rotation glam's `Quat * Vec3`, no fused multiply–add), and IEEE
//! addition, multiplication, division and square root round each lane as they round a scalar,
//! so the results are bit for bit those of the per-wheel `Vec3` code.

use flockway_core::arrays::array4;
use glam::{Quat, Vec3};
use std::ops::{Add, Mul, Neg, Sub};
use wide::f32x4;

/// One `f32` per wheel.
pub(crate) type F4 = [f32; 4];

/// A lane mask (all bits set where `keep` holds) for [`f32x4::select`].
#[inline(always)]
pub(crate) fn mask(keep: [bool; 4]) -> f32x4 {
    f32x4::new(array4(|i| {
        f32::from_bits(if keep[i] { u32::MAX } else { 0 })
    }))
}

/// Each lane's magnitude with the sign of the same lane of `sign`, as `f32::copysign`.
#[inline(always)]
pub(crate) fn copysign(magnitude: f32x4, sign: f32x4) -> f32x4 {
    let bit = f32x4::splat(-0.0);
    (magnitude & !bit) | (sign & bit)
}

/// Each lane of `x` clamped to `[lo, hi]` as `f32::clamp` does it (which panics where
/// `lo > hi`; the callers' bounds never cross).
#[inline(always)]
pub(crate) fn clamp(x: f32x4, lo: f32x4, hi: f32x4) -> f32x4 {
    let x = x.simd_lt(lo).select(lo, x);
    x.simd_gt(hi).select(hi, x)
}

/// Four vectors, one per wheel, stored by axis.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Vec3x4 {
    /// The four x components.
    pub x: f32x4,
    /// The four y components.
    pub y: f32x4,
    /// The four z components.
    pub z: f32x4,
}

impl Vec3x4 {
    /// The same vector in every lane.
    #[inline(always)]
    pub fn splat(v: Vec3) -> Vec3x4 {
        Vec3x4 {
            x: f32x4::splat(v.x),
            y: f32x4::splat(v.y),
            z: f32x4::splat(v.z),
        }
    }

    /// Lane `i` from `f(i)`.
    #[inline(always)]
    pub fn from_fn(f: impl FnMut(usize) -> Vec3) -> Vec3x4 {
        let v: [Vec3; 4] = array4(f);
        Vec3x4 {
            x: f32x4::new(array4(|i| v[i].x)),
            y: f32x4::new(array4(|i| v[i].y)),
            z: f32x4::new(array4(|i| v[i].z)),
        }
    }

    /// Lane `i` as a vector.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Vec3 {
        Vec3::new(
            self.x.as_array()[i],
            self.y.as_array()[i],
            self.z.as_array()[i],
        )
    }

    /// Sets lane `i`.
    #[inline(always)]
    pub fn set(&mut self, i: usize, v: Vec3) {
        self.x.as_mut_array()[i] = v.x;
        self.y.as_mut_array()[i] = v.y;
        self.z.as_mut_array()[i] = v.z;
    }

    /// Each lane where `keep` holds, zero elsewhere.
    #[inline(always)]
    pub fn masked(self, keep: [bool; 4]) -> Vec3x4 {
        let mask = mask(keep);
        Vec3x4 {
            x: mask.select(self.x, f32x4::ZERO),
            y: mask.select(self.y, f32x4::ZERO),
            z: mask.select(self.z, f32x4::ZERO),
        }
    }

    /// Each lane's dot product with the same lane of `rhs`, as glam orders it.
    #[inline(always)]
    pub fn dot(self, rhs: Vec3x4) -> f32x4 {
        (self.x * rhs.x) + (self.y * rhs.y) + (self.z * rhs.z)
    }

    /// Each lane's cross product with the same lane of `rhs`, as glam orders it.
    #[inline(always)]
    pub fn cross(self, rhs: Vec3x4) -> Vec3x4 {
        Vec3x4 {
            x: self.y * rhs.z - rhs.y * self.z,
            y: self.z * rhs.x - rhs.z * self.x,
            z: self.x * rhs.y - rhs.x * self.y,
        }
    }

    /// Each lane normalised, or zero where that is not finite (glam's `normalize_or_zero`).
    #[inline(always)]
    pub fn normalize_or_zero(self) -> Vec3x4 {
        let rcp = f32x4::ONE / self.dot(self).sqrt();
        let keep = rcp.is_finite() & rcp.simd_gt(f32x4::ZERO);
        // A dropped lane is +0.0 in every component, as glam's `Vec3::ZERO` (the product
        // could be −0.0 or NaN there).
        let scaled = self * rcp;
        Vec3x4 {
            x: keep.select(scaled.x, f32x4::ZERO),
            y: keep.select(scaled.y, f32x4::ZERO),
            z: keep.select(scaled.z, f32x4::ZERO),
        }
    }

    /// Each lane rotated by `q`, as glam's scalar `Quat * Vec3` computes it.
    #[inline(always)]
    pub fn rotated_by(self, q: Quat) -> Vec3x4 {
        Quatx4::splat(q).rotate(self)
    }
}

impl Add for Vec3x4 {
    type Output = Vec3x4;

    #[inline(always)]
    fn add(self, rhs: Vec3x4) -> Vec3x4 {
        Vec3x4 {
            x: self.x + rhs.x,
            y: self.y + rhs.y,
            z: self.z + rhs.z,
        }
    }
}

impl Sub for Vec3x4 {
    type Output = Vec3x4;

    #[inline(always)]
    fn sub(self, rhs: Vec3x4) -> Vec3x4 {
        Vec3x4 {
            x: self.x - rhs.x,
            y: self.y - rhs.y,
            z: self.z - rhs.z,
        }
    }
}

/// Each lane's sign flipped (glam's `-Vec3`: `-0.0` from `0.0`, unlike a subtraction).
impl Neg for Vec3x4 {
    type Output = Vec3x4;

    #[inline(always)]
    fn neg(self) -> Vec3x4 {
        Vec3x4 {
            x: -self.x,
            y: -self.y,
            z: -self.z,
        }
    }
}

/// Each lane scaled by its own factor.
impl Mul<f32x4> for Vec3x4 {
    type Output = Vec3x4;

    #[inline(always)]
    fn mul(self, s: f32x4) -> Vec3x4 {
        Vec3x4 {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
}

/// Four quaternions, one per lane, stored by component.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Quatx4 {
    /// The four x components.
    pub x: f32x4,
    /// The four y components.
    pub y: f32x4,
    /// The four z components.
    pub z: f32x4,
    /// The four w components.
    pub w: f32x4,
}

impl Quatx4 {
    /// The same quaternion in every lane.
    #[inline(always)]
    pub fn splat(q: Quat) -> Quatx4 {
        Quatx4 {
            x: f32x4::splat(q.x),
            y: f32x4::splat(q.y),
            z: f32x4::splat(q.z),
            w: f32x4::splat(q.w),
        }
    }

    /// Lane `i` from `f(i)`.
    #[inline(always)]
    pub fn from_fn(f: impl FnMut(usize) -> Quat) -> Quatx4 {
        let q: [Quat; 4] = array4(f);
        Quatx4 {
            x: f32x4::new(array4(|i| q[i].x)),
            y: f32x4::new(array4(|i| q[i].y)),
            z: f32x4::new(array4(|i| q[i].z)),
            w: f32x4::new(array4(|i| q[i].w)),
        }
    }

    /// Lane `i` as a quaternion.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Quat {
        Quat::from_xyzw(
            self.x.as_array()[i],
            self.y.as_array()[i],
            self.z.as_array()[i],
            self.w.as_array()[i],
        )
    }

    /// Each lane's product with the same lane of `rhs`, as glam's `Quat * Quat` orders it.
    #[inline(always)]
    pub fn mul(self, rhs: Quatx4) -> Quatx4 {
        let (x0, y0, z0, w0) = (self.x, self.y, self.z, self.w);
        let (x1, y1, z1, w1) = (rhs.x, rhs.y, rhs.z, rhs.w);
        Quatx4 {
            x: w0 * x1 + x0 * w1 + y0 * z1 - z0 * y1,
            y: w0 * y1 - x0 * z1 + y0 * w1 + z0 * x1,
            z: w0 * z1 + x0 * y1 - y0 * x1 + z0 * w1,
            w: w0 * w1 - x0 * x1 - y0 * y1 - z0 * z1,
        }
    }

    /// Each lane's conjugate (a unit quaternion's inverse, as glam's `Quat::inverse`).
    #[inline(always)]
    pub fn conjugate(self) -> Quatx4 {
        Quatx4 {
            x: -self.x,
            y: -self.y,
            z: -self.z,
            w: self.w,
        }
    }

    /// Each lane normalised as glam's `Quat::normalize` does it (times one over its length).
    #[inline(always)]
    pub fn normalize(self) -> Quatx4 {
        let dot = self.x * self.x + self.y * self.y + self.z * self.z + self.w * self.w;
        let recip = f32x4::ONE / dot.sqrt();
        Quatx4 {
            x: self.x * recip,
            y: self.y * recip,
            z: self.z * recip,
            w: self.w * recip,
        }
    }

    /// Each lane of `v` rotated by the same lane, as glam's scalar `Quat * Vec3` computes it.
    #[inline(always)]
    pub fn rotate(self, v: Vec3x4) -> Vec3x4 {
        let b = Vec3x4 {
            x: self.x,
            y: self.y,
            z: self.z,
        };
        let b2 = b.dot(b);
        let along = v.dot(b) * f32x4::splat(2.0);
        (v * (self.w * self.w - b2) + b * along) + b.cross(v) * (self.w * f32x4::splat(2.0))
    }

    /// A mask of the lanes whose four components are all finite.
    #[inline(always)]
    pub fn is_finite(self) -> f32x4 {
        self.x.is_finite() & self.y.is_finite() & self.z.is_finite() & self.w.is_finite()
    }
}

impl Vec3x4 {
    /// Each lane's components times the same lane's components of `rhs` (glam's `Vec3 * Vec3`).
    #[inline(always)]
    pub fn mul_lanes(self, rhs: Vec3x4) -> Vec3x4 {
        Vec3x4 {
            x: self.x * rhs.x,
            y: self.y * rhs.y,
            z: self.z * rhs.z,
        }
    }

    /// A mask of the lanes whose three components are all finite.
    #[inline(always)]
    pub fn is_finite(self) -> f32x4 {
        self.x.is_finite() & self.y.is_finite() & self.z.is_finite()
    }

    /// Each lane of `a` where `mask` is set, of `b` elsewhere.
    #[inline(always)]
    pub fn select(mask: f32x4, a: Vec3x4, b: Vec3x4) -> Vec3x4 {
        Vec3x4 {
            x: mask.select(a.x, b.x),
            y: mask.select(a.y, b.y),
            z: mask.select(a.z, b.z),
        }
    }
}

/// Test inputs: numbers spread evenly over `[lo, hi)` from a seeded xorshift, the same on every
/// machine.
#[cfg(test)]
pub(crate) fn uniform(mut seed: u32) -> impl FnMut(f32, f32) -> f32 {
    move |lo, hi| {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        lo + (hi - lo) * (seed >> 8) as f32 / (1u32 << 24) as f32
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
            Vec3::new(f32::NAN, 1.0, 0.0),
            Vec3::new(f32::INFINITY, 1.0, -2.0),
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
            let k = f32x4::new(std::array::from_fn(|i| window[i].y - 0.5));
            let (sum, diff, scaled) = (a + b, a - b, a * k);
            let (dot, cross, unit, turned) =
                (a.dot(b), a.cross(b), a.normalize_or_zero(), a.rotated_by(q));
            for i in 0..4 {
                let (u, v) = (a.lane(i), b.lane(i));
                assert_eq!(bits(sum.lane(i)), bits(u + v));
                assert_eq!(bits(diff.lane(i)), bits(u - v));
                assert_eq!(bits(scaled.lane(i)), bits(u * k.as_array()[i]));
                assert_eq!(dot.as_array()[i].to_bits(), u.dot(v).to_bits());
                assert_eq!(bits(cross.lane(i)), bits(u.cross(v)));
                assert_eq!(bits(unit.lane(i)), bits(u.normalize_or_zero()), "{u}");
                assert_eq!(bits(turned.lane(i)), bits(q * u));
            }
        }
        assert_eq!(Vec3x4::splat(Vec3::X).lane(2), Vec3::X);
        let mut m = Vec3x4::splat(Vec3::ONE).masked([true, false, true, false]);
        assert_eq!((m.lane(0), m.lane(1)), (Vec3::ONE, Vec3::ZERO));
        m.set(1, Vec3::Z);
        assert_eq!((m.lane(1), m.lane(2)), (Vec3::Z, Vec3::ONE));
        let x = f32x4::new([-2.0, 0.5, f32::NAN, -0.0]);
        let (lo, hi) = (f32x4::splat(-1.0), f32x4::new([1.0, 1.0, 1.0, 0.0]));
        let c = clamp(x, lo, hi).to_array();
        let (x, lo, hi) = (x.to_array(), lo.to_array(), hi.to_array());
        for i in 0..4 {
            assert_eq!(c[i].to_bits(), x[i].clamp(lo[i], hi[i]).to_bits());
            for s in [1.0, -1.0, 0.0, -0.0, f32::NAN] {
                let got = copysign(f32x4::splat(x[i]), f32x4::splat(s)).to_array()[0];
                assert_eq!(got.to_bits(), x[i].copysign(s).to_bits());
            }
        }
    }
}

//! The Pacejka magic formula and combined slip.

use crate::lanes::copysign;
use crate::params::{MagicFormula, TyreParams};
use flockway_core::arrays::array4;
use std::f32::consts::FRAC_PI_2;
use wide::f32x4;

impl MagicFormula {
    /// Normalised force at slip `x` (peak 1): `sin(C·atan(B·x − E·(B·x − atan(B·x))))`.
    pub fn eval(&self, x: f32) -> f32 {
        let bx = self.b * x;
        libm::sinf(self.c * libm::atanf(bx - self.e * (bx - libm::atanf(bx))))
    }

    /// Derivative of [`MagicFormula::eval`] with respect to the slip.
    pub fn slope(&self, x: f32) -> f32 {
        let bx = self.b * x;
        let phi = bx - self.e * (bx - libm::atanf(bx));
        let dphi = self.b - self.e * (self.b - self.b / (1.0 + bx * bx));
        libm::cosf(self.c * libm::atanf(phi)) * self.c / (1.0 + phi * phi) * dphi
    }

    /// [`eval`](Self::eval) and [`slope`](Self::slope) at once, sharing their arctangents.
    pub fn eval_with_slope(&self, x: f32) -> (f32, f32) {
        let bx = self.b * x;
        let phi = bx - self.e * (bx - libm::atanf(bx));
        let dphi = self.b - self.e * (self.b - self.b / (1.0 + bx * bx));
        let angle = self.c * libm::atanf(phi);
        let (sin, cos) = libm::sincosf(angle);
        (sin, cos * self.c / (1.0 + phi * phi) * dphi)
    }

    /// The slip at which the force peaks, found once per vehicle type. With C ≤ 1 the curve
    /// never falls, and the slip where it reaches 99 % of its limit is returned instead.
    pub fn peak_slip(&self) -> f32 {
        // The peak is where C·atan(φ) = π/2, i.e. φ = tan(π / 2C); φ(x) rises monotonically.
        let phi = if self.c > 1.0 {
            libm::tanf(FRAC_PI_2 / self.c)
        } else {
            libm::tanf(0.99 * FRAC_PI_2)
        };
        let f = |x: f32| {
            let bx = self.b * x;
            bx - self.e * (bx - libm::atanf(bx))
        };
        let (mut lo, mut hi) = (0.0f32, 1.0f32);
        while f(hi) < phi && hi < 1.0e4 {
            hi *= 2.0;
        }
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if f(mid) < phi {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }
}

/// A magic-formula curve sampled for fast evaluation: linear interpolation in a table of
/// [`CURVE_SAMPLES`] values from zero to ten times the peak slip, flat beyond (the curves are
/// flat there too). Within 2·10⁻⁴ of the formula; value and slope cost a few multiplications
/// instead of four arctangents and a sine.
#[derive(Debug, Clone, PartialEq)]
pub struct SampledCurve {
    inv_step: f32,
    values: Vec<f32>,
    /// Each sample with the next, so that the four-wide evaluation reads a lane's two samples
    /// at once.
    pairs: Vec<[f32; 2]>,
}

/// Number of samples in a [`SampledCurve`].
pub const CURVE_SAMPLES: usize = 2048;

impl SampledCurve {
    /// Samples `mf` from zero to `x_max`.
    pub fn new(mf: &MagicFormula, x_max: f32) -> SampledCurve {
        let step = x_max / (CURVE_SAMPLES - 1) as f32;
        let values: Vec<f32> = (0..CURVE_SAMPLES)
            .map(|i| mf.eval(i as f32 * step))
            .collect();
        SampledCurve {
            inv_step: 1.0 / step,
            pairs: values.windows(2).map(|w| [w[0], w[1]]).collect(),
            values,
        }
    }

    /// [`eval`](Self::eval) at four points: the same bits in each lane, the arithmetic four
    /// wide and only the table reads one at a time.
    #[inline(always)]
    pub(crate) fn eval4(&self, x: f32x4) -> (f32x4, f32x4) {
        let inv_step = f32x4::splat(self.inv_step);
        let pos = x.abs() * inv_step;
        let last = self.values.len().saturating_sub(1);
        // `eval`'s `pos as usize` past the table's end (or NaN, which it reads as 0) is a lane
        // that reads the first two samples here and is replaced below.
        let beyond = pos.simd_ge(f32x4::splat(last as f32));
        let skip = (beyond | pos.is_nan()).to_bitmask();
        let trunc = pos.fast_trunc_int().to_array();
        let index: [usize; 4] = array4(|k| {
            if skip >> k & 1 != 0 {
                0
            } else {
                usize::try_from(trunc[k]).unwrap_or(0)
            }
        });
        // A lane replaced below may read past the pairs (a table of fewer than two samples).
        let pair: [[f32; 2]; 4] = array4(|k| self.pairs.get(index[k]).copied().unwrap_or([0.0; 2]));
        let a = f32x4::new(array4(|k| pair[k][0]));
        let b = f32x4::new(array4(|k| pair[k][1]));
        let sample = |i: usize| self.values.get(i).copied().unwrap_or(0.0);
        let t = pos - f32x4::new(array4(|k| index[k] as f32));
        let rise = b - a;
        let value = copysign(a + rise * t, x);
        let slope = rise * inv_step;
        let flat = copysign(f32x4::splat(sample(last)), x);
        (
            beyond.select(flat, value),
            beyond.select(f32x4::ZERO, slope),
        )
    }

    /// `(value, slope)` at `x` (odd in `x`, like the formula).
    #[inline]
    pub fn eval(&self, x: f32) -> (f32, f32) {
        let pos = x.abs() * self.inv_step;
        let i = pos as usize;
        if i + 1 >= self.values.len() {
            let last = self.values.last().copied().unwrap_or(0.0);
            return (last.copysign(x), 0.0);
        }
        let (a, b) = (self.values[i], self.values[i + 1]);
        let t = pos - i as f32;
        ((a + (b - a) * t).copysign(x), (b - a) * self.inv_step)
    }
}

/// Tyre constants derived once from [`TyreParams`].
#[derive(Debug, Clone, PartialEq)]
pub struct Tyre {
    /// Longitudinal curve.
    pub longitudinal: MagicFormula,
    /// Lateral curve.
    pub lateral: MagicFormula,
    /// Slip ratio of peak longitudinal force.
    pub peak_slip_ratio: f32,
    /// Slip angle of peak lateral force, rad.
    pub peak_slip_angle_rad: f32,
    /// Peak friction coefficient.
    pub friction: f32,
    /// The longitudinal curve, sampled.
    pub longitudinal_table: SampledCurve,
    /// The lateral curve, sampled.
    pub lateral_table: SampledCurve,
}

impl Tyre {
    /// Prepares the combined-slip model for one set of parameters.
    pub fn new(p: &TyreParams) -> Tyre {
        let peak_slip_ratio = p.longitudinal.peak_slip();
        let peak_slip_angle_rad = p.lateral.peak_slip();
        Tyre {
            longitudinal: p.longitudinal,
            lateral: p.lateral,
            peak_slip_ratio,
            peak_slip_angle_rad,
            friction: p.friction,
            longitudinal_table: SampledCurve::new(&p.longitudinal, 10.0 * peak_slip_ratio),
            lateral_table: SampledCurve::new(&p.lateral, 10.0 * peak_slip_angle_rad),
        }
    }

    /// Longitudinal and lateral force coefficients (force ÷ load ÷ friction scale) for a slip
    /// ratio and a slip angle, combined by normalised slip: each direction's slip is scaled by
    /// its peak, the magnitude of the combined slip vector picks a point on each curve, and the
    /// force is shared in the direction of that vector. Pure slip gives the pure curves back;
    /// combined slip stays inside the friction ellipse.
    ///
    /// Signs: a positive slip ratio (wheel faster than the road) pushes forward; a positive slip
    /// angle (contact patch sliding to the left) pushes right, so the result is negated for it.
    pub fn combined(&self, slip_ratio: f32, slip_angle_rad: f32) -> (f32, f32) {
        let sx = slip_ratio / self.peak_slip_ratio;
        let sy = slip_angle_rad / self.peak_slip_angle_rad;
        let rho = (sx * sx + sy * sy).sqrt();
        if rho < 1.0e-9 {
            return (0.0, 0.0);
        }
        let fx = self.longitudinal.eval(rho * self.peak_slip_ratio) * sx / rho;
        let fy = -self.lateral.eval(rho * self.peak_slip_angle_rad) * sy / rho;
        (self.friction * fx, self.friction * fy)
    }

    /// Rate of change of the longitudinal coefficient with slip ratio near a combined slip state,
    /// never negative (past the peak the force is treated as flat). Used to integrate wheel spin
    /// implicitly.
    pub fn longitudinal_stiffness(&self, slip_ratio: f32, slip_angle_rad: f32) -> f32 {
        self.forces(slip_ratio, slip_angle_rad).2
    }

    /// [`combined`](Self::combined) and [`longitudinal_stiffness`](Self::longitudinal_stiffness)
    /// in one evaluation from the sampled curves: `(fx, fy, dfx/dslip)`. This is what the
    /// simulation uses each step.
    pub fn forces(&self, slip_ratio: f32, slip_angle_rad: f32) -> (f32, f32, f32) {
        let sx = slip_ratio / self.peak_slip_ratio;
        let sy = slip_angle_rad / self.peak_slip_angle_rad;
        let rho = (sx * sx + sy * sy).sqrt();
        let (long, slope) = self.longitudinal_table.eval(rho * self.peak_slip_ratio);
        let slope = (self.friction * slope).max(0.0);
        if rho < 1.0e-9 {
            return (0.0, 0.0, slope);
        }
        let fx = long * sx / rho;
        let fy = -self.lateral_table.eval(rho * self.peak_slip_angle_rad).0 * sy / rho;
        (self.friction * fx, self.friction * fy, slope)
    }

    /// [`forces`](Self::forces) for four wheels at once, bit for bit the same in each lane.
    #[inline(always)]
    pub(crate) fn forces4(&self, slip_ratio: f32x4, slip_angle_rad: f32x4) -> [f32x4; 3] {
        let peak_ratio = f32x4::splat(self.peak_slip_ratio);
        let peak_angle = f32x4::splat(self.peak_slip_angle_rad);
        let friction = f32x4::splat(self.friction);
        let sx = slip_ratio / peak_ratio;
        let sy = slip_angle_rad / peak_angle;
        let rho = (sx * sx + sy * sy).sqrt();
        let (long, slope) = self.longitudinal_table.eval4(rho * peak_ratio);
        // `f32::max(_, 0.0)` lane by lane: a tie of signed zeros must resolve as it does there.
        let slope = (friction * slope).to_array();
        let slope = f32x4::new(array4(|k| slope[k].max(0.0)));
        let (lat, _) = self.lateral_table.eval4(rho * peak_angle);
        let at_rest = rho.simd_lt(f32x4::splat(1.0e-9));
        let fx = friction * (long * sx / rho);
        let fy = friction * (-lat * sy / rho);
        [
            at_rest.select(f32x4::ZERO, fx),
            at_rest.select(f32x4::ZERO, fy),
            slope,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn magic_formula_matches_hand_computed_values() {
        // B = 10, C = 1.9, E = 0.97 at x = 0.05:
        // Bx = 0.5; atan(0.5) = 0.463648; Bx − E(Bx − atan Bx) = 0.5 − 0.97·0.036352 = 0.464739;
        // atan(0.464739) = 0.435000; sin(1.9 · 0.435000) = sin(0.826500) = 0.735623.
        let mf = MagicFormula {
            b: 10.0,
            c: 1.9,
            e: 0.97,
        };
        assert!(close(mf.eval(0.05), 0.735_62, 1e-4), "{}", mf.eval(0.05));
        // x = 1 (locked wheel): Bx = 10; atan 10 = 1.471128; 10 − 0.97·8.528872 = 1.727014;
        // atan(1.727014) = 1.045975; sin(1.987353) = 0.914522.
        assert!(close(mf.eval(1.0), 0.914_52, 1e-4), "{}", mf.eval(1.0));
        assert_eq!(mf.eval(0.0), 0.0);
        assert!(close(mf.eval(-0.05), -mf.eval(0.05), 1e-7));
    }

    #[test]
    fn slope_matches_a_finite_difference() {
        let mf = MagicFormula {
            b: 10.0,
            c: 1.9,
            e: 0.97,
        };
        assert!(close(mf.slope(0.0), 19.0, 1e-4), "B·C at zero slip");
        for x in [0.01f32, 0.05, 0.15, 0.4, 1.0] {
            let fd = (mf.eval(x + 1e-3) - mf.eval(x - 1e-3)) / 2e-3;
            assert!(
                close(mf.slope(x), fd, 2e-2 * fd.abs().max(1.0)),
                "{x}: {} vs {fd}",
                mf.slope(x)
            );
        }
    }

    #[test]
    fn peak_slip_is_where_the_curve_peaks() {
        let mf = MagicFormula {
            b: 10.0,
            c: 1.9,
            e: 0.97,
        };
        let k = mf.peak_slip();
        assert!(close(mf.eval(k), 1.0, 1e-5));
        assert!(mf.eval(k * 0.9) < 1.0 && mf.eval(k * 1.1) < 1.0);
        // Typical dry asphalt peaks between 8 % and 20 % slip.
        assert!((0.08..0.2).contains(&k), "{k}");
    }

    #[test]
    fn combined_slip_reduces_to_pure_slip_and_stays_in_the_ellipse() {
        let t = Tyre::new(&TyreParams::default());
        let (fx, fy) = t.combined(0.05, 0.0);
        assert!(close(fx, t.longitudinal.eval(0.05), 1e-6) && fy == 0.0);
        let (fx, fy) = t.combined(0.0, 0.03);
        assert!(fx == 0.0 && close(fy, -t.lateral.eval(0.03), 1e-6));
        for &(k, a) in &[(0.1, 0.1), (0.5, 0.02), (-0.3, -0.2), (0.05, 0.05)] {
            let (fx, fy) = t.combined(k, a);
            assert!(
                fx.hypot(fy) <= t.friction + 1e-5,
                "({k}, {a}) → ({fx}, {fy})"
            );
            assert!(fx.signum() == k.signum() && fy.signum() == -a.signum());
        }
    }

    #[test]
    fn joint_evaluation_matches_the_separate_ones() {
        let t = Tyre::new(&TyreParams::default());
        for &(k, a) in &[
            (0.0, 0.0),
            (0.03, 0.0),
            (-0.2, 0.05),
            (0.5, -0.3),
            (0.0, 0.1),
        ] {
            let (fx, fy, d) = t.forces(k, a);
            let (cx, cy) = t.combined(k, a);
            assert!(close(fx, cx, 2e-4) && close(fy, cy, 2e-4), "({k}, {a})");
            let rho =
                ((k / t.peak_slip_ratio).powi(2) + (a / t.peak_slip_angle_rad).powi(2)).sqrt();
            let slope = (t.longitudinal.slope(rho * t.peak_slip_ratio) * t.friction).max(0.0);
            assert!(close(d, slope, 0.05 * slope.max(1.0)), "{d} vs {slope}");
        }
    }

    #[test]
    fn four_wheels_at_once_give_each_wheel_s_bits() {
        let t = Tyre::new(&TyreParams::default());
        // Rest, tiny, ordinary, past the peak, past the table's end, signed zeros, NaN.
        let slips = [
            (0.0, 0.0),
            (-0.0, -0.0),
            (1.0e-12, -1.0e-12),
            (0.03, 0.0),
            (-0.2, 0.05),
            (0.5, -0.3),
            (0.0, 0.1),
            (40.0, -7.0),
            (-1.0e6, 3.0e5),
            (0.08, -0.0),
            (f32::NAN, 0.1),
            (0.01, 0.0),
        ];
        for w in slips.windows(4) {
            let [fx, fy, d] = t.forces4(
                f32x4::new(std::array::from_fn(|i| w[i].0)),
                f32x4::new(std::array::from_fn(|i| w[i].1)),
            );
            let (fx, fy, d) = (fx.to_array(), fy.to_array(), d.to_array());
            for (i, &(k, a)) in w.iter().enumerate() {
                let (ex, ey, ed) = t.forces(k, a);
                let got = [fx[i], fy[i], d[i]].map(f32::to_bits);
                assert_eq!(got, [ex, ey, ed].map(f32::to_bits), "({k}, {a})");
            }
        }
    }

    #[test]
    fn sampled_curves_follow_the_formula_everywhere() {
        let t = Tyre::new(&TyreParams::default());
        for (mf, table, peak) in [
            (t.longitudinal, &t.longitudinal_table, t.peak_slip_ratio),
            (t.lateral, &t.lateral_table, t.peak_slip_angle_rad),
        ] {
            for i in -4000..=4000 {
                let x = i as f32 * peak * 3.0 / 4000.0;
                let (v, _) = table.eval(x);
                assert!(close(v, mf.eval(x), 2e-4), "{x}: {v} vs {}", mf.eval(x));
            }
            // Beyond the table the curve is flat and keeps its sign.
            let far = table.eval(-50.0 * peak);
            assert!(close(far.0, mf.eval(-10.0 * peak), 1e-6) && far.1 == 0.0);
        }
    }

    #[test]
    fn lateral_peak_is_at_a_realistic_slip_angle() {
        let t = Tyre::new(&TyreParams::default());
        let deg = t.peak_slip_angle_rad.to_degrees();
        assert!((4.0..12.0).contains(&deg), "{deg}");
    }
}

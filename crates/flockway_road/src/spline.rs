//! Cubic segments of a centripetal Catmull-Rom spline, in Hermite form.

use crate::spec::RoadSpec;
use glam::DVec3;

/// One cubic piece `C(u) = a + b·u + c·u² + d·u³`, `u` in [0, 1], from control point `i` to `i+1`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Cubic {
    a: DVec3,
    b: DVec3,
    c: DVec3,
    d: DVec3,
}

impl Cubic {
    /// The Hermite cubic from `p0` to `p1` with end derivatives `m0`, `m1` (per unit `u`).
    pub(crate) fn hermite(p0: DVec3, m0: DVec3, p1: DVec3, m1: DVec3) -> Cubic {
        Cubic {
            a: p0,
            b: m0,
            c: -3.0 * p0 - 2.0 * m0 + 3.0 * p1 - m1,
            d: 2.0 * p0 + m0 - 2.0 * p1 + m1,
        }
    }

    /// The box the curve on `u` in [0, 1] stays within: its Bézier control points' box (a
    /// Bézier curve lies in the convex hull of its control points).
    pub(crate) fn bounds(&self) -> (DVec3, DVec3) {
        let p0 = self.a;
        let p3 = self.a + self.b + self.c + self.d;
        let p1 = p0 + self.b / 3.0;
        let p2 = p3 - self.d1(1.0) / 3.0;
        (p0.min(p1).min(p2).min(p3), p0.max(p1).max(p2).max(p3))
    }

    /// The coefficients `a + u·(b + u·(c + u·d))`.
    #[inline]
    pub(crate) fn coefficients(&self) -> [DVec3; 4] {
        [self.a, self.b, self.c, self.d]
    }

    #[inline]
    pub(crate) fn pos(&self, u: f64) -> DVec3 {
        self.a + u * (self.b + u * (self.c + u * self.d))
    }

    #[inline]
    pub(crate) fn d1(&self, u: f64) -> DVec3 {
        self.b + u * (2.0 * self.c + 3.0 * u * self.d)
    }

    #[inline]
    pub(crate) fn d2(&self, u: f64) -> DVec3 {
        2.0 * self.c + 6.0 * u * self.d
    }

    /// Arc length from `u0` to `u1` by 5-point Gauss–Legendre quadrature.
    #[inline]
    pub(crate) fn length(&self, u0: f64, u1: f64) -> f64 {
        // Nodes and weights on [-1, 1].
        const X: [f64; 5] = [
            0.0,
            -0.538_469_310_105_683,
            0.538_469_310_105_683,
            -0.906_179_845_938_664,
            0.906_179_845_938_664,
        ];
        const W: [f64; 5] = [
            0.568_888_888_888_889,
            0.478_628_670_499_366,
            0.478_628_670_499_366,
            0.236_926_885_056_189,
            0.236_926_885_056_189,
        ];
        let half = 0.5 * (u1 - u0);
        let mid = 0.5 * (u1 + u0);
        let mut sum = 0.0;
        for k in 0..5 {
            sum += W[k] * self.d1(mid + half * X[k]).length();
        }
        sum * half
    }
}

/// The cubic pieces of a road's centre line: `n − 1` for an open road, `n` for a closed loop.
///
/// Directions at the points follow the centripetal Catmull-Rom rule (knot spacing √distance, no
/// cusps or self-loops), or a point's `tangent` override. Magnitudes are fitted per segment end so
/// that points on a circle give that circle: a chord `c` whose end direction deviates from it by
/// `α` gets magnitude `c / cos²(α/2)` — exact for a circular arc, and `c` (a straight line) when
/// `α` is 0. Plain Catmull-Rom magnitudes cut inside circles (−0.09 % length on a 12-point ring).
pub(crate) fn centre_line(spec: &RoadSpec) -> Vec<Cubic> {
    let p: Vec<DVec3> = spec.points.iter().map(|cp| cp.pos).collect();
    let n = p.len();
    let closed = spec.closed;
    // Point i, with phantom points mirrored past the ends of open roads.
    let at = |i: isize| -> DVec3 {
        let n_i = n as isize;
        if closed {
            p[i.rem_euclid(n_i) as usize]
        } else if i < 0 {
            2.0 * p[0] - p[1]
        } else if i >= n_i {
            2.0 * p[n - 1] - p[n - 2]
        } else {
            p[i as usize]
        }
    };
    let knot = |a: DVec3, b: DVec3| (a - b).length().sqrt().max(1e-9);

    // Unit direction at each point.
    let direction = |i: usize| -> DVec3 {
        let (pm, p0, pp) = (at(i as isize - 1), at(i as isize), at(i as isize + 1));
        let (dt0, dt1) = (knot(p0, pm), knot(pp, p0));
        let m = (p0 - pm) / dt0 - (pp - pm) / (dt0 + dt1) + (pp - p0) / dt1;
        let chord = (pp - pm).normalize_or(DVec3::X);
        match spec.points[i].tangent {
            Some(dir) if dir.length_squared() > 1e-12 => dir.normalize(),
            _ => m.normalize_or(chord),
        }
    };
    let d: Vec<DVec3> = (0..n).map(direction).collect();
    let magnitude = |chord: DVec3, dir: DVec3| {
        let c = chord.length();
        let cos_alpha = (chord.dot(dir) / c).clamp(0.0, 1.0);
        // cos²(α/2) = (1 + cos α) / 2; α is capped at 90° so the magnitude stays within 2c.
        c / (0.5 * (1.0 + cos_alpha))
    };
    let segments = if closed { n } else { n - 1 };
    (0..segments)
        .map(|i| {
            let j = (i + 1) % n;
            let chord = p[j] - p[i];
            Cubic::hermite(
                p[i],
                d[i] * magnitude(chord, d[i]),
                p[j],
                d[j] * magnitude(chord, d[j]),
            )
        })
        .collect()
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hermite_meets_its_end_conditions() {
        let (p0, m0, p1, m1) = (
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(4.0, 0.0, 1.0),
            DVec3::new(5.0, -1.0, 0.0),
            DVec3::new(0.0, 3.0, 0.0),
        );
        let c = Cubic::hermite(p0, m0, p1, m1);
        assert!((c.pos(0.0) - p0).length() < 1e-12);
        assert!((c.pos(1.0) - p1).length() < 1e-12);
        assert!((c.d1(0.0) - m0).length() < 1e-12);
        assert!((c.d1(1.0) - m1).length() < 1e-12);
    }

    #[test]
    fn straight_line_length_is_exact() {
        let c = Cubic::hermite(
            DVec3::ZERO,
            DVec3::X * 10.0,
            DVec3::X * 10.0,
            DVec3::X * 10.0,
        );
        assert!((c.length(0.0, 1.0) - 10.0).abs() < 1e-12);
    }
}

//! Euclidean remainders for the step's hot paths: positions on a loop and angles, which are
//! nearly always within a period of their range already. `f64::rem_euclid` calls the maths
//! library's `fmod` whatever the value (a loop in software, not one instruction); these answer
//! those within a period by one addition or subtraction and are equal to it bit for bit.

/// Defines `$name(x, m)`, `x.rem_euclid(m)` in `$t` for a period `m > 0`, to the bit.
macro_rules! rem_euclid_for {
    ($name:ident, $t:ty, $doc:literal) => {
        #[doc = $doc]
        #[inline]
        pub fn $name(x: $t, m: $t) -> $t {
            // fmod is exact: within (−m, 2m) the remainder is x, x + m or x − m, and the last
            // is exact in floating point too (Sterbenz: m ≤ x ≤ 2m). −m itself goes to the
            // library, whose answer is −0.
            if (0.0..m).contains(&x) {
                x
            } else if x < 0.0 && x > -m {
                x + m
            } else if x >= m && x < 2.0 * m {
                x - m
            } else {
                x.rem_euclid(m)
            }
        }
    };
}

rem_euclid_for!(
    rem_euclid,
    f64,
    "`x.rem_euclid(m)` for a period `m > 0`, to the bit."
);
rem_euclid_for!(
    rem_euclid_f32,
    f32,
    "`x.rem_euclid(m)` for a period `m > 0` in single precision, to the bit."
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_remainders_equal_the_standard_ones_to_the_bit() {
        let periods = [1.0, 3.7, 523.6, 6_283.185_307_179_586, 1.0e-3, 5.0e7];
        let mut seed = 3_u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for &m in &periods {
            let mut xs = vec![
                0.0,
                -0.0,
                m,
                -m,
                2.0 * m,
                -2.0 * m,
                m - m * f64::EPSILON,
                -m + m * f64::EPSILON,
                f64::MIN_POSITIVE,
                -f64::MIN_POSITIVE,
                1.0e300,
                -1.0e300,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NAN,
            ];
            xs.extend((0..2000).map(|_| (next() * 8.0 - 4.0) * m));
            for x in xs {
                let (want, got) = (x.rem_euclid(m), rem_euclid(x, m));
                assert!(
                    want.to_bits() == got.to_bits() || (want.is_nan() && got.is_nan()),
                    "{x} mod {m}: {got} not {want}"
                );
                let (x, m) = (x as f32, m as f32);
                let (want, got) = (x.rem_euclid(m), rem_euclid_f32(x, m));
                assert!(
                    want.to_bits() == got.to_bits() || (want.is_nan() && got.is_nan()),
                    "{x} mod {m}: {got} not {want}"
                );
            }
        }
    }
}

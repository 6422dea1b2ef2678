//! Small fixed-size arrays built element by element, for the per-car code that is built twice
//! (for x86-64 and for AVX2, chosen at run time).
//!
//! `std::array::from_fn` and `<[T; N]>::map` go through core's generic `try_from_fn` loop, which
//! the compiler left out of line in the AVX2 build (callgrind counted five such calls a car and
//! step), and code out of line runs the baseline build, not the caller's. These are always
//! inlined and spell the elements out, so a small closure's calls sit in the caller and inline
//! into its build too; a large closure called twice may still stay a call, so such calls are
//! better written out. The elements are made in index order, as `from_fn` makes them.

/// `[f(0), f(1)]`, made in that order.
#[inline(always)]
pub fn array2<T>(mut f: impl FnMut(usize) -> T) -> [T; 2] {
    [f(0), f(1)]
}

/// `[f(0), f(1), f(2), f(3)]`, made in that order.
#[inline(always)]
pub fn array4<T>(mut f: impl FnMut(usize) -> T) -> [T; 4] {
    [f(0), f(1), f(2), f(3)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn elements_come_in_index_order_like_from_fn() {
        let mut calls = Vec::new();
        let got = array4(|i| {
            calls.push(i);
            i * 10
        });
        assert_eq!(got, std::array::from_fn::<usize, 4, _>(|i| i * 10));
        assert_eq!(calls, [0, 1, 2, 3]);
        let mut calls = Vec::new();
        let pair = array2(|i| {
            calls.push(i);
            format!("{i}")
        });
        assert_eq!(pair, ["0".to_string(), "1".to_string()]);
        assert_eq!(calls, [0, 1]);
    }
}

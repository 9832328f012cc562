//! Small vector kernels shared by the crates above (correlations, simulation).

/// Dot product `Σ a_i b_i` over the common length of `a` and `b`.
///
/// Eight independent fused multiply-add accumulators, which the compiler maps to
/// SIMD registers (a sequential fold is one dependent chain and cannot be
/// vectorised). Exact for integer-valued data whose partial sums stay below 2⁵³,
/// like the sequential sum. O(n), no allocation; `#[inline]` so that hot loops in
/// other crates (periodic correlations, the simulator's state update) can inline it.
/// Meant for code inside [`crate::simd::dispatch`]: compiled for the baseline
/// x86-64 outside it, each fused multiply-add is a library call (the same bits,
/// a call per product). It does not dispatch itself: a check per call made the
/// simulator's engine 7–21 % slower in four of the five criterion `sim` cases
/// (10 % faster in one; 2026-12-01), whose short row products run inside
/// dispatched loops.
///
/// ```
/// assert_eq!(lifted_linalg::dot(&[1.0, 2.0, 3.0], &[4.0, 5.0, 6.0, 7.0]), 32.0);
/// ```
#[inline]
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 8];
    let mut ca = a.chunks_exact(8);
    let mut cb = b.chunks_exact(8);
    for (xa, xb) in (&mut ca).zip(&mut cb) {
        for i in 0..8 {
            acc[i] = xa[i].mul_add(xb[i], acc[i]);
        }
    }
    let mut tail = 0.0;
    for (xa, xb) in ca.remainder().iter().zip(cb.remainder()) {
        tail = xa.mul_add(*xb, tail);
    }
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7])) + tail
}

/// Sum `Σ x_i` with eight independent accumulators (vectorised, like
/// [`dot`]). O(n), no allocation.
///
/// ```
/// assert_eq!(lifted_linalg::kernels::sum(&[1.0, 2.0, 3.0, 4.5]), 10.5);
/// ```
#[inline]
pub fn sum(x: &[f64]) -> f64 {
    let mut acc = [0.0f64; 8];
    let mut chunks = x.chunks_exact(8);
    for c in &mut chunks {
        for i in 0..8 {
            acc[i] += c[i];
        }
    }
    let tail: f64 = chunks.remainder().iter().sum();
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7])) + tail
}

/// Index of the first entry of `x` that is NaN or infinite (`None`: every
/// entry is finite).
///
/// Scans blocks of 64 entries without branches (a vectorised compare-and-or),
/// then locates the entry inside the first failing block, so validating a long
/// record costs a fraction of a cycle per number instead of a compare-and-branch
/// each. O(n), no allocation.
///
/// ```
/// use lifted_linalg::kernels::first_non_finite;
/// assert_eq!(first_non_finite(&[1.0, 2.0, f64::NAN, f64::INFINITY]), Some(2));
/// assert_eq!(first_non_finite(&[1.0, -3.5]), None);
/// ```
#[inline]
pub fn first_non_finite(x: &[f64]) -> Option<usize> {
    // |v| < ∞ is false for NaN and ±∞.
    first_failing(
        x,
        #[inline(always)]
        |v| v.abs() < f64::INFINITY,
    )
}

/// Index of the first entry of `x` that is +∞ or −∞ (NaN passes: a
/// record's unsampled outputs), `None` when there is none. Blocks of 64
/// scanned without branches, as [`first_non_finite`]. O(n).
///
/// ```
/// use lifted_linalg::kernels::first_infinite;
/// assert_eq!(first_infinite(&[1.0, f64::NAN, f64::NEG_INFINITY]), Some(2));
/// assert_eq!(first_infinite(&[f64::NAN, 2.0]), None);
/// ```
#[inline]
pub fn first_infinite(x: &[f64]) -> Option<usize> {
    first_failing(
        x,
        #[inline(always)]
        |v| v.abs() != f64::INFINITY,
    )
}

/// Whether an entry of `x` is NaN. Blocks of 64 scanned without
/// branches, as [`first_non_finite`]. O(n).
///
/// ```
/// assert!(lifted_linalg::kernels::has_nan(&[1.0, f64::NAN]));
/// assert!(!lifted_linalg::kernels::has_nan(&[1.0, f64::INFINITY]));
/// ```
#[inline]
pub fn has_nan(x: &[f64]) -> bool {
    first_failing(
        x,
        #[inline(always)]
        |v: f64| !v.is_nan(),
    )
    .is_some()
}

/// Index of the first entry of `x` for which `ok` is false: each block of
/// 64 tested by an and-reduction of `ok` without branches (vectorised),
/// the entry located inside the first failing block.
#[inline(always)]
fn first_failing(x: &[f64], ok: impl Fn(f64) -> bool + Copy) -> Option<usize> {
    crate::simd::dispatch(
        #[inline(always)]
        || {
            const B: usize = 64;
            let mut blocks = x.chunks_exact(B);
            for (b, blk) in blocks.by_ref().enumerate() {
                // `&` (not `&&`) keeps it branch-free.
                if !blk.iter().fold(true, |all, &v| all & ok(v)) {
                    return blk.iter().position(|&v| !ok(v)).map(|i| b * B + i);
                }
            }
            let base = x.len() - blocks.remainder().len();
            blocks
                .remainder()
                .iter()
                .position(|&v| !ok(v))
                .map(|i| base + i)
        },
    )
}

#[cfg(test)]
mod tests {
    use super::{dot, first_infinite, first_non_finite, has_nan};

    #[test]
    fn matches_the_sequential_sum() {
        for n in [0usize, 1, 7, 8, 9, 31, 64, 100] {
            let a: Vec<f64> = (0..n).map(|i| (i as f64) - 3.0).collect();
            let b: Vec<f64> = (0..n).map(|i| 2.0 * (i as f64) + 1.0).collect();
            let seq: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
            assert_eq!(dot(&a, &b), seq, "n = {n}");
        }
    }

    #[test]
    fn first_non_finite_finds_the_first_bad_entry_in_any_block() {
        for n in [0usize, 1, 63, 64, 65, 200] {
            let x: Vec<f64> = (0..n).map(|i| i as f64 - 7.0).collect();
            assert_eq!(first_non_finite(&x), None, "n = {n}");
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                for k in (0..n).step_by(13).chain(n.checked_sub(1)) {
                    let mut y = x.clone();
                    y[k] = bad;
                    if k + 3 < n {
                        y[k + 3] = f64::NAN;
                    }
                    assert_eq!(first_non_finite(&y), Some(k), "n = {n}, k = {k}");
                }
            }
        }
    }

    /// The infinity and NaN scans against their plain loops, the entry in
    /// any block and in the remainder, NaN and infinities mixed.
    #[test]
    fn the_infinity_and_nan_scans_find_what_the_plain_loops_find() {
        for n in [0usize, 1, 63, 64, 65, 200] {
            let x: Vec<f64> = (0..n).map(|i| i as f64 - 7.0).collect();
            assert_eq!(first_infinite(&x), None, "n = {n}");
            assert!(!has_nan(&x), "n = {n}");
            for k in (0..n).step_by(13).chain(n.checked_sub(1)) {
                for (bad, other) in [
                    (f64::INFINITY, f64::NAN),
                    (f64::NEG_INFINITY, f64::NAN),
                    (f64::NAN, f64::INFINITY),
                ] {
                    let mut y = x.clone();
                    y[k] = bad;
                    if k + 3 < n {
                        y[k + 3] = other;
                    }
                    let inf = y.iter().position(|v| v.is_infinite());
                    assert_eq!(first_infinite(&y), inf, "n = {n}, k = {k}");
                    assert_eq!(
                        has_nan(&y),
                        y.iter().any(|v| v.is_nan()),
                        "n = {n}, k = {k}"
                    );
                }
            }
        }
    }

    #[test]
    fn uses_the_common_length() {
        assert_eq!(dot(&[1.0, 1.0], &[2.0]), 2.0);
        assert_eq!(dot(&[], &[1.0]), 0.0);
    }
}

//! Small vector kernels shared by the crates above (correlations, simulation).

/// Dot product `Σ a_i b_i` over the common length of `a` and `b`.
///
/// Eight independent fused multiply-add accumulators, which the compiler maps to
/// SIMD registers (a sequential fold is one dependent chain and cannot be
/// vectorised). Exact for integer-valued data whose partial sums stay below 2⁵³,
/// like the sequential sum. O(n), no allocation; `#[inline]` so that hot loops in
/// other crates (periodic correlations, the simulator's state update) can inline it.
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

#[cfg(test)]
mod tests {
    use super::dot;

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
    fn uses_the_common_length() {
        assert_eq!(dot(&[1.0, 1.0], &[2.0]), 2.0);
        assert_eq!(dot(&[], &[1.0]), 0.0);
    }
}

//! The R factor of a triangle and a block of rows: [R; B] = Q [R'; 0], for
//! an upper triangular n×n R and a dense m×n B (LAPACK's `tpqrt` with a
//! dense pentagon), the step of [`crate::RAccumulator::push_rows`] once
//! its R is full.
//!
//! Householder reflection j acts on row j of R and the m rows of B only
//! (the rows of R below j are zero in column j): β = −sign(α)·‖(α, x)‖ with
//! α = R_jj and x = B's column j, τ = (β − α)/β, v = x/(α − β) (LAPACK's
//! `dlarfg`; none when x = 0), then for each later column k:
//! w = τ (R_jk + vᵀB_k), R_jk −= w, B_k −= w v. 2mn² flops, no stacked
//! copy, each column pair one contiguous dot product and one update over
//! B's columns (AVX2/FMA kernels, four 256-bit accumulators; B's columns
//! stay in L1/L2 for m ≈ 1000). The reflections are those of the stacked
//! Householder QR, so R' equals its R up to rounding (and row signs).

use crate::simd::Avx2Fma;
use nalgebra::DMatrix;

/// R of [r; b] into `r` (see the module docs); `b` is overwritten. The
/// token is the proof that the vector kernels can run. O(m n²).
pub(crate) fn fold_into_triangle(simd: Avx2Fma, r: &mut DMatrix<f64>, b: &mut DMatrix<f64>) {
    let (m, n) = b.shape();
    assert!(r.shape() == (n, n), "fold: R must be n×n");
    if m == 0 {
        return;
    }
    // The reflections' loop compiled for AVX2/FMA, so that the kernels
    // below inline into it.
    simd.run(
        #[inline(always)]
        || {
            let cols = b.as_mut_slice();
            for j in 0..n {
                let (head, tail) = cols.split_at_mut((j + 1) * m);
                let x = &mut head[j * m..];
                let xnorm = norm2(simd, x);
                if xnorm == 0.0 {
                    continue;
                }
                let alpha = r[(j, j)];
                let beta = -alpha.signum() * alpha.hypot(xnorm);
                let tau = (beta - alpha) / beta;
                let scale = 1.0 / (alpha - beta);
                x.iter_mut().for_each(|v| *v *= scale);
                r[(j, j)] = beta;
                for (k, col) in (j + 1..n).zip(tail.chunks_exact_mut(m)) {
                    let w = tau * (r[(j, k)] + dot(simd, x, col));
                    r[(j, k)] -= w;
                    axpy(simd, -w, x, col);
                }
            }
        },
    )
}

/// ‖x‖₂: the plain sum of squares unless it leaves the safe range, then
/// with the entries scaled by their largest magnitude (as LAPACK's
/// `dnrm2`: no overflow or underflow).
#[inline(always)]
fn norm2(simd: Avx2Fma, x: &[f64]) -> f64 {
    let ss = dot(simd, x, x);
    if ss.is_finite() && ss > 1e-280 && ss < 1e280 {
        return ss.sqrt();
    }
    let big = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    if big == 0.0 || !big.is_finite() {
        return big;
    }
    let scaled: f64 = x.iter().map(|v| (v / big) * (v / big)).sum();
    big * scaled.sqrt()
}

/// Σ a_i b_i (equal lengths).
#[inline(always)]
fn dot(simd: Avx2Fma, a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "fold: dot of unequal lengths");
    let _ = simd;
    #[cfg(target_arch = "x86_64")]
    // SAFETY: `simd` proves AVX2 and FMA; the lengths are equal
    // (asserted), and the kernel reads a[i], b[i] for i < len only.
    unsafe {
        dot_avx2(a.as_ptr(), b.as_ptr(), a.len())
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        a.iter().zip(b).map(|(x, y)| x * y).sum()
    }
}

/// y += α x (equal lengths).
#[inline(always)]
fn axpy(simd: Avx2Fma, alpha: f64, x: &[f64], y: &mut [f64]) {
    assert_eq!(x.len(), y.len(), "fold: axpy of unequal lengths");
    let _ = simd;
    #[cfg(target_arch = "x86_64")]
    // SAFETY: as in `dot`; the kernel reads x[i] and writes y[i] for
    // i < len only.
    unsafe {
        axpy_avx2(alpha, x.as_ptr(), y.as_mut_ptr(), x.len())
    }
    #[cfg(not(target_arch = "x86_64"))]
    for (v, u) in y.iter_mut().zip(x) {
        *v = alpha.mul_add(*u, *v);
    }
}

/// Σ a_i b_i over `len` entries: four accumulators of four lanes.
///
/// # Safety
/// AVX2 and FMA must be available; `a` and `b` readable for `len` entries.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn dot_avx2(a: *const f64, b: *const f64, len: usize) -> f64 {
    use std::arch::x86_64::*;
    // SAFETY: every offset formed is below `len` (the caller's bound).
    unsafe {
        let mut acc = [_mm256_setzero_pd(); 4];
        let mut i = 0;
        while i + 16 <= len {
            for (k, s) in acc.iter_mut().enumerate() {
                let (x, y) = (
                    _mm256_loadu_pd(a.add(i + 4 * k)),
                    _mm256_loadu_pd(b.add(i + 4 * k)),
                );
                *s = _mm256_fmadd_pd(x, y, *s);
            }
            i += 16;
        }
        while i + 4 <= len {
            acc[0] = _mm256_fmadd_pd(_mm256_loadu_pd(a.add(i)), _mm256_loadu_pd(b.add(i)), acc[0]);
            i += 4;
        }
        let s = _mm256_add_pd(_mm256_add_pd(acc[0], acc[1]), _mm256_add_pd(acc[2], acc[3]));
        let mut lanes = [0.0; 4];
        _mm256_storeu_pd(lanes.as_mut_ptr(), s);
        let mut total = (lanes[0] + lanes[2]) + (lanes[1] + lanes[3]);
        while i < len {
            total = (*a.add(i)).mul_add(*b.add(i), total);
            i += 1;
        }
        total
    }
}

/// y_i += α x_i over `len` entries.
///
/// # Safety
/// AVX2 and FMA must be available; `x` readable and `y` writable for
/// `len` entries.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn axpy_avx2(alpha: f64, x: *const f64, y: *mut f64, len: usize) {
    use std::arch::x86_64::*;
    // SAFETY: every offset formed is below `len` (the caller's bound).
    unsafe {
        let a = _mm256_set1_pd(alpha);
        let mut i = 0;
        while i + 8 <= len {
            let y0 = _mm256_fmadd_pd(a, _mm256_loadu_pd(x.add(i)), _mm256_loadu_pd(y.add(i)));
            let y1 = _mm256_fmadd_pd(
                a,
                _mm256_loadu_pd(x.add(i + 4)),
                _mm256_loadu_pd(y.add(i + 4)),
            );
            _mm256_storeu_pd(y.add(i), y0);
            _mm256_storeu_pd(y.add(i + 4), y1);
            i += 8;
        }
        while i < len {
            *y.add(i) = alpha.mul_add(*x.add(i), *y.add(i));
            i += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fold's R against the Householder QR of the stacked matrix
    /// (rows up to sign), on blocks with a zero column, scaled extremes and
    /// lengths that are no multiple of the vector width.
    #[test]
    fn the_fold_is_the_r_of_the_stacked_rows() {
        let Some(simd) = Avx2Fma::detect() else {
            return;
        };
        let mut x = 0.37f64;
        let mut next = || {
            x = (x * 3.7 + 0.11).fract();
            x - 0.5
        };
        for (m, n, scale) in [(1000, 13, 1.0), (37, 5, 1e-160), (3, 8, 1e150), (1, 1, 1.0)] {
            let first = DMatrix::from_fn(n + 4, n, |_, _| next() * scale);
            let mut block = DMatrix::from_fn(m, n, |_, _| next() * scale);
            if n > 2 {
                block.column_mut(2).fill(0.0);
            }
            let mut r = crate::qr_r(&first).unwrap();
            let mut b = block.clone();
            fold_into_triangle(simd, &mut r, &mut b);
            let mut stacked = DMatrix::zeros(n + 4 + m, n);
            stacked.rows_mut(0, n + 4).copy_from(&first);
            stacked.rows_mut(n + 4, m).copy_from(&block);
            let want = crate::qr_r(&stacked).unwrap();
            let norm = want.norm();
            for i in 0..n {
                let sign = if (r[(i, i)] >= 0.0) == (want[(i, i)] >= 0.0) {
                    1.0
                } else {
                    -1.0
                };
                for j in 0..n {
                    let d = (sign * r[(i, j)] - want[(i, j)]).abs();
                    assert!(d <= 1e-13 * norm, "{m}×{n}: R[{i},{j}] off by {d:e}");
                }
            }
        }
    }
}

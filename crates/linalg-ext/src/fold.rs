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
///
/// Each reflection's products with B's later columns are taken in the
/// previous reflection's update of those columns (look-ahead): while
/// column k is updated by reflection j − 1, its product with the already
/// updated column j is summed, so each (j, k) pair is one pass over B's
/// column k (three loads, one store, two multiply-adds per entry) instead
/// of a product pass and an update pass. The reflector is kept unscaled
/// (x = s·B_j with s = 1/(α − β) folded into the update's coefficient).
/// Where the unscaled sums of squares or products leave the safe range
/// (entries beyond about 1e±140), that reflection is taken the plain way
/// ([`reflect_plain`]: the norm with scaling, as LAPACK's `dnrm2`).
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
            // d[k] = B_jᵀ B_k for k ≥ j, when `ahead` (else recomputed).
            let mut d = vec![0.0f64; n];
            let mut ahead = false;
            for j in 0..n {
                let (head, tail) = cols.split_at_mut((j + 1) * m);
                let x = &head[j * m..];
                if !ahead {
                    d[j] = dot(simd, x, x);
                    for (k, col) in (j + 1..n).zip(tail.chunks_exact(m)) {
                        d[k] = dot(simd, x, col);
                    }
                }
                ahead = false;
                let ss = d[j];
                let safe = |v: f64| v.is_finite() && v.abs() < 1e280;
                if !(ss > 1e-280 && safe(ss) && d[j + 1..].iter().all(|&v| safe(v))) {
                    reflect_plain(simd, r, &mut head[j * m..], tail, j);
                    continue;
                }
                let alpha = r[(j, j)];
                let beta = -alpha.signum() * alpha.hypot(ss.sqrt());
                let tau = (beta - alpha) / beta;
                let scale = 1.0 / (alpha - beta);
                r[(j, j)] = beta;
                // B_k −= c_k B_j with c_k = τ (R_jk + s dᵏ) s.
                for k in j + 1..n {
                    let w = tau * scale.mul_add(d[k], r[(j, k)]);
                    r[(j, k)] -= w;
                    d[k] = w * scale;
                }
                if j + 1 == n {
                    continue;
                }
                let (next, later) = tail.split_at_mut(m);
                let c = d[j + 1];
                d[j + 1] = axpy_dot_self(simd, -c, x, next);
                for (k, col) in (j + 2..n).zip(later.chunks_exact_mut(m)) {
                    let c = d[k];
                    d[k] = axpy_dot(simd, -c, x, next, col);
                }
                ahead = true;
            }
        },
    )
}

/// Reflection `j` of [`fold_into_triangle`] the plain way: `x` is B's
/// column j (scaled in place to the reflector), `tail` its later columns.
#[inline(always)]
fn reflect_plain(simd: Avx2Fma, r: &mut DMatrix<f64>, x: &mut [f64], tail: &mut [f64], j: usize) {
    let (m, n) = (x.len(), r.ncols());
    let xnorm = norm2(simd, x);
    if xnorm == 0.0 {
        return;
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

/// y += α x, returning Σ y_i² of the updated y (equal lengths).
#[inline(always)]
fn axpy_dot_self(simd: Avx2Fma, alpha: f64, x: &[f64], y: &mut [f64]) -> f64 {
    assert_eq!(x.len(), y.len(), "fold: axpy of unequal lengths");
    let _ = simd;
    #[cfg(target_arch = "x86_64")]
    // SAFETY: as in `dot`; the kernel reads x[i], y[i] and writes y[i]
    // for i < len only (z = y: the products with the updated entries).
    unsafe {
        let yp = y.as_mut_ptr();
        axpy_dot_avx2(alpha, x.as_ptr(), yp, yp, x.len())
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut s = 0.0;
        for (v, u) in y.iter_mut().zip(x) {
            *v = alpha.mul_add(*u, *v);
            s = v.mul_add(*v, s);
        }
        s
    }
}

/// y += α x, returning Σ z_i y_i of the updated y (equal lengths).
#[inline(always)]
fn axpy_dot(simd: Avx2Fma, alpha: f64, x: &[f64], z: &[f64], y: &mut [f64]) -> f64 {
    assert!(
        x.len() == y.len() && z.len() == y.len(),
        "fold: axpy of unequal lengths"
    );
    let _ = simd;
    #[cfg(target_arch = "x86_64")]
    // SAFETY: as in `dot`; the kernel reads x[i], z[i], y[i] and writes
    // y[i] for i < len only; z does not alias y (a shared and a mutable
    // borrow).
    unsafe {
        axpy_dot_avx2(alpha, x.as_ptr(), z.as_ptr(), y.as_mut_ptr(), x.len())
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut s = 0.0;
        for ((v, u), w) in y.iter_mut().zip(x).zip(z) {
            *v = alpha.mul_add(*u, *v);
            s = w.mul_add(*v, s);
        }
        s
    }
}

/// y_i += α x_i and Σ z_i y_i (the updated y_i) over `len` entries, four
/// accumulators of four lanes; `z` may be `y` itself.
///
/// # Safety
/// AVX2 and FMA must be available; `x` and `z` readable and `y` readable
/// and writable for `len` entries.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn axpy_dot_avx2(alpha: f64, x: *const f64, z: *const f64, y: *mut f64, len: usize) -> f64 {
    use std::arch::x86_64::*;
    // SAFETY: every offset formed is below `len` (the caller's bound); each
    // y entry is read before it is written, and z at an index is read
    // after y's store there (z = y is the updated value).
    unsafe {
        let a = _mm256_set1_pd(alpha);
        let mut acc = [_mm256_setzero_pd(); 4];
        let mut i = 0;
        while i + 16 <= len {
            for (k, s) in acc.iter_mut().enumerate() {
                let at = i + 4 * k;
                let v = _mm256_fmadd_pd(a, _mm256_loadu_pd(x.add(at)), _mm256_loadu_pd(y.add(at)));
                _mm256_storeu_pd(y.add(at), v);
                *s = _mm256_fmadd_pd(_mm256_loadu_pd(z.add(at)), v, *s);
            }
            i += 16;
        }
        while i + 4 <= len {
            let v = _mm256_fmadd_pd(a, _mm256_loadu_pd(x.add(i)), _mm256_loadu_pd(y.add(i)));
            _mm256_storeu_pd(y.add(i), v);
            acc[0] = _mm256_fmadd_pd(_mm256_loadu_pd(z.add(i)), v, acc[0]);
            i += 4;
        }
        let mut total = sum_lanes(acc);
        while i < len {
            let v = alpha.mul_add(*x.add(i), *y.add(i));
            *y.add(i) = v;
            total = (*z.add(i)).mul_add(v, total);
            i += 1;
        }
        total
    }
}

/// The sum of four accumulators of four lanes, in the kernels' one order
/// ((a₀ + a₁) + (a₂ + a₃), then lanes (0 + 2) + (1 + 3)).
///
/// # Safety
/// AVX2 and FMA must be available.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn sum_lanes(acc: [std::arch::x86_64::__m256d; 4]) -> f64 {
    use std::arch::x86_64::*;
    let s = _mm256_add_pd(_mm256_add_pd(acc[0], acc[1]), _mm256_add_pd(acc[2], acc[3]));
    let mut lanes = [0.0; 4];
    // SAFETY: `lanes` holds four doubles.
    unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), s) };
    (lanes[0] + lanes[2]) + (lanes[1] + lanes[3])
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
        let mut total = sum_lanes(acc);
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

    /// R of [first; block] by the fold against the Householder QR of the
    /// stacked matrix, rows up to sign, each column to 1e-13 of its norm.
    fn check(simd: Avx2Fma, first: &DMatrix<f64>, block: &DMatrix<f64>) {
        let (m, n) = block.shape();
        let mut r = crate::qr_r(first).unwrap();
        let mut b = block.clone();
        fold_into_triangle(simd, &mut r, &mut b);
        let k = first.nrows();
        let mut stacked = DMatrix::zeros(k + m, n);
        stacked.rows_mut(0, k).copy_from(first);
        stacked.rows_mut(k, m).copy_from(block);
        let want = crate::qr_r(&stacked).unwrap();
        for i in 0..n {
            let sign = if (r[(i, i)] >= 0.0) == (want[(i, i)] >= 0.0) {
                1.0
            } else {
                -1.0
            };
            for j in 0..n {
                let d = (sign * r[(i, j)] - want[(i, j)]).abs();
                let norm = want.column(j).norm();
                assert!(d <= 1e-13 * norm, "{m}×{n}: R[{i},{j}] off by {d:e}");
            }
        }
    }

    /// The fold's R against the Householder QR of the stacked matrix
    /// (rows up to sign), on blocks with a zero column, scaled extremes,
    /// columns of very different scales (reflections outside the
    /// look-ahead's safe range taken the plain way between look-ahead
    /// ones) and lengths that are no multiple of the vector width.
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
            check(simd, &first, &block);
        }
        let scales = [1.0, 3.0, 1e150, 1.0, 1e-150, 0.5, 1e-3];
        let n = scales.len();
        let first = DMatrix::from_fn(n + 2, n, |_, j| next() * scales[j]);
        let block = DMatrix::from_fn(203, n, |_, j| next() * scales[j]);
        check(simd, &first, &block);
    }
}

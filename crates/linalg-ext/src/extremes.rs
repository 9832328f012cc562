//! The extreme singular values of a square lower-triangular matrix without
//! an SVD: power iteration on L Lᵀ for σ_max and on (L Lᵀ)⁻¹ (two
//! triangular solves per step) for σ_min. O(k²) per iteration, at most
//! [`MAX_ITERATIONS`] iterations each, against O(k³) with a large constant
//! for the singular values (a 160×160 factor: ≈ 0.2 ms against ≈ 2.8 ms).
//!
//! The estimates bound from the safe side of a condition test: the σ_max
//! estimate never exceeds σ_max and the σ_min estimate is never below
//! σ_min, so (σ_min/σ_max) is over-estimated. A caller that must decide
//! "well conditioned" reliably accepts only with a margin and computes the
//! singular values near its threshold ([`ConditionCheck`]).
//!
//! Two certificates decide most tests without iterating at all:
//!
//! * [`triangular_ratio_bound`]: σ_min/σ_max ≥ 1/(‖L⁻¹‖_F ‖L‖_F) from the
//!   explicit inverse (one triangular solve with k right-hand sides,
//!   O(k³/3)); within a factor k of the ratio, so it settles the small
//!   thresholds of rank tests (10⁻¹⁰, k ε) at once;
//! * [`exceeds_min_eigenvalue`]: λ_min(G) > τ for a symmetric G because
//!   the Cholesky factorisation of G − τI succeeds (Sylvester's law of
//!   inertia), O(k³/3); exact up to the backward error O(k ε ‖G‖), so it
//!   settles thresholds on a Gram matrix's condition down to ≈ 10⁻¹⁰
//!   ([`gram_condition_exceeds`]).

use nalgebra::{DMatrix, DVector};

use crate::check::check_finite;
use crate::convert::as_faer;
use crate::{Error, Result};

/// Most iterations of each power iteration.
pub const MAX_ITERATIONS: usize = 60;

/// Relative change of an estimate at which an iteration stops.
const TOLERANCE: f64 = 1e-6;

/// A deterministic start vector with components of both signs and no
/// special direction (so that it is not orthogonal to the extreme singular
/// vectors of structured matrices).
fn start(k: usize) -> DVector<f64> {
    let mut s: u64 = 0x2545_F491_4F6C_DD1D;
    let v = DVector::from_fn(k, |_, _| {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        0.5 + (s >> 11) as f64 / (1u64 << 53) as f64
    });
    let n = v.norm();
    v / n
}

/// Estimates (σ_max, σ_min) of a square lower-triangular `l` (entries above
/// the diagonal are ignored). σ_min is 0 when a diagonal entry is 0.
///
/// Errors: [`Error::NonFinite`], [`Error::DimensionMismatch`] when not square.
pub fn lower_triangular_extremes(l: &DMatrix<f64>) -> Result<(f64, f64)> {
    lower_triangular_extremes_within(l, MAX_ITERATIONS)
}

/// [`lower_triangular_extremes`] with at most `max_iterations` steps of
/// each power iteration (the bounds hold after any number of steps).
///
/// Errors: as [`lower_triangular_extremes`].
pub fn lower_triangular_extremes_within(
    l: &DMatrix<f64>,
    max_iterations: usize,
) -> Result<(f64, f64)> {
    let k = check_square_lower(l)?;
    if k == 0 {
        return Ok((0.0, 0.0));
    }
    // σ_max: v ← Lᵀ L v / ‖·‖, estimate ‖L v‖ (‖v‖ = 1) ≤ σ_max. The
    // products read the lower triangle in place (no k×k copy with the
    // upper part zeroed: half the work, and no fresh pages).
    let mut v = start(k);
    let mut smax = 0.0f64;
    for _ in 0..max_iterations.max(1) {
        let lv = lower_mul(l, &v);
        let est = lv.norm();
        let w = lower_tr_mul(l, &lv);
        let n = w.norm();
        if n == 0.0 {
            break;
        }
        v = w / n;
        let done = (est - smax).abs() <= TOLERANCE * est;
        smax = smax.max(est);
        if done {
            break;
        }
    }
    if (0..k).any(|i| l[(i, i)] == 0.0) {
        return Ok((smax, 0.0));
    }
    // σ_min: x ← L⁻ᵀ L⁻¹ x / ‖·‖, estimate 1/‖L⁻¹ x‖ ≥ σ_min (the solves
    // read only the lower triangle).
    let mut x = start(k);
    let mut inv_max = 0.0f64;
    for _ in 0..max_iterations.max(1) {
        let Some(a) = lower_solve(l, &x) else {
            return Ok((smax, 0.0));
        };
        let est = a.norm();
        let Some(b) = lower_tr_solve(l, &a) else {
            return Ok((smax, 0.0));
        };
        let n = b.norm();
        if !n.is_finite() || !est.is_finite() {
            return Ok((smax, 0.0));
        }
        x = b / n;
        let done = (est - inv_max).abs() <= TOLERANCE * est;
        inv_max = inv_max.max(est);
        if done {
            break;
        }
    }
    Ok((smax, if inv_max > 0.0 { 1.0 / inv_max } else { 0.0 }))
}

/// L v for the lower triangle of the square `l` (column axpys, O(k²/2)).
fn lower_mul(l: &DMatrix<f64>, v: &DVector<f64>) -> DVector<f64> {
    let k = l.nrows();
    let mut y = DVector::zeros(k);
    let ys = y.as_mut_slice();
    for (j, col) in l.as_slice().chunks_exact(k.max(1)).enumerate() {
        let vj = v[j];
        for (yi, lij) in ys[j..].iter_mut().zip(&col[j..]) {
            *yi += lij * vj;
        }
    }
    y
}

/// Four independent sums of products (vectorised), plain products:
/// `kernels::dot`'s fused multiply-adds are library calls outside
/// `simd::dispatch` in the baseline x86-64 build.
fn dot4(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (xa, xb) in ca.zip(cb) {
        for i in 0..4 {
            acc[i] += xa[i] * xb[i];
        }
    }
    (acc[0] + acc[2]) + (acc[1] + acc[3]) + tail
}

/// Lᵀ y for the lower triangle of the square `l` (column dots, O(k²/2)).
fn lower_tr_mul(l: &DMatrix<f64>, y: &DVector<f64>) -> DVector<f64> {
    let k = l.nrows();
    let ys = y.as_slice();
    DVector::from_iterator(
        k,
        l.as_slice()
            .chunks_exact(k.max(1))
            .enumerate()
            .map(|(j, col)| dot4(&col[j..], &ys[j..])),
    )
}

/// L⁻¹ b for the lower triangle of the square `l` by forward substitution
/// over contiguous columns (an axpy per column, O(k²/2)); `None` when a
/// diagonal entry is 0.
fn lower_solve(l: &DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    let k = l.nrows();
    let mut x = b.clone();
    let xs = x.as_mut_slice();
    for (j, col) in l.as_slice().chunks_exact(k.max(1)).enumerate() {
        let d = col[j];
        if d == 0.0 {
            return None;
        }
        xs[j] /= d;
        let (head, rest) = xs.split_at_mut(j + 1);
        let xj = head[j];
        for (xi, lij) in rest.iter_mut().zip(&col[j + 1..]) {
            *xi -= lij * xj;
        }
    }
    Some(x)
}

/// L⁻ᵀ b for the lower triangle of the square `l` by back substitution
/// (a column dot per row of Lᵀ, O(k²/2)); `None` when a diagonal entry is
/// 0.
fn lower_tr_solve(l: &DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    let k = l.nrows();
    let mut x = b.clone();
    let xs = x.as_mut_slice();
    for j in (0..k).rev() {
        let col = &l.as_slice()[j * k..(j + 1) * k];
        let d = col[j];
        if d == 0.0 {
            return None;
        }
        xs[j] = (xs[j] - dot4(&col[j + 1..], &xs[j + 1..])) / d;
    }
    Some(x)
}

/// Checks finiteness and squareness; returns k.
pub(crate) fn check_square_lower(l: &DMatrix<f64>) -> Result<usize> {
    check_finite("l", l)?;
    let k = l.nrows();
    if l.ncols() != k {
        return Err(Error::DimensionMismatch {
            what: "l",
            expected: "a square matrix".into(),
            got: format!("{}x{}", k, l.ncols()),
        });
    }
    Ok(k)
}

/// ‖L⁻¹‖_F of a square lower-triangular `l` (entries above the diagonal
/// ignored) from the explicit inverse, column j of L⁻¹ by forward
/// substitution from row j (its entries above j are zero: k³/3 flops, a
/// contiguous update of L's column per step, vectorised), the squares
/// summed as they come; where the inverse's entries leave the range in
/// which their squares neither overflow nor underflow, the inverse again by
/// faer's triangular solve and the scaled norm; +∞ when a diagonal entry is
/// 0 or the inverse overflows. 1/‖L⁻¹‖_F ≤ σ_min(L) ≤ √k/‖L⁻¹‖_F; the norms of the
/// inverses of leading and trailing diagonal blocks of a triangular L are
/// at most this one (they are blocks of L⁻¹).
///
/// Errors: [`Error::NonFinite`], [`Error::DimensionMismatch`] when not square.
pub fn lower_inverse_frobenius(l: &DMatrix<f64>) -> Result<f64> {
    let k = check_square_lower(l)?;
    if k == 0 {
        return Ok(0.0);
    }
    if (0..k).any(|i| l[(i, i)] == 0.0) {
        return Ok(f64::INFINITY);
    }
    let (sum, amax) = inverse_squares(l.as_slice(), k);
    // Squares exact to rounding: entries within 1e±150.
    if sum.is_finite() && amax < 1e150 && amax > 1e-150 {
        return Ok(sum.sqrt());
    }
    let mut inv = faer::Mat::<f64>::identity(k, k);
    faer::linalg::triangular_solve::solve_lower_triangular_in_place(
        as_faer(l),
        inv.as_mut(),
        faer::Par::Seq,
    );
    let norm = inv.norm_l2();
    Ok(if norm.is_finite() {
        norm
    } else {
        f64::INFINITY
    })
}

/// The sum of squares and the largest magnitude of the entries of L⁻¹ for
/// the column-major k×k lower-triangular `l` (its upper triangle not
/// read): column j of L⁻¹ solves L x = e_j with x's first j entries zero,
/// by column-oriented forward substitution (x_p /= L_pp, then
/// x_{p+1..} −= x_p L_{p+1.., p}, a contiguous axpy). Σ_j (k − j)² ≈ k³/3
/// flops, O(k) scratch; plain products (no FMA), so every machine rounds
/// alike.
fn inverse_squares(l: &[f64], k: usize) -> (f64, f64) {
    let mut x = vec![0.0; k];
    crate::simd::dispatch(
        #[inline(always)]
        || {
            let (mut sum, mut amax) = (0.0f64, 0.0f64);
            for j in 0..k {
                let x = &mut x[j..];
                x.fill(0.0);
                x[0] = 1.0;
                for p in 0..k - j {
                    let c = (j + p) * k;
                    let xp = x[p] / l[c + j + p];
                    x[p] = xp;
                    sum += xp * xp;
                    amax = amax.max(xp.abs());
                    let col = &l[c + j + p + 1..c + k];
                    for (xi, li) in x[p + 1..].iter_mut().zip(col) {
                        *xi -= xp * li;
                    }
                }
            }
            (sum, amax)
        },
    )
}

/// A certified lower bound 1/(‖L⁻¹‖_F ‖L‖_F) ≤ σ_min/σ_max of a square
/// lower-triangular `l` (entries above the diagonal ignored), from the
/// explicit inverse ([`lower_inverse_frobenius`], O(k³/3)); it is at most
/// a factor k below the ratio. 0 when a diagonal entry is 0 or the inverse
/// overflows.
///
/// Errors: [`Error::NonFinite`], [`Error::DimensionMismatch`] when not square.
pub fn triangular_ratio_bound(l: &DMatrix<f64>) -> Result<f64> {
    let inv_norm = lower_inverse_frobenius(l)?;
    Ok(ratio_bound(inv_norm, l.lower_triangle().norm()))
}

/// The certified bound 1/(‖L⁻¹‖_F ‖L‖_F) ≤ σ_min/σ_max of
/// [`triangular_ratio_bound`] from the two norms (an upper bound of
/// ‖L⁻¹‖_F is as good), halved for the rounding in the inverse; 0 when
/// either norm is not finite and positive.
pub fn ratio_bound(inverse_norm: f64, norm: f64) -> f64 {
    let bound = 1.0 / (inverse_norm * norm);
    // Rounding in the inverse is far below the factor of 2 given away.
    if bound.is_finite() && bound > 0.0 {
        0.5 * bound
    } else {
        0.0
    }
}

/// Whether λ_min(G) > τ for a symmetric `g` (lower triangle used): true
/// when the Cholesky factorisation of G − τI succeeds (Sylvester's law of
/// inertia). Exact up to the backward error of the factorisation,
/// O(k ε ‖G‖): meaningful for τ well above that. O(k³/3).
///
/// Errors: [`Error::NonFinite`], [`Error::DimensionMismatch`] when not square.
pub fn exceeds_min_eigenvalue(g: &DMatrix<f64>, tau: f64) -> Result<bool> {
    let k = check_square_lower(g)?;
    Ok(k == 0 || crate::cholesky_lower(shifted_diagonal(g.clone(), -tau)).is_some())
}

/// `m` + `shift`·I in place (one copy of the caller's matrix, no identity).
fn shifted_diagonal(mut m: DMatrix<f64>, shift: f64) -> DMatrix<f64> {
    for i in 0..m.nrows().min(m.ncols()) {
        m[(i, i)] += shift;
    }
    m
}

/// ‖G‖∞ of the symmetric matrix whose lower triangle `g` holds (the
/// largest row sum of |G|, an upper bound of λ_max). O(k²).
pub(crate) fn lower_row_sums_max(g: &DMatrix<f64>) -> f64 {
    let k = g.nrows();
    // Row i is G[i, ..=i] then G[i+1.., i] (column i below the diagonal):
    // column j adds its part below the diagonal to rows j+1.. (a
    // contiguous, vectorised update) and its whole sum to row j.
    let mut sums = vec![0.0f64; k];
    for j in 0..k {
        let col = &g.as_slice()[j * k + j..(j + 1) * k];
        let mut below = 0.0;
        for (s, v) in sums[j + 1..].iter_mut().zip(&col[1..]) {
            let a = v.abs();
            *s += a;
            below += a;
        }
        sums[j] += col[0].abs() + below;
    }
    sums.iter().cloned().fold(0.0, f64::max)
}

/// Whether λ_min(G)/λ_max(G) > threshold for a symmetric positive
/// semi-definite `g` (lower triangle used), proven by Cholesky
/// factorisations: λ_min > threshold · ‖G‖∞ (the row-sum bound of λ_max),
/// else λ_max < λ₊ for λ₊ = 1.05 × a power-iteration estimate and
/// λ_min > threshold · λ₊. A false answer only says "not proven" (the
/// ratio may be up to 1.05 times above the threshold); a caller decides
/// those cases exactly. O(k³/3) per factorisation. Meaningful for
/// thresholds above ≈ 100 k ε.
///
/// Errors: as [`exceeds_min_eigenvalue`].
pub fn gram_condition_exceeds(g: &DMatrix<f64>, threshold: f64) -> Result<bool> {
    let k = check_square_lower(g)?;
    if k == 0 {
        return Ok(true);
    }
    let row_sums = lower_row_sums_max(g);
    if row_sums.is_nan() || row_sums <= 0.0 {
        return Ok(false);
    }
    if exceeds_min_eigenvalue(g, threshold * row_sums)? {
        return Ok(true);
    }
    power_certificate(g, threshold, row_sums)
}

/// The second certificate of [`gram_condition_exceeds`], for when the
/// row-sum bound `row_sums` (‖G‖∞, finite and positive) of λ_max was too
/// loose: λ_max < λ₊ = 1.05 × a power-iteration estimate, proven by a
/// Cholesky factorisation of λ₊I − G, then λ_min > threshold · λ₊ by one of
/// G − threshold·λ₊ I. `g` square, finite, lower triangle used.
pub(crate) fn power_certificate(g: &DMatrix<f64>, threshold: f64, row_sums: f64) -> Result<bool> {
    let k = g.nrows();
    // The symmetric matrix of the lower triangle, in one copy.
    let mut sym = g.clone();
    for j in 0..k {
        for i in j + 1..k {
            sym[(j, i)] = sym[(i, j)];
        }
    }
    let mut v = start(k);
    let mut lam = 0.0f64;
    for _ in 0..30 {
        let w = &sym * &v;
        let est = v.dot(&w);
        let n = w.norm();
        if n == 0.0 {
            break;
        }
        v = w / n;
        let done = (est - lam).abs() <= 1e-3 * est;
        lam = lam.max(est);
        if done {
            break;
        }
    }
    let upper = 1.05 * lam;
    if upper.is_nan()
        || upper <= 0.0
        || upper >= row_sums
        || crate::cholesky_lower(shifted_diagonal(-&sym, upper)).is_none()
    {
        return Ok(false);
    }
    exceeds_min_eigenvalue(&sym, threshold * upper)
}

/// A condition test "σ_min/σ_max > threshold" on a lower-triangular factor
/// that is exact where it matters: decided by the certified lower bound of
/// [`triangular_ratio_bound`] when it clears the threshold, else by the
/// O(k²) estimates when they are clear of the threshold by `margin`, else
/// by the singular values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConditionCheck {
    /// σ_min/σ_max: a proven lower bound when `certified`, an estimate
    /// (at or above the ratio) when neither `certified` nor `exact`.
    pub ratio: f64,
    /// Whether the ratio comes from the singular values.
    pub exact: bool,
    /// Whether `ratio` is the certified lower bound.
    pub certified: bool,
}

/// σ_min/σ_max of a lower-triangular factor: the certified lower bound of
/// [`triangular_ratio_bound`] when it is above `threshold` (O(k³/3), no
/// iteration), else the estimates when the estimated ratio is above
/// `threshold · margin` (the estimate can only over-state the ratio, and
/// it converges to it: a margin of 10 leaves room for a start vector
/// poorly aligned with the smallest direction), else the singular values
/// (exact decision near the threshold).
///
/// Errors: as [`lower_triangular_extremes`] and [`crate::singular_values`].
pub fn triangular_condition(
    l: &DMatrix<f64>,
    threshold: f64,
    margin: f64,
) -> Result<ConditionCheck> {
    let bound = triangular_ratio_bound(l)?;
    if bound > threshold {
        return Ok(ConditionCheck {
            ratio: bound,
            exact: false,
            certified: true,
        });
    }
    let (smax, smin) = lower_triangular_extremes(l)?;
    let ratio = if smax > 0.0 { smin / smax } else { 0.0 };
    if ratio.is_finite() && ratio > threshold * margin {
        return Ok(ConditionCheck {
            ratio,
            exact: false,
            certified: false,
        });
    }
    let s = crate::singular_values(&l.lower_triangle())?;
    let hi = s.iter().cloned().fold(0.0, f64::max);
    let lo = s.iter().cloned().fold(f64::INFINITY, f64::min);
    Ok(ConditionCheck {
        ratio: if hi > 0.0 { lo / hi } else { 0.0 },
        exact: true,
        certified: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lower(k: usize, seed: u64, diag: f64) -> DMatrix<f64> {
        let mut s = seed | 1;
        DMatrix::from_fn(k, k, |i, j| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let r = (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            if i > j {
                r
            } else if i == j {
                diag + r.abs()
            } else {
                0.0
            }
        })
    }

    #[test]
    fn row_sums_of_the_symmetric_matrix_from_its_lower_triangle() {
        let k = 9;
        let g = lower(k, 11, 2.0);
        let sym = g.lower_triangle() + g.lower_triangle().transpose()
            - DMatrix::from_diagonal(&g.diagonal());
        let naive = (0..k)
            .map(|i| sym.row(i).iter().map(|v| v.abs()).sum::<f64>())
            .fold(0.0, f64::max);
        assert!((lower_row_sums_max(&g) - naive).abs() <= 1e-13 * naive);
    }

    /// The forward-substitution norm against the explicit inverse by
    /// nalgebra (upper triangle filled with garbage: not read), at unit
    /// scale and at scales whose squares overflow or underflow (the faer
    /// route), and +∞ for a zero pivot.
    #[test]
    fn the_inverse_norm_is_that_of_the_explicit_inverse() {
        for (k, seed) in [(1, 1), (2, 5), (7, 2), (80, 3), (160, 4)] {
            for scale in [1.0, 1e-170, 1e170, 1e-300] {
                let l = lower(k, seed, 1.0) * scale;
                let mut messy = l.clone();
                for j in 1..k {
                    messy[(0, j)] = 1e300;
                }
                let unit = lower(k, seed, 1.0);
                let exact = unit.try_inverse().unwrap().norm() / scale;
                let got = lower_inverse_frobenius(&messy).unwrap();
                if exact.is_finite() {
                    assert!(
                        (got - exact).abs() <= 1e-12 * exact,
                        "k {k} scale {scale:e}: {got:e} vs {exact:e}"
                    );
                } else {
                    assert_eq!(got, f64::INFINITY, "k {k} scale {scale:e}");
                }
            }
        }
        let mut l = lower(5, 7, 1.0);
        l[(3, 3)] = 0.0;
        assert_eq!(lower_inverse_frobenius(&l).unwrap(), f64::INFINITY);
    }

    #[test]
    fn estimates_bound_and_approach_the_singular_values() {
        for (k, seed) in [(1, 1), (5, 2), (40, 3), (160, 4)] {
            let l = lower(k, seed, 1.0);
            let s = crate::singular_values(&l).unwrap();
            let (hi, lo) = (s[0], s[k - 1]);
            let (eh, el) = lower_triangular_extremes(&l).unwrap();
            assert!(
                eh <= hi * (1.0 + 1e-12) && eh >= hi * 0.999,
                "{k}: {eh} vs {hi}"
            );
            assert!(
                el >= lo * (1.0 - 1e-12) && el <= lo * 1.01,
                "{k}: {el} vs {lo}"
            );
        }
    }

    #[test]
    fn near_singular_factors_are_decided_by_the_singular_values() {
        let mut l = lower(30, 9, 1.0);
        l[(29, 29)] = 1e-12;
        let c = triangular_condition(&l, 1e-8, 10.0).unwrap();
        assert!(c.exact && c.ratio < 1e-8, "{c:?}");
        l[(29, 29)] = 0.0;
        assert_eq!(lower_triangular_extremes(&l).unwrap().1, 0.0);
        let good = lower(30, 9, 1.0);
        let c = triangular_condition(&good, 1e-8, 10.0).unwrap();
        assert!(!c.exact && c.certified && c.ratio > 1e-8, "{c:?}");
        // Above the certified bound, the estimates decide (no SVD).
        let s = crate::singular_values(&good).unwrap();
        let c = triangular_condition(
            &good,
            0.9 * triangular_ratio_bound(&good)
                .unwrap()
                .max(s[29] / s[0] / 100.0),
            1.0,
        )
        .unwrap();
        assert!(!c.exact, "{c:?}");
    }

    #[test]
    fn certificates_hold_and_are_reasonably_tight() {
        for (k, seed) in [(1, 1), (5, 2), (40, 3), (160, 4)] {
            let l = lower(k, seed, 1.0);
            let s = crate::singular_values(&l).unwrap();
            let ratio = s[k - 1] / s[0];
            let b = triangular_ratio_bound(&l).unwrap();
            assert!(
                b <= ratio && b >= ratio / (2.0 * k as f64),
                "{k}: {b} vs {ratio}"
            );
            let g = &l * l.transpose();
            let (lmin, lmax) = (s[k - 1] * s[k - 1], s[0] * s[0]);
            assert!(exceeds_min_eigenvalue(&g, 0.99 * lmin).unwrap());
            assert!(!exceeds_min_eigenvalue(&g, 1.01 * lmin).unwrap());
            assert!(gram_condition_exceeds(&g, 0.5 * lmin / lmax).unwrap());
            assert!(!gram_condition_exceeds(&g, 1.01 * lmin / lmax).unwrap());
        }
        let mut l = lower(30, 9, 1.0);
        l[(29, 29)] = 0.0;
        assert_eq!(triangular_ratio_bound(&l).unwrap(), 0.0);
        let c = triangular_condition(&lower(30, 9, 1.0), 1e-8, 10.0).unwrap();
        assert!(c.certified && !c.exact && c.ratio > 1e-8, "{c:?}");
    }

    #[test]
    fn bad_input_is_named() {
        let mut l = lower(3, 1, 1.0);
        l[(1, 0)] = f64::NAN;
        assert!(lower_triangular_extremes(&l).is_err());
        assert!(lower_triangular_extremes(&DMatrix::zeros(2, 3)).is_err());
    }

    #[test]
    fn the_triangular_solves_invert_the_products() {
        // Entries above the diagonal are ignored; a zero pivot is refused.
        for k in [1, 3, 4, 9, 40] {
            let l = DMatrix::from_fn(k, k, |i, j| {
                if i == j {
                    2.0 + (i as f64).sin()
                } else {
                    (0.3 * (i * k + j) as f64).cos()
                }
            });
            let lower = l.lower_triangle();
            let b = DVector::from_fn(k, |i, _| 1.0 - 0.1 * i as f64);
            let x = super::lower_solve(&l, &b).unwrap();
            assert!((&lower * &x - &b).amax() < 1e-12, "k = {k}");
            let y = super::lower_tr_solve(&l, &b).unwrap();
            assert!((lower.transpose() * &y - &b).amax() < 1e-12, "k = {k}");
            assert!((super::lower_tr_mul(&l, &b) - lower.transpose() * &b).amax() < 1e-12);
            let mut singular = l.clone();
            singular[(k - 1, k - 1)] = 0.0;
            assert!(super::lower_solve(&singular, &b).is_none());
            assert!(super::lower_tr_solve(&singular, &b).is_none());
        }
    }
}

//! Time-delay estimation from multirate data (thesis §4.4, errata L-8, L-10).
//!
//! 1. Lifted impulse response by correlation (§4.4 steps 1–3):
//!    p̲(i) = R_yu(i) R_uu(0)⁻¹ with R_yu(i) = (1/(N−i)) Σ y̲(k+i) u̲(k)ᵀ
//!    (a white lifted input makes R_uu(i) = 0 for i ≠ 0). O(N L n̲_y n̲_u).
//! 2. Delay matrix l_ij: the first lag whose coefficient exceeds a threshold
//!    (k standard errors of the estimate, or an absolute tolerance for exact
//!    models).
//! 3. With T_ij = d_c + jm − in and (l_ij−1)mn ≤ T_ij < l_ij·mn (strictly
//!    proper plant, half-open per erratum L-8), the mn inequalities (4.14)
//!    give (l_ij−1)mn + in − jm ≤ d_c < l_ij·mn + in − jm; for co-prime m, n
//!    their intersection is [d_d, d_d + 1) (the Claim of §4.4).
//! 4. Shift (§4.7 step 2, L-10): d_d = k₁m + k₂n; the input is delayed k₁
//!    hold periods, u'(i) = u(i − k₁), and the output advanced k₂ samples,
//!    y'(j) = y(j + k₂), leaving a residual delay in [0, 1).

use lifted_linalg::solve;
use lifted_lti::{Dataset, StateSpace};
use nalgebra::DMatrix;

use crate::error::{Error, Result, check_finite};
use crate::lifting::SisoRates;

/// Lifted impulse-response estimate with standard errors.
#[derive(Debug, Clone, PartialEq)]
pub struct ImpulseEstimate {
    /// p̲(0) … p̲(L−1), each n̲_y×n̲_u.
    pub coefficients: Vec<DMatrix<f64>>,
    /// Approximate standard error of each entry,
    /// σ_{y,i}·√((R_uu⁻¹)_jj / N) (white input, noise dominated).
    pub std_error: DMatrix<f64>,
}

/// Lifted impulse response by correlation analysis (§4.4): `ul` K×n̲_u,
/// `yl` K×n̲_y, `lags` coefficients. Means are removed first.
///
/// Errors: shapes, non-finite data, K < lags + n̲_u
/// ([`Error::TooShort`]), singular R_uu(0).
pub fn lifted_impulse_response(
    ul: &DMatrix<f64>,
    yl: &DMatrix<f64>,
    lags: usize,
) -> Result<ImpulseEstimate> {
    check_finite("lifted u", ul)?;
    check_finite("lifted y", yl)?;
    let k = ul.nrows();
    if yl.nrows() != k {
        return Err(Error::DimensionMismatch {
            what: "lifted y rows",
            expected: format!("{k}"),
            got: format!("{}", yl.nrows()),
        });
    }
    if lags == 0 || k < lags + ul.ncols() + 2 {
        return Err(Error::TooShort {
            what: "impulse-response estimation",
            got: k,
            needed: lags + ul.ncols() + 2,
        });
    }
    let center = |m: &DMatrix<f64>| {
        let mut c = m.clone();
        for mut col in c.column_iter_mut() {
            let mean = col.mean();
            col.add_scalar_mut(-mean);
        }
        c
    };
    let u = center(ul);
    let y = center(yl);
    let ruu = u.transpose() * &u / k as f64;
    let ruu_inv = lifted_linalg::inv(&ruu)?;
    let mut coefficients = Vec::with_capacity(lags);
    for i in 0..lags {
        let len = k - i;
        let ryu = y.rows(i, len).transpose() * u.rows(0, len) / len as f64;
        // p = R_yu R_uu⁻¹  ⇔  R_uu pᵀ = R_yuᵀ
        let pt = solve(&ruu, &ryu.transpose())?;
        coefficients.push(pt.transpose());
    }
    let std_error = DMatrix::from_fn(y.ncols(), u.ncols(), |i, j| {
        let var_y = y.column(i).norm_squared() / k as f64;
        (var_y * ruu_inv[(j, j)].max(0.0) / k as f64).sqrt()
    });
    Ok(ImpulseEstimate {
        coefficients,
        std_error,
    })
}

/// Lifted impulse response by joint least squares over all `lags` (an FIR
/// regression y̲(k) = Σ_{i<L} p̲(i) u̲(k−i) + e, means removed), with
/// standard errors from the residual: σ_e,o √((ΦᵀΦ)⁻¹)_cc. Unlike the
/// correlation estimate of [`lifted_impulse_response`] the other lags and
/// inputs do not act as noise, so a small first coefficient of a slow plant
/// stands out. O(K (L n̲_u)² + (L n̲_u)³) by one QR (`lifted_linalg::lstsq`).
///
/// Errors: shapes, non-finite data, too few lifted samples for the
/// regression ([`Error::TooShort`]), a rank-deficient regressor.
pub fn lifted_fir_estimate(
    ul: &DMatrix<f64>,
    yl: &DMatrix<f64>,
    lags: usize,
) -> Result<ImpulseEstimate> {
    check_finite("lifted u", ul)?;
    check_finite("lifted y", yl)?;
    let (k, nu) = ul.shape();
    if yl.nrows() != k {
        return Err(Error::DimensionMismatch {
            what: "lifted y rows",
            expected: format!("{k}"),
            got: format!("{}", yl.nrows()),
        });
    }
    let width = lags * nu;
    if lags == 0 || k < lags + width + 2 {
        return Err(Error::TooShort {
            what: "FIR impulse-response estimation",
            got: k,
            needed: lags + width + 2,
        });
    }
    let rows = k - (lags - 1);
    let mean = |m: &DMatrix<f64>, c: usize| m.column(c).mean();
    let mut phi = DMatrix::zeros(rows, width);
    for r in 0..rows {
        let t = r + lags - 1;
        for i in 0..lags {
            for c in 0..nu {
                phi[(r, i * nu + c)] = ul[(t - i, c)] - mean(ul, c);
            }
        }
    }
    let ny = yl.ncols();
    let y = DMatrix::from_fn(rows, ny, |r, o| yl[(r + lags - 1, o)] - mean(yl, o));
    let theta = lifted_linalg::lstsq(&phi, &y)?;
    let resid = &y - &phi * &theta;
    let gram_inv = lifted_linalg::inv(&(phi.transpose() * &phi))?;
    let dof = (rows - width).max(1) as f64;
    let coefficients = (0..lags)
        .map(|i| DMatrix::from_fn(ny, nu, |o, c| theta[(i * nu + c, o)]))
        .collect();
    // The first lag's standard errors (the others differ only through the
    // diagonal of (ΦᵀΦ)⁻¹, nearly equal for a white input).
    let std_error = DMatrix::from_fn(ny, nu, |o, c| {
        let var_e = resid.column(o).norm_squared() / dof;
        (var_e * gram_inv[(c, c)].max(0.0)).sqrt()
    });
    Ok(ImpulseEstimate {
        coefficients,
        std_error,
    })
}

/// Delay matrix l_ij from an estimate: the first lag with
/// |p̲_ij(l)| > `sigmas`·(standard error) (the reference uses 3σ).
/// Errors: [`Error::NoDelayDetected`] when no lag qualifies.
pub fn delay_matrix(est: &ImpulseEstimate, sigmas: f64) -> Result<DMatrix<usize>> {
    let first = est.coefficients.first().ok_or(Error::TooShort {
        what: "impulse response",
        got: 0,
        needed: 1,
    })?;
    let (ny, nu) = first.shape();
    let mut l = DMatrix::zeros(ny, nu);
    for i in 0..ny {
        for j in 0..nu {
            let thr = sigmas * est.std_error[(i, j)];
            let lag = est
                .coefficients
                .iter()
                .position(|p| p[(i, j)].abs() > thr)
                .ok_or(Error::NoDelayDetected {
                    input: j,
                    output: i,
                    lags: est.coefficients.len(),
                })?;
            l[(i, j)] = lag;
        }
    }
    Ok(l)
}

/// Exact delay matrix of a lifted model: the first Markov parameter index
/// (H₀ = D̄) with |entry| > `tol`, searching `lags` parameters.
pub fn delay_matrix_exact(lifted: &StateSpace, lags: usize, tol: f64) -> Result<DMatrix<usize>> {
    let h = lifted.markov_parameters(lags)?;
    let (ny, nu) = (lifted.n_outputs(), lifted.n_inputs());
    let mut l = DMatrix::zeros(ny, nu);
    for i in 0..ny {
        for j in 0..nu {
            l[(i, j)] =
                h.iter()
                    .position(|p| p[(i, j)].abs() > tol)
                    .ok_or(Error::NoDelayDetected {
                        input: j,
                        output: i,
                        lags,
                    })?;
        }
    }
    Ok(l)
}

/// A delay interval d_c ∈ [lower, upper) in base periods (half-open,
/// erratum L-8).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct DelayInterval {
    /// max of the lower limits (= d_d, the integer delay to shift by).
    pub lower: i64,
    /// min of the upper limits.
    pub upper: i64,
}

impl DelayInterval {
    /// upper − lower (1 for co-prime m, n).
    pub fn width(&self) -> i64 {
        self.upper - self.lower
    }

    /// Whether d_c lies in [lower, upper).
    pub fn contains(&self, dc: f64) -> bool {
        dc >= self.lower as f64 && dc < self.upper as f64
    }
}

/// The per-entry bounds of (4.14), half-open: for entry (i, j),
/// ((l_ij−1)mn + in − jm, l_ij·mn + in − jm).
pub fn delay_bounds(l: &DMatrix<usize>, rates: SisoRates) -> Result<DMatrix<(i64, i64)>> {
    let (m, n) = (rates.m as i64, rates.n as i64);
    if l.shape() != (rates.m, rates.n) {
        return Err(Error::DimensionMismatch {
            what: "delay matrix",
            expected: format!("{}x{}", rates.m, rates.n),
            got: format!("{}x{}", l.nrows(), l.ncols()),
        });
    }
    Ok(DMatrix::from_fn(rates.m, rates.n, |i, j| {
        let lij = l[(i, j)] as i64;
        let off = i as i64 * n - j as i64 * m;
        ((lij - 1) * m * n + off, lij * m * n + off)
    }))
}

/// Intersection of the mn inequalities (4.14) (half-open, L-8).
/// Errors: [`Error::DelayInconsistent`] when empty (noisy l_ij).
pub fn delay_interval(l: &DMatrix<usize>, rates: SisoRates) -> Result<DelayInterval> {
    let b = delay_bounds(l, rates)?;
    let lower = b.iter().map(|x| x.0).max().unwrap_or(0);
    let upper = b.iter().map(|x| x.1).min().unwrap_or(0);
    if lower >= upper {
        return Err(Error::DelayInconsistent { lower, upper });
    }
    Ok(DelayInterval { lower, upper })
}

/// Splits d_d = k₁m + k₂n (co-prime m, n) with 0 ≤ k₁ < n; k₂ may be
/// negative (erratum L-10: shift the other way).
pub fn shift_split(dd: i64, rates: SisoRates) -> (i64, i64) {
    let (m, n) = (rates.m as i64, rates.n as i64);
    for k1 in 0..n {
        if (dd - k1 * m).rem_euclid(n) == 0 {
            return (k1, (dd - k1 * m) / n);
        }
    }
    // unreachable for co-prime rates; fall back to a pure output shift
    (0, dd / n)
}

/// Applies the shift of §4.7 step 2 (L-10) to a SISO multirate data set
/// with hold m and period n (phases 0): u'(t) = u(t − k₁m) and
/// y'(t) = y(t + k₂n) on the fast grid, keeping the instants where both are
/// defined, starting at a multiple of the frame mn so that the sampling
/// pattern is unchanged. Returns the shifted data set.
///
/// Errors: a data set that is not SISO with these rates, a record too short
/// for the shift.
pub fn shift_dataset(data: &Dataset, rates: SisoRates, k1: i64, k2: i64) -> Result<Dataset> {
    if data.n_inputs() != 1
        || data.n_outputs() != 1
        || data.inputs()[0].hold != rates.m
        || data.outputs()[0].period != rates.n
        || data.inputs()[0].offset != 0
        || data.outputs()[0].offset != 0
    {
        return Err(Error::Unsupported {
            what: "shift_dataset",
            reason: format!(
                "SISO data with hold {} and output period {} at phase 0 expected",
                rates.m, rates.n
            ),
        });
    }
    let a = k1 * rates.m as i64; // input delay
    let b = k2 * rates.n as i64; // output advance
    let len = data.len() as i64;
    let frame = rates.period() as i64;
    // t valid iff 0 ≤ t − a < len and 0 ≤ t + b < len
    let lo = 0i64.max(a).max(-b);
    let hi = len.min(len + a).min(len - b);
    let t0 = (lo + frame - 1).div_euclid(frame) * frame;
    if hi - t0 < frame {
        return Err(Error::TooShort {
            what: "record after the delay shift",
            got: data.len(),
            needed: (t0 + frame - hi + len).max(0) as usize,
        });
    }
    let rows = (hi - t0) as usize;
    let u = DMatrix::from_fn(rows, 1, |r, _| data.u()[((t0 + r as i64 - a) as usize, 0)]);
    let y = DMatrix::from_fn(rows, 1, |r, _| data.y()[((t0 + r as i64 + b) as usize, 0)]);
    Ok(Dataset::new(
        data.ts(),
        u,
        y,
        data.inputs().to_vec(),
        data.outputs().to_vec(),
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thesis_example_interval() {
        let l = DMatrix::from_row_slice(2, 3, &[2usize, 2, 3, 1, 2, 2]);
        let r = SisoRates::new(2, 3).unwrap();
        let iv = delay_interval(&l, r).unwrap();
        assert_eq!((iv.lower, iv.upper), (8, 9));
        let b = delay_bounds(&l, r).unwrap();
        assert_eq!(b[(0, 0)], (6, 12));
        assert_eq!(b[(1, 0)], (3, 9));
    }

    #[test]
    fn split() {
        let r = SisoRates::new(2, 3).unwrap();
        assert_eq!(shift_split(5, r), (1, 1));
        let (k1, k2) = shift_split(1, r);
        assert_eq!(k1 * 2 + k2 * 3, 1);
        let r = SisoRates::new(3, 4).unwrap();
        for dd in 0..30 {
            let (k1, k2) = shift_split(dd, r);
            assert_eq!(k1 * 3 + k2 * 4, dd);
        }
    }
}

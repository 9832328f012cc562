//! Canonical correlation analysis of two multivariate data sets.
//!
//! With x (p×N) and y (q×N), one observation per COLUMN (variables in
//! rows, like the block-Hankel data matrices of the subspace methods), the
//! thin QR factorisations xᵀ = Q_x R_x and yᵀ = Q_y R_y give
//! Σ_xx = R_xᵀR_x/N, Σ_yy = R_yᵀR_y/N, Σ_xy = R_xᵀQ_xᵀQ_yR_y/N, so the
//! canonical correlations are the singular values of Q_xᵀQ_y = U S Vᵀ
//! (the SVD of Σ_xx^{-1/2} Σ_xy Σ_yy^{-1/2}) and the weights are
//! A = √N·R_x⁻¹U, B = √N·R_y⁻¹V. x xᵀ is never formed, so the squared
//! condition number is avoided. Cost O(N(p² + q²) + pq·N + min(p,q)·pq).
//!
//! **No mean removal**: the covariances are the raw second moments
//! (1/N)·x xᵀ. Call [`center_rows`] first for the classical (centred) CCA.

use nalgebra::{DMatrix, DVector};

use crate::check::{check_cols, check_finite};
use crate::qr::qr_thin;
use crate::rank::RankTolerance;
use crate::svd::{singular_values, svd};
use crate::{Error, Result};

/// Canonical correlations and weights.
#[derive(Debug, Clone, PartialEq)]
pub struct Cca {
    /// Canonical correlations ρ₁ ≥ ρ₂ ≥ … ≥ ρ_k ≥ 0, k = min(p, q), each ≤ 1.
    pub correlations: DVector<f64>,
    /// x weights A (p×k): the canonical variates Aᵀx have unit sample
    /// second moment, (1/N)·Aᵀ x xᵀ A = I.
    pub x_weights: DMatrix<f64>,
    /// y weights B (q×k), (1/N)·Bᵀ y yᵀ B = I and (1/N)·Aᵀ x yᵀ B = diag(ρ).
    pub y_weights: DMatrix<f64>,
}

/// Subtracts each row's mean (variables in rows, observations in columns),
/// O(pN).
///
/// Errors: [`Error::NonFinite`], [`Error::Empty`] when there are no columns.
pub fn center_rows(m: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    check_finite("m", m)?;
    if m.ncols() == 0 {
        return Err(Error::Empty { what: "m" });
    }
    let mut out = m.clone();
    for mut row in out.row_iter_mut() {
        let mean = row.mean();
        row.add_scalar_mut(-mean);
    }
    Ok(out)
}

/// Factors dᵀ = Q R and checks full column rank p of dᵀ.
fn orth(what: &'static str, d: &DMatrix<f64>) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    let f = qr_thin(&d.transpose())?;
    let s = singular_values(&f.r)?;
    let p = d.nrows();
    let tol = RankTolerance::Default.threshold(d.ncols(), p, s.get(0).copied().unwrap_or(0.0))?;
    let r = s.iter().filter(|&&v| v > tol).count();
    if r < p || s.get(0).copied().unwrap_or(0.0) == 0.0 {
        return Err(Error::RankDeficient {
            what,
            rank: r,
            needed: p,
        });
    }
    Ok((f.q, f.r))
}

/// Canonical correlation analysis of x (p×N) and y (q×N), observations in
/// columns, without mean removal (see the module docs; QR + SVD, never
/// x xᵀ).
///
/// Errors: [`Error::DimensionMismatch`] when x and y have different N,
/// [`Error::NonFinite`], [`Error::Empty`] for p = 0 or q = 0,
/// [`Error::NotEnoughData`] when N < p + q, [`Error::RankDeficient`] when x
/// or y does not have full row rank.
pub fn cca(x: &DMatrix<f64>, y: &DMatrix<f64>) -> Result<Cca> {
    check_finite("x", x)?;
    let (p, n) = x.shape();
    check_cols("y", y, n)?;
    check_finite("y", y)?;
    let q = y.nrows();
    if p == 0 {
        return Err(Error::Empty { what: "x" });
    }
    if q == 0 {
        return Err(Error::Empty { what: "y" });
    }
    if n < p + q {
        return Err(Error::NotEnoughData {
            what: "cca",
            got: n,
            needed: p + q,
        });
    }
    let (qx, rx) = orth("x", x)?;
    let (qy, ry) = orth("y", y)?;
    let f = svd(&(qx.transpose() * qy))?;
    let sqrt_n = (n as f64).sqrt();
    let k = p.min(q);
    let a = rx
        .solve_upper_triangular(&(f.u.columns(0, k) * sqrt_n))
        .ok_or(Error::RankDeficient {
            what: "x",
            rank: 0,
            needed: p,
        })?;
    let b = ry
        .solve_upper_triangular(&(f.v.columns(0, k) * sqrt_n))
        .ok_or(Error::RankDeficient {
            what: "y",
            rank: 0,
            needed: q,
        })?;
    Ok(Cca {
        correlations: f.s.map(|v| v.clamp(0.0, 1.0)),
        x_weights: a,
        y_weights: b,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn identical_sets_correlate_perfectly() {
        let x = DMatrix::from_fn(2, 20, |i, j| {
            ((i + 1) * j % 7) as f64 - 3.0 + i as f64 * 0.1
        });
        let c = cca(&x, &x).unwrap();
        assert_relative_eq!(
            c.correlations,
            DVector::from_vec(vec![1.0, 1.0]),
            epsilon = 1e-12
        );
    }

    #[test]
    fn centering() {
        let m = DMatrix::from_row_slice(2, 3, &[1.0, 2.0, 3.0, 10.0, 10.0, 10.0]);
        let c = center_rows(&m).unwrap();
        assert_relative_eq!(
            c,
            DMatrix::from_row_slice(2, 3, &[-1.0, 0.0, 1.0, 0.0, 0.0, 0.0])
        );
        assert!(matches!(
            center_rows(&DMatrix::zeros(2, 0)),
            Err(Error::Empty { .. })
        ));
    }
}

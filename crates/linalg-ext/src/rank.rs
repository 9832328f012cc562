//! Rank-revealing kernels from the SVD: numerical rank, pseudo-inverse,
//! orthonormal null-space and range bases.
//!
//! All of them threshold the singular values σ₁ ≥ … ≥ σ_k of the m×n matrix
//! A with a [`RankTolerance`]: σᵢ counts (is "nonzero") iff σᵢ > tol.
//! Cost: one SVD, O(mn·min(m,n)); [`null_space`] first reduces a tall A to
//! its n×n R factor (O(mn²)) and then takes the full SVD of R (O(n³)).

use nalgebra::{DMatrix, DVector};

use crate::check::check_finite;
use crate::qr::qr_r;
use crate::svd::{svd, svd_full};
use crate::{Error, Result};

/// Threshold for deciding which singular values are zero.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum RankTolerance {
    /// tol = max(m, n)·ε·σ_max (the rule of MATLAB `rank`, NumPy
    /// `matrix_rank` and LAPACK-based `pinv`).
    #[default]
    Default,
    /// tol = the given absolute value (≥ 0).
    Absolute(f64),
    /// tol = the given value (≥ 0) times σ_max.
    Relative(f64),
}

impl RankTolerance {
    /// The absolute threshold for an m×n matrix with largest singular
    /// value `smax`; fails for a negative or non-finite value.
    pub fn threshold(self, m: usize, n: usize, smax: f64) -> Result<f64> {
        let check = |v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(v)
            } else {
                Err(Error::InvalidArgument {
                    what: "tol",
                    reason: format!("rank tolerance must be finite and ≥ 0, got {v}"),
                })
            }
        };
        match self {
            RankTolerance::Default => Ok(m.max(n) as f64 * f64::EPSILON * smax),
            RankTolerance::Absolute(t) => check(t),
            RankTolerance::Relative(r) => Ok(check(r)? * smax),
        }
    }
}

fn count_above(s: &DVector<f64>, tol: f64) -> usize {
    s.iter().filter(|&&v| v > tol).count()
}

/// Numerical rank: the number of singular values above the tolerance
/// (one SVD, O(mn·min(m,n))).
///
/// Errors: [`Error::NonFinite`], [`Error::InvalidArgument`] for a bad
/// tolerance, [`Error::NoConvergence`].
pub fn rank(a: &DMatrix<f64>, tol: RankTolerance) -> Result<usize> {
    let s = crate::svd::singular_values(a)?;
    let smax = s.iter().copied().fold(0.0, f64::max);
    let t = tol.threshold(a.nrows(), a.ncols(), smax)?;
    Ok(count_above(&s, t))
}

/// Moore–Penrose pseudo-inverse A⁺ = V diag(1/σᵢ) Uᵀ over the singular
/// values above the tolerance (n×m; one thin SVD, O(mn·min(m,n))).
///
/// Errors as [`rank`].
pub fn pinv(a: &DMatrix<f64>, tol: RankTolerance) -> Result<DMatrix<f64>> {
    let (m, n) = a.shape();
    let f = svd(a)?;
    let smax = f.s.iter().copied().fold(0.0, f64::max);
    let t = tol.threshold(m, n, smax)?;
    let r = count_above(&f.s, t);
    let mut v = f.v.columns(0, r).into_owned();
    for (j, mut col) in v.column_iter_mut().enumerate() {
        col /= f.s[j];
    }
    Ok(v * f.u.columns(0, r).transpose())
}

/// Orthonormal basis (n×(n − r) columns) of the null space {x : A x = 0},
/// r the numerical rank.
///
/// For m > n the SVD is taken of the n×n R factor of A (same right singular
/// vectors and singular values), O(mn² + n³); otherwise of A (full V).
/// Errors as [`rank`].
pub fn null_space(a: &DMatrix<f64>, tol: RankTolerance) -> Result<DMatrix<f64>> {
    check_finite("a", a)?;
    let (m, n) = a.shape();
    let reduced = if m > n { qr_r(a)? } else { a.clone() };
    let f = svd_full(&reduced)?;
    let smax = f.s.iter().copied().fold(0.0, f64::max);
    let t = tol.threshold(m, n, smax)?;
    let r = count_above(&f.s, t);
    Ok(f.v.columns(r, n - r).into_owned())
}

/// Orthonormal basis (m×r columns) of the range (column space) of A: the
/// leading r left singular vectors (one thin SVD).
/// Errors as [`rank`].
pub fn range_basis(a: &DMatrix<f64>, tol: RankTolerance) -> Result<DMatrix<f64>> {
    let (m, n) = a.shape();
    let f = svd(a)?;
    let smax = f.s.iter().copied().fold(0.0, f64::max);
    let t = tol.threshold(m, n, smax)?;
    let r = count_above(&f.s, t);
    Ok(f.u.columns(0, r).into_owned())
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn rank_one_matrix() {
        let a = DMatrix::from_fn(4, 3, |i, j| (i + 1) as f64 * (j + 2) as f64);
        assert_eq!(rank(&a, RankTolerance::Default).unwrap(), 1);
        let ns = null_space(&a, RankTolerance::Default).unwrap();
        assert_eq!(ns.shape(), (3, 2));
        assert!((&a * &ns).norm() < 1e-13);
        assert_relative_eq!(
            ns.transpose() * &ns,
            DMatrix::identity(2, 2),
            epsilon = 1e-14
        );
        let rb = range_basis(&a, RankTolerance::Default).unwrap();
        assert_eq!(rb.shape(), (4, 1));
        let p = pinv(&a, RankTolerance::Default).unwrap();
        assert_relative_eq!(&a * &p * &a, a, epsilon = 1e-12);
    }

    #[test]
    fn tolerances() {
        let a = DMatrix::from_diagonal(&nalgebra::dvector![1.0, 1e-6, 1e-20]);
        assert_eq!(rank(&a, RankTolerance::Default).unwrap(), 2);
        assert_eq!(rank(&a, RankTolerance::Relative(1e-3)).unwrap(), 1);
        assert_eq!(rank(&a, RankTolerance::Absolute(0.0)).unwrap(), 3);
        assert!(matches!(
            rank(&a, RankTolerance::Absolute(-1.0)),
            Err(Error::InvalidArgument { what: "tol", .. })
        ));
        assert!(matches!(
            rank(&a, RankTolerance::Relative(f64::NAN)),
            Err(Error::InvalidArgument { .. })
        ));
    }
}

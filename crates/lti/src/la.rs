//! Internal façade over `lifted-linalg`: the only place this crate touches
//! dense real kernels, so every algorithm calls one name. (Complex LU and
//! SVD of frequency-response matrices use nalgebra directly, since
//! `lifted-linalg` is real-only.)

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::Result;

pub(crate) use lifted_linalg::{check_cols, check_finite, check_rows, check_square};

/// Eigenvalues of a square matrix (unsorted).
pub(crate) fn eigenvalues(a: &DMatrix<f64>) -> Result<Vec<Complex64>> {
    Ok(lifted_linalg::eigenvalues(a)?)
}

/// Solves A X = B (LU; `Singular` when ill-conditioned beyond 1/ε).
pub(crate) fn solve(a: &DMatrix<f64>, b: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    Ok(lifted_linalg::solve(a, b)?)
}

/// Inverse.
pub(crate) fn inv(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    Ok(lifted_linalg::inv(a)?)
}

/// Matrix exponential.
pub(crate) fn expm(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    Ok(lifted_linalg::expm(a)?)
}

/// Principal matrix logarithm (`NoPrincipalBranch` on ℝ⁻ ∪ {0}).
pub(crate) fn logm(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    Ok(lifted_linalg::logm(a)?)
}

/// Symmetric eigendecomposition, descending: (values, vectors).
pub(crate) fn sym_eig_desc(a: &DMatrix<f64>) -> Result<(Vec<f64>, DMatrix<f64>)> {
    let e = lifted_linalg::sym_eig(a, lifted_linalg::SortOrder::Descending)?;
    Ok((e.values.iter().copied().collect(), e.vectors))
}

/// Thin SVD (u, s descending, v).
pub(crate) fn svd(a: &DMatrix<f64>) -> Result<(DMatrix<f64>, Vec<f64>, DMatrix<f64>)> {
    let f = lifted_linalg::svd(a)?;
    Ok((f.u, f.s.iter().copied().collect(), f.v))
}

/// Full QR: the orthogonal Q (m×m); its first k columns span range(A) when
/// A (m×k) has full column rank.
pub(crate) fn qr_full_q(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    Ok(lifted_linalg::qr_full(a)?.q)
}

/// Continuous Lyapunov: A X + X Aᵀ + Q = 0.
pub(crate) fn lyap(a: &DMatrix<f64>, q: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    Ok(lifted_linalg::lyap(a, q)?)
}

/// Discrete Lyapunov: A X Aᵀ − X + Q = 0.
pub(crate) fn dlyap(a: &DMatrix<f64>, q: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    Ok(lifted_linalg::dlyap(a, q)?)
}

/// The initial state `x0` checked for `n` finite entries (named "x0"), or
/// zeros when `None`. O(n).
///
/// Errors: [`crate::Error::DimensionMismatch`], [`crate::Error::Linalg`]
/// for a non-finite entry.
pub(crate) fn initial_state(
    x0: Option<&nalgebra::DVector<f64>>,
    n: usize,
) -> Result<nalgebra::DVector<f64>> {
    match x0 {
        Some(v) => {
            if v.len() != n {
                return Err(crate::Error::DimensionMismatch {
                    what: "x0",
                    expected: format!("{n} entries"),
                    got: format!("{}", v.len()),
                });
            }
            check_finite("x0", &DMatrix::from_column_slice(n, 1, v.as_slice()))?;
            Ok(v.clone())
        }
        None => Ok(nalgebra::DVector::zeros(n)),
    }
}

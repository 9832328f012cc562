//! Eigen-decompositions through faer: general (complex eigenvalues and
//! eigenvectors) and symmetric (real, sorted).
//!
//! * [`eig`], [`eigenvalues`]: faer's Hessenberg + Francis QR and
//!   eigenvector back-substitution, O(10n³) (≈ 25n³ with vectors). The order
//!   of the eigenvalues is faer's (not sorted); eigenvectors have unit
//!   2-norm, their phase is arbitrary (Pitfall 1).
//! * [`sym_eig`]: symmetrises (A + Aᵀ)/2, then faer's tridiagonalisation +
//!   divide and conquer, O(4n³/3 + vectors); values sorted as requested.

use faer::Side;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

use crate::check::square_finite;
use crate::convert::as_faer;
use crate::{Error, Result};

/// Eigenvalues and right eigenvectors A V = V diag(values).
#[derive(Debug, Clone, PartialEq)]
pub struct Eigen {
    /// Eigenvalues (faer's order; complex pairs adjacent).
    pub values: Vec<Complex64>,
    /// Right eigenvectors as columns, unit 2-norm.
    pub vectors: DMatrix<Complex64>,
}

/// Sort order of symmetric eigenvalues.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SortOrder {
    /// Smallest first.
    Ascending,
    /// Largest first (as the q-Markov cover and CCA need, Pitfall 1).
    Descending,
}

/// Eigen-decomposition of a symmetric matrix, A = V diag(values) Vᵀ.
#[derive(Debug, Clone, PartialEq)]
pub struct SymEigen {
    /// Real eigenvalues, sorted as requested.
    pub values: DVector<f64>,
    /// Orthonormal eigenvectors as columns, in the order of `values`.
    pub vectors: DMatrix<f64>,
}

fn evd_err(what: &'static str) -> Error {
    Error::NoConvergence {
        what,
        iterations: 0,
    }
}

/// Eigenvalues and eigenvectors of a general real square matrix (faer
/// `eigen`, O(25n³)).
///
/// Errors: [`Error::NotSquare`], [`Error::NonFinite`],
/// [`Error::NoConvergence`].
pub fn eig(a: &DMatrix<f64>) -> Result<Eigen> {
    let n = square_finite("a", a)?;
    if n == 0 {
        return Ok(Eigen {
            values: Vec::new(),
            vectors: DMatrix::zeros(0, 0),
        });
    }
    let e = as_faer(a).eigen().map_err(|_| evd_err("faer eigen"))?;
    let s = e.S().column_vector();
    let u = e.U();
    let values: Vec<Complex64> = (0..n).map(|i| s[i]).collect();
    let vectors = DMatrix::from_fn(n, n, |i, j| u[(i, j)]);
    Ok(Eigen { values, vectors })
}

/// Eigenvalues of a general real square matrix (faer `eigenvalues`,
/// O(10n³)), unsorted.
///
/// Errors as [`eig`].
pub fn eigenvalues(a: &DMatrix<f64>) -> Result<Vec<Complex64>> {
    let n = square_finite("a", a)?;
    if n == 0 {
        return Ok(Vec::new());
    }
    as_faer(a)
        .eigenvalues()
        .map_err(|_| evd_err("faer eigenvalues"))
}

/// Symmetric eigen-decomposition of (A + Aᵀ)/2 (faer `self_adjoint_eigen`,
/// O(9n³) with vectors), eigenvalues sorted by `order`.
///
/// Errors: [`Error::NotSquare`], [`Error::NonFinite`],
/// [`Error::NoConvergence`].
pub fn sym_eig(a: &DMatrix<f64>, order: SortOrder) -> Result<SymEigen> {
    let n = square_finite("a", a)?;
    if n == 0 {
        return Ok(SymEigen {
            values: DVector::zeros(0),
            vectors: DMatrix::zeros(0, 0),
        });
    }
    let sym = (a + a.transpose()) * 0.5;
    let e = as_faer(&sym)
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| evd_err("faer self_adjoint_eigen"))?;
    let s = e.S().column_vector();
    let u = e.U();
    // faer returns ascending values.
    let idx: Vec<usize> = match order {
        SortOrder::Ascending => (0..n).collect(),
        SortOrder::Descending => (0..n).rev().collect(),
    };
    let values = DVector::from_fn(n, |k, _| s[idx[k]]);
    let vectors = DMatrix::from_fn(n, n, |i, k| u[(i, idx[k])]);
    Ok(SymEigen { values, vectors })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn eig_reconstructs() {
        let a = DMatrix::from_row_slice(3, 3, &[1.0, 2.0, 0.0, -2.0, 1.0, 0.5, 0.0, 0.3, 3.0]);
        let e = eig(&a).unwrap();
        let ac = a.map(|v| Complex64::new(v, 0.0));
        let lhs = &ac * &e.vectors;
        let rhs = &e.vectors * DMatrix::from_diagonal(&DVector::from_vec(e.values.clone()));
        assert!((lhs - rhs).norm() < 1e-13);
        assert_eq!(eigenvalues(&a).unwrap().len(), 3);
    }

    #[test]
    fn sym_eig_sorted_both_ways() {
        let a = DMatrix::from_row_slice(3, 3, &[2.0, 1.0, 0.0, 1.0, 2.0, 1.0, 0.0, 1.0, 2.0]);
        let d = sym_eig(&a, SortOrder::Descending).unwrap();
        let s2 = 2f64.sqrt();
        assert_relative_eq!(
            d.values,
            DVector::from_vec(vec![2.0 + s2, 2.0, 2.0 - s2]),
            epsilon = 1e-14
        );
        let asc = sym_eig(&a, SortOrder::Ascending).unwrap();
        assert_relative_eq!(asc.values[0], 2.0 - s2, epsilon = 1e-14);
        let back = &d.vectors * DMatrix::from_diagonal(&d.values) * d.vectors.transpose();
        assert_relative_eq!(back, a, epsilon = 1e-14);
    }

    #[test]
    fn sym_eig_uses_symmetric_part() {
        let a = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 0.0, 1.0]);
        let e = sym_eig(&a, SortOrder::Descending).unwrap();
        assert_relative_eq!(e.values, DVector::from_vec(vec![2.0, 0.0]), epsilon = 1e-14);
    }
}

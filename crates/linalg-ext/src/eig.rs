//! Eigen-decompositions through faer: general (complex eigenvalues and
//! eigenvectors) and symmetric (real, sorted).
//!
//! * [`eig`], [`eigenvalues`]: faer's Hessenberg + Francis QR and
//!   eigenvector back-substitution, O(10n³) (≈ 25n³ with vectors). The order
//!   of the eigenvalues is faer's (not sorted); eigenvectors have unit
//!   2-norm, their phase is arbitrary (Pitfall 1).
//! * [`sym_eig`]: symmetrises (A + Aᵀ)/2, then faer's tridiagonalisation +
//!   divide and conquer, O(4n³/3 + vectors); values sorted as requested.
//! * [`reflect_into_unit_disc`]: A with its eigenvalues outside the unit
//!   circle reflected inside, eigenvectors kept, O(25n³).

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

/// Spectral radius ρ(A) = maxᵢ |λᵢ| of a real square matrix (0 for an
/// empty one), from [`eigenvalues`]: O(10n³).
///
/// Errors as [`eig`].
pub fn spectral_radius(a: &DMatrix<f64>) -> Result<f64> {
    Ok(eigenvalues(a)?.iter().map(|z| z.norm()).fold(0.0, f64::max))
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

/// Largest condition ‖V‖_F ‖V⁻¹‖_F of the eigenvector matrix for which
/// [`reflect_into_unit_disc`] moves eigenvalues in the eigenbasis.
pub const MAX_REFLECTION_CONDITION: f64 = 1e8;

/// The matrix A' = V Λ' V⁻¹ with the eigenvectors V of A kept and every
/// eigenvalue on or outside the unit circle moved inside: λ ↦ λ/|λ|²
/// (reflected through the circle, keeping the mode's frequency), its
/// modulus capped at `max_radius` < 1; the other eigenvalues are
/// untouched. Conjugate pairs move together, so A' is real (imaginary
/// rounding dropped). `None` when A is already stable, or its eigenvector
/// matrix is singular or worse conditioned than
/// [`MAX_REFLECTION_CONDITION`] (a defective A needs another
/// stabilisation). O(25n³).
///
/// Errors: [`Error::NotSquare`], [`Error::NonFinite`],
/// [`Error::NoConvergence`]; [`Error::InvalidArgument`] unless
/// 0 < `max_radius` < 1.
pub fn reflect_into_unit_disc(a: &DMatrix<f64>, max_radius: f64) -> Result<Option<DMatrix<f64>>> {
    if !(max_radius > 0.0 && max_radius < 1.0) {
        return Err(Error::InvalidArgument {
            what: "max_radius",
            reason: format!("must lie in (0, 1), got {max_radius}"),
        });
    }
    let e = eig(a)?;
    if e.values.iter().all(|l| l.norm() < 1.0) {
        return Ok(None);
    }
    let v = &e.vectors;
    let Some(vi) = v.clone().try_inverse() else {
        return Ok(None);
    };
    let cond = v.norm() * vi.norm();
    if !cond.is_finite() || cond > MAX_REFLECTION_CONDITION {
        return Ok(None);
    }
    let n = a.nrows();
    let mut vl = v.clone();
    for (j, &l) in e.values.iter().enumerate() {
        let r = l.norm();
        let moved = if r < 1.0 {
            l
        } else {
            l * ((1.0 / r).min(max_radius) / r)
        };
        for i in 0..n {
            vl[(i, j)] *= moved;
        }
    }
    let ac = vl * vi;
    if ac.iter().any(|z| z.im.abs() > 1e-8 * a.norm().max(1.0)) {
        return Ok(None);
    }
    Ok(Some(DMatrix::from_fn(n, n, |i, j| ac[(i, j)].re)))
}

#[cfg(test)]
mod reflection_tests {
    use super::*;

    #[test]
    fn unstable_eigenvalues_are_reflected_the_others_kept() {
        // Eigenvalues 1.25, 0.5 and the pair 0.6 ± 0.9i (|λ| ≈ 1.08), in a
        // non-modal basis.
        let lam = DMatrix::from_row_slice(
            4,
            4,
            &[
                1.25, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.6, 0.9, 0.0, 0.0, -0.9, 0.6,
            ],
        );
        let t = DMatrix::from_fn(4, 4, |i, j| {
            if i == j {
                2.0
            } else {
                0.3 * (i + 2 * j) as f64 / 7.0
            }
        });
        let a = &t * lam * t.clone().try_inverse().unwrap();
        let r = reflect_into_unit_disc(&a, 0.999).unwrap().unwrap();
        let mut got: Vec<f64> = eigenvalues(&r).unwrap().iter().map(|z| z.norm()).collect();
        got.sort_by(f64::total_cmp);
        let pair = (0.36f64 + 0.81).sqrt();
        let mut want = vec![0.5, 1.0 / 1.25, 1.0 / pair, 1.0 / pair];
        want.sort_by(f64::total_cmp);
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() < 1e-10, "{got:?} vs {want:?}");
        }
        // A stable matrix is left alone; a bad radius is refused.
        assert!(
            reflect_into_unit_disc(&(a.clone() * 0.1), 0.999)
                .unwrap()
                .is_none()
        );
        assert!(reflect_into_unit_disc(&a, 1.0).is_err());
        // A defective unstable A (Jordan block) has no eigenbasis.
        let j = DMatrix::from_row_slice(2, 2, &[1.1, 1.0, 0.0, 1.1]);
        assert!(reflect_into_unit_disc(&j, 0.999).unwrap().is_none());
    }
}

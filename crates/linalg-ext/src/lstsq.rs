//! Linear least squares min ‖A X − B‖_F.
//!
//! For m ≥ n the Householder QR of A in place (faer, unblocked for narrow
//! A; O(mn²)) is computed and the singular values of its n×n R factor
//! decide the rank with the default rule of [`crate::RankTolerance`]
//! (O(n²) estimates when clearly above the threshold, O(n³) near it). With
//! full column rank X = R⁻¹ (Qᵀ B)₁:ₙ (reflectors applied to B, O(mnk),
//! one triangular solve); otherwise — and always for m < n — the
//! minimum-norm solution X = A⁺ B from the thin SVD (O(mn·min(m,n))).

use faer::Par;
use nalgebra::DMatrix;

use crate::Result;
use crate::check::{check_finite, check_rows};
use crate::convert::as_faer_mut;
use crate::extremes::triangular_condition;
use crate::qr::{apply_qt, householder_in_place};
use crate::rank::{RankTolerance, pinv};

/// Least-squares solution X (n×k) of A X ≈ B for A m×n, B m×k; the
/// minimum-norm one when A is rank deficient. O(mn² + mnk).
///
/// Errors: [`crate::Error::DimensionMismatch`] when B does not have m rows,
/// [`crate::Error::NonFinite`], [`crate::Error::NoConvergence`].
pub fn lstsq(a: &DMatrix<f64>, b: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    check_finite("a", a)?;
    let (m, n) = a.shape();
    check_rows("b", b, m)?;
    check_finite("b", b)?;
    if n == 0 {
        return Ok(DMatrix::zeros(0, b.ncols()));
    }
    if m >= n {
        let mut work = a.clone();
        let coeff = householder_in_place(&mut work);
        // Rᵀ (lower triangular) for the condition test.
        let rt = DMatrix::from_fn(n, n, |i, j| if j <= i { work[(j, i)] } else { 0.0 });
        // Full rank when σ_min/σ_max of R exceeds the default tolerance
        // max(m, n) ε: the O(n²) estimates decide when clearly above it,
        // the singular values near it (same decision as before).
        let thr = RankTolerance::Default.threshold(m, n, 1.0)?;
        let check = triangular_condition(&rt, thr, 10.0)?;
        if check.ratio > thr {
            let mut qtb = b.clone();
            apply_qt(&work, &coeff, &mut qtb);
            let mut x = qtb.rows(0, n).into_owned();
            faer::linalg::triangular_solve::solve_upper_triangular_in_place(
                crate::convert::as_faer(&work).get(..n, ..n),
                as_faer_mut(&mut x),
                Par::Seq,
            );
            return Ok(x);
        }
    }
    Ok(pinv(a, RankTolerance::Default)? * b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn line_fit() {
        // y = 2 + 3t exactly.
        let a = DMatrix::from_fn(5, 2, |i, j| if j == 0 { 1.0 } else { i as f64 });
        let b = DMatrix::from_fn(5, 1, |i, _| 2.0 + 3.0 * i as f64);
        let x = lstsq(&a, &b).unwrap();
        assert_relative_eq!(
            x,
            DMatrix::from_row_slice(2, 1, &[2.0, 3.0]),
            epsilon = 1e-13
        );
    }

    #[test]
    fn minimum_norm_for_rank_deficient() {
        // Two identical columns: the minimum-norm solution splits equally.
        let a = DMatrix::from_row_slice(3, 2, &[1.0, 1.0, 2.0, 2.0, 3.0, 3.0]);
        let b = DMatrix::from_row_slice(3, 1, &[2.0, 4.0, 6.0]);
        let x = lstsq(&a, &b).unwrap();
        assert_relative_eq!(
            x,
            DMatrix::from_row_slice(2, 1, &[1.0, 1.0]),
            epsilon = 1e-13
        );
        // Underdetermined: x = Aᵀ(AAᵀ)⁻¹b.
        let a = DMatrix::from_row_slice(1, 2, &[3.0, 4.0]);
        let x = lstsq(&a, &DMatrix::from_element(1, 1, 25.0)).unwrap();
        assert_relative_eq!(
            x,
            DMatrix::from_row_slice(2, 1, &[3.0, 4.0]),
            epsilon = 1e-13
        );
    }
}

//! Cholesky factorisation G = L Lᵀ through faer (blocked, SIMD), for the
//! positive-definiteness tests and Gram factors of the subspace methods.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch};
use nalgebra::DMatrix;

use crate::Result;
use crate::convert::as_faer_mut;

/// Lower Cholesky factor L of a symmetric matrix (lower triangle read, the
/// strict upper triangle of the result zero), or `None` when the matrix is
/// not numerically positive definite (a pivot ≤ 0 or not finite) or not
/// square. In place on the owned matrix; faer's blocked left-looking
/// factorisation, on the calling thread below ≈ 3e7 flops. O(k³/3) flops.
pub fn cholesky_lower(mut g: DMatrix<f64>) -> Option<DMatrix<f64>> {
    let k = g.nrows();
    if g.ncols() != k {
        return None;
    }
    if !factor_lower_in_place(&mut g) {
        return None;
    }
    for j in 1..k {
        for i in 0..j {
            g[(i, j)] = 0.0;
        }
    }
    Some(g)
}

/// faer's Cholesky factorisation of the lower triangle of the square `g`
/// in place (faer may also write the strict upper triangle); whether it
/// succeeded with finite positive pivots.
fn factor_lower_in_place(g: &mut DMatrix<f64>) -> bool {
    let k = g.nrows();
    if k == 0 {
        return true;
    }
    let par = crate::svd::par_for(k, k);
    let params = Default::default();
    let mut mem = MemBuffer::new(cholesky_in_place_scratch::<f64>(k, par, params));
    cholesky_in_place(
        as_faer_mut(g),
        Default::default(),
        par,
        MemStack::new(&mut mem),
        params,
    )
    .is_ok()
        && (0..k).all(|i| g[(i, i)].is_finite() && g[(i, i)] > 0.0)
}

/// The lower Cholesky factor of the symmetric positive semi-definite
/// matrix whose lower triangle `g` holds, and whether λ_min/λ_max >
/// `threshold` is proven — the decision of [`crate::gram_condition_exceeds`]
/// followed by [`cholesky_lower`], with less memory: the shifted matrix
/// G − τI (τ = threshold · ‖G‖∞, the row-sum bound of λ_max) is factored in
/// G's own storage, G's lower triangle being kept meanwhile in a packed
/// copy (k(k+1)/2 entries, half a matrix), and restored for the
/// factorisation proper. Only when that certificate fails does the
/// power-iteration route of [`crate::gram_condition_exceeds`] run (with its
/// copies; the row-sum certificate is not repeated). `None` when G is not numerically positive definite. Two
/// factorisations, O(2k³/3).
///
/// Errors: [`crate::Error::NonFinite`], [`crate::Error::DimensionMismatch`]
/// when not square.
pub fn cholesky_condition(
    mut g: DMatrix<f64>,
    threshold: f64,
) -> Result<Option<(DMatrix<f64>, bool)>> {
    let k = crate::extremes::check_square_lower(&g)?;
    if k == 0 {
        return Ok(Some((g, true)));
    }
    let row_sums = crate::extremes::lower_row_sums_max(&g);
    let mut proven = false;
    if row_sums.is_finite() && row_sums > 0.0 {
        let mut packed = Vec::with_capacity(k * (k + 1) / 2);
        for j in 0..k {
            packed.extend_from_slice(&g.column(j).as_slice()[j..]);
        }
        let tau = threshold * row_sums;
        for i in 0..k {
            g[(i, i)] -= tau;
        }
        proven = factor_lower_in_place(&mut g);
        // G back: the lower triangle from the copy, the upper mirrored.
        let mut at = 0;
        for j in 0..k {
            g.column_mut(j).as_mut_slice()[j..].copy_from_slice(&packed[at..at + k - j]);
            at += k - j;
        }
        drop(packed);
        for j in 0..k {
            for i in j + 1..k {
                g[(j, i)] = g[(i, j)];
            }
        }
        if !proven {
            proven = crate::extremes::power_certificate(&g, threshold, row_sums)?;
        }
    }
    Ok(cholesky_lower(g).map(|l| (l, proven)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn certified_factor_equals_the_plain_one_and_the_copying_test() {
        let mut outcomes = Vec::new();
        for k in [1, 17, 40, 160] {
            let x = DMatrix::from_fn(k + 9, k, |i, j| {
                (1.0 + 0.7 * i as f64 + 0.3 * (j * j) as f64).sin() + f64::from(u8::from(i == j))
            });
            let g = x.transpose() * &x;
            // Well conditioned (first certificate), needs the power route,
            // and far below the threshold.
            for (shift, threshold) in [(1.0, 1e-8), (1.0, 0.5), (0.0, 0.9)] {
                let mut gs = g.clone();
                for i in 0..k {
                    gs[(i, i)] += shift;
                }
                let (l, proven) = cholesky_condition(gs.clone(), threshold).unwrap().unwrap();
                assert_eq!(l, cholesky_lower(gs.clone()).unwrap(), "k = {k}");
                assert_eq!(
                    proven,
                    crate::gram_condition_exceeds(&gs, threshold).unwrap(),
                    "k = {k}, threshold {threshold}"
                );
                outcomes.push(proven);
            }
        }
        // Both answers occur.
        assert!(outcomes.contains(&true) && outcomes.contains(&false));
        let x = DMatrix::from_fn(12, 6, |i, j| ((i * 5 + j * 11) % 13) as f64 - 6.0);
        let mut bad = x.transpose() * &x;
        bad[(3, 3)] = -1.0;
        assert!(cholesky_condition(bad, 1e-8).unwrap().is_none());
        assert!(cholesky_condition(DMatrix::zeros(2, 3), 1e-8).is_err());
        let mut nan = DMatrix::identity(3, 3);
        nan[(2, 0)] = f64::NAN;
        assert!(cholesky_condition(nan, 1e-8).is_err());
    }

    #[test]
    fn factor_reproduces_the_matrix_and_refuses_indefinite_ones() {
        let k = 70;
        let x = DMatrix::from_fn(k + 5, k, |i, j| {
            ((i * 7 + j * 13) % 17) as f64 - 8.0 + (i == j) as u8 as f64
        });
        let g = x.transpose() * &x;
        let l = cholesky_lower(g.clone()).expect("positive definite");
        assert!((&l * l.transpose() - &g).norm() <= 1e-12 * g.norm());
        let reference = g.clone().cholesky().expect("nalgebra").unpack();
        assert!((&l - reference).norm() <= 1e-10 * l.norm());
        let mut bad = g.clone();
        bad[(3, 3)] = -1.0;
        assert!(cholesky_lower(bad).is_none());
        assert!(cholesky_lower(DMatrix::zeros(2, 3)).is_none());
        assert_eq!(
            cholesky_lower(DMatrix::zeros(0, 0)).map(|m| m.len()),
            Some(0)
        );
    }
}

//! Cholesky factorisation G = L Lᵀ through faer (blocked, SIMD), for the
//! positive-definiteness tests and Gram factors of the subspace methods.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch};
use nalgebra::DMatrix;

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
    if k == 0 {
        return Some(g);
    }
    let par = crate::svd::par_for(k, k);
    let params = Default::default();
    let mut mem = MemBuffer::new(cholesky_in_place_scratch::<f64>(k, par, params));
    cholesky_in_place(
        as_faer_mut(&mut g),
        Default::default(),
        par,
        MemStack::new(&mut mem),
        params,
    )
    .ok()?;
    for j in 1..k {
        for i in 0..j {
            g[(i, j)] = 0.0;
        }
    }
    if (0..k).any(|i| !g[(i, i)].is_finite() || g[(i, i)] <= 0.0) {
        return None;
    }
    Some(g)
}

#[cfg(test)]
mod tests {
    use super::*;

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

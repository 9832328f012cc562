//! Singular values of complex matrices through their real embedding
//! [Re −Im; Im Re] (each singular value of M twice): the frequency-domain
//! bounds of the robust and conic MPC designs. O(r c · min(r, c)) per SVD.

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::error::Result;

/// Largest singular value of a complex matrix, via the real embedding
/// [Re −Im; Im Re] (whose singular values are those of M, each twice).
///
/// Errors: non-finite entries.
pub fn sigma_max(m: &DMatrix<Complex64>) -> Result<f64> {
    if m.nrows() == 0 || m.ncols() == 0 {
        return Ok(0.0);
    }
    let e = real_embedding(m);
    let s = lifted_linalg::singular_values(&e)?;
    Ok(s.iter().copied().fold(0.0, f64::max))
}

/// Real embedding [Re −Im; Im Re] of a complex matrix: its singular values
/// are those of M, each twice, and [a; b] ↦ a + jb maps its right singular
/// vectors to those of M.
pub(crate) fn real_embedding(m: &DMatrix<Complex64>) -> DMatrix<f64> {
    let (r, c) = m.shape();
    let mut e = DMatrix::zeros(2 * r, 2 * c);
    for i in 0..r {
        for j in 0..c {
            let z = m[(i, j)];
            e[(i, j)] = z.re;
            e[(i + r, j + c)] = z.re;
            e[(i, j + c)] = -z.im;
            e[(i + r, j)] = z.im;
        }
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sigma_max_of_complex_matrix() {
        // [[1, i], [0, 1]]: singular values (√5 ± 1)/2
        let m = DMatrix::from_row_slice(
            2,
            2,
            &[
                Complex64::new(1.0, 0.0),
                Complex64::new(0.0, 1.0),
                Complex64::new(0.0, 0.0),
                Complex64::new(1.0, 0.0),
            ],
        );
        assert!((sigma_max(&m).unwrap() - (5f64.sqrt() + 1.0) / 2.0).abs() < 1e-12);
    }
}

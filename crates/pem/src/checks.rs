//! Checks of the records and matrices a caller hands in, with this crate's
//! errors.

use nalgebra::DMatrix;

use crate::error::{Error, Result};

/// [`Error::DimensionMismatch`] for `what` unless `u` is N×`nu` and `y`
/// N×`ny` for some N.
pub(crate) fn check_record_shape(
    what: &'static str,
    u: &DMatrix<f64>,
    y: &DMatrix<f64>,
    nu: usize,
    ny: usize,
) -> Result<()> {
    if u.ncols() != nu || y.ncols() != ny || u.nrows() != y.nrows() {
        return Err(Error::DimensionMismatch {
            what,
            expected: format!("N×{nu} and N×{ny}"),
            got: format!(
                "{}x{} and {}x{}",
                u.nrows(),
                u.ncols(),
                y.nrows(),
                y.ncols()
            ),
        });
    }
    Ok(())
}

/// [`Error::NonFinite`] at the first NaN or infinity of `m` (by column,
/// then row), O(size) vectorised.
pub(crate) fn check_finite(what: &'static str, m: &DMatrix<f64>) -> Result<()> {
    match lifted_linalg::first_non_finite(m.as_slice()) {
        Some(i) => Err(Error::NonFinite {
            what,
            row: i % m.nrows(),
            col: i / m.nrows(),
        }),
        None => Ok(()),
    }
}

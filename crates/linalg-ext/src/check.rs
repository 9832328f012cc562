//! Input validation shared by every Lifted crate: finiteness and shapes.
//!
//! Each check names the argument (`what`) in the error it returns, so a user
//! sees which input was wrong. All checks are O(1) except [`check_finite`],
//! which is O(mn).

use nalgebra::DMatrix;

use crate::{Error, Result};

/// Fails with [`Error::NonFinite`] at the first NaN or infinity (column-major
/// order) of `m`.
pub fn check_finite(what: &'static str, m: &DMatrix<f64>) -> Result<()> {
    match crate::kernels::first_non_finite(m.as_slice()) {
        None => Ok(()),
        Some(k) => Err(Error::NonFinite {
            what,
            row: k % m.nrows(),
            col: k / m.nrows(),
        }),
    }
}

/// Fails with [`Error::NotSquare`] unless `m` is square; returns its order n.
pub fn check_square(what: &'static str, m: &DMatrix<f64>) -> Result<usize> {
    let (rows, cols) = m.shape();
    if rows == cols {
        Ok(rows)
    } else {
        Err(Error::NotSquare { what, rows, cols })
    }
}

/// Fails with [`Error::DimensionMismatch`] unless `m` has `rows` rows.
pub fn check_rows(what: &'static str, m: &DMatrix<f64>, rows: usize) -> Result<()> {
    if m.nrows() == rows {
        Ok(())
    } else {
        Err(Error::DimensionMismatch {
            what,
            expected: format!("{rows} rows"),
            got: format!("{} rows", m.nrows()),
        })
    }
}

/// Fails with [`Error::DimensionMismatch`] unless `m` has `cols` columns.
pub fn check_cols(what: &'static str, m: &DMatrix<f64>, cols: usize) -> Result<()> {
    if m.ncols() == cols {
        Ok(())
    } else {
        Err(Error::DimensionMismatch {
            what,
            expected: format!("{cols} columns"),
            got: format!("{} columns", m.ncols()),
        })
    }
}

/// Square and finite: the usual precondition of a square kernel. Returns n.
pub(crate) fn square_finite(what: &'static str, m: &DMatrix<f64>) -> Result<usize> {
    let n = check_square(what, m)?;
    check_finite(what, m)?;
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finite_reports_position() {
        let mut a = DMatrix::<f64>::zeros(3, 2);
        assert_eq!(check_finite("a", &a), Ok(()));
        a[(2, 1)] = f64::NAN;
        assert_eq!(
            check_finite("a", &a),
            Err(Error::NonFinite {
                what: "a",
                row: 2,
                col: 1
            })
        );
        a[(2, 1)] = 0.0;
        a[(1, 0)] = f64::NEG_INFINITY;
        assert_eq!(
            check_finite("a", &a),
            Err(Error::NonFinite {
                what: "a",
                row: 1,
                col: 0
            })
        );
    }

    #[test]
    fn shapes() {
        let a = DMatrix::<f64>::zeros(3, 2);
        assert_eq!(check_square("a", &DMatrix::<f64>::zeros(4, 4)), Ok(4));
        assert!(matches!(
            check_square("a", &a),
            Err(Error::NotSquare {
                what: "a",
                rows: 3,
                cols: 2
            })
        ));
        assert_eq!(check_rows("a", &a, 3), Ok(()));
        assert!(matches!(
            check_rows("a", &a, 2),
            Err(Error::DimensionMismatch { .. })
        ));
        assert_eq!(check_cols("a", &a, 2), Ok(()));
        assert!(matches!(
            check_cols("b", &a, 3),
            Err(Error::DimensionMismatch { what: "b", .. })
        ));
    }
}

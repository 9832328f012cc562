//! Products of blocks of `DMatrix` operands through faer's matmul.
//!
//! nalgebra's `*` on views goes through matrixmultiply, which packs its
//! whole right operand on every call; for the short, wide products of the
//! subspace estimates (4×80 coefficients times 80×160 rows of a factor)
//! faer's kernels on zero-copy views take half the time (4.6 µs against
//! 2.2 µs, measured 2026-11-26 on the AVX-512 machine of benches/results/slicot.md).

use std::ops::Range;

use faer::{Accum, Par};
use nalgebra::DMatrix;

use crate::convert::{as_faer, as_faer_mut};
use crate::{Error, Result};

/// C ← A[:, a_cols] · B[b_rows, :] (or C + that with `accumulate`), on
/// views of the operands (no copies), sequential. O(m k n) for C m×n and
/// k = |a_cols| = |b_rows|.
///
/// Errors: [`Error::DimensionMismatch`] when a range is out of bounds, the
/// ranges differ in length or C is not A's rows × B's columns.
pub fn mul_blocks(
    c: &mut DMatrix<f64>,
    accumulate: bool,
    a: &DMatrix<f64>,
    a_cols: Range<usize>,
    b: &DMatrix<f64>,
    b_rows: Range<usize>,
) -> Result<()> {
    let mismatch = |expected: String, got: String| Error::DimensionMismatch {
        what: "mul_blocks",
        expected,
        got,
    };
    if a_cols.start > a_cols.end
        || a_cols.end > a.ncols()
        || b_rows.start > b_rows.end
        || b_rows.end > b.nrows()
    {
        return Err(mismatch(
            format!(
                "columns within 0..{} of A and rows within 0..{} of B",
                a.ncols(),
                b.nrows()
            ),
            format!("{a_cols:?} and {b_rows:?}"),
        ));
    }
    if a_cols.len() != b_rows.len() || c.shape() != (a.nrows(), b.ncols()) {
        return Err(mismatch(
            format!("|a_cols| = |b_rows| and C {}x{}", a.nrows(), b.ncols()),
            format!(
                "{} columns, {} rows, C {}x{}",
                a_cols.len(),
                b_rows.len(),
                c.nrows(),
                c.ncols()
            ),
        ));
    }
    let k = a_cols.len();
    faer::linalg::matmul::matmul(
        as_faer_mut(c),
        if accumulate {
            Accum::Add
        } else {
            Accum::Replace
        },
        as_faer(a).subcols(a_cols.start, k),
        as_faer(b).subrows(b_rows.start, k),
        1.0,
        Par::Seq,
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_multiply_like_nalgebra_views() {
        let a = DMatrix::from_fn(3, 7, |i, j| (i as f64 + 1.0) * (j as f64 - 2.5));
        let b = DMatrix::from_fn(9, 4, |i, j| ((i * 3 + j) % 5) as f64 - 1.5);
        let mut c = DMatrix::zeros(3, 4);
        mul_blocks(&mut c, false, &a, 2..6, &b, 5..9).unwrap();
        let want = a.columns(2, 4) * b.rows(5, 4);
        assert!((&c - &want).norm() <= 1e-13 * want.norm());
        mul_blocks(&mut c, true, &a, 0..1, &b, 0..1).unwrap();
        let want = want + a.columns(0, 1) * b.rows(0, 1);
        assert!((&c - &want).norm() <= 1e-13 * want.norm());
        assert!(mul_blocks(&mut c, false, &a, 2..6, &b, 5..8).is_err());
        assert!(mul_blocks(&mut c, false, &a, 5..9, &b, 0..4).is_err());
        assert!(mul_blocks(&mut DMatrix::zeros(2, 4), false, &a, 0..4, &b, 0..4).is_err());
    }
}

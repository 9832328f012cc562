//! Zero-copy conversions between `nalgebra::DMatrix<f64>` and faer views.
//!
//! `DMatrix` stores its entries contiguously in column-major order, which is
//! exactly what a faer view with unit row stride and column stride `nrows`
//! describes, so the conversions to faer cost nothing. Going back from faer
//! copies, because a `faer::Mat` may pad its columns.

use faer::{MatMut, MatRef};
use nalgebra::DMatrix;

/// Borrows a `DMatrix` as a faer view (no copy, O(1)).
pub fn as_faer(m: &DMatrix<f64>) -> MatRef<'_, f64> {
    MatRef::from_column_major_slice(m.as_slice(), m.nrows(), m.ncols())
}

/// Borrows a `DMatrix` mutably as a faer view (no copy, O(1)).
pub fn as_faer_mut(m: &mut DMatrix<f64>) -> MatMut<'_, f64> {
    let (r, c) = m.shape();
    MatMut::from_column_major_slice_mut(m.as_mut_slice(), r, c)
}

/// Copies any faer view (arbitrary strides) into a new `DMatrix` (O(mn)).
pub fn to_dmatrix(m: MatRef<'_, f64>) -> DMatrix<f64> {
    DMatrix::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_is_exact() {
        let a = DMatrix::from_fn(7, 3, |i, j| (i * 10 + j) as f64);
        let v = as_faer(&a);
        assert_eq!(v.nrows(), 7);
        assert_eq!(v.ncols(), 3);
        assert_eq!(v[(4, 2)], 42.0);
        assert_eq!(to_dmatrix(v), a);
        // A padded faer Mat and a transposed (strided) view convert correctly.
        let m = faer::Mat::from_fn(7, 3, |i, j| (i * 10 + j) as f64);
        assert_eq!(to_dmatrix(m.as_ref()), a);
        assert_eq!(to_dmatrix(m.as_ref().transpose()), a.transpose());
    }

    #[test]
    fn mutable_view_writes_through() {
        let mut a = DMatrix::<f64>::zeros(2, 3);
        as_faer_mut(&mut a)[(1, 2)] = 5.0;
        assert_eq!(a[(1, 2)], 5.0);
    }

    #[test]
    fn empty_matrices_convert() {
        let a = DMatrix::<f64>::zeros(0, 4);
        assert_eq!(as_faer(&a).ncols(), 4);
        assert_eq!(to_dmatrix(as_faer(&a)).shape(), (0, 4));
    }
}

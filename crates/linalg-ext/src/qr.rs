//! QR factorisations through faer, including the R-only low-memory path
//! and a streaming accumulator for tall data.
//!
//! * [`qr_r`] / [`qr_r_owned`]: Householder QR without pivoting, in place
//!   with a `MemBuffer` scratch of O(b·n) (faer `qr_in_place`, block size
//!   b from `recommended_block_size`, unblocked for at most 24 columns);
//!   only R (min(m,n)×n) is kept.
//!   ≈ 2mn² − ⅔n³ flops. This is the LQ of the subspace methods: for a
//!   wide data matrix H, `qr_r(&H.transpose())` gives Lᵀ.
//! * [`qr_thin`], [`qr_full`]: Q and R (faer `qr`), O(mn²) more for Q.
//! * [`RAccumulator`]: R of a tall matrix fed in row blocks,
//!   R ← qr_r([R; block]); memory O(n² + b·n), total O(m n²).
//!
//! R is unique only up to the signs of its rows (for full column rank).

use faer::Mat;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::householder;
use faer::linalg::qr::no_pivoting::factor::{
    qr_in_place, qr_in_place_scratch, recommended_block_size,
};
use nalgebra::DMatrix;

use crate::Result;
use crate::check::{check_cols, check_finite};
use crate::convert::{as_faer, as_faer_mut, to_dmatrix};

/// A QR factorisation A = Q R.
#[derive(Debug, Clone, PartialEq)]
pub struct Qr {
    /// Orthonormal columns: m×k (thin, k = min(m, n)) or m×m (full).
    pub q: DMatrix<f64>,
    /// Upper triangular (trapezoidal) factor: k×n (thin) or m×n (full).
    pub r: DMatrix<f64>,
}

/// Matrices with at most this many columns are factored unblocked: faer's
/// blocked update (block size from `recommended_block_size`) costs more
/// than it saves on narrow matrices (720×8: 5 µs unblocked against 19 µs
/// blocked; 10 000×16: 0.32 ms against 0.50 ms; even at 24 columns, above
/// it the blocked form wins; one-off timings of both block sizes,
/// 2026-11-25; the unblocked path against nalgebra is the criterion bench
/// `kernels -- narrow_least`).
const NARROW_COLUMNS: usize = 24;

/// Householder QR of `work` in place (faer `qr_in_place`): R in the upper
/// triangle, the essential parts of the reflectors below it; returns the
/// block coefficients (b×min(m,n)) that [`apply_qt`] needs. ≈ 2mn² − ⅔n³
/// flops, O(b·n) scratch.
pub(crate) fn householder_in_place(work: &mut DMatrix<f64>) -> Mat<f64> {
    let (m, n) = work.shape();
    let k = m.min(n);
    let par = crate::svd::par_for(m, n);
    let bs = if n <= NARROW_COLUMNS {
        1
    } else {
        recommended_block_size::<f64>(m, n)
    };
    let mut coeff = Mat::<f64>::zeros(bs, k);
    if k == 0 {
        return coeff;
    }
    let params = Default::default();
    let mut mem = MemBuffer::new(qr_in_place_scratch::<f64>(m, n, bs, par, params));
    qr_in_place(
        as_faer_mut(work),
        coeff.as_mut(),
        par,
        MemStack::new(&mut mem),
        params,
    );
    coeff
}

/// Applies Qᵀ of a factorisation by [`householder_in_place`] (`work`,
/// `coeff`) to `b` in place (m rows). O(m·k·ncols(b)).
pub(crate) fn apply_qt(work: &DMatrix<f64>, coeff: &Mat<f64>, b: &mut DMatrix<f64>) {
    let (m, n) = work.shape();
    let k = m.min(n);
    if k == 0 || b.ncols() == 0 {
        return;
    }
    let basis = as_faer(work).get(.., ..k);
    let par = crate::svd::par_for(m, b.ncols());
    let mut mem =
        MemBuffer::new(
            householder::apply_block_householder_sequence_transpose_on_the_left_in_place_scratch::<
                f64,
            >(m, coeff.nrows(), b.ncols()),
        );
    householder::apply_block_householder_sequence_transpose_on_the_left_in_place_with_conj(
        basis,
        coeff.as_ref(),
        faer::Conj::No,
        as_faer_mut(b),
        par,
        MemStack::new(&mut mem),
    );
}

/// Factors `work` in place; returns the upper triangle (min(m,n)×n).
fn r_in_place(mut work: DMatrix<f64>) -> DMatrix<f64> {
    let (m, n) = work.shape();
    let k = m.min(n);
    if k == 0 {
        return DMatrix::zeros(0, n);
    }
    householder_in_place(&mut work);
    DMatrix::from_fn(k, n, |i, j| if i <= j { work[(i, j)] } else { 0.0 })
}

/// R factor of A = Q R (min(m,n)×n upper triangular) without forming Q,
/// in place on a copy of `a` with O(b·n) scratch (≈ 2mn² − ⅔n³ flops).
///
/// Errors: [`crate::Error::NonFinite`].
pub fn qr_r(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    check_finite("a", a)?;
    Ok(r_in_place(a.clone()))
}

/// As [`qr_r`], but factors the caller's matrix in place instead of a copy
/// (no extra m×n allocation: the path for very tall data).
pub fn qr_r_owned(a: DMatrix<f64>) -> Result<DMatrix<f64>> {
    check_finite("a", &a)?;
    Ok(r_in_place(a))
}

/// Thin QR: Q (m×k orthonormal columns), R (k×n), k = min(m, n)
/// (faer `qr` + `compute_thin_Q`, O(mn·k)).
///
/// Errors: [`crate::Error::NonFinite`].
pub fn qr_thin(a: &DMatrix<f64>) -> Result<Qr> {
    check_finite("a", a)?;
    let (m, n) = a.shape();
    if m.min(n) == 0 {
        return Ok(Qr {
            q: DMatrix::zeros(m, 0),
            r: DMatrix::zeros(0, n),
        });
    }
    let f = as_faer(a).qr();
    Ok(Qr {
        q: to_dmatrix(f.compute_thin_Q().as_ref()),
        r: to_dmatrix(f.thin_R()),
    })
}

/// Full QR: Q (m×m orthogonal), R (m×n) (faer `qr` + `compute_Q`, O(m²n)).
///
/// Errors: [`crate::Error::NonFinite`].
pub fn qr_full(a: &DMatrix<f64>) -> Result<Qr> {
    check_finite("a", a)?;
    let (m, n) = a.shape();
    if m.min(n) == 0 {
        return Ok(Qr {
            q: DMatrix::identity(m, m),
            r: DMatrix::zeros(m, n),
        });
    }
    let f = as_faer(a).qr();
    let thin = f.thin_R();
    let r = DMatrix::from_fn(m, n, |i, j| {
        if i < thin.nrows() && i <= j {
            thin[(i, j)]
        } else {
            0.0
        }
    });
    Ok(Qr {
        q: to_dmatrix(f.compute_Q().as_ref()),
        r,
    })
}

/// Streaming R-only QR of a tall matrix fed in row blocks.
///
/// After pushing blocks A₁, A₂, …, [`RAccumulator::r`] equals (up to row
/// signs) `qr_r` of the stacked matrix [A₁; A₂; …], because
/// [A₁; A₂] = diag(Q₁, I)[R₁; A₂]. Memory O(n² + b·n) for blocks of b
/// rows; each push costs O((n + b)·n²).
///
/// ```
/// # fn main() -> lifted_linalg::Result<()> {
/// use lifted_linalg::{RAccumulator, qr_r};
/// use nalgebra::DMatrix;
/// let a = DMatrix::from_fn(50, 3, |i, j| ((i * 7 + j * 3) % 11) as f64);
/// let mut acc = RAccumulator::new(3);
/// acc.push_rows(&a.rows(0, 20).into_owned())?;
/// acc.push_rows(&a.rows(20, 30).into_owned())?;
/// let (r1, r2) = (acc.r(), qr_r(&a)?);
/// for i in 0..3 {
///     for j in 0..3 {
///         assert!((r1[(i, j)].abs() - r2[(i, j)].abs()).abs() < 1e-10);
///     }
/// }
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct RAccumulator {
    ncols: usize,
    r: DMatrix<f64>,
    rows_seen: usize,
}

impl RAccumulator {
    /// An empty accumulator for matrices with `ncols` columns.
    pub fn new(ncols: usize) -> Self {
        RAccumulator {
            ncols,
            r: DMatrix::zeros(0, ncols),
            rows_seen: 0,
        }
    }

    /// Folds a block of rows into R.
    ///
    /// Errors: [`crate::Error::DimensionMismatch`] if the block does not
    /// have `ncols` columns, [`crate::Error::NonFinite`].
    pub fn push_rows(&mut self, block: &DMatrix<f64>) -> Result<()> {
        if let Some(simd) = self.folds(block)? {
            // A full (or empty) triangle and a narrow block: the
            // structured fold.
            let mut b = block.clone();
            crate::fold::fold_into_triangle(simd, &mut self.r, &mut b);
        } else if block.nrows() > 0 {
            self.stack(block);
        }
        self.rows_seen += block.nrows();
        Ok(())
    }

    /// [`push_rows`](Self::push_rows) for a block the caller gives up as
    /// scratch (overwritten): no copy of it when R is full and the block
    /// narrow (the structured fold). The same R up to rounding.
    ///
    /// Errors: as [`push_rows`](Self::push_rows).
    pub fn fold_rows(&mut self, block: &mut DMatrix<f64>) -> Result<()> {
        if let Some(simd) = self.folds(block)? {
            crate::fold::fold_into_triangle(simd, &mut self.r, block);
        } else if block.nrows() > 0 {
            self.stack(block);
        }
        self.rows_seen += block.nrows();
        Ok(())
    }

    /// Checks a block (width, finiteness) and says whether it is folded by
    /// the structured reflections (the block non-empty and narrow, the
    /// vector kernels available: their token) rather than by the stacked
    /// QR: onto a full R, or onto an empty one when the block has at least
    /// as many rows as columns — R then starts as the n×n zero triangle,
    /// and the fold of [0; B] is the Householder QR of B (the reflections
    /// of a column with a zero head; R's rows up to sign), without the
    /// general blocked QR's set-up for every fresh accumulator (the modal
    /// scan's parts start one per pattern for each block of a stream).
    fn folds(&mut self, block: &DMatrix<f64>) -> Result<Option<crate::simd::Avx2Fma>> {
        check_cols("block", block, self.ncols)?;
        check_finite("block", block)?;
        let n = self.ncols;
        let (m, k) = (block.nrows(), self.r.nrows());
        let fresh = k == 0 && self.rows_seen == 0 && m >= n;
        let structured = m > 0 && n > 0 && n <= NARROW_COLUMNS && (k == n || fresh);
        let simd = crate::simd::Avx2Fma::detect().filter(|_| structured);
        if simd.is_some() && fresh {
            self.r = DMatrix::zeros(n, n);
        }
        Ok(simd)
    }

    /// R of [R; block] by the Householder QR of the stacked copy.
    fn stack(&mut self, block: &DMatrix<f64>) {
        let (k, n) = (self.r.nrows(), self.ncols);
        let mut stacked = DMatrix::zeros(k + block.nrows(), n);
        stacked.rows_mut(0, k).copy_from(&self.r);
        stacked.rows_mut(k, block.nrows()).copy_from(block);
        self.r = r_in_place(stacked);
    }

    /// The current R, min(rows_seen, ncols)×ncols upper triangular.
    pub fn r(&self) -> DMatrix<f64> {
        self.r.clone()
    }

    /// Number of rows pushed so far.
    pub fn rows_seen(&self) -> usize {
        self.rows_seen
    }

    /// Number of columns.
    pub fn ncols(&self) -> usize {
        self.ncols
    }

    /// Whether the stored factor has the accumulator's shape (at most
    /// `ncols` rows, `ncols` columns): a check for states decoded from
    /// bytes.
    pub fn is_consistent(&self) -> bool {
        self.r.ncols() == self.ncols && self.r.nrows() <= self.ncols
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn small_qr_identities() {
        let a = DMatrix::from_row_slice(3, 2, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let t = qr_thin(&a).unwrap();
        assert_eq!((t.q.shape(), t.r.shape()), ((3, 2), (2, 2)));
        assert_relative_eq!(&t.q * &t.r, a, epsilon = 1e-14);
        let f = qr_full(&a).unwrap();
        assert_eq!((f.q.shape(), f.r.shape()), ((3, 3), (3, 2)));
        assert_relative_eq!(&f.q * &f.r, a, epsilon = 1e-14);
        let r = qr_r(&a).unwrap();
        assert_relative_eq!(r.transpose() * &r, a.transpose() * &a, epsilon = 1e-13);
        assert_eq!(r[(1, 0)], 0.0);
    }

    #[test]
    fn accumulator_rejects_wrong_width() {
        let mut acc = RAccumulator::new(3);
        assert!(acc.push_rows(&DMatrix::zeros(2, 4)).is_err());
        assert_eq!(acc.rows_seen(), 0);
        assert_eq!(acc.r().shape(), (0, 3));
        acc.push_rows(&DMatrix::zeros(0, 3)).unwrap();
        acc.push_rows(&DMatrix::from_element(2, 3, 1.0)).unwrap();
        assert_eq!((acc.rows_seen(), acc.r().shape()), (2, (2, 3)));
    }

    /// A fresh accumulator's first block of at least n rows is folded onto
    /// the zero triangle (the structured fold, where AVX2/FMA run): R is
    /// that of the stacked QR up to row signs, by either entry point and
    /// for later blocks too; a first block of fewer rows keeps its m rows.
    #[test]
    fn a_fresh_accumulator_folds_its_first_block() {
        let n = 17;
        let rows = |m: usize, seed: usize| {
            DMatrix::from_fn(m, n, |i, j| {
                (((i + seed) * 7919 + j * 104_729) % 1009) as f64 / 1009.0 - 0.5
                    + f64::from(u8::from(i == j))
            })
        };
        let (b1, b2) = (rows(1000, 0), rows(300, 5));
        let mut stacked = DMatrix::zeros(1300, n);
        stacked.rows_mut(0, 1000).copy_from(&b1);
        stacked.rows_mut(1000, 300).copy_from(&b2);
        let want = qr_r(&stacked).unwrap();
        let mut folded = RAccumulator::new(n);
        folded.fold_rows(&mut b1.clone()).unwrap();
        folded.push_rows(&b2).unwrap();
        let mut pushed = RAccumulator::new(n);
        pushed.push_rows(&b1).unwrap();
        pushed.push_rows(&b2).unwrap();
        for acc in [&folded, &pushed] {
            let r = acc.r();
            assert_eq!((r.shape(), acc.rows_seen()), ((n, n), 1300));
            for i in 0..n {
                let sign = if (r[(i, i)] > 0.0) == (want[(i, i)] > 0.0) {
                    1.0
                } else {
                    -1.0
                };
                for j in 0..n {
                    let d = (sign * r[(i, j)] - want[(i, j)]).abs();
                    assert!(d <= 1e-12 * want[(i, i)].abs(), "R[{i},{j}] off by {d:e}");
                }
            }
        }
        let mut short = RAccumulator::new(n);
        short.push_rows(&rows(5, 1)).unwrap();
        assert_eq!(short.r().shape(), (5, n));
    }
}

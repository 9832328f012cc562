//! Streaming compression of block-Hankel data.
//!
//! The block-Hankel matrix H (rows = stacked lagged signals, one column per
//! time instant) is never formed. Its transpose is built `chunk_rows`
//! time instants at a time and folded into an R-only QR
//! ([`lifted_linalg::RAccumulator`]): Hᵀ = Q R, so H = L Qᵀ with L = Rᵀ
//! (k×k lower triangular, k = number of Hankel rows). Every row-space
//! operation of the subspace methods (orthogonal and oblique projections,
//! weights, covariances) acts on the rows of H only through inner products,
//! so it can be carried out on L instead of H: the results differ by the
//! right factor Qᵀ, which changes neither the column spaces, the singular
//! values nor the covariances.
//!
//! Cost: each chunk of b rows costs ≈ 2(k + b)k² flops, in total
//! ≈ 2Jk²(1 + k/b) for J columns; memory O(k² + b·k), independent of J.
//!
//! The compression sits behind the small [`Compressor`] interface so that a
//! Hankel-structure-exploiting variant (or a Cholesky-of-correlation one)
//! can replace the Householder accumulation later.

use lifted_linalg::RAccumulator;
use nalgebra::DMatrix;

use crate::Result;

/// Internal interface of a data compressor: rows of Hᵀ in, L out.
pub(crate) trait Compressor {
    /// Folds a block of rows of Hᵀ into the compressed factor.
    fn push(&mut self, block: &DMatrix<f64>) -> Result<()>;
    /// Rows pushed so far.
    fn rows_seen(&self) -> usize;
    /// The lower-triangular factor L (k×k) with H Hᵀ = L Lᵀ.
    fn lower_factor(&self) -> DMatrix<f64>;
}

/// Householder R-only QR accumulated over row blocks.
pub(crate) struct QrCompressor {
    acc: RAccumulator,
}

impl QrCompressor {
    pub(crate) fn new(ncols: usize) -> Self {
        QrCompressor {
            acc: RAccumulator::new(ncols),
        }
    }
}

impl Compressor for QrCompressor {
    fn push(&mut self, block: &DMatrix<f64>) -> Result<()> {
        Ok(self.acc.push_rows(block)?)
    }
    fn rows_seen(&self) -> usize {
        self.acc.rows_seen()
    }
    fn lower_factor(&self) -> DMatrix<f64> {
        let r = self.acc.r();
        let k = self.acc.ncols();
        // Pad to k×k if fewer rows than columns were seen (callers check J ≥ k).
        let mut l = DMatrix::zeros(k, k);
        for i in 0..r.nrows().min(k) {
            for j in i..k {
                l[(j, i)] = r[(i, j)];
            }
        }
        l
    }
}

/// Layout of the block-Hankel rows [U_f; U_p; Y_p; Y_f] (thesis §2.4 ordering,
/// erratum L-3) for past horizon `past` and future horizon `future`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct HankelLayout {
    pub past: usize,
    pub future: usize,
    pub nu: usize,
    pub ny: usize,
}

impl HankelLayout {
    /// Number of Hankel rows k = (p + f)(n_u + n_y).
    pub(crate) fn nrows(&self) -> usize {
        (self.past + self.future) * (self.nu + self.ny)
    }
    /// Columns contributed by a record of `n` samples.
    pub(crate) fn columns(&self, n: usize) -> usize {
        (n + 1).saturating_sub(self.past + self.future)
    }
    pub(crate) fn uf(&self) -> std::ops::Range<usize> {
        0..self.future * self.nu
    }
    pub(crate) fn up(&self) -> std::ops::Range<usize> {
        let s = self.future * self.nu;
        s..s + self.past * self.nu
    }
    pub(crate) fn yp(&self) -> std::ops::Range<usize> {
        let s = (self.future + self.past) * self.nu;
        s..s + self.past * self.ny
    }
    pub(crate) fn yf(&self) -> std::ops::Range<usize> {
        let s = (self.future + self.past) * self.nu + self.past * self.ny;
        s..s + self.future * self.ny
    }

    /// Writes the Hankel column of "present" time t (t ≥ past) into `out`.
    fn fill(&self, u: &DMatrix<f64>, y: &DMatrix<f64>, t: usize, out: &mut [f64]) {
        let (p, f, nu, ny) = (self.past, self.future, self.nu, self.ny);
        let mut idx = 0;
        for lag in 0..f {
            for j in 0..nu {
                out[idx] = u[(t + lag, j)];
                idx += 1;
            }
        }
        for lag in 0..p {
            for j in 0..nu {
                out[idx] = u[(t - p + lag, j)];
                idx += 1;
            }
        }
        for lag in 0..p {
            for j in 0..ny {
                out[idx] = y[(t - p + lag, j)];
                idx += 1;
            }
        }
        for lag in 0..f {
            for j in 0..ny {
                out[idx] = y[(t + lag, j)];
                idx += 1;
            }
        }
    }
}

/// Compresses the block-Hankel data of all records into L/√J (k×k), J the
/// total number of columns. Records must already be validated.
pub(crate) fn compress(
    records: &[(&DMatrix<f64>, &DMatrix<f64>)],
    layout: &HankelLayout,
    chunk_rows: usize,
) -> Result<(DMatrix<f64>, usize)> {
    let k = layout.nrows();
    let mut comp = QrCompressor::new(k);
    let b = chunk_rows.max(1);
    let mut row = vec![0.0; k];
    let mut total = 0;
    for (u, y) in records {
        let cols = layout.columns(u.nrows());
        let mut start = 0;
        while start < cols {
            let len = b.min(cols - start);
            let mut block = DMatrix::zeros(len, k);
            for r in 0..len {
                layout.fill(u, y, layout.past + start + r, &mut row);
                for (c, v) in row.iter().enumerate() {
                    block[(r, c)] = *v;
                }
            }
            comp.push(&block)?;
            start += len;
        }
        total += cols;
    }
    let mut l = comp.lower_factor();
    if total > 0 {
        l /= (total as f64).sqrt();
    }
    debug_assert_eq!(comp.rows_seen(), total);
    Ok((l, total))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compressed_gram_matches_explicit_hankel() {
        let n = 57;
        let u = DMatrix::from_fn(n, 2, |i, j| ((i * 7 + j * 3) % 11) as f64 - 5.0);
        let y = DMatrix::from_fn(n, 1, |i, _| ((i * i) % 13) as f64 * 0.1);
        let lay = HankelLayout {
            past: 3,
            future: 2,
            nu: 2,
            ny: 1,
        };
        let (l, j) = compress(&[(&u, &y)], &lay, 7).unwrap();
        assert_eq!(j, n - 4);
        let k = lay.nrows();
        let mut h = DMatrix::zeros(k, j);
        let mut col = vec![0.0; k];
        for t in 0..j {
            lay.fill(&u, &y, t + 3, &mut col);
            for r in 0..k {
                h[(r, t)] = col[r];
            }
        }
        let g1 = &h * h.transpose() / j as f64;
        let g2 = &l * l.transpose();
        assert!((g1 - g2).norm() < 1e-9 * h.norm_squared() / j as f64);
        // ordering: first Uf row is u(t, 0) at t = past
        assert_eq!(h[(lay.uf().start, 0)], u[(3, 0)]);
        assert_eq!(h[(lay.yf().start, 0)], y[(3, 0)]);
        assert_eq!(h[(lay.yp().start, 0)], y[(0, 0)]);
    }
}

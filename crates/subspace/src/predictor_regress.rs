//! (B̃, K, D, x₀) of an innovations model by least squares on the
//! one-step predictor, for given (Ã, C) (step 5 of [`crate::pbsid_identify`]).
//!
//! With Ã = A − K C fixed, the predictor output
//!
//! ```text
//! ŷ(t) = C Ã^t x₀ + Σ_{s<t} C Ã^{t−1−s} (B̃ u(s) + K y(s)) + D u(t)          (8)
//! ```
//!
//! is linear in (B̃, K, D, x₀), and y(t) − ŷ(t) = e(t) is the innovation,
//! uncorrelated with every regressor (they depend on data before t, and
//! on u(t) only through D): the regression is consistent in closed loop,
//! like the VARX (3), but uses the whole past through Ã instead of p lags.
//! This is how PARSIM-K (Qin, Lin & Ljung 2005) and SSARX (Jansson 2003)
//! finish; it needs the records (a second reading of the data), and
//! A = Ã + K C, B = B̃ + K D follow.
//!
//! The regressor of entry (i, j) of [B̃ K] is C X_j(t) e_i with
//! X_j(t + 1) = Ã X_j(t) + z_j(t) I (n×n, z = [u; y]), so all n n_z of
//! them cost n³ n_z flops per sample; the rows are folded into an R-only
//! QR ([`lifted_linalg::RAccumulator`]) in blocks, memory O(q²) for q
//! parameters whatever N, time O(N n_y q² + N n³ n_z).

use lifted_linalg::RAccumulator;
use nalgebra::{DMatrix, DVector};

use crate::error::Result;
use crate::estimated::Record;

/// Samples folded into the QR at a time.
const BLOCK: usize = 2048;

/// The re-estimated innovations model.
pub(crate) struct PredictorFit {
    pub b: DMatrix<f64>,
    pub k: DMatrix<f64>,
    pub d: DMatrix<f64>,
    pub a: DMatrix<f64>,
    pub x0: Vec<DVector<f64>>,
    /// Innovation covariance of the re-estimated predictor on the records.
    pub innovation_covariance: DMatrix<f64>,
}

/// Least squares (8) for (B̃, K, D (entries where `mask`), and x₀ per
/// record when `with_x0`, else x₀ = 0) with (Ã, C) fixed; Ã must be
/// stable (the caller checks).
pub(crate) fn predictor_regression(
    a_pred: &DMatrix<f64>,
    c: &DMatrix<f64>,
    mask: &DMatrix<bool>,
    records: &[Record<'_>],
    with_x0: bool,
) -> Result<PredictorFit> {
    let n = a_pred.nrows();
    let (ny, nu) = mask.shape();
    let nz = nu + ny;
    let free_d: Vec<(usize, usize)> = (0..ny)
        .flat_map(|i| (0..nu).map(move |j| (i, j)))
        .filter(|&(i, j)| mask[(i, j)])
        .collect();
    let n_bk = n * nz;
    let n_x0 = if with_x0 { n * records.len() } else { 0 };
    let q = n_bk + free_d.len() + n_x0;
    let mut acc = RAccumulator::new(q + 1);
    for (r, rec) in records.iter().enumerate() {
        let samples = rec.u.nrows();
        // X = [X_0 … X_{n_z−1}] (n × n n_z); Φ = C Ã^t.
        let mut x = DMatrix::<f64>::zeros(n, n_bk);
        let mut next = DMatrix::<f64>::zeros(n, n_bk);
        let mut cx = DMatrix::<f64>::zeros(ny, n_bk);
        let mut phi = c.clone();
        let mut phi_next = c.clone();
        let mut t0 = 0;
        while t0 < samples {
            let len = BLOCK.min(samples - t0);
            let mut rows = DMatrix::zeros(len * ny, q + 1);
            for dt in 0..len {
                let t = t0 + dt;
                cx.gemm(1.0, c, &x, 0.0);
                for o in 0..ny {
                    let row = dt * ny + o;
                    // Column j n + i holds (C X_j)[o, i]: entry (i, j) of [B̃ K].
                    for col in 0..n_bk {
                        let (j, i) = (col / n, col % n);
                        rows[(row, i * nz + j)] = cx[(o, col)];
                    }
                    for (m, &(oi, j)) in free_d.iter().enumerate() {
                        if oi == o {
                            rows[(row, n_bk + m)] = rec.u[(t, j)];
                        }
                    }
                    if with_x0 {
                        let base = n_bk + free_d.len() + r * n;
                        for i in 0..n {
                            rows[(row, base + i)] = phi[(o, i)];
                        }
                    }
                    rows[(row, q)] = rec.y[(t, o)];
                }
                // X(t+1) = Ã X(t) + [z_0(t) I … z_{n_z−1}(t) I].
                next.gemm(1.0, a_pred, &x, 0.0);
                for j in 0..nz {
                    let zj = if j < nu {
                        rec.u[(t, j)]
                    } else {
                        rec.y[(t, j - nu)]
                    };
                    for i in 0..n {
                        next[(i, j * n + i)] += zj;
                    }
                }
                std::mem::swap(&mut x, &mut next);
                phi_next.gemm(1.0, &phi, a_pred, 0.0);
                std::mem::swap(&mut phi, &mut phi_next);
            }
            acc.push_rows(&rows)?;
            t0 += len;
        }
    }
    let rfac = acc.r();
    let theta = if rfac.nrows() > q {
        lifted_linalg::lstsq(
            &rfac.view((0, 0), (q, q)).into_owned(),
            &rfac.view((0, q), (q, 1)).into_owned(),
        )?
    } else {
        let k = rfac.nrows();
        lifted_linalg::lstsq(
            &rfac.columns(0, q).into_owned(),
            &rfac.view((0, q), (k, 1)).into_owned(),
        )?
    };
    let mut bk = DMatrix::zeros(n, nz);
    for i in 0..n {
        for j in 0..nz {
            bk[(i, j)] = theta[i * nz + j];
        }
    }
    let b_pred = bk.columns(0, nu).into_owned();
    let k = bk.columns(nu, ny).into_owned();
    let mut d = DMatrix::zeros(ny, nu);
    for (m, &(i, j)) in free_d.iter().enumerate() {
        d[(i, j)] = theta[n_bk + m];
    }
    let x0: Vec<DVector<f64>> = (0..records.len())
        .map(|r| {
            let base = n_bk + free_d.len() + r * n;
            DVector::from_fn(n, |i, _| if with_x0 { theta[base + i] } else { 0.0 })
        })
        .collect();
    let innovation_covariance = innovations(a_pred, &b_pred, &k, c, &d, records, &x0);
    Ok(PredictorFit {
        a: a_pred + &k * c,
        b: &b_pred + &k * &d,
        k,
        d,
        x0,
        innovation_covariance,
    })
}

/// Sample covariance of the one-step prediction errors of the predictor
/// (Ã, B̃, K, C, D) from x₀ over all records.
fn innovations(
    a_pred: &DMatrix<f64>,
    b_pred: &DMatrix<f64>,
    k: &DMatrix<f64>,
    c: &DMatrix<f64>,
    d: &DMatrix<f64>,
    records: &[Record<'_>],
    x0: &[DVector<f64>],
) -> DMatrix<f64> {
    let ny = c.nrows();
    let mut cov = DMatrix::zeros(ny, ny);
    let mut count = 0usize;
    for (rec, x0) in records.iter().zip(x0) {
        let mut x = x0.clone();
        for t in 0..rec.u.nrows() {
            let u = rec.u.row(t).transpose();
            let y = rec.y.row(t).transpose();
            let e = &y - c * &x - d * &u;
            cov += &e * e.transpose();
            x = a_pred * &x + b_pred * &u + k * &y;
        }
        count += rec.u.nrows();
    }
    cov / count.max(1) as f64
}

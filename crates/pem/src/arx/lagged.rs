//! The lagged data of an ARX regression, compressed once: the factor of
//! the Gram matrix of every lagged signal, and least squares on any subset
//! of its columns without a further pass over the data.
//!
//! With z(t) = [u(t); y(t)] and a longest lag L, the regressor of every ARX
//! structure whose lags are at most L is a subset of the rows of the
//! block-Hankel column [z(t − L); …; z(t)]. `lifted_subspace::compress_hankel`
//! (past horizon L − 1, future horizon 2: a span of L + 1 samples, at
//! least 3) gives the k×k factor 𝓛 with
//! H Hᵀ/J = 𝓛 𝓛ᵀ (k = (L + 1)(n_u + n_y), J = N − L columns), from the
//! lagged correlations of the data (≈ 2 N n_z² (L + 1) flops, one pass)
//! with the R-only QR as the fallback when the correlations are ill
//! conditioned. Hᵀ = Q (√J 𝓛ᵀ) for an orthonormal Q, so 𝓛ᵀ stands in for
//! the data matrix in every least-squares problem on its columns: for the
//! columns S of the regressors and t of the target, the thin QR
//! 𝓛ᵀ[S t] = U T gives θ = T₁₁⁻¹ t₁₂ and the mean squared residual
//! V = t₂₂² exactly as the QR of the N-row data would (the normal equations
//! are never formed). Each solve costs O(k d²) for d regressors.

use lifted_subspace::{Compression, CompressionReport, Experiment, hankel_row_sources};
use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result};

/// Relative size of a diagonal entry of T below which a regressor is taken
/// as a linear combination of the others (numerical rank of the regressor
/// matrix), scaled by the number of regressors.
const RANK_TOLERANCE: f64 = 1e-10;

/// The compressed lagged data of a set of records.
pub(crate) struct Lagged {
    /// 𝓛ᵀ: k×k upper triangular; its columns are the lagged signals.
    lt: DMatrix<f64>,
    /// Column of 𝓛ᵀ of each (lag, channel): index lag·n_z + channel.
    position: Vec<usize>,
    /// Longest lag L.
    lags: usize,
    nu: usize,
    ny: usize,
    /// Regression rows J (time instants with every lag available).
    pub rows: usize,
    /// How the factor was obtained.
    pub report: CompressionReport,
}

/// One least-squares solve on a subset of the lagged columns.
pub(crate) struct Solve {
    /// Coefficients of the regressor columns, in the order given.
    pub theta: DVector<f64>,
    /// Mean squared residual over the J rows.
    pub loss: f64,
    /// U of the thin QR 𝓛ᵀ[S] = U T₁₁ (k×d), for covariances across outputs.
    pub u: DMatrix<f64>,
    /// T₁₁ (d×d upper triangular).
    pub t: DMatrix<f64>,
    /// The residual in the factor's coordinates: 𝓛ᵀ[S t] [−θ; 1] (k),
    /// whose inner products are mean products of the residuals over the
    /// J rows.
    pub residual: DVector<f64>,
}

/// A regressor column: the signal `channel` of z = [u; y] delayed by `lag`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Column {
    pub lag: usize,
    pub channel: usize,
}

/// A compression's error for `samples` samples: a record too short for
/// the lags as [`Error::TooFewSamples`] of the ARX regression, the rest as
/// they are.
pub(crate) fn too_short(e: lifted_subspace::Error, samples: usize) -> Error {
    match e {
        lifted_subspace::Error::HorizonTooLong { min_samples, .. } => Error::TooFewSamples {
            what: "the ARX regression (every lag and channel)",
            measured: samples,
            needed: min_samples,
        },
        e => e.into(),
    }
}

impl Lagged {
    /// Compresses `experiments` for lags 0..=`lags`. O(N n_z² L) flops (the
    /// correlations) or O(N k²) (the QR fallback); memory O(k²).
    pub(crate) fn new(
        experiments: &[Experiment<'_>],
        lags: usize,
        compression: Compression,
        threads: usize,
    ) -> Result<Self> {
        let first = experiments.first().ok_or(Error::NoData)?;
        let (nu, ny) = (first.u.ncols(), first.y.ncols());
        let (past, future) = Self::horizons(lags);
        let samples: usize = experiments.iter().map(|e| e.u.nrows()).sum();
        let factor =
            lifted_subspace::compress_hankel(experiments, past, future, compression, threads)
                .map_err(|e| too_short(e, samples))?;
        Ok(Self::from_factor(factor, past, future, nu, ny))
    }

    /// The lagged data of a Hankel factor of horizons (`past`, `future`)
    /// (rows as [`hankel_row_sources`] orders them), as [`Lagged::new`]
    /// makes it; lags 0..=past + future − 1.
    pub(crate) fn from_factor(
        factor: lifted_subspace::HankelFactor,
        past: usize,
        future: usize,
        nu: usize,
        ny: usize,
    ) -> Self {
        let span = past + future;
        let nz = nu + ny;
        let sources = hankel_row_sources(past, future, nu, ny);
        let mut position = vec![0; span * nz];
        for (row, &(offset, channel)) in sources.iter().enumerate() {
            // Row r holds z_channel(t − (span − 1) + offset) for the target
            // time t: lag span − 1 − offset.
            position[(span - 1 - offset) * nz + channel] = row;
        }
        Lagged {
            lt: factor.l.transpose(),
            position,
            lags: span - 1,
            nu,
            ny,
            rows: factor.columns,
            report: factor.report,
        }
    }

    /// The compression's horizons (past, future) for lags 0..=`lags`: a
    /// Hankel column spans lags 0..=L, past L − 1 and future 2 block rows
    /// (the compression's smallest future horizon), at least past 1.
    pub(crate) fn horizons(lags: usize) -> (usize, usize) {
        let span = (lags + 1).max(3);
        (span - 2, 2)
    }

    /// Inputs n_u.
    pub(crate) fn nu(&self) -> usize {
        self.nu
    }

    /// Outputs n_y.
    pub(crate) fn ny(&self) -> usize {
        self.ny
    }

    /// The column of input `k` at `lag`.
    pub(crate) fn input(k: usize, lag: usize) -> Column {
        Column { lag, channel: k }
    }

    /// The column of output `j` at `lag` (for this data's n_u).
    pub(crate) fn output(&self, j: usize, lag: usize) -> Column {
        Column {
            lag,
            channel: self.nu + j,
        }
    }

    fn column(&self, c: Column) -> usize {
        debug_assert!(c.lag <= self.lags);
        self.position[c.lag * (self.nu + self.ny) + c.channel]
    }

    /// 𝓛ᵀ restricted to `columns` (k × len).
    fn gather(&self, columns: &[Column]) -> DMatrix<f64> {
        let k = self.lt.nrows();
        let mut m = DMatrix::zeros(k, columns.len());
        for (i, &c) in columns.iter().enumerate() {
            m.set_column(i, &self.lt.column(self.column(c)));
        }
        m
    }

    /// The upper-triangular R ((d + 1) × (d + 1)) of the data matrix
    /// [Φ y] of `regressors` and `target` over the J rows, in the data's
    /// scale (RᵀR = [Φ y]ᵀ[Φ y]): √J times the R of the factor's columns.
    /// O(k d²).
    pub(crate) fn r_factor(&self, regressors: &[Column], target: Column) -> Result<DMatrix<f64>> {
        let mut cols = regressors.to_vec();
        cols.push(target);
        let r = lifted_linalg::qr_r(&self.gather(&cols))?;
        let d = cols.len();
        let mut out = DMatrix::zeros(d, d);
        let rows = r.nrows().min(d);
        out.view_mut((0, 0), (rows, d)).copy_from(&r.rows(0, rows));
        Ok(out * (self.rows as f64).sqrt())
    }

    /// Least squares of `target` on `regressors`: O(k d²).
    ///
    /// Errors: [`Error::RankDeficient`] when a regressor is (numerically) a
    /// combination of the others (a lag structure the data do not
    /// determine: a non-exciting input, or an output tied to the inputs).
    pub(crate) fn solve(&self, regressors: &[Column], target: Column) -> Result<Solve> {
        let d = regressors.len();
        let mut cols = regressors.to_vec();
        cols.push(target);
        let m = self.gather(&cols);
        let qr = lifted_linalg::qr_thin(&m)?;
        let r = qr.r;
        let scale = (0..d).map(|i| r[(i, i)].abs()).fold(0.0, f64::max);
        let rank = (0..d)
            .filter(|&i| r[(i, i)].abs() > RANK_TOLERANCE * scale.max(f64::MIN_POSITIVE))
            .count();
        if rank < d {
            return Err(Error::RankDeficient {
                what: "the ARX regressors (lagged inputs and outputs)",
                rank,
                needed: d,
            });
        }
        let t = r.view((0, 0), (d, d)).into_owned();
        let rhs = r.view((0, d), (d, 1)).column(0).into_owned();
        let theta = t.solve_upper_triangular(&rhs).ok_or(Error::RankDeficient {
            what: "the ARX regressors (lagged inputs and outputs)",
            rank: 0,
            needed: d,
        })?;
        let loss = if r.nrows() > d {
            r[(d, d)].powi(2)
        } else {
            0.0
        };
        let mut coef = DVector::zeros(d + 1);
        coef.rows_mut(0, d).copy_from(&(-&theta));
        coef[d] = 1.0;
        let residual = &m * &coef;
        let u = qr.q.columns(0, d).into_owned();
        Ok(Solve {
            theta,
            loss,
            u,
            t,
            residual,
        })
    }

    /// Mean squared residual of `target − regressors·θ` over this data's
    /// rows (a held-out loss of coefficients fitted elsewhere): O(k d).
    pub(crate) fn loss_of(
        &self,
        regressors: &[Column],
        target: Column,
        theta: &DVector<f64>,
    ) -> f64 {
        let mut cols = regressors.to_vec();
        cols.push(target);
        let m = self.gather(&cols);
        let mut coef = DVector::zeros(theta.len() + 1);
        coef.rows_mut(0, theta.len()).copy_from(&(-theta));
        coef[theta.len()] = 1.0;
        (&m * &coef).norm_squared()
    }

    /// Mean square of output `i` over the rows (the loss of the zero
    /// predictor). O(k).
    pub(crate) fn mean_square(&self, i: usize) -> f64 {
        self.lt
            .column(self.column(self.output(i, 0)))
            .norm_squared()
    }
}

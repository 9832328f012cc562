//! Streaming compression of block-Hankel data.
//!
//! The block-Hankel matrix H (rows = stacked lagged signals, one column per
//! time instant) is never formed. Two compressions produce the same k×k
//! lower-triangular factor L with H Hᵀ/J = L Lᵀ (k = number of Hankel rows,
//! J = number of columns). Every row-space operation of the subspace methods
//! (orthogonal and oblique projections, weights, covariances) acts on the
//! rows of H only through inner products, so it can be carried out on L
//! instead of H: the results differ by a right orthogonal factor, which
//! changes neither the column spaces, the singular values nor the
//! covariances.
//!
//! * [`Compression::Qr`], the accurate reference: Hᵀ is built `chunk_rows`
//!   time instants at a time and folded into an R-only QR
//!   ([`lifted_linalg::RAccumulator`]), Hᵀ = Q R, L = Rᵀ/√J. Cost
//!   ≈ 2Jk²(1 + k/b) flops for blocks of b rows.
//! * [`Compression::Correlation`] exploits the Hankel structure: with
//!   z(t) = [u(t); y(t)] (n_z = n_u + n_y channels) and s = p + f block rows,
//!   every entry of H Hᵀ is a lagged correlation
//!   Σ_j z_c(j + o₁) z_d(j + o₂), which equals the full-record sum
//!   S_cd(δ) = Σ_t z_c(t) z_d(t + δ), δ = o₂ − o₁ < s, minus at most 2s
//!   boundary products. One pass over the data accumulates the s matrices
//!   S(δ) (≈ 2 N n_z² s flops: a register-tiled AVX2/FMA kernel over
//!   interleaved cache-sized blocks, [`crate::lagged`], optionally split over
//!   threads; for s ≥ 24 by FFT over blocks of ≥ 32 s samples,
//!   O(N (n_z log s + n_z² + n_z² s/64)), in the same module: 1.6× faster
//!   at s = 40), the boundary corrections cost
//!   O(k² s) per record, and L is the Cholesky factor of H Hᵀ/J. As
//!   SLICOT's IB01AD with ALG = 'C', squaring the data costs accuracy when H
//!   is ill conditioned, so [`Compression::Auto`] checks the factor
//!   (Cholesky breakdown, or reciprocal condition of H Hᵀ below
//!   [`CORRELATION_RCOND_MIN`]) and falls back to the QR, reporting why.
//!
//! Memory: O(k² + b·k) for the QR, O(n_z² s + n_z (s + b)) plus the k×k
//! Gram for the correlations, independent of N; [`HankelStream`] takes the
//! data in blocks of any size (one record after the other).

use lifted_linalg::RAccumulator;
use nalgebra::{DMatrix, DMatrixView};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::lagged::{Channel, Scratch, channel_sums_par};
use crate::numerics::Scale;

/// Smallest reciprocal condition number (λ_min/λ_max) of the correlation
/// matrix H Hᵀ accepted by [`Compression::Auto`] and
/// [`Compression::Correlation`]. The Cholesky factor of a Gram matrix has
/// relative errors ≈ k ε/rcond in its smallest directions; at 1e-8 they stay
/// below ≈ 4e-6 for k = 160 (and at rounding level on well-conditioned
/// data), below it the QR is used.
pub const CORRELATION_RCOND_MIN: f64 = 1e-8;

/// Samples per block when in-memory records are streamed (bounds the
/// working copy to 64 Ki samples per channel).
const PUSH_BLOCK: usize = 1 << 16;

/// Which compression of the block-Hankel data [`crate::identify`] uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Compression {
    /// Correlations and Cholesky (structure-exploiting, ≈ 2 N n_z² s flops,
    /// fewer by FFT for s ≥ 24);
    /// falls back to the R-only QR when the correlation matrix is not
    /// numerically positive definite or its reciprocal condition is below
    /// [`CORRELATION_RCOND_MIN`] (reported in
    /// [`CompressionReport::fallback`]). Default. For
    /// [`crate::StreamingIdentifier`] the data cannot be read twice: there
    /// the fallback is an [`Error::IllConditionedCorrelation`] asking for
    /// [`Compression::Qr`].
    #[default]
    Auto,
    /// Correlations and Cholesky only; [`Error::IllConditionedCorrelation`]
    /// when the check fails.
    Correlation,
    /// R-only Householder QR of Hᵀ streamed over row blocks (≈ 2Jk² flops),
    /// the accurate reference.
    Qr,
}

/// What the compression did (part of [`crate::Diagnostics`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CompressionReport {
    /// The compression requested.
    pub requested: Compression,
    /// The compression whose factor was used: [`Compression::Correlation`]
    /// or [`Compression::Qr`].
    pub used: Compression,
    /// Reciprocal condition number λ_min/λ_max of H Hᵀ when the correlation
    /// route was tried (NaN otherwise, or when its Cholesky broke down):
    /// exact near the threshold, else a short power-iteration estimate (at
    /// or above the true value) once the threshold is proven by Cholesky
    /// factorisations of shifted copies of H Hᵀ.
    pub rcond: f64,
    /// Why the correlation factor was rejected and the QR used instead (the
    /// analogue of SLICOT's IWARN = 2), `None` when no fallback happened.
    pub fallback: Option<String>,
    /// Approximate flop count of the compression actually run
    /// (QR: 2Jk²(1 + k/b); correlations: 2 N n_z² s + k³/3).
    pub flops: f64,
    /// Threads used by the correlation kernel.
    pub threads: usize,
}

/// The compressed data: L (k×k lower triangular) with H Hᵀ/J = L Lᵀ.
#[derive(Debug, Clone, PartialEq)]
pub struct HankelFactor {
    /// The factor L, rows in the order [U_f; U_p; Y_p; Y_f] (thesis §2.4).
    pub l: DMatrix<f64>,
    /// Hankel columns J over all records.
    pub columns: usize,
    /// How it was obtained.
    pub report: CompressionReport,
    /// A proven lower bound of λ_min/λ_max of L Lᵀ: [`CORRELATION_RCOND_MIN`]
    /// when the correlation route's factorisation of the shifted Gram
    /// matrix certified it (`lifted_linalg::cholesky_condition`), 0
    /// otherwise (the QR route, or a condition only estimated). Every
    /// diagonal block of L then has σ_min/σ_max above about its square
    /// root, which the projections' block tests use instead of inverting
    /// the blocks (`crate::oblique::Projector`).
    pub certified_rcond: f64,
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
    /// Block rows s = p + f (the span of one Hankel column in samples).
    pub(crate) fn span(&self) -> usize {
        self.past + self.future
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

    /// Row of the factor of each natural index o·n_z + c (offset o,
    /// channel c).
    pub(crate) fn positions(&self) -> Vec<usize> {
        let nz = self.nu + self.ny;
        let mut position = vec![0; self.span() * nz];
        for (r, &(o, c)) in self.sources().iter().enumerate() {
            position[o * nz + c] = r;
        }
        position
    }

    /// (offset, channel) of every Hankel row: row r of the column of
    /// "present" time t holds z_channel(t − p + offset), channels u first.
    pub(crate) fn sources(&self) -> Vec<(usize, usize)> {
        let (p, f, nu, ny) = (self.past, self.future, self.nu, self.ny);
        let mut out = Vec::with_capacity(self.nrows());
        for lag in 0..f {
            out.extend((0..nu).map(|j| (p + lag, j)));
        }
        for lag in 0..p {
            out.extend((0..nu).map(|j| (lag, j)));
        }
        for lag in 0..p {
            out.extend((0..ny).map(|j| (lag, nu + j)));
        }
        for lag in 0..f {
            out.extend((0..ny).map(|j| (p + lag, nu + j)));
        }
        out
    }
}

/// (offset, channel) of every row of the factor of [`crate::compress_hankel`]
/// for horizons (`past`, `future`) and `nu` + `ny` channels, in the
/// factor's row order: row r of the Hankel column of "present" time t holds
/// z_channel(t − past + offset), z = [u; y] (channels u first). The
/// regressions that read the factor (ARX in `lifted-pem`) locate their
/// lagged signals by it. O(k).
pub fn hankel_row_sources(past: usize, future: usize, nu: usize, ny: usize) -> Vec<(usize, usize)> {
    HankelLayout {
        past,
        future,
        nu,
        ny,
    }
    .sources()
}

/// Per-method state of a [`HankelStream`].
enum Engine {
    Qr {
        acc: RAccumulator,
        chunk_rows: usize,
        sources: Vec<(usize, usize)>,
    },
    Correlation {
        /// S(δ) of the current record.
        s: Vec<f64>,
        /// Gram matrix of the completed records, in the row order of the
        /// factor (sources order); 0×0 until a record yields a column, so
        /// that a horizon too long for the data is reported without the
        /// k×k allocation.
        gram: DMatrix<f64>,
        /// Row of the factor of each natural index o·n_z + c (offset o,
        /// channel c).
        position: Vec<usize>,
        /// First s − 1 samples of the current record, per channel.
        head: Vec<Vec<f64>>,
        threads: usize,
        /// Kernel work space, one per thread (kept across blocks).
        scratch: Vec<Scratch>,
    },
}

/// Block-by-block compression of one or more records of (u, y) data.
///
/// Feed each record with any number of [`HankelStream::push`] calls (blocks
/// of consecutive samples), call [`HankelStream::end_record`] between
/// records and [`HankelStream::finish`] at the end. Only the last s − 1
/// samples are kept between blocks.
pub(crate) struct HankelStream {
    layout: HankelLayout,
    engine: Engine,
    /// Samples of the current record not yet used as a column start
    /// (the last ≤ s − 1), per channel.
    carry: Vec<Vec<f64>>,
    /// The next block's carry while it is built (correlation engine).
    next_carry: Vec<Vec<f64>>,
    /// Samples of the current record so far.
    record_len: usize,
    /// Columns of the completed records.
    columns: usize,
    /// Samples seen (all records).
    samples: usize,
    requested: Compression,
    /// Factors 1/s_u, 1/s_y applied to the samples as they are copied in.
    inv_scale: [f64; 2],
    /// Remove the pooled per-channel means (see [`HankelStream::set_centering`]).
    center: bool,
    /// Σ (z_c − r_c) over all samples of all records (scaled), per channel.
    sums: Vec<f64>,
    /// With centring, the reference r_c (mean of the first block, scaled)
    /// subtracted from every sample as it is copied in, so that the final
    /// correction removes a small residual mean instead of cancelling a
    /// large offset in the squared data.
    reference: Vec<f64>,
    /// Set by [`HankelStream::set_reference`]: the first block does not
    /// choose the reference.
    fixed_reference: bool,
    /// Σ z_c over the current record, per channel.
    record_sums: Vec<f64>,
    /// Window sums W_r = Σ_j H_{r,j} of every Hankel row (sources order),
    /// completed records (correlation engine; the QR engine carries them in
    /// its column of ones).
    window_sums: Vec<f64>,
}

impl HankelStream {
    pub(crate) fn new(
        layout: HankelLayout,
        compression: Compression,
        chunk_rows: usize,
        threads: usize,
    ) -> Self {
        let nz = layout.nu + layout.ny;
        let k = layout.nrows();
        let engine = match compression {
            Compression::Qr => Engine::Qr {
                acc: RAccumulator::new(k),
                chunk_rows: chunk_rows.max(1),
                sources: layout.sources(),
            },
            Compression::Auto | Compression::Correlation => Engine::Correlation {
                s: vec![0.0; layout.span() * nz * nz],
                gram: DMatrix::zeros(0, 0),
                position: layout.positions(),
                head: vec![Vec::new(); nz],
                threads: threads.max(1),
                scratch: (0..threads.max(1)).map(|_| Scratch::default()).collect(),
            },
        };
        HankelStream {
            layout,
            engine,
            carry: vec![Vec::new(); nz],
            next_carry: vec![Vec::new(); nz],
            record_len: 0,
            columns: 0,
            samples: 0,
            requested: compression,
            inv_scale: [1.0, 1.0],
            center: false,
            sums: vec![0.0; nz],
            reference: vec![0.0; nz],
            fixed_reference: false,
            record_sums: vec![0.0; nz],
            window_sums: vec![0.0; k],
        }
    }

    /// Makes the factor that of the Hankel data with the row of ones
    /// projected out: every Hankel row less its own mean over the columns,
    /// Σ_j (h_j − h̄)(h_j − h̄)ᵀ. A constant offset anywhere in the data (an
    /// operating point, or the O(1/N) constant left after removing the
    /// record means from a response that started at rest) then drops out of
    /// the projections exactly, so it cannot appear as a mode at z = 1.
    /// No second pass: the correlation engine corrects its Gram matrix with
    /// the window sums W of the Hankel rows (− W Wᵀ/J), the QR engine
    /// carries a column of ones and keeps the trailing block of R. Call
    /// before the first push.
    pub(crate) fn set_centering(&mut self, center: bool) {
        self.center = center;
        if center && let Engine::Qr { acc, .. } = &mut self.engine {
            *acc = RAccumulator::new(self.layout.nrows() + 1);
        }
    }

    /// The pooled per-channel means of the (scaled) samples pushed so far,
    /// the open record's included (its sums join `sums` only when it ends).
    pub(crate) fn means(&self) -> Vec<f64> {
        let n = self.samples.max(1) as f64;
        self.sums
            .iter()
            .zip(&self.record_sums)
            .zip(&self.reference)
            .map(|((s, o), r)| (s + o) / n + r)
            .collect()
    }

    /// Fixes the centring reference r_c (per channel, in the units of the
    /// scaled samples) instead of taking the mean of the first block, so
    /// that pieces of one record compressed apart share it
    /// ([`crate::CompressionPlan`]). Call before the first push.
    pub(crate) fn set_reference(&mut self, reference: Vec<f64>) {
        debug_assert_eq!(reference.len(), self.reference.len());
        self.reference = reference;
        self.fixed_reference = true;
    }

    /// Divides every later sample by the scales (powers of 4, exact) of
    /// `scale`: inputs by s_u, outputs by s_y.
    pub(crate) fn set_scale(&mut self, scale: Scale) {
        self.inv_scale = [1.0 / scale.u, 1.0 / scale.y];
    }

    /// Appends consecutive samples of the current record: `u` (b×n_u) and
    /// `y` (b×n_y), already checked for shape and finiteness.
    pub(crate) fn push(&mut self, u: DMatrixView<'_, f64>, y: DMatrixView<'_, f64>) -> Result<()> {
        let b = u.nrows();
        if b == 0 {
            return Ok(());
        }
        let span = self.layout.span();
        let nz = self.carry.len();
        if self.center && self.samples == 0 && !self.fixed_reference {
            let bf = b as f64;
            for c in 0..nz {
                // Column slices: the vectorised sum (nalgebra's is one
                // dependent chain through an iterator).
                self.reference[c] = if c < self.layout.nu {
                    lifted_linalg::kernels::sum(u.column(c).data.into_slice()) * self.inv_scale[0]
                        / bf
                } else {
                    lifted_linalg::kernels::sum(y.column(c - self.layout.nu).data.into_slice())
                        * self.inv_scale[1]
                        / bf
                };
            }
        }
        if let Engine::Correlation {
            s,
            head,
            threads,
            scratch,
            ..
        } = &mut self.engine
        {
            // Fused: the kernel reads the carry and the caller's columns,
            // scaling and centring while it interleaves (no working copy).
            let held = self.carry[0].len();
            let total = held + b;
            let chans: Vec<Channel<'_>> = self
                .carry
                .iter()
                .enumerate()
                .map(|(c, carry)| {
                    let (col, inv) = if c < self.layout.nu {
                        (u.column(c), self.inv_scale[0])
                    } else {
                        (y.column(c - self.layout.nu), self.inv_scale[1])
                    };
                    Channel {
                        carry,
                        new: col.data.into_slice(),
                        scale: inv,
                        offset: self.reference[c],
                    }
                })
                .collect();
            if self.record_len < span - 1 {
                let want = (span - 1 - self.record_len).min(b);
                for (h, ch) in head.iter_mut().zip(&chans) {
                    h.extend((held..held + want).map(|t| ch.at(t)));
                }
            }
            let starts = (total + 1).saturating_sub(span);
            if starts > 0 {
                channel_sums_par(&chans, span, starts, s, *threads, scratch);
            }
            if self.center {
                for (sum, ch) in self.record_sums.iter_mut().zip(&chans) {
                    *sum += lifted_linalg::kernels::sum(ch.new) * ch.scale - b as f64 * ch.offset;
                }
            }
            // Keep the last ≤ s − 1 samples (prepared) for the next block.
            let keep = total - starts;
            for (next, ch) in self.next_carry.iter_mut().zip(&chans) {
                next.clear();
                next.extend((starts..total).map(|t| ch.at(t)));
                debug_assert_eq!(next.len(), keep);
            }
            drop(chans);
            std::mem::swap(&mut self.carry, &mut self.next_carry);
            self.record_len += b;
            self.samples += b;
            return Ok(());
        }
        // QR: working buffer per channel, the carry followed by the new
        // samples (the vectors keep their capacity: no allocation after the
        // first block of the largest size).
        for (c, v) in self.carry.iter_mut().enumerate() {
            let (col, inv) = if c < self.layout.nu {
                (u.column(c), self.inv_scale[0])
            } else {
                (y.column(c - self.layout.nu), self.inv_scale[1])
            };
            let from = v.len();
            let r = self.reference[c];
            v.extend(col.iter().map(|x| x * inv - r));
            if self.center {
                self.record_sums[c] += v[from..].iter().sum::<f64>();
            }
        }
        let buf = &self.carry;
        let len = buf[0].len();
        // Column starts with a complete Hankel column inside the buffer.
        let starts = (len + 1).saturating_sub(span);
        match &mut self.engine {
            Engine::Correlation { .. } => unreachable!("the correlation engine returned above"),
            Engine::Qr {
                acc,
                chunk_rows,
                sources,
            } => {
                let k = sources.len();
                // With centring, column 0 holds ones (window sums in R).
                let first = usize::from(self.center);
                let mut start = 0;
                while start < starts {
                    let rows = (*chunk_rows).min(starts - start);
                    let mut block = DMatrix::zeros(rows, k + first);
                    if self.center {
                        block.column_mut(0).fill(1.0);
                    }
                    for (r, &(off, ch)) in sources.iter().enumerate() {
                        let src = &buf[ch][start + off..start + off + rows];
                        block.column_mut(r + first).copy_from_slice(src);
                    }
                    acc.push_rows(&block)?;
                    start += rows;
                }
            }
        }
        // Keep the samples not yet used as a column start (≤ s − 1).
        for v in &mut self.carry {
            v.drain(..starts);
        }
        self.record_len += b;
        self.samples += b;
        Ok(())
    }

    /// Closes the current record; the next push starts a new one.
    pub(crate) fn end_record(&mut self) {
        let span = self.layout.span();
        let n = self.record_len;
        let cols = self.layout.columns(n);
        for (total, rec) in self.sums.iter_mut().zip(&self.record_sums) {
            *total += *rec;
        }
        if let Engine::Correlation {
            s,
            gram,
            position,
            head,
            ..
        } = &mut self.engine
        {
            if cols > 0 {
                if gram.nrows() == 0 {
                    let k = self.layout.nrows();
                    *gram = DMatrix::zeros(k, k);
                }
                complete_tail(s, &self.carry, span);
                fold_record(
                    &self.layout,
                    position,
                    RecordSums {
                        s,
                        head,
                        tail: &self.carry,
                        len: n,
                        sums: &self.record_sums,
                    },
                    self.center,
                    gram,
                    &mut self.window_sums,
                );
            }
            s.iter_mut().for_each(|v| *v = 0.0);
            head.iter_mut().for_each(|h| h.clear());
        }
        self.columns += cols;
        self.record_len = 0;
        self.carry.iter_mut().for_each(|c| c.clear());
        self.record_sums.iter_mut().for_each(|v| *v = 0.0);
    }

    /// The lag sums and boundary samples of the data pushed since the last
    /// record end, as one [`Piece`] of a record (correlation engine only,
    /// `None` for the QR); the stream starts a new record afterwards.
    pub(crate) fn take_piece(&mut self) -> Option<Piece> {
        let span = self.layout.span();
        let Engine::Correlation { s, head, .. } = &mut self.engine else {
            return None;
        };
        complete_tail(s, &self.carry, span);
        let piece = Piece {
            s: std::mem::replace(s, vec![0.0; s.len()]),
            head: std::mem::replace(head, vec![Vec::new(); self.carry.len()]),
            tail: std::mem::replace(&mut self.carry, vec![Vec::new(); self.next_carry.len()]),
            len: self.record_len,
            sums: std::mem::replace(&mut self.record_sums, vec![0.0; self.next_carry.len()]),
        };
        self.record_len = 0;
        Some(piece)
    }

    /// Hankel columns so far (completed records plus the current one).
    pub(crate) fn columns(&self) -> usize {
        self.columns + self.layout.columns(self.record_len)
    }

    /// Closes the last record and returns the factor L/√J. For the
    /// correlation route the check of [`Compression::Auto`] is applied and
    /// a failure is returned as [`Error::IllConditionedCorrelation`] (the
    /// caller decides whether it can fall back).
    pub(crate) fn finish(mut self) -> Result<HankelFactor> {
        if self.record_len > 0 {
            self.end_record();
        }
        let k = self.layout.nrows();
        let j = self.columns;
        let nz = self.carry.len();
        let span = self.layout.span();
        let scale = if j > 0 { 1.0 / j as f64 } else { 0.0 };
        match self.engine {
            Engine::Qr {
                acc, chunk_rows, ..
            } => {
                let mut r = acc.r();
                if self.center {
                    // R = [ρ wᵀ; 0 R₁] for [1, Hᵀ]: R₁ᵀR₁ = Σ(h − h̄)(h − h̄)ᵀ.
                    let kk = r.nrows().min(k + 1);
                    r = if kk > 1 {
                        r.view((1, 1), (kk - 1, k)).into_owned()
                    } else {
                        DMatrix::zeros(0, k)
                    };
                }
                let mut l = DMatrix::zeros(k, k);
                for i in 0..r.nrows().min(k) {
                    for c in i..k {
                        l[(c, i)] = r[(i, c)];
                    }
                }
                l *= scale.sqrt();
                let b = chunk_rows as f64;
                let kf = k as f64;
                Ok(HankelFactor {
                    l,
                    columns: j,
                    report: CompressionReport {
                        requested: self.requested,
                        used: Compression::Qr,
                        rcond: f64::NAN,
                        fallback: None,
                        flops: 2.0 * j as f64 * kf * kf * (1.0 + kf / b),
                        threads: 1,
                    },
                    certified_rcond: 0.0,
                })
            }
            Engine::Correlation { gram, threads, .. } => correlation_factor(
                gram,
                &self.window_sums,
                j,
                CompressionWork {
                    requested: self.requested,
                    samples: self.samples,
                    nz,
                    span,
                    threads,
                },
            ),
        }
    }
}

/// What a correlation compression did, for its [`CompressionReport`].
pub(crate) struct CompressionWork {
    pub requested: Compression,
    pub samples: usize,
    pub nz: usize,
    pub span: usize,
    pub threads: usize,
}

/// The factor L/√J of the correlation route from the Gram matrix H Hᵀ of
/// all records (0×0 when no record gave a column) and, with centring, the
/// window sums W of the Hankel rows (zeros otherwise), with the checks of
/// [`Compression::Auto`] ([`Error::IllConditionedCorrelation`]). O(k³/3).
pub(crate) fn correlation_factor(
    mut g: DMatrix<f64>,
    w: &[f64],
    columns: usize,
    work: CompressionWork,
) -> Result<HankelFactor> {
    let k = w.len();
    if g.nrows() == 0 {
        // No record gave a column (the callers report that first).
        g = DMatrix::zeros(k, k);
    }
    let scale = if columns > 0 {
        1.0 / columns as f64
    } else {
        0.0
    };
    // Σ(h − h̄)(h − h̄)ᵀ/J = (HHᵀ − W Wᵀ/J)/J (W = 0 without centring), in
    // place, column by contiguous column (vectorised).
    let kk = g.nrows();
    for (col, &wc) in g.as_mut_slice().chunks_exact_mut(kk.max(1)).zip(w) {
        for (v, &wr) in col.iter_mut().zip(w) {
            *v = (*v - wr * wc * scale) * scale;
        }
    }
    let kf = k as f64;
    let flops =
        2.0 * work.samples as f64 * (work.nz * work.nz * work.span) as f64 + kf * kf * kf / 3.0;
    let (l, rcond, certified_rcond) = cholesky_checked(g)?;
    Ok(HankelFactor {
        l,
        columns,
        certified_rcond,
        report: CompressionReport {
            requested: work.requested,
            used: Compression::Correlation,
            rcond,
            fallback: None,
            flops,
            threads: work.threads,
        },
    })
}

/// Lag sums and boundary samples of a contiguous piece of one record
/// (scaled, less the reference): everything the correlation compression
/// needs from it. Pieces of a record concatenate ([`Piece::append`]), and a
/// whole record folds into the Gram matrix ([`fold_record`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct Piece {
    /// S(δ) = Σ z(t) z(t + δ)ᵀ over the t with t and t + δ in the piece,
    /// entry (δ n_z + c) n_z + e for channels c, e and δ < s.
    pub s: Vec<f64>,
    /// The first min(s − 1, len) samples, per channel.
    pub head: Vec<Vec<f64>>,
    /// The last min(s − 1, len) samples, per channel.
    pub tail: Vec<Vec<f64>>,
    /// Samples in the piece.
    pub len: usize,
    /// Σ z_c over the piece, per channel (kept with centring only).
    pub sums: Vec<f64>,
}

impl Piece {
    /// The piece of the samples of `self` followed by those of `next`:
    /// the lag sums gain the products that straddle the boundary (only
    /// the last s − 1 samples of `self` and the first s − 1 of `next` take
    /// part, O(s² n_z²)). Associative up to rounding.
    pub(crate) fn append(mut self, next: Piece, span: usize) -> Piece {
        let nz = self.head.len();
        let keep = span - 1;
        for (a, b) in self.s.iter_mut().zip(&next.s) {
            *a += b;
        }
        // t in self (index tail_start + i of the tail), t + δ in next.
        let tl = self.tail.first().map_or(0, Vec::len);
        let hl = next.head.first().map_or(0, Vec::len);
        for d in 1..span {
            for back in 1..=d.min(tl) {
                // t = len − back, t + δ = len − back + d: index d − back of next.
                let j = d - back;
                if j >= hl {
                    continue;
                }
                for c in 0..nz {
                    let zc = self.tail[c][tl - back];
                    for e in 0..nz {
                        self.s[(d * nz + c) * nz + e] += zc * next.head[e][j];
                    }
                }
            }
        }
        for c in 0..nz {
            if self.head[c].len() < keep {
                let more = (keep - self.head[c].len()).min(next.head[c].len());
                let add: Vec<f64> = next.head[c][..more].to_vec();
                self.head[c].extend(add);
            }
            let mut tail = std::mem::take(&mut self.tail[c]);
            if next.tail[c].len() < keep {
                tail.extend_from_slice(&next.tail[c]);
                let drop = tail.len().saturating_sub(keep);
                tail.drain(..drop);
            } else {
                tail.clone_from(&next.tail[c]);
            }
            self.tail[c] = tail;
        }
        for (a, b) in self.sums.iter_mut().zip(&next.sums) {
            *a += b;
        }
        self.len += next.len;
        self
    }
}

/// Borrowed [`Piece`] of a whole record, as [`fold_record`] reads it.
pub(crate) struct RecordSums<'a> {
    pub s: &'a [f64],
    pub head: &'a [Vec<f64>],
    pub tail: &'a [Vec<f64>],
    pub len: usize,
    pub sums: &'a [f64],
}

/// Completes the lag sums S(δ) with the start positions t held in `tail`
/// (the last ≤ s − 1 samples, whose products t + δ fall inside it): the
/// kernel sums only the starts of complete Hankel columns.
fn complete_tail(s: &mut [f64], tail: &[Vec<f64>], span: usize) {
    let nz = tail.len();
    let tl = tail.first().map_or(0, Vec::len);
    for t in 0..tl {
        for d in 0..(tl - t).min(span) {
            for c in 0..nz {
                let zc = tail[c][t];
                for e in 0..nz {
                    s[(d * nz + c) * nz + e] += zc * tail[e][t + d];
                }
            }
        }
    }
}

/// Adds the Hankel Gram matrix Σ_j h_j h_jᵀ of one whole record (at least
/// one column) to `gram` (rows in the factor's order, `position` from
/// [`HankelLayout::positions`]) from its full lag sums, and with centring
/// its window sums W_r = Σ_j H_{r,j} to `window_sums`: O(s² n_z²).
pub(crate) fn fold_record(
    layout: &HankelLayout,
    position: &[usize],
    rec: RecordSums<'_>,
    center: bool,
    gram: &mut DMatrix<f64>,
    window_sums: &mut [f64],
) {
    let span = layout.span();
    let n = rec.len;
    let cols = layout.columns(n);
    let nz = rec.head.len();
    let (s, head, tail) = (rec.s, rec.head, rec.tail);
    let tl = tail[0].len();
    // z(t) for t < s − 1 (head) and t ≥ N − (s − 1) (tail).
    let tail_start = n - tl;
    let at = |ch: usize, t: usize| -> f64 {
        if t < head[ch].len() {
            head[ch][t]
        } else {
            tail[ch][t - tail_start]
        }
    };
    if center {
        // W_r = Σ_{j<J} z_c(j + o) = record sum − head − tail.
        for (r, &(o, c)) in layout.sources().iter().enumerate() {
            let mut w = rec.sums[c];
            for t in 0..o {
                w -= at(c, t);
            }
            for t in (o + cols)..n {
                w -= at(c, t);
            }
            window_sums[r] += w;
        }
    }
    // Natural order: index o·n_z + c for offset o, channel c.
    // Σ_{j<J} z_c1(j+o1) z_c2(j+o1+δ) = S(δ) − Σ_{t<o1} − Σ_{t=o1+J}^{N−1−δ}:
    // both corrections are running sums over o1, O(s² n_z²) in all.
    // The head holds z(0 … s−2) and the tail z(J … N−1)
    // (tail_start = J as soon as a column exists), so both
    // corrections read plain slices.
    debug_assert_eq!(tail_start, cols);
    // For one (δ, c1) the running sums of every c2 side by side (entry
    // o1·n_z + c2): n_z independent chains per step instead of one, each
    // summed in the same order as alone (same bits).
    let k = gram.nrows();
    let g = gram.as_mut_slice();
    let mut head_part = vec![0.0; span * nz];
    let mut tail_part = vec![0.0; span * nz];
    let mut acc = vec![0.0; nz];
    for d in 0..span {
        let m = span - d;
        for c1 in 0..nz {
            let (h1, t1) = (&head[c1][..m - 1], &tail[c1][..m - 1]);
            // head_part[o1][c2] = Σ_{t<o1} z_c1(t) z_c2(t+δ).
            acc.fill(0.0);
            for (o1, &a) in h1.iter().enumerate() {
                let row = &mut head_part[o1 * nz..(o1 + 1) * nz];
                for (c2, (h, s)) in row.iter_mut().zip(acc.iter_mut()).enumerate() {
                    *h = *s;
                    *s += a * head[c2][o1 + d];
                }
            }
            head_part[(m - 1) * nz..m * nz].copy_from_slice(&acc);
            // tail_part[o1][c2] = Σ_{t=o1+J}^{N−1−δ} z_c1(t) z_c2(t+δ).
            acc.fill(0.0);
            tail_part[(m - 1) * nz..m * nz].fill(0.0);
            for o1 in (0..m - 1).rev() {
                let a = t1[o1];
                let row = &mut tail_part[o1 * nz..(o1 + 1) * nz];
                for (c2, (t, s)) in row.iter_mut().zip(acc.iter_mut()).enumerate() {
                    *s += a * tail[c2][o1 + d];
                    *t = *s;
                }
            }
            for o1 in 0..m {
                let i = position[o1 * nz + c1];
                for c2 in 0..nz {
                    let sd = s[(d * nz + c1) * nz + c2];
                    let v = sd - head_part[o1 * nz + c2] - tail_part[o1 * nz + c2];
                    let j = position[(o1 + d) * nz + c2];
                    // Equal offsets visit both (c1, c2) and (c2, c1).
                    g[j * k + i] += v;
                    if d != 0 {
                        g[i * k + j] += v;
                    }
                }
            }
        }
    }
}

/// Cholesky factor of the Gram matrix with the definiteness and condition
/// checks of [`Compression::Auto`], the reported rcond and the proven
/// lower bound of [`HankelFactor::certified_rcond`].
fn cholesky_checked(g: DMatrix<f64>) -> Result<(DMatrix<f64>, f64, f64)> {
    // rcond above the threshold proven by the Cholesky factorisation of a
    // shifted G (O(k³/3); no SVD), the common case, then G's own factor.
    let Some((l, proven)) = lifted_linalg::cholesky_condition(g, CORRELATION_RCOND_MIN)? else {
        return Err(Error::IllConditionedCorrelation {
            rcond: f64::NAN,
            min: CORRELATION_RCOND_MIN,
            reason:
                "the correlation matrix is not numerically positive definite (Cholesky breakdown)"
                    .into(),
        });
    };
    if proven {
        // Reported value: a short power-iteration estimate (at or above
        // the true rcond; the decision above is exact).
        let (smax, smin) = lifted_linalg::lower_triangular_extremes_within(&l, 3)?;
        let rcond = if smax > 0.0 {
            (smin / smax).powi(2)
        } else {
            0.0
        };
        return Ok((l, rcond.max(CORRELATION_RCOND_MIN), CORRELATION_RCOND_MIN));
    }
    // Otherwise σ_min/σ_max of L by O(k²) estimates when clearly above the
    // threshold (10× on the ratio), by the singular values near it.
    let check = lifted_linalg::triangular_condition(&l, CORRELATION_RCOND_MIN.sqrt(), 10.0)?;
    let rcond = check.ratio.powi(2);
    if rcond.is_nan() || rcond < CORRELATION_RCOND_MIN {
        return Err(Error::IllConditionedCorrelation {
            rcond,
            min: CORRELATION_RCOND_MIN,
            reason: format!(
                "reciprocal condition {rcond:.2e} of the correlation matrix below {CORRELATION_RCOND_MIN:.0e}: squaring the data would lose accuracy"
            ),
        });
    }
    Ok((l, rcond, 0.0))
}

/// Compresses the block-Hankel data of all records (already validated),
/// divided by `scale`, into L/√J (k×k), with the row of ones projected out
/// when `center` ([`HankelStream::set_centering`]); [`Compression::Auto`]
/// falls back to the QR when the correlation factor fails its check and
/// records why.
pub(crate) fn compress(
    records: &[(&DMatrix<f64>, &DMatrix<f64>)],
    layout: &HankelLayout,
    compression: Compression,
    chunk_rows: usize,
    threads: usize,
    scale: Scale,
    center: bool,
) -> Result<HankelFactor> {
    let run = |mode: Compression| -> Result<HankelFactor> {
        let mut st = HankelStream::new(*layout, mode, chunk_rows, threads);
        st.set_scale(scale);
        st.set_centering(center);
        // The QR copies each push into its working buffer: blocks of
        // PUSH_BLOCK samples bound it (it splits them into chunk_rows
        // columns). The correlation kernel reads the caller's columns and
        // blocks in cache itself, so a record goes in one push: its threads
        // start once per record and split the whole record between them.
        let block = match mode {
            Compression::Qr => PUSH_BLOCK,
            Compression::Auto | Compression::Correlation => usize::MAX,
        };
        for (u, y) in records {
            let n = u.nrows();
            let mut s = 0;
            while s < n {
                let len = block.min(n - s);
                st.push(u.rows(s, len), y.rows(s, len))?;
                s += len;
            }
            st.end_record();
        }
        st.finish()
    };
    match compression {
        Compression::Qr | Compression::Correlation => run(compression),
        Compression::Auto => match run(Compression::Auto) {
            Ok(f) => Ok(f),
            Err(Error::IllConditionedCorrelation { rcond, reason, .. }) => {
                let mut f = run(Compression::Qr)?;
                f.report.requested = Compression::Auto;
                f.report.rcond = rcond;
                f.report.fallback = Some(reason);
                Ok(f)
            }
            Err(e) => Err(e),
        },
    }
}

#[cfg(test)]
mod tests;

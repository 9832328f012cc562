//! Mergeable partial compressions: one record compressed in pieces on
//! different machines, the pieces merged associatively (a tree reduction
//! on Dask, Ray or a thread pool) and identified from the merged result.
//!
//! The correlation compression ([`crate::Compression::Correlation`], module
//! docs of `hankel`) needs from the data only the lagged sums
//! S(δ) = Σ_t z(t) z(t + δ)ᵀ (δ < s = p + f), the first and last s − 1
//! samples of each record and the channel sums. For a piece of a record the
//! sums run over the pairs (t, t + δ) inside the piece; two adjacent pieces
//! A, B concatenate by adding their sums and the products that straddle
//! the boundary, which involve only the last s − 1 samples of A and the
//! first s − 1 of B (O(s² n_z²)). The result is the piece of the
//! concatenated samples: concatenation is associative, so any tree of
//! merges gives the whole record's sums (up to the rounding of the
//! summation order). A closed record folds into the Hankel Gram matrix
//! H Hᵀ (k×k, k = s n_z), and Gram matrices of different records add.
//!
//! Every piece is compressed in the units of one [`CompressionPlan`]: the
//! data scale (powers of 4, exact) and the centring reference are fixed
//! before the first piece, from the first block of the record, as the
//! [`crate::StreamingIdentifier`] fixes them from its first push. The model
//! from merged pieces is therefore the model of the streaming identifier on
//! the whole record, up to rounding (poles and frequency response agree to
//! ≈ 1e-12 in the tests).
//!
//! Cost: compressing a piece of N_i samples is the correlation kernel,
//! ≈ 2 N_i n_z² s flops; a merge of pieces O(s² n_z²); closing a record
//! O(s² n_z² + k²); merging closed records O(k²); the identification
//! O(k³), independent of N. Sizes on the wire (CBOR, [`RecordPiece::to_bytes`]):
//! ≈ 9 (s n_z² + 2 s n_z) bytes per piece, ≈ 9 k² per closed set of records.
//!
//! Only the correlation route merges: when the merged correlation matrix
//! fails the conditioning check of [`crate::Compression::Auto`],
//! [`CompressedRecords::identify`] returns
//! [`Error::IllConditionedCorrelation`] (the QR reference needs the data
//! in one pass; identify the record with `Compression::Qr` then).
//!
//! The output-error (B, D, x₀) regression of the default route is a second
//! pass over the data: [`crate::StreamedSubspace::regression`] gives its
//! stream, fed the shards in order.

use lifted_linalg::budget::{MemoryBudget, Size};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::checks::{check_options, check_record_shape, thread_count};
use crate::error::{Error, Result};
use crate::hankel::{
    Compression, CompressionWork, HankelLayout, HankelStream, Piece, RecordSums,
    correlation_factor, fold_record,
};
use crate::numerics::{Scale, first_block_centring};
use crate::options::SubspaceOptions;
use crate::streaming::{StreamedParts, StreamedSubspace, streamed_subspace};
use crate::wire::{from_cbor, to_cbor};

/// The units every piece of a record is compressed in: horizons, data
/// scale and centring reference (see the module docs). Serialisable, so a
/// client can fix it and send it to the workers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CompressionPlan {
    n_inputs: usize,
    n_outputs: usize,
    past: usize,
    future: usize,
    remove_means: bool,
    /// Input and output scales s_u, s_y (powers of 4).
    scale: [f64; 2],
    /// Centring reference per channel, in scaled units (zeros without
    /// mean removal).
    reference: Vec<f64>,
}

/// A piece of a record compressed from blocks of consecutive samples
/// ([`CompressionPlan::stream`]).
pub struct PieceStream {
    plan: CompressionPlan,
    stream: HankelStream,
    threads: usize,
    /// Samples pushed so far (a bad sample's place in the piece).
    pushed: usize,
}

impl PieceStream {
    /// The next consecutive samples `u` (b×m), `y` (b×p).
    ///
    /// Errors: [`Error::DimensionMismatch`], [`Error::NonFinite`].
    pub fn push(&mut self, u: &DMatrix<f64>, y: &DMatrix<f64>) -> Result<()> {
        let (nu, ny) = (self.plan.n_inputs, self.plan.n_outputs);
        check_record_shape("piece (u, y)", "N", u, y, nu, ny)?;
        let result = crate::checks::check_data_on("u", u, self.threads)
            .and_then(|()| crate::checks::check_data_on("y", y, self.threads))
            .map_err(|e| e.after(self.pushed));
        self.pushed += u.nrows();
        result?;
        self.stream.push(u.as_view(), y.as_view())
    }

    /// The piece of the samples pushed.
    ///
    /// Errors: [`Error::InvalidOption`] when the compression kept no lag
    /// sums.
    pub fn finish(mut self) -> Result<RecordPiece> {
        // The correlation engine always keeps lag sums; the QR has none.
        let piece = self.stream.take_piece().ok_or(Error::InvalidOption {
            what: "compression",
            reason: "partial compressions need the correlation route".into(),
        })?;
        Ok(RecordPiece {
            plan: self.plan,
            piece,
        })
    }
}

impl CompressionPlan {
    /// The plan for records whose first samples are `u` (b×n_u) and `y`
    /// (b×n_y): any leading block, e.g. the first shard or its first
    /// 65 536 rows. The scale is the power of 4 nearest the RMS of the
    /// block (less its means when `opts.remove_means`), the centring
    /// reference its channel means, as [`crate::StreamingIdentifier`]
    /// takes them from its first push.
    ///
    /// Errors: [`Error::DimensionMismatch`], [`Error::NonFinite`],
    /// [`Error::NoData`] (empty block), and the option checks of
    /// [`crate::identify`] ([`Error::InvalidHorizon`],
    /// [`Error::OrderTooLarge`], [`lifted_linalg::Error::TooLarge`] (as [`Error::Linalg`]));
    /// [`Error::InvalidOption`] for `Compression::Qr`, which does not merge.
    pub fn from_first_block(
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        opts: &SubspaceOptions,
    ) -> Result<Self> {
        let (nu, ny) = (u.ncols(), y.ncols());
        if nu == 0 || ny == 0 {
            return Err(Error::DimensionMismatch {
                what: "u, y",
                expected: "at least one input and one output".into(),
                got: format!("{nu} inputs, {ny} outputs"),
            });
        }
        check_record_shape("first block (u, y)", "b", u, y, nu, ny)?;
        if u.nrows() == 0 {
            return Err(Error::NoData);
        }
        crate::error::check_data("u", u)?;
        crate::error::check_data("y", y)?;
        if opts.compression == Compression::Qr {
            return Err(Error::InvalidOption {
                what: "compression",
                reason: "partial compressions merge only on the correlation route \
                         (Compression::Auto or Correlation); the QR needs the record in one pass"
                    .into(),
            });
        }
        check_options(nu, ny, opts)?;
        let (scale, reference) = first_block_centring(u, y, opts.remove_means);
        let scale = [scale.u, scale.y];
        Ok(CompressionPlan {
            n_inputs: nu,
            n_outputs: ny,
            past: opts.past,
            future: opts.future,
            remove_means: opts.remove_means,
            scale,
            reference,
        })
    }

    /// (past, future) horizons of the plan.
    pub fn horizons(&self) -> (usize, usize) {
        (self.past, self.future)
    }

    /// (inputs, outputs) of the records the plan is for.
    pub fn channels(&self) -> (usize, usize) {
        (self.n_inputs, self.n_outputs)
    }

    /// Compact binary form (CBOR) for sending to the workers.
    ///
    /// Errors: [`Error::InvalidOption`] if encoding fails.
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        to_cbor(self)
    }

    /// The plan from [`to_bytes`](Self::to_bytes).
    ///
    /// Errors: [`Error::InvalidOption`] naming what is wrong with the bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self> {
        let p: CompressionPlan = from_cbor(bytes, "compression plan")?;
        let nz = p.n_inputs + p.n_outputs;
        let pow4 = |s: f64| s > 0.0 && s.is_finite();
        if p.n_inputs == 0
            || p.n_outputs == 0
            || p.past == 0
            || p.future < 2
            || p.reference.len() != nz
            || !pow4(p.scale[0])
            || !pow4(p.scale[1])
            || p.reference.iter().any(|r| !r.is_finite())
        {
            return Err(Error::InvalidOption {
                what: "compression plan",
                reason: "the decoded plan is inconsistent (corrupted bytes?)".into(),
            });
        }
        crate::budget::check_hankel(
            p.past,
            p.future,
            p.n_inputs,
            p.n_outputs,
            Compression::Correlation,
            1,
        )?;
        Ok(p)
    }

    fn layout(&self) -> HankelLayout {
        HankelLayout {
            past: self.past,
            future: self.future,
            nu: self.n_inputs,
            ny: self.n_outputs,
        }
    }

    /// Compresses consecutive samples `u` (N_i×n_u), `y` (N_i×n_y) of one
    /// record into a [`RecordPiece`], on `threads` threads (0 = all cores;
    /// the result depends on the count through rounding only).
    /// ≈ 2 N_i n_z² s flops, O(s n_z²) memory besides the data.
    ///
    /// Errors: [`Error::DimensionMismatch`] (channels differ from the
    /// plan's), [`Error::NonFinite`].
    pub fn compress(
        &self,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        threads: usize,
    ) -> Result<RecordPiece> {
        let mut stream = self.stream(threads);
        for (k, len) in crate::records::chunks(u.nrows()) {
            stream.push(&u.rows(k, len).into_owned(), &y.rows(k, len).into_owned())?;
        }
        stream.finish()
    }

    /// [`compress`](Self::compress) of samples fed in blocks: push them in
    /// order to the [`PieceStream`], then [`finish`](PieceStream::finish)
    /// it. Memory of one block whatever the piece's length (a shard read
    /// from a file block by block).
    pub fn stream(&self, threads: usize) -> PieceStream {
        let threads = thread_count(threads);
        let mut stream = HankelStream::new(self.layout(), Compression::Correlation, 1, threads);
        stream.set_scale(Scale {
            u: self.scale[0],
            y: self.scale[1],
        });
        stream.set_centering(self.remove_means);
        stream.set_reference(self.reference.clone());
        PieceStream {
            plan: self.clone(),
            stream,
            threads,
            pushed: 0,
        }
    }

    fn check_same(&self, other: &CompressionPlan, what: &'static str) -> Result<()> {
        if self == other {
            Ok(())
        } else {
            Err(Error::InvalidOption {
                what,
                reason: "the partial compressions were made with different plans (horizons, \
                         channels, scale or centring reference): compress every piece with one \
                         CompressionPlan"
                    .into(),
            })
        }
    }
}

/// The compressed statistics of a contiguous piece of one record
/// ([`CompressionPlan::compress`]); pieces concatenate with
/// [`RecordPiece::append`] and a whole record becomes
/// [`CompressedRecords`] with [`RecordPiece::close`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RecordPiece {
    plan: CompressionPlan,
    piece: Piece,
}

impl RecordPiece {
    /// The piece of the samples of `self` followed directly by those of
    /// `next` (the next samples of the same record). Associative up to
    /// rounding, O(s² n_z²).
    ///
    /// Errors: [`Error::InvalidOption`] when the plans differ.
    pub fn append(self, next: RecordPiece) -> Result<RecordPiece> {
        self.plan.check_same(&next.plan, "piece")?;
        let span = self.plan.past + self.plan.future;
        Ok(RecordPiece {
            piece: self.piece.append(next.piece, span),
            plan: self.plan,
        })
    }

    /// Samples in the piece.
    pub fn len(&self) -> usize {
        self.piece.len
    }

    /// Whether the piece holds no sample.
    pub fn is_empty(&self) -> bool {
        self.piece.len == 0
    }

    /// The plan the piece was compressed with.
    pub fn plan(&self) -> &CompressionPlan {
        &self.plan
    }

    /// Closes the record: the piece must hold the whole record. Its Hankel
    /// Gram matrix (none when it is shorter than s samples: such a record
    /// only adds to the means) joins [`CompressedRecords`]. O(s² n_z² + k²).
    ///
    /// Errors: [`lifted_linalg::Error::TooLarge`] (as [`Error::Linalg`]) when the k×k matrix exceeds the memory
    /// budget.
    pub fn close(self) -> Result<CompressedRecords> {
        let layout = self.plan.layout();
        let k = layout.nrows();
        let nz = layout.nu + layout.ny;
        let cols = layout.columns(self.piece.len);
        let mut gram = DMatrix::zeros(0, 0);
        let mut window = vec![0.0; k];
        if cols > 0 {
            MemoryBudget::default().check(
                "closing a compressed record (Hankel Gram matrix)",
                Size::matrices(1, k, k),
            )?;
            gram = DMatrix::zeros(k, k);
            fold_record(
                &layout,
                &layout.positions(),
                RecordSums {
                    s: &self.piece.s,
                    head: &self.piece.head,
                    tail: &self.piece.tail,
                    len: self.piece.len,
                    sums: &self.piece.sums,
                },
                self.plan.remove_means,
                &mut gram,
                &mut window,
            );
        }
        let sums = if self.plan.remove_means {
            self.piece.sums.clone()
        } else {
            vec![0.0; nz]
        };
        Ok(CompressedRecords {
            gram: gram.as_slice().to_vec(),
            window,
            columns: cols,
            records: vec![self.piece.len],
            sums,
            plan: self.plan,
        })
    }

    /// Compact binary form (CBOR) for sending between processes.
    ///
    /// Errors: [`Error::InvalidOption`] if encoding fails.
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        to_cbor(self)
    }

    /// The piece from [`to_bytes`](Self::to_bytes).
    ///
    /// Errors: [`Error::InvalidOption`] naming what is wrong with the bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self> {
        let p: RecordPiece = from_cbor(bytes, "piece")?;
        p.check_shapes()?;
        Ok(p)
    }

    fn check_shapes(&self) -> Result<()> {
        let l = self.plan.layout();
        let nz = l.nu + l.ny;
        let span = l.span();
        let keep = self.piece.len.min(span - 1);
        let ok = self.plan.reference.len() == nz
            && self.piece.s.len() == span * nz * nz
            && self.piece.head.len() == nz
            && self.piece.tail.len() == nz
            && self.piece.head.iter().all(|h| h.len() == keep)
            && self.piece.tail.iter().all(|t| t.len() == keep)
            && self.piece.sums.len() == nz;
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidOption {
                what: "piece",
                reason: "the decoded piece is inconsistent with its plan (corrupted bytes?)".into(),
            })
        }
    }
}

/// The Hankel factor of compressed records and the units it is in
/// ([`CompressedRecords::factor`]).
#[derive(Debug, Clone)]
pub struct LaggedFactor {
    /// The factor, its Hankel columns and how it was obtained.
    pub factor: crate::HankelFactor,
    /// The input and output scales s_u, s_y the data were divided by
    /// (powers of 4).
    pub scale: [f64; 2],
    /// The channel means [u; y] in the scaled units (removed from the
    /// factor when the plan removes means; the centring reference
    /// otherwise zero).
    pub means: Vec<f64>,
    /// Samples over the records.
    pub samples: usize,
}

/// The compressed data of one or more whole records, ready to identify;
/// merges with others made with the same plan ([`CompressedRecords::merge`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CompressedRecords {
    plan: CompressionPlan,
    /// Σ over records of H Hᵀ (k×k column-major), empty when no record gave
    /// a Hankel column.
    gram: Vec<f64>,
    /// Σ over records of the Hankel row sums W (centring).
    window: Vec<f64>,
    /// Hankel columns J.
    columns: usize,
    /// Samples of each record, in merge order.
    records: Vec<usize>,
    /// Channel sums of the scaled samples less the reference.
    sums: Vec<f64>,
}

impl CompressedRecords {
    /// The records of `self` and of `other` together (record order: those
    /// of `self` first). O(k²).
    ///
    /// Errors: [`Error::InvalidOption`] when the plans differ.
    pub fn merge(mut self, other: CompressedRecords) -> Result<CompressedRecords> {
        self.plan.check_same(&other.plan, "compressed records")?;
        if self.gram.is_empty() {
            self.gram = other.gram;
        } else if !other.gram.is_empty() {
            for (a, b) in self.gram.iter_mut().zip(&other.gram) {
                *a += b;
            }
        }
        for (a, b) in self.window.iter_mut().zip(&other.window) {
            *a += b;
        }
        for (a, b) in self.sums.iter_mut().zip(&other.sums) {
            *a += b;
        }
        self.columns += other.columns;
        self.records.extend(other.records);
        Ok(self)
    }

    /// Samples of each record, in merge order.
    pub fn records(&self) -> &[usize] {
        &self.records
    }

    /// Hankel columns over all records.
    pub fn columns(&self) -> usize {
        self.columns
    }

    /// The plan the records were compressed with.
    pub fn plan(&self) -> &CompressionPlan {
        &self.plan
    }

    /// Samples over the records and the channel means [u; y] in the plan's
    /// units, once there are at least `k` Hankel columns.
    ///
    /// Errors: [`Error::HorizonTooLong`] (fewer Hankel columns than rows).
    fn samples_and_means(&self, k: usize) -> Result<(usize, Vec<f64>)> {
        let plan = &self.plan;
        let samples: usize = self.records.iter().sum();
        if self.columns < k {
            return Err(Error::HorizonTooLong {
                past: plan.past,
                future: plan.future,
                n_samples: samples,
                min_samples: k + (plan.past + plan.future - 1) * self.records.len().max(1),
            });
        }
        let n = samples.max(1) as f64;
        let means = self
            .sums
            .iter()
            .zip(&plan.reference)
            .map(|(s, r)| s / n + r)
            .collect();
        Ok((samples, means))
    }

    /// The records' Hankel factor L (H Hᵀ/J = L Lᵀ, rows in the order of
    /// [`crate::hankel_row_sources`] for the plan's horizons) for a
    /// least-squares use of the lagged data other than the subspace step
    /// (the ARX regression of `lifted-pem` from a streamed file), with the
    /// units it is in: the data divided by the plan's scales (s_u, s_y),
    /// less the channel means over all the samples when the plan removes
    /// them (the samples centred, then compressed; the subspace step
    /// centres each Hankel row by its own mean instead). `compression`
    /// as [`crate::Compression::Auto`] or `Correlation` (the check of the
    /// correlation's conditioning; the QR needs the record in one pass),
    /// `threads` for the factorisation. O(k³).
    ///
    /// Errors: [`Error::HorizonTooLong`] (fewer Hankel columns than rows),
    /// [`Error::IllConditionedCorrelation`] (identify the records in one
    /// pass with the QR then), [`Error::InvalidOption`] for
    /// `Compression::Qr`.
    pub fn factor(self, compression: Compression, threads: usize) -> Result<LaggedFactor> {
        if compression == Compression::Qr {
            return Err(Error::InvalidOption {
                what: "compression",
                reason: "compressed records factor by their correlations; the QR needs the record in one pass".into(),
            });
        }
        let layout = self.plan.layout();
        let k = layout.nrows();
        let (samples, means) = self.samples_and_means(k)?;
        let n = samples.max(1) as f64;
        let plan = self.plan;
        let mut gram = if self.gram.is_empty() {
            DMatrix::zeros(0, 0)
        } else {
            DMatrix::from_vec(k, k, self.gram)
        };
        // Centred by the channel means m of all the samples (the samples
        // less their means, then the Gram matrix: least squares on the
        // centred record), not by each Hankel row's own mean W/J (the
        // subspace step's centring): Σ_j (h_j − m)(h_j − m)ᵀ = (HHᵀ −
        // W Wᵀ/J) + d dᵀ/J with d = W − J m, small where the two means
        // agree; `correlation_factor` subtracts W Wᵀ/J.
        if plan.remove_means && gram.nrows() == k {
            let jf = self.columns as f64;
            let d: Vec<f64> = layout
                .sources()
                .iter()
                .zip(&self.window)
                .map(|(&(_, c), w)| w - jf * self.sums[c] / n)
                .collect();
            for (c, mut col) in gram.column_iter_mut().enumerate() {
                for (r, v) in col.iter_mut().enumerate() {
                    *v += d[r] * d[c] / jf;
                }
            }
        }
        let factor = correlation_factor(
            gram,
            &self.window,
            self.columns,
            CompressionWork {
                requested: compression,
                samples,
                nz: layout.nu + layout.ny,
                span: layout.span(),
                threads: thread_count(threads),
            },
        )?;
        Ok(LaggedFactor {
            factor,
            scale: plan.scale,
            means,
            samples,
        })
    }

    /// The first pass of the identification with `opts` (their horizons
    /// and mean removal must be the plan's): the model with (B, D) from the
    /// projection, and for the default route the
    /// [`crate::StreamedSubspace::regression`] that takes the records again
    /// for the output-error (B, D, x₀). O(k³).
    ///
    /// Errors: [`Error::InvalidOption`] (options differ from the plan),
    /// [`Error::HorizonTooLong`] (fewer Hankel columns than rows),
    /// [`Error::IllConditionedCorrelation`], and those of
    /// [`crate::identify`] after the compression.
    pub fn identify(self, opts: &SubspaceOptions) -> Result<StreamedSubspace> {
        let plan = &self.plan;
        if (opts.past, opts.future, opts.remove_means)
            != (plan.past, plan.future, plan.remove_means)
        {
            return Err(Error::InvalidOption {
                what: "options",
                reason: format!(
                    "the records were compressed with past {}, future {}, remove_means {}; the options ask for past {}, future {}, remove_means {}",
                    plan.past,
                    plan.future,
                    plan.remove_means,
                    opts.past,
                    opts.future,
                    opts.remove_means
                ),
            });
        }
        let layout = check_options(plan.n_inputs, plan.n_outputs, opts)?;
        let k = layout.nrows();
        let (samples, means) = self.samples_and_means(k)?;
        let t0 = std::time::Instant::now();
        let nz = layout.nu + layout.ny;
        let scale = Scale {
            u: plan.scale[0],
            y: plan.scale[1],
        };
        let gram = if self.gram.is_empty() {
            DMatrix::zeros(0, 0)
        } else {
            DMatrix::from_vec(k, k, self.gram)
        };
        let factor = correlation_factor(
            gram,
            &self.window,
            self.columns,
            CompressionWork {
                requested: opts.compression,
                samples,
                nz,
                span: layout.span(),
                threads: thread_count(opts.threads),
            },
        )?;
        streamed_subspace(
            factor,
            StreamedParts {
                layout,
                opts: opts.clone(),
                scale,
                means,
                record_samples: self.records,
                compress_s: t0.elapsed().as_secs_f64(),
            },
        )
    }

    /// Compact binary form (CBOR) for sending between processes.
    ///
    /// Errors: [`Error::InvalidOption`] if encoding fails.
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        to_cbor(self)
    }

    /// The records from [`to_bytes`](Self::to_bytes).
    ///
    /// Errors: [`Error::InvalidOption`] naming what is wrong with the bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self> {
        let c: CompressedRecords = from_cbor(bytes, "compressed records")?;
        let l = c.plan.layout();
        let k = l.nrows();
        let nz = l.nu + l.ny;
        if !(c.gram.is_empty() || c.gram.len() == k * k)
            || c.window.len() != k
            || c.sums.len() != nz
            || c.plan.reference.len() != nz
        {
            return Err(Error::InvalidOption {
                what: "compressed records",
                reason: "the decoded records are inconsistent with their plan (corrupted bytes?)"
                    .into(),
            });
        }
        Ok(c)
    }
}

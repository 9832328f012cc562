//! The streaming identification: [`StreamingIdentifier`] compresses blocks
//! of one or more records as they arrive; [`StreamedSubspace`] is its first
//! pass, finished with the output-error (B, D, x₀) of a second pass.

use lifted_lti::{OperatingPoint, StateSpace};
use nalgebra::{DMatrix, DVector};
use std::time::Instant;

use crate::bd_stream::{OutputErrorStream, OutputErrorStreamOptions};
use crate::checks::{check_data_on, check_options, check_record_shape, thread_count};
use crate::error::{Error, Result};
use crate::estimated::InitialState;
use crate::fit::{Factored, Fit, NoisePart, from_factor_parts, noise_part};
use crate::hankel::{HankelFactor, HankelLayout, HankelStream};
use crate::model::{BdRoute, SubspaceModel, fold_output_offsets};
use crate::numerics::{Scale, first_block_centring};
use crate::options::{BdEstimate, SubspaceOptions, SystemEstimate};
use crate::records::need_records;

/// Identification from data fed in blocks (e.g. while a CSV file is read):
/// memory O(((n_u + n_y)(p + f))²) whatever the number of samples.
///
/// Each [`push`](Self::push) takes consecutive samples of the current
/// record; [`end_record`](Self::end_record) starts a new record (experiment);
/// [`finish`](Self::finish) identifies the model from the compressed data
/// exactly as [`identify`](crate::identify) would (same factor up to rounding, same steps
/// 2–5) except that the records are gone: (A, B, C, D) come from the state
/// sequences ([`SystemEstimate::StateSequence`], required), no initial
/// state is estimated (`x0` is empty, or zeros per record for
/// [`InitialState::Zero`]), the AIC-type order criteria (which simulate
/// models on the records) are not available, the data scaling (a power
/// of 4 per signal, see [`identify`](crate::identify)) is fixed by the first non-empty block,
/// and [`Compression::Auto`](crate::Compression::Auto) cannot fall back to
/// the QR after the pass: it returns [`Error::IllConditionedCorrelation`]
/// and the data must be fed again with [`Compression::Qr`](crate::Compression::Qr).
///
/// # Example
///
/// ```
/// use lifted_lti::{OperatingPoint, StateSpace};
/// use lifted_subspace::{OrderSelection, StreamingIdentifier, SubspaceOptions};
/// use nalgebra::DMatrix;
///
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let g = StateSpace::new(
///     DMatrix::from_element(1, 1, 0.9),
///     DMatrix::from_element(1, 1, 0.5),
///     DMatrix::from_element(1, 1, 1.0),
///     DMatrix::zeros(1, 1),
///     Some(1.0),
/// )?;
/// let u = DMatrix::from_fn(3000, 1, |k, _| if (k * 7919 + k / 3) % 5 < 2 { 1.0 } else { -1.0 });
/// // A little output noise keeps the correlation matrix well conditioned.
/// let mut y = g.lsim(&u, None, None)?.y;
/// for (k, v) in y.iter_mut().enumerate() {
///     *v += 1e-2 * (((k * 104_729) % 1000) as f64 / 500.0 - 1.0);
/// }
/// let opts = SubspaceOptions { order: OrderSelection::Fixed(1), past: 5, future: 5, ..Default::default() };
/// let mut id = StreamingIdentifier::new(1, 1, &opts)?;
/// for s in (0..3000).step_by(700) {
///     let len = 700.min(3000 - s);
///     id.push(&u.rows(s, len).into_owned(), &y.rows(s, len).into_owned())?;
/// }
/// let fit = id.finish()?;
/// assert!((fit.model.poles()?[0].re - 0.9).abs() < 1e-2);
/// # Ok(())
/// # }
/// ```
pub struct StreamingIdentifier {
    layout: HankelLayout,
    opts: SubspaceOptions,
    stream: HankelStream,
    samples: usize,
    /// Samples per record pushed so far.
    record_samples: Vec<usize>,
    record_open: bool,
    /// Data scaling, fixed by the first non-empty block.
    scale: Option<Scale>,
}

impl StreamingIdentifier {
    /// A streaming identification of a system with `n_inputs` inputs and
    /// `n_outputs` outputs.
    ///
    /// (B, D) come from the compressed data ([`BdEstimate::Projection`]
    /// under [`BdEstimate::Auto`]); x₀ is not estimated.
    ///
    /// Errors: [`Error::DimensionMismatch`] (no input or output),
    /// [`Error::InvalidHorizon`], [`Error::InvalidOption`] (sample period,
    /// or [`BdEstimate::OutputError`] / an AIC-type [`OrderCriterion`](crate::OrderCriterion),
    /// which need the records), [`Error::OrderTooLarge`].
    pub fn new(n_inputs: usize, n_outputs: usize, opts: &SubspaceOptions) -> Result<Self> {
        // faer's one-time set-up runs while the data are pushed.
        lifted_linalg::warm_up();
        if n_inputs == 0 || n_outputs == 0 {
            return Err(Error::DimensionMismatch {
                what: "u, y",
                expected: "at least one input and one output".into(),
                got: format!("{n_inputs} inputs, {n_outputs} outputs"),
            });
        }
        let layout = check_options(n_inputs, n_outputs, opts)?;
        if opts.bd == BdEstimate::OutputError {
            need_records(None)?;
        }
        if opts.order_criterion.needs_models() {
            return Err(Error::InvalidOption {
                what: "order_criterion",
                reason: format!(
                    "{} simulates a model of every order on the records, which streaming does not keep; use OrderCriterion::Svc or Gap",
                    opts.order_criterion.name()
                ),
            });
        }
        let mut stream = HankelStream::new(
            layout,
            opts.compression,
            opts.chunk_rows,
            thread_count(opts.threads),
        );
        stream.set_centering(opts.remove_means);
        Ok(StreamingIdentifier {
            layout,
            opts: opts.clone(),
            stream,
            samples: 0,
            record_samples: Vec::new(),
            record_open: false,
            scale: None,
        })
    }

    /// Appends consecutive samples of the current record: `u` (b×n_u) and
    /// `y` (b×n_y), one row per sample; blocks may have any length.
    ///
    /// Errors: [`Error::DimensionMismatch`], [`Error::NonFinite`].
    pub fn push(&mut self, u: &DMatrix<f64>, y: &DMatrix<f64>) -> Result<()> {
        let (nu, ny) = (self.layout.nu, self.layout.ny);
        check_record_shape("block (u, y)", "b", u, y, nu, ny)?;
        let threads = thread_count(self.opts.threads);
        // A bad sample located in the stream, not in the block.
        check_data_on("u", u, threads).map_err(|e| e.after(self.samples))?;
        check_data_on("y", y, threads).map_err(|e| e.after(self.samples))?;
        if u.nrows() > 0 && self.scale.is_none() {
            // With mean removal, the scale of the first block less its
            // means, as `identify` scales the centred records (the same
            // power of 4 unless the RMS sits near a boundary; the model is
            // then the same up to a diagonal change of state basis).
            let (scale, reference) = first_block_centring(u, y, self.opts.remove_means);
            if self.opts.remove_means {
                self.stream.set_reference(reference);
            }
            self.stream.set_scale(scale);
            self.scale = Some(scale);
        }
        if u.nrows() > 0 && !self.record_open {
            self.record_samples.push(0);
            self.record_open = true;
        }
        if let Some(last) = self.record_samples.last_mut() {
            *last += u.nrows();
        }
        self.samples += u.nrows();
        self.stream.push(u.as_view(), y.as_view())
    }

    /// Ends the current record; the next [`push`](Self::push) starts a new
    /// one (its first s − 1 samples only start Hankel columns).
    pub fn end_record(&mut self) {
        self.stream.end_record();
        self.record_open = false;
    }

    /// Samples pushed so far (all records).
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// Sets [`SubspaceOptions::marginal_tolerance`] for the estimate made
    /// by [`finish`](Self::finish): a tolerance that depends on the record's
    /// length (an integrator's, 2/N), known only once it is pushed.
    ///
    /// Errors: [`Error::InvalidOption`] for a negative or non-finite value.
    pub fn set_marginal_tolerance(&mut self, tolerance: f64) -> Result<()> {
        if !(tolerance.is_finite() && tolerance >= 0.0) {
            return Err(Error::InvalidOption {
                what: "marginal_tolerance",
                reason: format!("must be finite and non-negative, got {tolerance}"),
            });
        }
        self.opts.marginal_tolerance = tolerance;
        Ok(())
    }

    /// Hankel columns collected so far.
    pub fn columns(&self) -> usize {
        self.stream.columns()
    }

    /// Identifies the model from the data pushed so far in one pass: (B, D)
    /// from the projection on the compressed data, no x₀
    /// ([`finish_subspace`](Self::finish_subspace) for the two-pass
    /// identification with the output-error (B, D, x₀)).
    ///
    /// Errors: [`Error::HorizonTooLong`] (fewer Hankel columns than rows),
    /// [`Error::IllConditionedCorrelation`] (correlation route rejected),
    /// and those of [`identify`](crate::identify) after the compression.
    pub fn finish(self) -> Result<SubspaceModel> {
        Ok(self.finish_subspace()?.into_model())
    }

    /// The first pass of the two-pass identification: the model of
    /// [`finish`](Self::finish) (its (A, C) final, (B, D) from the
    /// projection) with what the second pass needs. Feed the records again
    /// to [`StreamedSubspace::regression`] and give it to
    /// [`StreamedSubspace::finish`]: the result is the model [`identify`](crate::identify)
    /// returns on the same data in memory (output-error (B, D, x₀), noise
    /// model from them), up to rounding.
    ///
    /// Errors: as [`finish`](Self::finish).
    pub fn finish_subspace(self) -> Result<StreamedSubspace> {
        let k = self.layout.nrows();
        let columns = self.stream.columns();
        let records = self.record_samples.len().max(1);
        if columns < k {
            let (p, f) = (self.layout.past, self.layout.future);
            return Err(Error::HorizonTooLong {
                past: p,
                future: f,
                n_samples: self.samples,
                min_samples: k + (p + f - 1) * records,
            });
        }
        let t0 = Instant::now();
        let scale = self.scale.unwrap_or(Scale::ONE);
        let means = self.stream.means();
        let factor = self.stream.finish()?;
        streamed_subspace(
            factor,
            StreamedParts {
                layout: self.layout,
                opts: self.opts,
                scale,
                means,
                record_samples: self.record_samples,
                compress_s: t0.elapsed().as_secs_f64(),
            },
        )
    }
}

/// What [`streamed_subspace`] needs besides the factor.
pub(crate) struct StreamedParts {
    pub layout: HankelLayout,
    pub opts: SubspaceOptions,
    pub scale: Scale,
    /// Pooled channel means of the scaled data (used with mean removal).
    pub means: Vec<f64>,
    pub record_samples: Vec<usize>,
    pub compress_s: f64,
}

/// The first pass of a streamed identification from the compressed data
/// (a [`StreamingIdentifier`] or merged [`crate::CompressedRecords`]).
pub(crate) fn streamed_subspace(
    factor: HankelFactor,
    parts: StreamedParts,
) -> Result<StreamedSubspace> {
    let StreamedParts {
        layout,
        opts,
        scale,
        means,
        record_samples,
        compress_s,
    } = parts;
    let records = record_samples.len().max(1);
    let nu = layout.nu;
    let mut factored = from_factor_parts(factor, &layout, &opts, None, scale, compress_s)?;
    let fit = &mut factored.fit;
    if opts.remove_means {
        fit.operating_point = Some(OperatingPoint::new(
            means[..nu].iter().map(|m| m * scale.u).collect(),
            means[nu..].iter().map(|m| m * scale.y).collect(),
        )?);
    }
    if opts.initial_state == InitialState::Zero {
        fit.x0 = vec![DVector::zeros(fit.model.order()); records];
    }
    Ok(StreamedSubspace {
        factored,
        layout,
        opts,
        scale,
        record_samples,
    })
}

/// The first pass of a streamed identification
/// ([`StreamingIdentifier::finish_subspace`]): the model with (B, D) from
/// the projection, and the compressed data to finish the two-pass
/// identification with the output-error (B, D, x₀) of a second pass.
pub struct StreamedSubspace {
    factored: Factored,
    layout: HankelLayout,
    opts: SubspaceOptions,
    scale: Scale,
    record_samples: Vec<usize>,
}

impl StreamedSubspace {
    /// The one-pass model ((B, D) from the projection).
    pub fn model(&self) -> &SubspaceModel {
        &self.factored.fit
    }

    /// The one-pass model, consuming the first pass.
    pub fn into_model(self) -> SubspaceModel {
        self.factored.fit
    }

    /// Whether the options ask for the output-error (B, D, x₀) of a second
    /// pass: (A, C) by shift invariance and [`BdEstimate::Auto`] or
    /// [`BdEstimate::OutputError`].
    pub fn wants_second_pass(&self) -> bool {
        self.opts.system == SystemEstimate::ShiftInvariance
            && self.opts.bd != BdEstimate::Projection
    }

    /// The second pass: an [`OutputErrorStream`] for the model's (A, C)
    /// that takes the records again, as pushed to the
    /// [`StreamingIdentifier`] (same records, same order, raw data: the
    /// operating point is removed inside), ending each record with
    /// [`OutputErrorStream::end_record`].
    ///
    /// Errors: [`Error::UnstableEstimate`] when A is too unstable for the
    /// regression over the longest record (keep the one-pass model then).
    pub fn regression(&self) -> Result<OutputErrorStream> {
        let fit = &self.factored.fit;
        let opts = OutputErrorStreamOptions {
            feedthrough: self.opts.feedthrough.clone(),
            initial_state: self.opts.initial_state,
            offsets: self.opts.remove_means,
            records: self.record_samples.len().max(1),
            longest_record: self.record_samples.iter().copied().max().unwrap_or(0),
            operating_point: fit.operating_point.clone(),
            threads: thread_count(self.opts.threads),
        };
        OutputErrorStream::new(fit.model.a(), fit.model.c(), self.layout.nu, &opts)
    }

    /// The model with (B, D, x₀) from the second pass, the noise model
    /// recomputed from them, and the operating point corrected by the
    /// estimated output offsets (as [`identify`](crate::identify) does).
    ///
    /// Errors: those of [`OutputErrorStream::finish`].
    pub fn finish(self, pass: OutputErrorStream) -> Result<SubspaceModel> {
        let bd = pass.finish()?;
        let StreamedSubspace {
            factored,
            layout,
            opts,
            scale,
            record_samples,
        } = self;
        let Factored {
            fit: mut model,
            l,
            gamma,
            map,
        } = factored;
        let t0 = Instant::now();
        let fit = Fit {
            a: model.model.a().clone(),
            b: bd.b,
            c: model.model.c().clone(),
            d: bd.d,
            x0: bd.x0,
            offsets: if opts.remove_means {
                bd.offsets
            } else {
                Vec::new()
            },
            stabilized: model.diagnostics.stabilized,
            gamma,
            bd_route: BdRoute::OutputError,
            fallback: None,
        };
        let noise = if opts.noise_model {
            noise_part(&l, &layout, &fit.gamma, &map, &fit, scale)
        } else {
            NoisePart::default()
        };
        model.model = StateSpace::new(fit.a, fit.b, fit.c, fit.d, Some(opts.ts))?;
        model.kalman_gain = noise.kalman_gain;
        model.noise = noise.covariances;
        model.diagnostics.noise_model_error = noise.error;
        model.diagnostics.bd_route = BdRoute::OutputError;
        model.diagnostics.profile.estimate_s += t0.elapsed().as_secs_f64();
        model.x0 = fit.x0;
        if let Some(op) = model.operating_point.as_mut() {
            *op = fold_output_offsets(op, &record_samples, &fit.offsets)?;
        }
        model.output_offsets = fit.offsets;
        Ok(model)
    }
}

//! The identification in separable steps, as SLICOT separates IB01AD
//! (compression and SVD), IB01BD (system matrices) and IB01CD (initial
//! state): [`CompressedData::new`] is step 1 of [`crate::identify`] (mean
//! removal, exact power-of-4 scaling, the block-Hankel compression to the
//! k×k factor L, O(N (n_u + n_y)² s)), and [`CompressedData::identify`]
//! runs steps 2–5 on it for any weighting, order, (A, C) and (B, D) route
//! with the same horizons: the oblique projection and weighted SVD
//! (O(k³)), (A, C) at the order (O(k³)), (B, D, x₀) by output-error least
//! squares over the kept records (O(N q²)) or by the projection (O(k³)).
//! One compression therefore serves every order and method (an order
//! slider, an order criterion): the O(N) compression is not repeated.
//! [`CompressedData::singular_values`] is step 2 alone.
//!
//! `identify(records, opts)` equals
//! `CompressedData::new(records, opts)?.identify(opts)` exactly (it is
//! implemented so).

use lifted_lti::OperatingPoint;
use nalgebra::DMatrix;
use std::time::Instant;

use crate::checks::{thread_count, validate_on};
use crate::error::{Error, Result};
use crate::fit::from_factor;
use crate::hankel::{HankelFactor, HankelLayout};
use crate::model::{Experiment, SubspaceModel, fold_output_offsets};
use crate::numerics::Scale;
use crate::options::{Method, SubspaceOptions};
use crate::records::{OwnedRecords, compressed, records_of, remove_means};

/// The records as given, or their centred copies.
enum Records<'a> {
    Borrowed(Vec<Experiment<'a>>),
    Centred(OwnedRecords),
}

impl Records<'_> {
    fn experiments(&self) -> Vec<Experiment<'_>> {
        match self {
            Records::Borrowed(e) => e.clone(),
            Records::Centred(c) => c.iter().map(|(u, y)| Experiment { u, y }).collect(),
        }
    }
}

/// Step 1 of the identification, kept for any number of fits: the
/// compressed block-Hankel data of the records (means removed and scaled
/// as [`crate::identify`] does) and the records themselves for the
/// output-error (B, D, x₀). Memory: the k×k factor, plus a centred copy of
/// the records when means are removed (as `identify` makes).
pub struct CompressedData<'a> {
    layout: HankelLayout,
    factor: HankelFactor,
    scale: Scale,
    operating_point: Option<OperatingPoint>,
    records: Records<'a>,
    /// Samples per record.
    lengths: Vec<usize>,
    /// The options of the compression (horizons, mean removal,
    /// compression route, threads).
    opts: SubspaceOptions,
    compress_s: f64,
}

impl<'a> CompressedData<'a> {
    /// Step 1 of [`crate::identify`] with `opts` (only its horizons,
    /// `remove_means`, `compression`, `chunk_rows`, `threads` and the
    /// option checks matter here).
    ///
    /// Errors: as [`crate::identify`] for the data and horizons
    /// ([`Error::NoData`], [`Error::DimensionMismatch`],
    /// [`Error::NonFinite`], [`Error::InvalidHorizon`],
    /// [`Error::HorizonTooLong`], [`Error::OrderTooLarge`], memory budget).
    pub fn new(experiments: &[Experiment<'a>], opts: &SubspaceOptions) -> Result<Self> {
        lifted_linalg::warm_up();
        validate_on(experiments, thread_count(opts.threads))?;
        let lengths = experiments.iter().map(|e| e.u.nrows()).collect();
        let t0 = Instant::now();
        let (operating_point, records) = if opts.remove_means {
            let (op, centred) = remove_means(experiments)?;
            (Some(op), Records::Centred(centred))
        } else {
            (None, Records::Borrowed(experiments.to_vec()))
        };
        let (layout, factor, scale) = compressed(&records.experiments(), opts)?;
        Ok(CompressedData {
            layout,
            factor,
            scale,
            operating_point,
            records,
            lengths,
            opts: opts.clone(),
            compress_s: t0.elapsed().as_secs_f64(),
        })
    }

    /// The factor L (H Hᵀ/J = L Lᵀ) of the centred data divided by the
    /// scales (powers of 4): the one [`crate::identify`] works on. (The
    /// factor of [`crate::compress_hankel`] is that of the raw data.)
    pub fn factor(&self) -> &HankelFactor {
        &self.factor
    }

    /// The data scales (s_u, s_y) the factor's data were divided by.
    pub fn scales(&self) -> (f64, f64) {
        (self.scale.u, self.scale.y)
    }

    /// The means removed from the records, `None` without mean removal.
    pub fn operating_point(&self) -> Option<&OperatingPoint> {
        self.operating_point.as_ref()
    }

    /// Step 2 alone: the singular values of the weighted projection for
    /// `method` (in the units of the original data), O(k³).
    ///
    /// Errors: [`Error::NotExciting`] (input rows of less than full rank).
    pub fn singular_values(&self, method: Method) -> Result<Vec<f64>> {
        let opts = SubspaceOptions {
            method,
            ..self.opts.clone()
        };
        crate::fit::weighted_singular_values(&self.factor, self.layout, &opts, self.scale)
    }

    /// Steps 2–5 with `opts`: the model [`crate::identify`] returns for the
    /// records with these options. `opts` may choose any method, order,
    /// order criterion, (A, C) and (B, D) route, feedthrough, initial
    /// state, noise model, stability option and sample period; its
    /// horizons, mean removal and compression must be those of the
    /// compression. O(k³) + the (B, D, x₀) regression (O(N q²), or O(k³)
    /// by the projection).
    ///
    /// Errors: [`Error::InvalidOption`] when the horizons, mean removal or
    /// compression differ from those of [`CompressedData::new`]; otherwise
    /// as [`crate::identify`] after the compression.
    pub fn identify(&self, opts: &SubspaceOptions) -> Result<SubspaceModel> {
        let c = &self.opts;
        if (opts.past, opts.future, opts.remove_means, opts.compression)
            != (c.past, c.future, c.remove_means, c.compression)
        {
            return Err(Error::InvalidOption {
                what: "options",
                reason: format!(
                    "the data were compressed with past {}, future {}, remove_means {}, {:?}; the options ask for past {}, future {}, remove_means {}, {:?}",
                    c.past,
                    c.future,
                    c.remove_means,
                    c.compression,
                    opts.past,
                    opts.future,
                    opts.remove_means,
                    opts.compression
                ),
            });
        }
        crate::checks::check_options(self.layout.nu, self.layout.ny, opts)?;
        let mut fit = from_factor(
            self.factor.clone(),
            &self.layout,
            opts,
            Some(&records_of(&self.records.experiments())),
            self.scale,
            self.compress_s,
        )?;
        if let Some(op) = &self.operating_point {
            fit.operating_point =
                Some(fold_output_offsets(op, &self.lengths, &fit.output_offsets)?);
        }
        Ok(fit)
    }

    /// The same compressed data owning its records (a copy of them when
    /// they were borrowed, i.e. without mean removal), so that it can be
    /// kept beyond the records' lifetime (the studio keeps one between two
    /// moves of its order slider). Every fit is unchanged: the copies hold
    /// the same values.
    pub fn into_owned(self) -> CompressedData<'static> {
        let records = match self.records {
            Records::Borrowed(e) => {
                Records::Centred(e.iter().map(|e| (e.u.clone(), e.y.clone())).collect())
            }
            Records::Centred(c) => Records::Centred(c),
        };
        CompressedData {
            layout: self.layout,
            factor: self.factor,
            scale: self.scale,
            operating_point: self.operating_point,
            records,
            lengths: self.lengths,
            opts: self.opts,
            compress_s: self.compress_s,
        }
    }

    /// The records the compression was made from (centred when means were
    /// removed), for refinements on the same data.
    pub fn records(&self) -> Vec<(&DMatrix<f64>, &DMatrix<f64>)> {
        match &self.records {
            Records::Borrowed(e) => e.iter().map(|e| (e.u, e.y)).collect(),
            Records::Centred(c) => c.iter().map(|(u, y)| (u, y)).collect(),
        }
    }
}

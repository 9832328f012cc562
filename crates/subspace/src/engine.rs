//! The entry points of the unified subspace engine (N4SID, MOESP and CVA
//! as one weighted SVD, thesis §2.5): [`identify`], [`compress_hankel`] and
//! [`SubspaceIdentifier`]. The steps live in modules of their own, as
//! SLICOT separates IB01AD / IB01BD / IB01CD: [`crate::records`] (checks,
//! scales, compression), [`crate::separable`] (the reusable compressed data
//! and weighted SVD) and [`crate::fit`] (the model at an order); no module
//! imports from this one.

use nalgebra::DMatrix;

use crate::checks::{check_options, thread_count, validate_on};
use crate::error::{Error, Result};
use crate::hankel::{Compression, HankelFactor, compress};
use crate::model::{Diagnostics, Experiment, SubspaceModel};
use crate::numerics::Scale;
use crate::options::{OrderSelection, SubspaceOptions};

/// Compresses the block-Hankel data [U_f; U_p; Y_p; Y_f] of the records
/// (past/future horizons `past`, `future`) into the k×k factor L with
/// H Hᵀ/J = L Lᵀ, by `compression` (see [`Compression`]) with `threads`
/// threads for the correlation kernel (0 = all cores): step 1 of
/// [`identify`]'s kernel on the data as given (no scaling, no centring),
/// exposed for benchmarks; [`crate::CompressedData`] keeps the factor
/// [`identify`] itself uses, for reuse across orders and methods.
///
/// Errors: as [`identify`] for the data and horizons;
/// [`Error::IllConditionedCorrelation`] for [`Compression::Correlation`]
/// when the check fails.
pub fn compress_hankel(
    experiments: &[Experiment<'_>],
    past: usize,
    future: usize,
    compression: Compression,
    threads: usize,
) -> Result<HankelFactor> {
    let (nu, ny, total) = validate_on(experiments, thread_count(threads))?;
    let opts = SubspaceOptions {
        past,
        future,
        order: OrderSelection::Gap { max: 1 },
        ..Default::default()
    };
    crate::checks::check_length(experiments, past, future, nu, ny)?;
    let layout = check_options(nu, ny, &opts)?;
    let columns: usize = experiments
        .iter()
        .map(|e| layout.columns(e.u.nrows()))
        .sum();
    if columns < layout.nrows() {
        return Err(Error::HorizonTooLong {
            past,
            future,
            n_samples: total,
            min_samples: layout.nrows() + (past + future - 1) * experiments.len(),
        });
    }
    let recs: Vec<(&DMatrix<f64>, &DMatrix<f64>)> =
        experiments.iter().map(|e| (e.u, e.y)).collect();
    compress(
        &recs,
        &layout,
        compression,
        opts.chunk_rows,
        thread_count(threads),
        Scale::ONE,
        false,
    )
}

/// Identifies a state-space model from one or more records with N4SID,
/// MOESP or CVA (thesis ch. 2, unified by the weights of §2.5).
///
/// Steps: (1) streamed compression of the block-Hankel data
/// [U_f; U_p; Y_p; Y_f] to L with H Hᵀ/J = L Lᵀ ([`Compression`]: lagged
/// correlations + Cholesky, ≈ 2N(n_u+n_y)²(p+f) flops, falling back to the
/// R-only QR, ≈ 2Jk²(1 + k/b) flops; O(k²) memory, k = (p+f)(n_u+n_y)); (2) oblique projection Φ = Y_f /_{U_f} W_p
/// and SVD of W₁ Φ W₂ on the k×k factor (O(k³)); (3) Γ = W₁⁻¹U₁S₁^{1/2},
/// C = first block row, A = Γ↑⁺Γ↓ (all block rows, erratum L-3);
/// (4) (B, D, x₀) by streamed output-error least squares with the
/// feedthrough mask ([`crate::estimate_bd`], O(N q²) with q = n n_u + n_u + n +
/// n_y + 1 in modal coordinates, O(N n_y (n_u n³ + p²)) otherwise);
/// (5) optionally Q, R, S from the state sequences X_i = Γ⁺Φ and
/// X_{i+1} = Γ₋⁺Φ₊ and the Kalman gain from the filter DARE.
///
/// Units: u and y are divided by a power of 4 near their RMS before step
/// (1) (exact, O(N) pass) and the model, noise model and singular values
/// are returned in the original units, so neither the magnitude of the data
/// (1e-200 … 1e200) nor the ratio of output to input units changes the
/// result.
///
/// Order: `order_criterion` ([`crate::OrderCriterion`]) chooses the order for
/// [`OrderSelection::Gap`] and is reported for every candidate order in
/// [`Diagnostics::order_selection`]: the gap rule and Bauer's SVC cost
/// O(max) (SVC one more k×k SVD for N4SID/MOESP); AIC/AICc/BIC fit and
/// simulate one model per candidate order (max × step 4 plus
/// O(N n (n + n_u + n_y)) each).
///
/// Errors: [`Error::NoData`], [`Error::DimensionMismatch`],
/// [`Error::NonFinite`], [`Error::InvalidHorizon`],
/// [`Error::HorizonTooLong`], [`Error::OrderTooLarge`] (also for a
/// criterion's `max` beyond (f − 1)n_y, or beyond what the number of
/// samples supports for AIC-type criteria), [`Error::NotExciting`],
/// [`Error::UnstableEstimate`] when the shift-invariance A is so unstable
/// that the (B, D, x₀) output-error regression over the record cannot be
/// computed (raised before it runs; the default state-sequence route
/// returns an unstable model instead and estimates x₀ on the window where
/// C Aᵗ has grown by less than [`crate::MAX_REGRESSOR_GROWTH`]).
/// [`Error::Unstable`] is never returned here (use `enforce_stability`).
pub fn identify(experiments: &[Experiment<'_>], opts: &SubspaceOptions) -> Result<SubspaceModel> {
    crate::separable::CompressedData::new(experiments, opts)?.identify(opts)
}

/// [`identify`] behind the common [`lifted_lti::identify::Identifier`]
/// interface: single-rate [`lifted_lti::Dataset`]s (several experiments are
/// merged); the model gets the data's period.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SubspaceIdentifier {
    /// Options (the sample period is taken from the data).
    pub options: SubspaceOptions,
}

impl lifted_lti::identify::Identifier for SubspaceIdentifier {
    type Diagnostics = Diagnostics;
    type Error = Error;

    fn name(&self) -> &'static str {
        self.options.method.name()
    }

    fn identify(
        &self,
        experiments: &[lifted_lti::Dataset],
    ) -> Result<lifted_lti::identify::Identified<Diagnostics>> {
        let layout = lifted_lti::identify::check_experiments(experiments)?;
        if let Some(i) = experiments.iter().position(|e| !e.is_single_rate()) {
            return Err(Error::InvalidOption {
                what: "experiments",
                reason: format!("experiment {i} is multirate; use the multirate crate (lifting)"),
            });
        }
        let recs: Vec<Experiment<'_>> = experiments
            .iter()
            .map(|e| Experiment { u: e.u(), y: e.y() })
            .collect();
        let opts = SubspaceOptions {
            ts: layout.ts,
            ..self.options.clone()
        };
        let fit = identify(&recs, &opts)?;
        Ok(lifted_lti::identify::Identified {
            model: fit.model,
            diagnostics: fit.diagnostics,
        })
    }
}

//! Subspace identification for Lifted.
//!
//! # Map of the crate
//!
//! | item | what |
//! |---|---|
//! | [`identify`] ([`SubspaceOptions`], [`Method`]) | N4SID, MOESP and CVA through the weights of the unifying theorem (thesis §2.5) |
//! | [`SystemEstimate`], [`BdEstimate`] | (A, C) by shift invariance (consistent default) or from the state sequences; (B, D) by output-error regression on the records or by the Γ⊥ projection on the compressed data |
//! | [`SubspaceIdentifier`] | the same behind `lifted_lti::identify::Identifier` (single-rate `Dataset`s) |
//! | [`SubspaceModel`], [`Diagnostics`] ([`CompressionReport`], [`Profile`]) | model, Kalman gain, (Q, R, S), singular values, suggested order, compression used and fallback, time per phase |
//! | [`OrderCriterion`], [`OrderReport`], [`gap_order`] | order selection: singular-value gap (default), Bauer's SVC, SIPPY's AIC/AICc/BIC; the criterion's value per order in the diagnostics |
//! | [`StreamingIdentifier`], [`StreamedSubspace`] | the same identification from data fed in blocks, memory independent of N: one pass ((B, D) by the projection) or two passes ((B, D, x₀) by the output-error regression of a second pass, equal to [`identify`] in memory up to rounding) |
//! | [`OutputErrorStream`] ([`OutputErrorStreamOptions`]) | the output-error (B, D, x₀) regression fed in blocks (the second pass) |
//! | [`select_structure`] ([`StructureOptions`], [`StructureSelection`], [`Candidate`]) | horizon, (A, C) route and order chosen by the simulation fit on held-out data (the default of the `lifted` command) |
//! | [`crossval`] ([`crossval::Folds`], [`crossval::held_out_fit`]) | blocked cross-validation: K contiguous blocks held out in turn, a model scored on them by its simulation fit with x₀ fitted per block (shared by [`select_structure`] and `lifted-pem`'s check of a refinement) |
//! | [`checks::validate`] | the record checks (shapes, finite samples) every identification entry runs, public for the crates above |
//! | [`estimate_x0`] | least-squares initial state of each record for a fixed model |
//! | [`CompressedData`] | the separable steps (as SLICOT's IB01AD / IB01BD / IB01CD): step 1 of [`identify`] kept, then any number of fits (every order, method and route) at O(k³) plus the (B, D, x₀) regression, each equal to [`identify`] with those options |
//! | [`CompressionPlan`], [`RecordPiece`], [`CompressedRecords`], [`RegressionPiece`] | one record compressed in pieces on several machines: pieces concatenate associatively, closed records add, both passes (compression, (B, D, x₀) rows) merge; CBOR bytes to cross processes (the `lifted.dask` package) |
//! | [`compress_hankel`] ([`Compression`], [`HankelFactor`]) | the compression kernel alone on the raw data (no scaling or centring; benchmarks): correlation/Cholesky or QR |
//! | [`estimate_bd`], [`estimate_bd_with_offsets`], [`estimate_bd_iv`] ([`Feedthrough`], [`InitialState`], [`MAX_REGRESSOR_GROWTH`]) | (B, D, x₀) for given (A, C) by least squares or instrumental variables, masked D, NaN (unsampled) outputs skipped; an A too unstable for the record is [`Error::UnstableEstimate`] |
//! | [`check_kalman_gain`] ([`GainCheck`]) | the subspace step's Kalman gain checked on the records: it, a regression on VARX innovations and K = 0 scored by the one-step prediction error, the best refined over K with (A, B, C, D) fixed: BFGS on the covariances of the start's one-step errors finished by quasi-Newton on the records, or Levenberg–Marquardt on the records (the `lifted` command's default for single-rate subspace models) |
//! | [`structured_state_lstsq`] | the causality-structured least squares of thesis §4.5 (eqs. 4.17–4.19) |
//! | [`iv_identify`] ([`IvOptions`]) | instrumental-variable subspace identification, open loop (u as instrument, §7.3) or closed loop (external excitation f, §7.4) |
//! | [`pbsid_identify`] ([`PbsidOptions`], [`PbsidModel`]) | predictor-based subspace identification (PBSID-opt, Chiuso 2007; row-wise PBSID; SSARX, Jansson 2003; [`PbsidVariant`]): consistent on closed-loop data without an instrument, on the same compressed lagged data, then (B, K, x₀) by the predictor regression on the records |
//! | [`iv_multirate_fast`] ([`MultirateIvOptions`]) | the one-step fast model of §7.5 (eq. 7.27) |
//!
//! # Method
//!
//! With past/future block-Hankel matrices U_p, U_f, Y_p, Y_f (thesis §2.3)
//! and W_p = [U_p; Y_p], all three methods compute the oblique projection
//! Φ = (Y_f/U_f⊥)(W_p/U_f⊥)ᵀ[(W_p/U_f⊥)(W_p/U_f⊥)ᵀ]⁻¹ W_p and the SVD
//! W₁ Φ W₂ = U₁S₁V₁ᵀ + …; the extended observability matrix is
//! Γ = W₁⁻¹U₁S₁^{1/2} (§2.5). N4SID: W₁ = W₂ = I. MOESP: W₁ = I,
//! W₂ = Π_{U_f⊥} (erratum L-4). CVA: W₁ = [(Y_f/U_f⊥)(Y_f/U_f⊥)ᵀ]^{−1/2},
//! W₂ = Π_{U_f⊥} (erratum L-1 for the Σ^{−1/2}). C is the first block row of
//! Γ and A = Γ↑⁺Γ↓ uses all block rows (erratum L-3, eq. 2.20 with the
//! missing transpose). (B, D) and the initial state come from a streamed
//! least-squares regression on the data with per-output regressor selection
//! so that a causality mask on D holds exactly (§4.5, Pitfall 5); when
//! streaming, from the MOESP regression Γ⊥ᵀ Θ_u = Γ⊥ᵀ H_f(B, D) on the
//! compressed data ([`BdEstimate::Projection`]). This route is consistent:
//! pole and frequency-response errors shrink like 1/√N on open-loop data
//! (the thesis' state-sequence regression, [`SystemEstimate::StateSequence`],
//! is biased for short past horizons and is kept as an option).
//!
//! Every projection acts on the lower-triangular compressed factor L of the
//! data (H = L Qᵀ): once the inputs are shown persistently exciting, removing
//! the row space of U_f is zeroing L's first f n_u columns and the oblique
//! projection's map is one triangular solve with L's W_p block (a
//! pseudo-inverse only when that block is numerically singular), O(k² n)
//! instead of SVDs of the k-column blocks. Condition and rank tests are first
//! decided by certificates (an explicit-inverse bound; Cholesky
//! factorisations of shifted Gram matrices), the singular values only near
//! the thresholds.
//!
//! Offsets: by default each channel's mean is removed before the
//! identification and returned as [`SubspaceModel::operating_point`]; the
//! compressed Hankel data have the row of ones projected out (every Hankel
//! row less its own mean), so no constant in the data can become a mode at
//! z = 1, and the output-error regression estimates the O(1/N) constant a
//! response that started at rest keeps after the means are removed.
//!
//! The Hankel matrix is never stored. It is compressed in one streaming
//! pass to a k×k factor L with H Hᵀ/J = L Lᵀ (k = (p+f)(n_u+n_y) Hankel
//! rows, J columns), by default from the lagged correlations of the data
//! (the Hankel structure makes every entry of H Hᵀ a correlation at one of
//! p + f lags plus boundary terms: ≈ 2N(n_u+n_y)²(p+f) flops) and a
//! Cholesky factorisation, with the R-only QR of Hᵀ (≈ 2Jk² flops) as the
//! accurate reference and automatic fallback when the correlation matrix
//! is not safely positive definite ([`Compression`], reported in
//! [`Diagnostics::compression`], as SLICOT's IWARN). The projections then
//! act on L. Several records (experiments) are merged by stacking their
//! Hankel columns; [`StreamingIdentifier`] takes the data in blocks with
//! memory O(k²) whatever N, and [`Diagnostics::profile`] times the phases.
//!
//! Order selection ([`OrderCriterion`]): the largest gap ln(σ_n/σ_{n+1})
//! (default), Bauer's singular value criterion SVC(n) = σ̂²_{n+1} +
//! n(2n_y + n_u) ln J/J on the canonical correlations (Automatica 37, 2001),
//! or SIPPY's AIC = N ln V_n + 2K, AICc and BIC = N ln V_n + K ln N on the
//! mean squared simulation error V_n of the model of each order.
//!
//! Data units: u, y (and an instrument) are divided by a power of 4 near
//! their RMS before anything else (exact; the methods are equivariant under
//! such scalings) and every result is returned in the original units, so
//! relative rank tolerances and squared-data products see data of order 1.
//!
//! The output-error regressions simulate the estimated model over the
//! record; an unstable A whose growth ρ^(N−1) exceeds
//! [`MAX_REGRESSOR_GROWTH`] (typical of IV or shift-invariance estimates
//! at very low SNR) is reported as [`Error::UnstableEstimate`] before the
//! regression instead of ending in overflow or a spurious rank deficiency.
//!
//! The instrumental-variable method of ch. 7 correlates future inputs and
//! outputs with α_p > α block rows of past instruments (erratum L-16), takes
//! the LQ factorisation of [U_f Zᵀ; Y_f Zᵀ]/J and the SVD of R₂₂ for Γ, and
//! estimates (B, D) by IV regression with instruments filtered from f
//! (the excitation, independent of the noise), which removes the
//! closed-loop bias of the plain methods.
//!
//! # Example
//!
//! ```
//! use lifted_lti::StateSpace;
//! use lifted_subspace::{Experiment, OrderSelection, SubspaceOptions, identify};
//! use nalgebra::DMatrix;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // y(k+1) = 0.9 y(k) + 0.5 u(k), noise free
//! let g = StateSpace::new(
//!     DMatrix::from_element(1, 1, 0.9),
//!     DMatrix::from_element(1, 1, 0.5),
//!     DMatrix::from_element(1, 1, 1.0),
//!     DMatrix::zeros(1, 1),
//!     Some(1.0),
//! )?;
//! let u = DMatrix::from_fn(400, 1, |k, _| if (k * 7919 + k / 3) % 5 < 2 { 1.0 } else { -1.0 });
//! let y = g.lsim(&u, None, None)?.y;
//! let opts = SubspaceOptions { order: OrderSelection::Fixed(1), past: 5, future: 5, ..Default::default() };
//! let fit = identify(&[Experiment { u: &u, y: &y }], &opts)?;
//! let pole = fit.model.poles()?[0];
//! assert!((pole.re - 0.9).abs() < 1e-8);
//! assert!((fit.model.dc_gain()?[(0, 0)] - 5.0).abs() < 1e-6);
//! # Ok(())
//! # }
//! ```
#![deny(missing_docs)]

mod bd_stream;
mod budget;
pub mod checks;
pub mod crossval;
mod engine;
pub mod error;
mod error_covariance;
mod estimated;
mod fit;
mod gain_check;
mod hankel;
mod held_out_order;
mod iv;
mod iv_order;
mod lagged;
mod modal;
mod model;
mod numerics;
mod oblique;
mod one_step;
mod options;
mod order;
mod partial;
mod pbsid;
mod pbsid_order;
mod predictor_regress;
mod projection;
mod records;
pub use records::longest_horizon;
mod regress;
mod select;
mod separable;
mod streaming;
mod wire;

pub use bd_stream::{OutputErrorStream, OutputErrorStreamOptions, RegressionPiece, ShardScan};
pub use engine::{SubspaceIdentifier, compress_hankel, identify};
pub use error::{Error, Result};
pub use estimated::{BdFit, Feedthrough, InitialState, Record};
pub use gain_check::{
    GainCheck, GainCheckOptions, MEMO_ENTRIES, MINIMISE_WORK, VARX_WORK, VarxMemo,
    check_kalman_gain, check_kalman_gain_memo, records_hash,
};
pub use hankel::{
    CORRELATION_RCOND_MIN, Compression, CompressionReport, HankelFactor, hankel_row_sources,
};
pub use held_out_order::{HeldOutOrder, OrderCandidate};
pub use iv::{
    IvDiagnostics, IvExperiment, IvModel, IvOptions, MultirateIvOptions, iv_identify,
    iv_longest_alpha, iv_multirate_fast,
};
pub use iv_order::select_iv_order;
pub use model::{BdRoute, Diagnostics, Experiment, NoiseCovariances, Profile, SubspaceModel};
pub use options::{BdEstimate, Method, OrderSelection, SubspaceOptions, SystemEstimate};
pub use order::{OrderCriterion, OrderReport, gap_order};
pub use partial::{CompressedRecords, CompressionPlan, LaggedFactor, PieceStream, RecordPiece};
pub use pbsid::{
    PbsidDiagnostics, PbsidModel, PbsidOptions, PbsidVariant, SAMPLES_PER_VARX_PARAMETER,
    pbsid_identify, pbsid_longest_future,
};
pub use pbsid_order::select_pbsid_order;
pub use regress::{
    MAX_REGRESSOR_GROWTH, StateFit, estimate_bd, estimate_bd_iv, estimate_bd_with_offsets,
    estimate_x0, structured_state_lstsq,
};
pub use select::{
    Candidate, DEFAULT_HORIZONS, StructureOptions, StructureSelection, default_horizons,
    select_structure,
};
pub use separable::CompressedData;
pub use streaming::{StreamedSubspace, StreamingIdentifier};

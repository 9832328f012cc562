//! Prediction-error identification for Lifted.
//!
//! # Map of the crate
//!
//! | item | what |
//! |---|---|
//! | [`refine_pem`] ([`PemOptions`], [`PemCost`], [`PemMethod`], [`PemFit`], [`PemReport`], [`Kept`], [`Termination`]) | prediction-error or output-error refinement of a state-space model by variable projection (B, D, K, x₀ solved for, Levenberg–Marquardt on the predictor's Ā, C in data-driven local coordinates, warm stages on long records); multirate records (NaN = not sampled) use the measured samples only; keeps the better of start and result; a drifted realization is returned balanced |
//! | [`pem_work_estimate`], [`pem_work_estimate_of_sizes`] ([`PemWorkEstimate`]) | the refinement's predicted work, in the units of its work bound, before running it |
//! | [`cross_validate_refinement`] ([`RefinementCheck`]) | whether a refinement helps on data it was not fitted to: each of K blocks held out once, the fold's subspace model and its refinement scored on it; a verdict only when the blocks tell the two apart |
//! | [`arx`] ([`ArxOptions`], [`ArxFit`]) | multi-output ARX and FIR by least squares on the compressed lagged data (one pass, memory independent of N), with the noise covariance and the parameter covariance |
//! | [`arx_scan`] ([`ArxScanOptions`], [`ArxScan`], [`ArxStructure`], [`AStructure`], [`StructureCriterion`]), [`estimate_delays`] ([`DelayOptions`]) | the structure scan over a grid of (na, nb, nk) by AIC, MDL or held-out loss, and the input delays, on one compression |
//! | [`impulseest`] ([`ImpulseOptions`], [`Kernel`], [`ImpulseFit`]) | regularised FIR (impulse response) with a TC or DC kernel, hyperparameters by the marginal likelihood on the compressed lagged data (O(p³) per evaluation whatever N), posterior covariance |
//! | [`arx_compressed`] ([`arx_horizons`], [`ArxCompressedFit`]) | the same ARX/FIR from records compressed in blocks (`lifted_subspace::CompressionPlan`, a file streamed or shards merged): memory O(k²) whatever N, means and scales mapped back |
//! | [`arx_regul`] ([`ArxRegulOptions`], [`ArxRegulFit`], [`ArxHyperparameters`]) | regularised ARX (MATLAB's `arxRegul`): a TC or DC kernel for the past outputs' and another for the lagged inputs' coefficients, hyperparameters by the marginal likelihood (module `regularized`, shared with [`impulseest`]), posterior covariance |
//! | [`oe`] ([`OeOptions`], [`OeFit`], [`FStructure`]) | output-error models B/F per input–output pair (or one F per output) by Levenberg–Marquardt on the simulation error of the measured samples (multirate records included), started from a FIR regression and ARX fits to it, with the parameter covariance |
//! | [`polyest`], [`armax`], [`bj`] ([`PolyestOptions`], [`PolyestFit`]) | ARMAX, Box–Jenkins and the general diagonal-A structure by Levenberg–Marquardt on the one-step prediction error (analytic gradient by filtering), Hannan–Rissanen / OE starts, consistent in closed loop (the direct method), with the parameter covariance |
//! | [`procest`] ([`ProcessKind`], [`ProcessModel`], [`ProcessOptions`], [`ProcessFit`]) | process models with dead time (MATLAB's `idproc`: P1D, P2D, P1DI, P2DZ, P2DU) — gain, time constants, any dead time (exact ZOH with a fractional delay) — by output error on the measured samples (multirate records included), grid and two-point starts, Levenberg–Marquardt, covariance of K, T, θ; equations, discretisation, estimator and complexity in [`process`] |
//! | [`PEM_SAMPLES_PER_PARAMETER`] | the bound on free parameters per measured output sample |
//!
//! # Method
//!
//! The model is the innovations form x(t+1) = A x + B u + K e,
//! y = C x + D u + e, refined from a start (a subspace estimate of
//! `lifted-subspace`) by minimising the one-step prediction error (the
//! direct method, consistent in closed loop: Ljung 1999, §13.4) or the
//! simulation error (K = 0) over the measured samples, by variable
//! projection (Golub & Pereyra 1973; Kaufman 1975): for fixed (Ā = A − KC,
//! C) the residuals are affine in (B̄, D, K, x₀), which are solved for at
//! every iterate, while Levenberg–Marquardt steps run on (Ā, C) in the
//! data-driven local coordinates of McKelvey, Helmersson & Ribarits
//! (2004). The Jacobian comes from the sensitivity recursion of the
//! predictor, streamed into an R-only QR (memory O(p²), not O(N p)). Cost
//! per iteration ≈ 2·p·N·n(n + n_u + n_y) flops for the sensitivities plus
//! 2p²·M for the QR (p parameters, N samples, M measured output samples);
//! the details, warm stages and bounds are in the docs of [`refine_pem`]'s
//! module (`state_space`).
//!
//! # Example
//!
//! ```
//! use lifted_lti::StateSpace;
//! use lifted_pem::{PemOptions, refine_pem};
//! use lifted_subspace::{Feedthrough, Record};
//! use nalgebra::DMatrix;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // y(k+1) = 0.9 y(k) + 0.5 u(k), noise free; start from a wrong pole.
//! let g = StateSpace::new(
//!     DMatrix::from_element(1, 1, 0.9),
//!     DMatrix::from_element(1, 1, 0.5),
//!     DMatrix::from_element(1, 1, 1.0),
//!     DMatrix::zeros(1, 1),
//!     Some(1.0),
//! )?;
//! let u = DMatrix::from_fn(400, 1, |k, _| if (k * 7919 + k / 3) % 5 < 2 { 1.0 } else { -1.0 });
//! let y = g.lsim(&u, None, None)?.y;
//! let start = StateSpace::new(
//!     DMatrix::from_element(1, 1, 0.8),
//!     DMatrix::from_element(1, 1, 0.5),
//!     DMatrix::from_element(1, 1, 1.0),
//!     DMatrix::zeros(1, 1),
//!     Some(1.0),
//! )?;
//! let opts = PemOptions { feedthrough: Feedthrough::Zero, ..Default::default() };
//! let rec = [Record { u: &u, y: &y, instrument: None }];
//! let fit = refine_pem(&start, None, &rec, &[], &opts)?;
//! let pole = fit.model.poles()?[0];
//! assert!((pole.re - 0.9).abs() < 1e-6);
//! # Ok(())
//! # }
//! ```
#![deny(missing_docs)]

mod arx;
mod budget;
mod checks;
pub mod error;
mod filters;
mod held_out;
mod impulse;
mod measured_delays;
mod oe;
mod polyest;
pub mod process;
mod regularized;
mod state_space;

pub use arx::{
    AStructure, ArxCompressedFit, ArxFit, ArxHyperparameters, ArxOptions, ArxRegulFit,
    ArxRegulOptions, ArxScan, ArxScanOptions, ArxScanRow, ArxStructure, DelayOptions,
    StructureCriterion, arx, arx_compressed, arx_horizons, arx_regul, arx_scan, estimate_delays,
};
pub use budget::PEM_SAMPLES_PER_PARAMETER;
pub use error::{Error, Result};
pub use held_out::{CheckRule, RefinementCheck, cross_validate_refinement};
pub use impulse::{ImpulseFit, ImpulseOptions, impulseest};
pub use measured_delays::{MeasuredDelayOptions, estimate_delays_measured};
pub use oe::{FStructure, OeFit, OeOptions, oe};
pub use polyest::{PolyestFit, PolyestOptions, armax, bj, polyest};
pub use process::{InterSample, ProcessFit, ProcessKind, ProcessModel, ProcessOptions, procest};
pub use regularized::Kernel;
pub use state_space::{
    CovarianceOptions, Kept, PemCost, PemFit, PemMethod, PemOptions, PemReport, PemWorkEstimate,
    StateSpaceUncertainty, Termination, covariance_work, pem_work_estimate,
    pem_work_estimate_of_sizes, refine_pem, state_space_covariance,
};

/// The README example, compiled and run as a doc test.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

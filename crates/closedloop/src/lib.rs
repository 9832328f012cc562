//! Closed-loop identification set-ups and the integral-control error study of
//! Ren & Zhu (2009), *PRBS closed-loop system identification error with
//! integration control*.
//!
//! # Method
//!
//! The loop of eq. (9) is y = G(r₂ + K(r₁ − y)), with the closed-loop transfer
//! matrices H₁ = GK(I + GK)⁻¹ (from r₁) and H₂ = (I + GK)⁻¹G = G(I + KG)⁻¹
//! (from r₂; MIMO ordering of erratum RZ-5). Identifying Ĥ₁ and/or Ĥ₂ and
//! solving for G gives the three set-ups (vocabulary of the thesis §7.1: the
//! general set-up is the *joint input–output* approach, the other two are
//! *indirect*):
//!
//! | set-up | excitation | eq. | recovery |
//! |---|---|---|---|
//! | [`Setup::General`] | r₁ and r₂ | (10) | G = (I − Ĥ₁)⁻¹Ĥ₂ |
//! | [`Setup::Controller`] | r₁ | (11) | G = Ĥ₁(I − Ĥ₁)⁻¹K⁻¹ |
//! | [`Setup::Compensator`] | r₂ | (12) | G = Ĥ₂(I − KĤ₂)⁻¹ |
//!
//! # Map of the crate
//!
//! | item | what |
//! |---|---|
//! | [`recover`] | model-level recovery: state space (MIMO, discrete or continuous, then minreal) and exact SISO polynomials without cancellation (the paper's approach (b): G = N₂/(D − N₁) when both Ĥ share D); exact loop algebra of Tables 2–3 |
//! | [`run_experiment`], [`ClosedLoopData`] | closed-loop inverse-PRBS experiments, one per excited r₁/r₂ channel (spec A2.3) |
//! | [`identify_closed_loop`], [`estimate_plant`] | identify Ĥ with any [`lifted_lti::Identifier`] (q-Markov Cover, subspace), recover the plant in approach (a) or (b), keep the diagnostics |
//! | [`metrics`] | DC-gain error, relative frequency-response error, error below the PRBS limit 1/(2 m n_r T), pole/zero comparison |
//! | [`feedback`] | feedback detection: each input's Granger test on a model's past output innovations (χ² at 1 %), single- and multirate; the workflow runs it on every identification |
//!
//! # Findings reproduced (spec A2.5–A2.7)
//!
//! With a proportional controller all set-ups recover the plant; with an
//! integral (PI) controller the closed loop carries almost no information
//! below the PRBS's lowest frequency ω₀ = 2π/(2 m n_r T), and the recovered
//! plant has a large low-frequency error (DC gain 0 in the indirect set-ups,
//! where K⁻¹ or (I − KĤ₂)⁻¹ amplifies it); raising the PRBS order lowers ω₀
//! and the error. The `lifted-tests` package reproduces Tables 5–6 and eqs.
//! (16)–(17) (`lifted reproduce --only A2.2-A2.7`; its test `a25_a26` prints
//! them beside the paper). On the command line: `lifted closedloop`.
//!
//! # Complexity
//!
//! Recovery: O(n³) for n closed-loop states (interconnection, minimal
//! realisation). Experiments: O(periods · 2m · n²) per excited channel;
//! identification as the chosen method.
//!
//! # Example
//!
//! ```
//! use lifted_closedloop::recover::{self, RecoveryOptions};
//! use lifted_lti::TransferFunction;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // G = 1/(0.3s+1) under PI control K = (0.2s+5)/s (Ren & Zhu Table 2).
//! let g = TransferFunction::from_coeffs(&[1.0], &[0.3, 1.0], None)?.to_ss()?;
//! let k = TransferFunction::from_coeffs(&[0.2, 5.0], &[1.0, 0.0], None)?.to_ss()?;
//! let (h1, h2) = recover::closed_loop(&g, &k)?;
//! let opts = RecoveryOptions::default();
//! for est in [
//!     recover::general(&h1, &h2, &opts)?,
//!     recover::controller(&h1, &k, &opts)?,
//!     recover::compensator(&h2, &k, &opts)?,
//! ] {
//!     assert_eq!(est.order(), 1);
//!     assert!((est.dc_gain()?[(0, 0)] - 1.0).abs() < 1e-9);
//! }
//! # Ok(())
//! # }
//! ```
#![deny(missing_docs)]

mod error;
mod experiment;
pub mod feedback;
pub mod metrics;
pub mod recover;
mod setup;

pub use error::{Error, Result};
pub use experiment::{
    Approach, ClosedLoopData, ExperimentOptions, PlantEstimate, PlantOptions, estimate_plant,
    identify_closed_loop, recover_plant, run_experiment,
};
pub use feedback::{FeedbackOptions, FeedbackTest, InputEvidence, arx_innovations, feedback_test};
pub use metrics::{Accuracy, FrequencyModel, accuracy, prbs_low_frequency, relative_error_at};
pub use recover::{RecoveryOptions, Setup};

/// The README example, compiled and run as a doc test.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

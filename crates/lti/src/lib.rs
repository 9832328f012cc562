//! Linear time-invariant systems for Lifted: state space and transfer
//! functions in continuous or discrete time, discretisation, responses,
//! norms, interconnections and reduction.
//!
//! # Map of the crate
//!
//! | type / function | what |
//! |---|---|
//! | [`StateSpace`] | (A, B, C, D, ts) with validation, JSON (serde), names, [`StateSpace::similarity_transform`], pure delays [`StateSpace::with_io_delays`] |
//! | [`TransferFunction`], [`SisoTf`], [`Poly`] | MIMO matrices of SISO ratios; polynomials in **descending powers** |
//! | [`TransferFunction::to_ss`], [`StateSpace::to_tf`] | conversions (controllable canonical form; per-entry minimal realisation + characteristic polynomials) |
//! | [`StateSpace::c2d`] ([`C2dOptions`]), [`StateSpace::d2c`] | ZOH (with exact fractional input delay), FOH, Tustin (prewarp); inverse ZOH by the principal logarithm |
//! | [`StateSpace::poles`], [`StateSpace::zeros`], [`StateSpace::dc_gain`], [`StateSpace::is_stable`] | analysis (transmission zeros by the Emami-Naeini–Van Dooren reduction) |
//! | [`StateSpace::lsim`], [`StateSpace::step`], [`StateSpace::impulse`], [`StateSpace::markov_parameters`], [`StateSpace::covariance_parameters`] | time responses |
//! | [`StateSpace::freqresp`], [`StateSpace::bode`], [`StateSpace::h2_norm`], [`StateSpace::hinf_norm`] | frequency domain and norms |
//! | [`series`], [`parallel`], [`feedback`], [`append`], [`StateSpace::inverse`] | interconnections (MIMO) |
//! | [`StateSpace::minreal`], [`StateSpace::balanced_truncation`] | reduction (staircase; square-root balanced truncation) |
//! | [`PolyModel`] ([`Polynomials`], [`PolyOrders`], [`PolyFamily`]) | polynomial models (MATLAB `idpoly`: ARX, ARMAX, OE, BJ, FIR; q⁻¹ coefficients in **ascending** powers, delays `nk` per input): parameters and covariance, [`PolyModel::to_ss`] / [`PolyModel::to_innovations_ss`] / [`PolyModel::to_tf`], [`PolyModel::from_tf`] / [`PolyModel::from_ss`], simulation, prediction, frequency response, stability (module [`polymodel`]) |
//! | [`spectral::welch`] | empirical frequency response from data (Welch's averaged periodograms, Ĝ = Φ̂_yu Φ̂_u⁻¹) |
//!
//! # Conventions (used by every Lifted crate)
//!
//! * Matrices are `nalgebra::DMatrix<f64>`, complex numbers `num_complex::Complex64`.
//! * Time series are `DMatrix<f64>` with **one row per sample, one column per
//!   channel** (MATLAB/CSV layout).
//! * Markov parameters are `Vec<DMatrix<f64>>`, H₀ = D first.
//! * Polynomial coefficients are in **descending powers** (MATLAB/scipy):
//!   `[1, 2, 3]` is s² + 2s + 3. Discrete transfer functions use positive
//!   powers of z. The exception is [`PolyModel`], whose polynomials are in
//!   the delay operator q⁻¹ with **ascending** powers (MATLAB `idpoly`):
//!   `[1, -0.5]` is 1 − 0.5 q⁻¹.
//! * `ts: None` is continuous time, `Some(T)` discrete with period T seconds;
//!   frequencies are always in rad/s (discrete: z = e^{jωT}).
//!
//! # Methods and sources
//!
//! * ZOH: expm([A B; 0 0]T); the fractional input delay τ = dT + δ by the
//!   modified z-transform realised with one extra state per delayed input.
//!   d2c: logm([A_d B_d; 0 I])/T, the "approach (b)" of the spec (A2.3) used
//!   to reproduce Ren & Zhu (2009) Tables 5–6; it fails with a named error
//!   when the principal logarithm does not exist (spec, pitfall 2).
//! * Markov parameters H₀ = D, Hᵢ = CAⁱ⁻¹B and covariance parameters
//!   Rᵢ = CAⁱXCᵀ + HᵢWDᵀ with X = AXAᵀ + BWBᵀ: Zhu (2000) eqs. (III-2),
//!   (III-3) (the seed writes D for our B and H for our D).
//! * Closed loop (Ren & Zhu 2009, eq. 9): H₁ = GK(I + GK)⁻¹ is
//!   `feedback(K·G, I)` and H₂ = (I + GK)⁻¹G = G(I + KG)⁻¹ is `feedback(G, K)`
//!   (erratum RZ-5 for the MIMO ordering).
//! * H∞: Bruinsma–Steinbuch Hamiltonian iteration (continuous), bilinear
//!   map for discrete models. H2 and balanced truncation from the Gramians
//!   (Lyapunov equations of `lifted-linalg`).
//!
//! Every function validates user data (finite entries, shapes, positive
//! finite `ts`, properness where required) and returns a named [`Error`].
//! Complexities are stated per function; the dense kernels are O(n³).
//!
//! # Example
//!
//! ```
//! use lifted_lti::{C2dOptions, HinfOptions, TransferFunction};
//!
//! # fn main() -> Result<(), lifted_lti::Error> {
//! // 1/(s² + 0.2 s + 1): ζ = 0.1, resonance peak 1/(2ζ√(1−ζ²)) ≈ 5.025
//! let g = TransferFunction::from_coeffs(&[1.0], &[1.0, 0.2, 1.0], None)?;
//! let ss = g.to_ss()?;
//! let hinf = ss.hinf_norm(&HinfOptions::default())?;
//! assert!((hinf.norm - 1.0 / (0.2 * (1.0f64 - 0.01).sqrt())).abs() < 1e-6);
//! let gd = ss.c2d(0.1, &C2dOptions::default())?;
//! assert!((gd.dc_gain()?[(0, 0)] - 1.0).abs() < 1e-12);
//! println!("{}", gd.to_tf(&Default::default())?);
//! # Ok(())
//! # }
//! ```
#![deny(missing_docs)]

mod analysis;
mod connect;
mod convert;
pub mod data;
mod discretize;
pub mod error;
mod flat;
mod freq;
pub mod identify;
mod la;
pub mod model_file;
mod operating_point;
pub mod poly;
pub mod polymodel;
mod predict;
mod reduce;
mod response;
pub mod spectral;
mod ss;
pub mod ss_uncertainty;
mod tf;
pub mod validation;

pub use connect::FeedbackSign;
pub use connect::{append, feedback, parallel, series};
pub use data::{
    DataError, Dataset, InputChannel, LiftOrdering, Lifted, OutputChannel, SamplingError,
    TIME_STEP_TOLERANCE, interpolate_unmeasured, output_sampling, period_from_times, snap_period,
    time_step_within,
};
pub use discretize::{C2dMethod, C2dOptions};
pub use error::{Error, Result};
pub use freq::{Bode, HinfNorm, HinfOptions};
pub use identify::{Identified, Identifier};
pub use model_file::{ModelFile, ModelFileError};
pub use operating_point::OperatingPoint;
pub use poly::{Poly, cancel_common_roots};
pub use polymodel::{
    FreqStd, POLY_TRIM_TOL, PolyFamily, PolyModel, PolyOrders, Polynomials, normal_quantile,
    student_t_quantile,
};
pub use reduce::{Balancing, MinrealOptions};
pub use response::SimResult;
pub use ss::StateSpace;
pub use ss_uncertainty::SsCovariance;
pub use tf::{SisoTf, TransferFunction};
pub use validation::{
    InitialCondition, OutputValidation, Residual, SimulationFit, Validation, ValidationOptions,
    simulation_fits, validate,
};

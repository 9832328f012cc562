//! Weighted multirate q-Markov Cover identification from steady-state PRBS data
//! (Zhu 2000, §§III–IV; Ren & Zhu 2009, §4; for `n_r = 1` the single-rate method of
//! Zhu, Skelton & Li 1995).
//!
//! # Method (spec A1.4, the corrected algorithm)
//!
//! Input channel `l = 1…n_w` is excited **alone** (one experiment per channel) by an
//! inverse PRBS `u_l` of order `n` (`m = 2ⁿ − 1`) and magnitude `a_l`, held `n_r`
//! output samples. One steady-state period `N = 2 n_r m` of the outputs is used
//! (checked by the antisymmetry test `y(k) ≈ −y(k + n_r m)`, erratum Z-12). With all
//! correlations circular over that period and normalised by `1/(2m)` (erratum Z-2):
//!
//! 1. `R_yy(τ) = (1/2m) Σ_l Σ_k y^l(k+τ) y^l(k)ᵀ`, τ < q (III-22).
//! 2. Markov parameters, column `l` of `H_τ`: for `n_r = 1`,
//!    `h^l(τ) = (1/2m) Σ_k y^l(k+τ) u_l(k) / a_l²` (III-23); for `n_r > 1` the causal
//!    hold-deconvolution `g^l(τ) = (1/(2m a_l²)) Σ_p y^l(p n_r + τ) u_l(p)`,
//!    `h^l(τ) = g^l(τ) − g^l(τ−1) + h^l(τ−n_r)` (erratum Z-8;
//!    [`MarkovEstimator::PrintedIII23`] keeps the printed form for comparison).
//! 3. `R_q` (block Toeplitz, upper blocks `R_yy(j−i)ᵀ`, Z-6), `H_q` (lower block
//!    Toeplitz), `W_q` full block Toeplitz with `W(τ) = diag_l (n_r − τ(m−1)/m) a_l²`
//!    for `τ < n_r`, 0 beyond (III-13, corrected II-10 from `lifted-prbs`, Z-7),
//!    `Q_q = I_q ⊗ Q`.
//! 4. `D_q = Q_q (R_q − H_q W_q H_qᵀ) Q_qᵀ = P̂ Λ P̂ᵀ + P̃ Λ̃ P̃ᵀ` in descending order
//!    (III-25); `P_q = P̂ Λ^{1/2}` for the order `r` (III-26). If `D_q` is not positive
//!    semidefinite the data are not q-identifiable (Lemma III-1): the diagnostics say
//!    so and the least-squares cover is returned ([`CoverKind::LeastSquares`]);
//!    square roots are only taken of eigenvalues above `eigen_tol · λ₁`.
//! 5. `P`, `P̄` = block rows `0…q−2`, `1…q−1` of `P_q` (III-27),
//!    `M_q = (I ⊗ Q)[H_1; …; H_{q−1}]`.
//! 6. `Â = P⁺P̄`, `D̂ = P⁺M_q` (plus `V_b U V_dᵀ [I_r; 0]`, `V_b U V_dᵀ [0; I_{n_w}]`
//!    when `P` is rank deficient, III-28 – III-30, Z-10), `Ĉ = Q⁻¹P₀`, `Ĥ = H₀`.
//!
//! The model `(Â, D̂, Ĉ, Ĥ)` (our `(A, B, C, D)`) is a [`lifted_lti::StateSpace`] at
//! the output period. It is checked for stability (erratum Z-9): an unstable cover
//! is an error unless [`QMarkovOptions::require_stable`] is false, and is always
//! flagged in [`Diagnostics::stable`].
//!
//! # Entry points
//! * [`QMarkov`]: the common [`lifted_lti::Identifier`] trait on
//!   [`lifted_lti::Dataset`]s; experiment `l` excites input channel `l` only.
//! * [`identify_records`]: plain matrices, one [`ChannelRecord`] per input channel.
//! * [`realize`]: steps 3–6 from given [`CoverData`] (`R_yy`, `H`, `W`).
//! * [`largest_gap_order`]: the order suggestion from the eigenvalues of `D_q`.
//!
//! # Complexity
//! The correlations cost O(N log N) per output pair and per output–input pair
//! (FFT through `lifted-prbs`; its direct method, used below
//! [`lifted_prbs::FFT_THRESHOLD`] samples, is O(N²) ≤ O(128 N)); the cover costs
//! O((q n_y)³) (symmetric eigen-decomposition of `D_q`); the diagnostics simulate
//! the model over one period per experiment, O(N r²). Measured figures are in the
//! crate README (`cargo bench -p lifted-qmarkov`).
//!
//! # Example
//! ```
//! use lifted_lti::StateSpace;
//! use lifted_prbs::{InversePrbs, InversePrbsOptions};
//! use lifted_qmarkov::{ChannelRecord, QMarkovOptions, RecordMode, identify_records};
//! use nalgebra::DMatrix;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // y(k+1) = 0.8 y(k) + 0.2 w(k), excited by an inverse PRBS of order 6 (m = 63).
//! let plant = StateSpace::new(
//!     DMatrix::from_element(1, 1, 0.8),
//!     DMatrix::from_element(1, 1, 0.2),
//!     DMatrix::from_element(1, 1, 1.0),
//!     DMatrix::zeros(1, 1),
//!     Some(0.1),
//! )?;
//! let prbs = InversePrbs::new(&InversePrbsOptions { order: 6, amplitude: 1.0, hold: 1, taps: None })?;
//! let w = prbs.generate(10 * prbs.period() as usize); // ten periods from rest
//! let y = plant.lsim(&DMatrix::from_column_slice(w.len(), 1, &w), None, None)?.y;
//! let opts = QMarkovOptions {
//!     q: 10,
//!     order: Some(1),
//!     prbs_order: 6,
//!     record: RecordMode::LastPeriod,
//!     ..Default::default()
//! };
//! let id = identify_records(&[ChannelRecord { input: w, output: y }], 0.1, &opts)?;
//! let pole = id.model.poles()?[0];
//! assert!((pole.re - 0.8).abs() < 0.02);
//! assert!((id.model.dc_gain()?[(0, 0)] - 1.0).abs() < 0.05);
//! # Ok(())
//! # }
//! ```
#![deny(missing_docs)]

mod cover;
mod dataset;
mod error;
mod identify;
mod options;

pub use cover::{CoverData, CoverKind, CoverSettings, Realization, largest_gap_order, realize};
pub use dataset::QMarkov;
pub use error::{Error, Result};
pub use identify::{ChannelRecord, Diagnostics, identify_records};
pub use options::{MarkovEstimator, QMarkovOptions, RecordMode, WeightingStructure};

/// The README example, compiled and run as a doc test.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

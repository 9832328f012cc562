//! Model predictive control for multirate sampled-data systems (Li 2001,
//! Chapters 8 and 9).
//!
//! * [`Dmc`] — dynamic matrix control on the step-response coefficients a_i
//!   of P_T/Δ (8.6): free response f̂(t+j|t) = v(t) + Σ_{i=1}^{N}(a_{i+j}−a_i)Δu(t−i)
//!   (8.8, with the **+y(nk)** of erratum L-19), dynamic matrix 𝒜, gain
//!   K_c = (𝒜ᵀQ𝒜 + R)⁻¹𝒜ᵀQ, receding horizon; from a model ([`Dmc::new`]) or
//!   from measured step-response coefficients ([`Dmc::from_steps`]).
//! * [`StateSpaceMpc`] — the same law on the realisation of P_T/Δ (8.10–8.14):
//!   Ŷ = Γx_d + HΔU + 1⊗(y(nk) − C_Ix_d(nk)), MIMO.
//! * Dual-rate inferential MPC: both controllers accept `None` for an output
//!   that is not sampled at this instant and use the minimum-variance
//!   inter-sample estimate instead (equations after (8.8) and (8.14),
//!   corrected per L-19). [`SlowRate`] + [`hold_model`] give the slow
//!   single-rate MPC at nT.
//! * Limits on u, Δu and the predicted y (not in the thesis): [`MoveLaw`]
//!   solves the QP with clarabel when the closed form violates a limit
//!   ([`Error::Infeasible`] when no move sequence satisfies them);
//!   [`Predictive`] exposes the move plan and a forced-QP update.
//! * [`DualRateLoop`] — the Chapter 9 scheme (uncorrected parallel model,
//!   periodic switch): simulation, monodromy matrix, lifted closed loop.
//! * [`beta_sr`], [`beta_dr`], [`beta_dr_lifted`], [`beta_socp`] — Prop. 6 /
//!   Cor. 1 robustness measures (9.8), SISO and MIMO (all outputs sampled
//!   every n): closed form via the alias formula
//!   β_dr = max_θ √(λ_max((1/n)Σ_l T(z_l)ᴴT(z_l))), a brute-force lifted
//!   SVD, and the conic form of (9.8) on a θ grid solved by clarabel.
//! * [`gamma_sr`], [`gamma_dr`], [`prop5`] — Prop. 5 (§9.4) as convex
//!   programmes: FIR Youla parameter Q, min ‖(I − PQ)W₂‖ (9.3) and
//!   min ‖(I − P̲Q̲R₁)W̲₂‖ (9.7) on a frequency grid, solved as SOCPs (with
//!   cutting planes for the spectral norm of matrices, [`NormMinimax`]);
//!   γ_dr(L) ≥ γ_sr(L) holds exactly on the grids used by [`prop5`].
//! * [`simulate`] — closed loop with IAE, overshoot, settling time, input energy.
//!
//! Complexity: building a controller costs O((hp)(mn_u)² + (mn_u)³); an
//! unconstrained update is O(hp·mn_u) plus the free response; a constrained
//! update solves a dense QP with m·n_u variables. The robustness and Prop. 5
//! routines state their costs in their docs (dominated by K frequency
//! evaluations of lifted n-fold systems and one interior-point solve per
//! cutting-plane round).
//!
//! ```
//! use lifted_lti::StateSpace;
//! use lifted_mpc::{LoopSetup, MpcOptions, StateSpaceMpc, simulate};
//! use nalgebra::{DMatrix, dmatrix};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // y(k) = 0.9 y(k−1) + 0.1 u(k−1)
//! let plant = StateSpace::new(dmatrix![0.9], dmatrix![1.0], dmatrix![0.1], dmatrix![0.0], Some(1.0))?;
//! let mut mpc = StateSpaceMpc::new(&plant, &MpcOptions::default())?;
//! // output sampled every 4 fast samples: inferential MPC
//! let setup = LoopSetup::new(DMatrix::from_element(80, 1, 1.0), vec![4]);
//! let run = simulate(&plant, &mut mpc, &setup)?;
//! assert!((run.y[(79, 0)] - 1.0).abs() < 1e-6);
//! # Ok(()) }
//! ```
#![deny(missing_docs)]

mod complex_svd;
mod conic;
mod controller;
mod dmc;
pub mod error;
mod gpc;
mod inferential;
mod law;
mod lifting;
mod model;
mod options;
mod prop5;
mod robust;
mod simulate;

pub use conic::{MinimaxOptions, MinimaxSolution, NormMinimax};
pub use controller::{Controller, Predictive, SlowRate};
pub use dmc::Dmc;
pub use error::{Error, Result};
pub use gpc::StateSpaceMpc;
pub use inferential::{DualRateLoop, DualRateResponse};
pub use law::{MoveLaw, Moves, dynamic_matrix};
pub use lifting::{PeriodicStep, lift, lift_periodic, sigma_max};
pub use model::{hold_model, integrated_model, step_coefficients};
pub use options::{Constraints, MpcOptions};
pub use prop5::{ModelMatching, Prop5Comparison, Prop5Options, gamma_dr, gamma_sr, prop5};
pub use robust::{
    Beta, ConicBeta, ConicOptions, LiftedPieces, RobustnessOptions, Uncertainty, alias_gain,
    beta_dr, beta_dr_lifted, beta_socp, beta_sr, lifted_response, robustness_map,
};
pub use simulate::{LoopResult, LoopSetup, Performance, performance, simulate};

/// The README example, compiled and run as a doc test.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

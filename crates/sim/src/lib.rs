//! Simulation of multirate sampled-data experiments for Lifted.
//!
//! # Map of the crate
//!
//! | item | what |
//! |---|---|
//! | [`Plant`] ([`Delays`]) | continuous plant discretised by ZOH with **exact** fractional input/output delays, or a discrete plant at the base period T |
//! | [`Controller`] | discrete controller (state space, transfer function, gain, decentralised with open loops) at T, or at m·T executing every m samples at a chosen phase |
//! | [`WholeLoop`], [`closed_loop`] | a continuous closed loop discretised as a whole (Ren & Zhu, spec A2.3); the loop algebra y = G(r₂ + K(r₁ − y)) |
//! | [`Simulator`] | open loop, plant + controller (fast, hold-last or inferential feedback), or a whole loop; input holds m_i and output sampling (J_i, offset); produces a [`lifted_lti::Dataset`] ([`SimOutput`]) or fills reusable [`SimSignals`] |
//! | [`NoiseSpec`] | seeded white noise through a (Box–Jenkins) noise model, optionally integrated, at an absolute level or a per-channel SNR (variance or std ratio) |
//! | [`Simulator::periodic_steady_state`] | one period of the periodic steady state: exact x₀ = (I − Φ)⁻¹x_P or iterated until y(k) ≈ −y(k + P/2) |
//! | [`plants`] | the reference plants of the seeds (stirred tanks, diesel engine, Ren & Zhu, thesis Ch. 4, 7, 9) |
//!
//! # Method
//!
//! Everything runs at the base period T. A continuous plant with input
//! delay τ = dT + δ is discretised by ZOH with the modified z-transform
//! (`lifted_lti::StateSpace::c2d`): the response at the samples is exact for
//! held inputs, never rounded to a whole number of samples. An output delay
//! τ_i is realised exactly by shifting every input of row i by τ_i.
//!
//! The loop (spec A2.2, negative feedback) at sample k is
//!
//! * u(k) = r₂(k) + K(r₁ − v)(k) at the start of each input's hold block
//!   (u held otherwise, m_i samples; thesis eq. 3.1 setting); a controller
//!   whose model is at m·T runs only at k ≡ phase (mod m), its state frozen
//!   and its output held in between,
//! * y(k) = (Gu)(k) + v_n(k) with the output noise v_n = α ∘ H(q)e,
//! * v(k) = y(k) (fast feedback), the last sample of y (hold-last), or the
//!   inferential switch of thesis §9.3 (Fig. 9.4, spec A3.11):
//!   v_j(k) = y_j(k) when channel j samples k, else ŷ_j(k) = (P̂u)_j(k).
//!
//! Direct feedthrough (D_K D_G ≠ 0) is solved exactly per phase of the
//! sampling pattern, (I + S_h D_K D_v)u = a, or rejected with
//! [`Error::AlgebraicLoop`] when singular. A run stops with
//! [`Error::Diverged`] instead of returning NaNs.
//!
//! **SNR** (spec §0): SNR = var(noise-free output)/var(noise) per output
//! channel (or the std ratio), the noise scaled after it is generated: the
//! loop runs once noise-free to obtain y₀ (linearity), then with α_j chosen so
//! that the realised ratio on the record is exact — on every fast sample, or
//! (`SimOptions::snr_samples` = [`SnrSamples::Measured`]) on the samples at
//! which each output channel is measured.
//!
//! **Periodic steady state** (spec pitfall 7; Zhu 2000 IV.B, erratum Z-12):
//! the one-period map z ↦ Φz + f of the whole simulator state (plant,
//! controller, parallel model, held values) is built by simulation, and
//! z₀ = (I − Φ)⁻¹f; or the loop runs period by period until
//! max|y(k) + y(k + P/2)| ≤ tol·max|y|.
//!
//! # Complexity
//!
//! A run costs O(N · r · c) for the fused per-phase map (r = live states +
//! n_y + n_u rows, c ≤ n_z + 2n_y + n_u active columns): one dense product
//! per sample, blocks of 64 samples, no allocation in the loop ([`Simulator::simulate_reference`] steps
//! the blocks instead, O(N(n² + nm + pn)); both agree to rounding). The
//! per-phase matrices cost (frame period) · c reference steps to build.
//! [`Simulator::simulate_into`] reuses caller buffers (see the criterion
//! bench and README for the measured rate). The exact steady state costs n_z + 1 runs
//! of one period plus an O(n_z³) solve.
//!
//! # Example
//!
//! ```
//! use lifted_lti::TransferFunction;
//! use lifted_sim::{Delays, Excitation, NoiseSpec, Plant, Simulator};
//! use nalgebra::DMatrix;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // e^{-2.5 s}/(10 s + 1) at T = 1 s: the 2.5 s delay is exact, not rounded.
//! let g = TransferFunction::from_coeffs(&[1.0], &[10.0, 1.0], None)?;
//! let plant = Plant::continuous_tf(&g, 1.0, &Delays::input(vec![2.5]))?;
//! let sim = Simulator::open_loop(plant)
//!     .with_sampling(&[(5, 0)])? // output sampled every 5 base periods
//!     .with_noise(NoiseSpec::white_snr(10.0, 42))?;
//! let out = sim.simulate(&Excitation::input(DMatrix::from_element(200, 1, 1.0)))?;
//! assert_eq!(out.data.output_samples(0)?.0.len(), 40);
//! // step response without noise: 1 − e^{−(k − 2.5)/10} for k ≥ 3
//! let k = 50.0;
//! assert!((out.y_clean[(50, 0)] - (1.0 - f64::exp(-(k - 2.5) / 10.0))).abs() < 1e-12);
//! # Ok(())
//! # }
//! ```
#![deny(missing_docs)]

mod engine;
mod error;
mod model;
mod noise;
pub mod plants;
mod simulator;
mod steady;

/// Longest period of the sampling/hold pattern (the least common multiple
/// of input holds, output periods and the controller period) the simulator
/// tabulates: 2^24 phases (its masks take O(period × channels) memory).
pub const MAX_PATTERN_PERIOD: usize = 1 << 24;

pub use error::{Error, Result};
pub use model::{Controller, Delays, Plant, WholeLoop, closed_loop};
pub use noise::{NoiseLevel, NoiseSpec, SnrDefinition};
pub use simulator::{
    Excitation, Feedback, SimOptions, SimOutput, SimSignals, Simulator, SnrSamples, StateLayout,
};
pub use steady::{PeriodicityCheck, SteadyState, SteadyStateMethod, SteadyStateOptions};

/// The README example, compiled and run as a doc test.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

//! Process models with dead time (MATLAB's `idproc` / `procest`): gain, time
//! constants and dead time of each input–output pair, for PID tuning, from
//! a step or PRBS test — on multirate records too (output measured at some
//! instants only, NaN elsewhere).
//!
//! **Structures** ([`ProcessKind`]), from input j to the output, the output
//! the sum over the inputs (plus an optional offset):
//!
//! | kind | G(s) |
//! |---|---|
//! | P1D | K e^{−θs} / (1 + T₁s) |
//! | P2D | K e^{−θs} / ((1 + T₁s)(1 + T₂s)) |
//! | P1DI | K e^{−θs} / (s(1 + T₁s)) |
//! | P2DZ | K (1 + T_z s) e^{−θs} / ((1 + T₁s)(1 + T₂s)) |
//! | P2DU | K e^{−θs} / (1 + 2ζT_w s + T_w² s²) |
//!
//! **Discretisation.** By default the input is held between samples (ZOH,
//! MATLAB's `InterSample` 'zoh'); [`InterSample::Foh`] takes it linear
//! between samples (a sampled continuous signal; the taps of the module
//! `model`'s `foh_taps`, below). The dead time is any θ ≥ 0, not only a multiple of
//! the sample period T: with θ = dT + δ, 0 ≤ δ < T, the held input reaches
//! the plant δ late in each period, which the modified z-transform realises
//! exactly with one extra state ([`lifted_lti::StateSpace::c2d`] with
//! [`lifted_lti::C2dOptions::input_delays`]):
//! x(k+1) = Φx(k) + Γ₀u(k−d) + Γ₁u(k−d−1), Γ₀ = ∫₀^{T−δ} e^{As}ds B,
//! Γ₁ = e^{A(T−δ)} ∫₀^δ e^{As}ds B. The integer part d is an index shift
//! in the estimator's simulation and d shift-register states in
//! [`ProcessModel::to_discrete_ss`]. First-order hold with θ = dT + δ:
//! on [0, δ) of a period the delayed input runs from u(k−d−1) to u(k−d),
//! on [δ, T) from u(k−d) to u(k−d+1), so
//! x(k+1) = Φx(k) + G₋₁u(k−d−1) + G₀u(k−d) + G₁u(k−d+1) with the three
//! taps from one augmented matrix exponential (Van Loan 1978; δ = 0 is the
//! triangle hold of Franklin, Powell & Workman §6.3.2); with d = 0 the
//! next sample enters, which the state z = x − G₁u(k) turns into the
//! direct term C G₁. The record starts at rest: the input 0 before its
//! first sample, ramping to u(0) over the period before it.
//!
//! **Estimator** ([`procest`]). The output-error cost
//! V = Σ_t ε(t)², ε = y(t) − ŷ(t | p), over the M samples where y was
//! measured (finite; NaN = not sampled, so a slow or irregular output uses
//! its samples only), ŷ the model's simulation at the fast rate from zero
//! initial state (the records are deviations from a steady operating point;
//! [`ProcessOptions::offset`] adds a constant output offset). Parameters in
//! a well-scaled box: K as is, log T for every time constant and for ζ, θ
//! projected onto [0, θ_max], T_z as is. Levenberg–Marquardt with
//! Marquardt's scaling on the R-only QR of [∂ŷ/∂φ | ε], the Jacobian by
//! central differences (one-sided at a bound); a trial is projected onto the
//! box and accepted when it lowers V.
//!
//! **Starts.** ŷ is linear in K (and in K·T_z, and the offset), so a grid
//! over the shape — time constants log-spaced from T/2 to a quarter of the
//! record, ζ ∈ {0.15 … 1} for P2DU, the dead time over 64 shifts up to
//! θ_max, refined to one sample around the best — solves for the gains by
//! least squares at every point (variable projection on a grid); the best
//! distinct points start Levenberg–Marquardt runs ([`ProcessOptions::starts`]).
//! On a step test (one input that changes once) Smith's two-point method
//! adds a start: K from the final value, T = 1.5 (t₆₃ − t₂₈),
//! θ = t₆₃ − T (for P1DI the slope and intercept of the ramp). Several
//! inputs: two sweeps of per-input grids, each against the output minus the
//! other inputs' current responses, then one joint run. The lowest cost is
//! kept.
//!
//! **Uncertainty.** Cov p = λ̂ (J_pᵀJ_p)⁻¹ at the optimum in the physical
//! parameters (K, T₁, …, θ), λ̂ = V / (M − d) (Ljung 1999, eq. (9.18)),
//! computed as D Cov φ D (D = ∂p/∂φ, diagonal). A dead time at its bound 0
//! has a one-sided derivative; its interval is then only indicative.
//!
//! **Complexity.** The grid: S shapes (12 for P1D/P1DI, 78 for P2D/P2DZ,
//! 60 for P2DU) × 64 shifts × M samples; each iteration 2d + 1 simulations,
//! O(N) each (n ≤ 3 states), and a QR of O(M d²), d = n_u × (3 … 5)
//! parameters. Memory O(N d).
//!
//! # Example
//!
//! ```
//! use lifted_pem::{ProcessKind, ProcessModel, ProcessOptions, procest};
//! use lifted_subspace::Experiment;
//! use nalgebra::DMatrix;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // First order plus dead time, K = 2, T₁ = 20 s, θ = 7.3 s, sampled at 1 s.
//! let truth = ProcessModel::from_parameters(ProcessKind::P1D, &[2.0, 20.0, 7.3], 1.0)?;
//! let u: Vec<f64> = (0..600).map(|k| if (k / 40) % 2 == 0 { 1.0 } else { -1.0 }).collect();
//! let y = truth.simulate(&u)?;
//! let (u, y) = (DMatrix::from_column_slice(600, 1, &u), DMatrix::from_column_slice(600, 1, &y));
//! let fit = procest(&[Experiment { u: &u, y: &y }], ProcessKind::P1D, 1.0, &ProcessOptions::default())?;
//! let m = &fit.models[0];
//! assert!((m.k - 2.0).abs() < 1e-6 && (m.tp1 - 20.0).abs() < 1e-5 && (m.theta - 7.3).abs() < 1e-5);
//! # Ok(())
//! # }
//! ```

mod estimate;
mod model;

pub use estimate::{ProcessFit, ProcessOptions, procest};
pub use model::{InterSample, ProcessKind, ProcessModel};

#[cfg(test)]
mod tests;

//! Prediction-error refinement of a state-space model (PEM), started from a
//! subspace estimate.
//!
//! The model is the innovations form x(t+1) = A x + B u + K e,
//! y = C x + D u + e. Two costs ([`PemCost`]):
//!
//! * **prediction error**: the one-step predictor x̂(t+1) = A x̂ + B u +
//!   K (y − C x̂ − D u) runs over each record and the residuals
//!   e(t) = y(t) − C x̂ − D u are minimised over (A, B, C, D, K, x₀);
//! * **output (simulation) error**: K = 0, the residuals are y − ŷ of the
//!   simulation from x₀ — the cost a step-response or simulation-fit user
//!   cares about, consistent in open loop whatever the noise colour.
//!
//! **Closed loop.** The prediction-error cost with K free is the direct
//! method (Ljung 1999, §13.4): consistent on closed-loop data without an
//! instrument when the true system, noise included, is an innovations model
//! of the chosen order n — the noise filter shares the plant's poles
//! (ARMAX-like). Noise with dynamics of its own (a coloured disturbance
//! with other poles) lies outside an order-n innovations model of the plant
//! alone, and the feedback then carries the misfit into the plant estimate:
//! refine at the order of plant and noise together (as the predictor-based
//! [`lifted_subspace::pbsid_identify`] identifies them), or use an instrument
//! ([`lifted_subspace::iv_identify`]). No separate noise-model order is offered: in
//! state space the noise shares the state, so "a noise model of its own"
//! is the same as a larger n. The output-error cost is biased in closed
//! loop (the noise reaches the input through the controller).
//!
//! Multirate records: y holds NaN where an output is not sampled; the cost
//! uses only the measured samples while the model stays at the fast rate
//! (the predictor corrects with the measured outputs only).
//!
//! Each output's residuals are divided by the standard deviation of its
//! measured samples (units do not matter); the cost is V = ‖e‖²/M over the
//! M measured samples. The iterations themselves run on the outputs so
//! divided (the rows of C and D and the columns of K scaled to match, and
//! scaled back at the end), so that their absolute step and gradient
//! tolerances mean the same in any output units.
//!
//! **Variable projection** ([`PemMethod::VariableProjection`], the
//! default; Golub & Pereyra 1973, 2003; Kaufman 1975). In predictor form
//!
//! x̂(t+1) = Ā x̂ + B̄ u + K y,  ŷ = C x̂ + D u,  Ā = A − KC, B̄ = B − KD, (1)
//!
//! the residuals e = y − ŷ are, for fixed α = (Ā, C), **affine** in
//! β = (B̄, free D, K, x₀ per record) (for the output error K = 0 and
//! Ā = A: β = (B, D, x₀)). So V(α, β) is minimised over β exactly, by
//! one least-squares solve, at every α, and the iterations run on the
//! projected cost V(α, β̂(α)) alone: n² + n n_y parameters instead of
//! n² + n(n_u + 2n_y) + n_y n_u + n·records. This removes the valley
//! along which B (and K) trade off against A that made the joint
//! iterations converge linearly (Ruhe & Wedin 1980 compare the
//! convergence of the reduced and the joint Gauss–Newton iterations;
//! Ljung 1999, §10.2 for the Gauss–Newton iterations of prediction-error
//! methods). Each iteration:
//!
//! 1. the Jacobians J_β, J_α of e along the columns of the identity of β
//!    and of the local coordinates of α (below), by the sensitivity
//!    recursion, streamed into the R-only QR of [J_β J_α | e]:
//!    R = [R₁₁ R₁₂ r₁; 0 R₂₂ r₂; 0 0 ρ];
//! 2. Kaufman's step: R₂₂ is the R of P⊥J_α (J_α projected off the
//!    columns of J_β) and r₂ = P⊥e restricted to them, so the
//!    Levenberg–Marquardt step on α solves [R₂₂; √λ D] δ = [−r₂; 0]
//!    with D² = diag(R₂₂ᵀR₂₂) (Marquardt's scaling, λ from 1e-3, ÷3 on
//!    success, ×4 on failure);
//! 3. at the trial α + δ, β̂ is solved for (a Jacobian pass along β only,
//!    one Gauss–Newton step, exact since e is affine in β) and the trial
//!    kept when V decreases;
//! 4. stop when the full Gauss–Newton step predicts a relative decrease
//!    ‖r₂‖²/‖e‖² below [`PemOptions::expected_decrease_tolerance`] (the
//!    expected-improvement test of MATLAB's `ssest`), an accepted step
//!    lowers V by less than [`PemOptions::cost_tolerance`], the step or
//!    the gradient R₁₂ᵀr₁ + R₂₂ᵀr₂ is below its tolerance, or the work
//!    bound is reached.
//!
//! The model (1) is mapped back by A = Ā + KC, B = B̄ + KD, and its
//! directions by the derivative δA = δĀ + δK C + K δC,
//! δB = δB̄ + δK D + K δD, which is what the sensitivity recursion
//! below is given. Parameterising the innovations form by Ā instead of A
//! is what makes K a linear parameter; before (A, C, K as the nonlinear
//! part) the prediction cost still converged linearly.
//!
//! **Warm stages** ([`PemOptions::warm_start_samples`], default 5 000).
//! When the records are long, the iterations first run on their leading
//! parts (5 000 samples, then 20× more, … while a part is less than half
//! the records), each to a loose tolerance (1e-6) from where the previous
//! one stopped: a part's optimum is within its estimation error of the
//! next one's, so each stage needs one to three iterations. On the whole
//! records after a warm stage, the Gauss–Newton matrix is estimated from
//! a **Hessian subsample** (every sample of the first 256·s of each record,
//! which hold the x₀ transient, then one block of 256 samples in s, rows
//! scaled by √s, s = samples / 100 000), while the gradient Jᵀe uses
//! every sample: with R₁₁ from the subsample, r̃ solves R₁₁ᵀr̃ = Jᵀe, so
//! the model ½‖R₁₁δ + r̃‖² has the exact gradient and a Hessian with
//! relative error O(√(p/10⁵)) (the contraction factor of the iterations
//! there); β is then re-corrected at every Jacobian.
//!
//! **Local coordinates** (McKelvey, Helmersson & Ribarits 2004, "Data
//! driven local coordinates for multivariable linear systems"): the
//! similarity transformations x → (I + T)x leave the cost unchanged and
//! span an n²-dimensional tangent space at the current model
//! (TĀ − ĀT, −CT on α); every step is taken in its orthogonal complement
//! (an orthonormal basis recomputed at each accepted iterate), so the
//! Gauss–Newton matrix is not singular along the similarity directions.
//! [`PemMethod::Joint`], the method before variable projection, iterates
//! on all of (A, B, C, D, K, x₀) in those coordinates (the tangent then
//! includes TB, TK, Tx₀) with the same step and stopping rules (the
//! expected-decrease test excepted).
//!
//! **Analytic Jacobian.** Along a basis direction β_i the model moves by
//! (δA, δB, δC, δD, δK, δx₀) (linear in β), and the state sensitivity
//! s = ∂x̂/∂β_i follows the predictor's own recursion:
//! δe(t) = −(C s + δC x̂ + δD u) on the measured outputs,
//! s(t+1) = A s + δA x̂ + δB u + δK e + K δe = (A − K_m C_m) s + forcing,
//! s(0) = δx₀ (K = 0 for the output error; K_m, C_m the measured outputs'
//! columns and rows). All p directions run together as an n × p matrix,
//! stored state-major so that every operation of a time step is an axpy
//! over the directions; the forcing of a column of [x̂; u; e] touches only
//! the directions that have it (a B̄ entry forces one input column, x₀
//! none). The rows of [J | e] are streamed in blocks into an R-only QR
//! (`lifted_linalg::RAccumulator`), so memory is O(p²), not O(M p), and
//! JᵀJ is never formed; the step's small system [R; √λ D] δ = [−r; 0] is
//! solved by a second small QR.
//!
//! **Threads** ([`PemOptions::threads`]): each record is split into
//! contiguous ranges. A serial predictor pass gives x̂ at each range start;
//! a parallel pass gives, per range, the sensitivities from a zero start
//! and the n × n transition of A − K_m C_m over the range, which chain
//! serially into the exact sensitivities at every range start; a second
//! parallel pass forms the rows and each range's R, and the R's are
//! stacked and reduced in range order. The Hessian subsample picks its
//! blocks by absolute sample index. The result depends on the thread
//! count through rounding only.
//!
//! **Cost** (the work model of [`PemOptions::max_work`] and
//! [`pem_work_estimate`]): one Jacobian pass along w directions costs
//! ≈ 2·w·N·n(n + n_u + n_y) flops for the sensitivities (twice with
//! threads) and 2(w + 1)²·M for the QR (M/s rows with a Hessian
//! subsample); a variable-projection iteration is one pass along all
//! p_β + p_α directions plus, per trial, one along the p_β linear ones and
//! a predictor run, plus the SVD of the similarity tangent
//! (4·len·n⁴ + 4·len³/3). Measured on one core of the 2-core bench
//! machine (`benches/benches/pem.rs`): 3×2, order 6, N = 2e4 converges
//! in about 6 iterations; 2×2, order 4, N = 1e6 in two warm stages and
//! two whole-record iterations (`crates/subspace/README.md`).
//!
//! Bounds, checked before anything is formed: at most one free parameter
//! per two measured output samples ([`Error::TooManyParameters`]), the
//! memory of the local coordinates and the Jacobian within the budget of
//! `lifted_linalg::budget`, and one iteration on the whole records within
//! [`PemOptions::max_work`] ([`Error::TooMuchWork`] otherwise). The work
//! of every pass is booked as it runs; the iterations stop when the next
//! one would exceed the bound ([`PemReport::iteration_cap`] then says how
//! many ran).
//!
//! References: G. H. Golub, V. Pereyra, "The differentiation of
//! pseudo-inverses and nonlinear least squares problems whose variables
//! separate", SIAM J. Numer. Anal. 10 (1973) 413–432; G. H. Golub,
//! V. Pereyra, "Separable nonlinear least squares: the variable
//! projection method and its applications", Inverse Problems 19 (2003)
//! R1–R26; L. Kaufman, "A variable projection method for solving
//! separable nonlinear least squares problems", BIT 15 (1975) 49–57;
//! A. Ruhe, P.-Å. Wedin, "Algorithms for separable nonlinear least squares
//! problems", SIAM Review 22 (1980) 318–337; L. Ljung, *System
//! Identification: Theory for the User*, 2nd ed., 1999, ch. 10 (and
//! §13.4 for closed loop); T. McKelvey, A. Helmersson, T. Ribarits, "Data
//! driven local coordinates for multivariable linear systems and their
//! application to system identification", Automatica 40 (2004)
//! 1629–1635.
//!
//! An iterate whose A has spectral radius ≥ 1 + δ
//! ([`PemOptions::marginal_tolerance`], default δ = 0), or, for the
//! prediction cost, whose predictor A − KC has spectral radius ≥ 1, is
//! rejected like a cost increase, so a stable start stays stable (δ = 0) or
//! within δ of the unit circle (an integrating plant: poles on the circle
//! that the data put just outside it stay there instead of being pulled
//! in); a start with ρ(A) ≥ 1 + δ is first stabilised (its unstable
//! eigenvalues reflected into the unit circle,
//! [`PemReport::stabilized_start`]) for either cost. A marginal start
//! whose predictor is unstable with its K and with K = 0 starts from the
//! observer gain of the Riccati equation with unit weights. The better of
//! the start and the refined model is kept ([`Kept`]), judged by the simulation error (the
//! validation fit) on optional validation records, or on the estimation
//! records.

use lifted_lti::StateSpace;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use lifted_linalg::spectral_radius;
use lifted_subspace::{Feedthrough, Record, estimate_x0};

mod covariance;
mod jacobian;
mod joint;
mod lm;
mod point;
mod problem;
mod projection;
mod warm;
mod work;

pub use covariance::{
    CovarianceOptions, StateSpaceUncertainty, covariance_work, state_space_covariance,
};
use point::{
    Layout, Point, STABILIZED_START_RADIUS, admissible, mean_square, output_weights, residuals,
};
use problem::{Limits, Outcome, Problem, WorkAccount};

/// The cost minimised by [`refine_pem`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum PemCost {
    /// One-step prediction error with the Kalman gain K among the
    /// parameters (default: statistically efficient when the noise is an
    /// innovations process; on the spec A3.7 stand-in it lowered every
    /// channel's step error, the output error did not).
    #[default]
    Prediction,
    /// Simulation (output) error, K = 0: consistent in open loop whatever
    /// the noise colour.
    OutputError,
}

/// Why the iterations stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Termination {
    /// Relative cost decrease of an accepted step below `cost_tolerance`.
    CostConverged,
    /// Step norm (in local coordinates) below `step_tolerance`.
    StepConverged,
    /// Gradient norm below `gradient_tolerance`.
    GradientConverged,
    /// `max_iterations` reached.
    MaxIterations,
    /// The damping grew past 1e16 without an acceptable step.
    NoProgress,
}

/// Which model [`refine_pem`] returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Kept {
    /// The refined model (it was at least as good).
    Refined,
    /// The starting model (the refined one was worse on the judging data).
    Initial,
}

/// How [`refine_pem`] iterates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum PemMethod {
    /// Variable projection (default): B − KD, the free D, K and x₀ solved
    /// for by least squares at every (A − KC, C), Levenberg–Marquardt on
    /// (A − KC, C) in local coordinates with Kaufman's Jacobian, after warm
    /// stages on the leading parts of long records (module docs). The
    /// prediction cost on records with unmeasured outputs runs
    /// [`PemMethod::Joint`] instead ([`PemReport::method`]).
    #[default]
    VariableProjection,
    /// Levenberg–Marquardt on all parameters (A, B, C, D, K, x₀) together
    /// (the method before 2026-11-26: linear convergence along the valley
    /// where B and K trade off against A; kept for multirate prediction
    /// and for comparison).
    Joint,
}

/// Options of [`refine_pem`]; `Default` gives the documented values.
#[derive(Debug, Clone, PartialEq)]
pub struct PemOptions {
    /// Cost. Default [`PemCost::Prediction`].
    pub cost: PemCost,
    /// Which entries of D are free. Default [`Feedthrough::Free`].
    pub feedthrough: Feedthrough,
    /// Largest number of accepted-or-rejected LM iterations. Default 100.
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this
    /// fraction. Default 1e-9.
    pub cost_tolerance: f64,
    /// Stop when the step norm (local coordinates) is below this times
    /// (1 + ‖θ‖). Default 1e-10.
    pub step_tolerance: f64,
    /// Stop when ‖Jᵀe‖∞ falls below this times the cost. Default 1e-10.
    pub gradient_tolerance: f64,
    /// Bound on the work of the whole refinement, in floating-point
    /// operations of the cost model of the module docs (see also
    /// [`pem_work_estimate`]). The work of every pass is booked as it
    /// runs; when the next Jacobian or trial would exceed the bound the
    /// iterations stop and [`PemReport::iteration_cap`] says so (the
    /// joint method books a fixed figure per iteration instead); when one
    /// iteration on the whole records exceeds it, [`Error::TooMuchWork`].
    /// Default 2e10 (a few seconds: ≈ 4e9 of these operations per second
    /// were measured on one core).
    pub max_work: f64,
    /// [`PemMethod::VariableProjection`] stops when the Gauss–Newton step
    /// at an iterate predicts a relative cost decrease below this (the
    /// expected-improvement test of MATLAB's `ssest`, whose default is
    /// 1e-4). Default 1e-6: below the statistical resolution of the cost
    /// (a relative change of about p/N between estimates from N samples
    /// with p parameters) for records up to 1e6 samples per parameter.
    pub expected_decrease_tolerance: f64,
    /// Iteration scheme. Default [`PemMethod::VariableProjection`].
    pub method: PemMethod,
    /// Warm stages of [`PemMethod::VariableProjection`]: when the records
    /// hold more than twice this many samples, the iterations first run
    /// on their leading parts (this many samples in all, then 20× more,
    /// … while a part is less than half the records), each to a relative
    /// cost decrease of 1e-6, then finish on the whole records with a
    /// Hessian subsample (module docs); 0 = never. Default 5 000 (on the
    /// bench cases the first stage takes about five cheap iterations and
    /// every later one two or three).
    pub warm_start_samples: usize,
    /// Threads for the Jacobian (contiguous ranges of each record, std
    /// scoped threads; results depend on the count through rounding only);
    /// 1 = single-threaded, 0 = all available cores. Default 1.
    pub threads: usize,
    /// Return the refined model even when the start simulates the judged
    /// records better ([`PemReport::judged`] still gives both errors): for
    /// a caller that judges the two itself, e.g. on held-out data
    /// ([`crate::cross_validate_refinement`]). Default false.
    pub keep_refined: bool,
    /// δ ≥ 0: an iterate (and the start) may have ρ(A) < 1 + δ, poles on
    /// or just outside the unit circle taken as integrators (marginal), not
    /// instability; the predictor A − KC of the prediction cost must still
    /// be stable. A start with ρ(A) ≥ 1 + δ is stabilised first. Default 0
    /// (every iterate stable); `lifted_workflow` derives δ from the
    /// record's length (its integrator tolerance, 2/N: the estimation
    /// error of a unit root is O(1/N), and ρ = 1 + 2/N grows by at most
    /// e² over N samples).
    pub marginal_tolerance: f64,
}

impl Default for PemOptions {
    fn default() -> Self {
        PemOptions {
            cost: PemCost::Prediction,
            feedthrough: Feedthrough::Free,
            max_iterations: 100,
            cost_tolerance: 1e-9,
            step_tolerance: 1e-10,
            gradient_tolerance: 1e-10,
            max_work: 2e10,
            expected_decrease_tolerance: 1e-6,
            method: PemMethod::VariableProjection,
            warm_start_samples: 5_000,
            threads: 1,
            keep_refined: false,
            marginal_tolerance: 0.0,
        }
    }
}

/// The method [`refine_pem`] runs: [`PemMethod::Joint`] for the
/// prediction cost on records with unmeasured outputs (multirate), where
/// the predictor's transition A − K_m C_m changes with the measured set m
/// and the residuals are therefore not affine in K at fixed (A − KC, C),
/// so variable projection in predictor coordinates does not apply;
/// `opts.method` otherwise.
fn effective_method(opts: &PemOptions, records: &[Record<'_>]) -> PemMethod {
    let unmeasured = records.iter().any(|r| r.y.iter().any(|v| v.is_nan()));
    if opts.cost == PemCost::Prediction && unmeasured {
        PemMethod::Joint
    } else {
        opts.method
    }
}

/// What the refinement did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PemReport {
    /// Cost used.
    pub cost: PemCost,
    /// Method run (the joint one for the prediction cost on multirate
    /// records, whatever [`PemOptions::method`] asked).
    #[serde(default)]
    pub method: PemMethod,
    /// LM iterations run (accepted and rejected steps).
    pub iterations: usize,
    /// Accepted steps.
    pub accepted: usize,
    /// Normalised cost (mean squared scaled residual) at the start.
    pub initial_cost: f64,
    /// Normalised cost at the end of the iterations.
    pub final_cost: f64,
    /// Why the iterations stopped.
    pub termination: Termination,
    /// Which model was returned.
    pub kept: Kept,
    /// The judging figure (mean squared scaled simulation error, x₀
    /// re-estimated, on the validation records or else the estimation
    /// records) of the start and of the refined model.
    pub judged: (f64, f64),
    /// The iterations run when [`PemOptions::max_work`] stopped them
    /// before `max_iterations` (the work bound, not convergence, then
    /// stopped the refinement); `None` when it did not.
    #[serde(default)]
    pub iteration_cap: Option<usize>,
    /// ρ(A) of the given start when it was unstable: the refinement then
    /// started from it with its unstable eigenvalues reflected into the
    /// unit circle (and K = 0 if the predictor was then unstable); `None`
    /// for a stable start.
    #[serde(default)]
    pub stabilized_start: Option<f64>,
    /// The refined realization had drifted (‖A‖_F above 10 √n for a
    /// stable A: coordinates, not dynamics, grown by the iterations) and
    /// was brought to its balanced realization — the same transfer
    /// functions of input and innovations, better conditioned (Moore 1981).
    #[serde(default)]
    pub balanced: bool,
}

/// A refined model.
#[derive(Debug, Clone, PartialEq)]
pub struct PemFit {
    /// (A, B, C, D) with the sample period of the start.
    pub model: StateSpace,
    /// Kalman gain K (n × n_y) for [`PemCost::Prediction`].
    pub kalman_gain: Option<DMatrix<f64>>,
    /// Initial state per estimation record.
    pub x0: Vec<DVector<f64>>,
    /// Iterations, costs and the keep-the-better decision.
    pub report: PemReport,
}

/// `set` with the outputs `ys` (one per record, in order).
fn with_outputs<'a>(set: &[Record<'a>], ys: &'a [DMatrix<f64>]) -> Vec<Record<'a>> {
    set.iter()
        .zip(ys)
        .map(|(r, y)| Record { y, ..*r })
        .collect()
}

fn check_records(model: &StateSpace, records: &[Record<'_>]) -> Result<usize> {
    if records.is_empty() {
        return Err(Error::NoData);
    }
    let (nu, ny) = (model.n_inputs(), model.n_outputs());
    let mut measured = 0;
    for r in records {
        crate::checks::check_record_shape("record (u, y)", r.u, r.y, nu, ny)?;
        crate::checks::check_finite("u", r.u)?;
        for ((row, col), v) in
            r.y.iter()
                .enumerate()
                .map(|(i, v)| ((i % r.y.nrows(), i / r.y.nrows()), v))
        {
            if v.is_infinite() {
                return Err(Error::NonFinite {
                    what: "y",
                    row,
                    col,
                });
            }
            if !v.is_nan() {
                measured += 1;
            }
        }
    }
    Ok(measured)
}

/// The free-D mask of `feedthrough` and the parameter layout of `model`
/// with `records` initial states (K free with `gain`).
fn masked_layout(
    model: &StateSpace,
    feedthrough: &Feedthrough,
    records: usize,
    gain: bool,
) -> Result<(DMatrix<bool>, Layout)> {
    let (n, nu, ny) = (model.order(), model.n_inputs(), model.n_outputs());
    let mask = feedthrough.mask(ny, nu)?;
    let d_free: Vec<(usize, usize)> = (0..ny)
        .flat_map(|o| (0..nu).map(move |j| (o, j)))
        .filter(|&(o, j)| mask[(o, j)])
        .collect();
    let lay = Layout {
        n,
        nu,
        ny,
        records,
        gain,
        d_free,
    };
    Ok((mask, lay))
}

/// The Kalman gain the prediction errors start from: the one given
/// (checked: n × n_y, finite) with `gain`, else zero.
fn start_gain(
    kalman_gain: Option<&DMatrix<f64>>,
    gain: bool,
    n: usize,
    ny: usize,
) -> Result<DMatrix<f64>> {
    match kalman_gain {
        Some(k) if gain => {
            if k.shape() != (n, ny) {
                return Err(Error::DimensionMismatch {
                    what: "Kalman gain",
                    expected: format!("{n}x{ny}"),
                    got: format!("{}x{}", k.nrows(), k.ncols()),
                });
            }
            crate::checks::check_finite("Kalman gain", k)?;
            Ok(k.clone())
        }
        _ => Ok(DMatrix::zeros(n, ny)),
    }
}

/// `d` with the entries `mask` does not free set to zero.
fn masked_d(d: &DMatrix<f64>, mask: &DMatrix<bool>) -> DMatrix<f64> {
    d.zip_map(mask, |v, free| if free { v } else { 0.0 })
}

/// Refines `initial` (with `kalman_gain` as the start of K for the
/// prediction cost; zero when `None`) on the estimation `records` by
/// Levenberg–Marquardt in data-driven local coordinates (module docs).
/// The refined model is kept only if its simulation error (x₀
/// re-estimated) on the `validation` records — or, when none are given, on
/// the estimation records — is not larger than the start's.
///
/// Errors: [`Error::NoData`], [`Error::DimensionMismatch`],
/// [`Error::NonFinite`] (u anywhere, y infinite; NaN y = not sampled),
/// [`Error::InvalidOption`] (a continuous model, bad tolerances),
/// [`Error::TooFewSamples`] when fewer measured samples than parameters,
/// [`Error::TooManyParameters`] when more than one free parameter per two
/// measured samples, [`Error::TooMuchWork`] when one iteration on the
/// whole records exceeds [`PemOptions::max_work`] (a bound reached later
/// stops the iterations, see [`PemReport::iteration_cap`]),
/// [`lifted_linalg::Error::TooLarge`] (wrapped) beyond the memory budget,
/// [`Error::Unstable`] when the start is unstable and defective (no
/// eigenbasis to stabilise it in) or its stabilised predictor is unstable for the chosen cost
/// (A for the output error, A − KC for the prediction error).
pub fn refine_pem(
    initial: &StateSpace,
    kalman_gain: Option<&DMatrix<f64>>,
    records: &[Record<'_>],
    validation: &[Record<'_>],
    opts: &PemOptions,
) -> Result<PemFit> {
    let ts = initial.ts().ok_or(Error::InvalidOption {
        what: "model",
        reason: "PEM refinement needs a discrete-time model".into(),
    })?;
    if opts.max_iterations == 0
        || opts.max_work.is_nan()
        || opts.max_work <= 0.0
        || !(opts.cost_tolerance >= 0.0
            && opts.step_tolerance >= 0.0
            && opts.gradient_tolerance >= 0.0
            && opts.expected_decrease_tolerance >= 0.0
            && opts.marginal_tolerance >= 0.0
            && opts.marginal_tolerance.is_finite())
    {
        return Err(Error::InvalidOption {
            what: "PemOptions",
            reason: "max_iterations ≥ 1, max_work > 0 and non-negative tolerances are required"
                .into(),
        });
    }
    let measured = check_records(initial, records)?;
    if !validation.is_empty() {
        check_records(initial, validation)?;
    }
    let (n, nu, ny) = (initial.order(), initial.n_inputs(), initial.n_outputs());
    // The iterations run on outputs divided by their standard deviations
    // (C, D rows and K columns scaled to match, undone at the end): the
    // step and gradient tolerances are absolute, and outputs in small units
    // (1e-6: a record in metres of a micrometre motion) stopped the
    // iterations where the same record in micrometres converged.
    let out_scale: Vec<f64> = output_weights(records, ny)
        .iter()
        .map(|w| {
            if w.is_finite() && *w > 0.0 {
                1.0 / w
            } else {
                1.0
            }
        })
        .collect();
    let scaled_y = |set: &[Record<'_>]| -> Vec<DMatrix<f64>> {
        set.iter()
            .map(|r| {
                let mut y = r.y.clone();
                for (o, s) in out_scale.iter().enumerate() {
                    y.column_mut(o).iter_mut().for_each(|v| *v /= s);
                }
                y
            })
            .collect()
    };
    let (y_est, y_val) = (scaled_y(records), scaled_y(validation));
    let (records, validation) = (
        with_outputs(records, &y_est),
        with_outputs(validation, &y_val),
    );
    let (records, validation) = (records.as_slice(), validation.as_slice());
    let gain = opts.cost == PemCost::Prediction;
    let method = effective_method(opts, records);
    let (mask, lay) = masked_layout(initial, &opts.feedthrough, records.len(), gain)?;
    let free = lay.len() - n * n;
    if measured <= free {
        return Err(Error::TooFewSamples {
            what: "the PEM refinement",
            measured,
            needed: free + 1,
        });
    }
    // The data must support the parameters, and the work must be bounded,
    // before the n² × len similarity tangent and the Jacobian are formed.
    crate::budget::check_pem_parameters(free, measured)?;
    crate::budget::check_pem_memory(n, lay.len(), measured)?;
    let samples: usize = records.iter().map(|r| r.u.nrows()).sum();
    let threads = lifted_linalg::budget::resolve_threads(opts.threads);
    let sizes = work::Sizes {
        n,
        nu,
        ny,
        samples,
        measured,
        threads,
        hessian_stride: 1,
    };
    // Work of one iteration on the whole records: more than the bound is
    // an error before anything runs.
    let per_iteration = match method {
        PemMethod::Joint => {
            crate::budget::pem_flops_per_iteration(n, nu, ny, lay.len(), samples, measured)
        }
        PemMethod::VariableProjection => {
            // After warm stages the whole records take the Hessian
            // subsample and model-β trials.
            let warmed = !warm::stage_sizes(samples, opts.warm_start_samples).is_empty();
            let w = work::ProjectionWork::new(
                &work::Sizes {
                    hessian_stride: warm::whole_stride(samples, warmed),
                    ..sizes
                },
                lay.linear_indices().len(),
                lay.nonlinear_indices().len(),
            );
            w.jacobian + if warmed { w.model_trial } else { w.trial }
        }
    };
    if per_iteration > opts.max_work {
        return Err(Error::TooMuchWork {
            what: "the PEM refinement",
            flops: per_iteration,
            limit: opts.max_work,
        });
    }
    let k0 = start_gain(kalman_gain, gain, n, ny)?;
    let mut d0 = masked_d(initial.d(), &mask);
    let (mut c0, mut k0) = (initial.c().clone(), k0);
    for (o, s) in out_scale.iter().enumerate() {
        c0.row_mut(o).iter_mut().for_each(|v| *v /= s);
        d0.row_mut(o).iter_mut().for_each(|v| *v /= s);
        k0.column_mut(o).iter_mut().for_each(|v| *v *= s);
    }
    let mut start = Point {
        a: initial.a().clone(),
        b: initial.b().clone(),
        c: c0,
        d: d0,
        k: k0,
        x0: Vec::new(),
    };
    // An unstable start (either cost) is stabilised first: its unstable
    // eigenvalues reflected into the unit circle, eigenvectors kept; a
    // predictor that is then unstable starts with K = 0.
    let marginal = opts.marginal_tolerance;
    let rho_start = spectral_radius(&start.a)?;
    let mut stabilized_start = None;
    if rho_start >= 1.0 + marginal {
        match lifted_linalg::reflect_into_unit_disc(&start.a, STABILIZED_START_RADIUS)? {
            Some(a) => {
                start.a = a;
                stabilized_start = Some(rho_start);
            }
            None => {
                return Err(Error::Unstable {
                    spectral_radius: rho_start,
                });
            }
        }
    }
    if gain && !admissible(&start, gain, marginal) {
        start.k = DMatrix::zeros(n, ny);
        // A marginal A (integrators kept, ρ(A) ≥ 1) has no stable
        // predictor with K = 0: the observer gain of the Riccati equation
        // with unit weights instead (A − KC stable whenever (A, C) is
        // detectable), as the IV route's predictor form takes.
        if !admissible(&start, gain, marginal)
            && let Ok(s) = lifted_linalg::dare(
                &start.a.transpose(),
                &start.c.transpose(),
                &DMatrix::identity(n, n),
                &DMatrix::identity(ny, ny),
                None,
            )
        {
            start.k = s.k.transpose();
        }
    }
    if !admissible(&start, gain, marginal) {
        return Err(Error::Unstable {
            spectral_radius: spectral_radius(&start.a)?,
        });
    }
    start.x0 = estimate_x0(&start.a, &start.b, &start.c, &start.d, records)?;
    let weights = output_weights(records, ny);
    let total = measured;
    let cost_of = |p: &Point| residuals(p, records, &weights, gain, total);
    let e0 = cost_of(&start).ok_or(Error::InvalidOption {
        what: "initial model",
        reason: "its residuals are not finite on the records".into(),
    })?;
    let initial_cost = mean_square(&e0);
    let limits = Limits {
        max_iterations: opts.max_iterations,
        cost_tolerance: opts.cost_tolerance,
        step_tolerance: opts.step_tolerance,
        gradient_tolerance: opts.gradient_tolerance,
        expected_decrease_tolerance: opts.expected_decrease_tolerance,
    };
    let mut account = WorkAccount {
        limit: opts.max_work,
        spent: 0.0,
        stopped: false,
    };
    let whole = Problem {
        lay: &lay,
        records,
        weights: &weights,
        gain,
        threads,
        measured,
        samples,
        hessian_stride: 1,
        marginal,
    };
    let outcome = match method {
        PemMethod::Joint => {
            joint::minimise(&whole, &start, e0, &limits, per_iteration, &mut account)?
        }
        PemMethod::VariableProjection => warm::minimise(
            &whole,
            &start,
            &limits,
            opts.warm_start_samples,
            &mut account,
        )?,
    };
    let iteration_cap = (account.stopped && outcome.termination == Termination::MaxIterations)
        .then_some(outcome.iterations);
    let Outcome {
        point,
        cost,
        iterations,
        accepted,
        termination,
    } = outcome;
    // A drifted realization is balanced (same model, conditioned).
    let (point, balanced) = match point.drifted().then(|| point.balanced()).flatten() {
        Some(b) => (b, true),
        None => (point, false),
    };
    // Keep the better of the start and the refined model, judged by the
    // simulation error (x₀ re-estimated, K unused) on the validation records
    // or, without them, on the estimation records.
    let judged_on = if validation.is_empty() {
        records
    } else {
        validation
    };
    let judge = |p: &Point| -> f64 {
        let sim = Point {
            k: DMatrix::zeros(n, ny),
            x0: match estimate_x0(&p.a, &p.b, &p.c, &p.d, judged_on) {
                Ok(x) => x,
                Err(_) => return f64::INFINITY,
            },
            ..p.clone()
        };
        let w = output_weights(judged_on, ny);
        let count = judged_on
            .iter()
            .map(|r| r.y.iter().filter(|v| !v.is_nan()).count())
            .sum();
        residuals(&sim, judged_on, &w, false, count).map_or(f64::INFINITY, |v| mean_square(&v))
    };
    let (j0, j1) = (judge(&start), judge(&point));
    let (mut best, kept) = if j1 <= j0 || opts.keep_refined {
        (point, Kept::Refined)
    } else {
        (start, Kept::Initial)
    };
    // Back to the outputs' units.
    for (o, s) in out_scale.iter().enumerate() {
        best.c.row_mut(o).iter_mut().for_each(|v| *v *= s);
        best.d.row_mut(o).iter_mut().for_each(|v| *v *= s);
        best.k.column_mut(o).iter_mut().for_each(|v| *v /= s);
    }
    let model = StateSpace::new(best.a, best.b, best.c, best.d, Some(ts))?;
    Ok(PemFit {
        model,
        kalman_gain: gain.then_some(best.k),
        x0: best.x0,
        report: PemReport {
            cost: opts.cost,
            method,
            iterations,
            accepted,
            initial_cost,
            final_cost: cost,
            termination,
            kept,
            judged: (j0, j1),
            iteration_cap,
            stabilized_start,
            balanced,
        },
    })
}

/// (Jacobians, trials) of a typical first (or only) stage of variable
/// projection from a subspace start: the largest counts measured by
/// `benches/examples/pem_cost.rs` (up to 22 iterations in all, most of
/// them on the first stage).
const FIRST_STAGE: (f64, f64) = (16.0, 20.0);

/// (Jacobians, trials) of a later warm stage or of the whole records
/// after warm stages (two or three iterations measured).
const LATER_STAGE: (f64, f64) = (3.0, 3.0);

/// The predicted work of [`refine_pem`] in the units of
/// [`PemOptions::max_work`] (floating-point operations of the cost model
/// in the module docs), from the sizes alone.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PemWorkEstimate {
    /// One iteration on the whole records (a Jacobian along every
    /// direction and one trial): [`refine_pem`] refuses to start when it
    /// exceeds [`PemOptions::max_work`].
    pub per_iteration: f64,
    /// A typical whole refinement from a subspace start: for
    /// [`PemMethod::VariableProjection`] 16 Jacobians and 20 trials on the
    /// first (or only) stage, three of each on every later warm stage and
    /// on the whole records (with the Hessian subsample), the largest
    /// counts measured by `benches/examples/pem_cost.rs`; for
    /// [`PemMethod::Joint`] 45 iterations (where the default work bound
    /// stopped it on the 3×2 bench case). Capped at
    /// [`PemOptions::max_work`].
    pub typical: f64,
    /// Warm stages before the whole records.
    pub warm_stages: usize,
    /// The method the estimate is for: [`PemOptions::method`], or the
    /// joint iterations that the prediction cost takes on records with
    /// unmeasured samples (their operations run at a different rate).
    #[serde(default)]
    pub method: PemMethod,
}

/// Predicts the work of [`refine_pem`] for a model of `initial`'s sizes
/// on `records` with `opts`, without running it: a caller can compare it
/// with the subspace step's `compression_flops` (the diagnostics of
/// [`lifted_subspace::identify`]) to decide whether the refinement pays.
///
/// Errors: those of [`refine_pem`]'s input checks ([`Error::NoData`],
/// [`Error::DimensionMismatch`], [`Error::NonFinite`], a bad
/// feedthrough mask).
pub fn pem_work_estimate(
    initial: &StateSpace,
    records: &[Record<'_>],
    opts: &PemOptions,
) -> Result<PemWorkEstimate> {
    let measured = check_records(initial, records)?;
    let samples: usize = records.iter().map(|r| r.u.nrows()).sum();
    estimate_of_sizes(
        initial,
        samples,
        measured,
        records.len(),
        effective_method(opts, records),
        opts,
    )
}

/// [`pem_work_estimate`] from the sizes alone, for records of `samples`
/// samples each with every output measured (single rate): a caller that
/// streams a record can decide before it loads it.
///
/// Errors: [`Error::NoData`] for no record or an empty one, a bad
/// feedthrough mask.
pub fn pem_work_estimate_of_sizes(
    initial: &StateSpace,
    samples: &[usize],
    opts: &PemOptions,
) -> Result<PemWorkEstimate> {
    if samples.is_empty() || samples.contains(&0) {
        return Err(Error::NoData);
    }
    let total: usize = samples.iter().sum();
    estimate_of_sizes(
        initial,
        total,
        total * initial.n_outputs(),
        samples.len(),
        opts.method,
        opts,
    )
}

fn estimate_of_sizes(
    initial: &StateSpace,
    samples: usize,
    measured: usize,
    n_records: usize,
    method: PemMethod,
    opts: &PemOptions,
) -> Result<PemWorkEstimate> {
    let (n, nu, ny) = (initial.order(), initial.n_inputs(), initial.n_outputs());
    let mask = opts.feedthrough.mask(ny, nu)?;
    let lay = Layout {
        n,
        nu,
        ny,
        records: n_records,
        gain: opts.cost == PemCost::Prediction,
        d_free: (0..ny)
            .flat_map(|o| (0..nu).map(move |j| (o, j)))
            .filter(|&(o, j)| mask[(o, j)])
            .collect(),
    };
    let threads = lifted_linalg::budget::resolve_threads(opts.threads);
    let sizes = |samples: usize, measured: usize, hessian_stride: usize| work::Sizes {
        n,
        nu,
        ny,
        samples,
        measured,
        threads,
        hessian_stride,
    };
    let (linear, nonlinear) = (lay.linear_indices().len(), lay.nonlinear_indices().len());
    Ok(match method {
        PemMethod::Joint => {
            let per =
                crate::budget::pem_flops_per_iteration(n, nu, ny, lay.len(), samples, measured);
            PemWorkEstimate {
                per_iteration: per,
                typical: (45.0 * per).min(opts.max_work),
                warm_stages: 0,
                method,
            }
        }
        PemMethod::VariableProjection => {
            let stages = warm::stage_sizes(samples, opts.warm_start_samples);
            let rows_per_sample = measured as f64 / samples.max(1) as f64;
            let mut typical = 0.0;
            for (i, &size) in stages.iter().enumerate() {
                let m = (size as f64 * rows_per_sample) as usize;
                let stride = warm::whole_stride(size, i > 0);
                let w = work::ProjectionWork::new(&sizes(size, m, stride), linear, nonlinear);
                typical += if i == 0 {
                    FIRST_STAGE.0 * w.jacobian + FIRST_STAGE.1 * w.trial
                } else {
                    LATER_STAGE.0 * w.jacobian + LATER_STAGE.1 * w.trial
                };
            }
            let warmed = !stages.is_empty();
            let stride = warm::whole_stride(samples, warmed);
            let w = work::ProjectionWork::new(&sizes(samples, measured, stride), linear, nonlinear);
            let per = w.jacobian + if warmed { w.model_trial } else { w.trial };
            typical += if warmed {
                LATER_STAGE.0 * w.jacobian + LATER_STAGE.1 * w.model_trial
            } else {
                FIRST_STAGE.0 * w.jacobian + FIRST_STAGE.1 * w.trial
            };
            let warm_stages = stages.len();
            PemWorkEstimate {
                per_iteration: per,
                typical: typical.min(opts.max_work),
                warm_stages,
                method,
            }
        }
    })
}

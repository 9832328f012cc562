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
//! [`crate::pbsid_identify`] identifies them), or use an instrument
//! ([`crate::iv_identify`]). No separate noise-model order is offered: in
//! state space the noise shares the state, so "a noise model of its own"
//! is the same as a larger n. The output-error cost is biased in closed
//! loop (the noise reaches the input through the controller).
//!
//! Multirate records: y holds NaN where an output is not sampled; the cost
//! uses only the measured samples while the model stays at the fast rate
//! (the predictor corrects with the measured outputs only).
//!
//! Each output's residuals are divided by the standard deviation of its
//! measured samples (units do not matter). Parameterisation: all entries of
//! (A, B, C, K, x₀ per record) and the free entries of D (the feedthrough
//! mask), with **data-driven local coordinates** (McKelvey, Helmersson &
//! Ribarits 2004): the similarity transformations x → (I + T)x leave the
//! cost unchanged and span an n²-dimensional tangent space at the current
//! model; every Levenberg–Marquardt step is taken in its orthogonal
//! complement (an orthonormal basis recomputed at each accepted iterate),
//! so the Gauss–Newton matrix is not singular along the similarity
//! directions.
//!
//! **Analytic Jacobian.** Along a basis direction β_i the model moves by
//! (δA, δB, δC, δD, δK, δx₀) (linear in β), and the state sensitivity
//! s = ∂x̂/∂β_i follows the predictor's own recursion:
//! δe(t) = −(C s + δC x̂ + δD u) on the measured outputs,
//! s(t+1) = A s + δA x̂ + δB u + δK e + K δe = (A − K_m C_m) s + forcing,
//! s(0) = δx₀ (K = 0 for the output error; K_m, C_m the measured outputs'
//! columns and rows). All p directions run together as an n × p matrix.
//! The rows of [J | e] are streamed in blocks into an R-only QR
//! (`lifted_linalg::RAccumulator`), so memory is O(p²), not O(M p), and
//! JᵀJ is never formed: the Levenberg–Marquardt step solves
//! [R₁₁; √λ D] δ = [−r; 0] by a second small QR, with D² = diag(JᵀJ)
//! (the squared column norms of R₁₁, floored at 1e-10 of the largest;
//! Marquardt's scaling, λ dimensionless from 1e-3) and r = Qᵀe.
//!
//! **Threads** ([`PemOptions::threads`]): each record is split into
//! contiguous ranges. A serial predictor pass gives x̂ at each range start;
//! a parallel pass gives, per range, the sensitivities from a zero start
//! and the n × n transition of A − K_m C_m over the range, which chain
//! serially into the exact sensitivities at every range start; a second
//! parallel pass forms the rows and each range's R, and the R's are
//! stacked and reduced in range order. The result depends on the thread
//! count through rounding only.
//!
//! Cost per iteration: O(M · p · n (n + n_u + n_y)) for the sensitivities
//! and O(M · p²) for the QR, for p local coordinates (about
//! n(n_u + 2 n_y) + n_y n_u plus n per record) and M measured samples,
//! plus O(p³) per trial step; with threads the sensitivity recursion runs
//! twice over all but the last range of each record.
//!
//! Bounds, checked before anything is formed: at most one free parameter
//! per two measured output samples ([`Error::TooManyParameters`]), the
//! memory of the local coordinates and the Jacobian within the budget of
//! `lifted_linalg::budget`, and `max_iterations` × the cost of one
//! iteration (the null space of the n²-column similarity tangent,
//! O(len · n⁴ + len³), dominates for large n) within
//! [`PemOptions::max_work`]: fewer iterations when it allows fewer, an
//! error when it does not allow one.
//!
//! An iterate whose A (or A − KC for the prediction cost) has spectral
//! radius ≥ 1 is rejected like a cost increase, so a stable start stays
//! stable; an unstable start is first stabilised (its unstable eigenvalues
//! reflected into the unit circle, [`PemReport::stabilized_start`]) for
//! either cost. The better of the start and
//! the refined model is kept ([`Kept`]), judged by the simulation error (the
//! validation fit) on optional validation records, or on the estimation
//! records.

use lifted_lti::StateSpace;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::numerics::spectral_radius;
use crate::regress::{Feedthrough, Record, estimate_x0};

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
    /// operations of the cost model of the module docs
    /// (`max_iterations` × the cost of one iteration). When the bound
    /// allows fewer iterations than `max_iterations` they are capped and
    /// [`PemReport::iteration_cap`] says so; when it does not allow one,
    /// [`Error::TooMuchWork`]. Default 2e10 (a few seconds: ≈ 4e9 of
    /// these operations per second were measured on one core).
    pub max_work: f64,
    /// Threads for the Jacobian (contiguous ranges of each record, std
    /// scoped threads; results depend on the count through rounding only);
    /// 1 = single-threaded, 0 = all available cores. Default 1.
    pub threads: usize,
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
            threads: 1,
        }
    }
}

/// What the refinement did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PemReport {
    /// Cost used.
    pub cost: PemCost,
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
    /// The iteration limit used when [`PemOptions::max_work`] lowered
    /// `max_iterations` (the work bound, not convergence, may then have
    /// stopped the iterations); `None` when it did not.
    #[serde(default)]
    pub iteration_cap: Option<usize>,
    /// ρ(A) of the given start when it was unstable: the refinement then
    /// started from it with its unstable eigenvalues reflected into the
    /// unit circle (and K = 0 if the predictor was then unstable); `None`
    /// for a stable start.
    #[serde(default)]
    pub stabilized_start: Option<f64>,
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

/// The parameter vector θ and its layout.
#[derive(Debug, Clone)]
struct Layout {
    n: usize,
    nu: usize,
    ny: usize,
    records: usize,
    gain: bool,
    /// Free D entries (output, input).
    d_free: Vec<(usize, usize)>,
}

impl Layout {
    fn len(&self) -> usize {
        let (n, nu, ny) = (self.n, self.nu, self.ny);
        n * n
            + n * nu
            + ny * n
            + self.d_free.len()
            + if self.gain { n * ny } else { 0 }
            + self.records * n
    }
}

/// Model matrices and initial states as one value.
#[derive(Debug, Clone)]
struct Point {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    c: DMatrix<f64>,
    d: DMatrix<f64>,
    k: DMatrix<f64>,
    x0: Vec<DVector<f64>>,
}

impl Point {
    fn pack(&self, lay: &Layout) -> DVector<f64> {
        let mut v = Vec::with_capacity(lay.len());
        v.extend(self.a.iter());
        v.extend(self.b.iter());
        v.extend(self.c.iter());
        v.extend(lay.d_free.iter().map(|&(o, j)| self.d[(o, j)]));
        if lay.gain {
            v.extend(self.k.iter());
        }
        for x in &self.x0 {
            v.extend(x.iter());
        }
        DVector::from_vec(v)
    }

    fn unpack(theta: &DVector<f64>, lay: &Layout) -> Point {
        let (n, nu, ny) = (lay.n, lay.nu, lay.ny);
        let mut at = 0;
        let mut take = |rows: usize, cols: usize| {
            let m = DMatrix::from_column_slice(rows, cols, &theta.as_slice()[at..at + rows * cols]);
            at += rows * cols;
            m
        };
        let a = take(n, n);
        let b = take(n, nu);
        let c = take(ny, n);
        let dv = take(lay.d_free.len(), 1);
        let mut d = DMatrix::zeros(ny, nu);
        for (i, &(o, j)) in lay.d_free.iter().enumerate() {
            d[(o, j)] = dv[(i, 0)];
        }
        let k = if lay.gain {
            take(n, ny)
        } else {
            DMatrix::zeros(n, ny)
        };
        let x0 = (0..lay.records)
            .map(|_| take(n, 1).column(0).into_owned())
            .collect();
        Point { a, b, c, d, k, x0 }
    }

    /// Tangent directions of the similarity x → (I + T)x at this point, one
    /// column per elementary T = e_i e_jᵀ (D and nothing else fixed).
    fn similarity_tangent(&self, lay: &Layout) -> DMatrix<f64> {
        let n = lay.n;
        let mut q = DMatrix::zeros(lay.len(), n * n);
        for i in 0..n {
            for j in 0..n {
                let mut t = DMatrix::zeros(n, n);
                t[(i, j)] = 1.0;
                let dir = Point {
                    a: &t * &self.a - &self.a * &t,
                    b: &t * &self.b,
                    c: -(&self.c * &t),
                    d: DMatrix::zeros(lay.ny, lay.nu),
                    k: &t * &self.k,
                    x0: self.x0.iter().map(|x| &t * x).collect(),
                };
                q.column_mut(j * n + i).copy_from(&dir.pack(lay));
            }
        }
        q
    }
}

/// Scaled residuals of all records (measured samples only); `None` when
/// the predictor or simulation is unstable or overflows.
fn residuals(
    p: &Point,
    records: &[Record<'_>],
    weights: &[f64],
    gain: bool,
    total: usize,
) -> Option<DVector<f64>> {
    let mut out = Vec::with_capacity(total);
    let (n, nu, ny) = (p.a.nrows(), p.b.ncols(), p.c.nrows());
    let mut z = vec![0.0; n + nu + ny];
    let mut next = vec![0.0; n];
    let mut meas = vec![false; ny];
    for (r, rec) in records.iter().enumerate() {
        let mut x = p.x0[r].as_slice().to_vec();
        for t in 0..rec.u.nrows() {
            predictor_step(p, gain, rec, t, &mut x, &mut z, &mut meas, &mut next);
            for o in 0..ny {
                if meas[o] {
                    out.push(z[n + nu + o] * weights[o]);
                }
            }
        }
    }
    let v = DVector::from_vec(out);
    v.iter().all(|e| e.is_finite()).then_some(v)
}

/// One step of the predictor (simulation when `gain` is false) at time
/// `t`: fills z = [x̂; u; e_m] (e_m the residuals of the measured outputs,
/// 0 for the others), `meas` (which outputs are measured) and advances x̂,
/// using `next` as workspace. O(n (n + n_u + n_y)), no allocation.
#[allow(clippy::too_many_arguments)]
fn predictor_step(
    p: &Point,
    gain: bool,
    rec: &Record<'_>,
    t: usize,
    x: &mut [f64],
    z: &mut [f64],
    meas: &mut [bool],
    next: &mut [f64],
) {
    let (n, nu, ny) = (p.a.nrows(), p.b.ncols(), p.c.nrows());
    let (a, b, c, d, k) = (
        p.a.as_slice(),
        p.b.as_slice(),
        p.c.as_slice(),
        p.d.as_slice(),
        p.k.as_slice(),
    );
    z[..n].copy_from_slice(x);
    for j in 0..nu {
        z[n + j] = rec.u[(t, j)];
    }
    for o in 0..ny {
        let yo = rec.y[(t, o)];
        meas[o] = !yo.is_nan();
        z[n + nu + o] = if meas[o] {
            let mut yhat = 0.0;
            for i in 0..n {
                yhat += c[o + i * ny] * x[i];
            }
            for j in 0..nu {
                yhat += d[o + j * ny] * z[n + j];
            }
            yo - yhat
        } else {
            0.0
        };
    }
    next.fill(0.0);
    for i in 0..n {
        let xi = x[i];
        for (nr, ar) in next.iter_mut().zip(&a[i * n..(i + 1) * n]) {
            *nr += ar * xi;
        }
    }
    for j in 0..nu {
        let uj = z[n + j];
        for (nr, br) in next.iter_mut().zip(&b[j * n..(j + 1) * n]) {
            *nr += br * uj;
        }
    }
    if gain {
        for o in 0..ny {
            let eo = z[n + nu + o];
            if eo != 0.0 {
                for (nr, kr) in next.iter_mut().zip(&k[o * n..(o + 1) * n]) {
                    *nr += kr * eo;
                }
            }
        }
    }
    x.copy_from_slice(next);
}

/// Mean of the squared entries.
fn mean_square(e: &DVector<f64>) -> f64 {
    e.norm_squared() / e.len().max(1) as f64
}

/// Is the iterate admissible: a stable simulation (ρ(A) < 1) and, for the
/// prediction cost, a stable predictor (ρ(A − KC) < 1)? A refinement never
/// turns a stable model unstable.
fn admissible(p: &Point, gain: bool) -> bool {
    let stable_a = spectral_radius(&p.a).is_ok_and(|r| r < 1.0);
    if !gain {
        return stable_a;
    }
    stable_a && spectral_radius(&(&p.a - &p.k * &p.c)).is_ok_and(|r| r < 1.0)
}

/// Largest modulus of an eigenvalue of an unstable start moved inside the
/// unit circle ([`lifted_linalg::reflect_into_unit_disc`]).
const STABILIZED_START_RADIUS: f64 = 0.999;

/// 1/std of each output's measured samples over the records (1 for a
/// constant output).
fn output_weights(records: &[Record<'_>], ny: usize) -> Vec<f64> {
    (0..ny)
        .map(|o| {
            let vals: Vec<f64> = records
                .iter()
                .flat_map(|r| {
                    r.y.column(o)
                        .iter()
                        .copied()
                        .filter(|v| !v.is_nan())
                        .collect::<Vec<_>>()
                })
                .collect();
            let m = vals.iter().sum::<f64>() / vals.len().max(1) as f64;
            let var = vals.iter().map(|v| (v - m).powi(2)).sum::<f64>() / vals.len().max(1) as f64;
            if var > 0.0 { 1.0 / var.sqrt() } else { 1.0 }
        })
        .collect()
}

fn check_records(model: &StateSpace, records: &[Record<'_>]) -> Result<usize> {
    if records.is_empty() {
        return Err(Error::NoData);
    }
    let (nu, ny) = (model.n_inputs(), model.n_outputs());
    let mut measured = 0;
    for r in records {
        crate::checks::check_record_shape("record (u, y)", "N", r.u, r.y, nu, ny)?;
        crate::error::check_data("u", r.u)?;
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
/// [`Error::NotExciting`] when fewer measured samples than parameters,
/// [`Error::TooManyParameters`] when more than one free parameter per two
/// measured samples, [`Error::TooMuchWork`] when one iteration exceeds
/// [`PemOptions::max_work`] (fewer affordable iterations than
/// `max_iterations` cap them, see [`PemReport::iteration_cap`]),
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
            && opts.gradient_tolerance >= 0.0)
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
    let gain = opts.cost == PemCost::Prediction;
    let mask = opts.feedthrough.mask(ny, nu)?;
    let d_free: Vec<(usize, usize)> = (0..ny)
        .flat_map(|o| (0..nu).map(move |j| (o, j)))
        .filter(|&(o, j)| mask[(o, j)])
        .collect();
    let lay = Layout {
        n,
        nu,
        ny,
        records: records.len(),
        gain,
        d_free,
    };
    let free = lay.len() - n * n;
    if measured <= free {
        return Err(Error::NotExciting {
            what: "measured output samples for the PEM parameters",
            rank: measured,
            needed: free + 1,
        });
    }
    // The data must support the parameters, and the work must be bounded,
    // before the n² × len similarity tangent and the Jacobian are formed.
    crate::budget::check_pem_parameters(free, measured)?;
    crate::budget::check_pem_memory(n, lay.len(), measured)?;
    let samples: usize = records.iter().map(|r| r.u.nrows()).sum();
    let per_iteration =
        crate::budget::pem_flops_per_iteration(n, nu, ny, lay.len(), samples, measured);
    let affordable = opts.max_work / per_iteration;
    if affordable < 1.0 {
        return Err(Error::TooMuchWork {
            what: "the PEM refinement",
            flops: per_iteration,
            limit: opts.max_work,
        });
    }
    let (max_iterations, iteration_cap) = if affordable < opts.max_iterations as f64 {
        let cap = affordable as usize;
        (cap, Some(cap))
    } else {
        (opts.max_iterations, None)
    };
    let k0 = match kalman_gain {
        Some(k) if gain => {
            if k.shape() != (n, ny) {
                return Err(Error::DimensionMismatch {
                    what: "Kalman gain",
                    expected: format!("{n}x{ny}"),
                    got: format!("{}x{}", k.nrows(), k.ncols()),
                });
            }
            crate::error::check_data("Kalman gain", k)?;
            k.clone()
        }
        _ => DMatrix::zeros(n, ny),
    };
    let mut d0 = initial.d().clone();
    for o in 0..ny {
        for j in 0..nu {
            if !mask[(o, j)] {
                d0[(o, j)] = 0.0;
            }
        }
    }
    let mut start = Point {
        a: initial.a().clone(),
        b: initial.b().clone(),
        c: initial.c().clone(),
        d: d0,
        k: k0,
        x0: Vec::new(),
    };
    // An unstable start (either cost) is stabilised first: its unstable
    // eigenvalues reflected into the unit circle, eigenvectors kept; a
    // predictor that is then unstable starts with K = 0.
    let rho_start = spectral_radius(&start.a)?;
    let mut stabilized_start = None;
    if rho_start >= 1.0 {
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
    if gain && !admissible(&start, gain) {
        start.k = DMatrix::zeros(n, ny);
    }
    if !admissible(&start, gain) {
        return Err(Error::Unstable {
            spectral_radius: spectral_radius(&start.a)?,
        });
    }
    start.x0 = estimate_x0(&start.a, &start.b, &start.c, &start.d, records)?;
    let weights = output_weights(records, ny);
    let total = measured;
    let cost_of = |p: &Point| residuals(p, records, &weights, gain, total);
    let mut theta = start.pack(&lay);
    let mut point = start.clone();
    let mut e = cost_of(&point).ok_or(Error::InvalidOption {
        what: "initial model",
        reason: "its residuals are not finite on the records".into(),
    })?;
    let initial_cost = mean_square(&e);
    let mut cost = initial_cost;
    let mut lambda = 0.0;
    let mut iterations = 0;
    let mut accepted = 0;
    let mut termination = Termination::MaxIterations;
    let threads = crate::checks::thread_count(opts.threads);
    // The DDLC basis and R₁₁, r of the QR of [J | e] (J in local coordinates).
    let mut basis_and_r: Option<(DMatrix<f64>, DMatrix<f64>, DVector<f64>)> = None;
    while iterations < max_iterations {
        // The DDLC basis and the Jacobian are recomputed after an accepted step only.
        let (basis, r11, rv) = match basis_and_r {
            Some(ref br) => br,
            None => {
                let q = point.similarity_tangent(&lay);
                let basis = lifted_linalg::null_space(
                    &q.transpose(),
                    lifted_linalg::RankTolerance::Default,
                )?;
                let Ok(raug) = jacobian_r(&point, &basis, &lay, records, &weights, gain, threads)
                else {
                    termination = Termination::NoProgress;
                    break;
                };
                let np = basis.ncols();
                let r11 = raug.view((0, 0), (np, np)).into_owned();
                let rv = raug.view((0, np), (np, 1)).column(0).into_owned();
                basis_and_r.insert((basis, r11, rv))
            }
        };
        let grad = r11.transpose() * rv;
        if grad.amax() <= opts.gradient_tolerance * (1.0 + e.norm_squared()) {
            termination = Termination::GradientConverged;
            break;
        }
        // diag(JᵀJ) = diag(R₁₁ᵀR₁₁): the squared column norms of R₁₁.
        let colsq: Vec<f64> = r11.column_iter().map(|c| c.norm_squared()).collect();
        if lambda == 0.0 {
            // Dimensionless: the damping term is λ diag(JᵀJ) (Marquardt's
            // scaling), so 1e-3 is a small fraction of the curvature in
            // every direction. (Before 2026-11-26: λ₀ = 1e-3 max diag(JᵀJ)
            // on 1 + diag(JᵀJ), which damped every direction by ≈ 1e-3
            // max c_i / c_i and took twice the iterations.)
            lambda = 1e-3;
        }
        iterations += 1;
        let Some(step) = lm_step(r11, rv, lambda, &colsq) else {
            lambda *= 10.0;
            continue;
        };
        let trial_theta = &theta + basis * &step;
        let trial = Point::unpack(&trial_theta, &lay);
        let trial_e = admissible(&trial, gain).then(|| cost_of(&trial)).flatten();
        match trial_e {
            Some(te) if mean_square(&te) < cost => {
                let new_cost = mean_square(&te);
                let rel = (cost - new_cost) / cost.max(f64::MIN_POSITIVE);
                let small_step = step.norm() <= opts.step_tolerance * (1.0 + theta.norm());
                theta = trial_theta;
                point = trial;
                e = te;
                cost = new_cost;
                accepted += 1;
                lambda = (lambda / 3.0).max(1e-14);
                basis_and_r = None;
                if rel < opts.cost_tolerance {
                    termination = Termination::CostConverged;
                    break;
                }
                if small_step {
                    termination = Termination::StepConverged;
                    break;
                }
            }
            _ => {
                lambda *= 4.0;
                if lambda > 1e16 {
                    termination = Termination::NoProgress;
                    break;
                }
            }
        }
    }
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
    let (best, kept) = if j1 <= j0 {
        (point, Kept::Refined)
    } else {
        (start, Kept::Initial)
    };
    let model = StateSpace::new(best.a, best.b, best.c, best.d, Some(ts))?;
    Ok(PemFit {
        model,
        kalman_gain: gain.then_some(best.k),
        x0: best.x0,
        report: PemReport {
            cost: opts.cost,
            iterations,
            accepted,
            initial_cost,
            final_cost: cost,
            termination,
            kept,
            judged: (j0, j1),
            iteration_cap,
            stabilized_start,
        },
    })
}

/// The Levenberg–Marquardt step δ minimising ‖R₁₁ δ + r‖² + λ Σ c_i δ_i²
/// (c_i = diag(JᵀJ), floored at 1e-10 max c_i so that a direction the data
/// do not determine stays damped) by the R-only QR of [R₁₁ −r; √(λc) 0];
/// `None`
/// when the triangular factor is singular or the step not finite. O(p³).
fn lm_step(
    r11: &DMatrix<f64>,
    rv: &DVector<f64>,
    lambda: f64,
    colsq: &[f64],
) -> Option<DVector<f64>> {
    let np = r11.ncols();
    let floor = 1e-10 * colsq.iter().copied().fold(0.0, f64::max);
    let mut stacked = DMatrix::zeros(2 * np, np + 1);
    stacked.view_mut((0, 0), (np, np)).copy_from(r11);
    for i in 0..np {
        stacked[(i, np)] = -rv[i];
        stacked[(np + i, i)] = (lambda * colsq[i].max(floor).max(f64::MIN_POSITIVE)).sqrt();
    }
    let r = lifted_linalg::qr_r_owned(stacked).ok()?;
    if r.nrows() < np || (0..np).any(|i| r[(i, i)] == 0.0) {
        return None;
    }
    let tri = r.view((0, 0), (np, np)).upper_triangle();
    let step = tri.solve_upper_triangular(&r.view((0, np), (np, 1)).column(0).into_owned())?;
    step.iter().all(|v| v.is_finite()).then_some(step)
}

/// Rows of [J | e] gathered before each push into the R-only QR (memory
/// O(p²) for p local coordinates).
fn block_rows(np: usize) -> usize {
    (8 * (np + 1)).max(256)
}

/// The per-direction perturbations of the model along the local-coordinate
/// basis, arranged for the sensitivity recursion.
struct Directions {
    n: usize,
    nu: usize,
    ny: usize,
    /// Directions (columns of the basis).
    np: usize,
    /// [δA_i δB_i δK_i] stacked: (n·np) × (n + n_u + n_y), column-major,
    /// row i·n + r.
    m: Vec<f64>,
    /// [δC_i δD_i] stacked: (n_y·np) × (n + n_u), column-major, row i·n_y + o.
    mc: Vec<f64>,
    /// δx₀ per record: n × np, column-major.
    s0: Vec<Vec<f64>>,
}

impl Directions {
    fn new(basis: &DMatrix<f64>, lay: &Layout) -> Directions {
        let (n, nu, ny, np) = (lay.n, lay.nu, lay.ny, basis.ncols());
        let (mz, mcz) = (n + nu + ny, n + nu);
        let mut m = vec![0.0; n * np * mz];
        let mut mc = vec![0.0; ny * np * mcz];
        let mut s0 = vec![vec![0.0; n * np]; lay.records];
        for i in 0..np {
            let dir = Point::unpack(&basis.column(i).into_owned(), lay);
            for col in 0..mz {
                for r in 0..n {
                    m[col * n * np + i * n + r] = if col < n {
                        dir.a[(r, col)]
                    } else if col < n + nu {
                        dir.b[(r, col - n)]
                    } else {
                        dir.k[(r, col - n - nu)]
                    };
                }
            }
            for col in 0..mcz {
                for o in 0..ny {
                    mc[col * ny * np + i * ny + o] = if col < n {
                        dir.c[(o, col)]
                    } else {
                        dir.d[(o, col - n)]
                    };
                }
            }
            for (s, x) in s0.iter_mut().zip(&dir.x0) {
                s[i * n..(i + 1) * n].copy_from_slice(x.as_slice());
            }
        }
        Directions {
            n,
            nu,
            ny,
            np,
            m,
            mc,
            s0,
        }
    }
}

/// Rows of [J | e] in a row-major block, folded into an R-only QR when full.
struct RowSink {
    width: usize,
    cap: usize,
    rows: usize,
    buf: Vec<f64>,
    acc: lifted_linalg::RAccumulator,
}

impl RowSink {
    fn new(width: usize) -> RowSink {
        let cap = block_rows(width);
        RowSink {
            width,
            cap,
            rows: 0,
            buf: vec![0.0; cap * width],
            acc: lifted_linalg::RAccumulator::new(width),
        }
    }

    fn flush(&mut self) -> Result<()> {
        if self.rows > 0 {
            let block =
                DMatrix::from_row_slice(self.rows, self.width, &self.buf[..self.rows * self.width]);
            self.acc.push_rows(&block)?;
            self.rows = 0;
        }
        Ok(())
    }

    /// Room for `k` more rows; returns the first new row's index.
    fn reserve(&mut self, k: usize) -> Result<usize> {
        if self.rows + k > self.cap {
            self.flush()?;
        }
        let at = self.rows;
        self.rows += k;
        Ok(at)
    }

    fn finish(mut self) -> Result<DMatrix<f64>> {
        self.flush()?;
        Ok(self.acc.r())
    }
}

/// Runs the predictor and the sensitivity recursion over samples
/// `range` of `rec` from state `x` and sensitivities `s` (n × width,
/// column-major; the first `dirs.np` columns are forced, any further ones
/// — transition columns — are not), leaving the end values in `x` and
/// `s`. With a `sink` (width = np) the weighted rows [J | e] of the
/// measured samples are pushed into it. O(len · width · n (n + n_u + n_y)).
#[allow(clippy::too_many_arguments)]
fn sweep(
    p: &Point,
    dirs: &Directions,
    rec: &Record<'_>,
    range: std::ops::Range<usize>,
    weights: &[f64],
    gain: bool,
    x: &mut [f64],
    s: &mut Vec<f64>,
    mut sink: Option<&mut RowSink>,
) -> Result<()> {
    let (n, nu, ny, np) = (dirs.n, dirs.nu, dirs.ny, dirs.np);
    let width = s.len() / n.max(1);
    let (mz, mcz) = (n + nu + ny, n + nu);
    let (a, c, k) = (p.a.as_slice(), p.c.as_slice(), p.k.as_slice());
    let mut z = vec![0.0; mz];
    let mut meas = vec![false; ny];
    let mut next = vec![0.0; n];
    let mut f = vec![0.0; n * np];
    let mut g = vec![0.0; ny * np];
    let mut de = vec![0.0; ny];
    let mut sn = vec![0.0; s.len()];
    for t in range {
        predictor_step(p, gain, rec, t, x, &mut z, &mut meas, &mut next);
        // z holds the pre-step state x̂(t); the forcing terms use it.
        f.fill(0.0);
        for (col, &zc) in z.iter().enumerate() {
            if zc != 0.0 {
                for (fi, mi) in f.iter_mut().zip(&dirs.m[col * n * np..(col + 1) * n * np]) {
                    *fi += mi * zc;
                }
            }
        }
        g.fill(0.0);
        for (col, &zc) in z[..mcz].iter().enumerate() {
            if zc != 0.0 {
                for (gi, mi) in g
                    .iter_mut()
                    .zip(&dirs.mc[col * ny * np..(col + 1) * ny * np])
                {
                    *gi += mi * zc;
                }
            }
        }
        let nmeas = meas.iter().filter(|&&m| m).count();
        let base = match sink.as_deref_mut() {
            Some(sk) if nmeas > 0 => Some(sk.reserve(nmeas)?),
            _ => None,
        };
        for i in 0..width {
            let si = &s[i * n..(i + 1) * n];
            for o in 0..ny {
                de[o] = if meas[o] {
                    let mut cs = if i < np { g[i * ny + o] } else { 0.0 };
                    for (j, sj) in si.iter().enumerate() {
                        cs += c[o + j * ny] * sj;
                    }
                    -cs
                } else {
                    0.0
                };
            }
            let out = &mut sn[i * n..(i + 1) * n];
            if i < np {
                out.copy_from_slice(&f[i * n..(i + 1) * n]);
            } else {
                out.fill(0.0);
            }
            for (j, &sj) in si.iter().enumerate() {
                for (or, ar) in out.iter_mut().zip(&a[j * n..(j + 1) * n]) {
                    *or += ar * sj;
                }
            }
            if gain {
                for (o, &d) in de.iter().enumerate() {
                    if d != 0.0 {
                        for (or, kr) in out.iter_mut().zip(&k[o * n..(o + 1) * n]) {
                            *or += kr * d;
                        }
                    }
                }
            }
            if let (Some(at), Some(sk)) = (base, sink.as_deref_mut()) {
                let w = sk.width;
                let mut row = at;
                for o in 0..ny {
                    if meas[o] {
                        sk.buf[row * w + i] = weights[o] * de[o];
                        row += 1;
                    }
                }
            }
        }
        if let (Some(at), Some(sk)) = (base, sink.as_deref_mut()) {
            let w = sk.width;
            let mut row = at;
            for o in 0..ny {
                if meas[o] {
                    sk.buf[row * w + np] = weights[o] * z[n + nu + o];
                    row += 1;
                }
            }
        }
        std::mem::swap(s, &mut sn);
    }
    Ok(())
}

/// `work(j)` for every job, in job order, the jobs split into `threads`
/// contiguous chunks run on std scoped threads.
fn run_parallel(
    threads: usize,
    jobs: Vec<usize>,
    work: &(dyn Fn(usize) -> Result<Vec<f64>> + Sync),
) -> Result<Vec<Vec<f64>>> {
    if threads <= 1 || jobs.len() <= 1 {
        return jobs.into_iter().map(work).collect();
    }
    let per = jobs.len().div_ceil(threads);
    std::thread::scope(|scope| {
        let handles: Vec<_> = jobs
            .chunks(per)
            .map(|chunk| scope.spawn(move || chunk.iter().map(|&j| work(j)).collect::<Vec<_>>()))
            .collect();
        let mut out = Vec::with_capacity(jobs.len());
        for h in handles {
            let part = h.join().map_err(|_| Error::InvalidOption {
                what: "threads",
                reason: "a Jacobian thread panicked".into(),
            })?;
            for v in part {
                out.push(v?);
            }
        }
        Ok(out)
    })
}

/// Smallest range of samples given to a thread.
const MIN_RANGE: usize = 2048;

/// R of the QR of [J | e] ((p+1) × (p+1), zero rows appended when fewer
/// rows were seen), J = ∂e/∂β the analytic Jacobian of the scaled
/// residuals along the columns of `basis` (module docs), with each record
/// split over `threads` ranges.
fn jacobian_r(
    p: &Point,
    basis: &DMatrix<f64>,
    lay: &Layout,
    records: &[Record<'_>],
    weights: &[f64],
    gain: bool,
    threads: usize,
) -> Result<DMatrix<f64>> {
    let (n, nu, ny) = (p.a.nrows(), p.b.ncols(), p.c.nrows());
    let dirs = Directions::new(basis, lay);
    let np = dirs.np;
    // Ranges: (record, range), contiguous per record.
    struct Range {
        r: usize,
        span: std::ops::Range<usize>,
        x: Vec<f64>,
        s: Vec<f64>,
    }
    let mut ranges: Vec<Range> = Vec::new();
    let mut z = vec![0.0; n + nu + ny];
    let mut meas = vec![false; ny];
    let mut next = vec![0.0; n];
    for (r, rec) in records.iter().enumerate() {
        let len = rec.u.nrows();
        let parts = threads.min(len / MIN_RANGE).max(1);
        let per = len.div_ceil(parts);
        // Serial predictor pass: x̂ at each range start.
        let mut x = p.x0[r].as_slice().to_vec();
        for i in 0..parts {
            let span = i * per..((i + 1) * per).min(len);
            ranges.push(Range {
                r,
                span: span.clone(),
                x: x.clone(),
                s: if i == 0 {
                    dirs.s0[r].clone()
                } else {
                    Vec::new()
                },
            });
            if i + 1 < parts {
                for t in span {
                    predictor_step(p, gain, rec, t, &mut x, &mut z, &mut meas, &mut next);
                }
            }
        }
    }
    // Parallel pass 1: each range that is followed by another one in its
    // record gives its end sensitivities from a zero start and its
    // transition matrix; they chain serially into the starts.
    let chained: Vec<usize> = (0..ranges.len())
        .filter(|&i| i + 1 < ranges.len() && ranges[i + 1].r == ranges[i].r)
        .collect();
    if !chained.is_empty() {
        let ends = {
            let ranges = &ranges;
            let dirs = &dirs;
            run_parallel(threads, chained.clone(), &|i: usize| {
                let rg = &ranges[i];
                let mut s = vec![0.0; n * (np + n)];
                for j in 0..n {
                    s[(np + j) * n + j] = 1.0;
                }
                let mut x = rg.x.clone();
                sweep(
                    p,
                    dirs,
                    &records[rg.r],
                    rg.span.clone(),
                    weights,
                    gain,
                    &mut x,
                    &mut s,
                    None,
                )?;
                Ok(s)
            })?
        };
        for (&i, end) in chained.iter().zip(ends) {
            // s_next = S_part + Ψ s_start.
            let start = ranges[i].s.clone();
            let mut s = end[..n * np].to_vec();
            let psi = &end[n * np..];
            for col in 0..np {
                for j in 0..n {
                    let v = start[col * n + j];
                    for r in 0..n {
                        s[col * n + r] += psi[j * n + r] * v;
                    }
                }
            }
            ranges[i + 1].s = s;
        }
    }
    // Parallel pass 2: the rows of [J | e] of each range into its own R.
    let rs = {
        let ranges = &ranges;
        let dirs = &dirs;
        run_parallel(threads, (0..ranges.len()).collect(), &|i: usize| {
            let rg = &ranges[i];
            let mut sink = RowSink::new(np + 1);
            let (mut x, mut s) = (rg.x.clone(), rg.s.clone());
            sweep(
                p,
                dirs,
                &records[rg.r],
                rg.span.clone(),
                weights,
                gain,
                &mut x,
                &mut s,
                Some(&mut sink),
            )?;
            Ok(sink.finish()?.as_slice().to_vec())
        })?
    };
    let mut acc = lifted_linalg::RAccumulator::new(np + 1);
    for r in rs {
        let rows = r.len() / (np + 1);
        acc.push_rows(&DMatrix::from_column_slice(rows, np + 1, &r))?;
    }
    let r = acc.r();
    let mut out = DMatrix::zeros(np + 1, np + 1);
    out.view_mut((0, 0), (r.nrows(), np + 1)).copy_from(&r);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// ∂e/∂β along the columns of `basis` by central differences (the
    /// Jacobian used before the analytic one; the reference here).
    fn jacobian_fd(
        theta: &DVector<f64>,
        basis: &DMatrix<f64>,
        lay: &Layout,
        e: &DVector<f64>,
        cost_of: &dyn Fn(&Point) -> Option<DVector<f64>>,
    ) -> DMatrix<f64> {
        let h = 1e-6 * (1.0 + theta.amax());
        let mut jac = DMatrix::zeros(e.len(), basis.ncols());
        for c in 0..basis.ncols() {
            let dir = basis.column(c);
            let plus = cost_of(&Point::unpack(&(theta + dir * h), lay)).unwrap();
            let minus = cost_of(&Point::unpack(&(theta - dir * h), lay)).unwrap();
            jac.column_mut(c).copy_from(&((plus - minus) / (2.0 * h)));
        }
        jac
    }

    /// A random stable model (n = 3, 2 × 2), a small gain with A − KC
    /// stable, random x₀ per record and random records (`nan_every`:
    /// output 0 measured every that many samples).
    fn setup(
        seed: u64,
        gain: bool,
        len: usize,
        nan_every: usize,
    ) -> (Point, Layout, Vec<DMatrix<f64>>, Vec<DMatrix<f64>>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut r = |s: f64| s * (2.0 * rng.random::<f64>() - 1.0);
        let (n, nu, ny) = (3, 2, 2);
        let mut a = DMatrix::from_fn(n, n, |_, _| r(1.0));
        let rho = spectral_radius(&a).unwrap();
        a *= 0.8 / rho;
        let p = Point {
            a,
            b: DMatrix::from_fn(n, nu, |_, _| r(1.0)),
            c: DMatrix::from_fn(ny, n, |_, _| r(1.0)),
            // D(0, 1) is not free in the layout below.
            d: DMatrix::from_fn(ny, nu, |o, j| if (o, j) == (0, 1) { 0.0 } else { r(0.5) }),
            k: if gain {
                DMatrix::from_fn(n, ny, |_, _| r(0.05))
            } else {
                DMatrix::zeros(n, ny)
            },
            x0: (0..2).map(|_| DVector::from_fn(n, |_, _| r(1.0))).collect(),
        };
        assert!(admissible(&p, gain));
        let us: Vec<_> = (0..2)
            .map(|_| DMatrix::from_fn(len, nu, |_, _| r(1.0)))
            .collect();
        let ys: Vec<_> = (0..2)
            .map(|_| {
                DMatrix::from_fn(len, ny, |t, o| {
                    if o == 0 && nan_every > 1 && t % nan_every != 0 {
                        f64::NAN
                    } else {
                        r(2.0)
                    }
                })
            })
            .collect();
        let lay = Layout {
            n,
            nu,
            ny,
            records: 2,
            gain,
            d_free: vec![(0, 0), (1, 0), (1, 1)],
        };
        (p, lay, us, ys)
    }

    fn records<'a>(us: &'a [DMatrix<f64>], ys: &'a [DMatrix<f64>]) -> Vec<Record<'a>> {
        us.iter()
            .zip(ys)
            .map(|(u, y)| Record {
                u,
                y,
                instrument: None,
            })
            .collect()
    }

    /// (Jᵀe, JᵀJ) from the analytic R of [J | e].
    fn normal_terms(raug: &DMatrix<f64>) -> (DVector<f64>, DMatrix<f64>) {
        let np = raug.ncols() - 1;
        let r11 = raug.view((0, 0), (np, np));
        let rv = raug.view((0, np), (np, 1));
        (
            (r11.transpose() * rv).column(0).into_owned(),
            r11.transpose() * r11,
        )
    }

    fn rel(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
        (a - b).norm() / b.norm()
    }

    #[test]
    fn analytic_gradient_matches_central_differences() {
        for (gain, nan_every, seed) in [(false, 1, 1), (true, 1, 2), (false, 5, 3), (true, 5, 4)] {
            let (p, lay, us, ys) = setup(seed, gain, 400, nan_every);
            let recs = records(&us, &ys);
            let weights = output_weights(&recs, lay.ny);
            let total = recs
                .iter()
                .map(|r| r.y.iter().filter(|v| !v.is_nan()).count())
                .sum();
            let cost_of = |q: &Point| residuals(q, &recs, &weights, gain, total);
            let theta = p.pack(&lay);
            let basis = lifted_linalg::null_space(
                &p.similarity_tangent(&lay).transpose(),
                lifted_linalg::RankTolerance::Default,
            )
            .unwrap();
            let e = cost_of(&p).unwrap();
            let jfd = jacobian_fd(&theta, &basis, &lay, &e, &cost_of);
            let raug = jacobian_r(&p, &basis, &lay, &recs, &weights, gain, 1).unwrap();
            let (g, h) = normal_terms(&raug);
            let gfd = jfd.transpose() * &e;
            let hfd = jfd.transpose() * &jfd;
            let (eg, eh) = (
                rel(
                    &DMatrix::from_column_slice(g.len(), 1, g.as_slice()),
                    &DMatrix::from_column_slice(gfd.len(), 1, gfd.as_slice()),
                ),
                rel(&h, &hfd),
            );
            assert!(
                eg < 1e-6 && eh < 1e-6,
                "gain {gain}, NaN every {nan_every}: gradient {eg:.1e}, JᵀJ {eh:.1e}"
            );
            // ‖e‖² = ‖r‖² + ρ² (the last diagonal entry of R).
            let np = basis.ncols();
            let ee = raug.view((0, np), (np + 1, 1)).norm_squared();
            assert!((ee - e.norm_squared()).abs() < 1e-10 * e.norm_squared());
        }
    }

    #[test]
    fn thread_count_changes_the_jacobian_by_rounding_only() {
        for (gain, nan_every) in [(true, 5), (false, 1)] {
            let (p, lay, us, ys) = setup(9, gain, 3 * MIN_RANGE + 17, nan_every);
            let recs = records(&us, &ys);
            let weights = output_weights(&recs, lay.ny);
            let basis = lifted_linalg::null_space(
                &p.similarity_tangent(&lay).transpose(),
                lifted_linalg::RankTolerance::Default,
            )
            .unwrap();
            let one = jacobian_r(&p, &basis, &lay, &recs, &weights, gain, 1).unwrap();
            let (g1, h1) = normal_terms(&one);
            for threads in [2, 3, 4] {
                let many = jacobian_r(&p, &basis, &lay, &recs, &weights, gain, threads).unwrap();
                let (g, h) = normal_terms(&many);
                let eg = (&g - &g1).norm() / g1.norm();
                let eh = rel(&h, &h1);
                assert!(
                    eg < 1e-9 && eh < 1e-11,
                    "{threads} threads: {eg:.1e} {eh:.1e}"
                );
            }
        }
    }
}

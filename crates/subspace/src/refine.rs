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
//! directions. The Jacobian is formed by central differences along the
//! basis directions (2 simulations each).
//!
//! Cost per iteration: O(p · M · n (n + n_u)) for p parameters (about
//! n(n_u + 2 n_y) + n_y n_u plus n per record) and M samples, plus O(p³).
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
//! radius ≥ 1 is rejected like a cost increase. The better of the start and
//! the refined model is kept ([`Kept`]), judged by the simulation error (the
//! validation fit) on optional validation records, or on the estimation
//! records.

use lifted_lti::StateSpace;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::engine::spectral_radius;
use crate::error::{Error, Result};
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
    let ny = p.c.nrows();
    for (r, rec) in records.iter().enumerate() {
        let mut x = p.x0[r].clone();
        for t in 0..rec.u.nrows() {
            let ut = rec.u.row(t).transpose();
            let yhat = &p.c * &x + &p.d * &ut;
            let mut next = &p.a * &x + &p.b * &ut;
            for o in 0..ny {
                let yo = rec.y[(t, o)];
                if yo.is_nan() {
                    continue;
                }
                let e = yo - yhat[o];
                out.push(e * weights[o]);
                if gain {
                    next += p.k.column(o) * e;
                }
            }
            x = next;
        }
    }
    let v = DVector::from_vec(out);
    v.iter().all(|e| e.is_finite()).then_some(v)
}

/// Mean of the squared entries.
fn mean_square(e: &DVector<f64>) -> f64 {
    e.norm_squared() / e.len().max(1) as f64
}

/// Is the iterate admissible (stable simulation or predictor)?
fn admissible(p: &Point, gain: bool) -> bool {
    let m = if gain {
        &p.a - &p.k * &p.c
    } else {
        p.a.clone()
    };
    spectral_radius(&m).is_ok_and(|r| r < 1.0)
}

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
        crate::engine::check_record_shape("record (u, y)", "N", r.u, r.y, nu, ny)?;
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
/// [`Error::Unstable`] when the start is unstable for the chosen cost
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
    if !admissible(&start, gain) {
        let m = if gain {
            &start.a - &start.k * &start.c
        } else {
            start.a.clone()
        };
        return Err(Error::Unstable {
            spectral_radius: spectral_radius(&m)?,
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
    let mut basis_and_jacobian: Option<(DMatrix<f64>, DMatrix<f64>)> = None;
    while iterations < max_iterations {
        // The DDLC basis and the Jacobian are recomputed after an accepted step only.
        let (basis, jac) = match basis_and_jacobian {
            Some(ref bj) => bj,
            None => {
                let q = point.similarity_tangent(&lay);
                let basis = lifted_linalg::null_space(
                    &q.transpose(),
                    lifted_linalg::RankTolerance::Default,
                )?;
                let jac = jacobian(&theta, &basis, &lay, &e, &cost_of);
                basis_and_jacobian.insert((basis, jac))
            }
        };
        let grad = jac.transpose() * &e;
        if grad.amax() <= opts.gradient_tolerance * (1.0 + e.norm_squared()) {
            termination = Termination::GradientConverged;
            break;
        }
        let jtj = jac.transpose() * jac;
        if lambda == 0.0 {
            lambda = 1e-3 * jtj.diagonal().amax().max(f64::MIN_POSITIVE);
        }
        iterations += 1;
        let mut damped = jtj.clone();
        for i in 0..damped.nrows() {
            damped[(i, i)] += lambda * (1.0 + jtj[(i, i)]);
        }
        let step = match damped.clone().cholesky() {
            Some(ch) => -ch.solve(&grad),
            None => {
                lambda *= 10.0;
                continue;
            }
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
                basis_and_jacobian = None;
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
        },
    })
}

/// ∂e/∂β along the columns of `basis` by central differences (an
/// inadmissible or non-finite side falls back to a one-sided difference).
fn jacobian(
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
        let plus = cost_of(&Point::unpack(&(theta + dir * h), lay));
        let minus = cost_of(&Point::unpack(&(theta - dir * h), lay));
        let col = match (plus, minus) {
            (Some(p), Some(m)) => (p - m) / (2.0 * h),
            (Some(p), None) => (p - e) / h,
            (None, Some(m)) => (e - m) / h,
            (None, None) => DVector::zeros(e.len()),
        };
        jac.column_mut(c).copy_from(&col);
    }
    jac
}

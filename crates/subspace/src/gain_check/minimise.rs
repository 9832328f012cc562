//! The minimisation over K of the Kalman-gain check: Levenberg–Marquardt on
//! the one-step prediction cost from the best start (every iterate's
//! predictor A − K C stable), its exact runs over the records folded into
//! R factors, and the covariance-form route (BFGS on the sample covariances)
//! for long records. O(iterations · N · n (n + p)·p) on the records.

use lifted_lti::StateSpace;

use crate::error_covariance::{Covariances, bfgs_update, positive_curvature};
use crate::model::Experiment;
use crate::one_step::{OneStep, Sensitivities};
use lifted_linalg::spectral_radius;
use nalgebra::{DMatrix, DVector};

use super::varx::{normalised_cost, prediction_cost};
use super::{BLOCK_ROWS, Limits, MODEL_AGREEMENT};

/// What a step of [`minimise`] is solved with: the R factor of [J | r]
/// at the point where it was last folded (the Gauss–Newton matrix
/// R_Jᵀ R_J of that point) and the exact gradient Jᵀ r at the current
/// point.
pub(super) struct StepBasis {
    /// R of [J | r] (its first P columns' upper block R_J, the last
    /// column's first P entries q).
    r: DMatrix<f64>,
    /// Jᵀ r at the current iterate (the gradient of ½ ‖r‖²).
    gradient: DVector<f64>,
    /// Whether `r` was folded at the current iterate (then R_Jᵀ q is the
    /// gradient and q is taken as it is).
    fresh: bool,
}

impl StepBasis {
    /// At a point whose factor was just folded: the gradient R_Jᵀ q.
    pub(super) fn folded(r: DMatrix<f64>, params: usize) -> Self {
        let k = r.nrows().min(params);
        let rj = r.view((0, 0), (k, params));
        let q = r.view((0, params), (k, 1));
        let gradient = rj.transpose() * q;
        StepBasis {
            gradient: gradient.column(0).into_owned(),
            r,
            fresh: true,
        }
    }

    /// R_J, its column norms (Marquardt's scaling D: J's column norms at
    /// the factor's point) and the right-hand side q̃ with R_Jᵀ q̃ = Jᵀ r
    /// (q itself when the factor is fresh), so that the damped problem
    /// [R_J; √λ D] δ ≈ [−q̃; 0] is (R_Jᵀ R_J + λ D²) δ = −Jᵀ r without
    /// forming R_Jᵀ R_J. `None` when a stale R_J is singular or has fewer
    /// rows than parameters (a fresh factor is then needed).
    pub(super) fn parts(&self, params: usize) -> Option<(DMatrix<f64>, Vec<f64>, DVector<f64>)> {
        let k = self.r.nrows().min(params);
        let rj = self.r.view((0, 0), (k, params)).into_owned();
        let scale: Vec<f64> = (0..params)
            .map(|p| rj.column(p).norm().max(1e-300))
            .collect();
        let q = if self.fresh {
            self.r.view((0, params), (k, 1)).column(0).into_owned()
        } else {
            if k < params || (0..params).any(|p| rj[(p, p)] == 0.0) {
                return None;
            }
            let q = rj.transpose().solve_lower_triangular(&self.gradient)?;
            if !q.iter().all(|v| v.is_finite()) {
                return None;
            }
            q
        };
        Some((rj, scale, q))
    }
}

/// Levenberg–Marquardt on the one-step prediction errors over K from
/// `start` (its predictor stable), the predictor started from `x0s`, with
/// the exact Jacobian from the sensitivity recursions
/// S(t+1) = (A − K C) S(t) + E(ε(t)), ∂ε(t)/∂vec K = −C S(t). The rows
/// of [J | r] are folded block by block into the R factor of their QR
/// (memory O(P²), never JᵀJ), and each step solves the small damped
/// problem [R_J; √λ D] δ = [−q̃; 0] (D: Marquardt's column norms of J).
///
/// The factor is lazy (Jacobian reuse, the idea of the chord and
/// Shamanskii variants of Newton's method; Kelley, *Iterative Methods for
/// Linear and Nonlinear Equations*, 1995): it is folded at the start and
/// again only where the factor's quadratic model mispredicts a step's
/// decrease ([`MODEL_AGREEMENT`]) or a step taken with a factor of an
/// earlier iterate fails. Every iterate gets its exact gradient Jᵀ r by
/// the adjoint recursion backwards over the errors of the run that gave
/// its cost (`OneStep::add_adjoint_gradient`, O(N (n² + n n_y))), and q̃
/// solves R_Jᵀ q̃ = Jᵀ r (so the step is (R_Jᵀ R_J + λ D²) δ = −Jᵀ r with
/// the Gauss–Newton matrix of the factor's point: a descent direction at
/// any λ). Near the optimum J changes little, so the steps are those of
/// Gauss–Newton at a fraction of the cost: the forward sensitivities and
/// the fold of a factor cost O(N n_y (n² n_y + P²)), several times a run
/// with its adjoint. Every trial is accepted only on a lower cost on the
/// records, as before.
///
/// `spread`: [`output_spread`] of `sets` (the outputs' weights);
/// `limits`: the relative decrease below which it stops and the largest
/// number of iterations; `route`: how a factor's sensitivities are
/// computed ([`Sensitivities`]). Returns the gain, its cost
/// ([`prediction_cost`]), the iterations taken and the factors folded.
/// O(N (n² + n n_y + n n_u)) per iteration, plus O(N n_y (n² n_y + P²))
/// per factor (O(N n_y (n² P + P²)) on records with outputs not measured).
pub(super) fn minimise(
    model: &StateSpace,
    start: &DMatrix<f64>,
    sets: &[Experiment<'_>],
    x0s: &[DVector<f64>],
    spread: &[f64],
    limits: Limits,
    route: Sensitivities,
) -> Result<(DMatrix<f64>, f64, usize, usize), String> {
    let Limits {
        tolerance,
        max_iterations,
        work,
    } = limits;
    let (n, ny) = (model.order(), model.n_outputs());
    if n == 0 {
        return Err("a static model has no gain".into());
    }
    let params = n * ny;
    let rows: usize = sets.iter().map(|d| d.u.nrows() * ny).sum();
    let per_run = rows as f64 * ((n * n * params) as f64 + 2.0 * (params * params) as f64);
    let mut runs_left = (work / per_run).floor() as usize;
    if runs_left < 3 {
        return Err(format!(
            "its predictor runs would cost {per_run:.2e} operations each, more than a third of {work:.0e}"
        ));
    }
    let runs = ExactRuns::new(model, sets, x0s, spread);
    let w = &runs.w;
    let mut theta = DVector::from_column_slice(start.as_slice());
    let gain = |theta: &DVector<f64>| DMatrix::from_column_slice(n, ny, theta.as_slice());
    let predictor = |theta: &DVector<f64>| runs.predictor(theta);
    let run_at = |theta: &DVector<f64>| runs.run_at(theta);
    let gradient_of =
        |errors: &[Vec<f64>], predictor: &OneStep| runs.gradient_of(errors, predictor);
    // The cost and the R factor of [J | r] at θ from one run (the factor
    // `None` when its rows are not finite); None when A − K C is not
    // stable or the cost is not finite. The rows are folded on a second
    // thread while the predictor makes the next ones, when there is one
    // and the records are long ([`Blocks`]: the same blocks in the same
    // order, the same R bit for bit).
    let parallel =
        rows > 4 * BLOCK_ROWS && std::thread::available_parallelism().map_or(1, |n| n.get()) > 1;
    let factor_at = |theta: &DVector<f64>| -> Option<(f64, Option<DMatrix<f64>>)> {
        let predictor = predictor(theta)?;
        let mut cost = 0.0;
        let r = fold_rows(params + 1, parallel, |blocks| {
            for (data, x0) in sets.iter().zip(x0s) {
                predictor.with_sensitivities(route, data.u, data.y, x0, |o, cs, eps| {
                    let (block, at) = blocks.row();
                    for (p, v) in cs.iter().enumerate() {
                        block[(at, p)] = -w[o] * v;
                    }
                    let r = w[o] * eps;
                    block[(at, params)] = r;
                    cost += r * r;
                });
            }
        });
        cost.is_finite().then_some((cost, r))
    };
    let start_at = factor_at(&theta).and_then(|(c, r)| Some((c, r?)));
    let Some((mut cost, r)) = start_at else {
        return Err("the start's predictor is not stable".into());
    };
    let mut basis = StepBasis::folded(r, params);
    let mut factors = 1;
    runs_left -= 1;
    let mut lambda: f64 = 1e-3;
    let mut iterations = 0;
    // The errors of the last accepted trial's run.
    let mut last_errors: Option<Vec<Vec<f64>>> = None;
    while iterations < max_iterations {
        iterations += 1;
        let mut improved = false;
        while lambda < 1e10 && runs_left > 0 {
            // A stale factor that cannot give the step is folded anew here.
            let parts = match basis.parts(params) {
                Some(parts) => parts,
                None if !basis.fresh => {
                    runs_left -= 1;
                    match factor_at(&theta) {
                        Some((_, Some(r))) => {
                            basis = StepBasis::folded(r, params);
                            factors += 1;
                            continue;
                        }
                        _ => break,
                    }
                }
                None => break,
            };
            let (rj, scale, q) = parts;
            let k = rj.nrows();
            let mut aug = DMatrix::zeros(k + params, params);
            aug.rows_mut(0, k).copy_from(&rj);
            for p in 0..params {
                aug[(k + p, p)] = lambda.sqrt() * scale[p];
            }
            let mut rhs = DMatrix::zeros(k + params, 1);
            rhs.view_mut((0, 0), (k, 1)).copy_from(&(-&q));
            let Ok(step) = lifted_linalg::lstsq(&aug, &rhs) else {
                lambda *= 4.0;
                continue;
            };
            let trial = &theta + step.column(0);
            let predicted = q.norm_squared() - (&rj * step.column(0) + &q).norm_squared();
            runs_left -= 1;
            let evaluated = run_at(&trial);
            // Accepted with a further iteration to come: its step basis, the
            // factor kept and the trial's gradient while the factor's
            // quadratic model predicted the decrease to within
            // [`MODEL_AGREEMENT`], else a factor folded at the trial.
            let accepted = match evaluated {
                Some((ct, errors, run)) if ct < cost => {
                    let decrease = (cost - ct) / cost.max(f64::MIN_POSITIVE);
                    let agreement = (cost - ct) / predicted.max(f64::MIN_POSITIVE);
                    let keep = (1.0 / MODEL_AGREEMENT..=MODEL_AGREEMENT).contains(&agreement);
                    // A small decrease ends the iterations only from a
                    // factor that is fresh or whose model predicted it: a
                    // stale factor that mispredicts can make short steps
                    // far from the optimum (it is folded anew instead).
                    let more = decrease > tolerance || !(basis.fresh || keep);
                    let next = if !(more && iterations < max_iterations) {
                        Some(None)
                    } else if keep {
                        gradient_of(&errors, &run).map(|gt| {
                            Some(StepBasis {
                                r: std::mem::take(&mut basis.r),
                                gradient: gt,
                                fresh: false,
                            })
                        })
                    } else {
                        runs_left = runs_left.saturating_sub(1);
                        factors += 1;
                        factor_at(&trial)
                            .and_then(|(_, r)| Some(Some(StepBasis::folded(r?, params))))
                    };
                    next.map(|next| (ct, next, more, errors))
                }
                _ => None,
            };
            match accepted {
                Some((ct, next, more, errors)) => {
                    (theta, cost) = (trial, ct);
                    last_errors = Some(errors);
                    if let Some(next) = next {
                        basis = next;
                    }
                    lambda = (lambda / 3.0).max(1e-12);
                    improved = more;
                    break;
                }
                // A step from a factor of an earlier iterate failed: the
                // factor is folded at this one and the step tried again
                // at the same damping.
                None if !basis.fresh && runs_left > 0 => {
                    runs_left -= 1;
                    match factor_at(&theta) {
                        Some((_, Some(r))) => {
                            basis = StepBasis::folded(r, params);
                            factors += 1;
                        }
                        _ => break,
                    }
                }
                None => lambda *= 4.0,
            }
        }
        if !improved {
            break;
        }
    }
    let k = gain(&theta);
    let cost = runs.final_cost(&k, last_errors.as_deref())?;
    Ok((k, cost, iterations, factors))
}

/// The one-step cost over the records and its gradient at a gain, for the
/// minimisations over K ([`minimise`], [`minimise_from_covariances`]).
pub(super) struct ExactRuns<'a, 'r> {
    model: &'a StateSpace,
    sets: &'a [Experiment<'r>],
    x0s: &'a [DVector<f64>],
    spread: &'a [f64],
    /// Per-output weights 1/‖y_o − ȳ_o‖ over all records (the cost of
    /// prediction_cost without its division by n_y).
    w: Vec<f64>,
    /// The weights squared.
    w2: Vec<f64>,
}

/// A run's cost ‖r‖², its errors (one row-major block a record) and its
/// predictor.
pub(super) type Run = (f64, Vec<Vec<f64>>, OneStep);

impl<'a, 'r> ExactRuns<'a, 'r> {
    pub(super) fn new(
        model: &'a StateSpace,
        sets: &'a [Experiment<'r>],
        x0s: &'a [DVector<f64>],
        spread: &'a [f64],
    ) -> Self {
        let w: Vec<f64> = spread
            .iter()
            .map(|s| if *s > 0.0 { 1.0 / s.sqrt() } else { 0.0 })
            .collect();
        let w2 = w.iter().map(|v| v * v).collect();
        ExactRuns {
            model,
            sets,
            x0s,
            spread,
            w,
            w2,
        }
    }

    /// The predictor at θ = vec K; None when A − K C is not stable.
    pub(super) fn predictor(&self, theta: &DVector<f64>) -> Option<OneStep> {
        let (n, ny) = (self.model.order(), self.model.n_outputs());
        let k = DMatrix::from_column_slice(n, ny, theta.as_slice());
        let m = self.model.a() - &k * self.model.c();
        let rho = spectral_radius(&m).ok()?;
        (rho < 1.0).then(|| OneStep::new(self.model, &k, &m))
    }

    /// ‖r‖² at θ (the rows' squares summed in the order every run visits
    /// them, so the same number bit for bit) with the run's errors (one
    /// row-major block a record, for the adjoint gradient) and its
    /// predictor; None when A − K C is not stable or the cost is not
    /// finite.
    pub(super) fn run_at(&self, theta: &DVector<f64>) -> Option<Run> {
        let predictor = self.predictor(theta)?;
        let mut cost = 0.0;
        let mut errors = Vec::with_capacity(self.sets.len());
        for (data, x0) in self.sets.iter().zip(self.x0s) {
            let mut record = Vec::with_capacity(data.y.len());
            predictor.with_errors(data.u, data.y, x0, |eps| {
                for (o, e) in eps.iter().enumerate() {
                    let r = self.w[o] * e;
                    cost += r * r;
                }
                record.extend_from_slice(eps);
            });
            errors.push(record);
        }
        cost.is_finite().then_some((cost, errors, predictor))
    }

    /// The gradient Jᵀ r (½ ∇‖r‖²) of a run by the adjoint recursion over
    /// its errors (`OneStep::add_adjoint_gradient`: one n-state recursion
    /// backwards, no sensitivities); None when it is not finite.
    pub(super) fn gradient_of(
        &self,
        errors: &[Vec<f64>],
        predictor: &OneStep,
    ) -> Option<DVector<f64>> {
        let params = self.model.order() * self.model.n_outputs();
        let mut gradient = vec![0.0; params];
        for (data, eps) in self.sets.iter().zip(errors) {
            predictor.add_adjoint_gradient(data.y, eps, &self.w2, &mut gradient);
        }
        gradient
            .iter()
            .all(|g| g.is_finite())
            .then(|| DVector::from_vec(gradient))
    }

    /// The gain's cost ([`prediction_cost`]) from the errors of the run
    /// that accepted it (the same number: the squares summed in the same
    /// order), else by a run.
    pub(super) fn final_cost(
        &self,
        k: &DMatrix<f64>,
        errors: Option<&[Vec<f64>]>,
    ) -> Result<f64, String> {
        lifted_linalg::simd::dispatch(
            #[inline(always)]
            || match errors {
                Some(errors) => {
                    let mut err = vec![0.0; self.model.n_outputs()];
                    for record in errors {
                        for eps in record.chunks_exact(err.len()) {
                            for (e, v) in err.iter_mut().zip(eps) {
                                *e += v * v;
                            }
                        }
                    }
                    normalised_cost(&err, self.spread)
                }
                None => prediction_cost(self.model, k, self.sets, self.x0s, self.spread),
            },
        )
    }
}

/// The covariance route of the minimisation over K (module
/// `error_covariance`): BFGS on the cost written exactly through the
/// covariances of the start's one-step errors (`base`, a block a record
/// as [`ExactRuns::run_at`] gives them) from the start, then quasi-Newton
/// on the cost over the records from its minimum, with BFGS's curvature
/// and each iterate's exact gradient (adjoint), a trial only where the
/// step predicts more than the relative `tolerance` and accepted only on
/// a lower cost over the records, until a decrease below `tolerance` or
/// `max_iterations`. Returns the gain, its cost ([`prediction_cost`]), the
/// iterations on the records and the covariance form's; `None` when the
/// route cannot be taken (its work beyond [`GainCheckOptions::minimise_work`]) or does not
/// end below `start_cost` (then Levenberg–Marquardt runs as before).
/// Records with every output measured (the errors of a constant K are
/// then a filter of those of the start). O(N n_y² log N) for the
/// covariances, O(L (n² n_y + n n_y²) + n³ log L) per evaluation of the
/// covariance form (L ≤ `error_covariance::MAX_LAGS` lags, and each
/// record's last L errors), O(N (n² + n n_y + n n_u)) per iteration on the
/// records.
pub(super) fn minimise_from_covariances(
    runs: &ExactRuns<'_, '_>,
    start: &DMatrix<f64>,
    base: &[Vec<f64>],
    start_cost: f64,
    limits: Limits,
) -> Option<(DMatrix<f64>, f64, usize, usize)> {
    let Limits {
        tolerance,
        max_iterations,
        work,
    } = limits;
    let model = runs.model;
    let (n, ny) = (model.order(), model.n_outputs());
    if n == 0 {
        return None;
    }
    // Within the minimisation's work budget: the start's Hessian (P
    // gradients) and the most BFGS iterations, each evaluation with its
    // gradient about three Horner passes over the lags and each record's
    // end (else Levenberg–Marquardt, under the same budget).
    let longest = base.iter().map(|e| e.len() / ny).max().unwrap_or(0);
    let lags = crate::error_covariance::MAX_LAGS.min(longest.saturating_sub(1)) as f64;
    let per_evaluation =
        6.0 * lags * ((n * n * ny + n * ny * ny) as f64) * base.len().max(1) as f64;
    if ((n * ny + COVARIANCE_ITERATIONS) as f64) * per_evaluation > work {
        return None;
    }
    // The start's one-step errors (its predictor is stable), of which
    // every other gain's are a filter: K = K₀ + ΔK has the errors of
    // A − K₀ C with gain ΔK (module `error_covariance`).
    let cov = Covariances::from_errors(base, ny, &runs.w2)?;
    // BFGS from the start: ΔK = 0 on (A − K₀ C, C).
    let shifted = model.a() - start * model.c();
    let min = cov.minimise(
        &shifted,
        model.c(),
        &DMatrix::zeros(n, ny),
        COVARIANCE_ITERATIONS,
    )?;
    let mut theta = DVector::from_column_slice((start + &min.k).as_slice());
    let (mut cost, mut errors, mut predictor) = runs.run_at(&theta)?;
    // (‖r‖² is n_y times the normalised cost.)
    if cost / ny as f64 >= start_cost {
        return None;
    }
    let mut h = min.inverse_hessian;
    // ∇‖r‖² = 2 Jᵀ r.
    let mut g = runs.gradient_of(&errors, &predictor)? * 2.0;
    let mut iterations = 0;
    while iterations < max_iterations {
        // The decrease a quasi-Newton step predicts, ½ gᵀ H g: below the
        // stopping decrease, no trial is run (the covariance form is the
        // cost over the records, so its minimum is one of the cost's, and
        // there a trial step only meets rounding).
        let dir = -(&h * &g);
        let predicted = -0.5 * g.dot(&dir);
        if predicted.is_nan() || predicted <= tolerance * cost {
            break;
        }
        iterations += 1;
        let mut alpha = 1.0;
        let mut accepted = None;
        for _ in 0..4 {
            let trial = &theta + alpha * &dir;
            match runs.run_at(&trial) {
                Some(run) if run.0 < cost => {
                    accepted = Some((trial, run));
                    break;
                }
                _ => alpha *= 0.25,
            }
        }
        let Some((trial, (ct, et, pt))) = accepted else {
            break;
        };
        let decrease = (cost - ct) / cost.max(f64::MIN_POSITIVE);
        (theta, cost, errors, predictor) = (trial.clone(), ct, et, pt);
        if decrease <= tolerance || iterations == max_iterations {
            break;
        }
        let Some(gt) = runs.gradient_of(&errors, &predictor) else {
            break;
        };
        let gt = gt * 2.0;
        let s = alpha * &dir;
        let yv = &gt - &g;
        if let Some(sy) = positive_curvature(&s, &yv) {
            bfgs_update(&mut h, &s, &yv, sy);
        }
        g = gt;
    }
    let k = DMatrix::from_column_slice(n, ny, theta.as_slice());
    let final_cost = runs.final_cost(&k, Some(&errors)).ok()?;
    (final_cost < start_cost).then_some((k, final_cost, iterations, min.iterations))
}

/// Most BFGS iterations on the covariance form (each costs no pass over
/// the records; on the studio bench's record 17–133 reach the minimum, to a
/// decrease below 1e-12 of the cost).
pub(super) const COVARIANCE_ITERATIONS: usize = 200;

/// Where [`fold_rows`] sends its full blocks: an accumulator here, or the
/// folding thread (blocks out, emptied blocks back).
pub(super) enum Sink<'a> {
    Here(lifted_linalg::RAccumulator),
    Thread {
        full: std::sync::mpsc::SyncSender<DMatrix<f64>>,
        spent: &'a std::sync::mpsc::Receiver<DMatrix<f64>>,
    },
}

/// Blocks of [`BLOCK_ROWS`] rows filled one row at a time by
/// [`fold_rows`]'s producer.
pub(super) struct Blocks<'a> {
    block: DMatrix<f64>,
    filled: usize,
    folded: bool,
    sink: Sink<'a>,
}

impl Blocks<'_> {
    /// The block and the index of the next row to fill (a full block is
    /// folded, or sent to the folding thread, first).
    pub(super) fn row(&mut self) -> (&mut DMatrix<f64>, usize) {
        if self.filled == BLOCK_ROWS {
            match &mut self.sink {
                Sink::Here(acc) => self.folded &= acc.push_rows(&self.block).is_ok(),
                Sink::Thread { full, spent } => {
                    let (r, c) = self.block.shape();
                    let next = spent.try_recv().unwrap_or_else(|_| DMatrix::zeros(r, c));
                    let block = std::mem::replace(&mut self.block, next);
                    self.folded &= full.send(block).is_ok();
                }
            }
            self.filled = 0;
        }
        self.filled += 1;
        (&mut self.block, self.filled - 1)
    }
}

/// The R factor of the QR of the rows (`width` columns) that `produce`
/// writes through [`Blocks::row`], folded block by block into an
/// `RAccumulator`; with `parallel`, the blocks are folded on a second
/// thread while `produce` fills the next (the same blocks pushed in the
/// same order: the same R bit for bit). `None` when a block is not
/// finite or the folding thread fails.
pub(super) fn fold_rows(
    width: usize,
    parallel: bool,
    produce: impl FnOnce(&mut Blocks<'_>),
) -> Option<DMatrix<f64>> {
    let finish = |mut blocks: Blocks<'_>| -> Option<Option<lifted_linalg::RAccumulator>> {
        let last = blocks.block.rows(0, blocks.filled).into_owned();
        match blocks.sink {
            Sink::Here(mut acc) => {
                blocks.folded &= acc.push_rows(&last).is_ok();
                blocks.folded.then_some(Some(acc))
            }
            Sink::Thread { full, .. } => {
                blocks.folded &= full.send(last).is_ok();
                blocks.folded.then_some(None)
            }
        }
    };
    if !parallel {
        let mut blocks = Blocks {
            block: DMatrix::zeros(BLOCK_ROWS, width),
            filled: 0,
            folded: true,
            sink: Sink::Here(lifted_linalg::RAccumulator::new(width)),
        };
        produce(&mut blocks);
        return finish(blocks).flatten().map(|acc| acc.r());
    }
    let (full, blocks_in) = std::sync::mpsc::sync_channel::<DMatrix<f64>>(2);
    let (spent_out, spent) = std::sync::mpsc::channel::<DMatrix<f64>>();
    std::thread::scope(|scope| {
        let folder = scope.spawn(move || {
            let mut acc = lifted_linalg::RAccumulator::new(width);
            let mut folded = true;
            for block in blocks_in {
                folded &= acc.push_rows(&block).is_ok();
                // (The producer may have finished: a block not taken back
                // is dropped.)
                let _ = spent_out.send(block);
            }
            folded.then(|| acc.r())
        });
        let mut blocks = Blocks {
            block: DMatrix::zeros(BLOCK_ROWS, width),
            filled: 0,
            folded: true,
            sink: Sink::Thread {
                full,
                spent: &spent,
            },
        };
        produce(&mut blocks);
        // (Sending the last block and dropping the sender ends the folding
        // thread's loop.)
        let sent = finish(blocks).is_some();
        let r = folder.join().ok().flatten();
        r.filter(|_| sent)
    })
}

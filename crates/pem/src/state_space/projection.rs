//! Variable projection (Golub & Pereyra 1973; Kaufman 1975) in predictor
//! coordinates: for fixed α = (Ā, C), Ā = A − KC, the residuals are
//! affine in the linear parameters β = (B̄ = B − KD, free D, K, x₀), so β
//! is eliminated by an exact least-squares solve and Levenberg–Marquardt
//! runs on α alone, in the local coordinates of its similarity orbit,
//! with Kaufman's Jacobian P⊥ ∂e/∂α (the columns of ∂e/∂α projected off
//! those of ∂e/∂β). θ is kept in predictor coordinates (Ā and B̄ in the
//! places of A and B of the model's layout); [`to_model`] maps it back.
//! Module docs of [`super`] for the equations.

use nalgebra::{DMatrix, DVector};

use super::Termination;
use super::jacobian::jacobian_r;
use super::lm::lm_step;
use super::point::{Layout, Point, mean_square, step_is_small};
use super::problem::{Limits, Outcome, Problem, WorkAccount};
use super::work::{ProjectionWork, Sizes};
use crate::error::Result;

/// Damping of the linear solve: only a floor against a singular R₁₁ (a
/// linear parameter the data do not determine, e.g. an x₀ direction the
/// outputs never see); 1e-12 of the column's curvature moves a determined
/// parameter by a relative 1e-12, below the tolerances.
const LINEAR_DAMPING: f64 = 1e-12;

impl Layout {
    /// Start offsets of the blocks of θ: (B, C, D, K, x₀).
    fn offsets(&self) -> [usize; 5] {
        let (n, nu, ny) = (self.n, self.nu, self.ny);
        let b = n * n;
        let c = b + n * nu;
        let d = c + ny * n;
        let k = d + self.d_free.len();
        let x0 = k + if self.gain { n * ny } else { 0 };
        [b, c, d, k, x0]
    }

    /// Indices in θ (predictor coordinates) of the linear parameters:
    /// B̄, free D, K, x₀.
    pub(super) fn linear_indices(&self) -> Vec<usize> {
        let [b, c, d, _, _] = self.offsets();
        (b..c).chain(d..self.len()).collect()
    }

    /// Indices in θ (predictor coordinates) of the nonlinear parameters:
    /// Ā = A − KC and C.
    pub(super) fn nonlinear_indices(&self) -> Vec<usize> {
        let [b, c, d, _, _] = self.offsets();
        (0..b).chain(c..d).collect()
    }
}

/// The predictor form of `p`: Ā = A − KC in the place of A, B̄ = B − KD
/// in the place of B (the other matrices as they are).
fn to_predictor(p: &Point) -> Point {
    Point {
        a: &p.a - &p.k * &p.c,
        b: &p.b - &p.k * &p.d,
        ..p.clone()
    }
}

/// The model of a predictor-form point: A = Ā + KC, B = B̄ + KD.
fn to_model(q: &Point) -> Point {
    Point {
        a: &q.a + &q.k * &q.c,
        b: &q.b + &q.k * &q.d,
        ..q.clone()
    }
}

/// The directions of the model's θ of the columns of `dirs` (directions of
/// the predictor-form θ at `q`): the derivative of [`to_model`],
/// δA = δĀ + δK C + K δC, δB = δB̄ + δK D + K δD.
fn push_forward(q: &Point, dirs: &DMatrix<f64>, lay: &Layout) -> DMatrix<f64> {
    let mut out = DMatrix::zeros(dirs.nrows(), dirs.ncols());
    for j in 0..dirs.ncols() {
        let d = Point::unpack(&dirs.column(j).into_owned(), lay);
        let m = Point {
            a: &d.a + &d.k * &q.c + &q.k * &d.c,
            b: &d.b + &d.k * &q.d + &q.k * &d.d,
            ..d
        };
        out.column_mut(j).copy_from(&m.pack(lay));
    }
    out
}

/// The columns of θ's identity at `idx` (len × idx.len()).
fn unit_columns(len: usize, idx: &[usize]) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(len, idx.len());
    for (j, &i) in idx.iter().enumerate() {
        m[(i, j)] = 1.0;
    }
    m
}

/// Local coordinates of α = (Ā, C) at `p` (predictor coordinates): an orthonormal basis of the
/// orthogonal complement of the similarity tangent restricted to the
/// nonlinear parameters, embedded in θ (len × p_α).
fn nonlinear_basis(p: &Point, lay: &Layout, nl: &[usize]) -> Result<DMatrix<f64>> {
    let q = p.similarity_tangent(lay).select_rows(nl);
    let local = lifted_linalg::null_space(&q.transpose(), lifted_linalg::RankTolerance::Default)?;
    let mut basis = DMatrix::zeros(lay.len(), local.ncols());
    for (r, &i) in nl.iter().enumerate() {
        basis.row_mut(i).copy_from(&local.row(r));
    }
    Ok(basis)
}

/// θ with its linear parameters replaced by their least-squares values at
/// its nonlinear ones, the point and its residuals; `None` when the
/// predictor is unstable or the solve fails. Exact in one Gauss–Newton
/// step: the residuals are affine in β.
fn solve_linear(
    prob: &Problem<'_, '_>,
    theta: &DVector<f64>,
    lin: &DMatrix<f64>,
) -> Option<(DVector<f64>, Point, DVector<f64>)> {
    let lay = prob.lay;
    let q = Point::unpack(theta, lay);
    let raug = jacobian_r(
        &to_model(&q),
        &push_forward(&q, lin, lay),
        lay,
        prob.records,
        prob.weights,
        prob.gain,
        prob.threads,
        prob.hessian_stride,
    )
    .ok()?;
    let pl = lin.ncols();
    let r11 = raug.view((0, 0), (pl, pl)).into_owned();
    let r1 = raug.view((0, pl), (pl, 1)).column(0).into_owned();
    let colsq: Vec<f64> = r11.column_iter().map(|c| c.norm_squared()).collect();
    let delta = lm_step(&r11, &r1, LINEAR_DAMPING, &colsq)?;
    // K is among the linear parameters and A = Ā + KC moves with it: the
    // solved model must be admissible too. Near the stability boundary
    // (a slow pole of A, ρ(A) ≈ 0.9999 on the flexible-arm record) the
    // exact solve can cross it while a shorter move of β does not:
    // the step is halved up to LINEAR_BACKTRACKS times (β then not
    // exactly at its optimum for this α; the next Jacobian's solve
    // brings it there), and the trial is refused only when no fraction,
    // nor β unchanged, is admissible.
    let mut fraction = 1.0;
    for _ in 0..=LINEAR_BACKTRACKS {
        let t = theta + lin * (&delta * fraction);
        let p = to_model(&Point::unpack(&t, lay));
        if prob.admissible(&p)
            && let Some(e) = prob.residuals(&p)
        {
            return Some((t, p, e));
        }
        fraction *= 0.5;
    }
    let p = to_model(&Point::unpack(theta, lay));
    if !prob.admissible(&p) {
        return None;
    }
    let e = prob.residuals(&p)?;
    Some((theta.clone(), p, e))
}

/// Halvings of the linear parameters' step tried by [`solve_linear`] when
/// the full step leaves the admissible set.
const LINEAR_BACKTRACKS: usize = 6;

/// What an accepted iterate's Jacobian leaves for its trials: the local
/// basis of α (embedded in θ), Kaufman's R₂₂ and r₂, and −R₁₁⁻¹R₁₂ (empty
/// unless a Hessian subsample is used).
type Step = (DMatrix<f64>, DMatrix<f64>, DVector<f64>, DMatrix<f64>);

/// Minimises the projected cost from `start` (its α; β is solved
/// for first). Every Jacobian and trial books its flops in `account`; the
/// iterations stop when it refuses them.
pub(super) fn minimise(
    prob: &Problem<'_, '_>,
    start: &Point,
    limits: &Limits,
    account: &mut WorkAccount,
) -> Result<Outcome> {
    let lay = prob.lay;
    let lin_idx = lay.linear_indices();
    let nl_idx = lay.nonlinear_indices();
    let lin = unit_columns(lay.len(), &lin_idx);
    let pl = lin.ncols();
    let sizes = Sizes {
        n: lay.n,
        nu: lay.nu,
        ny: lay.ny,
        samples: prob.samples,
        measured: prob.measured,
        threads: prob.threads,
        hessian_stride: prob.hessian_stride,
    };
    let work = ProjectionWork::new(&sizes, pl, nl_idx.len());
    // θ in predictor coordinates; `outcome.point` holds the model.
    let start_theta = to_predictor(start).pack(lay);
    let mut outcome = Outcome {
        point: start.clone(),
        cost: prob
            .residuals(start)
            .map_or(f64::INFINITY, |e| mean_square(&e)),
        iterations: 0,
        accepted: 0,
        termination: Termination::MaxIterations,
    };
    let mut theta = start_theta;
    let mut e = prob.residuals(start).unwrap_or_else(|| DVector::zeros(0));
    // β is brought to its optimum for the start's α from the first
    // Jacobian (its R₁₁, r₁: exact, the residuals being affine in β); after
    // that every accepted trial has it at its optimum.
    let mut beta_solved = false;
    let mut lambda = 1e-3;
    // Local coordinates of α, and R₂₂, r₂ (Kaufman's projected
    // Jacobian and residual) of the QR of [J_β J_α | e].
    // With a Hessian subsample (the whole records after a warm start) a
    // trial takes β from the Gauss–Newton model, δβ = −R₁₁⁻¹R₁₂δα, and is
    // judged by one predictor run instead of a least-squares pass; β is
    // re-solved at the next Jacobian.
    let model_beta = prob.hessian_stride > 1;
    let mut current: Option<Step> = None;
    while outcome.iterations < limits.max_iterations {
        let (basis, r22, r2, beta_of_alpha) = match current {
            Some(ref c) => c,
            None => {
                if !account.spend(work.jacobian) {
                    break;
                }
                let q = Point::unpack(&theta, lay);
                let basis = nonlinear_basis(&q, lay, &nl_idx)?;
                let mut all = DMatrix::zeros(lay.len(), pl + basis.ncols());
                all.columns_mut(0, pl).copy_from(&lin);
                all.columns_mut(pl, basis.ncols()).copy_from(&basis);
                let Ok(raug) = jacobian_r(
                    &outcome.point,
                    &push_forward(&q, &all, lay),
                    lay,
                    prob.records,
                    prob.weights,
                    prob.gain,
                    prob.threads,
                    prob.hessian_stride,
                ) else {
                    outcome.termination = Termination::NoProgress;
                    break;
                };
                let (np, pa) = (all.ncols(), basis.ncols());
                // With a Hessian subsample the linear solves are inexact:
                // β is then corrected at every Jacobian.
                if !beta_solved || prob.hessian_stride > 1 {
                    beta_solved = true;
                    let r11 = raug.view((0, 0), (pl, pl)).into_owned();
                    let r1 = raug.view((0, np), (pl, 1)).column(0).into_owned();
                    let colsq: Vec<f64> = r11.column_iter().map(|c| c.norm_squared()).collect();
                    if let Some(delta) = lm_step(&r11, &r1, LINEAR_DAMPING, &colsq) {
                        let t = &theta + &lin * delta;
                        let p = to_model(&Point::unpack(&t, lay));
                        if prob.admissible(&p)
                            && let Some(te) = prob.residuals(&p)
                            && mean_square(&te) <= outcome.cost
                        {
                            // r₂ and R₂₂ are those of the projected cost at
                            // this α; R₂₂ is Kaufman's Jacobian evaluated at
                            // the previous β for this first step.
                            outcome.cost = mean_square(&te);
                            outcome.point = p;
                            theta = t;
                            e = te;
                        }
                    }
                }
                let r12 = raug.view((0, pl), (pl, pa));
                let r1 = raug.view((0, np), (pl, 1));
                let r22 = raug.view((pl, pl), (pa, pa)).into_owned();
                let r2 = raug.view((pl, np), (pa, 1)).column(0).into_owned();
                // Gradient of the cost along α: R₁₂ᵀr₁ + R₂₂ᵀr₂ (r₁ ≈ 0 at
                // the β optimum: then the projected cost's gradient).
                let grad = r12.transpose() * r1 + r22.transpose() * &r2;
                if grad.amax() <= limits.gradient_tolerance * (1.0 + e.norm_squared()) {
                    outcome.termination = Termination::GradientConverged;
                    break;
                }
                // A full Gauss–Newton step would lower the cost by
                // ‖r₁‖² + ‖r₂‖² (R₂₂ square; r₁ ≈ 0 when β is at its
                // optimum, but not when its solve was held back at the
                // stability boundary): when that is below the tolerance of
                // the cost, no step can be worth its work.
                if r1.norm_squared() + r2.norm_squared()
                    <= limits.expected_decrease_tolerance * e.norm_squared()
                {
                    outcome.termination = Termination::CostConverged;
                    break;
                }
                // −R₁₁⁻¹R₁₂: the β step of the Gauss–Newton model per unit
                // step in α (used with a Hessian subsample only).
                let beta_of_alpha = if model_beta {
                    raug.view((0, 0), (pl, pl))
                        .upper_triangle()
                        .solve_upper_triangular(&(-r12.into_owned()))
                        .filter(|m| m.iter().all(|v| v.is_finite()))
                        .unwrap_or_else(|| DMatrix::zeros(0, 0))
                } else {
                    DMatrix::zeros(0, 0)
                };
                current.insert((basis, r22, r2, beta_of_alpha))
            }
        };
        let by_model = beta_of_alpha.nrows() == pl && pl > 0;
        if !account.spend(if by_model {
            work.model_trial
        } else {
            work.trial
        }) {
            break;
        }
        outcome.iterations += 1;
        let colsq: Vec<f64> = r22.column_iter().map(|c| c.norm_squared()).collect();
        let Some(step) = lm_step(r22, r2, lambda, &colsq) else {
            lambda *= 10.0;
            continue;
        };
        let trial_theta = &theta + basis * &step;
        let trial = to_model(&Point::unpack(&trial_theta, lay));
        let solved = if !prob.admissible(&trial) {
            None
        } else if by_model {
            let t = &trial_theta + &lin * (beta_of_alpha * &step);
            let p = to_model(&Point::unpack(&t, lay));
            prob.admissible(&p)
                .then(|| prob.residuals(&p))
                .flatten()
                .map(|te| (t, p, te))
        } else {
            solve_linear(prob, &trial_theta, &lin)
        };
        match solved {
            Some((t, p, te)) if mean_square(&te) < outcome.cost => {
                let new_cost = mean_square(&te);
                let rel = (outcome.cost - new_cost) / outcome.cost.max(f64::MIN_POSITIVE);
                let small_step =
                    step_is_small(&(basis * &step), &theta, lay, limits.step_tolerance);
                theta = t;
                outcome.point = p;
                e = te;
                outcome.cost = new_cost;
                outcome.accepted += 1;
                lambda = (lambda / 3.0).max(1e-14);
                current = None;
                if rel < limits.cost_tolerance {
                    outcome.termination = Termination::CostConverged;
                    break;
                }
                if small_step {
                    outcome.termination = Termination::StepConverged;
                    break;
                }
            }
            _ => {
                lambda *= 4.0;
                if lambda > 1e16 {
                    outcome.termination = Termination::NoProgress;
                    break;
                }
            }
        }
    }
    Ok(outcome)
}

//! Levenberg–Marquardt on all parameters together (A, B, C, D, K, x₀ in
//! the local coordinates of the similarity orbit): the method before
//! variable projection, kept as [`super::PemMethod::Joint`] for comparison.

use nalgebra::{DMatrix, DVector};

use super::Termination;
use super::jacobian::jacobian_r;
use super::lm::lm_step;
use super::point::{Point, mean_square, step_is_small};
use super::problem::{Limits, Outcome, Problem, WorkAccount};
use crate::error::Result;

/// Minimises from `start` (residuals `e`); every iteration books
/// `per_iteration` flops in `account` and the iterations stop when it
/// refuses them.
pub(super) fn minimise(
    prob: &Problem<'_, '_>,
    start: &Point,
    e: DVector<f64>,
    limits: &Limits,
    per_iteration: f64,
    account: &mut WorkAccount,
) -> Result<Outcome> {
    let lay = prob.lay;
    let mut theta = start.pack(lay);
    let mut point = start.clone();
    let mut e = e;
    let mut cost = mean_square(&e);
    let mut lambda = 0.0;
    let mut iterations = 0;
    let mut accepted = 0;
    let mut termination = Termination::MaxIterations;
    // The DDLC basis and R₁₁, r of the QR of [J | e] (J in local coordinates).
    let mut basis_and_r: Option<(DMatrix<f64>, DMatrix<f64>, DVector<f64>)> = None;
    while iterations < limits.max_iterations && account.spend(per_iteration) {
        // The DDLC basis and the Jacobian are recomputed after an accepted step only.
        let (basis, r11, rv) = match basis_and_r {
            Some(ref br) => br,
            None => {
                let q = point.similarity_tangent(lay);
                let basis = lifted_linalg::null_space(
                    &q.transpose(),
                    lifted_linalg::RankTolerance::Default,
                )?;
                let Ok(raug) = jacobian_r(
                    &point,
                    &basis,
                    lay,
                    prob.records,
                    prob.weights,
                    prob.gain,
                    prob.threads,
                    1,
                ) else {
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
        if grad.amax() <= limits.gradient_tolerance * (1.0 + e.norm_squared()) {
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
        let trial = Point::unpack(&trial_theta, lay);
        let trial_e = prob
            .admissible(&trial)
            .then(|| prob.residuals(&trial))
            .flatten();
        match trial_e {
            Some(te) if mean_square(&te) < cost => {
                let new_cost = mean_square(&te);
                let rel = (cost - new_cost) / cost.max(f64::MIN_POSITIVE);
                let small_step =
                    step_is_small(&(basis * &step), &theta, lay, limits.step_tolerance);
                theta = trial_theta;
                point = trial;
                e = te;
                cost = new_cost;
                accepted += 1;
                lambda = (lambda / 3.0).max(1e-14);
                basis_and_r = None;
                if rel < limits.cost_tolerance {
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
    Ok(Outcome {
        point,
        cost,
        iterations,
        accepted,
        termination,
    })
}

//! The Kalman gain of a single-rate subspace model, checked on its records.
//!
//! The subspace step's K comes from the covariances of the state-sequence
//! residuals through a Riccati equation (`lifted_subspace`'s noise model).
//! On real records that gain can make the one-step predictions worse than
//! the simulation they should correct, on the very data it was estimated
//! from (the CD-player arm: one-step fits 69.6 / 69.5 % where the
//! simulation fits 77.7 / 85.8 %; `benches/README.md`, "A Kalman gain that
//! predicts"): an observer or MPC built on it would track worse than no
//! correction at all.
//!
//! A second estimate of K is therefore made on the records, for the
//! model's (A, B, C, D), as SSARX and PARSIM-K finish (Jansson 2003; Qin,
//! Lin & Ljung 2005): the innovations ê are estimated by a high-order VARX
//! of the records (order: the identification's past horizon), and with
//! them the innovations form is linear in K and x₀,
//!
//!   y(t) − y_sim(t) − ê(t) = C Aᵗ x₀ + Σ_{j<t} C A^{t−1−j} K ê(j),
//!
//! so K comes from the same output-error regression that gives (B, D, x₀)
//! (`lifted_subspace::estimate_bd` with ê as the input). Of the two gains,
//! the one whose one-step predictor (A − K C stable; its initial state
//! fitted by least squares) has the smaller prediction error on the
//! records is kept; `diagnostics.kalman_gain_route` says which, with both
//! costs.
//!
//! Cost: the VARX least squares O(N (p n_z + n_u)²) (p lowered so that it
//! stays within [`VARX_WORK`]), the regression O(N n_y (n_y n³ + q²)), the
//! starts' predictor runs O(N n²) and at most [`MAX_ITERATIONS`]
//! Levenberg–Marquardt iterations of O(N n_y (n² P + P²)) for P = n n_y
//! (rows folded into an R factor: memory O(P² + N n_y)).

use lifted_lti::{Dataset, StateSpace};
use lifted_subspace::{Feedthrough, InitialState, Record, estimate_bd};
use nalgebra::{DMatrix, DVector};
use serde_json::json;

/// Largest VARX least-squares work (N (p n_z + n_u)² operations) of the
/// innovation estimate: about a second; a record that would need more
/// gets a shorter VARX.
pub(crate) const VARX_WORK: f64 = 4e9;

/// Largest number of Levenberg–Marquardt iterations over K.
const MAX_ITERATIONS: usize = 30;

/// Largest work of the Levenberg–Marquardt iterations over K (predictor
/// runs with their sensitivities and the folding of [J | r] into R,
/// N n_y (n² P + 2 P²) operations each): about two seconds. Records whose
/// three runs would exceed it keep the best start.
pub(crate) const MINIMISE_WORK: f64 = 8e9;

/// The gain to keep for `model` on `sets` (deviations from the model's
/// operating point, in the units the model was identified in) and the
/// `kalman_gain_route` diagnostics entry. `riccati`: the subspace step's
/// gain; `past`: the identification's past horizon (the VARX order).
/// Three starts — the subspace step's gain, the regression on VARX
/// innovations and K = 0 (the output-error predictor) — are scored by
/// their one-step prediction error on the records, and the best is
/// refined by Levenberg–Marquardt over K (and the predictor's initial
/// states), A, B, C, D fixed, every iterate's predictor A − K C stable.
/// Never fails: when nothing can be computed, the subspace step's gain
/// stays and the entry says why.
pub(crate) fn checked_gain(
    model: &StateSpace,
    riccati: Option<&DMatrix<f64>>,
    sets: &[Dataset],
    past: usize,
) -> (Option<DMatrix<f64>>, serde_json::Value) {
    let (n, ny) = (model.order(), model.n_outputs());
    let x0s = match simulation_states(model, sets) {
        Ok(x) => x,
        Err(e) => {
            return (
                riccati.cloned(),
                json!({"used": starts_name(riccati), "rule": format!("no check: {e}")}),
            );
        }
    };
    let regression = regression_gain(model, sets, past);
    let zero = DMatrix::zeros(n, ny);
    let starts: Vec<(&str, Option<DMatrix<f64>>)> = vec![
        ("state-sequence covariances (Riccati)", riccati.cloned()),
        (
            "regression on VARX innovations",
            regression.as_ref().ok().map(|(k, _)| k.clone()),
        ),
        ("none (K = 0, the output-error predictor)", Some(zero)),
    ];
    let costs: Vec<Option<f64>> = starts
        .iter()
        .map(|(_, k)| {
            k.as_ref()
                .and_then(|k| prediction_cost(model, k, sets, &x0s).ok())
        })
        .collect();
    let best = (0..starts.len())
        .filter_map(|i| costs[i].map(|c| (i, c)))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    let cost_json = json!({
        "riccati": costs[0],
        "regression": costs[1],
        "zero": costs[2],
    });
    let varx = match &regression {
        Ok((_, order)) => json!({"order": order}),
        Err(e) => json!({"error": e}),
    };
    let Some((i, start_cost)) = best else {
        return (
            riccati.cloned(),
            json!({
                "used": starts_name(riccati),
                "one_step_cost": cost_json,
                "varx": varx,
                "rule": "no gain gives a stable one-step predictor: the subspace step's is kept",
            }),
        );
    };
    let start = starts[i].1.clone().unwrap_or_else(|| DMatrix::zeros(n, ny));
    match minimise(model, &start, sets, &x0s) {
        Ok((k, cost, iterations)) if cost < start_cost => (
            Some(k),
            json!({
                "used": format!("prediction-error minimisation over K from {}", starts[i].0),
                "start": starts[i].0,
                "one_step_cost": cost_json,
                "final_cost": cost,
                "iterations": iterations,
                "varx": varx,
                "rule": RULE,
            }),
        ),
        outcome => (
            Some(start),
            json!({
                "used": starts[i].0,
                "start": starts[i].0,
                "one_step_cost": cost_json,
                "final_cost": start_cost,
                "minimisation": match outcome {
                    Ok(_) => "no decrease".to_string(),
                    Err(e) => e,
                },
                "varx": varx,
                "rule": RULE,
            }),
        ),
    }
}

/// `kalman_gain_route.used` when the subspace step's gain stays unchecked.
fn starts_name(riccati: Option<&DMatrix<f64>>) -> &'static str {
    if riccati.is_some() {
        "state-sequence covariances (Riccati)"
    } else {
        "none"
    }
}

/// `kalman_gain_route.rule`.
const RULE: &str = "one-step prediction error on the records (normalised squared error, mean over the outputs; the predictor started from the state the simulation is fitted from, as `validate` does): the best of three starts (subspace step, regression on VARX innovations, K = 0), then Levenberg–Marquardt over K with A, B, C, D fixed and A − K C stable";

/// Rows of [J | r] folded into the R factor at a time.
const BLOCK_ROWS: usize = 2048;

/// Levenberg–Marquardt on the one-step prediction errors over K from
/// `start` (its predictor stable), the predictor started from `x0s`, with
/// the exact Jacobian from the sensitivity recursions
/// S(t+1) = (A − K C) S(t) + E(ε(t)), ∂ε(t)/∂vec K = −C S(t). The rows
/// of [J | r] are folded block by block into the R factor of their QR
/// (memory O(P²), never JᵀJ), and each step solves the small damped
/// problem [R_J; √λ D] δ = [−q; 0] (D: Marquardt's column norms of J).
/// Returns the gain, its cost ([`prediction_cost`]) and the iterations
/// taken. O(N n² P) per iteration for P = n n_y parameters.
fn minimise(
    model: &StateSpace,
    start: &DMatrix<f64>,
    sets: &[Dataset],
    x0s: &[DVector<f64>],
) -> Result<(DMatrix<f64>, f64, usize), String> {
    let (n, ny) = (model.order(), model.n_outputs());
    if n == 0 {
        return Err("a static model has no gain".into());
    }
    let params = n * ny;
    let rows: usize = sets.iter().map(|d| d.len() * ny).sum();
    let per_run = rows as f64 * ((n * n * params) as f64 + 2.0 * (params * params) as f64);
    let mut runs_left = (MINIMISE_WORK / per_run).floor() as usize;
    if runs_left < 3 {
        return Err(format!(
            "its predictor runs would cost {per_run:.2e} operations each, more than a third of {MINIMISE_WORK:.0e}"
        ));
    }
    // Per-output weights 1/‖y_o − ȳ_o‖ over all records (the cost of
    // prediction_cost without its division by n_y).
    let mut spread = vec![0.0; ny];
    for d in sets {
        for (o, s) in spread.iter_mut().enumerate() {
            let mean = d.y().column(o).mean();
            *s += d
                .y()
                .column(o)
                .iter()
                .map(|v| (v - mean).powi(2))
                .sum::<f64>();
        }
    }
    let w: Vec<f64> = spread
        .iter()
        .map(|s| if *s > 0.0 { 1.0 / s.sqrt() } else { 0.0 })
        .collect();
    let mut theta = DVector::from_column_slice(start.as_slice());
    let gain = |theta: &DVector<f64>| DMatrix::from_column_slice(n, ny, theta.as_slice());
    // ‖r‖² and the R factor of [J | r] at θ; None when A − K C is not
    // stable or the errors are not finite.
    let eval = |theta: &DVector<f64>| -> Option<(f64, DMatrix<f64>)> {
        let k = gain(theta);
        let m = model.a() - &k * model.c();
        let rho = lifted_linalg::eigenvalues(&m)
            .ok()?
            .iter()
            .map(|z| z.norm())
            .fold(0.0, f64::max);
        if rho >= 1.0 {
            return None;
        }
        let (a, b, c, d) = (model.a(), model.b(), model.c(), model.d());
        let mut acc = lifted_linalg::RAccumulator::new(params + 1);
        let mut block = DMatrix::zeros(BLOCK_ROWS, params + 1);
        let mut filled = 0;
        let mut cost = 0.0;
        for (data, x0) in sets.iter().zip(x0s) {
            let (u, y) = (data.u(), data.y());
            let mut x = x0.clone();
            let mut sens = DMatrix::zeros(n, params);
            for t in 0..data.len() {
                let ut = u.row(t).transpose();
                let eps = y.row(t).transpose() - c * &x - d * &ut;
                let cs = c * &sens;
                for o in 0..ny {
                    if filled == BLOCK_ROWS {
                        acc.push_rows(&block).ok()?;
                        filled = 0;
                    }
                    for p in 0..params {
                        block[(filled, p)] = -w[o] * cs[(o, p)];
                    }
                    let r = w[o] * eps[o];
                    block[(filled, params)] = r;
                    cost += r * r;
                    filled += 1;
                }
                // S(t+1) = M S(t) + E(ε(t)): entry K_io (column o·n + i of
                // vec K) adds ε_o(t) to state i.
                let mut next = &m * &sens;
                for o in 0..ny {
                    for i in 0..n {
                        next[(i, o * n + i)] += eps[o];
                    }
                }
                sens = next;
                x = a * &x + b * &ut + &k * &eps;
            }
        }
        acc.push_rows(&block.rows(0, filled).into_owned()).ok()?;
        cost.is_finite().then(|| (cost, acc.r()))
    };
    let Some((mut cost, mut r)) = eval(&theta) else {
        return Err("the start's predictor is not stable".into());
    };
    runs_left -= 1;
    let mut lambda: f64 = 1e-3;
    let mut iterations = 0;
    while iterations < MAX_ITERATIONS {
        iterations += 1;
        // R of [J | r]: its first P columns' upper block is R_J, the last
        // column's first P entries q (J δ + r ≈ R_J δ + q).
        let k = r.nrows().min(params);
        let rj = r.view((0, 0), (k, params)).into_owned();
        let q = r.view((0, params), (k, 1)).into_owned();
        let scale: Vec<f64> = (0..params)
            .map(|p| rj.column(p).norm().max(1e-300))
            .collect();
        let mut improved = false;
        while lambda < 1e10 && runs_left > 0 {
            let mut aug = DMatrix::zeros(k + params, params);
            aug.rows_mut(0, k).copy_from(&rj);
            for p in 0..params {
                aug[(k + p, p)] = lambda.sqrt() * scale[p];
            }
            let mut rhs = DMatrix::zeros(k + params, 1);
            rhs.rows_mut(0, k).copy_from(&(-&q));
            let Ok(step) = lifted_linalg::lstsq(&aug, &rhs) else {
                lambda *= 4.0;
                continue;
            };
            let trial = &theta + step.column(0);
            runs_left -= 1;
            match eval(&trial) {
                Some((ct, rt)) if ct < cost => {
                    let decrease = (cost - ct) / cost.max(f64::MIN_POSITIVE);
                    (theta, cost, r) = (trial, ct, rt);
                    lambda = (lambda / 3.0).max(1e-12);
                    improved = decrease > 1e-9;
                    break;
                }
                _ => lambda *= 4.0,
            }
        }
        if !improved {
            break;
        }
    }
    let k = gain(&theta);
    let cost = prediction_cost(model, &k, sets, x0s)?;
    Ok((k, cost, iterations))
}

/// K by the output-error regression on VARX innovations (module docs),
/// and the VARX order used.
fn regression_gain(
    model: &StateSpace,
    sets: &[Dataset],
    past: usize,
) -> Result<(DMatrix<f64>, usize), String> {
    let (nu, ny) = (model.n_inputs(), model.n_outputs());
    let nz = nu + ny;
    let total: usize = sets.iter().map(Dataset::len).sum();
    let cols = |p: usize| (p * nz + nu) as f64;
    // The longest VARX within the work bound with ten samples per
    // regressor in every record.
    let shortest = sets.iter().map(Dataset::len).min().unwrap_or(0);
    let order = (1..=past.max(1))
        .rev()
        .find(|&p| {
            total as f64 * cols(p) * cols(p) <= VARX_WORK && shortest > p + 10 * (p * nz + nu)
        })
        .ok_or_else(|| "the records are too short for a VARX".to_string())?;
    let innovations = varx_innovations(sets, order)?;
    let a = model.a();
    let c = model.c();
    let mut targets = Vec::with_capacity(sets.len());
    for (d, e) in sets.iter().zip(&innovations) {
        let len = d.len() - order;
        let u = d.u().rows(order, len).into_owned();
        let y = d.y().rows(order, len).into_owned();
        let sim = model.lsim(&u, None, None).map_err(|e| e.to_string())?;
        targets.push(y - sim.y - e);
    }
    let recs: Vec<Record<'_>> = innovations
        .iter()
        .zip(&targets)
        .map(|(e, r)| Record {
            u: e,
            y: r,
            instrument: None,
        })
        .collect();
    let fit = estimate_bd(a, c, &recs, &Feedthrough::Zero, InitialState::Estimate)
        .map_err(|e| format!("the regression of K failed ({e})"))?;
    Ok((fit.b, order))
}

/// The one-step prediction errors of a VARX of order `p` fitted to all
/// records together by least squares (y(t) on z(t−1) … z(t−p) and u(t)):
/// per record, the N − p estimates ê(p) … ê(N−1). The regressor rows are
/// folded block by block into the R factor of [X | Y] (memory
/// O(w²) for w = p n_z + n_u regressors), the coefficients solved from it,
/// and the residuals formed in a second pass.
fn varx_innovations(sets: &[Dataset], p: usize) -> Result<Vec<DMatrix<f64>>, String> {
    let (nu, ny) = (sets[0].u().ncols(), sets[0].y().ncols());
    let nz = nu + ny;
    let width = p * nz + nu;
    // Row t of record d: [z(t−1) … z(t−p), u(t) | y(t)].
    let fill = |d: &Dataset, t: usize, row: &mut [f64]| {
        let (u, y) = (d.u(), d.y());
        for lag in 1..=p {
            let base = (lag - 1) * nz;
            for j in 0..nu {
                row[base + j] = u[(t - lag, j)];
            }
            for j in 0..ny {
                row[base + nu + j] = y[(t - lag, j)];
            }
        }
        for j in 0..nu {
            row[p * nz + j] = u[(t, j)];
        }
        for j in 0..ny {
            row[width + j] = y[(t, j)];
        }
    };
    let mut acc = lifted_linalg::RAccumulator::new(width + ny);
    let mut block = DMatrix::zeros(BLOCK_ROWS, width + ny);
    let mut row = vec![0.0; width + ny];
    let mut filled = 0;
    for d in sets {
        for t in p..d.len() {
            if filled == BLOCK_ROWS {
                acc.push_rows(&block).map_err(|e| e.to_string())?;
                filled = 0;
            }
            fill(d, t, &mut row);
            for (c, v) in row.iter().enumerate() {
                block[(filled, c)] = *v;
            }
            filled += 1;
        }
    }
    acc.push_rows(&block.rows(0, filled).into_owned())
        .map_err(|e| e.to_string())?;
    let r = acc.r();
    if r.nrows() < width + ny {
        return Err("the records are too short for the VARX".into());
    }
    let theta = lifted_linalg::lstsq(
        &r.view((0, 0), (width, width)).into_owned(),
        &r.view((0, width), (width, ny)).into_owned(),
    )
    .map_err(|e| format!("the VARX failed ({e})"))?;
    let mut out = Vec::with_capacity(sets.len());
    for d in sets {
        let len = d.len() - p;
        let mut e = DMatrix::zeros(len, ny);
        for t in p..d.len() {
            fill(d, t, &mut row);
            for j in 0..ny {
                let fitted: f64 = (0..width).map(|c| row[c] * theta[(c, j)]).sum();
                e[(t - p, j)] = row[width + j] - fitted;
            }
        }
        out.push(e);
    }
    Ok(out)
}

/// The initial state of each record that `lifted validate` simulates
/// from: least squares on the free response C Aᵗ x₀ of the simulation
/// error (over the samples where ρ(A)ᵗ ≥ 1e-12); zero for an unstable or
/// static model. The one-step predictor starts from it, as in
/// `lifted_lti::validate`, so the cost minimised is the one the
/// validation reports.
fn simulation_states(model: &StateSpace, sets: &[Dataset]) -> Result<Vec<DVector<f64>>, String> {
    let n = model.order();
    let rho = if n == 0 {
        0.0
    } else {
        lifted_linalg::eigenvalues(model.a())
            .map_err(|e| e.to_string())?
            .iter()
            .map(|z| z.norm())
            .fold(0.0, f64::max)
    };
    sets.iter()
        .map(|d| {
            if n == 0 || rho >= 1.0 {
                return Ok(DVector::zeros(n));
            }
            let sim = model.lsim(d.u(), None, None).map_err(|e| e.to_string())?;
            let err = d.y() - sim.y;
            free_response_fit(model.a(), model.c(), rho, &err)
        })
        .collect()
}

/// x₀ minimising ‖e(t) − C Mᵗ x₀‖ over the samples where ρᵗ ≥ 1e-12 (ρ the
/// spectral radius of M): O(T n_y n²) for those T samples.
fn free_response_fit(
    m: &DMatrix<f64>,
    c: &DMatrix<f64>,
    rho: f64,
    err: &DMatrix<f64>,
) -> Result<DVector<f64>, String> {
    let (n, ny, len) = (m.nrows(), c.nrows(), err.nrows());
    let span = if rho > 0.0 {
        ((1e-12f64).ln() / rho.ln()).ceil().min(len as f64) as usize
    } else {
        1
    }
    .clamp(1, len);
    let mut phi = DMatrix::zeros(span * ny, n);
    let mut target = DMatrix::zeros(span * ny, 1);
    let mut p = c.clone();
    for t in 0..span {
        phi.rows_mut(t * ny, ny).copy_from(&p);
        for o in 0..ny {
            target[(t * ny + o, 0)] = err[(t, o)];
        }
        p = &p * m;
    }
    let x0 = lifted_linalg::lstsq(&phi, &target).map_err(|e| e.to_string())?;
    Ok(x0.column(0).into_owned())
}

/// The one-step prediction error of gain `k` on `sets`, the predictor
/// started from `x0s` (one state per record): per output, the squared
/// error over the records divided by the output's squared deviation from
/// its mean, averaged over the outputs. `Err` when A − K C is not stable
/// (no predictor) or the prediction fails.
fn prediction_cost(
    model: &StateSpace,
    k: &DMatrix<f64>,
    sets: &[Dataset],
    x0s: &[DVector<f64>],
) -> Result<f64, String> {
    let ny = model.n_outputs();
    let m = model.a() - k * model.c();
    let rho = lifted_linalg::eigenvalues(&m)
        .map_err(|e| e.to_string())?
        .iter()
        .map(|z| z.norm())
        .fold(0.0, f64::max);
    if rho >= 1.0 {
        return Err(format!("A − K C is not stable (spectral radius {rho:.4})"));
    }
    let mut err = vec![0.0; ny];
    let mut spread = vec![0.0; ny];
    for (d, x0) in sets.iter().zip(x0s) {
        let (u, y) = (d.u(), d.y());
        let resid = y - model
            .predict_from(k, u, y, 1, Some(x0))
            .map_err(|e| e.to_string())?;
        for o in 0..ny {
            let mean = y.column(o).mean();
            for t in 0..y.nrows() {
                err[o] += resid[(t, o)].powi(2);
                spread[o] += (y[(t, o)] - mean).powi(2);
            }
        }
    }
    let cost = err
        .iter()
        .zip(&spread)
        .map(|(e, s)| if *s > 0.0 { e / s } else { 0.0 })
        .sum::<f64>()
        / ny as f64;
    if cost.is_finite() {
        Ok(cost)
    } else {
        Err("the prediction error is not finite".into())
    }
}

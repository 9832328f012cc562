//! The starts and costs of the Kalman-gain check: the regression of the
//! states on VARX innovations (the second start), the simulated states, the
//! one-step prediction cost and its normalisation by the outputs' spread.
//! O(N · (m + p)·s) for the VARX, O(N n²) per cost.

use lifted_lti::StateSpace;

use crate::estimated::Record;
use crate::estimated::{Feedthrough, InitialState};
use crate::model::Experiment;
use crate::one_step::OneStep;
use crate::regress::{estimate_bd, estimate_x0};
use lifted_linalg::spectral_radius;
use nalgebra::{DMatrix, DVector};

use super::{BLOCK_ROWS, CentredRecord, MEMO_ENTRIES, VarxMemo, records_hash};

/// K by the output-error regression on VARX innovations (module docs),
/// and the VARX order used.
pub(super) fn regression_gain(
    model: &StateSpace,
    sets: &[Experiment<'_>],
    past: usize,
    varx_work: f64,
    memo: &mut VarxMemo,
) -> Result<(DMatrix<f64>, usize), String> {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            let (nu, ny) = (model.n_inputs(), model.n_outputs());
            let nz = nu + ny;
            let total: usize = sets.iter().map(|d| d.u.nrows()).sum();
            let cols = |p: usize| (p * nz + nu) as f64;
            // The longest VARX within the work bound with ten samples per
            // regressor in every record.
            let shortest = sets.iter().map(|d| d.u.nrows()).min().unwrap_or(0);
            let order = (1..=past.max(1))
                .rev()
                .find(|&p| {
                    total as f64 * cols(p) * cols(p) <= varx_work
                        && shortest > p + 10 * (p * nz + nu)
                })
                .ok_or_else(|| "the records are too short for a VARX".to_string())?;
            // u(t) among the regressors only for a model with a direct
            // feedthrough: under a controller reacting within the sample it would
            // carry the innovation into the regression.
            let direct = model.d().iter().any(|v| *v != 0.0);
            // The VARX's records: the memo's source when it has the check's
            // shapes (every model of a record then shares its innovations), else
            // the records as given.
            let fits = |c: &[CentredRecord]| {
                c.len() == sets.len()
                    && c.iter()
                        .zip(sets)
                        .all(|((u, y), d)| u.shape() == d.u.shape() && y.shape() == d.y.shape())
            };
            // Keyed by the records' hash and whether they were centred (a record
            // given as it is and the same record centred are different VARX data).
            let (hash, varx_sets): ((u64, bool), Vec<Experiment<'_>>) = match &memo.source {
                Some((h, c)) if fits(c) => (
                    (*h, true),
                    c.iter().map(|(u, y)| Experiment { u, y }).collect(),
                ),
                _ => ((records_hash(sets), false), sets.to_vec()),
            };
            let found = memo
                .kept
                .iter()
                .position(|(h, o, d, _)| (*h, *o, *d) == (hash, order, direct));
            let at = match found {
                Some(at) => at,
                None => {
                    let e = varx_innovations(&varx_sets, order, direct)?;
                    memo.computed += 1;
                    if memo.kept.len() == MEMO_ENTRIES {
                        memo.kept.remove(0);
                    }
                    memo.kept.push((hash, order, direct, e));
                    memo.kept.len() - 1
                }
            };
            let innovations = &memo.kept[at].3;
            let a = model.a();
            let c = model.c();
            let mut targets = Vec::with_capacity(sets.len());
            for (d, e) in sets.iter().zip(innovations) {
                let len = d.u.nrows() - order;
                let u = d.u.rows(order, len).into_owned();
                let y = d.y.rows(order, len).into_owned();
                let sim = model.lsim_outputs(&u, None).map_err(|e| e.to_string())?;
                targets.push(y - sim - e);
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
        },
    )
}

/// The one-step prediction errors of a VARX of order `p` fitted to all
/// records together by least squares (y(t) on z(t−1) … z(t−p), and u(t)
/// when `direct`): per record, the N − p estimates ê(p) … ê(N−1). The
/// regressor rows are folded block by block into the R factor of [X | Y]
/// (memory O(w²) for w ≤ p n_z + n_u regressors), the coefficients solved
/// from it, and the residuals formed in a second pass.
pub(super) fn varx_innovations(
    sets: &[Experiment<'_>],
    p: usize,
    direct: bool,
) -> Result<Vec<DMatrix<f64>>, String> {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            let (nu, ny) = (sets[0].u.ncols(), sets[0].y.ncols());
            let nz = nu + ny;
            let nd = if direct { nu } else { 0 };
            let width = p * nz + nd;
            // Rows t0 … t0 + rows − 1 of record d into block rows at … at + rows − 1:
            // row t is [z(t−1) … z(t−p), u(t) | y(t)], filled a column segment at a
            // time (contiguous copies of the column-major records).
            let fill = |d: &Experiment<'_>,
                        t0: usize,
                        rows: usize,
                        block: &mut DMatrix<f64>,
                        at: usize| {
                let (u, y) = (d.u, d.y);
                for lag in 1..=p {
                    let base = (lag - 1) * nz;
                    for j in 0..nu {
                        block
                            .view_mut((at, base + j), (rows, 1))
                            .copy_from(&u.view((t0 - lag, j), (rows, 1)));
                    }
                    for j in 0..ny {
                        block
                            .view_mut((at, base + nu + j), (rows, 1))
                            .copy_from(&y.view((t0 - lag, j), (rows, 1)));
                    }
                }
                for j in 0..nd {
                    block
                        .view_mut((at, p * nz + j), (rows, 1))
                        .copy_from(&u.view((t0, j), (rows, 1)));
                }
                for j in 0..ny {
                    block
                        .view_mut((at, width + j), (rows, 1))
                        .copy_from(&y.view((t0, j), (rows, 1)));
                }
            };
            let mut acc = lifted_linalg::RAccumulator::new(width + ny);
            let mut block = DMatrix::zeros(BLOCK_ROWS, width + ny);
            let mut filled = 0;
            for d in sets {
                let mut t = p;
                while t < d.u.nrows() {
                    if filled == BLOCK_ROWS {
                        acc.push_rows(&block).map_err(|e| e.to_string())?;
                        filled = 0;
                    }
                    let take = (BLOCK_ROWS - filled).min(d.u.nrows() - t);
                    fill(d, t, take, &mut block, filled);
                    filled += take;
                    t += take;
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
            // The residuals block by block: ê = y − [z(t−1) … z(t−p), u(t)] θ.
            let mut out = Vec::with_capacity(sets.len());
            for d in sets {
                let len = d.u.nrows() - p;
                let mut e = DMatrix::zeros(len, ny);
                let mut t = p;
                while t < d.u.nrows() {
                    let take = BLOCK_ROWS.min(d.u.nrows() - t);
                    fill(d, t, take, &mut block, 0);
                    let mut rows = e.view_mut((t - p, 0), (take, ny));
                    rows.copy_from(&block.view((0, width), (take, ny)));
                    rows.gemm(-1.0, &block.view((0, 0), (take, width)), &theta, 1.0);
                    t += take;
                }
                out.push(e);
            }
            Ok(out)
        },
    )
}

/// The initial state of each record that `lifted validate` simulates
/// from: the least-squares x₀ of the simulation error
/// ([`crate::regress::estimate_x0`]); zero for an unstable model, as
/// `validate` does. The one-step predictor starts from it, as in
/// `lifted_lti::validate`, so the cost minimised is the one the
/// validation reports.
pub(super) fn simulation_states(
    model: &StateSpace,
    sets: &[Experiment<'_>],
) -> Result<Vec<DVector<f64>>, String> {
    let n = model.order();
    let rho = if n == 0 {
        0.0
    } else {
        spectral_radius(model.a()).map_err(|e| e.to_string())?
    };
    if n == 0 || rho >= 1.0 {
        return Ok(vec![DVector::zeros(n); sets.len()]);
    }
    let recs = crate::records::records_of(sets);
    estimate_x0(model.a(), model.b(), model.c(), model.d(), &recs).map_err(|e| e.to_string())
}

/// The one-step prediction error of gain `k` on `sets`, the predictor
/// started from `x0s` (one state per record): per output, the squared
/// error over the records divided by the output's squared deviation from
/// its mean ([`output_spread`] of `sets`: `spread`), averaged over the
/// outputs. `Err` when A − K C is not stable (no predictor) or the
/// prediction fails.
pub(super) fn prediction_cost(
    model: &StateSpace,
    k: &DMatrix<f64>,
    sets: &[Experiment<'_>],
    x0s: &[DVector<f64>],
    spread: &[f64],
) -> Result<f64, String> {
    let ny = model.n_outputs();
    let m = model.a() - k * model.c();
    let rho = spectral_radius(&m).map_err(|e| e.to_string())?;
    if rho >= 1.0 {
        return Err(format!("A − K C is not stable (spectral radius {rho:.4})"));
    }
    let predictor = OneStep::new(model, k, &m);
    let mut err = vec![0.0; ny];
    for (d, x0) in sets.iter().zip(x0s) {
        predictor.add_squared_errors(d.u, d.y, x0, &mut err);
    }
    normalised_cost(&err, spread)
}

/// [`prediction_cost`] from the outputs' summed squared errors `err`:
/// each divided by its [`output_spread`], averaged over the outputs.
pub(super) fn normalised_cost(err: &[f64], spread: &[f64]) -> Result<f64, String> {
    let cost = err
        .iter()
        .zip(spread)
        .map(|(e, s)| if *s > 0.0 { e / s } else { 0.0 })
        .sum::<f64>()
        / err.len().max(1) as f64;
    if cost.is_finite() {
        Ok(cost)
    } else {
        Err("the prediction error is not finite".into())
    }
}

/// Per output, the squared deviations of its measured samples from their
/// record's mean, summed over the records (the normalisation of the
/// one-step cost). O(N n_y).
pub(super) fn output_spread(sets: &[Experiment<'_>], ny: usize) -> Vec<f64> {
    let mut spread = vec![0.0; ny];
    for d in sets {
        // (The means over the measured samples where some are missing.)
        let means: Vec<f64> = if d.y.iter().any(|v| v.is_nan()) {
            measured_means(d.y)
        } else {
            d.y.column_iter().map(|c| c.mean()).collect()
        };
        for (o, s) in spread.iter_mut().enumerate() {
            *s +=
                d.y.column(o)
                    .iter()
                    .filter(|v| !v.is_nan())
                    .map(|v| (v - means[o]).powi(2))
                    .sum::<f64>();
        }
    }
    spread
}

/// The mean of each output over its measured (non-NaN) samples.
pub(super) fn measured_means(y: &DMatrix<f64>) -> Vec<f64> {
    y.column_iter()
        .map(|col| {
            let (sum, count) = col
                .iter()
                .filter(|v| !v.is_nan())
                .fold((0.0, 0usize), |(s, c), v| (s + v, c + 1));
            if count > 0 { sum / count as f64 } else { 0.0 }
        })
        .collect()
}

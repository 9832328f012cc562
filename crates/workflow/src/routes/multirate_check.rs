//! The multirate route judged against interpolation on held-out blocks.
//!
//! A user without a multirate tool interpolates the slow outputs linearly
//! and runs the single-rate route on the result. The multirate route
//! (lifting, the interpolated start refitted and refined on the measured
//! samples, `super::multirate_start`) departs from that model, and every
//! one of its choices is made by the simulation fit on the measured
//! samples it was fitted to: the (B, D) refit is the least-squares
//! minimiser of that very criterion for the start's (A, C), so compared on
//! the same samples it wins by construction. On records whose output
//! carries a slow disturbance and whose inputs drift together, that
//! in-sample advantage is spurious: on the debutanizer record thinned to
//! every fifth output sample (issue 46; `benches/results/closed-loop.md`)
//! the refit fits the measured estimation samples at 54.8 % against 48.8
//! for the interpolated model, while on the validation half it gives 14.9
//! against 33.2 % (its simulation residuals have a lag-one correlation of
//! 0.86 between measured samples: a few hundred samples carry the
//! information of a few dozen).
//!
//! So the two *procedures* are compared as the single-rate route compares
//! a subspace model with its refinement (`crate::refine`, `lifted_pem::
//! cross_validate_refinement`): each record is cut into six blocks; for
//! each block, the multirate route (at the order it chose, without this
//! check) and the single-rate route on the interpolated record are run on
//! the longer contiguous part of the record beside it (the lifted route
//! takes one contiguous record; at least half the record), and both models
//! simulate the held-out block's measured samples from their operating
//! points (x₀ estimated on the block). The route's model is kept
//! when the per-block differences tell the two apart in its favour by the
//! refinement check's rule (`opts.refinement.check`, by default a paired
//! t-test or a sign test at 95 %, the median block agreeing; a block whose
//! model fails scores `failed_fold`, −100); otherwise the interpolated
//! record's single-rate model of the whole record is returned: the model a
//! user would have had without the multirate route, which the multirate
//! route replaces only on held-out evidence (Bergmeir & Benítez 2012 for
//! blocked cross-validation of time series).
//!
//! Applies where the interpolated start applies (`multirate_start::
//! applies`) to a stable model (within the integrator tolerance) whose
//! free parameters k as a simulated model (n(n_u + n_y) for A and B in an
//! observable canonical form, n for x₀, n_u n_y with a feedthrough)
//! leave every fold's part at least [`MEASURED_PER_PARAMETER`] measured
//! output values per parameter, on records of at most `budgets.refine_check_samples` samples
//! (the budget of the single-rate held-out check, 2e4 by default; 0 turns
//! it off). The fold runs hold the whole record's choices of horizon,
//! (A, C) estimator, refinement (a route whose whole-record refinement
//! was not kept is not refined in its folds) and multirate start (the
//! route's folds refine only the start the whole record's run kept,
//! `multirate_start::choose`): a cross-validation of the procedure with
//! its hyperparameters fixed. Cost: thirteen runs of the
//! two routes (the whole record's interpolated model, and both routes on
//! each of six folds of a half to five sixths of the record), each O(N) at
//! the fixed order, the folds on the machine's threads; `diagnostics.
//! multirate_check` gives the per-block fits and the verdict.

use lifted_lti::{Dataset, OperatingPoint, StateSpace};
use lifted_pem::RefinementCheck;
use nalgebra::DMatrix;
use serde_json::json;

use crate::diagnostics::push_warning;
use crate::options::{Estimator, Order, Refine, WorkflowOptions};
use crate::routes::multirate_start::{Start, interpolated, records_fit_from};

/// Blocks of the held-out check (as the single-rate refinement check).
pub const CHECK_BLOCKS: usize = 6;

/// Measured output values per free parameter that each fold's part must
/// carry for the check to run: 2. With k parameters fitted to N values,
/// the expected held-out error of a fold's model is the noise's times
/// Akaike's final prediction error factor (1 + k/N)/(1 − k/N), which
/// reaches 3 at N = 2k: beyond it the held-out fits of the two routes
/// compare their parameter noise more than the routes (and the thirteen
/// runs at such orders cost most: a 600-sample record at order 48 took
/// 25 s of checking).
pub const MEASURED_PER_PARAMETER: usize = 2;

/// `diagnostics.multirate_check.kept` when the route's model stays.
pub const KEPT_ROUTE: &str = "the multirate route's model";
/// `… .kept` when the interpolated record's model is returned.
pub const KEPT_INTERPOLATED: &str =
    "the single-rate model of the record with its slow outputs interpolated linearly";

/// The options of the runs inside the check: the order fixed at the
/// route's, no covariance, no stability requirement. The records come
/// detrended and scaled by the outer run; the detrending is the run's own
/// again, so that the single-rate route removes the interpolated record's
/// means inside its identification as a user's run on that record does
/// (the outer operating point is kept: the interpolated record's output
/// mean differs from the measured samples' by a small fraction of their
/// spread, 2e-5 of it on the thinned debutanizer record).
fn fold_options(opts: &WorkflowOptions, order: usize) -> WorkflowOptions {
    let mut o = opts.clone();
    o.identification.order = Order::Fixed(order);
    o.validation.covariance = false;
    o.validation.require_stable = false;
    o
}

/// The options of the fold runs (the route's, the interpolated record's):
/// without the single-rate route's own held-out checks nested in each
/// fold — its refinement judged on the fold's records, its horizon and
/// (A, C) estimator those the whole interpolated record's structure
/// selection chose (`interp_whole`: that run's diagnostics) — as
/// hyperparameters are held at the whole record's choice in a
/// cross-validation of the procedure. The refinement is held alike: a
/// route whose refinement the whole record's run did not keep (its judge
/// kept the start, or it was not run) is not refined in the folds either
/// (`route_whole`: the route's diagnostics), so that each fold fits the
/// kind of model the whole record delivers — and the folds skip the
/// iterations whose result the whole record set aside, most of the
/// check's cost (a 15 000-sample 2 × 2 record: 23 s of checking before,
/// 7.7 s after, the interpolated record's refinement not kept there).
fn fold_runs(
    o: &WorkflowOptions,
    route_whole: &serde_json::Value,
    interp_whole: &serde_json::Value,
) -> (WorkflowOptions, WorkflowOptions) {
    let mut route = o.clone();
    route.budgets.refine_check_samples = 0;
    route.identification.threads = Some(1);
    let mut interp = route.clone();
    let chosen = &interp_whole["structure_selection"];
    if interp.identification.horizon.is_none()
        && let Some(h) = chosen["horizon"].as_u64()
    {
        interp.identification.horizon = Some(h as usize);
    }
    if interp.identification.estimator == Estimator::Auto {
        match chosen["system"].as_str() {
            Some("shift invariance") => interp.identification.estimator = Estimator::Shift,
            Some("state sequences") => interp.identification.estimator = Estimator::States,
            _ => {}
        }
    }
    for (fold, whole) in [(&mut route, route_whole), (&mut interp, interp_whole)] {
        if !refinement_kept(whole) {
            fold.refinement.refine = Refine::None;
        }
    }
    (route, interp)
}

/// Whether a run's model is its refinement (`diagnostics.refinement.kept`).
fn refinement_kept(diagnostics: &serde_json::Value) -> bool {
    diagnostics["refinement"]["kept"].as_str() == Some("Refined")
}

/// One fold's held-out fits: (interpolated record's model, route's model).
type FoldFits = (Option<f64>, Option<f64>);

/// Per fold (in block order, folds without a block or part left out): the
/// held-out fits of the interpolated record's model and the route's, each
/// fitted to the part beside the block; the folds on `workers` threads.
fn held_out_fits(
    run: FoldRun<'_>,
    sets: &[Dataset],
    (o_route, start): (&WorkflowOptions, Option<Start>),
    o_interp: &WorkflowOptions,
    workers: usize,
) -> Vec<FoldFits> {
    let one = |k: usize| {
        let (est, held) = fold(sets, k)?;
        let score = |m: Option<Fitted>| m.and_then(|m| held_out_fit(&m, &held));
        let route = score(model_of(run, &est, o_route, start));
        let interp = est
            .iter()
            .map(interpolated)
            .collect::<crate::Result<Vec<_>>>()
            .ok()
            .and_then(|s| score(model_of(run, &s, o_interp, None)));
        Some((interp, route))
    };
    crate::parallel::map_in_order(CHECK_BLOCKS, workers, one)
        .into_iter()
        .filter_map(|f| f.flatten())
        .collect()
}

/// One run of the workflow inside the check, without the check (the
/// pipeline's, handed in by it): the model, its operating point (the
/// means its run removed, in the units of the records given) and its
/// diagnostics; `None` when it fails.
pub(crate) type FoldRun<'a> = &'a (
        dyn Fn(&[Dataset], &WorkflowOptions, Option<Start>) -> Option<(Fitted, serde_json::Value)>
            + Sync
    );

/// The model of one run inside the check with its operating point; `held`:
/// the multirate start it takes without comparing the two.
fn model_of(
    run: FoldRun<'_>,
    sets: &[Dataset],
    opts: &WorkflowOptions,
    held: Option<Start>,
) -> Option<Fitted> {
    run(sets, opts, held).map(|(m, _)| m)
}

/// A model and its operating point.
pub(crate) type Fitted = (StateSpace, Option<OperatingPoint>);

/// The held-out fit of a model from its operating point
/// (`multirate_start::records_fit_from`).
fn held_out_fit((model, op): &Fitted, sets: &[Dataset]) -> Option<f64> {
    records_fit_from(model, op.clone(), sets)
}

/// Each record's block `k` of [`CHECK_BLOCKS`] (bounds on its frame
/// period) and the longer of the parts before and after it (the multirate
/// route identifies one contiguous record: the two parts are not joined);
/// `None` when a record has no such block or part.
fn fold(sets: &[Dataset], k: usize) -> Option<(Vec<Dataset>, Vec<Dataset>)> {
    let (mut est, mut held) = (Vec::new(), Vec::new());
    for d in sets {
        let (len, frame) = (d.len(), d.frame_period().max(1));
        let bound = |j: usize| {
            if j == CHECK_BLOCKS {
                len
            } else {
                (len * j / CHECK_BLOCKS) / frame * frame
            }
        };
        let (a, b) = (bound(k), bound(k + 1));
        if b <= a + frame {
            return None;
        }
        let (s, e) = if a >= len - b { (0, a) } else { (b, len) };
        if e < s + 2 * frame {
            return None;
        }
        held.push(d.slice(a..b).ok()?);
        est.push(d.slice(s..e).ok()?);
    }
    Some((est, held))
}

/// What [`against_interpolation`] returns: the model, the diagnostics, and
/// when the interpolated record's model replaces the route's, the operating
/// point its run took from `sets` (means of the interpolated record, in
/// the units of `sets`: the caller adds it to its own).
pub(crate) type Judged = (StateSpace, serde_json::Value, Option<OperatingPoint>);

/// The fewest measured output values of a fold's part over the
/// [`CHECK_BLOCKS`] folds (0 when a fold has no part).
fn fewest_measured(sets: &[Dataset]) -> usize {
    (0..CHECK_BLOCKS)
        .map(|k| {
            fold(sets, k).map_or(0, |(est, _)| {
                est.iter()
                    .map(|d| d.y().iter().filter(|v| v.is_finite()).count())
                    .sum()
            })
        })
        .min()
        .unwrap_or(0)
}

/// The route's `chosen` model, or the interpolated record's single-rate
/// model when the held-out blocks do not favour the route (module docs);
/// the Kalman gain is then cleared (the pipeline checks one on the
/// measured samples). `diagnostics.multirate_check` says what was done.
pub(crate) fn against_interpolation(
    opts: &WorkflowOptions,
    chosen: (StateSpace, serde_json::Value),
    sets: &[Dataset],
    kalman_gain: &mut Option<DMatrix<f64>>,
    run: FoldRun<'_>,
) -> Judged {
    let (model, mut diagnostics) = chosen;
    let samples: usize = sets.iter().map(Dataset::len).sum();
    let most = opts.budgets.refine_check_samples;
    let note = |d: &mut serde_json::Value, v: serde_json::Value| {
        if let Some(obj) = d.as_object_mut() {
            obj.insert("multirate_check".into(), v);
        }
    };
    if samples > most {
        note(
            &mut diagnostics,
            json!({
                "applied": false,
                "why": format!("{samples} samples, more than budgets.refine_check_samples = {most}"),
            }),
        );
        return (model, diagnostics, None);
    }
    // An unstable estimate (beyond the integrator tolerance) is returned
    // as identified, with the validation stage's warning: its simulation
    // on a held-out block diverges, so simulation fits judge nothing (the
    // single-rate refinement check skips such starts alike).
    let (marginal, _) = crate::integrators::tolerance(opts, sets);
    if crate::validate::spectral_radius(&model).map_or(true, |r| r >= 1.0 + marginal) {
        note(
            &mut diagnostics,
            json!({"applied": false, "why": "the route's model is unstable"}),
        );
        return (model, diagnostics, None);
    }
    // Every fold part must carry at least MEASURED_PER_PARAMETER measured
    // output values per free parameter of the route's model as the blocks
    // score it, a simulation: A and B in an observable canonical form,
    // x₀, and D when it has one.
    let (n, n_u, n_y) = (model.order(), model.n_inputs(), model.n_outputs());
    let d_free = if model.d().iter().any(|v| *v != 0.0) {
        n_u * n_y
    } else {
        0
    };
    let parameters = n * (n_u + n_y) + d_free + n;
    let fewest = fewest_measured(sets);
    if fewest < MEASURED_PER_PARAMETER * parameters {
        note(
            &mut diagnostics,
            json!({"applied": false, "why": format!("a fold's part has {fewest} measured output values, fewer than {MEASURED_PER_PARAMETER} per free parameter of the model ({parameters})")}),
        );
        return (model, diagnostics, None);
    }
    let o = fold_options(opts, model.order());
    let smooth = match sets
        .iter()
        .map(interpolated)
        .collect::<crate::Result<Vec<_>>>()
    {
        Ok(s) => s,
        Err(e) => {
            note(
                &mut diagnostics,
                json!({"applied": false, "why": format!("no interpolated record: {e}")}),
            );
            return (model, diagnostics, None);
        }
    };
    let Some((whole, whole_diagnostics)) = run(&smooth, &o, None) else {
        note(
            &mut diagnostics,
            json!({"applied": false, "why": "the single-rate route failed on the interpolated record"}),
        );
        return (model, diagnostics, None);
    };
    let (o_route, o_interp) = fold_runs(&o, &diagnostics, &whole_diagnostics);
    let floor = opts.identification.selection.failed_fold;
    let workers = crate::parallel::threads(opts).min(CHECK_BLOCKS);
    // The start the whole record's run kept, held in the folds.
    let start = Start::kept_in(&diagnostics);
    let per_fold = held_out_fits(run, sets, (&o_route, start), &o_interp, workers);
    let check = RefinementCheck {
        initial_fit: 0.0,
        refined_fit: 0.0,
        folds: per_fold.len(),
        per_fold,
        floor,
    }
    .with_floor(floor);
    let rule = &opts.refinement.check;
    let keep_route = check.decide(rule) == Some(true);
    note(
        &mut diagnostics,
        json!({
            "applied": true,
            "rule": format!(
                "{} blocks, each held out once; the multirate route (at order {}) and the single-rate route on the interpolated record fitted to the longer part of the record beside it and scored by the simulation fit on the block's measured samples (x0 estimated); the route's model kept when {} favours it, else the interpolated record's model",
                CHECK_BLOCKS,
                model.order(),
                rule.describe()
            ),
            "refined_in_folds": {
                "route": o_route.refinement.refine != Refine::None,
                "interpolated": o_interp.refinement.refine != Refine::None,
                "why": "each route refined in its folds only when the whole record's run kept its refinement",
            },
            "start_in_folds": start.map(|s| match s {
                Start::Lifted => crate::routes::multirate_start::START_LIFTED,
                Start::Interpolated => crate::routes::multirate_start::START_INTERPOLATED,
            }),
            "interpolated_fit": check.initial_fit,
            "route_fit": check.refined_fit,
            "per_fold": check.per_fold.iter().map(|(i, r)| json!({"interpolated": i, "route": r})).collect::<Vec<_>>(),
            "kept": if keep_route { KEPT_ROUTE } else { KEPT_INTERPOLATED },
        }),
    );
    if keep_route {
        return (model, diagnostics, None);
    }
    *kalman_gain = None;
    // A refinement asked for: what its warnings said of the model written
    // no longer holds; the warning says which model is written and why.
    if matches!(opts.refinement.refine, Refine::Pem | Refine::Oe) {
        if let Some(w) = diagnostics
            .get_mut("warnings")
            .and_then(|w| w.as_array_mut())
        {
            w.retain(|v| v.as_str().is_none_or(|s| !s.contains("model written")));
        }
        push_warning(
            &mut diagnostics,
            format!(
                "the multirate route's model (refined as asked) is not written: on {} held-out blocks it did not simulate better than the single-rate model of the record with its slow outputs interpolated linearly (mean held-out fits {:.1} against {:.1} %), which is written (diagnostics.multirate_check; budgets.refine_check_samples = 0 turns the check off)",
                check.folds, check.refined_fit, check.initial_fit
            ),
        );
    }
    (whole.0, diagnostics, whole.1)
}

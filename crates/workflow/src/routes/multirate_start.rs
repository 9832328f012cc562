//! A second start for multirate records: the single-rate subspace model of
//! the record with its slow outputs interpolated, refined on the measured
//! samples like the lifted route's model, the better of the two kept.
//!
//! The lifted route (lifting, causal lifted subspace identification,
//! fast-model extraction, thesis §4.5–§4.7) needs the lifted input to be
//! persistently exciting and enough frames for the lifted horizon: a record
//! whose input moves slower than the frame (a set-point held for minutes)
//! is refused ("u is not persistently exciting"), and a short record gives
//! a lifted model from which no extraction reproduces a fast model (the
//! flexible-arm record of DaISy with its output kept every third sample:
//! 171 output samples, lifted response errors near 100 %, validation fits
//! from −3000 % to 2 % after refinement). The fast model is identifiable
//! from such records all the same — the refinement (`lifted_subspace::
//! refine_pem` on the measured samples) needs only a start in the right
//! basin. A single-rate subspace identification of the record with each
//! slow output interpolated linearly between its samples gives one: it sees
//! the plant through the interpolation's low-pass, which the refinement on
//! the measured samples removes.
//!
//! Measured on twelve DaISy records (`lifted identify` with its defaults
//! on the estimation half with every output kept every third sample,
//! validation simulation fit on the full-rate second half; `benches/
//! README.md`, "A second start for multirate records"): the flexible arm
//! at order 6 went from −23.6 % to 81.1 %, the thermal wall at order 2
//! from −24.8 % to 85.1 %, the CSTR at order 3 from 78.8 % to 86.6 %, the
//! steam generator at order 6 from 65.7 % to 72.7 %, unstable models of
//! the heat exchanger and the flutter record became 50.4 % and 44.6–51.9 %,
//! and the heating rig, refused before, gives 76–86 %: 26 of 36 cells
//! rose, 4 lost (the winding rig at order 4 57.1 → 52.7, the evaporator at
//! order 3 42.0 → 40.6, the flexible arm's automatic order 0.8 → −0.0, the
//! steam generator at order 9 74.3 → 73.7).
//!
//! Rule ([`choose`]): both starts are refined with the run's refinement
//! options, and the model whose simulation fits the measured samples of
//! the records best (x₀ estimated, mean over the outputs: the refinement
//! judge's measure) is kept; `diagnostics.multirate_start` gives both fits.
//! When the lifted route fails, the interpolated route alone identifies
//! the record (with its own automatic order) and a warning names the
//! lifted route's error. Then ([`or_as_identified`]) the interpolated
//! record's model as identified — (B, D) from the interpolated record, not
//! refitted, not refined — is kept instead when it simulates the measured
//! samples better still: fitted to the measured samples alone, the refit
//! and the refinement leave the model's output between them free, and
//! with many inputs or few samples they can end farther from the samples
//! than the interpolated model (records thinned to every fifth output
//! sample, issue 46: SRU order 2, winding order 2, thermal wall order 2).
//! With the default feedthrough, models with D free compete too (the
//! interpolated record's, and the kept model's (A, C) with (B, D) refitted
//! on the measured samples), kept by the Bayesian information criterion
//! on the measured samples as `crate::routes::feedthrough` keeps D on single-rate
//! records (`benches/results/closed-loop.md`, "Multirate routes on real records
//! thinned as an analyser delivers them"). Applied to N4SID / MOESP / CVA records of inputs
//! held one sample, up to [`MULTIRATE_START_SAMPLES`] samples, without
//! `--stable`. Cost: one single-rate identification and a second
//! refinement. Every choice here is made on the measured samples the
//! candidates were fitted to; the model chosen then meets the held-out
//! check of `super::multirate_check` against the interpolated record's own
//! single-rate model.

use lifted_lti::{Dataset, OutputChannel, StateSpace, ValidationOptions, validate};
use nalgebra::DMatrix;
use serde_json::json;

use crate::error::{Error, Result};
use crate::options::{Estimator, Order, WorkflowOptions};
use crate::refine::refine;
use crate::routes::{self, RouteFit};

/// Largest record (samples over the records) given the interpolated start.
pub const MULTIRATE_START_SAMPLES: usize = 200_000;

/// `diagnostics.multirate_start.candidates[].start` of the lifted route.
pub const START_LIFTED: &str = "lifted subspace identification and fast-model extraction";
/// `… .start` of the interpolated record's model.
pub const START_INTERPOLATED: &str =
    "single-rate subspace identification of the record with its slow outputs interpolated linearly";

/// Whether the interpolated start applies to `sets` under `opts` (module
/// docs).
pub(crate) fn applies(opts: &WorkflowOptions, sets: &[Dataset]) -> bool {
    let samples: usize = sets.iter().map(Dataset::len).sum();
    opts.identification.method.is_subspace()
        && !opts.identification.stable
        && samples <= MULTIRATE_START_SAMPLES
        && sets.iter().all(|d| d.inputs().iter().all(|c| c.hold == 1))
}

/// `d` with each output interpolated linearly between its measured
/// (finite) samples and held before the first and after the last: a
/// single-rate record. Errors: an output with fewer than two samples.
/// O(N n_y).
pub(crate) fn interpolated(d: &Dataset) -> Result<Dataset> {
    let (n, ny) = (d.len(), d.n_outputs());
    let mut y = DMatrix::zeros(n, ny);
    for j in 0..ny {
        let col: Vec<f64> = d.y().column(j).iter().copied().collect();
        let Some(filled) = lifted_lti::interpolate_unmeasured(&col) else {
            return Err(Error::Data(format!(
                "output {} has {} sample(s): nothing to interpolate",
                j + 1,
                col.iter().filter(|v| v.is_finite()).count()
            )));
        };
        y.column_mut(j).copy_from_slice(&filled);
    }
    let outputs = d
        .outputs()
        .iter()
        .map(|c| {
            let mut o = OutputChannel::new(c.name.clone(), 1, 0);
            o.unit = c.unit.clone();
            o
        })
        .collect();
    Dataset::new(d.ts(), d.u().clone(), y, d.inputs().to_vec(), outputs)
        .map_err(|e| Error::Data(format!("interpolated record: {e}")))
}

/// `opts` with the multirate routes' feedthrough: D = 0 unless a
/// feedthrough is asked for. The interpolated record makes a slow output
/// between its samples an average of its neighbours, the later of which
/// the input at the same instant reaches: an estimated D takes that
/// non-causal artefact (the quick start's model got D = −0.0025 and a zero
/// at z ≈ 76 from it, which MPC refuses).
fn strictly_proper_unless_asked(opts: &WorkflowOptions) -> WorkflowOptions {
    let mut o = opts.clone();
    o.identification.feedthrough = Some(opts.identification.feedthrough == Some(true));
    o
}

/// The single-rate subspace model of the interpolated `sets` at `order`
/// (the options' automatic order when `None`), with its route's
/// diagnostics.
pub(crate) fn start(
    opts: &WorkflowOptions,
    sets: &[Dataset],
    order: Option<usize>,
) -> Result<(StateSpace, serde_json::Value)> {
    let smooth = sets.iter().map(interpolated).collect::<Result<Vec<_>>>()?;
    let mut o = strictly_proper_unless_asked(opts);
    if let Some(n) = order {
        o.identification.order = Order::Fixed(n);
    }
    let route = routes::subspace(&o, &smooth, false, None)?;
    Ok((refit_bd(route.fit.model, sets), route.diagnostics))
}

/// The single-rate subspace model of the interpolated `sets` at `order`
/// as that route identified it ((B, D) from the interpolated record, no
/// refit on the measured samples, no refinement): the third candidate of
/// [`or_as_identified`].
pub(crate) fn start_as_identified(
    opts: &WorkflowOptions,
    sets: &[Dataset],
    order: usize,
) -> Result<StateSpace> {
    let smooth = sets.iter().map(interpolated).collect::<Result<Vec<_>>>()?;
    let mut o = strictly_proper_unless_asked(opts);
    o.identification.order = Order::Fixed(order);
    Ok(routes::subspace(&o, &smooth, false, None)?.fit.model)
}

/// `chosen` (the route's model after the start choice and the
/// refinement), or the interpolated start as identified at its order
/// ([`start_as_identified`]) when that simulates the measured samples of
/// `sets` better (the same measure as [`choose`]); the Kalman gain is
/// then cleared (the pipeline checks one for the model kept).
/// `diagnostics.multirate_start.as_identified` gives both fits.
///
/// Why a third candidate: the refit of (B, D) on the measured samples and
/// the prediction-error refinement both fit the measured samples alone,
/// which leaves the model's output between them free; with many inputs
/// or few measured samples both can end farther from those samples in
/// simulation than the interpolated record's own model, which the
/// interpolation holds to a linear course between them. Measured on
/// records thinned to every fifth output sample
/// (`benches/peers/thinned.py`): in-sample simulation fits 39.4 against
/// 17.9 (SRU, order 2), 72.2 against 58.0 (winding, order 2), 80.5
/// against 67.3 (thermal wall, order 2), the validation halves agreeing.
pub(crate) fn or_as_identified(
    opts: &WorkflowOptions,
    chosen: (StateSpace, serde_json::Value),
    sets: &[Dataset],
    kalman_gain: &mut Option<DMatrix<f64>>,
) -> (StateSpace, serde_json::Value) {
    let (model, mut diagnostics) = chosen;
    let order = model.order();
    // Two structures of the interpolated record's identification: the one
    // its held-out selection chooses (scored on interpolated samples) and
    // the fixed one of the quick start (horizon 10, shift invariance); the
    // better on the measured samples competes.
    let selected = start_as_identified(opts, sets, order).ok();
    let fixed = match sets {
        [d] => quick_as_identified(opts, d, order).ok(),
        _ => None,
    };
    // With the default feedthrough, also the interpolated record's model
    // with D free: a response within the sample (a plant fast against the
    // sample period, or an order too low for its fast modes) is a
    // feedthrough the measured samples can support.
    let with_d = (opts.identification.feedthrough.is_none())
        .then(|| {
            let mut o = opts.clone();
            o.identification.feedthrough = Some(true);
            start_as_identified(&o, sets, order).ok()
        })
        .flatten();
    // And the chosen model's (A, C) with (B, D) fitted on the measured
    // samples with D free: the interpolation biases an estimated D (the
    // interpolated output between two samples averages them), the
    // regression on the measured samples does not.
    let refit_d = (opts.identification.feedthrough.is_none())
        .then(|| refit_bd_with(model.clone(), sets, lifted_subspace::Feedthrough::Free));
    let mut alt: Option<StateSpace> = None;
    for m in [selected, fixed, with_d, refit_d].into_iter().flatten() {
        alt = match alt {
            Some(a) if !better_by_bic(&m, &a, sets) => Some(a),
            _ => Some(m),
        };
    }
    let Some(alt) = alt else {
        return (model, diagnostics);
    };
    let (f_chosen, f_alt) = (records_fit(&model, sets), records_fit(&alt, sets));
    let take = better_by_bic(&alt, &model, sets);
    let entry = json!({
        "rule": "the interpolated record's model as identified (no refit, no refinement; the structure its held-out selection chooses or the quick start's, and with the default feedthrough also with D free), or with the default feedthrough the chosen model's (A, C) with (B, D) fitted on the measured samples with D free, is kept when it simulates the measured samples better than the model chosen above (x0 estimated), by the Bayesian information criterion when it has more feedthrough entries: N sum_j ln(V_chosen,j / V_j) > (extra entries of D) ln N over the N measured samples",
        "fit": f_alt,
        "fit_of_chosen": f_chosen,
        "feedthrough": alt.d().iter().any(|v| *v != 0.0),
        "kept": take,
    });
    if let Some(obj) = diagnostics.as_object_mut() {
        match obj
            .get_mut("multirate_start")
            .and_then(|m| m.as_object_mut())
        {
            Some(m) => {
                m.insert("as_identified".into(), entry);
            }
            None => {
                obj.insert("multirate_start".into(), json!({"as_identified": entry}));
            }
        }
        if take {
            obj.insert(
                "refinement_decision".into(),
                json!("not refined: the interpolated record's model as identified simulates the measured samples better than the refined model (diagnostics.multirate_start.as_identified)"),
            );
        }
    }
    if take {
        *kalman_gain = None;
        (alt, diagnostics)
    } else {
        (model, diagnostics)
    }
}

/// `model`'s (A, C) with (B, D) fitted again on the measured samples of
/// `sets` by output-error least squares (`lifted_subspace::estimate_bd`,
/// x₀ estimated; D zero when the model's is): the interpolation biases
/// (B, D) more than the poles (it filters the output by a short
/// non-causal FIR, which has no poles of its own). The model as it was
/// when the regression fails.
fn refit_bd(model: StateSpace, sets: &[Dataset]) -> StateSpace {
    let feedthrough = if model.d().iter().all(|v| *v == 0.0) {
        lifted_subspace::Feedthrough::Zero
    } else {
        lifted_subspace::Feedthrough::Free
    };
    refit_bd_with(model, sets, feedthrough)
}

/// [`refit_bd`] with the given feedthrough structure.
fn refit_bd_with(
    model: StateSpace,
    sets: &[Dataset],
    feedthrough: lifted_subspace::Feedthrough,
) -> StateSpace {
    let records = crate::refine::records_of(sets);
    let refit = lifted_subspace::estimate_bd(
        model.a(),
        model.c(),
        &records,
        &feedthrough,
        lifted_subspace::InitialState::Estimate,
    );
    match refit {
        Ok(f) => StateSpace::new(model.a().clone(), f.b, model.c().clone(), f.d, model.ts())
            .unwrap_or(model),
        Err(_) => model,
    }
}

/// The interpolated start of `d` at order `n` without the structure
/// selection (the options' horizon or 10, shortened to the longest the
/// record supports; shift invariance): the second candidate at each order
/// of the multirate route's held-out order curve.
pub(crate) fn quick_start(opts: &WorkflowOptions, d: &Dataset, n: usize) -> Result<StateSpace> {
    let model = quick_as_identified(opts, d, n)?;
    Ok(refit_bd(model, std::slice::from_ref(d)))
}

/// Whether `a` simulates the measured samples of `sets` better than `b`
/// (x₀ estimated): with N the measured samples over the records and
/// outputs and V_j each output's mean squared simulation error,
/// Δ = N/n_y Σ_j ln(V_b,j / V_a,j) must exceed k ln(N/n_y), k the entries
/// of D that `a` has free beyond `b`'s (the Bayesian information
/// criterion of `crate::routes::feedthrough`; k = 0: the better fit). `false`
/// when `a` does not simulate; `true` when only `a` does.
fn better_by_bic(a: &StateSpace, b: &StateSpace, sets: &[Dataset]) -> bool {
    let opts = ValidationOptions {
        lags: 1,
        horizons: Vec::new(),
        ..Default::default()
    };
    let errors = |m: &StateSpace| -> Option<(Vec<f64>, usize)> {
        let mut logs = vec![0.0; m.n_outputs()];
        let mut count = 0;
        for d in sets {
            let v = validate(m, d, &opts).ok()?;
            for (j, o) in v.outputs.iter().enumerate() {
                let r = 1.0 - o.fit / 100.0;
                if !(r.is_finite() && r > 0.0) {
                    return None;
                }
                // ln V_j up to a constant, weighted by the samples.
                logs[j] += 2.0 * r.ln() * o.samples as f64;
                count += o.samples;
            }
        }
        Some((logs, count))
    };
    let Some((la, n)) = errors(a) else {
        return false;
    };
    let Some((lb, _)) = errors(b) else {
        return true;
    };
    let free = |m: &StateSpace| m.d().iter().filter(|v| **v != 0.0).count();
    let k = free(a).saturating_sub(free(b)) as f64;
    let per_output = (n as f64 / a.n_outputs().max(1) as f64).max(1.0);
    let delta: f64 = lb.iter().zip(&la).map(|(x, y)| x - y).sum();
    delta > k * per_output.ln()
}

/// [`quick_start`] without the (B, D) refit: the interpolated record's
/// model at order `n`, horizon the options' or 10 (shortened to what the
/// record supports), shift invariance.
fn quick_as_identified(opts: &WorkflowOptions, d: &Dataset, n: usize) -> Result<StateSpace> {
    let smooth = interpolated(d)?;
    let mut o = strictly_proper_unless_asked(opts);
    o.identification.order = Order::Fixed(n);
    let h = opts.identification.horizon.unwrap_or(10);
    let width = d.n_inputs() + d.n_outputs();
    o.identification.horizon =
        Some(lifted_subspace::longest_horizon(&[d.len()], width, h).unwrap_or(2));
    o.identification.estimator = Estimator::Shift;
    Ok(routes::subspace(&o, &[smooth], false, None)?.fit.model)
}

/// Of the lifted route's model and the interpolated start at one order,
/// the one that fits the measured samples of `d` better (simulation, x₀
/// estimated); either alone when the other is missing or does not
/// simulate.
pub(crate) fn better(
    lifted: Option<StateSpace>,
    interp: Option<StateSpace>,
    d: &Dataset,
) -> Option<StateSpace> {
    let sets = std::slice::from_ref(d);
    let score = |m: &Option<StateSpace>| m.as_ref().and_then(|m| records_fit(m, sets));
    match (score(&lifted), score(&interp)) {
        (Some(a), Some(b)) if b > a => interp,
        (None, Some(_)) => interp,
        (None, None) if lifted.is_none() => interp,
        _ => lifted,
    }
}

/// The route's fit when the lifted route failed with `lifted_error`: the
/// interpolated record's model (at `order`, else its own order
/// selection), with a warning.
pub(crate) fn instead_of_lifted(
    opts: &WorkflowOptions,
    sets: &[Dataset],
    lifted_error: &Error,
    order: Option<usize>,
) -> Result<RouteFit> {
    let (model, d) = start(opts, sets, order)?;
    Ok(interpolated_route(model, d, lifted_error))
}

/// [`instead_of_lifted`]'s fit from the interpolated start already made
/// ([`start`]'s model and diagnostics).
pub(crate) fn interpolated_route(
    model: StateSpace,
    mut d: serde_json::Value,
    lifted_error: &Error,
) -> RouteFit {
    if let Some(obj) = d.as_object_mut() {
        obj.insert(
            "route".into(),
            json!(format!(
                "multirate: {START_INTERPOLATED}, then refined on the measured samples when the refinement runs (the lifted route failed)"
            )),
        );
        obj.insert(
            "multirate_start".into(),
            json!({"kept": START_INTERPOLATED, "lifted_error": lifted_error.to_string()}),
        );
    }
    crate::diagnostics::push_warning(
        &mut d,
        format!(
            "the lifted multirate route failed ({lifted_error}); the model starts from the single-rate subspace model of the record with its slow outputs interpolated, refined on the measured samples when the refinement runs (diagnostics.refinement_decision)"
        ),
    );
    let order = model.order();
    RouteFit::plain(model, d, &[], order)
}

/// Mean over the records and outputs of the simulation fit on the measured
/// samples (x₀ estimated); `None` when it is not finite (an unstable or
/// failed model).
fn records_fit(model: &StateSpace, sets: &[Dataset]) -> Option<f64> {
    records_fit_from(model, None, sets)
}

/// [`records_fit`] of a model deviating from `operating_point` (the
/// records in absolute units).
pub(crate) fn records_fit_from(
    model: &StateSpace,
    operating_point: Option<lifted_lti::OperatingPoint>,
    sets: &[Dataset],
) -> Option<f64> {
    // The simulation fit only: no k-step predictions, one residual lag.
    let opts = ValidationOptions {
        lags: 1,
        horizons: Vec::new(),
        operating_point,
        ..Default::default()
    };
    let mut total = 0.0;
    let mut count = 0;
    for d in sets {
        let v = validate(model, d, &opts).ok()?;
        for o in &v.outputs {
            total += o.fit;
            count += 1;
        }
    }
    let fit = total / count.max(1) as f64;
    fit.is_finite().then_some(fit)
}

/// The start a run of the route takes (`diagnostics.multirate_start.kept`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Start {
    /// The lifted route's model ([`START_LIFTED`]).
    Lifted,
    /// The interpolated record's model ([`START_INTERPOLATED`]).
    Interpolated,
}

impl Start {
    /// The start a run kept, from its diagnostics; `None` when it compared
    /// none (no second start, or the lifted route failed).
    pub(crate) fn kept_in(diagnostics: &serde_json::Value) -> Option<Start> {
        match diagnostics["multirate_start"]["kept"].as_str() {
            Some(START_LIFTED) => Some(Start::Lifted),
            Some(START_INTERPOLATED) => Some(Start::Interpolated),
            _ => None,
        }
    }
}

/// Refines the lifted route's `model` and the interpolated start `alt`
/// alike ([`refine`]) and keeps the one whose model fits the measured
/// samples of `sets` best (module docs); `diagnostics.multirate_start`
/// says which, with both fits. The Kalman gain is the kept run's.
///
/// `held`: the start to take without the comparison — a fold of the
/// held-out check (`super::multirate_check`) holds the whole record's
/// choice, as it holds its horizon, (A, C) estimator and refinement
/// decision; only that start is refined (half the fold's iterations).
pub(crate) fn choose(
    opts: &WorkflowOptions,
    model: StateSpace,
    diagnostics: serde_json::Value,
    sets: &[Dataset],
    kalman_gain: &mut Option<DMatrix<f64>>,
    alt: StateSpace,
    held: Option<Start>,
) -> Result<(StateSpace, serde_json::Value)> {
    let fit_of = |r: &Result<(StateSpace, serde_json::Value)>| {
        r.as_ref().ok().and_then(|(m, _)| records_fit(m, sets))
    };
    if let Some(start) = held {
        let mut gain = if start == Start::Lifted {
            kalman_gain.clone()
        } else {
            None
        };
        let (start_model, kept) = match start {
            Start::Lifted => (model.clone(), START_LIFTED),
            Start::Interpolated => (alt.clone(), START_INTERPOLATED),
        };
        // A held start whose refinement fails: the comparison below, as
        // in any run.
        if let Ok((model, mut diagnostics)) = refine(
            opts,
            start_model,
            diagnostics.clone(),
            sets,
            &mut gain,
            None,
        ) {
            *kalman_gain = gain;
            if let Some(obj) = diagnostics.as_object_mut() {
                obj.insert(
                    "multirate_start".into(),
                    json!({
                        "rule": "held: the start the whole record's run kept (a fold of the held-out check)",
                        "kept": kept,
                    }),
                );
            }
            return Ok((model, diagnostics));
        }
    }
    let mut gain_lifted = kalman_gain.clone();
    let mut gain_alt = None;
    // The two refinements are independent: on two threads when the run
    // may use them (the same models either way).
    let d_lifted = diagnostics.clone();
    let (lifted, interp) = if crate::parallel::threads(opts) >= 2 {
        std::thread::scope(|s| {
            let other = s.spawn(|| refine(opts, alt, diagnostics, sets, &mut gain_alt, None));
            let lifted = refine(opts, model, d_lifted, sets, &mut gain_lifted, None);
            let interp = other.join().unwrap_or_else(|_| {
                Err(Error::Data(
                    "the interpolated start's refinement panicked".into(),
                ))
            });
            (lifted, interp)
        })
    } else {
        (
            refine(opts, model, d_lifted, sets, &mut gain_lifted, None),
            refine(opts, alt, diagnostics, sets, &mut gain_alt, None),
        )
    };
    let (f_lifted, f_interp) = (fit_of(&lifted), fit_of(&interp));
    let take_interp = match (f_lifted, f_interp) {
        (Some(a), Some(b)) => b > a,
        (None, Some(_)) => true,
        _ => false,
    };
    let summary = json!({
        "rule": "both starts refined alike on the measured samples; the model with the better simulation fit on them (x0 estimated, mean over the outputs) is kept",
        "candidates": [
            {"start": START_LIFTED, "fit": f_lifted},
            {"start": START_INTERPOLATED, "fit": f_interp},
        ],
        "kept": if take_interp { START_INTERPOLATED } else { START_LIFTED },
    });
    let (kept, gain) = if take_interp {
        (interp, gain_alt)
    } else {
        (lifted, gain_lifted)
    };
    let (model, mut diagnostics) = kept?;
    *kalman_gain = gain;
    if let Some(obj) = diagnostics.as_object_mut() {
        obj.insert("multirate_start".into(), summary);
    }
    Ok((model, diagnostics))
}

#[cfg(test)]
mod tests {
    use super::*;
    use lifted_lti::InputChannel;

    #[test]
    fn the_kept_start_is_read_from_the_diagnostics() {
        let of = |kept: &str| json!({"multirate_start": {"kept": kept}});
        assert_eq!(Start::kept_in(&of(START_LIFTED)), Some(Start::Lifted));
        assert_eq!(
            Start::kept_in(&of(START_INTERPOLATED)),
            Some(Start::Interpolated)
        );
        assert_eq!(Start::kept_in(&of("something else")), None);
        assert_eq!(Start::kept_in(&json!({})), None);
    }

    #[test]
    fn slow_outputs_are_interpolated_between_their_samples() {
        let nan = f64::NAN;
        let y = DMatrix::from_row_slice(
            7,
            2,
            &[
                nan, 1.0, //
                2.0, nan, //
                nan, nan, //
                nan, 4.0, //
                8.0, nan, //
                nan, nan, //
                nan, 1.0,
            ],
        );
        let d = Dataset::new(
            1.0,
            DMatrix::from_fn(7, 1, |t, _| t as f64),
            y,
            vec![InputChannel::new("u", 1)],
            vec![OutputChannel::new("a", 3, 1), OutputChannel::new("b", 3, 0)],
        )
        .unwrap();
        let s = interpolated(&d).unwrap();
        assert!(s.is_single_rate());
        let want_a = [2.0, 2.0, 4.0, 6.0, 8.0, 8.0, 8.0];
        let want_b = [1.0, 2.0, 3.0, 4.0, 3.0, 2.0, 1.0];
        for t in 0..7 {
            assert!((s.y()[(t, 0)] - want_a[t]).abs() < 1e-12, "a at {t}");
            assert!((s.y()[(t, 1)] - want_b[t]).abs() < 1e-12, "b at {t}");
        }
        assert_eq!(s.outputs()[0].name, "a");
        // One sample: nothing to interpolate.
        let mut y1 = DMatrix::from_element(7, 1, nan);
        y1[(3, 0)] = 1.0;
        let one = Dataset::new(
            1.0,
            DMatrix::from_fn(7, 1, |t, _| t as f64),
            y1,
            vec![InputChannel::new("u", 1)],
            vec![OutputChannel::new("a", 7, 3)],
        )
        .unwrap();
        assert!(interpolated(&one).is_err());
    }
}

//! Feedback detection on the identification's records (issue 46): whether
//! the inputs depend on the model's past output innovations
//! ([`lifted_closedloop::feedback_test`]: a Granger test of each input on
//! the innovations' past given its own, χ² at 1 %). On a single-rate
//! record the innovations are the one-step errors of a VARX of order 10
//! fitted to it (`lifted_closedloop::arx_innovations`, as MATLAB's
//! `feedback` uses an ARX): a model's own errors carry what it misses of
//! the input's effect, which a coloured or periodic input turns into a
//! false alarm. On a multirate record (no VARX on the base grid) they are
//! the identified model's one-step prediction errors (with its Kalman
//! gain, K = 0 without one; outputs not measured skipped). The verdict
//! and the evidence go to `diagnostics.feedback`; an open-loop method
//! (N4SID, MOESP, CVA) on records where feedback is detected gets a
//! warning naming the methods that are consistent there. The default
//! method does not switch on it: a biased but close model is often what
//! the open-loop methods give at a high signal-to-noise ratio, and the
//! consistent routes need an instrument or a longer record; the warning
//! leaves the choice to the engineer. Cost: one predictor run O(N n²)
//! and the test's regression (`lifted_closedloop::feedback`).

use lifted_lti::{Dataset, StateSpace};
use nalgebra::DMatrix;
use serde_json::json;

use crate::diagnostics::push_warning;
use crate::options::{Method, WorkflowOptions};

/// The model-free tests of the last records ([`report`] on single-rate
/// records: the VARX innovations and the test on them depend on the record
/// and the options, not on the model), kept for a front end that
/// identifies one record many times (the studio's order slider, through
/// [`crate::SubspaceCache`]): an order identified on a record already
/// tested takes the kept outcome, the same bit for bit. Keyed by the
/// record's samples (their hash, `lifted_subspace::records_hash`), the
/// test's options and the longest output period.
#[derive(Debug, Clone, Default)]
pub(crate) struct FeedbackMemo {
    kept: Option<(String, Outcome)>,
    computed: usize,
}

/// A test's outcome: the test on the innovations, or why there is none.
type Outcome = Result<lifted_closedloop::FeedbackTest, String>;

/// How [`model_free`] knows the record it tests for its memo.
#[derive(Debug, Clone, Copy)]
enum Known {
    /// Record `index` of records whose `records_hash` the run computed.
    Among(u64, usize),
    /// By its own hash (computed here).
    Alone,
}

impl FeedbackMemo {
    /// Tests computed through this memo (a reuse computes none).
    pub(crate) fn computed(&self) -> usize {
        self.computed
    }
}

/// The test on a VARX's errors of the single-rate record `set` (the
/// records before any model's operating point was removed: the VARX's
/// constant takes any offset), or `None` when the record is multirate or
/// too short for the VARX (the model's own errors are then tested). Taken
/// from `memo` when it holds the same record and options.
fn model_free(
    fb: &lifted_closedloop::FeedbackOptions,
    set: &Dataset,
    longest: usize,
    memo: Option<(&mut FeedbackMemo, Known)>,
) -> Option<Outcome> {
    if !set.is_single_rate() {
        return None;
    }
    let run = || -> Option<Outcome> {
        let e = lifted_closedloop::arx_innovations(set.u(), set.y(), fb.arx_order, fb.max_samples)
            .ok()?;
        Some(lifted_closedloop::feedback_test(set.u(), &e, longest, fb).map_err(|e| e.to_string()))
    };
    let Some((memo, known)) = memo else {
        return run();
    };
    let records = match known {
        Known::Among(hash, index) => format!("{hash:016x}#{index}"),
        Known::Alone => {
            let exps = [lifted_subspace::Experiment {
                u: set.u(),
                y: set.y(),
            }];
            format!("{:016x}", lifted_subspace::records_hash(&exps))
        }
    };
    let key = format!("{records}|{fb:?}|{longest}");
    if let Some((k, outcome)) = &memo.kept
        && *k == key
    {
        return Some(outcome.clone());
    }
    let outcome = run();
    memo.computed += 1;
    memo.kept = outcome.clone().map(|o| (key, o));
    outcome
}

/// Runs the test and writes `diagnostics.feedback` (and the warning).
/// `before`: the records before the identification removed its operating
/// point, when it did (single-rate N4SID/MOESP/CVA; the same for every
/// order of a record), for the model-free test, with their
/// `lifted_subspace::records_hash` when the run computed it; `memo`: the
/// outcomes kept between calls ([`FeedbackMemo`]).
pub(crate) fn report(
    opts: &WorkflowOptions,
    model: &StateSpace,
    gain: Option<&DMatrix<f64>>,
    sets: &[Dataset],
    before: Option<(&[Dataset], Option<u64>)>,
    memo: Option<&mut FeedbackMemo>,
    diagnostics: &mut serde_json::Value,
) {
    let Some(set) = sets.iter().max_by_key(|d| d.len()) else {
        return;
    };
    let started = std::time::Instant::now();
    let fb = &opts.identification.feedback;
    let longest = set.outputs().iter().map(|c| c.period).max().unwrap_or(1);
    // Single-rate records: a VARX's errors (model-free); else, or when the
    // record is too short for the VARX, the model's own.
    let (free_set, known) = match before.filter(|(b, _)| b.len() == sets.len()) {
        Some((b, hash)) => match b.iter().enumerate().max_by_key(|(_, d)| d.len()) {
            Some((i, d)) => (d, hash.map_or(Known::Alone, |h| Known::Among(h, i))),
            None => (set, Known::Alone),
        },
        None => (set, Known::Alone),
    };
    let varx = model_free(fb, free_set, longest, memo.map(|m| (m, known)));
    let source = if varx.is_some() {
        format!(
            "the one-step errors of a VARX of order {} fitted to the longest record",
            fb.arx_order
        )
    } else {
        "the identified model's one-step prediction errors on its longest record".to_string()
    };
    let outcome = match varx {
        Some(outcome) => outcome,
        None => innovations(model, gain, set).and_then(|e| {
            lifted_closedloop::feedback_test(set.u(), &e, longest, fb).map_err(|e| e.to_string())
        }),
    };
    crate::diagnostics::add_phase(diagnostics, "feedback_s", started.elapsed().as_secs_f64());
    let Some(obj) = diagnostics.as_object_mut() else {
        return;
    };
    let test = match outcome {
        Ok(t) => t,
        Err(why) => {
            obj.insert(
                "feedback".into(),
                json!({ "note": format!("not tested: {why}") }),
            );
            return;
        }
    };
    obj.insert(
        "feedback".into(),
        json!({
            "detected": test.detected,
            "verdict": verdict(&test, set),
            "inputs": serde_json::to_value(&test.inputs).unwrap_or_default(),
            "lags": test.lags,
            "rows": test.rows,
            "significance": test.significance,
            "innovations": source,
            "rule": test.rule,
        }),
    );
    let method = opts.identification.method;
    if test.detected && matches!(method, Method::N4sid | Method::Moesp | Method::Cva) {
        let multirate = !set.is_single_rate();
        let consistent = if multirate {
            "--method iv --instrument with the logged set-point or excitation"
        } else {
            "--method pbsid or ssarx (no instrument needed), or --method iv --instrument with the logged set-point or excitation"
        };
        push_warning(
            diagnostics,
            format!(
                "closed loop detected ({}): {} is biased under feedback (the noise reaches the input through the controller); consistent here: {consistent}",
                verdict(&test, set),
                method.name().to_uppercase()
            ),
        );
    }
}

/// "input u1 depends on past output innovations (χ²(10) = 85.3, p = 1e-9,
/// 12 % of its variance)" for each input where feedback was detected, or
/// "no input depends on past output innovations (largest χ²(10) = 8.1,
/// p = 0.62)".
fn verdict(test: &lifted_closedloop::FeedbackTest, set: &Dataset) -> String {
    let name = |j: usize| {
        set.inputs()
            .get(j)
            .map_or_else(|| format!("u{}", j + 1), |c| c.name.clone())
    };
    let detected: Vec<String> = test
        .inputs
        .iter()
        .filter(|i| i.detected)
        .map(|i| {
            format!(
                "input {} depends on past output innovations (χ²({}) = {:.1}, p = {:.1e}, {:.1} % of its variance)",
                name(i.input),
                i.dof,
                i.statistic,
                i.p_value,
                100.0 * i.explained
            )
        })
        .collect();
    if !detected.is_empty() {
        return detected.join("; ");
    }
    match test
        .inputs
        .iter()
        .max_by(|a, b| a.statistic.total_cmp(&b.statistic))
    {
        Some(i) => format!(
            "no input depends on past output innovations at the {} % level (largest χ²({}) = {:.1}, p = {:.2})",
            100.0 * test.significance,
            i.dof,
            i.statistic,
            i.p_value
        ),
        None => "no inputs".into(),
    }
}

/// y − ŷ of the one-step predictor of `model` with `gain` (K = 0 without
/// one) on `set`, from x̂(0) = 0; NaN where an output is not measured.
fn innovations(
    model: &StateSpace,
    gain: Option<&DMatrix<f64>>,
    set: &Dataset,
) -> Result<DMatrix<f64>, String> {
    if model.ts().is_none() {
        return Err("a continuous-time model".into());
    }
    let zero = DMatrix::zeros(model.order(), model.n_outputs());
    let k = gain
        .filter(|k| k.shape() == (model.order(), model.n_outputs()))
        .unwrap_or(&zero);
    let predicted = model
        .predict_from(k, set.u(), set.y(), 1, None)
        .map_err(|e| e.to_string())?;
    Ok(set.y() - predicted)
}

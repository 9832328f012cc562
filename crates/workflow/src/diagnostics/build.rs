//! Building the diagnostics of a run: the entries every route writes (order
//! selection, subspace fit, run facts, warnings, phases), each of the form
//! of its [`super::Diagnostics`] field.

use lifted_subspace::{OrderReport, SubspaceModel, SystemEstimate};
use nalgebra::DMatrix;
use serde_json::json;

/// `diagnostics.extraction` of a multirate route: the extraction kept,
/// its consistency with the lifted model and the methods compared.
pub(crate) fn extraction_json(e: &lifted_multirate::ExtractionDiagnostics) -> serde_json::Value {
    let compared: Vec<serde_json::Value> = e
        .comparison
        .iter()
        .map(|c| {
            json!({
                "method": format!("{:?}", c.method),
                "lifted_response_error": c.lifted_response_error,
                "failure": c.failure,
            })
        })
        .collect();
    json!({
        "method": format!("{:?}", e.method),
        "input_residual": e.input_residual,
        "lifted_response_error": e.lifted_response_error,
        "comparison": compared,
        "rule": "the extraction (matrix root, controllability, eigenvalue; thesis §4.6) whose lifting reproduces the lifted model best: relative error of the Markov parameters of the outputs at frame time 0",
        "fallback": e.fallback,
    })
}

/// The order-selection entry: what the values are, the values, the order
/// used and the suggested one.
pub(crate) fn order_json(
    kind: &str,
    values: &[f64],
    order: usize,
    suggested: usize,
) -> serde_json::Value {
    serde_json::to_value(super::OrderSelection {
        kind: kind.to_string(),
        values: values.to_vec(),
        order,
        suggested_order: suggested,
        rest: Default::default(),
    })
    .unwrap_or_default()
}

/// Name of an (A, C) route in the diagnostics.
pub(crate) fn system_name(s: SystemEstimate) -> &'static str {
    match s {
        SystemEstimate::ShiftInvariance => "shift invariance",
        SystemEstimate::StateSequence => "state sequences",
    }
}

/// The order-selection rule's values per order (orders 1, 2, …) and choice.
pub(crate) fn criterion_json(r: &OrderReport) -> serde_json::Value {
    let values: Vec<Option<f64>> = r
        .values
        .iter()
        .map(|v| v.is_finite().then_some(*v))
        .collect();
    serde_json::to_value(super::OrderCriterion {
        criterion: format!("{:?}", r.criterion),
        values,
        selected: r.selected,
        rule: None,
        rest: Default::default(),
    })
    .unwrap_or_default()
}

/// `order_criterion` of a model whose order the held-out selection chose
/// (`structure_selection` with its order and candidates): the rule, the
/// order chosen and the best held-out fit of each order, instead of the
/// criterion of the subspace step's refit at that order (it read
/// `{"criterion": "Gap", "selected": 1}` beside a chosen order 6).
pub(crate) fn criterion_from_selection(d: &mut serde_json::Value) {
    let Some(sel) = d.get("structure_selection") else {
        return;
    };
    let (Some(order), Some(cands)) = (
        sel.get("order").and_then(serde_json::Value::as_u64),
        sel.get("candidates").and_then(serde_json::Value::as_array),
    ) else {
        return;
    };
    let top = cands
        .iter()
        .filter_map(|c| c.get("order").and_then(serde_json::Value::as_u64))
        .max()
        .unwrap_or(order);
    let values: Vec<Option<f64>> = (1..=top)
        .map(|n| {
            cands
                .iter()
                .filter(|c| c.get("order").and_then(serde_json::Value::as_u64) == Some(n))
                .filter_map(|c| c.get("fit").and_then(serde_json::Value::as_f64))
                .fold(None, |m: Option<f64>, f| Some(m.map_or(f, |m| m.max(f))))
        })
        .collect();
    if let Some(obj) = d.as_object_mut() {
        obj.insert(
            "order_criterion".into(),
            json!({
                "criterion": "Validation",
                "selected": order,
                "values": values,
                "rule": "held-out simulation fit (%) of the best structure of each order; diagnostics.structure_selection has the candidates",
            }),
        );
    }
}

/// Rows of a matrix (JSON arrays).
pub(crate) fn rows(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect()
}

/// Diagnostics of a subspace fit: horizons, order selection, compression
/// used and the per-phase times (under "phases", merged into "profile" by
/// [`add_run_facts`]).
pub(crate) fn subspace_json(fit: &SubspaceModel, route: &str) -> serde_json::Value {
    let dg = &fit.diagnostics;
    json!({
        "route": route,
        "bd_route": dg.bd_route.name(),
        "fallbacks": dg.fallbacks,
        "stabilized": dg.stabilized,
        "horizons": [dg.horizons.0, dg.horizons.1],
        "hankel_columns": dg.columns,
        "kalman_gain": fit.kalman_gain.as_ref().map(rows),
        "order_selection": order_json("singular values of W1 Φ W2", &dg.singular_values, dg.order, dg.suggested_order),
        "order_criterion": criterion_json(&dg.order_selection),
        "compression": {
            "used": format!("{:?}", dg.compression.used),
            "rcond": dg.compression.rcond,
            "fallback": dg.compression.fallback,
        },
        "phases": {
            "compress_s": dg.profile.compress_s,
            "svd_s": dg.profile.svd_s,
            "estimate_s": dg.profile.estimate_s,
        },
    })
}

/// The diagnostics entry of a PBSID identification.
pub(crate) fn pbsid_json(fit: &lifted_subspace::PbsidModel) -> serde_json::Value {
    let dg = &fit.diagnostics;
    json!({
        "route": format!("single-rate predictor-based subspace identification ({})", dg.variant.name()),
        "horizons": [dg.horizons.0, dg.horizons.1],
        "past_selection": dg.past_selection.iter().map(|(p, v)| json!({"past": p, "aic": v})).collect::<Vec<_>>(),
        "hankel_columns": dg.columns,
        "kalman_gain": rows(&fit.kalman_gain),
        "innovation_covariance": rows(&fit.innovation_covariance),
        "predictor_spectral_radius": dg.predictor_spectral_radius,
        "order_selection": order_json("singular values of the predictor-based Γ_f K_p", &dg.singular_values, dg.order, dg.suggested_order),
        "compression": {
            "used": format!("{:?}", dg.compression.used),
            "rcond": dg.compression.rcond,
            "fallback": dg.compression.fallback,
        },
        "notes": dg.notes,
    })
}

/// Adds the facts of the run to the diagnostics: sample count, base
/// period, output periods, and the wall time per phase under "profile":
/// reading the data (`read_s`, when the workflow read them itself), the
/// whole identification, and a method's own phases (moved there from
/// "phases"). The caller adds what only it knows (the CLI: the data files
/// and its reading time).
pub(crate) fn add_run_facts(
    diagnostics: &mut serde_json::Value,
    samples: usize,
    ts: f64,
    output_periods: &[usize],
    read_s: Option<f64>,
    identify_s: f64,
) {
    let Some(obj) = diagnostics.as_object_mut() else {
        return;
    };
    let mut profile = json!({ "identify_s": identify_s });
    if let (Some(p), Some(r)) = (profile.as_object_mut(), read_s) {
        p.insert("read_s".into(), json!(r));
    }
    if let (Some(p), Some(phases)) = (profile.as_object_mut(), obj.remove("phases"))
        && let Some(ph) = phases.as_object()
    {
        for (k, v) in ph {
            p.insert(k.clone(), v.clone());
        }
    }
    obj.insert("profile".into(), profile);
    obj.insert("samples".into(), json!(samples));
    obj.insert("base_period".into(), json!(ts));
    obj.insert("output_periods".into(), json!(output_periods));
}

/// Records the options the run was given (`diagnostics.options`: the
/// serialised [`crate::WorkflowOptions`], `null` where a default is
/// resolved by the route, which the route's own entries then report), the
/// work budgets (`diagnostics.budgets`: [`crate::Budgets`] with the
/// Kalman-gain check's two) and
/// the selection policy an automatic order was picked by
/// (`diagnostics.selection_policy`: [`crate::SelectionOptions`]; nothing
/// when the order was given): the configuration that made a model, as
/// data.
pub(crate) fn add_selection_policy(
    diagnostics: &mut serde_json::Value,
    opts: &crate::WorkflowOptions,
) {
    let Some(obj) = diagnostics.as_object_mut() else {
        return;
    };
    if let Ok(o) = serde_json::to_value(opts) {
        obj.insert("options".into(), o);
    }
    obj.insert(
        "budgets".into(),
        serde_json::to_value(super::BudgetsUsed::of(
            &opts.budgets,
            &opts.identification.gain_check,
        ))
        .unwrap_or_default(),
    );
    if opts.identification.order == crate::Order::Auto {
        obj.insert(
            "selection_policy".into(),
            serde_json::to_value(opts.identification.selection).unwrap_or_default(),
        );
    }
}

/// Adds `secs` to the wall time of the phase `key` (seconds) in the
/// diagnostics' `phases`, which [`add_run_facts`] merges into `profile`;
/// a phase timed twice (the gain check of a multirate model) accumulates.
pub(crate) fn add_phase(diagnostics: &mut serde_json::Value, key: &str, secs: f64) {
    let Some(obj) = diagnostics.as_object_mut() else {
        return;
    };
    let phases = obj.entry("phases").or_insert_with(|| json!({}));
    if let Some(ph) = phases.as_object_mut() {
        let before = ph.get(key).and_then(|v| v.as_f64()).unwrap_or(0.0);
        ph.insert(key.into(), json!(before + secs));
    }
}

/// Appends a warning to the diagnostics' `warnings` list.
pub(crate) fn push_warning(diagnostics: &mut serde_json::Value, warning: String) {
    if let Some(obj) = diagnostics.as_object_mut() {
        let warnings = obj.entry("warnings").or_insert_with(|| json!([]));
        if let Some(w) = warnings.as_array_mut() {
            w.push(json!(warning));
        }
    }
}

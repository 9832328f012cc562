//! Order selection: held-out blocks, AICc on short records, horizons the records
//! support, unstable choices giving way to the next stable order, capped searches, the
//! predictor-based and IV routes' choices, the polynomial methods' order scan.

use crate::common::*;
use lifted_lti::StateSpace;
use lifted_workflow::{
    Error, Estimator, Method, Order, OrderCriterion, Record, Refine, WorkflowOptions, identify,
};
use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[test]
fn orders_beyond_the_horizon_are_said_in_its_terms() {
    // A fixed order the default horizons cannot reach was "model order 50
    // invalid: it must lie in 1..=9"; an automatic search bound above what
    // the horizons identify was lowered without a word. One output: the
    // longest default horizon, 30, identifies orders up to 29.
    let (u, y) = siso_record(2000, 0.05, 7);
    let rec = [Record::new(dataset(&u, &y))];
    let mut o = WorkflowOptions::default();
    o.identification.order = Order::Fixed(50);
    o.refinement.refine = Refine::None;
    let e = identify(&rec, &o).expect_err("order 50").to_string();
    assert!(e.contains("--horizon 51 or more"), "{e}");
    o.identification.order = Order::Auto;
    o.identification.max_order = 100;
    let d = identify(&rec, &o).expect("identify").file.diagnostics;
    assert!(
        d["warnings"].as_array().is_some_and(|w| w
            .iter()
            .any(|m| m.as_str().is_some_and(|m| m.contains("instead of 1..=100")))),
        "{d}"
    );
}

#[test]
fn an_order_search_beyond_the_data_is_capped_with_a_warning() {
    // 60 samples of a 2×2 record, horizon 3: AIC needs K(n) + 1 < N with
    // K(n) = n(n_y + n_u) + 4 (D) + n (x₀) = 5n + 4, so at most order 10
    // would need 55 < 60 — but the horizon identifies at most
    // (f − 1) n_y = 4 states: the default search bound 10 is capped to 4.
    let (u, y) = record(60, 0.1, 9);
    let records = [Record::new(dataset(&u, &y))];
    let mut opts = WorkflowOptions::default();
    opts.identification.order_criterion = OrderCriterion::Aic;
    opts.identification.horizon = Some(3);
    opts.refinement.refine = Refine::None;
    let fit = identify(&records, &opts).expect("capped search");
    let warnings = fit.file.diagnostics["warnings"].to_string();
    assert!(
        warnings.contains("searched 1..=4 instead of 1..=10"),
        "{warnings}"
    );
    assert!((1..=4).contains(&fit.order), "{}", fit.order);
    // A fixed order beyond the data stays an error naming the limit.
    opts.identification.order = Order::Fixed(6);
    let err = identify(&records, &opts).unwrap_err().to_string();
    assert!(err.contains("1..=4"), "{err}");
}

#[test]
fn an_automatic_order_is_judged_by_its_refined_models() {
    // A short noisy record (refined by default, held-out check): the best
    // orders of the selection are scored by the held-out fit of the model
    // each would deliver, and the order chosen follows the rule.
    let (u, y) = record(1500, 0.3, 11);
    let records = [Record::new(dataset(&u, &y))];
    let fit = identify(&records, &WorkflowOptions::default()).expect("identify");
    let d = &fit.file.diagnostics;
    let sel = &d["structure_selection"];
    let short = &sel["refined_shortlist"];
    let rows = short["candidates"].as_array().expect("shortlist");
    assert!(rows.len() >= 2, "{short}");
    let orders: Vec<u64> = rows.iter().map(|r| r["order"].as_u64().unwrap()).collect();
    let mut distinct = orders.clone();
    distinct.dedup();
    distinct.sort_unstable();
    distinct.dedup();
    assert_eq!(
        distinct.len(),
        orders.len(),
        "one structure per order: {short}"
    );
    // The smallest order within the selection's tolerance (0.5 points) of
    // the best score.
    let score = |r: &serde_json::Value| r["score"].as_f64().unwrap();
    let best = rows.iter().map(score).fold(f64::NEG_INFINITY, f64::max);
    let want = rows
        .iter()
        .filter(|r| score(r) >= best - 0.5)
        .map(|r| r["order"].as_u64().unwrap())
        .min()
        .unwrap();
    assert_eq!(short["order"].as_u64(), Some(want), "{short}");
    assert_eq!(fit.order as u64, want);
    assert_eq!(sel["order"].as_u64(), Some(want));
    // The chosen order's check judged its refinement (not computed again).
    let chosen = rows
        .iter()
        .find(|r| r["order"].as_u64() == Some(want))
        .unwrap();
    let held = &d["refinement_judge"]["held_out"];
    assert_eq!(held["initial_fit"], chosen["held_out_subspace"], "{d}");
    assert_eq!(held["refined_fit"], chosen["held_out_refined"], "{d}");

    // The same structure given: the check computed afresh gives the same
    // numbers and the same model, bit for bit.
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(want as usize);
    opts.identification.horizon = Some(chosen["horizon"].as_u64().unwrap() as usize);
    opts.identification.estimator = match chosen["system"].as_str().unwrap() {
        "shift invariance" => Estimator::Shift,
        _ => Estimator::States,
    };
    let again = identify(&records, &opts).expect("fixed structure");
    let d2 = &again.file.diagnostics;
    assert!(d2.get("structure_selection").is_none(), "{d2}");
    assert_eq!(d2["refinement_judge"]["held_out"], *held);
    assert_eq!(again.file.model.a(), fit.file.model.a());
    assert_eq!(again.file.model.b(), fit.file.model.b());

    // No refinement: the selection's order stands, no shortlist.
    let mut opts = WorkflowOptions::default();
    opts.refinement.refine = Refine::None;
    let plain = identify(&records, &opts).expect("no refinement");
    let sel = &plain.file.diagnostics["structure_selection"];
    assert!(sel.get("refined_shortlist").is_none(), "{sel}");
    assert_eq!(sel["order"].as_u64(), Some(plain.order as u64));
}

/// The held-out folds' refinements of the judge stop at
/// `RefinementOptions::judge_iterations` (default 20, MATLAB's `ssest`
/// limit), recorded in the shortlist and the judge; the delivered model's
/// refinement keeps its own limit. On the noisy 2×2 record of the test
/// above the order and the model are the same with the judge at 20 and at
/// 100 iterations (as on the 17 real records of `benches/peers/
/// judge_iterations.py`); one iteration scores the candidates
/// differently: the cap is applied.
#[test]
fn the_judges_fold_refinements_stop_at_their_iteration_limit() {
    let (u, y) = record(1500, 0.3, 11);
    let records = [Record::new(dataset(&u, &y))];
    let run = |judge: usize| {
        let mut o = WorkflowOptions::default();
        o.refinement.judge_iterations = judge;
        identify(&records, &o).expect("identify")
    };
    let (default, long, one) = (
        identify(&records, &WorkflowOptions::default()).expect("identify"),
        run(100),
        run(1),
    );
    let short = |f: &lifted_workflow::Identified| {
        f.file.diagnostics["structure_selection"]["refined_shortlist"].clone()
    };
    assert_eq!(short(&default)["fold_iterations"], 20);
    assert_eq!(short(&long)["fold_iterations"], 100);
    assert_eq!(
        default.file.diagnostics["refinement_judge"]["fold_iterations"],
        20
    );
    assert_eq!(default.order, long.order);
    assert_eq!(default.file.model.a(), long.file.model.a());
    assert_eq!(default.file.model.c(), long.file.model.c());
    let scores = |f: &lifted_workflow::Identified| -> Vec<f64> {
        short(f)["candidates"]
            .as_array()
            .expect("shortlist")
            .iter()
            .map(|r| r["held_out_refined"].as_f64().unwrap())
            .collect()
    };
    assert_ne!(scores(&one), scores(&long), "{}", short(&one));
}

#[test]
fn a_record_too_short_for_held_out_blocks_gets_its_order_by_aicc() {
    // 60 samples at horizon 5: no fold of six blocks has the Hankel
    // columns the horizon needs, so no structure is selected on held-out
    // blocks; the automatic order is then the AICc minimiser on the
    // output-error fits of the whole record (not the singular-value gap).
    let (u, y) = record(60, 0.02, 3);
    let records = [Record::new(dataset(&u, &y))];
    let mut opts = WorkflowOptions::default();
    opts.identification.horizon = Some(5);
    let fit = identify(&records, &opts).expect("identify");
    let d = &fit.file.diagnostics;
    let why = d["structure_selection"]["error"]
        .as_str()
        .expect("no selection");
    assert!(why.contains("AICc"), "{why}");
    let crit = &d["order_criterion"];
    assert_eq!(crit["criterion"], "Aicc", "{crit}");
    let values: Vec<f64> = crit["values"]
        .as_array()
        .expect("values")
        .iter()
        .map(|v| v.as_f64().unwrap_or(f64::INFINITY))
        .collect();
    let argmin = 1
        + (0..values.len())
            .min_by(|&a, &b| values[a].total_cmp(&values[b]))
            .expect("orders");
    assert_eq!(fit.order, argmin, "{crit}");
    // The plant's order at this noise level (σ = 0.02 on unit outputs).
    assert_eq!(fit.order, 3, "{crit}");
}

#[test]
fn a_record_too_short_for_the_default_horizon_gets_one_it_supports() {
    // 45 samples of 6 inputs (the plant's 2 and 4 it does not respond to)
    // and 2 outputs: horizon 10 needs 179 samples (J ≥ k Hankel columns)
    // and no fold of six blocks has the columns of horizon 2, so neither
    // the default nor the held-out selection applies. The horizon is then
    // chosen by AICc among those the record supports (here only 2) instead
    // of refusing the record, for an automatic and a fixed order alike.
    // Before, both were refused: "horizons past 10 + future 10 too long
    // for 45 samples".
    let (u2, y) = record(45, 0.02, 5);
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    let u = DMatrix::from_fn(45, 6, |i, j| {
        if j < 2 {
            u2[(i, j)]
        } else if rng.random::<f64>() < 0.5 {
            -1.0
        } else {
            1.0
        }
    });
    let records = [Record::new(dataset(&u, &y))];
    for order in [Order::Auto, Order::Fixed(2)] {
        let mut opts = WorkflowOptions::default();
        opts.identification.order = order;
        let fit = identify(&records, &opts).expect("identify");
        let d = &fit.file.diagnostics;
        assert_eq!(d["horizons"], serde_json::json!([2, 2]), "{order:?}");
        let why = d["structure_selection"]["error"]
            .as_str()
            .expect("no selection");
        assert!(
            why.contains("the default horizon 10 is too long for these records: horizon 2"),
            "{why}"
        );
        if order == Order::Fixed(2) {
            // (order 3 needs horizon 3: n ≤ 2 at s = 2 with 2 outputs)
            assert_eq!(fit.order, 2);
        }
        // A horizon given by the caller is kept: refused when too long.
        opts.identification.horizon = Some(10);
        let e = identify(&records, &opts).expect_err("horizon 10 on 45 samples");
        assert!(e.to_string().contains("179"), "{e}");
    }
    // Another order rule (no held-out selection): the longest horizon the
    // record supports, with a warning.
    let mut opts = WorkflowOptions::default();
    opts.identification.order_criterion = OrderCriterion::Aicc;
    let fit = identify(&records, &opts).expect("identify");
    let d = &fit.file.diagnostics;
    assert_eq!(d["horizons"], serde_json::json!([2, 2]));
    assert!(
        d["warnings"]
            .to_string()
            .contains("the default horizon 10 is too long"),
        "{d}"
    );
    // Too short for any horizon: the error names the smallest one and the
    // samples it needs (2 s (n_u + n_y) + 2 s − 1 = 35), not horizon 10's.
    let (u, y) = (u.rows(0, 30).into_owned(), y.rows(0, 30).into_owned());
    let records = [Record::new(dataset(&u, &y))];
    for criterion in [OrderCriterion::Validation, OrderCriterion::Aicc] {
        let mut opts = WorkflowOptions::default();
        opts.identification.order_criterion = criterion;
        let e = identify(&records, &opts).expect_err("30 samples");
        assert!(
            e.to_string().contains("past 2 + future 2")
                && e.to_string().contains("at least 35 samples"),
            "{e}"
        );
    }
    // A fixed order names the shortest horizon that identifies it (order
    // 3 with 2 outputs: horizon 3, 2·3·8 + 5 = 53 samples), not an order
    // bound of horizon 2.
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(3);
    let e = identify(&records, &opts).expect_err("30 samples, order 3");
    assert!(
        e.to_string().contains("past 3 + future 3") && e.to_string().contains("at least 53"),
        "{e}"
    );
}

#[test]
fn an_unstable_aicc_choice_gives_way_to_the_next_stable_order() {
    // The plant with its slow pole at 0.98, 50 samples, horizon 5: no
    // held-out block fits, AICc ranks order 2 first, but its model has
    // ρ(A) = 1.02; the next of the ranking, order 3 (the plant's), is
    // stable and kept, and the diagnostics say what was passed over.
    // (Before, the unstable order-2 model was returned.)
    let a = DMatrix::from_row_slice(3, 3, &[0.98, 0.0, 0.0, 0.0, 0.7, -0.3, 0.0, 0.3, 0.7]);
    let g = plant();
    let g =
        StateSpace::new(a, g.b().clone(), g.c().clone(), g.d().clone(), Some(1.0)).expect("plant");
    let (u, y) = record_of(&g, 50, 0.1, 7, [0.0, 0.0]);
    let records = [Record::new(dataset(&u, &y))];
    let mut opts = WorkflowOptions::default();
    opts.identification.horizon = Some(5);
    let fit = identify(&records, &opts).expect("identify");
    let d = &fit.file.diagnostics;
    let why = d["structure_selection"]["error"]
        .as_str()
        .expect("no selection");
    assert!(why.contains("passed over"), "{why}");
    assert_eq!(fit.order, 3, "{why}");
    assert!(
        d["stability"]["stable"].as_bool().expect("stability"),
        "{d}"
    );
    // The AICc curve stays in the diagnostics, its minimiser order 2.
    assert_eq!(d["order_criterion"]["criterion"], "Aicc", "{d}");
    assert_eq!(d["order_criterion"]["selected"], 2, "{d}");
}

#[test]
fn the_predictor_based_routes_choose_their_order_on_held_out_blocks() {
    // The singular-value gap, PBSID's own rule, chose order 1 here
    // (simulation fit 75.1 % on a fresh record); the held-out fit chooses
    // order 3 (95.7 %), as on real records where the gap chose order 1 on
    // 9 of 17 (benches/results/real-records.md). (SSARX's gap finds 3 on this record.)
    // Row-wise PBSID (whose Python route took the gap before it became a
    // workflow method) likewise.
    let (u, y) = distributed_record(2000, 3);
    let (uv, yv) = distributed_record(2000, 2);
    let rec = [Record::new(dataset(&u, &y))];
    let fresh = dataset(&uv, &yv);
    let fit_on_fresh = |file: &lifted_lti::ModelFile| {
        let opts = lifted_lti::ValidationOptions {
            operating_point: file.operating_point.clone(),
            ..Default::default()
        };
        lifted_lti::validate(&file.model, &fresh, &opts)
            .expect("validate")
            .outputs[0]
            .fit
    };
    for method in [Method::Pbsid, Method::Ssarx, Method::PbsidRowwise] {
        let mut o = WorkflowOptions::default();
        o.identification.method = method;
        o.refinement.refine = Refine::None;
        let fit = identify(&rec, &o).expect("identify");
        let d = &fit.file.diagnostics;
        let sel = &d["structure_selection"];
        let order = sel["order"].as_u64().expect("order") as usize;
        assert_eq!(fit.order, order, "{method:?}: {d}");
        assert!(order >= 3, "{method:?}: {d}");
        // Ten orders, each scored on six blocks.
        let candidates = sel["candidates"].as_array().expect("candidates");
        assert_eq!(candidates.len(), 10, "{method:?}: {d}");
        assert!(
            candidates
                .iter()
                .all(|c| c["fold_fits"].as_array().is_some_and(|f| f.len() == 6)),
            "{method:?}: {d}"
        );
        // 3 % drifting noise: a fit near 95 % on a fresh record.
        let chosen = fit_on_fresh(&fit.file);
        assert!(chosen > 93.0, "{method:?}: {chosen} {d}");
        // The model is the fixed-order identification at that order and
        // the selection's past horizon.
        let mut fixed = o.clone();
        fixed.identification.order = Order::Fixed(order);
        fixed.identification.horizon = Some(sel["horizon"].as_u64().expect("past") as usize);
        fixed.identification.future = Some(10);
        let again = identify(&rec, &fixed).expect("identify");
        assert_eq!(again.file.model.a(), fit.file.model.a(), "{method:?}");
        assert_eq!(again.file.model.b(), fit.file.model.b(), "{method:?}");
        // The gap rule is still there on request, and worse here for PBSID.
        let mut gap = o.clone();
        gap.identification.order_criterion = OrderCriterion::Gap;
        let by_gap = identify(&rec, &gap).expect("identify");
        assert!(by_gap.file.diagnostics.get("structure_selection").is_none());
        if method == Method::Pbsid {
            assert_eq!(by_gap.order, 1);
            assert!(fit_on_fresh(&by_gap.file) < chosen - 10.0);
        }
    }
}

/// The single-rate IV route's automatic order by held-out simulation fit
/// (`lifted_subspace::select_iv_order`), with its curve in the diagnostics.
#[test]
fn the_iv_route_chooses_its_order_on_held_out_blocks() {
    let (u, y) = distributed_record(2000, 3);
    let (uv, yv) = distributed_record(2000, 2);
    let rec = [Record::new(dataset(&u, &y))];
    let fresh = dataset(&uv, &yv);
    let mut o = WorkflowOptions::default();
    o.identification.method = Method::Iv;
    o.refinement.refine = Refine::None;
    let fit = identify(&rec, &o).expect("identify");
    let d = &fit.file.diagnostics;
    let sel = &d["structure_selection"];
    assert_eq!(
        fit.order as u64,
        sel["order"].as_u64().expect("order"),
        "{d}"
    );
    // α = 8: orders 1..=7, each on six blocks.
    let candidates = sel["candidates"].as_array().expect("candidates");
    assert_eq!(candidates.len(), 7, "{d}");
    let opts = lifted_lti::ValidationOptions {
        operating_point: fit.file.operating_point.clone(),
        ..Default::default()
    };
    let chosen = lifted_lti::validate(&fit.file.model, &fresh, &opts)
        .expect("validate")
        .outputs[0]
        .fit;
    let mut gap = o.clone();
    gap.identification.order_criterion = OrderCriterion::Gap;
    let by_gap = identify(&rec, &gap).expect("identify");
    let opts = lifted_lti::ValidationOptions {
        operating_point: by_gap.file.operating_point.clone(),
        ..Default::default()
    };
    let gap_fit = lifted_lti::validate(&by_gap.file.model, &fresh, &opts)
        .expect("validate")
        .outputs[0]
        .fit;
    eprintln!(
        "IV chosen {} {chosen} gap {} {gap_fit}",
        fit.order, by_gap.order
    );
    // The gap rule of R₂₂'s singular values took order 7 here (fit 95.6 %
    // on a fresh record); the held-out fit takes 3 (95.9 %): as good with
    // fewer states.
    assert!(chosen > 93.0, "{chosen} {d}");
    assert!(fit.order < by_gap.order, "{} {}", fit.order, by_gap.order);
    assert!(chosen > gap_fit - 0.5, "{chosen} {gap_fit}");
}

/// PBSID/SSARX on a record too short for the default future horizon 10
/// (30 samples of 2 inputs and 2 outputs), and IV on one too short for its
/// default α = 8: refused before ("horizons past 10 + future 10 too long
/// for 30 samples"); now the longest horizon the record supports, with a
/// warning, as the other subspace routes do — and a given horizon is still
/// refused.
#[test]
fn a_record_too_short_for_the_default_future_horizon_gets_one_it_supports() {
    let (u, y) = record(30, 0.05, 9);
    let rec = [Record::new(dataset(&u, &y))];
    for (method, f) in [(Method::Pbsid, 5), (Method::Ssarx, 3)] {
        let mut o = WorkflowOptions::default();
        o.identification.method = method;
        let fit = identify(&rec, &o).expect("identify");
        let d = &fit.file.diagnostics;
        assert_eq!(d["horizons"][1].as_u64(), Some(f), "{method:?}: {d}");
        assert!(
            d["warnings"]
                .to_string()
                .contains(&format!("future horizon {f}, the longest they support")),
            "{method:?}: {d}"
        );
        let mut given = o.clone();
        given.identification.future = Some(10);
        assert!(identify(&rec, &given).is_err(), "{method:?}");
    }
    // The IV method's α (default 8) likewise: 31 − 3α ≥ 4α columns at
    // α_p = 2α, so α = 4.
    let mut o = WorkflowOptions::default();
    o.identification.method = Method::Iv;
    let fit = identify(&rec, &o).expect("identify");
    let d = &fit.file.diagnostics;
    assert_eq!(d["horizons"][0].as_u64(), Some(4), "{d}");
    assert!(
        d["warnings"]
            .to_string()
            .contains("alpha 4, the longest they support"),
        "{d}"
    );
    o.identification.horizon = Some(8);
    assert!(identify(&rec, &o).is_err());
}

/// SSARX on a drifting 80-sample record: the held-out blocks cannot be
/// identified at the past horizon, the gap's order 7 is unstable
/// (ρ = 1.027), and the next order of the gap's ranking with a stable model
/// (2) is kept, the orders passed over named — as on the multirate route
/// (it returned the unstable order 7).
#[test]
fn an_unstable_gap_choice_gives_way_to_the_next_stable_order() {
    let (u, y) = drifting_record(2);
    let rec = [Record::new(dataset(&u, &y))];
    let mut o = WorkflowOptions::default();
    o.identification.method = Method::Ssarx;
    let fit = identify(&rec, &o).expect("identify");
    let d = &fit.file.diagnostics;
    let note = d["structure_selection"]["error"]
        .as_str()
        .unwrap_or_default();
    assert!(note.contains("no order selected on held-out blocks"), "{d}");
    assert!(note.contains("passed over: [{\"order\":7"), "{note}");
    assert_eq!(fit.order, 2, "{d}");
    assert_eq!(d["stability"]["stable"], true, "{d}");
}

/// The predictor-based routes on an unstable plant held by a loop: no
/// order can be scored by simulation on the held-out blocks, so the gap
/// decides (order 1, the plant's pole 1.02), and the note says why in
/// words (it said "identified A is unstable: spectral radius NaN").
#[test]
fn an_unstable_plant_in_a_loop_gets_its_order_from_the_gap() {
    let (u, y, _) = unstable_loop(3000, 4);
    let rec = [Record::new(dataset(&u, &y))];
    for method in [Method::Pbsid, Method::Ssarx] {
        let mut o = WorkflowOptions::default();
        o.identification.method = method;
        let fit = identify(&rec, &o).expect("identify");
        let d = &fit.file.diagnostics;
        assert_eq!(fit.order, 1, "{method:?}: {d}");
        let a = fit.file.model.a()[(0, 0)];
        assert!((a - 1.02).abs() < 0.01, "{method:?}: {a}");
        let note = d["structure_selection"]["error"]
            .as_str()
            .unwrap_or_default();
        assert!(
            note.contains("no candidate gave a stable model on any held-out block")
                && !note.contains("NaN"),
            "{method:?}: {note}"
        );
    }
}

/// PBSID/SSARX on a record whose second output is a noise-free
/// combination of the first and the state (y1 = x1 + e, y2 = x2 − e): the
/// automatic order and past horizon identify it at the shortened
/// horizons (past outputs linearly dependent from three lags on), and the
/// model's notes say why (before: refused, "the VARX regressor Z_p is not
/// persistently exciting: numerical rank 32, 40 needed").
#[test]
fn predictor_methods_shorten_the_past_for_tied_outputs() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let n = 300;
    let (mut u, mut y) = (DMatrix::zeros(n, 2), DMatrix::zeros(n, 2));
    let (mut x1, mut x2) = (0.0f64, 0.0f64);
    for t in 0..n {
        let u1 = if rng.random::<bool>() { 1.0 } else { -1.0 };
        let u2 = if rng.random::<bool>() { 1.0 } else { -1.0 };
        let e = 0.01 * rng.random::<f64>();
        u[(t, 0)] = u1;
        u[(t, 1)] = u2;
        y[(t, 0)] = x1 + e;
        y[(t, 1)] = x2 - e;
        x1 = 0.8 * x1 + 0.5 * u1;
        x2 = 0.5 * x2 + 0.3 * u2 + 0.2 * u1;
    }
    let rec = [Record::new(dataset(&u, &y))];
    for method in [Method::Pbsid, Method::Ssarx, Method::PbsidRowwise] {
        let mut o = WorkflowOptions::default();
        o.identification.method = method;
        o.refinement.refine = Refine::None;
        let fit = identify(&rec, &o).expect("identify");
        let d = &fit.file.diagnostics;
        assert_eq!(fit.order, 2, "{method:?}: {d}");
        assert_eq!(d["structure_selection"]["horizon"], 2, "{method:?}: {d}");
        let notes = d["notes"].as_array().expect("notes");
        assert!(
            notes.iter().any(|n| n
                .as_str()
                .is_some_and(|s| s.contains("shortened to p = 2, f = 2"))),
            "{method:?}: {d}"
        );
        let mut poles: Vec<f64> = fit
            .file
            .model
            .poles()
            .expect("poles")
            .iter()
            .map(|p| p.re)
            .collect();
        poles.sort_by(f64::total_cmp);
        assert!(
            (poles[0] - 0.5).abs() < 0.01 && (poles[1] - 0.8).abs() < 0.01,
            "{method:?}: {poles:?}"
        );
    }
}

/// A fixed order the record is too short for, the horizon left to the
/// selection: the refusal names the order and the largest order the
/// record identifies, not the horizons the selection tried (the DaISy
/// distillation column's 45 samples of 5 inputs and 3 outputs at order 4
/// said "horizons past 3 + future 3 too long for 45 samples").
#[test]
fn an_order_beyond_a_short_record_is_named() {
    let (u, y) = record(25, 0.01, 3);
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(5);
    let e = identify(&[Record::new(dataset(&u, &y))], &opts)
        .expect_err("order 5 from 25 samples")
        .to_string();
    assert!(
        e.contains("order 5 is not identifiable from 25 samples"),
        "{e}"
    );
    assert!(e.contains("orders up to"), "{e}");
    // An order the record supports still identifies.
    opts.identification.order = Order::Fixed(2);
    assert!(identify(&[Record::new(dataset(&u, &y))], &opts).is_ok());
}

/// Issue 47: an automatic order by AIC (no held-out selection) gave an
/// unstable model where the default's was stable (a 3-input heating
/// record at order 4: −7868 % validation fit against 79.8 %). Here AIC's
/// minimiser on 200 samples of [`heating_record`] is unstable; as the
/// held-out selection and the singular-value gap do, it now gives way to
/// the next order of AIC's ranking with a stable model (at most
/// `STABLE_TRIES` models tried), the orders passed over named in
/// `diagnostics.stable_order`, the AIC curve kept; the model kept is then
/// refined by default as any stable estimate (an unstable one is not).
#[test]
fn an_unstable_aic_choice_gives_way_to_the_next_stable_order() {
    let (u, _, y) = heating_record(200, 0.1, 0);
    let records = [Record::new(dataset(&u, &y))];
    let mut opts = WorkflowOptions::default();
    opts.identification.order_criterion = OrderCriterion::Aic;
    let fit = identify(&records, &opts).expect("identify");
    let d = &fit.file.diagnostics;
    assert_eq!(d["stability"]["stable"], true, "{d}");
    // AIC's own choice, its curve, stays in the diagnostics.
    let values: Vec<f64> = d["order_criterion"]["values"]
        .as_array()
        .expect("AIC curve")
        .iter()
        .map(|v| v.as_f64().unwrap_or(f64::INFINITY))
        .collect();
    let chosen = d["order_criterion"]["selected"].as_u64().expect("selected") as usize;
    assert_eq!(d["order_criterion"]["criterion"], "Aic", "{d}");
    let passed = d["stable_order"]["passed_over"]
        .as_array()
        .expect("orders passed over");
    assert_eq!(passed[0]["order"], chosen as u64, "{d}");
    assert!(
        passed
            .iter()
            .all(|p| p["spectral_radius"].as_f64().is_some_and(|r| r >= 1.0)),
        "{d}"
    );
    // The order kept is the best of AIC's ranking after those passed over.
    let skipped: Vec<u64> = passed.iter().filter_map(|p| p["order"].as_u64()).collect();
    let best_left = (1..=values.len())
        .filter(|n| !skipped.contains(&(*n as u64)))
        .min_by(|a, b| values[a - 1].total_cmp(&values[b - 1]))
        .expect("an order left");
    assert_eq!(fit.order, best_left, "{d}");
    assert_ne!(fit.order, chosen);
    // Stable, it is refined as the default refines a stable estimate.
    let decision = d["refinement_decision"].as_str().unwrap_or_default();
    assert!(decision.starts_with("refined"), "{decision}");
    // On a fresh record of the plant the model simulates as the default
    // route's does: on 2000 noiseless samples the AIC model fitted 63.0 %
    // and the default's 53.9 % when written; asserted within 10 points
    // (the unstable order-8 model fitted −1.5e8 %).
    let (uv, yv, _) = heating_record(2000, 0.0, 100);
    let default = identify(&records, &WorkflowOptions::default()).expect("default");
    let (f_aic, f_default) = (
        simulation_fit(&fit, &uv, &yv),
        simulation_fit(&default, &uv, &yv),
    );
    assert!(
        f_aic > f_default - 10.0,
        "AIC {f_aic} vs default {f_default}"
    );
    // A refinement asked for starts from that model: the order is searched
    // as the plain identification's, as under the held-out selection (the
    // refinement's stabilised start does not change it).
    for refine in [Refine::None, Refine::Pem] {
        opts.refinement.refine = refine;
        let other = identify(&records, &opts).expect("identify");
        assert_eq!(other.order, fit.order, "{refine:?}");
        assert_eq!(other.file.diagnostics["stable_order"], d["stable_order"]);
    }
}

/// The IV route under AIC (no held-out selection): on 300 samples of
/// [`heating_record`] AIC's order 5 is unstable (ρ = 1.024); the next
/// order of its ranking with a stable model is kept, as on the other
/// routes (it returned order 5). (`max_order` 7: α = 8 identifies
/// orders up to 7 of one output.)
#[test]
fn an_unstable_aic_choice_on_the_iv_route_gives_way_to_the_next_stable_order() {
    let (u, _, y) = heating_record(300, 0.2, 4);
    let records = [Record::new(dataset(&u, &y))];
    let mut opts = WorkflowOptions::default();
    opts.identification.method = Method::Iv;
    opts.identification.order_criterion = OrderCriterion::Aic;
    opts.identification.max_order = 7;
    let fit = identify(&records, &opts).expect("identify");
    let d = &fit.file.diagnostics;
    assert_eq!(d["stability"]["stable"], true, "{d}");
    assert_eq!(d["order_criterion"]["selected"], 5, "{d}");
    assert_eq!(d["stable_order"]["passed_over"][0]["order"], 5, "{d}");
    assert_eq!(d["stable_order"]["order"], fit.order as u64, "{d}");
    assert_ne!(fit.order, 5);
}

/// Issue 47: the IV route with an order rule asked for caps the automatic
/// order's search at what the records identify, as the subspace routes
/// do (α = 8 identifies orders up to 7 of one output; the default bound
/// 10 failed: "IV identification: model order 10 invalid: it must lie in
/// 1..=7"), with their warning.
#[test]
fn the_iv_route_caps_the_automatic_order_search() {
    let (u, _, y) = heating_record(300, 0.2, 4);
    let records = [Record::new(dataset(&u, &y))];
    for criterion in [
        OrderCriterion::Aic,
        OrderCriterion::Aicc,
        OrderCriterion::Bic,
    ] {
        let mut opts = WorkflowOptions::default();
        opts.identification.method = Method::Iv;
        opts.identification.order_criterion = criterion;
        let fit = identify(&records, &opts).expect("identify");
        let d = &fit.file.diagnostics;
        let warned = d["warnings"].as_array().is_some_and(|w| {
            w.iter().any(|m| {
                m.as_str()
                    .is_some_and(|m| m.contains("searched 1..=7 instead of 1..=10"))
            })
        });
        assert!(warned, "{criterion:?}: {d}");
        assert!(fit.order <= 7, "{criterion:?}");
    }
}

/// The singular-value gap asked for on the predictor-based routes (no
/// held-out selection): the drifting record of
/// `an_unstable_gap_choice_gives_way_to_the_next_stable_order`, whose
/// gap order 7 is unstable, gets the next stable order of the gap's
/// ranking as the default's fallback does (it returned order 7).
#[test]
fn an_unstable_gap_choice_asked_for_gives_way_to_the_next_stable_order() {
    let (u, y) = drifting_record(2);
    let rec = [Record::new(dataset(&u, &y))];
    let mut o = WorkflowOptions::default();
    o.identification.method = Method::Ssarx;
    o.identification.order_criterion = OrderCriterion::Gap;
    let fit = identify(&rec, &o).expect("identify");
    let d = &fit.file.diagnostics;
    assert_eq!(d["stability"]["stable"], true, "{d}");
    assert_eq!(d["stable_order"]["passed_over"][0]["order"], 7, "{d}");
    let default = identify(
        &rec,
        &WorkflowOptions {
            identification: lifted_workflow::IdentificationOptions {
                method: Method::Ssarx,
                ..Default::default()
            },
            ..Default::default()
        },
    )
    .expect("default");
    assert_eq!(fit.order, default.order, "{d}");
}

/// Issue 49: OE, ARMAX and BJ without orders scan the fixed orders by the
/// held-out simulation fit and keep the smallest within the tolerance of
/// the best: the OE plant of order 2 gets order 2 from OE and from BJ (its
/// plant part), every candidate is recorded; another order rule is
/// refused naming it.
#[test]
fn iterative_polynomial_methods_scan_their_order() {
    let data = oe_record(3000, 0.1, 11);
    for method in [Method::Oe, Method::Bj, Method::Armax] {
        let mut o = WorkflowOptions::default();
        o.identification.method = method;
        o.identification.max_order = 4;
        let fit = identify(&[Record::new(data.clone())], &o).expect("scanned");
        let scan = &fit.file.diagnostics["structure_scan"];
        let cands = scan["candidates"].as_array().expect("candidates");
        assert_eq!(cands.len(), 4, "{method:?}: {scan}");
        let order = scan["order"].as_u64().expect("order");
        let best = cands
            .iter()
            .filter_map(|c| c["held_out_fit"].as_f64())
            .fold(f64::NEG_INFINITY, f64::max);
        let chosen = scan["held_out_fit"].as_f64().expect("fit");
        assert!(chosen >= best - 0.5, "{method:?}: {scan}");
        // ARMAX's noise model A/C is not the plant's: it needs a higher
        // order to fit the OE plant; OE and BJ have the true structure.
        if method != Method::Armax {
            assert_eq!(order, 2, "{method:?}: {scan}");
        }
        // Every smaller order fits the held-out third worse than the
        // tolerance.
        for c in cands.iter().take(order as usize - 1) {
            let f = c["held_out_fit"].as_f64().unwrap_or(f64::NEG_INFINITY);
            assert!(f < best - 0.5, "{method:?}: {c}");
        }
    }
    let mut o = WorkflowOptions::default();
    o.identification.method = Method::Oe;
    o.identification.order_criterion = OrderCriterion::Aic;
    match identify(&[Record::new(data)], &o) {
        Err(Error::InvalidOption { option, .. }) => assert_eq!(option, "order_criterion"),
        other => panic!("expected the rule refused, got {other:?}"),
    }
}

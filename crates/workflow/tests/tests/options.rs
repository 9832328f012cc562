//! Options: the defaults recover a known plant; options round-trip through JSON and
//! bad ones are named; per-method options reach their routes; budgets and the selection
//! policy decide and are recorded; every route writes typed diagnostics; the caches give
//! the uncached model; units and constant channels.

use crate::common::*;
use lifted_lti::StateSpace;
use lifted_workflow::{
    Detrend, Error, Estimator, Method, Order, OrderCriterion, Record, Refine, SubspaceCache,
    WorkflowOptions, identify, identify_cached, identify_streamed,
};
use nalgebra::DMatrix;

#[test]
fn default_options_recover_the_plant() {
    let (u, y) = record(3000, 0.02, 1);
    let fit =
        identify(&[Record::new(dataset(&u, &y))], &WorkflowOptions::default()).expect("identify");
    let m = &fit.file.model;
    assert_eq!(m.order(), 3, "{}", fit.file.diagnostics);
    // 3000 samples at σ = 0.02 against unit-size outputs: the poles are
    // within 0.01 (a wrong order or route misses by ≥ 0.1).
    let want = poles(&plant());
    for (got, want) in poles(m).iter().zip(&want) {
        assert!((got.0 - want.0).abs() < 0.01, "{got:?} vs {want:?}");
        assert!((got.1 - want.1).abs() < 0.01, "{got:?} vs {want:?}");
    }
    let d = &fit.file.diagnostics;
    assert!(d["structure_selection"]["horizon"].is_u64(), "{d}");
    assert_eq!(d["stability"]["stable"], true);
    let op = fit.file.operating_point.as_ref().expect("operating point");
    // The offsets (2, −1) plus the plant's mean response to the 0.3 input mean.
    assert!(op.y0.iter().all(|v| v.is_finite()));
    assert_eq!(fit.x0.len(), 1);
    assert_eq!(fit.order, 3);
}

/// The selection policy an automatic order was picked by is in the
/// diagnostics, the values given; a given order records none.
#[test]
fn the_selection_policy_is_recorded_with_an_automatic_order() {
    let (u, y) = record(1200, 0.1, 6);
    let rec = [Record::new(dataset(&u, &y))];
    let mut o = WorkflowOptions::default();
    o.refinement.refine = Refine::None;
    o.identification.selection.failed_fold = -40.0;
    o.identification.selection.stable_tries = 3;
    let fit = identify(&rec, &o).expect("automatic order");
    let p = &fit.file.diagnostics["selection_policy"];
    assert_eq!(
        (p["failed_fold"].as_f64(), p["stable_tries"].as_u64()),
        (Some(-40.0), Some(3))
    );
    assert_eq!(p["tolerance"].as_f64(), Some(0.5));
    let floor = fit.file.diagnostics["structure_selection"]["candidates"]
        .as_array()
        .expect("candidates")
        .iter()
        .flat_map(|c| c["fold_fits"].as_array().cloned().unwrap_or_default())
        .filter_map(|f| f.as_f64())
        .fold(f64::INFINITY, f64::min);
    // Some fold of a high order fails or diverges on this record: its
    // score is the policy's (−100 by default).
    assert_eq!(floor, -40.0);
    o.identification.order = Order::Fixed(2);
    let fixed = identify(&rec, &o).expect("order given");
    assert!(fixed.file.diagnostics.get("selection_policy").is_none());
    // The options the run was given, as data: they read back as given.
    let back: WorkflowOptions =
        serde_json::from_value(fixed.file.diagnostics["options"].clone()).expect("options");
    assert_eq!(back, o);
}

#[test]
fn options_round_trip_through_json_and_default_when_absent() {
    let mut o = WorkflowOptions::default();
    o.identification.method = Method::Cva;
    o.identification.order = Order::Fixed(4);
    o.data.detrend = Detrend::Linear;
    o.refinement.refine = Refine::Oe;
    let text = serde_json::to_string(&o).expect("json");
    let back: WorkflowOptions = serde_json::from_str(&text).expect("parse");
    assert_eq!(back, o);
    let partial: WorkflowOptions =
        serde_json::from_str(r#"{"identification": {"method": "moesp"}}"#).expect("parse");
    assert_eq!(partial.identification.method, Method::Moesp);
    assert_eq!(partial.identification.max_order, 10);
    assert_eq!(partial.data, WorkflowOptions::default().data);
}

#[test]
fn bad_options_are_named() {
    let (u, y) = record(400, 0.1, 4);
    let rec = [Record::new(dataset(&u, &y))];
    let named = |o: &WorkflowOptions| match identify(&rec, o) {
        Err(Error::InvalidOption { option, .. }) => option,
        other => panic!("expected an invalid option, got {other:?}"),
    };
    let mut o = WorkflowOptions::default();
    o.identification.order = Order::Fixed(0);
    assert_eq!(named(&o), "order");
    let mut o = WorkflowOptions::default();
    o.refinement.refine = Refine::Pem;
    o.refinement.iterations = 0;
    assert_eq!(named(&o), "refine_iterations");
    let mut o = WorkflowOptions::default();
    o.refinement.judge_iterations = 0;
    assert_eq!(named(&o), "judge_iterations");
    let mut o = WorkflowOptions::default();
    o.refinement.refine = Refine::Oe;
    o.refinement.max_work = f64::NAN;
    assert_eq!(named(&o), "refine_max_work");
    let mut o = WorkflowOptions::default();
    o.identification.output_weight = vec![2.0];
    assert_eq!(named(&o), "output_weight");
    let mut o = WorkflowOptions::default();
    o.identification.method = Method::Pbsid;
    o.identification.stable = true;
    assert_eq!(named(&o), "stable");
    let mut o = WorkflowOptions::default();
    o.identification.method = Method::Qmarkov;
    o.identification.order_criterion = OrderCriterion::Aic;
    assert_eq!(named(&o), "order_criterion");
    // The options of one method refused with the others.
    let mut o = WorkflowOptions::default();
    o.identification.future = Some(5);
    assert_eq!(named(&o), "future");
    let mut o = WorkflowOptions::default();
    o.identification.method = Method::Qmarkov;
    o.identification.feedthrough = Some(false);
    assert_eq!(named(&o), "feedthrough");
    let mut o = WorkflowOptions::default();
    o.identification.method = Method::Pbsid;
    o.identification.instrument_past = Some(12);
    assert_eq!(named(&o), "instrument_past");
    let mut o = WorkflowOptions::default();
    o.identification.amplitudes = vec![1.0, 2.0];
    assert_eq!(named(&o), "amplitudes");
    // The selection policy's values.
    let policy = |f: &dyn Fn(&mut lifted_workflow::SelectionOptions)| {
        let mut o = WorkflowOptions::default();
        f(&mut o.identification.selection);
        named(&o)
    };
    assert_eq!(policy(&|s| s.stable_tries = 0), "stable_tries");
    assert_eq!(policy(&|s| s.shortlist = 0), "shortlist");
    assert_eq!(policy(&|s| s.shortlist_span = f64::NAN), "shortlist_span");
    assert_eq!(policy(&|s| s.tolerance = -0.1), "selection_tolerance");
    assert_eq!(policy(&|s| s.failed_fold = 5.0), "failed_fold");
    let mut o = WorkflowOptions::default();
    o.identification.method = Method::Pbsid;
    o.identification.future = Some(0);
    assert_eq!(named(&o), "future");
    for bad in [f64::NAN, -1e-3, 1.0, f64::INFINITY] {
        let mut o = WorkflowOptions::default();
        o.identification.integrator_tolerance = Some(bad);
        assert_eq!(named(&o), "integrator_tolerance", "{bad}");
    }
    let with_instrument = [Record {
        data: dataset(&u, &y),
        instrument: Some(u.clone()),
    }];
    match identify(&with_instrument, &WorkflowOptions::default()) {
        Err(Error::InvalidOption { option, .. }) => assert_eq!(option, "instrument"),
        other => panic!("{other:?}"),
    }
    match identify(&[], &WorkflowOptions::default()) {
        Err(Error::Data(m)) => assert!(m.contains("no data"), "{m}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn the_cache_gives_the_uncached_model_without_a_new_compression() {
    let (u, y) = record(4000, 0.1, 5);
    let records = [Record::new(dataset(&u, &y))];
    let mut cache = SubspaceCache::default();
    let mut opts = fixed_structure_unrefined();
    for (i, (method, n)) in [(Method::N4sid, 2), (Method::N4sid, 3), (Method::Moesp, 4)]
        .into_iter()
        .enumerate()
    {
        opts.identification.method = method;
        opts.identification.order = Order::Fixed(n);
        let cached = identify_cached(&records, &opts, &[], &mut cache).expect("cached");
        let plain = identify(&records, &opts).expect("plain");
        // Bit for bit: the cached route is how the uncached one runs.
        assert_eq!(cached.file.model, plain.file.model, "{method:?} n = {n}");
        assert_eq!(cached.file.kalman_gain, plain.file.kalman_gain);
        assert_eq!(cached.x0, plain.x0);
        // One compression for the three fits, and one VARX innovation
        // estimate for their three Kalman-gain checks: estimated from the
        // record itself, not from each model's deviations (issue 47: the
        // studio's slider recomputed it for every order).
        assert_eq!(cache.compressions(), 1, "fit {i}");
        assert_eq!(cache.varx_estimates(), 1, "fit {i}");
    }
    // An order identified again reuses them too, with the same model and
    // gain as without the cache.
    let estimates = cache.varx_estimates();
    opts.identification.method = Method::N4sid;
    opts.identification.order = Order::Fixed(2);
    let again = identify_cached(&records, &opts, &[], &mut cache).expect("again");
    assert_eq!(cache.varx_estimates(), estimates, "VARX again");
    let plain = identify(&records, &opts).expect("plain");
    assert_eq!(again.file.kalman_gain, plain.file.kalman_gain);
    // A new horizon or new data compress again.
    opts.identification.horizon = Some(8);
    identify_cached(&records, &opts, &[], &mut cache).expect("new horizon");
    assert_eq!(cache.compressions(), 2);
    let (u2, y2) = record(4000, 0.1, 6);
    identify_cached(&[Record::new(dataset(&u2, &y2))], &opts, &[], &mut cache).expect("new data");
    assert_eq!(cache.compressions(), 3);
}

/// On a long record the cached run identifies the feedthrough test's D = 0
/// model with the D-free one (two threads on the kept compression) and
/// simulates the two on two threads: the same model file as the uncached
/// run, bit for bit, with one compression.
#[test]
fn the_paired_feedthrough_fits_give_the_uncached_model() {
    let (u, y) = record(20_000, 0.1, 8);
    let records = [Record::new(dataset(&u, &y))];
    let mut cache = SubspaceCache::default();
    let mut opts = fixed_structure_unrefined();
    for n in [2, 3] {
        opts.identification.order = Order::Fixed(n);
        let cached = identify_cached(&records, &opts, &[], &mut cache).expect("cached");
        let plain = identify(&records, &opts).expect("plain");
        assert_eq!(cached.file.model, plain.file.model, "order {n}");
        assert_eq!(cached.file.kalman_gain, plain.file.kalman_gain, "order {n}");
        assert_eq!(
            cached.file.diagnostics["feedthrough"], plain.file.diagnostics["feedthrough"],
            "order {n}"
        );
        assert!(
            cached.file.diagnostics["feedthrough"]["statistic"].is_f64(),
            "the test ran: {}",
            cached.file.diagnostics["feedthrough"]
        );
    }
    assert_eq!(cache.compressions(), 1);
}

/// The feedback test of a single-rate record is made once for every order
/// identified through the cache, on the record before the model's
/// operating point is removed, and it says what the test on each model's
/// deviations (the route of before) says: the same verdict and statistics
/// to 1e-8 (the VARX's and the test's constants take the offsets, the
/// channels' scales cancel in the ratios). A new record or new test
/// options make a new test; the uncached run gives the same diagnostics.
#[test]
fn the_feedback_test_is_made_once_per_record() {
    let (u, y) = record(4000, 0.1, 5);
    let records = [Record::new(dataset(&u, &y))];
    let mut cache = SubspaceCache::default();
    let mut opts = fixed_structure_unrefined();
    let fb = opts.identification.feedback;
    for n in [2, 3, 4] {
        opts.identification.order = Order::Fixed(n);
        let cached = identify_cached(&records, &opts, &[], &mut cache).expect("cached");
        assert_eq!(cache.feedback_tests(), 1, "order {n}");
        let plain = identify(&records, &opts).expect("plain");
        let got = &cached.file.diagnostics["feedback"];
        assert_eq!(*got, plain.file.diagnostics["feedback"], "order {n}");
        // The route of before: the test on this model's deviations.
        let op = cached
            .file
            .operating_point
            .as_ref()
            .expect("operating point");
        let (du, dy) = op.to_deviations(&u, &y).expect("deviations");
        let e = lifted_closedloop::arx_innovations(&du, &dy, fb.arx_order, fb.max_samples)
            .expect("VARX");
        let before = lifted_closedloop::feedback_test(&du, &e, 1, &fb).expect("test");
        assert_eq!(got["detected"], serde_json::json!(before.detected));
        let inputs = got["inputs"].as_array().expect("inputs");
        assert_eq!(inputs.len(), before.inputs.len());
        for (now, then) in inputs.iter().zip(&before.inputs) {
            let s = now["statistic"].as_f64().expect("statistic");
            assert!(
                (s - then.statistic).abs() <= 1e-8 * then.statistic.abs().max(1.0),
                "order {n}: {s} vs {}",
                then.statistic
            );
            assert_eq!(now["detected"], serde_json::json!(then.detected));
        }
    }
    let (u2, y2) = record(4000, 0.1, 6);
    identify_cached(&[Record::new(dataset(&u2, &y2))], &opts, &[], &mut cache).expect("new data");
    assert_eq!(cache.feedback_tests(), 2);
    opts.identification.feedback.arx_order = 8;
    identify_cached(&[Record::new(dataset(&u2, &y2))], &opts, &[], &mut cache)
        .expect("new options");
    assert_eq!(cache.feedback_tests(), 3);
    cache.clear();
    identify_cached(&[Record::new(dataset(&u2, &y2))], &opts, &[], &mut cache).expect("cleared");
    assert_eq!(cache.feedback_tests(), 1);
}

/// Issue 48: the work budgets are parameters. Below the samples budget the
/// default refines; with both refinement budgets lowered under the
/// record's size and work it does not, and says which bound; with the gain
/// check's samples budget under the record the gain is checked on the
/// record's last that many samples (issue 50), and with it 0 the subspace
/// step's gain is kept. The values used are in `diagnostics.budgets`; bad
/// ones are refused naming the budget.
#[test]
fn the_work_budgets_decide_and_are_recorded() {
    let (u, y) = record(3000, 0.1, 7);
    let records = [Record::new(dataset(&u, &y))];
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(3);
    let auto = identify(&records, &opts).expect("default budgets");
    let d = &auto.file.diagnostics;
    assert_eq!(d["budgets"]["auto_refine_samples"], 10_000);
    assert_eq!(d["budgets"]["gain_check_minimise_work"], 8e9);
    assert!(d["kalman_gain_route"].is_object(), "{d}");
    let why = d["refinement_decision"].as_str().unwrap_or_default();
    assert!(why.starts_with("refined"), "{why}");
    opts.budgets.auto_refine_samples = 1000;
    opts.budgets.auto_refine_work = 1.0;
    opts.budgets.gain_check_samples = 2999;
    let tight = identify(&records, &opts).expect("tight budgets");
    let d = &tight.file.diagnostics;
    let why = d["refinement_decision"].as_str().unwrap_or_default();
    assert!(
        why.starts_with("not refined") && why.contains("1e0"),
        "{why}"
    );
    assert!(d.get("refinement").is_none(), "{d}");
    assert!(d["kalman_gain_route"].is_object(), "{d}");
    assert_eq!(d["kalman_gain_window"]["samples"], 2999, "{d}");
    assert_eq!(d["kalman_gain_window"]["of"], 3000, "{d}");
    assert_eq!(d["budgets"]["auto_refine_samples"], 1000);
    assert_eq!(d["budgets"]["gain_check_samples"], 2999);
    // With the gain check's budget at 0 the subspace step's gain is kept.
    let mut off = opts.clone();
    off.budgets.gain_check_samples = 0;
    let kept = identify(&records, &off).expect("no gain check");
    let dk = &kept.file.diagnostics;
    assert!(dk.get("kalman_gain_route").is_none(), "{dk}");
    assert_ne!(
        tight.file.kalman_gain_matrix().expect("gain"),
        kept.file.kalman_gain_matrix().expect("gain")
    );
    // Read back from the model file's options as given.
    let back: WorkflowOptions = serde_json::from_value(d["options"].clone()).expect("options");
    assert_eq!(back.budgets, opts.budgets);
    let mut gain = opts.identification.gain_check;
    let mut b = opts.budgets;
    let e = b
        .set(&mut gain, "auto_refine_wrok", 1.0)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("auto_refine_wrok") && e.contains("auto_refine_work"),
        "{e}"
    );
    let e = b
        .set(&mut gain, "gain_check_samples", 1.5)
        .unwrap_err()
        .to_string();
    assert!(e.contains("gain_check_samples"), "{e}");
    b.set(&mut gain, "gain_check_minimise_work", 1e9)
        .expect("a budget");
    assert_eq!(gain.minimise_work, 1e9);
    opts.budgets.refine_check_work = -1.0;
    let e = identify(&records, &opts).unwrap_err().to_string();
    assert!(e.contains("refine_check_work"), "{e}");
}

#[test]
fn the_per_method_options_reach_their_routes() {
    // Each option changes the model of its method (a route that dropped it
    // would give the default's model bit for bit); PBSID's feedthrough
    // gives a nonzero D, its default none.
    let (u, y) = record(2000, 0.05, 7);
    let rec = [Record::new(dataset(&u, &y))];
    let fit = |o: &WorkflowOptions| identify(&rec, o).expect("identify").file.model;
    let mut base = WorkflowOptions::default();
    base.identification.order = Order::Fixed(3);
    base.identification.horizon = Some(12);
    base.refinement.refine = Refine::None;
    for method in [Method::Pbsid, Method::Ssarx, Method::Iv] {
        let mut o = base.clone();
        o.identification.method = method;
        let plain = fit(&o);
        assert!(
            plain.d().iter().all(|&v| v == 0.0),
            "{method:?}: D = 0 by default"
        );
        if method != Method::Iv {
            let mut f = o.clone();
            f.identification.future = Some(5);
            assert_ne!(fit(&f).a(), plain.a(), "{method:?}: future");
        }
        let mut d = o.clone();
        d.identification.feedthrough = Some(true);
        assert!(
            fit(&d).d().iter().any(|&v| v != 0.0),
            "{method:?}: feedthrough"
        );
    }
    let mut o = base.clone();
    o.identification.method = Method::Iv;
    let plain = fit(&o);
    o.identification.instrument_past = Some(30);
    assert_ne!(fit(&o).a(), plain.a(), "instrument_past");
    // N4SID, MOESP and CVA estimate D unless D = 0 is asked for (a strictly
    // proper model, as the MPC designs take), in memory and streamed.
    for method in [Method::N4sid, Method::Moesp, Method::Cva] {
        let mut o = base.clone();
        o.identification.method = method;
        assert!(fit(&o).d().iter().any(|&v| v != 0.0), "{method:?}: D");
        o.identification.feedthrough = Some(false);
        let zero = fit(&o);
        assert!(zero.d().iter().all(|&v| v == 0.0), "{method:?}: D = 0");
        let mut src = Blocks::of(&u, &y);
        let streamed = identify_streamed(&mut src, &o)
            .expect("streamed")
            .expect("a streamed model")
            .file
            .model;
        assert!(
            streamed.d().iter().all(|&v| v == 0.0),
            "{method:?}: streamed D = 0"
        );
    }
}

#[test]
fn a_constant_input_is_named_when_the_inputs_do_not_excite() {
    // A set-point logged as a second input: the subspace step refuses the
    // inputs as not persistently exciting; the refusal names the column.
    let (u, y) = record(400, 0.02, 8);
    let u = DMatrix::from_fn(400, 2, |i, j| if j == 0 { u[(i, 0)] } else { 0.5 });
    let records = [Record::new(dataset(&u, &y))];
    let e = identify(&records, &WorkflowOptions::default()).expect_err("constant input");
    let msg = e.to_string();
    assert!(
        msg.contains("input 2 (always 0.5) is constant")
            && msg.contains("not persistently exciting"),
        "{msg}"
    );
    // The subspace step's refusal stays the named refusal's source (a
    // front end maps it by its variant).
    let Error::Step { source, .. } = &e else {
        panic!("{e:?}");
    };
    let below = std::error::Error::source(source.as_ref())
        .and_then(|s| s.downcast_ref::<lifted_subspace::Error>());
    assert!(
        matches!(below, Some(lifted_subspace::Error::NotExciting { .. })),
        "{e:?}"
    );
    // The predictor-based and IV routes refuse the same record through
    // their own regressors (the VARX past, the instrument rows): the same
    // column is named (they gave only "… is not persistently exciting:
    // numerical rank r, k needed").
    for method in [Method::Pbsid, Method::Ssarx, Method::Iv] {
        let mut o = WorkflowOptions::default();
        o.identification.method = method;
        let e = identify(&records, &o).expect_err("constant input");
        let msg = e.to_string();
        assert!(
            msg.contains("input 2 (always 0.5) is constant")
                && msg.contains("not persistently exciting"),
            "{method:?}: {msg}"
        );
    }
    // Read in blocks (a file too large for memory), the same message after
    // one more pass; the fixed-order streamed set-up of
    // `the_streamed_route_gives_the_in_memory_model`.
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(3);
    opts.identification.horizon = Some(10);
    opts.identification.estimator = Estimator::Shift;
    opts.identification.order_criterion = OrderCriterion::Gap;
    let mut src = Blocks::of(&u, &y);
    let e = identify_streamed(&mut src, &opts).expect_err("constant input, streamed");
    assert!(
        e.to_string().contains("input 2 (always 0.5) is constant"),
        "{e}"
    );
    // Two inputs tied together: named as a group.
    let tied = DMatrix::from_fn(400, 2, |i, j| u[(i, 0)] * if j == 0 { 1.0 } else { -3.0 });
    let mut src = Blocks::of(&tied, &y);
    let e = identify_streamed(&mut src, &opts).expect_err("tied inputs, streamed");
    assert!(e.to_string().contains("inputs 1, 2 move together"), "{e}");
}

#[test]
fn a_constant_output_is_identified_with_a_warning() {
    // A stuck sensor: the model is still given for the other output, with
    // a warning naming the constant one.
    let (u, y) = record(400, 0.02, 10);
    let y = DMatrix::from_fn(400, 2, |i, j| if j == 0 { y[(i, 0)] } else { 2.0 });
    let fit =
        identify(&[Record::new(dataset(&u, &y))], &WorkflowOptions::default()).expect("identify");
    let w = fit.file.diagnostics["warnings"].to_string();
    assert!(
        w.contains("output 2 is constant over the records (always 2)"),
        "{w}"
    );
}

/// The same record with its channels in other units (inputs ×1e4 and
/// ×1e-3, outputs ×1e-6 and ×1e5): the default identification gives the
/// same model once the units are undone, whatever the method. N4SID's and
/// MOESP's projections weight the outputs by their units; before the
/// workflow scaled the channels a 3×3 record logged in units 1e-7 … 1e6
/// apart got another order and validation fits of 19/1/47 % instead of
/// 48/58/41 % (benches/results/real-records.md, session 17).
#[test]
fn the_model_does_not_depend_on_the_channels_units() {
    let (u, y) = record(2000, 0.05, 21);
    let (su, sy) = ([1e4, 1e-3], [1e-6, 1e5]);
    let mut u2 = u.clone();
    let mut y2 = y.clone();
    for j in 0..2 {
        u2.column_mut(j).iter_mut().for_each(|v| *v *= su[j]);
        y2.column_mut(j).iter_mut().for_each(|v| *v *= sy[j]);
    }
    for method in [Method::N4sid, Method::Moesp, Method::Pbsid] {
        let mut opts = WorkflowOptions::default();
        opts.identification.method = method;
        let a = identify(&[Record::new(dataset(&u, &y))], &opts).expect("identify");
        let b = identify(&[Record::new(dataset(&u2, &y2))], &opts).expect("identify scaled");
        let (ma, mb) = (&a.file.model, &b.file.model);
        assert_eq!(ma.order(), mb.order(), "{method:?}");
        // b's model in a's units: B diag(su), diag(1/sy) C, diag(1/sy) D diag(su).
        let mut bb = mb.b().clone();
        let mut cb = mb.c().clone();
        let mut db = mb.d().clone();
        for j in 0..2 {
            bb.column_mut(j).iter_mut().for_each(|v| *v *= su[j]);
            db.column_mut(j).iter_mut().for_each(|v| *v *= su[j]);
            cb.row_mut(j).iter_mut().for_each(|v| *v /= sy[j]);
            db.row_mut(j).iter_mut().for_each(|v| *v /= sy[j]);
        }
        let back = StateSpace::new(mb.a().clone(), bb, cb, db, Some(1.0)).expect("model");
        let d = fr_error(&back, ma);
        assert!(d < 1e-6, "{method:?}: the models differ by {d} (relative)");
        let (opa, opb) = (
            a.file.operating_point.as_ref().expect("op"),
            b.file.operating_point.as_ref().expect("op"),
        );
        for j in 0..2 {
            assert!((opb.y0[j] / sy[j] - opa.y0[j]).abs() < 1e-6 * opa.y0[j].abs().max(1.0));
            assert!((opb.u0[j] / su[j] - opa.u0[j]).abs() < 1e-6 * opa.u0[j].abs().max(1.0));
        }
    }
}

/// Issue 47: the default feedthrough of N4SID/MOESP/CVA. A plant without
/// one gets D = 0 exactly (the model MPC takes; an estimated D took noise),
/// a plant with one (D = diag(0.1, 0.2)) keeps it; the diagnostics give the
/// information criterion's statistic and threshold. `--feedthrough`
/// overrides either way.
#[test]
fn the_default_keeps_a_feedthrough_only_where_the_records_support_it() {
    let p = plant();
    let strictly_proper = StateSpace::new(
        p.a().clone(),
        p.b().clone(),
        p.c().clone(),
        DMatrix::zeros(2, 2),
        Some(1.0),
    )
    .expect("plant");
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(3);
    for method in [Method::N4sid, Method::Moesp, Method::Cva] {
        opts.identification.method = method;
        let (u, y) = record_of(&strictly_proper, 3000, 0.05, 21, [2.0, -1.0]);
        let fit = identify(&[Record::new(dataset(&u, &y))], &opts).expect("identify");
        let d = &fit.file.diagnostics["feedthrough"];
        assert!(
            fit.file.model.d().iter().all(|&v| v == 0.0),
            "{method:?}: {d}"
        );
        let (stat, threshold) = (d["statistic"].as_f64(), d["threshold"].as_f64());
        assert!(stat < threshold, "{method:?}: {d}");
        let (u, y) = record_of(&p, 3000, 0.05, 22, [2.0, -1.0]);
        let fit = identify(&[Record::new(dataset(&u, &y))], &opts).expect("identify");
        let d = &fit.file.diagnostics["feedthrough"];
        assert!(
            d["used"]
                .as_str()
                .is_some_and(|s| s.starts_with("D estimated")),
            "{d}"
        );
        let dd = fit.file.model.d();
        // D within 0.02 of the truth (σ = 0.05, 3000 samples).
        assert!(
            (dd[(0, 0)] - 0.1).abs() < 0.02 && (dd[(1, 1)] - 0.2).abs() < 0.02,
            "{dd}"
        );
    }
}

/// Every route's diagnostics have the form of `lifted_workflow::Diagnostics`
/// (read strictly, every entry in its field or kept by name) and write
/// back unchanged: the type the front ends read is the one the workflow
/// writes.
#[test]
fn every_route_writes_typed_diagnostics() {
    use lifted_workflow::Diagnostics;
    let (u, y) = record(3000, 0.05, 21);
    let single = || vec![Record::new(dataset(&u, &y))];
    let multirate = || {
        vec![Record::new(multirate_record(
            &issue_plant(),
            6000,
            &[3, 5],
            1,
            3,
        ))]
    };
    let cases: Vec<(&str, Method, Order, Vec<Record>)> = vec![
        ("default", Method::N4sid, Order::Auto, single()),
        ("moesp", Method::Moesp, Order::Fixed(3), single()),
        ("cva", Method::Cva, Order::Auto, single()),
        ("pbsid", Method::Pbsid, Order::Auto, single()),
        (
            "iv",
            Method::Iv,
            Order::Fixed(3),
            vec![Record {
                data: dataset(&u, &y),
                instrument: Some(u.clone()),
            }],
        ),
        ("arx", Method::Arx, Order::Auto, single()),
        ("oe", Method::Oe, Order::Fixed(2), single()),
        ("multirate", Method::N4sid, Order::Auto, multirate()),
        (
            "multirate pbsid",
            Method::Pbsid,
            Order::Fixed(4),
            multirate(),
        ),
    ];
    for (name, method, order, records) in cases {
        let mut o = WorkflowOptions::default();
        o.identification.method = method;
        o.identification.order = order;
        let fit = identify(&records, &o).unwrap_or_else(|e| panic!("{name}: {e}"));
        let v = &fit.file.diagnostics;
        let d = Diagnostics::strict(v).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(&d.to_value(), v, "{name}");
        assert!(d.route.is_some(), "{name}");
        assert_eq!(
            d.samples,
            Some(records.iter().map(|r| r.data.len()).sum()),
            "{name}"
        );
        assert!(
            d.plan.is_some() && d.options.is_some() && d.budgets.is_some(),
            "{name}"
        );
        assert!(d.stability.is_some(), "{name}");
    }
}

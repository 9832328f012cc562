//! Multirate records: the issue case with every method, the starts that fit the
//! measured samples, held inputs, records starting between slow samples, the held-out
//! order choice, units, feedthrough and the multirate IV route.

use crate::common::*;
use lifted_lti::{Dataset, StateSpace};
use lifted_workflow::{Method, Order, OrderCriterion, Record, Refine, WorkflowOptions, identify};
use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The multirate case of issue 26: 2×2, poles 0.95 ± 0.1j, 0.85 and 0.7,
/// y₁ measured every 3 and y₂ every 5 samples (lifting period 15), 3e4
/// samples of random binary input, output noise 10 % of each output's
/// standard deviation. The fast pole 0.7 lifts to 0.7¹⁵ ≈ 0.005, which
/// noise can push below zero (no principal 15th root): every method must
/// still identify, and the default refinement (the joint iterations of the
/// prediction cost, about 1e-1 s here) must run and bring every method to
/// the truth.
#[test]
fn the_multirate_issue_case_identifies_with_every_method() {
    let truth = issue_plant();
    let data = multirate_record(&truth, 30_000, &[3, 5], 1, 7);
    for method in [Method::N4sid, Method::Moesp, Method::Cva] {
        let mut opts = WorkflowOptions::default();
        opts.identification.method = method;
        opts.identification.order = Order::Fixed(4);
        let fit = identify(&[Record::new(data.clone())], &opts).expect("identify");
        let d = &fit.file.diagnostics;
        let decision = d["refinement_decision"].as_str().unwrap_or_default();
        assert!(
            decision.starts_with("refined") && decision.contains("joint"),
            "{method:?}: {decision}"
        );
        let err = fr_error(&fit.file.model, &truth);
        // The issue's bound. Measured 0.003–0.004 with the refinement
        // (seeds 0–2 of the Python version of this case); without it CVA
        // gave 0.059–0.089 at this noise level.
        assert!(err < 0.06, "{method:?}: FR error {err}: {d}");
    }
}

/// The issue's multirate case without the refinement (`--refine none`):
/// the fast model is the extraction's alone. The matrix root of the
/// estimated lifted A amplifies the noise of its small eigenvalues
/// (0.7¹⁵ ≈ 0.005, 0.85¹⁵ ≈ 0.09); the route now keeps the extraction
/// whose lifting reproduces the lifted model best (root, controllability
/// or eigenvalue), which was the closest to the plant in every case
/// measured. FR errors, seeds 0–5, three weightings: at most 0.030 (the
/// root alone: CVA 0.038 / 0.059 / 0.059 on seeds 0, 2, 3, and 0.074 on a
/// record of Gaussian noise through the CLI, above the issue's 0.06). The
/// bound 0.045 lies between the two.
#[test]
fn the_multirate_issue_case_extracts_without_the_refinement() {
    let truth = issue_plant();
    for seed in 0..6 {
        let data = multirate_record(&truth, 30_000, &[3, 5], 1, seed);
        for method in [Method::N4sid, Method::Moesp, Method::Cva] {
            let mut opts = WorkflowOptions::default();
            opts.identification.method = method;
            opts.identification.order = Order::Fixed(4);
            opts.refinement.refine = Refine::None;
            let fit = identify(&[Record::new(data.clone())], &opts).expect("identify");
            let d = &fit.file.diagnostics;
            let compared = d["extraction"]["comparison"].as_array().map_or(0, Vec::len);
            assert_eq!(compared, 3, "{method:?}: {d}");
            let err = fr_error(&fit.file.model, &truth);
            assert!(err < 0.045, "seed {seed} {method:?}: FR error {err}: {d}");
        }
    }
}

/// An input that moves slower than the frame (drawn every 12 samples,
/// logged every sample) with the output measured every 4: the lifted input
/// (4 slots per frame, nearly always equal) is not persistently exciting,
/// and the lifted route refused the record ("u is not persistently
/// exciting: numerical rank 20, 80 needed"). The record identifies from the
/// interpolated record's single-rate model, refined on the measured
/// samples, with a warning naming the lifted route's failure. Measured FR
/// error 0.0053; bound 0.03, half the 0.06 of issue 26's multirate case.
#[test]
fn a_multirate_record_whose_input_moves_slower_than_the_frame_is_identified() {
    let truth = resonant_plant();
    let data = slow_input_record(&truth, 6000, 12, 4, 0.05, 3);
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(3);
    let fit = identify(&[Record::new(data)], &opts).expect("identify");
    let d = &fit.file.diagnostics;
    assert!(
        d["multirate_start"]["lifted_error"]
            .as_str()
            .is_some_and(|s| s.contains("not persistently exciting")),
        "{d}"
    );
    assert!(
        d["warnings"]
            .to_string()
            .contains("the lifted multirate route failed"),
        "{d}"
    );
    let err = fr_error(&fit.file.model, &truth);
    assert!(err < 0.03, "FR error {err}: {d}");
}

/// Both starts of a multirate record are refined and the one that fits the
/// measured samples better is kept: `multirate_start` names it, and the
/// model returned has its fit (recomputed here by `lifted_lti::validate`,
/// as the rule computes it). Records with a drift (an AR(1) disturbance,
/// pole 0.99) on a two-mode flexible plant, output every 3 samples, 600
/// samples: on these the two starts end in different models.
#[test]
fn a_multirate_record_keeps_the_start_that_fits_its_samples() {
    let truth = flexible_plant();
    let mut differed = 0;
    for seed in 0..4 {
        let data = with_drift(&multirate_record(&truth, 600, &[3], 1, seed), 0.6, seed);
        for refine in [Refine::Auto, Refine::None] {
            let mut opts = WorkflowOptions::default();
            opts.identification.order = Order::Fixed(4);
            opts.refinement.refine = refine;
            // The route's choice of start, without the check against the
            // interpolated record's model (`routes::multirate_check`).
            opts.budgets.refine_check_samples = 0;
            let fit = identify(&[Record::new(data.clone())], &opts).expect("identify");
            let d = &fit.file.diagnostics;
            let ms = &d["multirate_start"];
            let fits: Vec<f64> = (0..2)
                .map(|i| ms["candidates"][i]["fit"].as_f64().expect("fit"))
                .collect();
            let best = if fits[1] > fits[0] { 1 } else { 0 };
            assert_eq!(ms["kept"], ms["candidates"][best]["start"], "{ms}");
            if (fits[0] - fits[1]).abs() > 1.0 {
                differed += 1;
            }
            // The model returned is the kept candidate's (in the data's
            // units: the operating point applied as the rule's records
            // were its deviations).
            let op = fit.file.operating_point.clone();
            let v = lifted_lti::validate(
                &fit.file.model,
                &data,
                &lifted_lti::ValidationOptions {
                    operating_point: op,
                    ..Default::default()
                },
            )
            .expect("validate");
            let mean = v.outputs.iter().map(|o| o.fit).sum::<f64>() / v.outputs.len() as f64;
            // (Or the interpolated record's model as identified, when it
            // simulates the samples better still: multirate_start::
            // or_as_identified.)
            let want = if ms["as_identified"]["kept"] == true {
                ms["as_identified"]["fit"].as_f64().expect("fit")
            } else {
                fits[best]
            };
            assert!((mean - want).abs() < 0.05, "{mean} vs {want}: {ms}");
        }
    }
    // Measured: 4 of the 8 runs end more than a point apart (the others
    // in the same model from both starts).
    assert!(differed >= 3, "{differed}");
}

/// A multirate model the refinement gives no Kalman gain (`--refine
/// none`; the lifted routes estimate none) gets the gain checked on the
/// measured samples from K = 0: on an innovations record (the issue's
/// plant, x(t+1) = A x + B u + K e, y = C x + e; outputs every 3 and 5
/// samples) its one-step predictions at the measured samples fit better
/// than the simulation. Before, the model file had no gain and `validate`
/// predicted by simulating. Measured (seed 4): one-step fits 81.3 / 77.9
/// against simulation fits 71.0 / 74.0.
#[test]
fn an_unrefined_multirate_model_carries_a_checked_kalman_gain() {
    use lifted_lti::{InputChannel, OutputChannel, ValidationOptions};
    let truth = issue_plant();
    let k = DMatrix::from_row_slice(4, 2, &[0.5, 0.1, 0.2, 0.4, 0.3, -0.2, 0.1, 0.3]);
    let n = 20_000;
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let u = DMatrix::from_fn(
        n,
        2,
        |_, _| if rng.random::<f64>() < 0.5 { -1.0 } else { 1.0 },
    );
    let mut x = DVector::zeros(4);
    let mut y = DMatrix::zeros(n, 2);
    for t in 0..n {
        let e = DVector::from_fn(2, |_, _| 0.5 * (rng.random::<f64>() - 0.5) * 12f64.sqrt());
        let ut = u.row(t).transpose();
        let yt = truth.c() * &x + &e;
        for (j, &p) in [3usize, 5].iter().enumerate() {
            y[(t, j)] = if t % p == 0 { yt[j] } else { f64::NAN };
        }
        x = truth.a() * &x + truth.b() * &ut + &k * &e;
    }
    let data = Dataset::new(
        1.0,
        u,
        y,
        vec![InputChannel::new("u1", 1), InputChannel::new("u2", 1)],
        vec![
            OutputChannel::new("y1", 3, 0),
            OutputChannel::new("y2", 5, 0),
        ],
    )
    .expect("dataset");
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(4);
    opts.refinement.refine = Refine::None;
    let fit = identify(&[Record::new(data.clone())], &opts).expect("identify");
    let d = &fit.file.diagnostics;
    let gain = fit.file.kalman_gain_matrix().expect("a Kalman gain");
    assert!(d["kalman_gain_route"]["final_cost"].is_number(), "{d}");
    let v = lifted_lti::validate(
        &fit.file.model,
        &data,
        &ValidationOptions {
            kalman_gain: Some(gain),
            operating_point: fit.file.operating_point.clone(),
            ..Default::default()
        },
    )
    .expect("validate");
    // Measured +10.3 (y1, every 3 samples) and +3.9 (y2, every 5): the
    // sparser output gains less from a constant gain applied at its
    // samples. The prediction-error refinement's own gain (`--refine pem`,
    // A, B, C, D refined too) gives +10.4 / +4.4.
    let gains: Vec<f64> = v
        .outputs
        .iter()
        .map(|o| o.prediction_fits[0] - o.fit)
        .collect();
    assert!(gains.iter().all(|g| *g > 2.0), "{gains:?}");
    assert!(
        gains.iter().sum::<f64>() / gains.len() as f64 > 5.0,
        "{gains:?}"
    );
}

/// The plant of the issue's multirate case on 6000 samples (400 frames of
/// the lifting period 15): horizon 10 is too long for the lifted record
/// (the route refused it: "at least 779 samples needed"), and the
/// singular-value gap picked order 2 (FR error 0.23). The default now takes
/// the longest horizon the frames support and the order of the best
/// held-out fit: the plant's 4.
#[test]
fn a_short_multirate_record_gets_its_horizon_and_order_from_the_data() {
    let truth = issue_plant();
    let data = multirate_record(&truth, 6000, &[3, 5], 1, 1);
    let fit = identify(&[Record::new(data)], &WorkflowOptions::default()).expect("identify");
    let d = &fit.file.diagnostics;
    assert_eq!(fit.order, 4, "{d}");
    assert!(
        d["warnings"]
            .to_string()
            .contains("horizon 5, the longest it supports"),
        "{d}"
    );
    // Measured 0.0086 (the gap's order 2: 0.23).
    let err = fr_error(&fit.file.model, &truth);
    assert!(err < 0.06, "FR error {err}: {d}");
}

/// Inputs held 2 samples (outputs every 2 and 4): the extraction gives the
/// fast model at the hold period 2T (thesis §4.6). The route returned it
/// at 2T: the refinement then fitted it to the records' T steps (initial
/// cost 0.97 against 0.011 for the model at T on a CLI record) and
/// `validate` refused the record ("base period 1 s differs from the
/// model's 2 s"). The model now comes at T (ZOH conversion, said in the
/// diagnostics) and is close to the plant.
#[test]
fn a_held_input_record_gives_a_model_at_the_base_period() {
    let truth = issue_plant();
    let data = multirate_record(&truth, 12_000, &[2, 4], 2, 5);
    let records = [Record::new(data.clone())];
    let fit = identify(&records, &WorkflowOptions::default()).expect("identify");
    let d = &fit.file.diagnostics;
    assert_eq!(fit.file.model.ts(), Some(1.0), "{d}");
    assert!(
        d["base_period_conversion"]
            .as_str()
            .is_some_and(|s| s.contains("input hold period 2 s")),
        "{d}"
    );
    let v = lifted_lti::validate(&fit.file.model, &data, &Default::default()).expect("validate");
    for o in &v.outputs {
        // 10 % output noise: about 90 % at best.
        assert!(o.fit > 85.0, "{}: {} {d}", o.name, o.fit);
    }
    let err = fr_error(&fit.file.model, &truth);
    assert!(err < 0.06, "FR error {err}: {d}");
}

/// A multirate record that does not start on a sample of its slow outputs
/// (y₁ every 3 from sample 2, y₂ every 5 from sample 4: the lab analyser
/// started later than the logger). The extraction reads C at frame time 0,
/// so the route refused it ("output 0 is not sampled at frame time 0");
/// the lifting now starts at the first instant both are sampled (14), and
/// the model is the plant's.
#[test]
fn a_multirate_record_starting_between_slow_samples_is_identified() {
    let truth = issue_plant();
    let whole = multirate_record(&truth, 6001, &[3, 5], 1, 6);
    let data = whole.slice(1..6001).expect("slice");
    assert_eq!(data.outputs()[0].offset, 2);
    let fit = identify(&[Record::new(data)], &WorkflowOptions::default()).expect("identify");
    let d = &fit.file.diagnostics;
    assert!(
        d["lifting_start"]
            .as_str()
            .is_some_and(|s| s.contains("starts at sample 14")),
        "{d}"
    );
    let err = fr_error(&fit.file.model, &truth);
    assert!(err < 0.06, "FR error {err}: {d}");
}

/// A multirate record (y₁ every sample, y₂ every 3) of a lightly damped
/// second-order plant with outputs of very different scales: the
/// singular-value gap of the lifted step picks its largest order (10), whose
/// extracted fast model is unstable; the route refused the record then
/// ("extracted fast model is unstable"). The default automatic order is now
/// chosen by the held-out fit of the last third (the plant's order 2, the
/// curve in the diagnostics); with the gap asked for, the channels' scaling
/// makes its choice the plant's order.
#[test]
fn a_multirate_automatic_order_is_chosen_on_held_out_data_and_stable() {
    let a = DMatrix::from_row_slice(2, 2, &[0.78, 0.14, -0.37, 0.92]);
    let b = DMatrix::from_row_slice(2, 1, &[0.062, 0.097]);
    let c = DMatrix::from_row_slice(2, 2, &[0.0122, -0.004, -2.82, 0.48]);
    let truth = StateSpace::new(a, b, c, DMatrix::zeros(2, 1), Some(1.0)).expect("plant");
    let data = multirate_record(&truth, 6000, &[1, 3], 1, 3);
    let records = [Record::new(data)];
    let fit = identify(&records, &WorkflowOptions::default()).expect("identify");
    let d = &fit.file.diagnostics;
    assert_eq!(d["stability"]["stable"], true, "{d}");
    assert_eq!(fit.order, 2, "{d}");
    let sel = &d["structure_selection"];
    assert_eq!(sel["order"], 2, "{d}");
    let curve = sel["candidates"].as_array().expect("curve");
    assert_eq!(curve.len(), 10, "{d}");
    // The held-out fit of order 2 is high (10 % noise: about 90 %).
    assert!(curve[1]["fit"].as_f64().is_some_and(|f| f > 80.0), "{d}");
    // Any bound the caller gives is cut at the identifiable orders,
    // (f − 1) p̄ = 9 · 4 here (it ran an identification per order up to
    // 1e6: found by fuzzing, 28 s on a 300-row record).
    let mut opts = WorkflowOptions::default();
    opts.identification.max_order = 1_000_000;
    let fit = identify(&records, &opts).expect("identify");
    let curve = &fit.file.diagnostics["structure_selection"]["candidates"];
    assert_eq!(curve.as_array().map(Vec::len), Some(36), "{curve}");
    // The gap asked for: on channels of unit standard deviation (the
    // workflow's channel scaling) its largest gap is the plant's order 2,
    // stable; on the raw channels, 200-fold apart, it was order 10 and
    // unstable, passed over for the next stable order of its ranking.
    let mut opts = WorkflowOptions::default();
    opts.identification.order_criterion = OrderCriterion::Gap;
    let fit = identify(&records, &opts).expect("identify");
    let d = &fit.file.diagnostics;
    assert_eq!(d["stability"]["stable"], true, "{d}");
    assert_eq!(fit.order, 2, "{d}");
    assert_eq!(d["order_selection"]["suggested_order"], 2, "{d}");
}

/// The issue's multirate plant at 15 000 samples (over the default
/// refinement's 1e4 samples, so a large order is not refined): the
/// unrefined models' held-out fit kept rising past the true order. On
/// seeds 1–14 of this generator the curve alone chose orders 4–10 with FR
/// errors up to 0.087 (8 of 14 above 0.02; seeds 1, 6, 7 below: orders
/// 8, 6, 9, errors 0.053, 0.087, 0.076); judged by the refined models of
/// the shortlist, orders 4–5 with errors 0.003–0.007 on all 14. 0.02 is
/// three times the worst of those and a quarter of the over-fitted picks'.
/// One seed, 6 (the curve's worst pick): seeds 1 and 7 (the same
/// over-fitting, 0.053 and 0.076) ran here too until session 42 and were
/// dropped for CI time (13 s each).
#[test]
fn a_multirate_order_is_judged_by_its_refined_models() {
    let truth = issue_plant();
    let seed = 6;
    let data = multirate_record(&truth, 15_000, &[3, 5], 1, seed);
    let fit = identify(&[Record::new(data)], &WorkflowOptions::default()).expect("identify");
    let d = &fit.file.diagnostics;
    let err = fr_error(&fit.file.model, &truth);
    assert!(
        err < 0.02,
        "seed {seed}: order {}, FR error {err}: {d}",
        fit.order
    );
    assert!(
        d["structure_selection"]["refined_shortlist"]["candidates"].is_array(),
        "{d}"
    );
}

/// The issue's multirate plant with its slow output y₂ logged in units 1e6
/// times smaller (an analyser in other units): the same order and the same
/// model in the data's units, and the lifted model of the details scaled
/// back with it. Before the workflow scaled the channels of multirate
/// records this record got order 3 and a frequency-response error 15 times
/// larger (0.074 against 0.005, 12 000 samples).
#[test]
fn a_multirate_model_does_not_depend_on_the_outputs_units() {
    let truth = issue_plant();
    let data = multirate_record(&truth, 12_000, &[3, 5], 1, 3);
    let mut y = data.y().clone();
    y.column_mut(1).iter_mut().for_each(|v| *v *= 1e-6);
    let small = Dataset::new(
        1.0,
        data.u().clone(),
        y,
        data.inputs().to_vec(),
        data.outputs().to_vec(),
    )
    .expect("dataset");
    let opts = WorkflowOptions::default();
    let a = identify(&[Record::new(data)], &opts).expect("identify");
    let b = identify(&[Record::new(small)], &opts).expect("identify small units");
    assert_eq!(a.order, b.order);
    let back = |m: &StateSpace| {
        let mut c = m.c().clone();
        let mut d = m.d().clone();
        c.row_mut(1).iter_mut().for_each(|v| *v *= 1e6);
        d.row_mut(1).iter_mut().for_each(|v| *v *= 1e6);
        StateSpace::new(m.a().clone(), m.b().clone(), c, d, m.ts()).expect("model")
    };
    let diff = fr_error(&back(&b.file.model), &a.file.model);
    assert!(diff < 1e-6, "fast models differ by {diff}");
    assert!(fr_error(&a.file.model, &truth) < 0.06);
    // The lifted model: its rows of y₂ (channel 1) in the small units.
    let (la, lb) = (
        a.details.lifted.as_ref().expect("lifted"),
        b.details.lifted.as_ref().expect("lifted"),
    );
    let (_, outs) = b.details.lifted_channels.as_ref().expect("channels");
    let mut c = lb.c().clone();
    let mut d = lb.d().clone();
    for (i, &ch) in outs.iter().enumerate() {
        if ch == 1 {
            c.row_mut(i).iter_mut().for_each(|v| *v *= 1e6);
            d.row_mut(i).iter_mut().for_each(|v| *v *= 1e6);
        }
    }
    let lb = StateSpace::new(lb.a().clone(), lb.b().clone(), c, d, lb.ts()).expect("lifted");
    let diff = fr_error(&lb, la);
    assert!(diff < 1e-6, "lifted models differ by {diff}");
}

/// The multirate IV route's automatic order: the singular-value gap of the
/// lifted R₂₂ chose order 2 on the issue's plant (FR error ≈ 0.2 against
/// the truth on three records of 6000 and 3e4 samples); now the held-out
/// fit of the last third, as the multirate subspace route (on 6000 samples
/// at a shorter α for the first two thirds, which do not support α = 6).
#[test]
fn the_multirate_iv_route_chooses_its_order_on_held_out_data() {
    let truth = issue_plant();
    let data = multirate_record(&truth, 6000, &[3, 5], 1, 3);
    let mut opts = WorkflowOptions::default();
    opts.identification.method = Method::Iv;
    let fit = identify(&[Record::new(data.clone())], &opts).expect("identify");
    let d = &fit.file.diagnostics;
    let sel = &d["structure_selection"];
    assert_eq!(sel["order"].as_u64(), Some(fit.order as u64), "{d}");
    assert_eq!(fit.order, 4, "{d}");
    assert!(
        sel["candidates"].as_array().is_some_and(|c| c.len() == 10),
        "{d}"
    );
    let err = fr_error(&fit.file.model, &truth);
    // The issue's multirate bound.
    assert!(err < 0.06, "FR error {err}: {d}");
    // The gap rule, still there on request, misses it on this record.
    opts.identification.order_criterion = OrderCriterion::Gap;
    let gap = identify(&[Record::new(data)], &opts).expect("identify");
    let gap_err = fr_error(&gap.file.model, &truth);
    assert!(
        gap.order < 4 && gap_err > 0.1,
        "order {} FR error {gap_err}",
        gap.order
    );
}

/// A maximum order far beyond the identifiable (`--max-order` takes up to
/// 1e6): the multirate routes' held-out curves list only the orders the
/// horizon identifies, (f − 1) p̄ for p̄ lifted outputs per frame (here
/// 5 + 3 = 8); the loop ran to the given maximum, one failed
/// identification per order (a fuzz input hung there).
#[test]
fn the_multirate_held_out_orders_stop_at_the_identifiable() {
    let truth = issue_plant();
    let data = multirate_record(&truth, 6000, &[3, 5], 1, 5);
    for method in [Method::N4sid, Method::Iv] {
        let mut opts = WorkflowOptions::default();
        opts.identification.method = method;
        opts.identification.max_order = 1_000_000;
        opts.refinement.refine = Refine::None;
        let fit = identify(&[Record::new(data.clone())], &opts).expect("identify");
        let d = &fit.file.diagnostics;
        let candidates = d["structure_selection"]["candidates"]
            .as_array()
            .map_or(0, Vec::len);
        // The horizon (N4SID: the longest 400 frames support, ≤ 10; IV:
        // α = 6) bounds the orders: at most (10 − 1)·8 = 72.
        assert!(
            (1..=72).contains(&candidates),
            "{method:?}: {candidates} {d}"
        );
    }
}

/// A plant with a direct feedthrough (y = 0.3 x + 0.5 u, pole 0.7), its
/// output measured every fifth sample: the lifted and refitted starts fix
/// D = 0 (multirate records, 21 % fit on the measured samples); a model
/// with D free simulates them far better and the BIC on the measured
/// samples keeps it (`diagnostics.multirate_start.as_identified`): the
/// route's (A, C) with (B, D) refitted on the measured samples (D within
/// 0.05 of 0.5; the interpolated record's own model with D free, 47.6 %,
/// estimated it 0.18: the interpolation averages two samples). With
/// `--feedthrough false` no model with D competes.
#[test]
fn a_multirate_feedthrough_the_samples_support_is_kept() {
    let n = 3000;
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let u = DMatrix::from_fn(
        n,
        1,
        |_, _| {
            if rng.random::<f64>() < 0.5 { -1.0 } else { 1.0 }
        },
    );
    let mut x = 0.0;
    let y = DMatrix::from_fn(n, 1, |t, _| {
        let out = 0.3 * x + 0.5 * u[(t, 0)] + 0.02 * (rng.random::<f64>() - 0.5);
        x = 0.7 * x + u[(t, 0)];
        if t % 5 == 0 { out } else { f64::NAN }
    });
    let rec = [Record::new(multirate_dataset(u, y, 1, &[5]))];
    let mut o = WorkflowOptions::default();
    o.identification.order = Order::Fixed(1);
    let fit = identify(&rec, &o).expect("identify");
    let d = &fit.file.diagnostics;
    let entry = &d["multirate_start"]["as_identified"];
    assert_eq!(entry["kept"], true, "{d}");
    assert_eq!(entry["feedthrough"], true, "{d}");
    let dhat = fit.file.model.d()[(0, 0)];
    assert!((dhat - 0.5).abs() < 0.05, "D = {dhat}: {d}");
    o.identification.feedthrough = Some(false);
    let fit = identify(&rec, &o).expect("identify, D = 0");
    assert!(fit.file.model.d().iter().all(|v| *v == 0.0));
}

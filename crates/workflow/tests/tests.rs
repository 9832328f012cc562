//! The workflow crate's integration tests: the default options recover a
//! known plant; the streamed route (a record read in blocks) gives the
//! in-memory route's model; the refinement starts from exactly the plain
//! identification's model; options round-trip through JSON; bad options
//! are named; the per-method options (PBSID's future horizon and
//! feedthrough, IV's past instrument rows) reach their routes; multirate
//! closed loops come back from the lifted IV route with their set-points
//! (module `multirate_closed_loop`, issue 46).

use lifted_lti::{Dataset, StateSpace};
use lifted_workflow::{
    BlockSink, Detrend, Error, Estimator, Method, Order, OrderCriterion, Pass, Record,
    RecordSource, Refine, SubspaceCache, WorkflowOptions, identify, identify_cached,
    identify_streamed,
};
use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

mod multirate_closed_loop;
mod polynomial;

/// 2 inputs, 2 outputs, order 3: poles 0.9 and 0.7 ± 0.3j.
fn plant() -> StateSpace {
    let a = DMatrix::from_row_slice(3, 3, &[0.9, 0.0, 0.0, 0.0, 0.7, -0.3, 0.0, 0.3, 0.7]);
    let b = DMatrix::from_row_slice(3, 2, &[1.0, 0.2, -0.5, 1.0, 0.3, 0.7]);
    let c = DMatrix::from_row_slice(2, 3, &[1.0, 0.5, -0.3, 0.0, 0.7, 0.4]);
    let d = DMatrix::from_row_slice(2, 2, &[0.1, 0.0, 0.0, 0.2]);
    StateSpace::new(a, b, c, d, Some(1.0)).expect("plant")
}

/// A record of `n` samples: random binary inputs around 0.3, the plant's
/// response plus white noise (σ = `noise`) around the offsets (2, −1).
fn record(n: usize, noise: f64, seed: u64) -> (DMatrix<f64>, DMatrix<f64>) {
    record_of(&plant(), n, noise, seed, [2.0, -1.0])
}

/// [`record`] of the 2×2 model `g` around the output offsets `offsets`.
fn record_of(
    g: &StateSpace,
    n: usize,
    noise: f64,
    seed: u64,
    offsets: [f64; 2],
) -> (DMatrix<f64>, DMatrix<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let u = DMatrix::from_fn(
        n,
        2,
        |_, _| {
            if rng.random::<f64>() < 0.5 { -0.7 } else { 1.3 }
        },
    );
    let mut x = DVector::zeros(3);
    let mut y = DMatrix::zeros(n, 2);
    for k in 0..n {
        let uk = u.row(k).transpose();
        let yk = g.c() * &x + g.d() * &uk;
        for j in 0..2 {
            let e: f64 = rng.random::<f64>() - 0.5;
            y[(k, j)] = yk[j] + offsets[j] + noise * 12f64.sqrt() * e;
        }
        x = g.a() * &x + g.b() * &uk;
    }
    (u, y)
}

fn dataset(u: &DMatrix<f64>, y: &DMatrix<f64>) -> Dataset {
    Dataset::single_rate(1.0, u.clone(), y.clone()).expect("dataset")
}

/// Sorted pole moduli and arguments of a model.
fn poles(m: &StateSpace) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = m
        .poles()
        .expect("poles")
        .iter()
        .map(|z| (z.norm(), z.arg().abs()))
        .collect();
    p.sort_by(|a, b| a.partial_cmp(b).expect("finite"));
    p
}

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

/// The record of a test served in blocks of 700 rows, as a file reader
/// would.
struct Blocks {
    u: DMatrix<f64>,
    y: DMatrix<f64>,
    passes: usize,
    /// Rows per block (700 unless set).
    rows: usize,
}

impl Blocks {
    fn of(u: &DMatrix<f64>, y: &DMatrix<f64>) -> Self {
        Blocks {
            u: u.clone(),
            y: y.clone(),
            passes: 0,
            rows: 700,
        }
    }
}

impl RecordSource for Blocks {
    fn channels(&self) -> (usize, usize) {
        (self.u.ncols(), self.y.ncols())
    }

    fn pass(&mut self, push: &mut BlockSink<'_>) -> lifted_workflow::Result<Pass> {
        self.passes += 1;
        let n = self.u.nrows();
        let mut k = 0;
        while k < n {
            let r = self.rows.min(n - k);
            push(
                &self.u.rows(k, r).into_owned(),
                &self.y.rows(k, r).into_owned(),
            )?;
            k += r;
        }
        Ok(Pass {
            rows: n,
            ts: 1.0,
            multirate: false,
        })
    }

    fn load(&mut self) -> lifted_workflow::Result<Dataset> {
        Ok(dataset(&self.u, &self.y))
    }
}

#[test]
fn the_streamed_route_gives_the_in_memory_model() {
    streamed_equals_in_memory(5000, [1.0, 1.0]);
    // Longer than the rows the channel scales come from (the first pass
    // holds its blocks back until it has them), channels in other units.
    streamed_equals_in_memory(12_000, [1e-5, 3e4]);
}

/// Order 3, horizon 10, shift invariance, on `threads` threads: the
/// structure both routes take.
fn fixed_structure(threads: usize) -> WorkflowOptions {
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(3);
    opts.identification.horizon = Some(10);
    opts.identification.estimator = Estimator::Shift;
    opts.identification.order_criterion = OrderCriterion::Gap;
    opts.identification.threads = Some(threads);
    opts
}

/// The frequency responses of `a` and `b` agree to 1e-8 of their size:
/// the same estimator on the same samples, the compressions summed in
/// another order (rounding amplified by the SVD; a lost block or another
/// (B, D) route moves them ≥ 1e-4).
fn same_response(a: &StateSpace, b: &StateSpace) {
    let w = [0.0, 0.3, 1.0, 2.5];
    let (ga, gb) = (a.freqresp(&w).expect("G"), b.freqresp(&w).expect("G"));
    for (k, (p, q)) in ga.iter().zip(&gb).enumerate() {
        let err = (p - q).iter().map(|z| z.norm()).fold(0.0, f64::max);
        let scale = p.iter().map(|z| z.norm()).fold(1.0, f64::max);
        assert!(err < 1e-8 * scale, "w = {}: {err}", w[k]);
    }
}

fn streamed_equals_in_memory(n: usize, output_units: [f64; 2]) {
    let (u, mut y) = record(n, 0.05, 2);
    for (j, s) in output_units.iter().enumerate() {
        y.column_mut(j).iter_mut().for_each(|v| *v *= s);
    }
    let opts = fixed_structure(1);
    let mem = identify(&[Record::new(dataset(&u, &y))], &opts).expect("in memory");
    let mut src = Blocks::of(&u, &y);
    let streamed = identify_streamed(&mut src, &opts)
        .expect("streamed")
        .expect("a single-rate record streams");
    // One pass: the first pass kept the small record for the regression.
    assert_eq!(src.passes, 1, "n = {n}");
    // Blocks of 700 against the in-memory chunks.
    same_response(&mem.file.model, &streamed.file.model);
    let (oa, ob) = (
        mem.file.operating_point.as_ref().expect("op"),
        streamed.file.operating_point.as_ref().expect("op"),
    );
    for (p, q) in oa.y0.iter().zip(&ob.y0) {
        assert!((p - q).abs() < 1e-9 * p.abs().max(1.0), "{p} vs {q}");
    }
}

/// Two threads, blocks of 65 536 rows: the first pass reads ahead on its
/// own thread, the regression scans each block's ranges on both threads in
/// turn; the model is the one thread's in memory (to rounding).
#[test]
fn the_streamed_route_on_two_threads_gives_the_in_memory_model() {
    let (u, y) = record(150_000, 0.05, 4);
    let mem = identify(&[Record::new(dataset(&u, &y))], &fixed_structure(1)).expect("in memory");
    let opts = fixed_structure(2);
    let mut src = Blocks {
        rows: 65_536,
        ..Blocks::of(&u, &y)
    };
    let streamed = identify_streamed(&mut src, &opts)
        .expect("streamed")
        .expect("a single-rate record streams");
    same_response(&mem.file.model, &streamed.file.model);
}

/// A block the identification refuses while the reading thread is ahead:
/// the reading stops and the refusal is what comes back (no hang, no
/// other error in its place).
#[test]
fn a_refused_block_stops_the_reading_ahead() {
    let (u, mut y) = record(40_000, 0.05, 5);
    y[(30_000, 1)] = f64::INFINITY;
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(3);
    opts.identification.horizon = Some(10);
    opts.identification.threads = Some(2);
    let mut src = Blocks {
        rows: 4096,
        ..Blocks::of(&u, &y)
    };
    let Err(e) = identify_streamed(&mut src, &opts) else {
        panic!("an infinite output is refused");
    };
    let e = e.to_string();
    // Located in the record, not in its block of 4096 rows.
    assert!(
        e.contains("y contains a non-finite value at sample 30000, channel 1"),
        "{e}"
    );
    assert!(!e.contains("reading stopped"), "{e}");
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
fn the_refinement_starts_from_the_plain_model() {
    let (u, y) = record(1500, 0.1, 3);
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(3);
    opts.refinement.refine = Refine::None;
    let plain = identify(&[Record::new(dataset(&u, &y))], &opts).expect("plain");
    opts.refinement.refine = Refine::Pem;
    let refined = identify(&[Record::new(dataset(&u, &y))], &opts).expect("refined");
    let report = &refined.file.diagnostics["refinement"];
    // The report's initial cost is that of the plain model on the same
    // deviations: refining it again from its own start reproduces it.
    assert!(report.is_object(), "{}", refined.file.diagnostics);
    // Same structure selected, same start.
    assert_eq!(
        plain.file.diagnostics["structure_selection"]["horizon"],
        refined.file.diagnostics["structure_selection"]["horizon"]
    );
    assert_eq!(plain.singular_values, refined.singular_values);
    assert_eq!(plain.x0, refined.x0);
    assert_eq!(plain.file.operating_point, refined.file.operating_point);

    // The structure left to the held-out selection, on short noisy records
    // whose folds give unstable models at some candidates: `--refine pem`
    // (which re-estimates an unstable start by the zero-padded shift) must
    // not score the candidates differently — same ranking, same structure,
    // same start as `--refine none`.
    for seed in 1..=4 {
        let (u, y) = record(300, 0.6, seed);
        let records = [Record::new(dataset(&u, &y))];
        let mut opts = WorkflowOptions::default();
        opts.refinement.refine = Refine::None;
        let plain = identify(&records, &opts).expect("plain");
        opts.refinement.refine = Refine::Pem;
        let refined = identify(&records, &opts).expect("refined");
        let (p, r) = (
            &plain.file.diagnostics["structure_selection"],
            &refined.file.diagnostics["structure_selection"],
        );
        assert_eq!(p["candidates"], r["candidates"], "seed {seed}");
        assert_eq!(plain.order, refined.order, "seed {seed}");
        if plain.file.diagnostics["stability"]["stable"] == true {
            assert_eq!(plain.x0, refined.x0, "seed {seed}");
            assert_eq!(
                plain.singular_values, refined.singular_values,
                "seed {seed}"
            );
        }
    }
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

/// Default options with the structure fixed (horizon 10, shift
/// invariance) and no refinement: the cached runs' tests.
fn fixed_structure_unrefined() -> WorkflowOptions {
    let mut opts = WorkflowOptions::default();
    opts.identification.horizon = Some(10);
    opts.identification.estimator = Estimator::Shift;
    opts.refinement.refine = Refine::None;
    opts
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

#[test]
fn the_default_refines_short_records_and_says_so() {
    let (u, y) = record(3000, 0.1, 7);
    let records = [Record::new(dataset(&u, &y))];
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(3);
    let auto = identify(&records, &opts).expect("auto");
    let d = &auto.file.diagnostics;
    // Fewer than 1e4 samples and a stable estimate: refined by PEM.
    assert!(
        d["refinement_decision"]
            .as_str()
            .is_some_and(|s| s.starts_with("refined by the prediction error")),
        "{d}"
    );
    assert_eq!(d["refinement"]["cost"], serde_json::json!("Prediction"));
    // The same run with `Refine::Pem` asked explicitly gives the same model.
    opts.refinement.refine = Refine::Pem;
    let pem = identify(&records, &opts).expect("pem");
    assert_eq!(auto.file.model, pem.file.model);
    // `Refine::None`: no refinement, no decision.
    opts.refinement.refine = Refine::None;
    let none = identify(&records, &opts).expect("none");
    assert!(none.file.diagnostics.get("refinement").is_none());
    assert!(none.file.diagnostics.get("refinement_decision").is_none());
}

/// Issue 48: the work budgets are parameters. Below the samples budget the
/// default refines; with both refinement budgets lowered under the
/// record's size and work it does not, and says which bound; with the gain
/// check's samples budget under the record the subspace step's gain is
/// kept. The values used are in `diagnostics.budgets`; bad ones are
/// refused naming the budget.
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
    assert!(d.get("kalman_gain_route").is_none(), "{d}");
    assert_eq!(d["budgets"]["auto_refine_samples"], 1000);
    assert_eq!(d["budgets"]["gain_check_samples"], 2999);
    // The subspace step's gain kept instead of the checked one.
    assert_ne!(
        auto.file.kalman_gain_matrix().expect("gain"),
        tight.file.kalman_gain_matrix().expect("gain")
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

/// A multirate record of `truth` driven by `n` samples of random binary
/// input held `hold` samples (seed `seed`): output j measured every
/// `periods[j]` samples (phase 0), with uniform noise of 10 % of its
/// standard deviation, NaN between.
fn multirate_record(
    truth: &StateSpace,
    n: usize,
    periods: &[usize],
    hold: usize,
    seed: u64,
) -> Dataset {
    let (n_u, n_y) = (truth.n_inputs(), truth.n_outputs());
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut u = DMatrix::from_fn(
        n,
        n_u,
        |_, _| {
            if rng.random::<f64>() < 0.5 { -1.0 } else { 1.0 }
        },
    );
    for k in 0..n {
        let held = k - k % hold;
        for i in 0..n_u {
            u[(k, i)] = u[(held, i)];
        }
    }
    let clean = truth.lsim(&u, None, None).expect("lsim").y;
    let mut y = clean.clone();
    for (j, &period) in periods.iter().enumerate().take(n_y) {
        let col = clean.column(j);
        let sd = (col.iter().map(|v| v * v).sum::<f64>() / n as f64
            - (col.sum() / n as f64).powi(2))
        .sqrt();
        for k in 0..n {
            // Uniform noise of standard deviation 0.1 sd.
            let e = (rng.random::<f64>() - 0.5) * 12f64.sqrt();
            y[(k, j)] = if k % period == 0 {
                clean[(k, j)] + 0.1 * sd * e
            } else {
                f64::NAN
            };
        }
    }
    multirate_dataset(u, y, hold, periods)
}

/// A dataset of inputs u1… held `hold` base periods and outputs y1…
/// measured every `periods[j]` (NaN between), base period 1 s.
fn multirate_dataset(u: DMatrix<f64>, y: DMatrix<f64>, hold: usize, periods: &[usize]) -> Dataset {
    use lifted_lti::{InputChannel, OutputChannel};
    let n_u = u.ncols();
    Dataset::new(
        1.0,
        u,
        y,
        (1..=n_u)
            .map(|i| InputChannel::new(format!("u{i}"), hold))
            .collect(),
        periods
            .iter()
            .enumerate()
            .map(|(j, &p)| OutputChannel::new(format!("y{}", j + 1), p, 0))
            .collect(),
    )
    .expect("dataset")
}

/// The plant of the issue's multirate case: 2×2, poles 0.95 ± 0.1j, 0.85
/// and 0.7.
fn issue_plant() -> StateSpace {
    let a = DMatrix::from_row_slice(
        4,
        4,
        &[
            0.95, 0.1, 0.0, 0.0, //
            -0.1, 0.95, 0.0, 0.0, //
            0.0, 0.0, 0.85, 0.0, //
            0.0, 0.0, 0.0, 0.7,
        ],
    );
    let b = DMatrix::from_row_slice(4, 2, &[1.0, 0.2, 0.3, 0.8, 0.5, -0.6, 0.4, 1.0]);
    let c = DMatrix::from_row_slice(2, 4, &[1.0, 0.0, 0.6, 0.3, 0.2, 0.7, -0.4, 0.9]);
    StateSpace::new(a, b, c, DMatrix::zeros(2, 2), Some(1.0)).expect("plant")
}

/// Relative frequency-response error ‖G − G₀‖/‖G₀‖ of `model` against
/// `truth` over 200 frequencies in (0, π).
fn fr_error(model: &StateSpace, truth: &StateSpace) -> f64 {
    let omega: Vec<f64> = (0..200)
        .map(|i| 1e-3 + i as f64 * (std::f64::consts::PI / 200.0))
        .collect();
    let want = truth.freqresp(&omega).expect("truth");
    let got = model.freqresp(&omega).expect("model");
    let (mut num, mut den) = (0.0, 0.0);
    for (g, w) in got.iter().zip(&want) {
        num += (g - w).norm_squared();
        den += w.norm_squared();
    }
    (num / den).sqrt()
}

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

/// A SISO record whose input is drawn every `block` samples (logged every
/// sample: hold 1) and whose output is measured every `period` samples,
/// with white noise of `noise` times the output's standard deviation.
fn slow_input_record(
    truth: &StateSpace,
    n: usize,
    block: usize,
    period: usize,
    noise: f64,
    seed: u64,
) -> Dataset {
    use lifted_lti::{InputChannel, OutputChannel};
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut level = 0.0;
    let u = DMatrix::from_fn(n, 1, |t, _| {
        if t % block == 0 {
            level = if rng.random::<f64>() < 0.5 { -1.0 } else { 1.0 };
        }
        level
    });
    let clean = truth.lsim(&u, None, None).expect("lsim").y;
    let col = clean.column(0);
    let sd =
        (col.iter().map(|v| v * v).sum::<f64>() / n as f64 - (col.sum() / n as f64).powi(2)).sqrt();
    let y = DMatrix::from_fn(n, 1, |t, _| {
        let e = (rng.random::<f64>() - 0.5) * 12f64.sqrt();
        if t % period == 0 {
            clean[(t, 0)] + noise * sd * e
        } else {
            f64::NAN
        }
    });
    Dataset::new(
        1.0,
        u,
        y,
        vec![InputChannel::new("u1", 1)],
        vec![OutputChannel::new("y1", period, 0)],
    )
    .expect("dataset")
}

/// A second-order plant with a resonance (poles 0.97 e^{±0.25j}) and a
/// real pole 0.8.
fn resonant_plant() -> StateSpace {
    let (r, w) = (0.97f64, 0.25f64);
    let a = DMatrix::from_row_slice(
        3,
        3,
        &[
            r * w.cos(),
            r * w.sin(),
            0.0,
            -r * w.sin(),
            r * w.cos(),
            0.0,
            0.0,
            0.0,
            0.8,
        ],
    );
    let b = DMatrix::from_row_slice(3, 1, &[0.3, 0.2, 0.5]);
    let c = DMatrix::from_row_slice(1, 3, &[1.0, 0.0, 0.6]);
    StateSpace::new(a, b, c, DMatrix::zeros(1, 1), Some(1.0)).expect("plant")
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

/// Two lightly damped modes (poles 0.98 e^{±0.9j} and 0.95 e^{±0.3j}), as
/// a flexible arm.
fn flexible_plant() -> StateSpace {
    let block = |r: f64, w: f64| [r * w.cos(), r * w.sin(), -r * w.sin(), r * w.cos()];
    let (p, q) = (block(0.98, 0.9), block(0.95, 0.3));
    let a = DMatrix::from_row_slice(
        4,
        4,
        &[
            p[0], p[1], 0.0, 0.0, //
            p[2], p[3], 0.0, 0.0, //
            0.0, 0.0, q[0], q[1], //
            0.0, 0.0, q[2], q[3],
        ],
    );
    let b = DMatrix::from_row_slice(4, 1, &[0.2, 0.1, 0.3, 0.2]);
    let c = DMatrix::from_row_slice(1, 4, &[1.0, 0.0, 1.0, 0.0]);
    StateSpace::new(a, b, c, DMatrix::zeros(1, 1), Some(1.0)).expect("plant")
}

/// `data` with a drift added to its measured outputs: an AR(1) disturbance
/// (pole 0.99, unit variance) times `level` times each output's standard
/// deviation.
fn with_drift(data: &Dataset, level: f64, seed: u64) -> Dataset {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed);
    let mut y = data.y().clone();
    for j in 0..y.ncols() {
        let vals: Vec<f64> = y
            .column(j)
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect();
        let m = vals.iter().sum::<f64>() / vals.len() as f64;
        let sd = (vals.iter().map(|v| (v - m).powi(2)).sum::<f64>() / vals.len() as f64).sqrt();
        let mut v = 0.0;
        for t in 0..y.nrows() {
            let e = (rng.random::<f64>() - 0.5) * 12f64.sqrt();
            v = 0.99 * v + e * (1.0 - 0.99f64 * 0.99).sqrt();
            if y[(t, j)].is_finite() {
                y[(t, j)] += level * sd * v;
            }
        }
    }
    Dataset::new(
        data.ts(),
        data.u().clone(),
        y,
        data.inputs().to_vec(),
        data.outputs().to_vec(),
    )
    .expect("dataset")
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

/// A closed loop whose controller reacts within the sample: the plant
/// (poles 0.8 ± 0.3j, D = 0, DC gain 6.154) under the PI controller
/// u = 0.05 x_c + 0.1 (r − y), x_c⁺ = x_c + r − y, r a random binary
/// set-point switching with probability 0.1, white output noise of
/// standard deviation `noise`. Returns (u, y, r).
fn closed_loop_record(n: usize, noise: f64, seed: u64) -> [DMatrix<f64>; 3] {
    let a = DMatrix::from_row_slice(2, 2, &[1.6, -0.73, 1.0, 0.0]);
    let c = [0.5, 0.3];
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut u, mut y, mut r) = (
        DMatrix::zeros(n, 1),
        DMatrix::zeros(n, 1),
        DMatrix::zeros(n, 1),
    );
    let (mut x, mut xc, mut level) = (DVector::<f64>::zeros(2), 0.0, 1.0);
    for t in 0..n {
        if rng.random::<f64>() < 0.1 {
            level = -level;
        }
        let v = noise * 12f64.sqrt() * (rng.random::<f64>() - 0.5);
        let yt = c[0] * x[0] + c[1] * x[1] + v;
        let e = level - yt;
        let ut = 0.05 * xc + 0.1 * e;
        xc += e;
        (u[(t, 0)], y[(t, 0)], r[(t, 0)]) = (ut, yt, level);
        x = &a * &x + DVector::from_column_slice(&[ut, 0.0]);
    }
    [u, y, r]
}

#[test]
fn the_closed_loop_iv_keeps_d_zero_unless_asked() {
    // The noise reaches u within the sample through the controller's
    // proportional term, so an estimated D takes it: with D free the
    // default refinement made D = −2.7 and the DC gain 5.42 against 6.154
    // (the Python new-user pass, 2026-11-27; the bias did not shrink from
    // 4e4 samples on). D = 0 by default, as PBSID's.
    let [u, y, r] = closed_loop_record(20_000, 0.3, 4);
    let rec = [Record {
        data: dataset(&u, &y),
        instrument: Some(r),
    }];
    let mut o = WorkflowOptions::default();
    o.identification.method = Method::Iv;
    o.identification.order = Order::Fixed(2);
    let fit = identify(&rec, &o).expect("identify");
    let m = &fit.file.model;
    assert!(m.d().iter().all(|&v| v == 0.0), "D = 0 by default");
    let dc = (m.c()
        * (DMatrix::identity(2, 2) - m.a())
            .try_inverse()
            .expect("I − A")
        * m.b())[0];
    // 6.154 the truth; 2 % is several times the spread over seeds at this
    // length (the D-free refinement missed by 12 %).
    assert!((dc / 6.153_846 - 1.0).abs() < 0.02, "DC gain {dc}");
    assert!(
        fit.file.diagnostics["feedthrough"]
            .as_str()
            .is_some_and(|s| s.starts_with("D = 0")),
        "{}",
        fit.file.diagnostics
    );
    o.identification.feedthrough = Some(true);
    let free = identify(&rec, &o).expect("identify with D");
    assert!(free.file.model.d()[0] != 0.0);
}

/// 1 input, 1 output, poles 0.9 ± 0.2j, white-noise input, output noise
/// of standard deviation `noise` (output RMS ≈ 0.6).
fn siso_record(n: usize, noise: f64, seed: u64) -> (DMatrix<f64>, DMatrix<f64>) {
    let a = DMatrix::from_row_slice(2, 2, &[0.9, 0.2, -0.2, 0.9]);
    let b = DMatrix::from_row_slice(2, 1, &[1.0, 0.5]);
    let c = DMatrix::from_row_slice(1, 2, &[0.3, 0.4]);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut g = || -> f64 { 12f64.sqrt() * (rng.random::<f64>() - 0.5) };
    let u = DMatrix::from_fn(n, 1, |_, _| g());
    let mut y = DMatrix::zeros(n, 1);
    let mut x = DVector::zeros(2);
    for t in 0..n {
        y[(t, 0)] = (&c * &x)[0] + noise * g();
        x = &a * &x + &b * u.row(t).transpose();
    }
    (u, y)
}

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
fn a_refinement_asked_for_and_not_kept_is_said() {
    // `--refine oe` on a record the subspace model already fits to its
    // noise: the held-out blocks do not tell the two apart, the identified
    // model is written, and a warning says so (the command printed only
    // "wrote m.json": the same model as `--refine none`, without a word).
    let (u, y) = siso_record(1200, 0.01, 2);
    let records = [Record::new(dataset(&u, &y))];
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(2);
    opts.refinement.refine = Refine::Oe;
    let fit = identify(&records, &opts).expect("identify");
    let d = &fit.file.diagnostics;
    assert_eq!(d["refinement"]["kept"], serde_json::json!("Initial"), "{d}");
    let said = d["warnings"].as_array().is_some_and(|w| {
        w.iter().any(|m| {
            m.as_str()
                .is_some_and(|m| m.contains("refinement asked for was not kept"))
        })
    });
    assert!(said, "{d}");
    // The default refinement steps aside without a warning.
    opts.refinement.refine = Refine::Auto;
    let d = identify(&records, &opts)
        .expect("identify")
        .file
        .diagnostics;
    assert!(!d.to_string().contains("asked for was not kept"), "{d}");
}

#[test]
fn the_refinement_is_judged_on_held_out_blocks() {
    // Heavy output noise and a short horizon: the subspace models of the
    // six folds are poor, their refinements near the noise floor, so the
    // held-out blocks decide (by far more than the 3-point margin) and the
    // refinement is kept.
    let (u, y) = siso_record(1200, 0.5, 2);
    let records = [Record::new(dataset(&u, &y))];
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(2);
    opts.identification.horizon = Some(3);
    let fit = identify(&records, &opts).expect("identify");
    let d = &fit.file.diagnostics;
    let j = &d["refinement_judge"];
    assert_eq!(j["decided_by"], serde_json::json!("held-out blocks"), "{d}");
    let held = &j["held_out"];
    let (i, r) = (
        held["initial_fit"].as_f64().unwrap(),
        held["refined_fit"].as_f64().unwrap(),
    );
    assert!(r > i + 20.0, "{held}");
    assert_eq!(held["folds"], serde_json::json!(6));
    assert_eq!(d["refinement"]["kept"], serde_json::json!("Refined"), "{d}");

    // A quiet record: both fit the held-out blocks alike (within the
    // margin): no held-out evidence for the refinement, so the subspace
    // model stays (the records, which the refinement was fitted to, no
    // longer decide), and the check's numbers are still shown.
    let (u, y) = record(3000, 0.1, 7);
    let records = [Record::new(dataset(&u, &y))];
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(3);
    let fit = identify(&records, &opts).expect("identify");
    let d = &fit.file.diagnostics;
    let j = &d["refinement_judge"];
    assert_eq!(
        j["decided_by"],
        serde_json::json!(lifted_workflow::JUDGE_NOT_TOLD_APART),
        "{j}"
    );
    let held = &j["held_out"];
    let gap = held["initial_fit"].as_f64().unwrap() - held["refined_fit"].as_f64().unwrap();
    assert!(gap.abs() <= 3.0, "{j}");
    assert_eq!(d["refinement"]["kept"], serde_json::json!("Initial"), "{d}");
    let mut plain = opts.clone();
    plain.refinement.refine = Refine::None;
    let unrefined = identify(&records, &plain).expect("identify");
    assert_eq!(fit.file.model, unrefined.file.model);

    // Beyond 2e4 samples the records decide without a check.
    let (u, y) = record(20_001, 0.1, 8);
    let records = [Record::new(dataset(&u, &y))];
    opts.refinement.refine = Refine::Pem;
    let fit = identify(&records, &opts).expect("identify");
    let j = &fit.file.diagnostics["refinement_judge"];
    assert_eq!(j["decided_by"], serde_json::json!("records"), "{j}");
    assert!(j["rule"].as_str().unwrap().contains("20000"), "{j}");
    assert!(j.get("held_out").is_none(), "{j}");
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
fn the_default_refinement_skips_a_refinement_over_the_work_bound() {
    // One PEM iteration over the work bound: `--refine pem` refuses it,
    // but the default (`auto`) must still give the identified model (it
    // refused the whole identification before: `lifted identify --order
    // 50` on 3750 samples).
    let (u, y) = record(400, 0.02, 9);
    let records = [Record::new(dataset(&u, &y))];
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(3);
    opts.refinement.max_work = 1e4;
    let fit = identify(&records, &opts).expect("identify");
    let why = fit.file.diagnostics["refinement_decision"]
        .as_str()
        .expect("decision");
    assert!(why.contains("not refined: one iteration"), "{why}");
    opts.refinement.refine = Refine::Pem;
    let e = identify(&records, &opts).expect_err("--refine pem over the bound");
    assert!(e.to_string().contains("more than the bound"), "{e}");
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

/// The issue's multirate plant at 15 000 samples (over the default
/// refinement's 1e4 samples, so a large order is not refined): the
/// unrefined models' held-out fit kept rising past the true order. On
/// seeds 1–14 of this generator the curve alone chose orders 4–10 with FR
/// errors up to 0.087 (8 of 14 above 0.02; seeds 1, 6, 7 below: orders
/// 8, 6, 9, errors 0.053, 0.087, 0.076); judged by the refined models of
/// the shortlist, orders 4–5 with errors 0.003–0.007 on all 14. 0.02 is
/// three times the worst of those and a quarter of the over-fitted picks'.
#[test]
fn a_multirate_order_is_judged_by_its_refined_models() {
    let truth = issue_plant();
    for seed in [1, 6, 7] {
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

/// A thermal-like SISO plant of seven first-order modes (poles 0.97 … 0.1,
/// unit DC gains shrinking with speed), a binary input held for three
/// samples, drifting output noise v(t+1) = 0.9 v(t) + 0.03 e(t): singular
/// values that decay without a gap, as on real records.
fn distributed_record(n: usize, seed: u64) -> (DMatrix<f64>, DMatrix<f64>) {
    let poles = [0.97, 0.9, 0.8, 0.65, 0.5, 0.3, 0.1];
    let gains = [1.0, 0.8, 0.6, 0.5, 0.4, 0.3, 0.3];
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut u = DMatrix::zeros(n, 1);
    for k in 0..n {
        u[(k, 0)] = if k % 3 == 0 {
            if rng.random::<f64>() < 0.5 { -1.0 } else { 1.0 }
        } else {
            u[(k - 1, 0)]
        };
    }
    let mut x = [0.0; 7];
    let mut y = DMatrix::zeros(n, 1);
    let mut v = 0.0;
    for k in 0..n {
        v = 0.9 * v + 0.03 * 12f64.sqrt() * (rng.random::<f64>() - 0.5);
        y[(k, 0)] = x.iter().sum::<f64>() + v;
        for i in 0..7 {
            x[i] = poles[i] * x[i] + gains[i] * (1.0 - poles[i]) * u[(k, 0)];
        }
    }
    (u, y)
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

/// An unstable plant (pole 1.02) held by u = r − 0.5 y, identified by IV
/// with the reference r as instrument over 3000 samples: the output-error
/// regression refused the estimate ("estimated A is unstable") and the
/// route ended in an error; the model now comes back, its (B, D, x₀) from
/// the one-step predictor regression (named in the diagnostics), flagged
/// unstable.
#[test]
fn an_unstable_plant_in_a_loop_comes_back_from_the_iv_route() {
    let (u, y, r) = unstable_loop(3000, 4);
    let mut rec = Record::new(dataset(&u, &y));
    rec.instrument = Some(r.clone());
    let mut o = WorkflowOptions::default();
    o.identification.method = Method::Iv;
    o.identification.order = Order::Fixed(1);
    o.refinement.refine = Refine::None;
    let fit = identify(&[rec], &o).expect("identify");
    let d = &fit.file.diagnostics;
    let a = fit.file.model.a()[(0, 0)];
    assert!((a - 1.02).abs() < 0.01, "{a} {d}");
    assert!(
        d["bd_route"]
            .as_str()
            .is_some_and(|s| s.contains("predictor")),
        "{d}"
    );
    assert_eq!(d["stability"]["stable"], false, "{d}");
    assert!(d["warnings"].to_string().contains("unstable"), "{d}");
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

/// 80 samples of a 2×2 plant (poles 0.995 and 0.9) whose outputs drift (a
/// random walk of half their spread): too short for the held-out blocks
/// of SSARX at its past horizon, so the singular-value gap decides.
fn drifting_record(seed: u64) -> (DMatrix<f64>, DMatrix<f64>) {
    let n = 80;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut g = || 12f64.sqrt() * (rng.random::<f64>() - 0.5);
    let b = DMatrix::from_fn(2, 2, |_, _| g());
    let c = DMatrix::from_fn(2, 2, |_, _| g());
    let u = DMatrix::from_fn(n, 2, |_, _| g());
    let mut x = DVector::zeros(2);
    let mut y = DMatrix::zeros(n, 2);
    for k in 0..n {
        let yk = &c * &x;
        y.set_row(k, &yk.transpose());
        x = DVector::from_vec(vec![0.995 * x[0], 0.9 * x[1]]) + &b * u.row(k).transpose();
    }
    let spread: Vec<f64> = (0..2)
        .map(|j| {
            let col = y.column(j);
            let mean = col.mean();
            (col.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64).sqrt()
        })
        .collect();
    let mut walk = [0.0; 2];
    for k in 0..n {
        for j in 0..2 {
            walk[j] += g() / (n as f64).sqrt();
            y[(k, j)] += 0.5 * spread[j] * walk[j];
        }
    }
    (u, y)
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

/// `n` samples (u, y, r) of the unstable plant x(t+1) = 1.02 x + u, y = x +
/// e (e uniform, standard deviation 0.014) held by u = r − 0.5 y (closed
/// loop pole 0.52), r uniform on ±0.5.
fn unstable_loop(n: usize, seed: u64) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut u, mut y, mut r) = (
        DMatrix::zeros(n, 1),
        DMatrix::zeros(n, 1),
        DMatrix::zeros(n, 1),
    );
    let mut x = 0.0;
    for t in 0..n {
        r[(t, 0)] = rng.random::<f64>() - 0.5;
        y[(t, 0)] = x + 0.05 * (rng.random::<f64>() - 0.5);
        u[(t, 0)] = r[(t, 0)] - 0.5 * y[(t, 0)];
        x = 1.02 * x + u[(t, 0)];
    }
    (u, y, r)
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

/// The model's Kalman gain predicts: on an output-error plant (white
/// measurement noise, so the best one-step predictor is the simulation,
/// K = 0) the one-step prediction on a fresh record is as good as the
/// simulation — the subspace step's Riccati gain made it worse (about 2
/// points of fit) — and on a plant with drifting output noise the
/// one-step prediction beats the simulation by far. The diagnostics name
/// the gain kept and the costs of the starts.
#[test]
fn the_kalman_gain_predicts_at_least_as_well_as_the_simulation() {
    let validate = |file: &lifted_lti::ModelFile, u: &DMatrix<f64>, y: &DMatrix<f64>| {
        let opts = lifted_lti::ValidationOptions {
            operating_point: file.operating_point.clone(),
            kalman_gain: file.kalman_gain_matrix(),
            ..Default::default()
        };
        let v = lifted_lti::validate(&file.model, &dataset(u, y), &opts).expect("validate");
        v.outputs
            .iter()
            .map(|o| (o.fit, o.prediction_fits[0]))
            .collect::<Vec<_>>()
    };
    let mut o = WorkflowOptions::default();
    o.identification.order = Order::Fixed(3);
    o.refinement.refine = Refine::None;
    // White output noise, 20 % of the outputs' spread.
    let (u, y) = record(3000, 0.3, 41);
    let (uf, yf) = record(3000, 0.3, 42);
    let fit = identify(&[Record::new(dataset(&u, &y))], &o).expect("identify");
    let route = &fit.file.diagnostics["kalman_gain_route"];
    let final_cost = route["final_cost"].as_f64().expect("final cost");
    assert!(
        final_cost <= route["riccati_cost"].as_f64().unwrap_or(f64::INFINITY),
        "{route}"
    );
    assert!(
        final_cost <= route["zero_cost"].as_f64().expect("zero") + 1e-12,
        "{route}"
    );
    // The IV route, which has no noise model of its own, gets the checked
    // gain as well (from the regression or K = 0).
    let mut iv = o.clone();
    iv.identification.method = Method::Iv;
    let iv_fit = identify(&[Record::new(dataset(&u, &y))], &iv).expect("identify");
    assert!(
        iv_fit.file.kalman_gain_matrix().is_some(),
        "{}",
        iv_fit.file.diagnostics
    );
    for (sim, one_step) in validate(&iv_fit.file, &uf, &yf) {
        assert!(
            one_step > sim - 0.2,
            "IV: one-step {one_step}, simulation {sim}"
        );
    }
    for (sim, one_step) in validate(&fit.file, &uf, &yf) {
        assert!(
            one_step > sim - 0.2,
            "one-step {one_step} below simulation {sim}: {route}"
        );
    }
    // Drifting output noise (a random walk-like disturbance, pole 0.995):
    // the predictor corrects it.
    let drift = |seed: u64| {
        let (u, mut y) = record(3000, 0.02, seed);
        let mut rng = ChaCha8Rng::seed_from_u64(seed + 100);
        let mut v = [0.0f64; 2];
        for t in 0..y.nrows() {
            for (j, vj) in v.iter_mut().enumerate() {
                *vj = 0.995 * *vj + 0.1 * (rng.random::<f64>() - 0.5);
                y[(t, j)] += *vj;
            }
        }
        (u, y)
    };
    let (u, y) = drift(43);
    let (uf, yf) = drift(44);
    let fit = identify(&[Record::new(dataset(&u, &y))], &o).expect("identify");
    for (sim, one_step) in validate(&fit.file, &uf, &yf) {
        assert!(
            one_step > sim + 10.0,
            "one-step {one_step}, simulation {sim}"
        );
    }
}

/// The default refinement on a record too short for its parameters (a
/// short multirate record at a high order): the identified model is kept
/// and the diagnostics say why, where the default used to fail the whole
/// identification (the DaISy power plant with its outputs every third
/// sample: 102 measured samples for 112 parameters). An asked-for
/// refinement still refuses.
#[test]
fn the_default_refinement_steps_aside_when_the_record_cannot_support_it() {
    let truth = flexible_plant();
    let data = multirate_record(&truth, 120, &[3], 1, 2);
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(6);
    let fit = identify(&[Record::new(data.clone())], &opts).expect("identify");
    let d = &fit.file.diagnostics;
    let why = d["refinement_decision"].as_str().expect("decision");
    assert!(why.starts_with("not refined: "), "{why}");
    assert!(
        why.contains("persistently exciting") || why.contains("parameters"),
        "{why}"
    );
    assert_eq!(fit.file.model.order(), 6);
    opts.refinement.refine = Refine::Pem;
    assert!(identify(&[Record::new(data)], &opts).is_err());
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

/// `n` samples of a 3-input, 1-output plant of order 4, near-integrating
/// and lightly damped (poles 0.995, 0.9 ± 0.3j, 0.6; a heated building's
/// slow mode and its ringing), driven from rest by random ±1 inputs: the
/// noiseless output and the output with uniform noise of standard
/// deviation `noise` times the output's RMS.
fn heating_record(n: usize, noise: f64, seed: u64) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let a = DMatrix::from_row_slice(
        4,
        4,
        &[
            0.995, 0.0, 0.0, 0.0, 0.0, 0.9, -0.3, 0.0, 0.0, 0.3, 0.9, 0.0, 0.0, 0.0, 0.0, 0.6,
        ],
    );
    let b = DMatrix::from_row_slice(
        4,
        3,
        &[
            0.05, 0.02, 0.01, 0.3, -0.2, 0.1, 0.1, 0.4, -0.3, 0.5, 0.1, 0.6,
        ],
    );
    let c = DMatrix::from_row_slice(1, 4, &[1.0, 0.8, 0.5, 0.4]);
    let g = StateSpace::new(a, b, c, DMatrix::zeros(1, 3), Some(1.0)).expect("plant");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let u = DMatrix::from_fn(
        n,
        3,
        |_, _| {
            if rng.random::<f64>() < 0.5 { -1.0 } else { 1.0 }
        },
    );
    let clean = g.lsim(&u, None, None).expect("lsim").y;
    let rms = (clean.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
    let mut y = clean.clone();
    for v in y.iter_mut() {
        *v += noise * rms * 12f64.sqrt() * (rng.random::<f64>() - 0.5);
    }
    (u, clean, y)
}

/// Simulation fit (%) of an identified model file on (u, y): the model's
/// response to u − u₀ from x = 0, plus y₀, against y.
fn simulation_fit(fit: &lifted_workflow::Identified, u: &DMatrix<f64>, y: &DMatrix<f64>) -> f64 {
    let op = fit.file.operating_point.as_ref().expect("operating point");
    let du = DMatrix::from_fn(u.nrows(), u.ncols(), |k, i| u[(k, i)] - op.u0[i]);
    let sim = fit.file.model.lsim(&du, None, None).expect("lsim").y;
    let (mut err, mut spread) = (0.0, 0.0);
    for j in 0..y.ncols() {
        let mean = y.column(j).mean();
        for k in 0..y.nrows() {
            err += (y[(k, j)] - sim[(k, j)] - op.y0[j]).powi(2);
            spread += (y[(k, j)] - mean).powi(2);
        }
    }
    100.0 * (1.0 - (err / spread).sqrt())
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

/// Issue 47: a single-output record read in blocks (the CLI streams a
/// file too large for the held-out selection) under the default options:
/// horizon 10 identifies orders up to (10 − 1)·1 = 9, so the automatic
/// order's bound 10 is capped there with the in-memory route's warning
/// (it was refused: "model order 10 invalid: it must lie in 1..=9").
#[test]
fn a_streamed_single_output_record_caps_the_automatic_order_search() {
    let n = 6000;
    let g = StateSpace::new(
        DMatrix::from_row_slice(2, 2, &[0.8, 0.3, -0.3, 0.8]),
        DMatrix::from_row_slice(2, 1, &[1.0, 0.5]),
        DMatrix::from_row_slice(1, 2, &[1.0, 0.0]),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .expect("plant");
    let mut rng = ChaCha8Rng::seed_from_u64(47);
    let u = DMatrix::from_fn(
        n,
        1,
        |_, _| {
            if rng.random::<f64>() < 0.5 { -1.0 } else { 1.0 }
        },
    );
    let mut y = g.lsim(&u, None, None).expect("lsim").y;
    for v in y.iter_mut() {
        *v += 0.1 * 12f64.sqrt() * (rng.random::<f64>() - 0.5);
    }
    let mut src = Blocks::of(&u, &y);
    let opts = WorkflowOptions::default();
    let streamed = identify_streamed(&mut src, &opts)
        .expect("streamed")
        .expect("a single-rate record streams");
    let capped = |f: &lifted_workflow::Identified| -> Vec<String> {
        f.file.diagnostics["warnings"]
            .as_array()
            .map(|w| {
                w.iter()
                    .filter_map(|s| s.as_str())
                    .filter(|s| s.contains("the automatic order searched"))
                    .map(String::from)
                    .collect()
            })
            .unwrap_or_default()
    };
    let warned = capped(&streamed);
    assert_eq!(warned.len(), 1, "{}", streamed.file.diagnostics);
    assert!(
        warned[0].contains("searched 1..=9 instead of 1..=10"),
        "{warned:?}"
    );
    assert_eq!(streamed.order, 2, "{}", streamed.file.diagnostics);
    // The in-memory route with the streamed route's structure (Bauer's
    // SVC, horizon 10, shift invariance): the same order and warning.
    let mut mem_opts = WorkflowOptions::default();
    mem_opts.identification.order_criterion = OrderCriterion::Svc;
    mem_opts.identification.horizon = Some(10);
    mem_opts.identification.estimator = Estimator::Shift;
    let mem = identify(&[Record::new(dataset(&u, &y))], &mem_opts).expect("in memory");
    assert_eq!(capped(&mem), warned);
    assert_eq!(mem.order, streamed.order);
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

/// A mass (m = 1 kg, x'' = F/m) sampled with a zero-order hold at
/// Ts = 0.01 s: the double integrator A = [1 Ts; 0 1], B = [Ts²/2; Ts]/m,
/// y = position.
fn mass() -> StateSpace {
    let ts = 0.01;
    StateSpace::new(
        DMatrix::from_row_slice(2, 2, &[1.0, ts, 0.0, 1.0]),
        DMatrix::from_row_slice(2, 1, &[ts * ts / 2.0, ts]),
        DMatrix::from_row_slice(1, 2, &[1.0, 0.0]),
        DMatrix::zeros(1, 1),
        Some(ts),
    )
    .expect("mass")
}

/// The mass of [`mass`] under position control, `n` samples from rest:
/// a PD loop F = kp (r − y) − kd (y_t − y_{t−1})/Ts (kp = 150 N/m,
/// kd = 17.6 N s/m: a closed loop of about 2 Hz, damping 0.7) plus a
/// random binary excitation of ±1 N, the reference a random step
/// sequence of ±0.1 m (a switch with probability 0.01 per sample), the
/// measured position with white noise of σ = 1e-4 m. The last fifth
/// returns to rest (reference 0, no excitation), so the record's mean
/// force, which the default detrending takes for an operating point, is
/// that of a mass at rest (≈ 0: a force offset would be integrated twice
/// into a drift). Returns the force and the measured position.
fn position_loop(n: usize, seed: u64) -> (DMatrix<f64>, DMatrix<f64>) {
    let g = mass();
    let ts = 0.01;
    let (kp, kd) = (150.0, 17.6);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut u, mut y) = (DMatrix::zeros(n, 1), DMatrix::zeros(n, 1));
    let (mut x, mut level, mut last) = (DVector::<f64>::zeros(2), 0.1, 0.0);
    for t in 0..n {
        let rest = t >= n - n / 5;
        if rng.random::<f64>() < 0.01 {
            level = -level;
        }
        let v = 1e-4 * 12f64.sqrt() * (rng.random::<f64>() - 0.5);
        let yt = x[0] + v;
        let d = if rng.random::<f64>() < 0.5 { -1.0 } else { 1.0 };
        let (r, d) = if rest { (0.0, 0.0) } else { (level, d) };
        let f = kp * (r - yt) - kd * (yt - if t == 0 { yt } else { last }) / ts + d;
        last = yt;
        (u[(t, 0)], y[(t, 0)]) = (f, yt);
        x = g.a() * &x + g.b() * f;
    }
    (u, y)
}

/// Validation fit (%) of a model file on (u, y) as benches/peers/realdata.py
/// scores it: the response to u − u₀ plus y₀, x₀ by least squares on the
/// record itself (an integrator's start cannot be known otherwise).
fn fit_with_x0(fit: &lifted_workflow::Identified, u: &DMatrix<f64>, y: &DMatrix<f64>) -> f64 {
    let op = fit.file.operating_point.as_ref().expect("operating point");
    let m = &fit.file.model;
    let du = DMatrix::from_fn(u.nrows(), 1, |k, _| u[(k, 0)] - op.u0[0]);
    let forced = m.lsim(&du, None, None).expect("lsim").y;
    let n = m.order();
    let rows = y.nrows();
    let mut phi = DMatrix::zeros(rows, n);
    let mut ca = m.c().clone();
    for k in 0..rows {
        phi.row_mut(k).copy_from(&ca.row(0));
        ca = &ca * m.a();
    }
    let resid = DVector::from_fn(rows, |k, _| y[(k, 0)] - op.y0[0] - forced[(k, 0)]);
    let x0 = phi
        .clone()
        .svd(true, true)
        .solve(&resid, 1e-12)
        .expect("x0");
    let err = &resid - &phi * x0;
    let mean = y.column(0).mean();
    let spread = y.column(0).iter().map(|v| (v - mean).powi(2)).sum::<f64>();
    100.0 * (1.0 - (err.norm_squared() / spread).sqrt())
}

/// Issue 46, "Integrators kept": a double integrator under position
/// control, four records (seeds). The subspace estimate of the mass puts
/// its double pole at z = 1 within the integrator tolerance 2/N of the
/// circle (here just inside: ρ = 0.99999, poles 1 ± 0.001i). The default,
/// `--refine pem` and `--stable` all keep both poles within 0.01 of z = 1
/// (the truth: 1, twice), report them under `diagnostics.integrators` and
/// as marginal under `diagnostics.stability`, and fit a held-out record
/// (another seed) above [`HELD_OUT_FIT`]; a refinement kept is never
/// worse on the estimation record than its start.
#[test]
fn a_double_integrator_under_position_control_keeps_its_poles() {
    for seed in [46, 47, 48, 49] {
        let (u, y) = position_loop(6000, seed);
        let (uv, yv) = position_loop(6000, 1000 + seed);
        let records = [Record::new(
            Dataset::single_rate(0.01, u.clone(), y.clone()).expect("dataset"),
        )];
        let run = |refine: Refine, stable: bool| {
            let mut opts = WorkflowOptions::default();
            opts.identification.order = Order::Fixed(2);
            opts.identification.stable = stable;
            opts.validation.require_stable = stable;
            opts.refinement.refine = refine;
            identify(&records, &opts).expect("identify")
        };
        let plain = run(Refine::None, false);
        let d = &plain.file.diagnostics;
        let tolerance = d["integrators"]["tolerance"].as_f64().expect("tolerance");
        assert!((tolerance - 2.0 / 6000.0).abs() < 1e-12, "{d}");
        let fits = [
            ("plain", plain.clone()),
            ("default", run(Refine::Auto, false)),
            ("pem", run(Refine::Pem, false)),
            ("stable", run(Refine::Auto, true)),
        ];
        for (name, fit) in &fits {
            let d = &fit.file.diagnostics;
            let f = fit_with_x0(fit, &uv, &yv);
            assert!(near_one(&fit.file.model) < 0.01, "seed {seed} {name}: {d}");
            assert!(f > HELD_OUT_FIT, "seed {seed} {name}: held-out fit {f}");
            assert!(
                d["integrators"]["count"].as_u64().expect("count") >= 1,
                "{d}"
            );
            assert_eq!(d["stability"]["marginal"], true, "{d}");
            if d["refinement"]["kept"] == "Refined" {
                let judged = &d["refinement"]["judged"];
                assert!(judged[1].as_f64() <= judged[0].as_f64(), "{d}");
            }
        }
    }
}

/// Held-out fit (%) every variant reaches on the position loop: measured
/// 62.7–90.8 over the four seeds (the same for every variant: the
/// refinement was not kept, the estimates were inside the circle); a model
/// with its double pole pulled to ρ ≈ 0.9 (the zero-padded start) stops
/// integrating after about ten samples (2.2 % on the EMPS drive record,
/// benches/results/closed-loop.md). The truth fits these records to their noise.
const HELD_OUT_FIT: f64 = 60.0;

/// Largest distance of a model's poles from z = 1.
fn near_one(m: &StateSpace) -> f64 {
    m.poles()
        .expect("poles")
        .iter()
        .map(|z| (z - nalgebra::Complex::new(1.0, 0.0)).norm())
        .fold(0.0, f64::max)
}

/// Issue 46, the issue's case: an estimate of the mass just outside the
/// unit circle (the identified model of [`position_loop`] with A scaled to
/// ρ = 1 + δ/2, δ = 2/N the integrator tolerance; the EMPS drive record's
/// order-3 estimate had ρ = 1.00003 with δ = 1.6e-4). `--refine pem` used
/// to reflect such a start inside before iterating
/// (`refinement.stabilized_start`), or, from the route, start from the
/// zero-padded shift (ρ ≈ 0.9 on EMPS); now the refinement starts from it
/// as it is, keeps both poles within 0.01 of z = 1 and ρ < 1 + δ, and the
/// model written fits the held-out record above [`HELD_OUT_FIT`]. With
/// `--stable` the marginal poles are moved just inside (ρ < 1) and the
/// route says so.
#[test]
fn a_start_just_outside_the_circle_is_refined_as_an_integrator() {
    let (u, y) = position_loop(6000, 48);
    let (uv, yv) = position_loop(6000, 1048);
    let data = Dataset::single_rate(0.01, u.clone(), y.clone()).expect("dataset");
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(2);
    opts.refinement.refine = Refine::None;
    let plain = identify(&[Record::new(data.clone())], &opts).expect("identify");
    let op = plain.file.operating_point.clone().expect("op");
    let set = lifted_workflow::deviations(&data, Some(&op)).expect("deviations");
    let m = &plain.file.model;
    let tolerance = 2.0 / 6000.0;
    let rho = lifted_workflow::spectral_radius(m).expect("rho");
    let outside = StateSpace::new(
        m.a() * ((1.0 + tolerance / 2.0) / rho),
        m.b().clone(),
        m.c().clone(),
        m.d().clone(),
        m.ts(),
    )
    .expect("model");
    for stable in [false, true] {
        let mut o = WorkflowOptions::default();
        o.refinement.refine = Refine::Pem;
        o.identification.stable = stable;
        let mut gain = None;
        let (model, d) = lifted_workflow::refine(
            &o,
            outside.clone(),
            serde_json::json!({}),
            std::slice::from_ref(&set),
            &mut gain,
            None,
        )
        .expect("refine");
        assert_eq!(
            d["refinement"]["stabilized_start"],
            serde_json::Value::Null,
            "{d}"
        );
        assert!(near_one(&model) < 0.01, "stable {stable}: {d}");
        let r = lifted_workflow::spectral_radius(&model).expect("rho");
        if stable {
            assert!(r < 1.0, "{r} {d}");
            assert_eq!(d["integrators_moved_inside"], true, "{d}");
            assert!(
                d["stable_route"]
                    .as_str()
                    .is_some_and(|s| s.contains("marginal")),
                "{d}"
            );
        } else {
            assert!(r < 1.0 + tolerance, "{r} {d}");
        }
        if d["refinement"]["kept"] == "Refined" {
            let judged = &d["refinement"]["judged"];
            assert!(judged[1].as_f64() <= judged[0].as_f64(), "{d}");
        }
        let file = lifted_workflow::Identified {
            file: lifted_lti::ModelFile::new(model)
                .with_operating_point(op.clone())
                .expect("op"),
            ..plain.clone()
        };
        let f = fit_with_x0(&file, &uv, &yv);
        eprintln!(
            "stable {stable}: rho {r:.7} held-out fit {f:.2} kept {}",
            d["refinement"]["kept"]
        );
        assert!(f > HELD_OUT_FIT, "stable {stable}: held-out fit {f}");
    }
}

/// Issue 46: the feedback test says "closed loop" on a PI loop (the
/// controller acts on the noisy output) and warns that N4SID is biased
/// there, naming the consistent methods; on open-loop records (random
/// binary inputs, three fixed seeds) it finds no feedback and warns of
/// none (each input's test is at 1 %, so a false alarm somewhere among
/// these six tests had a 6 % chance; these seeds have none).
#[test]
fn feedback_is_detected_in_closed_loop_only() {
    let [u, y, _] = closed_loop_record(20_000, 0.3, 4);
    let rec = [Record {
        data: dataset(&u, &y),
        instrument: None,
    }];
    let mut o = WorkflowOptions::default();
    o.identification.order = Order::Fixed(2);
    o.refinement.refine = Refine::None;
    let fit = identify(&rec, &o).expect("identify");
    let d = &fit.file.diagnostics;
    assert_eq!(d["feedback"]["detected"], true, "{}", d["feedback"]);
    let warned = d["warnings"].as_array().is_some_and(|w| {
        w.iter().any(|s| {
            s.as_str()
                .is_some_and(|s| s.starts_with("closed loop detected") && s.contains("pbsid"))
        })
    });
    assert!(warned, "{}", d["warnings"]);
    for seed in [1, 2, 3] {
        let (u, y) = record(20_000, 0.1, seed);
        let rec = [Record {
            data: dataset(&u, &y),
            instrument: None,
        }];
        let fit = identify(&rec, &o).expect("identify");
        let d = &fit.file.diagnostics;
        assert_eq!(
            d["feedback"]["detected"], false,
            "seed {seed}: {}",
            d["feedback"]
        );
        assert!(
            d["feedback"]["verdict"]
                .as_str()
                .is_some_and(|v| v.starts_with("no input depends")),
            "{}",
            d["feedback"]
        );
    }
}

/// A stable plant (four first-order lags, poles 0.5–0.9, unit gains)
/// whose output, measured every fifth sample, carries a random walk: at
/// order 3 the prediction-error refinement wants the integrator for the
/// disturbance, and its iterates (kept stable) run onto the unit circle
/// (seed 2 of six). The default keeps the start and says why; an
/// asked-for refinement is kept with a warning, and the model is reported
/// as having an integrator. Measured: FR error against the plant 0.47 for
/// the start kept (the random walk is outside an order-3 model) against
/// 1.75 for the model on the boundary.
#[test]
fn a_refinement_onto_the_stability_boundary_is_not_kept_by_default() {
    let (n, nu) = (1200, 4);
    let poles = [0.9, 0.7, 0.5, 0.8];
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut u = DMatrix::zeros(n, nu);
    for i in 0..nu {
        let mut level = 1.0;
        for t in 0..n {
            if t % 10 == 0 && rng.random::<f64>() < 0.5 {
                level = -level;
            }
            u[(t, i)] = level;
        }
    }
    let (mut xs, mut w) = (vec![0.0; nu], 0.0);
    let y = DMatrix::from_fn(n, 1, |t, _| {
        let out: f64 = xs.iter().sum::<f64>() + w;
        for i in 0..nu {
            xs[i] = poles[i] * xs[i] + (1.0 - poles[i]) * u[(t, i)];
        }
        w += 0.2 * (rng.random::<f64>() - 0.5);
        if t % 5 == 0 { out } else { f64::NAN }
    });
    let rec = [Record::new(multirate_dataset(u, y, 1, &[5]))];
    let mut o = WorkflowOptions::default();
    o.identification.order = Order::Fixed(3);
    let fit = identify(&rec, &o).expect("identify");
    let d = &fit.file.diagnostics;
    let decision = d["refinement_decision"].as_str().unwrap_or_default();
    assert!(
        decision.contains("ran onto the stability boundary"),
        "{decision}"
    );
    let rho = d["stability"]["spectral_radius"]
        .as_f64()
        .unwrap_or(f64::NAN);
    let tolerance = d["integrators"]["tolerance"].as_f64().unwrap_or(f64::NAN);
    assert!(rho < 1.0 - tolerance, "rho {rho}, tolerance {tolerance}");
    o.refinement.refine = Refine::Pem;
    let asked = identify(&rec, &o).expect("identify, pem asked");
    let da = &asked.file.diagnostics;
    let warnings = da["warnings"].to_string();
    assert!(
        warnings.contains("ran onto the stability boundary"),
        "{warnings}"
    );
    assert!(
        warnings.contains("the model has integrator(s)"),
        "{warnings}"
    );
    let truth = StateSpace::new(
        DMatrix::from_diagonal(&DVector::from_row_slice(&poles)),
        DMatrix::from_diagonal(&DVector::from_iterator(nu, poles.iter().map(|p| 1.0 - p))),
        DMatrix::from_element(1, nu, 1.0),
        DMatrix::zeros(1, nu),
        Some(1.0),
    )
    .expect("truth");
    let (kept, boundary) = (
        fr_error(&fit.file.model, &truth),
        fr_error(&asked.file.model, &truth),
    );
    assert!(
        kept < boundary,
        "FR error: start kept {kept:.3}, boundary model {boundary:.3}"
    );
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

/// y = B/F u + e with B = 0.5 q⁻² + 0.3 q⁻³, F = 1 − 1.2 q⁻¹ + 0.5 q⁻²
/// (an OE plant of order 2, delay 2), u white ±1, e white of sd `sd`.
fn oe_record(n: usize, sd: f64, seed: u64) -> Dataset {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let u: Vec<f64> = (0..n)
        .map(|_| if rng.random::<bool>() { 1.0 } else { -1.0 })
        .collect();
    let mut w = vec![0.0; n];
    for t in 0..n {
        let b = |k: usize| if t >= k { u[t - k] } else { 0.0 };
        let f = |k: usize| if t >= k { w[t - k] } else { 0.0 };
        w[t] = 0.5 * b(2) + 0.3 * b(3) + 1.2 * f(1) - 0.5 * f(2);
    }
    let y: Vec<f64> = w
        .iter()
        .map(|v| v + sd * (2.0 * rng.random::<f64>() - 1.0) * 3f64.sqrt())
        .collect();
    dataset(
        &DMatrix::from_column_slice(n, 1, &u),
        &DMatrix::from_column_slice(n, 1, &y),
    )
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

//! The streamed route (a record read in blocks, two passes) gives the in-memory
//! route's model; a refused block stops the reading ahead; its automatic order search
//! is capped where the record supports no more.

use crate::common::*;
use lifted_lti::StateSpace;
use lifted_workflow::{
    Estimator, Order, OrderCriterion, Record, WorkflowOptions, identify, identify_streamed,
};
use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[test]
fn the_streamed_route_gives_the_in_memory_model() {
    streamed_equals_in_memory(5000, [1.0, 1.0]);
    // Longer than the rows the channel scales come from (the first pass
    // holds its blocks back until it has them), channels in other units.
    streamed_equals_in_memory(12_000, [1e-5, 3e4]);
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

/// ARX [2 3 1] and FIR [4 1] of a 2×2 record in odd units (12 000 rows in
/// blocks of 700, two threads reading ahead): the streamed route reads
/// the record once into the lagged correlations and gives the in-memory
/// route's polynomials, covariance and operating point to rounding; the
/// diagnostics say it was streamed. A NaN sample is refused (a file
/// source stops at an output not sampled and reports the record
/// multirate instead, which the caller then loads whole).
#[test]
fn arx_and_fir_stream_to_the_in_memory_model() {
    let (u, mut y) = record(12_000, 0.05, 6);
    for (j, s) in [1e-3, 40.0].iter().enumerate() {
        y.column_mut(j).iter_mut().for_each(|v| *v = *v * s + 7.0);
    }
    for (method, orders) in [
        (lifted_workflow::Method::Arx, vec![2, 3, 1]),
        (lifted_workflow::Method::Fir, vec![4, 1]),
    ] {
        let mut opts = WorkflowOptions::default();
        opts.identification.method = method;
        opts.identification.orders = orders;
        opts.identification.threads = Some(2);
        assert!(lifted_workflow::streamable(&opts));
        let mem = identify(&[Record::new(dataset(&u, &y))], &opts).expect("in memory");
        let mut src = Blocks::of(&u, &y);
        let streamed = identify_streamed(&mut src, &opts)
            .expect("streamed")
            .expect("a single-rate record streams");
        assert_eq!(src.passes, 1, "{method:?}");
        let (pm, ps) = (
            mem.details.polynomial.as_ref().expect("polynomial"),
            streamed.details.polynomial.as_ref().expect("polynomial"),
        );
        for (a, b) in pm.parameters().iter().zip(ps.parameters()) {
            assert!(
                (a - b).abs() < 1e-9 * a.abs().max(1e-3),
                "{method:?}: {a} vs {b}"
            );
        }
        let (cm, cs) = (pm.covariance().expect("cov"), ps.covariance().expect("cov"));
        assert!((cm - cs).norm() < 1e-8 * cm.norm(), "{method:?}");
        let (oa, ob) = (
            mem.file.operating_point.as_ref().expect("op"),
            streamed.file.operating_point.as_ref().expect("op"),
        );
        for (p, q) in oa.y0.iter().chain(&oa.u0).zip(ob.y0.iter().chain(&ob.u0)) {
            assert!((p - q).abs() < 1e-9 * p.abs().max(1.0), "{p} vs {q}");
        }
        let d = &streamed.file.diagnostics;
        assert!(d["streamed"].is_string(), "{d}");
        assert_eq!(d["route"], method.name());
        same_response(&mem.file.model, &streamed.file.model);
    }
    let mut opts = WorkflowOptions::default();
    opts.identification.method = lifted_workflow::Method::Arx;
    opts.identification.orders = vec![2, 2, 1];
    let mut slow = y.clone();
    for t in (0..slow.nrows()).filter(|t| t % 3 != 0) {
        slow[(t, 1)] = f64::NAN;
    }
    let mut src = Blocks::of(&u, &slow);
    assert!(identify_streamed(&mut src, &opts).is_err());
}

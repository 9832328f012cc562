//! The two-pass streamed identification (compression, then the output-error
//! (B, D, x₀) regression on a second pass over the data) against the
//! in-memory identification on the same data: the same model up to
//! rounding, with flat memory.

use lifted_lti::StateSpace;
use lifted_subspace::{
    BdRoute, Experiment, Feedthrough, InitialState, Method, OrderSelection, OutputErrorStream,
    OutputErrorStreamOptions, Record, StreamingIdentifier, SubspaceModel, SubspaceOptions,
    estimate_bd, estimate_bd_with_offsets, identify,
};
use nalgebra::DMatrix;

use crate::common::{freq_error, random_system, rbs, sim, white};

/// A 2×2 order-4 plant, 20 000 samples with offsets and output noise.
fn record(seed: u64) -> (StateSpace, DMatrix<f64>, DMatrix<f64>) {
    let g = random_system(seed, &[0.9, 0.5], &[(0.8, 0.6)], 2, 2, true);
    let n = 20_000;
    let u = rbs(seed + 1, n, 2).add_scalar(0.3);
    let y = sim(&g, &u, None) + white(seed + 2, n, 2, 0.05);
    let y = y.add_scalar(2.0);
    (g, u, y)
}

/// Pushes `u`, `y` in blocks of `block` rows through both passes.
fn two_pass(
    u: &DMatrix<f64>,
    y: &DMatrix<f64>,
    opts: &SubspaceOptions,
    block: usize,
) -> SubspaceModel {
    let mut sid = StreamingIdentifier::new(u.ncols(), y.ncols(), opts).unwrap();
    let n = u.nrows();
    for s in (0..n).step_by(block) {
        let len = block.min(n - s);
        sid.push(&u.rows(s, len).into_owned(), &y.rows(s, len).into_owned())
            .unwrap();
    }
    let first = sid.finish_subspace().unwrap();
    assert_eq!(first.model().diagnostics.bd_route, BdRoute::Projection);
    assert!(first.wants_second_pass());
    let mut bd = first.regression().unwrap();
    for s in (0..n).step_by(block) {
        let len = block.min(n - s);
        bd.push(&u.rows(s, len).into_owned(), &y.rows(s, len).into_owned())
            .unwrap();
    }
    first.finish(bd).unwrap()
}

fn rel(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).norm() / b.norm().max(1e-300)
}

#[test]
fn two_pass_equals_the_in_memory_identification() {
    let (g, u, y) = record(11);
    for method in [Method::N4sid, Method::Moesp, Method::Cva] {
        let opts = SubspaceOptions {
            method,
            order: OrderSelection::Fixed(4),
            ..Default::default()
        };
        let mem = identify(&[Experiment { u: &u, y: &y }], &opts).unwrap();
        // Blocks that do not divide the record, and one that does; one
        // thread and all of them.
        for (block, threads) in [(4096, 1), (5000, 1), (4096, 0), (30_000, 0)] {
            let st = two_pass(
                &u,
                &y,
                &SubspaceOptions {
                    threads,
                    ..opts.clone()
                },
                block,
            );
            assert_eq!(st.diagnostics.bd_route, BdRoute::OutputError);
            // Same (A, C) basis up to rounding (same factor, same SVD), so
            // the matrices themselves agree; 1e-10 relative (the
            // compressions differ in summation order only), 1e-9 for CVA,
            // whose weight W₁ = [(Y_f/U_f⊥)(·)ᵀ]^{−1/2} amplifies the
            // rounding by its condition (measured 1.4e-10 on B).
            let tol = if method == Method::Cva { 1e-9 } else { 1e-10 };
            for (x, z, what) in [
                (st.model.a(), mem.model.a(), "A"),
                (st.model.b(), mem.model.b(), "B"),
                (st.model.c(), mem.model.c(), "C"),
                (st.model.d(), mem.model.d(), "D"),
            ] {
                let e = rel(x, z);
                assert!(e < tol, "{method:?} block {block}: {what} differs by {e:e}");
            }
            let (ka, kb) = (
                st.kalman_gain.as_ref().unwrap(),
                mem.kalman_gain.as_ref().unwrap(),
            );
            // The DARE amplifies the 1e-12 differences of the covariances
            // (its condition here ~1e3): 1e-8.
            assert!(
                rel(ka, kb) < 1e-8,
                "Kalman gain differs by {:e}",
                rel(ka, kb)
            );
            let (oa, ob) = (
                st.operating_point.as_ref().unwrap(),
                mem.operating_point.as_ref().unwrap(),
            );
            for (p, q) in oa.y0.iter().zip(&ob.y0).chain(oa.u0.iter().zip(&ob.u0)) {
                assert!(
                    (p - q).abs() < 1e-10 * q.abs().max(1.0),
                    "operating point {p} vs {q}"
                );
            }
            assert_eq!(st.x0.len(), 1);
            assert!((&st.x0[0] - &mem.x0[0]).norm() < 1e-8 * mem.x0[0].norm().max(1.0));
        }
        // And the model is accurate: FR error against the truth at this SNR
        // (output noise 0.05 on outputs of RMS ≈ 2) below 2 %.
        let st = two_pass(&u, &y, &opts, 4096);
        let e = freq_error(&st.model, &g);
        assert!(e < 0.02, "{method:?}: FR error {e}");
    }
}

#[test]
fn output_error_stream_equals_estimate_bd() {
    let (g, u, y) = record(5);
    let (a, c) = (g.a().clone(), g.c().clone());
    let recs = [Record {
        u: &u,
        y: &y,
        instrument: None,
    }];
    for (offsets, ft) in [(false, Feedthrough::Free), (true, Feedthrough::Zero)] {
        let mem = if offsets {
            estimate_bd_with_offsets(&a, &c, &recs, &ft, InitialState::Estimate).unwrap()
        } else {
            estimate_bd(&a, &c, &recs, &ft, InitialState::Estimate).unwrap()
        };
        let opts = OutputErrorStreamOptions {
            feedthrough: ft.clone(),
            offsets,
            records: 1,
            longest_record: u.nrows(),
            ..Default::default()
        };
        let mut bd = OutputErrorStream::new(&a, &c, 2, &opts).unwrap();
        for s in (0..u.nrows()).step_by(3333) {
            let len = 3333.min(u.nrows() - s);
            bd.push(&u.rows(s, len).into_owned(), &y.rows(s, len).into_owned())
                .unwrap();
        }
        assert_eq!(bd.route(), Some("modal"));
        let st = bd.finish().unwrap();
        assert!(rel(&st.b, &mem.b) < 1e-10, "B: {:e}", rel(&st.b, &mem.b));
        if offsets {
            assert!(st.d.iter().all(|&v| v == 0.0));
            assert!((&st.offsets[0] - &mem.offsets[0]).norm() < 1e-9);
        } else {
            assert!(rel(&st.d, &mem.d) < 1e-10);
        }
    }
}

#[test]
fn output_error_stream_direct_route_with_two_records() {
    // A defective A (Jordan block) keeps the direct recursions.
    let a = DMatrix::from_row_slice(2, 2, &[0.7, 1.0, 0.0, 0.7]);
    let b = DMatrix::from_row_slice(2, 1, &[0.5, 1.0]);
    let c = DMatrix::from_row_slice(1, 2, &[1.0, 0.0]);
    let g = StateSpace::new(
        a.clone(),
        b.clone(),
        c.clone(),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap();
    let u1 = rbs(1, 700, 1);
    let u2 = rbs(2, 900, 1);
    let x0 = nalgebra::DVector::from_vec(vec![1.0, -2.0]);
    let y1 = sim(&g, &u1, Some(&x0));
    let y2 = sim(&g, &u2, None);
    let opts = OutputErrorStreamOptions {
        records: 2,
        longest_record: 900,
        ..Default::default()
    };
    let mut bd = OutputErrorStream::new(&a, &c, 1, &opts).unwrap();
    bd.push(&u1.rows(0, 300).into_owned(), &y1.rows(0, 300).into_owned())
        .unwrap();
    bd.push(
        &u1.rows(300, 400).into_owned(),
        &y1.rows(300, 400).into_owned(),
    )
    .unwrap();
    bd.end_record().unwrap();
    bd.push(&u2, &y2).unwrap();
    assert_eq!(bd.route(), Some("direct"));
    let fit = bd.finish().unwrap();
    assert!((&fit.b - &b).norm() < 1e-9);
    assert!((&fit.x0[0] - &x0).norm() < 1e-8);
    assert!(fit.x0[1].norm() < 1e-8);
}

#[test]
fn output_error_stream_rejects_bad_use() {
    let a = DMatrix::from_element(1, 1, 0.5);
    let c = DMatrix::from_element(1, 1, 1.0);
    let opts = OutputErrorStreamOptions::default();
    // Nothing pushed.
    let bd = OutputErrorStream::new(&a, &c, 1, &opts).unwrap();
    assert!(bd.finish().is_err());
    // A non-finite input names itself.
    let mut bd = OutputErrorStream::new(&a, &c, 1, &opts).unwrap();
    let mut u = DMatrix::from_element(10, 1, 1.0);
    u[(3, 0)] = f64::NAN;
    let err = bd.push(&u, &DMatrix::zeros(10, 1)).unwrap_err();
    assert!(err.to_string().contains("u contains a non-finite value"));
    // More records than declared.
    let mut bd = OutputErrorStream::new(&a, &c, 1, &opts).unwrap();
    let u = rbs(3, 50, 1);
    bd.push(&u, &u).unwrap();
    bd.end_record().unwrap();
    assert!(bd.push(&u, &u).is_err());
    // An unstable A too unstable for the record is refused up front.
    let big = DMatrix::from_element(1, 1, 1.1);
    let o = OutputErrorStreamOptions {
        longest_record: 10_000,
        ..Default::default()
    };
    assert!(matches!(
        OutputErrorStream::new(&big, &c, 1, &o),
        Err(lifted_subspace::Error::UnstableEstimate { .. })
    ));
    // Wrong block shape.
    let mut bd = OutputErrorStream::new(&a, &c, 1, &opts).unwrap();
    assert!(
        bd.push(&DMatrix::zeros(5, 2), &DMatrix::zeros(5, 1))
            .is_err()
    );
}

#[test]
fn output_error_stream_threads_change_rounding_only() {
    let g = random_system(9, &[0.9, 0.5], &[(0.8, 0.6)], 2, 2, true);
    let n = 150_000;
    let u = rbs(10, n, 2);
    let y = sim(&g, &u, None) + white(11, n, 2, 0.05);
    let run = |threads: usize| {
        let opts = OutputErrorStreamOptions {
            records: 1,
            longest_record: n,
            threads,
            ..Default::default()
        };
        let mut bd = OutputErrorStream::new(g.a(), g.c(), 2, &opts).unwrap();
        for s in (0..n).step_by(65_536) {
            let len = 65_536.min(n - s);
            bd.push(&u.rows(s, len).into_owned(), &y.rows(s, len).into_owned())
                .unwrap();
        }
        bd.finish().unwrap()
    };
    let (one, two, three) = (run(1), run(2), run(3));
    for other in [&two, &three] {
        assert!(rel(&other.b, &one.b) < 1e-10);
        assert!(rel(&other.d, &one.d) < 1e-10);
        assert!((&other.x0[0] - &one.x0[0]).norm() < 1e-8 * one.x0[0].norm().max(1.0));
    }
    // Same count, same bits.
    assert_eq!(run(2).b, two.b);
}

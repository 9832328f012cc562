use super::*;
use crate::estimated::BdFit;
use crate::estimated::{Feedthrough, InitialState};
use crate::regress::{Route, output_error_route};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The modal and the direct route on the same problem (one thread).
fn both_routes(
    a: &DMatrix<f64>,
    c: &DMatrix<f64>,
    recs: &[Record<'_>],
    ft: &Feedthrough,
    x0: InitialState,
    offsets: bool,
) -> (BdFit, BdFit) {
    let run = |allow_modal| {
        let route = Route {
            offsets,
            allow_modal,
            threads: 1,
        };
        output_error_route(a, c, recs, ft, x0, route).unwrap()
    };
    (run(true), run(false))
}

/// A stable 4-state A with a complex pair and two real modes, in a
/// non-modal basis.
fn system() -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let lam = DMatrix::from_row_slice(
        4,
        4,
        &[
            0.8, 0.3, 0.0, 0.0, //
            -0.3, 0.8, 0.0, 0.0, //
            0.0, 0.0, 0.6, 0.0, //
            0.0, 0.0, 0.0, -0.4,
        ],
    );
    let t = DMatrix::from_row_slice(
        4,
        4,
        &[
            1.0, 0.2, 0.0, 0.3, //
            0.1, 1.0, 0.4, 0.0, //
            0.0, 0.3, 1.0, 0.2, //
            0.2, 0.0, 0.1, 1.0,
        ],
    );
    let a = &t * lam * lifted_linalg::inv(&t).unwrap();
    let b = DMatrix::from_row_slice(4, 2, &[1.0, 0.0, 0.0, 1.0, 0.5, 0.5, -0.3, 1.0]);
    let c = DMatrix::from_row_slice(2, 4, &[1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0]);
    (a, b, c)
}

fn record(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    c: &DMatrix<f64>,
    n: usize,
    seed: u64,
) -> (DMatrix<f64>, DMatrix<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let u = DMatrix::from_fn(n, 2, |_, _| if rng.random::<bool>() { 1.0 } else { -1.0 });
    let mut x = nalgebra::DVector::from_element(4, 0.7);
    let mut y = DMatrix::zeros(n, 2);
    for t in 0..n {
        let ut = u.row(t).transpose();
        let yt: nalgebra::DVector<f64> = c * &x + &ut * 0.2;
        for o in 0..2 {
            y[(t, o)] = yt[o] + 3.0 + 0.05 * (rng.random::<f64>() - 0.5);
        }
        x = a * &x + b * &ut;
    }
    (u, y)
}

/// The modal form of [`system`], a record of `n` samples and filter
/// states away from rest once the free response is gone.
fn filters_case(n: usize, seed: u64) -> (ModalForm, DMatrix<f64>, DMatrix<f64>, FilterState) {
    let (a, b, c) = system();
    let form = ModalForm::of(&a).expect("modes");
    let (u, y) = record(&a, &b, &c, n, seed);
    let start = FilterState {
        w: (0..8).map(|i| 0.1 * i as f64 - 0.3).collect(),
        fr: vec![0.0; 4],
        fr_live: false,
    };
    (form, u, y, start)
}

#[test]
fn the_filters_run_over_a_stretch_as_sample_by_sample() {
    // Bit for bit: the stretch-wise run (the scan's fast path) and the
    // sample-by-sample steps, states and the values written.
    let (form, u, y, start) = filters_case(700, 7);
    let rec = Record {
        u: &u,
        y: &y,
        instrument: None,
    };
    let (mut by_step, mut by_run) = (start.clone(), start);
    let ts = 13..613;
    let mut written = vec![0.0; 8 * 1000];
    form.run(
        &mut by_run.w,
        &u,
        0.37,
        ts.clone(),
        Some((&mut written, 1000, 5)),
    );
    for (k, t) in ts.enumerate() {
        for (col, &v) in by_step.w.iter().enumerate() {
            assert_eq!(written[col * 1000 + 5 + k].to_bits(), v.to_bits());
        }
        by_step.step(&form, &rec, 0.37, t);
    }
    assert!(
        by_step
            .w
            .iter()
            .zip(&by_run.w)
            .all(|(x, z)| x.to_bits() == z.to_bits())
    );
}

#[test]
fn the_filters_jump_to_the_state_the_steps_reach() {
    let (form, u, y, start) = filters_case(5000, 8);
    let rec = Record {
        u: &u,
        y: &y,
        instrument: None,
    };
    for ts in [3..4003, 10..73, 0..5000, 7..7] {
        let (mut stepped, mut jumped) = (start.clone(), start.clone());
        for t in ts.clone() {
            stepped.step(&form, &rec, 0.37, t);
        }
        jumped.jump(&form, &rec, 0.37, ts.clone());
        for (s, j) in stepped.w.iter().zip(&jumped.w) {
            assert!(
                (s - j).abs() <= 1e-13 * (1.0 + s.abs()),
                "{ts:?}: {s} vs {j}"
            );
        }
    }
}

#[test]
fn modal_form_reproduces_a() {
    let (a, _, _) = system();
    let f = ModalForm::of(&a).expect("well-conditioned modes");
    let back = &f.v * f.lambda() * &f.v_inv;
    assert!((back - &a).norm() < 1e-12);
    assert_eq!(f.modes.len(), 3);
}

#[test]
fn defective_a_keeps_the_direct_route() {
    let a = DMatrix::from_row_slice(2, 2, &[0.5, 1.0, 0.0, 0.5]);
    assert!(ModalForm::of(&a).is_none());
    assert!(ModalForm::of(&DMatrix::zeros(0, 0)).is_none());
    // A nilpotent A (FIR model) is defective too; A = 0 is diagonal.
    let nil = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
    assert!(ModalForm::of(&nil).is_none());
    assert!(ModalForm::of(&DMatrix::zeros(3, 3)).is_some());
}

/// More sampling patterns than the modal route keeps (five outputs
/// missing at random) fall back to the direct route: the same bits.
#[test]
fn many_sampling_patterns_take_the_direct_route() {
    let (a, b, _) = system();
    let c = DMatrix::from_fn(5, 4, |i, j| ((i + 2 * j) % 5) as f64 * 0.3 + 0.1);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let n = 800;
    let u = DMatrix::from_fn(n, 2, |_, _| if rng.random::<bool>() { 1.0 } else { -1.0 });
    let mut x = nalgebra::DVector::zeros(4);
    let mut y = DMatrix::zeros(n, 5);
    for t in 0..n {
        let yt: nalgebra::DVector<f64> = &c * &x;
        for o in 0..5 {
            y[(t, o)] = if rng.random::<f64>() < 0.3 {
                f64::NAN
            } else {
                yt[o]
            };
        }
        x = &a * &x + &b * u.row(t).transpose();
    }
    let recs = [Record {
        u: &u,
        y: &y,
        instrument: None,
    }];
    let (ft, x0) = (Feedthrough::Free, InitialState::Estimate);
    let (fast, slow) = both_routes(&a, &c, &recs, &ft, x0, true);
    assert_eq!(fast, slow);
    assert!((&fast.b - &b).norm() < 1e-8 * b.norm());
}

/// The modal base rows give the direct route's (B, D, x₀, offsets) to
/// rounding: several records, multirate NaN patterns, a D mask, with
/// and without x₀ and offsets. Both records outlive their free
/// response (0.854ᵗ < 1e-30 from t ≈ 440): their later rows go
/// through the narrow accumulator without the x₀ columns, across
/// several blocks.
#[test]
fn modal_route_equals_direct_route() {
    let (a, b, c) = system();
    let (u1, mut y1) = record(&a, &b, &c, 6000, 1);
    let (u2, mut y2) = record(&a, &b, &c, 1700, 2);
    // Output 2 sampled every third instant in the first record, output
    // 1 missing at a few instants of the second.
    for t in 0..y1.nrows() {
        if t % 3 != 0 {
            y1[(t, 1)] = f64::NAN;
        }
    }
    for t in (5..y2.nrows()).step_by(97) {
        y2[(t, 0)] = f64::NAN;
    }
    let recs = [
        Record {
            u: &u1,
            y: &y1,
            instrument: None,
        },
        Record {
            u: &u2,
            y: &y2,
            instrument: None,
        },
    ];
    let mask = Feedthrough::Mask(DMatrix::from_row_slice(2, 2, &[true, false, true, true]));
    for ft in [Feedthrough::Free, Feedthrough::Zero, mask] {
        for x0 in [InitialState::Estimate, InitialState::Zero] {
            for offsets in [false, true] {
                let (fast, slow) = both_routes(&a, &c, &recs, &ft, x0, offsets);
                let close =
                    |x: &DMatrix<f64>, y: &DMatrix<f64>| (x - y).norm() <= 1e-9 * (1.0 + y.norm());
                assert!(close(&fast.b, &slow.b), "{ft:?} {x0:?} {offsets}");
                assert!(close(&fast.d, &slow.d), "{ft:?} {x0:?} {offsets}");
                for (p, q) in fast.x0.iter().zip(&slow.x0) {
                    assert!((p - q).norm() <= 1e-8 * (1.0 + q.norm()));
                }
                for (p, q) in fast.offsets.iter().zip(&slow.offsets) {
                    assert!((p - q).norm() <= 1e-9 * (1.0 + q.norm()));
                }
                if offsets && x0 == InitialState::Estimate {
                    // The estimate itself is right (noise 0.05 uniform).
                    assert!((&fast.b - &b).norm() < 0.02 * b.norm());
                }
            }
        }
    }
}

/// A free response that dies out before n rows (modes 1e-40, 0, 0):
/// the factor still has q rows (fuzzing found an R of fewer rows than
/// the regression reads, a panic); both routes agree on (B, D) and on
/// whether x₀ is identifiable.
#[test]
fn a_free_response_gone_within_n_rows_keeps_the_full_factor() {
    let a = DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(&[1e-40, 0.0, 0.0]));
    let b = DMatrix::from_row_slice(3, 1, &[1.0, 0.5, -0.3]);
    let c = DMatrix::from_row_slice(1, 3, &[1.0, 1.0, 0.5]);
    let n = 300;
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let u = DMatrix::from_fn(n, 1, |_, _| if rng.random::<bool>() { 1.0 } else { -1.0 });
    let mut x = nalgebra::DVector::zeros(3);
    let mut y = DMatrix::zeros(n, 1);
    for t in 0..n {
        y[(t, 0)] = (&c * &x)[0] + 0.2 * u[(t, 0)];
        x = &a * &x + &b * u.row(t).transpose();
    }
    let recs = [Record {
        u: &u,
        y: &y,
        instrument: None,
    }];
    for offsets in [false, true] {
        let run = |allow_modal| {
            let route = Route {
                offsets,
                allow_modal,
                threads: 1,
            };
            output_error_route(
                &a,
                &c,
                &recs,
                &Feedthrough::Free,
                InitialState::Estimate,
                route,
            )
        };
        match (run(true), run(false)) {
            (Ok(fast), Ok(slow)) => {
                assert!((&fast.b - &slow.b).norm() <= 1e-8 * (1.0 + slow.b.norm()));
                assert!((&fast.d - &slow.d).norm() <= 1e-8 * (1.0 + slow.d.norm()));
            }
            // x₀ of a state gone after one step is not identifiable:
            // both refuse (their numerical rank counts may differ by
            // the 1e-40 entry only the direct route keeps).
            (Err(e), Err(f)) => {
                for m in [e.to_string(), f.to_string()] {
                    assert!(m.contains("rank deficient"), "{m}");
                }
            }
            (f, s) => panic!("modal {f:?} against direct {s:?}"),
        }
    }
}

#[test]
fn threads_split_long_records_with_the_same_result() {
    let (a, b, c) = system();
    let n = 3 * PARALLEL_MIN_SAMPLES + 123;
    let (u, mut y) = record(&a, &b, &c, n, 5);
    // Output 2 sampled every fourth instant: two patterns in every
    // range, one range boundary inside a stretch of missing samples.
    for t in 0..n {
        if t % 4 != 0 {
            y[(t, 1)] = f64::NAN;
        }
    }
    let (u2, y2) = record(&a, &b, &c, 900, 6);
    let recs = [
        Record {
            u: &u,
            y: &y,
            instrument: None,
        },
        Record {
            u: &u2,
            y: &y2,
            instrument: None,
        },
    ];
    for x0 in [InitialState::Estimate, InitialState::Zero] {
        let run = |threads| {
            let route = Route {
                offsets: true,
                allow_modal: true,
                threads,
            };
            output_error_route(&a, &c, &recs, &Feedthrough::Free, x0, route).unwrap()
        };
        let one = run(1);
        for threads in [2, 3, 4] {
            let many = run(threads);
            let close =
                |x: &DMatrix<f64>, y: &DMatrix<f64>| (x - y).norm() <= 1e-10 * (1.0 + y.norm());
            assert!(close(&many.b, &one.b), "{threads} threads, {x0:?}");
            assert!(close(&many.d, &one.d), "{threads} threads, {x0:?}");
            for (p, q) in many.x0.iter().zip(&one.x0) {
                assert!((p - q).norm() <= 1e-9 * (1.0 + q.norm()));
            }
            for (p, q) in many.offsets.iter().zip(&one.offsets) {
                assert!((p - q).norm() <= 1e-10 * (1.0 + q.norm()));
            }
        }
        // Same threads, same bits.
        assert_eq!(run(2).b, run(2).b);
    }
}

/// The filters in vector lanes give the scalar loop's values (equal as
/// numbers: only a zero's sign may differ), written values and end states,
/// for real modes, pairs, mixed and odd orders, one to three inputs, up to
/// the lanes' largest layout, and stretches that are no multiple of the
/// lanes' chunk.
#[test]
fn the_lanes_run_the_scalar_filters() {
    let Some(simd) = lifted_linalg::simd::Avx2Fma::detect() else {
        return;
    };
    let mut rng = ChaCha8Rng::seed_from_u64(44);
    let cases: Vec<(Vec<Mode>, usize)> = vec![
        (vec![Mode::Real(0.9)], 1),
        (vec![Mode::Pair(0.7, 0.5)], 2),
        (
            vec![Mode::Real(0.9), Mode::Real(0.5), Mode::Pair(0.64, 0.48)],
            2,
        ),
        (vec![Mode::Pair(0.3, -0.2), Mode::Real(-0.6)], 3),
        (
            vec![
                Mode::Real(0.1),
                Mode::Pair(0.5, 0.4),
                Mode::Real(0.95),
                Mode::Pair(-0.2, 0.7),
                Mode::Real(0.0),
            ],
            2,
        ),
        (
            vec![
                Mode::Pair(0.9, 0.1),
                Mode::Pair(0.8, 0.2),
                Mode::Pair(0.7, 0.3),
                Mode::Pair(0.6, 0.4),
            ],
            4,
        ),
    ];
    for (modes, nu) in cases {
        let n: usize = modes
            .iter()
            .map(|m| if matches!(m, Mode::Real(_)) { 1 } else { 2 })
            .sum();
        let form = ModalForm {
            modes: modes.clone(),
            v: DMatrix::identity(n, n),
            v_inv: DMatrix::identity(n, n),
        };
        let lanes = lanes::Lanes::of(&modes, nu).expect("within the lanes");
        let len = 300;
        let u = DMatrix::from_fn(len + 7, nu, |_, _| rng.random::<f64>() - 0.5);
        let w0: Vec<f64> = (0..n * nu).map(|_| rng.random::<f64>()).collect();
        let ts = 3..3 + len;
        let stride = len + 5;
        let (mut wa, mut wb) = (w0.clone(), w0.clone());
        let (mut ba, mut bb) = (vec![0.0; n * nu * stride], vec![0.0; n * nu * stride]);
        lanes.run(
            simd,
            &mut wa,
            &u,
            1.5,
            ts.clone(),
            Some((&mut ba, stride, 2)),
        );
        form.run_scalar(&mut wb, &u, 1.5, ts.clone(), Some((&mut bb, stride, 2)));
        assert_eq!(wa, wb, "{modes:?} × {nu}: end states");
        assert_eq!(ba, bb, "{modes:?} × {nu}: written values");
        // Without writing: the same end states.
        let mut wc = w0.clone();
        lanes.run(simd, &mut wc, &u, 1.5, ts, None);
        assert_eq!(wc, wb, "{modes:?} × {nu}: end states without writing");
    }
    // Beyond the lanes' layout: none (the scalar loop runs).
    assert!(lanes::Lanes::of(&[Mode::Real(0.5); 5], 8).is_none());
}

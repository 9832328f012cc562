//! Structural results: thesis §4.3 example, zeros, minreal, responses, serde.

use approx::assert_abs_diff_eq;
use lifted_lti::{C2dOptions, MinrealOptions, StateSpace, TransferFunction, series};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

use crate::common::*;

fn thesis_43() -> StateSpace {
    StateSpace::new(
        mat(3, 3, &[0.9, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]),
        mat(3, 1, &[1.0, 0.0, 0.0]),
        mat(1, 3, &[0.0, 0.0, 0.1]),
        mat(1, 1, &[0.0]),
        Some(1.0),
    )
    .unwrap()
}

/// Li (2001) §4.3, erratum L-6: the TF is 0.1/(z³ − 0.9z²), poles {0.9, 0, 0}.
#[test]
fn thesis_section_4_3_example() {
    let g = thesis_43();
    let t = g.to_tf(&MinrealOptions::default()).unwrap();
    let want = tf(&[0.1], &[1.0, -0.9, 0.0, 0.0], Some(1.0));
    assert!(tf_diff(&t, &want) < 1e-14, "{t}");
    assert_eq!(t.num(0, 0).degree(), 0);
    let p = sorted_re(g.poles().unwrap());
    for (got, want) in p.iter().zip([0.0, 0.0, 0.9]) {
        // a double eigenvalue at 0 (Jordan block) is computed to ~√ε
        assert!((got - Complex64::new(want, 0.0)).norm() < 1e-7, "{p:?}");
    }
    // Markov parameters: 0, 0, 0, 0.1, 0.09, ...
    let h = g.markov_parameters(5).unwrap();
    let want_h = [0.0, 0.0, 0.0, 0.1, 0.09, 0.081];
    for (hk, w) in h.iter().zip(want_h) {
        assert_abs_diff_eq!(hk[(0, 0)], w, epsilon = 1e-15);
    }
    assert!(g.zeros().unwrap().is_empty());
}

#[test]
fn siso_and_mimo_zeros() {
    // (s+2)(s−1)/((s+1)(s+3)(s+4)): zeros −2, 1
    let num = &poly(&[1.0, 2.0]) * &poly(&[1.0, -1.0]);
    let den = &(&poly(&[1.0, 1.0]) * &poly(&[1.0, 3.0])) * &poly(&[1.0, 4.0]);
    let g = TransferFunction::siso(num, den, None)
        .unwrap()
        .to_ss()
        .unwrap();
    let z = sorted_re(g.zeros().unwrap());
    assert_eq!(z.len(), 2);
    assert!(
        (z[0] - Complex64::new(-2.0, 0.0)).norm() < 1e-10
            && (z[1] - Complex64::new(1.0, 0.0)).norm() < 1e-10,
        "{z:?}"
    );
    // tall 2×1 system with a common zero at −2 only
    let g1 = tf(&[1.0, 2.0], &[1.0, 4.0, 3.0], None);
    let g2 = tf(&[1.0, 2.0], &[1.0, 8.0, 16.0], None);
    let col = TransferFunction::from_entries(
        vec![vec![g1.entry(0, 0).clone()], vec![g2.entry(0, 0).clone()]],
        None,
    )
    .unwrap();
    let s = col.to_ss().unwrap();
    assert_eq!(s.order(), 4);
    let z = s.zeros().unwrap();
    assert_eq!(z.len(), 1, "{z:?}");
    assert!((z[0] - Complex64::new(-2.0, 0.0)).norm() < 1e-8, "{z:?}");
    // wide 1×2 (the dual) has the same zero
    let wide = StateSpace::new(
        s.a().transpose(),
        s.c().transpose(),
        s.b().transpose(),
        s.d().transpose(),
        None,
    )
    .unwrap();
    let zw = wide.zeros().unwrap();
    assert_eq!(zw.len(), 1);
    assert!((zw[0] - Complex64::new(-2.0, 0.0)).norm() < 1e-8);
    // square 2×2 with invertible D: zeros = eig(A − B D⁻¹ C)
    let sq = StateSpace::new(
        mat(2, 2, &[-1.0, 0.5, 0.0, -2.0]),
        mat(2, 2, &[1.0, 0.0, 0.3, 1.0]),
        mat(2, 2, &[1.0, 1.0, 0.0, 2.0]),
        mat(2, 2, &[1.0, 0.2, 0.0, 1.0]),
        None,
    )
    .unwrap();
    let a2 = sq.a() - sq.b() * sq.d().clone().try_inverse().unwrap() * sq.c();
    let want = sorted_re(a2.complex_eigenvalues().iter().copied().collect());
    let got = sorted_re(sq.zeros().unwrap());
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).norm() < 1e-10);
    }
    // zeros are invariant under the transmission: G(z) loses rank there
    let g0 = sq.eval_complex(got[0]).unwrap();
    assert!(g0.determinant().norm() < 1e-9);
}

#[test]
fn minreal_removes_uncontrollable_and_unobservable() {
    let g = tf(&[1.0, 0.5], &[1.0, 1.2, 0.8], None).to_ss().unwrap();
    // append an uncontrollable mode (B row 0) and an unobservable one (C col 0)
    let n = g.order();
    let mut a = DMatrix::zeros(n + 2, n + 2);
    a.view_mut((0, 0), (n, n)).copy_from(g.a());
    a[(n, n)] = -5.0;
    a[(n + 1, n + 1)] = -7.0;
    a[(n, 0)] = 1.0; // driven by the plant but not observed
    let mut b = DMatrix::zeros(n + 2, 1);
    b.view_mut((0, 0), (n, 1)).copy_from(g.b());
    b[(n, 0)] = 1.0;
    let mut c = DMatrix::zeros(1, n + 2);
    c.view_mut((0, 0), (1, n)).copy_from(g.c());
    c[(0, n + 1)] = 3.0; // observed but never excited
    let big = StateSpace::new(a, b, c, g.d().clone(), None).unwrap();
    let r = big.minreal(&MinrealOptions::default()).unwrap();
    assert_eq!(r.order(), 2);
    let pts: Vec<_> = [0.1, 1.0, 10.0]
        .iter()
        .map(|&w| Complex64::new(0.0, w))
        .collect();
    assert!(freq_diff(&g, &r, &pts) < 1e-12);
}

#[test]
fn balanced_truncation_error_bound() {
    // weakly coupled fast mode: 1/(s+1) + 0.001/(s+50)
    let g = tf(&[1.001, 50.001], &[1.0, 51.0, 50.0], None)
        .to_ss()
        .unwrap();
    let (r, hsv) = g.balanced_truncation(1).unwrap();
    assert_eq!(r.order(), 1);
    assert!(hsv[0] > hsv[1]);
    let err = g
        .parallel(&StateSpace::new(r.a().clone(), r.b().clone(), -r.c(), -r.d(), None).unwrap())
        .unwrap();
    let e = err.hinf_norm(&Default::default()).unwrap().norm;
    assert!(e <= 2.0 * hsv[1] * (1.0 + 1e-6), "{e} > 2·{}", hsv[1]);
    // Hankel singular values are similarity invariants. Tolerance: the Gramian
    // factors come from eigendecompositions, so the small value carries an
    // absolute error ~ ε·cond(T)·‖P‖/√λ_min(P) (6.6e-11 observed here).
    let t = mat(2, 2, &[2.0, 1.0, 0.5, 3.0]);
    let (_, hsv2) = g
        .similarity_transform(&t)
        .unwrap()
        .balanced_truncation(2)
        .unwrap();
    for (a, b) in hsv.iter().zip(&hsv2) {
        assert!((a - b).abs() < 1e-9 * hsv[0], "{hsv:?} vs {hsv2:?}");
    }
}

/// Rᵢ = Σₖ H_{k+i} W H_kᵀ (the definition E[y(k+i)y(k)ᵀ]) vs the Lyapunov form (III-2/III-3).
#[test]
fn covariance_parameters_match_markov_sum() {
    let g = StateSpace::new(
        mat(2, 2, &[0.5, 0.2, -0.3, 0.6]),
        mat(2, 2, &[1.0, 0.0, 0.5, 1.0]),
        mat(1, 2, &[1.0, -0.4]),
        mat(1, 2, &[0.3, 0.1]),
        Some(1.0),
    )
    .unwrap();
    let w = mat(2, 2, &[2.0, 0.3, 0.3, 1.0]);
    let r = g.covariance_parameters(&w, 4).unwrap();
    let h = g.markov_parameters(400).unwrap();
    for (i, ri) in r.iter().enumerate() {
        let mut s = DMatrix::zeros(1, 1);
        for k in 0..(400 - i) {
            s += &h[k + i] * &w * h[k].transpose();
        }
        assert!((ri - &s).norm() < 1e-12, "R{i}: {ri} vs {s}");
    }
}

#[test]
fn lsim_initial_state_and_step() {
    let g = thesis_43();
    let x0 = DVector::from_vec(vec![1.0, 0.0, 0.0]);
    let u = DMatrix::zeros(6, 1);
    let r = g.lsim(&u, Some(&x0), None).unwrap();
    // y(k) = C A^k x0 = 0, 0, 0.1, 0.09, 0.081, ...
    for (k, w) in [0.0, 0.0, 0.1, 0.09, 0.081, 0.0729].iter().enumerate() {
        assert_abs_diff_eq!(r.y[(k, 0)], *w, epsilon = 1e-15);
    }
    assert_eq!(r.x.shape(), (6, 3));
    // continuous step of 1/(s+1) sampled exactly
    let c = tf(&[1.0], &[1.0, 1.0], None).to_ss().unwrap();
    let y = c.step(20, Some(0.1)).unwrap().remove(0);
    for k in 0..20 {
        assert_abs_diff_eq!(y[(k, 0)], 1.0 - (-(k as f64) * 0.1).exp(), epsilon = 1e-14);
    }
    let imp = c.impulse(5, Some(0.1)).unwrap().remove(0);
    assert_abs_diff_eq!(imp[(3, 0)], (-0.3f64).exp(), epsilon = 1e-14);
}

#[test]
fn io_delays_shift_markov_parameters() {
    let g = tf(&[1.0], &[1.0, -0.5], Some(0.1)).to_ss().unwrap();
    let gd = g.with_io_delays(&[2], &[1]).unwrap();
    assert_eq!(gd.order(), 4);
    let h0 = g.markov_parameters(8).unwrap();
    let h = gd.markov_parameters(8).unwrap();
    for k in 0..=8 {
        let want = if k >= 3 { h0[k - 3][(0, 0)] } else { 0.0 };
        assert_abs_diff_eq!(h[k][(0, 0)], want, epsilon = 1e-15);
    }
}

#[test]
fn json_round_trip_with_names() {
    let g = StateSpace::new(
        mat(2, 2, &[0.5, 0.1, 0.0, 0.3]),
        mat(2, 1, &[1.0, 2.0]),
        mat(1, 2, &[1.0, 0.0]),
        mat(1, 1, &[0.0]),
        Some(0.01),
    )
    .unwrap()
    .with_input_names(vec!["fuel".into()])
    .unwrap()
    .with_output_names(vec!["speed".into()])
    .unwrap();
    let js = g.to_json().unwrap();
    assert!(js.contains("\"a\":[[0.5,0.1],[0.0,0.3]]"), "{js}");
    assert!(js.contains("\"ts\":0.01"));
    let back = StateSpace::from_json(&js).unwrap();
    assert_eq!(back, g);
    // continuous: ts null, no names
    let c = tf(&[1.0], &[1.0, 1.0], None).to_ss().unwrap();
    let js = c.to_json().unwrap();
    assert!(js.contains("\"ts\":null") && !js.contains("names"), "{js}");
    assert_eq!(StateSpace::from_json(&js).unwrap(), c);
    // static gain (no states) keeps its shape
    let k = StateSpace::gain(mat(2, 3, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]), None).unwrap();
    let back = StateSpace::from_json(&k.to_json().unwrap()).unwrap();
    assert_eq!(back, k);
    // a bad document is rejected with a named error
    assert!(matches!(
        StateSpace::from_json(r#"{"a":[[1,2]],"b":[[1]],"c":[[1]],"d":[[0]],"ts":null}"#),
        Err(lifted_lti::Error::Json { .. })
    ));
}

#[test]
fn bode_phase_is_unwrapped() {
    let g = tf(&[1.0], &[1.0, 3.0, 3.0, 1.0], None).to_ss().unwrap(); // 1/(s+1)^3
    let w: Vec<f64> = (0..200)
        .map(|k| 10f64.powf(-2.0 + 4.0 * k as f64 / 199.0))
        .collect();
    let b = g.bode(&w).unwrap();
    for (k, wk) in w.iter().enumerate() {
        let want = -3.0 * wk.atan().to_degrees();
        assert_abs_diff_eq!(b.phase_deg[k][(0, 0)], want, epsilon = 1e-9);
        assert_abs_diff_eq!(
            b.magnitude[k][(0, 0)],
            (1.0 + wk * wk).powf(-1.5),
            epsilon = 1e-12
        );
    }
}

#[test]
fn series_parallel_feedback_mimo() {
    let g = StateSpace::new(
        mat(2, 2, &[-1.0, 0.3, 0.0, -2.0]),
        mat(2, 2, &[1.0, 0.0, 0.5, 1.0]),
        mat(2, 2, &[1.0, 0.0, 0.2, 1.0]),
        mat(2, 2, &[0.1, 0.0, 0.0, 0.2]),
        None,
    )
    .unwrap();
    let k = StateSpace::new(
        mat(1, 1, &[-3.0]),
        mat(1, 2, &[1.0, 1.0]),
        mat(2, 1, &[0.5, -0.5]),
        mat(2, 2, &[1.0, 0.2, 0.0, 0.5]),
        None,
    )
    .unwrap();
    let cl = g.feedback(&k, lifted_lti::FeedbackSign::Negative).unwrap();
    for &w in &[0.0, 0.3, 2.0] {
        let s = Complex64::new(0.0, w);
        let gs = g.eval_complex(s).unwrap();
        let ks = k.eval_complex(s).unwrap();
        let i = DMatrix::<Complex64>::identity(2, 2);
        let want = &gs * (i + &ks * &gs).try_inverse().unwrap();
        assert!((cl.eval_complex(s).unwrap() - want).norm() < 1e-12);
        let ser = series(&g, &k).unwrap().eval_complex(s).unwrap();
        assert!((ser - &ks * &gs).norm() < 1e-12);
    }
    // ZOH of a MIMO model: DC gain preserved
    let gd = g.c2d(0.05, &C2dOptions::default()).unwrap();
    assert!((gd.dc_gain().unwrap() - g.dc_gain().unwrap()).norm() < 1e-12);
}

#[test]
fn mimo_tf_round_trip() {
    let e = |n: &[f64], d: &[f64]| tf(n, d, None).entry(0, 0).clone();
    let g = TransferFunction::from_entries(
        vec![
            vec![e(&[1.0], &[1.0, 1.0]), e(&[2.0], &[1.0, 2.0])],
            vec![e(&[1.0, 0.0], &[1.0, 1.0]), e(&[0.5], &[1.0, 3.0, 2.0])],
        ],
        None,
    )
    .unwrap();
    let s = g.to_ss().unwrap();
    // McMillan degree 3: residue at −1 has rank 2, at −2 rank 1
    assert_eq!(s.order(), 3);
    let back = s.to_tf(&MinrealOptions::default()).unwrap();
    for i in 0..2 {
        for j in 0..2 {
            let a = TransferFunction::siso(g.num(i, j).clone(), g.den(i, j).clone(), None).unwrap();
            let b = TransferFunction::siso(back.num(i, j).clone(), back.den(i, j).clone(), None)
                .unwrap();
            assert!(tf_diff(&a, &b) < 1e-10, "({i},{j}): {b}");
        }
    }
}

//! Property tests (proptest) of identities, over seeded random plants.

use lifted_lti::{C2dOptions, FeedbackSign, MinrealOptions, Poly, StateSpace, TransferFunction};
use nalgebra::DMatrix;
use num_complex::Complex64;
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::common::*;

/// Random continuous stable (A, B, C, D): Gaussian-ish entries, A shifted so
/// its spectral abscissa is −0.5·margin.
fn random_stable(seed: u64, n: usize, m: usize, p: usize) -> StateSpace {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut r = |rows, cols| DMatrix::from_fn(rows, cols, |_, _| rng.random_range(-1.0..1.0));
    let mut a: DMatrix<f64> = r(n, n);
    let (b, c, d) = (r(n, m), r(p, n), r(p, m));
    let abscissa = a
        .complex_eigenvalues()
        .iter()
        .map(|z| z.re)
        .fold(f64::NEG_INFINITY, f64::max);
    for i in 0..n {
        a[(i, i)] -= abscissa + 0.5;
    }
    StateSpace::new(a, b, c, d, None).unwrap()
}

fn jw_points() -> Vec<Complex64> {
    [0.0, 0.2, 1.0, 3.0, 20.0]
        .iter()
        .map(|&w| Complex64::new(0.0, w))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    #[test]
    fn feedback_with_zero_controller_is_identity(seed in any::<u64>(), n in 1usize..5, m in 1usize..3, p in 1usize..3) {
        let g = random_stable(seed, n, m, p);
        let k = StateSpace::gain(DMatrix::zeros(m, p), None).unwrap();
        let cl = g.feedback(&k, FeedbackSign::Negative).unwrap();
        prop_assert!(freq_diff(&g, &cl, &jw_points()) < 1e-13);
        let gd = g.c2d(0.1, &C2dOptions::default()).unwrap();
        let kd = StateSpace::gain(DMatrix::zeros(m, p), Some(0.1)).unwrap();
        let h1 = gd.markov_parameters(10).unwrap();
        let h2 = gd.feedback(&kd, FeedbackSign::Positive).unwrap().markov_parameters(10).unwrap();
        for (a, b) in h1.iter().zip(&h2) {
            prop_assert!((a - b).norm() < 1e-13);
        }
    }

    /// Minimum-phase SISO G with D ≠ 0: G⁻¹·G = 1 (frequency response and
    /// Markov parameters of the discretised series connection).
    #[test]
    fn series_with_inverse_is_identity(seed in any::<u64>(), n in 1usize..5) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let roots = |rng: &mut ChaCha8Rng| (0..n).map(|_| Complex64::new(-rng.random_range(0.2..3.0), 0.0)).collect::<Vec<_>>();
        let zs = roots(&mut rng);
        let ps = roots(&mut rng);
        let k = rng.random_range(0.5..2.0);
        let g = TransferFunction::siso(Poly::from_roots(&zs).unwrap().scale(k), Poly::from_roots(&ps).unwrap(), None).unwrap().to_ss().unwrap();
        let gi = g.inverse().unwrap();
        let id = g.series(&gi).unwrap();
        for s in jw_points() {
            let v = id.eval_complex(s).unwrap()[(0, 0)];
            prop_assert!((v - 1.0).norm() < 1e-9, "{v}");
        }
        let h = id.c2d(0.05, &C2dOptions::default()).unwrap().markov_parameters(20).unwrap();
        prop_assert!((h[0][(0, 0)] - 1.0).abs() < 1e-9);
        for hk in &h[1..] {
            prop_assert!(hk[(0, 0)].abs() < 1e-9, "{}", hk[(0, 0)]);
        }
    }

    #[test]
    fn tf_ss_tf_round_trip(seed in any::<u64>(), n in 1usize..6, rel_deg in 0usize..3) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut den = vec![1.0];
        den.extend((0..n).map(|_| rng.random_range(-2.0..2.0)));
        let nn = n.saturating_sub(rel_deg);
        let num: Vec<f64> = (0..=nn).map(|_| rng.random_range(-2.0..2.0)).collect();
        let g = tf(&num, &den, Some(0.1));
        let back = g.to_ss().unwrap().to_tf(&MinrealOptions { tol: 0.0 }).unwrap();
        // compare as rational functions (coefficients can be ill-conditioned for clustered roots)
        for &z in &[Complex64::new(0.3, 1.7), Complex64::new(-2.1, 0.4), Complex64::new(2.5, -1.0)] {
            let a = g.eval(z).unwrap()[(0, 0)];
            let b = back.eval(z).unwrap()[(0, 0)];
            prop_assert!((a - b).norm() <= 1e-8 * (1.0 + a.norm()), "{a} vs {b}");
        }
        prop_assert_eq!(back.den(0, 0).degree(), n);
    }

    #[test]
    fn minreal_drops_appended_uncontrollable_mode(seed in any::<u64>(), n in 1usize..5, m in 1usize..3, p in 1usize..3) {
        let g = random_stable(seed, n, m, p);
        // generic random (A, B, C) is minimal
        prop_assume!(g.minreal(&MinrealOptions::default()).unwrap().order() == n);
        // appended mode x' = −0.7 x: not excited (B row 0) but seen by the
        // plant states and the outputs, so uncontrollable and observable
        let mut a = DMatrix::zeros(n + 1, n + 1);
        a.view_mut((0, 0), (n, n)).copy_from(g.a());
        a[(n, n)] = -0.7;
        for i in 0..n { a[(i, n)] = 0.3; }
        let mut b = DMatrix::zeros(n + 1, m);
        b.view_mut((0, 0), (n, m)).copy_from(g.b());
        let mut c = DMatrix::from_element(p, n + 1, 1.0);
        c.view_mut((0, 0), (p, n)).copy_from(g.c());
        let big = StateSpace::new(a, b, c, g.d().clone(), None).unwrap();
        let r = big.minreal(&MinrealOptions::default()).unwrap();
        prop_assert!(freq_diff(&g, &r, &jw_points()) < 1e-10);
        prop_assert_eq!(r.order(), n);
    }

    #[test]
    fn d2c_of_c2d_is_identity(seed in any::<u64>(), n in 1usize..5, m in 1usize..3) {
        let g = random_stable(seed, n, m, 1);
        let t = 0.1;
        let back = g.c2d(t, &C2dOptions::default()).unwrap().d2c().unwrap();
        let scale = g.a().norm().max(1.0);
        prop_assert!((back.a() - g.a()).norm() < 1e-9 * scale, "{}", (back.a() - g.a()).norm());
        prop_assert!((back.b() - g.b()).norm() < 1e-9 * scale);
        prop_assert!(freq_diff(&g, &back, &jw_points()) < 1e-9);
    }
}

/// σ_min/σ_max of the Rosenbrock matrix [A − zI, B; C, D] at z.
fn rosenbrock_rank_gap(g: &StateSpace, z: Complex64) -> (f64, Vec<f64>) {
    let (n, m, p) = (g.order(), g.n_inputs(), g.n_outputs());
    let mut r = DMatrix::<Complex64>::zeros(n + p, n + m);
    for i in 0..n {
        for j in 0..n {
            r[(i, j)] = Complex64::new(g.a()[(i, j)], 0.0)
                - if i == j { z } else { Complex64::new(0.0, 0.0) };
        }
        for j in 0..m {
            r[(i, n + j)] = Complex64::new(g.b()[(i, j)], 0.0);
        }
    }
    for i in 0..p {
        for j in 0..n {
            r[(n + i, j)] = Complex64::new(g.c()[(i, j)], 0.0);
        }
        for j in 0..m {
            r[(n + i, n + j)] = Complex64::new(g.d()[(i, j)], 0.0);
        }
    }
    let mut s: Vec<f64> = r.singular_values().iter().copied().collect();
    s.sort_by(|a, b| b.total_cmp(a));
    (s[0], s)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    /// Square random systems: D = 0 (generic CB invertible) has n − m finite
    /// zeros, invertible D has n; at every zero the (n+m)-square Rosenbrock
    /// matrix is singular. Tall/wide random systems have no zeros.
    #[test]
    fn transmission_zeros_are_rank_drops(seed in any::<u64>(), n in 2usize..6, m in 1usize..3, with_d in any::<bool>()) {
        prop_assume!(m < n);
        let mut g = random_stable(seed, n, m, m);
        if !with_d {
            g = StateSpace::new(g.a().clone(), g.b().clone(), g.c().clone(), DMatrix::zeros(m, m), None).unwrap();
        }
        let z = g.zeros().unwrap();
        let expected = if with_d { n } else { n - m };
        prop_assert_eq!(z.len(), expected, "{:?}", z);
        for &zi in &z {
            let (smax, s) = rosenbrock_rank_gap(&g, zi);
            // zeros of a random system can be ill-conditioned: relative 1e-7
            prop_assert!(s[s.len() - 1] <= 1e-7 * smax * (1.0 + zi.norm()), "{zi}: {s:?}");
        }
        let tall = random_stable(seed ^ 0x5555, n, m, m + 1);
        prop_assert!(tall.zeros().unwrap().is_empty());
        let wide = random_stable(seed ^ 0xaaaa, n, m + 1, m);
        prop_assert!(wide.zeros().unwrap().is_empty());
    }

    /// H∞ of random stable MIMO models: not below a frequency grid, and
    /// σ_max at the returned peak frequency equals the returned norm.
    #[test]
    fn hinf_is_consistent_with_frequency_response(seed in any::<u64>(), n in 1usize..6, m in 1usize..3, p in 1usize..3, discrete in any::<bool>()) {
        let mut g = random_stable(seed, n, m, p);
        if discrete {
            g = g.c2d(0.3, &C2dOptions::default()).unwrap();
        }
        let opts = lifted_lti::HinfOptions::default();
        let h = g.hinf_norm(&opts).unwrap();
        let wmax = if discrete { std::f64::consts::PI / 0.3 } else { 100.0 };
        let grid: Vec<f64> = (0..=2000).map(|k| wmax * k as f64 / 2000.0).collect();
        let smax = |gm: &DMatrix<Complex64>| gm.clone().singular_values().iter().fold(0.0f64, |a, &b| a.max(b));
        let best = g.freqresp(&grid).unwrap().iter().map(smax).fold(0.0, f64::max);
        // The iteration guarantees the norm to its stated relative tolerance
        // (HinfOptions::rel_tol), so a grid maximum may exceed it by that much.
        prop_assert!(h.norm >= best * (1.0 - 2.0 * opts.rel_tol), "{} < {best}", h.norm);
        let at_peak = if h.peak_frequency.is_infinite() {
            g.d().clone().svd(false, false).singular_values.iter().fold(0.0f64, |a, &b| a.max(b))
        } else {
            smax(&g.freqresp(&[h.peak_frequency]).unwrap()[0])
        };
        prop_assert!((at_peak - h.norm).abs() <= 1e-9 * h.norm, "{at_peak} vs {}", h.norm);
    }
}

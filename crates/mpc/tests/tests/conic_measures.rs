//! β via the conic form of (9.8), MIMO β, and Prop. 5 as SOCPs.
use super::common::*;
use lifted_lti::{HinfOptions, StateSpace, append};
use lifted_mpc::*;
use nalgebra::{DMatrix, DVector, dmatrix};
use num_complex::Complex64;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Bound on max_θ f − max_k f(θ_k) for the grid θ_k = π(k+½)/K: the
/// supremum θ* lies within h/2 = π/(2K) of a grid point and f′(θ*) = 0
/// (interior maximum, or θ* = π where f is even about π), so the loss is
/// at most ½·max|f″|·(h/2)². |f″| is estimated by a central difference
/// (δ = 1e-3) at θ* and doubled for its variation over h/2; 1e-8 covers
/// the solver tolerance (1e-10 relative).
fn grid_bound(t: &StateSpace, n: usize, theta: f64, grid: usize) -> f64 {
    let f = |th: f64| alias_gain(t, n, th).unwrap();
    let d = 1e-3;
    let f2 = ((f(theta + d) - 2.0 * f(theta) + f(theta - d)) / (d * d)).abs();
    let h = std::f64::consts::PI / grid as f64;
    0.5 * 2.0 * f2 * (h / 2.0).powi(2) + 1e-8
}

/// T̲R₁ as a lifted state space (its first p inputs), for the exact
/// Hamiltonian H∞ norm of `lifted-lti` — independent of any θ grid.
fn lifted_switched(t: &StateSpace, n: usize) -> StateSpace {
    let tl = lift(t, n).unwrap();
    let p = t.n_inputs();
    StateSpace::new(
        tl.a().clone(),
        tl.b().columns(0, p).into_owned(),
        tl.c().clone(),
        tl.d().columns(0, p).into_owned(),
        tl.ts(),
    )
    .unwrap()
}

fn hinf(s: &StateSpace) -> f64 {
    s.hinf_norm(&HinfOptions {
        rel_tol: 1e-12,
        ..HinfOptions::default()
    })
    .unwrap()
    .norm
}

/// 2×2 case: tank model, diagonal PI, coupled first-order weight.
fn mimo() -> (StateSpace, StateSpace, StateSpace) {
    let k = append(
        &tf(&[3.0, -2.8], &[1.0, -1.0]),
        &tf(&[4.0, -3.7], &[1.0, -1.0]),
    )
    .unwrap();
    let w = StateSpace::new(
        dmatrix![0.5, 0.0; 0.0, 0.3],
        dmatrix![0.1, 0.02; -0.03, 0.08],
        dmatrix![1.0, 0.2; 0.0, 1.0],
        dmatrix![0.01, 0.0; 0.0, 0.02],
        Some(1.0),
    )
    .unwrap();
    (tank(), k, w)
}

#[test]
fn socp_beta_matches_closed_form_example96() {
    // spec A3.11 figures; the closed form and the SOCP are compared with the grid bound
    let (phat, k, _, w1) = example96();
    let t = robustness_map(&phat, &k, &w1, Uncertainty::Additive).unwrap();
    let opts = ConicOptions::default();
    for (n, paper) in [
        (1, 1.2582),
        (2, 0.9220),
        (3, 0.9975),
        (4, 0.9071),
        (5, 0.8488),
        (8, 0.7826),
    ] {
        let cf = beta_dr(
            &phat,
            &k,
            &w1,
            Uncertainty::Additive,
            n,
            &RobustnessOptions::default(),
        )
        .unwrap();
        let s = beta_socp(&phat, &k, &w1, Uncertainty::Additive, n, &opts).unwrap();
        let bound = grid_bound(&t, n, cf.theta, opts.grid);
        assert_eq!(s.rounds, 1, "SISO: one SOCP, no cutting planes");
        assert!(
            cf.value - s.value <= bound,
            "n = {n}: {} vs {} (bound {bound:e})",
            cf.value,
            s.value
        );
        assert!(
            s.value - cf.value <= 1e-8,
            "the grid optimum cannot exceed the supremum"
        );
        assert!((s.value - s.grid_max).abs() <= 1e-8);
        assert!((s.value - paper).abs() < 1e-3);
    }
}

#[test]
fn mimo_beta_three_routes_and_exact_lifted_hinf() {
    let (p, k, w) = mimo();
    let o = RobustnessOptions::default();
    for unc in [Uncertainty::Additive, Uncertainty::Multiplicative] {
        let t = robustness_map(&p, &k, &w, unc).unwrap();
        let sr = beta_sr(&p, &k, &w, unc).unwrap();
        for n in 1..=4 {
            let cf = beta_dr(&p, &k, &w, unc, n, &o).unwrap();
            let bf = beta_dr_lifted(&p, &k, &w, unc, n, &o).unwrap();
            let exact = hinf(&lifted_switched(&t, n));
            let s = beta_socp(&p, &k, &w, unc, n, &ConicOptions::default()).unwrap();
            // closed form and brute force maximise to θ_tol 1e-10; Hamiltonian to 1e-12
            assert!(
                (cf.value - exact).abs() < 1e-8 * exact,
                "{unc:?} n = {n}: {} vs {exact}",
                cf.value
            );
            assert!((bf.value - exact).abs() < 1e-8 * exact);
            let bound = grid_bound(&t, n, cf.theta, ConicOptions::default().grid);
            assert!(
                exact - s.value <= bound && s.value <= exact + 1e-8,
                "{unc:?} n = {n}: socp {} vs {exact}",
                s.value
            );
            // Cor. 1 and the lower bound β_sr/√n
            assert!(cf.value <= sr.value + 1e-9);
            assert!(cf.value >= sr.value / (n as f64).sqrt() - 1e-9);
            if n == 1 {
                assert!((cf.value - sr.value).abs() < 1e-8 * sr.value);
            }
        }
    }
}

#[test]
fn block_diagonal_beta_is_the_larger_siso_beta() {
    let p1 = tf(&[0.15], &[1.0, -0.9]);
    let p2 = tf(&[0.2, 0.05], &[1.0, -0.7, 0.1]);
    let k1 = tf(&[3.5, -3.0], &[1.0, -1.0]);
    let k2 = tf(&[1.2, -1.0], &[1.0, -1.0]);
    let w1 = tf(&[0.1], &[1.0, -0.5]);
    let w2 = tf(&[0.3, 0.1], &[1.0, 0.2, 0.0]);
    let (p, k, w) = (
        append(&p1, &p2).unwrap(),
        append(&k1, &k2).unwrap(),
        append(&w1, &w2).unwrap(),
    );
    let o = RobustnessOptions::default();
    for n in [2, 3, 5] {
        let a = beta_dr(&p1, &k1, &w1, Uncertainty::Additive, n, &o)
            .unwrap()
            .value;
        let b = beta_dr(&p2, &k2, &w2, Uncertainty::Additive, n, &o)
            .unwrap()
            .value;
        let ab = beta_dr(&p, &k, &w, Uncertainty::Additive, n, &o)
            .unwrap()
            .value;
        assert!(
            (ab - a.max(b)).abs() < 1e-9,
            "n = {n}: {ab} vs max({a}, {b})"
        );
    }
}

#[test]
fn mimo_dimension_checks() {
    let (p, k, w) = mimo();
    let o = RobustnessOptions::default();
    let siso_k = tf(&[3.5, -3.0], &[1.0, -1.0]);
    assert!(matches!(
        beta_dr(&p, &siso_k, &w, Uncertainty::Additive, 2, &o),
        Err(Error::DimensionMismatch { .. })
    ));
    let w3 = StateSpace::new(
        dmatrix![0.5],
        dmatrix![1.0, 0.0, 0.0],
        dmatrix![1.0],
        dmatrix![0.0, 0.0, 0.0],
        Some(1.0),
    )
    .unwrap();
    assert!(matches!(
        beta_socp(
            &p,
            &k,
            &w3,
            Uncertainty::Multiplicative,
            2,
            &ConicOptions::default()
        ),
        Err(Error::DimensionMismatch { .. })
    ));
    assert!(matches!(
        beta_socp(
            &p,
            &k,
            &w,
            Uncertainty::Additive,
            2,
            &ConicOptions {
                grid: 0,
                ..ConicOptions::default()
            }
        ),
        Err(Error::InvalidArgument { .. })
    ));
    assert!(matches!(
        beta_socp(
            &p,
            &k,
            &w,
            Uncertainty::Additive,
            0,
            &ConicOptions::default()
        ),
        Err(Error::InvalidArgument { .. })
    ));
    let t = robustness_map(&p, &k, &w, Uncertainty::Additive).unwrap();
    assert!(matches!(
        alias_gain(&t, 0, 1.0),
        Err(Error::InvalidArgument { .. })
    ));
    assert!(matches!(
        alias_gain(&t, 2, f64::NAN),
        Err(Error::NonFinite { .. })
    ));
}

/// A realisation of the FIR Q(z) = Σ Q_i z^{−i} (m×p taps): states are
/// the delayed inputs — independent of the tap algebra inside `prop5`.
fn fir(taps: &[DMatrix<f64>]) -> StateSpace {
    let (m, p) = taps[0].shape();
    let l = taps.len();
    let nx = p * (l - 1);
    let mut a = DMatrix::zeros(nx, nx);
    for i in p..nx {
        a[(i, i - p)] = 1.0;
    }
    let mut b = DMatrix::zeros(nx, p);
    let mut c = DMatrix::zeros(m, nx);
    for i in 0..p.min(nx) {
        b[(i, i)] = 1.0;
    }
    for (i, q) in taps.iter().enumerate().skip(1) {
        c.columns_mut((i - 1) * p, p).copy_from(q);
    }
    StateSpace::new(a, b, c, taps[0].clone(), Some(1.0)).unwrap()
}

/// max over θ_k of σ_max((I − P̲Q̲R₁)W̲₂), from lifted state spaces.
fn dual_rate_cost(
    p: &StateSpace,
    w2: &StateSpace,
    taps: &[DMatrix<f64>],
    n: usize,
    grid: usize,
) -> f64 {
    let (pl, ql, wl) = (
        lift(p, n).unwrap(),
        lift(&fir(taps), n).unwrap(),
        lift(w2, n).unwrap(),
    );
    let ny = p.n_outputs();
    (0..grid)
        .map(|k| {
            let z =
                Complex64::from_polar(1.0, std::f64::consts::PI * (k as f64 + 0.5) / grid as f64);
            let mut q = ql.eval_complex(z).unwrap();
            for c in ny..q.ncols() {
                q.column_mut(c).fill(Complex64::new(0.0, 0.0));
            }
            let w = wl.eval_complex(z).unwrap();
            sigma_max(&(&w - pl.eval_complex(z).unwrap() * q * &w)).unwrap()
        })
        .fold(0.0, f64::max)
}

/// max over the fast grid of σ_max((I − PQ)W₂).
fn single_rate_cost(p: &StateSpace, w2: &StateSpace, taps: &[DMatrix<f64>], omegas: &[f64]) -> f64 {
    let q = fir(taps);
    omegas
        .iter()
        .map(|&w| {
            let z = Complex64::from_polar(1.0, w);
            let wz = w2.eval_complex(z).unwrap();
            sigma_max(&(&wz - p.eval_complex(z).unwrap() * q.eval_complex(z).unwrap() * &wz))
                .unwrap()
        })
        .fold(0.0, f64::max)
}

fn grid(k: usize) -> Vec<f64> {
    (0..k)
        .map(|i| std::f64::consts::PI * (i as f64 + 0.5) / k as f64)
        .collect()
}

#[test]
fn gamma_sr_analytic_optimum() {
    // P = 0.15/(z − 0.9), W₂ = 0.2/(z − 0.8): ‖(1 − PQ)W₂‖∞ ≥ |first Markov
    // parameter of z·(1 − PQ)W₂| = 0.2 (P has one delay; maximum modulus), attained
    // by Q = (0.8/0.15)(1 − 0.9z⁻¹) (then (1 − PQ)W₂ = 0.2z⁻¹): an FIR of length 2.
    let p = tf(&[0.15], &[1.0, -0.9]);
    let w2 = tf(&[0.2], &[1.0, -0.8]);
    for l in [2, 5] {
        let r = gamma_sr(
            &p,
            &w2,
            &Prop5Options {
                fir_length: l,
                grid: 64,
                ..Prop5Options::default()
            },
        )
        .unwrap();
        assert_eq!(r.rounds, 1);
        assert!((r.gamma - 0.2).abs() < 1e-7, "L = {l}: {}", r.gamma);
        assert!((r.lower_bound - 0.2).abs() < 1e-7);
        // on a grid the optimiser is not unique for L > 2; for L = 2 it is
        if l == 2 {
            assert!(
                (r.taps[0][(0, 0)] - 0.8 / 0.15).abs() < 1e-4,
                "{:?}",
                r.taps
            );
            assert!((r.taps[1][(0, 0)] + 0.8 * 0.9 / 0.15).abs() < 1e-4);
        }
    }
}

#[test]
fn gamma_sr_one_tap_equals_golden_section() {
    // L = 1: J(q) = max_k |(1 − P q)W₂| is convex in the scalar q; golden
    // section on [−100, 100] to 1e-11 is an independent minimiser.
    let p = tf(&[0.3, 0.1], &[1.0, -0.5, 0.06]);
    let w2 = tf(&[0.5], &[1.0, -0.6]);
    let omegas = grid(48);
    let j = |q: f64| single_rate_cost(&p, &w2, &[DMatrix::from_element(1, 1, q)], &omegas);
    let (mut a, mut b) = (-100.0f64, 100.0f64);
    let g = (5f64.sqrt() - 1.0) / 2.0;
    while b - a > 1e-11 {
        let (x1, x2) = (b - g * (b - a), a + g * (b - a));
        if j(x1) < j(x2) { b = x2 } else { a = x1 }
    }
    let r = gamma_sr(
        &p,
        &w2,
        &Prop5Options {
            fir_length: 1,
            grid: 48,
            ..Prop5Options::default()
        },
    )
    .unwrap();
    assert!(
        (r.gamma - j(0.5 * (a + b))).abs() < 1e-8,
        "{} vs {}",
        r.gamma,
        j(0.5 * (a + b))
    );
    assert!((r.gamma - single_rate_cost(&p, &w2, &r.taps, &omegas)).abs() < 1e-12);
}

#[test]
fn prop5_siso_random_pairs() {
    let mut rng = ChaCha8Rng::seed_from_u64(55);
    let opts = Prop5Options {
        fir_length: 5,
        grid: 32,
        ..Prop5Options::default()
    };
    for _ in 0..4 {
        let pole = rng.random::<f64>() * 1.6 - 0.8;
        let zero = rng.random::<f64>() * 2.4 - 1.2; // may be non-minimum phase
        let p = tf(&[0.2, -0.2 * zero], &[1.0, -pole, 0.0]);
        let w2 = tf(&[0.4], &[1.0, -(rng.random::<f64>() * 1.6 - 0.8)]);
        let n = 2 + (rng.random::<f64>() * 3.0) as usize;
        let r = prop5(&p, &w2, n, &opts).unwrap();
        let (sr, dr) = (&r.single_rate, &r.dual_rate);
        assert!(
            dr.lower_bound >= sr.gamma - 1e-6,
            "Prop. 5: {} < {}",
            dr.lower_bound,
            sr.gamma
        );
        assert!(
            r.averaged >= sr.lower_bound - 1e-7 && r.averaged <= dr.gamma + 1e-9,
            "{r:?}"
        );
        // the costs at the returned taps, recomputed from FIR state spaces
        assert!(
            (dual_rate_cost(&p, &w2, &dr.taps, n, opts.grid) - dr.gamma).abs()
                < 1e-10 * dr.gamma.max(1.0)
        );
        let omegas: Vec<f64> = grid(opts.grid)
            .iter()
            .flat_map(|t| {
                (0..n).map(move |l| (t + 2.0 * std::f64::consts::PI * l as f64) / n as f64)
            })
            .collect();
        assert!(
            (single_rate_cost(&p, &w2, &sr.taps, &omegas) - sr.gamma).abs()
                < 1e-10 * sr.gamma.max(1.0)
        );
        assert!(dr.gamma - dr.lower_bound <= 1e-6 * dr.gamma);
    }
}

#[test]
fn prop5_mimo_2x2_certified_optimum() {
    // 2×2: the SOCP lower bound is a global certificate, so no tap vector
    // (random or near the optimum) may cost less than it.
    let p = tank();
    let w2 = StateSpace::new(
        dmatrix![0.8, 0.0; 0.0, 0.6],
        dmatrix![0.2, 0.0; 0.05, 0.3],
        dmatrix![1.0, 0.0; 0.0, 1.0],
        DMatrix::zeros(2, 2),
        Some(1.0),
    )
    .unwrap();
    let n = 2;
    let opts = Prop5Options {
        fir_length: 2,
        grid: 12,
        ..Prop5Options::default()
    };
    let r = prop5(&p, &w2, n, &opts).unwrap();
    let (sr, dr) = (&r.single_rate, &r.dual_rate);
    assert!(dr.lower_bound >= sr.gamma - 1e-6);
    assert!(r.averaged >= sr.lower_bound - 1e-7 && r.averaged <= dr.gamma + 1e-9);
    for m in [sr, dr] {
        assert!(m.gamma - m.lower_bound <= 1e-6 * m.gamma, "{m:?}");
    }
    assert!((dual_rate_cost(&p, &w2, &dr.taps, n, opts.grid) - dr.gamma).abs() < 1e-10);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let flat =
        |t: &[DMatrix<f64>]| DVector::from_iterator(8, t.iter().flat_map(|q| q.iter().copied()));
    let x0 = flat(&dr.taps);
    for scale in [1e-3, 1e-2, 0.1, 1.0, 10.0] {
        for _ in 0..10 {
            let x = &x0 + DVector::from_fn(8, |_, _| scale * (rng.random::<f64>() - 0.5));
            let taps: Vec<DMatrix<f64>> = (0..2)
                .map(|i| DMatrix::from_column_slice(2, 2, &x.as_slice()[4 * i..4 * i + 4]))
                .collect();
            let j = dual_rate_cost(&p, &w2, &taps, n, opts.grid);
            assert!(
                j >= dr.lower_bound - 1e-9,
                "cost {j} below the certificate {}",
                dr.lower_bound
            );
        }
    }
}

#[test]
fn prop5_rejects_bad_input() {
    let p = tf(&[0.15], &[1.0, -0.9]);
    let w2 = tf(&[0.2], &[1.0, -0.8]);
    let o = Prop5Options::default();
    let unstable = tf(&[0.1], &[1.0, -1.05]);
    assert!(matches!(
        gamma_sr(&unstable, &w2, &o),
        Err(Error::Unstable { .. })
    ));
    assert!(matches!(
        gamma_dr(&p, &unstable, 2, &o),
        Err(Error::Unstable { .. })
    ));
    assert!(matches!(
        prop5(&tank(), &w2, 2, &o),
        Err(Error::DimensionMismatch { .. })
    ));
    let cont = StateSpace::new(
        dmatrix![-1.0],
        dmatrix![1.0],
        dmatrix![1.0],
        dmatrix![0.0],
        None,
    )
    .unwrap();
    assert!(matches!(
        gamma_sr(&cont, &w2, &o),
        Err(Error::InvalidModel { .. })
    ));
    let slow = lifted_lti::TransferFunction::from_coeffs(&[0.2], &[1.0, -0.8], Some(2.0))
        .unwrap()
        .to_ss()
        .unwrap();
    assert!(matches!(
        gamma_sr(&p, &slow, &o),
        Err(Error::InvalidModel { .. })
    ));
    assert!(matches!(
        gamma_dr(&p, &w2, 0, &o),
        Err(Error::InvalidArgument { .. })
    ));
    assert!(matches!(
        gamma_sr(&p, &w2, &Prop5Options { fir_length: 0, ..o }),
        Err(Error::InvalidArgument { .. })
    ));
    assert!(matches!(
        gamma_sr(
            &p,
            &w2,
            &Prop5Options {
                minimax: MinimaxOptions {
                    gap_tol: f64::NAN,
                    ..MinimaxOptions::default()
                },
                ..o
            }
        ),
        Err(Error::InvalidArgument { .. })
    ));
    // one cutting-plane round cannot close the dual-rate gap
    assert!(matches!(
        gamma_dr(
            &p,
            &w2,
            3,
            &Prop5Options {
                minimax: MinimaxOptions {
                    max_rounds: 1,
                    ..MinimaxOptions::default()
                },
                ..o
            }
        ),
        Err(Error::NoConvergence { .. })
    ));
}

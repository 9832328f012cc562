//! Predictor-based subspace identification on closed-loop data without
//! an instrument (issue 27): a SISO third-order plant and a 2×2
//! fourth-order plant, each in innovations form (coloured output noise
//! H(z) = C(zI − A)⁻¹K + I sharing the plant's poles), under PI control
//! u = k_p ε + k_i Σε, ε = r − y, so that the noise is fed back through
//! the controller; the reference r is not given to the estimators.
//!
//! Checks: the pole error of PBSID falls like 1/√N from 1e4 to 1e6
//! samples while N4SID's stays biased; on open-loop data PBSID and N4SID
//! agree within the noise.

use lifted_lti::StateSpace;
use lifted_subspace::*;
use nalgebra::DMatrix;

use crate::common::*;

/// A plant with the given poles, its innovations gain K and the PI gains
/// (k_p, k_i) of a stable loop.
struct Loop {
    plant: StateSpace,
    k: DMatrix<f64>,
    kp: f64,
    ki: f64,
    /// Input matrix of the controller, u = M (k_p ε + k_i Σε): the inverse
    /// DC gain of the plant (a decoupling PI), so that the loop is stable
    /// for small gains whatever the signs of the plant's DC gains.
    m: DMatrix<f64>,
    /// Past horizon of PBSID: ρ(A − KC)^p < 1e-4.
    past: usize,
}

/// M = G(1)⁻¹ of the plant.
fn decoupler(g: &StateSpace) -> DMatrix<f64> {
    g.dc_gain().unwrap().try_inverse().unwrap()
}

/// SISO, poles 0.9, 0.7 e^{±0.6i}.
fn siso() -> Loop {
    let plant = random_system(31, &[0.9], &[(0.7, 0.6)], 1, 1, false);
    let k = predictor_gain(&plant, 1.0);
    Loop {
        m: decoupler(&plant),
        past: 20,
        plant,
        k,
        kp: 0.3,
        ki: 0.05,
    }
}

/// 2×2, poles 0.95, 0.6 and 0.8 e^{±0.5i}.
fn mimo() -> Loop {
    let plant = random_system(2024, &[0.95, 0.6], &[(0.8, 0.5)], 2, 2, false);
    let k = predictor_gain(&plant, 10.0);
    Loop {
        m: decoupler(&plant),
        past: 40,
        plant,
        k,
        kp: 0.3,
        ki: 0.05,
    }
}

/// The steady-state Kalman predictor gain of the plant for process noise
/// q·I and unit measurement noise (a DARE on the dual pair): A − K C is
/// stable, and the larger q the faster its poles.
fn predictor_gain(g: &StateSpace, q: f64) -> DMatrix<f64> {
    let (n, ny) = (g.order(), g.c().nrows());
    let q = DMatrix::<f64>::identity(n, n) * q;
    let r = DMatrix::<f64>::identity(ny, ny);
    let sol = lifted_linalg::dare(&g.a().transpose(), &g.c().transpose(), &q, &r, None).unwrap();
    sol.k.transpose()
}

/// The closed loop: returns (u, y) of `n` samples with reference
/// standard deviation `r_sd` and innovation standard deviation `e_sd`;
/// `open` runs the plant with u = r instead (open loop).
fn simulate(
    l: &Loop,
    n: usize,
    seed: u64,
    r_sd: f64,
    e_sd: f64,
    open: bool,
) -> (DMatrix<f64>, DMatrix<f64>) {
    let (a, b, c) = (l.plant.a(), l.plant.b(), l.plant.c());
    let (nx, nu, ny) = (a.nrows(), b.ncols(), c.nrows());
    let r = white(1000 + seed, n, nu, r_sd);
    let e = white(2000 + seed, n, ny, e_sd);
    let mut x = nalgebra::DVector::zeros(nx);
    let mut s = nalgebra::DVector::zeros(ny);
    let mut u = DMatrix::zeros(n, nu);
    let mut y = DMatrix::zeros(n, ny);
    for t in 0..n {
        let et = e.row(t).transpose();
        let yt = c * &x + &et;
        let ut = if open {
            r.row(t).transpose()
        } else {
            let eps = r.row(t).transpose() - &yt;
            let ut = &l.m * (&eps * l.kp + &s * l.ki);
            s += eps;
            ut
        };
        x = a * &x + b * &ut + &l.k * &et;
        u.row_mut(t).copy_from(&ut.transpose());
        y.row_mut(t).copy_from(&yt.transpose());
    }
    (u, y)
}

/// Spectral radius of the closed loop [x; s] (must be < 1).
fn loop_radius(l: &Loop) -> f64 {
    let (a, b, c) = (l.plant.a(), l.plant.b(), l.plant.c());
    let (nx, ny) = (a.nrows(), c.nrows());
    let mut m = DMatrix::zeros(nx + ny, nx + ny);
    m.view_mut((0, 0), (nx, nx))
        .copy_from(&(a - b * &l.m * c * l.kp));
    m.view_mut((0, nx), (nx, ny)).copy_from(&(b * &l.m * l.ki));
    m.view_mut((nx, 0), (ny, nx)).copy_from(&(-c));
    m.view_mut((nx, nx), (ny, ny)).fill_with_identity();
    lifted_linalg::eigenvalues(&m)
        .unwrap()
        .iter()
        .map(|z| z.norm())
        .fold(0.0, f64::max)
}

fn predictor_radius(l: &Loop) -> f64 {
    let ac = l.plant.a() - &l.k * l.plant.c();
    lifted_linalg::eigenvalues(&ac)
        .unwrap()
        .iter()
        .map(|z| z.norm())
        .fold(0.0, f64::max)
}

/// Largest distance between true and estimated poles under the best
/// pairing (greedy on sorted lists is not enough for complex pairs: all
/// pairings of up to 4 poles).
fn pole_error(truth: &StateSpace, est: &StateSpace) -> f64 {
    let t = truth.poles().unwrap();
    let e = est.poles().unwrap();
    assert_eq!(t.len(), e.len());
    let mut best = f64::INFINITY;
    let mut idx: Vec<usize> = (0..e.len()).collect();
    permute(&mut idx, 0, &mut |perm| {
        let worst = t
            .iter()
            .zip(perm)
            .map(|(a, &j)| (a - e[j]).norm())
            .fold(0.0, f64::max);
        best = best.min(worst);
    });
    best
}

fn permute(v: &mut Vec<usize>, k: usize, visit: &mut dyn FnMut(&[usize])) {
    if k == v.len() {
        visit(v);
        return;
    }
    for i in k..v.len() {
        v.swap(k, i);
        permute(v, k + 1, visit);
        v.swap(k, i);
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

fn pbsid_options(n: usize, past: usize) -> PbsidOptions {
    PbsidOptions {
        order: OrderSelection::Fixed(n),
        past: Some(past),
        ..Default::default()
    }
}

fn n4sid_options(n: usize) -> SubspaceOptions {
    SubspaceOptions {
        order: OrderSelection::Fixed(n),
        past: 10,
        future: 10,
        feedthrough: Feedthrough::Zero,
        ..Default::default()
    }
}

/// Median pole errors of PBSID and N4SID over `seeds` closed-loop records.
fn errors(l: &Loop, n: usize, seeds: u64, open: bool) -> (f64, f64) {
    let order = l.plant.order();
    let (mut pb, mut n4) = (Vec::new(), Vec::new());
    for seed in 0..seeds {
        let (u, y) = simulate(l, n, seed, 1.0, 0.25, open);
        let exp = [Experiment { u: &u, y: &y }];
        let p = pbsid_identify(&exp, &pbsid_options(order, l.past)).unwrap();
        pb.push(pole_error(&l.plant, &p.model));
        let m = identify(&exp, &n4sid_options(order)).unwrap();
        n4.push(pole_error(&l.plant, &m.model));
    }
    (median(pb), median(n4))
}

/// Least-squares slope of ln e against ln N.
fn slope(ns: &[usize], e: &[f64]) -> f64 {
    let x: Vec<f64> = ns.iter().map(|&n| (n as f64).ln()).collect();
    let y: Vec<f64> = e.iter().map(|v| v.ln()).collect();
    let (mx, my) = (
        x.iter().sum::<f64>() / x.len() as f64,
        y.iter().sum::<f64>() / y.len() as f64,
    );
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

fn check_loop(name: &str, l: &Loop, seeds: u64) {
    assert!(
        loop_radius(l) < 0.99,
        "{name}: closed loop {}",
        loop_radius(l)
    );
    let truncation = predictor_radius(l).powi(l.past as i32);
    assert!(truncation < 1e-4, "{name}: ρ(A − KC)^p = {truncation}");
    let ns = [10_000, 100_000, 1_000_000];
    let (pb, n4): (Vec<f64>, Vec<f64>) = ns.iter().map(|&n| errors(l, n, seeds, false)).unzip();
    let s = slope(&ns, &pb);
    eprintln!("{name}: PBSID median pole error {pb:?} (slope {s:.3}), N4SID {n4:?}");
    // 1/√N is a slope of −0.5 on the log-log plot. At 1e4 samples the
    // errors are not yet in the linear regime (they hold second-order
    // terms: measured ratios 1e4 → 1e5 of 5–8× against 3.2× from 1e5 to
    // 1e6), which steepens the three-point fit to about −0.6…−0.7; a bias
    // would flatten it towards 0. Accepted: a fitted slope in
    // [−0.8, −0.4], and at least 2.3× per decade from 1e5 to 1e6 (√10 =
    // 3.16; the medians of 9–15 seeds scatter by about ±20 %).
    assert!((-0.8..=-0.4).contains(&s), "{name}: PBSID slope {s}");
    assert!(pb[1] / pb[2] >= 2.3, "{name}: PBSID 1e5 → 1e6 {pb:?}");
    // N4SID stays biased: from 1e5 to 1e6 its error falls by less than
    // 1.5× (1/√N would give 3.2×) and at 1e6 it is at least 5× PBSID's.
    assert!(n4[1] / n4[2] < 1.5, "{name}: N4SID {n4:?}");
    assert!(n4[2] > 5.0 * pb[2], "{name}: N4SID {n4:?} vs PBSID {pb:?}");
}

#[test]
fn pbsid_is_consistent_in_closed_loop_siso() {
    check_loop("SISO order 3", &siso(), 15);
}

#[test]
fn pbsid_is_consistent_in_closed_loop_mimo() {
    check_loop("2x2 order 4", &mimo(), 9);
}

/// Open loop (u = r white): both methods are consistent, and PBSID's
/// median pole error and N4SID's are within a factor of 2 of each other at
/// 1e5 samples (the two estimators have different but comparable
/// variances; a bias of either would show as a larger factor, as N4SID's
/// 12–67× in closed loop above), and their models' frequency responses
/// differ by less than 2 % (measured 0.09 % SISO and 0.5 % 2×2, each model
/// 0.3–0.6 % from the truth: the noise level).
fn check_open_loop(name: &str, l: &Loop, seeds: u64) {
    let (pb, n4) = errors(l, 100_000, seeds, true);
    eprintln!("{name} open loop at 1e5: PBSID {pb:.3e}, N4SID {n4:.3e}");
    assert!(pb <= 2.0 * n4 && n4 <= 2.0 * pb, "{name}: {pb} vs {n4}");
    let (u, y) = simulate(l, 100_000, 77, 1.0, 0.25, true);
    let exp = [Experiment { u: &u, y: &y }];
    let order = l.plant.order();
    let p = pbsid_identify(&exp, &pbsid_options(order, l.past)).unwrap();
    let m = identify(&exp, &n4sid_options(order)).unwrap();
    let fr = freq_error(&p.model, &m.model);
    eprintln!(
        "{name} open loop, seed 77: FR difference {fr:.3e} (PBSID–truth {:.3e}, N4SID–truth {:.3e})",
        freq_error(&p.model, &l.plant),
        freq_error(&m.model, &l.plant)
    );
    assert!(fr < 0.02, "{name}: {fr}");
}

#[test]
fn pbsid_agrees_with_n4sid_in_open_loop_siso() {
    check_open_loop("SISO order 3", &siso(), 9);
}

#[test]
fn pbsid_agrees_with_n4sid_in_open_loop_mimo() {
    check_open_loop("2x2 order 4", &mimo(), 9);
}

/// Every option route agrees with the truth on one closed-loop record of
/// 1e5 samples: the row-wise variant, SSARX, the automatic past horizon, the
/// state-sequence (B, K) without the predictor regression. Each pole
/// error is below 0.05 (measured 0.009–0.019; N4SID's median is 0.06,
/// biased). A free D is not among them: this PI controller reacts to y(t)
/// in the same sample, so u(t) is correlated with e(t) and an estimated D
/// is biased (pole error 0.054 measured), as the module docs say.
#[test]
fn pbsid_option_routes_agree_in_closed_loop() {
    let l = siso();
    let (u, y) = simulate(&l, 100_000, 3, 1.0, 0.25, false);
    let exp = [Experiment { u: &u, y: &y }];
    let base = pbsid_options(3, 20);
    let variants = [
        ("default", base.clone()),
        (
            "row-wise",
            PbsidOptions {
                variant: PbsidVariant::RowWise,
                ..base.clone()
            },
        ),
        (
            "SSARX",
            PbsidOptions {
                variant: PbsidVariant::Ssarx,
                ..base.clone()
            },
        ),
        (
            "automatic past",
            PbsidOptions {
                past: None,
                ..base.clone()
            },
        ),
        (
            "no predictor regression",
            PbsidOptions {
                predictor_regression: false,
                ..base.clone()
            },
        ),
    ];
    for (name, opts) in variants {
        let fit = pbsid_identify(&exp, &opts).unwrap();
        let err = pole_error(&l.plant, &fit.model);
        let dg = &fit.diagnostics;
        eprintln!(
            "{name}: pole error {err:.3e}, horizons {:?}, notes {:?}",
            dg.horizons, dg.notes
        );
        assert!(err < 0.05, "{name}: {err}");
        assert_eq!(fit.model.d()[(0, 0)], 0.0, "{name}");
        assert_eq!(dg.predictor_regression, opts.predictor_regression, "{name}");
        if opts.past.is_none() {
            let (p, f) = dg.horizons;
            assert!(
                (f..=30).contains(&p) && !dg.past_selection.is_empty(),
                "{name}: {p}"
            );
        }
    }
}

/// Rejected inputs name the problem.
#[test]
fn pbsid_rejects_bad_input() {
    let l = siso();
    let (u, y) = simulate(&l, 2_000, 1, 1.0, 0.25, false);
    let exp = [Experiment { u: &u, y: &y }];
    let run = |opts: PbsidOptions| pbsid_identify(&exp, &opts).unwrap_err();
    assert!(matches!(
        pbsid_identify(&[], &PbsidOptions::default()),
        Err(Error::NoData)
    ));
    let mut bad = y.clone();
    bad[(17, 0)] = f64::NAN;
    assert!(matches!(
        pbsid_identify(&[Experiment { u: &u, y: &bad }], &PbsidOptions::default()),
        Err(Error::NonFinite {
            what: "y",
            row: 17,
            col: 0
        })
    ));
    let short = y.rows(0, 1_999).into_owned();
    assert!(matches!(
        pbsid_identify(&[Experiment { u: &u, y: &short }], &PbsidOptions::default()),
        Err(Error::DimensionMismatch { .. })
    ));
    let e = run(PbsidOptions {
        past: Some(5),
        future: 10,
        ..Default::default()
    });
    assert!(
        matches!(e, Error::InvalidHorizon { what: "future", .. }),
        "{e}"
    );
    let e = run(PbsidOptions {
        past: Some(0),
        ..Default::default()
    });
    assert!(
        matches!(e, Error::InvalidHorizon { what: "past", .. }),
        "{e}"
    );
    let e = run(PbsidOptions {
        past: Some(900),
        ..Default::default()
    });
    assert!(matches!(e, Error::HorizonTooLong { .. }), "{e}");
    let e = run(PbsidOptions {
        order: OrderSelection::Fixed(11),
        past: Some(10),
        ..Default::default()
    });
    assert!(matches!(e, Error::OrderTooLarge { .. }), "{e}");
    let e = run(PbsidOptions {
        order_criterion: OrderCriterion::Aic,
        ..Default::default()
    });
    assert!(
        matches!(
            e,
            Error::InvalidOption {
                what: "order_criterion",
                ..
            }
        ),
        "{e}"
    );
    let e = run(PbsidOptions {
        past: Some(1 << 40),
        future: 1,
        ..Default::default()
    });
    assert!(matches!(e, Error::Linalg(_)), "{e}");
    // Noise-free data under a static controller: u = −0.5 y makes the
    // past inputs a multiple of the past outputs.
    let (_, y0) = simulate(&l, 2_000, 1, 1.0, 0.0, true);
    let u0 = &y0 * -0.5;
    let e = pbsid_identify(
        &[Experiment { u: &u0, y: &y0 }],
        &PbsidOptions {
            past: Some(10),
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(matches!(e, Error::NotExciting { .. }), "{e}");
}

/// Two records of one loop (different seeds) identify the plant as well
/// as one record of their joint length (pole errors within 2× of each
/// other, both below 0.05), with one x₀ per record, and a record that
/// starts at a non-zero state gets a non-zero x₀.
#[test]
fn pbsid_merges_records() {
    let l = siso();
    let (u1, y1) = simulate(&l, 50_000, 5, 1.0, 0.25, false);
    let (u2, y2) = simulate(&l, 50_000, 6, 1.0, 0.25, false);
    // The second record starts mid-transient: drop its first 50 samples.
    let (u2, y2) = (
        u2.rows(50, 49_950).into_owned(),
        y2.rows(50, 49_950).into_owned(),
    );
    let opts = pbsid_options(3, 20);
    let two = pbsid_identify(
        &[Experiment { u: &u1, y: &y1 }, Experiment { u: &u2, y: &y2 }],
        &opts,
    )
    .unwrap();
    let (u, y) = simulate(&l, 100_000, 5, 1.0, 0.25, false);
    let one = pbsid_identify(&[Experiment { u: &u, y: &y }], &opts).unwrap();
    let (e2, e1) = (
        pole_error(&l.plant, &two.model),
        pole_error(&l.plant, &one.model),
    );
    eprintln!("two records {e2:.3e}, one record {e1:.3e}, x0 {:?}", two.x0);
    assert!(e2 < 0.05 && e1 < 0.05 && e2 < 2.0 * e1 && e1 < 2.0 * e2);
    assert_eq!(two.x0.len(), 2);
    assert!(two.x0[1].norm() > 0.0);
}

/// A 2×2 record whose second output is a noise-free combination of the
/// first, the state and nothing else: y1 = x1 + e, y2 = x2 − e (the same
/// measurement noise with opposite signs, so y1 + y2 = x1 + x2 exactly),
/// with first-order states x1 (pole 0.8) and x2 (pole 0.5) driven by
/// random binary inputs.
fn tied_outputs(n: usize, seed: u64) -> (DMatrix<f64>, DMatrix<f64>) {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
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
    (u, y)
}

/// Past outputs that are linearly dependent given the past inputs (an
/// output that is a noise-free combination of the others, as a computed
/// or duplicated channel) make the VARX regressor rank deficient beyond
/// two lags here: an automatic past horizon is shortened to the longest
/// full-rank one, with a note, and every variant finds the plant's poles
/// (before: refused, "numerical rank 32, 40 needed"); a given past
/// horizon is refused with the remedy named, and inputs tied to the
/// outputs at every lag stay refused (`pbsid_rejects_bad_input`).
#[test]
fn linearly_dependent_past_outputs_shorten_an_automatic_past() {
    let (u, y) = tied_outputs(300, 5);
    let exp = [Experiment { u: &u, y: &y }];
    let truth = StateSpace::new(
        DMatrix::from_row_slice(2, 2, &[0.8, 0.0, 0.0, 0.5]),
        DMatrix::from_row_slice(2, 2, &[0.5, 0.0, 0.2, 0.3]),
        DMatrix::identity(2, 2),
        DMatrix::zeros(2, 2),
        Some(1.0),
    )
    .unwrap();
    for variant in [
        PbsidVariant::Optimized,
        PbsidVariant::RowWise,
        PbsidVariant::Ssarx,
    ] {
        let opts = PbsidOptions {
            variant,
            order: OrderSelection::Fixed(2),
            ..Default::default()
        };
        let fit = pbsid_identify(&exp, &opts).unwrap();
        // Z_s has full rank up to s = 2 lags (two states, y1 + y2 = x1 + x2
        // is free over two samples, determined by them and the inputs
        // from the third on).
        assert_eq!(fit.diagnostics.horizons, (2, 2), "{variant:?}");
        assert!(
            fit.diagnostics
                .notes
                .iter()
                .any(|n| n.contains("shortened to p = 2, f = 2")),
            "{:?}",
            fit.diagnostics.notes
        );
        // The noise is 1 % of the outputs' spread: poles within 0.01.
        let err = pole_error(&truth, &fit.model);
        assert!(err < 0.01, "{variant:?}: pole error {err}");
        // The held-out order search runs at the shortened horizons and
        // finds the plant's order.
        let sel = select_pbsid_order(
            &exp,
            &PbsidOptions {
                variant,
                ..Default::default()
            },
            &StructureOptions::default(),
        )
        .unwrap();
        assert_eq!((sel.horizon, sel.future, sel.order), (2, 2, 2), "{sel:?}");
        assert!(sel.notes.iter().any(|n| n.contains("shortened")));
    }
    // A given past horizon is kept, so refused, with the remedy named.
    let e = pbsid_identify(
        &exp,
        &PbsidOptions {
            past: Some(10),
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            Error::NotExciting {
                rank: 32,
                needed: 40,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("shorter past horizon"), "{e}");
}

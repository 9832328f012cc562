use super::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

fn gauss(seed: u64, n: usize, m: usize, sd: f64) -> DMatrix<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    DMatrix::from_fn(n, m, |_, _| {
        let v: f64 = StandardNormal.sample(&mut rng);
        sd * v
    })
}

/// y = q⁻²(0.5 + 0.3q⁻¹)/(1 − 1.2q⁻¹ + 0.5q⁻²) u + e.
fn truth() -> PolyModel {
    PolyModel::oe(&[0.5, 0.3], &[1.0, -1.2, 0.5], 2, 1.0).unwrap()
}

fn fit(u: &DMatrix<f64>, y: &DMatrix<f64>, orders: &PolyOrders) -> OeFit {
    oe(&[Experiment { u, y }], orders, 1.0, &OeOptions::default()).unwrap()
}

#[test]
fn noise_free_oe_is_recovered() {
    let g = truth();
    let u = gauss(1, 1000, 1, 1.0);
    let y = g.simulate(&u, None).unwrap();
    let f = fit(&u, &y, &g.orders());
    for (a, b) in f.model.parameters().iter().zip(g.parameters()) {
        assert!((a - b).abs() < 1e-7, "{a} {b}");
    }
    assert!(f.loss[0] < 1e-14);
}

#[test]
fn coloured_noise_does_not_bias_it_and_the_intervals_hold() {
    // OE is consistent in open loop whatever the noise colour: with noise
    // filtered by 1/(1 − 0.9q⁻¹) (σ ≈ 0.23) the estimate stays within 4σ
    // of the truth. Then 200 seeded records with white noise: the ±1.96σ
    // interval of each of the 4 parameters holds the truth in 92–98 % of
    // the 800 parameter-runs (binomial spread ±1.5 points at 2σ).
    let g = truth();
    let u = gauss(2, 4000, 1, 1.0);
    let w = gauss(3, 4000, 1, 0.1);
    let mut e = w.clone();
    for t in 1..4000 {
        e[(t, 0)] = 0.9 * e[(t - 1, 0)] + w[(t, 0)];
    }
    let y = g.simulate(&u, None).unwrap() + e;
    let f = fit(&u, &y, &g.orders());
    let std = f.model.std().unwrap();
    for ((a, b), s) in f.model.parameters().iter().zip(g.parameters()).zip(&std) {
        assert!((a - b).abs() < 6.0 * s.max(1e-3), "{a} {b} ± {s}");
    }
    let truth = g.parameters();
    let (mut hits, mut total) = (0usize, 0usize);
    for seed in 0..200 {
        let u = gauss(100 + seed, 400, 1, 1.0);
        let e = gauss(1000 + seed, 400, 1, 0.3);
        let y = g.simulate(&u, Some(&e)).unwrap();
        let f = fit(&u, &y, &g.orders());
        let std = f.model.std().unwrap();
        for ((p, s), t) in f.model.parameters().iter().zip(&std).zip(&truth) {
            total += 1;
            if (p - t).abs() <= 1.96 * s {
                hits += 1;
            }
        }
    }
    let share = hits as f64 / total as f64;
    assert!((0.92..=0.98).contains(&share), "coverage {share}");
}

#[test]
fn a_multirate_output_gives_the_same_model_from_its_samples() {
    // The output measured every 5 samples (NaN between): the fast model
    // comes back, with larger standard deviations (one sample in five).
    let g = truth();
    let u = gauss(4, 5000, 1, 1.0);
    let y = g.simulate(&u, Some(&gauss(5, 5000, 1, 0.1))).unwrap();
    let full = fit(&u, &y, &g.orders());
    let mut slow = y.clone();
    for t in 0..5000 {
        if t % 5 != 0 {
            slow[(t, 0)] = f64::NAN;
        }
    }
    let f = fit(&u, &slow, &g.orders());
    assert_eq!(f.measured, vec![1000]);
    let (std, std_full) = (f.model.std().unwrap(), full.model.std().unwrap());
    for (((a, b), s), sf) in f
        .model
        .parameters()
        .iter()
        .zip(g.parameters())
        .zip(&std)
        .zip(&std_full)
    {
        assert!((a - b).abs() < 4.5 * s, "{a} {b} ± {s}");
        assert!(s > sf, "{s} {sf}");
    }
}

#[test]
fn two_inputs_with_their_own_delays_and_denominators() {
    let p = Polynomials {
        b: vec![vec![vec![1.0, 0.5], vec![0.4]]],
        f: Some(vec![vec![vec![1.0, -0.8], vec![1.0, -1.1, 0.4]]]),
        nk: vec![vec![1, 3]],
        ..Default::default()
    };
    let g = PolyModel::new(p, 1.0).unwrap();
    let u = gauss(6, 3000, 2, 1.0);
    let y = g.simulate(&u, Some(&gauss(7, 3000, 1, 0.05))).unwrap();
    let f = fit(&u, &y, &g.orders());
    let std = f.model.std().unwrap();
    for ((a, b), s) in f.model.parameters().iter().zip(g.parameters()).zip(&std) {
        assert!((a - b).abs() < 4.5 * s, "{a} {b} ± {s}");
    }
}

#[test]
fn bad_input_is_refused_with_a_named_error() {
    let g = truth();
    let u = gauss(8, 300, 1, 1.0);
    let y = g.simulate(&u, None).unwrap();
    let run = |u: &DMatrix<f64>, y: &DMatrix<f64>, o: &PolyOrders| {
        oe(&[Experiment { u, y }], o, 1.0, &OeOptions::default())
    };
    let mut bad = u.clone();
    bad[(3, 0)] = f64::NAN;
    assert!(matches!(
        run(&bad, &y, &g.orders()),
        Err(Error::NonFinite { what: "u", .. })
    ));
    let mut inf = y.clone();
    inf[(3, 0)] = f64::INFINITY;
    assert!(matches!(
        run(&u, &inf, &g.orders()),
        Err(Error::NonFinite { what: "y", .. })
    ));
    assert!(matches!(
        run(&u, &y, &PolyOrders::siso(1, 2, 0, 0, 2, 1)),
        Err(Error::InvalidOption { what: "orders", .. })
    ));
    assert!(matches!(
        run(&u, &y, &PolyOrders::siso(0, 0, 0, 0, 0, 1)),
        Err(Error::InvalidOption { what: "orders", .. })
    ));
    let flat = DMatrix::from_element(300, 1, 0.0);
    assert!(matches!(
        run(&flat, &y, &g.orders()),
        Err(Error::RankDeficient { .. })
    ));
    let (us, ys) = (u.rows(0, 4).into_owned(), y.rows(0, 4).into_owned());
    assert!(matches!(
        run(&us, &ys, &g.orders()),
        Err(Error::TooFewSamples { .. })
    ));
    let wide = DMatrix::from_element(300, 2, 1.0);
    assert!(matches!(
        run(&wide, &y, &g.orders()),
        Err(Error::DimensionMismatch { .. })
    ));
    assert!(matches!(
        oe(&[], &g.orders(), 1.0, &OeOptions::default()),
        Err(Error::NoData)
    ));
}

/// The second start never raises the cost: over seeded short records of an
/// over-parametrised structure (where minima other than the truth's exist),
/// the loss with two starts is at most the loss from the first start alone,
/// and on at least one record strictly lower; no start is refused.
#[test]
fn the_second_start_keeps_the_lower_cost() {
    let g = truth();
    let orders = PolyOrders::siso(0, 3, 0, 0, 3, 2);
    let (mut lower, mut cases) = (0, 0);
    for seed in 0..12 {
        let u = gauss(200 + seed, 150, 1, 1.0);
        let y = g
            .simulate(&u, Some(&gauss(300 + seed, 150, 1, 0.5)))
            .unwrap();
        let run = |starts: usize| {
            let opts = OeOptions {
                starts,
                ..Default::default()
            };
            oe(&[Experiment { u: &u, y: &y }], &orders, 1.0, &opts).map(|f| f.loss[0])
        };
        let (Ok(one), Ok(two)) = (run(1), run(2)) else {
            continue;
        };
        cases += 1;
        assert!(two <= one * (1.0 + 1e-12), "seed {seed}: {two} > {one}");
        lower += usize::from(two < one * (1.0 - 1e-9));
    }
    assert!(cases >= 10, "{cases}");
    assert!(
        lower >= 1,
        "the second start never helped on {cases} records"
    );
    let bad = OeOptions {
        starts: 0,
        ..Default::default()
    };
    let u = gauss(9, 200, 1, 1.0);
    let y = g.simulate(&u, None).unwrap();
    assert!(matches!(
        oe(&[Experiment { u: &u, y: &y }], &orders, 1.0, &bad),
        Err(Error::InvalidOption {
            what: "OE starts",
            ..
        })
    ));
}

/// A ±1 input held for `hold` samples (seeded).
fn held(seed: u64, n: usize, hold: usize) -> DMatrix<f64> {
    let g = gauss(seed, n.div_ceil(hold), 1, 1.0);
    DMatrix::from_fn(n, 1, |t, _| g[(t / hold, 0)].signum())
}

#[test]
fn an_input_held_longer_than_the_output_period_still_gives_the_model() {
    // Set-points held for 10 samples, the output read every 5th: at the
    // measured rows the lagged inputs of the FIR start repeat in groups
    // (lags 1–5 and 6–10 of a hold give the same columns), which was
    // refused as rank deficient. The minimum-norm FIR start now leads the
    // iterations to the plant: parameters within 4.5σ (their intervals
    // from the Jacobian at the optimum, where B/F are determined).
    let g = truth();
    let u = held(61, 8000, 10);
    let y = g.simulate(&u, Some(&gauss(62, 8000, 1, 0.05))).unwrap();
    let slow = DMatrix::from_fn(
        8000,
        1,
        |t, _| if t % 5 == 0 { y[(t, 0)] } else { f64::NAN },
    );
    let f = fit(&u, &slow, &g.orders());
    let std = f.model.std().unwrap();
    for ((a, b), s) in f.model.parameters().iter().zip(g.parameters()).zip(&std) {
        assert!((a - b).abs() < 4.5 * s, "{a} {b} ± {s}");
    }
    // An input that does not move at all is still refused by name.
    let still = DMatrix::zeros(8000, 1);
    assert!(matches!(
        oe(
            &[Experiment {
                u: &still,
                y: &slow
            }],
            &g.orders(),
            1.0,
            &OeOptions::default()
        ),
        Err(Error::RankDeficient { .. })
    ));
}

/// y = (1/F) [q⁻¹(1 + 0.5q⁻¹) u₁ + q⁻²(0.4 − 0.2q⁻¹) u₂] + e with one
/// F = 1 − 1.3q⁻¹ + 0.6q⁻² for both inputs (its copies per pair).
fn common_truth() -> PolyModel {
    let f = vec![1.0, -1.3, 0.6];
    let p = Polynomials {
        b: vec![vec![vec![1.0, 0.5], vec![0.4, -0.2]]],
        f: Some(vec![vec![f.clone(), f]]),
        nk: vec![vec![1, 2]],
        ..Default::default()
    };
    PolyModel::new(p, 1.0).unwrap()
}

fn fit_common(u: &DMatrix<f64>, y: &DMatrix<f64>, orders: &PolyOrders) -> Result<OeFit> {
    let opts = OeOptions {
        f_structure: FStructure::Common,
        ..Default::default()
    };
    oe(&[Experiment { u, y }], orders, 1.0, &opts)
}

#[test]
fn a_common_denominator_is_recovered_with_fewer_parameters() {
    // Noise-free: the common-F model to rounding, 6 free parameters (the
    // per-pair structure has 8); with noise, within 4.5σ, the copies of F
    // equal and perfectly correlated in the covariance, and each shared
    // f's std below the per-pair fit's (one F estimated from both inputs).
    let g = common_truth();
    let u = gauss(21, 2000, 2, 1.0);
    let y = g.simulate(&u, None).unwrap();
    let f = fit_common(&u, &y, &g.orders()).unwrap();
    assert_eq!(f.parameters, vec![6]);
    for (a, b) in f.model.parameters().iter().zip(g.parameters()) {
        assert!((a - b).abs() < 1e-7, "{a} {b}");
    }
    let y = g.simulate(&u, Some(&gauss(22, 2000, 1, 0.3))).unwrap();
    let f = fit_common(&u, &y, &g.orders()).unwrap();
    let per_pair = fit(&u, &y, &g.orders());
    let (theta, std) = (f.model.parameters(), f.model.std().unwrap());
    for ((a, b), s) in theta.iter().zip(g.parameters()).zip(&std) {
        assert!((a - b).abs() < 4.5 * s, "{a} {b} ± {s}");
    }
    // Parameters: b1 (2), b2 (2), F of u1 (2), F of u2 (2).
    assert_eq!(&theta[4..6], &theta[6..8]);
    let cov = f.model.covariance().unwrap();
    for j in 0..2 {
        let (a, b) = (4 + j, 6 + j);
        assert!((cov[(a, b)] - cov[(a, a)]).abs() <= 1e-12 * cov[(a, a)]);
        assert!(std[a] < per_pair.model.std().unwrap()[a], "{j}");
    }
}

#[test]
fn a_common_denominator_on_an_output_measured_every_fourth_sample() {
    // The same structure from every 4th output sample: within 4.5σ.
    let g = common_truth();
    let u = gauss(23, 8000, 2, 1.0);
    let mut y = g.simulate(&u, Some(&gauss(24, 8000, 1, 0.2))).unwrap();
    for t in 0..8000 {
        if t % 4 != 0 {
            y[(t, 0)] = f64::NAN;
        }
    }
    let f = fit_common(&u, &y, &g.orders()).unwrap();
    assert_eq!(f.measured, vec![2000]);
    let std = f.model.std().unwrap();
    for ((a, b), s) in f.model.parameters().iter().zip(g.parameters()).zip(&std) {
        assert!((a - b).abs() < 4.5 * s, "{a} {b} ± {s}");
    }
}

#[test]
fn a_common_denominator_needs_equal_degrees() {
    let g = common_truth();
    let u = gauss(25, 500, 2, 1.0);
    let y = g.simulate(&u, None).unwrap();
    let mut orders = g.orders();
    orders.nf[0][1] = 1;
    let e = fit_common(&u, &y, &orders).unwrap_err();
    assert!(e.to_string().contains("common F"), "{e}");
}

#[test]
fn the_steiglitz_mcbride_start_of_a_common_denominator() {
    // White noise: the Steiglitz–McBride passes from the ARX start settle
    // near the output-error estimate (F within 3σ of the truth); short
    // over-parameterised records (nf = nb = 3 for a second-order F): the
    // third start never raises the cost and lowers it on some records
    // (the start that found the lower minimum is kept).
    let g = common_truth();
    let u = gauss(31, 3000, 2, 1.0);
    let y = g.simulate(&u, Some(&gauss(32, 3000, 1, 0.3))).unwrap();
    let ex = [Experiment { u: &u, y: &y }];
    let pairs = Pairs {
        nb: vec![2, 2],
        nf: vec![2, 2],
        nk: vec![1, 2],
        common: true,
    };
    let firs = fir(&ex, 0, &pairs, 3000, &OeOptions::default()).unwrap();
    let (start0, _) = start(&ex, &pairs, &firs);
    let sm = steiglitz_mcbride(&ex, 0, &pairs, &start0).unwrap();
    let f = fit_common(&u, &y, &g.orders()).unwrap();
    let std = f.model.std().unwrap();
    for j in 0..2 {
        let truth = g.f(0, 0)[j + 1];
        assert!(
            (sm[0].1[j] - truth).abs() < 3.0 * std[4 + j],
            "{:?}",
            sm[0].1
        );
    }
    // A NaN (an unmeasured sample) leaves the start out.
    let mut slow = y.clone();
    slow[(10, 0)] = f64::NAN;
    let ex_slow = [Experiment { u: &u, y: &slow }];
    assert!(steiglitz_mcbride(&ex_slow, 0, &pairs, &start0).is_none());
    let mut orders = g.orders();
    orders.nb = vec![vec![3, 3]];
    orders.nf = vec![vec![3, 3]];
    let (mut lower, mut cases) = (0, 0);
    for seed in 0..12 {
        let u = gauss(400 + seed, 150, 2, 1.0);
        let y = g
            .simulate(&u, Some(&gauss(500 + seed, 150, 1, 0.5)))
            .unwrap();
        let run = |starts: usize| {
            let opts = OeOptions {
                starts,
                f_structure: FStructure::Common,
                ..Default::default()
            };
            oe(&[Experiment { u: &u, y: &y }], &orders, 1.0, &opts).map(|f| f.loss[0])
        };
        let (Ok(two), Ok(three)) = (run(2), run(3)) else {
            continue;
        };
        cases += 1;
        assert!(three <= two * (1.0 + 1e-12), "seed {seed}: {three} > {two}");
        lower += usize::from(three < two * (1.0 - 1e-9));
    }
    assert!(cases >= 10, "{cases}");
    assert!(
        lower >= 1,
        "the third start never helped on {cases} records"
    );
}

#[test]
fn the_per_input_fit_starts_from_the_common_one() {
    // The common-F structure is nested in the per-input one (F₁ = F₂ = F),
    // so from its optimum the per-input cost can only fall: on short
    // records of the two-denominator plant, the per-input loss is never
    // above the common-F loss nor above its own without that start
    // (starts = 2), and lower than the latter on some records.
    let p = Polynomials {
        b: vec![vec![vec![1.0, 0.5], vec![0.4, 0.3]]],
        f: Some(vec![vec![vec![1.0, -0.8, 0.1], vec![1.0, -1.1, 0.4]]]),
        nk: vec![vec![1, 1]],
        ..Default::default()
    };
    let g = PolyModel::new(p, 1.0).unwrap();
    let orders = g.orders();
    let (mut lower, mut cases) = (0, 0);
    for seed in 0..40 {
        let u = gauss(600 + seed, 80, 2, 1.0);
        let y = g
            .simulate(&u, Some(&gauss(700 + seed, 80, 1, 1.0)))
            .unwrap();
        let run = |starts: usize, f_structure: FStructure| {
            let opts = OeOptions {
                starts,
                f_structure,
                ..Default::default()
            };
            oe(&[Experiment { u: &u, y: &y }], &orders, 1.0, &opts).map(|f| f.loss[0])
        };
        let (Ok(two), Ok(three), Ok(common)) = (
            run(2, FStructure::PerInput),
            run(3, FStructure::PerInput),
            run(3, FStructure::Common),
        ) else {
            continue;
        };
        cases += 1;
        assert!(three <= two * (1.0 + 1e-12), "seed {seed}: {three} > {two}");
        assert!(
            three <= common * (1.0 + 1e-12),
            "seed {seed}: {three} > {common}"
        );
        lower += usize::from(three < two * (1.0 - 1e-9));
    }
    assert!(cases >= 10, "{cases}");
    assert!(
        lower >= 1,
        "the nested start never helped on {cases} records"
    );
}

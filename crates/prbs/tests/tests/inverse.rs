use approx::assert_abs_diff_eq;
use lifted_prbs::{
    InversePrbs, InversePrbsOptions, Normalization, held_autocorrelation,
    inverse_prbs_autocorrelation, periodic_autocorrelation,
};

fn prbs(order: u32, amplitude: f64, hold: usize) -> InversePrbs {
    InversePrbs::new(&InversePrbsOptions {
        order,
        amplitude,
        hold,
        taps: None,
    })
    .unwrap()
}

#[test]
fn golden_prefix_a1_2() {
    let u = prbs(5, 1.0, 1).generate(10);
    assert_eq!(u, [-1., -1., 1., 1., 1., 1., -1., -1., 1., 1.]);
}

/// Spec A1.2 / eq. II-5, II-6 in integer arithmetic for n = 2..=11:
/// period 2m, u(k+m) = −u(k), zero sum, and Σ u(k+τ)u(k) = 2m·{1, −1, −1/m, +1/m}.
#[test]
fn inverse_prbs_exact_properties() {
    for n in 2..=11u32 {
        let p = prbs(n, 1.0, 1);
        let m = p.m() as usize;
        let s: Vec<i64> = p.slow_signs(4 * m).into_iter().map(i64::from).collect();
        for k in 0..2 * m {
            assert_eq!(s[k + m], -s[k], "n {n}");
            assert_eq!(s[k + 2 * m], s[k], "n {n}");
        }
        assert_eq!(s[..2 * m].iter().sum::<i64>(), 0);
        for tau in 0..2 * m {
            let r: i64 = (0..2 * m).map(|k| s[(k + tau) % (2 * m)] * s[k]).sum();
            let expect = if tau == 0 {
                2 * m as i64
            } else if tau == m {
                -2 * (m as i64)
            } else if tau % 2 == 0 {
                -2
            } else {
                2
            };
            assert_eq!(r, expect, "n {n} tau {tau}");
        }
    }
}

/// The floating-point closed form equals the circular correlation to 1e-12 for
/// a ∈ {1, 2}, n = 2..=11 (A1.2 acceptance).
#[test]
fn eq_ii6_closed_form() {
    for n in 2..=11u32 {
        for a in [1.0, 2.0] {
            let p = prbs(n, a, 1);
            let m = p.m() as f64;
            let u = p.one_period();
            let r = periodic_autocorrelation(&u, Normalization::Divisor(2.0 * m)).unwrap();
            for (tau, &v) in r.iter().enumerate() {
                assert_abs_diff_eq!(v, p.slow_autocorrelation(tau as i64), epsilon = 1e-12);
                assert_abs_diff_eq!(
                    v,
                    inverse_prbs_autocorrelation(n, a, -(tau as i64)).unwrap(),
                    epsilon = 1e-12
                );
            }
        }
    }
}

/// Corrected eq. II-10 (spec A1.3) against the numerical circular correlation
/// over the whole period, n = 2..=10, n_r = 1..=12, a ∈ {1, 2}, to 1e-12.
/// Also checks the equivalent form (n_r − τ̄)R_u(q) + τ̄R_u(q+1).
#[test]
fn eq_ii10_corrected_closed_form() {
    for n in 2..=10u32 {
        for nr in 1..=12usize {
            for a in [1.0, 2.0] {
                let p = prbs(n, a, nr);
                let m = p.m();
                let w = p.one_period();
                assert_eq!(w.len() as u64, 2 * nr as u64 * m);
                let r =
                    periodic_autocorrelation(&w, Normalization::Divisor(2.0 * m as f64)).unwrap();
                for (tau, &v) in r.iter().enumerate() {
                    let t = tau as i64;
                    let closed = p.autocorrelation(t);
                    assert!(
                        (v - closed).abs() < 1e-12,
                        "n {n} nr {nr} a {a} tau {tau}: {v} vs {closed}"
                    );
                    assert_eq!(closed, held_autocorrelation(n, nr, a, t).unwrap());
                    assert!((p.autocorrelation(-t) - closed).abs() < 1e-12);
                    let (q, tb) = (t / nr as i64, (t % nr as i64) as f64);
                    let eq = (nr as f64 - tb) * p.slow_autocorrelation(q)
                        + tb * p.slow_autocorrelation(q + 1);
                    assert!((eq - closed).abs() < 1e-12);
                }
            }
        }
    }
}

/// Zhu 2000 Fig. 1 (n = 5, n_r = 3, a = 1) with erratum Z-4: R(0) = 3,
/// R(±1) = 2.0323, R(±2) = 1.0645 (printed to 4 decimals), and max |R| over
/// 3 ≤ |τ| < 90 is exactly 3/31, attained at multiples of 3.
#[test]
fn figure_1() {
    let p = prbs(5, 1.0, 3);
    let r = periodic_autocorrelation(&p.one_period(), Normalization::Divisor(62.0)).unwrap();
    let at = |t: i64| r[t.rem_euclid(r.len() as i64) as usize];
    assert_abs_diff_eq!(at(0), 3.0, epsilon = 1e-12);
    for s in [1, -1] {
        assert_abs_diff_eq!(at(s), 2.0323, epsilon = 1e-4);
        assert_abs_diff_eq!(at(2 * s), 1.0645, epsilon = 1e-4);
    }
    let mut max = 0.0f64;
    let mut attained_at = Vec::new();
    for t in 3..90i64 {
        for v in [at(t), at(-t)] {
            max = max.max(v.abs());
            if (v.abs() - 3.0 / 31.0).abs() < 1e-12 {
                attained_at.push(t);
            }
        }
    }
    assert_abs_diff_eq!(max, 3.0 / 31.0, epsilon = 1e-12);
    assert!(!attained_at.is_empty());
    assert!(attained_at.iter().all(|t| t % 3 == 0));
    // n = 10, n_r = 3: the bound is 3/1023 = 0.00293 (Zhu 2000 text).
    let p = prbs(10, 1.0, 3);
    let bound = (3..3 * 1022)
        .map(|t| p.autocorrelation(t).abs())
        .fold(0.0, f64::max);
    assert_abs_diff_eq!(bound, 3.0 / 1023.0, epsilon = 1e-15);
}

#[test]
fn held_zero_mean_and_antiperiodic() {
    let p = prbs(7, 2.0, 4);
    let w = p.generate(2 * p.period() as usize);
    let half = p.period() as usize / 2;
    assert_eq!(w[..p.period() as usize].iter().sum::<f64>(), 0.0);
    for k in 0..p.period() as usize {
        assert_eq!(w[k + half], -w[k]);
    }
    assert!(w.chunks(4).all(|c| c.iter().all(|&v| v == c[0])));
}

#[test]
fn serde_roundtrip() {
    let o = InversePrbsOptions {
        order: 9,
        amplitude: 2.0,
        hold: 10,
        taps: None,
    };
    let s = serde_json::to_string(&o).unwrap();
    let back: InversePrbsOptions = serde_json::from_str(&s).unwrap();
    assert_eq!(back, o);
    let d: InversePrbsOptions = serde_json::from_str("{}").unwrap();
    assert_eq!(d, InversePrbsOptions::default());
    let p = InversePrbs::new(&o).unwrap();
    let back: InversePrbs = serde_json::from_str(&serde_json::to_string(&p).unwrap()).unwrap();
    assert_eq!(back, p);
    // Loading validates: order 1 is rejected.
    assert!(serde_json::from_str::<InversePrbs>(r#"{"order":1}"#).is_err());
}

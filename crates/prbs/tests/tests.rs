//! Integration tests of `lifted-prbs` (spec A1.1–A1.3, A2.1, A3.8, Table II).

mod mseq {
    use lifted_prbs::{
        MSequence, Normalization, is_primitive, periodic_autocorrelation, table_taps,
    };

    /// Zhu 2000 Table I / Ren & Zhu 2009 Table 1 (spec A1.1), plus 12 and 13 of A1.1.
    const TABLE_I: [(u32, &[u32]); 12] = [
        (2, &[1, 2]),
        (3, &[2, 3]),
        (4, &[3, 4]),
        (5, &[3, 5]),
        (6, &[5, 6]),
        (7, &[4, 7]),
        (8, &[2, 3, 4, 8]),
        (9, &[5, 9]),
        (10, &[7, 10]),
        (11, &[9, 11]),
        (12, &[6, 8, 11, 12]),
        (13, &[9, 10, 12, 13]),
    ];

    #[test]
    fn table_i_taps() {
        for (n, taps) in TABLE_I {
            assert_eq!(table_taps(n).unwrap(), taps, "order {n}");
            assert_eq!(MSequence::new(n).unwrap().taps(), taps);
        }
    }

    #[test]
    fn golden_prefixes() {
        let bits = |n: u32, len: usize| -> String {
            MSequence::new(n)
                .unwrap()
                .take(len)
                .map(|b| char::from(b'0' + b))
                .collect()
        };
        assert_eq!(bits(3, 7), "1011100");
        assert_eq!(bits(5, 31), "1001011001111100011011101010000");
    }

    /// Orders 2..=20 exhaustively: the register state first returns to its initial
    /// value after exactly m steps; 2^{n−1} ones per period; the ±1 sequence has the
    /// two-valued periodic autocorrelation (m at lag 0, −1 at every other lag) —
    /// integer sums for n ≤ 11, FFT (rounded; error ≪ 0.5) for 12 ≤ n ≤ 20.
    #[test]
    fn exhaustive_period_and_two_valued_autocorrelation() {
        for n in 2..=20u32 {
            let m = (1usize << n) - 1;
            let mut reg = MSequence::new(n).unwrap();
            let init = reg.state();
            let mut bits = Vec::with_capacity(m);
            for k in 0..m {
                if k > 0 {
                    assert_ne!(reg.state(), init, "order {n}: early return at {k}");
                }
                bits.push(reg.next_bit());
            }
            assert_eq!(reg.state(), init, "order {n}: not back after m steps");
            let ones = bits.iter().filter(|&&b| b == 1).count();
            assert_eq!(ones, 1 << (n - 1), "order {n}");
            if n <= 11 {
                let s: Vec<i64> = bits.iter().map(|&b| 1 - 2 * b as i64).collect();
                for tau in 0..m {
                    let r: i64 = (0..m).map(|k| s[(k + tau) % m] * s[k]).sum();
                    assert_eq!(r, if tau == 0 { m as i64 } else { -1 }, "n {n} tau {tau}");
                }
            } else {
                let s: Vec<f64> = bits.iter().map(|&b| 1.0 - 2.0 * b as f64).collect();
                let r = periodic_autocorrelation(&s, Normalization::Sum).unwrap();
                for (tau, v) in r.iter().enumerate() {
                    let expect = if tau == 0 { m as f64 } else { -1.0 };
                    assert!((v - expect).abs() < 1e-3, "n {n} tau {tau}: {v}");
                }
            }
        }
    }

    /// Orders 2..=32: the characteristic polynomial is primitive (x^m ≡ 1, x^{m/q} ≢ 1
    /// for every prime q | m), and the register state jumped ahead by m equals the
    /// initial state while a jump by m/q does not.
    #[test]
    fn all_orders_have_period_m_on_the_register_state() {
        for n in 2..=32u32 {
            let reg = MSequence::new(n).unwrap();
            let p = reg.polynomial();
            assert!(is_primitive(p), "order {n} polynomial {p:#x} not primitive");
            assert!(reg.is_maximal());
            let m = reg.period();
            assert_eq!(m, (1u64 << n) - 1);
            let mut jumped = reg.clone();
            jumped.advance(m);
            assert_eq!(jumped.state(), reg.state(), "order {n}");
            let mut q = 2u64;
            let mut rest = m;
            while q * q <= rest {
                if rest.is_multiple_of(q) {
                    let mut j = reg.clone();
                    j.advance(m / q);
                    assert_ne!(j.state(), reg.state(), "order {n}, m/{q}");
                    while rest.is_multiple_of(q) {
                        rest /= q;
                    }
                }
                q += 1;
            }
            if rest > 1 {
                let mut j = reg.clone();
                j.advance(m / rest);
                assert_ne!(j.state(), reg.state(), "order {n}, m/{rest}");
            }
        }
    }

    #[test]
    fn non_primitive_taps_are_detected() {
        // x^4 + x^2 + 1 is reducible: period 6, not 15.
        let reg = MSequence::with_taps(4, &[2, 4]).unwrap();
        assert!(!reg.is_maximal());
        let mut r = reg.clone();
        r.advance(6);
        assert_eq!(r.state(), reg.state());
    }

    #[test]
    fn word_parallel_agrees_with_fibonacci() {
        for n in 2..=32u32 {
            let reg = MSequence::new(n).unwrap();
            let mut serial = reg.clone();
            let mut words = reg.into_words();
            let nwords = 2 * n as usize + 40;
            for t in 0..nwords {
                let w = words.next_word();
                for j in 0..64 {
                    assert_eq!(
                        ((w >> j) & 1) as u8,
                        serial.next_bit(),
                        "order {n}, bit {}",
                        64 * t + j
                    );
                }
            }
        }
    }

    #[test]
    fn word_parallel_agrees_after_advance() {
        let mut reg = MSequence::new(17).unwrap();
        reg.advance(123_457);
        let mut serial = reg.clone();
        let mut words = reg.into_words();
        for _ in 0..100 {
            let w = words.next_word();
            for j in 0..64 {
                assert_eq!(((w >> j) & 1) as u8, serial.next_bit());
            }
        }
    }
}

mod inverse {
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
                    let r = periodic_autocorrelation(&w, Normalization::Divisor(2.0 * m as f64))
                        .unwrap();
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
}

mod random {
    use lifted_prbs::{
        Error, GaussianOptions, GbnOptions, MultisineOptions, RandomBinaryOptions, gaussian_white,
        generalized_binary_noise, multisine, random_binary,
    };

    #[test]
    fn gaussian_seeds_moments_and_hold() {
        let o = |seed, hold| GaussianOptions {
            std: 2.0,
            hold,
            seed,
        };
        let a = gaussian_white(40_000, &o(3, 1)).unwrap();
        assert_eq!(a, gaussian_white(40_000, &o(3, 1)).unwrap());
        assert_ne!(a, gaussian_white(40_000, &o(4, 1)).unwrap());
        let n = a.len() as f64;
        let mean = a.iter().sum::<f64>() / n;
        let var = a.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
        // σ = 2: the mean's standard error is 2/√40000 = 0.01 (allow 5σ); the
        // sample variance's is 4·√(2/40000) ≈ 0.028 (allow 5σ)
        assert!(mean.abs() < 0.05, "mean {mean}");
        assert!((var - 4.0).abs() < 0.15, "variance {var}");
        // lag-1 correlation of white noise: standard error 1/√n = 0.005
        let r1 = a
            .windows(2)
            .map(|w| (w[0] - mean) * (w[1] - mean))
            .sum::<f64>()
            / (n * var);
        assert!(r1.abs() < 0.025, "lag-1 correlation {r1}");
        // held: blocks of 4 equal values, the same draws as hold 1
        let h = gaussian_white(1000, &o(3, 4)).unwrap();
        for (k, c) in h.chunks(4).enumerate() {
            assert!(c.iter().all(|&v| v == a[k]), "block {k}");
        }
        // bad input
        assert!(matches!(
            gaussian_white(0, &o(1, 1)),
            Err(Error::ZeroLength { .. })
        ));
        for std in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let bad = GaussianOptions {
                std,
                ..Default::default()
            };
            assert!(matches!(
                gaussian_white(10, &bad),
                Err(Error::InvalidParameter { .. })
            ));
        }
        assert!(gaussian_white(10, &o(1, 0)).is_err());
    }

    #[test]
    fn rbs_seeds() {
        let o = |seed| RandomBinaryOptions {
            amplitude: 2.0,
            hold: 3,
            seed,
        };
        let a = random_binary(300, &o(1)).unwrap();
        assert_eq!(a, random_binary(300, &o(1)).unwrap());
        assert_ne!(a, random_binary(300, &o(2)).unwrap());
        assert!(a.iter().all(|&v| v == 2.0 || v == -2.0));
        assert!(a.chunks(3).all(|c| c.iter().all(|&v| v == c[0])));
        // 100 fair coin flips: mean within 4.5 standard errors (σ = 2/√100 = 0.2).
        let mean = a.iter().sum::<f64>() / a.len() as f64;
        assert!(mean.abs() < 0.9, "mean {mean}");
    }

    #[test]
    fn gbn_seeds_and_switching_rate() {
        let o = |seed, p| GbnOptions {
            amplitude: 1.0,
            switch_probability: p,
            hold: 1,
            seed,
        };
        let a = generalized_binary_noise(20_000, &o(5, 0.1)).unwrap();
        assert_eq!(a, generalized_binary_noise(20_000, &o(5, 0.1)).unwrap());
        assert_ne!(a, generalized_binary_noise(20_000, &o(6, 0.1)).unwrap());
        let switches = a.windows(2).filter(|w| w[0] != w[1]).count() as f64;
        // Binomial(19999, 0.1): mean 2000, σ ≈ 42; allow 5σ.
        assert!((switches - 2000.0).abs() < 210.0, "switches {switches}");
    }

    #[test]
    fn multisine_rms_period_and_crest() {
        let o = MultisineOptions {
            amplitude: 1.5,
            period: 256,
            first_harmonic: 1,
            last_harmonic: Some(40),
        };
        let x = multisine(512, &o).unwrap();
        let rms = (x[..256].iter().map(|v| v * v).sum::<f64>() / 256.0).sqrt();
        assert!((rms - 1.5).abs() < 1e-12, "rms {rms}");
        for k in 0..256 {
            assert_eq!(x[k], x[k + 256]);
        }
        // Schroeder phases keep the crest factor well below the zero-phase √(2K) ≈ 8.9.
        let crest = x.iter().fold(0.0f64, |m, v| m.max(v.abs())) / rms;
        assert!(crest < 2.0, "crest {crest}");
        // Only harmonics 1..=40 present: DFT bin 41 is zero.
        let (mut re, mut im) = (0.0, 0.0);
        for (t, v) in x[..256].iter().enumerate() {
            let ang = 2.0 * std::f64::consts::PI * 41.0 * t as f64 / 256.0;
            re += v * ang.cos();
            im += v * ang.sin();
        }
        assert!(re.hypot(im) < 1e-9);
    }
}

mod correlation {
    use lifted_prbs::{
        CorrelationMethod, Normalization, RandomBinaryOptions, periodic_autocorrelation,
        periodic_cross_correlation, periodic_cross_correlation_with, random_binary,
    };
    use proptest::prelude::*;

    /// One harness for both algorithms (and Auto) against the same answer.
    fn check_all(x: &[f64], y: &[f64]) {
        let d =
            periodic_cross_correlation_with(x, y, Normalization::Sum, CorrelationMethod::Direct)
                .unwrap();
        let scale = x.iter().map(|v| v.abs()).sum::<f64>() * y.iter().map(|v| v.abs()).sum::<f64>();
        for method in [CorrelationMethod::Fft, CorrelationMethod::Auto] {
            let f = periodic_cross_correlation_with(x, y, Normalization::Sum, method).unwrap();
            for (a, b) in d.iter().zip(&f) {
                // FFT rounding: a few ε per operation times log N, relative to Σ|x|Σ|y|.
                assert!((a - b).abs() <= 1e-13 * scale.max(1.0), "{a} vs {b}");
            }
        }
    }

    #[test]
    fn direct_and_fft_agree() {
        for n in [1, 2, 3, 17, 127, 128, 129, 1000] {
            let x = random_binary(
                n,
                &RandomBinaryOptions {
                    seed: 1,
                    ..Default::default()
                },
            )
            .unwrap();
            let y: Vec<f64> = (0..n).map(|k| (k as f64 * 0.37).sin()).collect();
            check_all(&x, &y);
        }
    }

    #[test]
    fn normalizations() {
        let x = [1.0, -2.0, 3.0, 0.5];
        let s = periodic_autocorrelation(&x, Normalization::Sum).unwrap();
        let l = periodic_autocorrelation(&x, Normalization::Length).unwrap();
        let d = periodic_autocorrelation(&x, Normalization::Divisor(2.0)).unwrap();
        assert_eq!(s[0], 14.25);
        assert_eq!(l[0], 14.25 / 4.0);
        assert_eq!(d[0], 14.25 / 2.0);
        let c = periodic_cross_correlation(&x, &x, Normalization::Sum).unwrap();
        assert_eq!(c, s);
    }

    proptest! {
        #[test]
        fn cross_correlation_identities(x in prop::collection::vec(-10.0f64..10.0, 1..300),
                                        shift in 0usize..300) {
            let n = x.len();
            let shift = shift % n;
            // y(k) = x(k − shift)  ⇒  R_xy(τ) = Σ_k x(k+τ) x(k−shift) = R_xx(τ + shift).
            let y: Vec<f64> = (0..n).map(|k| x[(k + n - shift) % n]).collect();
            let rxx = periodic_autocorrelation(&x, Normalization::Sum).unwrap();
            let rxy = periodic_cross_correlation(&x, &y, Normalization::Sum).unwrap();
            let scale = x.iter().map(|v| v * v).sum::<f64>().max(1.0);
            for tau in 0..n {
                prop_assert!((rxy[tau] - rxx[(tau + shift) % n]).abs() <= 1e-11 * scale);
            }
            // Symmetry of the autocorrelation.
            for tau in 1..n {
                prop_assert!((rxx[tau] - rxx[n - tau]).abs() <= 1e-11 * scale);
            }
            check_all(&x, &y);
        }
    }
}

mod plan {
    use lifted_prbs::{
        ChannelScheme, ExperimentPlan, InversePrbsOptions, Normalization, PlanOptions,
        periodic_cross_correlation,
    };

    fn opts(scheme: ChannelScheme) -> PlanOptions {
        PlanOptions {
            prbs: InversePrbsOptions {
                order: 6,
                hold: 2,
                ..Default::default()
            },
            amplitudes: vec![1.0, 2.0, 0.5],
            scheme,
            settle_periods: 1,
            record_periods: 2,
        }
    }

    #[test]
    fn one_at_a_time() {
        let plan = ExperimentPlan::new(&opts(ChannelScheme::OneAtATime)).unwrap();
        let u = plan.signal();
        let period = 2 * 2 * 63;
        assert_eq!(plan.period(), period);
        assert_eq!(u.ncols(), 3);
        assert_eq!(u.nrows(), 3 * 3 * period);
        assert_eq!(plan.segments().len(), 3);
        for (l, seg) in plan.segments().iter().enumerate() {
            assert_eq!(seg.channel, Some(l));
            assert_eq!(seg.record_start, seg.start + period);
            assert_eq!(seg.record_len, 2 * period);
            for k in seg.start..seg.start + seg.len {
                for c in 0..3 {
                    if c == l {
                        assert_eq!(u[(k, c)].abs(), plan.options().amplitudes[l]);
                    } else {
                        assert_eq!(u[(k, c)], 0.0);
                    }
                }
            }
            // Periodic within the block (steady state is reachable).
            for k in seg.start..seg.start + seg.len - period {
                assert_eq!(u[(k, l)], u[(k + period, l)]);
            }
        }
    }

    #[test]
    fn shifted_channels_are_nearly_uncorrelated() {
        let plan = ExperimentPlan::new(&opts(ChannelScheme::Shifted)).unwrap();
        let u = plan.signal();
        let n = plan.period();
        assert_eq!(plan.shift(), 21);
        let col = |c: usize| -> Vec<f64> { (0..n).map(|k| u[(k, c)]).collect() };
        let (x0, x1) = (col(0), col(1));
        // Channel 1 is channel 0 delayed by d n_r samples (scaled by a_1/a_0 = 2).
        let d = plan.shift() * 2;
        for k in d..n {
            assert_eq!(x1[k], 2.0 * x0[k - d]);
        }
        // Zero-lag cross-correlation (1/2m) is a_0 a_1 R_w(d) = 2·(±n_r/m): small.
        let r = periodic_cross_correlation(&x0, &x1, Normalization::Divisor(126.0)).unwrap();
        assert!(r[0].abs() <= 2.0 * 2.0 / 63.0 + 1e-12, "{}", r[0]);
        assert!((r[n - d] - 2.0 * 2.0).abs() < 1e-12);
    }

    #[test]
    fn independent_channels() {
        let plan = ExperimentPlan::new(&opts(ChannelScheme::Independent { seed: 3 })).unwrap();
        let u = plan.signal();
        let n = plan.period();
        assert_ne!(u.column(0).rows(0, n), u.column(2).rows(0, n) * 2.0);
        for k in 0..u.nrows() - n {
            assert_eq!(u[(k, 1)], u[(k + n, 1)]);
        }
        assert_eq!(
            u,
            ExperimentPlan::new(&opts(ChannelScheme::Independent { seed: 3 }))
                .unwrap()
                .signal()
        );
        assert_ne!(
            u,
            ExperimentPlan::new(&opts(ChannelScheme::Independent { seed: 4 }))
                .unwrap()
                .signal()
        );
    }

    #[test]
    fn serde_roundtrip_validates() {
        let plan = ExperimentPlan::new(&opts(ChannelScheme::Shifted)).unwrap();
        let s = serde_json::to_string(&plan).unwrap();
        let back: ExperimentPlan = serde_json::from_str(&s).unwrap();
        assert_eq!(back, plan);
        let mut bad = opts(ChannelScheme::OneAtATime);
        bad.amplitudes.clear();
        let s = serde_json::to_string(&bad).unwrap();
        assert!(serde_json::from_str::<ExperimentPlan>(&s).is_err());
    }
}

mod vectorized {
    use lifted_prbs::{
        RandomBinaryOptions, VectorizedOptions, lifted_covariance, random_binary,
        vectorized_excitation,
    };
    use nalgebra::DMatrix;

    fn sv_ratio(c: &DMatrix<f64>) -> f64 {
        let s = c.clone().singular_values();
        let max = s.max();
        let min = s.min();
        min / max
    }

    /// Li 2001 §6.3 / spec A3.8: a slow-held input gives a rank-1 lifted covariance
    /// (σ_n/σ₁ < 1e-12); independent components give σ_n/σ₁ > 0.8 at N = 5000.
    #[test]
    fn a3_8_rank() {
        for n in [2, 3, 5] {
            let held = random_binary(
                5000 * n,
                &RandomBinaryOptions {
                    amplitude: 1.0,
                    hold: n,
                    seed: 11,
                },
            )
            .unwrap();
            let c = lifted_covariance(&held, n).unwrap();
            assert!(sv_ratio(&c) < 1e-12, "held n {n}: {}", sv_ratio(&c));

            let v = vectorized_excitation(
                5000,
                &VectorizedOptions {
                    factor: n,
                    amplitude: 1.0,
                    seed: 11,
                },
            )
            .unwrap();
            assert_eq!(v.fast.len(), 5000 * n);
            for k in 0..5000 {
                for i in 0..n {
                    assert_eq!(v.fast[n * k + i], v.lifted[(k, i)]);
                }
            }
            let again = vectorized_excitation(
                5000,
                &VectorizedOptions {
                    factor: n,
                    amplitude: 1.0,
                    seed: 11,
                },
            )
            .unwrap();
            assert_eq!(again, v);
            let other = vectorized_excitation(
                5000,
                &VectorizedOptions {
                    factor: n,
                    amplitude: 1.0,
                    seed: 12,
                },
            )
            .unwrap();
            assert_ne!(other, v);
            let c = lifted_covariance(&v.fast, n).unwrap();
            let r = sv_ratio(&c);
            assert!(r > 0.8, "vectorized n {n}: {r}");
        }
    }
}

mod design {
    use approx::assert_relative_eq;
    use lifted_prbs::{DesignRequest, Error, InversePrbs, design};

    /// Zhu 2000 Table II: a = 2, T = 0.01 s, 30 Hz injection, margin 3, slowest mode
    /// 0.025 Hz → n = 8, T_p = 0.1 s, n_r = 10, period 51 s, f₀ = 1/51 Hz (Z-13).
    #[test]
    fn table_ii() {
        let p = design(&DesignRequest {
            output_period: 0.01,
            actuator_rate_hz: 30.0,
            actuator_margin: 3.0,
            slowest_mode_hz: 0.025,
            amplitude: 2.0,
            min_order: 2,
        })
        .unwrap();
        assert_eq!((p.order, p.m, p.hold), (8, 255, 10));
        assert_eq!(p.amplitude, 2.0);
        assert_relative_eq!(p.generation_period, 0.1, max_relative = 1e-12);
        assert_eq!(p.period_samples, 5100);
        assert_relative_eq!(p.record_length_s, 51.0, max_relative = 1e-12);
        assert_relative_eq!(p.fundamental_hz, 1.0 / 51.0, max_relative = 1e-12);
        assert!((p.fundamental_hz - 0.0196).abs() < 1e-4);
        assert_relative_eq!(p.band_high_hz, 5.0, max_relative = 1e-12);
        assert!(p.explanation.contains("n_r = ceil"));
        let prbs = InversePrbs::new(&p.prbs_options()).unwrap();
        assert_eq!(prbs.period(), 5100);
    }

    #[test]
    fn fast_actuator_gives_no_hold() {
        let p = design(&DesignRequest {
            actuator_rate_hz: 1000.0,
            ..Default::default()
        })
        .unwrap();
        assert_eq!(p.hold, 1);
    }

    #[test]
    fn infeasible() {
        let e = design(&DesignRequest {
            slowest_mode_hz: 1e-12,
            ..Default::default()
        })
        .unwrap_err();
        assert!(matches!(e, Error::DesignInfeasible { .. }));
    }
}

mod errors {
    use lifted_prbs::*;

    fn opts(order: u32, amplitude: f64, hold: usize) -> InversePrbsOptions {
        InversePrbsOptions {
            order,
            amplitude,
            hold,
            taps: None,
        }
    }

    #[test]
    fn order_out_of_range() {
        for order in [0, 1, 33, 64] {
            assert_eq!(
                MSequence::new(order).unwrap_err(),
                Error::OrderOutOfRange {
                    order,
                    min: 2,
                    max: 32
                }
            );
            assert!(matches!(
                InversePrbs::new(&opts(order, 1.0, 1)),
                Err(Error::OrderOutOfRange { .. })
            ));
            assert!(matches!(
                table_taps(order),
                Err(Error::OrderOutOfRange { .. })
            ));
            assert!(matches!(period(order), Err(Error::OrderOutOfRange { .. })));
            assert!(matches!(
                held_autocorrelation(order, 1, 1.0, 0),
                Err(Error::OrderOutOfRange { .. })
            ));
        }
    }

    #[test]
    fn bad_amplitude() {
        for a in [0.0, -1.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert!(matches!(
                InversePrbs::new(&opts(5, a, 1)),
                Err(Error::InvalidAmplitude { .. })
            ));
            assert!(matches!(
                inverse_prbs_autocorrelation(5, a, 0),
                Err(Error::InvalidAmplitude { .. })
            ));
            assert!(matches!(
                random_binary(
                    10,
                    &RandomBinaryOptions {
                        amplitude: a,
                        ..Default::default()
                    }
                ),
                Err(Error::InvalidAmplitude { .. })
            ));
            assert!(matches!(
                multisine(
                    10,
                    &MultisineOptions {
                        amplitude: a,
                        period: 8,
                        ..Default::default()
                    }
                ),
                Err(Error::InvalidAmplitude { .. })
            ));
            assert!(matches!(
                ExperimentPlan::new(&PlanOptions {
                    amplitudes: vec![1.0, a],
                    ..Default::default()
                }),
                Err(Error::InvalidAmplitude { .. })
            ));
        }
    }

    #[test]
    fn zero_hold() {
        assert_eq!(
            InversePrbs::new(&opts(5, 1.0, 0)).unwrap_err(),
            Error::ZeroFactor {
                what: "hold n_r",
                value: 0
            }
        );
        assert!(matches!(
            held_autocorrelation(5, 0, 1.0, 0),
            Err(Error::ZeroFactor { .. })
        ));
        assert!(matches!(
            random_binary(
                10,
                &RandomBinaryOptions {
                    hold: 0,
                    ..Default::default()
                }
            ),
            Err(Error::ZeroFactor { .. })
        ));
        assert!(matches!(
            generalized_binary_noise(
                10,
                &GbnOptions {
                    hold: 0,
                    ..Default::default()
                }
            ),
            Err(Error::ZeroFactor { .. })
        ));
    }

    #[test]
    fn bad_taps() {
        assert!(matches!(
            MSequence::with_taps(5, &[3]),
            Err(Error::InvalidTaps { .. })
        ));
        assert!(matches!(
            MSequence::with_taps(5, &[0, 5]),
            Err(Error::InvalidTaps { .. })
        ));
        assert!(matches!(
            MSequence::with_taps(5, &[6, 5]),
            Err(Error::InvalidTaps { .. })
        ));
        assert!(matches!(
            MSequence::with_taps(5, &[3, 3, 5]),
            Err(Error::InvalidTaps { .. })
        ));
        let e = InversePrbs::new(&InversePrbsOptions {
            order: 4,
            taps: Some(vec![2, 4]),
            ..Default::default()
        })
        .unwrap_err();
        assert_eq!(
            e,
            Error::NotMaximal {
                order: 4,
                taps: vec![2, 4]
            }
        );
    }

    #[test]
    fn empty_channel_set() {
        let e = ExperimentPlan::new(&PlanOptions {
            amplitudes: vec![],
            ..Default::default()
        });
        assert_eq!(e.unwrap_err(), Error::EmptyChannelSet);
    }

    #[test]
    fn too_many_shifted_channels() {
        let e = ExperimentPlan::new(&PlanOptions {
            prbs: InversePrbsOptions {
                order: 2,
                ..Default::default()
            },
            amplitudes: vec![1.0; 4],
            scheme: ChannelScheme::Shifted,
            ..Default::default()
        });
        assert_eq!(
            e.unwrap_err(),
            Error::TooManyChannels {
                channels: 4,
                half_period: 3
            }
        );
    }

    #[test]
    fn plan_too_long_for_memory() {
        // Order 32 held 10 samples: 8.6e10 samples per period, far beyond the limit.
        let e = ExperimentPlan::new(&PlanOptions {
            prbs: InversePrbsOptions {
                order: 32,
                hold: 10,
                ..Default::default()
            },
            amplitudes: vec![1.0, 1.0],
            ..Default::default()
        });
        assert!(matches!(e, Err(Error::TooLong { .. })), "{e:?}");
    }

    #[test]
    fn zero_record_periods() {
        let e = ExperimentPlan::new(&PlanOptions {
            record_periods: 0,
            ..Default::default()
        });
        assert!(matches!(e, Err(Error::ZeroLength { .. })));
    }

    #[test]
    fn switching_probability() {
        for p in [0.0, -0.1, 1.5, f64::NAN] {
            let e = generalized_binary_noise(
                10,
                &GbnOptions {
                    switch_probability: p,
                    ..Default::default()
                },
            );
            assert!(matches!(e, Err(Error::InvalidProbability { .. })), "{p}");
        }
        assert!(
            generalized_binary_noise(
                10,
                &GbnOptions {
                    switch_probability: 1.0,
                    ..Default::default()
                }
            )
            .is_ok()
        );
    }

    #[test]
    fn zero_length_signals() {
        assert!(matches!(
            random_binary(0, &Default::default()),
            Err(Error::ZeroLength { .. })
        ));
        assert!(matches!(
            generalized_binary_noise(0, &Default::default()),
            Err(Error::ZeroLength { .. })
        ));
        assert!(matches!(
            multisine(0, &Default::default()),
            Err(Error::ZeroLength { .. })
        ));
        assert!(matches!(
            vectorized_excitation(0, &Default::default()),
            Err(Error::ZeroLength { .. })
        ));
    }

    #[test]
    fn bad_harmonics() {
        for (first, last, period) in [
            (0, Some(3), 16),
            (4, Some(3), 16),
            (1, Some(8), 16),
            (1, None, 2),
        ] {
            let e = multisine(
                10,
                &MultisineOptions {
                    amplitude: 1.0,
                    period,
                    first_harmonic: first,
                    last_harmonic: last,
                },
            );
            assert!(
                matches!(e, Err(Error::InvalidHarmonics { .. })),
                "{first} {last:?} {period}"
            );
        }
    }

    #[test]
    fn correlation_inputs() {
        let x = [1.0, 2.0];
        assert_eq!(
            periodic_autocorrelation(&[], Normalization::Sum).unwrap_err(),
            Error::EmptySignal { what: "x" }
        );
        assert_eq!(
            periodic_cross_correlation(&x, &[1.0], Normalization::Sum).unwrap_err(),
            Error::LengthMismatch { left: 2, right: 1 }
        );
        assert_eq!(
            periodic_cross_correlation(&x, &[1.0, f64::NAN], Normalization::Sum).unwrap_err(),
            Error::NonFinite {
                what: "y",
                index: 1
            }
        );
        for c in [0.0, -2.0, f64::INFINITY] {
            assert!(matches!(
                periodic_autocorrelation(&x, Normalization::Divisor(c)),
                Err(Error::InvalidParameter { .. })
            ));
        }
    }

    #[test]
    fn lifted_covariance_inputs() {
        assert!(matches!(
            lifted_covariance(&[1.0; 4], 0),
            Err(Error::ZeroFactor { .. })
        ));
        assert!(matches!(
            lifted_covariance(&[], 2),
            Err(Error::EmptySignal { .. })
        ));
        assert_eq!(
            lifted_covariance(&[1.0; 5], 2).unwrap_err(),
            Error::NotMultiple { len: 5, factor: 2 }
        );
        assert!(matches!(
            lifted_covariance(&[1.0, f64::NAN], 2),
            Err(Error::NonFinite { .. })
        ));
        assert!(matches!(
            vectorized_excitation(
                10,
                &VectorizedOptions {
                    factor: 0,
                    ..Default::default()
                }
            ),
            Err(Error::ZeroFactor { .. })
        ));
    }

    #[test]
    fn bad_design_requests() {
        let base = DesignRequest::default();
        let cases = [
            DesignRequest {
                output_period: 0.0,
                ..base.clone()
            },
            DesignRequest {
                output_period: f64::NAN,
                ..base.clone()
            },
            DesignRequest {
                actuator_rate_hz: -30.0,
                ..base.clone()
            },
            DesignRequest {
                actuator_margin: 0.0,
                ..base.clone()
            },
            DesignRequest {
                slowest_mode_hz: f64::INFINITY,
                ..base.clone()
            },
        ];
        for c in cases {
            assert!(
                matches!(design(&c), Err(Error::InvalidParameter { .. })),
                "{c:?}"
            );
        }
        assert!(matches!(
            design(&DesignRequest {
                amplitude: -2.0,
                ..base.clone()
            }),
            Err(Error::InvalidAmplitude { .. })
        ));
        assert!(matches!(
            design(&DesignRequest {
                min_order: 40,
                ..base
            }),
            Err(Error::OrderOutOfRange { .. })
        ));
    }
}

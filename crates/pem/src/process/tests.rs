use super::*;
use crate::error::Error;
use lifted_subspace::Experiment;
use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Random binary signal ±1, a new random sign every `hold` samples.
fn rbs(seed: u64, n: usize, hold: usize) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut v = 1.0;
    (0..n)
        .map(|k| {
            if k % hold == 0 {
                v = if rng.random::<bool>() { 1.0 } else { -1.0 };
            }
            v
        })
        .collect()
}

fn gauss(seed: u64, n: usize, sd: f64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let v: f64 = StandardNormal.sample(&mut rng);
            sd * v
        })
        .collect()
}

fn col(v: &[f64]) -> DMatrix<f64> {
    DMatrix::from_column_slice(v.len(), 1, v)
}

fn variance(v: &[f64]) -> f64 {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / v.len() as f64
}

fn fit(u: &DMatrix<f64>, y: &DMatrix<f64>, kind: ProcessKind) -> ProcessFit {
    procest(
        &[Experiment { u, y }],
        kind,
        1.0,
        &ProcessOptions::default(),
    )
    .unwrap()
}

/// Every `every`-th sample kept, NaN between.
fn every(y: &[f64], every: usize) -> Vec<f64> {
    y.iter()
        .enumerate()
        .map(|(k, &v)| if k % every == 0 { v } else { f64::NAN })
        .collect()
}

#[test]
fn fractional_dead_time_is_exact_on_the_step_response() {
    // K(1 − e^{−(t − θ)/T}) for t ≥ θ, at t = kT: the ZOH step response
    // with θ = 7.3 not a multiple of T = 1 (closed form, no tolerance beyond
    // rounding); to_discrete_ss (shift register + modified z-transform)
    // and the estimator's simulation agree.
    let m = ProcessModel::from_parameters(ProcessKind::P1D, &[2.0, 20.0, 7.3], 1.0).unwrap();
    let u = vec![1.0; 60];
    let y = m.simulate(&u).unwrap();
    for (k, &v) in y.iter().enumerate() {
        let t = k as f64;
        let want = if t >= 7.3 {
            2.0 * (1.0 - (-(t - 7.3) / 20.0f64).exp())
        } else {
            0.0
        };
        assert!((v - want).abs() < 1e-13, "{k}: {v} {want}");
    }
    let ss = m.to_discrete_ss().unwrap();
    assert_eq!(ss.order(), 1 + 7 + 1);
    let y2 = ss.lsim(&col(&u), None, None).unwrap().y;
    for (a, b) in y.iter().zip(y2.iter()) {
        assert!((a - b).abs() < 1e-13);
    }
}

#[test]
fn realisations_have_the_stated_transfer_functions() {
    type Complex64 = nalgebra::Complex<f64>;
    // G(jω) of each continuous realisation against the formula at ω = 0.3.
    let s = Complex64::new(0.0, 0.3);
    let one = Complex64::new(1.0, 0.0);
    let cases: [(ProcessKind, &[f64], Complex64); 5] = [
        (ProcessKind::P1D, &[2.0, 5.0, 0.0], 2.0 / (one + 5.0 * s)),
        (
            ProcessKind::P2D,
            &[2.0, 5.0, 2.0, 0.0],
            2.0 / ((one + 5.0 * s) * (one + 2.0 * s)),
        ),
        (
            ProcessKind::P1DI,
            &[2.0, 5.0, 0.0],
            2.0 / (s * (one + 5.0 * s)),
        ),
        (
            ProcessKind::P2DZ,
            &[2.0, 5.0, 2.0, -3.0, 0.0],
            2.0 * (one - 3.0 * s) / ((one + 5.0 * s) * (one + 2.0 * s)),
        ),
        (
            ProcessKind::P2DU,
            &[2.0, 5.0, 0.2, 0.0],
            2.0 / (one + 2.0 * 0.2 * 5.0 * s + 25.0 * s * s),
        ),
    ];
    for (kind, p, want) in cases {
        let m = ProcessModel::from_parameters(kind, p, 1.0).unwrap();
        let g = m.to_continuous_ss().unwrap().eval_complex(s).unwrap()[(0, 0)];
        assert!((g - want).norm() < 1e-12, "{kind:?}: {g} {want}");
    }
}

#[test]
fn noise_free_recovery_of_every_structure() {
    // Random binary input, hold 8, N = 1500; every dead time fractional;
    // parameters to 1e-5 relative.
    let cases: [(ProcessKind, &[f64]); 6] = [
        (ProcessKind::P1D, &[2.0, 20.0, 7.3]),
        (ProcessKind::P2D, &[-1.5, 15.0, 4.0, 3.6]),
        (ProcessKind::P1DI, &[0.05, 6.0, 2.4]),
        (ProcessKind::P2DZ, &[1.2, 12.0, 3.0, 5.0, 4.7]),
        (ProcessKind::P2DZ, &[1.2, 12.0, 3.0, -4.0, 1.7]),
        (ProcessKind::P2DU, &[0.8, 5.0, 0.3, 2.2]),
    ];
    for (i, (kind, p)) in cases.iter().enumerate() {
        let m = ProcessModel::from_parameters(*kind, p, 1.0).unwrap();
        let u = rbs(10 + i as u64, 1500, 8);
        let y = m.simulate(&u).unwrap();
        // at full rate and with the output every 5th sample
        for rate in [1, 5] {
            let f = fit(&col(&u), &col(&every(&y, rate)), *kind);
            for ((a, b), name) in f
                .parameters
                .iter()
                .zip(p.iter())
                .zip(kind.parameter_names())
            {
                assert!(
                    (a - b).abs() < 1e-5 * b.abs().max(1.0),
                    "{kind:?} 1/{rate} {name}: {a} vs {b} ({f:?})"
                );
            }
            assert!(f.loss < 1e-16, "{kind:?} 1/{rate} loss {}", f.loss);
        }
    }
}

/// The issue's plant: K = 2, τ = 20 s, θ = 7.3 s, T = 1 s; N = 2000 samples
/// of a random binary input (a new sign every 3 s: its band covers the
/// plant's corner 1/τ and the phase lag of θ), output noise of a tenth of
/// the noise-free output's variance (SNR 10).
fn fopdt_record(seed: u64) -> (Vec<f64>, Vec<f64>) {
    let m = ProcessModel::from_parameters(ProcessKind::P1D, &[2.0, 20.0, 7.3], 1.0).unwrap();
    let u = rbs(seed, 2000, 3);
    let y0 = m.simulate(&u).unwrap();
    let sd = (variance(&y0) / 10.0).sqrt();
    let e = gauss(seed + 1_000_000, 2000, sd);
    let y = y0.iter().zip(&e).map(|(a, b)| a + b).collect();
    (u, y)
}

fn relative_errors(f: &ProcessFit) -> [f64; 3] {
    let m = &f.models[0];
    [
        (m.k - 2.0).abs() / 2.0,
        (m.tp1 - 20.0).abs() / 20.0,
        (m.theta - 7.3).abs() / 7.3,
    ]
}

#[test]
fn issue_49_fopdt_at_full_rate_and_every_fifth_sample() {
    // 40 seeded records of the issue's plant, fitted at full rate and with
    // the output kept every 5th sample (NaN between).
    //
    // Full rate: the RMS relative errors of K, τ and θ are below the
    // issue's 2 % (measured: K 1.1 %, τ 1.5 %, θ 0.6 %; all three within
    // 2 % on 34 of the 40 records).
    //
    // Every 5th sample the 2 % is NOT reached, and cannot be: with M = 400
    // measured samples at SNR 10 even a known τ and θ leave K a relative
    // standard deviation of 1/√(SNR·M) = 1.58 % (the least-squares variance
    // σ²/Σy₀² of a gain; zero-mean input). Measured RMS: K 2.5 %, τ 3.1 %,
    // θ 1.2 %; all three within 2 % on 12 of the 40 records. What is
    // asserted there: the estimator is efficient — its errors match its
    // own reported standard deviations, as at full rate — and below 5 %.
    let n = 40;
    for (rate, bound) in [(1usize, 0.02), (5, 0.05)] {
        let (mut sq, mut sd) = ([0.0; 3], [0.0; 3]);
        let mut within = 0;
        for seed in 0..n {
            let (u, y) = fopdt_record(4900 + seed);
            let f = fit(&col(&u), &col(&every(&y, rate)), ProcessKind::P1D);
            assert_eq!(f.measured, 2000 / rate);
            let r = relative_errors(&f);
            for i in 0..3 {
                sq[i] += r[i] * r[i] / n as f64;
                sd[i] += f.std[i] / f.parameters[i] / n as f64;
            }
            within += usize::from(r.iter().all(|&e| e < 0.02));
        }
        let rms = sq.map(f64::sqrt);
        eprintln!(
            "rate 1/{rate}: RMS relative errors {rms:?}, mean relative std {sd:?}, all within 2 %: {within}/{n}"
        );
        for i in 0..3 {
            assert!(rms[i] < bound, "rate 1/{rate}: RMS relative errors {rms:?}");
            let ratio = rms[i] / sd[i];
            assert!(
                (0.7..1.4).contains(&ratio),
                "rate 1/{rate}: RMS {rms:?} against std {sd:?}"
            );
        }
    }
}

#[test]
fn the_95_percent_intervals_hold_the_truth() {
    // 100 seeded records of the issue's plant at full rate: each of the
    // 300 ±1.96σ intervals (K, τ, θ) holds the truth in 91–99 % of the
    // cases (binomial spread ±1.3 points at 1σ around 95 %; ±3σ band).
    let truth = [2.0, 20.0, 7.3];
    let (mut hits, mut total) = (0usize, 0usize);
    for seed in 0..100 {
        let (u, y) = fopdt_record(7000 + seed);
        let f = fit(&col(&u), &col(&y), ProcessKind::P1D);
        for ((p, s), t) in f.parameters.iter().zip(&f.std).zip(&truth) {
            total += 1;
            hits += usize::from((p - t).abs() <= 1.96 * s);
        }
    }
    let share = hits as f64 / total as f64;
    eprintln!("coverage {share}");
    assert!((0.91..=0.99).contains(&share), "coverage {share}");
}

#[test]
fn a_step_test_gives_the_model() {
    // The input steps from 0 to 1.5 at sample 50; 400 samples, output noise
    // sd 0.02 (2.7 % of the P1D plant's final value 0.75). Every parameter
    // within 3σ of the truth; K within 1 %; for P1D every parameter within
    // 3 %. (A step shows P2D's second time constant and dead time mostly
    // through their sum: T₂ and θ come with σ ≈ 1.2 s and 0.7 s here; the
    // integrator's T₁ and θ likewise, σ ≈ 1.0 s and 0.9 s: no 3 % claim.)
    let mut u = vec![0.0; 400];
    for v in u.iter_mut().skip(50) {
        *v = 1.5;
    }
    let cases: [(ProcessKind, &[f64]); 3] = [
        (ProcessKind::P1D, &[0.5, 25.0, 7.3]),
        (ProcessKind::P2D, &[0.5, 20.0, 6.0, 4.4]),
        (ProcessKind::P1DI, &[0.01, 8.0, 3.3]),
    ];
    for (i, (kind, p)) in cases.iter().enumerate() {
        let m = ProcessModel::from_parameters(*kind, p, 1.0).unwrap();
        let y0 = m.simulate(&u).unwrap();
        let y: Vec<f64> = y0
            .iter()
            .zip(gauss(20 + i as u64, 400, 0.02))
            .map(|(a, b)| a + b)
            .collect();
        let f = fit(&col(&u), &col(&y), *kind);
        for (j, ((a, b), s)) in f.parameters.iter().zip(p.iter()).zip(&f.std).enumerate() {
            let close = match kind {
                ProcessKind::P2D | ProcessKind::P1DI => j > 0 || (a - b).abs() < 0.01 * b.abs(),
                _ => (a - b).abs() < 0.03 * b.abs() && (j > 0 || (a - b).abs() < 0.01 * b.abs()),
            };
            assert!(
                (a - b).abs() < 3.0 * s && close,
                "{kind:?}: {:?} ± {:?}",
                f.parameters,
                f.std
            );
        }
    }
}

#[test]
fn two_inputs_with_their_own_dead_times_and_an_offset() {
    // MISO, noise free: y = P1D(u₀) + P1D(u₁) + 0.7, the offset estimated.
    let m0 = ProcessModel::from_parameters(ProcessKind::P1D, &[1.5, 10.0, 2.5], 1.0).unwrap();
    let m1 = ProcessModel::from_parameters(ProcessKind::P1D, &[-0.8, 4.0, 6.2], 1.0).unwrap();
    let (u0, u1) = (rbs(30, 1500, 7), rbs(31, 1500, 5));
    let y: Vec<f64> = m0
        .simulate(&u0)
        .unwrap()
        .iter()
        .zip(m1.simulate(&u1).unwrap())
        .map(|(a, b)| a + b + 0.7)
        .collect();
    let mut u = DMatrix::zeros(1500, 2);
    u.column_mut(0).copy_from_slice(&u0);
    u.column_mut(1).copy_from_slice(&u1);
    let opts = ProcessOptions {
        offset: true,
        ..Default::default()
    };
    let yc = col(&every(&y, 3));
    let f = procest(
        &[Experiment { u: &u, y: &yc }],
        ProcessKind::P1D,
        1.0,
        &opts,
    )
    .unwrap();
    let want = [1.5, 10.0, 2.5, -0.8, 4.0, 6.2, 0.7];
    for (a, b) in f.parameters.iter().zip(&want) {
        assert!(
            (a - b).abs() < 1e-6 * b.abs().max(1.0),
            "{:?}",
            f.parameters
        );
    }
    assert_eq!(f.names[3], "K(u1)");
    let sim = f.simulate(&u).unwrap();
    assert!(sim.iter().zip(&y).all(|(a, b)| (a - b).abs() < 1e-6));
    // the exported state space (shift registers for the integer delays)
    let ss = f.to_discrete_ss().unwrap();
    let ys = ss.lsim(&u, None, None).unwrap().y;
    assert!(ys.iter().zip(&y).all(|(a, b)| (a + 0.7 - b).abs() < 1e-6));
}

#[test]
fn bad_input_is_refused_with_a_named_error() {
    let m = ProcessModel::from_parameters(ProcessKind::P1D, &[2.0, 20.0, 7.3], 1.0).unwrap();
    let u = col(&rbs(40, 300, 5));
    let y = col(&m.simulate(u.as_slice()).unwrap());
    let run = |u: &DMatrix<f64>, y: &DMatrix<f64>, ts: f64, o: &ProcessOptions| {
        procest(&[Experiment { u, y }], ProcessKind::P1D, ts, o)
    };
    let d = ProcessOptions::default();
    let mut bad = u.clone();
    bad[(3, 0)] = f64::NAN;
    assert!(matches!(
        run(&bad, &y, 1.0, &d),
        Err(Error::NonFinite {
            what: "u",
            row: 3,
            ..
        })
    ));
    bad[(3, 0)] = f64::INFINITY;
    assert!(matches!(
        run(&bad, &y, 1.0, &d),
        Err(Error::NonFinite { what: "u", .. })
    ));
    let mut inf = y.clone();
    inf[(4, 0)] = f64::NEG_INFINITY;
    assert!(matches!(
        run(&u, &inf, 1.0, &d),
        Err(Error::NonFinite {
            what: "y",
            row: 4,
            ..
        })
    ));
    let two = DMatrix::from_element(300, 2, 1.0);
    assert!(matches!(
        run(&u, &two, 1.0, &d),
        Err(Error::DimensionMismatch { .. })
    ));
    let short = y.rows(0, 200).into_owned();
    assert!(matches!(
        run(&u, &short, 1.0, &d),
        Err(Error::DimensionMismatch { .. })
    ));
    let flat = DMatrix::from_element(300, 1, 1.0);
    assert!(matches!(
        run(&flat, &y, 1.0, &d),
        Err(Error::RankDeficient { .. })
    ));
    let sparse = col(&every(y.as_slice(), 50)); // 6 measured samples, 3 parameters
    assert!(matches!(
        run(&u, &sparse, 1.0, &d),
        Err(Error::TooFewSamples {
            measured: 6,
            needed: 7,
            ..
        })
    ));
    for ts in [0.0, -1.0, f64::NAN] {
        assert!(matches!(
            run(&u, &y, ts, &d),
            Err(Error::InvalidOption { what: "ts", .. })
        ));
    }
    let o = ProcessOptions {
        starts: 0,
        ..Default::default()
    };
    assert!(matches!(
        run(&u, &y, 1.0, &o),
        Err(Error::InvalidOption { .. })
    ));
    let o = ProcessOptions {
        max_delay: Some(-1.0),
        ..Default::default()
    };
    assert!(matches!(
        run(&u, &y, 1.0, &o),
        Err(Error::InvalidOption {
            what: "max_delay",
            ..
        })
    ));
    assert!(matches!(
        procest(&[], ProcessKind::P1D, 1.0, &d),
        Err(Error::NoData)
    ));
    assert!(matches!(
        ProcessModel::from_parameters(ProcessKind::P2D, &[1.0, -2.0, 1.0, 0.0], 1.0),
        Err(Error::InvalidOption {
            what: "process model",
            ..
        })
    ));
    assert!(matches!(
        ProcessModel::from_parameters(ProcessKind::P1D, &[1.0, 2.0, -0.1], 1.0),
        Err(Error::InvalidOption { .. })
    ));
    assert!(matches!(
        ProcessModel::from_parameters(ProcessKind::P1D, &[1.0, 2.0], 1.0),
        Err(Error::DimensionMismatch { .. })
    ));
}

#[test]
fn several_records_are_fitted_together() {
    // Two records from rest, different inputs and lengths, one of them
    // sampled every 4th: the P2DU plant comes back to 1e-5.
    let m = ProcessModel::from_parameters(ProcessKind::P2DU, &[0.8, 5.0, 0.3, 2.2], 1.0).unwrap();
    let (u1, u2) = (rbs(50, 500, 6), rbs(51, 700, 9));
    let (y1, y2) = (
        m.simulate(&u1).unwrap(),
        every(&m.simulate(&u2).unwrap(), 4),
    );
    let (u1, y1, u2, y2) = (col(&u1), col(&y1), col(&u2), col(&y2));
    let f = procest(
        &[Experiment { u: &u1, y: &y1 }, Experiment { u: &u2, y: &y2 }],
        ProcessKind::P2DU,
        1.0,
        &ProcessOptions::default(),
    )
    .unwrap();
    assert_eq!(f.measured, 500 + 175);
    for (a, b) in f.parameters.iter().zip([0.8, 5.0, 0.3, 2.2]) {
        assert!((a - b).abs() < 1e-5 * b, "{:?}", f.parameters);
    }
}

/// Held parameters (MATLAB's `Structure.Td.Free = false`): the issue's
/// FOPDT plant with its dead time known, 7.3 s, held; K and τ estimated,
/// θ exactly 7.3 with no variance; the per-input name ("Td(u0)") does the
/// same; unknown names and bad values are refused naming them. Over 20
/// records the held dead time shrinks K's and τ's RMS errors (the dead
/// time no longer trades against τ).
#[test]
fn a_held_dead_time_stays_and_has_no_variance() {
    let held = |name: &str, v: f64| ProcessOptions {
        fixed: vec![(name.to_string(), v)],
        ..Default::default()
    };
    let (mut free_sq, mut held_sq) = ([0.0; 2], [0.0; 2]);
    for seed in 0..20 {
        let (u, y) = fopdt_record(7100 + seed);
        let (u, y) = (col(&u), col(&every(&y, 5)));
        let exps = [Experiment { u: &u, y: &y }];
        let f = procest(&exps, ProcessKind::P1D, 1.0, &held("Td", 7.3)).unwrap();
        assert_eq!(f.models[0].theta, 7.3);
        assert_eq!(f.parameters[2], 7.3);
        assert_eq!(f.std[2], 0.0);
        assert!(f.std[0] > 0.0 && f.std[1] > 0.0);
        let free = procest(&exps, ProcessKind::P1D, 1.0, &ProcessOptions::default()).unwrap();
        for i in 0..2 {
            held_sq[i] += relative_errors(&f)[i].powi(2) / 20.0;
            free_sq[i] += relative_errors(&free)[i].powi(2) / 20.0;
        }
        if seed == 0 {
            let one = procest(&exps, ProcessKind::P1D, 1.0, &held("Td(u0)", 7.3)).unwrap();
            assert_eq!(one.parameters, f.parameters);
        }
    }
    eprintln!(
        "every 5th sample, RMS relative errors of K, τ: θ held {:?}, θ estimated {:?}",
        held_sq.map(f64::sqrt),
        free_sq.map(f64::sqrt)
    );
    for i in 0..2 {
        assert!(held_sq[i] < free_sq[i], "{held_sq:?} vs {free_sq:?}");
    }
    let (u, y) = fopdt_record(1);
    let (u, y) = (col(&u), col(&y));
    let exps = [Experiment { u: &u, y: &y }];
    for (name, v, says) in [
        ("Tz", 1.0, "no parameter 'Tz'"),
        ("Td", -1.0, "dead time"),
        ("Tp1", 0.0, "> 0"),
        ("K", f64::NAN, "not finite"),
    ] {
        let e = procest(&exps, ProcessKind::P1D, 1.0, &held(name, v)).unwrap_err();
        assert!(e.to_string().contains(says), "{name}: {e}");
    }
}

/// The output at t = kT of the continuous model `m` driven by its input
/// samples `u` interpolated linearly (u(−1) = 0: at rest before −T, the
/// input ramping to u(0) over [−T, 0)) and delayed by θ, by fine steps
/// from t = −T: each of `m_sub` sub-steps of a period a ZOH step of
/// h = T/m_sub at the interpolated input's midpoint value (error O(h²)).
fn foh_reference(m: &ProcessModel, u: &[f64], m_sub: usize) -> Vec<f64> {
    let ts = m.ts;
    let h = ts / m_sub as f64;
    let cont = m.to_continuous_ss().unwrap();
    let fine = cont.c2d(h, &lifted_lti::C2dOptions::default()).unwrap();
    let lin = |t: f64| -> f64 {
        // The input's linear interpolation at time t (samples at kT).
        let k = (t / ts).floor();
        let s = t / ts - k;
        let at = |i: f64| -> f64 {
            if i < 0.0 {
                0.0
            } else {
                u.get(i as usize).copied().unwrap_or(0.0)
            }
        };
        at(k) * (1.0 - s) + at(k + 1.0) * s
    };
    let n = fine.order();
    let mut x = DMatrix::zeros(n, 1);
    let mut y = Vec::with_capacity(u.len());
    for k in -1..u.len() as i64 {
        if k >= 0 {
            y.push((fine.c() * &x)[(0, 0)]);
        }
        for j in 0..m_sub {
            let t = k as f64 * ts + (j as f64 + 0.5) * h - m.theta;
            x = fine.a() * &x + fine.b() * lin(t);
        }
    }
    y
}

#[test]
fn first_order_hold_is_exact_for_a_linearly_interpolated_input() {
    // The FOH taps against a fine simulation of the continuous plant with
    // the input interpolated linearly and delayed (2000 sub-steps a
    // period: the reference's own error ≈ 1e-7 relative): dead times under
    // one period (the direct term), with a fraction, on the grid; real and
    // complex poles, an integrator. The state-space form (a register of
    // past inputs) simulates the same numbers.
    let u: Vec<f64> = gauss(41, 80, 1.0);
    let cases: [(ProcessKind, &[f64]); 5] = [
        (ProcessKind::P1D, &[2.0, 6.0, 0.4]),
        (ProcessKind::P1D, &[2.0, 6.0, 2.3]),
        (ProcessKind::P2DU, &[0.8, 3.0, 0.3, 1.0]),
        (ProcessKind::P2DZ, &[1.5, 5.0, 2.0, -1.0, 3.7]),
        (ProcessKind::P1DI, &[0.2, 4.0, 0.0]),
    ];
    for (kind, p) in cases {
        let m = ProcessModel::from_parameters(kind, p, 1.0)
            .unwrap()
            .with_intersample(InterSample::Foh);
        let got = m.simulate(&u).unwrap();
        let want = foh_reference(&m, &u, 2000);
        let scale = want.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        for (k, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!(
                (g - w).abs() < 1e-6 * scale,
                "{kind:?} {p:?} k {k}: {g} vs {w}"
            );
        }
        let ss = m.to_discrete_ss().unwrap();
        let y_ss = ss.lsim_outputs(&col(&u), None).unwrap();
        for (k, g) in got.iter().enumerate() {
            assert!(
                (g - y_ss[(k, 0)]).abs() < 1e-10 * scale,
                "{kind:?} ss k {k}"
            );
        }
        // ZOH differs from FOH on the same samples (the hold matters).
        let zoh = ProcessModel::from_parameters(kind, p, 1.0)
            .unwrap()
            .simulate(&u)
            .unwrap();
        let gap = zoh
            .iter()
            .zip(&got)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(gap > 1e-3 * scale, "{kind:?}: ZOH and FOH agree ({gap})");
    }
    assert_eq!(
        InterSample::parse("FOH", "intersample").unwrap(),
        InterSample::Foh
    );
    assert!(InterSample::parse("tustin", "intersample").is_err());
}

#[test]
fn procest_under_first_order_hold_recovers_a_sampled_continuous_input() {
    // A FOPDT plant (K 2, T 20 s, θ 7.3 s, T = 1 s) driven by a smooth
    // input sampled every second (filtered noise: a continuous signal, not
    // a held one), noise-free: with intersample FOH the estimate is the
    // plant; the ZOH assumption reads the input's course between samples
    // (the ramp to the next sample: the input half a period early) as a
    // dead time about half a period shorter.
    let raw = gauss(43, 600, 1.0);
    let mut u = vec![0.0; 600];
    for k in 1..600 {
        u[k] = 0.9 * u[k - 1] + 0.1 * raw[k];
    }
    let truth = ProcessModel::from_parameters(ProcessKind::P1D, &[2.0, 20.0, 7.3], 1.0)
        .unwrap()
        .with_intersample(InterSample::Foh);
    let y = truth.simulate(&u).unwrap();
    let (uc, yc) = (col(&u), col(&y));
    let exps = [Experiment { u: &uc, y: &yc }];
    let foh = procest(
        &exps,
        ProcessKind::P1D,
        1.0,
        &ProcessOptions {
            intersample: InterSample::Foh,
            ..Default::default()
        },
    )
    .unwrap();
    let m = &foh.models[0];
    assert_eq!(m.intersample, InterSample::Foh);
    for (got, want) in m.parameters().iter().zip([2.0, 20.0, 7.3]) {
        assert!(
            (got - want).abs() < 1e-4 * want,
            "FOH: {:?}",
            m.parameters()
        );
    }
    // The fit's state-space form simulates what the fit does (θ over a
    // period: a register of past inputs, no direct term).
    let ss = foh.to_discrete_ss().unwrap();
    let y_ss = ss.lsim_outputs(&uc, None).unwrap();
    for (k, v) in foh.simulate(&uc).unwrap().iter().enumerate() {
        assert!((v - y_ss[(k, 0)]).abs() < 1e-9, "k {k}");
    }
    let zoh = procest(&exps, ProcessKind::P1D, 1.0, &ProcessOptions::default()).unwrap();
    let theta = zoh.models[0].theta;
    assert!((theta - (7.3 - 0.5)).abs() < 0.2, "ZOH dead time {theta}");
}

/// A smooth input (first-order filtered noise, pole 0.9: a sampled
/// continuous signal, not a held one) through the issue's FOPDT plant under
/// a first-order hold; output noise at SNR 10, N = 2000.
fn foh_fopdt_record(seed: u64, snr: Option<f64>) -> (Vec<f64>, Vec<f64>) {
    let raw = gauss(seed, 2000, 1.0);
    let mut u = vec![0.0; 2000];
    for k in 1..2000 {
        u[k] = 0.9 * u[k - 1] + raw[k];
    }
    let m = ProcessModel::from_parameters(ProcessKind::P1D, &[2.0, 20.0, 7.3], 1.0)
        .unwrap()
        .with_intersample(InterSample::Foh);
    let y0 = m.simulate(&u).unwrap();
    let Some(snr) = snr else {
        return (u, y0);
    };
    let sd = (variance(&y0) / snr).sqrt();
    let e = gauss(seed + 1_000_000, 2000, sd);
    (u, y0.iter().zip(&e).map(|(a, b)| a + b).collect())
}

fn foh_fit(u: &[f64], y: &[f64]) -> ProcessFit {
    let (uc, yc) = (col(u), col(y));
    procest(
        &[Experiment { u: &uc, y: &yc }],
        ProcessKind::P1D,
        1.0,
        &ProcessOptions {
            intersample: InterSample::Foh,
            ..Default::default()
        },
    )
    .unwrap()
}

#[test]
fn first_order_hold_on_a_multirate_record() {
    // Issue 49 (multirate process models) under a first-order hold: the
    // output kept every 5th sample (NaN between), the cost on the measured
    // samples only, the input's linear course between its samples in the
    // predictor. Noise-free the plant comes back (1e-4 relative); with
    // noise at SNR 10 over 20 records the errors of K, τ, θ match the fit's
    // own standard deviations (RMS ÷ mean σ within 0.7–1.4, as for the ZOH
    // fits above) and stay below 5 % RMS (1/√(SNR·M) = 1.6 % for K alone
    // with M = 400 measured samples, the bound of the ZOH test above).
    // Measured: RMS K 2.2 %, τ 2.9 %, θ 3.4 % against mean σ 2.0, 3.8,
    // 3.5 % (the smooth input carries less of the dead time than the ZOH
    // test's random binary one).
    let (u, y) = foh_fopdt_record(61, None);
    let f = foh_fit(&u, &every(&y, 5));
    assert_eq!(f.measured, 400);
    for (got, want) in f.models[0].parameters().iter().zip([2.0, 20.0, 7.3]) {
        assert!(
            (got - want).abs() < 1e-4 * want,
            "noise-free: {:?}",
            f.models[0].parameters()
        );
    }
    let n = 20;
    let (mut sq, mut sd) = ([0.0; 3], [0.0; 3]);
    for seed in 0..n {
        let (u, y) = foh_fopdt_record(6100 + seed, Some(10.0));
        let f = foh_fit(&u, &every(&y, 5));
        assert_eq!(f.models[0].intersample, InterSample::Foh);
        let r = relative_errors(&f);
        for i in 0..3 {
            sq[i] += r[i] * r[i] / n as f64;
            sd[i] += f.std[i] / f.parameters[i] / n as f64;
        }
    }
    let rms = sq.map(f64::sqrt);
    eprintln!("FOH, every 5th sample: RMS relative errors {rms:?}, mean relative std {sd:?}");
    for i in 0..3 {
        assert!(rms[i] < 0.05, "RMS relative errors {rms:?}");
        let ratio = rms[i] / sd[i];
        assert!(
            (0.7..1.4).contains(&ratio),
            "RMS {rms:?} against std {sd:?}"
        );
    }
    // The ZOH assumption on the noise-free thinned record reads the input's
    // ramp as a dead time about half a period shorter, as at full rate.
    let (u0, y0) = foh_fopdt_record(61, None);
    let (uc, yc) = (col(&u0), col(&every(&y0, 5)));
    let zoh = procest(
        &[Experiment { u: &uc, y: &yc }],
        ProcessKind::P1D,
        1.0,
        &ProcessOptions::default(),
    )
    .unwrap();
    let theta = zoh.models[0].theta;
    assert!(
        (theta - (7.3 - 0.5)).abs() < 0.2,
        "ZOH dead time on the noise-free thinned record {theta}"
    );
}

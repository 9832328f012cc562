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

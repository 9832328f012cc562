use super::*;

fn mean_product(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum::<f64>() / x.len() as f64
}

#[test]
fn shifted_prbs_channels_have_the_designed_cross_correlation() {
    let d = tmp("channels-prbs");
    let f = p(&d, "u.csv");
    // m-sequence n = 5 (m = 31), hold 2, a = 2, 3 channels shifted by
    // l·⌊31/3⌋ = 10 l: over whole periods every pair correlates to −a²/m
    // exactly (the ±1 m-sequence's periodic autocorrelation is −1/m off
    // lag 0), each channel to a².
    let s = ok(&[
        "prbs",
        "--order",
        "5",
        "--amplitude",
        "2",
        "--hold",
        "2",
        "--periods",
        "2",
        "--channels",
        "3",
        "--out",
        &f,
    ]);
    assert!(s.contains("3 channels"), "{s}");
    let (head, cols) = read_csv(&f);
    assert_eq!(head, ["t", "u1", "u2", "u3"]);
    assert_eq!(cols[1].len(), 2 * 2 * 31);
    for i in 1..4 {
        assert!((mean_product(&cols[i], &cols[i]) - 4.0).abs() < 1e-12);
        for j in i + 1..4 {
            let r = mean_product(&cols[i], &cols[j]);
            assert!((r + 4.0 / 31.0).abs() < 1e-12, "{i},{j}: {r}");
        }
    }
    // one channel is the plain command's output
    let g = p(&d, "one.csv");
    ok(&[
        "prbs",
        "--order",
        "5",
        "--amplitude",
        "2",
        "--hold",
        "2",
        "--periods",
        "2",
        "--out",
        &g,
    ]);
    assert_eq!(read_csv(&g).1[1], cols[1]);

    // inverse PRBS (n = 4, m = 15), 2 channels shifted by 7: |R| = a²/m
    // (eqs. II-6, II-10 normalised per sample).
    let s = ok(&[
        "prbs",
        "--inverse",
        "--order",
        "4",
        "--amplitude",
        "1",
        "--hold",
        "3",
        "--inputs",
        "ua,ub",
        "--out",
        &f,
    ]);
    assert!(s.contains("2 channels"), "{s}");
    let (head, cols) = read_csv(&f);
    assert_eq!(head, ["t", "ua", "ub"]);
    assert_eq!(cols[1].len(), 2 * 3 * 15);
    let r = mean_product(&cols[1], &cols[2]);
    assert!((r.abs() - 1.0 / 15.0).abs() < 1e-12, "{r}");
    // more channels than m: refused
    let e = fails(
        &[
            "prbs",
            "--order",
            "2",
            "--amplitude",
            "1",
            "--channels",
            "4",
            "--out",
            &f,
        ],
        2,
    );
    assert!(e.contains("at most 3 channels"), "{e}");
}

#[test]
fn multisine_channels_are_orthogonal_and_random_ones_independent() {
    let d = tmp("channels-random");
    let f = p(&d, "u.csv");
    // zippered harmonics: disjoint frequency sets, cross-correlation 0
    // over whole periods at every lag (rounding only: 1e-12 · RMS²).
    ok(&[
        "multisine",
        "--len",
        "512",
        "--period",
        "128",
        "--channels",
        "3",
        "--out",
        &f,
    ]);
    let (_, cols) = read_csv(&f);
    for i in 1..4 {
        assert!((mean_product(&cols[i], &cols[i]) - 1.0).abs() < 1e-9);
        for j in i + 1..4 {
            for lag in [0usize, 1, 5] {
                let shifted: Vec<f64> = (0..512).map(|k| cols[j][(k + lag) % 512]).collect();
                let r = mean_product(&cols[i], &shifted);
                assert!(r.abs() < 1e-12, "{i},{j} lag {lag}: {r}");
            }
        }
    }
    // rbs / gbn / gaussian: independent seeded streams; channel 1 is the
    // single-channel signal. Sample correlation of N = 20000 independent
    // ±1 values has standard deviation 1/√N = 0.007; 5σ bound.
    for cmd in ["rbs", "gbn", "gaussian"] {
        ok(&[
            cmd,
            "--len",
            "20000",
            "--seed",
            "4",
            "--channels",
            "2",
            "--out",
            &f,
        ]);
        let (_, cols) = read_csv(&f);
        let g = p(&d, "one.csv");
        ok(&[cmd, "--len", "20000", "--seed", "4", "--out", &g]);
        assert_eq!(read_csv(&g).1[1], cols[1], "{cmd}");
        let r = mean_product(&cols[1], &cols[2])
            / (mean_product(&cols[1], &cols[1]) * mean_product(&cols[2], &cols[2])).sqrt();
        assert!(r.abs() < 5.0 / 20000f64.sqrt(), "{cmd}: {r}");
        assert_ne!(cols[1], cols[2]);
    }
    let e = fails(
        &[
            "rbs",
            "--len",
            "10",
            "--inputs",
            "a,b",
            "--channels",
            "3",
            "--out",
            &f,
        ],
        2,
    );
    assert!(e.contains("--channels 3") && e.contains("2 names"), "{e}");
    let e = fails(&["rbs", "--len", "10", "--inputs", "a,a", "--out", &f], 2);
    assert!(e.contains("named twice"), "{e}");
    let e = fails(
        &[
            "multisine",
            "--len",
            "64",
            "--period",
            "8",
            "--channels",
            "5",
            "--out",
            &f,
        ],
        2,
    );
    assert!(e.contains("harmonics"), "{e}");
}

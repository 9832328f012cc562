use super::*;

#[test]
fn inverse_prbs_csv_has_the_period_and_antisymmetry() {
    let d = tmp("prbs");
    let out = p(&d, "u.csv");
    ok(&[
        "prbs",
        "--inverse",
        "--order",
        "5",
        "--amplitude",
        "2",
        "--hold",
        "3",
        "--out",
        &out,
    ]);
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t,u1"));
    let u: Vec<f64> = lines
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    assert_eq!(u.len(), 2 * 3 * 31);
    assert!(u.iter().all(|v| v.abs() == 2.0));
    for k in 0..93 {
        assert_eq!(u[k + 93], -u[k]);
    }
    // the same as the library's
    let lib = InversePrbs::new(&InversePrbsOptions {
        order: 5,
        amplitude: 2.0,
        hold: 3,
        taps: None,
    })
    .unwrap()
    .one_period();
    assert_eq!(u, lib);
}

#[test]
fn plain_prbs_rbs_gbn_multisine() {
    let d = tmp("signals");
    ok(&[
        "prbs",
        "--order",
        "4",
        "--amplitude",
        "1",
        "--periods",
        "2",
        "--out",
        &p(&d, "p.csv"),
    ]);
    assert_eq!(
        std::fs::read_to_string(p(&d, "p.csv"))
            .unwrap()
            .lines()
            .count(),
        1 + 30
    );
    ok(&[
        "rbs",
        "--len",
        "100",
        "--seed",
        "3",
        "--out",
        &p(&d, "r.csv"),
    ]);
    ok(&[
        "gbn",
        "--len",
        "100",
        "--switch-probability",
        "0.1",
        "--out",
        &p(&d, "g.csv"),
    ]);
    ok(&[
        "multisine",
        "--len",
        "64",
        "--period",
        "32",
        "--out",
        &p(&d, "m.csv"),
    ]);
    ok(&[
        "gaussian",
        "--len",
        "100",
        "--std",
        "0.5",
        "--hold",
        "2",
        "--seed",
        "4",
        "--out",
        &p(&d, "n.csv"),
    ]);
    let n = std::fs::read_to_string(p(&d, "n.csv")).unwrap();
    let vals: Vec<f64> = n
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect();
    assert!(vals.chunks(2).all(|c| c[0] == c[1]), "held pairs");
    let e = fails(
        &[
            "gaussian",
            "--len",
            "10",
            "--std",
            "0",
            "--out",
            &p(&d, "x.csv"),
        ],
        2,
    );
    assert!(e.contains("standard deviation"), "{e}");
    for f in ["r.csv", "g.csv", "n.csv"] {
        assert_eq!(
            std::fs::read_to_string(p(&d, f)).unwrap().lines().count(),
            101
        );
    }
    fails(
        &[
            "prbs",
            "--order",
            "1",
            "--amplitude",
            "1",
            "--out",
            &p(&d, "x.csv"),
        ],
        2,
    );
}

#[test]
fn design_reproduces_table_ii() {
    // Zhu 2000 Table II: T = 0.01 s, 30 Hz actuator, margin 3, 0.025 Hz: n = 8, n_r = 10.
    let s = ok(&["design"]);
    assert!(s.contains("order n            8"), "{s}");
    assert!(s.contains("hold n_r           10"), "{s}");
}

use super::*;

/// G(z) = b/(z − a) at T = 0.1 s.
fn first_order(a: f64, b: f64) -> StateSpace {
    StateSpace::new(
        DMatrix::from_element(1, 1, a),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, b),
        DMatrix::zeros(1, 1),
        Some(0.1),
    )
    .unwrap()
}

fn json(args: &[&str]) -> serde_json::Value {
    serde_json::from_str(&ok(args)).unwrap()
}

#[test]
fn analyze_matches_first_order_closed_forms() {
    let d = tmp("analyze");
    let (a, b) = (0.8, 0.5);
    let m = p(&d, "d.json");
    ModelFile::new(first_order(a, b)).write(&m).unwrap();
    let r = json(&["analyze", "--model", &m, "--json"]);
    // ‖G‖₂² = Σ_k (b a^k)² = b²/(1 − a²); ‖G‖∞ = b/(1 − a) at θ = 0;
    // Hankel value b/(1 − a²). Tolerances: exact to rounding for the
    // Lyapunov solves (1e-12), the H∞ iteration's relative 1e-8.
    let h2 = r["h2_norm"].as_f64().unwrap();
    assert!((h2 - b / (1.0 - a * a).sqrt()).abs() < 1e-12, "{h2}");
    let hinf = r["hinf_norm"]["norm"].as_f64().unwrap();
    assert!((hinf - b / (1.0 - a)).abs() < 1e-7 * hinf, "{hinf}");
    assert!(r["hinf_norm"]["peak_frequency"].as_f64().unwrap().abs() < 1e-6);
    let hsv = r["hankel_singular_values"][0].as_f64().unwrap();
    assert!((hsv - b / (1.0 - a * a)).abs() < 1e-12);
    assert_eq!(r["stability"]["stable"], true);
    assert!((r["stability"]["spectral_radius"].as_f64().unwrap() - a).abs() < 1e-15);
    assert!((r["dc_gain"][0][0].as_f64().unwrap() - b / (1.0 - a)).abs() < 1e-12);
    let text = ok(&["analyze", "--model", &m]);
    for what in [
        "poles (1)",
        "spectral radius",
        "DC gain",
        "H2 norm: 0.833333",
        "H∞ norm: 2.500000 at ω = 0",
        "Hankel singular values: 1.388889",
    ] {
        assert!(text.contains(what), "{what}: {text}");
    }

    // Continuous k/(s + p): ‖G‖₂ = k/√(2p), ‖G‖∞ = k/p, Hankel k/(2p).
    let (pl, k) = (2.0, 3.0);
    let c = p(&d, "c.json");
    ModelFile::new(
        StateSpace::new(
            DMatrix::from_element(1, 1, -pl),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, k),
            DMatrix::zeros(1, 1),
            None,
        )
        .unwrap(),
    )
    .write(&c)
    .unwrap();
    let r = json(&["analyze", "--model", &c, "--json"]);
    assert!((r["h2_norm"].as_f64().unwrap() - k / (2.0 * pl).sqrt()).abs() < 1e-12);
    assert!((r["hinf_norm"]["norm"].as_f64().unwrap() - k / pl).abs() < 1e-7);
    assert!((r["hankel_singular_values"][0].as_f64().unwrap() - k / (2.0 * pl)).abs() < 1e-12);
    assert_eq!(r["stability"]["max_real_part"].as_f64(), Some(-pl));
    assert!(ok(&["analyze", "--model", &c]).contains("largest real part of a pole = -2"));
    // its work arrays are checked against the memory budget first
    let e = fails(&["analyze", "--model", &c, "--memory-limit", "100"], 2);
    assert!(e.contains("Hamiltonian") && e.contains("needs"), "{e}");
}

#[test]
fn analyze_of_an_unstable_model_says_the_norms_are_not_defined() {
    let d = tmp("analyze-unstable");
    let m = p(&d, "u.json");
    ModelFile::new(first_order(1.2, 1.0)).write(&m).unwrap();
    let text = ok(&["analyze", "--model", &m]);
    assert!(
        text.contains("UNSTABLE, spectral radius ρ(A) = 1.2"),
        "{text}"
    );
    for what in ["H2 norm", "H∞ norm", "Hankel singular values"] {
        assert!(
            text.contains(&format!("{what}: not defined: the model is unstable")),
            "{what}: {text}"
        );
    }
    let r = json(&["analyze", "--model", &m, "--json"]);
    assert!(r["h2_norm"].is_null() && r["hinf_norm"].is_null());
    assert!(r["notes"]["hinf_norm"].as_str().unwrap().contains("1.2"));
    // an integrator has no DC gain
    let i = p(&d, "i.json");
    ModelFile::new(first_order(1.0, 1.0)).write(&i).unwrap();
    let r = json(&["analyze", "--model", &i, "--json"]);
    assert!(r["dc_gain"].is_null());
    assert!(r["notes"]["dc_gain"].as_str().unwrap().contains("infinite"));
}

#[test]
fn bode_at_given_frequencies() {
    let d = tmp("bode-omega");
    let (a, b) = (0.8, 0.5);
    let m = p(&d, "d.json");
    ModelFile::new(first_order(a, b)).write(&m).unwrap();
    let r = json(&["bode", "--model", &m, "--omega", "0.1,1,10,31.4", "--json"]);
    let omega = [0.1, 1.0, 10.0, 31.4];
    for (k, w) in omega.iter().enumerate() {
        // |b/(e^{jωT} − a)|, phase −arg(e^{jωT} − a)
        let z = num_complex::Complex64::from_polar(1.0, w * 0.1) - a;
        let mag = b / z.norm();
        let got = r["pairs"][0]["magnitude"][k].as_f64().unwrap();
        assert!((got - mag).abs() < 1e-12 * mag, "{w}: {got} vs {mag}");
        let ph = r["pairs"][0]["phase_deg"][k].as_f64().unwrap();
        assert!((ph + z.arg().to_degrees()).abs() < 1e-9, "{w}: {ph}");
    }
    let table = ok(&["bode", "--model", &m, "--omega", "0.1,1"]);
    assert_eq!(table.lines().count(), 3, "{table}");
    // above the Nyquist frequency π/T = 31.4159 rad/s: refused
    let e = fails(&["bode", "--model", &m, "--omega", "1,40"], 2);
    assert!(e.contains("Nyquist") && e.contains("40"), "{e}");
    let e = fails(&["bode", "--model", &m, "--omega", "-1"], 2);
    assert!(e.contains("non-negative"), "{e}");
    // a frequency file with a header line; a CSV file written from it
    let f = p(&d, "w.csv");
    std::fs::write(&f, "omega\n0.1\n1\n10\n").unwrap();
    let out = p(&d, "b.csv");
    ok(&["bode", "--model", &m, "--omega-file", &f, "--out", &out]);
    let (head, cols) = read_csv(&out);
    assert_eq!(head[0], "omega");
    assert_eq!(cols[0], vec![0.1, 1.0, 10.0]);
    std::fs::write(&f, "omega\n0.1\nx\n").unwrap();
    let e = fails(&["bode", "--model", &m, "--omega-file", &f], 2);
    assert!(e.contains("line 3"), "{e}");
    let e = fails(&["bode", "--model", &m, "--omega", "1", "--wmin", "0.1"], 2);
    assert!(e.contains("--wmin"), "{e}");
    let e = fails(&["bode", "--model", &m], 2);
    assert!(e.contains("--out") && e.contains("--omega"), "{e}");
}

#[test]
fn lqr_matches_the_scalar_riccati_equation() {
    let d = tmp("lqr");
    let m = p(&d, "d.json");
    let a = 1.1;
    ModelFile::new(first_order(a, 1.0)).write(&m).unwrap();
    let (q, r) = (2.0, 0.5);
    // Scalar DARE with b = 1: x² + (r(1 − a²) − q)x − q r = 0, positive root;
    // k = a x/(r + x), closed-loop pole a − k.
    let bq = r * (1.0 - a * a) - q;
    let x = (-bq + (bq * bq + 4.0 * q * r).sqrt()) / 2.0;
    let k = a * x / (r + x);
    let out = json(&["lqr", "--model", &m, "--q", "2", "--r", "0.5", "--json"]);
    // the solver verifies a relative residual ≤ 1e-9
    assert!((out["x"][0][0].as_f64().unwrap() - x).abs() < 1e-9 * x);
    assert!((out["k"][0][0].as_f64().unwrap() - k).abs() < 1e-9 * k);
    let pole = out["closed_loop_poles"][0]["re"].as_f64().unwrap();
    assert!((pole - (a - k)).abs() < 1e-9);
    let text = ok(&["lqr", "--model", &m, "--q", "2", "--r", "0.5"]);
    assert!(
        text.contains("gain K") && text.contains("closed-loop poles"),
        "{text}"
    );
    let e = fails(&["lqr", "--model", &m, "--q", "1,2"], 2);
    assert!(e.contains("--q") && e.contains("1 states"), "{e}");
    let e = fails(&["lqr", "--model", &m, "--r", "-1"], 2);
    assert!(e.contains("positive definite"), "{e}");
    let c = p(&d, "c.json");
    ModelFile::new(
        StateSpace::new(
            DMatrix::from_element(1, 1, -1.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::zeros(1, 1),
            None,
        )
        .unwrap(),
    )
    .write(&c)
    .unwrap();
    let e = fails(&["lqr", "--model", &c], 2);
    assert!(e.contains("continuous") && e.contains("DARE"), "{e}");
}

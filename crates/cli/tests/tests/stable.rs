use super::*;

/// A record of the unstable y(k+1) = 1.02 y(k) + u(k) (RBS input, no
/// noise; y sampled every `period`): the honest estimate is unstable,
/// so it tests that `--stable` offers a stable one on every route.
fn unstable_record(path: &str, n: usize, period: usize) {
    let u = rbs(n, 3);
    let mut y = 0.0;
    let mut text = String::from("t,u1,y1\n");
    for (k, uk) in u.iter().enumerate() {
        let cell = if k % period == 0 {
            format!("{y}")
        } else {
            String::new()
        };
        text.push_str(&format!("{},{uk},{cell}\n", 0.1 * k as f64));
        y = 1.02 * y + uk;
    }
    std::fs::write(path, text).unwrap();
}

fn radius(path: &str) -> f64 {
    pole_modulus(&ModelFile::read(path).unwrap().model)
        .last()
        .copied()
        .unwrap()
}

#[test]
fn every_route_offers_a_stable_model() {
    let d = tmp("stable");
    let data = p(&d, "unstable.csv");
    unstable_record(&data, 150, 1);
    let base = |method: &str, out: &str| {
        vec![
            "identify".to_string(),
            "--method".into(),
            method.into(),
            "--data".into(),
            data.clone(),
            "--inputs".into(),
            "u1".into(),
            "--outputs".into(),
            "y1".into(),
            "--order".into(),
            "1".into(),
            "--horizon".into(),
            "4".into(),
            "--detrend".into(),
            "none".into(),
            "--out".into(),
            out.into(),
        ]
    };
    let run = |args: &[String]| ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    for method in ["n4sid", "moesp", "cva", "iv"] {
        let plain = p(&d, &format!("{method}.json"));
        run(&base(method, &plain));
        let rho = radius(&plain);
        assert!(
            (rho - 1.02).abs() < 1e-3,
            "{method}: the plain estimate is the true unstable pole, got {rho}"
        );
        let stab = p(&d, &format!("{method}-stable.json"));
        let mut args = base(method, &stab);
        args.push("--stable".into());
        run(&args);
        let rho = radius(&stab);
        assert!(rho < 1.0, "{method} --stable: spectral radius {rho}");
    }
    // Multirate (y every 2): as on the single-rate routes, the unstable
    // estimate (the plant's own pole) is returned with a warning naming
    // its spectral radius (the lifted route refused it before), and
    // --stable offers a stable one.
    let mr = p(&d, "mr.csv");
    unstable_record(&mr, 400, 2);
    let out = p(&d, "mr.json");
    let mut args = base("n4sid", &out);
    args[4] = mr.clone();
    args.extend(["--output-period".into(), "y1=2".into()]);
    let o = lifted(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success());
    let msg = String::from_utf8_lossy(&o.stderr);
    assert!(
        msg.contains("warning: the identified model is unstable") && msg.contains("rho(A) = 1.02"),
        "{msg}"
    );
    assert!((radius(&out) - 1.02).abs() < 1e-2, "{}", radius(&out));
    args.push("--stable".into());
    run(&args);
    let rho = radius(&out);
    assert!(rho < 1.0, "multirate --stable: spectral radius {rho}");
    let f = ModelFile::read(&out).unwrap();
    assert!((f.model.ts().unwrap() - 0.1).abs() < 1e-12);
}

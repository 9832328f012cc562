use super::*;
use lifted_subspace::{Experiment, Method, OrderSelection, SubspaceOptions, identify};

/// A 2-input 2-output order-3 record with offsets and output noise,
/// written as CSV; returns (u, y).
fn record(path: &str, n: usize) -> (DMatrix<f64>, DMatrix<f64>) {
    let g = StateSpace::new(
        DMatrix::from_row_slice(3, 3, &[0.8, 0.2, 0.0, -0.2, 0.8, 0.0, 0.0, 0.0, 0.5]),
        DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 1.0, 0.5, -0.5]),
        DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 1.0, 0.0, 1.0, 0.5]),
        DMatrix::from_row_slice(2, 2, &[0.1, 0.0, 0.0, 0.2]),
        Some(1.0),
    )
    .unwrap();
    let u1 = rbs(n, 21);
    let u2 = rbs(n, 22);
    let u = DMatrix::from_fn(n, 2, |k, j| if j == 0 { u1[k] } else { u2[k] } + 0.5);
    let noise = rbs(2 * n, 23);
    let mut y = g.lsim(&u, None, None).unwrap().y;
    for k in 0..n {
        y[(k, 0)] += 3.0 + 0.05 * noise[k];
        y[(k, 1)] -= 1.0 + 0.05 * noise[n + k];
    }
    let mut text = String::from("t,u1,u2,y1,y2\n");
    for k in 0..n {
        text.push_str(&format!(
            "{},{},{},{:e},{:e}\n",
            k,
            u[(k, 0)],
            u[(k, 1)],
            y[(k, 0)],
            y[(k, 1)]
        ));
    }
    std::fs::write(path, text).unwrap();
    // The values as the CSV holds them (the outputs printed with `{:e}`
    // round-trip exactly).
    (u, y)
}

fn args<'a>(data: &'a str, out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec![
        "identify",
        "--method",
        "n4sid",
        "--data",
        data,
        "--inputs",
        "u1,u2",
        "--outputs",
        "y1,y2",
        "--out",
        out,
    ];
    a.extend_from_slice(extra);
    a
}

fn rel(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).norm() / b.norm().max(1e-300)
}

#[test]
fn streamed_cli_model_equals_the_library_in_memory() {
    let d = tmp("trust-stream");
    let data = p(&d, "rec.csv");
    let (u, y) = record(&data, 6000);
    let out = p(&d, "m.json");
    // Horizon, route and order given: the file is streamed (two passes);
    // no refinement (the default would refine this short record by PEM),
    // so the subspace model itself is compared.
    ok(&args(
        &data,
        &out,
        &[
            "--order",
            "3",
            "--horizon",
            "10",
            "--estimator",
            "shift",
            "--refine",
            "none",
        ],
    ));
    let f = ModelFile::read(&out).unwrap();
    let diag = &f.diagnostics;
    assert!(
        diag["route"].as_str().unwrap().contains("streamed"),
        "{diag}"
    );
    assert_eq!(
        diag["bd_route"].as_str().unwrap(),
        "output-error least squares on the data"
    );
    assert_eq!(diag["stability"]["stable"], serde_json::json!(true));
    let opts = SubspaceOptions {
        method: Method::N4sid,
        order: OrderSelection::Fixed(3),
        ..Default::default()
    };
    // The workflow identifies on channels divided by their standard
    // deviations (over the first 1e4 rows: all 6000 here) and brings the
    // model back to the data's units; the library is given the same.
    let sd = |m: &DMatrix<f64>| -> Vec<f64> {
        (0..m.ncols())
            .map(|c| {
                let col = m.column(c);
                let mean = col.mean();
                (col.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / col.len() as f64).sqrt()
            })
            .collect()
    };
    let (su, sy) = (sd(&u), sd(&y));
    let us = DMatrix::from_fn(u.nrows(), 2, |k, j| u[(k, j)] / su[j]);
    let ys = DMatrix::from_fn(y.nrows(), 2, |k, j| y[(k, j)] / sy[j]);
    let mut mem = identify(&[Experiment { u: &us, y: &ys }], &opts).unwrap();
    let m = &mem.model;
    mem.model = StateSpace::new(
        m.a().clone(),
        DMatrix::from_fn(3, 2, |i, j| m.b()[(i, j)] / su[j]),
        DMatrix::from_fn(2, 3, |i, j| m.c()[(i, j)] * sy[i]),
        DMatrix::from_fn(2, 2, |i, j| m.d()[(i, j)] * sy[i] / su[j]),
        m.ts(),
    )
    .unwrap();
    if let Some(op) = mem.operating_point.as_mut() {
        op.u0.iter_mut().zip(&su).for_each(|(v, s)| *v *= s);
        op.y0.iter_mut().zip(&sy).for_each(|(v, s)| *v *= s);
    }
    // The same model: Markov parameters (D, CB, CAB, …) and poles to
    // 1e-10 (compared as invariants: the state basis may differ by a
    // diagonal scaling where the data scales do).
    let (mc, ml) = (
        f.model.markov_parameters(30).unwrap(),
        mem.model.markov_parameters(30).unwrap(),
    );
    let num: f64 = mc
        .iter()
        .zip(&ml)
        .map(|(a, b)| (a - b).norm_squared())
        .sum::<f64>()
        .sqrt();
    let den: f64 = ml.iter().map(|b| b.norm_squared()).sum::<f64>().sqrt();
    assert!(
        num / den < 1e-10,
        "Markov parameters differ by {:e}",
        num / den
    );
    let (pc, pl) = (pole_modulus(&f.model), pole_modulus(&mem.model));
    for (a, b) in pc.iter().zip(&pl) {
        assert!((a - b).abs() < 1e-10, "poles {pc:?} vs {pl:?}");
    }
    let op = f.operating_point.as_ref().unwrap();
    let mop = mem.operating_point.as_ref().unwrap();
    for (a, b) in op.y0.iter().zip(&mop.y0).chain(op.u0.iter().zip(&mop.u0)) {
        assert!((a - b).abs() < 1e-10 * b.abs().max(1.0), "{a} vs {b}");
    }
    // The one-pass projection stays available and says so.
    let proj = p(&d, "proj.json");
    ok(&args(
        &data,
        &proj,
        &[
            "--order",
            "3",
            "--horizon",
            "10",
            "--estimator",
            "shift",
            "--bd",
            "projection",
        ],
    ));
    let fp = ModelFile::read(&proj).unwrap();
    assert_eq!(
        fp.diagnostics["bd_route"].as_str().unwrap(),
        "projection on the compressed data"
    );
}

#[test]
fn default_structure_is_chosen_on_held_out_data() {
    let d = tmp("trust-select");
    let data = p(&d, "rec.csv");
    record(&data, 3000);
    let out = p(&d, "m.json");
    ok(&args(&data, &out, &[]));
    let f = ModelFile::read(&out).unwrap();
    let sel = &f.diagnostics["structure_selection"];
    assert!(sel["candidates"].as_array().unwrap().len() > 10, "{sel}");
    let order = sel["order"].as_u64().unwrap() as usize;
    assert_eq!(f.model.order(), order);
    // The true order (3) or close above it, and a good held-out fit
    // (noise 0.05 on outputs of RMS ≈ 1.5).
    assert!((3..=5).contains(&order), "order {order}: {sel}");
    assert!(sel["held_out_fit"].as_f64().unwrap() > 90.0, "{sel}");
    let h = sel["horizon"].as_u64().unwrap() as usize;
    assert_eq!(f.diagnostics["horizons"], serde_json::json!([h, h]));
}

#[test]
fn refine_starts_from_the_plain_model() {
    let d = tmp("trust-refine");
    let data = p(&d, "rec.csv");
    record(&data, 3000);
    let plain = p(&d, "plain.json");
    let refined = p(&d, "refined.json");
    let fixed = ["--order", "3", "--horizon", "10", "--estimator", "shift"];
    ok(&args(&data, &plain, &fixed));
    let mut extra = fixed.to_vec();
    extra.extend(["--refine", "oe", "--refine-iterations", "1"]);
    ok(&args(&data, &refined, &extra));
    let fp = ModelFile::read(&plain).unwrap();
    let fr = ModelFile::read(&refined).unwrap();
    let start = &fr.diagnostics["refinement"];
    // The refinement's starting cost is that of the plain model: both
    // runs took the same (streamed) route to the same start.
    assert_eq!(fp.diagnostics["route"], fr.diagnostics["route"]);
    if start["kept"] == serde_json::json!("Initial") {
        assert!(rel(fr.model.b(), fp.model.b()) < 1e-12);
    }
}

#[test]
fn unstable_models_are_flagged() {
    let d = tmp("trust-unstable");
    // An unstable plant, y(k+1) = 1.02 y(k) + u(k), no noise: the honest
    // estimate is unstable.
    let data = p(&d, "unstable.csv");
    let u = rbs(150, 3);
    let mut yk = 0.0;
    let mut text = String::from("t,u1,y1\n");
    for (k, uk) in u.iter().enumerate() {
        text.push_str(&format!("{k},{uk},{yk}\n"));
        yk = 1.02 * yk + uk;
    }
    std::fs::write(&data, text).unwrap();
    let out = p(&d, "m.json");
    let o = lifted(&[
        "identify",
        "--method",
        "n4sid",
        "--data",
        &data,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--order",
        "1",
        "--horizon",
        "4",
        "--detrend",
        "none",
        "--out",
        &out,
    ]);
    assert!(o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("warning: the identified model is unstable") && err.contains("rho(A) = 1.02"),
        "{err}"
    );
    let f = ModelFile::read(&out).unwrap();
    assert_eq!(
        f.diagnostics["stability"]["stable"],
        serde_json::json!(false)
    );
    // validate: no fit number, no residual test reported as passed.
    let v = lifted(&[
        "validate",
        "--model",
        &out,
        "--data",
        &data,
        "--detrend",
        "none",
    ]);
    let table = String::from_utf8_lossy(&v.stdout);
    let verr = String::from_utf8_lossy(&v.stderr);
    assert!(table.contains("n/a: unstable"), "{table}");
    assert!(
        verr.contains("unstable: simulation fit not meaningful"),
        "{verr}"
    );
    // --refine starts from the stabilised model with either cost and
    // returns a stable model (never an unstable one, never an error).
    for cost in ["pem", "oe"] {
        let r = p(&d, &format!("{cost}.json"));
        ok(&[
            "identify",
            "--method",
            "n4sid",
            "--data",
            &data,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--order",
            "1",
            "--horizon",
            "4",
            "--detrend",
            "none",
            "--refine",
            cost,
            "--out",
            &r,
        ]);
        let fr = ModelFile::read(&r).unwrap();
        let rho = pole_modulus(&fr.model)[0];
        assert!(rho < 1.0, "--refine {cost}: rho {rho}");
        // Both costs start from the zero-padded-shift re-estimate (the
        // unconstrained one, ρ = 1.02, cannot start stable iterates).
        assert_eq!(fr.diagnostics["stabilized"], serde_json::json!(true));
        assert!(
            fr.diagnostics["refinement_start"]
                .as_str()
                .is_some_and(|s| s.contains("zero-padded")),
            "{cost}: {}",
            fr.diagnostics
        );
    }
    // --min-fit fails on an unstable model.
    let m = lifted(&[
        "validate",
        "--model",
        &out,
        "--data",
        &data,
        "--detrend",
        "none",
        "--min-fit",
        "0",
    ]);
    assert_eq!(
        m.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&m.stderr)
    );
}

//! ARX and FIR from the command line (issue 49): the polynomials with
//! their standard deviations, a polynomial model file the other
//! commands take, refusals.
use super::*;

#[test]
fn arx_prints_the_polynomials_and_its_model_file_feeds_validate_and_mpc() {
    let d = tmp("arx_cli");
    let (id, val) = single_rate_data(&d);
    let out = p(&d, "arx.json");
    let text = ok(&[
        "identify",
        "--method",
        "arx",
        "--orders",
        "2, 2 1",
        "--data",
        &id,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--out",
        &out,
    ]);
    // The polynomials with a standard deviation after each free
    // coefficient (4 of them).
    assert!(text.contains("A(q) = 1 "), "{text}");
    assert_eq!(text.matches("(±").count(), 4, "{text}");
    let f = ModelFile::read(&out).unwrap();
    assert_eq!(f.kind, "polynomial");
    let poly = f.polynomial.as_ref().unwrap();
    assert_eq!(poly.parameters().len(), 4);
    assert!(poly.std().unwrap().iter().all(|s| *s > 0.0 && *s < 0.05));
    // The plant's poles (SNR 1000: ARX is nearly unbiased).
    let got = pole_modulus(&f.model);
    let want = pole_modulus(&plant());
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() < 0.03, "{got:?} vs {want:?}");
    }
    ok(&["validate", "--model", &out, "--data", &val]);
    let sim = p(&d, "mpc.csv");
    ok(&[
        "mpc",
        "--model",
        &out,
        "--setpoint",
        "y1=1",
        "--steps",
        "40",
        "--out",
        &sim,
    ]);
    // The scan without orders, and FIR.
    let auto = p(&d, "auto.json");
    ok(&[
        "identify",
        "--method",
        "arx",
        "--data",
        &id,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--out",
        &auto,
    ]);
    let f = ModelFile::read(&auto).unwrap();
    assert!(f.diagnostics["structure_scan"]["chosen"].is_object());
    let fir = p(&d, "fir.json");
    ok(&[
        "identify",
        "--method",
        "fir",
        "--orders",
        "20 1",
        "--data",
        &id,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--out",
        &fir,
    ]);
}

#[test]
fn oe_identifies_from_a_slow_output() {
    // The test plant's output kept every 4th sample (empty cells): OE
    // [nb nf nk] = [2 2 1] gives the fast model with its deviations.
    let d = tmp("oe_cli");
    let data = p(&d, "slow.csv");
    simulate(&data, rbs(4000, 3), 4, 1000.0, 5);
    let out = p(&d, "oe.json");
    let text = ok(&[
        "identify",
        "--method",
        "oe",
        "--orders",
        "2 2 1",
        "--data",
        &data,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--out",
        &out,
    ]);
    assert!(text.contains("F(q) = 1 "), "{text}");
    let f = ModelFile::read(&out).unwrap();
    assert_eq!(f.kind, "polynomial");
    assert_eq!(f.diagnostics["measured"][0], 1000);
    let got = pole_modulus(&f.model);
    let want = pole_modulus(&plant());
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() < 0.03, "{got:?} vs {want:?}");
    }
}

#[test]
fn armax_and_bj_identify_from_a_slow_output() {
    // The same slow record (every 4th sample): ARMAX [2 2 1 1] and BJ
    // [2 1 1 2 1] run on its measured samples (the predictor skips the
    // empty cells) and give the plant's poles; the BJ file feeds validate.
    let d = tmp("armax_bj_cli");
    let data = p(&d, "slow.csv");
    simulate(&data, rbs(4000, 3), 4, 1000.0, 5);
    for (method, orders) in [("armax", "2 2 1 1"), ("bj", "2 1 1 2 1")] {
        let out = p(&d, &format!("{method}.json"));
        let text = ok(&[
            "identify",
            "--method",
            method,
            "--orders",
            orders,
            "--data",
            &data,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--out",
            &out,
        ]);
        assert!(text.contains("C(q) = 1 "), "{text}");
        let f = ModelFile::read(&out).unwrap();
        assert_eq!(f.diagnostics["measured"][0], 1000);
        let got = pole_modulus(&f.model);
        let want = pole_modulus(&plant());
        for w in &want {
            assert!(
                got.iter().any(|g| (g - w).abs() < 0.03),
                "{method}: {got:?} vs {want:?}"
            );
        }
        if method == "bj" {
            let v = ok(&[
                "validate",
                "--model",
                &out,
                "--data",
                &data,
                "--inputs",
                "u1",
                "--outputs",
                "y1",
            ]);
            assert!(v.contains("1000"), "{v}");
        }
    }
}

/// The ARX [2 2 1] model file of the record `id` (u1 → y1), written in
/// `d`.
fn arx_221(d: &Path, id: &str) -> String {
    let out = p(d, "arx.json");
    ok(&[
        "identify",
        "--method",
        "arx",
        "--orders",
        "2 2 1",
        "--data",
        id,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--out",
        &out,
    ]);
    out
}

#[test]
fn bode_draws_the_confidence_band_of_a_polynomial_model() {
    let d = tmp("arx_bode");
    let (id, _) = single_rate_data(&d);
    let out = arx_221(&d, &id);
    // analyze shows the polynomials with their deviations.
    let text = ok(&["analyze", "--model", &out]);
    assert!(text.contains("A(q) = 1 ") && text.contains("(±"), "{text}");
    let text = ok(&["analyze", "--model", &out, "--json"]);
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["polynomial"]["std"].as_array().unwrap().len(), 4);
    let text = ok(&["bode", "--model", &out, "--omega", "0.1,1,3", "--json"]);
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["confidence"], 0.95);
    let pair = &v["pairs"][0];
    for k in 0..3 {
        let mid = pair["magnitude_db"][k].as_f64().unwrap();
        let lo = pair["magnitude_db_lower"][k].as_f64().unwrap();
        let hi = pair["magnitude_db_upper"][k].as_f64().unwrap();
        assert!(lo < mid && mid < hi, "{lo} {mid} {hi}");
        // SNR 1000, 2000 samples: a narrow band (well under 1 dB).
        assert!(hi - lo < 1.0, "{lo} {hi}");
        let sd = pair["phase_std_deg"][k].as_f64().unwrap();
        assert!(sd > 0.0 && sd < 2.0, "{sd}");
    }
    // The SVG carries the band's legend; --confidence 0 drops it.
    let svg = p(&d, "bode.svg");
    ok(&["bode", "--model", &out, "--out", &svg]);
    assert!(std::fs::read_to_string(&svg).unwrap().contains("±95 %"));
    let text = ok(&[
        "bode",
        "--model",
        &out,
        "--omega",
        "1",
        "--json",
        "--confidence",
        "0",
    ]);
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert!(v["confidence"].is_null() && v["pairs"][0].get("magnitude_db_lower").is_none());
    fails(
        &[
            "bode",
            "--model",
            &out,
            "--omega",
            "1",
            "--confidence",
            "1.5",
        ],
        2,
    );
}

/// `lifted step` draws the band of a model with a parameter covariance
/// (issue 49): `_lo`/`_hi` columns around every sample after the
/// delay (zero width before it: the response is exactly 0 there),
/// widening as the response builds up; `--confidence 0` drops them; a
/// bad level is refused.
#[test]
fn step_draws_the_band_of_a_model_with_a_covariance() {
    let d = tmp("step_band");
    let (id, _) = single_rate_data(&d);
    let out = arx_221(&d, &id);
    let csv = p(&d, "step.csv");
    ok(&["step", "--model", &out, "--out", &csv, "--samples", "40"]);
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header.len(), 4, "{header:?}");
    assert!(
        header[2].ends_with("_lo") && header[3].ends_with("_hi"),
        "{header:?}"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 40);
    assert_eq!(rows[0][2], rows[0][3]);
    for r in &rows[1..] {
        assert!(r[2] < r[1] && r[1] < r[3], "{r:?}");
    }
    assert!(rows[39][3] - rows[39][2] > rows[1][3] - rows[1][2]);
    let svg = p(&d, "step.svg");
    ok(&["step", "--model", &out, "--out", &svg]);
    assert!(std::fs::read_to_string(&svg).unwrap().contains("±95 %"));
    ok(&["step", "--model", &out, "--out", &csv, "--confidence", "0"]);
    let plain = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(plain.lines().next().unwrap().split(',').count(), 2);
    fails(
        &[
            "step",
            "--model",
            &out,
            "--out",
            &csv,
            "--confidence",
            "1.5",
        ],
        2,
    );
    // The band's gradients (2p + 3 responses) are sized before they
    // are allocated: over the memory budget, a clear refusal.
    let msg = fails(
        &[
            "step",
            "--model",
            &out,
            "--out",
            &csv,
            "--samples",
            "2000000",
            "--memory-limit",
            "50M",
        ],
        2,
    );
    assert!(msg.contains("confidence band"), "{msg}");
}

/// The report draws the 95 % bands of a model with a parameter
/// covariance on its step and Bode figures and says so in their
/// captions (issue 49); a subspace model identified without its
/// covariance (`--no-covariance`) has none.
#[test]
fn the_report_draws_the_bands_of_a_model_with_a_covariance() {
    let d = tmp("report_band");
    let (id, val) = single_rate_data(&d);
    let arx = arx_221(&d, &id);
    let html = p(&d, "r.html");
    ok(&["report", "--model", &arx, "--data", &val, "--out", &html]);
    let page = std::fs::read_to_string(&html).unwrap();
    assert_eq!(
        page.matches("95 % confidence band").count(),
        2,
        "step and Bode"
    );
    assert!(
        page.matches("±95 %").count() >= 3,
        "the bands' legend entries"
    );
    let ss = p(&d, "ss.json");
    ok(&[
        "identify",
        "--method",
        "n4sid",
        "--order",
        "2",
        "--data",
        &id,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--out",
        &ss,
        "--no-covariance",
    ]);
    ok(&["report", "--model", &ss, "--data", &val, "--out", &html]);
    let page = std::fs::read_to_string(&html).unwrap();
    assert!(!page.contains("confidence band") && !page.contains("±95 %"));
}

#[test]
fn a_step_test_gives_gain_time_constant_and_dead_time() {
    // K = 2, τ = 20 s, θ = 7.3 s, T = 1 s: at rest for 20 s, then a unit
    // step and back after 250 s; noise σ 0.02. The printed parameters
    // within 2 % (SNR ≈ 2500 on a step of this size).
    use lifted_pem::{ProcessKind, ProcessModel};
    let d = tmp("process_cli");
    let data = p(&d, "step.csv");
    let g = ProcessModel::from_parameters(ProcessKind::P1D, &[2.0, 20.0, 7.3], 1.0).unwrap();
    let n = 500;
    let u: Vec<f64> = (0..n)
        .map(|t| if (20..270).contains(&t) { 1.0 } else { 0.0 })
        .collect();
    let y = g.simulate(&u).unwrap();
    let noise = rbs(n, 9);
    let mut text = String::from("t,u1,y1\n");
    for t in 0..n {
        text.push_str(&format!(
            "{t},{},{}\n",
            u[t] + 5.0,
            y[t] + 0.02 * noise[t] + 40.0
        ));
    }
    std::fs::write(&data, text).unwrap();
    let out = p(&d, "p1d.json");
    let printed = ok(&[
        "identify",
        "--method",
        "process",
        "--process",
        "p1d",
        "--data",
        &data,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--out",
        &out,
    ]);
    assert!(
        printed.contains("process model P1D, output 1: K(u1) = "),
        "{printed}"
    );
    let f = ModelFile::read(&out).unwrap();
    let values: Vec<f64> = f.diagnostics["process"]["outputs"][0]["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    for (got, want) in values.iter().zip([2.0, 20.0, 7.3]) {
        assert!((got - want).abs() < 0.02 * want, "{values:?}");
    }
    // A dead time known from the plant, held (in seconds): it stays 7.3
    // with no deviation; the gain is held in the data's units (the
    // channels are scaled inside); an unknown parameter is named.
    let held = p(&d, "held.json");
    let base = [
        "identify",
        "--method",
        "process",
        "--process",
        "p1d",
        "--data",
        &data,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--out",
        &held,
    ];
    let mut with = base.to_vec();
    with.extend(["--process-fix", "Td=7.3", "--process-fix", "K(u1)=2"]);
    ok(&with);
    let f = ModelFile::read(&held).unwrap();
    let out0 = &f.diagnostics["process"]["outputs"][0];
    let values: Vec<f64> = out0["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert!(
        (values[0] - 2.0).abs() < 1e-12 && (values[2] - 7.3).abs() < 1e-12,
        "{values:?}"
    );
    assert_eq!(out0["std"][0], 0.0);
    assert_eq!(out0["std"][2], 0.0);
    assert!((values[1] - 20.0).abs() < 0.02 * 20.0, "{values:?}");
    let mut bad = base.to_vec();
    bad.extend(["--process-fix", "Tq=1"]);
    let msg = fails(&bad, 2);
    assert!(msg.contains("Tq") && msg.contains("Tp1"), "{msg}");
    let mut bad = base.to_vec();
    bad.extend(["--process-fix", "Td"]);
    assert!(fails(&bad, 2).contains("--process-fix"));
    fails(
        &[
            "identify",
            "--method",
            "arx",
            "--process",
            "p1d",
            "--data",
            &data,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--out",
            &out,
        ],
        2,
    );
}

#[test]
fn bad_orders_are_named() {
    let d = tmp("arx_cli_bad");
    let (id, _) = single_rate_data(&d);
    let out = p(&d, "m.json");
    let run = |method: &str, orders: &str| {
        fails(
            &[
                "identify",
                "--method",
                method,
                "--orders",
                orders,
                "--data",
                &id,
                "--inputs",
                "u1",
                "--outputs",
                "y1",
                "--out",
                &out,
            ],
            2,
        )
    };
    assert!(run("arx", "2 x 1").contains("'x' is not a non-negative integer"));
    assert!(run("arx", "2 2").contains("[na nb nk]"));
    assert!(run("n4sid", "2 2 1").contains("only used with the arx and fir methods"));
    assert!(run("fir", "0 1").contains("nb must be at least 1"));
    assert!(run("armax", "2 2 1").contains("[na nb nc nk]"));
    // ARMAX and BJ run from the command line.
    for (method, orders) in [("armax", "2 2 1 1"), ("bj", "2 1 1 2 1")] {
        let text = ok(&[
            "identify",
            "--method",
            method,
            "--orders",
            orders,
            "--data",
            &id,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--out",
            &out,
        ]);
        assert!(text.contains("C(q) = 1 "), "{text}");
    }
}

#[test]
fn arx_with_a_kernel_is_the_regularised_arx() {
    // `--kernel tc` on `--method arx --orders`: the regularised estimate
    // (the polynomials with their posterior deviations, the kernels'
    // hyperparameters in the model file); without a structure it is
    // refused, naming the option.
    let d = tmp("arx_regul_cli");
    let (id, _) = single_rate_data(&d);
    let out = p(&d, "regul.json");
    let base = ["identify", "--method", "arx", "--kernel", "tc"];
    let mut a = base.to_vec();
    a.extend(["--orders", "6 6 1"]);
    a.extend([
        "--data",
        &id,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--out",
        &out,
    ]);
    let text = ok(&a);
    assert_eq!(text.matches("(±").count(), 12, "{text}");
    let f = ModelFile::read(&out).unwrap();
    let r = &f.diagnostics["regularization"];
    assert_eq!(r["kernel"], "Tc", "{r}");
    assert!(r["hyperparameters"][0]["a"]["lambda"].is_f64(), "{r}");
    assert!(r["hyperparameters"][0]["b"]["lambda"].is_f64(), "{r}");
    let scan = p(&d, "scan.json");
    let mut a = base.to_vec();
    a.extend([
        "--data",
        &id,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--out",
        &scan,
    ]);
    let err = fails(&a, 2);
    assert!(err.contains("kernel") && err.contains("structure"), "{err}");
}

#[test]
fn process_models_take_a_first_order_hold() {
    // `--intersample foh` reaches the process route (the model file's
    // diagnostics say so); with another method it is refused by name.
    let d = tmp("process_foh_cli");
    let (id, _) = single_rate_data(&d);
    let out = p(&d, "foh.json");
    let args = [
        "identify",
        "--method",
        "process",
        "--intersample",
        "foh",
        "--data",
        &id,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--out",
        &out,
    ];
    ok(&args);
    let f = ModelFile::read(&out).unwrap();
    assert_eq!(f.diagnostics["process"]["intersample"], "Foh");
    let other = p(&d, "n4sid.json");
    let err = fails(
        &[
            "identify",
            "--method",
            "n4sid",
            "--intersample",
            "foh",
            "--data",
            &id,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--out",
            &other,
        ],
        2,
    );
    assert!(err.contains("intersample"), "{err}");
}

#[test]
fn a_diagonal_a_is_one_miso_model_per_output() {
    // `--a-structure diagonal` on a 2×2 record: each output's equation has
    // its own past only (SIPPY's MIMO ARX), 3 parameters per output at
    // orders "1 1 1" against 4 with the full A; the diagnostics say which;
    // with another method the option is refused by name.
    let d = tmp("arx_diagonal_cli");
    let n = 2000;
    let (u1, u2, e) = (rbs(n, 71), rbs(n, 72), rbs(n, 73));
    let mut csv = String::from("u1,u2,y1,y2\n");
    let (mut y1, mut y2) = (0.0f64, 0.0f64);
    for t in 0..n {
        let (p1, p2) = (y1, y2);
        if t > 0 {
            y1 = 0.7 * p1 + 0.2 * p2 + u1[t - 1] + 0.05 * e[t];
            y2 = 0.5 * p2 + 0.5 * u2[t - 1] + 0.3 * u1[t - 1] - 0.05 * e[t];
        }
        csv += &format!("{},{},{y1},{y2}\n", u1[t], u2[t]);
    }
    let data = p(&d, "mimo.csv");
    std::fs::write(&data, csv).unwrap();
    let args = |method: &'static str, structure: &'static str, out: &str| -> Vec<String> {
        [
            "identify",
            "--method",
            method,
            "--orders",
            "1 1 1",
            "--a-structure",
            structure,
            "--data",
            &data,
            "--ts",
            "1",
            "--inputs",
            "u1,u2",
            "--outputs",
            "y1,y2",
            "--out",
            out,
        ]
        .iter()
        .map(|s| s.to_string())
        .collect()
    };
    let run = |structure: &'static str, name: &str| -> (String, ModelFile) {
        let out = p(&d, name);
        let a = args("arx", structure, &out);
        let text = ok(&a.iter().map(String::as_str).collect::<Vec<_>>());
        (text, ModelFile::read(&out).unwrap())
    };
    let (text, diagonal) = run("diagonal", "diagonal.json");
    assert_eq!(text.matches("(±").count(), 6, "{text}");
    assert_eq!(
        diagonal.diagnostics["a_structure"], "diagonal",
        "{}",
        diagonal.diagnostics
    );
    let orders = diagonal.polynomial.as_ref().unwrap().orders();
    assert_eq!(orders.na, vec![vec![1, 0], vec![0, 1]]);
    let (text, full) = run("full", "full.json");
    assert_eq!(text.matches("(±").count(), 8, "{text}");
    assert_eq!(
        full.polynomial.as_ref().unwrap().orders().na,
        vec![vec![1, 1], vec![1, 1]]
    );
    let a = args("oe", "diagonal", &p(&d, "oe.json"));
    let err = fails(&a.iter().map(String::as_str).collect::<Vec<_>>(), 2);
    assert!(err.contains("--a-structure"), "{err}");
    // OE with one F per output shared by both inputs (`--f-structure
    // common`): the copies of F equal, 3 free parameters per output;
    // ARX refuses the option.
    let swap = |a: Vec<String>, structure: &str| -> Vec<String> {
        let mut a = a;
        let at = a.iter().position(|s| s == "--a-structure").unwrap();
        a[at] = "--f-structure".into();
        a[at + 1] = structure.into();
        a
    };
    let out = p(&d, "oe_common.json");
    let a = swap(args("oe", "diagonal", &out), "common");
    ok(&a.iter().map(String::as_str).collect::<Vec<_>>());
    let common = ModelFile::read(&out).unwrap();
    assert_eq!(common.diagnostics["f_structure"], "common");
    assert_eq!(common.diagnostics["parameters"], 6);
    let m = common.polynomial.as_ref().unwrap();
    assert_eq!(m.f(0, 0), m.f(0, 1));
    let a = swap(args("arx", "diagonal", &p(&d, "arx.json")), "common");
    let err = fails(&a.iter().map(String::as_str).collect::<Vec<_>>(), 2);
    assert!(err.contains("--f-structure"), "{err}");
}

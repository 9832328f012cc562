use super::*;

#[test]
fn validate_report_convert_bode_step() {
    let d = tmp("use");
    let (id, val) = single_rate_data(&d);
    let model = p(&d, "m.json");
    ok(&[
        "identify",
        "--method",
        "n4sid",
        "--data",
        &id,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--order",
        "2",
        "--out",
        &model,
    ]);

    let table = ok(&[
        "validate",
        "--model",
        &model,
        "--data",
        &val,
        "--min-fit",
        "90",
    ]);
    let row = table.lines().find(|l| l.starts_with("y1")).unwrap();
    let fit: f64 = row.split_whitespace().nth(1).unwrap().parse().unwrap();
    assert!(fit > 95.0, "{table}");
    assert!(table.contains("initial state fitted"), "{table}");
    // From rest: the table says so, and the fit is at most the fitted
    // x0's (least squares over x0 includes x0 = 0).
    let rest = ok(&[
        "validate",
        "--model",
        &model,
        "--data",
        &val,
        "--initial-state",
        "zero",
    ]);
    assert!(rest.contains("(simulated from rest)"), "{rest}");
    let row = rest.lines().find(|l| l.starts_with("y1")).unwrap();
    let from_rest: f64 = row.split_whitespace().nth(1).unwrap().parse().unwrap();
    assert!(from_rest <= fit + 0.005, "{rest}");
    // The method defaults to N4SID, as in the workflow and Python.
    let default = p(&d, "default.json");
    ok(&[
        "identify",
        "--data",
        &id,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--order",
        "2",
        "--out",
        &default,
    ]);
    let a: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    let b: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&default).unwrap()).unwrap();
    assert_eq!(
        (&a["method"], &a["a"], &a["b"]),
        (&b["method"], &b["a"], &b["b"])
    );
    let msg = fails(
        &[
            "validate",
            "--model",
            &model,
            "--data",
            &val,
            "--min-fit",
            "99.99",
        ],
        1,
    );
    assert!(msg.contains("fit below"), "{msg}");

    let html_path = p(&d, "report.html");
    ok(&[
        "report", "--model", &model, "--data", &val, "--out", &html_path,
    ]);
    let html = std::fs::read_to_string(&html_path).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>"));
    for tag in ["html", "head", "body", "table", "figure", "svg"] {
        let open = html.matches(&format!("<{tag}")).count();
        let close = html.matches(&format!("</{tag}>")).count();
        assert!(
            open > 0 && open == close,
            "<{tag}>: {open} open, {close} closed"
        );
    }
    for id in [
        "excitation",
        "fit-y1",
        "order-selection",
        "order-criterion",
        "step",
        "bode",
        "pole-zero",
    ] {
        let at = html
            .find(&format!("<figure id=\"{id}\">"))
            .unwrap_or_else(|| panic!("figure {id}"));
        assert!(
            html[at..]
                .trim_start_matches(&format!("<figure id=\"{id}\">"))
                .trim_start()
                .starts_with("<svg"),
            "{id}"
        );
    }
    assert!(html.contains("<td>y1</td>"));
    assert!(!html.contains("<script"), "self-contained, no scripts");

    let tf = ok(&["convert", "--model", &model, "--to", "tf"]);
    assert!(tf.contains('z'), "{tf}");
    let cont = p(&d, "c.json");
    ok(&[
        "convert",
        "--model",
        &model,
        "--to",
        "continuous",
        "--out",
        &cont,
    ]);
    let c = ModelFile::read(&cont).unwrap();
    assert_eq!(c.model.ts(), None);
    let disc = p(&d, "d.json");
    ok(&[
        "convert", "--model", &cont, "--to", "discrete", "--ts", "0.1", "--out", &disc,
    ]);
    let back = ModelFile::read(&disc).unwrap().model;
    let m0 = ModelFile::read(&model).unwrap().model;
    assert!((back.dc_gain().unwrap()[(0, 0)] - m0.dc_gain().unwrap()[(0, 0)]).abs() < 1e-8);
    fails(&["convert", "--model", &cont, "--to", "discrete"], 2);

    ok(&[
        "bode",
        "--model",
        &model,
        "--out",
        &p(&d, "b.csv"),
        "--points",
        "50",
    ]);
    assert_eq!(
        std::fs::read_to_string(p(&d, "b.csv"))
            .unwrap()
            .lines()
            .count(),
        51
    );
    ok(&["bode", "--model", &model, "--out", &p(&d, "b.svg")]);
    assert!(
        std::fs::read_to_string(p(&d, "b.svg"))
            .unwrap()
            .starts_with("<svg")
    );
    ok(&[
        "step",
        "--model",
        &model,
        "--out",
        &p(&d, "s.csv"),
        "--samples",
        "40",
    ]);
    let s = std::fs::read_to_string(p(&d, "s.csv")).unwrap();
    assert_eq!(s.lines().count(), 41);
    ok(&["step", "--model", &model, "--out", &p(&d, "s.svg")]);
    fails(&["step", "--model", &model, "--out", &p(&d, "s.png")], 2);
}

#[test]
fn simulate_command_writes_a_multirate_csv() {
    let d = tmp("simulate");
    let model = p(&d, "plant.json");
    ModelFile::new(plant()).write(&model).unwrap();
    let u = p(&d, "u.csv");
    ok(&["rbs", "--len", "300", "--ts", "0.1", "--out", &u]);
    let data = p(&d, "data.csv");
    ok(&[
        "simulate",
        "--model",
        &model,
        "--input",
        &u,
        "--output-period",
        "y1=3",
        "--snr",
        "100",
        "--out",
        &data,
    ]);
    let text = std::fs::read_to_string(&data).unwrap();
    assert_eq!(text.lines().next(), Some("t,u1,y1"));
    assert_eq!(text.lines().count(), 301);
}

#[test]
fn simulate_command_closes_the_loop() {
    let d = tmp("simulate_closed");
    let model = p(&d, "plant.json");
    ModelFile::new(plant()).write(&model).unwrap();
    // a P controller at T and a slower one at 3T
    let k_fast = p(&d, "k.json");
    let gain = DMatrix::from_element(1, 1, 0.2);
    ModelFile::new(StateSpace::gain(gain.clone(), Some(0.1)).unwrap())
        .write(&k_fast)
        .unwrap();
    let k_slow = p(&d, "k3.json");
    ModelFile::new(StateSpace::gain(gain.clone(), Some(0.3)).unwrap())
        .write(&k_slow)
        .unwrap();
    let r = p(&d, "r.csv");
    ok(&[
        "rbs", "--len", "200", "--hold", "10", "--ts", "0.1", "--name", "sp", "--out", &r,
    ]);
    let data = p(&d, "cl.csv");
    ok(&[
        "simulate",
        "--model",
        &model,
        "--input",
        &r,
        "--controller",
        &k_fast,
        "--references",
        "sp",
        "--out",
        &data,
    ]);
    // the same loop through the library
    let (_, rc) = read_csv(&r);
    let r1 = DMatrix::from_column_slice(200, 1, &rc[1]);
    let sim = Simulator::closed_loop(
        Plant::discrete(&plant(), &[], &[]).unwrap(),
        lifted_sim::Controller::from_ss(&StateSpace::gain(gain, Some(0.1)).unwrap()).unwrap(),
    )
    .unwrap();
    let want = sim.simulate(&Excitation::reference(r1)).unwrap();
    let (head, cols) = read_csv(&data);
    assert_eq!(head, ["t", "u1", "y1"]);
    for (k, (u, y)) in cols[1].iter().zip(&cols[2]).enumerate() {
        assert!((u - want.u()[(k, 0)]).abs() < 1e-12, "u at {k}");
        assert!((y - want.y[(k, 0)]).abs() < 1e-12, "y at {k}");
    }
    // slow controller, y sampled every 3 (offset 0), hold-last, noise:
    // the plant input moves only when the controller runs (k ≡ 0 mod 3)
    let slow = p(&d, "cl3.csv");
    ok(&[
        "simulate",
        "--model",
        &model,
        "--input",
        &r,
        "--controller",
        &k_slow,
        "--references",
        "sp",
        "--output-period",
        "y1=3",
        "--feedback",
        "hold-last",
        "--snr",
        "20",
        "--snr-samples",
        "measured",
        "--seed",
        "4",
        "--out",
        &slow,
    ]);
    let (_, cols) = read_csv(&slow);
    for k in 1..200 {
        if k % 3 != 0 {
            assert_eq!(cols[1][k], cols[1][k - 1], "u moved at {k}");
        }
        assert_eq!(cols[2][k].is_nan(), k % 3 != 0, "y sample pattern at {k}");
    }
    // bad combinations are named errors
    let e = fails(
        &[
            "simulate",
            "--model",
            &model,
            "--input",
            &r,
            "--references",
            "sp",
            "--out",
            &slow,
        ],
        2,
    );
    assert!(e.contains("--controller"), "{e}");
    let e = fails(
        &[
            "simulate",
            "--model",
            &model,
            "--input",
            &r,
            "--controller",
            &k_fast,
            "--out",
            &slow,
        ],
        2,
    );
    assert!(e.contains("--references"), "{e}");
    let e = fails(
        &[
            "simulate",
            "--model",
            &model,
            "--input",
            &r,
            "--noise-model",
            &model,
            "--inputs",
            "sp",
            "--out",
            &slow,
        ],
        2,
    );
    assert!(e.contains("--snr"), "{e}");
    let k_bad = p(&d, "k15.json");
    ModelFile::new(StateSpace::gain(DMatrix::from_element(1, 1, 0.2), Some(0.15)).unwrap())
        .write(&k_bad)
        .unwrap();
    let e = fails(
        &[
            "simulate",
            "--model",
            &model,
            "--input",
            &r,
            "--controller",
            &k_bad,
            "--references",
            "sp",
            "--out",
            &slow,
        ],
        2,
    );
    assert!(e.contains("integer multiple"), "{e}");
}

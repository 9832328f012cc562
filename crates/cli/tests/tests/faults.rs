use super::*;

#[test]
fn refine_iterations_zero_names_the_option() {
    let d = tmp("refine-zero");
    let (id, _) = single_rate_data(&d);
    let e = fails(
        &[
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
            "--refine",
            "pem",
            "--refine-iterations",
            "0",
            "--out",
            &p(&d, "m.json"),
        ],
        2,
    );
    assert!(
        e.contains("--refine-iterations") && !e.contains("PemOptions"),
        "{e}"
    );
}

/// Issue 47: the Kalman-gain check's stopping share is an option: a
/// bad value is refused naming the flag, a given one is recorded in the
/// model's diagnostics with the tolerance it gave.
#[test]
fn gain_stop_share_is_checked_and_recorded() {
    let d = tmp("gain-stop");
    let (id, _) = single_rate_data(&d);
    let out = p(&d, "m.json");
    let args = |share: &'static str| -> Vec<String> {
        [
            "identify",
            "--data",
            &id,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--order",
            "2",
            "--refine",
            "none",
            "--out",
            &out,
        ]
        .iter()
        .map(|s| s.to_string())
        .chain([format!("--gain-stop-share={share}")])
        .collect()
    };
    for bad in ["-1", "nan", "inf"] {
        let a = args(bad);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let e = fails(&a, 2);
        assert!(e.contains("--gain-stop-share"), "{e}");
    }
    let a = args("0.5");
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    let o = lifted(&a);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let stop = m["diagnostics"]["kalman_gain_route"]["stop"]
        .as_str()
        .unwrap_or_default()
        .to_string();
    assert!(stop.contains("0.5 of its sampling spread"), "{stop}");
}

/// Issue 48: the automatic order's selection rules are flags: bad
/// values refused naming the flag, given ones recorded in
/// `diagnostics.selection_policy`.
#[test]
fn selection_policy_flags_are_checked_and_recorded() {
    let d = tmp("selection-policy");
    let (id, _) = single_rate_data(&d);
    let out = p(&d, "m.json");
    let args = |extra: &[&str]| -> Vec<String> {
        [
            "identify",
            "--data",
            &id,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--refine",
            "none",
            "--out",
            &out,
        ]
        .iter()
        .chain(extra)
        .map(|s| s.to_string())
        .collect()
    };
    for (bad, flag) in [
        (["--stable-tries", "0"], "--stable-tries"),
        (["--shortlist", "0"], "--shortlist"),
        (["--shortlist-span", "nan"], "--shortlist-span"),
        (["--selection-tolerance", "-1"], "--selection-tolerance"),
        (["--failed-fold", "5"], "--failed-fold"),
    ] {
        let a = args(&bad);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let e = fails(&a, 2);
        assert!(e.contains(flag), "{e}");
    }
    let a = args(&["--failed-fold", "-30", "--stable-tries", "2"]);
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    let o = lifted(&a);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let policy = &m["diagnostics"]["selection_policy"];
    assert_eq!(policy["failed_fold"], -30.0);
    assert_eq!(policy["stable_tries"], 2);
    assert_eq!(policy["shortlist"], 3);
}

/// Issue 48: the default route's work budgets are `--budget NAME=VALUE`:
/// an unknown name, a malformed pair or a bad value refused naming the
/// budget (one line, exit 2); given ones recorded in
/// `diagnostics.budgets` and deciding the refinement.
#[test]
fn budget_flags_are_checked_and_recorded() {
    let d = tmp("budgets");
    let (id, _) = single_rate_data(&d);
    let out = p(&d, "m.json");
    let args = |extra: &[&str]| -> Vec<String> {
        [
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
            &out,
        ]
        .iter()
        .chain(extra)
        .map(|s| s.to_string())
        .collect()
    };
    for (bad, said) in [
        (["--budget", "auto_refine_wrok=1"], "auto_refine_work"),
        (["--budget", "auto_refine_work"], "NAME=VALUE"),
        (["--budget", "auto_refine_work=lots"], "not a number"),
        (
            ["--budget", "auto_refine_work=-1"],
            "--budget auto_refine_work",
        ),
        (["--budget", "gain_check_samples=2.5"], "gain_check_samples"),
    ] {
        let a = args(&bad);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let e = fails(&a, 2);
        assert!(e.contains(said), "{e}");
    }
    let a = args(&[
        "--budget",
        "auto_refine_samples=10",
        "--budget",
        "auto_refine_work=1",
    ]);
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    ok(&a);
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let b = &m["diagnostics"]["budgets"];
    assert_eq!(b["auto_refine_samples"], 10);
    assert_eq!(b["auto_refine_work"], 1.0);
    assert_eq!(b["gain_check_samples"], 200_000);
    let why = m["diagnostics"]["refinement_decision"]
        .as_str()
        .unwrap_or_default();
    assert!(why.starts_with("not refined"), "{why}");
}

/// Issue 48: `--plan` takes the options from a model file (its
/// `diagnostics.options`) or from `--write-plan`'s file, and the same
/// records give the same model bit for bit — single-rate with options
/// away from the defaults, and a multirate record at the automatic
/// order; option flags beside a plan, unknown fields and a model file
/// without options are refused naming them.
#[test]
fn a_plan_reproduces_its_model() {
    let d = tmp("plan");
    let (id, _) = single_rate_data(&d);
    let mr = p(&d, "mr.csv");
    simulate(&mr, rbs(3000, 5), 3, 1000.0, 4);
    let strip = |path: &str| -> serde_json::Value {
        let mut m: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        m.as_object_mut().unwrap().remove("diagnostics");
        m
    };
    for (data, extra) in [
        (
            &id,
            &[
                "--order",
                "3",
                "--horizon",
                "8",
                "--refine",
                "pem",
                "--budget",
                "gain_check_minimise_work=1e9",
                "--max-order",
                "6",
            ][..],
        ),
        (&mr, &["--output-period", "y1=3", "--max-order", "4"][..]),
    ] {
        let (first, again, from_plan, plan) = (
            p(&d, "first.json"),
            p(&d, "again.json"),
            p(&d, "from_plan.json"),
            p(&d, "plan.json"),
        );
        let base = [
            "identify",
            "--data",
            data.as_str(),
            "--inputs",
            "u1",
            "--outputs",
            "y1",
        ];
        let with = |tail: &[&str]| -> Vec<String> {
            base.iter().chain(tail).map(|s| s.to_string()).collect()
        };
        let run = |args: Vec<String>| {
            let a: Vec<&str> = args.iter().map(String::as_str).collect();
            ok(&a);
        };
        let mut tail: Vec<&str> = extra.to_vec();
        tail.extend(["--write-plan", &plan, "--out", &first]);
        run(with(&tail));
        // The data flags stay; the options come from the plan.
        let keep: Vec<&str> = if data == &mr {
            vec!["--output-period", "y1=3"]
        } else {
            vec![]
        };
        let mut t = keep.clone();
        t.extend(["--plan", &first, "--out", &again]);
        run(with(&t));
        let mut t = keep.clone();
        t.extend(["--plan", &plan, "--out", &from_plan]);
        run(with(&t));
        assert_eq!(
            strip(&first),
            strip(&again),
            "{data}: the model file's plan"
        );
        assert_eq!(
            strip(&first),
            strip(&from_plan),
            "{data}: --write-plan's file"
        );
    }
    // Refusals, one line each.
    let first = p(&d, "first.json");
    let out = p(&d, "x.json");
    let args = |tail: &[&str]| -> Vec<String> {
        [
            "identify",
            "--data",
            &mr,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
        ]
        .iter()
        .chain(tail)
        .map(|s| s.to_string())
        .collect()
    };
    let refused = |tail: &[&str]| -> String {
        let a = args(tail);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        fails(&a, 2)
    };
    let e = refused(&["--plan", &first, "--order", "2", "--out", &out]);
    assert!(e.contains("identification.order"), "{e}");
    let bad = p(&d, "bad.json");
    std::fs::write(&bad, r#"{"identification": {"ordr": 3}}"#).unwrap();
    let e = refused(&["--plan", &bad, "--out", &out]);
    assert!(e.contains("unknown option identification.ordr"), "{e}");
    let old = p(&d, "old.json");
    let mut m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&first).unwrap()).unwrap();
    m["diagnostics"].as_object_mut().unwrap().remove("options");
    std::fs::write(&old, m.to_string()).unwrap();
    let e = refused(&["--plan", &old, "--out", &out]);
    assert!(e.contains("records no options"), "{e}");
    let e = refused(&["--plan", &p(&d, "none.json"), "--out", &out]);
    assert!(e.contains("none.json"), "{e}");
}

/// A 2-output model y = (x, 2x), x(k+1) = 0.9x + 0.1u, T = 1 s.
fn two_outputs() -> StateSpace {
    StateSpace::new(
        DMatrix::from_element(1, 1, 0.9),
        DMatrix::from_element(1, 1, 0.1),
        DMatrix::from_row_slice(2, 1, &[1.0, 2.0]),
        DMatrix::zeros(2, 1),
        Some(1.0),
    )
    .unwrap()
}

#[test]
fn mpc_names_plant_and_model_dimensions() {
    let d = tmp("mpc-dims");
    let m = p(&d, "m.json");
    ModelFile::new(two_outputs()).write(&m).unwrap();
    let plant = p(&d, "plant.json");
    let one = StateSpace::new(
        DMatrix::from_element(1, 1, 0.9),
        DMatrix::from_element(1, 1, 0.1),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap();
    ModelFile::new(one).write(&plant).unwrap();
    let e = fails(
        &[
            "mpc",
            "--model",
            &m,
            "--plant",
            &plant,
            "--setpoint",
            "y1=1",
            "--out",
            &p(&d, "o.csv"),
        ],
        2,
    );
    assert!(
        e.contains("1 output and 1 input") && e.contains("2 outputs and 1 input"),
        "{e}"
    );
    assert!(!e.contains("controller"), "{e}");
}

#[test]
fn mpc_applies_the_operating_point() {
    let d = tmp("mpc-op");
    let plain = p(&d, "plain.json");
    let lag = StateSpace::new(
        DMatrix::from_element(1, 1, 0.9),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 0.1),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap();
    ModelFile::new(lag.clone()).write(&plain).unwrap();
    let shifted = p(&d, "op.json");
    ModelFile::new(lag)
        .with_operating_point(lifted_lti::OperatingPoint::new(vec![1.0], vec![5.0]).unwrap())
        .unwrap()
        .write(&shifted)
        .unwrap();
    let (a, b) = (p(&d, "a.csv"), p(&d, "b.csv"));
    // deviations: a step of +1 from y0 = 5 is the step to 1 without one
    ok(&[
        "mpc",
        "--model",
        &plain,
        "--setpoint",
        "y1=1",
        "--steps",
        "60",
        "--out",
        &a,
    ]);
    ok(&[
        "mpc",
        "--model",
        &shifted,
        "--setpoint",
        "y1=6",
        "--steps",
        "60",
        "--out",
        &b,
    ]);
    let (ha, ca) = read_csv(&a);
    let (hb, cb) = read_csv(&b);
    assert_eq!(ha, hb);
    let col = |h: &[String], n: &str| h.iter().position(|x| x == n).unwrap();
    for (name, offset) in [("y1", 5.0), ("r_y1", 5.0), ("u1", 1.0)] {
        let (ia, ib) = (col(&ha, name), col(&hb, name));
        for (x, y) in ca[ia].iter().zip(&cb[ib]) {
            // the same loop in deviations; only the offset's rounding differs
            assert!((y - x - offset).abs() < 1e-9, "{name}: {x} vs {y}");
        }
    }
    // plant values: the run starts at the operating point, settles at 6
    let y = &cb[col(&hb, "y1")];
    assert!(
        (y[0] - 5.0).abs() < 1e-12 && (y[59] - 6.0).abs() < 1e-3,
        "{y:?}"
    );
    // limits are plant values too: u ≤ 1.5 binds (u0 = 1, the steady
    // deviation needed is 1)
    let c = p(&d, "c.csv");
    ok(&[
        "mpc",
        "--model",
        &shifted,
        "--setpoint",
        "y1=6",
        "--steps",
        "60",
        "--u-max",
        "1.5",
        "--out",
        &c,
    ]);
    let (hc, cc) = read_csv(&c);
    let u = &cc[col(&hc, "u1")];
    assert!(u.iter().all(|v| *v <= 1.5 + 1e-6), "{u:?}");
    assert!((u[59] - 1.5).abs() < 1e-6, "{u:?}");
}

#[test]
fn convert_keeps_the_operating_point_and_prints_pole_and_gain() {
    let d = tmp("convert-op");
    // the README's plant 2/(10 s + 1) at T = 1 s, identified with offsets
    let cont = StateSpace::new(
        DMatrix::from_element(1, 1, -0.1),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 0.2),
        DMatrix::zeros(1, 1),
        None,
    )
    .unwrap();
    let disc = cont.c2d(1.0, &lifted_lti::C2dOptions::default()).unwrap();
    let m = p(&d, "m.json");
    ModelFile::new(disc)
        .with_method("n4sid")
        .with_diagnostics(serde_json::json!({"horizons": [10], "samples": 500}))
        .with_operating_point(lifted_lti::OperatingPoint::new(vec![0.5], vec![3.0]).unwrap())
        .unwrap()
        .with_kalman_gain(&DMatrix::from_element(1, 1, 0.3))
        .unwrap()
        .write(&m)
        .unwrap();
    let out = p(&d, "c.json");
    let s = ok(&[
        "convert",
        "--model",
        &m,
        "--to",
        "continuous",
        "--out",
        &out,
    ]);
    assert!(s.contains("poles: -0.100000"), "{s}");
    assert!(s.contains("DC gain: y1/u1 2.000000"), "{s}");
    assert!(
        s.contains("operating point: u0 = [0.500000], y0 = [3.000000]"),
        "{s}"
    );
    assert!(!s.trim_start().starts_with('{'), "{s}");
    let c = ModelFile::read(&out).unwrap();
    assert_eq!(c.model.ts(), None);
    let op = c.operating_point.unwrap();
    assert_eq!((op.u0, op.y0), (vec![0.5], vec![3.0]));
    assert!(
        c.kalman_gain.is_none(),
        "the Kalman gain is discrete-time only"
    );
    assert!(c.diagnostics.get("horizons").is_none(), "{}", c.diagnostics);
    assert_eq!(c.diagnostics["converted_from"]["ts"], 1.0);
    assert_eq!(c.method.as_deref(), Some("n4sid"));
    // --json prints the model file
    let j = ok(&["convert", "--model", &m, "--to", "continuous", "--json"]);
    assert!(ModelFile::from_json(&j).is_ok(), "{j}");
}

#[test]
fn memory_limit_overrides_the_environment() {
    let d = tmp("memory-limit");
    let (id, _) = single_rate_data(&d);
    let out = p(&d, "m.json");
    let args = [
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
        "--horizon",
        "10",
        "--out",
        &out,
    ];
    let run = |env: Option<&str>, extra: &[&str]| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_lifted"));
        c.args(args).args(extra);
        if let Some(v) = env {
            c.env("LIFTED_MEMORY_LIMIT", v);
        }
        c.output().unwrap()
    };
    let tiny = run(None, &["--memory-limit", "2K"]);
    let e = String::from_utf8_lossy(&tiny.stderr);
    assert_eq!(tiny.status.code(), Some(2), "{e}");
    assert!(e.contains("needs") && e.contains("2048 bytes"), "{e}");
    // the flag wins over a tiny environment budget
    let ok_run = run(Some("1000"), &["--memory-limit", "1G"]);
    assert!(
        ok_run.status.success(),
        "{}",
        String::from_utf8_lossy(&ok_run.stderr)
    );
    assert_eq!(run(Some("1000"), &[]).status.code(), Some(2));
    let bad = fails(&[&args[..], &["--memory-limit", "4X"]].concat(), 2);
    assert!(
        bad.contains("--memory-limit") && bad.contains("unit"),
        "{bad}"
    );
}

#[test]
fn memory_limit_units() {
    use lifted_cli::args::parse_memory_limit;
    assert_eq!(parse_memory_limit("4G"), Ok(4 << 30));
    assert_eq!(parse_memory_limit("512M"), Ok(512 << 20));
    assert_eq!(parse_memory_limit("1.5GiB"), Ok(3 << 29));
    assert_eq!(parse_memory_limit("2GB"), Ok(2_000_000_000));
    assert_eq!(parse_memory_limit("1000"), Ok(1000));
    assert!(parse_memory_limit("0").is_err());
    assert!(parse_memory_limit("-1G").is_err());
    assert!(parse_memory_limit("1e30").is_err());
    assert!(parse_memory_limit("99999999999T").is_err());
}

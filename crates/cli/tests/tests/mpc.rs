use super::*;
use lifted_mpc::{Controller, Dmc, LoopSetup, MpcOptions, StateSpaceMpc, simulate};

/// y(k) = 0.9 y(k−1) + 0.1 u(k−1), T = 1 s.
fn lag() -> StateSpace {
    StateSpace::new(
        DMatrix::from_element(1, 1, 0.9),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 0.1),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap()
}

fn column(path: &str, name: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let j = header.iter().position(|h| *h == name).unwrap();
    lines
        .map(|l| {
            let cell = l.split(',').nth(j).unwrap();
            if cell.is_empty() {
                f64::NAN
            } else {
                cell.parse().unwrap()
            }
        })
        .collect()
}

/// The CLI's loop equals lifted-mpc's own simulation sample by sample,
/// for both laws, fast and dual-rate (inferential) sampling.
#[test]
fn design_and_simulate_match_the_library() {
    let d = tmp("mpc");
    let model = p(&d, "lag.json");
    ModelFile::new(lag()).write(&model).unwrap();
    for (law, period) in [("gpc", 1), ("dmc", 1), ("gpc", 4), ("dmc", 4)] {
        let out = p(&d, &format!("{law}{period}.csv"));
        let svg = p(&d, &format!("{law}{period}.svg"));
        let text = ok(&[
            "mpc",
            "--model",
            &model,
            "--law",
            law,
            "--setpoint",
            "y1=1",
            "--step-at",
            "5",
            "--steps",
            "80",
            "--output-period",
            &format!("y1={period}"),
            "--out",
            &out,
            "--plot",
            &svg,
            "--json",
        ]);
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let opts = MpcOptions::default();
        let mut c: Box<dyn Controller> = if law == "gpc" {
            Box::new(StateSpaceMpc::new(&lag(), &opts).unwrap())
        } else {
            Box::new(Dmc::new(&lag(), 48, &opts).unwrap())
        };
        let mut r = DMatrix::zeros(80, 1);
        r.view_mut((5, 0), (75, 1)).fill(1.0);
        let want = simulate(&lag(), c.as_mut(), &LoopSetup::new(r, vec![period])).unwrap();
        let (y, u) = (column(&out, "y1"), column(&out, "u1"));
        for t in 0..80 {
            assert!(
                (y[t] - want.y[(t, 0)]).abs() < 1e-12,
                "{law}/{period} y at {t}"
            );
            assert!(
                (u[t] - want.u[(t, 0)]).abs() < 1e-12,
                "{law}/{period} u at {t}"
            );
        }
        assert!(
            (y[79] - 1.0).abs() < 1e-4,
            "{law}/{period}: offset {}",
            y[79] - 1.0
        );
        let iae = v["outputs"][0]["iae"].as_f64().unwrap();
        assert!((iae - want.performance.iae[0]).abs() < 1e-9);
        // measured column: the slow samples only
        let measured = column(&out, "y1_measured");
        assert_eq!(
            measured.iter().filter(|x| x.is_nan()).count(),
            80 - 80usize.div_ceil(period)
        );
        assert!(std::fs::read_to_string(&svg).unwrap().starts_with("<svg"));
    }
}

/// Limits bind (u ≤ 2 where the unconstrained law wants more), the slow
/// single-rate MPC holds its input n samples, and the table prints.
#[test]
fn limits_slow_rate_and_table() {
    let d = tmp("mpc-limits");
    let model = p(&d, "lag.json");
    ModelFile::new(lag()).write(&model).unwrap();
    let out = p(&d, "lim.csv");
    let table = ok(&[
        "mpc",
        "--model",
        &model,
        "--setpoint",
        "y1=5",
        "--u-max",
        "6",
        "--move-weight",
        "0.01",
        "--steps",
        "60",
        "--out",
        &out,
    ]);
    assert!(table.contains("IAE") && table.contains("y1"), "{table}");
    let u = column(&out, "u1");
    assert!(u.iter().all(|&x| x <= 6.0 + 1e-7), "{u:?}");
    assert!(u.iter().any(|&x| x > 6.0 - 1e-6), "the limit never bound");
    let slow = p(&d, "slow.csv");
    ok(&[
        "mpc",
        "--model",
        &model,
        "--setpoint",
        "y1=1",
        "--slow",
        "4",
        "--steps",
        "80",
        "--out",
        &slow,
    ]);
    let u = column(&slow, "u1");
    for k in 0..80 {
        assert_eq!(u[k], u[k - k % 4], "held input at {k}");
    }
    assert!((column(&slow, "y1")[79] - 1.0).abs() < 1e-3);
}

#[test]
fn bad_input() {
    let d = tmp("mpc-bad");
    let model = p(&d, "lag.json");
    ModelFile::new(lag()).write(&model).unwrap();
    let cont = p(&d, "cont.json");
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
    .write(&cont)
    .unwrap();
    let out = p(&d, "o.csv");
    let run = |extra: &[&str]| {
        let mut args = vec!["mpc", "--out", &out];
        args.extend_from_slice(extra);
        fails(&args, 2)
    };
    let m = model.as_str();
    let e = run(&["--model", &cont]);
    assert!(e.contains("continuous"), "{e}");
    let e = run(&["--model", m, "--output-weight", "1,2"]);
    assert!(
        e.contains("--output-weight") && e.contains("2 values"),
        "{e}"
    );
    let e = run(&["--model", m, "--setpoint", "y9=1"]);
    assert!(e.contains("no output 'y9'"), "{e}");
    let e = run(&["--model", m, "--control-horizon", "20"]);
    assert!(e.contains("design"), "{e}");
    let e = run(&["--model", m, "--move-weight", "-1"]);
    assert!(e.contains("non-negative"), "{e}");
    let e = run(&["--model", m, "--slow", "2", "--output-period", "y1=2"]);
    assert!(e.contains("--slow"), "{e}");
    let e = run(&["--model", m, "--step-at", "200"]);
    assert!(e.contains("--step-at"), "{e}");
    let e = run(&["--model", &p(&d, "none.json")]);
    assert!(e.contains("none.json"), "{e}");
}

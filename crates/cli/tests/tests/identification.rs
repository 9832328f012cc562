use super::*;

#[test]
fn profile_prints_the_phases() {
    let d = tmp("profile");
    let (id, _) = single_rate_data(&d);
    let out = p(&d, "n4sid.json");
    let s = ok(&[
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
        "8",
        "--out",
        &out,
        "--profile",
    ]);
    for phase in [
        "read",
        "compress",
        "svd",
        "estimate",
        "identify (total)",
        "compression:",
        // The stages after the subspace step (a short record: its gain
        // checked, the default refinement run).
        "Kalman gain",
        "refinement",
    ] {
        assert!(s.contains(phase), "missing {phase}: {s}");
    }
    // The same timings are kept in the model file's diagnostics.
    let f = ModelFile::read(&out).expect("model file");
    let prof = &f.diagnostics["profile"];
    for key in [
        "read_s",
        "compress_s",
        "svd_s",
        "estimate_s",
        "kalman_gain_s",
        "refine_s",
        "identify_s",
    ] {
        assert!(
            prof[key].as_f64().is_some_and(|t| t >= 0.0),
            "{key}: {prof}"
        );
    }
    // The stages after the first pass are within the identification's
    // time (the whole run after reading), not outside it.
    let stages: f64 = ["second_pass_s", "kalman_gain_s", "refine_s"]
        .iter()
        .filter_map(|k| prof[*k].as_f64())
        .sum();
    let total = prof["identify_s"].as_f64().unwrap_or(0.0);
    assert!(stages <= total, "{prof}");
}

/// Where the default's time goes: an automatic order's structure
/// selection has its own row (within the subspace row), and a multirate
/// record's lifted route (lifting, its order selection, extraction) its
/// own — with the multirate check's, the rows account for the run.
#[test]
fn profile_names_the_selection_and_the_multirate_route() {
    let d = tmp("profile-selection");
    // The default run of a file with --profile: its printout and the
    // model file's profile.
    let profiled = |data: &str, name: &str| {
        let out = p(&d, name);
        let s = ok(&[
            "identify",
            "--data",
            data,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--out",
            &out,
            "--profile",
        ]);
        let f = ModelFile::read(&out).expect("model file");
        (s, f.diagnostics["profile"].clone())
    };
    let (id, _) = single_rate_data(&d);
    let (s, prof) = profiled(&id, "auto.json");
    assert!(s.contains("structure selection"), "{s}");
    let (sel, sub) = (prof["selection_s"].as_f64(), prof["subspace_s"].as_f64());
    assert!(
        sel.zip(sub).is_some_and(|(a, b)| 0.0 <= a && a <= b),
        "{prof}"
    );
    let mr = p(&d, "mr.csv");
    simulate(&mr, rbs(1500, 3), 3, 1000.0, 5);
    let (s, prof) = profiled(&mr, "mr.json");
    assert!(s.contains("multirate route"), "{s}");
    let parts: f64 = [
        "multirate_s",
        "multirate_start_s",
        "multirate_check_s",
        "refine_s",
    ]
    .iter()
    .filter_map(|k| prof[*k].as_f64())
    .sum();
    let total = prof["identify_s"].as_f64().unwrap_or(0.0);
    assert!(
        prof["multirate_s"].as_f64().is_some() && parts <= total && parts >= 0.5 * total,
        "{prof}"
    );
}

#[test]
fn subspace_methods_and_iv_identify_the_plant() {
    let d = tmp("subspace");
    let (id, _) = single_rate_data(&d);
    for method in ["n4sid", "moesp", "cva", "iv"] {
        let out = p(&d, &format!("{method}.json"));
        ok(&[
            "identify",
            "--method",
            method,
            "--data",
            &id,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--order",
            "2",
            "--horizon",
            "8",
            "--out",
            &out,
        ]);
        let f = check_model(&out, 0.02);
        assert_eq!(f.method.as_deref(), Some(method));
        assert!((f.model.ts().unwrap() - 0.1).abs() < 1e-12);
        assert!(
            f.diagnostics["order_selection"]["values"]
                .as_array()
                .is_some_and(|v| v.len() >= 2)
        );
    }
    // automatic order: the gap rule finds 2 on nearly noise-free data
    let out = p(&d, "auto.json");
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
        "--out",
        &out,
    ]);
    check_model(&out, 0.02);
    // the other rules pick the order too (AIC-type rules load the file
    // in memory, SVC streams), and report their value per order
    for (method, rule, name) in [
        ("n4sid", "svc", "Svc"),
        ("cva", "bic", "Bic"),
        ("moesp", "aic", "Aic"),
        ("iv", "aicc", "Aicc"),
    ] {
        let out = p(&d, &format!("auto_{rule}.json"));
        ok(&[
            "identify",
            "--method",
            method,
            "--data",
            &id,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--max-order",
            "6",
            "--order-criterion",
            rule,
            "--out",
            &out,
        ]);
        let f = check_model(&out, 0.02);
        let c = &f.diagnostics["order_criterion"];
        assert_eq!(c["criterion"], name, "{rule}: {c}");
        assert_eq!(c["selected"], 2, "{rule}: {c}");
        assert!(c["values"].as_array().is_some_and(|v| v.len() >= 2), "{c}");
    }
    // q-Markov has only the gap rule
    let e = fails(
        &[
            "identify",
            "--method",
            "qmarkov",
            "--data",
            &id,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--order-criterion",
            "aic",
            "--out",
            &p(&d, "q.json"),
        ],
        2,
    );
    assert!(e.contains("--order-criterion"), "{e}");
}

#[test]
fn iv_with_an_instrument_column() {
    let d = tmp("iv");
    let (id, _) = single_rate_data(&d);
    // open loop: the excitation itself is the instrument, in a column f1
    let text = std::fs::read_to_string(&id).unwrap();
    let mut out = String::new();
    for (k, line) in text.lines().enumerate() {
        let u = line.split(',').nth(1).unwrap();
        out += &format!("{line},{}\n", if k == 0 { "f1" } else { u });
    }
    let data = p(&d, "with_f.csv");
    std::fs::write(&data, out).unwrap();
    let model = p(&d, "iv.json");
    ok(&[
        "identify",
        "--method",
        "iv",
        "--data",
        &data,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--instrument",
        "f1",
        "--order",
        "2",
        "--out",
        &model,
    ]);
    let f = check_model(&model, 0.02);
    assert_eq!(f.diagnostics["instrument"][0], "f1");
    let e = fails(
        &[
            "identify",
            "--method",
            "n4sid",
            "--data",
            &data,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--instrument",
            "f1",
            "--out",
            &model,
        ],
        2,
    );
    assert!(e.contains("--instrument"), "{e}");
}

#[test]
fn qmarkov_from_inverse_prbs() {
    let d = tmp("qmarkov");
    let prbs = InversePrbs::new(&InversePrbsOptions {
        order: 6,
        amplitude: 1.0,
        hold: 1,
        taps: None,
    })
    .unwrap();
    let u = prbs.generate(5 * prbs.period() as usize);
    let data = p(&d, "prbs.csv");
    simulate(&data, u, 1, 1e4, 3);
    let out = p(&d, "qm.json");
    ok(&[
        "identify",
        "--method",
        "qmarkov",
        "--data",
        &data,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--prbs-order",
        "6",
        "--q",
        "20",
        "--order",
        "2",
        "--out",
        &out,
    ]);
    check_model(&out, 0.03);
}

#[test]
fn multirate_output_gives_the_fast_model() {
    let d = tmp("multirate");
    let data = p(&d, "mr.csv");
    simulate(&data, rbs(3000, 5), 3, 1000.0, 4);
    let text = std::fs::read_to_string(&data).unwrap();
    assert!(
        text.lines().nth(2).unwrap().ends_with(','),
        "slow output cells are empty"
    );
    let out = p(&d, "mr.json");
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
        "--output-period",
        "y1=3",
        "--order",
        "2",
        "--horizon",
        "5",
        "--out",
        &out,
    ]);
    let f = check_model(&out, 0.03);
    assert!(
        (f.model.ts().unwrap() - 0.1).abs() < 1e-12,
        "fast model at the base period"
    );
    assert_eq!(f.diagnostics["output_periods"][0], 3);

    // A logger that stops between slow samples: 3002 rows, the output
    // every 3 (its last sample at row 3000). The record is read as it is
    // (it used to be refused: "period 3 does not divide 3002 rows"), the
    // lifting drops the incomplete last frame, validation uses every row.
    let data = p(&d, "mr_odd.csv");
    simulate(&data, rbs(3002, 5), 3, 1000.0, 4);
    let out = p(&d, "mr_odd.json");
    ok(&[
        "identify",
        "--data",
        &data,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--order",
        "2",
        "--out",
        &out,
    ]);
    let f = check_model(&out, 0.03);
    assert_eq!(f.diagnostics["output_periods"][0], 3);
    let v = ok(&["validate", "--model", &out, "--data", &data]);
    assert!(v.contains("1001"), "1001 slow samples validated: {v}");
}

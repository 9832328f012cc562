use super::*;

#[test]
fn the_quick_start_model_feeds_mpc() {
    let d = tmp("quick-start");
    let plant = p(&d, "plant.json");
    std::fs::write(
        &plant,
        r#"{"kind": "state_space", "ts": null,
 "a": [[-0.1]], "b": [[1.0]], "c": [[0.2]], "d": [[0.0]],
 "input_names": ["u1"], "output_names": ["y1"]}"#,
    )
    .unwrap();
    let (u, data, model) = (p(&d, "u.csv"), p(&d, "data.csv"), p(&d, "model.json"));
    ok(&[
        "prbs",
        "--inverse",
        "--order",
        "7",
        "--amplitude",
        "1",
        "--ts",
        "1",
        "--periods",
        "4",
        "--out",
        &u,
    ]);
    ok(&[
        "simulate",
        "--model",
        &plant,
        "--input",
        &u,
        "--output-period",
        "y1=2",
        "--snr",
        "100",
        "--seed",
        "1",
        "--out",
        &data,
    ]);
    let identify = |extra: &[&str]| {
        let mut args = vec![
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
            "--out",
            &model,
        ];
        args.extend_from_slice(extra);
        ok(&args);
        ModelFile::read(&model).unwrap()
    };
    let f = identify(&[]);
    assert!(f.model.d().iter().all(|&v| v == 0.0), "{}", f.model.d());
    let run = p(&d, "run.csv");
    ok(&[
        "mpc",
        "--model",
        &model,
        "--setpoint",
        "y1=1",
        "--steps",
        "40",
        "--out",
        &run,
    ]);
    // D = 0 asked for on the multirate record: accepted, the same model.
    let zero = identify(&["--feedthrough", "false"]);
    assert_eq!(zero.model, f.model);
    // A feedthrough asked for is estimated.
    let free = identify(&["--feedthrough"]);
    assert!(
        free.diagnostics["feedthrough"]
            .as_str()
            .is_some_and(|s| s.starts_with("D estimated"))
    );
}

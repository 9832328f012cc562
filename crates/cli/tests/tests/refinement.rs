use super::*;

/// `--refine pem|oe` on a single-rate and a multirate record: the report
/// is in the diagnostics, the refined model keeps the plant's poles, and
/// every model stores a Kalman gain.
#[test]
fn refine_pem_and_oe() {
    let dir = tmp("refine");
    let single = p(&dir, "single.csv");
    let slow = p(&dir, "slow.csv");
    simulate(&single, rbs(3000, 21), 1, 20.0, 22);
    simulate(&slow, rbs(3999, 23), 3, 20.0, 24);
    for (data, how, order) in [
        (&single, "pem", "2"),
        (&slow, "oe", "2"),
        (&slow, "pem", "2"),
    ] {
        let out = p(&dir, "m.json");
        ok(&[
            "identify",
            "--method",
            "n4sid",
            "--data",
            data,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--order",
            order,
            "--refine",
            how,
            "--out",
            &out,
        ]);
        let f = check_model(&out, 0.05);
        let r = &f.diagnostics["refinement"];
        assert!(r["iterations"].as_u64().unwrap() >= 1, "{r}");
        assert!(r["kept"] == "Refined" || r["kept"] == "Initial", "{r}");
        // Every model stores a Kalman gain: the prediction-error
        // refinement's, or (the multirate output-error model, whose
        // lifted route estimates none) the one checked on the measured
        // samples.
        assert!(f.kalman_gain.is_some(), "{how}");
        assert_eq!(
            f.diagnostics.get("kalman_gain_route").is_some(),
            how == "oe" || data == &single,
            "{how}"
        );
    }
    // Bad option values are one-line usage errors.
    let msg = fails(
        &[
            "identify",
            "--method",
            "n4sid",
            "--data",
            &single,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--refine",
            "newton",
            "--out",
            &p(&dir, "x.json"),
        ],
        2,
    );
    assert!(msg.contains("newton"), "{msg}");
}

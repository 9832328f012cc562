//! A state-space model's uncertainty (issue 49): `lifted identify` writes
//! the covariance of its entries into the model file, `lifted analyze`
//! prints the entries ± σ, `bode`, `step` and `report` draw its bands;
//! `--no-covariance` leaves it out and says so.

use super::*;

#[test]
fn a_subspace_model_carries_its_covariance_and_its_bands() {
    let d = tmp("ss_covariance");
    let (id, val) = single_rate_data(&d);
    let out = p(&d, "ss.json");
    let args = [
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
        &out,
    ];
    ok(&args);
    let f = ModelFile::read(&out).unwrap();
    let cov = f.covariance.as_ref().expect("the model's covariance");
    // (A, B, C, D) of order 2, one input, one output: 4 + 2 + 2 + 1.
    assert_eq!(cov.matrix().nrows(), 9);
    let c = &f.diagnostics["covariance"];
    assert_eq!(c["computed"], true, "{c}");
    assert!(c["parameters"].as_u64().unwrap() >= 4, "{c}");
    // The Bode band: narrow at SNR 1000 and 2000 samples, around the curve.
    let text = ok(&["bode", "--model", &out, "--omega", "0.1,1,3", "--json"]);
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let pair = &v["pairs"][0];
    for k in 0..3 {
        let mid = pair["magnitude_db"][k].as_f64().unwrap();
        let lo = pair["magnitude_db_lower"][k].as_f64().unwrap();
        let hi = pair["magnitude_db_upper"][k].as_f64().unwrap();
        assert!(lo < mid && mid < hi && hi - lo < 1.0, "{lo} {mid} {hi}");
    }
    // The step band.
    let csv = p(&d, "step.csv");
    ok(&["step", "--model", &out, "--out", &csv]);
    let (header, cols) = read_csv(&csv);
    assert_eq!(
        &header[1..4],
        ["y1_from_u1", "y1_from_u1_lo", "y1_from_u1_hi"]
    );
    let k = cols[1].len() - 1;
    assert!(
        cols[2][k] < cols[1][k] && cols[1][k] < cols[3][k],
        "{header:?}"
    );
    // The report's figures carry the bands.
    let html = p(&d, "r.html");
    ok(&["report", "--model", &out, "--data", &val, "--out", &html]);
    let page = std::fs::read_to_string(&html).unwrap();
    assert_eq!(page.matches("95 % confidence band").count(), 2);
    // analyze prints the entries with their σ.
    let text = ok(&["analyze", "--model", &out]);
    assert!(text.contains("±"), "{text}");
    // --no-covariance: none, and the diagnostics say why.
    let bare = p(&d, "bare.json");
    let mut no = args.to_vec();
    no.pop();
    no.extend([bare.as_str(), "--no-covariance"]);
    ok(&no);
    let f = ModelFile::read(&bare).unwrap();
    assert!(f.covariance.is_none());
    assert_eq!(f.diagnostics["covariance"]["computed"], false);
    let text = ok(&["bode", "--model", &bare, "--omega", "1", "--json"]);
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert!(v["pairs"][0].get("magnitude_db_lower").is_none());
    // A budget too small for the pass: no covariance, the reason named.
    let small = p(&d, "small.json");
    let mut tiny = args.to_vec();
    tiny.pop();
    tiny.extend([small.as_str(), "--budget", "covariance_work=1000"]);
    ok(&tiny);
    let f = ModelFile::read(&small).unwrap();
    assert!(f.covariance.is_none());
    let why = f.diagnostics["covariance"]["why"].as_str().unwrap();
    assert!(why.contains("work"), "{why}");
}

use super::*;
use lifted_lti::{C2dOptions, TransferFunction};

/// One input held 2 samples, two outputs sampled every 3 with delays
/// 5 T and 2.3 T: `lifted delay` prints [5, 6) and [2, 3).
#[test]
fn delay_per_pair() {
    let dir = tmp("delay");
    let path = p(&dir, "d.csv");
    let n = 3600;
    let e = rbs(n / 2, 31);
    let u: Vec<f64> = (0..n).map(|t| e[t / 2]).collect();
    let um = DMatrix::from_column_slice(n, 1, &u);
    let resp = |tau: f64, d: f64| {
        TransferFunction::from_coeffs(&[1.0], &[tau, 1.0], None)
            .unwrap()
            .to_ss()
            .unwrap()
            .c2d(
                1.0,
                &C2dOptions {
                    input_delays: Some(vec![d]),
                    ..Default::default()
                },
            )
            .unwrap()
            .lsim(&um, None, None)
            .unwrap()
            .y
    };
    let (y1, y2) = (resp(20.0, 5.0), resp(5.0, 2.3));
    let mut text = String::from("t,u1,y1,y2\n");
    for t in 0..n {
        let (a, b) = if t % 3 == 0 {
            (y1[(t, 0)].to_string(), y2[(t, 0)].to_string())
        } else {
            (String::new(), String::new())
        };
        text += &format!("{t},{},{a},{b}\n", u[t]);
    }
    std::fs::write(&path, text).unwrap();
    let args = [
        "delay",
        "--data",
        &path,
        "--inputs",
        "u1",
        "--outputs",
        "y1,y2",
        "--hold",
        "2",
    ];
    let table = ok(&args);
    assert!(
        table.contains("[5, 6)") && table.contains("[2, 3)"),
        "{table}"
    );
    let mut j = args.to_vec();
    j.push("--json");
    let v: serde_json::Value = serde_json::from_str(&ok(&j)).unwrap();
    let pairs = v["pairs"].as_array().unwrap();
    assert_eq!(pairs.len(), 2);
    assert_eq!(pairs[0]["interval"], serde_json::json!([5, 6]));
    assert_eq!(pairs[1]["interval"], serde_json::json!([2, 3]));
    let msg = fails(
        &[
            "delay",
            "--data",
            &path,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--hold",
            "0",
        ],
        2,
    );
    assert!(msg.contains("--hold"), "{msg}");
    let msg = fails(
        &[
            "delay",
            "--data",
            &path,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--sigmas=-1",
        ],
        2,
    );
    assert!(msg.contains("--sigmas"), "{msg}");
}

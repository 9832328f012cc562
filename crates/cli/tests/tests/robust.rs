use super::*;
use lifted_lti::TransferFunction;
use lifted_mpc::DualRateLoop;

fn tf(num: &[f64], den: &[f64]) -> StateSpace {
    TransferFunction::from_coeffs(num, den, Some(1.0))
        .unwrap()
        .to_ss()
        .unwrap()
}

/// Thesis §9.6 (spec A3.11): P̂ = 0.15/(z−0.9), K = 3 + 0.5/(1−z⁻¹),
/// P = 0.13/(z³(z−0.92)), W₁ = P̂ − P. The figures are the spec's
/// reference values (β_sr 1.2582 at θ 0.734, β_dr 0.9220/0.9071 at
/// n = 2/4); the monodromy is checked against `DualRateLoop` and must
/// differ between the model and the true plant.
#[test]
fn chapter9_example() {
    let dir = tmp("robust");
    let phat = tf(&[0.15], &[1.0, -0.9]);
    let k = tf(&[3.5, -3.0], &[1.0, -1.0]);
    let plant = tf(&[0.13], &[1.0, -0.92, 0.0, 0.0, 0.0]);
    let w = tf(
        &[0.15, -0.138, 0.0, -0.13, 0.117],
        &[1.0, -1.82, 0.828, 0.0, 0.0, 0.0],
    );
    let write = |name: &str, m: &StateSpace| {
        let path = p(&dir, name);
        ModelFile::new(m.clone()).write(&path).unwrap();
        path
    };
    let (pm, pk, pp, pw) = (
        write("phat.json", &phat),
        write("k.json", &k),
        write("p.json", &plant),
        write("w.json", &w),
    );
    let text = ok(&[
        "robust",
        "--model",
        &pm,
        "--controller",
        &pk,
        "--weight",
        &pw,
        "--plant",
        &pp,
        "--periods",
        "2,4",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let num = |x: &serde_json::Value| x.as_f64().unwrap();
    assert!((num(&v["beta_sr"]["value"]) - 1.2582).abs() < 1e-3, "{v}");
    assert!((num(&v["beta_sr"]["theta"]) - 0.734).abs() < 2e-3, "{v}");
    let rows = v["periods"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    for (row, n, beta) in [(&rows[0], 2, 0.9220), (&rows[1], 4, 0.9071)] {
        assert_eq!(row["n"].as_u64(), Some(n as u64));
        assert!((num(&row["beta_dr"]) - beta).abs() < 1e-3, "{row}");
        assert_eq!(row["robustly_stable"].as_bool(), Some(true));
        let rho = DualRateLoop::new(&plant, &phat, &k, n)
            .unwrap()
            .spectral_radius()
            .unwrap();
        assert!((num(&row["monodromy_spectral_radius"]) - rho).abs() < 1e-12);
        let nominal = DualRateLoop::new(&phat, &phat, &k, n)
            .unwrap()
            .spectral_radius()
            .unwrap();
        assert!(
            (rho - nominal).abs() > 1e-6,
            "plant must enter the monodromy"
        );
    }
    // Table output and the identity weight (default).
    let table = ok(&["robust", "--model", &pm, "--controller", &pk]);
    assert!(
        table.contains("beta_sr") && table.contains("rho(Phi)"),
        "{table}"
    );
}

/// Named errors: sizes that do not fit, an unstable nominal loop, a
/// zero period, a missing file.
#[test]
fn bad_input() {
    let dir = tmp("robust-bad");
    let phat = tf(&[0.15], &[1.0, -0.9]);
    let write = |name: &str, m: &StateSpace| {
        let path = p(&dir, name);
        ModelFile::new(m.clone()).write(&path).unwrap();
        path
    };
    let pm = write("phat.json", &phat);
    let pk = write("k.json", &tf(&[3.5, -3.0], &[1.0, -1.0]));
    // 0.15·40/(z − 0.9): closed-loop pole 0.9 − 6 = −5.1.
    let big = write("big.json", &tf(&[40.0], &[1.0]));
    let two = write(
        "k2.json",
        &StateSpace::gain(DMatrix::identity(2, 2), Some(1.0)).unwrap(),
    );
    let msg = fails(&["robust", "--model", &pm, "--controller", &two], 2);
    assert!(msg.contains("controller"), "{msg}");
    let msg = fails(&["robust", "--model", &pm, "--controller", &big], 2);
    assert!(msg.contains("unstable"), "{msg}");
    let msg = fails(
        &[
            "robust",
            "--model",
            &pm,
            "--controller",
            &pk,
            "--periods",
            "2,0",
        ],
        2,
    );
    assert!(msg.contains("slow period 0"), "{msg}");
    let msg = fails(
        &[
            "robust",
            "--model",
            &p(&dir, "nope.json"),
            "--controller",
            &pk,
        ],
        2,
    );
    assert!(msg.contains("nope.json"), "{msg}");
    let msg = fails(
        &["robust", "--model", &pm, "--controller", &pk, "--grid", "3"],
        2,
    );
    assert!(msg.contains("grid"), "{msg}");
}

use super::*;
use lifted_lti::TransferFunction;

/// Ĥ₁, Ĥ₂ of G = 1/(0.3s+1) under K = (0.2s+5)/s (Ren & Zhu Table 2)
/// discretised at 5 ms; each set-up's recovery returns G.
#[test]
fn every_setup_recovers_the_plant() {
    let dir = tmp("closedloop");
    let ts = 0.005;
    let g = TransferFunction::from_coeffs(&[1.0], &[0.3, 1.0], None)
        .unwrap()
        .to_ss()
        .unwrap()
        .c2d(ts, &Default::default())
        .unwrap();
    // Discrete PI u = 0.2 e + 5·0.005 Σe: (0.225 z − 0.2)/(z − 1).
    let k = TransferFunction::from_coeffs(&[0.225, -0.2], &[1.0, -1.0], Some(ts))
        .unwrap()
        .to_ss()
        .unwrap();
    let (h1, h2) = lifted_closedloop::recover::closed_loop(&g, &k).unwrap();
    let write = |name: &str, m: &StateSpace| {
        let path = p(&dir, name);
        ModelFile::new(m.clone()).write(&path).unwrap();
        path
    };
    let (ph1, ph2, pk) = (
        write("h1.json", &h1),
        write("h2.json", &h2),
        write("k.json", &k),
    );
    for (setup, extra) in [
        ("general", vec!["--h1", &ph1, "--h2", &ph2]),
        ("controller", vec!["--h1", &ph1, "--controller", &pk]),
        ("compensator", vec!["--h2", &ph2, "--controller", &pk]),
    ] {
        let out = p(&dir, &format!("g-{setup}.json"));
        let mut args = vec!["closedloop", "--setup", setup, "--out", &out];
        args.extend(extra);
        let text = ok(&args);
        assert!(text.contains("recovered plant"), "{text}");
        let f = ModelFile::read(&out).unwrap();
        assert_eq!(f.model.order(), 1, "{setup}: minimal realisation");
        let w = [0.1, 1.0, 10.0, 100.0];
        let (a, b) = (f.model.freqresp(&w).unwrap(), g.freqresp(&w).unwrap());
        for (x, y) in a.iter().zip(&b) {
            assert!(
                (x[(0, 0)] - y[(0, 0)]).norm() < 1e-6 * y[(0, 0)].norm(),
                "{setup}"
            );
        }
    }
    let msg = fails(
        &[
            "closedloop",
            "--setup",
            "general",
            "--h1",
            &ph1,
            "--out",
            &p(&dir, "x.json"),
        ],
        2,
    );
    assert!(msg.contains("--h2"), "{msg}");
    let msg = fails(
        &[
            "closedloop",
            "--setup",
            "general",
            "--h1",
            &ph1,
            "--h2",
            &ph2,
            "--controller",
            &pk,
            "--out",
            &p(&dir, "x.json"),
        ],
        2,
    );
    assert!(msg.contains("does not use --controller"), "{msg}");
    let msg = fails(
        &[
            "closedloop",
            "--setup",
            "controller",
            "--h1",
            &p(&dir, "nope.json"),
            "--controller",
            &pk,
            "--out",
            &p(&dir, "x.json"),
        ],
        2,
    );
    assert!(msg.contains("nope.json"), "{msg}");
}

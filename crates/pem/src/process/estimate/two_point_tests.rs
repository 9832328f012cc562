use super::*;

#[test]
fn smith_two_point_start_on_a_noise_free_step() {
    // On a first order plus dead time, 28.3 % is reached at θ + T/3 and
    // 63.2 % at θ + T, so the two-point start is exact up to the linear
    // interpolation between samples: within 0.1 s here (T = 20 s, 1 s
    // samples), the gain to 1e-3 (the last third is 0.9999 settled).
    let m = ProcessModel::from_parameters(ProcessKind::P1D, &[2.0, 20.0, 7.3], 1.0).unwrap();
    let mut u = vec![0.0; 600];
    for v in u.iter_mut().skip(40) {
        *v = 1.0;
    }
    let y = m.simulate(&u).unwrap();
    let p = Problem {
        kind: ProcessKind::P1D,
        ts: 1.0,
        intersample: InterSample::Zoh,
        nu: 1,
        offset: false,
        inputs: vec![vec![u]],
        outputs: vec![&y],
        measured: 600,
        theta_max: 200.0,
        log_t: (1e-3f64.ln(), 6e4f64.ln()),
        gain_scale: 1.0,
        duration: 600.0,
        fixed: Vec::new(),
    };
    let s = two_point_start(&p).unwrap();
    assert!((s[0] - 2.0).abs() < 1e-3, "{s:?}");
    assert!(
        (s[1] - 20.0).abs() < 0.1 && (s[2] - 7.3).abs() < 0.1,
        "{s:?}"
    );
}

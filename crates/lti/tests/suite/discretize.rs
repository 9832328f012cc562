//! c2d / d2c against closed forms and scipy values.

use approx::assert_abs_diff_eq;
use lifted_lti::{C2dMethod, C2dOptions, MinrealOptions, StateSpace};
use num_complex::Complex64;

use crate::common::*;

fn zoh() -> C2dOptions {
    C2dOptions::default()
}

/// ZOH of a/(s+a): (1 − e^{−aT})/(z − e^{−aT}).
#[test]
fn zoh_first_order_closed_form() {
    let (a, t) = (2.0, 0.1);
    let g = tf(&[a], &[1.0, a], None).to_ss().unwrap();
    let gd = g
        .c2d(t, &zoh())
        .unwrap()
        .to_tf(&MinrealOptions::default())
        .unwrap();
    let e = (-a * t).exp();
    let want = tf(&[1.0 - e], &[1.0, -e], Some(t));
    assert!(tf_diff(&gd, &want) < 1e-14, "{gd}");
}

/// ZOH of 1/((s+1)(s+2)) vs the closed form
/// G(z) = 1/2 − (z−1)/(z−e^{−T}) + 1/2·(z−1)/(z−e^{−2T}), at points on and
/// off the unit circle; plus the scipy 1.17.1 `cont2discrete(.., 'zoh')`
/// coefficients (0.00452795850303156, 0.00409706628085671)/(1, −1.7235681711139414, 0.7408182206817179).
#[test]
fn zoh_second_order_closed_form() {
    let t = 0.1;
    let g = tf(&[1.0], &[1.0, 3.0, 2.0], None).to_ss().unwrap();
    let gd = g.c2d(t, &zoh()).unwrap();
    let (e1, e2) = ((-t).exp(), (-2.0 * t).exp());
    for &z in &[
        Complex64::new(0.3, 0.8),
        Complex64::new(-1.2, 0.1),
        Complex64::from_polar(1.0, 0.7),
    ] {
        let want = 0.5 - (z - 1.0) / (z - e1) + 0.5 * (z - 1.0) / (z - e2);
        let got = gd.eval_complex(z).unwrap()[(0, 0)];
        assert!((got - want).norm() < 1e-14, "{got} vs {want}");
    }
    let tfd = gd.to_tf(&MinrealOptions::default()).unwrap();
    let scipy = tf(
        &[0.00452795850303156, 0.00409706628085671],
        &[1.0, -1.7235681711139414, 0.7408182206817179],
        Some(t),
    );
    assert!(tf_diff(&tfd, &scipy) < 1e-14);
}

/// Fractional input delay τ = dT + δ: modified z-transform of 1/(s+a),
/// G(z) = z^{−d−1}[(1 − e^{−amT})z + (e^{−amT} − e^{−aT})]/(a(z − e^{−aT})), m = 1 − δ/T.
#[test]
fn zoh_fractional_delay_modified_z_transform() {
    let (a, t) = (1.5, 0.2);
    let g = tf(&[1.0], &[1.0, a], None).to_ss().unwrap();
    for &(d, delta) in &[(0usize, 0.05), (2, 0.13), (1, 0.0), (3, 0.199)] {
        let tau = d as f64 * t + delta;
        let opts = C2dOptions {
            input_delays: Some(vec![tau]),
            ..C2dOptions::default()
        };
        let gd = g.c2d(t, &opts).unwrap();
        let m = 1.0 - delta / t;
        let (em, e) = ((-a * m * t).exp(), (-a * t).exp());
        for &z in &[
            Complex64::new(0.5, 0.5),
            Complex64::from_polar(1.0, 1.1),
            Complex64::new(1.7, -0.2),
        ] {
            let want = z.powi(-(d as i32) - 1) * ((1.0 - em) * z + (em - e)) / (a * (z - e));
            let got = gd.eval_complex(z).unwrap()[(0, 0)];
            assert!(
                (got - want).norm() < 1e-13,
                "d={d} δ={delta}: {got} vs {want}"
            );
        }
        // Order: 1 plant state + d shift states + 1 fractional state (δ > 0).
        assert_eq!(gd.order(), 1 + d + usize::from(delta > 0.0));
    }
}

/// Delay with a feedthrough: y(kT) = D u(kT − τ) needs the delayed sample.
#[test]
fn zoh_delay_with_feedthrough_matches_simulation() {
    // G = (s + 3)/(s + 1) = 1 + 2/(s+1), τ = 0.25 with T = 0.1 (d = 2, δ = 0.05)
    let g = tf(&[1.0, 3.0], &[1.0, 1.0], None).to_ss().unwrap();
    let t = 0.1;
    let opts = C2dOptions {
        input_delays: Some(vec![0.25]),
        ..C2dOptions::default()
    };
    let gd = g.c2d(t, &opts).unwrap();
    let y = gd.step(8, None).unwrap().remove(0);
    // exact step response of the delayed plant at t = kT: 0 for t < τ, else 3 − 2e^{−(t−τ)}
    for k in 0..8 {
        let tk = k as f64 * t;
        let want = if tk < 0.25 - 1e-12 {
            0.0
        } else {
            3.0 - 2.0 * (-(tk - 0.25)).exp()
        };
        assert_abs_diff_eq!(y[(k, 0)], want, epsilon = 1e-12);
    }
}

/// FOH and Tustin against scipy 1.17.1 `cont2discrete` ('foh', 'bilinear')
/// and python-control 0.10.2 `sample_system(.., 'tustin', prewarp_frequency=5)`.
#[test]
fn foh_and_tustin_vs_scipy() {
    let g = tf(&[1.0], &[1.0, 3.0, 2.0], None).to_ss().unwrap();
    let t = 0.1;
    let cases = [
        (
            C2dMethod::Foh,
            [
                0.00154729766464112,
                0.00574594735542377,
                0.00133177976382326,
            ],
            [1.0, -1.7235681711139414, 0.7408182206817179],
        ),
        (
            C2dMethod::Tustin { prewarp: None },
            [
                0.00216450216450215,
                0.00432900432900452,
                0.00216450216450204,
            ],
            [1.0, -1.722943722943723, 0.7402597402597403],
        ),
        (
            C2dMethod::Tustin { prewarp: Some(5.0) },
            [
                0.00225132280587537,
                0.00450264561175051,
                0.00225132280587559,
            ],
            [1.0, -1.7174825796108082, 0.7354931620578107],
        ),
    ];
    for (method, num, den) in cases {
        let gd = g
            .c2d(
                t,
                &C2dOptions {
                    method,
                    ..C2dOptions::default()
                },
            )
            .unwrap();
        let got = gd.to_tf(&MinrealOptions::default()).unwrap();
        assert!(
            tf_diff(&got, &tf(&num, &den, Some(t))) < 1e-13,
            "{method:?}: {got}"
        );
    }
    // biproper second-order plant with D ≠ 0
    let g2 = tf(&[0.5, 1.0, 2.0], &[1.0, 0.4, 4.0], None)
        .to_ss()
        .unwrap();
    let cases2 = [
        (
            C2dMethod::Foh,
            [0.5198508021852526, -0.9852850708306166, 0.47038047644461584],
            [1.0, -1.9703062577082515, 0.9801986733067553],
        ),
        (
            C2dMethod::Tustin { prewarp: None },
            [0.519753086419753, -0.9851851851851848, 0.47037037037037005],
            [1.0, -1.9703703703703703, 0.9802469135802468],
        ),
    ];
    for (method, num, den) in cases2 {
        let got = g2
            .c2d(
                0.05,
                &C2dOptions {
                    method,
                    ..C2dOptions::default()
                },
            )
            .unwrap()
            .to_tf(&MinrealOptions::default())
            .unwrap();
        assert!(
            tf_diff(&got, &tf(&num, &den, Some(0.05))) < 1e-13,
            "{method:?}: {got}"
        );
    }
}

/// Tustin with prewarp matches the continuous response exactly at ω₀.
#[test]
fn tustin_prewarp_matches_at_omega0() {
    let g = tf(&[1.0], &[1.0, 0.3, 4.0], None).to_ss().unwrap();
    let (t, w0) = (0.2, 2.0);
    let gd = g
        .c2d(
            t,
            &C2dOptions {
                method: C2dMethod::Tustin { prewarp: Some(w0) },
                ..C2dOptions::default()
            },
        )
        .unwrap();
    let a = g.freqresp(&[w0]).unwrap()[0][(0, 0)];
    let b = gd.freqresp(&[w0]).unwrap()[0][(0, 0)];
    assert!((a - b).norm() < 1e-12 * a.norm());
}

#[test]
fn d2c_inverts_zoh() {
    let g = StateSpace::new(
        mat(2, 2, &[-1.0, 2.0, -3.0, -0.5]),
        mat(2, 1, &[1.0, 0.5]),
        mat(1, 2, &[1.0, -1.0]),
        mat(1, 1, &[0.2]),
        None,
    )
    .unwrap();
    let back = g.c2d(0.05, &C2dOptions::default()).unwrap().d2c().unwrap();
    assert!(back.ts().is_none());
    assert!((back.a() - g.a()).norm() < 1e-10);
    assert!((back.b() - g.b()).norm() < 1e-10);
}

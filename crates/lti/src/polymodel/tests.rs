use super::*;

#[test]
fn present_shows_the_standard_deviations() {
    let m = PolyModel::arx(&[1.0, -1.5, 0.7], &[1.0, 0.5], 1, 1.0).unwrap();
    assert_eq!(m.present(), m.to_string());
    let cov = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1e-4, 4e-4, 0.0225, 1e-6]));
    let m = m.with_covariance(&cov).unwrap();
    let text = m.present();
    assert!(
        text.contains("A(q) = 1 - 1.5 (±0.010) q^-1 + 0.7 (±0.020) q^-2"),
        "{text}"
    );
    assert!(
        text.contains("B(q) = q^-1 (1 (±0.15) + 0.5 (±0.0010) q^-1)"),
        "{text}"
    );
    assert_eq!(significant(0.0123), "0.012");
    assert_eq!(significant(12.3), "12");
}

/// A coupled two-output, one-input ARX model (A12 = 0.2 q⁻¹,
/// A21 = −0.1 q⁻¹ + 0.05 q⁻²).
pub(crate) fn coupled_arx() -> PolyModel {
    PolyModel::new(
        Polynomials {
            a: Some(vec![
                vec![vec![1.0, -0.9, 0.2], vec![0.0, 0.2]],
                vec![vec![0.0, -0.1, 0.05], vec![1.0, -0.5]],
            ]),
            b: vec![vec![vec![1.0, 0.4]], vec![vec![0.5]]],
            nk: vec![vec![1], vec![2]],
            ..Default::default()
        },
        0.5,
    )
    .unwrap()
}

/// One output, two inputs, output error with different F and delays.
pub(crate) fn miso_oe() -> PolyModel {
    PolyModel::new(
        Polynomials {
            b: vec![vec![vec![1.0, 0.5], vec![-0.3]]],
            f: Some(vec![vec![vec![1.0, -0.8], vec![1.0, -1.2, 0.5]]]),
            nk: vec![vec![1, 3]],
            ..Default::default()
        },
        0.1,
    )
    .unwrap()
}

/// The SISO families used across the tests.
pub(crate) fn siso_models() -> Vec<PolyModel> {
    vec![
        PolyModel::arx(&[1.0, -1.5, 0.7], &[1.0, 0.5], 1, 1.0).unwrap(),
        PolyModel::armax(&[1.0, -1.5, 0.7], &[1.0, 0.5], &[1.0, -0.2, 0.1], 2, 1.0).unwrap(),
        PolyModel::oe(&[0.5, -0.2], &[1.0, -0.6], 1, 0.2).unwrap(),
        PolyModel::bj(
            &[1.0, 0.3],
            &[1.0, 0.4],
            &[1.0, -0.7],
            &[1.0, -1.1, 0.3],
            1,
            1.0,
        )
        .unwrap(),
        PolyModel::fir(&[0.5, 0.25, 0.125], 2, 1.0).unwrap(),
        // General: A with F and D, and a direct feedthrough (nk = 0).
        PolyModel::siso(
            &[1.0, -0.5],
            &[0.3, 0.2],
            &[1.0, 0.5],
            &[1.0, -0.4],
            &[1.0, 0.2],
            0,
            1.0,
        )
        .unwrap(),
    ]
}

#[test]
fn families_orders_and_parameters() {
    let fams: Vec<_> = siso_models().iter().map(PolyModel::family).collect();
    use PolyFamily::*;
    assert_eq!(fams, vec![Arx, Armax, Oe, Bj, Fir, General]);
    assert_eq!(coupled_arx().family(), Arx);
    assert_eq!(miso_oe().family(), Oe);
    let bj = &siso_models()[3];
    assert_eq!(bj.orders(), PolyOrders::siso(0, 2, 1, 1, 2, 1));
    // MATLAB order: b, c, d, f.
    assert_eq!(bj.parameters(), vec![1.0, 0.3, 0.4, -0.7, -1.1, 0.3]);
    let m = coupled_arx();
    // Output 1: A11[1..], A12[1..], B11; output 2: A21[1..], A22[1..], B21.
    assert_eq!(
        m.parameters(),
        vec![-0.9, 0.2, 0.2, 1.0, 0.4, -0.1, 0.05, -0.5, 0.5]
    );
    assert_eq!(m.n_parameters(), m.orders().n_parameters());
    let theta: Vec<f64> = (0..m.n_parameters()).map(|i| i as f64 * 0.01).collect();
    let m2 = m.with_parameters(&theta).unwrap();
    assert_eq!(m2.parameters(), theta);
    assert_eq!(m2.a(1, 0)[0], 0.0);
    assert_eq!(m2.nk(1, 0), 2);
    // The template of a structure has the structure.
    let t = PolyModel::from_orders(&m.orders(), 0.5).unwrap();
    assert_eq!(t.orders(), m.orders());
    assert!(t.parameters().iter().all(|&v| v == 0.0));
    assert_eq!(PolyModel::new(m.polynomials(), 0.5).unwrap(), m);
    assert!(!m.has_diagonal_a());
}

#[test]
fn covariance_and_std() {
    let m = PolyModel::arx(&[1.0, -0.5], &[2.0], 1, 1.0).unwrap();
    let cov = DMatrix::from_row_slice(2, 2, &[0.04, 0.01, 0.01, 0.09]);
    let m = m.with_covariance(&cov).unwrap();
    let s = m.std().unwrap();
    approx::assert_abs_diff_eq!(s[0], 0.2, epsilon = 1e-15);
    approx::assert_abs_diff_eq!(s[1], 0.3, epsilon = 1e-15);
    // New parameters drop the old covariance.
    assert!(m.with_parameters(&[0.1, 0.2]).unwrap().std().is_none());
    assert!(m.clone().without_covariance().covariance().is_none());
    assert!(matches!(
        m.clone().with_covariance(&DMatrix::identity(3, 3)),
        Err(Error::DimensionMismatch { .. })
    ));
    let asym = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0]);
    assert!(matches!(
        m.clone().with_covariance(&asym),
        Err(Error::InvalidArgument { .. })
    ));
    let lam = DMatrix::from_element(1, 1, 0.25);
    assert_eq!(m.with_noise_variance(&lam).unwrap().noise_variance(), &lam);
}

#[test]
fn display_shows_the_polynomials() {
    let m = PolyModel::armax(&[1.0, -1.5, 0.7], &[1.0, 0.5], &[1.0, -0.2], 1, 0.1).unwrap();
    assert_eq!(
        m.to_string(),
        "discrete-time polynomial model (ARMAX, T = 0.1), 1 output(s), 1 input(s)\n\
         A(q) = 1 - 1.5 q^-1 + 0.7 q^-2\n\
         B(q) = q^-1 (1 + 0.5 q^-1)\n\
         C(q) = 1 - 0.2 q^-1"
    );
    let s = coupled_arx().to_string();
    assert!(s.contains("A12(q) = 0.2 q^-1"), "{s}");
    assert!(s.contains("B21(q) = q^-2 0.5"), "{s}");
    assert_eq!(display_q(&[], None, 0), "0");
}

#[test]
fn time_series_models_have_no_inputs() {
    // ARMA: (1 − 0.7q⁻¹) y = (1 + 0.4q⁻¹) e.
    let m = PolyModel::new(
        Polynomials {
            a: Some(vec![vec![vec![1.0, -0.7]]]),
            b: vec![vec![]],
            c: Some(vec![vec![1.0, 0.4]]),
            nk: vec![vec![]],
            ..Default::default()
        },
        1.0,
    )
    .unwrap();
    assert_eq!(m.n_inputs(), 0);
    assert_eq!(m.family(), PolyFamily::Armax);
    let u = DMatrix::zeros(100, 0);
    let e = DMatrix::from_fn(100, 1, |t, _| ((t * 37 % 11) as f64 - 5.0) / 5.0);
    let y = m.simulate(&u, Some(&e)).unwrap();
    assert!((m.prediction_errors(&u, &y).unwrap() - &e).amax() < 1e-12);
    let (ss, k) = m.to_innovations_ss().unwrap();
    assert_eq!(ss.order(), 1);
    let back = PolyModel::from_ss(&ss, Some(&k)).unwrap();
    assert!(convert::tests::model_diff(&back, &m) < 1e-12);
    assert_eq!(PolyModel::from_json(&m.to_json().unwrap()).unwrap(), m);
}

// One test per rejected input.

#[test]
fn rejects_nan_coefficient() {
    let e = PolyModel::arx(&[1.0, f64::NAN], &[1.0], 1, 1.0).unwrap_err();
    assert!(
        matches!(
            e,
            Error::NonFiniteCoefficient {
                which: "A",
                row: 0,
                col: 0,
                index: 1,
                ..
            }
        ),
        "{e}"
    );
    let e = PolyModel::oe(&[f64::INFINITY], &[1.0], 1, 1.0).unwrap_err();
    assert!(
        matches!(e, Error::NonFiniteCoefficient { which: "B", .. }),
        "{e}"
    );
    let m = PolyModel::arx(&[1.0, -0.5], &[1.0], 1, 1.0).unwrap();
    assert!(matches!(
        m.with_parameters(&[f64::NAN, 1.0]),
        Err(Error::NonFiniteCoefficient { which: "A", .. })
    ));
}

#[test]
fn rejects_non_monic_polynomials() {
    let e = PolyModel::arx(&[2.0, -0.5], &[1.0], 1, 1.0).unwrap_err();
    assert!(
        matches!(
            e,
            Error::NonMonicPolynomial {
                which: "A",
                expected: 1.0,
                got: Some(2.0),
                ..
            }
        ),
        "{e}"
    );
    assert!(matches!(
        PolyModel::armax(&[1.0], &[1.0], &[], 1, 1.0),
        Err(Error::NonMonicPolynomial {
            which: "C",
            got: None,
            ..
        })
    ));
    assert!(matches!(
        PolyModel::oe(&[1.0], &[0.5, 1.0], 1, 1.0),
        Err(Error::NonMonicPolynomial { which: "F", .. })
    ));
    // An off-diagonal A must start with 0.
    let mut p = coupled_arx().polynomials();
    if let Some(a) = p.a.as_mut() {
        a[0][1][0] = 0.1;
    }
    assert!(matches!(
        PolyModel::new(p, 1.0),
        Err(Error::NonMonicPolynomial {
            which: "A",
            row: 0,
            col: 1,
            expected: 0.0,
            ..
        })
    ));
}

#[test]
fn rejects_wrong_shapes() {
    let mut p = coupled_arx().polynomials();
    p.nk = vec![vec![1]];
    assert!(matches!(
        PolyModel::new(p, 1.0),
        Err(Error::DimensionMismatch { what: "nk", .. })
    ));
    let mut p = coupled_arx().polynomials();
    if let Some(a) = p.a.as_mut() {
        a[1].pop();
    }
    assert!(matches!(
        PolyModel::new(p, 1.0),
        Err(Error::DimensionMismatch { what: "A", .. })
    ));
    let mut p = coupled_arx().polynomials();
    p.c = Some(vec![vec![1.0]]);
    assert!(matches!(
        PolyModel::new(p, 1.0),
        Err(Error::DimensionMismatch { what: "C", .. })
    ));
    assert!(matches!(
        PolyModel::new(Polynomials::default(), 1.0),
        Err(Error::DimensionMismatch { what: "B", .. })
    ));
    let mut o = coupled_arx().orders();
    o.nd.push(1);
    assert!(matches!(
        PolyModel::from_orders(&o, 1.0),
        Err(Error::DimensionMismatch { what: "nd", .. })
    ));
    let m = coupled_arx();
    assert!(m.clone().with_input_names(vec![]).is_err());
    assert!(m.with_noise_variance(&DMatrix::identity(1, 1)).is_err());
}

#[test]
fn rejects_bad_sample_period() {
    for ts in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let e = PolyModel::fir(&[1.0], 0, ts).unwrap_err();
        assert!(matches!(e, Error::InvalidSamplePeriod { .. }), "{e}");
    }
}

#[test]
fn rejects_parameter_vector_of_wrong_length() {
    let m = coupled_arx();
    let e = m.with_parameters(&[0.0; 3]).unwrap_err();
    assert_eq!(
        e,
        Error::ParameterCount {
            expected: 9,
            got: 3
        }
    );
}

/// A Box–Jenkins model of seven inputs, each its own F with roots near
/// 0.9–0.95, and D = (1 − 0.9q⁻¹)²: realised through the product of the
/// denominators (one companion form of degree 16), the state space had
/// spectral radius 1.06 and its simulation differed from the difference
/// equations by 1e56 relative (the roots of a degree-16 product with
/// clustered roots are not determined by its rounded coefficients; the
/// thinned debutanizer's BJ model came back "unstable"). The parallel
/// form keeps each denominator in its own block: the model's own poles
/// (0.95 the largest) and its simulation to rounding.
#[test]
fn seven_inputs_with_their_own_denominators_realise_without_a_product() {
    let nu = 7;
    let b: Vec<Vec<f64>> = (0..nu).map(|k| vec![0.1 + 0.01 * k as f64, 0.05]).collect();
    let f: Vec<Vec<f64>> = (0..nu)
        .map(|k| {
            let (r1, r2) = (0.95 - 0.01 * k as f64, 0.9 - 0.02 * k as f64);
            vec![1.0, -(r1 + r2), r1 * r2]
        })
        .collect();
    let p = Polynomials {
        b: vec![b],
        f: Some(vec![f]),
        c: Some(vec![vec![1.0, 0.3]]),
        d: Some(vec![vec![1.0, -1.8, 0.81]]),
        nk: vec![vec![1; nu]],
        ..Default::default()
    };
    let m = PolyModel::new(p, 1.0).unwrap();
    let (ss, _k) = m.to_innovations_ss().unwrap();
    let rho = lifted_linalg::spectral_radius(ss.a()).unwrap();
    let n = 3000;
    let u = DMatrix::from_fn(n, nu, |t, k| (((t * 7 + k * 13) % 17) as f64 - 8.0) / 8.0);
    let y1 = m.simulate(&u, None).unwrap();
    let y2 = ss.lsim_outputs(&u, None).unwrap();
    let err = (&y1 - &y2).norm() / y1.norm();
    assert_eq!(ss.order(), 16);
    assert!((rho - 0.95).abs() < 1e-9, "spectral radius {rho}");
    assert!(err < 1e-12, "simulation differs by {err:e}");
    // The innovations form predicts as the polynomial model.
    let e = DMatrix::from_fn(n, 1, |t, _| (((t * 5) % 11) as f64 - 5.0) / 5.0);
    let y = m.simulate(&u, Some(&e)).unwrap();
    let eps = m.prediction_errors(&u, &y).unwrap();
    assert!(
        (&eps - &e).norm() < 1e-9 * e.norm(),
        "one-step errors are not e"
    );
}

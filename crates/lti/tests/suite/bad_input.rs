//! One test per rejected input: a named error, never a panic.

use lifted_linalg::Error as LaError;
use lifted_lti::{
    C2dMethod, C2dOptions, Error, HinfOptions, MinrealOptions, Poly, StateSpace, TransferFunction,
};
use nalgebra::DMatrix;

use crate::common::*;

fn ok_parts() -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    (
        mat(2, 2, &[-1.0, 0.0, 0.0, -2.0]),
        mat(2, 1, &[1.0, 1.0]),
        mat(1, 2, &[1.0, 0.0]),
        mat(1, 1, &[0.0]),
    )
}

#[test]
fn nan_in_a_matrix() {
    let (mut a, b, c, d) = ok_parts();
    a[(1, 0)] = f64::NAN;
    let e = StateSpace::new(a, b, c, d, None).unwrap_err();
    assert!(
        matches!(
            e,
            Error::Linalg(LaError::NonFinite {
                what: "A",
                row: 1,
                col: 0
            })
        ),
        "{e}"
    );
    let (a, b, mut c, d) = ok_parts();
    c[(0, 1)] = f64::INFINITY;
    assert!(matches!(
        StateSpace::new(a, b, c, d, None),
        Err(Error::Linalg(LaError::NonFinite { what: "C", .. }))
    ));
    assert!(matches!(
        Poly::new(vec![1.0, f64::NAN]),
        Err(Error::NonFiniteScalar { .. })
    ));
}

#[test]
fn non_square_a() {
    let (_, b, c, d) = ok_parts();
    let a = DMatrix::zeros(2, 3);
    assert!(matches!(
        StateSpace::new(a, b, c, d, None),
        Err(Error::Linalg(LaError::NotSquare {
            what: "A",
            rows: 2,
            cols: 3
        }))
    ));
}

#[test]
fn mismatched_b_rows() {
    let (a, _, c, d) = ok_parts();
    let b = DMatrix::zeros(3, 1);
    assert!(matches!(
        StateSpace::new(a, b, c, d, None),
        Err(Error::Linalg(LaError::DimensionMismatch { what: "B", .. }))
    ));
}

#[test]
fn mismatched_c_cols_and_d_shape() {
    let (a, b, _, d) = ok_parts();
    assert!(matches!(
        StateSpace::new(a.clone(), b.clone(), DMatrix::zeros(1, 3), d, None),
        Err(Error::Linalg(LaError::DimensionMismatch { what: "C", .. }))
    ));
    let (_, _, c, _) = ok_parts();
    assert!(matches!(
        StateSpace::new(a, b, c, DMatrix::zeros(2, 1), None),
        Err(Error::Linalg(LaError::DimensionMismatch { what: "D", .. }))
    ));
}

#[test]
fn invalid_sample_period() {
    let (a, b, c, d) = ok_parts();
    for ts in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            StateSpace::new(a.clone(), b.clone(), c.clone(), d.clone(), Some(ts)),
            Err(Error::InvalidSamplePeriod { .. })
        ));
    }
    let g = StateSpace::new(a, b, c, d, None).unwrap();
    assert!(matches!(
        g.c2d(-0.1, &C2dOptions::default()),
        Err(Error::InvalidSamplePeriod { .. })
    ));
}

#[test]
fn improper_transfer_function_where_proper_required() {
    let g = tf(&[1.0, 0.0, 1.0], &[1.0, 1.0], None);
    assert!(matches!(
        g.to_ss(),
        Err(Error::ImproperTransferFunction {
            row: 0,
            col: 0,
            num_degree: 2,
            den_degree: 1
        })
    ));
    assert!(matches!(
        TransferFunction::from_coeffs(&[1.0], &[0.0], None),
        Err(Error::ZeroDenominator { .. })
    ));
}

#[test]
fn d2c_pole_at_zero() {
    // thesis §4.3 model has poles at z = 0
    let g = StateSpace::new(
        mat(3, 3, &[0.9, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]),
        mat(3, 1, &[1.0, 0.0, 0.0]),
        mat(1, 3, &[0.0, 0.0, 0.1]),
        mat(1, 1, &[0.0]),
        Some(1.0),
    )
    .unwrap();
    let e = g.d2c().unwrap_err();
    assert!(matches!(e, Error::NoContinuousEquivalent { .. }), "{e}");
}

#[test]
fn d2c_pole_on_negative_real_axis() {
    let g = tf(&[1.0], &[1.0, 0.5], Some(0.1)).to_ss().unwrap(); // pole at z = −0.5
    let e = g.d2c().unwrap_err();
    match e {
        Error::NoContinuousEquivalent { eigenvalue } => assert!((eigenvalue.re + 0.5).abs() < 1e-9),
        other => panic!("unexpected {other}"),
    }
}

#[test]
fn wrong_domain_operations() {
    let c = tf(&[1.0], &[1.0, 1.0], None).to_ss().unwrap();
    let d = tf(&[1.0], &[1.0, -0.5], Some(0.1)).to_ss().unwrap();
    assert!(matches!(c.series(&d), Err(Error::DomainMismatch { .. })));
    assert!(matches!(
        d.c2d(0.1, &C2dOptions::default()),
        Err(Error::NotContinuous { .. })
    ));
    assert!(matches!(c.d2c(), Err(Error::NotDiscrete { .. })));
    assert!(matches!(
        c.markov_parameters(3),
        Err(Error::NotDiscrete { .. })
    ));
    assert!(matches!(
        c.lsim(&DMatrix::zeros(3, 1), None, None),
        Err(Error::InvalidArgument { .. })
    ));
}

#[test]
fn bad_simulation_data() {
    let d = tf(&[1.0], &[1.0, -0.5], Some(0.1)).to_ss().unwrap();
    let mut u = DMatrix::zeros(4, 1);
    u[(2, 0)] = f64::NAN;
    assert!(matches!(
        d.lsim(&u, None, None),
        Err(Error::Linalg(LaError::NonFinite { what: "u", .. }))
    ));
    assert!(matches!(
        d.lsim(&DMatrix::zeros(4, 2), None, None),
        Err(Error::Linalg(LaError::DimensionMismatch { .. }))
    ));
    let x0 = nalgebra::DVector::from_vec(vec![1.0, 2.0]);
    assert!(matches!(
        d.lsim(&DMatrix::zeros(4, 1), Some(&x0), None),
        Err(Error::DimensionMismatch { what: "x0", .. })
    ));
}

#[test]
fn bad_options() {
    let g = tf(&[1.0], &[1.0, 1.0], None).to_ss().unwrap();
    assert!(matches!(
        g.hinf_norm(&HinfOptions {
            rel_tol: -1.0,
            ..HinfOptions::default()
        }),
        Err(Error::InvalidArgument { .. })
    ));
    assert!(matches!(
        g.minreal(&MinrealOptions { tol: f64::NAN }),
        Err(Error::InvalidArgument { .. })
    ));
    let bad_delay = C2dOptions {
        input_delays: Some(vec![-0.1]),
        ..C2dOptions::default()
    };
    assert!(matches!(
        g.c2d(0.1, &bad_delay),
        Err(Error::InvalidArgument { .. })
    ));
    let foh_delay = C2dOptions {
        method: C2dMethod::Foh,
        input_delays: Some(vec![0.1]),
    };
    assert!(matches!(
        g.c2d(0.1, &foh_delay),
        Err(Error::InvalidArgument { .. })
    ));
    let warp = C2dOptions {
        method: C2dMethod::Tustin {
            prewarp: Some(100.0),
        },
        input_delays: None,
    };
    assert!(matches!(
        g.c2d(0.1, &warp),
        Err(Error::InvalidArgument { .. })
    ));
    assert!(matches!(
        g.is_stable(-1.0),
        Err(Error::InvalidArgument { .. })
    ));
}

#[test]
fn singular_feedthrough_inverse_and_algebraic_loop() {
    let g = tf(&[1.0], &[1.0, 1.0], None).to_ss().unwrap(); // D = 0
    assert!(matches!(g.inverse(), Err(Error::NotInvertible { .. })));
    let one = StateSpace::gain(mat(1, 1, &[1.0]), None).unwrap();
    // positive feedback of 1 around 1: I − D1 D2 = 0
    assert!(matches!(
        one.feedback(&one, lifted_lti::FeedbackSign::Positive),
        Err(Error::AlgebraicLoop)
    ));
    assert!(matches!(
        tf(&[1.0], &[1.0, 1.0], None).mul(&tf(&[1.0], &[1.0], Some(1.0))),
        Err(Error::DomainMismatch { .. })
    ));
}

#[test]
fn dc_gain_with_integrator() {
    let g = tf(&[1.0], &[1.0, 0.0], None).to_ss().unwrap();
    assert!(matches!(g.dc_gain(), Err(Error::Infinite { .. })));
}

#[test]
fn data_errors_convert_into_the_crate_error() {
    // A data-set error keeps its structured form inside the crate's single error type.
    let u = DMatrix::from_element(4, 1, 1.0);
    let y = DMatrix::from_element(3, 1, 1.0);
    let e: lifted_lti::Error = lifted_lti::data::Dataset::single_rate(0.1, u, y)
        .unwrap_err()
        .into();
    assert!(matches!(e, lifted_lti::Error::Data(_)), "{e:?}");
}

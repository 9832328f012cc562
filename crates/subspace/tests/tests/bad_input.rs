use super::common::*;
use lifted_subspace::*;
use nalgebra::DMatrix;

fn data() -> (DMatrix<f64>, DMatrix<f64>) {
    let g = random_system(1, &[0.8, 0.3], &[], 1, 1, false);
    let u = rbs(1, 500, 1);
    let y = sim(&g, &u, None);
    (u, y)
}

#[test]
fn horizon_too_long() {
    let (u, y) = data();
    let (u, y) = (u.rows(0, 40).into_owned(), y.rows(0, 40).into_owned());
    let err = identify(&[Experiment { u: &u, y: &y }], &SubspaceOptions::default()).unwrap_err();
    assert!(
        matches!(err, Error::HorizonTooLong { n_samples: 40, .. }),
        "{err}"
    );
}

#[test]
fn order_too_large() {
    let (u, y) = data();
    let opts = SubspaceOptions {
        order: OrderSelection::Fixed(10),
        ..Default::default()
    };
    let err = identify(&[Experiment { u: &u, y: &y }], &opts).unwrap_err();
    assert!(
        matches!(err, Error::OrderTooLarge { order: 10, max: 9 }),
        "{err}"
    );
    let opts = IvOptions {
        order: OrderSelection::Fixed(8),
        ..Default::default()
    };
    let err = iv_identify(
        &[IvExperiment {
            u: &u,
            y: &y,
            instrument: None,
        }],
        &opts,
    )
    .unwrap_err();
    assert!(matches!(err, Error::OrderTooLarge { .. }), "{err}");
}

#[test]
fn constant_input_is_not_exciting() {
    let (_, y) = data();
    let u = DMatrix::from_element(500, 1, 1.0);
    // With the means removed (default) a constant input is zero: rank 0.
    let err = identify(&[Experiment { u: &u, y: &y }], &SubspaceOptions::default()).unwrap_err();
    assert!(
        matches!(
            err,
            Error::NotExciting {
                what: "u",
                rank: 0,
                ..
            }
        ),
        "{err}"
    );
    let as_given = SubspaceOptions {
        remove_means: false,
        ..Default::default()
    };
    let err = identify(&[Experiment { u: &u, y: &y }], &as_given).unwrap_err();
    assert!(
        matches!(
            err,
            Error::NotExciting {
                what: "u",
                rank: 1,
                ..
            }
        ),
        "{err}"
    );
    let err = iv_identify(
        &[IvExperiment {
            u: &u,
            y: &y,
            instrument: None,
        }],
        &IvOptions::default(),
    )
    .unwrap_err();
    assert!(
        matches!(
            err,
            Error::NotExciting {
                what: "instrument",
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn nan_is_rejected() {
    let (u, mut y) = data();
    y[(17, 0)] = f64::NAN;
    let err = identify(&[Experiment { u: &u, y: &y }], &SubspaceOptions::default()).unwrap_err();
    assert!(
        matches!(
            err,
            Error::NonFinite {
                what: "y",
                row: 17,
                col: 0
            }
        ),
        "{err}"
    );
    let mut u2 = u.clone();
    u2[(3, 0)] = f64::INFINITY;
    let err = iv_identify(
        &[IvExperiment {
            u: &u2,
            y: &y,
            instrument: None,
        }],
        &IvOptions::default(),
    )
    .unwrap_err();
    assert!(
        matches!(
            err,
            Error::NonFinite {
                what: "u",
                row: 3,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn mismatched_records_and_short_instrument() {
    let (u, y) = data();
    let y2 = DMatrix::zeros(400, 1);
    let err = identify(&[Experiment { u: &u, y: &y2 }], &SubspaceOptions::default()).unwrap_err();
    assert!(matches!(err, Error::DimensionMismatch { .. }), "{err}");
    assert!(matches!(
        identify(&[], &SubspaceOptions::default()),
        Err(Error::NoData)
    ));
    let opts = IvOptions {
        alpha: 8,
        alpha_p: Some(8),
        ..Default::default()
    };
    let err = iv_identify(
        &[IvExperiment {
            u: &u,
            y: &y,
            instrument: None,
        }],
        &opts,
    )
    .unwrap_err();
    assert!(
        matches!(
            err,
            Error::InvalidHorizon {
                what: "alpha_p",
                ..
            }
        ),
        "{err}"
    );
    let opts = IvOptions {
        alpha: 8,
        alpha_p: Some(9),
        order: OrderSelection::Fixed(3),
        ..Default::default()
    };
    let err = iv_identify(
        &[IvExperiment {
            u: &u,
            y: &y,
            instrument: None,
        }],
        &opts,
    )
    .unwrap_err();
    assert!(matches!(err, Error::InstrumentTooShort { .. }), "{err}");
    let mask = Feedthrough::Mask(DMatrix::from_element(2, 2, true));
    let opts = SubspaceOptions {
        feedthrough: mask,
        order: OrderSelection::Fixed(2),
        ..Default::default()
    };
    let err = identify(&[Experiment { u: &u, y: &y }], &opts).unwrap_err();
    assert!(
        matches!(
            err,
            Error::DimensionMismatch {
                what: "feedthrough mask",
                ..
            }
        ),
        "{err}"
    );
}

use super::common::*;
use lifted_lti::StateSpace;
use lifted_mpc::*;
use nalgebra::{DMatrix, DVector, dmatrix, dvector};

fn siso() -> StateSpace {
    tf(&[0.1, 0.05], &[1.0, -1.2, 0.35])
}

#[test]
fn zero_horizons() {
    for (hp, hc) in [(0, 0), (12, 0), (0, 3)] {
        let o = MpcOptions {
            prediction_horizon: hp,
            control_horizon: hc,
            ..MpcOptions::default()
        };
        assert!(matches!(
            StateSpaceMpc::new(&siso(), &o),
            Err(Error::InvalidHorizon { .. })
        ));
        assert!(matches!(
            Dmc::new(&siso(), 50, &o),
            Err(Error::InvalidHorizon { .. })
        ));
    }
}

#[test]
fn control_horizon_above_prediction() {
    let o = MpcOptions {
        prediction_horizon: 3,
        control_horizon: 4,
        ..MpcOptions::default()
    };
    assert!(matches!(
        StateSpaceMpc::new(&siso(), &o),
        Err(Error::InvalidHorizon {
            prediction: 3,
            control: 4
        })
    ));
}

#[test]
fn negative_definite_weights() {
    let o = MpcOptions {
        output_weight: Some(dmatrix![-1.0]),
        ..MpcOptions::default()
    };
    assert!(matches!(
        StateSpaceMpc::new(&siso(), &o),
        Err(Error::NotPositiveDefinite { .. })
    ));
    let o = MpcOptions {
        move_weight: Some(dmatrix![-0.5]),
        ..MpcOptions::default()
    };
    assert!(matches!(
        Dmc::new(&siso(), 50, &o),
        Err(Error::NotPositiveDefinite { .. })
    ));
    let o = MpcOptions {
        output_weight: Some(dmatrix![1.0, 0.0; 0.0, 1.0]),
        ..MpcOptions::default()
    };
    assert!(matches!(
        StateSpaceMpc::new(&siso(), &o),
        Err(Error::DimensionMismatch { .. })
    ));
    let o = MpcOptions {
        move_weight: Some(dmatrix![f64::NAN]),
        ..MpcOptions::default()
    };
    assert!(matches!(
        StateSpaceMpc::new(&siso(), &o),
        Err(Error::NonFinite { .. })
    ));
}

#[test]
fn dmc_refuses_an_unstable_model() {
    // Pole 1.1: the truncated step response does not stand for it (the
    // loop diverged to y = −6.4 after 40 steps without a word).
    let unstable = tf(&[1.0], &[1.0, -1.1]);
    match Dmc::new(&unstable, 50, &MpcOptions::default()) {
        Err(Error::InvalidModel { reason, .. }) => {
            assert!(reason.contains("stable model"), "{reason}")
        }
        other => panic!("{other:?}"),
    }
    assert!(StateSpaceMpc::new(&unstable, &MpcOptions::default()).is_ok());
}

#[test]
fn dmc_predictions_reject_non_finite_outputs() {
    let d = Dmc::new(&siso(), 50, &MpcOptions::default()).unwrap();
    let bad = DVector::from_element(1, f64::NAN);
    assert!(matches!(
        d.free_response(&bad, &[]),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        d.intersample_estimate(&bad, &[], &[]),
        Err(Error::NonFinite { .. })
    ));
    assert!(d.free_response(&DVector::from_element(1, 0.5), &[]).is_ok());
}

#[test]
fn singular_hessian() {
    // Q = 0 and R = 0: no unique move
    let o = MpcOptions {
        output_weight: Some(dmatrix![0.0]),
        move_weight: Some(dmatrix![0.0]),
        ..MpcOptions::default()
    };
    assert!(matches!(
        StateSpaceMpc::new(&siso(), &o),
        Err(Error::NotPositiveDefinite { .. })
    ));
}

#[test]
fn model_plant_dimension_mismatch() {
    let mut c = StateSpaceMpc::new(&siso(), &MpcOptions::default()).unwrap();
    let r = DMatrix::from_element(10, 2, 1.0);
    let err = simulate(&tank(), &mut c, &LoopSetup::new(r, vec![1, 1])).unwrap_err();
    assert!(matches!(err, Error::DimensionMismatch { .. }), "{err}");
    let err = c
        .update(&[Some(1.0), Some(2.0)], &dvector![0.0])
        .unwrap_err();
    assert!(matches!(err, Error::DimensionMismatch { .. }));
    assert!(matches!(
        DualRateLoop::new(&tank(), &siso(), &siso(), 2),
        Err(Error::DimensionMismatch { .. })
    ));
}

#[test]
fn inconsistent_constraints() {
    let bad = [
        Constraints {
            u_min: Some(dvector![1.0]),
            u_max: Some(dvector![0.0]),
            ..Constraints::default()
        },
        Constraints {
            y_min: Some(dvector![1.0]),
            y_max: Some(dvector![0.0]),
            ..Constraints::default()
        },
        Constraints {
            du_max: Some(dvector![-0.1]),
            ..Constraints::default()
        },
    ];
    for c in bad {
        let o = MpcOptions {
            constraints: c,
            ..MpcOptions::default()
        };
        assert!(matches!(
            StateSpaceMpc::new(&siso(), &o),
            Err(Error::InvalidConstraint { .. })
        ));
    }
    let o = MpcOptions {
        constraints: Constraints {
            u_max: Some(dvector![1.0, 2.0]),
            ..Constraints::default()
        },
        ..MpcOptions::default()
    };
    assert!(matches!(
        StateSpaceMpc::new(&siso(), &o),
        Err(Error::DimensionMismatch { .. })
    ));
}

#[test]
fn models_that_are_not_discrete_strictly_proper() {
    let cont = StateSpace::new(
        dmatrix![-1.0],
        dmatrix![1.0],
        dmatrix![1.0],
        dmatrix![0.0],
        None,
    )
    .unwrap();
    assert!(matches!(
        StateSpaceMpc::new(&cont, &MpcOptions::default()),
        Err(Error::InvalidModel { .. })
    ));
    let proper = StateSpace::new(
        dmatrix![0.5],
        dmatrix![1.0],
        dmatrix![1.0],
        dmatrix![1.0],
        Some(1.0),
    )
    .unwrap();
    assert!(matches!(
        Dmc::new(&proper, 50, &MpcOptions::default()),
        Err(Error::InvalidModel { .. })
    ));
    assert!(matches!(
        hold_model(&siso(), 0),
        Err(Error::InvalidArgument { .. })
    ));
    assert!(matches!(
        Dmc::new(&siso(), 5, &MpcOptions::default()),
        Err(Error::InvalidArgument { .. })
    ));
}

#[test]
fn non_finite_and_missing_measurements() {
    let mut c = StateSpaceMpc::new(&siso(), &MpcOptions::default()).unwrap();
    assert!(matches!(
        c.update(&[Some(f64::NAN)], &dvector![0.0]),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        c.update(&[None], &dvector![0.0]),
        Err(Error::InvalidArgument { .. })
    ));
    let mut d = Dmc::new(&siso(), 50, &MpcOptions::default()).unwrap();
    assert!(matches!(
        d.update(&[Some(0.0)], &dvector![f64::INFINITY]),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        d.update(&[None], &dvector![0.0]),
        Err(Error::InvalidArgument { .. })
    ));
}

#[test]
fn robustness_needs_nominal_stability_and_fitting_sizes() {
    let (phat, _, _, w1) = example96();
    let destabilising = tf(&[-30.0, 0.0], &[1.0, -1.0]);
    assert!(matches!(
        beta_sr(&phat, &destabilising, &w1, Uncertainty::Additive),
        Err(Error::Unstable { .. })
    ));
    // a 2x2 model with a SISO controller: the sizes do not fit
    assert!(matches!(
        beta_dr(
            &tank(),
            &phat,
            &w1,
            Uncertainty::Additive,
            2,
            &RobustnessOptions::default()
        ),
        Err(Error::DimensionMismatch { .. })
    ));
    let (phat, k, _, w1) = example96();
    assert!(matches!(
        beta_dr(
            &phat,
            &k,
            &w1,
            Uncertainty::Additive,
            0,
            &RobustnessOptions::default()
        ),
        Err(Error::InvalidArgument { .. })
    ));
    assert!(matches!(
        DualRateLoop::new(&phat, &phat, &k, 0),
        Err(Error::InvalidArgument { .. })
    ));
}

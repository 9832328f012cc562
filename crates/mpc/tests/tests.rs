//! Integration tests of `lifted-mpc`.

mod common {
    use lifted_lti::{StateSpace, TransferFunction};
    use nalgebra::{DMatrix, dmatrix, dvector};

    /// The A3.7 stirred-tank fast model (2x2).
    pub fn tank() -> StateSpace {
        let a = DMatrix::from_diagonal(&dvector![0.9868, 0.97, 0.9131, 0.9048]);
        let b = dmatrix![1.0, 0.0; 0.0, 1.0; 1.0, 0.0; 0.0, 1.0];
        let c = dmatrix![0.1416, -0.03, 0.0, 0.0; 0.0, 0.0, -0.0379, 0.0595];
        StateSpace::new(a, b, c, DMatrix::zeros(2, 2), Some(1.0)).unwrap()
    }

    /// Discrete SISO model from z-domain coefficients (descending powers), T = 1.
    pub fn tf(num: &[f64], den: &[f64]) -> StateSpace {
        TransferFunction::from_coeffs(num, den, Some(1.0))
            .and_then(|t| t.to_ss())
            .unwrap()
    }

    /// The §9.6 example: (P̂, K, P, W₁).
    pub fn example96() -> (StateSpace, StateSpace, StateSpace, StateSpace) {
        let phat = tf(&[0.15], &[1.0, -0.9]);
        // K = 3 + 0.5/(1 − z⁻¹) = (3.5 z − 3)/(z − 1)
        let k = tf(&[3.5, -3.0], &[1.0, -1.0]);
        let p = tf(&[0.13], &[1.0, -0.92, 0.0, 0.0, 0.0]);
        let w1 = tf(
            &[0.15, -0.138, 0.0, -0.13, 0.117],
            &[1.0, -1.82, 0.828, 0.0, 0.0, 0.0],
        );
        (phat, k, p, w1)
    }
}

mod qp {
    use super::common::*;
    use lifted_mpc::*;
    use nalgebra::{DMatrix, DVector, dvector};

    fn siso() -> lifted_lti::StateSpace {
        tf(&[0.1, 0.05], &[1.0, -1.2, 0.35])
    }

    #[test]
    fn qp_equals_closed_form_when_inactive() {
        // generous limits: never active
        let opts = MpcOptions {
            constraints: Constraints {
                u_min: Some(dvector![-100.0]),
                u_max: Some(dvector![100.0]),
                du_max: Some(dvector![100.0]),
                y_min: Some(dvector![-100.0]),
                y_max: Some(dvector![100.0]),
            },
            ..MpcOptions::default()
        };
        let plant = siso();
        let mut a = StateSpaceMpc::new(&plant, &opts).unwrap();
        let mut b = StateSpaceMpc::new(&plant, &opts).unwrap();
        let mut x = DVector::zeros(plant.order());
        let r = dvector![1.0];
        for _ in 0..40 {
            let y = (plant.c() * &x)[0];
            let (ua, pa) = a.update_with_plan(&[Some(y)], &r).unwrap();
            let (ub, pb) = b.update_qp(&[Some(y)], &r).unwrap();
            assert!(!pa.constrained && pb.constrained);
            assert!((&pa.du - &pb.du).amax() < 1e-6, "{} vs {}", pa.du, pb.du);
            assert!((ua[0] - ub[0]).abs() < 1e-6);
            x = plant.a() * x + plant.b() * ua;
        }
    }

    #[test]
    fn limits_respected_when_active() {
        let plant = tank();
        let opts = MpcOptions {
            prediction_horizon: 20,
            control_horizon: 5,
            constraints: Constraints {
                u_min: Some(dvector![-0.3, -0.3]),
                u_max: Some(dvector![0.3, 0.3]),
                du_max: Some(dvector![0.05, 0.05]),
                ..Constraints::default()
            },
            ..MpcOptions::default()
        };
        let mut ctrl = StateSpaceMpc::new(&plant, &opts).unwrap();
        let r = DMatrix::from_fn(300, 2, |_, c| if c == 0 { 1.0 } else { -0.5 });
        let run = simulate(&plant, &mut ctrl, &LoopSetup::new(r, vec![10, 1])).unwrap();
        let mut prev: DVector<f64> = DVector::zeros(2);
        let mut active = false;
        for t in 0..300 {
            let u = run.u.row(t).transpose();
            for c in 0..2 {
                assert!(u[c] <= 0.3 + 1e-7 && u[c] >= -0.3 - 1e-7, "u = {u}");
                assert!((u[c] - prev[c]).abs() <= 0.05 + 1e-7);
                active |=
                    (u[c].abs() - 0.3).abs() < 1e-6 || ((u[c] - prev[c]).abs() - 0.05).abs() < 1e-6;
            }
            prev = u;
        }
        assert!(active, "limits never active: test is vacuous");
        // without limits the same loop exceeds them
        let mut free = StateSpaceMpc::new(
            &plant,
            &MpcOptions {
                constraints: Constraints::default(),
                ..opts
            },
        )
        .unwrap();
        let r = DMatrix::from_fn(300, 2, |_, c| if c == 0 { 1.0 } else { -0.5 });
        let run2 = simulate(&plant, &mut free, &LoopSetup::new(r, vec![10, 1])).unwrap();
        assert!(run2.u.amax() > 0.3);
    }

    #[test]
    fn output_limit_respected() {
        let plant = siso();
        let opts = MpcOptions {
            constraints: Constraints {
                y_max: Some(dvector![1.0]),
                ..Constraints::default()
            },
            ..MpcOptions::default()
        };
        // aggressive tuning overshoots without the limit
        let tuned = MpcOptions {
            move_weight: Some(DMatrix::from_element(1, 1, 0.001)),
            ..opts.clone()
        };
        let r = DMatrix::from_element(100, 1, 1.0);
        let mut c = StateSpaceMpc::new(&plant, &tuned).unwrap();
        let run = simulate(&plant, &mut c, &LoopSetup::new(r.clone(), vec![1])).unwrap();
        assert!(run.y.max() <= 1.0 + 1e-6, "peak {}", run.y.max());
        let mut c2 = StateSpaceMpc::new(
            &plant,
            &MpcOptions {
                constraints: Constraints::default(),
                ..tuned
            },
        )
        .unwrap();
        let run2 = simulate(&plant, &mut c2, &LoopSetup::new(r, vec![1])).unwrap();
        assert!((run2.y.max() - 1.0).abs() < 0.5);
    }

    #[test]
    fn infeasible_is_a_named_error() {
        // two-sample delay: ŷ(t+1) does not depend on Δu(t); y = 2 > y_max = 1
        let plant = tf(&[0.1], &[1.0, -0.9, 0.0]);
        let opts = MpcOptions {
            constraints: Constraints {
                y_max: Some(dvector![1.0]),
                ..Constraints::default()
            },
            ..MpcOptions::default()
        };
        let mut c = StateSpaceMpc::new(&plant, &opts).unwrap();
        let err = c.update(&[Some(2.0)], &dvector![0.0]).unwrap_err();
        assert!(matches!(err, Error::Infeasible { .. }), "{err}");
    }
}

mod bad_input {
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
}

mod predictions {
    use super::common::*;
    use lifted_mpc::*;
    use nalgebra::{DVector, dvector};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn mimo_dmc_and_state_space_predictions_agree() {
        let plant = tank();
        let opts = MpcOptions {
            prediction_horizon: 15,
            control_horizon: 4,
            ..MpcOptions::default()
        };
        let dmc = Dmc::new(&plant, 300, &opts).unwrap();
        let ss = StateSpaceMpc::new(&plant, &opts).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let moves: Vec<DVector<f64>> = (0..60)
            .map(|_| DVector::from_fn(2, |_, _| rng.random::<f64>() - 0.5))
            .collect();
        let (ai, bi, _) = integrated_model(&plant).unwrap();
        let mut x = DVector::zeros(ai.nrows());
        for du in &moves {
            x = &ai * x + &bi * du;
        }
        let past: Vec<DVector<f64>> = moves.iter().rev().cloned().collect();
        let future = DVector::from_fn(8, |_, _| rng.random::<f64>() - 0.5);
        let y = dvector![0.3, -0.2];
        let a = dmc.predict(&y, &past, &future).unwrap();
        let b = ss.predict(&x, &y, &future).unwrap();
        assert!((a - b).amax() < 1e-10);
        assert_eq!(dmc.law().dynamic_matrix(), ss.law().dynamic_matrix());
    }

    #[test]
    fn dmc_from_step_test_equals_model_based() {
        let plant = tank();
        let opts = MpcOptions::default();
        let steps = step_coefficients(&plant, 200).unwrap();
        let mut a = Dmc::from_steps(steps, &opts).unwrap();
        let mut b = Dmc::new(&plant, 200, &opts).unwrap();
        let r = nalgebra::DMatrix::from_fn(50, 2, |_, c| c as f64 + 0.5);
        let ya = simulate(&plant, &mut a, &LoopSetup::new(r.clone(), vec![10, 1]))
            .unwrap()
            .y;
        let yb = simulate(&plant, &mut b, &LoopSetup::new(r, vec![10, 1]))
            .unwrap()
            .y;
        assert_eq!(ya, yb);
        assert!(matches!(
            Dmc::from_steps(vec![], &opts),
            Err(Error::InvalidArgument { .. })
        ));
        let bad = vec![nalgebra::DMatrix::from_element(1, 1, 1.0); 20];
        assert!(matches!(
            Dmc::from_steps(bad, &opts),
            Err(Error::InvalidArgument { .. })
        ));
    }

    #[test]
    fn slow_rate_wrapper_holds_input() {
        let plant = tank();
        let slow = hold_model(&plant, 5).unwrap();
        let mut c = SlowRate::new(
            StateSpaceMpc::new(&slow, &MpcOptions::default()).unwrap(),
            5,
        )
        .unwrap();
        let r = nalgebra::DMatrix::from_fn(100, 2, |_, ch| if ch == 0 { 1.0 } else { 0.0 });
        let run = simulate(&plant, &mut c, &LoopSetup::new(r, vec![5, 5])).unwrap();
        for t in 0..100 {
            if t % 5 != 0 {
                assert_eq!(run.u.row(t), run.u.row(t - 1));
            }
        }
        assert!((run.y[(95, 0)] - 1.0).abs() < 1e-3);
    }

    #[test]
    fn performance_figures() {
        let r = nalgebra::DMatrix::from_element(6, 1, 1.0);
        let y = nalgebra::DMatrix::from_column_slice(6, 1, &[0.0, 0.5, 1.2, 1.01, 1.0, 1.0]);
        let u = nalgebra::DMatrix::from_element(6, 1, 2.0);
        let p = performance(&y, &u, &r, 0.02).unwrap();
        assert!((p.iae[0] - (1.0 + 0.5 + 0.2 + 0.01)).abs() < 1e-12);
        assert!((p.overshoot[0] - 0.2).abs() < 1e-12);
        assert_eq!(p.settling_time[0], Some(3));
        assert!((p.input_energy - 24.0).abs() < 1e-12);
    }
}

mod chapter9 {
    use super::common::*;
    use lifted_mpc::*;
    use nalgebra::{DMatrix, dvector};
    use num_complex::Complex64;
    use proptest::prelude::*;

    #[test]
    fn example_96_betas() {
        let (phat, k, _, w1) = example96();
        let o = RobustnessOptions::default();
        let sr = beta_sr(&phat, &k, &w1, Uncertainty::Additive).unwrap();
        assert!((sr.value - 1.2582).abs() < 1e-3);
        let b1 = beta_dr(&phat, &k, &w1, Uncertainty::Additive, 1, &o).unwrap();
        assert!(
            (b1.value - sr.value).abs() < 1e-8,
            "n = 1 is the single-rate loop"
        );
        let b4 = beta_dr(&phat, &k, &w1, Uncertainty::Additive, 4, &o).unwrap();
        assert!((b4.value - 0.9071).abs() < 1e-3);
    }

    #[test]
    fn example_96_stability() {
        let (phat, k, p, _) = example96();
        assert!(
            DualRateLoop::new(&p, &phat, &k, 1)
                .unwrap()
                .spectral_radius()
                .unwrap()
                > 1.02
        );
        let l = DualRateLoop::new(&p, &phat, &k, 4).unwrap();
        assert!(l.spectral_radius().unwrap() < 0.75);
        let y = l
            .simulate(&DMatrix::from_element(200, 1, 1.0), None)
            .unwrap()
            .y;
        assert!(y.amax() < 1.3);
        // the lifted closed loop has the monodromy matrix as its A
        assert!((l.lifted().unwrap().a() - l.monodromy()).amax() < 1e-14);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        /// Lifted response = V diag(G(e^{j(θ+2πl)/n})) Vᴴ with V_{il} = e^{jω_l i}/√n.
        #[test]
        fn lifted_response_is_alias_form(pole in -0.9f64..0.9, zero in -2.0f64..2.0, n in 1usize..6, theta in 0.01f64..3.1) {
            let g = tf(&[1.0, -zero], &[1.0, -pole, 0.0]);
            let lifted = lifted_response(&g, n, theta).unwrap();
            let w: Vec<f64> = (0..n).map(|l| (theta + 2.0 * std::f64::consts::PI * l as f64) / n as f64).collect();
            let gv: Vec<Complex64> = w.iter().map(|&wl| g.eval_complex(Complex64::from_polar(1.0, wl)).unwrap()[(0, 0)]).collect();
            for i in 0..n {
                for j in 0..n {
                    let mut acc = Complex64::new(0.0, 0.0);
                    for l in 0..n {
                        acc += gv[l] * Complex64::from_polar(1.0, w[l] * (i as f64 - j as f64));
                    }
                    acc /= n as f64;
                    prop_assert!((acc - lifted[(i, j)]).norm() < 1e-10);
                }
            }
        }

        /// Without mismatch and disturbance the dual-rate loop is the single-rate loop (§9.4).
        #[test]
        fn no_mismatch_dual_rate_equals_single_rate(pole in 0.0f64..0.95, gain in 0.05f64..0.5, kp in 0.1f64..2.0, n in 2usize..7) {
            let p = tf(&[gain], &[1.0, -pole]);
            let k = tf(&[kp + 0.1, -kp], &[1.0, -1.0]);
            let r = DMatrix::from_element(60, 1, 1.0);
            let a = DualRateLoop::new(&p, &p, &k, n).unwrap().simulate(&r, None).unwrap().y;
            let b = DualRateLoop::new(&p, &p, &k, 1).unwrap().simulate(&r, None).unwrap().y;
            prop_assert!((a - b).amax() < 1e-9);
        }

        /// Cor. 1: β_dr ≤ β_sr for every admissible triple.
        #[test]
        fn beta_dr_below_beta_sr(pole in -0.8f64..0.9, wpole in -0.8f64..0.8, n in 2usize..6) {
            let phat = tf(&[0.2], &[1.0, -pole]);
            let k = tf(&[1.1, -1.0], &[1.0, -1.0]);
            let w = tf(&[0.3], &[1.0, -wpole]);
            if let Ok(sr) = beta_sr(&phat, &k, &w, Uncertainty::Multiplicative) {
                let dr = beta_dr(&phat, &k, &w, Uncertainty::Multiplicative, n, &RobustnessOptions { grid: 300, ..Default::default() }).unwrap();
                prop_assert!(dr.value <= sr.value + 1e-9);
            }
        }
    }

    #[test]
    fn intersample_estimate_example() {
        // with n = 1 every sample is measured: inferential = fast
        let p = tf(&[0.15], &[1.0, -0.9]);
        let mut a = StateSpaceMpc::new(&p, &MpcOptions::default()).unwrap();
        let u = a.update(&[Some(0.0)], &dvector![1.0]).unwrap();
        assert!(u[0] > 0.0);
    }
}

mod conic_measures {
    //! β via the conic form of (9.8), MIMO β, and Prop. 5 as SOCPs.
    use super::common::*;
    use lifted_lti::{HinfOptions, StateSpace, append};
    use lifted_mpc::*;
    use nalgebra::{DMatrix, DVector, dmatrix};
    use num_complex::Complex64;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Bound on max_θ f − max_k f(θ_k) for the grid θ_k = π(k+½)/K: the
    /// supremum θ* lies within h/2 = π/(2K) of a grid point and f′(θ*) = 0
    /// (interior maximum, or θ* = π where f is even about π), so the loss is
    /// at most ½·max|f″|·(h/2)². |f″| is estimated by a central difference
    /// (δ = 1e-3) at θ* and doubled for its variation over h/2; 1e-8 covers
    /// the solver tolerance (1e-10 relative).
    fn grid_bound(t: &StateSpace, n: usize, theta: f64, grid: usize) -> f64 {
        let f = |th: f64| alias_gain(t, n, th).unwrap();
        let d = 1e-3;
        let f2 = ((f(theta + d) - 2.0 * f(theta) + f(theta - d)) / (d * d)).abs();
        let h = std::f64::consts::PI / grid as f64;
        0.5 * 2.0 * f2 * (h / 2.0).powi(2) + 1e-8
    }

    /// T̲R₁ as a lifted state space (its first p inputs), for the exact
    /// Hamiltonian H∞ norm of `lifted-lti` — independent of any θ grid.
    fn lifted_switched(t: &StateSpace, n: usize) -> StateSpace {
        let tl = lift(t, n).unwrap();
        let p = t.n_inputs();
        StateSpace::new(
            tl.a().clone(),
            tl.b().columns(0, p).into_owned(),
            tl.c().clone(),
            tl.d().columns(0, p).into_owned(),
            tl.ts(),
        )
        .unwrap()
    }

    fn hinf(s: &StateSpace) -> f64 {
        s.hinf_norm(&HinfOptions {
            rel_tol: 1e-12,
            ..HinfOptions::default()
        })
        .unwrap()
        .norm
    }

    /// 2×2 case: tank model, diagonal PI, coupled first-order weight.
    fn mimo() -> (StateSpace, StateSpace, StateSpace) {
        let k = append(
            &tf(&[3.0, -2.8], &[1.0, -1.0]),
            &tf(&[4.0, -3.7], &[1.0, -1.0]),
        )
        .unwrap();
        let w = StateSpace::new(
            dmatrix![0.5, 0.0; 0.0, 0.3],
            dmatrix![0.1, 0.02; -0.03, 0.08],
            dmatrix![1.0, 0.2; 0.0, 1.0],
            dmatrix![0.01, 0.0; 0.0, 0.02],
            Some(1.0),
        )
        .unwrap();
        (tank(), k, w)
    }

    #[test]
    fn socp_beta_matches_closed_form_example96() {
        // spec A3.11 figures; the closed form and the SOCP are compared with the grid bound
        let (phat, k, _, w1) = example96();
        let t = robustness_map(&phat, &k, &w1, Uncertainty::Additive).unwrap();
        let opts = ConicOptions::default();
        for (n, paper) in [
            (1, 1.2582),
            (2, 0.9220),
            (3, 0.9975),
            (4, 0.9071),
            (5, 0.8488),
            (8, 0.7826),
        ] {
            let cf = beta_dr(
                &phat,
                &k,
                &w1,
                Uncertainty::Additive,
                n,
                &RobustnessOptions::default(),
            )
            .unwrap();
            let s = beta_socp(&phat, &k, &w1, Uncertainty::Additive, n, &opts).unwrap();
            let bound = grid_bound(&t, n, cf.theta, opts.grid);
            assert_eq!(s.rounds, 1, "SISO: one SOCP, no cutting planes");
            assert!(
                cf.value - s.value <= bound,
                "n = {n}: {} vs {} (bound {bound:e})",
                cf.value,
                s.value
            );
            assert!(
                s.value - cf.value <= 1e-8,
                "the grid optimum cannot exceed the supremum"
            );
            assert!((s.value - s.grid_max).abs() <= 1e-8);
            assert!((s.value - paper).abs() < 1e-3);
        }
    }

    #[test]
    fn mimo_beta_three_routes_and_exact_lifted_hinf() {
        let (p, k, w) = mimo();
        let o = RobustnessOptions::default();
        for unc in [Uncertainty::Additive, Uncertainty::Multiplicative] {
            let t = robustness_map(&p, &k, &w, unc).unwrap();
            let sr = beta_sr(&p, &k, &w, unc).unwrap();
            for n in 1..=4 {
                let cf = beta_dr(&p, &k, &w, unc, n, &o).unwrap();
                let bf = beta_dr_lifted(&p, &k, &w, unc, n, &o).unwrap();
                let exact = hinf(&lifted_switched(&t, n));
                let s = beta_socp(&p, &k, &w, unc, n, &ConicOptions::default()).unwrap();
                // closed form and brute force maximise to θ_tol 1e-10; Hamiltonian to 1e-12
                assert!(
                    (cf.value - exact).abs() < 1e-8 * exact,
                    "{unc:?} n = {n}: {} vs {exact}",
                    cf.value
                );
                assert!((bf.value - exact).abs() < 1e-8 * exact);
                let bound = grid_bound(&t, n, cf.theta, ConicOptions::default().grid);
                assert!(
                    exact - s.value <= bound && s.value <= exact + 1e-8,
                    "{unc:?} n = {n}: socp {} vs {exact}",
                    s.value
                );
                // Cor. 1 and the lower bound β_sr/√n
                assert!(cf.value <= sr.value + 1e-9);
                assert!(cf.value >= sr.value / (n as f64).sqrt() - 1e-9);
                if n == 1 {
                    assert!((cf.value - sr.value).abs() < 1e-8 * sr.value);
                }
            }
        }
    }

    #[test]
    fn block_diagonal_beta_is_the_larger_siso_beta() {
        let p1 = tf(&[0.15], &[1.0, -0.9]);
        let p2 = tf(&[0.2, 0.05], &[1.0, -0.7, 0.1]);
        let k1 = tf(&[3.5, -3.0], &[1.0, -1.0]);
        let k2 = tf(&[1.2, -1.0], &[1.0, -1.0]);
        let w1 = tf(&[0.1], &[1.0, -0.5]);
        let w2 = tf(&[0.3, 0.1], &[1.0, 0.2, 0.0]);
        let (p, k, w) = (
            append(&p1, &p2).unwrap(),
            append(&k1, &k2).unwrap(),
            append(&w1, &w2).unwrap(),
        );
        let o = RobustnessOptions::default();
        for n in [2, 3, 5] {
            let a = beta_dr(&p1, &k1, &w1, Uncertainty::Additive, n, &o)
                .unwrap()
                .value;
            let b = beta_dr(&p2, &k2, &w2, Uncertainty::Additive, n, &o)
                .unwrap()
                .value;
            let ab = beta_dr(&p, &k, &w, Uncertainty::Additive, n, &o)
                .unwrap()
                .value;
            assert!(
                (ab - a.max(b)).abs() < 1e-9,
                "n = {n}: {ab} vs max({a}, {b})"
            );
        }
    }

    #[test]
    fn mimo_dimension_checks() {
        let (p, k, w) = mimo();
        let o = RobustnessOptions::default();
        let siso_k = tf(&[3.5, -3.0], &[1.0, -1.0]);
        assert!(matches!(
            beta_dr(&p, &siso_k, &w, Uncertainty::Additive, 2, &o),
            Err(Error::DimensionMismatch { .. })
        ));
        let w3 = StateSpace::new(
            dmatrix![0.5],
            dmatrix![1.0, 0.0, 0.0],
            dmatrix![1.0],
            dmatrix![0.0, 0.0, 0.0],
            Some(1.0),
        )
        .unwrap();
        assert!(matches!(
            beta_socp(
                &p,
                &k,
                &w3,
                Uncertainty::Multiplicative,
                2,
                &ConicOptions::default()
            ),
            Err(Error::DimensionMismatch { .. })
        ));
        assert!(matches!(
            beta_socp(
                &p,
                &k,
                &w,
                Uncertainty::Additive,
                2,
                &ConicOptions {
                    grid: 0,
                    ..ConicOptions::default()
                }
            ),
            Err(Error::InvalidArgument { .. })
        ));
        assert!(matches!(
            beta_socp(
                &p,
                &k,
                &w,
                Uncertainty::Additive,
                0,
                &ConicOptions::default()
            ),
            Err(Error::InvalidArgument { .. })
        ));
        let t = robustness_map(&p, &k, &w, Uncertainty::Additive).unwrap();
        assert!(matches!(
            alias_gain(&t, 0, 1.0),
            Err(Error::InvalidArgument { .. })
        ));
        assert!(matches!(
            alias_gain(&t, 2, f64::NAN),
            Err(Error::NonFinite { .. })
        ));
    }

    /// A realisation of the FIR Q(z) = Σ Q_i z^{−i} (m×p taps): states are
    /// the delayed inputs — independent of the tap algebra inside `prop5`.
    fn fir(taps: &[DMatrix<f64>]) -> StateSpace {
        let (m, p) = taps[0].shape();
        let l = taps.len();
        let nx = p * (l - 1);
        let mut a = DMatrix::zeros(nx, nx);
        for i in p..nx {
            a[(i, i - p)] = 1.0;
        }
        let mut b = DMatrix::zeros(nx, p);
        let mut c = DMatrix::zeros(m, nx);
        for i in 0..p.min(nx) {
            b[(i, i)] = 1.0;
        }
        for (i, q) in taps.iter().enumerate().skip(1) {
            c.columns_mut((i - 1) * p, p).copy_from(q);
        }
        StateSpace::new(a, b, c, taps[0].clone(), Some(1.0)).unwrap()
    }

    /// max over θ_k of σ_max((I − P̲Q̲R₁)W̲₂), from lifted state spaces.
    fn dual_rate_cost(
        p: &StateSpace,
        w2: &StateSpace,
        taps: &[DMatrix<f64>],
        n: usize,
        grid: usize,
    ) -> f64 {
        let (pl, ql, wl) = (
            lift(p, n).unwrap(),
            lift(&fir(taps), n).unwrap(),
            lift(w2, n).unwrap(),
        );
        let ny = p.n_outputs();
        (0..grid)
            .map(|k| {
                let z = Complex64::from_polar(
                    1.0,
                    std::f64::consts::PI * (k as f64 + 0.5) / grid as f64,
                );
                let mut q = ql.eval_complex(z).unwrap();
                for c in ny..q.ncols() {
                    q.column_mut(c).fill(Complex64::new(0.0, 0.0));
                }
                let w = wl.eval_complex(z).unwrap();
                sigma_max(&(&w - pl.eval_complex(z).unwrap() * q * &w)).unwrap()
            })
            .fold(0.0, f64::max)
    }

    /// max over the fast grid of σ_max((I − PQ)W₂).
    fn single_rate_cost(
        p: &StateSpace,
        w2: &StateSpace,
        taps: &[DMatrix<f64>],
        omegas: &[f64],
    ) -> f64 {
        let q = fir(taps);
        omegas
            .iter()
            .map(|&w| {
                let z = Complex64::from_polar(1.0, w);
                let wz = w2.eval_complex(z).unwrap();
                sigma_max(&(&wz - p.eval_complex(z).unwrap() * q.eval_complex(z).unwrap() * &wz))
                    .unwrap()
            })
            .fold(0.0, f64::max)
    }

    fn grid(k: usize) -> Vec<f64> {
        (0..k)
            .map(|i| std::f64::consts::PI * (i as f64 + 0.5) / k as f64)
            .collect()
    }

    #[test]
    fn gamma_sr_analytic_optimum() {
        // P = 0.15/(z − 0.9), W₂ = 0.2/(z − 0.8): ‖(1 − PQ)W₂‖∞ ≥ |first Markov
        // parameter of z·(1 − PQ)W₂| = 0.2 (P has one delay; maximum modulus), attained
        // by Q = (0.8/0.15)(1 − 0.9z⁻¹) (then (1 − PQ)W₂ = 0.2z⁻¹): an FIR of length 2.
        let p = tf(&[0.15], &[1.0, -0.9]);
        let w2 = tf(&[0.2], &[1.0, -0.8]);
        for l in [2, 5] {
            let r = gamma_sr(
                &p,
                &w2,
                &Prop5Options {
                    fir_length: l,
                    grid: 64,
                    ..Prop5Options::default()
                },
            )
            .unwrap();
            assert_eq!(r.rounds, 1);
            assert!((r.gamma - 0.2).abs() < 1e-7, "L = {l}: {}", r.gamma);
            assert!((r.lower_bound - 0.2).abs() < 1e-7);
            // on a grid the optimiser is not unique for L > 2; for L = 2 it is
            if l == 2 {
                assert!(
                    (r.taps[0][(0, 0)] - 0.8 / 0.15).abs() < 1e-4,
                    "{:?}",
                    r.taps
                );
                assert!((r.taps[1][(0, 0)] + 0.8 * 0.9 / 0.15).abs() < 1e-4);
            }
        }
    }

    #[test]
    fn gamma_sr_one_tap_equals_golden_section() {
        // L = 1: J(q) = max_k |(1 − P q)W₂| is convex in the scalar q; golden
        // section on [−100, 100] to 1e-11 is an independent minimiser.
        let p = tf(&[0.3, 0.1], &[1.0, -0.5, 0.06]);
        let w2 = tf(&[0.5], &[1.0, -0.6]);
        let omegas = grid(48);
        let j = |q: f64| single_rate_cost(&p, &w2, &[DMatrix::from_element(1, 1, q)], &omegas);
        let (mut a, mut b) = (-100.0f64, 100.0f64);
        let g = (5f64.sqrt() - 1.0) / 2.0;
        while b - a > 1e-11 {
            let (x1, x2) = (b - g * (b - a), a + g * (b - a));
            if j(x1) < j(x2) { b = x2 } else { a = x1 }
        }
        let r = gamma_sr(
            &p,
            &w2,
            &Prop5Options {
                fir_length: 1,
                grid: 48,
                ..Prop5Options::default()
            },
        )
        .unwrap();
        assert!(
            (r.gamma - j(0.5 * (a + b))).abs() < 1e-8,
            "{} vs {}",
            r.gamma,
            j(0.5 * (a + b))
        );
        assert!((r.gamma - single_rate_cost(&p, &w2, &r.taps, &omegas)).abs() < 1e-12);
    }

    #[test]
    fn prop5_siso_random_pairs() {
        let mut rng = ChaCha8Rng::seed_from_u64(55);
        let opts = Prop5Options {
            fir_length: 5,
            grid: 32,
            ..Prop5Options::default()
        };
        for _ in 0..4 {
            let pole = rng.random::<f64>() * 1.6 - 0.8;
            let zero = rng.random::<f64>() * 2.4 - 1.2; // may be non-minimum phase
            let p = tf(&[0.2, -0.2 * zero], &[1.0, -pole, 0.0]);
            let w2 = tf(&[0.4], &[1.0, -(rng.random::<f64>() * 1.6 - 0.8)]);
            let n = 2 + (rng.random::<f64>() * 3.0) as usize;
            let r = prop5(&p, &w2, n, &opts).unwrap();
            let (sr, dr) = (&r.single_rate, &r.dual_rate);
            assert!(
                dr.lower_bound >= sr.gamma - 1e-6,
                "Prop. 5: {} < {}",
                dr.lower_bound,
                sr.gamma
            );
            assert!(
                r.averaged >= sr.lower_bound - 1e-7 && r.averaged <= dr.gamma + 1e-9,
                "{r:?}"
            );
            // the costs at the returned taps, recomputed from FIR state spaces
            assert!(
                (dual_rate_cost(&p, &w2, &dr.taps, n, opts.grid) - dr.gamma).abs()
                    < 1e-10 * dr.gamma.max(1.0)
            );
            let omegas: Vec<f64> = grid(opts.grid)
                .iter()
                .flat_map(|t| {
                    (0..n).map(move |l| (t + 2.0 * std::f64::consts::PI * l as f64) / n as f64)
                })
                .collect();
            assert!(
                (single_rate_cost(&p, &w2, &sr.taps, &omegas) - sr.gamma).abs()
                    < 1e-10 * sr.gamma.max(1.0)
            );
            assert!(dr.gamma - dr.lower_bound <= 1e-6 * dr.gamma);
        }
    }

    #[test]
    fn prop5_mimo_2x2_certified_optimum() {
        // 2×2: the SOCP lower bound is a global certificate, so no tap vector
        // (random or near the optimum) may cost less than it.
        let p = tank();
        let w2 = StateSpace::new(
            dmatrix![0.8, 0.0; 0.0, 0.6],
            dmatrix![0.2, 0.0; 0.05, 0.3],
            dmatrix![1.0, 0.0; 0.0, 1.0],
            DMatrix::zeros(2, 2),
            Some(1.0),
        )
        .unwrap();
        let n = 2;
        let opts = Prop5Options {
            fir_length: 2,
            grid: 12,
            ..Prop5Options::default()
        };
        let r = prop5(&p, &w2, n, &opts).unwrap();
        let (sr, dr) = (&r.single_rate, &r.dual_rate);
        assert!(dr.lower_bound >= sr.gamma - 1e-6);
        assert!(r.averaged >= sr.lower_bound - 1e-7 && r.averaged <= dr.gamma + 1e-9);
        for m in [sr, dr] {
            assert!(m.gamma - m.lower_bound <= 1e-6 * m.gamma, "{m:?}");
        }
        assert!((dual_rate_cost(&p, &w2, &dr.taps, n, opts.grid) - dr.gamma).abs() < 1e-10);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let flat = |t: &[DMatrix<f64>]| {
            DVector::from_iterator(8, t.iter().flat_map(|q| q.iter().copied()))
        };
        let x0 = flat(&dr.taps);
        for scale in [1e-3, 1e-2, 0.1, 1.0, 10.0] {
            for _ in 0..10 {
                let x = &x0 + DVector::from_fn(8, |_, _| scale * (rng.random::<f64>() - 0.5));
                let taps: Vec<DMatrix<f64>> = (0..2)
                    .map(|i| DMatrix::from_column_slice(2, 2, &x.as_slice()[4 * i..4 * i + 4]))
                    .collect();
                let j = dual_rate_cost(&p, &w2, &taps, n, opts.grid);
                assert!(
                    j >= dr.lower_bound - 1e-9,
                    "cost {j} below the certificate {}",
                    dr.lower_bound
                );
            }
        }
    }

    #[test]
    fn prop5_rejects_bad_input() {
        let p = tf(&[0.15], &[1.0, -0.9]);
        let w2 = tf(&[0.2], &[1.0, -0.8]);
        let o = Prop5Options::default();
        let unstable = tf(&[0.1], &[1.0, -1.05]);
        assert!(matches!(
            gamma_sr(&unstable, &w2, &o),
            Err(Error::Unstable { .. })
        ));
        assert!(matches!(
            gamma_dr(&p, &unstable, 2, &o),
            Err(Error::Unstable { .. })
        ));
        assert!(matches!(
            prop5(&tank(), &w2, 2, &o),
            Err(Error::DimensionMismatch { .. })
        ));
        let cont = StateSpace::new(
            dmatrix![-1.0],
            dmatrix![1.0],
            dmatrix![1.0],
            dmatrix![0.0],
            None,
        )
        .unwrap();
        assert!(matches!(
            gamma_sr(&cont, &w2, &o),
            Err(Error::InvalidModel { .. })
        ));
        let slow = lifted_lti::TransferFunction::from_coeffs(&[0.2], &[1.0, -0.8], Some(2.0))
            .unwrap()
            .to_ss()
            .unwrap();
        assert!(matches!(
            gamma_sr(&p, &slow, &o),
            Err(Error::InvalidModel { .. })
        ));
        assert!(matches!(
            gamma_dr(&p, &w2, 0, &o),
            Err(Error::InvalidArgument { .. })
        ));
        assert!(matches!(
            gamma_sr(&p, &w2, &Prop5Options { fir_length: 0, ..o }),
            Err(Error::InvalidArgument { .. })
        ));
        assert!(matches!(
            gamma_sr(
                &p,
                &w2,
                &Prop5Options {
                    minimax: MinimaxOptions {
                        gap_tol: f64::NAN,
                        ..MinimaxOptions::default()
                    },
                    ..o
                }
            ),
            Err(Error::InvalidArgument { .. })
        ));
        // one cutting-plane round cannot close the dual-rate gap
        assert!(matches!(
            gamma_dr(
                &p,
                &w2,
                3,
                &Prop5Options {
                    minimax: MinimaxOptions {
                        max_rounds: 1,
                        ..MinimaxOptions::default()
                    },
                    ..o
                }
            ),
            Err(Error::NoConvergence { .. })
        ));
    }
}

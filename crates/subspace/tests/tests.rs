//! Integration tests of lifted-subspace: exact recovery, agreement of the
//! methods, noise models, IV methods and rejected inputs.

mod common {
    use lifted_lti::StateSpace;
    use nalgebra::{DMatrix, DVector};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    /// A stable system with the given real poles and complex pairs (r, θ),
    /// hidden behind a random similarity; B, C, D Gaussian.
    pub fn random_system(
        seed: u64,
        real: &[f64],
        pairs: &[(f64, f64)],
        nu: usize,
        ny: usize,
        with_d: bool,
    ) -> StateSpace {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = real.len() + 2 * pairs.len();
        let mut a = DMatrix::zeros(n, n);
        for (i, &p) in real.iter().enumerate() {
            a[(i, i)] = p;
        }
        for (k, &(r, th)) in pairs.iter().enumerate() {
            let i = real.len() + 2 * k;
            a[(i, i)] = r * th.cos();
            a[(i, i + 1)] = -r * th.sin();
            a[(i + 1, i)] = r * th.sin();
            a[(i + 1, i + 1)] = r * th.cos();
        }
        let mut gauss = |r: usize, c: usize| {
            DMatrix::from_fn(r, c, |_, _| rng.sample::<f64, _>(StandardNormal))
        };
        let t = gauss(n, n) + DMatrix::identity(n, n) * 3.0;
        let ti = t.clone().try_inverse().unwrap();
        let b = gauss(n, nu);
        let c = gauss(ny, n);
        let d = if with_d {
            gauss(ny, nu)
        } else {
            DMatrix::zeros(ny, nu)
        };
        StateSpace::new(&t * a * &ti, &t * b, c * ti, d, Some(1.0)).unwrap()
    }

    pub fn rbs(seed: u64, n: usize, m: usize) -> DMatrix<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        DMatrix::from_fn(n, m, |_, _| if rng.random::<bool>() { 1.0 } else { -1.0 })
    }

    pub fn white(seed: u64, n: usize, m: usize, sd: f64) -> DMatrix<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        DMatrix::from_fn(n, m, |_, _| sd * rng.sample::<f64, _>(StandardNormal))
    }

    /// Max relative frequency-response difference over a grid.
    pub fn freq_error(a: &StateSpace, b: &StateSpace) -> f64 {
        let w: Vec<f64> = (0..64).map(|k| 0.001 + k as f64 * 3.1 / 63.0).collect();
        let ga = a.freqresp(&w).unwrap();
        let gb = b.freqresp(&w).unwrap();
        let mut err: f64 = 0.0;
        for (x, y) in ga.iter().zip(gb.iter()) {
            let scale = y.iter().map(|v| v.norm()).fold(0.0, f64::max).max(1e-12);
            for (p, q) in x.iter().zip(y.iter()) {
                err = err.max((p - q).norm() / scale);
            }
        }
        err
    }

    pub fn sim(g: &StateSpace, u: &DMatrix<f64>, x0: Option<&DVector<f64>>) -> DMatrix<f64> {
        g.lsim(u, x0, None).unwrap().y
    }
}

mod suite {
    pub mod closed_loop;
    pub mod consistency;
    pub mod partial;
    pub mod two_pass;
}

mod exact {
    use super::common::*;
    use lifted_subspace::*;
    use nalgebra::DVector;

    #[test]
    fn sixth_order_three_inputs_two_outputs_all_methods() {
        let g = random_system(7, &[0.9, -0.5, 0.3], &[(0.8, 0.6)], 3, 2, true);
        assert_eq!(g.order(), 5);
        let g = random_system(7, &[0.9, -0.5], &[(0.8, 0.6), (0.6, 1.9)], 3, 2, true);
        assert_eq!(g.order(), 6);
        let u = rbs(1, 2000, 3);
        let x0 = DVector::from_vec(vec![1.0, -2.0, 0.5, 0.0, 1.0, 3.0]);
        let y = sim(&g, &u, Some(&x0));
        for method in [Method::N4sid, Method::Moesp, Method::Cva] {
            let opts = SubspaceOptions {
                method,
                past: 8,
                future: 8,
                order: OrderSelection::Gap { max: 12 },
                ..Default::default()
            };
            let fit = identify(&[Experiment { u: &u, y: &y }], &opts).unwrap();
            assert_eq!(
                fit.diagnostics.order, 6,
                "{method:?} gap rule {:?}",
                fit.diagnostics.singular_values
            );
            let err = freq_error(&fit.model, &g);
            assert!(err < 1e-8, "{method:?}: frequency response error {err:e}");
            // the estimated initial state reproduces the record exactly,
            // about the returned operating point: y = y₀ + G(u − u₀) + CAᵗx₀
            let op = fit.operating_point.clone().expect("means removed");
            let dev = sim(&fit.model, &op.remove_input(&u).unwrap(), Some(&fit.x0[0]));
            let yhat = op.add_output(&dev).unwrap();
            assert!((yhat - &y).norm() / y.norm() < 1e-8);
        }
    }

    #[test]
    fn two_records_are_merged() {
        let g = random_system(3, &[0.8, 0.4], &[(0.7, 0.9)], 2, 2, false);
        let (u1, u2) = (rbs(5, 300, 2), rbs(6, 250, 2));
        let y1 = sim(&g, &u1, None);
        let y2 = sim(&g, &u2, Some(&DVector::from_vec(vec![1.0, 1.0, -1.0, 0.5])));
        // The records start at rest in these units: x₀ of the first is 0
        // only for the data as given (with the means removed it is the
        // state of the deviation record).
        let opts = SubspaceOptions {
            order: OrderSelection::Fixed(4),
            past: 6,
            future: 6,
            feedthrough: Feedthrough::Zero,
            remove_means: false,
            ..Default::default()
        };
        let fit = identify(
            &[Experiment { u: &u1, y: &y1 }, Experiment { u: &u2, y: &y2 }],
            &opts,
        )
        .unwrap();
        assert!(freq_error(&fit.model, &g) < 1e-8);
        assert_eq!(fit.x0.len(), 2);
        assert!(fit.x0[0].norm() < 1e-8);
        assert!(fit.model.d().norm() == 0.0);
    }

    #[test]
    fn streaming_chunk_size_does_not_change_the_result() {
        let g = random_system(4, &[0.95, 0.5], &[], 1, 1, false);
        let u = rbs(9, 1500, 1);
        let y = sim(&g, &u, None) + white(10, 1500, 1, 0.05);
        let fit = |chunk| {
            let opts = SubspaceOptions {
                order: OrderSelection::Fixed(2),
                chunk_rows: chunk,
                ..Default::default()
            };
            identify(&[Experiment { u: &u, y: &y }], &opts).unwrap()
        };
        let (a, b) = (fit(37), fit(100_000));
        for (x, y) in a
            .diagnostics
            .singular_values
            .iter()
            .zip(&b.diagnostics.singular_values)
        {
            assert!((x - y).abs() < 1e-10 * (1.0 + y.abs()));
        }
        assert!(freq_error(&a.model, &b.model) < 1e-8);
    }
}

mod noise {
    use super::common::*;
    use lifted_lti::StateSpace;
    use lifted_subspace::*;
    use nalgebra::DMatrix;

    /// Innovation model x+ = Ax + Bu + Ke, y = Cx + e: the identified
    /// Kalman predictor must approach the true one.
    #[test]
    fn kalman_gain_of_an_innovation_model() {
        let a = DMatrix::from_row_slice(2, 2, &[0.8, 0.2, 0.0, 0.5]);
        let b = DMatrix::from_row_slice(2, 1, &[1.0, 0.5]);
        let k = DMatrix::from_row_slice(2, 1, &[0.4, 0.3]);
        let c = DMatrix::from_row_slice(1, 2, &[1.0, 0.0]);
        let n = 20000;
        let u = rbs(1, n, 1);
        let e = white(2, n, 1, 0.3);
        let mut bk = DMatrix::zeros(2, 2);
        bk.columns_mut(0, 1).copy_from(&b);
        bk.columns_mut(1, 1).copy_from(&k);
        let mut dk = DMatrix::zeros(1, 2);
        dk[(0, 1)] = 1.0;
        let g = StateSpace::new(a.clone(), bk, c.clone(), dk, Some(1.0)).unwrap();
        let mut ue = DMatrix::zeros(n, 2);
        ue.columns_mut(0, 1).copy_from(&u);
        ue.columns_mut(1, 1).copy_from(&e);
        let y = sim(&g, &ue, None);
        let opts = SubspaceOptions {
            order: OrderSelection::Fixed(2),
            feedthrough: Feedthrough::Zero,
            ..Default::default()
        };
        let fit = identify(&[Experiment { u: &u, y: &y }], &opts).unwrap();
        let kg = fit.kalman_gain.clone().expect("Kalman gain");
        // Compare the noise transfer C(zI − A)⁻¹K (similarity invariant)
        // through its first Markov parameters.
        let true_noise = StateSpace::new(a, k, c, DMatrix::zeros(1, 1), Some(1.0)).unwrap();
        let est_noise = StateSpace::new(
            fit.model.a().clone(),
            kg,
            fit.model.c().clone(),
            DMatrix::zeros(1, 1),
            Some(1.0),
        )
        .unwrap();
        let mt = true_noise.markov_parameters(4).unwrap();
        let me = est_noise.markov_parameters(4).unwrap();
        for i in 1..=4 {
            assert!(
                (mt[i][(0, 0)] - me[i][(0, 0)]).abs() < 0.05,
                "noise Markov {i}: {} vs {}",
                mt[i],
                me[i]
            );
        }
        let r = fit.noise.unwrap().r[(0, 0)];
        assert!((r - 0.09).abs() < 0.01, "innovation variance {r}");
        assert!(
            freq_error(
                &fit.model,
                &StateSpace::new(
                    g.a().clone(),
                    b,
                    g.c().clone(),
                    DMatrix::zeros(1, 1),
                    Some(1.0)
                )
                .unwrap()
            ) < 0.05
        );
    }

    #[test]
    fn stability_enforcement_gives_a_stable_model() {
        // A marginal integrator-like plant with heavy noise and short data.
        let g = random_system(11, &[0.999, 0.2], &[], 1, 1, false);
        let u = rbs(3, 200, 1);
        let y = sim(&g, &u, None) + white(4, 200, 1, 5.0);
        let opts = SubspaceOptions {
            order: OrderSelection::Fixed(2),
            past: 5,
            future: 5,
            enforce_stability: true,
            ..Default::default()
        };
        let fit = identify(&[Experiment { u: &u, y: &y }], &opts).unwrap();
        assert!(fit.model.is_stable(0.0).unwrap());
    }
}

mod iv {
    use super::common::*;
    use lifted_subspace::*;
    use nalgebra::DMatrix;

    #[test]
    fn open_loop_iv_is_exact_without_noise() {
        let g = random_system(21, &[0.9, 0.6], &[(0.7, 0.5)], 2, 2, true);
        let u = rbs(2, 3000, 2);
        let y = sim(&g, &u, None);
        let opts = IvOptions {
            order: OrderSelection::Fixed(4),
            alpha: 5,
            ..Default::default()
        };
        let fit = iv_identify(
            &[IvExperiment {
                u: &u,
                y: &y,
                instrument: None,
            }],
            &opts,
        )
        .unwrap();
        assert!(freq_error(&fit.model, &g) < 1e-8);
    }

    /// An unstable plant (pole 1.02) held by the loop u = r − 0.5 y (closed
    /// loop pole 0.52), identified by IV with the reference as instrument:
    /// the output-error regression over 3000 samples would simulate the
    /// plant to 1.02^2999 ≈ 6e25 (it refused: "estimated A is unstable"),
    /// and on the first 911 samples (growth 6.7e7) its regressors for B and
    /// x₀ are collinear (rank 1 of 2). (B, D, x₀) now come from the
    /// one-step predictor regression, whose regressors a stable observer
    /// filters, and the model comes back, unstable and named so.
    #[test]
    fn an_unstable_plant_in_a_loop_is_identified_in_predictor_form() {
        use rand::{RngExt, SeedableRng};
        let n = 3000;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let (mut u, mut y, mut r) = (
            DMatrix::zeros(n, 1),
            DMatrix::zeros(n, 1),
            DMatrix::zeros(n, 1),
        );
        let mut x = 0.0;
        for t in 0..n {
            r[(t, 0)] = rng.random::<f64>() - 0.5;
            y[(t, 0)] = x + 0.05 * (rng.random::<f64>() - 0.5);
            u[(t, 0)] = r[(t, 0)] - 0.5 * y[(t, 0)];
            x = 1.02 * x + u[(t, 0)];
        }
        let opts = IvOptions {
            order: OrderSelection::Fixed(1),
            alpha: 4,
            feedthrough: Feedthrough::Zero,
            ..Default::default()
        };
        let fit = iv_identify(
            &[IvExperiment {
                u: &u,
                y: &y,
                instrument: Some(&r),
            }],
            &opts,
        )
        .unwrap();
        let a = fit.model.a()[(0, 0)];
        let gain = fit.model.b()[(0, 0)] * fit.model.c()[(0, 0)];
        // The pole and the gain C B of the plant (1.02 and 1) within the
        // noise's effect (output noise RMS 0.014 against an output RMS ≈ 0.5).
        assert!((a - 1.02).abs() < 0.01, "{a}");
        assert!((gain - 1.0).abs() < 0.05, "{gain}");
        let note = fit.diagnostics.bd_fallback.as_deref().unwrap_or_default();
        assert!(note.contains("one-step predictor regression"), "{note}");
    }

    #[test]
    fn multirate_one_step_recovers_an_observable_fast_model() {
        // y1 sampled every 3, y2 every sample; (C2, A) observable.
        let g = random_system(31, &[0.9, 0.7, 0.4], &[], 2, 2, false);
        let n = 3000;
        let u = rbs(5, n, 2);
        let mut y = sim(&g, &u, None);
        for t in 0..n {
            if t % 3 != 0 {
                y[(t, 0)] = f64::NAN;
            }
        }
        let opts = MultirateIvOptions {
            order: OrderSelection::Fixed(3),
            alpha: 4,
            feedthrough: Feedthrough::Zero,
            ..Default::default()
        };
        let fit = iv_multirate_fast(&u, &y, &u, &[3, 1], &opts).unwrap();
        assert!(
            freq_error(&fit.model, &g) < 1e-7,
            "{}",
            freq_error(&fit.model, &g)
        );
    }

    #[test]
    fn multirate_one_step_reports_unobservable_fast_outputs() {
        // The 0.9868 mode is seen only by y1 (the stirred tank of §7.8.2):
        // Γ_R is rank deficient (erratum L-18).
        let a = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![0.9868, 0.913, 0.9048]));
        let b = DMatrix::from_row_slice(3, 2, &[0.1416, 0.0, -0.0379, 0.0, 0.0, 0.0595]);
        let c = DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.0, 0.0, 1.0, 1.0]);
        let g = lifted_lti::StateSpace::new(a, b, c, DMatrix::zeros(2, 2), Some(1.0)).unwrap();
        let n = 5000;
        let u = rbs(8, n, 2);
        let y = sim(&g, &u, None);
        let opts = MultirateIvOptions {
            order: OrderSelection::Fixed(3),
            alpha: 4,
            ..Default::default()
        };
        let err = iv_multirate_fast(&u, &y, &u, &[5, 1], &opts).unwrap_err();
        assert!(
            matches!(
                err,
                Error::RankDeficient {
                    rank: 2,
                    needed: 3,
                    ..
                }
            ),
            "{err}"
        );
    }
}

mod bad_input {
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
        let err =
            identify(&[Experiment { u: &u, y: &y }], &SubspaceOptions::default()).unwrap_err();
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
        let err =
            identify(&[Experiment { u: &u, y: &y }], &SubspaceOptions::default()).unwrap_err();
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
        let err =
            identify(&[Experiment { u: &u, y: &y }], &SubspaceOptions::default()).unwrap_err();
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
        let err =
            identify(&[Experiment { u: &u, y: &y2 }], &SubspaceOptions::default()).unwrap_err();
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
}

mod identifier {
    use super::common::*;
    use lifted_lti::Dataset;
    use lifted_lti::identify::Identifier;
    use lifted_subspace::*;

    #[test]
    fn identifier_trait_on_datasets() {
        let g = random_system(5, &[0.8, 0.5], &[], 1, 1, false);
        let u = rbs(3, 600, 1);
        let y = sim(&g, &u, None);
        let data = Dataset::single_rate(1.0, u, y).unwrap();
        let id = SubspaceIdentifier {
            options: SubspaceOptions {
                order: OrderSelection::Fixed(2),
                method: Method::Cva,
                ..Default::default()
            },
        };
        assert_eq!(id.name(), "CVA");
        let out = id.identify(&[data.clone(), data]).unwrap();
        assert!(freq_error(&out.model, &g) < 1e-8);
        assert_eq!(out.diagnostics.order, 2);
        assert!(matches!(id.identify(&[]), Err(Error::Data(_))));
    }
}

mod compression {
    //! The correlation/Cholesky compression against the QR reference, its
    //! automatic fallback and the streaming entry point.
    use super::common::{random_system, rbs, white};
    use lifted_subspace::{
        BdEstimate, Compression, Error, Experiment, InitialState, Method, OrderSelection,
        StreamingIdentifier, SubspaceOptions, compress_hankel, identify,
    };
    use nalgebra::DMatrix;

    /// 2-input 2-output order-4 data with output noise `sd`.
    fn data(n: usize, sd: f64) -> (DMatrix<f64>, DMatrix<f64>) {
        let g = random_system(11, &[0.7, -0.5], &[(0.92, 0.22)], 2, 2, false);
        let u = rbs(12, n, 2);
        let y = g.lsim(&u, None, None).unwrap().y + white(13, n, 2, sd);
        (u, y)
    }

    fn opts(method: Method, compression: Compression) -> SubspaceOptions {
        SubspaceOptions {
            method,
            order: OrderSelection::Fixed(4),
            past: 8,
            future: 8,
            compression,
            ..Default::default()
        }
    }

    fn sorted_poles(m: &lifted_lti::StateSpace) -> Vec<(f64, f64)> {
        let mut p: Vec<(f64, f64)> = m.poles().unwrap().iter().map(|z| (z.re, z.im)).collect();
        p.sort_by(|a, b| a.partial_cmp(b).unwrap());
        p
    }

    #[test]
    fn correlation_equals_the_qr_reference_on_well_conditioned_data() {
        let (u, y) = data(5000, 0.1);
        let e = [Experiment { u: &u, y: &y }];
        for method in [Method::N4sid, Method::Moesp, Method::Cva] {
            let qr = identify(&e, &opts(method, Compression::Qr)).unwrap();
            let co = identify(&e, &opts(method, Compression::Auto)).unwrap();
            assert_eq!(co.diagnostics.compression.used, Compression::Correlation);
            assert!(co.diagnostics.compression.fallback.is_none());
            assert_eq!(qr.diagnostics.compression.used, Compression::Qr);
            // Well conditioned: rcond far above the fallback threshold.
            assert!(
                co.diagnostics.compression.rcond > 1e-6,
                "{}",
                co.diagnostics.compression.rcond
            );
            // Singular values to 1e-8 relative (issue 11 target).
            let s1 = &qr.diagnostics.singular_values;
            let s2 = &co.diagnostics.singular_values;
            for (a, b) in s1.iter().zip(s2) {
                assert!((a - b).abs() <= 1e-8 * a, "{method:?}: {a} vs {b}");
            }
            // Identified poles identical to the QR path to 1e-8.
            for (p, q) in sorted_poles(&qr.model).iter().zip(sorted_poles(&co.model)) {
                assert!(
                    (p.0 - q.0).hypot(p.1 - q.1) < 1e-8,
                    "{method:?}: {p:?} vs {q:?}"
                );
            }
        }
    }

    #[test]
    fn ill_conditioned_data_fall_back_to_the_qr_and_say_so() {
        // Noise-free outputs: the Hankel rows of [u; y] are linearly
        // dependent (order 4 < rows), H Hᵀ is singular up to rounding.
        let (u, y) = data(3000, 0.0);
        let e = [Experiment { u: &u, y: &y }];
        let fit = identify(&e, &opts(Method::N4sid, Compression::Auto)).unwrap();
        let rep = &fit.diagnostics.compression;
        assert_eq!(rep.requested, Compression::Auto);
        assert_eq!(rep.used, Compression::Qr);
        let why = rep.fallback.as_deref().unwrap_or("");
        assert!(
            why.contains("positive definite") || why.contains("reciprocal condition"),
            "{why}"
        );
        // The QR answer is still exact.
        let g = random_system(11, &[0.7, -0.5], &[(0.92, 0.22)], 2, 2, false);
        let want = sorted_poles(&g);
        for (p, q) in want.iter().zip(sorted_poles(&fit.model)) {
            assert!((p.0 - q.0).hypot(p.1 - q.1) < 1e-6, "{p:?} vs {q:?}");
        }
        // Forcing the correlations reports the named error.
        assert!(matches!(
            compress_hankel(&e, 8, 8, Compression::Correlation, 1),
            Err(Error::IllConditionedCorrelation { .. })
        ));
        // Nearly noise-free (1e-7): definite but too ill conditioned.
        let (u, y) = data(3000, 1e-7);
        let e = [Experiment { u: &u, y: &y }];
        let fit = identify(&e, &opts(Method::N4sid, Compression::Auto)).unwrap();
        assert_eq!(fit.diagnostics.compression.used, Compression::Qr);
        assert!(fit.diagnostics.compression.fallback.is_some());
    }

    #[test]
    fn streaming_equals_in_memory_and_two_threads_equal_one() {
        let (u, y) = data(7000, 0.1);
        let e = [Experiment { u: &u, y: &y }];
        let base = SubspaceOptions {
            initial_state: InitialState::Zero,
            ..opts(Method::N4sid, Compression::Auto)
        };
        let whole = identify(&e, &base).unwrap();
        for (block, threads) in [(1000usize, 1usize), (333, 2), (7000, 2)] {
            let o = SubspaceOptions {
                threads,
                ..base.clone()
            };
            let mut id = StreamingIdentifier::new(2, 2, &o).unwrap();
            let mut s = 0;
            while s < 7000 {
                let len = block.min(7000 - s);
                id.push(&u.rows(s, len).into_owned(), &y.rows(s, len).into_owned())
                    .unwrap();
                s += len;
            }
            assert_eq!(id.columns(), 7000 - 16 + 1);
            let fit = id.finish().unwrap();
            assert_eq!(fit.diagnostics.columns, whole.diagnostics.columns);
            for (a, b) in whole
                .diagnostics
                .singular_values
                .iter()
                .zip(&fit.diagnostics.singular_values)
            {
                assert!((a - b).abs() <= 1e-9 * a, "block {block}: {a} vs {b}");
            }
            for (p, q) in sorted_poles(&whole.model)
                .iter()
                .zip(sorted_poles(&fit.model))
            {
                assert!((p.0 - q.0).hypot(p.1 - q.1) < 1e-9);
            }
            assert_eq!(fit.x0.len(), 1);
        }
    }

    #[test]
    fn streaming_records_and_rejections() {
        let (u, y) = data(4000, 0.1);
        let e = [
            Experiment {
                u: &u.rows(0, 2500).into_owned(),
                y: &y.rows(0, 2500).into_owned(),
            },
            Experiment {
                u: &u.rows(2500, 1500).into_owned(),
                y: &y.rows(2500, 1500).into_owned(),
            },
        ];
        let o = SubspaceOptions {
            initial_state: InitialState::Zero,
            ..opts(Method::Moesp, Compression::Qr)
        };
        let merged = identify(&e, &o).unwrap();
        let mut id = StreamingIdentifier::new(2, 2, &o).unwrap();
        for r in &e {
            id.push(r.u, r.y).unwrap();
            id.end_record();
        }
        let fit = id.finish().unwrap();
        assert_eq!(fit.diagnostics.columns, merged.diagnostics.columns);
        assert_eq!(fit.x0.len(), 2);
        for (a, b) in merged
            .diagnostics
            .singular_values
            .iter()
            .zip(&fit.diagnostics.singular_values)
        {
            assert!((a - b).abs() <= 1e-9 * a);
        }
        // Rejected: wrong block shape, NaN, options that need the records,
        // too few samples, ill-conditioned data with Auto.
        let mut id = StreamingIdentifier::new(2, 2, &o).unwrap();
        assert!(matches!(
            id.push(&DMatrix::zeros(5, 1), &DMatrix::zeros(5, 2)),
            Err(Error::DimensionMismatch { .. })
        ));
        let mut bad = y.rows(0, 10).into_owned();
        bad[(3, 1)] = f64::NAN;
        assert!(matches!(
            id.push(&u.rows(0, 10).into_owned(), &bad),
            Err(Error::NonFinite { .. })
        ));
        id.push(&u.rows(0, 20).into_owned(), &y.rows(0, 20).into_owned())
            .unwrap();
        assert!(matches!(id.finish(), Err(Error::HorizonTooLong { .. })));
        let si = SubspaceOptions {
            bd: BdEstimate::OutputError,
            ..o.clone()
        };
        assert!(matches!(
            StreamingIdentifier::new(2, 2, &si),
            Err(Error::InvalidOption { .. })
        ));
        assert!(matches!(
            StreamingIdentifier::new(0, 2, &o),
            Err(Error::DimensionMismatch { .. })
        ));
        let (u0, y0) = data(3000, 0.0);
        let mut id =
            StreamingIdentifier::new(2, 2, &opts(Method::N4sid, Compression::Auto)).unwrap();
        id.push(&u0, &y0).unwrap();
        assert!(matches!(
            id.finish(),
            Err(Error::IllConditionedCorrelation { .. })
        ));
    }
}

/// Extreme SNR on the §7.8.2 SISO loop (`lifted_sim::plants::chapter7_siso`,
/// RBS ±1 dither at the plant input, variance SNR of spec §0, α = 8,
/// α_p = 16, order 2, N = 3000 — the set-up of `lifted-tests` A3.9
/// `regime`): the IV estimate of A is unstable on some seeds and the
/// output-error (B, D, x₀) regression over the record cannot be computed.
/// These seeds failed with "faer singular_values did not converge after 0
/// iterations", `RankDeficient { "B/D regressor" }` or `NonFinite {
/// "block" }`, then with `UnstableEstimate` before the regression ran; now
/// (B, D, x₀) and A come from the one-step predictor regression, whose
/// regressors a stabilising observer filters, and the model comes back
/// with the reason in `bd_fallback`. The plant is 0.5/(5s + 1) with one
/// sample of delay: poles 0.819 and 0.
mod extreme_snr {
    use lifted_prbs::{RandomBinaryOptions, random_binary};
    use lifted_sim::plants::chapter7_siso;
    use lifted_sim::{Excitation, SnrDefinition};
    use lifted_subspace::*;
    use nalgebra::DMatrix;

    /// (u, y, dither) of one closed-loop record: noise seed `seed`, dither
    /// seed `seed + 1000`.
    fn record(snr: f64, seed: u64) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        let fx = chapter7_siso().unwrap();
        let noise = fx.noise_spec(snr, SnrDefinition::Variance, seed).unwrap();
        let sim = fx.simulator().unwrap().with_noise(noise).unwrap();
        let s = random_binary(
            3000,
            &RandomBinaryOptions {
                seed: seed + 1000,
                ..Default::default()
            },
        )
        .unwrap();
        let f = DMatrix::from_column_slice(3000, 1, &s);
        let out = sim.simulate(&Excitation::input(f.clone())).unwrap();
        (out.u().clone(), out.y.clone(), f)
    }

    fn options() -> IvOptions {
        IvOptions {
            order: OrderSelection::Fixed(2),
            alpha: 8,
            alpha_p: Some(16),
            ..Default::default()
        }
    }

    fn assert_unstable_estimate(err: &Error, stage_part: &str, rho_min: f64) {
        match err {
            Error::UnstableEstimate {
                stage,
                spectral_radius,
                samples,
                growth,
                max_growth,
            } => {
                assert!(stage.contains(stage_part), "{err}");
                assert!(*spectral_radius > rho_min, "{err}");
                assert_eq!(*samples, 3000);
                assert!(*growth > *max_growth, "{err}");
                assert_eq!(*max_growth, MAX_REGRESSOR_GROWTH);
            }
            other => panic!("expected UnstableEstimate, got {other:?}"),
        }
    }

    /// The fallback names the unstable IV estimate (ρ above `rho_min`) and
    /// its growth over the 3000 samples, and the model's slow pole is the
    /// plant's 0.819 within `tol`.
    fn assert_predictor_fallback(fit: &IvModel, rho_min: f64, tol: f64) {
        let note = fit.diagnostics.bd_fallback.as_deref().unwrap_or_default();
        assert!(note.contains("IV estimate of A is unstable"), "{note}");
        assert!(note.contains("over 3000 samples"), "{note}");
        let rho: f64 = note
            .split("spectral radius ")
            .nth(1)
            .and_then(|s| s.split(')').next())
            .and_then(|s| s.parse().ok())
            .unwrap_or(0.0);
        assert!(rho > rho_min, "{note}");
        let slow = fit
            .model
            .poles()
            .unwrap()
            .iter()
            .map(|p| p.norm())
            .fold(0.0, f64::max);
        assert!((slow - 0.819).abs() < tol, "{slow} {note}");
    }

    /// var-SNR 0.25, seed 5012: IV with the dither as instrument. Before:
    /// `Linalg(NoConvergence { "faer singular_values" })`, then
    /// `UnstableEstimate`: A has ρ = 1.0699 (ρ^2999 ≈ 1e88). The predictor
    /// regression's model has its slow pole at 0.829.
    #[test]
    fn closed_loop_iv_with_unstable_a_gets_the_predictor_form() {
        let (u, y, f) = record(0.25, 5012);
        let rec = [IvExperiment {
            u: &u,
            y: &y,
            instrument: Some(&f),
        }];
        let fit = iv_identify(&rec, &options()).unwrap();
        assert_predictor_fallback(&fit, 1.06, 0.03);
        // require_stable reports the IV estimate of A as Error::Unstable.
        let strict = IvOptions {
            require_stable: true,
            ..options()
        };
        let err2 = iv_identify(&rec, &strict).unwrap_err();
        assert!(matches!(err2, Error::Unstable { spectral_radius } if spectral_radius > 1.06));
        // enforce_stability re-estimates A and identifies a stable model.
        let fixed = IvOptions {
            enforce_stability: true,
            ..options()
        };
        let fit = iv_identify(&rec, &fixed).unwrap();
        assert!(fit.diagnostics.stabilized);
        assert!(fit.diagnostics.bd_fallback.is_none());
        assert!(fit.model.poles().unwrap().iter().all(|p| p.norm() < 1.0));
    }

    /// var-SNR 0.25, seed 5012, u as its own instrument (§7.3 on
    /// closed-loop data): before `RankDeficient { "B/D regressor", rank 1,
    /// needed 5 }`, which was really ρ = 1.0217 (ρ^2999 ≈ 1e28).
    #[test]
    fn open_loop_iv_rank_deficiency_was_an_unstable_a() {
        let fit = open_loop_iv(0.25, 5012);
        assert_predictor_fallback(&fit, 1.02, 0.1);
    }

    /// The §7.3 IV method (u as instrument) on one record.
    fn open_loop_iv(snr: f64, seed: u64) -> IvModel {
        let (u, y, _) = record(snr, seed);
        let rec = [IvExperiment {
            u: &u,
            y: &y,
            instrument: None,
        }];
        iv_identify(&rec, &options()).unwrap()
    }

    /// var-SNR 0.025, seed 5003, u as instrument: before
    /// `Linalg(NonFinite { "block", row 475 })` (the regressors overflowed;
    /// ρ = 1.325, ρ^2999 = ∞ in f64).
    #[test]
    fn overflowing_regressors_are_avoided_by_the_predictor_form() {
        let fit = open_loop_iv(0.025, 5003);
        assert!(
            fit.diagnostics
                .bd_fallback
                .as_deref()
                .is_some_and(|n| n.contains("grow by inf")),
            "{:?}",
            fit.diagnostics.bd_fallback
        );
        assert_predictor_fallback(&fit, 1.3, 0.1);
    }

    /// The public regressions `estimate_bd` and `estimate_bd_iv` (also used
    /// by the shift-invariance route of `identify` and by the multirate
    /// crate) check the growth themselves.
    #[test]
    fn estimate_bd_and_estimate_bd_iv_report_it_too() {
        let (u, y, _) = record(0.25, 5012);
        let a = DMatrix::from_row_slice(2, 2, &[1.07, 0.0, 0.0, 0.5]);
        let c = DMatrix::from_row_slice(1, 2, &[1.0, 1.0]);
        let rec = [Record {
            u: &u,
            y: &y,
            instrument: None,
        }];
        let err =
            estimate_bd(&a, &c, &rec, &Feedthrough::Free, InitialState::Estimate).unwrap_err();
        assert_unstable_estimate(&err, "output-error regression", 1.06);
        let err =
            estimate_bd_iv(&a, &c, &rec, &Feedthrough::Free, InitialState::Estimate).unwrap_err();
        assert_unstable_estimate(&err, "IV regression", 1.06);
        // A mildly unstable A whose growth stays below the bound is fine:
        // 1.005^2999 ≈ 3.3e6.
        let a = DMatrix::from_row_slice(2, 2, &[1.005, 0.0, 0.0, 0.5]);
        assert!(estimate_bd(&a, &c, &rec, &Feedthrough::Free, InitialState::Estimate).is_ok());
    }
}

/// The identification does not depend on the units of u and y: both are
/// divided internally by a power of 4 near their RMS. Before, outputs 1e-7
/// times the inputs moved the N4SID poles (0.8035 → 0.6935), and data of
/// magnitude 1e139…1e200 failed with "faer thin_svd did not converge",
/// `NonFinite { "a" }` or a spurious `RankDeficient`.
mod scale {
    use super::common::*;
    use lifted_subspace::*;
    use nalgebra::DMatrix;

    /// One identification route: (u, y) → model.
    type Route = dyn Fn(&DMatrix<f64>, &DMatrix<f64>) -> lifted_lti::StateSpace;

    fn poles(m: &lifted_lti::StateSpace) -> Vec<f64> {
        let mut p: Vec<f64> = m
            .poles()
            .unwrap()
            .iter()
            .flat_map(|z| [z.re, z.im.abs()])
            .collect();
        p.sort_by(|a, b| a.total_cmp(b));
        p
    }

    #[test]
    fn every_route_is_invariant_to_the_units_of_u_and_y() {
        let g = random_system(41, &[0.9], &[(0.8, 0.4)], 1, 1, true);
        let u = rbs(41, 2000, 1);
        let y = sim(&g, &u, None) + white(42, 2000, 1, 0.05);
        let scales = [
            (1.0, 1e-7),
            (1e-150, 1.0),
            (1.0, 1e150),
            (1e139, 1e139),
            (1e-200, 1e-200),
            (1e8, 1e-8),
        ];
        let base = SubspaceOptions {
            order: OrderSelection::Fixed(3),
            past: 8,
            future: 8,
            ..Default::default()
        };
        let in_memory = |o: SubspaceOptions| -> Box<Route> {
            Box::new(move |u, y| identify(&[Experiment { u, y }], &o).unwrap().model)
        };
        let cva = SubspaceOptions {
            method: Method::Cva,
            ..base.clone()
        };
        let routes: Vec<(&str, Box<Route>)> = vec![
            ("N4SID", in_memory(base.clone())),
            (
                "MOESP shift invariance, QR",
                in_memory(SubspaceOptions {
                    method: Method::Moesp,
                    system: SystemEstimate::ShiftInvariance,
                    compression: Compression::Qr,
                    ..base.clone()
                }),
            ),
            (
                "CVA streaming",
                Box::new(move |u, y| {
                    let mut st = StreamingIdentifier::new(1, 1, &cva).unwrap();
                    st.push(u, y).unwrap();
                    st.finish().unwrap().model
                }),
            ),
            (
                "IV",
                Box::new(|u, y| {
                    let o = IvOptions {
                        order: OrderSelection::Fixed(3),
                        alpha: 6,
                        ..Default::default()
                    };
                    let rec = [IvExperiment {
                        u,
                        y,
                        instrument: None,
                    }];
                    iv_identify(&rec, &o).unwrap().model
                }),
            ),
        ];
        for (name, route) in &routes {
            let reference = route(&u, &y);
            let p0 = poles(&reference);
            let dc0 = reference.dc_gain().unwrap()[(0, 0)];
            for &(su, sy) in &scales {
                let m = route(&(&u * su), &(&y * sy));
                let p = poles(&m);
                for (a, b) in p.iter().zip(&p0) {
                    assert!(
                        (a - b).abs() < 1e-9,
                        "{name} scales ({su:e}, {sy:e}): poles {p:?} vs {p0:?}"
                    );
                }
                let dc = m.dc_gain().unwrap()[(0, 0)] * su / sy;
                assert!(
                    (dc - dc0).abs() < 1e-9 * dc0.abs().max(1.0),
                    "{name} ({su:e}, {sy:e}): DC {dc} vs {dc0}"
                );
            }
        }
    }

    #[test]
    fn diagnostics_are_in_the_units_of_the_data() {
        let g = random_system(43, &[0.9, 0.5], &[], 1, 1, false);
        let u = rbs(43, 1500, 1);
        let y = sim(&g, &u, None) + white(44, 1500, 1, 0.05);
        let opts = SubspaceOptions {
            order: OrderSelection::Fixed(2),
            past: 6,
            future: 6,
            ..Default::default()
        };
        let a = identify(&[Experiment { u: &u, y: &y }], &opts).unwrap();
        let y2 = &y * 1e6;
        let b = identify(&[Experiment { u: &u, y: &y2 }], &opts).unwrap();
        for (s1, s2) in a
            .diagnostics
            .singular_values
            .iter()
            .zip(&b.diagnostics.singular_values)
        {
            assert!((s2 / s1 - 1e6).abs() < 1e-3, "{s1} {s2}");
        }
        let (ra, rb) = (&a.noise.as_ref().unwrap().r, &b.noise.as_ref().unwrap().r);
        assert!((rb[(0, 0)] / ra[(0, 0)] - 1e12).abs() < 1e3);
        let (ka, kb) = (a.kalman_gain.unwrap(), b.kalman_gain.unwrap());
        // K maps innovations (y units) to states: K·C is invariant.
        let kca = &ka * a.model.c();
        let kcb = &kb * b.model.c();
        assert!((kca.trace() - kcb.trace()).abs() < 1e-8, "{kca} {kcb}");
    }
}

/// Order selection: gap rule (default), Bauer's SVC, SIPPY's AIC/AICc/BIC.
mod order_selection {
    use super::common::*;
    use lifted_subspace::*;
    use nalgebra::DMatrix;

    /// Known-order systems with white output noise (sd a fraction of the
    /// output RMS), RBS input. In an exploration over 24 cases (2nd/3rd-order
    /// SISO and 4th-order 2x2 systems of `random_system`, seeds 0–3,
    /// N = 2000 with 10 % noise and N = 4000 with 30 %), N4SID found the
    /// true order with the gap rule in 10, SVC 22, AIC 19, AICc 19 and BIC 21
    /// of 24 (misses: weakly excited modes, AIC/AICc overfitting by 1–4).
    /// These two cases are among the 7 where every criterion and method
    /// (and the IV method) is right.
    fn case(which: usize) -> (DMatrix<f64>, DMatrix<f64>, usize) {
        let (g, n, seed, sd) = match which {
            0 => (
                random_system(3, &[0.85], &[(0.8, 0.7)], 1, 1, false),
                2000,
                103,
                0.1,
            ),
            _ => (
                random_system(0, &[0.9, 0.5], &[(0.8, 1.0)], 2, 2, false),
                4000,
                100,
                0.3,
            ),
        };
        let nu = g.n_inputs();
        let u = rbs(seed, n, nu);
        let y0 = sim(&g, &u, None);
        let rms = (y0.iter().map(|v| v * v).sum::<f64>() / y0.len() as f64).sqrt();
        let y = &y0 + white(seed + 7, n, g.n_outputs(), sd * rms);
        (u, y, g.order())
    }

    const CRITERIA: [OrderCriterion; 5] = [
        OrderCriterion::Gap,
        OrderCriterion::Svc,
        OrderCriterion::Aic,
        OrderCriterion::Aicc,
        OrderCriterion::Bic,
    ];

    #[test]
    fn every_criterion_picks_the_true_order() {
        for which in 0..2 {
            let (u, y, n_true) = case(which);
            for method in [Method::N4sid, Method::Moesp, Method::Cva] {
                for criterion in CRITERIA {
                    let opts = SubspaceOptions {
                        method,
                        order: OrderSelection::Gap { max: 8 },
                        order_criterion: criterion,
                        noise_model: false,
                        ..Default::default()
                    };
                    let fit = identify(&[Experiment { u: &u, y: &y }], &opts).unwrap();
                    let d = &fit.diagnostics;
                    assert_eq!(
                        d.order, n_true,
                        "case {which} {method:?} {criterion:?}: {:?}",
                        d.order_selection
                    );
                    assert_eq!(d.order_selection.criterion, criterion);
                    assert_eq!(d.order_selection.selected, n_true);
                    assert_eq!(d.order_selection.values.len(), 8);
                    assert_eq!(fit.model.order(), n_true);
                }
            }
            for criterion in [
                OrderCriterion::Gap,
                OrderCriterion::Aic,
                OrderCriterion::Aicc,
                OrderCriterion::Bic,
            ] {
                let opts = IvOptions {
                    order: OrderSelection::Gap { max: 6 },
                    order_criterion: criterion,
                    ..Default::default()
                };
                let fit = iv_identify(
                    &[IvExperiment {
                        u: &u,
                        y: &y,
                        instrument: None,
                    }],
                    &opts,
                )
                .unwrap();
                assert_eq!(
                    fit.diagnostics.order, n_true,
                    "case {which} IV {criterion:?}: {:?}",
                    fit.diagnostics.order_selection
                );
                assert_eq!(fit.diagnostics.order_selection.values.len(), 6);
            }
        }
    }

    #[test]
    fn reported_values_follow_the_definitions() {
        let (u, y, _) = case(0);
        let n_samples = u.nrows() as f64;
        // SVC on CVA: values are σ_{n+1}² + n(2n_y + n_u) ln J/J with σ the
        // CVA singular values (canonical correlations).
        let opts = SubspaceOptions {
            method: Method::Cva,
            order: OrderSelection::Gap { max: 5 },
            order_criterion: OrderCriterion::Svc,
            ..Default::default()
        };
        let fit = identify(&[Experiment { u: &u, y: &y }], &opts).unwrap();
        let d = &fit.diagnostics;
        let j = d.columns as f64;
        for (i, v) in d.order_selection.values.iter().enumerate() {
            let n = (i + 1) as f64;
            let want = d.singular_values[i + 1].powi(2) + n * 3.0 * j.ln() / j;
            assert!((v - want).abs() < 1e-12, "SVC({n}) {v} vs {want}");
        }
        // N4SID's SVC uses the same canonical correlations.
        let n4 = identify(
            &[Experiment { u: &u, y: &y }],
            &SubspaceOptions {
                method: Method::N4sid,
                ..opts.clone()
            },
        )
        .unwrap();
        for (a, b) in n4
            .diagnostics
            .order_selection
            .values
            .iter()
            .zip(&d.order_selection.values)
        {
            assert!((a - b).abs() < 1e-9, "{a} {b}");
        }
        // AIC − BIC = K(2 − ln N), K = n(n_y + n_u) + 1 (free D) + n (x₀).
        let ic = |c| {
            identify(
                &[Experiment { u: &u, y: &y }],
                &SubspaceOptions {
                    order: OrderSelection::Gap { max: 4 },
                    order_criterion: c,
                    ..Default::default()
                },
            )
            .unwrap()
            .diagnostics
            .order_selection
            .values
        };
        let (aic, bic, aicc) = (
            ic(OrderCriterion::Aic),
            ic(OrderCriterion::Bic),
            ic(OrderCriterion::Aicc),
        );
        for i in 0..4 {
            let k = ((i + 1) * 3 + 1) as f64;
            assert!((aic[i] - bic[i] - k * (2.0 - n_samples.ln())).abs() < 1e-6);
            let corr = 2.0 * k * (k + 1.0) / (n_samples - k - 1.0);
            assert!((aicc[i] - aic[i] - corr).abs() < 1e-6);
        }
        // A fixed order still reports the criterion (orders 1..=min((f−1)n_y, 10)).
        let fixed = identify(
            &[Experiment { u: &u, y: &y }],
            &SubspaceOptions {
                order: OrderSelection::Fixed(2),
                order_criterion: OrderCriterion::Bic,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(fixed.diagnostics.order, 2);
        assert_eq!(fixed.diagnostics.order_selection.values.len(), 9);
        assert_eq!(fixed.diagnostics.order_selection.selected, 3);
    }

    #[test]
    fn gap_rule_stays_the_default_and_keeps_capping() {
        let (u, y, _) = case(0);
        let fit = identify(&[Experiment { u: &u, y: &y }], &SubspaceOptions::default()).unwrap();
        let d = &fit.diagnostics;
        assert_eq!(d.order_selection.criterion, OrderCriterion::Gap);
        // Default Gap { max: 10 } with f = 10, n_y = 1: capped at 9.
        assert_eq!(d.order_selection.values.len(), 9);
        assert_eq!(d.order, d.suggested_order);
        assert_eq!(d.order, gap_order(&d.singular_values, 9));
    }

    #[test]
    fn max_order_beyond_what_is_identifiable_is_rejected() {
        let (u, y, _) = case(0);
        for criterion in [
            OrderCriterion::Svc,
            OrderCriterion::Aic,
            OrderCriterion::Bic,
        ] {
            // f = 10, n_y = 1: at most order 9.
            let opts = SubspaceOptions {
                order: OrderSelection::Gap { max: 10 },
                order_criterion: criterion,
                ..Default::default()
            };
            let err = identify(&[Experiment { u: &u, y: &y }], &opts).unwrap_err();
            assert!(
                matches!(err, Error::OrderTooLarge { order: 10, max: 9 }),
                "{err}"
            );
            let opts = SubspaceOptions {
                order: OrderSelection::Gap { max: 0 },
                ..opts
            };
            let err = identify(&[Experiment { u: &u, y: &y }], &opts).unwrap_err();
            assert!(
                matches!(err, Error::OrderTooLarge { order: 0, .. }),
                "{err}"
            );
        }
        // IV: (α − 1)n_y = 7 for α = 8.
        let opts = IvOptions {
            order: OrderSelection::Gap { max: 8 },
            order_criterion: OrderCriterion::Aic,
            ..Default::default()
        };
        let rec = [IvExperiment {
            u: &u,
            y: &y,
            instrument: None,
        }];
        let err = iv_identify(&rec, &opts).unwrap_err();
        assert!(
            matches!(err, Error::OrderTooLarge { order: 8, max: 7 }),
            "{err}"
        );
        // AIC-type criteria: more parameters than samples. 2x2, p = 1,
        // f = 6 (orders up to 10), 40 samples: K(n) = n(n_y + n_u) + 4 (D)
        // + n (x₀) = 5n + 4 must stay below N − 1 = 39, i.e. n ≤ 6.
        let (u, y, _) = case(1);
        let (us, ys) = (u.rows(0, 40).into_owned(), y.rows(0, 40).into_owned());
        let opts = SubspaceOptions {
            order: OrderSelection::Gap { max: 10 },
            order_criterion: OrderCriterion::Aicc,
            past: 1,
            future: 6,
            ..Default::default()
        };
        let err = identify(&[Experiment { u: &us, y: &ys }], &opts).unwrap_err();
        assert!(
            matches!(err, Error::OrderTooLarge { order: 10, max: 6 }),
            "{err}"
        );
    }

    #[test]
    fn unsupported_combinations_are_named() {
        let (u, y, _) = case(0);
        let err = iv_identify(
            &[IvExperiment {
                u: &u,
                y: &y,
                instrument: None,
            }],
            &IvOptions {
                order_criterion: OrderCriterion::Svc,
                order: OrderSelection::Gap { max: 5 },
                ..Default::default()
            },
        )
        .unwrap_err();
        assert!(
            matches!(
                err,
                Error::InvalidOption {
                    what: "order_criterion",
                    ..
                }
            ),
            "{err}"
        );
        let opts = SubspaceOptions {
            order: OrderSelection::Gap { max: 5 },
            order_criterion: OrderCriterion::Aic,
            ..Default::default()
        };
        assert!(matches!(
            StreamingIdentifier::new(1, 1, &opts),
            Err(Error::InvalidOption {
                what: "order_criterion",
                ..
            })
        ));
        // SVC needs only the compressed data: streaming works.
        let opts = SubspaceOptions {
            order_criterion: OrderCriterion::Svc,
            ..opts
        };
        let mut st = StreamingIdentifier::new(1, 1, &opts).unwrap();
        st.push(&u, &y).unwrap();
        let fit = st.finish().unwrap();
        assert_eq!(fit.diagnostics.order, 3);
    }
}

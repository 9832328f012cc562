//! Prediction-error refinement (`refine_pem`): recovery from a perturbed
//! start, invariance under a similarity transform of the start, multirate
//! records, keep-the-better rule and rejected inputs.

use lifted_lti::StateSpace;
use lifted_pem::*;
use lifted_subspace::{Feedthrough, Record};
use nalgebra::DMatrix;

use crate::common::*;

/// The test plant (2×2, order 2) and a noisy record of it: output noise
/// white, σ = 0.2.
fn plant_and_data(n: usize, seed: u64) -> (StateSpace, DMatrix<f64>, DMatrix<f64>) {
    let g = random_system(77, &[0.9, 0.5], &[], 2, 2, false);
    let g = StateSpace::new(
        g.a().clone(),
        g.b().clone(),
        g.c().clone(),
        g.d().clone(),
        Some(1.0),
    )
    .unwrap();
    let u = rbs(seed, n, 2);
    let y = sim(&g, &u, None) + white(seed + 1, n, 2, 0.2);
    (g, u, y)
}

/// The plant with A, B perturbed by `eps` (relative), still stable.
fn perturbed(g: &StateSpace, eps: f64) -> StateSpace {
    let a = g.a().map(|v| v * (1.0 - eps));
    let b = g.b().map(|v| v * (1.0 + eps));
    StateSpace::new(a, b, g.c().clone(), g.d().clone(), Some(1.0)).unwrap()
}

fn opts(cost: PemCost) -> PemOptions {
    PemOptions {
        cost,
        feedthrough: Feedthrough::Zero,
        ..Default::default()
    }
}

#[test]
fn both_costs_recover_the_plant_from_a_perturbed_start() {
    let (g, u, y) = plant_and_data(4000, 3);
    let start = perturbed(&g, 0.05);
    let rec = [Record {
        u: &u,
        y: &y,
        instrument: None,
    }];
    for cost in [PemCost::OutputError, PemCost::Prediction] {
        let fit = refine_pem(&start, None, &rec, &[], &opts(cost)).unwrap();
        let before = freq_error(&start, &g);
        let after = freq_error(&fit.model, &g);
        assert!(
            after < 0.03 && after < 0.2 * before,
            "{cost:?}: {before} → {after}"
        );
        assert_eq!(fit.report.kept, Kept::Refined);
        assert!(fit.report.final_cost < fit.report.initial_cost);
        assert_eq!(fit.kalman_gain.is_some(), cost == PemCost::Prediction);
    }
}

#[test]
fn a_similarity_transform_of_the_start_gives_the_same_model() {
    let (g, u, y) = plant_and_data(3000, 5);
    let start = perturbed(&g, 0.05);
    let t = DMatrix::from_row_slice(2, 2, &[2.0, 0.3, -0.1, 0.7]);
    let ti = t.clone().try_inverse().unwrap();
    let moved = StateSpace::new(
        &t * start.a() * &ti,
        &t * start.b(),
        start.c() * &ti,
        start.d().clone(),
        Some(1.0),
    )
    .unwrap();
    let rec = [Record {
        u: &u,
        y: &y,
        instrument: None,
    }];
    let a = refine_pem(&start, None, &rec, &[], &opts(PemCost::OutputError)).unwrap();
    let b = refine_pem(&moved, None, &rec, &[], &opts(PemCost::OutputError)).unwrap();
    let d = freq_error(&a.model, &b.model);
    assert!(d < 1e-4, "refined models differ by {d}");
}

#[test]
fn output_units_do_not_change_the_refinement() {
    // The same record with its outputs in units 1e6 times larger (metres
    // for a micrometre motion): the same cost path and the same model up to
    // the units. The iterations used to stop at the start there (1 step of
    // 23 accepted on a first-order record, cost unchanged).
    let (g, u, y) = plant_and_data(3000, 9);
    let start = perturbed(&g, 0.05);
    let small_y = &y * 1e-6;
    let small_start = StateSpace::new(
        start.a().clone(),
        start.b().clone(),
        start.c() * 1e-6,
        start.d() * 1e-6,
        Some(1.0),
    )
    .unwrap();
    for cost in [PemCost::OutputError, PemCost::Prediction] {
        let rec = [Record {
            u: &u,
            y: &y,
            instrument: None,
        }];
        let small = [Record {
            u: &u,
            y: &small_y,
            instrument: None,
        }];
        let a = refine_pem(&start, None, &rec, &[], &opts(cost)).unwrap();
        let b = refine_pem(&small_start, None, &small, &[], &opts(cost)).unwrap();
        assert_eq!(a.report.kept, Kept::Refined, "{cost:?}");
        assert_eq!(b.report.kept, Kept::Refined, "{cost:?}");
        approx::assert_relative_eq!(
            a.report.final_cost,
            b.report.final_cost,
            max_relative = 1e-8
        );
        let back = StateSpace::new(
            b.model.a().clone(),
            b.model.b().clone(),
            b.model.c() * 1e6,
            b.model.d() * 1e6,
            Some(1.0),
        )
        .unwrap();
        let d = freq_error(&a.model, &back);
        assert!(d < 1e-6, "{cost:?}: models differ by {d}");
    }
}

#[test]
fn multirate_records_use_the_measured_samples_only() {
    let (g, u, mut y) = plant_and_data(5000, 7);
    for t in 0..y.nrows() {
        if t % 5 != 0 {
            y[(t, 0)] = f64::NAN;
        }
    }
    let start = perturbed(&g, 0.05);
    let rec = [Record {
        u: &u,
        y: &y,
        instrument: None,
    }];
    let fit = refine_pem(&start, None, &rec, &[], &opts(PemCost::Prediction)).unwrap();
    let after = freq_error(&fit.model, &g);
    assert!(after < 0.5 * freq_error(&start, &g), "{after}");
    assert!(fit.model.ts() == Some(1.0));
    // The predictor's transition changes with the measured outputs, so the
    // prediction cost runs the joint method there.
    assert_eq!(fit.report.method, PemMethod::Joint);
    let fit = refine_pem(&start, None, &rec, &[], &opts(PemCost::OutputError)).unwrap();
    assert_eq!(fit.report.method, PemMethod::VariableProjection);
    assert!(freq_error(&fit.model, &g) < 0.5 * freq_error(&start, &g));
}

#[test]
fn the_better_model_is_kept_on_validation_data() {
    // Refining on a record of another system makes the model worse on data
    // of the true one: the start is kept and the report says so.
    let (g, u, y) = plant_and_data(3000, 9);
    let other = perturbed(&g, 0.3);
    let y_other = sim(&other, &u, None);
    let est = [Record {
        u: &u,
        y: &y_other,
        instrument: None,
    }];
    let val = [Record {
        u: &u,
        y: &y,
        instrument: None,
    }];
    let fit = refine_pem(&g, None, &est, &val, &opts(PemCost::OutputError)).unwrap();
    assert_eq!(fit.report.kept, Kept::Initial);
    assert!(fit.report.judged.0 <= fit.report.judged.1);
    assert!(freq_error(&fit.model, &g) < 1e-12);
}

#[test]
fn rejected_inputs_are_named() {
    let (g, u, y) = plant_and_data(500, 11);
    let rec = |u: &DMatrix<f64>, y: &DMatrix<f64>| -> Result<PemFit> {
        refine_pem(
            &g,
            None,
            &[Record {
                u,
                y,
                instrument: None,
            }],
            &[],
            &PemOptions::default(),
        )
    };
    let mut un = u.clone();
    un[(3, 1)] = f64::NAN;
    assert!(matches!(
        rec(&un, &y),
        Err(Error::NonFinite { what: "u", .. })
    ));
    let mut yi = y.clone();
    yi[(4, 0)] = f64::INFINITY;
    assert!(matches!(
        rec(&u, &yi),
        Err(Error::NonFinite { what: "y", .. })
    ));
    assert!(matches!(
        rec(&u.columns(0, 1).into_owned(), &y),
        Err(Error::DimensionMismatch { .. })
    ));
    assert!(matches!(
        rec(&u.rows(0, 5).into_owned(), &y.rows(0, 5).into_owned()),
        Err(Error::TooFewSamples { .. })
    ));
    assert!(matches!(
        refine_pem(&g, None, &[], &[], &PemOptions::default()),
        Err(Error::NoData)
    ));
    let unstable = StateSpace::new(
        g.a() * 1.5,
        g.b().clone(),
        g.c().clone(),
        g.d().clone(),
        Some(1.0),
    )
    .unwrap();
    // An unstable start is stabilised first (its unstable eigenvalues
    // reflected into the unit circle), for either cost, and the result is
    // stable.
    for cost in [PemCost::Prediction, PemCost::OutputError] {
        let fit = refine_pem(
            &unstable,
            None,
            &[Record {
                u: &u,
                y: &y,
                instrument: None,
            }],
            &[],
            &PemOptions {
                cost,
                ..PemOptions::default()
            },
        )
        .unwrap();
        let rho_start = fit.report.stabilized_start.unwrap();
        assert!(rho_start > 1.0);
        let rho = fit
            .model
            .poles()
            .unwrap()
            .iter()
            .map(|p| p.norm())
            .fold(0.0, f64::max);
        assert!(rho < 1.0, "{cost:?}: rho {rho}");
    }
    // A defective unstable start has no eigenbasis to stabilise it in.
    let n = g.order();
    let mut jordan = DMatrix::<f64>::identity(n, n) * 1.1;
    for i in 0..n - 1 {
        jordan[(i, i + 1)] = 1.0;
    }
    let defective = StateSpace::new(
        jordan,
        g.b().clone(),
        g.c().clone(),
        g.d().clone(),
        Some(1.0),
    )
    .unwrap();
    assert!(matches!(
        refine_pem(
            &defective,
            None,
            &[Record {
                u: &u,
                y: &y,
                instrument: None
            }],
            &[],
            &PemOptions::default()
        ),
        Err(Error::Unstable { .. })
    ));
    let continuous = StateSpace::new(
        g.a().clone(),
        g.b().clone(),
        g.c().clone(),
        g.d().clone(),
        None,
    )
    .unwrap();
    assert!(matches!(
        refine_pem(
            &continuous,
            None,
            &[Record {
                u: &u,
                y: &y,
                instrument: None
            }],
            &[],
            &PemOptions::default()
        ),
        Err(Error::InvalidOption { .. })
    ));
    let bad_k = DMatrix::zeros(3, 2);
    assert!(matches!(
        refine_pem(
            &g,
            Some(&bad_k),
            &[Record {
                u: &u,
                y: &y,
                instrument: None
            }],
            &[],
            &PemOptions::default()
        ),
        Err(Error::DimensionMismatch { .. })
    ));
    let zero_iter = PemOptions {
        max_iterations: 0,
        ..Default::default()
    };
    assert!(matches!(
        refine_pem(
            &g,
            None,
            &[Record {
                u: &u,
                y: &y,
                instrument: None
            }],
            &[],
            &zero_iter
        ),
        Err(Error::InvalidOption { .. })
    ));
}

/// Variable projection and the joint iterations minimise the same cost:
/// from the same start they stop at the same cost, to the tolerance of
/// the stopping rules (a relative 1e-6: `expected_decrease_tolerance`; the
/// joint method, whose convergence is linear, is given 400 iterations and
/// a cost tolerance of 1e-12 to get there).
#[test]
fn variable_projection_and_joint_reach_the_same_optimum() {
    let (g, u, y) = plant_and_data(4000, 13);
    let start = perturbed(&g, 0.05);
    let rec = [Record {
        u: &u,
        y: &y,
        instrument: None,
    }];
    for cost in [PemCost::Prediction, PemCost::OutputError] {
        let vp = refine_pem(&start, None, &rec, &[], &opts(cost)).unwrap();
        let joint = refine_pem(
            &start,
            None,
            &rec,
            &[],
            &PemOptions {
                method: PemMethod::Joint,
                max_iterations: 400,
                cost_tolerance: 1e-12,
                ..opts(cost)
            },
        )
        .unwrap();
        assert_eq!(vp.report.method, PemMethod::VariableProjection);
        assert_eq!(joint.report.method, PemMethod::Joint);
        let (a, b) = (vp.report.final_cost, joint.report.final_cost);
        assert!(
            (a - b).abs() <= 1e-6 * b,
            "{cost:?}: projection {a:.12e}, joint {b:.12e}"
        );
        // Same model to the resolution of the cost (frequency responses
        // within 1e-3 of each other; the noise-free responses differ by
        // 0.05 at the start).
        let d = freq_error(&vp.model, &joint.model);
        assert!(d < 1e-3, "{cost:?}: models differ by {d}");
        assert!(vp.report.iterations < joint.report.iterations);
    }
}

/// On a long record the warm stages (5 000 samples, then 100 000) and the
/// Hessian subsample on the whole record (stride 2 at 250 000 samples)
/// end at the optimum of the iterations on the whole record from the
/// start: costs within the relative 1e-6 of the stopping rule.
#[test]
fn warm_stages_reach_the_whole_record_optimum() {
    let (g, u, y) = plant_and_data(250_000, 17);
    let start = perturbed(&g, 0.05);
    let rec = [Record {
        u: &u,
        y: &y,
        instrument: None,
    }];
    for cost in [PemCost::Prediction, PemCost::OutputError] {
        let warm = refine_pem(&start, None, &rec, &[], &opts(cost)).unwrap();
        let cold = refine_pem(
            &start,
            None,
            &rec,
            &[],
            &PemOptions {
                warm_start_samples: 0,
                ..opts(cost)
            },
        )
        .unwrap();
        let (a, b) = (warm.report.final_cost, cold.report.final_cost);
        assert!(
            (a - b).abs() <= 1e-6 * b,
            "{cost:?}: warm {a:.12e}, cold {b:.12e}"
        );
        assert_eq!(warm.report.iteration_cap, None);
        assert_eq!(
            pem_work_estimate(&start, &rec, &opts(cost))
                .unwrap()
                .warm_stages,
            2
        );
    }
}

/// The work bound stops the variable-projection iterations (and the
/// report says after how many), refuses a refinement whose first
/// iteration does not fit, and `pem_work_estimate` predicts both figures.
#[test]
fn the_work_bound_stops_variable_projection() {
    let (g, u, y) = plant_and_data(4000, 19);
    let start = perturbed(&g, 0.05);
    let rec = [Record {
        u: &u,
        y: &y,
        instrument: None,
    }];
    let base = opts(PemCost::Prediction);
    let est = pem_work_estimate(&start, &rec, &base).unwrap();
    assert!(est.per_iteration > 0.0 && est.typical >= est.per_iteration);
    assert_eq!(est.warm_stages, 0);
    let free = refine_pem(&start, None, &rec, &[], &base).unwrap();
    assert!(free.report.iterations > 2, "{:?}", free.report);
    let capped = refine_pem(
        &start,
        None,
        &rec,
        &[],
        &PemOptions {
            max_work: 2.5 * est.per_iteration,
            ..base.clone()
        },
    )
    .unwrap();
    let cap = capped.report.iteration_cap.expect("stopped by the bound");
    assert!((1..=3).contains(&cap), "{:?}", capped.report);
    assert_eq!(capped.report.termination, Termination::MaxIterations);
    assert!(capped.report.final_cost < capped.report.initial_cost);
    assert!(matches!(
        refine_pem(
            &start,
            None,
            &rec,
            &[],
            &PemOptions {
                max_work: 0.5 * est.per_iteration,
                ..base
            },
        ),
        Err(Error::TooMuchWork { .. })
    ));
}

/// Variable projection from a start whose exact linear solve leaves the
/// admissible set: the flexible-arm model of the DaISy record at order 4
/// with its checked Kalman gain (`check_kalman_gain`) as the start, on
/// records simulated from the prediction-error optimum the joint
/// iterations reached from it (innovations form, σ_e = 6.5e-4: the
/// optimum's one-step error, and 3e-4). In predictor coordinates K is a
/// linear parameter and A = Ā + KC moves with it; the exact solve crossed
/// the unit circle on every trial and the iterations stopped without an
/// accepted step on all ten records (cost 0.9–1.6e-2 kept). The solve now
/// backs off to an admissible fraction of its step, and the expected
/// decrease that ends the iterations counts the linear parameters' part
/// ‖r₁‖² too (held back at the boundary, β is not at its optimum: with
/// ‖r₂‖² alone one record still stopped at its start): the refinement
/// reaches below 1 % of the start's cost on every record (1e-6 – 2e-5).
#[test]
fn variable_projection_backs_off_at_the_stability_boundary() {
    let cm = |r: usize, c: usize, v: &[f64]| DMatrix::from_column_slice(r, c, v);
    let opt = StateSpace::new(
        cm(
            4,
            4,
            &[
                0.8401682576386523,
                -1.500567365006266,
                1.0218001407751571,
                -0.4212635514851871,
                0.16963702999110447,
                0.7776857498658106,
                -0.40560578553267956,
                -0.15555282653049457,
                -0.09005007045390019,
                0.49471280738861434,
                0.9549410044579423,
                -0.6951946982771523,
                0.027117628475746353,
                0.4406899662839693,
                -0.005687522784823686,
                0.690525417948123,
            ],
        ),
        cm(
            4,
            1,
            &[
                0.030450254534093033,
                1.482190038020464,
                0.18340685947914537,
                -0.4699975121091326,
            ],
        ),
        cm(
            1,
            4,
            &[
                0.07593076679285778,
                -0.10431760719950214,
                0.16307635425698994,
                -0.031495382858741476,
            ],
        ),
        cm(1, 1, &[-0.2390876841886568]),
        Some(1.0),
    )
    .unwrap();
    let k_opt = cm(
        4,
        1,
        &[
            3.4124846220426623,
            -8.11443286565667,
            4.196204135882873,
            -54.17106750887567,
        ],
    );
    let start = StateSpace::new(
        cm(
            4,
            4,
            &[
                0.7467648083156632,
                -1.531983953193864,
                0.9775613848108844,
                -0.3555250022450663,
                0.21403567914648203,
                0.7392600053563279,
                -0.4702877759451598,
                -0.15603703791483747,
                -0.024857602044219333,
                0.28996456126351106,
                0.7392811932697099,
                0.131640301347347,
                0.016825406096539628,
                0.024403952983962973,
                0.00592821653168344,
                0.8159521498450064,
            ],
        ),
        cm(
            4,
            1,
            &[
                -0.0642222481704794,
                1.335003391993908,
                -0.021022576497334827,
                -0.5197926573763175,
            ],
        ),
        cm(
            1,
            4,
            &[
                0.07446463398541543,
                -0.07038998625464866,
                0.1676942880704771,
                -0.012514589539674707,
            ],
        ),
        cm(1, 1, &[-0.1892814175569889]),
        Some(1.0),
    )
    .unwrap();
    let k_start = cm(
        4,
        1,
        &[
            3.287836213172478,
            -8.116381004951855,
            4.2428221650530915,
            -54.1296443638,
        ],
    );
    for (seed, noise) in (0..5u64).flat_map(|s| [(s, 3e-4), (s, 6.5e-4)]) {
        let n = 512;
        let u = rbs(seed, n, 1) * 0.165;
        let e = white(seed + 50, n, 1, noise);
        let mut y = DMatrix::zeros(n, 1);
        let mut x = nalgebra::DVector::zeros(4);
        for t in 0..n {
            let ut = u.row(t).transpose();
            let et = e.row(t).transpose();
            y.row_mut(t)
                .copy_from(&(opt.c() * &x + opt.d() * &ut + &et).transpose());
            x = opt.a() * &x + opt.b() * &ut + &k_opt * &et;
        }
        let recs = [Record {
            u: &u,
            y: &y,
            instrument: None,
        }];
        let vp = refine_pem(
            &start,
            Some(&k_start),
            &recs,
            &[],
            &PemOptions {
                method: PemMethod::VariableProjection,
                feedthrough: Feedthrough::Free,
                ..opts(PemCost::Prediction)
            },
        )
        .unwrap()
        .report;
        assert!(vp.accepted > 0, "seed {seed}, noise {noise}: {vp:?}");
        assert!(
            vp.final_cost < 0.01 * vp.initial_cost,
            "seed {seed}, noise {noise}: {vp:?}"
        );
    }
}

/// Issue 46, "Integrators kept": an integrator y(t+1) = y(t) + 0.1 u(t)
/// (open loop, random binary input, output noise σ = 0.01) refined from a
/// start just outside the unit circle (pole 1.0001). With the marginal
/// tolerance δ = 1e-3 the start is kept (no stabilised start) and the
/// refined pole stays within 1e-3 of 1 (its standard error on 2000
/// samples is of order 1/N = 5e-4); with δ = 0 (the default) the start is
/// reflected inside first, as before.
#[test]
fn a_marginal_start_is_kept_within_the_tolerance() {
    let n = 2000;
    let g = StateSpace::new(
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 0.1),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap();
    let u = rbs(5, n, 1);
    let y = sim(&g, &u, None) + white(6, n, 1, 0.01);
    let start = StateSpace::new(
        DMatrix::from_element(1, 1, 1.0001),
        DMatrix::from_element(1, 1, 0.1),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap();
    let rec = [Record {
        u: &u,
        y: &y,
        instrument: None,
    }];
    let marginal = PemOptions {
        marginal_tolerance: 1e-3,
        ..opts(PemCost::Prediction)
    };
    let fit = refine_pem(&start, None, &rec, &[], &marginal).unwrap();
    assert_eq!(fit.report.stabilized_start, None);
    let pole = fit.model.a()[(0, 0)];
    assert!((pole - 1.0).abs() < 1e-3, "pole {pole}");
    assert!(pole < 1.0 + 1e-3, "pole {pole}");
    let strict = refine_pem(&start, None, &rec, &[], &opts(PemCost::Prediction)).unwrap();
    assert_eq!(strict.report.stabilized_start, Some(1.0001));
    assert!(strict.model.a()[(0, 0)] < 1.0);
    // A tolerance that is not a finite non-negative number is refused.
    for bad in [f64::NAN, -1.0, f64::INFINITY] {
        let o = PemOptions {
            marginal_tolerance: bad,
            ..opts(PemCost::Prediction)
        };
        assert!(
            matches!(
                refine_pem(&start, None, &rec, &[], &o),
                Err(Error::InvalidOption { .. })
            ),
            "{bad}"
        );
    }
}

//! Prediction-error refinement (`refine_pem`): recovery from a perturbed
//! start, invariance under a similarity transform of the start, multirate
//! records, keep-the-better rule and rejected inputs.

use lifted_lti::StateSpace;
use lifted_subspace::*;
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
        Err(Error::NotExciting { .. })
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

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

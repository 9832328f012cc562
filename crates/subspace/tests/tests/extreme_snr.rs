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
    let err = estimate_bd(&a, &c, &rec, &Feedthrough::Free, InitialState::Estimate).unwrap_err();
    assert_unstable_estimate(&err, "output-error regression", 1.06);
    let err = estimate_bd_iv(&a, &c, &rec, &Feedthrough::Free, InitialState::Estimate).unwrap_err();
    assert_unstable_estimate(&err, "IV regression", 1.06);
    // A mildly unstable A whose growth stays below the bound is fine:
    // 1.005^2999 ≈ 3.3e6.
    let a = DMatrix::from_row_slice(2, 2, &[1.005, 0.0, 0.0, 0.5]);
    assert!(estimate_bd(&a, &c, &rec, &Feedthrough::Free, InitialState::Estimate).is_ok());
}

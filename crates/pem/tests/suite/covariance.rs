//! The covariance of a state-space model's entries
//! (`state_space_covariance`, issue 49): the 95 % regions of the frequency
//! response it gives hold the truth as often as they say, the entries' σ
//! follow the spread of the estimates, and bad calls are refused.

use lifted_lti::StateSpace;
use lifted_pem::*;
use lifted_subspace::{Experiment, Feedthrough, OrderSelection, Record, SubspaceOptions, identify};
use nalgebra::DMatrix;

use crate::common::*;

/// The true innovations model: poles 0.8 and 0.5, one input, one output,
/// K = [0.3, 0.1]ᵀ, innovations σ = 0.5 (`u`, `e` seeded).
fn truth() -> (StateSpace, DMatrix<f64>) {
    let g = StateSpace::new(
        DMatrix::from_row_slice(2, 2, &[0.8, 0.0, 0.0, 0.5]),
        DMatrix::from_row_slice(2, 1, &[1.0, 0.5]),
        DMatrix::from_row_slice(1, 2, &[1.0, 1.0]),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap();
    (g, DMatrix::from_row_slice(2, 1, &[0.3, 0.1]))
}

/// A record of the innovations model from rest.
fn record(seed: u64, n: usize) -> (DMatrix<f64>, DMatrix<f64>) {
    let (g, k) = truth();
    let u = rbs(seed, n, 1);
    let e = white(seed + 5000, n, 1, 0.5);
    let mut x = nalgebra::DVector::zeros(2);
    let mut y = DMatrix::zeros(n, 1);
    for t in 0..n {
        y[(t, 0)] = (g.c() * &x)[0] + e[(t, 0)];
        x = g.a() * &x + g.b() * u[(t, 0)] + &k * e[(t, 0)];
    }
    (u, y)
}

/// N4SID at order 2 (D = 0), refined by the prediction error and the
/// refined model kept (the estimate the covariance describes: the
/// prediction-error method's), with its Kalman gain.
fn estimate(u: &DMatrix<f64>, y: &DMatrix<f64>) -> (StateSpace, Option<DMatrix<f64>>) {
    let sub = identify(
        &[Experiment { u, y }],
        &SubspaceOptions {
            order: OrderSelection::Fixed(2),
            feedthrough: Feedthrough::Zero,
            ..Default::default()
        },
    )
    .unwrap();
    let rec = [Record {
        u,
        y,
        instrument: None,
    }];
    let fit = refine_pem(
        &sub.model,
        sub.kalman_gain.as_ref(),
        &rec,
        &[],
        &PemOptions {
            feedthrough: Feedthrough::Zero,
            keep_refined: true,
            ..Default::default()
        },
    )
    .unwrap();
    (fit.model, fit.kalman_gain)
}

fn options() -> CovarianceOptions {
    CovarianceOptions {
        feedthrough: Feedthrough::Zero,
        ..Default::default()
    }
}

/// Over 200 seeded records of 3000 samples, the 95 % region of the
/// complex frequency response (the ellipse of the (Re, Im) covariance at
/// the χ²₂ quantile 5.991) holds the true G at ω = 0.1, 0.5 and 1.5 in
/// 92–98 % of the 600 region-runs (the band: a binomial spread of
/// ±1.8 points at 2σ for 600 independent regions; 94.7 % measured). The
/// covariance is asymptotic: at 1000 samples the same regions held 90.7 %
/// (the empirical variances 1.2× the covariance's at the extreme
/// frequencies), at 2000 93.5 %, at 4000 96.2 %; and evaluated at the
/// subspace estimate where the keep-the-better rule kept it (85 of 200
/// records at 1000 samples) they held 87.8 % — the prediction-error
/// covariance is optimistic for the less efficient subspace estimate, as
/// MATLAB's convention for subspace models is.
#[test]
fn the_frequency_response_regions_hold_the_truth_at_their_level() {
    let (g, _) = truth();
    let w = [0.1, 0.5, 1.5];
    let g0 = g.freqresp(&w).unwrap();
    let (mut hits, mut total) = (0usize, 0usize);

    for seed in 0..200 {
        let (u, y) = record(100 + seed, 3000);
        let (m, k) = estimate(&u, &y);
        let rec = [Record {
            u: &u,
            y: &y,
            instrument: None,
        }];
        let unc = state_space_covariance(&m, k.as_ref(), &rec, &options()).unwrap();
        let cov = unc.covariance.freqresp_cov(&m, &w).unwrap();
        let gm = m.freqresp(&w).unwrap();
        for f in 0..w.len() {
            let d = gm[f][(0, 0)] - g0[f][(0, 0)];
            let c = cov[f][(0, 0)];
            let det = c[0][0] * c[1][1] - c[0][1] * c[1][0];
            let q =
                (c[1][1] * d.re * d.re - 2.0 * c[0][1] * d.re * d.im + c[0][0] * d.im * d.im) / det;
            total += 1;
            if q <= 5.991 {
                hits += 1;
            }
        }
    }
    let share = hits as f64 / total as f64;
    assert!((0.92..=0.98).contains(&share), "coverage {share}");
}

/// The σ of |G| at ω = 0.5 against the spread of |G| over 100 seeded
/// estimates: within 25 % (the spread of 100 estimates has a relative
/// error of about 1/√200 ≈ 7 %; the covariance is asymptotic).
#[test]
fn the_magnitude_sigma_is_the_spread_of_the_estimates() {
    let w = [0.5];
    let mut mags = Vec::new();
    let mut sigmas = Vec::new();
    for seed in 0..100 {
        let (u, y) = record(900 + seed, 2000);
        let (m, k) = estimate(&u, &y);
        let rec = [Record {
            u: &u,
            y: &y,
            instrument: None,
        }];
        let unc = state_space_covariance(&m, k.as_ref(), &rec, &options()).unwrap();
        mags.push(m.freqresp(&w).unwrap()[0][(0, 0)].norm());
        sigmas.push(unc.covariance.freqresp_std(&m, &w).unwrap().magnitude[0][(0, 0)]);
        assert!(
            (unc.noise_variance[0] - 0.25).abs() < 0.05,
            "{:?}",
            unc.noise_variance
        );
        assert_eq!(unc.measured, 2000);
    }
    let mean = mags.iter().sum::<f64>() / mags.len() as f64;
    let spread =
        (mags.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (mags.len() - 1) as f64).sqrt();
    let sigma = sigmas.iter().sum::<f64>() / sigmas.len() as f64;
    assert!(
        (sigma / spread - 1.0).abs() < 0.25,
        "σ {sigma} vs spread {spread}"
    );
}

#[test]
fn bad_calls_are_refused_by_name() {
    let (u, y) = record(7, 300);
    let (m, k) = estimate(&u, &y);
    let rec = [Record {
        u: &u,
        y: &y,
        instrument: None,
    }];
    // Too little work allowed.
    let e = state_space_covariance(
        &m,
        k.as_ref(),
        &rec,
        &CovarianceOptions {
            max_work: 10.0,
            ..options()
        },
    )
    .unwrap_err();
    assert!(matches!(e, Error::TooMuchWork { .. }), "{e}");
    // The predicted work counts the similarity tangent's null space (an
    // SVD of n² × (p + n²)), which dominates at high order: a 2 × 2 model
    // of order 48 on 600 samples (p = 340 local coordinates) is predicted
    // above the default 4e9 although its Jacobian pass is 1.3e9 (it took
    // 13 s when only the pass was counted).
    let pass = 2.0 * 340.0 * 600.0 * (48.0 * 52.0) + 2.0 * 341f64.powi(2) * 1200.0;
    let work = covariance_work(48, 2, 2, 340, 600, 1200);
    assert!(pass < 4e9 && work > 4e9, "{pass:e} {work:e}");
    // Too few samples for the coordinates.
    let short = [Record {
        u: &u.rows(0, 8).into_owned(),
        y: &y.rows(0, 8).into_owned(),
        instrument: None,
    }];
    let e = state_space_covariance(&m, k.as_ref(), &short, &options()).unwrap_err();
    assert!(matches!(e, Error::TooFewSamples { .. }), "{e}");
    // An unstable model has no prediction errors.
    let bad = StateSpace::new(
        m.a() * 2.0,
        m.b().clone(),
        m.c().clone(),
        m.d().clone(),
        Some(1.0),
    )
    .unwrap();
    let e = state_space_covariance(&bad, None, &rec, &options()).unwrap_err();
    assert!(matches!(e, Error::Unstable { .. }), "{e}");
    // A wrong Kalman gain shape.
    let e = state_space_covariance(&m, Some(&DMatrix::zeros(3, 1)), &rec, &options()).unwrap_err();
    assert!(matches!(e, Error::DimensionMismatch { .. }), "{e}");
}

use super::*;
use crate::data::{InputChannel, OutputChannel};

#[test]
fn corr_equals_the_serial_sum_at_every_lag() {
    // Lengths around the 4-wide blocks, lags of both signs up to and
    // past the record (no overlap: 0).
    for n in [0usize, 1, 3, 4, 5, 17] {
        let a: Vec<f64> = (0..n).map(|k| ((k * 7 % 11) as f64 - 5.0) / 3.0).collect();
        let b: Vec<f64> = (0..n).map(|k| ((k * 5 % 13) as f64 - 6.0) / 7.0).collect();
        for tau in -(n as i64) - 2..=n as i64 + 2 {
            let serial: f64 = (0..n as i64)
                .filter(|&k| (0..n as i64).contains(&(k + tau)))
                .map(|k| a[(k + tau) as usize] * b[k as usize])
                .sum();
            let c = corr(&a, &b, tau);
            assert!(
                (c - serial).abs() <= 1e-12 * (1.0 + serial.abs()),
                "n {n} tau {tau}: {c} vs {serial}"
            );
        }
    }
}

fn lag() -> StateSpace {
    StateSpace::new(
        DMatrix::from_element(1, 1, 0.8),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 0.5),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap()
}

#[test]
fn diverging_simulation_passes_no_residual_test() {
    // A = 2: the simulation overflows to ±∞ within the record, so the
    // residuals are not finite: no fit, and neither test may pass.
    let g = StateSpace::new(
        DMatrix::from_element(1, 1, 2.0),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap();
    let n = 2000;
    let u = DMatrix::from_fn(n, 1, |k, _| if (k * 7919) % 5 < 2 { 1.0 } else { -1.0 });
    let y = DMatrix::from_fn(n, 1, |k, _| (k as f64 * 0.1).sin());
    let v = validate(&g, &data(u, y, 1), &ValidationOptions::default()).unwrap();
    let o = &v.outputs[0];
    assert!(!v.stable());
    assert!((v.spectral_radius - 2.0).abs() < 1e-12);
    assert!(!o.residual_finite);
    assert!(o.fit.is_nan());
    assert!(!o.white && !o.independent);
    // A stable model keeps the flags as before.
    let n = 400;
    let u = DMatrix::from_fn(n, 1, |k, _| if (k * 7919) % 5 < 2 { 1.0 } else { -1.0 });
    let y = lag().lsim(&u, None, None).unwrap().y;
    let v = validate(&lag(), &data(u, y, 1), &ValidationOptions::default()).unwrap();
    assert!(v.stable() && v.outputs[0].residual_finite);
}

fn data(u: DMatrix<f64>, y: DMatrix<f64>, period: usize) -> Dataset {
    Dataset::new(
        1.0,
        u,
        y,
        vec![InputChannel::new("u", 1)],
        vec![OutputChannel::new("y", period, 0)],
    )
    .unwrap()
}

/// A record that starts away from rest (a slow plant, x(0) = 3): the
/// simulation from the estimated x₀ fits it exactly and recovers x(0);
/// from zero the transient costs fit. Multirate output (every 3rd
/// A long two-output record (validated an output per thread) gives
/// each output the numbers of its own validation (the model with that
/// output alone, from x₀ = 0, no gain: the same simulation of it), bit
/// for bit.
#[test]
fn outputs_validated_apart_are_validated_alone() {
    let g = StateSpace::new(
        DMatrix::from_row_slice(2, 2, &[0.9, 0.1, -0.2, 0.7]),
        DMatrix::from_row_slice(2, 1, &[0.1, 0.3]),
        DMatrix::from_row_slice(2, 2, &[1.0, 0.5, -0.3, 1.0]),
        DMatrix::from_row_slice(2, 1, &[0.0, 0.2]),
        Some(1.0),
    )
    .unwrap();
    let n = PARALLEL_SAMPLES + 10;
    let u = DMatrix::from_fn(n, 1, |k, _| if (k * 7919) % 13 < 6 { 1.0 } else { -1.0 });
    let mut y = g.lsim(&u, None, None).unwrap().y;
    for (k, mut row) in y.row_iter_mut().enumerate() {
        row[0] += 0.05 * (((k * 31) % 17) as f64 - 8.0);
        row[1] += 0.04 * (((k * 13) % 11) as f64 - 5.0);
    }
    let opts = ValidationOptions {
        initial_state: InitialCondition::Zero,
        ..Default::default()
    };
    let both = validate(
        &g,
        &Dataset::new(
            1.0,
            u.clone(),
            y.clone(),
            vec![InputChannel::new("u", 1)],
            vec![
                OutputChannel::new("y1", 1, 0),
                OutputChannel::new("y2", 1, 0),
            ],
        )
        .unwrap(),
        &opts,
    )
    .unwrap();
    for o in 0..2 {
        let alone = StateSpace::new(
            g.a().clone(),
            g.b().clone(),
            g.c().rows(o, 1).into_owned(),
            g.d().rows(o, 1).into_owned(),
            Some(1.0),
        )
        .unwrap();
        let d = Dataset::new(
            1.0,
            u.clone(),
            y.columns(o, 1).into_owned(),
            vec![InputChannel::new("u", 1)],
            vec![OutputChannel::new("y", 1, 0)],
        )
        .unwrap();
        let v = validate(&alone, &d, &opts).unwrap();
        let (a, b) = (&both.outputs[o], &v.outputs[0]);
        assert_eq!(a.fit.to_bits(), b.fit.to_bits());
        assert_eq!(a.auto, b.auto);
        assert_eq!(a.cross, b.cross);
        assert_eq!(a.simulated, b.simulated);
    }
}

/// `simulation_fits` gives `validate`'s fits bit for bit (x₀ estimated
/// or zero, an operating point, an output sampled every third instant,
/// a model with its gain), and its errors for wrong channels.
#[test]
fn simulation_fits_are_the_validations() {
    let g = StateSpace::new(
        DMatrix::from_row_slice(2, 2, &[0.9, 0.1, -0.2, 0.7]),
        DMatrix::from_row_slice(2, 1, &[0.1, 0.3]),
        DMatrix::from_row_slice(2, 2, &[1.0, 0.5, -0.3, 1.0]),
        DMatrix::from_row_slice(2, 1, &[0.0, 0.2]),
        Some(1.0),
    )
    .unwrap();
    let n = 500;
    let u = DMatrix::from_fn(n, 1, |k, _| if (k * 7919) % 13 < 6 { 1.0 } else { -1.0 });
    let x0 = DVector::from_row_slice(&[2.0, -1.0]);
    let mut y = g.lsim(&u, Some(&x0), None).unwrap().y;
    for (k, mut row) in y.row_iter_mut().enumerate() {
        row[0] += 0.05 * (((k * 31) % 17) as f64 - 8.0) + 1.5;
        row[1] += 0.04 * (((k * 13) % 11) as f64 - 5.0);
        if k % 3 != 0 {
            row[1] = f64::NAN;
        }
    }
    let d = Dataset::new(
        1.0,
        u,
        y,
        vec![InputChannel::new("u", 1)],
        vec![
            OutputChannel::new("y1", 1, 0),
            OutputChannel::new("y2", 3, 0),
        ],
    )
    .unwrap();
    let op = OperatingPoint {
        u0: vec![0.0],
        y0: vec![1.5, 0.0],
    };
    for (initial_state, gain) in [
        (InitialCondition::Estimate, None),
        (InitialCondition::Zero, None),
        (
            InitialCondition::Estimate,
            Some(DMatrix::from_element(2, 2, 0.1)),
        ),
    ] {
        let opts = ValidationOptions {
            operating_point: Some(op.clone()),
            initial_state,
            kalman_gain: gain,
            ..Default::default()
        };
        let v = validate(&g, &d, &opts).unwrap();
        let f = simulation_fits(&g, &d, &opts).unwrap();
        assert_eq!(f.len(), 2);
        for (a, b) in f.iter().zip(&v.outputs) {
            assert_eq!(a.fit.to_bits(), b.fit.to_bits());
            assert_eq!(a.samples, b.samples);
            assert!(a.finite);
        }
    }
    let one = StateSpace::new(
        DMatrix::from_element(1, 1, 0.5),
        DMatrix::from_element(1, 2, 1.0),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::zeros(1, 2),
        Some(1.0),
    )
    .unwrap();
    assert!(matches!(
        simulation_fits(&one, &d, &ValidationOptions::default()),
        Err(Error::DimensionMismatch { .. })
    ));
}

/// sample) likewise.
#[test]
fn the_initial_state_is_estimated_by_default() {
    let g = StateSpace::new(
        DMatrix::from_element(1, 1, 0.98),
        DMatrix::from_element(1, 1, 0.1),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap();
    let n = 600;
    let u = DMatrix::from_fn(n, 1, |k, _| if (k * 7919) % 13 < 6 { 1.0 } else { -1.0 });
    let x0 = DVector::from_element(1, 3.0);
    let y = g.lsim(&u, Some(&x0), None).unwrap().y;
    for period in [1, 3] {
        let mut ys = y.clone();
        for k in 0..n {
            if k % period != 0 {
                ys[(k, 0)] = f64::NAN;
            }
        }
        let d = data(u.clone(), ys, period);
        let v = validate(&g, &d, &ValidationOptions::default()).unwrap();
        assert!(
            (v.outputs[0].fit - 100.0).abs() < 1e-8,
            "{}",
            v.outputs[0].fit
        );
        let est = v.x0.as_ref().expect("estimated");
        assert!((est[0] - 3.0).abs() < 1e-9, "{est}");
        let zero = ValidationOptions {
            initial_state: InitialCondition::Zero,
            ..Default::default()
        };
        let v0 = validate(&g, &d, &zero).unwrap();
        assert!(v0.x0.is_none());
        // The transient 3·0.98ᵏ against a forced response of about
        // ±0.1/(1 − 0.98) = ±5 at most: tens of points lost.
        assert!(v0.outputs[0].fit < 80.0, "{}", v0.outputs[0].fit);
    }
}

#[test]
fn the_fits_do_not_depend_on_the_outputs_units() {
    // One slow state seen by two outputs, a model whose second output
    // gain is wrong (so x₀ is a compromise between the outputs), on a
    // record from x(0) = 4; then the same with output 2 in units 1e6
    // times larger: the same fits. Unweighted, the x₀ followed the
    // large output alone and output 1's fit changed.
    let model = |c2: f64, scale: f64| {
        StateSpace::new(
            DMatrix::from_element(1, 1, 0.98),
            DMatrix::from_element(1, 1, 0.05),
            DMatrix::from_row_slice(2, 1, &[1.0, c2 * scale]),
            DMatrix::zeros(2, 1),
            Some(1.0),
        )
        .unwrap()
    };
    let n = 400;
    let u = DMatrix::from_fn(n, 1, |k, _| if (k * 7919) % 13 < 6 { 1.0 } else { -1.0 });
    let x0 = DVector::from_element(1, 4.0);
    let fits = |scale: f64| {
        let y = model(-0.4, scale).lsim(&u, Some(&x0), None).unwrap().y;
        let d = Dataset::single_rate(1.0, u.clone(), y).unwrap();
        let v = validate(&model(-0.8, scale), &d, &ValidationOptions::default()).unwrap();
        [v.outputs[0].fit, v.outputs[1].fit]
    };
    let (f1, f2) = (fits(1.0), fits(1e6));
    for k in 0..2 {
        assert!(
            (f1[k] - f2[k]).abs() < 1e-6,
            "output {k}: {} vs {}",
            f1[k],
            f2[k]
        );
    }
}

/// A model validated on its own noise-free response fits 100 %, the
/// residual is zero (tests pass); a wrong model fits less.
#[test]
fn exact_model_fits_everything() {
    let u = DMatrix::from_fn(200, 1, |k, _| if (k * 7919) % 13 < 6 { 1.0 } else { -1.0 });
    let y = lag().lsim(&u, None, None).unwrap().y;
    let v = validate(&lag(), &data(u.clone(), y.clone(), 1), &Default::default()).unwrap();
    assert!((v.outputs[0].fit - 100.0).abs() < 1e-9);
    assert!(v.outputs[0].white && v.outputs[0].independent);
    assert!(v.horizons.is_empty());
    let mut wrong = lag();
    wrong = StateSpace::new(
        DMatrix::from_element(1, 1, 0.5),
        wrong.b().clone(),
        wrong.c().clone(),
        wrong.d().clone(),
        Some(1.0),
    )
    .unwrap();
    let w = validate(&wrong, &data(u, y, 1), &Default::default()).unwrap();
    assert!(w.outputs[0].fit < 90.0);
}

/// An innovations model, x⁺ = 0.8 x + u + 0.6 e, y = 0.5 x + e: with
/// its Kalman gain the tests run on the one-step prediction errors (the
/// innovations e: white, independent of u); without it on the
/// simulation error, the coloured noise (1 + 0.3 q⁻¹/(1 − 0.8 q⁻¹)) e,
/// which is not white. The tests ran on the simulation error with the
/// gain too, and a right model with its noise model never passed.
#[test]
fn a_model_with_its_gain_is_tested_on_its_innovations() {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let n = 4000;
    let mut g = || 12f64.sqrt() * (rng.random::<f64>() - 0.5);
    let u = DMatrix::from_fn(n, 1, |_, _| g());
    let e: Vec<f64> = (0..n).map(|_| 0.3 * g()).collect();
    let (mut x, mut y) = (0.0, DMatrix::zeros(n, 1));
    for k in 0..n {
        y[(k, 0)] = 0.5 * x + e[k];
        x = 0.8 * x + u[(k, 0)] + 0.6 * e[k];
    }
    let d = data(u, y, 1);
    let with_gain = ValidationOptions {
        kalman_gain: Some(DMatrix::from_element(1, 1, 0.6)),
        ..Default::default()
    };
    let v = validate(&lag(), &d, &with_gain).unwrap();
    assert_eq!(v.residual, Residual::OneStepPrediction);
    assert!(
        v.outputs[0].white && v.outputs[0].independent,
        "{:?}",
        v.outputs[0].auto
    );
    let v = validate(&lag(), &d, &ValidationOptions::default()).unwrap();
    assert_eq!(v.residual, Residual::Simulation);
    assert!(!v.outputs[0].white, "{:?}", v.outputs[0].auto);
}

/// Multirate: only the measured samples are compared.
#[test]
fn multirate_compares_measured_samples() {
    let u = DMatrix::from_fn(300, 1, |k, _| ((k as f64) * 0.37).sin());
    let mut y = lag().lsim(&u, None, None).unwrap().y;
    for k in 0..300 {
        if k % 3 != 0 {
            y[(k, 0)] = f64::NAN;
        }
    }
    let v = validate(&lag(), &data(u, y, 3), &Default::default()).unwrap();
    assert_eq!(v.outputs[0].samples, 100);
    assert!((v.outputs[0].fit - 100.0).abs() < 1e-9);
}

#[test]
fn outputs_near_the_ends_of_the_double_range_are_scored() {
    // A record in units of 1e160 (1e-170): the same fit and the same
    // correlations as in units of 1 (they read "n/a: constant output"
    // and 0: the squares overflowed).
    let u = DMatrix::from_fn(300, 1, |k, _| if (k * 7919) % 13 < 6 { 1.0 } else { -1.0 });
    let y = lag()
        .lsim(&u, None, None)
        .unwrap()
        .y
        .map(|v| v + 0.3 * (v * 7.0).sin());
    let base = validate(&lag(), &data(u.clone(), y.clone(), 1), &Default::default()).unwrap();
    for unit in [1e160, 1e-170] {
        let scaled = StateSpace::new(
            lag().a().clone(),
            lag().b().clone(),
            lag().c() * unit,
            lag().d().clone(),
            Some(1.0),
        )
        .unwrap();
        let v = validate(
            &scaled,
            &data(u.clone(), y.map(|x| x * unit), 1),
            &Default::default(),
        )
        .unwrap();
        let (a, b) = (&base.outputs[0], &v.outputs[0]);
        assert!(
            (a.fit - b.fit).abs() < 1e-9,
            "{unit}: {} vs {}",
            a.fit,
            b.fit
        );
        for (x, z) in a.auto.iter().zip(&b.auto) {
            assert!((x - z).abs() < 1e-9, "{unit}: {x} vs {z}");
        }
    }
}

#[test]
fn zero_lags_are_refused() {
    // Nothing tested passed both tests ("white yes, independent yes").
    let u = DMatrix::from_fn(100, 1, |k, _| ((k as f64) * 0.37).sin());
    let y = lag().lsim(&u, None, None).unwrap().y;
    let opts = ValidationOptions {
        lags: 0,
        ..Default::default()
    };
    let e = validate(&lag(), &data(u, y, 1), &opts).unwrap_err();
    assert!(e.to_string().contains("at least 1 correlation lag"), "{e}");
}

#[test]
fn bad_input_is_named() {
    let u = DMatrix::from_element(30, 1, 1.0);
    let y = lag().lsim(&u, None, None).unwrap().y;
    let d = data(u, y, 1);
    let e = validate(&lag(), &d, &Default::default()).unwrap_err();
    assert!(
        matches!(e, Error::InvalidArgument { what: "lags", .. }),
        "{e}"
    );
    let opts = ValidationOptions {
        lags: 5,
        kalman_gain: Some(DMatrix::zeros(2, 1)),
        ..Default::default()
    };
    let e = validate(&lag(), &d, &opts).unwrap_err();
    assert!(
        matches!(
            e,
            Error::DimensionMismatch {
                what: "Kalman gain",
                ..
            }
        ),
        "{e}"
    );
    let other = StateSpace::new(
        lag().a().clone(),
        lag().b().clone(),
        lag().c().clone(),
        lag().d().clone(),
        Some(0.5),
    )
    .unwrap();
    let e = validate(
        &other,
        &d,
        &ValidationOptions {
            lags: 5,
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(matches!(e, Error::DomainMismatch { .. }), "{e}");
}

//! Noise: SNR scaling (both definitions), colour, integration.

use crate::common::*;
use lifted_sim::plants;
use lifted_sim::{Controller, Excitation, NoiseLevel, NoiseSpec, Plant, Simulator, SnrDefinition};
use nalgebra::DMatrix;

#[test]
fn snr_scaling_hits_the_requested_ratio_open_loop() -> TestResult {
    let fx = plants::stirred_tank_5_3_1()?;
    let n = 20_000;
    let u = random_input(n, 2, 1, 21);
    for (def, ratio) in [
        (SnrDefinition::Variance, 5.0),
        (SnrDefinition::StdRatio, 2.5),
    ] {
        let spec = NoiseSpec {
            model: fx.noise.clone(),
            level: NoiseLevel::Snr {
                ratio: vec![ratio],
                definition: def,
            },
            seed: 3,
            ..Default::default()
        };
        let out = Simulator::open_loop(fx.discrete_plant()?)
            .with_noise(spec)?
            .simulate(&Excitation::input(u.clone()))?;
        for j in 0..2 {
            let vs = variance(out.y_clean.column(j).as_slice());
            let vn = variance(out.noise.column(j).as_slice());
            let got = match def {
                SnrDefinition::Variance => vs / vn,
                SnrDefinition::StdRatio => (vs / vn).sqrt(),
            };
            assert!(
                (got / ratio - 1.0).abs() < 0.01,
                "{def:?} channel {j}: {got}"
            );
            // measured = clean + noise
            let sum = &out.y_clean + &out.noise;
            assert!(max_diff(&sum, &out.y) < 1e-12);
        }
    }
    Ok(())
}

#[test]
fn snr_per_channel_in_closed_loop_uses_the_noise_free_output() -> TestResult {
    let fx = plants::chapter7_siso()?;
    let n = 30_000;
    let r2 = random_input(n, 1, 1, 8).map(|v| v.signum());
    let base = fx.simulator()?;
    let clean = base.simulate(&Excitation::input(r2.clone()))?;
    let spec = fx
        .noise_spec(2.5, SnrDefinition::Variance, 17)
        .ok_or("noise")?;
    let noisy = fx
        .simulator()?
        .with_noise(spec)?
        .simulate(&Excitation::input(r2))?;
    let got = variance(clean.y.column(0).as_slice()) / variance(noisy.noise.column(0).as_slice());
    assert!((got / 2.5 - 1.0).abs() < 0.01, "{got}");
    // the noise circulates: u differs from the noise-free u
    assert!(max_diff(clean.u(), noisy.u()) > 1e-3);
    Ok(())
}

#[test]
fn per_channel_ratios_and_absolute_levels() -> TestResult {
    let fx = plants::stirred_tank_5_3_1()?;
    let n = 20_000;
    let u = random_input(n, 2, 1, 2);
    let spec = NoiseSpec {
        level: NoiseLevel::Snr {
            ratio: vec![2.0, 8.0],
            definition: SnrDefinition::Variance,
        },
        seed: 1,
        ..Default::default()
    };
    let out = Simulator::open_loop(fx.discrete_plant()?)
        .with_noise(spec)?
        .simulate(&Excitation::input(u.clone()))?;
    for (j, r) in [2.0, 8.0].iter().enumerate() {
        let got =
            variance(out.y_clean.column(j).as_slice()) / variance(out.noise.column(j).as_slice());
        assert!((got / r - 1.0).abs() < 0.01);
    }
    // absolute std: white noise of std 0.3 (sample std within 2% on 20000 samples)
    let spec = NoiseSpec {
        level: NoiseLevel::Std(vec![0.3]),
        seed: 1,
        ..Default::default()
    };
    let out = Simulator::open_loop(fx.discrete_plant()?)
        .with_noise(spec)?
        .simulate(&Excitation::input(u))?;
    let s = variance(out.noise.column(1).as_slice()).sqrt();
    assert!((s / 0.3 - 1.0).abs() < 0.02, "{s}");
    assert_eq!(out.noise_scale, vec![1.0, 1.0]);
    Ok(())
}

#[test]
fn coloured_and_integrated_noise() -> TestResult {
    let g = tf(&[0.1], &[1.0, -0.9], Some(1.0));
    let n = 50_000;
    let u = DMatrix::zeros(n, 1);
    // AR(1) noise 1/(1 − 0.97 z⁻¹): lag-1 autocorrelation 0.97, started stationary
    let ar = tf(&[1.0, 0.0], &[1.0, -0.97], Some(1.0));
    let spec = NoiseSpec {
        model: Some(ar),
        level: NoiseLevel::Std(vec![1.0]),
        seed: 4,
        ..Default::default()
    };
    let out = Simulator::open_loop(Plant::discrete(&g, &[], &[])?)
        .with_noise(spec)?
        .simulate(&Excitation::input(u.clone()))?;
    let rho = lag1(out.noise.column(0).as_slice());
    assert!((rho - 0.97).abs() < 0.01, "{rho}");
    // stationary start: the first samples already have the stationary variance 1/(1 − 0.97²) ≈ 16.9 on average
    let v = variance(out.noise.column(0).as_slice());
    assert!(
        (v / (1.0 / (1.0 - 0.97f64.powi(2))) - 1.0).abs() < 0.15,
        "{v}"
    );
    // integrated white noise: the increments are white with std 1
    let spec = NoiseSpec {
        integrated: true,
        level: NoiseLevel::Std(vec![1.0]),
        seed: 4,
        ..Default::default()
    };
    let out = Simulator::open_loop(Plant::discrete(&g, &[], &[])?)
        .with_noise(spec)?
        .simulate(&Excitation::input(u))?;
    let col = out.noise.column(0);
    let inc: Vec<f64> = (1..n).map(|k| col[k] - col[k - 1]).collect();
    assert!(lag1(&inc).abs() < 0.02);
    assert!((variance(&inc) - 1.0).abs() < 0.03);
    assert!(lag1(col.as_slice()) > 0.99);
    Ok(())
}

#[test]
fn noise_in_a_decentralised_loop_is_deterministic() -> TestResult {
    let fx = plants::stirred_tank_7_8_2()?;
    let spec = fx
        .noise_spec(5.0, SnrDefinition::StdRatio, 99)
        .ok_or("noise")?;
    let sim = fx.simulator()?.with_noise(spec)?;
    let exc = Excitation::both(random_input(2000, 2, 1, 1), random_input(2000, 2, 1, 2));
    assert_eq!(sim.simulate(&exc)?, sim.simulate(&exc)?);
    let _ = Controller::gain(DMatrix::zeros(2, 2), 1.0)?;
    Ok(())
}

#[test]
fn snr_on_the_measured_samples_only() -> TestResult {
    // y1 measured every 5 samples (offset 2), y2 every sample: with
    // SnrSamples::Measured the ratio holds exactly on y1's measured samples
    let fx = plants::stirred_tank_5_3_1()?;
    let n = 6000;
    let u = random_input(n, 2, 3, 5);
    let spec = NoiseSpec {
        model: fx.noise.clone(),
        level: NoiseLevel::Snr {
            ratio: vec![4.0],
            definition: SnrDefinition::Variance,
        },
        seed: 9,
        ..Default::default()
    };
    let base = Simulator::open_loop(fx.discrete_plant()?)
        .with_sampling(&[(5, 2), (1, 0)])?
        .with_noise(spec)?;
    let measured = base.clone().with_options(lifted_sim::SimOptions {
        snr_samples: lifted_sim::SnrSamples::Measured,
        ..Default::default()
    })?;
    let every5 = |x: &[f64]| x.iter().skip(2).step_by(5).copied().collect::<Vec<f64>>();
    let ratio_on = |out: &lifted_sim::SimOutput, j: usize, slow: bool| {
        let (c, v) = (out.y_clean.column(j), out.noise.column(j));
        if slow {
            variance(&every5(c.as_slice())) / variance(&every5(v.as_slice()))
        } else {
            variance(c.as_slice()) / variance(v.as_slice())
        }
    };
    let exc = Excitation::input(u);
    let (a, b) = (base.simulate(&exc)?, measured.simulate(&exc)?);
    // default: exact on the fast record; measured: exact on the measured samples
    assert!((ratio_on(&a, 0, false) - 4.0).abs() < 1e-9);
    assert!((ratio_on(&b, 0, true) - 4.0).abs() < 1e-9);
    // y2 is measured every sample: both agree there
    assert!((ratio_on(&b, 1, false) - 4.0).abs() < 1e-9);
    // the two windows give (slightly) different scales on y1
    assert!(a.noise_scale[0] != b.noise_scale[0]);
    Ok(())
}

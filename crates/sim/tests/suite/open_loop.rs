//! Open-loop simulation against lifted-lti and analytic ZOH models.

use crate::common::*;
use lifted_lti::{C2dOptions, StateSpace};
use lifted_sim::{Delays, Excitation, NoiseSpec, Plant, Simulator};
use nalgebra::DMatrix;

fn plant_2x2() -> StateSpace {
    // a 4-state 2x2 continuous plant with feedthrough on one entry
    let a = DMatrix::from_row_slice(
        4,
        4,
        &[
            -1.0, 0.5, 0.0, 0.0, -0.5, -1.2, 0.0, 0.1, 0.0, 0.0, -0.3, 0.0, 0.2, 0.0, 1.0, -2.0,
        ],
    );
    let b = DMatrix::from_row_slice(4, 2, &[1.0, 0.0, 0.0, 0.5, 0.3, 1.0, 0.0, -0.4]);
    let c = DMatrix::from_row_slice(2, 4, &[1.0, 0.0, 0.5, 0.0, 0.0, 1.0, 0.0, 0.7]);
    let d = DMatrix::from_row_slice(2, 2, &[0.0, 0.1, 0.0, 0.0]);
    StateSpace::new(a, b, c, d, None).unwrap()
}

#[test]
fn noise_free_open_loop_equals_lsim_of_zoh_model() -> TestResult {
    let g = plant_2x2();
    let ts = 0.1;
    let plant = Plant::continuous(&g, ts, &Delays::default())?;
    let zoh = g.c2d(ts, &C2dOptions::default())?;
    let u = random_input(2000, 2, 1, 7);
    let out = Simulator::open_loop(plant).simulate(&Excitation::input(u.clone()))?;
    let reference = zoh.lsim(&u, None, None)?.y;
    // same operations in a different summation order: rounding level
    let err = max_diff(&out.y, &reference);
    assert!(err <= 1e-12 * max_abs(&reference).max(1.0), "err {err}");
    assert_eq!(out.u(), &u);
    // the continuous lsim (ZOH inside lifted-lti) agrees too
    let cont = g.lsim(&u, None, Some(ts))?.y;
    assert!(max_diff(&out.y, &cont) <= 1e-12 * max_abs(&cont).max(1.0));
    Ok(())
}

#[test]
fn fractional_input_delay_equals_analytic_zoh_with_delay() -> TestResult {
    // 1/(tau s + 1) with delay 2.3 T: modified z-transform
    // y(k+1) = a y(k) + g0 u(k-2) + g1 u(k-3), a = e^{-T/tau},
    // g0 = 1 - e^{-(T-δ)/tau}, g1 = e^{-(T-δ)/tau} - e^{-T/tau}, δ = 0.3 T.
    let (ts, tau, delay) = (0.5, 2.0, 2.3 * 0.5);
    let g = tf(&[1.0], &[tau, 1.0], None);
    let plant = Plant::continuous(&g, ts, &Delays::input(vec![delay]))?;
    let n = 500;
    let u = random_input(n, 1, 1, 3);
    let out = Simulator::open_loop(plant).simulate(&Excitation::input(u.clone()))?;
    let dlt = delay - 2.0 * ts;
    let a = (-ts / tau).exp();
    let g0 = 1.0 - (-(ts - dlt) / tau).exp();
    let g1 = (-(ts - dlt) / tau).exp() - a;
    let mut y = vec![0.0; n];
    for k in 0..n - 1 {
        let uk = |i: isize| if i >= 0 { u[(i as usize, 0)] } else { 0.0 };
        y[k + 1] = a * y[k] + g0 * uk(k as isize - 2) + g1 * uk(k as isize - 3);
    }
    let analytic = DMatrix::from_column_slice(n, 1, &y);
    assert!(
        max_diff(&out.y, &analytic) < 1e-12,
        "{}",
        max_diff(&out.y, &analytic)
    );
    // step response: 1 − e^{−(kT − τ_d)/τ} for kT ≥ τ_d, not rounded to 2 or 3 samples
    let step = Simulator::open_loop(Plant::continuous(&g, ts, &Delays::input(vec![delay]))?)
        .simulate(&Excitation::input(DMatrix::from_element(40, 1, 1.0)))?;
    for k in 0..40 {
        let t = k as f64 * ts;
        let expect = if t >= delay {
            1.0 - (-(t - delay) / tau).exp()
        } else {
            0.0
        };
        assert!(
            (step.y[(k, 0)] - expect).abs() < 1e-13,
            "k {k}: {} vs {expect}",
            step.y[(k, 0)]
        );
    }
    Ok(())
}

#[test]
fn fractional_output_delays_per_channel_are_exact() -> TestResult {
    // two outputs of one input: 1/(s+1) delayed 0.4 s and 2/(2s+1) delayed 1.7 s
    let a = DMatrix::from_row_slice(2, 2, &[-1.0, 0.0, 0.0, -0.5]);
    let b = DMatrix::from_row_slice(2, 1, &[1.0, 1.0]);
    let c = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 1.0]);
    let g = StateSpace::new(a, b, c, DMatrix::zeros(2, 1), None)?;
    let ts = 0.25;
    let delays = Delays {
        input: vec![0.1],
        output: vec![0.3, 1.6],
    };
    let plant = Plant::continuous(&g, ts, &delays)?;
    let out = Simulator::open_loop(plant)
        .simulate(&Excitation::input(DMatrix::from_element(60, 1, 1.0)))?;
    for k in 0..60 {
        let t = k as f64 * ts;
        let e1 = if t >= 0.4 {
            1.0 - (-(t - 0.4)).exp()
        } else {
            0.0
        };
        let e2 = if t >= 1.7 {
            2.0 * (1.0 - (-(t - 1.7) / 2.0).exp())
        } else {
            0.0
        };
        assert!(
            (out.y[(k, 0)] - e1).abs() < 1e-13 && (out.y[(k, 1)] - e2).abs() < 1e-13,
            "k {k}"
        );
    }
    Ok(())
}

#[test]
fn discrete_plant_with_integer_delays() -> TestResult {
    let g = tf(&[0.5], &[1.0, -0.8], Some(1.0));
    let plant = Plant::discrete(&g, &[2], &[1])?;
    let out = Simulator::open_loop(plant)
        .simulate(&Excitation::input(DMatrix::from_element(10, 1, 1.0)))?;
    // 0.5 z^-4/(1 - 0.8 z^-1): first nonzero at k = 4
    assert_eq!(out.y[(3, 0)], 0.0);
    assert!((out.y[(4, 0)] - 0.5).abs() < 1e-15);
    assert!((out.y[(5, 0)] - 0.9).abs() < 1e-15);
    Ok(())
}

#[test]
fn same_seed_same_data_bit_for_bit() -> TestResult {
    let g = tf(&[1.0], &[5.0, 1.0], None);
    let noise = tf(&[1.0], &[2.0, 1.0], None);
    let mk = |seed| -> Result<_, lifted_sim::Error> {
        Simulator::open_loop(Plant::continuous(&g, 1.0, &Delays::default())?)
            .with_noise(NoiseSpec::filtered(
                noise.clone(),
                4.0,
                Default::default(),
                seed,
            ))?
            .simulate(&Excitation::input(random_input(3000, 1, 3, 11)))
    };
    let (a, b, c) = (mk(5)?, mk(5)?, mk(6)?);
    assert!(
        a.y.iter()
            .zip(b.y.iter())
            .all(|(x, y)| x.to_bits() == y.to_bits())
    );
    assert_eq!(a.data, b.data);
    assert!(max_diff(&a.y, &c.y) > 1e-3);
    Ok(())
}

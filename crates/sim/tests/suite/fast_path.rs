//! The fused per-phase path (`simulate`) against the block-by-block
//! reference path (`simulate_reference`): equal to 1e-12 (relative to the
//! signal size) on every loop structure the simulator supports. The two
//! paths differ only in the order of the floating-point sums.

use crate::common::*;
use lifted_lti::InputChannel;
use lifted_sim::plants::{self, RenZhuController, RenZhuPlant};
use lifted_sim::{
    Controller, Excitation, Feedback, NoiseLevel, NoiseSpec, Plant, SimOutput, Simulator,
    SnrDefinition,
};
use nalgebra::DMatrix;

/// max |a − b| ≤ 1e-12 · max(1, max |b|).
fn close(what: &str, a: &DMatrix<f64>, b: &DMatrix<f64>) {
    let d = max_diff(a, b);
    let scale = max_abs(b).max(1.0);
    assert!(
        d <= 1e-12 * scale,
        "{what}: |fast − reference| = {d:e}, scale {scale:e}"
    );
}

fn same(a: &SimOutput, b: &SimOutput) {
    close("y", &a.y, &b.y);
    close("y_clean", &a.y_clean, &b.y_clean);
    close("u", a.u(), b.u());
    close("noise", &a.noise, &b.noise);
    for (x, y) in a.noise_scale.iter().zip(&b.noise_scale) {
        assert!(
            (x - y).abs() <= 1e-12 * y.abs().max(1.0),
            "noise scale {x} vs {y}"
        );
    }
    // the data set: same NaN pattern, same samples
    let (ya, yb) = (a.data.y(), b.data.y());
    assert_eq!(ya.shape(), yb.shape());
    for (x, y) in ya.iter().zip(yb.iter()) {
        assert_eq!(x.is_nan(), y.is_nan());
    }
    let fin = |m: &DMatrix<f64>| m.map(|v| if v.is_nan() { 0.0 } else { v });
    close("data.y", &fin(ya), &fin(yb));
    assert_eq!(a.data.inputs(), b.data.inputs());
    assert_eq!(a.data.outputs(), b.data.outputs());
    let za = DMatrix::from_column_slice(a.final_state.len(), 1, &a.final_state);
    let zb = DMatrix::from_column_slice(b.final_state.len(), 1, &b.final_state);
    close("final state", &za, &zb);
}

fn check(sim: &Simulator, exc: &Excitation) -> TestResult {
    same(&sim.simulate(exc)?, &sim.simulate_reference(exc)?);
    Ok(())
}

fn coloured(ny: usize, level: NoiseLevel, seed: u64) -> NoiseSpec {
    let h = lifted_lti::TransferFunction::from_coeffs(&[0.2, 0.0], &[1.0, -0.8], Some(1.0))
        .expect("filter");
    NoiseSpec {
        model: Some(NoiseSpec::diagonal_model(&vec![h; ny]).expect("diagonal model")),
        level,
        seed,
        ..Default::default()
    }
}

#[test]
fn open_loop_with_holds_sampling_and_noise() -> TestResult {
    let fx = plants::stirred_tank_5_3_1()?;
    let n = 3000;
    let r2 = random_input(n, 2, 1, 21);
    let base = Simulator::open_loop(fx.discrete_plant()?);
    check(&base, &Excitation::input(r2.clone()))?;
    let multirate = base
        .with_inputs(vec![
            InputChannel::new("u1", 3),
            InputChannel::new("u2", 2).with_offset(1),
        ])?
        .with_sampling(&[(5, 2), (3, 0)])?;
    check(&multirate, &Excitation::input(r2.clone()))?;
    let noisy = multirate.with_noise(coloured(
        2,
        NoiseLevel::Snr {
            ratio: vec![4.0],
            definition: SnrDefinition::Variance,
        },
        3,
    ))?;
    check(&noisy, &Excitation::input(r2))
}

#[test]
fn closed_loop_fast_hold_last_and_multirate() -> TestResult {
    let fx = plants::stirred_tank_7_8_2()?;
    let n = 4000;
    let exc = Excitation::both(random_input(n, 2, 1, 4), random_input(n, 2, 1, 5));
    let sim = fx.simulator()?; // y1 every 5, y2 every 1
    check(&sim, &exc)?;
    let abs = sim
        .clone()
        .with_noise(coloured(2, NoiseLevel::Std(vec![0.1, 0.3]), 8))?;
    check(&abs, &exc)?;
    let held = abs
        .with_holds(&[2, 3])?
        .with_sampling(&[(3, 1), (2, 0)])?
        .with_feedback(Feedback::HoldLast)?;
    check(&held, &exc)?;
    let snr = held.with_noise(NoiseSpec::white_snr(10.0, 12))?;
    check(&snr, &exc)
}

#[test]
fn inferential_feedback() -> TestResult {
    let fx = plants::chapter9_dual_rate()?;
    let sim = fx.simulator()?;
    let n = 2000;
    let r1 = random_input(n, 1, 20, 6);
    check(&sim, &Excitation::reference(r1.clone()))?;
    let noisy = sim.with_noise(coloured(
        1,
        NoiseLevel::Snr {
            ratio: vec![2.0],
            definition: SnrDefinition::StdRatio,
        },
        7,
    ))?;
    check(&noisy, &Excitation::both(r1, random_input(n, 1, 3, 9)))
}

#[test]
fn direct_feedthrough_is_solved_per_phase() -> TestResult {
    // biproper plant and controller: (I + D_K D_v) is solved, differently
    // at sampled and unsampled phases with hold-last feedback
    let g = tf(&[1.0, -0.5], &[1.0, -0.9], Some(1.0));
    let k = tf(&[0.6, -0.4], &[1.0, -1.0], Some(1.0));
    let sim = Simulator::closed_loop(Plant::discrete(&g, &[], &[])?, Controller::from_ss(&k)?)?;
    let n = 1500;
    let exc = Excitation::both(random_input(n, 1, 1, 10), random_input(n, 1, 2, 11));
    check(&sim, &exc)?;
    let multirate = sim
        .with_sampling(&[(3, 1)])?
        .with_feedback(Feedback::HoldLast)?
        .with_noise(NoiseSpec::white_snr(5.0, 1))?;
    check(&multirate, &exc)
}

#[test]
fn whole_loop_model() -> TestResult {
    let fx = plants::ren_zhu(RenZhuPlant::G1, RenZhuController::P)?;
    let sim = fx.simulator()?.with_noise(NoiseSpec::white_snr(10.0, 2))?;
    let n = 1000;
    check(
        &sim,
        &Excitation::both(random_input(n, 1, 7, 1), random_input(n, 1, 3, 2)),
    )
}

#[test]
fn simulate_into_reuses_buffers_and_equals_simulate() -> TestResult {
    let fx = plants::stirred_tank_7_8_2()?;
    let sim = fx.simulator()?.with_noise(NoiseSpec::white_snr(3.0, 4))?;
    let mut sig = lifted_sim::SimSignals::default();
    for (n, seed) in [(500, 1), (800, 2), (800, 3)] {
        let exc = Excitation::both(random_input(n, 2, 1, seed), random_input(n, 2, 2, seed + 9));
        sim.simulate_into(&exc, &mut sig)?;
        let full = sim.simulate(&exc)?;
        assert_eq!(&sig.u, full.u());
        assert_eq!(sig.y, full.y);
        assert_eq!(sig.y_clean, full.y_clean);
        assert_eq!(sig.noise, full.noise);
        assert_eq!(sig.noise_scale, full.noise_scale);
        assert_eq!(sig.final_state, full.final_state);
    }
    Ok(())
}

#[test]
fn large_loop_takes_the_run_time_size_step() -> TestResult {
    // a 30-state 2x2 plant under a PI pair: 32 live states + y + u = 36
    // rows, beyond the compile-time sizes; fast, held and noisy variants
    let n_x = 30;
    let a = DMatrix::from_fn(n_x, n_x, |i, j| {
        if i == j {
            0.9 - 0.01 * i as f64
        } else if j + 1 == i {
            0.05
        } else {
            0.0
        }
    });
    let b = DMatrix::from_fn(n_x, 2, |i, j| if i % 2 == j { 0.05 } else { 0.01 });
    let c = DMatrix::from_fn(2, n_x, |i, j| if j % 2 == i { 0.3 } else { 0.05 });
    let g = lifted_lti::StateSpace::new(a, b, c, DMatrix::zeros(2, 2), Some(1.0))?;
    let k = Controller::decentralized(
        2,
        2,
        1.0,
        &[
            (0, 0, &[0.3, -0.25], &[1.0, -1.0]),
            (1, 1, &[0.2, -0.15], &[1.0, -1.0]),
        ],
    )?;
    let sim = Simulator::closed_loop(Plant::discrete(&g, &[], &[])?, k)?;
    let n = 1500;
    let exc = Excitation::both(random_input(n, 2, 1, 31), random_input(n, 2, 1, 32));
    check(&sim, &exc)?;
    let noisy = sim
        .clone()
        .with_noise(coloured(2, NoiseLevel::Std(vec![0.2]), 5))?;
    check(&noisy, &exc)?;
    let held = noisy
        .with_holds(&[3, 2])?
        .with_sampling(&[(4, 1), (1, 0)])?
        .with_feedback(Feedback::HoldLast)?;
    check(&held, &exc)
}

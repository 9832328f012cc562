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

mod random_loops {
    //! Property: on random loops — plant order 1–6, 1–3 inputs and outputs,
    //! direct feedthrough or not, random holds, output sampling and
    //! offsets, fast / hold-last / inferential feedback, a controller at T
    //! or at 2T/3T,
    //! absolute coloured noise — the fused path equals the block-by-block
    //! reference (1e-10 relative), or both report the same divergence.
    use super::*;
    use lifted_lti::StateSpace;
    use lifted_sim::Error;
    use proptest::prelude::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_ss(
        rng: &mut ChaCha8Rng,
        n: usize,
        p: usize,
        m: usize,
        d: bool,
        ts: f64,
    ) -> StateSpace {
        let mut a = DMatrix::from_fn(n, n, |_, _| rng.random_range(-1.0..1.0));
        // scale to spectral radius ≤ 0.9 (the ∞-norm bounds it)
        let norm = (0..n)
            .map(|i| a.row(i).iter().map(|v: &f64| v.abs()).sum::<f64>())
            .fold(0.0, f64::max);
        a *= 0.9 / norm.max(1e-12);
        let b = DMatrix::from_fn(n, m, |_, _| rng.random_range(-1.0..1.0));
        let c = DMatrix::from_fn(p, n, |_, _| rng.random_range(-1.0..1.0));
        let dm = DMatrix::from_fn(
            p,
            m,
            |_, _| if d { rng.random_range(-0.3..0.3) } else { 0.0 },
        );
        StateSpace::new(a, b, c, dm, Some(ts)).expect("valid model")
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
        #[test]
        fn fused_equals_reference(seed in 0u64..1_000_000) {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let (n, ny, nu) = (rng.random_range(1..7usize), rng.random_range(1..4usize), rng.random_range(1..4usize));
            let dg = rng.random_bool(0.3);
            let g = random_ss(&mut rng, n, ny, nu, dg, 1.0);
            let k_period = [1.0, 2.0, 3.0][rng.random_range(0..3usize)];
            let nk = rng.random_range(0..3usize);
            let dk = rng.random_bool(0.5);
            let k = random_ss(&mut rng, nk, nu, ny, dk, k_period);
            let k = StateSpace::new(k.a().clone(), k.b() * 0.2, k.c() * 0.2, k.d() * 0.2, Some(k_period)).unwrap();
            let phase = rng.random_range(0..k_period as usize);
            let holds: Vec<usize> = (0..nu).map(|_| rng.random_range(1..4usize)).collect();
            let sampling: Vec<(usize, usize)> = (0..ny)
                .map(|_| {
                    let p = rng.random_range(1..5usize);
                    (p, rng.random_range(0..p))
                })
                .collect();
            let mut sim = Simulator::closed_loop(
                Plant::discrete(&g, &[], &[]).unwrap(),
                Controller::from_ss(&k).unwrap().with_phase(phase),
            )
            .unwrap()
            .with_holds(&holds)
            .unwrap()
            .with_sampling(&sampling)
            .unwrap();
            match rng.random_range(0..3usize) {
                0 => {}
                1 => sim = sim.with_feedback(Feedback::HoldLast).unwrap(),
                _ => {
                    let np = rng.random_range(1..4usize);
                    let dp = rng.random_bool(0.5);
                    let phat = random_ss(&mut rng, np, ny, nu, dp, 1.0);
                    sim = sim.with_feedback(Feedback::Inferential(phat)).unwrap();
                }
            }
            if rng.random_bool(0.5) {
                sim = sim.with_noise(coloured(ny, NoiseLevel::Std(vec![0.1]), seed)).unwrap();
            }
            let len = 300;
            let exc = Excitation::both(random_input(len, ny, 3, seed + 1), random_input(len, nu, 1, seed + 2));
            match (sim.simulate(&exc), sim.simulate_reference(&exc)) {
                (Ok(a), Ok(b)) => {
                    let scale = max_abs(&b.y).max(max_abs(b.u())).max(1.0);
                    prop_assert!(max_diff(&a.y, &b.y) <= 1e-10 * scale, "y differs");
                    prop_assert!(max_diff(a.u(), b.u()) <= 1e-10 * scale, "u differs");
                    prop_assert_eq!(a.final_state.len(), b.final_state.len());
                    for (x, y) in a.final_state.iter().zip(&b.final_state) {
                        prop_assert!((x - y).abs() <= 1e-9 * scale.max(y.abs()), "final state {} vs {}", x, y);
                    }
                }
                (Err(Error::Diverged { .. }), Err(Error::Diverged { .. })) => {}
                (Err(Error::AlgebraicLoop { .. }), Err(Error::AlgebraicLoop { .. })) => {}
                (a, b) => prop_assert!(false, "paths disagree: {:?} vs {:?}", a.err(), b.err()),
            }
        }
    }
}

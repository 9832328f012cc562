//! A controller that runs every m base periods (its model at m·T): it
//! reads the measurement when it runs, updates its state once and holds its
//! output in between. Checked against a hand-written loop of the difference
//! equations, fused against reference, and the bad-input errors. Also the
//! state layout and sharing a simulator across threads.

use crate::common::*;
use lifted_sim::{Controller, Error, Excitation, Feedback, Plant, Simulator};
use nalgebra::DMatrix;

/// y(k+1) = 0.9 y(k) + 0.1 u(k); PI u_K(j) = u_K(j−1) + 0.8 e(j) − 0.6 e(j−1)
/// run at k ≡ phase (mod m), e = r₁ − y; u(k) = r₂(k) + held u_K.
fn by_hand(r1: &[f64], r2: &[f64], m: usize, phase: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut y, mut uk, mut e_prev) = (0.0, 0.0, 0.0);
    let (mut ys, mut us) = (Vec::new(), Vec::new());
    for k in 0..r1.len() {
        if k % m == phase {
            let e = r1[k] - y;
            uk += 0.8 * e - 0.6 * e_prev;
            e_prev = e;
        }
        let u = r2[k] + uk;
        ys.push(y);
        us.push(u);
        y = 0.9 * y + 0.1 * u;
    }
    (ys, us)
}

fn pi_at(period: f64) -> Controller {
    Controller::decentralized(1, 1, period, &[(0, 0, &[0.8, -0.6], &[1.0, -1.0])]).expect("PI")
}

#[test]
fn slow_pi_equals_the_difference_equations() -> TestResult {
    let g = tf(&[0.1], &[1.0, -0.9], Some(1.0));
    let n = 400;
    let r1 = random_input(n, 1, 7, 3);
    let r2 = random_input(n, 1, 1, 4) * 0.2;
    for (m, phase) in [(1, 0), (3, 0), (3, 2), (5, 1)] {
        let sim = Simulator::closed_loop(
            Plant::discrete(&g, &[], &[])?,
            pi_at(m as f64).with_phase(phase),
        )?;
        assert_eq!(sim.frame_period(), m);
        let out = sim.simulate(&Excitation::both(r1.clone(), r2.clone()))?;
        let (ys, us) = by_hand(r1.as_slice(), r2.as_slice(), m, phase);
        for k in 0..n {
            assert!((out.y[(k, 0)] - ys[k]).abs() < 1e-12, "m {m} k {k}");
            assert!((out.u()[(k, 0)] - us[k]).abs() < 1e-12, "m {m} k {k}");
        }
        // the fused path equals the block-by-block reference
        let reference = sim.simulate_reference(&Excitation::both(r1.clone(), r2.clone()))?;
        assert!(max_diff(&out.y, &reference.y) < 1e-12);
        assert!(max_diff(&out.final_state_matrix(), &reference.final_state_matrix()) < 1e-12);
    }
    Ok(())
}

/// Final state as a column (for `max_diff`).
trait FinalState {
    fn final_state_matrix(&self) -> DMatrix<f64>;
}

impl FinalState for lifted_sim::SimOutput {
    fn final_state_matrix(&self) -> DMatrix<f64> {
        DMatrix::from_column_slice(self.final_state.len(), 1, &self.final_state)
    }
}

#[test]
fn slow_controller_with_feedthrough_holds_and_hold_last() -> TestResult {
    // a 2x2 plant with direct feedthrough, a MIMO controller with D_K at
    // 2T, input holds (2, 3), slow outputs with hold-last feedback: the
    // algebraic loop is solved only when the controller runs
    let g = lifted_lti::StateSpace::new(
        DMatrix::from_row_slice(2, 2, &[0.8, 0.1, 0.0, 0.7]),
        DMatrix::from_row_slice(2, 2, &[0.5, 0.0, 0.1, 0.4]),
        DMatrix::from_row_slice(2, 2, &[1.0, 0.2, 0.0, 1.0]),
        DMatrix::from_row_slice(2, 2, &[0.1, 0.0, 0.0, 0.05]),
        Some(1.0),
    )?;
    let k = lifted_lti::StateSpace::new(
        DMatrix::identity(2, 2),
        DMatrix::identity(2, 2) * 0.2,
        DMatrix::identity(2, 2) * 0.3,
        DMatrix::from_row_slice(2, 2, &[0.6, 0.1, 0.0, 0.5]),
        Some(2.0),
    )?;
    let n = 600;
    let exc = Excitation::both(random_input(n, 2, 4, 8), random_input(n, 2, 1, 9) * 0.1);
    let sim = Simulator::closed_loop(
        Plant::discrete(&g, &[], &[])?,
        Controller::from_ss(&k)?.with_phase(1),
    )?
    .with_holds(&[2, 3])?
    .with_sampling(&[(3, 0), (1, 0)])?
    .with_feedback(Feedback::HoldLast)?;
    assert_eq!(sim.frame_period(), 6);
    let (a, b) = (sim.simulate(&exc)?, sim.simulate_reference(&exc)?);
    assert!(max_diff(&a.y, &b.y) < 1e-12 * max_abs(&b.y).max(1.0));
    assert!(max_diff(a.u(), b.u()) < 1e-12 * max_abs(b.u()).max(1.0));
    // the controller output changes only when it runs (odd k) or r₂ moves;
    // with r₂ = 0 the plant input moves only at odd k and hold starts
    let quiet = Excitation::reference(random_input(n, 2, 4, 8));
    let out = sim.simulate(&quiet)?;
    for k in 1..n {
        for i in 0..2 {
            let moved = out.u()[(k, i)] != out.u()[(k - 1, i)];
            if moved {
                // input 0 starts blocks at even k, input 1 at k ≡ 0 (mod 3)
                let starts = if i == 0 { k % 2 == 0 } else { k % 3 == 0 };
                assert!(starts, "input {i} moved at k = {k} outside a hold start");
            }
        }
    }
    assert!(sim.lti_model().is_err());
    Ok(())
}

#[test]
fn controller_period_and_phase_errors() -> TestResult {
    let g = tf(&[0.1], &[1.0, -0.9], Some(1.0));
    let plant = || Plant::discrete(&g, &[], &[]);
    // 1.5 T is not an integer multiple of T
    assert!(matches!(
        Simulator::closed_loop(plant()?, pi_at(1.5)),
        Err(Error::ControllerPeriod { .. })
    ));
    // faster than the plant's base period
    assert!(matches!(
        Simulator::closed_loop(plant()?, pi_at(0.5)),
        Err(Error::ControllerPeriod { .. })
    ));
    assert!(matches!(
        Simulator::closed_loop(plant()?, pi_at(3.0).with_phase(3)),
        Err(Error::ControllerPhase {
            phase: 3,
            period: 3
        })
    ));
    assert!(matches!(
        Simulator::closed_loop(plant()?, pi_at(1.0).with_phase(1)),
        Err(Error::ControllerPhase { .. })
    ));
    Ok(())
}

#[test]
fn state_layout_matches_the_final_state() -> TestResult {
    use lifted_sim::plants;
    let g = tf(&[0.1], &[1.0, -0.9], Some(1.0));
    let n = 50;
    let r = random_input(n, 1, 1, 2);
    // open loop: the plant part is x(N), so C x(N) is the next output
    // y(N) = 0.9 y(N−1) + 0.1 u(N−1) whatever the realisation
    let plant = Plant::discrete(&g, &[], &[])?;
    let c = plant.model().c()[(0, 0)];
    let open = Simulator::open_loop(plant);
    let out = open.simulate(&Excitation::input(r.clone()))?;
    let lay = open.state_layout();
    assert_eq!(lay.len(), out.final_state.len());
    assert_eq!(lay.plant, 0..1);
    assert!(lay.controller.is_empty() && lay.held_controller.is_empty());
    let y_next = 0.9 * out.y[(n - 1, 0)] + 0.1 * out.u()[(n - 1, 0)];
    let x_n = out.final_state[lay.plant.start];
    assert!((c * x_n - y_next).abs() < 1e-12 * y_next.abs().max(1.0));
    // the held input is the last plant input
    assert_eq!(out.final_state[lay.held_inputs.start], out.u()[(n - 1, 0)]);
    // slow PI and the inferential loop: the layout covers the state
    let slow = Simulator::closed_loop(Plant::discrete(&g, &[], &[])?, pi_at(2.0))?;
    let lay = slow.state_layout();
    assert_eq!((lay.controller.len(), lay.held_controller.len()), (1, 1));
    let exc = Excitation::reference(r);
    assert_eq!(slow.simulate(&exc)?.final_state.len(), lay.len());
    let inferential = plants::chapter9_dual_rate()?.simulator()?;
    let lay = inferential.state_layout();
    assert!(!lay.model.is_empty());
    assert_eq!(inferential.simulate(&exc)?.final_state.len(), lay.len());
    Ok(())
}

#[test]
fn simulators_can_be_shared_across_threads() {
    // Monte-Carlo runs over seeds can run on a thread pool (e.g. rayon):
    // the simulator is shared by reference, each job owns its output
    fn send_sync<T: Send + Sync>() {}
    send_sync::<Simulator>();
    send_sync::<lifted_sim::SimOutput>();
    send_sync::<lifted_sim::SimSignals>();
    let g = tf(&[0.1], &[1.0, -0.9], Some(1.0));
    let sim = Simulator::closed_loop(Plant::discrete(&g, &[], &[]).unwrap(), pi_at(1.0)).unwrap();
    let r = random_input(300, 1, 5, 1);
    let outs: Vec<_> = std::thread::scope(|s| {
        let jobs: Vec<_> = (0..2)
            .map(|_| s.spawn(|| sim.simulate(&Excitation::reference(r.clone())).unwrap()))
            .collect();
        jobs.into_iter().map(|j| j.join().unwrap()).collect()
    });
    assert_eq!(outs[0].y, outs[1].y);
}

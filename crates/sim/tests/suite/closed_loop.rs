//! Closed loops: whole-loop discretisation (Ren & Zhu), plant + discrete
//! controller, algebraic loops, partly open loops, inferential feedback.

use crate::common::*;
use lifted_lti::{C2dOptions, FeedbackSign, StateSpace};
use lifted_sim::plants::{self, RenZhuController, RenZhuPlant};
use lifted_sim::{
    Controller, Delays, Error, Excitation, Feedback, Plant, Simulator, WholeLoop, closed_loop,
};
use nalgebra::DMatrix;

#[test]
fn ren_zhu_p_loop_matches_table_2() -> TestResult {
    // Table 2 (spec A2.2): G1 = 1/(0.3s+1), K = 0.2:
    // H1 = 0.2/(0.3s+1.2), H2 = 1/(0.3s+1.2), discretised by ZOH at T = 5 ms (A2.3).
    let fx = plants::ren_zhu(RenZhuPlant::G1, RenZhuController::P)?;
    let sim = fx.simulator()?;
    let ts = fx.ts;
    let n = 600;
    let h1 = tf(&[0.2], &[0.3, 1.2], None).c2d(ts, &C2dOptions::default())?;
    let h2 = tf(&[1.0], &[0.3, 1.2], None).c2d(ts, &C2dOptions::default())?;
    let step = DMatrix::from_element(n, 1, 1.0);
    let r1 = sim.simulate(&Excitation::reference(step.clone()))?;
    let r2 = sim.simulate(&Excitation::input(step.clone()))?;
    let e1 = max_diff(&r1.y, &h1.step(n, None)?[0]);
    let e2 = max_diff(&r2.y, &h2.step(n, None)?[0]);
    assert!(
        e1 < 1e-12 && e2 < 1e-12,
        "r1 step error {e1}, r2 step error {e2}"
    );
    // final values: H1(0) = 1/6, H2(0) = 5/6 (approached after 600 × 5 ms = 3 s = 12 τ)
    assert!((r1.y[(n - 1, 0)] - 0.2 / 1.2).abs() < 1e-4);
    assert!((r2.y[(n - 1, 0)] - 1.0 / 1.2).abs() < 1e-4);
    // u = r2 + K(r1 − y)
    for k in 0..n {
        assert!((r1.u()[(k, 0)] - 0.2 * (1.0 - r1.y[(k, 0)])).abs() < 1e-12);
    }
    Ok(())
}

#[test]
fn plant_plus_discrete_controller_equals_discrete_closed_loop() -> TestResult {
    // G1 ZOH at 5 ms with the discrete gain 0.2: the discrete loop
    // y = GdK/(1 + GdK) r1 (lifted_lti::feedback), to rounding; it
    // approximates the whole-loop discretisation to O(T).
    let ts = 0.005;
    let g = tf(&[1.0], &[0.3, 1.0], None);
    let gd = g.c2d(ts, &C2dOptions::default())?;
    let k = StateSpace::gain(DMatrix::from_element(1, 1, 0.2), Some(ts))?;
    let sim = Simulator::closed_loop(
        Plant::continuous(&g, ts, &Delays::default())?,
        Controller::from_ss(&k)?,
    )?;
    let n = 600;
    let out = sim.simulate(&Excitation::reference(DMatrix::from_element(n, 1, 1.0)))?;
    let h1d = lifted_lti::feedback(
        &k.series(&gd)?,
        &StateSpace::gain(DMatrix::from_element(1, 1, 1.0), Some(ts))?,
        FeedbackSign::Negative,
    )?;
    let reference = h1d.step(n, None)?[0].clone();
    assert!(max_diff(&out.y, &reference) < 1e-13);
    let whole = tf(&[0.2], &[0.3, 1.2], None)
        .c2d(ts, &C2dOptions::default())?
        .step(n, None)?[0]
        .clone();
    let gap = max_diff(&out.y, &whole);
    // sampled feedback vs continuous feedback: a one-sample lag in the loop, O(T/τ)·H1(0)
    assert!(gap < 5e-3, "gap {gap}");
    // the assembled LTI model of the loop agrees as well
    let lti = sim.lti_model()?;
    let mut rr = DMatrix::zeros(n, 2);
    rr.column_mut(0).fill(1.0);
    let y = lti.lsim(&rr, None, None)?.y;
    assert!(max_diff(&y.columns(0, 1).into_owned(), &out.y) < 1e-13);
    Ok(())
}

#[test]
fn algebraic_loop_is_solved_or_rejected() -> TestResult {
    let ts = 1.0;
    // biproper plant (z − 0.5)/(z − 0.9) ⇒ D_G = 1, controller 0.4 + integrator
    let g = tf(&[1.0, -0.5], &[1.0, -0.9], Some(ts));
    let k = tf(&[0.6, -0.4], &[1.0, -1.0], Some(ts));
    let sim = Simulator::closed_loop(Plant::discrete(&g, &[], &[])?, Controller::from_ss(&k)?)?;
    let n = 200;
    let r = random_input(n, 1, 1, 9);
    let out = sim.simulate(&Excitation::reference(r.clone()))?;
    let cl = closed_loop(&g, &k)?;
    let mut rr = DMatrix::zeros(n, 2);
    rr.column_mut(0).copy_from(&r.column(0));
    let y = cl.lsim(&rr, None, None)?.y;
    assert!(max_diff(&y.columns(0, 1).into_owned(), &out.y) < 1e-12);
    assert!(max_diff(&y.columns(1, 1).into_owned(), out.u()) < 1e-12);
    // I + D_K D_G = 1 + (−1)(1) = 0: ill-posed
    let kbad = StateSpace::gain(DMatrix::from_element(1, 1, -1.0), Some(ts))?;
    let bad = Simulator::closed_loop(Plant::discrete(&g, &[], &[])?, Controller::from_ss(&kbad)?)?;
    assert!(matches!(
        bad.simulate(&Excitation::reference(r)),
        Err(Error::AlgebraicLoop { .. })
    ));
    assert!(matches!(
        closed_loop(&g, &kbad),
        Err(Error::AlgebraicLoop { .. })
    ));
    Ok(())
}

#[test]
fn some_loops_open_some_closed() -> TestResult {
    // thesis 7.8.2: PI on u2 → y2, y1 open loop (u1 = r2_1 exactly)
    let fx = plants::stirred_tank_7_8_2()?;
    let sim = fx.simulator()?;
    let n = 500;
    let r2 = random_input(n, 2, 1, 4);
    let r1 = random_input(n, 2, 1, 5);
    let out = sim.simulate(&Excitation::both(r1.clone(), r2.clone()))?;
    assert_eq!(out.u().column(0), r2.column(0));
    // u2 = r2_2 + K(r1_2 − y2) with K = (1.6z − 1.5)/(z − 1): Δ(u2 − r2_2)(k) = 1.6e(k) − 1.5e(k−1)
    let e: Vec<f64> = (0..n).map(|k| r1[(k, 1)] - out.y[(k, 1)]).collect();
    let mut w_prev = 0.0;
    for k in 0..n {
        let w = out.u()[(k, 1)] - r2[(k, 1)];
        let expect = w_prev + 1.6 * e[k] - if k > 0 { 1.5 * e[k - 1] } else { 0.0 };
        assert!((w - expect).abs() < 1e-12, "k {k}");
        w_prev = w;
    }
    // the slow y1 channel is sampled every 5
    assert_eq!(out.data.output_samples(0)?.0.len(), n / 5);
    Ok(())
}

#[test]
fn chapter9_inferential_loop_matches_spec_a3_11() -> TestResult {
    // spec A3.11 (9.6 example): dual-rate n = 4, the unit step peaks at 1.193 at k = 8.
    let fx = plants::chapter9_dual_rate()?;
    let sim = fx.simulator()?;
    let out = sim.simulate(&Excitation::reference(DMatrix::from_element(200, 1, 1.0)))?;
    let (kmax, peak) =
        out.y.column(0).iter().enumerate().fold(
            (0, f64::MIN),
            |(i, m), (k, &v)| if v > m { (k, v) } else { (i, m) },
        );
    assert_eq!(kmax, 8);
    assert!((peak - 1.193).abs() < 5e-4, "peak {peak}");
    // the feedback is exactly y at k ≡ 0 (mod 4): the samples in the data set
    assert_eq!(out.data.output_samples(0)?.0[..3], [0, 4, 8]);
    Ok(())
}

#[test]
fn inferential_with_perfect_model_equals_single_rate_loop() -> TestResult {
    // spec A3.11: with P̂ = P the dual-rate and the single-rate step responses coincide (1e-12)
    let fx = plants::chapter9_dual_rate()?;
    let plant = Plant::discrete(&fx.plant, &[], &[])?;
    let k = Controller::from_ss(fx.controller.as_ref().ok_or("controller")?)?;
    let dual = Simulator::closed_loop(plant.clone(), k.clone())?
        .with_sampling(&[(4, 0)])?
        .with_feedback(Feedback::Inferential(fx.plant.clone()))?;
    let single = Simulator::closed_loop(plant, k)?;
    let exc = Excitation::reference(DMatrix::from_element(150, 1, 1.0));
    let (a, b) = (dual.simulate(&exc)?, single.simulate(&exc)?);
    assert!(max_diff(&a.y, &b.y) < 1e-12);
    Ok(())
}

#[test]
fn unstable_single_rate_loop_is_reported() -> TestResult {
    // spec A3.11: the fast single-rate loop of K with the true P is unstable (|z| = 1.0266)
    let fx = plants::chapter9_dual_rate()?;
    let sim = Simulator::closed_loop(
        Plant::discrete(&fx.plant, &[], &[])?,
        Controller::from_ss(fx.controller.as_ref().ok_or("controller")?)?,
    )?;
    let res = sim.simulate(&Excitation::reference(DMatrix::from_element(5000, 1, 1.0)));
    match res {
        Err(Error::Diverged { sample, value, .. }) => assert!(sample > 100 && value.abs() > 1e12),
        other => panic!("expected Diverged, got {other:?}"),
    }
    Ok(())
}

#[test]
fn whole_loop_from_model_checks_shapes() -> TestResult {
    let g = tf(&[1.0], &[1.0, 1.0, 1.0], None);
    let k = tf(&[0.5, 0.2], &[1.0, 0.0], None);
    let cl = closed_loop(&g, &k)?;
    let w = WholeLoop::from_model(&cl, 1, 1, 0.005)?;
    assert_eq!(w.model().n_inputs(), 2);
    assert!(matches!(
        WholeLoop::from_model(&cl, 2, 1, 0.005),
        Err(Error::DimensionMismatch { .. })
    ));
    // Table 3 PI: H2 = s/(s³+s²+1.5s+0.2): zero DC gain from r2
    let sim = Simulator::whole_loop(w);
    let out = sim.simulate(&Excitation::input(DMatrix::from_element(20000, 1, 1.0)))?;
    assert!(out.y[(19999, 0)].abs() < 0.05, "{}", out.y[(19999, 0)]);
    Ok(())
}

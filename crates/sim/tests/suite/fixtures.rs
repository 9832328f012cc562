//! The reference plants reproduce the published discretisations.

use crate::common::*;
use lifted_lti::C2dOptions;
use lifted_sim::Excitation;
use lifted_sim::plants::{self, EngineSpeed, RenZhuController, RenZhuPlant};
use nalgebra::DMatrix;

fn sorted_real_poles(p: &lifted_lti::StateSpace) -> Vec<f64> {
    let mut v: Vec<f64> = p.poles().unwrap().iter().map(|z| z.re).collect();
    v.sort_by(|a, b| b.total_cmp(a));
    v
}

#[test]
fn diesel_engine_zoh_matches_spec_a1_5() -> TestResult {
    // spec A1.5 [V]: ZOH at T = 0.0113: 1150 rpm poles 0.996075, 0.835735, DC 114;
    // 1500 rpm poles 0.995681, 0.737466
    for (speed, poles, dc) in [
        (EngineSpeed::Rpm1150, [0.996075, 0.835735], 114.0),
        (EngineSpeed::Rpm1500, [0.995681, 0.737466], 85.6),
    ] {
        let fx = plants::diesel_engine(speed)?;
        let d = fx.discrete_plant()?;
        let p = sorted_real_poles(d.model());
        assert!(
            (p[0] - poles[0]).abs() < 1e-6 && (p[1] - poles[1]).abs() < 1e-6,
            "{p:?}"
        );
        assert!((d.model().dc_gain()?[(0, 0)] - dc).abs() < 1e-9 * dc);
    }
    Ok(())
}

#[test]
fn chapter7_fixture_matches_printed_discrete_models() -> TestResult {
    // spec A3.9: P(z) = 0.09063 z⁻²/(1 − 0.81873 z⁻¹), N = 0.28347 z⁻¹/(1 − 0.71653 z⁻¹)
    let fx = plants::chapter7_siso()?;
    let n = 30;
    let p = fx.discrete_plant()?.model().step(n, None)?[0].clone();
    let printed = tf(&[0.09063], &[1.0, -0.81873, 0.0], Some(1.0)).step(n, None)?[0].clone();
    assert!(
        max_diff(&p, &printed) < 5e-5 * 5.0,
        "{}",
        max_diff(&p, &printed)
    ); // printed to 5 digits
    let nz = fx
        .noise
        .as_ref()
        .ok_or("noise")?
        .c2d(1.0, &C2dOptions::default())?;
    let np = sorted_real_poles(&nz);
    assert!((np[0] - 0.71653).abs() < 5e-6);
    assert!((nz.dc_gain()?[(0, 0)] - 1.0).abs() < 1e-12);
    Ok(())
}

#[test]
fn chapter9_fixture_nominal_closed_loop_poles() -> TestResult {
    // spec A3.11: nominal loop K with P̂: poles 0.838 and 0.537
    let fx = plants::chapter9_dual_rate()?;
    let cl = lifted_sim::closed_loop(
        fx.parallel_model.as_ref().ok_or("P̂")?,
        fx.controller.as_ref().ok_or("K")?,
    )?;
    let p = sorted_real_poles(&cl);
    assert!(
        (p[0] - 0.838).abs() < 1e-3 && (p[1] - 0.537).abs() < 1e-3,
        "{p:?}"
    );
    // the fast loop with the true P has a pair at |z| = 1.0266
    let fast = lifted_sim::closed_loop(&fx.plant, fx.controller.as_ref().ok_or("K")?)?;
    let rmax = fast.poles()?.iter().map(|z| z.norm()).fold(0.0, f64::max);
    assert!((rmax - 1.0266).abs() < 1e-3, "{rmax}");
    Ok(())
}

#[test]
fn stirred_tank_fixtures_differ_as_in_erratum_l14() -> TestResult {
    let a = plants::stirred_tank_2_6_2()?;
    let b = plants::stirred_tank_5_3_1()?;
    let c = plants::stirred_tank_7_8_2()?;
    assert_ne!(a.plant, b.plant);
    assert_ne!(a.noise, b.noise);
    assert_eq!(a.plant, c.plant);
    assert!(c.controller.is_some() && a.controller.is_none());
    // G11 DC gain 0.1416/(1 − 0.9868) = 10.727
    let dc = a.plant.dc_gain()?;
    assert!((dc[(0, 0)] - 0.1416 / 0.0132).abs() < 1e-9);
    assert!(dc[(0, 1)].abs() < 1e-12);
    assert!((b.plant.dc_gain()?[(0, 1)] + 1.0).abs() < 1e-9);
    Ok(())
}

#[test]
fn every_fixture_simulates() -> TestResult {
    let all = vec![
        plants::stirred_tank_2_6_2()?,
        plants::stirred_tank_5_3_1()?,
        plants::stirred_tank_7_8_2()?,
        plants::diesel_engine(EngineSpeed::Rpm1150)?,
        plants::diesel_engine(EngineSpeed::Rpm1500)?,
        plants::ren_zhu(RenZhuPlant::G1, RenZhuController::Open)?,
        plants::ren_zhu(RenZhuPlant::G1, RenZhuController::FirstOrder)?,
        plants::ren_zhu(RenZhuPlant::G1, RenZhuController::Pi)?,
        plants::ren_zhu(RenZhuPlant::G2, RenZhuController::P)?,
        plants::loss_of_observability()?,
        plants::first_order_with_delay(8.5)?,
        plants::chapter4_example()?,
        plants::chapter7_siso()?,
        plants::chapter9_dual_rate()?,
    ];
    for fx in all {
        let sim = fx.simulator()?;
        let n = 120;
        let exc = if fx.controller.is_some() {
            Excitation::both(
                DMatrix::from_element(n, sim.n_outputs(), 1.0),
                random_input(n, sim.n_inputs(), 1, 1),
            )
        } else {
            Excitation::input(random_input(n, sim.n_inputs(), 1, 1))
        };
        let out = sim.simulate(&exc)?;
        assert_eq!(out.data.len(), n, "{}", fx.name);
        assert!(!fx.source.is_empty());
    }
    Ok(())
}

#[test]
fn ren_zhu_open_loop_is_the_plant() -> TestResult {
    let fx = plants::ren_zhu(RenZhuPlant::G2, RenZhuController::Open)?;
    let out = fx
        .simulator()?
        .simulate(&Excitation::input(DMatrix::from_element(400, 1, 1.0)))?;
    let g = tf(&[1.0], &[1.0, 1.0, 1.0], None)
        .c2d(0.005, &C2dOptions::default())?
        .step(400, None)?[0]
        .clone();
    assert!(max_diff(&out.y, &g) < 1e-12);
    Ok(())
}

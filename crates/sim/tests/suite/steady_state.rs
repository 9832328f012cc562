//! Periodic steady state for PRBS experiments.

use crate::common::*;
use lifted_prbs::{InversePrbs, InversePrbsOptions};
use lifted_sim::plants::{self, EngineSpeed, RenZhuController, RenZhuPlant};
use lifted_sim::{
    Error, Excitation, NoiseSpec, PeriodicityCheck, SteadyStateMethod, SteadyStateOptions,
};
use nalgebra::DMatrix;

fn prbs(order: u32, amplitude: f64, hold: usize) -> DMatrix<f64> {
    let p = InversePrbs::new(&InversePrbsOptions {
        order,
        amplitude,
        hold,
        taps: None,
    })
    .unwrap();
    let w = p.one_period();
    DMatrix::from_column_slice(w.len(), 1, &w)
}

#[test]
fn engine_prbs_iterated_and_exact_agree() -> TestResult {
    // spec A1.5: diesel engine 1150 rpm, T = 0.0113, inverse PRBS a = 2, n = 8, n_r = 10 (P = 5100)
    let fx = plants::diesel_engine(EngineSpeed::Rpm1150)?;
    let sim = fx.simulator()?;
    let exc = Excitation::input(prbs(8, 2.0, 10));
    let tol = 1e-9;
    let it = sim.periodic_steady_state(&exc, &SteadyStateOptions::iterate(tol))?;
    let periods = it.periods.ok_or("periods")?;
    assert!(it.residual <= tol, "residual {}", it.residual);
    assert!(periods >= 2, "needs a transient: {periods}");
    assert_eq!(it.output.y.nrows(), 5100);
    let ex = sim.periodic_steady_state(&exc, &SteadyStateOptions::default())?;
    assert!(ex.periods.is_none());
    assert!(ex.residual < 1e-11, "exact residual {}", ex.residual);
    let diff = max_diff(&ex.output.y, &it.output.y) / max_abs(&ex.output.y);
    assert!(diff < 10.0 * tol, "exact vs iterated {diff}");
    // antisymmetry y(k) = −y(k + n_r m) (erratum Z-12) on the returned record
    let y = &ex.output.y;
    for k in 0..2550 {
        assert!((y[(k, 0)] + y[(k + 2550, 0)]).abs() < 1e-9 * max_abs(y));
    }
    Ok(())
}

#[test]
fn closed_loop_steady_state_with_pi_controller() -> TestResult {
    // Ren & Zhu G2 with the PI controller (integrator in the loop), PRBS n = 7 at r1
    let fx = plants::ren_zhu(RenZhuPlant::G2, RenZhuController::Pi)?;
    let sim = fx.simulator()?;
    let exc = Excitation::reference(prbs(7, 1.0, 1));
    let ex = sim.periodic_steady_state(&exc, &SteadyStateOptions::default())?;
    let it = sim.periodic_steady_state(
        &exc,
        &SteadyStateOptions {
            method: SteadyStateMethod::Iterate {
                tolerance: 1e-10,
                max_periods: 5000,
                check: PeriodicityCheck::Periodic,
            },
            check: PeriodicityCheck::Periodic,
        },
    )?;
    assert!(it.residual <= 1e-10 && ex.residual < 1e-10);
    assert!(max_diff(&ex.output.y, &it.output.y) < 1e-8 * max_abs(&ex.output.y));
    assert!(it.periods.unwrap_or(0) > 1);
    Ok(())
}

#[test]
fn inferential_loop_periodic_steady_state_by_phase() -> TestResult {
    // spec A3.11: dual-rate n = 4, unit step; steady state y = (1.0537, 1.0668, 1.0738, 1.0775) by phase
    let fx = plants::chapter9_dual_rate()?;
    let sim = fx.simulator()?;
    let exc = Excitation::reference(DMatrix::from_element(4, 1, 1.0));
    let opts = SteadyStateOptions {
        method: SteadyStateMethod::Exact,
        check: PeriodicityCheck::Periodic,
    };
    let ss = sim.periodic_steady_state(&exc, &opts)?;
    let expect = [1.0537, 1.0668, 1.0738, 1.0775];
    for (k, e) in expect.iter().enumerate() {
        assert!(
            (ss.output.y[(k, 0)] - e).abs() < 1e-4,
            "phase {k}: {}",
            ss.output.y[(k, 0)]
        );
    }
    Ok(())
}

#[test]
fn steady_state_with_noise_keeps_the_deterministic_part() -> TestResult {
    let fx = plants::diesel_engine(EngineSpeed::Rpm1500)?;
    let exc = Excitation::input(prbs(6, 2.0, 10));
    let clean = fx
        .simulator()?
        .periodic_steady_state(&exc, &SteadyStateOptions::default())?;
    let noisy = fx
        .simulator()?
        .with_noise(NoiseSpec::white_snr(100.0, 1))?
        .periodic_steady_state(&exc, &SteadyStateOptions::default())?;
    // open loop: the noise-free part is unchanged, the noise is added on top
    assert!(max_diff(&clean.output.y, &noisy.output.y_clean) < 1e-9 * max_abs(&clean.output.y));
    let ratio = variance(noisy.output.y_clean.column(0).as_slice())
        / variance(noisy.output.noise.column(0).as_slice());
    assert!((ratio / 100.0 - 1.0).abs() < 1e-9);
    Ok(())
}

#[test]
fn steady_state_errors() -> TestResult {
    let fx = plants::chapter9_dual_rate()?;
    let sim = fx.simulator()?;
    // period 6 is not a multiple of the sampling pattern's 4
    let exc = Excitation::reference(DMatrix::from_element(6, 1, 1.0));
    assert!(matches!(
        sim.periodic_steady_state(&exc, &SteadyStateOptions::default()),
        Err(Error::PeriodMismatch {
            period: 6,
            frame: 4
        })
    ));
    // odd period with the antisymmetric check
    let fx = plants::diesel_engine(EngineSpeed::Rpm1150)?;
    let exc = Excitation::input(DMatrix::from_element(7, 1, 1.0));
    assert!(matches!(
        fx.simulator()?
            .periodic_steady_state(&exc, &SteadyStateOptions::default()),
        Err(Error::OddPeriod { period: 7 })
    ));
    // too few periods to converge
    let exc = Excitation::input(prbs(4, 1.0, 1));
    let opts = SteadyStateOptions {
        method: SteadyStateMethod::Iterate {
            tolerance: 1e-12,
            max_periods: 2,
            check: PeriodicityCheck::Antisymmetric,
        },
        ..Default::default()
    };
    assert!(matches!(
        fx.simulator()?.periodic_steady_state(&exc, &opts),
        Err(Error::NotPeriodic { periods: 2, .. })
    ));
    // an integrator in open loop has no periodic steady state
    let g = tf(&[1.0], &[1.0, -1.0], Some(1.0));
    let sim = lifted_sim::Simulator::open_loop(lifted_sim::Plant::discrete(&g, &[], &[])?);
    let exc = Excitation::input(prbs(3, 1.0, 1));
    assert!(matches!(
        sim.periodic_steady_state(&exc, &SteadyStateOptions::default()),
        Err(Error::UnstableLoop { .. })
    ));
    Ok(())
}

use super::common::*;
use lifted_mpc::*;
use nalgebra::{DVector, dvector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[test]
fn mimo_dmc_and_state_space_predictions_agree() {
    let plant = tank();
    let opts = MpcOptions {
        prediction_horizon: 15,
        control_horizon: 4,
        ..MpcOptions::default()
    };
    let dmc = Dmc::new(&plant, 300, &opts).unwrap();
    let ss = StateSpaceMpc::new(&plant, &opts).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let moves: Vec<DVector<f64>> = (0..60)
        .map(|_| DVector::from_fn(2, |_, _| rng.random::<f64>() - 0.5))
        .collect();
    let (ai, bi, _) = integrated_model(&plant).unwrap();
    let mut x = DVector::zeros(ai.nrows());
    for du in &moves {
        x = &ai * x + &bi * du;
    }
    let past: Vec<DVector<f64>> = moves.iter().rev().cloned().collect();
    let future = DVector::from_fn(8, |_, _| rng.random::<f64>() - 0.5);
    let y = dvector![0.3, -0.2];
    let a = dmc.predict(&y, &past, &future).unwrap();
    let b = ss.predict(&x, &y, &future).unwrap();
    assert!((a - b).amax() < 1e-10);
    assert_eq!(dmc.law().dynamic_matrix(), ss.law().dynamic_matrix());
}

#[test]
fn dmc_from_step_test_equals_model_based() {
    let plant = tank();
    let opts = MpcOptions::default();
    let steps = step_coefficients(&plant, 200).unwrap();
    let mut a = Dmc::from_steps(steps, &opts).unwrap();
    let mut b = Dmc::new(&plant, 200, &opts).unwrap();
    let r = nalgebra::DMatrix::from_fn(50, 2, |_, c| c as f64 + 0.5);
    let ya = simulate(&plant, &mut a, &LoopSetup::new(r.clone(), vec![10, 1]))
        .unwrap()
        .y;
    let yb = simulate(&plant, &mut b, &LoopSetup::new(r, vec![10, 1]))
        .unwrap()
        .y;
    assert_eq!(ya, yb);
    assert!(matches!(
        Dmc::from_steps(vec![], &opts),
        Err(Error::InvalidArgument { .. })
    ));
    let bad = vec![nalgebra::DMatrix::from_element(1, 1, 1.0); 20];
    assert!(matches!(
        Dmc::from_steps(bad, &opts),
        Err(Error::InvalidArgument { .. })
    ));
}

#[test]
fn slow_rate_wrapper_holds_input() {
    let plant = tank();
    let slow = hold_model(&plant, 5).unwrap();
    let mut c = SlowRate::new(
        StateSpaceMpc::new(&slow, &MpcOptions::default()).unwrap(),
        5,
    )
    .unwrap();
    let r = nalgebra::DMatrix::from_fn(100, 2, |_, ch| if ch == 0 { 1.0 } else { 0.0 });
    let run = simulate(&plant, &mut c, &LoopSetup::new(r, vec![5, 5])).unwrap();
    for t in 0..100 {
        if t % 5 != 0 {
            assert_eq!(run.u.row(t), run.u.row(t - 1));
        }
    }
    assert!((run.y[(95, 0)] - 1.0).abs() < 1e-3);
}

#[test]
fn performance_figures() {
    let r = nalgebra::DMatrix::from_element(6, 1, 1.0);
    let y = nalgebra::DMatrix::from_column_slice(6, 1, &[0.0, 0.5, 1.2, 1.01, 1.0, 1.0]);
    let u = nalgebra::DMatrix::from_element(6, 1, 2.0);
    let p = performance(&y, &u, &r, 0.02).unwrap();
    assert!((p.iae[0] - (1.0 + 0.5 + 0.2 + 0.01)).abs() < 1e-12);
    assert!((p.overshoot[0] - 0.2).abs() < 1e-12);
    assert_eq!(p.settling_time[0], Some(3));
    assert!((p.input_energy - 24.0).abs() < 1e-12);
}

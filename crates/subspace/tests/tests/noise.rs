use super::common::*;
use lifted_lti::StateSpace;
use lifted_subspace::*;
use nalgebra::DMatrix;

/// Innovation model x+ = Ax + Bu + Ke, y = Cx + e: the identified
/// Kalman predictor must approach the true one.
#[test]
fn kalman_gain_of_an_innovation_model() {
    let a = DMatrix::from_row_slice(2, 2, &[0.8, 0.2, 0.0, 0.5]);
    let b = DMatrix::from_row_slice(2, 1, &[1.0, 0.5]);
    let k = DMatrix::from_row_slice(2, 1, &[0.4, 0.3]);
    let c = DMatrix::from_row_slice(1, 2, &[1.0, 0.0]);
    let n = 20000;
    let u = rbs(1, n, 1);
    let e = white(2, n, 1, 0.3);
    let mut bk = DMatrix::zeros(2, 2);
    bk.columns_mut(0, 1).copy_from(&b);
    bk.columns_mut(1, 1).copy_from(&k);
    let mut dk = DMatrix::zeros(1, 2);
    dk[(0, 1)] = 1.0;
    let g = StateSpace::new(a.clone(), bk, c.clone(), dk, Some(1.0)).unwrap();
    let mut ue = DMatrix::zeros(n, 2);
    ue.columns_mut(0, 1).copy_from(&u);
    ue.columns_mut(1, 1).copy_from(&e);
    let y = sim(&g, &ue, None);
    let opts = SubspaceOptions {
        order: OrderSelection::Fixed(2),
        feedthrough: Feedthrough::Zero,
        ..Default::default()
    };
    let fit = identify(&[Experiment { u: &u, y: &y }], &opts).unwrap();
    let kg = fit.kalman_gain.clone().expect("Kalman gain");
    // Compare the noise transfer C(zI − A)⁻¹K (similarity invariant)
    // through its first Markov parameters.
    let true_noise = StateSpace::new(a, k, c, DMatrix::zeros(1, 1), Some(1.0)).unwrap();
    let est_noise = StateSpace::new(
        fit.model.a().clone(),
        kg,
        fit.model.c().clone(),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap();
    let mt = true_noise.markov_parameters(4).unwrap();
    let me = est_noise.markov_parameters(4).unwrap();
    for i in 1..=4 {
        assert!(
            (mt[i][(0, 0)] - me[i][(0, 0)]).abs() < 0.05,
            "noise Markov {i}: {} vs {}",
            mt[i],
            me[i]
        );
    }
    let r = fit.noise.unwrap().r[(0, 0)];
    assert!((r - 0.09).abs() < 0.01, "innovation variance {r}");
    assert!(
        freq_error(
            &fit.model,
            &StateSpace::new(
                g.a().clone(),
                b,
                g.c().clone(),
                DMatrix::zeros(1, 1),
                Some(1.0)
            )
            .unwrap()
        ) < 0.05
    );
}

#[test]
fn stability_enforcement_gives_a_stable_model() {
    // A marginal integrator-like plant with heavy noise and short data.
    let g = random_system(11, &[0.999, 0.2], &[], 1, 1, false);
    let u = rbs(3, 200, 1);
    let y = sim(&g, &u, None) + white(4, 200, 1, 5.0);
    let opts = SubspaceOptions {
        order: OrderSelection::Fixed(2),
        past: 5,
        future: 5,
        enforce_stability: true,
        ..Default::default()
    };
    let fit = identify(&[Experiment { u: &u, y: &y }], &opts).unwrap();
    assert!(fit.model.is_stable(0.0).unwrap());
}

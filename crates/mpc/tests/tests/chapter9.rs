use super::common::*;
use lifted_mpc::*;
use nalgebra::{DMatrix, dvector};
use num_complex::Complex64;
use proptest::prelude::*;

#[test]
fn example_96_betas() {
    let (phat, k, _, w1) = example96();
    let o = RobustnessOptions::default();
    let sr = beta_sr(&phat, &k, &w1, Uncertainty::Additive).unwrap();
    assert!((sr.value - 1.2582).abs() < 1e-3);
    let b1 = beta_dr(&phat, &k, &w1, Uncertainty::Additive, 1, &o).unwrap();
    assert!(
        (b1.value - sr.value).abs() < 1e-8,
        "n = 1 is the single-rate loop"
    );
    let b4 = beta_dr(&phat, &k, &w1, Uncertainty::Additive, 4, &o).unwrap();
    assert!((b4.value - 0.9071).abs() < 1e-3);
}

#[test]
fn example_96_stability() {
    let (phat, k, p, _) = example96();
    assert!(
        DualRateLoop::new(&p, &phat, &k, 1)
            .unwrap()
            .spectral_radius()
            .unwrap()
            > 1.02
    );
    let l = DualRateLoop::new(&p, &phat, &k, 4).unwrap();
    assert!(l.spectral_radius().unwrap() < 0.75);
    let y = l
        .simulate(&DMatrix::from_element(200, 1, 1.0), None)
        .unwrap()
        .y;
    assert!(y.amax() < 1.3);
    // the lifted closed loop has the monodromy matrix as its A
    assert!((l.lifted().unwrap().a() - l.monodromy()).amax() < 1e-14);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    /// Lifted response = V diag(G(e^{j(θ+2πl)/n})) Vᴴ with V_{il} = e^{jω_l i}/√n.
    #[test]
    fn lifted_response_is_alias_form(pole in -0.9f64..0.9, zero in -2.0f64..2.0, n in 1usize..6, theta in 0.01f64..3.1) {
        let g = tf(&[1.0, -zero], &[1.0, -pole, 0.0]);
        let lifted = lifted_response(&g, n, theta).unwrap();
        let w: Vec<f64> = (0..n).map(|l| (theta + 2.0 * std::f64::consts::PI * l as f64) / n as f64).collect();
        let gv: Vec<Complex64> = w.iter().map(|&wl| g.eval_complex(Complex64::from_polar(1.0, wl)).unwrap()[(0, 0)]).collect();
        for i in 0..n {
            for j in 0..n {
                let mut acc = Complex64::new(0.0, 0.0);
                for l in 0..n {
                    acc += gv[l] * Complex64::from_polar(1.0, w[l] * (i as f64 - j as f64));
                }
                acc /= n as f64;
                prop_assert!((acc - lifted[(i, j)]).norm() < 1e-10);
            }
        }
    }

    /// Without mismatch and disturbance the dual-rate loop is the single-rate loop (§9.4).
    #[test]
    fn no_mismatch_dual_rate_equals_single_rate(pole in 0.0f64..0.95, gain in 0.05f64..0.5, kp in 0.1f64..2.0, n in 2usize..7) {
        let p = tf(&[gain], &[1.0, -pole]);
        let k = tf(&[kp + 0.1, -kp], &[1.0, -1.0]);
        let r = DMatrix::from_element(60, 1, 1.0);
        let a = DualRateLoop::new(&p, &p, &k, n).unwrap().simulate(&r, None).unwrap().y;
        let b = DualRateLoop::new(&p, &p, &k, 1).unwrap().simulate(&r, None).unwrap().y;
        prop_assert!((a - b).amax() < 1e-9);
    }

    /// Cor. 1: β_dr ≤ β_sr for every admissible triple.
    #[test]
    fn beta_dr_below_beta_sr(pole in -0.8f64..0.9, wpole in -0.8f64..0.8, n in 2usize..6) {
        let phat = tf(&[0.2], &[1.0, -pole]);
        let k = tf(&[1.1, -1.0], &[1.0, -1.0]);
        let w = tf(&[0.3], &[1.0, -wpole]);
        if let Ok(sr) = beta_sr(&phat, &k, &w, Uncertainty::Multiplicative) {
            let dr = beta_dr(&phat, &k, &w, Uncertainty::Multiplicative, n, &RobustnessOptions { grid: 300, ..Default::default() }).unwrap();
            prop_assert!(dr.value <= sr.value + 1e-9);
        }
    }
}

#[test]
fn intersample_estimate_example() {
    // with n = 1 every sample is measured: inferential = fast
    let p = tf(&[0.15], &[1.0, -0.9]);
    let mut a = StateSpaceMpc::new(&p, &MpcOptions::default()).unwrap();
    let u = a.update(&[Some(0.0)], &dvector![1.0]).unwrap();
    assert!(u[0] > 0.0);
}

//! Integration tests of `lifted-mpc`.

mod common {
    use lifted_lti::{StateSpace, TransferFunction};

    /// Discrete SISO model from z-domain coefficients (descending powers), T = 1.
    pub fn tf(num: &[f64], den: &[f64]) -> StateSpace {
        TransferFunction::from_coeffs(num, den, Some(1.0))
            .and_then(|t| t.to_ss())
            .unwrap()
    }

    /// The §9.6 example: (P̂, K, P, W₁).
    pub fn example96() -> (StateSpace, StateSpace, StateSpace, StateSpace) {
        let phat = tf(&[0.15], &[1.0, -0.9]);
        // K = 3 + 0.5/(1 − z⁻¹) = (3.5 z − 3)/(z − 1)
        let k = tf(&[3.5, -3.0], &[1.0, -1.0]);
        let p = tf(&[0.13], &[1.0, -0.92, 0.0, 0.0, 0.0]);
        let w1 = tf(
            &[0.15, -0.138, 0.0, -0.13, 0.117],
            &[1.0, -1.82, 0.828, 0.0, 0.0, 0.0],
        );
        (phat, k, p, w1)
    }
}

mod chapter9 {
    use super::common::*;
    use lifted_mpc::*;
    use nalgebra::DMatrix;

    #[test]
    fn example_96_numbers() {
        let (phat, k, p, w1) = example96();
        let o = RobustnessOptions::default();
        let sr = beta_sr(&phat, &k, &w1, Uncertainty::Additive).unwrap();
        println!("beta_sr {:?}", sr);
        for n in [1, 2, 3, 4, 5, 8] {
            let b = beta_dr(&phat, &k, &w1, Uncertainty::Additive, n, &o).unwrap();
            let bl = beta_dr_lifted(&phat, &k, &w1, Uncertainty::Additive, n, &o).unwrap();
            println!("n={n} beta_dr {:?} lifted {:?}", b, bl);
        }
        for n in [1, 2, 3, 4, 5, 6, 8, 10] {
            let l = DualRateLoop::new(&p, &phat, &k, n).unwrap();
            println!("n={n} rho {}", l.spectral_radius().unwrap());
        }
        let l = DualRateLoop::new(&p, &phat, &k, 4).unwrap();
        let r = l.simulate(&DMatrix::from_element(400, 1, 1.0), None).unwrap();
        let (imax, ymax) = r.y.column(0).iter().enumerate().fold((0, f64::MIN), |a, (i, &v)| if v > a.1 { (i, v) } else { a });
        println!("peak {ymax} at {imax}; tail {:?}", r.y.rows(396, 4).iter().collect::<Vec<_>>());
    }
}

use lifted_lti::{StateSpace, TransferFunction};
use nalgebra::{DMatrix, dmatrix, dvector};

/// The A3.7 stirred-tank fast model (2x2).
pub fn tank() -> StateSpace {
    let a = DMatrix::from_diagonal(&dvector![0.9868, 0.97, 0.9131, 0.9048]);
    let b = dmatrix![1.0, 0.0; 0.0, 1.0; 1.0, 0.0; 0.0, 1.0];
    let c = dmatrix![0.1416, -0.03, 0.0, 0.0; 0.0, 0.0, -0.0379, 0.0595];
    StateSpace::new(a, b, c, DMatrix::zeros(2, 2), Some(1.0)).unwrap()
}

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

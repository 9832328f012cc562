//! Shared helpers.

use lifted_lti::{StateSpace, TransferFunction};
use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub type TestResult = Result<(), Box<dyn std::error::Error>>;

pub fn tf(num: &[f64], den: &[f64], ts: Option<f64>) -> StateSpace {
    TransferFunction::from_coeffs(num, den, ts)
        .unwrap()
        .to_ss()
        .unwrap()
}

/// Uniform random input in [-1, 1], N × m, held `hold` samples.
pub fn random_input(n: usize, m: usize, hold: usize, seed: u64) -> DMatrix<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut u = DMatrix::zeros(n, m);
    for j in 0..m {
        let mut v = 0.0;
        for k in 0..n {
            if k % hold == 0 {
                v = rng.random_range(-1.0..1.0);
            }
            u[(k, j)] = v;
        }
    }
    u
}

/// max |a − b|.
pub fn max_diff(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    assert_eq!(a.shape(), b.shape());
    a.iter()
        .zip(b.iter())
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

pub fn max_abs(a: &DMatrix<f64>) -> f64 {
    a.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

pub fn variance(x: &[f64]) -> f64 {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n
}

/// Lag-1 autocorrelation coefficient.
pub fn lag1(x: &[f64]) -> f64 {
    let n = x.len();
    let mean = x.iter().sum::<f64>() / n as f64;
    let c0: f64 = x.iter().map(|v| (v - mean).powi(2)).sum();
    let c1: f64 = (1..n).map(|k| (x[k] - mean) * (x[k - 1] - mean)).sum();
    c1 / c0
}

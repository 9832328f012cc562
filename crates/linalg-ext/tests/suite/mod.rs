//! Test modules by area, plus shared helpers.

mod cca;
mod decompositions;
mod equations;
mod matrix_functions;
mod rejected;

use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Seeded uniform [−1, 1) matrix.
pub fn random(m: usize, n: usize, seed: u64) -> DMatrix<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    DMatrix::from_fn(m, n, |_, _| rng.random::<f64>() * 2.0 - 1.0)
}

/// Seeded standard-normal matrix.
pub fn gaussian(m: usize, n: usize, seed: u64) -> DMatrix<f64> {
    use rand_distr::{Distribution, StandardNormal};
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    DMatrix::from_fn(m, n, |_, _| StandardNormal.sample(&mut rng))
}

/// Backward-error tolerance for an m×n computation on data of norm `scale`:
/// c·max(m, n)·ε·scale, with c = 50 covering the constants of Householder
/// and QR-iteration error bounds for these small sizes.
pub fn tol(m: usize, n: usize, scale: f64) -> f64 {
    50.0 * (m.max(n).max(1) as f64) * f64::EPSILON * scale.max(1.0)
}

/// The swept shapes: tall, wide, square, 1×1.
pub const SHAPES: [(usize, usize); 7] = [
    (1, 1),
    (5, 3),
    (3, 5),
    (40, 7),
    (7, 40),
    (30, 30),
    (200, 12),
];

/// Test matrices per shape: random, zero, and identity-like (ones on the
/// main diagonal).
pub fn cases(m: usize, n: usize, seed: u64) -> Vec<(&'static str, DMatrix<f64>)> {
    vec![
        ("random", random(m, n, seed)),
        ("zero", DMatrix::zeros(m, n)),
        ("identity", DMatrix::identity(m, n)),
    ]
}

/// ‖QᵀQ − I‖ small.
pub fn assert_orthonormal_columns(q: &DMatrix<f64>, what: &str) {
    let k = q.ncols();
    let e = (q.transpose() * q - DMatrix::identity(k, k)).norm();
    assert!(e <= tol(q.nrows(), k, 1.0), "{what}: ‖QᵀQ − I‖ = {e:e}");
}

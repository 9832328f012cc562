//! Criterion benches of the Lifted kernels; run with
//! `cargo bench -p lifted-benches --bench kernels`.
//!
//! The library part only holds the seeded data generator shared by the benches.

use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A `rows`×`cols` matrix of independent uniform entries in [−1, 1), built
/// from a fixed `seed` so every bench run sees the same data.
pub fn random_matrix(rows: usize, cols: usize, seed: u64) -> DMatrix<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    DMatrix::from_fn(rows, cols, |_, _| rng.random::<f64>() * 2.0 - 1.0)
}

//! Criterion benches of the Lifted kernels and identification pipelines; run
//! with `cargo bench -p lifted-benches` (see benches/README.md for the groups,
//! the peer comparison in `peers/` and the recorded figures).
//!
//! The library part only holds the seeded data generators shared by the
//! benches and examples.

use lifted_lti::StateSpace;
use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A `rows`×`cols` matrix of independent uniform entries in [−1, 1), built
/// from a fixed `seed` so every bench run sees the same data.
pub fn random_matrix(rows: usize, cols: usize, seed: u64) -> DMatrix<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    DMatrix::from_fn(rows, cols, |_, _| rng.random::<f64>() * 2.0 - 1.0)
}

/// The 2-input 2-output order-4 system of the peer comparison
/// (benches/peers/peers.py): A = blockdiag([[0.9, 0.2], [−0.2, 0.9]], 0.7,
/// −0.5), B = [[1, 0], [0, 1], [1, 0.5], [0.3, 1]], C = [[1, 0, 1, 0],
/// [0, 1, 0, 1]], D = 0, sample time 1.
pub fn peer_system() -> StateSpace {
    let a = DMatrix::from_row_slice(
        4,
        4,
        &[
            0.9, 0.2, 0.0, 0.0, //
            -0.2, 0.9, 0.0, 0.0, //
            0.0, 0.0, 0.7, 0.0, //
            0.0, 0.0, 0.0, -0.5,
        ],
    );
    let b = DMatrix::from_row_slice(4, 2, &[1.0, 0.0, 0.0, 1.0, 1.0, 0.5, 0.3, 1.0]);
    let c = DMatrix::from_row_slice(2, 4, &[1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0]);
    StateSpace::new(a, b, c, DMatrix::zeros(2, 2), Some(1.0)).expect("valid constant system")
}

/// `n` samples of [`peer_system`] driven by independent random binary ±1
/// inputs, outputs with white Gaussian noise of standard deviation
/// `noise_std` (Box–Muller on ChaCha8 with `seed`). Returns (u, y), one row
/// per sample. Noise 0 gives exactly rank-deficient Hankel data.
pub fn peer_data(n: usize, noise_std: f64, seed: u64) -> (DMatrix<f64>, DMatrix<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let u = DMatrix::from_fn(n, 2, |_, _| if rng.random::<bool>() { 1.0 } else { -1.0 });
    let mut y = peer_system()
        .lsim(&u, None, None)
        .expect("simulation of a valid system")
        .y;
    if noise_std > 0.0 {
        for v in y.iter_mut() {
            let (a, b): (f64, f64) = (rng.random(), rng.random());
            let g = (-2.0 * (1.0 - a).ln()).sqrt() * (std::f64::consts::TAU * b).cos();
            *v += noise_std * g;
        }
    }
    (u, y)
}

/// The plant and record of the PEM benches (`benches/pem.rs`,
/// `examples/pem_cost.rs`): a stable order-`n` plant with `nu` inputs and
/// `ny` outputs (poles 0.95, 0.9, 0.8, 0.6, −0.4, 0.3 taken in order, 0.1
/// couplings on the superdiagonal, seeded B and C uniform in [−0.5, 0.5)),
/// `len` samples of a random binary ±1 input and its response with uniform
/// output noise of width 0.1 (seed 27). Returns (plant, u, y).
///
/// Errors: `n` above 6 (there are six poles) or a plant the state-space
/// checks refuse ([`lifted_lti::Error`]).
pub fn pem_case(
    n: usize,
    nu: usize,
    ny: usize,
    len: usize,
) -> lifted_lti::Result<(StateSpace, DMatrix<f64>, DMatrix<f64>)> {
    let poles = [0.95, 0.9, 0.8, 0.6, -0.4, 0.3];
    if n > poles.len() {
        return Err(lifted_lti::Error::InvalidArgument {
            what: "n",
            reason: format!(
                "the PEM bench plant has at most {} states, got {n}",
                poles.len()
            ),
        });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(27);
    let mut a = DMatrix::from_diagonal(&nalgebra::DVector::from_fn(n, |i, _| poles[i]));
    for i in 0..n.saturating_sub(1) {
        a[(i, i + 1)] = 0.1;
    }
    let b = DMatrix::from_fn(n, nu, |_, _| rng.random::<f64>() - 0.5);
    let c = DMatrix::from_fn(ny, n, |_, _| rng.random::<f64>() - 0.5);
    let g = StateSpace::new(a, b, c, DMatrix::zeros(ny, nu), Some(1.0))?;
    let u = DMatrix::from_fn(
        len,
        nu,
        |_, _| if rng.random::<bool>() { 1.0 } else { -1.0 },
    );
    let mut y = g.lsim(&u, None, None)?.y;
    y.iter_mut()
        .for_each(|v| *v += 0.1 * (rng.random::<f64>() - 0.5));
    Ok((g, u, y))
}

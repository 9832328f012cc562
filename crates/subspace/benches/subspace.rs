//! Criterion benches of the subspace engine: N = 1e4, 1e5, 1e6 samples,
//! SISO and 2x2, order 4, horizons p = f = 20 (N4SID). Peak memory is
//! measured separately by `examples/peak_memory.rs`. The prediction-error
//! refinement's bench is `cargo bench -p lifted-benches --bench pem`.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use lifted_lti::StateSpace;
use lifted_subspace::{Experiment, OrderSelection, SubspaceOptions, identify};
use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn plant(nu: usize, ny: usize) -> StateSpace {
    let a = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![0.95, 0.8, 0.6, -0.4]));
    let b = DMatrix::from_fn(4, nu, |i, j| 1.0 / (1.0 + i as f64 + j as f64));
    let c = DMatrix::from_fn(ny, 4, |i, j| if (i + j) % 2 == 0 { 1.0 } else { 0.5 });
    StateSpace::new(a, b, c, DMatrix::zeros(ny, nu), Some(1.0)).expect("valid model")
}

fn data(n: usize, nu: usize, ny: usize) -> (DMatrix<f64>, DMatrix<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let u = DMatrix::from_fn(n, nu, |_, _| if rng.random::<bool>() { 1.0 } else { -1.0 });
    let mut y = plant(nu, ny).lsim(&u, None, None).expect("simulation").y;
    y.iter_mut()
        .for_each(|v| *v += 0.1 * (rng.random::<f64>() - 0.5));
    (u, y)
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("n4sid_order4_horizon20");
    group.sample_size(10);
    for &(nu, ny) in &[(1usize, 1usize), (2, 2)] {
        for &n in &[10_000usize, 100_000, 1_000_000] {
            let (u, y) = data(n, nu, ny);
            let opts = SubspaceOptions {
                order: OrderSelection::Fixed(4),
                past: 20,
                future: 20,
                noise_model: false,
                ..Default::default()
            };
            group.bench_with_input(BenchmarkId::new(format!("{nu}x{ny}"), n), &n, |b, _| {
                b.iter(|| identify(&[Experiment { u: &u, y: &y }], &opts).expect("identify"))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

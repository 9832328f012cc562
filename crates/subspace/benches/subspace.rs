//! Criterion benches of the subspace engine: N = 1e4, 1e5, 1e6 samples,
//! SISO and 2x2, order 4, horizons p = f = 20 (N4SID). Peak memory is
//! measured separately by `examples/peak_memory.rs`. Group `refine_pem`:
//! prediction-error refinement (analytic Jacobian, QR-based LM) of a
//! perturbed start, 3×2 order 6 at N = 2e4 and 2×2 order 4 at N = 1e6.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use lifted_lti::StateSpace;
use lifted_subspace::{
    Experiment, Feedthrough, OrderSelection, PemOptions, Record, SubspaceOptions, identify,
    refine_pem,
};
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

/// A stable order-`n` plant with `nu` inputs and `ny` outputs (fixed
/// poles, seeded B, C), its record (binary input, white output noise 0.1,
/// seeded) and a start with A shrunk and B grown by 3 %.
fn pem_case(
    n: usize,
    nu: usize,
    ny: usize,
    len: usize,
) -> (StateSpace, DMatrix<f64>, DMatrix<f64>) {
    let poles = [0.95, 0.9, 0.8, 0.6, -0.4, 0.3];
    let mut rng = ChaCha8Rng::seed_from_u64(27);
    let mut a = DMatrix::from_diagonal(&nalgebra::DVector::from_fn(n, |i, _| poles[i]));
    // A mild coupling keeps the plant non-diagonal.
    for i in 0..n - 1 {
        a[(i, i + 1)] = 0.1;
    }
    let b = DMatrix::from_fn(n, nu, |_, _| rng.random::<f64>() - 0.5);
    let c = DMatrix::from_fn(ny, n, |_, _| rng.random::<f64>() - 0.5);
    let g = StateSpace::new(a, b, c, DMatrix::zeros(ny, nu), Some(1.0)).expect("valid model");
    let u = DMatrix::from_fn(
        len,
        nu,
        |_, _| if rng.random::<bool>() { 1.0 } else { -1.0 },
    );
    let mut y = g.lsim(&u, None, None).expect("simulation").y;
    y.iter_mut()
        .for_each(|v| *v += 0.1 * (rng.random::<f64>() - 0.5));
    let start = StateSpace::new(
        g.a() * 0.97,
        g.b() * 1.03,
        g.c().clone(),
        g.d().clone(),
        Some(1.0),
    )
    .expect("valid model");
    (start, u, y)
}

fn bench_pem(c: &mut Criterion) {
    let mut group = c.benchmark_group("refine_pem");
    group.sample_size(10);
    let opts = PemOptions {
        feedthrough: Feedthrough::Zero,
        ..Default::default()
    };
    for &(n, nu, ny, len) in &[(6usize, 3usize, 2usize, 20_000usize), (4, 2, 2, 1_000_000)] {
        let (start, u, y) = pem_case(n, nu, ny, len);
        let rec = [Record {
            u: &u,
            y: &y,
            instrument: None,
        }];
        group.bench_with_input(
            BenchmarkId::new(format!("{nu}x{ny}_order{n}"), len),
            &len,
            |b, _| b.iter(|| refine_pem(&start, None, &rec, &[], &opts).expect("refine")),
        );
    }
    group.finish();
}

criterion_group!(benches, bench, bench_pem);
criterion_main!(benches);

//! Criterion benches: lifting and lifted identification, 2×2 plant, J = 5
//! (y₁ every 5, y₂ every 1), N = 10⁵ fast samples.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use lifted_lti::StateSpace;
use lifted_multirate::{LiftedIdOptions, MultirateLifting, Ordering, identify_lifted};
use lifted_subspace::OrderSelection;
use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn plant() -> StateSpace {
    let a = DMatrix::from_row_slice(
        4,
        4,
        &[
            0.9868, 0.0, 0.0, 0.0, 0.0, 0.97, 0.0, 0.0, 0.0, 0.0, 0.9131, 0.0, 0.0, 0.0, 0.0,
            0.9048,
        ],
    );
    let b = DMatrix::from_row_slice(4, 2, &[0.1416, 0.0, 0.0, -0.03, -0.0379, 0.0, 0.0, 0.0595]);
    let c = DMatrix::from_row_slice(2, 4, &[1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0]);
    StateSpace::new(a, b, c, DMatrix::zeros(2, 2), Some(1.0)).expect("valid plant")
}

fn data(len: usize) -> (DMatrix<f64>, DMatrix<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let u = DMatrix::from_fn(len, 2, |_, _| if rng.random::<bool>() { 1.0 } else { -1.0 });
    let mut y = plant().lsim(&u, None, None).expect("simulation").y;
    for v in y.iter_mut() {
        *v += 0.05 * (rng.random::<f64>() - 0.5);
    }
    (u, y)
}

fn bench(c: &mut Criterion) {
    let len = 100_000;
    let (u, y) = data(len);
    let lifting = MultirateLifting::mimo(2, &[5, 1], Ordering::TimeMajor).expect("lifting");
    let ds = lifting.dataset(1.0, u, y).expect("data set");
    let mut g = c.benchmark_group("lifting");
    g.bench_with_input(
        BenchmarkId::new("lift_dataset_2x2_J5", len),
        &ds,
        |b, ds| b.iter(|| lifting.lift_dataset(ds, false).expect("lift")),
    );
    g.finish();
    let ld = lifting.lift_dataset(&ds, false).expect("lift");
    let mut g = c.benchmark_group("lifted_identification");
    g.sample_size(10);
    let opts = LiftedIdOptions {
        order: OrderSelection::Fixed(4),
        past: 6,
        future: 6,
        ..Default::default()
    };
    g.bench_with_input(
        BenchmarkId::new("n4sid_causal_2x2_J5", len),
        &ld,
        |b, ld| b.iter(|| identify_lifted(ld, &opts).expect("identify")),
    );
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

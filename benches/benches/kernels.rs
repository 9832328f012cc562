//! Thin SVD and R-only QR: the faer path of `lifted-linalg` against
//! nalgebra's own decompositions, on the tall shapes of the subspace
//! methods (2000×200 and 100000×160).
//!
//! Run: `cargo bench -p lifted-benches --bench kernels`.
//! Inputs are built (and, for consuming APIs, cloned) outside the timed
//! closures. Sample counts are criterion's minimum (10) with flat sampling,
//! so the large nalgebra SVD (several seconds per call) keeps the whole run
//! to a few minutes.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BatchSize, BenchmarkId, Criterion, SamplingMode, criterion_group, criterion_main};
use lifted_benches::random_matrix;

const SIZES: [(usize, usize); 2] = [(2000, 200), (100_000, 160)];

fn label(m: usize, n: usize) -> String {
    format!("{m}x{n}")
}

fn thin_svd(c: &mut Criterion) {
    let mut group = c.benchmark_group("thin_svd");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_millis(500));
    for (m, n) in SIZES {
        let a = random_matrix(m, n, 1);
        group.measurement_time(Duration::from_secs(if m > 10_000 { 10 } else { 3 }));
        group.bench_with_input(BenchmarkId::new("faer", label(m, n)), &a, |b, a| {
            b.iter(|| black_box(lifted_linalg::svd(a).expect("finite input")))
        });
        group.bench_with_input(BenchmarkId::new("nalgebra", label(m, n)), &a, |b, a| {
            b.iter_batched(
                || a.clone(),
                |a| black_box(a.svd(true, true)),
                BatchSize::LargeInput,
            )
        });
    }
    group.finish();
}

fn r_only_qr(c: &mut Criterion) {
    let mut group = c.benchmark_group("qr_r");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_millis(500));
    for (m, n) in SIZES {
        let a = random_matrix(m, n, 2);
        group.measurement_time(Duration::from_secs(if m > 10_000 { 8 } else { 2 }));
        // Both factor a fresh copy in place; the copy is made outside the timing.
        group.bench_with_input(BenchmarkId::new("faer", label(m, n)), &a, |b, a| {
            b.iter_batched(
                || a.clone(),
                |a| black_box(lifted_linalg::qr_r_owned(a).expect("finite input")),
                BatchSize::LargeInput,
            )
        });
        group.bench_with_input(BenchmarkId::new("nalgebra", label(m, n)), &a, |b, a| {
            b.iter_batched(
                || a.clone(),
                |a| black_box(a.qr().r()),
                BatchSize::LargeInput,
            )
        });
    }
    group.finish();
}

criterion_group!(kernels, thin_svd, r_only_qr);
criterion_main!(kernels);

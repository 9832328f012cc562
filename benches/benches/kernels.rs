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

/// The narrow least squares of the subspace estimates (the projection (B, D)
/// regression is 720 × 8; `lstsq` 720 × 6 with two right-hand sides): this
/// crate's unblocked in-place path against nalgebra's QR solve.
fn narrow_least_squares(c: &mut Criterion) {
    let mut group = c.benchmark_group("narrow_least_squares");
    group
        .sample_size(20)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    let a = random_matrix(720, 8, 3);
    group.bench_function(BenchmarkId::new("qr_r_faer", "720x8"), |b| {
        b.iter(|| black_box(lifted_linalg::qr_r(black_box(&a)).expect("finite input")))
    });
    group.bench_function(BenchmarkId::new("qr_r_nalgebra", "720x8"), |b| {
        b.iter(|| black_box(black_box(&a).clone().qr().r()))
    });
    let (x, y) = (a.columns(0, 6).into_owned(), a.columns(6, 2).into_owned());
    group.bench_function(BenchmarkId::new("lstsq_faer", "720x6"), |b| {
        b.iter(|| black_box(lifted_linalg::lstsq(black_box(&x), &y).expect("finite input")))
    });
    group.bench_function(BenchmarkId::new("lstsq_nalgebra", "720x6"), |b| {
        b.iter(|| {
            let qr = black_box(&x).clone().qr();
            let qty = qr.q().transpose() * &y;
            black_box(qr.r().solve_upper_triangular(&qty))
        })
    });
    group.finish();
}

/// One block of 1000 rows × 13 columns (the modal regression's narrow
/// base rows) folded into a full 13×13 R: `RAccumulator::fold_rows` (the
/// structured reflections, the block as scratch) and `push_rows` (a copy
/// of the block first) against the Householder QR of the stacked
/// [R; block] (1013×13, faer, what `push_rows` did before).
fn accumulator_fold(c: &mut Criterion) {
    let mut group = c.benchmark_group("accumulator_fold_1000x13");
    group
        .sample_size(30)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    let block = random_matrix(1000, 13, 5);
    let mut acc = lifted_linalg::RAccumulator::new(13);
    acc.push_rows(&random_matrix(50, 13, 6))
        .expect("finite input");
    let r = acc.r();
    group.bench_function("fold_rows", |b| {
        b.iter_batched(
            || (acc.clone(), block.clone()),
            |(mut a, mut blk)| {
                a.fold_rows(&mut blk).expect("finite input");
                black_box(a)
            },
            BatchSize::SmallInput,
        )
    });
    group.bench_function("push_rows", |b| {
        b.iter_batched(
            || acc.clone(),
            |mut a| {
                a.push_rows(black_box(&block)).expect("finite input");
                black_box(a)
            },
            BatchSize::SmallInput,
        )
    });
    let mut stacked = nalgebra::DMatrix::zeros(1013, 13);
    stacked.rows_mut(0, 13).copy_from(&r);
    stacked.rows_mut(13, 1000).copy_from(&block);
    group.bench_function("stacked_qr_faer", |b| {
        b.iter(|| black_box(lifted_linalg::qr_r(black_box(&stacked)).expect("finite input")))
    });
    group.finish();
}

criterion_group!(
    kernels,
    thin_svd,
    r_only_qr,
    narrow_least_squares,
    accumulator_fold
);
criterion_main!(kernels);

//! Block-Hankel compression of 2-input 2-output data with s = 20 block rows
//! (past = future = 20, k = 160 Hankel rows): the structure-exploiting
//! correlation/Cholesky route (1 and 2 threads) against the R-only QR
//! reference, N = 1e4, 1e5, 1e6 (and 1e7 for the correlations when
//! `LIFTED_BENCH_1E7=1` is set; the QR at 1e7 takes minutes per call).
//!
//! Before timing each size the accuracy of the correlation factor against
//! the QR reference is printed to stderr: the relative difference of the
//! Gram matrices L Lᵀ and the largest relative difference of the singular
//! values of L.
//!
//! Run: `cargo bench -p lifted-benches --bench compression`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, SamplingMode, criterion_group, criterion_main};
use lifted_benches::peer_data;
use lifted_subspace::{Compression, Experiment, compress_hankel};

const S: usize = 20;

fn sizes() -> Vec<usize> {
    let mut v = vec![10_000, 100_000, 1_000_000];
    if std::env::var("LIFTED_BENCH_1E7").is_ok_and(|x| x == "1") {
        v.push(10_000_000);
    }
    v
}

fn accuracy(u: &nalgebra::DMatrix<f64>, y: &nalgebra::DMatrix<f64>) {
    let e = [Experiment { u, y }];
    let qr = compress_hankel(&e, S, S, Compression::Qr, 1).expect("QR compression");
    let co = compress_hankel(&e, S, S, Compression::Correlation, 1).expect("correlations");
    let (gq, gc) = (&qr.l * qr.l.transpose(), &co.l * co.l.transpose());
    let sq = lifted_linalg::singular_values(&qr.l).expect("svd");
    let sc = lifted_linalg::singular_values(&co.l).expect("svd");
    let sv = sq
        .iter()
        .zip(sc.iter())
        .map(|(a, b)| (a - b).abs() / a)
        .fold(0.0, f64::max);
    eprintln!(
        "N = {}: correlation vs QR: |G_c - G_qr|/|G_qr| = {:.2e}, max rel. singular value difference {:.2e}, rcond {:.2e}",
        u.nrows(),
        (gc - &gq).norm() / gq.norm(),
        sv,
        co.report.rcond
    );
}

fn compression(c: &mut Criterion) {
    let mut group = c.benchmark_group("hankel_compression_2x2_s20");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_millis(500));
    for n in sizes() {
        let (u, y) = peer_data(n, 0.1, 1);
        if n <= 1_000_000 {
            accuracy(&u, &y);
        }
        let e = [Experiment { u: &u, y: &y }];
        for threads in [1usize, 2] {
            group.bench_function(
                BenchmarkId::new(format!("correlation_{threads}thread"), n),
                |b| {
                    b.iter(|| {
                        compress_hankel(black_box(&e), S, S, Compression::Correlation, threads)
                            .expect("compression")
                    })
                },
            );
        }
        if n <= 1_000_000 {
            group.bench_function(BenchmarkId::new("qr", n), |b| {
                b.iter(|| {
                    compress_hankel(black_box(&e), S, S, Compression::Qr, 1).expect("compression")
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, compression);
criterion_main!(benches);

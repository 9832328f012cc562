//! End-to-end pipelines: subspace identification (N4SID, MOESP, CVA) of
//! 2-input 2-output data with s = 20 block rows, in memory and streamed in
//! blocks, and the q-Markov Cover on one period of 81 900 samples with its
//! correlations computed directly at the q = 60 lags used or by FFT.
//!
//! Lifting and the MPC update have their own benches in their crates
//! (`cargo bench -p lifted-multirate`, `cargo bench -p lifted-mpc`); they
//! are not repeated here.
//!
//! The fixed cost at N = 1e4 (in memory and streamed) is its own group:
//! `cargo bench -p lifted-benches --bench pipelines -- fixed_cost`.
//!
//! Run: `cargo bench -p lifted-benches --bench pipelines`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, SamplingMode, criterion_group, criterion_main};
use lifted_benches::peer_data;
use lifted_prbs::{CorrelationMethod, InversePrbs, InversePrbsOptions};
use lifted_qmarkov::{ChannelRecord, QMarkovOptions, RecordMode, identify_records};
use lifted_subspace::{
    Compression, Experiment, InitialState, Method, OrderSelection, StreamingIdentifier,
    SubspaceOptions, identify,
};
use nalgebra::DMatrix;

fn options(method: Method, compression: Compression) -> SubspaceOptions {
    SubspaceOptions {
        method,
        order: OrderSelection::Fixed(4),
        past: 20,
        future: 20,
        compression,
        ..Default::default()
    }
}

fn subspace(c: &mut Criterion) {
    let mut group = c.benchmark_group("subspace_identify_2x2_s20");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_millis(500));
    let n = 100_000;
    let (u, y) = peer_data(n, 0.1, 1);
    let e = [Experiment { u: &u, y: &y }];
    for method in [Method::N4sid, Method::Moesp, Method::Cva] {
        for (name, comp) in [("auto", Compression::Auto), ("qr", Compression::Qr)] {
            let opts = options(method, comp);
            group.bench_function(
                BenchmarkId::new(format!("{}_{name}", method.name()), n),
                |b| b.iter(|| identify(black_box(&e), &opts).expect("identification")),
            );
        }
    }
    // The 1e6 target case: compression + SVD + estimate, data in memory.
    let n = 1_000_000;
    let (u, y) = peer_data(n, 0.1, 1);
    let e = [Experiment { u: &u, y: &y }];
    for (name, x0) in [
        ("x0", InitialState::Estimate),
        ("zero_x0", InitialState::Zero),
    ] {
        let opts = SubspaceOptions {
            initial_state: x0,
            ..options(Method::N4sid, Compression::Auto)
        };
        group.bench_function(BenchmarkId::new(format!("N4SID_auto_{name}"), n), |b| {
            b.iter(|| identify(black_box(&e), &opts).expect("identification"))
        });
    }
    // The in-memory default on 2 threads (compression, finiteness scan and
    // the modal (B, D, x₀) regression split over them).
    let opts = SubspaceOptions {
        threads: 2,
        ..options(Method::N4sid, Compression::Auto)
    };
    group.bench_function(BenchmarkId::new("N4SID_auto_x0_2threads", n), |b| {
        b.iter(|| identify(black_box(&e), &opts).expect("identification"))
    });
    // Streaming: blocks of 65 536 samples.
    let opts = SubspaceOptions {
        initial_state: InitialState::Zero,
        ..options(Method::N4sid, Compression::Auto)
    };
    let blocks: Vec<(DMatrix<f64>, DMatrix<f64>)> = (0..n)
        .step_by(1 << 16)
        .map(|s| {
            let len = (1usize << 16).min(n - s);
            (u.rows(s, len).into_owned(), y.rows(s, len).into_owned())
        })
        .collect();
    group.bench_function(BenchmarkId::new("N4SID_streaming_blocks65536", n), |b| {
        b.iter(|| {
            let mut id = StreamingIdentifier::new(2, 2, &opts).expect("options");
            for (bu, by) in &blocks {
                id.push(bu, by).expect("push");
            }
            id.finish().expect("identification")
        })
    });
    group.finish();
}

/// The fixed cost: N4SID end to end on N = 1e4 samples (2×2, s = 20,
/// order 4), where the k×k work (k = 160) outweighs the compression; in
/// memory (x₀ estimated, output-error (B, D) over the record) and streamed
/// in one block (x₀ = 0, (B, D) from the compressed data).
fn fixed_cost(c: &mut Criterion) {
    let mut group = c.benchmark_group("subspace_fixed_cost_2x2_s20");
    group
        .sample_size(30)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    let n = 10_000;
    let (u, y) = peer_data(n, 0.1, 1);
    let e = [Experiment { u: &u, y: &y }];
    let opts = options(Method::N4sid, Compression::Auto);
    group.bench_function(BenchmarkId::new("N4SID_in_memory", n), |b| {
        b.iter(|| identify(black_box(&e), &opts).expect("identification"))
    });
    let stream = SubspaceOptions {
        initial_state: InitialState::Zero,
        ..opts.clone()
    };
    group.bench_function(BenchmarkId::new("N4SID_streamed", n), |b| {
        b.iter(|| {
            let mut id = StreamingIdentifier::new(2, 2, &stream).expect("options");
            id.push(black_box(&u), black_box(&y)).expect("push");
            id.finish().expect("identification")
        })
    });
    group.finish();
}

/// Two periods from rest per channel of the held inverse PRBS (m = 4095,
/// n_r = 10) through a stable 2-state plant; the last period is used.
fn qmarkov_records(ni: usize, no: usize) -> Vec<ChannelRecord> {
    let a = DMatrix::from_row_slice(2, 2, &[0.95, 0.1, 0.0, 0.8]);
    let b = DMatrix::from_fn(2, ni, |i, j| 0.05 * (1 + i + j) as f64);
    let cm = DMatrix::from_fn(no, 2, |i, j| if i == j { 1.0 } else { 0.3 });
    let g = lifted_lti::StateSpace::new(a, b, cm, DMatrix::zeros(no, ni), Some(0.01))
        .expect("valid plant");
    let prbs = InversePrbs::new(&InversePrbsOptions {
        order: 12,
        amplitude: 1.0,
        hold: 10,
        taps: None,
    })
    .expect("valid PRBS");
    let w = prbs.generate(2 * prbs.period() as usize);
    (0..ni)
        .map(|l| {
            let mut u = DMatrix::zeros(w.len(), ni);
            u.set_column(l, &nalgebra::DVector::from_column_slice(&w));
            ChannelRecord {
                input: w.clone(),
                output: g.lsim(&u, None, None).expect("simulation").y,
            }
        })
        .collect()
}

fn qmarkov(c: &mut Criterion) {
    let mut group = c.benchmark_group("qmarkov_m4095_nr10_q60");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500));
    for (ni, no) in [(1usize, 1usize), (2, 2)] {
        let recs = qmarkov_records(ni, no);
        for (name, method) in [
            ("auto", CorrelationMethod::Auto),
            ("direct", CorrelationMethod::Direct),
            ("fft", CorrelationMethod::Fft),
        ] {
            let opts = QMarkovOptions {
                q: 60,
                order: Some(2),
                hold: 10,
                prbs_order: 12,
                record: RecordMode::LastPeriod,
                correlation: method,
                ..Default::default()
            };
            group.bench_function(BenchmarkId::new(name, format!("{no}x{ni}")), |b| {
                b.iter(|| identify_records(black_box(&recs), 0.01, &opts).expect("cover"))
            });
        }
    }
    // One full periodic correlation of 81 900 samples by FFT (cached plan).
    let x: Vec<f64> = (0..81_900)
        .map(|k| ((k * 7919) % 101) as f64 - 50.0)
        .collect();
    group.bench_function("prbs_fft_correlation_81900", |b| {
        b.iter(|| {
            lifted_prbs::periodic_cross_correlation_with(
                black_box(&x),
                &x,
                lifted_prbs::Normalization::Length,
                CorrelationMethod::Fft,
            )
            .expect("correlation")
        })
    });
    group.finish();
}

criterion_group!(benches, fixed_cost, subspace, qmarkov);
criterion_main!(benches);

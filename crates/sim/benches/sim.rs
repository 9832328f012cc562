//! Simulated samples per second: a 6-state 2x2 plant with coloured noise in
//! a decentralised PI loop (the workspace's typical closed-loop experiment),
//! the fused fast path next to the block-by-block reference path. Times are
//! the benchmarking thread's CPU time (the machine is shared).

use std::hint::black_box;

use criterion::measurement::{Measurement, ValueFormatter, WallTime};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use lifted_lti::{StateSpace, TransferFunction};
use lifted_sim::{
    Controller, Excitation, NoiseLevel, NoiseSpec, Plant, SimSignals, Simulator, SnrDefinition,
};
use nalgebra::DMatrix;

/// CPU time of the benchmarking thread (Linux `/proc/thread-self/schedstat`,
/// ns on the CPU, user + system, page faults included), so that other
/// processes sharing the cores do not inflate the figures; wall-clock time
/// where the file is missing.
struct CpuTime;

static WALL: WallTime = WallTime;

fn thread_cpu_ns() -> u64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse().ok())
        .unwrap_or_else(|| {
            static T0: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
            T0.get_or_init(std::time::Instant::now).elapsed().as_nanos() as u64
        })
}

impl Measurement for CpuTime {
    type Intermediate = u64;
    type Value = u64;
    fn start(&self) -> u64 {
        thread_cpu_ns()
    }
    fn end(&self, i: u64) -> u64 {
        thread_cpu_ns().saturating_sub(i)
    }
    fn add(&self, a: &u64, b: &u64) -> u64 {
        a + b
    }
    fn zero(&self) -> u64 {
        0
    }
    fn to_f64(&self, v: &u64) -> f64 {
        *v as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        WALL.formatter()
    }
}

fn plant() -> Plant {
    // 6 states: three stable modes per input, coupled outputs, discrete at T = 1
    let a = DMatrix::from_fn(6, 6, |i, j| {
        if i == j {
            0.95 - 0.05 * i as f64
        } else if j + 1 == i {
            0.1
        } else {
            0.0
        }
    });
    let b = DMatrix::from_fn(6, 2, |i, j| if i % 2 == j { 0.1 } else { 0.02 });
    let c = DMatrix::from_fn(2, 6, |i, j| if j % 2 == i { 1.0 } else { 0.3 });
    let g = StateSpace::new(a, b, c, DMatrix::zeros(2, 2), Some(1.0)).expect("valid plant");
    Plant::discrete(&g, &[], &[]).expect("discrete plant")
}

fn simulator(level: NoiseLevel) -> Simulator {
    let k = Controller::decentralized(
        2,
        2,
        1.0,
        &[
            (0, 0, &[0.6, -0.5], &[1.0, -1.0]),
            (1, 1, &[0.4, -0.3], &[1.0, -1.0]),
        ],
    )
    .expect("PI pair");
    let noise =
        TransferFunction::from_coeffs(&[0.1, 0.0], &[1.0, -0.9], Some(1.0)).expect("filter");
    let h = NoiseSpec::diagonal_model(&[noise.clone(), noise]).expect("noise model");
    Simulator::closed_loop(plant(), k)
        .expect("loop")
        .with_noise(NoiseSpec {
            model: Some(h),
            level,
            seed: 1,
            ..Default::default()
        })
        .expect("noise")
}

fn closed_loop(c: &mut Criterion<CpuTime>) {
    let mut g = c.benchmark_group("closed_loop_6state_2x2_noise");
    {
        let n = 100_000usize;
        let r = DMatrix::from_fn(n, 2, |k, j| if (k / 7 + j) % 3 == 0 { 1.0 } else { -1.0 });
        let exc = Excitation::both(r.clone(), r);
        g.throughput(Throughput::Elements(n as u64));
        let abs = simulator(NoiseLevel::Std(vec![1.0]));
        g.bench_with_input(BenchmarkId::new("absolute_noise", n), &exc, |b, exc| {
            b.iter(|| black_box(abs.simulate(exc).expect("runs")));
        });
        g.bench_with_input(
            BenchmarkId::new("absolute_noise_reference", n),
            &exc,
            |b, exc| {
                b.iter(|| black_box(abs.simulate_reference(exc).expect("runs")));
            },
        );
        // the same simulation into reused buffers (no data set, no copies
        // of the excitation, no fresh pages)
        let mut sig = SimSignals::default();
        g.bench_with_input(
            BenchmarkId::new("absolute_noise_into_buffers", n),
            &exc,
            |b, exc| {
                b.iter(|| {
                    abs.simulate_into(exc, &mut sig).expect("runs");
                    black_box(&sig);
                });
            },
        );
        let clean = Simulator::closed_loop(
            plant(),
            Controller::decentralized(
                2,
                2,
                1.0,
                &[
                    (0, 0, &[0.6, -0.5], &[1.0, -1.0]),
                    (1, 1, &[0.4, -0.3], &[1.0, -1.0]),
                ],
            )
            .expect("PI pair"),
        )
        .expect("loop");
        g.bench_with_input(BenchmarkId::new("noise_free", n), &exc, |b, exc| {
            b.iter(|| black_box(clean.simulate(exc).expect("runs")));
        });
        g.bench_with_input(
            BenchmarkId::new("noise_free_into_buffers", n),
            &exc,
            |b, exc| {
                b.iter(|| {
                    clean.simulate_into(exc, &mut sig).expect("runs");
                    black_box(&sig);
                });
            },
        );
        g.bench_with_input(
            BenchmarkId::new("noise_free_reference", n),
            &exc,
            |b, exc| {
                b.iter(|| black_box(clean.simulate_reference(exc).expect("runs")));
            },
        );
        let snr = simulator(NoiseLevel::Snr {
            ratio: vec![5.0],
            definition: SnrDefinition::Variance,
        });
        g.bench_with_input(
            BenchmarkId::new("snr_scaled_two_runs", n),
            &exc,
            |b, exc| {
                b.iter(|| black_box(snr.simulate(exc).expect("runs")));
            },
        );
        g.bench_with_input(
            BenchmarkId::new("snr_scaled_two_runs_reference", n),
            &exc,
            |b, exc| {
                b.iter(|| black_box(snr.simulate_reference(exc).expect("runs")));
            },
        );
        g.bench_with_input(
            BenchmarkId::new("snr_scaled_two_runs_into_buffers", n),
            &exc,
            |b, exc| {
                b.iter(|| {
                    snr.simulate_into(exc, &mut sig).expect("runs");
                    black_box(&sig);
                });
            },
        );
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().with_measurement(CpuTime);
    targets = closed_loop
}
criterion_main!(benches);

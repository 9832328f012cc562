//! Throughput of the m-sequence generators and of the held inverse PRBS.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use lifted_prbs::{InversePrbs, InversePrbsOptions, MSequence};

const BITS: usize = 1 << 20;

fn mseq_bits(c: &mut Criterion) {
    let mut g = c.benchmark_group("mseq_order20_bits");
    g.throughput(Throughput::Elements(BITS as u64));
    let reg = MSequence::new(20).expect("order 20 is supported");
    g.bench_with_input(
        BenchmarkId::new("fibonacci_bit_serial", BITS),
        &reg,
        |b, reg| {
            let mut out = vec![0u8; BITS];
            b.iter(|| {
                let mut r = reg.clone();
                r.fill_bits(&mut out);
                black_box(&out);
            });
        },
    );
    g.bench_with_input(BenchmarkId::new("word_parallel", BITS), &reg, |b, reg| {
        let mut out = vec![0u64; BITS / 64];
        b.iter(|| {
            let mut w = reg.clone().into_words();
            w.fill_words(&mut out);
            black_box(&out);
        });
    });
    g.finish();
}

fn held_inverse_prbs(c: &mut Criterion) {
    let mut g = c.benchmark_group("held_inverse_prbs_samples");
    let len = 1 << 20;
    g.throughput(Throughput::Elements(len as u64));
    for hold in [1usize, 10] {
        let p = InversePrbs::new(&InversePrbsOptions {
            order: 20,
            amplitude: 2.0,
            hold,
            taps: None,
        })
        .expect("valid options");
        g.bench_with_input(BenchmarkId::new("iterator", hold), &p, |b, p| {
            let mut out = vec![0.0f64; len];
            b.iter(|| {
                for (o, v) in out.iter_mut().zip(p.iter()) {
                    *o = v;
                }
                black_box(&out);
            });
        });
        g.bench_with_input(BenchmarkId::new("bulk_generate", hold), &p, |b, p| {
            b.iter(|| black_box(p.generate(len)));
        });
    }
    g.finish();
}

criterion_group!(benches, mseq_bits, held_inverse_prbs);
criterion_main!(benches);

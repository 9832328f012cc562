//! Identification time for one steady-state period: m = 2¹² − 1, n_r = 10, q = 60
//! (N = 81 900 samples), SISO and 2×2.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use lifted_lti::StateSpace;
use lifted_prbs::{InversePrbs, InversePrbsOptions};
use lifted_qmarkov::{ChannelRecord, QMarkovOptions, RecordMode, identify_records};
use nalgebra::DMatrix;

const ORDER: u32 = 12;
const HOLD: usize = 10;

/// A stable 2-state plant with `ni` inputs and `no` outputs.
fn plant(ni: usize, no: usize) -> StateSpace {
    let a = DMatrix::from_row_slice(2, 2, &[0.95, 0.1, 0.0, 0.8]);
    let b = DMatrix::from_fn(2, ni, |i, j| 0.05 * (1 + i + j) as f64);
    let c = DMatrix::from_fn(no, 2, |i, j| if i == j { 1.0 } else { 0.3 });
    StateSpace::new(a, b, c, DMatrix::zeros(no, ni), Some(0.01)).expect("valid plant")
}

/// Two periods from rest per channel; the last is used (transients ~0.95^32760).
fn records(ni: usize, no: usize) -> Vec<ChannelRecord> {
    let g = plant(ni, no);
    let prbs = InversePrbs::new(&InversePrbsOptions {
        order: ORDER,
        amplitude: 1.0,
        hold: HOLD,
        taps: None,
    })
    .expect("valid PRBS");
    let w = prbs.generate(2 * prbs.period() as usize);
    (0..ni)
        .map(|l| {
            let mut u = DMatrix::zeros(w.len(), ni);
            u.set_column(l, &nalgebra::DVector::from_column_slice(&w));
            let y = g.lsim(&u, None, None).expect("simulation").y;
            ChannelRecord {
                input: w.clone(),
                output: y,
            }
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("qmarkov_identify");
    group.sample_size(10);
    for (ni, no) in [(1usize, 1usize), (2, 2)] {
        let recs = records(ni, no);
        let opts = QMarkovOptions {
            q: 60,
            order: Some(2),
            hold: HOLD,
            prbs_order: ORDER,
            record: RecordMode::LastPeriod,
            ..Default::default()
        };
        group.bench_with_input(
            BenchmarkId::new("m4095_nr10_q60", format!("{no}x{ni}")),
            &recs,
            |bch, recs| bch.iter(|| identify_records(recs, 0.01, &opts).expect("identification")),
        );
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

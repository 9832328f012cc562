//! Criterion bench of the Kalman-gain check (`check_kalman_gain_memo`),
//! the largest cost of a studio slider move (issue 47): the 2×2 peer
//! system at 1e5 samples, the model identified at order 4 (N4SID, horizon
//! 10, shift estimator, D estimated), its VARX innovations kept in the
//! memo as the studio keeps them (so the bench times the three starts'
//! predictor runs and the Levenberg–Marquardt over K, what a new order
//! costs), and once without the memo (what the first identification of a
//! record costs). The report's iterations are printed once.
//!
//! `cargo bench -p lifted-benches --bench gain_check --profile release`

use criterion::{Criterion, criterion_group, criterion_main};
use lifted_benches::peer_data;
use lifted_subspace::{
    Experiment, GainCheckOptions, OrderSelection, SubspaceOptions, VarxMemo,
    check_kalman_gain_memo, identify,
};
use nalgebra::DMatrix;

/// `m` with each column centred by its mean (the records' deviations
/// from the operating point, as the workflow checks them).
fn centred(m: &DMatrix<f64>) -> DMatrix<f64> {
    let mut c = m.clone();
    for mut col in c.column_iter_mut() {
        let mean = col.mean();
        col.add_scalar_mut(-mean);
    }
    c
}

fn bench_gain_check(c: &mut Criterion) {
    let (u, y) = peer_data(100_000, 0.1, 7);
    let opts = SubspaceOptions {
        order: OrderSelection::Fixed(4),
        past: 10,
        future: 10,
        ..Default::default()
    };
    let (ud, yd) = (centred(&u), centred(&y));
    let records = [Experiment { u: &ud, y: &yd }];
    let fit = identify(&records, &opts).expect("identification of the peer record");
    let riccati = fit.kalman_gain.as_ref();
    let check = |memo: &mut VarxMemo| {
        check_kalman_gain_memo(
            &fit.model,
            riccati,
            &records,
            opts.past,
            &GainCheckOptions::default(),
            memo,
        )
    };
    let mut memo = VarxMemo::default();
    let (_, report) = check(&mut memo);
    println!(
        "gain check at 1e5 samples, 2×2, order 4: {} ({} iterations)",
        report.used, report.iterations
    );
    let mut group = c.benchmark_group("gain_check_1e5_2x2_order4");
    group.sample_size(10);
    group.bench_function("varx_kept", |b| b.iter(|| check(&mut memo)));
    group.bench_function("varx_computed", |b| {
        b.iter(|| check(&mut VarxMemo::default()))
    });
    group.finish();
}

criterion_group!(benches, bench_gain_check);
criterion_main!(benches);

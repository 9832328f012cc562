//! `lifted studio`: one slider move = one `Session::identify` (read the
//! record, identify, validate, draw every figure as SVG) on a 1e5-sample
//! record of the 2×2 peer system (order 4, N4SID, horizon 10), at orders 3
//! and 4 as the slider moves; and the record upload (every cell checked).
//! Issue 17 asks for an update within 200 ms at 1e5 samples.
//!
//! Run: `cargo bench -p lifted-benches --bench studio`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, SamplingMode, criterion_group, criterion_main};
use lifted_benches::peer_data;
use lifted_cli::studio::{Request, Session};

fn csv(n: usize) -> String {
    let (u, y) = peer_data(n, 0.1, 7);
    let mut s = String::from("t,u1,u2,y1,y2\n");
    for k in 0..n {
        s += &format!(
            "{k},{},{},{},{}\n",
            u[(k, 0)],
            u[(k, 1)],
            y[(k, 0)],
            y[(k, 1)]
        );
    }
    s
}

fn studio(c: &mut Criterion) {
    let n = 100_000;
    let text = csv(n);
    let dir = std::env::temp_dir();
    let mut session = Session::new(&dir).expect("scratch directory");
    let mut group = c.benchmark_group("studio_1e5_2x2");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .measurement_time(Duration::from_secs(10));
    group.bench_function("upload", |b| {
        b.iter(|| black_box(session.upload("peer.csv", text.as_bytes()).expect("upload")))
    });
    for order in [3usize, 4] {
        let r = Request {
            inputs: vec!["u1".into(), "u2".into()],
            outputs: vec!["y1".into(), "y2".into()],
            method: Some("n4sid".into()),
            order: Some(order.to_string()),
            ..Default::default()
        };
        group.bench_with_input(BenchmarkId::new("identify_n4sid", order), &r, |b, r| {
            b.iter(|| black_box(session.identify(r).expect("identify")))
        });
    }
    group.finish();
    session.close();
}

criterion_group!(benches, studio);
criterion_main!(benches);

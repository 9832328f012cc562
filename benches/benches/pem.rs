//! Criterion bench of the prediction-error refinement (`refine_pem`) on
//! the two cases of issue 27: a 3-input 2-output plant of order 6 with
//! N = 2e4 samples, and a 2×2 plant of order 4 with N = 1e6. Each case
//! runs the default method (variable projection in predictor
//! coordinates, warm start on long records) and the joint
//! Levenberg–Marquardt of before (`PemMethod::Joint`), both with the
//! default options (prediction cost, work bound 2e10) and D = 0, from the
//! same start: the plant with A shrunk and B grown by 3 %. The final costs
//! are printed once per case so that the runs can be compared.
//!
//! `cargo bench -p lifted-benches --bench pem`

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use lifted_lti::StateSpace;
use lifted_pem::{PemMethod, PemOptions, refine_pem};
use lifted_subspace::{Feedthrough, Record};
use nalgebra::DMatrix;

/// The plant and record of [`lifted_benches::pem_case`] and a start near
/// the plant (A × 0.97, B × 1.03).
fn case(n: usize, nu: usize, ny: usize, len: usize) -> (StateSpace, DMatrix<f64>, DMatrix<f64>) {
    let (g, u, y) = lifted_benches::pem_case(n, nu, ny, len).expect("bench plant");
    let start = StateSpace::new(
        g.a() * 0.97,
        g.b() * 1.03,
        g.c().clone(),
        g.d().clone(),
        Some(1.0),
    )
    .expect("valid model");
    (start, u, y)
}

fn bench_pem(c: &mut Criterion) {
    let mut group = c.benchmark_group("refine_pem");
    group.sample_size(10);
    for &(n, nu, ny, len) in &[(6usize, 3usize, 2usize, 20_000usize), (4, 2, 2, 1_000_000)] {
        let (start, u, y) = case(n, nu, ny, len);
        let rec = [Record {
            u: &u,
            y: &y,
            instrument: None,
        }];
        for (name, method) in [
            ("variable_projection", PemMethod::VariableProjection),
            ("joint", PemMethod::Joint),
        ] {
            let opts = PemOptions {
                feedthrough: Feedthrough::Zero,
                method,
                ..Default::default()
            };
            let r = refine_pem(&start, None, &rec, &[], &opts)
                .expect("refine")
                .report;
            println!(
                "{name} {nu}x{ny} order {n} N = {len}: {} iterations ({} accepted), cost {:.6e} → {:.9e}, {:?}, work cap {:?}",
                r.iterations,
                r.accepted,
                r.initial_cost,
                r.final_cost,
                r.termination,
                r.iteration_cap
            );
            group.bench_with_input(
                BenchmarkId::new(format!("{name}/{nu}x{ny}_order{n}"), len),
                &len,
                |b, _| b.iter(|| refine_pem(&start, None, &rec, &[], &opts).expect("refine")),
            );
        }
    }
    group.finish();
}

criterion_group!(benches, bench_pem);
criterion_main!(benches);

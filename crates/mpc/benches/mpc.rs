//! Controller update time for a 2x2 model, horizon 20: unconstrained
//! (closed-form gain) and constrained (clarabel QP with active limits).
//!
//! Run: `cargo bench -p lifted-mpc --bench mpc`.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use lifted_lti::StateSpace;
use lifted_mpc::{Constraints, MpcOptions, Predictive, StateSpaceMpc};
use nalgebra::{DMatrix, DVector, dmatrix, dvector};

/// The A3.7 stirred-tank fast model (2x2, four first-order channels).
fn tank() -> StateSpace {
    let a = DMatrix::from_diagonal(&dvector![0.9868, 0.97, 0.9131, 0.9048]);
    let b = dmatrix![1.0, 0.0; 0.0, 1.0; 1.0, 0.0; 0.0, 1.0];
    let c = dmatrix![0.1416, -0.03, 0.0, 0.0; 0.0, 0.0, -0.0379, 0.0595];
    match StateSpace::new(a, b, c, DMatrix::zeros(2, 2), Some(1.0)) {
        Ok(s) => s,
        Err(e) => panic!("bench model: {e}"),
    }
}

fn bench(c: &mut Criterion) {
    let plant = tank();
    let mut group = c.benchmark_group("mpc_update_2x2_h20");
    for (name, constraints) in [
        ("unconstrained", Constraints::default()),
        (
            "constrained",
            Constraints {
                u_min: Some(dvector![-0.3, -0.3]),
                u_max: Some(dvector![0.3, 0.3]),
                du_max: Some(dvector![0.05, 0.05]),
                ..Constraints::default()
            },
        ),
    ] {
        let opts = MpcOptions {
            prediction_horizon: 20,
            control_horizon: 5,
            constraints,
            ..MpcOptions::default()
        };
        let base = match StateSpaceMpc::new(&plant, &opts) {
            Ok(m) => m,
            Err(e) => panic!("bench controller: {e}"),
        };
        let r = dvector![1.0, -0.5];
        let y = [Some(0.0), Some(0.0)];
        group.bench_function(BenchmarkId::new(name, 20), |bch| {
            bch.iter_batched(
                || base.clone(),
                |mut ctrl| {
                    let out = ctrl.update_with_plan(black_box(&y), black_box(&r));
                    black_box(out.map(|(u, _)| u).unwrap_or_else(|_| DVector::zeros(2)))
                },
                criterion::BatchSize::SmallInput,
            )
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

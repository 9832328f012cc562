//! The cost of `--refine pem` against the subspace step, one timed run per
//! case (issue 27: the data for a "refine by default when it pays" rule).
//! For each size (n_u × n_y, order n) and record length N: a stable plant
//! (poles 0.95, 0.9, 0.8, 0.6, −0.4, 0.3 with 0.1 couplings, seeded B and
//! C), a binary input and white output noise (uniform, width 0.1, seeded);
//! N4SID at order n (default options), then `refine_pem` from its model and
//! Kalman gain (default options, prediction cost, D = 0). Prints the wall
//! times, the subspace step's `compression_flops`, `pem_work_estimate`'s
//! prediction and the refinement's report.
//!
//! `cargo run --release -p lifted-benches --example pem_cost [N ...]`

use std::time::Instant;

use lifted_lti::StateSpace;
use lifted_subspace::{
    Experiment, Feedthrough, OrderSelection, PemOptions, Record, SubspaceOptions, identify,
    pem_work_estimate, refine_pem,
};
use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn data(n: usize, nu: usize, ny: usize, len: usize) -> (DMatrix<f64>, DMatrix<f64>) {
    let poles = [0.95, 0.9, 0.8, 0.6, -0.4, 0.3];
    let mut rng = ChaCha8Rng::seed_from_u64(27);
    let mut a = DMatrix::from_diagonal(&DVector::from_fn(n, |i, _| poles[i]));
    for i in 0..n - 1 {
        a[(i, i + 1)] = 0.1;
    }
    let b = DMatrix::from_fn(n, nu, |_, _| rng.random::<f64>() - 0.5);
    let c = DMatrix::from_fn(ny, n, |_, _| rng.random::<f64>() - 0.5);
    let g = StateSpace::new(a, b, c, DMatrix::zeros(ny, nu), Some(1.0)).expect("valid model");
    let u = DMatrix::from_fn(
        len,
        nu,
        |_, _| if rng.random::<bool>() { 1.0 } else { -1.0 },
    );
    let mut y = g.lsim(&u, None, None).expect("simulation").y;
    y.iter_mut()
        .for_each(|v| *v += 0.1 * (rng.random::<f64>() - 0.5));
    (u, y)
}

fn main() {
    let lens: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse::<f64>().ok().map(|v| v as usize))
        .collect();
    let lens = if lens.is_empty() {
        vec![10_000, 100_000, 1_000_000]
    } else {
        lens
    };
    println!(
        "| n_u×n_y | order | N | subspace s | PEM s | PEM/subspace | compression flops | PEM estimate (typical) | iterations | termination |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for &(nu, ny, n) in &[(1usize, 1usize, 2usize), (2, 2, 4), (3, 2, 6)] {
        for &len in &lens {
            let (u, y) = data(n, nu, ny, len);
            let sopts = SubspaceOptions {
                order: OrderSelection::Fixed(n),
                ..Default::default()
            };
            let t = Instant::now();
            let id = identify(&[Experiment { u: &u, y: &y }], &sopts).expect("identify");
            let t_sub = t.elapsed().as_secs_f64();
            let rec = [Record {
                u: &u,
                y: &y,
                instrument: None,
            }];
            let popts = PemOptions {
                feedthrough: Feedthrough::Zero,
                ..Default::default()
            };
            let est = pem_work_estimate(&id.model, &rec, &popts).expect("estimate");
            let t = Instant::now();
            let fit =
                refine_pem(&id.model, id.kalman_gain.as_ref(), &rec, &[], &popts).expect("refine");
            let t_pem = t.elapsed().as_secs_f64();
            println!(
                "| {nu}×{ny} | {n} | {len:.0e} | {t_sub:.3} | {t_pem:.3} | {:.0} | {:.2e} | {:.2e} | {} | {:?}{} |",
                t_pem / t_sub,
                id.diagnostics.compression_flops,
                est.typical,
                fit.report.iterations,
                fit.report.termination,
                fit.report
                    .iteration_cap
                    .map_or(String::new(), |c| format!(" (work cap {c})")),
            );
        }
    }
}

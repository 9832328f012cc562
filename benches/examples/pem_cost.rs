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

use lifted_pem::{PemOptions, pem_work_estimate, refine_pem};
use lifted_subspace::{Experiment, Feedthrough, OrderSelection, Record, SubspaceOptions, identify};

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
            let (_, u, y) = lifted_benches::pem_case(n, nu, ny, len).expect("bench plant");
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

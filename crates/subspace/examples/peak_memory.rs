//! Peak resident memory of one identification, for the README table:
//! `cargo run --release -p lifted-subspace --example peak_memory -- 1000000 2`
//! (samples, inputs = outputs). The data are generated in place (u, y:
//! N×(n_u+n_y) doubles); the identification itself keeps O(k²) memory for
//! k = (p+f)(n_u+n_y) Hankel rows, so VmHWM minus the data size stays flat.

use lifted_lti::StateSpace;
use lifted_subspace::{Experiment, OrderSelection, SubspaceOptions, identify};
use nalgebra::DMatrix;

fn vm(key: &str) -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines().find(|l| l.starts_with(key)).and_then(|l| {
                l.split_whitespace()
                    .nth(1)
                    .and_then(|v| v.parse::<f64>().ok())
            })
        })
        .unwrap_or(f64::NAN)
        / 1024.0
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).map_or(Ok(100_000), |s| s.parse())?;
    let m: usize = args.get(2).map_or(Ok(1), |s| s.parse())?;
    let a = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![0.95, 0.8, 0.6, -0.4]));
    let b = DMatrix::from_fn(4, m, |i, j| 1.0 / (1.0 + i as f64 + j as f64));
    let c = DMatrix::from_fn(m, 4, |i, j| if (i + j) % 2 == 0 { 1.0 } else { 0.5 });
    let g = StateSpace::new(a, b, c, DMatrix::zeros(m, m), Some(1.0))?;
    let mut state = 12345u64;
    let u = DMatrix::from_fn(n, m, |_, _| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        if state >> 63 == 1 { 1.0 } else { -1.0 }
    });
    let y = g.lsim(&u, None, None)?.y;
    let before = vm("VmHWM:");
    let opts = SubspaceOptions {
        order: OrderSelection::Fixed(4),
        past: 20,
        future: 20,
        noise_model: false,
        ..Default::default()
    };
    let fit = identify(&[Experiment { u: &u, y: &y }], &opts)?;
    let after = vm("VmHWM:");
    println!(
        "N = {n}, {m}x{m}: data {:.1} MiB, VmHWM before identify {before:.1} MiB, after {after:.1} MiB, growth {:.1} MiB (order {})",
        (n * 2 * m * 8) as f64 / 1048576.0,
        after - before,
        fit.diagnostics.order
    );
    Ok(())
}

//! The lifted side of the simulation-throughput peer comparison
//! (benches/peers/sim_run.sh, benches/peers/sim_peers.py).
//!
//! The case is the criterion bench `crates/sim/benches/sim.rs`: a 6-state
//! 2×2 discrete plant (T = 1) in a decentralised PI loop,
//! K₁(z) = (0.6z − 0.5)/(z − 1) on (u₁, y₁) and K₂(z) = (0.4z − 0.3)/(z − 1)
//! on (u₂, y₂), output noise v_j = 0.1/(1 − 0.9z⁻¹) e_j with absolute std 1
//! of e and seed 1, and r₁ = r₂ = r with r_j(k) = 1 if ⌊k/7⌋ + j ≡ 0 (mod 3),
//! else −1 (u = r₂ + K(r₁ − y), y = Gu + v).
//!
//! ```text
//! peer_sim N [N ...] [--reps 7] [--csv DIR]
//! ```
//!
//! For each N it times, on the same excitation (built outside the timing),
//! `Simulator::simulate` and `Simulator::simulate_into` (buffers reused
//! across the repetitions), for the noisy loop and for the same loop without
//! noise: one untimed warm-up run, then `--reps` timed runs (wall clock).
//! It prints one JSON object with, per N, variant and method, the sorted
//! times, the best and median and the simulated samples per second.
//!
//! `--csv DIR` also writes `DIR/sim_N.csv` for each N with the columns
//! `y1,y2,u1,u2` of the noise-free loop, `v1,v2` (the noise added at the
//! output in the noisy loop) and `yn1,yn2,un1,un2` (the noisy loop's
//! measured output and plant input), so that the peers can be checked
//! against lifted before their times count.

use std::error::Error;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::time::Instant;

use lifted_lti::{StateSpace, TransferFunction};
use lifted_sim::{Controller, Excitation, NoiseLevel, NoiseSpec, Plant, SimSignals, Simulator};
use nalgebra::DMatrix;

/// The bench's plant: A lower bidiagonal with diagonal 0.95 − 0.05i and
/// sub-diagonal 0.1, B = 0.1 where i ≡ j (mod 2) else 0.02, C = 1 where
/// j ≡ i (mod 2) else 0.3, D = 0, discrete at T = 1.
fn plant() -> Result<Plant, Box<dyn Error>> {
    let a = DMatrix::from_fn(6, 6, |i, j| match (i, j) {
        (i, j) if i == j => 0.95 - 0.05 * i as f64,
        (i, j) if i == j + 1 => 0.1,
        _ => 0.0,
    });
    let b = DMatrix::from_fn(6, 2, |i, j| if i % 2 == j { 0.1 } else { 0.02 });
    let c = DMatrix::from_fn(2, 6, |i, j| if j % 2 == i { 1.0 } else { 0.3 });
    let g = StateSpace::new(a, b, c, DMatrix::zeros(2, 2), Some(1.0))?;
    Ok(Plant::discrete(&g, &[], &[])?)
}

/// The loop of the bench, with the noise filters at absolute std 1 (seed 1)
/// when `noisy`.
fn simulator(noisy: bool) -> Result<Simulator, Box<dyn Error>> {
    let pi = Controller::decentralized(
        2,
        2,
        1.0,
        &[
            (0, 0, &[0.6, -0.5], &[1.0, -1.0]),
            (1, 1, &[0.4, -0.3], &[1.0, -1.0]),
        ],
    )?;
    let sim = Simulator::closed_loop(plant()?, pi)?;
    if !noisy {
        return Ok(sim);
    }
    let filter = TransferFunction::from_coeffs(&[0.1, 0.0], &[1.0, -0.9], Some(1.0))?;
    let h = NoiseSpec::diagonal_model(&[filter.clone(), filter])?;
    Ok(sim.with_noise(NoiseSpec {
        model: Some(h),
        level: NoiseLevel::Std(vec![1.0]),
        seed: 1,
        ..Default::default()
    })?)
}

/// r₁ = r₂ of the bench, N × 2.
fn excitation(n: usize) -> Excitation {
    let r = DMatrix::from_fn(n, 2, |k, j| if (k / 7 + j) % 3 == 0 { 1.0 } else { -1.0 });
    Excitation::both(r.clone(), r)
}

/// Best and median of `times` (seconds), sorted in place.
fn best_median(times: &mut [f64]) -> (f64, f64) {
    times.sort_by(f64::total_cmp);
    let m = times.len();
    let median = if m % 2 == 1 {
        times[m / 2]
    } else {
        0.5 * (times[m / 2 - 1] + times[m / 2])
    };
    (times[0], median)
}

/// Times `reps` runs of `run` after one warm-up run.
fn time_runs(
    reps: usize,
    mut run: impl FnMut() -> Result<(), Box<dyn Error>>,
) -> Result<Vec<f64>, Box<dyn Error>> {
    run()?;
    let mut t = Vec::with_capacity(reps);
    for _ in 0..reps {
        let t0 = Instant::now();
        run()?;
        t.push(t0.elapsed().as_secs_f64());
    }
    Ok(t)
}

fn write_csv(path: &str, clean: &SimSignals, noisy: &SimSignals) -> Result<(), Box<dyn Error>> {
    let mut w = BufWriter::new(File::create(path)?);
    writeln!(w, "y1,y2,u1,u2,v1,v2,yn1,yn2,un1,un2")?;
    for k in 0..clean.y.nrows() {
        writeln!(
            w,
            "{},{},{},{},{},{},{},{},{},{}",
            clean.y[(k, 0)],
            clean.y[(k, 1)],
            clean.u[(k, 0)],
            clean.u[(k, 1)],
            noisy.noise[(k, 0)],
            noisy.noise[(k, 1)],
            noisy.y[(k, 0)],
            noisy.y[(k, 1)],
            noisy.u[(k, 0)],
            noisy.u[(k, 1)],
        )?;
    }
    w.flush()?;
    Ok(())
}

fn main() -> Result<(), Box<dyn Error>> {
    let mut sizes = Vec::new();
    let mut reps = 7usize;
    let mut csv_dir: Option<String> = None;
    let mut it = std::env::args().skip(1);
    while let Some(x) = it.next() {
        match x.as_str() {
            "--reps" => reps = it.next().ok_or("--reps needs a value")?.parse()?,
            "--csv" => csv_dir = Some(it.next().ok_or("--csv needs a directory")?),
            s if !s.starts_with("--") => sizes.push(s.parse::<f64>()? as usize),
            s => return Err(format!("unknown argument {s}").into()),
        }
    }
    if sizes.is_empty() || reps == 0 || sizes.contains(&0) {
        return Err("usage: peer_sim N [N ...] [--reps 7] [--csv DIR] (N ≥ 1, reps ≥ 1)".into());
    }
    let noisy = simulator(true)?;
    let clean = simulator(false)?;
    let mut results = Vec::new();
    for &n in &sizes {
        let exc = excitation(n);
        let mut sig_noisy = SimSignals::default();
        let mut sig_clean = SimSignals::default();
        for (noise, sim, sig) in [
            (true, &noisy, &mut sig_noisy),
            (false, &clean, &mut sig_clean),
        ] {
            let mut t_sim = time_runs(reps, || {
                std::hint::black_box(sim.simulate(&exc)?);
                Ok(())
            })?;
            let mut t_into = time_runs(reps, || {
                sim.simulate_into(&exc, sig)?;
                std::hint::black_box(&*sig);
                Ok(())
            })?;
            for (method, times) in [("simulate", &mut t_sim), ("simulate_into", &mut t_into)] {
                let (best, median) = best_median(times);
                results.push(serde_json::json!({
                    "n": n,
                    "noise": noise,
                    "method": method,
                    "reps": reps,
                    "best_s": best,
                    "median_s": median,
                    "samples_per_s_best": n as f64 / best,
                    "samples_per_s_median": n as f64 / median,
                    "times_s": &*times,
                }));
            }
        }
        if let Some(dir) = &csv_dir {
            write_csv(&format!("{dir}/sim_{n}.csv"), &sig_clean, &sig_noisy)?;
        }
    }
    let out = serde_json::json!({
        "case": "closed_loop_6state_2x2_noise (crates/sim/benches/sim.rs)",
        "clock": "wall",
        "results": results,
    });
    println!("{out}");
    Ok(())
}

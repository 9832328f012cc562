//! The lifted side of the peer comparison (benches/peers/run.sh): reads a CSV
//! with columns u1,u2,…,y1,y2,… (header line; `--inputs` gives the number of
//! input columns, default 2), identifies a state-space model with
//! lifted-subspace and prints one JSON line with the timings per phase and
//! (A, B, C, D).
//!
//! ```text
//! peer_lifted data.csv [--inputs 2] [--order 4] [--horizon 20]
//!             [--method n4sid|moesp|cva] [--compression auto|correlation|qr]
//!             [--threads 1] [--stream] [--block 65536] [--no-noise-model]
//!             [--repeat 1]
//! peer_lifted --synthetic N [--threads 1] [--block 65536]
//! ```
//!
//! `--synthetic N` reads no file: it simulates N samples of
//! [`lifted_benches::peer_system`] (random binary inputs, output noise 0.1)
//! block by block and streams them, so that peak memory shows what the
//! identification itself needs at any N (the 1e7 streaming target).
//!
//! `--repeat K` (with `--stream`) parses the blocks once, keeps them, and
//! runs the streamed identification K times on them, printing the fastest
//! run's timings (for profilers and small-N timing; the blocks stay in
//! memory then).
//!
//! `--no-noise-model` skips the noise covariances and the Kalman gain
//! (`SubspaceOptions::noise_model = false`), the work SLICOT's driver
//! skips with JOBCK = 'N'.
//!
//! Like the `lifted` command, it starts `lifted_linalg::warm_up` before
//! anything else.
//!
//! `--stream` feeds the file to [`StreamingIdentifier`] in blocks of
//! `--block` rows while it is parsed (memory independent of N); without it
//! the whole file is parsed into matrices first and [`identify`] runs on
//! them. `identify_s` excludes CSV parsing in both modes.

use std::error::Error;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::time::Instant;

use lifted_subspace::{
    Compression, Experiment, InitialState, Method, OrderSelection, StreamingIdentifier,
    SubspaceModel, SubspaceOptions, identify,
};
use nalgebra::DMatrix;

struct Args {
    path: String,
    inputs: usize,
    order: usize,
    horizon: usize,
    method: Method,
    compression: Compression,
    threads: usize,
    stream: bool,
    block: usize,
    synthetic: Option<usize>,
    no_noise_model: bool,
    repeat: usize,
}

fn parse_args() -> Result<Args, Box<dyn Error>> {
    let mut it = std::env::args().skip(1);
    let mut a = Args {
        path: String::new(),
        inputs: 2,
        order: 4,
        horizon: 20,
        method: Method::N4sid,
        compression: Compression::Auto,
        threads: 1,
        stream: false,
        block: 1 << 16,
        synthetic: None,
        no_noise_model: false,
        repeat: 1,
    };
    while let Some(x) = it.next() {
        let mut val = || it.next().ok_or(format!("{x} needs a value"));
        match x.as_str() {
            "--inputs" => a.inputs = val()?.parse()?,
            "--order" => a.order = val()?.parse()?,
            "--horizon" => a.horizon = val()?.parse()?,
            "--threads" => a.threads = val()?.parse()?,
            "--block" => a.block = val()?.parse()?,
            "--repeat" => a.repeat = val()?.parse::<usize>()?.max(1),
            "--stream" => a.stream = true,
            "--no-noise-model" => a.no_noise_model = true,
            "--synthetic" => a.synthetic = Some(val()?.parse()?),
            "--method" => {
                a.method = match val()?.as_str() {
                    "n4sid" => Method::N4sid,
                    "moesp" => Method::Moesp,
                    "cva" => Method::Cva,
                    m => return Err(format!("unknown method {m}").into()),
                }
            }
            "--compression" => {
                a.compression = match val()?.as_str() {
                    "auto" => Compression::Auto,
                    "correlation" => Compression::Correlation,
                    "qr" => Compression::Qr,
                    m => return Err(format!("unknown compression {m}").into()),
                }
            }
            p if !p.starts_with("--") && a.path.is_empty() => a.path = p.to_string(),
            p => return Err(format!("unknown argument {p}").into()),
        }
    }
    if a.synthetic.is_some() {
        a.stream = true;
    }
    if a.path.is_empty() && a.synthetic.is_none() {
        return Err("usage: peer_lifted data.csv [options]".into());
    }
    Ok(a)
}

/// Parses up to `max` data rows into `rows` (row-major); false at end of file.
fn read_rows(
    lines: &mut impl Iterator<Item = std::io::Result<String>>,
    ncols: usize,
    max: usize,
    rows: &mut Vec<f64>,
) -> Result<bool, Box<dyn Error>> {
    rows.clear();
    for _ in 0..max {
        let Some(line) = lines.next() else {
            return Ok(false);
        };
        let line = line?;
        let before = rows.len();
        for f in line.split(',') {
            rows.push(f.trim().parse::<f64>()?);
        }
        if rows.len() - before != ncols {
            return Err(format!("expected {ncols} columns in line {line:?}").into());
        }
    }
    Ok(true)
}

fn split(rows: &[f64], ncols: usize, nu: usize) -> (DMatrix<f64>, DMatrix<f64>) {
    let n = rows.len() / ncols;
    let u = DMatrix::from_fn(n, nu, |i, j| rows[i * ncols + j]);
    let y = DMatrix::from_fn(n, ncols - nu, |i, j| rows[i * ncols + nu + j]);
    (u, y)
}

/// Streams `n` simulated samples of the peer system in blocks.
fn synthetic(
    n: usize,
    a: &Args,
    opts: &SubspaceOptions,
) -> Result<(SubspaceModel, f64, f64), Box<dyn Error>> {
    use rand::{RngExt, SeedableRng};
    let g = lifted_benches::peer_system();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let mut x = nalgebra::DVector::zeros(g.order());
    let mut id = StreamingIdentifier::new(2, 2, opts)?;
    let (mut gen_s, mut push_s) = (0.0, 0.0);
    let mut s = 0;
    while s < n {
        let t = Instant::now();
        let len = a.block.min(n - s);
        let u = DMatrix::from_fn(len, 2, |_, _| if rng.random::<bool>() { 1.0 } else { -1.0 });
        let sim = g.lsim(&u, Some(&x), None)?;
        let last = sim.x.row(len - 1).transpose();
        x = g.a() * last + g.b() * u.row(len - 1).transpose();
        let mut y = sim.y;
        for v in y.iter_mut() {
            let (p, q): (f64, f64) = (rng.random(), rng.random());
            *v += 0.1 * (-2.0 * (1.0 - p).ln()).sqrt() * (std::f64::consts::TAU * q).cos();
        }
        gen_s += t.elapsed().as_secs_f64();
        let t = Instant::now();
        id.push(&u, &y)?;
        push_s += t.elapsed().as_secs_f64();
        s += len;
    }
    Ok((id.finish()?, gen_s, push_s))
}

/// The identification options of the command line; x₀ is estimated only
/// in memory (a stream keeps no records).
fn options(a: &Args) -> SubspaceOptions {
    SubspaceOptions {
        method: a.method,
        order: OrderSelection::Fixed(a.order),
        past: a.horizon,
        future: a.horizon,
        compression: a.compression,
        threads: a.threads,
        initial_state: if a.stream {
            InitialState::Zero
        } else {
            InitialState::Estimate
        },
        noise_model: !a.no_noise_model,
        ..Default::default()
    }
}

fn main() -> Result<(), Box<dyn Error>> {
    // As the `lifted` command does first thing: faer's one-time set-up on
    // a background thread while the arguments and the file are read (see
    // lifted_linalg::warm_up; identify and StreamingIdentifier::new call it
    // too, but later), and the allocator's thresholds as the command sets
    // them (lifted_linalg::malloc).
    lifted_linalg::malloc::tune_malloc();
    lifted_linalg::warm_up();
    let a = parse_args()?;
    let t_start = Instant::now();
    if let Some(n) = a.synthetic {
        let (fit, gen_s, push_s) = synthetic(n, &a, &options(&a))?;
        let p = &fit.diagnostics.profile;
        let poles: Vec<(f64, f64)> = fit.model.poles()?.iter().map(|z| (z.re, z.im)).collect();
        let out = serde_json::json!({
            "samples": n,
            "generate_s": gen_s,
            "identify_s": push_s + p.compress_s + p.svd_s + p.estimate_s,
            "compress_s": push_s + p.compress_s,
            "svd_s": p.svd_s,
            "estimate_s": p.estimate_s,
            "compression": format!("{:?}", fit.diagnostics.compression.used),
            "poles": poles,
        });
        println!("{out}");
        return Ok(());
    }
    let mut lines = BufReader::with_capacity(1 << 20, File::open(&a.path)?).lines();
    let header = lines.next().ok_or("empty file")??;
    let ncols = header.split(',').count();
    if ncols <= a.inputs {
        return Err(format!("{ncols} columns but {} inputs", a.inputs).into());
    }
    let opts = options(&a);
    let mut read_s = 0.0;
    let mut samples = 0;
    let fit: SubspaceModel = if a.stream && a.repeat > 1 {
        // Profiling: the blocks parsed once and kept, the streamed
        // identification run `repeat` times on them, the fastest kept.
        let mut blocks = Vec::new();
        let mut rows = Vec::new();
        let t = Instant::now();
        loop {
            let more = read_rows(&mut lines, ncols, a.block, &mut rows)?;
            let (u, y) = split(&rows, ncols, a.inputs);
            samples += u.nrows();
            blocks.push((u, y));
            if !more {
                break;
            }
        }
        read_s = t.elapsed().as_secs_f64();
        let mut best: Option<(f64, SubspaceModel)> = None;
        for _ in 0..a.repeat {
            let t = Instant::now();
            let mut id = StreamingIdentifier::new(a.inputs, ncols - a.inputs, &opts)?;
            for (u, y) in &blocks {
                id.push(u, y)?;
            }
            let push_s = t.elapsed().as_secs_f64();
            let mut fit = id.finish()?;
            fit.diagnostics.profile.compress_s += push_s;
            let p = &fit.diagnostics.profile;
            let total = p.compress_s + p.svd_s + p.estimate_s;
            if best.as_ref().is_none_or(|(b, _)| total < *b) {
                best = Some((total, fit));
            }
        }
        best.ok_or("no run")?.1
    } else if a.stream {
        let mut id = StreamingIdentifier::new(a.inputs, ncols - a.inputs, &opts)?;
        let mut rows = Vec::new();
        let mut push_s = 0.0;
        loop {
            let t = Instant::now();
            let more = read_rows(&mut lines, ncols, a.block, &mut rows)?;
            let (u, y) = split(&rows, ncols, a.inputs);
            read_s += t.elapsed().as_secs_f64();
            let t = Instant::now();
            samples += u.nrows();
            id.push(&u, &y)?;
            push_s += t.elapsed().as_secs_f64();
            if !more {
                break;
            }
        }
        let mut fit = id.finish()?;
        // The compression ran inside the pushes.
        fit.diagnostics.profile.compress_s += push_s;
        fit
    } else {
        let t = Instant::now();
        let mut rows = Vec::new();
        read_rows(&mut lines, ncols, usize::MAX, &mut rows)?;
        let (u, y) = split(&rows, ncols, a.inputs);
        drop(rows);
        samples = u.nrows();
        read_s = t.elapsed().as_secs_f64();
        identify(&[Experiment { u: &u, y: &y }], &opts)?
    };
    let p = &fit.diagnostics.profile;
    let m = &fit.model;
    let rows_of = |x: &DMatrix<f64>| -> Vec<Vec<f64>> {
        (0..x.nrows())
            .map(|i| x.row(i).iter().cloned().collect())
            .collect()
    };
    let out = serde_json::json!({
        "samples": samples,
        "read_s": read_s,
        "identify_s": p.compress_s + p.svd_s + p.estimate_s,
        "compress_s": p.compress_s,
        "svd_s": p.svd_s,
        "estimate_s": p.estimate_s,
        "total_s": t_start.elapsed().as_secs_f64(),
        "compression": format!("{:?}", fit.diagnostics.compression.used),
        "fallback": fit.diagnostics.compression.fallback,
        "a": rows_of(m.a()),
        "b": rows_of(m.b()),
        "c": rows_of(m.c()),
        "d": rows_of(m.d()),
    });
    println!("{out}");
    Ok(())
}

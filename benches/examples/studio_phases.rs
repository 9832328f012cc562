//! Where a studio slider move to an order not seen goes (issue 47): the
//! workflow's own phases (`diagnostics.profile`) of `identify_cached` on the
//! 2×2 peer record at 1e5 samples (N4SID, horizon 10, shift estimator, no
//! refinement, as the studio asks), each order identified once on a
//! kept compression, then the studio's whole answer
//! (`Session::identify`, identification, validation and figures) for
//! orders not seen (overall and by order). Medians of `rounds` passes.
//!
//! `cargo run --release -p lifted-benches --example studio_phases -- [rounds] [csv]`
//! (`LIFTED_ORDERS=8,7`: visit these orders instead of 3, 5, 6, 7, 8, 2;
//! `LIFTED_HORIZON=5`: that horizon instead of 10)
//! (`csv`: where to write the record, for `lifted identify --profile`)
//! (`LIFTED_RECORD=path`: time this `t,u1,u2,y1,y2` CSV instead, such as
//! the browser bench's record kept by `LIFTED_BENCH_RECORD`).

use std::collections::BTreeMap;
use std::time::Instant;

use lifted_benches::peer_data;
use lifted_cli::studio::{Request, Session};
use lifted_lti::Dataset;
use lifted_workflow::{
    Estimator, Method, Order, Record, Refine, SubspaceCache, WorkflowOptions, identify_cached,
};
use nalgebra::DMatrix;

/// The process's CPU time so far (user + system, s; Linux `/proc`, 10 ms
/// ticks), or NaN elsewhere: on a shared machine the CPU time per move is
/// steadier than the wall time.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return f64::NAN;
    };
    // Fields after the command's closing parenthesis: utime and stime are
    // the 12th and 13th.
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<f64> = rest
        .split_whitespace()
        .skip(11)
        .take(2)
        .filter_map(|v| v.parse().ok())
        .collect();
    if f.len() == 2 {
        (f[0] + f[1]) / 100.0
    } else {
        f64::NAN
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

/// A `t,u1,u2,y1,y2` CSV with a header line: (u, y).
fn read_record(path: &str) -> Result<(DMatrix<f64>, DMatrix<f64>), Box<dyn std::error::Error>> {
    let text = std::fs::read_to_string(path)?;
    let mut rows = Vec::new();
    for line in text.lines().skip(1) {
        let v: Vec<f64> = line.split(',').map(str::parse).collect::<Result<_, _>>()?;
        if v.len() != 5 {
            return Err(format!("{path}: a row without 5 columns").into());
        }
        rows.push(v);
    }
    let u = DMatrix::from_fn(rows.len(), 2, |i, j| rows[i][1 + j]);
    let y = DMatrix::from_fn(rows.len(), 2, |i, j| rows[i][3 + j]);
    Ok((u, y))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let rounds: usize = std::env::args().nth(1).map_or(Ok(3), |s| s.parse())?;
    let (u, y) = match std::env::var("LIFTED_RECORD") {
        Ok(path) => read_record(&path)?,
        Err(_) => peer_data(100_000, 0.1, 7),
    };
    let n = u.nrows();
    let records = [Record::new(Dataset::single_rate(
        1.0,
        u.clone(),
        y.clone(),
    )?)];
    // The orders visited, in turn (`LIFTED_ORDERS=8,7` to look at some).
    let orders: Vec<usize> = match std::env::var("LIFTED_ORDERS") {
        Ok(list) => list
            .split(',')
            .map(|k| k.trim().parse())
            .collect::<Result<_, _>>()?,
        Err(_) => vec![3, 5, 6, 7, 8, 2],
    };
    // The horizon (`LIFTED_HORIZON`, default 10; the browser bench's page
    // asks for the automatic order's, 5 on its record).
    let horizon: usize = match std::env::var("LIFTED_HORIZON") {
        Ok(h) => h.parse()?,
        Err(_) => 10,
    };
    let opts = |order: usize| {
        let mut o = WorkflowOptions::default();
        o.identification.method = Method::N4sid;
        o.identification.order = Order::Fixed(order);
        o.identification.horizon = Some(horizon);
        o.identification.estimator = Estimator::Shift;
        o.refinement.refine = Refine::None;
        o
    };
    let mut phases: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let mut cpu = 0.0;
    for _ in 0..rounds {
        let mut cache = SubspaceCache::default();
        identify_cached(&records, &opts(4), &[], &mut cache)?;
        for &k in &orders {
            let t = Instant::now();
            let c0 = cpu_seconds();
            let id = identify_cached(&records, &opts(k), &[], &mut cache)?;
            cpu += cpu_seconds() - c0;
            phases
                .entry("workflow total".into())
                .or_default()
                .push(t.elapsed().as_secs_f64());
            if let Some(p) = id
                .file
                .diagnostics
                .get("profile")
                .and_then(|p| p.as_object())
            {
                for (key, v) in p {
                    if let Some(x) = v.as_f64() {
                        phases.entry(key.clone()).or_default().push(x);
                    }
                }
            }
        }
    }
    println!(
        "workflow phases, ms (median and least over {} moves):",
        rounds * orders.len()
    );
    for (k, v) in &mut phases {
        let least = v.iter().copied().fold(f64::INFINITY, f64::min);
        println!("  {k:<24} {:8.1} {:8.1}", 1e3 * median(v), 1e3 * least);
    }
    println!(
        "  CPU time per move (all threads) {:.1}",
        1e3 * cpu / (rounds * orders.len()) as f64
    );

    let mut text = String::from("t,u1,u2,y1,y2\n");
    for k in 0..n {
        text += &format!(
            "{k},{},{},{},{}\n",
            u[(k, 0)],
            u[(k, 1)],
            y[(k, 0)],
            y[(k, 1)]
        );
    }
    let mut session = Session::new(&std::env::temp_dir())?;
    session.upload("peer.csv", text.as_bytes())?;
    let request = |order: usize| Request {
        inputs: vec!["u1".into(), "u2".into()],
        outputs: vec!["y1".into(), "y2".into()],
        method: Some("n4sid".into()),
        order: Some(order.to_string()),
        horizon: Some(horizon),
        detrend: Some("mean".into()),
        ..Default::default()
    };
    let first = session.identify(&request(4))?;
    println!("command: {}", first.command);
    if let Some(path) = std::env::args().nth(2) {
        std::fs::write(path, &text)?;
    }
    let mut server = Vec::new();
    let mut by_order: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
    let c0 = cpu_seconds();
    for _ in 0..rounds {
        for &k in &orders {
            session.forget_identifications();
            let t = Instant::now();
            session.identify(&request(k))?;
            let took = t.elapsed().as_secs_f64();
            server.push(took);
            by_order.entry(k).or_default().push(took);
        }
    }
    let studio_cpu = (cpu_seconds() - c0) / server.len() as f64;
    let mut seen = Vec::new();
    for &k in &orders {
        session.identify(&request(k))?;
    }
    for &k in &orders {
        let t = Instant::now();
        session.identify(&request(k))?;
        seen.push(t.elapsed().as_secs_f64());
    }
    println!(
        "studio answer, ms: order not seen median {:.1} (min {:.1}, max {:.1}; {} moves; CPU {:.1} per move), seen median {:.1}",
        1e3 * median(&mut server.clone()),
        1e3 * server.iter().copied().fold(f64::INFINITY, f64::min),
        1e3 * server.iter().copied().fold(0.0, f64::max),
        server.len(),
        1e3 * studio_cpu,
        1e3 * median(&mut seen)
    );
    let per_order: Vec<String> = by_order
        .iter_mut()
        .map(|(k, v)| format!("{k}: {:.1}", 1e3 * median(v)))
        .collect();
    println!(
        "studio answer by order not seen, median ms: {}",
        per_order.join(", ")
    );
    session.close();
    Ok(())
}

//! The bodies of the cargo-fuzz targets, one function per target taking
//! the raw input bytes: the libFuzzer binaries of `fuzz_targets/` call
//! them, and the main workspace's test `crates/cli/tests/fuzz_corpus.rs`
//! includes this file to replay every committed corpus input and a seeded
//! mutation smoke through the same code inside the README's test command
//! (no separate instrumented build in CI; `fuzz/README.md`).
//!
//! A target whose input is a structured case decodes it as libfuzzer-sys's
//! typed `fuzz_target!` does (inputs shorter than the type's size hint are
//! skipped, then `arbitrary_take_rest`), so the committed corpora keep their
//! meaning.

use std::path::PathBuf;
use std::sync::OnceLock;

use arbitrary::{Arbitrary, Unstructured};
use clap::Parser;
use lifted_cli::args::{Cli, Command};
use lifted_cli::service::identify::run_identification;
use lifted_cli::table::{DataSpec, load};
use lifted_linalg::budget::MemoryBudget;
use lifted_lti::{Dataset, Identifier, InputChannel, ModelFile, OutputChannel};
use lifted_multirate::{MultirateLifting, Ordering, ProcedureOptions, identify_multirate};
use lifted_qmarkov::{QMarkov, QMarkovOptions};
use lifted_subspace::{
    Experiment, IvExperiment, IvOptions, Method, OrderSelection, SubspaceOptions, SystemEstimate,
    identify as subspace_identify, iv_identify,
};
use nalgebra::DMatrix;

/// A target's body: the raw input bytes in, a panic on a failed check.
pub type Body = fn(&[u8]);

/// The targets by name, as `fuzz/corpus/<name>` holds their inputs.
pub const TARGETS: [(&str, Body); 6] = [
    ("csv_table", csv_table),
    ("npy_table", npy_table),
    ("model_file", model_file),
    ("identify", identify),
    ("identify_options", identify_options),
    ("lifting", lifting),
];

/// Decodes a structured case from the input bytes as libfuzzer-sys's typed
/// `fuzz_target!` does: `None` for inputs shorter than the type's size
/// hint or that do not decode.
fn decode<'a, T: Arbitrary<'a>>(bytes: &'a [u8]) -> Option<T> {
    if bytes.len() < T::size_hint(0).0 {
        return None;
    }
    T::arbitrary_take_rest(Unstructured::new(bytes)).ok()
}

/// Arbitrary bytes as a CSV file, read by the `lifted` command's table
/// reader (`lifted_data::table`, the one reader of every front end: named
/// columns, empty output cells, declared periods): either a data set or an
/// error, never a panic or a hang.
pub fn csv_table(bytes: &[u8]) {
    let path = std::env::temp_dir().join(format!("lifted-fuzz-csv-{}.csv", std::process::id()));
    if std::fs::write(&path, bytes).is_err() {
        return;
    }
    let p = path.display().to_string();
    for (periods, hold) in [(vec![], 1), (vec![("y1".to_string(), 2)], 1), (vec![], 3)] {
        let spec = DataSpec {
            inputs: vec!["u1".into()],
            outputs: vec!["y1".into()],
            periods,
            hold,
            ..Default::default()
        };
        if let Ok(l) = load(&p, &spec) {
            // A loaded data set is finite at its sampled instants.
            assert!(l.data.u().iter().all(|v| v.is_finite()));
        }
    }
}

/// Arbitrary bytes as a numpy `.npy` file, read by the `lifted` command's
/// table reader (the header, both layouts and element types, the column
/// blocks of `npy::scan_blocks`, empty output cells): either a data set or
/// an error, never a panic or a hang.
pub fn npy_table(bytes: &[u8]) {
    let path = std::env::temp_dir().join(format!("lifted-fuzz-npy-{}.npy", std::process::id()));
    if std::fs::write(&path, bytes).is_err() {
        return;
    }
    let p = path.display().to_string();
    for columns in [vec![], vec!["t".to_string(), "u1".into(), "y1".into()]] {
        let (inputs, outputs) = if columns.is_empty() {
            (vec!["c0".to_string()], vec!["c1".to_string()])
        } else {
            (vec!["u1".to_string()], vec!["y1".to_string()])
        };
        let spec = DataSpec {
            inputs,
            outputs,
            columns,
            ..Default::default()
        };
        if let Ok(l) = load(&p, &spec) {
            // A loaded data set is finite at its sampled instants.
            assert!(l.data.u().iter().all(|v| v.is_finite()));
        }
    }
    let _ = std::fs::remove_file(&path);
}

/// Arbitrary text as a model file (the CLI's JSON): either a model whose
/// analyses return values or errors, or an error; never a panic.
pub fn model_file(bytes: &[u8]) {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return;
    };
    let Ok(file) = ModelFile::from_json(text) else {
        return;
    };
    let m = &file.model;
    if m.order() > 40 {
        return; // the analyses are O(n³); keep executions fast
    }
    let _ = m.poles();
    let _ = m.zeros();
    let _ = m.dc_gain();
    let _ = m.step(16, Some(0.1));
    let _ = file.kalman_gain_matrix();
    let again = file.to_json().expect("a read model file serialises");
    ModelFile::from_json(&again).expect("a written model file reads back");
}

#[derive(Debug, Arbitrary)]
struct IdentifyCase {
    route: u8,
    order: u8,
    horizon: u8,
    period: u8,
    stable: bool,
    states: bool,
    inputs: u8,
    outputs: u8,
    /// Samples, read row-major as [u | y]; special values come through.
    values: Vec<f64>,
}
/// Identification on arbitrary small records and options: every route
/// (N4SID/MOESP/CVA, IV, q-Markov Cover, multirate lifted subspace) returns
/// a model or an error naming the problem; never a panic, hang or abort.
pub fn identify(bytes: &[u8]) {
    let Some(c) = decode::<IdentifyCase>(bytes) else {
        return;
    };
    let nu = 1 + (c.inputs % 2) as usize;
    let ny = 1 + (c.outputs % 2) as usize;
    let n = (c.values.len() / (nu + ny)).min(400);
    if n == 0 {
        return;
    }
    let u = DMatrix::from_fn(n, nu, |i, j| c.values[i * (nu + ny) + j]);
    let y = DMatrix::from_fn(n, ny, |i, j| c.values[i * (nu + ny) + nu + j]);
    let order = match c.order % 8 {
        0 => OrderSelection::Gap { max: 6 },
        k => OrderSelection::Fixed(k as usize),
    };
    let horizon = 1 + (c.horizon % 12) as usize;
    let method = [Method::N4sid, Method::Moesp, Method::Cva][(c.route % 3) as usize];
    match c.route % 6 {
        0..=2 => {
            let opts = SubspaceOptions {
                method,
                order,
                past: horizon,
                future: horizon,
                enforce_stability: c.stable,
                system: if c.states {
                    SystemEstimate::StateSequence
                } else {
                    SystemEstimate::ShiftInvariance
                },
                ..Default::default()
            };
            let _ = subspace_identify(&[Experiment { u: &u, y: &y }], &opts);
        }
        3 => {
            let opts = IvOptions {
                order,
                alpha: horizon,
                enforce_stability: c.stable,
                ..Default::default()
            };
            let _ = iv_identify(
                &[IvExperiment {
                    u: &u,
                    y: &y,
                    instrument: Some(&u),
                }],
                &opts,
            );
        }
        4 => {
            let ch_u = (0..nu)
                .map(|i| InputChannel::new(format!("u{i}"), 1))
                .collect();
            let ch_y = (0..ny)
                .map(|i| OutputChannel::new(format!("y{i}"), 1, 0))
                .collect();
            if let Ok(d) = Dataset::new(1.0, u, y, ch_u, ch_y) {
                let opts = QMarkovOptions {
                    q: horizon,
                    prbs_order: 2 + (c.period % 5) as u32,
                    order: match order {
                        OrderSelection::Fixed(k) => Some(k),
                        _ => None,
                    },
                    enforce_stability: c.stable,
                    ..Default::default()
                };
                let sets = vec![d; nu];
                let _ = QMarkov::new(opts).identify(&sets);
            }
        }
        _ => {
            let period = 1 + (c.period % 4) as usize;
            let mut y = y;
            for k in 0..n {
                if k % period != 0 {
                    y.row_mut(k).fill(f64::NAN);
                }
            }
            let ch_u = (0..nu)
                .map(|i| InputChannel::new(format!("u{i}"), 1))
                .collect();
            let ch_y = (0..ny)
                .map(|i| OutputChannel::new(format!("y{i}"), period, 0))
                .collect();
            if let Ok(d) = Dataset::new(1.0, u, y, ch_u, ch_y) {
                let mut opts = ProcedureOptions::default();
                opts.identification.order = order;
                opts.identification.past = horizon;
                opts.identification.future = horizon;
                opts.identification.enforce_stability = c.stable;
                let _ = identify_multirate(&d, None, &opts);
            }
        }
    }
}

#[derive(Debug, Arbitrary)]
struct LiftingCase {
    holds: Vec<u8>,
    periods: Vec<u8>,
    offsets: Vec<u8>,
    time_major: bool,
    len: u16,
    values: Vec<f64>,
}
/// Multirate lifting of arbitrary records and rate patterns: lifting then
/// inverse lifting returns the inputs (property), or an error; never a
/// panic.
pub fn lifting(bytes: &[u8]) {
    let Some(c) = decode::<LiftingCase>(bytes) else {
        return;
    };
    let nu = c.holds.len().clamp(1, 3);
    let ny = c.periods.len().clamp(1, 3);
    let n = (c.len % 600) as usize;
    if n == 0 || c.values.is_empty() {
        return;
    }
    let hold = |i: usize| 1 + (c.holds.get(i).copied().unwrap_or(0) % 6) as usize;
    let period = |i: usize| 1 + (c.periods.get(i).copied().unwrap_or(0) % 6) as usize;
    let offset = |i: usize| c.offsets.get(i).copied().unwrap_or(0) as usize % period(i);
    let v = |k: usize| c.values[k % c.values.len()];
    // inputs held: constant over each hold block
    let u = DMatrix::from_fn(n, nu, |k, j| v((k / hold(j)) * 7 + j));
    let y = DMatrix::from_fn(n, ny, |k, i| {
        if k % period(i) == offset(i) {
            v(k * 3 + i + 1)
        } else {
            f64::NAN
        }
    });
    let ch_u = (0..nu)
        .map(|j| InputChannel::new(format!("u{j}"), hold(j)))
        .collect();
    let ch_y = (0..ny)
        .map(|i| OutputChannel::new(format!("y{i}"), period(i), offset(i)))
        .collect();
    let Ok(d) = Dataset::new(1.0, u, y, ch_u, ch_y) else {
        return;
    };
    let ordering = if c.time_major {
        Ordering::TimeMajor
    } else {
        Ordering::ChannelMajor
    };
    let Ok(l) = MultirateLifting::from_dataset(&d, ordering) else {
        return;
    };
    let Ok(ld) = l.lift_dataset(&d, true) else {
        return;
    };
    let back = l.unlift_inputs(&ld.u).expect("lifted inputs unlift");
    let rows = back.nrows();
    assert_eq!(rows, ld.u.nrows() * l.period());
    let orig = d.u().rows(0, rows);
    for (a, b) in back.iter().zip(orig.iter()) {
        assert!(a == b || (a.is_nan() && b.is_nan()), "unlift(lift(u)) != u");
    }
}

#[derive(Debug, Arbitrary)]
struct OptionsCase {
    data: u8,
    method: u8,
    order: u32,
    horizon: Option<u32>,
    max_order: Option<u32>,
    hold: Option<u32>,
    q: Option<u32>,
    output_period: Option<u32>,
    criterion: u8,
    estimator: bool,
    refine: u8,
    refine_iterations: u8,
    stable: bool,
    detrend: u8,
}
/// A value up to 1e6 from arbitrary bits: small values often, large ones
/// too (`v % 1_000_001` keeps every magnitude up to 1e6 reachable).
fn up_to_1e6(v: u32) -> u32 {
    match v >> 30 {
        0 => v % 16,
        1 => v % 200,
        _ => v % 1_000_001,
    }
}

/// Two 300-row records written once per process: (t, u1, u2, y1, y2)
/// single rate, and the same with y2 sampled every third row.
fn records() -> &'static (String, String) {
    static FILES: OnceLock<(String, String)> = OnceLock::new();
    FILES.get_or_init(|| {
        // Within the smoke run's -rss_limit_mb=4096: a request the budget
        // admits must also fit under libFuzzer's limit.
        MemoryBudget::set_process_default(2 << 30);
        let dir: PathBuf = std::env::temp_dir();
        let pid = std::process::id();
        let single = dir.join(format!("lifted-fuzz-options-{pid}-single.csv"));
        let multi = dir.join(format!("lifted-fuzz-options-{pid}-multi.csv"));
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        let (mut a, mut b) = (
            String::from("t,u1,u2,y1,y2\n"),
            String::from("t,u1,u2,y1,y2\n"),
        );
        let (mut x1, mut x2) = (0.0f64, 0.0f64);
        for k in 0..300 {
            let u1 = if next() & 1 == 0 { -1.0 } else { 1.0 };
            let u2 = if next() & 1 == 0 { -1.0 } else { 1.0 };
            let e = (next() % 1000) as f64 * 1e-5;
            let (y1, y2) = (x1 + e, x2 - e);
            a += &format!("{k},{u1},{u2},{y1},{y2}\n");
            let y2s = if k % 3 == 0 {
                format!("{y2}")
            } else {
                String::new()
            };
            b += &format!("{k},{u1},{u2},{y1},{y2s}\n");
            x1 = 0.8 * x1 + 0.5 * u1;
            x2 = 0.5 * x2 + 0.3 * u2 + 0.2 * u1;
        }
        std::fs::write(&single, a).expect("temp dir is writable");
        std::fs::write(&multi, b).expect("temp dir is writable");
        (single.display().to_string(), multi.display().to_string())
    })
}

/// The `identify` options as the command line gives them — method, order,
/// horizon, hold, q, output period, order criterion, estimator, refinement,
/// stability — each up to 1e6 (and past the limits the record allows), on
/// small single-rate and multirate records, through the same service the
/// `lifted identify` command calls (`run_identification`): a model file or
/// a one-line error, never a panic, abort (allocation failure) or hang.
/// The memory budget is 2 GiB (the smoke run's RSS limit is 4 GiB).
/// Refinement runs with at most 3 iterations and orders up to 12 here so
/// that one input stays within the smoke run's `-timeout` (the work bound
/// of `refine_pem`, 2e10 operations, is unit-tested in lifted-pem).
pub fn identify_options(bytes: &[u8]) {
    let Some(c) = decode::<OptionsCase>(bytes) else {
        return;
    };
    let (single, multi) = records();
    let data = if c.data % 3 == 0 { multi } else { single };
    let method = ["n4sid", "moesp", "cva", "iv", "qmarkov"][(c.method % 5) as usize];
    // Refinement: orders up to 12 (one PEM iteration of order 40 on these
    // records is allowed by its work bound but takes seconds, too long for
    // the smoke run's -timeout under instrumentation; the bound itself is
    // unit-tested in lifted-subspace).
    let refine = c.refine % 4;
    let cap = |v: u32| {
        if refine == 1 || refine == 2 {
            1 + up_to_1e6(v) % 12
        } else {
            up_to_1e6(v)
        }
    };
    let order = if c.order % 7 == 0 {
        "auto".to_string()
    } else {
        cap(c.order).to_string()
    };
    let mut argv: Vec<String> = [
        "lifted",
        "identify",
        "--method",
        method,
        "--data",
        data,
        "--inputs",
        "u1,u2",
        "--outputs",
        "y1,y2",
        "--order",
        &order,
        "--out",
        "unused.json",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let mut opt = |name: &str, v: String| {
        argv.push(name.to_string());
        argv.push(v);
    };
    if let Some(h) = c.horizon {
        opt("--horizon", up_to_1e6(h).to_string());
    }
    if let Some(m) = c.max_order {
        opt("--max-order", cap(m).to_string());
    } else if refine == 1 || refine == 2 {
        opt("--max-order", "12".to_string());
    }
    if let Some(h) = c.hold {
        opt("--hold", up_to_1e6(h).to_string());
    }
    if let Some(q) = c.q {
        opt("--q", up_to_1e6(q).to_string());
    }
    if let Some(p) = c.output_period {
        opt("--output-period", format!("y2={}", up_to_1e6(p)));
    }
    opt(
        "--order-criterion",
        ["validation", "gap", "svc", "aic", "aicc", "bic"][(c.criterion % 6) as usize].to_string(),
    );
    if c.estimator {
        opt("--estimator", "states".to_string());
    }
    opt(
        "--detrend",
        ["mean", "none", "linear", "auto"][(c.detrend % 4) as usize].to_string(),
    );
    match refine {
        1 => opt("--refine", "pem".to_string()),
        2 => opt("--refine", "oe".to_string()),
        _ => {}
    }
    opt(
        "--refine-iterations",
        (1 + c.refine_iterations % 3).to_string(),
    );
    if c.stable {
        argv.push("--stable".to_string());
    }
    // Option values clap rejects (e.g. an order of 0) are usage errors.
    let Ok(cli) = Cli::try_parse_from(&argv) else {
        return;
    };
    if let Command::Identify(a) = cli.command {
        let _ = run_identification(&a);
    }
}

//! The `identify` options as the command line gives them — method, order,
//! horizon, hold, q, output period, order criterion, estimator, refinement,
//! stability — each up to 1e6 (and past the limits the record allows), on
//! small single-rate and multirate records, through the same service the
//! `lifted identify` command calls (`run_identification`): a model file or
//! a one-line error, never a panic, abort (allocation failure) or hang.
//! The memory budget is 2 GiB (the smoke run's RSS limit is 4 GiB).
//! Refinement runs with at most 3 iterations and orders up to 12 here so
//! that one input stays within the smoke run's `-timeout` (the work bound
//! of `refine_pem`, 2e10 operations, is unit-tested in lifted-pem).
#![no_main]

use std::path::PathBuf;
use std::sync::OnceLock;

use arbitrary::Arbitrary;
use clap::Parser;
use libfuzzer_sys::fuzz_target;
use lifted_cli::args::{Cli, Command};
use lifted_cli::service::identify::run_identification;
use lifted_linalg::budget::MemoryBudget;

#[derive(Debug, Arbitrary)]
struct Case {
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

fuzz_target!(|c: Case| {
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
});

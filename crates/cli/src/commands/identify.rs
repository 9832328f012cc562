//! `lifted identify`: CSV → model file, through the identification service
//! ([`lifted_cli::service::identify`]).

use crate::args::IdentifyArgs;
use crate::error::{CliResult, input};
use lifted_cli::service::identify::{require_stable, run_identification};

/// `lifted identify`.
pub fn identify_cmd(a: &IdentifyArgs) -> CliResult<()> {
    let file = run_identification(a)?;
    // `--stable`, or the plan's `validation.require_stable`.
    let required = file
        .diagnostics
        .pointer("/options/validation/require_stable")
        .and_then(|v| v.as_bool());
    if a.stable || required == Some(true) {
        require_stable(&file.model)?;
    }
    file.write(&a.out).map_err(|e| input(e.to_string()))?;
    print_notes(&file.diagnostics);
    if a.profile {
        print_profile(&file.diagnostics);
    }
    if let Some(p) = &file.polynomial {
        println!("{}", p.present());
    }
    print_process(&file.diagnostics);
    let m = &file.model;
    let method = file
        .diagnostics
        .pointer("/options/identification/method")
        .and_then(|v| v.as_str())
        .unwrap_or(a.method.name());
    println!(
        "{}: order {}, {} input(s), {} output(s), T = {} s; wrote {}",
        method,
        m.order(),
        m.n_inputs(),
        m.n_outputs(),
        m.ts().unwrap_or(f64::NAN),
        a.out
    );
    Ok(())
}

/// Prints the diagnostics' warnings (an unstable model) and fallbacks (a
/// route refused and the one used instead) to standard error.
fn print_notes(diagnostics: &serde_json::Value) {
    for (key, label) in [("warnings", "warning"), ("fallbacks", "note")] {
        if let Some(list) = diagnostics.get(key).and_then(|v| v.as_array()) {
            for w in list.iter().filter_map(|v| v.as_str()) {
                eprintln!("{label}: {w}");
            }
        }
    }
}

/// Prints the per-phase wall times recorded in the diagnostics (`--profile`).
fn print_profile(diagnostics: &serde_json::Value) {
    let Some(p) = diagnostics.get("profile").and_then(|p| p.as_object()) else {
        return;
    };
    // The compress/svd/estimate rows are the final fit's; the subspace row
    // also counts the structure selection's fits before it and the
    // feedthrough test (the D = 0 fit, unless it ran with the fit on a
    // second thread, and the two simulations).
    let phases = [
        ("read", "read_s"),
        ("compress", "compress_s"),
        ("svd", "svd_s"),
        ("estimate", "estimate_s"),
        ("feedthrough test", "feedthrough_s"),
        ("subspace (all)", "subspace_s"),
        ("second pass", "second_pass_s"),
        ("multirate start", "multirate_start_s"),
        ("Kalman gain", "kalman_gain_s"),
        ("refinement", "refine_s"),
        ("ARX / FIR", "arx_s"),
        ("OE", "oe_s"),
        ("ARMAX / BJ", "pem_s"),
        ("process model", "process_s"),
        ("regularised FIR", "impulse_s"),
        ("feedback test", "feedback_s"),
        ("identify (total)", "identify_s"),
    ];
    println!("phase              wall time");
    for (label, key) in phases {
        if let Some(t) = p.get(key).and_then(|v| v.as_f64()) {
            println!("{label:<18} {:>9.4} s", t);
        }
    }
    if let Some(c) = diagnostics.get("compression")
        && let Some(used) = c.get("used").and_then(|v| v.as_str())
    {
        print!("compression: {used}");
        if let Some(f) = c.get("fallback").and_then(|v| v.as_str()) {
            print!(" (fallback: {f})");
        }
        println!();
    }
}

/// Prints a process model's parameters with their standard deviations
/// (`diagnostics.process`), one output a line.
fn print_process(diagnostics: &serde_json::Value) {
    let Some(p) = diagnostics.get("process") else {
        return;
    };
    let kind = p["kind"].as_str().unwrap_or_default();
    for (i, out) in p["outputs"].as_array().into_iter().flatten().enumerate() {
        let names = out["names"].as_array().cloned().unwrap_or_default();
        let values = out["parameters"].as_array().cloned().unwrap_or_default();
        let std = out["std"].as_array().cloned().unwrap_or_default();
        let terms: Vec<String> = names
            .iter()
            .zip(&values)
            .zip(&std)
            .map(|((n, v), s)| {
                format!(
                    "{} = {:.6} (±{:.2e})",
                    n.as_str().unwrap_or_default(),
                    v.as_f64().unwrap_or(f64::NAN),
                    s.as_f64().unwrap_or(f64::NAN)
                )
            })
            .collect();
        println!(
            "process model {kind}, output {}: {}",
            i + 1,
            terms.join(", ")
        );
    }
}

//! `lifted identify`: CSV → model file, through the identification service
//! ([`lifted_cli::service::identify`]).

use crate::args::IdentifyArgs;
use crate::error::{CliResult, input};
use lifted_cli::service::identify::{parameters_text, require_stable, run_identification};
use lifted_workflow::Diagnostics;
use lifted_workflow::diagnostics::Compression;

/// `lifted identify`.
pub fn identify_cmd(a: &IdentifyArgs) -> CliResult<()> {
    let file = run_identification(a)?;
    let diagnostics = Diagnostics::of(&file);
    // `--stable`, or the plan's `validation.require_stable`.
    let required = diagnostics
        .options
        .as_ref()
        .is_some_and(|o| o.validation.require_stable);
    if a.stable || required {
        require_stable(&file.model)?;
    }
    file.write(&a.out).map_err(|e| input(e.to_string()))?;
    print_notes(&diagnostics);
    if a.profile {
        print_profile(&diagnostics);
    }
    // A polynomial or process model's parameters ± σ (a state-space
    // model's are in the file: `lifted analyze` prints them).
    if let Some(text) = parameters_text(&file, &diagnostics, false) {
        println!("{text}");
    }
    let m = &file.model;
    let method = diagnostics.method().map_or(a.method.name(), |m| m.name());
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
fn print_notes(diagnostics: &Diagnostics) {
    for w in &diagnostics.warnings {
        eprintln!("warning: {w}");
    }
    for f in diagnostics.fallbacks.iter().flatten() {
        eprintln!("note: {f}");
    }
}

/// Prints the per-phase wall times recorded in the diagnostics (`--profile`).
fn print_profile(diagnostics: &Diagnostics) {
    if diagnostics.profile.is_none() {
        return;
    }
    // The compress/svd/estimate rows are the final fit's; the subspace row
    // also counts the structure selection's fits before it (its own row:
    // the held-out fits and the refined shortlist) and the feedthrough
    // test (the D = 0 fit, unless it ran with the fit on a second thread,
    // and the two simulations). The multirate route's row counts lifting,
    // its order selection and the fast model's extraction.
    let phases = [
        ("read", "read_s"),
        ("compress", "compress_s"),
        ("svd", "svd_s"),
        ("estimate", "estimate_s"),
        ("feedthrough test", "feedthrough_s"),
        ("structure selection", "selection_s"),
        ("subspace (all)", "subspace_s"),
        ("second pass", "second_pass_s"),
        ("multirate route", "multirate_s"),
        ("multirate start", "multirate_start_s"),
        ("multirate check", "multirate_check_s"),
        ("Kalman gain", "kalman_gain_s"),
        ("refinement", "refine_s"),
        ("ARX / FIR", "arx_s"),
        ("OE", "oe_s"),
        ("ARMAX / BJ", "pem_s"),
        ("process model", "process_s"),
        ("regularised FIR", "impulse_s"),
        ("feedback test", "feedback_s"),
        ("covariance", "covariance_s"),
        ("identify (total)", "identify_s"),
    ];
    println!("phase               wall time");
    for (label, key) in phases {
        if let Some(t) = diagnostics.phase(key) {
            println!("{label:<19} {:>9.4} s", t);
        }
    }
    if let Some(Compression::Used { used, fallback, .. }) = &diagnostics.compression {
        print!("compression: {used}");
        if let Some(f) = fallback {
            print!(" (fallback: {f})");
        }
        println!();
    }
}

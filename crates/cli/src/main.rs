//! `lifted`: the command-line front end of the Lifted toolkit.
//!
//! Every command validates its input and ends with a one-line message on
//! error: exit code 2 for usage or input errors (missing file, bad CSV,
//! impossible options, an identification that cannot run on the data),
//! 1 for failed checks (`validate --min-fit`, a failed reproduction), 0
//! otherwise. See the crate README for the commands, the model-file schema
//! and a five-minute walk-through.
#![deny(missing_docs)]

mod commands;

use std::process::ExitCode;

use lifted_cli::{args, error, escape, html, plot, table, terminal};

use clap::Parser;
use clap::error::ErrorKind;

use crate::args::{Cli, Command, ResourceArgs};
use crate::commands::{
    analyze, closedloop, delay, identify, model, mpc, report, reproduce, robust, signals, studio,
    validate,
};
use crate::error::CliResult;

/// The `--memory-limit` of the commands that size their work by options.
fn resources(c: &Command) -> Option<&ResourceArgs> {
    match c {
        Command::Simulate(a) => Some(&a.resources),
        Command::Identify(a) => Some(&a.resources),
        Command::Validate(a) => Some(&a.resources),
        Command::Bode(a) => Some(&a.resources),
        Command::Step(a) => Some(&a.resources),
        Command::Delay(a) => Some(&a.resources),
        Command::Closedloop(a) => Some(&a.resources),
        Command::Mpc(a) => Some(&a.resources),
        Command::Robust(a) => Some(&a.resources),
        Command::Analyze(a) => Some(&a.resources),
        Command::Lqr(a) => Some(&a.resources),
        Command::Report(a) => Some(&a.resources),
        Command::Studio(a) => Some(&a.resources),
        _ => None,
    }
}

/// The files a command reads and the one it writes.
fn files(c: &Command) -> (Vec<&str>, Option<&str>) {
    fn one(s: &Option<String>) -> Vec<&str> {
        s.iter().map(String::as_str).collect()
    }
    match c {
        Command::Simulate(a) => (vec![&a.model, &a.input], Some(&a.out)),
        Command::Identify(a) => (a.data.iter().map(String::as_str).collect(), Some(&a.out)),
        Command::Closedloop(a) => {
            let mut v = one(&a.h1);
            v.extend(one(&a.h2));
            v.extend(one(&a.controller));
            (v, Some(&a.out))
        }
        Command::Mpc(a) => {
            let mut v = vec![a.model.as_str()];
            v.extend(one(&a.plant));
            (v, Some(&a.out))
        }
        Command::Convert(a) => (vec![&a.model], a.out.as_deref()),
        Command::Bode(a) => (vec![&a.model], a.out.as_deref()),
        Command::Step(a) => (vec![&a.model], Some(&a.out)),
        Command::Report(a) => (vec![&a.model, &a.data], Some(&a.out)),
        _ => (Vec::new(), None),
    }
}

/// Refuses an `--out` that names one of the command's own input files
/// (`identify --data d.csv --out d.csv` replaced the data by the model).
fn refuse_overwriting_inputs(c: &Command) -> CliResult<()> {
    let (inputs, Some(out)) = files(c) else {
        return Ok(());
    };
    let Ok(out_path) = std::fs::canonicalize(out) else {
        return Ok(()); // not there yet: nothing to overwrite
    };
    for f in inputs {
        if std::fs::canonicalize(f).is_ok_and(|p| p == out_path) {
            return Err(error::input(format!(
                "--out {out} is the input file {f}: writing it would destroy the input; give another --out"
            )));
        }
    }
    Ok(())
}

fn run(cli: Cli) -> CliResult<()> {
    // --memory-limit overrides LIFTED_MEMORY_LIMIT for every budget check
    // of this process (lifted_linalg::budget::MemoryBudget::default).
    if let Some(bytes) = resources(&cli.command).and_then(|r| r.memory_limit) {
        lifted_linalg::budget::MemoryBudget::set_process_default(bytes);
    }
    refuse_overwriting_inputs(&cli.command)?;
    match cli.command {
        Command::Prbs(a) => signals::prbs(&a),
        Command::Rbs(a) => signals::rbs(&a),
        Command::Gbn(a) => signals::gbn(&a),
        Command::Gaussian(a) => signals::gaussian(&a),
        Command::Multisine(a) => signals::multisine_cmd(&a),
        Command::Design(a) => signals::design_cmd(&a),
        Command::Simulate(a) => model::simulate(&a),
        Command::Identify(a) => identify::identify_cmd(&a),
        Command::Validate(a) => validate::validate_cmd(&a),
        Command::Convert(a) => model::convert(&a),
        Command::Bode(a) => model::bode(&a),
        Command::Step(a) => model::step(&a),
        Command::Delay(a) => delay::delay_cmd(&a),
        Command::Closedloop(a) => closedloop::closedloop_cmd(&a),
        Command::Mpc(a) => mpc::mpc_cmd(&a),
        Command::Robust(a) => robust::robust_cmd(&a),
        Command::Analyze(a) => analyze::analyze_cmd(&a),
        Command::Lqr(a) => analyze::lqr_cmd(&a),
        Command::Report(a) => report::report_cmd(&a),
        Command::Reproduce(a) => reproduce::reproduce_cmd(&a),
        Command::Studio(a) => studio::studio_cmd(&a),
    }
}

fn main() -> ExitCode {
    // Working matrices from the heap instead of fresh mmaps (glibc).
    lifted_linalg::malloc::tune_malloc();
    // faer's one-time set-up runs while the arguments and data are read.
    lifted_linalg::warm_up();
    // A bug below must not print a Rust backtrace: one line, exit code 2.
    // (Written without `eprintln!`, which panics on a closed stderr: a
    // panic in the hook aborts the process.)
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into());
        say(&format!("lifted: internal error: {msg}"));
    }));
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => match e.kind() {
            ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
                let _ = e.print();
                return ExitCode::SUCCESS;
            }
            ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
                let _ = e.print();
                return ExitCode::from(2);
            }
            _ => {
                eprintln!(
                    "lifted: {} (see --help)",
                    error::clap_one_line(&e).trim_start_matches("error: ")
                );
                return ExitCode::from(2);
            }
        },
    };
    if !matches!(cli.command, Command::Studio(_)) {
        quiet_on_closed_pipe();
    }
    match std::panic::catch_unwind(|| run(cli)) {
        Ok(Ok(())) => ExitCode::SUCCESS,
        Ok(Err(e)) => {
            say(&format!("lifted: {e}"));
            ExitCode::from(e.exit_code())
        }
        Err(_) => ExitCode::from(2),
    }
}

/// One line on stderr, nothing when stderr is closed.
fn say(line: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "{line}");
}

/// A command whose output goes to a reader that stops early (`lifted
/// analyze … | head -1`) ends as `cat` or `grep` do there: silently, by
/// SIGPIPE, instead of failing on its next write ("failed printing to
/// stdout: Broken pipe", or an abort when stderr was closed too). Not for
/// the studio, whose server must outlive a browser that closes its socket.
fn quiet_on_closed_pipe() {
    #[cfg(unix)]
    // SAFETY: restores the default disposition of SIGPIPE (the Rust
    // runtime set it to ignore) before any thread that writes is started;
    // no handler is installed.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

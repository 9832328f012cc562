//! The top-level error of the `lifted` command and its exit codes: the
//! front ends' error of `lifted_data` ([`CliError`], [`input`],
//! [`failed`], [`Context`]), and clap's errors on one line.

pub use lifted_data::error::{Context, failed, input};

/// Everything that ends a command early (`lifted_data::Error`): `main`
/// prints the message on one line and exits with its `exit_code`.
pub type CliError = lifted_data::Error;

/// Result alias of the command.
pub type CliResult<T> = Result<T, CliError>;

/// Clap's error on one line: the message and its hints, without the
/// usage block.
pub fn clap_one_line(e: &clap::Error) -> String {
    e.render()
        .to_string()
        .lines()
        .map(str::trim)
        .filter(|l| {
            !l.is_empty() && !l.starts_with("Usage:") && !l.starts_with("For more information")
        })
        .collect::<Vec<_>>()
        .join(" ")
}

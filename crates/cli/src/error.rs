//! The top-level error of the `lifted` command and its exit codes.

use std::fmt::Display;

use crate::shown::clean_message;

/// Everything that ends a command early. `main` prints the message on one
/// line and exits with [`CliError::exit_code`].
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// Bad usage or bad input data (missing file, bad CSV, impossible
    /// options, an identification that cannot run on the data): exit code 2.
    #[error("{0}")]
    Input(String),
    /// The command ran but a check failed (`validate --min-fit`, a failed
    /// reproduction): exit code 1.
    #[error("{0}")]
    Failed(String),
}

impl CliError {
    /// 2 for usage/input errors, 1 for failed checks.
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::Input(_) => 2,
            CliError::Failed(_) => 1,
        }
    }
}

/// Result alias of the command.
pub type CliResult<T> = Result<T, CliError>;

/// An input error with a message, made safe for one line
/// ([`crate::shown::clean_message`]: control characters escaped, long
/// runs and the whole cut with a count).
pub fn input(msg: impl Display) -> CliError {
    CliError::Input(clean_message(&msg.to_string()))
}

/// A failed check with a message, made safe like [`input`]'s.
pub fn failed(msg: impl Display) -> CliError {
    CliError::Failed(clean_message(&msg.to_string()))
}

/// Adds context ("what was being done") to any displayable error.
pub trait Context<T> {
    /// Maps the error to [`CliError::Input`] with "`what`: `error`"
    /// (through [`input`]).
    fn ctx(self, what: impl Display) -> CliResult<T>;
}

impl<T, E: Display> Context<T> for Result<T, E> {
    fn ctx(self, what: impl Display) -> CliResult<T> {
        self.map_err(|e| input(format!("{what}: {e}")))
    }
}

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

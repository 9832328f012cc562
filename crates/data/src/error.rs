//! The error of the front ends (the `lifted` command, its studio) and
//! their exit codes: bad input (2) or a failed check (1), with messages
//! made safe for one line ([`crate::shown::clean_message`]).

use std::fmt::Display;

use crate::shown::clean_message;

/// Everything that ends a command early. `main` prints the message on one
/// line and exits with [`Error::exit_code`].
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad usage or bad input data (missing file, bad CSV, impossible
    /// options, an identification that cannot run on the data): exit code 2.
    #[error("{0}")]
    Input(String),
    /// The command ran but a check failed (`validate --min-fit`, a failed
    /// reproduction): exit code 1.
    #[error("{0}")]
    Failed(String),
}

impl Error {
    /// 2 for usage/input errors, 1 for failed checks.
    pub fn exit_code(&self) -> u8 {
        match self {
            Error::Input(_) => 2,
            Error::Failed(_) => 1,
        }
    }
}

/// Result alias of the front ends.
pub type Result<T> = std::result::Result<T, Error>;

/// An input error with a message, made safe for one line
/// ([`crate::shown::clean_message`]: control characters escaped, long
/// runs and the whole cut with a count).
pub fn input(msg: impl Display) -> Error {
    Error::Input(clean_message(&msg.to_string()))
}

/// A failed check with a message, made safe like [`input`]'s.
pub fn failed(msg: impl Display) -> Error {
    Error::Failed(clean_message(&msg.to_string()))
}

/// Adds context ("what was being done") to any displayable error.
pub trait Context<T> {
    /// Maps the error to [`Error::Input`] with "`what`: `error`"
    /// (through [`input`]).
    fn ctx(self, what: impl Display) -> Result<T>;
}

impl<T, E: Display> Context<T> for std::result::Result<T, E> {
    fn ctx(self, what: impl Display) -> Result<T> {
        self.map_err(|e| input(format!("{what}: {e}")))
    }
}

//! The error type of `lifted-closedloop`.

use crate::setup::Setup;

/// Errors returned by `lifted-closedloop`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An error from `lifted-lti` (model validation, d2c, interconnection, …).
    #[error(transparent)]
    Lti(#[from] lifted_lti::Error),
    /// A data-set error from `lifted-lti` (shapes, non-finite samples, …).
    #[error(transparent)]
    Data(#[from] lifted_lti::DataError),
    /// An error from `lifted-sim` (closed-loop simulation).
    #[error(transparent)]
    Sim(#[from] lifted_sim::Error),
    /// An error from `lifted-prbs` (PRBS generation).
    #[error(transparent)]
    Prbs(#[from] lifted_prbs::Error),
    /// The identification method failed.
    #[error("identification of the closed loop with {method} failed: {source}")]
    Identification {
        /// The identifier's name.
        method: &'static str,
        /// Its error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync + 'static>,
    },
    /// Two models or data sets have incompatible dimensions (e.g. K is not
    /// n_u × n_y for the given Ĥ).
    #[error("dimension mismatch for {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// What was matched.
        what: &'static str,
        /// Expected size.
        expected: String,
        /// Actual size.
        got: String,
    },
    /// Models live in different time domains (continuous vs discrete, or
    /// different sample periods).
    #[error("{what}: time domains differ (ts {left:?} vs {right:?}; None = continuous)")]
    DomainMismatch {
        /// Which operation.
        what: &'static str,
        /// Sample period of the first model.
        left: Option<f64>,
        /// Sample period of the second model.
        right: Option<f64>,
    },
    /// I − Ĥ₁ (eqs. 10, 11) or I − KĤ₂ (eq. 12) has no (proper) inverse.
    #[error("{what} is not invertible: {reason}")]
    SingularReturnDifference {
        /// "I - H1" or "I - K H2".
        what: &'static str,
        /// Why.
        reason: String,
    },
    /// The controller set-up (eq. 11) needs K⁻¹, and K is not invertible
    /// (not square, identically zero or singular feedthrough).
    #[error("the controller K is not invertible: {reason}")]
    ControllerNotInvertible {
        /// Why.
        reason: String,
    },
    /// The chosen set-up needs an excitation channel the data do not contain
    /// (general: r₁ and r₂; controller: r₁; compensator: r₂).
    #[error("the {setup} set-up needs excitation at {channel}, but {reason}")]
    MissingExcitation {
        /// The set-up.
        setup: Setup,
        /// "r1" or "r2".
        channel: &'static str,
        /// What is missing.
        reason: String,
    },
    /// An option or argument is out of range.
    #[error("invalid {what}: {reason}")]
    InvalidArgument {
        /// Which option.
        what: &'static str,
        /// Why.
        reason: String,
    },
    /// A linear-algebra kernel failed.
    #[error(transparent)]
    Linalg(#[from] lifted_linalg::Error),
    /// The record is too short for what was asked.
    #[error("{what}: the record is too short: it needs at least {need} samples, it has {got}")]
    TooShort {
        /// What needed the samples.
        what: &'static str,
        /// Samples needed.
        need: usize,
        /// Samples given.
        got: usize,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

pub(crate) fn dims(what: &'static str, expected: impl ToString, got: impl ToString) -> Error {
    Error::DimensionMismatch {
        what,
        expected: expected.to_string(),
        got: got.to_string(),
    }
}

//! The error type of the workflow.

/// Result alias of the workflow.
pub type Result<T> = std::result::Result<T, Error>;

/// Why a workflow could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An option is invalid, or does not apply to the set-up. `option` is
    /// the option's name as in [`crate::WorkflowOptions`]'s sections (the
    /// CLI spells it `--option-name`, the Python package `option_name`).
    #[error("{option}: {reason}")]
    InvalidOption {
        /// The option's name (e.g. `refine_iterations`).
        option: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// The data do not fit the set-up (e.g. several records where the
    /// route takes one).
    #[error("{0}")]
    Data(String),
    /// A step of the pipeline failed in the layer below (`what` names the
    /// step, e.g. "N4SID identification").
    #[error("{what}: {source}")]
    Step {
        /// The step.
        what: String,
        /// The error of the layer below.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync + 'static>,
    },
    /// The caller's [`crate::RecordSource`] failed (its message as it gave
    /// it: a file, a line and a column, say).
    #[error("{0}")]
    Source(String),
    /// A model file's diagnostics do not have the form of
    /// [`crate::Diagnostics`] (the entry and serde's reason).
    #[error("{0}")]
    Diagnostics(String),
}

impl Error {
    /// An [`Error::InvalidOption`].
    pub(crate) fn option(option: &'static str, reason: impl Into<String>) -> Self {
        Error::InvalidOption {
            option,
            reason: reason.into(),
        }
    }
}

/// Adds the step's name to an error of the layer below.
pub(crate) trait Context<T> {
    /// Maps the error to [`Error::Step`].
    fn ctx(self, what: impl std::fmt::Display) -> Result<T>;
}

impl<T, E: std::error::Error + Send + Sync + 'static> Context<T> for std::result::Result<T, E> {
    fn ctx(self, what: impl std::fmt::Display) -> Result<T> {
        self.map_err(|e| Error::Step {
            what: what.to_string(),
            source: Box::new(e),
        })
    }
}

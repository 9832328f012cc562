//! The error type of `lifted-pem`.

/// Errors returned by the prediction-error methods of this crate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An error from `lifted-linalg` (a failed decomposition, a working
    /// matrix beyond the memory budget: `TooLarge`).
    #[error(transparent)]
    Linalg(#[from] lifted_linalg::Error),
    /// An error from `lifted-lti` (building or simulating a model).
    #[error(transparent)]
    Lti(#[from] lifted_lti::Error),
    /// An error from `lifted-subspace`: the record checks shared with the
    /// subspace methods (shapes, non-finite samples), the initial-state
    /// regression, the subspace identification of a fold
    /// ([`crate::cross_validate_refinement`]).
    #[error(transparent)]
    Subspace(#[from] lifted_subspace::Error),
    /// No record was given, or an empty one.
    #[error("no data: at least one non-empty record is needed")]
    NoData,
    /// Arguments have incompatible dimensions.
    #[error("dimension mismatch for {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// What was being matched.
        what: &'static str,
        /// Expected dimension, human readable.
        expected: String,
        /// Actual dimension, human readable.
        got: String,
    },
    /// A data matrix contains an infinity (or NaN where NaN does not mean
    /// "not sampled").
    #[error("{what} contains a non-finite value at sample {row}, channel {col}")]
    NonFinite {
        /// Which argument (e.g. "y").
        what: &'static str,
        /// Sample (row) of the first non-finite entry.
        row: usize,
        /// Channel (column) of the first non-finite entry.
        col: usize,
    },
    /// Fewer measured output samples than free parameters: the cost has
    /// no unique minimum.
    #[error(
        "{what}: {measured} measured output samples for {needed} parameters; lower the order or use more data"
    )]
    TooFewSamples {
        /// Which computation.
        what: &'static str,
        /// Measured output samples.
        measured: usize,
        /// Samples needed (free parameters + 1).
        needed: usize,
    },
    /// More free parameters than the data can support: [`crate::refine_pem`]
    /// takes at most one per [`crate::PEM_SAMPLES_PER_PARAMETER`] measured
    /// output samples.
    #[error(
        "{what}: {parameters} free parameters for {measured} measured output samples (at most {max}, one per two samples); lower the order or use more data"
    )]
    TooManyParameters {
        /// Which computation.
        what: &'static str,
        /// Free parameters requested.
        parameters: usize,
        /// Measured output samples.
        measured: usize,
        /// Largest accepted count.
        max: usize,
    },
    /// Even one iteration would exceed the work bound
    /// ([`crate::PemOptions::max_work`]).
    #[error(
        "{what}: one iteration needs about {flops:.2e} floating-point operations, more than the bound of {limit:.2e}; lower the order or raise the bound"
    )]
    TooMuchWork {
        /// Which computation.
        what: &'static str,
        /// Estimated operations of one iteration.
        flops: f64,
        /// The bound.
        limit: f64,
    },
    /// The start is unstable and cannot be stabilised (defective, no
    /// eigenbasis to reflect its poles in), or its predictor is unstable for
    /// the chosen cost.
    #[error("the start of the refinement is unstable: spectral radius {spectral_radius}")]
    Unstable {
        /// Spectral radius of the start's A (or of its predictor).
        spectral_radius: f64,
    },
    /// A regressor matrix is (numerically) rank deficient: a lag
    /// structure the data do not determine (a non-exciting input, an output
    /// tied to the inputs, a delay longer than the record shows).
    #[error(
        "{what}: rank deficient (numerical rank {rank}, {needed} needed); lower the orders or excite the inputs more"
    )]
    RankDeficient {
        /// Which regressors.
        what: &'static str,
        /// Numerical rank found.
        rank: usize,
        /// Rank needed (the number of regressors).
        needed: usize,
    },
    /// The prediction errors are not finite at every start (the model's
    /// simulation or its predictor diverges on the records).
    #[error(
        "{what}: the prediction errors are not finite (the simulation or the predictor diverges on these records)"
    )]
    Diverged {
        /// Which problem.
        what: &'static str,
    },
    /// An option has an invalid value.
    #[error("invalid option {what}: {reason}")]
    InvalidOption {
        /// Which option.
        what: &'static str,
        /// Why.
        reason: String,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// Whether the records cannot support the refinement's parameters
    /// ([`Error::TooFewSamples`], [`Error::TooManyParameters`]): a caller
    /// returns its start instead.
    pub fn unsupported_by_data(&self) -> bool {
        matches!(
            self,
            Error::TooFewSamples { .. } | Error::TooManyParameters { .. }
        )
    }
}

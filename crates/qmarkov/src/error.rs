//! The error type of `lifted-qmarkov`.

/// Errors returned by `lifted-qmarkov`.
///
/// Bad experiment data (NaN, wrong lengths, a record that is not one steady-state
/// PRBS period, an input that is not the declared PRBS) and bad options (q too large,
/// an order above the rank of `D_q`, a zero amplitude) are named variants with the
/// offending values; errors of the layers below arrive through `#[from]`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An error from `lifted-linalg`.
    #[error(transparent)]
    Linalg(#[from] lifted_linalg::Error),
    /// An error from `lifted-lti`.
    #[error(transparent)]
    Lti(#[from] lifted_lti::Error),
    /// An error from the data layer of `lifted-lti` (experiments with different
    /// periods or channel counts, ...).
    #[error(transparent)]
    Data(#[from] lifted_lti::DataError),
    /// An error from `lifted-prbs` (PRBS order out of range, ...).
    #[error(transparent)]
    Prbs(#[from] lifted_prbs::Error),
    /// No experiment was given.
    #[error("no experiment given: the q-Markov Cover needs one record per input channel")]
    NoExperiments,
    /// A per-channel option does not have one entry per experiment.
    #[error("{what}: expected {expected} entries (one per input channel), got {got}")]
    ChannelCount {
        /// Which option or argument.
        what: &'static str,
        /// Number of experiments (input channels).
        expected: usize,
        /// Number of entries given.
        got: usize,
    },
    /// Two arguments have incompatible dimensions.
    #[error("dimension mismatch for {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// What was being matched.
        what: &'static str,
        /// Expected dimension.
        expected: String,
        /// Actual dimension.
        got: String,
    },
    /// A NaN or infinite sample (also NaN marking an unsampled output instant: the
    /// q-Markov Cover needs the output at every output instant).
    #[error("experiment {experiment}: non-finite {what} at sample {sample}, channel {channel}")]
    NonFinite {
        /// Index of the experiment (input channel).
        experiment: usize,
        /// `"input"` or `"output"`.
        what: &'static str,
        /// Sample (row) index.
        sample: usize,
        /// Channel (column) index.
        channel: usize,
    },
    /// The record is shorter than one excitation period `2 n_r m`.
    #[error(
        "experiment {experiment}: record of {len} samples is shorter than one period of {period} (2 n_r m, the inverse PRBS of the m-sequence order and hold the identification was given: the workflow's default order is 8; --prbs-order / prbs_order gives the order the record was made with)"
    )]
    RecordTooShort {
        /// Index of the experiment.
        experiment: usize,
        /// Record length.
        len: usize,
        /// One period `2 n_r m` (eq. II-8).
        period: usize,
    },
    /// In [`RecordMode::OnePeriod`](crate::RecordMode::OnePeriod) the record must be
    /// exactly one period long.
    #[error("experiment {experiment}: record of {got} samples is not one period of {expected}")]
    WrongPeriodLength {
        /// Index of the experiment.
        experiment: usize,
        /// One period `2 n_r m`.
        expected: usize,
        /// Record length.
        got: usize,
    },
    /// The recorded input is not antisymmetric with the declared half period
    /// `n_r m` (`w(k) = −w(k + n_r m)`, eq. II-5): wrong PRBS order or hold.
    #[error(
        "experiment {experiment}: the input is not an inverse PRBS of half period {half_period} (w(k) = -w(k + n_r m) fails at sample {sample})"
    )]
    PeriodMismatch {
        /// Index of the experiment.
        experiment: usize,
        /// Declared half period `n_r m`.
        half_period: usize,
        /// First sample where the antisymmetry fails.
        sample: usize,
    },
    /// The recorded input does not take the values `±a` or its changes are not on a
    /// single hold phase (multiples of `n_r`).
    #[error("experiment {experiment}: the input is not the declared held PRBS: {reason}")]
    NotPrbs {
        /// Index of the experiment.
        experiment: usize,
        /// What is wrong.
        reason: String,
    },
    /// Experiment `experiment` must excite only its own input channel.
    #[error(
        "experiment {experiment} also excites input channel {channel}; q-Markov needs one channel per experiment"
    )]
    CrossExcitation {
        /// Index of the experiment.
        experiment: usize,
        /// The other, nonzero input channel.
        channel: usize,
    },
    /// The output period is not steady state: the antisymmetry test
    /// `y(k) ≈ −y(k + n_r m)` (erratum Z-12) fails.
    #[error(
        "experiment {experiment}: output not in periodic steady state (antisymmetry residual {residual:.3e} > {tol:.3e})"
    )]
    NotSteadyState {
        /// Index of the experiment.
        experiment: usize,
        /// `‖y(k) + y(k + n_r m)‖ / ‖y‖` over the period.
        residual: f64,
        /// The tolerance of the options.
        tol: f64,
    },
    /// A PRBS amplitude is zero, negative or not finite.
    #[error("PRBS amplitude of channel {channel} is {value}: it must be finite and positive")]
    InvalidAmplitude {
        /// Input channel.
        channel: usize,
        /// The rejected amplitude.
        value: f64,
    },
    /// `q` must satisfy `2 ≤ q < n_r m` (eq. III-8: Toeplitz structure of `R_q`).
    #[error("q = {q} is out of range: need 2 <= q < n_r m = {max_exclusive}")]
    LagsOutOfRange {
        /// Requested number of Markov parameters.
        q: usize,
        /// `n_r m`.
        max_exclusive: usize,
    },
    /// The requested order exceeds the numerical rank of `D_q` (there are not that
    /// many positive eigenvalues to take square roots of).
    #[error("order r = {order} exceeds the numerical rank {rank} of D_q")]
    OrderExceedsRank {
        /// Requested order.
        order: usize,
        /// Numerical rank of `D_q` (eigenvalues above the tolerance).
        rank: usize,
    },
    /// `D_q` has no positive eigenvalue: the outputs carry no dynamics beyond the
    /// direct feedthrough (or are zero).
    #[error("D_q has no positive eigenvalue (largest {largest:.3e}): nothing to realise")]
    NoPositiveEigenvalue {
        /// Largest eigenvalue of `D_q`.
        largest: f64,
    },
    /// The output weighting `Q` is not symmetric positive definite.
    #[error("output weighting Q is not symmetric positive definite: {reason}")]
    InvalidWeighting {
        /// What is wrong.
        reason: String,
    },
    /// An option has an invalid value.
    #[error("invalid option {what}: {reason}")]
    InvalidOption {
        /// Which option.
        what: &'static str,
        /// Why.
        reason: String,
    },
    /// The identified cover is unstable (erratum Z-9: Theorem III-1's "stable for
    /// any q" does not hold for the finite-m estimate). Returned unless
    /// [`QMarkovOptions::require_stable`](crate::QMarkovOptions::require_stable) is false.
    #[error("the identified q-Markov cover is unstable (spectral radius {spectral_radius:.6})")]
    UnstableCover {
        /// Largest pole modulus of Â.
        spectral_radius: f64,
    },
}

/// `Result` with this crate's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;

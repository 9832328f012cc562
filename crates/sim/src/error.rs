//! The error type of `lifted-sim`.

/// Errors returned by `lifted-sim`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An error from `lifted-lti` (model validation, discretisation, …).
    #[error(transparent)]
    Lti(#[from] lifted_lti::Error),
    /// An error from the data layer (building the [`lifted_lti::Dataset`]).
    #[error(transparent)]
    Data(#[from] lifted_lti::DataError),
    /// An error from `lifted-linalg`.
    #[error(transparent)]
    Linalg(#[from] lifted_linalg::Error),
    /// Two arguments have incompatible dimensions.
    #[error("dimension mismatch for {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// What was being matched.
        what: &'static str,
        /// Expected size.
        expected: usize,
        /// Actual size.
        got: usize,
    },
    /// A scalar or signal value is NaN or infinite.
    #[error("{what} is not finite ({value})")]
    NonFinite {
        /// Name of the argument.
        what: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A delay is negative.
    #[error("{what} delay {index} is negative ({value})")]
    NegativeDelay {
        /// "input" or "output".
        what: &'static str,
        /// Channel index.
        index: usize,
        /// The value in seconds (or samples).
        value: f64,
    },
    /// A sample period is not positive and finite.
    #[error("invalid sample period {ts}: must be positive and finite")]
    InvalidSamplePeriod {
        /// The rejected value.
        ts: f64,
    },
    /// A discrete model's sample period differs from the simulation's base period.
    #[error("{what}: sample period {got} differs from the base period {expected}")]
    SamplePeriodMismatch {
        /// Which model.
        what: &'static str,
        /// The base period.
        expected: f64,
        /// The model's period.
        got: f64,
    },
    /// A model must be discrete here (e.g. a controller).
    #[error("{what} must be a discrete-time model")]
    NotDiscrete {
        /// Which model.
        what: &'static str,
    },
    /// An input hold m_i is 0.
    #[error("input channel {channel}: hold must be at least 1")]
    ZeroHold {
        /// Input channel.
        channel: usize,
    },
    /// An output sampling period J_i is 0.
    #[error("output channel {channel}: sampling period must be at least 1")]
    ZeroPeriod {
        /// Output channel.
        channel: usize,
    },
    /// The controller's sample period is not an integer multiple of the
    /// plant's base period.
    #[error(
        "controller sample period {controller} s is not an integer multiple (≥ 1) of the base period {base} s"
    )]
    ControllerPeriod {
        /// The controller model's sample period (s).
        controller: f64,
        /// The plant's base period (s).
        base: f64,
    },
    /// The controller's execution phase is not below its period.
    #[error("controller phase {phase} must be < its period {period} (base periods)")]
    ControllerPhase {
        /// Requested phase.
        phase: usize,
        /// Controller period in base periods.
        period: usize,
    },
    /// A sampling offset is not below its period.
    #[error("output channel {channel}: offset {offset} must be < period {period}")]
    OffsetOutOfRange {
        /// Output channel.
        channel: usize,
        /// Offset.
        offset: usize,
        /// Period.
        period: usize,
    },
    /// A signal-to-noise ratio is not positive and finite.
    #[error("output channel {channel}: SNR must be positive and finite (got {value})")]
    InvalidSnr {
        /// Output channel.
        channel: usize,
        /// The rejected value.
        value: f64,
    },
    /// A noise standard deviation is negative or not finite.
    #[error(
        "noise channel {channel}: standard deviation must be non-negative and finite (got {value})"
    )]
    InvalidNoiseStd {
        /// Noise source index.
        channel: usize,
        /// The rejected value.
        value: f64,
    },
    /// SNR scaling needs a noise-free output with nonzero variance.
    #[error(
        "output channel {channel}: the noise-free output has zero variance, SNR scaling is undefined"
    )]
    ZeroSignalVariance {
        /// Output channel.
        channel: usize,
    },
    /// SNR scaling needs noise with nonzero variance on the channel.
    #[error(
        "output channel {channel}: the generated noise has zero variance (noise model row is zero)"
    )]
    ZeroNoiseVariance {
        /// Output channel.
        channel: usize,
    },
    /// The loop has an algebraic loop (I + D_K D_G singular at some phase).
    #[error("algebraic loop: I + D_K D_G is singular (phase {phase} of the sampling pattern)")]
    AlgebraicLoop {
        /// Phase (sample index modulo the pattern period) where it is singular.
        phase: usize,
    },
    /// The simulation diverged (a signal exceeded the divergence limit or became non-finite).
    #[error(
        "simulation diverged at sample {sample}: {signal} = {value}, |{signal}| beyond {limit}"
    )]
    Diverged {
        /// Fast-grid sample index.
        sample: usize,
        /// Which signal ("y" or "u").
        signal: &'static str,
        /// The value reached.
        value: f64,
        /// The limit ([`crate::SimOptions::divergence_limit`]).
        limit: f64,
    },
    /// The periodic steady state does not exist: the one-period map is not contracting.
    #[error(
        "no periodic steady state: spectral radius of the one-period map is {spectral_radius} ≥ 1"
    )]
    UnstableLoop {
        /// Spectral radius of the monodromy matrix.
        spectral_radius: f64,
    },
    /// The iterative steady-state search did not reach the tolerance.
    #[error(
        "response not periodic after {periods} periods (residual {residual:.3e} > tolerance {tolerance:.3e})"
    )]
    NotPeriodic {
        /// Periods simulated.
        periods: usize,
        /// Final residual.
        residual: f64,
        /// Requested tolerance.
        tolerance: f64,
    },
    /// The excitation period is incompatible with the sampling pattern.
    #[error("excitation period {period} is not a multiple of the sampling-pattern period {frame}")]
    PeriodMismatch {
        /// Excitation period (samples).
        period: usize,
        /// Period of the holds/sampling pattern.
        frame: usize,
    },
    /// The antisymmetric periodicity check needs an even period.
    #[error("antisymmetry check needs an even period, got {period}")]
    OddPeriod {
        /// The period.
        period: usize,
    },
    /// An excitation has no samples.
    #[error("excitation is empty")]
    EmptyExcitation,
    /// The sampling/hold pattern repeats too rarely to tabulate.
    #[error(
        "the sampling/hold pattern repeats every {frame} samples (the least common multiple of the input holds, output periods and controller period), more than the limit of {max}; choose holds and periods with a smaller common multiple"
    )]
    PatternTooLong {
        /// The pattern's period (saturated at u64::MAX).
        frame: u64,
        /// The limit, [`crate::MAX_PATTERN_PERIOD`].
        max: usize,
    },
    /// A combination of options that the chosen loop structure does not support.
    #[error("unsupported: {what}")]
    Unsupported {
        /// What was requested.
        what: &'static str,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

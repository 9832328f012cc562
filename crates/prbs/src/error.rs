//! The crate's error type.

/// Errors returned by every fallible function of `lifted-prbs`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A linear-algebra kernel (the FFT of the correlations) failed.
    #[error(transparent)]
    Linalg(#[from] lifted_linalg::Error),
    /// The m-sequence order `n` is outside the supported range.
    #[error("PRBS order {order} is outside the supported range {min}..={max}")]
    OrderOutOfRange {
        /// Requested order.
        order: u32,
        /// Smallest supported order.
        min: u32,
        /// Largest supported order.
        max: u32,
    },
    /// A feedback tap is outside `1..=order`, repeated, or the top tap `order` is missing.
    #[error("invalid feedback taps {taps:?} for order {order}: {reason}")]
    InvalidTaps {
        /// Order of the register.
        order: u32,
        /// The taps given.
        taps: Vec<u32>,
        /// What is wrong with them.
        reason: &'static str,
    },
    /// The taps are valid but their polynomial is not primitive (period < 2ⁿ − 1).
    #[error("taps {taps:?} of order {order} do not give a maximal-length sequence")]
    NotMaximal {
        /// Order of the register.
        order: u32,
        /// The taps given.
        taps: Vec<u32>,
    },
    /// An amplitude is zero, negative, NaN or infinite.
    #[error("amplitude {amplitude} must be finite and positive")]
    InvalidAmplitude {
        /// The rejected amplitude.
        amplitude: f64,
    },
    /// The hold factor `n_r` (eq. II-7) or a lifting factor is zero.
    #[error("{what} must be at least 1, got {value}")]
    ZeroFactor {
        /// Which factor (`"hold n_r"`, `"lifting factor n"`, ...).
        what: &'static str,
        /// The rejected value.
        value: usize,
    },
    /// A probability is outside `(0, 1]`.
    #[error("switching probability {probability} must lie in (0, 1]")]
    InvalidProbability {
        /// The rejected probability.
        probability: f64,
    },
    /// A multichannel plan was asked for with no channel.
    #[error("the channel set is empty")]
    EmptyChannelSet,
    /// Too many channels for the mutually shifted scheme.
    #[error(
        "{channels} channels cannot be shifted apart within a half period of {half_period} samples"
    )]
    TooManyChannels {
        /// Number of channels requested.
        channels: usize,
        /// Half period (slow samples) available for the shifts.
        half_period: usize,
    },
    /// A time, frequency or rate is zero, negative, NaN or infinite.
    #[error("{what} = {value} must be finite and positive")]
    InvalidParameter {
        /// Name of the parameter.
        what: &'static str,
        /// The rejected value.
        value: f64,
    },
    /// A multisine harmonic band is empty or does not fit below Nyquist.
    #[error(
        "multisine harmonics {first}..={last} are invalid for period {period} (need 1 <= first <= last < period/2)"
    )]
    InvalidHarmonics {
        /// First harmonic.
        first: usize,
        /// Last harmonic.
        last: usize,
        /// Period in samples.
        period: usize,
    },
    /// A signal or record has no sample.
    #[error("{what} is empty")]
    EmptySignal {
        /// Which signal.
        what: &'static str,
    },
    /// Two records that must have the same length do not.
    #[error("length mismatch: {left} vs {right} samples")]
    LengthMismatch {
        /// Length of the first record.
        left: usize,
        /// Length of the second record.
        right: usize,
    },
    /// A record length is not a multiple of a required factor.
    #[error("length {len} is not a multiple of {factor}")]
    NotMultiple {
        /// The record length.
        len: usize,
        /// The required factor.
        factor: usize,
    },
    /// A sample is NaN or infinite.
    #[error("{what}[{index}] is not finite")]
    NonFinite {
        /// Which signal.
        what: &'static str,
        /// Index of the first non-finite sample.
        index: usize,
    },
    /// A period count or record length is zero.
    #[error("{what} must be at least 1")]
    ZeroLength {
        /// Which quantity.
        what: &'static str,
    },
    /// A multisine whose harmonics times computed samples exceed the work
    /// limit (one period, or the whole signal when it is shorter, is
    /// computed harmonic by harmonic).
    #[error(
        "a multisine of {harmonics} harmonics over {samples} computed samples needs {work} cosine evaluations, more than the limit of {max}; use fewer harmonics or a shorter period"
    )]
    TooManyHarmonics {
        /// Harmonics requested.
        harmonics: u128,
        /// Samples computed (one period, or the signal when shorter).
        samples: u128,
        /// Their product.
        work: u128,
        /// The limit, [`crate::MAX_SIGNAL_ENTRIES`] × 16.
        max: u128,
    },
    /// A requested signal would not fit in memory.
    #[error(
        "the signal would have {samples} entries, more than the limit of {max}; generate it in blocks with `InversePrbs::iter` or `generate`"
    )]
    TooLong {
        /// Entries requested (samples × channels).
        samples: u128,
        /// The limit, [`crate::MAX_SIGNAL_ENTRIES`].
        max: u128,
    },
    /// The design request cannot be met by any supported order.
    #[error(
        "no PRBS order up to {max_order} reaches a fundamental of {slowest_mode_hz} Hz with T_p = {generation_period} s"
    )]
    DesignInfeasible {
        /// Slowest mode to excite (Hz).
        slowest_mode_hz: f64,
        /// PRBS generation period T_p (s).
        generation_period: f64,
        /// Largest supported order.
        max_order: u32,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// Checks that `amplitude` is finite and positive.
pub(crate) fn check_amplitude(amplitude: f64) -> Result<()> {
    if amplitude.is_finite() && amplitude > 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidAmplitude { amplitude })
    }
}

/// Checks that a positive parameter is finite and `> 0`.
pub(crate) fn check_positive(what: &'static str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidParameter { what, value })
    }
}

/// Checks that a factor is at least one.
pub(crate) fn check_factor(what: &'static str, value: usize) -> Result<()> {
    if value == 0 {
        Err(Error::ZeroFactor { what, value })
    } else {
        Ok(())
    }
}

/// Checks that every sample is finite.
pub(crate) fn check_finite(what: &'static str, x: &[f64]) -> Result<()> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(Error::NonFinite { what, index }),
        None => Ok(()),
    }
}

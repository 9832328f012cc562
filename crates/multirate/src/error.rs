//! The error type of `lifted-multirate`.

/// Errors of the multirate routines.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An error from `lifted-linalg`.
    #[error(transparent)]
    Linalg(#[from] lifted_linalg::Error),
    /// An error from `lifted-lti` (models, transfer functions).
    #[error(transparent)]
    Lti(#[from] lifted_lti::Error),
    /// An error of the data layer (`lifted_lti::data`).
    #[error(transparent)]
    Data(#[from] lifted_lti::DataError),
    /// An error from `lifted-subspace` (lifted identification).
    #[error(transparent)]
    Subspace(#[from] lifted_subspace::Error),
    /// Hold m and sampling n are not co-prime (thesis §4.2 assumes they are;
    /// absorb the common factor into the base period T, see
    /// [`crate::SisoRates::normalized`]).
    #[error(
        "hold m = {m} and sampling n = {n} are not co-prime (gcd {gcd}); use SisoRates::normalized"
    )]
    NotCoprime {
        /// Hold (base periods).
        m: usize,
        /// Sampling period (base periods).
        n: usize,
        /// Their greatest common divisor.
        gcd: usize,
    },
    /// A rate, hold, period or factor is invalid (zero, or incompatible with
    /// the frame).
    #[error("invalid {what}: {reason}")]
    InvalidRates {
        /// Which quantity.
        what: &'static str,
        /// Why.
        reason: String,
    },
    /// A record's length is not a multiple of the lifting period (use the
    /// explicit truncation option to drop the incomplete last frame).
    #[error("record length {len} is not a multiple of the lifting period {period}")]
    LengthNotMultiple {
        /// Record length (fast samples).
        len: usize,
        /// Lifting period J (fast samples).
        period: usize,
    },
    /// Too few samples for the requested operation.
    #[error("{what}: {got} samples, at least {needed} needed")]
    TooShort {
        /// What was too short.
        what: &'static str,
        /// Samples available.
        got: usize,
        /// Samples needed.
        needed: usize,
    },
    /// A NaN or an infinity where finite data are required (e.g. an output
    /// at an instant its channel samples).
    #[error("{what} has a non-finite value at row {row}, column {col}")]
    NonFinite {
        /// Which argument.
        what: &'static str,
        /// Row of the first offending entry.
        row: usize,
        /// Column of the first offending entry.
        col: usize,
    },
    /// Arguments have incompatible dimensions.
    #[error("dimension mismatch for {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// What was matched.
        what: &'static str,
        /// Expected, human readable.
        expected: String,
        /// Got, human readable.
        got: String,
    },
    /// The requested model order cannot be supported by the data or model.
    #[error("model order {order} too large: at most {max}")]
    OrderTooLarge {
        /// Requested order.
        order: usize,
        /// Largest admissible order.
        max: usize,
    },
    /// A matrix that must have full rank does not (e.g. the controllability
    /// matrix Φ_c of thesis §4.6.1 when the lifted model lost a delay).
    #[error("{what} is rank deficient: rank {rank}, {needed} needed")]
    RankDeficient {
        /// Which matrix.
        what: &'static str,
        /// Numerical rank.
        rank: usize,
        /// Rank needed.
        needed: usize,
    },
    /// The eigenvalue approach (§4.6.2) needs distinct eigenvalues of Ā and
    /// every mode excited by the last two lifted input columns.
    #[error("eigenvalue approach not applicable: {reason}")]
    EigenApproach {
        /// Why.
        reason: String,
    },
    /// Ā has an eigenvalue on or near the closed negative real axis (or
    /// zero), so its principal q-th root does not exist and the fast model is
    /// ambiguous (thesis Prop. 3, spec pitfalls 2–3).
    #[error(
        "no principal {root}{} root of the lifted A: eigenvalue {eigenvalue} on or near the negative real axis (aliasing, |n m T η| < π cannot hold)",
        ordinal_suffix(*.root)
    )]
    NoPrincipalRoot {
        /// Root order q.
        root: usize,
        /// Offending eigenvalue of Ā.
        eigenvalue: num_complex::Complex64,
    },
    /// The lifted model is not consistent with any fast model for the chosen
    /// extraction (e.g. an aliased principal root: B̄_{q−2} ≠ A_h B̄_{q−1}).
    #[error(
        "extracted fast model inconsistent with the lifted model: relative residual {residual:.3e} > {tol:.3e} ({what})"
    )]
    Inconsistent {
        /// Which relation failed.
        what: &'static str,
        /// Relative residual.
        residual: f64,
        /// Tolerance.
        tol: f64,
    },
    /// The m n delay inequalities (4.14) have an empty intersection.
    #[error("delay inequalities inconsistent: lower bound {lower} ≥ upper bound {upper}")]
    DelayInconsistent {
        /// max of the lower limits.
        lower: i64,
        /// min of the upper limits.
        upper: i64,
    },
    /// No significant lifted impulse-response coefficient within the lags.
    #[error(
        "no significant impulse response from lifted input {input} to lifted output {output} within {lags} lags"
    )]
    NoDelayDetected {
        /// Lifted input index.
        input: usize,
        /// Lifted output index.
        output: usize,
        /// Lags searched.
        lags: usize,
    },
    /// An identified or extracted model is unstable where stability is
    /// required.
    #[error("{what} is unstable: spectral radius {spectral_radius:.6}")]
    Unstable {
        /// Which model.
        what: &'static str,
        /// Largest eigenvalue modulus.
        spectral_radius: f64,
    },
    /// The operation does not support this configuration.
    #[error("unsupported: {what}: {reason}")]
    Unsupported {
        /// Which operation.
        what: &'static str,
        /// Why.
        reason: String,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// First non-finite entry of `m` as [`Error::NonFinite`] (lifted-linalg's
/// `check_finite`, re-tagged so callers match one variant of this crate).
pub(crate) fn check_finite(what: &'static str, m: &nalgebra::DMatrix<f64>) -> Result<()> {
    lifted_linalg::check_finite(what, m).map_err(|e| match e {
        lifted_linalg::Error::NonFinite { what, row, col } => Error::NonFinite { what, row, col },
        other => other.into(),
    })
}

pub(crate) fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// lcm(a, b), `None` when it overflows (lcm(0, ·) = 0).
pub(crate) fn checked_lcm(a: usize, b: usize) -> Option<usize> {
    if a == 0 || b == 0 {
        Some(0)
    } else {
        (a / gcd(a, b)).checked_mul(b)
    }
}

/// The English ordinal suffix of `n`: "st" (1, 21), "nd", "rd", "th" (4, 11–13).
pub(crate) fn ordinal_suffix(n: usize) -> &'static str {
    match (n % 10, n % 100) {
        (_, 11..=13) => "th",
        (1, _) => "st",
        (2, _) => "nd",
        (3, _) => "rd",
        _ => "th",
    }
}

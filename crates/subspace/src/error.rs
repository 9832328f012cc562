//! The error type of `lifted-subspace`.

/// Errors returned by the identification routines of this crate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An error from `lifted-linalg` (singular matrix, failed decomposition, …).
    #[error(transparent)]
    Linalg(#[from] lifted_linalg::Error),
    /// An error from `lifted-lti` (building the identified model).
    #[error(transparent)]
    Lti(#[from] lifted_lti::Error),
    /// An error of the data layer (incompatible experiments, …).
    #[error(transparent)]
    Data(#[from] lifted_lti::DataError),
    /// A data matrix contains NaN or an infinity where finite data are required.
    #[error("{what} contains a non-finite value at sample {row}, channel {col}")]
    NonFinite {
        /// Which argument (e.g. "u", "y").
        what: &'static str,
        /// Sample (row) of the first non-finite entry.
        row: usize,
        /// Channel (column) of the first non-finite entry.
        col: usize,
    },
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
    /// The correlation matrix of the Hankel data is not numerically positive
    /// definite or too ill conditioned for its Cholesky factor to be accurate
    /// ([`crate::Compression::Correlation`], or [`crate::Compression::Auto`]
    /// when streaming, where the data cannot be read again for the QR).
    #[error("correlation compression rejected: {reason}; use Compression::Qr")]
    IllConditionedCorrelation {
        /// Reciprocal condition number λ_min/λ_max of H Hᵀ (NaN after a
        /// Cholesky breakdown).
        rcond: f64,
        /// The smallest accepted value ([`crate::CORRELATION_RCOND_MIN`]).
        min: f64,
        /// Why, human readable.
        reason: String,
    },
    /// No experiment (data record) was given.
    #[error("no data: at least one experiment is needed")]
    NoData,
    /// The block-Hankel horizons are too long for the number of samples.
    #[error(
        "horizons past {past} + future {future} too long for {n_samples} samples: at least {min_samples} samples needed"
    )]
    HorizonTooLong {
        /// Past horizon (block rows).
        past: usize,
        /// Future horizon (block rows).
        future: usize,
        /// Samples available (all experiments).
        n_samples: usize,
        /// Samples needed.
        min_samples: usize,
    },
    /// A horizon is zero or otherwise invalid.
    #[error("invalid horizon {what} = {value}: {reason}")]
    InvalidHorizon {
        /// Which horizon.
        what: &'static str,
        /// The rejected value.
        value: usize,
        /// Why.
        reason: String,
    },
    /// The requested model order is zero or not below the number of rows of
    /// the extended observability matrix.
    #[error("model order {order} invalid: it must lie in 1..={max}")]
    OrderTooLarge {
        /// Requested order.
        order: usize,
        /// Largest admissible order (future horizon × outputs − 1, or the
        /// rank the data support).
        max: usize,
    },
    /// The input is not persistently exciting (its block-Hankel matrix is
    /// rank deficient), e.g. a constant input.
    #[error("{what} is not persistently exciting: numerical rank {rank}, {needed} needed")]
    NotExciting {
        /// Which signal ("u" or the instrument).
        what: &'static str,
        /// Numerical rank of its block-Hankel matrix.
        rank: usize,
        /// Rank needed.
        needed: usize,
    },
    /// The instrument has too few block rows: R₂₂ of the IV QR would have
    /// fewer columns than the model order (erratum L-16: α_p·dim f must
    /// exceed α·dim u + n).
    #[error(
        "instrument too short: {instrument_rows} instrument rows, more than {needed} needed (erratum L-16)"
    )]
    InstrumentTooShort {
        /// Rows of the instrument block-Hankel matrix (α_p · dim f).
        instrument_rows: usize,
        /// α · dim u + n.
        needed: usize,
    },
    /// A matrix that must have full column rank is rank deficient, e.g. Γ_R
    /// of the one-step multirate formula (7.27) when (C₂, A) is not
    /// observable (erratum L-18).
    #[error(
        "{what} is rank deficient: numerical rank {rank}, {needed} needed{}",
        rank_hint(what)
    )]
    RankDeficient {
        /// Which matrix.
        what: &'static str,
        /// Numerical rank found.
        rank: usize,
        /// Rank needed.
        needed: usize,
    },
    /// The identified model is unstable although a stable model was required.
    #[error("identified A is unstable: spectral radius {spectral_radius}")]
    Unstable {
        /// Spectral radius of the estimated A.
        spectral_radius: f64,
    },
    /// The estimated A is unstable and the record too long for the
    /// output-error regression that needs it: the (B, D, x₀) regressors
    /// simulate the model over the record and grow like ρ(A)ᵗ, by
    /// ρ^(N−1) over N samples. Beyond `max_growth` = 1/√ε the squared
    /// regressors span more than 1/ε, the first samples fall below rounding
    /// and the regression would end in overflow, a failed SVD or a spurious
    /// rank deficiency. Raised before the regression runs (typically an IV
    /// or shift-invariance estimate at very low SNR, or too high an order).
    #[error(
        "estimated A is unstable (spectral radius {spectral_radius:.6}): the {stage} simulates the model over {samples} samples, where its regressors would grow by ρ^(N−1) = {growth:.3e} > {max_growth:.1e}; lower the order, use enforce_stability or require_stable, or shorten the record"
    )]
    UnstableEstimate {
        /// Which regression needed the simulation.
        stage: &'static str,
        /// Spectral radius ρ of the estimated A (> 1).
        spectral_radius: f64,
        /// Samples N of the longest record.
        samples: usize,
        /// ρ^(N−1) (may be +∞).
        growth: f64,
        /// The largest accepted growth ([`crate::MAX_REGRESSOR_GROWTH`]).
        max_growth: f64,
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

/// The `what` of [`Error::NotExciting`] for the subspace methods' input
/// rows.
pub const INPUT_ROWS: &str = "u";
/// The `what` of [`Error::NotExciting`] for the IV method's instrument rows.
pub const INSTRUMENT_ROWS: &str = "instrument";
/// The `what` of [`Error::NotExciting`] for PBSID/SSARX's past inputs.
pub const VARX_REGRESSOR: &str = "past inputs (the input rows of the VARX regressor Z_p)";
/// The `what` of [`Error::NotExciting`] for PBSID/SSARX's past inputs and
/// outputs together (inputs tied to the outputs).
pub const VARX_PAST: &str = "past inputs and outputs (the VARX regressor Z_p; past outputs linearly dependent given the past inputs, e.g. a noise-free combination of outputs, need a shorter past horizon: leave it automatic to get the longest that works)";

impl Error {
    /// A [`Error::NonFinite`] of a block located in the whole stream: its
    /// sample moved by `by`, the samples pushed before the block (other
    /// errors as they are).
    pub(crate) fn after(self, by: usize) -> Self {
        match self {
            Error::NonFinite { what, row, col } => Error::NonFinite {
                what,
                row: row + by,
                col,
            },
            e => e,
        }
    }

    /// Whether this is a refusal of data whose rows built from the inputs
    /// are not persistently exciting — the subspace methods' input rows,
    /// the IV method's instrument rows (the inputs in open loop),
    /// PBSID/SSARX's past data — which a constant or tied input column
    /// causes (a caller can then look for one and name it).
    pub fn refuses_input_excitation(&self) -> bool {
        matches!(self, Error::NotExciting { what, .. }
            if [INPUT_ROWS, INSTRUMENT_ROWS, VARX_REGRESSOR, VARX_PAST].contains(what))
    }

    /// Whether this is the memory budget's refusal of a working matrix
    /// (`lifted_linalg::Error::TooLarge`), which a caller streaming a
    /// record meets before it knows the record's length.
    pub fn exceeds_memory_budget(&self) -> bool {
        matches!(self, Error::Linalg(lifted_linalg::Error::TooLarge { .. }))
    }
}

/// What a user can do about a rank-deficient `what` (empty when nothing
/// general applies).
fn rank_hint(what: &str) -> &'static str {
    match what {
        "B/D regressor" | "B/D instrument matrix" => {
            " (the input does not tell the model's modes apart: too few changes of the input (e.g. a few steps), or modes it does not excite; a lower order or a richer excitation)"
        }
        _ => "",
    }
}

/// [`Error::RankDeficient`] for `what` when `rank < needed`.
pub(crate) fn check_rank(what: &'static str, rank: usize, needed: usize) -> Result<()> {
    if rank < needed {
        return Err(Error::RankDeficient { what, rank, needed });
    }
    Ok(())
}

/// [`Error::NotExciting`] for `what` when `rank < needed`.
pub(crate) fn check_exciting(what: &'static str, rank: usize, needed: usize) -> Result<()> {
    if rank < needed {
        return Err(Error::NotExciting { what, rank, needed });
    }
    Ok(())
}

/// Rejects NaN/inf in a data matrix with [`Error::NonFinite`].
pub(crate) fn check_data(what: &'static str, m: &nalgebra::DMatrix<f64>) -> Result<()> {
    // Column-major: the first non-finite entry in storage order is the
    // first by column, then row (vectorised scan).
    match lifted_linalg::kernels::first_non_finite(m.as_slice()) {
        Some(i) => Err(non_finite_at(what, m, i)),
        None => Ok(()),
    }
}

/// [`Error::NonFinite`] for the entry at column-major storage index `i`
/// of `m`.
pub(crate) fn non_finite_at(what: &'static str, m: &nalgebra::DMatrix<f64>, i: usize) -> Error {
    Error::NonFinite {
        what,
        row: i % m.nrows(),
        col: i / m.nrows(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rank_deficient_regressor_says_what_to_do() {
        let e = Error::RankDeficient {
            what: "B/D regressor",
            rank: 5,
            needed: 9,
        };
        let msg = e.to_string();
        assert!(
            msg.starts_with(
                "B/D regressor is rank deficient: numerical rank 5, 9 needed (the input"
            ),
            "{msg}"
        );
        assert!(
            msg.contains("a lower order or a richer excitation"),
            "{msg}"
        );
        // Other matrices keep the plain message.
        let e = Error::RankDeficient {
            what: "Γ_R",
            rank: 2,
            needed: 3,
        };
        assert_eq!(
            e.to_string(),
            "Γ_R is rank deficient: numerical rank 2, 3 needed"
        );
    }
}

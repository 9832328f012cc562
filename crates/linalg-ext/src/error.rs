//! The error type of `lifted-linalg`.

use num_complex::Complex64;

/// Errors returned by the kernels of this crate.
///
/// Every public function validates the shape and finiteness of its inputs and
/// reports the first problem it finds, naming the argument (`what`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An input contains NaN or an infinity.
    #[error("{what} contains a non-finite value (NaN or infinity) at ({row}, {col})")]
    NonFinite {
        /// Name of the offending argument.
        what: &'static str,
        /// Row of the first non-finite entry.
        row: usize,
        /// Column of the first non-finite entry.
        col: usize,
    },
    /// A matrix that must be square is not.
    #[error("{what} must be square, got {rows}x{cols}")]
    NotSquare {
        /// Name of the offending argument.
        what: &'static str,
        /// Number of rows.
        rows: usize,
        /// Number of columns.
        cols: usize,
    },
    /// Two arguments have incompatible dimensions.
    #[error("dimension mismatch for {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// What was being matched.
        what: &'static str,
        /// Expected dimension(s), human readable (e.g. "5 rows").
        expected: String,
        /// Actual dimension(s), human readable.
        got: String,
    },
    /// An input is empty where data are required.
    #[error("{what} is empty")]
    Empty {
        /// Name of the offending argument.
        what: &'static str,
    },
    /// An argument is outside its valid range (e.g. a root of order 0).
    #[error("invalid argument {what}: {reason}")]
    InvalidArgument {
        /// Name of the offending argument.
        what: &'static str,
        /// Why it is invalid.
        reason: String,
    },
    /// A matrix is (numerically) singular where an inverse is needed.
    #[error("{what} is singular to working precision (reciprocal condition {rcond:e})")]
    Singular {
        /// Name of the offending matrix.
        what: &'static str,
        /// Estimated reciprocal condition number.
        rcond: f64,
    },
    /// A matrix that must be symmetric positive (semi)definite is not.
    #[error("{what} is not positive definite")]
    NotPositiveDefinite {
        /// Name of the offending matrix.
        what: &'static str,
    },
    /// The principal branch of a matrix function does not exist
    /// (e.g. logarithm or root of a matrix with an eigenvalue on the closed
    /// negative real axis).
    #[error(
        "{what}: no principal branch, eigenvalue {eigenvalue} lies on or near the closed negative real axis"
    )]
    NoPrincipalBranch {
        /// Which function failed (e.g. "logm").
        what: &'static str,
        /// The eigenvalue that prevents the principal branch.
        eigenvalue: Complex64,
    },
    /// A matrix equation has no unique solution (e.g. a Lyapunov equation
    /// whose operator is singular because eigenvalues pair up to 1 or 0).
    #[error("{what} has no unique solution: {reason}")]
    NoUniqueSolution {
        /// Which equation.
        what: &'static str,
        /// Why.
        reason: String,
    },
    /// A Riccati equation has no stabilizing solution (or it could not be
    /// computed to the required accuracy).
    #[error("{what} has no stabilizing solution: {reason}")]
    NoStabilizingSolution {
        /// Which equation.
        what: &'static str,
        /// Why (e.g. the closed-loop spectral radius or the residual).
        reason: String,
    },
    /// Too few observations for the requested computation.
    #[error("{what}: {got} observations, at least {needed} needed")]
    NotEnoughData {
        /// Which computation or argument.
        what: &'static str,
        /// Observations supplied.
        got: usize,
        /// Minimum required.
        needed: usize,
    },
    /// A data matrix is (numerically) rank deficient where full rank is
    /// required.
    #[error("{what} is rank deficient: numerical rank {rank}, {needed} needed")]
    RankDeficient {
        /// Name of the offending argument.
        what: &'static str,
        /// Numerical rank found.
        rank: usize,
        /// Rank required.
        needed: usize,
    },
    /// An iterative algorithm failed to converge.
    #[error("{what} did not converge after {iterations} iterations")]
    NoConvergence {
        /// Which algorithm.
        what: &'static str,
        /// Iterations performed.
        iterations: usize,
    },
    /// A request would need more memory than the budget allows
    /// ([`crate::budget::MemoryBudget`]): refused before anything is
    /// allocated.
    #[error(
        "{what} needs {} of memory, more than the budget of {} (half the physical memory by default); \
         make it smaller (the horizons, order, periods or the number of steps or samples that size it), \
         or set LIFTED_MEMORY_LIMIT=<bytes> to raise the budget",
        crate::units::format_bytes(*needed_bytes),
        crate::units::format_bytes(*budget_bytes)
    )]
    TooLarge {
        /// What would have been allocated.
        what: &'static str,
        /// Bytes needed (`u64::MAX` when the size overflows 64 bits).
        needed_bytes: u64,
        /// The budget in bytes.
        budget_bytes: u64,
    },
    /// The backend decomposition failed.
    #[error("{what} failed in the backend: {reason}")]
    Backend {
        /// Which decomposition.
        what: &'static str,
        /// Backend message.
        reason: String,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

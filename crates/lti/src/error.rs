//! The error type of `lifted-lti`.

use num_complex::Complex64;

/// Errors returned by `lifted-lti`.
///
/// Input validation errors from the linear-algebra layer (NaN/infinity,
/// non-square or mismatched matrices) arrive as [`Error::Linalg`] and keep
/// their structured fields (`what`, `row`, `col`, …).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An error from `lifted-linalg` (non-finite entry, wrong shape, singular
    /// matrix, no principal logarithm, …).
    #[error(transparent)]
    Linalg(#[from] lifted_linalg::Error),
    /// An error about a data set (validation, slicing, lifting, CSV), from
    /// [`crate::data`].
    #[error(transparent)]
    Data(#[from] crate::data::DataError),
    /// A scalar argument is NaN or infinite.
    #[error("{what} is not finite ({value})")]
    NonFiniteScalar {
        /// Name of the argument.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// Two arguments have incompatible dimensions.
    #[error("dimension mismatch for {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// What was being matched.
        what: &'static str,
        /// Expected dimension, human readable.
        expected: String,
        /// Actual dimension, human readable.
        got: String,
    },
    /// An entry index of a MIMO model is out of range.
    #[error("entry ({row}, {col}) is out of range for a {rows}×{cols} model")]
    IndexOutOfRange {
        /// Requested output index.
        row: usize,
        /// Requested input index.
        col: usize,
        /// Outputs of the model.
        rows: usize,
        /// Inputs of the model.
        cols: usize,
    },
    /// A sample period is not positive and finite.
    #[error("invalid sample period {ts}: must be positive and finite")]
    InvalidSamplePeriod {
        /// The rejected value.
        ts: f64,
    },
    /// Two systems live in different time domains (continuous vs discrete, or
    /// different sample periods).
    #[error("{what}: time domains differ (ts {left:?} vs {right:?}; None = continuous)")]
    DomainMismatch {
        /// Which operation.
        what: &'static str,
        /// Sample period of the left operand (None: continuous).
        left: Option<f64>,
        /// Sample period of the right operand (None: continuous).
        right: Option<f64>,
    },
    /// The operation needs a continuous-time system.
    #[error("{what} needs a continuous-time system")]
    NotContinuous {
        /// Which operation.
        what: &'static str,
    },
    /// The operation needs a discrete-time system.
    #[error("{what} needs a discrete-time system")]
    NotDiscrete {
        /// Which operation.
        what: &'static str,
    },
    /// A transfer function has more zeros than poles where a proper one is needed.
    #[error(
        "transfer function entry ({row}, {col}) is improper: numerator degree {num_degree} > denominator degree {den_degree}"
    )]
    ImproperTransferFunction {
        /// Output index of the entry.
        row: usize,
        /// Input index of the entry.
        col: usize,
        /// Degree of the numerator.
        num_degree: usize,
        /// Degree of the denominator.
        den_degree: usize,
    },
    /// A denominator polynomial is identically zero.
    #[error("{what}: zero denominator")]
    ZeroDenominator {
        /// Where.
        what: &'static str,
    },
    /// A polynomial or transfer function argument is empty/zero where a
    /// nonzero one is required (e.g. the roots of the zero polynomial).
    #[error("{what}: {reason}")]
    InvalidArgument {
        /// Name of the argument.
        what: &'static str,
        /// Why it was rejected.
        reason: String,
    },
    /// The feedthrough (or another matrix) is singular where an inverse is needed.
    #[error("{what} is not invertible: {reason}")]
    NotInvertible {
        /// Which object.
        what: &'static str,
        /// Why.
        reason: String,
    },
    /// A feedback interconnection is ill-posed: I − s·D₁D₂ is singular.
    #[error("feedback loop is ill-posed (algebraic loop): I - sign*D1*D2 is singular")]
    AlgebraicLoop,
    /// `d2c`: the discrete system has an eigenvalue of [A B; 0 I] on the closed
    /// negative real axis (e.g. a pole at 0 or at z < 0), so no principal
    /// logarithm and no continuous ZOH equivalent exists.
    #[error(
        "no continuous-time ZOH equivalent: eigenvalue {eigenvalue} of [A B; 0 I] lies on the closed negative real axis"
    )]
    NoContinuousEquivalent {
        /// The offending eigenvalue.
        eigenvalue: Complex64,
    },
    /// A stable system is required.
    #[error("{what} requires a stable system; pole {pole} is not inside the stability region")]
    Unstable {
        /// Which operation.
        what: &'static str,
        /// A pole outside the stability region.
        pole: Complex64,
    },
    /// The requested quantity is infinite (e.g. the H2 norm of a continuous
    /// system with D ≠ 0, or the DC gain with a pole at s = 0 / z = 1).
    #[error("{what} is infinite: {reason}")]
    Infinite {
        /// Which quantity.
        what: &'static str,
        /// Why.
        reason: String,
    },
    /// An iterative algorithm did not converge.
    #[error("{what} did not converge after {iterations} iterations")]
    NoConvergence {
        /// Which algorithm.
        what: &'static str,
        /// Iterations performed.
        iterations: usize,
    },
    /// A polynomial coefficient of a [`crate::PolyModel`] is NaN or infinite.
    #[error("polynomial {which}({row}, {col}): coefficient {index} is not finite ({value})")]
    NonFiniteCoefficient {
        /// Which polynomial ("A", "B", "C", "D" or "F").
        which: &'static str,
        /// Output index (row of the polynomial matrix).
        row: usize,
        /// Column of the polynomial matrix (input index for B and F, output
        /// index for A, 0 for C and D).
        col: usize,
        /// Index of the coefficient (power of q⁻¹, counted from the first
        /// stored coefficient).
        index: usize,
        /// Its value.
        value: f64,
    },
    /// A polynomial of a [`crate::PolyModel`] does not start with the
    /// required leading coefficient: 1 for the diagonal of A and for C, D
    /// and F (monic), 0 for the off-diagonal entries of A (and every
    /// polynomial must have at least that leading coefficient).
    #[error("polynomial {which}({row}, {col}) must start with {expected}, got {got:?}")]
    NonMonicPolynomial {
        /// Which polynomial ("A", "C", "D" or "F").
        which: &'static str,
        /// Output index (row of the polynomial matrix).
        row: usize,
        /// Column of the polynomial matrix (see [`Error::NonFiniteCoefficient`]).
        col: usize,
        /// The required leading coefficient.
        expected: f64,
        /// The leading coefficient found (None: the polynomial is empty).
        got: Option<f64>,
    },
    /// A parameter vector does not have one entry per free parameter of the
    /// model structure.
    #[error("parameter vector of length {got}, the model structure has {expected} free parameters")]
    ParameterCount {
        /// Number of free parameters of the structure.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// A model cannot be written exactly in the requested form (e.g. a
    /// multi-output noise model with cross-couplings as diagonal C/D
    /// polynomials).
    #[error("{what}: not representable: {reason}")]
    NotRepresentable {
        /// Which conversion.
        what: &'static str,
        /// What cannot be represented.
        reason: String,
    },
    /// JSON (de)serialisation failed.
    #[error("JSON: {reason}")]
    Json {
        /// The serde_json message.
        reason: String,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// Rejects NaN/inf scalars.
pub(crate) fn check_scalar(what: &'static str, value: f64) -> Result<()> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(Error::NonFiniteScalar { what, value })
    }
}

/// Rejects sample periods that are not positive and finite.
pub(crate) fn check_ts(ts: Option<f64>) -> Result<()> {
    match ts {
        Some(t) if !(t.is_finite() && t > 0.0) => Err(Error::InvalidSamplePeriod { ts: t }),
        _ => Ok(()),
    }
}

/// Two sample periods describe the same domain (relative tolerance 1e-9).
pub(crate) fn same_domain(a: Option<f64>, b: Option<f64>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(x), Some(y)) => (x - y).abs() <= 1e-9 * x.abs().max(y.abs()),
        _ => false,
    }
}

/// Fails with [`Error::DomainMismatch`] unless both domains agree.
pub(crate) fn check_domain(what: &'static str, a: Option<f64>, b: Option<f64>) -> Result<()> {
    if same_domain(a, b) {
        Ok(())
    } else {
        Err(Error::DomainMismatch {
            what,
            left: a,
            right: b,
        })
    }
}

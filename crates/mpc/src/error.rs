//! The error type of `lifted-mpc`.

/// Errors of the MPC and inferential-control routines.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Horizons must satisfy 1 ≤ control ≤ prediction.
    #[error(
        "invalid horizons: prediction {prediction}, control {control} (need 1 <= control <= prediction)"
    )]
    InvalidHorizon {
        /// Prediction horizon h.
        prediction: usize,
        /// Control horizon m.
        control: usize,
    },
    /// A weight (or the resulting QP Hessian) is not positive (semi)definite.
    #[error("{what} is not positive {kind}definite (smallest eigenvalue {min_eigenvalue:e})")]
    NotPositiveDefinite {
        /// Which matrix.
        what: &'static str,
        /// "semi-" for weights that may be singular, "" otherwise.
        kind: &'static str,
        /// Its smallest eigenvalue.
        min_eigenvalue: f64,
    },
    /// Two sizes that must agree do not.
    #[error("dimension mismatch in {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// What was compared.
        what: &'static str,
        /// Expected size.
        expected: usize,
        /// Size found.
        got: usize,
    },
    /// The model or plant must be strictly proper (D = 0), discrete, etc.
    #[error("{what}: {reason}")]
    InvalidModel {
        /// Which model.
        what: &'static str,
        /// Why.
        reason: String,
    },
    /// Constraint data are inconsistent (e.g. u_min > u_max, negative rate limit).
    #[error("invalid constraint {what}: {reason}")]
    InvalidConstraint {
        /// Which limit.
        what: &'static str,
        /// Why.
        reason: String,
    },
    /// The constrained MPC problem has no feasible move sequence.
    #[error("the constrained MPC problem is infeasible (QP status {status})")]
    Infeasible {
        /// Solver status reported by clarabel.
        status: String,
    },
    /// The QP/SOCP solver (clarabel) stopped without a solution or an
    /// infeasibility certificate.
    #[error("conic solver failed: {reason}")]
    Solver {
        /// Status or setup error of the solver.
        reason: String,
    },
    /// NaN or infinite data.
    #[error("{what} contains NaN or infinite values")]
    NonFinite {
        /// Which input.
        what: &'static str,
    },
    /// An argument is out of its range.
    #[error("invalid argument {what}: {reason}")]
    InvalidArgument {
        /// Which argument.
        what: &'static str,
        /// Why.
        reason: String,
    },
    /// A loop that must be stable is not.
    #[error("{what} is unstable (spectral radius {spectral_radius})")]
    Unstable {
        /// Which loop.
        what: &'static str,
        /// Largest |eigenvalue| found.
        spectral_radius: f64,
    },
    /// An iteration stopped before its tolerance was met.
    #[error("{what} did not converge in {iterations} iterations (gap {gap:e})")]
    NoConvergence {
        /// Which iteration.
        what: &'static str,
        /// Iterations performed.
        iterations: usize,
        /// Remaining gap between its upper and lower bounds.
        gap: f64,
    },
    /// A computation whose work is set by its options (e.g. the slow period
    /// n and the θ grid of β_dr) would exceed its work bound
    /// ([`crate::RobustnessOptions::max_work`]).
    #[error(
        "{what} needs about {flops:.2e} floating-point operations, more than the bound of {limit:.2e}; {hint}"
    )]
    TooMuchWork {
        /// Which computation.
        what: &'static str,
        /// Estimated operations.
        flops: f64,
        /// The bound.
        limit: f64,
        /// Which options lower the work.
        hint: &'static str,
    },
    /// Error from `lifted-linalg` (including `TooLarge`: a horizon or
    /// period whose matrices would exceed the memory budget).
    #[error(transparent)]
    Linalg(#[from] lifted_linalg::Error),
    /// Error from `lifted-lti`.
    #[error(transparent)]
    Lti(#[from] lifted_lti::Error),
    /// Error from `lifted-multirate` (lifting).
    #[error(transparent)]
    Multirate(#[from] lifted_multirate::Error),
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

pub(crate) fn check_finite_slice(what: &'static str, v: &[f64]) -> Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(Error::NonFinite { what })
    }
}

/// [`Error::InvalidArgument`] "must be at least 1" when `n = 0` (a period,
/// lifting factor or count).
pub(crate) fn check_at_least_one(what: &'static str, n: usize) -> Result<()> {
    if n == 0 {
        return Err(Error::InvalidArgument {
            what,
            reason: "must be at least 1".into(),
        });
    }
    Ok(())
}

/// Checks the length and finiteness of each (name, vector, expected length).
pub(crate) fn check_vectors(
    items: &[(&'static str, &nalgebra::DVector<f64>, usize)],
) -> Result<()> {
    for &(what, v, n) in items {
        if v.len() != n {
            return Err(Error::DimensionMismatch {
                what,
                expected: n,
                got: v.len(),
            });
        }
        check_finite_slice(what, v.as_slice())?;
    }
    Ok(())
}

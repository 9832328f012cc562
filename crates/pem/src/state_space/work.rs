//! The work model of the refinement, in floating-point operations: what
//! [`super::PemOptions::max_work`] bounds and [`super::pem_work_estimate`]
//! predicts.

/// Model dimensions and data sizes of one pass.
#[derive(Debug, Clone, Copy)]
pub(super) struct Sizes {
    pub(super) n: usize,
    pub(super) nu: usize,
    pub(super) ny: usize,
    /// Time steps.
    pub(super) samples: usize,
    /// Measured output samples (rows of the Jacobian).
    pub(super) measured: usize,
    /// Threads of the Jacobian (> 1: the recursion runs twice).
    pub(super) threads: usize,
    /// Hessian subsample: about one measured row in this many enters the
    /// QR.
    pub(super) hessian_stride: usize,
}

impl Sizes {
    /// One sweep of the sensitivity recursion with `width` directions
    /// (≈ 2·width·n·(n + n_u + n_y) flops per sample, counted twice with
    /// threads: the recursion then runs twice over all but the last range) and
    /// the R-only QR of its rows of width + 1 columns (≈ 2·(width + 1)²
    /// flops per measured sample).
    pub(super) fn jacobian_pass(&self, width: usize) -> f64 {
        let (n, nu, ny, w) = (self.n as f64, self.nu as f64, self.ny as f64, width as f64);
        let runs = if self.threads > 1 { 2.0 } else { 1.0 };
        runs * 2.0 * w * self.samples as f64 * n * (n + nu + ny)
            + 2.0 * (w + 1.0).powi(2) * self.measured as f64 / self.hessian_stride.max(1) as f64
    }

    /// One run of the predictor (≈ 2·n·(n + n_u + n_y) flops per sample).
    pub(super) fn residual_pass(&self) -> f64 {
        let (n, nu, ny) = (self.n as f64, self.nu as f64, self.ny as f64);
        2.0 * self.samples as f64 * n * (n + nu + ny)
    }
}

/// The null space of the n² × `len` similarity tangent (an SVD,
/// ≈ 4·len·n⁴ + 4·len³/3 for the full right basis).
pub(super) fn tangent_basis(n: usize, len: usize) -> f64 {
    let (n, len) = (n as f64, len as f64);
    4.0 * len * n.powi(4) + 4.0 * len.powi(3) / 3.0
}

/// Work of the variable-projection iterations on data of `sizes`, with
/// `linear` parameters (B̄, free D, K, x₀) eliminated and `nonlinear`
/// ones (Ā, C) iterated on.
#[derive(Debug, Clone, Copy)]
pub(super) struct ProjectionWork {
    /// The basis and the Jacobian of all directions at an accepted iterate.
    pub(super) jacobian: f64,
    /// One trial step: the LM solve, the linear parameters re-solved at
    /// the trial (a Jacobian pass over their directions only) and its
    /// residuals.
    pub(super) trial: f64,
    /// One trial with β from the Gauss–Newton model (Hessian subsample):
    /// the LM solve and a predictor run.
    pub(super) model_trial: f64,
}

impl ProjectionWork {
    pub(super) fn new(sizes: &Sizes, linear: usize, nonlinear: usize) -> ProjectionWork {
        let n2 = sizes.n * sizes.n;
        let local = nonlinear.saturating_sub(n2);
        let (pl, pn) = (linear as f64, local as f64);
        ProjectionWork {
            jacobian: tangent_basis(sizes.n, nonlinear) + sizes.jacobian_pass(linear + local),
            trial: sizes.jacobian_pass(linear)
                + sizes.residual_pass()
                + 4.0 * (pn.powi(3) + pl.powi(3)),
            model_trial: sizes.residual_pass() + 4.0 * pn.powi(3) + 2.0 * pl * pl * pn,
        }
    }
}

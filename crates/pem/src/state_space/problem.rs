//! What every iteration scheme shares: the records and their weights, the
//! parameter layout, the stopping rules, the work account and the outcome.

use nalgebra::DVector;

use super::Termination;
use super::point::{Layout, Point, residuals};
use lifted_subspace::Record;

/// The data of one minimisation: records, output weights, layout.
pub(super) struct Problem<'a, 'r> {
    pub(super) lay: &'a Layout,
    pub(super) records: &'a [Record<'r>],
    pub(super) weights: &'a [f64],
    pub(super) gain: bool,
    pub(super) threads: usize,
    /// Measured output samples of `records`.
    pub(super) measured: usize,
    /// Time steps of `records`.
    pub(super) samples: usize,
    /// Hessian subsample of the variable-projection Jacobians (1 = all
    /// rows; [`super::jacobian`]).
    pub(super) hessian_stride: usize,
    /// [`super::PemOptions::marginal_tolerance`].
    pub(super) marginal: f64,
}

impl Problem<'_, '_> {
    /// Whether `p` is an admissible iterate ([`super::point::admissible`]).
    pub(super) fn admissible(&self, p: &Point) -> bool {
        super::point::admissible(p, self.gain, self.marginal)
    }

    /// Scaled residuals at `p` (`None`: unstable or not finite).
    pub(super) fn residuals(&self, p: &Point) -> Option<DVector<f64>> {
        residuals(p, self.records, self.weights, self.gain, self.measured)
    }
}

/// Stopping rules ([`super::PemOptions`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct Limits {
    pub(super) max_iterations: usize,
    pub(super) cost_tolerance: f64,
    pub(super) step_tolerance: f64,
    pub(super) gradient_tolerance: f64,
    /// Variable projection: stop when the Gauss–Newton step predicts a
    /// relative cost decrease below this.
    pub(super) expected_decrease_tolerance: f64,
}

/// The work spent so far against [`super::PemOptions::max_work`], in the
/// units of [`super::work`].
#[derive(Debug, Clone, Copy)]
pub(super) struct WorkAccount {
    pub(super) limit: f64,
    pub(super) spent: f64,
    /// Set when a step was not taken because the bound did not allow it.
    pub(super) stopped: bool,
}

impl WorkAccount {
    /// Books `flops` when they fit under the limit; `false` (and
    /// `stopped`) when they do not.
    pub(super) fn spend(&mut self, flops: f64) -> bool {
        if self.spent + flops > self.limit {
            self.stopped = true;
            return false;
        }
        self.spent += flops;
        true
    }
}

/// Where a minimisation ended.
pub(super) struct Outcome {
    pub(super) point: Point,
    /// Mean squared scaled residual at `point`.
    pub(super) cost: f64,
    pub(super) iterations: usize,
    pub(super) accepted: usize,
    pub(super) termination: Termination,
}

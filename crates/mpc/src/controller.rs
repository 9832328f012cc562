//! The controller interface used by the closed-loop simulator, and the
//! slow single-rate wrapper.

use nalgebra::DVector;

use crate::error::{Error, Result};
use crate::law::Moves;

/// A discrete controller run every fast period T.
pub trait Controller {
    /// Number of manipulated inputs.
    fn n_inputs(&self) -> usize;
    /// Number of controlled outputs.
    fn n_outputs(&self) -> usize;
    /// One update: `measured[q]` is `Some(y_q(t))` when output q is sampled
    /// at this instant and `None` between its slow samples; `reference` is
    /// the set-point r(t) (held over the horizon). Returns u(t).
    fn update(
        &mut self,
        measured: &[Option<f64>],
        reference: &DVector<f64>,
    ) -> Result<DVector<f64>>;
}

/// A receding-horizon controller ([`crate::Dmc`], [`crate::StateSpaceMpc`])
/// that exposes its whole move plan.
pub trait Predictive: Controller {
    /// One update: u(t) and the plan ΔU; with `force_qp` the QP is solved
    /// even when the closed form respects every limit.
    ///
    /// Errors: as [`Controller::update`], [`Error::Infeasible`].
    fn step_plan(
        &mut self,
        measured: &[Option<f64>],
        reference: &DVector<f64>,
        force_qp: bool,
    ) -> Result<(DVector<f64>, Moves)>;

    /// One update returning u(t) and the move plan.
    ///
    /// Errors: as [`Controller::update`].
    fn update_with_plan(
        &mut self,
        measured: &[Option<f64>],
        reference: &DVector<f64>,
    ) -> Result<(DVector<f64>, Moves)> {
        self.step_plan(measured, reference, false)
    }

    /// One update forced through the QP (to check that the QP path equals
    /// the closed form when no limit is active).
    ///
    /// Errors: as [`Controller::update`], [`Error::Infeasible`].
    fn update_qp(
        &mut self,
        measured: &[Option<f64>],
        reference: &DVector<f64>,
    ) -> Result<(DVector<f64>, Moves)> {
        self.step_plan(measured, reference, true)
    }
}

pub(crate) fn check_update_args(
    p: usize,
    measured: &[Option<f64>],
    reference: &DVector<f64>,
) -> Result<()> {
    if measured.len() != p {
        return Err(Error::DimensionMismatch {
            what: "measured outputs",
            expected: p,
            got: measured.len(),
        });
    }
    if reference.len() != p {
        return Err(Error::DimensionMismatch {
            what: "reference",
            expected: p,
            got: reference.len(),
        });
    }
    if measured.iter().flatten().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            what: "measured outputs",
        });
    }
    crate::error::check_finite_slice("reference", reference.as_slice())
}

/// The error of an update that leaves output `q` unmeasured before its
/// first sample (no estimate exists yet).
pub(crate) fn never_sampled(q: usize) -> Error {
    Error::InvalidArgument {
        what: "measured outputs",
        reason: format!("output {q} has never been sampled; the first update needs every output"),
    }
}

/// Runs an inner controller (designed on the slow model, see
/// [`crate::hold_model`]) every `period` fast samples and holds its input in
/// between: the slow single-rate control of thesis §3 / §8.1.
#[derive(Debug, Clone)]
pub struct SlowRate<C> {
    inner: C,
    period: usize,
    t: usize,
    held: DVector<f64>,
}

impl<C: Controller> SlowRate<C> {
    /// Wraps `inner`, updated at t = 0, period, 2·period, …
    ///
    /// Errors: `period = 0`.
    pub fn new(inner: C, period: usize) -> Result<Self> {
        crate::error::check_at_least_one("slow period", period)?;
        let m = inner.n_inputs();
        Ok(Self {
            inner,
            period,
            t: 0,
            held: DVector::zeros(m),
        })
    }
    /// The wrapped controller.
    pub fn inner(&self) -> &C {
        &self.inner
    }
}

impl<C: Controller> Controller for SlowRate<C> {
    fn n_inputs(&self) -> usize {
        self.inner.n_inputs()
    }
    fn n_outputs(&self) -> usize {
        self.inner.n_outputs()
    }
    fn update(
        &mut self,
        measured: &[Option<f64>],
        reference: &DVector<f64>,
    ) -> Result<DVector<f64>> {
        if self.t.is_multiple_of(self.period) {
            self.held = self.inner.update(measured, reference)?;
        }
        self.t += 1;
        Ok(self.held.clone())
    }
}

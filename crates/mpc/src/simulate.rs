//! Closed-loop simulation of a (possibly constrained, hence nonlinear)
//! controller on a discrete plant, step by step, and the performance figures.

use lifted_lti::StateSpace;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::controller::Controller;
use crate::error::{Error, Result};
use crate::model::check_model;

/// The experiment: set-points, disturbance and output sampling periods.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopSetup {
    /// Set-point r(t): one row per fast sample, one column per output.
    pub reference: DMatrix<f64>,
    /// Additive output disturbance d(t) (same shape), or `None`.
    pub output_disturbance: Option<DMatrix<f64>>,
    /// Sampling period of each output in fast samples (1 = every sample; the
    /// dual-rate case of Ch. 8 has n for the slow output).
    pub periods: Vec<usize>,
    /// Settling band as a fraction of each set-point step. Default 0.02.
    pub settle_band: f64,
}

impl LoopSetup {
    /// Set-points `reference`, every output sampled every `period`, no
    /// disturbance, 2 % settling band.
    pub fn new(reference: DMatrix<f64>, periods: Vec<usize>) -> Self {
        Self {
            reference,
            output_disturbance: None,
            periods,
            settle_band: 0.02,
        }
    }
}

/// Per-output performance of a closed-loop run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Performance {
    /// Integral of absolute error Σ_t |r_q(t) − y_q(t)| (fast samples, true
    /// output including the inter-sample values).
    pub iae: Vec<f64>,
    /// Largest overshoot over the set-point steps, as a fraction of the step.
    pub overshoot: Vec<f64>,
    /// Largest settling time (samples after a step until |y − r| stays within
    /// the band); `None` when some step does not settle before the next one.
    pub settling_time: Vec<Option<usize>>,
    /// Input energy Σ_t ‖u(t)‖².
    pub input_energy: f64,
}

/// Trajectories and performance of a closed-loop run.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopResult {
    /// True plant output y(t) (rows = samples).
    pub y: DMatrix<f64>,
    /// Applied input u(t).
    pub u: DMatrix<f64>,
    /// Performance figures.
    pub performance: Performance,
}

/// Simulates y(t) = C x(t) + d(t), u(t) = controller(measured y, r(t)),
/// x(t+1) = A x(t) + B u(t) from rest. O(steps · (order² + controller)).
///
/// Errors: plant not discrete/strictly proper, sizes of the set-up, the
/// controller's errors.
pub fn simulate(
    plant: &StateSpace,
    controller: &mut dyn Controller,
    setup: &LoopSetup,
) -> Result<LoopResult> {
    let (p, m) = check_model("plant", plant)?;
    if controller.n_outputs() != p {
        return Err(Error::DimensionMismatch {
            what: "controller outputs vs plant outputs",
            expected: p,
            got: controller.n_outputs(),
        });
    }
    if controller.n_inputs() != m {
        return Err(Error::DimensionMismatch {
            what: "controller inputs vs plant inputs",
            expected: m,
            got: controller.n_inputs(),
        });
    }
    let steps = setup.reference.nrows();
    if setup.reference.ncols() != p {
        return Err(Error::DimensionMismatch {
            what: "reference columns",
            expected: p,
            got: setup.reference.ncols(),
        });
    }
    if setup.periods.len() != p || setup.periods.contains(&0) {
        return Err(Error::InvalidArgument {
            what: "periods",
            reason: format!("need {p} sampling periods, each at least 1"),
        });
    }
    if let Some(d) = &setup.output_disturbance
        && d.shape() != setup.reference.shape()
    {
        return Err(Error::DimensionMismatch {
            what: "output disturbance rows",
            expected: steps,
            got: d.nrows(),
        });
    }
    let mut x = DVector::zeros(plant.order());
    let mut y = DMatrix::zeros(steps, p);
    let mut u = DMatrix::zeros(steps, m);
    for t in 0..steps {
        let mut yt = plant.c() * &x;
        if let Some(d) = &setup.output_disturbance {
            yt += d.row(t).transpose();
        }
        let meas: Vec<Option<f64>> = (0..p)
            .map(|q| t.is_multiple_of(setup.periods[q]).then_some(yt[q]))
            .collect();
        let r = setup.reference.row(t).transpose();
        let ut = controller.update(&meas, &r)?;
        if ut.len() != m || ut.iter().any(|v| !v.is_finite()) {
            return Err(Error::NonFinite {
                what: "controller output",
            });
        }
        y.row_mut(t).copy_from(&yt.transpose());
        u.row_mut(t).copy_from(&ut.transpose());
        x = plant.a() * x + plant.b() * ut;
    }
    let performance = performance(&y, &u, &setup.reference, setup.settle_band)?;
    Ok(LoopResult { y, u, performance })
}

/// IAE, overshoot, settling time per output and input energy of a record.
/// Set-point steps are detected as changes of r; the level before the first
/// segment is y(0).
///
/// Errors: shape mismatch, non-finite data, `band ≤ 0`.
pub fn performance(
    y: &DMatrix<f64>,
    u: &DMatrix<f64>,
    r: &DMatrix<f64>,
    band: f64,
) -> Result<Performance> {
    if y.shape() != r.shape() || u.nrows() != y.nrows() {
        return Err(Error::DimensionMismatch {
            what: "record rows",
            expected: y.nrows(),
            got: r.nrows().min(u.nrows()),
        });
    }
    if !(band > 0.0 && band.is_finite()) {
        return Err(Error::InvalidArgument {
            what: "settle band",
            reason: "must be positive".into(),
        });
    }
    for (what, mtx) in [("y", y), ("u", u), ("reference", r)] {
        crate::error::check_finite_slice(what, mtx.as_slice())?;
    }
    let (n, p) = y.shape();
    let mut iae = vec![0.0; p];
    let mut overshoot = vec![0.0; p];
    let mut settling = vec![Some(0usize); p];
    for q in 0..p {
        iae[q] = (0..n).map(|t| (r[(t, q)] - y[(t, q)]).abs()).sum();
        let mut start = 0;
        let mut prev_level = if n > 0 { y[(0, q)] } else { 0.0 };
        while start < n {
            let level = r[(start, q)];
            let mut end = start + 1;
            while end < n && r[(end, q)] == level {
                end += 1;
            }
            let step = level - prev_level;
            if step.abs() > 0.0 {
                let s = step.signum();
                let over = (start..end)
                    .map(|t| (y[(t, q)] - level) * s)
                    .fold(0.0, f64::max)
                    / step.abs();
                overshoot[q] = f64::max(overshoot[q], over);
                let tol = band * step.abs();
                let mut t0 = end;
                while t0 > start && (y[(t0 - 1, q)] - level).abs() <= tol {
                    t0 -= 1;
                }
                settling[q] = match (settling[q], t0 < end) {
                    (Some(prev), true) => Some(prev.max(t0 - start)),
                    _ => None,
                };
            }
            prev_level = level;
            start = end;
        }
    }
    let input_energy = u.iter().map(|v| v * v).sum();
    Ok(Performance {
        iae,
        overshoot,
        settling_time: settling,
        input_energy,
    })
}

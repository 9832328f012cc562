//! A warm start on the leading part of long records: the projected
//! iterations first run on the first [`super::PemOptions::warm_start_samples`]
//! samples (shared among the records in proportion to their lengths; x₀
//! is the same parameter there), to a loose cost tolerance, and then
//! finish on the whole records, where a start that close to the optimum
//! needs only a few iterations.

use nalgebra::DMatrix;

use super::point::Point;
use super::problem::{Limits, Outcome, Problem, WorkAccount};
use super::projection;
use crate::error::Result;
use crate::regress::Record;

/// Relative cost decrease that ends the iterations on the leading part:
/// the leading part's optimum differs from the whole records' by the
/// estimation error of the shorter record anyway, far more than this.
pub(super) const WARM_COST_TOLERANCE: f64 = 1e-6;

/// Variable projection on the whole records of `whole`, from the optimum
/// on their leading parts when they hold more than twice `warm_samples`
/// samples (and the leading parts support the parameters); the
/// iterations of both phases count against `limits.max_iterations`.
pub(super) fn minimise(
    whole: &Problem<'_, '_>,
    start: &Point,
    limits: &Limits,
    warm_samples: usize,
    account: &mut WorkAccount,
) -> Result<Outcome> {
    let mut from = start.clone();
    let (mut iterations, mut accepted) = (0, 0);
    if warm_samples > 0 && whole.samples > 2 * warm_samples {
        let share = warm_samples as f64 / whole.samples as f64;
        let parts: Vec<(DMatrix<f64>, DMatrix<f64>)> = whole
            .records
            .iter()
            .map(|r| {
                let len = ((r.u.nrows() as f64 * share).ceil() as usize).clamp(1, r.u.nrows());
                (r.u.rows(0, len).into_owned(), r.y.rows(0, len).into_owned())
            })
            .collect();
        let records: Vec<Record<'_>> = parts
            .iter()
            .map(|(u, y)| Record {
                u,
                y,
                instrument: None,
            })
            .collect();
        let measured = parts
            .iter()
            .map(|(_, y)| y.iter().filter(|v| !v.is_nan()).count())
            .sum();
        let free = whole.lay.len() - whole.lay.n * whole.lay.n;
        if crate::budget::check_pem_parameters(free, measured).is_ok() {
            let leading = Problem {
                lay: whole.lay,
                records: &records,
                weights: whole.weights,
                gain: whole.gain,
                threads: whole.threads,
                measured,
                samples: parts.iter().map(|(u, _)| u.nrows()).sum(),
            };
            let loose = Limits {
                cost_tolerance: limits.cost_tolerance.max(WARM_COST_TOLERANCE),
                ..*limits
            };
            let out = projection::minimise(&leading, start, &loose, account)?;
            iterations = out.iterations;
            accepted = out.accepted;
            from = out.point;
        }
    }
    let rest = Limits {
        max_iterations: limits.max_iterations.saturating_sub(iterations).max(1),
        ..*limits
    };
    let mut out = projection::minimise(whole, &from, &rest, account)?;
    out.iterations += iterations;
    out.accepted += accepted;
    Ok(out)
}

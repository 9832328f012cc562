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
use lifted_subspace::Record;

/// Relative cost decrease that ends the iterations on the leading part:
/// the leading part's optimum differs from the whole records' by the
/// estimation error of the shorter record anyway, far more than this.
pub(super) const WARM_COST_TOLERANCE: f64 = 1e-6;

/// Samples of the Hessian subsample on the whole records after a warm
/// start: its relative error, O(√(p / HESSIAN_SAMPLES)) for p
/// parameters, is the contraction factor of the remaining iterations
/// (the gradient is exact), ≈ 0.02 for p = 40.
pub(super) const HESSIAN_SAMPLES: usize = 100_000;

/// Growth of the leading part from one warm stage to the next.
pub(super) const STAGE_GROWTH: usize = 20;

/// Variable projection on the whole records of `whole`, after warm stages
/// on their leading parts: `warm_samples` samples, then
/// [`STAGE_GROWTH`] times more, … while a stage holds less than half the
/// samples (and supports the parameters). Each stage starts where the
/// previous one stopped, within the smaller record's estimation error of
/// its own optimum; the iterations of all stages count against
/// `limits.max_iterations`.
pub(super) fn minimise(
    whole: &Problem<'_, '_>,
    start: &Point,
    limits: &Limits,
    warm_samples: usize,
    account: &mut WorkAccount,
) -> Result<Outcome> {
    let mut from = start.clone();
    let (mut iterations, mut accepted) = (0, 0);
    let mut warmed = false;
    let mut size = warm_samples;
    while size > 0 && size.saturating_mul(2) < whole.samples && iterations < limits.max_iterations {
        let share = size as f64 / whole.samples as f64;
        size = size.saturating_mul(STAGE_GROWTH);
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
        if crate::budget::check_pem_parameters(free, measured).is_err() {
            continue;
        }
        let samples = parts.iter().map(|(u, _)| u.nrows()).sum();
        let leading = Problem {
            lay: whole.lay,
            records: &records,
            weights: whole.weights,
            gain: whole.gain,
            threads: whole.threads,
            measured,
            samples,
            hessian_stride: if warmed {
                (samples / HESSIAN_SAMPLES).max(1)
            } else {
                1
            },
            marginal: whole.marginal,
        };
        let loose = Limits {
            max_iterations: limits.max_iterations - iterations,
            cost_tolerance: limits.cost_tolerance.max(WARM_COST_TOLERANCE),
            expected_decrease_tolerance: limits
                .expected_decrease_tolerance
                .max(WARM_COST_TOLERANCE),
            ..*limits
        };
        let out = projection::minimise(&leading, &from, &loose, account)?;
        iterations += out.iterations;
        accepted += out.accepted;
        from = out.point;
        warmed = true;
    }
    let rest = Limits {
        max_iterations: limits.max_iterations.saturating_sub(iterations).max(1),
        ..*limits
    };
    // On the whole records (long ones only) the Gauss–Newton matrix of a
    // start this close to the optimum is estimated from a subsample of
    // about HESSIAN_SAMPLES samples; the gradient uses every sample.
    let whole = Problem {
        hessian_stride: whole_stride(whole.samples, warmed),
        ..*whole
    };
    let mut out = projection::minimise(&whole, &from, &rest, account)?;
    out.iterations += iterations;
    out.accepted += accepted;
    Ok(out)
}

/// Stages run before the whole records of `samples` samples
/// ([`minimise`]'s rule, without the check that a stage supports the
/// parameters).
pub(super) fn stage_sizes(samples: usize, warm_samples: usize) -> Vec<usize> {
    let mut sizes = Vec::new();
    let mut size = warm_samples;
    while size > 0 && size.saturating_mul(2) < samples {
        sizes.push(size);
        size = size.saturating_mul(STAGE_GROWTH);
    }
    sizes
}

/// The Hessian stride on the whole records of `samples` samples after
/// warm stages (1 without them).
pub(super) fn whole_stride(samples: usize, warmed: bool) -> usize {
    if warmed {
        (samples / HESSIAN_SAMPLES).max(1)
    } else {
        1
    }
}

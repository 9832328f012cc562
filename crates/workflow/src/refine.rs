//! The refinement stage: prediction-error or output-error refinement of the
//! identified model on the (detrended) records, measured samples only
//! (`lifted_subspace::refine_pem`). The report goes to
//! `diagnostics.refinement`; for the prediction error the Kalman gain is
//! replaced when the refined model is kept.

use lifted_lti::{Dataset, StateSpace};
use lifted_subspace::{Feedthrough, Kept, PemCost, PemOptions, Record, refine_pem};
use nalgebra::DMatrix;
use serde_json::json;

use crate::diagnostics::push_warning;
use crate::error::{Context, Result};
use crate::options::{Refine, RefinementOptions};

/// What the refinement's noise model is, and when it is consistent under
/// feedback (written to the diagnostics with every refinement).
const PEM_NOISE_MODEL: [&str; 2] = [
    "innovations form of the model's own order (Kalman gain K free; the direct prediction-error method): consistent on closed-loop data when the noise is the output of an innovations model of that order (its dynamics those of the plant, as in ARMAX); noise with dynamics of its own needs the order of plant and noise together (e.g. --method pbsid at that order) or an instrument (--method iv)",
    "none (output-error cost): consistent in open loop only; under feedback the noise reaches the input and the estimate is biased",
];

/// Refines `model` (and `kalman_gain`) on `sets` per `opts`; returns the
/// model kept and the diagnostics with the refinement's report. No
/// refinement: the model and diagnostics as given.
pub fn refine(
    opts: &RefinementOptions,
    model: StateSpace,
    mut diagnostics: serde_json::Value,
    sets: &[Dataset],
    kalman_gain: &mut Option<DMatrix<f64>>,
) -> Result<(StateSpace, serde_json::Value)> {
    let cost = match opts.refine {
        Refine::None => return Ok((model, diagnostics)),
        Refine::Pem => PemCost::Prediction,
        Refine::Oe => PemCost::OutputError,
    };
    if opts.iterations == 0 {
        return Err(crate::Error::option(
            "refine_iterations",
            "0: the refinement needs at least one iteration (or no refinement)",
        ));
    }
    if !(opts.max_work.is_finite() && opts.max_work > 0.0) {
        return Err(crate::Error::option(
            "refine_max_work",
            format!(
                "must be a positive number of operations, got {}",
                opts.max_work
            ),
        ));
    }
    let records: Vec<Record<'_>> = sets
        .iter()
        .map(|d| Record {
            u: d.u(),
            y: d.y(),
            instrument: None,
        })
        .collect();
    let feedthrough = if model.d().iter().all(|&v| v == 0.0) {
        Feedthrough::Zero
    } else {
        Feedthrough::Free
    };
    let pem = PemOptions {
        cost,
        feedthrough,
        max_iterations: opts.iterations,
        max_work: opts.max_work,
        ..Default::default()
    };
    let fit = refine_pem(&model, kalman_gain.as_ref(), &records, &[], &pem).ctx("refine")?;
    if let (Some(cap), lifted_subspace::Termination::MaxIterations) =
        (fit.report.iteration_cap, fit.report.termination)
    {
        push_warning(
            &mut diagnostics,
            format!(
                "--refine stopped by its work bound after {cap} iterations (--refine-max-work {:.1e} operations), before convergence: raise --refine-max-work for this record",
                opts.max_work
            ),
        );
    }
    if let Some(obj) = diagnostics.as_object_mut() {
        obj.insert(
            "refinement".into(),
            serde_json::to_value(&fit.report).unwrap_or(serde_json::Value::Null),
        );
        obj.insert(
            "refinement_noise_model".into(),
            json!(PEM_NOISE_MODEL[usize::from(cost == PemCost::OutputError)]),
        );
    }
    if fit.report.kept == Kept::Refined && cost == PemCost::Prediction {
        *kalman_gain = fit.kalman_gain.clone();
    }
    Ok((fit.model, diagnostics))
}

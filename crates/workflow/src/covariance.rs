//! The covariance stage (issue 49): a state-space model leaves the
//! workflow with the covariance of its entries (A, B, C, D), as MATLAB
//! gives every identified model one, from the prediction-error Jacobian at
//! the model returned (`lifted_pem::state_space_covariance`: exact to first
//! order for a refined model; for a subspace model kept as identified, the
//! covariance the prediction-error method would have there, which the less
//! efficient subspace estimate can exceed). The model file carries it
//! (`ModelFile::covariance`, in the data's units), `lifted bode`, `step`
//! and the report draw bands from it, and `diagnostics.covariance` says
//! what it rests on or why a model has none.
//!
//! Which D entries were estimated: those that are not exactly zero (the
//! routes set the entries they fix to 0.0; an estimated entry is never
//! exactly zero). The prediction errors are the innovations model's with
//! its Kalman gain when the model has one (and a stable predictor), else
//! the simulation errors. Work: one Jacobian pass, bounded by
//! [`crate::Budgets::covariance_work`] before anything runs.

use lifted_lti::{Dataset, SsCovariance, StateSpace};
use lifted_pem::{CovarianceOptions, PemCost, state_space_covariance};
use lifted_subspace::Feedthrough;
use nalgebra::DMatrix;
use serde_json::{Value, json};

use crate::options::WorkflowOptions;
use crate::refine::records_of;

/// The covariance of `model`'s entries on the (scaled) records `sets`, in
/// the records' units, with `diagnostics.covariance` set; `None` (and the
/// reason in the diagnostics) when the budget, the model or the records do
/// not allow it. Never fails the identification: the model stands without
/// a covariance.
pub(crate) fn of_model(
    opts: &WorkflowOptions,
    model: &StateSpace,
    kalman_gain: Option<&DMatrix<f64>>,
    sets: &[Dataset],
    diagnostics: &mut Value,
) -> Option<SsCovariance> {
    let t = std::time::Instant::now();
    let same_rate = model
        .ts()
        .zip(sets.first())
        .is_some_and(|(ts, d)| (ts - d.ts()).abs() <= 1e-9 * d.ts());
    let result = if !same_rate {
        Err("the model's sample period is not the records' (a lifted or slow model)".to_string())
    } else if model.order() == 0 {
        Err("a static model (order 0)".to_string())
    } else {
        let mask = model.d().map(|v| v != 0.0);
        let records = records_of(sets);
        let with_gain = kalman_gain.filter(|k| {
            lifted_linalg::spectral_radius(&(model.a() - *k * model.c())).is_ok_and(|r| r < 1.0)
        });
        let options = CovarianceOptions {
            cost: if with_gain.is_some() {
                PemCost::Prediction
            } else {
                PemCost::OutputError
            },
            feedthrough: Feedthrough::Mask(mask),
            threads: opts.identification.threads.unwrap_or(1),
            max_work: opts.budgets.covariance_work,
            ..Default::default()
        };
        state_space_covariance(model, with_gain, &records, &options)
            .map(|u| (u, options.cost))
            .map_err(|e| match e {
                lifted_pem::Error::TooMuchWork { flops, limit, .. } => format!(
                    "its Jacobian pass and the null space of its similarity tangent need about {flops:.2e} operations, more than the work budget budgets.covariance_work = {limit:.2e} (--budget covariance_work=…)"
                ),
                e => e.to_string(),
            })
    };
    let (entry, cov) = match result {
        Ok((u, cost)) => (
            json!({
                "computed": true,
                "errors": match cost {
                    PemCost::Prediction => "prediction (the innovations model with its Kalman gain)",
                    PemCost::OutputError => "simulation (no Kalman gain)",
                },
                "parameters": u.parameters,
                "measured": u.measured,
                "noise_variance": u.noise_variance,
                "note": "first-order (asymptotic) covariance of the entries from the prediction-error Jacobian at the model returned; for a subspace model kept as identified it is the prediction-error method's there, which the subspace estimate's own spread can exceed",
            }),
            Some(u.covariance),
        ),
        Err(why) => (json!({"computed": false, "why": why}), None),
    };
    if let Some(obj) = diagnostics.as_object_mut() {
        obj.insert("covariance".into(), entry);
    }
    crate::diagnostics::add_phase(diagnostics, "covariance_s", t.elapsed().as_secs_f64());
    cov
}

/// `diagnostics.covariance` of a run that did not ask for it.
pub(crate) fn not_asked(diagnostics: &mut Value) {
    if let Some(obj) = diagnostics.as_object_mut() {
        obj.insert(
            "covariance".into(),
            json!({"computed": false, "why": "not asked (validation.covariance = false, --no-covariance)"}),
        );
    }
}

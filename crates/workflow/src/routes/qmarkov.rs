//! The q-Markov Cover route (seed paper §2): Markov parameters and output
//! covariances from the record under a white excitation, the cover of q of
//! them as a state-space model.

use lifted_lti::{Dataset, Identifier};
use lifted_qmarkov::{QMarkov, QMarkovOptions, RecordMode};
use lifted_subspace::OrderSelection;
use serde_json::json;

use crate::diagnostics::order_json;
use crate::error::{Context, Error, Result};
use crate::options::{IdentificationOptions, WorkflowOptions};
use crate::refine::stabilized_start;

use crate::routes::iv::output_weighting;
use crate::routes::{RouteDetails, RouteFit};
use crate::subspace_options::order_of;

/// The weighted multirate q-Markov Cover (Zhu 2000), one inverse-PRBS
/// record per input.
pub(crate) fn qmarkov(opts: &WorkflowOptions, sets: &[Dataset]) -> Result<RouteFit> {
    let id = &opts.identification;
    let stable = stabilized_start(opts);
    let prbs_order = id
        .prbs_order
        .unwrap_or(QMarkovOptions::default().prbs_order);
    let m = lifted_prbs::period(prbs_order).ctx("prbs_order")? as usize;
    let hold = opts.data.hold.max(1);
    let period = 2 * hold * m;
    let len = sets[0].len();
    let record = if len == period {
        RecordMode::OnePeriod
    } else {
        RecordMode::LastPeriod
    };
    let q = id.q.unwrap_or(60.min(hold * m - 1));
    let (order, max_auto_order) = match order_of(id) {
        OrderSelection::Fixed(n) => (Some(n), id.max_order),
        OrderSelection::Gap { max } => (None, max),
    };
    let output_weighting = output_weighting(&id.output_weight, sets[0].n_outputs())?;
    let qopts = QMarkovOptions {
        q,
        output_weighting,
        order,
        max_auto_order,
        hold,
        prbs_order,
        amplitudes: amplitudes(id, sets[0].n_inputs())?,
        record,
        enforce_stability: stable,
        ..Default::default()
    };
    let model = QMarkov::new(qopts)
        .identify(sets)
        .ctx("q-Markov Cover identification")?;
    let dg = &model.diagnostics;
    let d = json!({
        "route": "weighted multirate q-Markov Cover (Zhu 2000)",
        "q": q,
        "hold": hold,
        "prbs_order": prbs_order,
        "cover": format!("{:?}", dg.cover),
        "markov_error": dg.markov_error,
        "covariance_error": dg.covariance_error,
        "stable": dg.stable,
        "spectral_radius": dg.spectral_radius,
        "stabilized_from": dg.stabilized_from,
        "order_selection": order_json("eigenvalues of D_q (Λ diagonal)", &dg.eigenvalues, dg.order, dg.suggested_order),
    });
    let (eig, suggested) = (dg.eigenvalues.clone(), dg.suggested_order);
    let details = RouteDetails {
        markov_data: dg.markov_data.clone(),
        markov_model: dg.markov_model.clone(),
        ..Default::default()
    };
    Ok(RouteFit::plain(model.model, d, &eig, suggested).with_details(details))
}

/// The PRBS magnitudes of the q-Markov Cover: one per input, from
/// `amplitudes` (one per input) or `amplitude` (every input); `None`: read
/// from the data.
pub(crate) fn amplitudes(id: &IdentificationOptions, inputs: usize) -> Result<Option<Vec<f64>>> {
    let values = match (&id.amplitudes[..], id.amplitude) {
        ([], None) => return Ok(None),
        ([], Some(a)) => vec![a; inputs],
        (a, _) if a.len() == inputs => a.to_vec(),
        (a, _) => {
            return Err(Error::option(
                "amplitudes",
                format!(
                    "{} values for {inputs} inputs (give one per input)",
                    a.len()
                ),
            ));
        }
    };
    if let Some(bad) = values.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
        return Err(Error::option(
            "amplitude",
            format!("{bad}: the PRBS magnitude must be positive and finite"),
        ));
    }
    Ok(Some(values))
}

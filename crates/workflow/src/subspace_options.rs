//! What the workflow options say to lifted-subspace: the method, order
//! rule, (A, C) and (B, D) estimators, order criterion and feedthrough of
//! [`IdentificationOptions`] as [`SubspaceOptions`] fields, for every route
//! and the structure selection.

use lifted_subspace::{
    BdEstimate, OrderCriterion as SubCriterion, OrderSelection, SubspaceOptions, SystemEstimate,
};

use crate::options::{
    BdRoute, Estimator, IdentificationOptions, Method, Order, OrderCriterion, WorkflowOptions,
};
use crate::refine::stabilized_start;
use serde_json::json;

/// The subspace crate's order selection for the options.
pub(crate) fn order_of(id: &IdentificationOptions) -> OrderSelection {
    match id.order {
        Order::Fixed(n) => OrderSelection::Fixed(n),
        Order::Auto => OrderSelection::Gap { max: id.max_order },
    }
}

/// The subspace crate's method.
pub(crate) fn method_of(m: Method) -> lifted_subspace::Method {
    match m {
        Method::Moesp => lifted_subspace::Method::Moesp,
        Method::Cva => lifted_subspace::Method::Cva,
        _ => lifted_subspace::Method::N4sid,
    }
}

/// The subspace crate's (A, C) route.
pub(crate) fn system_of(e: Estimator) -> SystemEstimate {
    match e {
        Estimator::Auto | Estimator::Shift => SystemEstimate::ShiftInvariance,
        Estimator::States => SystemEstimate::StateSequence,
    }
}

/// The subspace crate's (B, D) route.
pub(crate) fn bd_of(b: BdRoute) -> BdEstimate {
    match b {
        BdRoute::Auto => BdEstimate::Auto,
        BdRoute::OutputError => BdEstimate::OutputError,
        BdRoute::Projection => BdEstimate::Projection,
    }
}

/// The subspace crate's rule for the order criterion (the held-out
/// validation runs before the identification, which then gets a fixed
/// order: the gap stands for it).
pub(crate) fn criterion_of(c: OrderCriterion) -> SubCriterion {
    match c {
        OrderCriterion::Validation | OrderCriterion::Gap => SubCriterion::Gap,
        OrderCriterion::Svc => SubCriterion::Svc,
        OrderCriterion::Aic => SubCriterion::Aic,
        OrderCriterion::Aicc => SubCriterion::Aicc,
        OrderCriterion::Bic => SubCriterion::Bic,
    }
}

/// The subspace options of the workflow options for records in memory of
/// period `ts` (the options' structure: horizon 10 and the gap rule unless
/// given); `remove_means`: the means are removed inside the identification.
pub(crate) fn subspace_options(
    opts: &WorkflowOptions,
    ts: f64,
    remove_means: bool,
) -> SubspaceOptions {
    let id = &opts.identification;
    SubspaceOptions {
        method: method_of(id.method),
        order: order_of(id),
        order_criterion: criterion_of(id.order_criterion),
        past: id.horizon.unwrap_or(10),
        future: id.horizon.unwrap_or(10),
        system: system_of(id.estimator),
        bd: bd_of(id.bd),
        remove_means,
        noise_model: id.noise_model,
        enforce_stability: stabilized_start(opts),
        feedthrough: feedthrough_of(id, true),
        ts,
        threads: id.threads.unwrap_or(1),
        ..Default::default()
    }
}

/// The feedthrough of a route: as asked (`--feedthrough [true|false]`),
/// else the route's default: `estimated` for single-rate N4SID, MOESP and
/// CVA (then kept only where the records support it,
/// [`crate::routes::feedthrough`]), D = 0 for the closed-loop capable routes
/// (PBSID/SSARX, IV: an estimated D is biased when the controller reacts
/// within the sample, the noise reaching u at once).
pub(crate) fn feedthrough_of(
    id: &IdentificationOptions,
    estimated: bool,
) -> lifted_subspace::Feedthrough {
    if id.feedthrough.unwrap_or(estimated) {
        lifted_subspace::Feedthrough::Free
    } else {
        lifted_subspace::Feedthrough::Zero
    }
}

/// The fast model strictly proper (the lifted causal mask without the
/// instantaneous terms, eq. 4.17) unless a feedthrough is asked for.
pub(crate) fn strictly_proper(id: &IdentificationOptions) -> bool {
    id.feedthrough != Some(true)
}

/// `diagnostics.feedthrough` of the routes whose default is D = 0 (the
/// closed-loop capable and the multirate routes).
pub(crate) fn feedthrough_json(id: &IdentificationOptions) -> serde_json::Value {
    json!(match id.feedthrough {
        Some(true) => "D estimated (feedthrough asked for)",
        Some(false) => "D = 0 (asked for)",
        None => {
            "D = 0 (the default of the closed-loop capable and multirate routes: a strictly proper model, as MPC designs take; in closed loop an estimated D takes the noise that reaches u within the sample through the controller; --feedthrough estimates it)"
        }
    })
}

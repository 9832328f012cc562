//! An order rule's choice kept stable: the next order of the rule's
//! ranking whose model has ρ(A) < 1 + δ (the integrator tolerance), at most
//! `stable_tries` models, the orders passed over listed; an unstable choice
//! re-estimated for a stabilised refinement start.

use lifted_subspace::{
    OrderCriterion as SubCriterion, OrderSelection, SubspaceModel, SubspaceOptions,
};
use serde_json::json;

use crate::error::Result;

use crate::selection::{criterion_ranking, with_report_of};

/// The model `fit` identified with `used`, or, when the route's options
/// `sub` ask for the refinement's stabilised start
/// ([`stabilized_start`]), `used` did not and `fit` is unstable, its
/// re-estimate by the zero-padded shift at its order (`run`), so that the
/// refinement starts from the plain identification's choice; with the
/// options that give it. Both the held-out selection's and the other order
/// rules' choices go through it.
pub(crate) fn stabilized_if_unstable(
    sub: &SubspaceOptions,
    fit: SubspaceModel,
    used: SubspaceOptions,
    run: impl FnOnce(&SubspaceOptions) -> Result<SubspaceModel>,
) -> Result<(SubspaceModel, SubspaceOptions)> {
    if sub.enforce_stability
        && !used.enforce_stability
        && fit.diagnostics.spectral_radius >= 1.0 + sub.marginal_tolerance
    {
        // An automatic order's search is not run again (its rule's values
        // would be those of the stabilised models): the order kept, fixed.
        let at_order = match used.order {
            OrderSelection::Fixed(_) => used,
            OrderSelection::Gap { .. } => at_fixed_order(&used, fit.diagnostics.order),
        };
        let stabilized = SubspaceOptions {
            enforce_stability: true,
            ..at_order
        };
        Ok((run(&stabilized)?, stabilized))
    } else {
        Ok((fit, used))
    }
}

/// The options `o` with the order fixed at `n`, the gap standing for the
/// order rule (as after a selection: the rule's values are not computed
/// again; [`with_report_of`] keeps those of the search).
pub(crate) fn at_fixed_order(o: &SubspaceOptions, n: usize) -> SubspaceOptions {
    SubspaceOptions {
        order: OrderSelection::Fixed(n),
        order_criterion: SubCriterion::Gap,
        ..o.clone()
    }
}

/// The automatic order's model `first` (the rule's choice, identified
/// with the options `search`) when it is stable, else, as the held-out
/// selection does, the first stable model of the next orders of the
/// rule's ranking ([`criterion_ranking`], [`first_stable`]: at most
/// `tries` models in all), identified at a fixed order with
/// `run`; none stable: `first`. Returns the model, the options that give
/// it and the orders passed over ([`add_stable_choice`]).
pub(crate) fn stable_choice(
    first: SubspaceModel,
    search: SubspaceOptions,
    tries: usize,
    mut run: impl FnMut(&SubspaceOptions) -> Result<SubspaceModel>,
) -> (SubspaceModel, SubspaceOptions, Vec<serde_json::Value>) {
    let max = match search.order {
        OrderSelection::Gap { max } => max,
        OrderSelection::Fixed(n) => n,
    };
    let first_order = first.diagnostics.order;
    let ranking = criterion_ranking(
        &first.diagnostics.order_selection,
        &first.diagnostics.singular_values,
        max,
    );
    let searched = first.diagnostics.clone();
    let bound = if search.enforce_stability {
        1.0
    } else {
        1.0 + search.marginal_tolerance
    };
    let (fit, passed) = first_stable(
        first,
        ranking,
        tries,
        bound,
        |m: &SubspaceModel| (m.diagnostics.order, m.diagnostics.spectral_radius),
        |n| {
            run(&at_fixed_order(&search, n))
                .ok()
                .map(|m| with_report_of(m, &searched))
        },
    );
    let used = if fit.diagnostics.order == first_order {
        search
    } else {
        at_fixed_order(&search, fit.diagnostics.order)
    };
    (fit, used, passed)
}

/// `first` when its model is stable, else the first stable model of the
/// next orders of `ranking` (the order of `first` skipped; at most
/// `tries` models in all, [`SelectionOptions::stable_tries`]; `identify_at(n)`, `None` when it
/// fails), else `first` (unstable: the validation stage warns) — "stable"
/// meaning ρ < `bound`, 1 + the integrator tolerance
/// (`crate::integrators::stability_bound`: an integrating plant's marginal
/// model is kept as the refinement keeps it) — how every
/// automatic order rule handles an unstable choice: the held-out
/// selections, the singular-value gap of the multirate routes and of the
/// fallbacks, and the order rules asked for (AIC, AICc, BIC, SVC, the gap).
/// `order_rho(model)`: its order and spectral radius. Also returns the
/// orders passed over, `{order, spectral_radius}`, the rule's choice first.
pub(crate) fn first_stable<M>(
    first: M,
    ranking: impl IntoIterator<Item = usize>,
    tries: usize,
    bound: f64,
    order_rho: impl Fn(&M) -> (usize, f64),
    mut identify_at: impl FnMut(usize) -> Option<M>,
) -> (M, Vec<serde_json::Value>) {
    let (first_order, rho) = order_rho(&first);
    let mut fit = first;
    let mut passed_over = Vec::new();
    if rho >= bound {
        passed_over.push(json!({"order": first_order, "spectral_radius": rho}));
        for n in ranking
            .into_iter()
            .filter(|&n| n != first_order)
            .take(tries.saturating_sub(1))
        {
            let Some(other) = identify_at(n) else {
                continue;
            };
            let (_, r) = order_rho(&other);
            if r < bound {
                fit = other;
                break;
            }
            passed_over.push(json!({"order": n, "spectral_radius": r}));
        }
    }
    (fit, passed_over)
}

/// `diagnostics.stable_order` of an automatic order by the order rule
/// asked for whose choice was unstable ([`first_stable`]; nothing when
/// none was passed over): the orders passed over and the order kept.
pub(crate) fn add_stable_choice(
    d: &mut serde_json::Value,
    passed_over: &[serde_json::Value],
    order: usize,
    tries: usize,
) {
    let Some(first) = passed_over.first() else {
        return;
    };
    let kept_stable = !passed_over.iter().any(|p| p["order"] == json!(order));
    let rule = if kept_stable {
        format!(
            "the order rule's choice ({}) gave an unstable model on the records: the next orders of its ranking were identified (at most {tries} models in all) and the first stable one kept, as the held-out selection does",
            first["order"]
        )
    } else {
        format!(
            "the order rule's choice ({}) gave an unstable model on the records and so did the next orders of its ranking (at most {tries} models in all): the rule's choice is kept",
            first["order"]
        )
    };
    if let Some(obj) = d.as_object_mut() {
        obj.insert(
            "stable_order".into(),
            json!({"rule": rule, "order": order, "passed_over": passed_over}),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An order rule's choice with ρ within the integrator tolerance of 1
    /// is kept (an integrating plant's marginal model); beyond it, or with
    /// the bound 1 (`--stable`), the next order of the ranking that is
    /// inside is taken and the choice is listed as passed over.
    #[test]
    fn an_order_rule_keeps_a_marginal_choice_within_the_integrator_tolerance() {
        let models = [(3usize, 1.0005f64), (2, 0.9), (4, 1.2)];
        let at = |n: usize| models.iter().copied().find(|m| m.0 == n);
        let rho = |m: &(usize, f64)| *m;
        let (kept, passed) = first_stable(models[0], [3, 2, 4], 6, 1.001, rho, at);
        assert_eq!((kept, passed.len()), ((3, 1.0005), 0));
        let (kept, passed) = first_stable(models[0], [3, 2, 4], 6, 1.0, rho, at);
        assert_eq!(kept, (2, 0.9));
        assert_eq!(passed[0]["order"], 3);
        let (kept, _) = first_stable((4, 1.2), [4, 3, 2], 6, 1.001, rho, at);
        assert_eq!(kept, (3, 1.0005));
    }

    /// The selection's `stable_tries` bounds the models tried: one try
    /// keeps the rule's unstable choice, two reach the next order only.
    #[test]
    fn stable_tries_bound_the_models_tried_for_a_stable_one() {
        let models = [(4usize, 1.2f64), (5, 1.1), (2, 0.9)];
        let at = |n: usize| models.iter().copied().find(|m| m.0 == n);
        let rho = |m: &(usize, f64)| *m;
        let (kept, passed) = first_stable(models[0], [4, 5, 2], 1, 1.0, rho, at);
        assert_eq!((kept, passed.len()), ((4, 1.2), 1));
        let (kept, passed) = first_stable(models[0], [4, 5, 2], 2, 1.0, rho, at);
        assert_eq!((kept, passed.len()), ((4, 1.2), 2));
        let (kept, passed) = first_stable(models[0], [4, 5, 2], 3, 1.0, rho, at);
        assert_eq!((kept, passed.len()), ((2, 0.9), 2));
    }
}

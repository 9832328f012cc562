//! Structure selection: which order (and horizon, estimator) a route
//! keeps, under [`crate::SelectionOptions`] (the policy: stable tries,
//! shortlist, tolerance, failed-fold floor; documented defaults, none fitted
//! to a benchmark). Children: [`stable`] (an order rule's choice kept
//! stable), [`held_out`] (held-out folds and cross-validation of the
//! single-rate routes), [`multirate`] (the multirate routes' held-out
//! ranking), [`shortlist`] (the refined shortlist). Here: the search capped
//! at the largest supported order and the rankings of the order rules.

pub(crate) mod held_out;
pub(crate) mod multirate;
pub(crate) mod shortlist;
pub(crate) mod stable;

use lifted_subspace::{
    OrderCriterion as SubCriterion, OrderReport, OrderSelection, SubspaceModel, SubspaceOptions,
};

use crate::error::{Error, Result};

/// An automatic order's search capped by [`capped_to_supported`]: the
/// bound asked for and the one searched.
pub(crate) type SearchCap = (usize, usize);

/// `run` on `sub`, or, when it refused an automatic order's search bound
/// beyond what the records or the horizon identify ([`supported_cap`]),
/// on `sub` with the search capped at the largest supported order
/// instead; with the options run and the cap (the bound asked for, the
/// one searched) for [`push_capped_search_warning`]. The in-memory and the
/// streamed route both take an automatic order's search through it.
pub(crate) fn capped_to_supported<T>(
    sub: SubspaceOptions,
    mut run: impl FnMut(&SubspaceOptions) -> Result<T>,
) -> Result<(T, SubspaceOptions, Option<SearchCap>)> {
    let e = match run(&sub) {
        Ok(t) => return Ok((t, sub, None)),
        Err(e) => e,
    };
    match (supported_cap(&e, sub.order), sub.order) {
        // An automatic order's search bound (--max-order, default 10)
        // beyond what the records or horizon identify: searched up to the
        // largest supported order instead, with a warning.
        (Some(max), OrderSelection::Gap { max: asked }) => {
            let capped = SubspaceOptions {
                order: OrderSelection::Gap { max },
                ..sub
            };
            let t = run(&capped)?;
            Ok((t, capped, Some((asked, max))))
        }
        _ => Err(e),
    }
}

/// The warning of an automatic order's search capped by
/// [`capped_to_supported`]: `(asked, max)`, the bound asked for and the one
/// searched.
pub(crate) fn push_capped_search_warning(d: &mut serde_json::Value, (asked, max): SearchCap) {
    crate::diagnostics::push_warning(
        d,
        format!(
            "orders above {max} are not identifiable from these records with this horizon and order criterion: the automatic order searched 1..={max} instead of 1..={asked} (--max-order)"
        ),
    );
}

/// `fit` (identified at a fixed order, [`at_fixed_order`]) with the order
/// rule's values and the suggested order of the search (its diagnostics
/// `search`), so that the rule's curve stays in the diagnostics.
pub(crate) fn with_report_of(
    mut fit: SubspaceModel,
    search: &lifted_subspace::Diagnostics,
) -> SubspaceModel {
    fit.diagnostics.order_selection = search.order_selection.clone();
    fit.diagnostics.suggested_order = search.suggested_order;
    fit
}

/// The orders of an order rule's report ranked best first (the gap's
/// largest values first, the other rules' smallest), ties to the lower
/// order, orders whose value is not finite (a model AIC could not fit or
/// simulate) left out; the gap rule ranks the singular values `sv` as the
/// default's fallbacks do ([`gap_ranking`], up to `max`). O(n log n).
pub(crate) fn criterion_ranking(report: &OrderReport, sv: &[f64], max: usize) -> Vec<usize> {
    if report.criterion == SubCriterion::Gap {
        return gap_ranking(sv, max);
    }
    let mut orders: Vec<usize> = (1..=report.values.len())
        .filter(|&n| report.values[n - 1].is_finite())
        .collect();
    orders.sort_by(|&a, &b| report.values[a - 1].total_cmp(&report.values[b - 1]));
    orders
}

/// The largest order the records support when `e` refused an automatic
/// order's search bound (`lifted_subspace::Error::OrderTooLarge` for the
/// bound itself, with a supported order of at least 1); `None` for any
/// other error or a fixed order.
pub(crate) fn supported_cap(e: &Error, order: OrderSelection) -> Option<usize> {
    let OrderSelection::Gap { max: asked } = order else {
        return None;
    };
    let Error::Step { source, .. } = e else {
        return None;
    };
    match source.downcast_ref::<lifted_subspace::Error>() {
        Some(lifted_subspace::Error::OrderTooLarge { order, max })
            if *order == asked && (1..asked).contains(max) =>
        {
            Some(*max)
        }
        _ => None,
    }
}

/// Orders 1..=`max` (below the number of singular values) ranked by the
/// gap ln(σ_n/σ_{n+1}), largest first. O(max log max).
pub(crate) fn gap_ranking(sv: &[f64], max: usize) -> Vec<usize> {
    let top = max.min(sv.len().saturating_sub(1));
    let gap = |n: usize| {
        let (a, b) = (sv[n - 1], sv[n]);
        if b > 0.0 { (a / b).ln() } else { f64::INFINITY }
    };
    let mut orders: Vec<usize> = (1..=top).collect();
    orders.sort_by(|&x, &y| gap(y).total_cmp(&gap(x)));
    orders
}

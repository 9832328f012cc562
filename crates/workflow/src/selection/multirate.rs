//! The multirate routes' held-out order ranking: the record cut at a frame
//! boundary near two thirds, each order identified on the first part and
//! simulated on the rest from its least-squares x₀; the refined shortlist
//! judges orders whose start is unstable by their refinements.

use lifted_lti::{Dataset, StateSpace};
use serde_json::json;

use crate::options::{Refine, WorkflowOptions};
use lifted_pem::PemCost;

use crate::selection::held_out::{held_out_mean, two_thirds};

/// The held-out order choice of the multirate route: orders ranked by the
/// simulation fit on the last third of the record of the model identified
/// on the first two thirds (best first, an order within the tolerance of a
/// better one above it when it is smaller), and the curve.
pub(crate) struct HeldOutOrders {
    pub(crate) ranking: Vec<(usize, f64)>,
    pub(crate) curve: Vec<serde_json::Value>,
    pub(crate) split: usize,
    /// The leading order when its start was unstable on the first part
    /// and its refinement (from the stabilised start) scored best.
    pub(crate) lead_from_unstable: Option<usize>,
    /// The refined shortlist's rule and scores, when it was judged.
    pub(crate) refined: Option<serde_json::Value>,
    /// Points within which the smallest order leads
    /// ([`SelectionOptions::tolerance`]).
    pub(crate) tolerance: f64,
}

impl HeldOutOrders {
    /// The `structure_selection` entry of the diagnostics, order `n` kept.
    pub(crate) fn diagnostics(&self, n: usize) -> serde_json::Value {
        json!({
            "criterion": format!(
                "simulation fit (x0 estimated, mean over the outputs' measured samples) on the held-out samples {}.. of the model identified on the samples before, for orders 1..={}; the smallest order within {} points of the best, the next of the ranking when its model on the whole record is unstable",
                self.split,
                self.curve.len(),
                self.tolerance
            ),
            "order": n,
            "candidates": self.curve,
            "refined_shortlist": self.refined,
        })
    }
}

/// Records up to this many base samples get the held-out order choice on
/// the multirate route (one multirate identification per candidate order).
pub(crate) const MULTIRATE_SELECTION_SAMPLES: usize = 200_000;

/// The multirate routes' held-out order ranking for an automatic order up
/// to `max` ([`HeldOutOrders`]): the record cut at a frame boundary near
/// two thirds, every order identified on the first part (`fit_at(part,
/// n)`: the route's fast model of order n, `None` when it fails) and
/// simulated on the rest from its least-squares x₀. `None`
/// when the record is longer than [`MULTIRATE_SELECTION_SAMPLES`], too
/// short for the cut, or no order could be scored. O(max) multirate
/// identifications of 2N/3 samples, on the run's threads (the orders are
/// independent; the same curve whatever the count).
pub(crate) fn held_out_orders(
    data: &Dataset,
    max: usize,
    fit_at: impl Fn(&Dataset, usize) -> Option<StateSpace> + Sync,
    wf: &WorkflowOptions,
    judge_unstable: bool,
) -> Option<HeldOutOrders> {
    let n = data.len();
    if n > MULTIRATE_SELECTION_SAMPLES {
        return None;
    }
    let (est, val, split) = two_thirds(data)?;
    let vopts = lifted_lti::ValidationOptions {
        lags: 1,
        horizons: Vec::new(),
        ..Default::default()
    };
    let mut scored = Vec::new();
    let mut curve = Vec::new();
    // The fast model (at the base period) of each scored order, and of
    // each order whose start is unstable (judged by its refinement only).
    let mut models: Vec<(usize, StateSpace)> = Vec::new();
    let mut unstable: Vec<(usize, StateSpace)> = Vec::new();
    // A marginal model (integrators within the tolerance) is scored as a
    // stable one.
    let bound = crate::integrators::stability_bound_for(&wf.identification, n);
    // Each order's fit: Ok((held-out mean, fast model)) when stable,
    // Err(fast model) when unstable (None when it fails). The orders are
    // independent: on the run's threads (`parallel::map_in_order`, the
    // results in order whatever the count).
    let one = |k: usize| -> Option<std::result::Result<(f64, StateSpace), StateSpace>> {
        let m = fit_at(&est, k + 1)?;
        let fast = at_base_period(&m, val.ts()).ok()?;
        if crate::validate::spectral_radius(&m).is_ok_and(|r| r < bound) {
            Some(Ok((held_out_mean(&fast, &val, &vopts)?, fast)))
        } else {
            Some(Err(fast))
        }
    };
    let workers = crate::parallel::threads(wf);
    let fits = crate::parallel::map_in_order(max.max(1), workers, one);
    for (k, fit) in fits.into_iter().enumerate() {
        let order = k + 1;
        let fit = match fit.flatten() {
            Some(Ok(f)) => Some(f),
            Some(Err(fast)) => {
                if judge_unstable {
                    unstable.push((order, fast));
                }
                None
            }
            None => None,
        };
        curve.push(json!({"order": order, "fit": fit.as_ref().map(|f| f.0)}));
        if let Some((f, fast)) = fit {
            scored.push((order, f));
            models.push((order, fast));
        }
    }
    // No stable start at any order: nothing on this part to compare the
    // refinements with; the route's fallbacks decide (the gap, or the
    // interpolated record's own selection when the lifted route fails).
    if scored.is_empty() {
        return None;
    }
    // Best first, with the parsimony of the single-rate selection: the
    // smallest order within the tolerance of the best leads — of the
    // refined shortlist's scores when it was judged, else of the curve.
    let policy = wf.identification.selection;
    let tolerance = policy.tolerance;
    let mut ranking = scored.clone();
    ranking.sort_by(|a, b| b.1.total_cmp(&a.1));
    // The best few orders judged by the model each delivers: refined on the
    // first part (the default refinement's prediction cost) and scored on
    // the rest. The unrefined subspace models' held-out fit keeps rising
    // past the true order (extra states make up for the extraction's bias
    // in simulation while the frequency response drifts: the plant
    // at 15 000 samples scored 85.3 at order 4 and 89.6 at order 9, FR
    // errors 0.005 and 0.038).
    let refined = refined_shortlist(&ranking, &models, &unstable, &est, &val, &vopts, wf);
    // An order whose start was unstable competes only when its refined
    // model fits the held-out samples better than their mean (fit > 0):
    // where every order fails there the part holds no evidence to prefer
    // it, and the ranking stays the stable starts' (flutter's output every
    // third sample: all orders below −30 held out).
    let from_unstable = |o: usize| unstable.iter().any(|m| m.0 == o);
    let usable = refined.as_ref().and_then(|r| {
        let kept: Vec<(usize, f64)> = r
            .iter()
            .filter(|e| !from_unstable(e.0) || e.1 > 0.0)
            .copied()
            .collect();
        (kept.len() >= 2 || kept.iter().any(|e| from_unstable(e.0))).then_some(kept)
    });
    let (lead_scores, rule) = match &usable {
        Some(r) => (r.clone(), "refined"),
        None => (ranking.clone(), "subspace"),
    };
    let lead_best = lead_scores
        .iter()
        .map(|&(_, f)| f)
        .fold(f64::NEG_INFINITY, f64::max);
    let mut lead_from_unstable = None;
    if let Some(lead_order) = lead_scores
        .iter()
        .filter(|c| c.1 >= lead_best - tolerance)
        .map(|c| c.0)
        .min()
    {
        if let Some(pos) = ranking.iter().position(|c| c.0 == lead_order) {
            let lead = ranking.remove(pos);
            ranking.insert(0, lead);
        } else {
            // An order whose start was unstable on the first part, judged
            // by its refinement alone.
            let score = lead_scores
                .iter()
                .find(|c| c.0 == lead_order)
                .map_or(lead_best, |c| c.1);
            ranking.insert(0, (lead_order, score));
            lead_from_unstable = Some(lead_order);
        }
    }
    if ranking.is_empty() {
        return None;
    }
    Some(HeldOutOrders {
        tolerance,
        ranking,
        curve,
        split,
        lead_from_unstable,
        refined: refined.map(|r| {
            json!({
                "rule": format!(
                    "the best {} orders of the curve (the smallest within {} points of the best, then the best) and the orders whose start was unstable there, each refined on the samples before {split} (the prediction cost; an unstable start from its stabilised version) and scored on the rest; the smallest order within {tolerance} points of the best refined score leads (scores of the {rule} models)",
                    policy.shortlist,
                    policy.shortlist_span
                ),
                "candidates": r.iter().map(|e| json!({"order": e.0, "score": e.1})).collect::<Vec<_>>(),
            })
        }),
    })
}

/// The held-out fits of the refined models of the best
/// [`SelectionOptions::shortlist`] orders of `ranking` (`(order, fit)`: the
/// smallest within [`SelectionOptions::shortlist_span`] points of the best,
/// then the best), then of
/// the orders whose start was `unstable` on the first part (refined from
/// their stabilised start, `lifted_pem::refine_pem`: the default
/// refinement cannot reach them otherwise, and on a short record the
/// well-fitting orders can be exactly those — the flexible arm's output
/// every third sample: no start above order 3 stable on its first 339
/// samples, order 9 refined scores 86 held out), as far as the work
/// bound allows; or `None` when the run does not refine (`--refine
/// none`), fewer than two orders were refined, or the refinements
/// together are predicted to cost more than two default refinements
/// ([`crate::Budgets::auto_refine_work_joint`] each, about 2 s). O(shortlist + unstable)
/// refinements of 2N/3 samples, on the run's threads (the candidates
/// within the work bound are fixed first; the same scores whatever the
/// count).
pub(crate) fn refined_shortlist(
    ranking: &[(usize, f64)],
    models: &[(usize, StateSpace)],
    unstable: &[(usize, StateSpace)],
    est: &Dataset,
    val: &Dataset,
    vopts: &lifted_lti::ValidationOptions,
    wf: &WorkflowOptions,
) -> Option<Vec<(usize, f64)>> {
    let cost = match wf.refinement.refine {
        Refine::None => return None,
        Refine::Oe => PemCost::OutputError,
        Refine::Auto | Refine::Pem => PemCost::Prediction,
    };
    let records = [lifted_subspace::Record {
        u: est.u(),
        y: est.y(),
        instrument: None,
    }];
    // The smallest orders within the shortlist's span of the best (the
    // unrefined curve flattens out past the true order while its level
    // keeps creeping up), then the best itself.
    let policy = wf.identification.selection;
    let mut near: Vec<usize> = Vec::new();
    if let Some(best) = ranking.first() {
        near = ranking
            .iter()
            .filter(|c| c.1 >= best.1 - policy.shortlist_span)
            .map(|c| c.0)
            .collect();
        near.sort_unstable();
        near.truncate(policy.shortlist);
        if !near.contains(&best.0) {
            near.push(best.0);
        }
    }
    let mut work = 0.0;
    let mut out = Vec::new();
    let candidates: Vec<&(usize, StateSpace)> = near
        .iter()
        .filter_map(|n| models.iter().find(|m| m.0 == *n))
        .chain(unstable.iter())
        .collect();
    // The candidates within the work bound, then their refinements (each
    // independent: on the run's threads, the results in order).
    let mut within = Vec::new();
    for (order, fast) in candidates {
        let pem = crate::refine::pem_options(wf, fast, cost, false);
        let w = lifted_pem::pem_work_estimate(fast, &records, &pem).ok()?;
        work += w.typical;
        if work > 2.0 * wf.budgets.auto_refine_work_joint || w.per_iteration > pem.max_work {
            break;
        }
        within.push((*order, fast, pem));
    }
    let workers = crate::parallel::threads(wf);
    let scores = crate::parallel::map_in_order(within.len(), workers, |k| {
        let (_, fast, pem) = &within[k];
        let r = lifted_pem::refine_pem(fast, None, &records, &[], pem).ok()?;
        held_out_mean(&r.model, val, vopts)
    });
    for ((order, _, _), f) in within.iter().zip(scores) {
        if let Some(f) = f.flatten() {
            out.push((*order, f));
        }
    }
    (out.len() >= 2).then_some(out)
}

/// `fast` at the base period `ts`: itself when it is at `ts` (or
/// continuous), else its ZOH equivalent at `ts` (d2c at its own period,
/// c2d at `ts`: exact for a plant whose input is held over its period).
/// Errors: the d2c's (an eigenvalue on the closed negative real axis has no
/// continuous equivalent). O(n³).
pub(crate) fn at_base_period(
    fast: &StateSpace,
    ts: f64,
) -> std::result::Result<StateSpace, String> {
    match fast.ts() {
        Some(t) if (t - ts).abs() > 1e-9 * ts => fast
            .d2c()
            .and_then(|c| c.c2d(ts, &lifted_lti::C2dOptions::default()))
            .map_err(|e| e.to_string()),
        _ => Ok(fast.clone()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lifted_lti::{InputChannel, OutputChannel};
    use nalgebra::DMatrix;

    /// A second-order plant measured every third sample; `fit_at` gives a
    /// poor first-order model at order 1 and the plant with its poles
    /// pushed outside the unit circle at order 2 (an unstable start, as
    /// short records give at the orders that fit): judged by its
    /// refinement from the stabilised start, order 2 leads; without that,
    /// order 1 is all there is.
    #[test]
    fn an_order_whose_start_is_unstable_is_judged_by_its_refinement() {
        use rand::{RngExt, SeedableRng};
        let a = DMatrix::from_row_slice(2, 2, &[1.6, -0.8, 1.0, 0.0]);
        let b = DMatrix::from_row_slice(2, 1, &[1.0, 0.0]);
        let c = DMatrix::from_row_slice(1, 2, &[0.3, 0.2]);
        let d = DMatrix::zeros(1, 1);
        let plant =
            StateSpace::new(a.clone(), b.clone(), c.clone(), d.clone(), Some(1.0)).expect("plant");
        let n = 900;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let u = DMatrix::from_fn(
            n,
            1,
            |_, _| {
                if rng.random::<f64>() < 0.5 { -1.0 } else { 1.0 }
            },
        );
        let sim = plant.lsim(&u, None, None).expect("simulation").y;
        let y = DMatrix::from_fn(n, 1, |k, _| {
            if k % 3 == 0 {
                sim[(k, 0)] + 0.02 * (rng.random::<f64>() - 0.5)
            } else {
                f64::NAN
            }
        });
        let data = Dataset::new(
            1.0,
            u,
            y,
            vec![InputChannel::new("u", 1)],
            vec![OutputChannel::new("y", 3, 0)],
        )
        .expect("record");
        let first_order = StateSpace::new(
            DMatrix::from_element(1, 1, 0.5),
            DMatrix::from_element(1, 1, 0.1),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::zeros(1, 1),
            Some(1.0),
        )
        .expect("first order");
        // Poles 0.8 ± 0.4j (|λ| = 0.894) scaled by 1.15: |λ| = 1.03.
        let pushed = StateSpace::new(a * 1.15, b, c, d, Some(1.0)).expect("unstable start");
        let fit_at = |_: &Dataset, order: usize| match order {
            1 => Some(first_order.clone()),
            2 => Some(pushed.clone()),
            _ => None,
        };
        let wf = WorkflowOptions::default();
        let judged = held_out_orders(&data, 2, fit_at, &wf, true).expect("ranking");
        assert_eq!(judged.lead_from_unstable, Some(2), "{:?}", judged.ranking);
        assert_eq!(judged.ranking[0].0, 2);
        assert!(judged.ranking[0].1 > 90.0, "{:?}", judged.ranking);
        let plain = held_out_orders(&data, 2, fit_at, &wf, false).expect("ranking");
        assert_eq!(plain.lead_from_unstable, None);
        assert_eq!(plain.ranking[0].0, 1);
    }
}

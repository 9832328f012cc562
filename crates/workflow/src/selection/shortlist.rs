//! An automatic order judged by the model it delivers: the held-out fit of
//! the refined models of the best few orders.
//!
//! The structure selection (`lifted_subspace::select_structure`) ranks
//! (order, horizon, (A, C) route) by the held-out simulation fit of the
//! *subspace* models, but on a short record the workflow then refines the
//! chosen model and keeps the refinement when it does better on held-out
//! blocks ([`crate::refine`]). The order that is best before the refinement
//! need not be best after it: on the heating rig of `benches/results/real-records.md`
//! (400 estimation samples) the selection's order 7 scores 82.6 % on the
//! validation half, while the refined orders 2 and 5 score 89.4 and 88.7 %.
//!
//! So when the order is automatic, the records are short enough for the
//! held-out check of a refinement ([`crate::Budgets::refine_check_samples`]) and a
//! refinement will run, the first structure of each of the best
//! `SelectionOptions::shortlist` orders (default 3) of the selection's ranking (stable on the whole
//! records) is checked the way the refinement is judged
//! (`lifted_pem::cross_validate_refinement`, six blocks each held out
//! once, the subspace model and its refinement fitted to the others), and
//! each order is scored by the held-out fit of what it would deliver: the
//! refinement or the subspace model where the blocks tell them apart
//! ([`RefinementCheck::decide`] with `RefinementOptions::check`), the mean of
//! the two where they do not. The smallest order within the selection's
//! tolerance of the best score is chosen, and its check then judges its
//! refinement (not computed twice).
//!
//! Cost: one whole-record identification and one refinement check (six
//! fold identifications and refinements) per shortlisted order; the
//! shortlist is cut where the predicted work of its checks would pass
//! [`shortlist_work`] (about 2 s), and is not judged at all with fewer than
//! two orders (the selection's choice stands).

use lifted_lti::StateSpace;
use lifted_pem::{
    PemCost, PemMethod, RefinementCheck, cross_validate_refinement, pem_work_estimate_of_sizes,
};
use lifted_subspace::{Candidate, Experiment, SubspaceModel, SubspaceOptions};
use serde_json::json;

use crate::diagnostics::system_name;
use crate::options::{Order, Refine, WorkflowOptions};
use crate::refine::{CHECK_BLOCKS, judge_options, pem_options};

/// Most predicted work of the shortlist's refinement checks together
/// (operations; about 2 s here): twice the budget of one check
/// ([`crate::Budgets::refine_check_work`]).
pub(crate) fn shortlist_work(opts: &WorkflowOptions) -> f64 {
    2.0 * opts.budgets.refine_check_work
}

/// A shortlisted structure: its options (order fixed), its selection
/// candidate and its model on the whole records.
pub(crate) struct Entry {
    pub options: SubspaceOptions,
    pub candidate: Candidate,
    pub fit: SubspaceModel,
}

/// How the shortlist is judged: the run's options, the refinement cost and
/// the points of held-out fit within which the smaller order is preferred
/// (the structure selection's tolerance).
#[derive(Clone, Copy)]
pub(crate) struct Judge<'a> {
    pub options: &'a WorkflowOptions,
    pub cost: PemCost,
    pub tolerance: f64,
}

/// The order chosen from the shortlist: its index, the check that scored
/// it (reused to judge its refinement) and the diagnostics entry.
pub(crate) struct Choice {
    pub index: usize,
    pub check: RefinementCheck,
    pub diagnostics: serde_json::Value,
}

/// The judge of the run when the shortlist applies: the order automatic,
/// a refinement that runs on a stable start (the default, or `--refine
/// pem|oe`), records of at most [`crate::Budgets::refine_check_samples`] samples;
/// `tolerance` as [`Judge::tolerance`].
pub(crate) fn judge_of(
    opts: &WorkflowOptions,
    samples: usize,
    tolerance: f64,
) -> Option<Judge<'_>> {
    if opts.identification.order != Order::Auto || samples > opts.budgets.refine_check_samples {
        return None;
    }
    let cost = match opts.refinement.refine {
        Refine::Auto | Refine::Pem => PemCost::Prediction,
        Refine::Oe => PemCost::OutputError,
        Refine::None => return None,
    };
    Some(Judge {
        options: opts,
        cost,
        tolerance,
    })
}

/// What the check of one entry would cost, or why the entry cannot be
/// compared with the others (its model would not be refined).
fn check_work(
    opts: &WorkflowOptions,
    model: &StateSpace,
    sizes: &[usize],
    cost: PemCost,
) -> std::result::Result<f64, String> {
    let pem = pem_options(opts, model, cost, false);
    let work = pem_work_estimate_of_sizes(model, sizes, &pem)
        .map_err(|e| format!("its refinement work could not be predicted ({e})"))?;
    if opts.refinement.refine == Refine::Auto {
        // The default refines below the budget's auto_refine_samples (its
        // iterations stopped at auto_refine_work when over it) or within
        // its auto_refine_work (crate::refine::auto_decision); the work
        // counted here is the uncapped prediction, an upper bound.
        let samples: usize = sizes.iter().sum();
        let limit = match pem.method {
            PemMethod::VariableProjection => opts.budgets.auto_refine_work,
            PemMethod::Joint => return Err("its refinement would use joint iterations".into()),
        };
        if work.per_iteration > pem.max_work {
            return Err("one iteration of its refinement is over the work bound".into());
        }
        if work.typical > limit && samples >= opts.budgets.auto_refine_samples {
            return Err("it would not be refined by default (predicted work)".into());
        }
    }
    Ok(work.typical * CHECK_BLOCKS as f64 * 5.0 / 6.0)
}

/// The held-out fit an order is scored by: its refinement's or its subspace
/// model's where the blocks decide, else the mean of the two; and what
/// decided.
fn score(check: &RefinementCheck, rule: &lifted_pem::CheckRule) -> (f64, &'static str) {
    match check.decide(rule) {
        Some(true) => (check.refined_fit, "refinement"),
        Some(false) => (check.initial_fit, "subspace model"),
        None => (
            0.5 * (check.initial_fit + check.refined_fit),
            "not told apart: mean of the two",
        ),
    }
}

/// Judges `entries` (the selection's ranking order, the selection's choice
/// first) on the records. `Err(reason)` when the shortlist cannot be judged
/// (the selection's choice then stands).
pub(crate) fn judge(
    judge: Judge<'_>,
    exps: &[Experiment<'_>],
    entries: &[Entry],
) -> std::result::Result<Choice, String> {
    let Judge {
        options: opts,
        cost,
        tolerance,
    } = judge;
    let sizes: Vec<usize> = exps.iter().map(|e| e.u.nrows()).collect();
    // The entries whose checks fit in the work bound, in ranking order.
    let mut total = 0.0;
    let mut count = 0;
    let mut cut = String::new();
    // A marginal model (integrators within the tolerance) is checked as a
    // stable one.
    let bound = crate::integrators::stability_bound_for(
        &opts.identification,
        sizes.iter().copied().max().unwrap_or(0),
    );
    for e in entries {
        let order = e.candidate.order;
        if e.fit.diagnostics.stabilized || e.fit.diagnostics.spectral_radius >= bound {
            cut = format!("order {order}: its model is unstable or stabilised");
            break;
        }
        let work = match check_work(opts, &e.fit.model, &sizes, cost) {
            Ok(w) => w,
            Err(why) => {
                cut = format!("order {order}: {why}");
                break;
            }
        };
        let budget = opts.budgets.refine_check_work;
        if work > budget {
            cut = format!(
                "order {order}: its check would cost {work:.2e} operations, more than {budget:.0e}"
            );
            break;
        }
        if total + work > shortlist_work(opts) {
            cut = format!(
                "order {order}: the checks would cost more than {:.0e} operations together",
                shortlist_work(opts)
            );
            break;
        }
        total += work;
        count += 1;
    }
    if count < 2 {
        return Err(if cut.is_empty() {
            "fewer than two orders to compare".into()
        } else {
            cut
        });
    }
    let mut scored = Vec::with_capacity(count);
    for e in &entries[..count] {
        let pem = judge_options(
            &pem_options(opts, &e.fit.model, cost, false),
            opts.refinement.judge_iterations,
        );
        let check = cross_validate_refinement(exps, &e.options, &pem, CHECK_BLOCKS)
            .map_err(|err| format!("order {}: no held-out check ({err})", e.candidate.order))?
            .with_floor(opts.identification.selection.failed_fold);
        scored.push(check);
    }
    let rule = &opts.refinement.check;
    let scores: Vec<(f64, &str)> = scored.iter().map(|c| score(c, rule)).collect();
    let best = scores.iter().map(|s| s.0).fold(f64::NEG_INFINITY, f64::max);
    let index = (0..count)
        .filter(|&i| scores[i].0 >= best - tolerance)
        .min_by_key(|&i| (entries[i].candidate.order, i))
        .unwrap_or(0);
    let rows: Vec<serde_json::Value> = (0..count)
        .map(|i| {
            let c = &entries[i].candidate;
            json!({
                "order": c.order,
                "horizon": c.horizon,
                "system": system_name(c.system),
                "selection_fit": c.fit,
                "held_out_subspace": scored[i].initial_fit,
                "held_out_refined": scored[i].refined_fit,
                "folds": scored[i].folds,
                "scored_by": scores[i].1,
                "score": scores[i].0,
            })
        })
        .collect();
    let diagnostics = json!({
        "rule": format!(
            "the first structure of each of the best {} orders of the ranking, scored by the held-out fit of the model it delivers ({CHECK_BLOCKS} blocks each held out once, the subspace model and its refinement (at most {} iterations) fitted to the others; the one the blocks prefer ({}), else the mean of the two); the smallest order within {tolerance} points of the best",
            judge.options.identification.selection.shortlist,
            judge.options.refinement.judge_iterations,
            rule.describe()
        ),
        "fold_iterations": judge.options.refinement.judge_iterations,
        "candidates": rows,
        "order": entries[index].candidate.order,
    });
    Ok(Choice {
        index,
        check: scored.swap_remove(index),
        diagnostics,
    })
}

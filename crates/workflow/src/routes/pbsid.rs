//! The PBSID / SSARX route (closed-loop consistent, predictor-based): the
//! order by the held-out choice or the gap fallback of `crate::selection`;
//! multirate records go to `super::multirate_predictor`.

use lifted_lti::Dataset;
use lifted_subspace::{Experiment, OrderSelection};

use crate::diagnostics::pbsid_json;
use crate::error::{Context, Error, Result};
use crate::options::{
    IdentificationOptions, Method, Order, OrderCriterion, SelectionOptions, gap_only,
};

use crate::routes::{RouteDetails, RouteFit};
use crate::selection::criterion_ranking;
use crate::selection::held_out::{gap_fallback, held_out_choice, held_out_refusal};
use crate::selection::stable::{add_stable_choice, first_stable};
use crate::subspace_options::{feedthrough_json, feedthrough_of, order_of};

/// PBSID / SSARX on single-rate records.
pub(crate) fn pbsid(
    id: &IdentificationOptions,
    sets: &[Dataset],
    multirate: bool,
) -> Result<RouteFit> {
    if multirate {
        return Err(Error::option(
            "method",
            "pbsid and ssarx need single-rate records (every output sampled at every \
             instant); use n4sid, moesp, cva or iv for multirate data",
        ));
    }
    gap_only(id)?;
    if id.stable {
        return Err(Error::option(
            "stable",
            "not available with the pbsid or ssarx methods (A comes from the \
             state-sequence regression, with no stabilised variant)",
        ));
    }
    let past = id.horizon;
    let variant = match id.method {
        Method::Ssarx => lifted_subspace::PbsidVariant::Ssarx,
        Method::PbsidRowwise => lifted_subspace::PbsidVariant::RowWise,
        _ => lifted_subspace::PbsidVariant::Optimized,
    };
    // A record too short for the default future horizon 10 (neither
    // horizon given): the longest it supports, with a warning, as the
    // other subspace routes do (it was refused: "horizons past 10 +
    // future 10 too long for 45 samples").
    let default_future = past.map_or(10, |p| p.min(10));
    let future = match (id.future, past) {
        (Some(f), _) => f,
        (None, Some(_)) => default_future,
        (None, None) => {
            let lengths: Vec<usize> = sets.iter().map(Dataset::len).collect();
            let (nu, ny) = (sets[0].n_inputs(), sets[0].n_outputs());
            lifted_subspace::pbsid_longest_future(&lengths, nu, ny, variant, default_future)
                .unwrap_or(default_future)
        }
    };
    let opts = lifted_subspace::PbsidOptions {
        variant,
        order: order_of(id),
        past,
        future,
        feedthrough: feedthrough_of(id, false),
        ts: sets[0].ts(),
        threads: id.threads.unwrap_or(1),
        ..Default::default()
    };
    let exps: Vec<Experiment<'_>> = sets
        .iter()
        .map(|d| Experiment { u: d.u(), y: d.y() })
        .collect();
    let what = format!("{} identification", opts.variant.name());
    let mut passed_over = Vec::new();
    let (fit, structure) =
        if id.order == Order::Auto && id.order_criterion == OrderCriterion::Validation {
            pbsid_selected(
                &exps,
                &opts,
                &what,
                (&id.selection, crate::integrators::stability_bound(id, sets)),
            )?
        } else {
            let fit = lifted_subspace::pbsid_identify(&exps, &opts).ctx(&what)?;
            match opts.order {
                // The gap asked for: an unstable choice handled as the
                // default's fallback handles one (`first_stable`).
                OrderSelection::Gap { max } => {
                    let dg = &fit.diagnostics;
                    let ranking = criterion_ranking(&dg.order_selection, &dg.singular_values, max);
                    let (fit, passed) = first_stable(
                        fit,
                        ranking,
                        id.selection.stable_tries,
                        crate::integrators::stability_bound(id, sets),
                        |m: &lifted_subspace::PbsidModel| {
                            (m.diagnostics.order, m.diagnostics.spectral_radius)
                        },
                        |n| {
                            let o = lifted_subspace::PbsidOptions {
                                order: OrderSelection::Fixed(n),
                                ..opts.clone()
                            };
                            lifted_subspace::pbsid_identify(&exps, &o).ok()
                        },
                    );
                    passed_over = passed;
                    (fit, None)
                }
                OrderSelection::Fixed(_) => (fit, None),
            }
        };
    let dg = &fit.diagnostics;
    let mut diagnostics = pbsid_json(&fit);
    add_stable_choice(
        &mut diagnostics,
        &passed_over,
        dg.order,
        id.selection.stable_tries,
    );
    if let Some(obj) = diagnostics.as_object_mut() {
        obj.insert("feedthrough".into(), feedthrough_json(id));
        if let Some(st) = structure {
            obj.insert("structure_selection".into(), st);
        }
    }
    if future < default_future && id.future.is_none() && past.is_none() {
        crate::diagnostics::push_warning(
            &mut diagnostics,
            format!(
                "the default future horizon {default_future} is too long for these records (fewer Hankel columns than rows): future horizon {future}, the longest they support (--future sets it)"
            ),
        );
    }
    Ok(RouteFit {
        model: fit.model.clone(),
        diagnostics,
        kalman_gain: Some(fit.kalman_gain.clone()),
        x0: fit.x0.clone(),
        singular_values: dg.singular_values.clone(),
        order: dg.order,
        suggested_order: dg.suggested_order,
        details: RouteDetails::default(),
    })
}

/// PBSID / SSARX with the order chosen by held-out simulation fit
/// ([`lifted_subspace::select_pbsid_order`]: the folds, score and parsimony
/// rule of the N4SID/MOESP/CVA structure selection, at the whole record's
/// past horizon) and the `structure_selection` diagnostics entry
/// ([`held_out_choice`]). Records too short for the folds, or without a
/// stable model on any fold, get the singular-value gap, and the entry
/// says why.
pub(crate) fn pbsid_selected(
    exps: &[Experiment<'_>],
    opts: &lifted_subspace::PbsidOptions,
    what: &str,
    (policy, bound): (&SelectionOptions, f64),
) -> Result<(lifted_subspace::PbsidModel, Option<serde_json::Value>)> {
    let sel = match lifted_subspace::select_pbsid_order(exps, opts, &policy.structure()) {
        Ok(sel) => sel,
        Err(e) => {
            let fit = lifted_subspace::pbsid_identify(exps, opts).ctx(what)?;
            let sv = fit.diagnostics.singular_values.clone();
            let (fit, note) = gap_fallback(
                fit,
                &held_out_refusal(&e),
                &sv,
                opts.order,
                (policy.stable_tries, bound),
                |m| (m.diagnostics.order, m.diagnostics.spectral_radius),
                |n| {
                    let o = lifted_subspace::PbsidOptions {
                        order: OrderSelection::Fixed(n),
                        ..opts.clone()
                    };
                    lifted_subspace::pbsid_identify(exps, &o).ok()
                },
            );
            return Ok((fit, Some(note)));
        }
    };
    let (mut fit, d) = held_out_choice(
        &sel,
        (policy, bound),
        &format!("the whole record's past horizon {}", sel.horizon),
        |n| {
            let o = lifted_subspace::PbsidOptions {
                order: OrderSelection::Fixed(n),
                past: Some(sel.horizon),
                future: sel.future,
                ..opts.clone()
            };
            lifted_subspace::pbsid_identify(exps, &o).map_err(|e| e.to_string())
        },
        |fit| fit.diagnostics.spectral_radius,
        what,
    )?;
    // The whole records' notes on the horizons (a past shortened for
    // linearly dependent past outputs), which the identification at the
    // fixed past does not repeat.
    for note in &sel.notes {
        if !fit.diagnostics.notes.contains(note) {
            fit.diagnostics.notes.insert(0, note.clone());
        }
    }
    Ok((fit, Some(d)))
}

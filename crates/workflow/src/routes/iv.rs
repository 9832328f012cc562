//! The instrumental-variable route, single-rate and multirate (lifted IV,
//! thesis §4.5): the instruments named by the user (a logged excitation),
//! α chosen from the records, an unstable lifted estimate kept with a warning
//! or refined from a stabilised start (issue 26, 46).

use lifted_lti::Dataset;
use lifted_multirate::{ExtractOptions, LiftedIvOptions, Ordering, identify_lifted_iv};
use lifted_subspace::{
    IvExperiment, IvOptions, OrderCriterion as SubCriterion, OrderSelection, iv_identify,
};
use nalgebra::{DMatrix, DVector};
use serde_json::json;

use crate::diagnostics::{criterion_json, extraction_json, order_json};
use crate::error::{Context, Error, Result};
use crate::options::{Order, OrderCriterion, Refine, WorkflowOptions, gap_only};
use crate::refine::stabilized_start;
use crate::routes::multirate::{lifted_max_order, lifted_widths, slot_channels};
use crate::selection::multirate::held_out_orders;

use crate::routes::{RouteDetails, RouteFit, single};
use crate::selection::held_out::{gap_fallback, held_out_choice, held_out_refusal};
use crate::selection::stable::{add_stable_choice, first_stable};
use crate::selection::{criterion_ranking, push_capped_search_warning, supported_cap};
use crate::subspace_options::{
    criterion_of, feedthrough_json, feedthrough_of, order_of, strictly_proper,
};

/// IV subspace identification (single-rate, or lifted IV on a multirate
/// record); `instruments[k]`: the instrument columns of record k (`None`:
/// the inputs, the open-loop case); `names`: the instrument columns' names
/// for the diagnostics (empty: the inputs).
pub(crate) fn iv(
    opts: &WorkflowOptions,
    sets: &[Dataset],
    instruments: &[Option<&DMatrix<f64>>],
    names: &[String],
    multirate: bool,
) -> Result<RouteFit> {
    let id = &opts.identification;
    let stable = stabilized_start(opts);
    let order = order_of(id);
    if multirate {
        gap_only(id)?;
        let data = single(sets, "multirate IV identification")?;
        // Closed loop (an instrument given): the default refinement runs
        // whatever the record's length (refine::START_NOT_EFFICIENT), so an
        // unstable lifted estimate is re-estimated by the zero-padded shift
        // and the refinement, whose iterates stay stable, starts from it
        // (as with --stable); without a refinement an unstable estimate is
        // kept with the validation's warning, as on the single-rate route.
        let closed_loop = instruments.first().copied().flatten().is_some();
        let stable = stable || (closed_loop && opts.refinement.refine == Refine::Auto);
        let f = instruments
            .first()
            .copied()
            .flatten()
            .cloned()
            .unwrap_or_else(|| data.u().clone());
        let lopts = LiftedIvOptions {
            order,
            alpha: id.horizon.unwrap_or(6),
            alpha_p: id.instrument_past,
            strictly_proper: strictly_proper(id),
            enforce_stability: stable,
            extraction: ExtractOptions {
                fallback_without_root: true,
                best_of_methods: true,
                ..Default::default()
            },
            // An unstable estimate is a model with a warning (as on the
            // single-rate IV route), never a refusal: `--stable`,
            // `--refine pem` and the closed loop's default refinement
            // re-estimate it by the zero-padded shift and refine it with
            // stable iterates (`refine::stabilized_start`).
            require_stable: false,
        };
        // The default automatic order: by the held-out fit of the last
        // third (as the multirate subspace route), else the gap.
        let held_out = match (order, id.order_criterion) {
            (OrderSelection::Gap { max }, OrderCriterion::Validation) => {
                // The estimation part's instrument rows, copied once for
                // every order (the part is the same for all).
                let f_est = std::sync::OnceLock::new();
                let fit_at = |est: &Dataset, n: usize| {
                    let o = LiftedIvOptions {
                        order: OrderSelection::Fixed(n),
                        alpha: iv_alpha_for(&[est], lopts.alpha, lopts.alpha_p),
                        ..lopts.clone()
                    };
                    let f_est =
                        f_est.get_or_init(|| f.rows(0, est.len().min(f.nrows())).into_owned());
                    identify_lifted_iv(est, f_est, Ordering::ChannelMajor, &o)
                        .ok()
                        .map(|m| m.fast)
                };
                // Orders above (α − 1) p̄ (p̄ lifted outputs per frame)
                // are not identifiable: not tried (`max` may be anything
                // the caller gave), with α the longest the record holds
                // (`iv_alpha_for`, what `fit_at` gets at most: a horizon
                // beyond the record would otherwise let a search of a
                // million orders through, each lifting the record).
                let alpha = iv_alpha_for(&[data], lopts.alpha, lopts.alpha_p);
                held_out_orders(
                    data,
                    max.min(lifted_max_order(data, alpha)),
                    fit_at,
                    opts,
                    false,
                )
            }
            _ => None,
        };
        let chosen = held_out.as_ref().and_then(|sel| {
            sel.ranking
                .iter()
                .take(id.selection.stable_tries)
                .find_map(|&(n, _)| {
                    let o = LiftedIvOptions {
                        order: OrderSelection::Fixed(n),
                        ..lopts.clone()
                    };
                    let fit = identify_lifted_iv(data, &f, Ordering::ChannelMajor, &o).ok()?;
                    crate::validate::spectral_radius(&fit.fast)
                        .is_ok_and(|r| r < 1.0)
                        .then_some(fit)
                })
        });
        let from_ranking = chosen.is_some();
        let mut stabilized_note = None;
        let fit = match chosen {
            Some(fit) => fit,
            None => match identify_lifted_iv(data, &f, Ordering::ChannelMajor, &lopts) {
                Ok(fit) => fit,
                // A lifted A so unstable that not even the one-step
                // predictor regression gives (B̄, D̄): the zero-padded
                // shift's stable A instead, said in a warning (the
                // refinement then starts from it, as with `--stable`).
                Err(lifted_multirate::Error::Subspace(
                    e @ lifted_subspace::Error::UnstableEstimate { .. },
                )) if !lopts.enforce_stability => {
                    let o = LiftedIvOptions {
                        enforce_stability: true,
                        ..lopts.clone()
                    };
                    stabilized_note = Some(e.to_string());
                    identify_lifted_iv(data, &f, Ordering::ChannelMajor, &o)
                        .ctx("multirate IV identification")?
                }
                Err(e) => {
                    return Err::<RouteFit, _>(e).ctx("multirate IV identification");
                }
            },
        };
        let structure = held_out.as_ref().map(|sel| {
            let mut d = sel.diagnostics(fit.fast.order());
            if !from_ranking && let Some(obj) = d.as_object_mut() {
                obj.insert(
                    "note".into(),
                    json!("no order of the held-out ranking gave a stable model on the whole record: the singular-value gap decided"),
                );
            }
            d
        });
        let lifting =
            lifted_multirate::MultirateLifting::from_dataset(data, Ordering::ChannelMajor)
                .ctx("multirate IV identification")?;
        let lifting_period = lifting.period();
        let n = fit.fast.order();
        let suggested = lifted_subspace::gap_order(&fit.singular_values, id.max_order);
        let d = json!({
            "route": "multirate IV: lifted IV identification with causal mask, fast-model extraction",
            "extraction": extraction_json(&fit.extraction),
            "fallbacks": fit.extraction.fallback.iter().chain(&fit.bd_fallback).collect::<Vec<_>>(),
            "instrument": names,
            "lifting_period": lifting_period,
            "feedthrough": feedthrough_json(id),
            "order_selection": order_json("singular values of R22 (lifted IV)", &fit.singular_values, n, suggested),
            "stabilized": fit.stabilized,
        });
        let mut d = d;
        if let Some(why) = &stabilized_note {
            crate::diagnostics::push_warning(
                &mut d,
                format!(
                    "the lifted IV estimate was too unstable for the (B, D) regression ({why}): A re-estimated by the zero-padded shift (Maciejowski), B and D fitted to it, not refined"
                ),
            );
        }
        // An unstable lifted estimate kept (no refinement to start from
        // its zero-padded shift): the predictor regression may have moved
        // its A inside the unit circle, or the extraction may give a
        // stable fast model, which the validation's warning would not flag.
        let rho = crate::validate::spectral_radius(&fit.lifted).unwrap_or(f64::INFINITY);
        let kept_unstable = match (&fit.bd_fallback, rho >= 1.0) {
            (Some(why), _) => Some(why.clone()),
            (None, true) => Some(format!(
                "spectral radius {rho:.4} over the lifting period {lifting_period}"
            )),
            (None, false) => None,
        };
        if let Some(why) = kept_unstable {
            crate::diagnostics::push_warning(
                &mut d,
                format!(
                    "the lifted IV estimate is unstable: {why}; the fast model extracted from it is not reliable; --stable or a refinement (--refine pem; the default with an instrument) re-estimates it by the zero-padded shift and refines it with stable iterates"
                ),
            );
        }
        if fit.stabilized && !id.stable && stabilized_note.is_none() {
            crate::diagnostics::push_warning(
                &mut d,
                "the lifted IV estimate was unstable: A re-estimated by the zero-padded shift (Maciejowski), the start of the prediction-error refinement with stable iterates (--refine none keeps the unstable estimate)".to_string(),
            );
        }
        if closed_loop {
            // The IV estimate uses only the part of the signals the
            // instrument explains (refine::START_NOT_EFFICIENT).
            if let Some(obj) = d.as_object_mut() {
                obj.insert(
                    crate::refine::START_NOT_EFFICIENT.into(),
                    json!("closed-loop multirate IV: the lifted estimate uses only the part of the signals the instrument explains"),
                );
            }
        }
        if let (Some(obj), Some(st)) = (d.as_object_mut(), structure) {
            obj.insert("structure_selection".into(), st);
        }
        let details = RouteDetails {
            lifted: Some(fit.lifted.clone()),
            lifting_period: Some(lifting_period),
            lifted_channels: Some(slot_channels(&lifting)),
            ..Default::default()
        };
        return Ok(
            RouteFit::plain(fit.fast, d, &fit.singular_values, suggested).with_details(details),
        );
    }
    // A record too short for the default α = 8 (no horizon given): the
    // longest α it supports, with a warning (it was refused: "horizons past
    // 16 + future 8 too long for 45 samples").
    let alpha = match id.horizon {
        Some(a) => a,
        None => iv_alpha_for(&sets.iter().collect::<Vec<_>>(), 8, id.instrument_past),
    };
    let iopts = IvOptions {
        order,
        order_criterion: criterion_of(id.order_criterion),
        alpha,
        alpha_p: id.instrument_past,
        enforce_stability: stable,
        feedthrough: feedthrough_of(id, false),
        ts: sets[0].ts(),
        ..Default::default()
    };
    let exps: Vec<IvExperiment<'_>> = sets
        .iter()
        .zip(instruments)
        .map(|(d, f)| IvExperiment {
            u: d.u(),
            y: d.y(),
            instrument: *f,
        })
        .collect();
    let what = "IV identification";
    // The model of the options `o` at order n (the gap standing for the
    // rule, as after a selection: the rule of the held-out selection and of
    // its fallback), its order and spectral radius.
    let at_order_of = |o: &IvOptions, n: usize| {
        let o = IvOptions {
            order: OrderSelection::Fixed(n),
            order_criterion: SubCriterion::Gap,
            ..o.clone()
        };
        iv_identify(&exps, &o)
    };
    let at_order = |n: usize| at_order_of(&iopts, n);
    let bound = crate::integrators::stability_bound(id, sets);
    let order_rho = |m: &lifted_subspace::IvModel| {
        let rho = crate::validate::spectral_radius(&m.model).unwrap_or(f64::INFINITY);
        (m.diagnostics.order, rho)
    };
    let mut iv_passed_over = Vec::new();
    let mut iv_capped = None;
    let (fit, structure) = if id.order == Order::Auto
        && id.order_criterion == OrderCriterion::Validation
    {
        match lifted_subspace::select_iv_order(&exps, &iopts, &id.selection.structure()) {
            Ok(sel) => {
                let (fit, d) = held_out_choice(
                    &sel,
                    (&id.selection, bound),
                    &format!("alpha = {}", sel.horizon),
                    |n| at_order(n).map_err(|e| e.to_string()),
                    |fit| order_rho(fit).1,
                    what,
                )?;
                (fit, Some(d))
            }
            Err(e) => {
                let fit = iv_identify(&exps, &iopts).ctx(what)?;
                let sv = fit.diagnostics.singular_values.clone();
                let (fit, note) = gap_fallback(
                    fit,
                    &held_out_refusal(&e),
                    &sv,
                    iopts.order,
                    (id.selection.stable_tries, bound),
                    order_rho,
                    |n| at_order(n).ok(),
                );
                (fit, Some(note))
            }
        }
    } else {
        // An automatic order's search bound beyond what the records
        // identify: searched up to the largest supported order, with the
        // warning of the subspace routes.
        let (fit, iopts) = match iv_identify(&exps, &iopts).ctx(what) {
            Ok(fit) => (fit, iopts),
            Err(e) => match (supported_cap(&e, iopts.order), iopts.order) {
                (Some(max), OrderSelection::Gap { max: asked }) => {
                    let capped = IvOptions {
                        order: OrderSelection::Gap { max },
                        ..iopts
                    };
                    iv_capped = Some((asked, max));
                    (iv_identify(&exps, &capped).ctx(what)?, capped)
                }
                _ => return Err(e),
            },
        };
        let at_order = |n: usize| at_order_of(&iopts, n);
        match iopts.order {
            // An automatic order by the rule asked for: an unstable
            // choice handled as the held-out selection handles one
            // (`first_stable`), the rule's values kept.
            OrderSelection::Gap { max } => {
                let searched = fit.diagnostics.clone();
                let ranking =
                    criterion_ranking(&searched.order_selection, &searched.singular_values, max);
                let tries = id.selection.stable_tries;
                let (fit, passed) = first_stable(fit, ranking, tries, bound, order_rho, |n| {
                    let mut m = at_order(n).ok()?;
                    m.diagnostics.order_selection = searched.order_selection.clone();
                    m.diagnostics.suggested_order = searched.suggested_order;
                    Some(m)
                });
                iv_passed_over = passed;
                (fit, None)
            }
            OrderSelection::Fixed(_) => (fit, None),
        }
    };
    let dg = &fit.diagnostics;
    let d = json!({
        "route": "single-rate instrumental-variable subspace identification",
        "bd_route": if dg.bd_fallback.is_some() {
            "one-step predictor regression (A re-estimated with it)"
        } else if names.is_empty() {
            "output-error least squares on the data"
        } else {
            "output-error instrumental variables on the data"
        },
        "fallbacks": dg.bd_fallback.iter().collect::<Vec<_>>(),
        "stabilized": dg.stabilized,
        "feedthrough": feedthrough_json(id),
        "instrument": if names.is_empty() { json!("inputs") } else { json!(names) },
        "horizons": [dg.horizons.0, dg.horizons.1],
        "order_selection": order_json("singular values of R22", &dg.singular_values, dg.order, dg.suggested_order),
        "order_criterion": criterion_json(&dg.order_selection),
    });
    let mut d = d;
    if let (Some(obj), Some(st)) = (d.as_object_mut(), structure) {
        obj.insert("structure_selection".into(), st);
    }
    add_stable_choice(&mut d, &iv_passed_over, dg.order, id.selection.stable_tries);
    if let Some(cap) = iv_capped {
        push_capped_search_warning(&mut d, cap);
    }
    if alpha < 8 && id.horizon.is_none() {
        crate::diagnostics::push_warning(
            &mut d,
            format!(
                "the default alpha 8 is too long for these records (fewer Hankel columns than instrument rows): alpha {alpha}, the longest they support (--horizon sets it)"
            ),
        );
    }
    Ok(RouteFit {
        model: fit.model,
        diagnostics: d,
        kalman_gain: None,
        x0: fit.x0.clone(),
        singular_values: dg.singular_values.clone(),
        order: dg.order,
        suggested_order: dg.suggested_order,
        details: RouteDetails::default(),
    })
}

/// The largest α ≤ `alpha` (at least 2) for which the IV method has the
/// Hankel columns it needs on `sets`, each lifted by its frame period (1
/// for a single-rate record; `lifted_subspace::iv_longest_alpha` on the
/// frame counts and lifted widths, the instrument as wide as the inputs),
/// α_p = `alpha_p` or 2α. The held-out part of a multirate record (two
/// thirds of its frames), or a short record, may not support the route's
/// α. O(alpha · records).
pub(crate) fn iv_alpha_for(sets: &[&Dataset], alpha: usize, alpha_p: Option<usize>) -> usize {
    let Some(first) = sets.first() else {
        return alpha;
    };
    let (mb, pb) = lifted_widths(first);
    let frames: Vec<usize> = sets
        .iter()
        .map(|d| d.len() / d.frame_period().max(1))
        .collect();
    lifted_subspace::iv_longest_alpha(&frames, (mb, pb, mb), alpha, alpha_p).unwrap_or(2)
}

/// The diagonal Q of the q-Markov output weighting: one value for every
/// output or one per output, each positive and finite.
pub(crate) fn output_weighting(w: &[f64], outputs: usize) -> Result<Option<DMatrix<f64>>> {
    if w.is_empty() {
        return Ok(None);
    }
    if let Some(bad) = w.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
        return Err(Error::option(
            "output_weight",
            format!("{bad}: the weights must be positive and finite"),
        ));
    }
    let diag: Vec<f64> = match w.len() {
        1 => vec![w[0]; outputs],
        n if n == outputs => w.to_vec(),
        n => {
            return Err(Error::option(
                "output_weight",
                format!("{n} values for {outputs} outputs (give one, or one per output)"),
            ));
        }
    };
    Ok(Some(DMatrix::from_diagonal(&DVector::from_vec(diag))))
}

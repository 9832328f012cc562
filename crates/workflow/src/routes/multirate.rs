//! The multirate lifted subspace route (thesis §4; `lifted_multirate`):
//! the record lifted at its output frame, the lifted model identified and
//! the fast model extracted; the automatic order by the held-out ranking of
//! `crate::selection::multirate`, the interpolated start of
//! `super::multirate_start` competing with the lifted one.

use lifted_lti::{Dataset, StateSpace};
use lifted_multirate::{ExtractOptions, LiftedIdOptions, ProcedureOptions, identify_multirate};
use lifted_subspace::OrderSelection;
use serde_json::json;

use crate::diagnostics::{extraction_json, order_json};
use crate::error::{Context, Error, Result};
use crate::options::{IdentificationOptions, OrderCriterion, WorkflowOptions, gap_only};
use crate::refine::stabilized_start;
use crate::selection::multirate::{at_base_period, held_out_orders};

use crate::routes::{RouteDetails, RouteFit, single};
use crate::selection::gap_ranking;
use crate::selection::stable::first_stable;
use crate::subspace_options::{feedthrough_json, method_of, order_of, strictly_proper, system_of};

/// Multirate N4SID/MOESP/CVA: lifting, causal lifted subspace
/// identification, fast-model extraction (thesis chs. 4–5). With the fit,
/// the interpolated start at its order when the route has made it already
/// (`crate::routes::multirate_start::start`; the pipeline's second start).
pub(crate) fn multirate(
    opts: &WorkflowOptions,
    sets: &[Dataset],
) -> Result<(RouteFit, Option<StateSpace>)> {
    let wf = opts;
    let id = &opts.identification;
    let stable = stabilized_start(opts);
    gap_only(id)?;
    let data = single(sets, "multirate identification")?;
    // The lifting reads C at frame time 0: a record whose slow outputs (or
    // held inputs) do not start on its first sample is identified from the
    // first instant where all of them do (the model is the same; the
    // refinement and the validation use the whole record).
    let start = aligned_start(data);
    let aligned;
    let data = match start {
        Some(s) if s > 0 => {
            aligned = data.slice(s..data.len()).ctx("multirate identification")?;
            &aligned
        }
        _ => data,
    };
    // An unstable estimate is returned (the validation stage warns), not
    // refused: the library's default refusal is the thesis' experiment's
    // (spec A3.9), not a user's.
    // A record too short for the default horizon (in lifted frames): the
    // longest it supports, with a warning (the refusal named horizon 10
    // otherwise: 6000 samples of a 2×2 record lifted by 15 are 400 frames
    // of 38 values, horizon 5 at most).
    let horizon = match id.horizon {
        Some(h) => h,
        None => lifted_horizon(data, 10).unwrap_or(10),
    };
    let opts = ProcedureOptions {
        identification: LiftedIdOptions {
            method: method_of(id.method),
            order: order_of(id),
            past: horizon,
            future: horizon,
            system: system_of(id.estimator),
            strictly_proper: strictly_proper(id),
            enforce_stability: stable,
            require_stable: false,
            ..Default::default()
        },
        // The extraction whose lifting reproduces the lifted model best
        // (root, controllability, eigenvalue; the root alone amplifies
        // the noise of Ā's small eigenvalues).
        extraction: ExtractOptions {
            fallback_without_root: true,
            best_of_methods: true,
            ..Default::default()
        },
        require_stable: false,
        ..Default::default()
    };
    // The default automatic order: by the held-out fit of the last third
    // (when the record allows it), else the singular-value gap.
    let held_out = match (opts.identification.order, id.order_criterion) {
        (OrderSelection::Gap { max }, OrderCriterion::Validation) => {
            // Orders above (f − 1) p̄ (p̄ lifted outputs per frame) are not
            // identifiable at the horizon: not tried (`max` may be anything
            // the caller gave). f: the horizon, or the longest the record
            // supports when a given one is longer (the parts are fitted at
            // what they support; a horizon of 963 001 on 100 frames tried
            // as many orders, each a failed identification).
            let future = opts.identification.future;
            let second_start =
                crate::routes::multirate_start::applies(wf, std::slice::from_ref(data));
            let identifiable =
                lifted_max_order(data, lifted_horizon(data, future).unwrap_or(future));
            let fit_at = |est: &Dataset, n: usize| {
                // The horizon the estimation part supports when the
                // route's is too long for it (two thirds of the frames).
                let mut o = at_order(&opts, n);
                if let Some(s) = lifted_horizon(est, o.identification.past) {
                    o.identification.past = s;
                    o.identification.future = s;
                }
                let lifted = identify_multirate(est, None, &o).ok().map(|m| m.fast);
                if !second_start {
                    return lifted;
                }
                // The interpolated record's model where it fits the
                // part's measured samples better (crate::routes::multirate_start).
                let interp = crate::routes::multirate_start::quick_start(wf, est, n).ok();
                crate::routes::multirate_start::better(lifted, interp, est)
            };
            // Orders whose start is unstable on the first part are judged
            // by their refinement when the second start can deliver them
            // (the interpolated start is kept where it fits better).
            held_out_orders(data, max.min(identifiable), fit_at, wf, second_start)
        }
        _ => None,
    };
    if let Some(sel) = &held_out {
        // A lead judged by its refinement from an unstable start: kept when
        // the interpolated start at its order is stable on the whole record
        // (the pipeline then refines both starts and keeps the better;
        // when the lifted route fails there, the interpolated start alone).
        if let Some(n) = sel.lead_from_unstable
            && let Ok((interp, interp_d)) = crate::routes::multirate_start::start(wf, sets, Some(n))
            && crate::validate::spectral_radius(&interp).is_ok_and(|r| r < 1.0)
        {
            match identify_multirate(data, None, &at_order(&opts, n)) {
                Ok(fit) => {
                    let route =
                        multirate_fit(fit, id, data.ts(), Some(sel.diagnostics(n)), Vec::new());
                    return Ok((with_short_horizon(route, id, horizon, start), Some(interp)));
                }
                Err(e) => {
                    let e = Error::Step {
                        what: "multirate identification".into(),
                        source: Box::new(e),
                    };
                    let mut fit =
                        crate::routes::multirate_start::interpolated_route(interp, interp_d, &e);
                    if let Some(obj) = fit.diagnostics.as_object_mut() {
                        obj.insert("structure_selection".into(), sel.diagnostics(n));
                    }
                    return Ok((fit, None));
                }
            }
        }
        for &(n, _) in sel.ranking.iter().take(id.selection.stable_tries) {
            let Ok(fit) = identify_multirate(data, None, &at_order(&opts, n)) else {
                continue;
            };
            if crate::validate::spectral_radius(&fit.fast).is_ok_and(|r| r < 1.0) {
                let route = multirate_fit(fit, id, data.ts(), Some(sel.diagnostics(n)), Vec::new());
                return Ok((with_short_horizon(route, id, horizon, start), None));
            }
        }
    }
    let mut fit = identify_multirate(data, None, &opts).ctx("multirate identification")?;
    // An automatic order whose fast model is unstable gives way to the next
    // orders of the singular-value gap's ranking (up to the selection's
    // stable_tries), as
    // the single-rate selection does; the first stable one is kept, else
    // the gap's choice (unstable, warned).
    let mut passed_over = Vec::new();
    if let OrderSelection::Gap { max } = opts.identification.order {
        let ranking = gap_ranking(&fit.lifted.singular_values, max);
        (fit, passed_over) = first_stable(
            fit,
            ranking,
            id.selection.stable_tries,
            crate::integrators::stability_bound(id, sets),
            |m: &lifted_multirate::MultirateModel| {
                let rho = crate::validate::spectral_radius(&m.fast).unwrap_or(f64::INFINITY);
                (m.fast.order(), rho)
            },
            |n| identify_multirate(data, None, &at_order(&opts, n)).ok(),
        );
    }
    let structure = held_out.map(|sel| {
        let mut d = sel.diagnostics(fit.fast.order());
        if let Some(obj) = d.as_object_mut() {
            obj.insert(
                "note".into(),
                json!("no order of the held-out ranking gave a stable model on the whole record: the singular-value gap decided"),
            );
        }
        d
    });
    let route = multirate_fit(fit, id, data.ts(), structure, passed_over);
    Ok((with_short_horizon(route, id, horizon, start), None))
}

/// The first instant s < min(J, N) (J the frame period, N the record's
/// length) at which every output is sampled and every held input starts a
/// block, so that the record from s on has all phases 0; `None` when there
/// is none (phases that never meet, e.g. two outputs of period 2 at phases
/// 0 and 1). O(min(J, N) · channels).
pub(crate) fn aligned_start(data: &Dataset) -> Option<usize> {
    (0..data.frame_period().max(1).min(data.len())).find(|&s| {
        data.outputs().iter().all(|c| c.is_sampled(s))
            && data.inputs().iter().all(|c| c.is_block_start(s))
    })
}

/// `route` with a warning when the default horizon was shortened to
/// `horizon` for the record's lifted frames, and a note when the lifting
/// started at sample `start` > 0.
pub(crate) fn with_short_horizon(
    mut route: RouteFit,
    id: &IdentificationOptions,
    horizon: usize,
    start: Option<usize>,
) -> RouteFit {
    if let (Some(s), Some(obj)) = (start.filter(|&s| s > 0), route.diagnostics.as_object_mut()) {
        obj.insert(
            "lifting_start".into(),
            json!(format!(
                "the lifting starts at sample {s}, the first instant at which every output is sampled and every held input starts a block (the extraction reads C at frame time 0); the refinement and the validation use the whole record"
            )),
        );
    }
    if id.horizon.is_none() && horizon < 10 {
        crate::diagnostics::push_warning(
            &mut route.diagnostics,
            format!(
                "the default horizon 10 is too long for this record's lifted frames: horizon {horizon}, the longest it supports (--horizon sets it)"
            ),
        );
    }
    route
}

/// The lifted inputs m̄ = Σ J/m_c and outputs p̄ = Σ J/J_o per frame of
/// the record's frame period J. O(channels).
pub(crate) fn lifted_widths(data: &Dataset) -> (usize, usize) {
    let j = data.frame_period().max(1);
    (
        data.inputs().iter().map(|c| j / c.hold.max(1)).sum(),
        data.outputs().iter().map(|c| j / c.period.max(1)).sum(),
    )
}

/// The largest order a lifted identification of `data` at future horizon
/// f identifies: (f − 1) p̄, p̄ the lifted outputs per frame
/// ([`lifted_widths`]); saturating, for any f a caller gives.
pub(crate) fn lifted_max_order(data: &Dataset, future: usize) -> usize {
    let (_, frame_outputs) = lifted_widths(data);
    future.saturating_sub(1).saturating_mul(frame_outputs)
}

/// The longest horizon s ≤ `max` (s ≥ 2) for which the record lifted by
/// its frame period J gives at least as many Hankel columns as rows:
/// F − 2s + 1 ≥ 2s(m̄ + p̄), F = ⌊N/J⌋ frames of m̄ = Σ J/m_c inputs and
/// p̄ = Σ J/J_o outputs (`lifted_subspace::identify` on the lifted data);
/// `None` when `max` fits, 2 when none does (its refusal then names the
/// fewest frames any horizon needs). O(max).
pub(crate) fn lifted_horizon(data: &Dataset, max: usize) -> Option<usize> {
    let frames = data.len() / data.frame_period().max(1);
    let (m_bar, p_bar) = lifted_widths(data);
    match lifted_subspace::longest_horizon(&[frames], m_bar + p_bar, max) {
        Some(s) if s == max => None,
        s => Some(s.unwrap_or(2)),
    }
}

/// `opts` with the lifted model's order fixed at `n`.
pub(crate) fn at_order(opts: &ProcedureOptions, n: usize) -> ProcedureOptions {
    ProcedureOptions {
        identification: LiftedIdOptions {
            order: OrderSelection::Fixed(n),
            ..opts.identification.clone()
        },
        ..opts.clone()
    }
}

/// The route's fit with its diagnostics: the extraction, the lifting
/// period, the singular values and what chose the order.
pub(crate) fn multirate_fit(
    mut fit: lifted_multirate::MultirateModel,
    id: &IdentificationOptions,
    ts: f64,
    structure: Option<serde_json::Value>,
    passed_over: Vec<serde_json::Value>,
) -> RouteFit {
    // The extraction gives the fast model at the inputs' hold period hT
    // (thesis §4.6); the refinement, the validation and the model file
    // work at the record's base period T.
    let hold_period = fit.fast.ts().filter(|&t| (t - ts).abs() > 1e-9 * ts);
    let conversion = hold_period.map(|t| match at_base_period(&fit.fast, ts) {
        Ok(m) => {
            fit.fast = m;
            Ok(format!(
                "the fast model extracted at the input hold period {t} s, converted to the base period {ts} s (ZOH: d2c at {t} s, c2d at {ts} s)"
            ))
        }
        Err(e) => Err(format!(
            "the fast model is at the input hold period {t} s, not the record's base period {ts} s: it has no ZOH model at {ts} s ({e}); it is not refined, and validating it needs data at {t} s"
        )),
    });
    let n = fit.fast.order();
    let sv = &fit.lifted.singular_values;
    let suggested = lifted_subspace::gap_order(sv, id.max_order);
    let d = json!({
        "route": "multirate: lifting, causal lifted subspace identification, fast-model extraction",
        "extraction": extraction_json(&fit.extraction),
        "fallbacks": fit.extraction.fallback.iter().collect::<Vec<_>>(),
        "lifting_period": fit.lifting.period(),
        "feedthrough": feedthrough_json(id),
        "order_selection": order_json("singular values of the lifted subspace step", sv, n, suggested),
    });
    let mut d = d;
    if !passed_over.is_empty()
        && let Some(obj) = d.as_object_mut()
    {
        let kept = if crate::validate::spectral_radius(&fit.fast).is_ok_and(|r| r < 1.0) {
            format!("order {n}, the first stable one of the singular-value gap's ranking")
        } else {
            format!("order {n}, the gap's choice: no stable model among the tries")
        };
        obj.insert(
            "unstable_orders_passed_over".into(),
            json!({"tried": passed_over, "kept": kept}),
        );
    }
    if let (Some(obj), Some(st)) = (d.as_object_mut(), structure) {
        obj.insert("structure_selection".into(), st);
    }
    match conversion {
        Some(Ok(note)) => {
            if let Some(obj) = d.as_object_mut() {
                obj.insert("base_period_conversion".into(), json!(note));
            }
        }
        Some(Err(w)) => crate::diagnostics::push_warning(&mut d, w),
        None => {}
    }
    let details = RouteDetails {
        lifted: Some(fit.lifted.model.clone()),
        lifting_period: Some(fit.lifting.period()),
        lifted_channels: Some(slot_channels(&fit.lifting)),
        ..Default::default()
    };
    RouteFit::plain(fit.fast, d, sv, suggested).with_details(details)
}

/// The record's channel behind each lifted input and output of `lifting`.
pub(crate) fn slot_channels(
    lifting: &lifted_multirate::MultirateLifting,
) -> (Vec<usize>, Vec<usize>) {
    (
        lifting.input_slots().iter().map(|s| s.channel).collect(),
        lifting.output_slots().iter().map(|s| s.channel).collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use lifted_lti::{InputChannel, OutputChannel};
    use nalgebra::DMatrix;

    fn record(periods: &[(usize, usize)], n: usize) -> Dataset {
        let y = DMatrix::from_fn(n, periods.len(), |k, j| {
            let (p, o) = periods[j];
            if k % p == o { 1.0 } else { f64::NAN }
        });
        Dataset::new(
            1.0,
            DMatrix::zeros(n, 1),
            y,
            vec![InputChannel::new("u", 1)],
            periods
                .iter()
                .enumerate()
                .map(|(j, &(p, o))| OutputChannel::new(format!("y{j}"), p, o))
                .collect(),
        )
        .expect("record")
    }

    #[test]
    fn the_lifting_starts_where_every_phase_meets() {
        // y₁ every 3 from 2, y₂ every 5 from 4: 14 ≡ 2 (mod 3) ≡ 4 (mod 5).
        assert_eq!(aligned_start(&record(&[(3, 2), (5, 4)], 60)), Some(14));
        assert_eq!(aligned_start(&record(&[(1, 0), (3, 0)], 60)), Some(0));
        // Phases that never meet, and a frame longer than the record: the
        // search stops at the record's end.
        assert_eq!(aligned_start(&record(&[(2, 0), (2, 1)], 60)), None);
        assert_eq!(
            aligned_start(&record(&[(999_983, 3), (999_979, 5)], 10)),
            None
        );
    }
}

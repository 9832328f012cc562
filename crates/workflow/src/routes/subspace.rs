//! The single-rate N4SID / MOESP / CVA route on records in memory: the
//! held-out structure selection when the options leave the structure to it
//! (`crate::selection`), else the options' structure; the feedthrough test
//! (`super::feedthrough`); an unstable choice re-estimated for a stabilised
//! refinement start. O(N k²) per identification (k = (m + p)·s).

use lifted_lti::Dataset;
use lifted_pem::RefinementCheck;
use lifted_subspace::{Experiment, OrderSelection, SubspaceModel, SubspaceOptions, identify};

use crate::cache::SubspaceCache;
use crate::error::{Context, Error, Result};
use crate::options::{Order, WorkflowOptions};
use crate::selection::shortlist::{self};

use crate::selection::held_out::{select, short_horizons};
use crate::selection::stable::{add_stable_choice, stabilized_if_unstable, stable_choice};
use crate::selection::{capped_to_supported, push_capped_search_warning, with_report_of};
use crate::subspace_options::subspace_options;

/// What the single-rate subspace route gives: the model, its diagnostics,
/// the subspace options that give it on these records (the structure
/// chosen, the order fixed) and, when an automatic order was chosen by the
/// refined models' held-out fits ([`crate::selection::shortlist`]), the held-out
/// check of its refinement.
pub(crate) struct SubspaceRoute {
    pub fit: SubspaceModel,
    pub diagnostics: serde_json::Value,
    pub used: SubspaceOptions,
    pub check: Option<RefinementCheck>,
    /// The records' hash, when a cache was given (`SubspaceCache::hash`
    /// of the records identified: the records before any operating point
    /// was removed), for the other caches of the run.
    pub records_hash: Option<u64>,
}

/// Single-rate N4SID/MOESP/CVA on records in memory: the held-out
/// structure selection when the options leave the structure to it
/// ([`WorkflowOptions::wants_selection`]; an automatic order of a run that
/// refines short records is then judged by its refined models,
/// [`crate::selection::shortlist`]), else the options' structure. `remove_means`: the
/// means are removed inside the identification.
pub(crate) fn subspace(
    opts: &WorkflowOptions,
    sets: &[Dataset],
    remove_means: bool,
    cache: Option<&mut SubspaceCache>,
) -> Result<SubspaceRoute> {
    let id = &opts.identification;
    // Estimates within the integrator tolerance of the unit circle are
    // kept by the refinement's stabilised start (crate::integrators).
    let sub = SubspaceOptions {
        marginal_tolerance: crate::integrators::tolerance(opts, sets).0,
        ..subspace_options(opts, sets[0].ts(), remove_means)
    };
    let exps: Vec<Experiment<'_>> = sets
        .iter()
        .map(|d| Experiment { u: d.u(), y: d.y() })
        .collect();
    let what = format!("{} identification", sub.method.name());
    let mut capped_search = None;
    let mut passed_over = Vec::new();
    let mut short_horizon = None;
    let samples = sets.iter().map(Dataset::len).sum();
    let mut known = None;
    let mut cache = cache;
    // The records' hash, once for every cache of the run.
    let records_hash = cache.is_some().then(|| SubspaceCache::hash(&exps));
    // The feedthrough test's D = 0 fit when it was made with the fit
    // (its options and the fit).
    let mut zero_fit: Option<(SubspaceOptions, Result<lifted_subspace::SubspaceModel>)> = None;
    // The structure selection's wall time (its held-out fits and the
    // refined shortlist), a phase of `--profile` inside the subspace row.
    let mut selection_s = None;
    let (fit, structure, used) = if opts.wants_selection() {
        let judge = shortlist::judge_of(opts, samples, id.selection.tolerance);
        // A refinement's stabilised start (`--refine pem|oe` without
        // `--stable`) must not change the structure: the selection runs as
        // the plain identification's, and only an unstable choice is then
        // re-estimated by the zero-padded shift, so the refinement starts
        // from exactly the model `--refine none` writes whenever that model
        // is stable.
        let plain = SubspaceOptions {
            enforce_stability: id.stable,
            ..sub.clone()
        };
        let t_selection = std::time::Instant::now();
        let (fit, d, used, check) = select(id, &exps, plain, judge)
            .map_err(|e| order_beyond_the_records(e, id, &exps, &sub))?;
        selection_s = Some(t_selection.elapsed().as_secs_f64());
        known = check;
        let (fit, used) =
            stabilized_if_unstable(&sub, fit, used, |o| identify(&exps, o).ctx(&what))?;
        (fit, Some(d), used)
    } else {
        // A record too short for the default horizon (and no horizon
        // given): the longest it supports instead of a refusal (the
        // shortest that identifies the order, whose error names the fewest
        // samples needed, when none fits).
        let default = sub.past;
        let sub = match short_horizons(&exps, &sub) {
            Some((_, s)) if id.horizon.is_none() => {
                short_horizon = Some((default, s));
                SubspaceOptions {
                    past: s,
                    future: s,
                    ..sub
                }
            }
            _ => sub,
        };
        // The order given, the default feedthrough test to come and a
        // long record: the D = 0 fit of the test (crate::routes::feedthrough) on a
        // second thread with the fit itself (both from the kept
        // compression; the same fits as one after the other).
        let pair = match (&sub.order, cache.as_deref_mut(), records_hash) {
            (OrderSelection::Fixed(_), Some(c), Some(hash))
                if id.feedthrough.is_none()
                    && samples >= crate::routes::feedthrough::PARALLEL_SAMPLES
                    && std::thread::available_parallelism().map_or(1, |n| n.get()) > 1 =>
            {
                let zero_opts = SubspaceOptions {
                    feedthrough: lifted_subspace::Feedthrough::Zero,
                    ..sub.clone()
                };
                c.identify_pair(&exps, hash, (&sub, &zero_opts), &what)
                    .map(|(fit, zero)| (fit, (zero_opts, zero)))
            }
            _ => None,
        };
        let mut run = |o: &SubspaceOptions| match cache.as_deref_mut() {
            Some(c) => c.identify(&exps, records_hash.unwrap_or_default(), o, &what),
            None => identify(&exps, o).ctx(&what),
        };
        match sub.order {
            // The order given: identified as it is.
            OrderSelection::Fixed(_) => match pair {
                Some((fit, zero)) => {
                    zero_fit = Some(zero);
                    (fit?, None, sub)
                }
                None => (run(&sub)?, None, sub),
            },
            // An automatic order by the order rule asked for: searched as
            // the plain identification's, as the held-out selection does (a
            // refinement's stabilised start must not change the order), its
            // bound capped at what the records identify (with a warning),
            // an unstable choice handled as the held-out selection handles
            // one (`stable_choice`), and a model still unstable re-estimated
            // as the refinement's stabilised start, as after the selection.
            OrderSelection::Gap { .. } => {
                let plain = SubspaceOptions {
                    enforce_stability: id.stable,
                    ..sub.clone()
                };
                let (fit, plain, capped) = capped_to_supported(plain, &mut run)?;
                capped_search = capped;
                let (fit, used, passed) =
                    stable_choice(fit, plain, id.selection.stable_tries, &mut run);
                passed_over = passed;
                let searched = fit.diagnostics.clone();
                let (fit, used) = stabilized_if_unstable(&sub, fit, used, &mut run)?;
                (with_report_of(fit, &searched), None, used)
            }
        }
    };
    let used = SubspaceOptions {
        order: OrderSelection::Fixed(fit.diagnostics.order),
        ..used
    };
    // The default feedthrough: D kept only where the records support it
    // (crate::routes::feedthrough), the D = 0 model identified at the same
    // structure.
    let t_feedthrough = std::time::Instant::now();
    let (fit, used, feedthrough) = match crate::routes::feedthrough::settled(id, &fit) {
        Some(said) => (fit, used, said),
        None => {
            let zero_opts = SubspaceOptions {
                feedthrough: lifted_subspace::Feedthrough::Zero,
                ..used.clone()
            };
            let zero = match (zero_fit.take(), cache) {
                (Some((o, zero)), _) if o == zero_opts => zero,
                (_, Some(c)) => {
                    c.identify(&exps, records_hash.unwrap_or_default(), &zero_opts, &what)
                }
                (_, None) => identify(&exps, &zero_opts).ctx(&what),
            };
            let (fit, zero_kept, said) = crate::routes::feedthrough::choose(fit, zero, sets);
            (fit, if zero_kept { zero_opts } else { used }, said)
        }
    };
    let feedthrough_s = t_feedthrough.elapsed().as_secs_f64();
    let mut d = crate::diagnostics::subspace_json(&fit, "single-rate subspace identification");
    if let Some(obj) = d.as_object_mut() {
        obj.insert("feedthrough".into(), feedthrough);
    }
    crate::diagnostics::add_phase(&mut d, "feedthrough_s", feedthrough_s);
    if let Some(t) = selection_s {
        crate::diagnostics::add_phase(&mut d, "selection_s", t);
    }
    // The held-out search's own cap (the largest order its horizons
    // identify), said as the gap search's is (--max-order 100 searched
    // 1..=29 without a word).
    let searched = structure.as_ref().and_then(|st| {
        st.get("candidates")?
            .as_array()?
            .iter()
            .filter_map(|c| c.get("order")?.as_u64())
            .max()
    });
    if let Some(top) = searched
        && id.order == Order::Auto
        && (top as usize) < id.max_order
    {
        crate::diagnostics::push_warning(
            &mut d,
            format!(
                "orders above {top} are not identifiable from these records at the horizons tried: the automatic order searched 1..={top} instead of 1..={} (--max-order)",
                id.max_order
            ),
        );
    }
    if let (Some(obj), Some(st)) = (d.as_object_mut(), structure) {
        obj.insert("structure_selection".into(), st);
    }
    if let Some((default, s)) = short_horizon {
        crate::diagnostics::push_warning(
            &mut d,
            format!(
                "the default horizon {default} is too long for these records (fewer Hankel columns than rows): horizon {s}, the longest they support (--horizon sets it)"
            ),
        );
    }
    if let Some(cap) = capped_search {
        push_capped_search_warning(&mut d, cap);
    }
    add_stable_choice(
        &mut d,
        &passed_over,
        fit.diagnostics.order,
        id.selection.stable_tries,
    );
    Ok(SubspaceRoute {
        fit,
        diagnostics: d,
        used,
        check: known,
        records_hash,
    })
}

/// `e` said in terms of the order asked for when it is a fixed order's
/// refusal for want of samples with the horizon left to the selection
/// (which tried the shortest horizon that identifies the order): the
/// order, the records' size and the largest order the longest horizon
/// they support identifies (an identification at that horizon, O(N k²)),
/// instead of horizons the user never set. Any other error as it is.
pub(crate) fn order_beyond_the_records(
    e: Error,
    id: &crate::IdentificationOptions,
    exps: &[Experiment<'_>],
    sub: &SubspaceOptions,
) -> Error {
    let OrderSelection::Fixed(n) = sub.order else {
        return e;
    };
    let too_long = |e: &Error| match e {
        Error::Step { source, .. } => matches!(
            source.downcast_ref::<lifted_subspace::Error>(),
            Some(lifted_subspace::Error::HorizonTooLong { .. })
        ),
        _ => false,
    };
    let too_large = |e: &Error| match e {
        Error::Step { source, .. } => match source.downcast_ref::<lifted_subspace::Error>() {
            Some(lifted_subspace::Error::OrderTooLarge { max, .. }) => Some(*max),
            _ => None,
        },
        _ => None,
    };
    // An order beyond what the horizon identifies (future block rows ×
    // outputs − 1) on a record long enough for a longer one: said in
    // terms of --horizon ("model order 50 invalid: it must lie in 1..=9").
    // (The error keeps its kind — the Python package's OrderError — with
    // the remedy in its step.)
    if let (Some(max), None, Some(x)) = (too_large(&e), id.horizon, exps.first())
        && let Error::Step { what, source } = e
    {
        let ny = x.y.ncols().max(1);
        let need = (n + 1).div_ceil(ny);
        return Error::Step {
            what: format!(
                "{what} (the horizon tried identifies orders up to {max}, the future block rows × outputs − 1: give --horizon {need} or more, the record long enough for it, or a lower --order)"
            ),
            source,
        };
    }
    if id.horizon.is_some() || !too_long(&e) || exps.is_empty() {
        return e;
    }
    let (nu, ny) = (exps[0].u.ncols(), exps[0].y.ncols());
    let lengths: Vec<usize> = exps.iter().map(|x| x.u.nrows()).collect();
    let samples: usize = lengths.iter().sum();
    let Some(s) = lifted_subspace::longest_horizon(&lengths, nu + ny, sub.past.max(2)) else {
        return e;
    };
    let at = SubspaceOptions {
        past: s,
        future: s,
        ..sub.clone()
    };
    let max = match identify(exps, &at) {
        Err(lifted_subspace::Error::OrderTooLarge { max, .. }) if max < n => max,
        _ => return e,
    };
    Error::Data(format!(
        "order {n} is not identifiable from {samples} samples of {nu} input(s) and {ny} output(s) ({e}); at horizon {s}, the longest these records support, orders up to {max} are: give a lower --order or a longer record"
    ))
}

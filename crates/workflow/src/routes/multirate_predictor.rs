//! Multirate records from a plant under feedback, without an instrument:
//! the direct prediction-error method on the measured samples (issue 46;
//! `--method pbsid|ssarx|pbsid_rowwise` on a multirate record).
//!
//! **Why not the lifted subspace routes.** Under feedback the input
//! depends on past noise, so the open-loop projections of N4SID / MOESP /
//! CVA are biased; on a multirate record even the predictor-based
//! subspace methods (PBSID, SSARX) do not apply as they are: lifted over
//! the frame J, the controller acts *within* a frame on outputs measured
//! earlier in it, so the lifted loop has a direct term in both the lifted
//! plant (block lower-triangular D_L) and the lifted controller, and the
//! lifted regressors U_k correlate with the lifted innovations E_k
//! (Forssell & Ljung 1999, "Closed-loop identification revisited",
//! Automatica 35: the direct method needs a delay in the loop). At the
//! fast rate the loop is causal, so the prediction error is taken there.
//!
//! **The method** (Ljung 1999, *System Identification*, §13.4, the direct
//! method; missing outputs as in Isaksson 1993, "Identification of ARX
//! models subject to missing data", IEEE TAC 38, and Ding & Chen 2004,
//! "Identification of dual-rate systems based on finite impulse response
//! models" for the multirate setting): the fast innovations model
//!
//! x(t+1) = A x + B u + K_{m(t)} e_{m(t)},  y_{m(t)}(t) = C_{m(t)} x + e_{m(t)}(t),  (1)
//!
//! where m(t) is the set of outputs measured at t and K_{m(t)}, C_{m(t)}
//! the columns of K and the rows of C of those outputs, gives the one-step
//! predictor x̂(t+1) = A x̂ + B u + K_m (y_m − C_m x̂), with no correction
//! at an instant where nothing is measured. (A, B, C, K, x₀) minimise
//! V = Σ_t ‖e_{m(t)}(t)‖² / M over the M measured samples (each output
//! scaled by its spread), by the joint Levenberg–Marquardt iterations of
//! `lifted_pem::refine_pem` (prediction cost; D = 0 unless
//! `--feedthrough`). The input enters through u only, whatever produced
//! it, so the estimate is consistent in closed loop when (1) contains the
//! true predictor (Ljung 1999, Theorem 13.1 and §13.4): the plant and
//! the noise filter together of order n. With **one slow output** (or all
//! outputs at one period) the optimal predictor of a periodically
//! sampled LTI system is (1) exactly: between two measurements the
//! Kalman predictor runs open loop, and at the measured phase its
//! steady-state periodic gain is one constant K. With **outputs at
//! different periods** the optimal gain of an output depends on the
//! phase (how long ago the other outputs were measured); (1) keeps one
//! gain per output, a restriction whose bias was measured on the 2×2 loop
//! of issue 46 (periods 3 and 5) with white measurement noise at the true
//! order 4: over three seeds the RMS pole error was 0.0059 / 0.0032 /
//! 0.0019 and the FR error 0.010 / 0.0033 / 0.0018 at 1.5e4 / 6e4 / 2.4e5
//! samples, still falling about as 1/√N (`benches/results/closed-loop.md`, "Multirate
//! closed loop without an instrument").
//!
//! **Starts.** The iterations need a start in the optimum's basin, not a
//! consistent one: the multirate subspace route (N4SID on the lifted
//! record and the fast-model extraction, with its automatic order when
//! none is given) and the single-rate model of the record with its slow
//! outputs interpolated (`crate::routes::multirate_start`), each with the Kalman
//! gain of the gain check on the measured samples. Both are refined; the
//! one with the lower prediction cost V on the records is kept
//! (`diagnostics.multirate_predictor.candidates`). Both models have the
//! same parameters, so the in-sample cost compares them fairly; the
//! simulation error, the judge of the open-loop routes, is itself biased
//! in closed loop (the noise reaches u through the controller) and is not
//! used. The iterations run up to `--refine-max-work` whatever the
//! record's length (the start is not an estimate of its own).
//!
//! **The order** covers the plant *and* the noise's dynamics: coloured
//! noise with poles of its own (an AR(1) disturbance) needs states of its
//! own in (1), or the feedback carries the misfit into the plant's part.
//! An automatic order is the multirate subspace route's choice (a
//! simulation-fit criterion, which sees the plant only); the diagnostics
//! say so.
//!
//! **Cost.** Each start: the subspace route, then the joint iterations,
//! O(iterations · M · p · n) with p = n(n + n_u + 2 n_y) parameters
//! (`lifted_pem::pem_work_estimate`); about 1–3 s per start at
//! 4e4–6e4 samples of the loops.

use lifted_lti::{Dataset, StateSpace};
use lifted_pem::{PemCost, PemFit, PemMethod, PemOptions, refine_pem};
use serde_json::json;

use crate::diagnostics::{add_phase, push_warning};
use crate::error::{Error, Result};
use crate::gain::{GainCheckWith, checked_gain};
use crate::options::{Method, Order, Refine, WorkflowOptions};
use crate::refine::{pem_options, records_of};
use crate::routes::RouteFit;

/// `diagnostics.route` of this route.
pub const ROUTE: &str = "multirate prediction error (direct method): the fast innovations model refined on the measured samples from the multirate subspace and interpolated starts";

/// One refined start.
struct Candidate {
    start: &'static str,
    fit: PemFit,
    /// The prediction cost on the records where their iterations began
    /// (after the warm stage, when there was one).
    start_cost: f64,
    /// The warm stage's samples, when it ran.
    warm: Option<usize>,
}

/// The route (module docs). `sets`: the detrended, scaled records.
///
/// Errors: [`Error::InvalidOption`] for `--refine oe` (biased in closed
/// loop) and `--stable` with an automatic order rule other than the
/// default; the starts' errors when neither start can be made; the
/// refinement's when neither start refines.
pub(crate) fn identify(opts: &WorkflowOptions, sets: &[Dataset]) -> Result<RouteFit> {
    if opts.refinement.refine == Refine::Oe {
        return Err(Error::option(
            "refine",
            format!(
                "the {} route on multirate records is the prediction-error method (the output error is biased under feedback); use --refine pem (the default) or none",
                opts.identification.method.name()
            ),
        ));
    }
    let t_start = std::time::Instant::now();
    // The starts: the multirate N4SID route with the same order rule and
    // options, and the interpolated record's model at its order.
    let mut subspace_opts = opts.clone();
    subspace_opts.identification.method = Method::N4sid;
    subspace_opts.refinement.refine = Refine::None;
    let (route, made) = crate::routes::multirate(&subspace_opts, sets)?;
    let order = route.model.order();
    let interpolated = match made {
        Some(m) => Ok(m),
        None => crate::routes::multirate_start::start(&subspace_opts, sets, Some(order))
            .map(|(m, _)| m)
            .map_err(|e| e.to_string()),
    };
    let mut diagnostics = route.diagnostics.clone();
    add_phase(
        &mut diagnostics,
        "multirate_starts_s",
        t_start.elapsed().as_secs_f64(),
    );
    let starts: Vec<(&'static str, std::result::Result<StateSpace, String>)> = vec![
        (
            crate::routes::multirate_start::START_LIFTED,
            Ok(route.model.clone()),
        ),
        (
            crate::routes::multirate_start::START_INTERPOLATED,
            interpolated,
        ),
    ];
    if opts.refinement.refine == Refine::None {
        push_warning(
            &mut diagnostics,
            format!(
                "--refine none: the model is the multirate subspace start of the {} route, not its prediction-error estimate; the start is not consistent in closed loop",
                opts.identification.method.name()
            ),
        );
        let mut fit = route;
        fit.diagnostics = with_route(diagnostics, json!({"refined": false}));
        return Ok(fit);
    }
    let t_refine = std::time::Instant::now();
    let records = records_of(sets);
    let (marginal, _) = crate::integrators::tolerance(opts, sets);
    let mut candidates = Vec::new();
    let mut notes = Vec::new();
    for (name, start) in starts {
        let model = match start {
            Ok(m) => m,
            Err(why) => {
                notes.push(json!({"start": name, "error": why}));
                continue;
            }
        };
        let mut scratch = json!({});
        let gain = checked_gain(
            &model,
            None,
            sets,
            None,
            &mut scratch,
            GainCheckWith {
                past: 0,
                options: &opts.identification.gain_check,
                most_samples: opts.budgets.gain_check_samples,
                memo: None,
                records_hash: None,
            },
        );
        let stable_start = crate::validate::spectral_radius(&model).is_ok_and(|r| r < 1.0);
        let pem = PemOptions {
            method: PemMethod::Joint,
            keep_refined: true,
            marginal_tolerance: if opts.identification.stable || !stable_start {
                0.0
            } else {
                marginal
            },
            ..pem_options(opts, &model, PemCost::Prediction, false)
        };
        // Long records: the iterations first run on a leading part
        // ([`WARM_SAMPLES`]), from whose optimum the whole records need few.
        let (model, gain, warm) = match warm_start(&model, gain.as_ref(), sets, &pem) {
            Some((fit, samples)) => (fit.model, fit.kalman_gain, Some(samples)),
            None => (model, gain, None),
        };
        match refine_pem(&model, gain.as_ref(), &records, &[], &pem) {
            Ok(fit) => {
                let start_cost = fit.report.initial_cost;
                candidates.push(Candidate {
                    start: name,
                    fit,
                    start_cost,
                    warm,
                });
            }
            Err(e) => notes.push(json!({"start": name, "error": e.to_string()})),
        }
    }
    add_phase(
        &mut diagnostics,
        "multirate_predictor_s",
        t_refine.elapsed().as_secs_f64(),
    );
    let best = candidates
        .iter()
        .enumerate()
        .filter(|(_, c)| c.fit.report.final_cost.is_finite())
        .min_by(|(_, a), (_, b)| a.fit.report.final_cost.total_cmp(&b.fit.report.final_cost))
        .map(|(i, _)| i);
    let Some(best) = best else {
        let why = notes
            .iter()
            .filter_map(|n| n["error"].as_str().map(str::to_owned))
            .collect::<Vec<_>>()
            .join("; ");
        return Err(Error::Step {
            what: "multirate prediction-error identification".into(),
            source: Box::new(Error::Data(format!("no start could be refined: {why}"))),
        });
    };
    let summary = json!({
        "rule": "each start refined by the prediction error (K free, joint iterations, measured samples only); the lowest prediction cost kept",
        "candidates": candidates.iter().map(|c| json!({
            "start": c.start,
            "start_cost": c.start_cost,
            "warm_stage_samples": c.warm,
            "cost": c.fit.report.final_cost,
            "iterations": c.fit.report.iterations,
            "termination": format!("{:?}", c.fit.report.termination),
        })).chain(notes).collect::<Vec<_>>(),
        "kept": candidates[best].start,
        "order": if opts.identification.order == Order::Auto {
            "automatic: the multirate subspace route's choice (judged by simulation, which sees the plant only); under feedback with coloured noise an order covering the noise's dynamics too may predict better"
        } else {
            "given"
        },
        "consistency": if sets.first().is_some_and(one_period) {
            "one output period: the predictor with one constant Kalman gain is the optimal periodic predictor, the estimate is consistent in closed loop at the true order"
        } else {
            "outputs at different periods: one Kalman gain per output approximates the phase-dependent optimal gain (a small bias; see the crate docs)"
        },
    });
    let kept = candidates.swap_remove(best);
    let refinement = serde_json::to_value(&kept.fit.report).unwrap_or_default();
    if let (Some(cap), lifted_pem::Termination::MaxIterations) =
        (kept.fit.report.iteration_cap, kept.fit.report.termination)
    {
        push_warning(
            &mut diagnostics,
            format!(
                "the prediction-error iterations stopped at their work bound after {cap} iterations (--refine-max-work {:.1e} operations), before convergence: raise it for this record",
                opts.refinement.max_work
            ),
        );
    }
    let mut diagnostics = with_route(diagnostics, summary);
    if let Some(obj) = diagnostics.as_object_mut() {
        obj.insert("refinement".into(), refinement);
        obj.insert(
            "refinement_decision".into(),
            json!("refined by the prediction error: the route's own estimate (direct method)"),
        );
    }
    let PemFit {
        model,
        kalman_gain,
        x0,
        ..
    } = kept.fit;
    Ok(RouteFit {
        model,
        diagnostics,
        kalman_gain,
        x0,
        singular_values: route.singular_values,
        order: route.order,
        suggested_order: route.suggested_order,
        details: route.details,
    })
}

/// Samples of the warm stage: records longer than twice this are refined
/// first on their leading part of this length (cut at a frame boundary),
/// then on the whole from there. The joint iterations cost O(M p n) per
/// iteration and have no warm stages of their own (variable projection
/// does); from a start within the leading part's estimation error of the
/// whole records' optimum the iterations on the whole converge in a few
/// steps, within the work bound (at 1e6 samples the default bound 2e10
/// otherwise stopped them before convergence). 40 000 samples: where the
/// SISO loop's FR error had settled to 0.01 (`benches/results/closed-loop.md`,
/// "Multirate closed loop without an instrument").
pub const WARM_SAMPLES: usize = 40_000;

/// The warm stage (see [`WARM_SAMPLES`]): the refined fit on the leading
/// part of the one record and that part's samples; `None`
/// when the records are not long enough, not one record, or the stage
/// fails (the whole records are then refined from the start itself).
fn warm_start(
    model: &StateSpace,
    gain: Option<&nalgebra::DMatrix<f64>>,
    sets: &[Dataset],
    pem: &PemOptions,
) -> Option<(PemFit, usize)> {
    let [d] = sets else { return None };
    if d.len() <= 2 * WARM_SAMPLES {
        return None;
    }
    let frame = d.frame_period().max(1);
    let part = d.slice(0..WARM_SAMPLES / frame * frame).ok()?;
    let records = records_of(std::slice::from_ref(&part));
    let fit = refine_pem(model, gain, &records, &[], pem).ok()?;
    Some((fit, part.len()))
}

/// Whether every output of `d` is measured at one period and phase.
fn one_period(d: &Dataset) -> bool {
    let outs = d.outputs();
    outs.windows(2)
        .all(|w| w[0].period == w[1].period && w[0].offset == w[1].offset)
}

/// `diagnostics` with this route's name and summary.
fn with_route(mut diagnostics: serde_json::Value, summary: serde_json::Value) -> serde_json::Value {
    if let Some(obj) = diagnostics.as_object_mut() {
        obj.insert(
            "start_route".into(),
            obj.get("route").cloned().unwrap_or_default(),
        );
        obj.insert("route".into(), json!(ROUTE));
        obj.insert("multirate_predictor".into(), summary);
    }
    diagnostics
}

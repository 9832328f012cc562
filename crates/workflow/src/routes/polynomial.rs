//! The polynomial routes: ARX and FIR by least squares
//! (`lifted_pem::arx`), their structure from the options or from the
//! structure scan (`lifted_pem::arx_scan`); output error by
//! prediction-error minimisation (`lifted_pem::oe`), on multirate records
//! too (the cost on the measured samples).
//!
//! **Structure.** `orders` = `[na nb nk]` (ARX) or `[nb nk]` (FIR), the
//! same for every input–output pair (A full n_y × n_y), as MATLAB's
//! `arx(data, [na nb nk])`. Without it, the scan compares every structure
//! of the grid na, nb ∈ 1..=max_order (FIR: na = 0; a fixed order n: na =
//! nb = n) and nk ∈ 1..=[`SCAN_MAX_DELAY`] (from 0 when a feedthrough is
//! asked for) on one compression of the records, ranked by
//! `order_criterion`: the one-step loss on held-out data (default: the
//! last [`SCAN_HOLDOUT_SHARE`] of every record, the coefficients fitted on
//! the rest; MATLAB's `arxstruc(ze, zv, …)` with `selstruc(…, 0)`),
//! Akaike's criterion (AIC, AICc) or Rissanen's MDL (BIC) on the whole
//! records. The chosen structure is then fitted to the whole records.
//!
//! **Model.** The polynomial model with its noise covariance Λ and the
//! covariance of its parameters, in the data's units; the state-space
//! model the rest of the workflow (validation, prediction, MPC) works with
//! is its innovations realisation (A, B, C, D, K) (`PolyModel::to_innovations_ss`).
//! No refinement follows: the least-squares estimate is the
//! prediction-error estimate of the ARX structure.
//!
//! OE and BJ fit one F per input–output pair (MATLAB's `oe`, `bj`), or
//! with `f_structure` common one F per output shared by its input terms
//! (SIPPY's OE and BJ; `lifted_pem::FStructure`); `diagnostics.parameters`
//! counts a common F once.
//!
//! ARX and FIR refuse records whose outputs are measured at slower rates
//! (their regressors are past outputs at every sample); OE takes them: its
//! predictor is the simulation, scored where the outputs were measured;
//! ARMAX and BJ take them with a diagonal A: their predictor is a Kalman
//! filter on the noise model that skips the missing samples
//! (`lifted_pem::polyest`), the delays estimated as OE's.
//! OE's structure is `orders` = `[nb nf nk]` or a fixed order n (nb = nf =
//! n, nk per pair from the ARX delay estimate on single-rate records, on
//! multirate ones from the FIR regression of the measured samples,
//! `lifted_pem::estimate_delays_measured`).
//!
//! **Order scan of OE, ARMAX and BJ.** Without `orders` and with the order
//! automatic, every fixed order n = 1..=max_order (OE [n n nk], ARMAX
//! [n n n nk], BJ [n n n n nk], the delays estimated) is estimated on the
//! first two thirds of every record and its plant simulated on the last
//! third (x₀ estimated, the mean fit over the outputs' measured samples:
//! the held-out criterion of the subspace routes); the smallest order
//! within the selection's tolerance of the best
//! (`SelectionOptions::tolerance`, 0.5 points) is estimated on the whole
//! records (`diagnostics.structure_scan`). O(max_order) estimations.

use lifted_lti::{Dataset, PolyModel, PolyOrders};
use lifted_pem::{ArxOptions, ArxScanOptions, ArxStructure, StructureCriterion, arx, arx_scan};
use lifted_subspace::Experiment;
use nalgebra::DMatrix;
use serde_json::json;

use crate::error::{Context, Error, Result};
use crate::options::{IdentificationOptions, Method, Order, OrderCriterion, WorkflowOptions};
use crate::routes::{RouteDetails, RouteFit};

/// Largest input delay (samples) the structure scan tries. Default 5: the
/// scan's grid, like MATLAB's `struc(1:10, 1:10, 1:5)`; a longer delay is
/// asked for with `orders`.
pub const SCAN_MAX_DELAY: usize = 5;

/// Share of every record the held-out criterion of the structure scan
/// keeps for validation (the last third; the first two thirds estimate).
/// A split, not a tuned value: two thirds leave the estimate most of the
/// data while a third gives the held-out loss a spread of about
/// √(2/(N/3)) relative.
pub const SCAN_HOLDOUT_SHARE: f64 = 1.0 / 3.0;

/// Records shorter than this (samples, after the split) are not split for
/// the held-out criterion: AIC ranks the structures instead (with a
/// warning). 50 samples per block, at least the 20 rows per parameter of
/// the smallest structures, keep the held-out loss meaningful.
const MIN_HOLDOUT_SAMPLES: usize = 50;

/// The uniform orders of `s` for `nu` inputs and `ny` outputs.
pub(crate) fn orders_of(
    id: &IdentificationOptions,
    s: ArxStructure,
    nu: usize,
    ny: usize,
) -> PolyOrders {
    s.orders_with(nu, ny, id.a_structure.unwrap_or_default())
}

/// The structure the options fix, if they do.
pub(crate) fn fixed_structure(id: &IdentificationOptions) -> Option<ArxStructure> {
    match (id.method, id.orders.as_slice()) {
        (Method::Arx, &[na, nb, nk]) => Some(ArxStructure { na, nb, nk }),
        (Method::Fir, &[nb, nk]) => Some(ArxStructure { na: 0, nb, nk }),
        _ => None,
    }
}

/// The scan's grid for the options.
fn grid(id: &IdentificationOptions) -> ArxScanOptions {
    let (na, nb): (Vec<usize>, Vec<usize>) = match (id.method, id.order) {
        (Method::Fir, Order::Fixed(n)) => (vec![0], vec![n]),
        (Method::Fir, Order::Auto) => (vec![0], (1..=id.max_order).collect()),
        (_, Order::Fixed(n)) => (vec![n], vec![n]),
        (_, Order::Auto) => ((1..=id.max_order).collect(), (1..=id.max_order).collect()),
    };
    let first = if id.feedthrough == Some(true) { 0 } else { 1 };
    ArxScanOptions {
        na,
        nb,
        nk: (first..=SCAN_MAX_DELAY).collect(),
        threads: id.threads.unwrap_or(1),
        a_structure: id.a_structure.unwrap_or_default(),
        ..Default::default()
    }
}

/// The leading and trailing parts of every record, split at
/// 1 − [`SCAN_HOLDOUT_SHARE`].
fn split(sets: &[Dataset]) -> (Parts, Parts) {
    let mut est = Vec::new();
    let mut val = Vec::new();
    for d in sets {
        let n = d.len();
        let cut = n - (n as f64 * SCAN_HOLDOUT_SHARE).round() as usize;
        est.push((
            d.u().rows(0, cut).into_owned(),
            d.y().rows(0, cut).into_owned(),
        ));
        val.push((
            d.u().rows(cut, n - cut).into_owned(),
            d.y().rows(cut, n - cut).into_owned(),
        ));
    }
    (est, val)
}

/// Records as owned (u, y) pairs.
type Parts = Vec<(DMatrix<f64>, DMatrix<f64>)>;

/// The records as experiments, borrowed.
fn borrowed(sets: &[Dataset]) -> Vec<Experiment<'_>> {
    sets.iter()
        .map(|d| Experiment { u: d.u(), y: d.y() })
        .collect()
}

fn experiments(parts: &[(DMatrix<f64>, DMatrix<f64>)]) -> Vec<Experiment<'_>> {
    parts.iter().map(|(u, y)| Experiment { u, y }).collect()
}

/// The structure chosen by the scan, and the scan's diagnostics.
fn scanned(
    id: &IdentificationOptions,
    sets: &[Dataset],
    warnings: &mut Vec<String>,
) -> Result<(ArxStructure, serde_json::Value)> {
    let opts = grid(id);
    let shortest = sets.iter().map(Dataset::len).min().unwrap_or(0);
    let held_out = id.order_criterion == OrderCriterion::Validation
        && (shortest as f64 * SCAN_HOLDOUT_SHARE) as usize >= MIN_HOLDOUT_SAMPLES;
    if id.order_criterion == OrderCriterion::Validation && !held_out {
        warnings.push(format!(
            "the records are too short to hold out {:.0} % of them ({shortest} samples): the ARX structure was ranked by AIC",
            100.0 * SCAN_HOLDOUT_SHARE
        ));
    }
    let (criterion, scan) = if held_out {
        let (est, val) = split(sets);
        let scan =
            arx_scan(&experiments(&est), &experiments(&val), &opts).ctx("ARX structure scan")?;
        (StructureCriterion::Validation, scan)
    } else {
        let scan = arx_scan(&borrowed(sets), &[], &opts).ctx("ARX structure scan")?;
        let c = if id.order_criterion == OrderCriterion::Bic {
            StructureCriterion::Mdl
        } else {
            StructureCriterion::Aic
        };
        (c, scan)
    };
    let best = scan
        .best(criterion)
        .ok_or_else(|| Error::Data("the ARX structure scan fitted no candidate".into()))?;
    let chosen = best.structure;
    let candidates: Vec<serde_json::Value> = scan
        .rows
        .iter()
        .map(|r| {
            json!({
                "na": r.structure.na, "nb": r.structure.nb, "nk": r.structure.nk,
                "parameters": r.parameters,
                "value": r.value(criterion),
            })
        })
        .collect();
    let d = json!({
        "criterion": match criterion {
            StructureCriterion::Validation => "validation",
            StructureCriterion::Aic => "aic",
            StructureCriterion::Mdl => "mdl",
        },
        "holdout_share": held_out.then_some(SCAN_HOLDOUT_SHARE),
        "max_delay": SCAN_MAX_DELAY,
        "rows": scan.samples,
        "validation_rows": scan.validation_samples,
        "skipped": scan.skipped.len(),
        "chosen": {"na": chosen.na, "nb": chosen.nb, "nk": chosen.nk},
        "candidates": candidates,
    });
    Ok((chosen, d))
}

/// The ARX/FIR route on the (detrended, scaled) records.
///
/// Errors: [`Error::InvalidOption`] (`method`) on multirate records;
/// [`Error::Step`] with `lifted_pem`'s error (too short, not exciting).
pub(crate) fn identify(
    opts: &WorkflowOptions,
    sets: &[Dataset],
    multirate: bool,
) -> Result<RouteFit> {
    let id = &opts.identification;
    if id.method.is_iterative_polynomial() && id.orders.is_empty() && id.order == Order::Auto {
        return scanned_order(opts, sets, multirate);
    }
    if id.method == Method::Oe {
        return output_error(opts, sets, multirate);
    }
    if matches!(id.method, Method::Armax | Method::Bj) {
        return prediction_error(opts, sets, multirate);
    }
    if id.method == Method::Impulse && !multirate {
        return regularised_fir(opts, sets);
    }
    if multirate {
        return Err(Error::option(
            "method",
            format!(
                "{} needs every output sample (its predictor filters past outputs); this record has outputs measured at slower rates: use oe, armax, bj (their predictors run on the measured samples), n4sid (the multirate routes) or pbsid",
                id.method.name()
            ),
        ));
    }
    let first = sets
        .first()
        .ok_or_else(|| Error::Data("no data record".into()))?;
    let (nu, ny, ts) = (first.n_inputs(), first.y().ncols(), first.ts());
    let mut warnings = Vec::new();
    let (structure, scan) = match fixed_structure(id) {
        Some(s) => (s, serde_json::Value::Null),
        None => scanned(id, sets, &mut warnings)?,
    };
    let t_arx = std::time::Instant::now();
    let orders = orders_of(id, structure, nu, ny);
    let what = format!("{} estimation", id.method.name().to_uppercase());
    let threads = id.threads.unwrap_or(1);
    let (fit, regularisation) = match id.kernel {
        Some(kernel) if id.method == Method::Arx => {
            let o = lifted_pem::ArxRegulOptions {
                kernel,
                threads,
                ..Default::default()
            };
            let r = lifted_pem::arx_regul(&borrowed(sets), &orders, ts, &o)
                .ctx(format!("regularised {what}"))?;
            let hyper =
                |h: Option<[f64; 3]>| h.map(|h| json!({"c": h[0], "lambda": h[1], "rho": h[2]}));
            let d = json!({
                "kernel": format!("{kernel:?}"),
                "hyperparameters": r.hyperparameters.iter().map(|h| json!({"a": hyper(h.a), "b": hyper(h.b)})).collect::<Vec<_>>(),
                "objective": r.objective,
            });
            (r.arx, d)
        }
        _ => {
            let arx_opts = ArxOptions {
                threads,
                ..Default::default()
            };
            let fit = arx(&borrowed(sets), &orders, ts, &arx_opts).ctx(what)?;
            (fit, serde_json::Value::Null)
        }
    };
    let mut diagnostics = arx_diagnostics(id, structure, &fit, scan, regularisation);
    crate::diagnostics::add_phase(&mut diagnostics, "arx_s", t_arx.elapsed().as_secs_f64());
    for w in warnings {
        crate::diagnostics::push_warning(&mut diagnostics, w);
    }
    finish(fit.model, diagnostics)
}

/// The route's diagnostics of an ARX/FIR fit of `structure` (in memory or
/// streamed, `crate::stream`): the structure, the loss and fit, the
/// compression, the scan's and the regularisation's entries (null when
/// neither ran).
pub(crate) fn arx_diagnostics(
    id: &IdentificationOptions,
    structure: ArxStructure,
    fit: &lifted_pem::ArxFit,
    scan: serde_json::Value,
    regularisation: serde_json::Value,
) -> serde_json::Value {
    json!({
        "route": id.method.name(),
        "orders": {"na": structure.na, "nb": structure.nb, "nk": structure.nk},
        "a_structure": format!("{:?}", id.a_structure.unwrap_or_default()).to_lowercase(),
        "parameters": fit.model.n_parameters(),
        "loss": fit.loss,
        "one_step_fit": fit.fit,
        "rows": fit.rows,
        "compression": fit.compression.used,
        "structure_scan": scan,
        "regularization": regularisation,
    })
}

/// The polynomial model `p` of the channels scaled by `sc` in the data's
/// units (see `ChannelScales::poly`).
pub(crate) fn in_units(sc: &crate::ChannelScales, p: &PolyModel) -> Result<PolyModel> {
    sc.poly(p)
}

/// The order scan of OE, ARMAX and BJ (module docs): the route at every
/// fixed order on the first two thirds of the records, scored on the last
/// third, the smallest order within the tolerance of the best estimated
/// on the whole records.
fn scanned_order(opts: &WorkflowOptions, sets: &[Dataset], multirate: bool) -> Result<RouteFit> {
    let id = &opts.identification;
    let route = |o: &WorkflowOptions, s: &[Dataset]| {
        if id.method == Method::Oe {
            output_error(o, s, multirate)
        } else {
            prediction_error(o, s, multirate)
        }
    };
    let (mut est, mut val) = (Vec::new(), Vec::new());
    for d in sets {
        let Some((e, v, _)) = crate::selection::held_out::two_thirds(d) else {
            return Err(Error::Data(format!(
                "the {} order scan needs records it can cut into two thirds and a third; one has {} samples: give the orders or a fixed order",
                id.method.name(),
                d.len()
            )));
        };
        est.push(e);
        val.push(v);
    }
    let vopts = lifted_lti::ValidationOptions {
        lags: 1,
        horizons: Vec::new(),
        ..Default::default()
    };
    let mut candidates = Vec::new();
    let mut scores: Vec<(usize, f64)> = Vec::new();
    for n in 1..=id.max_order.max(1) {
        let mut at = opts.clone();
        at.identification.order = Order::Fixed(n);
        let scored = route(&at, &est).map_err(|e| e.to_string()).and_then(|fit| {
            if !crate::validate::spectral_radius(&fit.model).is_ok_and(|r| r < 1.0) {
                return Err("unstable plant on the first two thirds".into());
            }
            let fits: Vec<f64> = val
                .iter()
                .filter_map(|v| crate::selection::held_out::held_out_mean(&fit.model, v, &vopts))
                .collect();
            if fits.len() == val.len() {
                Ok(fits.iter().sum::<f64>() / fits.len() as f64)
            } else {
                Err("not scored on the last third".into())
            }
        });
        match scored {
            Ok(f) => {
                candidates.push(json!({"order": n, "held_out_fit": f}));
                scores.push((n, f));
            }
            Err(why) => candidates.push(json!({"order": n, "held_out_fit": null, "why": why})),
        }
    }
    let best = scores.iter().map(|s| s.1).fold(f64::NEG_INFINITY, f64::max);
    let tolerance = id.selection.tolerance;
    let Some(&(order, held_out_fit)) = scores.iter().find(|s| s.1 >= best - tolerance) else {
        return Err(Error::Data(format!(
            "no order of 1..={} gave a {} model with a stable plant on the first two thirds of the records: give the orders or a fixed order",
            id.max_order.max(1),
            id.method.name()
        )));
    };
    let mut chosen = opts.clone();
    chosen.identification.order = Order::Fixed(order);
    let mut fit = route(&chosen, sets)?;
    if let Some(obj) = fit.diagnostics.as_object_mut() {
        obj.insert(
            "structure_scan".into(),
            json!({
                "criterion": format!(
                    "simulation fit (x0 estimated, mean over the outputs' measured samples) on the last third of every record of the model estimated on the first two thirds, fixed orders 1..={}; the smallest order within {tolerance} points of the best",
                    id.max_order.max(1)
                ),
                "candidates": candidates,
                "order": order,
                "held_out_fit": held_out_fit,
            }),
        );
    }
    fit.suggested_order = fit.order;
    Ok(fit)
}

/// The input delays of every input–output pair: `nk` for all when given,
/// else estimated — by the ARX-based estimate on single-rate records, from
/// the FIR regression of the measured samples on multirate ones (the
/// ARX-based estimate needs every output sample). From 0 when a
/// feedthrough is asked for, else from 1.
fn delays_of(
    id: &IdentificationOptions,
    records: &[Experiment<'_>],
    nk: Option<usize>,
    multirate: bool,
) -> Result<Vec<Vec<usize>>> {
    let first = records
        .first()
        .ok_or_else(|| Error::Data("no data record".into()))?;
    let (nu, ny) = (first.u.ncols(), first.y.ncols());
    let first_delay = if id.feedthrough == Some(true) { 0 } else { 1 };
    let what = id.method.name().to_uppercase();
    match nk {
        Some(nk) => Ok(vec![vec![nk; nu]; ny]),
        None if !multirate => lifted_pem::estimate_delays(
            records,
            &lifted_pem::DelayOptions {
                min_delay: first_delay,
                threads: id.threads.unwrap_or(1),
                ..Default::default()
            },
        )
        .ctx(format!("{what} delay estimate")),
        None => lifted_pem::estimate_delays_measured(
            records,
            &lifted_pem::MeasuredDelayOptions {
                min_delay: first_delay,
                ..Default::default()
            },
        )
        .ctx(format!("{what} delay estimate from the measured samples")),
    }
}

/// `diagnostics.f_structure`: the F polynomials of OE and BJ.
fn f_structure_name(f: lifted_pem::FStructure) -> &'static str {
    match f {
        lifted_pem::FStructure::PerInput => "per-input",
        lifted_pem::FStructure::Common => "common",
    }
}

/// The OE route (module docs).
fn output_error(opts: &WorkflowOptions, sets: &[Dataset], multirate: bool) -> Result<RouteFit> {
    let id = &opts.identification;
    let first = sets
        .first()
        .ok_or_else(|| Error::Data("no data record".into()))?;
    let (nu, ny, ts) = (first.n_inputs(), first.y().ncols(), first.ts());
    let records = borrowed(sets);
    let (nb, nf, nk): (usize, usize, Option<usize>) = match (id.orders.as_slice(), id.order) {
        (&[nb, nf, nk], _) => (nb, nf, Some(nk)),
        (_, Order::Fixed(n)) => (n, n, None),
        _ => {
            return Err(Error::option(
                "orders",
                "oe needs orders [nb nf nk] or a fixed order",
            ));
        }
    };
    let delays = delays_of(id, &records, nk, multirate)?;
    let orders = PolyOrders {
        na: vec![vec![0; ny]; ny],
        nb: vec![vec![nb; nu]; ny],
        nc: vec![0; ny],
        nd: vec![0; ny],
        nf: vec![vec![nf; nu]; ny],
        nk: delays.clone(),
    };
    let t_oe = std::time::Instant::now();
    let f_structure = id.f_structure.unwrap_or_default();
    let oe_opts = lifted_pem::OeOptions {
        f_structure,
        ..Default::default()
    };
    let fit = lifted_pem::oe(&records, &orders, ts, &oe_opts).ctx("OE estimation")?;
    let mut diagnostics = json!({
        "route": "oe",
        "orders": {"nb": nb, "nf": nf, "nk": delays},
        "f_structure": f_structure_name(f_structure),
        "parameters": fit.parameters.iter().sum::<usize>(),
        "loss": fit.loss,
        "simulation_fit": fit.fit,
        "measured": fit.measured,
        "iterations": fit.iterations,
    });
    crate::diagnostics::add_phase(&mut diagnostics, "oe_s", t_oe.elapsed().as_secs_f64());
    finish(fit.model, diagnostics)
}

/// The ARMAX and BJ routes (`lifted_pem::polyest`): the structure from
/// `orders`, or a fixed order n for every polynomial with the delays
/// estimated.
fn prediction_error(opts: &WorkflowOptions, sets: &[Dataset], multirate: bool) -> Result<RouteFit> {
    let id = &opts.identification;
    let first = sets
        .first()
        .ok_or_else(|| Error::Data("no data record".into()))?;
    let (nu, ny, ts) = (first.n_inputs(), first.y().ncols(), first.ts());
    let records = borrowed(sets);
    let armax = id.method == Method::Armax;
    // (na, nb, nc, nd, nf, nk); nk None: estimated.
    let (na, nb, nc, nd, nf, nk) = match (id.orders.as_slice(), id.order) {
        (&[na, nb, nc, nk], _) if armax => (na, nb, nc, 0, 0, Some(nk)),
        (&[nb, nc, nd, nf, nk], _) if !armax => (0, nb, nc, nd, nf, Some(nk)),
        (_, Order::Fixed(n)) if armax => (n, n, n, 0, 0, None),
        (_, Order::Fixed(n)) => (0, n, n, n, n, None),
        _ => {
            return Err(Error::option(
                "orders",
                format!("{} needs its orders or a fixed order", id.method.name()),
            ));
        }
    };
    let delays = delays_of(id, &records, nk, multirate)?;
    // A diagonal unless a coupled one is asked for (ARMAX; BJ has none).
    let coupled = id.a_structure == Some(lifted_pem::AStructure::Full);
    let orders = PolyOrders {
        na: (0..ny)
            .map(|i| {
                (0..ny)
                    .map(|j| if i == j || coupled { na } else { 0 })
                    .collect()
            })
            .collect(),
        nb: vec![vec![nb; nu]; ny],
        nc: vec![nc; ny],
        nd: vec![nd; ny],
        nf: vec![vec![nf; nu]; ny],
        nk: delays.clone(),
    };
    let t_pem = std::time::Instant::now();
    let fit = lifted_pem::polyest(
        &records,
        &orders,
        ts,
        &lifted_pem::PolyestOptions {
            f_structure: id.f_structure.unwrap_or_default(),
            ..Default::default()
        },
    )
    .ctx(format!("{} estimation", id.method.name().to_uppercase()))?;
    let mut diagnostics = json!({
        "route": id.method.name(),
        "orders": {"na": na, "nb": nb, "nc": nc, "nd": nd, "nf": nf, "nk": delays},
        "a_structure": if coupled { "full" } else { "diagonal" },
        "f_structure": f_structure_name(id.f_structure.unwrap_or_default()),
        "parameters": fit.parameters.iter().sum::<usize>(),
        "loss": fit.loss,
        "one_step_fit": fit.fit,
        "measured": fit.measured,
        "iterations": fit.iterations,
    });
    crate::diagnostics::add_phase(&mut diagnostics, "pem_s", t_pem.elapsed().as_secs_f64());
    finish(fit.model, diagnostics)
}

/// The regularised FIR route (`lifted_pem::impulseest`).
fn regularised_fir(opts: &WorkflowOptions, sets: &[Dataset]) -> Result<RouteFit> {
    let id = &opts.identification;
    let ts = sets
        .first()
        .ok_or_else(|| Error::Data("no data record".into()))?
        .ts();
    let mut o = lifted_pem::ImpulseOptions {
        kernel: id.kernel.unwrap_or_default(),
        threads: id.threads.unwrap_or(1),
        ..Default::default()
    };
    if let &[nb, nk] = id.orders.as_slice() {
        o.lags = nb;
        o.delay = nk;
    }
    if id.feedthrough == Some(true) && id.orders.is_empty() {
        o.delay = 0;
    }
    let t_fit = std::time::Instant::now();
    let fit = lifted_pem::impulseest(&borrowed(sets), ts, &o).ctx("regularised FIR")?;
    let mut diagnostics = json!({
        "route": "impulse",
        "lags": o.lags,
        "delay": o.delay,
        "kernel": format!("{:?}", o.kernel),
        "hyperparameters": fit.hyperparameters.iter().map(|h| json!({"c": h[0], "lambda": h[1], "rho": h[2]})).collect::<Vec<_>>(),
        "objective": fit.objective,
    });
    crate::diagnostics::add_phase(&mut diagnostics, "impulse_s", t_fit.elapsed().as_secs_f64());
    finish(fit.model, diagnostics)
}

/// The route's result for a polynomial model: its innovations realisation
/// (A, B, C, D, K) as the model, the polynomials in the details.
fn finish(poly: PolyModel, diagnostics: serde_json::Value) -> Result<RouteFit> {
    let (model, k) = poly
        .to_innovations_ss()
        .ctx("the polynomial model's state-space form")?;
    let mut route = RouteFit::plain(model, diagnostics, &[], 0);
    route.suggested_order = route.order;
    route.kalman_gain = Some(k);
    Ok(route.with_details(RouteDetails {
        polynomial: Some(poly),
        ..Default::default()
    }))
}

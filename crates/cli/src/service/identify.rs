//! Identification service: CSV files and the `identify` options → a model
//! file (every route: q-Markov Cover, N4SID/MOESP/CVA in memory or streamed,
//! IV, multirate subspace and multirate IV; detrending, refinement). Used by
//! `lifted identify` and by `lifted studio`.

use lifted_lti::data::Detrend;
use lifted_lti::{Dataset, Identifier, ModelFile, OperatingPoint, StateSpace};
use lifted_multirate::{
    ExtractOptions, LiftedIdOptions, LiftedIvOptions, Ordering, ProcedureOptions,
    identify_lifted_iv, identify_multirate,
};
use lifted_qmarkov::{QMarkov, QMarkovOptions, RecordMode};
use lifted_subspace::{
    BdEstimate, Compression, Experiment, Feedthrough, IvExperiment, IvOptions, Kept, Method,
    OrderCriterion, OrderReport, OrderSelection, PemCost, PemOptions, Record, StreamedSubspace,
    StreamingIdentifier, StructureOptions, SubspaceModel, SubspaceOptions, SystemEstimate,
    identify, iv_identify, refine_pem, select_structure,
};
use nalgebra::DMatrix;
use serde_json::json;

use crate::args::{
    BdArg, CriterionArg, DataArgs, DetrendArg, EstimatorArg, IdentifyArgs, MethodArg, RefineArg,
};
use crate::error::{CliResult, Context, input};
use crate::table::{DataSpec, Loaded, load, names, parse_periods, scan_rows};

/// The order argument: a number or `auto`.
fn parse_order(s: &str, max: usize) -> CliResult<OrderSelection> {
    if s.eq_ignore_ascii_case("auto") {
        if max == 0 {
            return Err(input("--max-order must be at least 1"));
        }
        return Ok(OrderSelection::Gap { max });
    }
    match s.trim().parse::<usize>() {
        Ok(n) if n > 0 => Ok(OrderSelection::Fixed(n)),
        _ => Err(input(format!(
            "--order '{s}': expected a positive integer or 'auto'"
        ))),
    }
}

/// Builds the data specification from the column arguments; `defaults`
/// gives the channel names when `--inputs`/`--outputs` are absent.
pub fn data_spec(
    cols: &DataArgs,
    defaults: Option<(Vec<String>, Vec<String>)>,
    hold: usize,
    extra: Vec<String>,
) -> CliResult<DataSpec> {
    let (du, dy) = match defaults {
        Some((u, y)) => (Some(u), Some(y)),
        None => (None, None),
    };
    let inputs = match (&cols.inputs, du) {
        (Some(s), _) => names(s),
        (None, Some(u)) => u,
        (None, None) => return Err(input("--inputs NAME[,NAME…] is required")),
    };
    let outputs = match (&cols.outputs, dy) {
        (Some(s), _) => names(s),
        (None, Some(y)) => y,
        (None, None) => return Err(input("--outputs NAME[,NAME…] is required")),
    };
    if inputs.is_empty() || outputs.is_empty() {
        return Err(input("at least one input and one output column are needed"));
    }
    let spec = DataSpec {
        inputs,
        outputs,
        extra,
        ts: cols.ts,
        hold,
        periods: parse_periods(&cols.output_period)?,
        columns: cols.columns.as_deref().map(names).unwrap_or_default(),
    };
    spec.check_selection()?;
    Ok(spec)
}

fn method_of(m: MethodArg) -> Method {
    match m {
        MethodArg::Moesp => Method::Moesp,
        MethodArg::Cva => Method::Cva,
        _ => Method::N4sid,
    }
}

/// The subspace crate's (A, C) route for `--estimator`.
fn system_of(e: EstimatorArg) -> SystemEstimate {
    match e {
        EstimatorArg::Auto | EstimatorArg::Shift => SystemEstimate::ShiftInvariance,
        EstimatorArg::States => SystemEstimate::StateSequence,
    }
}

/// The subspace crate's (B, D) route for `--bd`.
fn bd_of(b: BdArg) -> BdEstimate {
    match b {
        BdArg::Auto => BdEstimate::Auto,
        BdArg::OutputError => BdEstimate::OutputError,
        BdArg::Projection => BdEstimate::Projection,
    }
}

/// The pooled per-channel means of the records (the operating point stored
/// with the model) and the records detrended per `--detrend`.
fn detrend_sets(
    sets: Vec<Dataset>,
    detrend: DetrendArg,
) -> CliResult<(Option<OperatingPoint>, Vec<Dataset>)> {
    let kind = match detrend {
        DetrendArg::None => return Ok((None, sets)),
        DetrendArg::Auto | DetrendArg::Mean => Detrend::Constant,
        DetrendArg::Linear => Detrend::Linear,
    };
    let us: Vec<&DMatrix<f64>> = sets.iter().map(Dataset::u).collect();
    let ys: Vec<&DMatrix<f64>> = sets.iter().map(Dataset::y).collect();
    let op = OperatingPoint::means(&us, &ys).ctx("--detrend")?;
    let out = sets
        .iter()
        .map(|d| d.detrend(kind).ctx("--detrend"))
        .collect::<CliResult<_>>()?;
    Ok((Some(op), out))
}

fn order_json(kind: &str, values: &[f64], order: usize, suggested: usize) -> serde_json::Value {
    json!({"kind": kind, "values": values, "order": order, "suggested_order": suggested})
}

/// Fails unless `--order-criterion` is the gap (the routes without the other rules).
fn gap_only(a: &IdentifyArgs) -> CliResult<()> {
    if matches!(
        a.order_criterion,
        CriterionArg::Gap | CriterionArg::Validation
    ) {
        Ok(())
    } else {
        Err(input(
            "--order-criterion applies to single-rate n4sid, moesp, cva and iv; \
             q-Markov and the multirate routes use the singular-value gap",
        ))
    }
}

/// The subspace crate's rule for `--order-criterion`.
fn criterion_of(c: CriterionArg) -> OrderCriterion {
    match c {
        // The held-out validation runs before the identification
        // (`select`); a fixed order is then passed on.
        CriterionArg::Validation | CriterionArg::Gap => OrderCriterion::Gap,
        CriterionArg::Svc => OrderCriterion::Svc,
        CriterionArg::Aic => OrderCriterion::Aic,
        CriterionArg::Aicc => OrderCriterion::Aicc,
        CriterionArg::Bic => OrderCriterion::Bic,
    }
}

/// Largest data file (bytes, all files) on which the structure of a
/// single-rate subspace identification is selected on held-out data; larger
/// files are streamed with horizon 10, shift invariance and, for an
/// automatic order, Bauer's SVC.
pub const SELECT_MAX_BYTES: u64 = 16 << 20;

/// Whether the set-up leaves the structure (horizon, (A, C) route, order) of
/// a single-rate N4SID/MOESP/CVA to the held-out validation: the default
/// `--order-criterion validation` with any of them not given.
fn wants_selection(a: &IdentifyArgs) -> bool {
    matches!(
        a.method,
        MethodArg::N4sid | MethodArg::Moesp | MethodArg::Cva
    ) && a.order_criterion == CriterionArg::Validation
        && (a.horizon.is_none()
            || a.estimator == EstimatorArg::Auto
            || a.order.trim().eq_ignore_ascii_case("auto"))
}

/// Whether the data files are small enough for the held-out selection
/// ([`SELECT_MAX_BYTES`]); a file that cannot be read counts as small (the
/// loader then names the problem).
fn small_enough_to_select(a: &IdentifyArgs) -> bool {
    let bytes: u64 = a
        .data
        .iter()
        .map(|p| std::fs::metadata(p).map_or(0, |m| m.len()))
        .sum();
    bytes <= SELECT_MAX_BYTES
}

/// Most candidates of the structure ranking identified on the whole
/// records while looking for a stable model.
const STABLE_TRIES: usize = 6;

/// The model of the structure chosen by cross-validated simulation fit for
/// `opts` on the records ([`select_structure`]), identified on the whole
/// records, and the diagnostics entry. When the chosen structure's model is
/// unstable on the whole records, the next candidates of the ranking are
/// tried (up to [`STABLE_TRIES`]) and the first stable one is kept (the
/// diagnostics say so); a selection that fails keeps `opts` (horizon 10,
/// shift invariance, the singular-value gap) and says why.
fn select(
    a: &IdentifyArgs,
    exps: &[Experiment<'_>],
    opts: SubspaceOptions,
) -> CliResult<(SubspaceModel, serde_json::Value)> {
    let what = format!("{} identification", method_of(a.method).name());
    let sel_opts = StructureOptions {
        horizons: a.horizon.map(|h| vec![h]).unwrap_or_default(),
        systems: match a.estimator {
            EstimatorArg::Auto => Vec::new(),
            e => vec![system_of(e)],
        },
        max_order: a.max_order.max(1),
        ..Default::default()
    };
    let sel = match select_structure(exps, &opts, &sel_opts) {
        Ok(sel) => sel,
        Err(e) => {
            let fit = identify(exps, &opts).ctx(&what)?;
            let d = json!({"error": format!("no structure selected by cross-validation ({e}); horizon {}, shift invariance, singular-value gap", opts.past)});
            return Ok((fit, d));
        }
    };
    let candidates: Vec<serde_json::Value> = sel
        .candidates
        .iter()
        .map(|c| {
            json!({"horizon": c.horizon, "system": system_name(c.system),
                   "order": c.order, "fit": c.fit})
        })
        .collect();
    let mut tried = Vec::new();
    let mut first_fit = None;
    for c in sel
        .ranking(sel_opts.tolerance)
        .into_iter()
        .take(STABLE_TRIES)
    {
        let o = SubspaceOptions {
            past: c.horizon,
            future: c.horizon,
            system: c.system,
            order: OrderSelection::Fixed(c.order),
            ..opts.clone()
        };
        let fit = match identify(exps, &o) {
            Ok(fit) => fit,
            Err(e) => {
                tried.push(json!({"horizon": c.horizon, "system": system_name(c.system), "order": c.order, "error": e.to_string()}));
                continue;
            }
        };
        let stable = fit.diagnostics.spectral_radius < 1.0;
        let d = json!({
            "criterion": "simulation fit on the held-out last third of the record (x0 estimated), the structure identified on the first two thirds",
            "horizon": c.horizon,
            "system": system_name(c.system),
            "order": c.order,
            "held_out_fit": c.fit,
            "folds": sel.folds,
            "unstable_on_whole_record": tried,
            "candidates": candidates,
        });
        if stable {
            return Ok((fit, d));
        }
        tried.push(json!({"horizon": c.horizon, "system": system_name(c.system), "order": c.order, "spectral_radius": fit.diagnostics.spectral_radius}));
        if first_fit.is_none() {
            first_fit = Some((fit, d));
        }
    }
    // No stable model among the tries: the first choice, unstable (the
    // caller warns).
    match first_fit {
        Some(r) => Ok(r),
        None => Err(input(format!(
            "{what}: no candidate structure could be identified on the whole record ({})",
            serde_json::Value::Array(tried)
        ))),
    }
}

/// Name of an (A, C) route in the diagnostics.
fn system_name(s: SystemEstimate) -> &'static str {
    match s {
        SystemEstimate::ShiftInvariance => "shift invariance",
        SystemEstimate::StateSequence => "state sequences",
    }
}

/// The order-selection rule's values per order (orders 1, 2, …) and choice.
fn criterion_json(r: &OrderReport) -> serde_json::Value {
    let values: Vec<Option<f64>> = r
        .values
        .iter()
        .map(|v| v.is_finite().then_some(*v))
        .collect();
    json!({"criterion": format!("{:?}", r.criterion), "values": values, "selected": r.selected})
}

/// Runs the identification and returns the model file (not yet written).
pub fn run_identification(a: &IdentifyArgs) -> CliResult<ModelFile> {
    let expanded = IdentifyArgs {
        data: crate::shards::expand(&a.data)?,
        ..a.clone()
    };
    let a = &expanded;
    if a.concat && a.method == MethodArg::Qmarkov {
        return Err(input(
            "--concat joins shards of one record; q-Markov takes one file per input",
        ));
    }
    let order = parse_order(&a.order, a.max_order)?;
    if a.refine != RefineArg::None && a.refine_iterations == 0 {
        return Err(input(
            "--refine-iterations 0: the refinement needs at least one iteration (or drop --refine)",
        ));
    }
    if a.method == MethodArg::Qmarkov {
        gap_only(a)?;
    }
    let extra = a.instrument.as_deref().map(names).unwrap_or_default();
    if !a.output_weight.is_empty() && a.method != MethodArg::Qmarkov {
        return Err(input("--output-weight is only used with --method qmarkov"));
    }
    if !extra.is_empty() && a.method != MethodArg::Iv {
        return Err(input("--instrument is only used with --method iv"));
    }
    let spec = data_spec(&a.columns, None, a.hold, extra.clone())?;
    if !extra.is_empty() && extra.len() != spec.inputs.len() {
        return Err(input(format!(
            "--instrument: {} columns for {} inputs (one instrument per input)",
            extra.len(),
            spec.inputs.len()
        )));
    }
    if let Some(file) = identify_streaming(a, &spec, order)? {
        return Ok(file);
    }
    let t_read = std::time::Instant::now();
    let mut loaded: Vec<Loaded> = a
        .data
        .iter()
        .map(|p| load(p, &spec))
        .collect::<CliResult<_>>()?;
    if a.concat {
        loaded = vec![crate::shards::join(loaded, &a.data)?];
    }
    let read_s = t_read.elapsed().as_secs_f64();
    let t_identify = std::time::Instant::now();
    let raw: Vec<Dataset> = loaded.iter().map(|l| l.data.clone()).collect();
    let multirate = raw.iter().any(|d| !d.is_single_rate());
    let subspace_single_rate = !multirate
        && matches!(
            a.method,
            MethodArg::N4sid | MethodArg::Moesp | MethodArg::Cva
        );
    // Single-rate N4SID/MOESP/CVA remove the means inside the
    // identification (as the streamed route and the Python package do:
    // the output-error regression then also estimates the constant a
    // response that started at rest keeps); the other routes take the
    // detrended records.
    let inner_means =
        subspace_single_rate && matches!(a.detrend, DetrendArg::Auto | DetrendArg::Mean);
    let (mut operating_point, mut sets) = if inner_means {
        (None, raw)
    } else {
        detrend_sets(raw, a.detrend)?
    };
    let mut kalman_gain = None;
    let ts = sets[0].ts();
    let (model, diagnostics) = match a.method {
        MethodArg::Qmarkov => qmarkov(a, &sets, order)?,
        MethodArg::N4sid | MethodArg::Moesp | MethodArg::Cva if multirate => {
            gap_only(a)?;
            let data = single(&sets, "multirate identification")?;
            let opts = ProcedureOptions {
                identification: LiftedIdOptions {
                    method: method_of(a.method),
                    order,
                    past: a.horizon.unwrap_or(10),
                    future: a.horizon.unwrap_or(10),
                    system: system_of(a.estimator),
                    enforce_stability: stabilized_start(a),
                    ..Default::default()
                },
                extraction: ExtractOptions {
                    fallback_without_root: true,
                    ..Default::default()
                },
                ..Default::default()
            };
            let fit = identify_multirate(data, None, &opts).ctx("multirate identification")?;
            let n = fit.fast.order();
            let sv = &fit.lifted.singular_values;
            let suggested = lifted_subspace::gap_order(sv, a.max_order);
            let d = json!({
                "route": "multirate: lifting, causal lifted subspace identification, fast-model extraction",
                "extraction": {
                    "method": format!("{:?}", fit.extraction.method),
                    "input_residual": fit.extraction.input_residual,
                    "fallback": fit.extraction.fallback,
                },
                "fallbacks": fit.extraction.fallback.iter().collect::<Vec<_>>(),
                "lifting_period": fit.lifting.period(),
                "order_selection": order_json("singular values of the lifted subspace step", sv, n, suggested),
            });
            (fit.fast, d)
        }
        MethodArg::N4sid | MethodArg::Moesp | MethodArg::Cva => {
            let opts = SubspaceOptions {
                method: method_of(a.method),
                order,
                order_criterion: criterion_of(a.order_criterion),
                past: a.horizon.unwrap_or(10),
                future: a.horizon.unwrap_or(10),
                system: system_of(a.estimator),
                bd: bd_of(a.bd),
                // Means removed here (--detrend mean) or already (--detrend
                // linear / none).
                remove_means: inner_means,
                enforce_stability: stabilized_start(a),
                ts,
                ..Default::default()
            };
            let exps: Vec<Experiment<'_>> = sets
                .iter()
                .map(|d| Experiment { u: d.u(), y: d.y() })
                .collect();
            let what = format!("{} identification", method_of(a.method).name());
            let (fit, structure) = if wants_selection(a) {
                let (fit, d) = select(a, &exps, opts)?;
                (fit, Some(d))
            } else {
                (identify(&exps, &opts).ctx(&what)?, None)
            };
            let mut d = subspace_json(&fit, "single-rate subspace identification");
            if let (Some(obj), Some(st)) = (d.as_object_mut(), structure) {
                obj.insert("structure_selection".into(), st);
            }
            kalman_gain = fit.kalman_gain.clone();
            if inner_means {
                // The refinement and the stored model see deviations from
                // the identification's operating point.
                sets = sets
                    .iter()
                    .map(|r| deviations(r, fit.operating_point.as_ref()))
                    .collect::<CliResult<_>>()?;
                operating_point = fit.operating_point.clone();
            }
            (fit.model, d)
        }
        MethodArg::Pbsid | MethodArg::Ssarx => {
            if multirate {
                return Err(input(
                    "--method pbsid and ssarx need single-rate records (every output sampled at every \
                     instant); use n4sid, moesp, cva or iv for multirate data",
                ));
            }
            gap_only(a)?;
            if a.stable {
                return Err(input(
                    "--stable is not available with --method pbsid or ssarx (A comes from the \
                     state-sequence regression, with no stabilised variant)",
                ));
            }
            let past = a.horizon;
            let opts = lifted_subspace::PbsidOptions {
                variant: if a.method == MethodArg::Ssarx {
                    lifted_subspace::PbsidVariant::Ssarx
                } else {
                    lifted_subspace::PbsidVariant::Optimized
                },
                order,
                past,
                future: past.map_or(10, |p| p.min(10)),
                ts,
                ..Default::default()
            };
            let exps: Vec<Experiment<'_>> = sets
                .iter()
                .map(|d| Experiment { u: d.u(), y: d.y() })
                .collect();
            let what = format!("{} identification", opts.variant.name());
            let fit = lifted_subspace::pbsid_identify(&exps, &opts).ctx(&what)?;
            kalman_gain = Some(fit.kalman_gain.clone());
            (fit.model.clone(), pbsid_json(&fit))
        }
        MethodArg::Iv => {
            let instruments: Vec<Option<&DMatrix<f64>>> = loaded
                .iter()
                .map(|l| {
                    if extra.is_empty() {
                        None
                    } else {
                        Some(&l.extra)
                    }
                })
                .collect();
            if multirate {
                gap_only(a)?;
                let data = single(&sets, "multirate IV identification")?;
                let f = instruments[0].cloned().unwrap_or_else(|| data.u().clone());
                let opts = LiftedIvOptions {
                    order,
                    alpha: a.horizon.unwrap_or(6),
                    enforce_stability: stabilized_start(a),
                    extraction: ExtractOptions {
                        fallback_without_root: true,
                        ..Default::default()
                    },
                    ..Default::default()
                };
                let fit = identify_lifted_iv(data, &f, Ordering::ChannelMajor, &opts)
                    .ctx("multirate IV identification")?;
                let n = fit.fast.order();
                let suggested = lifted_subspace::gap_order(&fit.singular_values, a.max_order);
                let d = json!({
                    "route": "multirate IV: lifted IV identification with causal mask, fast-model extraction",
                    "instrument": extra,
                    "order_selection": order_json("singular values of R22 (lifted IV)", &fit.singular_values, n, suggested),
                });
                (fit.fast, d)
            } else {
                let opts = IvOptions {
                    order,
                    order_criterion: criterion_of(a.order_criterion),
                    alpha: a.horizon.unwrap_or(8),
                    enforce_stability: stabilized_start(a),
                    ts,
                    ..Default::default()
                };
                let exps: Vec<IvExperiment<'_>> = sets
                    .iter()
                    .zip(&instruments)
                    .map(|(d, f)| IvExperiment {
                        u: d.u(),
                        y: d.y(),
                        instrument: *f,
                    })
                    .collect();
                let fit = iv_identify(&exps, &opts).ctx("IV identification")?;
                let dg = &fit.diagnostics;
                let d = json!({
                    "route": "single-rate instrumental-variable subspace identification",
                    "stabilized": dg.stabilized,
                    "instrument": if extra.is_empty() { json!("inputs") } else { json!(extra) },
                    "horizons": [dg.horizons.0, dg.horizons.1],
                    "order_selection": order_json("singular values of R22", &dg.singular_values, dg.order, dg.suggested_order),
                    "order_criterion": criterion_json(&dg.order_selection),
                });
                (fit.model, d)
            }
        }
    };
    let (model, diagnostics) = refine(a, model, diagnostics, &sets, &mut kalman_gain)?;
    let model = model
        .with_input_names(spec.inputs.clone())
        .and_then(|m| m.with_output_names(spec.outputs.clone()))
        .ctx("identify")?;
    let identify_s = t_identify.elapsed().as_secs_f64();
    let periods: Vec<usize> = sets[0].outputs().iter().map(|c| c.period).collect();
    let samples = sets.iter().map(Dataset::len).sum::<usize>();
    let mut diagnostics = diagnostics;
    add_run_facts(
        &mut diagnostics,
        a,
        samples,
        ts,
        &periods,
        read_s,
        identify_s,
    );
    finish_file(
        ModelFile::new(model)
            .with_method(a.method.name())
            .with_diagnostics(diagnostics),
        operating_point,
        kalman_gain.as_ref(),
    )
}

/// The diagonal Q of `--output-weight`: one value for every output or one
/// per output, each positive and finite.
fn output_weighting(w: &[f64], outputs: usize) -> CliResult<Option<DMatrix<f64>>> {
    if w.is_empty() {
        return Ok(None);
    }
    if let Some(bad) = w.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
        return Err(input(format!(
            "--output-weight {bad}: the weights must be positive and finite"
        )));
    }
    let diag: Vec<f64> = match w.len() {
        1 => vec![w[0]; outputs],
        n if n == outputs => w.to_vec(),
        n => {
            return Err(input(format!(
                "--output-weight: {n} values for {outputs} outputs (give one, or one per output)"
            )));
        }
    };
    Ok(Some(DMatrix::from_diagonal(&nalgebra::DVector::from_vec(
        diag,
    ))))
}

/// `--refine`: prediction-error or output-error refinement of the model on
/// the (detrended) records, measured samples only; the report goes to
/// `diagnostics.refinement` and, for `pem`, the Kalman gain is replaced.
/// What the refinement's noise model is, and when it is consistent under
/// feedback (written to the diagnostics with every refinement).
const PEM_NOISE_MODEL: [&str; 2] = [
    "innovations form of the model's own order (Kalman gain K free; the direct prediction-error method): consistent on closed-loop data when the noise is the output of an innovations model of that order (its dynamics those of the plant, as in ARMAX); noise with dynamics of its own needs the order of plant and noise together (e.g. --method pbsid at that order) or an instrument (--method iv)",
    "none (output-error cost): consistent in open loop only; under feedback the noise reaches the input and the estimate is biased",
];

fn refine(
    a: &IdentifyArgs,
    model: StateSpace,
    mut diagnostics: serde_json::Value,
    sets: &[Dataset],
    kalman_gain: &mut Option<DMatrix<f64>>,
) -> CliResult<(StateSpace, serde_json::Value)> {
    let Some(cost) = refinement_cost(a, &diagnostics) else {
        if a.stable
            && let Some(obj) = diagnostics.as_object_mut()
        {
            let route = if was_stabilized(obj) {
                STABLE_ROUTE[1]
            } else if obj.contains_key("stabilized") || obj.contains_key("stabilized_from") {
                STABLE_ROUTE[0]
            } else {
                STABLE_ROUTE[5]
            };
            obj.insert("stable_route".into(), json!(route));
        }
        return Ok((model, diagnostics));
    };
    let polish = a.refine == RefineArg::None;
    let records: Vec<Record<'_>> = sets
        .iter()
        .map(|d| Record {
            u: d.u(),
            y: d.y(),
            instrument: None,
        })
        .collect();
    let feedthrough = if model.d().iter().all(|&v| v == 0.0) {
        Feedthrough::Zero
    } else {
        Feedthrough::Free
    };
    if !(a.refine_max_work.is_finite() && a.refine_max_work > 0.0) {
        return Err(input(format!(
            "--refine-max-work must be a positive number of operations, got {}",
            a.refine_max_work
        )));
    }
    let opts = PemOptions {
        cost,
        feedthrough,
        max_iterations: a.refine_iterations,
        max_work: a.refine_max_work,
        ..Default::default()
    };
    let fit = refine_pem(&model, kalman_gain.as_ref(), &records, &[], &opts).ctx("--refine")?;
    if let (Some(cap), lifted_subspace::Termination::MaxIterations) =
        (fit.report.iteration_cap, fit.report.termination)
        && let Some(obj) = diagnostics.as_object_mut()
    {
        let warnings = obj.entry("warnings").or_insert_with(|| json!([]));
        if let Some(w) = warnings.as_array_mut() {
            w.push(json!(format!(
                "--refine stopped by its work bound after {cap} iterations (--refine-max-work {:.1e} operations), before convergence: raise --refine-max-work for this record",
                a.refine_max_work
            )));
        }
    }
    if let Some(obj) = diagnostics.as_object_mut() {
        obj.insert(
            "refinement".into(),
            serde_json::to_value(&fit.report).unwrap_or(serde_json::Value::Null),
        );
        obj.insert(
            "refinement_noise_model".into(),
            json!(PEM_NOISE_MODEL[usize::from(cost == PemCost::OutputError)]),
        );
    }
    if a.stable
        && let Some(obj) = diagnostics.as_object_mut()
    {
        let route = match (was_stabilized(obj), polish, fit.report.kept) {
            (false, _, _) => STABLE_ROUTE[0],
            (true, true, Kept::Refined) => STABLE_ROUTE[2],
            (true, true, Kept::Initial) => STABLE_ROUTE[3],
            (true, false, _) => STABLE_ROUTE[4],
        };
        obj.insert("stable_route".into(), json!(route));
    }
    if let Some(obj) = diagnostics.as_object_mut()
        && was_stabilized(obj)
    {
        obj.insert(
            "refinement_start".into(),
            json!(
                "the zero-padded-shift re-estimate of A (the unconstrained estimate was unstable)"
            ),
        );
    }
    if fit.report.kept == Kept::Refined && cost == PemCost::Prediction {
        *kalman_gain = fit.kalman_gain.clone();
    }
    Ok((fit.model, diagnostics))
}

/// Whether the routes re-estimate an unstable A by the zero-padded shift:
/// for `--stable`, and for `--refine`, whose iterates must stay stable so an
/// unstable estimate cannot start them. The zero-padded start refines to
/// models closer to the data than the library's own stabilised start (the
/// unstable eigenvalues reflected): on the 2×2 low-pass-noise records of
/// `tests.rs::stable_close` (N = 3000, order 6–8) the refined model's
/// frequency-response error against the truth was 0.05–0.36 from the
/// zero-padded start against 0.09–0.83 from the reflected one. A stable
/// estimate is not changed by it, so `--refine` still starts from exactly the
/// model plain `identify` writes whenever that model is stable.
fn stabilized_start(a: &IdentifyArgs) -> bool {
    a.stable || a.refine != RefineArg::None
}

/// `diagnostics.stable_route` of `--stable`: [not needed, zero-padded shift
/// only (route without refinement), zero-padded shift + PEM kept, zero-padded
/// shift kept over PEM, zero-padded shift + the `--refine` asked for, a
/// route that does not report whether it stabilised].
const STABLE_ROUTE: [&str; 6] = [
    "the estimate was stable: not changed",
    "unstable estimate: A re-estimated by the zero-padded shift (Maciejowski), B and D fitted to it",
    "unstable estimate: A re-estimated by the zero-padded shift (Maciejowski), then refined by the prediction-error method with every iterate stable",
    "unstable estimate: A re-estimated by the zero-padded shift (Maciejowski); the prediction-error refinement from it did not fit the data better and was not kept",
    "unstable estimate: A re-estimated by the zero-padded shift (Maciejowski), then refined by the --refine cost with every iterate stable",
    "A re-estimated by the zero-padded shift (Maciejowski) if it was unstable (this route does not report whether it was; no refinement)",
];

/// Whether the route had to stabilise its estimate (`--stable`): the
/// subspace routes' `stabilized`, the q-Markov Cover's `stabilized_from`.
fn was_stabilized(d: &serde_json::Map<String, serde_json::Value>) -> bool {
    d.get("stabilized") == Some(&json!(true))
        || d.get("stabilized_from")
            .is_some_and(serde_json::Value::is_number)
}

/// The cost of the refinement to run: `--refine`'s, or for `--stable` on
/// an estimate that had to be stabilised, the prediction-error cost from the
/// stabilised start. The zero-padded shift alone moves the poles far from
/// the data (its model's frequency-response error was about 3× the
/// unconstrained one's on the 2×2 low-pass-noise records of
/// `tests.rs::stable_close`); the refinement, whose iterates stay stable,
/// brings the model back to the data (0.2–1.0× the unconstrained error
/// there).
fn refinement_cost(a: &IdentifyArgs, diagnostics: &serde_json::Value) -> Option<PemCost> {
    match a.refine {
        RefineArg::Pem => Some(PemCost::Prediction),
        RefineArg::Oe => Some(PemCost::OutputError),
        RefineArg::None => (a.stable && diagnostics.as_object().is_some_and(was_stabilized))
            .then_some(PemCost::Prediction),
    }
}

/// Spectral radius ρ(A) of a model (0 for a static gain).
pub fn spectral_radius(model: &StateSpace) -> CliResult<f64> {
    if model.order() == 0 {
        return Ok(0.0);
    }
    Ok(model
        .poles()
        .ctx("poles of the model")?
        .iter()
        .map(|p| p.norm())
        .fold(0.0, f64::max))
}

/// The warning printed and stored for an unstable model.
pub fn unstable_warning(rho: f64) -> String {
    format!(
        "the identified model is unstable: spectral radius rho(A) = {rho:.6} >= 1; its simulation diverges, so simulation fits are not meaningful (try a lower order, --stable, or --refine pem)"
    )
}

/// Adds `stability` ({stable, spectral_radius}) to the diagnostics and, for
/// an unstable model, the warning under `warnings`.
fn add_stability(file: &mut ModelFile) -> CliResult<()> {
    let rho = spectral_radius(&file.model)?;
    let stable = rho < 1.0;
    if let Some(obj) = file.diagnostics.as_object_mut() {
        obj.insert(
            "stability".into(),
            json!({"stable": stable, "spectral_radius": rho}),
        );
        if !stable {
            let warnings = obj.entry("warnings").or_insert_with(|| json!([]));
            if let Some(w) = warnings.as_array_mut() {
                w.push(json!(unstable_warning(rho)));
            }
        }
    }
    Ok(())
}

/// Adds the operating point and the Kalman gain (when present) to a model
/// file, and its stability to the diagnostics.
fn finish_file(
    mut file: ModelFile,
    operating_point: Option<OperatingPoint>,
    kalman_gain: Option<&DMatrix<f64>>,
) -> CliResult<ModelFile> {
    add_stability(&mut file)?;
    let file = match operating_point {
        Some(op) => file.with_operating_point(op).ctx("operating point")?,
        None => file,
    };
    match kalman_gain {
        Some(k) => file.with_kalman_gain(k).ctx("Kalman gain"),
        None => Ok(file),
    }
}

fn rows(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect()
}

fn single<'a>(sets: &'a [Dataset], what: &str) -> CliResult<&'a Dataset> {
    match sets {
        [one] => Ok(one),
        _ => Err(input(format!(
            "{what} takes one data file (got {}); concatenate the records",
            sets.len()
        ))),
    }
}

fn qmarkov(
    a: &IdentifyArgs,
    sets: &[Dataset],
    order: OrderSelection,
) -> CliResult<(StateSpace, serde_json::Value)> {
    let prbs_order = a.prbs_order.unwrap_or(QMarkovOptions::default().prbs_order);
    let m = lifted_prbs::period(prbs_order).ctx("--prbs-order")? as usize;
    let hold = a.hold.max(1);
    let period = 2 * hold * m;
    let len = sets[0].len();
    let record = if len == period {
        RecordMode::OnePeriod
    } else {
        RecordMode::LastPeriod
    };
    let q = a.q.unwrap_or(60.min(hold * m - 1));
    let (order, max_auto_order) = match order {
        OrderSelection::Fixed(n) => (Some(n), a.max_order),
        OrderSelection::Gap { max } => (None, max),
    };
    let output_weighting = output_weighting(&a.output_weight, sets[0].n_outputs())?;
    let opts = QMarkovOptions {
        q,
        output_weighting,
        order,
        max_auto_order,
        hold,
        prbs_order,
        amplitudes: a.amplitude.map(|x| vec![x; sets[0].n_inputs()]),
        record,
        enforce_stability: stabilized_start(a),
        ..Default::default()
    };
    let id = QMarkov::new(opts)
        .identify(sets)
        .ctx("q-Markov Cover identification")?;
    let dg = &id.diagnostics;
    let d = json!({
        "route": "weighted multirate q-Markov Cover (Zhu 2000)",
        "q": q,
        "hold": hold,
        "prbs_order": prbs_order,
        "cover": format!("{:?}", dg.cover),
        "markov_error": dg.markov_error,
        "covariance_error": dg.covariance_error,
        "stable": dg.stable,
        "spectral_radius": dg.spectral_radius,
        "stabilized_from": dg.stabilized_from,
        "order_selection": order_json("eigenvalues of D_q (Λ diagonal)", &dg.eigenvalues, dg.order, dg.suggested_order),
    });
    Ok((id.model, d))
}

/// Rows per block pushed to the streaming identifier.
const STREAM_BLOCK: usize = 65_536;

/// What a pass over the data file saw.
struct FilePass {
    rows: usize,
    ts: f64,
    /// An output cell was empty (a multirate record): the pass stopped.
    multirate: bool,
}

/// One pass over the single data file of a streamed identification: the
/// rows of the input and output columns in blocks of [`STREAM_BLOCK`]
/// samples to `push` (u block, y block). Stops at the first empty output
/// cell (a multirate record, loaded whole by the caller instead).
fn stream_file(
    path: &str,
    spec: &DataSpec,
    mut push: impl FnMut(&DMatrix<f64>, &DMatrix<f64>) -> CliResult<()>,
) -> CliResult<FilePass> {
    let (n_u, n_y) = (spec.inputs.len(), spec.outputs.len());
    let wanted: Vec<&String> = spec.inputs.iter().chain(&spec.outputs).collect();
    let block = STREAM_BLOCK;
    let (mut ub, mut yb) = (DMatrix::zeros(block, n_u), DMatrix::zeros(block, n_y));
    let (mut fill, mut multirate) = (0usize, false);
    let (rows, ts) = scan_rows(
        path,
        &spec.columns,
        &wanted,
        n_u..n_u + n_y,
        spec.ts,
        |row| {
            if row[n_u..].iter().any(|v| v.is_nan()) {
                multirate = true;
                return Ok(false);
            }
            for (j, v) in row[..n_u].iter().enumerate() {
                ub[(fill, j)] = *v;
            }
            for (j, v) in row[n_u..].iter().enumerate() {
                yb[(fill, j)] = *v;
            }
            fill += 1;
            if fill == block {
                push(&ub, &yb)?;
                fill = 0;
            }
            Ok(true)
        },
    )?;
    if !multirate && fill > 0 {
        push(
            &ub.rows(0, fill).into_owned(),
            &yb.rows(0, fill).into_owned(),
        )?;
    }
    Ok(FilePass {
        rows,
        ts,
        multirate,
    })
}

/// Largest record (bytes of its input and output samples) the first pass of
/// a streamed identification keeps for the second, instead of reading the
/// files again: 64 MiB (1e6 samples of 2 inputs and 2 outputs take 32 MB),
/// so memory stays bounded whatever the record length.
const KEEP_MAX_BYTES: usize = 64 << 20;

/// The blocks of the first pass, while they fit in [`KEEP_MAX_BYTES`]
/// (`None` once they do not: the second pass reads the files again).
struct KeptBlocks {
    blocks: Option<Vec<(DMatrix<f64>, DMatrix<f64>)>>,
    bytes: usize,
    limit: usize,
}

impl Default for KeptBlocks {
    fn default() -> Self {
        KeptBlocks::with_limit(KEEP_MAX_BYTES)
    }
}

impl KeptBlocks {
    fn with_limit(limit: usize) -> Self {
        KeptBlocks {
            blocks: Some(Vec::new()),
            bytes: 0,
            limit,
        }
    }

    fn keep(&mut self, u: &DMatrix<f64>, y: &DMatrix<f64>) {
        let Some(blocks) = self.blocks.as_mut() else {
            return;
        };
        self.bytes += (u.len() + y.len()) * std::mem::size_of::<f64>();
        if self.bytes > self.limit {
            self.blocks = None;
        } else {
            blocks.push((u.clone(), y.clone()));
        }
    }
}

/// [`stream_file`] over the files of one record in order (`--concat`; one
/// file otherwise): the rows of all files, the sample period of the first
/// (the others must agree), the pass stopped at a multirate file.
fn stream_files(
    paths: &[String],
    spec: &DataSpec,
    mut push: impl FnMut(&DMatrix<f64>, &DMatrix<f64>) -> CliResult<()>,
) -> CliResult<FilePass> {
    let mut total = FilePass {
        rows: 0,
        ts: f64::NAN,
        multirate: false,
    };
    for (k, path) in paths.iter().enumerate() {
        let pass = stream_file(path, spec, &mut push)?;
        if k == 0 {
            total.ts = pass.ts;
        } else if (pass.ts - total.ts).abs() > 1e-9 * total.ts.abs() {
            return Err(input(format!(
                "--concat: {} has sample period {} s, {} has {} s",
                crate::shown::shown(path),
                pass.ts,
                crate::shown::shown(&paths[0]),
                total.ts
            )));
        }
        total.rows += pass.rows;
        if pass.multirate {
            total.multirate = true;
            break;
        }
    }
    Ok(total)
}

/// Single-rate N4SID / MOESP / CVA from one data file, streamed in two
/// passes: rows are read in blocks of [`STREAM_BLOCK`] and pushed to
/// `lifted_subspace::StreamingIdentifier` (the Hankel compression, then
/// (A, C)); the file is then read a second time for the output-error
/// (B, D, x₀) regression (`StreamedSubspace::regression`), so the model is
/// the one the in-memory identification gives and memory is
/// O(((m + l) s)² + block) whatever the file length. `--bd projection`
/// keeps the one-pass (B, D) from the compressed data. Returns `None` when
/// the set-up is not a single-rate subspace identification of one file, or
/// when the file turns out to be multirate (an empty output cell): the
/// caller then loads it whole. If the fast correlation compression is
/// rejected as ill-conditioned, the file is read again with the R-only QR
/// compression (reported in the diagnostics). `--refine` then refines this
/// model on the file loaded in memory, so it starts from exactly the model
/// plain `identify` writes.
fn identify_streaming(
    a: &IdentifyArgs,
    spec: &DataSpec,
    order: OrderSelection,
) -> CliResult<Option<ModelFile>> {
    let subspace = matches!(
        a.method,
        MethodArg::N4sid | MethodArg::Moesp | MethodArg::Cva
    );
    // AIC-type rules simulate candidate models on the records: in memory
    let needs_records = matches!(
        a.order_criterion,
        CriterionArg::Aic | CriterionArg::Aicc | CriterionArg::Bic
    );
    if !subspace
        || needs_records
        || (wants_selection(a) && small_enough_to_select(a))
        || a.detrend == DetrendArg::Linear
        || (a.data.len() != 1 && !a.concat)
        || !spec.periods.is_empty()
        || spec.hold > 1
        || !spec.extra.is_empty()
    {
        return Ok(None);
    }
    let paths = &a.data;
    let (n_u, n_y) = (spec.inputs.len(), spec.outputs.len());
    if n_u == 0 || n_y == 0 {
        return Ok(None); // the loader reports the missing columns
    }
    let what = format!("{} identification", method_of(a.method).name());
    // Too large a file for the held-out selection: horizon 10, shift
    // invariance, and Bauer's SVC for an automatic order.
    let criterion = match a.order_criterion {
        CriterionArg::Validation => OrderCriterion::Svc,
        c => criterion_of(c),
    };
    let opts_with = |compression: Compression| SubspaceOptions {
        method: method_of(a.method),
        order,
        order_criterion: criterion,
        past: a.horizon.unwrap_or(10),
        future: a.horizon.unwrap_or(10),
        system: system_of(a.estimator),
        bd: bd_of(a.bd),
        remove_means: a.detrend != DetrendArg::None,
        enforce_stability: stabilized_start(a),
        ts: spec.ts.unwrap_or(1.0),
        compression,
        // The machine's threads (results depend on the count through
        // rounding only): the correlation kernel and the second pass's
        // modal regression.
        threads: 0,
        ..Default::default()
    };
    let first_pass =
        |compression: Compression| -> CliResult<Option<(StreamedSubspace, FilePass, KeptBlocks)>> {
            let mut sid = StreamingIdentifier::new(n_u, n_y, &opts_with(compression)).ctx(&what)?;
            let mut kept = KeptBlocks::default();
            let pass = stream_files(paths, spec, |u, y| {
                kept.keep(u, y);
                sid.push(u, y).ctx(&what)
            })?;
            if pass.multirate {
                return Ok(None);
            }
            match sid.finish_subspace() {
                Ok(first) => Ok(Some((first, pass, kept))),
                Err(lifted_subspace::Error::IllConditionedCorrelation { .. })
                    if compression != Compression::Qr =>
                {
                    Ok(None)
                }
                Err(e) => Err(input(format!("{what}: {e}"))),
            }
        };
    let t_total = std::time::Instant::now();
    let (first, pass, kept) = match first_pass(Compression::Auto)? {
        Some(r) => r,
        None => match first_pass(Compression::Qr)? {
            Some(r) => r,
            None => return Ok(None),
        },
    };
    let read_s = t_total.elapsed().as_secs_f64();
    let fit = if first.wants_second_pass() {
        second_pass(paths, spec, first, kept, &what)?
    } else {
        first.into_model()
    };
    let identify_s = t_total.elapsed().as_secs_f64() - read_s;
    let (ts, n_rows) = (pass.ts, pass.rows);
    let m = &fit.model;
    let model = StateSpace::new(
        m.a().clone(),
        m.b().clone(),
        m.c().clone(),
        m.d().clone(),
        Some(ts),
    )
    .ctx("identify")?;
    let d = subspace_json(
        &fit,
        "single-rate subspace identification, streamed in blocks",
    );
    let mut kalman_gain = fit.kalman_gain.clone();
    let (model, mut d) = if refinement_cost(a, &d).is_none() {
        // No refinement: `refine` only records `--stable`'s route.
        refine(a, model, d, &[], &mut kalman_gain)?
    } else {
        // The refinement starts from the model above, on the file in memory
        // (deviations from the model's operating point).
        let loaded: Vec<Loaded> = paths
            .iter()
            .map(|p| load(p, spec))
            .collect::<CliResult<_>>()?;
        let loaded = crate::shards::join(loaded, paths)?;
        let set = deviations(&loaded.data, fit.operating_point.as_ref())?;
        refine(a, model, d, &[set], &mut kalman_gain)?
    };
    let model = model
        .with_input_names(spec.inputs.clone())
        .and_then(|m| m.with_output_names(spec.outputs.clone()))
        .ctx("identify")?;
    // Reading and compressing overlap: blocks are compressed as they are read.
    add_run_facts(&mut d, a, n_rows, ts, &vec![1; n_y], read_s, identify_s);
    Ok(Some(finish_file(
        ModelFile::new(model)
            .with_method(a.method.name())
            .with_diagnostics(d),
        fit.operating_point.clone(),
        kalman_gain.as_ref(),
    )?))
}

/// The second pass of the streamed identification: the file read again
/// into the output-error (B, D, x₀) regression for the first pass's
/// (A, C). A regression that cannot run (A too unstable for the record,
/// regressors rank deficient) keeps the one-pass model and says so in its
/// fallbacks.
fn second_pass(
    paths: &[String],
    spec: &DataSpec,
    first: StreamedSubspace,
    kept: KeptBlocks,
    what: &str,
) -> CliResult<SubspaceModel> {
    let mut bd = match first.regression() {
        Ok(bd) => bd,
        Err(e) => return Ok(with_fallback(first.into_model(), &e)),
    };
    match kept.blocks {
        // The first pass kept the (small) record: no second read.
        Some(blocks) => {
            for (u, y) in &blocks {
                bd.push(u, y).ctx(what)?;
            }
        }
        None => {
            stream_files(paths, spec, |u, y| bd.push(u, y).ctx(what))?;
        }
    }
    first.finish(bd).map_err(|e| input(format!("{what}: {e}")))
}

/// A record less an operating point (the data the model's deviations are
/// fitted to), or the record itself.
fn deviations(data: &Dataset, op: Option<&OperatingPoint>) -> CliResult<Dataset> {
    match op {
        Some(op) => {
            let neg = |v: &[f64]| v.iter().map(|x| -x).collect::<Vec<f64>>();
            data.shifted(&neg(&op.u0), &neg(&op.y0))
                .ctx("operating point")
        }
        None => Ok(data.clone()),
    }
}

/// The one-pass model with a note of why the output-error (B, D) was not
/// used.
fn with_fallback(mut fit: SubspaceModel, e: &lifted_subspace::Error) -> SubspaceModel {
    fit.diagnostics.fallbacks.push(format!(
        "(B, D) from the projection on the compressed data: the output-error regression was refused ({e})"
    ));
    fit
}

/// Diagnostics of a subspace fit: horizons, order selection, compression used
/// and the per-phase times (under "phases", merged into "profile" by
/// [`add_run_facts`]).
fn subspace_json(fit: &SubspaceModel, route: &str) -> serde_json::Value {
    let dg = &fit.diagnostics;
    json!({
        "route": route,
        "bd_route": dg.bd_route.name(),
        "fallbacks": dg.fallbacks,
        "stabilized": dg.stabilized,
        "horizons": [dg.horizons.0, dg.horizons.1],
        "hankel_columns": dg.columns,
        "kalman_gain": fit.kalman_gain.as_ref().map(rows),
        "order_selection": order_json("singular values of W1 Φ W2", &dg.singular_values, dg.order, dg.suggested_order),
        "order_criterion": criterion_json(&dg.order_selection),
        "compression": {
            "used": format!("{:?}", dg.compression.used),
            "rcond": dg.compression.rcond,
            "fallback": dg.compression.fallback,
        },
        "phases": {
            "compress_s": dg.profile.compress_s,
            "svd_s": dg.profile.svd_s,
            "estimate_s": dg.profile.estimate_s,
        },
    })
}

/// The diagnostics entry of a PBSID identification.
fn pbsid_json(fit: &lifted_subspace::PbsidModel) -> serde_json::Value {
    let dg = &fit.diagnostics;
    json!({
        "route": format!("single-rate predictor-based subspace identification ({})", dg.variant.name()),
        "horizons": [dg.horizons.0, dg.horizons.1],
        "past_selection": dg.past_selection.iter().map(|(p, v)| json!({"past": p, "aic": v})).collect::<Vec<_>>(),
        "hankel_columns": dg.columns,
        "kalman_gain": rows(&fit.kalman_gain),
        "innovation_covariance": rows(&fit.innovation_covariance),
        "predictor_spectral_radius": dg.predictor_spectral_radius,
        "order_selection": order_json("singular values of the predictor-based Γ_f K_p", &dg.singular_values, dg.order, dg.suggested_order),
        "compression": {
            "used": format!("{:?}", dg.compression.used),
            "rcond": dg.compression.rcond,
            "fallback": dg.compression.fallback,
        },
        "notes": dg.notes,
    })
}

/// Adds the facts of the run to the diagnostics: the data files, sample count,
/// base period, output periods, and the wall time per phase under "profile"
/// (`lifted identify --profile` prints it): reading the CSV, the whole
/// identification, and a method's own phases (moved there from "phases").
fn add_run_facts(
    diagnostics: &mut serde_json::Value,
    a: &IdentifyArgs,
    samples: usize,
    ts: f64,
    output_periods: &[usize],
    read_s: f64,
    identify_s: f64,
) {
    let Some(obj) = diagnostics.as_object_mut() else {
        return;
    };
    let mut profile = json!({ "read_s": read_s, "identify_s": identify_s });
    if let (Some(p), Some(phases)) = (profile.as_object_mut(), obj.remove("phases"))
        && let Some(ph) = phases.as_object()
    {
        for (k, v) in ph {
            p.insert(k.clone(), v.clone());
        }
    }
    obj.insert("profile".into(), profile);
    obj.insert("data".into(), json!(a.data));
    obj.insert("samples".into(), json!(samples));
    obj.insert("base_period".into(), json!(ts));
    obj.insert("output_periods".into(), json!(output_periods));
}

/// `--stable`: the model written must have every pole strictly inside the
/// unit circle (the stabilised estimates guarantee it up to rounding).
pub fn require_stable(model: &StateSpace) -> CliResult<()> {
    let rho = spectral_radius(model)?;
    if rho >= 1.0 {
        return Err(input(format!(
            "--stable: no stable estimate could be had, the model's spectral radius is {rho:.6}              (lower the order or lengthen the record)"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod kept_tests {
    use super::*;

    #[test]
    fn the_first_pass_keeps_blocks_up_to_its_limit_only() {
        let (u, y) = (DMatrix::zeros(10, 2), DMatrix::zeros(10, 2));
        // 320 bytes per block.
        let mut k = KeptBlocks::with_limit(700);
        k.keep(&u, &y);
        k.keep(&u, &y);
        assert_eq!(k.blocks.as_ref().map(Vec::len), Some(2));
        k.keep(&u, &y);
        assert!(
            k.blocks.is_none(),
            "over the limit: the files are read again"
        );
        k.keep(&u, &y);
        assert!(k.blocks.is_none());
    }
}

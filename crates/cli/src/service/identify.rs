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
    Compression, Experiment, Feedthrough, IvExperiment, IvOptions, Kept, Method, OrderCriterion,
    OrderReport, OrderSelection, PemCost, PemOptions, Record, StreamingIdentifier, SubspaceModel,
    SubspaceOptions, SystemEstimate, identify, iv_identify, refine_pem,
};
use nalgebra::DMatrix;
use serde_json::json;

use crate::args::{
    CriterionArg, DataArgs, DetrendArg, EstimatorArg, IdentifyArgs, MethodArg, RefineArg,
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
        EstimatorArg::Shift => SystemEstimate::ShiftInvariance,
        EstimatorArg::States => SystemEstimate::StateSequence,
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
    if a.order_criterion == CriterionArg::Gap {
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
        CriterionArg::Gap => OrderCriterion::Gap,
        CriterionArg::Svc => OrderCriterion::Svc,
        CriterionArg::Aic => OrderCriterion::Aic,
        CriterionArg::Aicc => OrderCriterion::Aicc,
        CriterionArg::Bic => OrderCriterion::Bic,
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
    let order = parse_order(&a.order, a.max_order)?;
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
    let loaded: Vec<Loaded> = a
        .data
        .iter()
        .map(|p| load(p, &spec))
        .collect::<CliResult<_>>()?;
    let read_s = t_read.elapsed().as_secs_f64();
    let t_identify = std::time::Instant::now();
    let sets: Vec<Dataset> = loaded.iter().map(|l| l.data.clone()).collect();
    let (operating_point, sets) = detrend_sets(sets, a.detrend)?;
    let mut kalman_gain = None;
    let ts = sets[0].ts();
    let multirate = sets.iter().any(|d| !d.is_single_rate());
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
                    enforce_stability: a.stable,
                    ..Default::default()
                },
                extraction: ExtractOptions::default(),
                ..Default::default()
            };
            let fit = identify_multirate(data, None, &opts).ctx("multirate identification")?;
            let n = fit.fast.order();
            let sv = &fit.lifted.singular_values;
            let suggested = lifted_subspace::gap_order(sv, a.max_order);
            let d = json!({
                "route": "multirate: lifting, causal lifted subspace identification, fast-model extraction",
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
                // The records are already detrended per --detrend.
                remove_means: false,
                enforce_stability: a.stable,
                ts,
                ..Default::default()
            };
            let exps: Vec<Experiment<'_>> = sets
                .iter()
                .map(|d| Experiment { u: d.u(), y: d.y() })
                .collect();
            let fit = identify(&exps, &opts)
                .ctx(format!("{} identification", method_of(a.method).name()))?;
            let d = subspace_json(&fit, "single-rate subspace identification");
            kalman_gain = fit.kalman_gain.clone();
            (fit.model, d)
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
                    enforce_stability: a.stable,
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
                    enforce_stability: a.stable,
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
fn refine(
    a: &IdentifyArgs,
    model: StateSpace,
    mut diagnostics: serde_json::Value,
    sets: &[Dataset],
    kalman_gain: &mut Option<DMatrix<f64>>,
) -> CliResult<(StateSpace, serde_json::Value)> {
    let cost = match a.refine {
        RefineArg::None => return Ok((model, diagnostics)),
        RefineArg::Pem => PemCost::Prediction,
        RefineArg::Oe => PemCost::OutputError,
    };
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
    let opts = PemOptions {
        cost,
        feedthrough,
        max_iterations: a.refine_iterations,
        ..Default::default()
    };
    let fit = refine_pem(&model, kalman_gain.as_ref(), &records, &[], &opts).ctx("--refine")?;
    if let Some(obj) = diagnostics.as_object_mut() {
        obj.insert(
            "refinement".into(),
            serde_json::to_value(&fit.report).unwrap_or(serde_json::Value::Null),
        );
    }
    if fit.report.kept == Kept::Refined && cost == PemCost::Prediction {
        *kalman_gain = fit.kalman_gain.clone();
    }
    Ok((fit.model, diagnostics))
}

/// Adds the operating point and the Kalman gain (when present) to a model file.
fn finish_file(
    file: ModelFile,
    operating_point: Option<OperatingPoint>,
    kalman_gain: Option<&DMatrix<f64>>,
) -> CliResult<ModelFile> {
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
        enforce_stability: a.stable,
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

/// Single-rate N4SID / MOESP / CVA from one CSV file, streamed: rows are read
/// in blocks of [`STREAM_BLOCK`] and pushed to `lifted_subspace::StreamingIdentifier`,
/// so memory is O(((m + l) s)² + block) whatever the file length (a 1e7-row
/// file needs no more than a 1e5-row one). Returns `None` when the set-up is not
/// a single-rate subspace identification of one file, or when the file turns out
/// to be multirate (an empty output cell): the caller then loads it whole. If the
/// fast correlation compression is rejected as ill-conditioned, the file is read
/// again with the R-only QR compression (reported in the diagnostics).
/// The initial state is not estimated on this path (it does not change the model).
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
        || a.detrend == DetrendArg::Linear
        || a.refine != RefineArg::None
        || a.data.len() != 1
        || !spec.periods.is_empty()
        || spec.hold > 1
        || !spec.extra.is_empty()
    {
        return Ok(None);
    }
    let path = &a.data[0];
    let (n_u, n_y) = (spec.inputs.len(), spec.outputs.len());
    if n_u == 0 || n_y == 0 {
        return Ok(None); // the loader reports the missing columns
    }
    let wanted: Vec<&String> = spec.inputs.iter().chain(&spec.outputs).collect();
    let what = format!("{} identification", method_of(a.method).name());
    let run = |compression: Compression| -> CliResult<Option<(SubspaceModel, usize, f64, f64)>> {
        let opts = SubspaceOptions {
            method: method_of(a.method),
            order,
            order_criterion: criterion_of(a.order_criterion),
            past: a.horizon.unwrap_or(10),
            future: a.horizon.unwrap_or(10),
            system: system_of(a.estimator),
            remove_means: a.detrend != DetrendArg::None,
            enforce_stability: a.stable,
            ts: spec.ts.unwrap_or(1.0),
            compression,
            ..Default::default()
        };
        let mut sid = StreamingIdentifier::new(n_u, n_y, &opts).ctx(&what)?;
        let block = STREAM_BLOCK;
        let (mut ub, mut yb) = (DMatrix::zeros(block, n_u), DMatrix::zeros(block, n_y));
        let (mut fill, mut multirate) = (0usize, false);
        let t = std::time::Instant::now();
        let (n_rows, ts) = scan_rows(
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
                    sid.push(&ub, &yb).ctx(&what)?;
                    fill = 0;
                }
                Ok(true)
            },
        )?;
        if multirate {
            return Ok(None);
        }
        if fill > 0 {
            sid.push(
                &ub.rows(0, fill).into_owned(),
                &yb.rows(0, fill).into_owned(),
            )
            .ctx(&what)?;
        }
        let read_s = t.elapsed().as_secs_f64();
        match sid.finish() {
            Ok(fit) => Ok(Some((fit, n_rows, ts, read_s))),
            Err(lifted_subspace::Error::IllConditionedCorrelation { .. })
                if compression != Compression::Qr =>
            {
                Ok(None)
            }
            Err(e) => Err(input(format!("{what}: {e}"))),
        }
    };
    let t_total = std::time::Instant::now();
    let (fit, n_rows, ts, read_s) = match run(Compression::Auto)? {
        Some(r) => r,
        None => match run(Compression::Qr)? {
            Some(r) => r,
            None => return Ok(None),
        },
    };
    let identify_s = t_total.elapsed().as_secs_f64() - read_s;
    let m = &fit.model;
    let model = StateSpace::new(
        m.a().clone(),
        m.b().clone(),
        m.c().clone(),
        m.d().clone(),
        Some(ts),
    )
    .and_then(|m| m.with_input_names(spec.inputs.clone()))
    .and_then(|m| m.with_output_names(spec.outputs.clone()))
    .ctx("identify")?;
    let mut d = subspace_json(
        &fit,
        "single-rate subspace identification, streamed in blocks",
    );
    // Reading and compressing overlap: blocks are compressed as they are read.
    add_run_facts(&mut d, a, n_rows, ts, &vec![1; n_y], read_s, identify_s);
    Ok(Some(finish_file(
        ModelFile::new(model)
            .with_method(a.method.name())
            .with_diagnostics(d),
        fit.operating_point.clone(),
        fit.kalman_gain.as_ref(),
    )?))
}

/// Diagnostics of a subspace fit: horizons, order selection, compression used
/// and the per-phase times (under "phases", merged into "profile" by
/// [`add_run_facts`]).
fn subspace_json(fit: &SubspaceModel, route: &str) -> serde_json::Value {
    let dg = &fit.diagnostics;
    json!({
        "route": route,
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
    if model.order() == 0 {
        return Ok(());
    }
    let rho = model
        .poles()
        .ctx("--stable: poles of the model")?
        .iter()
        .map(|p| p.norm())
        .fold(0.0, f64::max);
    if rho >= 1.0 {
        return Err(input(format!(
            "--stable: no stable estimate could be had, the model's spectral radius is {rho:.6}              (lower the order or lengthen the record)"
        )));
    }
    Ok(())
}

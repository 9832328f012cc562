//! What the studio keeps between two requests so that a move of the order
//! slider costs O(k³) and the (B, D, x₀) regression instead of a new read
//! of the CSV file and a new O(N) compression:
//!
//! * the parsed record ([`Loaded`]) of the current channel selection,
//!   keyed by the data specification (inputs, outputs, base period, hold,
//!   declared output periods);
//! * step 1 of the subspace identification
//!   ([`lifted_subspace::CompressedData`]: means removed, scaled,
//!   block-Hankel factor L) of that record, keyed by what the compression
//!   depends on (the data key, the horizon, mean removal). Each order is
//!   then [`CompressedData::identify`] on it, which equals
//!   [`lifted_subspace::identify`] on the records exactly (it is
//!   implemented so).
//!
//! # The same model as `lifted identify`
//!
//! [`in_memory_route`] says when `lifted identify` with the request's
//! options itself runs `lifted_subspace::identify` on the whole record in
//! memory (single-rate N4SID/MOESP/CVA, a fixed order, horizon and (A, C)
//! route given, so no held-out structure selection, and a set-up the
//! streamed route declines: declared output periods, a hold, an AIC-type
//! rule). Only then does the studio take this cached route, and
//! [`model_file`] writes the model file as the command's in-memory branch
//! does (the same diagnostics, operating point, Kalman gain, stability
//! note). The page makes these options explicit for a numeric order
//! (`--horizon`, `--estimator`, `--output-period NAME=1` for each complete
//! output), so its command line takes this very route; the studio's tests
//! compare the two model files field by field.
//!
//! Every other request (order `auto` with the held-out selection, q-Markov,
//! IV, PBSID, multirate records, `--detrend linear`, `--refine`) goes
//! through `service::identify::run_identification` as the command does.

use lifted_lti::spectral::{FrequencyResponse, SpectralOptions, welch};
use lifted_lti::{Dataset, ModelFile, OperatingPoint};
use lifted_subspace::{
    BdEstimate, CompressedData, Experiment, Method, OrderCriterion, OrderReport, OrderSelection,
    SubspaceModel, SubspaceOptions, SystemEstimate,
};
use nalgebra::DMatrix;
use serde_json::json;

use crate::args::{
    BdArg, CriterionArg, DetrendArg, EstimatorArg, IdentifyArgs, MethodArg, RefineArg,
};
use crate::error::{CliResult, Context, input};
use crate::service::identify::{spectral_radius, unstable_warning};
use crate::table::{DataSpec, Loaded, load};

/// The parsed record and the compressed data of the last requests.
#[derive(Default)]
pub struct Cache {
    /// The last [`KEPT_RECORDS`] parsed selections, most recent last.
    data: Vec<(String, Loaded)>,
    compressed: Option<(String, CompressedData<'static>)>,
    reads: usize,
    compressions: usize,
    /// Welch's estimate of the last record's frequency response, with the
    /// key of the data it was made from.
    spectral: Option<(String, FrequencyResponse)>,
}

/// Parsed selections kept: the page's view (channels only) and its
/// identification (with the explicit output periods of
/// `Session::explicit`) read the same columns with two specifications, and
/// a validation record a third.
const KEPT_RECORDS: usize = 3;

/// The key of a data specification (its fields, exactly: a base period
/// is compared by its bits through `Debug`, which prints f64 exactly).
fn data_key(path: &str, spec: &DataSpec) -> String {
    format!(
        "{path}|{:?}|{:?}|{:?}|{:?}|{}|{:?}",
        spec.inputs, spec.outputs, spec.extra, spec.ts, spec.hold, spec.periods
    )
}

impl Cache {
    /// Forgets everything (a new record, a reset).
    pub fn clear(&mut self) {
        self.data.clear();
        self.compressed = None;
        self.spectral = None;
    }

    /// Welch's estimate of the frequency response of `data` (default
    /// segments, [`lifted_lti::spectral::welch`]), made once per record
    /// and channel selection; `None` when the record is too short or the
    /// estimate fails (the Bode plot then shows the model alone).
    pub fn spectral(&mut self, data: &Dataset) -> Option<&FrequencyResponse> {
        // The selection and the record's size and sums identify the data
        // (a new record or selection clears or changes them).
        let sums: Vec<u64> = data
            .u()
            .column_iter()
            .chain(data.y().column_iter())
            .map(|c| c.iter().sum::<f64>().to_bits())
            .collect();
        let names: Vec<&str> = data
            .inputs()
            .iter()
            .map(|c| c.name.as_str())
            .chain(data.outputs().iter().map(|c| c.name.as_str()))
            .collect();
        let key = format!("{names:?}|{}|{}|{sums:?}", data.len(), data.ts());
        if self.spectral.as_ref().is_none_or(|(k, _)| *k != key) {
            self.spectral = None;
            let g = welch(data.u(), data.y(), data.ts(), &SpectralOptions::default()).ok()?;
            self.spectral = Some((key, g));
        }
        self.spectral.as_ref().map(|(_, g)| g)
    }

    /// The record `path` read with `spec` (read once per specification).
    pub fn loaded(&mut self, path: &str, spec: &DataSpec) -> CliResult<&Loaded> {
        let key = data_key(path, spec);
        match self.data.iter().position(|(k, _)| *k == key) {
            Some(i) => {
                let kept = self.data.remove(i);
                self.data.push(kept);
            }
            None => {
                let l = load(path, spec)?;
                self.reads += 1;
                if self.data.len() >= KEPT_RECORDS {
                    self.data.remove(0);
                }
                self.data.push((key, l));
            }
        }
        match self.data.last() {
            Some((_, l)) => Ok(l),
            None => Err(input("internal: the record was not kept")),
        }
    }

    /// Records read and compressions made since the session began (the
    /// tests check that a slider move makes neither).
    pub fn counts(&self) -> (usize, usize) {
        (self.reads, self.compressions)
    }

    /// The model of `opts` on the record of `spec`, from the kept
    /// compression (made first when the record, the horizon or the mean
    /// removal changed).
    fn subspace_fit(
        &mut self,
        path: &str,
        spec: &DataSpec,
        opts: &SubspaceOptions,
        what: &str,
    ) -> CliResult<SubspaceModel> {
        let key = compression_key(&data_key(path, spec), opts);
        if self.compressed.as_ref().is_none_or(|(k, _)| *k != key) {
            self.compressed = None;
            let data = &self.loaded(path, spec)?.data;
            let exps = [Experiment {
                u: data.u(),
                y: data.y(),
            }];
            let c = CompressedData::new(&exps, opts).ctx(what)?.into_owned();
            self.compressions += 1;
            self.compressed = Some((key, c));
        }
        match &self.compressed {
            Some((_, c)) => c.identify(opts).ctx(what),
            None => Err(input("internal: the compression was not kept")),
        }
    }
}

/// What [`CompressedData::new`] depends on besides the record.
fn compression_key(data: &str, opts: &SubspaceOptions) -> String {
    format!(
        "{data}|{}|{}|{}|{:?}|{}|{}",
        opts.past, opts.future, opts.remove_means, opts.compression, opts.chunk_rows, opts.threads
    )
}

/// Whether `lifted identify` with `a` on the one file `a.data[0]` (read
/// with `spec` into `data`) identifies with `lifted_subspace::identify` on
/// the whole record in memory, without structure selection or refinement,
/// with its means removed inside or no detrending: the route of
/// `service::identify::run_identification` for single-rate N4SID, MOESP
/// and CVA when neither the held-out selection (`wants_selection`) nor the
/// streamed route (`identify_streaming`) applies. Mirrors those two
/// functions' conditions; the tests compare the model files.
pub fn in_memory_route(a: &IdentifyArgs, spec: &DataSpec, data: &Dataset) -> bool {
    let subspace = matches!(
        a.method,
        MethodArg::N4sid | MethodArg::Moesp | MethodArg::Cva
    );
    let numeric_order = a.order.trim().parse::<usize>().is_ok_and(|n| n > 0);
    // `wants_selection`: the default rule with any of horizon, (A, C)
    // route or order left open.
    let selection = a.order_criterion == CriterionArg::Validation
        && (a.horizon.is_none() || a.estimator == EstimatorArg::Auto || !numeric_order);
    let needs_records = matches!(
        a.order_criterion,
        CriterionArg::Aic | CriterionArg::Aicc | CriterionArg::Bic
    );
    // `identify_streaming` declines (for a single file, no selection,
    // detrending by the mean or none) only for these set-ups.
    let not_streamed = needs_records || !spec.periods.is_empty() || spec.hold > 1;
    subspace
        && numeric_order
        && !selection
        && not_streamed
        && a.data.len() == 1
        && !a.concat
        && spec.extra.is_empty()
        && a.refine == RefineArg::None
        && matches!(
            a.detrend,
            DetrendArg::Auto | DetrendArg::Mean | DetrendArg::None
        )
        && data.is_single_rate()
}

fn method_of(m: MethodArg) -> Method {
    match m {
        MethodArg::Moesp => Method::Moesp,
        MethodArg::Cva => Method::Cva,
        _ => Method::N4sid,
    }
}

fn system_of(e: EstimatorArg) -> SystemEstimate {
    match e {
        EstimatorArg::Auto | EstimatorArg::Shift => SystemEstimate::ShiftInvariance,
        EstimatorArg::States => SystemEstimate::StateSequence,
    }
}

fn bd_of(b: BdArg) -> BdEstimate {
    match b {
        BdArg::Auto => BdEstimate::Auto,
        BdArg::OutputError => BdEstimate::OutputError,
        BdArg::Projection => BdEstimate::Projection,
    }
}

fn criterion_of(c: CriterionArg) -> OrderCriterion {
    match c {
        CriterionArg::Validation | CriterionArg::Gap => OrderCriterion::Gap,
        CriterionArg::Svc => OrderCriterion::Svc,
        CriterionArg::Aic => OrderCriterion::Aic,
        CriterionArg::Aicc => OrderCriterion::Aicc,
        CriterionArg::Bic => OrderCriterion::Bic,
    }
}

/// The subspace options of the command's in-memory branch for `a`.
fn options(a: &IdentifyArgs, ts: f64) -> CliResult<SubspaceOptions> {
    let n = a.order.trim().parse::<usize>().map_err(|_| {
        input(format!(
            "--order '{}': expected a positive integer",
            a.order
        ))
    })?;
    let h = a.horizon.unwrap_or(10);
    Ok(SubspaceOptions {
        method: method_of(a.method),
        order: OrderSelection::Fixed(n),
        order_criterion: criterion_of(a.order_criterion),
        past: h,
        future: h,
        system: system_of(a.estimator),
        bd: bd_of(a.bd),
        remove_means: matches!(a.detrend, DetrendArg::Auto | DetrendArg::Mean),
        enforce_stability: a.stable,
        ts,
        ..Default::default()
    })
}

/// The model file `lifted identify` writes for `a` (which must take the
/// [`in_memory_route`]), from the cached record and compression.
pub fn model_file(cache: &mut Cache, a: &IdentifyArgs, spec: &DataSpec) -> CliResult<ModelFile> {
    let path = a
        .data
        .first()
        .ok_or_else(|| input("--data is required"))?
        .clone();
    let t_read = std::time::Instant::now();
    let (ts, samples, periods) = {
        let d = &cache.loaded(&path, spec)?.data;
        let periods: Vec<usize> = d.outputs().iter().map(|c| c.period).collect();
        (d.ts(), d.len(), periods)
    };
    let read_s = t_read.elapsed().as_secs_f64();
    let t_identify = std::time::Instant::now();
    let opts = options(a, ts)?;
    let what = format!("{} identification", opts.method.name());
    let fit = cache.subspace_fit(&path, spec, &opts, &what)?;
    let mut d = subspace_json(&fit, "single-rate subspace identification");
    let operating_point: Option<OperatingPoint> = if opts.remove_means {
        fit.operating_point.clone()
    } else {
        None
    };
    let model = fit
        .model
        .clone()
        .with_input_names(spec.inputs.clone())
        .and_then(|m| m.with_output_names(spec.outputs.clone()))
        .ctx("identify")?;
    let identify_s = t_identify.elapsed().as_secs_f64();
    add_run_facts(&mut d, a, samples, ts, &periods, read_s, identify_s);
    let mut file = ModelFile::new(model)
        .with_method(a.method.name())
        .with_diagnostics(d);
    add_stability(&mut file)?;
    if let Some(op) = operating_point {
        file = file.with_operating_point(op).ctx("operating point")?;
    }
    match &fit.kalman_gain {
        Some(k) => file.with_kalman_gain(k).ctx("Kalman gain"),
        None => Ok(file),
    }
}

fn rows(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect()
}

fn order_json(kind: &str, values: &[f64], order: usize, suggested: usize) -> serde_json::Value {
    json!({"kind": kind, "values": values, "order": order, "suggested_order": suggested})
}

fn criterion_json(r: &OrderReport) -> serde_json::Value {
    let values: Vec<Option<f64>> = r
        .values
        .iter()
        .map(|v| v.is_finite().then_some(*v))
        .collect();
    json!({"criterion": format!("{:?}", r.criterion), "values": values, "selected": r.selected})
}

/// The diagnostics of the command's subspace branch (`subspace_json`).
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

/// The facts of the run (`add_run_facts` of the command).
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

/// The stability entry and warning (`add_stability` of the command).
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

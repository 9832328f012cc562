//! Identification service: data files and the identification options → a
//! model file. The pipeline itself (every route: q-Markov Cover,
//! N4SID/MOESP/CVA in memory or streamed, IV, PBSID, multirate subspace
//! and multirate IV; detrending, refinement, stability) is the workflow
//! layer `lifted_workflow`, shared with the Python package; this module
//! reads the files (CSV / `.npy`, shards of one record) and feeds them to
//! it. Used by `lifted identify` and by `lifted studio`.
//!
//! Two entry points: [`identify_files`] takes a [`DataFiles`] and a
//! [`WorkflowOptions`] (no command-line types: the studio builds them
//! directly), [`run_identification`] takes the parsed `lifted identify`
//! arguments and converts them ([`options_from_args`],
//! [`files_from_args`]).

use lifted_lti::{Dataset, ModelFile, StateSpace};
use lifted_workflow::{
    BdRoute, BlockSink, Detrend, Estimator, Method, Order, OrderCriterion, Pass, Record,
    RecordSource, Refine, WorkflowOptions,
};
use nalgebra::DMatrix;

use crate::args::{
    AStructureArg, BdArg, CriterionArg, DataArgs, DetrendArg, EstimatorArg, FStructureArg,
    IdentifyArgs, InterSampleArg, KernelArg, MethodArg, ProcessArg, RefineArg,
};
use crate::error::{CliError, CliResult, input};
use crate::table::{DataSpec, Loaded, load, names, parse_periods, scan_rows};

pub use lifted_workflow::unstable_warning;

/// The order argument: a number or `auto`.
fn parse_order(s: &str, max: usize) -> CliResult<Order> {
    if s.eq_ignore_ascii_case("auto") {
        if max == 0 {
            return Err(input("--max-order must be at least 1"));
        }
        return Ok(Order::Auto);
    }
    match s.trim().parse::<usize>() {
        Ok(n) if n > 0 => Ok(Order::Fixed(n)),
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

/// The data files of an identification and how to read them (the data
/// half of `lifted identify`'s arguments, without command-line types).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct DataFiles {
    /// Data files, CSV or `.npy`, one per experiment (q-Markov: one per
    /// input channel, in input order); a `*` or `?` in a file name is
    /// expanded to the matching files in name order.
    pub paths: Vec<String>,
    /// The files are consecutive shards of one record, not experiments.
    pub concat: bool,
    /// Input column names.
    pub inputs: Vec<String>,
    /// Output column names.
    pub outputs: Vec<String>,
    /// IV instrument column names (one per input; empty: the inputs).
    pub instruments: Vec<String>,
    /// Base period (default: from the time column).
    pub ts: Option<f64>,
    /// Declared output periods by name (otherwise inferred from the empty
    /// cells).
    pub output_periods: Vec<(String, usize)>,
    /// Names of the columns of a `.npy` file, in order (empty: c0, c1, …).
    pub columns: Vec<String>,
}

/// The workflow options of `lifted identify`'s arguments (the same
/// defaults: the command's defaults are the workflow's).
pub fn options_from_args(a: &IdentifyArgs) -> CliResult<WorkflowOptions> {
    let mut o = WorkflowOptions::default();
    o.data.detrend = match a.detrend {
        DetrendArg::Auto | DetrendArg::Mean => Detrend::Mean,
        DetrendArg::None => Detrend::None,
        DetrendArg::Linear => Detrend::Linear,
    };
    o.data.hold = a.hold;
    let id = &mut o.identification;
    id.method = match a.method {
        MethodArg::Qmarkov => Method::Qmarkov,
        MethodArg::N4sid => Method::N4sid,
        MethodArg::Moesp => Method::Moesp,
        MethodArg::Cva => Method::Cva,
        MethodArg::Iv => Method::Iv,
        MethodArg::Pbsid => Method::Pbsid,
        MethodArg::Ssarx => Method::Ssarx,
        MethodArg::PbsidRowwise => Method::PbsidRowwise,
        MethodArg::Arx => Method::Arx,
        MethodArg::Fir => Method::Fir,
        MethodArg::Oe => Method::Oe,
        MethodArg::Armax => Method::Armax,
        MethodArg::Bj => Method::Bj,
        MethodArg::Process => Method::Process,
        MethodArg::Impulse => Method::Impulse,
    };
    id.a_structure = a.a_structure.map(|k| match k {
        AStructureArg::Full => lifted_pem::AStructure::Full,
        AStructureArg::Diagonal => lifted_pem::AStructure::Diagonal,
    });
    id.f_structure = a.f_structure.map(|k| match k {
        FStructureArg::PerInput => lifted_pem::FStructure::PerInput,
        FStructureArg::Common => lifted_pem::FStructure::Common,
    });
    id.kernel = a.kernel.map(|k| match k {
        KernelArg::Tc => lifted_pem::Kernel::Tc,
        KernelArg::Dc => lifted_pem::Kernel::Dc,
    });
    id.process = a.process.map(|p| match p {
        ProcessArg::P1d => lifted_pem::ProcessKind::P1D,
        ProcessArg::P2d => lifted_pem::ProcessKind::P2D,
        ProcessArg::P1di => lifted_pem::ProcessKind::P1DI,
        ProcessArg::P2dz => lifted_pem::ProcessKind::P2DZ,
        ProcessArg::P2du => lifted_pem::ProcessKind::P2DU,
    });
    id.intersample = a.intersample.map(|h| match h {
        InterSampleArg::Zoh => lifted_pem::InterSample::Zoh,
        InterSampleArg::Foh => lifted_pem::InterSample::Foh,
    });
    for item in &a.process_fix {
        let bad = || {
            input(format!(
                "--process-fix {item}: NAME=VALUE, a parameter of the structure and its value in the data's units (Td=7.3, K(u1)=2)"
            ))
        };
        let (name, value) = item.split_once('=').ok_or_else(bad)?;
        let value: f64 = value.trim().parse().map_err(|_| bad())?;
        id.process_fixed.push((name.trim().to_string(), value));
    }
    if let Some(text) = &a.orders {
        id.orders = parse_orders(text)?;
    }
    id.order = parse_order(&a.order, a.max_order)?;
    id.max_order = a.max_order;
    id.order_criterion = match a.order_criterion {
        CriterionArg::Validation => OrderCriterion::Validation,
        CriterionArg::Gap => OrderCriterion::Gap,
        CriterionArg::Svc => OrderCriterion::Svc,
        CriterionArg::Aic => OrderCriterion::Aic,
        CriterionArg::Aicc => OrderCriterion::Aicc,
        CriterionArg::Bic => OrderCriterion::Bic,
    };
    id.horizon = a.horizon;
    id.estimator = match a.estimator {
        EstimatorArg::Auto => Estimator::Auto,
        EstimatorArg::Shift => Estimator::Shift,
        EstimatorArg::States => Estimator::States,
    };
    id.bd = match a.bd {
        BdArg::Auto => BdRoute::Auto,
        BdArg::OutputError => BdRoute::OutputError,
        BdArg::Projection => BdRoute::Projection,
    };
    id.stable = a.stable;
    id.integrator_tolerance = a.integrator_tolerance;
    id.q = a.q;
    id.prbs_order = a.prbs_order;
    match a.amplitude[..] {
        [] => {}
        [one] => id.amplitude = Some(one),
        ref many => id.amplitudes = many.to_vec(),
    }
    id.future = a.future;
    id.feedthrough = a.feedthrough;
    id.instrument_past = a.instrument_past;
    id.output_weight = a.output_weight.clone();
    o.refinement.refine = match a.refine {
        RefineArg::Auto => Refine::Auto,
        RefineArg::None => Refine::None,
        RefineArg::Pem => Refine::Pem,
        RefineArg::Oe => Refine::Oe,
    };
    o.refinement.iterations = a.refine_iterations;
    o.refinement.max_work = a.refine_max_work;
    o.refinement.check = a.refine_check;
    o.refinement.judge_iterations = a.judge_iterations;
    o.identification.gain_check.stop_share = a.gain_stop_share;
    o.identification.gain_check.covariance_start = a.gain_covariance_start;
    o.identification.selection = lifted_workflow::SelectionOptions {
        stable_tries: a.stable_tries,
        shortlist: a.shortlist,
        shortlist_span: a.shortlist_span,
        tolerance: a.selection_tolerance,
        failed_fold: a.failed_fold,
    };
    for spec in &a.budget {
        let bad = |why: &str| {
            input(format!(
                "--budget {spec}: {why}; the budgets are {}",
                lifted_workflow::BUDGET_NAMES.join(", ")
            ))
        };
        let (name, value) = spec
            .split_once('=')
            .ok_or_else(|| bad("expected NAME=VALUE"))?;
        let value: f64 = value
            .trim()
            .parse()
            .map_err(|_| bad("the value is not a number"))?;
        o.budgets
            .set(&mut o.identification.gain_check, name.trim(), value)
            .map_err(cli_error)?;
    }
    o.validation.require_stable = a.stable;
    o.validation.covariance = !a.no_covariance;
    Ok(o)
}

/// MATLAB's order vector from `--orders`: non-negative integers separated
/// by spaces or commas.
fn parse_orders(text: &str) -> CliResult<Vec<usize>> {
    let parts: Vec<&str> = text
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|p| !p.is_empty())
        .collect();
    if parts.is_empty() {
        return Err(input(format!(
            "--orders '{text}': expected numbers such as \"2 2 1\" (na nb nk)"
        )));
    }
    parts
        .iter()
        .map(|p| {
            p.parse::<usize>().map_err(|_| {
                input(format!(
                    "--orders '{text}': '{p}' is not a non-negative integer"
                ))
            })
        })
        .collect()
}

/// The message for a missing `--inputs`/`--outputs` (`flag`): the first
/// data file's columns when its header can be read, and the command line
/// for them when the names follow the u…/y… convention.
fn missing_channels(flag: &str, a: &IdentifyArgs) -> String {
    let plain = format!("{flag} NAME[,NAME…] is required");
    let Some(path) = a.data.first() else {
        return plain;
    };
    let columns = a.columns.columns.as_deref().map(names).unwrap_or_default();
    let Ok(header) = crate::table::header(path, &columns) else {
        return plain;
    };
    let time = crate::table::time_column(&header);
    let cols: Vec<&String> = header
        .iter()
        .enumerate()
        .filter(|(i, _)| Some(*i) != time)
        .map(|(_, h)| h)
        .collect();
    let like = |prefix: char| -> Vec<&str> {
        cols.iter()
            .map(|h| crate::table::bare_name(h))
            .filter(|n| {
                let mut ch = n.chars();
                ch.next().is_some_and(|c| c.eq_ignore_ascii_case(&prefix))
                    && ch.as_str().chars().all(|c| c.is_ascii_digit() || c == '_')
            })
            .collect()
    };
    let (us, ys) = (like('u'), like('y'));
    let example = if !us.is_empty() && !ys.is_empty() {
        format!(
            "; e.g. --inputs {} --outputs {}",
            us.join(","),
            ys.join(",")
        )
    } else {
        String::new()
    };
    let list: Vec<&str> = cols.iter().map(|h| h.as_str()).collect();
    format!(
        "{plain}: name the input and output columns of {path} (its columns: {}){example}",
        list.join(", ")
    )
}

/// The data files of `lifted identify`'s arguments.
pub fn files_from_args(a: &IdentifyArgs) -> CliResult<DataFiles> {
    let c = &a.columns;
    if c.inputs.is_none() {
        return Err(input(missing_channels("--inputs", a)));
    }
    if c.outputs.is_none() {
        return Err(input(missing_channels("--outputs", a)));
    }
    Ok(DataFiles {
        paths: a.data.clone(),
        concat: a.concat,
        inputs: c.inputs.as_deref().map(names).unwrap_or_default(),
        outputs: c.outputs.as_deref().map(names).unwrap_or_default(),
        instruments: a.instrument.as_deref().map(names).unwrap_or_default(),
        ts: c.ts,
        output_periods: parse_periods(&c.output_period)?,
        columns: c.columns.as_deref().map(names).unwrap_or_default(),
    })
}

/// The command's spelling of a workflow option (`refine_iterations` →
/// `--refine-iterations`; a budget `auto_refine_work` → `--budget
/// auto_refine_work`).
fn flag(option: &str) -> String {
    if lifted_workflow::BUDGET_NAMES.contains(&option) {
        return format!("--budget {option}");
    }
    format!("--{}", option.replace('_', "-"))
}

/// A workflow error as the command reports it: options by their flags.
pub fn cli_error(e: lifted_workflow::Error) -> CliError {
    match e {
        lifted_workflow::Error::InvalidOption { option, reason } => {
            input(format!("{}: {reason}", flag(option)))
        }
        lifted_workflow::Error::Step { what, source }
            if matches!(what.as_str(), "detrend" | "refine" | "prbs_order") =>
        {
            input(format!("{}: {source}", flag(&what)))
        }
        other => input(other),
    }
}

/// Runs `lifted identify`'s identification and returns the model file (not
/// yet written): [`identify_files`] with the arguments converted, or with
/// the options of `--plan` ([`plan_options`]); `--write-plan` writes the
/// options used.
pub fn run_identification(a: &IdentifyArgs) -> CliResult<ModelFile> {
    let opts = match &a.plan {
        Some(path) => plan_options(a, path)?,
        None => options_from_args(a)?,
    };
    let files = files_from_args(a)?;
    let file = identify_files(&files, &opts)?;
    if let Some(path) = &a.write_plan {
        let text =
            serde_json::to_string_pretty(&opts).map_err(|e| input(format!("--write-plan: {e}")))?;
        std::fs::write(path, text + "\n")
            .map_err(|e| input(format!("--write-plan {path}: {e}")))?;
    }
    Ok(file)
}

/// The options of `--plan FILE`: a model file's `diagnostics.options`, or a
/// plan file (a JSON object of [`WorkflowOptions`], or one under the key
/// `options`); fields left out take their defaults, a field the options do
/// not have is an error naming it, and so are option flags given beside
/// the plan (the data flags excepted). Checked as the flags' options are.
pub fn plan_options(a: &IdentifyArgs, path: &str) -> CliResult<WorkflowOptions> {
    let bad = |why: String| input(format!("--plan {path}: {why}"));
    let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
    let doc: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(format!("not JSON: {e}")))?;
    let opts = options_of_plan(&doc, &format!("--plan {path}"))?;
    // The option flags must be at their defaults: compare the options the
    // flags give with those of a command line with the data flags only.
    let plain = IdentifyArgs::defaults("-").map_err(|e| input(e.to_string()))?;
    let (flags, defaults) = (
        serde_json::to_value(options_from_args(a)?).map_err(|e| bad(e.to_string()))?,
        serde_json::to_value(options_from_args(&plain)?).map_err(|e| bad(e.to_string()))?,
    );
    if let Some(key) = first_difference(&flags, &defaults, "") {
        return Err(bad(format!(
            "the options come from the plan: leave the option flags at their defaults \
             ({key} was given)"
        )));
    }
    Ok(opts)
}

/// The workflow options of a plan document (a model file, its diagnostics,
/// a `--write-plan` file: `lifted_workflow::options_from_plan`), errors
/// named by `label` (`--plan FILE` for the command, `plan` for the studio's
/// request): a field the options do not have, or options that fail their
/// check (named by their flags).
pub fn options_of_plan(doc: &serde_json::Value, label: &str) -> CliResult<WorkflowOptions> {
    lifted_workflow::options_from_plan(doc).map_err(|e| match e {
        lifted_workflow::Error::InvalidOption {
            option: "plan",
            reason,
        } => input(format!("{label}: {reason}")),
        other => input(format!("{label}: {}", cli_error(other))),
    })
}

/// The first dotted path where two JSON trees differ.
fn first_difference(a: &serde_json::Value, b: &serde_json::Value, at: &str) -> Option<String> {
    match (a, b) {
        (serde_json::Value::Object(x), serde_json::Value::Object(y)) => {
            x.iter().find_map(|(k, v)| {
                let path = if at.is_empty() {
                    k.clone()
                } else {
                    format!("{at}.{k}")
                };
                match y.get(k) {
                    Some(w) => first_difference(v, w, &path),
                    None => Some(path),
                }
            })
        }
        _ if a != b => Some(at.to_string()),
        _ => None,
    }
}

/// Largest data file (bytes, all files) on which the structure of a
/// single-rate subspace identification is selected on held-out data; larger
/// files are streamed with horizon 10, shift invariance and, for an
/// automatic order, Bauer's SVC.
pub const SELECT_MAX_BYTES: u64 = 16 << 20;

/// Whether the data files are small enough for the held-out selection
/// ([`SELECT_MAX_BYTES`]); a file that cannot be read counts as small (the
/// loader then names the problem).
fn small_enough_to_select(paths: &[String]) -> bool {
    let bytes: u64 = paths
        .iter()
        .map(|p| std::fs::metadata(p).map_or(0, |m| m.len()))
        .sum();
    bytes <= SELECT_MAX_BYTES
}

/// Reads the data files and runs the workflow on them
/// (`lifted_workflow`): a single-rate N4SID/MOESP/CVA of one record too
/// large for the held-out selection is streamed in two passes
/// ([`lifted_workflow::identify_streamed`]), everything else is loaded in
/// memory ([`lifted_workflow::identify_named`]). The model carries the
/// column names; the diagnostics the data files and the reading time.
pub fn identify_files(files: &DataFiles, opts: &WorkflowOptions) -> CliResult<ModelFile> {
    identify_files_with(files, opts, &mut NoKeeping)
}

/// Where [`identify_files_with`] gets the parsed records of its in-memory
/// route and keeps step 1 of the subspace identification: a front end that
/// refits the same files many times (the studio) keeps both between calls;
/// [`identify_files`] reads the files every time and keeps nothing.
pub trait RecordKeeper {
    /// The record of `path` read with `spec`.
    fn loaded(&mut self, path: &str, spec: &DataSpec) -> CliResult<Loaded>;
    /// The compression kept between calls, if any.
    fn subspace_cache(&mut self) -> Option<&mut lifted_workflow::SubspaceCache>;
}

/// Reads every time, keeps nothing.
struct NoKeeping;

impl RecordKeeper for NoKeeping {
    fn loaded(&mut self, path: &str, spec: &DataSpec) -> CliResult<Loaded> {
        load(path, spec)
    }
    fn subspace_cache(&mut self) -> Option<&mut lifted_workflow::SubspaceCache> {
        None
    }
}

/// The data specification of `files` with the hold of `opts`. The
/// q-Markov hold n_r is the PRBS's, which the route takes from the options
/// and not from the records: its records are read with every input held
/// one base period, so a shifted inverse PRBS (e.g. `lifted.inverse_prbs`
/// with a seed, whose hold blocks need not start at sample 0) is read as
/// the Python package reads it instead of refused as a broken hold.
pub fn spec_of(files: &DataFiles, opts: &WorkflowOptions) -> DataSpec {
    let hold = if opts.identification.method == Method::Qmarkov {
        1
    } else {
        opts.data.hold
    };
    DataSpec {
        inputs: files.inputs.clone(),
        outputs: files.outputs.clone(),
        extra: files.instruments.clone(),
        ts: files.ts,
        hold,
        periods: files.output_periods.clone(),
        columns: files.columns.clone(),
    }
}

/// Whether [`identify_files`] takes the streamed route (one record read in
/// blocks, two passes) for `files` and `opts`; otherwise it reads the
/// records whole and runs the workflow on them in memory.
pub fn streams(files: &DataFiles, opts: &WorkflowOptions) -> CliResult<bool> {
    let paths = crate::shards::expand(&files.paths)?;
    Ok(streams_paths(files, opts, &paths))
}

fn streams_paths(files: &DataFiles, opts: &WorkflowOptions, paths: &[String]) -> bool {
    lifted_workflow::streamable(opts)
        && !(opts.wants_selection() && small_enough_to_select(paths))
        && (paths.len() == 1 || files.concat)
        && files.output_periods.is_empty()
        && opts.data.hold <= 1
        && files.instruments.is_empty()
}

/// [`identify_files`] with the records of the in-memory route read through
/// `keeper` and step 1 of its subspace identification kept there
/// ([`lifted_workflow::identify_cached`]): the same model file, bit for bit.
pub fn identify_files_with(
    files: &DataFiles,
    opts: &WorkflowOptions,
    keeper: &mut dyn RecordKeeper,
) -> CliResult<ModelFile> {
    let paths = crate::shards::expand(&files.paths)?;
    let method = opts.identification.method;
    if files.concat && method == Method::Qmarkov {
        return Err(input(
            "--concat joins shards of one record; q-Markov takes one file per input",
        ));
    }
    opts.check().map_err(cli_error)?;
    let extra = files.instruments.clone();
    if !extra.is_empty() && method != Method::Iv {
        return Err(input("--instrument is only used with --method iv"));
    }
    if files.inputs.is_empty() || files.outputs.is_empty() {
        return Err(input("at least one input and one output column are needed"));
    }
    let spec = spec_of(files, opts);
    spec.check_selection()?;
    if !extra.is_empty() && extra.len() != spec.inputs.len() {
        return Err(input(format!(
            "--instrument: {} columns for {} inputs (one instrument per input)",
            extra.len(),
            spec.inputs.len()
        )));
    }
    if streams_paths(files, opts, &paths) {
        let mut source = FileSource {
            paths: &paths,
            spec: &spec,
        };
        if let Some(fit) =
            lifted_workflow::identify_streamed(&mut source, opts).map_err(cli_error)?
        {
            return finish(fit.file, &spec, &paths, None);
        }
    }
    let t_read = std::time::Instant::now();
    let mut loaded: Vec<Loaded> = paths
        .iter()
        .map(|p| keeper.loaded(p, &spec))
        .collect::<CliResult<_>>()?;
    if files.concat {
        loaded = vec![crate::shards::join(loaded, &paths)?];
    }
    let read_s = t_read.elapsed().as_secs_f64();
    let records: Vec<Record> = loaded
        .into_iter()
        .map(|l| Record {
            data: l.data,
            instrument: (!extra.is_empty()).then_some(l.extra),
        })
        .collect();
    let fit = match keeper.subspace_cache() {
        Some(cache) => lifted_workflow::identify_cached(&records, opts, &extra, cache),
        None => lifted_workflow::identify_named(&records, opts, &extra),
    }
    .map_err(cli_error)?;
    finish(fit.file, &spec, &paths, Some(read_s))
}

/// The column names on the model, and the data files (and the reading
/// time, when read here) in the diagnostics.
fn finish(
    mut file: ModelFile,
    spec: &DataSpec,
    paths: &[String],
    read_s: Option<f64>,
) -> CliResult<ModelFile> {
    file.model = file
        .model
        .with_input_names(spec.inputs.clone())
        .and_then(|m| m.with_output_names(spec.outputs.clone()))
        .map_err(|e| input(format!("identify: {e}")))?;
    let mut diagnostics = lifted_workflow::Diagnostics::of(&file);
    diagnostics.data = Some(paths.to_vec());
    if let (Some(r), Some(p)) = (read_s, diagnostics.profile.as_mut()) {
        p.insert("read_s".into(), r);
    }
    file.diagnostics = diagnostics.to_value();
    Ok(file)
}

/// The estimated parameters with their standard deviations, as text: a
/// polynomial model's polynomials (`PolyModel::present`), then a process
/// model's gains, time constants and dead times per output
/// (`diagnostics.process`), and, with `state_space`, a state-space model's
/// entries (`SsCovariance::present`); `None` when the file has none.
pub fn parameters_text(
    file: &ModelFile,
    diagnostics: &lifted_workflow::Diagnostics,
    state_space: bool,
) -> Option<String> {
    let mut parts = Vec::new();
    if let Some(p) = &file.polynomial {
        parts.push(p.present());
    }
    if let Some(p) = &diagnostics.process {
        let lines: Vec<String> = p
            .outputs
            .iter()
            .enumerate()
            .map(|(i, out)| {
                let terms: Vec<String> = out
                    .names
                    .iter()
                    .zip(&out.parameters)
                    .zip(&out.std)
                    .map(|((n, v), s)| {
                        format!(
                            "{} = {:.6} (±{:.2e})",
                            n,
                            v.unwrap_or(f64::NAN),
                            s.unwrap_or(f64::NAN)
                        )
                    })
                    .collect();
                format!(
                    "process model {}, output {}: {}",
                    p.kind,
                    i + 1,
                    terms.join(", ")
                )
            })
            .collect();
        parts.push(lines.join("\n"));
    }
    if let (true, None, Some(c)) = (state_space, &file.polynomial, &file.covariance)
        && let Ok(text) = c.present(&file.model)
    {
        parts.push(text);
    }
    (!parts.is_empty()).then(|| parts.join("\n"))
}

/// `--stable`: the model written must have every pole strictly inside the
/// unit circle (the stabilised estimates guarantee it up to rounding).
pub fn require_stable(model: &StateSpace) -> CliResult<()> {
    lifted_workflow::require_stable(model).map_err(cli_error)
}

/// Spectral radius ρ(A) of a model (0 for a static gain).
pub fn spectral_radius(model: &StateSpace) -> CliResult<f64> {
    lifted_workflow::spectral_radius(model).map_err(cli_error)
}

/// Rows per block pushed to the streaming identifier.
const STREAM_BLOCK: usize = 65_536;

/// The data files of one record (one file, or the shards of `--concat` in
/// order) read in blocks for the streamed route.
struct FileSource<'a> {
    paths: &'a [String],
    spec: &'a DataSpec,
}

impl RecordSource for FileSource<'_> {
    fn channels(&self) -> (usize, usize) {
        (self.spec.inputs.len(), self.spec.outputs.len())
    }

    fn pass(&mut self, push: &mut BlockSink<'_>) -> lifted_workflow::Result<Pass> {
        stream_files(self.paths, self.spec, push)
    }

    fn load(&mut self) -> lifted_workflow::Result<Dataset> {
        let loaded: Vec<Loaded> = self
            .paths
            .iter()
            .map(|p| load(p, self.spec))
            .collect::<CliResult<_>>()
            .map_err(source_error)?;
        Ok(crate::shards::join(loaded, self.paths)
            .map_err(source_error)?
            .data)
    }
}

/// A reader error for the workflow (its message kept as it is).
fn source_error(e: CliError) -> lifted_workflow::Error {
    lifted_workflow::Error::Source(e.to_string())
}

/// One pass over one data file: the rows of the input and output columns
/// in blocks of [`STREAM_BLOCK`] samples to `push` (u block, y block).
/// Stops at the first empty output cell (a multirate record, loaded whole
/// by the caller instead).
fn stream_file(
    path: &str,
    spec: &DataSpec,
    push: &mut BlockSink<'_>,
) -> lifted_workflow::Result<Pass> {
    let (n_u, n_y) = (spec.inputs.len(), spec.outputs.len());
    let wanted: Vec<&String> = spec.inputs.iter().chain(&spec.outputs).collect();
    if crate::table::is_npy(path) {
        return stream_npy(path, spec, &wanted, push);
    }
    let block = STREAM_BLOCK;
    let (mut ub, mut yb) = (DMatrix::zeros(block, n_u), DMatrix::zeros(block, n_y));
    let (mut fill, mut multirate) = (0usize, false);
    let mut pushed: Option<lifted_workflow::Error> = None;
    let scanned = scan_rows(
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
                if let Err(e) = push(&ub, &yb) {
                    // Stop the scan; the error is returned below.
                    pushed = Some(e);
                    return Ok(false);
                }
                fill = 0;
            }
            Ok(true)
        },
    );
    let (rows, ts) = match (scanned, pushed) {
        (_, Some(e)) => return Err(e),
        (Err(e), None) => return Err(source_error(e)),
        (Ok(r), None) => r,
    };
    if !multirate && fill > 0 {
        push(
            &ub.rows(0, fill).into_owned(),
            &yb.rows(0, fill).into_owned(),
        )?;
    }
    Ok(Pass {
        rows,
        ts,
        multirate,
    })
}

/// [`stream_file`] for a `.npy` file: its blocks of [`STREAM_BLOCK`] rows
/// decoded column by column ([`crate::npy::scan_blocks`]) and copied into
/// the (u, y) blocks whole (the same blocks as the row-by-row reading).
fn stream_npy(
    path: &str,
    spec: &DataSpec,
    wanted: &[&String],
    push: &mut BlockSink<'_>,
) -> lifted_workflow::Result<Pass> {
    let (n_u, n_y) = (spec.inputs.len(), spec.outputs.len());
    let mut multirate = false;
    let scanned = lifted_data::npy::scan_record_blocks(
        path,
        &spec.columns,
        wanted,
        n_u,
        n_u..n_u + n_y,
        spec.ts,
        STREAM_BLOCK,
        |u, y| {
            if lifted_linalg::kernels::has_nan(y.as_slice()) {
                // A multirate record: the pass stops, the caller loads it
                // whole.
                multirate = true;
                return Ok(false);
            }
            push(u, y).map(|()| true)
        },
    );
    let (rows, ts) = match scanned {
        Ok(r) => r,
        Err(lifted_data::npy::BlockStop::Visit(e)) => return Err(e),
        Err(lifted_data::npy::BlockStop::Read(e)) => return Err(source_error(e)),
    };
    Ok(Pass {
        rows,
        ts,
        multirate,
    })
}

/// [`stream_file`] over the files of one record in order (`--concat`; one
/// file otherwise): the rows of all files, the sample period of the first
/// (the others must agree), the pass stopped at a multirate file.
fn stream_files(
    paths: &[String],
    spec: &DataSpec,
    push: &mut BlockSink<'_>,
) -> lifted_workflow::Result<Pass> {
    let mut total = Pass {
        rows: 0,
        ts: f64::NAN,
        multirate: false,
    };
    for (k, path) in paths.iter().enumerate() {
        let pass = stream_file(path, spec, push)?;
        if k == 0 {
            total.ts = pass.ts;
        } else if (pass.ts - total.ts).abs() > 1e-9 * total.ts.abs() {
            return Err(source_error(input(format!(
                "--concat: {} has sample period {} s, {} has {} s",
                crate::shown::shown(path),
                pass.ts,
                crate::shown::shown(&paths[0]),
                total.ts
            ))));
        }
        total.rows += pass.rows;
        if pass.multirate {
            total.multirate = true;
            break;
        }
    }
    Ok(total)
}

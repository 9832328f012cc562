//! The studio's state and its operations, without HTTP: a record is
//! uploaded, its channels viewed, a model identified with the `identify`
//! options, and the last model saved as a model file or a report. Every
//! operation goes through the service layer ([`crate::table`],
//! [`crate::service`]): a request's values are set on the command's
//! arguments directly and converted to the workflow's options by the
//! command's own conversion, so a model made here equals the one
//! `lifted identify` writes with the same options.

use std::path::{Path, PathBuf};
use std::time::Instant;

use lifted_lti::{Dataset, ModelFile};
use lifted_workflow::Diagnostics;
use serde::{Deserialize, Serialize};

use crate::args::{DetrendArg, IdentifyArgs};
use crate::error::{CliError, CliResult, clap_one_line, input};
use crate::plot::svg;
use crate::service::figures::{
    bode_grid, criterion_plot, excitation_plot_in, order_plot, outputs_plot_in, pz_plot,
    residual_plots, response_error_plot_in, response_plot_in, stack_svgs,
};
use crate::service::identify::{
    files_from_args, identify_files_with, options_from_args, require_stable,
};
use crate::service::pairs::{PairFigure, add_empirical_pairs, bode_pairs, pairs_svg, step_pairs};
use crate::service::report::render;
use crate::service::validation::{validate_model_at, with_detrend};
use crate::studio::board::Pinned;
use crate::studio::cached::Cache;
use crate::studio::ranges;
use crate::table::{DataSpec, header, parse_periods, scan_rows};

/// Largest upload accepted (bytes).
pub const MAX_UPLOAD: usize = 1 << 30;

/// Largest working matrix an identification request may ask for, in bytes
/// (8 k² for the k block-Hankel rows of the request): larger requests are
/// refused before the identification allocates anything.
pub const MAX_WORK_BYTES: u64 = 2 << 30;

/// Lags of the residual tests in the studio (as `lifted validate`'s
/// default), fewer on a short record.
const LAGS: usize = 20;

/// The prediction horizons of a validation the page shows (its one-step
/// fit; the 5-step predictions, five model runs over the record, only for
/// the report).
pub(crate) const SLIDER_HORIZONS: &[usize] = &[1];

/// The prediction horizons of the report's table (`lifted report`'s).
pub(crate) const REPORT_HORIZONS: &[usize] = &[1, 5];

/// Identification and view options of the page, named as the options of
/// `lifted identify` (`output_period` entries are `NAME=PERIOD`; `order` is a
/// positive integer or `auto`). Absent fields take the command's defaults.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Request {
    /// Input column names.
    pub inputs: Vec<String>,
    /// Output column names.
    pub outputs: Vec<String>,
    /// Base period in seconds (default: from the time column, else 1).
    pub ts: Option<f64>,
    /// Input hold n_r in base periods.
    pub hold: Option<usize>,
    /// Declared output periods, `NAME=PERIOD`.
    pub output_period: Vec<String>,
    /// `qmarkov`, `n4sid`, `moesp`, `cva` or `iv` (multirate records take
    /// the multirate route of the subspace and IV methods).
    pub method: Option<String>,
    /// Model order, or `auto`.
    pub order: Option<String>,
    /// Largest order of `auto`.
    pub max_order: Option<usize>,
    /// Horizon (subspace i, IV α).
    pub horizon: Option<usize>,
    /// q-Markov: q.
    pub q: Option<usize>,
    /// q-Markov: PRBS order n.
    pub prbs_order: Option<u32>,
    /// q-Markov: PRBS magnitude.
    pub amplitude: Option<f64>,
    /// q-Markov: diagonal output weighting Q.
    pub output_weight: Vec<f64>,
    /// IV: instrument columns.
    pub instrument: Vec<String>,
    /// `auto`, `mean`, `linear` or `none`.
    pub detrend: Option<String>,
    /// `shift` or `states`.
    pub estimator: Option<String>,
    /// `gap`, `svc`, `aic`, `aicc` or `bic`.
    pub order_criterion: Option<String>,
    /// Enforce a stable model.
    pub stable: bool,
    /// Estimate a direct feedthrough D (`true`) or fix D = 0 (`false`);
    /// absent: the method's default (`lifted identify --feedthrough`).
    pub feedthrough: Option<bool>,
    /// The page's sequence number of this request (not an option of
    /// `lifted identify`): echoed in the answer, and the key under which
    /// the model is kept for `GET /api/model?seq=`.
    pub seq: Option<u64>,
    /// The rows of the estimation record to identify on, `[t0, t1]` in
    /// seconds (absent: all); see [`crate::studio::ranges`].
    pub estimation_range: Option<[f64; 2]>,
    /// The rows of the validation data (the validation record, else the
    /// estimation record) the model is checked on, `[t0, t1]` seconds.
    pub validation_range: Option<[f64; 2]>,
    /// `pem` or `oe`: refine the model (Levenberg–Marquardt on the
    /// prediction or simulation error, `lifted identify --refine`).
    pub refine: Option<String>,
    /// The time window `[t0, t1]` (seconds) of the time plots: the page's
    /// zoom (not an option of `lifted identify`; absent: the whole record).
    pub window: Option<[f64; 2]>,
    /// The figures the page shows, by slot (`response`, `bode`, …) with
    /// the digest an earlier answer gave them (`Identified::figure_digests`;
    /// not an option of `lifted identify`): a figure whose digest is the
    /// same is not sent again (its slot is listed in
    /// `Identified::unchanged`, its content left empty).
    pub have: std::collections::BTreeMap<String, String>,
}

/// One column of an uploaded record.
#[derive(Debug, Clone, Serialize)]
pub struct ColumnInfo {
    /// Header name.
    pub name: String,
    /// Non-empty cells.
    pub samples: usize,
    /// Spacing of its samples in rows (1: every row), when regular.
    pub period: Option<usize>,
}

/// What the page learns of an uploaded record.
#[derive(Debug, Clone, Serialize)]
pub struct DataInfo {
    /// File name as uploaded.
    pub name: String,
    /// Data rows.
    pub rows: usize,
    /// Base period (time column, else 1).
    pub ts: f64,
    /// Whether the file has a time column (`t` or `time`); without one the
    /// base period is the page's field (1 s when empty, `--ts 1` on the
    /// command line).
    pub has_time: bool,
    /// The columns other than the time column.
    pub columns: Vec<ColumnInfo>,
    /// Columns proposed as inputs: complete columns whose names say so
    /// (`named_role`: `u…`, `r…`, plant tags ending `.OP`/`.MV`), else
    /// the first complete one.
    pub suggested_inputs: Vec<String>,
    /// Columns proposed as outputs: those whose names say so (`y…`, tags
    /// ending `.PV`/`.CV`), else the columns not proposed as inputs.
    pub suggested_outputs: Vec<String>,
    /// The proposal is a guess (no naming convention decided the inputs or
    /// the outputs): the page asks the user to confirm the channels before
    /// it identifies.
    pub channels_guessed: bool,
}

/// Copies of a request's record an identification holds at once (the
/// values read, scaled, as deviations, simulated, the residuals): the
/// factor of [`Session::check_sizes`]' memory check.
const RECORD_COPIES: u128 = 5;

/// The measured samples of a column and their spacing, gathered row by row
/// ([`Session`]'s upload check keeps no values).
#[derive(Debug, Clone, Copy, Default)]
struct SampleSpacing {
    samples: usize,
    first: usize,
    last: usize,
    /// The spacing of the first two samples, and whether every later one
    /// kept it.
    step: Option<usize>,
    regular: bool,
}

impl SampleSpacing {
    fn push(&mut self, row: usize) {
        match self.samples {
            0 => self.first = row,
            1 => {
                self.step = Some(row - self.first);
                self.regular = true;
            }
            _ => self.regular &= Some(row - self.last) == self.step,
        }
        self.last = row;
        self.samples += 1;
    }

    /// The sampling period: none without a sample, the record's length
    /// for a single one, the common spacing when every spacing is equal.
    fn period(&self, rows: usize) -> Option<usize> {
        match self.samples {
            0 => None,
            1 => Some(rows),
            _ => self.step.filter(|_| self.regular),
        }
    }
}

/// The size of an uploaded record: rows and base period.
struct RecordSize {
    rows: usize,
    ts: f64,
}

/// What a column is by its name, when a convention says so: plant tags
/// `FIC101.OP`/`.MV` (a controller's output, the manipulated variable)
/// are inputs, `TI203.PV`/`.CV` (process or controlled variable) outputs;
/// else a first letter `u` or `r` (input, reference) or `y` (output).
/// `Some(true)`: an input, `Some(false)`: an output.
pub fn named_role(name: &str) -> Option<bool> {
    let lower = name.trim().to_ascii_lowercase();
    if let Some((_, suffix)) = lower.rsplit_once('.') {
        match suffix {
            "op" | "mv" => return Some(true),
            "pv" | "cv" => return Some(false),
            _ => {}
        }
    }
    match lower.chars().next() {
        Some('u' | 'r') => Some(true),
        Some('y') => Some(false),
        _ => None,
    }
}

/// A channel and its rate, for the page.
#[derive(Debug, Clone, Serialize)]
pub struct Channel {
    /// Name.
    pub name: String,
    /// Hold (inputs) or sampling period (outputs) in base periods.
    pub period: usize,
    /// Samples of the channel in the record.
    pub samples: usize,
}

/// The record as selected: channels, rates and the signal plots.
#[derive(Debug, Clone, Serialize)]
pub struct View {
    /// Data rows.
    pub rows: usize,
    /// Base period.
    pub ts: f64,
    /// Inputs with their holds.
    pub inputs: Vec<Channel>,
    /// Outputs with their sampling periods.
    pub outputs: Vec<Channel>,
    /// SVG of the inputs.
    pub inputs_svg: String,
    /// SVG of the outputs (slow outputs as markers).
    pub outputs_svg: String,
}

/// Order-selection data of the model file.
#[derive(Debug, Clone, Serialize)]
pub struct OrderSelection {
    /// What the values are (singular values, Λ diagonal).
    pub kind: String,
    /// The values, largest first.
    pub values: Vec<f64>,
    /// The order of the model.
    pub order: usize,
    /// The order the gap rule suggests.
    pub suggested_order: Option<usize>,
}

/// One output's simulation fit.
#[derive(Debug, Clone, Serialize)]
pub struct Fit {
    /// Output name.
    pub output: String,
    /// Fit % (100 (1 − ‖y − ŷ‖/‖y − ȳ‖), simulated from the initial state
    /// fitted to the record by least squares); `null`
    /// when it is not meaningful: an unstable model (its simulation
    /// diverges), a non-finite residual or a constant output.
    pub fit: Option<f64>,
    /// Whether the model is stable (ρ(A) < 1); when not, the page shows
    /// "n/a: unstable" for the fit.
    pub stable: bool,
    /// Whether the residual is white.
    pub white: bool,
    /// Whether the residual is independent of the inputs.
    pub independent: bool,
    /// One-step prediction fit % with the model's Kalman gain (the
    /// predictor started from the simulation's initial state); `null`
    /// without a gain or when the simulation fit is not meaningful.
    pub one_step: Option<f64>,
}

/// The model's matrices, one inner vector per row.
#[derive(Debug, Clone, Serialize)]
pub struct Matrices {
    /// A (n × n).
    pub a: Vec<Vec<f64>>,
    /// B (n × m).
    pub b: Vec<Vec<f64>>,
    /// C (p × n).
    pub c: Vec<Vec<f64>>,
    /// D (p × m).
    pub d: Vec<Vec<f64>>,
    /// The Kalman gain K (n × p) of the innovations form, when the route
    /// gives one.
    pub k: Option<Vec<Vec<f64>>>,
}

/// One channel's transfer function G_ij(z) = num(z)/den(z) (positive
/// powers of z, minimal realisation of the channel).
#[derive(Debug, Clone, Serialize)]
pub struct ChannelTf {
    /// Output name.
    pub output: String,
    /// Input name.
    pub input: String,
    /// Numerator, as text (`0.5 z - 0.2`).
    pub num: String,
    /// Denominator, as text.
    pub den: String,
}

/// The figures of an identification, as SVG documents.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Figures {
    /// Order selection (log scale, chosen order marked).
    pub order: Option<String>,
    /// Per output: measured and simulated response.
    pub response: Vec<String>,
    /// Per output: response error.
    pub error: Vec<String>,
    /// Per output: residual autocorrelation over the cross-correlation
    /// with the inputs, with the 99 % bands (the tests of `lifted
    /// validate`).
    pub residuals: Vec<String>,
    /// Step response.
    pub step: String,
    /// Bode magnitude over phase, with the empirical response of the
    /// data (Welch's estimate) as markers for a single-rate record.
    pub bode: String,
    /// Pole-zero map.
    pub pz: String,
    /// The order criterion's values per order (AIC, SVC, …, chosen order
    /// marked), when the route reports them.
    pub criterion: Option<String>,
}

/// The slots of [`Figures`], as the answer names them.
const FIGURE_SLOTS: [&str; 8] = [
    "order",
    "response",
    "error",
    "residuals",
    "step",
    "bode",
    "pz",
    "criterion",
];

impl Figures {
    /// Each slot's content: its SVG documents (none for an absent figure).
    fn slot(&self, name: &str) -> Vec<&str> {
        fn one(s: &str) -> Vec<&str> {
            vec![s]
        }
        fn all(v: &[String]) -> Vec<&str> {
            v.iter().map(String::as_str).collect()
        }
        match name {
            "order" => self.order.iter().map(String::as_str).collect(),
            "response" => all(&self.response),
            "error" => all(&self.error),
            "residuals" => all(&self.residuals),
            "step" => one(&self.step),
            "bode" => one(&self.bode),
            "pz" => one(&self.pz),
            "criterion" => self.criterion.iter().map(String::as_str).collect(),
            _ => Vec::new(),
        }
    }

    /// Empties slot `name` (the page keeps what it shows there).
    fn clear(&mut self, name: &str) {
        match name {
            "order" => self.order = None,
            "response" => self.response.clear(),
            "error" => self.error.clear(),
            "residuals" => self.residuals.clear(),
            "step" => self.step.clear(),
            "bode" => self.bode.clear(),
            "pz" => self.pz.clear(),
            "criterion" => self.criterion = None,
            _ => {}
        }
    }

    /// The digest of every slot (a hash of its documents, with their
    /// count and lengths), and the figures without the slots whose digest
    /// is in `have` under the same slot, with those slots' names.
    pub fn unsent(
        mut self,
        have: &std::collections::BTreeMap<String, String>,
    ) -> (
        Figures,
        std::collections::BTreeMap<String, String>,
        Vec<String>,
    ) {
        use std::hash::{Hash, Hasher};
        let mut digests = std::collections::BTreeMap::new();
        let mut unchanged = Vec::new();
        for name in FIGURE_SLOTS {
            let mut h = std::collections::hash_map::DefaultHasher::new();
            self.slot(name).hash(&mut h);
            let digest = format!("{:016x}", h.finish());
            if have.get(name) == Some(&digest) {
                self.clear(name);
                unchanged.push(name.to_string());
            }
            digests.insert(name.to_string(), digest);
        }
        (self, digests, unchanged)
    }
}

/// The answer to an identification.
#[derive(Debug, Clone, Serialize)]
pub struct Identified {
    /// The request's sequence number, as sent (the page drops an answer
    /// older than its latest request).
    pub seq: Option<u64>,
    /// Whether the model is stable (ρ(A) < 1).
    pub stable: bool,
    /// The spectral radius ρ(A) (`null` if not finite).
    pub spectral_radius: Option<f64>,
    /// The equivalent command line.
    pub command: String,
    /// Method name.
    pub method: String,
    /// Model order.
    pub order: usize,
    /// Order-selection data, when the route has it.
    pub order_selection: Option<OrderSelection>,
    /// Simulation fit per output.
    pub fits: Vec<Fit>,
    /// Poles as (re, im).
    pub poles: Vec<(f64, f64)>,
    /// The feedback test's verdict (`diagnostics.feedback`), in words,
    /// when it ran: "closed loop detected: …" or "no input depends on past
    /// output innovations …".
    pub feedback: Option<String>,
    /// The identification's warnings (`diagnostics.warnings`).
    pub warnings: Vec<String>,
    /// The figures (the slots in `unchanged` left empty).
    pub figures: Figures,
    /// Every figure slot's digest (the page sends them back as
    /// `Request::have`).
    pub figure_digests: std::collections::BTreeMap<String, String>,
    /// The slots not sent again: the page shows them already
    /// (`Request::have`).
    pub unchanged: Vec<String>,
    /// The subspace horizon the model was identified with (chosen by the
    /// held-out selection for order `auto`, else the request's), when the
    /// route has one: the page keeps it for the slider's numeric orders.
    pub horizon: Option<usize>,
    /// The (A, C) route of a subspace model (`shift` or `states`), chosen
    /// or requested, as `--estimator` spells it.
    pub estimator: Option<String>,
    /// The model's matrices.
    pub matrices: Matrices,
    /// The transfer function of each channel (empty, with a note in
    /// `transfer_note`, when the conversion fails).
    pub transfer_functions: Vec<ChannelTf>,
    /// Why there are no transfer functions, if so.
    pub transfer_note: Option<String>,
    /// The refinement's report (`--refine`), when there was one, with how
    /// it was judged (`judge`: `diagnostics.refinement_judge`).
    pub refinement: Option<serde_json::Value>,
    /// How the Kalman gain was made (`diagnostics.kalman_gain_route`), when
    /// it was checked on the records.
    pub gain: Option<lifted_subspace::GainCheck>,
    /// The record the fits and residuals are computed on.
    pub validation_data: String,
    /// Wall time of identify + validate + figures, milliseconds.
    pub elapsed_ms: f64,
}

/// An identification kept for saving, under its request's sequence number.
struct Last {
    seq: Option<u64>,
    file: ModelFile,
    request: Request,
    command: String,
    /// The data file of the command line (the record, or the file of its
    /// estimation range) and its path.
    data: (String, PathBuf),
}

/// Data files of one identification at most (the record and the further
/// experiments).
pub const MAX_EXPERIMENTS: usize = 16;

/// Lifted lags of the delay estimate (`lifted delay --lags` default).
const DELAY_LAGS: usize = 8;
/// Significance of the delay estimate in standard errors (`lifted delay
/// --sigmas` default).
const DELAY_SIGMAS: f64 = 3.0;

/// One input-output pair's delay interval (`lifted delay --json`).
#[derive(Debug, Clone, Serialize)]
pub struct PairDelay {
    /// Input name.
    pub input: String,
    /// Output name.
    pub output: String,
    /// The input's hold m (base periods).
    pub hold: usize,
    /// The output's period n (base periods).
    pub period: usize,
    /// d_c ∈ [lower, upper) in base periods, when the pair gave one.
    pub interval: Option<[i64; 2]>,
    /// The same in seconds.
    pub interval_s: Option<[f64; 2]>,
    /// Why the pair gave none.
    pub failure: Option<String>,
}

/// The delays of the record's pairs.
#[derive(Debug, Clone, Serialize)]
pub struct Delays {
    /// Base period, seconds.
    pub base_period: f64,
    /// Lifted lags of the estimate.
    pub lags: usize,
    /// Significance in standard errors.
    pub sigmas: f64,
    /// One entry per input-output pair.
    pub pairs: Vec<PairDelay>,
}

/// Models kept per session: the page may save any of its last few answers
/// by sequence number.
pub const KEPT_MODELS: usize = 8;

/// The uploaded record: `path` is `<scratch>/<folder>/<name>`, in a folder
/// of its own so that a new upload never touches the loaded record.
struct Record {
    name: String,
    folder: PathBuf,
    path: PathBuf,
    info: DataInfo,
}

/// The studio's state: a scratch directory, the uploaded record and the
/// last model. The scratch directory has a random name and owner-only
/// permissions (0700 on Unix); it is removed when the session is dropped.
pub struct Session {
    dir: PathBuf,
    record: Option<Record>,
    /// The last [`KEPT_MODELS`] identifications, oldest first.
    models: Vec<Last>,
    /// The parsed record and the compressed data of the last requests.
    cache: Cache,
    /// A validation record of its own (else the models are validated on
    /// the estimation record).
    validation: Option<Record>,
    /// Further estimation records after the first (q-Markov: one file per
    /// input), each a `--data` of the command.
    experiments: Vec<Record>,
    /// The model board, oldest first.
    pub(crate) board: Vec<Pinned>,
    /// The last id given to a model on the board.
    pub(crate) board_ids: u64,
}

/// `bytes` random bytes from the operating system's CSPRNG, as hex.
pub(crate) fn random_hex(bytes: usize) -> CliResult<String> {
    use rand::TryRng;
    let mut b = vec![0u8; bytes];
    rand::rngs::SysRng
        .try_fill_bytes(&mut b)
        .map_err(|e| input(format!("studio: no random numbers from the system: {e}")))?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

/// Creates the directory `path` (not its parents) for the owner only; fails
/// if it exists.
fn private_dir(path: &Path) -> std::io::Result<()> {
    let mut b = std::fs::DirBuilder::new();
    #[cfg(unix)]
    {
        use std::os::unix::fs::DirBuilderExt;
        b.mode(0o700);
    }
    b.create(path)
}

/// An error message with `folder/` taken out of the paths it names.
fn plain_in(folder: &Path, e: CliError) -> CliError {
    let prefix = format!("{}{}", folder.display(), std::path::MAIN_SEPARATOR);
    match e {
        CliError::Input(m) => CliError::Input(m.replace(&prefix, "")),
        CliError::Failed(m) => CliError::Failed(m.replace(&prefix, "")),
    }
}

/// A new folder `upload-<random>` of the scratch directory `dir`, owner
/// only, and the path of the record `name` in it (made safe: its base name
/// with anything but letters, digits, `.`, `-`, `_` replaced).
pub(crate) fn staging(dir: &Path, name: &str) -> CliResult<(PathBuf, PathBuf)> {
    let folder = dir.join(format!("upload-{}", random_hex(8)?));
    private_dir(&folder).map_err(|e| input(format!("cannot store the upload: {e}")))?;
    let path = folder.join(safe_name(name));
    Ok((folder, path))
}

/// `8 k²` in bytes, as text (`2.0 GiB`).
fn bytes_text(b: f64) -> String {
    let gib = b / (1u64 << 30) as f64;
    if gib >= 1024.0 {
        format!("{:.1} TiB", gib / 1024.0)
    } else if gib >= 1.0 {
        format!("{gib:.1} GiB")
    } else if b >= (1u64 << 20) as f64 {
        format!("{:.1} MiB", b / (1u64 << 20) as f64)
    } else {
        format!("{:.1} KiB", b / 1024.0)
    }
}

/// A file name safe to write in the scratch directory (the base name, with
/// anything but letters, digits, `.`, `-`, `_` replaced).
fn safe_name(name: &str) -> String {
    let base = name.rsplit(['/', '\\']).next().unwrap_or("");
    let s: String = base
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_') {
                c
            } else {
                '_'
            }
        })
        .collect();
    let s = s.trim_start_matches('.');
    // File systems take names of at most 255 bytes: keep the last 100
    // characters (the extension with them).
    let skip = s.chars().count().saturating_sub(100);
    let s: String = s.chars().skip(skip).collect();
    if s.is_empty() { "data.csv".into() } else { s }
}

/// A time plot with the request's estimation and validation ranges marked:
/// a pair of vertical lines at each range's ends, one series per range
/// (its own colour and dash pattern, named in the legend).
fn marked(mut p: crate::plot::Plot, r: &Request) -> crate::plot::Plot {
    let (lo, hi) = p
        .series
        .iter()
        .flat_map(|s| s.y.iter().copied())
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if lo > hi {
        return p;
    }
    let short = |x: f64| {
        let t = format!("{x:.6}");
        t.trim_end_matches('0').trim_end_matches('.').to_string()
    };
    for (what, range) in [
        ("estimation", r.estimation_range),
        ("validation", r.validation_range),
    ] {
        if let Some([a, b]) = range
            && a.is_finite()
            && b.is_finite()
        {
            p.series.push(crate::plot::Series::line(
                format!("{what} rows {} … {} s", short(a), short(b)),
                vec![a, a, f64::NAN, b, b],
                vec![lo, hi, f64::NAN, lo, hi],
            ));
        }
    }
    p
}

/// The zoom window of a request, checked: finite, t0 < t1.
fn window_of(r: &Request) -> CliResult<Option<(f64, f64)>> {
    window_of_pair(r.window)
}

/// A zoom window `[t0, t1]`, checked: finite, t0 < t1.
pub(crate) fn window_of_pair(w: Option<[f64; 2]>) -> CliResult<Option<(f64, f64)>> {
    match w {
        None => Ok(None),
        Some([a, b]) if a.is_finite() && b.is_finite() && a < b => Ok(Some((a, b))),
        Some([a, b]) => Err(input(format!(
            "window [{a}, {b}]: a time window is two finite times t0 < t1 in seconds"
        ))),
    }
}

/// A matrix as rows.
fn rows_of(m: &nalgebra::DMatrix<f64>) -> Vec<Vec<f64>> {
    m.row_iter().map(|r| r.iter().copied().collect()).collect()
}

/// Each channel's transfer function (`StateSpace::to_tf`), or why not.
fn channel_tfs(model: &lifted_lti::StateSpace) -> (Vec<ChannelTf>, Option<String>) {
    let tf = match model.to_tf(&Default::default()) {
        Ok(tf) => tf,
        Err(e) => return (Vec::new(), Some(format!("no transfer function: {e}"))),
    };
    let var = if model.ts().is_some() { "z" } else { "s" };
    let (un, yn) = crate::service::models::channel_names(model);
    let mut out = Vec::new();
    for (i, y) in yn.iter().enumerate().take(tf.n_outputs()) {
        for (j, u) in un.iter().enumerate().take(tf.n_inputs()) {
            out.push(ChannelTf {
                output: y.clone(),
                input: u.clone(),
                num: tf.num(i, j).display_with(var),
                den: tf.den(i, j).display_with(var),
            });
        }
    }
    (out, None)
}

/// Quotes a command-line word for a POSIX shell when needed.
fn shell_word(w: &str) -> String {
    if !w.is_empty()
        && w.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_=.,/:+".contains(c))
    {
        w.to_string()
    } else {
        format!("'{}'", w.replace('\'', "'\\''"))
    }
}

impl Session {
    /// A session with a fresh scratch directory under `parent`
    /// (`lifted-studio-<32 random hex digits>`, created for the owner only:
    /// mode 0700 on Unix; an existing directory of that name is an error,
    /// never reused).
    pub fn new(parent: &Path) -> CliResult<Self> {
        Self::named(parent, "lifted-studio-")
    }

    /// A session with a fresh directory `<parent>/<prefix><32 random hex
    /// digits>` (owner only; a tab's session is `session-…` inside the
    /// studio's scratch directory).
    pub fn named(parent: &Path, prefix: &str) -> CliResult<Self> {
        let dir = parent.join(format!("{prefix}{}", random_hex(16)?));
        private_dir(&dir).map_err(|e| input(format!("cannot create {}: {e}", dir.display())))?;
        Ok(Session {
            dir,
            record: None,
            models: Vec::new(),
            cache: Cache::default(),
            validation: None,
            experiments: Vec::new(),
            board: Vec::new(),
            board_ids: 0,
        })
    }

    /// The scratch directory (removed by [`Session::close`]).
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Removes the scratch directory (dropping the session does too).
    pub fn close(&self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }

    /// Forgets the record and the last model and empties the scratch
    /// directory: the state after a request failed halfway (a poisoned
    /// lock), when what it left cannot be trusted. Only the session's own
    /// upload folders go (the sessions of other tabs may live beside them).
    pub fn reset(&mut self) {
        self.record = None;
        self.validation = None;
        self.experiments.clear();
        self.models.clear();
        self.board.clear();
        self.cache.clear();
        if let Ok(entries) = std::fs::read_dir(&self.dir) {
            for e in entries.flatten() {
                if !e.file_name().to_string_lossy().starts_with("upload-") {
                    continue;
                }
                let p = e.path();
                let _ = if p.is_dir() {
                    std::fs::remove_dir_all(&p)
                } else {
                    std::fs::remove_file(&p)
                };
            }
        }
    }

    /// Error messages name the record by its uploaded name, not the
    /// scratch path.
    fn plain(&self, e: CliError) -> CliError {
        match &self.record {
            Some(r) => plain_in(&r.folder, e),
            None => plain_in(&self.dir, e),
        }
    }

    fn record(&self) -> CliResult<&Record> {
        self.record
            .as_ref()
            .ok_or_else(|| input("no data loaded: load a CSV file first"))
    }

    /// A new folder of the scratch directory for an incoming record, and
    /// the path of the record `name` in it (made safe: its base name with
    /// anything but letters, digits, `.`, `-`, `_` replaced).
    pub fn staging(&self, name: &str) -> CliResult<(PathBuf, PathBuf)> {
        staging(&self.dir, name)
    }

    /// `bytes` written to a new staging folder under `name`: (folder,
    /// file); the folder is removed again when the write fails.
    fn stage(&self, name: &str, bytes: &[u8]) -> CliResult<(PathBuf, PathBuf)> {
        let (folder, path) = self.staging(name)?;
        if let Err(e) = std::fs::write(&path, bytes) {
            let _ = std::fs::remove_dir_all(&folder);
            return Err(input(format!("cannot store {}: {e}", safe_name(name))));
        }
        Ok((folder, path))
    }

    /// Stores an uploaded CSV and checks every cell with the command's
    /// reader (the same one-line errors as the CLI); the record replaces
    /// the previous one only once it has been read whole (a bad file leaves
    /// the loaded record and the last model as they were).
    pub fn upload(&mut self, name: &str, bytes: &[u8]) -> CliResult<DataInfo> {
        let (folder, path) = self.stage(name, bytes)?;
        self.adopt(folder, path)
    }

    /// Reads the record staged at `path` (in `folder`, both from
    /// [`Session::staging`]) and, if it reads whole, makes it the loaded
    /// record (the previous one and the last model are dropped); else
    /// removes `folder` and keeps the state as it was.
    pub fn adopt(&mut self, folder: PathBuf, path: PathBuf) -> CliResult<DataInfo> {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "data.csv".into());
        match self.inspect(&name, &path) {
            Ok(info) => {
                let old = self.record.replace(Record {
                    name,
                    folder,
                    path,
                    info: info.clone(),
                });
                self.models.clear();
                self.cache.clear();
                // The further experiments belonged to the old record.
                self.clear_experiments();
                if let Some(old) = old {
                    let _ = std::fs::remove_dir_all(old.folder);
                }
                Ok(info)
            }
            Err(e) => {
                let _ = std::fs::remove_dir_all(&folder);
                Err(plain_in(&folder, e))
            }
        }
    }

    /// The loaded record's name and file, if any (a new tab's session
    /// starts with a copy: [`Session::seed`]).
    pub fn record_file(&self) -> Option<(String, PathBuf)> {
        self.record
            .as_ref()
            .map(|r| (r.name.clone(), r.path.clone()))
    }

    /// Loads a copy of the record file `path` (named `name`), as an upload
    /// would.
    pub fn seed(&mut self, name: &str, path: &Path) -> CliResult<DataInfo> {
        let (folder, to) = self.staging(name)?;
        if let Err(e) = std::fs::copy(path, &to) {
            let _ = std::fs::remove_dir_all(&folder);
            return Err(input(format!("cannot copy {name}: {e}")));
        }
        self.adopt(folder, to)
    }

    /// Uses a file on disk as the record (`lifted studio --data`).
    pub fn open(&mut self, path: &str) -> CliResult<DataInfo> {
        let bytes =
            std::fs::read(path).map_err(|e| input(format!("cannot open data file {path}: {e}")))?;
        self.upload(path, &bytes)
    }

    fn inspect(&self, name: &str, path: &Path) -> CliResult<DataInfo> {
        let p = path.display().to_string();
        let all = header(&p, &[])?;
        let is_time = |h: &String| h.eq_ignore_ascii_case("t") || h.eq_ignore_ascii_case("time");
        let has_time = all.iter().any(is_time);
        let cols: Vec<String> = all.into_iter().filter(|h| !is_time(h)).collect();
        if cols.is_empty() {
            return Err(input(format!("{name}: the file has no data columns")));
        }
        let wanted: Vec<&String> = cols.iter().collect();
        // Every cell checked by the command's reader, the values not kept:
        // per column its measured samples and their spacing (O(columns)
        // memory: a 1 GiB wide upload parsed whole peaked at 4.2 GB).
        let mut stats = vec![SampleSpacing::default(); cols.len()];
        let mut row = 0usize;
        // Without a time column the base period is the page's (1 s here).
        let (rows, ts) = scan_rows(
            &p,
            &[],
            &wanted,
            0..cols.len(),
            (!has_time).then_some(1.0),
            |values| {
                for (s, v) in stats.iter_mut().zip(values) {
                    if !v.is_nan() {
                        s.push(row);
                    }
                }
                row += 1;
                Ok(true)
            },
        )?;
        if rows == 0 {
            return Err(input(format!(
                "{name}: the file has a header but no data rows"
            )));
        }
        let columns: Vec<ColumnInfo> = cols
            .iter()
            .zip(&stats)
            .map(|(n, s)| ColumnInfo {
                name: n.clone(),
                samples: s.samples,
                period: s.period(rows),
            })
            .collect();
        let raw = RecordSize { rows, ts };
        let complete = |c: &&ColumnInfo| c.samples == raw.rows;
        let mut inputs: Vec<String> = columns
            .iter()
            .filter(complete)
            .filter(|c| named_role(&c.name) == Some(true))
            .map(|c| c.name.clone())
            .collect();
        let mut guessed = inputs.is_empty();
        if inputs.is_empty() {
            inputs = columns
                .iter()
                .filter(complete)
                .take(1)
                .map(|c| c.name.clone())
                .collect();
        }
        let named_y: Vec<String> = columns
            .iter()
            .filter(|c| named_role(&c.name) == Some(false))
            .map(|c| c.name.clone())
            .collect();
        let outputs = if named_y.is_empty() {
            guessed = true;
            columns
                .iter()
                .filter(|c| !inputs.contains(&c.name))
                .map(|c| c.name.clone())
                .collect()
        } else {
            named_y
        };
        Ok(DataInfo {
            name: name.to_string(),
            rows: raw.rows,
            ts: raw.ts,
            has_time,
            columns,
            suggested_inputs: inputs,
            suggested_outputs: outputs,
            channels_guessed: guessed,
        })
    }

    /// The data specification of a request.
    fn spec(r: &Request) -> CliResult<DataSpec> {
        if r.inputs.is_empty() || r.outputs.is_empty() {
            return Err(input("choose at least one input and one output column"));
        }
        Ok(DataSpec {
            inputs: r.inputs.clone(),
            outputs: r.outputs.clone(),
            extra: Vec::new(),
            ts: r.ts,
            hold: r.hold.unwrap_or(1),
            periods: parse_periods(&r.output_period)?,
            columns: Vec::new(),
        })
    }

    /// The record read with the request's channels (read once per
    /// selection: [`Cache`]).
    fn load(&mut self, r: &Request) -> CliResult<&Dataset> {
        let rec = self.record()?;
        let (path, folder) = (rec.path.display().to_string(), rec.folder.clone());
        self.load_from(&path, &folder, r)
    }

    /// The file `path` (in the upload folder `folder`) read with the
    /// request's channels, through the [`Cache`].
    fn load_from(&mut self, path: &str, folder: &Path, r: &Request) -> CliResult<&Dataset> {
        let spec = Self::spec(r)?;
        let folder = folder.to_path_buf();
        match self.cache.loaded(path, &spec) {
            Ok(l) => Ok(&l.data),
            Err(e) => Err(plain_in(&folder, e)),
        }
    }

    /// The selected channels with their rates and plots.
    pub fn view(&mut self, r: &Request) -> CliResult<View> {
        self.check_sizes(r)?;
        let r = &self.explicit(r)?;
        let window = window_of(r)?;
        let data = self.load(r)?;
        let n = data.len();
        let inputs = data
            .inputs()
            .iter()
            .map(|c| Channel {
                name: c.name.clone(),
                period: c.hold,
                samples: n,
            })
            .collect();
        let outputs = data
            .outputs()
            .iter()
            .map(|c| Channel {
                name: c.name.clone(),
                period: c.period,
                samples: n / c.period.max(1),
            })
            .collect();
        Ok(View {
            rows: n,
            ts: data.ts(),
            inputs,
            outputs,
            inputs_svg: svg(
                &marked(excitation_plot_in(data, &r.inputs, window), r),
                900,
                240,
            )?,
            outputs_svg: svg(&marked(outputs_plot_in(data, window), r), 900, 240)?,
        })
    }

    /// The `lifted identify` arguments of a request (without `lifted`).
    fn identify_words(r: &Request, data: &[String], out: &str) -> Vec<String> {
        let mut w: Vec<String> = vec!["identify".into()];
        // A value that starts with '-' is attached (`--flag=-1`): clap
        // would take it for an option.
        let mut opt = |flag: &str, v: String| {
            if v.starts_with('-') {
                w.push(format!("--{flag}={v}"));
            } else {
                w.push(format!("--{flag}"));
                w.push(v);
            }
        };
        opt("method", r.method.clone().unwrap_or_else(|| "n4sid".into()));
        for d in data {
            opt("data", d.clone());
        }
        opt("inputs", r.inputs.join(","));
        opt("outputs", r.outputs.join(","));
        if let Some(ts) = r.ts {
            opt("ts", ts.to_string());
        }
        if let Some(h) = r.hold {
            opt("hold", h.to_string());
        }
        for p in &r.output_period {
            opt("output-period", p.clone());
        }
        if let Some(o) = &r.order {
            opt("order", o.clone());
        }
        let num = |v: Option<usize>| v.map(|x| x.to_string());
        for (flag, v) in [
            ("max-order", num(r.max_order)),
            ("horizon", num(r.horizon)),
            ("q", num(r.q)),
            ("prbs-order", r.prbs_order.map(|x| x.to_string())),
            ("amplitude", r.amplitude.map(|x| x.to_string())),
            ("detrend", r.detrend.clone()),
            ("estimator", r.estimator.clone()),
            ("order-criterion", r.order_criterion.clone()),
            // The page refines only on its PEM button: a slider move stays a
            // subspace fit (the command's default, `auto`, would refine).
            (
                "refine",
                Some(r.refine.clone().unwrap_or_else(|| "none".into())),
            ),
        ] {
            if let Some(v) = v {
                opt(flag, v);
            }
        }
        if !r.output_weight.is_empty() {
            let s: Vec<String> = r.output_weight.iter().map(f64::to_string).collect();
            opt("output-weight", s.join(","));
        }
        if !r.instrument.is_empty() {
            opt("instrument", r.instrument.join(","));
        }
        if let Some(d) = r.feedthrough {
            opt("feedthrough", d.to_string());
        }
        if r.stable {
            w.push("--stable".into());
        }
        w.push("--out".into());
        w.push(out.into());
        w
    }

    /// The request as the command's arguments, built field by field from
    /// its typed values (no command line written and parsed again): the
    /// command's defaults, then each value the request gives — the same
    /// arguments the shown command line parses to (test
    /// `the_request_builds_the_shown_command_s_arguments`). A name the
    /// command does not take (method, detrend, estimator, order criterion,
    /// refinement) is an error naming the field and the names it takes.
    fn identify_args(r: &Request, data: &[String]) -> CliResult<IdentifyArgs> {
        fn named<T: clap::ValueEnum>(field: &str, value: &str) -> CliResult<T> {
            T::from_str(value, false).map_err(|_| {
                let names: Vec<String> = T::value_variants()
                    .iter()
                    .filter_map(|v| v.to_possible_value())
                    .map(|v| format!("'{}'", v.get_name()))
                    .collect();
                input(format!(
                    "invalid {field} '{value}' (one of {})",
                    names.join(", ")
                ))
            })
        }
        let mut a = Self::default_identify_args()?;
        a.data = data.to_vec();
        a.method = named("method", r.method.as_deref().unwrap_or("n4sid"))?;
        a.columns.inputs = Some(r.inputs.join(","));
        a.columns.outputs = Some(r.outputs.join(","));
        a.columns.ts = r.ts;
        a.columns.output_period = r.output_period.clone();
        if let Some(h) = r.hold {
            a.hold = h;
        }
        if let Some(o) = &r.order {
            a.order = o.clone();
        }
        if let Some(m) = r.max_order {
            a.max_order = m;
        }
        a.horizon = r.horizon.or(a.horizon);
        a.q = r.q.or(a.q);
        a.prbs_order = r.prbs_order.or(a.prbs_order);
        if let Some(x) = r.amplitude {
            a.amplitude = vec![x];
        }
        if let Some(d) = &r.detrend {
            a.detrend = named("detrend", d)?;
        }
        if let Some(e) = &r.estimator {
            a.estimator = named("estimator", e)?;
        }
        if let Some(c) = &r.order_criterion {
            a.order_criterion = named("order_criterion", c)?;
        }
        // The page refines only on its PEM button: a slider move stays a
        // subspace fit (the command's default, `auto`, would refine).
        a.refine = named("refine", r.refine.as_deref().unwrap_or("none"))?;
        if !r.output_weight.is_empty() {
            a.output_weight = r.output_weight.clone();
        }
        if !r.instrument.is_empty() {
            a.instrument = Some(r.instrument.join(","));
        }
        a.feedthrough = r.feedthrough.or(a.feedthrough);
        a.stable = r.stable;
        a.out = "model.json".into();
        Ok(a)
    }

    /// `lifted identify`'s arguments at their defaults (the parser's
    /// defaults, from a command line of constants).
    fn default_identify_args() -> CliResult<IdentifyArgs> {
        IdentifyArgs::defaults("model.json")
            .map_err(|e| input(clap_one_line(&e).trim_start_matches("error: ")))
    }

    /// The model file of a request, as `lifted identify` writes it: the
    /// command's own identification, with the record and the compression of
    /// its in-memory route kept between requests ([`Cache`]).
    fn model_file(&mut self, r: &Request) -> CliResult<ModelFile> {
        let paths: Vec<String> = self
            .estimation_sources(r)?
            .into_iter()
            .map(|(_, p)| p.display().to_string())
            .collect();
        let key = Self::identification_key(r, &paths);
        if let Some(file) = self.cache.identification(&key) {
            return Ok(file);
        }
        let a = Self::identify_args(r, &paths)?;
        let (files, opts) = (files_from_args(&a)?, options_from_args(&a)?);
        let file =
            identify_files_with(&files, &opts, &mut self.cache).map_err(|e| self.plain(e))?;
        if a.stable {
            require_stable(&file.model)?;
        }
        self.cache.keep_identification(key, file.clone());
        Ok(file)
    }

    /// What tells identifications apart for the kept ones (the module
    /// `cached`): the command line (every option and data file) and the
    /// ranges the data files were cut from.
    fn identification_key(r: &Request, paths: &[String]) -> String {
        let words = Self::identify_words(r, paths, "model.json");
        format!(
            "{}\u{1f}{:?}\u{1f}{:?}",
            words.join("\u{1f}"),
            r.estimation_range,
            r.validation_range
        )
    }

    /// The request with the options the page leaves to the defaults made
    /// explicit where that keeps the command on the studio's fast route
    /// (the command line shown then takes the same route, see the module `cached`):
    /// for a numeric order of single-rate N4SID/MOESP/CVA, the horizon
    /// (10, or the least that holds the order), the (A, C) route (shift invariance) and, when no output period
    /// is declared, period 1 for every output (the record's complete
    /// columns: the command then identifies in memory, not streamed); for
    /// a record without a time column, the base period (1 s).
    pub fn explicit(&self, r: &Request) -> CliResult<Request> {
        let rec = self.record()?;
        let mut r = r.clone();
        if r.ts.is_none() && !rec.info.has_time {
            r.ts = Some(1.0);
        }
        let subspace = matches!(
            r.method.as_deref().unwrap_or("n4sid"),
            "n4sid" | "moesp" | "cva"
        );
        let numeric = r
            .order
            .as_deref()
            .is_some_and(|o| o.trim().parse::<usize>().is_ok_and(|n| n > 0));
        let complete = |name: &String| {
            rec.info
                .columns
                .iter()
                .any(|c| &c.name == name && c.samples == rec.info.rows)
        };
        let single_rate = r.outputs.iter().all(complete) && r.hold.unwrap_or(1) <= 1;
        if subspace && numeric && single_rate && r.instrument.is_empty() && r.refine.is_none() {
            // The command's default horizon 10, or the least one that holds
            // the order ((i − 1) n_y ≥ n).
            let n = r
                .order
                .as_deref()
                .and_then(|o| o.trim().parse::<usize>().ok())
                .unwrap_or(1);
            let ny = r.outputs.len().max(1);
            r.horizon.get_or_insert(10.max(n.div_ceil(ny) + 1));
            r.estimator.get_or_insert_with(|| "shift".into());
            if r.output_period.is_empty() {
                r.output_period = r.outputs.iter().map(|o| format!("{o}=1")).collect();
            }
        }
        Ok(r)
    }

    /// The record of a request checked against a model file, as `lifted
    /// validate --detrend auto` does; `horizons`: the prediction fits'
    /// ([`SLIDER_HORIZONS`] for what the page shows, [`REPORT_HORIZONS`]
    /// for the report's table).
    pub(crate) fn validated(
        &mut self,
        file: &ModelFile,
        r: &Request,
        horizons: &[usize],
    ) -> CliResult<(ModelFile, Dataset, crate::service::validation::Validation)> {
        let (name, path, folder) = self.validation_source(r)?;
        let paths: Vec<String> = self
            .estimation_sources(r)?
            .into_iter()
            .map(|(_, p)| p.display().to_string())
            .collect();
        // The model's matrices too: the key then tells apart any two
        // models given with one request.
        let matrices = {
            use std::hash::{Hash, Hasher};
            let m = &file.model;
            let mut h = std::collections::hash_map::DefaultHasher::new();
            for x in [m.a(), m.b(), m.c(), m.d()] {
                x.shape().hash(&mut h);
                x.iter().for_each(|v| v.to_bits().hash(&mut h));
            }
            h.finish()
        };
        let key = format!(
            "{}\u{1f}{}\u{1f}{}\u{1f}{matrices:x}\u{1f}{horizons:?}",
            Self::identification_key(r, &paths),
            name,
            path.display()
        );
        if let Some(kept) = self.cache.validation(&key) {
            return Ok(kept);
        }
        let data = self
            .load_from(&path.display().to_string(), &folder, r)?
            .clone();
        let (file, data) = with_detrend(file.clone(), data, DetrendArg::Auto, &name)?;
        let shortest = data
            .outputs()
            .iter()
            .map(|c| data.len() / c.period.max(1))
            .min()
            .unwrap_or(0);
        let lags = LAGS.min(shortest.saturating_sub(1) / 4).max(1);
        // The page shows the simulation fits, the residual tests (on the
        // simulation's residuals) and the one-step prediction fits.
        let v = validate_model_at(
            &file,
            &data,
            lags,
            lifted_lti::InitialCondition::Estimate,
            horizons,
            &name,
        )?;
        let validated = (file, data, v);
        self.cache.keep_validation(key, validated.clone());
        Ok(validated)
    }

    /// Refuses a request whose sizes the record cannot support, before
    /// anything is allocated: a horizon i whose block Hankel matrix (past +
    /// future = 2i block rows of n_u + n_y rows each) would have more rows
    /// than the record has samples, or whose k² working matrix would pass
    /// [`MAX_WORK_BYTES`]; a q, order or largest order beyond the record's
    /// length or that bound; a hold longer than the record. (A lifted,
    /// multirate record needs at least as many rows, so the bound never
    /// refuses a request the identification could have served.)
    pub fn check_sizes(&self, r: &Request) -> CliResult<()> {
        let rec = self.record()?;
        let (rows, name) = (rec.info.rows, rec.name.as_str());
        let channels = (r.inputs.len() + r.outputs.len()).max(1) as u128;
        // The selected channels of the record, read for the request, and
        // the copies an identification makes of them (scaled, deviations,
        // simulated, residuals: RECORD_COPIES in all) within the memory
        // budget (`lifted studio --memory-limit`, LIFTED_MEMORY_LIMIT,
        // default half the physical memory).
        let budget = lifted_linalg::budget::MemoryBudget::default().bytes() as u128;
        let record_bytes = rows as u128 * channels * 8 * RECORD_COPIES;
        if record_bytes > budget {
            return Err(input(format!(
                "{name}: {rows} rows of the {channels} channels chosen need about {} of memory \
                 for an identification, more than the studio's budget of {} (lifted studio \
                 --memory-limit, or LIFTED_MEMORY_LIMIT): choose fewer channels or raise the budget",
                bytes_text(record_bytes as f64),
                bytes_text(budget as f64)
            )));
        }
        let memory = |flag: &str, value: usize, k: u128, what: &str| -> CliResult<()> {
            let bytes = 8 * k * k;
            if bytes > MAX_WORK_BYTES as u128 {
                return Err(input(format!(
                    "{flag} {value} is too large: the {what} ({k} rows) would need {} of memory \
                     (the studio's limit is {})",
                    bytes_text(bytes as f64),
                    bytes_text(MAX_WORK_BYTES as f64)
                )));
            }
            Ok(())
        };
        if let Some(h) = r.horizon {
            let k = 2 * h as u128 * channels;
            if k > rows as u128 {
                return Err(input(format!(
                    "horizon {h} is too large for {name}: the block Hankel matrix would have \
                     {k} rows (2 × {h} × {channels} channels), more than the record's {rows} samples"
                )));
            }
            memory("horizon", h, k, "block Hankel matrix")?;
        }
        let numeric_order = r
            .order
            .as_deref()
            .and_then(|o| o.trim().parse::<usize>().ok());
        for (flag, v) in [
            ("q", r.q),
            ("order", numeric_order),
            ("max_order", r.max_order),
            ("hold", r.hold),
        ] {
            let Some(v) = v else { continue };
            if v > rows {
                return Err(input(format!(
                    "{flag} {v} is too large for {name}: more than the record's {rows} samples"
                )));
            }
            match flag {
                "q" => memory(flag, v, v as u128 * channels, "q-Markov data matrix")?,
                "order" | "max_order" => memory(flag, v, v as u128, "state matrix")?,
                _ => {}
            }
        }
        Ok(())
    }

    /// Identifies with the request's options, validates on the record and
    /// draws the figures; the model is kept for [`Session::model_json`] and
    /// [`Session::report`]. A failed identification leaves no model (the
    /// previous ones are dropped: saving after a failure is an error, not the
    /// model of other options).
    pub fn identify(&mut self, r: &Request) -> CliResult<Identified> {
        let out = self.identified(r);
        if out.is_err() {
            self.models.clear();
        }
        out
    }

    fn identified(&mut self, r: &Request) -> CliResult<Identified> {
        let start = Instant::now();
        self.check_sizes(r)?;
        let r = &self.explicit(r)?;
        self.check_sizes(r)?;
        let (data_name, data_path) = self.estimation_source(r)?;
        let names: Vec<String> = self
            .estimation_sources(r)?
            .into_iter()
            .map(|(n, _)| n)
            .collect();
        let words = Self::identify_words(r, &names, "model.json");
        let command = std::iter::once("lifted".to_string())
            .chain(words)
            .map(|w| shell_word(&w))
            .collect::<Vec<_>>()
            .join(" ");
        let file = self.model_file(r)?;
        let model = &file.model;
        let diagnostics = Diagnostics::of(&file);
        // The model's own figures (step, pole-zero map, Bode curves,
        // transfer functions) on a second thread while the model is
        // validated on the record (simulation and residual tests).
        type ModelFigures = (String, String, PairFigure, (Vec<ChannelTf>, Option<String>));
        let (validated, drawn) = std::thread::scope(|scope| {
            let drawn = scope.spawn(|| -> CliResult<ModelFigures> {
                let omega = bode_grid(model, None, None, 200)?;
                let one = [(String::new(), model)];
                Ok((
                    pairs_svg(&step_pairs(&one)?, 560, 240)?,
                    svg(&pz_plot(model)?, 380, 440)?,
                    bode_pairs(&one, &omega)?,
                    channel_tfs(model),
                ))
            });
            let validated = self.validated(&file, r, SLIDER_HORIZONS);
            let drawn = drawn
                .join()
                .unwrap_or_else(|_| Err(input("internal: drawing the model's figures failed")));
            (validated, drawn)
        });
        let (_, data, v) = validated?;
        let (step, pz, mut bode, (transfer_functions, transfer_note)) = drawn?;
        let ts = data.ts();
        let n = data.len();
        let mut response = Vec::new();
        let mut error = Vec::new();
        let window = window_of(r)?;
        let mut residuals = Vec::new();
        for o in &v.outputs {
            response.push(svg(
                &response_plot_in(o, ts, n, v.stable(), window),
                900,
                260,
            )?);
            error.push(svg(&response_error_plot_in(o, ts, window), 900, 160)?);
            let (auto, cross) = residual_plots(o, &r.inputs);
            residuals.push(stack_svgs(
                &svg(&auto, 450, 220)?,
                &svg(&cross, 450, 220)?,
                450,
                220,
            ));
        }
        if data.is_single_rate()
            && let Some(g) = self.cache.spectral(&data)
        {
            add_empirical_pairs(&mut bode, g);
        }
        let figures = Figures {
            order: order_plot(&diagnostics)
                .map(|p| svg(&p, 560, 280))
                .transpose()?,
            response,
            error,
            residuals,
            step,
            bode: pairs_svg(&bode, 560, 200)?,
            pz,
            criterion: criterion_plot(&diagnostics)
                .map(|p| svg(&p, 560, 280))
                .transpose()?,
        };
        let (figures, figure_digests, unchanged) = figures.unsent(&r.have);
        let order_selection = diagnostics
            .order_selection
            .as_ref()
            .map(|os| OrderSelection {
                kind: os.kind.clone(),
                values: os.values.clone(),
                order: model.order(),
                suggested_order: Some(os.suggested_order),
            });
        let poles = model
            .poles()
            .map(|p| p.iter().map(|z| (z.re, z.im)).collect())
            .unwrap_or_default();
        let stable = v.stable();
        let fits = v
            .outputs
            .iter()
            .map(|o| Fit {
                output: o.name.clone(),
                fit: (stable && o.residual_finite && o.fit.is_finite()).then_some(o.fit),
                stable,
                white: o.white,
                independent: o.independent,
                one_step: o
                    .prediction_fits
                    .first()
                    .copied()
                    .filter(|f| stable && o.residual_finite && f.is_finite()),
            })
            .collect();
        let chosen = diagnostics.structure_selection.as_ref();
        let horizon = chosen.and_then(|c| c.horizon).or(r.horizon);
        let estimator = chosen
            .and_then(|c| c.system.as_deref())
            .map(|s| {
                if s.starts_with("shift") {
                    "shift".to_string()
                } else {
                    "states".to_string()
                }
            })
            .or_else(|| r.estimator.clone());
        let out = Identified {
            matrices: Matrices {
                a: rows_of(model.a()),
                b: rows_of(model.b()),
                c: rows_of(model.c()),
                d: rows_of(model.d()),
                k: file.kalman_gain.clone(),
            },
            transfer_functions,
            transfer_note,
            refinement: diagnostics.refinement.as_ref().map(|refinement| {
                // How it was judged (held-out blocks or the record).
                let mut v = serde_json::to_value(refinement).unwrap_or_default();
                if let (Some(obj), Some(j)) = (v.as_object_mut(), &diagnostics.refinement_judge) {
                    obj.insert("judge".into(), serde_json::to_value(j).unwrap_or_default());
                }
                v
            }),
            gain: diagnostics.kalman_gain_route.clone(),
            validation_data: self.validation_source(r)?.0,
            seq: r.seq,
            horizon,
            estimator,
            stable,
            spectral_radius: v.spectral_radius.is_finite().then_some(v.spectral_radius),
            command,
            method: file.method.clone().unwrap_or_default(),
            order: model.order(),
            order_selection,
            fits,
            poles,
            feedback: diagnostics.feedback.as_ref().and_then(|f| f.summary()),
            warnings: diagnostics.warnings.clone(),
            figures,
            figure_digests,
            unchanged,
            elapsed_ms: start.elapsed().as_secs_f64() * 1e3,
        };
        if self.models.len() >= KEPT_MODELS {
            self.models.remove(0);
        }
        self.models.push(Last {
            seq: r.seq,
            file,
            request: r.clone(),
            command: out.command.clone(),
            data: (data_name, data_path),
        });
        Ok(out)
    }

    /// The model of the request numbered `seq`, or the last one.
    fn last(&self, seq: Option<u64>) -> CliResult<&Last> {
        let Some(last) = self.models.last() else {
            return Err(input("no model yet: identify one first"));
        };
        match seq {
            None => Ok(last),
            Some(s) => self
                .models
                .iter()
                .rev()
                .find(|m| m.seq == Some(s))
                .ok_or_else(|| {
                    input(format!(
                        "no model of request {s}: the studio keeps the last {KEPT_MODELS} \
                         models of the current options"
                    ))
                }),
        }
    }

    /// The model of request `seq` (the last model without one) as the
    /// command's model-file JSON.
    pub fn model_json(&self, seq: Option<u64>) -> CliResult<String> {
        self.last(seq)?
            .file
            .to_json()
            .map_err(|e| input(format!("model file: {e}")))
    }

    /// The report page of the model of request `seq` (the last model
    /// without one) on the record.
    pub fn report(&mut self, seq: Option<u64>) -> CliResult<String> {
        let last = self.last(seq)?;
        let (file, request) = (last.file.clone(), last.request.clone());
        let name = self.record()?.name.clone();
        let (file, data, v) = self.validated(&file, &request, REPORT_HORIZONS)?;
        render(&file, &data, &v, "model.json (lifted studio)", &name)
    }

    /// The file of the rows of `range` of the record `src` (written once,
    /// [`ranges::slice_file`]), aligned to the frame of the request's
    /// outputs and hold; `what` names the range in errors.
    fn range_file(
        &self,
        src: &Record,
        range: [f64; 2],
        r: &Request,
        what: &str,
    ) -> CliResult<(String, PathBuf)> {
        let ts = r.ts.unwrap_or(src.info.ts);
        let periods = src
            .info
            .columns
            .iter()
            .filter(|c| r.outputs.contains(&c.name))
            .filter_map(|c| c.period);
        let align = ranges::frame(periods, r.hold.unwrap_or(1));
        let (k0, k1) = ranges::rows_of_range(range, ts, src.info.rows, align, what)?;
        ranges::slice_file(&src.path, &src.folder, &src.name, k0, k1)
    }

    /// The data a request validates on: the validation record (else the
    /// estimation record), or the file of its validation range; its name,
    /// path and upload folder.
    fn validation_source(&self, r: &Request) -> CliResult<(String, PathBuf, PathBuf)> {
        let src = match &self.validation {
            Some(v) => v,
            None => self.record()?,
        };
        match r.validation_range {
            Some(range) => {
                let (name, path) = self.range_file(src, range, r, "validation range")?;
                Ok((name, path, src.folder.clone()))
            }
            None => Ok((src.name.clone(), src.path.clone(), src.folder.clone())),
        }
    }

    /// The data file a request identifies on: the record, or the file of
    /// its estimation range; its name (for the command line) and path.
    pub fn estimation_source(&self, r: &Request) -> CliResult<(String, PathBuf)> {
        let rec = self.record()?;
        match r.estimation_range {
            Some(range) => self.range_file(rec, range, r, "estimation range"),
            None => Ok((rec.name.clone(), rec.path.clone())),
        }
    }

    /// Every data file a request identifies on: [`Session::estimation_source`]
    /// and the further experiments (q-Markov: one file per input, in input
    /// order), each `--data` of the command line.
    pub fn estimation_sources(&self, r: &Request) -> CliResult<Vec<(String, PathBuf)>> {
        let mut all = vec![self.estimation_source(r)?];
        all.extend(
            self.experiments
                .iter()
                .map(|e| (e.name.clone(), e.path.clone())),
        );
        Ok(all)
    }

    /// Reads the record staged at `path` (in `folder`) as a further
    /// experiment (appended; the estimation record stays the first `--data`).
    /// A file that does not read whole is removed and nothing changes.
    ///
    /// Errors: no estimation record yet, [`MAX_EXPERIMENTS`] already, the
    /// reader's error.
    pub fn adopt_experiment(&mut self, folder: PathBuf, path: PathBuf) -> CliResult<DataInfo> {
        let full = self.record().err().or_else(|| {
            (self.experiments.len() + 1 >= MAX_EXPERIMENTS).then(|| {
                input(format!(
                    "at most {MAX_EXPERIMENTS} data files per identification"
                ))
            })
        });
        if let Some(e) = full {
            let _ = std::fs::remove_dir_all(&folder);
            return Err(e);
        }
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "experiment.csv".into());
        match self.inspect(&name, &path) {
            Ok(info) => {
                self.experiments.push(Record {
                    name,
                    folder,
                    path,
                    info: info.clone(),
                });
                self.cache.forget_identifications();
                Ok(info)
            }
            Err(e) => {
                let _ = std::fs::remove_dir_all(&folder);
                Err(plain_in(&folder, e))
            }
        }
    }

    /// Stores and reads an uploaded further experiment
    /// ([`Session::adopt_experiment`]).
    pub fn upload_experiment(&mut self, name: &str, bytes: &[u8]) -> CliResult<DataInfo> {
        let (folder, path) = self.stage(name, bytes)?;
        self.adopt_experiment(folder, path)
    }

    /// Drops the further experiments.
    pub fn clear_experiments(&mut self) {
        self.cache.forget_identifications();
        for e in self.experiments.drain(..) {
            let _ = std::fs::remove_dir_all(e.folder);
        }
    }

    /// The further experiments' descriptions.
    pub fn experiments_info(&self) -> Vec<DataInfo> {
        self.experiments.iter().map(|e| e.info.clone()).collect()
    }

    /// The data file of the model of request `seq` (the record or the rows
    /// of its estimation range) and its name, for download.
    pub fn estimation_data(&self, seq: Option<u64>) -> CliResult<(String, String)> {
        let last = self.last(seq)?;
        let (name, path) = &last.data;
        let text =
            std::fs::read_to_string(path).map_err(|e| input(format!("cannot read {name}: {e}")))?;
        Ok((name.clone(), text))
    }

    /// The model of identify request `seq`, its request and command line
    /// (for the board).
    pub(crate) fn kept_model(&self, seq: u64) -> CliResult<(ModelFile, Request, String)> {
        let last = self.last(Some(seq))?;
        Ok((
            last.file.clone(),
            last.request.clone(),
            last.command.clone(),
        ))
    }

    /// The name of the record the models are validated on: the validation
    /// record when one is loaded, else the estimation record.
    pub fn validation_name(&self) -> CliResult<String> {
        match &self.validation {
            Some(v) => Ok(v.name.clone()),
            None => Ok(self.record()?.name.clone()),
        }
    }

    /// Reads the record staged at `path` (in `folder`, from
    /// [`Session::staging`]) as the validation record: once it reads whole
    /// it replaces the previous validation record (the estimation record,
    /// the models and the board stay); else `folder` is removed and nothing
    /// changes. The channels are checked when a model is validated on it.
    pub fn adopt_validation(&mut self, folder: PathBuf, path: PathBuf) -> CliResult<DataInfo> {
        self.record()?;
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "validation.csv".into());
        match self.inspect(&name, &path) {
            Ok(info) => {
                let old = self.validation.replace(Record {
                    name,
                    folder,
                    path,
                    info: info.clone(),
                });
                self.cache.forget_identifications();
                if let Some(old) = old {
                    let _ = std::fs::remove_dir_all(old.folder);
                }
                Ok(info)
            }
            Err(e) => {
                let _ = std::fs::remove_dir_all(&folder);
                Err(plain_in(&folder, e))
            }
        }
    }

    /// Stores and reads an uploaded validation record ([`Session::adopt_validation`]).
    pub fn upload_validation(&mut self, name: &str, bytes: &[u8]) -> CliResult<DataInfo> {
        let (folder, path) = self.stage(name, bytes)?;
        self.adopt_validation(folder, path)
    }

    /// Drops the validation record (the models are validated on the
    /// estimation record again).
    pub fn clear_validation(&mut self) {
        self.cache.forget_identifications();
        if let Some(v) = self.validation.take() {
            let _ = std::fs::remove_dir_all(v.folder);
        }
    }

    /// The validation record's description, if any.
    pub fn validation_info(&self) -> Option<&DataInfo> {
        self.validation.as_ref().map(|r| &r.info)
    }

    /// The delay interval of every input-output pair of the record with
    /// the request's channels (thesis §4.4 per pair, as `lifted delay`
    /// with its defaults: 8 lifted lags, 3σ).
    pub fn delays(&mut self, r: &Request) -> CliResult<Delays> {
        self.check_sizes(r)?;
        let r = &self.explicit(r)?;
        let data = self.load(r)?;
        let ts = data.ts();
        let pairs = lifted_multirate::estimate_delays(data, DELAY_LAGS, DELAY_SIGMAS)
            .map_err(|e| input(format!("delay estimation: {e}")))?;
        Ok(Delays {
            base_period: ts,
            lags: DELAY_LAGS,
            sigmas: DELAY_SIGMAS,
            pairs: pairs
                .iter()
                .map(|p| PairDelay {
                    input: r.inputs.get(p.input).cloned().unwrap_or_default(),
                    output: r.outputs.get(p.output).cloned().unwrap_or_default(),
                    hold: p.hold,
                    period: p.period,
                    interval: p.interval.map(|iv| [iv.lower, iv.upper]),
                    interval_s: p
                        .interval
                        .map(|iv| [iv.lower as f64 * ts, iv.upper as f64 * ts]),
                    failure: p.failure.clone(),
                })
                .collect(),
        })
    }

    /// Records parsed and subspace compressions made by the studio's own
    /// route since the session began (the module `cached`); identifications by the
    /// command's route read the file themselves and are not counted.
    pub fn cache_counts(&self) -> (usize, usize) {
        self.cache.counts()
    }

    /// Identifications run since the session began, not counting those
    /// taken from the kept ones (the module `cached`).
    pub fn identifications_run(&self) -> usize {
        self.cache.identifications()
    }

    /// Forgets the kept identifications and validations, as a change of
    /// the further experiments or of the validation record does (the
    /// studio bench times a first visit of an order with it).
    pub fn forget_identifications(&mut self) {
        self.cache.forget_identifications();
    }

    /// The uploaded record's description, if any.
    pub fn data_info(&self) -> Option<&DataInfo> {
        self.record.as_ref().map(|r| &r.info)
    }
}

impl Drop for Session {
    /// Removes the scratch directory.
    fn drop(&mut self) {
        self.close();
    }
}

#[cfg(test)]
mod tests;

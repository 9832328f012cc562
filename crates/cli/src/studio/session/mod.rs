//! The studio's state and its operations, without HTTP: a record is
//! uploaded, its channels viewed, a model identified with the `identify`
//! options, and the last model saved as a model file or a report. Every
//! operation goes through the service layer ([`crate::table`],
//! [`crate::service`]): a request's values are set on the command's
//! arguments directly and converted to the workflow's options by the
//! command's own conversion, so a model made here equals the one
//! `lifted identify` writes with the same options.

use std::path::{Path, PathBuf};

use lifted_lti::{Dataset, ModelFile};

use crate::error::{CliError, CliResult, input};
use crate::plot::svg;
use crate::service::figures::{excitation_plot_in, outputs_plot_in};
use crate::studio::board::Pinned;
use crate::studio::cached::Cache;
use crate::table::{DataSpec, header, parse_periods, scan_rows};

mod data;
mod identify;
mod wire;

pub use wire::*;

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

/// Copies of a request's record an identification holds at once (the
/// values read, scaled, as deviations, simulated, the residuals): the
/// factor of [`Session::check_sizes`]' memory check.
const RECORD_COPIES: u128 = 5;

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
}

impl Drop for Session {
    /// Removes the scratch directory.
    fn drop(&mut self) {
        self.close();
    }
}

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

#[cfg(test)]
mod tests;

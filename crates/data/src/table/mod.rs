//! Reading data sets from CSV (or numpy `.npy`, see [`npy`]) by
//! column name, streaming, with error messages that name the file, the line
//! and the column.
//!
//! A CSV file has a header row. Only the requested columns are parsed and
//! kept (one `Vec<f64>` each), so memory is 8 bytes per kept cell whatever
//! the width of the file; the time column `t`/`time`, when present, is
//! checked for uniform spacing on the fly and gives the base period when
//! `--ts` is absent. An output column may have empty cells: a slowly
//! sampled output is written with empty cells between its samples. Input
//! and instrument columns must be complete.
//!
//! The CSV reader is a block reader with a fast path for lines of plain
//! numbers and `csv-core` for anything else (see [`scan_rows`]); on a
//! large file it parses blocks of whole lines on several threads and
//! delivers the rows in file order on the calling thread. Its throughput is
//! measured by `benches/benches/csv.rs` (benches/results/slicot.md).
//!
//! One file per reader: `fast` (the fast CSV path), `csv_records` (the
//! csv-crate path: `csv-core` records, cell checks, the header row),
//! `npy_glue` (which reader a file goes to; `.npy` files to [`npy`]),
//! `columns` (column selection and duplicate checks), `rows` (row count and
//! time-column checks shared with `.npy`), and the two CSV scans built on
//! them, `scan` (sequential) and `parallel`. This module holds the data-set
//! layer: [`DataSpec`], [`read_raw`], [`scan_rows`], [`load`],
//! [`write_columns`].

mod columns;
mod csv_records;
mod fast;
pub mod npy;
mod npy_glue;
mod parallel;
mod rows;
mod scan;
#[cfg(test)]
mod tests;
mod timestamps;

use std::fmt::Display;
use std::fs::File;

use lifted_lti::{Dataset, InputChannel, OutputChannel};
use nalgebra::DMatrix;

use crate::error::{Context, input};
use crate::shown::{shown, shown_list};

use self::csv_records::*;
use self::fast::*;
use self::parallel::*;
use self::scan::*;

use self::columns::column_indices;
pub use self::columns::{bare_name, not_the_time_column, time_column};
pub use self::columns::{check_unique, names, parse_name_counts, parse_periods};
pub use self::npy_glue::{header, is_npy};
pub(crate) use self::rows::RowCheck;

/// Which columns to read and how to lay out the data set.
#[derive(Debug, Clone, Default)]
pub struct DataSpec {
    /// Input column names.
    pub inputs: Vec<String>,
    /// Output column names.
    pub outputs: Vec<String>,
    /// Extra complete columns (e.g. instruments), returned separately.
    pub extra: Vec<String>,
    /// Base period; `None`: from the time column.
    pub ts: Option<f64>,
    /// Input hold (base periods), the same for every input; default 1.
    pub hold: usize,
    /// Declared output periods by name (`--output-period y1=5`).
    pub periods: Vec<(String, usize)>,
    /// Names of the columns of a `.npy` file, in order (`--columns`; empty:
    /// `c0, c1, …`). Ignored for CSV files, whose header row names them.
    pub columns: Vec<String>,
}

/// A data set read from a file, with the extra columns.
#[derive(Debug, Clone)]
pub struct Loaded {
    /// The data set.
    pub data: Dataset,
    /// The extra columns, N × extra.len().
    pub extra: DMatrix<f64>,
}

/// Columns read from a file.
pub struct Raw {
    /// The requested columns, in order.
    pub cols: Vec<Vec<f64>>,
    /// Number of data rows.
    pub rows: usize,
    /// Base period (given or from the time column).
    pub ts: f64,
}

/// Reads the named columns, streaming; cells of the columns in `may_be_empty`
/// (a range of indices into `wanted`) may be empty (NaN). `columns` names the
/// columns of a `.npy` file (empty: `c0, c1, …`; ignored for CSV). O(file)
/// time, O(rows × wanted) memory.
pub fn read_raw(
    path: &str,
    columns: &[String],
    wanted: &[&String],
    may_be_empty: std::ops::Range<usize>,
    ts: Option<f64>,
) -> crate::Result<Raw> {
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); wanted.len()];
    if is_npy(path) {
        // Whole blocks of columns (no per-row calls).
        let block_rows = 1 << 16;
        let (rows, ts) = npy::scan_blocks(
            path,
            columns,
            wanted,
            may_be_empty,
            ts,
            block_rows,
            |b, n| {
                for (c, col) in cols.iter_mut().zip(b.chunks_exact(n)) {
                    c.extend_from_slice(col);
                }
                Ok(n)
            },
        )?;
        return Ok(Raw { cols, rows, ts });
    }
    let (rows, ts) = scan_rows(path, columns, wanted, may_be_empty, ts, |row| {
        for (c, &v) in cols.iter_mut().zip(row) {
            c.push(v);
        }
        Ok(true)
    })?;
    Ok(Raw { cols, rows, ts })
}

/// Streams the named columns of a data file (CSV, or `.npy` by extension:
/// see [`npy`]) row by row: `visit` receives the values of `wanted`
/// (empty cells of the columns in `may_be_empty` as NaN) and returns whether
/// to go on. Returns the number of rows visited and the base period (given,
/// or from the time column over the rows read). `columns` names the columns
/// of a `.npy` file (empty: `c0, c1, …`); a CSV file names its own.
///
/// CSV files are read in blocks of 1 MiB (`Read::read` into one reusable
/// buffer; a line cut by the block end is carried over). Each line goes
/// first through a fast path: cells split by a word-at-a-time scan for `,`,
/// only the wanted cells and the time column parsed (Clinger's exact fast
/// path for the usual numbers, `fast-float2` for the rest: correctly
/// rounded, the grammar of `str::parse::<f64>`), the other cells skipped. A
/// line it does not take as plain numbers (a quote `"`, a lone carriage
/// return, a cell that is not a number, a ragged row) is read again through
/// `csv-core` (the csv crate's parser) with the checks and messages of
/// `cell_value`, so the result is that of a full CSV parser. Line numbers
/// in messages are those of the file.
///
/// A regular file of at least 4 MiB is parsed on up to 4 threads (the
/// available parallelism; 1: as above): blocks of about 1 MiB of whole lines
/// go through the fast path on helper threads and the calling thread, which
/// calls `visit` for the rows in file order; from a line the fast path does
/// not take, the file is read as above until the next block boundary. The
/// rows, checks and messages are the same (see `scan_parallel`). Time
/// O(file size), memory O(columns + threads × block + longest line),
/// whatever the file length.
pub fn scan_rows(
    path: &str,
    columns: &[String],
    wanted: &[&String],
    may_be_empty: std::ops::Range<usize>,
    ts: Option<f64>,
    visit: impl FnMut(&[f64]) -> crate::Result<bool>,
) -> crate::Result<(usize, f64)> {
    scan_rows_threads(path, columns, wanted, may_be_empty, ts, None, visit)
}

/// [`scan_rows`] with the number of threads parsing a CSV file given:
/// `Some(1)` reads on the calling thread alone, `Some(n)` parses blocks on
/// n threads in all (the calling thread included; at most the available
/// parallelism, `lifted_linalg::budget::resolve_threads`) whatever the file's size,
/// `None` chooses as [`scan_rows`] does. The same rows, checks and
/// messages in every case (the benches compare the timings).
pub fn scan_rows_threads(
    path: &str,
    columns: &[String],
    wanted: &[&String],
    may_be_empty: std::ops::Range<usize>,
    ts: Option<f64>,
    threads: Option<usize>,
    visit: impl FnMut(&[f64]) -> crate::Result<bool>,
) -> crate::Result<(usize, f64)> {
    if is_npy(path) {
        return npy::scan_rows(path, columns, wanted, may_be_empty, ts, visit);
    }
    let mode = Mode {
        threads: threads.map(|n| lifted_linalg::budget::resolve_threads(n.max(1))),
        ..Mode::default()
    };
    scan_csv(path, wanted, may_be_empty, ts, mode, visit)
}

/// Reads the file, streaming, and builds the data set.
pub fn load(path: &str, spec: &DataSpec) -> crate::Result<Loaded> {
    let n_in = spec.inputs.len();
    let n_out = spec.outputs.len();
    let wanted: Vec<&String> = spec
        .inputs
        .iter()
        .chain(&spec.outputs)
        .chain(&spec.extra)
        .collect();
    if n_in == 0 || n_out == 0 {
        return Err(input(
            "at least one input and one output column are needed (--inputs, --outputs)",
        ));
    }
    spec.check_selection()?;
    let Raw { mut cols, rows, ts } =
        read_raw(path, &spec.columns, &wanted, n_in..n_in + n_out, spec.ts)?;
    // Output sampling: declared periods are checked, others inferred.
    for (name, _) in &spec.periods {
        if !spec.outputs.contains(name) {
            return Err(input(format!(
                "--output-period {name}=…: '{name}' is not one of the outputs ({})",
                spec.outputs.join(", ")
            )));
        }
    }
    let mut outputs = Vec::with_capacity(n_out);
    for (o, name) in spec.outputs.iter().enumerate() {
        let col = &mut cols[n_in + o];
        let declared = spec.periods.iter().find(|(n, _)| n == name).map(|p| p.1);
        let (period, offset) = sampling(path, name, col, declared, is_npy(path))?;
        outputs.push(OutputChannel::new(name.clone(), period, offset));
    }
    let hold = spec.hold.max(1);
    let inputs: Vec<InputChannel> = spec
        .inputs
        .iter()
        .map(|n| InputChannel::new(n.clone(), hold))
        .collect();
    let mat = |range: std::ops::Range<usize>| {
        let mut m = DMatrix::zeros(rows, range.len());
        for (j, c) in range.enumerate() {
            m.column_mut(j).copy_from_slice(&cols[c]);
        }
        m
    };
    let u = mat(0..n_in);
    let y = mat(n_in..n_in + n_out);
    let extra = mat(n_in + n_out..wanted.len());
    drop(cols);
    let data = Dataset::new(ts, u, y, inputs, outputs).ctx(path)?;
    Ok(Loaded { data, extra })
}

/// (period, offset) of an output column from its empty cells; with a
/// declared period, checks that the samples follow it. Messages locate
/// sample k by its CSV line (k + 2) or, for a `.npy` file (`npy`), by its
/// row k. O(rows).
fn sampling(
    path: &str,
    name: &str,
    col: &[f64],
    declared: Option<usize>,
    npy: bool,
) -> crate::Result<(usize, usize)> {
    let at = |k: usize| {
        if npy {
            format!("row {k}")
        } else {
            format!("line {}", k + 2)
        }
    };
    use lifted_lti::SamplingError as S;
    lifted_lti::output_sampling(col, declared).map_err(|e| match e {
        S::NoSamples => input(format!(
            "{path}: output column '{name}' has no samples (all cells empty)"
        )),
        S::SingleSample => input(format!(
            "{path}: output column '{name}' has a single sample: give --output-period {name}=P"
        )),
        S::FirstMissing { first, period } => input(format!(
            "{path}: {}, column '{name}': first sample is missing (period {period}): the column's first value is at {}, {first} rows after the start; an output must be sampled within its first period (an analyser started after the logger?): cut the rows before {}",
            at(first - 1),
            at(first),
            at(first)
        )),
        S::MissingAt { sample, period } => input(format!(
            "{path}: {}, column '{name}': empty cell at a sampling instant of period {period} (an output is sampled every P instants from its first sample; isolated missing values are not supported: fill them, e.g. by interpolation, or cut the record there)",
            at(sample)
        )),
        S::Between { sample, period } => input(format!(
            "{path}: {}, column '{name}': value between samples of period {period} (the cell must be empty)",
            at(sample)
        )),
        other => input(format!("{path}: output column '{name}': {other}")),
    })
}

/// Writes columns as CSV: header then one row per sample; NaN is written
/// as an empty cell.
pub fn write_columns(path: &str, header: &[String], columns: &[Vec<f64>]) -> crate::Result<()> {
    let mut w = csv::Writer::from_path(path).ctx(format!("cannot write {path}"))?;
    w.write_record(header).ctx(format!("cannot write {path}"))?;
    let n = columns.first().map_or(0, Vec::len);
    let mut row: Vec<String> = Vec::with_capacity(columns.len());
    for k in 0..n {
        row.clear();
        for c in columns {
            let v = c[k];
            row.push(if v.is_nan() {
                String::new()
            } else {
                format!("{v}")
            });
        }
        w.write_record(&row).ctx(format!("cannot write {path}"))?;
    }
    w.flush().ctx(format!("cannot write {path}"))
}

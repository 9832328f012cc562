//! Reading data sets from CSV by column name, streaming, with error
//! messages that name the file, the line and the column.
//!
//! The file has a header row. Only the requested columns are parsed and
//! kept (one `Vec<f64>` each), so memory is 8 bytes per kept cell whatever
//! the width of the file; the time column `t`/`time`, when present, is
//! checked for uniform spacing on the fly and gives the base period when
//! `--ts` is absent. An output column may have empty cells: a slowly
//! sampled output is written with empty cells between its samples. Input
//! and instrument columns must be complete.

use std::fs::File;
use std::io::BufReader;

use lifted_lti::{Dataset, InputChannel, OutputChannel};
use nalgebra::DMatrix;

use crate::error::{CliResult, Context, input};

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
}

/// A data set read from a file, with the extra columns.
#[derive(Debug, Clone)]
pub struct Loaded {
    /// The data set.
    pub data: Dataset,
    /// The extra columns, N × extra.len().
    pub extra: DMatrix<f64>,
}

/// Parses `name=period` pairs of `--output-period`.
pub fn parse_periods(specs: &[String]) -> CliResult<Vec<(String, usize)>> {
    parse_name_counts(specs, "--output-period", "PERIOD", "y1=5")
}

/// Parses `name=n` pairs (n a positive integer) of the option `flag`.
pub fn parse_name_counts(
    specs: &[String],
    flag: &str,
    what: &str,
    example: &str,
) -> CliResult<Vec<(String, usize)>> {
    specs
        .iter()
        .flat_map(|s| s.split(','))
        .filter(|s| !s.trim().is_empty())
        .map(|s| {
            let (name, p) = s.split_once('=').ok_or_else(|| {
                input(format!(
                    "{flag} '{s}': expected NAME={what}, e.g. {example}"
                ))
            })?;
            let n: usize = p.trim().parse().ok().filter(|&p| p > 0).ok_or_else(|| {
                input(format!(
                    "{flag} '{s}': {} must be a positive integer",
                    what.to_lowercase()
                ))
            })?;
            Ok((name.trim().to_string(), n))
        })
        .collect()
}

/// Splits a comma-separated list of names.
pub fn names(list: &str) -> Vec<String> {
    list.split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(str::to_string)
        .collect()
}

fn cell_value(
    path: &str,
    line: u64,
    column: &str,
    cell: &[u8],
    allow_empty: bool,
) -> CliResult<f64> {
    let text = std::str::from_utf8(cell)
        .map_err(|_| {
            input(format!(
                "{path}: line {line}, column '{column}': cell is not UTF-8"
            ))
        })?
        .trim();
    if text.is_empty() {
        if allow_empty {
            return Ok(f64::NAN);
        }
        return Err(input(format!(
            "{path}: line {line}, column '{column}': empty cell (only output columns may have empty cells)"
        )));
    }
    let v: f64 = text.parse().map_err(|_| {
        input(format!(
            "{path}: line {line}, column '{column}': cannot parse '{text}' as a number"
        ))
    })?;
    if !v.is_finite() {
        return Err(input(format!(
            "{path}: line {line}, column '{column}': value '{text}' is not finite (NaN/inf are not allowed; leave the cell empty for an unsampled output)"
        )));
    }
    Ok(v)
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
/// (a range of indices into `wanted`) may be empty (NaN).
pub fn read_raw(
    path: &str,
    wanted: &[&String],
    may_be_empty: std::ops::Range<usize>,
    ts: Option<f64>,
) -> CliResult<Raw> {
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); wanted.len()];
    let (rows, ts) = scan_rows(path, wanted, may_be_empty, ts, |row| {
        for (c, &v) in cols.iter_mut().zip(row) {
            c.push(v);
        }
        Ok(true)
    })?;
    Ok(Raw { cols, rows, ts })
}

/// A CSV reader positioned after the header row, and the header's names.
type CsvFile = (csv::Reader<BufReader<File>>, Vec<String>);

/// Opens a CSV file and reads its header row (which must name the columns,
/// not hold numbers).
fn open_csv(path: &str) -> CliResult<CsvFile> {
    let file = File::open(path).ctx(format!("cannot open data file {path}"))?;
    let mut rd = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .buffer_capacity(1 << 16)
        .from_reader(BufReader::with_capacity(1 << 16, file));
    let mut rec = csv::ByteRecord::new();
    let got = rd
        .read_byte_record(&mut rec)
        .ctx(format!("{path}: line 1"))?;
    if !got || rec.iter().all(|c| c.iter().all(u8::is_ascii_whitespace)) {
        return Err(input(format!(
            "{path}: empty file (a header row is required)"
        )));
    }
    let header: Vec<String> = rec
        .iter()
        .map(|c| String::from_utf8_lossy(c).trim().to_string())
        .collect();
    if header
        .iter()
        .any(|h| !h.is_empty() && h.parse::<f64>().is_ok())
    {
        return Err(input(format!(
            "{path}: line 1 is not a header row (it contains numbers); the first row must name the columns"
        )));
    }
    Ok((rd, header))
}

/// The column names of a CSV file's header row.
pub fn header(path: &str) -> CliResult<Vec<String>> {
    open_csv(path).map(|(_, h)| h)
}

/// Streams the named columns of a CSV file row by row: `visit` receives the
/// values of `wanted` (empty cells of the columns in `may_be_empty` as NaN)
/// and returns whether to go on. Returns the number of rows visited and the
/// base period (given, or from the time column over the rows read). Memory
/// O(columns), whatever the file length.
pub fn scan_rows(
    path: &str,
    wanted: &[&String],
    may_be_empty: std::ops::Range<usize>,
    ts: Option<f64>,
    mut visit: impl FnMut(&[f64]) -> CliResult<bool>,
) -> CliResult<(usize, f64)> {
    let (mut rd, header) = open_csv(path)?;
    let mut rec = csv::ByteRecord::new();
    let find = |name: &str| -> CliResult<usize> {
        header.iter().position(|h| h == name).ok_or_else(|| {
            input(format!(
                "{path}: header has no column '{name}' (columns: {})",
                header.join(", ")
            ))
        })
    };
    let idx: Vec<usize> = wanted.iter().map(|n| find(n)).collect::<CliResult<_>>()?;
    let time_col = header
        .iter()
        .position(|h| h.eq_ignore_ascii_case("t") || h.eq_ignore_ascii_case("time"));
    let width = header.len();
    let mut row = vec![0.0; wanted.len()];
    let (mut t0, mut t1, mut t_last) = (f64::NAN, f64::NAN, f64::NAN);
    let mut rows = 0usize;
    let mut line = 1u64;
    loop {
        match rd.read_byte_record(&mut rec) {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => return Err(input(format!("{path}: line {}: {e}", line + 1))),
        }
        line = rec.position().map_or(line + 1, |p| p.line());
        if rec.len() == 1 && rec.get(0).is_some_and(<[u8]>::is_empty) {
            continue; // blank line
        }
        if rec.len() != width {
            return Err(input(format!(
                "{path}: line {line}: {} cells, the header has {width} (ragged row)",
                rec.len()
            )));
        }
        for (j, &c) in idx.iter().enumerate() {
            let allow_empty = may_be_empty.contains(&j);
            row[j] = cell_value(path, line, wanted[j], &rec[c], allow_empty)?;
        }
        if let (Some(tc), None) = (time_col, ts) {
            let t = cell_value(path, line, &header[tc], &rec[tc], false)?;
            match rows {
                0 => t0 = t,
                1 => t1 = t,
                _ => {
                    let dt = t1 - t0;
                    let expect = t0 + rows as f64 * dt;
                    if (t - expect).abs() > 1e-6 * dt.abs().max(1e-300) + 1e-9 * expect.abs() {
                        return Err(input(format!(
                            "{path}: line {line}, column '{}': time {t} breaks the uniform spacing {dt} (expected {expect}); give --ts to ignore the time column",
                            header[tc]
                        )));
                    }
                }
            }
            t_last = t;
        }
        rows += 1;
        if !visit(&row)? {
            break;
        }
    }
    if rows == 0 {
        return Err(input(format!("{path}: no data rows after the header")));
    }
    let ts = match ts {
        Some(ts) if ts.is_finite() && ts > 0.0 => ts,
        Some(ts) => return Err(input(format!("--ts {ts}: must be positive and finite"))),
        None => {
            if time_col.is_none() {
                return Err(input(format!(
                    "{path}: no time column ('t' or 'time'): give the base period with --ts"
                )));
            }
            if rows < 2 {
                return Err(input(format!(
                    "{path}: one row: give the base period with --ts"
                )));
            }
            let ts = (t_last - t0) / (rows - 1) as f64;
            if !(ts.is_finite() && ts > 0.0) {
                return Err(input(format!(
                    "{path}: the time column does not increase: give --ts"
                )));
            }
            ts
        }
    };
    Ok((rows, ts))
}

/// Reads the file, streaming, and builds the data set.
pub fn load(path: &str, spec: &DataSpec) -> CliResult<Loaded> {
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
    let Raw { mut cols, rows, ts } = read_raw(path, &wanted, n_in..n_in + n_out, spec.ts)?;
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
        let (period, offset) = sampling(path, name, col, declared)?;
        if rows % period != 0 {
            return Err(input(format!(
                "{path}: output '{name}' has period {period}, which does not divide the record length {rows} rows (trim the file to a multiple of {period} rows)"
            )));
        }
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
/// declared period, checks that the samples follow it.
fn sampling(
    path: &str,
    name: &str,
    col: &[f64],
    declared: Option<usize>,
) -> CliResult<(usize, usize)> {
    let first = col.iter().position(|v| !v.is_nan()).ok_or_else(|| {
        input(format!(
            "{path}: output column '{name}' has no samples (all cells empty)"
        ))
    })?;
    let period = match declared {
        Some(p) => p,
        None => match col[first + 1..].iter().position(|v| !v.is_nan()) {
            Some(gap) => gap + 1,
            None if col.len() == 1 => 1,
            None => {
                return Err(input(format!(
                    "{path}: output column '{name}' has a single sample: give --output-period {name}=P"
                )));
            }
        },
    };
    if first >= period {
        return Err(input(format!(
            "{path}: line {}, column '{name}': first sample is missing (period {period})",
            first + 1
        )));
    }
    for (k, v) in col.iter().enumerate() {
        let sampled = k % period == first;
        if sampled && v.is_nan() {
            return Err(input(format!(
                "{path}: line {}, column '{name}': empty cell at a sampling instant of period {period}",
                k + 2
            )));
        }
        if !sampled && !v.is_nan() {
            return Err(input(format!(
                "{path}: line {}, column '{name}': value between samples of period {period} (the cell must be empty)",
                k + 2
            )));
        }
    }
    Ok((period, first))
}

/// Writes columns as CSV: header then one row per sample; NaN is written
/// as an empty cell.
pub fn write_columns(path: &str, header: &[String], columns: &[Vec<f64>]) -> CliResult<()> {
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

//! Reading data sets from CSV (or numpy `.npy`, see [`crate::npy`]) by
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
//! measured by `benches/benches/csv.rs` (benches/README.md).

use std::fmt::Display;
use std::fs::File;

use lifted_lti::{Dataset, InputChannel, OutputChannel};
use nalgebra::DMatrix;

use crate::error::{CliResult, Context, input};
use crate::shown::{shown, shown_list};

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

/// An error naming the first name of `names` that occurs twice, with both
/// 1-based positions: "`what`: column 'y1' appears twice (positions 2 and
/// 3)". Empty names (a trailing comma in a header) are not compared.
pub fn check_unique<S: AsRef<str>>(what: &str, names: &[S]) -> CliResult<()> {
    let mut seen: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
    for (i, n) in names.iter().enumerate() {
        let n = n.as_ref();
        if n.is_empty() {
            continue;
        }
        if let Some(first) = seen.insert(n, i) {
            return Err(input(format!(
                "{what}: column '{}' appears twice (positions {} and {})",
                shown(n),
                first + 1,
                i + 1
            )));
        }
    }
    Ok(())
}

impl DataSpec {
    /// Rejects a column selected twice among the inputs and outputs (a name
    /// in both lists, or twice in one), naming it and both places, e.g.
    /// "column 'y1' is selected twice (--outputs position 1 and --outputs
    /// position 2)". Extra columns (instruments) may repeat an input.
    pub fn check_selection(&self) -> CliResult<()> {
        let mut seen: std::collections::HashMap<&str, (&str, usize)> =
            std::collections::HashMap::new();
        for (flag, list) in [("--inputs", &self.inputs), ("--outputs", &self.outputs)] {
            for (i, n) in list.iter().enumerate() {
                if let Some((f0, i0)) = seen.insert(n.as_str(), (flag, i)) {
                    return Err(input(format!(
                        "column '{}' is selected twice ({f0} position {} and {flag} position {})",
                        shown(n),
                        i0 + 1,
                        i + 1
                    )));
                }
            }
        }
        check_unique("--instrument", &self.extra)
    }
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
            "{path}: line {line}, column '{column}': cannot parse '{}' as a number",
            shown(text)
        ))
    })?;
    if !v.is_finite() {
        return Err(input(format!(
            "{path}: line {line}, column '{column}': value '{}' is not finite (NaN/inf are not allowed; leave the cell empty for an unsampled output)",
            shown(text)
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
/// (a range of indices into `wanted`) may be empty (NaN). `columns` names the
/// columns of a `.npy` file (empty: `c0, c1, …`; ignored for CSV). O(file)
/// time, O(rows × wanted) memory.
pub fn read_raw(
    path: &str,
    columns: &[String],
    wanted: &[&String],
    may_be_empty: std::ops::Range<usize>,
    ts: Option<f64>,
) -> CliResult<Raw> {
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); wanted.len()];
    let (rows, ts) = scan_rows(path, columns, wanted, may_be_empty, ts, |row| {
        for (c, &v) in cols.iter_mut().zip(row) {
            c.push(v);
        }
        Ok(true)
    })?;
    Ok(Raw { cols, rows, ts })
}

/// Whether `path` names a numpy `.npy` file (by its extension, any case).
pub fn is_npy(path: &str) -> bool {
    std::path::Path::new(path)
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("npy"))
}

/// The column names of a data file: a CSV file's header row, or a `.npy`
/// file's `columns` (default `c0, c1, …`, checked against the array's
/// width). Reads only the start of the file.
pub fn header(path: &str, columns: &[String]) -> CliResult<Vec<String>> {
    if is_npy(path) {
        return crate::npy::header(path, columns);
    }
    open_csv(path, 1 << 16).map(|(_, h)| h)
}

/// Positions of the `wanted` columns in a CSV header; a missing one is an
/// error naming the file and listing the columns it has.
fn column_indices(path: &str, header: &[String], wanted: &[&String]) -> CliResult<Vec<usize>> {
    wanted
        .iter()
        .map(|name| {
            header.iter().position(|h| h == *name).ok_or_else(|| {
                input(format!(
                    "{}: header has no column '{}' (columns: {})",
                    shown(path),
                    shown(name),
                    shown_list(header)
                ))
            })
        })
        .collect()
}

/// Streams the named columns of a data file (CSV, or `.npy` by extension:
/// see [`crate::npy`]) row by row: `visit` receives the values of `wanted`
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
    visit: impl FnMut(&[f64]) -> CliResult<bool>,
) -> CliResult<(usize, f64)> {
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
    visit: impl FnMut(&[f64]) -> CliResult<bool>,
) -> CliResult<(usize, f64)> {
    if is_npy(path) {
        return crate::npy::scan_rows(path, columns, wanted, may_be_empty, ts, visit);
    }
    let mode = Mode {
        threads: threads.map(|n| lifted_linalg::budget::resolve_threads(n.max(1))),
        ..Mode::default()
    };
    scan_csv(path, wanted, may_be_empty, ts, mode, visit)
}

/// How [`scan_csv`] reads (tests vary it).
#[derive(Debug, Clone, Copy)]
struct Mode {
    /// Try the fast path on each line (false: `csv-core` for every record,
    /// on the calling thread).
    fast: bool,
    /// Initial buffer size in bytes; also the size of the blocks of whole
    /// lines parsed in parallel.
    block: usize,
    /// Threads parsing the file, the calling thread included: 1 reads
    /// sequentially, n ≥ 2 parses blocks on the calling thread and n − 1
    /// helpers (see [`scan_parallel`]); `None` chooses (the available
    /// parallelism, at most [`MAX_THREADS`], for a regular file of at least
    /// [`MIN_BLOCKS`] blocks; otherwise 1).
    threads: Option<usize>,
}

impl Default for Mode {
    fn default() -> Self {
        Mode {
            fast: true,
            block: BLOCK,
            threads: None,
        }
    }
}

/// Bytes read from a CSV file at a time (the buffer grows for a longer line).
const BLOCK: usize = 1 << 20;

/// At most this many threads parse a CSV file.
const MAX_THREADS: usize = 4;

/// A file shorter than this many blocks is read sequentially (threads
/// would not pay for themselves).
const MIN_BLOCKS: u64 = 4;

/// A CSV file read in blocks: whole lines for the fast path (every line
/// before the block's last `\n`, found by `memchr::memrchr`), records by
/// `csv-core` (quotes, lone `\r`) for the rest. `line` is the 1-based
/// number of the line at `pos`.
struct CsvReader<R> {
    src: R,
    buf: Vec<u8>,
    /// Offset in the file of `buf[0]`.
    base: u64,
    pos: usize,
    filled: usize,
    /// End of the last whole line in `buf` (after its `\n`; `filled` at the
    /// end of the file): a line starting before it is entirely buffered.
    complete: usize,
    eof: bool,
    line: u64,
    core: csv_core::Reader,
    /// The fields of the last record read by `csv-core`, and their ends.
    fields: Vec<u8>,
    ends: Vec<usize>,
    nfields: usize,
}

impl<R: std::io::Read> CsvReader<R> {
    fn new(src: R, block: usize) -> Self {
        CsvReader {
            src,
            buf: vec![0; block.max(1)],
            base: 0,
            pos: 0,
            filled: 0,
            complete: 0,
            eof: false,
            line: 1,
            // The csv crate's defaults: ',' delimiter, '"' quotes (doubled
            // inside a quoted field), \r, \n or \r\n ending a record.
            core: csv_core::Reader::new(),
            fields: vec![0; 1024],
            ends: vec![0; 64],
            nfields: 0,
        }
    }

    /// Moves the unread bytes to the front and reads more (growing the buffer
    /// when it is full); false at the end of the file. O(bytes read + unread).
    fn refill(&mut self) -> std::io::Result<bool> {
        if self.eof {
            return Ok(false);
        }
        if self.pos > 0 {
            self.buf.copy_within(self.pos..self.filled, 0);
            self.filled -= self.pos;
            self.base += self.pos as u64;
            self.pos = 0;
        }
        if self.filled == self.buf.len() {
            self.buf.resize(2 * self.buf.len(), 0);
        }
        loop {
            match self.src.read(&mut self.buf[self.filled..]) {
                Ok(0) => {
                    self.eof = true;
                    self.complete = self.filled;
                    return Ok(false);
                }
                Ok(n) => {
                    self.filled += n;
                    self.complete =
                        memchr::memrchr(b'\n', &self.buf[..self.filled]).map_or(0, |i| i + 1);
                    return Ok(true);
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }

    /// Skips the line terminators before a record (blank lines, as the csv
    /// crate does); false when the file ends first.
    fn skip_blank_lines(&mut self) -> std::io::Result<bool> {
        loop {
            while self.pos < self.filled {
                match self.buf[self.pos] {
                    b'\n' => self.line += 1,
                    b'\r' => {}
                    _ => return Ok(true),
                }
                self.pos += 1;
            }
            if !self.refill()? {
                return Ok(false);
            }
        }
    }

    /// Reads until the line at `pos` is entirely buffered (or the file ends):
    /// afterwards `pos < complete` unless the file ended at `pos`.
    fn buffer_line(&mut self) -> std::io::Result<()> {
        while self.pos >= self.complete && self.refill()? {}
        Ok(())
    }

    /// Reads one record at `pos` with `csv-core` into `fields`/`ends`; false
    /// at the end of the file.
    fn read_record(&mut self) -> std::io::Result<bool> {
        use csv_core::ReadRecordResult as R;
        let (mut outlen, mut endlen) = (0, 0);
        loop {
            if self.pos == self.filled {
                self.refill()?; // empty input below tells csv-core the file ended
            }
            let input = &self.buf[self.pos..self.filled];
            let (res, nin, nout, nend) =
                self.core
                    .read_record(input, &mut self.fields[outlen..], &mut self.ends[endlen..]);
            self.line += memchr::memchr_iter(b'\n', &input[..nin]).count() as u64;
            self.pos += nin;
            outlen += nout;
            endlen += nend;
            match res {
                R::InputEmpty => {}
                R::OutputFull => {
                    let n = 2 * self.fields.len();
                    self.fields.resize(n, 0);
                }
                R::OutputEndsFull => {
                    let n = 2 * self.ends.len();
                    self.ends.resize(n, 0);
                }
                R::Record => {
                    self.nfields = endlen;
                    return Ok(true);
                }
                R::End => return Ok(false),
            }
        }
    }

    /// Field `i` of the last record read by [`Self::read_record`].
    fn field(&self, i: usize) -> &[u8] {
        let start = if i == 0 { 0 } else { self.ends[i - 1] };
        &self.fields[start..self.ends[i]]
    }

    /// The offset in the file of `pos`.
    fn offset(&self) -> u64 {
        self.base + self.pos as u64
    }
}

impl CsvReader<FileAt<'_>> {
    /// Moves to offset `at` of the file, the start of line `line` (between
    /// two records: `csv-core` goes on from its state after the last record,
    /// as after a line taken by the fast path). Keeps the buffer when it
    /// holds `at`.
    fn seek_to(&mut self, at: u64, line: u64) {
        if at >= self.base && at <= self.base + self.filled as u64 {
            self.pos = (at - self.base) as usize;
        } else {
            self.src.at = at;
            self.base = at;
            (self.pos, self.filled, self.complete, self.eof) = (0, 0, 0, false);
        }
        self.line = line;
    }
}

/// A regular file read from offset `at` on (each read seeks first), so that
/// the parallel reader's blocks and its sequential reader share one handle.
struct FileAt<'a> {
    file: &'a File,
    at: u64,
}

impl std::io::Read for FileAt<'_> {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        use std::io::Seek;
        let mut f = self.file;
        f.seek(std::io::SeekFrom::Start(self.at))?;
        let n = f.read(out)?;
        self.at += n as u64;
        Ok(n)
    }
}

/// Opens a CSV file and reads its header row (which must name the columns,
/// not hold numbers).
fn open_csv(path: &str, block: usize) -> CliResult<(CsvReader<File>, Vec<String>)> {
    let file = File::open(path).ctx(format!("cannot open data file {path}"))?;
    let mut rd = CsvReader::new(file, block);
    let header = read_header(path, &mut rd)?;
    Ok((rd, header))
}

/// Reads the header row of a CSV file at the start of `rd`.
fn read_header<R: std::io::Read>(path: &str, rd: &mut CsvReader<R>) -> CliResult<Vec<String>> {
    // csv-core skips the blank lines before the header and a UTF-8 BOM.
    let got = rd.read_record().ctx(format!("{path}: line 1"))?;
    if !got || (0..rd.nfields).all(|i| rd.field(i).iter().all(u8::is_ascii_whitespace)) {
        return Err(input(format!(
            "{path}: empty file (a header row is required)"
        )));
    }
    let header: Vec<String> = (0..rd.nfields)
        .map(|i| String::from_utf8_lossy(rd.field(i)).trim().to_string())
        .collect();
    if header
        .iter()
        .any(|h| !h.is_empty() && h.parse::<f64>().is_ok())
    {
        return Err(input(format!(
            "{path}: line 1 is not a header row (it contains numbers); the first row must name the columns"
        )));
    }
    check_unique(&format!("{}: header", shown(path)), &header)?;
    Ok(header)
}

/// The index of the time column `t`/`time` (any case) of a header.
pub(crate) fn time_column(header: &[String]) -> Option<usize> {
    header
        .iter()
        .position(|h| h.eq_ignore_ascii_case("t") || h.eq_ignore_ascii_case("time"))
}

/// Row count and time-column checks shared by the CSV and `.npy` readers.
pub(crate) struct RowCheck {
    ts: Option<f64>,
    t0: f64,
    t1: f64,
    t_last: f64,
    /// Rows accepted so far.
    pub(crate) rows: usize,
}

impl RowCheck {
    /// Checks for a file whose base period is `ts` (`None`: from the time column).
    pub(crate) fn new(ts: Option<f64>) -> Self {
        RowCheck {
            ts,
            t0: f64::NAN,
            t1: f64::NAN,
            t_last: f64::NAN,
            rows: 0,
        }
    }

    /// Whether the time column is read (no `--ts`).
    pub(crate) fn wants_time(&self) -> bool {
        self.ts.is_none()
    }

    /// Checks time `t` of the next row against the spacing of the first two;
    /// `at` locates the row in messages ("line 7", "row 5").
    #[inline]
    pub(crate) fn time(
        &mut self,
        path: &str,
        at: &dyn Display,
        column: &str,
        t: f64,
    ) -> CliResult<()> {
        match self.rows {
            0 => self.t0 = t,
            1 => self.t1 = t,
            rows => {
                let dt = self.t1 - self.t0;
                let expect = self.t0 + rows as f64 * dt;
                if (t - expect).abs() > 1e-6 * dt.abs().max(1e-300) + 1e-9 * expect.abs() {
                    return Err(input(format!(
                        "{path}: {at}, column '{column}': time {t} breaks the uniform spacing {dt} (expected {expect}); give --ts to ignore the time column"
                    )));
                }
            }
        }
        self.t_last = t;
        Ok(())
    }

    /// The row count and the base period once every row is read:
    /// `ts`, or from the time column (`has_time`).
    pub(crate) fn finish(&self, path: &str, has_time: bool) -> CliResult<(usize, f64)> {
        let rows = self.rows;
        if rows == 0 {
            return Err(input(format!("{path}: no data rows after the header")));
        }
        let ts = match self.ts {
            Some(ts) if ts.is_finite() && ts > 0.0 => ts,
            Some(ts) => return Err(input(format!("--ts {ts}: must be positive and finite"))),
            None => {
                if !has_time {
                    return Err(input(format!(
                        "{path}: no time column ('t' or 'time'): give the base period with --ts"
                    )));
                }
                if rows < 2 {
                    return Err(input(format!(
                        "{path}: one row: give the base period with --ts"
                    )));
                }
                let ts = (self.t_last - self.t0) / (rows - 1) as f64;
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
}

/// What the fast path does with each cell of a line: per header column,
/// its slot in the parsed values (or [`SKIP`]) and whether a blank cell is
/// accepted (as NaN).
struct Plan {
    cols: Vec<(usize, bool)>,
}

/// A column the fast path only skips.
const SKIP: usize = usize::MAX;

/// The index of the first `,`, `"`, `\r` or `\n` in `b[i..]` (or `b.len()`),
/// 8 bytes at a time (SWAR) while 8 are left. O(bytes skipped).
#[inline]
fn find_special(b: &[u8], mut i: usize) -> usize {
    const LO: u64 = 0x0101_0101_0101_0101;
    const HI: u64 = 0x8080_8080_8080_8080;
    // High bit of each zero byte of x (exact up to the first zero byte).
    let zero = |x: u64| x.wrapping_sub(LO) & !x & HI;
    while let Some(chunk) = b.get(i..i + 8) {
        let mut a = [0u8; 8];
        a.copy_from_slice(chunk);
        let v = u64::from_le_bytes(a);
        let hit = zero(v ^ (LO * u64::from(b',')))
            | zero(v ^ (LO * u64::from(b'"')))
            | zero(v ^ (LO * u64::from(b'\r')))
            | zero(v ^ (LO * u64::from(b'\n')));
        if hit != 0 {
            return i + (hit.trailing_zeros() / 8) as usize;
        }
        i += 8;
    }
    while i < b.len() && !matches!(b[i], b',' | b'"' | b'\r' | b'\n') {
        i += 1;
    }
    i
}

/// The powers of ten exactly representable as f64.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// The value of 8 ASCII digits read little-endian into `v` (SWAR).
#[inline]
fn parse_8digits(v: u64) -> u64 {
    const MASK: u64 = 0x0000_00FF_0000_00FF;
    const MUL1: u64 = 0x000F_4240_0000_0064; // 100 + (1000000 << 32)
    const MUL2: u64 = 0x0000_2710_0000_0001; // 1 + (10000 << 32)
    let v = v.wrapping_sub(0x3030_3030_3030_3030);
    let v = v.wrapping_mul(10).wrapping_add(v >> 8);
    let v1 = (v & MASK).wrapping_mul(MUL1);
    let v2 = ((v >> 16) & MASK).wrapping_mul(MUL2);
    u64::from((v1.wrapping_add(v2) >> 32) as u32)
}

/// 10^n for n < 8.
const POW10_U64: [u64; 8] = [1, 10, 100, 1_000, 10_000, 100_000, 1_000_000, 10_000_000];

/// Appends the run of ASCII digits at `b[i..]` to the decimal accumulator
/// `m` (wrapping: the caller discards more than 19 digits) and returns the
/// index after the run; 8 bytes at a time (SWAR) while 8 are left.
#[inline]
fn digit_run(b: &[u8], mut i: usize, m: &mut u64) -> usize {
    while let Some(chunk) = b.get(i..i + 8) {
        let mut a = [0u8; 8];
        a.copy_from_slice(chunk);
        let v = u64::from_le_bytes(a);
        // A byte's high bit is set iff it is not a digit: x = c ^ '0' is
        // 0..=9 for a digit, and x + 0x76 reaches 0x80 for x ≥ 10. A carry
        // out of a byte only reaches bytes after a non-digit.
        let x = v ^ 0x3030_3030_3030_3030;
        let non_digit = (x.wrapping_add(0x7676_7676_7676_7676) | x) & 0x8080_8080_8080_8080;
        if non_digit == 0 {
            *m = m.wrapping_mul(100_000_000).wrapping_add(parse_8digits(v));
            i += 8;
            continue;
        }
        let n = (non_digit.trailing_zeros() / 8) as usize;
        if n > 0 {
            // The n digits moved to the top, '0's before them.
            let w = (v << (8 * (8 - n))) | (0x3030_3030_3030_3030 >> (8 * n));
            *m = m.wrapping_mul(POW10_U64[n]).wrapping_add(parse_8digits(w));
        }
        return i + n;
    }
    while i < b.len() {
        let d = b[i].wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        *m = m.wrapping_mul(10).wrapping_add(u64::from(d));
        i += 1;
    }
    i
}

/// Parses the common numbers at the start of `b` quickly: an optional sign,
/// at most 19 digits with an optional '.', an optional exponent of at most
/// 3 digits, whose value m·10^e has m ≤ 2^53 and |e| ≤ 22, so that one
/// correctly rounded product or quotient of exact f64 values (Clinger's fast
/// path) is the nearest f64, as `str::parse` gives (and finite). Returns the
/// value and the bytes used, or `None` for anything else (then `fast-float2`
/// is used). O(digits).
#[inline]
fn parse_plain(b: &[u8]) -> Option<(f64, usize)> {
    let n = b.len();
    let (neg, start) = match b.first() {
        Some(b'-') => (true, 1),
        Some(b'+') => (false, 1),
        _ => (false, 0),
    };
    // The integer part, usually short: a byte at a time.
    let mut m: u64 = 0;
    let mut i = start;
    while i < n {
        let d = b[i].wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        m = m.wrapping_mul(10).wrapping_add(u64::from(d));
        i += 1;
    }
    let mut digits = i - start;
    let mut e: i64 = 0;
    if i < n && b[i] == b'.' {
        let from = i + 1;
        i = digit_run(b, from, &mut m);
        digits += i - from;
        e = -((i - from) as i64);
    }
    if digits == 0 || digits > 19 {
        return None;
    }
    if i < n && b[i] | 0x20 == b'e' {
        let mut j = i + 1;
        let eneg = match b.get(j) {
            Some(b'-') => {
                j += 1;
                true
            }
            Some(b'+') => {
                j += 1;
                false
            }
            _ => false,
        };
        let from = j;
        let mut x: i64 = 0;
        while j < n && j - from < 4 && b[j].is_ascii_digit() {
            x = 10 * x + i64::from(b[j] - b'0');
            j += 1;
        }
        if j == from || (j < n && b[j].is_ascii_digit()) {
            return None;
        }
        e += if eneg { -x } else { x };
        i = j;
    }
    if m > 1 << 53 || !(-22..=22).contains(&e) {
        return None;
    }
    let v = m as f64;
    let v = if e < 0 {
        v / POW10[(-e) as usize]
    } else {
        v * POW10[e as usize]
    };
    Some((if neg { -v } else { v }, i))
}

/// Parses the line at the start of `b` (which holds the whole line: up to
/// and with its `\n`, or to the end of the file) if its cells are plain
/// numbers: every needed cell a finite number (ASCII spaces and tabs around
/// it) or blank where allowed, the others free of quotes and carriage
/// returns, as many cells as the header, ended by `\n`, `\r\n` or the end of
/// the file. Returns the bytes of the line with its terminator; `None`
/// otherwise: the caller reads the line again with `csv-core` and
/// [`cell_value`], which accept or reject it with the exact message. O(line).
#[inline]
fn fast_line(b: &[u8], plan: &Plan, vals: &mut [f64]) -> Option<usize> {
    let width = plan.cols.len();
    let mut i = 0;
    for (c, &(slot, blank_ok)) in plan.cols.iter().enumerate() {
        if slot == SKIP {
            i = find_special(b, i);
        } else {
            while matches!(b.get(i), Some(b' ' | b'\t')) {
                i += 1;
            }
            let cell = &b[i..];
            let parsed = parse_plain(cell).or_else(|| {
                fast_float2::parse_partial::<f64, _>(cell)
                    .ok()
                    .filter(|(v, _)| v.is_finite())
            });
            match parsed {
                Some((v, len)) => {
                    vals[slot] = v;
                    i += len;
                    while matches!(b.get(i), Some(b' ' | b'\t')) {
                        i += 1;
                    }
                }
                // a blank cell if the cell ends here (checked below)
                None if blank_ok => vals[slot] = f64::NAN,
                None => return None,
            }
        }
        let last = c + 1 == width;
        match b.get(i) {
            Some(b',') if !last => i += 1,
            Some(b'\n') if last => return Some(i + 1),
            Some(b'\r') if last && b.get(i + 1) == Some(&b'\n') => return Some(i + 2),
            None if last => return Some(i),
            _ => return None,
        }
    }
    None
}

/// What [`scan_csv`] knows of a CSV file once its header is read.
struct Layout<'a> {
    path: &'a str,
    header: Vec<String>,
    wanted: &'a [&'a String],
    may_be_empty: std::ops::Range<usize>,
    /// Header positions of the `wanted` columns.
    idx: Vec<usize>,
    /// The time column, if any.
    time_col: Option<usize>,
    /// The time column when it is read (no `--ts`).
    read_time: Option<usize>,
    /// The fast path's plan; the slot in its values of each wanted column
    /// and of the time column read; values per line.
    plan: Plan,
    from: Vec<usize>,
    time_slot: Option<usize>,
    needed: usize,
}

impl<'a> Layout<'a> {
    fn new(
        path: &'a str,
        header: Vec<String>,
        wanted: &'a [&'a String],
        may_be_empty: std::ops::Range<usize>,
        wants_time: bool,
    ) -> CliResult<Self> {
        let idx = column_indices(path, &header, wanted)?;
        let time_col = time_column(&header);
        let read_time = time_col.filter(|_| wants_time);
        // The fast path parses each needed column once.
        let mut plan = Plan {
            cols: vec![(SKIP, true); header.len()],
        };
        let mut needed = 0;
        let mut need = |c: usize, blank_ok: bool, plan: &mut Plan| -> usize {
            let col = &mut plan.cols[c];
            if col.0 == SKIP {
                col.0 = needed;
                needed += 1;
            }
            col.1 &= blank_ok;
            col.0
        };
        let from: Vec<usize> = idx
            .iter()
            .enumerate()
            .map(|(j, &c)| need(c, may_be_empty.contains(&j), &mut plan))
            .collect();
        let time_slot = read_time.map(|c| need(c, false, &mut plan));
        Ok(Layout {
            path,
            header,
            wanted,
            may_be_empty,
            idx,
            time_col,
            read_time,
            plan,
            from,
            time_slot,
            needed,
        })
    }
}

/// Where the rows go, in file order: the row count and time-column checks,
/// then the caller's `visit`.
struct Sink<V> {
    check: RowCheck,
    visit: V,
}

impl<V: FnMut(&[f64]) -> CliResult<bool>> Sink<V> {
    /// Checks and visits the row of line `line` with time `t`; false: stop.
    #[inline]
    fn row(&mut self, lay: &Layout, row: &[f64], line: u64, t: f64) -> CliResult<bool> {
        if let Some(tc) = lay.read_time {
            self.check
                .time(lay.path, &format_args!("line {line}"), &lay.header[tc], t)?;
        }
        self.check.rows += 1;
        (self.visit)(row)
    }
}

/// [`scan_rows`] on a CSV file; `mode.fast` false reads every line with
/// `csv-core` (the reference the fast path is tested against), `mode.threads`
/// chooses between [`scan_sequential`] and [`scan_parallel`] (the same rows,
/// checks and messages).
fn scan_csv(
    path: &str,
    wanted: &[&String],
    may_be_empty: std::ops::Range<usize>,
    ts: Option<f64>,
    mode: Mode,
    visit: impl FnMut(&[f64]) -> CliResult<bool>,
) -> CliResult<(usize, f64)> {
    let file = File::open(path).ctx(format!("cannot open data file {path}"))?;
    let meta = file.metadata().ok();
    let regular = meta.as_ref().is_some_and(std::fs::Metadata::is_file);
    let threads = match mode.threads {
        Some(n) => n,
        None if meta.is_some_and(|m| m.len() >= MIN_BLOCKS * mode.block as u64) => {
            std::thread::available_parallelism()
                .map_or(1, std::num::NonZero::get)
                .min(MAX_THREADS)
        }
        None => 1,
    };
    let mut sink = Sink {
        check: RowCheck::new(ts),
        visit,
    };
    let wants_time = sink.check.wants_time();
    // Blocks are read at offsets: a regular file only.
    let has_time = if mode.fast && threads >= 2 && regular {
        // A small buffer: it holds the start of the first block, and the
        // lines the fast path does not take.
        let mut rd = CsvReader::new(FileAt { file: &file, at: 0 }, mode.block.min(1 << 16));
        let header = read_header(path, &mut rd)?;
        let lay = Layout::new(path, header, wanted, may_be_empty, wants_time)?;
        scan_parallel(rd, &lay, threads, mode.block, &mut sink)?;
        lay.time_col.is_some()
    } else {
        let mut rd = CsvReader::new(&file, mode.block);
        let header = read_header(path, &mut rd)?;
        let lay = Layout::new(path, header, wanted, may_be_empty, wants_time)?;
        scan_sequential(&mut rd, &lay, mode.fast, &mut sink)?;
        lay.time_col.is_some()
    };
    sink.check.finish(path, has_time)
}

/// What [`read_one`] found.
enum Step {
    /// The end of the file.
    End,
    /// A blank record (`""`), skipped.
    Blank,
    /// A row, in `row`: its line and its time (NaN unless read).
    Row(u64, f64),
}

/// Reads the record at `rd.pos` (after [`CsvReader::skip_blank_lines`]):
/// through the fast path if `fast` and it takes the line (its values in
/// `vals`, then `row`), else through `csv-core` and [`cell_value`] with
/// their messages. O(line).
fn read_one<R: std::io::Read>(
    rd: &mut CsvReader<R>,
    lay: &Layout,
    fast: bool,
    vals: &mut [f64],
    row: &mut [f64],
) -> CliResult<Step> {
    let path = lay.path;
    let line = rd.line;
    if fast {
        rd.buffer_line()
            .map_err(|e| input(format!("{path}: line {line}: {e}")))?;
        if let Some(len) = fast_line(&rd.buf[rd.pos..rd.complete], &lay.plan, vals) {
            for (r, &s) in row.iter_mut().zip(&lay.from) {
                *r = vals[s];
            }
            let t = lay.time_slot.map_or(f64::NAN, |s| vals[s]);
            rd.pos += len;
            rd.line += 1;
            return Ok(Step::Row(line, t));
        }
    }
    // csv-core and the cell checks, with their messages
    match rd.read_record() {
        Ok(true) => {}
        Ok(false) => return Ok(Step::End),
        Err(e) => return Err(input(format!("{path}: line {line}: {e}"))),
    }
    if rd.nfields == 1 && rd.field(0).is_empty() {
        return Ok(Step::Blank); // a blank record ("")
    }
    let width = lay.header.len();
    if rd.nfields != width {
        return Err(input(format!(
            "{path}: line {line}: {} cells, the header has {width} (ragged row)",
            rd.nfields
        )));
    }
    for (j, &c) in lay.idx.iter().enumerate() {
        let allow_empty = lay.may_be_empty.contains(&j);
        row[j] = cell_value(path, line, lay.wanted[j], rd.field(c), allow_empty)?;
    }
    let mut t = f64::NAN;
    if let Some(tc) = lay.read_time {
        t = cell_value(path, line, &lay.header[tc], rd.field(tc), false)?;
    }
    Ok(Step::Row(line, t))
}

/// Reads the rows after the header on the calling thread, line by line.
fn scan_sequential<R: std::io::Read, V: FnMut(&[f64]) -> CliResult<bool>>(
    rd: &mut CsvReader<R>,
    lay: &Layout,
    fast: bool,
    sink: &mut Sink<V>,
) -> CliResult<()> {
    let mut vals = vec![0.0; lay.needed];
    let mut row = vec![0.0; lay.wanted.len()];
    loop {
        match rd.skip_blank_lines() {
            Ok(true) => {}
            Ok(false) => return Ok(()),
            Err(e) => return Err(input(format!("{}: line {}: {e}", lay.path, rd.line))),
        }
        match read_one(rd, lay, fast, &mut vals, &mut row)? {
            Step::End => return Ok(()),
            Step::Blank => {}
            Step::Row(line, t) => {
                if !sink.row(lay, &row, line, t)? {
                    return Ok(());
                }
            }
        }
    }
}

/// A block of whole lines of a CSV file for [`scan_parallel`], and what the
/// fast path made of it ([`parse_block`]). Its buffers are reused.
#[derive(Default)]
struct Block {
    /// Its number in the file (0, 1, …).
    seq: u64,
    /// Offset in the file of its first byte, the start of a line.
    start: u64,
    /// The bytes `raw[..len]`: whole lines, each ended by `\n` except the
    /// file's last.
    raw: Vec<u8>,
    len: usize,
    /// Whether [`parse_block`] has run.
    parsed: bool,
    /// The values of the rows the fast path took, `rows` × `needed`.
    vals: Vec<f64>,
    rows: usize,
    /// (r, n): n blank lines before row r (r = `rows`: before the `stop`
    /// line), ascending.
    gaps: Vec<(usize, u64)>,
    /// Line ends (`\n`) in `raw[..stop]` (`raw[..len]` without a stop).
    newlines: u64,
    /// The start (in `raw`) of the first line the fast path does not take:
    /// the rest of the block is to be read by `csv-core`.
    stop: Option<usize>,
}

impl Block {
    /// Line ends before the block's first row or its stop line.
    fn lead(&self) -> u64 {
        match self.gaps.first() {
            Some(&(0, n)) => n,
            _ => 0,
        }
    }
}

/// Parses a block through the fast path (the loop of [`scan_sequential`]
/// without `csv-core`: blank lines skipped, then [`fast_line`]) up to its
/// end or the first line the fast path does not take. O(block); no
/// allocation once the block's buffers have grown.
fn parse_block(blk: &mut Block, plan: &Plan, needed: usize) {
    let b = &blk.raw[..blk.len];
    blk.gaps.clear();
    blk.stop = None;
    let (mut i, mut rows, mut newlines) = (0, 0, 0u64);
    loop {
        let mut blank = 0;
        while let Some(&c) = b.get(i) {
            match c {
                b'\n' => blank += 1,
                b'\r' => {}
                _ => break,
            }
            i += 1;
        }
        newlines += blank;
        if i == b.len() {
            break;
        }
        if blank > 0 {
            blk.gaps.push((rows, blank));
        }
        let at = rows * needed;
        if blk.vals.len() < at + needed {
            let n = (2 * blk.vals.len()).max(at + needed).max(1024);
            blk.vals.resize(n, 0.0);
        }
        match fast_line(&b[i..], plan, &mut blk.vals[at..at + needed]) {
            Some(len) if len > 0 => {
                i += len;
                newlines += u64::from(b[i - 1] == b'\n');
                rows += 1;
            }
            _ => {
                blk.stop = Some(i);
                break;
            }
        }
    }
    blk.rows = rows;
    blk.newlines = newlines;
    blk.parsed = true;
}

/// Cuts a CSV file into blocks of whole lines of about `block` bytes (the
/// bytes up to the last `\n` once `block` bytes are read) for
/// [`scan_parallel`].
struct Chunker<'a> {
    src: FileAt<'a>,
    /// The bytes read after the previous block (a part of a line).
    carry: Vec<u8>,
    /// Offset in the file of the next block.
    next: u64,
    block: usize,
    /// The largest block: a longer line stops the cutting.
    limit: usize,
    eof: bool,
    /// Where the cutting stopped before the end of the file (a line longer
    /// than `limit`, or a read error): the rest is read sequentially (which
    /// reports the error with its line).
    stopped: Option<u64>,
}

impl Chunker<'_> {
    /// Fills `blk` with the next block; false when there is none (the end of
    /// the file, or `stopped`). O(block).
    fn fill(&mut self, blk: &mut Block) -> bool {
        if self.stopped.is_some() || (self.eof && self.carry.is_empty()) {
            return false;
        }
        let mut len = self.carry.len();
        if blk.raw.len() < len.max(self.block) {
            blk.raw.resize(len.max(self.block), 0);
        }
        blk.raw[..len].copy_from_slice(&self.carry);
        self.carry.clear();
        // No `\n` in raw[..searched] (the carry has none).
        let mut searched = len;
        while !self.eof {
            if len >= self.block {
                if let Some(k) = memchr::memrchr(b'\n', &blk.raw[searched..len]) {
                    let cut = searched + k + 1;
                    self.carry.extend_from_slice(&blk.raw[cut..len]);
                    len = cut;
                    break;
                }
                searched = len;
                if len >= self.limit {
                    self.stopped = Some(self.next);
                    return false;
                }
            }
            if len == blk.raw.len() {
                blk.raw.resize(2 * len, 0);
            }
            match std::io::Read::read(&mut self.src, &mut blk.raw[len..]) {
                Ok(0) => self.eof = true,
                Ok(n) => len += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(_) => {
                    self.stopped = Some(self.next);
                    return false;
                }
            }
        }
        if len == 0 {
            return false;
        }
        blk.start = self.next;
        blk.len = len;
        blk.parsed = false;
        self.next += len as u64;
        true
    }
}

/// The blocks between the calling thread and the helpers of
/// [`scan_parallel`].
#[derive(Default)]
struct Queue {
    /// Read, not yet parsed, in file order.
    todo: std::collections::VecDeque<Block>,
    /// Parsed, not yet taken.
    done: Vec<Block>,
    /// The helpers are to stop.
    quit: bool,
    /// A helper panicked (its block is lost).
    failed: bool,
}

#[derive(Default)]
struct Shared {
    queue: std::sync::Mutex<Queue>,
    /// A block to parse, or `quit`.
    work: std::sync::Condvar,
    /// A block parsed, or `failed`.
    done: std::sync::Condvar,
}

impl Shared {
    fn lock(&self) -> std::sync::MutexGuard<'_, Queue> {
        self.queue
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Hands a block read to the parsers.
    fn push(&self, blk: Block) {
        self.lock().todo.push_back(blk);
        self.work.notify_one();
    }

    /// Takes block `seq` (read, not yet taken), parsed or not. With `help`,
    /// parses the oldest unclaimed block while `seq` is being parsed by a
    /// helper.
    fn take(&self, seq: u64, help: Option<(&Plan, usize)>) -> Block {
        let mut q = self.lock();
        loop {
            if let Some(k) = q.done.iter().position(|b| b.seq == seq) {
                return q.done.swap_remove(k);
            }
            if q.todo.front().is_some_and(|b| b.seq == seq)
                && let Some(b) = q.todo.pop_front()
            {
                return b;
            }
            assert!(!q.failed, "a CSV parsing thread panicked");
            if let Some((plan, needed)) = help
                && let Some(mut b) = q.todo.pop_front()
            {
                drop(q);
                parse_block(&mut b, plan, needed);
                q = self.lock();
                q.done.push(b);
                continue;
            }
            q = self
                .done
                .wait(q)
                .unwrap_or_else(std::sync::PoisonError::into_inner);
        }
    }

    /// A helper: parses the blocks it takes from `todo` until `quit`.
    fn help(&self, plan: &Plan, needed: usize) {
        // Tells the calling thread if this one panics (it would wait forever).
        struct Failed<'s>(&'s Shared);
        impl Drop for Failed<'_> {
            fn drop(&mut self) {
                if std::thread::panicking() {
                    self.0.lock().failed = true;
                    self.0.done.notify_all();
                }
            }
        }
        let _failed = Failed(self);
        let mut q = self.lock();
        loop {
            if q.quit {
                return;
            }
            if let Some(mut b) = q.todo.pop_front() {
                drop(q);
                parse_block(&mut b, plan, needed);
                q = self.lock();
                q.done.push(b);
                self.done.notify_one();
            } else {
                q = self
                    .work
                    .wait(q)
                    .unwrap_or_else(std::sync::PoisonError::into_inner);
            }
        }
    }
}

/// Stops the helpers when dropped (at the end of the scan or on an error).
struct Quit<'s>(&'s Shared);

impl Drop for Quit<'_> {
    fn drop(&mut self) {
        self.0.lock().quit = true;
        self.0.work.notify_all();
    }
}

/// What the rows of a block left to do.
enum After {
    /// `visit` asked to stop.
    Stop,
    /// Go on with the next block, which starts at this line.
    Next(u64),
    /// Read sequentially from this offset, the start of this line.
    Sequential(u64, u64),
}

/// Visits the rows of a parsed block whose first line is `line`.
fn consume<V: FnMut(&[f64]) -> CliResult<bool>>(
    blk: &Block,
    line: u64,
    lay: &Layout,
    sink: &mut Sink<V>,
    row: &mut [f64],
) -> CliResult<After> {
    let needed = lay.needed;
    let mut gaps = blk.gaps.iter().peekable();
    let mut newlines = 0;
    for r in 0..blk.rows {
        if let Some(&&(g, n)) = gaps.peek()
            && g == r
        {
            newlines += n;
            gaps.next();
        }
        let v = &blk.vals[r * needed..(r + 1) * needed];
        for (x, &s) in row.iter_mut().zip(&lay.from) {
            *x = v[s];
        }
        let t = lay.time_slot.map_or(f64::NAN, |s| v[s]);
        if !sink.row(lay, row, line + newlines, t)? {
            return Ok(After::Stop);
        }
        newlines += 1;
    }
    Ok(match blk.stop {
        Some(q) => After::Sequential(blk.start + q as u64, line + blk.newlines),
        None => After::Next(line + blk.newlines),
    })
}

/// Reads the rows after the header with `threads` parsers: the calling
/// thread cuts the file into blocks of whole lines ([`Chunker`]), at most
/// 2 × `threads` of them in flight; `threads` − 1 helpers and the calling
/// thread (while the next block is being parsed) run the fast path on them
/// ([`parse_block`]); the calling thread visits the rows in file order,
/// counting lines from the blocks' line ends.
///
/// A block the fast path does not take to its end is read from its stop
/// line on by `rd` (the sequential reader: `csv-core`, [`cell_value`] and
/// their messages) until `rd` is between two records at the start of a
/// later block: the fast path's rows of that block are then the
/// sequential reader's, and the blocks take over again (blocks passed over
/// are dropped). So the rows, checks and messages are those of
/// [`scan_sequential`]. Memory O(threads × block + longest line).
fn scan_parallel<V: FnMut(&[f64]) -> CliResult<bool>>(
    mut rd: CsvReader<FileAt<'_>>,
    lay: &Layout,
    threads: usize,
    block: usize,
    sink: &mut Sink<V>,
) -> CliResult<()> {
    let block = block.max(1);
    let mut chunker = Chunker {
        src: FileAt {
            file: rd.src.file,
            at: rd.src.at,
        },
        carry: rd.buf[rd.pos..rd.filled].to_vec(),
        next: rd.offset(),
        block,
        limit: block.saturating_mul(16).max(1 << 12),
        eof: rd.eof,
        stopped: None,
    };
    let shared = Shared::default();
    let (plan, needed) = (&lay.plan, lay.needed);
    std::thread::scope(|s| {
        for _ in 1..threads {
            // Without a helper the calling thread parses every block.
            let _ = std::thread::Builder::new()
                .name("lifted-csv".into())
                .spawn_scoped(s, || shared.help(plan, needed));
        }
        let _quit = Quit(&shared);
        let in_flight = 2 * threads.max(1);
        let mut row = vec![0.0; lay.wanted.len()];
        let mut vals = vec![0.0; needed];
        let mut free: Vec<Block> = Vec::new();
        // Starts of the blocks read and not yet taken; the first is block `taken`.
        let mut pending = std::collections::VecDeque::new();
        let (mut read, mut taken) = (0u64, 0u64);
        // A block to visit next (after switching back from `rd`).
        let mut ready: Option<Block> = None;
        // Some(line of the next block's start): visiting blocks; None:
        // reading with `rd`.
        let mut line = Some(rd.line);
        loop {
            while pending.len() < in_flight {
                let mut blk = free.pop().unwrap_or_default();
                if !chunker.fill(&mut blk) {
                    free.push(blk);
                    break;
                }
                blk.seq = read;
                read += 1;
                pending.push_back(blk.start);
                shared.push(blk);
            }
            if let Some(at) = line {
                let mut blk = match ready.take() {
                    Some(blk) => blk,
                    None if pending.pop_front().is_some() => {
                        taken += 1;
                        shared.take(taken - 1, Some((plan, needed)))
                    }
                    None => match chunker.stopped {
                        Some(next) => {
                            rd.seek_to(next, at);
                            line = None;
                            continue;
                        }
                        None => return Ok(()), // the end of the file
                    },
                };
                if !blk.parsed {
                    parse_block(&mut blk, plan, needed);
                }
                let after = consume(&blk, at, lay, sink, &mut row)?;
                free.push(blk);
                match after {
                    After::Stop => return Ok(()),
                    After::Next(next) => line = Some(next),
                    After::Sequential(offset, at) => {
                        rd.seek_to(offset, at);
                        line = None;
                    }
                }
                continue;
            }
            // One record with `rd`, the blocks it passes dropped; at a block
            // start between two records (before or among blank lines), the
            // blocks take over.
            let p0 = rd.offset();
            let more = rd
                .skip_blank_lines()
                .map_err(|e| input(format!("{}: line {}: {e}", lay.path, rd.line)))?;
            let p1 = rd.offset();
            while let Some(&start) = pending.front() {
                if start > p1 {
                    break;
                }
                pending.pop_front();
                taken += 1;
                let mut blk = shared.take(taken - 1, None);
                if start >= p0 {
                    if !blk.parsed {
                        parse_block(&mut blk, plan, needed);
                    }
                    if blk.rows > 0 || blk.stop.is_some() {
                        // Its first row or stop line is at p1, line rd.line.
                        line = Some(rd.line - blk.lead());
                        ready = Some(blk);
                        break;
                    }
                }
                free.push(blk);
            }
            if line.is_some() {
                continue;
            }
            if !more {
                return Ok(());
            }
            match read_one(&mut rd, lay, true, &mut vals, &mut row)? {
                Step::End => return Ok(()),
                Step::Blank => {}
                Step::Row(at, t) => {
                    #[cfg(test)]
                    tests::SEQUENTIAL_ROWS.with(|n| n.set(n.get() + 1));
                    if !sink.row(lay, &row, at, t)? {
                        return Ok(());
                    }
                }
            }
        }
    })
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
/// declared period, checks that the samples follow it. Messages locate
/// sample k by its CSV line (k + 2) or, for a `.npy` file (`npy`), by its
/// row k. O(rows).
fn sampling(
    path: &str,
    name: &str,
    col: &[f64],
    declared: Option<usize>,
    npy: bool,
) -> CliResult<(usize, usize)> {
    let at = |k: usize| {
        if npy {
            format!("row {k}")
        } else {
            format!("line {}", k + 2)
        }
    };
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
            "{path}: {}, column '{name}': first sample is missing (period {period})",
            at(first - 1)
        )));
    }
    for (k, v) in col.iter().enumerate() {
        let sampled = k % period == first;
        if sampled && v.is_nan() {
            return Err(input(format!(
                "{path}: {}, column '{name}': empty cell at a sampling instant of period {period}",
                at(k)
            )));
        }
        if !sampled && !v.is_nan() {
            return Err(input(format!(
                "{path}: {}, column '{name}': value between samples of period {period} (the cell must be empty)",
                at(k)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh file under the temp dir with `bytes`.
    fn file(name: &str, bytes: &[u8]) -> String {
        let dir = std::env::temp_dir().join(format!("lifted-table-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p.display().to_string()
    }

    /// xorshift64*: a small deterministic generator for the random files.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
        }
        fn below(&mut self, n: u64) -> u64 {
            self.next() % n
        }
        fn chance(&mut self, per_mille: u64) -> bool {
            self.below(1000) < per_mille
        }
    }

    /// What a scan gives: rows, base period and every visited row (bit
    /// patterns, so NaN compares), or the error message.
    type Scan = Result<(usize, u64, Vec<Vec<u64>>), String>;

    fn run(
        path: &str,
        wanted: &[&str],
        empty: std::ops::Range<usize>,
        ts: Option<f64>,
        mode: Option<Mode>,
    ) -> Scan {
        let wanted: Vec<String> = wanted.iter().map(|s| s.to_string()).collect();
        let w: Vec<&String> = wanted.iter().collect();
        let mut seen = Vec::new();
        let visit = |row: &[f64]| {
            seen.push(row.iter().map(|v| v.to_bits()).collect());
            Ok(true)
        };
        let r = match mode {
            Some(mode) => scan_csv(path, &w, empty, ts, mode, visit),
            None => legacy_scan(path, &w, empty, ts, visit),
        };
        r.map(|(n, ts)| (n, ts.to_bits(), seen))
            .map_err(|e| e.to_string())
    }

    /// The reader before the fast path (the csv crate's `ByteRecord` and
    /// `str::parse`), kept to check the new one against it.
    fn legacy_scan(
        path: &str,
        wanted: &[&String],
        may_be_empty: std::ops::Range<usize>,
        ts: Option<f64>,
        mut visit: impl FnMut(&[f64]) -> CliResult<bool>,
    ) -> CliResult<(usize, f64)> {
        let file = File::open(path).ctx(format!("cannot open data file {path}"))?;
        let mut rd = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .from_reader(std::io::BufReader::new(file));
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
        let idx = column_indices(path, &header, wanted)?;
        let time_col = time_column(&header);
        let width = header.len();
        let mut row = vec![0.0; wanted.len()];
        let mut check = RowCheck::new(ts);
        let mut line = 1u64;
        loop {
            match rd.read_byte_record(&mut rec) {
                Ok(true) => {}
                Ok(false) => break,
                Err(e) => return Err(input(format!("{path}: line {}: {e}", line + 1))),
            }
            line = rec.position().map_or(line + 1, |p| p.line());
            if rec.len() == 1 && rec.get(0).is_some_and(<[u8]>::is_empty) {
                continue;
            }
            if rec.len() != width {
                return Err(input(format!(
                    "{path}: line {line}: {} cells, the header has {width} (ragged row)",
                    rec.len()
                )));
            }
            for (j, &c) in idx.iter().enumerate() {
                row[j] = cell_value(path, line, wanted[j], &rec[c], may_be_empty.contains(&j))?;
            }
            if let (Some(tc), None) = (time_col, ts) {
                let t = cell_value(path, line, &header[tc], &rec[tc], false)?;
                check.time(path, &format_args!("line {line}"), &header[tc], t)?;
            }
            check.rows += 1;
            if !visit(&row)? {
                break;
            }
        }
        check.finish(path, time_col.is_some())
    }

    /// A random number as CSV text in one of the forms people write.
    fn number(rng: &mut Rng) -> String {
        let v = (rng.next() as f64 / u64::MAX as f64 - 0.5) * 10f64.powi(rng.below(9) as i32 - 4);
        match rng.below(9) {
            0 => format!("{}", rng.below(2000) as i64 - 1000),
            1 => format!("{v}"),
            2 => format!("{v:e}"),
            3 => format!("{v:E}"),
            4 => format!("{v:.3}"),
            5 => format!("{:+.17e}", v),
            6 => format!("{v:.25}"),
            7 => format!("{}e{}", rng.below(100), rng.below(40) as i64 - 20),
            _ => format!("{v:.1}"),
        }
    }

    /// A random number, padded with spaces or tabs now and then.
    fn padded(rng: &mut Rng) -> String {
        let s = number(rng);
        pad(rng, s)
    }

    /// Pads a cell with spaces or tabs now and then.
    fn pad(rng: &mut Rng, s: String) -> String {
        match rng.below(20) {
            0 => format!(" {s}"),
            1 => format!("{s}  "),
            2 => format!("\t{s} "),
            _ => s,
        }
    }

    /// A random CSV text: header t,u1,x,y1,y2 (x unread), `rows` rows,
    /// uniform time; `bad` per mille of the lines carry an oddity (quotes,
    /// blank lines, CR, bad cells, ragged rows).
    fn random_csv(rng: &mut Rng, rows: usize, crlf: u64, bad: u64) -> Vec<u8> {
        let mut out = String::from("t,u1,x,y1,y2\n");
        for k in 0..rows {
            let eol = if rng.chance(crlf) { "\r\n" } else { "\n" };
            let t = pad(rng, format!("{}", k as f64 * 0.25));
            let u = padded(rng);
            let x = if rng.chance(100) {
                "note".to_string()
            } else {
                number(rng)
            };
            let y1 = if rng.chance(50) {
                String::new()
            } else {
                padded(rng)
            };
            let y2 = padded(rng);
            let mut line = format!("{t},{u},{x},{y1},{y2}");
            if rng.chance(bad) {
                line = match rng.below(15) {
                    14 => format!("{t},{u},{x}\r{x},{y1},{y2}"),
                    0 => format!("{t},\"{u}\",{x},{y1},{y2}"),
                    1 => format!("{t},{u},\"a,\"\"b\"\"\nc\",{y1},{y2}"),
                    2 => format!("\n{line}"),
                    3 => format!("\r\n\r\n{line}"),
                    4 => format!("{t},{u},{x},{y1}\r{y2}"),
                    5 => format!("{t},abc,{x},{y1},{y2}"),
                    6 => format!("{t},{u},{x},nan,{y2}"),
                    7 => format!("{t},,{x},{y1},{y2}"),
                    8 => format!("{t},{u},{x},{y1}"),
                    9 => format!("{line},9"),
                    10 => format!("{t},{u},{x},{y1},1e999"),
                    11 => format!("{},{u},{x},{y1},{y2}", k as f64 * 0.25 + 1.0),
                    12 => format!("{t},{u},{x},{y1},\u{a0}1.5"),
                    _ => format!("{t},{u},\"{x}\",\"\",{y2}"),
                };
            }
            out += &line;
            out += eol;
        }
        if rng.chance(500) {
            out.pop(); // no final newline
        }
        out.into_bytes()
    }

    /// The fast path against `csv-core` alone, with small blocks so lines
    /// and quoted fields straddle refills, and against the old reader.
    #[test]
    fn fast_path_equals_the_csv_parser_on_random_files() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut errors = 0;
        for case in 0..400 {
            let rows = 1 + rng.below(60) as usize;
            let crlf = [0, 1000, 300][case % 3];
            let bad = [0, 20, 100][(case / 3) % 3];
            let text = random_csv(&mut rng, rows, crlf, bad);
            let path = file(&format!("r{case}.csv"), &text);
            let cols = ["u1", "y1", "y2"];
            let ts = if rng.chance(200) { Some(0.25) } else { None };
            let reference = run(
                &path,
                &cols,
                1..3,
                ts,
                Some(Mode {
                    fast: false,
                    block: BLOCK,
                    threads: Some(1),
                }),
            );
            for block in [BLOCK, 1, 7, 64] {
                let fast = run(
                    &path,
                    &cols,
                    1..3,
                    ts,
                    Some(Mode {
                        fast: true,
                        block,
                        threads: Some(1),
                    }),
                );
                assert_eq!(
                    fast,
                    reference,
                    "case {case}, block {block}: {}",
                    String::from_utf8_lossy(&text)
                );
            }
            errors += reference.is_err() as usize;
            // The old reader: the same values; the same messages up to the
            // line number (it counted the lines of CRLF files and blank
            // lines wrongly) or exactly for LF files without blank lines.
            let legacy = run(&path, &cols, 1..3, ts, None);
            let plain = !text.contains(&b'\r') && !text.windows(2).any(|w| w == b"\n\n");
            match (&reference, &legacy) {
                (Ok(a), Ok(b)) => assert_eq!(a, b, "case {case}"),
                (Err(a), Err(b)) if plain => assert_eq!(a, b, "case {case}"),
                (Err(a), Err(b)) => {
                    let mask = |s: &str| {
                        let mut out = String::new();
                        let mut it = s.split("line ");
                        out += it.next().unwrap_or("");
                        for part in it {
                            out += "line #";
                            out += part.trim_start_matches(|c: char| c.is_ascii_digit());
                        }
                        out
                    };
                    assert_eq!(mask(a), mask(b), "case {case}");
                }
                _ => panic!("case {case}: {reference:?} vs {legacy:?}"),
            }
        }
        // Both kinds of file were drawn.
        assert!(errors > 50 && errors < 350, "{errors}");
    }

    /// Lines longer than the block grow the buffer.
    #[test]
    fn long_lines_grow_the_buffer() {
        let mut text = String::from("t,u1,y1,");
        let filler: Vec<String> = (0..500).map(|i| format!("c{i}")).collect();
        text += &filler.join(",");
        text += "\n";
        for k in 0..20 {
            text += &format!("{k},{},{}", k * 2, k * 3);
            for _ in 0..500 {
                text += ",123456.789";
            }
            text += "\n";
        }
        let path = file("long.csv", text.as_bytes());
        for block in [BLOCK, 16, 1000] {
            let r = run(
                &path,
                &["u1", "y1"],
                1..2,
                None,
                Some(Mode {
                    fast: true,
                    block,
                    threads: Some(1),
                }),
            )
            .unwrap();
            assert_eq!(r.0, 20);
            assert_eq!(f64::from_bits(r.1), 1.0);
            assert_eq!(f64::from_bits(r.2[19][1]), 57.0);
        }
    }

    /// The float grammar of the fast path is that of `str::parse::<f64>`
    /// (no more: anything it refuses goes to `str::parse`).
    #[test]
    fn fast_float_accepts_what_str_parse_accepts() {
        let cases = [
            "1",
            "-2.5e-3",
            "1E5",
            "+3",
            "1.",
            ".5",
            "-.5",
            "1e+5",
            "1e-5",
            "0",
            "-0",
            "00012",
            "1.7976931348623157e308",
            "2.2250738585072014e-308",
            "4.9e-324",
            "1e-400",
            "1e400",
            "0.1000000000000000055511151231257827",
            "123456789012345678901234567890",
            "inf",
            "-inf",
            "Infinity",
            "nan",
            "NaN",
            "e5",
            "1e",
            "1e+",
            ".",
            "-",
            "+",
            "1.5.2",
            "0x10",
            "1_000",
            "1,5",
            "--1",
            "1e5e5",
            " 1",
            "1 ",
            "",
            "١",
            "1d5",
            "infinit",
        ];
        for c in cases {
            let std = c.parse::<f64>();
            let fast = fast_float2::parse::<f64, _>(c);
            match (std, fast) {
                (Ok(a), Ok(b)) => assert!(
                    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                    "{c}"
                ),
                (Err(_), Err(_)) => {}
                (a, b) => panic!("{c}: str::parse {a:?}, fast-float2 {b:?}"),
            }
        }
        // And on many random numbers, bit for bit.
        let mut rng = Rng(7);
        for _ in 0..100_000 {
            let s = number(&mut rng);
            assert_eq!(
                s.parse::<f64>().map(f64::to_bits).ok(),
                fast_float2::parse::<f64, _>(&s).map(f64::to_bits).ok(),
                "{s}"
            );
        }
    }

    /// The quick parser gives `str::parse`'s value for the bytes it takes,
    /// takes the whole number, and takes the common forms.
    #[test]
    fn parse_plain_is_str_parse() {
        let mut rng = Rng(11);
        let mut taken = 0;
        let ends = [",", "\n", "\r\n", "", " ", "e", "e+", "x", ".", "5"];
        for k in 0..200_000 {
            let s = number(&mut rng) + ends[k % ends.len()];
            if let Some((v, len)) = parse_plain(s.as_bytes()) {
                taken += 1;
                assert_eq!(
                    s[..len].parse::<f64>().map(f64::to_bits),
                    Ok(v.to_bits()),
                    "{s}"
                );
                let (w, flen) = fast_float2::parse_partial::<f64, _>(&s).unwrap();
                assert_eq!((w.to_bits(), flen), (v.to_bits(), len), "{s}");
            }
        }
        assert!(taken > 100_000, "{taken}");
        // every length of digit run, on both sides of the point
        for a in 0..=12 {
            for b in 0..=12 {
                let s = format!("{}.{},", "7".repeat(a), "3".repeat(b));
                let want = s[..s.len() - 1].parse::<f64>().ok();
                let got = parse_plain(s.as_bytes());
                match got {
                    None => assert!(a + b == 0 || a + b > 15, "{s}"),
                    Some(g) => assert_eq!(Some(g), want.map(|w| (w, a + b + 1)), "{s}"),
                }
            }
        }
        assert_eq!(
            parse_plain(b"-8.59509659634750,1"),
            Some((-8.5950965963475, 17))
        );
        assert_eq!(parse_plain(b"+1E5\n"), Some((1e5, 4)));
        assert_eq!(parse_plain(b"-2.5e-3"), Some((-2.5e-3, 7)));
        assert_eq!(parse_plain(b"1e"), None);
        assert_eq!(parse_plain(b"1e400"), None);
        assert_eq!(parse_plain(b"12345678901234567890"), None);
        assert_eq!(parse_plain(b"9007199254740993"), None);
        assert_eq!(parse_plain(b"inf"), None);
        assert_eq!(parse_plain(b"-"), None);
    }

    fn err(text: &str, wanted: &[&str], empty: std::ops::Range<usize>, ts: Option<f64>) -> String {
        let path = file("e.csv", text.as_bytes());
        let fast = run(&path, wanted, empty.clone(), ts, Some(Mode::default()));
        let slow = run(
            &path,
            wanted,
            empty,
            ts,
            Some(Mode {
                fast: false,
                block: BLOCK,
                threads: Some(1),
            }),
        );
        assert_eq!(fast, slow);
        fast.unwrap_err().replace(&path, "F")
    }

    /// Every message of the CSV reader, on LF and CRLF files.
    #[test]
    fn each_error_message() {
        let io = &["u1", "y1"];
        for eol in ["\n", "\r\n"] {
            let t = |s: &str| s.replace('\n', eol);
            assert_eq!(
                err(&t("t,u1,y1\n0,1,2\n0.1,1\n"), io, 1..2, None),
                "F: line 3: 2 cells, the header has 3 (ragged row)"
            );
            assert_eq!(
                err(&t("t,u1,y1\n0,1,2\n\n0.1,1,2,3\n"), io, 1..2, None),
                "F: line 4: 4 cells, the header has 3 (ragged row)"
            );
            assert_eq!(
                err(&t("t,u1,y1\n0,1,2\n0.1, ,2\n"), io, 1..2, None),
                "F: line 3, column 'u1': empty cell (only output columns may have empty cells)"
            );
            assert_eq!(
                err(
                    &t("t,u1,y1\n0,1,2\n0.1,1,\u{e9}\n").replace('\u{e9}', "\u{fffd}"),
                    io,
                    1..2,
                    None
                ),
                "F: line 3, column 'y1': cannot parse '\u{fffd}' as a number"
            );
            let mut latin1 = t("t,u1,y1\n0,1,2\n0.1,1,X\n").into_bytes();
            let x = latin1.iter().position(|&b| b == b'X').unwrap();
            latin1[x] = 0xe9;
            let path = file("latin1.csv", &latin1);
            let e = run(&path, io, 1..2, None, Some(Mode::default())).unwrap_err();
            assert_eq!(
                e.replace(&path, "F"),
                "F: line 3, column 'y1': cell is not UTF-8"
            );
            assert_eq!(
                err(&t("t,u1,y1\n0,1,2\n0.1,abc,2\n"), io, 1..2, None),
                "F: line 3, column 'u1': cannot parse 'abc' as a number"
            );
            assert_eq!(
                err(&t("t,u1,y1\n0,1,2\n0.1,1, NaN \n"), io, 1..2, None),
                "F: line 3, column 'y1': value 'NaN' is not finite (NaN/inf are not allowed; leave the cell empty for an unsampled output)"
            );
            assert_eq!(
                err(&t("t,u1,y1\n0,-inf,2\n"), io, 1..2, None),
                "F: line 2, column 'u1': value '-inf' is not finite (NaN/inf are not allowed; leave the cell empty for an unsampled output)"
            );
            assert_eq!(
                err(&t("t,u1,y1\n0,1,2\n0.1,1,2\n0.25,1,2\n"), io, 1..2, None),
                "F: line 4, column 't': time 0.25 breaks the uniform spacing 0.1 (expected 0.2); give --ts to ignore the time column"
            );
            assert_eq!(
                err(&t("t,u1,y1\n0,1,2\n,1,2\n"), io, 1..2, None),
                "F: line 3, column 't': empty cell (only output columns may have empty cells)"
            );
            assert_eq!(
                err(&t("t,u1,y1\n\n"), io, 1..2, None),
                "F: no data rows after the header"
            );
            assert_eq!(
                err("", io, 1..2, None),
                "F: empty file (a header row is required)"
            );
            assert_eq!(
                err(&t(" , \n1,2\n"), io, 1..2, None),
                "F: empty file (a header row is required)"
            );
            assert_eq!(
                err(&t("t,1,y1\n0,1,2\n"), io, 1..2, None),
                "F: line 1 is not a header row (it contains numbers); the first row must name the columns"
            );
            assert_eq!(
                err(&t("t,u1,y2\n0,1,2\n"), io, 1..2, None),
                "F: header has no column 'y1' (columns: t, u1, y2)"
            );
            assert_eq!(
                err(&t("u1,y1\n1,2\n1,2\n"), io, 1..2, None),
                "F: no time column ('t' or 'time'): give the base period with --ts"
            );
            assert_eq!(
                err(&t("t,u1,y1\n0,1,2\n"), io, 1..2, None),
                "F: one row: give the base period with --ts"
            );
            assert_eq!(
                err(&t("t,u1,y1\n0,1,2\n0,1,2\n"), io, 1..2, None),
                "F: the time column does not increase: give --ts"
            );
            assert_eq!(
                err(&t("u1,y1\n1,2\n"), io, 1..2, Some(-1.0)),
                "--ts -1: must be positive and finite"
            );
        }
    }

    /// Quoted cells, blank lines, CRLF, spaces and a BOM are read as the csv
    /// crate reads them; the line numbers are those of the file.
    #[test]
    fn quotes_blank_lines_and_crlf() {
        let text =
            "\u{feff}\"t\",u1,y1\r\n\r\n0, 1 ,\"2\"\r\n\n0.5,\"-2.5e-3\",\r\n1,1E5,\"a\nb\"\r\n";
        let path = file("q.csv", text.as_bytes());
        let e = run(&path, &["u1", "y1"], 1..2, None, Some(Mode::default())).unwrap_err();
        assert_eq!(
            e.replace(&path, "F"),
            // The newline in the cell is shown escaped (one-line messages).
            "F: line 6, column 'y1': cannot parse 'a\\nb' as a number"
        );
        let text = "\u{feff}\"t\",u1,y1\r\n\r\n0, 1 ,\"2\"\r\n\n0.5,\"-2.5e-3\",\r\n1,1E5,\"\"\"3\"\"\"\r\n";
        let path = file("q2.csv", text.as_bytes());
        let e = run(&path, &["u1", "y1"], 1..2, None, Some(Mode::default())).unwrap_err();
        assert_eq!(
            e.replace(&path, "F"),
            "F: line 6, column 'y1': cannot parse '\"3\"' as a number"
        );
        let text = "t,u1,y1\r\n\r\n0, 1 ,\"2\"\r\n\n0.5,\"-2.5e-3\",\r\n1,1E5,\t3 \r\n";
        let path = file("q3.csv", text.as_bytes());
        let (rows, ts, seen) =
            run(&path, &["u1", "y1"], 1..2, None, Some(Mode::default())).unwrap();
        assert_eq!((rows, f64::from_bits(ts)), (3, 0.5));
        let v: Vec<Vec<f64>> = seen
            .iter()
            .map(|r| r.iter().map(|&b| f64::from_bits(b)).collect())
            .collect();
        assert_eq!(v[0], [1.0, 2.0]);
        assert_eq!(v[1][0], -2.5e-3);
        assert!(v[1][1].is_nan());
        assert_eq!(v[2], [1e5, 3.0]);
    }

    thread_local! {
        /// Rows the parallel reader has read with its sequential reader on
        /// this thread (the others came from blocks).
        pub(super) static SEQUENTIAL_ROWS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
    }

    fn sequential() -> Mode {
        Mode {
            fast: true,
            block: BLOCK,
            threads: Some(1),
        }
    }

    fn parallel(threads: usize, block: usize) -> Mode {
        Mode {
            fast: true,
            block,
            threads: Some(threads),
        }
    }

    /// The parallel reader's scan of `path` (and the rows it read
    /// sequentially), checked equal to the sequential reader's.
    fn same_in_parallel(
        path: &str,
        wanted: &[&str],
        empty: std::ops::Range<usize>,
        ts: Option<f64>,
        modes: &[Mode],
        what: &str,
    ) -> (Scan, Vec<u64>) {
        let reference = run(path, wanted, empty.clone(), ts, Some(sequential()));
        let mut fallback = Vec::new();
        for &mode in modes {
            let before = SEQUENTIAL_ROWS.with(std::cell::Cell::get);
            let got = run(path, wanted, empty.clone(), ts, Some(mode));
            fallback.push(SEQUENTIAL_ROWS.with(std::cell::Cell::get) - before);
            assert_eq!(got, reference, "{what}, {mode:?}");
        }
        (reference, fallback)
    }

    /// Random files of many rows (every oddity of [`random_csv`]: quotes,
    /// blank lines, CRLF and lone CR, bad cells, ragged rows, empty output
    /// cells) read in parallel with blocks of a few lines to a few hundred:
    /// the sequential reader's rows, base period or message.
    #[test]
    fn parallel_equals_sequential_on_random_files() {
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        let mut errors = 0;
        for case in 0..120 {
            let rows = [150, 1500, 4000][case % 3];
            let crlf = [0, 1000, 300][(case / 3) % 3];
            let bad = [0, 1, 3, 20][(case / 9) % 4];
            let text = random_csv(&mut rng, rows, crlf, bad);
            let path = file(&format!("p{case}.csv"), &text);
            let ts = if rng.chance(200) { Some(0.25) } else { None };
            let mut modes = vec![parallel(2, 64), parallel(2, 700), parallel(3, 4096)];
            if rows < 1000 {
                modes.push(parallel(2, 1));
                modes.push(parallel(4, 16));
            }
            let (reference, _) = same_in_parallel(
                &path,
                &["u1", "y1", "y2"],
                1..3,
                ts,
                &modes,
                &format!("case {case}"),
            );
            errors += reference.is_err() as usize;
        }
        assert!(errors > 20 && errors < 100, "{errors}");
    }

    /// A clean file of `rows` rows t,u1,x,y1,y2 (t = k/4, y1 empty on odd
    /// rows, x unread), `blanks` blank lines after every `blank_every` rows
    /// (0: none), as lines to edit.
    fn clean_lines(rows: usize, blank_every: usize, blanks: usize) -> Vec<String> {
        let mut lines = vec!["t,u1,x,y1,y2".to_string()];
        for k in 0..rows {
            let y1 = if k % 2 == 0 {
                format!("{:.14}", (k as f64 * 0.37).sin())
            } else {
                String::new()
            };
            lines.push(format!(
                "{},{},{},{y1},{:.6e}",
                k as f64 * 0.25,
                if k % 3 == 0 { -1 } else { 1 },
                k * 7,
                (k as f64).sqrt()
            ));
            if blank_every > 0 && k % blank_every == blank_every - 1 {
                lines.extend(std::iter::repeat_n(String::new(), blanks));
            }
        }
        lines
    }

    fn join(lines: &[String], eol: &str) -> Vec<u8> {
        let mut text = lines.join(eol);
        text += eol;
        text.into_bytes()
    }

    /// A quoted cell in the middle of a big file, with line ends inside it
    /// that look like rows: read by `csv-core`, and the blocks take over
    /// again after it (the rows read sequentially are about a block's); a
    /// bad cell further on has its line number (counted from the block
    /// where the blocks took over, which may start with blank lines).
    #[test]
    fn parallel_quoted_line_in_a_big_file() {
        for eol in ["\n", "\r\n"] {
            // Runs of 30 blank lines: blocks often start with blank lines.
            for (blank_every, blanks) in [(0, 0), (1, 30), (97, 1)] {
                let mut lines = clean_lines(20_000, blank_every, blanks);
                let mid = (lines.len() / 2..)
                    .find(|&k| !lines[k].is_empty())
                    .unwrap_or(1);
                let t = mid as f64; // any: x is not read
                lines[mid] = lines[mid].replacen(
                    &format!(",{},", lines[mid].split(',').nth(2).unwrap_or("")),
                    &format!(",\"{t},1,2,3,4{eol}{t},1,2,3,4{eol}\","),
                    1,
                );
                assert!(lines[mid].contains('"'), "{}", lines[mid]);
                let text = join(&lines, eol);
                let path = file("quoted_big.csv", &text);
                let modes = [parallel(2, 4096), parallel(2, 1 << 16), parallel(3, 300)];
                let (reference, fallback) =
                    same_in_parallel(&path, &["u1", "y1", "y2"], 1..3, None, &modes, "quoted");
                let (rows, ts, seen) = reference.unwrap();
                assert_eq!((rows, f64::from_bits(ts)), (20_000, 0.25));
                assert!(f64::from_bits(seen[1][1]).is_nan());
                // The blocks took over again: about one block of rows read
                // by csv-core (≈ 45 bytes a row).
                for (&n, mode) in fallback.iter().zip(&modes) {
                    assert!(
                        n >= 1 && n <= (mode.block / 20) as u64 + 2,
                        "{n} rows read sequentially, {mode:?}"
                    );
                }
                for after in [5, 150, 3000] {
                    let mut lines = lines.clone();
                    let bad = (mid + after..)
                        .find(|&k| lines[k].split(',').nth(1) == Some("1"))
                        .unwrap_or(mid);
                    lines[bad] = lines[bad].replacen(",1,", ",x,", 1);
                    let path = file("quoted_bad.csv", &join(&lines, eol));
                    let (reference, _) = same_in_parallel(
                        &path,
                        &["u1", "y1", "y2"],
                        1..3,
                        None,
                        &modes,
                        "quoted, bad",
                    );
                    // the quoted cell holds two line ends
                    let e = reference.unwrap_err().replace(&path, "F");
                    assert_eq!(
                        e,
                        format!(
                            "F: line {}, column 'u1': cannot parse 'x' as a number",
                            bad + 3
                        )
                    );
                }
            }
        }
    }

    /// Errors late in a big file (after blank lines, with LF and CRLF): the
    /// sequential reader's message and line number.
    #[test]
    fn parallel_errors_late_in_the_file() {
        for eol in ["\n", "\r\n"] {
            let lines = clean_lines(30_000, 50, 1);
            let at = lines.len() - 400; // line `at + 1` of the file
            type Edit = fn(&str) -> String;
            let cases: [(&str, Edit); 7] = [
                ("bad cell", |l| {
                    l.replacen(",-1,", ",abc,", 1).replacen(",1,", ",abc,", 1)
                }),
                ("NaN", |l| {
                    format!("{},nan", l.rsplit_once(',').map_or(l, |p| p.0))
                }),
                ("ragged", |l| format!("{l},5")),
                ("empty input", |l| {
                    l.replacen(",-1,", ",,", 1).replacen(",1,", ",,", 1)
                }),
                ("time", |l| format!("1e9{}", &l[l.find(',').unwrap_or(0)..])),
                ("lone CR", |l| l.replacen(',', "\r", 1)),
                ("quote then bad", |l| {
                    format!("\"{}", l.replacen(',', "\",x", 1))
                }),
            ];
            for (what, edit) in &cases {
                let mut lines = lines.clone();
                if lines[at].is_empty() {
                    lines.swap(at, at - 1);
                }
                lines[at] = edit(&lines[at]);
                let path = file("late.csv", &join(&lines, eol));
                let modes = [parallel(2, 4096), parallel(2, 1 << 16), parallel(3, 64)];
                let (reference, _) =
                    same_in_parallel(&path, &["u1", "y1", "y2"], 1..3, None, &modes, what);
                let e = reference.unwrap_err().replace(&path, "F");
                assert!(e.starts_with(&format!("F: line {}", at + 1)), "{what}: {e}");
            }
            // The time check counts rows across blocks and blank lines.
            let mut lines = lines.clone();
            let t = |l: &str| l.split(',').next().unwrap_or("").to_string();
            let k = lines.iter().rposition(|l| !l.is_empty()).unwrap_or(0);
            let last = t(&lines[k]);
            lines[k] = lines[k].replacen(&last, "0", 1);
            let path = file("late_t.csv", &join(&lines, eol));
            let (reference, _) = same_in_parallel(
                &path,
                &["u1", "y1", "y2"],
                1..3,
                None,
                &[parallel(2, 4096)],
                "time",
            );
            let e = reference.unwrap_err().replace(&path, "F");
            assert!(
                e.starts_with(&format!("F: line {}, column 't': time 0 breaks", k + 1)),
                "{e}"
            );
        }
    }

    /// Odd shapes in parallel: no final line end, blank lines only, CR line
    /// ends (no `\n` at all), lines longer than the block limit, a header
    /// with a quoted line end, `visit` stopping, and `--ts` without a time
    /// column.
    #[test]
    fn parallel_odd_files() {
        let modes = [parallel(2, 16), parallel(2, 64), parallel(3, 1000)];
        let w = ["u1", "y1", "y2"];
        let mut lines = clean_lines(3000, 7, 2);
        let check = |text: &[u8], what: &str, ts: Option<f64>| {
            let path = file("odd.csv", text);
            same_in_parallel(&path, &w, 1..3, ts, &modes, what).0
        };
        let text = join(&lines, "\n");
        assert!(check(&text[..text.len() - 1], "no final newline", None).is_ok());
        assert!(check(b"t,u1,x,y1,y2\n\n\r\n\n", "blank lines only", None).is_err());
        assert!(check(&join(&lines, "\r"), "CR only", None).is_ok());
        lines[0] = "\"t\",\"u\n1\",x,y1,y2".to_string();
        let e = check(&join(&lines, "\n"), "quoted header", None).unwrap_err();
        assert!(e.contains("header has no column 'u1'"), "{e}");
        lines[0] = "\u{feff}t,u1,x,y1,y2".to_string();
        for l in lines.iter_mut().skip(1000).step_by(300) {
            if !l.is_empty() {
                let pad = " ".repeat(5000);
                *l = l.replacen(',', &format!("{pad},"), 1);
            }
        }
        let long = check(&join(&lines, "\n"), "long lines", None).unwrap();
        assert_eq!(long.0, 3000);
        let no_t: Vec<String> = lines
            .iter()
            .map(|l| l.split_once(',').map_or(String::new(), |p| p.1.to_string()))
            .collect();
        let r = check(&join(&no_t, "\n"), "no time column", Some(0.5)).unwrap();
        assert_eq!((r.0, f64::from_bits(r.1)), (3000, 0.5));
        // visit stops: the same rows
        let path = file("odd_stop.csv", &join(&lines, "\n"));
        let u = "u1".to_string();
        let w = [&u];
        for mode in [sequential(), parallel(2, 64), parallel(2, 4096)] {
            let mut n = 0;
            let r = scan_csv(&path, &w, 0..0, None, mode, |_| {
                n += 1;
                Ok(n < 1234)
            });
            assert_eq!(r.unwrap(), (1234, 0.25), "{mode:?}");
        }
    }

    /// `visit` returning false stops the scan.
    #[test]
    fn visit_can_stop() {
        let path = file("stop.csv", b"t,u1,y1\n0,1,2\n1,1,2\n2,1,2\n3,x,2\n");
        let w = [&"u1".to_string()];
        let mut n = 0;
        let (rows, ts) = scan_rows(&path, &[], &w, 0..0, None, |_| {
            n += 1;
            Ok(n < 2)
        })
        .unwrap();
        assert_eq!((rows, ts), (2, 1.0));
    }
}

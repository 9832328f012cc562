//! The sequential CSV scan: the file's layout once its header is read,
//! each line through the fast path or `csv-core`, the rows in file order
//! to the caller.

use super::*;

/// How [`scan_csv`] reads (tests vary it).
#[derive(Debug, Clone, Copy)]
pub(super) struct Mode {
    /// Try the fast path on each line (false: `csv-core` for every record,
    /// on the calling thread).
    pub(super) fast: bool,
    /// Initial buffer size in bytes; also the size of the blocks of whole
    /// lines parsed in parallel.
    pub(super) block: usize,
    /// Threads parsing the file, the calling thread included: 1 reads
    /// sequentially, n ≥ 2 parses blocks on the calling thread and n − 1
    /// helpers (see [`scan_parallel`]); `None` chooses (the available
    /// parallelism, at most [`MAX_THREADS`], for a regular file of at least
    /// [`MIN_BLOCKS`] blocks; otherwise 1).
    pub(super) threads: Option<usize>,
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
pub(super) const BLOCK: usize = 1 << 20;

/// At most this many threads parse a CSV file.
pub(super) const MAX_THREADS: usize = 4;

/// A file shorter than this many blocks is read sequentially (threads
/// would not pay for themselves).
pub(super) const MIN_BLOCKS: u64 = 4;

/// What [`scan_csv`] knows of a CSV file once its header is read.
pub(super) struct Layout<'a> {
    pub(super) path: &'a str,
    pub(super) header: Vec<String>,
    pub(super) wanted: &'a [&'a String],
    pub(super) may_be_empty: std::ops::Range<usize>,
    /// Header positions of the `wanted` columns.
    pub(super) idx: Vec<usize>,
    /// The time column, if any.
    pub(super) time_col: Option<usize>,
    /// The time column when it is read (no `--ts`).
    pub(super) read_time: Option<usize>,
    /// The fast path's plan; the slot in its values of each wanted column
    /// and of the time column read; values per line.
    pub(super) plan: Plan,
    pub(super) from: Vec<usize>,
    pub(super) time_slot: Option<usize>,
    pub(super) needed: usize,
    /// The first time stamp when the time column holds dates and times.
    pub(super) epoch: super::timestamps::Epoch,
}

impl<'a> Layout<'a> {
    pub(super) fn new(
        path: &'a str,
        header: Vec<String>,
        wanted: &'a [&'a String],
        may_be_empty: std::ops::Range<usize>,
        wants_time: bool,
    ) -> crate::Result<Self> {
        let idx = column_indices(path, &header, wanted)?;
        let time_col = time_column(&header);
        let read_time = time_col.filter(|_| wants_time);
        super::columns::not_the_time_column(path, &header, &idx, read_time)?;
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
            epoch: Default::default(),
        })
    }
}

/// Where the rows go, in file order: the row count and time-column checks,
/// then the caller's `visit`.
pub(super) struct Sink<V> {
    pub(super) check: RowCheck,
    pub(super) visit: V,
}

impl<V: FnMut(&[f64]) -> crate::Result<bool>> Sink<V> {
    /// Checks and visits the row of line `line` with time `t`; false: stop.
    #[inline]
    pub(super) fn row(
        &mut self,
        lay: &Layout,
        row: &[f64],
        line: u64,
        t: f64,
    ) -> crate::Result<bool> {
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
pub(super) fn scan_csv(
    path: &str,
    wanted: &[&String],
    may_be_empty: std::ops::Range<usize>,
    ts: Option<f64>,
    mode: Mode,
    visit: impl FnMut(&[f64]) -> crate::Result<bool>,
) -> crate::Result<(usize, f64)> {
    let file = File::open(path).ctx(format!("cannot open data file {path}"))?;
    let meta = file.metadata().ok();
    let regular = meta.as_ref().is_some_and(std::fs::Metadata::is_file);
    let threads = match mode.threads {
        Some(n) => n,
        None if meta.is_some_and(|m| m.len() >= MIN_BLOCKS * mode.block as u64) => {
            lifted_linalg::budget::available_cores().min(MAX_THREADS)
        }
        None => 1,
    };
    let mut sink = Sink {
        check: RowCheck::new(ts),
        visit,
    };
    let wants_time = sink.check.wants_time();
    // A `;`- or tab-separated file: read sequentially through the byte map
    // (the parallel blocks read the file's own bytes).
    let sep = separator(path)?;
    // Blocks are read at offsets: a regular file only.
    let has_time = if sep.is_some() {
        let mut rd = CsvReader::new(Mapped::new(&file, sep), mode.block);
        let header = read_header(path, &mut rd)?;
        let lay = Layout::new(path, header, wanted, may_be_empty, wants_time)?;
        scan_sequential(&mut rd, &lay, mode.fast, &mut sink)?;
        lay.time_col.is_some()
    } else if mode.fast && threads >= 2 && regular {
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
pub(super) enum Step {
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
pub(super) fn read_one<R: std::io::Read>(
    rd: &mut CsvReader<R>,
    lay: &Layout,
    fast: bool,
    vals: &mut [f64],
    row: &mut [f64],
) -> crate::Result<Step> {
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
    // A separator closing every row (a trailing comma or tab, as DaISy's
    // tab-separated files have) is one empty cell more: read as the end of
    // the row.
    let trailing = rd.nfields == width + 1 && rd.field(width).is_empty();
    if rd.nfields != width && !trailing {
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
        t = time_value(lay, line, &lay.header[tc], rd.field(tc))?;
    }
    Ok(Step::Row(line, t))
}

/// The time column's cell of line `line`: seconds, or an ISO 8601 date and
/// time read as seconds after the file's first stamp
/// ([`super::timestamps`]); the messages of [`cell_value`] otherwise, a
/// cell that is neither saying which forms are read. O(cell).
fn time_value(lay: &Layout, line: u64, column: &str, cell: &[u8]) -> crate::Result<f64> {
    let path = lay.path;
    cell_value(path, line, column, cell, false).or_else(|e| {
        let text = std::str::from_utf8(cell).unwrap_or("").trim();
        if text.is_empty() || text.parse::<f64>().is_ok() {
            return Err(e);
        }
        match super::timestamps::epoch_nanos(text) {
            Some(nanos) => Ok(lay.epoch.seconds(nanos)),
            None => Err(input(format!(
                "{path}: line {line}, column '{column}': cannot parse '{}' as a time (seconds, or an ISO 8601 date and time such as 2026-11-26T10:00:00.5)",
                shown(text)
            ))),
        }
    })
}

/// Reads the rows after the header on the calling thread, line by line.
pub(super) fn scan_sequential<R: std::io::Read, V: FnMut(&[f64]) -> crate::Result<bool>>(
    rd: &mut CsvReader<R>,
    lay: &Layout,
    fast: bool,
    sink: &mut Sink<V>,
) -> crate::Result<()> {
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

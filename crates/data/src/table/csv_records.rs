//! The csv-crate path: a CSV file read in blocks, records by `csv-core`
//! (quotes, lone `\r`, ragged rows) with the cell checks and messages of
//! [`cell_value`], and the header row.

use super::*;

pub(super) fn cell_value(
    path: &str,
    line: u64,
    column: &str,
    cell: &[u8],
    allow_empty: bool,
) -> crate::Result<f64> {
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

/// A CSV file read in blocks: whole lines for the fast path (every line
/// before the block's last `\n`, found by `memchr::memrchr`), records by
/// `csv-core` (quotes, lone `\r`) for the rest. `line` is the 1-based
/// number of the line at `pos`.
pub(super) struct CsvReader<R> {
    pub(super) src: R,
    pub(super) buf: Vec<u8>,
    /// Offset in the file of `buf[0]`.
    pub(super) base: u64,
    pub(super) pos: usize,
    pub(super) filled: usize,
    /// End of the last whole line in `buf` (after its `\n`; `filled` at the
    /// end of the file): a line starting before it is entirely buffered.
    pub(super) complete: usize,
    pub(super) eof: bool,
    pub(super) line: u64,
    pub(super) core: csv_core::Reader,
    /// The fields of the last record read by `csv-core`, and their ends.
    pub(super) fields: Vec<u8>,
    pub(super) ends: Vec<usize>,
    pub(super) nfields: usize,
}

impl<R: std::io::Read> CsvReader<R> {
    pub(super) fn new(src: R, block: usize) -> Self {
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
    pub(super) fn refill(&mut self) -> std::io::Result<bool> {
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
    pub(super) fn skip_blank_lines(&mut self) -> std::io::Result<bool> {
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
    pub(super) fn buffer_line(&mut self) -> std::io::Result<()> {
        while self.pos >= self.complete && self.refill()? {}
        Ok(())
    }

    /// Reads one record at `pos` with `csv-core` into `fields`/`ends`; false
    /// at the end of the file.
    pub(super) fn read_record(&mut self) -> std::io::Result<bool> {
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
    pub(super) fn field(&self, i: usize) -> &[u8] {
        let start = if i == 0 { 0 } else { self.ends[i - 1] };
        &self.fields[start..self.ends[i]]
    }

    /// The offset in the file of `pos`.
    pub(super) fn offset(&self) -> u64 {
        self.base + self.pos as u64
    }
}

impl CsvReader<FileAt<'_>> {
    /// Moves to offset `at` of the file, the start of line `line` (between
    /// two records: `csv-core` goes on from its state after the last record,
    /// as after a line taken by the fast path). Keeps the buffer when it
    /// holds `at`.
    pub(super) fn seek_to(&mut self, at: u64, line: u64) {
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
pub(super) struct FileAt<'a> {
    pub(super) file: &'a File,
    pub(super) at: u64,
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
/// not hold numbers). A file separated by `;` or tabs is read through
/// [`Mapped`] (see [`separator`]).
pub(super) fn open_csv(
    path: &str,
    block: usize,
) -> crate::Result<(CsvReader<Mapped<File>>, Vec<String>)> {
    let sep = separator(path)?;
    let file = File::open(path).ctx(format!("cannot open data file {path}"))?;
    let mut rd = CsvReader::new(Mapped::new(file, sep), block);
    let header = read_header(path, &mut rd)?;
    Ok((rd, header))
}

/// The separator of a CSV file whose header row has no comma but has `;`
/// or a tab (`;` first): the exports of spreadsheets set to a decimal
/// comma (`t;u1;y1` / `0,5;1,25;…`) and of loggers writing tab-separated
/// text; blanks when it has neither but several blank-separated names
/// (`t u1 y1`: DaISy's files with a header row, MATLAB's `save -ascii`).
/// `None`: commas (the default, and the fast path's), and any file that is
/// not a regular file (a pipe is read once). Reads the first 64 KiB at
/// most.
pub(super) fn separator(path: &str) -> crate::Result<Option<Separator>> {
    use std::io::Read;
    let file = File::open(path).ctx(format!("cannot open data file {path}"))?;
    // A pipe cannot be read twice: commas.
    if !file.metadata().is_ok_and(|m| m.is_file()) {
        return Ok(None);
    }
    let mut head = Vec::with_capacity(1 << 16);
    file.take(1 << 16)
        .read_to_end(&mut head)
        .ctx(format!("cannot read data file {path}"))?;
    let text = head.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(&head);
    // The header: the first line with anything but blanks.
    let Some(line) = text
        .split(|&b| b == b'\n')
        .find(|l| l.iter().any(|b| !b.is_ascii_whitespace()))
    else {
        return Ok(None);
    };
    let (mut quoted, mut commas, mut semis, mut tabs) = (false, 0, 0, 0);
    for &b in line {
        match b {
            b'"' => quoted = !quoted,
            b',' if !quoted => commas += 1,
            b';' if !quoted => semis += 1,
            b'\t' if !quoted => tabs += 1,
            _ => {}
        }
    }
    let words = String::from_utf8_lossy(line).split_whitespace().count();
    Ok(match (commas, semis, tabs) {
        (0, s, _) if s > 0 => Some(Separator::Byte(b';')),
        (0, 0, t) if t > 0 => Some(Separator::Byte(b'\t')),
        (0, 0, 0) if words > 1 => Some(Separator::Blanks),
        _ => None,
    })
}

/// How the columns of a file that is not comma-separated are separated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Separator {
    /// One byte (`;` or a tab), a comma being a decimal comma.
    Byte(u8),
    /// Runs of spaces and tabs (DaISy's own files, MATLAB's `save
    /// -ascii`): no empty cells, a decimal point.
    Blanks,
}

/// A reader that maps the bytes of a `;`- or tab-separated file to the
/// comma-separated form the readers parse: the separator becomes `,` and
/// a comma (in such files a decimal comma) becomes `.`; one byte for one,
/// so offsets and line numbers are those of the file. A blank-separated
/// file: each run of spaces and tabs between two cells becomes one `,`,
/// those at the start and end of a line go (line numbers kept). `None`:
/// unchanged.
pub(super) struct Mapped<R> {
    inner: R,
    table: Option<Box<[u8; 256]>>,
    blanks: Option<Blanks>,
}

/// The state of a blank-separated file's mapping across reads.
#[derive(Debug, Clone, Copy)]
struct Blanks {
    /// No cell yet on this line.
    line_start: bool,
    /// Blanks seen after a cell: a `,` before the next one.
    pending: bool,
}

impl<R> Mapped<R> {
    pub(super) fn new(inner: R, separator: Option<Separator>) -> Self {
        let table = match separator {
            Some(Separator::Byte(sep)) => {
                let mut t = Box::new([0u8; 256]);
                for (i, v) in t.iter_mut().enumerate() {
                    *v = i as u8;
                }
                t[usize::from(b',')] = b'.';
                t[usize::from(sep)] = b',';
                Some(t)
            }
            _ => None,
        };
        let blanks = (separator == Some(Separator::Blanks)).then_some(Blanks {
            line_start: true,
            pending: false,
        });
        Mapped {
            inner,
            table,
            blanks,
        }
    }
}

impl<R: std::io::Read> std::io::Read for Mapped<R> {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        loop {
            let n = self.inner.read(out)?;
            if let Some(t) = &self.table {
                for b in &mut out[..n] {
                    *b = t[usize::from(*b)];
                }
            }
            let Some(st) = &mut self.blanks else {
                return Ok(n);
            };
            // In place: a `,` stands for at least one blank, so the
            // written part never passes the read one.
            let mut w = 0;
            for r in 0..n {
                let b = out[r];
                match b {
                    b' ' | b'\t' => st.pending = !st.line_start,
                    b'\n' | b'\r' => {
                        st.pending = false;
                        st.line_start = true;
                        out[w] = b;
                        w += 1;
                    }
                    _ => {
                        if st.pending {
                            out[w] = b',';
                            w += 1;
                            st.pending = false;
                        }
                        st.line_start = false;
                        out[w] = b;
                        w += 1;
                    }
                }
            }
            // A read of blanks only is not the end of the file.
            if w > 0 || n == 0 {
                return Ok(w);
            }
        }
    }
}

/// Reads the header row of a CSV file at the start of `rd`.
pub(super) fn read_header<R: std::io::Read>(
    path: &str,
    rd: &mut CsvReader<R>,
) -> crate::Result<Vec<String>> {
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

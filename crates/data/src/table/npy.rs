//! Reading numpy `.npy` files (written by `numpy.save`) as data sets.
//!
//! The array must be 2-D, rows × columns, of `float64` (`<f8`) or `float32`
//! (`<f4`, widened to f64; the big-endian `>f8`/`>f4` are read too), in C or
//! Fortran order, with a format 1.0, 2.0 or 3.0 header. The array has no
//! column names: they are given with `--columns NAME,…` (in order), else
//! `c0, c1, …`; a column named `t` or `time` is the time column, as in a
//! CSV file. A NaN in an output column marks an unsampled instant (like an
//! empty CSV cell); NaN or ±inf anywhere else is an error naming the column
//! and the row. Rows are numbered from 0, as numpy indexes them.
//!
//! Reading streams in blocks of about 1 MiB: memory is O(columns × block)
//! whatever the number of rows (a C-order block is one contiguous read; a
//! Fortran-order block is one read per needed column).

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};

use crate::error::input;
use crate::shown::{shown, shown_list};
use crate::table::{RowCheck, check_unique, time_column};

/// The magic string opening every `.npy` file.
const MAGIC: &[u8; 6] = b"\x93NUMPY";

/// Bytes of data read at a time (C order: whole rows; Fortran order: per column).
const BLOCK: usize = 1 << 20;

/// Bytes of whole rows [`scan_blocks`] reads at a time from a C-order file:
/// small enough that the read's copy and the decoding of it stay in the
/// core's L2 cache (a 2 MiB read of a 65 536-row block went to memory and
/// back), large enough that the calls cost nothing (a few per MiB).
const READ_BYTES: usize = 1 << 17;

/// The element type of an array (the `descr` of the header).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dtype {
    /// 8-byte float, little-endian (`<f8`) or big-endian (`>f8`).
    F8 {
        /// Big-endian.
        big: bool,
    },
    /// 4-byte float (`<f4`/`>f4`), widened to f64.
    F4 {
        /// Big-endian.
        big: bool,
    },
}

impl Dtype {
    /// Bytes per element.
    pub fn size(self) -> usize {
        match self {
            Dtype::F8 { .. } => 8,
            Dtype::F4 { .. } => 4,
        }
    }

    /// Decodes `out.len()` elements, the k-th from the `size()` bytes at
    /// `b[k * stride..]`: one loop per element type, no per-element
    /// dispatch. O(out.len()).
    fn decode_strided(self, b: &[u8], stride: usize, out: &mut [f64]) {
        // Rows of `stride` bytes (the last may be only the element long):
        // one slice per element without a bounds check per byte.
        macro_rules! each {
            ($n:literal, $from:expr) => {
                for (v, row) in out.iter_mut().zip(b.chunks(stride)) {
                    let Some(a) = row.first_chunk::<$n>() else {
                        break;
                    };
                    *v = $from(*a);
                }
            };
        }
        match self {
            Dtype::F8 { big: false } => each!(8, f64::from_le_bytes),
            Dtype::F8 { big: true } => each!(8, f64::from_be_bytes),
            Dtype::F4 { big: false } => each!(4, |a| f64::from(f32::from_le_bytes(a))),
            Dtype::F4 { big: true } => each!(4, |a| f64::from(f32::from_be_bytes(a))),
        }
    }
}

/// The header of a `.npy` file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NpyHeader {
    /// Element type.
    pub dtype: Dtype,
    /// Column-major data (`fortran_order: True`).
    pub fortran_order: bool,
    /// Rows of the array.
    pub rows: usize,
    /// Columns of the array.
    pub cols: usize,
    /// Byte offset of the data in the file.
    pub data_offset: u64,
}

impl NpyHeader {
    /// Bytes of data the header declares (rows × cols × element size), if
    /// that fits in a u64.
    pub fn data_len(&self) -> Option<u64> {
        (self.rows as u64)
            .checked_mul(self.cols as u64)?
            .checked_mul(self.dtype.size() as u64)
    }
}

/// Reads and checks the header of the `.npy` stream `r` (positioned at the
/// start of the file); `path` names it in messages. O(header length).
pub fn read_header(r: &mut impl Read, path: &str) -> crate::Result<NpyHeader> {
    let truncated = |what: &str| input(format!("{path}: not a .npy file ({what})"));
    let mut pre = [0u8; 8];
    r.read_exact(&mut pre)
        .map_err(|_| truncated("shorter than the magic string"))?;
    if &pre[..6] != MAGIC {
        return Err(input(format!(
            "{path}: not a .npy file (bad magic: the file must start with \\x93NUMPY)"
        )));
    }
    let (major, minor) = (pre[6], pre[7]);
    let (len, prefix) = match major {
        1 => {
            let mut b = [0u8; 2];
            r.read_exact(&mut b)
                .map_err(|_| truncated("truncated header"))?;
            (usize::from(u16::from_le_bytes(b)), 10)
        }
        2 | 3 => {
            let mut b = [0u8; 4];
            r.read_exact(&mut b)
                .map_err(|_| truncated("truncated header"))?;
            (u32::from_le_bytes(b) as usize, 12)
        }
        _ => {
            return Err(input(format!(
                "{path}: unsupported .npy format version {major}.{minor} (1.0, 2.0 and 3.0 are read)"
            )));
        }
    };
    if len > 1 << 24 {
        return Err(input(format!(
            "{path}: .npy header of {len} bytes is implausibly long"
        )));
    }
    let mut text = vec![0u8; len];
    r.read_exact(&mut text)
        .map_err(|_| truncated("truncated header"))?;
    // Versions 1 and 2 are latin-1, 3 is UTF-8; the keys and values read
    // here are ASCII either way.
    let text = String::from_utf8_lossy(&text);
    let bad = |why: String| input(format!("{path}: bad .npy header ({why}): {}", text.trim()));
    let descr = dict_value(&text, "descr").ok_or_else(|| bad("no 'descr'".into()))?;
    let dtype = match descr.trim_matches(|c| c == '\'' || c == '"') {
        "<f8" => Dtype::F8 { big: false },
        ">f8" => Dtype::F8 { big: true },
        "<f4" => Dtype::F4 { big: false },
        ">f4" => Dtype::F4 { big: true },
        _ => {
            return Err(input(format!(
                "{path}: unsupported dtype {descr} (float64 '<f8' or float32 '<f4' are read; convert with a.astype('<f8'))"
            )));
        }
    };
    let fortran_order = match dict_value(&text, "fortran_order") {
        Some("True") => true,
        Some("False") => false,
        Some(v) => return Err(bad(format!("fortran_order {v}"))),
        None => return Err(bad("no 'fortran_order'".into())),
    };
    let shape_text = dict_value(&text, "shape").ok_or_else(|| bad("no 'shape'".into()))?;
    let shape = parse_shape(shape_text).ok_or_else(|| bad(format!("shape {shape_text}")))?;
    let [rows, cols] = shape[..] else {
        return Err(input(format!(
            "{path}: the array has shape {shape_text}: a 2-D array (rows × columns) is needed"
        )));
    };
    Ok(NpyHeader {
        dtype,
        fortran_order,
        rows,
        cols,
        data_offset: (prefix + len) as u64,
    })
}

/// The text of the value of `key` in the header's dict literal: a quoted
/// string, a bracketed list or tuple, or a bare word. O(header).
fn dict_value<'a>(text: &'a str, key: &str) -> Option<&'a str> {
    let at = [format!("'{key}'"), format!("\"{key}\"")]
        .iter()
        .find_map(|k| text.find(k.as_str()).map(|i| i + k.len()))?;
    let rest = text[at..].trim_start().strip_prefix(':')?.trim_start();
    let first = rest.chars().next()?;
    let end = match first {
        '\'' | '"' => rest[1..].find(first)? + 2,
        '(' | '[' => {
            let close = if first == '(' { ')' } else { ']' };
            let mut depth = 0usize;
            let mut end = None;
            for (i, c) in rest.char_indices() {
                if c == first {
                    depth += 1;
                } else if c == close {
                    depth -= 1;
                    if depth == 0 {
                        end = Some(i + 1);
                        break;
                    }
                }
            }
            end?
        }
        _ => rest.find([',', '}']).unwrap_or(rest.len()),
    };
    Some(rest[..end].trim())
}

/// The dimensions of a shape tuple such as `(1000, 5)` or `(7,)`.
fn parse_shape(s: &str) -> Option<Vec<usize>> {
    let inner = s.strip_prefix('(')?.strip_suffix(')')?;
    inner
        .split(',')
        .map(str::trim)
        .filter(|d| !d.is_empty())
        .map(|d| d.trim_end_matches('L').parse().ok())
        .collect()
}

/// Opens a `.npy` file, reads its header and checks that the data are all
/// there. O(header length).
fn open(path: &str) -> crate::Result<(File, NpyHeader)> {
    let mut file =
        File::open(path).map_err(|e| input(format!("cannot open data file {path}: {e}")))?;
    let h = read_header(&mut file, path)?;
    let size = file
        .metadata()
        .map_err(|e| input(format!("{path}: {e}")))?
        .len();
    if h.rows == 0 || h.cols == 0 {
        return Err(input(format!(
            "{path}: the array has shape ({}, {}): no data",
            h.rows, h.cols
        )));
    }
    let need = h.data_len().ok_or_else(|| {
        input(format!(
            "{path}: the shape ({}, {}) is too large",
            h.rows, h.cols
        ))
    })?;
    let have = size.saturating_sub(h.data_offset);
    if have < need {
        return Err(input(format!(
            "{path}: truncated data: the header declares {} × {} values of {} bytes ({need} bytes), the file holds {have} bytes after the header",
            h.rows,
            h.cols,
            h.dtype.size()
        )));
    }
    Ok((file, h))
}

/// The column names of an array of `cols` columns: `given` (one per
/// column) or `c0, c1, …`.
fn names(path: &str, given: &[String], cols: usize) -> crate::Result<Vec<String>> {
    if given.is_empty() {
        return Ok((0..cols).map(|c| format!("c{c}")).collect());
    }
    if given.len() != cols {
        return Err(input(format!(
            "{path}: --columns gives {} names, the array has {cols} columns",
            given.len()
        )));
    }
    check_unique(&format!("{}: --columns", shown(path)), given)?;
    Ok(given.to_vec())
}

/// The column names of a `.npy` file (`given`, or `c0, c1, …`). O(header).
pub fn header(path: &str, given: &[String]) -> crate::Result<Vec<String>> {
    let (_, h) = open(path)?;
    names(path, given, h.cols)
}

/// [`crate::table::scan_rows`] for a `.npy` file: streams the rows, `visit`
/// receives the values of `wanted` (NaN allowed only in the columns of
/// `may_be_empty`), the time column is checked for uniform spacing. Row by
/// row on top of [`scan_blocks`]: the same checks and messages.
pub fn scan_rows(
    path: &str,
    given: &[String],
    wanted: &[&String],
    may_be_empty: std::ops::Range<usize>,
    ts: Option<f64>,
    mut visit: impl FnMut(&[f64]) -> crate::Result<bool>,
) -> crate::Result<(usize, f64)> {
    let mut row = vec![0.0; wanted.len()];
    let block_rows = (BLOCK / (8 * wanted.len().max(1))).max(1);
    scan_blocks(
        path,
        given,
        wanted,
        may_be_empty,
        ts,
        block_rows,
        |cols, n| {
            for i in 0..n {
                for (j, x) in row.iter_mut().enumerate() {
                    *x = cols[j * n + i];
                }
                if !visit(&row)? {
                    return Ok(i + 1);
                }
            }
            Ok(n)
        },
    )
}

/// Why [`scan_record_blocks`] stopped early.
#[derive(Debug)]
pub enum BlockStop<E> {
    /// The file could not be read or a value failed its check.
    Read(crate::Error),
    /// The visitor's error.
    Visit(E),
}

/// [`scan_blocks`] as a record's blocks: `visit(u, y)` receives each block
/// as an input matrix (the first `n_u` of `wanted`, one row per sample) and
/// an output matrix (the rest), reused from block to block (the visitor may
/// scale them in place), and returns whether to go on (`Ok(false)`: stop
/// there, e.g. at an output not sampled) or its error, which stops the scan
/// and is returned. Returns the rows taken and the base period. The front
/// ends' one way from a `.npy` file to blocks of samples (the command's
/// streamed route, `lifted.dask`'s shards). O(rows × wanted columns).
#[allow(clippy::too_many_arguments)]
pub fn scan_record_blocks<E>(
    path: &str,
    given: &[String],
    wanted: &[&String],
    n_u: usize,
    may_be_empty: std::ops::Range<usize>,
    ts: Option<f64>,
    block_rows: usize,
    mut visit: impl FnMut(
        &mut nalgebra::DMatrix<f64>,
        &mut nalgebra::DMatrix<f64>,
    ) -> std::result::Result<bool, E>,
) -> std::result::Result<(usize, f64), BlockStop<E>> {
    let n_y = wanted.len().saturating_sub(n_u);
    // The blocks are decoded straight into the matrices the visitor gets.
    let mut buf = RecordColumns {
        u: nalgebra::DMatrix::zeros(0, n_u),
        y: nalgebra::DMatrix::zeros(0, n_y),
        time: Vec::new(),
    };
    let mut stopped: Option<E> = None;
    let scanned = scan_core(
        path,
        given,
        wanted,
        may_be_empty,
        ts,
        block_rows,
        &mut buf,
        |b, n, good| {
            let went = if good == n {
                visit(&mut b.u, &mut b.y)
            } else {
                // The rows before the failing one, as a block of their own.
                let (mut u, mut y) = (
                    b.u.rows(0, good).into_owned(),
                    b.y.rows(0, good).into_owned(),
                );
                visit(&mut u, &mut y)
            };
            match went {
                Ok(true) => Ok(good),
                Ok(false) => Ok(0),
                Err(e) => {
                    stopped = Some(e);
                    Ok(0)
                }
            }
        },
    );
    match (scanned, stopped) {
        (_, Some(e)) => Err(BlockStop::Visit(e)),
        (Err(e), None) => Err(BlockStop::Read(e)),
        (Ok(r), None) => Ok(r),
    }
}

/// Where [`scan_core`] decodes a block: column k of the wanted columns
/// (then the time column, when read) over the block's n rows.
trait BlockColumns {
    /// Makes room for a block of `n` rows (`k` columns).
    fn reshape(&mut self, n: usize, k: usize);
    /// Column `k` of the current block.
    fn column(&mut self, k: usize) -> &mut [f64];
    /// Column `k` of the current block, to read.
    fn column_ref(&self, k: usize) -> &[f64];
}

/// One flat column-major buffer (column k at `k·n ..`), reused.
struct FlatColumns {
    data: Vec<f64>,
    n: usize,
}

impl BlockColumns for FlatColumns {
    fn reshape(&mut self, n: usize, k: usize) {
        if self.data.len() < n * k {
            self.data.resize(n * k, 0.0);
        }
        self.n = n;
    }
    fn column(&mut self, k: usize) -> &mut [f64] {
        &mut self.data[k * self.n..(k + 1) * self.n]
    }
    fn column_ref(&self, k: usize) -> &[f64] {
        &self.data[k * self.n..(k + 1) * self.n]
    }
}

/// A record's input and output matrices (and the time column), reused
/// while the blocks keep their length.
struct RecordColumns {
    u: nalgebra::DMatrix<f64>,
    y: nalgebra::DMatrix<f64>,
    time: Vec<f64>,
}

impl BlockColumns for RecordColumns {
    fn reshape(&mut self, n: usize, k: usize) {
        let (nu, ny) = (self.u.ncols(), self.y.ncols());
        if self.u.nrows() != n {
            self.u = nalgebra::DMatrix::zeros(n, nu);
            self.y = nalgebra::DMatrix::zeros(n, ny);
        }
        self.time.resize(if k > nu + ny { n } else { 0 }, 0.0);
    }
    fn column(&mut self, k: usize) -> &mut [f64] {
        let (n, nu, ny) = (self.u.nrows(), self.u.ncols(), self.y.ncols());
        if k < nu {
            &mut self.u.as_mut_slice()[k * n..(k + 1) * n]
        } else if k < nu + ny {
            &mut self.y.as_mut_slice()[(k - nu) * n..(k - nu + 1) * n]
        } else {
            &mut self.time
        }
    }
    fn column_ref(&self, k: usize) -> &[f64] {
        let (n, nu, ny) = (self.u.nrows(), self.u.ncols(), self.y.ncols());
        if k < nu {
            &self.u.as_slice()[k * n..(k + 1) * n]
        } else if k < nu + ny {
            &self.y.as_slice()[(k - nu) * n..(k - nu + 1) * n]
        } else {
            &self.time
        }
    }
}

/// Streams the `wanted` columns of a `.npy` file in blocks of up to
/// `block_rows` rows: `visit(cols, n)` receives the block column-major
/// (column j of `wanted` at `cols[j * n .. (j + 1) * n]`) and returns how
/// many of its rows it took; fewer than `n` ends the scan there. Values are
/// checked as [`scan_rows`] checks them (NaN only in the columns of
/// `may_be_empty`, the time column's spacing when no `ts` is given): at the
/// first row that fails, the rows before it are delivered and the error is
/// returned, as a row-by-row reading would. Returns the rows taken and the
/// base period.
///
/// Each column of a block is decoded by strided loops (C order: from reads
/// of whole rows 128 KiB at a time; Fortran order: one read per
/// wanted column) and checked for finiteness by branch-free block scans:
/// O(rows × wanted columns) with no per-row calls, memory O(block_rows ×
/// columns).
pub fn scan_blocks(
    path: &str,
    given: &[String],
    wanted: &[&String],
    may_be_empty: std::ops::Range<usize>,
    ts: Option<f64>,
    block_rows: usize,
    mut visit: impl FnMut(&[f64], usize) -> crate::Result<usize>,
) -> crate::Result<(usize, f64)> {
    let k = wanted.len();
    let mut buf = FlatColumns {
        data: Vec::new(),
        n: 0,
    };
    scan_core(
        path,
        given,
        wanted,
        may_be_empty,
        ts,
        block_rows,
        &mut buf,
        |b, n, good| {
            if good == n {
                visit(&b.data[..k * n], n)
            } else {
                // The rows before the failing one, as a block of their own.
                let mut part = vec![0.0; k * good];
                for (j, dst) in part.chunks_exact_mut(good).enumerate() {
                    dst.copy_from_slice(&b.column_ref(j)[..good]);
                }
                visit(&part, good)
            }
        },
    )
}

/// [`scan_blocks`] decoding into `buf`; `visit(buf, n, good)` takes the
/// first `good` rows of the block of `n` (fewer than `n` where a value
/// failed its check) and returns how many it took.
#[allow(clippy::too_many_arguments)]
fn scan_core<B: BlockColumns>(
    path: &str,
    given: &[String],
    wanted: &[&String],
    may_be_empty: std::ops::Range<usize>,
    ts: Option<f64>,
    block_rows: usize,
    buf: &mut B,
    mut visit: impl FnMut(&mut B, usize, usize) -> crate::Result<usize>,
) -> crate::Result<(usize, f64)> {
    let (mut file, h) = open(path)?;
    let header = names(path, given, h.cols)?;
    let idx: Vec<usize> = wanted
        .iter()
        .map(|n| {
            header.iter().position(|h| h == *n).ok_or_else(|| {
                let hint = if given.is_empty() {
                    "; name them with --columns"
                } else {
                    ""
                };
                input(format!(
                    "{}: no column '{}' (columns: {}{hint})",
                    shown(path),
                    shown(n),
                    shown_list(&header)
                ))
            })
        })
        .collect::<crate::Result<_>>()?;
    let time_col = time_column(&header);
    let mut check = RowCheck::new(ts);
    let read_time = time_col.filter(|_| check.wants_time());
    crate::table::not_the_time_column(path, &header, &idx, read_time)?;
    // The columns decoded per block: the wanted ones, then the time column.
    let sources: Vec<usize> = idx.iter().copied().chain(read_time).collect();
    let size = h.dtype.size();
    let row_bytes = h.cols * size;
    let block_rows = block_rows.max(1);
    let read_err = |e: std::io::Error| input(format!("{path}: truncated data ({e})"));
    // C order: whole rows read [`READ_BYTES`] at a time (the buffer stays
    // in the core's cache between the read's copy and the decoding).
    let read_rows = (READ_BYTES / row_bytes.max(1)).clamp(1, block_rows);
    let mut bytes = vec![
        0u8;
        if h.fortran_order {
            block_rows * size
        } else {
            read_rows * row_bytes
        }
    ];
    let mut r0 = 0;
    while r0 < h.rows {
        let n = block_rows.min(h.rows - r0);
        buf.reshape(n, sources.len());
        if h.fortran_order {
            for (k, &c) in sources.iter().enumerate() {
                let out = buf.column(k);
                let at = h.data_offset + (c as u64 * h.rows as u64 + r0 as u64) * size as u64;
                file.seek(SeekFrom::Start(at)).map_err(read_err)?;
                let b = &mut bytes[..n * size];
                file.read_exact(b).map_err(read_err)?;
                h.dtype.decode_strided(b, size, out);
            }
        } else {
            let mut i = 0;
            while i < n {
                let m = read_rows.min(n - i);
                let b = &mut bytes[..m * row_bytes];
                file.read_exact(b).map_err(read_err)?;
                for (k, &c) in sources.iter().enumerate() {
                    let out = &mut buf.column(k)[i..i + m];
                    h.dtype.decode_strided(&b[c * size..], row_bytes, out);
                }
                i += m;
            }
        }
        // The first row that fails a value check (and the column, in
        // wanted order, where a row-by-row reading fails it).
        let mut first_bad: Option<(usize, usize)> = None;
        for j in 0..wanted.len() {
            let col = buf.column_ref(j);
            let nan_ok = may_be_empty.contains(&j);
            let limit = first_bad.map_or(n, |(r, _)| r + 1);
            if let Some(r) = first_failing(&col[..limit], nan_ok)
                && first_bad.is_none_or(|(b, _)| r < b)
            {
                first_bad = Some((r, j));
            }
        }
        // The time column's checks up to that row (a row's values are
        // checked before its time).
        let checked = first_bad.map_or(n, |(r, _)| r);
        let mut time_error = None;
        if let Some(tc) = read_time {
            let times = buf.column_ref(wanted.len());
            let start = check.rows;
            for (i, &t) in times[..checked].iter().enumerate() {
                let step = if t.is_finite() {
                    check.time(path, &format_args!("row {}", r0 + i), &header[tc], t)
                } else {
                    Err(not_finite(path, r0 + i, &header[tc], t, false))
                };
                if let Err(e) = step {
                    time_error = Some((i, e));
                    break;
                }
                check.rows += 1;
            }
            check.rows = start;
        }
        let (good, error) = match (time_error, first_bad) {
            (Some((i, e)), _) => (i, Some(e)),
            (None, Some((r, j))) => {
                let v = buf.column_ref(j)[r];
                let e = not_finite(path, r0 + r, wanted[j], v, may_be_empty.contains(&j));
                (r, Some(e))
            }
            (None, None) => (n, None),
        };
        let taken = if good == 0 { 0 } else { visit(buf, n, good)? };
        check.rows += taken;
        if taken < good {
            break;
        }
        if let Some(e) = error {
            return Err(e);
        }
        r0 += n;
    }
    check.finish(path, time_col.is_some())
}

/// The first entry of `col` that is not finite
/// ([`lifted_linalg::kernels::first_non_finite`]), or with `nan_ok` (an
/// output whose NaN marks an unsampled instant) the first infinity.
fn first_failing(col: &[f64], nan_ok: bool) -> Option<usize> {
    if nan_ok {
        lifted_linalg::kernels::first_infinite(col)
    } else {
        lifted_linalg::kernels::first_non_finite(col)
    }
}

/// The error of a non-finite value at row `r` of `column`.
fn not_finite(path: &str, r: usize, column: &str, v: f64, output: bool) -> crate::Error {
    let why = if output {
        "only NaN, marking an unsampled output, is allowed"
    } else {
        "NaN/inf are not allowed here; NaN marks an unsampled output and is allowed in output columns only"
    };
    input(format!(
        "{path}: row {r}, column '{column}': value {v} is not finite ({why})"
    ))
}

#[cfg(test)]
mod tests;

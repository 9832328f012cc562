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
        macro_rules! each {
            ($n:literal, $from:expr) => {
                for (k, v) in out.iter_mut().enumerate() {
                    let mut a = [0u8; $n];
                    a.copy_from_slice(&b[k * stride..k * stride + $n]);
                    *v = $from(a);
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
    let (mut ub, mut yb) = (
        nalgebra::DMatrix::zeros(0, n_u),
        nalgebra::DMatrix::zeros(0, n_y),
    );
    let mut stopped: Option<E> = None;
    let scanned = scan_blocks(
        path,
        given,
        wanted,
        may_be_empty,
        ts,
        block_rows,
        |cols, n| {
            if n != ub.nrows() {
                ub = nalgebra::DMatrix::zeros(n, n_u);
                yb = nalgebra::DMatrix::zeros(n, n_y);
            }
            ub.as_mut_slice().copy_from_slice(&cols[..n_u * n]);
            yb.as_mut_slice()
                .copy_from_slice(&cols[n_u * n..(n_u + n_y) * n]);
            match visit(&mut ub, &mut yb) {
                Ok(true) => Ok(n),
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
/// Each column of a block is decoded in one strided loop (C order: from
/// one contiguous read of whole rows; Fortran order: one read per wanted
/// column) and checked for finiteness in chunks of 8: O(rows × wanted
/// columns) with no per-row calls, memory O(block_rows × columns).
pub fn scan_blocks(
    path: &str,
    given: &[String],
    wanted: &[&String],
    may_be_empty: std::ops::Range<usize>,
    ts: Option<f64>,
    block_rows: usize,
    mut visit: impl FnMut(&[f64], usize) -> crate::Result<usize>,
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
    let mut bytes = vec![0u8; block_rows * if h.fortran_order { size } else { row_bytes }];
    let mut cols = vec![0.0; sources.len() * block_rows];
    let mut r0 = 0;
    while r0 < h.rows {
        let n = block_rows.min(h.rows - r0);
        for (k, &c) in sources.iter().enumerate() {
            let out = &mut cols[k * n..(k + 1) * n];
            if h.fortran_order {
                let at = h.data_offset + (c as u64 * h.rows as u64 + r0 as u64) * size as u64;
                file.seek(SeekFrom::Start(at)).map_err(read_err)?;
                let b = &mut bytes[..n * size];
                file.read_exact(b).map_err(read_err)?;
                h.dtype.decode_strided(b, size, out);
            } else {
                if k == 0 {
                    file.read_exact(&mut bytes[..n * row_bytes])
                        .map_err(read_err)?;
                }
                h.dtype.decode_strided(&bytes[c * size..], row_bytes, out);
            }
        }
        // The first row that fails a value check (and the column, in
        // wanted order, where a row-by-row reading fails it).
        let mut first_bad: Option<(usize, usize)> = None;
        for (j, col) in cols[..wanted.len() * n].chunks_exact(n).enumerate() {
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
            let times = &cols[wanted.len() * n..(wanted.len() + 1) * n];
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
                let v = cols[j * n + r];
                let e = not_finite(path, r0 + r, wanted[j], v, may_be_empty.contains(&j));
                (r, Some(e))
            }
            (None, None) => (n, None),
        };
        let taken = if good == 0 {
            0
        } else if good == n {
            visit(&cols[..wanted.len() * n], n)?
        } else {
            // The rows before the failing one, as a block of their own.
            let mut part = vec![0.0; wanted.len() * good];
            for (j, dst) in part.chunks_exact_mut(good).enumerate() {
                dst.copy_from_slice(&cols[j * n..j * n + good]);
            }
            visit(&part, good)?
        };
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
        col.iter().position(|v| v.is_infinite())
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
mod tests {
    use super::*;
    use crate::table::{DataSpec, load, read_raw};

    /// A `.npy` file by hand: magic, version, header dict padded to 64
    /// bytes, then `data` (row-major values, written in `fortran` order if
    /// asked) as `descr`.
    fn npy(
        version: u8,
        descr: &str,
        fortran: bool,
        shape: &str,
        rows: usize,
        data: &[f64],
    ) -> Vec<u8> {
        let dict = format!(
            "{{'descr': '{descr}', 'fortran_order': {}, 'shape': {shape}, }}",
            if fortran { "True" } else { "False" }
        );
        let prefix = if version == 1 { 10 } else { 12 };
        let pad = (64 - (prefix + dict.len() + 1) % 64) % 64;
        let header = format!("{dict}{}\n", " ".repeat(pad));
        let mut out = b"\x93NUMPY".to_vec();
        out.extend([version, 0]);
        if version == 1 {
            out.extend((header.len() as u16).to_le_bytes());
        } else {
            out.extend((header.len() as u32).to_le_bytes());
        }
        out.extend(header.as_bytes());
        let cols = data.len().checked_div(rows).unwrap_or(0);
        let order: Vec<f64> = if fortran {
            (0..cols)
                .flat_map(|c| (0..rows).map(move |r| data[r * cols + c]))
                .collect()
        } else {
            data.to_vec()
        };
        for v in order {
            match descr {
                "<f4" => out.extend((v as f32).to_le_bytes()),
                ">f4" => out.extend((v as f32).to_be_bytes()),
                ">f8" => out.extend(v.to_be_bytes()),
                _ => out.extend(v.to_le_bytes()),
            }
        }
        out
    }

    fn file(name: &str, bytes: &[u8]) -> String {
        let dir = std::env::temp_dir().join(format!("lifted-npy-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p.display().to_string()
    }

    fn s(v: &[&str]) -> Vec<String> {
        v.iter().map(|x| x.to_string()).collect()
    }

    /// rows × 3: t = 0.5 k, u = k mod 7 − 3, y = sin k.
    fn table(rows: usize) -> Vec<f64> {
        (0..rows)
            .flat_map(|k| [0.5 * k as f64, (k % 7) as f64 - 3.0, (k as f64).sin()])
            .collect()
    }

    /// Every layout and element type, across block boundaries (the
    /// 70 000-row files are larger than a block).
    #[test]
    fn reads_every_layout_and_type() {
        for rows in [1usize, 5, 70_000] {
            let data = table(rows);
            for (version, descr, fortran) in [
                (1, "<f8", false),
                (2, "<f8", true),
                (3, "<f4", false),
                (1, "<f4", true),
                (1, ">f8", false),
                (2, ">f4", true),
            ] {
                let shape = format!("({rows}, 3)");
                let path = file(
                    &format!("l{rows}{version}{}{fortran}.npy", &descr[..1] == "<"),
                    &npy(version, descr, fortran, &shape, rows, &data),
                );
                let names = s(&["t", "u", "y"]);
                let wanted: Vec<&String> = vec![&names[2], &names[1]];
                let ts = if rows == 1 { Some(0.5) } else { None };
                let raw = read_raw(&path, &names, &wanted, 0..1, ts).unwrap();
                assert_eq!((raw.rows, raw.ts), (rows, 0.5), "{path}");
                let widen = |v: f64| {
                    if descr.ends_with('4') {
                        f64::from(v as f32)
                    } else {
                        v
                    }
                };
                for k in [0, rows / 2, rows - 1] {
                    assert_eq!(raw.cols[0][k], widen(data[3 * k + 2]), "{path} {k}");
                    assert_eq!(raw.cols[1][k], widen(data[3 * k + 1]), "{path} {k}");
                }
                assert!(
                    raw.cols[0]
                        .iter()
                        .enumerate()
                        .all(|(k, &v)| v == widen(data[3 * k + 2]))
                );
            }
        }
    }

    /// The default names, `--columns`, and the header.
    #[test]
    fn column_names() {
        let path = file("names.npy", &npy(1, "<f8", false, "(4, 3)", 4, &table(4)));
        assert_eq!(header(&path, &[]).unwrap(), s(&["c0", "c1", "c2"]));
        assert_eq!(
            crate::table::header(&path, &s(&["t", "u", "y"])).unwrap(),
            s(&["t", "u", "y"])
        );
        let c2 = "c2".to_string();
        let raw = read_raw(&path, &[], &[&c2], 0..0, Some(2.0)).unwrap();
        assert_eq!((raw.rows, raw.ts), (4, 2.0));
        let e = read_raw(&path, &[], &[&c2], 0..0, None)
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.ends_with("no time column ('t' or 'time'): give the base period with --ts"),
            "{e}"
        );
        let e = header(&path, &s(&["t", "u"])).unwrap_err().to_string();
        assert_eq!(
            e,
            format!("{path}: --columns gives 2 names, the array has 3 columns")
        );
        let y = "y".to_string();
        let e = read_raw(&path, &[], &[&y], 0..0, Some(1.0))
            .err()
            .unwrap()
            .to_string();
        assert_eq!(
            e,
            format!("{path}: no column 'y' (columns: c0, c1, c2; name them with --columns)")
        );
    }

    /// NaN marks an unsampled output; `load` infers the period from it.
    #[test]
    fn nan_in_outputs_is_unsampled() {
        let mut data = table(12);
        for k in 0..12 {
            if k % 3 != 0 {
                data[3 * k + 2] = f64::NAN;
            }
        }
        let path = file("slow.npy", &npy(1, "<f8", false, "(12, 3)", 12, &data));
        let spec = DataSpec {
            inputs: s(&["u"]),
            outputs: s(&["y"]),
            columns: s(&["time", "u", "y"]),
            ..Default::default()
        };
        let l = load(&path, &spec).unwrap();
        assert_eq!(l.data.outputs()[0].period, 3);
        assert_eq!(l.data.ts(), 0.5);
        // a value between samples is named by its row
        data[3 * 4 + 2] = 1.0;
        let path = file("slow2.npy", &npy(1, "<f8", false, "(12, 3)", 12, &data));
        let e = load(&path, &spec).err().unwrap().to_string();
        assert_eq!(
            e,
            format!(
                "{path}: row 4, column 'y': value between samples of period 3 (the cell must be empty)"
            )
        );
    }

    /// Blocks of any size give the rows of the row-by-row reading, in
    /// both layouts; a bad value mid-block delivers the rows before it,
    /// then the row reading's error; a visitor that takes fewer rows ends
    /// the scan there.
    #[test]
    fn blocks_are_the_rows_and_stop_where_rows_stop() {
        let names = s(&["time", "u", "y"]);
        let (u, y) = (s(&["u"])[0].clone(), s(&["y"])[0].clone());
        let wanted = [&y, &u];
        for fortran in [false, true] {
            let mut data = table(50);
            let path = file(
                &format!("blk-{fortran}.npy"),
                &npy(1, "<f8", fortran, "(50, 3)", 50, &data),
            );
            let mut rows = Vec::new();
            scan_rows(&path, &names, &wanted, 0..1, None, |r| {
                rows.push(r.to_vec());
                Ok(true)
            })
            .unwrap();
            for block in [1, 7, 50, 64] {
                let mut got = Vec::new();
                let (n, ts) = scan_blocks(&path, &names, &wanted, 0..1, None, block, |c, n| {
                    assert!(n <= block);
                    got.extend((0..n).map(|i| vec![c[i], c[n + i]]));
                    Ok(n)
                })
                .unwrap();
                assert_eq!((n, ts, &got), (50, 0.5, &rows));
            }
            // An infinite input at row 23: rows 0..23 delivered, then the error.
            data[3 * 23 + 1] = f64::INFINITY;
            let path = file(
                &format!("blk-inf-{fortran}.npy"),
                &npy(1, "<f8", fortran, "(50, 3)", 50, &data),
            );
            let mut seen = 0;
            let e = scan_blocks(&path, &names, &wanted, 0..1, None, 10, |_, n| {
                seen += n;
                Ok(n)
            })
            .unwrap_err()
            .to_string();
            assert_eq!(seen, 23);
            assert!(
                e.contains("row 23, column 'u': value inf is not finite"),
                "{e}"
            );
            // A visitor that stops at row 15 of 50: no error from row 23.
            let mut blocks = 0;
            let (n, _) = scan_blocks(&path, &names, &wanted, 0..1, None, 10, |_, n| {
                blocks += 1;
                Ok(if blocks == 2 { 5 } else { n })
            })
            .unwrap();
            assert_eq!((n, blocks), (15, 2));
            seen = 0;
            // A time step out of order at row 31 is found as row by row.
            data[3 * 23 + 1] = 0.0;
            data[3 * 31] = 100.0;
            let path = file(
                &format!("blk-t-{fortran}.npy"),
                &npy(1, "<f8", fortran, "(50, 3)", 50, &data),
            );
            let e = scan_blocks(&path, &names, &wanted, 0..1, None, 8, |_, n| {
                seen += n;
                Ok(n)
            })
            .unwrap_err()
            .to_string();
            assert_eq!(seen, 31);
            assert!(e.contains("row 31, column 'time'"), "{e}");
        }
    }

    /// Every error message of the reader.
    #[test]
    fn each_error_message() {
        let names = s(&["t", "u", "y"]);
        let (u, y) = (&names[1], &names[2]);
        let run = |bytes: &[u8], name: &str| -> String {
            let path = file(name, bytes);
            read_raw(&path, &names, &[u, y], 1..2, None)
                .err()
                .unwrap()
                .to_string()
                .replace(&path, "F")
        };
        let good = npy(1, "<f8", false, "(4, 3)", 4, &table(4));
        let mut bad = good.clone();
        bad[1] = b'X';
        assert_eq!(
            run(&bad, "magic.npy"),
            "F: not a .npy file (bad magic: the file must start with \\x93NUMPY)"
        );
        assert_eq!(
            run(b"\x93NU", "short.npy"),
            "F: not a .npy file (shorter than the magic string)"
        );
        let mut v4 = good.clone();
        v4[6] = 4;
        assert_eq!(
            run(&v4, "v4.npy"),
            "F: unsupported .npy format version 4.0 (1.0, 2.0 and 3.0 are read)"
        );
        assert_eq!(
            run(&good[..40], "cut.npy"),
            "F: not a .npy file (truncated header)"
        );
        let i8 = npy(1, "<i8", false, "(4, 3)", 4, &table(4));
        assert_eq!(
            run(&i8, "i8.npy"),
            "F: unsupported dtype '<i8' (float64 '<f8' or float32 '<f4' are read; convert with a.astype('<f8'))"
        );
        let one = npy(1, "<f8", false, "(12,)", 12, &table(4));
        assert_eq!(
            run(&one, "1d.npy"),
            "F: the array has shape (12,): a 2-D array (rows × columns) is needed"
        );
        let three = npy(1, "<f8", false, "(2, 2, 3)", 4, &table(4));
        assert_eq!(
            run(&three, "3d.npy"),
            "F: the array has shape (2, 2, 3): a 2-D array (rows × columns) is needed"
        );
        let empty = npy(1, "<f8", false, "(0, 3)", 0, &[]);
        assert_eq!(
            run(&empty, "empty.npy"),
            "F: the array has shape (0, 3): no data"
        );
        assert_eq!(
            run(&good[..good.len() - 5], "trunc.npy"),
            "F: truncated data: the header declares 4 × 3 values of 8 bytes (96 bytes), the file holds 91 bytes after the header"
        );
        let mut weird = good.clone();
        let at = weird.windows(7).position(|w| w == b"'shape'").unwrap();
        weird[at + 5] = b'X';
        let e = run(&weird, "noshape.npy");
        assert!(
            e.starts_with("F: bad .npy header (no 'shape'): {'descr'"),
            "{e}"
        );
        let mut data = table(4);
        data[3 + 1] = f64::NAN;
        assert_eq!(
            run(&npy(1, "<f8", false, "(4, 3)", 4, &data), "nan_u.npy"),
            "F: row 1, column 'u': value NaN is not finite (NaN/inf are not allowed here; NaN marks an unsampled output and is allowed in output columns only)"
        );
        let mut data = table(4);
        data[3 * 2 + 2] = f64::INFINITY;
        assert_eq!(
            run(&npy(1, "<f8", false, "(4, 3)", 4, &data), "inf_y.npy"),
            "F: row 2, column 'y': value inf is not finite (only NaN, marking an unsampled output, is allowed)"
        );
        let mut data = table(4);
        data[3 * 3] = 1.7;
        assert_eq!(
            run(&npy(1, "<f8", true, "(4, 3)", 4, &data), "time.npy"),
            "F: row 3, column 't': time 1.7 is 0.7 after the row before, not the spacing 0.5 of the rows so far (within 10 %): a missing, repeated or out-of-order row? give --ts to ignore the time column"
        );
        let mut data = table(4);
        data[0] = f64::NAN;
        assert_eq!(
            run(&npy(1, "<f8", false, "(4, 3)", 4, &data), "nan_t.npy"),
            "F: row 0, column 't': value NaN is not finite (NaN/inf are not allowed here; NaN marks an unsampled output and is allowed in output columns only)"
        );
        let missing = file("missing.npy", b"");
        std::fs::remove_file(&missing).unwrap();
        let e = header(&missing, &[]).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("cannot open data file {missing}: ")),
            "{e}"
        );
    }

    /// The header parser on the dicts numpy writes (and a few it might).
    #[test]
    fn header_dicts() {
        let t = "{'descr': '<f8', 'fortran_order': False, 'shape': (3, 2), }";
        assert_eq!(dict_value(t, "descr"), Some("'<f8'"));
        assert_eq!(dict_value(t, "fortran_order"), Some("False"));
        assert_eq!(dict_value(t, "shape"), Some("(3, 2)"));
        assert_eq!(parse_shape("(3, 2)"), Some(vec![3, 2]));
        assert_eq!(parse_shape("(7,)"), Some(vec![7]));
        assert_eq!(parse_shape("()"), Some(vec![]));
        assert_eq!(parse_shape("(3L, 2L)"), Some(vec![3, 2]));
        assert_eq!(parse_shape("(a, 2)"), None);
        let t =
            "{\"descr\": [('a', '<f8'), ('b', '<f8')], \"fortran_order\": False, \"shape\": (3,)}";
        assert_eq!(dict_value(t, "descr"), Some("[('a', '<f8'), ('b', '<f8')]"));
        assert_eq!(dict_value(t, "shape"), Some("(3,)"));
    }
}

//! Time ranges of a record for estimation and validation. The rows of a
//! range are written as a CSV file of their own (the header and those
//! rows, field for field as in the record), so that the command line the
//! page shows (`--data rec_rows1000-3000.csv`) identifies on exactly the
//! data the studio used; the page offers that file for download.
//!
//! A time t is row ⌈t/T⌉ of the record (the plots draw row k at k T). For
//! a multirate selection the range is aligned to the frame L = lcm of the
//! selected outputs' periods and the input hold: it starts at a multiple
//! of L and holds a multiple of L rows, so every slow output keeps its
//! sampling offset and divides the length.

use std::path::{Path, PathBuf};

use crate::error::{CliResult, input};

/// Greatest common divisor.
fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// The rows `[k0, k1)` of the time range `[t0, t1]` (seconds) of a record
/// of `rows` rows with base period `ts`, aligned to the frame `align`
/// (see the module documentation).
///
/// Errors (named for `what`, e.g. "estimation range"): times that are not
/// finite or not increasing, a range outside the record, fewer than two
/// frames of rows.
pub fn rows_of_range(
    range: [f64; 2],
    ts: f64,
    rows: usize,
    align: usize,
    what: &str,
) -> CliResult<(usize, usize)> {
    let [t0, t1] = range;
    if !(t0.is_finite() && t1.is_finite() && t0 < t1) {
        return Err(input(format!(
            "{what} [{t0}, {t1}]: two finite times t0 < t1 in seconds"
        )));
    }
    if !(ts.is_finite() && ts > 0.0) {
        return Err(input(format!(
            "{what}: the base period {ts} is not positive"
        )));
    }
    let end = (rows.saturating_sub(1)) as f64 * ts;
    if t0 < -0.5 * ts || t1 > end + 0.5 * ts {
        return Err(input(format!(
            "{what} [{t0}, {t1}] s lies outside the record (0 to {end} s)"
        )));
    }
    let align = align.max(1);
    // Row k is drawn at k T: the first row at or after t0, the last at or
    // before t1 (a rounding of 1e-9 rows forgiven).
    let k0 = ((t0 / ts) - 1e-9).ceil().max(0.0) as usize;
    let k1 = (((t1 / ts) + 1e-9).floor() as usize + 1).min(rows);
    let k0 = k0 / align * align;
    let len = k1.saturating_sub(k0) / align * align;
    if len < 2 * align || len < 2 {
        return Err(input(format!(
            "{what} [{t0}, {t1}] s holds {} rows: at least {} are needed{}",
            k1.saturating_sub(k0),
            (2 * align).max(2),
            if align > 1 {
                format!(" (two frames of {align} rows, the lcm of the output periods and the hold)")
            } else {
                String::new()
            }
        )));
    }
    Ok((k0, k0 + len))
}

/// The frame of a selection: the lcm of `periods` and `hold`.
pub fn frame(periods: impl Iterator<Item = usize>, hold: usize) -> usize {
    periods
        .chain(std::iter::once(hold))
        .filter(|p| *p > 0)
        .fold(1, |l, p| l / gcd(l, p) * p)
}

/// The file of rows `[k0, k1)` of the CSV record `src` (named `name`) in
/// `folder`: `<stem>_rows<k0>-<k1>.csv`, written once (the header and the
/// rows' fields as they are in `src`). Returns its name and path.
///
/// Errors: the record cannot be read or the file written.
pub fn slice_file(
    src: &Path,
    folder: &Path,
    name: &str,
    k0: usize,
    k1: usize,
) -> CliResult<(String, PathBuf)> {
    let stem = name.strip_suffix(".csv").unwrap_or(name);
    let file = format!("{stem}_rows{k0}-{k1}.csv");
    let path = folder.join(&file);
    if path.exists() {
        return Ok((file, path));
    }
    let read = |e: csv::Error| input(format!("{name}: {e}"));
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_path(src)
        .map_err(read)?;
    let tmp = folder.join(format!(".{file}.part"));
    let mut writer =
        csv::Writer::from_path(&tmp).map_err(|e| input(format!("cannot write {file}: {e}")))?;
    let write = |e: csv::Error| input(format!("cannot write {file}: {e}"));
    for (i, rec) in reader.byte_records().enumerate() {
        let rec = rec.map_err(read)?;
        // Row 0 is the header; data row k is record k + 1.
        if i == 0 || (k0 + 1..k1 + 1).contains(&i) {
            writer.write_byte_record(&rec).map_err(write)?;
        }
        if i >= k1 {
            break;
        }
    }
    writer
        .flush()
        .map_err(|e| input(format!("cannot write {file}: {e}")))?;
    drop(writer);
    std::fs::rename(&tmp, &path).map_err(|e| input(format!("cannot write {file}: {e}")))?;
    Ok((file, path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_become_aligned_rows() {
        // T = 0.1 s, 100 rows: 1.0 … 2.0 s is rows 10 … 20 (11 rows).
        assert_eq!(
            rows_of_range([1.0, 2.0], 0.1, 100, 1, "r").unwrap(),
            (10, 21)
        );
        // Frame 5: start down to 10, length down to 10 rows.
        assert_eq!(
            rows_of_range([1.2, 2.3], 0.1, 100, 5, "r").unwrap(),
            (10, 20)
        );
        assert_eq!(frame([2usize, 3].into_iter(), 4), 12);
        assert_eq!(frame(std::iter::empty(), 1), 1);
        for bad in [[2.0, 1.0], [f64::NAN, 1.0], [0.0, 50.0], [1.0, 1.05]] {
            let e = rows_of_range(bad, 0.1, 100, 1, "estimation range").unwrap_err();
            assert!(e.to_string().contains("estimation range"), "{e}");
        }
    }

    #[test]
    fn a_slice_holds_the_header_and_its_rows() {
        let dir = std::env::temp_dir().join(format!("lifted-ranges-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let src = dir.join("rec.csv");
        std::fs::write(&src, "t,u1,y1\n0,1,2\n0.1,-1,3\n0.2,1,\"4\"\n0.3,1,5\n").unwrap();
        let (name, path) = slice_file(&src, &dir, "rec.csv", 1, 3).unwrap();
        assert_eq!(name, "rec_rows1-3.csv");
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            "t,u1,y1\n0.1,-1,3\n0.2,1,4\n"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

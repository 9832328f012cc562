//! Unit tests of the readers: the fast path, `csv-core` and the parallel
//! scan give the same rows, checks and messages.
//!
//! Long file: the readers' three paths (the fast path, `csv-core`, the
//! parallel scan) are checked against each other on the same tables; the
//! tables and their expected rows are shared by every test here.

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
    mut visit: impl FnMut(&[f64]) -> crate::Result<bool>,
) -> crate::Result<(usize, f64)> {
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
        let trailing = rec.len() == width + 1 && rec.get(width).is_some_and(<[u8]>::is_empty);
        if rec.len() != width && !trailing {
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
            "F: line 4, column 't': time 0.25 is 0.15 after the row before, not the spacing 0.1 of the rows so far (within 10 %): a missing, repeated or out-of-order row? give --ts to ignore the time column"
        );
        assert_eq!(
            err(&t("t,u1,y1\n0,1,2\n0.1,1,2\n"), &["t", "y1"], 1..2, None),
            "F: 't' is the time column (the base period is read from it), not an input or output; give --ts to read it as data"
        );
        // Times as loggers round them (milliseconds at 30 Hz) or single
        // precision stores them: the period from the whole column.
        let rounded: String = (0..90)
            .map(|k| format!("{:.3},1,{}\n", k as f64 / 30.0, k % 7))
            .collect();
        let scan = |text: &str| {
            let path = file("times.csv", text.as_bytes());
            let (rows, ts, _) = run(&path, io, 1..2, None, Some(Mode::default())).expect("read");
            (rows, f64::from_bits(ts))
        };
        let (rows, ts) = scan(&t(&format!("t,u1,y1\n{rounded}")));
        assert_eq!(rows, 90);
        assert!((ts - 1.0 / 30.0).abs() < 1e-5, "{ts}");
        let single: String = (0..50)
            .map(|k| format!("{},1,{}\n", (k as f32 * 0.08f32) as f64, k % 5))
            .collect();
        let (_, ts) = scan(&t(&format!("t,u1,y1\n{single}")));
        assert!((ts - 0.08).abs() < 1e-7, "{ts}");
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
    let text = "\u{feff}\"t\",u1,y1\r\n\r\n0, 1 ,\"2\"\r\n\n0.5,\"-2.5e-3\",\r\n1,1E5,\"a\nb\"\r\n";
    let path = file("q.csv", text.as_bytes());
    let e = run(&path, &["u1", "y1"], 1..2, None, Some(Mode::default())).unwrap_err();
    assert_eq!(
        e.replace(&path, "F"),
        // The newline in the cell is shown escaped (one-line messages).
        "F: line 6, column 'y1': cannot parse 'a\\nb' as a number"
    );
    let text =
        "\u{feff}\"t\",u1,y1\r\n\r\n0, 1 ,\"2\"\r\n\n0.5,\"-2.5e-3\",\r\n1,1E5,\"\"\"3\"\"\"\r\n";
    let path = file("q2.csv", text.as_bytes());
    let e = run(&path, &["u1", "y1"], 1..2, None, Some(Mode::default())).unwrap_err();
    assert_eq!(
        e.replace(&path, "F"),
        "F: line 6, column 'y1': cannot parse '\"3\"' as a number"
    );
    let text = "t,u1,y1\r\n\r\n0, 1 ,\"2\"\r\n\n0.5,\"-2.5e-3\",\r\n1,1E5,\t3 \r\n";
    let path = file("q3.csv", text.as_bytes());
    let (rows, ts, seen) = run(&path, &["u1", "y1"], 1..2, None, Some(Mode::default())).unwrap();
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

#[test]
fn header_units_are_not_part_of_the_name() {
    use super::columns::bare_name;
    // lifted writes `name [unit]` headers; `--inputs u1` selects them, and
    // `t [s]` is the time column (its 0.5 s spacing is the base period).
    let text = "t [s],u1 [V],y1 [degC]\n0,1,2\n0.5,3,4\n";
    let path = file("units.csv", text.as_bytes());
    let (rows, ts, seen) = run(&path, &["u1", "y1"], 1..2, None, Some(Mode::default())).unwrap();
    assert_eq!((rows, f64::from_bits(ts)), (2, 0.5));
    assert_eq!(seen[1], [3.0f64.to_bits(), 4.0f64.to_bits()]);
    // The exact name wins over a bare one; names without a unit stay.
    assert_eq!(bare_name("y1 [degC]"), "y1");
    assert_eq!(bare_name("flow [m3/h] "), "flow");
    assert_eq!(bare_name("[x]"), "[x]");
    assert_eq!(bare_name("y[1]"), "y[1]");
    let header: Vec<String> = ["y1 [V]", "y1"].iter().map(|s| s.to_string()).collect();
    let y1 = "y1".to_string();
    assert_eq!(column_indices("F", &header, &[&y1]).unwrap(), [1]);
}

#[test]
fn semicolon_and_tab_separated_files_read_as_the_comma_file() {
    // A spreadsheet export with decimal commas, a tab-separated logger
    // file and the comma file: the same rows, period and messages (line
    // numbers of the file itself).
    let comma = "t,u1,y1\n0,1.5,\n0.25,-2,3.75\n0.5,1e3,4\n";
    let semi = "\u{feff}t;u1;y1\r\n0;1,5;\r\n0,25;-2;3,75\r\n0,5;1e3;4\r\n";
    let tab = "t\tu1\ty1\n0\t1.5\t\n0.25\t-2\t3.75\n0.5\t1e3\t4\n";
    let want = run(
        &file("c.csv", comma.as_bytes()),
        &["u1", "y1"],
        1..2,
        None,
        None,
    )
    .unwrap();
    for (name, text) in [("s.csv", semi), ("tab.csv", tab)] {
        let path = file(name, text.as_bytes());
        assert!(separator(&path).unwrap().is_some(), "{name}");
        for mode in [
            Some(Mode::default()),
            Some(sequential()),
            Some(parallel(2, 8)),
        ] {
            assert_eq!(
                run(&path, &["u1", "y1"], 1..2, None, mode).unwrap(),
                want,
                "{name}"
            );
        }
    }
    let path = file("c2.csv", comma.as_bytes());
    assert_eq!(separator(&path).unwrap(), None);
    // Blank-separated (DaISy's files, MATLAB's `save -ascii`, with a header
    // row): runs of spaces and tabs, blanks at the line ends, blank lines.
    let full = "t,u1,y1\n0,1.5,2\n0.25,-2,3.75\n0.5,1e3,4\n";
    let want_full = run(
        &file("f.csv", full.as_bytes()),
        &["u1", "y1"],
        1..2,
        None,
        None,
    )
    .unwrap();
    let blank = "  t   u1  y1 \n 0  1.5   2 \r\n0.25\t-2  3.75\n\n   0.5 1e3\t \t4\n";
    let path = file("blank.txt", blank.as_bytes());
    assert_eq!(separator(&path).unwrap(), Some(Separator::Blanks));
    for mode in [
        Some(Mode::default()),
        Some(sequential()),
        Some(parallel(2, 8)),
    ] {
        assert_eq!(
            run(&path, &["u1", "y1"], 1..2, None, mode).unwrap(),
            want_full
        );
    }
    // A separator closing every row (DaISy's tab-separated files end their
    // lines with a tab; some exports with a comma): the same rows.
    let trailing_comma = "t,u1,y1\n0,1.5,2,\n0.25,-2,3.75,\n0.5,1e3,4,\n";
    let trailing_tab = "t\tu1\ty1\n 0\t  1.5\t 2\t\n0.25\t-2\t3.75\t\n0.5\t1e3\t4\t\n";
    for (name, text) in [("tc.csv", trailing_comma), ("tt.txt", trailing_tab)] {
        let path = file(name, text.as_bytes());
        for mode in [
            Some(Mode::default()),
            Some(sequential()),
            Some(parallel(2, 8)),
        ] {
            assert_eq!(
                run(&path, &["u1", "y1"], 1..2, None, mode).unwrap(),
                want_full,
                "{name}"
            );
        }
    }
    // A bad cell is located in the file as it is.
    let path = file("s_bad.csv", "t;u1;y1\n0;1;2\n1;x;3\n".as_bytes());
    let e = run(&path, &["u1", "y1"], 1..2, None, Some(Mode::default())).unwrap_err();
    assert_eq!(
        e.replace(&path, "F"),
        "F: line 3, column 'u1': cannot parse 'x' as a number"
    );
}

#[test]
fn iso_time_stamps_give_the_base_period() {
    // A historian's export: stamps every 0.5 s across midnight, in every
    // read mode the rows and T = 0.5 s of the file in seconds.
    let secs = "t,u1,y1\n0,1,2\n0.5,3,4\n1,5,6\n1.5,7,8\n";
    let want = run(
        &file("secs.csv", secs.as_bytes()),
        &["u1", "y1"],
        1..2,
        None,
        None,
    )
    .unwrap();
    let stamps = "time,u1,y1\n2026-11-26T23:59:59,1,2\n2026-11-26 23:59:59.5,3,4\n\
                  2026-11-27T00:00:00Z,5,6\n2026-11-27T00:00:00.500,7,8\n";
    let path = file("stamps.csv", stamps.as_bytes());
    for mode in [
        Some(Mode::default()),
        Some(sequential()),
        Some(parallel(2, 16)),
    ] {
        assert_eq!(run(&path, &["u1", "y1"], 1..2, None, mode).unwrap(), want);
    }
    // A stamp off the spacing, and a cell that is no time.
    let jitter = stamps.replace("00:00:00Z", "00:00:00.2Z");
    let path = file("jitter.csv", jitter.as_bytes());
    let e = run(&path, &["u1", "y1"], 1..2, None, Some(Mode::default())).unwrap_err();
    assert!(
        e.contains("line 4, column 'time'") && e.contains("not the spacing"),
        "{e}"
    );
    let path = file("bad_time.csv", "t,u1,y1\n0,1,2\n1 s,3,4\n".as_bytes());
    let e = run(&path, &["u1", "y1"], 1..2, None, Some(Mode::default())).unwrap_err();
    assert!(e.contains("cannot parse '1 s' as a time"), "{e}");
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
            e.starts_with(&format!("F: line {}, column 't': time 0 is ", k + 1)),
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

#[test]
fn an_output_period_of_a_column_whose_name_holds_an_equals_sign() {
    let p = parse_periods(&["title='X'=3".to_string(), "y2=5".to_string()]).unwrap();
    assert_eq!(p, vec![("title='X'".to_string(), 3), ("y2".to_string(), 5)]);
}

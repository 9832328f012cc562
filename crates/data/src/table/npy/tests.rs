use super::*;
use crate::table::{DataSpec, load, read_raw};

/// A `.npy` file by hand: magic, version, header dict padded to 64
/// bytes, then `data` (row-major values, written in `fortran` order if
/// asked) as `descr`.
fn npy(version: u8, descr: &str, fortran: bool, shape: &str, rows: usize, data: &[f64]) -> Vec<u8> {
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

/// A record's blocks decoded into its (u, y) matrices: the rows of the
/// row-by-row reading in every block length, the rows before an
/// infinite input delivered as a shorter block of their own, then the
/// error; a visitor's stop and its error returned as such.
#[test]
fn record_blocks_are_the_rows_in_u_and_y() {
    let names = s(&["time", "u", "y"]);
    let (u, y) = (s(&["u"])[0].clone(), s(&["y"])[0].clone());
    let wanted = [&u, &y];
    for fortran in [false, true] {
        let mut data = table(50);
        let path = file(
            &format!("rec-{fortran}.npy"),
            &npy(1, "<f8", fortran, "(50, 3)", 50, &data),
        );
        let mut rows = Vec::new();
        scan_rows(&path, &names, &wanted, 1..2, None, |r| {
            rows.push(r.to_vec());
            Ok(true)
        })
        .unwrap();
        for block in [1, 7, 50, 64] {
            let mut got = Vec::new();
            let (n, ts) =
                scan_record_blocks::<()>(&path, &names, &wanted, 1, 1..2, None, block, |ub, yb| {
                    assert!(ub.nrows() <= block && ub.nrows() == yb.nrows());
                    got.extend((0..ub.nrows()).map(|i| vec![ub[(i, 0)], yb[(i, 0)]]));
                    Ok(true)
                })
                .unwrap();
            assert_eq!((n, ts, &got), (50, 0.5, &rows));
        }
        data[3 * 23 + 1] = f64::INFINITY;
        let path = file(
            &format!("rec-inf-{fortran}.npy"),
            &npy(1, "<f8", fortran, "(50, 3)", 50, &data),
        );
        let mut sizes = Vec::new();
        let e = scan_record_blocks::<()>(&path, &names, &wanted, 1, 1..2, None, 10, |ub, _| {
            sizes.push(ub.nrows());
            Ok(true)
        });
        assert_eq!(sizes, [10, 10, 3]);
        assert!(
            matches!(&e, Err(BlockStop::Read(e)) if e.to_string().contains("row 23, column 'u'")),
            "{e:?}"
        );
        let mut calls = 0;
        let stopped = scan_record_blocks(&path, &names, &wanted, 1, 1..2, None, 10, |_, _| {
            calls += 1;
            if calls == 2 { Err("enough") } else { Ok(true) }
        });
        assert!(matches!(stopped, Err(BlockStop::Visit("enough"))));
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
    let t = "{\"descr\": [('a', '<f8'), ('b', '<f8')], \"fortran_order\": False, \"shape\": (3,)}";
    assert_eq!(dict_value(t, "descr"), Some("[('a', '<f8'), ('b', '<f8')]"));
    assert_eq!(dict_value(t, "shape"), Some("(3,)"));
}

use super::*;

/// Writes `cols` as a float64 `.npy` file by hand (numpy's format 1.0:
/// magic, version, header length, the header dict padded with spaces to
/// a multiple of 64 bytes and ended by a newline, then the data,
/// row-major or column-major).
fn write_npy(path: &str, cols: &[Vec<f64>], fortran: bool) {
    let rows = cols[0].len();
    let dict = format!(
        "{{'descr': '<f8', 'fortran_order': {}, 'shape': ({rows}, {}), }}",
        if fortran { "True" } else { "False" },
        cols.len()
    );
    let pad = (64 - (10 + dict.len() + 1) % 64) % 64;
    let header = format!("{dict}{}\n", " ".repeat(pad));
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend((header.len() as u16).to_le_bytes());
    out.extend(header.as_bytes());
    if fortran {
        for c in cols {
            for v in c {
                out.extend(v.to_le_bytes());
            }
        }
    } else {
        for k in 0..rows {
            for c in cols {
                out.extend(c[k].to_le_bytes());
            }
        }
    }
    std::fs::write(path, out).unwrap();
}

/// Issue 30: `--columns` naming a column twice is an error naming it
/// and both positions (the first one would otherwise win silently).
#[test]
fn duplicate_columns_names_are_rejected() {
    let d = tmp("npy-dup");
    let f = p(&d, "three.npy");
    let cols = vec![
        (0..50).map(|k| k as f64).collect::<Vec<_>>(),
        (0..50).map(|k| (k % 2) as f64).collect(),
        (0..50).map(|k| (k % 3) as f64).collect(),
    ];
    write_npy(&f, &cols, false);
    let e = fails(
        &[
            "identify",
            "--method",
            "n4sid",
            "--data",
            &f,
            "--columns",
            "t,u1,u1",
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--out",
            &p(&d, "x.json"),
        ],
        2,
    );
    assert!(
        e.contains("--columns") && e.contains("'u1' appears twice (positions 2 and 3)"),
        "{e}"
    );
}

/// The model matrices and base period of a model file.
fn matrices(path: &str) -> Vec<serde_json::Value> {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let m = &v["model"];
    ["a", "b", "c", "d", "ts"]
        .iter()
        .map(|k| m[*k].clone())
        .collect()
}

#[test]
fn npy_identifies_as_the_csv() {
    let d = tmp("npy");
    let (csv, val) = single_rate_data(&d);
    let (head, cols) = read_csv(&csv);
    assert_eq!(head, ["t", "u1", "y1"]);
    let c_order = p(&d, "id.npy");
    write_npy(&c_order, &cols, false);
    let f_order = p(&d, "id_f.npy");
    write_npy(&f_order, &cols, true);
    let run = |data: &str, out: &str, extra: &[&str]| {
        let mut args = vec![
            "identify",
            "--method",
            "n4sid",
            "--data",
            data,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--columns",
            "t,u1,y1",
            "--order",
            "2",
            "--out",
            out,
        ];
        args.extend_from_slice(extra);
        ok(&args);
        matrices(out)
    };
    // streamed (single-rate n4sid) and in memory (linear detrending)
    for extra in [&[][..], &["--detrend", "linear"][..]] {
        let want = run(&csv, &p(&d, "csv.json"), extra);
        assert_eq!(run(&c_order, &p(&d, "c.json"), extra), want, "{extra:?}");
        assert_eq!(run(&f_order, &p(&d, "f.json"), extra), want, "{extra:?}");
    }
    check_model(&p(&d, "c.json"), 0.01);
    // validate reads it too: the same table as from the CSV
    let val_npy = p(&d, "val.npy");
    write_npy(&val_npy, &read_csv(&val).1, false);
    let model = p(&d, "c.json");
    let from_npy = ok(&[
        "validate",
        "--model",
        &model,
        "--data",
        &val_npy,
        "--columns",
        "t,u1,y1",
        "--min-fit",
        "90",
    ]);
    let from_csv = ok(&[
        "validate",
        "--model",
        &model,
        "--data",
        &val,
        "--min-fit",
        "90",
    ]);
    assert_eq!(from_npy, from_csv);
    // without --columns the columns are c0, c1, c2 and there is no time column
    let e = fails(
        &[
            "identify",
            "--method",
            "n4sid",
            "--data",
            &c_order,
            "--inputs",
            "c1",
            "--outputs",
            "c2",
            "--out",
            &p(&d, "x.json"),
        ],
        2,
    );
    assert!(e.contains("no time column") && e.contains("--ts"), "{e}");
    ok(&[
        "identify",
        "--method",
        "n4sid",
        "--data",
        &c_order,
        "--inputs",
        "c1",
        "--outputs",
        "c2",
        "--ts",
        "0.1",
        "--order",
        "2",
        "--out",
        &p(&d, "c012.json"),
    ]);
    assert_eq!(matrices(&p(&d, "c012.json")), matrices(&p(&d, "c.json")));
}

#[test]
fn multirate_npy_uses_nan_for_unsampled_outputs() {
    let d = tmp("npy_mr");
    let csv = p(&d, "mr.csv");
    simulate(&csv, rbs(3000, 5), 3, 1000.0, 6);
    let (_, cols) = read_csv(&csv);
    assert!(cols[2].iter().any(|v| v.is_nan()));
    let npy = p(&d, "mr.npy");
    write_npy(&npy, &cols, false);
    let run = |data: &str, out: &str| {
        ok(&[
            "identify",
            "--method",
            "n4sid",
            "--data",
            data,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--columns",
            "t,u1,y1",
            "--order",
            "2",
            "--out",
            out,
        ]);
        matrices(out)
    };
    assert_eq!(run(&npy, &p(&d, "n.json")), run(&csv, &p(&d, "c.json")));
    // NaN in an input column is an error naming the row and column
    let mut bad = cols.clone();
    bad[1][7] = f64::NAN;
    write_npy(&npy, &bad, false);
    let e = fails(
        &[
            "identify",
            "--method",
            "n4sid",
            "--data",
            &npy,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--columns",
            "t,u1,y1",
            "--out",
            &p(&d, "x.json"),
        ],
        2,
    );
    assert!(
        e.contains("mr.npy: row 7, column 'u1'") && e.contains("not finite"),
        "{e}"
    );
}

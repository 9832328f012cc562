use super::*;

fn write(dir: &Path, name: &str, text: &str) -> String {
    let f = p(dir, name);
    std::fs::write(&f, text).unwrap();
    f
}

fn identify(data: &str, extra: &[&str]) -> String {
    let out = format!("{data}.json");
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
        "--out",
        &out,
    ];
    args.extend_from_slice(extra);
    fails(&args, 2)
}

/// Without `--inputs`/`--outputs` the message lists the file's columns
/// and, for u…/y… names, the flags that name them (it said only
/// "--inputs NAME[,NAME…] is required").
#[test]
fn missing_channel_flags_list_the_files_columns() {
    let d = tmp("bad_channels");
    let f = write(&d, "named.csv", "t,u1,u2 [V],y1,y2\n0,1,2,3,4\n1,1,2,3,4\n");
    let out = p(&d, "m.json");
    let e = fails(&["identify", "--data", &f, "--out", &out], 2);
    assert!(e.contains("--inputs NAME[,NAME…] is required"), "{e}");
    assert!(e.contains("its columns: u1, u2 [V], y1, y2"), "{e}");
    assert!(e.contains("e.g. --inputs u1,u2 --outputs y1,y2"), "{e}");
    let e = fails(
        &["identify", "--data", &f, "--inputs", "u1", "--out", &out],
        2,
    );
    assert!(e.contains("--outputs NAME[,NAME…] is required"), "{e}");
    // Other names: the columns, no guess.
    let g = write(&d, "other.csv", "time,flow,level\n0,1,2\n1,1,2\n");
    let e = fails(&["identify", "--data", &g, "--out", &out], 2);
    assert!(e.contains("its columns: flow, level"), "{e}");
    assert!(!e.contains("e.g."), "{e}");
}

#[test]
fn each_bad_input_is_one_line_with_exit_code_2() {
    let d = tmp("bad");
    let missing = p(&d, "missing.csv");
    let e = identify(&missing, &[]);
    assert!(e.contains("missing.csv"), "{e}");

    let f = write(&d, "nocol.csv", "t,u1,y2\n0,1,2\n0.1,1,2\n");
    let e = identify(&f, &[]);
    assert!(e.contains("nocol.csv") && e.contains("'y1'"), "{e}");

    let f = write(&d, "text.csv", "t,u1,y1\n0,1,2\n0.1,abc,2\n");
    let e = identify(&f, &[]);
    assert!(
        e.contains("text.csv") && e.contains("line 3") && e.contains("'u1'") && e.contains("abc"),
        "{e}"
    );

    let f = write(&d, "nan.csv", "t,u1,y1\n0,1,2\n0.1,1,NaN\n");
    let e = identify(&f, &[]);
    assert!(
        e.contains("nan.csv")
            && e.contains("line 3")
            && e.contains("'y1'")
            && e.contains("not finite"),
        "{e}"
    );
    let f = write(&d, "inf.csv", "t,u1,y1\n0,inf,2\n0.1,1,1\n");
    let e = identify(&f, &[]);
    assert!(e.contains("line 2") && e.contains("'u1'"), "{e}");

    let f = write(&d, "ragged.csv", "t,u1,y1\n0,1,2\n0.1,1\n");
    let e = identify(&f, &[]);
    assert!(
        e.contains("ragged.csv") && e.contains("line 3") && e.contains("ragged"),
        "{e}"
    );

    let f = write(&d, "empty.csv", "");
    let e = identify(&f, &[]);
    assert!(e.contains("empty.csv") && e.contains("empty"), "{e}");
    let f = write(&d, "header_only.csv", "t,u1,y1\n");
    let e = identify(&f, &[]);
    assert!(e.contains("no data rows"), "{e}");

    // An output first sampled two periods after the start (an analyser
    // started late): the message says where and what to cut.
    let mut text = String::from("t,u1,y1\n");
    for k in 0..30 {
        let y = if k >= 7 && k % 3 == 1 { "1.5" } else { "" };
        text += &format!("{},{},{y}\n", k as f64 * 0.1, (k % 2) as f64);
    }
    let f = write(&d, "late.csv", &text);
    let e = identify(&f, &[]);
    assert!(
        e.contains("late.csv")
            && e.contains("first sample is missing")
            && e.contains("cut the rows before line 9"),
        "{e}"
    );

    // order above what the horizon allows
    let (id, _) = single_rate_data(&d);
    let e = identify(&id, &["--order", "50", "--horizon", "4"]);
    assert!(e.contains("order"), "{e}");

    // unknown method (a usage error)
    let e = fails(
        &[
            "identify",
            "--method",
            "magic",
            "--data",
            &id,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--out",
            "x.json",
        ],
        2,
    );
    assert!(e.contains("magic") && e.contains("n4sid"), "{e}");

    // bad model file
    let m = write(
        &d,
        "bad.json",
        "{\"kind\": \"state_space\", \"ts\": 0.1, \"a\": [[1, 2]]}",
    );
    let e = fails(&["step", "--model", &m, "--out", &p(&d, "s.csv")], 2);
    assert!(e.contains("bad.json"), "{e}");
}

#[test]
fn help_on_every_command() {
    for cmd in [
        "prbs",
        "rbs",
        "gbn",
        "gaussian",
        "multisine",
        "design",
        "simulate",
        "identify",
        "validate",
        "convert",
        "bode",
        "step",
        "report",
        "reproduce",
        "delay",
        "closedloop",
        "mpc",
        "robust",
        "analyze",
        "lqr",
    ] {
        let s = ok(&[cmd, "--help"]);
        assert!(s.contains("Usage: lifted"), "{cmd}: {s}");
    }
    assert!(ok(&["--help"]).contains("reproduce"));
    assert_eq!(lifted(&[]).status.code(), Some(2));
}

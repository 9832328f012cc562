//! `lifted studio`: its service (the session, without HTTP) and, in a real
//! headless Chromium driven over WebDriver (chromedriver + fantoccini), the
//! page itself: load a record, move the order slider from 1 to 2, check
//! that the fit and the plots change and that the saved model equals the
//! one `lifted identify` writes with the options the page shows; load a
//! ragged CSV and find the CLI's error in the page. Screenshots go to
//! `target/studio-screenshots/`. Issue 28: the slider pressed 50 ms apart
//! ends at the last order with everything shown and saved of that order;
//! an unstable model reads "n/a: unstable" without a script error; tabs
//! (and raw-request sessions) keep their own records and models
//! (screenshots in `target/screens/`).
//!
//! The browser test needs Debian's `chromium` and `chromium-driver` (or the
//! paths in `LIFTED_CHROMIUM` / `LIFTED_CHROMEDRIVER`). Without them it says
//! so and returns, unless `LIFTED_BROWSER_TESTS=require` (set by `.ci/run`,
//! which installs both), where their absence fails the test.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use fantoccini::{Client, Locator, key::Key};
use lifted_cli::studio::{MAX_JSON, MAX_SESSIONS, MAX_UPLOAD, Request, Session};
use lifted_prbs::{InversePrbs, InversePrbsOptions};
use serde_json::{Value, json};

#[path = "support/markup.rs"]
mod markup;

#[path = "support/browser.rs"]
mod browser;
use browser::*;

/// A fresh directory under the system temp dir.
fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lifted-studio-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A random binary input (xorshift, fixed seed).
fn binary_input(n: usize) -> Vec<f64> {
    let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            if s.is_multiple_of(2) { -1.0 } else { 1.0 }
        })
        .collect()
}

/// The CSV of the second-order plant x⁺ = A x + B u, y = C x + e driven by
/// `u`, with small deterministic noise e; with `slow`, y is sampled every
/// `slow` rows (empty cells between).
fn record_of(u: &[f64], slow: usize) -> String {
    let (mut x1, mut x2) = (0.0f64, 0.0f64);
    let mut out = String::from("t,u1,y1\n");
    for (k, &u) in u.iter().enumerate() {
        let e = 0.005 * ((k as f64 * 1.618_034).fract() - 0.5);
        let y = x1 + 0.5 * x2 + e;
        let cell = if k % slow == 0 {
            format!("{y:.9}")
        } else {
            String::new()
        };
        out += &format!("{},{u},{cell}\n", k as f64 * 0.1);
        (x1, x2) = (
            0.8 * x1 + 0.3 * x2 + 0.5 * u,
            -0.2 * x1 + 0.6 * x2 + 0.2 * u,
        );
    }
    out
}

/// The plant's record under a random binary input of `n` samples.
fn record(n: usize, slow: usize) -> String {
    record_of(&binary_input(n), slow)
}

fn request(order: &str) -> Request {
    Request {
        inputs: vec!["u1".into()],
        outputs: vec!["y1".into()],
        method: Some("n4sid".into()),
        order: Some(order.into()),
        ..Default::default()
    }
}

/// The model file without the facts that name the run (file path, times).
fn comparable(mut v: Value) -> Value {
    if let Some(d) = v.get_mut("diagnostics").and_then(Value::as_object_mut) {
        d.remove("profile");
        d.remove("data");
    }
    v
}

fn run_lifted(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_lifted"))
        .args(args)
        .output()
        .expect("the binary runs");
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs the command line the page shows (`lifted identify … --data NAME
/// … --out model.json`) with the record at `data` and the model file to
/// `out`. The studio quotes a word only when it holds a character outside
/// `[A-Za-z0-9-_=.,/:+]`; the test records need no quotes.
fn run_command_line(command: &str, data: &Path, out: &Path) {
    let words: Vec<&str> = command.split_whitespace().collect();
    assert_eq!(words.first(), Some(&"lifted"), "{command}");
    assert!(!command.contains('\''), "{command}");
    let mut args: Vec<String> = Vec::new();
    let mut it = words[1..].iter();
    while let Some(w) = it.next() {
        args.push(w.to_string());
        if *w == "--data" || *w == "--out" {
            it.next();
            args.push(
                if *w == "--data" { data } else { out }
                    .display()
                    .to_string(),
            );
        }
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    run_lifted(&args);
}

#[test]
fn session_identifies_like_the_command() {
    let dir = tmp("session");
    let mut s = Session::new(&dir).unwrap();
    let csv = record(1500, 1);
    let info = s.upload("rec.csv", csv.as_bytes()).unwrap();
    assert_eq!(info.rows, 1500);
    assert_eq!(info.suggested_inputs, ["u1"]);
    assert_eq!(info.suggested_outputs, ["y1"]);
    let one = s.identify(&request("1")).unwrap();
    let two = s.identify(&request("2")).unwrap();
    assert_eq!((one.order, two.order), (1, 2));
    // The plant is of order 2 with 1 % noise: order 2 fits far better.
    let fit = |id: &lifted_cli::studio::Identified| id.fits[0].fit.unwrap_or(f64::NAN);
    assert!(fit(&two) > 95.0, "order-2 fit {}", fit(&two));
    assert!(fit(&two) > fit(&one) + 5.0);
    assert_ne!(one.figures.response, two.figures.response);
    assert!(two.figures.order.as_deref().unwrap_or("").contains("<svg"));
    assert!(two.command.contains("--order 2"), "{}", two.command);

    let path = dir.join("rec.csv");
    std::fs::write(&path, &csv).unwrap();
    let out = dir.join("cli.json");
    run_command_line(&two.command, &path, &out);
    let cli: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let studio: Value = serde_json::from_str(&s.model_json(None).unwrap()).unwrap();
    assert_eq!(comparable(cli), comparable(studio));
    let report = s.report(None).unwrap();
    assert!(report.contains("<svg") && report.contains("rec.csv"));
    // The page's validation spares the 5-step predictions; the report
    // still has its table's 5-step fit (validated anew for it).
    assert!(two.fits[0].one_step.is_some());
    assert!(report.contains("fit % 5-step"));
    assert!(
        !report.contains("<td>n/a</td>"),
        "a fit missing from the report"
    );
    s.close();
}

/// Every string of the parts of an answer the page inserts as markup (the
/// SVG figures), each read as the page reads it (`innerHTML`): nothing in
/// it may run script. (The other fields, such as channel names, go in as
/// text nodes.)
fn assert_inert(answer: &Value, what: &str) {
    let mut strings = Vec::new();
    fn walk<'a>(v: &'a Value, out: &mut Vec<&'a str>) {
        match v {
            Value::String(s) if s.contains('<') => out.push(s),
            Value::Array(a) => a.iter().for_each(|x| walk(x, out)),
            Value::Object(o) => o.values().for_each(|x| walk(x, out)),
            _ => {}
        }
    }
    walk(answer, &mut strings);
    assert!(!strings.is_empty(), "{what}: no figure");
    for s in strings {
        let found = markup::script_vectors(s, true);
        assert!(found.is_empty(), "{what} can run script: {found:#?}");
    }
}

/// Issue 47: a record whose column and file names carry markup is shown,
/// identified and reported by the studio with the names as text only (the
/// answers' SVG figures and the saved report, parsed as a browser parses
/// them).
#[test]
fn session_shows_hostile_names_as_text() {
    let dir = tmp("hostile");
    let mut s = Session::new(&dir).unwrap();
    let (u, y) = (
        "u\"><img src=x onerror=alert(1)>",
        "y\"><script>document.title='X'</script>",
    );
    let csv = record(1200, 1).replacen(
        "t,u1,y1",
        &format!(
            "t,\"{}\",\"{}\"",
            u.replace('"', "\"\""),
            y.replace('"', "\"\"")
        ),
        1,
    );
    let info = s
        .upload("<svg onload=alert(1)>.csv", csv.as_bytes())
        .unwrap();
    let names: Vec<&str> = info.columns.iter().map(|c| c.name.as_str()).collect();
    assert!(names.contains(&u) && names.contains(&y), "{names:?}");
    let r = Request {
        inputs: vec![u.into()],
        outputs: vec![y.into()],
        method: Some("n4sid".into()),
        order: Some("2".into()),
        ..Default::default()
    };
    let view = s.view(&r).unwrap();
    let view = serde_json::to_value(&view).unwrap();
    assert_inert(
        &json!([view["inputs_svg"], view["outputs_svg"]]),
        "the channel view",
    );
    let id = s.identify(&r).unwrap();
    assert_inert(
        &serde_json::to_value(&id.figures).unwrap(),
        "the identification's figures",
    );
    let report = s.report(None).unwrap();
    let found = markup::script_vectors(&report, false);
    assert!(
        found.is_empty(),
        "the saved report can run script: {found:#?}"
    );
    assert!(markup::text_of(&report, false).contains(y));
    s.close();
}

/// The records of a 2-input, 1-output plant y = 0.5/(z − 0.7) u1 +
/// 0.3/(z + 0.4) u2 for q-Markov: one file per input, the other input 0,
/// each a PRBS of order 6 held one sample (four periods).
fn per_input_records() -> [String; 2] {
    let prbs = InversePrbs::new(&InversePrbsOptions {
        order: 6,
        amplitude: 1.0,
        hold: 1,
        taps: None,
    })
    .unwrap();
    let u = prbs.generate(4 * prbs.period() as usize);
    let file = |which: usize| {
        let (mut x1, mut x2) = (0.0f64, 0.0f64);
        let mut out = String::from("t,u1,u2,y1\n");
        for (k, &v) in u.iter().enumerate() {
            let (u1, u2) = if which == 0 { (v, 0.0) } else { (0.0, v) };
            let e = 0.002 * ((k as f64 * 1.618_034).fract() - 0.5);
            out += &format!("{},{u1},{u2},{:.9}\n", k as f64 * 0.1, x1 + x2 + e);
            (x1, x2) = (0.7 * x1 + 0.5 * u1, -0.4 * x2 + 0.3 * u2);
        }
        out
    };
    [file(0), file(1)]
}

/// Issue 28: q-Markov on one file per input: the record and a further
/// experiment are both `--data` of the command line, and the model equals
/// the one that command writes; a new record drops the experiment.
#[test]
fn session_takes_one_file_per_input_for_q_markov() {
    let dir = tmp("per-input");
    let mut s = Session::new(&dir).unwrap();
    let [a, b] = per_input_records();
    s.upload("u1.csv", a.as_bytes()).unwrap();
    s.upload_experiment("u2.csv", b.as_bytes()).unwrap();
    assert_eq!(s.experiments_info().len(), 1);
    let r = Request {
        inputs: vec!["u1".into(), "u2".into()],
        outputs: vec!["y1".into()],
        method: Some("qmarkov".into()),
        order: Some("2".into()),
        prbs_order: Some(6),
        q: Some(20),
        ..Default::default()
    };
    let id = s.identify(&r).unwrap();
    assert!(
        id.command.contains("--data u1.csv --data u2.csv"),
        "{}",
        id.command
    );
    std::fs::write(dir.join("u1.csv"), &a).unwrap();
    std::fs::write(dir.join("u2.csv"), &b).unwrap();
    let out = dir.join("cli.json");
    let mut args: Vec<String> = Vec::new();
    let words: Vec<&str> = id.command.split_whitespace().skip(1).collect();
    let mut it = words.iter();
    while let Some(w) = it.next() {
        args.push(w.to_string());
        if *w == "--data" || *w == "--out" {
            let v = it.next().unwrap();
            args.push(
                if *w == "--data" {
                    dir.join(v)
                } else {
                    out.clone()
                }
                .display()
                .to_string(),
            );
        }
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    run_lifted(&args);
    let cli: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let studio: Value = serde_json::from_str(&s.model_json(None).unwrap()).unwrap();
    assert_eq!(comparable(cli), comparable(studio));
    // Without the second file the cover has one file for two inputs.
    s.upload("u1.csv", a.as_bytes()).unwrap();
    assert!(s.experiments_info().is_empty());
    s.close();
}

/// The board through the session: keep by sequence number, a named error
/// for an unknown request or model, fits on the validation record, a kept
/// model whose channels a new record lacks stays (without fits), and its
/// model file is the one kept.
#[test]
fn session_board_keeps_compares_and_removes() {
    use lifted_cli::studio::BoardRequest;
    let dir = tmp("board-session");
    let mut s = Session::new(&dir).unwrap();
    s.upload("rec.csv", record(2000, 1).as_bytes()).unwrap();
    let mut r = request("2");
    r.seq = Some(1);
    s.identify(&r).unwrap();
    r.order = Some("1".into());
    r.seq = Some(2);
    s.identify(&r).unwrap();
    let e = s
        .board(&BoardRequest {
            add: Some(99),
            ..Default::default()
        })
        .unwrap_err();
    assert!(e.to_string().contains("no model of request 99"), "{e}");
    for seq in [1, 2] {
        s.board(&BoardRequest {
            add: Some(seq),
            ..Default::default()
        })
        .unwrap();
    }
    let other: Vec<f64> = binary_input(2333).split_off(333);
    s.upload_validation("val.csv", record_of(&other, 1).as_bytes())
        .unwrap();
    let b = s
        .board(&BoardRequest {
            selected: vec![1, 2],
            ..Default::default()
        })
        .unwrap();
    assert_eq!(b.data, "val.csv");
    assert_eq!(b.entries.len(), 2);
    let fit = |i: usize| b.entries[i].fits[0].1.unwrap();
    assert!(
        fit(0) > 95.0 && fit(0) > fit(1) + 5.0,
        "{} {}",
        fit(0),
        fit(1)
    );
    assert_eq!(b.response.len(), 1);
    assert!(b.step.is_some() && b.bode.is_some());
    let kept: Value = serde_json::from_str(&s.board_model_json(1).unwrap()).unwrap();
    assert_eq!(kept["a"].as_array().unwrap().len(), 2, "the order-2 model");
    let e = s
        .board(&BoardRequest {
            remove: Some(7),
            ..Default::default()
        })
        .unwrap_err();
    assert!(e.to_string().contains("no model #7"), "{e}");
    // A record without y1: the kept models stay, without fits.
    s.clear_validation();
    s.upload(
        "other.csv",
        b"t,u1,z\n0,1,2\n0.1,-1,3\n0.2,1,4\n".as_slice(),
    )
    .unwrap();
    let b = s.board(&BoardRequest::default()).unwrap();
    assert_eq!(b.entries.len(), 2);
    assert!(b.entries[0].fits.is_empty() && b.entries[0].label.contains("not on this data"));
    let b = s
        .board(&BoardRequest {
            remove: Some(1),
            ..Default::default()
        })
        .unwrap();
    assert_eq!(b.entries.len(), 1);
    s.close();
}

/// Issue 28: the parsed record and the subspace compression are kept
/// between slider moves (no new read, no new compression), made again when
/// the horizon or the detrending changes, and every model so made is the
/// one the page's command line writes (mean removal and no detrending,
/// N4SID and MOESP, fixed orders).
#[test]
fn session_keeps_the_record_and_the_compression_between_orders() {
    let dir = tmp("cache");
    let mut s = Session::new(&dir).unwrap();
    let csv = record(2000, 1);
    s.upload("rec.csv", csv.as_bytes()).unwrap();
    let path = dir.join("rec.csv");
    std::fs::write(&path, &csv).unwrap();
    let mut r = request("2");
    let first = s.identify(&r).unwrap();
    assert_eq!(s.cache_counts(), (1, 1));
    // The options that keep the command on the in-memory route are explicit.
    for w in ["--horizon 10", "--estimator shift", "--output-period y1=1"] {
        assert!(first.command.contains(w), "{w} missing: {}", first.command);
    }
    assert_eq!(
        (first.horizon, first.estimator.as_deref()),
        (Some(10), Some("shift"))
    );
    for order in ["3", "1", "2", "4"] {
        r.order = Some(order.into());
        s.identify(&r).unwrap();
    }
    assert_eq!(
        s.cache_counts(),
        (1, 1),
        "a slider move read or compressed again"
    );
    // The view of the same request reads nothing (the same explicit
    // options), nor does a move after it.
    s.view(&r).unwrap();
    s.identify(&r).unwrap();
    s.view(&r).unwrap();
    assert_eq!(s.cache_counts(), (1, 1));
    // The page's view (channels only) reads the columns once more (without
    // the explicit output periods), once.
    let channels = Request {
        inputs: r.inputs.clone(),
        outputs: r.outputs.clone(),
        ..Default::default()
    };
    s.view(&channels).unwrap();
    s.identify(&r).unwrap();
    s.view(&channels).unwrap();
    assert_eq!(s.cache_counts(), (2, 1));
    r.horizon = Some(8);
    s.identify(&r).unwrap();
    assert_eq!(s.cache_counts(), (2, 2), "a new horizon compresses again");
    let cases = [
        ("n4sid", None, "3"),
        ("moesp", Some("none"), "2"),
        ("n4sid", Some("none"), "2"),
    ];
    for (method, detrend, order) in cases {
        r.method = Some(method.into());
        r.detrend = detrend.map(String::from);
        r.order = Some(order.into());
        let id = s.identify(&r).unwrap();
        let out = dir.join(format!("cli-{method}-{order}.json"));
        run_command_line(&id.command, &path, &out);
        let cli: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        let studio: Value = serde_json::from_str(&s.model_json(None).unwrap()).unwrap();
        assert_eq!(comparable(cli), comparable(studio), "{}", id.command);
    }
    // No detrending: one compression more (the method is not part of it).
    assert_eq!(s.cache_counts(), (2, 3));
    // A new record starts over.
    s.upload("rec.csv", csv.as_bytes()).unwrap();
    s.identify(&r).unwrap();
    assert_eq!(s.cache_counts(), (3, 4));
    s.close();
}

/// Issue 47: a slider moved back to an order gets the model it got before
/// without identifying again (the same matrices, gain and fits), a new
/// order or method identifies, and a new validation record or further
/// experiment makes every order identify and validate anew.
#[test]
fn session_keeps_the_identifications_of_the_orders_seen() {
    let dir = tmp("kept-models");
    let mut s = Session::new(&dir).unwrap();
    let csv = record(2000, 1);
    s.upload("rec.csv", csv.as_bytes()).unwrap();
    let mut r = request("2");
    let two = s.identify(&r).unwrap();
    r.order = Some("3".into());
    s.identify(&r).unwrap();
    assert_eq!(s.identifications_run(), 2);
    r.order = Some("2".into());
    let again = s.identify(&r).unwrap();
    assert_eq!(s.identifications_run(), 2, "order 2 was identified again");
    assert_eq!(
        (&again.matrices.a, &again.matrices.k, &again.command),
        (&two.matrices.a, &two.matrices.k, &two.command)
    );
    let fits = |i: &lifted_cli::studio::Identified| -> Vec<Option<f64>> {
        i.fits.iter().map(|f| f.fit).collect()
    };
    assert_eq!(fits(&again), fits(&two));
    r.method = Some("moesp".into());
    s.identify(&r).unwrap();
    assert_eq!(s.identifications_run(), 3, "a new method must identify");
    // A validation record of its own: the kept validations are forgotten
    // (the fits are those on the new record).
    let other = record(1500, 1);
    s.upload_validation("val.csv", other.as_bytes()).unwrap();
    r.method = Some("n4sid".into());
    let on_other = s.identify(&r).unwrap();
    assert_eq!(s.identifications_run(), 4);
    assert_eq!(
        on_other.matrices.a, two.matrices.a,
        "the same estimation record"
    );
    assert_ne!(fits(&on_other), fits(&two), "validated on the old record");
    s.close();
}

/// Issue 47: a figure the page shows already (its digest sent back in
/// `have`) is not sent again; a figure that changed is, with its new
/// digest.
#[test]
fn session_sends_only_the_figures_that_changed() {
    let dir = tmp("digests");
    let mut s = Session::new(&dir).unwrap();
    s.upload("rec.csv", record(2000, 1).as_bytes()).unwrap();
    let mut r = request("2");
    let first = s.identify(&r).unwrap();
    assert!(first.unchanged.is_empty());
    assert_eq!(first.figure_digests.len(), 8, "{:?}", first.figure_digests);
    assert!(first.figures.bode.contains("<svg"));
    r.have = first.figure_digests.clone();
    let same = s.identify(&r).unwrap();
    assert_eq!(same.figure_digests, first.figure_digests);
    assert_eq!(same.unchanged.len(), 8, "{:?}", same.unchanged);
    assert!(same.figures.bode.is_empty() && same.figures.response.is_empty());
    r.order = Some("1".into());
    let other = s.identify(&r).unwrap();
    for slot in ["step", "bode", "pz", "response"] {
        assert!(!other.unchanged.contains(&slot.to_string()), "{slot}");
        assert_ne!(
            other.figure_digests[slot], first.figure_digests[slot],
            "{slot}"
        );
    }
    assert!(other.figures.bode.contains("<svg"));
    s.close();
}

/// A PI loop around y(t+1) = 1.6 y(t) − 0.73 y(t−1) + 0.5 u(t) + 0.3 u(t−1)
/// (second order), the controller acting on the noisy output, the
/// set-point a random ±1 level: a CSV `t,u1,y1,r1`.
fn closed_loop_csv(n: usize) -> String {
    let mut s = String::from("t,u1,y1,r1\n");
    let (mut x1, mut x2, mut xc, mut level) = (0.0, 0.0, 0.0, 1.0f64);
    let mut state = 12_345u64;
    let mut uniform = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for t in 0..n {
        if uniform() < 0.1 {
            level = -level;
        }
        let y = 0.5 * x1 + 0.3 * x2 + 0.3 * 12f64.sqrt() * (uniform() - 0.5);
        let e = level - y;
        let u = 0.05 * xc + 0.1 * e;
        xc += e;
        s += &format!("{t},{u},{y},{level}\n");
        (x1, x2) = (1.6 * x1 - 0.73 * x2 + u, x1);
    }
    s
}

/// Issue 46: the studio and the report say "closed loop detected" on a
/// record taken under feedback, with the warning that names the
/// consistent methods; an open-loop record gets the test's "no input
/// depends …" and no such warning.
#[test]
fn session_says_when_the_loop_is_closed() {
    let dir = tmp("feedback");
    let mut s = Session::new(&dir).unwrap();
    s.upload("loop.csv", closed_loop_csv(20_000).as_bytes())
        .unwrap();
    let mut r = request("2");
    r.refine = Some("none".into());
    let id = s.identify(&r).unwrap();
    let verdict = id.feedback.clone().unwrap_or_default();
    assert!(
        verdict.starts_with("closed loop detected: input u1 depends"),
        "{verdict}"
    );
    assert!(
        id.warnings
            .iter()
            .any(|w| w.contains("closed loop detected") && w.contains("pbsid")),
        "{:?}",
        id.warnings
    );
    let report = s.report(None).unwrap();
    let doc = scraper::Html::parse_document(&report);
    let items: Vec<String> = doc
        .select(&scraper::Selector::parse("ul.diagnostics li").unwrap())
        .map(|li| li.text().collect())
        .collect();
    assert!(
        items
            .iter()
            .any(|i| i.starts_with("Feedback: closed loop detected")),
        "{items:?}"
    );
    s.upload("rec.csv", record(20_000, 1).as_bytes()).unwrap();
    let id = s.identify(&request("2")).unwrap();
    let verdict = id.feedback.clone().unwrap_or_default();
    assert!(verdict.starts_with("no input depends"), "{verdict}");
    assert!(!id.warnings.iter().any(|w| w.contains("closed loop")));
    s.close();
}

#[test]
fn session_reports_bad_input_with_the_command_messages() {
    let dir = tmp("errors");
    let mut s = Session::new(&dir).unwrap();
    let e = s
        .upload("ragged.csv", b"t,u1,y1\n0,1,2\n0.1,1\n")
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "ragged.csv: line 3: 2 cells, the header has 3 (ragged row)"
    );
    let e = s.upload("x.csv", b"").unwrap_err().to_string();
    assert!(e.contains("x.csv: empty file"), "{e}");
    assert!(
        s.identify(&request("2"))
            .unwrap_err()
            .to_string()
            .contains("no data loaded")
    );
    s.upload("rec.csv", record(300, 1).as_bytes()).unwrap();
    let e = s.identify(&request("zero")).unwrap_err().to_string();
    assert!(e.contains("--order 'zero'"), "{e}");
    let mut r = request("2");
    r.method = Some("nonsense".into());
    let e = s.identify(&r).unwrap_err().to_string();
    assert!(e.contains("nonsense"), "{e}");
    let mut r = request("2");
    r.outputs = vec!["y9".into()];
    let e = s.view(&r).unwrap_err().to_string();
    assert!(e.starts_with("rec.csv: header has no column 'y9'"), "{e}");
    s.close();
}

#[test]
fn session_shows_slow_outputs_with_their_period() {
    let dir = tmp("slow");
    let mut s = Session::new(&dir).unwrap();
    let info = s.upload("slow.csv", record(1200, 3).as_bytes()).unwrap();
    let y = info.columns.iter().find(|c| c.name == "y1").unwrap();
    assert_eq!((y.samples, y.period), (400, Some(3)));
    let v = s.view(&request("auto")).unwrap();
    assert_eq!(v.outputs[0].period, 3);
    assert_eq!(v.outputs[0].samples, 400);
    // Slow samples are drawn as markers (dots), not as a polyline.
    assert!(v.outputs_svg.contains("class=\"dots\""));
    let id = s.identify(&request("2")).unwrap();
    let fit = id.fits[0].fit.unwrap_or(f64::NAN);
    assert!(fit > 90.0, "multirate fit {fit}");
    // The closed-loop method without an instrument on the slow record
    // (issue 46): the multirate prediction-error route, from the studio as
    // from the command.
    let mut pbsid = request("2");
    pbsid.method = Some("pbsid".into());
    let id = s.identify(&pbsid).unwrap();
    let fit = id.fits[0].fit.unwrap_or(f64::NAN);
    assert!(fit > 90.0, "multirate pbsid fit {fit}");
    assert!(id.command.contains("--method pbsid"), "{}", id.command);
    let model: Value = serde_json::from_str(&s.model_json(None).unwrap()).unwrap();
    let route = model["diagnostics"]["route"].as_str().unwrap_or_default();
    assert!(route.starts_with("multirate prediction error"), "{route}");
    s.close();
}

#[test]
fn session_moves_q_of_the_q_markov_cover() {
    let dir = tmp("qmarkov");
    let mut s = Session::new(&dir).unwrap();
    let prbs = InversePrbs::new(&InversePrbsOptions {
        order: 6,
        amplitude: 1.0,
        hold: 1,
        taps: None,
    })
    .unwrap();
    let u = prbs.generate(4 * prbs.period() as usize);
    s.upload("prbs.csv", record_of(&u, 1).as_bytes()).unwrap();
    let mut r = request("2");
    r.method = Some("qmarkov".into());
    r.prbs_order = Some(6);
    let mut fits = Vec::new();
    for q in [8, 20] {
        r.q = Some(q);
        let id = s.identify(&r).unwrap();
        let sel = id.order_selection.as_ref().unwrap();
        // Λ of eq. III-25 has one value per matched parameter: q l.
        assert_eq!(sel.values.len(), q, "q = {q}");
        assert!(id.command.contains(&format!("--q {q}")), "{}", id.command);
        fits.push(id.fits[0].fit.unwrap_or(f64::NAN));
    }
    // The cover matches q Markov and covariance parameters, not the
    // simulation error: 91.3 % (q = 8) and 91.2 % (q = 20) on this record.
    assert!(fits.iter().all(|f| *f > 85.0), "{fits:?}");
    // The output weighting Q is passed on (one output: any positive value).
    r.output_weight = vec![2.0];
    assert!(
        s.identify(&r)
            .unwrap()
            .command
            .contains("--output-weight 2")
    );
    r.output_weight = vec![-1.0];
    let e = s.identify(&r).unwrap_err().to_string();
    assert!(e.contains("--output-weight"), "{e}");
    s.close();
}

// ------------------------------------------------------------------- HTTP

/// An answer read off the socket.
struct Answer {
    status: u16,
    head: String,
    body: String,
}

impl Answer {
    fn header(&self, name: &str) -> Option<&str> {
        self.head.lines().find_map(|l| {
            let (k, v) = l.split_once(':')?;
            k.trim().eq_ignore_ascii_case(name).then_some(v.trim())
        })
    }

    /// The `error` of a JSON error answer (panics if it is not one).
    fn error(&self) -> String {
        assert_eq!(
            self.header("content-type"),
            Some("application/json"),
            "{} {}",
            self.status,
            self.body
        );
        let v: Value = serde_json::from_str(&self.body).expect("a JSON body");
        v["error"].as_str().expect("an error message").to_string()
    }
}

/// One raw HTTP/1.1 request on its own connection: `headers` as given (a
/// `Host` of 127.0.0.1:port and the `Content-Length` of `body` unless
/// given). The body is written by a second thread while the answer is read,
/// so a server that answers before reading it all (413) is seen.
fn raw(port: u16, method: &str, path: &str, headers: &[(&str, &str)], body: &[u8]) -> Answer {
    let has = |n: &str| headers.iter().any(|(k, _)| k.eq_ignore_ascii_case(n));
    let mut head = format!("{method} {path} HTTP/1.1\r\n");
    if !has("host") {
        head += &format!("Host: 127.0.0.1:{port}\r\n");
    }
    for (k, v) in headers {
        head += &format!("{k}: {v}\r\n");
    }
    if !has("content-length") {
        head += &format!("Content-Length: {}\r\n", body.len());
    }
    head += "Connection: close\r\n\r\n";
    let mut s = TcpStream::connect(("127.0.0.1", port)).expect("the studio listens");
    s.set_read_timeout(Some(Duration::from_secs(120))).unwrap();
    let mut w = s.try_clone().unwrap();
    let bytes = [head.as_bytes(), body].concat();
    let writer = std::thread::spawn(move || {
        let _ = w.write_all(&bytes);
    });
    let mut out = Vec::new();
    // A reset after the answer (body left unread) ends the read, not the data.
    let _ = s.read_to_end(&mut out);
    let _ = writer.join();
    let text = String::from_utf8_lossy(&out).into_owned();
    let (head, body) = text.split_once("\r\n\r\n").unwrap_or((&text, ""));
    let status = head
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("no HTTP answer: {text:?}"));
    Answer {
        status,
        head: head.to_string(),
        body: body.to_string(),
    }
}

/// A running studio seen from outside: its port, token and scratch folder.
struct Studio {
    proc: Option<Proc>,
    port: u16,
    token: String,
    scratch: PathBuf,
}

impl Studio {
    /// `lifted studio` with TMPDIR = `parent` (which holds nothing else).
    fn start(parent: &Path) -> Studio {
        let (proc, url) = start_studio(parent);
        let rest = url.trim_start_matches("http://127.0.0.1:");
        let (port, token) = rest.split_once("/?token=").expect("URL with token");
        let scratch: Vec<PathBuf> = std::fs::read_dir(parent)
            .unwrap()
            .flatten()
            .map(|e| e.path())
            .filter(|p| {
                p.file_name()
                    .is_some_and(|n| n.to_string_lossy().starts_with("lifted-studio-"))
            })
            .collect();
        assert_eq!(scratch.len(), 1, "{scratch:?}");
        Studio {
            proc: Some(proc),
            port: port.parse().unwrap(),
            token: token.to_string(),
            scratch: scratch[0].clone(),
        }
    }

    /// A call with the token header and, with a body, its content type.
    fn call(&self, method: &str, path: &str, ctype: &str, body: &[u8]) -> Answer {
        let mut h = vec![("X-Lifted-Token", self.token.as_str())];
        if !ctype.is_empty() {
            h.push(("Content-Type", ctype));
        }
        raw(self.port, method, path, &h, body)
    }

    fn upload(&self, name: &str, csv: &str) -> Answer {
        self.call(
            "POST",
            &format!("/api/data?name={name}"),
            "application/octet-stream",
            csv.as_bytes(),
        )
    }

    fn identify(&self, r: &Value) -> Answer {
        self.call(
            "POST",
            "/api/identify",
            "application/json",
            r.to_string().as_bytes(),
        )
    }

    /// The loaded record's (name, rows), from `GET /api/data`.
    fn record(&self) -> (String, u64) {
        let a = self.call("GET", "/api/data", "", b"");
        assert_eq!(a.status, 200, "{}", a.body);
        let v: Value = serde_json::from_str(&a.body).unwrap();
        (
            v["name"].as_str().unwrap_or("").to_string(),
            v["rows"].as_u64().unwrap_or(0),
        )
    }

    /// Stops the server with `signal` and waits for it.
    fn stop(&mut self, signal: &str) {
        if let Some(mut p) = self.proc.take() {
            let _ = Command::new("kill")
                .arg(format!("-{signal}"))
                .arg(p.0.id().to_string())
                .status();
            let t = Instant::now();
            while t.elapsed() < Duration::from_secs(10) {
                if let Ok(Some(_)) = p.0.try_wait() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(50));
            }
        }
    }
}

fn n4sid(order: &str) -> Value {
    json!({"inputs": ["u1"], "outputs": ["y1"], "method": "n4sid", "order": order})
}

#[test]
fn studio_refuses_foreign_requests_and_keeps_its_state() {
    let parent = tmp("attacks");
    let mut st = Studio::start(&parent);
    let port = st.port;

    // The scratch folder: a random name (not the PID), owner only.
    let name = st
        .scratch
        .file_name()
        .unwrap()
        .to_string_lossy()
        .into_owned();
    let suffix = name.trim_start_matches("lifted-studio-");
    assert!(
        suffix.len() == 32 && suffix.chars().all(|c| c.is_ascii_hexdigit()),
        "{name}"
    );
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&st.scratch).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o700, "scratch mode {mode:o}");
    }

    // The page: only with the token, which it carries for its script.
    let page = raw(port, "GET", &format!("/?token={}", st.token), &[], b"");
    assert_eq!(page.status, 200);
    assert!(page.body.contains(&format!("content=\"{}\"", st.token)));
    for (h, v) in [
        ("x-content-type-options", "nosniff"),
        ("x-frame-options", "DENY"),
        ("referrer-policy", "no-referrer"),
    ] {
        assert_eq!(page.header(h), Some(v), "{h}");
    }
    let csp = page.header("content-security-policy").unwrap_or("");
    assert!(
        csp.contains("script-src 'self'") && !csp.contains("unsafe-inline"),
        "{csp}"
    );
    assert!(csp.contains("frame-ancestors 'none'"), "{csp}");
    // Nothing inline for the policy to block (the browser tests count the
    // violations the page reports after its script has loaded).
    assert!(!page.body.contains("<style") && !page.body.contains(" style="));
    let handler = page.body.match_indices(" on").any(|(i, _)| {
        let rest = &page.body[i + 3..];
        let word = rest.len()
            - rest
                .trim_start_matches(|c: char| c.is_ascii_lowercase())
                .len();
        word > 0 && rest[word..].starts_with('=')
    });
    assert!(!handler, "an inline event handler");
    assert_eq!(
        page.body.matches("<script").count(),
        page.body
            .matches("<script src=\"/app.js\"></script>")
            .count()
    );
    let no_token = raw(port, "GET", "/", &[], b"");
    assert_eq!(no_token.status, 403);
    assert!(no_token.error().contains("token"));
    // Refusals carry the security headers too.
    assert!(no_token.header("content-security-policy").is_some());
    // The assets and the health check need no token.
    assert_eq!(raw(port, "GET", "/app.js", &[], b"").status, 200);
    assert_eq!(raw(port, "GET", "/api/health", &[], b"").body, "ok");

    // A record and a model.
    let csv = record(1500, 1);
    let up = st.upload("rec.csv", &csv);
    assert_eq!(up.status, 200, "{}", up.body);
    let id = st.identify(&n4sid("2"));
    assert_eq!(id.status, 200, "{}", id.body);
    let model = st.call("GET", "/api/model", "", b"");
    assert_eq!(model.status, 200, "{}", model.body);
    // The closed-loop methods without an instrument (issue 27) run too.
    for m in ["pbsid", "ssarx"] {
        let r =
            st.identify(&json!({"inputs": ["u1"], "outputs": ["y1"], "method": m, "order": "2"}));
        assert_eq!(r.status, 200, "{m}: {}", r.body);
        assert!(r.body.contains(m), "{m}: {}", r.body);
    }
    let id = st.identify(&n4sid("2"));
    assert_eq!(id.status, 200, "{}", id.body);
    let model = st.call("GET", "/api/model", "", b"");
    assert_eq!(model.status, 200, "{}", model.body);
    let other = record(400, 1);
    let t = st.token.clone();
    let tok = t.as_str();
    let up_path = "/api/data?name=other.csv";
    let octet = ("Content-Type", "application/octet-stream");
    let json_ct = ("Content-Type", "application/json");
    let body = n4sid("1").to_string();
    let refused: Vec<(&str, Answer, u16, &str)> = vec![
        (
            "DNS rebinding: Host evil.example",
            raw(
                port,
                "GET",
                &format!("/?token={tok}"),
                &[("Host", "evil.example")],
                b"",
            ),
            403,
            "Host 'evil.example'",
        ),
        (
            "Host evil.example with the port, on an upload",
            raw(
                port,
                "POST",
                up_path,
                &[
                    ("Host", &format!("evil.example:{port}")),
                    ("X-Lifted-Token", tok),
                    octet,
                ],
                other.as_bytes(),
            ),
            403,
            "is not this studio",
        ),
        (
            "foreign Origin, text/plain (a no-cors form post)",
            raw(
                port,
                "POST",
                up_path,
                &[
                    ("Origin", "http://evil.example"),
                    ("Content-Type", "text/plain"),
                ],
                other.as_bytes(),
            ),
            403,
            "Origin http://evil.example",
        ),
        (
            "foreign Origin even with the token",
            raw(
                port,
                "POST",
                up_path,
                &[
                    ("Origin", "http://evil.example"),
                    ("X-Lifted-Token", tok),
                    octet,
                ],
                other.as_bytes(),
            ),
            403,
            "cross-origin",
        ),
        (
            "another port of 127.0.0.1 is another origin",
            raw(
                port,
                "POST",
                "/api/identify",
                &[
                    (
                        "Origin",
                        &format!("http://127.0.0.1:{}", port.wrapping_add(1)),
                    ),
                    ("X-Lifted-Token", tok),
                    json_ct,
                ],
                body.as_bytes(),
            ),
            403,
            "cross-origin",
        ),
        (
            "Sec-Fetch-Site: cross-site",
            raw(
                port,
                "POST",
                "/api/identify",
                &[
                    ("Sec-Fetch-Site", "cross-site"),
                    ("X-Lifted-Token", tok),
                    json_ct,
                ],
                body.as_bytes(),
            ),
            403,
            "Sec-Fetch-Site: cross-site",
        ),
        (
            "Sec-Fetch-Site: same-site",
            raw(
                port,
                "POST",
                up_path,
                &[
                    ("Sec-Fetch-Site", "same-site"),
                    ("X-Lifted-Token", tok),
                    octet,
                ],
                other.as_bytes(),
            ),
            403,
            "Sec-Fetch-Site: same-site",
        ),
        (
            "text/plain on a JSON call",
            raw(
                port,
                "POST",
                "/api/identify",
                &[("X-Lifted-Token", tok), ("Content-Type", "text/plain")],
                body.as_bytes(),
            ),
            415,
            "application/json",
        ),
        (
            "JSON on the upload",
            raw(
                port,
                "POST",
                up_path,
                &[("X-Lifted-Token", tok), json_ct],
                other.as_bytes(),
            ),
            415,
            "application/octet-stream",
        ),
        (
            "no token",
            raw(port, "POST", up_path, &[octet], other.as_bytes()),
            403,
            "X-Lifted-Token",
        ),
        (
            "wrong token",
            raw(
                port,
                "POST",
                up_path,
                &[("X-Lifted-Token", &"0".repeat(64)), octet],
                other.as_bytes(),
            ),
            403,
            "wrong studio token",
        ),
        (
            "token in the query of a POST",
            raw(
                port,
                "POST",
                &format!("{up_path}&token={tok}"),
                &[octet],
                other.as_bytes(),
            ),
            403,
            "X-Lifted-Token",
        ),
        (
            "the model without the token",
            raw(port, "GET", "/api/model", &[], b""),
            403,
            "token",
        ),
        (
            "a JSON body over the 1 MiB limit",
            raw(
                port,
                "POST",
                "/api/identify",
                &[("X-Lifted-Token", tok), json_ct],
                &vec![b' '; MAX_JSON + 1],
            ),
            413,
            "request body too large: /api/identify takes at most 1 MiB",
        ),
        (
            "an upload declared over the 1 GiB limit",
            raw(
                port,
                "POST",
                up_path,
                &[
                    ("X-Lifted-Token", tok),
                    octet,
                    ("Content-Length", &(MAX_UPLOAD + 1).to_string()),
                ],
                b"",
            ),
            413,
            "/api/data takes at most 1024 MiB",
        ),
    ];
    for (what, a, status, msg) in &refused {
        assert_eq!(a.status, *status, "{what}: {}", a.body);
        let e = a.error();
        assert!(e.contains(msg), "{what}: {e}");
        assert_eq!(a.header("x-frame-options"), Some("DENY"), "{what}");
    }
    // Nothing of it reached the session: the record and the model stand.
    assert_eq!(st.record(), ("rec.csv".to_string(), 1500));
    let again = st.call("GET", &format!("/api/model?token={tok}"), "", b"");
    assert_eq!(again.status, 200);
    assert_eq!(again.body, model.body);

    // An absurd horizon is refused before anything is allocated (it used
    // to abort the process: 5 TB for the Hankel matrix).
    let mut r = n4sid("2");
    r["horizon"] = json!(100_000);
    let a = st.identify(&r);
    assert_eq!(a.status, 400, "{}", a.body);
    let e = a.error();
    assert!(
        e.starts_with("horizon 100000 is too large for rec.csv"),
        "{e}"
    );
    r["horizon"] = json!(20);
    r["q"] = json!(10_000_000);
    let e = st.identify(&r).error();
    assert!(e.starts_with("q 10000000 is too large"), "{e}");
    r["q"] = Value::Null;
    r["order"] = json!("5000");
    let e = st.identify(&r).error();
    assert!(e.starts_with("order 5000 is too large"), "{e}");
    // A failed identification leaves no model to save by mistake.
    let none = st.call("GET", "/api/model", "", b"");
    assert_eq!(none.status, 400);
    assert!(none.error().contains("no model yet"));
    assert_eq!(raw(port, "GET", "/api/health", &[], b"").body, "ok");

    // A bad file under the loaded record's name leaves the record intact.
    let bad = st.upload("rec.csv", "t,u1,y1\n0,1,2\n0.1,1\n");
    assert_eq!(bad.status, 400);
    assert_eq!(
        bad.error(),
        "rec.csv: line 3: 2 cells, the header has 3 (ragged row)"
    );
    assert_eq!(st.record(), ("rec.csv".to_string(), 1500));
    let id = st.identify(&n4sid("2"));
    assert_eq!(id.status, 200, "{}", id.body);
    let after: Value = serde_json::from_str(&st.call("GET", "/api/model", "", b"").body).unwrap();
    let before: Value = serde_json::from_str(&model.body).unwrap();
    assert_eq!(comparable(after), comparable(before));
    // A good new file replaces it, and only the new record stays on disk.
    assert_eq!(st.upload("rec.csv", &other).status, 200);
    assert_eq!(st.record(), ("rec.csv".to_string(), 400));
    assert_eq!(std::fs::read_dir(&st.scratch).unwrap().count(), 1);

    // SIGTERM: the scratch folder goes with the server.
    st.stop("TERM");
    assert!(!st.scratch.exists(), "{} left behind", st.scratch.display());
}

#[test]
fn studio_removes_its_scratch_folder_on_every_exit() {
    // Ctrl-C (SIGINT).
    let parent = tmp("exit-int");
    let mut st = Studio::start(&parent);
    assert_eq!(st.upload("rec.csv", &record(300, 1)).status, 200);
    st.stop("INT");
    assert!(!st.scratch.exists());
    // An error before the server starts (a bad --data file).
    let parent = tmp("exit-error");
    let bad = parent.join("bad.csv");
    std::fs::write(&bad, "t,u1,y1\n0,1\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_lifted"))
        .args(["studio", "--port", "0", "--data"])
        .arg(&bad)
        .env("TMPDIR", &parent)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let left: Vec<_> = std::fs::read_dir(&parent)
        .unwrap()
        .flatten()
        .filter(|e| {
            e.file_name()
                .to_string_lossy()
                .starts_with("lifted-studio-")
        })
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

// ---------------------------------------------------------------- browser

#[test]
fn studio_in_headless_chromium() {
    let Some((chromium, driver)) = browser_or_skip() else {
        return;
    };
    let dir = tmp("browser");
    let rec = dir.join("rec.csv");
    std::fs::write(&rec, record(5000, 1)).unwrap();
    let ragged = dir.join("ragged.csv");
    std::fs::write(&ragged, "t,u1,y1\n0,1,2\n0.1,1\n").unwrap();
    let shots = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/studio-screenshots");
    std::fs::create_dir_all(&shots).unwrap();

    let (_studio, url) = start_studio(&dir);
    let (_driver, port) = start_driver(&driver);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let model_from_page = rt.block_on(async {
        let c = connect(&chromium, port, &dir.join("profile")).await;
        c.goto(&url).await.unwrap();
        assert_eq!(c.title().await.unwrap(), "Lifted studio");

        // Load the record through the file picker: an automatic-order fit follows.
        let file = c.find(Locator::Id("file")).await.unwrap();
        file.send_keys(&rec.display().to_string()).await.unwrap();
        let g = wait_identified(&c, 0).await;
        assert_eq!(status(&c, "csp").await, 0, "a content-security-policy violation");
        assert!(html(&c, "fig-inputs").await.contains("<svg"));
        assert!(html(&c, "fig-outputs").await.contains("<svg"));
        assert!(html(&c, "fig-order").await.contains("<svg"));
        shot(&c, &shots, "1-loaded.png").await;

        // The order slider to 1 (Home key), then to 2 (one step right).
        let slider = c.find(Locator::Id("order-slider")).await.unwrap();
        slider.send_keys(&Key::Home.to_string()).await.unwrap();
        let g = wait_identified(&c, g).await;
        assert_eq!(text(&c, "#order-value").await, "1");
        let fit1: f64 = text(&c, "td.fit").await.parse().unwrap();
        let figs1: Vec<String> = futures_all(&c, &["fig-response", "fig-step", "fig-bode", "fig-pz"]).await;
        shot(&c, &shots, "2-order-1.png").await;

        slider.send_keys(&Key::Right.to_string()).await.unwrap();
        wait_identified(&c, g).await;
        assert_eq!(text(&c, "#order-value").await, "2");
        let fit2: f64 = text(&c, "td.fit").await.parse().unwrap();
        let figs2: Vec<String> = futures_all(&c, &["fig-response", "fig-step", "fig-bode", "fig-pz"]).await;
        shot(&c, &shots, "3-order-2.png").await;
        // Order 2 is the plant's order: its fit is far better than order 1's.
        assert!(fit2 > 95.0 && fit2 > fit1 + 5.0, "fit {fit1} → {fit2}");
        for (a, b) in figs1.iter().zip(&figs2) {
            assert!(b.contains("<svg") && a != b, "a plot did not change");
        }
        let command = text(&c, "#command").await;
        assert!(command.contains("--order 2"), "{command}");

        // "Save model": the link's target, fetched by the page.
        let href = c
            .find(Locator::Id("save-model"))
            .await
            .unwrap()
            .attr("href")
            .await
            .unwrap()
            .unwrap();
        let model = c
            .execute_async(
                "const done = arguments[arguments.length - 1]; fetch(arguments[0]).then(r => r.text()).then(done);",
                vec![json!(href)],
            )
            .await
            .unwrap();
        let report = c
            .execute_async(
                "const done = arguments[arguments.length - 1]; fetch(document.getElementById('save-report').href).then(r => r.text()).then(done);",
                vec![],
            )
            .await
            .unwrap();
        assert!(report.as_str().unwrap_or("").contains("Identification report"));

        // A ragged file: the CLI's one-line message in the page.
        let file = c.find(Locator::Id("file")).await.unwrap();
        file.send_keys(&ragged.display().to_string()).await.unwrap();
        let t = Instant::now();
        let msg = loop {
            let m = js(&c, "const e = document.getElementById('error'); return e.hidden ? '' : e.textContent;").await;
            let m = m.as_str().unwrap_or("").to_string();
            if !m.is_empty() {
                break m;
            }
            assert!(t.elapsed() < Duration::from_secs(20), "no error shown");
            tokio::time::sleep(Duration::from_millis(50)).await;
        };
        assert_eq!(msg, "ragged.csv: line 3: 2 cells, the header has 3 (ragged row)");
        shot(&c, &shots, "4-ragged.png").await;
        // The server still answers.
        c.goto(&url).await.unwrap();
        c.close().await.unwrap();
        (command, model.as_str().unwrap_or("").to_string())
    });

    // The saved model equals `lifted identify` with the options the page shows.
    let (command, model) = model_from_page;
    let out = dir.join("cli.json");
    let mut args: Vec<String> = command
        .split_whitespace()
        .skip(1)
        .map(|w| w.trim_matches('\'').to_string())
        .collect();
    for w in args.iter_mut() {
        if w == "rec.csv" {
            *w = rec.display().to_string();
        } else if w == "model.json" {
            *w = out.display().to_string();
        }
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    run_lifted(&args);
    let cli: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let page: Value = serde_json::from_str(&model).expect("the saved model is JSON");
    assert_eq!(comparable(cli), comparable(page));
}

async fn futures_all(c: &Client, ids: &[&str]) -> Vec<String> {
    let mut v = Vec::new();
    for id in ids {
        v.push(html(c, id).await);
    }
    v
}

/// A second origin: a tiny server on another port of 127.0.0.1 that
/// answers every request with an empty page (the test's script runs in it).
fn other_origin() -> u16 {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    std::thread::spawn(move || {
        for conn in listener.incoming().flatten() {
            let mut conn = conn;
            let mut seen = Vec::new();
            let mut buf = [0u8; 1024];
            while !seen.windows(4).any(|w| w == b"\r\n\r\n") {
                match conn.read(&mut buf) {
                    Ok(0) | Err(_) => break,
                    Ok(n) => seen.extend_from_slice(&buf[..n]),
                }
            }
            let page = "<!DOCTYPE html><title>another origin</title><p>not the studio</p>";
            let _ = write!(
                conn,
                "HTTP/1.1 200 OK\r\nContent-Type: text/html\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{page}",
                page.len()
            );
        }
    });
    port
}

/// The page's error text ('' when hidden).
async fn page_error(c: &Client) -> String {
    js(
        c,
        "const e = document.getElementById('error'); return e.hidden ? '' : e.textContent;",
    )
    .await
    .as_str()
    .unwrap_or("")
    .to_string()
}

/// Waits until the page has counted more than `after` failed calls and is
/// idle; returns the count.
async fn wait_failed(c: &Client, after: u64) -> u64 {
    let t = Instant::now();
    loop {
        let f = status(c, "failed").await;
        if f > after && status(c, "busy").await == 0 {
            return f;
        }
        assert!(t.elapsed() < Duration::from_secs(60), "no failure shown");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// Types `value` into the number field `id` and submits the form (Enter).
async fn set_field(c: &Client, id: &str, value: &str) {
    let f = c.find(Locator::Id(id)).await.unwrap();
    f.clear().await.unwrap();
    f.send_keys(&format!("{value}{}", Key::Enter))
        .await
        .unwrap();
}

async fn saves_disabled(c: &Client) -> bool {
    js(
        c,
        "const a = document.getElementById('save-model'); \
         return !a.hasAttribute('href') && a.getAttribute('aria-disabled') === 'true';",
    )
    .await
    .as_bool()
    .unwrap_or(false)
}

#[test]
fn studio_refuses_another_origin_in_chromium_and_works_under_its_policy() {
    let Some((chromium, driver)) = browser_or_skip() else {
        return;
    };
    let dir = tmp("browser-origin");
    let st = Studio::start(&dir);
    assert_eq!(st.upload("rec.csv", &record(3000, 1)).status, 200);
    let studio = format!("http://127.0.0.1:{}", st.port);
    let page_url = format!("{studio}/?token={}", st.token);
    let evil = other_origin();
    let (_driver, port) = start_driver(&driver);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let c = connect(&chromium, port, &dir.join("profile")).await;

        // A page of another origin posts at the studio: no-cors fetches
        // (a simple request, which the browser sends without asking),
        // with and without a content type, and even with the token (as if
        // it had leaked), which needs a CORS preflight.
        c.goto(&format!("http://127.0.0.1:{evil}/")).await.unwrap();
        assert_eq!(c.title().await.unwrap(), "another origin");
        let outcome = c
            .execute_async(
                r#"const [studio, token] = arguments;
                const done = arguments[arguments.length - 1];
                const csv = "t,u1,y1\n0,1,2\n0.1,3,4\n0.2,5,6\n";
                const tries = [
                  fetch(studio + "/api/data?name=rec.csv", {method: "POST", mode: "no-cors", body: csv}),
                  fetch(studio + "/api/data?name=rec.csv", {method: "POST", mode: "no-cors", body: csv,
                        headers: {"Content-Type": "text/plain"}}),
                  fetch(studio + "/api/identify", {method: "POST", mode: "no-cors",
                        body: '{"inputs":["u1"],"outputs":["y1"],"horizon":100000}'}),
                  fetch(studio + "/api/data?name=rec.csv", {method: "POST", mode: "cors", body: csv,
                        headers: {"X-Lifted-Token": token, "Content-Type": "application/octet-stream"}}),
                ];
                Promise.allSettled(tries).then((r) => done(r.map((x) => x.status + ":" +
                  (x.status === "fulfilled" ? x.value.type : String(x.reason)))));"#,
                vec![json!(studio), json!(st.token)],
            )
            .await
            .unwrap();
        let outcome: Vec<String> = serde_json::from_value(outcome).unwrap();
        // The page learns nothing (the studio's answers are same-origin
        // only: Cross-Origin-Resource-Policy turns them into network
        // errors), and the request with the token failed its preflight.
        assert!(
            outcome.iter().all(|o| o.starts_with("rejected:")),
            "{outcome:?}"
        );
        // The browser did send them, and the studio refused each one (its
        // log), the preflight included: the record stands.
        let log = std::fs::read_to_string(dir.join("studio.log")).unwrap();
        let refused = |what: &str| log.lines().filter(|l| l.contains(what)).count();
        assert_eq!(refused("refused POST /api/data"), 2, "{log}");
        assert_eq!(refused("refused POST /api/identify"), 1, "{log}");
        assert_eq!(refused("refused OPTIONS /api/data"), 1, "{log}");
        assert!(
            log.lines()
                .filter(|l| l.contains("refused"))
                .all(|l| l.contains("cross-origin request refused")),
            "{log}"
        );
        assert_eq!(st.record(), ("rec.csv".to_string(), 3000));

        // The studio's own page works under its policy: the record loaded
        // at start is shown and identified, with no violation reported.
        c.goto(&page_url).await.unwrap();
        let g = wait_identified(&c, 0).await;
        assert!(html(&c, "fig-pz").await.contains("<svg"));
        assert!(html(&c, "fig-order").await.contains("<svg"));
        assert!(!saves_disabled(&c).await);
        assert_eq!(status(&c, "csp").await, 0, "{}", page_error(&c).await);

        // A typo in a number field is an error in the page, not a default.
        set_field(&c, "horizon", "1e").await;
        let f = wait_failed(&c, 0).await;
        assert_eq!(page_error(&c).await, "Horizon: not a number");
        assert!(saves_disabled(&c).await);
        assert_eq!(html(&c, "fig-pz").await, "");

        // An absurd horizon: the server's named error; the old figures
        // and Save links are gone.
        set_field(&c, "horizon", "100000").await;
        wait_failed(&c, f).await;
        let e = page_error(&c).await;
        assert!(e.starts_with("horizon 100000 is too large for rec.csv"), "{e}");
        assert!(saves_disabled(&c).await);
        for id in ["fig-response", "fig-step", "fig-bode", "fig-pz", "fits", "gain"] {
            assert_eq!(html(&c, id).await, "", "{id} kept the previous model");
        }
        // A click on the disabled link goes nowhere.
        c.find(Locator::Id("save-model"))
            .await
            .unwrap()
            .click()
            .await
            .unwrap();
        assert_eq!(c.current_url().await.unwrap().as_str(), page_url);

        // A sensible horizon again: a model, its figures and Save links;
        // the fit table has the one-step prediction column of the model's
        // checked Kalman gain, which the page names.
        set_field(&c, "horizon", "12").await;
        wait_identified(&c, g).await;
        assert!(html(&c, "fig-pz").await.contains("<svg"));
        assert!(html(&c, "fits").await.contains("fit % (1-step)"));
        assert!(html(&c, "gain").await.starts_with("Kalman gain: "));
        assert!(!saves_disabled(&c).await);
        assert_eq!(status(&c, "csp").await, 0, "{}", page_error(&c).await);
        let png = c.screenshot().await.expect("screenshot");
        let target = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target");
        std::fs::create_dir_all(&target).unwrap();
        std::fs::write(target.join("studio-security.png"), png).unwrap();

        // A column name with markup and both quotes is shown as text: in
        // the channel boxes, the rates table, the fit table and its
        // data-output attribute, with no element made of it.
        let name = r#"y<b>"1'"#;
        let csv = record(3000, 1).replacen("y1", name, 1);
        assert_eq!(st.upload("xss.csv", &csv).status, 200);
        c.goto(&page_url).await.unwrap();
        wait_identified(&c, 0).await;
        let seen = js(
            &c,
            "return [document.querySelectorAll('main b').length, \
             document.querySelector('td.fit').dataset.output, \
             document.getElementById('outputs-box').textContent, \
             document.getElementById('rates').textContent];",
        )
        .await;
        assert_eq!(seen[0], json!(0), "markup from a column name: {seen}");
        assert_eq!(seen[1], json!(name));
        for text in [&seen[2], &seen[3]] {
            assert!(text.as_str().unwrap_or("").contains(name), "{seen}");
        }
        assert_eq!(status(&c, "csp").await, 0, "{}", page_error(&c).await);
        c.close().await.unwrap();
    });
    assert_eq!(st.record(), ("xss.csv".to_string(), 3000));
}

/// The CSV of a plant with an unstable mode (x1⁺ = 1.004 x1 + 0.5 u) beside
/// a stable one, under a random binary input: N4SID's models of it are
/// unstable, so the page must show "n/a: unstable" for the fit.
fn unstable_record(n: usize) -> String {
    let (mut x1, mut x2) = (0.0f64, 0.0f64);
    let mut out = String::from("t,u1,y1\n");
    for (k, &u) in binary_input(n).iter().enumerate() {
        let e = 0.005 * ((k as f64 * 1.618_034).fract() - 0.5);
        out += &format!("{},{u},{:.9}\n", k as f64 * 0.1, x1 + 0.5 * x2 + e);
        (x1, x2) = (1.004 * x1 + 0.5 * u, 0.5 * x2 + 0.3 * u);
    }
    out
}

/// The model behind the page's "Save model" link, fetched by the page.
async fn saved_model(c: &Client) -> Value {
    let m = c
        .execute_async(
            "const done = arguments[arguments.length - 1]; \
             fetch(document.getElementById('save-model').href).then(r => r.text()).then(done);",
            vec![],
        )
        .await
        .unwrap();
    serde_json::from_str(m.as_str().unwrap_or("")).expect("the saved model is JSON")
}

/// The state dimension of a model file.
fn order_of(model: &Value) -> usize {
    model["a"].as_array().map_or(0, Vec::len)
}

/// Waits until the page is idle with no request outstanding (its last
/// answer shown) and returns the number of identifications shown.
async fn wait_settled(c: &Client) -> u64 {
    let t = Instant::now();
    loop {
        tokio::time::sleep(Duration::from_millis(300)).await;
        let settled = js(
            c,
            "const s = document.getElementById('status').dataset; \
             return s.busy === '0' && s.generation !== '0';",
        )
        .await;
        if settled.as_bool() == Some(true) {
            tokio::time::sleep(Duration::from_millis(300)).await;
            if status(c, "busy").await == 0 {
                return status(c, "generation").await;
            }
        }
        assert!(
            t.elapsed() < Duration::from_secs(120),
            "the page never settled"
        );
    }
}

/// Presses `keys` on the order slider (focused) 50 ms apart, timed by the
/// browser (WebDriver key actions), not by this test's round trips.
async fn press_50ms_apart(c: &Client, keys: &[Key]) {
    use fantoccini::actions::{InputSource, KeyAction, KeyActions};
    js(
        c,
        "document.getElementById('order-slider').focus(); return 0;",
    )
    .await;
    let mut seq = KeyActions::new("keys".into());
    for (i, &k) in keys.iter().enumerate() {
        if i > 0 {
            seq = seq.pause(Duration::from_millis(50));
        }
        seq = seq
            .then(KeyAction::Down { value: k.into() })
            .then(KeyAction::Up { value: k.into() });
    }
    c.perform_actions(seq).await.expect("key presses");
}

#[test]
fn studio_shows_and_saves_one_model_in_chromium() {
    let Some((chromium, driver)) = browser_or_skip() else {
        return;
    };
    let dir = tmp("browser-consistent");
    let rec = dir.join("rec.csv");
    // Short, so that answers come back between the key presses.
    std::fs::write(&rec, record(600, 1)).unwrap();
    let unstable = dir.join("unstable.csv");
    std::fs::write(&unstable, unstable_record(600)).unwrap();
    let shots = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/screens");
    std::fs::create_dir_all(&shots).unwrap();

    let (_studio, url) = start_studio(&dir);
    let (_driver, port) = start_driver(&driver);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let c = connect(&chromium, port, &dir.join("profile")).await;
        c.goto(&url).await.unwrap();
        let file = c.find(Locator::Id("file")).await.unwrap();
        file.send_keys(&rec.display().to_string()).await.unwrap();
        wait_identified(&c, 0).await;

        // Home (order 1), then four right steps 50 ms apart: answers come
        // back while keys are still pressed, and none of them may move the
        // slider. Four runs: each must end at order 5.
        for run in 0..4 {
            press_50ms_apart(
                &c,
                &[Key::Home, Key::Right, Key::Right, Key::Right, Key::Right],
            )
            .await;
            wait_settled(&c).await;
            let value = js(&c, "return document.getElementById('order-slider').value;").await;
            assert_eq!(value.as_str(), Some("5"), "run {run}: the slider moved");
            assert_eq!(text(&c, "#order-value").await, "5", "run {run}");
            assert_eq!(status(&c, "order").await, 5, "run {run}: the answer shown");
            let command = text(&c, "#command").await;
            assert!(command.contains("--order 5"), "run {run}: {command}");
            assert!(text(&c, "#status").await.contains("order 5"), "run {run}");
            let poles = js(&c, "return document.querySelectorAll('#poles li').length;").await;
            assert_eq!(poles.as_u64(), Some(5), "run {run}: the pole list");
            let pz = html(&c, "fig-pz").await;
            assert!(pz.contains("<svg"), "run {run}: the pole-zero map");
            assert_eq!(
                order_of(&saved_model(&c).await),
                5,
                "run {run}: the saved model"
            );
        }
        shot(&c, &shots, "studio-order-5.png").await;

        // A record whose models are unstable: "n/a: unstable", the poles
        // outside the unit circle marked, no script error, and the saved
        // model is the one shown.
        let file = c.find(Locator::Id("file")).await.unwrap();
        file.send_keys(&unstable.display().to_string())
            .await
            .unwrap();
        wait_settled(&c).await;
        press_50ms_apart(&c, &[Key::Home, Key::Right]).await;
        wait_settled(&c).await;
        assert_eq!(status(&c, "jserrors").await, 0, "a script error");
        assert_eq!(page_error(&c).await, "");
        assert_eq!(text(&c, "#order-value").await, "2");
        assert_eq!(text(&c, "td.fit").await, "n/a: unstable");
        let note = text(&c, "#stability").await;
        assert!(
            note.starts_with("Unstable model: spectral radius"),
            "{note}"
        );
        let outside = text(&c, "#poles li.outside").await;
        assert!(outside.contains("outside the unit circle"), "{outside}");
        assert!(
            html(&c, "fig-pz")
                .await
                .contains("poles outside the unit circle")
        );
        assert!(text(&c, "#command").await.contains("--order 2"));
        let model = saved_model(&c).await;
        assert_eq!(order_of(&model), 2);
        shot(&c, &shots, "studio-unstable.png").await;

        // A second tab has its own session: loading another record there
        // leaves the first tab's record and model alone.
        let first = c.window().await.unwrap();
        let second = c.new_window(true).await.unwrap().handle;
        c.switch_to_window(second).await.unwrap();
        c.goto(&url).await.unwrap();
        let file = c.find(Locator::Id("file")).await.unwrap();
        file.send_keys(&rec.display().to_string()).await.unwrap();
        wait_settled(&c).await;
        assert!(text(&c, "#data-name").await.starts_with("rec.csv"));
        assert_eq!(status(&c, "jserrors").await, 0);
        c.switch_to_window(first).await.unwrap();
        let info = c
            .execute_async(
                "const done = arguments[arguments.length - 1]; \
                 const href = document.getElementById('save-model').href; \
                 const session = new URL(href).searchParams.get('session'); \
                 fetch('/api/data', {headers: {'X-Lifted-Token': document.querySelector('meta[name=\"lifted-token\"]').content, \
                   'X-Lifted-Session': session}}).then(r => r.json()).then(done);",
                vec![],
            )
            .await
            .unwrap();
        assert_eq!(info["name"], json!("unstable.csv"), "{info}");
        assert_eq!(order_of(&saved_model(&c).await), 2);
        assert_eq!(text(&c, "td.fit").await, "n/a: unstable");
        c.close().await.unwrap();
    });
}

#[test]
fn studio_keeps_a_session_per_tab() {
    let parent = tmp("sessions");
    let mut st = Studio::start(&parent);
    let (a, b) = ("tab-aaaaaaaaaaaa", "tab-bbbbbbbbbbbb");
    let call = |session: &str, method: &str, path: &str, ctype: &str, body: &[u8]| {
        let mut h = vec![
            ("X-Lifted-Token", st.token.as_str()),
            ("X-Lifted-Session", session),
        ];
        if !ctype.is_empty() {
            h.push(("Content-Type", ctype));
        }
        raw(st.port, method, path, &h, body)
    };
    let upload = |s: &str, name: &str, csv: &str| {
        let r = call(
            s,
            "POST",
            &format!("/api/data?name={name}"),
            "application/octet-stream",
            csv.as_bytes(),
        );
        assert_eq!(r.status, 200, "{}", r.body);
    };
    let identify = |s: &str, order: &str, seq: u64| {
        let mut r = n4sid(order);
        r["seq"] = json!(seq);
        let a = call(
            s,
            "POST",
            "/api/identify",
            "application/json",
            r.to_string().as_bytes(),
        );
        assert_eq!(a.status, 200, "{}", a.body);
        let v: Value = serde_json::from_str(&a.body).unwrap();
        assert_eq!(v["seq"], json!(seq));
        assert_eq!(v["order"], json!(order.parse::<u64>().unwrap()));
    };
    let name = |s: &str| -> String {
        let r = call(s, "GET", "/api/data", "", b"");
        let v: Value = serde_json::from_str(&r.body).unwrap();
        v["name"].as_str().unwrap_or("").to_string()
    };
    let model = |s: &str, q: &str| -> Answer { call(s, "GET", &format!("/api/model{q}"), "", b"") };
    let open = |s: &str| {
        let r = call(s, "POST", "/api/session", "application/json", b"{}");
        assert_eq!(r.status, 200, "{}", r.body);
    };
    // A session is opened before use (the page does it on load); an id
    // the server has not opened is refused with 410, not given a session.
    let unknown = call(a, "GET", "/api/data", "", b"");
    assert_eq!(unknown.status, 410, "{}", unknown.body);
    assert!(unknown.body.contains("session expired"), "{}", unknown.body);
    open(a);
    open(b);
    // Opening again keeps it.
    open(a);

    upload(a, "first.csv", &record(1000, 1));
    upload(b, "second.csv", &record(800, 1));
    assert_eq!(name(a), "first.csv");
    assert_eq!(name(b), "second.csv");
    // The default session (no id) has neither.
    assert_eq!(st.call("GET", "/api/data", "", b"").body, "null");
    identify(a, "2", 1);
    identify(a, "3", 2);
    identify(b, "1", 1);
    // Each tab saves its own models, by sequence number.
    let order = |ans: Answer| -> usize {
        assert_eq!(ans.status, 200, "{}", ans.body);
        order_of(&serde_json::from_str(&ans.body).unwrap())
    };
    assert_eq!(order(model(a, "?seq=1")), 2);
    assert_eq!(order(model(a, "?seq=2")), 3);
    assert_eq!(order(model(a, "")), 3);
    assert_eq!(order(model(b, "?seq=1")), 1);
    assert_eq!(model(b, "?seq=2").status, 400);
    // A GET may name its session in the query (the page's Save links).
    let q = format!("/api/model?token={}&session={a}&seq=1", st.token);
    assert_eq!(order(raw(st.port, "GET", &q, &[], b"")), 2);
    // A malformed id is refused.
    assert_eq!(call("x y", "GET", "/api/data", "", b"").status, 400);

    // Beyond eight tabs the least recently used goes (its folder too), and
    // a call of the dropped tab is told so (410), never answered with
    // another record's model.
    for k in 0..8 {
        let tab = format!("tab-{k:012}");
        open(&tab);
        upload(&tab, "more.csv", &record(300, 1));
    }
    for (method, path, body) in [
        ("GET", "/api/data", String::new()),
        ("GET", "/api/model", String::new()),
        ("POST", "/api/identify", n4sid("2").to_string()),
    ] {
        let ctype = if method == "POST" {
            "application/json"
        } else {
            ""
        };
        let r = call(b, method, path, ctype, body.as_bytes());
        assert_eq!(r.status, 410, "{method} {path}: {}", r.body);
        let v: Value = serde_json::from_str(&r.body).unwrap();
        assert_eq!(v["error"], json!(lifted_cli::studio::SESSION_EXPIRED));
    }
    let folders = std::fs::read_dir(&st.scratch)
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with("session-"))
        .count();
    assert!(folders <= 8, "{folders} session folders");
    st.stop("TERM");
    assert!(!st.scratch.exists());
}

/// A record without a time column (`u1,y1`), `n` samples of the plant.
fn untimed_record(n: usize) -> String {
    let timed = record(n, 1);
    let mut out = String::from("u1,y1\n");
    for line in timed.lines().skip(1) {
        let (_, rest) = line.split_once(',').unwrap();
        out += rest;
        out.push('\n');
    }
    out
}

/// Points of the `<polyline>`s and `<path>`s of an SVG document (a rough
/// count: the numbers after `points="`/`d="` over 2).
fn drawn_points(svg: &str) -> usize {
    let mut n = 0;
    for key in ["points=\"", " d=\""] {
        for part in svg.split(key).skip(1) {
            let body = part.split('"').next().unwrap_or("");
            n += body
                .split(|c: char| c == ' ' || c == ',' || c.is_ascii_alphabetic())
                .filter(|w| !w.is_empty())
                .count()
                / 2;
        }
    }
    n
}

async fn element_shot(c: &Client, css: &str, dir: &Path, name: &str) {
    let e = c.find(Locator::Css(css)).await.expect("element");
    let png = e.screenshot().await.expect("screenshot");
    std::fs::write(dir.join(name), png).unwrap();
}

/// Issue 28, the ident workbench in Chromium: a record without a time
/// column loads (the base period is the page's field, `--ts 1` on the
/// command line); the residual auto- and cross-correlation plots with
/// their 99 % bands, the data's empirical frequency response (Welch) on
/// the Bode plot, the model's matrices and transfer function are shown;
/// the order slider keeps the structure the automatic order chose, and
/// the model saved equals the one the page's command line writes; the
/// time plots zoom (wheel, the numeric fields) and pan (drag) with at most
/// a few thousand points drawn for 40 000 samples, and come back whole
/// (double-click). Screenshots `w*.png` in `target/studio-screenshots/`.
#[test]
fn studio_workbench_in_headless_chromium() {
    let Some((chromium, driver)) = browser_or_skip() else {
        return;
    };
    let dir = tmp("workbench");
    let rec = dir.join("untimed.csv");
    let n = 40_000;
    std::fs::write(&rec, untimed_record(n)).unwrap();
    let shots = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/studio-screenshots");
    std::fs::create_dir_all(&shots).unwrap();
    let (_studio, url) = start_studio(&dir);
    let (_driver, port) = start_driver(&driver);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let (command, model) = rt.block_on(async {
        let c = connect(&chromium, port, &dir.join("profile")).await;
        c.goto(&url).await.unwrap();
        let file = c.find(Locator::Id("file")).await.unwrap();
        file.send_keys(&rec.display().to_string()).await.unwrap();
        let g = wait_identified(&c, 0).await;
        assert_eq!(status(&c, "csp").await, 0);
        assert_eq!(status(&c, "jserrors").await, 0);
        let ts_hint = js(&c, "return document.getElementById('ts').placeholder;").await;
        assert_eq!(ts_hint.as_str(), Some("1 (no time column)"));
        assert!(text(&c, "#data-name").await.contains("no time column"));
        assert!(text(&c, "#command").await.contains("--ts 1"));
        // Residual plots with bands, Welch on the Bode plot, the model.
        let res = html(&c, "fig-residuals").await;
        assert!(res.contains("residual autocorrelation"), "{}", &res[..res.len().min(300)]);
        assert!(res.contains("cross-correlation") && res.contains("99 % bound"));
        assert!(html(&c, "fig-bode").await.contains("data (Welch)"));
        let tables = js(&c, "return document.querySelectorAll('#matrices table').length;").await;
        assert!(tables.as_u64().unwrap_or(0) >= 4, "matrices: {tables}");
        let tf = text(&c, "#tfs").await;
        assert!(tf.contains("y1 ← u1") && tf.contains('z'), "{tf}");
        // Whole record: min/max decimated, not 40 000 points a curve.
        let whole = html(&c, "fig-outputs").await;
        let pts = drawn_points(&whole);
        assert!(pts > 500 && pts < 6000, "{pts} points drawn");
        element_shot(&c, "#io-block", &shots, "w1-untimed-whole.png").await;
        element_shot(&c, "#response-block", &shots, "w2-response-residuals-model.png").await;

        // Order 2 on the slider: the automatic order's structure kept and
        // made explicit on the command line.
        let slider = c.find(Locator::Id("order-slider")).await.unwrap();
        slider.send_keys(&Key::Home.to_string()).await.unwrap();
        let g = wait_identified(&c, g).await;
        slider.send_keys(&Key::Right.to_string()).await.unwrap();
        let g = wait_identified(&c, g).await;
        assert_eq!(text(&c, "#order-value").await, "2");
        let command = text(&c, "#command").await;
        for w in ["--order 2", "--horizon", "--estimator", "--output-period y1=1", "--ts 1"] {
            assert!(command.contains(w), "{w} missing: {command}");
        }
        let model = c
            .execute_async(
                "const done = arguments[arguments.length - 1]; fetch(document.getElementById('save-model').href).then(r => r.text()).then(done);",
                vec![],
            )
            .await
            .unwrap();

        // Zoom in with the wheel at the middle of the outputs plot.
        let views = status(&c, "view").await;
        js(
            &c,
            "const s = document.querySelector('#fig-outputs svg'); const r = s.getBoundingClientRect();
             s.parentElement.dispatchEvent(new WheelEvent('wheel', {deltaY: -100, clientX: r.left + r.width / 2,
               clientY: r.top + r.height / 2, bubbles: true, cancelable: true})); return 0;",
        )
        .await;
        let t = Instant::now();
        while status(&c, "view").await <= views || status(&c, "busy").await == 1 {
            assert!(t.elapsed() < Duration::from_secs(30), "no zoomed view");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let t0: f64 = js(&c, "return Number(document.getElementById('win-t0').value);").await.as_f64().unwrap();
        let t1: f64 = js(&c, "return Number(document.getElementById('win-t1').value);").await.as_f64().unwrap();
        let whole_end = (n - 1) as f64;
        // Half the record around its middle (the plot area's centre is
        // the middle of the padded axis, i.e. of the record).
        assert!(t0 > 0.2 * whole_end && t1 < 0.8 * whole_end && t1 > t0, "window {t0}..{t1}");
        assert!(((t1 - t0) - 0.5 * whole_end).abs() < 0.02 * whole_end, "window {t0}..{t1}");
        let zoomed = html(&c, "fig-outputs").await;
        assert_ne!(zoomed, whole);
        // The numeric fields: a 200 s window, every sample drawn.
        set_field(&c, "win-t0", "1000").await;
        set_field(&c, "win-t1", "1200").await;
        let views = status(&c, "view").await;
        c.find(Locator::Id("win-apply")).await.unwrap().click().await.unwrap();
        let t = Instant::now();
        while status(&c, "view").await <= views || status(&c, "busy").await == 1 {
            assert!(t.elapsed() < Duration::from_secs(30), "no view of the window");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let narrow = html(&c, "fig-outputs").await;
        let pts = drawn_points(&narrow);
        assert!(pts >= 200, "{pts} points in a 200-sample window");
        wait_identified(&c, g).await;
        element_shot(&c, "#io-block", &shots, "w3-window-1000-1200.png").await;
        element_shot(&c, "#fig-response", &shots, "w4-response-window.png").await;
        // Drag to the right by a quarter of the plot: the window moves back
        // in time by about a quarter of its span (1.1 × 200 / 4 = 55 s).
        js(
            &c,
            "const d = document.getElementById('fig-outputs'); const s = d.querySelector('svg');
             const r = s.getBoundingClientRect(); const y = r.top + r.height / 2;
             d.dispatchEvent(new MouseEvent('mousedown', {button: 0, clientX: r.left + r.width / 2, clientY: y, bubbles: true}));
             window.dispatchEvent(new MouseEvent('mouseup', {button: 0, clientX: r.left + r.width * 0.75 + 0 * 1, clientY: y, bubbles: true}));
             return 0;",
        )
        .await;
        tokio::time::sleep(Duration::from_millis(300)).await;
        wait_settled(&c).await;
        let p0: f64 = js(&c, "return Number(document.getElementById('win-t0').value);").await.as_f64().unwrap();
        let shift = 1000.0 - p0;
        assert!(shift > 30.0 && shift < 80.0, "pan by {shift} s");
        // Double-click: the whole record again.
        js(&c, "document.getElementById('fig-outputs').dispatchEvent(new MouseEvent('dblclick', {bubbles: true})); return 0;").await;
        tokio::time::sleep(Duration::from_millis(300)).await;
        wait_settled(&c).await;
        assert_eq!(js(&c, "return document.getElementById('win-t0').value;").await.as_str(), Some(""));
        assert_eq!(status(&c, "jserrors").await, 0);
        assert_eq!(status(&c, "csp").await, 0);
        c.close().await.unwrap();
        (command, model.as_str().unwrap_or("").to_string())
    });
    let out = dir.join("cli.json");
    run_command_line(&command, &rec, &out);
    let cli: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let page: Value = serde_json::from_str(&model).expect("the saved model is JSON");
    assert_eq!(comparable(cli), comparable(page));
}

/// Issue 28, the rest of the workbench in Chromium: a validation record of
/// its own; the model board (keep two models, the fit table on the
/// validation record, the overlaid simulated outputs, step responses and
/// Bode plots, save a kept model = the model its command line writes,
/// remove one); the order criterion's curve (AIC); PEM refinement; delay
/// estimation. Screenshots `b*.png` in `target/studio-screenshots/`.
#[test]
fn studio_board_and_tools_in_headless_chromium() {
    let Some((chromium, driver)) = browser_or_skip() else {
        return;
    };
    let dir = tmp("board");
    let rec = dir.join("est.csv");
    std::fs::write(&rec, record(4000, 1)).unwrap();
    let val = dir.join("val.csv");
    let other: Vec<f64> = binary_input(4777).split_off(777);
    std::fs::write(&val, record_of(&other, 1)).unwrap();
    let shots = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/studio-screenshots");
    std::fs::create_dir_all(&shots).unwrap();
    let (_studio, url) = start_studio(&dir);
    let (_driver, port) = start_driver(&driver);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let (command, model) = rt.block_on(async {
        let c = connect(&chromium, port, &dir.join("profile")).await;
        c.goto(&url).await.unwrap();
        let file = c.find(Locator::Id("file")).await.unwrap();
        file.send_keys(&rec.display().to_string()).await.unwrap();
        let g = wait_identified(&c, 0).await;
        // The validation record: the fits are computed on it.
        let vfile = c.find(Locator::Id("val-file")).await.unwrap();
        vfile.send_keys(&val.display().to_string()).await.unwrap();
        let g = wait_identified(&c, g).await;
        let t = Instant::now();
        while !text(&c, "#val-name").await.contains("val.csv") {
            assert!(t.elapsed() < Duration::from_secs(20), "no validation record");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        // Keep the automatic order's model, then order 1's.
        let boards = status(&c, "board").await;
        c.find(Locator::Id("keep")).await.unwrap().click().await.unwrap();
        let t = Instant::now();
        while status(&c, "board").await <= boards {
            assert!(t.elapsed() < Duration::from_secs(20), "no board");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let slider = c.find(Locator::Id("order-slider")).await.unwrap();
        slider.send_keys(&Key::Home.to_string()).await.unwrap();
        let g = wait_identified(&c, g).await;
        let boards = status(&c, "board").await;
        c.find(Locator::Id("keep")).await.unwrap().click().await.unwrap();
        let t = Instant::now();
        while status(&c, "board").await <= boards {
            assert!(t.elapsed() < Duration::from_secs(20), "no board");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        assert_eq!(text(&c, "#board-data").await, "val.csv");
        let rows = js(&c, "return document.querySelectorAll('#board tr').length;").await;
        assert_eq!(rows.as_u64(), Some(3), "header and two models");
        let resp = html(&c, "board-response").await;
        assert!(resp.contains("#1") && resp.contains("#2") && resp.contains("measured"));
        assert!(html(&c, "board-step").await.contains("#2"));
        assert!(html(&c, "board-bode").await.contains("#1"));
        // Model #2 (order 1) fits the validation record worse than #1.
        let fits = js(
            &c,
            "return Array.from(document.querySelectorAll('#board tr')).slice(1).map(r => Number(r.children[2].textContent));",
        )
        .await;
        let fits: Vec<f64> = fits.as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        assert!(fits[0] > 95.0 && fits[0] > fits[1] + 5.0, "fits {fits:?}");
        element_shot(&c, "#board-block", &shots, "b1-board-two-models.png").await;
        // Save #1: the model its command line writes.
        let command = js(&c, "return document.querySelector('#board tr:nth-child(2) code').textContent;").await;
        let model = c
            .execute_async(
                "const done = arguments[arguments.length - 1]; fetch(document.querySelector('#board tr:nth-child(2) a').href).then(r => r.text()).then(done);",
                vec![],
            )
            .await
            .unwrap();
        // Remove #2.
        let boards = status(&c, "board").await;
        js(&c, "document.querySelectorAll('#board tr')[2].querySelector('button').click(); return 0;").await;
        let t = Instant::now();
        while status(&c, "board").await <= boards {
            assert!(t.elapsed() < Duration::from_secs(20), "no board after remove");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let rows = js(&c, "return document.querySelectorAll('#board tr').length;").await;
        assert_eq!(rows.as_u64(), Some(2));
        // The AIC curve over the orders.
        c.execute("const s = document.getElementById('order-criterion'); s.value = 'aic'; s.dispatchEvent(new Event('change')); return 0;", vec![]).await.unwrap();
        let g = wait_identified(&c, g).await;
        let crit = html(&c, "fig-criterion").await;
        assert!(crit.contains("Order criterion: Aic"), "{}", &crit[..crit.len().min(200)]);
        assert!(text(&c, "#command").await.contains("--order-criterion aic"));
        // PEM refinement of the shown model.
        c.find(Locator::Id("refine")).await.unwrap().click().await.unwrap();
        wait_identified(&c, g).await;
        assert!(text(&c, "#command").await.contains("--refine pem"));
        let refinement = text(&c, "#refinement").await;
        assert!(refinement.starts_with("PEM refinement:"), "{refinement}");
        // How the refinement was judged is shown with it.
        assert!(refinement.contains("decided on"), "{refinement}");
        // Delays.
        c.find(Locator::Id("delay")).await.unwrap().click().await.unwrap();
        let t = Instant::now();
        while status(&c, "delays").await == 0 {
            assert!(t.elapsed() < Duration::from_secs(20), "no delays");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let d = text(&c, "#delays").await;
        assert!(d.contains("u1 → y1"), "{d}");
        element_shot(&c, "#method-block", &shots, "b2-criterion-refine-delays.png").await;
        element_shot(&c, "#order-block", &shots, "b3-order-criterion.png").await;
        assert_eq!(status(&c, "jserrors").await, 0);
        assert_eq!(status(&c, "csp").await, 0);
        c.close().await.unwrap();
        (command.as_str().unwrap_or("").to_string(), model.as_str().unwrap_or("").to_string())
    });
    let out = dir.join("cli.json");
    run_command_line(&command, &rec, &out);
    let cli: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let page: Value = serde_json::from_str(&model).expect("the saved model is JSON");
    assert_eq!(comparable(cli), comparable(page));
}

/// Issue 28: estimation and validation rows of the record, by the numeric
/// fields and by dragging on the input plot: the model is identified on
/// the estimation rows (their file is the command line's `--data` and the
/// page's "Save estimation data"), checked on the validation rows, and
/// equals the model that command writes on the downloaded rows; the
/// ranges are marked on the time plots; a range outside the record is a
/// named error. Screenshot `r1-ranges.png`.
#[test]
fn studio_time_ranges_in_headless_chromium() {
    let Some((chromium, driver)) = browser_or_skip() else {
        return;
    };
    let dir = tmp("ranges");
    let rec = dir.join("rec.csv");
    std::fs::write(&rec, record(4000, 1)).unwrap();
    let shots = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/studio-screenshots");
    std::fs::create_dir_all(&shots).unwrap();
    let (_studio, url) = start_studio(&dir);
    let (_driver, port) = start_driver(&driver);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let (command, model, rows) = rt.block_on(async {
        let c = connect(&chromium, port, &dir.join("profile")).await;
        c.goto(&url).await.unwrap();
        let file = c.find(Locator::Id("file")).await.unwrap();
        file.send_keys(&rec.display().to_string()).await.unwrap();
        let g = wait_identified(&c, 0).await;
        // The fields: 0 … 200 s to estimate, 200 … 399.9 s to validate
        // (T = 0.1 s: rows 0 … 2000 and 2000 … 3999).
        for (id, v) in [("est-t0", "0"), ("est-t1", "200"), ("vr-t0", "200"), ("vr-t1", "399.9")] {
            c.execute(&format!("document.getElementById('{id}').value = '{v}'; return 0;"), vec![]).await.unwrap();
        }
        c.find(Locator::Id("ranges-apply")).await.unwrap().click().await.unwrap();
        let g = wait_identified(&c, g).await;
        let command = text(&c, "#command").await;
        assert!(command.contains("--data rec_rows0-2001.csv"), "{command}");
        assert_eq!(text(&c, "#validation-data").await, "rec_rows2000-4000.csv");
        assert!(html(&c, "fig-inputs").await.contains("estimation rows 0 … 200 s"));
        // Drag on the input plot from a quarter to a half of its width:
        // the estimation rows follow.
        c.execute("document.querySelector('input[name=drag][value=estimation]').click(); return 0;", vec![]).await.unwrap();
        js(
            &c,
            "const d = document.getElementById('fig-inputs'); const s = d.querySelector('svg');
             const r = s.getBoundingClientRect(); const y = r.top + r.height / 2;
             d.dispatchEvent(new MouseEvent('mousedown', {button: 0, clientX: r.left + r.width * 0.25, clientY: y, bubbles: true}));
             window.dispatchEvent(new MouseEvent('mouseup', {button: 0, clientX: r.left + r.width * 0.5, clientY: y, bubbles: true}));
             return 0;",
        )
        .await;
        wait_identified(&c, g).await;
        wait_settled(&c).await;
        let t0: f64 = js(&c, "return Number(document.getElementById('est-t0').value);").await.as_f64().unwrap();
        let t1: f64 = js(&c, "return Number(document.getElementById('est-t1').value);").await.as_f64().unwrap();
        // x = 0.25 W and 0.5 W (W = 900) on the plot area 70 … 890 over
        // the axis padded by 5 %, −20 … 420 s: about 63 s and 184 s.
        assert!((t0 - 63.0).abs() < 10.0 && (t1 - 184.0).abs() < 10.0, "{t0} … {t1}");
        let command = text(&c, "#command").await;
        assert!(command.contains("--data rec_rows"), "{command}");
        element_shot(&c, "#io-block", &shots, "r1-ranges.png").await;
        let fetch = |id: &str| {
            format!("const done = arguments[arguments.length - 1]; fetch(document.getElementById('{id}').href).then(r => r.text()).then(done);")
        };
        let model = c.execute_async(&fetch("save-model"), vec![]).await.unwrap();
        let rows = c.execute_async(&fetch("save-data"), vec![]).await.unwrap();
        // A range outside the record: a named error.
        for (id, v) in [("est-t0", "100"), ("est-t1", "9000")] {
            c.execute(&format!("document.getElementById('{id}').value = '{v}'; return 0;"), vec![]).await.unwrap();
        }
        let failed = status(&c, "failed").await;
        c.find(Locator::Id("ranges-apply")).await.unwrap().click().await.unwrap();
        wait_failed(&c, failed).await;
        let err = page_error(&c).await;
        assert!(err.contains("estimation range") && err.contains("outside the record"), "{err}");
        assert_eq!(status(&c, "jserrors").await, 0);
        c.close().await.unwrap();
        (
            command,
            model.as_str().unwrap_or("").to_string(),
            rows.as_str().unwrap_or("").to_string(),
        )
    });
    assert!(rows.starts_with("t,u1,y1\n"));
    let slice = dir.join("slice.csv");
    std::fs::write(&slice, &rows).unwrap();
    let out = dir.join("cli.json");
    run_command_line(&command, &slice, &out);
    let cli: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let page: Value = serde_json::from_str(&model).expect("the saved model is JSON");
    assert_eq!(comparable(cli), comparable(page));
}

/// Issue 28: the page's "More experiments" picker: q-Markov on one file
/// per input, both files on the command line. Screenshot
/// `e1-experiments.png`.
#[test]
fn studio_takes_one_file_per_input_in_chromium() {
    let Some((chromium, driver)) = browser_or_skip() else {
        return;
    };
    let dir = tmp("per-input-browser");
    let [a, b] = per_input_records();
    let (fa, fb) = (dir.join("u1.csv"), dir.join("u2.csv"));
    std::fs::write(&fa, a).unwrap();
    std::fs::write(&fb, b).unwrap();
    let shots = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/studio-screenshots");
    std::fs::create_dir_all(&shots).unwrap();
    let (_studio, url) = start_studio(&dir);
    let (_driver, port) = start_driver(&driver);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let c = connect(&chromium, port, &dir.join("profile")).await;
        c.goto(&url).await.unwrap();
        let file = c.find(Locator::Id("file")).await.unwrap();
        file.send_keys(&fa.display().to_string()).await.unwrap();
        // N4SID on the first file alone (u2 ≡ 0) fails: a named error.
        let f = wait_failed(&c, 0).await;
        assert!(page_error(&c).await.contains("persistently exciting"));
        c.execute(
            "document.getElementById('prbs-order').value = '6';
             const m = document.getElementById('method'); m.value = 'qmarkov';
             m.dispatchEvent(new Event('change')); return 0;",
            vec![],
        )
        .await
        .unwrap();
        // q-Markov with one file for two inputs: refused, named.
        wait_failed(&c, f).await;
        let exp = c.find(Locator::Id("exp-file")).await.unwrap();
        exp.send_keys(&fb.display().to_string()).await.unwrap();
        let t = Instant::now();
        while status(&c, "generation").await == 0 || status(&c, "busy").await == 1 {
            assert!(
                t.elapsed() < Duration::from_secs(30),
                "no model: {}",
                page_error(&c).await
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let command = text(&c, "#command").await;
        assert!(command.contains("--data u1.csv --data u2.csv"), "{command}");
        assert!(command.contains("--method qmarkov"), "{command}");
        assert!(text(&c, "#exp-names").await.contains("u2.csv"));
        element_shot(&c, "#load-block", &shots, "e1-experiments.png").await;
        assert_eq!(status(&c, "jserrors").await, 0);
        c.close().await.unwrap();
    });
}

/// Issue 47: a ninth tab drops the least recently used tab's session; that
/// tab's next identification is told "session expired" (the page shows it
/// where the record's name stood) instead of running on another record.
#[test]
fn studio_tells_a_dropped_tab_its_session_expired_in_chromium() {
    let Some((chromium, driver)) = browser_or_skip() else {
        return;
    };
    let dir = tmp("browser-expired");
    let rec = dir.join("first.csv");
    std::fs::write(&rec, record(600, 1)).unwrap();
    let shots = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/screens");
    std::fs::create_dir_all(&shots).unwrap();
    let (_studio, url) = start_studio(&dir);
    let (_driver, port) = start_driver(&driver);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let c = connect(&chromium, port, &dir.join("profile")).await;
        c.goto(&url).await.unwrap();
        let file = c.find(Locator::Id("file")).await.unwrap();
        file.send_keys(&rec.display().to_string()).await.unwrap();
        let shown = wait_identified(&c, 0).await;
        assert!(text(&c, "#data-name").await.starts_with("first.csv"));
        let first = c.window().await.unwrap();
        // Eight more tabs, each opening its own session on load: nine in
        // all, one more than the server keeps.
        for _ in 0..MAX_SESSIONS {
            let w = c.new_window(true).await.unwrap().handle;
            c.switch_to_window(w).await.unwrap();
            c.goto(&url).await.unwrap();
            let t = Instant::now();
            while js(
                &c,
                "return document.getElementById('status').dataset.session || '';",
            )
            .await
            .as_str()
                != Some("open")
            {
                assert!(t.elapsed() < Duration::from_secs(30), "no session opened");
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        }
        c.switch_to_window(first).await.unwrap();
        let failed = status(&c, "failed").await;
        // Identify again (the automatic order): the call names the dropped
        // session.
        c.find(Locator::Id("order-auto"))
            .await
            .unwrap()
            .click()
            .await
            .unwrap();
        wait_failed(&c, failed).await;
        let err = page_error(&c).await;
        assert!(err.contains("session expired"), "{err}");
        assert!(err.contains("reload the page"), "{err}");
        let name = text(&c, "#data-name").await;
        assert!(name.starts_with("Session expired"), "{name}");
        // No answer of another record was shown.
        assert_eq!(status(&c, "generation").await, shown);
        assert_eq!(status(&c, "jserrors").await, 0);
        shot(&c, &shots, "studio-session-expired.png").await;
        // A reload opens a new session on the page.
        c.refresh().await.unwrap();
        let t = Instant::now();
        while js(
            &c,
            "return document.getElementById('status').dataset.session || '';",
        )
        .await
        .as_str()
            != Some("open")
        {
            assert!(
                t.elapsed() < Duration::from_secs(30),
                "no session after reload"
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        assert_eq!(page_error(&c).await, "");
        c.close().await.unwrap();
    });
}

/// Issue 47: plant tags say what a column is (`FIC101.OP` an input,
/// `TI203.PV` an output, even with a first letter that reads otherwise);
/// names that say nothing make a guess the page must have confirmed.
#[test]
fn session_reads_channels_from_plant_tags_and_says_when_it_guesses() {
    let dir = tmp("tags");
    let mut s = Session::new(&dir).unwrap();
    let tagged = record(400, 1).replacen("t,u1,y1", "t,TI203.PV,RIC7.OP", 1);
    // The tags decide, whatever the column order and first letters.
    let info = s.upload("tags.csv", tagged.as_bytes()).unwrap();
    assert_eq!(info.suggested_inputs, ["RIC7.OP"]);
    assert_eq!(info.suggested_outputs, ["TI203.PV"]);
    assert!(!info.channels_guessed);
    let plain = record(400, 1).replacen("t,u1,y1", "t,a,b", 1);
    let info = s.upload("plain.csv", plain.as_bytes()).unwrap();
    assert_eq!(info.suggested_inputs, ["a"]);
    assert_eq!(info.suggested_outputs, ["b"]);
    assert!(info.channels_guessed);
    s.close();
}

/// Issue 47: with guessed channels the page identifies nothing until the
/// user confirms them; then it does.
#[test]
fn studio_asks_to_confirm_guessed_channels_in_chromium() {
    let Some((chromium, driver)) = browser_or_skip() else {
        return;
    };
    let dir = tmp("browser-confirm");
    let rec = dir.join("plain.csv");
    std::fs::write(&rec, record(600, 1).replacen("t,u1,y1", "t,a,b", 1)).unwrap();
    let shots = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/screens");
    std::fs::create_dir_all(&shots).unwrap();
    let (_studio, url) = start_studio(&dir);
    let (_driver, port) = start_driver(&driver);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let c = connect(&chromium, port, &dir.join("profile")).await;
        c.goto(&url).await.unwrap();
        let file = c.find(Locator::Id("file")).await.unwrap();
        file.send_keys(&rec.display().to_string()).await.unwrap();
        // The view comes, the identification does not.
        let t = Instant::now();
        while status(&c, "view").await == 0 {
            assert!(t.elapsed() < Duration::from_secs(30), "no view");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        tokio::time::sleep(Duration::from_millis(500)).await;
        assert_eq!(status(&c, "generation").await, 0, "identified a guess");
        let hidden = js(
            &c,
            "return document.getElementById('confirm-channels').hidden;",
        )
        .await;
        assert_eq!(hidden, json!(false));
        shot(&c, &shots, "studio-confirm-channels.png").await;
        c.find(Locator::Id("confirm-button"))
            .await
            .unwrap()
            .click()
            .await
            .unwrap();
        wait_identified(&c, 0).await;
        let hidden = js(
            &c,
            "return document.getElementById('confirm-channels').hidden;",
        )
        .await;
        assert_eq!(hidden, json!(true));
        assert_eq!(status(&c, "jserrors").await, 0);
        c.close().await.unwrap();
    });
}

/// Issue 47: an upload is checked cell by cell without keeping its values
/// (a wide file is accepted whatever its size within the upload limit),
/// and a request whose chosen channels need more memory than
/// `lifted studio --memory-limit` is refused naming the budget, before
/// anything is read.
#[test]
fn studio_bounds_a_request_by_its_memory_budget() {
    let parent = tmp("memory-limit");
    let (proc, url) = start_studio_with(&parent, &["--memory-limit", "64K"]);
    let rest = url.trim_start_matches("http://127.0.0.1:");
    let (port, token) = rest.split_once("/?token=").expect("URL with token");
    let port: u16 = port.parse().unwrap();
    let call = |method: &str, path: &str, ctype: &str, body: &[u8]| {
        let mut h = vec![("X-Lifted-Token", token)];
        if !ctype.is_empty() {
            h.push(("Content-Type", ctype));
        }
        raw(port, method, path, &h, body)
    };
    // 3000 rows: 3000 × 2 channels × 8 bytes × 5 copies = 240 kB > 64 KiB.
    let r = call(
        "POST",
        "/api/data?name=rec.csv",
        "application/octet-stream",
        record(3000, 1).as_bytes(),
    );
    assert_eq!(r.status, 200, "{}", r.body);
    let v: Value = serde_json::from_str(&r.body).unwrap();
    assert_eq!(v["rows"], json!(3000));
    let r = call(
        "POST",
        "/api/identify",
        "application/json",
        n4sid("2").to_string().as_bytes(),
    );
    assert_eq!(r.status, 400, "{}", r.body);
    assert!(
        r.body.contains("--memory-limit") && r.body.contains("64.0 KiB"),
        "{}",
        r.body
    );
    drop(proc);
}

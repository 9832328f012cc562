//! The studio's session in process: it identifies as the command line does, shows
//! hostile names as text, keeps records, compressions and identifications between
//! moves, sends only the figures that changed, and says what it sees in the data.

use crate::common::*;
use crate::markup;
use lifted_cli::studio::{Request, Session};
use lifted_prbs::{InversePrbs, InversePrbsOptions};
use serde_json::{Value, json};

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

/// Issue 48: the studio's plan. A model's plan (its workflow options,
/// `GET /api/plan`) given back as the request's `plan` makes the same
/// model, bit for bit, with the option fields left out; the command line
/// shown says `--plan plan.json`, and `lifted identify --plan` with the
/// saved plan writes that model too. A plan with a field the options do
/// not have is refused naming it.
#[test]
fn session_takes_a_plan_and_saves_one() {
    let dir = tmp("plan");
    let mut s = Session::new(&dir).unwrap();
    let csv = record(1500, 2);
    s.upload("rec.csv", csv.as_bytes()).unwrap();
    let mut asked = request("2");
    asked.method = Some("moesp".into());
    asked.horizon = Some(8);
    asked.refine = Some("pem".into());
    let first = s.identify(&asked).unwrap();
    let made: Value = serde_json::from_str(&s.model_json(None).unwrap()).unwrap();
    let plan_text = s.plan_json(None).unwrap();
    let plan: Value = serde_json::from_str(&plan_text).unwrap();
    assert_eq!(plan["identification"]["method"], json!("moesp"));
    assert_eq!(plan["identification"]["horizon"], json!(8));

    let planned = Request {
        inputs: vec!["u1".into()],
        outputs: vec!["y1".into()],
        plan: Some(plan.clone()),
        ..Default::default()
    };
    let again = s.identify(&planned).unwrap();
    assert_eq!(again.order, first.order);
    assert!(
        again.command.contains("--plan plan.json") && !again.command.contains("--method"),
        "{}",
        again.command
    );
    let remade: Value = serde_json::from_str(&s.model_json(None).unwrap()).unwrap();
    assert_eq!(comparable(remade.clone()), comparable(made.clone()));

    // The command line shown, with the saved plan, writes the same model.
    let (data, plan_path, out) = (
        dir.join("rec.csv"),
        dir.join("plan.json"),
        dir.join("cli.json"),
    );
    std::fs::write(&data, &csv).unwrap();
    std::fs::write(&plan_path, &plan_text).unwrap();
    let mut args: Vec<String> = Vec::new();
    let words: Vec<&str> = again.command.split_whitespace().skip(1).collect();
    let mut it = words.iter();
    while let Some(w) = it.next() {
        args.push(w.to_string());
        let path = match *w {
            "--data" => Some(&data),
            "--plan" => Some(&plan_path),
            "--out" => Some(&out),
            _ => None,
        };
        if let Some(p) = path {
            it.next();
            args.push(p.display().to_string());
        }
    }
    run_lifted(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let cli: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(comparable(cli), comparable(made));

    let typo = Request {
        plan: Some(json!({"identification": {"max_ordr": 3}})),
        ..planned
    };
    let e = s.identify(&typo).unwrap_err().to_string();
    assert!(e.contains("max_ordr"), "{e}");
    s.close();
}

/// Issue 49: the studio's step and Bode figures carry the confidence band
/// of the model's covariance at the page's level (95 % by default, the
/// band's legend names it), none at level 0, and a level outside [0, 1)
/// is refused naming the option.
#[test]
fn session_draws_the_models_confidence_bands_at_the_pages_level() {
    let dir = tmp("bands");
    let mut s = Session::new(&dir).unwrap();
    s.upload("rec.csv", record(1500, 1).as_bytes()).unwrap();
    let with = s.identify(&request("2")).unwrap();
    assert!(with.figures.bode.contains("±95 %"), "Bode band legend");
    assert!(with.figures.step.contains("±95 %"), "step band legend");
    let at99 = s
        .identify(&Request {
            confidence: Some(0.99),
            ..request("2")
        })
        .unwrap();
    assert!(at99.figures.bode.contains("±99 %"));
    let none = s
        .identify(&Request {
            confidence: Some(0.0),
            ..request("2")
        })
        .unwrap();
    assert!(!none.figures.bode.contains("±") && !none.figures.step.contains("±"));
    let err = s
        .identify(&Request {
            confidence: Some(1.5),
            ..request("2")
        })
        .unwrap_err()
        .to_string();
    assert!(err.contains("confidence"), "{err}");
    s.close();
}

/// Issue 49: the studio offers the model families of `lifted identify`
/// (ARX with MATLAB's order vector, OE at the slider's order, a process
/// model) and shows their parameters ± σ; a state-space model's entries
/// come with theirs; the command line shown makes the same model.
#[test]
fn session_identifies_the_model_families_with_their_deviations() {
    let dir = tmp("families");
    let mut s = Session::new(&dir).unwrap();
    let csv = record(1500, 1);
    s.upload("rec.csv", csv.as_bytes()).unwrap();
    let arx = s
        .identify(&Request {
            method: Some("arx".into()),
            order: None,
            orders: Some("2,2,1".into()),
            ..request("2")
        })
        .unwrap();
    let arx_json = s.model_json(None).unwrap();
    let text = arx.parameters.as_deref().unwrap_or("");
    assert!(text.contains("A(q)") && text.contains("±"), "{text}");
    assert!(arx.command.contains("--orders"), "{}", arx.command);
    assert!(arx.figures.bode.contains("±95 %"));
    let oe = s
        .identify(&Request {
            method: Some("oe".into()),
            ..request("2")
        })
        .unwrap();
    assert!(
        oe.parameters.as_deref().unwrap_or("").contains("F(q)"),
        "{:?}",
        oe.parameters
    );
    let process = s
        .identify(&Request {
            method: Some("process".into()),
            order: None,
            process: Some("p1d".into()),
            ..request("2")
        })
        .unwrap();
    let text = process.parameters.as_deref().unwrap_or("");
    assert!(
        text.contains("process model P1D") || text.contains("process model p1d"),
        "{text}"
    );
    let ss = s.identify(&request("2")).unwrap();
    assert!(
        ss.parameters.as_deref().unwrap_or("").contains("A ="),
        "{:?}",
        ss.parameters
    );
    // The ARX command line makes the studio's model.
    let path = dir.join("rec.csv");
    std::fs::write(&path, &csv).unwrap();
    let out = dir.join("arx.json");
    run_command_line(&arx.command, &path, &out);
    let cli: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let studio: Value = serde_json::from_str(&arx_json).unwrap();
    assert_eq!(cli["polynomial"], studio["polynomial"]);
    let bad = s.identify(&Request {
        method: Some("process".into()),
        order: None,
        process: Some("p9x".into()),
        ..request("2")
    });
    assert!(bad.unwrap_err().to_string().contains("process"));
    s.close();
}

/// Issue 49: the studio offers the regularised models (the regularised
/// FIR, the regularised ARX with its kernel) and the process models'
/// intersample behaviour; the diagnostics record them and the command line
/// shown makes the same model.
#[test]
fn session_offers_the_kernels_and_the_first_order_hold() {
    let dir = tmp("kernels");
    let mut s = Session::new(&dir).unwrap();
    let csv = record(1500, 1);
    s.upload("rec.csv", csv.as_bytes()).unwrap();
    let path = dir.join("rec.csv");
    std::fs::write(&path, &csv).unwrap();
    let cases = [
        (
            "regularised ARX",
            Request {
                method: Some("arx".into()),
                order: None,
                orders: Some("8,8,1".into()),
                kernel: Some("dc".into()),
                ..request("2")
            },
            "--kernel dc",
            "regularization",
        ),
        (
            "regularised FIR",
            Request {
                method: Some("impulse".into()),
                order: None,
                orders: Some("30,1".into()),
                ..request("2")
            },
            "--method impulse",
            "hyperparameters",
        ),
        (
            "process model, first-order hold",
            Request {
                method: Some("process".into()),
                order: None,
                process: Some("p1d".into()),
                intersample: Some("foh".into()),
                ..request("2")
            },
            "--intersample foh",
            "Foh",
        ),
    ];
    for (i, (what, r, flag, fact)) in cases.into_iter().enumerate() {
        let answer = s.identify(&r).unwrap_or_else(|e| panic!("{what}: {e}"));
        assert!(answer.command.contains(flag), "{what}: {}", answer.command);
        let studio: Value = serde_json::from_str(&s.model_json(None).unwrap()).unwrap();
        assert!(
            studio.to_string().contains(fact),
            "{what}: the diagnostics do not record {fact}"
        );
        let out = dir.join(format!("kernel-{i}.json"));
        run_command_line(&answer.command, &path, &out);
        let cli: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        assert_eq!(cli["model"], studio["model"], "{what}");
        assert_eq!(cli["polynomial"], studio["polynomial"], "{what}");
    }
    s.close();
}

//! The studio in headless Chromium: the page, another origin refused, one model shown
//! and saved, a session per tab, an expired session said, guessed channels confirmed.

use crate::common::*;
use fantoccini::{Client, Locator, key::Key};
use lifted_cli::studio::MAX_SESSIONS;
use serde_json::{Value, json};
use std::path::Path;
use std::time::{Duration, Instant};

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

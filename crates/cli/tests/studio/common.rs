//! Records, requests and the studio server the studio tests share.

use fantoccini::{Client, Locator, key::Key};
use lifted_cli::studio::Request;
use lifted_prbs::{InversePrbs, InversePrbsOptions};
use serde_json::{Value, json};
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

pub(crate) use crate::browser::*;
use crate::markup;

/// A fresh directory under the system temp dir.
pub(crate) fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lifted-studio-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A random binary input (xorshift, fixed seed).
pub(crate) fn binary_input(n: usize) -> Vec<f64> {
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
pub(crate) fn record_of(u: &[f64], slow: usize) -> String {
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
pub(crate) fn record(n: usize, slow: usize) -> String {
    record_of(&binary_input(n), slow)
}

pub(crate) fn request(order: &str) -> Request {
    Request {
        inputs: vec!["u1".into()],
        outputs: vec!["y1".into()],
        method: Some("n4sid".into()),
        order: Some(order.into()),
        ..Default::default()
    }
}

/// The model file without the facts that name the run (file path, times).
pub(crate) fn comparable(mut v: Value) -> Value {
    if let Some(d) = v.get_mut("diagnostics").and_then(Value::as_object_mut) {
        d.remove("profile");
        d.remove("data");
    }
    v
}

pub(crate) fn run_lifted(args: &[&str]) -> String {
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
pub(crate) fn run_command_line(command: &str, data: &Path, out: &Path) {
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

/// Every string of the parts of an answer the page inserts as markup (the
/// SVG figures), each read as the page reads it (`innerHTML`): nothing in
/// it may run script. (The other fields, such as channel names, go in as
/// text nodes.)
pub(crate) fn assert_inert(answer: &Value, what: &str) {
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

/// The records of a 2-input, 1-output plant y = 0.5/(z − 0.7) u1 +
/// 0.3/(z + 0.4) u2 for q-Markov: one file per input, the other input 0,
/// each a PRBS of order 6 held one sample (four periods).
pub(crate) fn per_input_records() -> [String; 2] {
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

/// A PI loop around y(t+1) = 1.6 y(t) − 0.73 y(t−1) + 0.5 u(t) + 0.3 u(t−1)
/// (second order), the controller acting on the noisy output, the
/// set-point a random ±1 level: a CSV `t,u1,y1,r1`.
pub(crate) fn closed_loop_csv(n: usize) -> String {
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

/// An answer read off the socket.
pub(crate) struct Answer {
    pub(crate) status: u16,
    pub(crate) head: String,
    pub(crate) body: String,
}

impl Answer {
    pub(crate) fn header(&self, name: &str) -> Option<&str> {
        self.head.lines().find_map(|l| {
            let (k, v) = l.split_once(':')?;
            k.trim().eq_ignore_ascii_case(name).then_some(v.trim())
        })
    }

    /// The `error` of a JSON error answer (panics if it is not one).
    pub(crate) fn error(&self) -> String {
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
pub(crate) fn raw(
    port: u16,
    method: &str,
    path: &str,
    headers: &[(&str, &str)],
    body: &[u8],
) -> Answer {
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
pub(crate) struct Studio {
    pub(crate) proc: Option<Proc>,
    pub(crate) port: u16,
    pub(crate) token: String,
    pub(crate) scratch: PathBuf,
}

impl Studio {
    /// `lifted studio` with TMPDIR = `parent` (which holds nothing else).
    pub(crate) fn start(parent: &Path) -> Studio {
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
    pub(crate) fn call(&self, method: &str, path: &str, ctype: &str, body: &[u8]) -> Answer {
        let mut h = vec![("X-Lifted-Token", self.token.as_str())];
        if !ctype.is_empty() {
            h.push(("Content-Type", ctype));
        }
        raw(self.port, method, path, &h, body)
    }

    pub(crate) fn upload(&self, name: &str, csv: &str) -> Answer {
        self.call(
            "POST",
            &format!("/api/data?name={name}"),
            "application/octet-stream",
            csv.as_bytes(),
        )
    }

    pub(crate) fn identify(&self, r: &Value) -> Answer {
        self.call(
            "POST",
            "/api/identify",
            "application/json",
            r.to_string().as_bytes(),
        )
    }

    /// The loaded record's (name, rows), from `GET /api/data`.
    pub(crate) fn record(&self) -> (String, u64) {
        let a = self.call("GET", "/api/data", "", b"");
        assert_eq!(a.status, 200, "{}", a.body);
        let v: Value = serde_json::from_str(&a.body).unwrap();
        (
            v["name"].as_str().unwrap_or("").to_string(),
            v["rows"].as_u64().unwrap_or(0),
        )
    }

    /// Stops the server with `signal` and waits for it.
    pub(crate) fn stop(&mut self, signal: &str) {
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

pub(crate) fn n4sid(order: &str) -> Value {
    json!({"inputs": ["u1"], "outputs": ["y1"], "method": "n4sid", "order": order})
}

/// A second origin: a tiny server on another port of 127.0.0.1 that
/// answers every request with an empty page (the test's script runs in it).
pub(crate) fn other_origin() -> u16 {
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
pub(crate) async fn page_error(c: &Client) -> String {
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
pub(crate) async fn wait_failed(c: &Client, after: u64) -> u64 {
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
pub(crate) async fn set_field(c: &Client, id: &str, value: &str) {
    let f = c.find(Locator::Id(id)).await.unwrap();
    f.clear().await.unwrap();
    f.send_keys(&format!("{value}{}", Key::Enter))
        .await
        .unwrap();
}

pub(crate) async fn saves_disabled(c: &Client) -> bool {
    js(
        c,
        "const a = document.getElementById('save-model'); \
         return !a.hasAttribute('href') && a.getAttribute('aria-disabled') === 'true';",
    )
    .await
    .as_bool()
    .unwrap_or(false)
}

/// The CSV of a plant with an unstable mode (x1⁺ = 1.004 x1 + 0.5 u) beside
/// a stable one, under a random binary input: N4SID's models of it are
/// unstable, so the page must show "n/a: unstable" for the fit.
pub(crate) fn unstable_record(n: usize) -> String {
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
pub(crate) async fn saved_model(c: &Client) -> Value {
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
pub(crate) fn order_of(model: &Value) -> usize {
    model["a"].as_array().map_or(0, Vec::len)
}

/// Waits until the page is idle with no request outstanding (its last
/// answer shown) and returns the number of identifications shown.
pub(crate) async fn wait_settled(c: &Client) -> u64 {
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
pub(crate) async fn press_50ms_apart(c: &Client, keys: &[Key]) {
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

/// A record without a time column (`u1,y1`), `n` samples of the plant.
pub(crate) fn untimed_record(n: usize) -> String {
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
pub(crate) fn drawn_points(svg: &str) -> usize {
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

pub(crate) async fn element_shot(c: &Client, css: &str, dir: &Path, name: &str) {
    let e = c.find(Locator::Css(css)).await.expect("element");
    let png = e.screenshot().await.expect("screenshot");
    std::fs::write(dir.join(name), png).unwrap();
}

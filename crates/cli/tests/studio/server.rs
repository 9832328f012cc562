//! The studio server over HTTP: foreign requests refused with its state kept, its
//! scratch folder removed on every exit, requests bounded by the memory budget.

use crate::common::*;
use lifted_cli::studio::{MAX_JSON, MAX_UPLOAD};
use serde_json::{Value, json};
use std::process::Command;

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

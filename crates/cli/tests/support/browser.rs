//! Driving `lifted studio` in headless Chromium over WebDriver
//! (chromedriver + fantoccini): the studio and the driver as child
//! processes, the page's status read back. Shared by the browser tests
//! (`tests/studio.rs`) and the browser-timed bench
//! (`benches/studio_browser.rs`), each of which includes it with `#[path]`.

use std::io::{BufRead, BufReader};
use std::net::TcpListener;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use fantoccini::{Client, ClientBuilder, Locator};
use serde_json::{Value, json};

/// Kills a child process when dropped (SIGTERM first for the studio, so it
/// removes its scratch directory).
pub struct Proc(pub Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = Command::new("kill")
            .arg("-TERM")
            .arg(self.0.id().to_string())
            .stderr(Stdio::null())
            .status();
        let t = Instant::now();
        while t.elapsed() < Duration::from_secs(3) {
            if let Ok(Some(_)) = self.0.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Chromium and chromedriver, or `None` (the test says it is skipped)
/// unless `LIFTED_BROWSER_TESTS=require`, where their absence fails it.
pub fn browser_or_skip() -> Option<(String, String)> {
    let found = browser_paths();
    if found.is_none() {
        let required = std::env::var("LIFTED_BROWSER_TESTS").is_ok_and(|v| v == "require");
        assert!(
            !required,
            "LIFTED_BROWSER_TESTS=require but chromium/chromedriver were not found"
        );
        eprintln!("studio browser test skipped: install chromium and chromium-driver");
    }
    found
}

pub fn browser_paths() -> Option<(String, String)> {
    let find = |var: &str, default: &str| {
        std::env::var(var)
            .ok()
            .or_else(|| Path::new(default).exists().then(|| default.to_string()))
    };
    let chromium = find("LIFTED_CHROMIUM", "/usr/bin/chromium")?;
    let driver = find("LIFTED_CHROMEDRIVER", "/usr/bin/chromedriver")?;
    Some((chromium, driver))
}

pub fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Starts `lifted studio --port 0` with its scratch directory under
/// `parent` (as TMPDIR) and its stderr in `parent/studio.log`, and returns
/// it with its URL (with the token).
pub fn start_studio(parent: &Path) -> (Proc, String) {
    start_studio_with(parent, &[])
}

/// [`start_studio`] with more arguments of `lifted studio`.
pub fn start_studio_with(parent: &Path, more: &[&str]) -> (Proc, String) {
    let log = std::fs::File::create(parent.join("studio.log")).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_lifted"))
        .args(["studio", "--port", "0"])
        .args(more)
        .env("TMPDIR", parent)
        .stdout(Stdio::piped())
        .stderr(log)
        .spawn()
        .expect("lifted studio starts");
    let stdout = child.stdout.take().unwrap();
    let mut line = String::new();
    BufReader::new(stdout).read_line(&mut line).unwrap();
    let url = line
        .split_whitespace()
        .find(|w| w.starts_with("http://"))
        .unwrap_or_else(|| panic!("no URL in {line:?}"))
        .to_string();
    (Proc(child), url)
}

pub fn start_driver(driver: &str) -> (Proc, u16) {
    let port = free_port();
    let child = Command::new(driver)
        .arg(format!("--port={port}"))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("chromedriver starts");
    let t = Instant::now();
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(
            t.elapsed() < Duration::from_secs(20),
            "chromedriver does not listen"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    (Proc(child), port)
}

pub async fn connect(chromium: &str, port: u16, profile: &Path) -> Client {
    let mut caps = serde_json::Map::new();
    caps.insert(
        "goog:chromeOptions".into(),
        json!({
            "binary": chromium,
            "args": [
                "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--disable-quic", "--no-first-run", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--window-size=1400,2600",
                format!("--user-data-dir={}", profile.display()),
            ],
        }),
    );
    ClientBuilder::new(hyper_util::client::legacy::connect::HttpConnector::new())
        .capabilities(caps)
        .connect(&format!("http://127.0.0.1:{port}"))
        .await
        .expect("a WebDriver session in headless Chromium")
}

pub async fn js(c: &Client, script: &str) -> Value {
    c.execute(script, vec![]).await.expect("script runs")
}

pub async fn status(c: &Client, key: &str) -> u64 {
    js(
        c,
        &format!("return Number(document.getElementById('status').dataset.{key});"),
    )
    .await
    .as_u64()
    .unwrap_or(0)
}

/// Waits until the page has finished `after + 1` identifications (or more)
/// and is idle.
pub async fn wait_identified(c: &Client, after: u64) -> u64 {
    let t = Instant::now();
    loop {
        let g = status(c, "generation").await;
        let busy = status(c, "busy").await;
        if g > after && busy == 0 {
            return g;
        }
        let err = js(
            c,
            "const e = document.getElementById('error'); return e.hidden ? '' : e.textContent;",
        )
        .await;
        assert!(err.as_str().unwrap_or("").is_empty(), "page error: {err}");
        assert!(t.elapsed() < Duration::from_secs(60), "no identification");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

pub async fn text(c: &Client, css: &str) -> String {
    c.find(Locator::Css(css))
        .await
        .unwrap()
        .text()
        .await
        .unwrap()
}

pub async fn html(c: &Client, id: &str) -> String {
    js(
        c,
        &format!("return document.getElementById('{id}').innerHTML;"),
    )
    .await
    .as_str()
    .unwrap_or("")
    .to_string()
}

pub async fn shot(c: &Client, dir: &Path, name: &str) {
    let png = c.screenshot().await.expect("screenshot");
    std::fs::write(dir.join(name), png).unwrap();
}

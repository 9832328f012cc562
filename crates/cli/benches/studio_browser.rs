//! The studio's order slider timed in a real browser (issue 47): `lifted
//! studio` and headless Chromium (chromedriver + fantoccini) on this
//! machine, a 2×2 record of 1e5 samples loaded through the page's file
//! picker, then the slider moved one order at a time with the keyboard,
//! first up through orders the page has not shown (each an
//! identification with its Kalman-gain check, a validation and the
//! figures), then back down through the orders seen (the kept
//! identifications: the figures only). For each move the page records
//! (status `data-…`) the server's time for the answer, the time from the
//! request until the answer arrived, and until the browser had painted
//! it (the frame after the update, then the task after it); the bench
//! prints each move and the medians.
//!
//! Run: `cargo bench -p lifted-cli --bench studio_browser` (needs Debian's
//! `chromium` and `chromium-driver`, or `LIFTED_CHROMIUM` /
//! `LIFTED_CHROMEDRIVER`; without them it says so and exits;
//! `LIFTED_BENCH_RECORD=path` also writes the record there).

use std::time::{Duration, Instant};

use fantoccini::{Client, Locator, key::Key};
use lifted_lti::StateSpace;
use nalgebra::DMatrix;
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::{Rng, SeedableRng};

#[path = "../tests/support/browser.rs"]
#[allow(dead_code)]
mod browser;

/// Samples of the record.
const SAMPLES: usize = 100_000;

/// A 2×2 record of a 4-state plant (poles 0.9 ± 0.2j, 0.7, −0.5) driven by
/// random binary inputs, outputs with uniform noise of ±0.1 (seeded).
fn record() -> String {
    let a = DMatrix::from_row_slice(
        4,
        4,
        &[
            0.9, 0.2, 0.0, 0.0, -0.2, 0.9, 0.0, 0.0, 0.0, 0.0, 0.7, 0.0, 0.0, 0.0, 0.0, -0.5,
        ],
    );
    let b = DMatrix::from_row_slice(4, 2, &[1.0, 0.0, 0.0, 1.0, 1.0, 0.5, 0.3, 1.0]);
    let c = DMatrix::from_row_slice(2, 4, &[1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0]);
    let g = StateSpace::new(a, b, c, DMatrix::zeros(2, 2), Some(1.0)).expect("plant");
    let mut rng = ChaCha8Rng::seed_from_u64(47);
    let u = DMatrix::from_fn(
        SAMPLES,
        2,
        |_, _| {
            if rng.next_u32() & 1 == 1 { 1.0 } else { -1.0 }
        },
    );
    let y = g.lsim(&u, None, None).expect("simulation").y;
    let mut s = String::from("t,u1,u2,y1,y2\n");
    for k in 0..SAMPLES {
        let noise = |r: &mut ChaCha8Rng| 0.2 * (r.next_u32() as f64 / u32::MAX as f64 - 0.5);
        let (e1, e2) = (noise(&mut rng), noise(&mut rng));
        s += &format!(
            "{k},{},{},{:.6},{:.6}\n",
            u[(k, 0)],
            u[(k, 1)],
            y[(k, 0)] + e1,
            y[(k, 1)] + e2
        );
    }
    s
}

/// A number the page put in the status line's data, or 0.
async fn datum(c: &Client, key: &str) -> f64 {
    browser::js(
        c,
        &format!("return Number(document.getElementById('status').dataset.{key} || 0);"),
    )
    .await
    .as_f64()
    .unwrap_or(0.0)
}

/// One key press on the slider, then the page's times once it has drawn
/// the answer: (order, server ms, answered ms, drawn ms).
async fn move_slider(c: &Client, key: Key) -> (u64, f64, f64, f64) {
    let before = browser::status(c, "generation").await;
    let slider = c.find(Locator::Id("order-slider")).await.expect("slider");
    slider.send_keys(&key.to_string()).await.expect("key");
    let g = browser::wait_identified(c, before).await;
    let t = Instant::now();
    // Drawn: the page stamps the sequence number it painted.
    while datum(c, "drawnSeq").await != datum(c, "seq").await {
        assert!(t.elapsed() < Duration::from_secs(30), "never drawn");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let _ = g;
    (
        browser::status(c, "order").await,
        datum(c, "serverMs").await,
        datum(c, "answeredMs").await,
        datum(c, "drawnMs").await,
    )
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn main() {
    let Some((chromium, driver)) = browser::browser_paths() else {
        eprintln!("studio_browser: chromium and chromedriver not found; nothing timed");
        return;
    };
    let dir = std::env::temp_dir().join(format!("lifted-studio-bench-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch directory");
    let rec = dir.join("rec.csv");
    let text = record();
    std::fs::write(&rec, &text).expect("record written");
    // (`LIFTED_BENCH_RECORD=path` keeps a copy of the record, for
    // `lifted identify --profile` on it.)
    if let Ok(copy) = std::env::var("LIFTED_BENCH_RECORD") {
        std::fs::write(copy, &text).expect("record copy written");
    }
    let (_studio, url) = browser::start_studio(&dir);
    let (_driver, port) = browser::start_driver(&driver);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime");
    rt.block_on(async {
        let c = browser::connect(&chromium, port, &dir.join("profile")).await;
        c.goto(&url).await.expect("page");
        let file = c.find(Locator::Id("file")).await.expect("file picker");
        file.send_keys(&rec.display().to_string()).await.expect("upload");
        browser::wait_identified(&c, 0).await;
        let mut up = Vec::new();
        let mut down = Vec::new();
        // Home: order 1, then up to 8 (orders not shown before, but for
        // the automatic order's), then back down to 1 (all seen).
        let first = move_slider(&c, Key::Home).await;
        println!("order  server ms  answered ms  drawn ms");
        println!("{:>5}  {:>9.1}  {:>11.1}  {:>8.1}  (new)", first.0, first.1, first.2, first.3);
        up.push(first);
        for _ in 0..7 {
            let m = move_slider(&c, Key::Right).await;
            println!("{:>5}  {:>9.1}  {:>11.1}  {:>8.1}  (new)", m.0, m.1, m.2, m.3);
            up.push(m);
        }
        for _ in 0..7 {
            let m = move_slider(&c, Key::Left).await;
            println!("{:>5}  {:>9.1}  {:>11.1}  {:>8.1}  (seen)", m.0, m.1, m.2, m.3);
            down.push(m);
        }
        // The page's command line for the last order shown (what the
        // slider asks the server for).
        let command = browser::js(&c, "return document.getElementById('command').textContent;")
            .await;
        println!("last command: {}", command.as_str().unwrap_or("?"));
        for (what, moves) in [("orders not seen", &up), ("orders seen", &down)] {
            println!(
                "median over {} moves to {what}: server {:.1} ms, answered {:.1} ms, drawn {:.1} ms",
                moves.len(),
                median(moves.iter().map(|m| m.1).collect()),
                median(moves.iter().map(|m| m.2).collect()),
                median(moves.iter().map(|m| m.3).collect()),
            );
        }
        c.close().await.expect("browser closed");
    });
    let _ = std::fs::remove_dir_all(&dir);
}

use super::*;
use std::time::{Duration, Instant};

/// splitmix64: a fixed-seed generator (no dependency for the test).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Log-uniform in 1..=max.
    fn log_uniform(&mut self, max: f64) -> u64 {
        max.powf(self.unit()).round().max(1.0) as u64
    }
    fn pick<'a>(&mut self, items: &[&'a str]) -> &'a str {
        items[self.below(items.len() as u64) as usize]
    }
}

/// 600 rows of (t, u1, u2, y1, y2) from a two-output second-order
/// system; with `every` > 1, y2 is sampled every `every` rows (empty
/// cells between).
fn record(path: &str, seed: u64, every: usize) {
    let mut rng = Rng(seed);
    let mut text = String::from("t,u1,u2,y1,y2\n");
    let (mut x1, mut x2) = (0.0, 0.0);
    for k in 0..600 {
        let u1: f64 = if rng.below(2) == 0 { -1.0 } else { 1.0 };
        let u2: f64 = if rng.below(2) == 0 { -1.0 } else { 1.0 };
        let y1 = x1 + 0.01 * (rng.unit() - 0.5);
        let y2 = x2 + 0.01 * (rng.unit() - 0.5);
        let y2 = if k % every == 0 {
            format!("{y2}")
        } else {
            String::new()
        };
        text += &format!("{},{u1},{u2},{y1},{y2}\n", k as f64);
        x1 = 0.8 * x1 + 0.5 * u1;
        x2 = 0.5 * x2 + 0.3 * u2 + 0.2 * u1;
    }
    std::fs::write(path, text).unwrap();
}

/// Runs the binary with a deadline; kills it and fails past it.
fn run_within(args: &[String], limit: Duration) -> (Option<i32>, String, Duration) {
    let t0 = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_lifted"))
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("the binary runs");
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            if let Some(mut e) = child.stderr.take() {
                use std::io::Read;
                e.read_to_string(&mut err).unwrap();
            }
            return (status.code(), err, t0.elapsed());
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{args:?} still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn horizon_beyond_memory_is_a_message_not_an_abort() {
    let d = tmp("rel-horizon");
    let rec = p(&d, "rec.csv");
    record(&rec, 1, 1);
    let out = p(&d, "m.json");
    for method in ["n4sid", "moesp", "cva", "iv"] {
        let e = fails(
            &[
                "identify",
                "--method",
                method,
                "--data",
                &rec,
                "--inputs",
                "u1,u2",
                "--outputs",
                "y1,y2",
                "--horizon",
                "100000",
                "--out",
                &out,
            ],
            2,
        );
        // A horizon too long for the record and too large for memory
        // is refused for the first reason, which names the record's
        // length (the length is checked before the memory budget; the
        // streamed route, which meets the budget before it has read
        // the record, counts its rows on that refusal).
        assert!(e.contains("too long for 600 samples"), "{method}: {e}");
    }
    // The same on the streamed route (the structure given in full).
    let streamed = |horizon: &str, extra: &[&str]| {
        let args = [
            &[
                "identify",
                "--method",
                "n4sid",
                "--data",
                &rec,
                "--inputs",
                "u1,u2",
                "--outputs",
                "y1,y2",
                "--order",
                "2",
                "--estimator",
                "shift",
                "--horizon",
                horizon,
                "--out",
                &out,
            ][..],
            extra,
        ]
        .concat();
        fails(&args, 2)
    };
    let e = streamed("100000", &[]);
    assert!(e.contains("too long for 600 samples"), "{e}");
    // A horizon the record supports but the budget does not: the
    // memory check names the size and the override.
    let e = streamed("50", &["--memory-limit", "64K"]);
    assert!(
        e.contains("block-Hankel") && e.contains("MB") && e.contains("LIFTED_MEMORY_LIMIT"),
        "{e}"
    );
}

/// A few hundred random option combinations on 600-row records (single
/// rate and multirate): each ends with exit 0 or 2 (one line) within
/// seconds; horizons, orders, holds, q up to 1e6.
#[test]
fn random_options_end_quickly_with_exit_0_or_2() {
    let d = tmp("rel-random");
    let single = p(&d, "rec.csv");
    let multi = p(&d, "mr.csv");
    record(&single, 7, 1);
    record(&multi, 8, 3);
    let out = p(&d, "m.json");
    let mut rng = Rng(30);
    let t0 = Instant::now();
    let mut slowest = (Duration::ZERO, Vec::new());
    let (mut ok, mut rejected) = (0, 0);
    for _ in 0..300 {
        let data = if rng.below(3) == 0 { &multi } else { &single };
        let method = rng.pick(&["n4sid", "moesp", "cva", "iv", "qmarkov"]);
        let mut args: Vec<String> = ["identify", "--method", method, "--data", data]
            .iter()
            .map(|s| s.to_string())
            .collect();
        args.extend(["--inputs", "u1,u2", "--outputs", "y1,y2", "--out", &out].map(String::from));
        let mut opt = |name: &str, value: String| {
            args.push(name.into());
            args.push(value);
        };
        match rng.below(4) {
            0 => opt("--order", "auto".into()),
            1 => opt("--order", (1 + rng.below(12)).to_string()),
            2 => opt("--order", (1 + rng.below(120)).to_string()),
            _ => opt("--order", rng.log_uniform(1e6).to_string()),
        }
        if rng.below(3) > 0 {
            let h = if rng.below(2) == 0 {
                1 + rng.below(80)
            } else {
                rng.log_uniform(1e6)
            };
            opt("--horizon", h.to_string());
        }
        if rng.below(4) == 0 {
            opt("--max-order", rng.log_uniform(1e6).to_string());
        }
        if rng.below(5) == 0 {
            opt("--hold", rng.log_uniform(1e6).to_string());
        }
        if rng.below(5) == 0 {
            opt("--q", rng.log_uniform(1e6).to_string());
        }
        if rng.below(6) == 0 {
            opt("--output-period", format!("y2={}", rng.log_uniform(1e6)));
        }
        if rng.below(3) == 0 {
            opt(
                "--order-criterion",
                rng.pick(&["gap", "svc", "aic", "aicc", "bic"]).into(),
            );
        }
        if rng.below(4) == 0 {
            opt("--estimator", rng.pick(&["shift", "states"]).into());
        }
        if rng.below(8) == 0 {
            opt("--refine", rng.pick(&["pem", "oe"]).into());
        }
        if rng.below(6) == 0 {
            args.push("--stable".into());
        }
        let (code, err, took) = run_within(&args, Duration::from_secs(30));
        assert!(
            !err.contains("panicked") && !err.contains("internal error"),
            "{args:?}: {err}"
        );
        match code {
            Some(0) => ok += 1,
            Some(2) => {
                rejected += 1;
                assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
            }
            other => panic!("{args:?}: exit {other:?}: {err}"),
        }
        if took > slowest.0 {
            slowest = (took, args.clone());
        }
    }
    // Both outcomes occur: the generator reaches the routes, not only
    // the option checks.
    assert!(
        ok > 20 && rejected > 20,
        "{ok} identified, {rejected} rejected"
    );
    eprintln!(
        "300 combinations in {:?} ({ok} identified, {rejected} rejected); slowest {:?}: {:?}",
        t0.elapsed(),
        slowest.0,
        slowest.1
    );
}

#[test]
fn robust_periods_are_bounded() {
    let d = tmp("rel-robust");
    let m = p(&d, "m.json");
    let g = StateSpace::new(
        DMatrix::from_element(1, 1, 0.9),
        DMatrix::from_element(1, 1, 0.15),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap();
    ModelFile::new(g).write(&m).unwrap();
    let args: Vec<String> = [
        "robust",
        "--model",
        &m,
        "--controller",
        &m,
        "--periods",
        "100000",
    ]
    .map(String::from)
    .to_vec();
    let (code, err, took) = run_within(&args, Duration::from_secs(10));
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("beta_dr") && err.contains("slow period"),
        "{err}"
    );
    assert!(took < Duration::from_secs(5), "{took:?}");
    // A large grid is bounded the same way.
    let args: Vec<String> = [
        "robust",
        "--model",
        &m,
        "--controller",
        &m,
        "--periods",
        "2",
        "--grid",
        "1000000000000",
    ]
    .map(String::from)
    .to_vec();
    let (code, err, _) = run_within(&args, Duration::from_secs(10));
    assert_eq!(code, Some(2), "{err}");
}

#[test]
fn duplicate_columns_are_named_with_both_positions() {
    let d = tmp("rel-dup");
    let f = p(&d, "dup.csv");
    std::fs::write(&f, "t,u1,y1,y1\n0,1,2,3\n1,1,2,3\n").unwrap();
    let out = p(&d, "m.json");
    let id = |data: &str, inputs: &str, outputs: &str| {
        fails(
            &[
                "identify",
                "--method",
                "n4sid",
                "--data",
                data,
                "--inputs",
                inputs,
                "--outputs",
                outputs,
                "--out",
                &out,
            ],
            2,
        )
    };
    let e = id(&f, "u1", "y1");
    assert!(
        e.contains("'y1' appears twice") && e.contains("positions 3 and 4"),
        "{e}"
    );
    let (rec, _) = single_rate_data(&d);
    let e = id(&rec, "u1", "y1,y1");
    assert!(
        e.contains("'y1' is selected twice")
            && e.contains("--outputs position 1 and --outputs position 2"),
        "{e}"
    );
    let e = id(&rec, "u1", "u1");
    assert!(
        e.contains("'u1' is selected twice")
            && e.contains("--inputs position 1 and --outputs position 1"),
        "{e}"
    );
    // delay reads through the same selection.
    let e = fails(
        &[
            "delay",
            "--data",
            &rec,
            "--inputs",
            "u1,u1",
            "--outputs",
            "y1",
        ],
        2,
    );
    assert!(e.contains("'u1' is selected twice"), "{e}");
    // mpc --reference: the set-point file's header.
    let m = p(&d, "lag.json");
    ModelFile::new(plant()).write(&m).unwrap();
    let r = p(&d, "ref.csv");
    std::fs::write(&r, "y1,y1\n1,2\n1,2\n").unwrap();
    let e = fails(
        &[
            "mpc",
            "--model",
            &m,
            "--reference",
            &r,
            "--out",
            &p(&d, "run.csv"),
        ],
        2,
    );
    assert!(e.contains("'y1' appears twice"), "{e}");
}

#[test]
fn messages_escape_and_bound_user_content() {
    let d = tmp("rel-msg");
    // 10 kB of bytes 0..=255 as a CSV file.
    let mut rng = Rng(99);
    let bytes: Vec<u8> = (0..10_000).map(|_| rng.below(256) as u8).collect();
    let f = p(&d, "noise.csv");
    std::fs::write(&f, &bytes).unwrap();
    let out = lifted(&[
        "identify",
        "--method",
        "n4sid",
        "--data",
        &f,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--out",
        &p(&d, "m.json"),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = &out.stderr;
    assert!(err.len() < 1500, "{} bytes", err.len());
    let text = String::from_utf8_lossy(err);
    assert!(
        !text.trim_end().chars().any(|c| c.is_control()),
        "control characters in {text:?}"
    );
    assert_eq!(text.trim_end().lines().count(), 1, "{text}");
    // A 5000-character file name is cut with a count.
    let long = p(&d, &"n".repeat(5000));
    let e = fails(
        &[
            "identify",
            "--method",
            "n4sid",
            "--data",
            &long,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--out",
            &p(&d, "m.json"),
        ],
        2,
    );
    assert!(
        e.len() < 600 && e.contains("more characters"),
        "{} chars: {e}",
        e.len()
    );
}

#[test]
fn huge_fit_percentages_have_bounded_width() {
    let d = tmp("rel-fit");
    let (rec, _) = single_rate_data(&d);
    // The plant with a gain of 1e40: fit ≈ −1e42 %.
    let g = plant();
    let big = StateSpace::new(
        g.a().clone(),
        g.b() * 1e40,
        g.c().clone(),
        g.d().clone(),
        g.ts(),
    )
    .unwrap();
    let m = p(&d, "big.json");
    ModelFile::new(big).write(&m).unwrap();
    let e = fails(
        &[
            "validate",
            "--model",
            &m,
            "--data",
            &rec,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--min-fit",
            "50",
        ],
        1,
    );
    assert!(e.contains("fit below") && e.contains("e4"), "{e}");
    assert!(e.len() < 120, "{e}");
}

//! End-to-end tests: run the `lifted` binary on CSV files simulated with
//! lifted-sim in a temporary directory.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use lifted_lti::{InputChannel, ModelFile, OutputChannel, StateSpace};
use lifted_prbs::{InversePrbs, InversePrbsOptions, RandomBinaryOptions, random_binary};
use lifted_sim::{Excitation, NoiseSpec, Plant, Simulator};
use nalgebra::DMatrix;

#[path = "../support/markup.rs"]
mod markup;

#[path = "../hostile/mod.rs"]
mod hostile;

/// A fresh directory under the system temp dir.
fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lifted-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn p(dir: &Path, f: &str) -> String {
    dir.join(f).display().to_string()
}

fn lifted(args: &[&str]) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_lifted"))
        .args(args)
        .output()
        .expect("the binary runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !err.contains("panicked")
            && !err.contains("RUST_BACKTRACE")
            && !err.contains("internal error"),
        "panic in {args:?}: {err}"
    );
    out
}

fn ok(args: &[&str]) -> String {
    let out = lifted(args);
    assert!(
        out.status.success(),
        "{args:?} failed ({:?}): {}{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).to_string()
}

/// Runs a command that must fail with `code`; returns its one-line message.
fn fails(args: &[&str], code: i32) -> String {
    let out = lifted(args);
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(code), "{args:?}: {err}");
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "{args:?}: not one line: {err}"
    );
    err
}

/// y(k) from x(k+1) = A x + B u with poles 0.75 ± 0.37i (|z| = 0.837), T = 0.1 s.
fn plant() -> StateSpace {
    StateSpace::new(
        DMatrix::from_row_slice(2, 2, &[1.5, -0.7, 1.0, 0.0]),
        DMatrix::from_row_slice(2, 1, &[1.0, 0.0]),
        DMatrix::from_row_slice(1, 2, &[0.5, 0.3]),
        DMatrix::zeros(1, 1),
        Some(0.1),
    )
    .unwrap()
}

fn pole_modulus(m: &StateSpace) -> Vec<f64> {
    let mut r: Vec<f64> = m.poles().unwrap().iter().map(|z| z.norm()).collect();
    r.sort_by(f64::total_cmp);
    r
}

/// Simulates the plant on `u` (output sampled every `period`) and writes the CSV.
fn simulate(path: &str, u: Vec<f64>, period: usize, snr: f64, seed: u64) {
    let n = u.len();
    let sim = Simulator::open_loop(Plant::discrete(&plant(), &[], &[]).unwrap())
        .with_inputs(vec![InputChannel::new("u1", 1)])
        .unwrap()
        .with_outputs(vec![OutputChannel::new("y1", period, 0)])
        .unwrap()
        .with_noise(NoiseSpec::white_snr(snr, seed))
        .unwrap();
    let out = sim
        .simulate(&Excitation::input(DMatrix::from_column_slice(n, 1, &u)))
        .unwrap();
    let f = std::fs::File::create(path).unwrap();
    out.data.to_csv_writer(f).unwrap();
}

fn rbs(n: usize, seed: u64) -> Vec<f64> {
    random_binary(
        n,
        &RandomBinaryOptions {
            amplitude: 1.0,
            hold: 1,
            seed,
        },
    )
    .unwrap()
}

fn single_rate_data(dir: &Path) -> (String, String) {
    let id = p(dir, "id.csv");
    let val = p(dir, "val.csv");
    simulate(&id, rbs(2000, 1), 1, 1000.0, 11);
    simulate(&val, rbs(1000, 2), 1, 1000.0, 12);
    (id, val)
}

/// Checks that the identified model's poles are within `tol` of the plant's.
fn check_model(path: &str, tol: f64) -> ModelFile {
    let f = ModelFile::read(path).unwrap();
    assert_eq!(f.kind, "state_space");
    assert_eq!(f.model.order(), 2, "{path}: order");
    let got = pole_modulus(&f.model);
    let want = pole_modulus(&plant());
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() < tol, "{path}: poles {got:?} vs {want:?}");
    }
    // first 20 Markov parameters (the impulse response) within `tol` relative
    let mh = f.model.markov_parameters(20).unwrap();
    let mp = plant().markov_parameters(20).unwrap();
    let err: f64 = mh
        .iter()
        .zip(&mp)
        .map(|(a, b)| (a - b).norm_squared())
        .sum::<f64>()
        .sqrt();
    let scale: f64 = mp.iter().map(|b| b.norm_squared()).sum::<f64>().sqrt();
    assert!(
        err / scale < 5.0 * tol,
        "{path}: Markov parameters off by {}",
        err / scale
    );
    f
}

/// Columns of a data CSV written by `simulate` (header, then numbers;
/// empty cells as NaN).
fn read_csv(path: &str) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let mut cols = vec![Vec::new(); head.len()];
    for l in lines {
        for (c, v) in cols.iter_mut().zip(l.split(',')) {
            c.push(v.parse().unwrap_or(f64::NAN));
        }
    }
    (head, cols)
}

mod generate;

mod identification;

mod use_models;

mod offsets;

mod refinement;

mod delay;

mod closedloop;

mod mpc;

mod robust;

mod stable;

mod reproduce;

mod bad_input;

/// `.npy` input: the same numbers as a CSV file give the same model.
mod npy_input;

/// The 1e6-row measurement of the README (run by hand:
/// `cargo test --release -p lifted-cli -- --ignored --nocapture million`).
#[test]
#[ignore]
fn million_rows_n4sid() {
    let d = tmp("million");
    let data = p(&d, "big.csv");
    simulate(&data, rbs(1_000_000, 9), 1, 100.0, 8);
    let size = std::fs::metadata(&data).unwrap().len();
    let out = p(&d, "big.json");
    let start = std::time::Instant::now();
    let o = Command::new("/usr/bin/time")
        .args(["-v", env!("CARGO_BIN_EXE_lifted")])
        .args([
            "identify",
            "--method",
            "n4sid",
            "--data",
            &data,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--order",
            "2",
            "--out",
            &out,
        ])
        .output()
        .unwrap();
    let secs = start.elapsed().as_secs_f64();
    let err = String::from_utf8_lossy(&o.stderr);
    let rss = err
        .lines()
        .find(|l| l.contains("Maximum resident set size"))
        .unwrap_or("")
        .to_string();
    println!("file {:.1} MB, {secs:.2} s, {rss}", size as f64 / 1e6);
    assert!(o.status.success(), "{err}");
    check_model(&out, 0.01);
}

/// Issue 30: no option value or file content can abort the process, run
/// away with memory or time, or print raw bytes.
mod reliability;

/// Issue 26: the defaults an engineer can trust — the streamed route gives
/// the in-memory model, `--refine` starts from the plain model, an unstable
/// model is flagged everywhere, and the structure is chosen from the data.
mod trust;

/// `analyze`, `bode --omega`, `lqr` against closed forms (issue 30).
mod analyses;

/// `--channels` on the excitation commands: the channels are uncorrelated
/// as designed (issue 30).
mod channels;

/// The smaller faults of issue 30, one test each.
mod faults;

mod pbsid;

mod concat;

mod refine_work;

/// `--stable` on estimates that come out unstable (issue 26): the stable
/// model stays close to the data.
mod stable_close;

mod constant_output;

#[cfg(unix)]
#[test]
fn a_reader_that_stops_early_ends_the_command_quietly() {
    // `lifted analyze … | head -1`: the command ended with "internal error:
    // failed printing to stdout: Broken pipe" (exit 2), or aborted (134)
    // when stderr went to the same closed pipe. Now as `cat`: by SIGPIPE,
    // nothing on stderr.
    use std::os::unix::process::ExitStatusExt;
    let dir = tmp("closed-pipe");
    let model = p(&dir, "m.json");
    std::fs::write(
        &model,
        r#"{"kind":"state_space","ts":1.0,"a":[[0.5,0.1],[0.0,0.3]],"b":[[1],[0.5]],"c":[[1,0]],"d":[[0]]}"#,
    )
    .unwrap();
    for args in [
        vec!["analyze", "--model", &model],
        vec!["reproduce", "--list"],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_lifted"))
            .args(&args)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("the binary runs");
        // The reader goes away before the command writes (its start-up
        // reads the model first); should it win the race, it exits 0.
        drop(child.stdout.take());
        let out = child.wait_with_output().expect("waits");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.is_empty(), "{args:?}: {err}");
        assert!(
            out.status.success() || out.status.signal() == Some(13),
            "{args:?}: {:?}",
            out.status
        );
    }
}

#[test]
fn an_output_file_that_is_an_input_is_refused() {
    // `identify --data d.csv --out d.csv` replaced the data by the model
    // (exit 0); `report`/`mpc` likewise overwrote their inputs.
    let dir = tmp("clobber");
    let (data, _) = single_rate_data(&dir);
    let before = std::fs::read(&data).unwrap();
    let msg = fails(
        &[
            "identify",
            "--data",
            &data,
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--out",
            &data,
        ],
        2,
    );
    assert!(msg.contains("is the input file"), "{msg}");
    assert_eq!(std::fs::read(&data).unwrap(), before, "the data are kept");
    let model = p(&dir, "m.json");
    ok(&[
        "identify",
        "--data",
        &data,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--order",
        "2",
        "--out",
        &model,
    ]);
    let msg = fails(
        &[
            "report", "--model", &model, "--data", &data, "--out", &model,
        ],
        2,
    );
    assert!(msg.contains("is the input file"), "{msg}");
    ModelFile::read(&model).expect("the model is kept");
}

#[test]
fn a_multirate_models_gain_is_not_applied_at_every_sample() {
    // The gain of a model identified from outputs every 3rd sample, applied
    // at every sample of a full-rate record, predicted worse than the
    // simulation (70 % against 86 % on the dryer): left out, with a note.
    let dir = tmp("mr-gain");
    let (mr, full, m) = (p(&dir, "mr.csv"), p(&dir, "full.csv"), p(&dir, "m.json"));
    simulate(&mr, rbs(3000, 1), 3, 1000.0, 11);
    simulate(&full, rbs(1000, 2), 1, 1000.0, 12);
    ok(&[
        "identify",
        "--data",
        &mr,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--order",
        "2",
        "--out",
        &m,
    ]);
    assert!(ModelFile::read(&m).unwrap().kalman_gain.is_some());
    let out = lifted(&["validate", "--model", &m, "--data", &full]);
    assert!(out.status.success());
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(
        stderr.contains("note: the model's Kalman gain was estimated"),
        "{stderr}"
    );
    assert!(stdout.contains("of the simulation residual"), "{stdout}");
    // On a record sampled as the model's was, the gain predicts.
    let out = lifted(&["validate", "--model", &m, "--data", &mr]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && !stderr.contains("note:"),
        "{stderr}"
    );
    let row = String::from_utf8_lossy(&out.stdout)
        .lines()
        .find(|l| l.starts_with("y1"))
        .map(str::to_string)
        .unwrap_or_default();
    assert!(
        row.split_whitespace()
            .nth(2)
            .is_some_and(|c| c.parse::<f64>().is_ok()),
        "{row}"
    );
}

/// Issue 47: the README's quick start ends in a model `mpc` takes without
/// flags (its multirate record's interpolated start took a spurious
/// D = −0.0025, which MPC refused), and `--feedthrough false` is accepted
/// on a multirate record.
mod quick_start;

/// Issue 46, "Integrators kept": `--integrator-tolerance` reaches the
/// workflow (a value outside [0, 1) is named by its flag), and a
/// double integrator under position control (a unit mass at 100 Hz, a PD
/// loop, a ±1 N binary excitation) comes back with its integrators listed
/// in `diagnostics.integrators` (tolerance 2/N by default, the value given
/// otherwise) and counted in `diagnostics.stability`.
#[test]
fn integrators_are_listed_and_their_tolerance_is_an_option() {
    let d = tmp("integrators");
    let data = p(&d, "mass.csv");
    let (ts, kp, kd) = (0.01, 150.0, 17.6);
    let (mut x, mut v, mut last, mut level) = (0.0f64, 0.0f64, 0.0f64, 0.1f64);
    let mut text = String::from("t,u1,y1\n");
    let excitation = random_binary(
        3000,
        &RandomBinaryOptions {
            seed: 46,
            ..Default::default()
        },
    )
    .unwrap();
    for (k, e) in excitation.iter().enumerate() {
        if k % 250 == 0 {
            level = -level;
        }
        let f = kp * (level - x) - kd * (x - if k == 0 { x } else { last }) / ts + e;
        last = x;
        text.push_str(&format!("{},{f},{x}\n", k as f64 * ts));
        x += ts * v + ts * ts / 2.0 * f;
        v += ts * f;
    }
    std::fs::write(&data, text).unwrap();
    let out = p(&d, "m.json");
    let base = [
        "identify",
        "--method",
        "n4sid",
        "--data",
        &data,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--order",
        "2",
        "--out",
        &out,
    ];
    ok(&base);
    let f = ModelFile::read(&out).unwrap();
    let i = &f.diagnostics["integrators"];
    assert!(
        (i["tolerance"].as_f64().unwrap() - 2.0 / 3000.0).abs() < 1e-15,
        "{i}"
    );
    assert_eq!(i["count"], 2, "{}", f.diagnostics);
    assert_eq!(f.diagnostics["stability"]["integrators"], 2);
    let mut given = base.to_vec();
    given.extend(["--integrator-tolerance", "1e-2"]);
    ok(&given);
    let f = ModelFile::read(&out).unwrap();
    assert_eq!(f.diagnostics["integrators"]["tolerance"], 1e-2);
    let mut bad = base.to_vec();
    bad.extend(["--integrator-tolerance", "1.5"]);
    let msg = fails(&bad, 2);
    assert!(msg.contains("--integrator-tolerance"), "{msg}");
}

mod polynomial;
mod uncertainty;

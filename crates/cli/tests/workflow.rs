//! One workflow under every front end (issue 26): the same data and options
//! through (a) the `lifted identify` binary, (c) the service function the
//! studio calls with options it builds itself
//! (`lifted_cli::service::identify::identify_files` with a
//! `lifted_workflow::WorkflowOptions`), and the workflow on arrays in memory
//! (`lifted_workflow::identify`, the call the Python package makes; the
//! package itself is checked against the binary by
//! `crates/python/tests/test_workflow.py` with the same option sets) give
//! the same model, to 1e-10.

use std::path::PathBuf;
use std::process::Command;

use lifted_cli::service::identify::{DataFiles, identify_files};
use lifted_lti::{Dataset, ModelFile};
use lifted_workflow::{
    Detrend, Estimator, Method, Order, Record, Refine, WorkflowOptions, identify,
};
use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Base period of the record (exact in binary, so the time column gives it
/// back exactly).
const TS: f64 = 0.5;

/// 2 inputs, 2 outputs, order 3 (poles 0.9, 0.7 ± 0.3j), random binary
/// inputs, white output noise σ ≈ 0.05, offsets (2, −1): N samples.
fn record(n: usize) -> (DMatrix<f64>, DMatrix<f64>) {
    let a = DMatrix::from_row_slice(3, 3, &[0.9, 0.0, 0.0, 0.0, 0.7, -0.3, 0.0, 0.3, 0.7]);
    let b = DMatrix::from_row_slice(3, 2, &[1.0, 0.2, -0.5, 1.0, 0.3, 0.7]);
    let c = DMatrix::from_row_slice(2, 3, &[1.0, 0.5, -0.3, 0.0, 0.7, 0.4]);
    let d = DMatrix::from_row_slice(2, 2, &[0.1, 0.0, 0.0, 0.2]);
    let mut rng = ChaCha8Rng::seed_from_u64(26);
    let u = DMatrix::from_fn(
        n,
        2,
        |_, _| {
            if rng.random::<f64>() < 0.5 { -0.7 } else { 1.3 }
        },
    );
    let mut x = DVector::zeros(3);
    let mut y = DMatrix::zeros(n, 2);
    for k in 0..n {
        let uk = u.row(k).transpose();
        let yk = &c * &x + &d * &uk;
        for j in 0..2 {
            let e: f64 = rng.random::<f64>() - 0.5;
            y[(k, j)] = yk[j] + [2.0, -1.0][j] + 0.17 * e;
        }
        x = &a * &x + &b * &uk;
    }
    (u, y)
}

/// Writes the record as CSV (`t,u1,u2,y1,y2`; Rust's shortest round-trip
/// decimal, so the reader gets the same doubles back).
fn write_csv(path: &PathBuf, u: &DMatrix<f64>, y: &DMatrix<f64>) {
    let mut text = String::from("t,u1,u2,y1,y2\n");
    for k in 0..u.nrows() {
        text.push_str(&format!(
            "{},{},{},{},{}\n",
            TS * k as f64,
            u[(k, 0)],
            u[(k, 1)],
            y[(k, 0)],
            y[(k, 1)]
        ));
    }
    std::fs::write(path, text).expect("write the CSV");
}

/// One option set: the command's flags and the same options built directly.
struct Case {
    name: &'static str,
    flags: &'static [&'static str],
    options: fn(&mut WorkflowOptions),
}

fn cases() -> Vec<Case> {
    vec![
        Case {
            name: "defaults",
            flags: &["--method", "n4sid"],
            options: |_| {},
        },
        Case {
            name: "moesp, order 3",
            flags: &["--method", "moesp", "--order", "3"],
            options: |o| {
                o.identification.method = Method::Moesp;
                o.identification.order = Order::Fixed(3);
            },
        },
        Case {
            name: "cva, horizon 15",
            flags: &["--method", "cva", "--horizon", "15"],
            options: |o| {
                o.identification.method = Method::Cva;
                o.identification.horizon = Some(15);
            },
        },
        Case {
            name: "no detrending, order 3, horizon 8, state sequences",
            flags: &[
                "--method",
                "n4sid",
                "--detrend",
                "none",
                "--order",
                "3",
                "--horizon",
                "8",
                "--estimator",
                "states",
            ],
            options: |o| {
                o.data.detrend = Detrend::None;
                o.identification.order = Order::Fixed(3);
                o.identification.horizon = Some(8);
                o.identification.estimator = Estimator::States;
            },
        },
        Case {
            name: "linear detrending",
            flags: &["--method", "n4sid", "--detrend", "linear", "--order", "3"],
            options: |o| {
                o.data.detrend = Detrend::Linear;
                o.identification.order = Order::Fixed(3);
            },
        },
        Case {
            name: "refine pem",
            flags: &["--method", "n4sid", "--order", "3", "--refine", "pem"],
            options: |o| {
                o.identification.order = Order::Fixed(3);
                o.refinement.refine = Refine::Pem;
            },
        },
    ]
}

/// Largest difference between two model files' matrices, operating points
/// and Kalman gains, relative to the largest entry (at least 1); infinite
/// when their shapes or what they carry differ.
fn difference(a: &ModelFile, b: &ModelFile) -> f64 {
    let (ma, mb) = (&a.model, &b.model);
    let mut pairs: Vec<(DMatrix<f64>, DMatrix<f64>)> = vec![
        (ma.a().clone(), mb.a().clone()),
        (ma.b().clone(), mb.b().clone()),
        (ma.c().clone(), mb.c().clone()),
        (ma.d().clone(), mb.d().clone()),
    ];
    match (&a.operating_point, &b.operating_point) {
        (Some(p), Some(q)) => {
            pairs.push((
                DMatrix::from_row_slice(1, p.u0.len(), &p.u0),
                DMatrix::from_row_slice(1, q.u0.len(), &q.u0),
            ));
            pairs.push((
                DMatrix::from_row_slice(1, p.y0.len(), &p.y0),
                DMatrix::from_row_slice(1, q.y0.len(), &q.y0),
            ));
        }
        (None, None) => {}
        _ => return f64::INFINITY,
    }
    match (a.kalman_gain_matrix(), b.kalman_gain_matrix()) {
        (Some(k), Some(l)) => pairs.push((k, l)),
        (None, None) => {}
        _ => return f64::INFINITY,
    }
    if ma.ts() != mb.ts() {
        return f64::INFINITY;
    }
    let mut worst: f64 = 0.0;
    for (p, q) in &pairs {
        if p.shape() != q.shape() {
            return f64::INFINITY;
        }
        let scale = p.abs().max().max(1.0);
        worst = worst.max((p - q).abs().max() / scale);
    }
    worst
}

#[test]
fn the_binary_the_studio_path_and_the_workflow_give_the_same_model() {
    let dir = std::env::temp_dir().join(format!("lifted-workflow-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    let (u, y) = record(2000);
    let data = dir.join("data.csv");
    write_csv(&data, &u, &y);
    let files = DataFiles {
        paths: vec![data.display().to_string()],
        inputs: vec!["u1".into(), "u2".into()],
        outputs: vec!["y1".into(), "y2".into()],
        ..Default::default()
    };
    let in_memory = [Record::new(
        Dataset::single_rate(TS, u.clone(), y.clone()).expect("dataset"),
    )];
    for (k, case) in cases().into_iter().enumerate() {
        let out = dir.join(format!("model{k}.json"));
        let run = Command::new(env!("CARGO_BIN_EXE_lifted"))
            .arg("identify")
            .args(case.flags)
            .args(["--data", &files.paths[0], "--inputs", "u1,u2"])
            .args(["--outputs", "y1,y2", "--out", &out.display().to_string()])
            .output()
            .expect("the binary runs");
        assert!(
            run.status.success(),
            "{}: {}",
            case.name,
            String::from_utf8_lossy(&run.stderr)
        );
        let binary = ModelFile::from_json(&std::fs::read_to_string(&out).expect("model file"))
            .expect("model file");
        let mut opts = WorkflowOptions::default();
        (case.options)(&mut opts);
        let studio = identify_files(&files, &opts).expect("identify_files");
        let workflow = identify(&in_memory, &opts).expect("workflow").file;
        // The three run the same code on the same doubles with one thread,
        // so they agree to the last bit; 1e-10 (relative to the largest
        // entry) leaves room for nothing but rounding, while any difference
        // in route, structure, offsets or data moves the entries by far
        // more (a different horizon: ~1e-2; one sample less: ~1e-5).
        let (d_studio, d_workflow) = (difference(&binary, &studio), difference(&binary, &workflow));
        assert!(
            d_studio <= 1e-10,
            "{}: binary vs studio path {d_studio:e}",
            case.name
        );
        assert!(
            d_workflow <= 1e-10,
            "{}: binary vs workflow in memory {d_workflow:e}",
            case.name
        );
        assert_eq!(binary.method, studio.method);
        for key in [
            "structure_selection",
            "order_selection",
            "refinement",
            "refinement_judge",
            "stability",
        ] {
            assert_eq!(
                binary.diagnostics.get(key),
                studio.diagnostics.get(key),
                "{}: diagnostics {key}",
                case.name
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A short noisy SISO record with the whole structure given: the binary
/// streams it (no structure to select) while the workflow in memory loads
/// it, and the refinement of both is judged on the same held-out blocks
/// (which decide here: the subspace models at horizon 3 are poor, their
/// refinements near the noise floor), so the models agree.
#[test]
fn a_streamed_short_record_is_judged_as_in_memory() {
    let dir = std::env::temp_dir().join(format!("lifted-judge-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    // Poles 0.9 ± 0.2j, white input, output noise σ = 0.5 (output RMS ≈ 0.6).
    let (a, b, c) = (
        DMatrix::from_row_slice(2, 2, &[0.9, 0.2, -0.2, 0.9]),
        DMatrix::from_row_slice(2, 1, &[1.0, 0.5]),
        DMatrix::from_row_slice(1, 2, &[0.3, 0.4]),
    );
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut g = || -> f64 { 12f64.sqrt() * (rng.random::<f64>() - 0.5) };
    let n = 1200;
    let u = DMatrix::from_fn(n, 1, |_, _| g());
    let mut y = DMatrix::zeros(n, 1);
    let mut x = DVector::zeros(2);
    for t in 0..n {
        y[(t, 0)] = (&c * &x)[0] + 0.5 * g();
        x = &a * &x + &b * u.row(t).transpose();
    }
    let path = dir.join("siso.csv");
    let mut text = String::from("t,u1,y1\n");
    for k in 0..n {
        text.push_str(&format!(
            "{:?},{:?},{:?}\n",
            k as f64 * TS,
            u[(k, 0)],
            y[(k, 0)]
        ));
    }
    std::fs::write(&path, text).expect("csv");
    let out = dir.join("m.json");
    let flags = [
        "--method",
        "n4sid",
        "--order",
        "2",
        "--horizon",
        "3",
        "--estimator",
        "shift",
        "--detrend",
        "none",
    ];
    let run = Command::new(env!("CARGO_BIN_EXE_lifted"))
        .arg("identify")
        .args(flags)
        .args(["--data", &path.display().to_string(), "--inputs", "u1"])
        .args(["--outputs", "y1", "--out", &out.display().to_string()])
        .output()
        .expect("the binary runs");
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let binary = ModelFile::from_json(&std::fs::read_to_string(&out).expect("model file"))
        .expect("model file");
    let mut opts = WorkflowOptions::default();
    opts.identification.order = Order::Fixed(2);
    opts.identification.horizon = Some(3);
    opts.identification.estimator = Estimator::Shift;
    opts.data.detrend = Detrend::None;
    let in_memory = [Record::new(
        Dataset::single_rate(TS, u, y).expect("dataset"),
    )];
    let workflow = identify(&in_memory, &opts).expect("workflow").file;
    // The binary took the streamed route, the workflow the in-memory one.
    let route = |f: &ModelFile| f.diagnostics["route"].as_str().unwrap_or("").to_string();
    assert!(route(&binary).contains("streamed"), "{}", route(&binary));
    assert!(
        !route(&workflow).contains("streamed"),
        "{}",
        route(&workflow)
    );
    for f in [&binary, &workflow] {
        assert_eq!(
            f.diagnostics["refinement_judge"]["decided_by"],
            serde_json::json!("held-out blocks"),
            "{}",
            f.diagnostics
        );
    }
    assert_eq!(
        binary.diagnostics["refinement_judge"],
        workflow.diagnostics["refinement_judge"]
    );
    let d = difference(&binary, &workflow);
    assert!(d <= 1e-8, "binary (streamed) vs workflow in memory {d:e}");
    let _ = std::fs::remove_dir_all(&dir);
}

//! The `lifted` command's data-file reader: a 1e6-row CSV file of the 2×2
//! peer system (columns t,u1,u2,y1,y2; t with 3 decimals, u = ±1, y with 14
//! decimals: ~48 bytes a row, as `benches/peers/csv_data.py` writes it) read
//! with `lifted_cli::table::read_raw` (parse and keep the four channels,
//! check the time column), with `scan_rows` alone (parse, nothing kept: the
//! streamed identification's reading) on as many threads as it chooses (the
//! parallel reader on a multi-core machine) and on the calling thread alone
//! (`scan_rows_threads(…, Some(1), …)`: the sequential reader), with
//! `scan_rows` and a consumer costing about what the streamed identifier's
//! compression costs per row, with the reader of main before the fast path
//! (csv crate `ByteRecord` + `str::parse`, same checks, kept here as
//! `legacy_read_raw`), and the same numbers as a C-order float64 `.npy`
//! file. Throughput in bytes of the file read.
//!
//! Run: `cargo bench -p lifted-benches --bench csv` (10 samples each, ~1 min).

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use lifted_benches::peer_data;
use lifted_cli::table::{read_raw, scan_rows, scan_rows_threads};

const ROWS: usize = 1_000_000;

/// Writes the CSV and `.npy` files; returns their paths.
fn files() -> (String, String) {
    let (u, y) = peer_data(ROWS, 0.1, 7);
    let dir = std::env::temp_dir().join(format!("lifted-bench-csv-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let csv = dir.join("d1e6.csv");
    let npy = dir.join("d1e6.npy");
    let mut text = String::with_capacity(50 * ROWS);
    text += "t,u1,u2,y1,y2\n";
    let dict = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': ({ROWS}, 5), }}");
    let pad = (64 - (10 + dict.len() + 1) % 64) % 64;
    let header = format!("{dict}{}\n", " ".repeat(pad));
    let mut bin = b"\x93NUMPY\x01\x00".to_vec();
    bin.extend((header.len() as u16).to_le_bytes());
    bin.extend(header.as_bytes());
    for k in 0..ROWS {
        let row = format!(
            "{:.3},{},{},{:.14},{:.14}",
            k as f64 * 0.001,
            u[(k, 0)],
            u[(k, 1)],
            y[(k, 0)],
            y[(k, 1)]
        );
        // the .npy holds exactly the numbers of the CSV
        for cell in row.split(',') {
            bin.extend(cell.parse::<f64>().unwrap_or(f64::NAN).to_le_bytes());
        }
        text += &row;
        text += "\n";
    }
    std::fs::write(&csv, text).expect("write csv");
    std::fs::write(&npy, bin).expect("write npy");
    (csv.display().to_string(), npy.display().to_string())
}

/// The reader of main before the block reader (commit 33a8ffc): the csv
/// crate's `ByteRecord`, `str::parse` per wanted cell, the same time-column
/// check, the columns kept in `Vec`s. Returns the rows read.
fn legacy_read_raw(path: &str, wanted: &[&str]) -> Option<(Vec<Vec<f64>>, usize)> {
    let file = std::fs::File::open(path).ok()?;
    let mut rd = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .buffer_capacity(1 << 16)
        .from_reader(std::io::BufReader::with_capacity(1 << 16, file));
    let mut rec = csv::ByteRecord::new();
    rd.read_byte_record(&mut rec).ok()?;
    let header: Vec<String> = rec
        .iter()
        .map(|c| String::from_utf8_lossy(c).trim().to_string())
        .collect();
    let idx: Vec<usize> = wanted
        .iter()
        .map(|n| header.iter().position(|h| h == n))
        .collect::<Option<_>>()?;
    let tc = header.iter().position(|h| h == "t")?;
    let cell = |c: &[u8]| -> Option<f64> {
        let v: f64 = std::str::from_utf8(c).ok()?.trim().parse().ok()?;
        v.is_finite().then_some(v)
    };
    let mut cols = vec![Vec::new(); wanted.len()];
    let (mut t0, mut t1, mut rows) = (0.0, 0.0, 0usize);
    while rd.read_byte_record(&mut rec).ok()? {
        if rec.len() != header.len() {
            return None;
        }
        for (col, &c) in cols.iter_mut().zip(&idx) {
            col.push(cell(&rec[c])?);
        }
        let t = cell(&rec[tc])?;
        match rows {
            0 => t0 = t,
            1 => t1 = t,
            _ => {
                let dt = t1 - t0;
                let expect = t0 + rows as f64 * dt;
                if (t - expect).abs() > 1e-6 * dt.abs().max(1e-300) + 1e-9 * expect.abs() {
                    return None;
                }
            }
        }
        rows += 1;
    }
    Some((cols, rows))
}

fn reader(c: &mut Criterion) {
    let (csv, npy) = files();
    let names: Vec<String> = ["u1", "u2", "y1", "y2"].map(String::from).to_vec();
    let wanted: Vec<&String> = names.iter().collect();
    let csv_bytes = std::fs::metadata(&csv).map(|m| m.len()).unwrap_or(0);
    let npy_bytes = std::fs::metadata(&npy).map(|m| m.len()).unwrap_or(0);
    println!(
        "{ROWS} rows: CSV {csv_bytes} bytes ({:.1} per row), .npy {npy_bytes} bytes",
        csv_bytes as f64 / ROWS as f64
    );
    let mut group = c.benchmark_group("read_1e6x5");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5));
    group.throughput(Throughput::Bytes(csv_bytes));
    group.bench_function("csv_read_raw", |b| {
        b.iter(|| black_box(read_raw(&csv, &[], &wanted, 2..4, None).expect("read")))
    });
    group.bench_function("csv_scan_rows", |b| {
        b.iter(|| {
            let mut sum = 0.0;
            let r = scan_rows(&csv, &[], &wanted, 2..4, None, |row| {
                sum += row[3];
                Ok(true)
            });
            black_box((r.expect("scan"), sum))
        })
    });
    group.bench_function("csv_scan_rows_1_thread", |b| {
        b.iter(|| {
            let mut sum = 0.0;
            let r = scan_rows_threads(&csv, &[], &wanted, 2..4, None, Some(1), |row| {
                sum += row[3];
                Ok(true)
            });
            black_box((r.expect("scan"), sum))
        })
    });
    // A consumer of ≈ 40 ns a row (12 × 4 dependent multiply-adds; about
    // what the streamed compression costs per row at 1e6, benches/results/slicot.md):
    // how much of it the parallel reader overlaps.
    let consumer = |threads: Option<usize>| {
        let mut acc = [0.0f64; 4];
        let r = scan_rows_threads(&csv, &[], &wanted, 2..4, None, threads, |row| {
            for _ in 0..12 {
                for (a, &v) in acc.iter_mut().zip(row) {
                    *a = a.mul_add(0.999_999, v);
                }
            }
            Ok(true)
        });
        black_box((r.expect("scan"), acc))
    };
    group.bench_function("csv_scan_rows_consumer", |b| b.iter(|| consumer(None)));
    group.bench_function("csv_scan_rows_consumer_1_thread", |b| {
        b.iter(|| consumer(Some(1)))
    });
    group.bench_function("csv_legacy_read_raw", |b| {
        b.iter(|| black_box(legacy_read_raw(&csv, &["u1", "u2", "y1", "y2"]).expect("read")))
    });
    group.throughput(Throughput::Bytes(npy_bytes));
    let npy_names: Vec<String> = ["t", "u1", "u2", "y1", "y2"].map(String::from).to_vec();
    group.bench_function("npy_read_raw", |b| {
        b.iter(|| black_box(read_raw(&npy, &npy_names, &wanted, 2..4, None).expect("read")))
    });
    group.finish();
    let _ = std::fs::remove_file(&csv);
    let _ = std::fs::remove_file(&npy);
}

criterion_group!(benches, reader);
criterion_main!(benches);

use super::*;

/// Splits a CSV file's rows into shard files (header repeated).
fn split(path: &str, dir: &Path, cuts: &[usize]) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let rows: Vec<&str> = lines.collect();
    for (k, w) in cuts.windows(2).enumerate() {
        let mut s = format!("{header}\n");
        for r in &rows[w[0]..w[1].min(rows.len())] {
            s.push_str(r);
            s.push('\n');
        }
        std::fs::write(dir.join(format!("shard-{k:02}.csv")), s).unwrap();
    }
}

fn matrices(path: &str) -> Vec<DMatrix<f64>> {
    let f = ModelFile::read(path).unwrap();
    vec![
        f.model.a().clone(),
        f.model.b().clone(),
        f.model.c().clone(),
        f.model.d().clone(),
    ]
}

/// `--concat` with a pattern: the shards of one record give the model
/// of the whole file, on the in-memory route (same data: same bits)
/// and on the streamed two-pass route (blocks cut elsewhere: rounding).
#[test]
fn shards_of_one_record_give_the_whole_files_model() {
    let d = tmp("concat");
    let (id, _) = single_rate_data(&d);
    split(&id, &d, &[0, 700, 702, 1500, 2000]);
    let pattern = p(&d, "shard-*.csv");
    for (extra, tol) in [
        (vec![], 0.0),
        (vec!["--horizon", "10", "--estimator", "shift"], 1e-10),
    ] {
        let whole = p(&d, "whole.json");
        let joined = p(&d, "joined.json");
        let mut a = vec![
            "identify",
            "--method",
            "n4sid",
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--order",
            "2",
        ];
        a.extend(extra.iter());
        let mut w = a.clone();
        w.extend(["--data", &id, "--out", &whole]);
        ok(&w);
        let mut j = a.clone();
        j.extend(["--data", &pattern, "--concat", "--out", &joined]);
        ok(&j);
        for (x, y) in matrices(&whole).iter().zip(matrices(&joined)) {
            let diff = (x - &y).norm();
            assert!(diff <= tol * x.norm().max(1.0), "{extra:?}: {diff:e}");
        }
        let f = ModelFile::read(&joined).unwrap();
        assert_eq!(f.diagnostics["data"].as_array().map(Vec::len), Some(4));
    }
    let sep = p(&d, "separate.json");
    let msg = fails(
        &[
            "identify",
            "--method",
            "n4sid",
            "--inputs",
            "u1",
            "--outputs",
            "y1",
            "--data",
            &p(&d, "nothing-*.csv"),
            "--concat",
            "--out",
            &sep,
        ],
        2,
    );
    assert!(msg.contains("no file matches"), "{msg}");
}

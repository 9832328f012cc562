//! lifted-data's integration tests: a record `lifted_lti::Dataset` writes
//! (`to_csv_writer`: empty cells between a slow output's samples, units in
//! the header) reads back through the one reader of every front end.

use lifted_data::table::{DataSpec, load};
use lifted_lti::{Dataset, InputChannel, OutputChannel};
use nalgebra::DMatrix;

/// 12 samples at T = 0.5 s: the input held 3 samples, one output at every
/// sample, one every 4 samples from sample 1.
fn multirate() -> Dataset {
    let u = DMatrix::from_fn(12, 1, |k, _| (k / 3) as f64 - 1.5);
    let y = DMatrix::from_fn(12, 2, |k, c| {
        if c == 0 || k % 4 == 1 {
            (k * k) as f64 * 0.1 + c as f64
        } else {
            f64::NAN
        }
    });
    Dataset::new(
        0.5,
        u,
        y,
        vec![InputChannel::new("fuel", 3).with_unit("mm3")],
        vec![
            OutputChannel::new("speed", 1, 0).with_unit("rpm"),
            OutputChannel::new("lab", 4, 1),
        ],
    )
    .unwrap()
}

#[test]
fn a_written_multirate_record_reads_back() {
    let d = multirate();
    let dir = std::env::temp_dir().join(format!("lifted-data-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("rec.csv");
    d.to_csv_writer(std::fs::File::create(&path).unwrap())
        .unwrap();
    let spec = DataSpec {
        inputs: vec!["fuel".into()],
        outputs: vec!["speed".into(), "lab".into()],
        hold: 3,
        ..Default::default()
    };
    let back = load(path.to_str().unwrap(), &spec).unwrap().data;
    assert_eq!(back.ts(), d.ts());
    assert_eq!(back.u(), d.u());
    for (a, b) in back.y().iter().zip(d.y().iter()) {
        assert!(a == b || (a.is_nan() && b.is_nan()), "{a} vs {b}");
    }
    assert_eq!(back.inputs()[0].hold, 3);
    let sampling: Vec<(usize, usize)> = back
        .outputs()
        .iter()
        .map(|o| (o.period, o.offset))
        .collect();
    assert_eq!(sampling, [(1, 0), (4, 1)]);
    // A column the spec names that the file does not have is an error
    // naming it.
    let missing = DataSpec {
        outputs: vec!["pressure".into()],
        ..spec
    };
    let e = load(path.to_str().unwrap(), &missing)
        .unwrap_err()
        .to_string();
    assert!(e.contains("pressure"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

//! Arbitrary bytes as a CSV file, read by the `lifted` command's table
//! reader (`lifted_data::table`, the one reader of every front end: named
//! columns, empty output cells, declared periods): either a data set or an
//! error, never a panic or a hang.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lifted_cli::table::{DataSpec, load};

fuzz_target!(|bytes: &[u8]| {
    let path = std::env::temp_dir().join(format!("lifted-fuzz-csv-{}.csv", std::process::id()));
    if std::fs::write(&path, bytes).is_err() {
        return;
    }
    let p = path.display().to_string();
    for (periods, hold) in [(vec![], 1), (vec![("y1".to_string(), 2)], 1), (vec![], 3)] {
        let spec = DataSpec {
            inputs: vec!["u1".into()],
            outputs: vec!["y1".into()],
            periods,
            hold,
            ..Default::default()
        };
        if let Ok(l) = load(&p, &spec) {
            // A loaded data set is finite at its sampled instants.
            assert!(l.data.u().iter().all(|v| v.is_finite()));
        }
    }
});

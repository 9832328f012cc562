//! Arbitrary bytes as a numpy `.npy` file, read by the `lifted` command's
//! table reader (the header, both layouts and element types, the column
//! blocks of `npy::scan_blocks`, empty output cells): either a data set or
//! an error, never a panic or a hang.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lifted_cli::table::{DataSpec, load};

fuzz_target!(|bytes: &[u8]| {
    let path = std::env::temp_dir().join(format!("lifted-fuzz-npy-{}.npy", std::process::id()));
    if std::fs::write(&path, bytes).is_err() {
        return;
    }
    let p = path.display().to_string();
    for columns in [vec![], vec!["t".to_string(), "u1".into(), "y1".into()]] {
        let (inputs, outputs) = if columns.is_empty() {
            (vec!["c0".to_string()], vec!["c1".to_string()])
        } else {
            (vec!["u1".to_string()], vec!["y1".to_string()])
        };
        let spec = DataSpec {
            inputs,
            outputs,
            columns,
            ..Default::default()
        };
        if let Ok(l) = load(&p, &spec) {
            // A loaded data set is finite at its sampled instants.
            assert!(l.data.u().iter().all(|v| v.is_finite()));
        }
    }
    let _ = std::fs::remove_file(&path);
});

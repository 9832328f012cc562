//! Arbitrary text as a model file (the CLI's JSON): either a model whose
//! analyses return values or errors, or an error; never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lifted_lti::ModelFile;

fuzz_target!(|bytes: &[u8]| {
    let Ok(text) = std::str::from_utf8(bytes) else {
        return;
    };
    let Ok(file) = ModelFile::from_json(text) else {
        return;
    };
    let m = &file.model;
    if m.order() > 40 {
        return; // the analyses are O(n³); keep executions fast
    }
    let _ = m.poles();
    let _ = m.zeros();
    let _ = m.dc_gain();
    let _ = m.step(16, Some(0.1));
    let _ = file.kalman_gain_matrix();
    let again = file.to_json().expect("a read model file serialises");
    ModelFile::from_json(&again).expect("a written model file reads back");
});

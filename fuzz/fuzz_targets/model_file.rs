//! Arbitrary text as a model file (the CLI's JSON): either a model whose
//! analyses return values or errors, or an error; never a panic.
//!
//! The body is `lifted_fuzz::model_file` (`fuzz/src/lib.rs`), shared with the corpus replay
//! of the main workspace's tests.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| lifted_fuzz::model_file(bytes));

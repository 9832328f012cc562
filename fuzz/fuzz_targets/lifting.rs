//! Multirate lifting of arbitrary records and rate patterns: lifting then
//! inverse lifting returns the inputs (property), or an error; never a
//! panic.
//!
//! The body is `lifted_fuzz::lifting` (`fuzz/src/lib.rs`), shared with the corpus replay
//! of the main workspace's tests.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| lifted_fuzz::lifting(bytes));

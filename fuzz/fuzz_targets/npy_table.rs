//! Arbitrary bytes as a numpy `.npy` file, read by the `lifted` command's
//! table reader (the header, both layouts and element types, the column
//! blocks of `npy::scan_blocks`, empty output cells): either a data set or
//! an error, never a panic or a hang.
//!
//! The body is `lifted_fuzz::npy_table` (`fuzz/src/lib.rs`), shared with the corpus replay
//! of the main workspace's tests.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| lifted_fuzz::npy_table(bytes));

//! Arbitrary bytes as a CSV file, read by the `lifted` command's table
//! reader (`lifted_data::table`, the one reader of every front end: named
//! columns, empty output cells, declared periods): either a data set or an
//! error, never a panic or a hang.
//!
//! The body is `lifted_fuzz::csv_table` (`fuzz/src/lib.rs`), shared with the corpus replay
//! of the main workspace's tests.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| lifted_fuzz::csv_table(bytes));

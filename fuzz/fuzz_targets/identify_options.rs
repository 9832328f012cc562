//! The `identify` options as the command line gives them — method, order,
//! horizon, hold, q, output period, order criterion, estimator, refinement,
//! stability — each up to 1e6 (and past the limits the record allows), on
//! small single-rate and multirate records, through the same service the
//! `lifted identify` command calls (`run_identification`): a model file or
//! a one-line error, never a panic, abort (allocation failure) or hang.
//! The memory budget is 2 GiB (the smoke run's RSS limit is 4 GiB).
//! Refinement runs with at most 3 iterations and orders up to 12 here so
//! that one input stays within the smoke run's `-timeout` (the work bound
//! of `refine_pem`, 2e10 operations, is unit-tested in lifted-pem).
//!
//! The body is `lifted_fuzz::identify_options` (`fuzz/src/lib.rs`), shared with the corpus replay
//! of the main workspace's tests.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| lifted_fuzz::identify_options(bytes));

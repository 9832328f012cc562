//! Identification on arbitrary small records and options: every route
//! (N4SID/MOESP/CVA, IV, q-Markov Cover, multirate lifted subspace) returns
//! a model or an error naming the problem; never a panic, hang or abort.
//!
//! The body is `lifted_fuzz::identify` (`fuzz/src/lib.rs`), shared with the corpus replay
//! of the main workspace's tests.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| lifted_fuzz::identify(bytes));

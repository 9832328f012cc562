//! End-to-end reproductions of the experiments in the three source documents.
//!
//! One module per section of `shared/spec/reproductions.md` (e.g. `a1_engine` for
//! A1.5). Each experiment is a function that **simulates** the set-up, runs the
//! identification or control method, and returns a [`Reproduction`]: the numbers it
//! obtained next to the published ones, and the spec's acceptance checks evaluated on
//! them. The same functions serve two callers:
//!
//! * the integration tests in `tests/tests.rs`, which assert that every check passes;
//! * the `lifted reproduce` command, which prints the same report.
//!
//! Each acceptance bound lives in exactly one place — the experiment module — with a
//! comment giving its source (spec section, calibration of the reference
//! implementation). Where a published number cannot be reached, the check says so in
//! its `note` and records the value obtained: tolerances are never loosened silently.
#![deny(missing_docs)]

pub mod a1_engine;
pub mod a1_prbs;
pub mod a2_closedloop;
pub mod a2_openloop;
pub mod a3_delay_example;
pub mod a3_dual_rate;
pub mod a3_iv;
pub mod a3_lifting;
pub mod a3_mimo;
pub mod a3_mpc;
pub mod a3_multirate_iv;
pub mod a3_polynomial;
pub mod a3_subspace;
pub mod registry;
pub mod report;

pub use report::{Check, Reproduction};

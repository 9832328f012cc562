//! Integration tests of lifted-lti (one binary, modules by area).

#[path = "suite/bad_input.rs"]
mod bad_input;
#[path = "suite/closed_loop.rs"]
mod closed_loop;
#[path = "suite/common.rs"]
mod common;
#[path = "suite/discretize.rs"]
mod discretize;
#[path = "suite/engine.rs"]
mod engine;
#[path = "suite/norms.rs"]
mod norms;
#[path = "suite/properties.rs"]
mod properties;
#[path = "suite/structure.rs"]
mod structure;

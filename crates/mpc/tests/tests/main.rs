//! Integration tests of `lifted-mpc`.

mod common;

mod qp;

mod bad_input;

mod predictions;

mod chapter9;

mod conic_measures;

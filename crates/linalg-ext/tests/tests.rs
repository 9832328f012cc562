//! Integration tests of `lifted-linalg` (one binary; modules by area).

mod suite;

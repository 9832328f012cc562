//! Integration tests of `lifted-multirate`.
mod suite;

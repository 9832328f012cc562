//! Integration tests of lifted-qmarkov (one binary, modules by area).

mod suite;

//! Integration tests of `lifted-prbs` (spec A1.1–A1.3, A2.1, A3.8, Table II).

mod mseq;

mod inverse;

mod random;

mod correlation;

mod plan;

mod vectorized;

mod design;

mod errors;

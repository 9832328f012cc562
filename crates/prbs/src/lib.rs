//! Excitation signals for multirate identification: m-sequences, the inverse PRBS of
//! Zhu (2000) and Ren & Zhu (2009), the PRBS held `n_r` samples and its closed-form
//! autocorrelation, random binary / GBN / Gaussian / multisine signals, multichannel plans, the
//! "vectorized" excitation of Li (2001) §6.3, and the design rules of Zhu (2000) §III.D.
//!
//! # Method
//!
//! **m-sequence** (Zhu 2000 eqs. II-1–II-3, Table I; spec A1.1). Bits
//! `b(k+1) = XOR_{i∈S_n} b(k+1−i)`, `b(0) = 1`, `b(−1) = … = b(−(n−1)) = 0`, with the
//! taps `S_n` of Table I for `n = 2…11` (e.g. `S_5 = {3, 5}`, `S_8 = {2, 3, 4, 8}`) and
//! primitive polynomials up to `n = 32`. Period `m = 2ⁿ − 1` ([`MSequence`],
//! bit-serial Fibonacci form; [`WordGenerator`], 64 bits per step using
//! `C(x)^64 = C(x^64)` over GF(2)).
//!
//! **Inverse PRBS** (eq. II-4; Ren & Zhu eq. 5; errata RZ-1, RZ-2):
//! `u(k) = s(k) ⊕ û(k) = (−1)^{k+1} · a · (2b(k) − 1)`. Period `2m`,
//! `u(k+m) = −u(k)`, zero mean (II-5), and with `R_u(τ) = (1/2m) Σ_{k<2m} u(k+τ)u(k)`
//! (eq. II-6): `R_u(0) = a²`, `R_u(m) = −a²`, `−a²/m` for other even `τ`, `+a²/m` for odd
//! `τ` ([`InversePrbs`]).
//!
//! **Held PRBS** (eqs. II-7–II-10; spec A1.3; errata Z-2, Z-3). `w(j) = u(⌊j/n_r⌋)`,
//! period `2 n_r m`; its autocorrelation, normalised by `1/(2m)`, is the corrected
//! eq. II-10 ([`held_autocorrelation`]), e.g. `R(0) = n_r a²`.
//!
//! **Multichannel plans** ([`ExperimentPlan`]): one channel at a time (q-Markov Cover,
//! Zhu 2000 §III.D step 2), mutually shifted or independent sequences.
//!
//! **Vectorized excitation** (Li 2001 §6.3, Fig. 6.2; [`vectorized_excitation`]):
//! independent components of the lifted input, inverse-lifted to the fast rate, so
//! the lifted covariance is full rank.
//!
//! **Design** (Zhu 2000 §III.D, Table II; [`design`]): from `T`, the actuator rate and
//! the slowest mode, propose `(n, n_r, a)`, the band `[1/(2mT_p), 1/(2T_p)]` and the
//! record length `2 m n_r T`.
//!
//! # Complexity
//! Bit-serial generation O(1) per sample without allocation; bulk generation
//! O(len/64) register steps; jump-ahead ([`MSequence::advance`]) O(n log k);
//! primitivity test ([`is_primitive`]) O(n² + √(2ⁿ)); periodic correlation O(N²)
//! direct or O(N log N) by FFT ([`periodic_cross_correlation_with`]).
//!
//! # Example
//! ```
//! use lifted_prbs::{InversePrbs, InversePrbsOptions, periodic_autocorrelation, Normalization};
//!
//! # fn main() -> Result<(), lifted_prbs::Error> {
//! // Zhu 2000 Fig. 1: n = 5, unit magnitude, held n_r = 3 samples.
//! let prbs = InversePrbs::new(&InversePrbsOptions { order: 5, amplitude: 1.0, hold: 3, taps: None })?;
//! let w = prbs.one_period(); // 2 n_r m = 186 samples
//! assert_eq!(w.len(), 186);
//! let r = periodic_autocorrelation(&w, Normalization::Divisor(2.0 * 31.0))?;
//! assert!((r[0] - 3.0).abs() < 1e-12);
//! assert!((r[1] - prbs.autocorrelation(1)).abs() < 1e-12); // 2.0323
//! # Ok(())
//! # }
//! ```
#![deny(missing_docs)]

mod correlation;
mod design;
mod error;
mod inverse;
mod mseq;
mod plan;
mod random;
mod vectorized;

pub use correlation::{
    CorrelationMethod, FFT_THRESHOLD, Normalization, periodic_autocorrelation,
    periodic_cross_correlation, periodic_cross_correlation_with,
};
pub use design::{DesignProposal, DesignRequest, design};
pub use error::{Error, Result};

/// Largest signal matrix (samples × channels) that the in-memory generators build:
/// 2^28 entries (2 GiB of `f64`). Longer excitations are generated in blocks.
pub const MAX_SIGNAL_ENTRIES: u128 = 1 << 28;
pub use inverse::{
    InversePrbs, InversePrbsIter, InversePrbsOptions, held_autocorrelation,
    inverse_prbs_autocorrelation,
};
pub use mseq::{
    MAX_ORDER, MIN_ORDER, MSequence, MSequenceSpec, WordGenerator, is_primitive, period, table_taps,
};
pub use plan::{ChannelScheme, ExperimentPlan, PlanOptions, Segment};
pub use random::{
    GaussianOptions, GbnOptions, MultisineOptions, RandomBinaryOptions, gaussian_white,
    generalized_binary_noise, multisine, multisine_harmonics, random_binary,
};
pub use vectorized::{
    VectorizedExcitation, VectorizedOptions, lifted_covariance, vectorized_excitation,
};

/// The README example, compiled and run as a doc test.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

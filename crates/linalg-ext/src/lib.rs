//! Dense linear-algebra kernels for Lifted.
//!
//! Every kernel takes and returns `nalgebra::DMatrix<f64>` (the public matrix
//! type of the workspace) and computes with faer through zero-copy views
//! ([`as_faer`]) wherever faer has the decomposition. Every function checks
//! shapes and finiteness first and returns [`Result`]: a NaN/∞ gives
//! [`Error::NonFinite`] naming the argument, a wrong shape
//! [`Error::NotSquare`] or [`Error::DimensionMismatch`].
//!
//! # Map
//!
//! | module | kernels | algorithm | cost |
//! |---|---|---|---|
//! | [`convert`], [`check`] | [`as_faer`], [`as_faer_mut`], [`to_dmatrix`]; [`check_finite`], [`check_square`], [`check_rows`], [`check_cols`] | zero-copy column-major views; input validation | O(1) / O(mn) |
//! | [`mod@solve`] | [`solve()`], [`inv`], [`det`], [`rcond`], [`solve_right_lower`] | faer partial-pivot LU; Hager–Higham 1-norm rcond estimate, [`Error::Singular`] below ε; X L = B by column updates | ⅔n³; r w²/2 |
//! | [`matfun`] | [`expm`], [`logm`], [`rootm`], [`rootm_primary`], [`sqrtm`] | Padé-13 scaling and squaring (Higham 2005); complex Schur + inverse scaling and squaring; Smith's Schur p-th root recurrence | O(n³), O(p·n³) |
//! | [`schur`] | [`real_schur`], [`RealSchur::eigenvalues`], [`RealSchur::reorder`] | nalgebra Francis QR (faer's is private), standardised 2×2 blocks; Bai–Demmel block swaps | O(10n³) |
//! | [`mod@eig`] | [`eig()`], [`eigenvalues`], [`sym_eig`] | faer `eigen`, `self_adjoint_eigen` on (A+Aᵀ)/2 | O(10n³) |
//! | [`mod@svd`] | [`svd()`], [`svd_left`], [`singular_values`] | faer thin SVD (U only for `svd_left`; a wide matrix's R of the transpose by unblocked reflections of faer's signs), s descending | O(mn·min(m,n)) |
//! | [`qr`] | [`qr_r`], [`qr_r_owned`], [`qr_thin`], [`qr_full`], [`RAccumulator`] | faer Householder QR (unblocked up to 24 columns); R only in place with a `MemBuffer`; streaming R of row blocks | 2mn² |
//! | [`cholesky`] | [`cholesky_lower`], [`cholesky_condition`] | faer blocked Cholesky; the latter also proves λ_min/λ_max above a threshold by factoring the shifted matrix in place (packed half-size copy) | k³/3, 2k³/3 |
//! | [`extremes`] | [`gram_condition_exceeds`], [`triangular_condition`], [`triangular_ratio_bound`], [`lower_inverse_frobenius`], [`lower_triangular_extremes`] | shifted-Cholesky certificates, explicit triangular inverse bounds, power iteration | O(k²) per step, O(k³/3) |
//! | [`mod@rank`] | [`rank()`], [`pinv`], [`null_space`], [`range_basis`] with [`RankTolerance`] | SVD thresholding, default tol = max(m,n)·ε·σ_max | O(mn·min(m,n)) |
//! | [`product`] | [`mul_blocks`] | faer matmul on column/row blocks of `DMatrix` operands (no copies) | O(mkn) |
//! | [`kernels`] | [`dot`], [`first_non_finite`], `first_infinite`, `has_nan` | eight FMA partial sums (SIMD); branch-free block scans | O(n) |
//! | [`mod@lstsq`] | [`lstsq()`] | Householder QR in place, reflectors applied to B, if full column rank; else minimum-norm SVD solution | O(mn²) |
//! | [`lyapunov`] | [`lyap`], [`dlyap`], [`sylvester`] | Bartels–Stewart on the Schur form | O(n³) |
//! | [`riccati`] | [`dare`] | structure-preserving doubling (no A⁻¹), Newton polish, verified residual and stability | O(n³) per step |
//! | [`mod@cca`] | [`cca()`], [`center_rows`] | thin QR of xᵀ, yᵀ, SVD of Q_xᵀQ_y (never x xᵀ) | O(N(p²+q²)) |
//! | [`budget`] | [`budget::MemoryBudget`], [`budget::Size`], [`budget::resolve_threads`], [`budget::available_cores`] | memory budget (half the physical memory, `LIFTED_MEMORY_LIMIT`), checked byte arithmetic, thread-count cap | O(1) |
//! | [`fft`] | [`fft::Transforms`], [`fft::fast_length`], [`fft::split_packed`] | rustfft through one process-wide planner (compiled once for the workspace), unnormalised; two real spectra from one packed transform | O(N log N) |
//! | [`malloc`] | [`malloc::tune_malloc`] | glibc's mmap/trim thresholds raised for executables, so k×k working matrices reuse heap pages | O(1) |
//! | [`warm`] | [`warm_up`], [`pin_parallelism`] | faer's one-time set-up on a background thread; faer's global parallelism pinned so its solvers start no idle thread pool | O(1) |
//!
//! Numerical notes from the reproduction spec (Part C, Pitfalls 1–2): SVD
//! and eigen bases are unique only up to sign/rotation, so tests compare
//! subspaces and products; the principal logarithm and roots fail with
//! [`Error::NoPrincipalBranch`] when an eigenvalue is on or near the closed
//! negative real axis, and a complex intermediate is returned as real only
//! after its imaginary residue is checked (< 1e-9·‖A‖).
//!
//! # Example
//!
//! ```
//! use lifted_linalg::{expm, logm, rootm, svd, lstsq, Error};
//! use nalgebra::DMatrix;
//!
//! fn main() -> Result<(), Error> {
//!     // d2c-style round trip: principal logarithm of a matrix exponential.
//!     let a = DMatrix::from_row_slice(2, 2, &[-0.5, 1.0, 0.0, -2.0]);
//!     let ad = expm(&a)?;
//!     assert!((logm(&ad)? - &a).norm() < 1e-12);
//!
//!     // Principal cube root: r³ = ad.
//!     let r = rootm(&ad, 3)?;
//!     assert!((&r * &r * &r - &ad).norm() < 1e-12);
//!
//!     // Thin SVD and least squares on a tall matrix.
//!     let h = DMatrix::from_fn(100, 3, |i, j| ((i + 1) as f64).powi(j as i32) / 100f64.powi(j as i32));
//!     let f = svd(&h)?;
//!     assert!(f.s[0] >= f.s[1] && f.s[1] >= f.s[2]);
//!     let y = &h * DMatrix::from_row_slice(3, 1, &[1.0, -2.0, 0.5]);
//!     let x = lstsq(&h, &y)?;
//!     assert!((x[(1, 0)] + 2.0).abs() < 1e-9);
//!
//!     // Invalid input is an error, not a panic.
//!     assert!(matches!(logm(&DMatrix::from_row_slice(1, 1, &[-1.0])), Err(Error::NoPrincipalBranch { .. })));
//!     Ok(())
//! }
//! ```
#![deny(missing_docs)]

pub mod budget;
pub mod cca;
pub mod check;
pub mod cholesky;
pub mod convert;
pub mod eig;
pub mod error;
pub mod extremes;
pub mod fft;
mod fold;
pub mod kernels;
pub mod lstsq;
pub mod lyapunov;
pub mod malloc;
pub mod matfun;
pub mod product;
pub mod qr;
pub mod rank;
pub mod riccati;
pub mod schur;
pub mod simd;
pub mod solve;
pub mod svd;
mod units;
pub mod warm;

pub use cca::{Cca, cca, center_rows};
pub use check::{check_cols, check_finite, check_rows, check_square};
pub use cholesky::{cholesky_condition, cholesky_lower};
pub use convert::{as_faer, as_faer_mut, to_dmatrix};
pub use eig::{
    Eigen, MAX_REFLECTION_CONDITION, SortOrder, SymEigen, eig, eigenvalues, reflect_into_unit_disc,
    spectral_radius, sym_eig,
};
pub use error::{Error, Result};
pub use extremes::{
    ConditionCheck, exceeds_min_eigenvalue, gram_condition_exceeds, lower_inverse_frobenius,
    lower_triangular_extremes, lower_triangular_extremes_within, ratio_bound, triangular_condition,
    triangular_ratio_bound,
};
pub use kernels::{dot, first_non_finite};
pub use lstsq::lstsq;
pub use lyapunov::{dlyap, lyap, sylvester};
pub use matfun::{expm, logm, rootm, rootm_primary, sqrtm};
pub use product::mul_blocks;
pub use qr::{Qr, RAccumulator, qr_full, qr_r, qr_r_owned, qr_thin};
pub use rank::{RankTolerance, null_space, pinv, range_basis, rank};
pub use riccati::{DareSolution, dare};
pub use schur::{RealSchur, real_schur};
pub use solve::{det, inv, rcond, solve, solve_right_lower};
pub use svd::{Svd, singular_values, svd, svd_left};
pub use warm::{pin_parallelism, warm_up};

/// Compiles the README example as a doc test.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;

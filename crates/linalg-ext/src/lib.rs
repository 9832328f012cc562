//! Dense linear-algebra kernels for Lifted.
#![deny(missing_docs)]

pub mod cca;
pub mod check;
pub mod convert;
pub mod eig;
pub mod error;
pub mod lstsq;
pub mod lyapunov;
pub mod matfun;
pub mod qr;
pub mod rank;
pub mod riccati;
pub mod schur;
pub mod solve;
pub mod svd;

pub use cca::{Cca, cca, center_rows};
pub use check::{check_cols, check_finite, check_rows, check_square};
pub use convert::{as_faer, as_faer_mut, to_dmatrix};
pub use eig::{Eigen, SortOrder, SymEigen, eig, eigenvalues, sym_eig};
pub use error::{Error, Result};
pub use lstsq::lstsq;
pub use lyapunov::{dlyap, lyap, sylvester};
pub use matfun::{expm, logm, rootm, sqrtm};
pub use qr::{Qr, RAccumulator, qr_full, qr_r, qr_r_owned, qr_thin};
pub use rank::{RankTolerance, null_space, pinv, range_basis, rank};
pub use riccati::{DareSolution, dare};
pub use schur::{RealSchur, real_schur};
pub use solve::{det, inv, rcond, solve};
pub use svd::{Svd, singular_values, svd};

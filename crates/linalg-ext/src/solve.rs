//! Square linear systems: partial-pivot LU solve, inverse, determinant.
//!
//! All three factor A = PᵀLU with faer's partial-pivoting LU (⅔n³ flops).
//! [`solve`] and [`inv`] then estimate the reciprocal 1-norm condition number
//! rcond = 1/(‖A‖₁‖A⁻¹‖₁) with Hager's estimator as refined by Higham
//! (LAPACK `dlacon`; a few O(n²) triangular solves) — exactly, from the
//! inverse, up to n = 16 — and refuse systems with rcond < ε, i.e.
//! condition numbers beyond ~1/ε, with [`Error::Singular`].

use faer::Mat;
use faer::linalg::solvers::{PartialPivLu, Solve};
use nalgebra::DMatrix;

use crate::check::{check_finite, check_rows, square_finite};
use crate::convert::{as_faer, to_dmatrix};
use crate::{Error, Result};

/// Order up to which the rcond is computed exactly from the inverse.
const EXACT_RCOND_MAX: usize = 16;

/// An LU factorisation together with its rcond estimate.
pub(crate) struct Lu {
    lu: PartialPivLu<f64>,
    n: usize,
    rcond: f64,
    /// A⁻¹ when the exact rcond computed it (n ≤ [`EXACT_RCOND_MAX`]).
    inverse: Option<Mat<f64>>,
}

impl Lu {
    /// Factors the square, finite matrix `a` (validated by the caller).
    pub(crate) fn new(a: &DMatrix<f64>) -> Self {
        let n = a.nrows();
        let lu = as_faer(a).partial_piv_lu();
        let mut this = Lu {
            lu,
            n,
            rcond: 1.0,
            inverse: None,
        };
        this.rcond = this.estimate_rcond(a);
        this
    }

    /// Fails with [`Error::Singular`] when rcond < ε.
    pub(crate) fn require_regular(&self, what: &'static str) -> Result<()> {
        if self.rcond >= f64::EPSILON {
            Ok(())
        } else {
            Err(Error::Singular {
                what,
                rcond: self.rcond,
            })
        }
    }

    /// Solves A X = B for a faer right-hand side.
    pub(crate) fn solve_mat(&self, b: &Mat<f64>) -> Mat<f64> {
        self.lu.solve(b)
    }

    /// Solves A X = B.
    pub(crate) fn solve(&self, b: &DMatrix<f64>) -> DMatrix<f64> {
        to_dmatrix(self.lu.solve(as_faer(b)).as_ref())
    }

    /// Solves Aᵀ X = B.
    pub(crate) fn solve_transpose(&self, b: &DMatrix<f64>) -> DMatrix<f64> {
        to_dmatrix(self.lu.solve_transpose(as_faer(b)).as_ref())
    }

    /// Reciprocal 1-norm condition estimate (Higham 1988, Alg. 4.1 of
    /// "FORTRAN codes for estimating the one-norm of a real or complex
    /// matrix"): at most 5 iterations of two solves each, then the
    /// alternating-sign lower bound of LAPACK's `dlacon`.
    fn estimate_rcond(&mut self, a: &DMatrix<f64>) -> f64 {
        let n = self.n;
        if n == 0 {
            return 1.0;
        }
        let u = self.lu.U();
        let umax = (0..n).map(|i| u[(i, i)].abs()).fold(0.0, f64::max);
        if (0..n).any(|i| u[(i, i)] == 0.0 || !u[(i, i)].is_finite()) || umax == 0.0 {
            return 0.0;
        }
        let anorm = a.column_iter().map(|c| c.lp_norm(1)).fold(0.0, f64::max);
        if anorm == 0.0 {
            return 0.0;
        }
        if n <= EXACT_RCOND_MAX {
            // Small: ‖A⁻¹‖₁ exactly from the inverse, one solve with n
            // right-hand sides (cheaper here than the estimator's up to
            // twelve single-column solves).
            let inv = self.lu.solve(Mat::<f64>::identity(n, n));
            let inv_norm = (0..n)
                .map(|j| (0..n).map(|i| inv[(i, j)].abs()).sum::<f64>())
                .fold(0.0, f64::max);
            self.inverse = Some(inv);
            let rcond = 1.0 / (anorm * inv_norm);
            return if rcond.is_finite() { rcond } else { 0.0 };
        }
        let mut x = DMatrix::from_element(n, 1, 1.0 / n as f64);
        let mut est: f64 = 0.0;
        let mut last_j = usize::MAX;
        for _ in 0..5 {
            let y = self.solve(&x);
            let new_est = y.iter().map(|v| v.abs()).sum::<f64>();
            if !new_est.is_finite() {
                return 0.0;
            }
            if new_est <= est && last_j != usize::MAX {
                break;
            }
            est = new_est;
            let xi = y.map(|v| if v >= 0.0 { 1.0 } else { -1.0 });
            let z = self.solve_transpose(&xi);
            let (j, zmax) = z.iter().enumerate().fold((0, -1.0), |(bj, bv), (k, v)| {
                if v.abs() > bv { (k, v.abs()) } else { (bj, bv) }
            });
            let ztx: f64 = z.iter().zip(x.iter()).map(|(p, q)| p * q).sum();
            if zmax <= ztx || j == last_j {
                break;
            }
            last_j = j;
            x.fill(0.0);
            x[(j, 0)] = 1.0;
        }
        // Alternating-sign test vector guards against an underestimate.
        let alt = DMatrix::from_fn(n, 1, |i, _| {
            let s = if i % 2 == 0 { 1.0 } else { -1.0 };
            s * (1.0 + i as f64 / (n.max(2) - 1) as f64)
        });
        let y = self.solve(&alt);
        let alt_est = 2.0 * y.iter().map(|v| v.abs()).sum::<f64>() / (3.0 * n as f64);
        if !alt_est.is_finite() {
            return 0.0;
        }
        let inv_norm: f64 = est.max(alt_est);
        let rcond = 1.0 / (anorm * inv_norm);
        if rcond.is_finite() { rcond } else { 0.0 }
    }

    /// The reciprocal condition estimate.
    pub(crate) fn rcond(&self) -> f64 {
        self.rcond
    }
}

/// X = B L⁻¹ for the lower triangle of the square `l` (entries above the
/// diagonal ignored): the right-hand triangular solve X L = B by columns
/// of X from the last, X_j = (B_j − Σ_{i>j} L_ij X_i) / L_jj, each step
/// contiguous column updates (vectorised). O(r w²/2) for B r×w. `None`
/// when a diagonal entry is 0 or the shapes differ. No condition check:
/// callers solve with factors whose conditioning they established.
pub fn solve_right_lower(l: &DMatrix<f64>, mut b: DMatrix<f64>) -> Option<DMatrix<f64>> {
    let w = l.nrows();
    if l.ncols() != w || b.ncols() != w || (0..w).any(|j| l[(j, j)] == 0.0) {
        return None;
    }
    let r = b.nrows();
    if r == 0 {
        return Some(b);
    }
    crate::simd::dispatch(
        #[inline(always)]
        || {
            let x = b.as_mut_slice();
            for j in (0..w).rev() {
                let col = &l.as_slice()[j * w..(j + 1) * w];
                let (head, rest) = x.split_at_mut((j + 1) * r);
                let xj = &mut head[j * r..];
                for (i, xi) in rest.chunks_exact(r).enumerate() {
                    let lij = col[j + 1 + i];
                    if lij != 0.0 {
                        for (a, v) in xj.iter_mut().zip(xi) {
                            *a -= lij * v;
                        }
                    }
                }
                let d = col[j];
                for a in xj.iter_mut() {
                    *a /= d;
                }
            }
        },
    );
    Some(b)
}

/// Solves the square system A X = B (partial-pivot LU, O(n³ + n²k) for k
/// right-hand sides).
///
/// Errors: [`Error::NotSquare`] for a non-square `a`,
/// [`Error::DimensionMismatch`] when `b` does not have n rows,
/// [`Error::NonFinite`], and [`Error::Singular`] (with the rcond estimate)
/// when A is singular or its condition number exceeds ~1/ε.
pub fn solve(a: &DMatrix<f64>, b: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = square_finite("a", a)?;
    check_rows("b", b, n)?;
    check_finite("b", b)?;
    if n == 0 {
        return Ok(DMatrix::zeros(0, b.ncols()));
    }
    let lu = Lu::new(a);
    lu.require_regular("a")?;
    Ok(lu.solve(b))
}

/// Inverse of a square matrix (partial-pivot LU, O(n³)).
///
/// Prefer [`solve`] when the inverse is only applied to a right-hand side.
/// Errors as [`solve`].
pub fn inv(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = square_finite("a", a)?;
    if n == 0 {
        return Ok(DMatrix::zeros(0, 0));
    }
    let lu = Lu::new(a);
    lu.require_regular("a")?;
    // Small orders: the rcond already computed the inverse.
    let inverse = match lu.inverse {
        Some(ref m) => to_dmatrix(m.as_ref()),
        None => to_dmatrix(lu.solve_mat(&Mat::identity(n, n)).as_ref()),
    };
    Ok(inverse)
}

/// Reciprocal 1-norm condition estimate rcond(A) = 1/(‖A‖₁‖A⁻¹‖₁) in [0, 1]
/// (LU + Hager–Higham estimator, O(n³)); 0 for an exactly singular matrix.
pub fn rcond(a: &DMatrix<f64>) -> Result<f64> {
    let n = square_finite("a", a)?;
    if n == 0 {
        return Ok(1.0);
    }
    Ok(Lu::new(a).rcond())
}

/// Determinant of a square matrix (LU, O(n³)); 1 for the 0×0 matrix.
///
/// A singular matrix is not an error here: its determinant is (close to) 0.
/// The result may overflow to ±∞ for large well-scaled matrices.
pub fn det(a: &DMatrix<f64>) -> Result<f64> {
    let n = square_finite("a", a)?;
    if n == 0 {
        return Ok(1.0);
    }
    Ok(as_faer(a).determinant())
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn solves_small_system() {
        let a = DMatrix::from_row_slice(2, 2, &[4.0, 1.0, 2.0, 3.0]);
        let b = DMatrix::from_row_slice(2, 1, &[1.0, 2.0]);
        let x = solve(&a, &b).unwrap();
        assert_relative_eq!(&a * &x, b, epsilon = 1e-14);
        assert_relative_eq!(det(&a).unwrap(), 10.0, epsilon = 1e-13);
        let ai = inv(&a).unwrap();
        assert_relative_eq!(&a * ai, DMatrix::identity(2, 2), epsilon = 1e-14);
    }

    #[test]
    fn rcond_matches_exact_value() {
        // diag(1, 1e-3): ‖A‖₁ = 1, ‖A⁻¹‖₁ = 1e3, so rcond = 1e-3 exactly.
        let a = DMatrix::from_diagonal(&nalgebra::dvector![1.0, 1e-3]);
        assert_relative_eq!(rcond(&a).unwrap(), 1e-3, max_relative = 1e-12);
        assert_eq!(rcond(&DMatrix::identity(3, 3)).unwrap(), 1.0);
    }

    #[test]
    fn exact_rcond_for_small_orders_and_an_estimate_above() {
        for n in [5, EXACT_RCOND_MAX, EXACT_RCOND_MAX + 14] {
            let a = DMatrix::from_fn(n, n, |i, j| {
                (1.0 + 0.9 * i as f64 + 0.37 * (j * j) as f64).sin()
                    + 2.0 * f64::from(u8::from(i == j))
            });
            let norm1 = |m: &DMatrix<f64>| {
                m.column_iter()
                    .map(|c| c.iter().map(|v| v.abs()).sum::<f64>())
                    .fold(0.0, f64::max)
            };
            let inverse = a.clone().try_inverse().unwrap();
            let exact = 1.0 / (norm1(&a) * norm1(&inverse));
            let got = rcond(&a).unwrap();
            if n <= EXACT_RCOND_MAX {
                assert_relative_eq!(got, exact, max_relative = 1e-10);
            } else {
                // The estimator bounds ‖A⁻¹‖₁ from below: rcond from above.
                assert!(
                    got >= exact * (1.0 - 1e-12) && got <= 10.0 * exact,
                    "{got} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn singular_is_rejected() {
        let a = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 4.0]);
        let b = DMatrix::from_element(2, 1, 1.0);
        assert!(matches!(
            solve(&a, &b),
            Err(Error::Singular { what: "a", .. })
        ));
        assert!(matches!(inv(&a), Err(Error::Singular { .. })));
        assert!(det(&a).unwrap().abs() < 1e-15);
        // Ill-conditioned beyond 1/ε.
        let a = DMatrix::from_diagonal(&nalgebra::dvector![1.0, 1e-17]);
        assert!(matches!(inv(&a), Err(Error::Singular { rcond, .. }) if rcond < 1e-16));
        assert!(
            matches!(inv(&DMatrix::zeros(3, 3)), Err(Error::Singular { rcond, .. }) if rcond == 0.0)
        );
    }

    #[test]
    fn empty_system() {
        let a = DMatrix::<f64>::zeros(0, 0);
        assert_eq!(solve(&a, &DMatrix::zeros(0, 3)).unwrap().shape(), (0, 3));
        assert_eq!(det(&a).unwrap(), 1.0);
        assert_eq!(inv(&a).unwrap().shape(), (0, 0));
    }

    #[test]
    fn the_right_lower_solve_inverts_the_product() {
        for (r, w) in [(1, 1), (3, 5), (40, 80), (7, 2)] {
            let l = DMatrix::from_fn(w, w, |i, j| {
                if i == j {
                    1.5 + (i as f64).cos()
                } else {
                    (0.7 * (i * w + j) as f64).sin()
                }
            });
            let b = DMatrix::from_fn(r, w, |i, j| ((i + 2 * j) as f64 * 0.37).cos());
            let x = solve_right_lower(&l, b.clone()).unwrap();
            // Entries above the diagonal ignored.
            assert!((&x * l.lower_triangle() - &b).amax() < 1e-11, "{r}x{w}");
            let mut singular = l.clone();
            singular[(w - 1, w - 1)] = 0.0;
            assert!(solve_right_lower(&singular, b.clone()).is_none());
            assert!(solve_right_lower(&l, DMatrix::zeros(r, w + 1)).is_none());
        }
        let empty = solve_right_lower(&DMatrix::identity(3, 3), DMatrix::zeros(0, 3)).unwrap();
        assert_eq!(empty.shape(), (0, 3));
    }
}

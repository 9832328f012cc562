//! Sylvester and Lyapunov equations by the Bartels–Stewart method.
//!
//! The coefficient matrices are reduced to (complex, upper triangular)
//! Schur form — real Schur + `rsf2csf` — the transformed equation is solved
//! column by column with triangular solves, and the solution is transformed
//! back; the real part is returned after checking that the imaginary residue
//! is negligible. Cost O(10n³ + 10m³ + n²m + nm²) (Bartels & Stewart 1972;
//! Kitagawa 1977 / Barraud 1977 for the discrete (Stein) equation).
//!
//! * [`sylvester`]: A X + X B = C, unique iff λᵢ(A) + λⱼ(B) ≠ 0.
//! * [`lyap`]: A X + X Aᵀ + Q = 0, unique iff λᵢ + λⱼ ≠ 0.
//! * [`dlyap`]: A X Aᵀ − X + Q = 0, unique iff λᵢλⱼ ≠ 1.
//!
//! A pair closer than 100·n·ε·‖·‖_F to violating the condition is reported
//! as [`Error::NoUniqueSolution`].

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::check::{check_cols, check_finite, check_rows, square_finite};
use crate::schur::real_schur;
use crate::{Error, Result};

type CMat = DMatrix<Complex64>;

fn to_c(m: &DMatrix<f64>) -> CMat {
    m.map(|v| Complex64::new(v, 0.0))
}

/// Complex Schur form (U, T) of a real square matrix.
fn cschur(a: &DMatrix<f64>) -> Result<(CMat, CMat)> {
    Ok(real_schur(a)?.to_complex())
}

/// Solves (S + shift·I) y = f for upper triangular S (back substitution).
fn tri_solve_shifted(s: &CMat, shift: Complex64, f: &mut [Complex64]) {
    let n = s.nrows();
    for i in (0..n).rev() {
        let mut acc = f[i];
        for k in (i + 1)..n {
            acc -= s[(i, k)] * f[k];
        }
        f[i] = acc / (s[(i, i)] + shift);
    }
}

/// Real part of a complex solution after checking its imaginary residue.
fn real_part(x: CMat, what: &'static str, scale: f64) -> Result<DMatrix<f64>> {
    let re = x.map(|z| z.re);
    let im = x.map(|z| z.im).norm();
    let tol = 1e-8 * (re.norm() + scale);
    if im.is_nan() || im > tol || re.iter().any(|v| !v.is_finite()) {
        return Err(Error::Backend {
            what,
            reason: format!(
                "imaginary residue {im:e} of the complex Schur solution exceeds {tol:e}"
            ),
        });
    }
    Ok(re)
}

/// Symmetrises X when the right-hand side was exactly symmetric.
fn symmetrise_if(x: DMatrix<f64>, q: &DMatrix<f64>) -> DMatrix<f64> {
    if *q == q.transpose() {
        (&x + x.transpose()) * 0.5
    } else {
        x
    }
}

/// Solves the Sylvester equation A X + X B = C for X (m×n), A m×m, B n×n,
/// C m×n (Bartels–Stewart, O(10m³ + 10n³ + m²n + mn²)).
///
/// Errors: [`Error::NotSquare`], [`Error::DimensionMismatch`],
/// [`Error::NonFinite`], [`Error::NoUniqueSolution`] when λᵢ(A) + λⱼ(B) ≈ 0.
pub fn sylvester(a: &DMatrix<f64>, b: &DMatrix<f64>, c: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let m = square_finite("a", a)?;
    let n = square_finite("b", b)?;
    check_rows("c", c, m)?;
    check_cols("c", c, n)?;
    check_finite("c", c)?;
    if m == 0 || n == 0 {
        return Ok(DMatrix::zeros(m, n));
    }
    let (ua, ta) = cschur(a)?;
    let (ub, tb) = cschur(b)?;
    let tol = 100.0 * (m + n) as f64 * f64::EPSILON * (a.norm() + b.norm());
    for i in 0..m {
        for j in 0..n {
            let s = ta[(i, i)] + tb[(j, j)];
            if s.norm() <= tol {
                return Err(Error::NoUniqueSolution {
                    what: "sylvester",
                    reason: format!("λ(A) = {} and λ(B) = {} sum to ≈ 0", ta[(i, i)], tb[(j, j)]),
                });
            }
        }
    }
    // T_A Y + Y T_B = U_Aᴴ C U_B, T_B upper: columns in increasing order.
    let mut f = ua.adjoint() * to_c(c) * &ub;
    for j in 0..n {
        let mut col: Vec<Complex64> = f.column(j).iter().copied().collect();
        for k in 0..j {
            let t = tb[(k, j)];
            for (i, v) in col.iter_mut().enumerate() {
                *v -= f[(i, k)] * t;
            }
        }
        tri_solve_shifted(&ta, tb[(j, j)], &mut col);
        f.column_mut(j).copy_from_slice(&col);
    }
    let x = &ua * f * ub.adjoint();
    real_part(x, "sylvester", c.norm())
}

/// Solves the continuous Lyapunov equation A X + X Aᵀ + Q = 0
/// (Bartels–Stewart on one Schur form of A, O(10n³ + n³)).
///
/// For a Hurwitz A and Q ⪰ 0, X = ∫₀^∞ e^{At} Q e^{Aᵀt} dt ⪰ 0. X is
/// symmetrised when Q is exactly symmetric.
///
/// Errors: [`Error::NotSquare`], [`Error::DimensionMismatch`],
/// [`Error::NonFinite`], [`Error::NoUniqueSolution`] when λᵢ + λⱼ ≈ 0.
pub fn lyap(a: &DMatrix<f64>, q: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = square_finite("a", a)?;
    check_rows("q", q, n)?;
    check_cols("q", q, n)?;
    check_finite("q", q)?;
    if n == 0 {
        return Ok(DMatrix::zeros(0, 0));
    }
    let (u, t) = cschur(a)?;
    let tol = 100.0 * n as f64 * f64::EPSILON * a.norm();
    for i in 0..n {
        for j in 0..n {
            if (t[(i, i)] + t[(j, j)].conj()).norm() <= tol {
                return Err(Error::NoUniqueSolution {
                    what: "lyap",
                    reason: format!("eigenvalues {} and {} sum to ≈ 0", t[(i, i)], t[(j, j)]),
                });
            }
        }
    }
    // A = U T Uᴴ, Aᵀ = U Tᴴ Uᴴ: T Y + Y Tᴴ = −Uᴴ Q U, Tᴴ lower triangular,
    // so columns are solved from the last one backwards.
    let mut f = -(u.adjoint() * to_c(q) * &u);
    for j in (0..n).rev() {
        let mut col: Vec<Complex64> = f.column(j).iter().copied().collect();
        for k in (j + 1)..n {
            let t_kj = t[(j, k)].conj(); // (Tᴴ)_{kj}
            for (i, v) in col.iter_mut().enumerate() {
                *v -= f[(i, k)] * t_kj;
            }
        }
        tri_solve_shifted(&t, t[(j, j)].conj(), &mut col);
        f.column_mut(j).copy_from_slice(&col);
    }
    let x = &u * f * u.adjoint();
    Ok(symmetrise_if(real_part(x, "lyap", q.norm())?, q))
}

/// Solves the discrete Lyapunov (Stein) equation A X Aᵀ − X + Q = 0
/// (Bartels–Stewart/Barraud on one Schur form of A, O(10n³ + 2n³)).
///
/// For a Schur-stable A and Q ⪰ 0, X = Σₖ Aᵏ Q (Aᵀ)ᵏ ⪰ 0. X is symmetrised
/// when Q is exactly symmetric.
///
/// Errors: [`Error::NotSquare`], [`Error::DimensionMismatch`],
/// [`Error::NonFinite`], [`Error::NoUniqueSolution`] when λᵢλⱼ ≈ 1.
pub fn dlyap(a: &DMatrix<f64>, q: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = square_finite("a", a)?;
    check_rows("q", q, n)?;
    check_cols("q", q, n)?;
    check_finite("q", q)?;
    if n == 0 {
        return Ok(DMatrix::zeros(0, 0));
    }
    let (u, t) = cschur(a)?;
    let tol = 100.0 * n as f64 * f64::EPSILON * (1.0 + a.norm() * a.norm());
    for i in 0..n {
        for j in 0..n {
            if (t[(i, i)] * t[(j, j)].conj() - 1.0).norm() <= tol {
                return Err(Error::NoUniqueSolution {
                    what: "dlyap",
                    reason: format!(
                        "eigenvalues {} and {} have product ≈ 1",
                        t[(i, i)],
                        t[(j, j)]
                    ),
                });
            }
        }
    }
    // T Y Tᴴ − Y + F = 0 with F = Uᴴ Q U. Column j (descending):
    // (conj(t_jj) T − I) y_j = −f_j − T Σ_{k>j} conj(t_jk) y_k.
    let f0 = u.adjoint() * to_c(q) * &u;
    let mut y = CMat::zeros(n, n);
    for j in (0..n).rev() {
        let mut w = vec![Complex64::new(0.0, 0.0); n];
        for k in (j + 1)..n {
            let c = t[(j, k)].conj();
            for (i, v) in w.iter_mut().enumerate() {
                *v += y[(i, k)] * c;
            }
        }
        // rhs = −f_j − T w
        let mut rhs = vec![Complex64::new(0.0, 0.0); n];
        for i in 0..n {
            let mut acc = -f0[(i, j)];
            for k in i..n {
                acc -= t[(i, k)] * w[k];
            }
            rhs[i] = acc;
        }
        // (c T − I) y = rhs with c = conj(t_jj): divide by c when possible.
        let cj = t[(j, j)].conj();
        let n_ = n;
        for i in (0..n_).rev() {
            let mut acc = rhs[i];
            for k in (i + 1)..n_ {
                acc -= cj * t[(i, k)] * rhs[k];
            }
            rhs[i] = acc / (cj * t[(i, i)] - 1.0);
        }
        y.column_mut(j).copy_from_slice(&rhs);
    }
    let x = &u * y * u.adjoint();
    Ok(symmetrise_if(real_part(x, "dlyap", q.norm())?, q))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn scalar_cases() {
        let a = DMatrix::from_element(1, 1, -2.0);
        let q = DMatrix::from_element(1, 1, 4.0);
        assert_relative_eq!(lyap(&a, &q).unwrap()[(0, 0)], 1.0, epsilon = 1e-15);
        let a = DMatrix::from_element(1, 1, 0.5);
        assert_relative_eq!(dlyap(&a, &q).unwrap()[(0, 0)], 4.0 / 0.75, epsilon = 1e-14);
    }

    #[test]
    fn lyapunov_residuals() {
        let a = DMatrix::from_row_slice(3, 3, &[-1.0, 2.0, 0.0, -3.0, -1.0, 1.0, 0.0, 0.5, -2.0]);
        let q = DMatrix::from_row_slice(3, 3, &[2.0, 1.0, 0.0, 1.0, 3.0, 0.5, 0.0, 0.5, 1.0]);
        let x = lyap(&a, &q).unwrap();
        assert!((&a * &x + &x * a.transpose() + &q).norm() < 1e-13);
        assert_eq!(x, x.transpose());
        let ad = &a * 0.3;
        let x = dlyap(&ad, &q).unwrap();
        assert!((&ad * &x * ad.transpose() - &x + &q).norm() < 1e-13);
        let b = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, -2.0, 1.0]);
        let c = DMatrix::from_fn(3, 2, |i, j| (i + 2 * j) as f64);
        let x = sylvester(&a, &b, &c).unwrap();
        assert!((&a * &x + &x * &b - &c).norm() < 1e-13);
    }

    #[test]
    fn singular_operators_are_rejected() {
        // λ = ±1 pair: λᵢ + λⱼ = 0 for the continuous equation.
        let a = DMatrix::from_diagonal(&nalgebra::dvector![1.0, -1.0]);
        let q = DMatrix::identity(2, 2);
        assert!(matches!(
            lyap(&a, &q),
            Err(Error::NoUniqueSolution { what: "lyap", .. })
        ));
        // λ = 2 and 0.5: product 1 for the discrete equation.
        let a = DMatrix::from_diagonal(&nalgebra::dvector![2.0, 0.5]);
        assert!(matches!(
            dlyap(&a, &q),
            Err(Error::NoUniqueSolution { what: "dlyap", .. })
        ));
        let a = DMatrix::from_element(1, 1, 1.0);
        let b = DMatrix::from_element(1, 1, -1.0);
        assert!(matches!(
            sylvester(&a, &b, &a),
            Err(Error::NoUniqueSolution { .. })
        ));
    }
}

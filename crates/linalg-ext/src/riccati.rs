//! Discrete-time algebraic Riccati equation (DARE) with cross term.
//!
//! X = AᵀXA − (AᵀXB + S)(R + BᵀXB)⁻¹(BᵀXA + Sᵀ) + Q,
//! K = (R + BᵀXB)⁻¹(BᵀXA + Sᵀ),
//! the stabilizing solution: A − BK Schur stable (LQR for the stage cost
//! xᵀQx + 2xᵀSu + uᵀRu with u = −Kx).
//!
//! Method: the cross term is removed (A_s = A − BR⁻¹Sᵀ, Q_s = Q − SR⁻¹Sᵀ,
//! G = BR⁻¹Bᵀ), then the structure-preserving doubling algorithm (SDA;
//! Chu, Fan, Lin & Wang 2004) iterates
//! W = I + G_kH_k, A_{k+1} = A_kW⁻¹A_k, G_{k+1} = G_k + A_kW⁻¹G_kA_kᵀ,
//! H_{k+1} = H_k + A_kᵀH_kW⁻¹A_k, with H_k → X quadratically. It never
//! inverts A, so singular A (pure delays) is fine. Each step costs O(n³);
//! typically 5–15 steps. Up to two Newton–Hewer refinement steps (one
//! [`crate::dlyap`] each) polish the result if the residual check fails.
//! The result is verified: relative residual ≤ 1e-9 and spectral radius of
//! A − BK < 1, otherwise [`Error::NoStabilizingSolution`].

use faer::Side;
use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::check::{check_cols, check_finite, check_rows, square_finite};
use crate::convert::as_faer;
use crate::eig::eigenvalues;
use crate::lyapunov::dlyap;
use crate::solve::solve;
use crate::{Error, Result};

/// Stabilizing solution of the DARE and the associated gain.
#[derive(Debug, Clone, PartialEq)]
pub struct DareSolution {
    /// The symmetric stabilizing solution X (n×n).
    pub x: DMatrix<f64>,
    /// The gain K = (R + BᵀXB)⁻¹(BᵀXA + Sᵀ) (m×n), u = −Kx.
    pub k: DMatrix<f64>,
    /// Eigenvalues of A − BK (all inside the unit circle).
    pub closed_loop_poles: Vec<Complex64>,
    /// SDA iterations used.
    pub iterations: usize,
    /// Relative residual ‖res‖_F / max(1, ‖X‖_F, ‖Q‖_F) of the returned X.
    pub residual: f64,
}

const MAX_ITER: usize = 100;
const RESIDUAL_TOL: f64 = 1e-9;

fn sym(m: &DMatrix<f64>) -> DMatrix<f64> {
    (m + m.transpose()) * 0.5
}

/// DARE residual and gain for a candidate X.
fn residual_and_gain(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    s: &DMatrix<f64>,
    x: &DMatrix<f64>,
) -> Result<(f64, DMatrix<f64>)> {
    let btx = b.transpose() * x;
    let rr = r + &btx * b;
    let k = solve(&rr, &(&btx * a + s.transpose())).map_err(|_| Error::NoStabilizingSolution {
        what: "dare",
        reason: "R + BᵀXB is singular".into(),
    })?;
    let atxb_s = a.transpose() * x * b + s;
    let res = a.transpose() * x * a - &atxb_s * &k + q - x;
    let scale = 1f64.max(x.norm()).max(q.norm());
    Ok((res.norm() / scale, k))
}

/// Solves the discrete-time algebraic Riccati equation for its stabilizing
/// solution (SDA, O(n³) per iteration; see the module docs).
///
/// A is n×n, B n×m, Q n×n symmetric, R m×m symmetric positive definite, S
/// (optional cross term) n×m. Q and R are symmetrised.
///
/// Errors: [`Error::NotSquare`], [`Error::DimensionMismatch`],
/// [`Error::NonFinite`], [`Error::NotPositiveDefinite`] for R,
/// [`Error::NoStabilizingSolution`] when the iteration diverges or the
/// result is not stabilizing or not accurate.
pub fn dare(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    s: Option<&DMatrix<f64>>,
) -> Result<DareSolution> {
    let n = square_finite("a", a)?;
    check_rows("b", b, n)?;
    check_finite("b", b)?;
    let m = b.ncols();
    let qn = square_finite("q", q)?;
    check_rows("q", q, n).map(|_| qn)?;
    let rm = square_finite("r", r)?;
    check_rows("r", r, m).map(|_| rm)?;
    let zero_s;
    let s = match s {
        Some(s) => {
            check_rows("s", s, n)?;
            check_cols("s", s, m)?;
            check_finite("s", s)?;
            s
        }
        None => {
            zero_s = DMatrix::zeros(n, m);
            &zero_s
        }
    };
    let q = sym(q);
    let r = sym(r);
    if n == 0 {
        return Ok(DareSolution {
            x: DMatrix::zeros(0, 0),
            k: DMatrix::zeros(m, 0),
            closed_loop_poles: Vec::new(),
            iterations: 0,
            residual: 0.0,
        });
    }
    if m > 0 && as_faer(&r).llt(Side::Lower).is_err() {
        return Err(Error::NotPositiveDefinite { what: "r" });
    }
    // Remove the cross term.
    let (a_s, q_s, g) = if m == 0 {
        (a.clone(), q.clone(), DMatrix::zeros(n, n))
    } else {
        let rinv_st =
            solve(&r, &s.transpose()).map_err(|_| Error::NotPositiveDefinite { what: "r" })?;
        let rinv_bt =
            solve(&r, &b.transpose()).map_err(|_| Error::NotPositiveDefinite { what: "r" })?;
        (
            a - b * &rinv_st,
            sym(&(&q - s * &rinv_st)),
            sym(&(b * rinv_bt)),
        )
    };
    let eye = DMatrix::<f64>::identity(n, n);
    let (mut ak, mut gk, mut hk) = (a_s, g, q_s);
    let mut iterations = 0;
    let mut prev_change = f64::INFINITY;
    let diverged = |what: &str| Error::NoStabilizingSolution {
        what: "dare",
        reason: what.to_string(),
    };
    loop {
        iterations += 1;
        let w = &eye + &gk * &hk;
        // W⁻¹A_k and W⁻¹G_k in one solve.
        let mut rhs = DMatrix::zeros(n, 2 * n);
        rhs.columns_mut(0, n).copy_from(&ak);
        rhs.columns_mut(n, n).copy_from(&gk);
        let sol = solve(&w, &rhs)
            .map_err(|_| diverged("I + G_k H_k became singular in the doubling iteration"))?;
        let wa = sol.columns(0, n).into_owned();
        let wg = sol.columns(n, n).into_owned();
        let h_next = sym(&(&hk + ak.transpose() * &hk * &wa));
        let g_next = sym(&(&gk + &ak * wg * ak.transpose()));
        let a_next = &ak * wa;
        let change = (&h_next - &hk).norm();
        let size = h_next.norm();
        hk = h_next;
        gk = g_next;
        ak = a_next;
        if hk.iter().any(|v| !v.is_finite()) {
            return Err(diverged("the doubling iteration diverged"));
        }
        // Converged, or stagnating at rounding level (the residual check
        // and the Newton polish below decide on the accuracy).
        if change <= 1e-14 * size
            || change == 0.0
            || (change <= 1e-9 * size && change >= prev_change)
        {
            break;
        }
        if iterations >= MAX_ITER {
            if change <= 1e-8 * size {
                break;
            }
            return Err(Error::NoConvergence {
                what: "dare doubling iteration",
                iterations,
            });
        }
        prev_change = change;
    }
    let mut x = hk;
    let (mut resid, mut k) = residual_and_gain(a, b, &q, &r, s, &x)?;
    // Newton–Hewer refinement: X = A_cᵀXA_c + Q − SK − KᵀSᵀ + KᵀRK.
    for _ in 0..2 {
        if resid <= 1e-12 {
            break;
        }
        let ac = a - b * &k;
        let qc = &q - s * &k - k.transpose() * s.transpose() + k.transpose() * &r * &k;
        let Ok(xn) = dlyap(&ac.transpose(), &sym(&qc)) else {
            break;
        };
        let (rn, kn) = residual_and_gain(a, b, &q, &r, s, &xn)?;
        if rn < resid {
            x = xn;
            resid = rn;
            k = kn;
        } else {
            break;
        }
    }
    let closed = a - b * &k;
    let poles = eigenvalues(&closed)?;
    let rho = poles.iter().map(|p| p.norm()).fold(0.0, f64::max);
    if rho.is_nan() || rho >= 1.0 {
        return Err(diverged(&format!("spectral radius of A − BK is {rho}")));
    }
    if resid.is_nan() || resid > RESIDUAL_TOL {
        return Err(diverged(&format!(
            "relative residual {resid:e} exceeds {RESIDUAL_TOL:e}"
        )));
    }
    Ok(DareSolution {
        x,
        k,
        closed_loop_poles: poles,
        iterations,
        residual: resid,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn scalar_dare_closed_form() {
        // a = 2, b = 1, q = 1, r = 1: x = 4x − 4x²/(1 + x) + 1
        // ⇔ x² − 4x − 1 = 0, x = 2 + √5.
        let one = DMatrix::from_element(1, 1, 1.0);
        let sol = dare(&DMatrix::from_element(1, 1, 2.0), &one, &one, &one, None).unwrap();
        let x = 2.0 + 5f64.sqrt();
        assert_relative_eq!(sol.x[(0, 0)], x, epsilon = 1e-12);
        assert_relative_eq!(sol.k[(0, 0)], 2.0 * x / (1.0 + x), epsilon = 1e-12);
        assert!(sol.closed_loop_poles[0].norm() < 1.0);
    }

    #[test]
    fn singular_a_and_cross_term() {
        // Pure delay chain (A nilpotent, singular) with a cross term.
        let a = DMatrix::from_row_slice(3, 3, &[0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
        let b = DMatrix::from_row_slice(3, 1, &[0.0, 0.0, 1.0]);
        let q = DMatrix::identity(3, 3);
        let r = DMatrix::from_element(1, 1, 2.0);
        let s = DMatrix::from_row_slice(3, 1, &[0.1, 0.0, 0.2]);
        let sol = dare(&a, &b, &q, &r, Some(&s)).unwrap();
        assert!(sol.residual < 1e-12);
        assert_eq!(sol.x, sol.x.transpose());
    }

    #[test]
    fn unstabilizable_is_rejected() {
        // Unstable mode not reachable from B.
        let a = DMatrix::from_diagonal(&nalgebra::dvector![2.0, 0.5]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let q = DMatrix::identity(2, 2);
        let r = DMatrix::identity(1, 1);
        assert!(dare(&a, &b, &q, &r, None).is_err());
        assert!(matches!(
            dare(&a, &b, &q, &DMatrix::from_element(1, 1, -1.0), None),
            Err(Error::NotPositiveDefinite { what: "r" })
        ));
    }
}

//! Simulation by difference equations and frequency responses of
//! [`PolyModel`].

use nalgebra::DMatrix;
use num_complex::Complex64;

use super::PolyModel;
use crate::error::{Error, Result, check_scalar};
use crate::la;

/// `out(t) = Σ_l num[l] x(t − delay − l) − Σ_{l≥1} den[l] out(t − l)`, zero
/// initial conditions; `den` monic. O(N (len num + len den)).
pub(super) fn filter(num: &[f64], delay: usize, den: &[f64], x: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; x.len()];
    for t in 0..x.len() {
        let mut v = 0.0;
        for (l, &b) in num.iter().enumerate() {
            let lag = delay + l;
            if lag > t {
                break;
            }
            v += b * x[t - lag];
        }
        for (l, &a) in den.iter().enumerate().skip(1) {
            if l > t {
                break;
            }
            v -= a * out[t - l];
        }
        out[t] = v;
    }
    out
}

/// Column j of `m` as a vector.
pub(super) fn column(m: &DMatrix<f64>, j: usize) -> Vec<f64> {
    m.column(j).iter().copied().collect()
}

/// `(A(q) y)_i(t) = Σ_j Σ_l A_ij[l] y_j(t − l)`, leading coefficients
/// included, zero before t = 0. O(Σ_j na_ij).
pub(super) fn apply_a_row(m: &PolyModel, i: usize, y: &[Vec<f64>], t: usize) -> f64 {
    let mut v = 0.0;
    for (j, yj) in y.iter().enumerate() {
        for (l, &a) in m.a(i, j).iter().enumerate() {
            if l > t {
                break;
            }
            v += a * yj[t - l];
        }
    }
    v
}

impl PolyModel {
    /// Checks u (N × n_u, finite) and returns its columns.
    pub(super) fn input_columns(&self, u: &DMatrix<f64>) -> Result<Vec<Vec<f64>>> {
        la::check_cols("u", u, self.nu)?;
        la::check_finite("u", u)?;
        Ok((0..self.nu).map(|k| column(u, k)).collect())
    }

    /// s_i(t) = Σ_k B_ik/F_ik u_k(t − nk_ik) for every output. O(N Σ (nb + nf)).
    pub(super) fn input_part(&self, u: &[Vec<f64>], len: usize) -> Vec<Vec<f64>> {
        (0..self.ny)
            .map(|i| {
                let mut s = vec![0.0; len];
                for (k, uk) in u.iter().enumerate() {
                    let b = self.b(i, k);
                    if b.is_empty() {
                        continue;
                    }
                    let w = filter(b, self.nk(i, k), self.f(i, k), uk);
                    for (si, wi) in s.iter_mut().zip(&w) {
                        *si += wi;
                    }
                }
                s
            })
            .collect()
    }

    /// Simulates y = G u + H e from zero initial conditions by the
    /// difference equations (one row per sample, one column per channel):
    /// w_ik = B_ik/F_ik u_k(t − nk), v_i = C_i/D_i e_i, then
    /// y_i(t) = w_i + v_i − Σ_j Σ_{l≥1} a_ij,l y_j(t − l). `e` (N × n_y)
    /// is the white noise realisation itself (not scaled by Λ); `None`
    /// simulates the deterministic part. O(N r).
    ///
    /// Errors: u without n_u columns, e not N × n_y
    /// ([`Error::DimensionMismatch`] or [`Error::Linalg`]), non-finite
    /// data ([`Error::Linalg`]).
    pub fn simulate(&self, u: &DMatrix<f64>, e: Option<&DMatrix<f64>>) -> Result<DMatrix<f64>> {
        let uc = self.input_columns(u)?;
        let len = u.nrows();
        let mut s = self.input_part(&uc, len);
        if let Some(e) = e {
            la::check_cols("e", e, self.ny)?;
            la::check_finite("e", e)?;
            if e.nrows() != len {
                return Err(Error::DimensionMismatch {
                    what: "e",
                    expected: format!("{len} rows (as u)"),
                    got: format!("{}", e.nrows()),
                });
            }
            for (i, si) in s.iter_mut().enumerate() {
                let v = filter(&self.c[i], 0, &self.d[i], &column(e, i));
                for (a, b) in si.iter_mut().zip(&v) {
                    *a += b;
                }
            }
        }
        // A(q) y = s, A(0) = I: y_i(t) = s_i(t) − (A y)_i(t) + y_i(t).
        let mut y = vec![vec![0.0; len]; self.ny];
        for t in 0..len {
            for i in 0..self.ny {
                y[i][t] = s[i][t] - apply_a_row(self, i, &y, t);
            }
        }
        Ok(DMatrix::from_fn(len, self.ny, |t, i| y[i][t]))
    }

    /// A(x)⁻¹ W(x) at x = e^{−jωT} (q⁻¹) for each ω, W the n_y × `cols`
    /// matrix of `rhs(i, k, x, ωT)`.
    fn solve_at(
        &self,
        omega: &[f64],
        cols: usize,
        rhs: impl Fn(usize, usize, Complex64, f64) -> Result<Complex64>,
    ) -> Result<Vec<DMatrix<Complex64>>> {
        omega
            .iter()
            .map(|&w| {
                check_scalar("omega", w)?;
                let x = Complex64::from_polar(1.0, -w * self.ts);
                let a = DMatrix::from_fn(self.ny, self.ny, |i, j| qeval(self.a(i, j), x));
                let mut r = DMatrix::zeros(self.ny, cols);
                for i in 0..self.ny {
                    for k in 0..cols {
                        r[(i, k)] = rhs(i, k, x, w * self.ts)?;
                    }
                }
                let g = if self.has_diagonal_a() {
                    DMatrix::from_fn(self.ny, cols, |i, k| r[(i, k)] / a[(i, i)])
                } else {
                    a.lu()
                        .solve(&r)
                        .unwrap_or_else(|| r.map(|_| Complex64::new(f64::NAN, 0.0)))
                };
                if g.iter().any(|v| !v.re.is_finite() || !v.im.is_finite()) {
                    return Err(Error::Infinite {
                        what: "frequency response",
                        reason: format!(
                            "ω = {w} rad/s is a pole (a root of A, D or F on the unit circle)"
                        ),
                    });
                }
                Ok(g)
            })
            .collect()
    }

    /// G(e^{jωT}) = A⁻¹ (B/F) e^{−jωT nk} at each ω (rad/s), n_y × n_u, by
    /// evaluating the polynomials. O(len (n_y³ + r)).
    ///
    /// Errors: non-finite ω, [`Error::Infinite`] at a root of A or F on the
    /// unit circle.
    pub fn freqresp(&self, omega: &[f64]) -> Result<Vec<DMatrix<Complex64>>> {
        self.solve_at(omega, self.nu, |i, k, x, wt| {
            let delay = Complex64::from_polar(1.0, -(self.nk(i, k) as f64) * wt);
            Ok(delay * qeval(self.b(i, k), x) / qeval(self.f(i, k), x))
        })
    }

    /// H(e^{jωT}) = A⁻¹ diag(C/D) at each ω (rad/s), n_y × n_y. The noise
    /// spectrum is H Λ Hᴴ (times T for a density). O(len (n_y³ + r)).
    ///
    /// Errors: as [`PolyModel::freqresp`] (roots of A or D).
    pub fn noise_freqresp(&self, omega: &[f64]) -> Result<Vec<DMatrix<Complex64>>> {
        self.solve_at(omega, self.ny, |i, j, x, _| {
            Ok(if i == j {
                qeval(&self.c[i], x) / qeval(&self.d[i], x)
            } else {
                Complex64::new(0.0, 0.0)
            })
        })
    }
}

/// `Σ_l p[l] x^l` (Horner).
fn qeval(p: &[f64], x: Complex64) -> Complex64 {
    p.iter()
        .rev()
        .fold(Complex64::new(0.0, 0.0), |acc, &c| acc * x + c)
}

#[cfg(test)]
mod tests {
    use super::super::tests::{coupled_arx, miso_oe, siso_models};
    use super::*;
    use crate::StateSpace;

    fn input(n: usize, m: usize, seed: usize) -> DMatrix<f64> {
        DMatrix::from_fn(n, m, |t, j| {
            (((t * 7 + j * 3 + seed) % 11) as f64 - 5.0) / 5.0 + 0.3 * ((t as f64) * 0.37).sin()
        })
    }

    fn all_models() -> Vec<PolyModel> {
        let mut v = siso_models();
        v.extend([coupled_arx(), miso_oe()]);
        v
    }

    #[test]
    fn simulation_is_the_state_space_simulation() {
        for m in all_models() {
            let u = input(300, m.n_inputs(), 1);
            let e = input(300, m.n_outputs(), 5) * 0.1;
            let y = m.simulate(&u, None).unwrap();
            let y_ss = m.to_ss().unwrap().lsim(&u, None, None).unwrap().y;
            assert!((&y - &y_ss).abs().max() < 1e-10, "{:?}", m.family());
            // With noise: the innovations form driven by [u e].
            let y = m.simulate(&u, Some(&e)).unwrap();
            let (ss, k) = m.to_innovations_ss().unwrap();
            let (nu, ny) = (m.n_inputs(), m.n_outputs());
            let mut bk = DMatrix::zeros(ss.order(), nu + ny);
            bk.columns_mut(0, nu).copy_from(ss.b());
            bk.columns_mut(nu, ny).copy_from(&k);
            let mut dk = DMatrix::zeros(ny, nu + ny);
            dk.columns_mut(0, nu).copy_from(ss.d());
            dk.columns_mut(nu, ny).fill_with_identity();
            let full =
                StateSpace::new(ss.a().clone(), bk, ss.c().clone(), dk, Some(m.ts())).unwrap();
            let mut ue = DMatrix::zeros(300, nu + ny);
            ue.columns_mut(0, nu).copy_from(&u);
            ue.columns_mut(nu, ny).copy_from(&e);
            let y_ss = full.lsim(&ue, None, None).unwrap().y;
            assert!((&y - &y_ss).abs().max() < 1e-10, "{:?}", m.family());
        }
    }

    #[test]
    fn impulse_response_of_arx() {
        // y(t) = 0.5 y(t−1) + u(t−2): impulse → 0, 0, 1, 0.5, 0.25
        let m = PolyModel::arx(&[1.0, -0.5], &[1.0], 2, 1.0).unwrap();
        let mut u = DMatrix::zeros(5, 1);
        u[(0, 0)] = 1.0;
        let y = m.simulate(&u, None).unwrap();
        assert_eq!(y.as_slice(), &[0.0, 0.0, 1.0, 0.5, 0.25]);
    }

    #[test]
    fn frequency_responses_match_state_space() {
        for m in all_models() {
            let w: Vec<f64> = (0..25).map(|i| 0.01 + i as f64 * 0.12 / m.ts()).collect();
            let g = m.freqresp(&w).unwrap();
            let g_ss = m.to_ss().unwrap().freqresp(&w).unwrap();
            let (ss, k) = m.to_innovations_ss().unwrap();
            let ny = m.n_outputs();
            let hss = StateSpace::new(
                ss.a().clone(),
                k,
                ss.c().clone(),
                DMatrix::identity(ny, ny),
                Some(m.ts()),
            )
            .unwrap();
            let h = m.noise_freqresp(&w).unwrap();
            let h_ss = hss.freqresp(&w).unwrap();
            for t in 0..w.len() {
                assert!((&g[t] - &g_ss[t]).map(Complex64::norm).max() < 1e-10);
                assert!((&h[t] - &h_ss[t]).map(Complex64::norm).max() < 1e-10);
            }
        }
    }

    #[test]
    fn rejects_bad_signals() {
        let m = coupled_arx();
        assert!(m.simulate(&DMatrix::zeros(10, 2), None).is_err());
        let mut u = DMatrix::zeros(10, 1);
        u[(3, 0)] = f64::NAN;
        assert!(m.simulate(&u, None).is_err());
        let u = DMatrix::zeros(10, 1);
        assert!(matches!(
            m.simulate(&u, Some(&DMatrix::zeros(9, 2))),
            Err(Error::DimensionMismatch { what: "e", .. })
        ));
        assert!(m.freqresp(&[f64::NAN]).is_err());
        // An integrator has a pole at ω = 0.
        let i = PolyModel::arx(&[1.0, -1.0], &[1.0], 1, 1.0).unwrap();
        assert!(matches!(i.freqresp(&[0.0]), Err(Error::Infinite { .. })));
    }
}

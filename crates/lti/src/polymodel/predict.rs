//! Prediction and stability of [`PolyModel`].

use nalgebra::DMatrix;
use num_complex::Complex64;

use super::PolyModel;
use super::simulate::{apply_a_row, column, filter};
use crate::error::{Error, Result};
use crate::la;
use crate::poly::Poly;

/// Roots in z of a polynomial in q⁻¹ (`p[0]` ≠ 0): the roots of the same
/// coefficients read in descending powers of z. O(len³).
fn q_roots(p: &[f64]) -> Result<Vec<Complex64>> {
    Poly::new(p.to_vec())?.roots()
}

fn all_inside(polys: &[&[f64]]) -> Result<bool> {
    for p in polys {
        if q_roots(p)?.iter().any(|r| r.norm() >= 1.0) {
            return Ok(false);
        }
    }
    Ok(true)
}

impl PolyModel {
    /// The prediction errors ε(t) = y(t) − ŷ(t|t−1) of [the module docs](crate::polymodel#the-predictor),
    /// ε_i = D_i/C_i [Σ_j A_ij y_j − Σ_k B_ik/F_ik u_k(t − nk_ik)], by
    /// filtering the data from zero initial conditions (N × n_y, one row
    /// per sample). For the model's own noise realisation this returns e.
    /// O(N r).
    ///
    /// Errors: u without n_u columns, y without n_y columns or not as many
    /// rows as u ([`Error::DimensionMismatch`], [`Error::Linalg`]),
    /// non-finite data (this filter has no missing-sample rule: use
    /// [`PolyModel::predict`] for records with NaN).
    pub fn prediction_errors(&self, u: &DMatrix<f64>, y: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        let uc = self.input_columns(u)?;
        la::check_cols("y", y, self.ny)?;
        la::check_finite("y", y)?;
        let len = u.nrows();
        if y.nrows() != len {
            return Err(Error::DimensionMismatch {
                what: "u, y",
                expected: format!("{len} rows"),
                got: format!("{}", y.nrows()),
            });
        }
        let s = self.input_part(&uc, len);
        let yc: Vec<Vec<f64>> = (0..self.ny).map(|i| column(y, i)).collect();
        let mut eps = DMatrix::zeros(len, self.ny);
        for (i, si) in s.iter().enumerate() {
            let r: Vec<f64> = (0..len)
                .map(|t| apply_a_row(self, i, &yc, t) - si[t])
                .collect();
            // C ε = D r
            let e = filter(&self.d[i], 0, &self.c[i], &r);
            eps.column_mut(i).copy_from_slice(&e);
        }
        Ok(eps)
    }

    /// The one-step-ahead prediction ŷ(t|t−1) = y(t) − ε(t) (Ljung 1999,
    /// eq. (4.35); see [`PolyModel::prediction_errors`]), by filtering.
    /// O(N r).
    ///
    /// Errors: those of [`PolyModel::prediction_errors`].
    pub fn predict_one_step(&self, u: &DMatrix<f64>, y: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        Ok(y - self.prediction_errors(u, y)?)
    }

    /// ŷ(t|t−k) for every instant (N × n_y) with the Kalman predictor of
    /// the innovations form [`PolyModel::to_innovations_ss`] (zero initial
    /// state, [`crate::StateSpace::predict`]): k = 1 equals
    /// [`PolyModel::predict_one_step`], k ≥ N the simulation. `y` may hold
    /// NaN at unsampled instants. O(N k n (n + n_u)).
    ///
    /// Errors: those of [`crate::StateSpace::predict`] (k = 0, shapes,
    /// non-finite u).
    pub fn predict(
        &self,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        horizon: usize,
    ) -> Result<DMatrix<f64>> {
        let (ss, k) = self.to_innovations_ss()?;
        ss.predict(&k, u, y, horizon)
    }

    /// Roots of det A(z) (in z, from the observer form of A alone).
    fn a_roots(&self) -> Result<Vec<Complex64>> {
        if self.ny == 1 {
            return q_roots(self.a(0, 0));
        }
        let autonomous = PolyModel {
            nu: 0,
            b: Vec::new(),
            f: Vec::new(),
            nk: Vec::new(),
            c: vec![vec![1.0]; self.ny],
            d: vec![vec![1.0]; self.ny],
            covariance: None,
            input_names: None,
            ..self.clone()
        };
        autonomous.to_ss()?.poles()
    }

    /// True when every root of det A(z) and of every F_ik(z) is strictly
    /// inside the unit circle (G stable). O(n³).
    ///
    /// Errors: eigenvalue failures only.
    pub fn is_stable(&self) -> Result<bool> {
        if self.a_roots()?.iter().any(|r| r.norm() >= 1.0) {
            return Ok(false);
        }
        all_inside(&self.f.iter().map(Vec::as_slice).collect::<Vec<_>>())
    }

    /// True when the roots of det A and of every D_i are inside the unit
    /// circle (H stable). O(n³).
    ///
    /// Errors: eigenvalue failures only.
    pub fn noise_is_stable(&self) -> Result<bool> {
        if self.a_roots()?.iter().any(|r| r.norm() >= 1.0) {
            return Ok(false);
        }
        all_inside(&self.d.iter().map(Vec::as_slice).collect::<Vec<_>>())
    }

    /// True when the predictor (I − H⁻¹, H⁻¹G; H⁻¹ = diag(D/C) A,
    /// H⁻¹G = diag(D/C) B/F) is stable: every root of C_i and of F_ik
    /// strictly inside the unit circle. O(r³).
    ///
    /// Errors: eigenvalue failures only.
    pub fn predictor_is_stable(&self) -> Result<bool> {
        let polys: Vec<&[f64]> = self.c.iter().chain(&self.f).map(Vec::as_slice).collect();
        all_inside(&polys)
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{coupled_arx, miso_oe, siso_models};
    use super::*;

    fn signal(n: usize, m: usize, seed: usize) -> DMatrix<f64> {
        DMatrix::from_fn(n, m, |t, j| {
            (((t * 13 + j * 5 + seed) % 17) as f64 - 8.0) / 8.0 + 0.2 * ((t as f64) * 0.21).cos()
        })
    }

    #[test]
    fn direct_predictor_equals_kalman_predictor() {
        let mut models = siso_models();
        models.extend([coupled_arx(), miso_oe()]);
        for m in models {
            let u = signal(400, m.n_inputs(), 2);
            let e = signal(400, m.n_outputs(), 7) * 0.2;
            let y = m.simulate(&u, Some(&e)).unwrap();
            let direct = m.predict_one_step(&u, &y).unwrap();
            let kalman = m.predict(&u, &y, 1).unwrap();
            let d = (&direct - &kalman).abs().max();
            assert!(d < 1e-10, "{:?}: {d}", m.family());
            // The prediction errors of the true model are the noise.
            let eps = m.prediction_errors(&u, &y).unwrap();
            assert!((&eps - &e).abs().max() < 1e-10, "{:?}", m.family());
            // A long horizon is the simulation.
            let far = m.predict(&u, &y, 10_000).unwrap();
            let sim = m.simulate(&u, None).unwrap();
            assert!((&far - &sim).abs().max() < 1e-10, "{:?}", m.family());
        }
    }

    #[test]
    fn armax_one_step_predictor_formula() {
        // ARMAX (1 + a q⁻¹) y = b q⁻¹ u + (1 + c q⁻¹) e:
        // ŷ(t) = (c − a) y(t−1) + b u(t−1) − c ŷ(t−1).
        let (a, b, c) = (-0.8, 0.5, 0.3);
        let m = PolyModel::armax(&[1.0, a], &[b], &[1.0, c], 1, 1.0).unwrap();
        let u = signal(50, 1, 0);
        let y = signal(50, 1, 3);
        let p = m.predict_one_step(&u, &y).unwrap();
        let mut prev = 0.0;
        for t in 0..50 {
            let expect = if t == 0 {
                0.0
            } else {
                (c - a) * y[(t - 1, 0)] + b * u[(t - 1, 0)] - c * prev
            };
            approx::assert_abs_diff_eq!(p[(t, 0)], expect, epsilon = 1e-12);
            prev = expect;
        }
    }

    #[test]
    fn stability_checks() {
        let models = siso_models();
        assert!(models.iter().all(|m| m.is_stable().unwrap()));
        assert!(models.iter().all(|m| m.predictor_is_stable().unwrap()));
        assert!(models.iter().all(|m| m.noise_is_stable().unwrap()));
        let unstable = PolyModel::arx(&[1.0, -1.1], &[1.0], 1, 1.0).unwrap();
        assert!(!unstable.is_stable().unwrap());
        assert!(unstable.predictor_is_stable().unwrap());
        let bad_c = PolyModel::armax(&[1.0, -0.5], &[1.0], &[1.0, 1.5], 1, 1.0).unwrap();
        assert!(bad_c.is_stable().unwrap());
        assert!(!bad_c.predictor_is_stable().unwrap());
        let bad_d = PolyModel::bj(&[1.0], &[1.0], &[1.0, -1.0], &[1.0], 1, 1.0).unwrap();
        assert!(!bad_d.noise_is_stable().unwrap());
        // Coupled A: det A = (1 − 0.9x + 0.2x²)(1 − 0.5x) − 0.2x(−0.1x + 0.05x²).
        let m = coupled_arx();
        assert!(m.is_stable().unwrap());
        let poles = m.to_ss().unwrap().poles().unwrap();
        let roots = m.a_roots().unwrap();
        let nonzero = |v: &[Complex64]| v.iter().filter(|r| r.norm() > 1e-6).count();
        assert_eq!(nonzero(&poles), nonzero(&roots));
        let mut big = m.polynomials();
        if let Some(a) = big.a.as_mut() {
            a[0][1] = vec![0.0, 5.0];
            a[1][0] = vec![0.0, 5.0];
        }
        assert!(!PolyModel::new(big, 1.0).unwrap().is_stable().unwrap());
    }

    #[test]
    fn prediction_rejects_bad_data() {
        let m = siso_models()[1].clone();
        let u = signal(20, 1, 0);
        let mut y = signal(20, 1, 1);
        assert!(m.predict_one_step(&u, &signal(19, 1, 1)).is_err());
        assert!(m.predict_one_step(&u, &signal(20, 2, 1)).is_err());
        assert!(m.predict(&u, &y, 0).is_err());
        y[(4, 0)] = f64::NAN;
        assert!(m.predict_one_step(&u, &y).is_err());
        // The Kalman predictor skips the unsampled instant.
        assert!(m.predict(&u, &y, 1).unwrap().iter().all(|v| v.is_finite()));
    }
}

//! Poles, transmission zeros, DC gain and stability tests.

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::error::{Error, Result, check_scalar};
use crate::la;
use crate::ss::StateSpace;

impl StateSpace {
    /// Poles: eigenvalues of A (O(n³)).
    pub fn poles(&self) -> Result<Vec<Complex64>> {
        la::eigenvalues(self.a())
    }

    /// Stability with a margin ≥ 0: continuous, every pole has
    /// Re λ < −margin; discrete, every pole has |λ| < 1 − margin.
    ///
    /// Errors: negative or non-finite margin.
    pub fn is_stable(&self, margin: f64) -> Result<bool> {
        Ok(self.unstable_pole(margin)?.is_none())
    }

    /// The first pole violating [`StateSpace::is_stable`] with this margin.
    pub(crate) fn unstable_pole(&self, margin: f64) -> Result<Option<Complex64>> {
        check_scalar("margin", margin)?;
        if margin < 0.0 {
            return Err(Error::InvalidArgument {
                what: "margin",
                reason: format!("must be >= 0, got {margin}"),
            });
        }
        let poles = self.poles()?;
        Ok(poles.into_iter().find(|p| match self.ts() {
            None => p.re >= -margin,
            Some(_) => p.norm() >= 1.0 - margin,
        }))
    }

    pub(crate) fn require_stable(&self, what: &'static str) -> Result<()> {
        match self.unstable_pole(0.0)? {
            None => Ok(()),
            Some(pole) => Err(Error::Unstable { what, pole }),
        }
    }

    /// DC gain: D − C A⁻¹ B (continuous) or D + C (I − A)⁻¹ B (discrete).
    ///
    /// Errors: [`Error::Infinite`] when A (resp. I − A) is singular, i.e.
    /// a pole at s = 0 (z = 1).
    pub fn dc_gain(&self) -> Result<DMatrix<f64>> {
        let n = self.order();
        let m = match self.ts() {
            None => -self.a().clone(),
            Some(_) => DMatrix::<f64>::identity(n, n) - self.a(),
        };
        let x = la::solve(&m, self.b()).map_err(|_| Error::Infinite {
            what: "DC gain",
            reason: "pole at s = 0 (continuous) or z = 1 (discrete)".into(),
        })?;
        Ok(self.d() + self.c() * x)
    }

    /// Transmission (invariant) zeros: the finite λ where the system matrix
    /// [A − λI, B; C, D] loses rank below its normal rank.
    ///
    /// Method (Emami-Naeini & Van Dooren, Automatica 18, 1982): the
    /// `reduce` step repeatedly row-compresses D by an SVD; the rows of
    /// [C D] with zero D-part constrain the states, so the states they see
    /// are eliminated by an orthogonal state transformation. This is done
    /// until D has full row rank, then again on the dual system until D has
    /// full column rank. The reduced system has a square invertible D_r
    /// (possibly 0×0) and the same finite zeros, which are then the
    /// eigenvalues of A_r − B_r D_r⁻¹ C_r (no QZ needed). Works for square
    /// and non-square systems; uncontrollable/unobservable modes that are
    /// invariant zeros are returned too. Rank decisions: singular values
    /// ≤ 1e-10·max(1, ‖[A B; C D]‖_F). O(n⁴) worst case.
    pub fn zeros(&self) -> Result<Vec<Complex64>> {
        let mut a = self.a().clone();
        let mut b = self.b().clone();
        let mut c = self.c().clone();
        let mut d = self.d().clone();
        let scale = {
            let top = crate::connect::hcat(&a, &b);
            let bot = crate::connect::hcat(&c, &d);
            crate::connect::vcat(&top, &bot).norm().max(1.0)
        };
        let tol = 1e-10 * scale;
        reduce(&mut a, &mut b, &mut c, &mut d, tol)?;
        // dual
        let (mut at, mut bt, mut ct, mut dt) =
            (a.transpose(), c.transpose(), b.transpose(), d.transpose());
        reduce(&mut at, &mut bt, &mut ct, &mut dt, tol)?;
        let (a, b, c, d) = (
            at.transpose(),
            ct.transpose(),
            bt.transpose(),
            dt.transpose(),
        );
        if a.nrows() == 0 {
            return Ok(vec![]);
        }
        if d.nrows() != d.ncols() {
            // normal rank deficiency left over: no isolated finite zeros
            return Ok(vec![]);
        }
        if d.nrows() == 0 {
            return la::eigenvalues(&a);
        }
        let x = la::solve(&d, &c)?;
        la::eigenvalues(&(&a - &b * x))
    }
}

/// One `reduce` pass of Emami-Naeini–Van Dooren: on return D has full row
/// rank and the finite zeros are unchanged.
fn reduce(
    a: &mut DMatrix<f64>,
    b: &mut DMatrix<f64>,
    c: &mut DMatrix<f64>,
    d: &mut DMatrix<f64>,
    tol: f64,
) -> Result<()> {
    loop {
        let n = a.nrows();
        let p = c.nrows();
        let m = b.ncols();
        if p == 0 {
            return Ok(());
        }
        // Row compression of D: Uᵀ D = [D1; 0], D1 ρ×m with full row rank.
        let (u_thin, s, _) = la::svd(d)?;
        let rho = s.iter().filter(|&&x| x > tol).count();
        let u = la::qr_full_q(&u_thin.columns(0, rho).into_owned())?;
        let cu = u.transpose() * &*c;
        let du = u.transpose() * &*d;
        if rho == p {
            return Ok(());
        }
        let c1 = cu.rows(0, rho).into_owned();
        let d1 = du.rows(0, rho).into_owned();
        let c2 = cu.rows(rho, p - rho).into_owned();
        if n == 0 {
            // rows [C2 0] are empty: drop them
            *c = c1;
            *d = d1;
            return Ok(());
        }
        // Column compression of C2: C2 V = [0, C̃], C̃ of full column rank μ.
        let (_, s2, v_thin) = la::svd(&c2)?;
        let mu = s2.iter().filter(|&&x| x > tol).count();
        if mu == 0 {
            // C2 ≈ 0: those rows are identically zero, drop them.
            *c = c1;
            *d = d1;
            return Ok(());
        }
        // V = [V_null, V_range] with the range of C2ᵀ last
        let vr = v_thin.columns(0, mu).into_owned();
        let qf = la::qr_full_q(&vr)?; // first mu columns span range(C2ᵀ)
        let mut v = DMatrix::<f64>::zeros(n, n);
        v.view_mut((0, 0), (n, n - mu))
            .copy_from(&qf.columns(mu, n - mu));
        v.view_mut((0, n - mu), (n, mu))
            .copy_from(&qf.columns(0, mu));
        let at = v.transpose() * &*a * &v;
        let bt = v.transpose() * &*b;
        let c1t = &c1 * &v;
        let k = n - mu;
        let a11 = at.view((0, 0), (k, k)).into_owned();
        let a21 = at.view((k, 0), (mu, k)).into_owned();
        let b1 = bt.rows(0, k).into_owned();
        let b2 = bt.rows(k, mu).into_owned();
        let c11 = c1t.columns(0, k).into_owned();
        *a = a11;
        *b = b1;
        *c = crate::connect::vcat(&a21, &c11);
        *d = crate::connect::vcat(&b2, &d1);
        debug_assert_eq!(d.ncols(), m);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stability_margins() {
        let c = StateSpace::new(
            DMatrix::from_element(1, 1, -0.5),
            DMatrix::identity(1, 1),
            DMatrix::identity(1, 1),
            DMatrix::zeros(1, 1),
            None,
        )
        .unwrap();
        assert!(c.is_stable(0.0).unwrap());
        assert!(c.is_stable(0.4).unwrap());
        assert!(!c.is_stable(0.6).unwrap());
        let d = StateSpace::new(
            DMatrix::from_element(1, 1, 0.95),
            DMatrix::identity(1, 1),
            DMatrix::identity(1, 1),
            DMatrix::zeros(1, 1),
            Some(1.0),
        )
        .unwrap();
        assert!(d.is_stable(0.01).unwrap());
        assert!(!d.is_stable(0.1).unwrap());
        assert!((d.dc_gain().unwrap()[(0, 0)] - 20.0).abs() < 1e-12);
    }

    #[test]
    fn zeros_of_biproper_siso() {
        // (s + 3)/(s + 1): A = −1, B = 1, C = 2, D = 1, zero at −3
        let s = StateSpace::new(
            DMatrix::from_element(1, 1, -1.0),
            DMatrix::identity(1, 1),
            DMatrix::from_element(1, 1, 2.0),
            DMatrix::identity(1, 1),
            None,
        )
        .unwrap();
        let z = s.zeros().unwrap();
        assert_eq!(z.len(), 1);
        assert!((z[0].re + 3.0).abs() < 1e-12);
    }
}

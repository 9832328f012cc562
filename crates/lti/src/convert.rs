//! Conversions between [`TransferFunction`] and [`StateSpace`].
//!
//! * tf → ss (SISO): controllable canonical form of the monic-normalised
//!   denominator (the scipy `tf2ss` layout); minimal exactly when num and den
//!   are coprime. MIMO: every entry is realised this way, the realisations
//!   are stacked (block-diagonal A) and reduced by [`StateSpace::minreal`].
//! * ss → tf: per entry (i, j), the SISO subsystem (A, b_j, c_i, d_ij) is
//!   first reduced to a minimal realisation, then
//!   num = det(sI − A + b c) − det(sI − A) + d·det(sI − A) and den = det(sI − A),
//!   characteristic polynomials from eigenvalues (O(n³) per entry).

use nalgebra::DMatrix;

use crate::poly::Poly;
use crate::ss::StateSpace;
use crate::tf::{SisoTf, TransferFunction};
use crate::{MinrealOptions, Result, la};

/// Controllable canonical realisation of a proper SISO entry.
fn siso_realisation(e: &SisoTf, row: usize, col: usize, ts: Option<f64>) -> Result<StateSpace> {
    if !e.is_proper() {
        return Err(crate::Error::ImproperTransferFunction {
            row,
            col,
            num_degree: e.num().degree(),
            den_degree: e.den().degree(),
        });
    }
    let e = e.normalized();
    let n = e.den().degree();
    let a_c: Vec<f64> = (1..=n).map(|k| e.den().coeffs()[k]).collect();
    // numerator padded to n+1 coefficients
    let mut b_c = vec![0.0; n + 1];
    let nc = e.num().coeffs();
    let off = n + 1 - nc.len();
    b_c[off..].copy_from_slice(nc);
    let d0 = b_c[0];
    let mut a = DMatrix::zeros(n, n);
    for j in 0..n {
        a[(0, j)] = -a_c[j];
    }
    for i in 1..n {
        a[(i, i - 1)] = 1.0;
    }
    let mut b = DMatrix::zeros(n, 1);
    if n > 0 {
        b[(0, 0)] = 1.0;
    }
    let c = DMatrix::from_fn(1, n, |_, j| b_c[j + 1] - d0 * a_c[j]);
    let d = DMatrix::from_element(1, 1, d0);
    Ok(StateSpace::from_parts(a, b, c, d, ts))
}

impl TransferFunction {
    /// State-space realisation (see the module docs). SISO: controllable
    /// canonical form (order = denominator degree). MIMO: stacked entry
    /// realisations reduced by `minreal` with default tolerance.
    ///
    /// Errors: [`crate::Error::ImproperTransferFunction`].
    pub fn to_ss(&self) -> Result<StateSpace> {
        self.check_proper()?;
        let (p, m) = (self.n_outputs(), self.n_inputs());
        if self.is_siso() {
            return siso_realisation(self.entry(0, 0), 0, 0, self.ts());
        }
        let mut parts = Vec::new();
        for i in 0..p {
            for j in 0..m {
                parts.push((i, j, siso_realisation(self.entry(i, j), i, j, self.ts())?));
            }
        }
        let n: usize = parts.iter().map(|(_, _, s)| s.order()).sum();
        let mut a = DMatrix::zeros(n, n);
        let mut b = DMatrix::zeros(n, m);
        let mut c = DMatrix::zeros(p, n);
        let mut d = DMatrix::zeros(p, m);
        let mut off = 0;
        for (i, j, s) in &parts {
            let k = s.order();
            a.view_mut((off, off), (k, k)).copy_from(s.a());
            b.view_mut((off, *j), (k, 1)).copy_from(s.b());
            c.view_mut((*i, off), (1, k)).copy_from(s.c());
            d[(*i, *j)] = s.d()[(0, 0)];
            off += k;
        }
        StateSpace::from_parts(a, b, c, d, self.ts()).minreal(&MinrealOptions::default())
    }
}

/// Characteristic polynomial det(xI − A) from the eigenvalues of A.
pub(crate) fn charpoly(a: &DMatrix<f64>) -> Result<Poly> {
    let ev = la::eigenvalues(a)?;
    let c = crate::poly::complex_from_roots(&ev);
    Ok(Poly::from_vec(c.iter().map(|z| z.re).collect()))
}

impl StateSpace {
    /// Transfer matrix; every entry is computed from a minimal realisation of
    /// its SISO subsystem (reduced with `opts`), so entries come out without
    /// common factors where the staircase can detect them. Denominators are
    /// monic; rounding residue in the leading numerator coefficients (below
    /// 1e-11 of the polynomial scale) is trimmed.
    pub fn to_tf(&self, opts: &MinrealOptions) -> Result<TransferFunction> {
        let (p, m) = (self.n_outputs(), self.n_inputs());
        let mut entries = Vec::with_capacity(p * m);
        for i in 0..p {
            for j in 0..m {
                let sub = StateSpace::from_parts(
                    self.a().clone(),
                    self.b().columns(j, 1).into_owned(),
                    self.c().rows(i, 1).into_owned(),
                    DMatrix::from_element(1, 1, self.d()[(i, j)]),
                    self.ts(),
                )
                .minreal(opts)?;
                entries.push(siso_tf_of(&sub)?);
            }
        }
        Ok(TransferFunction::from_parts(p, m, entries, self.ts()))
    }
}

/// num/den of a SISO state-space model (no reduction).
pub(crate) fn siso_tf_of(s: &StateSpace) -> Result<SisoTf> {
    let den = charpoly(s.a())?;
    let d = s.d()[(0, 0)];
    let bc = s.b() * s.c();
    let p1 = charpoly(&(s.a() - &bc))?;
    let scale = p1
        .coeffs()
        .iter()
        .chain(den.coeffs())
        .fold(0.0f64, |a, c| a.max(c.abs()))
        .max(d.abs());
    let diff = &p1 - &den;
    let num = &diff + &den.scale(d);
    // trim rounding residue in leading coefficients
    let co = num.coeffs();
    let first = co.iter().position(|c| c.abs() > 1e-11 * scale.max(1e-300));
    let num = match first {
        None => Poly::zero(),
        Some(k) => Poly::from_vec(co[k..].to_vec()),
    };
    SisoTf::new(num, den)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn canonical_form_and_back() {
        // (2s² + 3s + 1)/(s² + 0.5s + 0.25): D = 2
        let g = TransferFunction::from_coeffs(&[2.0, 3.0, 1.0], &[1.0, 0.5, 0.25], None).unwrap();
        let s = g.to_ss().unwrap();
        assert_eq!(s.d()[(0, 0)], 2.0);
        assert_eq!(s.a()[(0, 1)], -0.25);
        let back = s.to_tf(&MinrealOptions::default()).unwrap();
        assert!(back.num(0, 0).max_abs_diff(g.num(0, 0)) < 1e-14);
        assert!(back.den(0, 0).max_abs_diff(g.den(0, 0)) < 1e-14);
        // a common factor is removed by the per-entry minimal realisation
        let c = TransferFunction::from_coeffs(&[1.0, 1.0], &[1.0, 3.0, 2.0], None).unwrap();
        let t = c
            .to_ss()
            .unwrap()
            .to_tf(&MinrealOptions::default())
            .unwrap();
        assert_eq!(t.den(0, 0).degree(), 1);
    }
}

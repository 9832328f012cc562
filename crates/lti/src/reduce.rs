//! Minimal realisation (staircase) and balanced truncation.

use nalgebra::DMatrix;

use crate::error::{Error, Result};
use crate::la;
use crate::ss::StateSpace;

/// Options of [`StateSpace::minreal`] and [`crate::TransferFunction::minreal`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MinrealOptions {
    /// Relative tolerance. State space: a singular value in the staircase
    /// is treated as zero when it is ≤ `tol`·max(1, ‖[A B]‖_F) (controllability)
    /// or ≤ `tol`·max(1, ‖[A; C]‖_F) (observability). Transfer functions:
    /// roots closer than `tol`·max(1, |p|) cancel. Default √ε ≈ 1.49e-8 (as
    /// MATLAB's `minreal`).
    pub tol: f64,
}

impl Default for MinrealOptions {
    fn default() -> Self {
        Self {
            tol: f64::EPSILON.sqrt(),
        }
    }
}

/// Controllability staircase: returns orthogonal Q and the dimension nc of
/// the controllable subspace (first nc columns of Q span it). In the
/// coordinates x = Q z, (QᵀAQ, QᵀB) is in staircase form with
/// QᵀB = [B₁; 0], and the (2,1) block below the first nc states vanishes.
/// Rank decisions by SVD with absolute threshold `tol_abs`. O(n⁴) worst case
/// (n SVDs of at most n×n blocks), O(n³) typically.
fn controllable_staircase(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    tol_abs: f64,
) -> Result<(DMatrix<f64>, usize)> {
    let n = a.nrows();
    let mut q = DMatrix::<f64>::identity(n, n);
    let mut at = a.clone();
    let mut k = 0usize;
    let mut blk = b.clone(); // the block whose rows k.. must be compressed
    let mut blk_cols = (0usize, b.ncols());
    let mut first = true;
    while k < n {
        let sub = if first {
            blk.rows(k, n - k).into_owned()
        } else {
            at.view((k, blk_cols.0), (n - k, blk_cols.1)).into_owned()
        };
        if sub.ncols() == 0 {
            break;
        }
        let (u, s, _v) = la::svd(&sub)?;
        let r = s.iter().filter(|&&x| x > tol_abs).count();
        if r == 0 {
            break;
        }
        let ufull = la::qr_full_q(&u.columns(0, r).into_owned())?;
        let mut t = DMatrix::<f64>::identity(n, n);
        t.view_mut((k, k), (n - k, n - k)).copy_from(&ufull);
        at = t.transpose() * &at * &t;
        q = &q * &t;
        if first {
            blk = t.transpose() * &blk;
            first = false;
        }
        blk_cols = (k, r);
        k += r;
    }
    let _ = blk;
    Ok((q, k))
}

impl StateSpace {
    /// Keeps the controllable part (staircase with SVD rank decisions).
    pub fn controllable_part(&self, opts: &MinrealOptions) -> Result<StateSpace> {
        let n = self.order();
        if n == 0 {
            return Ok(self.clone());
        }
        let scale = crate::connect::hcat(self.a(), self.b()).norm().max(1.0);
        let (q, nc) = controllable_staircase(self.a(), self.b(), opts.tol * scale)?;
        let qc = q.columns(0, nc).into_owned();
        Ok(StateSpace::from_parts(
            qc.transpose() * self.a() * &qc,
            qc.transpose() * self.b(),
            self.c() * &qc,
            self.d().clone(),
            self.ts(),
        ))
    }

    /// Keeps the observable part (the dual staircase).
    pub fn observable_part(&self, opts: &MinrealOptions) -> Result<StateSpace> {
        let n = self.order();
        if n == 0 {
            return Ok(self.clone());
        }
        let scale = crate::connect::vcat(self.a(), self.c()).norm().max(1.0);
        let (q, no) = controllable_staircase(
            &self.a().transpose(),
            &self.c().transpose(),
            opts.tol * scale,
        )?;
        let qo = q.columns(0, no).into_owned();
        Ok(StateSpace::from_parts(
            qo.transpose() * self.a() * &qo,
            qo.transpose() * self.b(),
            self.c() * &qo,
            self.d().clone(),
            self.ts(),
        ))
    }

    /// Minimal realisation: the controllable part of the observable part,
    /// both by orthogonal staircase reductions (Varga's method) with SVD rank
    /// decisions at the relative tolerance `opts.tol`. Names are kept.
    /// O(n³)–O(n⁴).
    pub fn minreal(&self, opts: &MinrealOptions) -> Result<StateSpace> {
        if !(opts.tol.is_finite() && opts.tol >= 0.0) {
            return Err(Error::InvalidArgument {
                what: "MinrealOptions::tol",
                reason: format!("must be finite and non-negative, got {}", opts.tol),
            });
        }
        let mut r = self.controllable_part(opts)?.observable_part(opts)?;
        if let Some(n) = self.input_names() {
            r = r.with_input_names(n.to_vec())?;
        }
        if let Some(n) = self.output_names() {
            r = r.with_output_names(n.to_vec())?;
        }
        Ok(r)
    }

    /// Controllability Gramian P: A P + P Aᵀ + B Bᵀ = 0 (continuous) or
    /// A P Aᵀ − P + B Bᵀ = 0 (discrete). Requires a stable model. O(n³).
    pub fn controllability_gramian(&self) -> Result<DMatrix<f64>> {
        self.require_stable("controllability_gramian")?;
        let q = self.b() * self.b().transpose();
        if self.is_discrete() {
            la::dlyap(self.a(), &q)
        } else {
            la::lyap(self.a(), &q)
        }
    }

    /// Observability Gramian Q: Aᵀ Q + Q A + CᵀC = 0 (continuous) or
    /// Aᵀ Q A − Q + CᵀC = 0 (discrete). Requires a stable model. O(n³).
    pub fn observability_gramian(&self) -> Result<DMatrix<f64>> {
        self.require_stable("observability_gramian")?;
        let q = self.c().transpose() * self.c();
        let at = self.a().transpose();
        if self.is_discrete() {
            la::dlyap(&at, &q)
        } else {
            la::lyap(&at, &q)
        }
    }

    /// The square-root balancing transformation: Gramian factors P = L_P
    /// L_Pᵀ, Q = L_Q L_Qᵀ (from symmetric eigendecompositions, negative
    /// rounding eigenvalues clipped to 0), SVD L_Qᵀ L_P = U Σ Vᵀ; returns
    /// (T_l, T_r, σ) with T_r = L_P V Σ^{-1/2}, T_l = Σ^{-1/2} Uᵀ L_Qᵀ over
    /// the nonzero Hankel singular values σ (descending, all n of them in
    /// `hsv`), so that (T_l A T_r, T_l B, C T_r, D) is balanced and, for a
    /// minimal model, T_l = T_r⁻¹. Requires stability. O(n³).
    ///
    /// Errors: [`Error::Unstable`].
    pub fn balancing(&self) -> Result<Balancing> {
        let p = self.controllability_gramian()?;
        let q = self.observability_gramian()?;
        let lp = sym_factor(&p)?;
        let lq = sym_factor(&q)?;
        let (u, s, v) = la::svd(&(lq.transpose() * &lp))?;
        let nonzero = s
            .iter()
            .filter(|&&x| x > f64::EPSILON * s.first().copied().unwrap_or(0.0))
            .count();
        let sinv = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
            nonzero,
            s.iter().take(nonzero).map(|x| 1.0 / x.sqrt()),
        ));
        Ok(Balancing {
            right: &lp * v.columns(0, nonzero) * &sinv,
            left: &sinv * u.columns(0, nonzero).transpose() * lq.transpose(),
            hsv: s,
        })
    }

    /// Balanced truncation to `order` states by the square-root method:
    /// Gramian factors P = L_P L_Pᵀ, Q = L_Q L_Qᵀ (from symmetric
    /// eigendecompositions, negative rounding eigenvalues clipped to 0), SVD
    /// L_Qᵀ L_P = U Σ Vᵀ, T_r = L_P V_r Σ_r^{-1/2}, T_l = Σ_r^{-1/2} U_rᵀ L_Qᵀ,
    /// reduced model (T_l A T_r, T_l B, C T_r, D). Returns the model and all
    /// Hankel singular values (descending). The error bound is
    /// ‖G − G_r‖∞ ≤ 2 Σ_{i>r} σᵢ. Requires stability. O(n³).
    ///
    /// Errors: [`Error::Unstable`], `order` larger than the number of
    /// nonzero Hankel singular values ([`Error::InvalidArgument`]).
    pub fn balanced_truncation(&self, order: usize) -> Result<(StateSpace, Vec<f64>)> {
        let Balancing {
            left,
            right,
            hsv: s,
        } = self.balancing()?;
        let nonzero = right.ncols();
        if order > nonzero {
            return Err(Error::InvalidArgument {
                what: "order",
                reason: format!("{order} exceeds the {nonzero} nonzero Hankel singular values"),
            });
        }
        let tr = right.columns(0, order).into_owned();
        let tl = left.rows(0, order).into_owned();
        let red = StateSpace::from_parts(
            &tl * self.a() * &tr,
            &tl * self.b(),
            self.c() * &tr,
            self.d().clone(),
            self.ts(),
        );
        Ok((red, s))
    }
}

/// The square-root balancing transformation of [`StateSpace::balancing`].
#[derive(Debug, Clone, PartialEq)]
pub struct Balancing {
    /// T_l (r×n, r = the number of nonzero Hankel singular values).
    pub left: DMatrix<f64>,
    /// T_r (n×r).
    pub right: DMatrix<f64>,
    /// All n Hankel singular values, descending.
    pub hsv: Vec<f64>,
}

/// L with L Lᵀ = M for symmetric PSD M, from the eigendecomposition.
fn sym_factor(m: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let (vals, vecs) = la::sym_eig_desc(m)?;
    let n = vals.len();
    let mut l = vecs;
    for (j, &lam) in vals.iter().enumerate().take(n) {
        let s = lam.max(0.0).sqrt();
        l.column_mut(j).scale_mut(s);
    }
    Ok(l)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn staircase_detects_uncontrollable_mode() {
        let s = StateSpace::new(
            DMatrix::from_row_slice(2, 2, &[-1.0, 0.0, 0.0, -2.0]),
            DMatrix::from_row_slice(2, 1, &[1.0, 0.0]),
            DMatrix::from_row_slice(1, 2, &[1.0, 1.0]),
            DMatrix::zeros(1, 1),
            None,
        )
        .unwrap();
        let r = s.minreal(&MinrealOptions::default()).unwrap();
        assert_eq!(r.order(), 1);
        assert!((r.a()[(0, 0)] + 1.0).abs() < 1e-14);
        let o = s.observable_part(&MinrealOptions::default()).unwrap();
        assert_eq!(o.order(), 2);
    }
}

//! The receding-horizon move law shared by DMC and state-space MPC: the
//! dynamic matrix 𝒜, the closed-form gain K_c = (𝒜ᵀQ𝒜 + R)⁻¹𝒜ᵀQ (§8.2.1)
//! and the constrained QP solved with clarabel.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{NonnegativeConeT, SupportedConeT};
use lifted_linalg::{SortOrder, solve, sym_eig};
use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result};
use crate::options::{Constraints, MpcOptions};

/// Moves computed at one instant.
#[derive(Debug, Clone, PartialEq)]
pub struct Moves {
    /// ΔU = [Δu(t); …; Δu(t+m−1)] (length m·n_u).
    pub du: DVector<f64>,
    /// True when the QP was solved (some limit was active for the closed form).
    pub constrained: bool,
}

/// Dynamic matrix, weights, gain and constraint data of one controller.
///
/// Built once (O((h p)(m n_u)² + (m n_u)³)); each unconstrained update is a
/// matrix-vector product O(h p m n_u); a constrained update solves a dense
/// QP with m·n_u variables by clarabel's interior-point method.
#[derive(Debug, Clone)]
pub struct MoveLaw {
    hp: usize,
    hc: usize,
    p: usize,
    m: usize,
    dynamic: DMatrix<f64>,
    /// 𝒜ᵀ Q̄ (m n_u × h p).
    at_q: DMatrix<f64>,
    hessian: DMatrix<f64>,
    gain: DMatrix<f64>,
    constraints: Constraints,
}

/// Checks a symmetric weight and returns it (default identity).
fn weight(what: &'static str, w: &Option<DMatrix<f64>>, dim: usize) -> Result<DMatrix<f64>> {
    let Some(w) = w else {
        return Ok(DMatrix::identity(dim, dim));
    };
    if w.shape() != (dim, dim) {
        return Err(Error::DimensionMismatch {
            what,
            expected: dim,
            got: if w.nrows() != dim {
                w.nrows()
            } else {
                w.ncols()
            },
        });
    }
    if w.iter().any(|x| !x.is_finite()) {
        return Err(Error::NonFinite { what });
    }
    let sym = (w + w.transpose()) * 0.5;
    if (&sym - w).amax() > 1e-12 * (1.0 + w.amax()) {
        return Err(Error::InvalidArgument {
            what,
            reason: "weight must be symmetric".into(),
        });
    }
    let min = sym_eig(&sym, SortOrder::Ascending)?
        .values
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    if min < -1e-12 * (1.0 + w.amax()) {
        return Err(Error::NotPositiveDefinite {
            what,
            kind: "semi-",
            min_eigenvalue: min,
        });
    }
    Ok(sym)
}

/// [`Error::InvalidHorizon`] unless 1 ≤ m ≤ h (`hc` = m, `hp` = h).
pub(crate) fn check_horizons(hp: usize, hc: usize) -> Result<()> {
    if hp == 0 || hc == 0 || hc > hp {
        return Err(Error::InvalidHorizon {
            prediction: hp,
            control: hc,
        });
    }
    Ok(())
}

/// The memory of a receding-horizon law with horizons (h, m) for p outputs
/// and n_u inputs, checked against the memory budget before anything is
/// formed (`lifted_linalg::Error::TooLarge`, wrapped): the step
/// coefficients ((h + 1) p n_u), the dynamic matrix and its two weighted
/// copies (h p × m n_u each), the Hessian and its factor ((m n_u)² each).
pub(crate) fn check_horizon_size(hp: usize, hc: usize, p: usize, m: usize) -> Result<()> {
    use lifted_linalg::budget::{MemoryBudget, Size};
    let need = match (hp.checked_mul(p), hc.checked_mul(m)) {
        (Some(rows), Some(cols)) => Size::matrices(3, rows, cols)
            .plus(Size::matrices(2, cols, cols))
            .plus(Size::matrices(hp.saturating_add(1), p, m)),
        _ => Size::OVERFLOW,
    };
    Ok(MemoryBudget::default().check("the MPC prediction matrices (horizons)", need)?)
}

/// Block-Toeplitz dynamic matrix 𝒜 (h p × m n_u) with block (j, c) =
/// S_{j−c+1} (zero above the diagonal), from step-response coefficients
/// `steps[i] = S_i` (index 0 is S_0 = 0; needs `steps.len() > h`).
pub fn dynamic_matrix(steps: &[DMatrix<f64>], hp: usize, hc: usize) -> Result<DMatrix<f64>> {
    check_horizons(hp, hc)?;
    if steps.len() <= hp {
        return Err(Error::DimensionMismatch {
            what: "step-response coefficients (need h+1)",
            expected: hp + 1,
            got: steps.len(),
        });
    }
    let (p, m) = steps[0].shape();
    check_horizon_size(hp, hc, p, m)?;
    let mut a = DMatrix::zeros(hp * p, hc * m);
    for j in 0..hp {
        for c in 0..hc.min(j + 1) {
            a.view_mut((j * p, c * m), (p, m))
                .copy_from(&steps[j - c + 1]);
        }
    }
    Ok(a)
}

impl MoveLaw {
    /// Builds the law from step-response coefficients S_0 … S_h (S_0 = 0).
    ///
    /// Errors: [`Error::InvalidHorizon`], weight size/definiteness errors,
    /// [`Error::InvalidConstraint`], [`Error::NotPositiveDefinite`] for a
    /// singular Hessian 𝒜ᵀQ̄𝒜 + R̄.
    pub fn new(steps: &[DMatrix<f64>], opts: &MpcOptions) -> Result<Self> {
        let hp = opts.prediction_horizon;
        let hc = opts.control_horizon;
        let dynamic = dynamic_matrix(steps, hp, hc)?;
        let (p, m) = steps[0].shape();
        let q = weight("output weight Q", &opts.output_weight, p)?;
        let r = weight("move weight R", &opts.move_weight, m)?;
        check_constraints(&opts.constraints, p, m)?;
        let mut at_q = dynamic.transpose();
        for j in 0..hp {
            let blk = at_q.columns(j * p, p) * &q;
            at_q.columns_mut(j * p, p).copy_from(&blk);
        }
        let mut hessian = &at_q * &dynamic;
        for c in 0..hc {
            let mut v = hessian.view_mut((c * m, c * m), (m, m));
            v += &r;
        }
        hessian = (&hessian + hessian.transpose()) * 0.5;
        let min = sym_eig(&hessian, SortOrder::Ascending)?
            .values
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
        if min <= 1e-12 * (1.0 + hessian.amax()) {
            return Err(Error::NotPositiveDefinite {
                what: "QP Hessian AᵀQA + R",
                kind: "",
                min_eigenvalue: min,
            });
        }
        let gain = solve(&hessian, &at_q)?;
        Ok(Self {
            hp,
            hc,
            p,
            m,
            dynamic,
            at_q,
            hessian,
            gain,
            constraints: opts.constraints.clone(),
        })
    }

    /// The dynamic matrix 𝒜 (8.8 compact form, or H of (8.12)).
    pub fn dynamic_matrix(&self) -> &DMatrix<f64> {
        &self.dynamic
    }
    /// K_c = (𝒜ᵀQ̄𝒜 + R̄)⁻¹𝒜ᵀQ̄ (§8.2.1 step 1).
    pub fn gain(&self) -> &DMatrix<f64> {
        &self.gain
    }
    /// Hessian 𝒜ᵀQ̄𝒜 + R̄.
    pub fn hessian(&self) -> &DMatrix<f64> {
        &self.hessian
    }
    /// Prediction horizon h.
    pub fn prediction_horizon(&self) -> usize {
        self.hp
    }
    /// Control horizon m.
    pub fn control_horizon(&self) -> usize {
        self.hc
    }
    /// The constraints in force.
    pub fn constraints(&self) -> &Constraints {
        &self.constraints
    }

    fn check_args(
        &self,
        free: &DVector<f64>,
        reference: &DVector<f64>,
        u_prev: &DVector<f64>,
    ) -> Result<()> {
        crate::error::check_vectors(&[
            ("free response", free, self.hp * self.p),
            ("reference trajectory", reference, self.hp * self.p),
            ("previous input", u_prev, self.m),
        ])
    }

    /// One receding-horizon step: the set-point `reference` (length p) held
    /// over the horizon, moves from [`MoveLaw::moves`] (or always the QP
    /// when `force_qp`); returns the plan and the first move Δu(t).
    pub(crate) fn plan(
        &self,
        free: &DVector<f64>,
        reference: &DVector<f64>,
        u_prev: &DVector<f64>,
        force_qp: bool,
    ) -> Result<(DVector<f64>, Moves)> {
        let p = self.p;
        let rbar = DVector::from_fn(self.hp * p, |i, _| reference[i % p]);
        let moves = if force_qp {
            self.solve_qp(free, &rbar, u_prev)?
        } else {
            self.moves(free, &rbar, u_prev)?
        };
        Ok((moves.du.rows(0, self.m).into_owned(), moves))
    }

    /// Unconstrained moves ΔU = K_c (r̄ − F̂).
    pub fn unconstrained(&self, free: &DVector<f64>, reference: &DVector<f64>) -> DVector<f64> {
        &self.gain * (reference - free)
    }

    /// Optimal moves: the closed form when no limit is set or none is
    /// violated by it, otherwise the QP (which then has an active limit).
    ///
    /// Errors: size/finiteness of the arguments, [`Error::Infeasible`],
    /// [`Error::Solver`].
    pub fn moves(
        &self,
        free: &DVector<f64>,
        reference: &DVector<f64>,
        u_prev: &DVector<f64>,
    ) -> Result<Moves> {
        self.check_args(free, reference, u_prev)?;
        let du = self.unconstrained(free, reference);
        if self.constraints.is_empty() || self.satisfies(&du, free, u_prev, 1e-12) {
            return Ok(Moves {
                du,
                constrained: false,
            });
        }
        self.solve_qp(free, reference, u_prev)
    }

    /// True when ΔU respects every limit (with slack `tol`).
    pub fn satisfies(
        &self,
        du: &DVector<f64>,
        free: &DVector<f64>,
        u_prev: &DVector<f64>,
        tol: f64,
    ) -> bool {
        let (a, b) = self.inequalities(free, u_prev);
        if a.nrows() == 0 {
            return true;
        }
        let lhs = a * du;
        lhs.iter().zip(b.iter()).all(|(l, r)| *l <= *r + tol)
    }

    /// Inequalities G ΔU ≤ g of the constraints.
    fn inequalities(
        &self,
        free: &DVector<f64>,
        u_prev: &DVector<f64>,
    ) -> (DMatrix<f64>, DVector<f64>) {
        let (hp, hc, p, m) = (self.hp, self.hc, self.p, self.m);
        let nv = hc * m;
        let c = &self.constraints;
        let mut rows: Vec<DVector<f64>> = Vec::new();
        let mut rhs: Vec<f64> = Vec::new();
        // u(t+i) = u_prev + Σ_{j≤i} Δu(t+j)
        let mut push = |row: DVector<f64>, b: f64| {
            rows.push(row);
            rhs.push(b);
        };
        for i in 0..hc {
            for ch in 0..m {
                let mut row = DVector::zeros(nv);
                for j in 0..=i {
                    row[j * m + ch] = 1.0;
                }
                if let Some(umax) = &c.u_max {
                    push(row.clone(), umax[ch] - u_prev[ch]);
                }
                if let Some(umin) = &c.u_min {
                    push(-row.clone(), u_prev[ch] - umin[ch]);
                }
                if let Some(dmax) = &c.du_max {
                    let mut e = DVector::zeros(nv);
                    e[i * m + ch] = 1.0;
                    push(e.clone(), dmax[ch]);
                    push(-e, dmax[ch]);
                }
            }
        }
        if c.y_max.is_some() || c.y_min.is_some() {
            for j in 0..hp {
                for o in 0..p {
                    let row = self.dynamic.row(j * p + o).transpose();
                    if let Some(ymax) = &c.y_max {
                        push(row.clone(), ymax[o] - free[j * p + o]);
                    }
                    if let Some(ymin) = &c.y_min {
                        push(-row, free[j * p + o] - ymin[o]);
                    }
                }
            }
        }
        let mut a = DMatrix::zeros(rows.len(), nv);
        for (i, r) in rows.iter().enumerate() {
            a.row_mut(i).copy_from(&r.transpose());
        }
        (a, DVector::from_vec(rhs))
    }

    /// Solves min (r̄ − F̂ − 𝒜ΔU)ᵀQ̄(·) + ΔUᵀR̄ΔU subject to the limits with
    /// clarabel (P = 𝒜ᵀQ̄𝒜 + R̄, upper triangle; q = −𝒜ᵀQ̄(r̄ − F̂)), even
    /// when the closed form would be feasible.
    ///
    /// Errors: [`Error::Infeasible`] on a primal-infeasibility certificate,
    /// [`Error::Solver`] on any other non-solved status.
    pub fn solve_qp(
        &self,
        free: &DVector<f64>,
        reference: &DVector<f64>,
        u_prev: &DVector<f64>,
    ) -> Result<Moves> {
        self.check_args(free, reference, u_prev)?;
        let nv = self.hc * self.m;
        let (g, h) = self.inequalities(free, u_prev);
        let (mut pi, mut pj, mut pv) = (Vec::new(), Vec::new(), Vec::new());
        for j in 0..nv {
            for i in 0..=j {
                let v = self.hessian[(i, j)];
                if v != 0.0 {
                    pi.push(i);
                    pj.push(j);
                    pv.push(v);
                }
            }
        }
        let pmat = CscMatrix::new_from_triplets(nv, nv, pi, pj, pv);
        let q: Vec<f64> = (-(&self.at_q * (reference - free)))
            .iter()
            .copied()
            .collect();
        let (mut ai, mut aj, mut av) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..g.nrows() {
            for j in 0..nv {
                let v = g[(i, j)];
                if v != 0.0 {
                    ai.push(i);
                    aj.push(j);
                    av.push(v);
                }
            }
        }
        let amat = CscMatrix::new_from_triplets(g.nrows(), nv, ai, aj, av);
        let b: Vec<f64> = h.iter().copied().collect();
        let cones: Vec<SupportedConeT<f64>> = if g.nrows() > 0 {
            vec![NonnegativeConeT(g.nrows())]
        } else {
            Vec::new()
        };
        let du = crate::conic::solve_conic(&pmat, &q, &amat, &b, &cones, 1e-10)?;
        Ok(Moves {
            du: DVector::from_vec(du),
            constrained: true,
        })
    }
}

fn check_constraints(c: &Constraints, p: usize, m: usize) -> Result<()> {
    for (what, v, n) in [
        ("u_min", &c.u_min, m),
        ("u_max", &c.u_max, m),
        ("du_max", &c.du_max, m),
        ("y_min", &c.y_min, p),
        ("y_max", &c.y_max, p),
    ] {
        if let Some(v) = v {
            if v.len() != n {
                return Err(Error::DimensionMismatch {
                    what,
                    expected: n,
                    got: v.len(),
                });
            }
            if v.iter().any(|x| x.is_nan()) {
                return Err(Error::NonFinite { what });
            }
        }
    }
    let order = |lo: &Option<DVector<f64>>, hi: &Option<DVector<f64>>, what| {
        if let (Some(lo), Some(hi)) = (lo, hi)
            && let Some(i) = (0..lo.len()).find(|&i| lo[i] > hi[i])
        {
            return Err(Error::InvalidConstraint {
                what,
                reason: format!(
                    "lower limit {} exceeds upper limit {} in channel {i}",
                    lo[i], hi[i]
                ),
            });
        }
        Ok(())
    };
    order(&c.u_min, &c.u_max, "input limits")?;
    order(&c.y_min, &c.y_max, "output limits")?;
    if let Some(d) = &c.du_max
        && let Some(i) = (0..d.len()).find(|&i| d[i] < 0.0)
    {
        return Err(Error::InvalidConstraint {
            what: "du_max",
            reason: format!("rate limit {} < 0 in channel {i}", d[i]),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::dmatrix;

    fn steps() -> Vec<DMatrix<f64>> {
        (0..=6).map(|i| dmatrix![i as f64]).collect()
    }

    #[test]
    fn horizons_beyond_memory_are_too_large() {
        assert!(check_horizon_size(12, 3, 2, 2).is_ok());
        for (hp, hc) in [(10_000_000, 1_000_000), (usize::MAX, 1)] {
            let e = check_horizon_size(hp, hc, 2, 2).unwrap_err();
            assert!(
                matches!(e, Error::Linalg(lifted_linalg::Error::TooLarge { .. })),
                "{e}"
            );
        }
    }

    #[test]
    fn dynamic_matrix_is_lower_toeplitz() {
        let a = dynamic_matrix(&steps(), 4, 2).unwrap();
        assert_eq!(a, dmatrix![1.0, 0.0; 2.0, 1.0; 3.0, 2.0; 4.0, 3.0]);
        assert!(matches!(
            dynamic_matrix(&steps(), 7, 2),
            Err(Error::DimensionMismatch { .. })
        ));
    }

    #[test]
    fn gain_solves_normal_equations() {
        let law = MoveLaw::new(
            &steps(),
            &MpcOptions {
                prediction_horizon: 4,
                control_horizon: 2,
                ..Default::default()
            },
        )
        .unwrap();
        let a = law.dynamic_matrix();
        let lhs = (a.transpose() * a + DMatrix::identity(2, 2)) * law.gain();
        assert!((lhs - a.transpose()).amax() < 1e-12);
    }

    #[test]
    fn asymmetric_weight_rejected() {
        let o = MpcOptions {
            output_weight: Some(dmatrix![1.0, 2.0; 0.0, 1.0]),
            ..Default::default()
        };
        let s: Vec<DMatrix<f64>> = (0..=12)
            .map(|i| DMatrix::from_element(2, 1, i as f64))
            .collect();
        assert!(matches!(
            MoveLaw::new(&s, &o),
            Err(Error::InvalidArgument { .. })
        ));
    }
}

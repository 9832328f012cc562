//! Kernel-regularised least squares with the prior's hyperparameters by
//! the marginal likelihood: the machinery shared by the regularised FIR
//! ([`crate::impulseest`]) and the regularised ARX ([`crate::arx_regul`])
//! (Pillonetto & De Nicolao 2010; Chen, Ohlsson & Ljung 2012, "On the
//! estimation of transfer functions, regularizations and Gaussian
//! processes — revisited", Automatica 48, 1525–1535).
//!
//! One output: y = Φ θ + e, e ~ N(0, σ²), θ ~ N(0, P(η)) with P
//! block-diagonal over the regressor blocks (one block per input's
//! coefficients; for ARX also one per output's past values), each block a
//! kernel of its *group*'s hyperparameters (FIR: one group; ARX: the A
//! blocks one group, the B blocks another):
//!
//! * TC (tuned/correlated): P_ij = c λ^{max(i, j)}, η = (c, λ);
//! * DC (diagonal/correlated): P_ij = c ρ^{|i−j|} λ^{(i+j)/2}, η = (c, λ, ρ)
//!   (TC is DC with ρ = √λ).
//!
//! η minimises −2 log p(Y | η) = Yᵀ Σ⁻¹ Y + log det Σ, Σ = Φ P Φᵀ + σ² I,
//! evaluated without an N × N matrix (Chen & Ljung 2013, "Implementation
//! of algorithms for tuning parameters in regularized least squares
//! problems in system identification", Automatica 49, 2213–2220): with
//! [Φ Y] = Q [R₁ r; 0 ρ₀] (the compressed lagged data, one pass),
//! P = L Lᵀ and the QR [Lᵀ R₁ᵀ; σ I] = Q' S,
//!
//!   Yᵀ Σ⁻¹ Y = ‖S⁻ᵀ r‖² + ρ₀²/σ²,  log det Σ = 2 Σ log |S_ii| + (N − p) log σ²,
//!
//! O(p³) per evaluation whatever N. σ² is the noise variance of the
//! unregularised least squares of the same regressors (its residual over
//! N − p). The estimate is θ̂ = L z, z = argmin ‖R₁ L z − r‖² + σ² ‖z‖² (a
//! QR, no P⁻¹), with the posterior covariance σ² L (LᵀR₁ᵀR₁L + σ² I)⁻¹ Lᵀ.
//!
//! **Search.** One group: λ on a grid of 40 points in (0.5, 0.999)
//! (logit-spaced) with c by golden section on log c at each, then λ
//! refined within a grid step; DC then adjusts ρ, λ, c by coordinate
//! golden sections from the TC optimum. Several groups: the same grid
//! with one λ for every group and each group's c by golden section in
//! turn, then two rounds of coordinate searches of each group's λ (within
//! two grid steps of its current value, its c by golden section at each)
//! — the shared-λ optimum is a point of the search, so the groups' own
//! hyperparameters never give a lower likelihood than one set for all;
//! DC as for one group, group by group; each one-dimensional search of
//! several groups by Brent's method (parabolic interpolation, golden
//! steps where it is not trusted). About 2 500 evaluations for one group
//! (golden sections) and 1 350–1 650 for two (7 000 with golden sections
//! of the same width: the glass furnace record's ARX [20 20 1] with
//! p = 180 per output took 169 s before, 38 s after, the hyperparameters
//! the same to 1e-6 relative).
//!
//! **Cost.** One evaluation: the prior's blocks' Cholesky factors
//! (Σ len³/3), Lᵀ R₁ᵀ block row by block row (2 Σ len² (at + len), R₁
//! upper triangular) and the QR of the 2p × p stack (≈ 10p³/3): O(p³)
//! per evaluation, independent of N.

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// The prior's kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Kernel {
    /// Tuned/correlated, P_ij = c λ^{max(i, j)} (default).
    #[default]
    Tc,
    /// Diagonal/correlated, P_ij = c ρ^{|i−j|} λ^{(i+j)/2}.
    Dc,
}

/// A block of regressors sharing one kernel: its length and the group
/// whose hyperparameters it takes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Block {
    pub len: usize,
    pub group: usize,
}

/// One output's regularised least-squares problem: R₁ (p × p), r (p),
/// ρ₀², N, σ² and the prior's blocks.
pub(crate) struct Problem {
    r1: DMatrix<f64>,
    r: DVector<f64>,
    rho2: f64,
    n: f64,
    sigma2: f64,
    blocks: Vec<Block>,
    groups: usize,
}

/// The tuned hyperparameters (c, λ, ρ) per group, the objective there,
/// the estimate, its posterior covariance and σ².
pub(crate) struct Solution {
    pub hypers: Vec<[f64; 3]>,
    pub objective: f64,
    pub theta: DVector<f64>,
    pub cov: DMatrix<f64>,
    pub sigma2: f64,
}

/// The prior covariance of one block's n coefficients,
/// c ρ^{|i−j|} (√λ)^{i+j} for i, j = 1..n, from tables of powers (3n
/// `powi` instead of n² `powf`: the kernel was a quarter of the search).
fn kernel(n: usize, h: [f64; 3]) -> DMatrix<f64> {
    let [c, lambda, rho] = h;
    let root = lambda.sqrt();
    let rho_pow: Vec<f64> = (0..n).map(|k| rho.powi(k as i32)).collect();
    let root_pow: Vec<f64> = (0..=2 * n).map(|k| root.powi(k as i32)).collect();
    DMatrix::from_fn(n, n, |i, j| {
        c * rho_pow[i.abs_diff(j)] * root_pow[i + j + 2]
    })
}

/// Golden-section minimum of `f` on [a, b] in `steps` steps (the bracket
/// shrinks by 0.618 a step: 60 steps 3·10⁻¹³, 30 steps 5·10⁻⁷).
fn golden(mut a: f64, mut b: f64, steps: usize, mut f: impl FnMut(f64) -> f64) -> f64 {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (b - g * (b - a), a + g * (b - a));
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..steps {
        if f1 <= f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - g * (b - a);
            f1 = f(x1);
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + g * (b - a);
            f2 = f(x2);
        }
    }
    0.5 * (a + b)
}

/// Brent's minimum of `f` on [a, b] (Brent 1973, "Algorithms for
/// minimization without derivatives", ch. 5: parabolic interpolation
/// through the three best points, a golden-section step where the
/// parabola is not trusted), to within `tol` in x: the point and its
/// value. A smooth unimodal objective takes 10–15 evaluations where a
/// golden section to the same width takes 30; a value of +∞ only ever
/// makes a golden step.
fn brent(mut a: f64, mut b: f64, tol: f64, mut f: impl FnMut(f64) -> f64) -> (f64, f64) {
    const GOLD: f64 = 0.381_966_011_250_105_1;
    const MAX_EVALUATIONS: usize = 100;
    let mut x = a + GOLD * (b - a);
    let (mut w, mut v) = (x, x);
    let mut fx = f(x);
    let (mut fw, mut fv) = (fx, fx);
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 0..MAX_EVALUATIONS {
        let m = 0.5 * (a + b);
        let tol1 = 1e-10 * x.abs() + tol;
        let t2 = 2.0 * tol1;
        if (x - m).abs() <= t2 - 0.5 * (b - a) {
            break;
        }
        let mut parabolic = false;
        if e.abs() > tol1 {
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            } else {
                q = -q;
            }
            let last = e;
            e = d;
            if p.abs() < (0.5 * q * last).abs() && p > q * (a - x) && p < q * (b - x) {
                d = p / q;
                let u = x + d;
                if u - a < t2 || b - u < t2 {
                    d = if x < m { tol1 } else { -tol1 };
                }
                parabolic = true;
            }
        }
        if !parabolic {
            e = if x < m { b - x } else { a - x };
            d = GOLD * e;
        }
        let u = x + if d.abs() >= tol1 { d } else { tol1.copysign(d) };
        let fu = f(u);
        if fu <= fx {
            if u < x {
                b = x;
            } else {
                a = x;
            }
            (v, fv, w, fw, x, fx) = (w, fw, x, fx, u, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, fv, w, fw) = (w, fw, u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    (x, fx)
}

fn logistic(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

fn logit(p: f64) -> f64 {
    (p / (1.0 - p)).ln()
}

/// λ's search interval in logit coordinates: (0.5, 0.999).
const LAMBDA_LO: f64 = 0.0;
/// ln 999 = logit(0.999).
fn lambda_hi() -> f64 {
    999f64.ln()
}
/// Points of the λ grid.
const GRID: usize = 40;

impl Problem {
    /// The problem of the R factor `r` ((p + 1) × (p + 1), upper
    /// triangular, RᵀR = [Φ y]ᵀ[Φ y]) over `rows` regression rows, with
    /// the prior's `blocks` (lengths summing to p, groups numbered from 0).
    pub(crate) fn new(r: &DMatrix<f64>, rows: usize, blocks: Vec<Block>) -> Self {
        let p = r.nrows() - 1;
        let rho2 = r[(p, p)].powi(2);
        let n = rows as f64;
        Problem {
            r1: r.view((0, 0), (p, p)).into_owned(),
            r: r.view((0, p), (p, 1)).column(0).into_owned(),
            rho2,
            n,
            sigma2: (rho2 / (n - p as f64)).max(f64::MIN_POSITIVE),
            groups: blocks.iter().map(|b| b.group + 1).max().unwrap_or(1),
            blocks,
        }
    }

    /// The Cholesky factors of the block-diagonal prior's blocks, in block
    /// order (a relative jitter of 1e-10 per block keeps the fast-decaying
    /// tail positive): Σ_b len_b³/3 flops, not p³/3.
    fn prior_blocks(&self, h: &[[f64; 3]]) -> Option<Vec<DMatrix<f64>>> {
        self.blocks
            .iter()
            .map(|b| {
                let mut k = kernel(b.len, h[b.group]);
                let jitter = 1e-10 * k[(0, 0)].abs().max(f64::MIN_POSITIVE);
                for i in 0..b.len {
                    k[(i, i)] += jitter;
                }
                k.cholesky().map(|c| c.l())
            })
            .collect()
    }

    /// The prior's Cholesky factor L (block diagonal) as one p × p matrix.
    fn prior_factor(&self, h: &[[f64; 3]]) -> Option<DMatrix<f64>> {
        let p = self.r1.nrows();
        let mut full = DMatrix::zeros(p, p);
        let mut at = 0;
        for l in self.prior_blocks(h)? {
            let len = l.nrows();
            full.view_mut((at, at), (len, len)).copy_from(&l);
            at += len;
        }
        Some(full)
    }

    /// S of the QR of [Lᵀ R₁ᵀ; σ I]. Lᵀ R₁ᵀ is formed block row by block
    /// row: block b's rows are L_bᵀ (R₁'s columns of block b)ᵀ, and those
    /// columns of the upper-triangular R₁ vanish below the block's last
    /// row — 2 Σ_b len_b² (at_b + len_b) flops instead of 2p³ (the QR,
    /// ≈ 10p³/3, is the rest of an evaluation).
    fn s_factor(&self, l: &[DMatrix<f64>]) -> Result<DMatrix<f64>> {
        let p = self.r1.nrows();
        let mut m = DMatrix::zeros(2 * p, p);
        let mut at = 0;
        for lb in l {
            let len = lb.nrows();
            let cols = self.r1.view((0, at), (at + len, len));
            m.view_mut((at, 0), (len, at + len))
                .copy_from(&(lb.transpose() * cols.transpose()));
            at += len;
        }
        let s = self.sigma2.sqrt();
        for i in 0..p {
            m[(p + i, i)] = s;
        }
        Ok(lifted_linalg::qr_r(&m)?)
    }

    /// −2 log p(Y | η) (module docs); +∞ where the prior is not positive.
    pub(crate) fn objective(&self, h: &[[f64; 3]]) -> f64 {
        let Some(l) = self.prior_blocks(h) else {
            return f64::INFINITY;
        };
        let Ok(s) = self.s_factor(&l) else {
            return f64::INFINITY;
        };
        let p = self.r1.nrows();
        let Some(w) = s.transpose().solve_lower_triangular(&self.r) else {
            return f64::INFINITY;
        };
        let logdet: f64 = (0..p).map(|i| s[(i, i)].abs().ln()).sum::<f64>() * 2.0;
        w.norm_squared() + self.rho2 / self.sigma2 + logdet + (self.n - p as f64) * self.sigma2.ln()
    }

    /// Each group's scale of c: the mean square of its unregularised
    /// least-squares coefficients.
    fn scales(&self) -> Vec<f64> {
        let p = self.r1.nrows();
        let ls = self
            .r1
            .clone()
            .solve_upper_triangular(&self.r)
            .unwrap_or_else(|| DVector::zeros(p));
        let mut sums = vec![(0.0, 0usize); self.groups];
        let mut at = 0;
        for b in &self.blocks {
            let s = &mut sums[b.group];
            s.0 += ls.rows(at, b.len).norm_squared();
            s.1 += b.len;
            at += b.len;
        }
        sums.iter()
            .map(|&(s, n)| (s / n.max(1) as f64).max(1e-12))
            .collect()
    }

    /// The hyperparameters of the module docs' search and the objective
    /// there.
    fn tune(&self, kernel: Kernel) -> (Vec<[f64; 3]>, f64) {
        if self.groups == 1 {
            self.tune_one(kernel)
        } else {
            self.tune_groups(kernel)
        }
    }

    /// One group (the regularised FIR's search, unchanged).
    fn tune_one(&self, kernel: Kernel) -> (Vec<[f64; 3]>, f64) {
        let c0 = self.scales()[0];
        let obj = |h: [f64; 3]| self.objective(&[h]);
        let best_c = |lambda: f64, rho: f64| -> (f64, f64) {
            let lc = golden((c0 * 1e-4).ln(), (c0 * 1e4).ln(), 60, |x| {
                obj([x.exp(), lambda, rho])
            });
            let c = lc.exp();
            (c, obj([c, lambda, rho]))
        };
        let (lo, hi) = (LAMBDA_LO, lambda_hi());
        let mut best = (f64::INFINITY, [c0, 0.9, 0.9f64.sqrt()]);
        for g in 0..GRID {
            let lambda = logistic(lo + (hi - lo) * g as f64 / (GRID - 1) as f64);
            let (c, v) = best_c(lambda, lambda.sqrt());
            if v < best.0 {
                best = (v, [c, lambda, lambda.sqrt()]);
            }
        }
        // Refine λ around the grid's best (one grid step either side).
        let step = (hi - lo) / (GRID - 1) as f64;
        let x0 = logit(best.1[1]);
        let xl = golden(x0 - step, x0 + step, 60, |x| {
            let l = logistic(x);
            best_c(l, l.sqrt()).1
        });
        let lambda = logistic(xl);
        let (c, v) = best_c(lambda, lambda.sqrt());
        if v < best.0 {
            best = (v, [c, lambda, lambda.sqrt()]);
        }
        if kernel == Kernel::Dc {
            for _ in 0..3 {
                let [c, lambda, _] = best.1;
                let rho = golden(-0.99, 0.99, 60, |r| obj([c, lambda, r]));
                let xl = golden(lo, hi, 60, |x| obj([c, logistic(x), rho]));
                let (c, v) = best_c(logistic(xl), rho);
                if v < best.0 {
                    best = (v, [c, logistic(xl), rho]);
                }
            }
        }
        (vec![best.1], best.0)
    }

    /// Several groups (module docs): each one-dimensional search by
    /// Brent's method ([`brent`]).
    fn tune_groups(&self, kernel: Kernel) -> (Vec<[f64; 3]>, f64) {
        // Tolerances in the searched coordinates (ln c, logit λ, ρ): a
        // golden section of 30 steps, the search's before, ended within
        // 1e-5 of ln c's optimum and 4e-7 of logit λ's.
        const C_TOL: f64 = 1e-5;
        const LAMBDA_TOL: f64 = 1e-6;
        const RHO_TOL: f64 = 1e-6;
        let scales = self.scales();
        // Group g's c by Brent's method with the others held: the
        // objective there.
        let best_c = |h: &mut Vec<[f64; 3]>, g: usize| -> f64 {
            let c0 = scales[g];
            let mut trial = h.clone();
            let (lc, v) = brent((c0 * 1e-4).ln(), (c0 * 1e4).ln(), C_TOL, |x| {
                trial[g][0] = x.exp();
                self.objective(&trial)
            });
            h[g][0] = lc.exp();
            v
        };
        let (lo, hi) = (LAMBDA_LO, lambda_hi());
        let tc = |lambda: f64, c: f64| [c, lambda, lambda.sqrt()];
        let mut best: (f64, Vec<[f64; 3]>) =
            (f64::INFINITY, scales.iter().map(|&c| tc(0.9, c)).collect());
        for i in 0..GRID {
            let lambda = logistic(lo + (hi - lo) * i as f64 / (GRID - 1) as f64);
            let mut h: Vec<[f64; 3]> = scales.iter().map(|&c| tc(lambda, c)).collect();
            let mut v = f64::INFINITY;
            for g in 0..self.groups {
                v = best_c(&mut h, g);
            }
            if v < best.0 {
                best = (v, h);
            }
        }
        let step = (hi - lo) / (GRID - 1) as f64;
        for _ in 0..2 {
            for g in 0..self.groups {
                let x0 = logit(best.1[g][1]);
                let (a, b) = ((x0 - 2.0 * step).max(lo), (x0 + 2.0 * step).min(hi));
                // The point Brent's method returns is the one of lowest
                // value it evaluated (the later one on ties): kept as it
                // is evaluated, by the same rule, rather than searched
                // again.
                let mut lowest: Option<(f64, Vec<[f64; 3]>)> = None;
                brent(a, b, LAMBDA_TOL, |x| {
                    let mut h = best.1.clone();
                    h[g] = tc(logistic(x), h[g][0]);
                    let v = best_c(&mut h, g);
                    if lowest.as_ref().is_none_or(|(l, _)| v <= *l) {
                        lowest = Some((v, h));
                    }
                    v
                });
                if let Some((v, h)) = lowest
                    && v < best.0
                {
                    best = (v, h);
                }
            }
        }
        if kernel == Kernel::Dc {
            for _ in 0..3 {
                for g in 0..self.groups {
                    let mut h = best.1.clone();
                    let (rho, _) = brent(-0.99, 0.99, RHO_TOL, |r| {
                        let mut t = h.clone();
                        t[g][2] = r;
                        self.objective(&t)
                    });
                    h[g][2] = rho;
                    let (xl, _) = brent(lo, hi, LAMBDA_TOL, |x| {
                        let mut t = h.clone();
                        t[g][1] = logistic(x);
                        self.objective(&t)
                    });
                    h[g][1] = logistic(xl);
                    let v = best_c(&mut h, g);
                    if v < best.0 {
                        best = (v, h);
                    }
                }
            }
        }
        (best.1, best.0)
    }

    /// Tunes the hyperparameters and solves (module docs). `what` names
    /// the estimate in errors.
    ///
    /// Errors: [`Error::InvalidOption`] when the prior at the optimum is
    /// not positive definite; [`Error::RankDeficient`] when the
    /// regularised system is singular.
    pub(crate) fn solve(&self, kernel: Kernel, what: &'static str) -> Result<Solution> {
        let (hypers, objective) = self.tune(kernel);
        let p = self.r1.nrows();
        let l = self.prior_factor(&hypers).ok_or(Error::InvalidOption {
            what: "kernel",
            reason: "the prior at the optimum is not positive definite".into(),
        })?;
        // θ̂ = L z, z = argmin ‖R₁ L z − r‖² + σ²‖z‖²; covariance
        // σ² L (AᵀA + σ² I)⁻¹ Lᵀ with A = R₁ L.
        let a = &self.r1 * &l;
        let mut stacked = DMatrix::zeros(2 * p, p + 1);
        stacked.view_mut((0, 0), (p, p)).copy_from(&a);
        stacked.view_mut((0, p), (p, 1)).copy_from(&self.r);
        for j in 0..p {
            stacked[(p + j, j)] = self.sigma2.sqrt();
        }
        let q = lifted_linalg::qr_r(&stacked)?;
        let t = q.view((0, 0), (p, p)).into_owned();
        let singular = Error::RankDeficient {
            what,
            rank: 0,
            needed: p,
        };
        let z = t
            .clone()
            .solve_upper_triangular(&q.view((0, p), (p, 1)).into_owned())
            .ok_or_else(|| singular.clone())?;
        let theta = &l * z.column(0);
        let tinv = t
            .solve_upper_triangular(&DMatrix::identity(p, p))
            .ok_or(singular)?;
        let lt = &l * tinv;
        let cov = &lt * lt.transpose() * self.sigma2;
        Ok(Solution {
            hypers,
            objective,
            theta,
            cov: (&cov + cov.transpose()) * 0.5,
            sigma2: self.sigma2,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arx::lagged::Lagged;
    use lifted_lti::PolyModel;
    use lifted_subspace::{Compression, Experiment};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    fn gauss(seed: u64, n: usize, sd: f64) -> DMatrix<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        DMatrix::from_fn(n, 1, |_, _| {
            let v: f64 = StandardNormal.sample(&mut rng);
            sd * v
        })
    }

    #[test]
    fn brents_method_finds_the_minimum_in_fewer_evaluations_than_a_golden_section() {
        // A smooth, asymmetric objective with its minimum at x* = ln 3
        // (f(x) = eˣ − 3x), a bracket of 8 decades.
        let star = 3f64.ln();
        let mut calls = 0;
        let (x, fx) = brent(-9.0, 9.0, 1e-5, |x| {
            calls += 1;
            x.exp() - 3.0 * x
        });
        assert!((x - star).abs() < 2e-5, "{x} against {star}");
        assert!((fx - (3.0 - 3.0 * star)).abs() < 1e-9, "{fx}");
        // A golden section to the same width takes ⌈ln(18/1e-5)/ln(1/0.618)⌉
        // = 30 steps.
        assert!(calls < 20, "{calls} evaluations");
        // +∞ on part of the bracket (a prior that is not positive there):
        // only golden steps from such points, the finite minimum found.
        let (x, _) = brent(-1.0, 4.0, 1e-6, |x| {
            if x < 0.5 {
                f64::INFINITY
            } else {
                (x - 2.0).powi(2)
            }
        });
        assert!((x - 2.0).abs() < 1e-5, "{x}");
        // A minimum at the bracket's end is approached to within tol.
        let (x, _) = brent(0.0, 1.0, 1e-6, |x| x);
        assert!(x < 1e-5, "{x}");
    }

    #[test]
    fn the_marginal_likelihood_objective_equals_its_definition() {
        // Small case, two groups (an output lag and input lags, as ARX):
        // Σ formed explicitly (N × N) against the QR form.
        let truth = PolyModel::oe(&[0.3], &[1.0, -1.6, 0.7], 1, 1.0).unwrap();
        let u = gauss(1, 60, 1.0);
        let y = truth.simulate(&u, Some(&gauss(2, 60, 0.1))).unwrap();
        let data = Lagged::new(&[Experiment { u: &u, y: &y }], 5, Compression::Qr, 1).unwrap();
        let mut regs: Vec<_> = (1..=2).map(|l| data.output(0, l)).collect();
        regs.extend((0..5).map(|l| Lagged::input(0, 1 + l)));
        let r = data.r_factor(&regs, data.output(0, 0)).unwrap();
        let blocks = vec![Block { len: 2, group: 0 }, Block { len: 5, group: 1 }];
        let mut prob = Problem::new(&r, data.rows, blocks);
        prob.sigma2 = 0.02;
        let h = [[0.2, 0.6, 0.6f64.sqrt()], [0.5, 0.8, 0.7]];
        let got = prob.objective(&h);
        // Explicit: rows t = 5 .. 59 (J = 55), φ(t) = [y(t−1) y(t−2)
        // u(t−1) … u(t−5)].
        let rows = data.rows;
        let phi = DMatrix::from_fn(rows, 7, |t, l| {
            if l < 2 {
                y[(t + 5 - 1 - l, 0)]
            } else {
                u[(t + 5 - 1 - (l - 2), 0)]
            }
        });
        let yy = DVector::from_fn(rows, |t, _| y[(t + 5, 0)]);
        let mut p = DMatrix::zeros(7, 7);
        p.view_mut((0, 0), (2, 2)).copy_from(&kernel(2, h[0]));
        p.view_mut((2, 2), (5, 5)).copy_from(&kernel(5, h[1]));
        let sigma = &phi * p * phi.transpose() + DMatrix::identity(rows, rows) * 0.02;
        let chol = sigma.cholesky().unwrap();
        let want = yy.dot(&chol.solve(&yy)) + 2.0 * chol.l().diagonal().map(|v| v.ln()).sum();
        // The prior's jitter (1e-10 relative) moves it by rounding only.
        assert!((got - want).abs() < 1e-6 * want.abs(), "{got} {want}");
    }
}

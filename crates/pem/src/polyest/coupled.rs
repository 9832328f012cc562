//! A coupled A on multirate records: every output's prediction error from
//! the *measured* past of all outputs, by one Kalman filter on the joint
//! model.
//!
//! With A coupled, output i's equation Σ_j A_ij(q) y_j = Σ_k (B_ik/F_ik)
//! u_k(t − nk_ik) + C_i(q) e_i reaches the other outputs' past, which a
//! slow analyser leaves unmeasured at most instants; the outputs' problems
//! no longer separate (the full-rate route's other outputs as known
//! regressors, [`super`]). Written y = s + v, the simulated part s solves
//! A(q) s = Σ (B/F) u (known at every fast instant from the inputs alone)
//! and the noise v is the vector ARMA process A(q) v = C(q) e, e white
//! with Λ = diag(λ_i) (the outputs' innovations independent, as the
//! full-rate route's per-output costs assume). Its observer form, r the
//! longest of the A_ij and C_i (state x_{i,k}, k = 1 … r, per output):
//!
//! ```text
//!   x_{i,k}(t+1) = x_{i,k+1}(t) − Σ_j a_{ij,k} x_{j,1}(t) + Σ_j (c_{i,k} δ_ij − a_{ij,k}) e_j(t),
//!   v_i(t)       = x_{i,1}(t) + e_i(t),
//! ```
//!
//! i.e. x(t+1) = Φ x(t) + K e(t), v(t) = H x(t) + e(t) — substitute
//! v_j(t) = x_{j,1}(t) + e_j(t) in x_{i,k}(t+1) = x_{i,k+1}(t) − Σ_j
//! a_{ij,k} v_j(t) + c_{i,k} e_i(t). At an instant where the outputs m
//! were measured (H_m the rows of H, Λ̃ = Λ/λ₁, P in units of λ₁), the
//! Kalman filter of a model whose process and measurement noises are
//! correlated (Anderson & Moore 1979, §5.5):
//!
//! ```text
//!   ν = v_m − H_m x̂,   S = H_m P H_mᵀ + Λ̃_mm,   M = Φ P H_mᵀ + K Λ̃_{·m},
//!   x̂ ← Φ x̂ + M S⁻¹ ν,   P ← Φ P Φᵀ + K Λ̃ Kᵀ − M S⁻¹ Mᵀ;
//! ```
//!
//! where nothing was measured x̂ ← Φ x̂, P ← Φ P Φᵀ + K Λ̃ Kᵀ. From x̂ = 0,
//! P = 0 (zero initial conditions): with every output measured at every
//! instant P stays 0, M S⁻¹ = K and ν_i is the full-rate prediction error
//! C_i⁻¹(Σ_j A_ij y_j − Σ_k (B_ik/F_ik) u_k) (unit test). The Gaussian
//! likelihood concentrated in λ₁ (Jones 1980, §3, for vectors: Harvey
//! 1989, §3.4) is minimised by the least-squares problem in the scaled
//! innovations r_t = g L_t⁻¹ ν_t (S_t = L_t L_tᵀ), g = (Π det S_t)^{1/(2M)},
//! M the measured values; the variance ratios λ_i/λ₁ (i ≥ 2) are
//! parameters of their own, as logarithms.
//!
//! The gains do not depend on the data: where the pattern of measured
//! outputs repeats with a period T (an analyser every P₁ samples beside
//! one every P₂: T = lcm), the Riccati recursion is run until P repeats
//! after a period (relative change ≤ 1e-14) and its gains are replayed,
//! resumed where the pattern breaks.
//!
//! **Jacobian** by central differences of r (step 1e-5 (1 + |θ_j|),
//! one-sided where a side leaves a C or F unstable); the A, C and ratio
//! columns change the gains, the B and F columns only s. Near the
//! optimum Levenberg–Marquardt converges linearly here, not
//! quadratically: g depends on A, C and the ratios, and the Gauss–Newton
//! model drops the curvature g'' Σ (L⁻¹ν)², which does not average out as
//! the prediction errors' own curvature does (measured on the tests'
//! 2×2 record from the true parameters: 300 iterations end at a cost
//! 0.008 above the minimum). So Levenberg–Marquardt runs until an
//! iteration gains less than 1e-4 of the cost and a quasi-Newton polish
//! (BFGS from the Gauss–Newton Hessian, `filters::quasi_newton`) takes
//! over: from the true parameters it reaches the minimum to 1e-10 in 16
//! iterations. **Starts**: [`estimate`]'s docs; the iterations from
//! each, the lowest cost kept.
//!
//! Cost: a pass is O(N (n_y Σ_j na_ij + Σ (nb + nf) + n_x m)) once the
//! gains repeat (O(n_x³) per instant before, and throughout for an
//! irregular pattern), n_x = n_y r; a Jacobian 2 d passes, d the
//! parameters. Memory O(M d) for the Jacobian's columns.

use lifted_subspace::Experiment;
use nalgebra::DMatrix;

use super::Output;
use crate::error::{Error, Result};
use crate::filters::{Residuals, RowFolder, difference_column, input_response, stable};

/// Longest period of the measured-output pattern whose gains are replayed
/// (an analyser every 16 samples beside one every 15: 240).
const MAX_PERIOD: usize = 512;

/// Relative change of P over a period below which the gains are taken as
/// periodic: a hundred times the recursion's rounding (as
/// `measured::CONVERGED`).
const CONVERGED: f64 = 1e-14;

/// Relative gain per iteration below which Levenberg–Marquardt hands
/// over to the quasi-Newton polish (module docs): its Gauss–Newton model
/// converges linearly near the optimum here.
const LM_TOLERANCE: f64 = 1e-4;

/// Largest |log λ_i/λ₁| an iteration may reach (a ratio of e^±40 means an
/// output without noise or without signal: the step is refused).
const MAX_LOG_RATIO: f64 = 40.0;

/// The joint problem of all outputs on records where some are unmeasured
/// (module docs). θ: every output's [`Output::pack`] in turn, then
/// log(λ_i/λ₁) for i = 2 … n_y.
pub(super) struct CoupledPredictionError<'a, 'e> {
    pub(super) experiments: &'a [Experiment<'e>],
    pub(super) shapes: &'a [Output],
    /// Per record, per instant: the measured outputs (bit i: output i).
    masks: Vec<Vec<u64>>,
    /// Per record, the period of its mask sequence (if one ≤ MAX_PERIOD).
    periods: Vec<Option<usize>>,
}

/// The observer form of the noise model (module docs).
struct Noise {
    ny: usize,
    r: usize,
    /// −a_{ij,k}: `phi_a[(i * r + k) * ny + j]`.
    phi_a: Vec<f64>,
    /// K, n_x × n_y, column-major.
    k: DMatrix<f64>,
    /// Λ̃: the variance ratios (1 for output 0).
    lam: Vec<f64>,
}

impl Noise {
    fn new(outs: &[Output], lam: Vec<f64>) -> Self {
        let ny = outs.len();
        let r = outs
            .iter()
            .map(|o| o.a.iter().map(Vec::len).max().unwrap_or(0).max(o.c.len()))
            .max()
            .unwrap_or(0)
            .max(1);
        let nx = ny * r;
        let mut phi_a = vec![0.0; nx * ny];
        let mut k = DMatrix::zeros(nx, ny);
        for (i, o) in outs.iter().enumerate() {
            for kk in 0..r {
                for (j, aij) in o.a.iter().enumerate() {
                    let a = aij.get(kk).copied().unwrap_or(0.0);
                    phi_a[(i * r + kk) * ny + j] = -a;
                    k[(i * r + kk, j)] -= a;
                }
                k[(i * r + kk, i)] += o.c.get(kk).copied().unwrap_or(0.0);
            }
        }
        Noise {
            ny,
            r,
            phi_a,
            k,
            lam,
        }
    }

    fn nx(&self) -> usize {
        self.ny * self.r
    }

    /// x ← Φ x (`out` = Φ x).
    fn phi(&self, x: &[f64], out: &mut [f64]) {
        let (ny, r) = (self.ny, self.r);
        for i in 0..ny {
            for kk in 0..r {
                let row = i * r + kk;
                let mut v = if kk + 1 < r { x[row + 1] } else { 0.0 };
                let coeffs = &self.phi_a[row * ny..(row + 1) * ny];
                for (j, c) in coeffs.iter().enumerate() {
                    v += c * x[j * r];
                }
                out[row] = v;
            }
        }
    }

    /// Φ as a dense matrix (for the Riccati recursion).
    fn phi_dense(&self) -> DMatrix<f64> {
        let nx = self.nx();
        let mut m = DMatrix::zeros(nx, nx);
        let mut col = vec![0.0; nx];
        let mut out = vec![0.0; nx];
        for c in 0..nx {
            col.iter_mut().for_each(|v| *v = 0.0);
            col[c] = 1.0;
            self.phi(&col, &mut out);
            m.column_mut(c).copy_from_slice(&out);
        }
        m
    }
}

/// The filter's step at one instant: the measured outputs, the gain
/// G = M S⁻¹ (n_x × m, column-major), L⁻¹ (m × m, row-major lower),
/// log det S, and P after the step (for resuming a replay).
#[derive(Clone)]
struct Step {
    mask: u64,
    idx: Vec<usize>,
    g: Vec<f64>,
    linv: Vec<f64>,
    logdet: f64,
    p_after: DMatrix<f64>,
}

/// The gains of one record's instants in turn: the Riccati recursion, or
/// a replay of its last period once P repeats (module docs).
struct Gains<'n> {
    noise: &'n Noise,
    phi: DMatrix<f64>,
    /// K Λ̃ Kᵀ.
    q: DMatrix<f64>,
    p: DMatrix<f64>,
    period: Option<usize>,
    ring: Vec<Option<Step>>,
    current: Option<Step>,
    /// Consecutive instants whose mask equals the one a period before.
    matched: usize,
    frozen: bool,
    t: usize,
}

impl<'n> Gains<'n> {
    fn new(noise: &'n Noise, period: Option<usize>) -> Self {
        let nx = noise.nx();
        let kl = DMatrix::from_fn(nx, noise.ny, |r, c| noise.k[(r, c)] * noise.lam[c]);
        Gains {
            noise,
            phi: noise.phi_dense(),
            q: &kl * noise.k.transpose(),
            p: DMatrix::zeros(nx, nx),
            period,
            ring: vec![None; period.unwrap_or(0)],
            current: None,
            matched: 0,
            frozen: false,
            t: 0,
        }
    }

    /// The step of the next instant, whose measured outputs are `mask`;
    /// `None` when S is not positive definite.
    fn next(&mut self, mask: u64) -> Option<&Step> {
        let t = self.t;
        self.t += 1;
        if let Some(tp) = self.period {
            let slot = t % tp;
            if self.frozen {
                if self.ring[slot].as_ref().is_some_and(|s| s.mask == mask) {
                    return self.ring[slot].as_ref();
                }
                // The pattern broke: resume from P before this instant.
                let prev = (t + tp - 1) % tp;
                if let Some(s) = self.ring[prev].as_ref() {
                    self.p = s.p_after.clone();
                }
                self.frozen = false;
                self.matched = 0;
            }
            let step = self.riccati(mask)?;
            let same = self.ring[slot].as_ref().filter(|s| s.mask == mask);
            match same {
                Some(old) => {
                    self.matched += 1;
                    let scale = step.p_after.amax().max(f64::MIN_POSITIVE);
                    let change = (&step.p_after - &old.p_after).amax();
                    if self.matched >= tp && change <= CONVERGED * scale {
                        self.frozen = true;
                    }
                }
                None => self.matched = 0,
            }
            self.p = step.p_after.clone();
            self.ring[slot] = Some(step);
            return self.ring[slot].as_ref();
        }
        let step = self.riccati(mask)?;
        self.p = step.p_after.clone();
        self.current = Some(step);
        self.current.as_ref()
    }

    /// One step of the recursion from `self.p`.
    fn riccati(&self, mask: u64) -> Option<Step> {
        let noise = self.noise;
        let (r, nx) = (noise.r, noise.nx());
        let idx: Vec<usize> = (0..noise.ny).filter(|&i| mask >> i & 1 == 1).collect();
        let m = idx.len();
        let mut p_after = &self.phi * &self.p * self.phi.transpose() + &self.q;
        if m == 0 {
            return Some(Step {
                mask,
                idx,
                g: Vec::new(),
                linv: Vec::new(),
                logdet: 0.0,
                p_after,
            });
        }
        let s = DMatrix::from_fn(m, m, |a, b| {
            self.p[(idx[a] * r, idx[b] * r)] + if a == b { noise.lam[idx[a]] } else { 0.0 }
        });
        // M = Φ P H_mᵀ + K Λ̃_{·m}.
        let ph = DMatrix::from_fn(nx, m, |row, c| self.p[(row, idx[c] * r)]);
        let mm = &self.phi * ph
            + DMatrix::from_fn(nx, m, |row, c| noise.k[(row, idx[c])] * noise.lam[idx[c]]);
        let chol = nalgebra::Cholesky::new(s)?;
        let l = chol.l();
        let logdet = 2.0 * l.diagonal().iter().map(|v| v.ln()).sum::<f64>();
        // G = M S⁻¹ = (S⁻¹ Mᵀ)ᵀ.
        let g = chol.solve(&mm.transpose()).transpose();
        p_after -= &g * mm.transpose();
        p_after = (&p_after + p_after.transpose()) * 0.5;
        let linv_m = l.solve_lower_triangular(&DMatrix::identity(m, m))?;
        let linv = (0..m * m).map(|e| linv_m[(e / m, e % m)]).collect();
        Some(Step {
            mask,
            idx,
            g: g.as_slice().to_vec(),
            linv,
            logdet,
            p_after,
        })
    }
}

/// What the passes over all records give at θ.
struct Innovations {
    /// L⁻¹ ν of every measured instant in turn (unscaled).
    r: Vec<f64>,
    /// Σ log det S.
    logdet: f64,
    /// Per output: Σ ν_i² and its measured count.
    plain: Vec<(f64, usize)>,
}

impl Innovations {
    fn measured(&self) -> usize {
        self.r.len()
    }

    /// g = (Π det S)^{1/(2M)}.
    fn g(&self) -> f64 {
        let m = self.measured();
        if m == 0 {
            1.0
        } else {
            (self.logdet / (2.0 * m as f64)).exp()
        }
    }

    fn scaled(&self) -> Vec<f64> {
        let g = self.g();
        self.r.iter().map(|v| g * v).collect()
    }
}

impl<'a, 'e> CoupledPredictionError<'a, 'e> {
    pub(super) fn new(experiments: &'a [Experiment<'e>], shapes: &'a [Output]) -> Self {
        let masks: Vec<Vec<u64>> = experiments
            .iter()
            .map(|e| {
                (0..e.y.nrows())
                    .map(|t| {
                        (0..e.y.ncols())
                            .filter(|&i| !e.y[(t, i)].is_nan())
                            .fold(0u64, |acc, i| acc | 1 << i)
                    })
                    .collect()
            })
            .collect();
        let periods = masks.iter().map(|m| period(m)).collect();
        CoupledPredictionError {
            experiments,
            shapes,
            masks,
            periods,
        }
    }

    /// The parameters of the polynomials (all outputs), before the ratios.
    fn polynomial_count(&self) -> usize {
        self.shapes.iter().map(|s| s.pack().len()).sum()
    }

    /// θ of the polynomials `outs` and the ratios `lam` (λ_i/λ₁).
    pub(super) fn pack(outs: &[Output], lam: &[f64]) -> Vec<f64> {
        let mut v: Vec<f64> = outs.iter().flat_map(Output::pack).collect();
        v.extend(lam.iter().skip(1).map(|l| l.ln()));
        v
    }

    /// The polynomials and ratios of θ.
    pub(super) fn unpack(&self, theta: &[f64]) -> (Vec<Output>, Vec<f64>) {
        let mut at = 0;
        let outs = self
            .shapes
            .iter()
            .map(|s| {
                let n = s.pack().len();
                let o = s.with(&theta[at..at + n]);
                at += n;
                o
            })
            .collect();
        let lam = std::iter::once(1.0)
            .chain(theta[at..].iter().map(|v| v.exp()))
            .collect();
        (outs, lam)
    }

    /// The innovations of every record at θ; `None` where a filter step
    /// fails (S not positive definite) or a value is not finite.
    fn innovations(&self, theta: &[f64]) -> Option<Innovations> {
        let (outs, lam) = self.unpack(theta);
        let noise = Noise::new(&outs, lam);
        let ny = outs.len();
        let mut inn = Innovations {
            r: Vec::new(),
            logdet: 0.0,
            plain: vec![(0.0, 0); ny],
        };
        let nx = noise.nx();
        for ((e, masks), period) in self.experiments.iter().zip(&self.masks).zip(&self.periods) {
            let s = simulate(e, &outs);
            let mut gains = Gains::new(&noise, *period);
            let (mut x, mut next) = (vec![0.0; nx], vec![0.0; nx]);
            let mut nu = vec![0.0; ny];
            for (t, &mask) in masks.iter().enumerate() {
                let step = gains.next(mask)?;
                noise.phi(&x, &mut next);
                let m = step.idx.len();
                for (a, &i) in step.idx.iter().enumerate() {
                    nu[a] = e.y[(t, i)] - s[i][t] - x[i * noise.r];
                    inn.plain[i].0 += nu[a] * nu[a];
                    inn.plain[i].1 += 1;
                }
                for a in 0..m {
                    let row = &step.linv[a * m..(a + 1) * m];
                    inn.r
                        .push(row[..=a].iter().zip(&nu[..=a]).map(|(l, v)| l * v).sum());
                    let g = &step.g[a * nx..(a + 1) * nx];
                    for (xn, gv) in next.iter_mut().zip(g) {
                        *xn += gv * nu[a];
                    }
                }
                inn.logdet += step.logdet;
                std::mem::swap(&mut x, &mut next);
            }
        }
        let finite = inn.r.iter().all(|v| v.is_finite()) && inn.logdet.is_finite();
        finite.then_some(inn)
    }

    /// (Σ νᵀS⁻¹ν in units of λ₁, per output (Σ ν_i², count), M, Σ r²) at θ.
    #[allow(clippy::type_complexity)]
    pub(super) fn sums(&self, theta: &[f64]) -> Result<(f64, Vec<(f64, usize)>, usize, f64)> {
        let inn = self.innovations(theta).ok_or(Error::Diverged {
            what: "the joint prediction errors at the estimate",
        })?;
        let weighted = inn.r.iter().map(|v| v * v).sum();
        let cost = inn.scaled().iter().map(|v| v * v).sum();
        Ok((weighted, inn.plain.clone(), inn.measured(), cost))
    }

    /// The parameter count (polynomials and ratios).
    pub(super) fn dimension(&self) -> usize {
        self.polynomial_count() + self.shapes.len() - 1
    }
}

impl Residuals for CoupledPredictionError<'_, '_> {
    fn evaluate(&self, theta: &[f64], jacobian: bool) -> Result<(f64, Option<DMatrix<f64>>)> {
        let Some(base) = self.innovations(theta) else {
            if jacobian {
                return Err(Error::Diverged {
                    what: "the joint prediction errors",
                });
            }
            return Ok((f64::INFINITY, None));
        };
        let r0 = base.scaled();
        let cost = r0.iter().map(|v| v * v).sum();
        if !jacobian {
            return Ok((cost, None));
        }
        let d = theta.len();
        let mut columns: Vec<Vec<f64>> = Vec::with_capacity(d);
        for j in 0..d {
            let h = 1e-5 * (1.0 + theta[j].abs());
            let at = |delta: f64| {
                let mut th = theta.to_vec();
                th[j] += delta;
                if !self.admissible(&th) {
                    return None;
                }
                self.innovations(&th).map(|i| i.scaled())
            };
            let col = difference_column(at(h), at(-h), &r0, h);
            columns.push(col);
        }
        let mut rows = RowFolder::new(d + 1);
        for (t, rt) in r0.iter().enumerate() {
            rows.push(columns.iter().map(|c| c[t]).chain([*rt]))?;
        }
        Ok((cost, Some(rows.finish()?)))
    }

    fn admissible(&self, theta: &[f64]) -> bool {
        let np = self.polynomial_count();
        let (outs, _) = self.unpack(theta);
        theta[np..].iter().all(|v| v.abs() <= MAX_LOG_RATIO)
            && outs
                .iter()
                .all(|o| stable(&o.c) && o.f.iter().all(|f| stable(f)))
    }
}

/// The simulated part s (module docs) of every output of record `e`:
/// A(q) s = Σ_k (B_k/F_k) u_k(t − nk_k), zero initial conditions.
/// O(N (n_y Σ_j na_ij + Σ (nb + nf))).
fn simulate(e: &Experiment<'_>, outs: &[Output]) -> Vec<Vec<f64>> {
    let n = e.u.nrows();
    let mut s: Vec<Vec<f64>> = outs
        .iter()
        .map(|o| {
            let mut w = vec![0.0; n];
            for (k, b) in o.b.iter().enumerate() {
                if b.is_empty() {
                    continue;
                }
                let (_, wk) = input_response(e, k, b, &o.f[k], o.nk[k]);
                for (a, b) in w.iter_mut().zip(&wk) {
                    *a += b;
                }
            }
            w
        })
        .collect();
    for t in 0..n {
        for (i, o) in outs.iter().enumerate() {
            let mut v = s[i][t];
            for (j, aij) in o.a.iter().enumerate() {
                for (l, a) in aij.iter().enumerate() {
                    if t > l {
                        v -= a * s[j][t - l - 1];
                    }
                }
            }
            s[i][t] = v;
        }
    }
    s
}

/// The smallest T ≤ [`MAX_PERIOD`] with mask(t) = mask(t − T) over the
/// record's first 8 T + 64 instants (later breaks resume the recursion).
fn period(masks: &[u64]) -> Option<usize> {
    (1..=MAX_PERIOD.min(masks.len() / 2)).find(|&tp| {
        let end = masks.len().min(8 * tp + 64);
        (tp..end).all(|t| masks[t] == masks[t - tp])
    })
}

/// The polynomials of output `i` of `model` in the layout of `shape`
/// (zero-padded or cut to its orders).
pub(super) fn output_of(model: &lifted_lti::PolyModel, i: usize, shape: &Output) -> Output {
    let take = |v: &[f64], skip: usize, n: usize| -> Vec<f64> {
        (0..n)
            .map(|l| v.get(l + skip).copied().unwrap_or(0.0))
            .collect()
    };
    let mut o = shape.clone();
    for (j, a) in o.a.iter_mut().enumerate() {
        *a = take(model.a(i, j), 1, a.len());
    }
    for (k, b) in o.b.iter_mut().enumerate() {
        *b = take(model.b(i, k), 0, b.len());
    }
    for (k, f) in o.f.iter_mut().enumerate() {
        *f = take(model.f(i, k), 1, f.len());
    }
    o.c = take(model.c(i), 1, o.c.len());
    o
}

/// The variance ratios λ_i/λ₁ of a model's Λ (1 where not positive).
pub(super) fn ratios(model: &lifted_lti::PolyModel) -> Vec<f64> {
    let l = model.noise_variance();
    let l0 = l[(0, 0)];
    (0..l.nrows())
        .map(|i| {
            let v = l[(i, i)] / l0;
            if v.is_finite() && v > 0.0 { v } else { 1.0 }
        })
        .collect()
}

/// The unscaled innovations L⁻¹ν at θ (tests: the full-rate identity).
#[cfg(test)]
pub(super) fn unscaled_innovations(
    problem: &CoupledPredictionError<'_, '_>,
    theta: &[f64],
) -> Option<Vec<f64>> {
    problem.innovations(theta).map(|i| i.r)
}

/// Whether output `i` is in a coupled A (another output's past in its
/// equation, or its past in another's).
fn coupled_at(orders: &lifted_lti::PolyOrders, i: usize) -> bool {
    (0..orders.na.len()).any(|j| j != i && (orders.na[i][j] > 0 || orders.na[j][i] > 0))
}

/// Whether the outputs are estimated jointly (module docs): an output
/// with unmeasured samples in a coupled A. Refused there: a D polynomial
/// (the joint noise model is A⁻¹C) and a common F.
pub(super) fn joint(
    experiments: &[Experiment<'_>],
    orders: &lifted_lti::PolyOrders,
    opts: &super::PolyestOptions,
) -> Result<bool> {
    let ny = orders.na.len();
    let Some(i) =
        (0..ny).find(|&i| super::measured::has_missing(experiments, i) && coupled_at(orders, i))
    else {
        return Ok(false);
    };
    if orders.nd.iter().any(|&n| n > 0) || opts.f_structure == crate::FStructure::Common {
        return Err(Error::InvalidOption {
            what: "orders",
            reason: format!(
                "output {i} is measured at a slower rate (NaN samples) and a coupled A \
                 filters it into another output's equation: the joint predictor holds \
                 A, B, C and per-input F (no D, no common F); use a diagonal A for \
                 Box–Jenkins noise models"
            ),
        });
    }
    Ok(true)
}

/// The joint estimate of every output (module docs).
pub(super) struct JointEstimate {
    pub(super) outputs: Vec<Output>,
    /// λ_i = λ̂₁ λ_i/λ₁, λ̂₁ = Σ νᵀS⁻¹ν / (M − d).
    pub(super) lambdas: Vec<f64>,
    /// Of every output's polynomial parameters in turn (the ratios'
    /// rows and columns dropped: the marginal covariance).
    pub(super) cov: DMatrix<f64>,
    /// Per output: Σ ν_i² and its measured count.
    pub(super) plain: Vec<(f64, usize)>,
    pub(super) iterations: usize,
}

/// Every output of `experiments` with its unmeasured samples interpolated
/// linearly (held before the first and after the last); `None` when an
/// output of a record has fewer than two measured samples.
pub(super) fn interpolated(experiments: &[Experiment<'_>]) -> Option<Vec<DMatrix<f64>>> {
    experiments
        .iter()
        .map(|e| {
            let cols: Vec<Vec<f64>> = (0..e.y.ncols())
                .map(|i| {
                    let col: Vec<f64> = e.y.column(i).iter().copied().collect();
                    lifted_lti::interpolate_unmeasured(&col)
                })
                .collect::<Option<_>>()?;
            Some(DMatrix::from_fn(e.y.nrows(), e.y.ncols(), |t, i| {
                cols[i][t]
            }))
        })
        .collect()
}

/// The coupled structure `orders` (shapes per output) on records where an
/// output in it is unmeasured at some instants: the iterations from two
/// starts, the lower cost kept —
///
/// 1. the full-rate estimate of the same structure on the record with
///    every output interpolated linearly between its measured samples
///    (biased by the interpolation, in the basin of the coupling);
/// 2. the diagonal-A estimate on the measured samples (each output's own
///    Kalman predictor, [`super::measured`]), its coupling terms zero.
///
/// Each with the variance ratios of its own Λ, and each again with C = 0
/// (the noise model A⁻¹): on the tests' 2×2 record, read every 2nd and
/// every 3rd sample, the iterations from the two fitted C's ended in
/// local minima (costs 1 623 and 1 195) and those from C = 0 at the
/// lowest (1 190.53, below the true parameters' 1 193.84) — the
/// interpolated record's C is pulled towards the unit circle by the
/// interpolation's smoothing.
///
/// Errors: [`Error::TooFewSamples`] when the measured values do not
/// exceed the parameters; [`Error::Diverged`] when no start gives finite
/// prediction errors; [`Error::RankDeficient`] for a singular Jacobian at
/// the estimate.
pub(super) fn estimate(
    experiments: &[Experiment<'_>],
    orders: &lifted_lti::PolyOrders,
    shapes: &[Output],
    ts: f64,
    opts: &super::PolyestOptions,
) -> Result<JointEstimate> {
    let problem = CoupledPredictionError::new(experiments, shapes);
    let d = problem.dimension();
    let m: usize = problem
        .masks
        .iter()
        .flat_map(|r| r.iter())
        .map(|v| v.count_ones() as usize)
        .sum();
    if m <= d {
        return Err(Error::TooFewSamples {
            what: "the coupled polynomial model (measured output values)",
            measured: m,
            needed: d + 1,
        });
    }
    let mut starts: Vec<Vec<f64>> = Vec::new();
    let from_model = |model: &lifted_lti::PolyModel| {
        let outs: Vec<Output> = shapes
            .iter()
            .enumerate()
            .map(|(i, s)| output_of(model, i, s))
            .collect();
        CoupledPredictionError::pack(&outs, &ratios(model))
    };
    if let Some(ys) = interpolated(experiments) {
        let exps: Vec<Experiment<'_>> = experiments
            .iter()
            .zip(&ys)
            .map(|(e, y)| Experiment { u: e.u, y })
            .collect();
        if let Ok(fit) = super::polyest(&exps, orders, ts, opts) {
            starts.push(from_model(&fit.model));
        }
    }
    let mut diagonal = orders.clone();
    for (i, row) in diagonal.na.iter_mut().enumerate() {
        for (j, n) in row.iter_mut().enumerate() {
            if i != j {
                *n = 0;
            }
        }
    }
    if let Ok(fit) = super::polyest(experiments, &diagonal, ts, opts) {
        starts.push(from_model(&fit.model));
    }
    // Each start also with C = 0 (the noise model A⁻¹: the interpolated
    // record's C is biased towards the unit circle by the interpolation's
    // smoothing).
    let c_free: Vec<Vec<f64>> = starts
        .iter()
        .map(|theta| {
            let (mut outs, lam) = problem.unpack(theta);
            for o in &mut outs {
                o.c.iter_mut().for_each(|v| *v = 0.0);
            }
            CoupledPredictionError::pack(&outs, &lam)
        })
        .collect();
    for t in c_free {
        if !starts.contains(&t) {
            starts.push(t);
        }
    }
    let mut best: Option<(Vec<f64>, f64, DMatrix<f64>)> = None;
    let mut iterations = 0;
    for theta0 in starts {
        if !problem.admissible(&theta0) || problem.innovations(&theta0).is_none() {
            continue;
        }
        // A start whose iterations meet a diverging Jacobian is dropped;
        // the others stand.
        let Ok((theta, _, _, its)) =
            crate::filters::minimise(&problem, theta0, opts.max_iterations, LM_TOLERANCE)
        else {
            continue;
        };
        let Ok((theta, cost, r11, polish)) =
            crate::filters::quasi_newton(&problem, theta, opts.max_iterations, opts.tolerance)
        else {
            continue;
        };
        iterations += its + polish;
        if best.as_ref().is_none_or(|b| cost < b.1) {
            best = Some((theta, cost, r11));
        }
    }
    let (theta, cost, r11) = best.ok_or(Error::Diverged {
        what: "the coupled polynomial model on the measured samples",
    })?;
    let (weighted, plain, measured, _) = problem.sums(&theta)?;
    let dof = (measured - d) as f64;
    let inv = r11
        .solve_upper_triangular(&DMatrix::identity(d, d))
        .ok_or(Error::RankDeficient {
            what: "the joint prediction-error Jacobian at the estimate",
            rank: 0,
            needed: d,
        })?;
    let np = problem.polynomial_count();
    let full = &inv * inv.transpose() * (cost / dof);
    let cov = full.view((0, 0), (np, np)).into_owned();
    let (outputs, lam) = problem.unpack(&theta);
    let lambda1 = weighted / dof;
    Ok(JointEstimate {
        outputs,
        lambdas: lam.iter().map(|l| l * lambda1).collect(),
        cov,
        plain,
        iterations,
    })
}

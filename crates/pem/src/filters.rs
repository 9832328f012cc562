//! What the polynomial prediction-error estimators ([`crate::oe`],
//! [`crate::polyest`]) share: scalar polynomial filters in q⁻¹, the rows
//! of [J | ε] folded into an R-only QR, and the Levenberg–Marquardt
//! iterations on them.

use lifted_linalg::RAccumulator;
use lifted_subspace::Experiment;
use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result};

/// w(t) = s(t − delay) − Σ_j f_j w(t − j), zero initial conditions.
pub(crate) fn filter(s: &[f64], f: &[f64], delay: usize, out: &mut Vec<f64>) {
    out.clear();
    out.resize(s.len(), 0.0);
    for t in 0..s.len() {
        let mut v = if t >= delay { s[t - delay] } else { 0.0 };
        for (j, fj) in f.iter().enumerate() {
            if t > j {
                v -= fj * out[t - j - 1];
            }
        }
        out[t] = v;
    }
}

/// Input `k`'s term of a polynomial model's output: v = q^{−nk} u_k / F
/// and w = B v (the simulated contribution (B/F) u_k(t − nk)). O(N (nb + nf)).
pub(crate) fn input_response(
    e: &Experiment<'_>,
    k: usize,
    b: &[f64],
    f: &[f64],
    nk: usize,
) -> (Vec<f64>, Vec<f64>) {
    let uk: Vec<f64> = e.u.column(k).iter().copied().collect();
    let (mut v, mut w) = (Vec::new(), Vec::new());
    filter(&uk, f, nk, &mut v);
    fir_apply(&v, b, &mut w);
    (v, w)
}

/// Σ_m b_m v(t − m).
pub(crate) fn fir_apply(v: &[f64], b: &[f64], out: &mut Vec<f64>) {
    out.clear();
    out.resize(v.len(), 0.0);
    for t in 0..v.len() {
        let mut s = 0.0;
        for (m, bm) in b.iter().enumerate() {
            if t >= m {
                s += bm * v[t - m];
            }
        }
        out[t] = s;
    }
}

/// Whether 1 + f₁q⁻¹ + … has every root strictly inside the unit circle.
pub(crate) fn stable(f: &[f64]) -> bool {
    if f.is_empty() {
        return true;
    }
    let n = f.len();
    let companion = DMatrix::from_fn(n, n, |r, c| {
        if r == 0 {
            -f[c]
        } else if r == c + 1 {
            1.0
        } else {
            0.0
        }
    });
    lifted_linalg::spectral_radius(&companion).is_ok_and(|rho| rho < 1.0)
}

/// The Levenberg–Marquardt step δ solving [R₁₁; √λ D] δ = [rhs; 0] in
/// the least-squares sense by a small QR (D = diag(`scale`), Marquardt's
/// scaling); `None` when the damped system is singular. O(d³).
pub(crate) fn damped_step(
    r11: &DMatrix<f64>,
    rhs: &DVector<f64>,
    scale: &[f64],
    lambda: f64,
) -> Result<Option<DVector<f64>>> {
    let d = r11.nrows();
    let mut m = DMatrix::zeros(2 * d, d + 1);
    m.view_mut((0, 0), (d, d)).copy_from(r11);
    for j in 0..d {
        m[(d + j, j)] = lambda.sqrt() * scale[j];
        m[(j, d)] = rhs[j];
    }
    let q = lifted_linalg::qr_r(&m)?;
    Ok(q.view((0, 0), (d, d))
        .into_owned()
        .solve_upper_triangular(&q.view((0, d), (d, 1)).into_owned())
        .map(|v| v.column(0).into_owned()))
}

/// Rows folded into an R-only QR in blocks of [`FOLD_ROWS`] (memory
/// O(width · FOLD_ROWS + width²), whatever the number of rows).
pub(crate) struct RowFolder {
    acc: RAccumulator,
    block: Vec<f64>,
    rows: usize,
    width: usize,
}

/// Rows of a [`RowFolder`] block.
const FOLD_ROWS: usize = 4096;

impl RowFolder {
    /// An empty folder for rows of `width` entries.
    pub(crate) fn new(width: usize) -> Self {
        RowFolder {
            acc: RAccumulator::new(width),
            block: Vec::with_capacity(width * FOLD_ROWS.min(256)),
            rows: 0,
            width,
        }
    }

    /// Appends one row (`width` entries).
    pub(crate) fn push(&mut self, row: impl IntoIterator<Item = f64>) -> Result<()> {
        self.block.extend(row);
        self.rows += 1;
        if self.rows == FOLD_ROWS {
            self.flush()?;
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<()> {
        if self.rows > 0 {
            self.acc
                .push_rows(&DMatrix::from_row_slice(self.rows, self.width, &self.block))?;
            self.block.clear();
            self.rows = 0;
        }
        Ok(())
    }

    /// The R factor of every row pushed.
    pub(crate) fn finish(mut self) -> Result<DMatrix<f64>> {
        self.flush()?;
        Ok(self.acc.r())
    }
}

/// A nonlinear least-squares problem for [`minimise`].
pub(crate) trait Residuals {
    /// Σ ε² at θ and, with `jacobian`, the R factor of [J | ε] with
    /// J = ∂ε/∂θ (d + 1 columns).
    fn evaluate(&self, theta: &[f64], jacobian: bool) -> Result<(f64, Option<DMatrix<f64>>)>;
    /// Whether θ is admissible (its polynomials stable).
    fn admissible(&self, theta: &[f64]) -> bool;
}

/// A problem whose parameters are tied: the inner problem's θ is
/// (θ_c[source[0]], θ_c[source[1]], …) — a common F copied to every input
/// (`crate::FStructure::Common`). Its Jacobian is J E (E the 0/1 matrix
/// of `source`), so the R factor of [J E | ε] is that of [R E | r], R the
/// inner problem's factor of [J | ε]: its rows folded again, O(d² d_c).
pub(crate) struct Tied<'a, P> {
    /// The problem on the untied parameters.
    pub inner: &'a P,
    /// For each inner parameter, its tied parameter.
    pub source: Vec<usize>,
    /// Tied parameters.
    pub free: usize,
}

impl<P> Tied<'_, P> {
    /// The inner problem's θ of tied parameters `theta`.
    pub(crate) fn expand(&self, theta: &[f64]) -> Vec<f64> {
        self.source.iter().map(|&j| theta[j]).collect()
    }

    /// The tied parameters of an inner θ (each from the first inner
    /// parameter tied to it).
    pub(crate) fn tie(&self, full: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.free];
        for (k, &j) in self.source.iter().enumerate().rev() {
            out[j] = full[k];
        }
        out
    }
}

impl<P: Residuals> Residuals for Tied<'_, P> {
    fn evaluate(&self, theta: &[f64], jacobian: bool) -> Result<(f64, Option<DMatrix<f64>>)> {
        let (cost, r) = self.inner.evaluate(&self.expand(theta), jacobian)?;
        let Some(r) = r else {
            return Ok((cost, None));
        };
        let d = self.source.len();
        let mut fold = RowFolder::new(self.free + 1);
        let mut row = vec![0.0; self.free + 1];
        for i in 0..r.nrows() {
            row.iter_mut().for_each(|v| *v = 0.0);
            for (k, &j) in self.source.iter().enumerate() {
                row[j] += r[(i, k)];
            }
            row[self.free] = r[(i, d)];
            fold.push(row.iter().copied())?;
        }
        Ok((cost, Some(fold.finish()?)))
    }

    fn admissible(&self, theta: &[f64]) -> bool {
        self.inner.admissible(&self.expand(theta))
    }
}

/// The covariance of tied parameters on the untied ones: E Σ Eᵀ (entry
/// (k, l) = Σ[source[k], source[l]]; the copies perfectly correlated).
pub(crate) fn untied_covariance(cov: &DMatrix<f64>, source: &[usize]) -> DMatrix<f64> {
    DMatrix::from_fn(source.len(), source.len(), |r, c| {
        cov[(source[r], source[c])]
    })
}

/// `Err` naming `what` unless [`minimise`]'s limits are usable: at least
/// one iteration and a positive finite tolerance.
pub(crate) fn check_iterations(
    max_iterations: usize,
    tolerance: f64,
    what: &'static str,
) -> Result<()> {
    if max_iterations == 0 || !(tolerance.is_finite() && tolerance > 0.0) {
        return Err(Error::InvalidOption {
            what,
            reason: "max_iterations ≥ 1 and a positive finite tolerance".into(),
        });
    }
    Ok(())
}

/// The single-output records of output `i` of `experiments` (its y
/// columns, to be paired with the inputs by [`with_outputs`]).
pub(crate) fn output_columns(experiments: &[Experiment<'_>], i: usize) -> Vec<DMatrix<f64>> {
    experiments
        .iter()
        .map(|e| e.y.columns(i, 1).into_owned())
        .collect()
}

/// `experiments`' inputs with the outputs `ys` ([`output_columns`]).
pub(crate) fn with_outputs<'a>(
    experiments: &[Experiment<'a>],
    ys: &'a [DMatrix<f64>],
) -> Vec<Experiment<'a>> {
    experiments
        .iter()
        .zip(ys)
        .map(|(e, y)| Experiment { u: e.u, y })
        .collect()
}

/// Levenberg–Marquardt from `theta` (Marquardt's scaling, λ from 1e-3,
/// ÷3 on success, ×4 on failure, at most 12 trials per iteration; an
/// inadmissible trial counts as a failure): stops after `max_iterations`,
/// when an accepted step lowers the cost by less than `tolerance` of it,
/// or when the step is below √tolerance (1 + ‖θ‖). Returns (θ, cost, R₁₁
/// at θ, iterations). Cost per iteration: one Jacobian evaluation and a
/// few cost evaluations, plus O(d³) per trial.
pub(crate) fn minimise(
    problem: &impl Residuals,
    mut theta: Vec<f64>,
    max_iterations: usize,
    tolerance: f64,
) -> Result<(Vec<f64>, f64, DMatrix<f64>, usize)> {
    let d = theta.len();
    let mut lambda: f64 = 1e-3;
    let (mut cost, mut r) = problem.evaluate(&theta, true)?;
    let r11_of = |r: &Option<DMatrix<f64>>| {
        r.as_ref()
            .filter(|r| r.nrows() >= d)
            .map(|r| r.view((0, 0), (d, d)).into_owned())
            .unwrap_or_else(|| DMatrix::zeros(d, d))
    };
    let mut iterations = 0;
    while iterations < max_iterations {
        iterations += 1;
        let Some(rr) = r.as_ref().filter(|r| r.nrows() >= d) else {
            break;
        };
        let r11 = rr.view((0, 0), (d, d)).into_owned();
        // min ‖ε + J δ‖²: [R₁₁; √λ D] δ = [−r; 0].
        let rhs: DVector<f64> = -rr.view((0, d), (d, 1)).column(0).into_owned();
        let scale: Vec<f64> = (0..d)
            .map(|j| r11.column(j).norm().max(f64::MIN_POSITIVE))
            .collect();
        let mut accepted = false;
        for _ in 0..12 {
            let Some(delta) = damped_step(&r11, &rhs, &scale, lambda)? else {
                lambda *= 4.0;
                continue;
            };
            let trial: Vec<f64> = theta.iter().zip(delta.iter()).map(|(a, b)| a + b).collect();
            if !problem.admissible(&trial) {
                lambda *= 4.0;
                continue;
            }
            let (c, _) = problem.evaluate(&trial, false)?;
            if c < cost {
                let small_step = delta.norm()
                    <= tolerance.sqrt() * (1.0 + DVector::from_column_slice(&theta).norm());
                let small_gain = (cost - c) <= tolerance * cost;
                theta = trial;
                cost = c;
                lambda = (lambda / 3.0).max(1e-12);
                accepted = true;
                r = problem.evaluate(&theta, true)?.1;
                if small_step || small_gain {
                    return Ok((theta, cost, r11_of(&r), iterations));
                }
                break;
            }
            lambda *= 4.0;
        }
        if !accepted {
            break;
        }
    }
    Ok((theta, cost, r11_of(&r), iterations))
}

/// The block-diagonal matrix of `blocks`, each symmetrised ((B + Bᵀ)/2):
/// the parameter covariance of outputs estimated apart.
pub(crate) fn block_diagonal(blocks: &[DMatrix<f64>]) -> DMatrix<f64> {
    let total: usize = blocks.iter().map(DMatrix::nrows).sum();
    let mut cov = DMatrix::zeros(total, total);
    let mut at = 0;
    for b in blocks {
        let n = b.nrows();
        cov.view_mut((at, at), (n, n))
            .copy_from(&((b + b.transpose()) * 0.5));
        at += n;
    }
    cov
}

/// A Jacobian column by differences of the residuals `base` at θ: central
/// from the two sides `up` (θ + h) and `down` (θ − h), one-sided where a
/// side is inadmissible (`None`), zero where both are.
pub(crate) fn difference_column(
    up: Option<Vec<f64>>,
    down: Option<Vec<f64>>,
    base: &[f64],
    h: f64,
) -> Vec<f64> {
    match (up, down) {
        (Some(up), Some(down)) => up
            .iter()
            .zip(&down)
            .map(|(a, b)| (a - b) / (2.0 * h))
            .collect(),
        (Some(up), None) => up.iter().zip(base).map(|(a, b)| (a - b) / h).collect(),
        (None, Some(down)) => base.iter().zip(&down).map(|(a, b)| (a - b) / h).collect(),
        (None, None) => vec![0.0; base.len()],
    }
}

/// Quasi-Newton (BFGS) from `theta` on the cost of `problem`, its Hessian
/// model started at the Gauss–Newton 2 R₁₁ᵀR₁₁ and its gradient
/// 2 R₁₁ᵀ r₁ from the R factor of [J | r] (Nocedal & Wright 2006, §6.1
/// with §10.3's start): for residuals whose own curvature does not
/// average out near the optimum (the scaled innovations of a
/// concentrated likelihood), where Levenberg–Marquardt's Gauss–Newton
/// model converges linearly. Backtracking (Armijo, c = 1e-4, halving)
/// keeps every trial admissible; stops after `max_iterations`, when the
/// Newton decrement −gᵀp falls below `tolerance` of the cost, when an
/// accepted step lowers the cost by less than that, or when no step of
/// length ≥ 2⁻²⁰ lowers it. Returns (θ, cost, R₁₁ at θ, iterations).
/// Cost per iteration: one Jacobian evaluation, the line search's cost
/// evaluations and O(d³).
pub(crate) fn quasi_newton(
    problem: &impl Residuals,
    mut theta: Vec<f64>,
    max_iterations: usize,
    tolerance: f64,
) -> Result<(Vec<f64>, f64, DMatrix<f64>, usize)> {
    let d = theta.len();
    let split = |r: Option<DMatrix<f64>>| -> Option<(DMatrix<f64>, DVector<f64>)> {
        let r = r.filter(|r| r.nrows() >= d)?;
        let r11 = r.view((0, 0), (d, d)).into_owned();
        let grad = r11.transpose() * r.view((0, d), (d, 1)).column(0) * 2.0;
        Some((r11, grad))
    };
    let (mut cost, r) = problem.evaluate(&theta, true)?;
    let Some((mut r11, mut grad)) = split(r) else {
        return Ok((theta, cost, DMatrix::zeros(d, d), 0));
    };
    let mut hess = r11.transpose() * &r11 * 2.0;
    let mut iterations = 0;
    while iterations < max_iterations {
        iterations += 1;
        // p = −B⁻¹ g, B shifted towards its diagonal until positive definite.
        let mut shift = 0.0;
        let step = loop {
            let mut b = hess.clone();
            for j in 0..d {
                b[(j, j)] += shift * hess[(j, j)].abs().max(f64::MIN_POSITIVE);
            }
            if let Some(ch) = b.cholesky() {
                break Some(-ch.solve(&grad));
            }
            shift = if shift == 0.0 { 1e-8 } else { shift * 10.0 };
            if shift > 1e8 {
                break None;
            }
        };
        let Some(p) = step else { break };
        let slope = grad.dot(&p);
        if -slope <= tolerance * cost {
            break;
        }
        let mut alpha = 1.0;
        let mut accepted = None;
        while alpha >= 1.0 / 1_048_576.0 {
            let trial: Vec<f64> = theta
                .iter()
                .zip(p.iter())
                .map(|(a, b)| a + alpha * b)
                .collect();
            if problem.admissible(&trial) {
                let (c, _) = problem.evaluate(&trial, false)?;
                if c.is_finite() && c <= cost + 1e-4 * alpha * slope {
                    accepted = Some((trial, c));
                    break;
                }
            }
            alpha *= 0.5;
        }
        let Some((trial, c)) = accepted else { break };
        let (_, r) = problem.evaluate(&trial, true)?;
        let Some((r11_new, grad_new)) = split(r) else {
            break;
        };
        let s = DVector::from_iterator(d, trial.iter().zip(&theta).map(|(a, b)| a - b));
        let y = &grad_new - &grad;
        let ys = y.dot(&s);
        let bs = &hess * &s;
        let sbs = s.dot(&bs);
        if ys > 1e-12 * y.norm() * s.norm() && sbs > 0.0 {
            hess += &y * y.transpose() / ys - &bs * bs.transpose() / sbs;
        }
        let small_gain = cost - c <= tolerance * cost;
        theta = trial;
        cost = c;
        r11 = r11_new;
        grad = grad_new;
        if small_gain {
            break;
        }
    }
    Ok((theta, cost, r11, iterations))
}

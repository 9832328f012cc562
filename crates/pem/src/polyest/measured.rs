//! The prediction error of a polynomial model on the samples where its
//! output was measured (NaN elsewhere): ARMAX, Box–Jenkins and the general
//! structure with a diagonal A on multirate records.
//!
//! With A diagonal, output i is y = s + v with the simulated part
//! s = (1/A) Σ_k (B_k/F_k) u_k(t − nk_k), known at every fast instant,
//! and the noise v = C/(A D) e, an ARMA process observed only where y was.
//! Its one-step predictor from the *measured* past is a Kalman filter on a
//! state-space form of C/(A D) that skips the update where y is missing
//! (Jones 1980, "Maximum likelihood fitting of ARMA models to time series
//! with missing observations", Technometrics 22(3)): in the observer form
//! x(t+1) = Φ x(t) + k e(t), v(t) = x₁(t) + e(t) (Φ's first column
//! −(ā₁ … ā_n), ones above the diagonal; kⱼ = cⱼ − āⱼ; Ā = A D), with
//! Var e = λ and P in units of λ,
//!
//! ```text
//!   measured:  ε = v − x̂₁,  f = P₁₁ + 1,  κ = (Φ P e₁ + k)/f,
//!              x̂ ← Φ x̂ + κ ε,  P ← Φ P Φᵀ + k kᵀ − f κ κᵀ;
//!   missing:   x̂ ← Φ x̂,        P ← Φ P Φᵀ + k kᵀ,
//! ```
//!
//! from x̂ = 0, P = 0 (zero initial conditions, as the full-rate predictor):
//! with every sample measured P stays 0, f = 1 and ε is the full-rate
//! ε = (D/C)(A y − Σ (B/F) u) exactly. The innovation ε at a measured
//! sample has variance λ f, so the Gaussian likelihood concentrated in λ
//! is minimised by the least-squares problem in the scaled residuals
//! r = g ε/√f, g = (Π f)^{1/(2M)} over the M measured samples (Jones 1980,
//! §3; Harvey 1989, §3.4's prediction-error decomposition).
//!
//! **Jacobian.** Given (A, C, D) the filter is linear in v, so for the B
//! and F coefficients ∂ε/∂θ is the same filter run on −∂s/∂θ
//! (∂s/∂b_kj = (1/A) u_k(t − nk − j)/F_k, ∂s/∂f_kj = −(1/(A F_k)) w_k(t − j)):
//! analytic, in the same pass (x̂ carries one column per parameter). The
//! A, C and D coefficients change the filter's gains through its Riccati
//! recursion; their columns are central differences of r (step
//! 1e-5 (1 + |θⱼ|), one-sided where a side leaves C or D unstable): two
//! residual passes per coefficient.
//!
//! Cost: O(N n (1 + d_G)) per pass once the covariance recursion has
//! converged (an output read every P samples: after a few periods; until
//! then, and for irregular patterns, O(n²) more per sample), n = max(na +
//! nd, nc), d_G the B and F coefficients; a Jacobian is one pass plus
//! 2 (na + nc + nd) residual passes. Memory O(M d) for the Jacobian's rows
//! of one record.

use lifted_subspace::Experiment;
use nalgebra::DMatrix;

use super::Output;
use crate::error::Result;
use crate::filters::{Residuals, RowFolder, filter, fir_apply};

/// Whether output `i` of any record has an unmeasured (NaN) sample.
pub(super) fn has_missing(experiments: &[Experiment<'_>], i: usize) -> bool {
    experiments
        .iter()
        .any(|e| e.y.column(i).iter().any(|v| v.is_nan()))
}

/// The coefficients after the leading 1 of (1 + a₁q⁻¹ + …)(1 + d₁q⁻¹ + …).
fn monic_product(a: &[f64], d: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len() + d.len()];
    for (i, o) in out.iter_mut().enumerate() {
        let j = i + 1;
        // Coefficient of q^{-j}: a_j + d_j + Σ a_l d_{j−l}.
        let mut v = a.get(i).copied().unwrap_or(0.0) + d.get(i).copied().unwrap_or(0.0);
        for l in 1..j {
            if let (Some(al), Some(dm)) = (a.get(l - 1), d.get(j - l - 1)) {
                v += al * dm;
            }
        }
        *o = v;
    }
    out
}

/// The noise model C/Ā in observer form (module docs).
struct Observer {
    /// ā₁ … ā_n (zero-padded).
    abar: Vec<f64>,
    /// kⱼ = cⱼ − āⱼ.
    k: Vec<f64>,
}

impl Observer {
    fn new(abar: &[f64], c: &[f64]) -> Self {
        let n = abar.len().max(c.len());
        let at = |v: &[f64], j: usize| v.get(j).copied().unwrap_or(0.0);
        Observer {
            abar: (0..n).map(|j| at(abar, j)).collect(),
            k: (0..n).map(|j| at(c, j) - at(abar, j)).collect(),
        }
    }

    fn n(&self) -> usize {
        self.abar.len()
    }

    /// x ← Φ x for a state stored with stride 1 (x₁ first).
    fn phi(&self, x: &mut [f64]) {
        let n = self.n();
        let x1 = x[0];
        for j in 0..n {
            let next = if j + 1 < n { x[j + 1] } else { 0.0 };
            x[j] = next - self.abar[j] * x1;
        }
    }

    /// P ← Φ P Φᵀ + k kᵀ (P n×n, column-major), minus f κ κᵀ when `update`
    /// = Some((f, κ)).
    fn riccati(&self, p: &mut [f64], update: Option<(f64, &[f64])>) {
        let n = self.n();
        // Φ on every column, then on every row (P symmetric).
        for c in 0..n {
            self.phi(&mut p[c * n..(c + 1) * n]);
        }
        let mut row = vec![0.0; n];
        for r in 0..n {
            for c in 0..n {
                row[c] = p[c * n + r];
            }
            self.phi(&mut row);
            for c in 0..n {
                p[c * n + r] = row[c];
            }
        }
        for c in 0..n {
            for r in 0..n {
                let mut v = p[c * n + r] + self.k[r] * self.k[c];
                if let Some((f, kappa)) = update {
                    v -= f * kappa[r] * kappa[c];
                }
                p[c * n + r] = v;
            }
        }
        for c in 0..n {
            for r in (c + 1)..n {
                let m = 0.5 * (p[c * n + r] + p[r * n + c]);
                p[c * n + r] = m;
                p[r * n + c] = m;
            }
        }
    }
}

/// A signal whose lag is a Jacobian input: ±`signal`(t − `lag`).
struct LaggedColumn {
    signal: usize,
    lag: usize,
    sign: f64,
}

/// One record's pass: at its measured samples the innovations ε, their
/// variances f (units of λ) and, with the analytic columns, ∂ε/∂θ for the
/// B and F coefficients (in θ's order: every B, then every F).
struct Pass {
    eps: Vec<f64>,
    f: Vec<f64>,
    /// Measured samples × analytic columns, row-major.
    grad: Vec<f64>,
}

/// The pass of output `i` of record `e` for the polynomials `p`.
fn pass(e: &Experiment<'_>, i: usize, p: &Output, jacobian: bool) -> Pass {
    filtered(e, i, p, &simulated(e, i, p, jacobian), jacobian)
}

/// The simulated part s = (1/A) Σ (B/F) u of output `i` of record `e` and,
/// with `jacobian`, the signals whose lags are the B and F columns' inputs.
struct Simulated {
    s: Vec<f64>,
    signals: Vec<Vec<f64>>,
    columns: Vec<LaggedColumn>,
}

fn simulated(e: &Experiment<'_>, i: usize, p: &Output, jacobian: bool) -> Simulated {
    let n = e.u.nrows();
    let a = &p.a[i];
    let mut w_total = vec![0.0; n];
    let mut signals: Vec<Vec<f64>> = Vec::new();
    let mut columns: Vec<LaggedColumn> = Vec::new();
    let mut f_columns: Vec<LaggedColumn> = Vec::new();
    for (k, b) in p.b.iter().enumerate() {
        let (v, w) = crate::filters::input_response(e, k, b, &p.f[k], p.nk[k]);
        for (t, wt) in w.iter().enumerate() {
            w_total[t] += wt;
        }
        if jacobian {
            // −∂s/∂b_kj = −(1/A) v_k(t − j).
            let mut av = Vec::new();
            filter(&v, a, 0, &mut av);
            signals.push(av);
            for j in 0..b.len() {
                columns.push(LaggedColumn {
                    signal: signals.len() - 1,
                    lag: j,
                    sign: -1.0,
                });
            }
            // −∂s/∂f_kj = (1/(A F_k)) w_k(t − j).
            if !p.f[k].is_empty() {
                let (mut z, mut az) = (Vec::new(), Vec::new());
                filter(&w, &p.f[k], 0, &mut z);
                filter(&z, a, 0, &mut az);
                signals.push(az);
                for j in 1..=p.f[k].len() {
                    f_columns.push(LaggedColumn {
                        signal: signals.len() - 1,
                        lag: j,
                        sign: 1.0,
                    });
                }
            }
        }
    }
    columns.extend(f_columns);
    let mut s = Vec::new();
    filter(&w_total, a, 0, &mut s);
    Simulated {
        s,
        signals,
        columns,
    }
}

/// The Kalman filter's pass over output `i` of record `e` given its
/// simulated part `sim` (module docs), with the analytic columns when
/// `jacobian`.
fn filtered(e: &Experiment<'_>, i: usize, p: &Output, sim: &Simulated, jacobian: bool) -> Pass {
    let n = e.u.nrows();
    let none = Vec::new();
    let (s, signals) = (&sim.s, &sim.signals);
    let columns = if jacobian { &sim.columns } else { &none };
    let obs = Observer::new(&monic_product(&p.a[i], &p.d), &p.c);
    let ns = obs.n();
    let dg = columns.len();
    // x̂: column 0 the state for v, column 1 + j for parameter j's input.
    let mut x = vec![0.0; ns * (1 + dg)];
    let mut cov = Covariance::new(&obs);
    let mut kappa = vec![0.0; ns];
    let y = e.y.column(i);
    let mut out = Pass {
        eps: Vec::new(),
        f: Vec::new(),
        grad: Vec::new(),
    };
    for t in 0..n {
        let yt = y[t];
        if yt.is_nan() {
            if ns > 0 {
                for c in 0..=dg {
                    obs.phi(&mut x[c * ns..(c + 1) * ns]);
                }
                cov.missing();
            }
            continue;
        }
        let z0 = yt - s[t];
        if ns == 0 {
            out.eps.push(z0);
            out.f.push(1.0);
            for col in columns {
                let sig = &signals[col.signal];
                out.grad.push(if t >= col.lag {
                    col.sign * sig[t - col.lag]
                } else {
                    0.0
                });
            }
            continue;
        }
        let f = cov.measured(&mut kappa);
        for c in 0..=dg {
            let zc = if c == 0 {
                z0
            } else {
                let col = &columns[c - 1];
                let sig = &signals[col.signal];
                if t >= col.lag {
                    col.sign * sig[t - col.lag]
                } else {
                    0.0
                }
            };
            let xs = &mut x[c * ns..(c + 1) * ns];
            let ec = zc - xs[0];
            if c == 0 {
                out.eps.push(ec);
            } else {
                out.grad.push(ec);
            }
            obs.phi(xs);
            for (xj, kj) in xs.iter_mut().zip(&kappa) {
                *xj += kj * ec;
            }
        }
        out.f.push(f);
    }
    out
}

/// Relative change of the filter's covariance after a measured update,
/// between two updates after the same gap, below which it is taken as
/// converged ([`Covariance`]): 1e-14, a hundred times the rounding of
/// the recursion, so the frozen gains differ from the exact ones by that
/// much at most.
const CONVERGED: f64 = 1e-14;

/// The filter's covariance recursion (module docs), frozen once periodic:
/// when the covariance after a measured update repeats (to
/// [`CONVERGED`]) after two equal gaps between measured samples, the gain
/// and variance of that gap are reused and the recursion is skipped until
/// a gap of another length comes (the recursion then resumes from the
/// frozen covariance). An output read every P samples pays the O(n²)
/// recursion over its first few periods only; a pass then costs O(n) per
/// sample and column.
struct Covariance<'o> {
    obs: &'o Observer,
    /// P(t | t − 1), in units of λ (live recursion only).
    p: Vec<f64>,
    /// Unmeasured samples since the last measured one.
    missing: usize,
    /// The gap before the last measured update and P after it.
    last_gap: Option<usize>,
    last_p: Vec<f64>,
    frozen: Option<Frozen>,
}

/// A converged gap's variance f, gain κ and covariance after its update.
struct Frozen {
    gap: usize,
    f: f64,
    kappa: Vec<f64>,
    p_next: Vec<f64>,
}

impl<'o> Covariance<'o> {
    fn new(obs: &'o Observer) -> Self {
        let n = obs.n();
        Covariance {
            obs,
            p: vec![0.0; n * n],
            missing: 0,
            last_gap: None,
            last_p: vec![0.0; n * n],
            frozen: None,
        }
    }

    fn missing(&mut self) {
        self.missing += 1;
        if self.frozen.is_none() {
            self.obs.riccati(&mut self.p, None);
        }
    }

    /// The measured sample's f = P₁₁ + 1, with κ = (Φ P e₁ + k)/f written
    /// to `kappa`, and the update of P.
    fn measured(&mut self, kappa: &mut [f64]) -> f64 {
        let gap = self.missing + 1;
        self.missing = 0;
        if let Some(fr) = self.frozen.take() {
            if fr.gap == gap {
                kappa.copy_from_slice(&fr.kappa);
                let f = fr.f;
                self.frozen = Some(fr);
                return f;
            }
            // Another gap: the recursion from the frozen covariance.
            self.p.copy_from_slice(&fr.p_next);
            for _ in 1..gap {
                self.obs.riccati(&mut self.p, None);
            }
            self.last_gap = None;
        }
        let ns = self.obs.n();
        let f = self.p[0] + 1.0;
        kappa.copy_from_slice(&self.p[0..ns]);
        self.obs.phi(kappa);
        for (kj, k) in kappa.iter_mut().zip(&self.obs.k) {
            *kj = (*kj + k) / f;
        }
        self.obs.riccati(&mut self.p, Some((f, kappa)));
        if self.last_gap == Some(gap) {
            let scale = self.p.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let change = self
                .p
                .iter()
                .zip(&self.last_p)
                .fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
            if change <= CONVERGED * scale {
                self.frozen = Some(Frozen {
                    gap,
                    f,
                    kappa: kappa.to_vec(),
                    p_next: self.p.clone(),
                });
            }
        }
        self.last_gap = Some(gap);
        self.last_p.copy_from_slice(&self.p);
        f
    }
}

/// Output `i`'s problem on the measured samples (module docs), θ in the
/// layout of `shape`.
pub(super) struct MeasuredPredictionError<'a, 'e> {
    pub(super) experiments: &'a [Experiment<'e>],
    pub(super) i: usize,
    pub(super) shape: &'a Output,
}

/// What a problem's passes give at θ: the scaled residuals r of every
/// record in turn, Σ ε²/f, M and the scale g.
struct Scaled {
    r: Vec<f64>,
    /// Per record, its passes (kept for the analytic columns).
    passes: Vec<Pass>,
    g: f64,
}

impl MeasuredPredictionError<'_, '_> {
    fn scaled(&self, p: &Output, jacobian: bool) -> Scaled {
        let passes: Vec<Pass> = self
            .experiments
            .iter()
            .map(|e| pass(e, self.i, p, jacobian))
            .collect();
        Self::scaled_from(passes)
    }

    /// [`Self::scaled`] of the polynomials `p` whose B, F and A are those
    /// the records' simulated parts `sims` were computed with (only C or D
    /// differ): the filter passes alone.
    fn scaled_noise(&self, p: &Output, sims: &[Simulated]) -> Scaled {
        let passes: Vec<Pass> = self
            .experiments
            .iter()
            .zip(sims)
            .map(|(e, sim)| filtered(e, self.i, p, sim, false))
            .collect();
        Self::scaled_from(passes)
    }

    fn scaled_from(passes: Vec<Pass>) -> Scaled {
        let m: usize = passes.iter().map(|q| q.eps.len()).sum();
        let log_f: f64 = passes.iter().flat_map(|q| q.f.iter()).map(|f| f.ln()).sum();
        let g = if m > 0 {
            (log_f / (2.0 * m as f64)).exp()
        } else {
            1.0
        };
        let r = passes
            .iter()
            .flat_map(|q| q.eps.iter().zip(&q.f).map(move |(e, f)| g * e / f.sqrt()))
            .collect();
        Scaled { r, passes, g }
    }

    /// (Σ ε²/f, Σ ε², M) at θ: the innovations' weighted and plain sums
    /// of squares over the measured samples.
    pub(super) fn sums(&self, theta: &[f64]) -> (f64, f64, usize) {
        let p = self.shape.with(theta);
        let (mut weighted, mut plain, mut m) = (0.0, 0.0, 0);
        for e in self.experiments {
            let q = pass(e, self.i, &p, false);
            for (ev, f) in q.eps.iter().zip(&q.f) {
                weighted += ev * ev / f;
                plain += ev * ev;
            }
            m += q.eps.len();
        }
        (weighted, plain, m)
    }

    /// The ranges of θ (layout of [`Output::pack`]) whose columns are
    /// numerical: A, then C and D; the rest (B, then F) analytic.
    fn numerical(&self) -> Vec<usize> {
        let na: usize = self.shape.a.iter().map(Vec::len).sum();
        let nb: usize = self.shape.b.iter().map(Vec::len).sum();
        let ncd = self.shape.c.len() + self.shape.d.len();
        (0..na).chain(na + nb..na + nb + ncd).collect()
    }
}

impl Residuals for MeasuredPredictionError<'_, '_> {
    fn evaluate(&self, theta: &[f64], jacobian: bool) -> Result<(f64, Option<DMatrix<f64>>)> {
        let p = self.shape.with(theta);
        if !jacobian {
            let base = self.scaled(&p, false);
            return Ok((base.r.iter().map(|v| v * v).sum(), None));
        }
        // The simulated parts once: the C and D columns' passes reuse them.
        let sims: Vec<Simulated> = self
            .experiments
            .iter()
            .map(|e| simulated(e, self.i, &p, true))
            .collect();
        let passes: Vec<Pass> = self
            .experiments
            .iter()
            .zip(&sims)
            .map(|(e, sim)| filtered(e, self.i, &p, sim, true))
            .collect();
        let base = Self::scaled_from(passes);
        let cost = base.r.iter().map(|v| v * v).sum();
        let d = theta.len();
        let numerical = self.numerical();
        let na = self.shape.a[self.i].len();
        let mut columns: Vec<Vec<f64>> = Vec::with_capacity(numerical.len());
        for &j in &numerical {
            let h = 1e-5 * (1.0 + theta[j].abs());
            let at = |delta: f64| {
                let mut th = theta.to_vec();
                th[j] += delta;
                let q = self.shape.with(&th);
                // A moves the simulated part; C and D only the filter.
                self.admissible(&th).then(|| {
                    if j < na {
                        self.scaled(&q, false).r
                    } else {
                        self.scaled_noise(&q, &sims).r
                    }
                })
            };
            let col = crate::filters::difference_column(at(h), at(-h), &base.r, h);
            columns.push(col);
        }
        let mut rows = RowFolder::new(d + 1);
        let mut row = 0;
        let mut kinds = vec![None; d];
        for (c, &j) in numerical.iter().enumerate() {
            kinds[j] = Some(c);
        }
        for q in &base.passes {
            let dg = d - numerical.len();
            for (t, (ev, f)) in q.eps.iter().zip(&q.f).enumerate() {
                let w = base.g / f.sqrt();
                let mut analytic = q.grad[t * dg..(t + 1) * dg].iter();
                let mut entries = Vec::with_capacity(d + 1);
                for kind in &kinds {
                    entries.push(match kind {
                        Some(c) => columns[*c][row],
                        None => w * analytic.next().copied().unwrap_or(0.0),
                    });
                }
                entries.push(w * ev);
                rows.push(entries)?;
                row += 1;
            }
        }
        Ok((cost, Some(rows.finish()?)))
    }

    fn admissible(&self, theta: &[f64]) -> bool {
        self.shape.with(theta).admissible()
    }
}

/// (1 − p q⁻¹)ⁿ's coefficients after the leading 1.
fn repeated_root(p: f64, n: usize) -> Vec<f64> {
    let mut v: Vec<f64> = Vec::new();
    for _ in 0..n {
        v = monic_product(&v, &[-p]);
    }
    v
}

/// The starts of output `i` on records with unmeasured samples (the
/// full-rate start's Hannan–Rissanen regressions need every sample); the
/// iterations run from each and the lower cost is kept:
///
/// 1. B and F from the output-error model ([`crate::oe`], multirate
///    records included) of [nb nf nk] — for ARMAX [nb na nk], A then the F
///    of the input whose simulated contribution is largest and the B's
///    refitted to the measured samples by least squares with that A;
/// 2. B and F (ARMAX: A and B) from a long ARX model of the output
///    interpolated between its measured samples ([`interpolated_start`]).
///
/// Each with the noise polynomials of lowest cost among C ∈ {0, A} (C = A
/// is the output-error model written as ARMAX) and, with nd > 0,
/// D = (1 − ρ q⁻¹)^nd for ρ ∈ [`NOISE_POLES`] — ρ = 0 is not among them:
/// D = 1 is a stationary point of the cost when the output is measured
/// every P ≥ 2 samples (the noise's correlation at lag P is of order ρ^P,
/// its derivative in ρ zero at 0), where the iterations would not move D
/// and the Jacobian's D columns vanish.
///
/// Why two: on a record taken under feedback the output-error model is
/// biased (the noise reaches u through the controller), and on one of
/// four seeds of issue 46's SISO loop (PI on every 4th sample) the
/// iterations from it ended in a minimum 0.035 above the true parameters'
/// cost with FR error 0.18; the long ARX's start, biased only by the
/// interpolation, lands in the true parameters' basin there (OE's own
/// second start gave the first one's point to 1e-3).
pub(super) fn starts(
    experiments: &[Experiment<'_>],
    i: usize,
    shape: &Output,
    ts: f64,
    oe: &crate::OeOptions,
) -> Result<Vec<Output>> {
    let mut out = vec![start(experiments, i, shape, ts, oe)?];
    if let Some(p) = interpolated_start(experiments, i, shape) {
        let p = with_noise_start(experiments, i, p);
        if p.admissible() && !out.contains(&p) {
            out.push(p);
        }
    }
    Ok(out)
}

/// A start that is consistent under feedback up to the interpolation:
/// output `i` interpolated linearly between its measured samples (held
/// before the first and after the last), a long ARX model of it on every
/// input (na = nb = `long` as the full-rate start's, the delays of
/// `shape`; an ARX model is consistent in closed loop when it is long
/// enough, Ljung 1999 §13.4), its deterministic response to each input
/// simulated without noise, and [na nb nk] (ARMAX: one A for the inputs'
/// summed response) or per input [nf nb nk] fitted to it by least
/// squares — the OE start's FIR-then-ARX with the long ARX's response in
/// place of the FIR's. `None` when a record has fewer than two measured
/// samples of the output or a fit fails.
fn interpolated_start(experiments: &[Experiment<'_>], i: usize, shape: &Output) -> Option<Output> {
    let na = shape.a[i].len();
    let nu = shape.b.len();
    let armax = na > 0 && shape.f.iter().all(Vec::is_empty);
    let params = na + shape.c.len() + shape.d.len() + shape.f.iter().map(Vec::len).sum::<usize>();
    let total: usize = experiments.iter().map(|e| e.u.nrows()).sum();
    let long = (4 * (params + 1))
        .clamp(10, 40)
        .min((total / (8 * (nu + 1))).max(1));
    let ys: Vec<DMatrix<f64>> = experiments
        .iter()
        .map(|e| {
            let col: Vec<f64> = e.y.column(i).iter().copied().collect();
            lifted_lti::interpolate_unmeasured(&col).map(|v| DMatrix::from_vec(v.len(), 1, v))
        })
        .collect::<Option<_>>()?;
    let exps: Vec<Experiment<'_>> = experiments
        .iter()
        .zip(&ys)
        .map(|(e, y)| Experiment { u: e.u, y })
        .collect();
    let nk: Vec<usize> = shape.nk.clone();
    let long_orders = lifted_lti::PolyOrders {
        na: vec![vec![long]],
        nb: vec![
            shape
                .b
                .iter()
                .map(|b| if b.is_empty() { 0 } else { long })
                .collect(),
        ],
        nc: vec![0],
        nd: vec![0],
        nf: vec![vec![0; nu]],
        nk: vec![nk.clone()],
    };
    let one_thread = crate::ArxOptions {
        threads: 1,
        ..Default::default()
    };
    let arx = crate::arx(&exps, &long_orders, 1.0, &one_thread)
        .ok()?
        .model;
    let a_long = &arx.a(0, 0)[1..];
    // Each input's noise-free response through the long ARX, per record.
    let responses: Vec<Vec<Vec<f64>>> = experiments
        .iter()
        .map(|e| {
            (0..nu)
                .map(|k| {
                    let uk: Vec<f64> = e.u.column(k).iter().copied().collect();
                    let (mut v, mut w) = (Vec::new(), Vec::new());
                    filter(&uk, a_long, nk[k], &mut v);
                    fir_apply(&v, arx.b(0, k), &mut w);
                    w
                })
                .collect()
        })
        .collect();
    let fit = |u: DMatrix<f64>, y: Vec<f64>, orders: lifted_lti::PolyOrders| {
        let y = DMatrix::from_vec(y.len(), 1, y);
        crate::arx(&[Experiment { u: &u, y: &y }], &orders, 1.0, &one_thread)
            .ok()
            .map(|f| f.model)
    };
    // The longest record carries the fit (the responses are noise free).
    let longest = (0..experiments.len()).max_by_key(|&r| experiments[r].u.nrows())?;
    let e = &experiments[longest];
    let mut p = shape.clone();
    if armax {
        let sum: Vec<f64> = (0..e.u.nrows())
            .map(|t| responses[longest].iter().map(|w| w[t]).sum())
            .collect();
        let orders = lifted_lti::PolyOrders {
            na: vec![vec![na]],
            nb: vec![shape.b.iter().map(Vec::len).collect()],
            nc: vec![0],
            nd: vec![0],
            nf: vec![vec![0; nu]],
            nk: vec![nk],
        };
        let m = fit(e.u.clone(), sum, orders)?;
        p.a[i] = m.a(0, 0)[1..].to_vec();
        for k in 0..nu {
            p.b[k] = m.b(0, k).to_vec();
        }
    } else {
        for k in 0..nu {
            let (nb, nf) = (shape.b[k].len(), shape.f[k].len());
            if nb == 0 {
                continue;
            }
            let orders = lifted_lti::PolyOrders::siso(nf, nb, 0, 0, 0, nk[k]);
            let uk = e.u.columns(k, 1).into_owned();
            let m = fit(uk, responses[longest][k].clone(), orders)?;
            p.b[k] = m.b(0, 0).to_vec();
            p.f[k] = m.a(0, 0)[1..].to_vec();
        }
        if na > 0 {
            // A beside F (the general structure): A from the start's zero.
            p.a[i] = vec![0.0; na];
        }
    }
    Some(p)
}

/// The output-error start of [`starts`] (its item 1).
fn start(
    experiments: &[Experiment<'_>],
    i: usize,
    shape: &Output,
    ts: f64,
    oe: &crate::OeOptions,
) -> Result<Output> {
    let na = shape.a[i].len();
    let nb: Vec<usize> = shape.b.iter().map(Vec::len).collect();
    let nf: Vec<usize> = shape.f.iter().map(Vec::len).collect();
    let armax = na > 0 && nf.iter().all(|&f| f == 0);
    let ys = crate::filters::output_columns(experiments, i);
    let exps = crate::filters::with_outputs(experiments, &ys);
    let nu = nb.len();
    let oe_orders = lifted_lti::PolyOrders {
        na: vec![vec![0]],
        nb: vec![nb.clone()],
        nc: vec![0],
        nd: vec![0],
        nf: vec![if armax {
            nb.iter().map(|&b| if b > 0 { na } else { 0 }).collect()
        } else {
            nf.clone()
        }],
        nk: vec![shape.nk.clone()],
    };
    let mut p = shape.clone();
    if let Ok(g) = crate::oe(&exps, &oe_orders, ts, oe) {
        for k in 0..nu {
            p.b[k] = g.model.b(0, k).to_vec();
            if !armax {
                p.f[k] = g.model.f(0, k)[1..].to_vec();
            }
        }
        if armax {
            let largest = (0..nu)
                .filter(|&k| nb[k] > 0)
                .map(|k| (k, contribution(experiments, &g.model, k)))
                .max_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((k, _)) = largest {
                p.a[i] = g.model.f(0, k)[1..].to_vec();
                if let Some(b) = refit_b(experiments, i, &p) {
                    p.b = b;
                }
            }
        }
    }
    Ok(with_noise_start(experiments, i, p))
}

/// `p` with the noise candidate of lowest cost ([`starts`]).
fn with_noise_start(experiments: &[Experiment<'_>], i: usize, p: Output) -> Output {
    let problem = MeasuredPredictionError {
        experiments,
        i,
        shape: &p,
    };
    let na = p.a[i].len();
    let nc = p.c.len();
    let mut c_options = vec![vec![0.0; nc]];
    if na > 0 && nc > 0 {
        let c: Vec<f64> = (0..nc)
            .map(|j| p.a[i].get(j).copied().unwrap_or(0.0))
            .collect();
        if crate::filters::stable(&c) {
            c_options.push(c);
        }
    }
    let nd = p.d.len();
    let d_options: Vec<Vec<f64>> = if nd == 0 {
        vec![Vec::new()]
    } else {
        NOISE_POLES.iter().map(|&r| repeated_root(r, nd)).collect()
    };
    let mut best: Option<(f64, Output)> = None;
    for c in &c_options {
        for d in &d_options {
            let mut q = p.clone();
            q.c = c.clone();
            q.d = d.clone();
            if !q.admissible() {
                continue;
            }
            let Ok((cost, _)) = problem.evaluate(&q.pack(), false) else {
                continue;
            };
            if cost.is_finite() && best.as_ref().is_none_or(|(b, _)| cost < *b) {
                best = Some((cost, q));
            }
        }
    }
    best.map_or(p, |(_, q)| q)
}

/// The noise poles of the starts' D candidates (docs of
/// [`starts`]): a grid from fast to slow noise (±, an oscillating noise
/// too), the one of lowest cost kept; not a tuned number (every candidate
/// is scored on the record).
pub(super) const NOISE_POLES: [f64; 6] = [-0.5, 0.2, 0.5, 0.8, 0.9, 0.98];

/// Σ (B_k/F_k u_k)² of input `k` of output 0 of `model` over the records.
fn contribution(experiments: &[Experiment<'_>], model: &lifted_lti::PolyModel, k: usize) -> f64 {
    let b = model.b(0, k);
    let f = &model.f(0, k)[1..];
    let nk = model.nk(0, k);
    experiments
        .iter()
        .map(|e| {
            let (_, w) = crate::filters::input_response(e, k, b, f, nk);
            w.iter().map(|x| x * x).sum::<f64>()
        })
        .sum()
}

/// B of output `i` by least squares on its measured samples with A, F and
/// the delays of `p` fixed: y(t) = Σ_k Σ_j b_kj (1/(A F_k)) u_k(t − nk − j)
/// (R-only QR of the rows); `None` when the regressors are rank deficient.
fn refit_b(experiments: &[Experiment<'_>], i: usize, p: &Output) -> Option<Vec<Vec<f64>>> {
    let d: usize = p.b.iter().map(Vec::len).sum();
    if d == 0 {
        return None;
    }
    let mut rows = RowFolder::new(d + 1);
    for e in experiments {
        let signals: Vec<Vec<f64>> =
            p.b.iter()
                .enumerate()
                .map(|(k, _)| {
                    let uk: Vec<f64> = e.u.column(k).iter().copied().collect();
                    let (mut v, mut av) = (Vec::new(), Vec::new());
                    filter(&uk, &p.f[k], p.nk[k], &mut v);
                    filter(&v, &p.a[i], 0, &mut av);
                    av
                })
                .collect();
        for (t, yt) in e.y.column(i).iter().enumerate() {
            if yt.is_nan() {
                continue;
            }
            let row = p.b.iter().enumerate().flat_map(|(k, b)| {
                let sig = &signals[k];
                (0..b.len()).map(move |j| if t >= j { sig[t - j] } else { 0.0 })
            });
            rows.push(row.chain([*yt]).collect::<Vec<_>>()).ok()?;
        }
    }
    let r = rows.finish().ok()?;
    if r.nrows() < d {
        return None;
    }
    let r11 = r.view((0, 0), (d, d)).into_owned();
    let scale = (0..d).map(|j| r11[(j, j)].abs()).fold(0.0, f64::max);
    if (0..d).any(|j| r11[(j, j)].abs() <= 1e-10 * scale) {
        return None;
    }
    let x = r11.solve_upper_triangular(&r.view((0, d), (d, 1)).into_owned())?;
    let mut at = 0;
    Some(
        p.b.iter()
            .map(|b| {
                let v = x.as_slice()[at..at + b.len()].to_vec();
                at += b.len();
                v
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_frozen_covariance_gives_the_recursion_s_gains() {
        // C/Ā = (1 + 0.4q⁻¹)/(1 − 0.8q⁻¹)(1 − 0.5q⁻¹): the gains and variances of
        // the frozen recursion against the plain recursion run at every
        // sample, on gaps of 3 that switch to 5 and back (the frozen gap
        // left and re-entered).
        let obs = Observer::new(&monic_product(&[-0.8], &[-0.5]), &[0.4]);
        let n = obs.n();
        let mut frozen = Covariance::new(&obs);
        let mut plain = vec![0.0; n * n];
        let (mut k1, mut k2) = (vec![0.0; n], vec![0.0; n]);
        let gaps: Vec<usize> = (0..60)
            .map(|j| if (25..30).contains(&j) { 5 } else { 3 })
            .collect();
        let mut froze = false;
        for &gap in &gaps {
            for _ in 1..gap {
                frozen.missing();
                obs.riccati(&mut plain, None);
            }
            let f1 = frozen.measured(&mut k1);
            froze |= frozen.frozen.is_some();
            let f2 = plain[0] + 1.0;
            k2.copy_from_slice(&plain[0..n]);
            obs.phi(&mut k2);
            for (kj, k) in k2.iter_mut().zip(&obs.k) {
                *kj = (*kj + k) / f2;
            }
            obs.riccati(&mut plain, Some((f2, &k2)));
            assert!((f1 - f2).abs() <= 1e-12 * f2, "{f1} vs {f2}");
            for (a, b) in k1.iter().zip(&k2) {
                assert!((a - b).abs() <= 1e-12 * (1.0 + b.abs()), "{k1:?} vs {k2:?}");
            }
        }
        assert!(froze, "the recursion never converged");
    }

    #[test]
    fn monic_product_multiplies() {
        // (1 + 0.5q⁻¹)(1 − 0.2q⁻¹ + 0.1q⁻²) = 1 + 0.3q⁻¹ + 0q⁻² + 0.05q⁻³.
        let v = monic_product(&[0.5], &[-0.2, 0.1]);
        assert_eq!(v.len(), 3);
        for (a, b) in v.iter().zip([0.3, 0.0, 0.05]) {
            assert!((a - b).abs() < 1e-15, "{v:?}");
        }
        assert!(monic_product(&[], &[]).is_empty());
    }
}

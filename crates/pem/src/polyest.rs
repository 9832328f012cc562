//! ARMAX and Box–Jenkins models (and the general structure) by
//! prediction-error minimisation, MATLAB's `armax`, `bj`, `polyest`.
//!
//! Per output i,
//!
//! ```text
//!   Σ_j A_ij(q) y_j(t) = Σ_k B_k(q)/F_k(q) u_k(t − nk_k) + C(q)/D(q) e(t),
//! ```
//!
//! with A_ii monic and A_ij (j ≠ i) starting at q⁻¹ — a diagonal A (each
//! output's own past) or a coupled one (every output's past in every
//! equation, MATLAB's multi-output `armax` with an n_y × n_y `na`) — the
//! one-step prediction error is ε = (D/C) [Σ_j A_ij y_j − Σ_k (B_k/F_k) u_k]
//! (Ljung 1999, eq. (4.35) with (4.33)) and V = Σ ε²/N is minimised by
//! Levenberg–Marquardt with the analytic gradient (Ljung 1999, §10.3): with
//! s = Σ_j A_ij y_j − Σ w_k, w_k = (B_k/F_k) u_k(t − nk), every partial
//! derivative is a filtered signal —
//! ∂ε/∂a_ij,l = (D/C) y_j(t − l), ∂ε/∂b_kj = −(D/(C F_k)) u_k(t − nk − j),
//! ∂ε/∂f_kj = (D/(C F_k)) w_k(t − j), ∂ε/∂c_j = −(1/C) ε(t − j),
//! ∂ε/∂d_j = (1/C) s(t − j) — O(N d) flops per Jacobian; its rows are
//! folded into an R-only QR with ε (memory O(d²), JᵀJ never formed). The
//! outputs' equations share no parameter (C and D are per output), so each
//! is minimised on its own, the other outputs entering a coupled A as
//! known regressors. A
//! step that leaves C, D or any F with a root on or outside the unit circle
//! is rejected (the predictor and the noise model stay stable and
//! invertible). Zero initial conditions.
//!
//! **Starts** (Hannan & Rissanen 1982's two stages): ARMAX from a long ARX
//! model's residuals ê (a second least-squares fit of A, B and C with ê as
//! a known input, [`crate::arx`]; with a coupled A the other outputs are
//! inputs of both stages, delayed one sample); Box–Jenkins from the output-error model
//! ([`crate::oe`]) and an ARMA (C, D) fitted the same way to its residuals.
//!
//! **A common F.** With [`PolyestOptions::f_structure`]
//! [`crate::FStructure::Common`] an output's input terms share one F
//! (SIPPY's BJ; y = (1/F) Σ B_k u_k + (C/D) e): the iterations run on the
//! free parameters with the copies of F tied (`filters::Tied`: the
//! Jacobian J E, E repeating F's columns, its R factor that of [R E | r]
//! from the untied problem's R — no second Jacobian code), the start's
//! B/F from the common-F OE model; the model keeps a copy of F per input
//! and the covariance E Σ Eᵀ.
//!
//! **Closed loop.** The prediction-error method is consistent in closed
//! loop when the model set holds the true plant and noise model (the
//! direct method, Ljung 1999, §13.4): ARMAX and BJ are the structures for
//! records taken under feedback, OE and the FIR start are not (their
//! noise model is fixed).
//!
//! **Uncertainty.** Cov θ = λ̂ (JᵀJ)⁻¹ = λ̂ R₁₁⁻¹R₁₁⁻ᵀ, λ̂ = N V/(N − d)
//! (Ljung 1999, eq. (9.18)); outputs independent (block diagonal).
//!
//! **Multirate records.** An output with unmeasured (NaN) samples — an
//! analyser every P samples — is estimated on its measured samples: with
//! A diagonal, y = (1/A) Σ (B/F) u + C/(A D) e, and the one-step predictor
//! from the measured past is a Kalman filter on the noise model that skips
//! the missing samples (Jones 1980), the cost its concentrated Gaussian
//! likelihood; with every sample measured it is the predictor above
//! exactly. Equations, Jacobian and start in `polyest/measured.rs`. The
//! direct method's consistency in closed loop holds there too (the
//! likelihood is exact). With a coupled A the outputs' problems no longer
//! separate (an output's equation needs the others' unmeasured past):
//! all outputs are then estimated at once, by one Kalman filter on the
//! joint model and the likelihood of all measured values
//! (`polyest/coupled.rs`; A, B, C and per-input F; a D beside it is
//! refused). Not every noise
//! parameter is well determined from every P-th sample: the aliased noise
//! spectrum can be nearly flat in one of them (an MA coefficient of
//! ARMAX at P = 4, polyest's tests), which its interval then shows.

use lifted_lti::{PolyModel, PolyOrders, Polynomials};
use lifted_subspace::Experiment;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::filters::{
    Residuals, RowFolder, check_iterations, filter, fir_apply, minimise, output_columns, stable,
    with_outputs,
};

/// Options of [`polyest`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PolyestOptions {
    /// Largest number of Levenberg–Marquardt iterations per output
    /// (default 100).
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this
    /// fraction (default 1e-10), or the step is below its square root
    /// relative to θ.
    pub tolerance: f64,
    /// The F polynomials: one per input–output pair (the default,
    /// MATLAB's `bj`/`polyest`) or one per output shared by its input
    /// terms (SIPPY's BJ; [`crate::FStructure`], module docs).
    pub f_structure: crate::FStructure,
}

impl Default for PolyestOptions {
    fn default() -> Self {
        PolyestOptions {
            max_iterations: 100,
            tolerance: 1e-10,
            f_structure: crate::FStructure::PerInput,
        }
    }
}

/// An estimated polynomial model and what the iterations did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PolyestFit {
    /// The model, with the noise variances and the parameter covariance.
    pub model: PolyModel,
    /// Mean squared one-step prediction error per output (on its measured
    /// samples).
    pub loss: Vec<f64>,
    /// One-step prediction fit per output, percent: 100 (1 − ‖ε‖/‖y − ȳ‖)
    /// on the measured samples.
    pub fit: Vec<f64>,
    /// Samples per output the cost was taken on (its measured samples).
    pub measured: Vec<usize>,
    /// Free parameters per output (a common F counted once; the model's
    /// [`PolyModel::n_parameters`] counts its copies).
    pub parameters: Vec<usize>,
    /// Iterations run per output.
    pub iterations: Vec<usize>,
}

/// One output's polynomials: per output j the free part of A_ij (A_ii's
/// after its leading 1, A_ij's from q⁻¹), per input (b, f free, nk), c, d.
#[derive(Debug, Clone, PartialEq)]
struct Output {
    a: Vec<Vec<f64>>,
    b: Vec<Vec<f64>>,
    f: Vec<Vec<f64>>,
    nk: Vec<usize>,
    c: Vec<f64>,
    d: Vec<f64>,
}

impl Output {
    /// θ in [`PolyModel::parameters`]' order: a, B's, c, d, F's.
    fn pack(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self.a.concat();
        for b in &self.b {
            v.extend_from_slice(b);
        }
        v.extend_from_slice(&self.c);
        v.extend_from_slice(&self.d);
        for f in &self.f {
            v.extend_from_slice(f);
        }
        v
    }

    fn with(&self, theta: &[f64]) -> Output {
        let mut at = 0;
        let mut take = |n: usize| {
            let v = theta[at..at + n].to_vec();
            at += n;
            v
        };
        let a = self.a.iter().map(|a| take(a.len())).collect();
        let b = self.b.iter().map(|b| take(b.len())).collect();
        let c = take(self.c.len());
        let d = take(self.d.len());
        let f = self.f.iter().map(|f| take(f.len())).collect();
        Output {
            a,
            b,
            f,
            nk: self.nk.clone(),
            c,
            d,
        }
    }

    fn admissible(&self) -> bool {
        stable(&self.c) && stable(&self.d) && self.f.iter().all(|f| stable(f))
    }
}

/// x ↦ (D/C) x: multiply by D, divide by C.
fn noise_whiten(x: &[f64], c: &[f64], d: &[f64], out: &mut Vec<f64>) {
    let mut dx = Vec::new();
    let mut monic = vec![1.0];
    monic.extend_from_slice(d);
    fir_apply(x, &monic, &mut dx);
    filter(&dx, c, 0, out);
}

/// ε and (with `jacobian`) the columns ∂ε/∂θ for output `i` of one record.
fn residuals(
    e: &Experiment<'_>,
    i: usize,
    p: &Output,
    jacobian: bool,
) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = e.u.nrows();
    let column = |j: usize| -> Vec<f64> { e.y.column(j).iter().copied().collect() };
    // Every output a row of A reaches (its own always).
    let ys: Vec<Option<Vec<f64>>> = (0..p.a.len())
        .map(|j| (j == i || !p.a[j].is_empty()).then(|| column(j)))
        .collect();
    let mut s = ys.get(i).cloned().flatten().unwrap_or_else(|| column(i));
    for (a, yj) in p.a.iter().zip(&ys) {
        let Some(yj) = yj else { continue };
        for (l, al) in a.iter().enumerate() {
            for t in (l + 1)..n {
                s[t] += al * yj[t - l - 1];
            }
        }
    }
    let mut vs = Vec::with_capacity(p.b.len());
    let mut ws = Vec::with_capacity(p.b.len());
    for (k, b) in p.b.iter().enumerate() {
        let (v, w) = crate::filters::input_response(e, k, b, &p.f[k], p.nk[k]);
        for (st, wt) in s.iter_mut().zip(&w) {
            *st -= wt;
        }
        vs.push(v);
        ws.push(w);
    }
    let mut eps = Vec::new();
    noise_whiten(&s, &p.c, &p.d, &mut eps);
    if !jacobian {
        return (eps, Vec::new());
    }
    let lagged = |x: &[f64], j: usize, sign: f64| -> Vec<f64> {
        (0..n)
            .map(|t| if t >= j { sign * x[t - j] } else { 0.0 })
            .collect()
    };
    let mut cols = Vec::new();
    for (a, yj) in p.a.iter().zip(&ys) {
        let Some(yj) = yj else { continue };
        if a.is_empty() {
            continue;
        }
        let mut h = Vec::new();
        noise_whiten(yj, &p.c, &p.d, &mut h);
        for l in 1..=a.len() {
            cols.push(lagged(&h, l, 1.0));
        }
    }
    for (k, b) in p.b.iter().enumerate() {
        let mut pk = Vec::new();
        noise_whiten(&vs[k], &p.c, &p.d, &mut pk);
        for j in 0..b.len() {
            cols.push(lagged(&pk, j, -1.0));
        }
    }
    let (mut ec, mut sc) = (Vec::new(), Vec::new());
    filter(&eps, &p.c, 0, &mut ec);
    for j in 1..=p.c.len() {
        cols.push(lagged(&ec, j, -1.0));
    }
    filter(&s, &p.c, 0, &mut sc);
    for j in 1..=p.d.len() {
        cols.push(lagged(&sc, j, 1.0));
    }
    for (k, f) in p.f.iter().enumerate() {
        let (mut z, mut r) = (Vec::new(), Vec::new());
        filter(&ws[k], f, 0, &mut z);
        noise_whiten(&z, &p.c, &p.d, &mut r);
        for j in 1..=f.len() {
            cols.push(lagged(&r, j, 1.0));
        }
    }
    (eps, cols)
}

/// Σ ε² over the records, and (with `jacobian`) the R factor of [J | ε].
fn evaluate(
    experiments: &[Experiment<'_>],
    i: usize,
    p: &Output,
    jacobian: bool,
) -> Result<(f64, Option<DMatrix<f64>>)> {
    let d = p.pack().len();
    let mut rows = jacobian.then(|| RowFolder::new(d + 1));
    let mut cost = 0.0;
    for e in experiments {
        let (eps, cols) = residuals(e, i, p, jacobian);
        cost += eps.iter().map(|v| v * v).sum::<f64>();
        if let Some(rows) = rows.as_mut() {
            for (t, et) in eps.iter().enumerate() {
                rows.push(cols.iter().map(|c| c[t]).chain([*et]))?;
            }
        }
    }
    Ok((cost, rows.map(RowFolder::finish).transpose()?))
}

/// Output `i`'s prediction-error problem for [`minimise`] (θ in the
/// layout of `shape`).
struct PredictionError<'a, 'e> {
    experiments: &'a [Experiment<'e>],
    i: usize,
    shape: &'a Output,
}

impl Residuals for PredictionError<'_, '_> {
    fn evaluate(&self, theta: &[f64], jacobian: bool) -> Result<(f64, Option<DMatrix<f64>>)> {
        evaluate(self.experiments, self.i, &self.shape.with(theta), jacobian)
    }

    fn admissible(&self, theta: &[f64]) -> bool {
        self.shape.with(theta).admissible()
    }
}

/// Second stage of Hannan–Rissanen: least squares of y on its own lags
/// (na), the inputs (nb, nk) and the first-stage residuals ê (nc lags from
/// 1), through [`crate::arx`] with ê as an extra input. Returns (a, b per
/// input, c).
#[allow(clippy::type_complexity)]
fn hannan_rissanen(
    u: &DMatrix<f64>,
    y: &DVector<f64>,
    e_hat: &[f64],
    na: usize,
    nb: &[usize],
    nk: &[usize],
    nc: usize,
) -> Result<(Vec<f64>, Vec<Vec<f64>>, Vec<f64>)> {
    let (n, nu) = (u.nrows(), u.ncols());
    let mut inputs = DMatrix::zeros(n, nu + 1);
    inputs.view_mut((0, 0), (n, nu)).copy_from(u);
    for t in 0..n {
        inputs[(t, nu)] = e_hat[t];
    }
    let ym = DMatrix::from_column_slice(n, 1, y.as_slice());
    let mut nbs = nb.to_vec();
    nbs.push(nc);
    let mut nks = nk.to_vec();
    nks.push(1);
    let orders = PolyOrders {
        na: vec![vec![na]],
        nb: vec![nbs],
        nc: vec![0],
        nd: vec![0],
        nf: vec![vec![0; nu + 1]],
        nk: vec![nks],
    };
    let fit = crate::arx(
        &[Experiment { u: &inputs, y: &ym }],
        &orders,
        1.0,
        &crate::ArxOptions {
            threads: 1,
            ..Default::default()
        },
    )?;
    let m = fit.model;
    let a = m.a(0, 0)[1..].to_vec();
    let b = (0..nu).map(|k| m.b(0, k).to_vec()).collect();
    let c = m.b(0, nu).to_vec();
    Ok((a, b, c))
}

/// Each record's inputs followed by its outputs `others` (the other
/// outputs a coupled A row reaches), as the input columns of output `i`'s
/// regressions.
fn with_other_outputs(experiments: &[Experiment<'_>], others: &[usize]) -> Vec<DMatrix<f64>> {
    experiments
        .iter()
        .map(|e| {
            let (n, nu) = (e.u.nrows(), e.u.ncols());
            let mut m = DMatrix::zeros(n, nu + others.len());
            m.view_mut((0, 0), (n, nu)).copy_from(e.u);
            for (c, &j) in others.iter().enumerate() {
                m.column_mut(nu + c).copy_from(&e.y.column(j));
            }
            m
        })
        .collect()
}

/// One-step residuals of a long ARX model of output `i`
/// (na = nb = `order` for every input, delay 1; the outputs `others` as
/// inputs delayed one sample), one vector per record (used as ê; zero over
/// the first `order` samples of a record).
fn long_arx_residuals(
    experiments: &[Experiment<'_>],
    i: usize,
    order: usize,
    others: &[usize],
) -> Result<Vec<Vec<f64>>> {
    let nu = experiments[0].u.ncols() + others.len();
    let ys = output_columns(experiments, i);
    let inputs = with_other_outputs(experiments, others);
    let exps: Vec<Experiment<'_>> = inputs
        .iter()
        .zip(&ys)
        .map(|(u, y)| Experiment { u, y })
        .collect();
    let orders = PolyOrders {
        na: vec![vec![order]],
        nb: vec![vec![order; nu]],
        nc: vec![0],
        nd: vec![0],
        nf: vec![vec![0; nu]],
        nk: vec![vec![1; nu]],
    };
    let fit = crate::arx(
        &exps,
        &orders,
        1.0,
        &crate::ArxOptions {
            threads: 1,
            ..Default::default()
        },
    )?;
    let m = fit.model;
    exps.iter()
        .map(|e| {
            let r = m.prediction_errors(e.u, e.y)?;
            Ok(r.column(0).iter().copied().collect())
        })
        .collect()
}

/// The start of output `i` (module docs).
fn start(
    experiments: &[Experiment<'_>],
    i: usize,
    shape: &Output,
    ts: f64,
    oe: &crate::OeOptions,
) -> Result<Output> {
    let (na, nc, nd) = (shape.a[i].len(), shape.c.len(), shape.d.len());
    let nb: Vec<usize> = shape.b.iter().map(Vec::len).collect();
    let nf: Vec<usize> = shape.f.iter().map(Vec::len).collect();
    // The other outputs a coupled A reaches.
    let others: Vec<usize> = (0..shape.a.len())
        .filter(|&j| j != i && !shape.a[j].is_empty())
        .collect();
    let na_all: usize = shape.a.iter().map(Vec::len).sum();
    let total: usize = experiments.iter().map(|e| e.u.nrows()).sum();
    let long = (4 * (na_all + nc + nd + nf.iter().sum::<usize>() + 1)).clamp(10, 40);
    let columns = experiments[0].u.ncols() + others.len();
    let long = long.min((total / (8 * (columns + 1))).max(1));
    let mut p = shape.clone();
    if nf.iter().all(|&f| f == 0) && nd == 0 {
        // ARMAX (or ARX with C): Hannan–Rissanen on the records joined.
        // (A record too short for the long ARX: the zero start.)
        let Ok(e_hat) = long_arx_residuals(experiments, i, long, &others) else {
            return Ok(p);
        };
        // The other outputs are inputs delayed one sample: their B is
        // −A_ij (A_ij starts at q⁻¹).
        let inputs = with_other_outputs(experiments, &others);
        let mut nb_all = nb.clone();
        nb_all.extend(others.iter().map(|&j| shape.a[j].len()));
        let mut nk_all = shape.nk.clone();
        nk_all.extend(others.iter().map(|_| 1));
        let mut found = None;
        for ((e, u), eh) in experiments.iter().zip(&inputs).zip(&e_hat) {
            let y = e.y.column(i).into_owned();
            if let Ok(fit) = hannan_rissanen(u, &y, eh, na, &nb_all, &nk_all, nc) {
                found = Some(fit);
                break;
            }
        }
        if let Some((a, b, c)) = found {
            let nu = nb.len();
            p.a[i] = a;
            for (idx, &j) in others.iter().enumerate() {
                p.a[j] = b[nu + idx].iter().map(|v| -v).collect();
            }
            p.b = b[..nu].to_vec();
            p.c = if stable(&c) { c } else { vec![0.0; nc] };
        }
        return Ok(p);
    }
    // Box–Jenkins (and the general case): B/F from the output-error model,
    // then (C, D) as an ARMA model of its residuals.
    let ys = output_columns(experiments, i);
    let exps = with_outputs(experiments, &ys);
    let nu = nb.len();
    let oe_orders = PolyOrders {
        na: vec![vec![0]],
        nb: vec![nb.clone()],
        nc: vec![0],
        nd: vec![0],
        nf: vec![nf.clone()],
        nk: vec![shape.nk.clone()],
    };
    let Ok(g) = crate::oe(&exps, &oe_orders, ts, oe) else {
        return Ok(p);
    };
    for k in 0..nu {
        p.b[k] = g.model.b(0, k).to_vec();
        p.f[k] = g.model.f(0, k)[1..].to_vec();
    }
    if nc + nd == 0 {
        return Ok(p);
    }
    // Residuals r = y − B/F u, then D r = C e by Hannan–Rissanen.
    for (e, y) in exps.iter().zip(&ys) {
        let sim = g.model.simulate(e.u, None)?;
        let r: Vec<f64> = (0..e.u.nrows()).map(|t| y[(t, 0)] - sim[(t, 0)]).collect();
        let n = r.len();
        if n <= 2 * long + nc + nd + 2 {
            continue;
        }
        // A long AR model of r gives ê.
        let rm = DMatrix::from_column_slice(n, 1, &r);
        let none = DMatrix::zeros(n, 1);
        let ar = crate::arx(
            &[Experiment { u: &none, y: &rm }],
            &PolyOrders::siso(long, 0, 0, 0, 0, 1),
            1.0,
            &crate::ArxOptions {
                threads: 1,
                ..Default::default()
            },
        );
        let Ok(ar) = ar else { continue };
        let eh = ar.model.prediction_errors(&none, &rm)?;
        let eh: Vec<f64> = eh.column(0).iter().copied().collect();
        let rv = DVector::from_vec(r);
        if let Ok((dd, _, cc)) = hannan_rissanen(&none, &rv, &eh, nd, &[0], &[1], nc) {
            if stable(&dd) {
                p.d = dd;
            }
            if stable(&cc) {
                p.c = cc;
            }
        }
        break;
    }
    Ok(p)
}

/// One output's estimate: the polynomials, R₁₁ of the (scaled) Jacobian at
/// them, the factor of R₁₁⁻¹R₁₁⁻ᵀ in the covariance, the innovations
/// variance, Σ ε², the samples the cost was taken on, the iterations.
struct OutputEstimate {
    p: Output,
    /// Of the free parameters (a common F once).
    r11: DMatrix<f64>,
    /// A common F: the free parameter of each of θ's entries.
    source: Option<Vec<usize>>,
    scale: f64,
    lambda: f64,
    plain: f64,
    measured: usize,
    iterations: usize,
}

/// Output `i` on records where it has unmeasured samples: the Kalman
/// predictor on the measured samples ([`measured`]), from its start.
/// λ̂ = Σ (ε²/f)/(M − d); the covariance factor Σ r²/(M − d) (r the scaled
/// residuals the Jacobian is of).
fn estimate_measured(
    experiments: &[Experiment<'_>],
    i: usize,
    shape: &Output,
    ts: f64,
    opts: &PolyestOptions,
) -> Result<OutputEstimate> {
    let tied = tied_source(shape, opts.f_structure);
    let d = tied.as_ref().map_or(shape.pack().len(), |t| t.1);
    let problem = measured::MeasuredPredictionError {
        experiments,
        i,
        shape,
    };
    let m: usize = experiments
        .iter()
        .map(|e| e.y.column(i).iter().filter(|v| !v.is_nan()).count())
        .sum();
    if m <= d {
        return Err(Error::TooFewSamples {
            what: "the polynomial model (measured samples of the output)",
            measured: m,
            needed: d + 1,
        });
    }
    // From every start, the lowest cost kept; iterations summed.
    let mut best: Option<(Vec<f64>, f64, DMatrix<f64>)> = None;
    let mut iterations = 0;
    for p0 in measured::starts(experiments, i, shape, ts, &oe_options(opts))? {
        let (theta, cost, r11, its) = minimise_tied(&problem, tied.as_ref(), p0.pack(), opts)?;
        iterations += its;
        if best.as_ref().is_none_or(|b| cost < b.1) {
            best = Some((theta, cost, r11));
        }
    }
    let (theta, cost, r11) = best.ok_or(Error::NoData)?;
    let (weighted, plain, m) = problem.sums(&theta);
    let dof = (m - d) as f64;
    Ok(OutputEstimate {
        p: shape.with(&theta),
        r11,
        source: tied.map(|t| t.0),
        scale: cost / dof,
        lambda: weighted / dof,
        plain,
        measured: m,
        iterations,
    })
}

/// The structure's checks beside the shared ones: not A with both D and
/// F.
fn check(experiments: &[Experiment<'_>], orders: &PolyOrders) -> Result<(usize, usize)> {
    let dims = crate::checks::check_polynomial_records(experiments, orders, true)?;
    for (i, row) in orders.na.iter().enumerate() {
        if row.iter().any(|&n| n > 0) && orders.nf[i].iter().any(|&f| f > 0) && orders.nd[i] > 0 {
            return Err(Error::InvalidOption {
                what: "orders",
                reason: "A together with D and F: use ARMAX (na nb nc nk) or BJ (nb nc nd nf nk)"
                    .into(),
            });
        }
    }
    Ok(dims)
}

/// The prediction-error estimate of the polynomial structure `orders`
/// (A diagonal or coupled; any of B, C, D, F; MATLAB's `polyest`), sample period
/// `ts`, with the parameter covariance (module docs).
///
/// Cost per output: the start (one or two least-squares fits, an OE fit
/// for BJ), then per iteration one Jacobian pass O(N d) with its QR
/// O(N d²) and a few residual passes O(N d); memory O(N + d²) per record.
///
/// On an output with unmeasured (NaN) samples the cost is its measured
/// samples' (module docs): per pass O(N (n² + n d_G)), n = max(na + nd,
/// nc), and a Jacobian costs 2 (na + nc + nd) passes more; with a coupled
/// A, 2 d joint passes per Jacobian (`coupled`'s docs) after two starts.
/// [`Error::Diverged`] when no start of the joint problem gives finite
/// prediction errors.
///
/// Errors: [`Error::NoData`]; [`Error::DimensionMismatch`];
/// [`Error::InvalidOption`] for an F without B, A with both D and F, a
/// coupled A on an output with unmeasured samples beside a D or a common
/// F, a common F
/// ([`PolyestOptions::f_structure`]) without F or with unequal nf; [`Error::NonFinite`]
/// for NaN/inf in u or an infinite y; [`Error::TooFewSamples`] (measured
/// samples per output); [`Error::RankDeficient`] for inputs that do not
/// excite the start.
pub fn polyest(
    experiments: &[Experiment<'_>],
    orders: &PolyOrders,
    ts: f64,
    opts: &PolyestOptions,
) -> Result<PolyestFit> {
    let (nu, ny) = check(experiments, orders)?;
    check_iterations(opts.max_iterations, opts.tolerance, "iterations")?;
    if opts.f_structure == crate::FStructure::Common {
        for i in 0..ny {
            if orders.nf[i].iter().all(|&f| f == 0) {
                return Err(Error::InvalidOption {
                    what: "f_structure",
                    reason: format!(
                        "a common F needs F polynomials (Box–Jenkins or OE orders); output {i} has none"
                    ),
                });
            }
            crate::oe::check_common_f(orders, i)?;
        }
    }
    let samples: usize = experiments.iter().map(|e| e.u.nrows()).sum();
    // The orders size every allocation below: refused before any is made
    // when an output has no fewer parameters than samples (saturating sums).
    for i in 0..orders.nb.len() {
        let d = [
            orders.na[i]
                .iter()
                .fold(0usize, |a, &b| a.saturating_add(b)),
            orders.nc[i],
            orders.nd[i],
            orders.nb[i]
                .iter()
                .fold(0usize, |a, &b| a.saturating_add(b)),
            orders.nf[i]
                .iter()
                .fold(0usize, |a, &b| a.saturating_add(b)),
        ]
        .iter()
        .fold(0usize, |a, &b| a.saturating_add(b));
        if samples <= d {
            return Err(Error::TooFewSamples {
                what: "the polynomial model",
                measured: samples,
                needed: d.saturating_add(1),
            });
        }
    }
    let template = PolyModel::from_orders(orders, ts)?;
    let mut polys = template.polynomials();
    let mut blocks = Vec::new();
    let mut lambdas = Vec::new();
    let (mut loss, mut fit, mut iterations) = (Vec::new(), Vec::new(), Vec::new());
    let mut measured_counts = Vec::new();
    let mut free_parameters = Vec::new();
    let mut shapes = Vec::with_capacity(ny);
    for i in 0..ny {
        let shape = Output {
            a: orders.na[i].iter().map(|&n| vec![0.0; n]).collect(),
            b: orders.nb[i].iter().map(|&n| vec![0.0; n]).collect(),
            f: orders.nf[i].iter().map(|&n| vec![0.0; n]).collect(),
            nk: orders.nk[i].clone(),
            c: vec![0.0; orders.nc[i]],
            d: vec![0.0; orders.nd[i]],
        };
        let d = shape.pack().len();
        if samples <= d {
            return Err(Error::TooFewSamples {
                what: "the polynomial model",
                measured: samples,
                needed: d + 1,
            });
        }
        shapes.push(shape);
    }
    // A coupled A on multirate records: all outputs at once.
    let joint_fit = if coupled::joint(experiments, orders, opts)? {
        Some(coupled::estimate(experiments, orders, &shapes, ts, opts)?)
    } else {
        None
    };
    for (i, shape) in shapes.iter().enumerate() {
        let (p, plain, measured_count, its) = match &joint_fit {
            Some(j) => {
                free_parameters.push(shape.pack().len());
                lambdas.push(j.lambdas[i]);
                (
                    j.outputs[i].clone(),
                    j.plain[i].0,
                    j.plain[i].1,
                    j.iterations,
                )
            }
            None => {
                let est = single_output(experiments, i, shape, samples, ts, opts)?;
                let free = est.r11.nrows();
                let inv = est
                    .r11
                    .solve_upper_triangular(&DMatrix::identity(free, free))
                    .ok_or(Error::RankDeficient {
                        what: "the prediction-error Jacobian at the estimate",
                        rank: 0,
                        needed: free,
                    })?;
                let block = &inv * inv.transpose() * est.scale;
                blocks.push(match &est.source {
                    Some(source) => crate::filters::untied_covariance(&block, source),
                    None => block,
                });
                free_parameters.push(free);
                lambdas.push(est.lambda);
                (est.p, est.plain, est.measured, est.iterations)
            }
        };
        let monic = |v: &[f64]| {
            let mut m = vec![1.0];
            m.extend_from_slice(v);
            m
        };
        if let Some(a) = polys.a.as_mut() {
            for (j, aj) in p.a.iter().enumerate() {
                if j == i {
                    a[i][i] = monic(aj);
                } else if !aj.is_empty() {
                    a[i][j] = std::iter::once(0.0).chain(aj.iter().copied()).collect();
                }
            }
        }
        for k in 0..nu {
            polys.b[i][k] = p.b[k].clone();
            if let Some(f) = polys.f.as_mut() {
                f[i][k] = monic(&p.f[k]);
            }
        }
        if let Some(c) = polys.c.as_mut() {
            c[i] = monic(&p.c);
        }
        if let Some(dd) = polys.d.as_mut() {
            dd[i] = monic(&p.d);
        }
        let values: Vec<f64> = experiments
            .iter()
            .flat_map(|e| e.y.column(i).iter().copied().collect::<Vec<_>>())
            .filter(|v| !v.is_nan())
            .collect();
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let spread = values
            .iter()
            .map(|v| (v - mean).powi(2))
            .sum::<f64>()
            .sqrt();
        loss.push(plain / measured_count as f64);
        fit.push(if spread > 0.0 {
            100.0 * (1.0 - plain.sqrt() / spread)
        } else {
            f64::NAN
        });
        iterations.push(its);
        measured_counts.push(measured_count);
    }
    let cov = match &joint_fit {
        Some(j) => (&j.cov + j.cov.transpose()) * 0.5,
        None => crate::filters::block_diagonal(&blocks),
    };
    let model = PolyModel::new(
        Polynomials {
            nk: orders.nk.clone(),
            ..polys
        },
        ts,
    )?
    .with_noise_variance(&DMatrix::from_diagonal(&DVector::from_vec(lambdas)))?
    .with_covariance(&cov)?;
    Ok(PolyestFit {
        model,
        loss,
        fit,
        measured: measured_counts,
        iterations,
        parameters: free_parameters,
    })
}

/// Output `i`'s own estimate (A diagonal, or coupled at full rate with
/// the other outputs as known regressors).
fn single_output(
    experiments: &[Experiment<'_>],
    i: usize,
    shape: &Output,
    samples: usize,
    ts: f64,
    opts: &PolyestOptions,
) -> Result<OutputEstimate> {
    let d = shape.pack().len();
    if measured::has_missing(experiments, i) {
        return estimate_measured(experiments, i, shape, ts, opts);
    }
    let p0 = start(experiments, i, shape, ts, &oe_options(opts))?;
    let problem = PredictionError {
        experiments,
        i,
        shape: &p0,
    };
    let tied = tied_source(shape, opts.f_structure);
    let (theta, cost, r11, its) = minimise_tied(&problem, tied.as_ref(), p0.pack(), opts)?;
    let free = tied.as_ref().map_or(d, |t| t.1);
    let lambda = cost / (samples - free) as f64;
    Ok(OutputEstimate {
        p: p0.with(&theta),
        r11,
        source: tied.map(|t| t.0),
        scale: lambda,
        lambda,
        plain: cost,
        measured: samples,
        iterations: its,
    })
}

/// The OE options of the B/F starts: the structure's F.
fn oe_options(opts: &PolyestOptions) -> crate::OeOptions {
    crate::OeOptions {
        f_structure: opts.f_structure,
        ..Default::default()
    }
}

/// With a common F, the free parameter of each entry of the output's θ
/// (a, B's, c, d, F's: the copies of F tied to one) and the free count.
fn tied_source(shape: &Output, f_structure: crate::FStructure) -> Option<(Vec<usize>, usize)> {
    if f_structure != crate::FStructure::Common {
        return None;
    }
    let base = shape.a.iter().map(Vec::len).sum::<usize>()
        + shape.b.iter().map(Vec::len).sum::<usize>()
        + shape.c.len()
        + shape.d.len();
    let nf = shape.f.iter().map(Vec::len).max().unwrap_or(0);
    let mut source: Vec<usize> = (0..base).collect();
    for f in &shape.f {
        if !f.is_empty() {
            source.extend(base..base + nf);
        }
    }
    Some((source, base + nf))
}

/// [`minimise`] from the untied `theta0`, with a common F's copies tied
/// ([`crate::filters::Tied`]) when `tied` is given: the untied θ at the
/// optimum, its cost, R₁₁ of the free parameters, the iterations.
fn minimise_tied<P: Residuals>(
    problem: &P,
    tied: Option<&(Vec<usize>, usize)>,
    theta0: Vec<f64>,
    opts: &PolyestOptions,
) -> Result<(Vec<f64>, f64, DMatrix<f64>, usize)> {
    let Some((source, free)) = tied else {
        return minimise(problem, theta0, opts.max_iterations, opts.tolerance);
    };
    let t = crate::filters::Tied {
        inner: problem,
        source: source.clone(),
        free: *free,
    };
    let (theta, cost, r11, its) =
        minimise(&t, t.tie(&theta0), opts.max_iterations, opts.tolerance)?;
    Ok((t.expand(&theta), cost, r11, its))
}

/// ARMAX [na nb nc nk] (the same for every input–output pair, A diagonal):
/// [`polyest`] with nd = nf = 0 (MATLAB's `armax`).
///
/// Errors: those of [`polyest`].
pub fn armax(
    experiments: &[Experiment<'_>],
    orders: [usize; 4],
    ts: f64,
    opts: &PolyestOptions,
) -> Result<PolyestFit> {
    let first = experiments.first().ok_or(Error::NoData)?;
    let (nu, ny) = (first.u.ncols(), first.y.ncols());
    let [na, nb, nc, nk] = orders;
    let o = PolyOrders {
        na: (0..ny)
            .map(|i| (0..ny).map(|j| if i == j { na } else { 0 }).collect())
            .collect(),
        nb: vec![vec![nb; nu]; ny],
        nc: vec![nc; ny],
        nd: vec![0; ny],
        nf: vec![vec![0; nu]; ny],
        nk: vec![vec![nk; nu]; ny],
    };
    polyest(experiments, &o, ts, opts)
}

/// Box–Jenkins [nb nc nd nf nk] (the same for every input–output pair):
/// [`polyest`] with na = 0 (MATLAB's `bj`).
///
/// Errors: those of [`polyest`].
pub fn bj(
    experiments: &[Experiment<'_>],
    orders: [usize; 5],
    ts: f64,
    opts: &PolyestOptions,
) -> Result<PolyestFit> {
    let first = experiments.first().ok_or(Error::NoData)?;
    let (nu, ny) = (first.u.ncols(), first.y.ncols());
    let [nb, nc, nd, nf, nk] = orders;
    let o = PolyOrders {
        na: vec![vec![0; ny]; ny],
        nb: vec![vec![nb; nu]; ny],
        nc: vec![nc; ny],
        nd: vec![nd; ny],
        nf: vec![vec![nf; nu]; ny],
        nk: vec![vec![nk; nu]; ny],
    };
    polyest(experiments, &o, ts, opts)
}

mod coupled;
mod measured;

#[cfg(test)]
mod tests;

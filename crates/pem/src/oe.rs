//! Output-error models, y_i(t) = Σ_k B_ik(q)/F_ik(q) u_k(t − nk_ik) + e_i(t),
//! by prediction-error minimisation on the measured samples — multirate
//! records included.
//!
//! The output-error predictor is the simulation ŷ = Σ_k (B_k/F_k) u_k, which
//! needs no past output, so the cost V = Σ ε(t)² / M over the M samples where
//! output i was measured (NaN elsewhere) is the same whether the output is
//! sampled at every fast instant or every P-th (Ljung 1999, §4.2 eq. (4.25)
//! for the model, §10.2 for the Gauss–Newton iterations; the missing-output
//! cost as Isaksson 1993). Each output is its own problem (the OE model has
//! no noise coupling between outputs).
//!
//! **Start.** A FIR model of L lags per input, regressed on the measured
//! samples (u is known at every instant), then per input an ARX
//! [nf nb nk] fitted to the FIR model's noise-free simulation of that input's
//! contribution ([`crate::arx`]): B/F ≈ the FIR response, exact when the FIR
//! is. A start whose F is unstable is replaced by F = 1 and the leading FIR
//! coefficients. Where the measured samples cannot tell some lags apart (an
//! input held over several samples and read every P-th: a step test, a
//! set-point held for 10 samples read every 5th) the FIR is the
//! minimum-norm least-squares one (R's pseudo-inverse), which shares the
//! response equally among the lags it cannot separate; an input that does
//! not move at the measured samples is refused. By default the iterations also run from that plain start
//! (F = 1, B the leading FIR coefficients) and the lower cost is kept
//! ([`OeOptions::starts`]): the FIR-then-ARX start can lie in another
//! minimum's basin.
//!
//! **Denominators.** By default each input–output pair has its own F
//! (MATLAB's `oe`, [`FStructure::PerInput`]). [`FStructure::Common`] shares
//! one F between an output's input terms, y_i = (1/F_i) Σ_k B_ik u_k(t − nk)
//! plus e_i: a MISO transfer function with a common denominator (SIPPY's
//! OE structure; one set of modes seen from every input, as one vessel fed
//! by several streams). With n_u inputs of order n it has (n_u − 1) n
//! fewer parameters, so less variance where the modes are common, and a
//! bias where they are not. The start's ARX fit is then one MISO ARX
//! [nf nb… 0] to the FIR model's whole simulation, and a third start
//! refines the ARX start by Steiglitz–McBride passes where every output
//! sample is measured ([`OeOptions::starts`]). The common-F estimate in
//! turn starts the per-input structure (it is nested there: F_k = F), so
//! a per-input model never has a higher cost than the common-F one; the
//! Jacobian's F columns
//! are ∂ŷ/∂f_j = −(ŷ/F)(t − j). The model keeps one F per pair (each a
//! copy of the common one) and the covariance is mapped onto those copies
//! (Cov = E Σ Eᵀ, E repeating the F rows: perfectly correlated copies).
//!
//! **Iterations.** Levenberg–Marquardt on θ = (B_i1 … B_inu, F_i1 … F_inu)
//! (the parameter order of [`lifted_lti::PolyModel::parameters`]) with the
//! analytic Jacobian: with v_k = u_k(t − nk)/F_k and z_k = ŷ_k/F_k,
//! ∂ŷ/∂b_km = v_k(t − m) and ∂ŷ/∂f_kj = −z_k(t − j), filtered once per
//! iteration (O(N Σ(nb + nf)) flops); the rows of [J | ε] (J = −∂ŷ/∂θ)
//! at the measured samples are folded into an R-only QR (memory O(d²),
//! never JᵀJ); the damped step solves [R₁₁; √λ D] δ = [−r; 0]
//! (Marquardt's scaling D). A
//! step that leaves any F unstable (a root on or outside the unit circle) is
//! rejected like a cost increase. Zero initial conditions.
//!
//! **Uncertainty.** Cov θ = λ̂ (JᵀJ)⁻¹ = λ̂ R₁₁⁻¹R₁₁⁻ᵀ at the optimum with
//! λ̂ = M V / (M − d) (Ljung 1999, eq. (9.18)); across outputs the
//! parameters are taken as independent (block-diagonal covariance).

use lifted_lti::{PolyModel, PolyOrders, Polynomials};
use lifted_subspace::Experiment;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::filters::{Residuals, RowFolder, check_iterations, filter, fir_apply, minimise, stable};

/// Options of [`oe`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct OeOptions {
    /// Largest number of Levenberg–Marquardt iterations per output
    /// (default 100).
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this
    /// fraction (default 1e-10), or the step is below it relative to θ.
    pub tolerance: f64,
    /// Lags of the FIR start per input (default: 10 (nb + nf), at least
    /// 20 and at most 200, and at most one lag per 4 measured samples per
    /// input).
    pub fir_length: Option<usize>,
    /// Starts of the iterations: 1, the FIR-then-ARX start only; 2, also
    /// the FIR start with F = 1, the lower cost kept; 3 (the default), with
    /// a common F ([`FStructure::Common`]) on an output measured at every
    /// sample also the Steiglitz–McBride start (its ARX fits need every
    /// sample), and with one F per input (several inputs of one nf) also
    /// the common-F estimate, the optimum of the nested structure. The
    /// FIR-then-ARX start alone loses (the
    /// iterations from the first end in a worse minimum on some records:
    /// benches/results/polynomial.md, "Polynomial methods on the real
    /// records beside SIPPY"). At least 1.
    pub starts: usize,
    /// One F per input–output pair (the default) or one per output shared
    /// by its input terms (module docs).
    pub f_structure: FStructure,
}

/// The denominators of an output-error model (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum FStructure {
    /// One F per input–output pair, y_i = Σ_k (B_ik/F_ik) u_k (MATLAB's
    /// `oe`): the default.
    #[default]
    PerInput,
    /// One F per output shared by its input terms, y_i = (1/F_i) Σ_k B_ik u_k
    /// (SIPPY's OE): every input of an output with a B must have the same
    /// nf, and inputs without a B nf = 0.
    Common,
}

impl Default for OeOptions {
    fn default() -> Self {
        OeOptions {
            max_iterations: 100,
            tolerance: 1e-10,
            fir_length: None,
            starts: 3,
            f_structure: FStructure::PerInput,
        }
    }
}

/// An estimated output-error model and what the iterations did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OeFit {
    /// The model, with the noise variances and the parameter covariance.
    pub model: PolyModel,
    /// Mean squared simulation error per output on its measured samples.
    pub loss: Vec<f64>,
    /// Simulation fit per output, percent: 100 (1 − ‖ε‖/‖y − ȳ‖) on the
    /// measured samples.
    pub fit: Vec<f64>,
    /// Measured samples per output.
    pub measured: Vec<usize>,
    /// Iterations run per output.
    pub iterations: Vec<usize>,
    /// Free parameters per output (a common F counted once; the model's
    /// [`PolyModel::n_parameters`] counts its copies).
    pub parameters: Vec<usize>,
}

/// One output's structure: per input (nb, nf, nk).
#[derive(Debug, Clone)]
struct Pairs {
    nb: Vec<usize>,
    nf: Vec<usize>,
    nk: Vec<usize>,
    /// One F shared by the input terms ([`FStructure::Common`]).
    common: bool,
}

impl Pairs {
    /// Free parameters: Σ nb plus Σ nf, or the common F's nf once.
    fn parameters(&self) -> usize {
        self.nb.iter().sum::<usize>() + self.free_f()
    }

    /// Free F coefficients.
    fn free_f(&self) -> usize {
        if self.common {
            self.common_nf()
        } else {
            self.nf.iter().sum()
        }
    }

    /// The common F's degree (that of the first input with a B).
    fn common_nf(&self) -> usize {
        (0..self.nb.len())
            .find(|&k| self.nb[k] > 0)
            .map_or(0, |k| self.nf[k])
    }
}

/// (B_k, F_k) per input: b coefficients, f free coefficients (F = 1 + …).
type Rational = Vec<(Vec<f64>, Vec<f64>)>;

/// The OE structure's checks beside the shared ones: no A, C or D, an
/// input term per output; y may hold NaN (not measured).
fn check(
    experiments: &[Experiment<'_>],
    orders: &PolyOrders,
    f_structure: FStructure,
) -> Result<(usize, usize)> {
    let dims = crate::checks::check_polynomial_records(experiments, orders, true)?;
    if orders.na.iter().flatten().any(|&n| n > 0)
        || orders.nc.iter().chain(&orders.nd).any(|&n| n > 0)
    {
        return Err(Error::InvalidOption {
            what: "orders",
            reason: "an output-error structure has no A, C or D polynomial (na = nc = nd = 0)"
                .into(),
        });
    }
    for (i, row) in orders.nb.iter().enumerate() {
        if row.iter().all(|&b| b == 0) {
            return Err(Error::InvalidOption {
                what: "orders",
                reason: format!("output {i} has no input term (every nb = 0)"),
            });
        }
        if f_structure == FStructure::Common {
            check_common_f(orders, i)?;
        }
    }
    Ok(dims)
}

/// Output `i`'s orders admit one F shared by its input terms: the same nf
/// for every input with a B, nf = 0 where nb = 0.
pub(crate) fn check_common_f(orders: &PolyOrders, i: usize) -> Result<()> {
    let row = &orders.nb[i];
    let with_b: Vec<usize> = (0..row.len())
        .filter(|&k| row[k] > 0)
        .map(|k| orders.nf[i][k])
        .collect();
    let without_b = (0..row.len()).any(|k| row[k] == 0 && orders.nf[i][k] > 0);
    if with_b.windows(2).any(|w| w[0] != w[1]) || without_b {
        return Err(Error::InvalidOption {
            what: "orders",
            reason: format!(
                "a common F needs the same nf for every input of output {i} with a B (and nf = 0 where nb = 0); got nf {:?}",
                orders.nf[i]
            ),
        });
    }
    Ok(())
}

/// The simulated output ŷ_i = Σ_k (B_k/F_k) u_k and, with `jacobian`, the
/// columns ∂ŷ/∂θ, for one record. O(N Σ(nb + nf)).
fn simulate(
    u: &DMatrix<f64>,
    pairs: &Pairs,
    theta: &Rational,
    jacobian: bool,
) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = u.nrows();
    let mut yhat = vec![0.0; n];
    let mut cols: Vec<Vec<f64>> = Vec::new();
    let (mut v, mut yk, mut z) = (Vec::new(), Vec::new(), Vec::new());
    let mut b_cols = Vec::new();
    let mut f_cols = Vec::new();
    for (k, (b, f)) in theta.iter().enumerate() {
        if pairs.nb[k] == 0 {
            continue;
        }
        let uk: Vec<f64> = u.column(k).iter().copied().collect();
        filter(&uk, f, pairs.nk[k], &mut v);
        fir_apply(&v, b, &mut yk);
        for (a, c) in yhat.iter_mut().zip(&yk) {
            *a += c;
        }
        if jacobian {
            for m in 0..b.len() {
                b_cols.push(
                    (0..n)
                        .map(|t| if t >= m { v[t - m] } else { 0.0 })
                        .collect(),
                );
            }
            if !pairs.common {
                filter(&yk, f, 0, &mut z);
                f_cols.extend(delayed_negated(&z, f.len()));
            }
        }
    }
    // A common F: ∂ŷ/∂f_j = −(ŷ/F)(t − j), one filter of the sum.
    if jacobian
        && pairs.common
        && let Some((_, f)) = (0..theta.len())
            .find(|&k| pairs.nb[k] > 0)
            .map(|k| &theta[k])
    {
        filter(&yhat, f, 0, &mut z);
        f_cols.extend(delayed_negated(&z, f.len()));
    }
    if jacobian {
        // Parameter order: every B, then every F (PolyModel::parameters).
        cols.extend(b_cols);
        cols.extend(f_cols);
    }
    (yhat, cols)
}

/// The columns −z(t − j), j = 1 … nf (zero before the record).
fn delayed_negated(z: &[f64], nf: usize) -> impl Iterator<Item = Vec<f64>> + '_ {
    (1..=nf).map(move |j| {
        (0..z.len())
            .map(|t| if t >= j { -z[t - j] } else { 0.0 })
            .collect()
    })
}

/// Splits θ (B's then F's; a common F once) into per-input (b, f), the
/// common F copied to every input with a B.
fn unpack(theta: &[f64], pairs: &Pairs) -> Rational {
    let mut at = 0;
    let mut bs = Vec::new();
    for &nb in &pairs.nb {
        bs.push(theta[at..at + nb].to_vec());
        at += nb;
    }
    let mut out = Vec::new();
    if pairs.common {
        let f = theta[at..at + pairs.common_nf()].to_vec();
        for (k, b) in bs.into_iter().enumerate() {
            let fk = if pairs.nb[k] > 0 {
                f.clone()
            } else {
                Vec::new()
            };
            out.push((b, fk));
        }
        return out;
    }
    for (k, &nf) in pairs.nf.iter().enumerate() {
        out.push((bs[k].clone(), theta[at..at + nf].to_vec()));
        at += nf;
    }
    out
}

/// θ of per-input (b, f): B's then F's (a common F once, that of the first
/// input with a B).
fn pack(r: &Rational, pairs: &Pairs) -> Vec<f64> {
    let bs = r.iter().flat_map(|(b, _)| b.iter().copied());
    if pairs.common {
        let f = (0..r.len())
            .find(|&k| pairs.nb[k] > 0)
            .map(|k| r[k].1.clone())
            .unwrap_or_default();
        return bs.chain(f).collect();
    }
    bs.chain(r.iter().flat_map(|(_, f)| f.iter().copied()))
        .collect()
}

/// Cost Σ ε² over the measured samples of output `i`, and (with
/// `jacobian`) the R factor of [J | ε] (J = ∂ε/∂θ = −∂ŷ/∂θ).
fn evaluate(
    experiments: &[Experiment<'_>],
    i: usize,
    pairs: &Pairs,
    theta: &Rational,
    jacobian: bool,
) -> Result<(f64, Option<DMatrix<f64>>)> {
    let d = pairs.parameters();
    let mut rows = jacobian.then(|| RowFolder::new(d + 1));
    let mut cost = 0.0;
    for e in experiments {
        let (yhat, cols) = simulate(e.u, pairs, theta, jacobian);
        for (t, &yh) in yhat.iter().enumerate() {
            let y = e.y[(t, i)];
            if y.is_nan() {
                continue;
            }
            let eps = y - yh;
            cost += eps * eps;
            if let Some(rows) = rows.as_mut() {
                rows.push(cols.iter().map(|c| -c[t]).chain([eps]))?;
            }
        }
    }
    Ok((cost, rows.map(RowFolder::finish).transpose()?))
}

/// The FIR regression of the starts of output `i` (module docs): per
/// input with a B its L coefficients. The same for the per-input and the
/// nested common-F structure (the lags depend on nb and nf only), so
/// computed once per output. O(M L² n_u²).
fn fir(
    experiments: &[Experiment<'_>],
    i: usize,
    pairs: &Pairs,
    measured: usize,
    opts: &OeOptions,
) -> Result<Vec<Vec<f64>>> {
    let nu = pairs.nb.len();
    let active: Vec<usize> = (0..nu).filter(|&k| pairs.nb[k] > 0).collect();
    let longest = active
        .iter()
        .map(|&k| 10 * (pairs.nb[k] + pairs.nf[k]))
        .max()
        .unwrap_or(20);
    let cap = (measured / (4 * active.len().max(1))).max(1);
    let lags = opts
        .fir_length
        .unwrap_or_else(|| longest.clamp(20, 200))
        .min(cap)
        .max(pairs.nb.iter().copied().max().unwrap_or(1));
    // FIR regression on the measured samples: y(t) = Σ_k Σ_l g_kl u_k(t − nk_k − l).
    let p = lags * active.len();
    let mut fold = RowFolder::new(p + 1);
    for e in experiments {
        for t in 0..e.u.nrows() {
            let y = e.y[(t, i)];
            if y.is_nan() {
                continue;
            }
            let row = active.iter().flat_map(|&k| {
                (0..lags).map(move |l| {
                    let lag = pairs.nk[k] + l;
                    if t >= lag { e.u[(t - lag, k)] } else { 0.0 }
                })
            });
            fold.push(row.chain([y]))?;
        }
    }
    let r = fold.finish()?;
    if r.nrows() < p + 1 {
        return Err(Error::TooFewSamples {
            what: "the output-error start (FIR regression)",
            measured,
            needed: p + 1,
        });
    }
    let r11 = r.view((0, 0), (p, p)).into_owned();
    let scale = (0..p).map(|j| r11[(j, j)].abs()).fold(0.0, f64::max);
    let rank = (0..p)
        .filter(|&j| r11[(j, j)].abs() > 1e-10 * scale.max(f64::MIN_POSITIVE))
        .count();
    // Every input moves at the measured rows (‖column‖ of R₁₁ = ‖regressor‖).
    let norms: Vec<f64> = (0..p).map(|j| r11.column(j).norm()).collect();
    let top = norms.iter().copied().fold(0.0, f64::max);
    let quiet = (0..active.len())
        .filter(|&slot| {
            norms[slot * lags..(slot + 1) * lags]
                .iter()
                .all(|&v| v <= 1e-10 * top.max(f64::MIN_POSITIVE))
        })
        .count();
    if rank == 0 || quiet > 0 {
        return Err(Error::RankDeficient {
            what: "the FIR regressors of the output-error start (an input that does not move at the measured samples)",
            rank,
            needed: p,
        });
    }
    let rhs = r.view((0, p), (p, 1)).into_owned();
    let g = if rank == p {
        r11.clone().solve_upper_triangular(&rhs)
    } else {
        None
    };
    // Lags the measured samples do not tell apart (an input held over
    // several samples, read every P-th: identical columns at the measured
    // rows): the minimum-norm FIR (module docs).
    let g = match g {
        Some(g) => g,
        None => lifted_linalg::pinv(&r11, lifted_linalg::RankTolerance::Relative(1e-10))? * &rhs,
    };
    Ok((0..active.len())
        .map(|slot| (0..lags).map(|l| g[slot * lags + l]).collect())
        .collect())
}

/// The FIR-then-ARX start of output `i` from its FIR regression ([`fir`]),
/// and the plain FIR start (F = 1) (module docs).
fn start(experiments: &[Experiment<'_>], pairs: &Pairs, firs: &[Vec<f64>]) -> (Rational, Rational) {
    let nu = pairs.nb.len();
    let active: Vec<usize> = (0..nu).filter(|&k| pairs.nb[k] > 0).collect();
    let lags = firs.first().map_or(0, Vec::len);
    let mut out: Rational = vec![(Vec::new(), Vec::new()); nu];
    let mut plains: Rational = vec![(Vec::new(), Vec::new()); nu];
    if pairs.common {
        for (slot, &k) in active.iter().enumerate() {
            plains[k] = (firs[slot][..pairs.nb[k]].to_vec(), vec![0.0; pairs.nf[k]]);
        }
        let fitted = if pairs.common_nf() > 0 {
            common_start(experiments, pairs, &active, firs)
        } else {
            None
        };
        return (fitted.unwrap_or_else(|| plains.clone()), plains);
    }
    for (slot, &k) in active.iter().enumerate() {
        let fir = &firs[slot];
        let (nb, nf) = (pairs.nb[k], pairs.nf[k]);
        let plain = (fir[..nb].to_vec(), vec![0.0; nf]);
        plains[k] = plain.clone();
        if nf == 0 {
            out[k] = plain;
            continue;
        }
        // ARX [nf nb 0] on the FIR's simulation of this input (the delay
        // already applied): B/F fitted to the FIR response.
        let mut fitted = None;
        for e in experiments {
            let n = e.u.nrows();
            if n <= lags + nf + nb + 1 {
                continue;
            }
            let uk = DMatrix::from_fn(n, 1, |t, _| {
                if t >= pairs.nk[k] {
                    e.u[(t - pairs.nk[k], k)]
                } else {
                    0.0
                }
            });
            let mut yk = Vec::new();
            fir_apply(uk.as_slice(), fir, &mut yk);
            let ykm = DMatrix::from_column_slice(n, 1, &yk);
            let fit = crate::arx(
                &[Experiment { u: &uk, y: &ykm }],
                &PolyOrders::siso(nf, nb, 0, 0, 0, 0),
                1.0,
                &crate::ArxOptions {
                    threads: 1,
                    ..Default::default()
                },
            );
            if let Ok(fit) = fit {
                let a = fit.model.a(0, 0)[1..].to_vec();
                let b = fit.model.b(0, 0).to_vec();
                if stable(&a) {
                    fitted = Some((b, a));
                }
            }
            break;
        }
        out[k] = fitted.unwrap_or(plain);
    }
    (out, plains)
}

/// The common-F start: one MISO ARX [nf nb… 0] fitted to the FIR model's
/// whole simulation Σ_k G_k u_k(t − nk_k) of the first record long enough
/// (B/F ≈ the FIR responses with one F); `None` when it fails or its F is
/// unstable. O(N (nf + Σ nb)²).
fn common_start(
    experiments: &[Experiment<'_>],
    pairs: &Pairs,
    active: &[usize],
    firs: &[Vec<f64>],
) -> Option<Rational> {
    let nf = pairs.common_nf();
    let lags = firs.first().map_or(0, Vec::len);
    let widest: usize = active.iter().map(|&k| pairs.nb[k]).max().unwrap_or(0);
    let e = experiments
        .iter()
        .find(|e| e.u.nrows() > lags + nf + widest + 1)?;
    let n = e.u.nrows();
    let delayed = DMatrix::from_fn(n, active.len(), |t, slot| {
        let k = active[slot];
        if t >= pairs.nk[k] {
            e.u[(t - pairs.nk[k], k)]
        } else {
            0.0
        }
    });
    let mut y = vec![0.0; n];
    let mut yk = Vec::new();
    for (slot, fir) in firs.iter().enumerate() {
        fir_apply(delayed.column(slot).as_slice(), fir, &mut yk);
        for (a, b) in y.iter_mut().zip(&yk) {
            *a += b;
        }
    }
    let ym = DMatrix::from_column_slice(n, 1, &y);
    common_arx(
        &[Experiment {
            u: &delayed,
            y: &ym,
        }],
        pairs,
        active,
    )
}

/// The MISO ARX [nf nb… 0] F y = Σ_k B_k u_k + e of a common F by least
/// squares on `records` (their inputs the active inputs, already delayed),
/// as per-input (b, f) with every f the ARX's F; `None` when the fit fails
/// or its F is unstable. O(N d²).
fn common_arx(records: &[Experiment<'_>], pairs: &Pairs, active: &[usize]) -> Option<Rational> {
    let width = active.len();
    let orders = PolyOrders {
        na: vec![vec![pairs.common_nf()]],
        nb: vec![active.iter().map(|&k| pairs.nb[k]).collect()],
        nc: vec![0],
        nd: vec![0],
        nf: vec![vec![0; width]],
        nk: vec![vec![0; width]],
    };
    let opts = crate::ArxOptions {
        threads: 1,
        ..Default::default()
    };
    let fit = crate::arx(records, &orders, 1.0, &opts).ok()?;
    let a = fit.model.a(0, 0)[1..].to_vec();
    if !stable(&a) {
        return None;
    }
    let mut out: Rational = vec![(Vec::new(), Vec::new()); pairs.nb.len()];
    for (slot, &k) in active.iter().enumerate() {
        out[k] = (fit.model.b(0, slot).to_vec(), a.clone());
    }
    Some(out)
}

/// Largest number of Steiglitz–McBride passes of the third start
/// ([`steiglitz_mcbride`]); they stop earlier when F settles.
const SM_PASSES: usize = 20;

/// The Steiglitz–McBride start of a common-F output (Steiglitz & McBride
/// 1965, IEEE Trans. Autom. Control 10(4); Ljung 1999 §10.4): from the
/// common F of `from`, repeatedly filter y_i and each delayed input by
/// 1/F and fit the ARX [nf nb… 0] F y_f = Σ B_k u_f,k + e by least squares
/// (its F the next), until F moves by less than 1e-9 relative or
/// [`SM_PASSES`] passes; the last stable estimate. Its fixed point is the
/// output-error estimate when the noise is white, which the ARX start is
/// not (its equation error weights the fit by F). Every output sample
/// must be measured (the ARX regressors are past filtered outputs):
/// `None` otherwise, or when the first pass fails. O(passes · N (n_u nf +
/// d²)).
fn steiglitz_mcbride(
    experiments: &[Experiment<'_>],
    i: usize,
    pairs: &Pairs,
    from: &Rational,
) -> Option<Rational> {
    if experiments
        .iter()
        .any(|e| e.y.column(i).iter().any(|v| v.is_nan()))
    {
        return None;
    }
    let active: Vec<usize> = (0..pairs.nb.len()).filter(|&k| pairs.nb[k] > 0).collect();
    let first = *active.first()?;
    let mut f = from.get(first)?.1.clone();
    let width = active.len();
    let mut best: Option<Rational> = None;
    let mut buf = Vec::new();
    // Each record's active input columns and output column, copied once.
    let columns: Vec<(Vec<Vec<f64>>, Vec<f64>)> = experiments
        .iter()
        .map(|e| {
            let us = active
                .iter()
                .map(|&k| e.u.column(k).iter().copied().collect())
                .collect();
            (us, e.y.column(i).iter().copied().collect())
        })
        .collect();
    for _ in 0..SM_PASSES {
        let mut filtered = Vec::with_capacity(experiments.len());
        for (us, yi) in &columns {
            let n = yi.len();
            let mut uf = DMatrix::zeros(n, width);
            for ((slot, &k), uk) in active.iter().enumerate().zip(us) {
                filter(uk, &f, pairs.nk[k], &mut buf);
                uf.column_mut(slot).copy_from_slice(&buf);
            }
            filter(yi, &f, 0, &mut buf);
            filtered.push((uf, DMatrix::from_column_slice(n, 1, &buf)));
        }
        let records: Vec<Experiment<'_>> =
            filtered.iter().map(|(u, y)| Experiment { u, y }).collect();
        let Some(next) = common_arx(&records, pairs, &active) else {
            break;
        };
        let g = next[first].1.clone();
        let moved = g
            .iter()
            .zip(&f)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let size = 1.0 + g.iter().map(|v| v.abs()).fold(0.0, f64::max);
        best = Some(next);
        f = g;
        if moved < 1e-9 * size {
            break;
        }
    }
    best
}

/// Output `i`'s output-error problem for [`minimise`].
struct OutputError<'a, 'e> {
    experiments: &'a [Experiment<'e>],
    i: usize,
    pairs: &'a Pairs,
}

impl Residuals for OutputError<'_, '_> {
    fn evaluate(&self, theta: &[f64], jacobian: bool) -> Result<(f64, Option<DMatrix<f64>>)> {
        evaluate(
            self.experiments,
            self.i,
            self.pairs,
            &unpack(theta, self.pairs),
            jacobian,
        )
    }

    fn admissible(&self, theta: &[f64]) -> bool {
        unpack(theta, self.pairs).iter().all(|(_, f)| stable(f))
    }
}

/// The covariance of θ (B's, then the F's or a common F once) on the
/// model's parameters (B's, then one F per input): E Σ Eᵀ with E repeating
/// a common F's rows for every input with a B (module docs). O(d²).
fn on_pairs(cov: &DMatrix<f64>, pairs: &Pairs) -> DMatrix<f64> {
    if !pairs.common {
        return cov.clone();
    }
    let nb: usize = pairs.nb.iter().sum();
    let nf = pairs.common_nf();
    // Row of θ behind each model parameter.
    let mut source: Vec<usize> = (0..nb).collect();
    for k in 0..pairs.nb.len() {
        if pairs.nb[k] > 0 {
            source.extend(nb..nb + nf);
        }
    }
    crate::filters::untied_covariance(cov, &source)
}

/// One run of the iterations: θ, cost, R₁₁, iterations.
type Run = (Vec<f64>, f64, DMatrix<f64>, usize);

/// The iterations of output `i` from each start of [`OeOptions::starts`],
/// the lowest cost kept (its θ, cost and R₁₁; the iterations of every
/// start summed). The starts: the FIR-then-ARX start; the plain FIR start
/// (F = 1); with a common F on an output measured at every sample, the
/// Steiglitz–McBride start; with one F per input, n_u ≥ 2 inputs of one
/// nf, the common-F estimate (the nested structure's optimum: the
/// per-input cost from it is never above the common-F cost).
fn fit_output(
    experiments: &[Experiment<'_>],
    i: usize,
    pairs: &Pairs,
    firs: &[Vec<f64>],
    opts: &OeOptions,
) -> Result<Run> {
    let (theta0, plain) = start(experiments, pairs, firs);
    let problem = OutputError {
        experiments,
        i,
        pairs,
    };
    let run = |r: &Rational| {
        minimise(
            &problem,
            pack(r, pairs),
            opts.max_iterations,
            opts.tolerance,
        )
    };
    let mut best = run(&theta0)?;
    let mut its = best.3;
    let mut others: Vec<Result<Run>> = Vec::new();
    if opts.starts >= 2 && plain != theta0 {
        others.push(run(&plain));
    }
    if opts.starts >= 3 {
        if pairs.common {
            if pairs.common_nf() > 0
                && let Some(sm) = steiglitz_mcbride(experiments, i, pairs, &theta0)
            {
                others.push(run(&sm));
            }
        } else if let Some(nested) = nested_common(pairs)
            && let Ok((t, _, _, nested_its)) = fit_output(experiments, i, &nested, firs, opts)
        {
            its += nested_its;
            others.push(run(&unpack(&t, &nested)));
        }
    }
    for r in others.into_iter().flatten() {
        its += r.3;
        if r.1 < best.1 {
            best = r;
        }
    }
    best.3 = its;
    Ok(best)
}

/// The common-F structure nested in a per-input one: `Some` when at
/// least two inputs have a B and they all have the same nf > 0.
fn nested_common(pairs: &Pairs) -> Option<Pairs> {
    let active: Vec<usize> = (0..pairs.nb.len()).filter(|&k| pairs.nb[k] > 0).collect();
    let nf = pairs.nf[*active.first()?];
    let nestable = active.len() >= 2
        && nf > 0
        && active.iter().all(|&k| pairs.nf[k] == nf)
        && (0..pairs.nb.len()).all(|k| pairs.nb[k] > 0 || pairs.nf[k] == 0);
    nestable.then(|| Pairs {
        common: true,
        ..pairs.clone()
    })
}

/// Output-error model of structure `orders` (n_y × n_u nb, nf, nk; every
/// na, nc, nd 0) on the records, sample period `ts`, with the parameter
/// covariance. y may hold NaN where an output was not measured (a
/// multirate record): the cost uses the measured samples only.
///
/// Cost: per output, the FIR start (one pass, O(M L² n_u²) for L lags),
/// then per iteration one Jacobian pass O(N d) plus its QR O(M d²) and a
/// few trial simulations O(N d); memory O(N + d²) per record and output.
///
/// Errors: [`Error::NoData`]; [`Error::DimensionMismatch`] for orders or
/// records that do not match; [`Error::InvalidOption`] for a structure
/// with A, C or D, an output without input terms, or a common F
/// ([`FStructure::Common`]) with unequal nf; [`Error::NonFinite`]
/// for NaN/inf in u or an infinite y; [`Error::TooFewSamples`] when an
/// output has no more measured samples than parameters (and the FIR
/// start's lags); [`Error::RankDeficient`] for inputs that do not excite
/// the FIR start.
pub fn oe(
    experiments: &[Experiment<'_>],
    orders: &PolyOrders,
    ts: f64,
    opts: &OeOptions,
) -> Result<OeFit> {
    let (nu, ny) = check(experiments, orders, opts.f_structure)?;
    check_iterations(opts.max_iterations, opts.tolerance, "OE iterations")?;
    if opts.starts == 0 {
        return Err(Error::InvalidOption {
            what: "OE starts",
            reason: "at least 1".into(),
        });
    }
    let mut b_all = vec![vec![Vec::new(); nu]; ny];
    let mut f_all = vec![vec![vec![1.0]; nu]; ny];
    let mut blocks: Vec<DMatrix<f64>> = Vec::new();
    let mut lambdas = Vec::new();
    let (mut loss, mut fit, mut measured_all, mut iterations) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut free = Vec::new();
    for i in 0..ny {
        let pairs = Pairs {
            nb: orders.nb[i].clone(),
            nf: orders.nf[i].clone(),
            nk: orders.nk[i].clone(),
            common: opts.f_structure == FStructure::Common,
        };
        let d = pairs.parameters();
        let values: Vec<f64> = experiments
            .iter()
            .flat_map(|e| {
                e.y.column(i)
                    .iter()
                    .copied()
                    .filter(|v| !v.is_nan())
                    .collect::<Vec<_>>()
            })
            .collect();
        let measured = values.len();
        if measured <= d {
            return Err(Error::TooFewSamples {
                what: "the output-error model",
                measured,
                needed: d + 1,
            });
        }
        let firs = fir(experiments, i, &pairs, measured, opts)?;
        let (theta, cost, r11, its) = fit_output(experiments, i, &pairs, &firs, opts)?;
        let theta = unpack(&theta, &pairs);
        let lambda = cost / (measured - d) as f64;
        let inv =
            r11.solve_upper_triangular(&DMatrix::identity(d, d))
                .ok_or(Error::RankDeficient {
                    what: "the output-error Jacobian at the estimate",
                    rank: 0,
                    needed: d,
                })?;
        blocks.push(on_pairs(&(&inv * inv.transpose() * lambda), &pairs));
        lambdas.push(lambda);
        for (k, (b, f)) in theta.iter().enumerate() {
            b_all[i][k] = b.clone();
            let mut poly = vec![1.0];
            poly.extend_from_slice(f);
            f_all[i][k] = poly;
        }
        let mean = values.iter().sum::<f64>() / measured as f64;
        let spread: f64 = values
            .iter()
            .map(|v| (v - mean).powi(2))
            .sum::<f64>()
            .sqrt();
        loss.push(cost / measured as f64);
        fit.push(if spread > 0.0 {
            100.0 * (1.0 - cost.sqrt() / spread)
        } else {
            f64::NAN
        });
        measured_all.push(measured);
        iterations.push(its);
        free.push(d);
    }
    let cov = crate::filters::block_diagonal(&blocks);
    let model = PolyModel::new(
        Polynomials {
            b: b_all,
            f: Some(f_all),
            nk: orders.nk.clone(),
            ..Default::default()
        },
        ts,
    )?
    .with_noise_variance(&DMatrix::from_diagonal(&DVector::from_vec(lambdas)))?
    .with_covariance(&cov)?;
    Ok(OeFit {
        model,
        loss,
        fit,
        measured: measured_all,
        iterations,
        parameters: free,
    })
}

#[cfg(test)]
mod tests;

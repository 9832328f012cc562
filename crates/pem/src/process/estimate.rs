//! `procest`: the checks, the starts (grid with the gains solved for, the
//! two-point method on a step test), Levenberg–Marquardt on the simulation
//! error of the measured samples, the covariance.

use lifted_linalg::RAccumulator;
use lifted_subspace::Experiment;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use super::model::{Discrete, InterSample, ProcessKind, ProcessModel};
use crate::error::{Error, Result};

mod starts;
use starts::starts;
#[cfg(test)]
use starts::two_point_start;

/// Rows of [∂ŷ/∂φ | ε] folded into the R-only QR at a time.
const BLOCK_ROWS: usize = 4096;
/// Time constants on the start grid (log-spaced from T/2 to a quarter of
/// the longest record).
const GRID_TIME_CONSTANTS: usize = 12;
/// Damping ratios on the start grid of P2DU.
const GRID_ZETAS: [f64; 5] = [0.15, 0.3, 0.5, 0.7, 1.0];
/// Dead-time shifts evaluated per shape on the coarse grid.
const GRID_SHIFTS: usize = 64;

/// Options of [`procest`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProcessOptions {
    /// Largest number of Levenberg–Marquardt iterations per start
    /// (default 100).
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this
    /// fraction, or the step is below its square root relative to the
    /// parameters (default 1e-10).
    pub tolerance: f64,
    /// Estimate a constant output offset besides the models (default
    /// false: the records are deviations from the operating point, the
    /// caller removed it; MATLAB's `procest` likewise assumes detrended
    /// data unless an offset is asked for).
    pub offset: bool,
    /// Largest dead time in seconds the search considers (default: a third
    /// of the longest record's duration).
    pub max_delay: Option<f64>,
    /// Levenberg–Marquardt runs from the best distinct grid points (single
    /// input only; default 3); the two-point start of a step test is run
    /// besides. The lowest cost is kept.
    pub starts: usize,
    /// Parameters held at a value instead of estimated (MATLAB's
    /// `Structure.Td.Free = false`): `(name, value)` with a name of
    /// [`ProcessKind::parameter_names`] for every input ("Td": a dead time
    /// known from the plant, "K"), or a name of [`ProcessFit::names`] for
    /// one input ("Td(u0)"), or "offset". A held parameter keeps its
    /// value through the starts and iterations and has no variance.
    /// Default none.
    pub fixed: Vec<(String, f64)>,
    /// How the inputs move between their samples (default ZOH; FOH for
    /// sampled continuous signals: MATLAB's `InterSample`). The models
    /// carry it.
    #[serde(default)]
    pub intersample: InterSample,
}

impl Default for ProcessOptions {
    fn default() -> Self {
        ProcessOptions {
            max_iterations: 100,
            tolerance: 1e-10,
            offset: false,
            max_delay: None,
            starts: 3,
            fixed: Vec::new(),
            intersample: InterSample::Zoh,
        }
    }
}

/// An estimated process model (one per input, summed at the output), its
/// uncertainty and what the iterations did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProcessFit {
    /// One model per input, in input order (for P2D and P2DZ T₁ ≥ T₂).
    pub models: Vec<ProcessModel>,
    /// The estimated output offset ([`ProcessOptions::offset`]), else 0.
    pub offset: f64,
    /// Names of the estimated parameters: per input the
    /// [`ProcessKind::parameter_names`] suffixed `(u{j})`, then `offset`.
    pub names: Vec<String>,
    /// The estimated physical parameters in the order of `names`.
    pub parameters: Vec<f64>,
    /// Their covariance λ̂ (JᵀJ)⁻¹ at the optimum (J the Jacobian of the
    /// simulated measured samples with respect to the physical parameters,
    /// λ̂ = Σε² / (M − d)); NaN when JᵀJ is singular.
    pub covariance: DMatrix<f64>,
    /// Standard deviations, the square roots of the covariance's diagonal.
    pub std: Vec<f64>,
    /// Mean squared simulation error on the measured samples.
    pub loss: f64,
    /// Simulation fit, percent: 100 (1 − ‖ε‖/‖y − ȳ‖) on the measured
    /// samples.
    pub fit: f64,
    /// Measured output samples used (finite y).
    pub measured: usize,
    /// Levenberg–Marquardt iterations of the kept run.
    pub iterations: usize,
    /// Levenberg–Marquardt runs (starts) made.
    pub starts: usize,
}

impl ProcessFit {
    /// The simulated output for the inputs `u` (N × n_u, zero initial
    /// state), the offset included.
    ///
    /// Errors: [`Error::DimensionMismatch`] for a wrong column count,
    /// [`Error::NonFinite`] for NaN/inf in `u`.
    pub fn simulate(&self, u: &DMatrix<f64>) -> Result<Vec<f64>> {
        if u.ncols() != self.models.len() {
            return Err(Error::DimensionMismatch {
                what: "process-model input",
                expected: format!("{} columns", self.models.len()),
                got: format!("{}", u.ncols()),
            });
        }
        crate::checks::check_finite("u", u)?;
        let mut out = vec![self.offset; u.nrows()];
        for (j, m) in self.models.iter().enumerate() {
            m.validate()?;
            let col: Vec<f64> = u.column(j).iter().copied().collect();
            Discrete::new(m)?.add_response(&col, 1.0, &mut out);
        }
        Ok(out)
    }

    /// The exact discrete equivalent of the whole (MISO) model, every dead
    /// time included ([`ProcessModel::to_discrete_ss`]; ZOH in one `c2d`,
    /// FOH the inputs' models side by side); the offset is not in it.
    pub fn to_discrete_ss(&self) -> Result<lifted_lti::StateSpace> {
        if self
            .models
            .iter()
            .any(|m| m.intersample == InterSample::Foh)
        {
            return self.foh_discrete_ss();
        }
        let parts = self
            .models
            .iter()
            .map(ProcessModel::to_continuous_ss)
            .collect::<Result<Vec<_>>>()?;
        let ts = self.models.first().map_or(1.0, |m| m.ts);
        let cont = side_by_side(&parts, None)?;
        Ok(cont.c2d(
            ts,
            &lifted_lti::C2dOptions {
                input_delays: Some(self.models.iter().map(|m| m.theta).collect()),
                ..Default::default()
            },
        )?)
    }
}

impl ProcessFit {
    /// The FOH models' discrete forms side by side ([`side_by_side`]).
    fn foh_discrete_ss(&self) -> Result<lifted_lti::StateSpace> {
        let parts = self
            .models
            .iter()
            .map(ProcessModel::to_discrete_ss)
            .collect::<Result<Vec<_>>>()?;
        let ts = self.models.first().map_or(1.0, |m| m.ts);
        side_by_side(&parts, Some(ts))
    }
}

/// Single-input, single-output models side by side, one input each, the
/// output their sum: block-diagonal A, B and D one column per input, C
/// the row of the C's.
fn side_by_side(
    parts: &[lifted_lti::StateSpace],
    ts: Option<f64>,
) -> Result<lifted_lti::StateSpace> {
    let n: usize = parts.iter().map(|p| p.order()).sum();
    let m = parts.len();
    let (mut a, mut b, mut c, mut d) = (
        DMatrix::zeros(n, n),
        DMatrix::zeros(n, m),
        DMatrix::zeros(1, n),
        DMatrix::zeros(1, m),
    );
    let mut at = 0;
    for (j, p) in parts.iter().enumerate() {
        let k = p.order();
        a.view_mut((at, at), (k, k)).copy_from(p.a());
        b.view_mut((at, j), (k, 1)).copy_from(p.b());
        c.view_mut((0, at), (1, k)).copy_from(p.c());
        d[(0, j)] = p.d()[(0, 0)];
        at += k;
    }
    Ok(lifted_lti::StateSpace::new(a, b, c, d, ts)?)
}

/// The estimation problem: the records, the structure, the bounds.
struct Problem<'a> {
    kind: ProcessKind,
    ts: f64,
    intersample: InterSample,
    nu: usize,
    offset: bool,
    /// Per record, per input, the input samples.
    inputs: Vec<Vec<Vec<f64>>>,
    /// Per record, the output samples (NaN = not measured).
    outputs: Vec<&'a [f64]>,
    measured: usize,
    theta_max: f64,
    log_t: (f64, f64),
    /// Typical gain |y|/|u|, the scale of the gain's difference step.
    gain_scale: f64,
    /// Longest record, seconds.
    duration: f64,
    /// Per parameter, its held value in the internal coordinates φ
    /// ([`ProcessOptions::fixed`]); `None`: estimated.
    fixed: Vec<Option<f64>>,
}

/// Whether parameter `i` of a block of `kind` is carried as its logarithm.
fn is_log(kind: ProcessKind, i: usize) -> bool {
    match kind {
        ProcessKind::P1D | ProcessKind::P1DI => i == 1,
        _ => i == 1 || i == 2,
    }
}

impl Problem<'_> {
    fn block(&self) -> usize {
        self.kind.n_parameters()
    }

    fn n_phi(&self) -> usize {
        self.nu * self.block() + usize::from(self.offset)
    }

    /// Internal coordinates φ of physical parameters p (logs of the
    /// positive ones).
    fn to_phi(&self, p: &[f64]) -> Vec<f64> {
        let b = self.block();
        p.iter()
            .enumerate()
            .map(|(i, &v)| {
                if i < self.nu * b && is_log(self.kind, i % b) {
                    v.max(f64::MIN_POSITIVE).ln()
                } else {
                    v
                }
            })
            .collect()
    }

    fn to_physical(&self, phi: &[f64]) -> Vec<f64> {
        let b = self.block();
        phi.iter()
            .enumerate()
            .map(|(i, &v)| {
                if i < self.nu * b && is_log(self.kind, i % b) {
                    v.exp()
                } else {
                    v
                }
            })
            .collect()
    }

    /// Projects φ onto the box: θ ∈ [0, θ_max], time constants in
    /// [T/1000, 100 × record], ζ ∈ [0.01, 100].
    fn clamp(&self, phi: &mut [f64]) {
        self.box_clamp(phi);
        for (v, f) in phi.iter_mut().zip(&self.fixed) {
            if let Some(f) = f {
                *v = *f;
            }
        }
    }

    /// The estimated parameters' indices into φ.
    fn free(&self) -> Vec<usize> {
        (0..self.n_phi())
            .filter(|&i| self.fixed.get(i).is_none_or(Option::is_none))
            .collect()
    }

    fn box_clamp(&self, phi: &mut [f64]) {
        let b = self.block();
        for j in 0..self.nu {
            let blk = &mut phi[j * b..(j + 1) * b];
            blk[b - 1] = blk[b - 1].clamp(0.0, self.theta_max);
            for (i, v) in blk.iter_mut().enumerate() {
                if is_log(self.kind, i) {
                    *v = if self.kind == ProcessKind::P2DU && i == 2 {
                        v.clamp(0.01f64.ln(), 100f64.ln())
                    } else {
                        v.clamp(self.log_t.0, self.log_t.1)
                    };
                }
            }
        }
    }

    fn models(&self, phi: &[f64]) -> Result<(Vec<ProcessModel>, f64)> {
        let p = self.to_physical(phi);
        let b = self.block();
        let models = (0..self.nu)
            .map(|j| {
                ProcessModel::from_parameters(self.kind, &p[j * b..(j + 1) * b], self.ts)
                    .map(|m| m.with_intersample(self.intersample))
            })
            .collect::<Result<Vec<_>>>()?;
        let offset = if self.offset { p[p.len() - 1] } else { 0.0 };
        Ok((models, offset))
    }

    /// ŷ per record.
    fn simulate(&self, phi: &[f64]) -> Result<Vec<Vec<f64>>> {
        let (models, offset) = self.models(phi)?;
        let discrete = models
            .iter()
            .map(Discrete::new)
            .collect::<Result<Vec<_>>>()?;
        Ok(self
            .inputs
            .iter()
            .map(|us| {
                let mut out = vec![offset; us.first().map_or(0, Vec::len)];
                for (d, u) in discrete.iter().zip(us) {
                    d.add_response(u, 1.0, &mut out);
                }
                out
            })
            .collect())
    }

    fn cost(&self, phi: &[f64]) -> Result<f64> {
        let sims = self.simulate(phi)?;
        Ok(sims
            .iter()
            .zip(&self.outputs)
            .flat_map(|(s, y)| s.iter().zip(y.iter()))
            .filter(|(_, y)| !y.is_nan())
            .map(|(s, y)| (y - s) * (y - s))
            .sum())
    }

    /// The difference step of φ_i.
    fn step(&self, phi: &[f64], i: usize) -> f64 {
        let b = self.block();
        if i >= self.nu * b {
            return 1e-4 * (phi[i].abs() + self.gain_scale);
        }
        match i % b {
            0 => 1e-6 * phi[i].abs().max(1e-3 * self.gain_scale),
            r if r == b - 1 => 1e-4 * self.ts,
            r if is_log(self.kind, r) => 1e-5,
            _ => 1e-5 * phi[i].abs().max(self.ts), // T_z
        }
    }

    /// Cost and the R factor of [∂ŷ/∂φ | ε] (central differences, one-sided
    /// at a bound) over the measured samples.
    fn jacobian(&self, phi: &[f64]) -> Result<(f64, DMatrix<f64>)> {
        let free = self.free();
        let d = free.len();
        let base = self.simulate(phi)?;
        let mut cols: Vec<Vec<Vec<f64>>> = Vec::with_capacity(d);
        for &i in &free {
            let h = self.step(phi, i);
            let (mut hi, mut lo) = (phi.to_vec(), phi.to_vec());
            hi[i] += h;
            lo[i] -= h;
            self.clamp(&mut hi);
            self.clamp(&mut lo);
            let span = hi[i] - lo[i];
            let (sh, sl) = (self.simulate(&hi)?, self.simulate(&lo)?);
            cols.push(
                sh.iter()
                    .zip(&sl)
                    .map(|(a, b)| {
                        a.iter()
                            .zip(b)
                            .map(|(x, y)| if span > 0.0 { (x - y) / span } else { 0.0 })
                            .collect()
                    })
                    .collect(),
            );
        }
        let mut acc = RAccumulator::new(d + 1);
        let mut block = Vec::new();
        let mut rows = 0;
        let mut cost = 0.0;
        for (e, y) in self.outputs.iter().enumerate() {
            for (t, &yt) in y.iter().enumerate() {
                if yt.is_nan() {
                    continue;
                }
                let eps = yt - base[e][t];
                cost += eps * eps;
                block.extend(cols.iter().map(|c| c[e][t]));
                block.push(eps);
                rows += 1;
                if rows == BLOCK_ROWS {
                    acc.push_rows(&DMatrix::from_row_slice(rows, d + 1, &block))?;
                    block.clear();
                    rows = 0;
                }
            }
        }
        if rows > 0 {
            acc.push_rows(&DMatrix::from_row_slice(rows, d + 1, &block))?;
        }
        Ok((cost, acc.r()))
    }

    /// Levenberg–Marquardt from φ₀; returns (φ, cost, iterations).
    fn iterate(&self, mut phi: Vec<f64>, opts: &ProcessOptions) -> Result<(Vec<f64>, f64, usize)> {
        let free = self.free();
        let d = free.len();
        self.clamp(&mut phi);
        let mut lambda: f64 = 1e-3;
        let (mut cost, mut r) = self.jacobian(&phi)?;
        let mut iterations = 0;
        while iterations < opts.max_iterations && r.nrows() >= d {
            iterations += 1;
            let r11 = r.view((0, 0), (d, d)).into_owned();
            let r12 = r.view((0, d), (d, 1)).column(0).into_owned();
            let scale: Vec<f64> = (0..d)
                .map(|j| r11.column(j).norm().max(f64::MIN_POSITIVE))
                .collect();
            let mut accepted = false;
            for _ in 0..16 {
                // Rows [G | ε] with G = ∂ŷ/∂φ: the damped Gauss–Newton step
                // solves [R₁₁; √λ D] δ = [r; 0].
                let mut m = DMatrix::zeros(2 * d, d + 1);
                m.view_mut((0, 0), (d, d)).copy_from(&r11);
                for j in 0..d {
                    m[(d + j, j)] = lambda.sqrt() * scale[j];
                    m[(j, d)] = r12[j];
                }
                let q = lifted_linalg::qr_r(&m)?;
                let Some(delta) = q
                    .view((0, 0), (d, d))
                    .into_owned()
                    .solve_upper_triangular(&q.view((0, d), (d, 1)).into_owned())
                else {
                    lambda *= 4.0;
                    continue;
                };
                let mut trial = phi.clone();
                for (&i, dv) in free.iter().zip(delta.iter()) {
                    trial[i] += dv;
                }
                self.clamp(&mut trial);
                let c = self.cost(&trial)?;
                if c < cost {
                    let moved = DVector::from_iterator(
                        phi.len(),
                        trial.iter().zip(&phi).map(|(a, b)| a - b),
                    );
                    let small_step = moved.norm()
                        <= opts.tolerance.sqrt() * (1.0 + DVector::from_column_slice(&phi).norm());
                    let small_gain = cost - c <= opts.tolerance * cost;
                    phi = trial;
                    lambda = (lambda / 3.0).max(1e-12);
                    accepted = true;
                    (cost, r) = self.jacobian(&phi)?;
                    if small_step || small_gain {
                        return Ok((phi, cost, iterations));
                    }
                    break;
                }
                lambda *= 4.0;
            }
            if !accepted {
                break;
            }
        }
        Ok((phi, cost, iterations))
    }

    /// P2D and P2DZ: T₁ ≥ T₂ (the transfer function is symmetric in them).
    fn canonical(&self, phi: &mut [f64]) {
        if matches!(self.kind, ProcessKind::P2D | ProcessKind::P2DZ) {
            let b = self.block();
            for j in 0..self.nu {
                let held = |i: usize| self.fixed.get(i).is_some_and(Option::is_some);
                if phi[j * b + 1] < phi[j * b + 2] && !held(j * b + 1) && !held(j * b + 2) {
                    phi.swap(j * b + 1, j * b + 2);
                }
            }
        }
    }
}

/// Process model of structure `kind` from every input to the single output
/// of the records, sample period `ts`: the simulation error over the
/// measured output samples (NaN = not measured) minimised by
/// Levenberg–Marquardt from several starts; see the module docs.
///
/// The records are deviations from the operating point and start at rest
/// (zero initial state): remove the operating point (the values before the
/// test) first, or set [`ProcessOptions::offset`] for a constant output
/// offset.
///
/// Cost: the start grid evaluates ≤ 78 shapes (P2D, P2DZ; 12 for P1D and
/// P1DI, 60 for P2DU) × 64 dead times × M measured samples; each
/// iteration 2d + 1 simulations of O(N) and a QR of O(M d²) (d ≤ 6
/// parameters per input).
///
/// Errors: [`Error::NoData`]; [`Error::DimensionMismatch`] for a y with
/// other than one column, or records whose shapes differ;
/// [`Error::NonFinite`] for NaN/inf in u or an infinite y;
/// [`Error::InvalidOption`] for `ts` or an option out of range;
/// [`Error::RankDeficient`] for an input that is constant in every record
/// (no step or change to identify from); [`Error::TooFewSamples`] for no
/// more measured samples than twice the parameters.
pub fn procest(
    experiments: &[Experiment<'_>],
    kind: ProcessKind,
    ts: f64,
    opts: &ProcessOptions,
) -> Result<ProcessFit> {
    let first = experiments.first().ok_or(Error::NoData)?;
    let nu = first.u.ncols();
    if !(ts.is_finite() && ts > 0.0) {
        return Err(Error::InvalidOption {
            what: "ts",
            reason: format!("the sample period must be finite and > 0, got {ts}"),
        });
    }
    if opts.max_iterations == 0
        || !(opts.tolerance.is_finite() && opts.tolerance > 0.0)
        || opts.starts == 0
    {
        return Err(Error::InvalidOption {
            what: "process-model iterations",
            reason: "max_iterations ≥ 1, starts ≥ 1 and a positive finite tolerance".into(),
        });
    }
    if let Some(m) = opts.max_delay
        && !(m.is_finite() && m >= 0.0)
    {
        return Err(Error::InvalidOption {
            what: "max_delay",
            reason: format!("must be finite and ≥ 0, got {m}"),
        });
    }
    if nu == 0 {
        return Err(Error::DimensionMismatch {
            what: "process-model input",
            expected: "at least one input column".into(),
            got: "0".into(),
        });
    }
    for e in experiments {
        crate::checks::check_record_shape("record (u, y)", e.u, e.y, nu, 1)?;
        if e.u.nrows() == 0 {
            return Err(Error::NoData);
        }
        crate::checks::check_finite("u", e.u)?;
        if let Some(k) = e.y.iter().position(|v| v.is_infinite()) {
            return Err(Error::NonFinite {
                what: "y",
                row: k,
                col: 0,
            });
        }
    }
    for j in 0..nu {
        let varies = experiments.iter().any(|e| {
            let c = e.u.column(j);
            c.iter().any(|&v| v != c[0])
        });
        if !varies {
            return Err(Error::RankDeficient {
                what: "the process-model inputs (an input constant in every record: no step or change to identify from)",
                rank: 0,
                needed: 1,
            });
        }
    }
    let measured = experiments
        .iter()
        .map(|e| e.y.iter().filter(|v| !v.is_nan()).count())
        .sum::<usize>();
    let d = nu * kind.n_parameters() + usize::from(opts.offset);
    if measured <= 2 * d {
        return Err(Error::TooFewSamples {
            what: "the process model",
            measured,
            needed: 2 * d + 1,
        });
    }
    let longest = experiments.iter().map(|e| e.u.nrows()).max().unwrap_or(0);
    let duration = longest as f64 * ts;
    let rms = |it: &mut dyn Iterator<Item = f64>| {
        let (s, n) = it.fold((0.0, 0usize), |a, v| (a.0 + v * v, a.1 + 1));
        (s / n.max(1) as f64).sqrt()
    };
    let y_rms = rms(&mut experiments
        .iter()
        .flat_map(|e| e.y.iter().copied().filter(|v| !v.is_nan())));
    let u_rms = rms(&mut experiments.iter().flat_map(|e| e.u.iter().copied()));
    let held = held_parameters(kind, nu, opts)?;
    let theta_max = held
        .iter()
        .enumerate()
        .filter(|(i, v)| {
            v.is_some() && *i < nu * kind.n_parameters() && (i + 1) % kind.n_parameters() == 0
        })
        .filter_map(|(_, v)| *v)
        .fold(opts.max_delay.unwrap_or(duration / 3.0), f64::max);
    let p = Problem {
        kind,
        ts,
        intersample: opts.intersample,
        nu,
        offset: opts.offset,
        inputs: experiments
            .iter()
            .map(|e| {
                (0..nu)
                    .map(|j| e.u.column(j).iter().copied().collect())
                    .collect()
            })
            .collect(),
        outputs: experiments.iter().map(|e| e.y.as_slice()).collect(),
        measured,
        theta_max,
        log_t: ((ts * 1e-3).ln(), (duration * 100.0).ln()),
        gain_scale: if u_rms > 0.0 && y_rms > 0.0 {
            y_rms / u_rms
        } else {
            1.0
        },
        duration,
        fixed: Vec::new(),
    };
    // The held values in the internal coordinates.
    let p = Problem {
        fixed: held
            .iter()
            .enumerate()
            .map(|(i, v)| {
                v.map(|v| {
                    if i < nu * kind.n_parameters() && is_log(kind, i % kind.n_parameters()) {
                        v.ln()
                    } else {
                        v
                    }
                })
            })
            .collect(),
        ..p
    };
    let starts = starts(&p, opts)?;
    let mut best: Option<(Vec<f64>, f64, usize)> = None;
    let n_starts = starts.len();
    for s in starts {
        let phi0 = p.to_phi(&s);
        let (phi, cost, its) = p.iterate(phi0, opts)?;
        if best.as_ref().is_none_or(|b| cost < b.1) {
            best = Some((phi, cost, its));
        }
    }
    let Some((mut phi, _, iterations)) = best else {
        return Err(Error::RankDeficient {
            what: "the process-model start grid (no shape and dead time gives a determined gain)",
            rank: 0,
            needed: d,
        });
    };
    p.canonical(&mut phi);
    finish(&p, phi, iterations, n_starts)
}

/// The held parameters of [`ProcessOptions::fixed`] in physical units, one
/// entry per parameter of the fit (inputs' blocks, then the offset).
///
/// Errors: [`Error::InvalidOption`] naming an unknown parameter (with the
/// names there are) or a value out of its range (a time constant or ζ not
/// positive, a dead time negative, not finite).
fn held_parameters(
    kind: ProcessKind,
    nu: usize,
    opts: &ProcessOptions,
) -> Result<Vec<Option<f64>>> {
    let names = kind.parameter_names();
    let b = names.len();
    let mut held = vec![None; nu * b + usize::from(opts.offset)];
    for (name, value) in &opts.fixed {
        let bad = |reason: String| Error::InvalidOption {
            what: "fixed process parameter",
            reason,
        };
        if !value.is_finite() {
            return Err(bad(format!("{name} = {value}: not finite")));
        }
        let targets: Vec<usize> = if name == "offset" && opts.offset {
            vec![nu * b]
        } else if let Some(i) = names.iter().position(|n| n == name) {
            (0..nu).map(|j| j * b + i).collect()
        } else {
            let one = (0..nu)
                .flat_map(|j| (0..b).map(move |i| (j, i)))
                .find(|&(j, i)| *name == format!("{}(u{j})", names[i]));
            match one {
                Some((j, i)) => vec![j * b + i],
                None => {
                    return Err(bad(format!(
                        "no parameter '{name}' in a {kind:?} model; its parameters are {} (every input), {}(u0) … (one input){}",
                        names.join(", "),
                        names[0],
                        if opts.offset { " and offset" } else { "" }
                    )));
                }
            }
        };
        for t in targets {
            let slot = if t < nu * b { t % b } else { usize::MAX };
            if slot == b - 1 && *value < 0.0 {
                return Err(bad(format!("{name} = {value}: a dead time is ≥ 0")));
            }
            if slot != usize::MAX && is_log(kind, slot) && *value <= 0.0 {
                return Err(bad(format!("{name} = {value}: must be > 0")));
            }
            held[t] = Some(*value);
        }
    }
    Ok(held)
}

/// The fit at φ: models, covariance in the physical parameters, loss, fit.
fn finish(p: &Problem<'_>, phi: Vec<f64>, iterations: usize, starts: usize) -> Result<ProcessFit> {
    let d = p.n_phi();
    let free = p.free();
    let df = free.len();
    let (cost, r) = p.jacobian(&phi)?;
    let (models, offset) = p.models(&phi)?;
    let parameters = p.to_physical(&phi);
    let lambda = cost / (p.measured - df) as f64;
    // Cov p = D Cov φ D with D = diag(∂p/∂φ) (p for a logarithm, else 1):
    // the same as λ̂ (J_pᵀ J_p)⁻¹ since J_p = J_φ D⁻¹.
    let dvec: Vec<f64> = (0..d)
        .map(|i| {
            if i < p.nu * p.block() && is_log(p.kind, i % p.block()) {
                parameters[i]
            } else {
                1.0
            }
        })
        .collect();
    let inv = (r.nrows() >= df)
        .then(|| {
            r.view((0, 0), (df, df))
                .into_owned()
                .solve_upper_triangular(&DMatrix::identity(df, df))
        })
        .flatten();
    // The free parameters' covariance; a held one has none.
    let mut covariance = DMatrix::zeros(d, d);
    match inv {
        Some(inv) => {
            let c = &inv * inv.transpose() * lambda;
            for (x, &a) in free.iter().enumerate() {
                for (y, &b) in free.iter().enumerate() {
                    covariance[(a, b)] = 0.5 * (c[(x, y)] + c[(y, x)]) * dvec[a] * dvec[b];
                }
            }
        }
        None => {
            for &a in &free {
                for &b in &free {
                    covariance[(a, b)] = f64::NAN;
                }
            }
        }
    }
    let std = (0..d).map(|i| covariance[(i, i)].max(0.0).sqrt()).collect();
    let mut names = Vec::with_capacity(d);
    for j in 0..p.nu {
        for n in p.kind.parameter_names() {
            names.push(format!("{n}(u{j})"));
        }
    }
    if p.offset {
        names.push("offset".into());
    }
    let values: Vec<f64> = p
        .outputs
        .iter()
        .flat_map(|y| y.iter().copied().filter(|v| !v.is_nan()))
        .collect();
    let mean = values.iter().sum::<f64>() / values.len().max(1) as f64;
    let spread = values
        .iter()
        .map(|v| (v - mean).powi(2))
        .sum::<f64>()
        .sqrt();
    Ok(ProcessFit {
        models,
        offset,
        names,
        parameters,
        covariance,
        std,
        loss: cost / p.measured as f64,
        fit: if spread > 0.0 {
            100.0 * (1.0 - cost.sqrt() / spread)
        } else {
            f64::NAN
        },
        measured: p.measured,
        iterations,
        starts,
    })
}

#[cfg(test)]
mod two_point_tests;

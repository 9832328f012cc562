//! Model validation on a data set (Ljung's classical checks): the
//! simulation fit, k-step-ahead prediction fits with a Kalman gain, the
//! whiteness of the residual and its independence of the inputs.
//!
//! * fit = 100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖) per output, at the output's own
//!   sampling instants (multirate records: measured samples only); ŷ is
//!   simulated from the initial state x₀ that fits the record best in
//!   least squares (by default, as MATLAB's `compare`; a slow plant's
//!   transient from x₀ = 0 would otherwise dominate the fit) or from zero
//!   ([`InitialCondition`]);
//! * whiteness: r_e(τ)/r_e(0), τ = 1…M, of the centred residual e: the
//!   one-step prediction error y − ŷ(k|k−1) of the model with its Kalman
//!   gain (single-rate records; as MATLAB's `resid`: a model with a noise
//!   model is judged by its innovations, which are white when it is
//!   right), else the simulation error y − ŷ (an output-error model's
//!   prediction error) — [`Validation::residual`] says which;
//! * independence: r_eu(τ)/√(r_e(0) r_u(0)), τ = −M…M, per input;
//! * both pass when at most max(1, ⌈len/100⌉) correlations leave the 99 %
//!   band ±2.576/√N (N residual samples).
//!
//! Cost: one simulation O(N·n²), one prediction per horizon O(N·n²), the
//! correlations O(N·M·(n_u + 1)) per output; the initial state
//! O(K n_y n²) with K ≤ N the samples until the free response C Aᵏ has
//! decayed below 1e-30 of C (an R-only QR of K n_y rows of n + 1 columns,
//! accumulated in blocks: memory O(n²)).

use nalgebra::{DMatrix, DVector};

use crate::data::Dataset;
use crate::discretize::C2dOptions;
use crate::error::{Error, Result};
use crate::operating_point::OperatingPoint;
use crate::ss::StateSpace;

/// 99 % two-sided normal quantile.
const Z99: f64 = 2.576;

/// Options of [`validate`].
#[derive(Debug, Clone, PartialEq)]
pub struct ValidationOptions {
    /// Correlation lags M. Default 20.
    pub lags: usize,
    /// Operating point of the model (the data are compared in plant units:
    /// u − u₀ drives the model, y₀ is added back). Default none.
    pub operating_point: Option<OperatingPoint>,
    /// Kalman gain K (n × p) for the k-step-ahead prediction fits; used
    /// only when the model is discrete at the data's period. Default none.
    pub kalman_gain: Option<DMatrix<f64>>,
    /// Horizons k of the prediction fits. Default [1, 5].
    pub horizons: Vec<usize>,
    /// Initial state of the simulation. Default
    /// [`InitialCondition::Estimate`].
    pub initial_state: InitialCondition,
}

impl Default for ValidationOptions {
    fn default() -> Self {
        Self {
            lags: 20,
            operating_point: None,
            kalman_gain: None,
            horizons: vec![1, 5],
            initial_state: InitialCondition::Estimate,
        }
    }
}

/// The initial state of the validation's simulation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum InitialCondition {
    /// The x₀ minimising Σ ‖y(k) − ŷ(k)‖² over the measured samples
    /// (least squares on the free response C Aᵏ x₀; the default, as
    /// MATLAB's `compare`). Only for a stable model at the data's period
    /// (an unstable one is simulated from zero: its fit is not meaningful
    /// either way).
    #[default]
    Estimate,
    /// x₀ = 0.
    Zero,
}

/// Results for one output.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputValidation {
    /// Output name (from the data set).
    pub name: String,
    /// Simulation fit in percent (NaN for a constant output).
    pub fit: f64,
    /// Prediction fits in percent, one per horizon (empty without a gain).
    pub prediction_fits: Vec<f64>,
    /// Samples compared.
    pub samples: usize,
    /// 99 % confidence bound of the correlations.
    pub bound: f64,
    /// Residual autocorrelation for τ = 1…M.
    pub auto: Vec<f64>,
    /// Cross-correlation with each input for τ = −M…M (one vector per input).
    pub cross: Vec<Vec<f64>>,
    /// Whiteness test passed.
    pub white: bool,
    /// Independence test passed.
    pub independent: bool,
    /// Every residual is finite. When false (a diverging simulation of an
    /// unstable model), the fit is NaN or meaningless, the correlations are
    /// NaN and neither test passes.
    pub residual_finite: bool,
    /// Sample indices compared (the output's measured instants).
    pub instants: Vec<usize>,
    /// Measured output at those instants.
    pub measured: Vec<f64>,
    /// Simulated output at every base instant (plant units).
    pub simulated: Vec<f64>,
}

/// The residual the whiteness and independence tests are computed on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Residual {
    /// The one-step prediction error with the model's Kalman gain.
    OneStepPrediction,
    /// The simulation error (no Kalman gain, or a multirate record).
    Simulation,
}

impl Residual {
    /// A short name: "one-step prediction" or "simulation".
    pub fn name(self) -> &'static str {
        match self {
            Residual::OneStepPrediction => "one-step prediction",
            Residual::Simulation => "simulation",
        }
    }
}

/// Validation of a model on a data set.
#[derive(Debug, Clone, PartialEq)]
pub struct Validation {
    /// Per output, in the data set's order.
    pub outputs: Vec<OutputValidation>,
    /// The residual of the whiteness and independence tests.
    pub residual: Residual,
    /// Lags M.
    pub lags: usize,
    /// Horizons of the prediction fits (empty when no gain was used).
    pub horizons: Vec<usize>,
    /// Spectral radius ρ(A) of the model at the data's period (0 for a
    /// static gain).
    pub spectral_radius: f64,
    /// The initial state the simulation started from when it was estimated
    /// ([`InitialCondition::Estimate`] on a stable model); `None` for zero.
    pub x0: Option<DVector<f64>>,
}

impl Validation {
    /// Whether the model is stable (ρ(A) < 1): otherwise its simulation
    /// diverges and the simulation fits are not meaningful.
    pub fn stable(&self) -> bool {
        self.spectral_radius < 1.0
    }
}

/// 100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖); NaN for a constant `y`. O(N).
pub fn fit_percent(y: &[f64], yhat: &[f64]) -> f64 {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            let mean = y.iter().sum::<f64>() / y.len() as f64;
            let ne = y
                .iter()
                .zip(yhat)
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>()
                .sqrt();
            let nd = y.iter().map(|v| (v - mean).powi(2)).sum::<f64>().sqrt();
            if ne.is_finite() && nd.is_finite() && nd > f64::MIN_POSITIVE {
                return 100.0 * (1.0 - ne / nd);
            }
            // Outputs in units near the ends of the double range (the squares
            // overflow or underflow): the same ratio with every term divided by
            // the largest deviation from the mean.
            let big = y.iter().fold(0.0_f64, |m, v| m.max((v - mean).abs()));
            if !(big.is_finite() && big > 0.0) {
                return f64::NAN;
            }
            let norm = |it: &mut dyn Iterator<Item = f64>| {
                it.map(|v| (v / big).powi(2)).sum::<f64>().sqrt()
            };
            let ne = norm(&mut y.iter().zip(yhat).map(|(a, b)| a - b));
            let nd = norm(&mut y.iter().map(|v| v - mean));
            if nd > 0.0 {
                100.0 * (1.0 - ne / nd)
            } else {
                f64::NAN
            }
        },
    )
}

/// `v` itself, or divided by its largest magnitude when its squares would
/// overflow or underflow (values near the ends of the double range): the
/// normalised correlations do not change.
fn in_range(v: Vec<f64>) -> Vec<f64> {
    let big = v.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    if big.is_finite() && big > 0.0 && !(1e-150..=1e150).contains(&big) {
        v.into_iter().map(|x| x / big).collect()
    } else {
        v
    }
}

/// At most max(1, ⌈len/100⌉) of the correlations `r` outside ±`bound`;
/// never when one is not finite.
fn passes(r: &[f64], bound: f64) -> bool {
    if r.iter().any(|v| !v.is_finite()) {
        return false;
    }
    let outside = r.iter().filter(|v| v.abs() > bound).count();
    outside <= r.len().div_ceil(100).max(1)
}

/// Σ_k a(k+τ) b(k) over the overlap.
/// Σ_k a[k + τ] b[k] over the overlap, in four interleaved partial sums
/// (independent chains the compiler vectorises; the result differs from
/// the serial sum by rounding only). O(N) per lag.
fn corr(a: &[f64], b: &[f64], tau: i64) -> f64 {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            let n = a.len() as i64;
            let (lo, hi) = ((-tau).max(0), (n - tau).min(n));
            if hi <= lo {
                return 0.0;
            }
            let (lo, hi) = (lo as usize, hi as usize);
            let shift = |k: usize| (k as i64 + tau) as usize;
            let (x, y) = (&a[shift(lo)..shift(hi)], &b[lo..hi]);
            let mut acc = [0.0f64; 4];
            let (xc, yc) = (x.chunks_exact(4), y.chunks_exact(4));
            let (xr, yr) = (xc.remainder(), yc.remainder());
            for (p, q) in xc.zip(yc) {
                for j in 0..4 {
                    acc[j] += p[j] * q[j];
                }
            }
            let tail: f64 = xr.iter().zip(yr).map(|(p, q)| p * q).sum();
            (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
        },
    )
}

fn centred(v: &[f64]) -> Vec<f64> {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    v.iter().map(|x| x - m).collect()
}

/// The model at the data's base period: a continuous model is discretised
/// by ZOH; a discrete one must have the data's period.
///
/// Errors: [`Error::DomainMismatch`] for another sample period.
pub fn at_rate(model: &StateSpace, ts: f64) -> Result<StateSpace> {
    match model.ts() {
        None => model.c2d(ts, &C2dOptions::default()),
        Some(t) if (t - ts).abs() <= 1e-9 * t => Ok(model.clone()),
        Some(t) => Err(Error::DomainMismatch {
            what: "model sample period vs data base period",
            left: Some(t),
            right: Some(ts),
        }),
    }
}

/// What [`validate`] and [`simulation_fits`] share: the model at the
/// data's rate, the operating point, the deviations, the simulated outputs
/// (from the fitted x₀ when asked), x₀ and the spectral radius.
struct Simulated {
    m: StateSpace,
    op: OperatingPoint,
    du: DMatrix<f64>,
    dy: DMatrix<f64>,
    sim: DMatrix<f64>,
    x0: Option<DVector<f64>>,
    spectral_radius: f64,
}

/// The simulation of [`validate`] (its channels checked).
fn simulated(model: &StateSpace, data: &Dataset, opts: &ValidationOptions) -> Result<Simulated> {
    let m = at_rate(model, data.ts())?;
    let op = opts
        .operating_point
        .clone()
        .unwrap_or_else(|| OperatingPoint::zero(model.n_inputs(), model.n_outputs()));
    let (du, dy) = op.to_deviations(data.u(), data.y())?;
    let mut sim = op.add_output(&m.lsim_outputs(&du, None)?)?;
    let spectral_radius = if m.order() == 0 {
        0.0
    } else {
        m.poles()?.iter().map(|p| p.norm()).fold(0.0, f64::max)
    };
    let x0 = match opts.initial_state {
        InitialCondition::Estimate if m.order() > 0 && spectral_radius < 1.0 => {
            let x0 = initial_state(&m, data, &sim)?;
            free_response(&m, &x0, &mut sim);
            Some(x0)
        }
        _ => None,
    };
    Ok(Simulated {
        m,
        op,
        du,
        dy,
        sim,
        x0,
        spectral_radius,
    })
}

/// One output's simulation fit ([`simulation_fits`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimulationFit {
    /// The fit, % (NaN when the error is not finite), as
    /// [`OutputValidation::fit`].
    pub fit: f64,
    /// Whether the simulation error is finite.
    pub finite: bool,
    /// Measured samples of the output.
    pub samples: usize,
}

/// The simulation fit of each output as [`validate`] reports it (the same
/// numbers bit for bit: the same simulation, x₀ and fit), without the
/// predictions and the residual tests: O(N n (n + n_u + n_y)).
/// `opts.lags`, `opts.horizons` and `opts.kalman_gain` are not used.
///
/// Errors: those of [`validate`] but the lags' and horizons'.
pub fn simulation_fits(
    model: &StateSpace,
    data: &Dataset,
    opts: &ValidationOptions,
) -> Result<Vec<SimulationFit>> {
    if model.n_inputs() != data.n_inputs() || model.n_outputs() != data.n_outputs() {
        return Err(Error::DimensionMismatch {
            what: "data channels vs model",
            expected: format!("{} inputs, {} outputs", model.n_inputs(), model.n_outputs()),
            got: format!("{} inputs, {} outputs", data.n_inputs(), data.n_outputs()),
        });
    }
    let sim = simulated(model, data, opts)?.sim;
    (0..data.n_outputs())
        .map(|o| {
            let (idx, y) = data.output_samples(o)?;
            let yhat: Vec<f64> = idx.iter().map(|&k| sim[(k, o)]).collect();
            let finite = y.iter().zip(&yhat).all(|(a, b)| (a - b).is_finite());
            Ok(SimulationFit {
                fit: if finite {
                    fit_percent(&y, &yhat)
                } else {
                    f64::NAN
                },
                finite,
                samples: y.len(),
            })
        })
        .collect()
}

/// Records of at least this many samples are validated an output per
/// thread on two threads (below it a thread costs more than it saves).
const PARALLEL_SAMPLES: usize = 20_000;

/// Validates `model` on `data` (see the module docs).
///
/// Errors: [`Error::DimensionMismatch`] when the channels differ from the
/// model's or the operating point's, or the gain is not n × p;
/// [`Error::DomainMismatch`] for another sample period;
/// [`Error::InvalidArgument`] when M is 0, an output has fewer than 2M + 2
/// samples or a horizon is 0; simulation errors.
pub fn validate(
    model: &StateSpace,
    data: &Dataset,
    opts: &ValidationOptions,
) -> Result<Validation> {
    if model.n_inputs() != data.n_inputs() || model.n_outputs() != data.n_outputs() {
        return Err(Error::DimensionMismatch {
            what: "data channels vs model",
            expected: format!("{} inputs, {} outputs", model.n_inputs(), model.n_outputs()),
            got: format!("{} inputs, {} outputs", data.n_inputs(), data.n_outputs()),
        });
    }
    if opts.horizons.contains(&0) {
        return Err(Error::InvalidArgument {
            what: "horizons",
            reason: "a prediction horizon must be at least 1".into(),
        });
    }
    if opts.lags == 0 {
        // No lag tested would pass both tests with nothing tested.
        return Err(Error::InvalidArgument {
            what: "lags",
            reason: "at least 1 correlation lag is needed for the residual tests".into(),
        });
    }
    let Simulated {
        m,
        op,
        du,
        dy,
        sim,
        x0,
        spectral_radius,
    } = simulated(model, data, opts)?;
    let gain = opts.kalman_gain.as_ref().filter(|_| model.ts().is_some());
    if let Some(k) = gain
        && k.shape() != (m.order(), m.n_outputs())
    {
        return Err(Error::DimensionMismatch {
            what: "Kalman gain",
            expected: format!("{}x{}", m.order(), m.n_outputs()),
            got: format!("{}x{}", k.nrows(), k.ncols()),
        });
    }
    // Every horizon from one run of the one-step predictor.
    let predictions: Vec<DMatrix<f64>> = match gain {
        Some(k) => m
            .predict_horizons(k, &du, &dy, &opts.horizons, x0.as_ref())?
            .iter()
            .map(|p| op.add_output(p))
            .collect::<Result<_>>()?,
        None => Vec::new(),
    };
    // The tests' residual: the innovations of the model with its gain on a
    // single-rate record, else the simulation error.
    let one_step: Option<DMatrix<f64>> = match gain {
        Some(k) if data.is_single_rate() => match opts.horizons.iter().position(|&h| h == 1) {
            Some(i) => Some(predictions[i].clone()),
            None => Some(op.add_output(&m.predict_from(k, &du, &dy, 1, x0.as_ref())?)?),
        },
        _ => None,
    };
    let residual = if one_step.is_some() {
        Residual::OneStepPrediction
    } else {
        Residual::Simulation
    };
    let lags = opts.lags;
    // One output's validation (its fits and residual tests).
    let one = |o: usize, ch: &crate::data::OutputChannel| -> Result<OutputValidation> {
        let (idx, y) = data.output_samples(o)?;
        let n = y.len();
        if n < 2 * lags + 2 {
            return Err(Error::InvalidArgument {
                what: "lags",
                reason: format!(
                    "output '{}' has {n} samples, too few for {lags} correlation lags",
                    ch.name
                ),
            });
        }
        let yhat: Vec<f64> = idx.iter().map(|&k| sim[(k, o)]).collect();
        let sim_error: Vec<f64> = y.iter().zip(&yhat).map(|(a, b)| a - b).collect();
        let e: Vec<f64> = match &one_step {
            Some(p) => idx.iter().zip(&y).map(|(&k, a)| a - p[(k, o)]).collect(),
            None => sim_error.clone(),
        };
        let prediction_fits = predictions
            .iter()
            .map(|p| {
                let yp: Vec<f64> = idx.iter().map(|&k| p[(k, o)]).collect();
                fit_percent(&y, &yp)
            })
            .collect();
        let residual_finite =
            e.iter().all(|v| v.is_finite()) && sim_error.iter().all(|v| v.is_finite());
        let ec = in_range(centred(&e));
        let r0 = corr(&ec, &ec, 0);
        let auto: Vec<f64> = (1..=lags as i64)
            .map(|t| {
                if !residual_finite {
                    f64::NAN
                } else if r0 > 0.0 {
                    corr(&ec, &ec, t) / r0
                } else {
                    0.0
                }
            })
            .collect();
        let cross: Vec<Vec<f64>> = (0..data.n_inputs())
            .map(|i| {
                let u: Vec<f64> = idx.iter().map(|&k| data.u()[(k, i)]).collect();
                let uc = in_range(centred(&u));
                let den = (r0 * corr(&uc, &uc, 0)).sqrt();
                (-(lags as i64)..=lags as i64)
                    .map(|t| {
                        if !residual_finite {
                            f64::NAN
                        } else if den > 0.0 {
                            corr(&ec, &uc, t) / den
                        } else {
                            0.0
                        }
                    })
                    .collect()
            })
            .collect();
        let bound = Z99 / (n as f64).sqrt();
        let fit = if residual_finite {
            fit_percent(&y, &yhat)
        } else {
            f64::NAN
        };
        Ok(OutputValidation {
            name: ch.name.clone(),
            fit,
            residual_finite,
            prediction_fits,
            samples: n,
            bound,
            white: passes(&auto, bound),
            independent: cross.iter().all(|c| passes(c, bound)),
            auto,
            cross,
            instants: idx,
            measured: y,
            simulated: sim.column(o).iter().copied().collect(),
        })
    };
    // The outputs on two threads for long records with several outputs
    // (the same numbers; the first error in output order either way).
    let channels = data.outputs();
    let apart = channels.len() > 1
        && data.len() >= PARALLEL_SAMPLES
        && std::thread::available_parallelism().map_or(1, |n| n.get()) > 1;
    let results: Vec<Result<OutputValidation>> = if apart {
        let half = channels.len() / 2;
        std::thread::scope(|scope| {
            let later = scope.spawn(|| {
                (half..channels.len())
                    .map(|o| one(o, &channels[o]))
                    .collect::<Vec<_>>()
            });
            let mut first: Vec<_> = (0..half).map(|o| one(o, &channels[o])).collect();
            match later.join() {
                Ok(rest) => first.extend(rest),
                Err(_) => first.extend((half..channels.len()).map(|o| one(o, &channels[o]))),
            }
            first
        })
    } else {
        channels
            .iter()
            .enumerate()
            .map(|(o, ch)| one(o, ch))
            .collect()
    };
    let outputs = results.into_iter().collect::<Result<Vec<_>>>()?;
    Ok(Validation {
        outputs,
        residual,
        spectral_radius,
        x0,
        lags,
        horizons: if predictions.is_empty() {
            Vec::new()
        } else {
            opts.horizons.clone()
        },
    })
}

/// Below this fraction of max |C| the free response C Aᵏ counts as died
/// out (its rows no longer inform x₀; the simulation is left as it is).
const DECAYED: f64 = 1e-30;

/// Rows per block folded into the initial state's R factor.
const X0_BLOCK: usize = 256;

/// The least-squares x₀ of the free response C Aᵏ x₀ against the residual
/// of the zero-state simulation `sim` (plant units) at every measured
/// sample of `data`, each output's rows divided by its standard deviation
/// (as the fit is: the x₀ does not depend on the outputs' units, and an
/// output logged in large units does not take the whole fit), by an
/// R-only QR of [W C Aᵏ | W (y − ŷ)] accumulated over the samples until
/// W C Aᵏ has decayed (the later rows add nothing on x₀) and the
/// minimum-norm least-squares solution on R (an unobservable direction gets
/// 0). O(K n_y n²).
fn initial_state(m: &StateSpace, data: &Dataset, sim: &DMatrix<f64>) -> Result<DVector<f64>> {
    let (n, ny) = (m.order(), m.n_outputs());
    let y = data.y();
    // W: 1 / the standard deviation of each output's measured samples.
    let weights: Vec<f64> = (0..ny)
        .map(|o| 1.0 / crate::data::channel_scale(y.column(o).iter()))
        .collect();
    let mut acc = lifted_linalg::RAccumulator::new(n + 1);
    let mut block = DMatrix::zeros(X0_BLOCK, n + 1);
    let mut used = 0;
    // W C Aᵏ and the next one in two buffers (no allocation per sample).
    let mut ca = m.c().clone_owned();
    for (o, w) in weights.iter().enumerate() {
        ca.row_mut(o).iter_mut().for_each(|v| *v *= w);
    }
    let scale = ca.amax();
    let mut next = ca.clone();
    for k in 0..y.nrows() {
        if ca.amax() <= DECAYED * scale {
            break;
        }
        for o in 0..ny {
            let v = y[(k, o)];
            if !v.is_finite() {
                continue;
            }
            let r = (v - sim[(k, o)]) * weights[o];
            if !r.is_finite() {
                continue;
            }
            for j in 0..n {
                block[(used, j)] = ca[(o, j)];
            }
            block[(used, n)] = r;
            used += 1;
            if used == X0_BLOCK {
                acc.push_rows(&block)?;
                used = 0;
            }
        }
        next.gemm(1.0, &ca, m.a(), 0.0);
        std::mem::swap(&mut ca, &mut next);
    }
    if used > 0 {
        acc.push_rows(&block.rows(0, used).into_owned())?;
    }
    let r = acc.r();
    if r.nrows() == 0 {
        return Ok(DVector::zeros(n));
    }
    let x = lifted_linalg::lstsq(&r.columns(0, n).into_owned(), &r.columns(n, 1).into_owned())?;
    Ok(DVector::from_column_slice(x.as_slice()))
}

/// Adds the free response C Aᵏ x₀ to the simulation, until it has decayed.
/// O(K n_y n).
fn free_response(m: &StateSpace, x0: &DVector<f64>, sim: &mut DMatrix<f64>) {
    let scale = m.c().amax() * x0.amax();
    // x(k), x(k + 1) and C x(k) in preallocated buffers.
    let mut x = x0.clone();
    let mut next = x0.clone();
    let mut yk = DVector::zeros(sim.ncols());
    for k in 0..sim.nrows() {
        yk.gemv(1.0, m.c(), &x, 0.0);
        if yk.amax() <= DECAYED * scale && x.amax() <= DECAYED * x0.amax() {
            break;
        }
        for o in 0..sim.ncols() {
            sim[(k, o)] += yk[o];
        }
        next.gemv(1.0, m.a(), &x, 0.0);
        std::mem::swap(&mut x, &mut next);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::{InputChannel, OutputChannel};

    #[test]
    fn corr_equals_the_serial_sum_at_every_lag() {
        // Lengths around the 4-wide blocks, lags of both signs up to and
        // past the record (no overlap: 0).
        for n in [0usize, 1, 3, 4, 5, 17] {
            let a: Vec<f64> = (0..n).map(|k| ((k * 7 % 11) as f64 - 5.0) / 3.0).collect();
            let b: Vec<f64> = (0..n).map(|k| ((k * 5 % 13) as f64 - 6.0) / 7.0).collect();
            for tau in -(n as i64) - 2..=n as i64 + 2 {
                let serial: f64 = (0..n as i64)
                    .filter(|&k| (0..n as i64).contains(&(k + tau)))
                    .map(|k| a[(k + tau) as usize] * b[k as usize])
                    .sum();
                let c = corr(&a, &b, tau);
                assert!(
                    (c - serial).abs() <= 1e-12 * (1.0 + serial.abs()),
                    "n {n} tau {tau}: {c} vs {serial}"
                );
            }
        }
    }

    fn lag() -> StateSpace {
        StateSpace::new(
            DMatrix::from_element(1, 1, 0.8),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, 0.5),
            DMatrix::zeros(1, 1),
            Some(1.0),
        )
        .unwrap()
    }

    #[test]
    fn diverging_simulation_passes_no_residual_test() {
        // A = 2: the simulation overflows to ±∞ within the record, so the
        // residuals are not finite: no fit, and neither test may pass.
        let g = StateSpace::new(
            DMatrix::from_element(1, 1, 2.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::zeros(1, 1),
            Some(1.0),
        )
        .unwrap();
        let n = 2000;
        let u = DMatrix::from_fn(n, 1, |k, _| if (k * 7919) % 5 < 2 { 1.0 } else { -1.0 });
        let y = DMatrix::from_fn(n, 1, |k, _| (k as f64 * 0.1).sin());
        let v = validate(&g, &data(u, y, 1), &ValidationOptions::default()).unwrap();
        let o = &v.outputs[0];
        assert!(!v.stable());
        assert!((v.spectral_radius - 2.0).abs() < 1e-12);
        assert!(!o.residual_finite);
        assert!(o.fit.is_nan());
        assert!(!o.white && !o.independent);
        // A stable model keeps the flags as before.
        let n = 400;
        let u = DMatrix::from_fn(n, 1, |k, _| if (k * 7919) % 5 < 2 { 1.0 } else { -1.0 });
        let y = lag().lsim(&u, None, None).unwrap().y;
        let v = validate(&lag(), &data(u, y, 1), &ValidationOptions::default()).unwrap();
        assert!(v.stable() && v.outputs[0].residual_finite);
    }

    fn data(u: DMatrix<f64>, y: DMatrix<f64>, period: usize) -> Dataset {
        Dataset::new(
            1.0,
            u,
            y,
            vec![InputChannel::new("u", 1)],
            vec![OutputChannel::new("y", period, 0)],
        )
        .unwrap()
    }

    /// A record that starts away from rest (a slow plant, x(0) = 3): the
    /// simulation from the estimated x₀ fits it exactly and recovers x(0);
    /// from zero the transient costs fit. Multirate output (every 3rd
    /// A long two-output record (validated an output per thread) gives
    /// each output the numbers of its own validation (the model with that
    /// output alone, from x₀ = 0, no gain: the same simulation of it), bit
    /// for bit.
    #[test]
    fn outputs_validated_apart_are_validated_alone() {
        let g = StateSpace::new(
            DMatrix::from_row_slice(2, 2, &[0.9, 0.1, -0.2, 0.7]),
            DMatrix::from_row_slice(2, 1, &[0.1, 0.3]),
            DMatrix::from_row_slice(2, 2, &[1.0, 0.5, -0.3, 1.0]),
            DMatrix::from_row_slice(2, 1, &[0.0, 0.2]),
            Some(1.0),
        )
        .unwrap();
        let n = PARALLEL_SAMPLES + 10;
        let u = DMatrix::from_fn(n, 1, |k, _| if (k * 7919) % 13 < 6 { 1.0 } else { -1.0 });
        let mut y = g.lsim(&u, None, None).unwrap().y;
        for (k, mut row) in y.row_iter_mut().enumerate() {
            row[0] += 0.05 * (((k * 31) % 17) as f64 - 8.0);
            row[1] += 0.04 * (((k * 13) % 11) as f64 - 5.0);
        }
        let opts = ValidationOptions {
            initial_state: InitialCondition::Zero,
            ..Default::default()
        };
        let both = validate(
            &g,
            &Dataset::new(
                1.0,
                u.clone(),
                y.clone(),
                vec![InputChannel::new("u", 1)],
                vec![
                    OutputChannel::new("y1", 1, 0),
                    OutputChannel::new("y2", 1, 0),
                ],
            )
            .unwrap(),
            &opts,
        )
        .unwrap();
        for o in 0..2 {
            let alone = StateSpace::new(
                g.a().clone(),
                g.b().clone(),
                g.c().rows(o, 1).into_owned(),
                g.d().rows(o, 1).into_owned(),
                Some(1.0),
            )
            .unwrap();
            let d = Dataset::new(
                1.0,
                u.clone(),
                y.columns(o, 1).into_owned(),
                vec![InputChannel::new("u", 1)],
                vec![OutputChannel::new("y", 1, 0)],
            )
            .unwrap();
            let v = validate(&alone, &d, &opts).unwrap();
            let (a, b) = (&both.outputs[o], &v.outputs[0]);
            assert_eq!(a.fit.to_bits(), b.fit.to_bits());
            assert_eq!(a.auto, b.auto);
            assert_eq!(a.cross, b.cross);
            assert_eq!(a.simulated, b.simulated);
        }
    }

    /// `simulation_fits` gives `validate`'s fits bit for bit (x₀ estimated
    /// or zero, an operating point, an output sampled every third instant,
    /// a model with its gain), and its errors for wrong channels.
    #[test]
    fn simulation_fits_are_the_validations() {
        let g = StateSpace::new(
            DMatrix::from_row_slice(2, 2, &[0.9, 0.1, -0.2, 0.7]),
            DMatrix::from_row_slice(2, 1, &[0.1, 0.3]),
            DMatrix::from_row_slice(2, 2, &[1.0, 0.5, -0.3, 1.0]),
            DMatrix::from_row_slice(2, 1, &[0.0, 0.2]),
            Some(1.0),
        )
        .unwrap();
        let n = 500;
        let u = DMatrix::from_fn(n, 1, |k, _| if (k * 7919) % 13 < 6 { 1.0 } else { -1.0 });
        let x0 = DVector::from_row_slice(&[2.0, -1.0]);
        let mut y = g.lsim(&u, Some(&x0), None).unwrap().y;
        for (k, mut row) in y.row_iter_mut().enumerate() {
            row[0] += 0.05 * (((k * 31) % 17) as f64 - 8.0) + 1.5;
            row[1] += 0.04 * (((k * 13) % 11) as f64 - 5.0);
            if k % 3 != 0 {
                row[1] = f64::NAN;
            }
        }
        let d = Dataset::new(
            1.0,
            u,
            y,
            vec![InputChannel::new("u", 1)],
            vec![
                OutputChannel::new("y1", 1, 0),
                OutputChannel::new("y2", 3, 0),
            ],
        )
        .unwrap();
        let op = OperatingPoint {
            u0: vec![0.0],
            y0: vec![1.5, 0.0],
        };
        for (initial_state, gain) in [
            (InitialCondition::Estimate, None),
            (InitialCondition::Zero, None),
            (
                InitialCondition::Estimate,
                Some(DMatrix::from_element(2, 2, 0.1)),
            ),
        ] {
            let opts = ValidationOptions {
                operating_point: Some(op.clone()),
                initial_state,
                kalman_gain: gain,
                ..Default::default()
            };
            let v = validate(&g, &d, &opts).unwrap();
            let f = simulation_fits(&g, &d, &opts).unwrap();
            assert_eq!(f.len(), 2);
            for (a, b) in f.iter().zip(&v.outputs) {
                assert_eq!(a.fit.to_bits(), b.fit.to_bits());
                assert_eq!(a.samples, b.samples);
                assert!(a.finite);
            }
        }
        let one = StateSpace::new(
            DMatrix::from_element(1, 1, 0.5),
            DMatrix::from_element(1, 2, 1.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::zeros(1, 2),
            Some(1.0),
        )
        .unwrap();
        assert!(matches!(
            simulation_fits(&one, &d, &ValidationOptions::default()),
            Err(Error::DimensionMismatch { .. })
        ));
    }

    /// sample) likewise.
    #[test]
    fn the_initial_state_is_estimated_by_default() {
        let g = StateSpace::new(
            DMatrix::from_element(1, 1, 0.98),
            DMatrix::from_element(1, 1, 0.1),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::zeros(1, 1),
            Some(1.0),
        )
        .unwrap();
        let n = 600;
        let u = DMatrix::from_fn(n, 1, |k, _| if (k * 7919) % 13 < 6 { 1.0 } else { -1.0 });
        let x0 = DVector::from_element(1, 3.0);
        let y = g.lsim(&u, Some(&x0), None).unwrap().y;
        for period in [1, 3] {
            let mut ys = y.clone();
            for k in 0..n {
                if k % period != 0 {
                    ys[(k, 0)] = f64::NAN;
                }
            }
            let d = data(u.clone(), ys, period);
            let v = validate(&g, &d, &ValidationOptions::default()).unwrap();
            assert!(
                (v.outputs[0].fit - 100.0).abs() < 1e-8,
                "{}",
                v.outputs[0].fit
            );
            let est = v.x0.as_ref().expect("estimated");
            assert!((est[0] - 3.0).abs() < 1e-9, "{est}");
            let zero = ValidationOptions {
                initial_state: InitialCondition::Zero,
                ..Default::default()
            };
            let v0 = validate(&g, &d, &zero).unwrap();
            assert!(v0.x0.is_none());
            // The transient 3·0.98ᵏ against a forced response of about
            // ±0.1/(1 − 0.98) = ±5 at most: tens of points lost.
            assert!(v0.outputs[0].fit < 80.0, "{}", v0.outputs[0].fit);
        }
    }

    #[test]
    fn the_fits_do_not_depend_on_the_outputs_units() {
        // One slow state seen by two outputs, a model whose second output
        // gain is wrong (so x₀ is a compromise between the outputs), on a
        // record from x(0) = 4; then the same with output 2 in units 1e6
        // times larger: the same fits. Unweighted, the x₀ followed the
        // large output alone and output 1's fit changed.
        let model = |c2: f64, scale: f64| {
            StateSpace::new(
                DMatrix::from_element(1, 1, 0.98),
                DMatrix::from_element(1, 1, 0.05),
                DMatrix::from_row_slice(2, 1, &[1.0, c2 * scale]),
                DMatrix::zeros(2, 1),
                Some(1.0),
            )
            .unwrap()
        };
        let n = 400;
        let u = DMatrix::from_fn(n, 1, |k, _| if (k * 7919) % 13 < 6 { 1.0 } else { -1.0 });
        let x0 = DVector::from_element(1, 4.0);
        let fits = |scale: f64| {
            let y = model(-0.4, scale).lsim(&u, Some(&x0), None).unwrap().y;
            let d = Dataset::single_rate(1.0, u.clone(), y).unwrap();
            let v = validate(&model(-0.8, scale), &d, &ValidationOptions::default()).unwrap();
            [v.outputs[0].fit, v.outputs[1].fit]
        };
        let (f1, f2) = (fits(1.0), fits(1e6));
        for k in 0..2 {
            assert!(
                (f1[k] - f2[k]).abs() < 1e-6,
                "output {k}: {} vs {}",
                f1[k],
                f2[k]
            );
        }
    }

    /// A model validated on its own noise-free response fits 100 %, the
    /// residual is zero (tests pass); a wrong model fits less.
    #[test]
    fn exact_model_fits_everything() {
        let u = DMatrix::from_fn(200, 1, |k, _| if (k * 7919) % 13 < 6 { 1.0 } else { -1.0 });
        let y = lag().lsim(&u, None, None).unwrap().y;
        let v = validate(&lag(), &data(u.clone(), y.clone(), 1), &Default::default()).unwrap();
        assert!((v.outputs[0].fit - 100.0).abs() < 1e-9);
        assert!(v.outputs[0].white && v.outputs[0].independent);
        assert!(v.horizons.is_empty());
        let mut wrong = lag();
        wrong = StateSpace::new(
            DMatrix::from_element(1, 1, 0.5),
            wrong.b().clone(),
            wrong.c().clone(),
            wrong.d().clone(),
            Some(1.0),
        )
        .unwrap();
        let w = validate(&wrong, &data(u, y, 1), &Default::default()).unwrap();
        assert!(w.outputs[0].fit < 90.0);
    }

    /// An innovations model, x⁺ = 0.8 x + u + 0.6 e, y = 0.5 x + e: with
    /// its Kalman gain the tests run on the one-step prediction errors (the
    /// innovations e: white, independent of u); without it on the
    /// simulation error, the coloured noise (1 + 0.3 q⁻¹/(1 − 0.8 q⁻¹)) e,
    /// which is not white. The tests ran on the simulation error with the
    /// gain too, and a right model with its noise model never passed.
    #[test]
    fn a_model_with_its_gain_is_tested_on_its_innovations() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let n = 4000;
        let mut g = || 12f64.sqrt() * (rng.random::<f64>() - 0.5);
        let u = DMatrix::from_fn(n, 1, |_, _| g());
        let e: Vec<f64> = (0..n).map(|_| 0.3 * g()).collect();
        let (mut x, mut y) = (0.0, DMatrix::zeros(n, 1));
        for k in 0..n {
            y[(k, 0)] = 0.5 * x + e[k];
            x = 0.8 * x + u[(k, 0)] + 0.6 * e[k];
        }
        let d = data(u, y, 1);
        let with_gain = ValidationOptions {
            kalman_gain: Some(DMatrix::from_element(1, 1, 0.6)),
            ..Default::default()
        };
        let v = validate(&lag(), &d, &with_gain).unwrap();
        assert_eq!(v.residual, Residual::OneStepPrediction);
        assert!(
            v.outputs[0].white && v.outputs[0].independent,
            "{:?}",
            v.outputs[0].auto
        );
        let v = validate(&lag(), &d, &ValidationOptions::default()).unwrap();
        assert_eq!(v.residual, Residual::Simulation);
        assert!(!v.outputs[0].white, "{:?}", v.outputs[0].auto);
    }

    /// Multirate: only the measured samples are compared.
    #[test]
    fn multirate_compares_measured_samples() {
        let u = DMatrix::from_fn(300, 1, |k, _| ((k as f64) * 0.37).sin());
        let mut y = lag().lsim(&u, None, None).unwrap().y;
        for k in 0..300 {
            if k % 3 != 0 {
                y[(k, 0)] = f64::NAN;
            }
        }
        let v = validate(&lag(), &data(u, y, 3), &Default::default()).unwrap();
        assert_eq!(v.outputs[0].samples, 100);
        assert!((v.outputs[0].fit - 100.0).abs() < 1e-9);
    }

    #[test]
    fn outputs_near_the_ends_of_the_double_range_are_scored() {
        // A record in units of 1e160 (1e-170): the same fit and the same
        // correlations as in units of 1 (they read "n/a: constant output"
        // and 0: the squares overflowed).
        let u = DMatrix::from_fn(300, 1, |k, _| if (k * 7919) % 13 < 6 { 1.0 } else { -1.0 });
        let y = lag()
            .lsim(&u, None, None)
            .unwrap()
            .y
            .map(|v| v + 0.3 * (v * 7.0).sin());
        let base = validate(&lag(), &data(u.clone(), y.clone(), 1), &Default::default()).unwrap();
        for unit in [1e160, 1e-170] {
            let scaled = StateSpace::new(
                lag().a().clone(),
                lag().b().clone(),
                lag().c() * unit,
                lag().d().clone(),
                Some(1.0),
            )
            .unwrap();
            let v = validate(
                &scaled,
                &data(u.clone(), y.map(|x| x * unit), 1),
                &Default::default(),
            )
            .unwrap();
            let (a, b) = (&base.outputs[0], &v.outputs[0]);
            assert!(
                (a.fit - b.fit).abs() < 1e-9,
                "{unit}: {} vs {}",
                a.fit,
                b.fit
            );
            for (x, z) in a.auto.iter().zip(&b.auto) {
                assert!((x - z).abs() < 1e-9, "{unit}: {x} vs {z}");
            }
        }
    }

    #[test]
    fn zero_lags_are_refused() {
        // Nothing tested passed both tests ("white yes, independent yes").
        let u = DMatrix::from_fn(100, 1, |k, _| ((k as f64) * 0.37).sin());
        let y = lag().lsim(&u, None, None).unwrap().y;
        let opts = ValidationOptions {
            lags: 0,
            ..Default::default()
        };
        let e = validate(&lag(), &data(u, y, 1), &opts).unwrap_err();
        assert!(e.to_string().contains("at least 1 correlation lag"), "{e}");
    }

    #[test]
    fn bad_input_is_named() {
        let u = DMatrix::from_element(30, 1, 1.0);
        let y = lag().lsim(&u, None, None).unwrap().y;
        let d = data(u, y, 1);
        let e = validate(&lag(), &d, &Default::default()).unwrap_err();
        assert!(
            matches!(e, Error::InvalidArgument { what: "lags", .. }),
            "{e}"
        );
        let opts = ValidationOptions {
            lags: 5,
            kalman_gain: Some(DMatrix::zeros(2, 1)),
            ..Default::default()
        };
        let e = validate(&lag(), &d, &opts).unwrap_err();
        assert!(
            matches!(
                e,
                Error::DimensionMismatch {
                    what: "Kalman gain",
                    ..
                }
            ),
            "{e}"
        );
        let other = StateSpace::new(
            lag().a().clone(),
            lag().b().clone(),
            lag().c().clone(),
            lag().d().clone(),
            Some(0.5),
        )
        .unwrap();
        let e = validate(
            &other,
            &d,
            &ValidationOptions {
                lags: 5,
                ..Default::default()
            },
        )
        .unwrap_err();
        assert!(matches!(e, Error::DomainMismatch { .. }), "{e}");
    }
}

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
mod tests;

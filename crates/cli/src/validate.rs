//! `lifted validate`: simulation fit and residual tests.
//!
//! * fit % per output: 100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖), ŷ the model's simulated
//!   response to the measured input from a zero initial state, compared at
//!   the instants the output is sampled; with an operating point in the
//!   model file ŷ = y₀ + G(u − u₀);
//! * k-step-ahead prediction fit (k = 1, 5; k = ∞ is the simulation fit)
//!   with the model file's Kalman gain ([`lifted_lti::StateSpace::predict`]),
//!   when the file has one;
//! * whiteness: normalised autocorrelation r_e(τ)/r_e(0), τ = 1…M, of the
//!   residual e = y − ŷ (at the output's own sampling instants);
//! * independence: normalised cross-correlation r_eu(τ)/√(r_e(0) r_u(0)),
//!   τ = −M…M, between each input (at the output's instants) and e.
//!
//! The 99 % confidence bound of each correlation is ±2.576/√N (N residual
//! samples); a test passes when at most ⌈1 % of the lags⌉ (at least one)
//! lie outside the bound. O(N (n² + M)) per output.

use lifted_lti::data::Detrend;
use lifted_lti::{C2dOptions, Dataset, ModelFile, OperatingPoint, StateSpace};
use nalgebra::DMatrix;

use crate::args::{DetrendArg, ValidateArgs};
use crate::error::{CliError, CliResult, Context, input};
use crate::identify::data_spec;
use crate::model::{channel_names, read_model};
use crate::reproduce::print_table;
use crate::table::load;

/// 99 % two-sided normal quantile.
const Z99: f64 = 2.576;

/// Results for one output.
#[derive(Debug, Clone)]
pub struct OutputValidation {
    /// Output name.
    pub name: String,
    /// Fit in percent.
    pub fit: f64,
    /// k-step-ahead prediction fits in percent, for k in
    /// [`PREDICTION_HORIZONS`] (empty without a Kalman gain).
    pub prediction_fits: Vec<f64>,
    /// Samples compared.
    pub samples: usize,
    /// Confidence bound of the correlations.
    pub bound: f64,
    /// Residual autocorrelation for τ = 1…M.
    pub auto: Vec<f64>,
    /// Cross-correlation with each input for τ = −M…M (one vector per input).
    pub cross: Vec<Vec<f64>>,
    /// Whiteness test passed.
    pub white: bool,
    /// Independence test passed.
    pub independent: bool,
    /// Measured output at the compared instants (time, value).
    pub measured: (Vec<f64>, Vec<f64>),
    /// Simulated output at every base instant.
    pub simulated: Vec<f64>,
}

/// Validation of a model on a data set.
#[derive(Debug, Clone)]
pub struct Validation {
    /// Per output.
    pub outputs: Vec<OutputValidation>,
    /// Lags M.
    pub lags: usize,
}

fn passes(r: &[f64], bound: f64) -> bool {
    let outside = r.iter().filter(|v| v.abs() > bound).count();
    let allowed = r.len().div_ceil(100).max(1);
    outside <= allowed
}

/// Model at the data's base period (a continuous model is discretised by ZOH).
pub fn at_data_rate(model: &StateSpace, data: &Dataset, path: &str) -> CliResult<StateSpace> {
    match model.ts() {
        None => model
            .c2d(data.ts(), &C2dOptions::default())
            .ctx("discretising the model"),
        Some(ts) if (ts - data.ts()).abs() <= 1e-9 * ts => Ok(model.clone()),
        Some(ts) => Err(input(format!(
            "{path}: base period {} s differs from the model's sample period {ts} s",
            data.ts()
        ))),
    }
}

/// Horizons k of the k-step-ahead prediction fits (k = ∞ is the fit).
pub const PREDICTION_HORIZONS: [usize; 2] = [1, 5];

/// 100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖) (NaN for a constant y).
fn fit_percent(y: &[f64], yhat: &[f64]) -> f64 {
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    let ne = y
        .iter()
        .zip(yhat)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt();
    let nd = y.iter().map(|v| (v - mean).powi(2)).sum::<f64>().sqrt();
    if nd > 0.0 {
        100.0 * (1.0 - ne / nd)
    } else {
        f64::NAN
    }
}

/// Computes the validation of the model file's model, operating point and
/// Kalman gain (the gain is used only when the model runs at the data's
/// period as given).
pub fn validate_model(
    file: &ModelFile,
    data: &Dataset,
    lags: usize,
    path: &str,
) -> CliResult<Validation> {
    let model = &file.model;
    if model.n_inputs() != data.n_inputs() || model.n_outputs() != data.n_outputs() {
        return Err(input(format!(
            "{path}: {} inputs and {} outputs selected, the model has {} and {}",
            data.n_inputs(),
            data.n_outputs(),
            model.n_inputs(),
            model.n_outputs()
        )));
    }
    let m = at_data_rate(model, data, path)?;
    let op = file
        .operating_point
        .clone()
        .unwrap_or_else(|| OperatingPoint::zero(model.n_inputs(), model.n_outputs()));
    let (du, dy) = op.to_deviations(data.u(), data.y()).ctx(path)?;
    let mut sim = m.lsim(&du, None, None).ctx("simulating the model")?;
    sim.y = op.add_output(&sim.y).ctx(path)?;
    let gain = file
        .kalman_gain_matrix()
        .filter(|_| model.ts().is_some() && m.order() == model.order());
    let predictions: Vec<DMatrix<f64>> = match &gain {
        Some(k) => PREDICTION_HORIZONS
            .iter()
            .map(|&h| {
                m.predict(k, &du, &dy, h)
                    .and_then(|p| op.add_output(&p))
                    .ctx("k-step-ahead prediction")
            })
            .collect::<CliResult<_>>()?,
        None => Vec::new(),
    };
    let ts = data.ts();
    let mut outputs = Vec::new();
    for (o, ch) in data.outputs().iter().enumerate() {
        let (idx, y) = data.output_samples(o).ctx(path)?;
        let yhat: Vec<f64> = idx.iter().map(|&k| sim.y[(k, o)]).collect();
        let n = y.len();
        if n < 2 * lags + 2 {
            return Err(input(format!(
                "{path}: output '{}' has {n} samples, too few for {lags} correlation lags (use --lags)",
                ch.name
            )));
        }
        let e: Vec<f64> = y.iter().zip(&yhat).map(|(a, b)| a - b).collect();
        let fit = fit_percent(&y, &yhat);
        let prediction_fits = predictions
            .iter()
            .map(|p| {
                let yp: Vec<f64> = idx.iter().map(|&k| p[(k, o)]).collect();
                fit_percent(&y, &yp)
            })
            .collect();
        let em = e.iter().sum::<f64>() / n as f64;
        let ec: Vec<f64> = e.iter().map(|v| v - em).collect();
        let r0 = ec.iter().map(|v| v * v).sum::<f64>();
        let corr = |a: &[f64], b: &[f64], tau: i64| -> f64 {
            // Σ a(k+τ) b(k)
            let mut s = 0.0;
            for k in 0..n as i64 {
                let j = k + tau;
                if j >= 0 && (j as usize) < n {
                    s += a[j as usize] * b[k as usize];
                }
            }
            s
        };
        let auto: Vec<f64> = (1..=lags as i64)
            .map(|t| {
                if r0 > 0.0 {
                    corr(&ec, &ec, t) / r0
                } else {
                    0.0
                }
            })
            .collect();
        let mut cross = Vec::new();
        for i in 0..data.n_inputs() {
            let u: Vec<f64> = idx.iter().map(|&k| data.u()[(k, i)]).collect();
            let um = u.iter().sum::<f64>() / n as f64;
            let uc: Vec<f64> = u.iter().map(|v| v - um).collect();
            let ru = uc.iter().map(|v| v * v).sum::<f64>();
            let den = (r0 * ru).sqrt();
            cross.push(
                (-(lags as i64)..=lags as i64)
                    .map(|t| {
                        if den > 0.0 {
                            corr(&ec, &uc, t) / den
                        } else {
                            0.0
                        }
                    })
                    .collect(),
            );
        }
        let bound = Z99 / (n as f64).sqrt();
        let white = passes(&auto, bound);
        let independent = cross.iter().all(|c: &Vec<f64>| passes(c, bound));
        outputs.push(OutputValidation {
            name: ch.name.clone(),
            fit,
            prediction_fits,
            samples: n,
            bound,
            auto,
            cross,
            white,
            independent,
            measured: (idx.iter().map(|&k| k as f64 * ts).collect(), y),
            simulated: sim.y.column(o).iter().copied().collect(),
        });
    }
    Ok(Validation { outputs, lags })
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// Rows of the validation table: output, fit, 1- and 5-step prediction
/// fits, samples, max |r_e|, max |r_eu|, bound, white, independent.
pub fn table_rows(v: &Validation) -> Vec<[String; 10]> {
    v.outputs
        .iter()
        .map(|o| {
            let cross = o.cross.iter().map(|c| max_abs(c)).fold(0.0, f64::max);
            let pred = |i: usize| {
                o.prediction_fits
                    .get(i)
                    .map_or("n/a".to_string(), |f| format!("{f:.2}"))
            };
            [
                o.name.clone(),
                format!("{:.2}", o.fit),
                pred(0),
                pred(1),
                o.samples.to_string(),
                format!("{:.4}", max_abs(&o.auto)),
                format!("{cross:.4}"),
                format!("{:.4}", o.bound),
                if o.white { "yes" } else { "no" }.to_string(),
                if o.independent { "yes" } else { "no" }.to_string(),
            ]
        })
        .collect()
}

/// Header of [`table_rows`].
pub const TABLE_HEADER: [&str; 10] = [
    "output",
    "fit % (simulation)",
    "fit % 1-step",
    "fit % 5-step",
    "samples",
    "max |r_e(τ)|, τ≥1",
    "max |r_eu(τ)|",
    "99% bound",
    "white",
    "independent of u",
];

/// Loads the model and data of `validate`/`report` and applies `--detrend`:
/// `auto` keeps the file's operating point (or, without one, removes the
/// record's means), `mean`/`linear` detrend the record and drop the
/// operating point, `none` keeps both as they are.
pub fn load_for_validation(
    model_path: &str,
    data_path: &str,
    cols: &crate::args::DataArgs,
    detrend: DetrendArg,
) -> CliResult<(ModelFile, Dataset)> {
    let mut file = read_model(model_path)?;
    let spec = data_spec(cols, Some(channel_names(&file.model)), 1, Vec::new())?;
    let data = load(data_path, &spec)?.data;
    let kind = match detrend {
        DetrendArg::Auto if file.operating_point.is_none() => Some(Detrend::Constant),
        DetrendArg::Mean => Some(Detrend::Constant),
        DetrendArg::Linear => Some(Detrend::Linear),
        DetrendArg::Auto | DetrendArg::None => None,
    };
    match kind {
        Some(k) => {
            file.operating_point = None;
            Ok((file, data.detrend(k).ctx(data_path)?))
        }
        None => Ok((file, data)),
    }
}

/// `lifted validate`.
pub fn validate_cmd(a: &ValidateArgs) -> CliResult<()> {
    let (file, data) = load_for_validation(&a.model, &a.data, &a.columns, a.detrend)?;
    let v = validate_model(&file, &data, a.lags, &a.data)?;
    let rows: Vec<Vec<String>> = table_rows(&v).into_iter().map(|r| r.to_vec()).collect();
    print_table(&TABLE_HEADER, &rows);
    println!(
        "({} lags; a test passes with at most ⌈1% of the lags⌉ outside the 99% bound ±2.576/√N)",
        v.lags
    );
    if let Some(min) = a.min_fit {
        let low: Vec<String> = v
            .outputs
            .iter()
            .filter(|o| o.fit.is_nan() || o.fit < min)
            .map(|o| format!("{} ({:.2}%)", o.name, o.fit))
            .collect();
        if !low.is_empty() {
            return Err(CliError::Failed(format!(
                "fit below --min-fit {min}%: {}",
                low.join(", ")
            )));
        }
    }
    Ok(())
}

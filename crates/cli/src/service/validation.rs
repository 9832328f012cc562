//! Validation service: a model file checked on a data record (used by
//! `lifted validate`, `lifted report` and `lifted studio`): simulation fit
//! and residual tests.
//!
//! * fit % per output: 100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖), ŷ the model's simulated
//!   response to the measured input from the initial state fitted to the
//!   record (`--initial-state zero`: from rest), compared at the instants
//!   the output is sampled; with an operating point in the model file
//!   ŷ = y₀ + G(u − u₀);
//! * k-step-ahead prediction fit (k = 1, 5; k = ∞ is the simulation fit)
//!   with the model file's Kalman gain ([`lifted_lti::StateSpace::predict`]),
//!   when the file has one;
//! * whiteness: normalised autocorrelation r_e(τ)/r_e(0), τ = 1…M, of the
//!   residual e (at the output's own sampling instants): the one-step
//!   prediction error with the file's Kalman gain on a single-rate record
//!   (as MATLAB's `resid`), else the simulation error y − ŷ;
//! * independence: normalised cross-correlation r_eu(τ)/√(r_e(0) r_u(0)),
//!   τ = −M…M, between each input (at the output's instants) and e.
//!
//! The 99 % confidence bound of each correlation is ±2.576/√N (N residual
//! samples); a test passes when at most ⌈1 % of the lags⌉ (at least one)
//! lie outside the bound. O(N (n² + M)) per output.

use lifted_lti::data::Detrend;
use lifted_lti::{Dataset, InitialCondition, ModelFile, ValidationOptions, validate};

use crate::args::DetrendArg;
use crate::error::{CliResult, Context, input};
use crate::service::identify::data_spec;
use crate::service::models::{channel_names, read_model};
use crate::table::load;

pub use lifted_lti::validation::Validation;

/// Validates the model file's model, operating point and Kalman gain on
/// `data` with `lifted_lti::validate` (the gain only when the model runs at
/// the data's period as given), the simulation from `initial_state`, the
/// 1- and 5-step predictions; errors name the data file `path`.
pub fn validate_model(
    file: &ModelFile,
    data: &Dataset,
    lags: usize,
    initial_state: InitialCondition,
    path: &str,
) -> CliResult<Validation> {
    let horizons = lifted_lti::ValidationOptions::default().horizons;
    validate_model_at(file, data, lags, initial_state, &horizons, path)
}

/// [`validate_model`] with the prediction horizons given (the studio's
/// slider shows the one-step fit only: `&[1]`, which spares the 5-step
/// predictions, five model runs over the record).
pub fn validate_model_at(
    file: &ModelFile,
    data: &Dataset,
    lags: usize,
    initial_state: InitialCondition,
    horizons: &[usize],
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
    let opts = ValidationOptions {
        lags,
        operating_point: file.operating_point.clone(),
        kalman_gain: file
            .kalman_gain_matrix()
            .filter(|_| gain_mismatch(file, data).is_none()),
        initial_state,
        horizons: horizons.to_vec(),
    };
    validate(model, data, &opts).map_err(|e| match e {
        lifted_lti::Error::InvalidArgument {
            what: "lags",
            reason,
        } => input(format!("{path}: {reason} (use --lags)")),
        lifted_lti::Error::DomainMismatch {
            left: Some(t),
            right: Some(d),
            ..
        } => input(format!(
            "{path}: base period {d} s differs from the model's sample period {t} s"
        )),
        other => input(format!("{path}: {other}")),
    })
}

/// Why the model file's Kalman gain does not predict on `data`, if it does
/// not: the workflow's rule (`lifted_workflow::gain_mismatch`, also the
/// Python package's): estimated for outputs sampled at other periods than
/// the record's. The validation then leaves the prediction fits out and
/// tests the simulation error.
pub fn gain_mismatch(file: &ModelFile, data: &Dataset) -> Option<String> {
    let identified = lifted_workflow::gain_periods(file)?;
    let here: Vec<usize> = data.outputs().iter().map(|c| c.period).collect();
    lifted_workflow::gain_mismatch(&identified, &here)
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// The fit column: "n/a: unstable" for an unstable model (its simulation
/// diverges), "n/a: constant output" for an output that never moves on
/// these data (the fit's denominator ‖y − ȳ‖ is zero), else the
/// percentage.
pub fn fit_cell(v: &Validation, fit: f64) -> String {
    if !v.stable() {
        "n/a: unstable".to_string()
    } else if fit.is_nan() {
        "n/a: constant output".to_string()
    } else {
        crate::shown::percent(fit)
    }
}

/// The line printed under the table of an unstable model.
pub fn unstable_note(v: &Validation) -> Option<String> {
    (!v.stable()).then(|| {
        format!(
            "unstable: simulation fit not meaningful (spectral radius rho(A) = {:.6} >= 1)",
            v.spectral_radius
        )
    })
}

/// Rows of the validation table: output, fit, 1- and 5-step prediction
/// fits, samples, max |r_e|, max |r_eu|, bound, white, independent. An
/// unstable model's fit reads "n/a: unstable"; residual tests on
/// non-finite residuals, or on the residuals of an output that never moves
/// (nothing to test), read "n/a".
pub fn table_rows(v: &Validation) -> Vec<[String; 10]> {
    v.outputs
        .iter()
        .map(|o| {
            let constant = o.residual_finite && o.fit.is_nan();
            let test = |passed: bool| {
                if !o.residual_finite || constant {
                    "n/a"
                } else if passed {
                    "yes"
                } else {
                    "no"
                }
                .to_string()
            };
            let cross = o.cross.iter().map(|c| max_abs(c)).fold(0.0, f64::max);
            let pred = |i: usize| {
                o.prediction_fits
                    .get(i)
                    .filter(|f| !f.is_nan())
                    .map_or("n/a".to_string(), |f| crate::shown::percent(*f))
            };
            [
                o.name.clone(),
                fit_cell(v, o.fit),
                pred(0),
                pred(1),
                o.samples.to_string(),
                format!("{:.4}", max_abs(&o.auto)),
                format!("{cross:.4}"),
                format!("{:.4}", o.bound),
                test(o.white),
                test(o.independent),
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
    let file = read_model(model_path)?;
    let spec = data_spec(cols, Some(channel_names(&file.model)), 1, Vec::new())?;
    let data = load(data_path, &spec)?.data;
    with_detrend(file, data, detrend, data_path)
}

/// Applies `--detrend` to a model file and the record it is checked on:
/// `auto` keeps the file's operating point (or, without one, removes the
/// record's means), `mean`/`linear` detrend the record and drop the
/// operating point, `none` keeps both as they are; `label` names the
/// record in errors.
pub fn with_detrend(
    mut file: ModelFile,
    data: Dataset,
    detrend: DetrendArg,
    label: &str,
) -> CliResult<(ModelFile, Dataset)> {
    let kind = match detrend {
        DetrendArg::Auto if file.operating_point.is_none() => Some(Detrend::Constant),
        DetrendArg::Mean => Some(Detrend::Constant),
        DetrendArg::Linear => Some(Detrend::Linear),
        DetrendArg::Auto | DetrendArg::None => None,
    };
    match kind {
        Some(k) => {
            file.operating_point = None;
            Ok((file, data.detrend(k).ctx(label)?))
        }
        None => Ok((file, data)),
    }
}

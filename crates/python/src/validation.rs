//! Binding of `lifted_lti::validate`: simulation and k-step prediction
//! fits, residual whiteness and input independence (the CLI's `validate`).

use lifted_lti::{ValidationOptions, validate as run};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::choices::Choice;
use crate::convert::{
    Int, Vector, count, counts, int, ints, matrix, opt_ints, output_record, record,
};
use crate::dataset;
use crate::errors::{err, lifted_error};
use crate::statespace::PyStateSpace;

/// Validates `model` on `u` (N×m), `y` (N×p, NaN where output i is not
/// sampled; sampled every `periods[i]`): per output a dict with name, fit
/// (%), prediction_fits (one per horizon, with the Kalman gain), samples,
/// bound (99 %), auto (τ = 1…lags), cross (per input, τ = −lags…lags),
/// white, independent, simulated. The model's operating point and Kalman
/// gain are used (as the CLI's `lifted validate --model`); `u0`, `y0` and
/// `kalman_gain` replace them when given. A continuous model is
/// discretised (ZOH) at `dt`; a discrete one runs at its own period. The
/// simulation (and the predictor) start from the least-squares x₀
/// (`initial_state="estimate"`, returned as `x0`) or from rest (`"zero"`).
#[pyfunction]
#[pyo3(signature = (model, u, y, periods=None, lags=20, kalman_gain=None, u0=None, y0=None,
    horizons=vec![1, 5], dt=None, initial_state="estimate"))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn validate<'py>(
    py: Python<'py>,
    model: &PyStateSpace,
    u: &Bound<'py, PyAny>,
    y: &Bound<'py, PyAny>,
    #[pyo3(from_py_with = opt_ints)] periods: Option<Vec<Int>>,
    #[pyo3(from_py_with = int)] lags: Int,
    kalman_gain: Option<&Bound<'py, PyAny>>,
    u0: Option<&Bound<'py, PyAny>>,
    y0: Option<&Bound<'py, PyAny>>,
    #[pyo3(from_py_with = ints)] horizons: Vec<Int>,
    dt: Option<f64>,
    initial_state: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let initial_state = lifted_lti::InitialCondition::parse(initial_state, "initial_state")?;
    let m = &model.inner;
    let ts = match (m.ts(), dt) {
        (Some(t), None) => t,
        (_, Some(d)) => d,
        (None, None) => {
            return Err(lifted_error(
                "a continuous model needs dt (the data's sample period)",
            ));
        }
    };
    let periods = periods.map(|p| counts(&p, "periods")).transpose()?;
    let data = dataset(
        ts,
        record(u, "u")?,
        output_record(y, "y")?,
        None,
        periods.as_deref(),
    )?;
    let operating_point = match (u0, y0) {
        (None, None) => model.operating_point.clone(),
        (u0, y0) => {
            let base = model.operating_point.as_ref();
            let given = model.operating_point_of(u0, y0)?;
            // an offset not given stays the model's (zeros without one)
            given.map(|mut op| {
                if let (None, Some(b)) = (u0, base) {
                    op.u0 = b.u0.clone();
                }
                if let (None, Some(b)) = (y0, base) {
                    op.y0 = b.y0.clone();
                }
                op
            })
        }
    };
    // The model's gain is left out on a record sampled otherwise than the
    // one it was estimated with (the command line's rule,
    // `lifted_workflow::gain_mismatch`); a gain given here is used as given.
    let record_periods: Vec<usize> = data.outputs().iter().map(|c| c.period).collect();
    let gain_note = match (kalman_gain, &model.gain_periods) {
        (None, Some(p)) if model.kalman_gain.is_some() => {
            lifted_workflow::gain_mismatch(p, &record_periods)
        }
        _ => None,
    };
    let kalman_gain = match kalman_gain {
        Some(k) => Some(matrix(k, "kalman_gain", Vector::Column, None)?),
        None if gain_note.is_some() => None,
        None => model.kalman_gain.clone(),
    };
    let opts = ValidationOptions {
        lags: count(lags, "lags")?,
        operating_point,
        kalman_gain,
        horizons: counts(&horizons, "horizons")?,
        initial_state,
    };
    let model = m.clone();
    let v = py.detach(move || run(&model, &data, &opts)).map_err(err)?;
    let out = PyDict::new(py);
    let rows = v
        .outputs
        .iter()
        .map(|o| {
            let d = PyDict::new(py);
            d.set_item("name", &o.name)?;
            d.set_item("fit", o.fit)?;
            d.set_item("prediction_fits", o.prediction_fits.clone())?;
            d.set_item("samples", o.samples)?;
            d.set_item("bound", o.bound)?;
            d.set_item("auto", o.auto.clone())?;
            d.set_item("cross", o.cross.clone())?;
            d.set_item("white", o.white)?;
            d.set_item("independent", o.independent)?;
            d.set_item("simulated", o.simulated.clone())?;
            Ok(d)
        })
        .collect::<PyResult<Vec<_>>>()?;
    out.set_item("outputs", rows)?;
    out.set_item("gain_note", gain_note)?;
    out.set_item("lags", v.lags)?;
    out.set_item("residual", v.residual.name())?;
    out.set_item("stable", v.stable())?;
    out.set_item("horizons", v.horizons)?;
    out.set_item("spectral_radius", v.spectral_radius)?;
    out.set_item(
        "x0",
        v.x0.as_ref()
            .map(|x| x.iter().copied().collect::<Vec<f64>>()),
    )?;
    Ok(out)
}

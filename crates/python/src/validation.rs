//! Binding of `lifted_lti::validate`: simulation and k-step prediction
//! fits, residual whiteness and input independence (the CLI's `validate`).

use lifted_lti::{OperatingPoint, ValidationOptions, validate as run};
use numpy::PyReadonlyArray2;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::{LiftedError, PyStateSpace, dataset, err, to_mat};

/// Validates `model` on `u` (N×m), `y` (N×p, NaN where output i is not
/// sampled; sampled every `periods[i]`): per output a dict with name, fit
/// (%), prediction_fits (one per horizon, with `kalman_gain` n×p), samples,
/// bound (99 %), auto (τ = 1…lags), cross (per input, τ = −lags…lags),
/// white, independent, simulated. `u0`/`y0`: the model's operating point.
/// A continuous model is discretised (ZOH) at `dt`; a discrete one runs at
/// its own period.
#[pyfunction]
#[pyo3(signature = (model, u, y, periods=None, lags=20, kalman_gain=None, u0=None, y0=None,
    horizons=vec![1, 5], dt=None))]
#[allow(clippy::too_many_arguments)]
pub fn validate<'py>(
    py: Python<'py>,
    model: &PyStateSpace,
    u: PyReadonlyArray2<'py, f64>,
    y: PyReadonlyArray2<'py, f64>,
    periods: Option<Vec<usize>>,
    lags: usize,
    kalman_gain: Option<PyReadonlyArray2<'py, f64>>,
    u0: Option<Vec<f64>>,
    y0: Option<Vec<f64>>,
    horizons: Vec<usize>,
    dt: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let m = &model.inner;
    let ts = match (m.ts(), dt) {
        (Some(t), None) => t,
        (_, Some(d)) => d,
        (None, None) => {
            return Err(LiftedError::new_err(
                "a continuous model needs dt (the data's sample period)",
            ));
        }
    };
    let data = dataset(ts, to_mat(&u), to_mat(&y), None, periods.as_deref())?;
    let operating_point = match (u0, y0) {
        (None, None) => None,
        (u0, y0) => Some(OperatingPoint {
            u0: u0.unwrap_or_else(|| vec![0.0; m.n_inputs()]),
            y0: y0.unwrap_or_else(|| vec![0.0; m.n_outputs()]),
        }),
    };
    let opts = ValidationOptions {
        lags,
        operating_point,
        kalman_gain: kalman_gain.as_ref().map(to_mat),
        horizons,
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
    out.set_item("lags", v.lags)?;
    out.set_item("horizons", v.horizons)?;
    Ok(out)
}

//! Binding of the default identification route, `lifted_subspace::identify`
//! (N4SID, MOESP, CVA on one record or several). The model it returns
//! carries the operating point (the means removed from the records) and the
//! Kalman gain of the noise model, exactly as the CLI's model file does.

use lifted_linalg::budget::resolve_threads;
use lifted_subspace::{Experiment, Method, OrderSelection, SubspaceOptions, SystemEstimate};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::choices::Choice;
use crate::convert::{Int, count, opt_count};
use crate::errors::err;
use crate::statespace::PyStateSpace;
use crate::{records, to_py};

/// Order selection: fixed `order`, else the singular-value gap up to `max_order`.
pub(crate) fn order_of(order: Option<usize>, max_order: usize) -> OrderSelection {
    match order {
        Some(n) => OrderSelection::Fixed(n),
        None => OrderSelection::Gap { max: max_order },
    }
}

/// Subspace identification (lifted_subspace::identify) from one or several
/// records (`us`, `ys`: lists of N×m and N×p arrays). Keyword defaults are
/// those of `SubspaceOptions`; `threads` is capped at the machine's
/// available parallelism (0 = all cores). Returns a dict: model (with its
/// operating point and Kalman gain), kalman_gain, x0, u0/y0 (means
/// removed), singular_values, order, suggested_order, method, threads (the
/// count used), model_json (the CLI's model file). `system`: None (the
/// library's default `SystemEstimate`), "shift" or "states".
#[pyfunction]
#[pyo3(signature = (us, ys, method="n4sid", order=None, max_order=10, past=10, future=10,
    remove_means=true, noise_model=true, enforce_stability=false, dt=1.0, threads=1, system=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn identify<'py>(
    py: Python<'py>,
    us: Vec<Bound<'py, PyAny>>,
    ys: Vec<Bound<'py, PyAny>>,
    method: &str,
    order: Option<Int>,
    max_order: Int,
    past: Int,
    future: Int,
    remove_means: bool,
    noise_model: bool,
    enforce_stability: bool,
    dt: f64,
    threads: Int,
    system: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let method = Method::parse(method, "method")?;
    let system = match system {
        None => SystemEstimate::default(),
        Some(s) => SystemEstimate::parse(s, "system")?,
    };
    let (u, y) = records(&us, &ys)?;
    let threads = resolve_threads(count(threads, "threads")?);
    let opts = SubspaceOptions {
        method,
        order: order_of(opt_count(order, "order")?, count(max_order, "max_order")?),
        past: count(past, "past")?,
        future: count(future, "future")?,
        remove_means,
        noise_model,
        enforce_stability,
        ts: dt,
        threads,
        system,
        ..Default::default()
    };
    let fit = py
        .detach(move || {
            let ex: Vec<Experiment<'_>> =
                u.iter().zip(&y).map(|(u, y)| Experiment { u, y }).collect();
            lifted_subspace::identify(&ex, &opts)
        })
        .map_err(err)?;
    fit_dict(py, &fit, Method::name_of(&method), threads)
}

/// Predictor-based subspace identification (lifted_subspace::pbsid_identify:
/// PBSID-opt, row-wise PBSID or SSARX), consistent on closed-loop records
/// without an external excitation. `past` None: chosen by Akaike's
/// criterion on the VARX predictor (up to 30); `feedthrough` false: no D
/// (the closed-loop default). Returns the dict of `identify`.
#[pyfunction]
#[pyo3(signature = (us, ys, variant="pbsid", order=None, max_order=10, past=None, future=10,
    feedthrough=false, remove_means=true, dt=1.0, threads=1))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn pbsid<'py>(
    py: Python<'py>,
    us: Vec<Bound<'py, PyAny>>,
    ys: Vec<Bound<'py, PyAny>>,
    variant: &str,
    order: Option<Int>,
    max_order: Int,
    past: Option<Int>,
    future: Int,
    feedthrough: bool,
    remove_means: bool,
    dt: f64,
    threads: Int,
) -> PyResult<Bound<'py, PyDict>> {
    let variant = lifted_subspace::PbsidVariant::parse(variant, "variant")?;
    let (u, y) = records(&us, &ys)?;
    let threads = resolve_threads(count(threads, "threads")?);
    let opts = lifted_subspace::PbsidOptions {
        variant,
        order: order_of(opt_count(order, "order")?, count(max_order, "max_order")?),
        past: opt_count(past, "past")?,
        future: count(future, "future")?,
        feedthrough: if feedthrough {
            lifted_subspace::Feedthrough::Free
        } else {
            lifted_subspace::Feedthrough::Zero
        },
        remove_means,
        ts: dt,
        threads,
        ..Default::default()
    };
    let fit = py
        .detach(move || {
            let ex: Vec<Experiment<'_>> =
                u.iter().zip(&y).map(|(u, y)| Experiment { u, y }).collect();
            lifted_subspace::pbsid_identify(&ex, &opts)
        })
        .map_err(err)?;
    let name = lifted_subspace::PbsidVariant::name_of(&variant);
    let d = &fit.diagnostics;
    dict_of(
        py,
        FitParts {
            model: &fit.model,
            kalman_gain: Some(&fit.kalman_gain),
            x0: &fit.x0,
            operating_point: fit.operating_point.as_ref(),
            singular_values: &d.singular_values,
            order: d.order,
            suggested_order: d.suggested_order,
        },
        name,
        threads,
    )
}

/// What the result dict of a subspace-type fit is made of.
pub(crate) struct FitParts<'a> {
    pub model: &'a lifted_lti::StateSpace,
    pub kalman_gain: Option<&'a nalgebra::DMatrix<f64>>,
    pub x0: &'a [nalgebra::DVector<f64>],
    pub operating_point: Option<&'a lifted_lti::OperatingPoint>,
    pub singular_values: &'a [f64],
    pub order: usize,
    pub suggested_order: usize,
}

/// The dict `identify` returns for a subspace fit (`method_name`: the CLI's
/// method name, `threads`: the count used).
pub(crate) fn fit_dict<'py>(
    py: Python<'py>,
    fit: &lifted_subspace::SubspaceModel,
    method_name: &str,
    threads: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let d = &fit.diagnostics;
    dict_of(
        py,
        FitParts {
            model: &fit.model,
            kalman_gain: fit.kalman_gain.as_ref(),
            x0: &fit.x0,
            operating_point: fit.operating_point.as_ref(),
            singular_values: &d.singular_values,
            order: d.order,
            suggested_order: d.suggested_order,
        },
        method_name,
        threads,
    )
}

/// The result dict from its parts.
fn dict_of<'py>(
    py: Python<'py>,
    f: FitParts<'_>,
    method_name: &str,
    threads: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let model = PyStateSpace::with_parts(
        f.model.clone(),
        f.operating_point.cloned(),
        f.kalman_gain.cloned(),
    )?;
    let out = PyDict::new(py);
    out.set_item("model_json", model.to_json_with(Some(method_name))?)?;
    out.set_item("model", model)?;
    out.set_item("kalman_gain", f.kalman_gain.map(|k| to_py(py, k)))?;
    let x0: Vec<Vec<f64>> = f.x0.iter().map(|x| x.as_slice().to_vec()).collect();
    out.set_item("x0", x0)?;
    out.set_item("u0", f.operating_point.map(|o| o.u0.clone()))?;
    out.set_item("y0", f.operating_point.map(|o| o.y0.clone()))?;
    out.set_item("singular_values", f.singular_values.to_vec())?;
    out.set_item("order", f.order)?;
    out.set_item("suggested_order", f.suggested_order)?;
    out.set_item("method", method_name)?;
    out.set_item("threads", threads)?;
    Ok(out)
}

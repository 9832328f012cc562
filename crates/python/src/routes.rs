//! Bindings of the other identification routes: closed-loop IV subspace
//! (lifted-subspace, thesis ch. 7), the weighted multirate q-Markov Cover
//! (lifted-qmarkov, Zhu 2000) and multirate lifted identification
//! (lifted-multirate, thesis chs. 4–5, and its IV variant of §7.8.2).
//! Conversions only; every call releases the GIL.

use lifted_lti::Identifier;
use lifted_multirate::{
    LiftedIdOptions, LiftedIvOptions, Ordering, ProcedureOptions, identify_lifted_iv,
    identify_multirate,
};
use lifted_qmarkov::{QMarkov, QMarkovOptions, RecordMode};
use lifted_subspace::{IvExperiment, IvOptions, Method};
use nalgebra::DMatrix;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::choices::Choice;
use crate::convert::{Int, count, counts, opt_count, record, small};
use crate::errors::{err, lifted_error};
use crate::identify::order_of;
use crate::statespace::PyStateSpace;
use crate::{dataset, records, to_py};

/// Closed-loop instrumental-variable subspace identification (thesis ch. 7,
/// `lifted_subspace::iv_identify`) of one record or several: `us`, `ys`,
/// `instruments` lists of arrays (N×m, N×p, N×m; an instrument None uses u,
/// the open-loop case). Returns model, x0, singular_values, order,
/// suggested_order, stabilized, method, model_json.
#[pyfunction]
#[pyo3(signature = (us, ys, instruments, order=None, max_order=10, alpha=8, alpha_p=None,
    enforce_stability=false, require_stable=false, dt=1.0))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn iv<'py>(
    py: Python<'py>,
    us: Vec<Bound<'py, PyAny>>,
    ys: Vec<Bound<'py, PyAny>>,
    instruments: Vec<Option<Bound<'py, PyAny>>>,
    order: Option<Int>,
    max_order: Int,
    alpha: Int,
    alpha_p: Option<Int>,
    enforce_stability: bool,
    require_stable: bool,
    dt: f64,
) -> PyResult<Bound<'py, PyDict>> {
    if us.len() != instruments.len() {
        return Err(lifted_error(format!(
            "{} input records and {} instrument records (give one instrument, or None, per experiment)",
            us.len(),
            instruments.len()
        )));
    }
    let (u, y) = records(&us, &ys)?;
    let many = instruments.len() > 1;
    let f = instruments
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let name = if many {
                format!("instrument[{k}]")
            } else {
                "instrument".into()
            };
            f.as_ref().map(|f| record(f, &name)).transpose()
        })
        .collect::<PyResult<Vec<Option<DMatrix<f64>>>>>()?;
    let opts = IvOptions {
        order: order_of(opt_count(order, "order")?, count(max_order, "max_order")?),
        alpha: count(alpha, "alpha")?,
        alpha_p: opt_count(alpha_p, "alpha_p")?,
        enforce_stability,
        require_stable,
        ts: dt,
        ..Default::default()
    };
    let fit = py
        .detach(move || {
            let ex: Vec<IvExperiment<'_>> = u
                .iter()
                .zip(&y)
                .zip(&f)
                .map(|((u, y), f)| IvExperiment {
                    u,
                    y,
                    instrument: f.as_ref(),
                })
                .collect();
            lifted_subspace::iv_identify(&ex, &opts)
        })
        .map_err(err)?;
    let d = PyDict::new(py);
    let model = PyStateSpace::wrap(fit.model.clone());
    d.set_item("model_json", model.to_json_with(Some("iv"))?)?;
    d.set_item("model", model)?;
    let x0: Vec<Vec<f64>> = fit.x0.iter().map(|x| x.as_slice().to_vec()).collect();
    d.set_item("x0", x0)?;
    let dg = &fit.diagnostics;
    d.set_item("singular_values", dg.singular_values.clone())?;
    d.set_item("order", dg.order)?;
    d.set_item("suggested_order", dg.suggested_order)?;
    d.set_item("stabilized", dg.stabilized)?;
    d.set_item("method", "iv")?;
    Ok(d)
}

/// Weighted multirate q-Markov Cover (Zhu 2000) from inverse-PRBS
/// experiments, one per input channel (`us[l]` N×m with only column l
/// non-zero, `ys[l]` N×p, every output sampled every base period).
/// Returns model, eigenvalues (diag Λ of III-25, the order-selection plot),
/// order, suggested_order, markov_data, markov_model (lists of p×m arrays),
/// markov_error, covariance_error, cover ("Exact"/"LeastSquares"), stable,
/// spectral_radius, stabilized_from, model_json.
#[pyfunction]
#[pyo3(signature = (us, ys, q=60, order=None, max_order=20, hold=1, prbs_order=8,
    amplitudes=None, last_period=false, enforce_stability=false, require_stable=true, dt=1.0))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn qmarkov<'py>(
    py: Python<'py>,
    us: Vec<Bound<'py, PyAny>>,
    ys: Vec<Bound<'py, PyAny>>,
    q: Int,
    order: Option<Int>,
    max_order: Int,
    hold: Int,
    prbs_order: Int,
    amplitudes: Option<Vec<f64>>,
    last_period: bool,
    enforce_stability: bool,
    require_stable: bool,
    dt: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let (u, y) = records(&us, &ys)?;
    let sets = u
        .into_iter()
        .zip(y)
        .map(|(u, y)| dataset(dt, u, y, None, None))
        .collect::<PyResult<Vec<_>>>()?;
    let opts = QMarkovOptions {
        q: count(q, "q")?,
        order: opt_count(order, "order")?,
        max_auto_order: count(max_order, "max_order")?,
        hold: count(hold, "hold")?,
        prbs_order: small(prbs_order, "prbs_order")?,
        amplitudes,
        record: if last_period {
            RecordMode::LastPeriod
        } else {
            RecordMode::OnePeriod
        },
        enforce_stability,
        require_stable,
        ..Default::default()
    };
    let id = py
        .detach(move || QMarkov::new(opts).identify(&sets))
        .map_err(err)?;
    let dg = &id.diagnostics;
    let d = PyDict::new(py);
    let model = PyStateSpace::wrap(id.model.clone());
    d.set_item("model_json", model.to_json_with(Some("qmarkov"))?)?;
    d.set_item("model", model)?;
    d.set_item("eigenvalues", dg.eigenvalues.clone())?;
    d.set_item("order", dg.order)?;
    d.set_item("suggested_order", dg.suggested_order)?;
    let mats = |ms: &[DMatrix<f64>]| ms.iter().map(|m| to_py(py, m)).collect::<Vec<_>>();
    d.set_item("markov_data", mats(&dg.markov_data))?;
    d.set_item("markov_model", mats(&dg.markov_model))?;
    d.set_item("markov_error", dg.markov_error)?;
    d.set_item("covariance_error", dg.covariance_error)?;
    d.set_item("cover", format!("{:?}", dg.cover))?;
    d.set_item("stable", dg.stable)?;
    d.set_item("spectral_radius", dg.spectral_radius)?;
    d.set_item("stabilized_from", dg.stabilized_from)?;
    d.set_item("method", "qmarkov")?;
    Ok(d)
}

/// Multirate identification from one record: `u` (N×m, input i held
/// `holds[i]` samples), `y` (N×p, NaN where output i is not sampled; it is
/// sampled every `periods[i]` samples from sample 0). Lifting, causal lifted
/// subspace identification (or lifted IV with `instrument`, N×m), fast-model
/// extraction. Returns fast (the model at the base period dt), lifted,
/// lifting_period, singular_values, order, model_json.
#[pyfunction]
#[pyo3(signature = (u, y, periods, holds=None, instrument=None, method="n4sid", order=None,
    max_order=10, past=10, future=10, alpha=6, enforce_stability=false, require_stable=true,
    dt=1.0))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn multirate<'py>(
    py: Python<'py>,
    u: &Bound<'py, PyAny>,
    y: &Bound<'py, PyAny>,
    periods: Vec<Int>,
    holds: Option<Vec<Int>>,
    instrument: Option<&Bound<'py, PyAny>>,
    method: &str,
    order: Option<Int>,
    max_order: Int,
    past: Int,
    future: Int,
    alpha: Int,
    enforce_stability: bool,
    require_stable: bool,
    dt: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let method = Method::parse(method, "method")?;
    let periods = counts(&periods, "periods")?;
    let holds = holds.map(|h| counts(&h, "holds")).transpose()?;
    let (past, future) = (count(past, "past")?, count(future, "future")?);
    let alpha = count(alpha, "alpha")?;
    let data = dataset(
        dt,
        record(u, "u")?,
        record(y, "y")?,
        holds.as_deref(),
        Some(&periods),
    )?;
    let f = instrument.map(|f| record(f, "instrument")).transpose()?;
    let order = order_of(opt_count(order, "order")?, count(max_order, "max_order")?);
    let d = PyDict::new(py);
    let (fast, lifted, sv, period, name) = match f {
        Some(f) => {
            let opts = LiftedIvOptions {
                order,
                alpha,
                enforce_stability,
                require_stable,
                ..Default::default()
            };
            let fit = py
                .detach(|| identify_lifted_iv(&data, &f, Ordering::ChannelMajor, &opts))
                .map_err(err)?;
            let period =
                lifted_multirate::MultirateLifting::from_dataset(&data, Ordering::ChannelMajor)
                    .map_err(err)?
                    .period();
            (fit.fast, fit.lifted, fit.singular_values, period, "iv")
        }
        None => {
            let opts = ProcedureOptions {
                identification: LiftedIdOptions {
                    method,
                    order,
                    past,
                    future,
                    enforce_stability,
                    require_stable,
                    ..Default::default()
                },
                require_stable,
                ..Default::default()
            };
            let fit = py
                .detach(|| identify_multirate(&data, None, &opts))
                .map_err(err)?;
            let period = fit.lifting.period();
            let name = Method::name_of(&method);
            (
                fit.fast,
                fit.lifted.model,
                fit.lifted.singular_values,
                period,
                name,
            )
        }
    };
    d.set_item("order", fast.order())?;
    let fast = PyStateSpace::wrap(fast);
    d.set_item("model_json", fast.to_json_with(Some(name))?)?;
    d.set_item("fast", fast)?;
    d.set_item("lifted", PyStateSpace::wrap(lifted))?;
    d.set_item("lifting_period", period)?;
    d.set_item("singular_values", sv)?;
    d.set_item("method", name)?;
    Ok(d)
}

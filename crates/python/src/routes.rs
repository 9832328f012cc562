//! Bindings of the other identification routes, through the workflow layer
//! (`lifted_workflow::identify`, the layer of `lifted identify` and the
//! studio) with its defaults: closed-loop IV subspace (thesis ch. 7,
//! `lifted identify --method iv --instrument …`), the weighted multirate
//! q-Markov Cover (Zhu 2000, `--method qmarkov`, one record per input) and
//! multirate lifted identification (thesis chs. 4–5 and the lifted IV of
//! §7.8.2: a record whose outputs are sampled at multiples of the base
//! period). Conversions only; every call releases the GIL.

use lifted_workflow::{Method, Record, WorkflowOptions};
use nalgebra::DMatrix;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::choices::Choice;
use crate::convert::{
    Int, count, counts, int, ints, opt_count, opt_int, opt_ints, output_record, record, small,
};
use crate::errors::{arg_error, err, lifted_error};
use crate::identify::{detrend_of, identified_dict, order_choice, refinement, run, single_rate};
use crate::{dataset, finite, finite_records};

/// Closed-loop instrumental-variable subspace identification (thesis ch. 7)
/// of one record or several through the workflow (`lifted identify --method
/// iv`): `us`, `ys`, `instruments` lists of arrays (N×m, N×p, N×m; an
/// instrument None uses u, the open-loop case). `alpha` None: the
/// workflow's α (8); `alpha_p` None: 2α; `feedthrough` None or false: D = 0
/// (the closed-loop default). Returns the dict of `identified_dict` and
/// `stabilized`.
#[pyfunction]
#[pyo3(signature = (us, ys, instruments, order=None, max_order=10, alpha=None, alpha_p=None,
    feedthrough=None,
    order_criterion="validation", detrend="mean", remove_means=true, enforce_stability=false,
    require_stable=false, refine="auto", refine_iterations=100, refine_max_work=2e10, dt=1.0))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn iv<'py>(
    py: Python<'py>,
    us: Vec<Bound<'py, PyAny>>,
    ys: Vec<Bound<'py, PyAny>>,
    instruments: Vec<Option<Bound<'py, PyAny>>>,
    #[pyo3(from_py_with = opt_int)] order: Option<Int>,
    #[pyo3(from_py_with = int)] max_order: Int,
    #[pyo3(from_py_with = opt_int)] alpha: Option<Int>,
    #[pyo3(from_py_with = opt_int)] alpha_p: Option<Int>,
    feedthrough: Option<bool>,
    order_criterion: &str,
    detrend: &str,
    remove_means: bool,
    enforce_stability: bool,
    require_stable: bool,
    refine: &str,
    #[pyo3(from_py_with = int)] refine_iterations: Int,
    refine_max_work: f64,
    dt: f64,
) -> PyResult<Bound<'py, PyDict>> {
    if us.len() != instruments.len() {
        return Err(lifted_error(format!(
            "{} input records and {} instrument records (give one instrument, or None, per experiment)",
            us.len(),
            instruments.len()
        )));
    }
    let (u, y) = finite_records(&us, &ys)?;
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
    let mut opts = WorkflowOptions::default();
    opts.data.detrend = detrend_of(detrend, remove_means)?;
    let id = &mut opts.identification;
    id.method = Method::Iv;
    id.order = order_choice(order)?;
    id.max_order = count(max_order, "max_order")?;
    id.order_criterion =
        lifted_workflow::OrderCriterion::parse(order_criterion, "order_criterion")?;
    id.horizon = opt_count(alpha, "alpha")?;
    id.instrument_past = opt_count(alpha_p, "alpha_p")?;
    id.feedthrough = feedthrough;
    id.stable = enforce_stability;
    opts.validation.require_stable = require_stable;
    refinement(&mut opts, refine, refine_iterations, refine_max_work)?;
    let sets = u
        .into_iter()
        .zip(y)
        .zip(f)
        .map(|((u, y), f)| {
            dataset(dt, u, y, None, None).map(|data| Record {
                data,
                instrument: f,
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    let fit = run(py, sets, opts)?;
    let stabilized = lifted_workflow::Diagnostics::of(&fit.file).stabilized == Some(true);
    let d = identified_dict(py, &fit, 1)?;
    d.set_item("stabilized", stabilized)?;
    Ok(d)
}

/// Weighted multirate q-Markov Cover (Zhu 2000) from inverse-PRBS
/// experiments, one per input channel (`us[l]` N×m with only column l
/// non-zero, `ys[l]` N×p, every output sampled every base period), through
/// the workflow (`lifted identify --method qmarkov`). `q` None: 60 capped
/// below n_r m; `prbs_order` None: 8; `amplitudes` None: read from the
/// data (one value: every input). The record mode follows the record
/// length (one PRBS period, else its last period); `last_period` False
/// insists on one period. Returns the dict of `identified_dict`.
#[pyfunction]
#[pyo3(signature = (us, ys, q=None, order=None, max_order=10, hold=1, prbs_order=None,
    amplitudes=None, last_period=None, output_weight=None, detrend="mean", remove_means=true,
    enforce_stability=false, require_stable=false, refine="auto", refine_iterations=100,
    refine_max_work=2e10, dt=1.0))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn qmarkov<'py>(
    py: Python<'py>,
    us: Vec<Bound<'py, PyAny>>,
    ys: Vec<Bound<'py, PyAny>>,
    #[pyo3(from_py_with = opt_int)] q: Option<Int>,
    #[pyo3(from_py_with = opt_int)] order: Option<Int>,
    #[pyo3(from_py_with = int)] max_order: Int,
    #[pyo3(from_py_with = int)] hold: Int,
    #[pyo3(from_py_with = opt_int)] prbs_order: Option<Int>,
    amplitudes: Option<Vec<f64>>,
    last_period: Option<bool>,
    output_weight: Option<Vec<f64>>,
    detrend: &str,
    remove_means: bool,
    enforce_stability: bool,
    require_stable: bool,
    refine: &str,
    #[pyo3(from_py_with = int)] refine_iterations: Int,
    refine_max_work: f64,
    dt: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let (u, y) = finite_records(&us, &ys)?;
    let hold = count(hold, "hold")?;
    let prbs_order = prbs_order.map(|n| small(n, "prbs_order")).transpose()?;
    if last_period == Some(false) {
        let n = prbs_order.unwrap_or(lifted_qmarkov::QMarkovOptions::default().prbs_order);
        let m = lifted_prbs::period(n).map_err(err)? as usize;
        let period = 2 * hold.max(1) * m;
        if let Some(len) = u.iter().map(DMatrix::nrows).find(|&l| l != period) {
            return Err(arg_error(
                "last_period",
                format!(
                    "False asks for records of one PRBS period ({period} samples), got {len}; \
                     None or True uses the last period of a longer record"
                ),
            ));
        }
    }
    let mut opts = WorkflowOptions::default();
    opts.data.detrend = detrend_of(detrend, remove_means)?;
    opts.data.hold = hold;
    let id = &mut opts.identification;
    id.method = Method::Qmarkov;
    id.order = order_choice(order)?;
    id.max_order = count(max_order, "max_order")?;
    id.q = opt_count(q, "q")?;
    id.prbs_order = prbs_order;
    match amplitudes.as_deref() {
        None | Some([]) => {}
        Some([one]) => id.amplitude = Some(*one),
        Some(many) => id.amplitudes = many.to_vec(),
    }
    id.output_weight = output_weight.unwrap_or_default();
    id.stable = enforce_stability;
    opts.validation.require_stable = require_stable;
    refinement(&mut opts, refine, refine_iterations, refine_max_work)?;
    let fit = run(py, single_rate(dt, u, y)?, opts)?;
    identified_dict(py, &fit, 1)
}

/// Multirate identification from one record through the workflow (`lifted
/// identify` on a record with output periods): `u` (N×m, input i held
/// `holds[i]` samples), `y` (N×p, NaN where output i is not sampled; it is
/// sampled every `periods[i]` samples from sample 0). Lifting, causal
/// lifted subspace identification (or lifted IV with `instrument`, N×m, or
/// `method="iv"`), fast-model extraction, then the workflow's refinement.
/// `horizon` (or `past`/`future`, which must agree with it): the subspace
/// horizon (default 10); `alpha`: the IV horizon (default 6). Returns the
/// dict of `identified_dict`.
#[pyfunction]
#[pyo3(signature = (u, y, periods, holds=None, instrument=None, method="n4sid", order=None,
    max_order=10, horizon=None, past=None, future=None, alpha=None, alpha_p=None,
    detrend="mean", remove_means=true, enforce_stability=false, require_stable=false,
    refine="auto", refine_iterations=100, refine_max_work=2e10, dt=1.0, gain_stop_share=0.01,
    integrator_tolerance=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn multirate<'py>(
    py: Python<'py>,
    u: &Bound<'py, PyAny>,
    y: &Bound<'py, PyAny>,
    #[pyo3(from_py_with = ints)] periods: Vec<Int>,
    #[pyo3(from_py_with = opt_ints)] holds: Option<Vec<Int>>,
    instrument: Option<&Bound<'py, PyAny>>,
    method: &str,
    #[pyo3(from_py_with = opt_int)] order: Option<Int>,
    #[pyo3(from_py_with = int)] max_order: Int,
    #[pyo3(from_py_with = opt_int)] horizon: Option<Int>,
    #[pyo3(from_py_with = opt_int)] past: Option<Int>,
    #[pyo3(from_py_with = opt_int)] future: Option<Int>,
    #[pyo3(from_py_with = opt_int)] alpha: Option<Int>,
    #[pyo3(from_py_with = opt_int)] alpha_p: Option<Int>,
    detrend: &str,
    remove_means: bool,
    enforce_stability: bool,
    require_stable: bool,
    refine: &str,
    #[pyo3(from_py_with = int)] refine_iterations: Int,
    refine_max_work: f64,
    dt: f64,
    gain_stop_share: f64,
    integrator_tolerance: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut method = Method::parse(method, "method")?;
    let periods = counts(&periods, "periods")?;
    let holds = holds.map(|h| counts(&h, "holds")).transpose()?;
    let u = record(u, "u")?;
    finite("u", &u)?;
    let data = dataset(
        dt,
        u,
        output_record(y, "y")?,
        holds.as_deref(),
        Some(&periods),
    )?;
    let f = instrument.map(|f| record(f, "instrument")).transpose()?;
    if f.is_some() {
        method = Method::Iv;
    }
    let mut opts = WorkflowOptions::default();
    opts.data.detrend = detrend_of(detrend, remove_means)?;
    // The CLI's `--hold` (one hold for every input) sets the data's hold
    // too.
    if let Some([first, rest @ ..]) = holds.as_deref()
        && rest.iter().all(|h| h == first)
    {
        opts.data.hold = *first;
    }
    let id = &mut opts.identification;
    id.method = method;
    id.order = order_choice(order)?;
    id.max_order = count(max_order, "max_order")?;
    id.horizon = if method == Method::Iv {
        opt_count(alpha, "alpha")?
    } else {
        crate::identify::horizon_of(
            opt_count(horizon, "horizon")?,
            opt_count(past, "past")?,
            opt_count(future, "future")?,
        )?
    };
    id.instrument_past = opt_count(alpha_p, "alpha_p")?;
    id.stable = enforce_stability;
    id.gain_check.stop_share = gain_stop_share;
    id.integrator_tolerance = integrator_tolerance;
    opts.validation.require_stable = require_stable;
    refinement(&mut opts, refine, refine_iterations, refine_max_work)?;
    let sets = vec![Record {
        data,
        instrument: f,
    }];
    let fit = run(py, sets, opts)?;
    identified_dict(py, &fit, 1)
}

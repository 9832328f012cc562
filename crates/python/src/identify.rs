//! Binding of the identification workflow (`lifted_workflow`, the layer the
//! CLI and the studio call too): N4SID, MOESP, CVA on one record or several,
//! with the CLI's defaults (held-out structure selection, means removed, an
//! optional PEM/OE refinement). The model it returns carries the operating
//! point (the means removed from the records) and the Kalman gain of the
//! noise model, exactly as the CLI's model file does; the same data and
//! options give the same model as `lifted identify`.

use lifted_linalg::budget::resolve_threads;
use lifted_lti::ModelFile;
use lifted_subspace::{OrderSelection, SystemEstimate};
use lifted_workflow::{
    BdRoute, Detrend, Estimator, Order, OrderCriterion, Record, Refine, WorkflowOptions,
};
use nalgebra::DMatrix;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::choices::Choice;
use crate::convert::{Int, count, counts, int, opt_count, opt_int, opt_ints};
use crate::errors::{arg_error, err};
use crate::statespace::PyStateSpace;
use crate::{dataset, finite, finite_records, records, to_py};

/// Order selection: fixed `order`, else the singular-value gap up to `max_order`.
pub(crate) fn order_of(order: Option<usize>, max_order: usize) -> OrderSelection {
    match order {
        Some(n) => OrderSelection::Fixed(n),
        None => OrderSelection::Gap { max: max_order },
    }
}

/// The one horizon of the workflow from `horizon` and the older `past` /
/// `future` (each, when given, must agree with the others).
pub(crate) fn horizon_of(
    horizon: Option<usize>,
    past: Option<usize>,
    future: Option<usize>,
) -> PyResult<Option<usize>> {
    let mut h = horizon;
    for (name, v) in [("past", past), ("future", future)] {
        match (h, v) {
            (Some(a), Some(b)) if a != b => {
                return Err(arg_error(
                    name,
                    format!(
                        "{b} differs from the horizon {a}: the workflow takes one horizon \
                         (past = future), give `horizon`"
                    ),
                ));
            }
            (None, Some(b)) => h = Some(b),
            _ => {}
        }
    }
    Ok(h)
}

/// Identification through the workflow layer (`lifted_workflow::identify`,
/// the layer of `lifted identify` and the studio) from one or several
/// records (`us`, `ys`: lists of N×m and N×p arrays). Keyword defaults are
/// the workflow's (those of `lifted identify`): the horizon, the (A, C)
/// route and the order chosen by the held-out simulation fit when not
/// given, means removed, (B, D, x₀) by output-error least squares, the
/// prediction-error refinement where it pays (`refine="auto"`). `method`
/// also takes "pbsid", "ssarx" (`horizon`/`past`: their past horizon,
/// `future`: their future horizon) and "iv" (the inputs as instruments: the
/// open-loop case; `lifted.iv` takes instruments). `feedthrough` None: the
/// method's (N4SID/MOESP/CVA estimate D, the others not); False: D = 0.
/// `threads` is capped at
/// the machine's available parallelism (0 = all cores). `method` "arx" /
/// "fir": least-squares polynomial models, `orders` MATLAB's `[na nb nk]` /
/// `[nb nk]` (None: the workflow's structure scan). Returns the dict of
/// [`identified_dict`].
#[pyfunction]
#[pyo3(signature = (us, ys, method="n4sid", order=None, orders=None, max_order=10,
    order_criterion="validation", horizon=None, past=None, future=None, system=None, bd="auto",
    feedthrough=None, detrend="mean", remove_means=true, noise_model=true,
    enforce_stability=false, refine="auto", refine_iterations=100, refine_max_work=2e10, dt=1.0,
    threads=1, gain_stop_share=0.01, integrator_tolerance=None, process=None, kernel=None,
    refine_check="tests:0.95", selection=None, gain_covariance_start=true, budgets=None,
    plan=None, covariance=true, process_fixed=None, intersample=None, a_structure=None, f_structure=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn identify<'py>(
    py: Python<'py>,
    us: Vec<Bound<'py, PyAny>>,
    ys: Vec<Bound<'py, PyAny>>,
    method: &str,
    #[pyo3(from_py_with = opt_int)] order: Option<Int>,
    #[pyo3(from_py_with = opt_ints)] orders: Option<Vec<Int>>,
    #[pyo3(from_py_with = int)] max_order: Int,
    order_criterion: &str,
    #[pyo3(from_py_with = opt_int)] horizon: Option<Int>,
    #[pyo3(from_py_with = opt_int)] past: Option<Int>,
    #[pyo3(from_py_with = opt_int)] future: Option<Int>,
    system: Option<&str>,
    bd: &str,
    feedthrough: Option<bool>,
    detrend: &str,
    remove_means: bool,
    noise_model: bool,
    enforce_stability: bool,
    refine: &str,
    #[pyo3(from_py_with = int)] refine_iterations: Int,
    refine_max_work: f64,
    dt: f64,
    #[pyo3(from_py_with = int)] threads: Int,
    gain_stop_share: f64,
    integrator_tolerance: Option<f64>,
    process: Option<&str>,
    kernel: Option<&str>,
    refine_check: &str,
    selection: Option<Bound<'py, PyDict>>,
    gain_covariance_start: bool,
    budgets: Option<Bound<'py, PyDict>>,
    plan: Option<&str>,
    covariance: bool,
    process_fixed: Option<Bound<'py, PyDict>>,
    intersample: Option<&str>,
    a_structure: Option<&str>,
    f_structure: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let method = lifted_workflow::Method::parse(method, "method")?;
    let process = process
        .map(|p| lifted_pem::ProcessKind::parse(p, "process"))
        .transpose()?;
    let estimator = match system {
        None => Estimator::Auto,
        Some(s) => match SystemEstimate::parse(s, "system")? {
            SystemEstimate::ShiftInvariance => Estimator::Shift,
            SystemEstimate::StateSequence => Estimator::States,
        },
    };
    let records = sampled_records(&us, &ys, dt)?;
    let threads = resolve_threads(count(threads, "threads")?);
    let mut opts = WorkflowOptions::default();
    opts.data.detrend = detrend_of(detrend, remove_means)?;
    let id = &mut opts.identification;
    id.method = method;
    id.order = order_choice(order)?;
    id.orders = orders_of(orders.as_deref(), order)?;
    id.process = process;
    id.kernel = kernel
        .map(|k| lifted_pem::Kernel::parse(k, "kernel"))
        .transpose()?;
    id.max_order = count(max_order, "max_order")?;
    id.order_criterion = OrderCriterion::parse(order_criterion, "order_criterion")?;
    let (horizon, past, future) = (
        opt_count(horizon, "horizon")?,
        opt_count(past, "past")?,
        opt_count(future, "future")?,
    );
    if method.is_predictor_based() {
        // The past horizon (`horizon` or its spelling `past`) and the
        // future horizon of the predictor-based methods.
        id.horizon = horizon_of(horizon, past, None)?;
        id.future = future;
    } else {
        id.horizon = horizon_of(horizon, past, future)?;
    }
    id.estimator = estimator;
    id.bd = BdRoute::parse(bd, "bd")?;
    id.feedthrough = feedthrough;
    id.noise_model = noise_model;
    id.stable = enforce_stability;
    id.threads = Some(threads);
    id.gain_check.stop_share = gain_stop_share;
    id.gain_check.covariance_start = gain_covariance_start;
    id.integrator_tolerance = integrator_tolerance;
    id.a_structure = a_structure
        .map(|a| <lifted_pem::AStructure as Choice>::parse(a, "a_structure"))
        .transpose()?;
    id.f_structure = f_structure
        .map(|f| <lifted_pem::FStructure as Choice>::parse(f, "f_structure"))
        .transpose()?;
    id.intersample = intersample
        .map(|h| <lifted_pem::InterSample as Choice>::parse(h, "intersample"))
        .transpose()?;
    opts.validation.covariance = covariance;
    if let Some(d) = process_fixed {
        for (k, v) in d.iter() {
            let bad = |reason: String| {
                err(lifted_workflow::Error::InvalidOption {
                    option: "process_fixed",
                    reason,
                })
            };
            let name: String = k
                .extract()
                .map_err(|_| bad("the keys are parameter names ('Td', 'K(u1)')".into()))?;
            if v.is_instance_of::<pyo3::types::PyBool>() {
                return Err(bad(format!("{name}: a number, not a bool")));
            }
            let value: f64 = v
                .extract()
                .map_err(|_| bad(format!("{name}: a number, got {v}")))?;
            opts.identification.process_fixed.push((name, value));
        }
    }
    refinement(&mut opts, refine, refine_iterations, refine_max_work)?;
    opts.refinement.check = refine_check.parse::<lifted_pem::CheckRule>().map_err(|e| {
        err(lifted_workflow::Error::InvalidOption {
            option: "refine_check",
            reason: e.to_string(),
        })
    })?;
    if let Some(sel) = selection {
        opts.identification.selection = selection_of(&sel)?;
    }
    if let Some(b) = budgets {
        budgets_into(&b, &mut opts)?;
    }
    // A plan (the JSON of a model file or of the options): its options
    // replace the keywords' (the package's wrapper refuses keywords given
    // beside it).
    if let Some(text) = plan {
        let doc: serde_json::Value = serde_json::from_str(text).map_err(|e| {
            err(lifted_workflow::Error::InvalidOption {
                option: "plan",
                reason: format!("not JSON: {e}"),
            })
        })?;
        opts = lifted_workflow::options_from_plan(&doc).map_err(err)?;
    }
    let fit = run(py, records, opts)?;
    identified_dict(py, &fit, threads)
}

/// `selection={...}`: the automatic order's rules
/// (`lifted_workflow::SelectionOptions`), any of `stable_tries`,
/// `shortlist` (ints), `shortlist_span`, `tolerance`, `failed_fold`
/// (numbers); the others at their defaults. An unknown key or a value of
/// the wrong type is an `InvalidOptionError` naming it (the values' ranges
/// are checked by the workflow).
fn selection_of(d: &Bound<'_, PyDict>) -> PyResult<lifted_workflow::SelectionOptions> {
    let mut s = lifted_workflow::SelectionOptions::default();
    let bad = |key: &str, reason: String| {
        err(lifted_workflow::Error::InvalidOption {
            option: "selection",
            reason: format!("{key}: {reason}"),
        })
    };
    for (k, v) in d.iter() {
        let key: String = k
            .extract()
            .map_err(|_| bad("key", "the keys are the policy's field names".into()))?;
        let number = || -> PyResult<f64> {
            if v.is_instance_of::<pyo3::types::PyBool>() {
                return Err(bad(&key, "a number, not a bool".into()));
            }
            v.extract::<f64>()
                .map_err(|_| bad(&key, format!("a number, got {v}")))
        };
        let whole = || -> PyResult<usize> {
            if v.is_instance_of::<pyo3::types::PyBool>() {
                return Err(bad(&key, "an integer, not a bool".into()));
            }
            v.extract::<usize>()
                .map_err(|_| bad(&key, format!("a non-negative integer, got {v}")))
        };
        match key.as_str() {
            "stable_tries" => s.stable_tries = whole()?,
            "shortlist" => s.shortlist = whole()?,
            "shortlist_span" => s.shortlist_span = number()?,
            "tolerance" => s.tolerance = number()?,
            "failed_fold" => s.failed_fold = number()?,
            other => {
                return Err(bad(
                    other,
                    "unknown; the keys are stable_tries, shortlist, shortlist_span, tolerance, failed_fold".into(),
                ));
            }
        }
    }
    Ok(s)
}

/// `budgets={...}`: the default route's work and record-length budgets
/// (`lifted_workflow::Budgets` and the gain check's two; the names of
/// `lifted_workflow::BUDGET_NAMES`, as the command line's `--budget`), each
/// a number (samples: a whole one). An unknown name or a value of the wrong
/// type is an `InvalidOptionError` naming it (the values' ranges are
/// checked by the workflow).
fn budgets_into(
    d: &Bound<'_, PyDict>,
    opts: &mut lifted_workflow::WorkflowOptions,
) -> PyResult<()> {
    let bad = |key: &str, reason: String| {
        err(lifted_workflow::Error::InvalidOption {
            option: "budgets",
            reason: format!("{key}: {reason}"),
        })
    };
    for (k, v) in d.iter() {
        let key: String = k
            .extract()
            .map_err(|_| bad("key", "the keys are the budgets' names".into()))?;
        if v.is_instance_of::<pyo3::types::PyBool>() {
            return Err(bad(&key, "a number, not a bool".into()));
        }
        let value: f64 = v
            .extract()
            .map_err(|_| bad(&key, format!("a number, got {v}")))?;
        opts.budgets
            .set(&mut opts.identification.gain_check, &key, value)
            .map_err(err)?;
    }
    Ok(())
}

/// The records of `identify`: one record whose outputs hold NaN only at
/// instants that follow one period per output (the command line's rule for
/// empty cells, `lifted_lti::output_sampling`) is a multirate record with
/// those periods, identified by the multirate routes as the command line
/// identifies the same CSV; otherwise every value must be finite (the
/// single-rate records, [`finite_records`]'s error and message).
fn sampled_records(
    us: &[Bound<'_, PyAny>],
    ys: &[Bound<'_, PyAny>],
    dt: f64,
) -> PyResult<Vec<Record>> {
    if let ([u], [y]) = (us, ys) {
        let (mut u, mut y) = records(std::slice::from_ref(u), std::slice::from_ref(y))?;
        let (u, y) = (u.remove(0), y.remove(0));
        let gaps = y.iter().any(|v| v.is_nan()) && y.iter().all(|v| !v.is_infinite());
        if gaps && let Some(periods) = inferred_periods(&y) {
            finite("u", &u)?;
            return Ok(vec![Record::new(dataset(dt, u, y, None, Some(&periods))?)]);
        }
    }
    let (u, y) = finite_records(us, ys)?;
    single_rate(dt, u, y)
}

/// Each output's period from its NaN pattern (1 without NaN), `None` when
/// a pattern breaks the rule (an isolated missing value).
fn inferred_periods(y: &DMatrix<f64>) -> Option<Vec<usize>> {
    (0..y.ncols())
        .map(|j| {
            let col: Vec<f64> = y.column(j).iter().copied().collect();
            if col.iter().any(|v| v.is_nan()) {
                lifted_lti::output_sampling(&col, None).ok().map(|(p, _)| p)
            } else {
                Some(1)
            }
        })
        .collect()
}

/// The workflow's offsets from `detrend` and the older `remove_means`
/// (False is `detrend="none"`).
pub(crate) fn detrend_of(detrend: &str, remove_means: bool) -> PyResult<Detrend> {
    let detrend = Detrend::parse(detrend, "detrend")?;
    if remove_means {
        return Ok(detrend);
    }
    if detrend == Detrend::Linear {
        return Err(arg_error(
            "remove_means",
            "False (no offsets removed) contradicts detrend='linear'",
        ));
    }
    Ok(Detrend::None)
}

/// The workflow's order from the `order` keyword (None: automatic).
pub(crate) fn order_choice(order: Option<Int>) -> PyResult<Order> {
    Ok(match opt_count(order, "order")? {
        Some(n) => Order::Fixed(n),
        None => Order::Auto,
    })
}

/// The ARX/FIR order vector from the `orders` keyword (None: empty, the
/// structure scan); each entry non-negative. Given with `order` it is
/// refused (the two would contradict: `order` n is na = nb = n with nk
/// scanned). Its length, nb ≥ 1 and its use with a state-space method are
/// the workflow's checks (`argument 'orders'`).
pub(crate) fn orders_of(orders: Option<&[Int]>, order: Option<Int>) -> PyResult<Vec<usize>> {
    match orders {
        None => Ok(Vec::new()),
        Some(_) if order.is_some() => Err(arg_error(
            "orders",
            "give orders ([na nb nk] / [nb nk]) or order (na = nb = order, nk scanned), not both",
        )),
        Some([]) => Err(arg_error(
            "orders",
            "is empty: give [na nb nk] (arx) or [nb nk] (fir), or None for the structure scan",
        )),
        Some(v) => counts(v, "orders"),
    }
}

/// The refinement keywords (`refine`, `refine_iterations`,
/// `refine_max_work`) into the workflow options.
pub(crate) fn refinement(
    opts: &mut WorkflowOptions,
    refine: &str,
    iterations: Int,
    max_work: f64,
) -> PyResult<()> {
    opts.refinement.refine = Refine::parse(refine, "refine")?;
    opts.refinement.iterations = count(iterations, "refine_iterations")?;
    opts.refinement.max_work = max_work;
    Ok(())
}

/// Single-rate records (channels u1…, y1…) of the sample period `dt`.
pub(crate) fn single_rate(
    dt: f64,
    u: Vec<DMatrix<f64>>,
    y: Vec<DMatrix<f64>>,
) -> PyResult<Vec<Record>> {
    u.into_iter()
        .zip(y)
        .map(|(u, y)| dataset(dt, u, y, None, None).map(Record::new))
        .collect()
}

/// Runs the workflow on the records without the GIL.
pub(crate) fn run(
    py: Python<'_>,
    records: Vec<Record>,
    opts: WorkflowOptions,
) -> PyResult<lifted_workflow::Identified> {
    py.detach(move || lifted_workflow::identify(&records, &opts))
        .map_err(err)
}

/// The dict of a workflow run: model (with its operating point and Kalman
/// gain), kalman_gain, x0, u0/y0 (the offsets removed), singular_values,
/// order, suggested_order, method, threads (the count used), model_json
/// (the workflow's model file, as the CLI writes it: method, model,
/// operating point, Kalman gain and diagnostics; the CLI adds its column
/// names and data files), diagnostics_json (that file's diagnostics), and
/// the route's details: lifted and
/// lifting_period (multirate routes; None elsewhere), markov_data and
/// markov_model (q-Markov Cover; empty elsewhere), polynomial (ARX/FIR:
/// the dict of `polynomial::poly_dict`; None elsewhere).
pub(crate) fn identified_dict<'py>(
    py: Python<'py>,
    fit: &lifted_workflow::Identified,
    threads: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let f = &fit.file;
    let kalman_gain = f.kalman_gain_matrix();
    let name = f.method.as_deref().unwrap_or("?");
    let out = dict_of(
        py,
        FitParts {
            model: &f.model,
            kalman_gain: kalman_gain.as_ref(),
            x0: &fit.x0,
            operating_point: f.operating_point.as_ref(),
            singular_values: &fit.singular_values,
            order: fit.order,
            suggested_order: fit.suggested_order,
        },
        name,
        threads,
        Some(f),
    )?;
    out.set_item("diagnostics_json", f.diagnostics.to_string())?;
    let details = &fit.details;
    out.set_item("lifted", details.lifted.clone().map(PyStateSpace::wrap))?;
    out.set_item("lifting_period", details.lifting_period)?;
    let mats = |ms: &[DMatrix<f64>]| ms.iter().map(|m| to_py(py, m)).collect::<Vec<_>>();
    out.set_item("markov_data", mats(&details.markov_data))?;
    out.set_item("markov_model", mats(&details.markov_model))?;
    // ARX/FIR: the polynomial model of the model file (data units, with
    // its parameter covariance); None for the state-space routes.
    let polynomial = f
        .polynomial
        .as_ref()
        .map(|p| crate::polynomial::poly_dict(py, p))
        .transpose()?;
    out.set_item("polynomial", polynomial)?;
    Ok(out)
}

/// Predictor-based subspace identification through the workflow layer
/// (`lifted identify --method pbsid|ssarx|pbsid-rowwise`): PBSID-opt or SSARX, consistent
/// on closed-loop records without an external excitation. `past` None:
/// chosen by Akaike's criterion on the VARX predictor (up to 30); `future`
/// None: min(past, 10); `feedthrough` None or false: no D (the closed-loop
/// default); row-wise PBSID (`variant="pbsid_rowwise"`, `--method
/// pbsid-rowwise`) likewise. Returns the dict of [`identified_dict`].
#[pyfunction]
#[pyo3(signature = (us, ys, variant="pbsid", order=None, max_order=10, past=None, future=None,
    feedthrough=None, detrend="mean", remove_means=true, refine="auto", refine_iterations=100,
    refine_max_work=2e10, dt=1.0, threads=1))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn pbsid<'py>(
    py: Python<'py>,
    us: Vec<Bound<'py, PyAny>>,
    ys: Vec<Bound<'py, PyAny>>,
    variant: &str,
    #[pyo3(from_py_with = opt_int)] order: Option<Int>,
    #[pyo3(from_py_with = int)] max_order: Int,
    #[pyo3(from_py_with = opt_int)] past: Option<Int>,
    #[pyo3(from_py_with = opt_int)] future: Option<Int>,
    feedthrough: Option<bool>,
    detrend: &str,
    remove_means: bool,
    refine: &str,
    #[pyo3(from_py_with = int)] refine_iterations: Int,
    refine_max_work: f64,
    dt: f64,
    #[pyo3(from_py_with = int)] threads: Int,
) -> PyResult<Bound<'py, PyDict>> {
    let variant = lifted_subspace::PbsidVariant::parse(variant, "variant")?;
    let threads = resolve_threads(count(threads, "threads")?);
    let detrend = detrend_of(detrend, remove_means)?;
    let method = match variant {
        lifted_subspace::PbsidVariant::Optimized => lifted_workflow::Method::Pbsid,
        lifted_subspace::PbsidVariant::Ssarx => lifted_workflow::Method::Ssarx,
        lifted_subspace::PbsidVariant::RowWise => lifted_workflow::Method::PbsidRowwise,
    };
    let records = sampled_records(&us, &ys, dt)?;
    let mut opts = WorkflowOptions::default();
    opts.data.detrend = detrend;
    let id = &mut opts.identification;
    id.method = method;
    id.order = order_choice(order)?;
    id.max_order = count(max_order, "max_order")?;
    id.horizon = opt_count(past, "past")?;
    id.future = opt_count(future, "future")?;
    id.feedthrough = feedthrough;
    id.threads = Some(threads);
    refinement(&mut opts, refine, refine_iterations, refine_max_work)?;
    let fit = run(py, records, opts)?;
    identified_dict(py, &fit, threads)
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
        None,
    )
}

/// The result dict from its parts; `model_json` is `file` (the model file
/// of the identification, with its diagnostics) when given, else the
/// model's file with `method_name` and no diagnostics.
fn dict_of<'py>(
    py: Python<'py>,
    f: FitParts<'_>,
    method_name: &str,
    threads: usize,
    file: Option<&ModelFile>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut model = PyStateSpace::with_parts(
        f.model.clone(),
        f.operating_point.cloned(),
        f.kalman_gain.cloned(),
    )?;
    // The periods its gain was estimated with (the validation policy).
    model.gain_periods = file.and_then(lifted_workflow::gain_periods);
    let model_json = match file {
        Some(file) => file.to_json().map_err(err)?,
        None => model.to_json_with(Some(method_name))?,
    };
    let out = PyDict::new(py);
    out.set_item("model_json", model_json)?;
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

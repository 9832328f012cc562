//! Python bindings of Lifted: the extension module `lifted._lifted`, wrapped
//! by the pure-Python package `lifted` (`python/lifted/`).
//!
//! Every function reads its arguments with one conversion per kind
//! (`convert`: arrays through `numpy.asarray`, counts as Python integers,
//! string options through `choices`), calls the Lifted crates' public API
//! with the interpreter lock released (`Python::detach`), and maps every
//! Rust error to the exception hierarchy of `errors` (`LiftedError`, a
//! `ValueError`, and its subclasses carrying the error's fields). No
//! numerics live here: conversions only (O(N·channels) copies).
//!
//! The crate is built by maturin (`pip install ./crates/python`), which
//! enables the `extension-module` feature; without it (plain `cargo build`,
//! `cargo clippy`) pyo3 links libpython instead, so the workspace commands
//! work on a machine without maturin. See the crate README.

mod choices;
mod convert;
mod distributed;
mod errors;
mod identify;
mod mpc;
mod npy_shards;
mod polynomial;
mod routes;
mod signals;
mod simulation;
mod statespace;
mod validation;

use nalgebra::DMatrix;
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray2, PyArray3};
use pyo3::prelude::*;

pub use errors::LiftedError;
pub use statespace::PyStateSpace;

use crate::convert::{output_record, record};
use crate::errors::{err, lifted_error};

/// nalgebra → numpy, O(r·c).
pub(crate) fn to_py<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]).into_pyarray(py)
}

/// A list of N×p matrices (one per input, or per frequency) → one 3-D array.
pub(crate) fn stack<'py, T: numpy::Element + Copy + nalgebra::Scalar>(
    py: Python<'py>,
    ms: &[DMatrix<T>],
    rows: usize,
    cols: usize,
) -> Bound<'py, PyArray3<T>> {
    Array3::from_shape_fn((ms.len(), rows, cols), |(k, i, j)| ms[k][(i, j)]).into_pyarray(py)
}

/// Lists of input and output records, read as `u`/`y` (one record) or
/// `u[k]`/`y[k]` (several), with as many of each.
#[allow(clippy::type_complexity)]
pub(crate) fn records(
    us: &[Bound<'_, PyAny>],
    ys: &[Bound<'_, PyAny>],
) -> PyResult<(Vec<DMatrix<f64>>, Vec<DMatrix<f64>>)> {
    if us.len() != ys.len() {
        return Err(lifted_error(format!(
            "{} input records but {} output records",
            us.len(),
            ys.len()
        )));
    }
    let many = us.len() > 1;
    let name = |base: &str, k: usize| {
        if many {
            format!("{base}[{k}]")
        } else {
            base.to_string()
        }
    };
    let u = us
        .iter()
        .enumerate()
        .map(|(k, a)| record(a, &name("u", k)))
        .collect::<PyResult<Vec<_>>>()?;
    let y = ys
        .iter()
        .enumerate()
        .map(|(k, a)| output_record(a, &name("y", k)))
        .collect::<PyResult<Vec<_>>>()?;
    Ok((u, y))
}

/// The records of `us`, `ys` with every value finite (the subspace layer's
/// check and message: the sample and channel of the first NaN or
/// infinity).
#[allow(clippy::type_complexity)]
pub(crate) fn finite_records(
    us: &[Bound<'_, PyAny>],
    ys: &[Bound<'_, PyAny>],
) -> PyResult<(Vec<DMatrix<f64>>, Vec<DMatrix<f64>>)> {
    let (u, y) = records(us, ys)?;
    for (u, y) in u.iter().zip(&y) {
        for (what, m) in [("u", u), ("y", y)] {
            finite(what, m)?;
        }
    }
    Ok((u, y))
}

/// Fails on the first NaN or infinity of `m` (`what`: "u" or "y").
pub(crate) fn finite(what: &'static str, m: &DMatrix<f64>) -> PyResult<()> {
    match lifted_linalg::first_non_finite(m.as_slice()) {
        Some(i) => Err(err(lifted_subspace::Error::NonFinite {
            what,
            row: i % m.nrows().max(1),
            col: i / m.nrows().max(1),
        })),
        None => Ok(()),
    }
}

/// A data set with channels u1…, y1… (input i held `holds[i]`, output i
/// sampled every `periods[i]` from sample 0; None: every sample).
pub(crate) fn dataset(
    dt: f64,
    u: DMatrix<f64>,
    y: DMatrix<f64>,
    holds: Option<&[usize]>,
    periods: Option<&[usize]>,
) -> PyResult<lifted_lti::Dataset> {
    let (nu, ny) = (u.ncols(), y.ncols());
    if holds.is_some_and(|h| h.len() != nu) || periods.is_some_and(|p| p.len() != ny) {
        return Err(lifted_error(format!(
            "{} holds for {nu} inputs and {} periods for {ny} outputs",
            holds.map_or(nu, <[usize]>::len),
            periods.map_or(ny, <[usize]>::len)
        )));
    }
    let inputs = (0..nu)
        .map(|i| lifted_lti::InputChannel::new(format!("u{}", i + 1), holds.map_or(1, |h| h[i])))
        .collect();
    // A slow output's phase from its NaN pattern, by the command line's
    // rule (`lifted_lti::output_sampling`: the first measured sample, every
    // period from there; a record whose output is sampled at k ≡ 1 mod 4
    // was refused: "sample 0 is sampled but not finite").
    let outputs = (0..ny)
        .map(|i| {
            let period = periods.map_or(1, |p| p[i]);
            let offset = if period > 1 {
                let col: Vec<f64> = y.column(i).iter().copied().collect();
                lifted_lti::output_sampling(&col, Some(period))
                    .map_err(|e| lifted_error(format!("y column {}: {e}", i + 1)))?
                    .1
            } else {
                0
            };
            Ok(lifted_lti::OutputChannel::new(
                format!("y{}", i + 1),
                period,
                offset,
            ))
        })
        .collect::<PyResult<Vec<_>>>()?;
    lifted_lti::Dataset::new(dt, u, y, inputs, outputs).map_err(err)
}

/// Every string option type and its accepted names (the source of the
/// `Literal` aliases of `lifted._types`, checked by the test suite).
#[pyfunction]
fn _choices() -> Vec<(&'static str, Vec<&'static str>)> {
    choices::all()
}

/// The typed fields of the workflow's diagnostics
/// (`lifted_workflow::diagnostics::FIELDS`), which `lifted.Diagnostics`
/// mirrors (checked by the test suite).
#[pyfunction]
fn _diagnostics_fields() -> Vec<&'static str> {
    lifted_workflow::diagnostics::FIELDS.to_vec()
}

/// The thread count a `threads` option resolves to on this machine (0 =
/// all available cores; larger counts are capped at the available
/// parallelism), `lifted_linalg::budget::resolve_threads`.
#[pyfunction]
fn resolve_threads(#[pyo3(from_py_with = convert::int)] threads: convert::Int) -> PyResult<usize> {
    Ok(lifted_linalg::budget::resolve_threads(convert::count(
        threads, "threads",
    )?))
}

/// The extension module `lifted._lifted`.
#[pymodule]
fn _lifted(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    errors::register(m)?;
    m.add_class::<PyStateSpace>()?;
    m.add_class::<mpc::PyMpc>()?;
    m.add_function(wrap_pyfunction!(_diagnostics_fields, m)?)?;
    m.add_function(wrap_pyfunction!(routes::iv, m)?)?;
    m.add_function(wrap_pyfunction!(routes::qmarkov, m)?)?;
    m.add_function(wrap_pyfunction!(routes::multirate, m)?)?;
    m.add_function(wrap_pyfunction!(validation::validate, m)?)?;
    m.add_function(wrap_pyfunction!(signals::prbs, m)?)?;
    m.add_function(wrap_pyfunction!(signals::inverse_prbs, m)?)?;
    m.add_function(wrap_pyfunction!(signals::design, m)?)?;
    m.add_function(wrap_pyfunction!(signals::rbs, m)?)?;
    m.add_function(wrap_pyfunction!(signals::gbn, m)?)?;
    m.add_function(wrap_pyfunction!(signals::multisine, m)?)?;
    m.add_function(wrap_pyfunction!(identify::identify, m)?)?;
    m.add_function(wrap_pyfunction!(identify::pbsid, m)?)?;
    m.add_function(wrap_pyfunction!(polynomial::arxstruc, m)?)?;
    m.add_function(wrap_pyfunction!(polynomial::delayest, m)?)?;
    m.add_function(wrap_pyfunction!(polynomial::polynomial_from_json, m)?)?;
    m.add_function(wrap_pyfunction!(simulation::simulate_experiment, m)?)?;
    m.add_function(wrap_pyfunction!(resolve_threads, m)?)?;
    m.add_function(wrap_pyfunction!(_choices, m)?)?;
    m.add_class::<distributed::PyFirstPass>()?;
    m.add_function(wrap_pyfunction!(distributed::partial_plan, m)?)?;
    m.add_function(wrap_pyfunction!(distributed::channel_scales, m)?)?;
    m.add_function(wrap_pyfunction!(distributed::partial_compress, m)?)?;
    m.add_function(wrap_pyfunction!(distributed::partial_append, m)?)?;
    m.add_function(wrap_pyfunction!(distributed::partial_close, m)?)?;
    m.add_function(wrap_pyfunction!(distributed::partial_merge, m)?)?;
    m.add_function(wrap_pyfunction!(distributed::partial_identify, m)?)?;
    m.add_function(wrap_pyfunction!(distributed::regression_push, m)?)?;
    m.add_function(wrap_pyfunction!(distributed::regression_end_record, m)?)?;
    m.add_function(wrap_pyfunction!(distributed::regression_prime, m)?)?;
    m.add_function(wrap_pyfunction!(distributed::regression_advance, m)?)?;
    m.add_function(wrap_pyfunction!(distributed::regression_scan, m)?)?;
    m.add_function(wrap_pyfunction!(distributed::regression_merge, m)?)?;
    m.add_function(wrap_pyfunction!(distributed::regression_absorb, m)?)?;
    m.add_function(wrap_pyfunction!(npy_shards::partial_compress_npy, m)?)?;
    m.add_function(wrap_pyfunction!(npy_shards::regression_npy, m)?)?;
    m.add_function(wrap_pyfunction!(npy_shards::regression_memory, m)?)?;
    Ok(())
}

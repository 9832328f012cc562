//! Polynomial (MATLAB `idpoly`) models: the dict of a `lifted_lti::PolyModel`
//! (the `polynomial` of an ARX/FIR identification, `PolyModel.from_json`),
//! and the structure scan and delay estimate of `lifted_pem`
//! (`lifted.arxstruc`, `lifted.delayest`, MATLAB's `arxstruc`/`selstruc`
//! and `delayest`) on numpy records.
//!
//! Conversions only: the numerics are `lifted_pem`'s (one compression of
//! the lagged records, a QR per candidate and output).

use lifted_linalg::budget::resolve_threads;
use lifted_lti::{ModelFile, PolyFamily, PolyModel, PolyOrders};
use lifted_pem::{
    ArxScan, ArxScanOptions, DelayOptions, StructureCriterion, arx_scan, estimate_delays,
};
use lifted_subspace::Experiment;
use nalgebra::DMatrix;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{Int, count, counts, int, ints};
use crate::errors::{arg_error, err, lifted_error};

use crate::{finite_records, to_py};

/// The name of a polynomial family (`PolyModel.family`).
fn family_name(f: PolyFamily) -> &'static str {
    match f {
        PolyFamily::Arx => "arx",
        PolyFamily::Armax => "armax",
        PolyFamily::Oe => "oe",
        PolyFamily::Bj => "bj",
        PolyFamily::Fir => "fir",
        PolyFamily::General => "general",
    }
}

/// MATLAB's orders as a dict of nested lists (na, nb, nc, nd, nf, nk).
fn orders_dict<'py>(py: Python<'py>, o: &PolyOrders) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("na", o.na.clone())?;
    d.set_item("nb", o.nb.clone())?;
    d.set_item("nc", o.nc.clone())?;
    d.set_item("nd", o.nd.clone())?;
    d.set_item("nf", o.nf.clone())?;
    d.set_item("nk", o.nk.clone())?;
    Ok(d)
}

/// The dict of a polynomial model: `a` (n_y × n_y polynomials), `b`, `f`
/// (n_y × n_u), `c`, `d` (one per output), each in ascending powers of
/// q⁻¹; `nk` (n_y × n_u), `dt`, `family`, `orders`, `noise_variance`
/// (n_y × n_y), `parameters` (MATLAB's getpvec order), `covariance` and
/// `std` (None without a covariance), `poly_json` (the model's JSON,
/// `lifted_lti::PolyModel::to_json`).
pub(crate) fn poly_dict<'py>(py: Python<'py>, p: &PolyModel) -> PyResult<Bound<'py, PyDict>> {
    let polys = p.polynomials();
    let d = PyDict::new(py);
    d.set_item("family", family_name(p.family()))?;
    d.set_item("dt", p.ts())?;
    d.set_item("a", polys.a.unwrap_or_default())?;
    d.set_item("b", polys.b)?;
    d.set_item("c", polys.c.unwrap_or_default())?;
    d.set_item("d", polys.d.unwrap_or_default())?;
    d.set_item("f", polys.f.unwrap_or_default())?;
    d.set_item("nk", polys.nk)?;
    d.set_item("orders", orders_dict(py, &p.orders())?)?;
    d.set_item("noise_variance", to_py(py, p.noise_variance()))?;
    d.set_item("parameters", p.parameters().into_pyarray(py))?;
    d.set_item("covariance", p.covariance().map(|c| to_py(py, c)))?;
    d.set_item("std", p.std().map(|s| s.into_pyarray(py)))?;
    d.set_item("poly_json", p.to_json().map_err(err)?)?;
    Ok(d)
}

/// The polynomial model of `text`: a model file of kind "polynomial" (as
/// `lifted identify --method arx` and `fit.model_json` write it) or a
/// polynomial model's own JSON (`PolyModel.to_json()`). Returns the dict of
/// [`poly_dict`]; a state-space model file is a `LiftedError`.
#[pyfunction]
pub(crate) fn polynomial_from_json<'py>(
    py: Python<'py>,
    text: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let value: serde_json::Value =
        serde_json::from_str(text).map_err(|e| arg_error("text", format!("not JSON ({e})")))?;
    let poly = if value.get("kind").is_some() {
        let file = ModelFile::from_json(text).map_err(err)?;
        file.polynomial.ok_or_else(|| {
            lifted_error(format!(
                "the model file is of kind '{}', not 'polynomial': it holds no polynomial model \
                 (identify with method='arx' or 'fir')",
                file.kind
            ))
        })?
    } else {
        PolyModel::from_json(text).map_err(err)?
    };
    poly_dict(py, &poly)
}

/// The records `us`, `ys` (finite), each with its column means removed
/// when `remove_means`.
#[allow(clippy::type_complexity)]
fn scan_records(
    us: &[Bound<'_, PyAny>],
    ys: &[Bound<'_, PyAny>],
    remove_means: bool,
) -> PyResult<Vec<(DMatrix<f64>, DMatrix<f64>)>> {
    let (u, y) = finite_records(us, ys)?;
    let centre = |mut m: DMatrix<f64>| {
        if remove_means && m.nrows() > 0 {
            for mut c in m.column_iter_mut() {
                let mean = c.mean();
                c.add_scalar_mut(-mean);
            }
        }
        m
    };
    Ok(u.into_iter()
        .zip(y)
        .map(|(u, y)| (centre(u), centre(y)))
        .collect())
}

fn experiments(parts: &[(DMatrix<f64>, DMatrix<f64>)]) -> Vec<Experiment<'_>> {
    parts.iter().map(|(u, y)| Experiment { u, y }).collect()
}

/// A non-empty list of candidate orders (`name`).
fn grid(values: &[Int], name: &str) -> PyResult<Vec<usize>> {
    let v = counts(values, name)?;
    if v.is_empty() {
        return Err(arg_error(name, "needs at least one candidate value"));
    }
    Ok(v)
}

/// Rows × outputs matrix of per-output losses.
fn loss_matrix(rows: &[&[f64]], ny: usize) -> DMatrix<f64> {
    DMatrix::from_fn(rows.len(), ny, |r, i| {
        rows[r].get(i).copied().unwrap_or(f64::NAN)
    })
}

/// The dict of a structure scan (see `lifted.arxstruc`).
fn scan_dict<'py>(py: Python<'py>, scan: &ArxScan, ny: usize) -> PyResult<Bound<'py, PyDict>> {
    let rows = &scan.rows;
    let d = PyDict::new(py);
    d.set_item(
        "na",
        rows.iter().map(|r| r.structure.na).collect::<Vec<_>>(),
    )?;
    d.set_item(
        "nb",
        rows.iter().map(|r| r.structure.nb).collect::<Vec<_>>(),
    )?;
    d.set_item(
        "nk",
        rows.iter().map(|r| r.structure.nk).collect::<Vec<_>>(),
    )?;
    d.set_item(
        "parameters",
        rows.iter().map(|r| r.parameters).collect::<Vec<_>>(),
    )?;
    let losses: Vec<&[f64]> = rows.iter().map(|r| r.loss.as_slice()).collect();
    d.set_item("loss", to_py(py, &loss_matrix(&losses, ny)))?;
    d.set_item(
        "aic",
        rows.iter()
            .map(|r| r.aic)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    d.set_item(
        "mdl",
        rows.iter()
            .map(|r| r.mdl)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    let validation = if scan.validation_samples.is_some() {
        let v: Vec<&[f64]> = rows
            .iter()
            .map(|r| r.validation_loss.as_deref().unwrap_or(&[]))
            .collect();
        Some(to_py(py, &loss_matrix(&v, ny)))
    } else {
        None
    };
    d.set_item("validation_loss", validation)?;
    d.set_item("samples", scan.samples)?;
    d.set_item("validation_samples", scan.validation_samples)?;
    let skipped: Vec<(usize, usize, usize, String)> = scan
        .skipped
        .iter()
        .map(|(s, why)| (s.na, s.nb, s.nk, why.clone()))
        .collect();
    d.set_item("skipped", skipped)?;
    // The row each criterion picks, by the crate's rule (lowest value,
    // ties: fewer parameters), the rule of the workflow's scan.
    let best = PyDict::new(py);
    let index = |c: StructureCriterion| {
        scan.best(c)
            .and_then(|b| rows.iter().position(|r| std::ptr::eq(r, b)))
    };
    best.set_item("aic", index(StructureCriterion::Aic))?;
    best.set_item("mdl", index(StructureCriterion::Mdl))?;
    if scan.validation_samples.is_some() {
        best.set_item("validation", index(StructureCriterion::Validation))?;
    }
    d.set_item("best", best)?;
    Ok(d)
}

/// ARX structure scan (MATLAB's `arxstruc`): every (na, nb, nk) of the
/// grid fitted by least squares on one compression of the estimation
/// records `us`, `ys`, scored by AIC and MDL and, with validation records
/// `us_val`, `ys_val` (empty lists: none), by the one-step loss on them.
/// Returns a dict of the table (see `lifted.arxstruc`).
#[pyfunction]
#[pyo3(signature = (us, ys, us_val, ys_val, na, nb, nk, remove_means=true, threads=1))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn arxstruc<'py>(
    py: Python<'py>,
    us: Vec<Bound<'py, PyAny>>,
    ys: Vec<Bound<'py, PyAny>>,
    us_val: Vec<Bound<'py, PyAny>>,
    ys_val: Vec<Bound<'py, PyAny>>,
    #[pyo3(from_py_with = ints)] na: Vec<Int>,
    #[pyo3(from_py_with = ints)] nb: Vec<Int>,
    #[pyo3(from_py_with = ints)] nk: Vec<Int>,
    remove_means: bool,
    #[pyo3(from_py_with = int)] threads: Int,
) -> PyResult<Bound<'py, PyDict>> {
    let opts = ArxScanOptions {
        na: grid(&na, "na")?,
        nb: grid(&nb, "nb")?,
        nk: grid(&nk, "nk")?,
        threads: resolve_threads(count(threads, "threads")?),
        ..Default::default()
    };
    if opts.na.iter().all(|&a| a == 0) && opts.nb.iter().all(|&b| b == 0) {
        return Err(arg_error(
            "nb",
            "every candidate has na = nb = 0 (no parameter): give nb ≥ 1",
        ));
    }
    let est = scan_records(&us, &ys, remove_means)?;
    let val = scan_records(&us_val, &ys_val, remove_means)?;
    let ny = est.first().map_or(0, |(_, y)| y.ncols());
    let scan = py
        .detach(move || arx_scan(&experiments(&est), &experiments(&val), &opts))
        .map_err(err)?;
    scan_dict(py, &scan, ny)
}

/// Input delays (MATLAB's `delayest`): per output and input, the delay in
/// `min_delay..=max_delay` whose ARX model (A of degree `na`, `nb` B
/// coefficients) has the lowest loss. Returns n_y × n_u delays.
#[pyfunction]
#[pyo3(signature = (us, ys, na=2, nb=2, min_delay=0, max_delay=20, remove_means=true, threads=1))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn delayest<'py>(
    py: Python<'py>,
    us: Vec<Bound<'py, PyAny>>,
    ys: Vec<Bound<'py, PyAny>>,
    #[pyo3(from_py_with = int)] na: Int,
    #[pyo3(from_py_with = int)] nb: Int,
    #[pyo3(from_py_with = int)] min_delay: Int,
    #[pyo3(from_py_with = int)] max_delay: Int,
    remove_means: bool,
    #[pyo3(from_py_with = int)] threads: Int,
) -> PyResult<Vec<Vec<usize>>> {
    let opts = DelayOptions {
        na: count(na, "na")?,
        nb: count(nb, "nb")?,
        min_delay: count(min_delay, "min_delay")?,
        max_delay: count(max_delay, "max_delay")?,
        threads: resolve_threads(count(threads, "threads")?),
        ..Default::default()
    };
    if opts.nb == 0 {
        return Err(arg_error(
            "nb",
            "must be at least 1 (the delay is that of the input term)",
        ));
    }
    if opts.min_delay > opts.max_delay {
        return Err(arg_error(
            "max_delay",
            format!("{} is below min_delay {}", opts.max_delay, opts.min_delay),
        ));
    }
    let records = scan_records(&us, &ys, remove_means)?;
    py.detach(move || estimate_delays(&experiments(&records), &opts))
        .map_err(err)
}

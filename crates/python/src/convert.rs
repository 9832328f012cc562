//! Reading Python arguments: arrays and counts, each named in its errors.
//!
//! Arrays go through `numpy.asarray`, so anything numpy reads is accepted
//! (lists, nested lists, integer and boolean arrays, numpy scalars, objects
//! with `__array__`); complex and non-numeric arrays are refused with an
//! [`ArgumentError`](crate::errors::ArgumentError) naming the argument (the
//! imaginary part is never dropped silently). Counts arrive as Python
//! integers (`i128`, so a negative value is read, not an `OverflowError`)
//! and are checked here. Every conversion is one O(size) copy.

use nalgebra::{DMatrix, DVector};
use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;

use crate::errors::{arg_error, err};

/// The Python type of integer arguments (read without overflow, checked by
/// [`count`]).
pub(crate) type Int = i128;

/// A non-negative integer argument as `usize`.
pub(crate) fn count(value: Int, name: &str) -> PyResult<usize> {
    if value < 0 {
        return Err(arg_error(
            name,
            format!("must be a non-negative integer, got {value}"),
        ));
    }
    usize::try_from(value).map_err(|_| arg_error(name, format!("{value} is too large")))
}

/// An optional non-negative integer argument.
pub(crate) fn opt_count(value: Option<Int>, name: &str) -> PyResult<Option<usize>> {
    value.map(|v| count(v, name)).transpose()
}

/// A list of non-negative integers (entry k named `name[k]`).
pub(crate) fn counts(values: &[Int], name: &str) -> PyResult<Vec<usize>> {
    values
        .iter()
        .enumerate()
        .map(|(k, &v)| count(v, &format!("{name}[{k}]")))
        .collect()
}

/// Checks an allocation the binding asks for by an argument (a signal
/// length, a number of samples) against the memory budget
/// (`lifted_linalg::budget`): a `MemoryBudgetError`, not an abort, for a
/// length such as 2⁴⁰.
pub(crate) fn budget(what: &'static str, size: lifted_linalg::budget::Size) -> PyResult<()> {
    lifted_linalg::budget::MemoryBudget::default()
        .check(what, size)
        .map_err(err)
}

/// A non-negative integer that fits `u64` (seeds).
pub(crate) fn seed(value: Int, name: &str) -> PyResult<u64> {
    if value < 0 {
        return Err(arg_error(
            name,
            format!("must be a non-negative integer, got {value}"),
        ));
    }
    u64::try_from(value).map_err(|_| arg_error(name, format!("{value} does not fit 64 bits")))
}

/// A non-negative integer that fits `u32` (PRBS orders).
pub(crate) fn small(value: Int, name: &str) -> PyResult<u32> {
    let v = count(value, name)?;
    u32::try_from(v).map_err(|_| arg_error(name, format!("{value} is too large")))
}

/// `obj` as a float64 numpy array (any number of dimensions), refusing
/// complex and non-numeric data.
fn float_array<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    if let Ok(a) = obj.cast::<PyArrayDyn<f64>>() {
        return Ok(a.clone());
    }
    let np = obj.py().import("numpy")?;
    let raw = np
        .call_method1("asarray", (obj,))
        .map_err(|e| arg_error(name, format!("cannot be read as an array ({e})")))?;
    let dtype = raw.getattr("dtype")?;
    let kind: String = dtype.getattr("kind")?.extract()?;
    let dname: String = dtype.str()?.extract()?;
    match kind.as_str() {
        "c" => {
            return Err(arg_error(
                name,
                format!(
                    "is complex ({dname}); Lifted works on real signals and matrices \
                     (pass .real explicitly if the imaginary part is to be dropped)"
                ),
            ));
        }
        "b" | "i" | "u" | "f" | "O" => {}
        _ => {
            return Err(arg_error(
                name,
                format!("must hold real numbers, got an array of {dname}"),
            ));
        }
    }
    let converted = raw
        .call_method1("astype", ("float64",))
        .map_err(|e| arg_error(name, format!("must hold real numbers ({e})")))?;
    converted
        .cast_into::<PyArrayDyn<f64>>()
        .map_err(|e| arg_error(name, format!("cannot be read as a float64 array ({e})")))
}

/// The shape and row-major values of a float array.
fn values(a: &Bound<'_, PyArrayDyn<f64>>, name: &str) -> PyResult<(Vec<usize>, Vec<f64>)> {
    let ro = a
        .try_readonly()
        .map_err(|e| arg_error(name, format!("cannot be read ({e})")))?;
    let view = ro.as_array();
    Ok((a.shape().to_vec(), view.iter().copied().collect()))
}

/// A row-major buffer as an r×c matrix.
fn from_rows(r: usize, c: usize, v: &[f64]) -> DMatrix<f64> {
    DMatrix::from_fn(r, c, |i, j| v[i * c + j])
}

/// A data record: samples × channels; a 1-D array is one channel.
pub(crate) fn record(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<DMatrix<f64>> {
    let a = float_array(obj, name)?;
    let (shape, v) = values(&a, name)?;
    match shape.as_slice() {
        [n] => Ok(from_rows(*n, 1, &v)),
        [r, c] => Ok(from_rows(*r, *c, &v)),
        _ => Err(arg_error(
            name,
            format!(
                "must be a 1-D (one channel) or 2-D (samples x channels) array, got {} dimensions",
                shape.len()
            ),
        )),
    }
}

/// How a 1-D array fills a matrix argument.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Vector {
    /// A 1 × k row.
    Row,
    /// A k × 1 column.
    Column,
}

/// A matrix argument: 2-D as given, a scalar as 1×1 (or `fill` rows ×
/// cols of it, numpy's broadcasting of a scalar), a 1-D array as `vector`.
pub(crate) fn matrix(
    obj: &Bound<'_, PyAny>,
    name: &str,
    vector: Vector,
    fill: Option<(usize, usize)>,
) -> PyResult<DMatrix<f64>> {
    let a = float_array(obj, name)?;
    let (shape, v) = values(&a, name)?;
    match shape.as_slice() {
        [] => {
            let (r, c) = fill.unwrap_or((1, 1));
            Ok(DMatrix::from_element(r, c, v[0]))
        }
        [k] => Ok(match vector {
            Vector::Row => from_rows(1, *k, &v),
            Vector::Column => from_rows(*k, 1, &v),
        }),
        [r, c] => Ok(from_rows(*r, *c, &v)),
        _ => Err(arg_error(
            name,
            format!("must be a 2-D array, got {} dimensions", shape.len()),
        )),
    }
}

/// A vector argument: 1-D, a scalar (length 1), or a 2-D array with one
/// row or one column.
pub(crate) fn vector(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<f64>> {
    let a = float_array(obj, name)?;
    let (shape, v) = values(&a, name)?;
    match shape.as_slice() {
        [] | [_] => Ok(v),
        [1, _] | [_, 1] => Ok(v),
        _ => Err(arg_error(
            name,
            format!("must be a 1-D array, got shape {shape:?}"),
        )),
    }
}

/// An optional vector argument as a nalgebra vector.
pub(crate) fn opt_dvector(
    obj: Option<&Bound<'_, PyAny>>,
    name: &str,
) -> PyResult<Option<DVector<f64>>> {
    obj.map(|o| vector(o, name).map(DVector::from_vec))
        .transpose()
}

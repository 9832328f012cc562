//! Reading Python arguments: arrays and counts, each named in its errors.
//!
//! Arrays go through `numpy.asarray`, so anything numpy reads is accepted
//! (lists, nested lists, integer and boolean arrays, numpy scalars, objects
//! with `__array__`); complex and non-numeric arrays are refused with an
//! [`ArgumentError`](crate::errors::ArgumentError) naming the argument (the
//! imaginary part is never dropped silently). A numpy masked array's masked
//! entries are missing values: NaN where the argument takes missing samples
//! (outputs, [`Masked::Missing`]), refused by name everywhere else (inputs,
//! model matrices, [`Masked::Refused`]); its data under the mask are never
//! used as numbers.
//!
//! Integer arguments are read by [`int`] (and [`opt_int`], [`ints`],
//! [`opt_ints`]), named on every integer parameter as
//! `#[pyo3(from_py_with = int)]`: a Python `int` or anything with
//! `__index__` (numpy integers), as `i128` (so a negative value is read, not
//! an `OverflowError`), then checked by [`count`] and its siblings. A
//! `bool` (or `numpy.bool_`) is refused with a `TypeError` (pyo3 adds the
//! note "while processing 'order'"): `bool` is a subclass of `int`, and
//! `order=True` must not mean order 1. (Not a newtype with its own
//! `FromPyObject`: pyo3's signature defaults are Rust expressions of the
//! parameter's type, and only a primitive integer keeps them literals such
//! as `max_order=10`, which the text signatures and the stub show.) Every
//! conversion is one O(size) copy.

use nalgebra::{DMatrix, DVector};
use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyBool, PyInt, PyString, PyType};

use crate::errors::{arg_error, err};

/// The Rust type of integer arguments, read by [`int`] without overflow
/// and checked by [`count`].
pub(crate) type Int = i128;

/// Whether `obj` is a `bool` or a `numpy.bool_`.
fn is_bool(obj: &Bound<'_, PyAny>) -> PyResult<bool> {
    if obj.is_instance_of::<PyBool>() {
        return Ok(true);
    }
    if obj.is_instance_of::<PyInt>() {
        return Ok(false);
    }
    static NUMPY_BOOL: PyOnceLock<Py<PyType>> = PyOnceLock::new();
    obj.is_instance(NUMPY_BOOL.import(obj.py(), "numpy", "bool_")?)
}

/// The `TypeError` of a bool given for an integer (`at`: the entry of a
/// list argument).
fn bool_error(obj: &Bound<'_, PyAny>, at: Option<usize>) -> PyResult<PyErr> {
    let entry = at.map_or(String::new(), |k| format!("entry {k}: "));
    Ok(PyTypeError::new_err(format!(
        "{entry}expected an integer, got the bool {} (a bool is not read as 1 or 0: pass an int)",
        obj.repr()?
    )))
}

/// An integer argument (`#[pyo3(from_py_with = int)]`): a Python `int`
/// or an object with `__index__`; a bool is a `TypeError`.
pub(crate) fn int(obj: &Bound<'_, PyAny>) -> PyResult<Int> {
    if is_bool(obj)? {
        return Err(bool_error(obj, None)?);
    }
    obj.extract()
}

/// An optional integer argument (`#[pyo3(from_py_with = opt_int)]`):
/// None, or as [`int`].
pub(crate) fn opt_int(obj: &Bound<'_, PyAny>) -> PyResult<Option<Int>> {
    if obj.is_none() {
        return Ok(None);
    }
    int(obj).map(Some)
}

/// A list of integers (`#[pyo3(from_py_with = ints)]`): a sized
/// collection (a list, a tuple, a 1-D array; not a str) whose entries are
/// read as by [`int`].
pub(crate) fn ints(obj: &Bound<'_, PyAny>) -> PyResult<Vec<Int>> {
    if obj.is_instance_of::<PyString>() {
        return Err(PyTypeError::new_err(
            "expected a sequence of integers, got a str",
        ));
    }
    let mut out = Vec::with_capacity(obj.len()?);
    for (k, item) in obj.try_iter()?.enumerate() {
        let item = item?;
        if is_bool(&item)? {
            return Err(bool_error(&item, Some(k))?);
        }
        out.push(item.extract()?);
    }
    Ok(out)
}

/// An optional list of integers (`#[pyo3(from_py_with = opt_ints)]`).
pub(crate) fn opt_ints(obj: &Bound<'_, PyAny>) -> PyResult<Option<Vec<Int>>> {
    if obj.is_none() {
        return Ok(None);
    }
    ints(obj).map(Some)
}

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

/// What a masked entry of a numpy masked array (`numpy.ma`) means for an
/// array argument; the data under the mask are never read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Masked {
    /// A missing sample, read as NaN: exactly what a NaN entry means there
    /// (the instants an output was not sampled, whose pattern gives a slow
    /// output's sampling phase; a route without missing samples refuses it
    /// as it refuses NaN).
    Missing,
    /// Refused with an [`ArgumentError`](crate::errors::ArgumentError)
    /// naming the argument; the text says why it cannot have missing
    /// values.
    Refused(&'static str),
}

/// Why a signal other than an output cannot have missing samples.
const SIGNAL: &str = "a masked entry is a missing sample, and only an output can have \
     missing samples (NaN or a masked entry marks an instant it was not sampled); \
     an input, an instrument or a set-point needs every sample: fill them or leave \
     those samples out";

/// Why a matrix or vector argument cannot have masked entries.
const VALUES: &str = "a masked entry is a missing value, and this argument needs every \
     value: pass a filled array (numpy.ma.filled)";

/// `obj` as a float64 numpy array (any number of dimensions), refusing
/// complex and non-numeric data; a masked array's masked entries as
/// `masked` says.
fn float_array<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    masked: Masked,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    static MASKED_ARRAY: PyOnceLock<Py<PyType>> = PyOnceLock::new();
    // A masked array is an ndarray too: checked first, so that the data
    // under its mask never pass as numbers.
    if obj.is_instance(MASKED_ARRAY.import(obj.py(), "numpy.ma", "MaskedArray")?)? {
        return unmasked(obj, name, masked);
    }
    plain_float_array(obj, name)
}

/// The float64 data of the masked array `obj`, NaN where it is masked
/// ([`Masked::Missing`]) or refused when any entry is ([`Masked::Refused`]).
fn unmasked<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    masked: Masked,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let py = obj.py();
    let ma = py.import("numpy.ma")?;
    let data = plain_float_array(&ma.call_method1("getdata", (obj,))?, name)?;
    let mask = ma.call_method1("getmaskarray", (obj,))?;
    let n_masked: usize = mask.call_method0("sum")?.extract()?;
    if n_masked == 0 {
        return Ok(data);
    }
    let np = py.import("numpy")?;
    match masked {
        Masked::Refused(why) => {
            let first: Vec<usize> = np
                .call_method1("argwhere", (&mask,))?
                .get_item(0)?
                .call_method0("tolist")?
                .extract()?;
            let at = first
                .iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ");
            let entries = if n_masked == 1 { "entry" } else { "entries" };
            Err(arg_error(
                name,
                format!("{n_masked} masked {entries} (the first at index ({at})): {why}"),
            ))
        }
        Masked::Missing => np
            .call_method1("where", (&mask, f64::NAN, &data))?
            .cast_into::<PyArrayDyn<f64>>()
            .map_err(|e| arg_error(name, format!("cannot be read as a float64 array ({e})"))),
    }
}

/// [`float_array`] of an object that is not a masked array.
fn plain_float_array<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
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

/// A data record of a signal that has every sample (an input, an
/// instrument, a set-point): samples × channels; a 1-D array is one
/// channel. Masked entries are refused.
pub(crate) fn record(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<DMatrix<f64>> {
    record_of(obj, name, Masked::Refused(SIGNAL))
}

/// A record of outputs, whose missing samples (NaN, or masked entries,
/// read as NaN) are the instants an output was not sampled.
pub(crate) fn output_record(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<DMatrix<f64>> {
    record_of(obj, name, Masked::Missing)
}

/// A record with masked entries read as `masked` says.
fn record_of(obj: &Bound<'_, PyAny>, name: &str, masked: Masked) -> PyResult<DMatrix<f64>> {
    let a = float_array(obj, name, masked)?;
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
/// Masked entries are refused.
pub(crate) fn matrix(
    obj: &Bound<'_, PyAny>,
    name: &str,
    vector: Vector,
    fill: Option<(usize, usize)>,
) -> PyResult<DMatrix<f64>> {
    let a = float_array(obj, name, Masked::Refused(VALUES))?;
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
/// row or one column. Masked entries are refused.
pub(crate) fn vector(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<f64>> {
    let a = float_array(obj, name, Masked::Refused(VALUES))?;
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

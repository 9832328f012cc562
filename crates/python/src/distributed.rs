//! Bindings of the mergeable partial compressions of lifted-subspace
//! (`CompressionPlan`, `RecordPiece`, `CompressedRecords`) and of the
//! serialisable (B, D, x₀) regression stream, for `lifted.dask`: every
//! state that crosses a process boundary is `bytes` (CBOR), so it pickles
//! as is. Conversions only; every call releases the GIL.

use lifted_linalg::budget::resolve_threads;
use lifted_subspace::Method;
use lifted_subspace::{
    CompressedRecords, CompressionPlan, OrderSelection, OutputErrorStream, RecordPiece,
    RegressionPiece, StreamedSubspace, SubspaceOptions,
};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

use crate::choices::Choice;
use crate::convert::{Int, count, int, opt_count, opt_int, output_record, record};
use crate::errors::{err, lifted_error};

/// The options of a sharded identification (the in-memory `identify`'s).
#[allow(clippy::too_many_arguments)]
fn options(
    method: &str,
    order: Option<Int>,
    max_order: Int,
    past: Int,
    future: Int,
    remove_means: bool,
    noise_model: bool,
    dt: f64,
    threads: Int,
) -> PyResult<SubspaceOptions> {
    Ok(SubspaceOptions {
        method: Method::parse(method, "method")?,
        order: crate::identify::order_of(
            opt_count(order, "order")?,
            count(max_order, "max_order")?,
        ),
        past: count(past, "past")?,
        future: count(future, "future")?,
        remove_means,
        noise_model,
        ts: dt,
        threads: resolve_threads(count(threads, "threads")?),
        ..Default::default()
    })
}

/// Runs `f` without the GIL and returns its bytes (every state crossing a
/// process boundary).
fn bytes_of<'py>(
    py: Python<'py>,
    f: impl FnOnce() -> lifted_subspace::Result<Vec<u8>> + Send,
) -> PyResult<Bound<'py, PyBytes>> {
    let bytes = py.detach(f).map_err(err)?;
    Ok(PyBytes::new(py, &bytes))
}

/// The compression plan (scale, centring reference, horizons) from the
/// first samples of the record `u` (N×m), `y` (N×p); returns its bytes.
#[pyfunction]
#[pyo3(signature = (u, y, past=10, future=10, remove_means=true))]
pub fn partial_plan<'py>(
    py: Python<'py>,
    u: Bound<'py, PyAny>,
    y: Bound<'py, PyAny>,
    #[pyo3(from_py_with = int)] past: Int,
    #[pyo3(from_py_with = int)] future: Int,
    remove_means: bool,
) -> PyResult<Bound<'py, PyBytes>> {
    let (u, y) = (record(&u, "u")?, output_record(&y, "y")?);
    let opts = SubspaceOptions {
        past: count(past, "past")?,
        future: count(future, "future")?,
        remove_means,
        order: OrderSelection::Gap { max: 1 },
        ..Default::default()
    };
    let plan = py
        .detach(move || CompressionPlan::from_first_block(&u, &y, &opts))
        .map_err(err)?;
    let bytes = plan.to_bytes().map_err(err)?;
    Ok(PyBytes::new(py, &bytes))
}

/// The channel scales the workflow identifies with
/// (`lifted_workflow::ChannelScales`): the standard deviation of each
/// column of `u` and `y` over their first `SCALE_ROWS` (1e4) rows; returns
/// (input scales, output scales).
#[pyfunction]
pub fn channel_scales(u: Bound<'_, PyAny>, y: Bound<'_, PyAny>) -> PyResult<(Vec<f64>, Vec<f64>)> {
    let (u, y) = (record(&u, "u")?, output_record(&y, "y")?);
    let rows = u.nrows().min(y.nrows()).min(lifted_workflow::SCALE_ROWS);
    let s = lifted_workflow::ChannelScales::of_rows(&u.rows(0, rows), &y.rows(0, rows));
    Ok((s.u, s.y))
}

fn plan_of(bytes: &[u8]) -> PyResult<CompressionPlan> {
    CompressionPlan::from_bytes(bytes).map_err(err)
}

/// Compresses consecutive samples `u`, `y` of one record with `plan`;
/// returns the piece's bytes.
#[pyfunction]
#[pyo3(signature = (plan, u, y, threads=1))]
pub fn partial_compress<'py>(
    py: Python<'py>,
    plan: &[u8],
    u: Bound<'py, PyAny>,
    y: Bound<'py, PyAny>,
    #[pyo3(from_py_with = int)] threads: Int,
) -> PyResult<Bound<'py, PyBytes>> {
    let plan = plan_of(plan)?;
    let threads = resolve_threads(count(threads, "threads")?);
    let (u, y) = (record(&u, "u")?, output_record(&y, "y")?);
    bytes_of(py, move || plan.compress(&u, &y, threads)?.to_bytes())
}

/// The piece of the samples of `first` followed by those of `second`.
#[pyfunction]
pub fn partial_append<'py>(
    py: Python<'py>,
    first: &[u8],
    second: &[u8],
) -> PyResult<Bound<'py, PyBytes>> {
    let (a, b) = (first.to_vec(), second.to_vec());
    bytes_of(py, move || {
        RecordPiece::from_bytes(&a)?
            .append(RecordPiece::from_bytes(&b)?)?
            .to_bytes()
    })
}

/// Closes a piece holding a whole record into compressed records.
#[pyfunction]
pub fn partial_close<'py>(py: Python<'py>, piece: &[u8]) -> PyResult<Bound<'py, PyBytes>> {
    let a = piece.to_vec();
    bytes_of(py, move || RecordPiece::from_bytes(&a)?.close()?.to_bytes())
}

/// The compressed records of `first` and `second` together.
#[pyfunction]
pub fn partial_merge<'py>(
    py: Python<'py>,
    first: &[u8],
    second: &[u8],
) -> PyResult<Bound<'py, PyBytes>> {
    let (a, b) = (first.to_vec(), second.to_vec());
    bytes_of(py, move || {
        CompressedRecords::from_bytes(&a)?
            .merge(CompressedRecords::from_bytes(&b)?)?
            .to_bytes()
    })
}

/// Appends samples of the current record to a regression stream's state;
/// returns the new state.
#[pyfunction]
pub fn regression_push<'py>(
    py: Python<'py>,
    stream: &[u8],
    u: Bound<'py, PyAny>,
    y: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyBytes>> {
    let s = stream.to_vec();
    let (u, y) = (record(&u, "u")?, output_record(&y, "y")?);
    bytes_of(py, move || {
        let mut st = OutputErrorStream::from_bytes(&s)?;
        st.push(&u, &y)?;
        st.to_bytes()
    })
}

/// One step on a regression stream's state with a block of samples.
fn stream_step<'py>(
    py: Python<'py>,
    stream: &[u8],
    u: Bound<'py, PyAny>,
    y: Bound<'py, PyAny>,
    step: fn(
        &mut OutputErrorStream,
        &nalgebra::DMatrix<f64>,
        &nalgebra::DMatrix<f64>,
    ) -> lifted_subspace::Result<()>,
) -> PyResult<Bound<'py, PyBytes>> {
    let s = stream.to_vec();
    let (u, y) = (record(&u, "u")?, output_record(&y, "y")?);
    bytes_of(py, move || {
        let mut st = OutputErrorStream::from_bytes(&s)?;
        step(&mut st, &u, &y)?;
        st.to_bytes()
    })
}

/// Fixes a regression stream's data scale from the first samples of the
/// record (before a parallel second pass).
#[pyfunction]
pub fn regression_prime<'py>(
    py: Python<'py>,
    stream: &[u8],
    u: Bound<'py, PyAny>,
    y: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyBytes>> {
    stream_step(py, stream, u, y, OutputErrorStream::prime)
}

/// Moves a regression stream's recursions over a shard without its rows:
/// the state at the start of the next shard.
#[pyfunction]
pub fn regression_advance<'py>(
    py: Python<'py>,
    stream: &[u8],
    u: Bound<'py, PyAny>,
    y: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyBytes>> {
    stream_step(py, stream, u, y, OutputErrorStream::advance)
}

/// The rows of a shard scanned from the stream state at its start (bytes
/// of a regression piece).
#[pyfunction]
pub fn regression_scan<'py>(
    py: Python<'py>,
    stream: &[u8],
    u: Bound<'py, PyAny>,
    y: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyBytes>> {
    let s = stream.to_vec();
    let (u, y) = (record(&u, "u")?, output_record(&y, "y")?);
    bytes_of(py, move || {
        OutputErrorStream::from_bytes(&s)?
            .scan_apart(&u, &y)?
            .to_bytes()
    })
}

/// Two regression pieces together.
#[pyfunction]
pub fn regression_merge<'py>(
    py: Python<'py>,
    first: &[u8],
    second: &[u8],
) -> PyResult<Bound<'py, PyBytes>> {
    let (a, b) = (first.to_vec(), second.to_vec());
    bytes_of(py, move || {
        RegressionPiece::from_bytes(&a)?
            .merge(RegressionPiece::from_bytes(&b)?)?
            .to_bytes()
    })
}

/// A regression stream's state with the rows of a (merged) piece added.
#[pyfunction]
pub fn regression_absorb<'py>(
    py: Python<'py>,
    stream: &[u8],
    piece: &[u8],
) -> PyResult<Bound<'py, PyBytes>> {
    let (s, p) = (stream.to_vec(), piece.to_vec());
    bytes_of(py, move || {
        let mut st = OutputErrorStream::from_bytes(&s)?;
        st.absorb(RegressionPiece::from_bytes(&p)?)?;
        st.to_bytes()
    })
}

/// Ends the current record of a regression stream's state.
#[pyfunction]
pub fn regression_end_record<'py>(py: Python<'py>, stream: &[u8]) -> PyResult<Bound<'py, PyBytes>> {
    let s = stream.to_vec();
    bytes_of(py, move || {
        let mut st = OutputErrorStream::from_bytes(&s)?;
        st.end_record()?;
        st.to_bytes()
    })
}

/// The first pass of a sharded identification (held by the client): the
/// model from the merged compressed records, and the second pass's
/// regression stream for the output-error (B, D, x₀).
#[pyclass(name = "FirstPass", module = "lifted._lifted")]
pub struct PyFirstPass {
    inner: Option<StreamedSubspace>,
    method: String,
}

/// First pass of the identification from merged compressed records.
#[pyfunction]
#[pyo3(signature = (records, method="n4sid", order=None, max_order=10, past=10, future=10,
    remove_means=true, noise_model=true, dt=1.0, threads=1))]
#[allow(clippy::too_many_arguments)]
pub fn partial_identify(
    py: Python<'_>,
    records: &[u8],
    method: &str,
    #[pyo3(from_py_with = opt_int)] order: Option<Int>,
    #[pyo3(from_py_with = int)] max_order: Int,
    #[pyo3(from_py_with = int)] past: Int,
    #[pyo3(from_py_with = int)] future: Int,
    remove_means: bool,
    noise_model: bool,
    dt: f64,
    #[pyo3(from_py_with = int)] threads: Int,
) -> PyResult<PyFirstPass> {
    let opts = options(
        method,
        order,
        max_order,
        past,
        future,
        remove_means,
        noise_model,
        dt,
        threads,
    )?;
    let c = records.to_vec();
    let first = py
        .detach(move || CompressedRecords::from_bytes(&c)?.identify(&opts))
        .map_err(err)?;
    Ok(PyFirstPass {
        inner: Some(first),
        method: method.to_ascii_lowercase(),
    })
}

impl PyFirstPass {
    fn get(&self) -> PyResult<&StreamedSubspace> {
        self.inner
            .as_ref()
            .ok_or_else(|| lifted_error("this first pass was already finished"))
    }
}

#[pymethods]
impl PyFirstPass {
    /// Whether the options ask for the second pass (output-error (B, D, x₀)).
    fn wants_second_pass(&self) -> PyResult<bool> {
        Ok(self.get()?.wants_second_pass())
    }

    /// The empty regression stream of the second pass (bytes).
    fn regression<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let bytes = self
            .get()?
            .regression()
            .and_then(|s| s.to_bytes())
            .map_err(err)?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// The identified model: with `stream` (the regression state after the
    /// second pass over every record) the output-error (B, D, x₀), else the
    /// one-pass model; with `input_scales`/`output_scales` (the records were
    /// divided by them, `channel_scales`) brought back to the data's units.
    /// Returns the dict of `identify`.
    #[pyo3(signature = (stream=None, input_scales=None, output_scales=None))]
    fn finish<'py>(
        &mut self,
        py: Python<'py>,
        stream: Option<&[u8]>,
        input_scales: Option<Vec<f64>>,
        output_scales: Option<Vec<f64>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let first = self
            .inner
            .take()
            .ok_or_else(|| lifted_error("this first pass was already finished"))?;
        let stream = stream.map(<[u8]>::to_vec);
        let fit = py
            .detach(move || match stream {
                Some(s) => first.finish(OutputErrorStream::from_bytes(&s)?),
                None => Ok(first.into_model()),
            })
            .map_err(err)?;
        let mut fit = fit;
        if input_scales.is_some() || output_scales.is_some() {
            let sc = lifted_workflow::ChannelScales {
                u: input_scales.unwrap_or_else(|| vec![1.0; fit.model.n_inputs()]),
                y: output_scales.unwrap_or_else(|| vec![1.0; fit.model.n_outputs()]),
            };
            if sc.u.len() != fit.model.n_inputs() || sc.y.len() != fit.model.n_outputs() {
                return Err(lifted_error(format!(
                    "channel scales: {} input and {} output scales for a model of {} inputs and {} outputs",
                    sc.u.len(),
                    sc.y.len(),
                    fit.model.n_inputs(),
                    fit.model.n_outputs()
                )));
            }
            if sc
                .u
                .iter()
                .chain(&sc.y)
                .any(|s| !(s.is_finite() && *s > 0.0))
            {
                return Err(lifted_error("channel scales must be finite and positive"));
            }
            fit.model = sc
                .model(&fit.model)
                .map_err(|e| lifted_error(e.to_string()))?;
            fit.kalman_gain = fit.kalman_gain.map(|k| sc.gain(&k));
            fit.operating_point = fit.operating_point.map(|op| sc.operating_point(&op));
        }
        let threads = fit.diagnostics.compression.threads;
        crate::identify::fit_dict(py, &fit, &self.method, threads)
    }
}

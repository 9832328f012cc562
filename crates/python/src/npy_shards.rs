//! `.npy` shards of `lifted.dask`'s sharded engine read in Rust by the
//! command's reader (`lifted_data::npy::scan_blocks`: column blocks decoded
//! in one strided loop each, every value checked finite, messages naming
//! the file and the row), divided by the record's channel scales on the
//! way and pushed block by block to the compression or the regression
//! (`lifted_subspace::PieceStream`, `ShardScan`): one read of a shard per
//! pass, no numpy copy, O(rows × channels) time and one block in memory.

use lifted_subspace::{CompressionPlan, OutputErrorStream};
use nalgebra::DMatrix;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

use crate::convert::{Int, count, counts, ints};
use crate::errors::{LiftedError, err};

/// Rows per block of the reader (4 MiB of columns at 4 channels).
const BLOCK_ROWS: usize = 1 << 17;

/// Where the columns of a shard are and what they are divided by.
struct Columns {
    inputs: Vec<usize>,
    outputs: Vec<usize>,
    input_scales: Vec<f64>,
    output_scales: Vec<f64>,
}

impl Columns {
    fn new(
        inputs: Vec<Int>,
        outputs: Vec<Int>,
        input_scales: Vec<f64>,
        output_scales: Vec<f64>,
    ) -> PyResult<Self> {
        let (inputs, outputs) = (counts(&inputs, "inputs")?, counts(&outputs, "outputs")?);
        if inputs.is_empty() || outputs.is_empty() {
            return Err(LiftedError::new_err(
                "a shard needs at least one input and one output column",
            ));
        }
        for (scales, cols, name) in [
            (&input_scales, &inputs, "input_scales"),
            (&output_scales, &outputs, "output_scales"),
        ] {
            if scales.len() != cols.len() || scales.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
                return Err(LiftedError::new_err(format!(
                    "{name}: one positive finite scale per column ({} columns), got {scales:?}",
                    cols.len()
                )));
            }
        }
        Ok(Columns {
            inputs,
            outputs,
            input_scales,
            output_scales,
        })
    }

    /// Feeds the shard to `push` in blocks of up to [`BLOCK_ROWS`] rows,
    /// (u, y) scaled, in order; stops at the first error (the reader's or
    /// `push`'s). O(rows × channels) time, O(block) memory.
    fn feed(
        &self,
        path: &str,
        mut push: impl FnMut(&DMatrix<f64>, &DMatrix<f64>) -> PyResult<()>,
    ) -> PyResult<()> {
        let names: Vec<String> = self
            .inputs
            .iter()
            .chain(&self.outputs)
            .map(|c| format!("c{c}"))
            .collect();
        let wanted: Vec<&String> = names.iter().collect();
        let divide = |m: &mut DMatrix<f64>, scales: &[f64]| {
            for (mut col, s) in m.column_iter_mut().zip(scales) {
                let inv = 1.0 / s;
                col.iter_mut().for_each(|v| *v *= inv);
            }
        };
        // The base period is the engine's (no time column in an array).
        let read = lifted_data::npy::scan_record_blocks(
            path,
            &[],
            &wanted,
            self.inputs.len(),
            0..0,
            Some(1.0),
            BLOCK_ROWS,
            |u, y| {
                divide(u, &self.input_scales);
                divide(y, &self.output_scales);
                push(u, y).map(|()| true)
            },
        );
        match read {
            Ok(_) => Ok(()),
            Err(lifted_data::npy::BlockStop::Visit(e)) => Err(e),
            Err(lifted_data::npy::BlockStop::Read(e)) => Err(err(e)),
        }
    }
}

/// Compresses a `.npy` shard (the columns `inputs`, `outputs`, divided by
/// the scales) with `plan`; returns the piece's bytes
/// (`partial_compress` on the shard read in Rust).
#[pyfunction]
#[pyo3(signature = (plan, path, inputs, outputs, input_scales, output_scales, threads=1))]
#[allow(clippy::too_many_arguments)]
pub fn partial_compress_npy<'py>(
    py: Python<'py>,
    plan: &[u8],
    path: &str,
    #[pyo3(from_py_with = ints)] inputs: Vec<Int>,
    #[pyo3(from_py_with = ints)] outputs: Vec<Int>,
    input_scales: Vec<f64>,
    output_scales: Vec<f64>,
    #[pyo3(from_py_with = crate::convert::int)] threads: Int,
) -> PyResult<Bound<'py, PyBytes>> {
    let plan = CompressionPlan::from_bytes(plan).map_err(err)?;
    let threads = lifted_linalg::budget::resolve_threads(count(threads, "threads")?);
    let cols = Columns::new(inputs, outputs, input_scales, output_scales)?;
    let bytes = py.detach(|| -> PyResult<Vec<u8>> {
        let mut stream = plan.stream(threads);
        cols.feed(path, |u, y| stream.push(u, y).map_err(err))?;
        stream.finish().and_then(|p| p.to_bytes()).map_err(err)
    })?;
    Ok(PyBytes::new(py, &bytes))
}

/// The regression rows of a `.npy` shard scanned from the stream state at
/// its start (`regression_scan` on the shard read in Rust); with
/// `advance=True`, the state moved over the shard instead
/// (`regression_advance`).
#[pyfunction]
#[pyo3(signature = (stream, path, inputs, outputs, input_scales, output_scales, advance=false))]
#[allow(clippy::too_many_arguments)]
pub fn regression_npy<'py>(
    py: Python<'py>,
    stream: &[u8],
    path: &str,
    #[pyo3(from_py_with = ints)] inputs: Vec<Int>,
    #[pyo3(from_py_with = ints)] outputs: Vec<Int>,
    input_scales: Vec<f64>,
    output_scales: Vec<f64>,
    advance: bool,
) -> PyResult<Bound<'py, PyBytes>> {
    let cols = Columns::new(inputs, outputs, input_scales, output_scales)?;
    let bytes = py.detach(|| -> PyResult<Vec<u8>> {
        let mut st = OutputErrorStream::from_bytes(stream).map_err(err)?;
        if advance {
            cols.feed(path, |u, y| st.advance(u, y).map_err(err))?;
            return st.to_bytes().map_err(err);
        }
        let mut scan = st.shard_scan().map_err(err)?;
        cols.feed(path, |u, y| scan.push(u, y).map_err(err))?;
        scan.finish().and_then(|p| p.to_bytes()).map_err(err)
    })?;
    Ok(PyBytes::new(py, &bytes))
}

/// Samples after which a primed regression stream has forgotten its state
/// (`OutputErrorStream::memory`): a shard's starting state is then the
/// primed state advanced over that many samples before it; `None` when the
/// shards must be chained.
#[pyfunction]
pub fn regression_memory(stream: &[u8]) -> PyResult<Option<usize>> {
    Ok(OutputErrorStream::from_bytes(stream).map_err(err)?.memory())
}

//! Python bindings of Lifted: the extension module `lifted._lifted`, wrapped
//! by the pure-Python package `lifted` (`python/lifted/`).
//!
//! Every function converts numpy arrays (samples × channels, float64) to
//! `nalgebra` matrices, calls the Lifted crates' public API with the
//! interpreter lock released (`Python::detach`), and maps every Rust error to
//! [`LiftedError`] (a subclass of Python's `ValueError`) carrying the Rust
//! message. No numerics live here: conversions only (O(N·channels) copies).
//!
//! The crate is built by maturin (`pip install ./crates/python`), which
//! enables the `extension-module` feature; without it (plain `cargo build`,
//! `cargo clippy`) pyo3 links libpython instead, so the workspace commands
//! work on a machine without maturin. See the crate README.

mod distributed;
mod routes;
mod validation;

use lifted_lti::{C2dMethod, C2dOptions, ModelFile, StateSpace};
use lifted_mpc::{
    Constraints, Controller as MpcController, Dmc, LoopSetup, MpcOptions, StateSpaceMpc,
};
use lifted_prbs::{
    DesignRequest, GbnOptions, InversePrbs, InversePrbsOptions, MSequence, MultisineOptions,
    RandomBinaryOptions,
};
use lifted_sim::{
    Controller, Delays, Excitation, Feedback, NoiseSpec, Plant, SimOutput, Simulator,
};
use lifted_subspace::{Experiment, Method, OrderSelection, SubspaceOptions, SystemEstimate};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

create_exception!(
    _lifted,
    LiftedError,
    PyValueError,
    "Error raised by the Lifted library (bad input or a failed computation); the message is the Rust error's."
);

/// Maps any Lifted error to [`LiftedError`] with its display text.
pub(crate) fn err<E: std::fmt::Display>(e: E) -> PyErr {
    LiftedError::new_err(e.to_string())
}

/// numpy (row-major) → nalgebra (column-major), O(r·c).
pub(crate) fn to_mat(a: &PyReadonlyArray2<'_, f64>) -> DMatrix<f64> {
    let v = a.as_array();
    let (r, c) = v.dim();
    DMatrix::from_fn(r, c, |i, j| v[[i, j]])
}

/// nalgebra → numpy, O(r·c).
pub(crate) fn to_py<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]).into_pyarray(py)
}

/// A list of N×p matrices (one per input, or per frequency) → one 3-D array.
fn stack<'py, T: numpy::Element + Copy + nalgebra::Scalar>(
    py: Python<'py>,
    ms: &[DMatrix<T>],
    rows: usize,
    cols: usize,
) -> Bound<'py, PyArray3<T>> {
    Array3::from_shape_fn((ms.len(), rows, cols), |(k, i, j)| ms[k][(i, j)]).into_pyarray(py)
}

/// The subspace weighting named `name` (n4sid, moesp, cva; any case).
pub(crate) fn subspace_method(name: &str) -> PyResult<Method> {
    match name.to_ascii_lowercase().as_str() {
        "n4sid" => Ok(Method::N4sid),
        "moesp" => Ok(Method::Moesp),
        "cva" => Ok(Method::Cva),
        other => Err(LiftedError::new_err(format!(
            "unknown subspace method '{other}' (n4sid, moesp, cva)"
        ))),
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
        return Err(LiftedError::new_err(format!(
            "{} holds for {nu} inputs and {} periods for {ny} outputs",
            holds.map_or(nu, <[usize]>::len),
            periods.map_or(ny, <[usize]>::len)
        )));
    }
    let inputs = (0..nu)
        .map(|i| lifted_lti::InputChannel::new(format!("u{}", i + 1), holds.map_or(1, |h| h[i])))
        .collect();
    let outputs = (0..ny)
        .map(|i| {
            lifted_lti::OutputChannel::new(format!("y{}", i + 1), periods.map_or(1, |p| p[i]), 0)
        })
        .collect();
    lifted_lti::Dataset::new(dt, u, y, inputs, outputs).map_err(err)
}

/// A linear time-invariant model (A, B, C, D, dt) in state space; `dt` is
/// None for continuous time, the sample period in seconds otherwise.
#[pyclass(name = "StateSpace", module = "lifted._lifted", frozen, from_py_object)]
#[derive(Clone)]
pub struct PyStateSpace {
    inner: StateSpace,
}

impl PyStateSpace {
    pub(crate) fn wrap(inner: StateSpace) -> Self {
        Self { inner }
    }
}

#[pymethods]
impl PyStateSpace {
    /// StateSpace(A, B, C, D, dt=None): validated (shapes, finite entries,
    /// positive finite dt).
    #[new]
    #[pyo3(signature = (a, b, c, d, dt=None))]
    fn new(
        a: PyReadonlyArray2<'_, f64>,
        b: PyReadonlyArray2<'_, f64>,
        c: PyReadonlyArray2<'_, f64>,
        d: PyReadonlyArray2<'_, f64>,
        dt: Option<f64>,
    ) -> PyResult<Self> {
        StateSpace::new(to_mat(&a), to_mat(&b), to_mat(&c), to_mat(&d), dt)
            .map(Self::wrap)
            .map_err(err)
    }

    /// State matrix A (n×n).
    #[getter(A)]
    fn a<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        to_py(py, self.inner.a())
    }
    /// Input matrix B (n×m).
    #[getter(B)]
    fn b<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        to_py(py, self.inner.b())
    }
    /// Output matrix C (p×n).
    #[getter(C)]
    fn c<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        to_py(py, self.inner.c())
    }
    /// Feedthrough D (p×m).
    #[getter(D)]
    fn d<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        to_py(py, self.inner.d())
    }
    /// Sample period in seconds, None for continuous time.
    #[getter]
    fn dt(&self) -> Option<f64> {
        self.inner.ts()
    }
    /// Number of states.
    #[getter]
    fn nstates(&self) -> usize {
        self.inner.a().nrows()
    }
    /// Number of inputs.
    #[getter]
    fn ninputs(&self) -> usize {
        self.inner.b().ncols()
    }
    /// Number of outputs.
    #[getter]
    fn noutputs(&self) -> usize {
        self.inner.c().nrows()
    }

    /// Eigenvalues of A (complex array), O(n³).
    fn poles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<Complex64>>> {
        let s = self.inner.clone();
        let p = py.detach(move || s.poles()).map_err(err)?;
        Ok(PyArray1::from_vec(py, p))
    }

    /// Transmission zeros (complex array), O(n³).
    fn zeros<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<Complex64>>> {
        let s = self.inner.clone();
        let z = py.detach(move || s.zeros()).map_err(err)?;
        Ok(PyArray1::from_vec(py, z))
    }

    /// Steady-state gain (p×m).
    fn dcgain<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let g = self.inner.dc_gain().map_err(err)?;
        Ok(to_py(py, &g))
    }

    /// True when every pole is inside the stability region by `margin`.
    #[pyo3(signature = (margin=0.0))]
    fn is_stable(&self, margin: f64) -> PyResult<bool> {
        self.inner.is_stable(margin).map_err(err)
    }

    /// Frequency response at `omega` (rad/s): complex array (len(omega), p, m).
    fn freqresp<'py>(
        &self,
        py: Python<'py>,
        omega: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<Bound<'py, PyArray3<Complex64>>> {
        let w = omega.as_array().to_vec();
        let s = self.inner.clone();
        let h = py.detach(move || s.freqresp(&w)).map_err(err)?;
        let (p, m) = (self.inner.c().nrows(), self.inner.b().ncols());
        Ok(stack(py, &h, p, m))
    }

    /// Unit-step responses: array (m, n_samples, p), one N×p block per input.
    /// Continuous models are sampled every `dt`.
    #[pyo3(signature = (n_samples, dt=None))]
    fn step<'py>(
        &self,
        py: Python<'py>,
        n_samples: usize,
        dt: Option<f64>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let s = self.inner.clone();
        let r = py.detach(move || s.step(n_samples, dt)).map_err(err)?;
        Ok(stack(py, &r, n_samples, self.inner.c().nrows()))
    }

    /// Simulates the input `u` (N×m) from `x0` (zeros when None); returns
    /// (y N×p, x N×n). Continuous models need `dt` (input held over dt).
    #[pyo3(signature = (u, x0=None, dt=None))]
    #[allow(clippy::type_complexity)]
    fn lsim<'py>(
        &self,
        py: Python<'py>,
        u: PyReadonlyArray2<'_, f64>,
        x0: Option<PyReadonlyArray1<'_, f64>>,
        dt: Option<f64>,
    ) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>)> {
        let u = to_mat(&u);
        let x0 = x0.map(|x| DVector::from_vec(x.as_array().to_vec()));
        let s = self.inner.clone();
        let r = py
            .detach(move || s.lsim(&u, x0.as_ref(), dt))
            .map_err(err)?;
        Ok((to_py(py, &r.y), to_py(py, &r.x)))
    }

    /// Continuous → discrete with period `dt`: method "zoh" (default),
    /// "foh" or "tustin" (optional `prewarp` in rad/s); `input_delays` in
    /// seconds, one per input (ZOH only).
    #[pyo3(signature = (dt, method="zoh", prewarp=None, input_delays=None))]
    fn c2d(
        &self,
        py: Python<'_>,
        dt: f64,
        method: &str,
        prewarp: Option<f64>,
        input_delays: Option<Vec<f64>>,
    ) -> PyResult<Self> {
        let method = match method.to_ascii_lowercase().as_str() {
            "zoh" => C2dMethod::Zoh,
            "foh" => C2dMethod::Foh,
            "tustin" | "bilinear" => C2dMethod::Tustin { prewarp },
            other => {
                return Err(LiftedError::new_err(format!(
                    "unknown c2d method '{other}' (zoh, foh, tustin)"
                )));
            }
        };
        let opts = C2dOptions {
            method,
            input_delays,
        };
        let s = self.inner.clone();
        py.detach(move || s.c2d(dt, &opts))
            .map(Self::wrap)
            .map_err(err)
    }

    /// Discrete → continuous (inverse ZOH by the principal matrix logarithm).
    fn d2c(&self, py: Python<'_>) -> PyResult<Self> {
        let s = self.inner.clone();
        py.detach(move || s.d2c()).map(Self::wrap).map_err(err)
    }

    /// The CLI's model-file JSON (lifted_lti::ModelFile) of this model.
    #[pyo3(signature = (method=None))]
    fn to_json(&self, method: Option<String>) -> PyResult<String> {
        let mut f = ModelFile::new(self.inner.clone());
        if let Some(m) = method {
            f = f.with_method(m);
        }
        f.to_json().map_err(err)
    }

    /// The model of a CLI model file (JSON text, as written by `lifted identify`).
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        ModelFile::from_json(text)
            .map(|f| Self::wrap(f.model))
            .map_err(err)
    }

    fn __repr__(&self) -> String {
        format!(
            "StateSpace(nstates={}, ninputs={}, noutputs={}, dt={:?})",
            self.nstates(),
            self.ninputs(),
            self.noutputs(),
            self.inner.ts()
        )
    }

    fn __str__(&self) -> String {
        format!("{}", self.inner)
    }

    fn __eq__(&self, other: &Self) -> bool {
        self.inner == other.inner
    }
}

/// Maximum-length PRBS of shift-register order `order` mapped to ±amplitude,
/// each bit held `hold` samples, `periods` periods, the register advanced by
/// `seed mod period` first (same signal as `lifted signal prbs`). O(length).
#[pyfunction]
#[pyo3(signature = (order, amplitude=1.0, hold=1, periods=1, seed=0))]
fn prbs<'py>(
    py: Python<'py>,
    order: u32,
    amplitude: f64,
    hold: usize,
    periods: usize,
    seed: u64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    // Validate through the inverse-PRBS options (order, amplitude, hold), as the CLI.
    InversePrbs::new(&InversePrbsOptions {
        order,
        amplitude,
        hold,
        taps: None,
    })
    .map_err(err)?;
    if periods == 0 {
        return Err(LiftedError::new_err("prbs periods must be at least 1"));
    }
    let mut seq = MSequence::new(order).map_err(err)?;
    let m = seq.period();
    let len = (m as u128) * (hold as u128) * (periods as u128);
    if len > lifted_prbs::MAX_SIGNAL_ENTRIES {
        return Err(LiftedError::new_err(format!(
            "prbs of {len} samples exceeds the in-memory limit {}",
            lifted_prbs::MAX_SIGNAL_ENTRIES
        )));
    }
    let len = len as usize;
    seq.advance(seed % m);
    let mut w = Vec::with_capacity(len);
    while w.len() < len {
        let v = if seq.next_bit() == 1 {
            amplitude
        } else {
            -amplitude
        };
        let take = (len - w.len()).min(hold);
        w.extend(std::iter::repeat_n(v, take));
    }
    Ok(PyArray1::from_vec(py, w))
}

/// Inverse PRBS (Zhu 2000 eq. II-4) held `hold` samples: `periods` periods
/// of 2·hold·m samples, started `seed mod period` samples in (as
/// `lifted prbs --inverse`). O(length).
#[pyfunction]
#[pyo3(signature = (order, amplitude=1.0, hold=1, periods=1, seed=0))]
fn inverse_prbs<'py>(
    py: Python<'py>,
    order: u32,
    amplitude: f64,
    hold: usize,
    periods: usize,
    seed: u64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let p = InversePrbs::new(&InversePrbsOptions {
        order,
        amplitude,
        hold,
        taps: None,
    })
    .map_err(err)?;
    if periods == 0 {
        return Err(LiftedError::new_err(
            "inverse_prbs periods must be at least 1",
        ));
    }
    let len = (p.period() as u128) * (periods as u128);
    if len > lifted_prbs::MAX_SIGNAL_ENTRIES {
        return Err(LiftedError::new_err(format!(
            "inverse_prbs of {len} samples exceeds the in-memory limit {}",
            lifted_prbs::MAX_SIGNAL_ENTRIES
        )));
    }
    let shift = (seed % p.period()) as usize;
    let w: Vec<f64> = py.detach(move || p.iter().skip(shift).take(len as usize).collect());
    Ok(PyArray1::from_vec(py, w))
}

/// PRBS design (lifted_prbs::design, Zhu 2000 §III.D): proposes (order,
/// hold, amplitude) from the plant's time scales and the actuator rate.
/// Keyword defaults are `DesignRequest`'s (Table II). Returns a dict of the
/// `DesignProposal` fields.
#[pyfunction]
#[pyo3(signature = (output_period=0.01, actuator_rate_hz=30.0, actuator_margin=3.0,
    slowest_mode_hz=0.025, amplitude=1.0, min_order=2))]
fn design<'py>(
    py: Python<'py>,
    output_period: f64,
    actuator_rate_hz: f64,
    actuator_margin: f64,
    slowest_mode_hz: f64,
    amplitude: f64,
    min_order: u32,
) -> PyResult<Bound<'py, PyDict>> {
    let p = lifted_prbs::design(&DesignRequest {
        output_period,
        actuator_rate_hz,
        actuator_margin,
        slowest_mode_hz,
        amplitude,
        min_order,
    })
    .map_err(err)?;
    let out = PyDict::new(py);
    out.set_item("order", p.order)?;
    out.set_item("m", p.m)?;
    out.set_item("hold", p.hold)?;
    out.set_item("amplitude", p.amplitude)?;
    out.set_item("output_period", p.output_period)?;
    out.set_item("generation_period", p.generation_period)?;
    out.set_item("period_samples", p.period_samples)?;
    out.set_item("record_length_s", p.record_length_s)?;
    out.set_item("fundamental_hz", p.fundamental_hz)?;
    out.set_item("band_high_hz", p.band_high_hz)?;
    out.set_item("hold_null_hz", p.hold_null_hz)?;
    out.set_item("explanation", p.explanation)?;
    Ok(out)
}

/// Random binary signal ±amplitude held `hold` samples (lifted_prbs::random_binary).
#[pyfunction]
#[pyo3(signature = (n, amplitude=1.0, hold=1, seed=0))]
fn rbs<'py>(
    py: Python<'py>,
    n: usize,
    amplitude: f64,
    hold: usize,
    seed: u64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let o = RandomBinaryOptions {
        amplitude,
        hold,
        seed,
    };
    let v = py
        .detach(move || lifted_prbs::random_binary(n, &o))
        .map_err(err)?;
    Ok(PyArray1::from_vec(py, v))
}

/// Generalized binary noise (lifted_prbs::generalized_binary_noise).
#[pyfunction]
#[pyo3(signature = (n, amplitude=1.0, switch_probability=0.5, hold=1, seed=0))]
fn gbn<'py>(
    py: Python<'py>,
    n: usize,
    amplitude: f64,
    switch_probability: f64,
    hold: usize,
    seed: u64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let o = GbnOptions {
        amplitude,
        switch_probability,
        hold,
        seed,
    };
    let v = py
        .detach(move || lifted_prbs::generalized_binary_noise(n, &o))
        .map_err(err)?;
    Ok(PyArray1::from_vec(py, v))
}

/// Periodic multisine of RMS `amplitude` (lifted_prbs::multisine).
#[pyfunction]
#[pyo3(signature = (n, amplitude=1.0, period=1024, first_harmonic=1, last_harmonic=None))]
fn multisine<'py>(
    py: Python<'py>,
    n: usize,
    amplitude: f64,
    period: usize,
    first_harmonic: usize,
    last_harmonic: Option<usize>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let o = MultisineOptions {
        amplitude,
        period,
        first_harmonic,
        last_harmonic,
    };
    let v = py
        .detach(move || lifted_prbs::multisine(n, &o))
        .map_err(err)?;
    Ok(PyArray1::from_vec(py, v))
}

/// Subspace identification (lifted_subspace::identify) from one or several
/// records. Keyword defaults are those of `SubspaceOptions`. Returns a dict:
/// model, kalman_gain, x0, u0/y0 (means removed), singular_values, order,
/// suggested_order, method, model_json (the CLI's model file). `system`:
/// None (the library's default `SystemEstimate`), "shift" or "states".
#[pyfunction]
#[pyo3(signature = (us, ys, method="n4sid", order=None, max_order=10, past=10, future=10,
    remove_means=true, noise_model=true, enforce_stability=false, dt=1.0, threads=1, system=None))]
#[allow(clippy::too_many_arguments)]
fn identify<'py>(
    py: Python<'py>,
    us: Vec<PyReadonlyArray2<'py, f64>>,
    ys: Vec<PyReadonlyArray2<'py, f64>>,
    method: &str,
    order: Option<usize>,
    max_order: usize,
    past: usize,
    future: usize,
    remove_means: bool,
    noise_model: bool,
    enforce_stability: bool,
    dt: f64,
    threads: usize,
    system: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let system = match system.map(str::to_ascii_lowercase).as_deref() {
        None => SystemEstimate::default(),
        Some("shift" | "shift_invariance") => SystemEstimate::ShiftInvariance,
        Some("states" | "state_sequence") => SystemEstimate::StateSequence,
        Some(other) => {
            return Err(LiftedError::new_err(format!(
                "unknown system estimate '{other}' (shift, states)"
            )));
        }
    };
    let method = subspace_method(method)?;
    if us.len() != ys.len() {
        return Err(LiftedError::new_err(format!(
            "{} input records but {} output records",
            us.len(),
            ys.len()
        )));
    }
    let u: Vec<DMatrix<f64>> = us.iter().map(to_mat).collect();
    let y: Vec<DMatrix<f64>> = ys.iter().map(to_mat).collect();
    let opts = SubspaceOptions {
        method,
        order: match order {
            Some(n) => OrderSelection::Fixed(n),
            None => OrderSelection::Gap { max: max_order },
        },
        past,
        future,
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
    // The CLI's method names (`lifted identify --method`), lower case.
    fit_dict(py, &fit, &method.name().to_ascii_lowercase())
}

/// The dict `identify` returns for a subspace fit.
pub(crate) fn fit_dict<'py>(
    py: Python<'py>,
    fit: &lifted_subspace::SubspaceModel,
    method_name: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let mut file = ModelFile::new(fit.model.clone()).with_method(method_name);
    if let Some(op) = &fit.operating_point {
        file = file.with_operating_point(op.clone()).map_err(err)?;
    }
    if let Some(k) = &fit.kalman_gain {
        file = file.with_kalman_gain(k).map_err(err)?;
    }
    let out = PyDict::new(py);
    out.set_item("model", PyStateSpace::wrap(fit.model.clone()))?;
    out.set_item(
        "kalman_gain",
        fit.kalman_gain.as_ref().map(|k| to_py(py, k)),
    )?;
    let x0: Vec<Vec<f64>> = fit.x0.iter().map(|x| x.as_slice().to_vec()).collect();
    out.set_item("x0", x0)?;
    out.set_item("u0", fit.operating_point.as_ref().map(|o| o.u0.clone()))?;
    out.set_item("y0", fit.operating_point.as_ref().map(|o| o.y0.clone()))?;
    out.set_item("singular_values", fit.diagnostics.singular_values.clone())?;
    out.set_item("order", fit.diagnostics.order)?;
    out.set_item("suggested_order", fit.diagnostics.suggested_order)?;
    out.set_item("method", method_name)?;
    out.set_item("model_json", file.to_json().map_err(err)?)?;
    Ok(out)
}

/// Simulates an experiment with lifted_sim::Simulator: open loop (`r` is the
/// plant input) or closed loop with a discrete `controller` at the plant's
/// period (`r` is the setpoint r₁ when `reference`, else an input
/// disturbance r₂ added to the controller output); `feedback` "fast" or
/// "hold_last"; per-output `sampling` periods in base periods (offset 0) and
/// per-input `holds`; seeded white output noise at a variance `snr`. A
/// continuous plant is discretised by ZOH at `dt` (without `dt` it is an error). Returns a dict with `u`,
/// `y` (measured outputs, NaN where a channel does not sample), `y_fast`
/// (every fast sample) and `y_clean` (without the added noise). O(N·states).
#[pyfunction]
#[pyo3(signature = (plant, r, controller=None, reference=true, feedback="fast", sampling=None,
    holds=None, snr=None, seed=0, dt=None))]
#[allow(clippy::too_many_arguments)]
fn simulate_experiment<'py>(
    py: Python<'py>,
    plant: &PyStateSpace,
    r: PyReadonlyArray2<'py, f64>,
    controller: Option<&PyStateSpace>,
    reference: bool,
    feedback: &str,
    sampling: Option<Vec<usize>>,
    holds: Option<Vec<usize>>,
    snr: Option<f64>,
    seed: u64,
    dt: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let feedback = match feedback.to_ascii_lowercase().as_str() {
        "fast" => Feedback::Fast,
        "hold_last" | "holdlast" => Feedback::HoldLast,
        other => {
            return Err(LiftedError::new_err(format!(
                "unknown feedback '{other}' (fast, hold_last)"
            )));
        }
    };
    let g = plant.inner.clone();
    let k = controller.map(|c| c.inner.clone());
    let r = to_mat(&r);
    let out = py
        .detach(move || -> Result<SimOutput, lifted_sim::Error> {
            let plant = match dt {
                Some(ts) if !g.is_discrete() => Plant::continuous(&g, ts, &Delays::default())?,
                _ => Plant::discrete(&g, &[], &[])?,
            };
            let (mut sim, exc) = match &k {
                Some(k) => {
                    let sim = Simulator::closed_loop(plant, Controller::from_ss(k)?)?
                        .with_feedback(feedback)?;
                    let exc = if reference {
                        Excitation::reference(r)
                    } else {
                        Excitation::input(r)
                    };
                    (sim, exc)
                }
                None => (Simulator::open_loop(plant), Excitation::input(r)),
            };
            if let Some(h) = &holds {
                sim = sim.with_holds(h)?;
            }
            if let Some(periods) = &sampling {
                let pairs: Vec<(usize, usize)> = periods.iter().map(|&p| (p, 0)).collect();
                sim = sim.with_sampling(&pairs)?;
            }
            if let Some(snr) = snr {
                sim = sim.with_noise(NoiseSpec::white_snr(snr, seed))?;
            }
            sim.simulate(&exc)
        })
        .map_err(err)?;
    let d = PyDict::new(py);
    d.set_item("u", to_py(py, out.data.u()))?;
    d.set_item("y", to_py(py, out.data.y()))?;
    d.set_item("y_fast", to_py(py, &out.y))?;
    d.set_item("y_clean", to_py(py, &out.y_clean))?;
    Ok(d)
}

/// The two receding-horizon laws of lifted-mpc.
enum Law {
    Dmc(Box<Dmc>),
    Gpc(Box<StateSpaceMpc>),
}

impl Law {
    fn controller(&mut self) -> &mut dyn MpcController {
        match self {
            Law::Dmc(c) => c.as_mut(),
            Law::Gpc(c) => c.as_mut(),
        }
    }
}

/// Receding-horizon controller of lifted-mpc: DMC on the step-response
/// coefficients ([`Dmc`], `kind="dmc"`, truncation N ≥ h) or the same law on
/// the state-space realisation ([`StateSpaceMpc`], `kind="gpc"`). Keyword
/// defaults are `MpcOptions`' (h = 12, m = 3, identity weights, no limits).
/// Dual-rate inferential MPC: pass None (or NaN) for an output that is not
/// sampled at this instant.
#[pyclass(name = "Mpc", module = "lifted._lifted")]
pub struct PyMpc {
    law: Law,
}

/// An optional 1-D numpy array as a vector.
fn opt_vec(a: Option<PyReadonlyArray1<'_, f64>>) -> Option<DVector<f64>> {
    a.map(|a| DVector::from_vec(a.as_array().to_vec()))
}

#[pymethods]
impl PyMpc {
    /// Mpc(model, kind="gpc", prediction_horizon=12, control_horizon=3,
    /// output_weight=None, move_weight=None, truncation=None (DMC: 4·h),
    /// u_min=None, u_max=None, du_max=None, y_min=None, y_max=None).
    #[new]
    #[pyo3(signature = (model, kind="gpc", prediction_horizon=12, control_horizon=3,
        output_weight=None, move_weight=None, truncation=None, u_min=None, u_max=None,
        du_max=None, y_min=None, y_max=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: &PyStateSpace,
        kind: &str,
        prediction_horizon: usize,
        control_horizon: usize,
        output_weight: Option<PyReadonlyArray2<'_, f64>>,
        move_weight: Option<PyReadonlyArray2<'_, f64>>,
        truncation: Option<usize>,
        u_min: Option<PyReadonlyArray1<'_, f64>>,
        u_max: Option<PyReadonlyArray1<'_, f64>>,
        du_max: Option<PyReadonlyArray1<'_, f64>>,
        y_min: Option<PyReadonlyArray1<'_, f64>>,
        y_max: Option<PyReadonlyArray1<'_, f64>>,
    ) -> PyResult<Self> {
        let opts = MpcOptions {
            prediction_horizon,
            control_horizon,
            output_weight: output_weight.as_ref().map(to_mat),
            move_weight: move_weight.as_ref().map(to_mat),
            constraints: Constraints {
                u_min: opt_vec(u_min),
                u_max: opt_vec(u_max),
                du_max: opt_vec(du_max),
                y_min: opt_vec(y_min),
                y_max: opt_vec(y_max),
            },
        };
        let law = match kind.to_ascii_lowercase().as_str() {
            "dmc" => {
                let n = truncation.unwrap_or(4 * prediction_horizon);
                Law::Dmc(Box::new(Dmc::new(&model.inner, n, &opts).map_err(err)?))
            }
            "gpc" | "ss" | "statespace" => Law::Gpc(Box::new(
                StateSpaceMpc::new(&model.inner, &opts).map_err(err)?,
            )),
            other => {
                return Err(LiftedError::new_err(format!(
                    "unknown MPC kind '{other}' (dmc, gpc)"
                )));
            }
        };
        Ok(Self { law })
    }

    /// One update: `measured` has one entry per output, None (or NaN) when
    /// the output is not sampled now; `reference` the set-point. Returns u(t).
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        measured: Vec<Option<f64>>,
        reference: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let measured: Vec<Option<f64>> = measured
            .into_iter()
            .map(|v| v.filter(|x| !x.is_nan()))
            .collect();
        let r = DVector::from_vec(reference.as_array().to_vec());
        let u = self.law.controller().update(&measured, &r).map_err(err)?;
        Ok(PyArray1::from_vec(py, u.as_slice().to_vec()))
    }

    /// Closed loop of `plant` under this controller (lifted_mpc::simulate):
    /// set-point `reference` (N×p), output sampling `periods` per output
    /// (default every sample; > 1 is inferential MPC). Returns a dict `y`,
    /// `u`, `iae`, `overshoot`, `settling_time`, `input_energy`.
    #[pyo3(signature = (plant, reference, periods=None))]
    fn simulate<'py>(
        &mut self,
        py: Python<'py>,
        plant: &PyStateSpace,
        reference: PyReadonlyArray2<'_, f64>,
        periods: Option<Vec<usize>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let r = to_mat(&reference);
        let periods = periods.unwrap_or_else(|| vec![1; r.ncols()]);
        let setup = LoopSetup::new(r, periods);
        let run = lifted_mpc::simulate(&plant.inner, self.law.controller(), &setup).map_err(err)?;
        let d = PyDict::new(py);
        d.set_item("y", to_py(py, &run.y))?;
        d.set_item("u", to_py(py, &run.u))?;
        d.set_item("iae", run.performance.iae.clone())?;
        d.set_item("overshoot", run.performance.overshoot.clone())?;
        d.set_item("settling_time", run.performance.settling_time.clone())?;
        d.set_item("input_energy", run.performance.input_energy)?;
        Ok(d)
    }
}

/// The extension module `lifted._lifted`.
#[pymodule]
fn _lifted(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("LiftedError", m.py().get_type::<LiftedError>())?;
    m.add_class::<PyStateSpace>()?;
    m.add_class::<PyMpc>()?;
    m.add_function(wrap_pyfunction!(routes::iv, m)?)?;
    m.add_function(wrap_pyfunction!(routes::qmarkov, m)?)?;
    m.add_function(wrap_pyfunction!(routes::multirate, m)?)?;
    m.add_function(wrap_pyfunction!(validation::validate, m)?)?;
    m.add_function(wrap_pyfunction!(prbs, m)?)?;
    m.add_function(wrap_pyfunction!(inverse_prbs, m)?)?;
    m.add_function(wrap_pyfunction!(design, m)?)?;
    m.add_function(wrap_pyfunction!(rbs, m)?)?;
    m.add_function(wrap_pyfunction!(gbn, m)?)?;
    m.add_function(wrap_pyfunction!(multisine, m)?)?;
    m.add_function(wrap_pyfunction!(identify, m)?)?;
    m.add_function(wrap_pyfunction!(simulate_experiment, m)?)?;
    m.add_class::<distributed::PyFirstPass>()?;
    m.add_function(wrap_pyfunction!(distributed::partial_plan, m)?)?;
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
    Ok(())
}

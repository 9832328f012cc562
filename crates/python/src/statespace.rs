//! `StateSpace`: a linear time-invariant model with the two things an
//! identification estimates next to (A, B, C, D): the operating point
//! (u₀, y₀) it is linearised about and the Kalman predictor gain K of its
//! innovations form x(k+1) = A x + B u + K e. The same content as the CLI's
//! model file (`lifted_lti::ModelFile`), which is also its pickled form.

use lifted_linalg::budget::Size;
use lifted_lti::{C2dOptions, ModelFile, OperatingPoint, StateSpace};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use numpy::{PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::{PyFloat, PyTuple};

use crate::choices::{Choice, Discretization};
use crate::convert::{Int, Vector, budget, count, int, matrix, record, vector};
use crate::errors::err;
use crate::{stack, to_py};

/// A linear time-invariant model (A, B, C, D, dt); `dt` is None for
/// continuous time, the sample period in seconds otherwise. An identified
/// model also carries its operating point (`u0`, `y0`: it maps u − u₀ to
/// y − y₀) and its Kalman predictor gain (`kalman_gain`, n × p).
#[pyclass(name = "StateSpace", module = "lifted._lifted", frozen, from_py_object)]
#[derive(Clone)]
pub struct PyStateSpace {
    pub(crate) inner: StateSpace,
    pub(crate) operating_point: Option<OperatingPoint>,
    pub(crate) kalman_gain: Option<DMatrix<f64>>,
    /// The output periods the Kalman gain was estimated with (an
    /// identification's `diagnostics.output_periods`): `validate` leaves
    /// the gain out on a record sampled otherwise
    /// (`lifted_workflow::gain_mismatch`, the command line's rule).
    pub(crate) gain_periods: Option<Vec<usize>>,
}

impl PyStateSpace {
    /// A model without operating point or gain.
    pub(crate) fn wrap(inner: StateSpace) -> Self {
        Self {
            inner,
            operating_point: None,
            kalman_gain: None,
            gain_periods: None,
        }
    }

    /// A model with its operating point and Kalman gain, both checked
    /// against its dimensions (as the model file does).
    pub(crate) fn with_parts(
        inner: StateSpace,
        operating_point: Option<OperatingPoint>,
        kalman_gain: Option<DMatrix<f64>>,
    ) -> PyResult<Self> {
        let s = Self {
            inner,
            operating_point,
            kalman_gain,
            gain_periods: None,
        };
        s.model_file(None)?;
        Ok(s)
    }

    /// The model file of this model (validates the operating point and gain).
    pub(crate) fn model_file(&self, method: Option<&str>) -> PyResult<ModelFile> {
        let mut f = ModelFile::new(self.inner.clone());
        if let Some(m) = method {
            f = f.with_method(m);
        }
        if let Some(op) = &self.operating_point {
            let op = OperatingPoint::new(op.u0.clone(), op.y0.clone()).map_err(err)?;
            f = f.with_operating_point(op).map_err(err)?;
        }
        if let Some(k) = &self.kalman_gain {
            f = f.with_kalman_gain(k).map_err(err)?;
            if let Some(p) = &self.gain_periods {
                f.diagnostics = serde_json::json!({ "output_periods": p });
            }
        }
        Ok(f)
    }

    /// The model-file JSON with `method`.
    pub(crate) fn to_json_with(&self, method: Option<&str>) -> PyResult<String> {
        self.model_file(method)?.to_json().map_err(err)
    }

    pub(crate) fn from_file(f: ModelFile) -> Self {
        let kalman_gain = f.kalman_gain_matrix();
        let gain_periods = lifted_workflow::gain_periods(&f);
        Self {
            inner: f.model,
            operating_point: f.operating_point,
            kalman_gain,
            gain_periods,
        }
    }

    /// The operating point given by `u0`/`y0` (a missing one is zeros).
    pub(crate) fn operating_point_of(
        &self,
        u0: Option<&Bound<'_, PyAny>>,
        y0: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Option<OperatingPoint>> {
        if u0.is_none() && y0.is_none() {
            return Ok(None);
        }
        let (nu, ny) = (self.inner.n_inputs(), self.inner.n_outputs());
        let u0 = u0.map(|v| vector(v, "u0")).transpose()?;
        let y0 = y0.map(|v| vector(v, "y0")).transpose()?;
        let op = OperatingPoint::new(
            u0.unwrap_or_else(|| vec![0.0; nu]),
            y0.unwrap_or_else(|| vec![0.0; ny]),
        )
        .map_err(err)?;
        op.check_dims(nu, ny).map_err(err)?;
        Ok(Some(op))
    }

    /// The response to `u` (plant values when the model has an operating
    /// point: y = y₀ + G(u − u₀)); (y, x).
    pub(crate) fn respond(
        &self,
        py: Python<'_>,
        u: DMatrix<f64>,
        x0: Option<DVector<f64>>,
        dt: Option<f64>,
    ) -> PyResult<(DMatrix<f64>, DMatrix<f64>)> {
        let s = self.inner.clone();
        let op = self.operating_point.clone();
        py.detach(move || -> Result<_, lifted_lti::Error> {
            let du = match &op {
                Some(op) => op.remove_input(&u)?,
                None => u,
            };
            let r = s.lsim(&du, x0.as_ref(), dt)?;
            let y = match &op {
                Some(op) => op.add_output(&r.y)?,
                None => r.y,
            };
            Ok((y, r.x))
        })
        .map_err(err)
    }
}

#[pymethods]
impl PyStateSpace {
    /// StateSpace(A, B, C, D, dt=None, *, u0=None, y0=None, kalman_gain=None):
    /// validated (shapes, finite entries, positive finite dt). Matrices are
    /// anything numpy reads; as in python-control a scalar A is 1×1, a 1-D B
    /// of length n is a column, a 1-D C of length n a row, and a scalar D is
    /// broadcast to p × m.
    #[new]
    #[pyo3(signature = (a, b, c, d, dt=None, *, u0=None, y0=None, kalman_gain=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        a: &Bound<'_, PyAny>,
        b: &Bound<'_, PyAny>,
        c: &Bound<'_, PyAny>,
        d: &Bound<'_, PyAny>,
        dt: Option<f64>,
        u0: Option<&Bound<'_, PyAny>>,
        y0: Option<&Bound<'_, PyAny>>,
        kalman_gain: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let a = matrix(a, "A", Vector::Row, None)?;
        let n = a.nrows();
        let b_len = vector_len(b);
        let b = matrix(
            b,
            "B",
            if b_len == Some(n) {
                Vector::Column
            } else {
                Vector::Row
            },
            None,
        )?;
        let c_len = vector_len(c);
        let c = matrix(
            c,
            "C",
            if c_len == Some(n) {
                Vector::Row
            } else {
                Vector::Column
            },
            None,
        )?;
        let (p, m) = (c.nrows(), b.ncols());
        let d = matrix(
            d,
            "D",
            if m == 1 && p > 1 {
                Vector::Column
            } else {
                Vector::Row
            },
            Some((p, m)),
        )?;
        let inner = StateSpace::new(a, b, c, d, dt).map_err(err)?;
        let mut s = Self::wrap(inner);
        s.operating_point = s.operating_point_of(u0, y0)?;
        s.kalman_gain = kalman_gain
            .map(|k| matrix(k, "kalman_gain", Vector::Column, None))
            .transpose()?;
        s.model_file(None)?;
        Ok(s)
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
        self.inner.order()
    }
    /// Number of inputs.
    #[getter]
    fn ninputs(&self) -> usize {
        self.inner.n_inputs()
    }
    /// Number of outputs.
    #[getter]
    fn noutputs(&self) -> usize {
        self.inner.n_outputs()
    }
    /// Input offsets u₀ of the operating point (None: no operating point).
    #[getter]
    fn u0<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.operating_point
            .as_ref()
            .map(|op| PyArray1::from_slice(py, &op.u0))
    }
    /// Output offsets y₀ of the operating point (None: no operating point).
    #[getter]
    fn y0<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.operating_point
            .as_ref()
            .map(|op| PyArray1::from_slice(py, &op.y0))
    }
    /// Kalman predictor gain K (n×p) of the innovations form, None if not
    /// estimated.
    #[getter]
    fn kalman_gain<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.kalman_gain.as_ref().map(|k| to_py(py, k))
    }

    /// This model with the operating point (u0, y0) (a missing one is
    /// zeros; both None removes it).
    #[pyo3(signature = (u0=None, y0=None))]
    fn with_operating_point(
        &self,
        u0: Option<&Bound<'_, PyAny>>,
        y0: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let mut s = self.clone();
        s.operating_point = self.operating_point_of(u0, y0)?;
        Ok(s)
    }

    /// This model with the Kalman gain `kalman_gain` (n×p; None removes it).
    #[pyo3(signature = (kalman_gain=None))]
    fn with_kalman_gain(&self, kalman_gain: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        let mut s = self.clone();
        s.kalman_gain = kalman_gain
            .map(|k| matrix(k, "kalman_gain", Vector::Column, None))
            .transpose()?;
        // A gain given here: its sampling is not known.
        s.gain_periods = None;
        s.model_file(None)?;
        Ok(s)
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

    /// Steady-state gain (p×m) of the deviation model, O(n³).
    fn dcgain<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let s = self.inner.clone();
        let g = py.detach(move || s.dc_gain()).map_err(err)?;
        Ok(to_py(py, &g))
    }

    /// True when every pole is inside the stability region by `margin`, O(n³).
    #[pyo3(signature = (margin=0.0))]
    fn is_stable(&self, py: Python<'_>, margin: f64) -> PyResult<bool> {
        let s = self.inner.clone();
        py.detach(move || s.is_stable(margin)).map_err(err)
    }

    /// Frequency response at `omega` (rad/s): complex array (len(omega), p, m).
    /// A discrete model's frequencies are at most the Nyquist frequency π/T
    /// (above it the response repeats that of an alias, as `lifted bode`
    /// refuses too).
    fn freqresp<'py>(
        &self,
        py: Python<'py>,
        omega: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray3<Complex64>>> {
        let w = vector(omega, "omega")?;
        if let Some(ts) = self.inner.ts() {
            let nyquist = std::f64::consts::PI / ts;
            if let Some(bad) = w.iter().find(|&&v| v.abs() > nyquist * (1.0 + 1e-12)) {
                return Err(crate::errors::arg_error(
                    "omega",
                    format!(
                        "{bad} rad/s is above the Nyquist frequency π/T = {nyquist:.6} rad/s of \
                         the discrete model (T = {ts} s): its response there repeats that of an \
                         alias below π/T"
                    ),
                ));
            }
        }
        let s = self.inner.clone();
        let h = py.detach(move || s.freqresp(&w)).map_err(err)?;
        let (p, m) = (self.inner.n_outputs(), self.inner.n_inputs());
        Ok(stack(py, &h, p, m))
    }

    /// Unit-step responses of the deviation model: array (m, n_samples, p),
    /// one N×p block per input. Continuous models are sampled every `dt`.
    #[pyo3(signature = (n_samples, dt=None))]
    fn step<'py>(
        &self,
        py: Python<'py>,
        #[pyo3(from_py_with = int)] n_samples: Int,
        dt: Option<f64>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let n = count(n_samples, "n_samples")?;
        let (p, m, states) = (
            self.inner.n_outputs(),
            self.inner.n_inputs(),
            self.inner.order(),
        );
        // m responses of n × p, and the n × states trajectory of each run
        budget(
            "the step responses (n_samples x outputs x inputs)",
            Size::matrices(m.max(1), n, p + states),
        )?;
        let s = self.inner.clone();
        let r = py.detach(move || s.step(n, dt)).map_err(err)?;
        Ok(stack(py, &r, n, self.inner.n_outputs()))
    }

    /// Simulates the input `u` (N×m, a 1-D array is one input) from `x0`
    /// (zeros when None); returns (y N×p, x N×n). With an operating point
    /// `u` and `y` are plant values: y = y₀ + G(u − u₀). Continuous models
    /// need `dt` (input held over dt).
    #[pyo3(signature = (u, x0=None, dt=None))]
    #[allow(clippy::type_complexity)]
    fn lsim<'py>(
        &self,
        py: Python<'py>,
        u: &Bound<'py, PyAny>,
        x0: Option<&Bound<'py, PyAny>>,
        dt: Option<f64>,
    ) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>)> {
        let u = record(u, "u")?;
        let x0 = x0
            .map(|x| vector(x, "x0").map(DVector::from_vec))
            .transpose()?;
        let (y, x) = self.respond(py, u, x0, dt)?;
        Ok((to_py(py, &y), to_py(py, &x)))
    }

    /// Continuous → discrete with period `dt`: method "zoh" (default),
    /// "foh" or "tustin" (optional `prewarp` in rad/s); `input_delays` in
    /// seconds, one per input (ZOH only). The operating point is kept; a
    /// Kalman gain (a discrete-time quantity) is not.
    #[pyo3(signature = (dt, method="zoh", prewarp=None, input_delays=None))]
    fn c2d(
        &self,
        py: Python<'_>,
        dt: f64,
        method: &str,
        prewarp: Option<f64>,
        input_delays: Option<Vec<f64>>,
    ) -> PyResult<Self> {
        let opts = C2dOptions {
            method: Discretization::parse(method, "method")?.method(prewarp),
            input_delays,
        };
        let s = self.inner.clone();
        let g = py.detach(move || s.c2d(dt, &opts)).map_err(err)?;
        Self::with_parts(g, self.operating_point.clone(), None)
    }

    /// Discrete → continuous (inverse ZOH by the principal matrix
    /// logarithm: it returns the plant of `c2d(dt, "zoh")`, not of a Tustin
    /// or other discretisation). The operating point is kept, the Kalman
    /// gain is not.
    fn d2c(&self, py: Python<'_>) -> PyResult<Self> {
        let s = self.inner.clone();
        let g = py.detach(move || s.d2c()).map_err(err)?;
        Self::with_parts(g, self.operating_point.clone(), None)
    }

    /// The CLI's model-file JSON (lifted_lti::ModelFile) of this model,
    /// with its operating point and Kalman gain.
    #[pyo3(signature = (method=None))]
    fn to_json(&self, method: Option<&str>) -> PyResult<String> {
        self.to_json_with(method)
    }

    /// The model of a CLI model file (JSON text, as written by `lifted
    /// identify`), with its operating point and Kalman gain.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        ModelFile::from_json(text).map(Self::from_file).map_err(err)
    }

    /// Pickles as the model-file JSON: (StateSpace.from_json, (json,)).
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let rebuild = py.get_type::<PyStateSpace>().getattr("from_json")?;
        let json = self.to_json_with(None)?;
        PyTuple::new(py, [rebuild, PyTuple::new(py, [json])?.into_any()])
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let dt = match self.inner.ts() {
            Some(t) => PyFloat::new(py, t).repr()?.to_string(),
            None => "None".to_string(),
        };
        let mut s = format!(
            "StateSpace(n={}, m={}, p={}, dt={dt}",
            self.inner.order(),
            self.inner.n_inputs(),
            self.inner.n_outputs()
        );
        if let Some(op) = &self.operating_point {
            let list = |v: &[f64]| -> PyResult<String> {
                Ok(pyo3::types::PyList::new(py, v)?.repr()?.to_string())
            };
            s += &format!(", u0={}, y0={}", list(&op.u0)?, list(&op.y0)?);
        }
        if self.kalman_gain.is_some() {
            s += ", kalman_gain=...";
        }
        s.push(')');
        Ok(s)
    }

    fn __str__(&self) -> String {
        format!("{}", self.inner)
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        match other.extract::<PyRef<'_, PyStateSpace>>() {
            Ok(o) => {
                self.inner == o.inner
                    && self.operating_point == o.operating_point
                    && self.kalman_gain == o.kalman_gain
            }
            Err(_) => false,
        }
    }
}

/// The length of a 1-D array argument (None for anything else).
fn vector_len(obj: &Bound<'_, PyAny>) -> Option<usize> {
    let np = obj.py().import("numpy").ok()?;
    let shape: Vec<usize> = np.call_method1("shape", (obj,)).ok()?.extract().ok()?;
    match shape.as_slice() {
        [k] => Some(*k),
        _ => None,
    }
}

//! Binding of lifted-mpc: the receding-horizon controller (DMC or
//! state-space MPC) and its closed-loop simulation. `step` and `simulate`
//! run with the GIL released.

use lifted_lti::OperatingPoint;
use lifted_mpc::{
    Constraints, Controller as MpcController, Dmc, LoopSetup, MpcOptions, StateSpaceMpc,
};
use nalgebra::{DMatrix, DVector};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::choices::{Choice, MpcKind};
use crate::convert::{
    Int, Vector, count, counts, int, matrix, opt_count, opt_dvector, opt_int, opt_ints, record,
    vector,
};
use crate::errors::err;
use crate::statespace::PyStateSpace;
use crate::to_py;

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
/// coefficients (`Dmc`, `kind="dmc"`, truncation N ≥ h) or the same law on
/// the state-space realisation (`StateSpaceMpc`, `kind="gpc"`). Keyword
/// defaults are `MpcOptions`' (h = 12, m = 3, identity weights, no limits).
/// Dual-rate inferential MPC: pass None (or NaN) for an output that is not
/// sampled at this instant. With a model that has an operating point (an
/// identified one), measurements, set-points, limits and moves are plant
/// values: the law runs on y − y₀ and returns u₀ + its move, as the model
/// maps u − u₀ to y − y₀.
#[pyclass(name = "Mpc", module = "lifted._lifted")]
pub struct PyMpc {
    law: Law,
    operating_point: Option<OperatingPoint>,
}

/// `v − offsets` when the lengths agree (a length the law rejects is left
/// for its dimension check).
fn less(v: Option<DVector<f64>>, offsets: Option<&[f64]>) -> Option<DVector<f64>> {
    match (v, offsets) {
        (Some(v), Some(o)) if v.len() == o.len() => Some(v - DVector::from_column_slice(o)),
        (v, _) => v,
    }
}

/// Adds `sign · offsets[c]` to column c (columns beyond the offsets, which
/// the law has rejected by then, are left alone).
fn shift(m: &mut DMatrix<f64>, offsets: &[f64], sign: f64) {
    for (mut col, o) in m.column_iter_mut().zip(offsets) {
        col.add_scalar_mut(sign * o);
    }
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
        py: Python<'_>,
        model: &PyStateSpace,
        kind: &str,
        #[pyo3(from_py_with = int)] prediction_horizon: Int,
        #[pyo3(from_py_with = int)] control_horizon: Int,
        output_weight: Option<&Bound<'_, PyAny>>,
        move_weight: Option<&Bound<'_, PyAny>>,
        #[pyo3(from_py_with = opt_int)] truncation: Option<Int>,
        u_min: Option<&Bound<'_, PyAny>>,
        u_max: Option<&Bound<'_, PyAny>>,
        du_max: Option<&Bound<'_, PyAny>>,
        y_min: Option<&Bound<'_, PyAny>>,
        y_max: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let kind = MpcKind::parse(kind, "kind")?;
        let op = model.operating_point.clone();
        let (u0, y0) = (
            op.as_ref().map(|o| o.u0.as_slice()),
            op.as_ref().map(|o| o.y0.as_slice()),
        );
        let prediction_horizon = count(prediction_horizon, "prediction_horizon")?;
        let weight = |w: Option<&Bound<'_, PyAny>>, name: &str| {
            w.map(|w| matrix(w, name, Vector::Row, None)).transpose()
        };
        let opts = MpcOptions {
            prediction_horizon,
            control_horizon: count(control_horizon, "control_horizon")?,
            output_weight: weight(output_weight, "output_weight")?,
            move_weight: weight(move_weight, "move_weight")?,
            constraints: Constraints {
                u_min: less(opt_dvector(u_min, "u_min")?, u0),
                u_max: less(opt_dvector(u_max, "u_max")?, u0),
                du_max: opt_dvector(du_max, "du_max")?,
                y_min: less(opt_dvector(y_min, "y_min")?, y0),
                y_max: less(opt_dvector(y_max, "y_max")?, y0),
            },
        };
        let truncation = opt_count(truncation, "truncation")?;
        let g = model.inner.clone();
        let law = py
            .detach(move || -> Result<Law, lifted_mpc::Error> {
                Ok(match kind {
                    MpcKind::Dmc => {
                        let n = truncation.unwrap_or(4 * prediction_horizon);
                        Law::Dmc(Box::new(Dmc::new(&g, n, &opts)?))
                    }
                    MpcKind::Gpc => Law::Gpc(Box::new(StateSpaceMpc::new(&g, &opts)?)),
                })
            })
            .map_err(err)?;
        Ok(Self {
            law,
            operating_point: op,
        })
    }

    /// One update: `measured` has one entry per output, None (or NaN) when
    /// the output is not sampled now (one output: a number or None will
    /// do); `reference` the set-point. Returns u(t).
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        measured: &Bound<'py, PyAny>,
        reference: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, numpy::PyArray1<f64>>> {
        let measured: Vec<Option<f64>> = if measured.is_none() {
            vec![None]
        } else if let Ok(v) = measured.extract::<Vec<Option<f64>>>() {
            v
        } else {
            vec![Some(measured.extract::<f64>().map_err(|_| {
                crate::errors::arg_error(
                    "measured",
                    "must be a sequence with one number (or None: not sampled now) per output, \
                     or one number or None for one output",
                )
            })?)]
        };
        let y0 = self.operating_point.as_ref().map(|o| o.y0.as_slice());
        let measured: Vec<Option<f64>> = measured
            .into_iter()
            .enumerate()
            .map(|(q, v)| {
                let off = y0.and_then(|y0| y0.get(q)).copied().unwrap_or(0.0);
                v.filter(|x| !x.is_nan()).map(|x| x - off)
            })
            .collect();
        let r = DVector::from_vec(vector(reference, "reference")?);
        let r = less(Some(r), y0).unwrap_or_default();
        let law = &mut self.law;
        let mut u = py
            .detach(move || law.controller().update(&measured, &r))
            .map_err(err)?;
        if let Some(op) = &self.operating_point
            && op.u0.len() == u.len()
        {
            u += DVector::from_column_slice(&op.u0);
        }
        Ok(numpy::PyArray1::from_vec(py, u.as_slice().to_vec()))
    }

    /// Closed loop of `plant` under this controller (lifted_mpc::simulate):
    /// set-point `reference` (N×p, a 1-D array for one output), output
    /// sampling `periods` per output (default every sample; > 1 is
    /// inferential MPC). The loop starts at rest, at the operating point of
    /// the controller's model when it has one (then `reference`, `y` and `u`
    /// are plant values; `plant` is simulated as the deviation model).
    /// Returns a dict `y`, `u`, `iae`, `overshoot`, `settling_time`,
    /// `input_energy` (Σ‖u − u₀‖²).
    #[pyo3(signature = (plant, reference, periods=None))]
    fn simulate<'py>(
        &mut self,
        py: Python<'py>,
        plant: &PyStateSpace,
        reference: &Bound<'py, PyAny>,
        #[pyo3(from_py_with = opt_ints)] periods: Option<Vec<Int>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let mut r = record(reference, "reference")?;
        if let Some(op) = &self.operating_point {
            shift(&mut r, &op.y0, -1.0);
        }
        let periods = match periods {
            Some(p) => counts(&p, "periods")?,
            None => vec![1; r.ncols()],
        };
        let setup = LoopSetup::new(r, periods);
        let g = plant.inner.clone();
        let law = &mut self.law;
        let run = py
            .detach(move || lifted_mpc::simulate(&g, law.controller(), &setup))
            .map_err(err)?;
        let (mut y, mut u) = (run.y, run.u);
        if let Some(op) = &self.operating_point {
            shift(&mut y, &op.y0, 1.0);
            shift(&mut u, &op.u0, 1.0);
        }
        let d = PyDict::new(py);
        d.set_item("y", to_py(py, &y))?;
        d.set_item("u", to_py(py, &u))?;
        d.set_item("iae", run.performance.iae.clone())?;
        d.set_item("overshoot", run.performance.overshoot.clone())?;
        d.set_item("settling_time", run.performance.settling_time.clone())?;
        d.set_item("input_energy", run.performance.input_energy)?;
        Ok(d)
    }
}

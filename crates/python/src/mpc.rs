//! Binding of lifted-mpc: the receding-horizon controller (DMC or
//! state-space MPC) and its closed-loop simulation. `step` and `simulate`
//! run with the GIL released.

use lifted_mpc::{
    Constraints, Controller as MpcController, Dmc, LoopSetup, MpcOptions, StateSpaceMpc,
};
use nalgebra::DVector;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::choices::{Choice, MpcKind};
use crate::convert::{Int, Vector, count, counts, matrix, opt_count, opt_dvector, record, vector};
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
/// sampled at this instant. The controller works in deviation variables:
/// an identified model's operating point is not applied (measurements and
/// set-points are y − y₀, the moves u − u₀).
#[pyclass(name = "Mpc", module = "lifted._lifted")]
pub struct PyMpc {
    law: Law,
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
        prediction_horizon: Int,
        control_horizon: Int,
        output_weight: Option<&Bound<'_, PyAny>>,
        move_weight: Option<&Bound<'_, PyAny>>,
        truncation: Option<Int>,
        u_min: Option<&Bound<'_, PyAny>>,
        u_max: Option<&Bound<'_, PyAny>>,
        du_max: Option<&Bound<'_, PyAny>>,
        y_min: Option<&Bound<'_, PyAny>>,
        y_max: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let kind = MpcKind::parse(kind, "kind")?;
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
                u_min: opt_dvector(u_min, "u_min")?,
                u_max: opt_dvector(u_max, "u_max")?,
                du_max: opt_dvector(du_max, "du_max")?,
                y_min: opt_dvector(y_min, "y_min")?,
                y_max: opt_dvector(y_max, "y_max")?,
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
        Ok(Self { law })
    }

    /// One update: `measured` has one entry per output, None (or NaN) when
    /// the output is not sampled now; `reference` the set-point. Returns u(t).
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        measured: Vec<Option<f64>>,
        reference: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, numpy::PyArray1<f64>>> {
        let measured: Vec<Option<f64>> = measured
            .into_iter()
            .map(|v| v.filter(|x| !x.is_nan()))
            .collect();
        let r = DVector::from_vec(vector(reference, "reference")?);
        let law = &mut self.law;
        let u = py
            .detach(move || law.controller().update(&measured, &r))
            .map_err(err)?;
        Ok(numpy::PyArray1::from_vec(py, u.as_slice().to_vec()))
    }

    /// Closed loop of `plant` under this controller (lifted_mpc::simulate):
    /// set-point `reference` (N×p, a 1-D array for one output), output
    /// sampling `periods` per output (default every sample; > 1 is
    /// inferential MPC). Returns a dict `y`, `u`, `iae`, `overshoot`,
    /// `settling_time`, `input_energy`.
    #[pyo3(signature = (plant, reference, periods=None))]
    fn simulate<'py>(
        &mut self,
        py: Python<'py>,
        plant: &PyStateSpace,
        reference: &Bound<'py, PyAny>,
        periods: Option<Vec<Int>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let r = record(reference, "reference")?;
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

//! Binding of `lifted_sim::Simulator`: open- and closed-loop multirate
//! experiments. A plant with an operating point is simulated in deviations
//! and its signals are returned in plant values, as `lifted simulate` does.

use lifted_sim::{
    Controller, Delays, Excitation, Feedback, NoiseSpec, Plant, SimOutput, Simulator,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::choices::Choice;
use crate::convert::{Int, counts, int, opt_ints, record, seed as seed_of};
use crate::errors::{arg_error, err};
use crate::statespace::PyStateSpace;
use crate::to_py;

/// Simulates an experiment with lifted_sim::Simulator: open loop (`r` is the
/// plant input) or closed loop with a discrete `controller` at the plant's
/// period (`r` is the setpoint r₁ when `reference`, else an input
/// disturbance r₂ added to the controller output); `feedback` "fast" or
/// "hold_last"; per-output `sampling` periods in base periods (offset 0) and
/// per-input `holds`; seeded white output noise at a variance `snr`. A
/// continuous plant is discretised by ZOH at `dt` (without `dt` it is an
/// error). With an operating point the plant input r (open loop), the
/// set-point and the returned u and y are plant values. Returns a dict with
/// `u`, `y` (measured outputs, NaN where a channel does not sample),
/// `y_fast` (every fast sample) and `y_clean` (without the added noise).
/// O(N·states).
#[pyfunction]
#[pyo3(signature = (plant, r, controller=None, reference=true, feedback="fast", sampling=None,
    holds=None, snr=None, seed=0, dt=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn simulate_experiment<'py>(
    py: Python<'py>,
    plant: &PyStateSpace,
    r: &Bound<'py, PyAny>,
    controller: Option<&PyStateSpace>,
    reference: bool,
    feedback: &str,
    #[pyo3(from_py_with = opt_ints)] sampling: Option<Vec<Int>>,
    #[pyo3(from_py_with = opt_ints)] holds: Option<Vec<Int>>,
    snr: Option<f64>,
    #[pyo3(from_py_with = int)] seed: Int,
    dt: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let feedback = Feedback::parse(feedback, "feedback")?;
    let sampling = sampling.map(|s| counts(&s, "sampling")).transpose()?;
    let holds = holds.map(|h| counts(&h, "holds")).transpose()?;
    let seed = seed_of(seed, "seed")?;
    let r = record(r, "r")?;
    check_frame(
        r.nrows(),
        holds.as_deref(),
        sampling.as_deref(),
        plant.inner.ts().or(dt),
        controller.and_then(|c| c.inner.ts()),
    )?;
    let g = plant.inner.clone();
    let op = plant.operating_point.clone();
    let k = controller.map(|c| c.inner.clone());
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
                        let r = match &op {
                            Some(op) => shift_columns(r, &op.y0, -1.0)?,
                            None => r,
                        };
                        Excitation::reference(r)
                    } else {
                        Excitation::input(r)
                    };
                    (sim, exc)
                }
                None => {
                    let r = match &op {
                        Some(op) => op.remove_input(&r)?,
                        None => r,
                    };
                    (Simulator::open_loop(plant), Excitation::input(r))
                }
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
            let mut out = sim.simulate(&exc)?;
            if let Some(op) = &op {
                out.data = out.data.shifted(&op.u0, &op.y0)?;
                out.y = op.add_output(&out.y)?;
                out.y_clean = op.add_output(&out.y_clean)?;
            }
            Ok(out)
        })
        .map_err(err)?;
    let d = PyDict::new(py);
    d.set_item("u", to_py(py, out.data.u()))?;
    d.set_item("y", to_py(py, out.data.y()))?;
    d.set_item("y_fast", to_py(py, &out.y))?;
    d.set_item("y_clean", to_py(py, &out.y_clean))?;
    Ok(d)
}

/// Longest sampling pattern accepted whatever the record length (2²⁰
/// phases).
const MAX_FRAME: usize = 1 << 20;

/// The simulator tabulates its sampling pattern, one entry per phase of
/// the least common multiple of the holds, the output periods and the
/// controller's rate (lifted_sim's `Engine`), before it checks anything
/// else; a pattern longer than both the record and [`MAX_FRAME`] is refused
/// here, so that e.g. `holds=[2**40]` is an error and not an abort of the
/// interpreter on a failed allocation.
fn check_frame(
    samples: usize,
    holds: Option<&[usize]>,
    sampling: Option<&[usize]>,
    base: Option<f64>,
    controller: Option<f64>,
) -> PyResult<()> {
    let rate = match (base, controller) {
        // the controller runs every round(T_K / T) base periods; lifted-sim
        // rejects a ratio that is not an integer
        (Some(t), Some(tk)) if t > 0.0 && (tk / t).is_finite() => (tk / t).round().max(1.0),
        _ => 1.0,
    };
    let limit = samples.max(MAX_FRAME);
    if rate > limit as f64 {
        return Err(arg_error(
            "controller",
            format!(
                "runs every {rate} base periods, a pattern longer than the record ({samples} samples) and than {MAX_FRAME}"
            ),
        ));
    }
    let mut frame = rate as usize;
    let all = holds
        .unwrap_or_default()
        .iter()
        .map(|&h| ("holds", h))
        .chain(
            sampling
                .unwrap_or_default()
                .iter()
                .map(|&p| ("sampling", p)),
        );
    for (name, v) in all {
        if v == 0 {
            continue; // lifted-sim names the zero hold or period
        }
        frame = frame
            .checked_div(gcd(frame, v))
            .and_then(|f| f.checked_mul(v))
            .filter(|&f| f <= limit)
            .ok_or_else(|| {
                arg_error(
                    name,
                    format!(
                        "the holds, sampling periods and controller rate repeat only every \
                         lcm > {limit} samples, longer than the record ({samples} samples) and \
                         than {MAX_FRAME}; the simulator tabulates one entry per phase"
                    ),
                )
            })?;
    }
    Ok(())
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// Adds `sign · offsets[c]` to column c.
fn shift_columns(
    mut m: nalgebra::DMatrix<f64>,
    offsets: &[f64],
    sign: f64,
) -> Result<nalgebra::DMatrix<f64>, lifted_sim::Error> {
    if offsets.len() != m.ncols() {
        return Err(lifted_sim::Error::DimensionMismatch {
            what: "set-point columns (one per output)",
            expected: offsets.len(),
            got: m.ncols(),
        });
    }
    for (c, o) in offsets.iter().enumerate() {
        m.column_mut(c).iter_mut().for_each(|v| *v += sign * o);
    }
    Ok(m)
}

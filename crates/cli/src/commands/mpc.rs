//! `lifted mpc`: design a receding-horizon controller from a model file —
//! DMC on the step-response coefficients (thesis (8.6)–(8.9)) or the same law
//! on the state-space realisation ((8.10)–(8.14), "gpc") — with horizons,
//! weights and limits, optionally as dual-rate inferential MPC (outputs
//! sampled every n fast samples) or as the slow single-rate MPC on the
//! hold model at nT; simulate it against a plant model (default: the model)
//! and write the trajectories (CSV), an SVG plot and the performance table.
//! The model maps deviations from its operating point (u₀, y₀) (the model
//! file's, else the plant file's): the loop runs in deviations, set-points,
//! limits and the written trajectories are plant values.
//!
//! Cost: design O((h·p)(m·n_u)² + (m·n_u)³); each of the K steps an
//! unconstrained update O(h·p·m·n_u) or one dense QP with m·n_u variables
//! (clarabel) when a limit is active; the plant O(K·order²).

use lifted_lti::{OperatingPoint, StateSpace};
use lifted_mpc::{
    Constraints, Controller, Dmc, LoopResult, LoopSetup, MpcOptions, SlowRate, StateSpaceMpc,
    hold_model, simulate,
};
use nalgebra::{DMatrix, DVector};
use serde_json::json;

use crate::args::{MpcArgs, MpcLaw};
use crate::error::{CliResult, Context, input};
use crate::plot::{Plot, Series, svg};
use crate::table::{parse_periods, read_raw, write_columns};
use lifted_cli::service::models::{channel_names, read_model};

/// A per-channel vector option: empty → None; one value → repeated; else
/// exactly `n` values.
fn per_channel(flag: &str, v: &[f64], n: usize, what: &str) -> CliResult<Option<DVector<f64>>> {
    if let Some(bad) = v.iter().find(|x| x.is_nan()) {
        return Err(input(format!("{flag}: {bad} is not a number")));
    }
    match v.len() {
        0 => Ok(None),
        1 => Ok(Some(DVector::from_element(n, v[0]))),
        k if k == n => Ok(Some(DVector::from_column_slice(v))),
        k => Err(input(format!(
            "{flag}: {k} values for {n} {what} (give one value or one per {what})"
        ))),
    }
}

/// A diagonal weight from `--output-weight` / `--move-weight`.
fn weight(flag: &str, v: &[f64], n: usize, what: &str) -> CliResult<Option<DMatrix<f64>>> {
    let d = per_channel(flag, v, n, what)?;
    if let Some(d) = &d
        && let Some(bad) = d.iter().find(|x| !x.is_finite() || **x < 0.0)
    {
        return Err(input(format!(
            "{flag}: weight {bad} must be finite and non-negative"
        )));
    }
    Ok(d.map(|d| DMatrix::from_diagonal(&d)))
}

/// Each output's sampling period (fast samples), from `--output-period`.
fn periods(a: &MpcArgs, outputs: &[String]) -> CliResult<Vec<usize>> {
    let mut per = vec![1; outputs.len()];
    for (name, n) in parse_periods(&a.output_period)? {
        let i = outputs.iter().position(|o| *o == name).ok_or_else(|| {
            input(format!(
                "--output-period: the model has no output '{name}' (outputs: {})",
                outputs.join(", ")
            ))
        })?;
        per[i] = n;
    }
    Ok(per)
}

/// The set-point trajectory in plant units: `--reference` CSV (one column
/// per output name) or steps of `--setpoint NAME=VALUE` at `--step-at` held
/// for `--steps`; an output without a step stays at its operating value
/// `y0` (0 without an operating point).
fn reference(a: &MpcArgs, outputs: &[String], y0: &[f64]) -> CliResult<DMatrix<f64>> {
    if let Some(path) = &a.reference {
        if !a.setpoint.is_empty() {
            return Err(input("give --setpoint or --reference, not both"));
        }
        let wanted: Vec<&String> = outputs.iter().collect();
        let raw = read_raw(path, &[], &wanted, 0..0, Some(1.0))?;
        if raw.rows == 0 {
            return Err(input(format!("{path}: no set-point rows")));
        }
        return Ok(DMatrix::from_fn(raw.rows, outputs.len(), |t, q| {
            raw.cols[q][t]
        }));
    }
    if a.steps == 0 {
        return Err(input("--steps must be at least 1"));
    }
    if a.step_at >= a.steps {
        return Err(input(format!(
            "--step-at {} is not before the end of the run (--steps {})",
            a.step_at, a.steps
        )));
    }
    // The run keeps the set points, outputs, inputs and moves of every
    // step (a few trajectories of the outputs' and inputs' width).
    lifted_linalg::budget::MemoryBudget::default()
        .check(
            "the simulated run (--steps)",
            lifted_linalg::budget::Size::matrices(8, a.steps, outputs.len().max(1)),
        )
        .ctx("--steps")?;
    let mut r = DMatrix::from_fn(a.steps, outputs.len(), |_, q| y0[q]);
    for spec in a.setpoint.iter().flat_map(|s| s.split(',')) {
        let spec = spec.trim();
        if spec.is_empty() {
            continue;
        }
        let (name, value) = spec.split_once('=').ok_or_else(|| {
            input(format!(
                "--setpoint '{spec}': expected OUTPUT=VALUE, e.g. {}=1",
                outputs[0]
            ))
        })?;
        let q = outputs
            .iter()
            .position(|o| o == name.trim())
            .ok_or_else(|| {
                input(format!(
                    "--setpoint: the model has no output '{}' (outputs: {})",
                    name.trim(),
                    outputs.join(", ")
                ))
            })?;
        let v: f64 = value
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| {
                input(format!(
                    "--setpoint '{spec}': '{value}' is not a finite number"
                ))
            })?;
        r.view_mut((a.step_at, q), (a.steps - a.step_at, 1)).fill(v);
    }
    Ok(r)
}

/// The controller the options describe, designed on `model`, whose
/// variables are deviations from the operating point `(u0, y0)`: the limits,
/// given in plant units, are shifted by it (the move limit is not).
fn design(
    a: &MpcArgs,
    model: &StateSpace,
    (u0, y0): (&[f64], &[f64]),
) -> CliResult<Box<dyn Controller>> {
    let (m, p) = (model.n_inputs(), model.n_outputs());
    let shifted = |v: Option<DVector<f64>>, by: &[f64]| {
        v.map(|v| DVector::from_fn(v.len(), |i, _| v[i] - by[i]))
    };
    let opts = MpcOptions {
        prediction_horizon: a.horizon,
        control_horizon: a.control_horizon,
        output_weight: weight("--output-weight", &a.output_weight, p, "outputs")?,
        move_weight: weight("--move-weight", &a.move_weight, m, "inputs")?,
        constraints: Constraints {
            u_min: shifted(per_channel("--u-min", &a.u_min, m, "inputs")?, u0),
            u_max: shifted(per_channel("--u-max", &a.u_max, m, "inputs")?, u0),
            du_max: per_channel("--du-max", &a.du_max, m, "inputs")?,
            y_min: shifted(per_channel("--y-min", &a.y_min, p, "outputs")?, y0),
            y_max: shifted(per_channel("--y-max", &a.y_max, p, "outputs")?, y0),
        },
    };
    // --slow n: the law is designed on the hold model at nT and updated every n samples.
    let design_model = match a.slow {
        Some(n) => hold_model(model, n).ctx("--slow: hold model at nT")?,
        None => model.clone(),
    };
    match a.law {
        MpcLaw::Dmc => {
            let n = a.truncation.unwrap_or(4 * a.horizon);
            at_rate(Dmc::new(&design_model, n, &opts).ctx("DMC design")?, a.slow)
        }
        MpcLaw::Gpc => at_rate(
            StateSpaceMpc::new(&design_model, &opts).ctx("state-space MPC design")?,
            a.slow,
        ),
    }
}

/// The law itself, or wrapped in [`SlowRate`] for `--slow n`.
fn at_rate<C: Controller + 'static>(law: C, slow: Option<usize>) -> CliResult<Box<dyn Controller>> {
    Ok(match slow {
        Some(n) => Box::new(SlowRate::new(law, n).ctx("--slow")?),
        None => Box::new(law),
    })
}

/// SVG of the outputs with their set-points and of the inputs.
fn plot(run: &LoopResult, r: &DMatrix<f64>, ts: f64, names: (&[String], &[String])) -> Plot {
    let t: Vec<f64> = (0..r.nrows()).map(|k| k as f64 * ts).collect();
    let mut series = Vec::new();
    for (q, y) in names.1.iter().enumerate() {
        series.push(Series::line(
            y.clone(),
            t.clone(),
            run.y.column(q).iter().copied().collect(),
        ));
        series.push(Series::line(
            format!("{y} set-point"),
            t.clone(),
            r.column(q).iter().copied().collect(),
        ));
    }
    for (j, u) in names.0.iter().enumerate() {
        series.push(Series::line(
            u.clone(),
            t.clone(),
            run.u.column(j).iter().copied().collect(),
        ));
    }
    Plot {
        title: "Closed loop under MPC".into(),
        x_label: "t [s]".into(),
        y_label: "y, r, u".into(),
        series,
        ..Default::default()
    }
}

/// "2 outputs and 1 input" for messages.
fn shape(m: &StateSpace) -> String {
    let plural = |k: usize, what: &str| format!("{k} {what}{}", if k == 1 { "" } else { "s" });
    format!(
        "{} and {}",
        plural(m.n_outputs(), "output"),
        plural(m.n_inputs(), "input")
    )
}

/// The plant the loop is simulated with (default: the model), checked
/// against the model: same channels and sample period, and an operating
/// point, if it has one, equal to the model's. Returns the plant and the
/// operating point of the run: the model file's, else the plant file's.
fn plant_and_operating_point(
    a: &MpcArgs,
    model: &StateSpace,
    model_op: Option<OperatingPoint>,
) -> CliResult<(StateSpace, Option<OperatingPoint>)> {
    let Some(path) = &a.plant else {
        return Ok((model.clone(), model_op));
    };
    let file = read_model(path)?;
    let plant = file.model;
    if plant.n_outputs() != model.n_outputs() || plant.n_inputs() != model.n_inputs() {
        return Err(input(format!(
            "--plant {path} has {}, the model {} has {}: the plant must have the model's inputs and outputs",
            shape(&plant),
            a.model,
            shape(model)
        )));
    }
    if plant.ts() != model.ts() {
        return Err(input(format!(
            "--plant {path}: sample period {:?} differs from the model's {:?} (None = continuous;              discretise it with lifted convert --to discrete --ts T)",
            plant.ts(),
            model.ts()
        )));
    }
    match (model_op, file.operating_point) {
        (Some(m), Some(p)) if m != p => Err(input(format!(
            "--plant {path}: its operating point (u0 {:?}, y0 {:?}) differs from the model's              (u0 {:?}, y0 {:?}); the loop is simulated in deviations from one operating point",
            p.u0, p.y0, m.u0, m.y0
        ))),
        (m, p) => Ok((plant, m.or(p))),
    }
}

/// `lifted mpc`.
pub fn mpc_cmd(a: &MpcArgs) -> CliResult<()> {
    let file = read_model(&a.model)?;
    let model = file.model;
    let ts = model.ts().ok_or_else(|| {
        input(format!(
            "{}: the model is continuous; MPC needs a discrete model (lifted convert --to discrete --ts T)",
            a.model
        ))
    })?;
    let (plant, op) = plant_and_operating_point(a, &model, file.operating_point)?;
    // The model maps u − u0 to y − y0: the controller and the loop run in
    // these deviations; set-points, limits and the written trajectories are
    // plant values.
    let (u0, y0) = match &op {
        Some(op) => (op.u0.clone(), op.y0.clone()),
        None => (vec![0.0; model.n_inputs()], vec![0.0; model.n_outputs()]),
    };
    let (inputs, outputs) = channel_names(&model);
    let per = periods(a, &outputs)?;
    if let Some(n) = a.slow
        && per.iter().any(|&k| k != 1)
    {
        return Err(input(format!(
            "--slow {n} runs the single-rate MPC at nT on every output; drop --output-period"
        )));
    }
    let r = reference(a, &outputs, &y0)?;
    let mut controller = design(a, &model, (&u0, &y0))?;
    let r_dev = DMatrix::from_fn(r.nrows(), r.ncols(), |t, q| r[(t, q)] - y0[q]);
    let setup = LoopSetup::new(r_dev, per.clone());
    let mut run = simulate(&plant, controller.as_mut(), &setup).ctx("closed-loop simulation")?;
    for (q, v) in y0.iter().enumerate() {
        run.y.column_mut(q).add_scalar_mut(*v);
    }
    for (j, v) in u0.iter().enumerate() {
        run.u.column_mut(j).add_scalar_mut(*v);
    }

    let mut header = vec!["t".to_string()];
    let mut cols = vec![(0..r.nrows()).map(|k| k as f64 * ts).collect::<Vec<_>>()];
    for (q, y) in outputs.iter().enumerate() {
        header.push(format!("r_{y}"));
        cols.push(r.column(q).iter().copied().collect());
        header.push(y.clone());
        cols.push(run.y.column(q).iter().copied().collect());
        // What the controller saw: the slow samples only.
        header.push(format!("{y}_measured"));
        cols.push(
            run.y
                .column(q)
                .iter()
                .enumerate()
                .map(|(t, &v)| if t % per[q] == 0 { v } else { f64::NAN })
                .collect(),
        );
    }
    for (j, u) in inputs.iter().enumerate() {
        header.push(u.clone());
        cols.push(run.u.column(j).iter().copied().collect());
    }
    write_columns(&a.out, &header, &cols)?;
    if let Some(path) = &a.plot {
        let text = svg(&plot(&run, &r, ts, (&inputs, &outputs)), 900, 520)?;
        std::fs::write(path, text).ctx(format!("cannot write {path}"))?;
    }
    let perf = &run.performance;
    if a.json {
        let v = json!({
            "law": format!("{:?}", a.law).to_lowercase(),
            "slow_period": a.slow,
            "output_periods": per,
            "outputs": outputs.iter().enumerate().map(|(q, y)| json!({
                "name": y,
                "iae": perf.iae[q],
                "overshoot": perf.overshoot[q],
                "settling_time": perf.settling_time[q],
            })).collect::<Vec<_>>(),
            "input_energy": perf.input_energy,
            "operating_point": op.as_ref().map(|o| json!({"u0": o.u0, "y0": o.y0})),
            "out": a.out,
        });
        println!(
            "{}",
            serde_json::to_string_pretty(&v).ctx("JSON of the performance")?
        );
        return Ok(());
    }
    println!(
        "{:<10} {:>7} {:>12} {:>10} {:>14}",
        "output", "period", "IAE", "overshoot", "settling [k]"
    );
    for (q, y) in outputs.iter().enumerate() {
        println!(
            "{:<10} {:>7} {:>12.6} {:>10.4} {:>14}",
            y,
            per[q],
            perf.iae[q],
            perf.overshoot[q],
            perf.settling_time[q].map_or("not settled".to_string(), |k| k.to_string())
        );
    }
    println!(
        "input energy {:.6}{}; wrote {}",
        perf.input_energy,
        if op.is_some() { " (of u − u0)" } else { "" },
        a.out
    );
    Ok(())
}

//! The process-model route (MATLAB's `procest`): per output, gain, time
//! constants and dead time of each input's transfer function
//! (`lifted_pem::procest`: P1D, P2D, P1DI, P2DZ, P2DU), fitted by output
//! error on the measured samples (multirate records included).
//!
//! The process model relates deviations from the state at rest before the
//! record: each record's inputs are taken relative to their first sample
//! (a step test's level before the step; the route shifts them, a constant
//! shift of the detrended records) and a constant output offset is
//! estimated with the parameters. The stored state-space model is the
//! exact ZOH equivalent of the fitted transfer functions (every dead time
//! included; `ProcessFit::to_discrete_ss`), the outputs stacked (block
//! diagonal A), with K = 0 (an output-error model). The physical
//! parameters with their standard deviations, in the data's units, are in
//! `diagnostics.process`.

use lifted_lti::{Dataset, StateSpace};
use lifted_pem::{ProcessKind, ProcessOptions, procest};
use lifted_subspace::Experiment;
use nalgebra::DMatrix;
use serde_json::json;

use crate::error::{Context, Error, Result};
use crate::options::WorkflowOptions;
use crate::preprocess::ChannelScales;
use crate::routes::RouteFit;

/// The route (module docs). `scales`: the channel scales the records were
/// divided by (the gains, offsets and their deviations are reported in the
/// data's units).
///
/// Errors: [`Error::Step`] with `lifted_pem`'s error (a constant input,
/// too few measured samples).
pub(crate) fn identify(
    opts: &WorkflowOptions,
    sets: &[Dataset],
    scales: Option<&ChannelScales>,
) -> Result<RouteFit> {
    let id = &opts.identification;
    let kind = id.process.unwrap_or(ProcessKind::P1D);
    let first = sets
        .first()
        .ok_or_else(|| Error::Data("no data record".into()))?;
    let (nu, ny, ts) = (first.n_inputs(), first.y().ncols(), first.ts());
    // Inputs relative to their first sample, per record.
    let us: Vec<DMatrix<f64>> = sets
        .iter()
        .map(|d| {
            let u = d.u();
            DMatrix::from_fn(u.nrows(), u.ncols(), |t, j| u[(t, j)] - u[(0, j)])
        })
        .collect();
    let names: Vec<String> = first.inputs().iter().map(|c| c.name.clone()).collect();
    let mut parts: Vec<StateSpace> = Vec::with_capacity(ny);
    let mut outputs = Vec::with_capacity(ny);
    let t_fit = std::time::Instant::now();
    for i in 0..ny {
        let popts = ProcessOptions {
            offset: true,
            fixed: held(&id.process_fixed, kind, &names, i, scales)?,
            intersample: id.intersample.unwrap_or_default(),
            ..Default::default()
        };
        let ys: Vec<DMatrix<f64>> = sets
            .iter()
            .map(|d| d.y().columns(i, 1).into_owned())
            .collect();
        let exps: Vec<Experiment<'_>> = us
            .iter()
            .zip(&ys)
            .map(|(u, y)| Experiment { u, y })
            .collect();
        let fit = procest(&exps, kind, ts, &popts)
            .ctx(format!("process model ({kind:?}) of output {}", i + 1))?;
        parts.push(
            fit.to_discrete_ss()
                .ctx("the process model's state space")?,
        );
        // Physical units: K scales by s_y/s_u, the offset by s_y.
        let per = kind.n_parameters();
        let factor = |p: usize| -> f64 {
            let Some(sc) = scales else { return 1.0 };
            if p < per * nu {
                if p.is_multiple_of(per) {
                    sc.y[i] / sc.u[p / per]
                } else {
                    1.0
                }
            } else {
                sc.y[i]
            }
        };
        let values: Vec<f64> = fit
            .parameters
            .iter()
            .enumerate()
            .map(|(p, v)| v * factor(p))
            .collect();
        let std: Vec<f64> = fit
            .std
            .iter()
            .enumerate()
            .map(|(p, v)| v * factor(p))
            .collect();
        // The parameters named after the record's inputs.
        let names: Vec<String> = fit
            .names
            .iter()
            .map(|n| {
                // "K(u0)" → "K(<first input's name>)", one substitution.
                let input = n.rsplit_once("(u").and_then(|(head, tail)| {
                    Some((head, tail.strip_suffix(')')?.parse::<usize>().ok()?))
                });
                match input {
                    Some((head, j)) if j < nu => format!("{head}({})", first.inputs()[j].name),
                    _ => n.clone(),
                }
            })
            .collect();
        outputs.push(json!({
            "names": names,
            "parameters": values,
            "std": std,
            "simulation_fit": fit.fit,
            "measured": fit.measured,
            "iterations": fit.iterations,
        }));
    }
    let model = stack(&parts, ts)?;
    let mut diagnostics = json!({
        "route": "process",
        "process": {"kind": format!("{kind:?}"), "outputs": outputs,
                    "inputs_relative_to": "their first sample",
                    "intersample": format!("{:?}", id.intersample.unwrap_or_default())},
    });
    crate::diagnostics::add_phase(&mut diagnostics, "process_s", t_fit.elapsed().as_secs_f64());
    let n = model.order();
    let mut route = RouteFit::plain(model, diagnostics, &[], 0);
    route.suggested_order = route.order;
    route.kalman_gain = Some(DMatrix::zeros(n, ny));
    Ok(route)
}

/// [`crate::IdentificationOptions::process_fixed`] for output `i` as
/// `lifted_pem::ProcessOptions::fixed` takes them: per input ("K(u0)"), in
/// the scaled channels' units (a gain K ÷ s_y/s_u, the offset ÷ s_y; time
/// constants and dead times in seconds as given).
///
/// Errors: [`Error::InvalidOption`] (`process_fixed`) naming an unknown
/// parameter with the names there are.
fn held(
    fixed: &[(String, f64)],
    kind: ProcessKind,
    inputs: &[String],
    i: usize,
    scales: Option<&ChannelScales>,
) -> Result<Vec<(String, f64)>> {
    let params = kind.parameter_names();
    let (sy, su) = match scales {
        Some(sc) => (sc.y[i], sc.u.clone()),
        None => (1.0, vec![1.0; inputs.len()]),
    };
    let mut out = Vec::new();
    for (name, value) in fixed {
        if name == "offset" {
            out.push(("offset".to_string(), value / sy));
            continue;
        }
        // "Td" for every input, or "Td(<input name>)" for one.
        let (param, which): (&str, Vec<usize>) = match name.split_once('(') {
            Some((p, rest)) => {
                let input = rest.strip_suffix(')').unwrap_or(rest);
                match inputs.iter().position(|n| n == input) {
                    Some(j) => (p, vec![j]),
                    None => (p, Vec::new()),
                }
            }
            None => (name.as_str(), (0..inputs.len()).collect()),
        };
        if !params.contains(&param) || which.is_empty() {
            return Err(Error::option(
                "process_fixed",
                format!(
                    "no parameter '{name}' in a {kind:?} model of inputs {}; its parameters are {} (every input), {}({}) … (one input) and offset",
                    inputs.join(", "),
                    params.join(", "),
                    params[0],
                    inputs.first().map_or("u1", String::as_str)
                ),
            ));
        }
        for j in which {
            let v = if param == "K" {
                value * su[j] / sy
            } else {
                *value
            };
            out.push((format!("{param}(u{j})"), v));
        }
    }
    Ok(out)
}

/// The outputs' MISO models as one model: A block diagonal, B stacked, C
/// block diagonal, D stacked.
fn stack(parts: &[StateSpace], ts: f64) -> Result<StateSpace> {
    let n: usize = parts.iter().map(StateSpace::order).sum();
    let nu = parts.first().map_or(0, StateSpace::n_inputs);
    let ny = parts.len();
    let (mut a, mut b, mut c, mut d) = (
        DMatrix::zeros(n, n),
        DMatrix::zeros(n, nu),
        DMatrix::zeros(ny, n),
        DMatrix::zeros(ny, nu),
    );
    let mut at = 0;
    for (i, p) in parts.iter().enumerate() {
        let k = p.order();
        a.view_mut((at, at), (k, k)).copy_from(p.a());
        b.view_mut((at, 0), (k, nu)).copy_from(p.b());
        c.view_mut((i, at), (1, k)).copy_from(p.c());
        d.row_mut(i).copy_from(&p.d().row(0));
        at += k;
    }
    StateSpace::new(a, b, c, d, Some(ts)).ctx("the process model's state space")
}

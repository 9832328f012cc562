//! `convert`, `bode`, `step`, `simulate` (the figures come from the
//! figure service, [`lifted_cli::service::figures`]).

use lifted_lti::{C2dOptions, InputChannel, MinrealOptions, ModelFile, OutputChannel, StateSpace};
use lifted_sim::{
    Controller, Delays, Excitation, Feedback, NoiseSpec, Plant, SimOptions, Simulator,
    SnrDefinition, SnrSamples,
};
use nalgebra::DMatrix;

use crate::args::{
    BodeArgs, ConvertArgs, ConvertTo, FeedbackArg, SimulateArgs, SnrSamplesArg, StepArgs,
};
use crate::error::{CliResult, Context, input};
use crate::plot::{Plot, Series, svg};
use crate::table::{names, parse_name_counts, parse_periods, read_raw, write_columns};
use lifted_cli::service::figures::{bode_grid, bode_plots, stack_svgs, step_data};
use lifted_cli::service::models::{channel_names, read_model, write_model};

/// Keeps the channel names of `from` on `to` when the sizes agree.
fn keep_names(from: &StateSpace, to: StateSpace) -> StateSpace {
    let (u, y) = channel_names(from);
    let to = match to.clone().with_input_names(u) {
        Ok(m) => m,
        Err(_) => to,
    };
    match to.clone().with_output_names(y) {
        Ok(m) => m,
        Err(_) => to,
    }
}

/// `lifted convert`.
pub fn convert(a: &ConvertArgs) -> CliResult<()> {
    let file = read_model(&a.model)?;
    let m = &file.model;
    let converted = match a.to {
        ConvertTo::Tf => {
            let tf = m.to_tf(&MinrealOptions::default()).ctx("convert to tf")?;
            let text = format!("{tf}");
            match &a.out {
                Some(p) => std::fs::write(p, text + "\n").ctx(format!("cannot write {p}"))?,
                None => println!("{text}"),
            }
            return Ok(());
        }
        ConvertTo::Ss => m.clone(),
        ConvertTo::Continuous => keep_names(m, m.d2c().ctx("convert to continuous (d2c)")?),
        ConvertTo::Discrete => {
            let ts = a.ts.ok_or_else(|| {
                input("convert --to discrete needs --ts T (sample period in seconds)")
            })?;
            keep_names(
                m,
                m.c2d(ts, &C2dOptions::default())
                    .ctx("convert to discrete (c2d, ZOH)")?,
            )
        }
    };
    let mut out = ModelFile::new(converted).with_diagnostics(file.diagnostics.clone());
    out.method = file.method.clone();
    match &a.out {
        Some(p) => {
            write_model(&out, p)?;
            println!("wrote {p}");
        }
        None => println!("{}", out.to_json().map_err(|e| input(e.to_string()))?),
    }
    Ok(())
}

enum OutKind {
    Csv,
    Svg,
}

fn out_kind(path: &str) -> CliResult<OutKind> {
    let lower = path.to_ascii_lowercase();
    if lower.ends_with(".csv") {
        Ok(OutKind::Csv)
    } else if lower.ends_with(".svg") {
        Ok(OutKind::Svg)
    } else {
        Err(input(format!(
            "--out {path}: the file name must end in .csv or .svg"
        )))
    }
}

/// `lifted bode`.
pub fn bode(a: &BodeArgs) -> CliResult<()> {
    let kind = out_kind(&a.out)?;
    let m = read_model(&a.model)?.model;
    let omega = bode_grid(&m, a.wmin, a.wmax, a.points)?;
    match kind {
        OutKind::Csv => {
            let b = m.bode(&omega).ctx("bode")?;
            let (un, yn) = channel_names(&m);
            let mut header = vec!["omega".to_string()];
            let mut cols = vec![b.omega.clone()];
            for i in 0..m.n_outputs() {
                for j in 0..m.n_inputs() {
                    header.push(format!("mag_db_{}_{}", yn[i], un[j]));
                    cols.push(
                        b.magnitude
                            .iter()
                            .map(|g| 20.0 * g[(i, j)].max(1e-300).log10())
                            .collect(),
                    );
                    header.push(format!("phase_deg_{}_{}", yn[i], un[j]));
                    cols.push(b.phase_deg.iter().map(|g| g[(i, j)]).collect());
                }
            }
            write_columns(&a.out, &header, &cols)?;
        }
        OutKind::Svg => {
            let (mag, ph) = bode_plots(&m, &omega)?;
            let doc = stack_svgs(&svg(&mag, 720, 320)?, &svg(&ph, 720, 320)?, 720, 320);
            std::fs::write(&a.out, doc).ctx(format!("cannot write {}", a.out))?;
        }
    }
    println!("wrote {}", a.out);
    Ok(())
}

/// `lifted step`.
pub fn step(a: &StepArgs) -> CliResult<()> {
    let kind = out_kind(&a.out)?;
    let m = read_model(&a.model)?.model;
    let (t, cols) = step_data(&m, a.samples, a.dt)?;
    match kind {
        OutKind::Csv => {
            let mut header = vec!["t".to_string()];
            header.extend(cols.iter().map(|c| c.0.clone()));
            let mut data = vec![t];
            data.extend(cols.into_iter().map(|c| c.1));
            write_columns(&a.out, &header, &data)?;
        }
        OutKind::Svg => {
            let plot = Plot {
                title: "Step response".into(),
                x_label: "t [s]".into(),
                y_label: "y".into(),
                series: cols
                    .into_iter()
                    .map(|(n, y)| Series::line(n, t.clone(), y))
                    .collect(),
                ..Default::default()
            };
            std::fs::write(&a.out, svg(&plot, 720, 400)?).ctx(format!("cannot write {}", a.out))?;
        }
    }
    println!("wrote {}", a.out);
    Ok(())
}

/// `lifted simulate`.
pub fn simulate(a: &SimulateArgs) -> CliResult<()> {
    let file = read_model(&a.model)?;
    let operating_point = file.operating_point.clone();
    let model = file.model;
    let (def_u, yn) = channel_names(&model);
    let closed = a.controller.is_some();
    if !closed && (a.references.is_some() || a.feedback != FeedbackArg::Fast) {
        return Err(input(
            "--references and --feedback need a closed loop (--controller)",
        ));
    }
    // plant-input columns: open loop the inputs u, closed loop the optional
    // excitation r₂; closed loop also the set-points r₁
    let un = match (&a.inputs, closed) {
        (Some(list), _) => names(list),
        (None, false) => def_u.clone(),
        (None, true) => Vec::new(),
    };
    if !un.is_empty() && un.len() != model.n_inputs() {
        return Err(input(format!(
            "--inputs: {} names for a model with {} inputs",
            un.len(),
            model.n_inputs()
        )));
    }
    let rn = a.references.as_deref().map(names).unwrap_or_default();
    if !rn.is_empty() && rn.len() != model.n_outputs() {
        return Err(input(format!(
            "--references: {} names for a model with {} outputs",
            rn.len(),
            model.n_outputs()
        )));
    }
    if closed && un.is_empty() && rn.is_empty() {
        return Err(input(
            "closed loop: give the excitation columns (--inputs, added at the plant input) \
             and/or the set-point columns (--references)",
        ));
    }
    let wanted: Vec<&String> = un.iter().chain(&rn).collect();
    let ts_hint = a.ts.or(model.ts());
    let npy_columns = a.columns.as_deref().map(names).unwrap_or_default();
    let raw = read_raw(&a.input, &npy_columns, &wanted, 0..0, ts_hint)?;
    let ts = raw.ts;
    let plant = match model.ts() {
        Some(mts) => {
            if (mts - ts).abs() > 1e-9 * mts {
                return Err(input(format!(
                    "{}: base period {ts} differs from the model's {mts}",
                    a.input
                )));
            }
            Plant::discrete(&model, &[], &[]).ctx("simulate")?
        }
        None => Plant::continuous(&model, ts, &Delays::default()).ctx("simulate")?,
    };
    let periods = parse_periods(&a.output_period)?;
    for (n, _) in &periods {
        if !yn.contains(n) {
            return Err(input(format!(
                "--output-period {n}=…: the model's outputs are {}",
                yn.join(", ")
            )));
        }
    }
    // the plant-input channels of the data set: open loop the input columns
    // (u = r₂), closed loop the model's input names (u = r₂ + K(r₁ − v))
    let u_names = if closed { def_u.clone() } else { un.clone() };
    let holds = parse_name_counts(&a.hold, "--hold", "SAMPLES", "u1=3")?;
    for (n, _) in &holds {
        if !u_names.contains(n) {
            return Err(input(format!(
                "--hold {n}=…: the plant inputs are {}",
                u_names.join(", ")
            )));
        }
    }
    let outputs: Vec<OutputChannel> = yn
        .iter()
        .map(|n| {
            let p = periods.iter().find(|(m, _)| m == n).map_or(1, |p| p.1);
            OutputChannel::new(n.clone(), p, 0)
        })
        .collect();
    let inputs: Vec<InputChannel> = u_names
        .iter()
        .map(|n| {
            let h = holds.iter().find(|(m, _)| m == n).map_or(1, |h| h.1);
            InputChannel::new(n.clone(), h)
        })
        .collect();
    let mut sim = match &a.controller {
        None => Simulator::open_loop(plant),
        Some(path) => {
            let k = read_model(path)?.model;
            let k = Controller::from_ss(&k).ctx(format!("controller {path}"))?;
            Simulator::closed_loop(plant, k).ctx(format!("controller {path}"))?
        }
    };
    sim = sim
        .with_inputs(inputs)
        .ctx("simulate")?
        .with_outputs(outputs)
        .ctx("simulate")?
        .with_options(SimOptions {
            snr_samples: match a.snr_samples {
                SnrSamplesArg::Fast => SnrSamples::Fast,
                SnrSamplesArg::Measured => SnrSamples::Measured,
            },
            ..Default::default()
        })
        .ctx("simulate")?;
    if a.feedback == FeedbackArg::HoldLast {
        sim = sim.with_feedback(Feedback::HoldLast).ctx("simulate")?;
    }
    match (a.snr, &a.noise_model) {
        (Some(snr), None) => {
            sim = sim
                .with_noise(NoiseSpec::white_snr(snr, a.seed))
                .ctx("simulate")?;
        }
        (Some(snr), Some(path)) => {
            let h = read_model(path)?.model;
            sim = sim
                .with_noise(NoiseSpec::filtered(h, snr, SnrDefinition::Variance, a.seed))
                .ctx(format!("noise model {path}"))?;
        }
        (None, Some(_)) => return Err(input("--noise-model needs --snr (the noise level)")),
        (None, None) => {}
    }
    let column_block = |cols: &[Vec<f64>]| {
        let mut m = DMatrix::zeros(raw.rows, cols.len());
        for (j, c) in cols.iter().enumerate() {
            m.column_mut(j).copy_from_slice(c);
        }
        m
    };
    let (ucols, rcols) = raw.cols.split_at(un.len());
    let mut exc = Excitation {
        r1: (!rn.is_empty()).then(|| column_block(rcols)),
        r2: (!un.is_empty()).then(|| column_block(ucols)),
    };
    // The model maps deviations u − u₀ to y − y₀ (its operating point):
    // simulate in deviations, write plant values. In closed loop --inputs
    // is an excitation added to the controller's output, not a plant value.
    if let Some(op) = &operating_point {
        if let Some(r2) = exc.r2.as_mut().filter(|_| a.controller.is_none()) {
            *r2 = op.remove_input(r2).ctx("simulate")?;
        }
        if let Some(r1) = &mut exc.r1 {
            for (c, y0) in op.y0.iter().enumerate() {
                r1.column_mut(c).iter_mut().for_each(|v| *v -= y0);
            }
        }
    }
    let mut out = sim.simulate(&exc).ctx("simulate")?;
    if let Some(op) = &operating_point {
        out.data = out.data.shifted(&op.u0, &op.y0).ctx("simulate")?;
    }
    let file = std::fs::File::create(&a.out).ctx(format!("cannot write {}", a.out))?;
    out.data
        .to_csv_writer(std::io::BufWriter::new(file))
        .ctx(format!("cannot write {}", a.out))?;
    println!("wrote {} samples to {}", out.data.len(), a.out);
    Ok(())
}

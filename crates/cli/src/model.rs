//! `convert`, `bode`, `step`, `simulate`, and the model plots shared with
//! `report`.

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
use crate::plot::{Marker, Plot, Series, logspace, svg};
use crate::table::{names, parse_name_counts, parse_periods, read_raw, write_columns};

/// Reads a model file; the message names the file.
pub fn read_model(path: &str) -> CliResult<ModelFile> {
    ModelFile::read(path).map_err(|e| input(e.to_string()))
}

/// Writes a model file (one-line error on failure).
pub fn write_model(file: &ModelFile, path: &str) -> CliResult<()> {
    file.write(path).map_err(|e| input(e.to_string()))
}

/// Channel names of a model (its own, else u1…, y1…).
pub fn channel_names(model: &StateSpace) -> (Vec<String>, Vec<String>) {
    let u = model
        .input_names()
        .map(<[String]>::to_vec)
        .unwrap_or_else(|| (1..=model.n_inputs()).map(|i| format!("u{i}")).collect());
    let y = model
        .output_names()
        .map(<[String]>::to_vec)
        .unwrap_or_else(|| (1..=model.n_outputs()).map(|i| format!("y{i}")).collect());
    (u, y)
}

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

/// (slowest, fastest) natural frequency of the poles in rad/s, if any.
fn pole_frequencies(m: &StateSpace) -> Option<(f64, f64)> {
    let poles = m.poles().ok()?;
    let w: Vec<f64> = poles
        .iter()
        .map(|p| match m.ts() {
            Some(ts) => p.ln().norm() / ts,
            None => p.norm(),
        })
        .filter(|w| w.is_finite() && *w > 0.0)
        .collect();
    if w.is_empty() {
        return None;
    }
    Some((
        w.iter().copied().fold(f64::INFINITY, f64::min),
        w.iter().copied().fold(0.0, f64::max),
    ))
}

/// Default Bode grid.
pub fn bode_grid(
    m: &StateSpace,
    wmin: Option<f64>,
    wmax: Option<f64>,
    n: usize,
) -> CliResult<Vec<f64>> {
    let (slow, fast) = pole_frequencies(m).unwrap_or((0.1, 10.0));
    let hi = wmax.unwrap_or(match m.ts() {
        Some(ts) => std::f64::consts::PI / ts,
        None => 10.0 * fast,
    });
    let lo = wmin.unwrap_or((slow / 10.0).min(hi / 100.0));
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return Err(input(format!(
            "bode: invalid frequency range {lo}..{hi} rad/s"
        )));
    }
    if !(2..=1_000_000).contains(&n) {
        return Err(input(format!("bode: --points {n} must be in 2..=1000000")));
    }
    Ok(logspace(lo, hi, n))
}

/// Bode magnitude (dB) and phase (deg) plots, one curve per channel pair.
pub fn bode_plots(m: &StateSpace, omega: &[f64]) -> CliResult<(Plot, Plot)> {
    let b = m.bode(omega).ctx("bode")?;
    let (un, yn) = channel_names(m);
    let lw: Vec<f64> = b.omega.iter().map(|w| w.log10()).collect();
    let mut mag = Plot {
        title: "Bode magnitude".into(),
        x_label: "log10 ω [rad/s]".into(),
        y_label: "|G| [dB]".into(),
        ..Default::default()
    };
    let mut ph = Plot {
        title: "Bode phase".into(),
        x_label: "log10 ω [rad/s]".into(),
        y_label: "phase [deg]".into(),
        ..Default::default()
    };
    for i in 0..m.n_outputs() {
        for j in 0..m.n_inputs() {
            let label = format!("{} ← {}", yn[i], un[j]);
            let db: Vec<f64> = b
                .magnitude
                .iter()
                .map(|g| 20.0 * g[(i, j)].max(1e-300).log10())
                .collect();
            let deg: Vec<f64> = b.phase_deg.iter().map(|g| g[(i, j)]).collect();
            mag.series.push(Series::line(label.clone(), lw.clone(), db));
            ph.series.push(Series::line(label, lw.clone(), deg));
        }
    }
    if let Some(ts) = m.ts() {
        let ny = (std::f64::consts::PI / ts).log10();
        mag.vlines.push((ny, "Nyquist".into()));
    }
    Ok((mag, ph))
}

/// Step-response grid: (number of samples, time step).
fn step_grid(m: &StateSpace, samples: Option<usize>, dt: Option<f64>) -> CliResult<(usize, f64)> {
    let (slow, _) = pole_frequencies(m).unwrap_or((1.0, 1.0));
    let tau = 1.0 / slow;
    let h = match m.ts() {
        Some(ts) => ts,
        None => dt.unwrap_or(tau / 50.0),
    };
    if !(h.is_finite() && h > 0.0) {
        return Err(input(format!("step: invalid time step {h}")));
    }
    let n = samples.unwrap_or(((6.0 * tau / h).ceil() as usize).clamp(50, 20_000));
    if n == 0 || n > 10_000_000 {
        return Err(input(format!(
            "step: --samples {n} must be in 1..=10000000"
        )));
    }
    Ok((n, h))
}

/// A named data column.
pub type NamedColumn = (String, Vec<f64>);

/// Step responses: time and one column per (output, input).
pub fn step_data(
    m: &StateSpace,
    samples: Option<usize>,
    dt: Option<f64>,
) -> CliResult<(Vec<f64>, Vec<NamedColumn>)> {
    let (n, h) = step_grid(m, samples, dt)?;
    let r = m
        .step(n, if m.ts().is_some() { None } else { Some(h) })
        .ctx("step")?;
    let (un, yn) = channel_names(m);
    let t: Vec<f64> = (0..n).map(|k| k as f64 * h).collect();
    let mut cols = Vec::new();
    for (rj, uname) in r.iter().zip(&un) {
        for (i, yname) in yn.iter().enumerate() {
            cols.push((
                format!("{yname}_from_{uname}"),
                rj.column(i).iter().copied().collect(),
            ));
        }
    }
    Ok((t, cols))
}

/// Step-response plot.
pub fn step_plot(m: &StateSpace) -> CliResult<Plot> {
    let (t, cols) = step_data(m, None, None)?;
    Ok(Plot {
        title: "Step response".into(),
        x_label: "t [s]".into(),
        y_label: "y".into(),
        series: cols
            .into_iter()
            .map(|(name, y)| Series::line(name, t.clone(), y))
            .collect(),
        ..Default::default()
    })
}

/// Pole-zero map.
pub fn pz_plot(m: &StateSpace) -> CliResult<Plot> {
    let poles = m.poles().ctx("poles")?;
    let mut plot = Plot {
        title: "Poles (×) and transmission zeros (○)".into(),
        x_label: "Re".into(),
        y_label: "Im".into(),
        unit_circle: m.is_discrete(),
        ..Default::default()
    };
    plot.series.push(Series::points(
        "poles",
        poles.iter().map(|p| p.re).collect(),
        poles.iter().map(|p| p.im).collect(),
        Marker::Cross,
    ));
    // Zeros can legitimately fail to exist (e.g. non-square numerics); show poles then.
    if let Ok(zeros) = m.zeros() {
        plot.series.push(Series::points(
            "zeros",
            zeros.iter().map(|p| p.re).collect(),
            zeros.iter().map(|p| p.im).collect(),
            Marker::Ring,
        ));
    }
    Ok(plot)
}

/// Two SVG documents stacked vertically in one.
pub fn stack_svgs(top: &str, bottom: &str, w: u32, h: u32) -> String {
    let shift = |s: &str, y: u32| s.replacen("<svg ", &format!("<svg x=\"0\" y=\"{y}\" "), 1);
    let strip = |s: &str| {
        // drop an XML declaration if any
        match s.find("<svg") {
            Some(i) => s[i..].to_string(),
            None => s.to_string(),
        }
    };
    format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{}\" viewBox=\"0 0 {w} {}\">\n{}\n{}\n</svg>\n",
        2 * h,
        2 * h,
        shift(&strip(top), 0),
        shift(&strip(bottom), h)
    )
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
    let raw = read_raw(&a.input, &wanted, 0..0, ts_hint)?;
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

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
use crate::commands::analyze::num;
use crate::error::{CliResult, Context, input};
use crate::plot::{Plot, Series, svg};
use crate::table::{names, parse_name_counts, parse_periods, read_raw, write_columns};
use lifted_cli::service::analysis::check_omega;
use lifted_cli::service::bands;
use lifted_cli::service::figures::{bode_grid, step_data};
use lifted_cli::service::models::{channel_names, read_model, write_model};
use lifted_cli::service::pairs::{bode_pairs, pairs_svg};

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

/// Prints a model: time domain, poles, DC gain, operating point and the
/// matrices (what `convert` promises instead of raw JSON).
fn print_summary(title: &str, file: &ModelFile) {
    let m = &file.model;
    let (un, yn) = channel_names(m);
    let time = match m.ts() {
        Some(t) => format!("discrete, T = {t} s"),
        None => "continuous".to_string(),
    };
    println!(
        "{title}: {time}, order {}, inputs {}, outputs {}",
        m.order(),
        un.join(", "),
        yn.join(", ")
    );
    match m.poles() {
        Ok(p) => println!(
            "poles: {}",
            p.iter()
                .map(|z| lifted_cli::service::analysis::show_complex(*z))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        Err(e) => println!("poles: not computed ({e})"),
    }
    match m.dc_gain() {
        Ok(g) => {
            for (i, y) in yn.iter().enumerate() {
                let row: Vec<String> = (0..m.n_inputs())
                    .map(|j| format!("{}/{} {}", y, un[j], num(g[(i, j)])))
                    .collect();
                println!("DC gain: {}", row.join(", "));
            }
        }
        Err(e) => println!("DC gain: {e}"),
    }
    if let Some(op) = &file.operating_point {
        let list = |v: &[f64]| v.iter().map(|x| num(*x)).collect::<Vec<_>>().join(", ");
        println!(
            "operating point: u0 = [{}], y0 = [{}]",
            list(&op.u0),
            list(&op.y0)
        );
    }
    for (name, mat) in [("A", m.a()), ("B", m.b()), ("C", m.c()), ("D", m.d())] {
        println!("{name} =");
        for r in 0..mat.nrows() {
            let row: Vec<String> = mat
                .row(r)
                .iter()
                .map(|v| format!("{:>14}", num(*v)))
                .collect();
            println!("  {}", row.join(" "));
        }
    }
}

/// `lifted convert`.
pub fn convert(a: &ConvertArgs) -> CliResult<()> {
    if let (Some(ts), false) = (a.ts, matches!(a.to, ConvertTo::Discrete)) {
        return Err(input(format!(
            "--ts {ts}: only used with --to discrete (the period of a discrete model is its own)"
        )));
    }
    let file = read_model(&a.model)?;
    let m = &file.model;
    let (converted, how) = match a.to {
        ConvertTo::Tf => {
            let tf = m.to_tf(&MinrealOptions::default()).ctx("convert to tf")?;
            let text = format!("{tf}");
            match &a.out {
                Some(p) => std::fs::write(p, text + "\n").ctx(format!("cannot write {p}"))?,
                None => println!("{text}"),
            }
            return Ok(());
        }
        ConvertTo::Ss => (None, "state space"),
        ConvertTo::Continuous => (
            Some(keep_names(m, m.d2c().ctx("convert to continuous (d2c)")?)),
            "continuous model by inverse ZOH (d2c)",
        ),
        ConvertTo::Discrete => {
            let ts = a.ts.ok_or_else(|| {
                input("convert --to discrete needs --ts T (sample period in seconds)")
            })?;
            (
                Some(keep_names(
                    m,
                    m.c2d(ts, &C2dOptions::default())
                        .ctx("convert to discrete (c2d, ZOH)")?,
                )),
                "discrete model by ZOH (c2d)",
            )
        }
    };
    let out = match converted {
        None => file.clone(),
        Some(model) => {
            // The operating point is a steady state (u₀, y₀): the same for
            // the ZOH equivalents. The Kalman gain and the identification's
            // diagnostics (singular values, horizons, fits of the sampled
            // model) belong to the source's sample period: they are not
            // carried over; the diagnostics say where the model came from.
            let mut out = ModelFile::new(model).with_diagnostics(serde_json::json!({
                "converted_from": {
                    "file": a.model,
                    "ts": m.ts(),
                    "conversion": how,
                }
            }));
            out.method = file.method.clone();
            if let Some(op) = &file.operating_point {
                out = out
                    .with_operating_point(op.clone())
                    .ctx("operating point")?;
            }
            out
        }
    };
    if a.json {
        println!("{}", out.to_json().map_err(|e| input(e.to_string()))?);
    } else {
        print_summary(how, &out);
    }
    if let Some(p) = &a.out {
        write_model(&out, p)?;
        println!("wrote {p}");
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

/// The frequencies of `--omega` or `--omega-file` (rad/s), `None` for the grid.
fn given_omega(a: &BodeArgs) -> CliResult<Option<Vec<f64>>> {
    if !a.omega.is_empty() {
        return Ok(Some(a.omega.clone()));
    }
    let Some(path) = &a.omega_file else {
        return Ok(None);
    };
    let text = std::fs::read_to_string(path).ctx(format!("cannot read {path}"))?;
    let mut omega = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let cell = line.split(',').next().unwrap_or("").trim();
        if cell.is_empty() {
            continue;
        }
        match cell.parse::<f64>() {
            Ok(w) => omega.push(w),
            // the first line may be a header
            Err(_) if i == 0 => {}
            Err(_) => {
                return Err(input(format!(
                    "{path}: line {}: cannot parse '{}' as a frequency",
                    i + 1,
                    lifted_cli::shown::shown(cell)
                )));
            }
        }
    }
    if omega.is_empty() {
        return Err(input(format!("{path}: no frequency in the first column")));
    }
    Ok(Some(omega))
}

/// `lifted bode`.
pub fn bode(a: &BodeArgs) -> CliResult<()> {
    let kind = a.out.as_deref().map(out_kind).transpose()?;
    bands::check_level(a.confidence)?;
    let file = read_model(&a.model)?;
    let m = &file.model;
    let given = given_omega(a)?;
    if given.is_none() && kind.is_none() {
        return Err(input(
            "bode: give --out f.csv|f.svg, or the frequencies to print (--omega 0.1,1,10 or --omega-file f.csv)",
        ));
    }
    let omega = match given {
        Some(w) => {
            check_omega(m, &w)?;
            lifted_linalg::budget::MemoryBudget::default()
                .check(
                    "the frequency response (--omega)",
                    lifted_linalg::budget::Size::matrices(
                        3 * w.len(),
                        m.n_outputs().max(1),
                        m.n_inputs().max(1),
                    ),
                )
                .ctx("bode")?;
            w
        }
        None => bode_grid(m, a.wmin, a.wmax, a.points)?,
    };
    let b = m.bode(&omega).ctx("bode")?;
    let (un, yn) = channel_names(m);
    let db = |g: f64| 20.0 * g.max(1e-300).log10();
    // The confidence band: z σ of |G| (in dB: the bounds |G| ± z σ) and of
    // the phase, for a model file with a parameter covariance.
    let band = bands::bode_bounds(bands::Uncertain::of(&file), &b, &omega, a.confidence)?;
    let bounds = |k: usize, i: usize, j: usize| -> Option<[f64; 4]> {
        band.as_ref().map(|band| band.bounds[k][(i, j)])
    };
    match (&a.out, kind) {
        (Some(out), Some(OutKind::Csv)) => {
            let mut header = vec!["omega".to_string()];
            let mut cols = vec![b.omega.clone()];
            for i in 0..m.n_outputs() {
                for j in 0..m.n_inputs() {
                    header.push(format!("mag_db_{}_{}", yn[i], un[j]));
                    cols.push(b.magnitude.iter().map(|g| db(g[(i, j)])).collect());
                    header.push(format!("phase_deg_{}_{}", yn[i], un[j]));
                    cols.push(b.phase_deg.iter().map(|g| g[(i, j)]).collect());
                    if band.is_some() {
                        for (c, what) in ["mag_db_lo", "mag_db_hi", "phase_deg_lo", "phase_deg_hi"]
                            .iter()
                            .enumerate()
                        {
                            header.push(format!("{what}_{}_{}", yn[i], un[j]));
                            cols.push(
                                (0..omega.len())
                                    .map(|k| bounds(k, i, j).map_or(f64::NAN, |v| v[c]))
                                    .collect(),
                            );
                        }
                    }
                }
            }
            write_columns(out, &header, &cols)?;
            println!("wrote {out}");
        }
        (Some(out), _) => {
            let mut fig = bode_pairs(&[(String::new(), m)], &omega)?;
            if let Some(band) = &band {
                bands::add_bode_band(&mut fig, &omega, band, a.confidence);
            }
            let doc = pairs_svg(&fig, 720, 280)?;
            std::fs::write(out, doc).ctx(format!("cannot write {out}"))?;
            println!("wrote {out}");
        }
        (None, _) => {}
    }
    if a.out.is_some() && !a.json {
        return Ok(());
    }
    if a.json {
        let pairs: Vec<serde_json::Value> = (0..m.n_outputs())
            .flat_map(|i| (0..m.n_inputs()).map(move |j| (i, j)))
            .map(|(i, j)| {
                let mut v = serde_json::json!({
                    "output": yn[i],
                    "input": un[j],
                    "magnitude": b.magnitude.iter().map(|g| g[(i, j)]).collect::<Vec<_>>(),
                    "magnitude_db": b.magnitude.iter().map(|g| db(g[(i, j)])).collect::<Vec<_>>(),
                    "phase_deg": b.phase_deg.iter().map(|g| g[(i, j)]).collect::<Vec<_>>(),
                });
                if let Some(band) = &band {
                    let s = &band.std;
                    v["magnitude_std"] = s.magnitude.iter().map(|g| g[(i, j)]).collect();
                    v["phase_std_deg"] = s.phase.iter().map(|g| g[(i, j)].to_degrees()).collect();
                    for (c, what) in [
                        "magnitude_db_lower",
                        "magnitude_db_upper",
                        "phase_deg_lower",
                        "phase_deg_upper",
                    ]
                    .iter()
                    .enumerate()
                    {
                        v[*what] = (0..omega.len())
                            .map(|k| bounds(k, i, j).map_or(f64::NAN, |r| r[c]))
                            .collect();
                    }
                }
                v
            })
            .collect();
        let confidence = band.as_ref().map(|_| a.confidence);
        let v = serde_json::json!({"ts": m.ts(), "omega": b.omega, "pairs": pairs, "confidence": confidence});
        println!(
            "{}",
            serde_json::to_string_pretty(&v).ctx("JSON of the response")?
        );
        return Ok(());
    }
    print!("{:>14}", "omega [rad/s]");
    for y in &yn {
        for u in &un {
            print!(
                " {:>14} {:>14} {:>14}",
                format!("|G| {y}/{u}"),
                "dB",
                "phase [deg]"
            );
        }
    }
    println!();
    for (k, w) in b.omega.iter().enumerate() {
        print!("{:>14}", num(*w));
        for i in 0..m.n_outputs() {
            for j in 0..m.n_inputs() {
                let g = b.magnitude[k][(i, j)];
                print!(
                    " {:>14} {:>14} {:>14}",
                    num(g),
                    num(db(g)),
                    num(b.phase_deg[k][(i, j)])
                );
            }
        }
        println!();
    }
    Ok(())
}

/// `lifted step`.
pub fn step(a: &StepArgs) -> CliResult<()> {
    let kind = out_kind(&a.out)?;
    bands::check_level(a.confidence)?;
    let file = read_model(&a.model)?;
    let (t, cols) = step_data(&file.model, a.samples, a.dt)?;
    // The band: ± z σ of each sample, for a model file with a parameter
    // covariance.
    let band = bands::step_bounds(bands::Uncertain::of(&file), &cols, a.confidence)?;
    match kind {
        OutKind::Csv => {
            let mut header = vec!["t".to_string()];
            let mut data = vec![t];
            for (k, (name, y)) in cols.into_iter().enumerate() {
                header.push(name.clone());
                data.push(y);
                if let Some(b) = &band {
                    header.push(format!("{name}_lo"));
                    data.push(b[k].0.clone());
                    header.push(format!("{name}_hi"));
                    data.push(b[k].1.clone());
                }
            }
            write_columns(&a.out, &header, &data)?;
        }
        OutKind::Svg => {
            let mut series = Vec::new();
            for (k, (name, y)) in cols.into_iter().enumerate() {
                series.push(Series::line(name.clone(), t.clone(), y));
                if let Some(b) = &band {
                    series.push(bands::bound_series(
                        format!("{name} {}", bands::label(a.confidence)),
                        &t,
                        &b[k].0,
                        &b[k].1,
                    ));
                }
            }
            let plot = Plot {
                title: "Step response".into(),
                x_label: "t [s]".into(),
                y_label: "y".into(),
                series,
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

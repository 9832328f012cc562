//! `lifted reproduce`: run the registered reproductions, print the table,
//! write `reproductions.json` and `index.html`.

use std::io::IsTerminal;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use lifted_tests::registry::{Experiment, experiments, find};
use lifted_tests::{CurveStyle, FigureData};
use serde::Serialize;

use crate::args::ReproduceArgs;
use crate::error::{CliError, CliResult, Context, input};
use crate::html::{esc, figure, html_table, page};
use crate::plot::{Marker, Plot, Series};
use crate::terminal::print_table;
use lifted_cli::service::figures::decimate;

/// One row of `reproductions.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// Spec section.
    pub id: String,
    /// Experiment title.
    pub experiment: String,
    /// The checked quantity.
    pub quantity: String,
    /// The paper's printed value.
    pub paper: Option<f64>,
    /// The reference value compared with.
    pub reference: Option<f64>,
    /// Our value (`null` when the run failed).
    pub ours: Option<f64>,
    /// The condition (tolerance).
    pub tolerance: String,
    /// Whether it holds.
    pub pass: bool,
    /// Provenance note or deviation.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// The figures of one experiment for the HTML page: (id, title, figures).
type Figures = (String, String, Vec<FigureData>);

fn run_one(e: &Experiment) -> (Vec<Row>, f64, Option<Figures>) {
    let start = Instant::now();
    let outcome = std::panic::catch_unwind(e.run);
    let secs = start.elapsed().as_secs_f64();
    let mut curves = None;
    let rows = match outcome {
        Ok(Ok(rep)) => {
            if !rep.plots.is_empty() {
                curves = Some((rep.section.clone(), rep.title.clone(), rep.plots.clone()));
            }
            let mut rows: Vec<Row> = rep
                .checks
                .iter()
                .map(|c| Row {
                    id: rep.section.clone(),
                    experiment: rep.title.clone(),
                    quantity: c.name.clone(),
                    paper: c.paper,
                    reference: c.reference,
                    ours: Some(c.value).filter(|v| v.is_finite()),
                    tolerance: c.condition.clone(),
                    pass: c.passed,
                    note: c.note.clone(),
                })
                .collect();
            if rows.is_empty() {
                rows.push(failure_row(e, "the experiment recorded no check".into()));
            }
            rows
        }
        Ok(Err(err)) => vec![failure_row(e, format!("run failed: {err}"))],
        Err(_) => vec![failure_row(e, "run panicked".into())],
    };
    (rows, secs, curves)
}

fn failure_row(e: &Experiment, msg: String) -> Row {
    Row {
        id: e.id.to_string(),
        experiment: e.title.to_string(),
        quantity: "run".into(),
        paper: None,
        reference: None,
        ours: None,
        tolerance: msg,
        pass: false,
        note: None,
    }
}

fn num(v: Option<f64>) -> String {
    v.map_or("–".into(), |x| format!("{x:.6}"))
}

/// `lifted reproduce`.
pub fn reproduce_cmd(a: &ReproduceArgs) -> CliResult<()> {
    let selected = match &a.only {
        Some(key) => {
            let f = find(key);
            if f.is_empty() {
                let known: Vec<String> = experiments()
                    .iter()
                    .map(|e| format!("{} ({})", e.id, e.name))
                    .collect();
                return Err(input(format!(
                    "--only {key}: no such experiment; registered: {}",
                    known.join(", ")
                )));
            }
            f
        }
        None => experiments(),
    };
    if a.list {
        for e in &selected {
            println!("{:<6} {:<22} {}", e.id, e.name, e.title);
        }
        return Ok(());
    }
    std::fs::create_dir_all(&a.out).ctx(format!("cannot create {}", a.out))?;
    let bar = if std::io::stderr().is_terminal() {
        let b = ProgressBar::new(selected.len() as u64);
        if let Ok(style) = ProgressStyle::with_template("{bar:30} {pos}/{len} {elapsed} {msg}") {
            b.set_style(style);
        }
        b
    } else {
        ProgressBar::hidden()
    };
    // Panics inside an experiment are caught and reported as a failed row;
    // silence the default hook's message while they run.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let mut rows = Vec::new();
    let mut timings = Vec::new();
    let mut plots = Vec::new();
    for e in &selected {
        bar.set_message(format!("{} {}", e.id, e.name));
        let (r, secs, curves) = run_one(e);
        rows.extend(r);
        plots.extend(curves);
        timings.push((e.id, secs));
        bar.inc(1);
    }
    std::panic::set_hook(hook);
    bar.finish_and_clear();

    let header = [
        "id",
        "experiment",
        "quantity",
        "paper (reference)",
        "ours",
        "tolerance",
        "pass",
    ];
    let table: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                r.id.clone(),
                r.experiment.clone(),
                r.quantity.clone(),
                match (r.paper, r.reference) {
                    (Some(p), _) => num(Some(p)),
                    (None, Some(x)) => format!("({})", num(Some(x))),
                    (None, None) => num(None),
                },
                num(r.ours),
                r.tolerance.clone(),
                if r.pass { "pass" } else { "FAIL" }.to_string(),
            ]
        })
        .collect();
    print_table(&header, &table);
    let json = serde_json::to_string_pretty(&rows).ctx("reproductions.json")?;
    let json_path = format!("{}/reproductions.json", a.out);
    std::fs::write(&json_path, json + "\n").ctx(format!("cannot write {json_path}"))?;
    let html_path = format!("{}/index.html", a.out);
    std::fs::write(&html_path, html(&rows, &timings, &plots)?)
        .ctx(format!("cannot write {html_path}"))?;
    let failed = rows.iter().filter(|r| !r.pass).count();
    println!(
        "{} checks, {} passed, {} failed; wrote {json_path} and {html_path}",
        rows.len(),
        rows.len() - failed,
        failed
    );
    if failed > 0 {
        return Err(CliError::Failed(format!(
            "{failed} reproduction check(s) failed"
        )));
    }
    Ok(())
}

/// A paper's figure as a plot: log10 ordinates when asked, long curves
/// decimated.
fn to_plot(f: &FigureData) -> Plot {
    let series = f
        .curves
        .iter()
        .map(|c| {
            let y: Vec<f64> = if f.log_y {
                c.y.iter()
                    .map(|v| if *v > 0.0 { v.log10() } else { f64::NAN })
                    .collect()
            } else {
                c.y.clone()
            };
            let (x, y) = decimate(&c.x, &y);
            match c.style {
                CurveStyle::Line => Series::line(c.name.clone(), x, y),
                CurveStyle::Points => Series::points(c.name.clone(), x, y, Marker::Dot),
            }
        })
        .collect();
    Plot {
        title: f.caption.split(':').next().unwrap_or("").to_string(),
        x_label: f.x_label.clone(),
        y_label: f.y_label.clone(),
        series,
        ..Default::default()
    }
}

fn html(rows: &[Row], timings: &[(&str, f64)], plots: &[Figures]) -> CliResult<String> {
    let failed = rows.iter().filter(|r| !r.pass).count();
    let mut body = format!(
        "<h1>Lifted reproductions</h1>\n<p>{} checks, {} passed, {} failed.</p>\n",
        rows.len(),
        rows.len() - failed,
        failed
    );
    let table: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                r.id.clone(),
                r.experiment.clone(),
                r.quantity.clone(),
                num(r.paper),
                num(r.reference),
                num(r.ours),
                r.tolerance.clone(),
                if r.pass { "pass" } else { "FAIL" }.to_string(),
                r.note.clone().unwrap_or_default(),
            ]
        })
        .collect();
    body += &html_table(
        &[
            "id",
            "experiment",
            "quantity",
            "paper",
            "reference",
            "ours",
            "tolerance",
            "pass",
            "note",
        ],
        &table,
        Some(7),
    );
    body += "<h2>Run times</h2>\n<ul>\n";
    for (id, s) in timings {
        body += &format!("<li>{}: {s:.2} s</li>\n", esc(id));
    }
    body += "</ul>\n";
    if !plots.is_empty() {
        body += "<h2 id=\"figures\">Figures of the papers</h2>\n<ul>\n";
        for (id, title, figs) in plots {
            for f in figs {
                body += &format!(
                    "<li><a href=\"#{}\">{}</a> ({})</li>\n",
                    esc(&f.id),
                    esc(&f.caption),
                    esc(&format!("{id}: {title}"))
                );
            }
        }
        body += "</ul>\n";
    }
    for (id, title, figs) in plots {
        body += &format!(
            "<h3 id=\"exp-{}\">{}: {}</h3>\n",
            esc(id),
            esc(id),
            esc(title)
        );
        for f in figs {
            body += &figure(&f.id, &f.caption, &to_plot(f), 900, 360)?;
        }
    }
    Ok(page("Lifted reproductions", &body))
}

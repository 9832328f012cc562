//! `lifted reproduce`: run the registered reproductions, print the table,
//! write `reproductions.json` and `index.html`.

use std::collections::HashSet;
use std::io::IsTerminal;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use lifted_tests::registry::{Experiment, experiments, find};
use lifted_tests::report::{Curve, CurveStyle, FigureData};
use serde::Serialize;

use crate::args::ReproduceArgs;
use crate::error::{CliError, CliResult, Context, input};
use crate::escape::{html as esc, id as anchor};
use crate::html::{figure, html_table, page};
use crate::plot::{Marker, Plot, Series};
use crate::terminal::print_table;

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

/// What one experiment gave: its rows, run time and figures.
struct Outcome {
    experiment: Experiment,
    rows: Vec<Row>,
    secs: f64,
    plots: Vec<FigureData>,
}

/// One figure of `reproductions.json`: the experiment it belongs to and
/// the figure's data.
#[derive(Serialize)]
struct FigureRecord<'a> {
    /// Spec section of the experiment.
    section: &'a str,
    /// Registry name of the experiment.
    experiment: &'a str,
    #[serde(flatten)]
    figure: &'a FigureData,
}

/// The content of `reproductions.json`.
#[derive(Serialize)]
struct Output<'a> {
    rows: Vec<&'a Row>,
    figures: Vec<FigureRecord<'a>>,
}

fn run_one(e: &Experiment) -> Outcome {
    let start = Instant::now();
    let outcome = std::panic::catch_unwind(e.run);
    let secs = start.elapsed().as_secs_f64();
    let mut plots = Vec::new();
    let rows = match outcome {
        Ok(Ok(rep)) => {
            plots = rep.plots.clone();
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
    Outcome {
        experiment: *e,
        rows,
        secs,
        plots,
    }
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
    let mut outcomes = Vec::new();
    for e in &selected {
        bar.set_message(format!("{} {}", e.id, e.name));
        outcomes.push(run_one(e));
        bar.inc(1);
    }
    std::panic::set_hook(hook);
    bar.finish_and_clear();
    let rows: Vec<&Row> = outcomes.iter().flat_map(|o| &o.rows).collect();

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
    let output = Output {
        rows: rows.clone(),
        figures: outcomes
            .iter()
            .flat_map(|o| {
                o.plots.iter().map(|f| FigureRecord {
                    section: o.experiment.id,
                    experiment: o.experiment.name,
                    figure: f,
                })
            })
            .collect(),
    };
    let json = serde_json::to_string_pretty(&output).ctx("reproductions.json")?;
    let json_path = format!("{}/reproductions.json", a.out);
    std::fs::write(&json_path, json + "\n").ctx(format!("cannot write {json_path}"))?;
    let html_path = format!("{}/index.html", a.out);
    std::fs::write(&html_path, html(&outcomes)?).ctx(format!("cannot write {html_path}"))?;
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

/// Most points drawn per curve (longer curves are decimated by a stride).
const MAX_POINTS: usize = 4000;

/// The page: summary, figure and experiment indexes, then one section per
/// experiment with its checks and its figures.
fn html(outcomes: &[Outcome]) -> CliResult<String> {
    let rows: Vec<&Row> = outcomes.iter().flat_map(|o| &o.rows).collect();
    let failed = rows.iter().filter(|r| !r.pass).count();
    let mut body = format!(
        "<h1>Lifted reproductions</h1>\n<p>{} checks, {} passed, {} failed.</p>\n",
        rows.len(),
        rows.len() - failed,
        failed
    );
    let mut ids = HashSet::new();
    let anchors: Vec<Vec<String>> = outcomes
        .iter()
        .map(|o| o.plots.iter().map(|f| unique(&mut ids, &f.id)).collect())
        .collect();
    body += &figure_index(outcomes, &anchors);
    body += &experiment_index(outcomes);
    for (o, a) in outcomes.iter().zip(&anchors) {
        body += &section(o, a)?;
    }
    Ok(page("Lifted reproductions", &body))
}

/// `id`, suffixed with "-2", "-3", … if already taken (the raw text:
/// [`anchor`] writes it as an HTML id, distinct texts giving distinct ids).
fn unique(taken: &mut HashSet<String>, id: &str) -> String {
    let mut a = id.to_string();
    let mut k = 2;
    while !taken.insert(a.clone()) {
        a = format!("{id}-{k}");
        k += 1;
    }
    a
}

fn experiment_anchor(e: &Experiment) -> String {
    format!("exp-{}", anchor(e.name))
}

/// The figure's short name: its caption up to the first ':' (e.g.
/// "Zhu (2000) Fig. 1").
fn short(f: &FigureData) -> &str {
    f.caption.split(':').next().unwrap_or(&f.caption).trim()
}

fn figure_index(outcomes: &[Outcome], anchors: &[Vec<String>]) -> String {
    let mut s = String::from("<h2 id=\"figures\">Figures</h2>\n");
    if anchors.iter().all(Vec::is_empty) {
        return s + "<p>No experiment recorded a figure.</p>\n";
    }
    s += "<ul>\n";
    for (o, a) in outcomes.iter().zip(anchors) {
        if o.plots.is_empty() {
            continue;
        }
        let links: Vec<String> = o
            .plots
            .iter()
            .zip(a)
            .map(|(f, id)| format!("<a href=\"#{}\">{}</a>", anchor(id), esc(short(f))))
            .collect();
        s += &format!(
            "<li><a href=\"#{}\">{} {}</a>: {}</li>\n",
            experiment_anchor(&o.experiment),
            esc(o.experiment.id),
            esc(o.experiment.title),
            links.join(", ")
        );
    }
    s + "</ul>\n"
}

fn experiment_index(outcomes: &[Outcome]) -> String {
    let mut s = String::from("<h2 id=\"experiments\">Experiments</h2>\n<ul>\n");
    for o in outcomes {
        let failed = o.rows.iter().filter(|r| !r.pass).count();
        s += &format!(
            "<li{}><a href=\"#{}\">{} {}</a>: {} — {} of {} checks passed, {} figure(s), {:.2} s</li>\n",
            if failed > 0 { " class=\"fail\"" } else { "" },
            experiment_anchor(&o.experiment),
            esc(o.experiment.id),
            esc(o.experiment.name),
            esc(o.experiment.title),
            o.rows.len() - failed,
            o.rows.len(),
            o.plots.len(),
            o.secs
        );
    }
    s + "</ul>\n"
}

/// One experiment: heading, its checks, its figures.
fn section(o: &Outcome, anchors: &[String]) -> CliResult<String> {
    let e = &o.experiment;
    let mut s = format!(
        "<section id=\"{}\">\n<h2>{} — {}</h2>\n<p><code>{}</code>, {:.2} s</p>\n",
        experiment_anchor(e),
        esc(e.id),
        esc(e.title),
        esc(e.name),
        o.secs
    );
    let table: Vec<Vec<String>> = o
        .rows
        .iter()
        .map(|r| {
            vec![
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
    s += &html_table(
        &[
            "quantity",
            "paper",
            "reference",
            "ours",
            "tolerance",
            "pass",
            "note",
        ],
        &table,
        Some(5),
    );
    for (f, id) in o.plots.iter().zip(anchors) {
        s += &figure(id, &f.caption, &plot(f), 900, 360)?;
    }
    Ok(s + "</section>\n")
}

/// The SVG plot of a figure: log10 ordinates for `log_y`, long curves
/// decimated, staircases expanded; abscissae labelled `log10 …` (the
/// experiments' Bode plots) get decade ticks labelled 10^k.
fn plot(f: &FigureData) -> Plot {
    let log_x = f.x_label.strip_prefix("log10 ");
    Plot {
        title: short(f).to_string(),
        x_label: log_x.unwrap_or(&f.x_label).to_string(),
        log_x: log_x.is_some(),
        y_label: if f.log_y {
            format!("log10 {}", f.y_label)
        } else {
            f.y_label.clone()
        },
        series: f.curves.iter().map(|c| series(c, f.log_y)).collect(),
        ..Default::default()
    }
}

/// Every `stride`-th point (and the last), so that at most `max` remain.
fn decimate(x: &[f64], y: &[f64], max: usize) -> (Vec<f64>, Vec<f64>) {
    let n = x.len().min(y.len());
    if n <= max {
        return (x[..n].to_vec(), y[..n].to_vec());
    }
    let stride = n.div_ceil(max.max(2) - 1).max(1);
    let mut idx: Vec<usize> = (0..n).step_by(stride).collect();
    if n > 0 && idx.last() != Some(&(n - 1)) {
        idx.push(n - 1);
    }
    (
        idx.iter().map(|&k| x[k]).collect(),
        idx.iter().map(|&k| y[k]).collect(),
    )
}

/// One curve as a plot series.
fn series(c: &Curve, log_y: bool) -> Series {
    let y: Vec<f64> = if log_y {
        c.y.iter()
            .map(|&v| if v > 0.0 { v.log10() } else { f64::NAN })
            .collect()
    } else {
        c.y.clone()
    };
    match c.style {
        CurveStyle::Line => {
            let (x, y) = decimate(&c.x, &y, MAX_POINTS);
            Series::line(c.name.clone(), x, y)
        }
        CurveStyle::Points => {
            let (x, y) = decimate(&c.x, &y, MAX_POINTS);
            Series::points(c.name.clone(), x, y, Marker::Dot)
        }
        CurveStyle::Steps => {
            // the staircase doubles the points
            let (x, y) = decimate(&c.x, &y, MAX_POINTS / 2);
            let (sx, sy) = staircase(&x, &y);
            Series::line(c.name.clone(), sx, sy)
        }
    }
}

/// The staircase through (x_k, y_k): y_k held until x_{k+1}.
fn staircase(x: &[f64], y: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mut sx = Vec::with_capacity(2 * x.len());
    let mut sy = Vec::with_capacity(2 * y.len());
    for (k, (&xk, &yk)) in x.iter().zip(y).enumerate() {
        sx.push(xk);
        sy.push(yk);
        if let Some(&next) = x.get(k + 1) {
            sx.push(next);
            sy.push(yk);
        }
    }
    (sx, sy)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_the_ends_and_the_bound() {
        let x: Vec<f64> = (0..10_001).map(f64::from).collect();
        let (dx, dy) = decimate(&x, &x, MAX_POINTS);
        assert!(dx.len() <= MAX_POINTS && dx.len() > MAX_POINTS / 2);
        assert_eq!((dx[0], dx[dx.len() - 1]), (0.0, 10_000.0));
        assert_eq!(dx, dy);
        let (sx, _) = decimate(&x[..10], &x[..10], MAX_POINTS);
        assert_eq!(sx.len(), 10);
    }

    #[test]
    fn staircase_holds_each_value() {
        let (x, y) = staircase(&[0.0, 1.0, 2.0], &[5.0, 6.0, 7.0]);
        assert_eq!(x, vec![0.0, 1.0, 1.0, 2.0, 2.0]);
        assert_eq!(y, vec![5.0, 5.0, 6.0, 6.0, 7.0]);
    }

    #[test]
    fn log_axis_drops_non_positive_values() {
        let f = FigureData::new("a b/c", "Zhu (2000) Fig. 6: order selection", "i", "λ")
            .with_log_y()
            .with_curve(Curve::sampled(
                "λ",
                1.0,
                1.0,
                vec![100.0, 1.0, -1.0],
                CurveStyle::Points,
            ));
        let p = plot(&f);
        assert_eq!(p.y_label, "log10 λ");
        assert_eq!(p.title, "Zhu (2000) Fig. 6");
        assert_eq!(p.series[0].y[..2], [2.0, 0.0]);
        assert!(p.series[0].y[2].is_nan());
        let mut taken = HashSet::new();
        assert_eq!(anchor(&unique(&mut taken, &f.id)), "a_20b_2fc");
        assert_eq!(anchor(&unique(&mut taken, &f.id)), "a_20b_2fc-2");
    }
}

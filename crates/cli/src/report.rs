//! `lifted report`: one self-contained HTML page with inline SVG plots.

use crate::args::ReportArgs;
use crate::error::{CliResult, Context};
use crate::model::{bode_grid, bode_plots, channel_names, pz_plot, step_plot};
use crate::plot::{Marker, Plot, Series, svg};
use crate::validate::{TABLE_HEADER, load_for_validation, table_rows, validate_model};

/// Most points drawn per time series (longer records are decimated by a
/// stride; the page stays small).
const MAX_POINTS: usize = 4000;

/// Escapes text for HTML.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn stride(n: usize) -> usize {
    n.div_ceil(MAX_POINTS).max(1)
}

fn decimate(t: &[f64], y: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let s = stride(t.len());
    (
        t.iter().step_by(s).copied().collect(),
        y.iter().step_by(s).copied().collect(),
    )
}

/// A `<figure>` with an inline SVG.
pub fn figure(id: &str, caption: &str, plot: &Plot, w: u32, h: u32) -> CliResult<String> {
    Ok(format!(
        "<figure id=\"{id}\">\n{}\n<figcaption>{}</figcaption>\n</figure>\n",
        svg(plot, w, h)?,
        esc(caption)
    ))
}

/// The page skeleton.
pub fn page(title: &str, body: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{}</title>\n<style>\nbody {{ font-family: sans-serif; max-width: 1000px; margin: 2em auto; }}\ntable {{ border-collapse: collapse; }}\ntd, th {{ border: 1px solid #999; padding: 0.2em 0.6em; text-align: right; }}\nth {{ background: #eee; }}\ntd:first-child {{ text-align: left; }}\n.fail {{ color: #b00; font-weight: bold; }}\nfigure {{ margin: 1em 0; }}\n</style>\n</head>\n<body>\n{}\n</body>\n</html>\n",
        esc(title),
        body
    )
}

/// An HTML table.
pub fn html_table(header: &[&str], rows: &[Vec<String>], fail_col: Option<usize>) -> String {
    let mut s = String::from("<table>\n<thead><tr>");
    for h in header {
        s += &format!("<th>{}</th>", esc(h));
    }
    s += "</tr></thead>\n<tbody>\n";
    for r in rows {
        let failed = fail_col.is_some_and(|c| r.get(c).is_some_and(|v| v == "no" || v == "FAIL"));
        s += if failed {
            "<tr class=\"fail\">"
        } else {
            "<tr>"
        };
        for c in r {
            s += &format!("<td>{}</td>", esc(c));
        }
        s += "</tr>\n";
    }
    s += "</tbody>\n</table>\n";
    s
}

/// The order-selection plot from the model file's diagnostics, if present.
fn order_plot(diag: &serde_json::Value) -> Option<Plot> {
    let os = diag.get("order_selection")?;
    let values: Vec<f64> = os
        .get("values")?
        .as_array()?
        .iter()
        .filter_map(|v| v.as_f64())
        .collect();
    if values.is_empty() {
        return None;
    }
    let kind = os
        .get("kind")
        .and_then(|k| k.as_str())
        .unwrap_or("singular values");
    let order = os.get("order").and_then(serde_json::Value::as_u64);
    let x: Vec<f64> = (1..=values.len()).map(|i| i as f64).collect();
    let y: Vec<f64> = values
        .iter()
        .map(|v| if *v > 0.0 { v.log10() } else { f64::NAN })
        .collect();
    let mut plot = Plot {
        title: format!("Order selection: {kind}"),
        x_label: "index".into(),
        y_label: "log10 value".into(),
        series: vec![Series::points(kind, x, y, Marker::Dot)],
        ..Default::default()
    };
    if let Some(n) = order {
        plot.vlines
            .push((n as f64 + 0.5, format!("chosen order {n}")));
    }
    Some(plot)
}

/// `lifted report`.
pub fn report_cmd(a: &ReportArgs) -> CliResult<()> {
    let (file, data) = load_for_validation(&a.model, &a.data, &a.columns, a.detrend)?;
    let model = &file.model;
    let v = validate_model(&file, &data, a.lags, &a.data)?;
    let ts = data.ts();
    let n = data.len();
    let t: Vec<f64> = (0..n).map(|k| k as f64 * ts).collect();
    let (un, _) = channel_names(model);
    let mut body = String::new();
    body += &format!(
        "<h1>Identification report</h1>\n<p>Model <code>{}</code> (method {}, order {}, {} input(s), {} output(s), T = {} s); data <code>{}</code> ({} samples at T = {} s).</p>\n",
        esc(&a.model),
        esc(file.method.as_deref().unwrap_or("unknown")),
        model.order(),
        model.n_inputs(),
        model.n_outputs(),
        model
            .ts()
            .map_or("continuous".to_string(), |t| t.to_string()),
        esc(&a.data),
        n,
        ts
    );

    body += "<h2>Excitation</h2>\n";
    let mut exc = Plot {
        title: "Input signals".into(),
        x_label: "t [s]".into(),
        y_label: "u".into(),
        ..Default::default()
    };
    for (j, name) in un.iter().enumerate() {
        let u: Vec<f64> = data.u().column(j).iter().copied().collect();
        let (tt, uu) = decimate(&t, &u);
        exc.series.push(Series::line(name.clone(), tt, uu));
    }
    body += &figure(
        "excitation",
        "The measured inputs (excitation).",
        &exc,
        900,
        300,
    )?;

    body += "<h2>Measured and model output</h2>\n";
    for o in &v.outputs {
        let mt: Vec<f64> = o.instants.iter().map(|&k| k as f64 * ts).collect();
        let (mt, my) = decimate(&mt, &o.measured);
        let (st, sy) = decimate(&t, &o.simulated);
        let slow = o.samples < n;
        let plot = Plot {
            title: format!("{}: measured vs simulated (fit {:.2} %)", o.name, o.fit),
            x_label: "t [s]".into(),
            y_label: o.name.clone(),
            series: vec![
                if slow {
                    Series::points("measured", mt, my, Marker::Dot)
                } else {
                    Series::line("measured", mt, my)
                },
                Series::line("model (simulated)", st, sy),
            ],
            ..Default::default()
        };
        body += &figure(
            &format!("fit-{}", o.name),
            &format!(
                "Output {}: measurement and the model's simulated response from rest.",
                o.name
            ),
            &plot,
            900,
            320,
        )?;
    }

    body += "<h2>Order selection</h2>\n";
    match order_plot(&file.diagnostics) {
        Some(p) => {
            body += &figure(
                "order-selection",
                "Singular values (subspace) or the Λ diagonal (q-Markov Cover) on a log scale; the vertical line separates the chosen order.",
                &p,
                700,
                320,
            )?
        }
        None => body += "<p>The model file carries no order-selection data.</p>\n",
    }

    body += "<h2>Step response</h2>\n";
    body += &figure(
        "step",
        "Unit step on each input, zero initial state.",
        &step_plot(model)?,
        800,
        320,
    )?;

    body += "<h2>Bode plot</h2>\n";
    let omega = bode_grid(model, None, None, 300)?;
    let (mag, ph) = bode_plots(model, &omega)?;
    body += &figure(
        "bode-magnitude",
        "Magnitude of each input-output pair.",
        &mag,
        800,
        300,
    )?;
    body += &figure(
        "bode-phase",
        "Phase of each input-output pair.",
        &ph,
        800,
        300,
    )?;

    body += "<h2>Poles and zeros</h2>\n";
    body += &figure(
        "pole-zero",
        if model.is_discrete() {
            "Poles (×) and transmission zeros (○) in the z-plane, unit circle drawn."
        } else {
            "Poles (×) and transmission zeros (○) in the s-plane."
        },
        &pz_plot(model)?,
        500,
        500,
    )?;

    body += "<h2>Validation</h2>\n";
    let rows: Vec<Vec<String>> = table_rows(&v).into_iter().map(|r| r.to_vec()).collect();
    body += &html_table(&TABLE_HEADER, &rows, Some(6));
    body += &format!(
        "<p>Fit % = 100 (1 − ‖y − ŷ‖/‖y − ȳ‖) with ŷ simulated from rest; residual autocorrelation over τ = 1…{0} and input–residual cross-correlation over τ = −{0}…{0}, 99 % bound ±2.576/√N.</p>\n",
        v.lags
    );
    std::fs::write(&a.out, page("Lifted identification report", &body))
        .ctx(format!("cannot write {}", a.out))?;
    println!("wrote {}", a.out);
    Ok(())
}

//! The identification report: one self-contained HTML page with inline SVG
//! plots (excitation, measured vs simulated outputs, order selection, step
//! response, Bode, pole-zero map, validation table). Written by
//! `lifted report` and downloaded from `lifted studio`.

use lifted_lti::{Dataset, ModelFile};

use crate::error::{CliResult, Context};
use crate::escape::html as esc;
use crate::html::{figure, html_table, page, svg_figure};
use crate::service::bands;
use crate::service::figures::{
    bode_grid, criterion_plot, excitation_plot, order_plot, pz_plot, response_plot, step_data,
};
use crate::service::models::channel_names;
use crate::service::pairs::{bode_pairs, pairs_svg, step_pairs};
use crate::service::validation::{TABLE_HEADER, Validation, table_rows, unstable_note};

/// The confidence level of the report's bands (models with a parameter
/// covariance): 95 %, the level MATLAB's `showConfidence` and `lifted
/// bode`/`step` draw by default.
pub const REPORT_CONFIDENCE: f64 = 0.95;

/// The report page of `file` validated on `data` (`v`, from
/// [`crate::service::validation::validate_model`]); the labels name the
/// model and the data in the page's first paragraph.
pub fn render(
    file: &ModelFile,
    data: &Dataset,
    v: &Validation,
    model_label: &str,
    data_label: &str,
) -> CliResult<String> {
    let model = &file.model;
    let ts = data.ts();
    let n = data.len();
    let (un, _) = channel_names(model);
    let mut body = String::new();
    body += &format!(
        "<h1>Identification report</h1>\n<p>Model <code>{}</code> (method {}, order {}, {} input(s), {} output(s), T = {} s); data <code>{}</code> ({} samples at T = {} s).</p>\n",
        esc(model_label),
        esc(file.method.as_deref().unwrap_or("unknown")),
        model.order(),
        model.n_inputs(),
        model.n_outputs(),
        model
            .ts()
            .map_or("continuous".to_string(), |t| t.to_string()),
        esc(data_label),
        n,
        ts
    );

    let diagnostics = lifted_workflow::Diagnostics::of(file);
    body += &diagnostics_section(&file.diagnostics);

    body += "<h2>Excitation</h2>\n";
    let exc = excitation_plot(data, &un);
    body += &figure(
        "excitation",
        "The measured inputs (excitation).",
        &exc,
        900,
        300,
    )?;

    body += "<h2>Measured and model output</h2>\n";
    for o in &v.outputs {
        let plot = response_plot(o, ts, n, v.stable());
        body += &figure(
            &format!("fit-{}", o.name),
            &format!(
                "Output {}: measurement and the model's simulated response {}.",
                o.name,
                start_of(v)
            ),
            &plot,
            900,
            320,
        )?;
    }

    body += "<h2>Order selection</h2>\n";
    match order_plot(&diagnostics) {
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
    if let Some(p) = criterion_plot(&diagnostics) {
        let held_out = diagnostics
            .structure_selection
            .as_ref()
            .is_some_and(|s| s.candidates.is_some());
        let caption = if held_out {
            "The order rule's values per order: the held-out simulation fit of the best structure of each order, with the held-out fit of the model each shortlisted order delivers (refined where the held-out blocks prefer it); the vertical line marks the order chosen.".to_string()
        } else {
            let rule = diagnostics
                .order_criterion
                .as_ref()
                .map_or("the rule", |c| c.criterion.as_str());
            format!(
                "The order rule's values per order ({}; the smallest is chosen); the vertical line marks the order chosen.",
                match rule {
                    "Aicc" => "AICc on the output-error fits of the whole record",
                    "Aic" => "Akaike's information criterion",
                    "Bic" => "the Bayesian information criterion",
                    "Svc" => "Bauer's singular value criterion",
                    other => other,
                }
            )
        };
        body += &figure("order-criterion", &caption, &p, 700, 340)?;
    }

    let one = [(String::new(), model)];
    // A model with a parameter covariance gets its confidence bands
    // (`service::bands`) on the step and Bode figures.
    let poly = bands::Uncertain::of(file);
    let band_note = format!(
        " Dashed: the {:.0} % confidence band (± z σ, first-order propagation of the parameter covariance).",
        100.0 * REPORT_CONFIDENCE
    );
    // The band's sentence in a caption when the figure has one.
    let note_if = |has_band: bool| if has_band { band_note.as_str() } else { "" };
    body += "<h2>Step response</h2>\n";
    let mut step_fig = step_pairs(&one)?;
    let (t, cols) = step_data(model, None, None)?;
    let step_band = bands::step_bounds(poly, &cols, REPORT_CONFIDENCE)?;
    if let Some(b) = &step_band {
        bands::add_step_band(&mut step_fig, &t, b, REPORT_CONFIDENCE);
    }
    body += &svg_figure(
        "step",
        &format!(
            "Unit step on each input, zero initial state: one axes per output (rows) and input (columns).{}",
            note_if(step_band.is_some())
        ),
        &pairs_svg(&step_fig, 800, 260)?,
    );

    body += "<h2>Bode plot</h2>\n";
    let omega = bode_grid(model, None, None, 300)?;
    let mut bode_fig = bode_pairs(&one, &omega)?;
    let response = model.bode(&omega).ctx("bode")?;
    let bode_band = bands::bode_bounds(poly, &response, &omega, REPORT_CONFIDENCE)?;
    if let Some(b) = &bode_band {
        bands::add_bode_band(&mut bode_fig, &omega, b, REPORT_CONFIDENCE);
    }
    body += &svg_figure(
        "bode",
        &format!(
            "Magnitude over phase of each input–output pair: one axes per output (rows) and input (columns).{}",
            note_if(bode_band.is_some())
        ),
        &pairs_svg(&bode_fig, 800, 220)?,
    );

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
    let rows: Vec<Vec<String>> = table_rows(v).into_iter().map(|r| r.to_vec()).collect();
    if let Some(note) = unstable_note(v) {
        body += &format!(
            "<p class=\"warning\"><strong>Warning:</strong> {}.</p>\n",
            esc(&note)
        );
    }
    body += &html_table(&TABLE_HEADER, &rows, Some(6));
    body += &format!(
        "<p>Fit % = 100 (1 − ‖y − ŷ‖/‖y − ȳ‖) with ŷ simulated {1}; autocorrelation of the {2} residual over τ = 1…{0} and input–residual cross-correlation over τ = −{0}…{0}, 99 % bound ±2.576/√N.</p>\n",
        v.lags,
        start_of(v),
        v.residual.name()
    );
    Ok(page("Lifted identification report", &body))
}

/// Where the simulation started: "from the initial state fitted by least
/// squares" or "from rest".
fn start_of(v: &Validation) -> &'static str {
    if v.x0.is_some() {
        "from the initial state fitted to the record by least squares"
    } else {
        "from rest"
    }
}

/// The identification's verdicts a reader must see before the figures:
/// the feedback test's (`diagnostics.feedback`) and the warnings, each
/// escaped as element text. Empty when the model file has neither.
fn diagnostics_section(d: &serde_json::Value) -> String {
    let mut items = Vec::new();
    if let Some(f) = d.get("feedback") {
        let verdict = f.get("verdict").and_then(|v| v.as_str());
        let note = f.get("note").and_then(|v| v.as_str());
        let line = match (f.get("detected").and_then(|v| v.as_bool()), verdict, note) {
            (Some(true), Some(v), _) => format!("Feedback: closed loop detected: {v}."),
            (Some(false), Some(v), _) => format!("Feedback: {v}."),
            (_, _, Some(n)) => format!("Feedback: {n}."),
            _ => String::new(),
        };
        if !line.is_empty() {
            items.push(line);
        }
    }
    if let Some(w) = d.get("warnings").and_then(|w| w.as_array()) {
        items.extend(
            w.iter()
                .filter_map(|s| s.as_str())
                .map(|s| format!("Warning: {s}")),
        );
    }
    if items.is_empty() {
        return String::new();
    }
    let list: String = items
        .iter()
        .map(|i| format!("<li>{}</li>\n", esc(i)))
        .collect();
    format!("<h2>Diagnostics</h2>\n<ul class=\"diagnostics\">\n{list}</ul>\n")
}

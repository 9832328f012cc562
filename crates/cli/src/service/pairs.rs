//! Figures of a multivariable model with one axes per input–output pair,
//! as MATLAB's ident draws them: step responses and Bode diagrams in a
//! grid, outputs down and inputs across. Each axes is titled `y ← u`,
//! shortened to fit its width (the full names on hover, an SVG `<title>`
//! written through [`crate::escape::html`]); its legend names the models
//! (and the data's empirical response) drawn in it, so several models
//! overlaid on the model board each keep their own entry.

use lifted_lti::StateSpace;
use lifted_lti::spectral::FrequencyResponse;

use crate::error::{CliResult, Context};
use crate::escape;
use crate::plot::{Marker, Plot, Series, TITLE_CHAR, shortened, svg};
use crate::service::figures::step_data;
use crate::service::models::channel_names;

/// One figure: an `n_y × n_u` grid of cells, each a column of plots
/// (a step response; or a Bode magnitude over its phase).
#[derive(Debug, Clone)]
pub struct PairFigure {
    /// Outputs (grid rows).
    pub n_y: usize,
    /// Inputs (grid columns).
    pub n_u: usize,
    /// Per cell, row-major (output i, input j at `i * n_u + j`): the full
    /// label `y ← u` and the plots stacked in it.
    pub cells: Vec<(String, Vec<Plot>)>,
}

fn check_same_channels(models: &[(String, &StateSpace)]) -> CliResult<(usize, usize)> {
    let (ny, nu) = match models.first() {
        Some((_, m)) => (m.n_outputs(), m.n_inputs()),
        None => return Err(crate::error::input("no model to draw")),
    };
    if let Some((label, _)) = models
        .iter()
        .find(|(_, m)| (m.n_outputs(), m.n_inputs()) != (ny, nu))
    {
        return Err(crate::error::input(format!(
            "{label}: {ny} output(s) and {nu} input(s) expected, as the first model"
        )));
    }
    Ok((ny, nu))
}

/// The pair labels `y ← u` of `m`, row-major.
fn pair_labels(m: &StateSpace) -> Vec<String> {
    let (un, yn) = channel_names(m);
    let mut out = Vec::with_capacity(un.len() * yn.len());
    for y in &yn {
        for u in &un {
            out.push(format!("{y} ← {u}"));
        }
    }
    out
}

/// The legend name of a model: its label, or `model` for a lone one.
fn series_name(models: &[(String, &StateSpace)], k: usize) -> String {
    if models.len() == 1 && models[k].0.is_empty() {
        "model".into()
    } else {
        models[k].0.clone()
    }
}

/// Unit-step responses of `models` (labels, models of the same channels),
/// one axes per pair, on the first model's time grid. O(models · n_y ·
/// n_u · samples).
pub fn step_pairs(models: &[(String, &StateSpace)]) -> CliResult<PairFigure> {
    let (ny, nu) = check_same_channels(models)?;
    let labels = pair_labels(models[0].1);
    let mut cells: Vec<(String, Vec<Plot>)> = labels
        .iter()
        .map(|l| {
            (
                l.clone(),
                vec![Plot {
                    title: l.clone(),
                    x_label: "t [s]".into(),
                    y_label: "y".into(),
                    ..Default::default()
                }],
            )
        })
        .collect();
    let first = step_data(models[0].1, None, None)?;
    let (n, dt) = (first.0.len(), first.0.get(1).copied().unwrap_or(1.0));
    for k in 0..models.len() {
        let (t, cols) = if k == 0 {
            first.clone()
        } else {
            let m = models[k].1;
            step_data(m, Some(n), if m.ts().is_some() { None } else { Some(dt) })?
        };
        // step_data's columns: per input j, per output i.
        for (c, (_, y)) in cols.into_iter().enumerate() {
            let (j, i) = (c / ny, c % ny);
            cells[i * nu + j].1[0]
                .series
                .push(Series::line(series_name(models, k), t.clone(), y));
        }
    }
    Ok(PairFigure {
        n_y: ny,
        n_u: nu,
        cells,
    })
}

/// Bode diagrams of `models` at `omega` (rad/s), one cell per pair with
/// the magnitude (dB) over the phase (degrees); the Nyquist frequency
/// marked on a discrete model's magnitude. O(models · |ω| · n³).
pub fn bode_pairs(models: &[(String, &StateSpace)], omega: &[f64]) -> CliResult<PairFigure> {
    let (ny, nu) = check_same_channels(models)?;
    let labels = pair_labels(models[0].1);
    let lw: Vec<f64> = omega.iter().map(|w| w.log10()).collect();
    let mut cells: Vec<(String, Vec<Plot>)> = labels
        .iter()
        .map(|l| {
            let mut mag = Plot {
                title: l.clone(),
                x_label: "ω [rad/s]".into(),
                y_label: "|G| [dB]".into(),
                log_x: true,
                ..Default::default()
            };
            if let Some(ts) = models[0].1.ts() {
                mag.vlines
                    .push(((std::f64::consts::PI / ts).log10(), "Nyquist".into()));
            }
            let ph = Plot {
                x_label: "ω [rad/s]".into(),
                y_label: "phase [deg]".into(),
                log_x: true,
                ..Default::default()
            };
            (l.clone(), vec![mag, ph])
        })
        .collect();
    for (k, (_, m)) in models.iter().enumerate() {
        let b = m.bode(omega).ctx("bode")?;
        for i in 0..ny {
            for j in 0..nu {
                let db: Vec<f64> = b
                    .magnitude
                    .iter()
                    .map(|g| 20.0 * g[(i, j)].max(1e-300).log10())
                    .collect();
                let deg: Vec<f64> = b.phase_deg.iter().map(|g| g[(i, j)]).collect();
                let name = series_name(models, k);
                let cell = &mut cells[i * nu + j].1;
                cell[0]
                    .series
                    .push(Series::line(name.clone(), lw.clone(), db));
                cell[1].series.push(Series::line(name, lw.clone(), deg));
            }
        }
    }
    Ok(PairFigure {
        n_y: ny,
        n_u: nu,
        cells,
    })
}

/// The model's phase (the first series of `ph`, in degrees over log10 ω)
/// at `x` = log10 ω, linearly interpolated; `None` outside its range.
fn phase_at(ph: &Plot, x: f64) -> Option<f64> {
    let s = ph.series.first()?;
    let k = s.x.partition_point(|&v| v < x);
    if k == 0 {
        return (s.x.first() == Some(&x)).then(|| s.y[0]);
    }
    if k >= s.x.len() {
        return None;
    }
    let (x0, x1, y0, y1) = (s.x[k - 1], s.x[k], s.y[k - 1], s.y[k]);
    Some(if x1 > x0 {
        y0 + (y1 - y0) * (x - x0) / (x1 - x0)
    } else {
        y1
    })
}

/// Adds the empirical frequency response `g` of the data (Welch's
/// estimate) to a [`bode_pairs`] figure: markers per pair within the
/// figure's frequency range. Each phase is put on the 360° branch nearest
/// the (first) model's phase at its frequency, so a noisy estimate's
/// unwrapping cannot drift to ±2000° and flatten the model's curve.
pub fn add_empirical_pairs(fig: &mut PairFigure, g: &FrequencyResponse) {
    let lw: Vec<f64> = g.omega.iter().map(|w| w.log10()).collect();
    for i in 0..fig.n_y {
        for j in 0..fig.n_u {
            let cell = &mut fig.cells[i * fig.n_u + j].1;
            let [mag, ph] = &mut cell[..] else {
                continue;
            };
            let (lo, hi) = mag
                .series
                .first()
                .map(|s| {
                    s.x.iter()
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                            (a.min(x), b.max(x))
                        })
                })
                .unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
            let mags = g.magnitude(i, j);
            let phs = g.phase_deg(i, j);
            let (mut x, mut db, mut deg) = (Vec::new(), Vec::new(), Vec::new());
            for k in 0..lw.len() {
                if !(lw[k] >= lo && lw[k] <= hi && mags[k].is_finite()) {
                    continue;
                }
                x.push(lw[k]);
                db.push(20.0 * mags[k].max(1e-300).log10());
                deg.push(match phase_at(ph, lw[k]) {
                    Some(model) if phs[k].is_finite() => {
                        phs[k] - 360.0 * ((phs[k] - model) / 360.0).round()
                    }
                    _ => phs[k],
                });
            }
            let name = "data (Welch)";
            mag.series
                .push(Series::points(name, x.clone(), db, Marker::Dot));
            ph.series.push(Series::points(name, x, deg, Marker::Dot));
        }
    }
}

/// The figure as one SVG document, `width` pixels wide at most per row of
/// cells (each cell at least 280 wide), each plot of a cell `plot_h` high.
pub fn pairs_svg(fig: &PairFigure, width: u32, plot_h: u32) -> CliResult<String> {
    let cols = fig.n_u.max(1) as u32;
    let cell_w = (width / cols).max(280);
    let per_cell = fig.cells.first().map_or(1, |c| c.1.len().max(1)) as u32;
    let cell_h = plot_h * per_cell;
    let (w, h) = (cell_w * cols, cell_h * fig.n_y.max(1) as u32);
    let max_chars = ((cell_w.saturating_sub(20)) / TITLE_CHAR) as usize;
    let mut body = String::new();
    for (c, (label, plots)) in fig.cells.iter().enumerate() {
        let (row, col) = (c as u32 / cols, c as u32 % cols);
        body += &format!("<g>\n<title>{}</title>\n", escape::html(label));
        for (k, p) in plots.iter().enumerate() {
            let mut p = p.clone();
            p.title = shortened(&p.title, max_chars);
            let one = svg(&p, cell_w, plot_h)?;
            let at = format!(
                "<svg x=\"{}\" y=\"{}\" ",
                col * cell_w,
                row * cell_h + k as u32 * plot_h
            );
            body += &one.replacen("<svg ", &at, 1);
        }
        body += "</g>\n";
    }
    Ok(format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\">\n{body}</svg>\n"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    fn two_by_two() -> StateSpace {
        StateSpace::new(
            DMatrix::from_row_slice(2, 2, &[0.9, 0.0, 0.0, 0.5]),
            DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.5, 1.0]),
            DMatrix::identity(2, 2),
            DMatrix::zeros(2, 2),
            Some(1.0),
        )
        .unwrap()
    }

    #[test]
    fn one_axes_per_pair_with_a_legend_per_model() {
        let m = two_by_two();
        let m2 = StateSpace::new(
            m.a().clone(),
            m.b().clone(),
            m.c().clone(),
            DMatrix::from_element(2, 2, 0.1),
            Some(1.0),
        )
        .unwrap();
        let models = [("#1".to_string(), &m), ("#2".to_string(), &m2)];
        let steps = step_pairs(&models).unwrap();
        assert_eq!(steps.cells.len(), 4);
        assert_eq!(steps.cells[1].0, "y1 ← u2");
        // Pair (y2 ← u1) holds the two models' responses; its final value
        // is G(1)_21 = 0.5/(1 − 0.5) = 1 for the first.
        let cell = &steps.cells[2].1[0];
        assert_eq!(cell.series.len(), 2);
        assert_eq!(cell.series[1].name, "#2");
        let last = *cell.series[0].y.last().unwrap();
        assert!((last - 1.0).abs() < 1e-3, "{last}");
        let svg = pairs_svg(&steps, 560, 200).unwrap();
        assert_eq!(svg.matches("<title>").count(), 4);
        assert!(svg.contains("<title>y2 ← u1</title>"));
    }

    #[test]
    fn the_empirical_phase_sits_on_the_models_branch() {
        let m = two_by_two();
        let omega = [0.01, 0.1, 1.0];
        let mut fig = bode_pairs(&[(String::new(), &m)], &omega).unwrap();
        let model_phase = fig.cells[0].1[1].series[0].y.clone();
        // A response equal to the model's, its phase wrapped by 5 turns.
        let b = m.bode(&omega).unwrap();
        let g = FrequencyResponse {
            omega: omega.to_vec(),
            response: b
                .phase_deg
                .iter()
                .zip(&b.magnitude)
                .map(|(p, a)| {
                    DMatrix::from_fn(2, 2, |i, j| {
                        num_complex::Complex::from_polar(
                            a[(i, j)],
                            (p[(i, j)] + 1800.0).to_radians(),
                        )
                    })
                })
                .collect(),
            segment: 8,
            segments: 1,
        };
        add_empirical_pairs(&mut fig, &g);
        let data = &fig.cells[0].1[1].series[1];
        for (d, m) in data.y.iter().zip(&model_phase) {
            assert!((d - m).abs() < 1e-6, "{d} vs {m}");
        }
    }
}

//! SVG plots (plotters' SVG backend: no system library, no font file; text
//! is left to the browser).

use plotters::prelude::*;

use crate::error::{CliResult, input};

/// One curve or point set.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// Abscissae.
    pub x: Vec<f64>,
    /// Ordinates (NaN points are skipped).
    pub y: Vec<f64>,
    /// Marker style instead of a line.
    pub marker: Marker,
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    /// A polyline (NaN breaks it).
    Line,
    /// Small filled circles.
    Dot,
    /// Crosses (poles).
    Cross,
    /// Open circles (zeros).
    Ring,
}

impl Series {
    /// A line series.
    pub fn line(name: impl Into<String>, x: Vec<f64>, y: Vec<f64>) -> Self {
        Series {
            name: name.into(),
            x,
            y,
            marker: Marker::Line,
        }
    }
    /// A series drawn with markers.
    pub fn points(name: impl Into<String>, x: Vec<f64>, y: Vec<f64>, marker: Marker) -> Self {
        Series {
            name: name.into(),
            x,
            y,
            marker,
        }
    }
}

/// A 2-D plot.
#[derive(Debug, Clone, Default)]
pub struct Plot {
    /// Caption.
    pub title: String,
    /// x-axis label.
    pub x_label: String,
    /// y-axis label.
    pub y_label: String,
    /// The series.
    pub series: Vec<Series>,
    /// Vertical marker lines (e.g. the chosen order), with a label.
    pub vlines: Vec<(f64, String)>,
    /// Draw the unit circle and equal axes (pole-zero map of a discrete model).
    pub unit_circle: bool,
}

const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

fn range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
    if lo > hi {
        return None;
    }
    let pad = if hi > lo {
        0.05 * (hi - lo)
    } else {
        0.5 * lo.abs().max(1.0)
    };
    Some((lo - pad, hi + pad))
}

fn draw_err(e: impl std::fmt::Display) -> crate::error::CliError {
    input(format!("plot: {e}"))
}

/// Renders the plot as an SVG document (size w × h pixels).
pub fn svg(plot: &Plot, w: u32, h: u32) -> CliResult<String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let mut xs: Vec<f64> = plot
            .series
            .iter()
            .flat_map(|s| s.x.iter().copied())
            .collect();
        let mut ys: Vec<f64> = plot
            .series
            .iter()
            .flat_map(|s| s.y.iter().copied())
            .collect();
        xs.extend(plot.vlines.iter().map(|v| v.0));
        if plot.unit_circle {
            xs.extend([-1.05, 1.05]);
            ys.extend([-1.05, 1.05]);
        }
        let (mut x0, mut x1) = range(xs.into_iter()).unwrap_or((0.0, 1.0));
        let (mut y0, mut y1) = range(ys.into_iter()).unwrap_or((0.0, 1.0));
        if plot.unit_circle {
            // equal scales: widen the narrower range
            let aspect = (w as f64 - 80.0) / (h as f64 - 80.0);
            let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
            let half_x = ((x1 - x0) / 2.0).max((y1 - y0) / 2.0 * aspect);
            let half_y = half_x / aspect;
            (x0, x1, y0, y1) = (cx - half_x, cx + half_x, cy - half_y, cy + half_y);
        }
        let mut chart = ChartBuilder::on(&root)
            .caption(&plot.title, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc(plot.x_label.as_str())
            .y_desc(plot.y_label.as_str())
            .label_style(("sans-serif", 12))
            .draw()
            .map_err(draw_err)?;
        if plot.unit_circle {
            let circle: Vec<(f64, f64)> = (0..=200)
                .map(|k| {
                    let t = k as f64 / 200.0 * std::f64::consts::TAU;
                    (t.cos(), t.sin())
                })
                .collect();
            chart
                .draw_series(std::iter::once(PathElement::new(circle, BLACK.mix(0.4))))
                .map_err(draw_err)?;
        }
        for (x, label) in &plot.vlines {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(*x, y0), (*x, y1)],
                    BLACK.mix(0.6).stroke_width(1),
                )))
                .map_err(draw_err)?
                .label(label.as_str())
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], BLACK.mix(0.6)));
        }
        for (i, s) in plot.series.iter().enumerate() {
            let color = COLORS[i % COLORS.len()];
            let pts: Vec<(f64, f64)> = s.x.iter().copied().zip(s.y.iter().copied()).collect();
            let anno = match s.marker {
                Marker::Line => {
                    // NaN breaks the line into segments
                    let mut segments: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
                    for p in pts {
                        if p.0.is_finite() && p.1.is_finite() {
                            if let Some(last) = segments.last_mut() {
                                last.push(p);
                            }
                        } else if segments.last().is_some_and(|l| !l.is_empty()) {
                            segments.push(Vec::new());
                        }
                    }
                    chart
                        .draw_series(
                            segments
                                .into_iter()
                                .filter(|s| !s.is_empty())
                                .map(|s| PathElement::new(s, color.stroke_width(1))),
                        )
                        .map_err(draw_err)?
                }
                Marker::Dot => chart
                    .draw_series(
                        pts.into_iter()
                            .filter(|p| p.0.is_finite() && p.1.is_finite())
                            .map(|p| Circle::new(p, 2, color.filled())),
                    )
                    .map_err(draw_err)?,
                Marker::Cross => chart
                    .draw_series(
                        pts.into_iter()
                            .filter(|p| p.0.is_finite() && p.1.is_finite())
                            .map(|p| Cross::new(p, 5, color.stroke_width(2))),
                    )
                    .map_err(draw_err)?,
                Marker::Ring => chart
                    .draw_series(
                        pts.into_iter()
                            .filter(|p| p.0.is_finite() && p.1.is_finite())
                            .map(|p| Circle::new(p, 5, color.stroke_width(2))),
                    )
                    .map_err(draw_err)?,
            };
            anno.label(s.name.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], color));
        }
        if plot.series.len() + plot.vlines.len() > 1 {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .label_font(("sans-serif", 12))
                .draw()
                .map_err(draw_err)?;
        }
        root.present().map_err(draw_err)?;
    }
    Ok(out)
}

/// Log-spaced grid of `n` points from `lo` to `hi` (both > 0).
pub fn logspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let n = n.max(2);
    let (a, b) = (lo.log10(), hi.log10());
    (0..n)
        .map(|k| 10f64.powf(a + (b - a) * k as f64 / (n - 1) as f64))
        .collect()
}

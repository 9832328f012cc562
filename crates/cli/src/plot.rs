//! SVG plots (plotters' SVG backend: no system library, no font file; text
//! is left to the browser).

use plotters::element::DashedPathElement;
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
    /// A polyline (NaN breaks it). The k-th line of a plot is solid,
    /// dashed, dotted or long-dashed in turn, so coinciding curves stay
    /// distinguishable.
    Line,
    /// Small filled circles.
    Dot,
    /// Crosses (poles).
    Cross,
    /// Open circles (zeros).
    Ring,
    /// Triangles (a point beyond the frame, drawn at its edge).
    Triangle,
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
    /// The series (an empty one keeps its colour but has no legend entry).
    pub series: Vec<Series>,
    /// Vertical marker lines (e.g. the chosen order), with a label.
    pub vlines: Vec<(f64, String)>,
    /// Draw the unit circle and equal axes (pole-zero map of a discrete model).
    pub unit_circle: bool,
    /// The abscissae are log10 of the quantity: ticks at the decades,
    /// labelled 10^k (Bode plots).
    pub log_x: bool,
    /// Fixed axes `[x0, x1, y0, y1]` instead of the data's range (points
    /// outside are clipped).
    pub frame: Option<[f64; 4]>,
    /// Lines of text under the legend (e.g. what lies beyond the frame).
    pub notes: Vec<String>,
}

const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

/// Dash patterns (dash, gap) of the k-th line: solid, dashed, dotted,
/// long-dashed.
const DASHES: [Option<(i32, i32)>; 4] = [None, Some((7, 4)), Some((2, 3)), Some((14, 4))];

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

/// A legend entry: label, colour, marker, dash pattern.
type LegendEntry = (String, RGBColor, Marker, Option<(i32, i32)>);

/// Height of a legend row, pixels.
const LEGEND_ROW: i32 = 16;

/// Width of a legend entry of `label` (sample line plus text at 12 px).
fn entry_width(label: &str) -> i32 {
    34 + 7 * label.chars().count() as i32
}

/// Where the legend goes: below the plot area, never on it. Entries of
/// `labels` flow left to right in rows of a `w` pixels wide figure, then
/// one row per note; returns the height of the legend band and each
/// entry's top-left corner, relative to the band.
pub fn legend_layout(labels: &[String], notes: usize, w: u32) -> (i32, Vec<(i32, i32)>) {
    let (left, right) = (60, w as i32 - 10);
    let mut at = Vec::with_capacity(labels.len());
    let (mut x, mut y) = (left, 4);
    for l in labels {
        let ew = entry_width(l);
        if x > left && x + ew > right {
            x = left;
            y += LEGEND_ROW;
        }
        at.push((x, y));
        x += ew + 12;
    }
    let rows = if labels.is_empty() {
        0
    } else {
        y / LEGEND_ROW + 1
    };
    let total = rows + notes as i32;
    let height = if total == 0 {
        0
    } else {
        total * LEGEND_ROW + 8
    };
    (height, at)
}

/// `10^k` with superscript digits (`10⁻²`).
pub fn decade_label(k: i32) -> String {
    const SUP: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let mut s = String::from("10");
    if k < 0 {
        s.push('⁻');
    }
    for c in k.unsigned_abs().to_string().chars() {
        s.push(c.to_digit(10).map_or(c, |d| SUP[d as usize]));
    }
    s
}

/// Renders the plot as an SVG document (size w × h pixels). The legend
/// (when there is more than one entry) and the notes sit in a band under
/// the plot area, outside the data.
pub fn svg(plot: &Plot, w: u32, h: u32) -> CliResult<String> {
    let mut out = String::new();
    let mut lines_svg = String::new();
    let mut full_names: Vec<String> = Vec::new();
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
        if let Some([a, b, c, d]) = plot.frame
            && a < b
            && c < d
        {
            (x0, x1, y0, y1) = (a, b, c, d);
        }

        // The legend's entries: vertical lines, then the non-empty series.
        let mut entries: Vec<LegendEntry> = plot
            .vlines
            .iter()
            .map(|(_, l)| (l.clone(), RGBColor(90, 90, 90), Marker::Line, Some((3, 3))))
            .collect();
        let mut styles = Vec::with_capacity(plot.series.len());
        let mut lines = 0;
        for (i, s) in plot.series.iter().enumerate() {
            let color = COLORS[i % COLORS.len()];
            let dash = if s.marker == Marker::Line {
                lines += 1;
                DASHES[(lines - 1) % DASHES.len()]
            } else {
                None
            };
            styles.push((color, dash));
            if !s.x.is_empty() {
                entries.push((s.name.clone(), color, s.marker, dash));
            }
        }
        // Long names (plant tags with their paths) shortened in the middle
        // to fit the figure's width, a title and a legend entry alike; the
        // full texts are the figure's hover title.
        let title = shortened(&plot.title, ((w.saturating_sub(20)) / TITLE_CHAR) as usize);
        if title != plot.title {
            full_names.push(plot.title.clone());
        }
        let label_chars = (w.saturating_sub(100) / LEGEND_CHAR) as usize;
        for e in &mut entries {
            let short = shortened(&e.0, label_chars);
            if short != e.0 {
                full_names.push(std::mem::replace(&mut e.0, short));
            }
        }
        let show_legend = entries.len() > 1;
        let labels: Vec<String> = if show_legend {
            entries.iter().map(|e| e.0.clone()).collect()
        } else {
            Vec::new()
        };
        let (band, at) = legend_layout(&labels, plot.notes.len(), w);
        let band = band.min(h as i32 / 2).max(0);
        let (upper, lower) = root.split_vertically(h as i32 - band);

        let plot_h = (h as i32 - band) as f64;
        if plot.unit_circle {
            // equal scales: widen the narrower range
            let aspect = (w as f64 - 80.0) / (plot_h - 80.0).max(1.0);
            let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
            let half_x = ((x1 - x0) / 2.0).max((y1 - y0) / 2.0 * aspect);
            let half_y = half_x / aspect;
            (x0, x1, y0, y1) = (cx - half_x, cx + half_x, cy - half_y, cy + half_y);
        }
        let mut chart = ChartBuilder::on(&upper)
            .caption(&title, ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(draw_err)?;
        {
            // Labels at least ~50 px apart across and ~25 px up (plotters'
            // default of 10 each ran into one another on the per-pair
            // plots), at most 4 light lines between two labelled ones (its
            // default 10 gave a line every 2 pixels there: 200 elements a
            // chart, most of a step plot's bytes).
            let (px, py) = chart.plotting_area().get_pixel_range();
            let x_labels = ((px.end - px.start) / 50).clamp(2, 10) as usize;
            let y_labels = ((py.end - py.start) / 25).clamp(2, 10) as usize;
            let mut mesh = chart.configure_mesh();
            mesh.x_desc(plot.x_label.as_str())
                .y_desc(plot.y_label.as_str())
                .label_style(("sans-serif", 12))
                .x_labels(x_labels)
                .y_labels(y_labels)
                .max_light_lines(4);
            if plot.log_x {
                mesh.disable_x_mesh().x_labels(0);
            }
            mesh.draw().map_err(draw_err)?;
        }
        if plot.log_x {
            // Decades: grid line and 10^k label; light lines at 2..9 × 10^k.
            let (k0, k1) = (x0.floor() as i32, x1.ceil() as i32);
            for k in k0..=k1 {
                for m in 1..10 {
                    let x = k as f64 + (m as f64).log10();
                    if x < x0 || x > x1 {
                        continue;
                    }
                    let style = if m == 1 {
                        BLACK.mix(0.25).stroke_width(1)
                    } else {
                        BLACK.mix(0.08).stroke_width(1)
                    };
                    chart
                        .draw_series(std::iter::once(PathElement::new(
                            vec![(x, y0), (x, y1)],
                            style,
                        )))
                        .map_err(draw_err)?;
                    if m == 1 {
                        let (px, py) = chart.backend_coord(&(x, y0));
                        root.draw(&Text::new(
                            decade_label(k),
                            (px - 10, py + 6),
                            ("sans-serif", 12).into_font(),
                        ))
                        .map_err(draw_err)?;
                    }
                }
            }
        }
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
        for (x, _) in &plot.vlines {
            chart
                .draw_series(std::iter::once(DashedPathElement::new(
                    vec![(*x, y0), (*x, y1)],
                    3,
                    3,
                    BLACK.mix(0.6).stroke_width(1),
                )))
                .map_err(draw_err)?;
        }
        let inside = |p: &(f64, f64)| {
            p.0.is_finite()
                && p.1.is_finite()
                && (x0..=x1).contains(&p.0)
                && (y0..=y1).contains(&p.1)
        };
        // The lines, written after plotters' markup in a nested <svg> of
        // the plot area (which clips them to it).
        let (px, py) = chart.plotting_area().get_pixel_range();
        lines_svg += &format!(
            "<svg x=\"{0}\" y=\"{1}\" width=\"{2}\" height=\"{3}\" viewBox=\"{0} {1} {2} {3}\">\n",
            px.start,
            py.start,
            px.end - px.start,
            py.end - py.start
        );
        for (s, &(color, dash)) in plot.series.iter().zip(&styles) {
            let pts: Vec<(f64, f64)> = s.x.iter().copied().zip(s.y.iter().copied()).collect();
            match s.marker {
                Marker::Line => {
                    // NaN breaks the line into segments; each is one
                    // polyline, dashed by `stroke-dasharray`, its points
                    // min/max decimated per pixel column.
                    let mut segments: Vec<Vec<(i32, i32)>> = vec![Vec::new()];
                    for p in pts {
                        if p.0.is_finite() && p.1.is_finite() {
                            if let Some(last) = segments.last_mut() {
                                last.push(chart.backend_coord(&p));
                            }
                        } else if segments.last().is_some_and(|l| !l.is_empty()) {
                            segments.push(Vec::new());
                        }
                    }
                    for seg in segments.into_iter().filter(|s| !s.is_empty()) {
                        polyline(&mut lines_svg, &per_column(&seg), color, dash);
                    }
                }
                Marker::Dot => {
                    let at: Vec<(i32, i32)> = pts
                        .iter()
                        .filter(|p| inside(p))
                        .map(|p| chart.backend_coord(p))
                        .collect();
                    dots(&mut lines_svg, &at, color);
                }
                Marker::Cross => {
                    chart
                        .draw_series(
                            pts.into_iter()
                                .filter(inside)
                                .map(|p| Cross::new(p, 5, color.stroke_width(2))),
                        )
                        .map_err(draw_err)?;
                }
                Marker::Ring => {
                    chart
                        .draw_series(
                            pts.into_iter()
                                .filter(inside)
                                .map(|p| Circle::new(p, 5, color.stroke_width(2))),
                        )
                        .map_err(draw_err)?;
                }
                Marker::Triangle => {
                    chart
                        .draw_series(
                            pts.into_iter()
                                .filter(inside)
                                .map(|p| TriangleMarker::new(p, 6, color.filled())),
                        )
                        .map_err(draw_err)?;
                }
            }
        }
        lines_svg += "</svg>\n";
        // The legend band, under the plot area.
        let font = ("sans-serif", 12).into_font();
        for ((label, color, marker, dash), (x, y)) in
            entries.iter().zip(&at).filter(|_| show_legend)
        {
            let mid = y + LEGEND_ROW / 2;
            let sample: Vec<(i32, i32)> = vec![(x + 2, mid), (x + 26, mid)];
            match (marker, dash) {
                (Marker::Line, None) => {
                    lower.draw(&PathElement::new(sample, color.stroke_width(2)))
                }
                (Marker::Line, Some((on, off))) => lower.draw(&DashedPathElement::new(
                    sample,
                    *on,
                    *off,
                    color.stroke_width(2),
                )),
                (Marker::Dot, _) => lower.draw(&Circle::new((x + 14, mid), 3, color.filled())),
                (Marker::Cross, _) => {
                    lower.draw(&Cross::new((x + 14, mid), 5, color.stroke_width(2)))
                }
                (Marker::Ring, _) => {
                    lower.draw(&Circle::new((x + 14, mid), 5, color.stroke_width(2)))
                }
                (Marker::Triangle, _) => {
                    lower.draw(&TriangleMarker::new((x + 14, mid), 6, color.filled()))
                }
            }
            .map_err(draw_err)?;
            lower
                .draw(&Text::new(label.clone(), (x + 32, mid - 7), font.clone()))
                .map_err(draw_err)?;
        }
        let rows_used = at.last().map_or(0, |&(_, y)| y / LEGEND_ROW + 1);
        let first_note = if show_legend { rows_used } else { 0 };
        for (i, note) in plot.notes.iter().enumerate() {
            let y = 4 + (first_note + i as i32) * LEGEND_ROW;
            lower
                .draw(&Text::new(
                    note.clone(),
                    (60, y + 1),
                    font.clone().color(&BLACK.mix(0.7)),
                ))
                .map_err(draw_err)?;
        }
        root.present().map_err(draw_err)?;
    }
    match out.rfind("</svg>") {
        Some(end) => out.insert_str(end, &lines_svg),
        None => return Err(draw_err("the SVG backend wrote no closing tag")),
    }
    if !full_names.is_empty() {
        // The hover title of the whole figure: its first child.
        let at = out
            .find("<svg")
            .and_then(|s| out[s..].find('>').map(|e| s + e + 1))
            .ok_or_else(|| draw_err("the SVG backend wrote no root element"))?;
        let title = format!(
            "\n<title>{}</title>",
            crate::escape::html(&full_names.join("\n"))
        );
        out.insert_str(at, &title);
    }
    Ok(out)
}

/// Width of a character of the 16 px title font, pixels (a generous
/// average for sans-serif, so a shortened title fits).
pub const TITLE_CHAR: u32 = 9;

/// Width of a character of the 12 px legend font, pixels (as
/// [`legend_layout`] counts them).
const LEGEND_CHAR: u32 = 7;

/// `s` shortened to at most `max` characters by an ellipsis in its middle
/// (both ends of a tag name carry meaning: `PLANT.AREA7.FIC101.OP`); as it
/// is when it fits or `max` is below 5.
pub fn shortened(s: &str, max: usize) -> String {
    let n = s.chars().count();
    if n <= max || max < 5 {
        return s.to_string();
    }
    let head = (max - 1) / 2;
    let tail = max - 1 - head;
    let chars: Vec<char> = s.chars().collect();
    let mut out: String = chars[..head].iter().collect();
    out.push('…');
    out.extend(&chars[n - tail..]);
    out
}

/// One `<polyline>` through the pixel points `pts` in `color`, dashed by
/// `dash` (on, off) pixels.
fn polyline(out: &mut String, pts: &[(i32, i32)], color: RGBColor, dash: Option<(i32, i32)>) {
    use std::fmt::Write;
    let RGBColor(r, g, b) = color;
    let _ = write!(
        out,
        "<polyline fill=\"none\" stroke=\"#{r:02X}{g:02X}{b:02X}\" stroke-width=\"{}\"",
        if dash.is_some() { 2 } else { 1 }
    );
    if let Some((on, off)) = dash {
        let _ = write!(out, " stroke-dasharray=\"{on} {off}\"");
    }
    out.push_str(" points=\"");
    for (i, (x, y)) in pts.iter().enumerate() {
        if i > 0 {
            out.push(' ');
        }
        let _ = write!(out, "{x},{y}");
    }
    out.push_str("\"/>\n");
}

/// Filled dots of radius 2 at `pts` (pixel coordinates), as one path of
/// zero-length segments with round caps (one element per series instead
/// of one circle per point); a point within the 3 × 3-pixel cell of a dot
/// already drawn is not drawn (dense estimates, such as Welch's at high
/// frequency on a log axis, would otherwise hide the model's curve under
/// overlapping dots). O(n log n).
fn dots(out: &mut String, pts: &[(i32, i32)], color: RGBColor) {
    use std::fmt::Write;
    if pts.is_empty() {
        return;
    }
    let mut seen = std::collections::BTreeSet::new();
    let RGBColor(r, g, b) = color;
    let _ = write!(
        out,
        "<path class=\"dots\" fill=\"none\" stroke=\"#{r:02X}{g:02X}{b:02X}\" stroke-width=\"4\" stroke-linecap=\"round\" d=\""
    );
    for &(x, y) in pts {
        if seen.insert((x.div_euclid(3), y.div_euclid(3))) {
            let _ = write!(out, "M{x} {y}h0");
        }
    }
    out.push_str("\"/>\n");
}

/// The points of a polyline as drawn: within each pixel column the first,
/// the lowest, the highest and the last point, in their order (min/max
/// decimation per column: the drawn curve is the same, and a line never
/// holds more than four points per pixel of width). Repeated points go.
/// O(n).
fn per_column(pts: &[(i32, i32)]) -> Vec<(i32, i32)> {
    let mut out: Vec<(i32, i32)> = Vec::with_capacity(pts.len().min(4096));
    let mut i = 0;
    while i < pts.len() {
        let x = pts[i].0;
        let (mut lo, mut hi, mut j) = (i, i, i);
        while j < pts.len() && pts[j].0 == x {
            if pts[j].1 < pts[lo].1 {
                lo = j;
            }
            if pts[j].1 > pts[hi].1 {
                hi = j;
            }
            j += 1;
        }
        let mut keep = [i, lo, hi, j - 1];
        keep.sort_unstable();
        for k in keep {
            if out.last() != Some(&pts[k]) {
                out.push(pts[k]);
            }
        }
        i = j;
    }
    out
}

/// Log-spaced grid of `n` points from `lo` to `hi` (both > 0).
pub fn logspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let n = n.max(2);
    let (a, b) = (lo.log10(), hi.log10());
    (0..n)
        .map(|k| 10f64.powf(a + (b - a) * k as f64 / (n - 1) as f64))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_legend_sits_under_the_plot_area() {
        let labels: Vec<String> = ["measured", "model (simulated)", "y1 ← u1", "y2 ← u1"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        // Wide: one row; narrow: the entries flow into more rows, each inside the figure.
        let (wide, at) = legend_layout(&labels, 0, 900);
        assert_eq!(wide, LEGEND_ROW + 8);
        assert!(at.iter().all(|&(_, y)| y == 4));
        let (narrow, at) = legend_layout(&labels, 1, 340);
        assert!(narrow > 2 * LEGEND_ROW, "{narrow}");
        for (l, &(x, _)) in labels.iter().zip(&at) {
            assert!(x >= 60 && x + entry_width(l) <= 340 - 10, "{l} at {x}");
        }
        // In the SVG, every legend label is drawn below the plot area.
        let plot = Plot {
            title: "t".into(),
            series: vec![
                Series::line("measured", vec![0.0, 1.0], vec![0.0, 1.0]),
                Series::line("model (simulated)", vec![0.0, 1.0], vec![0.0, 1.0]),
            ],
            ..Default::default()
        };
        let (h, band) = (260, wide);
        let svg = svg(&plot, 900, h).unwrap();
        for label in ["measured", "model (simulated)"] {
            let at = svg.find(&format!(">\n{label}\n<")).expect(label);
            let tag = &svg[svg[..at].rfind("<text").unwrap()..at];
            let y: f64 = tag
                .split("y=\"")
                .nth(1)
                .and_then(|r| r.split('"').next())
                .and_then(|v| v.parse().ok())
                .expect("a y attribute");
            assert!(y >= (h as i32 - band) as f64, "{label} at y = {y}");
        }
        // Coinciding lines: the second is dashed, each one polyline.
        assert_eq!(svg.matches("stroke-dasharray=\"7 4\"").count(), 1, "{svg}");
    }

    #[test]
    fn a_long_curve_is_one_polyline_of_a_few_points_per_pixel() {
        let n = 100_000;
        let x: Vec<f64> = (0..n).map(|k| k as f64).collect();
        let y: Vec<f64> = x.iter().map(|t| (t * 0.37).sin()).collect();
        let plot = Plot {
            series: vec![
                Series::line("a", x.clone(), y.clone()),
                Series::line("b", x, y),
            ],
            ..Default::default()
        };
        let svg = svg(&plot, 900, 300).unwrap();
        let lengths: Vec<usize> = svg
            .split("points=\"")
            .skip(1)
            .map(|p| p.split('"').next().unwrap().split(' ').count())
            .filter(|&k| k > 10)
            .collect();
        assert_eq!(lengths.len(), 2, "one polyline a curve: {lengths:?}");
        assert!(lengths.iter().all(|&k| k <= 4 * 900), "{lengths:?} points");
        assert_eq!(svg.matches("stroke-dasharray").count(), 1);
        assert!(svg.len() < 200_000, "{} bytes", svg.len());
    }

    #[test]
    fn long_titles_and_labels_are_shortened_with_the_full_text_on_hover() {
        let long = "PLANT.AREA7.UNIT3.TI203.PV: measured vs simulated (fit 91.2 %)";
        let label = "PLANT.AREA7.UNIT3.FIC101.OP ← PLANT.AREA7.UNIT3.TI203.PV (model)";
        let plot = Plot {
            title: long.into(),
            series: vec![
                Series::line(label, vec![0.0, 1.0], vec![0.0, 1.0]),
                Series::line("measured", vec![0.0, 1.0], vec![1.0, 0.0]),
            ],
            ..Default::default()
        };
        let svg = svg(&plot, 300, 200).unwrap();
        let at = svg.find("<title>").expect("hover title");
        assert!(svg[at..].starts_with(&format!("<title>{}\n", crate::escape::html(long))));
        assert!(svg.contains(&crate::escape::html(label)));
        // The drawn title fits the figure.
        let shown = shortened(long, (300 - 20) / TITLE_CHAR as usize);
        assert!(
            shown.chars().count() <= 31 && shown.contains('…'),
            "{shown}"
        );
        assert!(svg.contains(&crate::escape::html(&shown)));
        // A plot whose names fit has no hover title.
        let plain = svg_plain();
        assert!(!plain.contains("<title>"));
    }

    fn svg_plain() -> String {
        let plot = Plot {
            title: "y1".into(),
            series: vec![Series::line("a", vec![0.0, 1.0], vec![0.0, 1.0])],
            ..Default::default()
        };
        svg(&plot, 600, 200).unwrap()
    }

    #[test]
    fn long_names_are_shortened_in_the_middle() {
        assert_eq!(shortened("y1 ← u1", 20), "y1 ← u1");
        let s = shortened("PLANT.AREA7.TI203.PV ← PLANT.AREA7.FIC101.OP", 21);
        assert_eq!(s.chars().count(), 21);
        assert!(
            s.starts_with("PLANT.AREA") && s.ends_with("FIC101.OP"),
            "{s}"
        );
    }

    #[test]
    fn per_column_keeps_first_extremes_and_last() {
        let pts = [(0, 5), (0, 9), (0, 1), (0, 4), (1, 3), (2, 3), (2, 3)];
        assert_eq!(
            per_column(&pts),
            vec![(0, 5), (0, 9), (0, 1), (0, 4), (1, 3), (2, 3)]
        );
    }

    #[test]
    fn decades_are_labelled_as_powers_of_ten() {
        assert_eq!(decade_label(0), "10⁰");
        assert_eq!(decade_label(3), "10³");
        assert_eq!(decade_label(-12), "10⁻¹²");
    }
}

//! The figures of a model and a record, as [`Plot`]s drawn to SVG by
//! [`crate::plot::svg`]: the Bode grid and step data, pole-zero map, order
//! selection, the excitation and the measured-vs-model output (the step
//! and Bode plots, one axes per input–output pair, are
//! [`crate::service::pairs`]'s). Shared by `lifted bode`/`step`/`report`
//! and `lifted studio`.

use lifted_lti::validation::OutputValidation;
use lifted_lti::{Dataset, StateSpace};
use lifted_workflow::Diagnostics;

use crate::error::{CliResult, Context, input};
use crate::plot::{Marker, Plot, Series, logspace};
use crate::service::models::channel_names;

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
    if let (Some(w), Some(ts)) = (wmax, m.ts())
        && w > crate::service::analysis::nyquist(ts) * (1.0 + 1e-12)
    {
        return Err(input(format!(
            "bode: --wmax {w} rad/s is above the Nyquist frequency π/T = {:.6} rad/s of the \
             discrete model (T = {ts} s); a discrete model's response there repeats that of \
             an alias below π/T (the default --wmax is π/T)",
            crate::service::analysis::nyquist(ts)
        )));
    }
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

/// The frame of a discrete model's pole-zero map: the unit circle and
/// every pole in view, far zeros moved to the edge.
#[derive(Debug, Clone, PartialEq)]
pub struct PzFrame {
    /// Half-width of the square frame: 1.2, or 1.1 max |p| when a pole lies
    /// beyond 1.2/1.1.
    pub half: f64,
    /// Zeros inside the frame, as (re, im).
    pub zeros: Vec<(f64, f64)>,
    /// Zeros beyond the frame, drawn at its edge in their direction:
    /// (re, im) on the edge and the zero's modulus.
    pub far: Vec<(f64, f64, f64)>,
}

/// The pole-zero frame of `poles` and `zeros` (as (re, im)): scaled to
/// the unit circle (±1.2) or to the poles when one lies outside, never to
/// far zeros (a zero at 4000 would shrink the poles and the circle to a
/// dot); zeros beyond it are placed on its edge.
pub fn pz_frame(poles: &[(f64, f64)], zeros: &[(f64, f64)]) -> PzFrame {
    let reach = poles
        .iter()
        .map(|p| p.0.abs().max(p.1.abs()))
        .filter(|r| r.is_finite())
        .fold(0.0, f64::max);
    let half = (1.1 * reach).max(1.2);
    let edge = 0.97 * half;
    let (mut inside, mut far) = (Vec::new(), Vec::new());
    for &(re, im) in zeros {
        let r = re.abs().max(im.abs());
        if !r.is_finite() {
            continue;
        }
        if r <= edge {
            inside.push((re, im));
        } else {
            let s = edge / r;
            far.push((re * s, im * s, re.hypot(im)));
        }
    }
    PzFrame {
        half,
        zeros: inside,
        far,
    }
}

/// Pole-zero map. A discrete model's map is framed by [`pz_frame`]: the
/// unit circle at about ±1.2, poles outside it in their own colour, zeros
/// beyond the frame as triangles at its edge with their moduli in a note.
pub fn pz_plot(m: &StateSpace) -> CliResult<Plot> {
    let poles = m.poles().ctx("poles")?;
    let discrete = m.is_discrete();
    let mut plot = Plot {
        title: "Poles (×) and transmission zeros (○)".into(),
        x_label: "Re".into(),
        y_label: "Im".into(),
        unit_circle: discrete,
        ..Default::default()
    };
    let p: Vec<(f64, f64)> = poles.iter().map(|z| (z.re, z.im)).collect();
    // Zeros can legitimately fail to exist (e.g. non-square numerics); show poles then.
    let z: Vec<(f64, f64)> = m
        .zeros()
        .map(|z| z.iter().map(|z| (z.re, z.im)).collect())
        .unwrap_or_default();
    let unzip = |v: Vec<(f64, f64)>| -> (Vec<f64>, Vec<f64>) { v.into_iter().unzip() };
    if !discrete {
        let (px, py) = unzip(p);
        plot.series
            .push(Series::points("poles", px, py, Marker::Cross));
        let (zx, zy) = unzip(z);
        plot.series
            .push(Series::points("zeros", zx, zy, Marker::Ring));
        return Ok(plot);
    }
    let frame = pz_frame(&p, &z);
    let (stable, outside): (Vec<_>, Vec<_>) = p.into_iter().partition(|q| q.0.hypot(q.1) < 1.0);
    let (px, py) = unzip(stable);
    plot.series
        .push(Series::points("poles", px, py, Marker::Cross));
    let (ox, oy) = unzip(outside);
    plot.series.push(Series::points(
        "poles outside the unit circle",
        ox,
        oy,
        Marker::Cross,
    ));
    let (zx, zy) = unzip(frame.zeros.clone());
    plot.series
        .push(Series::points("zeros", zx, zy, Marker::Ring));
    let fx = frame.far.iter().map(|f| f.0).collect();
    let fy = frame.far.iter().map(|f| f.1).collect();
    plot.series.push(Series::points(
        "zeros beyond the frame (at its edge)",
        fx,
        fy,
        Marker::Triangle,
    ));
    if !frame.far.is_empty() {
        let mut moduli: Vec<String> = frame
            .far
            .iter()
            .take(6)
            .map(|f| format!("{:.3e}", f.2))
            .collect();
        if frame.far.len() > 6 {
            moduli.push(format!("… ({} in all)", frame.far.len()));
        }
        plot.notes.push(format!(
            "▲ zeros beyond the frame: |z| = {}",
            moduli.join(", ")
        ));
    }
    let h = frame.half;
    plot.frame = Some([-h, h, -h, h]);
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

/// Most points drawn per time series: a longer record (or the part of it
/// in a zoom window) is reduced to the smallest and the largest value of
/// each of `MAX_POINTS / 2` equal buckets, in time order (min/max
/// decimation: every peak survives, and a 1e6-sample record costs 2000
/// points, not a solid band of 1e6).
pub const MAX_POINTS: usize = 2000;

/// A time window `[t0, t1]` in seconds (zoom), `None` for the whole record.
pub type Window = Option<(f64, f64)>;

/// The index range of the samples of `t` (increasing) inside `window`,
/// with one sample more on each side so that lines reach the window's
/// edges.
fn window_range(t: &[f64], window: Window) -> std::ops::Range<usize> {
    match window {
        Some((a, b)) if a < b => {
            let lo = t.partition_point(|v| *v < a).saturating_sub(1);
            let hi = (t.partition_point(|v| *v <= b) + 1).min(t.len());
            lo..hi.max(lo)
        }
        _ => 0..t.len(),
    }
}

/// The points of (t, y) to draw: those in `window` (all with `None`),
/// min/max decimated to at most [`MAX_POINTS`]. A bucket without a finite
/// value gives one NaN point (a break in the line). O(len).
pub fn decimate_in(t: &[f64], y: &[f64], window: Window) -> (Vec<f64>, Vec<f64>) {
    let n = t.len().min(y.len());
    let r = window_range(&t[..n], window);
    let (t, y) = (&t[r.clone()], &y[r]);
    let n = t.len();
    if n <= MAX_POINTS {
        return (t.to_vec(), y.to_vec());
    }
    let buckets = MAX_POINTS / 2;
    let (mut tt, mut yy) = (
        Vec::with_capacity(MAX_POINTS),
        Vec::with_capacity(MAX_POINTS),
    );
    for b in 0..buckets {
        let (lo, hi) = (b * n / buckets, (b + 1) * n / buckets);
        let mut lowest: Option<usize> = None;
        let mut highest: Option<usize> = None;
        for k in lo..hi {
            if !y[k].is_finite() {
                continue;
            }
            if lowest.is_none_or(|i| y[k] < y[i]) {
                lowest = Some(k);
            }
            if highest.is_none_or(|i| y[k] > y[i]) {
                highest = Some(k);
            }
        }
        match (lowest, highest) {
            (Some(i), Some(j)) => {
                for k in if i == j {
                    vec![i]
                } else {
                    vec![i.min(j), i.max(j)]
                } {
                    tt.push(t[k]);
                    yy.push(y[k]);
                }
            }
            _ => {
                tt.push(t[lo]);
                yy.push(f64::NAN);
            }
        }
    }
    (tt, yy)
}

/// [`decimate_in`] over the whole record.
pub fn decimate(t: &[f64], y: &[f64]) -> (Vec<f64>, Vec<f64>) {
    decimate_in(t, y, None)
}

/// The order-selection plot from the model file's diagnostics, if present.
pub fn order_plot(diag: &Diagnostics) -> Option<Plot> {
    let os = diag.order_selection.as_ref()?;
    let values = &os.values;
    if values.is_empty() {
        return None;
    }
    let kind = os.kind.as_str();
    let order = Some(os.order);
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

/// The measured inputs of a record against time, one line per input.
pub fn excitation_plot(data: &Dataset, names: &[String]) -> Plot {
    excitation_plot_in(data, names, None)
}

/// [`excitation_plot`] over a time window (zoom).
pub fn excitation_plot_in(data: &Dataset, names: &[String], window: Window) -> Plot {
    let ts = data.ts();
    let t: Vec<f64> = (0..data.len()).map(|k| k as f64 * ts).collect();
    let mut plot = Plot {
        title: "Input signals".into(),
        x_label: "t [s]".into(),
        y_label: "u".into(),
        ..Default::default()
    };
    for (j, name) in names.iter().enumerate().take(data.n_inputs()) {
        let u: Vec<f64> = data.u().column(j).iter().copied().collect();
        let (tt, uu) = decimate_in(&t, &u, window);
        plot.series.push(Series::line(name.clone(), tt, uu));
    }
    plot
}

/// The measured outputs of a record: one series per output, a line for a
/// fast output and markers at the sampling instants of a slow one.
pub fn outputs_plot(data: &Dataset) -> Plot {
    outputs_plot_in(data, None)
}

/// [`outputs_plot`] over a time window (zoom).
pub fn outputs_plot_in(data: &Dataset, window: Window) -> Plot {
    let ts = data.ts();
    let mut plot = Plot {
        title: "Output signals (slow outputs: markers at their samples)".into(),
        x_label: "t [s]".into(),
        y_label: "y".into(),
        ..Default::default()
    };
    for (i, ch) in data.outputs().iter().enumerate() {
        let (t, y): (Vec<f64>, Vec<f64>) = (0..data.len())
            .filter(|k| data.y()[(*k, i)].is_finite())
            .map(|k| (k as f64 * ts, data.y()[(k, i)]))
            .unzip();
        let (t, y) = decimate_in(&t, &y, window);
        let label = if ch.period > 1 {
            format!("{} (every {} samples)", ch.name, ch.period)
        } else {
            ch.name.clone()
        };
        plot.series.push(if ch.period > 1 {
            Series::points(label, t, y, Marker::Dot)
        } else {
            Series::line(label, t, y)
        });
    }
    plot
}

/// One output's measurement (markers when it is sampled slowly) and the
/// model's simulated response (dashed), against time; `n` is the record
/// length and `ts` its base period. The title gives the fit only for a
/// `stable` model with finite residuals ("fit n/a: unstable" otherwise).
pub fn response_plot(o: &OutputValidation, ts: f64, n: usize, stable: bool) -> Plot {
    response_plot_in(o, ts, n, stable, None)
}

/// [`response_plot`] over a time window (zoom).
pub fn response_plot_in(
    o: &OutputValidation,
    ts: f64,
    n: usize,
    stable: bool,
    window: Window,
) -> Plot {
    let t: Vec<f64> = (0..o.simulated.len()).map(|k| k as f64 * ts).collect();
    let mt: Vec<f64> = o.instants.iter().map(|&k| k as f64 * ts).collect();
    let (mt, my) = decimate_in(&mt, &o.measured, window);
    let (st, sy) = decimate_in(&t, &o.simulated, window);
    let slow = o.samples < n;
    Plot {
        title: if !o.residual_finite {
            format!("{}: measured vs simulated (simulation diverges)", o.name)
        } else if !stable {
            format!("{}: measured vs simulated (fit n/a: unstable)", o.name)
        } else if o.fit.is_nan() {
            format!(
                "{}: measured vs simulated (fit n/a: constant output)",
                o.name
            )
        } else {
            format!(
                "{}: measured vs simulated (fit {} %)",
                o.name,
                crate::shown::percent(o.fit)
            )
        },
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
    }
}

/// The response error y − ŷ of one output at its sampling instants.
pub fn response_error_plot(o: &OutputValidation, ts: f64) -> Plot {
    response_error_plot_in(o, ts, None)
}

/// [`response_error_plot`] over a time window (zoom).
pub fn response_error_plot_in(o: &OutputValidation, ts: f64, window: Window) -> Plot {
    let t: Vec<f64> = o.instants.iter().map(|&k| k as f64 * ts).collect();
    let e: Vec<f64> = o
        .instants
        .iter()
        .zip(&o.measured)
        .map(|(&k, y)| y - o.simulated.get(k).copied().unwrap_or(f64::NAN))
        .collect();
    let (t, e) = decimate_in(&t, &e, window);
    Plot {
        title: format!("{}: response error y − ŷ", o.name),
        x_label: "t [s]".into(),
        y_label: "error".into(),
        series: vec![Series::line("y − ŷ", t, e)],
        ..Default::default()
    }
}

/// The order criterion's values per order from the model file's
/// diagnostics (`order_criterion`: AIC, AICc, BIC or SVC, orders 1, 2, …),
/// the selected order marked; `None` when the route reports none or the
/// rule is the singular-value gap (the order-selection plot shows it).
/// For AIC, AICc and BIC a value far above the others (an unstable
/// candidate's simulation error) is left outside the frame and named in a
/// note.
pub fn criterion_plot(diag: &Diagnostics) -> Option<Plot> {
    if let Some(p) = held_out_plot(diag) {
        return Some(p);
    }
    let oc = diag.order_criterion.as_ref()?;
    let name = oc.criterion.clone();
    // The gap is the order-selection plot's singular values already.
    if name == "Gap" {
        return None;
    }
    let values: Vec<f64> = oc.values.iter().map(|v| v.unwrap_or(f64::NAN)).collect();
    if values.iter().all(|v| !v.is_finite()) {
        return None;
    }
    let x: Vec<f64> = (1..=values.len()).map(|i| i as f64).collect();
    // An unstable candidate's simulation error can be orders of magnitude
    // above the rest: the frame holds the values up to 1.5 × the spread of
    // the lower three quarters, the others are named in a note.
    let mut finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    finite.sort_by(f64::total_cmp);
    let lo = finite[0];
    let q3 = finite[(3 * (finite.len() - 1)) / 4];
    let top = finite
        .iter()
        .copied()
        .filter(|v| *v <= lo + 1.5 * (q3 - lo).max(lo.abs() * 1e-9))
        .fold(lo, f64::max);
    let minimised = matches!(name.as_str(), "Aic" | "Aicc" | "Bic");
    let beyond: Vec<String> = values
        .iter()
        .enumerate()
        .filter(|(_, v)| minimised && v.is_finite() && **v > top)
        .map(|(i, v)| format!("order {}: {v:.4e}", i + 1))
        .collect();
    let pad = 0.08 * (top - lo).max(lo.abs() * 1e-6).max(1e-12);
    let mut plot = Plot {
        title: format!("Order criterion: {name} per order"),
        x_label: "order n".into(),
        y_label: name.clone(),
        series: vec![Series::points(name, x, values.clone(), Marker::Dot)],
        ..Default::default()
    };
    {
        let n = oc.selected;
        plot.vlines
            .push((n as f64, format!("its choice: order {n}")));
    }
    if !beyond.is_empty() {
        plot.frame = Some([0.5, values.len() as f64 + 0.5, lo - pad, top + pad]);
        plot.notes
            .push(format!("beyond the frame: {}", beyond.join(", ")));
    }
    Some(plot)
}

/// Points of held-out fit below the best at which the curve's frame stops
/// (a fold without a stable model counts as −100 %, which would flatten
/// the rest).
const HELD_OUT_SPAN: f64 = 100.0;

/// The held-out selection's curve: the best held-out simulation fit of each
/// order's structures (`structure_selection.candidates`), the scores of the
/// refined shortlist (the held-out fit of the model each shortlisted order
/// delivers) when there is one, and the order chosen; `None` without a
/// structure selection.
fn held_out_plot(diag: &Diagnostics) -> Option<Plot> {
    let sel = diag.structure_selection.as_ref()?;
    let mut best: std::collections::BTreeMap<u64, f64> = Default::default();
    // The standard error over the held-out blocks of each order's best
    // structure (when its per-block fits are reported).
    let mut spread: std::collections::BTreeMap<u64, f64> = Default::default();
    for c in sel.candidates.as_ref()? {
        let (n, Some(f)) = (c.order as u64, c.fit) else {
            continue;
        };
        let e = best.entry(n).or_insert(f64::NEG_INFINITY);
        if f > *e {
            *e = f;
            match c
                .fold_fits
                .as_ref()
                .map(|v| v.iter().flatten().copied().collect::<Vec<f64>>())
                .and_then(|v| standard_error(&v))
            {
                Some(se) => spread.insert(n, se),
                None => spread.remove(&n),
            };
        }
    }
    if best.is_empty() {
        return None;
    }
    let mut series = vec![Series::points(
        "subspace models (best structure of each order)",
        best.keys().map(|&n| n as f64).collect(),
        best.values().copied().collect(),
        Marker::Dot,
    )];
    let shortlist_rows = sel.refined_shortlist.as_ref().and_then(Option::as_ref);
    let shortlist: Vec<(f64, f64)> = shortlist_rows
        .map(|s| {
            s.candidates
                .iter()
                .filter_map(|r| Some((r.order as f64, r.score?)))
                .collect()
        })
        .unwrap_or_default();
    let mut notes = Vec::new();
    if !shortlist.is_empty() {
        // The single-rate shortlist scores each order on six blocks (the
        // subspace model or its refinement, `scored_by`); the multirate one
        // scores the refined model on the last third.
        let blocks =
            shortlist_rows.is_some_and(|s| s.candidates.iter().any(|r| r.scored_by.is_some()));
        let (note, name) = if blocks {
            (
                "rings: refinement-check blocks (unidentifiable folds left out; dots count them as -100 %)",
                "the model each shortlisted order delivers (refined where the blocks prefer it)",
            )
        } else {
            (
                "rings: each shortlisted order's model refined on the first two thirds, scored on the last third",
                "the refined model of each shortlisted order",
            )
        };
        notes.push(note.to_string());
        series.push(Series::points(
            name,
            shortlist.iter().map(|p| p.0).collect(),
            shortlist.iter().map(|p| p.1).collect(),
            Marker::Ring,
        ));
    }
    let all: Vec<f64> = best
        .values()
        .copied()
        .chain(shortlist.iter().map(|p| p.1))
        .collect();
    let hi = all.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let lo = all.iter().copied().fold(f64::INFINITY, f64::min);
    if !spread.is_empty() {
        // Vertical bars mean ± one standard error, one polyline broken by
        // NaN; kept within the span the frame shows.
        let floor = hi - HELD_OUT_SPAN;
        let (mut x, mut y) = (Vec::new(), Vec::new());
        for (&n, &se) in &spread {
            let m = best[&n];
            if m < floor {
                continue;
            }
            x.extend([n as f64, n as f64, f64::NAN]);
            y.extend([(m - se).max(floor), m + se, f64::NAN]);
        }
        notes.push(
            "bars: ± one standard error of the mean over the held-out blocks (orders whose bars overlap are not told apart by the data)"
                .to_string(),
        );
        series.push(Series {
            name: "± one standard error over the blocks".into(),
            x,
            y,
            marker: Marker::Line,
        });
    }
    let mut plot = Plot {
        title: "Held-out simulation fit per order".into(),
        x_label: "order n".into(),
        y_label: "held-out fit (%)".into(),
        series,
        notes,
        ..Default::default()
    };
    if let Some(n) = sel.order {
        plot.vlines.push((n as f64, format!("chosen: order {n}")));
    }
    if lo < hi - HELD_OUT_SPAN {
        let floor = hi - HELD_OUT_SPAN;
        let below: Vec<String> = best
            .iter()
            .filter(|(_, f)| **f < floor)
            .map(|(n, f)| format!("order {n}: {f:.1} %"))
            .collect();
        let last = best.keys().next_back().copied().unwrap_or(1) as f64;
        plot.frame = Some([0.5, last + 0.5, floor - 3.0, hi + 3.0]);
        plot.notes
            .push(format!("below the frame: {}", below.join(", ")));
    }
    Some(plot)
}

/// The standard error of the mean of `v` (sample standard deviation over
/// √len); `None` for fewer than two values.
fn standard_error(v: &[f64]) -> Option<f64> {
    if v.len() < 2 {
        return None;
    }
    let k = v.len() as f64;
    let mean = v.iter().sum::<f64>() / k;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (k - 1.0);
    Some((var / k).sqrt())
}

/// Stems (τ, 0)–(τ, r) of correlations `r` at lags `lags`, as one line
/// broken by NaN.
fn stems(lags: impl Iterator<Item = f64>, r: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for (t, v) in lags.zip(r) {
        x.extend([t, t, f64::NAN]);
        y.extend([0.0, *v, f64::NAN]);
    }
    (x, y)
}

/// The band ±`bound` over [a, b], as one line broken by NaN.
fn band(a: f64, b: f64, bound: f64) -> Series {
    Series::line(
        "99 % bound ±2.576/√N",
        vec![a, b, f64::NAN, a, b],
        vec![bound, bound, f64::NAN, -bound, -bound],
    )
}

/// The residual tests of one output (`lifted validate`'s): the normalised
/// autocorrelation r_e(τ)/r_e(0), τ = 1…M, and the cross-correlation with
/// each input, τ = −M…M, as stems with the 99 % band ±2.576/√N (dashed).
/// A value outside the band counts against whiteness (independence).
pub fn residual_plots(o: &OutputValidation, inputs: &[String]) -> (Plot, Plot) {
    let m = o.auto.len() as f64;
    let (x, y) = stems((1..=o.auto.len()).map(|t| t as f64), &o.auto);
    let auto = Plot {
        title: format!(
            "{}: residual autocorrelation ({})",
            o.name,
            if o.white { "white" } else { "not white" }
        ),
        x_label: "lag τ [samples]".into(),
        y_label: "r_e(τ)/r_e(0)".into(),
        series: vec![
            Series::line("r_e(τ)/r_e(0)", x, y),
            band(0.5, m + 0.5, o.bound),
        ],
        ..Default::default()
    };
    let mut cross = Plot {
        title: format!(
            "{}: residual–input cross-correlation ({})",
            o.name,
            if o.independent {
                "independent"
            } else {
                "not independent"
            }
        ),
        x_label: "lag τ [samples]".into(),
        y_label: "r_eu(τ)".into(),
        ..Default::default()
    };
    let mut lines = Vec::new();
    for (j, c) in o.cross.iter().enumerate() {
        let half = (c.len() / 2) as f64;
        let (x, y) = stems((0..c.len()).map(|t| t as f64 - half), c);
        let name = inputs
            .get(j)
            .cloned()
            .unwrap_or_else(|| format!("u{}", j + 1));
        lines.push(Series::line(format!("e, {name}"), x, y));
    }
    let half = o.cross.first().map_or(0.0, |c| (c.len() / 2) as f64);
    // The stems first (the first input's solid), the band after them.
    cross.series.extend(lines);
    cross.series.push(band(-half - 0.5, half + 0.5, o.bound));
    (auto, cross)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_criterion_curve_frames_the_reasonable_values() {
        // AIC per order with an unstable order 4 (1e6): framed without it,
        // named in a note; the gap gives no curve (the singular values do).
        let d = serde_json::json!({"order_criterion": {"criterion": "Aic",
            "values": [10.0, -50.0, -48.0, 1e6], "selected": 2}});
        let p = super::criterion_plot(&Diagnostics::strict(&d).unwrap()).unwrap();
        let [_, _, y0, y1] = p.frame.unwrap();
        assert!(y0 < -50.0 && y1 > 10.0 && y1 < 100.0, "{y0} … {y1}");
        assert!(p.notes[0].contains("order 4"), "{:?}", p.notes);
        assert_eq!(p.vlines[0].0, 2.0);
        let gap = serde_json::json!({"order_criterion": {"criterion": "Gap",
            "values": [1.0, 4.0], "selected": 2}});
        assert!(super::criterion_plot(&Diagnostics::strict(&gap).unwrap()).is_none());
    }

    #[test]
    fn the_held_out_curve_shows_the_best_structure_per_order_and_the_shortlist() {
        // Two structures of order 1 (the better is shown), an order 3 far
        // below (framed out, named), the shortlist's scores as a second
        // series, the chosen order marked.
        let d = serde_json::json!({"structure_selection": {"order": 2,
            "candidates": [
                {"order": 1, "horizon": 5, "fit": 50.0},
                {"order": 1, "horizon": 10, "fit": 60.0},
                {"order": 2, "horizon": 5, "fit": 80.0},
                {"order": 3, "horizon": 5, "fit": -100.0},
                {"order": 4, "horizon": 5, "fit": null}],
            "refined_shortlist": {"candidates": [
                {"order": 2, "score": 85.0}, {"order": 1, "score": 70.0}]}},
            "order_criterion": {"criterion": "Gap", "values": [1.0, 2.0], "selected": 2}});
        let p = super::criterion_plot(&Diagnostics::strict(&d).unwrap()).unwrap();
        assert_eq!(p.series[0].x, vec![1.0, 2.0, 3.0]);
        assert_eq!(p.series[0].y, vec![60.0, 80.0, -100.0]);
        assert_eq!(p.series[1].y, vec![85.0, 70.0]);
        assert_eq!(p.vlines[0].0, 2.0);
        let [_, _, y0, y1] = p.frame.unwrap();
        assert!(y0 > -100.0 && y0 < 60.0 && y1 > 85.0, "{y0} … {y1}");
        assert!(p.notes[1].contains("order 3: -100.0"), "{:?}", p.notes);
        // No per-block fits: no bars.
        assert_eq!(p.series.len(), 2);
    }

    #[test]
    fn a_multirate_shortlist_is_named_for_what_scored_it() {
        let d = serde_json::json!({"structure_selection": {"order": 4,
            "candidates": [{"order": 3, "fit": 85.0}, {"order": 4, "fit": 84.0}],
            "refined_shortlist": {"candidates": [
                {"order": 3, "score": 88.0}, {"order": 4, "score": 90.0}]}},
            "order_criterion": {"criterion": "Gap", "values": [1.0, 2.0], "selected": 2}});
        let p = super::criterion_plot(&Diagnostics::strict(&d).unwrap()).unwrap();
        assert_eq!(p.series[1].y, vec![88.0, 90.0]);
        assert!(
            p.series[1].name.contains("refined model"),
            "{}",
            p.series[1].name
        );
        assert!(p.notes[0].contains("last third"), "{:?}", p.notes);
    }

    #[test]
    fn the_held_out_curve_carries_the_blocks_standard_error() {
        // Order 1's better structure has blocks 58, 62 (mean 60, SE 2);
        // order 2 blocks 70, 90 (mean 80, SE 10).
        let d = serde_json::json!({"structure_selection": {"order": 2,
            "candidates": [
                {"order": 1, "horizon": 5, "fit": 50.0, "fold_fits": [40.0, 60.0]},
                {"order": 1, "horizon": 10, "fit": 60.0, "fold_fits": [58.0, 62.0]},
                {"order": 2, "horizon": 5, "fit": 80.0, "fold_fits": [70.0, 90.0]}]},
            "order_criterion": {"criterion": "Gap", "values": [1.0, 2.0], "selected": 2}});
        let p = super::criterion_plot(&Diagnostics::strict(&d).unwrap()).unwrap();
        let bars = p.series.last().unwrap();
        assert_eq!(bars.marker, Marker::Line);
        assert_eq!(bars.x[..2], [1.0, 1.0]);
        assert_eq!(bars.y[..2], [58.0, 62.0]);
        assert!(bars.y[2].is_nan());
        assert_eq!(bars.y[3..5], [70.0, 90.0]);
        assert!(p.notes.iter().any(|n| n.contains("standard error")));
    }

    #[test]
    fn min_max_decimation_keeps_every_peak_and_honours_the_window() {
        // 1e5 samples of a slow sine with one spike: 2000 points at most,
        // the spike and the extremes kept.
        let n = 100_000;
        let t: Vec<f64> = (0..n).map(|k| k as f64 * 0.01).collect();
        let mut y: Vec<f64> = t.iter().map(|t| (0.05 * t).sin()).collect();
        y[54_321] = 7.0;
        let (tt, yy) = super::decimate(&t, &y);
        assert!(tt.len() <= super::MAX_POINTS && tt.len() > super::MAX_POINTS / 2);
        assert!(yy.contains(&7.0));
        let lo = yy.iter().copied().fold(f64::INFINITY, f64::min);
        let true_lo = y.iter().copied().fold(f64::INFINITY, f64::min);
        assert_eq!(lo, true_lo);
        assert!(tt.windows(2).all(|w| w[0] <= w[1]), "time order");
        // A window of 10 s: its 1000 samples (+ one each side), undecimated.
        let (tw, _) = super::decimate_in(&t, &y, Some((100.0, 110.0)));
        assert_eq!(tw.len(), 1003);
        assert!(tw[0] < 100.0 && *tw.last().unwrap() > 110.0);
        // A bucket without finite values breaks the line.
        let mut gap = y.clone();
        for v in &mut gap[..1000] {
            *v = f64::NAN;
        }
        let (_, yg) = super::decimate(&t, &gap);
        assert!(yg[0].is_nan());
    }

    #[test]
    fn the_pole_zero_frame_keeps_the_unit_circle_in_view() {
        // Poles inside, a zero at 4000 and one at -3000i: the frame stays
        // ±1.2 and the far zeros go to its edge, their moduli kept.
        let poles = [(0.9, 0.1), (0.9, -0.1), (0.5, 0.0)];
        let zeros = [(0.3, 0.0), (4000.0, 0.0), (0.0, -3000.0)];
        let f = pz_frame(&poles, &zeros);
        assert_eq!(f.half, 1.2);
        assert_eq!(f.zeros, vec![(0.3, 0.0)]);
        assert_eq!(f.far.len(), 2);
        for &(x, y, m) in &f.far {
            assert!(x.abs().max(y.abs()) <= f.half, "({x}, {y}) outside");
            assert!(x.abs().max(y.abs()) > 1.1, "({x}, {y}) not at the edge");
            assert!(m == 4000.0 || m == 3000.0);
        }
        assert!(f.far[0].0 > 0.0 && f.far[1].1 < 0.0, "direction kept");
        // A pole outside the unit circle widens the frame to it.
        let f = pz_frame(&[(1.5, 0.0), (0.2, 0.0)], &[(4000.0, 0.0)]);
        assert!((f.half - 1.65).abs() < 1e-12, "{}", f.half);
        assert_eq!(f.far.len(), 1);
        // No poles, no zeros: the unit circle's frame.
        assert_eq!(pz_frame(&[], &[]).half, 1.2);
    }
}

//! The report type every reproduction returns.

use lifted_lti::StateSpace;
use serde::{Deserialize, Serialize};
use std::fmt;

/// One acceptance check: a measured value and the condition it must meet.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Check {
    /// What is checked, e.g. "slow pole within 3% of 0.348 rad/s".
    pub name: String,
    /// The value obtained by the simulation.
    pub value: f64,
    /// The value the paper prints, if it prints one.
    pub paper: Option<f64>,
    /// The value it is compared with (the paper's, or the spec's reference
    /// implementation's where the paper has none or is wrong), if any.
    pub reference: Option<f64>,
    /// Human-readable condition, e.g. "|value - 0.348| / 0.348 < 0.03".
    pub condition: String,
    /// Whether the condition holds.
    pub passed: bool,
    /// Provenance of the bound, or why a published number is not reached.
    pub note: Option<String>,
}

impl Check {
    /// A check that `value` lies within `rel_tol` (relative) of `reference`.
    pub fn relative(name: impl Into<String>, value: f64, reference: f64, rel_tol: f64) -> Self {
        let err = (value - reference).abs() / reference.abs().max(f64::MIN_POSITIVE);
        Check {
            name: name.into(),
            value,
            paper: None,
            reference: Some(reference),
            condition: format!("relative error {err:.3e} <= {rel_tol:.3e}"),
            passed: err.is_finite() && err <= rel_tol,
            note: None,
        }
    }

    /// A check that `value` lies within `abs_tol` of `reference`.
    pub fn absolute(name: impl Into<String>, value: f64, reference: f64, abs_tol: f64) -> Self {
        let err = (value - reference).abs();
        Check {
            name: name.into(),
            value,
            paper: None,
            reference: Some(reference),
            condition: format!("|value - {reference}| = {err:.3e} <= {abs_tol:.3e}"),
            passed: err.is_finite() && err <= abs_tol,
            note: None,
        }
    }

    /// A check that `value < bound`.
    pub fn below(name: impl Into<String>, value: f64, bound: f64) -> Self {
        Check {
            name: name.into(),
            value,
            paper: None,
            reference: None,
            condition: format!("{value:.6e} < {bound:.6e}"),
            passed: value < bound,
            note: None,
        }
    }

    /// A check that `value > bound`.
    pub fn above(name: impl Into<String>, value: f64, bound: f64) -> Self {
        Check {
            name: name.into(),
            value,
            paper: None,
            reference: None,
            condition: format!("{value:.6e} > {bound:.6e}"),
            passed: value > bound,
            note: None,
        }
    }

    /// A check that `lo < value < hi`.
    pub fn within(name: impl Into<String>, value: f64, lo: f64, hi: f64) -> Self {
        Check {
            name: name.into(),
            value,
            paper: None,
            reference: None,
            condition: format!("{lo} < {value:.6e} < {hi}"),
            passed: lo < value && value < hi,
            note: None,
        }
    }

    /// A boolean condition (the value is recorded as 1.0 or 0.0).
    pub fn holds(name: impl Into<String>, condition: impl Into<String>, passed: bool) -> Self {
        Check {
            name: name.into(),
            value: if passed { 1.0 } else { 0.0 },
            paper: None,
            reference: None,
            condition: condition.into(),
            passed,
            note: None,
        }
    }

    /// Records the value printed in the paper (shown next to ours in reports).
    pub fn with_paper(mut self, paper: f64) -> Self {
        self.paper = Some(paper);
        self
    }

    /// Attaches a provenance note (the source of the bound, or a deviation).
    pub fn with_note(mut self, note: impl Into<String>) -> Self {
        self.note = Some(note.into());
        self
    }
}

/// How a curve is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CurveStyle {
    /// A polyline through the points.
    Line,
    /// Markers only (the thesis' "star" estimates, order-selection dots).
    Points,
    /// A staircase: each value held until the next abscissa (sampled or
    /// held signals).
    Steps,
}

/// One curve of a figure: ordinates `y` against abscissae `x` (same length,
/// finite values).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Curve {
    /// Legend label.
    pub name: String,
    /// Abscissae.
    pub x: Vec<f64>,
    /// Ordinates.
    pub y: Vec<f64>,
    /// How it is drawn.
    pub style: CurveStyle,
}

impl Curve {
    /// A curve with explicit abscissae.
    pub fn new(name: impl Into<String>, x: Vec<f64>, y: Vec<f64>, style: CurveStyle) -> Self {
        Curve {
            name: name.into(),
            x,
            y,
            style,
        }
    }

    /// A curve against `x0, x0 + dx, x0 + 2dx, …` (e.g. t = k·T).
    pub fn sampled(
        name: impl Into<String>,
        x0: f64,
        dx: f64,
        y: Vec<f64>,
        style: CurveStyle,
    ) -> Self {
        let x = (0..y.len()).map(|k| x0 + k as f64 * dx).collect();
        Curve::new(name, x, y, style)
    }
}

/// A figure of one of the papers, recomputed by an experiment: the data
/// `lifted reproduce` plots (and writes to `reproductions.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FigureData {
    /// Stable identifier, also the HTML anchor, e.g. "zhu-fig1".
    pub id: String,
    /// Caption naming the paper's figure, e.g. "Zhu (2000) Fig. 1: …".
    pub caption: String,
    /// x-axis label.
    pub x_label: String,
    /// y-axis label (without "log10": the renderer adds it for `log_y`).
    pub y_label: String,
    /// Plot the ordinates on a logarithmic scale.
    pub log_y: bool,
    /// The curves.
    pub curves: Vec<Curve>,
}

impl FigureData {
    /// An empty figure (linear axes).
    pub fn new(
        id: impl Into<String>,
        caption: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        FigureData {
            id: id.into(),
            caption: caption.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            log_y: false,
            curves: Vec::new(),
        }
    }

    /// The same figure with a logarithmic y axis.
    pub fn with_log_y(mut self) -> Self {
        self.log_y = true;
        self
    }

    /// Adds a curve.
    pub fn with_curve(mut self, curve: Curve) -> Self {
        self.curves.push(curve);
        self
    }

    /// The curve with this name, if any.
    pub fn curve(&self, name: &str) -> Option<&Curve> {
        self.curves.iter().find(|c| c.name == name)
    }
}

/// Step responses of channel (output `o`, input `i`) of each discrete
/// model over `horizon` samples, as curves against t = k·T (T of each
/// model; 1 for a model without a sample period).
pub fn step_curves(
    models: &[(&str, &StateSpace, CurveStyle)],
    o: usize,
    i: usize,
    horizon: usize,
) -> Result<Vec<Curve>, lifted_lti::Error> {
    models
        .iter()
        .map(|(name, g, style)| {
            if o >= g.n_outputs() || i >= g.n_inputs() {
                return Err(lifted_lti::Error::IndexOutOfRange {
                    row: o,
                    col: i,
                    rows: g.n_outputs(),
                    cols: g.n_inputs(),
                });
            }
            let s = g.step(horizon, None)?;
            let y: Vec<f64> = s
                .get(i)
                .map(|m| m.column(o).iter().copied().collect())
                .unwrap_or_default();
            Ok(Curve::sampled(*name, 0.0, g.ts().unwrap_or(1.0), y, *style))
        })
        .collect()
}

/// The outcome of one reproduced experiment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Reproduction {
    /// Spec section, e.g. "A1.5".
    pub section: String,
    /// Short title, e.g. "Zhu 2000 Tables II/III: diesel engine stand-in".
    pub title: String,
    /// The acceptance checks, in the order of the spec.
    pub checks: Vec<Check>,
    /// Free-form numbers worth printing (name, value) that are not checks.
    pub figures: Vec<(String, f64)>,
    /// The papers' figures recomputed by the experiment, drawn by
    /// `lifted reproduce` next to the checks. Empty by default.
    #[serde(default)]
    pub plots: Vec<FigureData>,
}

impl Reproduction {
    /// An empty report for a section.
    pub fn new(section: impl Into<String>, title: impl Into<String>) -> Self {
        Reproduction {
            section: section.into(),
            title: title.into(),
            checks: Vec::new(),
            figures: Vec::new(),
            plots: Vec::new(),
        }
    }

    /// Adds a check.
    pub fn check(&mut self, check: Check) -> &mut Self {
        self.checks.push(check);
        self
    }

    /// Records a figure that is reported but not checked.
    pub fn figure(&mut self, name: impl Into<String>, value: f64) -> &mut Self {
        self.figures.push((name.into(), value));
        self
    }

    /// Records a figure of the paper (curves) for the HTML report.
    pub fn plot(&mut self, figure: FigureData) -> &mut Self {
        self.plots.push(figure);
        self
    }

    /// The recorded figure with this id, if any.
    pub fn plot_by_id(&self, id: &str) -> Option<&FigureData> {
        self.plots.iter().find(|f| f.id == id)
    }

    /// True when every check passed (and there is at least one).
    pub fn all_passed(&self) -> bool {
        !self.checks.is_empty() && self.checks.iter().all(|c| c.passed)
    }

    /// The checks that failed.
    pub fn failures(&self) -> Vec<&Check> {
        self.checks.iter().filter(|c| !c.passed).collect()
    }
}

impl fmt::Display for Reproduction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{} — {}", self.section, self.title)?;
        for c in &self.checks {
            let mark = if c.passed { "pass" } else { "FAIL" };
            write!(f, "  [{mark}] {}: {} ({})", c.name, c.value, c.condition)?;
            if let Some(p) = c.paper {
                write!(f, " [paper {p}]")?;
            }
            if let Some(r) = c.reference {
                write!(f, " [reference {r}]")?;
            }
            if let Some(n) = &c.note {
                write!(f, " — {n}")?;
            }
            writeln!(f)?;
        }
        for (name, value) in &self.figures {
            writeln!(f, "  {name} = {value}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_check_passes_and_fails() {
        assert!(Check::relative("x", 1.02, 1.0, 0.03).passed);
        assert!(!Check::relative("x", 1.04, 1.0, 0.03).passed);
        assert!(!Check::relative("x", f64::NAN, 1.0, 0.03).passed);
    }

    #[test]
    fn empty_report_does_not_pass() {
        let r = Reproduction::new("A0", "nothing");
        assert!(!r.all_passed());
    }

    #[test]
    fn plots_default_to_empty_and_round_trip() {
        let old = r#"{"section":"A0","title":"t","checks":[],"figures":[]}"#;
        let r: Reproduction = serde_json::from_str(old).unwrap();
        assert!(r.plots.is_empty());
        let mut r = Reproduction::new("A0", "demo");
        r.plot(
            FigureData::new("demo-fig", "Demo", "x", "y")
                .with_log_y()
                .with_curve(Curve::sampled(
                    "c",
                    1.0,
                    0.5,
                    vec![1.0, 10.0],
                    CurveStyle::Steps,
                )),
        );
        let json = serde_json::to_string(&r).unwrap();
        assert!(json.contains(r#""style":"steps""#) && json.contains(r#""log_y":true"#));
        let back: Reproduction = serde_json::from_str(&json).unwrap();
        assert_eq!(back, r);
        let c = back.plot_by_id("demo-fig").unwrap().curve("c").unwrap();
        assert_eq!(c.x, vec![1.0, 1.5]);
    }

    #[test]
    fn step_curves_of_a_first_order_model() {
        let g = StateSpace::new(
            nalgebra::DMatrix::from_element(1, 1, 0.5),
            nalgebra::DMatrix::from_element(1, 1, 1.0),
            nalgebra::DMatrix::from_element(1, 1, 1.0),
            nalgebra::DMatrix::zeros(1, 1),
            Some(2.0),
        )
        .unwrap();
        let c = step_curves(&[("g", &g, CurveStyle::Line)], 0, 0, 4).unwrap();
        assert_eq!(c[0].x, vec![0.0, 2.0, 4.0, 6.0]);
        assert_eq!(c[0].y, vec![0.0, 1.0, 1.5, 1.75]);
        assert!(step_curves(&[("g", &g, CurveStyle::Line)], 1, 0, 4).is_err());
    }

    #[test]
    fn report_lists_failures() {
        let mut r = Reproduction::new("A0", "demo");
        r.check(Check::below("a", 1.0, 2.0));
        r.check(Check::above("b", 1.0, 2.0));
        assert!(!r.all_passed());
        assert_eq!(r.failures().len(), 1);
        assert!(r.to_string().contains("FAIL"));
    }
}

//! Confidence bands of a model file that carries a parameter covariance
//! (polynomial and process models, and state-space models with the
//! covariance of their entries; issue 49): ± z σ around the step
//! responses and the Bode magnitude and phase, σ by first-order
//! propagation of the covariance (`lifted_lti::PolyModel::step_std`,
//! `freqresp_std`; `lifted_lti::SsCovariance`'s), z the two-sided normal
//! quantile of the level (MATLAB's `showConfidence`). Used by `lifted
//! step`, `lifted bode` and the report.

use lifted_linalg::budget::{MemoryBudget, Size};
use lifted_lti::{Bode, FreqStd, ModelFile, PolyModel, SsCovariance, StateSpace};
use nalgebra::DMatrix;

use crate::error::{CliResult, Context, input};
use crate::plot::Series;
use crate::service::figures::NamedColumn;
use crate::service::pairs::PairFigure;

/// The parameter uncertainty of a model file, whichever model carries it.
#[derive(Clone, Copy)]
pub enum Uncertain<'a> {
    /// A polynomial or process model with its parameter covariance.
    Poly(&'a PolyModel),
    /// A state-space model with the covariance of its entries.
    StateSpace(&'a StateSpace, &'a SsCovariance),
}

impl<'a> Uncertain<'a> {
    /// The file's uncertainty: its polynomial model's (when it carries a
    /// covariance) or its state-space covariance; `None` without either.
    pub fn of(file: &'a ModelFile) -> Option<Self> {
        match (&file.polynomial, &file.covariance) {
            (Some(p), _) if p.covariance().is_some() => Some(Uncertain::Poly(p)),
            (None, Some(c)) => Some(Uncertain::StateSpace(&file.model, c)),
            _ => None,
        }
    }

    /// Parameters whose moves the propagation differentiates along.
    fn parameters(&self) -> usize {
        match self {
            Uncertain::Poly(p) => p.parameters().len(),
            Uncertain::StateSpace(_, c) => c.matrix().nrows(),
        }
    }

    fn dims(&self) -> (usize, usize) {
        match self {
            Uncertain::Poly(p) => (p.n_outputs(), p.n_inputs()),
            Uncertain::StateSpace(m, _) => (m.n_outputs(), m.n_inputs()),
        }
    }

    fn freqresp_std(&self, omega: &[f64]) -> lifted_lti::Result<Option<FreqStd>> {
        match self {
            Uncertain::Poly(p) => p.freqresp_std(omega),
            Uncertain::StateSpace(m, c) => c.freqresp_std(m, omega).map(Some),
        }
    }

    fn step_std(&self, samples: usize) -> lifted_lti::Result<Option<Vec<DMatrix<f64>>>> {
        match self {
            Uncertain::Poly(p) => p.step_std(samples),
            Uncertain::StateSpace(m, c) => c.step_std(m, samples).map(Some),
        }
    }
}

/// The level of the bands where none is given (`lifted bode`, `step`,
/// the studio): 95 %.
pub const DEFAULT_CONFIDENCE: f64 = 0.95;

/// Lower and upper bounds of one response column, sample by sample.
pub type Bounds = (Vec<f64>, Vec<f64>);

/// `Err` unless `confidence` is a level in [0, 1) (0: no band), naming
/// the flag.
pub fn check_level(confidence: f64) -> CliResult<()> {
    if confidence.is_finite() && (0.0..1.0).contains(&confidence) {
        Ok(())
    } else {
        Err(input(format!(
            "--confidence {confidence}: a level in [0, 1) (0.95 for 95 %; 0: no band)"
        )))
    }
}

/// The two-sided normal quantile of `confidence`.
fn quantile(confidence: f64) -> CliResult<f64> {
    lifted_lti::normal_quantile(0.5 + confidence / 2.0).ctx("confidence band")
}

/// The legend entry of a band.
pub fn label(confidence: f64) -> String {
    format!("±{:.0} %", 100.0 * confidence)
}

/// Lower and upper bounds of each of `step_data`'s columns `cols` (per
/// input, per output) of `poly`'s step responses, `None` when there is no
/// band (no covariance, or `confidence` 0). O(p² · samples · n_u n_y) for
/// p parameters, plus 2p step responses.
pub fn step_bounds(
    poly: Option<Uncertain<'_>>,
    cols: &[NamedColumn],
    confidence: f64,
) -> CliResult<Option<Vec<Bounds>>> {
    let (Some(p), true) = (poly, confidence > 0.0) else {
        return Ok(None);
    };
    let samples = cols.first().map_or(0, |c| c.1.len());
    // One set of step responses per parameter, two more per step and the
    // σ: refused before allocating when over the memory budget.
    MemoryBudget::default()
        .check(
            "the step response's confidence band (--samples)",
            Size::matrices((2 * p.parameters() + 3) * p.dims().1, samples, p.dims().0),
        )
        .ctx("step confidence band")?;
    let Some(sigma) = p.step_std(samples).ctx("step confidence band")? else {
        return Ok(None);
    };
    let z = quantile(confidence)?;
    let per_column = sigma.iter().flat_map(|s| {
        (0..s.ncols()).map(move |i| s.column(i).iter().copied().collect::<Vec<f64>>())
    });
    Ok(Some(
        cols.iter()
            .zip(per_column)
            .map(|((_, y), s)| {
                (
                    y.iter().zip(&s).map(|(v, s)| v - z * s).collect(),
                    y.iter().zip(&s).map(|(v, s)| v + z * s).collect(),
                )
            })
            .collect(),
    ))
}

/// `lo` then `hi` as one series over `x` twice (a NaN joins them), named
/// `name`.
pub fn bound_series(name: String, x: &[f64], lo: &[f64], hi: &[f64]) -> Series {
    // `a`, a NaN (the pen lifted), then `b`.
    let joined = |a: &[f64], b: &[f64]| -> Vec<f64> {
        a.iter()
            .copied()
            .chain([f64::NAN])
            .chain(b.iter().copied())
            .collect()
    };
    Series::line(name, joined(x, x), joined(lo, hi))
}

/// Adds the step bounds (`step_bounds` of the figure's first model, on
/// its time grid `t`) to the cells of a `step_pairs` figure.
pub fn add_step_band(fig: &mut PairFigure, t: &[f64], bounds: &[Bounds], confidence: f64) {
    let (ny, nu) = (fig.n_y, fig.n_u);
    for (c, (lo, hi)) in bounds.iter().enumerate() {
        // step_data's columns: per input j, per output i.
        let (j, i) = (c / ny.max(1), c % ny.max(1));
        if let Some(cell) = fig.cells.get_mut(i * nu + j)
            && let Some(plot) = cell.1.first_mut()
        {
            plot.series.push(bound_series(label(confidence), t, lo, hi));
        }
    }
}

/// The Bode band of `poly` on `omega`: per frequency and pair, the bounds
/// [|G| lower in dB, upper in dB, phase lower, upper in degrees] around
/// the response `b` (a lower bound at or below zero magnitude is NaN: no
/// dB value); `None` when there is no band.
pub fn bode_bounds(
    poly: Option<Uncertain<'_>>,
    b: &Bode,
    omega: &[f64],
    confidence: f64,
) -> CliResult<Option<BodeBand>> {
    let (Some(p), true) = (poly, confidence > 0.0) else {
        return Ok(None);
    };
    // One complex response per parameter and two per difference:
    // refused before allocating when over the memory budget.
    MemoryBudget::default()
        .check(
            "the frequency response's confidence band",
            Size::matrices(
                2 * (p.parameters() + 3),
                omega.len(),
                p.dims().0 * p.dims().1,
            ),
        )
        .ctx("bode confidence band")?;
    let Some(s) = p.freqresp_std(omega).ctx("bode confidence band")? else {
        return Ok(None);
    };
    let z = quantile(confidence)?;
    let db = |g: f64| 20.0 * g.max(1e-300).log10();
    let bounds = (0..omega.len())
        .map(|k| {
            let g = &b.magnitude[k];
            nalgebra::DMatrix::from_fn(g.nrows(), g.ncols(), |i, j| {
                let (gm, sm) = (g[(i, j)], s.magnitude[k][(i, j)]);
                let (ph, sp) = (b.phase_deg[k][(i, j)], s.phase[k][(i, j)].to_degrees());
                let lo = if gm - z * sm > 0.0 {
                    db(gm - z * sm)
                } else {
                    f64::NAN
                };
                [lo, db(gm + z * sm), ph - z * sp, ph + z * sp]
            })
        })
        .collect();
    Ok(Some(BodeBand { std: s, bounds }))
}

/// A Bode band: the standard deviations and, per frequency, the bounds of
/// each pair ([`bode_bounds`]).
pub struct BodeBand {
    /// σ of |G| and of arg G.
    pub std: FreqStd,
    /// Per frequency, per pair: [dB lower, dB upper, phase lower, phase
    /// upper].
    pub bounds: Vec<nalgebra::DMatrix<[f64; 4]>>,
}

/// Adds a Bode band to the cells of a `bode_pairs` figure (magnitude plot
/// first, phase second), x in log10 ω as `bode_pairs` draws it.
pub fn add_bode_band(fig: &mut PairFigure, omega: &[f64], band: &BodeBand, confidence: f64) {
    let lw: Vec<f64> = omega.iter().map(|w| w.log10()).collect();
    let nu = fig.n_u;
    for i in 0..fig.n_y {
        for j in 0..nu {
            let v: Vec<[f64; 4]> = band.bounds.iter().map(|m| m[(i, j)]).collect();
            let Some(cell) = fig.cells.get_mut(i * nu + j) else {
                continue;
            };
            for (plot, (lo, hi)) in [(0, (0, 1)), (1, (2, 3))] {
                let l: Vec<f64> = v.iter().map(|r| r[lo]).collect();
                let h: Vec<f64> = v.iter().map(|r| r[hi]).collect();
                if let Some(p) = cell.1.get_mut(plot) {
                    p.series.push(bound_series(label(confidence), &lw, &l, &h));
                }
            }
        }
    }
}

//! The ARX structure scan (MATLAB's `arxstruc` + `selstruc`) and the delay
//! estimate (`delayest`), both on one compression of the records.
//!
//! Every candidate (na, nb, nk) is a least-squares solve on columns of the
//! same compressed factor (module `lagged`), so a grid of G structures costs
//! one pass over the data plus O(G n_y k d²). All candidates share the same
//! regression rows (those with the grid's longest lag available), so their
//! losses compare on the same data. Criteria ([`StructureCriterion`]), with
//! V_i the mean squared one-step error of output i over J rows and d the
//! parameters of all outputs:
//!
//! * Akaike: Σ_i ln V_i + 2d/J (ln of MATLAB's `selstruc` 'aic',
//!   V (1 + 2d/J), to first order);
//! * Rissanen's MDL: Σ_i ln V_i + d ln J / J;
//! * held out: Σ_i ln V_i on validation records, the coefficients fitted on
//!   the estimation records (MATLAB's `arxstruc(ze, zv, …)`), with the
//!   one-standard-error rule for the choice ([`ArxScan::best`]).

use lifted_lti::PolyOrders;
use lifted_subspace::{Compression, Experiment};
use serde::{Deserialize, Serialize};

use super::lagged::Lagged;
use super::{channels, regressors};
use crate::error::{Error, Result};

/// One candidate structure of the scan: the same na for every output lag,
/// nb and nk for every input (MATLAB's `struc`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ArxStructure {
    /// Degree of every A entry.
    pub na: usize,
    /// Coefficients of every B entry.
    pub nb: usize,
    /// Delay of every input.
    pub nk: usize,
}

/// Which outputs' past enters each output's equation of a MIMO ARX: the
/// pattern of MATLAB's n_y × n_y `na` matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum AStructure {
    /// Every output's past in every output's equation (`na` full, MATLAB's
    /// `arx` with `na = n·ones(ny)`): the default.
    #[default]
    Full,
    /// Each output's own past only (`na = n·eye(ny)`): one MISO model per
    /// output, the structure of SIPPY's and sysidentpy's ARX. A diagonal A
    /// fits each output by least squares on its own regressors; it is the
    /// same model as n_y single-output fits.
    Diagonal,
}

impl ArxStructure {
    /// The [`PolyOrders`] of this structure for `nu` inputs and `ny`
    /// outputs (A full n_y × n_y).
    pub fn orders(&self, nu: usize, ny: usize) -> PolyOrders {
        self.orders_with(nu, ny, AStructure::Full)
    }

    /// The [`PolyOrders`] of this structure with A of pattern `a`.
    pub fn orders_with(&self, nu: usize, ny: usize, a: AStructure) -> PolyOrders {
        let na = |i: usize, j: usize| match a {
            AStructure::Diagonal if i != j => 0,
            _ => self.na,
        };
        PolyOrders {
            na: (0..ny)
                .map(|i| (0..ny).map(|j| na(i, j)).collect())
                .collect(),
            nb: vec![vec![self.nb; nu]; ny],
            nc: vec![0; ny],
            nd: vec![0; ny],
            nf: vec![vec![0; nu]; ny],
            nk: vec![vec![self.nk; nu]; ny],
        }
    }
}

/// How the scan picks a structure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum StructureCriterion {
    /// Akaike's criterion on the estimation records (default when no
    /// validation records are given).
    #[default]
    Aic,
    /// Rissanen's minimum description length (more parsimonious).
    Mdl,
    /// The one-step loss on the validation records.
    Validation,
}

/// Options of [`arx_scan`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ArxScanOptions {
    /// Candidate na (default 1..=10; 0 is the FIR structure).
    pub na: Vec<usize>,
    /// Candidate nb (default 1..=10).
    pub nb: Vec<usize>,
    /// Candidate nk (default `vec![1]`, MATLAB's `struc(1:10, 1:10, 1)`).
    pub nk: Vec<usize>,
    /// Compression of the lagged data (default [`Compression::Auto`]).
    pub compression: Compression,
    /// Threads of the correlation kernel (0 = all cores).
    pub threads: usize,
    /// The pattern of A of every candidate (default [`AStructure::Full`]).
    pub a_structure: AStructure,
}

impl Default for ArxScanOptions {
    fn default() -> Self {
        ArxScanOptions {
            na: (1..=10).collect(),
            nb: (1..=10).collect(),
            nk: vec![1],
            compression: Compression::Auto,
            threads: 0,
            a_structure: AStructure::Full,
        }
    }
}

/// One candidate's losses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ArxScanRow {
    /// The structure.
    pub structure: ArxStructure,
    /// Parameters d of all outputs.
    pub parameters: usize,
    /// Mean squared one-step error per output on the estimation rows.
    pub loss: Vec<f64>,
    /// Σ ln V_i + 2d/J.
    pub aic: f64,
    /// Σ ln V_i + d ln J / J.
    pub mdl: f64,
    /// Mean squared one-step error per output on the validation records
    /// (coefficients from the estimation records), when given.
    pub validation_loss: Option<Vec<f64>>,
}

impl ArxScanRow {
    /// The row's value of `criterion` (lower is better; +∞ for
    /// [`StructureCriterion::Validation`] without validation records).
    pub fn value(&self, criterion: StructureCriterion) -> f64 {
        match criterion {
            StructureCriterion::Aic => self.aic,
            StructureCriterion::Mdl => self.mdl,
            StructureCriterion::Validation => self
                .validation_loss
                .as_ref()
                .map_or(f64::INFINITY, |v| v.iter().map(|x| x.ln()).sum()),
        }
    }
}

/// What [`arx_scan`] measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ArxScan {
    /// One row per structure the data determine, in the order na, nb, nk.
    pub rows: Vec<ArxScanRow>,
    /// Structures left out and why (regressors rank deficient).
    pub skipped: Vec<(ArxStructure, String)>,
    /// Estimation rows J shared by every candidate.
    pub samples: usize,
    /// Validation rows, when validation records were given.
    pub validation_samples: Option<usize>,
}

impl ArxScan {
    /// The row with the lowest `criterion` (ties: fewer parameters first),
    /// `None` when no candidate could be fitted.
    ///
    /// For [`StructureCriterion::Validation`] the one-standard-error rule
    /// (Hastie, Tibshirani & Friedman 2009, §7.10): the held-out loss does
    /// not penalise parameters, and structures within its sampling spread of
    /// the lowest predict equally well, so the one with the fewest
    /// parameters among those whose Σ ln V_i is within n_y √(2/M) of the
    /// lowest is chosen (M validation rows: for Gaussian errors the mean
    /// square of M residuals has relative standard deviation √(2/M), which
    /// is the standard deviation of its logarithm to first order).
    pub fn best(&self, criterion: StructureCriterion) -> Option<&ArxScanRow> {
        let lowest = self.rows.iter().min_by(|a, b| {
            a.value(criterion)
                .total_cmp(&b.value(criterion))
                .then(a.parameters.cmp(&b.parameters))
        })?;
        let (StructureCriterion::Validation, Some(m)) = (criterion, self.validation_samples) else {
            return Some(lowest);
        };
        let outputs = lowest.loss.len() as f64;
        let bound = lowest.value(criterion) + outputs * (2.0 / m.max(1) as f64).sqrt();
        self.rows
            .iter()
            .filter(|r| r.value(criterion) <= bound)
            .min_by(|a, b| {
                a.parameters
                    .cmp(&b.parameters)
                    .then(a.value(criterion).total_cmp(&b.value(criterion)))
            })
    }

    /// The row with the lowest `criterion`, without the one-standard-error
    /// rule of [`ArxScan::best`].
    pub fn lowest(&self, criterion: StructureCriterion) -> Option<&ArxScanRow> {
        self.rows.iter().min_by(|a, b| {
            a.value(criterion)
                .total_cmp(&b.value(criterion))
                .then(a.parameters.cmp(&b.parameters))
        })
    }
}

fn check_grid(what: &'static str, v: &[usize]) -> Result<()> {
    if v.is_empty() {
        return Err(Error::InvalidOption {
            what,
            reason: "at least one candidate value".into(),
        });
    }
    Ok(())
}

/// Scans the ARX structures of the grid na × nb × nk on `estimation`,
/// scoring each also on `validation` when that is not empty (module docs).
///
/// Cost: one compression of each set of records for the longest lag
/// L = max(na) ∨ max(nk + nb − 1) of the grid, then O(G n_y k d²) for the
/// G candidates; memory O(k²).
///
/// Errors: [`Error::InvalidOption`] for an empty candidate list or a grid
/// whose every structure has no parameter; those of [`super::arx`] for the
/// records; [`Error::RankDeficient`] only when no candidate can be fitted.
pub fn arx_scan(
    estimation: &[Experiment<'_>],
    validation: &[Experiment<'_>],
    opts: &ArxScanOptions,
) -> Result<ArxScan> {
    check_grid("na", &opts.na)?;
    check_grid("nb", &opts.nb)?;
    check_grid("nk", &opts.nk)?;
    let (nu, ny) = channels(estimation)?;
    let max = |v: &[usize]| v.iter().copied().max().unwrap_or(0);
    let lags = max(&opts.na).max((max(&opts.nk) + max(&opts.nb)).saturating_sub(1));
    let data = Lagged::new(estimation, lags, opts.compression, opts.threads)?;
    let held = if validation.is_empty() {
        None
    } else {
        let (vu, vy) = channels(validation)?;
        if (vu, vy) != (nu, ny) {
            return Err(Error::DimensionMismatch {
                what: "validation records",
                expected: format!("{nu} inputs and {ny} outputs"),
                got: format!("{vu} inputs and {vy} outputs"),
            });
        }
        Some(Lagged::new(
            validation,
            lags,
            opts.compression,
            opts.threads,
        )?)
    };
    let j = data.rows as f64;
    let mut rows = Vec::new();
    let mut skipped = Vec::new();
    for &na in &opts.na {
        for &nb in &opts.nb {
            for &nk in &opts.nk {
                let structure = ArxStructure { na, nb, nk };
                if na == 0 && nb == 0 {
                    continue;
                }
                let orders = structure.orders_with(nu, ny, opts.a_structure);
                let mut loss = Vec::with_capacity(ny);
                let mut vloss = Vec::with_capacity(ny);
                let mut d = 0;
                let mut failed = None;
                for i in 0..ny {
                    let (cols, _) = regressors(&data, &orders, i);
                    d += cols.len();
                    if data.rows <= cols.len() {
                        failed = Some(format!("{} regressors for {} rows", cols.len(), data.rows));
                        break;
                    }
                    match data.solve(&cols, data.output(i, 0)) {
                        Ok(s) => {
                            if let Some(h) = &held {
                                vloss.push(h.loss_of(&cols, h.output(i, 0), &s.theta));
                            }
                            loss.push(s.loss);
                        }
                        Err(e) => {
                            failed = Some(e.to_string());
                            break;
                        }
                    }
                }
                if let Some(why) = failed {
                    skipped.push((structure, why));
                    continue;
                }
                let log_v: f64 = loss
                    .iter()
                    .map(|v: &f64| v.max(f64::MIN_POSITIVE).ln())
                    .sum();
                rows.push(ArxScanRow {
                    structure,
                    parameters: d,
                    aic: log_v + 2.0 * d as f64 / j,
                    mdl: log_v + d as f64 * j.ln() / j,
                    loss,
                    validation_loss: held.as_ref().map(|_| vloss),
                });
            }
        }
    }
    if rows.is_empty() {
        return Err(match skipped.first() {
            Some((s, why)) => Error::InvalidOption {
                what: "structure grid",
                reason: format!(
                    "no candidate could be fitted (na {}, nb {}, nk {}: {why})",
                    s.na, s.nb, s.nk
                ),
            },
            None => Error::InvalidOption {
                what: "structure grid",
                reason: "every candidate has na = nb = 0".into(),
            },
        });
    }
    Ok(ArxScan {
        rows,
        skipped,
        samples: data.rows,
        validation_samples: held.map(|h| h.rows),
    })
}

/// Options of [`estimate_delays`] (MATLAB's `delayest(data, na, nb, nkmin,
/// nkmax)`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DelayOptions {
    /// Degree of A of the ARX models compared (default 2).
    pub na: usize,
    /// Coefficients of B (default 2).
    pub nb: usize,
    /// Smallest delay tried (default 0).
    pub min_delay: usize,
    /// Largest delay tried (default 20).
    pub max_delay: usize,
    /// Compression of the lagged data (default [`Compression::Auto`]).
    pub compression: Compression,
    /// Threads of the correlation kernel (0 = all cores).
    pub threads: usize,
}

impl Default for DelayOptions {
    fn default() -> Self {
        DelayOptions {
            na: 2,
            nb: 2,
            min_delay: 0,
            max_delay: 20,
            compression: Compression::Auto,
            threads: 0,
        }
    }
}

/// The input delay of every input–output pair (n_y × n_u, samples): for
/// each output, ARX models with A of degree `na` and `nb` coefficients per
/// input are compared over delays `min_delay..=max_delay`, input by input
/// (the other inputs at their current estimates, starting at
/// `min_delay`; two sweeps), and the delay with the lowest loss kept. All
/// candidates share one compression and the same rows, and have the same
/// number of parameters, so their losses compare directly.
///
/// Cost: one compression for the longest lag max_delay + nb − 1, then
/// O(2 n_y n_u (max − min + 1) k d²).
///
/// Errors: [`Error::InvalidOption`] for `min_delay > max_delay` or
/// na = nb = 0, `nb` = 0; those of [`super::arx`] for the records.
pub fn estimate_delays(
    experiments: &[Experiment<'_>],
    opts: &DelayOptions,
) -> Result<Vec<Vec<usize>>> {
    if opts.min_delay > opts.max_delay || opts.nb == 0 {
        return Err(Error::InvalidOption {
            what: "delay range",
            reason: format!(
                "min_delay ≤ max_delay and nb ≥ 1, got {}..={} and nb {}",
                opts.min_delay, opts.max_delay, opts.nb
            ),
        });
    }
    let (nu, ny) = channels(experiments)?;
    let lags = opts.na.max(opts.max_delay + opts.nb - 1);
    let data = Lagged::new(experiments, lags, opts.compression, opts.threads)?;
    let mut delays = vec![vec![opts.min_delay; nu]; ny];
    for (i, row) in delays.iter_mut().enumerate() {
        for _sweep in 0..2 {
            for k in 0..nu {
                let mut best: Option<(f64, usize)> = None;
                for nk in opts.min_delay..=opts.max_delay {
                    row[k] = nk;
                    let orders = PolyOrders {
                        na: vec![vec![opts.na; ny]; ny],
                        nb: vec![vec![opts.nb; nu]; ny],
                        nc: vec![0; ny],
                        nd: vec![0; ny],
                        nf: vec![vec![0; nu]; ny],
                        nk: vec![row.clone(); ny],
                    };
                    let (cols, _) = regressors(&data, &orders, i);
                    if let Ok(s) = data.solve(&cols, data.output(i, 0))
                        && best.is_none_or(|(v, _)| s.loss < v)
                    {
                        best = Some((s.loss, nk));
                    }
                }
                row[k] = match best {
                    Some((_, nk)) => nk,
                    None => {
                        return Err(Error::RankDeficient {
                            what: "the ARX regressors of every delay tried",
                            rank: 0,
                            needed: opts.na * ny + opts.nb * nu,
                        });
                    }
                };
            }
        }
    }
    Ok(delays)
}

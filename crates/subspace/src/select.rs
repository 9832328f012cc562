//! Structure selection by held-out simulation fit: the horizon, the
//! (A, C) route and (optionally) the order of a subspace identification
//! chosen from the data, not from the singular values alone.
//!
//! The singular-value gap fails on real records (it picked order 1 on 9 of
//! 14 DaISy records where the literature orders give 10–96 points more
//! validation fit), and no single horizon or route is best on every record
//! (`benches/README.md`, "Real records beside SIPPY"). Each candidate
//! structure (horizon s = p = f, [`SystemEstimate`], order n) is therefore
//! identified on the first part of every record (by default 2/3) and
//! scored by its simulation fit on the held-out rest, with the initial
//! state of the held-out part estimated by least squares (the way a
//! validation record is scored): fit = 100 (1 − ‖y − ŷ‖/‖y − ȳ‖), averaged
//! over the outputs and records. Unstable candidates score nothing. The
//! selection is the smallest order, then the shortest horizon, within
//! [`StructureOptions::tolerance`] points of the best score (parsimony).
//!
//! Cost: one compression of the estimation part per (horizon, route),
//! O(N (n_u + n_y)² s), then per order O(k³) and the (B, D, x₀)
//! regression O(N q²), and a simulation of the held-out part, O(N n²).

use lifted_lti::StateSpace;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::engine::{
    Experiment, OrderSelection, SubspaceOptions, SystemEstimate, models_of_orders,
};
use crate::error::{Error, Result};
use crate::regress::{Record, estimate_x0};

/// Options of [`select_structure`]. `Default` gives the values documented
/// per field.
#[derive(Debug, Clone, PartialEq)]
pub struct StructureOptions {
    /// Candidate horizons s (p = f = s); an empty list means the default:
    /// 5, 10, 15, 20 and 30 for records of up to
    /// [`StructureOptions::search_samples`] samples, 10 beyond; always
    /// limited to those the estimation part supports with at least
    /// 3 k Hankel columns (k = 2 s (n_u + n_y)). A horizon given by the
    /// caller is the only candidate.
    pub horizons: Vec<usize>,
    /// Candidate (A, C) routes; empty means the default: shift invariance
    /// and the state sequences up to `search_samples` samples, shift
    /// invariance (consistent) beyond.
    pub systems: Vec<SystemEstimate>,
    /// Largest order tried when the order is automatic. Default 10.
    pub max_order: usize,
    /// Fraction of every record held out for scoring (from its end).
    /// Default 1/3.
    pub holdout: f64,
    /// Points of fit within which a smaller order or horizon is preferred.
    /// Default 0.5.
    pub tolerance: f64,
    /// Records of up to this many samples (all records) get the full
    /// search of horizons and routes. Default 200 000.
    pub search_samples: usize,
}

impl Default for StructureOptions {
    fn default() -> Self {
        StructureOptions {
            horizons: Vec::new(),
            systems: Vec::new(),
            max_order: 10,
            holdout: 1.0 / 3.0,
            tolerance: 0.5,
            search_samples: 200_000,
        }
    }
}

/// One scored candidate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// Horizon s (p = f = s).
    pub horizon: usize,
    /// Route of (A, C).
    pub system: SystemEstimate,
    /// Order.
    pub order: usize,
    /// Held-out simulation fit in percent (mean over outputs and records);
    /// `None` for a failed fit or an unstable model.
    pub fit: Option<f64>,
}

/// Result of [`select_structure`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StructureSelection {
    /// Chosen horizon s.
    pub horizon: usize,
    /// Chosen (A, C) route.
    pub system: SystemEstimate,
    /// Chosen order.
    pub order: usize,
    /// Its held-out fit (percent).
    pub fit: f64,
    /// Every candidate with its score (the curve shown by the front ends).
    pub candidates: Vec<Candidate>,
    /// Samples used for the estimation parts and held out.
    pub split: (usize, usize),
}

/// Chooses the horizon, the (A, C) route and, when `base.order` is
/// automatic, the order of a subspace identification by held-out
/// simulation fit (module docs). `base` gives the method, the feedthrough,
/// the mean removal and the other options; a fixed order in it is kept.
/// The caller then identifies on the whole records with
/// `past = future = horizon`, `system`, `order = Fixed(order)`.
///
/// Errors: [`Error::NoData`], [`Error::DimensionMismatch`],
/// [`Error::NonFinite`] (as [`crate::identify`]); [`Error::HorizonTooLong`]
/// when the records are too short for any candidate horizon;
/// [`Error::InvalidOption`] for a hold-out fraction outside (0, 0.9];
/// [`Error::Unstable`] when no candidate gives a stable model (the
/// caller then keeps its defaults).
pub fn select_structure(
    experiments: &[Experiment<'_>],
    base: &SubspaceOptions,
    opts: &StructureOptions,
) -> Result<StructureSelection> {
    if !(opts.holdout > 0.0 && opts.holdout <= 0.9) {
        return Err(Error::InvalidOption {
            what: "holdout",
            reason: format!(
                "the held-out fraction must lie in (0, 0.9], got {}",
                opts.holdout
            ),
        });
    }
    let (nu, ny, total) = crate::engine::validate(experiments)?;
    let cut = |len: usize| len - ((len as f64 * opts.holdout).round() as usize).min(len);
    let parts: Vec<(DMatrix<f64>, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>)> = experiments
        .iter()
        .map(|e| {
            let n = e.u.nrows();
            let m = cut(n);
            (
                e.u.rows(0, m).into_owned(),
                e.y.rows(0, m).into_owned(),
                e.u.rows(m, n - m).into_owned(),
                e.y.rows(m, n - m).into_owned(),
            )
        })
        .collect();
    let est: Vec<Experiment<'_>> = parts
        .iter()
        .map(|p| Experiment { u: &p.0, y: &p.1 })
        .collect();
    let est_len: usize = parts.iter().map(|p| p.0.nrows()).sum();
    let shortest = parts.iter().map(|p| p.0.nrows()).min().unwrap_or(0);
    let search = total <= opts.search_samples;
    let horizons: Vec<usize> = if !opts.horizons.is_empty() {
        opts.horizons.clone()
    } else if search {
        vec![5, 10, 15, 20, 30]
    } else {
        vec![10]
    };
    // At least 3k Hankel columns per estimation part (k = 2 s (n_u + n_y)):
    // fewer make the compressed correlations too noisy to rank structures.
    let feasible: Vec<usize> = horizons
        .iter()
        .copied()
        .filter(|&s| {
            s >= 2 && {
                let k = 2 * s * (nu + ny);
                shortest + 1 >= 2 * s && shortest + 1 - 2 * s >= 3 * k
            }
        })
        .collect();
    let horizons = if feasible.is_empty() {
        // The shortest candidate the data allow at all (J ≥ k).
        match (2..=horizons.iter().copied().max().unwrap_or(10))
            .rev()
            .find(|&s| {
                let k = 2 * s * (nu + ny);
                shortest + 1 >= 2 * s && shortest + 1 - 2 * s >= k
            }) {
            Some(s) => vec![s],
            None => {
                return Err(Error::HorizonTooLong {
                    past: 2,
                    future: 2,
                    n_samples: est_len,
                    min_samples: 4 * (nu + ny) + 3,
                });
            }
        }
    } else {
        feasible
    };
    let systems: Vec<SystemEstimate> = if !opts.systems.is_empty() {
        opts.systems.clone()
    } else if search {
        vec![
            SystemEstimate::ShiftInvariance,
            SystemEstimate::StateSequence,
        ]
    } else {
        vec![SystemEstimate::ShiftInvariance]
    };
    let held: Vec<(&DMatrix<f64>, &DMatrix<f64>)> = parts.iter().map(|p| (&p.2, &p.3)).collect();
    let mut candidates = Vec::new();
    for &s in &horizons {
        for &system in &systems {
            let (cap, fixed) = match base.order {
                OrderSelection::Fixed(n) => (n, Some(n)),
                OrderSelection::Gap { max } => (max.min(opts.max_order).max(1), None),
            };
            let o = SubspaceOptions {
                past: s,
                future: s,
                system,
                order: OrderSelection::Fixed(1),
                ..base.clone()
            };
            let fitted = models_of_orders(&est, &o, cap);
            let (op, models) = match fitted {
                Ok(r) => r,
                Err(_) => (None, Vec::new()),
            };
            let orders: Vec<usize> = match fixed {
                Some(n) => vec![n],
                None => (1..=cap).collect(),
            };
            for n in orders {
                let fit = models
                    .get(n - 1)
                    .and_then(Option::as_ref)
                    .and_then(|m| held_out_fit(m, op.as_ref(), &held));
                candidates.push(Candidate {
                    horizon: s,
                    system,
                    order: n,
                    fit,
                });
            }
        }
    }
    let best = candidates
        .iter()
        .filter_map(|c| c.fit)
        .fold(f64::NEG_INFINITY, f64::max);
    if !best.is_finite() {
        return Err(Error::Unstable {
            spectral_radius: f64::NAN,
        });
    }
    // Parsimony: the smallest order, then the shortest horizon, then shift
    // invariance, within the tolerance of the best score.
    let chosen = candidates
        .iter()
        .filter(|c| c.fit.is_some_and(|f| f >= best - opts.tolerance))
        .min_by_key(|c| {
            (
                c.order,
                c.horizon,
                c.system != SystemEstimate::ShiftInvariance,
            )
        })
        .cloned()
        .ok_or(Error::NoData)?;
    Ok(StructureSelection {
        horizon: chosen.horizon,
        system: chosen.system,
        order: chosen.order,
        fit: chosen.fit.unwrap_or(best),
        candidates,
        split: (est_len, total - est_len),
    })
}

/// Simulation fit (percent, mean over outputs and records) of `model` on
/// the held-out parts, deviations from the estimation part's operating
/// point, x₀ of each part by least squares; `None` for an unstable model
/// or a failed simulation.
fn held_out_fit(
    model: &StateSpace,
    op: Option<&lifted_lti::OperatingPoint>,
    held: &[(&DMatrix<f64>, &DMatrix<f64>)],
) -> Option<f64> {
    let rho = model
        .poles()
        .ok()?
        .iter()
        .map(|p| p.norm())
        .fold(0.0, f64::max);
    if !(rho < 1.0) {
        return None;
    }
    let dev: Vec<(DMatrix<f64>, DMatrix<f64>)> = held
        .iter()
        .map(|(u, y)| match op {
            Some(op) => op.to_deviations(u, y).ok(),
            None => Some(((*u).clone(), (*y).clone())),
        })
        .collect::<Option<_>>()?;
    let recs: Vec<Record<'_>> = dev
        .iter()
        .map(|(u, y)| Record {
            u,
            y,
            instrument: None,
        })
        .collect();
    let x0: Vec<DVector<f64>> =
        estimate_x0(model.a(), model.b(), model.c(), model.d(), &recs).ok()?;
    let (mut sum, mut count) = (0.0, 0usize);
    for ((u, y), x) in dev.iter().zip(&x0) {
        if u.nrows() < 2 {
            continue;
        }
        let yh = model.lsim(u, Some(x), None).ok()?.y;
        for o in 0..y.ncols() {
            let col = y.column(o);
            let mean = col.mean();
            let den = col.iter().map(|v| (v - mean).powi(2)).sum::<f64>().sqrt();
            let num = col
                .iter()
                .zip(yh.column(o).iter())
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>()
                .sqrt();
            if den > 0.0 && num.is_finite() {
                sum += 100.0 * (1.0 - num / den);
                count += 1;
            }
        }
    }
    (count > 0).then(|| sum / count as f64)
}

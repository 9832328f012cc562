//! The order of a subspace method chosen by held-out simulation fit, for
//! the methods whose horizon and (A, C) route are not searched
//! ([`crate::select_pbsid_order`], [`crate::select_iv_order`]): the folds,
//! the score and the parsimony rule of [`crate::select_structure`] (six
//! blocks each held out once for records of up to
//! [`StructureOptions::blocked_samples`] samples, else the last of
//! [`StructureOptions::folds`] blocks; simulation fit with x₀ by least
//! squares and the FPE factor for its n parameters, a fold without a stable
//! model counting as −100 %; the smallest order within
//! [`StructureOptions::tolerance`] points of the best).

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::crossval::{Folds, floored_at};
use crate::error::{Error, Result};
use crate::model::Experiment;
use crate::records::OwnedRecords;
use crate::select::{StructureOptions, parsimonious};

/// One order scored on the held-out blocks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrderCandidate {
    /// Order n.
    pub order: usize,
    /// Held-out simulation fit in percent (mean over the folds; a fold
    /// without a stable model counts as −100); `None` when no fold gave a
    /// stable model.
    pub fit: Option<f64>,
    /// The fit of each held-out fold (floored at −100 like the mean), in
    /// fold order.
    pub fold_fits: Vec<f64>,
}

/// An order chosen by held-out simulation fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeldOutOrder {
    /// The horizon every fold used: PBSID's past horizon p (chosen on the
    /// whole records), the IV method's α.
    pub horizon: usize,
    /// PBSID/SSARX: the future horizon f every fold used (the options'
    /// one, or shorter with the past when the whole records' past outputs
    /// are linearly dependent); the caller identifies the whole records
    /// with it. The IV method: its α, as `horizon`.
    #[serde(default)]
    pub future: usize,
    /// What the preparation of the whole records noted about the horizons
    /// (PBSID/SSARX: a past horizon shortened, Akaike's choice at its
    /// bound); the caller adds them to the model's notes.
    #[serde(default)]
    pub notes: Vec<String>,
    /// The order chosen (the first of [`HeldOutOrder::ranking`]).
    pub order: usize,
    /// Its held-out fit (percent).
    pub fit: f64,
    /// Every order with its score (the curve shown by the front ends).
    pub candidates: Vec<OrderCandidate>,
    /// Folds scored (1: the last block held out; more: blocked
    /// cross-validation).
    pub folds: usize,
}

impl HeldOutOrder {
    /// The scored orders in the order of preference: those within
    /// `tolerance` points of the best by increasing order, then the others
    /// by decreasing score. The first is the selection; a caller whose
    /// model of it on the whole records is unstable takes the next.
    pub fn ranking(&self, tolerance: f64) -> Vec<OrderCandidate> {
        parsimonious(&self.candidates, |c| c.fit, |c| c.order, tolerance)
    }
}

/// Scores `orders` on the folds of `experiments` (whose inputs may carry
/// extra columns, such as an instrument, that `fold` splits off) and
/// chooses among them. `fold(est, held)` fits the orders on a fold's
/// estimation pieces and returns each one's held-out fit on the held-out
/// parts, or the error that refused the fold's identification. Errors:
/// [`Error::InvalidOption`] for a fold count outside 2..=10, the first
/// fold's refusal when no fold could be identified (e.g.
/// [`Error::HorizonTooLong`] naming the fold's samples),
/// [`Error::Unstable`] when no order gave a stable model,
/// [`Error::Linalg`] (`TooLarge`) when the folds' copies exceed the
/// memory budget.
pub(crate) fn held_out_order(
    experiments: &[Experiment<'_>],
    orders: &[usize],
    structure: &StructureOptions,
    horizon: usize,
    mut fold: impl FnMut(&OwnedRecords, &[(&DMatrix<f64>, &DMatrix<f64>)]) -> Result<Vec<Option<f64>>>,
) -> Result<HeldOutOrder> {
    let total: usize = experiments.iter().map(|e| e.u.nrows()).sum();
    let (k_folds, forward) = structure.scheme(total)?;
    let layout = Folds::new(experiments, k_folds, forward);
    let folds = layout.split()?;
    // fits[order index][fold]
    let mut fits: Vec<Vec<Option<f64>>> = vec![Vec::with_capacity(folds.len()); orders.len()];
    let mut any_fold = false;
    let mut refusal = None;
    for (est, held) in &folds {
        let held: Vec<(&DMatrix<f64>, &DMatrix<f64>)> = held.iter().map(|(u, y)| (u, y)).collect();
        let scored = match fold(est, &held) {
            Ok(scored) => {
                any_fold = true;
                scored
            }
            Err(e) => {
                refusal.get_or_insert(e);
                vec![None; orders.len()]
            }
        };
        for (per_order, fit) in fits.iter_mut().zip(scored) {
            per_order.push(fit);
        }
    }
    if !any_fold {
        return Err(refusal.unwrap_or(Error::NoData));
    }
    let candidates: Vec<OrderCandidate> = orders
        .iter()
        .zip(&fits)
        .map(|(&order, f)| {
            let fold_fits: Vec<f64> = f
                .iter()
                .map(|&v| floored_at(v, structure.failed_fold))
                .collect();
            let mean = fold_fits.iter().sum::<f64>() / fold_fits.len().max(1) as f64;
            OrderCandidate {
                order,
                fit: f.iter().any(Option::is_some).then_some(mean),
                fold_fits,
            }
        })
        .collect();
    let mut sel = HeldOutOrder {
        horizon,
        future: horizon,
        notes: Vec::new(),
        order: 0,
        fit: f64::NAN,
        candidates,
        folds: layout.held_out.len(),
    };
    let chosen = sel
        .ranking(structure.tolerance)
        .into_iter()
        .next()
        .ok_or(Error::Unstable {
            spectral_radius: f64::NAN,
        })?;
    sel.order = chosen.order;
    sel.fit = chosen.fit.unwrap_or(f64::NAN);
    Ok(sel)
}

/// The refusal of a fold whose estimation pieces are all shorter than the
/// `needed` samples one Hankel column of horizons (`past`, `future`) spans
/// ([`Error::HorizonTooLong`] naming its longest piece).
pub(crate) fn short_fold(
    est: &OwnedRecords,
    (past, future): (usize, usize),
    needed: usize,
) -> Error {
    Error::HorizonTooLong {
        past,
        future,
        n_samples: est.iter().map(|(u, _)| u.nrows()).max().unwrap_or(0),
        min_samples: needed,
    }
}

//! Structure selection by held-out simulation fit: the horizon, the
//! (A, C) route and (optionally) the order of a subspace identification
//! chosen from the data, not from the singular values alone.
//!
//! The singular-value gap fails on real records (it picked order 1 on 9 of
//! 14 DaISy records where the literature orders give 10–96 points more
//! validation fit), and no single horizon or route is best on every record
//! (`benches/results/real-records.md`, "Real records beside SIPPY"). Each candidate
//! structure (horizon s = p = f, [`SystemEstimate`], order n) is therefore
//! scored on held-out data. Records of up to
//! [`StructureOptions::blocked_samples`] samples in all (default 20 000)
//! are cut into [`StructureOptions::blocked_folds`] contiguous blocks
//! (default 6) and each block is held out once, the structure identified
//! on the others (as separate records): blocked cross-validation, whose
//! mean over six held-out blocks varies much less than one held-out third
//! on records of a few thousand samples (Bergmeir & Benítez, "On the use of
//! cross-validation for time series predictor evaluation", Information
//! Sciences 191 (2012) 192–213). Longer records are cut into
//! [`StructureOptions::folds`] blocks (default 3) and by default
//! (forward validation) the structure is identified on all blocks but the
//! last and scored on the last one — on the data that follow its
//! estimation data, as the model will be used — or, with
//! [`StructureOptions::forward`] false, blocked as above. A fold's
//! score is the simulation fit on the held-out block, with
//! the block's initial state estimated by least squares (the way a
//! validation record is scored) and the error scaled by Akaike's FPE
//! factor for the n parameters x₀ fits to the block
//! (`crossval::held_out_fit`): fit = 100 (1 − c ‖y − ŷ‖/‖y − ȳ‖), averaged
//! over the outputs and records. The score is the mean over the folds, a
//! fold with no stable model counting as −100 %. The selection is the
//! smallest order, then the shortest horizon, within
//! [`StructureOptions::tolerance`] points of the best score (parsimony).
//!
//! On the 14 real records of `benches/results/real-records.md` the blocked scheme moved
//! the automatic order from 9 to 10 records within 2 points of the best
//! listed fixed order, and the default N4SID from 28 to 29 of 36 (record,
//! order) pairs within a point of SIPPY's best subspace method; its cost
//! is about 2.5 times the forward scheme's at 2e4 samples (0.5 → 1.3 s for
//! a 2×2 record, all candidates), which is why longer records keep one
//! held-out third.
//!
//! Cost per fold: one compression of the estimation blocks per (horizon,
//! route), O(N (n_u + n_y)² s), then per order O(k³) and the (B, D, x₀)
//! regression O(N q²), and a simulation of the held-out block, O(N n²).

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::crossval::{Folds, floored_at, held_out_fit, usable};
use crate::error::{Error, Result};
use crate::fit::models_of_orders;
use crate::model::Experiment;
use crate::options::{OrderSelection, SubspaceOptions, SystemEstimate};

/// Options of [`select_structure`]. `Default` gives the values documented
/// per field.
#[derive(Debug, Clone, PartialEq)]
pub struct StructureOptions {
    /// Candidate horizons s (p = f = s); an empty list means the default:
    /// 5, 10, 15, 20 and 30 for records of up to
    /// [`StructureOptions::search_samples`] samples, fewer beyond (down to
    /// 10 alone from five times that, [`default_horizons`]); always
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
    /// Contiguous blocks per record, 2..=10. Default 3.
    pub folds: usize,
    /// Forward validation: only the last block of every record is held
    /// out, so a structure is scored on the data that follow its
    /// estimation data, as the model will be used (default true); false:
    /// every block is held out once (blocked cross-validation).
    pub forward: bool,
    /// Records of up to this many samples in all are scored by blocked
    /// cross-validation over [`StructureOptions::blocked_folds`] blocks
    /// instead of `folds`/`forward`. Default 20 000.
    pub blocked_samples: usize,
    /// Blocks of the blocked cross-validation of short records, 2..=10.
    /// Default 6.
    pub blocked_folds: usize,
    /// Points of fit within which a smaller order or horizon is preferred.
    /// Default 0.5.
    pub tolerance: f64,
    /// Records of up to this many samples (all records) get the full
    /// search of horizons and routes; longer ones as many horizons as keep
    /// the search's work within the full search's at this length
    /// ([`default_horizons`]), shift invariance alone. Default 200 000.
    pub search_samples: usize,
    /// The score of a held-out fold whose model failed, and the floor of
    /// every fold's fit in the means (percent), so that one diverging fold
    /// does not swamp them. Default [`crate::crossval::FAILED_FOLD`] (−100:
    /// a fold twice as far off as predicting zero, the fit's scale; a
    /// policy, not fitted to any benchmark).
    pub failed_fold: f64,
}

impl StructureOptions {
    /// The blocks and the hold-out scheme for records of `total` samples:
    /// blocked cross-validation over [`StructureOptions::blocked_folds`]
    /// blocks up to [`StructureOptions::blocked_samples`] samples (every
    /// block held out once), else [`StructureOptions::folds`] blocks with
    /// [`StructureOptions::forward`]. [`Error::InvalidOption`] for a count
    /// outside 2..=10.
    pub(crate) fn scheme(&self, total: usize) -> Result<(usize, bool)> {
        if !(2..=10).contains(&self.folds) {
            return Err(Error::InvalidOption {
                what: "folds",
                reason: format!("2 to 10 cross-validation folds, got {}", self.folds),
            });
        }
        let (k_folds, forward) = if total <= self.blocked_samples {
            (self.blocked_folds, false)
        } else {
            (self.folds, self.forward)
        };
        if !(2..=10).contains(&k_folds) {
            return Err(Error::InvalidOption {
                what: "blocked_folds",
                reason: format!("2 to 10 cross-validation blocks, got {k_folds}"),
            });
        }
        Ok((k_folds, forward))
    }
}

impl Default for StructureOptions {
    fn default() -> Self {
        StructureOptions {
            horizons: Vec::new(),
            systems: Vec::new(),
            max_order: 10,
            folds: 3,
            forward: true,
            blocked_samples: 20_000,
            blocked_folds: 6,
            tolerance: 0.5,
            search_samples: 200_000,
            failed_fold: crate::crossval::FAILED_FOLD,
        }
    }
}

/// The default candidate horizons.
pub const DEFAULT_HORIZONS: [usize; 5] = [5, 10, 15, 20, 30];

/// The default candidate horizons for records of `total` samples: all of
/// [`DEFAULT_HORIZONS`] up to `search_samples` samples; beyond, as many as
/// keep the search's work within the full list's at `search_samples`
/// (each horizon's folds cost about the same, O(N) in the samples: the
/// count is ⌊5 · search_samples / total⌋, at least one), taken nearest
/// the default 10 on a logarithmic scale (10, 15, 5, 20, 30; the shorter
/// first on a tie). So the search's cost stays bounded past
/// `search_samples` and falls to one horizon gradually (one from
/// 5 · search_samples on) instead of at once (issue 50: the default's
/// cost without cliffs). O(1).
pub fn default_horizons(total: usize, search_samples: usize) -> Vec<usize> {
    if total <= search_samples {
        return DEFAULT_HORIZONS.to_vec();
    }
    let count = (DEFAULT_HORIZONS.len().saturating_mul(search_samples) / total.max(1)).max(1);
    let mut chosen: Vec<usize> = [10, 15, 5, 20, 30].into_iter().take(count).collect();
    chosen.sort_unstable();
    chosen
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
    /// Cross-validated simulation fit in percent (mean over the folds of
    /// the mean over outputs and records; a fold without a stable model
    /// counts as −100); `None` when no fold gave a stable model.
    pub fit: Option<f64>,
    /// The fit of each held-out fold (percent, floored at −100 like the
    /// mean; a fold without a stable model counts as −100), in fold order:
    /// the spread behind the mean.
    #[serde(default)]
    pub fold_fits: Vec<f64>,
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
    /// Folds scored (1 for forward validation, the block count for
    /// blocked cross-validation).
    pub folds: usize,
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
/// caller then keeps its defaults); [`Error::Linalg`] (`TooLarge`) when a
/// copy of the records per fold exceeds the memory budget.
pub fn select_structure(
    experiments: &[Experiment<'_>],
    base: &SubspaceOptions,
    opts: &StructureOptions,
) -> Result<StructureSelection> {
    let (nu, ny, total) = crate::checks::validate(experiments)?;
    let (k_folds, forward) = opts.scheme(total)?;
    // Hankel columns J per column of k = 2 s (n_u + n_y) that a horizon
    // needs in every fold's estimation pieces: 3 for forward validation (a
    // third of the record held out once), 1 (J ≥ k, the least that
    // identifies) for blocked cross-validation, whose estimation pieces are
    // 5/6 of a short record and whose score averages six held-out blocks.
    let column_factor = if forward { 3 } else { 1 };
    let fold_layout = Folds::new(experiments, k_folds, forward);
    // Hankel columns of the fold with the fewest at horizon s (pieces too
    // short for the horizon are left out of that fold's estimation).
    let columns_of = |s: usize| fold_layout.columns(s);
    let search = total <= opts.search_samples;
    let horizons: Vec<usize> = if !opts.horizons.is_empty() {
        opts.horizons.clone()
    } else {
        default_horizons(total, opts.search_samples)
    };
    // At least `column_factor` k Hankel columns in every fold's estimation
    // pieces (k = 2 s (n_u + n_y)): fewer make the compressed correlations
    // too noisy to rank structures.
    let columns_at = columns_of;
    // Estimation samples of the smallest fold (for the error message).
    let shortest = fold_layout.shortest();
    if !opts.horizons.is_empty() {
        // Horizons given by the caller are kept or refused, never replaced.
        let given: Vec<usize> = horizons
            .iter()
            .copied()
            .filter(|&s| s >= 2 && columns_at(s) >= 2 * s * (nu + ny))
            .collect();
        if given.is_empty() {
            let s = horizons.iter().copied().max().unwrap_or(0);
            return Err(Error::HorizonTooLong {
                past: s,
                future: s,
                n_samples: shortest,
                min_samples: (2 * s).saturating_mul(nu + ny + 1),
            });
        }
    }
    let feasible: Vec<usize> = horizons
        .iter()
        .copied()
        .filter(|&s| s >= 2 && columns_at(s) >= column_factor * 2 * s * (nu + ny))
        .collect();
    let horizons = if feasible.is_empty() && !opts.horizons.is_empty() {
        opts.horizons
            .iter()
            .copied()
            .filter(|&s| s >= 2 && columns_at(s) >= 2 * s * (nu + ny))
            .collect()
    } else if feasible.is_empty() {
        // The longest horizon the data allow at all (J ≥ k).
        match (2..=horizons.iter().copied().max().unwrap_or(10))
            .rev()
            .find(|&s| columns_at(s) >= 2 * s * (nu + ny))
        {
            Some(s) => vec![s],
            None => {
                return Err(Error::HorizonTooLong {
                    past: 2,
                    future: 2,
                    n_samples: total,
                    min_samples: k_folds * (4 * (nu + ny) + 3),
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
    let (cap, fixed) = match base.order {
        OrderSelection::Fixed(n) => (n, Some(n)),
        OrderSelection::Gap { max } => (max.min(opts.max_order).max(1), None),
    };
    // Orders above (s − 1) n_y are not identifiable at horizon s: not
    // tried (`cap` may be anything the caller gave, up to usize::MAX).
    let orders_at = |s: usize| -> Vec<usize> {
        match fixed {
            Some(n) => vec![n],
            None => (1..=cap.min(s.saturating_sub(1).saturating_mul(ny)).max(1)).collect(),
        }
    };
    // The estimation pieces and held-out blocks of every fold (copies:
    // O(K N (n_u + n_y)) memory for records of at most `search_samples`).
    let folds = fold_layout.split()?;
    let mut candidates = Vec::new();
    for &s in &horizons {
        let orders = orders_at(s);
        let o = SubspaceOptions {
            past: s,
            future: s,
            order: OrderSelection::Fixed(1),
            ..base.clone()
        };
        // fits[route index][order index][fold]: one compression and SVD
        // per fold serve every route.
        let mut fits: Vec<Vec<Vec<Option<f64>>>> =
            vec![vec![Vec::new(); orders.len()]; systems.len()];
        for (est, held) in &folds {
            // Pieces too short for the horizon are left out (they add no
            // Hankel column).
            let exps = usable(est, s);
            let (op, models) =
                models_of_orders(&exps, &o, &systems, cap, fixed).unwrap_or((None, Vec::new()));
            let held: Vec<(&DMatrix<f64>, &DMatrix<f64>)> =
                held.iter().map(|(u, y)| (u, y)).collect();
            for (r, route) in fits.iter_mut().enumerate() {
                for (i, &n) in orders.iter().enumerate() {
                    let fit = models
                        .get(r)
                        .and_then(|m| m.get(n - 1))
                        .and_then(Option::as_ref)
                        .and_then(|m| held_out_fit(m, op.as_ref(), &held));
                    route[i].push(fit);
                }
            }
        }
        for (&system, fits) in systems.iter().zip(&fits) {
            for (i, &n) in orders.iter().enumerate() {
                let any = fits[i].iter().any(Option::is_some);
                let mean = fits[i]
                    .iter()
                    .map(|&f| floored_at(f, opts.failed_fold))
                    .sum::<f64>()
                    / fold_layout.held_out.len() as f64;
                candidates.push(Candidate {
                    horizon: s,
                    system,
                    order: n,
                    fit: any.then_some(mean),
                    fold_fits: fits[i]
                        .iter()
                        .map(|&f| floored_at(f, opts.failed_fold))
                        .collect(),
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
    let mut sel = StructureSelection {
        horizon: 0,
        system: SystemEstimate::ShiftInvariance,
        order: 0,
        fit: best,
        candidates,
        folds: fold_layout.held_out.len(),
    };
    let chosen = sel
        .ranking(opts.tolerance)
        .into_iter()
        .next()
        .ok_or(Error::NoData)?;
    sel.horizon = chosen.horizon;
    sel.system = chosen.system;
    sel.order = chosen.order;
    sel.fit = chosen.fit.unwrap_or(best);
    Ok(sel)
}

impl StructureSelection {
    /// The scored candidates in the order of preference: those within
    /// `tolerance` points of the best score by parsimony (the smallest
    /// order, then the shortest horizon, then shift invariance), then the
    /// others by decreasing score. The first is the selection; a caller
    /// whose model of it on the whole records turns out unstable takes the
    /// next.
    pub fn ranking(&self, tolerance: f64) -> Vec<Candidate> {
        parsimonious(
            &self.candidates,
            |c| c.fit,
            |c| {
                (
                    c.order,
                    c.horizon,
                    c.system != SystemEstimate::ShiftInvariance,
                )
            },
            tolerance,
        )
    }
}

/// The scored `items` in the order of preference of a held-out selection:
/// those within `tolerance` points of the best score sorted by `key` (the
/// simplest first: parsimony), then the others by decreasing score; items
/// without a score are left out. O(m log m) for m items.
pub(crate) fn parsimonious<T: Clone, K: Ord>(
    items: &[T],
    score: impl Fn(&T) -> Option<f64>,
    key: impl Fn(&T) -> K,
    tolerance: f64,
) -> Vec<T> {
    let best = items
        .iter()
        .filter_map(&score)
        .fold(f64::NEG_INFINITY, f64::max);
    let (mut near, mut far): (Vec<T>, Vec<T>) = items
        .iter()
        .filter(|c| score(c).is_some())
        .cloned()
        .partition(|c| score(c).is_some_and(|f| f >= best - tolerance));
    near.sort_by_key(|c| key(c));
    far.sort_by(|a, b| {
        score(b)
            .unwrap_or(f64::NEG_INFINITY)
            .total_cmp(&score(a).unwrap_or(f64::NEG_INFINITY))
    });
    near.extend(far);
    near
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DVector;

    /// Past the full search's bound the horizons thin out nearest 10 and
    /// the search's work (horizons × samples) stays within the full
    /// search's at the bound.
    #[test]
    fn the_default_horizons_thin_out_past_the_bound() {
        let b = 200_000;
        assert_eq!(default_horizons(1000, b), DEFAULT_HORIZONS.to_vec());
        assert_eq!(default_horizons(b, b), DEFAULT_HORIZONS.to_vec());
        assert_eq!(default_horizons(b + 1, b), vec![5, 10, 15, 20]);
        assert_eq!(default_horizons(300_000, b), vec![5, 10, 15]);
        assert_eq!(default_horizons(500_000, b), vec![10, 15]);
        assert_eq!(default_horizons(1_000_000, b), vec![10]);
        assert_eq!(default_horizons(usize::MAX, b), vec![10]);
        for n in [b + 1, 250_000, 333_334, 499_999, 999_999] {
            assert!(default_horizons(n, b).len() * n <= 5 * b, "{n}");
        }
    }
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// A 2×1 record of `n` samples from a third-order plant (poles 0.9,
    /// 0.6 ± 0.3j), white input, output noise of standard deviation 0.05
    /// (outputs of RMS ≈ 1).
    fn record(n: usize, seed: u64) -> (DMatrix<f64>, DMatrix<f64>) {
        let a = DMatrix::from_row_slice(3, 3, &[0.9, 0.0, 0.0, 0.0, 0.6, 0.3, 0.0, -0.3, 0.6]);
        let b = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.5, 1.0, 0.0, -0.7]);
        let c = DMatrix::from_row_slice(1, 3, &[0.3, 0.8, 0.4]);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut g = || -> f64 { StandardNormal.sample(&mut rng) };
        let u = DMatrix::from_fn(n, 2, |_, _| g());
        let mut y = DMatrix::zeros(n, 1);
        let mut x = DVector::zeros(3);
        for t in 0..n {
            y[(t, 0)] = (&c * &x)[0] + 0.05 * g();
            x = &a * &x + &b * u.row(t).transpose();
        }
        (u, y)
    }

    fn base() -> SubspaceOptions {
        SubspaceOptions {
            order: OrderSelection::Gap { max: 6 },
            ..Default::default()
        }
    }

    #[test]
    fn short_records_are_scored_by_blocked_cross_validation() {
        let (u, y) = record(1200, 1);
        let exps = [Experiment { u: &u, y: &y }];
        let opts = StructureOptions {
            horizons: vec![5, 10],
            ..Default::default()
        };
        let sel = select_structure(&exps, &base(), &opts).unwrap();
        // Six blocks, each held out once.
        assert_eq!(sel.folds, 6);
        // The true order (a smaller one loses ≥ 10 points of fit on this
        // plant; parsimony keeps larger ones within 0.5 point out), and a
        // held-out fit near the noise floor (noise/RMS ≈ 5 % → fit ≈ 95).
        assert_eq!(sel.order, 3, "{sel:?}");
        assert!(sel.fit > 90.0, "{sel:?}");
        // Every (horizon, route, order) candidate is scored, the orders up
        // to 6 that the horizon identifies ((s − 1) n_y: 4 at s = 5).
        assert_eq!(sel.candidates.len(), 2 * (4 + 6));
        // Each score is the mean of its six held-out blocks' fits, which
        // are reported (the spread behind the mean).
        for c in &sel.candidates {
            assert_eq!(c.fold_fits.len(), 6, "{c:?}");
            if let Some(fit) = c.fit {
                let mean = c.fold_fits.iter().sum::<f64>() / 6.0;
                approx::assert_relative_eq!(fit, mean, epsilon = 1e-9);
            }
        }
        // The routes share one compression per fold: the scores are those
        // of separate selections restricted to one route.
        for system in [
            SystemEstimate::ShiftInvariance,
            SystemEstimate::StateSequence,
        ] {
            let one = select_structure(
                &exps,
                &base(),
                &StructureOptions {
                    systems: vec![system],
                    ..opts.clone()
                },
            )
            .unwrap();
            let shared: Vec<&Candidate> = sel
                .candidates
                .iter()
                .filter(|c| c.system == system)
                .collect();
            assert_eq!(one.candidates.iter().collect::<Vec<_>>(), shared);
        }
    }

    #[test]
    fn a_maximum_order_beyond_the_identifiable_tries_only_the_identifiable() {
        // The caller's maximum may be anything (the CLI's --max-order takes
        // up to 1e6; here usize::MAX): orders above (s − 1) n_y at horizon
        // s have no model and are not candidates (they were: a candidate
        // list of 310 011 orders per horizon and route took 24 s).
        let (u, y) = record(1200, 4);
        let exps = [Experiment { u: &u, y: &y }];
        let opts = StructureOptions {
            horizons: vec![5, 10],
            max_order: usize::MAX,
            ..Default::default()
        };
        let huge = SubspaceOptions {
            order: OrderSelection::Gap { max: usize::MAX },
            ..Default::default()
        };
        let sel = select_structure(&exps, &huge, &opts).unwrap();
        // (5 − 1)·1 + (10 − 1)·1 orders on each of the two routes.
        assert_eq!(sel.candidates.len(), 2 * (4 + 9), "{sel:?}");
        assert_eq!(sel.order, 3, "{sel:?}");
    }

    #[test]
    fn longer_records_keep_forward_validation() {
        let (u, y) = record(1200, 2);
        let exps = [Experiment { u: &u, y: &y }];
        let opts = StructureOptions {
            horizons: vec![5],
            blocked_samples: 1000,
            ..Default::default()
        };
        let sel = select_structure(&exps, &base(), &opts).unwrap();
        assert_eq!(sel.folds, 1);
        assert_eq!(sel.order, 3, "{sel:?}");
        let bad = StructureOptions {
            blocked_folds: 1,
            ..opts
        };
        let opts = StructureOptions {
            blocked_samples: 1200,
            ..bad
        };
        assert!(matches!(
            select_structure(&exps, &base(), &opts),
            Err(Error::InvalidOption {
                what: "blocked_folds",
                ..
            })
        ));
    }

    #[test]
    fn pieces_too_short_for_a_horizon_leave_it_out() {
        // 150 samples, 2 inputs + 1 output: horizon 30 needs
        // 2·30·3 = 180 Hankel columns, more than any fold has.
        let (u, y) = record(150, 3);
        let exps = [Experiment { u: &u, y: &y }];
        let opts = StructureOptions {
            horizons: vec![30],
            ..Default::default()
        };
        assert!(matches!(
            select_structure(&exps, &base(), &opts),
            Err(Error::HorizonTooLong { past: 30, .. })
        ));
        let opts = StructureOptions {
            horizons: Vec::new(),
            ..Default::default()
        };
        let sel = select_structure(&exps, &base(), &opts).unwrap();
        assert!(sel.horizon <= 10, "{sel:?}");
    }
}

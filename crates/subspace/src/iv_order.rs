//! The order of an IV subspace identification ([`crate::iv_identify`])
//! chosen by held-out simulation fit ([`crate::held_out_order`]'s folds,
//! score and parsimony rule, those of [`crate::select_structure`]).
//!
//! The IV method's own rules are the singular-value gap of R₂₂ and the
//! information criteria on the estimation records. On the records of
//! `benches/results/real-records.md` (open loop, the inputs as instruments) the gap was
//! within 2 points of validation fit of the best fixed order on few of
//! them; the held-out fit judges each order by what its model predicts on
//! data it was not fitted to, as for the other subspace routes.
//!
//! Each fold's estimation pieces (with their instrument rows) give one IV
//! subspace, from which every order's model follows (shift invariance for
//! (A, C), the output-error regression for (B, D, x₀), or the one-step
//! predictor regression when A is too unstable for it); each is simulated
//! on the held-out block from its inputs. In closed loop the simulation
//! from the measured input is still a fair test of the plant (y = G u +
//! H e: the error is H e when G is right); an unstable plant cannot be
//! scored that way, and a record on which no order is stable on any fold
//! gets [`crate::Error::Unstable`] (the caller falls back to the gap).
//!
//! Cost per fold: the IV subspace, O(J α(n_u+n_y) α_p n_z + (α_p n_z)³),
//! then per order the (B, D, x₀) regression O(N n_y(n_u n³ + q²)) and a
//! simulation of the held-out block O(N n²).

use nalgebra::DMatrix;

use crate::crossval::held_out_fit;
use crate::error::Result;
use crate::held_out_order::{HeldOutOrder, held_out_order, short_fold};
use crate::iv::{IvExperiment, IvOptions, IvPrepared};
use crate::model::Experiment;
use crate::options::OrderSelection;
use crate::order::OrderCriterion;
use crate::select::StructureOptions;

/// Chooses the order of [`crate::iv_identify`] by held-out simulation fit
/// (module docs). `opts` gives the horizons, instruments' use, feedthrough
/// and initial state; its order is the search's bound (`Gap { max }`, also
/// capped by `structure.max_order` and by what the IV subspace of the
/// whole records identifies) or, when fixed, the only candidate; its order
/// criterion is not used. The caller then identifies on the whole records
/// with `order = Fixed(order)`. Records with and without an instrument
/// are not mixed here: when any record has one, the others use their
/// inputs as theirs.
///
/// Errors: those of [`crate::iv_identify`] on the whole records;
/// [`crate::Error::InvalidOption`] for a fold count outside 2..=10;
/// [`crate::Error::HorizonTooLong`] when no fold's estimation part supports
/// the horizons; [`crate::Error::Unstable`] when no order gives a stable
/// model on any fold; [`crate::Error::Linalg`] (`TooLarge`) when a copy of
/// the records per fold exceeds the memory budget.
pub fn select_iv_order(
    experiments: &[IvExperiment<'_>],
    opts: &IvOptions,
    structure: &StructureOptions,
) -> Result<HeldOutOrder> {
    let gap = IvOptions {
        order_criterion: OrderCriterion::Gap,
        ..opts.clone()
    };
    let (orders, cap): (Vec<usize>, usize) = match opts.order {
        OrderSelection::Fixed(n) => (vec![n], n),
        OrderSelection::Gap { max } => {
            let whole = IvPrepared::new(
                experiments,
                &IvOptions {
                    order: OrderSelection::Gap { max: 1 },
                    ..gap.clone()
                },
            )?;
            let cap = max.min(structure.max_order).min(whole.supported()).max(1);
            ((1..=cap).collect(), cap)
        }
    };
    let fold_opts = IvOptions {
        order: OrderSelection::Gap { max: cap },
        ..gap
    };
    let alpha = opts.alpha;
    let alpha_p = opts.alpha_p.unwrap_or(alpha.saturating_mul(2));
    let nu = experiments.first().map_or(0, |e| e.u.ncols());
    let closed_loop = experiments.iter().any(|e| e.instrument.is_some());
    // The instrument rides along as extra input columns through the fold
    // split: [u | f] (f = u for a record without one).
    let joined: Vec<(DMatrix<f64>, &DMatrix<f64>)> = experiments
        .iter()
        .map(|e| {
            let f = e.instrument.unwrap_or(e.u);
            let mut uf = DMatrix::zeros(e.u.nrows(), 2 * nu);
            uf.columns_mut(0, nu).copy_from(e.u);
            if f.shape() == e.u.shape() {
                uf.columns_mut(nu, nu).copy_from(f);
            }
            (uf, e.y)
        })
        .collect();
    let joined: Vec<Experiment<'_>> = joined.iter().map(|(u, y)| Experiment { u, y }).collect();
    let span = alpha + alpha_p;
    held_out_order(&joined, &orders, structure, alpha, |est, held| {
        let parts: Vec<(DMatrix<f64>, DMatrix<f64>, &DMatrix<f64>)> = est
            .iter()
            .filter(|(u, _)| u.nrows() > span)
            .map(|(uf, y)| {
                (
                    uf.columns(0, nu).into_owned(),
                    uf.columns(nu, nu).into_owned(),
                    y,
                )
            })
            .collect();
        if parts.is_empty() {
            return Err(short_fold(est, (alpha_p, alpha), span + 1));
        }
        let exps: Vec<IvExperiment<'_>> = parts
            .iter()
            .map(|(u, f, y)| IvExperiment {
                u,
                y,
                instrument: closed_loop.then_some(f),
            })
            .collect();
        let prep = IvPrepared::new(&exps, &fold_opts)?;
        let held_u: Vec<DMatrix<f64>> = held
            .iter()
            .map(|(uf, _)| uf.columns(0, nu).into_owned())
            .collect();
        let held: Vec<(&DMatrix<f64>, &DMatrix<f64>)> =
            held_u.iter().zip(held).map(|(u, (_, y))| (u, *y)).collect();
        Ok(orders
            .iter()
            .map(|&n| {
                let model = prep.state_space(n, &fold_opts).ok()?;
                held_out_fit(&model, None, &held)
            })
            .collect())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Error;
    use nalgebra::DVector;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// `n` samples of a 1×1 thermal-like plant of five first-order modes
    /// (poles 0.95 … 0.2, unit DC gains shrinking with speed) under a
    /// binary input held for three samples, output noise of standard
    /// deviation 0.02.
    fn record(n: usize, seed: u64) -> (DMatrix<f64>, DMatrix<f64>) {
        let poles = [0.95, 0.85, 0.7, 0.5, 0.2];
        let gains = [1.0, 0.8, 0.6, 0.5, 0.4];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut g = || -> f64 { StandardNormal.sample(&mut rng) };
        let mut u = DMatrix::zeros(n, 1);
        for k in 0..n {
            u[(k, 0)] = if k % 3 == 0 {
                g().signum()
            } else {
                u[(k - 1, 0)]
            };
        }
        let mut x = DVector::<f64>::zeros(5);
        let mut y = DMatrix::zeros(n, 1);
        for k in 0..n {
            y[(k, 0)] = x.sum() + 0.02 * g();
            for i in 0..5 {
                x[i] = poles[i] * x[i] + gains[i] * (1.0 - poles[i]) * u[(k, 0)];
            }
        }
        (u, y)
    }

    #[test]
    fn every_order_is_scored_on_six_blocks() {
        let (u, y) = record(2000, 3);
        let exps = [IvExperiment {
            u: &u,
            y: &y,
            instrument: None,
        }];
        let sel =
            select_iv_order(&exps, &IvOptions::default(), &StructureOptions::default()).unwrap();
        assert_eq!(sel.folds, 6);
        assert_eq!(sel.horizon, 8);
        // (α − 1) n_y = 7 orders.
        assert_eq!(sel.candidates.len(), 7, "{sel:?}");
        for c in &sel.candidates {
            assert_eq!(c.fold_fits.len(), 6);
        }
        // Order 1 misses the faster modes: clearly below the chosen one,
        // whose fit is near the noise floor (noise 0.02 against an output
        // RMS ≈ 0.6: ≈ 97 %).
        let at = |n: usize| sel.candidates[n - 1].fit.unwrap_or(-100.0);
        assert!(at(1) < sel.fit - 3.0, "{sel:?}");
        assert!(sel.fit > 90.0, "{sel:?}");
        assert!(sel.order >= 2, "{sel:?}");
    }

    #[test]
    fn a_closed_loop_keeps_its_instrument_in_every_fold() {
        // u = r − 0.3 y: with the reference as instrument every fold is
        // identified; a fixed order is the only candidate.
        let (r, y0) = record(2000, 4);
        let u = &r - &y0 * 0.3;
        let exps = [IvExperiment {
            u: &u,
            y: &y0,
            instrument: Some(&r),
        }];
        let opts = IvOptions {
            order: OrderSelection::Fixed(3),
            ..Default::default()
        };
        let sel = select_iv_order(&exps, &opts, &StructureOptions::default()).unwrap();
        assert_eq!(sel.order, 3);
        assert_eq!(sel.candidates.len(), 1);
        let bad = StructureOptions {
            blocked_folds: 1,
            ..Default::default()
        };
        assert!(matches!(
            select_iv_order(&exps, &opts, &bad),
            Err(Error::InvalidOption {
                what: "blocked_folds",
                ..
            })
        ));
    }
}

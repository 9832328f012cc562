//! Model-order selection: the singular-value gap rule, Bauer's singular
//! value criterion (SVC) on the canonical correlations, and the
//! information criteria AIC, AICc and BIC of SIPPY on the simulation error
//! of the model of each order.
//!
//! References (definitions, not code):
//! * D. Bauer, "Order estimation for subspace methods", Automatica 37
//!   (2001) 1561–1573: SVC(n) = σ̂²_{n+1} + d(n)·C(T)/T with σ̂ the
//!   canonical correlations between future outputs and the past (the CVA
//!   singular values), T the sample size, d(n) the number of free
//!   parameters of an order-n system and the penalty C(T) = ln T. The
//!   RLDM package documents the same criterion with d(n) = 2n n_y for a
//!   system without inputs; with n_u inputs (A, B, C, K) modulo a change
//!   of basis have d(n) = n(2n_y + n_u) free parameters.
//! * SIPPY (Armenise, Bacci di Capaci, Vaccari, Pannocchia; University of
//!   Pisa), `functionset.information_criterion` and
//!   `OLSims_methods.select_order_SIM`: with V_n the mean squared
//!   simulation error Σ‖y − ŷ‖²/(N n_y) of the order-n model
//!   (`functionsetSIM.Vn_mat`), K = n n_y + n n_u (+ n_y n_u when D is
//!   estimated) parameters and N samples:
//!   AIC = N ln V_n + 2K, AICc = AIC + 2K(K+1)/(N − K − 1) (∞ when
//!   N − K − 1 ≤ 0), BIC = N ln V_n + K ln N; the minimiser is chosen.
//!   Here K also counts the n initial-state entries per record when x₀ is
//!   estimated (SIPPY simulates from x₀ = 0).

use lifted_lti::StateSpace;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::estimated::Record;
use crate::estimated::{Feedthrough, InitialState};

/// The rule of the automatic order choice
/// ([`crate::OrderSelection::Gap`]`{ max }` chooses 1 ≤ n ≤ max by this
/// rule). The values of the rule for every order are reported in
/// [`OrderReport`] (also when the order is fixed).
///
/// # Example
///
/// ```
/// use lifted_lti::StateSpace;
/// use lifted_subspace::{Experiment, OrderCriterion, OrderSelection, SubspaceOptions, identify};
/// use nalgebra::DMatrix;
///
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// // Second order: poles 0.9 and 0.5, a little output noise.
/// let g = StateSpace::new(
///     DMatrix::from_row_slice(2, 2, &[0.9, 0.0, 0.0, 0.5]),
///     DMatrix::from_row_slice(2, 1, &[1.0, 1.0]),
///     DMatrix::from_row_slice(1, 2, &[1.0, -1.0]),
///     DMatrix::zeros(1, 1),
///     Some(1.0),
/// )?;
/// // Pseudo-random numbers in [0, 1) from a 64-bit LCG.
/// let mut state = 1u64;
/// let mut rand = move || {
///     state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
///     (state >> 11) as f64 / (1u64 << 53) as f64
/// };
/// let u = DMatrix::from_fn(2000, 1, |_, _| if rand() < 0.5 { -1.0 } else { 1.0 });
/// let mut y = g.lsim(&u, None, None)?.y;
/// for v in y.iter_mut() {
///     *v += 0.1 * (rand() - 0.5); // white measurement noise
/// }
/// let opts = SubspaceOptions {
///     order: OrderSelection::Gap { max: 6 },
///     order_criterion: OrderCriterion::Bic,
///     ..Default::default()
/// };
/// let fit = identify(&[Experiment { u: &u, y: &y }], &opts)?;
/// let report = &fit.diagnostics.order_selection;
/// assert_eq!(report.values.len(), 6); // BIC of orders 1..=6
/// assert_eq!(fit.diagnostics.order, report.selected);
/// assert_eq!(fit.diagnostics.order, 2);
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[non_exhaustive]
pub enum OrderCriterion {
    /// The largest gap ln(σ_n/σ_{n+1}) of the singular values of the
    /// weighted projection (largest value chosen). Default.
    #[default]
    Gap,
    /// Bauer's singular value criterion (2001):
    /// SVC(n) = σ̂²_{n+1} + n(2n_y + n_u)·ln J/J on the canonical
    /// correlations σ̂ (the CVA singular values, computed whatever the
    /// method; J Hankel columns). Needs only the compressed data
    /// (streaming works); not defined for the IV method.
    Svc,
    /// Akaike's criterion N ln V_n + 2K on the simulation error of the
    /// order-n model (SIPPY's definition; module docs). Needs the records.
    Aic,
    /// Small-sample corrected AIC: AIC + 2K(K+1)/(N − K − 1).
    Aicc,
    /// Bayesian (Schwarz) criterion N ln V_n + K ln N.
    Bic,
}

impl OrderCriterion {
    /// Short name ("gap", "SVC", "AIC", "AICc", "BIC").
    pub fn name(self) -> &'static str {
        match self {
            OrderCriterion::Gap => "gap",
            OrderCriterion::Svc => "SVC",
            OrderCriterion::Aic => "AIC",
            OrderCriterion::Aicc => "AICc",
            OrderCriterion::Bic => "BIC",
        }
    }

    /// True for the criteria on the simulation error (AIC, AICc, BIC),
    /// which fit and simulate a model of every candidate order.
    pub fn needs_models(self) -> bool {
        matches!(
            self,
            OrderCriterion::Aic | OrderCriterion::Aicc | OrderCriterion::Bic
        )
    }

    /// True when the largest value wins (the gap rule); the others are
    /// minimised.
    fn maximise(self) -> bool {
        self == OrderCriterion::Gap
    }
}

/// The order choice of an identification (part of the diagnostics).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrderReport {
    /// The rule whose values are listed.
    pub criterion: OrderCriterion,
    /// Value of the rule for orders 1, 2, …: `values[i]` belongs to order
    /// i + 1 (+∞ for an AIC/AICc/BIC order whose model could not be fitted
    /// or simulated, e.g. an unstable one).
    pub values: Vec<f64>,
    /// The order the rule selects (argmax of the gap, argmin of the
    /// others); the order used may differ when it was fixed.
    pub selected: usize,
}

impl OrderReport {
    /// The report of `criterion` with `values` for orders 1, 2, …; the first
    /// best value wins (ties: the lowest order). O(len).
    pub(crate) fn new(criterion: OrderCriterion, values: Vec<f64>) -> Self {
        let mut best = (
            1,
            if criterion.maximise() {
                f64::NEG_INFINITY
            } else {
                f64::INFINITY
            },
        );
        for (i, &v) in values.iter().enumerate() {
            let better = if criterion.maximise() {
                v > best.1
            } else {
                v < best.1
            };
            if better {
                best = (i + 1, v);
            }
        }
        OrderReport {
            criterion,
            values,
            selected: best.0,
        }
    }
}

/// Floor of the singular values: values below ε·len·σ₁ are numerically
/// zero, so rounding noise beyond the true order creates no gap.
fn sv_floor(singular_values: &[f64]) -> f64 {
    let s0 = singular_values.first().cloned().unwrap_or(0.0);
    (s0 * f64::EPSILON * singular_values.len() as f64).max(f64::MIN_POSITIVE)
}

/// The gaps ln(σ_n/σ_{n+1}) for n = 1 … min(max, len − 1) (at least one
/// order), singular values floored at ε·len·σ₁. O(max).
pub(crate) fn gap_values(singular_values: &[f64], max: usize) -> Vec<f64> {
    let max = max.min(singular_values.len().saturating_sub(1)).max(1);
    let floor = sv_floor(singular_values);
    (1..=max)
        .map(|n| {
            if n >= singular_values.len() {
                return f64::NEG_INFINITY;
            }
            let hi = singular_values[n - 1].max(floor);
            let lo = singular_values[n].max(floor);
            (hi / lo).ln()
        })
        .collect()
}

/// Gap rule: argmax_{1≤n≤max} ln(σ_n/σ_{n+1}) (max capped at len − 1,
/// singular values below ε·len·σ₁ floored there). O(max).
pub fn gap_order(singular_values: &[f64], max: usize) -> usize {
    OrderReport::new(OrderCriterion::Gap, gap_values(singular_values, max)).selected
}

/// Bauer's SVC(n) = σ̂²_{n+1} + n(2n_y + n_u) ln J/J for n = 1 … max on
/// the canonical correlations `cc` (descending; σ̂_{n+1} = 0 past the
/// end). O(max).
pub(crate) fn svc_values(cc: &[f64], max: usize, ny: usize, nu: usize, columns: usize) -> Vec<f64> {
    let j = columns.max(2) as f64;
    let penalty = j.ln() / j;
    (1..=max)
        .map(|n| {
            let next = cc.get(n).cloned().unwrap_or(0.0);
            next * next + (n * (2 * ny + nu)) as f64 * penalty
        })
        .collect()
}

/// Parameters K of SIPPY's information criteria for an order-n model:
/// n n_y + n n_u + the free D entries + n per record when x₀ is estimated.
fn parameter_count(n: usize, ny: usize, nu: usize, free_d: usize, x0_records: usize) -> usize {
    n * (ny + nu) + free_d + n * x0_records
}

/// SIPPY's information criterion for `criterion` (AIC, AICc or BIC) with
/// mean squared simulation error `v`, `k` parameters and `n_samples`
/// samples; +∞ for a non-finite or zero error or, for AICc,
/// N − K − 1 ≤ 0. O(1).
pub(crate) fn information_criterion(
    criterion: OrderCriterion,
    v: f64,
    k: usize,
    n_samples: usize,
) -> f64 {
    if !(v.is_finite() && v > 0.0) {
        return f64::INFINITY;
    }
    let (n, k) = (n_samples as f64, k as f64);
    let fit = n * v.ln();
    match criterion {
        OrderCriterion::Aic => fit + 2.0 * k,
        OrderCriterion::Aicc => {
            if n - k - 1.0 > 0.0 {
                fit + 2.0 * k + 2.0 * k * (k + 1.0) / (n - k - 1.0)
            } else {
                f64::INFINITY
            }
        }
        OrderCriterion::Bic => fit + k * n.ln(),
        OrderCriterion::Gap | OrderCriterion::Svc => f64::NAN,
    }
}

/// SIPPY's AIC/AICc/BIC (`criterion`) for orders 1..=`cap` on the records:
/// `fit(n)` fits the model of order n (a failed fit, e.g. an A too
/// unstable for the regression, scores +∞), `sim_error` gives its mean
/// squared simulation error V_n; K counts n(n_y + n_u), the free entries
/// of D and n per record when x₀ is estimated. Returns the values and the
/// fitted models. O(cap) fits and simulations.
///
/// Errors: [`Error::OrderTooLarge`] when K(cap) + 1 ≥ N (the largest
/// supported order in `max`), [`Error::DimensionMismatch`] for a bad
/// feedthrough mask, and those of the simulation.
#[allow(clippy::too_many_arguments)]
pub(crate) fn information_criterion_values<T>(
    criterion: OrderCriterion,
    cap: usize,
    records: &[Record<'_>],
    (ny, nu): (usize, usize),
    feedthrough: &Feedthrough,
    initial_state: InitialState,
    mut fit: impl FnMut(usize) -> Result<T>,
    sim_error: impl Fn(&T) -> Result<f64>,
) -> Result<(Vec<f64>, Vec<Option<T>>)> {
    let n_samples: usize = records.iter().map(|r| r.u.nrows()).sum();
    let free_d = feedthrough.mask(ny, nu)?.iter().filter(|&&f| f).count();
    let x0_records = match initial_state {
        InitialState::Estimate => records.len(),
        InitialState::Zero => 0,
    };
    let k = |n| parameter_count(n, ny, nu, free_d, x0_records);
    if k(cap) + 1 >= n_samples {
        let supported = (1..=cap).take_while(|&n| k(n) + 1 < n_samples).count();
        return Err(Error::OrderTooLarge {
            order: cap,
            max: supported,
        });
    }
    let mut values = Vec::with_capacity(cap);
    let mut fits = Vec::with_capacity(cap);
    for n in 1..=cap {
        let model = fit(n).ok();
        let v = match &model {
            Some(m) => sim_error(m)?,
            None => f64::INFINITY,
        };
        values.push(information_criterion(criterion, v, k(n), n_samples));
        fits.push(model);
    }
    Ok((values, fits))
}

/// Mean squared simulation error Σ‖y − ŷ‖²/(number of finite outputs) of
/// the model (A, B, C, D) on the records from the initial states `x0`
/// (zeros when absent); NaN outputs are skipped; +∞ when the simulation
/// overflows. O(N n (n + n_u + n_y)) per record.
pub(crate) fn simulation_error(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    c: &DMatrix<f64>,
    d: &DMatrix<f64>,
    records: &[Record<'_>],
    x0: &[DVector<f64>],
) -> Result<f64> {
    let model = StateSpace::new(a.clone(), b.clone(), c.clone(), d.clone(), Some(1.0))?;
    let (mut sum, mut count) = (0.0, 0usize);
    for (i, rec) in records.iter().enumerate() {
        let yh = model.lsim(rec.u, x0.get(i), None)?.y;
        for (yv, yhv) in rec.y.iter().zip(yh.iter()) {
            if yv.is_nan() {
                continue;
            }
            let e = yv - yhv;
            sum += e * e;
            count += 1;
        }
    }
    if count == 0 || !sum.is_finite() {
        return Ok(f64::INFINITY);
    }
    Ok(sum / count as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_picks_argmax_for_the_gap_and_argmin_otherwise() {
        let s = [10.0, 5.0, 0.01, 0.005];
        assert_eq!(gap_order(&s, 3), 2);
        let r = OrderReport::new(OrderCriterion::Aic, vec![3.0, 1.0, 1.0, 2.0]);
        assert_eq!(r.selected, 2);
        let r = OrderReport::new(OrderCriterion::Bic, vec![f64::INFINITY, 4.0]);
        assert_eq!(r.selected, 2);
    }

    #[test]
    fn svc_and_information_criteria_follow_their_definitions() {
        // SVC(1) = σ₂² + 1·(2·1 + 1) ln 100/100.
        let v = svc_values(&[0.9, 0.5, 0.1], 2, 1, 1, 100);
        assert!((v[0] - (0.25 + 3.0 * 100f64.ln() / 100.0)).abs() < 1e-15);
        assert!((v[1] - (0.01 + 6.0 * 100f64.ln() / 100.0)).abs() < 1e-15);
        let k = parameter_count(2, 1, 1, 1, 0);
        assert_eq!(k, 5);
        let aic = information_criterion(OrderCriterion::Aic, 0.5, k, 1000);
        assert!((aic - (1000.0 * 0.5f64.ln() + 10.0)).abs() < 1e-12);
        let aicc = information_criterion(OrderCriterion::Aicc, 0.5, k, 1000);
        assert!((aicc - aic - 60.0 / 994.0).abs() < 1e-12);
        let bic = information_criterion(OrderCriterion::Bic, 0.5, k, 1000);
        assert!((bic - (1000.0 * 0.5f64.ln() + 5.0 * 1000f64.ln())).abs() < 1e-12);
        assert_eq!(
            information_criterion(OrderCriterion::Aicc, 0.5, 10, 11),
            f64::INFINITY
        );
        assert_eq!(
            information_criterion(OrderCriterion::Aic, f64::INFINITY, 1, 10),
            f64::INFINITY
        );
    }
}

//! ARX and FIR models by least squares on the compressed lagged data.
//!
//! The multi-output ARX model (MATLAB's `arx`, Ljung 1999 §4.2 eq. (4.7)
//! and §7.3 for the least-squares estimate):
//!
//! ```text
//!   y_i(t) + Σ_j Σ_{l=1..na_ij} a_ij,l y_j(t − l)
//!        = Σ_k Σ_{m=0..nb_ik−1} b_ik,m u_k(t − nk_ik − m) + e_i(t),
//! ```
//!
//! is linear in its parameters, so each output's row θ_i is the least-squares
//! solution y_i(t) = φ_i(t)ᵀθ_i + e_i(t) (FIR: every na = 0). Every lagged
//! signal the structure needs is a column of one compressed factor of the
//! block-Hankel data (module `lagged`): one pass over the records
//! (≈ 2 N n_z² (L + 1) flops for the longest lag L, memory O(k²),
//! k = (L + 1)(n_u + n_y)), then a QR of the factor's selected columns per
//! output (O(k d²)); the normal equations are never formed.
//!
//! **Uncertainty.** With the residuals ε_i of each output's regression, the
//! noise covariance is Λ_ij = ε_iᵀε_j / (J − max(d_i, d_j)) (J regression
//! rows, d_i parameters of output i: the unbiased estimate for one output)
//! and the covariance of the parameters is the least-squares one,
//! Cov(θ_i, θ_j) = Λ_ij (Φ_iᵀΦ_i)⁻¹ Φ_iᵀΦ_j (Φ_jᵀΦ_j)⁻¹ (Ljung 1999,
//! eq. (9.18) for one output), computed from the thin QR factors of the
//! selected columns as Λ_ij T_i⁻¹ U_iᵀU_j T_j⁻ᵀ / J. It is exact for
//! white noise e and regressors independent of it (open loop or closed
//! loop alike for ARX, whose predictor is linear in past data); coloured
//! noise biases ARX and its bounds (use OE/BJ/ARMAX then).
//!
//! The records are used as given: remove the operating point first (the
//! `lifted` workflow does). The structure scan over a grid of (na, nb, nk)
//! reuses one compression for every candidate ([`arx_scan`]), and so does
//! the delay estimate ([`estimate_delays`]).

mod compressed;
pub(crate) mod lagged;
mod regul;
mod scan;

use lifted_lti::{PolyModel, PolyOrders};
use lifted_subspace::{Compression, CompressionReport, Experiment};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use lagged::{Column, Lagged, Solve};

pub use compressed::{ArxCompressedFit, arx_compressed, arx_horizons};
pub use regul::{ArxHyperparameters, ArxRegulFit, ArxRegulOptions, arx_regul};
pub use scan::{
    AStructure, ArxScan, ArxScanOptions, ArxScanRow, ArxStructure, DelayOptions,
    StructureCriterion, arx_scan, estimate_delays,
};

/// Options of [`arx`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ArxOptions {
    /// How the lagged data are compressed (default [`Compression::Auto`]:
    /// the correlations, the QR when they are ill conditioned).
    pub compression: Compression,
    /// Threads of the correlation kernel (0 = all cores, the default).
    pub threads: usize,
}

impl Default for ArxOptions {
    fn default() -> Self {
        ArxOptions {
            compression: Compression::Auto,
            threads: 0,
        }
    }
}

/// An estimated ARX (or FIR) model and what the regression measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ArxFit {
    /// The model, with the noise covariance Λ and the covariance of its
    /// parameters ([`PolyModel::covariance`], [`PolyModel::std`]).
    pub model: PolyModel,
    /// Mean squared one-step prediction error per output over the
    /// regression rows (the loss V of MATLAB's `arx`).
    pub loss: Vec<f64>,
    /// One-step prediction fit per output, percent:
    /// 100 (1 − √(V_i / mean square of y_i)) over the same rows.
    pub fit: Vec<f64>,
    /// Regression rows J (samples with every lag available, all records).
    pub rows: usize,
    /// How the lagged data were compressed.
    pub compression: CompressionReport,
}

/// The regressor columns of output `i` of an ARX structure, in the
/// parameter order of [`PolyModel::parameters`] (A_i1 … A_iny, then
/// B_i1 … B_inu), and whether each is an A coefficient (its sign flips:
/// the regression coefficient of y_j(t − l) is −a_ij,l).
fn regressors(data: &Lagged, orders: &PolyOrders, i: usize) -> (Vec<Column>, Vec<bool>) {
    let mut cols = Vec::new();
    let mut is_a = Vec::new();
    for j in 0..data.ny() {
        for l in 1..=orders.na[i][j] {
            cols.push(data.output(j, l));
            is_a.push(true);
        }
    }
    for k in 0..data.nu() {
        for m in 0..orders.nb[i][k] {
            cols.push(Lagged::input(k, orders.nk[i][k] + m));
            is_a.push(false);
        }
    }
    (cols, is_a)
}

/// The longest lag of an ARX structure: max(na, nk + nb − 1).
fn longest_lag(orders: &PolyOrders) -> usize {
    let a = orders.na.iter().flatten().copied().max().unwrap_or(0);
    let b = orders
        .nb
        .iter()
        .zip(&orders.nk)
        .flat_map(|(nb, nk)| {
            nb.iter()
                .zip(nk)
                .filter(|(b, _)| **b > 0)
                .map(|(b, k)| k + b - 1)
        })
        .max()
        .unwrap_or(0);
    a.max(b)
}

/// Checks that `orders` is an ARX/FIR structure for n_u inputs and n_y
/// outputs with at least one parameter per output.
fn check_orders(orders: &PolyOrders, nu: usize, ny: usize) -> Result<()> {
    let grid = |m: &Vec<Vec<usize>>, rows: usize, cols: usize| {
        m.len() == rows && m.iter().all(|r| r.len() == cols)
    };
    if !(grid(&orders.na, ny, ny)
        && grid(&orders.nb, ny, nu)
        && grid(&orders.nk, ny, nu)
        && grid(&orders.nf, ny, nu)
        && orders.nc.len() == ny
        && orders.nd.len() == ny)
    {
        return Err(Error::DimensionMismatch {
            what: "ARX orders (na n_y×n_y, nb and nk n_y×n_u)",
            expected: format!("{ny} outputs and {nu} inputs"),
            got: format!(
                "na {}×{}, nb {}×{}",
                orders.na.len(),
                orders.na.first().map_or(0, Vec::len),
                orders.nb.len(),
                orders.nb.first().map_or(0, Vec::len)
            ),
        });
    }
    if orders.nc.iter().chain(&orders.nd).any(|&n| n > 0)
        || orders.nf.iter().flatten().any(|&n| n > 0)
    {
        return Err(Error::InvalidOption {
            what: "orders",
            reason: "an ARX or FIR structure has no C, D or F polynomial (nc = nd = nf = 0); use the prediction-error estimators for ARMAX, OE and BJ".into(),
        });
    }
    for i in 0..ny {
        let d: usize = orders.na[i].iter().sum::<usize>() + orders.nb[i].iter().sum::<usize>();
        if d == 0 {
            return Err(Error::InvalidOption {
                what: "orders",
                reason: format!("output {i} has no parameter (na = nb = 0)"),
            });
        }
    }
    Ok(())
}

/// The records' lagged data for the structure `orders` (checked against
/// their channels): one compression for its longest lag.
fn lagged_for(
    experiments: &[Experiment<'_>],
    orders: &PolyOrders,
    compression: Compression,
    threads: usize,
) -> Result<Lagged> {
    let (nu, ny) = channels(experiments)?;
    check_orders(orders, nu, ny)?;
    Lagged::new(experiments, longest_lag(orders), compression, threads)
}

/// (n_u, n_y) of the records, or [`Error::NoData`].
fn channels(experiments: &[Experiment<'_>]) -> Result<(usize, usize)> {
    let e = experiments.first().ok_or(Error::NoData)?;
    Ok((e.u.ncols(), e.y.ncols()))
}

/// Least-squares ARX (FIR when every na is 0) of structure `orders`
/// (n_y × n_y na, n_y × n_u nb and nk; nc = nd = nf = 0) on the records,
/// sample period `ts`, with the parameter covariance (module docs).
///
/// Cost: one compression of the records (≈ 2 N n_z² (L + 1) flops,
/// L = max(na, nk + nb − 1)), then O(n_y k d² + (n_y d)²·k) for the solves
/// and the covariance; memory O(k² + (n_y d)²), independent of N.
///
/// Errors: [`Error::NoData`]; [`Error::DimensionMismatch`] for orders that
/// do not match the records; [`Error::InvalidOption`] for a structure with
/// C, D or F, or an output without parameters;
/// [`Error::Subspace`] for records of inconsistent shapes or with NaN/inf
/// (an output measured at a slower rate cannot give ARX regressors: use
/// the output-error estimators); [`Error::TooFewSamples`] when the records
/// are shorter than the lags and parameters need;
/// [`Error::RankDeficient`] when the regressors do not determine the
/// parameters (a non-exciting input).
pub fn arx(
    experiments: &[Experiment<'_>],
    orders: &PolyOrders,
    ts: f64,
    opts: &ArxOptions,
) -> Result<ArxFit> {
    let data = lagged_for(experiments, orders, opts.compression, opts.threads)?;
    fit_structure(&data, orders, ts)
}

/// [`arx`] on data already compressed for lags at least those of `orders`.
fn fit_structure(data: &Lagged, orders: &PolyOrders, ts: f64) -> Result<ArxFit> {
    let (ny, rows) = (data.ny(), data.rows);
    let mut solves: Vec<Solve> = Vec::with_capacity(ny);
    let mut signs: Vec<f64> = Vec::new();
    for i in 0..ny {
        let (cols, is_a) = regressors(data, orders, i);
        if rows <= cols.len() {
            return Err(Error::TooFewSamples {
                what: "the ARX regression",
                measured: rows,
                needed: cols.len() + 1,
            });
        }
        solves.push(data.solve(&cols, data.output(i, 0))?);
        signs.extend(is_a.iter().map(|&a| if a { -1.0 } else { 1.0 }));
    }
    let dims: Vec<usize> = solves.iter().map(|s| s.theta.len()).collect();
    let j = rows as f64;
    let lambda = DMatrix::from_fn(ny, ny, |a, b| {
        let dof = j - dims[a].max(dims[b]) as f64;
        j * solves[a].residual.dot(&solves[b].residual) / dof
    });
    let offsets: Vec<usize> = dims
        .iter()
        .scan(0, |acc, &d| {
            let o = *acc;
            *acc += d;
            Some(o)
        })
        .collect();
    let total: usize = dims.iter().sum();
    let mut cov = DMatrix::zeros(total, total);
    // T_i⁻¹ (d_i × d_i), then the blocks Λ_ab T_a⁻¹ U_aᵀ U_b T_b⁻ᵀ / J.
    let inverses: Vec<DMatrix<f64>> = solves
        .iter()
        .map(|s| {
            s.t.clone()
                .solve_upper_triangular(&DMatrix::identity(s.t.nrows(), s.t.nrows()))
                .ok_or(Error::RankDeficient {
                    what: "the ARX regressors (lagged inputs and outputs)",
                    rank: 0,
                    needed: s.t.nrows(),
                })
        })
        .collect::<Result<_>>()?;
    for a in 0..ny {
        for b in a..ny {
            let cross = solves[a].u.transpose() * &solves[b].u;
            let block = &inverses[a] * cross * inverses[b].transpose() * (lambda[(a, b)] / j);
            cov.view_mut((offsets[a], offsets[b]), (dims[a], dims[b]))
                .copy_from(&block);
            if a != b {
                cov.view_mut((offsets[b], offsets[a]), (dims[b], dims[a]))
                    .copy_from(&block.transpose());
            }
        }
    }
    // Regression coefficients of y_j(t − l) are −a: flip those parameters
    // and the matching rows and columns of the covariance.
    let theta: Vec<f64> = solves
        .iter()
        .flat_map(|s| s.theta.iter().copied())
        .zip(&signs)
        .map(|(v, s)| v * s)
        .collect();
    let cov = DMatrix::from_fn(total, total, |r, c| cov[(r, c)] * signs[r] * signs[c]);
    let cov = (&cov + cov.transpose()) * 0.5;
    let model = PolyModel::from_orders(orders, ts)?
        .with_parameters(&theta)?
        .with_noise_variance(&lambda)?
        .with_covariance(&cov)?;
    let loss: Vec<f64> = solves.iter().map(|s| s.loss).collect();
    let fit = loss
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let ms = data.mean_square(i);
            if ms > 0.0 {
                100.0 * (1.0 - (v / ms).sqrt())
            } else {
                f64::NAN
            }
        })
        .collect();
    Ok(ArxFit {
        model,
        loss,
        fit,
        rows,
        compression: data.report.clone(),
    })
}

#[cfg(test)]
mod tests;

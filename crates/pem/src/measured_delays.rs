//! Input delays from the measured output samples alone (issue 49): the
//! delay estimate of the output-error methods on multirate records, whose
//! outputs are measured every P samples (an analyser), where the ARX-based
//! [`crate::estimate_delays`] cannot run (its regressors are past outputs).
//!
//! Per output, the FIR regression of each measured sample on the inputs'
//! `lags` past values from the smallest delay on (and a constant),
//! y(t) = c + Σ_j Σ_k b_jk u_j(t − k) + v(t) at the measured t only — a
//! valid least-squares problem without the missing samples, solved by an
//! R-only QR of the rows (never the normal equations). The delay of input j
//! is the first lag whose coefficient is significant, |b_jk| > z σ_jk, with
//! σ from the residual variance and R⁻¹ (Ljung 1999, §16.5: the delay as
//! the first non-zero impulse-response coefficient). O(M (n_u L)²) for M
//! measured samples.
//!
//! Where the measured samples cannot tell some lags apart — an input held
//! over several samples and an output measured every P (a step test read
//! by an analyser, set-points held for 10 samples read every 5th) make
//! lagged columns identical at the measured rows — the regression is
//! solved by the pseudo-inverse of R (the minimum-norm coefficients, which
//! share a response equally among the lags it cannot separate; the
//! standard deviations from R⁺ as from R⁻¹): the delay is then the first
//! lag of the first group of lags the data resolve with a significant
//! coefficient — the earliest delay the record is consistent with.

use lifted_linalg::RAccumulator;
use lifted_subspace::Experiment;
use nalgebra::DMatrix;

use crate::error::{Error, Result};

/// Relative rank tolerance of the FIR regression's R (singular values
/// below 1e-10 σ_max are lags the measured samples do not separate; the
/// threshold of the output-error start's rank check).
const RANK_TOLERANCE: lifted_linalg::RankTolerance = lifted_linalg::RankTolerance::Relative(1e-10);

/// Options of [`estimate_delays_measured`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeasuredDelayOptions {
    /// The smallest delay considered (1: no feedthrough). Default 1.
    pub min_delay: usize,
    /// FIR lags per input from `min_delay` on: the largest delay found is
    /// `min_delay + lags − 1`. Default 20.
    pub lags: usize,
    /// The significance threshold z on |b| / σ: 3 by default, a two-sided
    /// false alarm of 0.27 % per lag for Gaussian errors (about 5 % over
    /// the 20 lags of an input with no response at all, which then takes
    /// the first lag where the threshold is crossed by chance).
    pub z: f64,
}

impl Default for MeasuredDelayOptions {
    fn default() -> Self {
        MeasuredDelayOptions {
            min_delay: 1,
            lags: 20,
            z: 3.0,
        }
    }
}

/// The delay of every input to every output (`delays[output][input]`) from
/// the measured samples (NaN: not measured) of `experiments` (module docs).
///
/// Errors: [`Error::InvalidOption`] (no lags, a non-positive threshold),
/// [`Error::NoData`], [`Error::DimensionMismatch`], [`Error::TooFewSamples`]
/// (fewer measured samples than the FIR's coefficients), and the QR's.
pub fn estimate_delays_measured(
    experiments: &[Experiment<'_>],
    opts: &MeasuredDelayOptions,
) -> Result<Vec<Vec<usize>>> {
    if opts.lags == 0 || !(opts.z.is_finite() && opts.z > 0.0) {
        return Err(Error::InvalidOption {
            what: "MeasuredDelayOptions",
            reason: format!(
                "lags ≥ 1 and z > 0 are required, got {} and {}",
                opts.lags, opts.z
            ),
        });
    }
    let first = experiments.first().ok_or(Error::NoData)?;
    let (nu, ny) = (first.u.ncols(), first.y.ncols());
    for e in experiments {
        crate::checks::check_record_shape("record (u, y)", e.u, e.y, nu, ny)?;
        crate::checks::check_finite("u", e.u)?;
    }
    let (lags, d0) = (opts.lags, opts.min_delay);
    let span = d0 + lags - 1;
    let p = nu * lags + 1;
    let mut delays = vec![vec![d0; nu]; ny];
    for (o, out) in delays.iter_mut().enumerate() {
        let mut acc = RAccumulator::new(p + 1);
        let mut rows = 0usize;
        let mut block = DMatrix::zeros(256, p + 1);
        let mut used = 0;
        for e in experiments {
            for t in span..e.u.nrows() {
                let v = e.y[(t, o)];
                if v.is_nan() {
                    continue;
                }
                for j in 0..nu {
                    for k in 0..lags {
                        block[(used, j * lags + k)] = e.u[(t - d0 - k, j)];
                    }
                }
                block[(used, p - 1)] = 1.0;
                block[(used, p)] = v;
                used += 1;
                rows += 1;
                if used == block.nrows() {
                    acc.push_rows(&block)?;
                    used = 0;
                }
            }
        }
        if used > 0 {
            acc.push_rows(&block.rows(0, used).into_owned())?;
        }
        if rows <= p {
            return Err(Error::TooFewSamples {
                what: "the delay estimate from the measured samples",
                measured: rows,
                needed: p + 1,
            });
        }
        let r = acc.r();
        let r11 = r.view((0, 0), (p, p)).into_owned();
        // R₁₁⁻¹, or its pseudo-inverse where the measured samples cannot
        // tell some lags apart (module docs); the residual's degrees of
        // freedom are the rows less the rank.
        let rank = lifted_linalg::rank(&r11, RANK_TOLERANCE)?;
        let inv = if rank == p {
            r11.clone().try_inverse()
        } else {
            None
        };
        let inv = match inv.filter(|m| m.iter().all(|v| v.is_finite())) {
            Some(inv) => inv,
            None => lifted_linalg::pinv(&r11, RANK_TOLERANCE)?,
        };
        let theta = &inv * r.view((0, p), (p, 1));
        let s2 = r[(p, p)].powi(2) / (rows - rank.min(p)) as f64;
        for (j, d) in out.iter_mut().enumerate() {
            for k in 0..lags {
                let c = j * lags + k;
                let sd = (s2 * inv.row(c).norm_squared()).sqrt();
                if theta[c].abs() > opts.z * sd {
                    *d = d0 + k;
                    break;
                }
            }
        }
    }
    Ok(delays)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// y = q⁻ᵈ (0.5 + 0.3 q⁻¹)/(1 − 1.2 q⁻¹ + 0.5 q⁻²) u + e, measured
    /// every `period` samples.
    fn record(delay: usize, period: usize) -> (DMatrix<f64>, DMatrix<f64>) {
        let n = 3000;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(delay as u64 + 7);
        let u: Vec<f64> = (0..n)
            .map(|_| if rng.random::<bool>() { 1.0 } else { -1.0 })
            .collect();
        let mut w = vec![0.0; n];
        for t in 0..n {
            let b = |k: usize| if t >= k { u[t - k] } else { 0.0 };
            let f = |k: usize| if t >= k { w[t - k] } else { 0.0 };
            w[t] = 0.5 * b(delay) + 0.3 * b(delay + 1) + 1.2 * f(1) - 0.5 * f(2);
        }
        let y = DMatrix::from_fn(n, 1, |t, _| {
            if t % period == 0 {
                w[t] + 0.1 * (rng.random::<f64>() - 0.5)
            } else {
                f64::NAN
            }
        });
        (DMatrix::from_column_slice(n, 1, &u), y)
    }

    #[test]
    fn the_delay_is_found_from_slow_samples() {
        for (delay, period) in [(1, 1), (2, 5), (4, 3)] {
            let (u, y) = record(delay, period);
            let d = estimate_delays_measured(
                &[Experiment { u: &u, y: &y }],
                &MeasuredDelayOptions::default(),
            )
            .unwrap();
            assert_eq!(d, vec![vec![delay]], "delay {delay}, period {period}");
        }
        // The input held for 10 samples, the output read every 5th: lags
        // 1–5 (and 6–10) of a hold are the same columns at the measured
        // rows (once refused as rank deficient); the delay is the first lag
        // of the first group the data resolve — 1 for a true delay of 2.
        let (u, y) = record(2, 5);
        let held = DMatrix::from_fn(u.nrows(), 1, |t, _| u[(t - t % 10, 0)]);
        let mut w = vec![0.0; held.nrows()];
        for t in 0..w.len() {
            let b = |k: usize| if t >= k { held[(t - k, 0)] } else { 0.0 };
            let f = |k: usize| if t >= k { w[t - k] } else { 0.0 };
            w[t] = 0.5 * b(2) + 0.3 * b(3) + 1.2 * f(1) - 0.5 * f(2);
        }
        let yh = DMatrix::from_fn(w.len(), 1, |t, _| if t % 5 == 0 { w[t] } else { f64::NAN });
        let d = estimate_delays_measured(
            &[Experiment { u: &held, y: &yh }],
            &MeasuredDelayOptions::default(),
        )
        .unwrap();
        assert_eq!(d, vec![vec![1]]);
        let few = estimate_delays_measured(
            &[Experiment {
                u: &u.rows(0, 60).into_owned(),
                y: &y.rows(0, 60).into_owned(),
            }],
            &MeasuredDelayOptions::default(),
        );
        assert!(matches!(few, Err(Error::TooFewSamples { .. })), "{few:?}");
        assert!(
            estimate_delays_measured(
                &[Experiment { u: &u, y: &y }],
                &MeasuredDelayOptions {
                    lags: 0,
                    ..Default::default()
                }
            )
            .is_err()
        );
    }
}

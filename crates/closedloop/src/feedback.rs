//! Feedback detection: does the input depend on past output innovations?
//!
//! Under feedback the noise reaches the input through the controller, so
//! the input at t depends on the output innovations before t; in open loop
//! it does not (the idea of MATLAB's `feedback`/`advice`). Given the
//! inputs u (N × m) and the innovations e (N × p) of a model of the
//! records (its one-step prediction errors; NaN where an output is not
//! measured, taken as 0), each input is tested for Granger causality from
//! e: the least-squares regression of u_j(t) on a constant and
//! u(t−1) … u(t−L) (the input's own colour, and the other inputs')
//! against the same with e(t−1) … e(t−L) added. The likelihood-ratio
//! statistic
//!
//! T_j = n ln(RSS_restricted / RSS_full)
//!
//! is asymptotically χ² with p L degrees of freedom when u_j does not
//! depend on past innovations; feedback is detected for u_j when
//! P(χ²_{pL} > T_j) is below the significance level (default 1 %). The
//! lag L defaults to max(5, 2 P_max) base periods for the longest output
//! period P_max, so that a controller acting on the latest slow
//! measurement is seen. One QR factor of [1, u lags, e lags, u(t)]
//! (R-only, streamed in row blocks, never the normal equations) gives every
//! input's two residual sums at once: with R of that matrix, the residual
//! of response column c over the first k regressors is Σ_{i ≥ k} R_ic²
//! (i ≤ c). Cost O(n (1 + (m + p) L + m)²) for n rows, at most
//! [`FeedbackOptions::max_samples`] (the last ones).
//!
//! The χ² tail is the regularised upper incomplete gamma function
//! Q(k/2, T/2) (series or Lentz continued fraction, lnΓ by Lanczos;
//! Numerical Recipes, 3rd ed., §6.1–6.2), accurate to ~1e-12 here.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Options of [`feedback_test`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct FeedbackOptions {
    /// Lags L of the regression in base periods (default `None`:
    /// max(5, 2 P_max) for the longest output period P_max given to the
    /// test).
    pub lags: Option<usize>,
    /// Significance level of each input's test (default 0.01).
    pub significance: f64,
    /// Rows of the regressions at most (the last ones of the record;
    /// default 20 000: at that length a feedback path that explains
    /// 0.3 % of an input's variance gives a statistic of ≈ 60, beyond the
    /// 1 % critical value of χ² with 20 degrees of freedom, 37.6, while the
    /// VARX and the test cost ≈ 5e7 multiply-adds for a 2 × 2 record).
    pub max_samples: usize,
    /// Order of the VARX whose one-step errors stand for the innovations
    /// on single-rate records ([`arx_innovations`]; default 10): a model's
    /// own errors carry what it misses of the input's effect, and with a
    /// coloured or periodic input that part predicts the input's future
    /// (a false alarm: the robot-arm record's periodic sweep under an
    /// order-4 N4SID model explained 62 % of the input's variance).
    pub arx_order: usize,
}

impl Default for FeedbackOptions {
    fn default() -> Self {
        FeedbackOptions {
            lags: None,
            significance: 0.01,
            max_samples: 20_000,
            arx_order: 10,
        }
    }
}

/// One input's evidence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputEvidence {
    /// The input (0-based).
    pub input: usize,
    /// T = n ln(RSS_restricted / RSS_full).
    pub statistic: f64,
    /// Degrees of freedom p L.
    pub dof: usize,
    /// P(χ²_dof > T).
    pub p_value: f64,
    /// Whether p < the significance level.
    pub detected: bool,
    /// The share of the input's variance (after its own past) that the
    /// past innovations explain: 1 − RSS_full / RSS_restricted.
    pub explained: f64,
}

/// What [`feedback_test`] found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FeedbackTest {
    /// Whether feedback was detected for some input.
    pub detected: bool,
    /// The evidence per input.
    pub inputs: Vec<InputEvidence>,
    /// Lags L used.
    pub lags: usize,
    /// Rows of the regression.
    pub rows: usize,
    /// The significance level.
    pub significance: f64,
    /// The rule, in words.
    pub rule: String,
}

/// Tests whether the inputs `u` (N × m) depend on past innovations `e`
/// (N × p, NaN = output not measured) (module docs). `longest_period`: the
/// longest output period in base periods (1 for single-rate records).
///
/// Errors: [`Error::DimensionMismatch`] when u and e differ in length,
/// [`Error::InvalidArgument`] for a significance outside (0, 1),
/// `max_samples` 0, a non-finite input or an infinite innovation,
/// [`Error::TooShort`] when the record has too few rows for the
/// regression.
pub fn feedback_test(
    u: &DMatrix<f64>,
    e: &DMatrix<f64>,
    longest_period: usize,
    opts: &FeedbackOptions,
) -> Result<FeedbackTest> {
    let (n, m, p) = (u.nrows(), u.ncols(), e.ncols());
    if e.nrows() != n {
        return Err(Error::DimensionMismatch {
            what: "innovations",
            expected: format!("{n} rows (as the inputs)"),
            got: format!("{} rows", e.nrows()),
        });
    }
    if !(opts.significance > 0.0 && opts.significance < 1.0) {
        return Err(Error::InvalidArgument {
            what: "feedback significance",
            reason: format!("must lie in (0, 1), got {}", opts.significance),
        });
    }
    if opts.max_samples == 0 {
        return Err(Error::InvalidArgument {
            what: "feedback max_samples",
            reason: "must be at least 1".into(),
        });
    }
    if u.iter().any(|v| !v.is_finite()) || e.iter().any(|v| v.is_infinite()) {
        return Err(Error::InvalidArgument {
            what: "feedback test data",
            reason: "non-finite input or infinite innovation".into(),
        });
    }
    let lags = opts
        .lags
        .unwrap_or(5.max(longest_period.max(1).saturating_mul(2)))
        .max(1);
    if lags >= n {
        // (Checked before any size is computed from it.)
        return Err(Error::TooShort {
            what: "feedback test",
            need: lags.saturating_add(1),
            got: n,
        });
    }
    let (kr, ku) = (1 + m * lags, 1 + (m + p) * lags);
    let width = ku + m;
    let first = lags.max(n.saturating_sub(opts.max_samples));
    let rows = n.saturating_sub(first);
    if m == 0 || p == 0 || rows < 2 * width + 10 {
        return Err(Error::TooShort {
            what: "feedback test",
            need: first + 2 * width + 10,
            got: n,
        });
    }
    let ev = |t: usize, o: usize| {
        let v = e[(t, o)];
        if v.is_nan() { 0.0 } else { v }
    };
    let mut acc = lifted_linalg::RAccumulator::new(width);
    const BLOCK: usize = 1024;
    let mut t = first;
    while t < n {
        let take = BLOCK.min(n - t);
        let block = DMatrix::from_fn(take, width, |r, c| {
            let s = t + r;
            if c == 0 {
                1.0
            } else if c < kr {
                let (lag, j) = ((c - 1) / m + 1, (c - 1) % m);
                u[(s - lag, j)]
            } else if c < ku {
                let (lag, o) = ((c - kr) / p + 1, (c - kr) % p);
                ev(s - lag, o)
            } else {
                u[(s, c - ku)]
            }
        });
        acc.push_rows(&block)?;
        t += take;
    }
    let r = acc.r();
    let tail = |from: usize, c: usize| -> f64 {
        (from..=c.min(r.nrows().saturating_sub(1)))
            .map(|i| r[(i, c)] * r[(i, c)])
            .sum()
    };
    let dof = p * lags;
    let mut inputs = Vec::with_capacity(m);
    for j in 0..m {
        let c = ku + j;
        let (full, restricted) = (tail(ku, c), tail(kr, c));
        let (statistic, explained) = if restricted <= 0.0 {
            // The input is an exact function of its own past: nothing is
            // left for the innovations to explain.
            (0.0, 0.0)
        } else if full <= 0.0 {
            (f64::INFINITY, 1.0)
        } else {
            (
                rows as f64 * (restricted / full).ln(),
                1.0 - full / restricted,
            )
        };
        let p_value = chi2_survival(statistic, dof);
        inputs.push(InputEvidence {
            input: j,
            statistic,
            dof,
            p_value,
            detected: p_value < opts.significance,
            explained,
        });
    }
    Ok(FeedbackTest {
        detected: inputs.iter().any(|i| i.detected),
        inputs,
        lags,
        rows,
        significance: opts.significance,
        rule: format!(
            "each input regressed on a constant and its own and the other inputs' past {lags} samples, with and without the model's past {lags} output innovations (Granger); n ln(RSS ratio) against χ² with {dof} degrees of freedom at significance {}",
            opts.significance
        ),
    })
}

/// The one-step errors of a VARX of order `order` fitted by least squares
/// to the last `max_samples` rows of (u, y) (single-rate: every output
/// measured): y(t) regressed on a constant, y(t−1) … y(t−order) and
/// u(t−1) … u(t−order) (u(t) left out: under feedback it carries the
/// innovation of the same instant). One R-only QR of the regressors and
/// the outputs (streamed in row blocks), then the residuals in a second
/// pass; O(n (1 + order (m + p) + p)²). Rows before the first full lag
/// window are NaN (not measured, for [`feedback_test`]).
///
/// Errors: [`Error::DimensionMismatch`], [`Error::InvalidArgument`] for a
/// non-finite sample or order 0, [`Error::TooShort`].
pub fn arx_innovations(
    u: &DMatrix<f64>,
    y: &DMatrix<f64>,
    order: usize,
    max_samples: usize,
) -> Result<DMatrix<f64>> {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            let (n, m, p) = (u.nrows(), u.ncols(), y.ncols());
            if y.nrows() != n {
                return Err(Error::DimensionMismatch {
                    what: "outputs",
                    expected: format!("{n} rows (as the inputs)"),
                    got: format!("{} rows", y.nrows()),
                });
            }
            if order >= n {
                return Err(Error::TooShort {
                    what: "VARX innovations",
                    need: order.saturating_add(1),
                    got: n,
                });
            }
            if order == 0 || u.iter().chain(y.iter()).any(|v| !v.is_finite()) {
                return Err(Error::InvalidArgument {
            what: "VARX innovations",
            reason:
                "order 0, or a sample not finite (a multirate record has no VARX on the base grid)"
                    .into(),
        });
            }
            let k = 1 + order * (m + p);
            let first = order.max(n.saturating_sub(max_samples.max(1)));
            if n.saturating_sub(first) < 2 * (k + p) + 10 {
                return Err(Error::TooShort {
                    what: "VARX innovations",
                    need: first + 2 * (k + p) + 10,
                    got: n,
                });
            }
            let row = |s: usize, c: usize| -> f64 {
                if c == 0 {
                    1.0
                } else if c <= order * p {
                    let (lag, o) = ((c - 1) / p + 1, (c - 1) % p);
                    y[(s - lag, o)]
                } else if c < k {
                    let c = c - 1 - order * p;
                    let (lag, j) = (c / m + 1, c % m);
                    u[(s - lag, j)]
                } else {
                    y[(s, c - k)]
                }
            };
            const BLOCK: usize = 1024;
            let mut acc = lifted_linalg::RAccumulator::new(k + p);
            let mut t = first;
            while t < n {
                let take = BLOCK.min(n - t);
                acc.push_rows(&DMatrix::from_fn(take, k + p, |r, c| row(t + r, c)))?;
                t += take;
            }
            let r = acc.r();
            let rx = r.view((0, 0), (k, k)).into_owned();
            let ry = r.view((0, k), (k, p)).into_owned();
            let theta = lifted_linalg::lstsq(&rx, &ry)?;
            let mut e = DMatrix::from_element(n, p, f64::NAN);
            for s in first..n {
                for o in 0..p {
                    let mut v = y[(s, o)];
                    for c in 0..k {
                        v -= row(s, c) * theta[(c, o)];
                    }
                    e[(s, o)] = v;
                }
            }
            Ok(e)
        },
    )
}

/// P(χ²_k > x): the regularised upper incomplete gamma Q(k/2, x/2).
pub fn chi2_survival(x: f64, k: usize) -> f64 {
    if x.is_nan() || k == 0 {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 1.0;
    }
    if x.is_infinite() {
        return 0.0;
    }
    gamma_q(k as f64 / 2.0, x / 2.0)
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, 9 terms; relative error ~1e-15).
fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection.
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Q(a, x) = Γ(a, x) / Γ(a) for a > 0, x > 0: the series of P for
/// x < a + 1, else Lentz's continued fraction for Q.
fn gamma_q(a: f64, x: f64) -> f64 {
    let ln_front = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        let (mut sum, mut term, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (1.0 - sum * ln_front.exp()).clamp(0.0, 1.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (ln_front.exp() * h).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// The 1 % critical values of χ² (tables) have tail 0.01; the tail of
    /// χ²₂ is exp(−x/2) exactly.
    #[test]
    fn chi2_tails_match_the_tables() {
        for (x, k) in [
            (6.634_897, 1),
            (23.209_251, 10),
            (37.566_235, 20),
            (63.690_740, 40),
        ] {
            assert_relative_eq!(chi2_survival(x, k), 0.01, max_relative = 1e-5);
        }
        for x in [0.1, 1.0, 5.0, 30.0] {
            assert_relative_eq!(chi2_survival(x, 2), (-x / 2.0).exp(), max_relative = 1e-12);
        }
        assert_eq!(chi2_survival(0.0, 3), 1.0);
        assert_eq!(chi2_survival(f64::INFINITY, 3), 0.0);
    }

    /// A seeded linear congruential sequence of uniform deviates in
    /// (−0.5, 0.5) (the test needs no distribution beyond that).
    fn noise(seed: u64, n: usize) -> Vec<f64> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect()
    }

    /// The VARX errors of an ARX(1) record are its white noise (to the
    /// estimation error), NaN before the first lag window.
    #[test]
    fn arx_innovations_recover_the_noise() {
        let n = 5000;
        let (r, w) = (noise(3, n), noise(4, n));
        let mut y = DMatrix::zeros(n, 1);
        for t in 1..n {
            y[(t, 0)] = 0.8 * y[(t - 1, 0)] + 0.5 * r[t - 1] + w[t];
        }
        let u = DMatrix::from_column_slice(n, 1, &r);
        let e = arx_innovations(&u, &y, 2, n).unwrap();
        assert!(e[(1, 0)].is_nan() && e[(2, 0)].is_finite());
        let err: f64 = (2..n).map(|t| (e[(t, 0)] - w[t]).powi(2)).sum::<f64>() / (n - 2) as f64;
        let var: f64 = w.iter().map(|v| v * v).sum::<f64>() / n as f64;
        assert!(err < 0.01 * var, "{err} vs {var}");
    }

    /// Open loop: u independent of e (not detected); closed loop: u(t) =
    /// r(t) − 0.5 e(t − 1) (detected, most of the variance explained).
    #[test]
    fn feedback_is_told_from_open_loop() {
        let n = 20_000;
        let (r, w) = (noise(1, n), noise(2, n));
        let e = DMatrix::from_column_slice(n, 1, &w);
        let open = DMatrix::from_column_slice(n, 1, &r);
        let t = feedback_test(&open, &e, 1, &FeedbackOptions::default()).unwrap();
        assert!(!t.detected, "{t:?}");
        let closed = DMatrix::from_fn(n, 1, |k, _| r[k] - if k > 0 { 0.5 * w[k - 1] } else { 0.0 });
        let t = feedback_test(&closed, &e, 1, &FeedbackOptions::default()).unwrap();
        assert!(t.detected && t.inputs[0].p_value < 1e-12, "{t:?}");
        assert!(t.inputs[0].explained > 0.15, "{t:?}");
    }

    #[test]
    fn bad_input_is_refused() {
        let u = DMatrix::from_element(100, 1, 1.0);
        let e = DMatrix::from_element(99, 1, 1.0);
        assert!(feedback_test(&u, &e, 1, &FeedbackOptions::default()).is_err());
        let e = DMatrix::from_element(100, 1, 1.0);
        let bad = FeedbackOptions {
            significance: 1.5,
            ..Default::default()
        };
        assert!(feedback_test(&u, &e, 1, &bad).is_err());
        let short = DMatrix::from_element(20, 1, 1.0);
        assert!(feedback_test(&short, &short, 1, &FeedbackOptions::default()).is_err());
        // Absurd sizes are refused before anything is sized from them.
        let huge = FeedbackOptions {
            lags: Some(usize::MAX),
            ..Default::default()
        };
        assert!(feedback_test(&u, &e, 1, &huge).is_err());
        assert!(feedback_test(&u, &e, usize::MAX, &FeedbackOptions::default()).is_err());
        assert!(arx_innovations(&u, &e, usize::MAX, 100).is_err());
    }
}

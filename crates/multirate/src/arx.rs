//! Lifted ARX with causality constraints (thesis Ch. 6) and CCA input
//! screening (§6.4).
//!
//! **Lifted ARX.** For one slow output y(k) (one sample per frame) and
//! lifted inputs u̲_j(k), the MISO ARX model
//! A(q⁻¹) y(k) = Σ_j B_j(q⁻¹) u̲_j(k) + e(k) with A = 1 + a₁q⁻¹ + … + a_{n_a}q^{−n_a}
//! and B_j = Σ_{i=d_j}^{d_j+n_b−1} b_{ji} q^{−i}; the delay d_j is 1 for
//! lifted inputs that act after the output instant (causality of eq. 6.3:
//! P₁ … P_{n−1} are strictly proper) and 0 otherwise (or 1 for all when the
//! fast model is strictly proper). Least squares (QR), O(K p²) for
//! p = n_a + n_b·n̲_u parameters. The lifted transfer functions
//! P_j = B_j/A are returned in positive powers of z, ready for the
//! recombination (6.4) ([`crate::recombine_lifted_tf`]).
//!
//! **CCA screening.** Rank the original inputs by their structure
//! correlation with the slow output: the canonical variate of the lifted
//! inputs most correlated with y (lifted-linalg `cca`) and, per input, the
//! sum of squared correlations between that variate and the input's lifted
//! components (spec A3.8 stand-in for the CCR case).

use lifted_linalg::{cca, center_rows, lstsq};
use lifted_lti::{Poly, SisoTf};
use nalgebra::DMatrix;

use crate::error::{Error, Result, check_finite};
use crate::lifting::MultirateLifting;

/// Options of [`lifted_arx`].
#[derive(Debug, Clone, PartialEq)]
pub struct LiftedArxOptions {
    /// Order n_a of A. Default 1.
    pub na: usize,
    /// Number n_b of coefficients of each B_j. Default 1.
    pub nb: usize,
    /// Delay d_j per lifted input; None derives them from the causality of
    /// the lifting (see the [module docs](self)). Default None.
    pub delays: Option<Vec<usize>>,
    /// With derived delays: the fast model is strictly proper (every d_j ≥ 1).
    /// Default true.
    pub strictly_proper: bool,
}

impl Default for LiftedArxOptions {
    fn default() -> Self {
        LiftedArxOptions {
            na: 1,
            nb: 1,
            delays: None,
            strictly_proper: true,
        }
    }
}

/// A lifted ARX model.
#[derive(Debug, Clone, PartialEq)]
pub struct LiftedArx {
    /// a₁ … a_{n_a}.
    pub a: Vec<f64>,
    /// b_j coefficients per lifted input (n_b each, from lag d_j).
    pub b: Vec<Vec<f64>>,
    /// Delays d_j used.
    pub delays: Vec<usize>,
    /// P_j = B_j/A in positive powers of z.
    pub parts: Vec<SisoTf>,
    /// Residual variance of the one-step prediction errors.
    pub residual_variance: f64,
}

/// Delays d_j for a lifting with one output sample per frame (at time 0):
/// 0 for inputs whose slot may act at the output instant, else 1.
pub fn causal_delays(lifting: &MultirateLifting, strictly_proper: bool) -> Result<Vec<usize>> {
    if lifting.lifted_outputs() != 1 {
        return Err(Error::Unsupported {
            what: "lifted ARX",
            reason: "one slow output sample per frame needed".into(),
        });
    }
    let mask = lifting.causal_mask(strictly_proper);
    Ok((0..lifting.lifted_inputs())
        .map(|j| usize::from(!mask[(0, j)]))
        .collect())
}

/// Fits the lifted ARX model to `y` (K×1 slow output) and `ul` (K×n̲_u).
/// With `opts.delays = None`, `lifting` gives the causal delays.
/// Errors: shapes, non-finite data, orders 0 or too high for the data
/// ([`Error::OrderTooLarge`]), rank-deficient regressors.
pub fn lifted_arx(
    y: &DMatrix<f64>,
    ul: &DMatrix<f64>,
    lifting: Option<&MultirateLifting>,
    opts: &LiftedArxOptions,
) -> Result<LiftedArx> {
    check_finite("y", y)?;
    check_finite("lifted u", ul)?;
    if y.ncols() != 1 || y.nrows() != ul.nrows() {
        return Err(Error::DimensionMismatch {
            what: "slow output",
            expected: format!("{}x1", ul.nrows()),
            got: format!("{}x{}", y.nrows(), y.ncols()),
        });
    }
    let nu = ul.ncols();
    let delays = match (&opts.delays, lifting) {
        (Some(d), _) => {
            if d.len() != nu {
                return Err(Error::DimensionMismatch {
                    what: "delays",
                    expected: format!("{nu}"),
                    got: format!("{}", d.len()),
                });
            }
            d.clone()
        }
        (None, Some(l)) => causal_delays(l, opts.strictly_proper)?,
        (None, None) => vec![usize::from(opts.strictly_proper); nu],
    };
    if opts.nb == 0 {
        return Err(Error::InvalidRates {
            what: "n_b",
            reason: "at least one numerator coefficient".into(),
        });
    }
    let maxlag = delays
        .iter()
        .map(|&d| d + opts.nb - 1)
        .max()
        .unwrap_or(0)
        .max(opts.na);
    let np = opts.na + opts.nb * nu;
    let k = y.nrows();
    if k <= maxlag + np {
        return Err(Error::OrderTooLarge {
            order: np,
            max: k.saturating_sub(maxlag + 1),
        });
    }
    let rows = k - maxlag;
    let mut phi = DMatrix::zeros(rows, np);
    let mut target = DMatrix::zeros(rows, 1);
    for r in 0..rows {
        let t = r + maxlag;
        target[(r, 0)] = y[(t, 0)];
        for i in 0..opts.na {
            phi[(r, i)] = -y[(t - 1 - i, 0)];
        }
        for j in 0..nu {
            for i in 0..opts.nb {
                phi[(r, opts.na + j * opts.nb + i)] = ul[(t - delays[j] - i, j)];
            }
        }
    }
    let theta = lstsq(&phi, &target)?;
    let resid = &target - &phi * &theta;
    let residual_variance = resid.norm_squared() / rows as f64;
    let a: Vec<f64> = (0..opts.na).map(|i| theta[(i, 0)]).collect();
    let b: Vec<Vec<f64>> = (0..nu)
        .map(|j| {
            (0..opts.nb)
                .map(|i| theta[(opts.na + j * opts.nb + i, 0)])
                .collect()
        })
        .collect();
    // positive powers: multiply num and den by z^L, L = maxlag
    let l = maxlag;
    let mut den = vec![0.0; l + 1];
    den[0] = 1.0;
    for (i, &ai) in a.iter().enumerate() {
        den[i + 1] = ai;
    }
    let den = Poly::new(den)?;
    let mut parts = Vec::with_capacity(nu);
    for j in 0..nu {
        let mut num = vec![0.0; l + 1];
        for (i, &bi) in b[j].iter().enumerate() {
            num[delays[j] + i] = bi;
        }
        parts.push(SisoTf::new(Poly::new(num)?, den.clone())?);
    }
    Ok(LiftedArx {
        a,
        b,
        delays,
        parts,
        residual_variance,
    })
}

/// One input's score in [`screen_inputs`].
#[derive(Debug, Clone, PartialEq)]
pub struct InputScore {
    /// Index of the original input.
    pub input: usize,
    /// Structure correlation Σ corr(component, canonical variate)².
    pub structure_correlation: f64,
}

/// Result of [`screen_inputs`].
#[derive(Debug, Clone, PartialEq)]
pub struct Screening {
    /// Canonical correlations between lifted inputs and the output(s).
    pub canonical_correlations: Vec<f64>,
    /// Inputs ranked by structure correlation, largest first.
    pub ranking: Vec<InputScore>,
}

impl Screening {
    /// The `count` best inputs, in index order.
    pub fn top(&self, count: usize) -> Vec<usize> {
        let mut v: Vec<usize> = self.ranking.iter().take(count).map(|s| s.input).collect();
        v.sort_unstable();
        v
    }

    /// Inputs whose structure correlation is at least `fraction` of the best.
    pub fn significant(&self, fraction: f64) -> Vec<usize> {
        let best = self
            .ranking
            .first()
            .map(|s| s.structure_correlation)
            .unwrap_or(0.0);
        let mut v: Vec<usize> = self
            .ranking
            .iter()
            .filter(|s| s.structure_correlation >= fraction * best)
            .map(|s| s.input)
            .collect();
        v.sort_unstable();
        v
    }
}

/// CCA screening (§6.4): `x` K×p lifted regressors (one row per slow
/// sample), `y` K×q slow outputs, `groups[i]` the columns of x that belong
/// to original input i. Means are removed. O(K(p² + q²)).
/// Errors: shapes, non-finite data, K < p + q, rank-deficient regressors.
pub fn screen_inputs(
    x: &DMatrix<f64>,
    y: &DMatrix<f64>,
    groups: &[Vec<usize>],
) -> Result<Screening> {
    check_finite("x", x)?;
    check_finite("y", y)?;
    if x.nrows() != y.nrows() {
        return Err(Error::DimensionMismatch {
            what: "rows of y",
            expected: format!("{}", x.nrows()),
            got: format!("{}", y.nrows()),
        });
    }
    if let Some(bad) = groups.iter().flatten().find(|&&c| c >= x.ncols()) {
        return Err(Error::DimensionMismatch {
            what: "group column",
            expected: format!("< {}", x.ncols()),
            got: format!("{bad}"),
        });
    }
    let xc = center_rows(&x.transpose())?;
    let yc = center_rows(&y.transpose())?;
    let c = cca(&xc, &yc)?;
    let w = c.x_weights.column(0);
    let v = xc.transpose() * w; // K-vector canonical variate
    let vn = v.norm();
    let mut ranking: Vec<InputScore> = groups
        .iter()
        .enumerate()
        .map(|(i, cols)| {
            let s = cols
                .iter()
                .map(|&col| {
                    let comp = xc.row(col);
                    let cn = comp.norm();
                    if cn == 0.0 || vn == 0.0 {
                        0.0
                    } else {
                        let r = comp.dot(&v.transpose()) / (cn * vn);
                        r * r
                    }
                })
                .sum();
            InputScore {
                input: i,
                structure_correlation: s,
            }
        })
        .collect();
    ranking.sort_by(|a, b| b.structure_correlation.total_cmp(&a.structure_correlation));
    Ok(Screening {
        canonical_correlations: c.correlations.iter().cloned().collect(),
        ranking,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arx_recovers_exact_first_order() {
        // y(k) = 0.5 y(k-1) + u0(k-1) - 2 u1(k-1)
        let k = 50;
        let ul = DMatrix::from_fn(k, 2, |i, j| (((i * 7 + j * 3) % 5) as f64) - 2.0);
        let mut y = DMatrix::zeros(k, 1);
        for t in 1..k {
            y[(t, 0)] = 0.5 * y[(t - 1, 0)] + ul[(t - 1, 0)] - 2.0 * ul[(t - 1, 1)];
        }
        let m = lifted_arx(&y, &ul, None, &LiftedArxOptions::default()).unwrap();
        assert!((m.a[0] + 0.5).abs() < 1e-12);
        assert!((m.b[0][0] - 1.0).abs() < 1e-12 && (m.b[1][0] + 2.0).abs() < 1e-12);
        assert!(m.residual_variance < 1e-20);
    }
}

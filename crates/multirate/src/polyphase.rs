//! Polyphase forms of thesis Ch. 6 (§6.2) and §9.2.
//!
//! For a fast SISO model P_T(z) = Σ p(k) z^{−k} and lifting factor n
//! (hold T, output every nT):
//!
//! * polyphase components P̃_i(z) = Σ_k p(nk + i) z^{−k}, i = 0…n−1;
//! * lifted subsystems P_j (lifted input u_j = u(nk + j) → y(nk)):
//!   P₀ = P̃₀ and P_j = z^{−1} P̃_{n−j} for j ≥ 1 (erratum L-15; the
//!   thesis' "P̃_i are the models of P_i" is wrong);
//! * recombination (6.4): Σ_j z^{j} P_j(zⁿ) = P_T(z), and (6.5):
//!   Σ_i z^{−i} P̃_i(zⁿ) = P_T(z). Both hold for any delay, including delays
//!   that make the state-space lift unobservable (§6.2);
//! * the lifted n×n model (9.2) is pseudo-circulant: entry (i, j) is P̃_{i−j}
//!   for i ≥ j and z^{−1}P̃_{n+i−j} otherwise.
//!
//! Recombination is provided on impulse responses (exact index arithmetic,
//! O(nK)) and on transfer functions (polynomial substitution z → zⁿ, then
//! pole–zero cancellation: the result has a denominator in zⁿ of degree np,
//! spec pitfall 9, so [`recombine_lifted_tf`] cancels to the true order).

use lifted_lti::{Poly, SisoTf, StateSpace, cancel_common_roots};
use nalgebra::DMatrix;

use crate::error::{Error, Result};

fn check_siso(g: &StateSpace, what: &'static str) -> Result<()> {
    if g.n_inputs() != 1 || g.n_outputs() != 1 {
        return Err(Error::Unsupported {
            what,
            reason: format!("SISO model needed, got {}x{}", g.n_outputs(), g.n_inputs()),
        });
    }
    if g.ts().is_none() {
        return Err(Error::Unsupported {
            what,
            reason: "discrete model needed".into(),
        });
    }
    Ok(())
}

fn check_factor(n: usize) -> Result<()> {
    if n == 0 {
        return Err(Error::InvalidRates {
            what: "lifting factor",
            reason: "must be at least 1".into(),
        });
    }
    Ok(())
}

/// State-space realisations of the polyphase components P̃_i (sample period
/// nT): P̃₀ = (Aⁿ, B, CA^{n−1}, D), P̃_i = (Aⁿ, B, CA^{n+i−1}, CA^{i−1}B).
/// O(n·order³).
pub fn polyphase_components(fast: &StateSpace, n: usize) -> Result<Vec<StateSpace>> {
    check_siso(fast, "polyphase_components")?;
    check_factor(n)?;
    let ts = fast.ts().unwrap_or(1.0) * n as f64;
    let (a, b, c, d) = (fast.a(), fast.b(), fast.c(), fast.d());
    let k = a.nrows();
    let mut pw = vec![DMatrix::<f64>::identity(k, k)];
    for i in 0..2 * n {
        let next = a * &pw[i];
        pw.push(next);
    }
    let an = pw[n].clone();
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let (ci, di) = if i == 0 {
            (c * &pw[n - 1], d.clone())
        } else {
            (c * &pw[n + i - 1], c * &pw[i - 1] * b)
        };
        out.push(StateSpace::new(an.clone(), b.clone(), ci, di, Some(ts))?);
    }
    Ok(out)
}

/// Polyphase components of an impulse response: P̃_i(k) = h(nk + i),
/// K = ⌊len/n⌋ samples each.
pub fn polyphase_impulse(h: &[f64], n: usize) -> Result<Vec<Vec<f64>>> {
    check_factor(n)?;
    let k = h.len() / n;
    Ok((0..n)
        .map(|i| (0..k).map(|kk| h[n * kk + i]).collect())
        .collect())
}

/// Impulse responses of the lifted subsystems P_j (u(nk + j) → y(nk)):
/// P_j(k) = h(nk − j) (0 for negative index), K = ⌊len/n⌋ samples each.
pub fn lifted_impulse(h: &[f64], n: usize) -> Result<Vec<Vec<f64>>> {
    check_factor(n)?;
    let k = h.len() / n;
    Ok((0..n)
        .map(|j| {
            (0..k)
                .map(|kk| if n * kk >= j { h[n * kk - j] } else { 0.0 })
                .collect()
        })
        .collect())
}

/// Recombination (6.4) on impulse responses: the coefficients of
/// Σ_j z^{j} P_j(zⁿ), i.e. h(nk − j) = P_j(k); returns n·K − (n−1)
/// coefficients (the last lifted sample only determines h[n(K−1)]).
pub fn recombine_lifted_impulse(parts: &[Vec<f64>]) -> Result<Vec<f64>> {
    let n = parts.len();
    check_factor(n)?;
    let k = parts.iter().map(|p| p.len()).min().unwrap_or(0);
    if k == 0 {
        return Ok(vec![]);
    }
    let len = n * (k - 1) + 1;
    let mut h = vec![0.0; len];
    for (j, p) in parts.iter().enumerate() {
        for (kk, &v) in p.iter().take(k).enumerate() {
            if n * kk >= j {
                let idx = n * kk - j;
                if idx < len {
                    h[idx] += v;
                }
            }
        }
    }
    Ok(h)
}

/// Recombination (6.5) on impulse responses: Σ_i z^{−i} P̃_i(zⁿ), i.e.
/// h(nk + i) = P̃_i(k); returns n·K coefficients.
pub fn recombine_polyphase_impulse(parts: &[Vec<f64>]) -> Result<Vec<f64>> {
    let n = parts.len();
    check_factor(n)?;
    let k = parts.iter().map(|p| p.len()).min().unwrap_or(0);
    let mut h = vec![0.0; n * k];
    for (i, p) in parts.iter().enumerate() {
        for (kk, &v) in p.iter().take(k).enumerate() {
            h[n * kk + i] += v;
        }
    }
    Ok(h)
}

/// Impulse responses of the pseudo-circulant lifted model of §9.2: entry
/// (i, j) for output u(nk + i) … is P̃_{i−j} (i ≥ j) or z^{−1}P̃_{n+i−j}.
/// Returns an n×n grid of sequences of K = ⌊len/n⌋ samples.
pub fn pseudo_circulant_impulse(h: &[f64], n: usize) -> Result<Vec<Vec<Vec<f64>>>> {
    let pt = polyphase_impulse(h, n)?;
    let k = h.len() / n;
    Ok((0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    if i >= j {
                        pt[i - j].clone()
                    } else {
                        let mut v = vec![0.0];
                        v.extend_from_slice(&pt[n + i - j][..k.saturating_sub(1)]);
                        v.truncate(k);
                        v
                    }
                })
                .collect()
        })
        .collect())
}

/// p(zⁿ): inserts n−1 zeros between descending coefficients.
pub fn substitute_power(p: &Poly, n: usize) -> Result<Poly> {
    check_factor(n)?;
    let c = p.coeffs();
    if c.is_empty() {
        return Ok(Poly::zero());
    }
    let mut out = Vec::with_capacity((c.len() - 1) * n + 1);
    for (i, &v) in c.iter().enumerate() {
        out.push(v);
        if i + 1 < c.len() {
            out.extend(std::iter::repeat_n(0.0, n - 1));
        }
    }
    Ok(Poly::new(out)?)
}

fn times_z_power(p: &Poly, k: usize) -> Result<Poly> {
    if p.is_zero() {
        return Ok(Poly::zero());
    }
    let mut c = p.coeffs().to_vec();
    c.extend(std::iter::repeat_n(0.0, k));
    Ok(Poly::new(c)?)
}

fn same_den(a: &Poly, b: &Poly, tol: f64) -> bool {
    let (a, b) = (a.monic(), b.monic());
    a.degree() == b.degree()
        && a.max_abs_diff(&b) <= tol * a.coeffs().iter().fold(1.0f64, |m, v| m.max(v.abs()))
}

/// Sum Σ_k num_k/den with the k-th term multiplied by z^{shift_k}; all
/// terms share (up to `1e-12` relative) one denominator, or the general
/// common denominator is formed.
fn sum_terms(terms: &[(Poly, Poly, usize)]) -> Result<(Poly, Poly)> {
    let Some(first) = terms.first() else {
        return Ok((Poly::zero(), Poly::one()));
    };
    if terms.iter().all(|t| same_den(&t.1, &first.1, 1e-12)) {
        let den = first.1.monic();
        let mut num = Poly::zero();
        for (nk, dk, s) in terms {
            let scale = 1.0 / dk.leading();
            num = &num + &times_z_power(&nk.scale(scale), *s)?;
        }
        return Ok((num, den));
    }
    let mut den = Poly::one();
    for t in terms {
        den = &den * &t.1;
    }
    let mut num = Poly::zero();
    for (i, (nk, _, s)) in terms.iter().enumerate() {
        let mut term = times_z_power(nk, *s)?;
        for (j, t) in terms.iter().enumerate() {
            if i != j {
                term = &term * &t.1;
            }
        }
        num = &num + &term;
    }
    Ok((num, den))
}

/// Recombination (6.4) of lifted subsystem transfer functions P_j(z)
/// (positive powers of z, sample period nT) into the fast TF
/// φ(z) = Σ_j z^{j} P_j(zⁿ), followed by pole–zero cancellation with
/// relative tolerance `tol` (spec A3.8: 1e-8). O((np)³) root finding.
/// Errors: a non-proper result (a P_j, j ≥ 1, that is not strictly proper
/// breaks causality, eq. 6.3), zero parts.
pub fn recombine_lifted_tf(parts: &[SisoTf], tol: f64) -> Result<SisoTf> {
    let n = parts.len();
    check_factor(n)?;
    let mut terms = Vec::with_capacity(n);
    for (j, p) in parts.iter().enumerate() {
        if j >= 1 && !p.num().is_zero() && p.num().degree() >= p.den().degree() {
            return Err(Error::Unsupported {
                what: "recombination (6.4)",
                reason: format!(
                    "lifted subsystem P_{j} must be strictly proper (causality, eq. 6.3)"
                ),
            });
        }
        terms.push((
            substitute_power(p.num(), n)?,
            substitute_power(p.den(), n)?,
            j,
        ));
    }
    let (num, den) = sum_terms(&terms)?;
    let (num, den) = cancel_common_roots(&num, &den, tol)?;
    Ok(SisoTf::new(num, den)?)
}

/// Recombination (6.5) of polyphase components P̃_i(z) into
/// φ(z) = Σ_i z^{−i} P̃_i(zⁿ) (as z^{n−1−i}P̃_i(zⁿ)/z^{n−1}), followed by
/// pole–zero cancellation with relative tolerance `tol`.
pub fn recombine_polyphase_tf(parts: &[SisoTf], tol: f64) -> Result<SisoTf> {
    let n = parts.len();
    check_factor(n)?;
    let mut terms = Vec::with_capacity(n);
    for (i, p) in parts.iter().enumerate() {
        let den = times_z_power(&substitute_power(p.den(), n)?, n - 1)?;
        terms.push((substitute_power(p.num(), n)?, den, n - 1 - i));
    }
    let (num, den) = sum_terms(&terms)?;
    let (num, den) = cancel_common_roots(&num, &den, tol)?;
    Ok(SisoTf::new(num, den)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sequences_recombine() {
        let h: Vec<f64> = (0..30)
            .map(|k| if k < 2 { 0.0 } else { 0.8f64.powi(k - 2) })
            .collect();
        let pj = lifted_impulse(&h, 3).unwrap();
        let back = recombine_lifted_impulse(&pj).unwrap();
        for (a, b) in back.iter().zip(&h) {
            assert!((a - b).abs() < 1e-15);
        }
        let pt = polyphase_impulse(&h, 3).unwrap();
        let back = recombine_polyphase_impulse(&pt).unwrap();
        assert_eq!(back, h);
    }

    #[test]
    fn substitution() {
        let p = Poly::new(vec![1.0, -0.5]).unwrap();
        assert_eq!(
            substitute_power(&p, 3).unwrap().coeffs(),
            &[1.0, 0.0, 0.0, -0.5]
        );
    }
}

//! "Vectorized" excitation of Li 2001 §6.3 (Fig. 6.2).
//!
//! The lifted input `u̲(k) = [u(nk), …, u(nk+n−1)]ᵀ` must have a full-rank spectrum
//! `φ_u̲` for polynomial-domain lifted identification. A slow-held input
//! (`u(nk) = … = u(nk+n−1)`) gives a rank-1 lifted covariance (`σ_n → 0`). Instead,
//! draw the `n` components of `u̲(k)` independently and inverse-lift (`L_n⁻¹`) them to
//! the fast rate: `u(nk + i) = u̲_i(k)`; then `φ_u̲ = a² I`.

use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, check_amplitude, check_factor, check_finite};

/// Options of a vectorized excitation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct VectorizedOptions {
    /// Lifting factor `n` (fast samples per slow sample, Li 2001 eq. 3.1). Default 2.
    pub factor: usize,
    /// Magnitude `a` of each `±a` component. Default 1.0.
    pub amplitude: f64,
    /// Seed of the `ChaCha8Rng`. Default 0.
    pub seed: u64,
}

impl Default for VectorizedOptions {
    fn default() -> Self {
        Self {
            factor: 2,
            amplitude: 1.0,
            seed: 0,
        }
    }
}

/// A vectorized excitation: the lifted sequence and its fast-rate inverse lift.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VectorizedExcitation {
    /// Lifted input, `slow_len × n`: row `k` is `u̲(k)ᵀ`.
    pub lifted: DMatrix<f64>,
    /// Fast-rate input, `u(nk + i) = lifted[(k, i)]`, length `slow_len · n`.
    pub fast: Vec<f64>,
}

/// Generates `slow_len` lifted samples with `n` independent `±a` components each and
/// their inverse lift. O(slow_len · n).
///
/// # Errors
/// [`Error::ZeroLength`], [`Error::ZeroFactor`], [`Error::InvalidAmplitude`].
pub fn vectorized_excitation(
    slow_len: usize,
    options: &VectorizedOptions,
) -> Result<VectorizedExcitation> {
    if slow_len == 0 {
        return Err(Error::ZeroLength { what: "slow_len" });
    }
    check_factor("lifting factor n", options.factor)?;
    check_amplitude(options.amplitude)?;
    let n = options.factor;
    let a = options.amplitude;
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    let fast: Vec<f64> = (0..slow_len * n)
        .map(|_| if rng.random::<bool>() { a } else { -a })
        .collect();
    let lifted = DMatrix::from_row_slice(slow_len, n, &fast);
    Ok(VectorizedExcitation { lifted, fast })
}

/// Lifted input covariance `φ_u̲ = (1/N) Σ_{k<N} u̲(k) u̲(k)ᵀ` (`n × n`, zero lag,
/// no mean removal) of a fast signal of length `N · n`. O(N n²).
///
/// # Errors
/// [`Error::ZeroFactor`], [`Error::EmptySignal`], [`Error::NotMultiple`],
/// [`Error::NonFinite`].
pub fn lifted_covariance(fast: &[f64], factor: usize) -> Result<DMatrix<f64>> {
    check_factor("lifting factor n", factor)?;
    if fast.is_empty() {
        return Err(Error::EmptySignal { what: "fast" });
    }
    if !fast.len().is_multiple_of(factor) {
        return Err(Error::NotMultiple {
            len: fast.len(),
            factor,
        });
    }
    check_finite("fast", fast)?;
    let slow = fast.len() / factor;
    let mut cov = DMatrix::zeros(factor, factor);
    for row in fast.chunks_exact(factor) {
        for i in 0..factor {
            for j in 0..factor {
                cov[(i, j)] += row[i] * row[j];
            }
        }
    }
    Ok(cov / slow as f64)
}

#[cfg(test)]
mod unit {
    use super::*;

    #[test]
    fn covariance_of_constant_rows() {
        let c = lifted_covariance(&[1.0, 1.0, -2.0, -2.0], 2).unwrap();
        // Rows (1,1) and (−2,−2): φ = ((1+4)/2)·ones.
        assert_eq!(c, DMatrix::from_element(2, 2, 2.5));
    }
}

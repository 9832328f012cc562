//! Seeded random excitations: random binary sequence (RBS), generalized binary noise
//! (GBN), Gaussian white noise and Schroeder-phased multisine.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, check_amplitude, check_factor, check_positive};

/// Options of a random binary sequence: `±a` with probability ½ each, every value
/// held `hold` samples (spec §0 "RBS").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RandomBinaryOptions {
    /// Magnitude `a > 0`. Default 1.0.
    pub amplitude: f64,
    /// Samples each value is held (`n_r`, eq. II-7). Default 1.
    pub hold: usize,
    /// Seed of the `ChaCha8Rng`. Default 0.
    pub seed: u64,
}

impl Default for RandomBinaryOptions {
    fn default() -> Self {
        Self {
            amplitude: 1.0,
            hold: 1,
            seed: 0,
        }
    }
}

fn check_len(len: usize) -> Result<()> {
    if len == 0 {
        Err(Error::ZeroLength {
            what: "signal length",
        })
    } else {
        Ok(())
    }
}

/// Random binary sequence of `len` samples. O(len).
///
/// # Errors
/// [`Error::ZeroLength`], [`Error::InvalidAmplitude`], [`Error::ZeroFactor`].
pub fn random_binary(len: usize, options: &RandomBinaryOptions) -> Result<Vec<f64>> {
    check_len(len)?;
    check_amplitude(options.amplitude)?;
    check_factor("hold n_r", options.hold)?;
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    Ok(binary_from_rng(
        &mut rng,
        len,
        options.amplitude,
        options.hold,
    ))
}

/// `len` samples of `±a` held `hold` samples, drawn from `rng`.
pub(crate) fn binary_from_rng(rng: &mut ChaCha8Rng, len: usize, a: f64, hold: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(len);
    while out.len() < len {
        let v = if rng.random::<bool>() { a } else { -a };
        let take = (len - out.len()).min(hold);
        out.extend(std::iter::repeat_n(v, take));
    }
    out
}

/// Options of generalized binary noise (Tulleken 1990): a `±a` signal that switches
/// sign with probability `p` at each (held) step. `p = ½` is an RBS; small `p`
/// moves power to low frequencies (mean switching interval `1/p` steps).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct GbnOptions {
    /// Magnitude `a > 0`. Default 1.0.
    pub amplitude: f64,
    /// Switching probability `p ∈ (0, 1]`. Default 0.5.
    pub switch_probability: f64,
    /// Samples per decision step (`n_r`, eq. II-7). Default 1.
    pub hold: usize,
    /// Seed of the `ChaCha8Rng`. Default 0.
    pub seed: u64,
}

impl Default for GbnOptions {
    fn default() -> Self {
        Self {
            amplitude: 1.0,
            switch_probability: 0.5,
            hold: 1,
            seed: 0,
        }
    }
}

/// Generalized binary noise of `len` samples. The initial sign is random. O(len).
///
/// # Errors
/// [`Error::ZeroLength`], [`Error::InvalidAmplitude`], [`Error::InvalidProbability`],
/// [`Error::ZeroFactor`].
pub fn generalized_binary_noise(len: usize, options: &GbnOptions) -> Result<Vec<f64>> {
    check_len(len)?;
    check_amplitude(options.amplitude)?;
    check_factor("hold n_r", options.hold)?;
    let p = options.switch_probability;
    if !(p > 0.0 && p <= 1.0) {
        return Err(Error::InvalidProbability { probability: p });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    let mut v = if rng.random::<bool>() {
        options.amplitude
    } else {
        -options.amplitude
    };
    let mut out = Vec::with_capacity(len);
    let mut first = true;
    while out.len() < len {
        if !first && rng.random::<f64>() < p {
            v = -v;
        }
        first = false;
        let take = (len - out.len()).min(options.hold);
        out.extend(std::iter::repeat_n(v, take));
    }
    Ok(out)
}

/// Options of seeded Gaussian white noise `N(0, σ²)`, every value held `hold`
/// samples: the "white Gaussian" input of the subspace and lifting experiments
/// (e.g. spec A3.6 experiment 1), where a binary signal's ±a values are not wanted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct GaussianOptions {
    /// Standard deviation `σ > 0`. Default 1.0.
    pub std: f64,
    /// Samples each value is held (`n_r`, eq. II-7). Default 1.
    pub hold: usize,
    /// Seed of the `ChaCha8Rng`. Default 0.
    pub seed: u64,
}

impl Default for GaussianOptions {
    fn default() -> Self {
        Self {
            std: 1.0,
            hold: 1,
            seed: 0,
        }
    }
}

/// Gaussian white noise of `len` samples (standard normals from `rand_distr`'s
/// ziggurat on a seeded `ChaCha8Rng`, scaled by σ, each held `hold` samples).
/// O(len).
///
/// # Errors
/// [`Error::ZeroLength`], [`Error::InvalidParameter`] (σ not finite and
/// positive), [`Error::ZeroFactor`].
///
/// ```
/// use lifted_prbs::{GaussianOptions, gaussian_white};
/// let w = gaussian_white(6, &GaussianOptions { std: 2.0, hold: 3, seed: 7 })?;
/// assert_eq!(w[0], w[2]);
/// assert_ne!(w[2], w[3]);
/// # Ok::<(), lifted_prbs::Error>(())
/// ```
pub fn gaussian_white(len: usize, options: &GaussianOptions) -> Result<Vec<f64>> {
    check_len(len)?;
    check_positive("standard deviation σ", options.std)?;
    check_factor("hold n_r", options.hold)?;
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    let mut out = Vec::with_capacity(len);
    while out.len() < len {
        let z: f64 = rng.sample(StandardNormal);
        let take = (len - out.len()).min(options.hold);
        out.extend(std::iter::repeat_n(options.std * z, take));
    }
    Ok(out)
}

/// Options of a periodic multisine
/// `u(k) = c Σ_{j=1}^{K} cos(2π h_j k / P + φ_j)`, harmonics `h_j = first … last`,
/// Schroeder phases `φ_j = −π j (j − 1) / K` (low crest factor), and
/// `c = a √(2/K)` so that the RMS value is `a`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MultisineOptions {
    /// RMS value `a > 0` of the signal. Default 1.0.
    pub amplitude: f64,
    /// Period `P` in samples. Default 1024.
    pub period: usize,
    /// First excited harmonic (≥ 1). Default 1.
    pub first_harmonic: usize,
    /// Last excited harmonic (`< P/2`); `None` (default) means `⌈P/2⌉ − 1`.
    pub last_harmonic: Option<usize>,
}

impl Default for MultisineOptions {
    fn default() -> Self {
        Self {
            amplitude: 1.0,
            period: 1024,
            first_harmonic: 1,
            last_harmonic: None,
        }
    }
}

/// Schroeder-phased multisine of `len` samples (periodic with period `P`).
/// O(len · K) for `K` harmonics (one period is computed, then repeated).
///
/// # Errors
/// [`Error::ZeroLength`], [`Error::InvalidAmplitude`], [`Error::InvalidHarmonics`].
pub fn multisine(len: usize, options: &MultisineOptions) -> Result<Vec<f64>> {
    check_len(len)?;
    check_amplitude(options.amplitude)?;
    let p = options.period;
    let first = options.first_harmonic;
    let last = options
        .last_harmonic
        .unwrap_or(p.div_ceil(2).saturating_sub(1));
    if first == 0 || last < first || 2 * last >= p {
        return Err(Error::InvalidHarmonics {
            first,
            last,
            period: p,
        });
    }
    check_work((last - first + 1) as u128, len, p)?;
    let harmonics: Vec<usize> = (first..=last).collect();
    Ok(schroeder(len, options.amplitude, p, &harmonics))
}

/// Schroeder-phased multisine of `len` samples on an explicit set of
/// harmonics `h_1 < … < h_K` of the period `P`, RMS value `amplitude`:
/// `u(k) = a √(2/K) Σ_j cos(2π h_j k / P − π j (j − 1) / K)`. Multisine
/// channels on disjoint harmonic sets (e.g. the "zippered" sets
/// `{first + l, first + l + m, …}` of channel `l` out of `m`) are orthogonal
/// over every whole period: their cross-correlation is zero at every lag.
/// With `first..=last` it is [`multisine`]. O(len · K) (one period computed,
/// then repeated).
///
/// # Errors
/// [`Error::ZeroLength`], [`Error::InvalidAmplitude`],
/// [`Error::InvalidHarmonics`] (empty set, not strictly increasing, a
/// harmonic 0 or at or above `P/2`).
///
/// ```
/// use lifted_prbs::multisine_harmonics;
/// let a = multisine_harmonics(64, 1.0, 64, &[1, 3, 5])?;
/// let b = multisine_harmonics(64, 1.0, 64, &[2, 4, 6])?;
/// let cross: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
/// assert!(cross.abs() < 1e-12);
/// # Ok::<(), lifted_prbs::Error>(())
/// ```
pub fn multisine_harmonics(
    len: usize,
    amplitude: f64,
    period: usize,
    harmonics: &[usize],
) -> Result<Vec<f64>> {
    check_len(len)?;
    check_amplitude(amplitude)?;
    let first = harmonics.first().copied().unwrap_or(0);
    let last = harmonics.last().copied().unwrap_or(0);
    if harmonics.is_empty()
        || first == 0
        || 2 * last >= period
        || harmonics.windows(2).any(|w| w[1] <= w[0])
    {
        return Err(Error::InvalidHarmonics {
            first,
            last,
            period,
        });
    }
    check_work(harmonics.len() as u128, len, period)?;
    Ok(schroeder(len, amplitude, period, harmonics))
}

/// [`Error::TooLong`] for more than [`crate::MAX_SIGNAL_ENTRIES`] samples,
/// [`Error::TooManyHarmonics`] when `harmonics` × the computed samples
/// (min(P, len)) exceed 16 × that limit: checked before anything is
/// allocated.
fn check_work(harmonics: u128, len: usize, period: usize) -> Result<()> {
    let max = crate::MAX_SIGNAL_ENTRIES;
    if len as u128 > max {
        return Err(Error::TooLong {
            samples: len as u128,
            max,
        });
    }
    let samples = period.min(len) as u128;
    let work = harmonics.saturating_mul(samples);
    if work > 16 * max {
        return Err(Error::TooManyHarmonics {
            harmonics,
            samples,
            work,
            max: 16 * max,
        });
    }
    Ok(())
}

/// The multisine of [`multisine_harmonics`] on validated harmonics.
fn schroeder(len: usize, amplitude: f64, p: usize, harmonics: &[usize]) -> Vec<f64> {
    let k = harmonics.len() as f64;
    let c = amplitude * (2.0 / k).sqrt();
    let pi = std::f64::consts::PI;
    // One period, or the whole signal when it is shorter.
    let one: Vec<f64> = (0..p.min(len))
        .map(|t| {
            harmonics
                .iter()
                .enumerate()
                .map(|(j, &h)| {
                    let j = (j + 1) as f64;
                    let phase = -pi * j * (j - 1.0) / k;
                    // Reduce h·t mod P first so the argument stays exact.
                    let ht = ((h as u128 * t as u128) % p as u128) as f64;
                    (2.0 * pi * ht / p as f64 + phase).cos()
                })
                .sum::<f64>()
                * c
        })
        .collect();
    (0..len).map(|t| one[t % p]).collect()
}

#[cfg(test)]
mod limits {
    use super::*;

    #[test]
    fn huge_periods_are_errors_not_aborts() {
        let o = MultisineOptions {
            period: 1 << 40,
            ..Default::default()
        };
        assert!(matches!(
            multisine(100, &o),
            Err(Error::TooManyHarmonics { .. })
        ));
        // A short signal of a long period computes only its own samples.
        let h = multisine_harmonics(100, 1.0, 1 << 40, &[1, 2, 3]).unwrap();
        assert_eq!(h.len(), 100);
        assert!(matches!(
            multisine_harmonics(1 << 30, 1.0, 64, &[1]),
            Err(Error::TooLong { .. })
        ));
    }
}

#[cfg(test)]
mod unit {
    use super::*;

    #[test]
    fn gbn_with_probability_one_alternates() {
        let x = generalized_binary_noise(
            10,
            &GbnOptions {
                switch_probability: 1.0,
                ..Default::default()
            },
        )
        .unwrap();
        assert!(x.windows(2).all(|w| w[0] == -w[1]));
    }
}

//! Empirical frequency response from input–output data by Welch's
//! averaged, windowed periodograms (the non-parametric estimate a model is
//! held against on a Bode plot).
//!
//! # Method
//!
//! The record (N samples, m inputs, p outputs, period T) less its means is
//! cut into K segments of L samples (L a power of two) overlapping by L/2,
//! each weighted by the Hann window w_t = ½(1 − cos(2πt/L)) (Welch 1967).
//! With U_s(ω), Y_s(ω) the DFTs of segment s at the bin frequencies
//! ω_k = 2πk/(L T), k = 1 … L/2, the cross-spectra are averaged,
//!
//! ```text
//! Φ̂_u(ω)  = Σ_s U_s(ω) U_s(ω)ᴴ   (m × m),
//! Φ̂_yu(ω) = Σ_s Y_s(ω) U_s(ω)ᴴ   (p × m),
//! ```
//!
//! and the frequency response is their ratio (Ljung 1999, *System
//! Identification*, 2nd ed., §6.4, the spectral-analysis estimate
//! Ĝ = Φ̂_yu / Φ̂_u; the MIMO form right-multiplies by Φ̂_u⁻¹):
//!
//! ```text
//! Ĝ(e^{jωT}) = Φ̂_yu(ω) Φ̂_u(ω)⁻¹.
//! ```
//!
//! The common window and DFT scaling cancel in the ratio. The estimate is
//! consistent for open-loop data with noise independent of the input; its
//! variance falls as 1/K and its frequency resolution is about 4π/(L T)
//! (the Hann main lobe), so L trades resolution for variance. At a bin
//! where Φ̂_u is singular (an input without power there; fewer segments
//! than inputs) the estimate is NaN.
//!
//! Cost: O(N (m + p) log L) for the FFTs (radix 2) and O(N/L · L (m + p) m)
//! for the averages; memory O(L (m + p)).

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::{Error, Result};

/// Options of [`welch`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SpectralOptions {
    /// Segment length L, a power of two ≥ 8; 0 (the default) chooses the
    /// largest power of two ≤ N/8 (at least 8 segments with the 50 %
    /// overlap), between 16 and 1024.
    pub segment: usize,
}

/// An empirical frequency response: Ĝ at each frequency.
#[derive(Debug, Clone, PartialEq)]
pub struct FrequencyResponse {
    /// Frequencies ω_k in rad/s, increasing (k = 1 … L/2: up to Nyquist π/T).
    pub omega: Vec<f64>,
    /// Ĝ(e^{jω_k T}), p × m per frequency (NaN where Φ̂_u is singular).
    pub response: Vec<DMatrix<Complex64>>,
    /// Segment length L used.
    pub segment: usize,
    /// Number of segments K averaged.
    pub segments: usize,
}

impl FrequencyResponse {
    /// |Ĝ_ij| at every frequency.
    pub fn magnitude(&self, i: usize, j: usize) -> Vec<f64> {
        self.response.iter().map(|g| g[(i, j)].norm()).collect()
    }

    /// arg Ĝ_ij in degrees, unwrapped along the frequencies (jumps of more
    /// than 180° between neighbours removed).
    pub fn phase_deg(&self, i: usize, j: usize) -> Vec<f64> {
        let mut out: Vec<f64> = Vec::with_capacity(self.response.len());
        for g in &self.response {
            let mut d = g[(i, j)].arg().to_degrees();
            if let Some(&prev) = out.iter().rev().find(|v| v.is_finite()) {
                while d - prev > 180.0 {
                    d -= 360.0;
                }
                while d - prev < -180.0 {
                    d += 360.0;
                }
            }
            out.push(d);
        }
        out
    }
}

/// The segment length of `opts` for `n` samples.
fn segment_length(n: usize, opts: &SpectralOptions) -> Result<usize> {
    let l = if opts.segment == 0 {
        let mut l = 16usize;
        while l * 2 <= (n / 8).min(1024) {
            l *= 2;
        }
        l
    } else {
        opts.segment
    };
    if l < 8 || !l.is_power_of_two() {
        return Err(Error::InvalidArgument {
            what: "segment",
            reason: format!("the segment length must be a power of two of at least 8, got {l}"),
        });
    }
    if n < l {
        return Err(Error::InvalidArgument {
            what: "u, y",
            reason: format!("{n} samples are fewer than one segment of {l}"),
        });
    }
    Ok(l)
}

/// In-place radix-2 decimation-in-time FFT, X_k = Σ_t x_t e^{−2πjkt/L}
/// (L = `x.len()`, a power of two).
fn fft(x: &mut [Complex64]) {
    let n = x.len();
    let mut j = 0usize;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            x.swap(i, j);
        }
    }
    let mut len = 2;
    while len <= n {
        let step = -2.0 * std::f64::consts::PI / len as f64;
        for start in (0..n).step_by(len) {
            for k in 0..len / 2 {
                let w = Complex64::from_polar(1.0, step * k as f64);
                let a = x[start + k];
                let b = x[start + k + len / 2] * w;
                x[start + k] = a + b;
                x[start + k + len / 2] = a - b;
            }
        }
        len <<= 1;
    }
}

/// Welch's estimate of the frequency response of the system from `u`
/// (N × m) to `y` (N × p), one row per sample, sampled every `ts` seconds
/// (see the module documentation). The record's means are removed first.
///
/// Errors: [`Error::DimensionMismatch`] (row counts differ, no input or
/// output), [`Error::NonFiniteScalar`] (a NaN or infinite sample, a bad
/// `ts`), [`Error::InvalidArgument`] (a segment length that is not a
/// power of two ≥ 8, or a record shorter than one segment).
///
/// # Example
///
/// ```
/// use lifted_lti::spectral::{SpectralOptions, welch};
/// use nalgebra::DMatrix;
///
/// # fn main() -> Result<(), lifted_lti::Error> {
/// // y_k = 0.5 u_{k-1}: |G| = 0.5 at every frequency.
/// let u = DMatrix::from_fn(4096, 1, |k, _| ((k * 7919 % 1013) as f64 / 506.0) - 1.0);
/// let y = DMatrix::from_fn(4096, 1, |k, _| if k == 0 { 0.0 } else { 0.5 * u[(k - 1, 0)] });
/// let g = welch(&u, &y, 1.0, &SpectralOptions::default())?;
/// assert!(g.magnitude(0, 0).iter().all(|m| (m - 0.5).abs() < 0.05));
/// # Ok(())
/// # }
/// ```
pub fn welch(
    u: &DMatrix<f64>,
    y: &DMatrix<f64>,
    ts: f64,
    opts: &SpectralOptions,
) -> Result<FrequencyResponse> {
    let (n, m, p) = (u.nrows(), u.ncols(), y.ncols());
    if y.nrows() != n || m == 0 || p == 0 {
        return Err(Error::DimensionMismatch {
            what: "u, y",
            expected: "the same number of rows and at least one input and one output".into(),
            got: format!("u {}×{m}, y {}×{p}", n, y.nrows()),
        });
    }
    if !(ts.is_finite() && ts > 0.0) {
        return Err(Error::NonFiniteScalar {
            what: "ts",
            value: ts,
        });
    }
    if let Some(bad) = u.iter().chain(y.iter()).find(|v| !v.is_finite()) {
        return Err(Error::NonFiniteScalar {
            what: "a sample of u or y",
            value: *bad,
        });
    }
    let l = segment_length(n, opts)?;
    let half = l / 2;
    let window: Vec<f64> = (0..l)
        .map(|t| 0.5 * (1.0 - (2.0 * std::f64::consts::PI * t as f64 / l as f64).cos()))
        .collect();
    let mean = |x: &DMatrix<f64>, c: usize| x.column(c).iter().sum::<f64>() / n as f64;
    let means: Vec<f64> = (0..m)
        .map(|c| mean(u, c))
        .chain((0..p).map(|c| mean(y, c)))
        .collect();
    let channels = m + p;
    // Σ_s Z_s Z_sᴴ restricted to the (u, u) and (y, u) blocks, per bin.
    let mut phi_u = vec![DMatrix::<Complex64>::zeros(m, m); half];
    let mut phi_yu = vec![DMatrix::<Complex64>::zeros(p, m); half];
    let mut spectra = vec![vec![Complex64::new(0.0, 0.0); l]; channels];
    let mut segments = 0usize;
    let mut start = 0usize;
    while start + l <= n {
        for (c, spec) in spectra.iter_mut().enumerate() {
            for (t, z) in spec.iter_mut().enumerate() {
                let v = if c < m {
                    u[(start + t, c)]
                } else {
                    y[(start + t, c - m)]
                };
                *z = Complex64::new((v - means[c]) * window[t], 0.0);
            }
            fft(spec);
        }
        for k in 0..half {
            let bin = k + 1;
            for a in 0..m {
                for b in 0..m {
                    phi_u[k][(a, b)] += spectra[a][bin] * spectra[b][bin].conj();
                }
            }
            for i in 0..p {
                for b in 0..m {
                    phi_yu[k][(i, b)] += spectra[m + i][bin] * spectra[b][bin].conj();
                }
            }
        }
        segments += 1;
        start += half;
    }
    let nan = DMatrix::from_element(p, m, Complex64::new(f64::NAN, f64::NAN));
    let response = phi_u
        .into_iter()
        .zip(phi_yu)
        .map(|(su, syu)| {
            // A bin without input power gives no estimate.
            let scale = (0..m).map(|a| su[(a, a)].re).fold(0.0, f64::max);
            if scale <= 0.0 || scale.is_nan() {
                return nan.clone();
            }
            match su.try_inverse() {
                Some(inv) if inv.iter().all(|z| z.re.is_finite() && z.im.is_finite()) => syu * inv,
                _ => nan.clone(),
            }
        })
        .collect();
    let omega = (1..=half)
        .map(|k| 2.0 * std::f64::consts::PI * k as f64 / (l as f64 * ts))
        .collect();
    Ok(FrequencyResponse {
        omega,
        response,
        segment: l,
        segments,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::StateSpace;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn white(n: usize, m: usize, seed: u64) -> DMatrix<f64> {
        let mut r = ChaCha8Rng::seed_from_u64(seed);
        DMatrix::from_fn(n, m, |_, _| r.random_range(-1.0..1.0))
    }

    #[test]
    fn the_fft_matches_the_dft() {
        let x: Vec<Complex64> = (0..16)
            .map(|t| Complex64::new((t as f64 * 0.7).sin(), (t as f64 * 0.3).cos()))
            .collect();
        let mut f = x.clone();
        fft(&mut f);
        for (k, fk) in f.iter().enumerate() {
            let d: Complex64 = x
                .iter()
                .enumerate()
                .map(|(t, v)| {
                    v * Complex64::from_polar(
                        1.0,
                        -2.0 * std::f64::consts::PI * (k * t) as f64 / 16.0,
                    )
                })
                .sum();
            // 16 terms of unit size: rounding of order 16 ε.
            assert!((fk - d).norm() < 1e-12, "bin {k}: {fk} vs {d}");
        }
    }

    /// A 2 × 2 discrete system with distinct dynamics per channel, driven
    /// by two independent white inputs, plus white output noise: the Welch
    /// estimate follows the true response.
    #[test]
    fn welch_recovers_a_known_mimo_response() {
        let g = StateSpace::new(
            DMatrix::from_row_slice(2, 2, &[0.8, 0.0, 0.0, -0.5]),
            DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0]),
            DMatrix::from_row_slice(2, 2, &[0.4, 0.0, 0.3, 0.6]),
            DMatrix::from_row_slice(2, 2, &[0.0, 0.1, 0.0, 0.0]),
            Some(0.1),
        )
        .unwrap();
        let n = 1 << 16;
        let u = white(n, 2, 1);
        let mut y = g.lsim(&u, None, None).unwrap().y;
        y += white(n, 2, 2) * 0.05;
        let est = welch(&u, &y, 0.1, &SpectralOptions { segment: 256 }).unwrap();
        assert_eq!(est.segment, 256);
        assert_eq!(est.segments, 2 * n / 256 - 1);
        assert_eq!(est.omega.len(), 128);
        assert!((est.omega[127] - std::f64::consts::PI / 0.1).abs() < 1e-9);
        let truth = g.freqresp(&est.omega).unwrap();
        let mut worst = 0.0f64;
        for (k, (e, t)) in est.response.iter().zip(&truth).enumerate() {
            for i in 0..2 {
                for j in 0..2 {
                    // Relative to the channel's largest gain (0.4/(1−0.8) = 2):
                    // K = 511 segments of noise 0.05 against unit inputs give a
                    // standard error of a few 1e-3; the Hann window's bias at
                    // the pole 0.8 (half-power width 0.22 rad/sample against a
                    // resolution of 4π/256 = 0.05) stays below 2 %.
                    let err = (e[(i, j)] - t[(i, j)]).norm() / 2.0;
                    assert!(
                        err < 0.03,
                        "bin {k}, G[{i},{j}]: {} vs {}",
                        e[(i, j)],
                        t[(i, j)]
                    );
                    worst = worst.max(err);
                }
            }
        }
        assert!(worst > 0.0);
    }

    #[test]
    fn welch_names_bad_input() {
        let u = white(100, 1, 3);
        let y = white(100, 1, 4);
        assert!(matches!(
            welch(&u, &white(99, 1, 4), 1.0, &SpectralOptions::default()),
            Err(Error::DimensionMismatch { .. })
        ));
        assert!(matches!(
            welch(&u, &y, 0.0, &SpectralOptions::default()),
            Err(Error::NonFiniteScalar { what: "ts", .. })
        ));
        let mut bad = y.clone();
        bad[(5, 0)] = f64::NAN;
        assert!(matches!(
            welch(&u, &bad, 1.0, &SpectralOptions::default()),
            Err(Error::NonFiniteScalar { .. })
        ));
        assert!(matches!(
            welch(&u, &y, 1.0, &SpectralOptions { segment: 48 }),
            Err(Error::InvalidArgument {
                what: "segment",
                ..
            })
        ));
        assert!(matches!(
            welch(&u, &y, 1.0, &SpectralOptions { segment: 128 }),
            Err(Error::InvalidArgument { what: "u, y", .. })
        ));
        // An input without power: no estimate (NaN), not an error.
        let zero = DMatrix::zeros(100, 1);
        let g = welch(&zero, &y, 1.0, &SpectralOptions { segment: 16 }).unwrap();
        assert!(g.response.iter().all(|r| r[(0, 0)].re.is_nan()));
    }
}

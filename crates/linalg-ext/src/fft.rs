//! Complex FFTs of `f64` data: one process-wide rustfft planner behind
//! non-generic calls.
//!
//! rustfft's planner is generic over the float type, so every crate that
//! names `FftPlanner<f64>` compiles its whole family of algorithms again
//! (about 1 250 functions, twice with the crate's unit tests: when
//! `lifted-prbs` and `lifted-subspace` each held a planner, two thirds of
//! the first's machine code and a third of the second's). Here they are
//! compiled once; crates above call [`Transforms`] and never name rustfft.
//!
//! Plans (twiddle tables) are cached by the planner, so transforms of a
//! length already seen skip planning, which costs about as much as a few
//! runs of the transform. Transforms are unnormalised (the inverse of the
//! forward is N times the input), as rustfft's: O(N log N) for every N,
//! fastest for [`fast_length`]s.

use std::sync::{Arc, LazyLock, Mutex, PoisonError};

use num_complex::Complex;
use rustfft::{Fft, FftPlanner};

use crate::error::{Error, Result};

/// The process's planner: its plan cache is shared by every thread (the
/// lock is held only while planning).
static PLANNER: LazyLock<Mutex<FftPlanner<f64>>> = LazyLock::new(|| Mutex::new(FftPlanner::new()));

/// A forward and an inverse transform of one length, with their scratch.
pub struct Transforms {
    forward: Arc<dyn Fft<f64>>,
    inverse: Arc<dyn Fft<f64>>,
    scratch: Vec<Complex<f64>>,
}

impl Transforms {
    /// The transforms of length `len` (from the planner's cache when that
    /// length was planned before). O(len log len) the first time, O(1)
    /// after, plus the scratch.
    pub fn new(len: usize) -> Self {
        let (forward, inverse) = {
            let mut planner = PLANNER.lock().unwrap_or_else(PoisonError::into_inner);
            (planner.plan_fft_forward(len), planner.plan_fft_inverse(len))
        };
        let scratch = vec![
            Complex::new(0.0, 0.0);
            forward
                .get_inplace_scratch_len()
                .max(inverse.get_inplace_scratch_len())
        ];
        Self {
            forward,
            inverse,
            scratch,
        }
    }

    /// The transform length.
    pub fn len(&self) -> usize {
        self.forward.len()
    }

    /// Whether the length is zero.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// X_k = Σ_t x_t e^{−2πi kt/N} in place; `data` holds exactly
    /// `len()` values ([`Error::DimensionMismatch`] otherwise).
    pub fn forward(&mut self, data: &mut [Complex<f64>]) -> Result<()> {
        self.check(data)?;
        self.forward.process_with_scratch(data, &mut self.scratch);
        Ok(())
    }

    /// x_t = Σ_k X_k e^{+2πi kt/N} in place (not divided by N); `data`
    /// holds exactly `len()` values.
    pub fn inverse(&mut self, data: &mut [Complex<f64>]) -> Result<()> {
        self.check(data)?;
        self.inverse.process_with_scratch(data, &mut self.scratch);
        Ok(())
    }

    fn check(&self, data: &[Complex<f64>]) -> Result<()> {
        if data.len() == self.len() {
            Ok(())
        } else {
            Err(Error::DimensionMismatch {
                what: "FFT data",
                expected: format!("{} values", self.len()),
                got: format!("{} values", data.len()),
            })
        }
    }
}

/// The least 2^a 3^b ≥ `min` (rustfft's fastest radices; 104 976 for
/// 1e5 + 4096 instead of 131 072). 1 for `min` ≤ 1.
pub fn fast_length(min: usize) -> usize {
    let mut best = min.next_power_of_two();
    let mut three = 1usize;
    while three < best {
        let mut len = three;
        while len < min {
            len *= 2;
        }
        best = best.min(len);
        three *= 3;
    }
    best
}

/// The spectra at bin `k` of two real records x and y transformed together
/// as z = x + i y (one complex transform for two real ones):
/// X_k = (Z_k + conj Z_{N−k})/2, Y_k = (Z_k − conj Z_{N−k})/(2i), N =
/// `z.len()`. O(1); `k` < N (indexing past `z` panics, as a slice's).
#[inline]
pub fn split_packed(z: &[Complex<f64>], k: usize) -> (Complex<f64>, Complex<f64>) {
    let n = z.len();
    let (p, q) = (z[k], z[(n - k) % n]);
    (
        Complex::new(0.5 * (p.re + q.re), 0.5 * (p.im - q.im)),
        Complex::new(0.5 * (p.im + q.im), 0.5 * (q.re - p.re)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_packed_transform_splits_into_the_two_real_ones() {
        let n = 12;
        let x: Vec<f64> = (0..n).map(|t| (t as f64 * 0.7).sin()).collect();
        let y: Vec<f64> = (0..n).map(|t| (t as f64 * 1.3).cos() - 0.2).collect();
        let mut t = Transforms::new(n);
        let spectrum = |t: &mut Transforms, v: &[f64]| {
            let mut c: Vec<Complex<f64>> = v.iter().map(|&a| Complex::new(a, 0.0)).collect();
            t.forward(&mut c).unwrap();
            c
        };
        let (fx, fy) = (spectrum(&mut t, &x), spectrum(&mut t, &y));
        let mut z: Vec<Complex<f64>> = x
            .iter()
            .zip(&y)
            .map(|(&a, &b)| Complex::new(a, b))
            .collect();
        t.forward(&mut z).unwrap();
        for k in 0..n {
            let (a, b) = split_packed(&z, k);
            assert!(
                (a - fx[k]).norm() < 1e-12 && (b - fy[k]).norm() < 1e-12,
                "bin {k}"
            );
        }
    }

    #[test]
    fn forward_then_inverse_is_n_times_the_input() {
        for n in [1, 2, 7, 12, 97, 108] {
            let x: Vec<Complex<f64>> = (0..n)
                .map(|t| Complex::new((t as f64 * 0.7).sin(), (t as f64 * 1.3).cos()))
                .collect();
            let mut t = Transforms::new(n);
            assert_eq!(t.len(), n);
            let mut z = x.clone();
            t.forward(&mut z).unwrap();
            t.inverse(&mut z).unwrap();
            for (a, b) in z.iter().zip(&x) {
                assert!((a / n as f64 - b).norm() < 1e-12);
            }
        }
    }

    #[test]
    fn forward_is_the_dft() {
        let n = 12;
        let x: Vec<Complex<f64>> = (0..n).map(|t| Complex::new(t as f64, 0.5)).collect();
        let mut z = x.clone();
        Transforms::new(n).forward(&mut z).unwrap();
        assert!(Transforms::new(n).forward(&mut z[1..]).is_err());
        for (k, zk) in z.iter().enumerate() {
            let dft: Complex<f64> = x
                .iter()
                .enumerate()
                .map(|(t, xt)| {
                    let w = -2.0 * std::f64::consts::PI * (k * t) as f64 / n as f64;
                    xt * Complex::new(w.cos(), w.sin())
                })
                .sum();
            assert!((zk - dft).norm() < 1e-10);
        }
    }

    #[test]
    fn fast_lengths_are_the_least_products_of_two_and_three() {
        assert_eq!(fast_length(0), 1);
        assert_eq!(fast_length(1), 1);
        assert_eq!(fast_length(5), 6);
        assert_eq!(fast_length(100), 108);
        assert_eq!(fast_length(104_096), 104_976);
        assert_eq!(fast_length(131_072), 131_072);
        // 2^a 3^b, and no such number between `min` and it.
        let smooth = |mut k: usize| {
            while k.is_multiple_of(2) {
                k /= 2;
            }
            while k.is_multiple_of(3) {
                k /= 3;
            }
            k == 1
        };
        for min in 1..2000 {
            let m = fast_length(min);
            assert!(m >= min && smooth(m), "{min}: {m}");
            assert!(!(min..m).any(smooth), "{min}: {m}");
        }
    }
}

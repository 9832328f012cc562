//! Periodic (circular) auto- and cross-correlation of finite records,
//! `R_xy(τ) = (1/c) Σ_{k<N} x((k+τ) mod N) · y(k)`, `τ = 0 … N−1`
//! (eqs. II-5, II-9, III-22 with the normalisation chosen by [`Normalization`]).

use lifted_linalg::dot;
use lifted_linalg::fft::Transforms;
use num_complex::Complex;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, check_finite, check_positive};

/// Record length from which [`CorrelationMethod::Auto`] switches to the FFT.
pub const FFT_THRESHOLD: usize = 128;

/// Scale `1/c` applied to the circular sums.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub enum Normalization {
    /// `c = N` (the record length): the mean of the lagged products. Default.
    #[default]
    Length,
    /// `c = 1`: the raw sums.
    Sum,
    /// `c = value`, e.g. `2m` for the papers' normalisation (erratum Z-2).
    Divisor(f64),
}

/// Algorithm for the circular sums.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum CorrelationMethod {
    /// Direct below [`FFT_THRESHOLD`] samples, FFT from there on. Default.
    #[default]
    Auto,
    /// Direct double sum, O(N²), exact for integer-valued data.
    Direct,
    /// `R = IFFT(X · conj(Y)) / N` by FFT ([`lifted_linalg::fft`]), O(N log N), error ~ `ε ‖x‖ ‖y‖ log N`.
    Fft,
}

/// Periodic autocorrelation `R_xx(τ)`, `τ = 0 … N−1` (negative lags wrap to the end).
/// O(N²) direct or O(N log N) by FFT (see [`CorrelationMethod::Auto`]).
///
/// # Errors
/// [`Error::EmptySignal`], [`Error::NonFinite`], [`Error::InvalidParameter`] (divisor).
pub fn periodic_autocorrelation(x: &[f64], norm: Normalization) -> Result<Vec<f64>> {
    periodic_cross_correlation_with(x, x, norm, CorrelationMethod::Auto)
}

/// Periodic cross-correlation `R_xy(τ) = (1/c) Σ_k x(k+τ) y(k)`, automatic method.
///
/// # Errors
/// [`Error::EmptySignal`], [`Error::LengthMismatch`], [`Error::NonFinite`],
/// [`Error::InvalidParameter`] (divisor).
pub fn periodic_cross_correlation(x: &[f64], y: &[f64], norm: Normalization) -> Result<Vec<f64>> {
    periodic_cross_correlation_with(x, y, norm, CorrelationMethod::Auto)
}

/// Periodic cross-correlation with an explicit algorithm.
///
/// # Errors
/// As [`periodic_cross_correlation`].
pub fn periodic_cross_correlation_with(
    x: &[f64],
    y: &[f64],
    norm: Normalization,
    method: CorrelationMethod,
) -> Result<Vec<f64>> {
    if x.is_empty() {
        return Err(Error::EmptySignal { what: "x" });
    }
    if y.is_empty() {
        return Err(Error::EmptySignal { what: "y" });
    }
    if x.len() != y.len() {
        return Err(Error::LengthMismatch {
            left: x.len(),
            right: y.len(),
        });
    }
    check_finite("x", x)?;
    check_finite("y", y)?;
    let n = x.len();
    let scale = match norm {
        Normalization::Length => 1.0 / n as f64,
        Normalization::Sum => 1.0,
        Normalization::Divisor(c) => {
            check_positive("correlation divisor", c)?;
            1.0 / c
        }
    };
    let use_fft = match method {
        CorrelationMethod::Auto => n >= FFT_THRESHOLD,
        CorrelationMethod::Direct => false,
        CorrelationMethod::Fft => true,
    };
    let mut r = if use_fft {
        fft_sums(x, y)?
    } else {
        direct_sums(x, y)
    };
    for v in &mut r {
        *v *= scale;
    }
    Ok(r)
}

fn direct_sums(x: &[f64], y: &[f64]) -> Vec<f64> {
    let n = x.len();
    (0..n)
        .map(|tau| {
            // Σ_k x(k+τ) y(k), split at the wrap to avoid a modulo per term.
            dot(&x[tau..], &y[..n - tau]) + dot(&x[..tau], &y[n - tau..])
        })
        .collect()
}

/// Circular sums by one complex FFT of z = x + i·y (both records are real):
/// X_k = (Z_k + conj Z_{N−k})/2, Y_k = (Z_k − conj Z_{N−k})/(2i), then
/// R = IFFT(X · conj Y)/N. Two transforms of length N instead of three.
fn fft_sums(x: &[f64], y: &[f64]) -> Result<Vec<f64>> {
    let n = x.len();
    let mut fft = Transforms::new(n);
    let mut z: Vec<Complex<f64>> = x.iter().zip(y).map(|(&a, &b)| Complex::new(a, b)).collect();
    fft.forward(&mut z)?;
    let mut prod = vec![Complex::new(0.0, 0.0); n];
    for (k, pk) in prod.iter_mut().enumerate() {
        let (xk, yk) = lifted_linalg::fft::split_packed(&z, k);
        *pk = xk * yk.conj();
    }
    fft.inverse(&mut prod)?;
    // The transforms do not normalise: divide by N.
    let inv_n = 1.0 / n as f64;
    Ok(prod.iter().map(|c| c.re * inv_n).collect())
}

#[cfg(test)]
mod unit {
    use super::*;

    #[test]
    fn direct_small_example() {
        let x = [1.0, 2.0, 3.0];
        let y = [1.0, 0.0, 0.0];
        // R(τ) = x(τ) y(0).
        let r =
            periodic_cross_correlation_with(&x, &y, Normalization::Sum, CorrelationMethod::Direct)
                .unwrap();
        assert_eq!(r, vec![1.0, 2.0, 3.0]);
        let f = periodic_cross_correlation_with(&x, &y, Normalization::Sum, CorrelationMethod::Fft)
            .unwrap();
        for (a, b) in r.iter().zip(&f) {
            assert!((a - b).abs() < 1e-12);
        }
    }

    #[test]
    fn fft_matches_direct_on_random_lengths() {
        // Lengths with odd, prime and power-of-two sizes, both paths.
        for n in [1usize, 2, 3, 7, 64, 127, 128, 1000, 1023] {
            let x: Vec<f64> = (0..n).map(|k| ((k * 37 + 11) % 17) as f64 - 8.0).collect();
            let y: Vec<f64> = (0..n)
                .map(|k| ((k * 13 + 5) % 23) as f64 * 0.5 - 3.0)
                .collect();
            let d = periodic_cross_correlation_with(
                &x,
                &y,
                Normalization::Sum,
                CorrelationMethod::Direct,
            )
            .unwrap();
            let f =
                periodic_cross_correlation_with(&x, &y, Normalization::Sum, CorrelationMethod::Fft)
                    .unwrap();
            let scale: f64 = x.iter().map(|v| v * v).sum::<f64>().sqrt()
                * y.iter().map(|v| v * v).sum::<f64>().sqrt();
            for (a, b) in d.iter().zip(&f) {
                assert!((a - b).abs() <= 1e-12 * scale.max(1.0), "n {n}: {a} vs {b}");
            }
            // Direct sums of integers (halves) are exact: check one lag by hand.
            let tau = n / 3;
            let want: f64 = (0..n).map(|k| x[(k + tau) % n] * y[k]).sum();
            assert_eq!(d[tau], want);
        }
    }
}

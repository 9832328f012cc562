use lifted_prbs::{
    CorrelationMethod, Normalization, RandomBinaryOptions, periodic_autocorrelation,
    periodic_cross_correlation, periodic_cross_correlation_with, random_binary,
};
use proptest::prelude::*;

/// One harness for both algorithms (and Auto) against the same answer.
fn check_all(x: &[f64], y: &[f64]) {
    let d = periodic_cross_correlation_with(x, y, Normalization::Sum, CorrelationMethod::Direct)
        .unwrap();
    let scale = x.iter().map(|v| v.abs()).sum::<f64>() * y.iter().map(|v| v.abs()).sum::<f64>();
    for method in [CorrelationMethod::Fft, CorrelationMethod::Auto] {
        let f = periodic_cross_correlation_with(x, y, Normalization::Sum, method).unwrap();
        for (a, b) in d.iter().zip(&f) {
            // FFT rounding: a few ε per operation times log N, relative to Σ|x|Σ|y|.
            assert!((a - b).abs() <= 1e-13 * scale.max(1.0), "{a} vs {b}");
        }
    }
}

#[test]
fn direct_and_fft_agree() {
    for n in [1, 2, 3, 17, 127, 128, 129, 1000] {
        let x = random_binary(
            n,
            &RandomBinaryOptions {
                seed: 1,
                ..Default::default()
            },
        )
        .unwrap();
        let y: Vec<f64> = (0..n).map(|k| (k as f64 * 0.37).sin()).collect();
        check_all(&x, &y);
    }
}

#[test]
fn normalizations() {
    let x = [1.0, -2.0, 3.0, 0.5];
    let s = periodic_autocorrelation(&x, Normalization::Sum).unwrap();
    let l = periodic_autocorrelation(&x, Normalization::Length).unwrap();
    let d = periodic_autocorrelation(&x, Normalization::Divisor(2.0)).unwrap();
    assert_eq!(s[0], 14.25);
    assert_eq!(l[0], 14.25 / 4.0);
    assert_eq!(d[0], 14.25 / 2.0);
    let c = periodic_cross_correlation(&x, &x, Normalization::Sum).unwrap();
    assert_eq!(c, s);
}

proptest! {
    #[test]
    fn cross_correlation_identities(x in prop::collection::vec(-10.0f64..10.0, 1..300),
                                    shift in 0usize..300) {
        let n = x.len();
        let shift = shift % n;
        // y(k) = x(k − shift)  ⇒  R_xy(τ) = Σ_k x(k+τ) x(k−shift) = R_xx(τ + shift).
        let y: Vec<f64> = (0..n).map(|k| x[(k + n - shift) % n]).collect();
        let rxx = periodic_autocorrelation(&x, Normalization::Sum).unwrap();
        let rxy = periodic_cross_correlation(&x, &y, Normalization::Sum).unwrap();
        let scale = x.iter().map(|v| v * v).sum::<f64>().max(1.0);
        for tau in 0..n {
            prop_assert!((rxy[tau] - rxx[(tau + shift) % n]).abs() <= 1e-11 * scale);
        }
        // Symmetry of the autocorrelation.
        for tau in 1..n {
            prop_assert!((rxx[tau] - rxx[n - tau]).abs() <= 1e-11 * scale);
        }
        check_all(&x, &y);
    }
}

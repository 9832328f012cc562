use lifted_prbs::{
    RandomBinaryOptions, VectorizedOptions, lifted_covariance, random_binary, vectorized_excitation,
};
use nalgebra::DMatrix;

fn sv_ratio(c: &DMatrix<f64>) -> f64 {
    let s = c.clone().singular_values();
    let max = s.max();
    let min = s.min();
    min / max
}

/// Li 2001 §6.3 / spec A3.8: a slow-held input gives a rank-1 lifted covariance
/// (σ_n/σ₁ < 1e-12); independent components give σ_n/σ₁ > 0.8 at N = 5000.
#[test]
fn a3_8_rank() {
    for n in [2, 3, 5] {
        let held = random_binary(
            5000 * n,
            &RandomBinaryOptions {
                amplitude: 1.0,
                hold: n,
                seed: 11,
            },
        )
        .unwrap();
        let c = lifted_covariance(&held, n).unwrap();
        assert!(sv_ratio(&c) < 1e-12, "held n {n}: {}", sv_ratio(&c));

        let v = vectorized_excitation(
            5000,
            &VectorizedOptions {
                factor: n,
                amplitude: 1.0,
                seed: 11,
            },
        )
        .unwrap();
        assert_eq!(v.fast.len(), 5000 * n);
        for k in 0..5000 {
            for i in 0..n {
                assert_eq!(v.fast[n * k + i], v.lifted[(k, i)]);
            }
        }
        let again = vectorized_excitation(
            5000,
            &VectorizedOptions {
                factor: n,
                amplitude: 1.0,
                seed: 11,
            },
        )
        .unwrap();
        assert_eq!(again, v);
        let other = vectorized_excitation(
            5000,
            &VectorizedOptions {
                factor: n,
                amplitude: 1.0,
                seed: 12,
            },
        )
        .unwrap();
        assert_ne!(other, v);
        let c = lifted_covariance(&v.fast, n).unwrap();
        let r = sv_ratio(&c);
        assert!(r > 0.8, "vectorized n {n}: {r}");
    }
}

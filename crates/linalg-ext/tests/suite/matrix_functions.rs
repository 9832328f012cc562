//! expm / logm / rootm: identities and cross-checks between the algorithms.

use lifted_linalg::*;
use nalgebra::DMatrix;

use super::random;

/// Random matrix with spectrum in the right half plane (shifted).
fn right_half(n: usize, seed: u64) -> DMatrix<f64> {
    random(n, n, seed) + DMatrix::identity(n, n) * (1.0 + 0.4 * n as f64)
}

#[test]
fn exp_of_log_is_identity() {
    for (n, seed) in [(1usize, 1u64), (3, 2), (9, 3), (30, 4)] {
        let a = right_half(n, seed);
        let back = expm(&logm(&a).unwrap()).unwrap();
        // 1e-12 relative: the accuracy lti's d2c needs (Part C).
        assert!((&back - &a).norm() <= 1e-12 * a.norm(), "n={n}");
    }
}

#[test]
fn root_agrees_with_exp_of_scaled_log() {
    // Two independent algorithms (Smith's recurrence vs inverse scaling and
    // squaring + Padé 13) for the same principal root.
    for (n, seed) in [(2usize, 5u64), (6, 6), (15, 7)] {
        let a = right_half(n, seed);
        for p in [2u32, 3, 4, 8] {
            let r1 = rootm(&a, p).unwrap();
            let r2 = expm(&(logm(&a).unwrap() / p as f64)).unwrap();
            assert!((&r1 - &r2).norm() <= 1e-12 * r1.norm(), "n={n} p={p}");
        }
    }
}

#[test]
fn lifted_state_matrix_root() {
    // The fast-model extraction use: Ā = A^m of a discrete model; the
    // principal m-th root recovers A when |arg λ(A)| < π/m.
    let a = DMatrix::from_row_slice(3, 3, &[0.9, 0.2, 0.0, -0.2, 0.9, 0.1, 0.0, 0.0, 0.5]);
    for m in [2u32, 3, 5] {
        let mut abar = DMatrix::identity(3, 3);
        for _ in 0..m {
            abar = &abar * &a;
        }
        let r = rootm(&abar, m).unwrap();
        assert!((&r - &a).norm() <= 1e-12, "m={m}");
    }
}

#[test]
fn negative_and_zero_eigenvalues_have_no_principal_branch() {
    // Eigenvalue −2 (on ℝ⁻), eigenvalue 0, and a pair at angle π − 1e-10.
    let neg = DMatrix::from_row_slice(2, 2, &[1.0, 5.0, 0.0, -2.0]);
    let zero = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 3.0]);
    let th = std::f64::consts::PI - 1e-10;
    let near = DMatrix::from_row_slice(2, 2, &[th.cos(), -th.sin(), th.sin(), th.cos()]);
    for a in [neg, zero, near] {
        assert!(matches!(
            logm(&a),
            Err(Error::NoPrincipalBranch { what: "logm", .. })
        ));
        for p in [2, 3] {
            assert!(matches!(
                rootm(&a, p),
                Err(Error::NoPrincipalBranch { what: "rootm", .. })
            ));
        }
    }
}

#[test]
fn log_and_root_of_orthogonal_permutation() {
    // Cyclic 3×3 permutation: eigenvalues 1, e^{±2πi/3} (on the unit
    // circle, off ℝ⁻). Its principal log is real and skew-symmetric.
    let p = DMatrix::from_fn(3, 3, |i, j| if (i + 1) % 3 == j { 1.0 } else { 0.0 });
    let l = logm(&p).unwrap();
    assert!((&l + l.transpose()).norm() <= 1e-13);
    assert!((expm(&l).unwrap() - &p).norm() <= 1e-13);
    let r = rootm(&p, 4).unwrap();
    let r4 = &r * &r * &r * &r;
    assert!((r4 - &p).norm() <= 1e-13);
}

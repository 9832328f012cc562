//! Lyapunov, Sylvester and Riccati equations: property tests on random
//! stable systems (residuals relative to the data; tolerances ∝ n·ε·cond).

use lifted_linalg::*;
use nalgebra::DMatrix;
use proptest::prelude::*;

use super::gaussian;

/// Random Schur-stable A with spectral radius `rho`.
fn discrete_stable(n: usize, seed: u64, rho: f64) -> DMatrix<f64> {
    let a = gaussian(n, n, seed);
    let r = eigenvalues(&a)
        .unwrap()
        .iter()
        .map(|l| l.norm())
        .fold(0.0, f64::max);
    if r == 0.0 { a } else { a * (rho / r) }
}

/// Random Hurwitz A: shift the spectrum left of −margin.
fn continuous_stable(n: usize, seed: u64, margin: f64) -> DMatrix<f64> {
    let a = gaussian(n, n, seed);
    let m = eigenvalues(&a)
        .unwrap()
        .iter()
        .map(|l| l.re)
        .fold(f64::NEG_INFINITY, f64::max);
    a - DMatrix::identity(n, n) * (m + margin)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn lyap_residual(n in 1usize..8, seed in 0u64..1000, margin in 0.1f64..3.0) {
        let a = continuous_stable(n, seed, margin);
        let c = gaussian(2, n, seed + 1);
        let q = c.transpose() * &c;
        let x = lyap(&a, &q).unwrap();
        let res = (&a * &x + &x * a.transpose() + &q).norm();
        let scale = 2.0 * a.norm() * x.norm() + q.norm();
        prop_assert!(res <= 1e-12 * scale, "residual {res:e}, scale {scale:e}");
        // Hurwitz A, Q ⪰ 0 ⇒ X ⪰ 0.
        let min = sym_eig(&x, SortOrder::Ascending).unwrap().values[0];
        prop_assert!(min >= -1e-10 * x.norm());
    }

    #[test]
    fn dlyap_residual(n in 1usize..8, seed in 0u64..1000, rho in 0.05f64..0.98) {
        let a = discrete_stable(n, seed, rho);
        let c = gaussian(2, n, seed + 1);
        let q = c.transpose() * &c;
        let x = dlyap(&a, &q).unwrap();
        let res = (&a * &x * a.transpose() - &x + &q).norm();
        let scale = a.norm() * a.norm() * x.norm() + x.norm() + q.norm();
        prop_assert!(res <= 1e-12 * scale, "residual {res:e}, scale {scale:e}");
        let min = sym_eig(&x, SortOrder::Ascending).unwrap().values[0];
        prop_assert!(min >= -1e-10 * x.norm());
    }

    #[test]
    fn sylvester_residual(m in 1usize..6, n in 1usize..6, seed in 0u64..1000) {
        let a = continuous_stable(m, seed, 0.5);
        let b = continuous_stable(n, seed + 7, 0.5);
        let c = gaussian(m, n, seed + 3);
        let x = sylvester(&a, &b, &c).unwrap();
        let res = (&a * &x + &x * &b - &c).norm();
        let scale = (a.norm() + b.norm()) * x.norm() + c.norm();
        prop_assert!(res <= 1e-12 * scale, "residual {res:e}");
    }

    #[test]
    fn dare_residual_and_stability(n in 1usize..7, m in 1usize..3, seed in 0u64..1000, rho in 0.3f64..1.6) {
        // Possibly open-loop unstable A; random B is generically stabilizing,
        // Q = I ≻ 0 makes (Q, A) detectable.
        let a = discrete_stable(n, seed, rho);
        let b = gaussian(n, m, seed + 11);
        let q = DMatrix::identity(n, n);
        let r = DMatrix::identity(m, m) * 0.5;
        let sol = dare(&a, &b, &q, &r, None).unwrap();
        let x = &sol.x;
        let btx = b.transpose() * x;
        let k = solve(&(&r + &btx * &b), &(&btx * &a)).unwrap();
        let res = (a.transpose() * x * &a - (a.transpose() * x * &b) * &k + &q - x).norm();
        prop_assert!(res <= 1e-9 * x.norm().max(1.0), "residual {res:e}");
        prop_assert!((&k - &sol.k).norm() <= 1e-8 * k.norm().max(1.0));
        prop_assert!(sol.closed_loop_poles.iter().all(|p| p.norm() < 1.0));
        let min = sym_eig(x, SortOrder::Ascending).unwrap().values[0];
        prop_assert!(min > 0.0, "X must be positive definite for Q ≻ 0");
    }
}

#[test]
fn dare_with_cross_term_matches_completed_square() {
    // With S, the DARE equals the S-free one for A_s = A − BR⁻¹Sᵀ,
    // Q_s = Q − SR⁻¹Sᵀ; the gains differ by R⁻¹Sᵀ.
    let a = discrete_stable(4, 3, 1.2);
    let b = gaussian(4, 2, 4);
    let q = DMatrix::identity(4, 4) * 2.0;
    let r = DMatrix::identity(2, 2);
    let s = gaussian(4, 2, 5) * 0.2;
    let with = dare(&a, &b, &q, &r, Some(&s)).unwrap();
    let a_s = &a - &b * s.transpose();
    let q_s = &q - &s * s.transpose();
    let without = dare(&a_s, &b, &q_s, &r, None).unwrap();
    assert!((&with.x - &without.x).norm() <= 1e-9 * with.x.norm());
    assert!((&with.k - (&without.k + s.transpose())).norm() <= 1e-9 * with.k.norm());
}

#[test]
fn lyapunov_matches_series_solution() {
    // X = Σ Aᵏ Q Aᵀᵏ converges fast for ρ(A) = 0.5.
    let a = discrete_stable(5, 9, 0.5);
    let q = DMatrix::identity(5, 5);
    let mut series = DMatrix::zeros(5, 5);
    let mut term = q.clone();
    for _ in 0..200 {
        series += &term;
        term = &a * term * a.transpose();
    }
    let x = dlyap(&a, &q).unwrap();
    assert!((x - series).norm() <= 1e-12 * 5.0);
}

//! SVD, QR, rank kernels, least squares, eigen-decompositions, LU, Schur
//! reordering: invariants over swept shapes.

use lifted_linalg::*;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

use super::{SHAPES, assert_orthonormal_columns, cases, gaussian, random, tol};

#[test]
fn svd_invariants_over_shapes() {
    for (seed, (m, n)) in SHAPES.iter().copied().enumerate() {
        for (name, a) in cases(m, n, seed as u64) {
            let f = svd(&a).unwrap();
            let k = m.min(n);
            assert_eq!(
                (f.u.shape(), f.s.len(), f.v.shape()),
                ((m, k), k, (n, k)),
                "{name} {m}x{n}"
            );
            let e = (f.reconstruct() - &a).norm();
            assert!(
                e <= tol(m, n, a.norm()),
                "{name} {m}x{n}: ‖UΣVᵀ − A‖ = {e:e}"
            );
            if name != "zero" {
                assert_orthonormal_columns(&f.u, "U");
                assert_orthonormal_columns(&f.v, "V");
            }
            assert!(
                f.s.iter().zip(f.s.iter().skip(1)).all(|(x, y)| x >= y),
                "descending"
            );
            assert!(f.s.iter().all(|&v| v >= 0.0));
            let s = singular_values(&a).unwrap();
            assert!((s - &f.s).norm() <= tol(m, n, a.norm()));
        }
    }
}

/// Flips the rows of an upper triangular R to a nonnegative diagonal.
fn sign_normalised(r: &DMatrix<f64>) -> DMatrix<f64> {
    let mut r = r.clone();
    for i in 0..r.nrows().min(r.ncols()) {
        if r[(i, i)] < 0.0 {
            let mut row = r.row_mut(i);
            row *= -1.0;
        }
    }
    r
}

#[test]
fn qr_invariants_over_shapes() {
    for (seed, (m, n)) in SHAPES.iter().copied().enumerate() {
        for (name, a) in cases(m, n, 10 + seed as u64) {
            let k = m.min(n);
            let scale = a.norm();
            let thin = qr_thin(&a).unwrap();
            assert_eq!((thin.q.shape(), thin.r.shape()), ((m, k), (k, n)));
            assert!(
                (&thin.q * &thin.r - &a).norm() <= tol(m, n, scale),
                "{name} {m}x{n} thin"
            );
            assert_orthonormal_columns(&thin.q, "thin Q");
            let full = qr_full(&a).unwrap();
            assert_eq!((full.q.shape(), full.r.shape()), ((m, m), (m, n)));
            assert!(
                (&full.q * &full.r - &a).norm() <= tol(m, n, scale),
                "{name} {m}x{n} full"
            );
            assert_orthonormal_columns(&full.q, "full Q");
            let r = qr_r(&a).unwrap();
            assert_eq!(r.shape(), (k, n));
            for j in 0..n {
                for i in (j + 1)..k {
                    assert_eq!(r[(i, j)], 0.0, "R not upper triangular");
                }
            }
            // RᵀR = AᵀA, and R equals the thin R up to row signs.
            assert!((r.transpose() * &r - a.transpose() * &a).norm() <= tol(m, n, scale * scale));
            if name == "random" && m >= n {
                assert!(
                    (sign_normalised(&r) - sign_normalised(&thin.r)).norm() <= tol(m, n, scale)
                );
            }
        }
    }
}

#[test]
fn streaming_r_matches_batch_r() {
    let a = gaussian(1000, 24, 5);
    let want = sign_normalised(&qr_r(&a).unwrap());
    // Blocks smaller than, equal to and larger than the column count.
    for block in [7usize, 24, 100, 1000] {
        let mut acc = RAccumulator::new(24);
        let mut start = 0;
        while start < a.nrows() {
            let len = block.min(a.nrows() - start);
            acc.push_rows(&a.rows(start, len).into_owned()).unwrap();
            start += len;
        }
        assert_eq!(acc.rows_seen(), 1000);
        let got = sign_normalised(&acc.r());
        assert!(
            (got - &want).norm() <= tol(1000, 24, a.norm()),
            "block {block}"
        );
    }
    // Fewer rows than columns so far: R is rows_seen × ncols.
    let mut acc = RAccumulator::new(24);
    acc.push_rows(&a.rows(0, 5).into_owned()).unwrap();
    assert_eq!(acc.r().shape(), (5, 24));
}

/// A = U_r diag(σ) V_rᵀ with prescribed rank r.
fn rank_r(m: usize, n: usize, r: usize, seed: u64) -> DMatrix<f64> {
    let u = qr_thin(&gaussian(m, r, seed)).unwrap().q;
    let v = qr_thin(&gaussian(n, r, seed + 1)).unwrap().q;
    let s = DMatrix::from_diagonal(&DVector::from_fn(r, |i, _| 10.0 / (i + 1) as f64));
    u * s * v.transpose()
}

#[test]
fn rank_pinv_null_range_on_constructed_ranks() {
    for (m, n, r) in [(10, 6, 3), (6, 10, 4), (8, 8, 8), (20, 5, 1), (5, 20, 5)] {
        let a = rank_r(m, n, r, (m * 100 + n) as u64);
        assert_eq!(
            rank(&a, RankTolerance::Default).unwrap(),
            r,
            "{m}x{n} rank {r}"
        );
        let p = pinv(&a, RankTolerance::Default).unwrap();
        assert_eq!(p.shape(), (n, m));
        // Penrose conditions.
        let t = tol(m, n, 10.0) * 10.0;
        assert!((&a * &p * &a - &a).norm() <= t);
        assert!((&p * &a * &p - &p).norm() <= t);
        let ap = &a * &p;
        assert!((&ap - ap.transpose()).norm() <= t);
        let pa = &p * &a;
        assert!((&pa - pa.transpose()).norm() <= t);
        let ns = null_space(&a, RankTolerance::Default).unwrap();
        assert_eq!(ns.shape(), (n, n - r));
        if n > r {
            assert_orthonormal_columns(&ns, "null space");
            assert!((&a * &ns).norm() <= t);
        }
        let rb = range_basis(&a, RankTolerance::Default).unwrap();
        assert_eq!(rb.shape(), (m, r));
        assert_orthonormal_columns(&rb, "range");
        // Projecting A onto its range leaves it unchanged.
        assert!((&rb * (rb.transpose() * &a) - &a).norm() <= t);
    }
    // Zero and identity.
    let z = DMatrix::<f64>::zeros(4, 3);
    assert_eq!(rank(&z, RankTolerance::Default).unwrap(), 0);
    assert_eq!(
        null_space(&z, RankTolerance::Default).unwrap().shape(),
        (3, 3)
    );
    assert_eq!(
        range_basis(&z, RankTolerance::Default).unwrap().shape(),
        (4, 0)
    );
    assert_eq!(
        pinv(&z, RankTolerance::Default).unwrap(),
        DMatrix::zeros(3, 4)
    );
    let i = DMatrix::<f64>::identity(5, 5);
    assert_eq!(rank(&i, RankTolerance::Default).unwrap(), 5);
    assert_eq!(null_space(&i, RankTolerance::Default).unwrap().ncols(), 0);
}

#[test]
fn lstsq_matches_normal_equations_and_pinv() {
    // Full column rank, tall: the normal-equation solution (well conditioned
    // here, so forming AᵀA in the test is harmless).
    let a = gaussian(50, 6, 1);
    let b = gaussian(50, 3, 2);
    let x = lstsq(&a, &b).unwrap();
    let xn = solve(&(a.transpose() * &a), &(a.transpose() * &b)).unwrap();
    assert!((&x - xn).norm() <= 1e-12);
    // Rank deficient and wide: minimum-norm = pinv solution.
    for a in [rank_r(30, 8, 4, 3), gaussian(4, 9, 4)] {
        let b = gaussian(a.nrows(), 2, 5);
        let x = lstsq(&a, &b).unwrap();
        let xp = pinv(&a, RankTolerance::Default).unwrap() * &b;
        assert!((&x - xp).norm() <= 1e-11, "{:?}", a.shape());
    }
}

#[test]
fn lu_solve_inverse_determinant() {
    for n in [1, 2, 5, 20, 60] {
        let a = random(n, n, n as u64) + DMatrix::identity(n, n) * 2.0;
        let b = random(n, 3, 99);
        let x = solve(&a, &b).unwrap();
        assert!((&a * &x - &b).norm() <= tol(n, n, a.norm() * x.norm()));
        let ai = inv(&a).unwrap();
        assert!((&a * &ai - DMatrix::identity(n, n)).norm() <= tol(n, n, a.norm() * ai.norm()));
        let c = random(n, n, 7 + n as u64);
        let (da, dc, dac) = (det(&a).unwrap(), det(&c).unwrap(), det(&(&a * &c)).unwrap());
        assert!(
            (dac - da * dc).abs() <= 1e-10 * (da * dc).abs().max(1e-300),
            "n={n}"
        );
        let rc = rcond(&a).unwrap();
        assert!(rc > 0.0 && rc <= 1.0);
    }
    assert_eq!(det(&DMatrix::identity(4, 4)).unwrap(), 1.0);
}

#[test]
fn general_eigen_decomposition() {
    for n in [1, 2, 7, 25] {
        let a = random(n, n, 40 + n as u64);
        let e = eig(&a).unwrap();
        let ac = a.map(|v| Complex64::new(v, 0.0));
        let lam = DMatrix::from_diagonal(&DVector::from_vec(e.values.clone()));
        let res = (&ac * &e.vectors - &e.vectors * lam).norm();
        assert!(res <= tol(n, n, a.norm()) * 10.0, "n={n}: {res:e}");
        // Same spectrum as the real Schur form (matched greedily).
        let mut schur_ev = real_schur(&a).unwrap().eigenvalues();
        for l in eigenvalues(&a).unwrap() {
            let (i, d) = schur_ev
                .iter()
                .enumerate()
                .map(|(i, s)| (i, (s - l).norm()))
                .fold(
                    (0, f64::INFINITY),
                    |acc, x| if x.1 < acc.1 { x } else { acc },
                );
            assert!(d <= 1e-10, "eigenvalue {l} not found");
            schur_ev.swap_remove(i);
        }
    }
}

#[test]
fn symmetric_eigen_over_sizes() {
    for n in [1, 3, 10, 40] {
        let g = random(n, n, n as u64);
        let a = &g + g.transpose();
        let e = sym_eig(&a, SortOrder::Descending).unwrap();
        assert_orthonormal_columns(&e.vectors, "sym eigenvectors");
        let back = &e.vectors * DMatrix::from_diagonal(&e.values) * e.vectors.transpose();
        assert!((back - &a).norm() <= tol(n, n, a.norm()));
        assert!(
            e.values
                .iter()
                .zip(e.values.iter().skip(1))
                .all(|(x, y)| x >= y)
        );
        let asc = sym_eig(&a, SortOrder::Ascending).unwrap();
        let rev: Vec<f64> = asc.values.iter().rev().copied().collect();
        assert!((DVector::from_vec(rev) - &e.values).norm() <= tol(n, n, a.norm()));
    }
    let e = sym_eig(&DMatrix::identity(3, 3), SortOrder::Descending).unwrap();
    assert_eq!(e.values, DVector::from_element(3, 1.0));
}

#[test]
fn schur_reorder_selects_stable_part() {
    for seed in 0..20u64 {
        let n = 3 + (seed as usize % 10);
        let a = random(n, n, 500 + seed) * 1.5;
        let rs = real_schur(&a).unwrap();
        let stable = |l: Complex64| l.norm() < 1.0;
        let want = rs.eigenvalues().into_iter().filter(|l| stable(*l)).count();
        let (ro, count) = rs.reorder(stable).unwrap();
        assert_eq!(count, want);
        assert!((&ro.q * &ro.t * ro.q.transpose() - &a).norm() <= tol(n, n, a.norm()) * 10.0);
        assert_orthonormal_columns(&ro.q, "reordered Q");
        let ev = ro.eigenvalues();
        assert!(ev[..count].iter().all(|l| stable(*l)) && ev[count..].iter().all(|l| !stable(*l)));
        // The leading columns of Q span the stable invariant subspace:
        // A Q₁ = Q₁ T₁₁.
        let q1 = ro.q.columns(0, count);
        let t11 = ro.t.view((0, 0), (count, count));
        assert!((&a * q1 - q1 * t11).norm() <= tol(n, n, a.norm()) * 10.0);
    }
    // Nothing / everything selected, and repeated eigenvalues.
    let i = real_schur(&DMatrix::identity(4, 4)).unwrap();
    assert_eq!(i.reorder(|_| false).unwrap().1, 0);
    assert_eq!(i.reorder(|_| true).unwrap().1, 4);
    let d = real_schur(&DMatrix::from_diagonal(&nalgebra::dvector![
        2.0, 0.5, 2.0, 0.5
    ]))
    .unwrap();
    let (ro, k) = d.reorder(|l| l.re < 1.0).unwrap();
    assert_eq!(k, 2);
    assert!(
        ro.eigenvalues()[..2]
            .iter()
            .all(|l| (l.re - 0.5).abs() < 1e-15)
    );
}

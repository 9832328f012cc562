//! One test per rejected input: a NaN/inf, a non-square matrix, or a
//! mismatched dimension, each asserting the named error.

use lifted_linalg::*;
use nalgebra::DMatrix;

fn with_nan(n: usize, m: usize, at: (usize, usize)) -> DMatrix<f64> {
    let mut a = DMatrix::identity(n, m);
    a[at] = f64::NAN;
    a
}

fn with_inf(n: usize, m: usize) -> DMatrix<f64> {
    let mut a = DMatrix::identity(n, m);
    a[(n - 1, 0)] = f64::INFINITY;
    a
}

fn is_nonfinite<T: std::fmt::Debug>(r: Result<T>, name: &str) -> bool {
    matches!(r, Err(Error::NonFinite { what, .. }) if what == name)
}

fn is_not_square<T: std::fmt::Debug>(r: Result<T>) -> bool {
    matches!(r, Err(Error::NotSquare { .. }))
}

fn is_mismatch<T: std::fmt::Debug>(r: Result<T>, name: &str) -> bool {
    matches!(r, Err(Error::DimensionMismatch { what, .. }) if what == name)
}

#[test]
fn nan_position_is_reported() {
    assert_eq!(
        check_finite("a", &with_nan(3, 3, (2, 1))),
        Err(Error::NonFinite {
            what: "a",
            row: 2,
            col: 1
        })
    );
}

#[test]
fn solve_rejects_nan_inf_shape() {
    let i = DMatrix::identity(3, 3);
    let b = DMatrix::zeros(3, 1);
    assert!(is_nonfinite(solve(&with_nan(3, 3, (0, 0)), &b), "a"));
    assert!(is_nonfinite(solve(&i, &with_nan(3, 1, (1, 0))), "b"));
    assert!(is_nonfinite(inv(&with_inf(3, 3)), "a"));
    assert!(is_nonfinite(det(&with_inf(2, 2)), "a"));
    assert!(is_not_square(solve(&DMatrix::zeros(3, 2), &b)));
    assert!(is_not_square(inv(&DMatrix::zeros(2, 3))));
    assert!(is_not_square(det(&DMatrix::zeros(2, 3))));
    assert!(is_mismatch(solve(&i, &DMatrix::zeros(2, 1)), "b"));
}

#[test]
fn matrix_functions_reject_nan_and_nonsquare() {
    assert!(is_nonfinite(expm(&with_nan(2, 2, (0, 1))), "a"));
    assert!(is_nonfinite(logm(&with_inf(2, 2)), "a"));
    assert!(is_nonfinite(rootm(&with_nan(2, 2, (1, 1)), 3), "a"));
    assert!(is_nonfinite(sqrtm(&with_nan(2, 2, (1, 1))), "a"));
    assert!(is_not_square(expm(&DMatrix::zeros(2, 3))));
    assert!(is_not_square(logm(&DMatrix::zeros(2, 3))));
    assert!(is_not_square(rootm(&DMatrix::zeros(2, 3), 2)));
    assert!(is_not_square(sqrtm(&DMatrix::zeros(3, 2))));
    assert!(matches!(
        rootm(&DMatrix::identity(2, 2), 0),
        Err(Error::InvalidArgument { what: "p", .. })
    ));
}

#[test]
fn decompositions_reject_nan_and_nonsquare() {
    assert!(is_nonfinite(real_schur(&with_nan(3, 3, (2, 2))), "a"));
    assert!(is_not_square(real_schur(&DMatrix::zeros(3, 2))));
    assert!(is_nonfinite(eig(&with_inf(3, 3)), "a"));
    assert!(is_not_square(eig(&DMatrix::zeros(3, 2))));
    assert!(is_nonfinite(eigenvalues(&with_inf(3, 3)), "a"));
    assert!(is_not_square(eigenvalues(&DMatrix::zeros(1, 2))));
    assert!(is_nonfinite(
        sym_eig(&with_nan(3, 3, (0, 2)), SortOrder::Ascending),
        "a"
    ));
    assert!(is_not_square(sym_eig(
        &DMatrix::zeros(2, 3),
        SortOrder::Descending
    )));
    assert!(is_nonfinite(svd(&with_nan(4, 2, (3, 1))), "a"));
    assert!(is_nonfinite(singular_values(&with_inf(4, 2)), "a"));
    assert!(is_nonfinite(qr_r(&with_nan(4, 2, (0, 0))), "a"));
    assert!(is_nonfinite(qr_r_owned(with_nan(4, 2, (0, 0))), "a"));
    assert!(is_nonfinite(qr_thin(&with_inf(4, 2)), "a"));
    assert!(is_nonfinite(qr_full(&with_inf(4, 2)), "a"));
}

#[test]
fn accumulator_rejects_nan_and_width() {
    let mut acc = RAccumulator::new(2);
    assert!(is_nonfinite(
        acc.push_rows(&with_nan(3, 2, (1, 1))),
        "block"
    ));
    assert!(is_mismatch(acc.push_rows(&DMatrix::zeros(3, 3)), "block"));
    assert_eq!(acc.rows_seen(), 0);
}

#[test]
fn rank_kernels_reject_nan_and_bad_tolerance() {
    let a = with_nan(3, 2, (2, 0));
    assert!(is_nonfinite(rank(&a, RankTolerance::Default), "a"));
    assert!(is_nonfinite(pinv(&a, RankTolerance::Default), "a"));
    assert!(is_nonfinite(null_space(&a, RankTolerance::Default), "a"));
    assert!(is_nonfinite(range_basis(&a, RankTolerance::Default), "a"));
    let ok = DMatrix::identity(3, 2);
    for tol in [
        RankTolerance::Absolute(-1.0),
        RankTolerance::Relative(f64::INFINITY),
    ] {
        assert!(matches!(
            pinv(&ok, tol),
            Err(Error::InvalidArgument { what: "tol", .. })
        ));
        assert!(matches!(
            null_space(&ok, tol),
            Err(Error::InvalidArgument { .. })
        ));
        assert!(matches!(
            range_basis(&ok, tol),
            Err(Error::InvalidArgument { .. })
        ));
    }
}

#[test]
fn lstsq_rejects_nan_and_mismatch() {
    let a = DMatrix::identity(4, 2);
    assert!(is_nonfinite(
        lstsq(&with_nan(4, 2, (3, 1)), &DMatrix::zeros(4, 1)),
        "a"
    ));
    assert!(is_nonfinite(lstsq(&a, &with_inf(4, 1)), "b"));
    assert!(is_mismatch(lstsq(&a, &DMatrix::zeros(3, 1)), "b"));
}

#[test]
fn equations_reject_nan_shape_mismatch() {
    let a = DMatrix::identity(2, 2) * -1.0;
    let q = DMatrix::identity(2, 2);
    assert!(is_nonfinite(lyap(&with_nan(2, 2, (0, 0)), &q), "a"));
    assert!(is_nonfinite(lyap(&a, &with_inf(2, 2)), "q"));
    assert!(is_not_square(lyap(&DMatrix::zeros(2, 3), &q)));
    assert!(is_mismatch(lyap(&a, &DMatrix::identity(3, 3)), "q"));
    assert!(is_nonfinite(dlyap(&with_inf(2, 2), &q), "a"));
    assert!(is_mismatch(dlyap(&(&a * 0.5), &DMatrix::zeros(2, 3)), "q"));
    assert!(is_nonfinite(
        sylvester(&a, &with_nan(1, 1, (0, 0)), &DMatrix::zeros(2, 1)),
        "b"
    ));
    assert!(is_mismatch(sylvester(&a, &a, &DMatrix::zeros(2, 3)), "c"));
}

#[test]
fn dare_rejects_bad_inputs() {
    let a = DMatrix::identity(2, 2) * 0.5;
    let b = DMatrix::from_element(2, 1, 1.0);
    let q = DMatrix::identity(2, 2);
    let r = DMatrix::identity(1, 1);
    assert!(is_nonfinite(
        dare(&with_nan(2, 2, (1, 0)), &b, &q, &r, None),
        "a"
    ));
    assert!(is_nonfinite(dare(&a, &with_inf(2, 1), &q, &r, None), "b"));
    assert!(is_nonfinite(
        dare(&a, &b, &with_nan(2, 2, (0, 0)), &r, None),
        "q"
    ));
    assert!(is_nonfinite(
        dare(&a, &b, &q, &with_nan(1, 1, (0, 0)), None),
        "r"
    ));
    assert!(is_nonfinite(
        dare(&a, &b, &q, &r, Some(&with_inf(2, 1))),
        "s"
    ));
    assert!(is_not_square(dare(&DMatrix::zeros(2, 3), &b, &q, &r, None)));
    assert!(is_mismatch(
        dare(&a, &DMatrix::zeros(3, 1), &q, &r, None),
        "b"
    ));
    assert!(is_mismatch(
        dare(&a, &b, &DMatrix::identity(3, 3), &r, None),
        "q"
    ));
    assert!(is_mismatch(
        dare(&a, &b, &q, &DMatrix::identity(2, 2), None),
        "r"
    ));
    assert!(is_mismatch(
        dare(&a, &b, &q, &r, Some(&DMatrix::zeros(2, 2))),
        "s"
    ));
    assert!(matches!(
        dare(&a, &b, &q, &DMatrix::zeros(1, 1), None),
        Err(Error::NotPositiveDefinite { what: "r" })
    ));
}

#[test]
fn cca_rejects_nan() {
    let x = DMatrix::from_fn(2, 10, |i, j| (i * j) as f64 + i as f64);
    assert!(is_nonfinite(cca(&with_nan(2, 10, (1, 9)), &x), "x"));
    assert!(is_nonfinite(cca(&x, &with_inf(2, 10)), "y"));
    assert!(is_nonfinite(center_rows(&with_nan(2, 3, (0, 0))), "m"));
}

#[test]
fn check_helpers() {
    let a = DMatrix::<f64>::zeros(2, 3);
    assert!(is_not_square(check_square("a", &a)));
    assert!(is_mismatch(check_rows("a", &a, 3), "a"));
    assert!(is_mismatch(check_cols("a", &a, 2), "a"));
}

use super::*;

fn sim(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    c: &DMatrix<f64>,
    d: &DMatrix<f64>,
    u: &DMatrix<f64>,
    x0: &DVector<f64>,
) -> (DMatrix<f64>, DMatrix<f64>) {
    let nn = u.nrows();
    let mut x = x0.clone();
    let mut xs = DMatrix::zeros(nn + 1, a.nrows());
    let mut y = DMatrix::zeros(nn, c.nrows());
    for t in 0..nn {
        xs.row_mut(t).copy_from(&x.transpose());
        let ut = u.row(t).transpose();
        y.row_mut(t).copy_from(&(c * &x + d * &ut).transpose());
        x = a * &x + b * &ut;
    }
    xs.row_mut(nn).copy_from(&x.transpose());
    (xs, y)
}

#[allow(clippy::type_complexity)]
fn example() -> (
    DMatrix<f64>,
    DMatrix<f64>,
    DMatrix<f64>,
    DMatrix<f64>,
    DMatrix<f64>,
) {
    let a = DMatrix::from_row_slice(2, 2, &[0.7, 0.2, -0.1, 0.5]);
    let b = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.3, -0.5]);
    let c = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0]);
    let d = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, 0.4, 0.0]);
    let u = DMatrix::from_fn(300, 2, |i, j| {
        (((i * 37 + j * 11) * 7919) % 101) as f64 / 50.0 - 1.0
    });
    (a, b, c, d, u)
}

#[test]
fn infinite_output_is_named_nan_is_skipped() {
    let (a, b, c, d, u) = example();
    let (_, mut y) = sim(&a, &b, &c, &d, &u, &DVector::zeros(2));
    y[(3, 0)] = f64::NAN;
    let rec = |y: &DMatrix<f64>| {
        estimate_bd(
            &a,
            &c,
            &[Record {
                u: &u,
                y,
                instrument: None,
            }],
            &Feedthrough::Free,
            InitialState::Estimate,
        )
    };
    assert!(rec(&y).is_ok());
    y[(7, 1)] = f64::NEG_INFINITY;
    y[(9, 0)] = f64::INFINITY;
    match rec(&y) {
        Err(Error::NonFinite { what, row, col }) => assert_eq!((what, row, col), ("y", 9, 0)),
        other => panic!("expected NonFinite, got {other:?}"),
    }
}

#[test]
fn bd_exact_with_mask_and_x0() {
    let (a, b, c, d, u) = example();
    let x0 = DVector::from_vec(vec![0.5, -1.0]);
    let (_, y) = sim(&a, &b, &c, &d, &u, &x0);
    let mask = DMatrix::from_row_slice(2, 2, &[false, false, true, false]);
    let rec = [Record {
        u: &u,
        y: &y,
        instrument: None,
    }];
    let fit = estimate_bd(
        &a,
        &c,
        &rec,
        &Feedthrough::Mask(mask.clone()),
        InitialState::Estimate,
    )
    .unwrap();
    assert!((&fit.b - &b).norm() < 1e-9);
    assert!((&fit.d - &d).norm() < 1e-9);
    assert!((&fit.x0[0] - &x0).norm() < 1e-9);
    let fit = estimate_bd_iv(
        &a,
        &c,
        &rec,
        &Feedthrough::Mask(mask),
        InitialState::Estimate,
    )
    .unwrap();
    assert!((&fit.b - &b).norm() < 1e-8);
    // NaN outputs are skipped
    let mut y2 = y.clone();
    for t in (0..300).step_by(3) {
        y2[(t, 0)] = f64::NAN;
    }
    let rec = [Record {
        u: &u,
        y: &y2,
        instrument: None,
    }];
    let fit = estimate_bd(&a, &c, &rec, &Feedthrough::Free, InitialState::Estimate).unwrap();
    assert!((&fit.b - &b).norm() < 1e-9);
    assert!((&fit.d - &d).norm() < 1e-9);
}

#[test]
fn x0_of_an_unstable_model_comes_from_the_window_before_overflow() {
    // 1.2^4999 overflows f64: reading the whole record made the rows
    // non-finite; the window where C Aᵗ grew by less than
    // MAX_REGRESSOR_GROWTH (≈ 100 samples) determines x₀ exactly.
    let (_, _, _, _, u0) = example();
    let a = DMatrix::from_row_slice(2, 2, &[1.2, 0.1, 0.0, 0.5]);
    let b = DMatrix::from_row_slice(2, 1, &[1.0, 0.5]);
    let c = DMatrix::from_row_slice(1, 2, &[1.0, 1.0]);
    let d = DMatrix::zeros(1, 1);
    let mut u = DMatrix::zeros(5000, 1);
    for t in 0..5000 {
        u[(t, 0)] = u0[(t % 300, 0)];
    }
    let x0 = DVector::from_vec(vec![0.3, -0.7]);
    let (_, y) = sim(&a, &b, &c, &d, &u.rows(0, 150).into_owned(), &x0);
    // Beyond the window the output is irrelevant (the true one
    // overflows): zeros.
    let mut yy = DMatrix::zeros(5000, 1);
    yy.rows_mut(0, 150).copy_from(&y);
    let rec = [Record {
        u: &u,
        y: &yy,
        instrument: None,
    }];
    let est = estimate_x0(&a, &b, &c, &d, &rec).unwrap();
    // Rows up to the growth bound carry rounding of ε·6.7e7 ≈ 1.5e-8
    // relative to the late samples.
    assert!((&est[0] - &x0).norm() < 1e-7, "{}", est[0]);
    // The (B, D, x₀) regression over the whole record is refused.
    assert!(matches!(
        estimate_bd(&a, &c, &rec, &Feedthrough::Zero, InitialState::Estimate),
        Err(Error::UnstableEstimate { samples: 5000, .. })
    ));
}

#[test]
fn structured_lstsq_keeps_masked_zero() {
    let (a, b, c, d, u) = example();
    let (xs, mut y) = sim(&a, &b, &c, &d, &u, &DVector::zeros(2));
    // add a bias to make an unconstrained D(0,1) non-zero
    for t in 0..y.nrows() {
        y[(t, 0)] += 0.01 * u[(t, 1)];
    }
    let mask = DMatrix::from_row_slice(2, 2, &[false, false, true, false]);
    let fit = structured_state_lstsq(&xs, &u, &y, &mask).unwrap();
    assert_eq!(fit.d[(0, 1)], 0.0);
    assert_eq!(fit.d[(0, 0)], 0.0);
    assert!((fit.d[(1, 0)] - 0.4).abs() < 1e-9);
    assert!((&fit.a - &a).norm() < 1e-9);
    // the unconstrained fit would have picked up the 0.01
    let full = structured_state_lstsq(&xs, &u, &y, &DMatrix::from_element(2, 2, true)).unwrap();
    assert!((full.d[(0, 1)] - 0.01).abs() < 1e-9);
}

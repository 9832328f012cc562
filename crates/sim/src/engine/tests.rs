use super::*;

#[test]
fn block_products_match_nalgebra() {
    let a = DMatrix::from_fn(3, 3, |i, j| (i * 3 + j) as f64 * 0.1 - 0.4);
    let b = DMatrix::from_fn(3, 2, |i, j| (i + 2 * j) as f64 - 1.0);
    let c = DMatrix::from_fn(2, 3, |i, j| (i as f64 - j as f64) * 0.3);
    let d = DMatrix::from_fn(2, 2, |i, j| if i == j { 0.5 } else { 0.0 });
    let ss = StateSpace::new(a.clone(), b.clone(), c.clone(), d.clone(), Some(1.0)).unwrap();
    let blk = Block::new(&ss);
    let x = [0.3, -1.0, 2.0];
    let u = [1.5, -0.5];
    let (xv, uv) = (
        nalgebra::DVector::from_column_slice(&x),
        nalgebra::DVector::from_column_slice(&u),
    );
    let mut y = [0.0; 2];
    blk.cx(&x, &mut y);
    blk.add_du(&u, &mut y);
    let yr = &c * &xv + &d * &uv;
    let mut xn = [0.0; 3];
    blk.update(&x, &u, &mut xn);
    let xr = &a * &xv + &b * &uv;
    for i in 0..2 {
        assert!((y[i] - yr[i]).abs() < 1e-14);
        assert!((blk.du_row(i, &u) - (&d * &uv)[i]).abs() < 1e-15);
    }
    for i in 0..3 {
        assert!((xn[i] - xr[i]).abs() < 1e-14);
    }
}

#[test]
fn fused_matrices_are_built_and_match_the_reference_step() {
    // plant 2 states, PI controller, holds (2, 3) and sampling (3, 1):
    // frame 6, the fast path must be active (else the fast-path tests
    // would compare the reference with itself)
    let g = StateSpace::new(
        DMatrix::from_row_slice(2, 2, &[0.9, 0.1, 0.0, 0.7]),
        DMatrix::from_row_slice(2, 2, &[1.0, 0.2, 0.0, 0.5]),
        DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.3, 1.0]),
        DMatrix::zeros(2, 2),
        Some(1.0),
    )
    .unwrap();
    let k = StateSpace::new(
        DMatrix::identity(2, 2),
        DMatrix::identity(2, 2) * 0.1,
        DMatrix::identity(2, 2),
        DMatrix::identity(2, 2) * 0.5,
        Some(1.0),
    )
    .unwrap();
    let e = Engine::new(
        Structure::Loop {
            g: Block::new(&g),
            k: Some(Block::new(&k)),
            phat: None,
            feedback: FeedbackKind::HoldLast,
            k_rate: (1, 0),
        },
        2,
        2,
        &[(2, 0), (3, 1)],
        &[(3, 1), (1, 0)],
        1e12,
    )
    .unwrap();
    assert_eq!(e.frame, 6);
    assert!(e.fused.is_some());
    let n = 50;
    let r = DMatrix::from_fn(n, 2, |i, j| ((i * 7 + j * 3) % 5) as f64 - 2.0);
    let inp = RunInput {
        r1: Some(&r),
        r2: Some(&r),
        noise: None,
        len: n,
    };
    let z0: Vec<f64> = (0..e.nz).map(|i| i as f64 * 0.1).collect();
    let (a, b) = (
        e.run(&z0, &inp, None).unwrap(),
        e.run_reference(&z0, &inp, None).unwrap(),
    );
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() < 1e-12 * y.abs().max(1.0), "{x} vs {y}");
    }
}

#[test]
fn lcm_of_patterns() {
    assert_eq!(lcm(4, 6), 12);
    assert_eq!(lcm(1, 5), 5);
    assert_eq!([2usize, 3, 4].iter().fold(1, |a, &b| lcm(a, b)), 12);
}

//! Steps 3–6 on exact data (m = ∞, white input W = I, n_r = 1): the cover matches the
//! data and, for q beyond twice the order, recovers the system; the rank-deficient
//! branch (III-29, III-30) with different orthogonal U.

use super::common::*;
use lifted_qmarkov::{CoverData, CoverKind, CoverSettings, Error, realize};
use nalgebra::{DMatrix, DVector};

fn exact_data(g: &lifted_lti::StateSpace, q: usize) -> CoverData {
    let nw = g.n_inputs();
    let ryy = g
        .covariance_parameters(&DMatrix::identity(nw, nw), q - 1)
        .unwrap();
    let markov = g.markov_parameters(q - 1).unwrap();
    let mut weighting = vec![DVector::zeros(nw); q];
    weighting[0] = DVector::from_element(nw, 1.0);
    CoverData {
        ryy,
        markov,
        weighting,
    }
}

fn settings(order: usize) -> CoverSettings {
    CoverSettings {
        order: Some(order),
        max_auto_order: 10,
        eigen_tol: 1e-10,
        rank_tol: 1e-10,
        ..Default::default()
    }
}

fn to_ss(r: &lifted_qmarkov::Realization) -> lifted_lti::StateSpace {
    lifted_lti::StateSpace::new(
        r.a.clone(),
        r.b.clone(),
        r.c.clone(),
        r.d.clone(),
        Some(0.1),
    )
    .unwrap()
}

fn mimo() -> lifted_lti::StateSpace {
    ss(
        &[0.9, 0.0, 0.0, 0.0, 0.7, 0.2, 0.0, -0.2, 0.7],
        &[1.0, 0.0, 0.5, 1.0, 0.0, 0.8],
        &[0.2, 0.3, 0.0, 0.1, 0.0, 0.4],
        &[0.05, 0.0, 0.0, 0.02],
        3,
        2,
        2,
    )
}

#[test]
fn exact_data_recover_the_system() {
    let g = mimo();
    let data = exact_data(&g, 8);
    let r = realize(&data, &settings(3)).unwrap();
    assert_eq!(r.rank_dq, 3);
    assert_eq!(r.cover, CoverKind::Exact);
    assert_eq!(r.suggested_order, 3);
    let h = to_ss(&r);
    // Same transfer function: Markov parameters far beyond q, and the poles.
    assert!(markov_error(&g, &h, 40) < 1e-9);
    for (a, b) in sorted_poles(&g).iter().zip(sorted_poles(&h)) {
        assert!((a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9);
    }
    // The cover has identity state covariance (Lemma III-2, erratum Z-11 with W = I):
    // its covariance parameters match the data too.
    let rh = h
        .covariance_parameters(&DMatrix::identity(2, 2), 7)
        .unwrap();
    for (a, b) in rh.iter().zip(&data.ryy) {
        assert!((a - b).norm() < 1e-9);
    }
}

#[test]
fn weighted_cover_is_the_same_system() {
    let g = mimo();
    let data = exact_data(&g, 8);
    let q = DMatrix::from_row_slice(2, 2, &[2.0, 0.3, 0.3, 0.5]);
    let r = realize(
        &data,
        &CoverSettings {
            output_weighting: Some(q),
            ..settings(3)
        },
    )
    .unwrap();
    assert!(markov_error(&g, &to_ss(&r), 40) < 1e-9);
}

#[test]
fn rank_deficient_p_any_orthogonal_u() {
    // SISO second order, q = 2, r = 2: P = P_0 is 1×2 of rank 1, so the
    // V_b U V_dᵀ term of (III-29)/(III-30) is added. Every orthogonal U gives a cover
    // matching H_0, H_1 and R_0, R_1.
    let g = ss(
        &[1.5, -0.56, 1.0, 0.0],
        &[1.0, 0.0],
        &[0.3, 0.1],
        &[0.2],
        2,
        1,
        1,
    );
    let data = exact_data(&g, 2);
    let mut markov1 = Vec::new();
    for u in [1.0, -1.0] {
        let s = CoverSettings {
            rotation: Some(DMatrix::from_element(1, 1, u)),
            ..settings(2)
        };
        let r = realize(&data, &s).unwrap();
        assert_eq!(r.rank_p, 1);
        let h = to_ss(&r);
        let mk = h.markov_parameters(1).unwrap();
        assert!((mk[0][(0, 0)] - data.markov[0][(0, 0)]).abs() < 1e-12);
        assert!((mk[1][(0, 0)] - data.markov[1][(0, 0)]).abs() < 1e-10);
        markov1.push(r.a.clone());
    }
    // Different U, different covers.
    assert!((&markov1[0] - &markov1[1]).norm() > 1e-6);
    // A non-orthogonal U is rejected.
    let bad = CoverSettings {
        rotation: Some(DMatrix::from_element(1, 1, 2.0)),
        ..settings(2)
    };
    assert!(matches!(
        realize(&data, &bad),
        Err(Error::InvalidOption {
            what: "rotation",
            ..
        })
    ));
}

#[test]
fn order_above_rank_is_rejected() {
    let g = mimo();
    let data = exact_data(&g, 8);
    match realize(&data, &settings(5)) {
        Err(Error::OrderExceedsRank { order: 5, rank: 3 }) => {}
        other => panic!("expected OrderExceedsRank, got {other:?}"),
    }
}

#[test]
fn indefinite_dq_gives_least_squares_cover() {
    // Perturb R_yy(0) downwards: D_q is indefinite (not q-identifiable, Lemma III-1).
    let g = mimo();
    let mut data = exact_data(&g, 8);
    data.ryy[0][(0, 0)] -= 0.05;
    let r = realize(&data, &settings(3)).unwrap();
    assert_eq!(r.cover, CoverKind::LeastSquares);
    assert!(r.negative_eigenvalues > 0 && r.min_eigenvalue < 0.0);
    assert!(r.a.iter().all(|v| v.is_finite()));
}

#[test]
fn bad_weighting_is_rejected() {
    let g = mimo();
    let data = exact_data(&g, 8);
    for q in [
        DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]), // indefinite
        DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0]), // not symmetric
    ] {
        let s = CoverSettings {
            output_weighting: Some(q),
            ..settings(3)
        };
        assert!(matches!(
            realize(&data, &s),
            Err(Error::InvalidWeighting { .. })
        ));
    }
    let s = CoverSettings {
        output_weighting: Some(DMatrix::identity(3, 3)),
        ..settings(3)
    };
    assert!(matches!(
        realize(&data, &s),
        Err(Error::DimensionMismatch { .. })
    ));
}

/// Cover data (2 outputs, 1 input, q = 4; a randomly drawn set for which
/// the order-3 cover's Â = P⁺P̄ is unstable, ρ ≈ 1.24: Theorem III-1's
/// stability claim does not hold for arbitrary data, erratum Z-9); with
/// `enforce_stability` the zero-padded shift Â = P_q⁺[P̄; 0] is returned,
/// stable, and the original spectral radius is reported.
#[test]
fn enforce_stability_offers_a_stable_cover() {
    let m = |v: [f64; 4]| DMatrix::from_row_slice(2, 2, &v);
    let ryy = vec![
        m([
            8.783629686844645,
            4.145976694893784,
            4.145976694893784,
            6.039636288793552,
        ]),
        m([
            -0.2178425094723252,
            0.9131591364753681,
            -0.9552457688688952,
            -0.027069953906427045,
        ]),
        m([
            -0.08918129068891016,
            -1.3701483899041844,
            -0.8961793840953896,
            -0.4276748713792114,
        ]),
        m([
            -0.6337909362133467,
            1.0272177850669313,
            2.49783284750258,
            0.06847753065516042,
        ]),
    ];
    let markov = [
        [-0.1267452313817429, -0.8610974018259153],
        [0.06805433452258097, -0.23275401716748598],
        [-0.8218090804387952, -1.111190363084527],
        [0.46921791158562237, -0.3359291134054783],
    ]
    .iter()
    .map(|h| DMatrix::from_column_slice(2, 1, h))
    .collect();
    let mut weighting = vec![DVector::zeros(1); 4];
    weighting[0] = DVector::from_element(1, 1.0);
    let data = CoverData {
        ryy,
        markov,
        weighting,
    };
    let radius = |a: &DMatrix<f64>| {
        a.complex_eigenvalues()
            .iter()
            .map(|z| z.norm())
            .fold(0.0, f64::max)
    };
    let plain = realize(&data, &settings(3)).unwrap();
    let rho = radius(&plain.a);
    assert!(rho > 1.2, "the test needs an unstable cover, got {rho}");
    assert_eq!(plain.stabilized_from, None);
    let stable = realize(
        &data,
        &CoverSettings {
            enforce_stability: true,
            ..settings(3)
        },
    )
    .unwrap();
    let new = radius(&stable.a);
    assert!(new < 1.0, "stabilised radius {new}");
    approx::assert_relative_eq!(stable.stabilized_from.unwrap(), rho, max_relative = 1e-9);
    // The stabilisation only changes Â.
    assert_eq!(stable.c, plain.c);
    assert_eq!(stable.b, plain.b);
}

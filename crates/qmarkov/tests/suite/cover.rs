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

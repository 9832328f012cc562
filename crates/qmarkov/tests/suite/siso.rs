//! Single-input single-output covers: single rate (Zhu, Skelton & Li 1995) and held
//! PRBS (n_r > 1), exact order recovery, order suggestion, diagnostics.

use super::common::*;
use lifted_qmarkov::{
    ChannelRecord, CoverKind, MarkovEstimator, QMarkovOptions, RecordMode, identify_records,
};

fn first_order() -> lifted_lti::StateSpace {
    ss(&[0.9], &[0.1], &[1.0], &[0.0], 1, 1, 1)
}

fn second_order() -> lifted_lti::StateSpace {
    // poles 0.95 and 0.7, a zero, direct feedthrough.
    ss(
        &[1.65, -0.665, 1.0, 0.0],
        &[1.0, 0.0],
        &[0.05, 0.02],
        &[0.01],
        2,
        1,
        1,
    )
}

#[test]
fn single_rate_first_order() {
    let g = first_order();
    let recs = records(&g, &prbs(10, 1.0, 1, 4));
    let opts = QMarkovOptions {
        q: 20,
        order: Some(1),
        prbs_order: 10,
        record: RecordMode::LastPeriod,
        ..Default::default()
    };
    let id = identify_records(&recs, 0.1, &opts).unwrap();
    let p = id.model.poles().unwrap()[0];
    // Finite-m bias of III-23 is O(1/m) = 1e-3 relative.
    assert!((p.re - 0.9).abs() < 5e-3, "pole {p}");
    assert!((id.model.dc_gain().unwrap()[(0, 0)] - 1.0).abs() < 1e-2);
    let d = &id.diagnostics;
    assert!(d.stable && d.spectral_radius < 1.0);
    assert!(d.markov_error < 1e-2, "markov error {}", d.markov_error);
    assert!(d.fit[(0, 0)] > 98.0, "fit {}", d.fit[(0, 0)]);
    assert_eq!(d.eigenvalues.len(), 20);
    assert!(d.steady_state_residual[0] < 1e-9);
    assert_eq!(d.record_start[0], 3 * 2 * 1023);
}

#[test]
fn held_prbs_second_order_hold_deconvolution() {
    let g = second_order();
    let recs = records(&g, &prbs(9, 2.0, 4, 3));
    let opts = QMarkovOptions {
        q: 40,
        order: Some(2),
        hold: 4,
        prbs_order: 9,
        record: RecordMode::LastPeriod,
        ..Default::default()
    };
    let id = identify_records(&recs, 0.1, &opts).unwrap();
    let p = sorted_poles(&id.model);
    // Slow pole accurate; the fast pole carries the n_r > 1 bias of erratum Z-8.
    assert!((p[0].0 - 0.95).abs() < 5e-3, "poles {p:?}");
    assert!(
        (id.model.dc_gain().unwrap()[(0, 0)] - g.dc_gain().unwrap()[(0, 0)]).abs()
            < 0.03 * g.dc_gain().unwrap()[(0, 0)]
    );
    // The hold-deconvolved Markov parameters match the true ones closely.
    let h_true = g.markov_parameters(39).unwrap();
    let err: f64 = id
        .diagnostics
        .markov_data
        .iter()
        .zip(&h_true)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    let scale = h_true.iter().map(|m| m.norm()).fold(0.0, f64::max);
    assert!(err / scale < 0.01, "relative Markov error {}", err / scale);
    // The printed III-23 smears them (erratum Z-8): much larger error.
    let printed = QMarkovOptions {
        markov: MarkovEstimator::PrintedIII23,
        require_stable: false,
        ..opts.clone()
    };
    let idp = identify_records(&recs, 0.1, &printed).unwrap();
    let errp: f64 = idp
        .diagnostics
        .markov_data
        .iter()
        .zip(&h_true)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(
        errp / scale > 10.0 * err / scale,
        "printed {errp} vs deconvolved {err}"
    );
}

#[test]
fn automatic_order_and_gap() {
    let g = second_order();
    let recs = records(&g, &prbs(10, 1.0, 1, 3));
    let opts = QMarkovOptions {
        q: 30,
        order: None,
        prbs_order: 10,
        record: RecordMode::LastPeriod,
        ..Default::default()
    };
    let id = identify_records(&recs, 0.1, &opts).unwrap();
    let d = &id.diagnostics;
    assert_eq!(d.order, d.suggested_order);
    assert_eq!(
        d.suggested_order,
        2,
        "eigenvalues {:?}",
        &d.eigenvalues[..5]
    );
    assert!(d.eigenvalues.windows(2).all(|w| w[0] >= w[1]));
    assert!(d.markov_error < 0.02);
    assert!(
        d.covariance_error < 0.02,
        "covariance error {}",
        d.covariance_error
    );
}

#[test]
fn finite_m_data_are_flagged_least_squares() {
    // With finite m, D_q = R_q − H_q W_q H_qᵀ has small negative eigenvalues
    // (Δ_q ≠ 0): the cover is reported as least squares, and still accurate.
    let g = second_order();
    let recs = records(&g, &prbs(7, 1.0, 1, 6));
    let opts = QMarkovOptions {
        q: 30,
        order: Some(2),
        prbs_order: 7,
        record: RecordMode::LastPeriod,
        ..Default::default()
    };
    let id = identify_records(&recs, 0.1, &opts).unwrap();
    let d = &id.diagnostics;
    if d.min_eigenvalue < -opts.eigen_tol * d.eigenvalues[0] {
        assert_eq!(d.cover, CoverKind::LeastSquares);
        assert!(d.negative_eigenvalues > 0);
    } else {
        assert_eq!(d.cover, CoverKind::Exact);
    }
    assert!(d.eigenvalues[..2].iter().all(|&l| l > 0.0));
}

#[test]
fn output_weighting_and_offset() {
    // Q scales the output; the identified model is the same up to rounding.
    // A constant operating-point offset is removed by remove_mean.
    let g = second_order();
    let mut recs = records(&g, &prbs(9, 1.0, 1, 3));
    let opts = QMarkovOptions {
        q: 30,
        order: Some(2),
        prbs_order: 9,
        record: RecordMode::LastPeriod,
        ..Default::default()
    };
    let base = identify_records(&recs, 0.1, &opts).unwrap();
    let weighted = QMarkovOptions {
        output_weighting: Some(nalgebra::DMatrix::from_element(1, 1, 7.0)),
        ..opts.clone()
    };
    let w = identify_records(&recs, 0.1, &weighted).unwrap();
    for (a, b) in sorted_poles(&base.model).iter().zip(sorted_poles(&w.model)) {
        assert!((a.0 - b.0).abs() < 1e-8 && (a.1 - b.1).abs() < 1e-8);
    }
    recs[0].output.add_scalar_mut(1150.0);
    let off = identify_records(&recs, 0.1, &opts).unwrap();
    assert!(
        (off.model.dc_gain().unwrap()[(0, 0)] - base.model.dc_gain().unwrap()[(0, 0)]).abs() < 1e-6
    );
}

#[test]
fn one_period_mode_with_hold_phase() {
    // A period cut at an arbitrary sample (not a generation instant) in OnePeriod mode.
    let g = second_order();
    let w = prbs(8, 1.0, 3, 4);
    let all = records(&g, &w);
    let n = 2 * 3 * 255;
    let start = 2 * n + 5;
    let rec = ChannelRecord {
        input: w[start..start + n].to_vec(),
        output: all[0].output.rows(start, n).into_owned(),
    };
    let opts = QMarkovOptions {
        q: 30,
        order: Some(2),
        hold: 3,
        prbs_order: 8,
        ..Default::default()
    };
    let id = identify_records(&[rec], 0.1, &opts).unwrap();
    let cut = identify_records(
        &all,
        0.1,
        &QMarkovOptions {
            record: RecordMode::LastPeriod,
            ..opts
        },
    )
    .unwrap();
    for (a, b) in id
        .diagnostics
        .markov_data
        .iter()
        .zip(&cut.diagnostics.markov_data)
    {
        assert!((a - b).norm() < 1e-10);
    }
}

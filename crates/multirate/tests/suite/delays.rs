//! MIMO time-delay estimation per input-output pair (thesis §4.4,
//! `estimate_delays`): a 2×2 plant with a different delay on every pair.

use lifted_lti::{C2dOptions, Dataset, InputChannel, OutputChannel, TransferFunction};
use lifted_multirate::estimate_delays;
use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// y_i = Σ_j e^{−d_ij s}/(τ_ij s + 1) u_j at T = 1, inputs held 2 samples
/// (independent ±1 per hold), outputs sampled every 3, small output noise.
fn record(delays: [[f64; 2]; 2], seed: u64) -> Dataset {
    let taus = [[20.0, 8.0], [5.0, 12.0]];
    let n = 3600;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut u = DMatrix::zeros(n, 2);
    for j in 0..2 {
        for t in (0..n).step_by(2) {
            let v = if rng.random::<bool>() { 1.0 } else { -1.0 };
            u[(t, j)] = v;
            u[(t + 1, j)] = v;
        }
    }
    let mut y = DMatrix::zeros(n, 2);
    for i in 0..2 {
        for j in 0..2 {
            let g = TransferFunction::from_coeffs(&[1.0], &[taus[i][j], 1.0], None)
                .unwrap()
                .to_ss()
                .unwrap()
                .c2d(
                    1.0,
                    &C2dOptions {
                        input_delays: Some(vec![delays[i][j]]),
                        ..Default::default()
                    },
                )
                .unwrap();
            let yij = g.lsim(&u.columns(j, 1).into_owned(), None, None).unwrap().y;
            y.column_mut(i).axpy(1.0, &yij.column(0), 1.0);
        }
    }
    for t in 0..n {
        for i in 0..2 {
            y[(t, i)] = if t % 3 == 0 {
                y[(t, i)] + 0.01 * (rng.random::<f64>() - 0.5)
            } else {
                f64::NAN
            };
        }
    }
    Dataset::new(
        1.0,
        u,
        y,
        vec![InputChannel::new("u1", 2), InputChannel::new("u2", 2)],
        vec![
            OutputChannel::new("y1", 3, 0),
            OutputChannel::new("y2", 3, 0),
        ],
    )
    .unwrap()
}

#[test]
fn every_pair_gets_its_own_interval() {
    let d = [[5.0, 8.5], [2.3, 11.0]];
    let pairs = estimate_delays(&record(d, 3), 8, 3.0).unwrap();
    assert_eq!(pairs.len(), 4);
    for p in &pairs {
        let dc = d[p.output][p.input];
        let iv = p
            .interval
            .unwrap_or_else(|| panic!("pair {p:?} gave no interval"));
        assert!(
            iv.contains(dc),
            "pair (y{}, u{}): {iv:?} vs {dc}",
            p.output + 1,
            p.input + 1
        );
        assert_eq!(iv.width(), 1, "{iv:?}");
        assert_eq!((p.hold, p.period), (2, 3));
    }
}

#[test]
fn a_pair_without_response_is_reported_not_fatal() {
    // u2 does not reach y1 at all: that pair reports why, the others work.
    let (_, u, mut y, ins, outs) = record([[5.0, 8.5], [2.3, 11.0]], 4).into_parts();
    // Replace y1 by the response to u1 only (a fresh record with G12 = 0).
    let g = TransferFunction::from_coeffs(&[1.0], &[20.0, 1.0], None)
        .unwrap()
        .to_ss()
        .unwrap()
        .c2d(
            1.0,
            &C2dOptions {
                input_delays: Some(vec![5.0]),
                ..Default::default()
            },
        )
        .unwrap();
    let y1 = g.lsim(&u.columns(0, 1).into_owned(), None, None).unwrap().y;
    for t in 0..y.nrows() {
        if t % 3 == 0 {
            y[(t, 0)] = y1[(t, 0)] + 1e-3 * ((t * 7919 % 13) as f64 - 6.0);
        }
    }
    let data = Dataset::new(1.0, u, y, ins, outs).unwrap();
    let pairs = estimate_delays(&data, 8, 3.0).unwrap();
    let p12 = pairs
        .iter()
        .find(|p| p.output == 0 && p.input == 1)
        .unwrap();
    assert!(p12.interval.is_none() && p12.failure.is_some(), "{p12:?}");
    let p11 = pairs
        .iter()
        .find(|p| p.output == 0 && p.input == 0)
        .unwrap();
    assert!(p11.interval.unwrap().contains(5.0), "{p11:?}");
}

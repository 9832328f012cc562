//! A named error for every rejected input.

use super::common::*;
use lifted_lti::{Dataset, Identifier};
use lifted_qmarkov::{ChannelRecord, Error, QMarkov, QMarkovOptions, RecordMode, identify_records};
use nalgebra::DMatrix;

fn plant() -> lifted_lti::StateSpace {
    ss(&[0.8], &[0.2], &[1.0], &[0.0], 1, 1, 1)
}

fn opts() -> QMarkovOptions {
    QMarkovOptions {
        q: 10,
        order: Some(1),
        prbs_order: 6,
        record: RecordMode::LastPeriod,
        ..Default::default()
    }
}

fn good() -> Vec<ChannelRecord> {
    records(&plant(), &prbs(6, 1.0, 1, 4))
}

#[test]
fn good_data_pass() {
    assert!(identify_records(&good(), 0.1, &opts()).is_ok());
}

#[test]
fn record_shorter_than_one_period() {
    let mut r = good();
    r[0].input.truncate(100);
    r[0].output = r[0].output.rows(0, 100).into_owned();
    assert!(matches!(
        identify_records(&r, 0.1, &opts()),
        Err(Error::RecordTooShort {
            len: 100,
            period: 126,
            ..
        })
    ));
    let one = QMarkovOptions {
        record: RecordMode::OnePeriod,
        ..opts()
    };
    assert!(matches!(
        identify_records(&r, 0.1, &one),
        Err(Error::RecordTooShort { .. })
    ));
}

#[test]
fn wrong_period_length() {
    let one = QMarkovOptions {
        record: RecordMode::OnePeriod,
        ..opts()
    };
    assert!(matches!(
        identify_records(&good(), 0.1, &one),
        Err(Error::WrongPeriodLength {
            expected: 126,
            got: 504,
            ..
        })
    ));
    // The data were made with order 6; declaring order 7 breaks the antisymmetry.
    let wrong = QMarkovOptions {
        prbs_order: 7,
        ..opts()
    };
    let r = records(&plant(), &prbs(6, 1.0, 1, 6));
    assert!(matches!(
        identify_records(&r, 0.1, &wrong),
        Err(Error::PeriodMismatch {
            half_period: 127,
            ..
        })
    ));
}

#[test]
fn q_not_below_nr_m() {
    for q in [63, 100, 1] {
        let o = QMarkovOptions { q, ..opts() };
        assert!(matches!(
            identify_records(&good(), 0.1, &o),
            Err(Error::LagsOutOfRange {
                max_exclusive: 63,
                ..
            })
        ));
    }
}

#[test]
fn order_zero_rejected() {
    let o = QMarkovOptions {
        order: Some(0),
        ..opts()
    };
    assert!(matches!(
        identify_records(&good(), 0.1, &o),
        Err(Error::InvalidOption { what: "order", .. })
    ));
}

#[test]
fn nan_in_data() {
    let mut r = good();
    r[0].output[(300, 0)] = f64::NAN;
    assert!(matches!(
        identify_records(&r, 0.1, &opts()),
        Err(Error::NonFinite {
            what: "output",
            sample: 300,
            channel: 0,
            ..
        })
    ));
    let mut r = good();
    r[0].input[7] = f64::INFINITY;
    assert!(matches!(
        identify_records(&r, 0.1, &opts()),
        Err(Error::NonFinite {
            what: "input",
            sample: 7,
            ..
        })
    ));
}

#[test]
fn zero_amplitude() {
    let o = QMarkovOptions {
        amplitudes: Some(vec![0.0]),
        ..opts()
    };
    assert!(matches!(
        identify_records(&good(), 0.1, &o),
        Err(Error::InvalidAmplitude { channel: 0, .. })
    ));
    let mut r = good();
    r[0].input.iter_mut().for_each(|v| *v = 0.0);
    assert!(matches!(
        identify_records(&r, 0.1, &opts()),
        Err(Error::InvalidAmplitude { channel: 0, .. })
    ));
}

#[test]
fn input_is_not_the_declared_prbs() {
    let o = QMarkovOptions {
        amplitudes: Some(vec![2.0]),
        ..opts()
    };
    assert!(matches!(
        identify_records(&good(), 0.1, &o),
        Err(Error::NotPrbs { experiment: 0, .. })
    ));
    // Declared hold 2 while the data change at every sample.
    let r = records(&plant(), &prbs(6, 1.0, 1, 8));
    let o = QMarkovOptions {
        hold: 2,
        q: 10,
        prbs_order: 6,
        ..opts()
    };
    assert!(matches!(
        identify_records(&r, 0.1, &o),
        Err(Error::PeriodMismatch { .. } | Error::NotPrbs { .. })
    ));
}

#[test]
fn channel_counts() {
    let o = QMarkovOptions {
        amplitudes: Some(vec![1.0, 1.0]),
        ..opts()
    };
    assert!(matches!(
        identify_records(&good(), 0.1, &o),
        Err(Error::ChannelCount {
            expected: 1,
            got: 2,
            ..
        })
    ));
    assert!(matches!(
        identify_records(&[], 0.1, &opts()),
        Err(Error::NoExperiments)
    ));
    let mut r = good();
    r[0].output = DMatrix::zeros(r[0].input.len() - 1, 1);
    assert!(matches!(
        identify_records(&r, 0.1, &opts()),
        Err(Error::DimensionMismatch { .. })
    ));
}

#[test]
fn transient_record_is_not_steady_state() {
    // The first period from rest of a slow plant is far from antisymmetric.
    let slow = ss(&[0.99], &[0.01], &[1.0], &[0.0], 1, 1, 1);
    let r = records(&slow, &prbs(6, 1.0, 1, 1));
    let o = QMarkovOptions {
        record: RecordMode::OnePeriod,
        steady_state_tol: 0.05,
        ..opts()
    };
    assert!(matches!(
        identify_records(&r, 0.1, &o),
        Err(Error::NotSteadyState { experiment: 0, .. })
    ));
}

#[test]
fn bad_sample_period() {
    assert!(matches!(
        identify_records(&good(), 0.0, &opts()),
        Err(Error::InvalidOption { what: "ts", .. })
    ));
}

#[test]
fn dataset_cross_excitation_and_count() {
    let w = prbs(6, 1.0, 1, 4);
    let u = DMatrix::from_fn(w.len(), 2, |k, _| w[k]);
    let g = ss(&[0.8], &[0.2, 0.1], &[1.0], &[0.0, 0.0], 1, 2, 1);
    let y = g.lsim(&u, None, None).unwrap().y;
    let e = Dataset::single_rate(0.1, u, y).unwrap();
    let qm = QMarkov::new(opts());
    assert!(matches!(
        qm.identify(&[e.clone(), e.clone()]),
        Err(Error::CrossExcitation {
            experiment: 0,
            channel: 1
        })
    ));
    assert!(matches!(
        qm.identify(&[e]),
        Err(Error::ChannelCount {
            expected: 2,
            got: 1,
            ..
        })
    ));
    assert!(matches!(qm.identify(&[]), Err(Error::NoExperiments)));
}

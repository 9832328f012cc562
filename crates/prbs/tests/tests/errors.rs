use lifted_prbs::*;

fn opts(order: u32, amplitude: f64, hold: usize) -> InversePrbsOptions {
    InversePrbsOptions {
        order,
        amplitude,
        hold,
        taps: None,
    }
}

#[test]
fn order_out_of_range() {
    for order in [0, 1, 33, 64] {
        assert_eq!(
            MSequence::new(order).unwrap_err(),
            Error::OrderOutOfRange {
                order,
                min: 2,
                max: 32
            }
        );
        assert!(matches!(
            InversePrbs::new(&opts(order, 1.0, 1)),
            Err(Error::OrderOutOfRange { .. })
        ));
        assert!(matches!(
            table_taps(order),
            Err(Error::OrderOutOfRange { .. })
        ));
        assert!(matches!(period(order), Err(Error::OrderOutOfRange { .. })));
        assert!(matches!(
            held_autocorrelation(order, 1, 1.0, 0),
            Err(Error::OrderOutOfRange { .. })
        ));
    }
}

#[test]
fn bad_amplitude() {
    for a in [0.0, -1.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        assert!(matches!(
            InversePrbs::new(&opts(5, a, 1)),
            Err(Error::InvalidAmplitude { .. })
        ));
        assert!(matches!(
            inverse_prbs_autocorrelation(5, a, 0),
            Err(Error::InvalidAmplitude { .. })
        ));
        assert!(matches!(
            random_binary(
                10,
                &RandomBinaryOptions {
                    amplitude: a,
                    ..Default::default()
                }
            ),
            Err(Error::InvalidAmplitude { .. })
        ));
        assert!(matches!(
            multisine(
                10,
                &MultisineOptions {
                    amplitude: a,
                    period: 8,
                    ..Default::default()
                }
            ),
            Err(Error::InvalidAmplitude { .. })
        ));
        assert!(matches!(
            ExperimentPlan::new(&PlanOptions {
                amplitudes: vec![1.0, a],
                ..Default::default()
            }),
            Err(Error::InvalidAmplitude { .. })
        ));
    }
}

#[test]
fn zero_hold() {
    assert_eq!(
        InversePrbs::new(&opts(5, 1.0, 0)).unwrap_err(),
        Error::ZeroFactor {
            what: "hold n_r",
            value: 0
        }
    );
    assert!(matches!(
        held_autocorrelation(5, 0, 1.0, 0),
        Err(Error::ZeroFactor { .. })
    ));
    assert!(matches!(
        random_binary(
            10,
            &RandomBinaryOptions {
                hold: 0,
                ..Default::default()
            }
        ),
        Err(Error::ZeroFactor { .. })
    ));
    assert!(matches!(
        generalized_binary_noise(
            10,
            &GbnOptions {
                hold: 0,
                ..Default::default()
            }
        ),
        Err(Error::ZeroFactor { .. })
    ));
}

#[test]
fn bad_taps() {
    assert!(matches!(
        MSequence::with_taps(5, &[3]),
        Err(Error::InvalidTaps { .. })
    ));
    assert!(matches!(
        MSequence::with_taps(5, &[0, 5]),
        Err(Error::InvalidTaps { .. })
    ));
    assert!(matches!(
        MSequence::with_taps(5, &[6, 5]),
        Err(Error::InvalidTaps { .. })
    ));
    assert!(matches!(
        MSequence::with_taps(5, &[3, 3, 5]),
        Err(Error::InvalidTaps { .. })
    ));
    let e = InversePrbs::new(&InversePrbsOptions {
        order: 4,
        taps: Some(vec![2, 4]),
        ..Default::default()
    })
    .unwrap_err();
    assert_eq!(
        e,
        Error::NotMaximal {
            order: 4,
            taps: vec![2, 4]
        }
    );
}

#[test]
fn empty_channel_set() {
    let e = ExperimentPlan::new(&PlanOptions {
        amplitudes: vec![],
        ..Default::default()
    });
    assert_eq!(e.unwrap_err(), Error::EmptyChannelSet);
}

#[test]
fn too_many_shifted_channels() {
    let e = ExperimentPlan::new(&PlanOptions {
        prbs: InversePrbsOptions {
            order: 2,
            ..Default::default()
        },
        amplitudes: vec![1.0; 4],
        scheme: ChannelScheme::Shifted,
        ..Default::default()
    });
    assert_eq!(
        e.unwrap_err(),
        Error::TooManyChannels {
            channels: 4,
            half_period: 3
        }
    );
}

#[test]
fn plan_too_long_for_memory() {
    // Order 32 held 10 samples: 8.6e10 samples per period, far beyond the limit.
    let e = ExperimentPlan::new(&PlanOptions {
        prbs: InversePrbsOptions {
            order: 32,
            hold: 10,
            ..Default::default()
        },
        amplitudes: vec![1.0, 1.0],
        ..Default::default()
    });
    assert!(matches!(e, Err(Error::TooLong { .. })), "{e:?}");
}

#[test]
fn zero_record_periods() {
    let e = ExperimentPlan::new(&PlanOptions {
        record_periods: 0,
        ..Default::default()
    });
    assert!(matches!(e, Err(Error::ZeroLength { .. })));
}

#[test]
fn switching_probability() {
    for p in [0.0, -0.1, 1.5, f64::NAN] {
        let e = generalized_binary_noise(
            10,
            &GbnOptions {
                switch_probability: p,
                ..Default::default()
            },
        );
        assert!(matches!(e, Err(Error::InvalidProbability { .. })), "{p}");
    }
    assert!(
        generalized_binary_noise(
            10,
            &GbnOptions {
                switch_probability: 1.0,
                ..Default::default()
            }
        )
        .is_ok()
    );
}

#[test]
fn zero_length_signals() {
    assert!(matches!(
        random_binary(0, &Default::default()),
        Err(Error::ZeroLength { .. })
    ));
    assert!(matches!(
        generalized_binary_noise(0, &Default::default()),
        Err(Error::ZeroLength { .. })
    ));
    assert!(matches!(
        multisine(0, &Default::default()),
        Err(Error::ZeroLength { .. })
    ));
    assert!(matches!(
        vectorized_excitation(0, &Default::default()),
        Err(Error::ZeroLength { .. })
    ));
}

#[test]
fn bad_harmonics() {
    for (first, last, period) in [
        (0, Some(3), 16),
        (4, Some(3), 16),
        (1, Some(8), 16),
        (1, None, 2),
    ] {
        let e = multisine(
            10,
            &MultisineOptions {
                amplitude: 1.0,
                period,
                first_harmonic: first,
                last_harmonic: last,
            },
        );
        assert!(
            matches!(e, Err(Error::InvalidHarmonics { .. })),
            "{first} {last:?} {period}"
        );
    }
}

#[test]
fn correlation_inputs() {
    let x = [1.0, 2.0];
    assert_eq!(
        periodic_autocorrelation(&[], Normalization::Sum).unwrap_err(),
        Error::EmptySignal { what: "x" }
    );
    assert_eq!(
        periodic_cross_correlation(&x, &[1.0], Normalization::Sum).unwrap_err(),
        Error::LengthMismatch { left: 2, right: 1 }
    );
    assert_eq!(
        periodic_cross_correlation(&x, &[1.0, f64::NAN], Normalization::Sum).unwrap_err(),
        Error::NonFinite {
            what: "y",
            index: 1
        }
    );
    for c in [0.0, -2.0, f64::INFINITY] {
        assert!(matches!(
            periodic_autocorrelation(&x, Normalization::Divisor(c)),
            Err(Error::InvalidParameter { .. })
        ));
    }
}

#[test]
fn lifted_covariance_inputs() {
    assert!(matches!(
        lifted_covariance(&[1.0; 4], 0),
        Err(Error::ZeroFactor { .. })
    ));
    assert!(matches!(
        lifted_covariance(&[], 2),
        Err(Error::EmptySignal { .. })
    ));
    assert_eq!(
        lifted_covariance(&[1.0; 5], 2).unwrap_err(),
        Error::NotMultiple { len: 5, factor: 2 }
    );
    assert!(matches!(
        lifted_covariance(&[1.0, f64::NAN], 2),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        vectorized_excitation(
            10,
            &VectorizedOptions {
                factor: 0,
                ..Default::default()
            }
        ),
        Err(Error::ZeroFactor { .. })
    ));
}

#[test]
fn bad_design_requests() {
    let base = DesignRequest::default();
    let cases = [
        DesignRequest {
            output_period: 0.0,
            ..base.clone()
        },
        DesignRequest {
            output_period: f64::NAN,
            ..base.clone()
        },
        DesignRequest {
            actuator_rate_hz: -30.0,
            ..base.clone()
        },
        DesignRequest {
            actuator_margin: 0.0,
            ..base.clone()
        },
        DesignRequest {
            slowest_mode_hz: f64::INFINITY,
            ..base.clone()
        },
    ];
    for c in cases {
        assert!(
            matches!(design(&c), Err(Error::InvalidParameter { .. })),
            "{c:?}"
        );
    }
    assert!(matches!(
        design(&DesignRequest {
            amplitude: -2.0,
            ..base.clone()
        }),
        Err(Error::InvalidAmplitude { .. })
    ));
    assert!(matches!(
        design(&DesignRequest {
            min_order: 40,
            ..base
        }),
        Err(Error::OrderOutOfRange { .. })
    ));
}

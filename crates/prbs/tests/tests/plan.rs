use lifted_prbs::{
    ChannelScheme, ExperimentPlan, InversePrbsOptions, Normalization, PlanOptions,
    periodic_cross_correlation,
};

fn opts(scheme: ChannelScheme) -> PlanOptions {
    PlanOptions {
        prbs: InversePrbsOptions {
            order: 6,
            hold: 2,
            ..Default::default()
        },
        amplitudes: vec![1.0, 2.0, 0.5],
        scheme,
        settle_periods: 1,
        record_periods: 2,
    }
}

#[test]
fn one_at_a_time() {
    let plan = ExperimentPlan::new(&opts(ChannelScheme::OneAtATime)).unwrap();
    let u = plan.signal();
    let period = 2 * 2 * 63;
    assert_eq!(plan.period(), period);
    assert_eq!(u.ncols(), 3);
    assert_eq!(u.nrows(), 3 * 3 * period);
    assert_eq!(plan.segments().len(), 3);
    for (l, seg) in plan.segments().iter().enumerate() {
        assert_eq!(seg.channel, Some(l));
        assert_eq!(seg.record_start, seg.start + period);
        assert_eq!(seg.record_len, 2 * period);
        for k in seg.start..seg.start + seg.len {
            for c in 0..3 {
                if c == l {
                    assert_eq!(u[(k, c)].abs(), plan.options().amplitudes[l]);
                } else {
                    assert_eq!(u[(k, c)], 0.0);
                }
            }
        }
        // Periodic within the block (steady state is reachable).
        for k in seg.start..seg.start + seg.len - period {
            assert_eq!(u[(k, l)], u[(k + period, l)]);
        }
    }
}

#[test]
fn shifted_channels_are_nearly_uncorrelated() {
    let plan = ExperimentPlan::new(&opts(ChannelScheme::Shifted)).unwrap();
    let u = plan.signal();
    let n = plan.period();
    assert_eq!(plan.shift(), 21);
    let col = |c: usize| -> Vec<f64> { (0..n).map(|k| u[(k, c)]).collect() };
    let (x0, x1) = (col(0), col(1));
    // Channel 1 is channel 0 delayed by d n_r samples (scaled by a_1/a_0 = 2).
    let d = plan.shift() * 2;
    for k in d..n {
        assert_eq!(x1[k], 2.0 * x0[k - d]);
    }
    // Zero-lag cross-correlation (1/2m) is a_0 a_1 R_w(d) = 2·(±n_r/m): small.
    let r = periodic_cross_correlation(&x0, &x1, Normalization::Divisor(126.0)).unwrap();
    assert!(r[0].abs() <= 2.0 * 2.0 / 63.0 + 1e-12, "{}", r[0]);
    assert!((r[n - d] - 2.0 * 2.0).abs() < 1e-12);
}

#[test]
fn independent_channels() {
    let plan = ExperimentPlan::new(&opts(ChannelScheme::Independent { seed: 3 })).unwrap();
    let u = plan.signal();
    let n = plan.period();
    assert_ne!(u.column(0).rows(0, n), u.column(2).rows(0, n) * 2.0);
    for k in 0..u.nrows() - n {
        assert_eq!(u[(k, 1)], u[(k + n, 1)]);
    }
    assert_eq!(
        u,
        ExperimentPlan::new(&opts(ChannelScheme::Independent { seed: 3 }))
            .unwrap()
            .signal()
    );
    assert_ne!(
        u,
        ExperimentPlan::new(&opts(ChannelScheme::Independent { seed: 4 }))
            .unwrap()
            .signal()
    );
}

#[test]
fn serde_roundtrip_validates() {
    let plan = ExperimentPlan::new(&opts(ChannelScheme::Shifted)).unwrap();
    let s = serde_json::to_string(&plan).unwrap();
    let back: ExperimentPlan = serde_json::from_str(&s).unwrap();
    assert_eq!(back, plan);
    let mut bad = opts(ChannelScheme::OneAtATime);
    bad.amplitudes.clear();
    let s = serde_json::to_string(&bad).unwrap();
    assert!(serde_json::from_str::<ExperimentPlan>(&s).is_err());
}

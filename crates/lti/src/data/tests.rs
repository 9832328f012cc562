use super::*;

#[test]
fn a_channel_scale_is_its_standard_deviation_or_one() {
    assert_eq!(channel_scale(&[0.0, 4.0]), 2.0);
    // Unsampled (NaN) cells are left out; a constant or empty channel is 1.
    assert_eq!(channel_scale(&[0.0, f64::NAN, 4.0]), 2.0);
    assert_eq!(channel_scale(&[3.5, 3.5]), 1.0);
    assert_eq!(channel_scale(&[]), 1.0);
    // Units near the ends of the double range: the squares overflow
    // (underflow), the scale is still the deviation (it was 1, and a
    // record in units of 1e160 failed in the refinement's SVD).
    for unit in [1e160, 1e-170] {
        let s = channel_scale(&[0.0, 4.0 * unit]);
        assert!((s / (2.0 * unit) - 1.0).abs() < 1e-15, "{unit}: {s}");
    }
}
use proptest::prelude::*;

#[test]
fn a_decimal_time_column_gives_its_decimal_period() {
    // (599.9 − 0)/5999 is 0.09999999999999999 in binary.
    assert_eq!(period_from_times(0.0, 599.9, 6000), 0.1);
    assert_eq!(period_from_times(0.0, 59.9, 600), 0.1);
    assert_eq!(period_from_times(1.0, 3.5, 6), 0.5);
    // A period that is not a short decimal is kept as computed.
    let third = period_from_times(0.0, 1.0, 4);
    assert_eq!(third, 1.0 / 3.0);
    assert_eq!(snap_period(0.1 * 3.0), 0.3);
    assert_eq!(snap_period(0.3 / 3.0), 0.1);
    // Written times are decimals too, at an integer rate or not.
    for (ts, want) in [(0.1, "0.3,"), (0.08, "0.24,")] {
        let d = Dataset::single_rate(ts, DMatrix::zeros(4, 1), DMatrix::zeros(4, 1)).expect("data");
        let mut out = Vec::new();
        d.to_csv_writer(&mut out).expect("csv");
        let text = String::from_utf8(out).expect("utf8");
        assert!(text.contains(&format!("\n{want}")), "{text}");
    }
}

fn mr() -> Dataset {
    // 12 samples, input held 3, output 1 fast, output 2 every 4 at offset 1.
    let u = DMatrix::from_fn(12, 1, |k, _| (k / 3) as f64 - 1.5);
    let y = DMatrix::from_fn(12, 2, |k, c| {
        if c == 0 || k % 4 == 1 {
            (k * k) as f64 * 0.1 + c as f64
        } else {
            f64::NAN
        }
    });
    Dataset::new(
        0.5,
        u,
        y,
        vec![InputChannel::new("fuel", 3).with_unit("mm3")],
        vec![
            OutputChannel::new("speed", 1, 0).with_unit("rpm"),
            OutputChannel::new("lab", 4, 1),
        ],
    )
    .unwrap()
}

#[test]
fn validation_errors() {
    let u = DMatrix::from_element(6, 1, 1.0);
    let y = DMatrix::from_element(6, 1, 2.0);
    assert!(matches!(
        Dataset::single_rate(0.0, u.clone(), y.clone()),
        Err(DataError::InvalidSamplePeriod { .. })
    ));
    assert!(matches!(
        Dataset::single_rate(f64::NAN, u.clone(), y.clone()),
        Err(DataError::InvalidSamplePeriod { .. })
    ));
    assert!(matches!(
        Dataset::single_rate(1.0, u.clone(), DMatrix::zeros(5, 1)),
        Err(DataError::DimensionMismatch { .. })
    ));
    assert!(matches!(
        Dataset::single_rate(1.0, DMatrix::zeros(0, 1), DMatrix::zeros(0, 1)),
        Err(DataError::Empty)
    ));
    let mut bad = u.clone();
    bad[(2, 0)] = f64::INFINITY;
    assert!(matches!(
        Dataset::single_rate(1.0, bad, y.clone()),
        Err(DataError::NonFiniteInput { sample: 2, .. })
    ));
    let mut bad = y.clone();
    bad[(3, 0)] = f64::NAN;
    assert!(matches!(
        Dataset::single_rate(1.0, u.clone(), bad),
        Err(DataError::MissingSample { sample: 3, .. })
    ));
    // (u, y) with the given channel layout
    let layout = |inputs, outputs| Dataset::new(1.0, u.clone(), y.clone(), inputs, outputs);
    let out2 = vec![OutputChannel::new("y", 2, 0)];
    assert!(matches!(
        layout(default_inputs(1), out2.clone()),
        Err(DataError::UnexpectedSample { sample: 1, .. })
    ));
    assert!(Dataset::from_fast(1.0, u.clone(), y.clone(), default_inputs(1), out2).is_ok());
    assert!(matches!(
        layout(vec![InputChannel::new("u", 0)], default_outputs(1)),
        Err(DataError::ZeroHold { channel: 0 })
    ));
    assert!(matches!(
        layout(default_inputs(1), vec![OutputChannel::new("y", 0, 0)]),
        Err(DataError::ZeroPeriod { channel: 0 })
    ));
    assert!(matches!(
        layout(default_inputs(1), vec![OutputChannel::new("y", 2, 2)]),
        Err(DataError::OffsetOutOfRange { .. })
    ));
    let steps = DMatrix::from_fn(6, 1, |k, _| k as f64);
    assert!(matches!(
        Dataset::new(
            1.0,
            steps,
            y.clone(),
            vec![InputChannel::new("u", 2)],
            default_outputs(1)
        ),
        Err(DataError::HoldViolated {
            sample: 1,
            hold: 2,
            ..
        })
    ));
    assert!(matches!(
        layout(default_inputs(2), default_outputs(1)),
        Err(DataError::DimensionMismatch { .. })
    ));
}

#[test]
fn accessors_and_samples() {
    let d = mr();
    assert_eq!((d.len(), d.n_inputs(), d.n_outputs()), (12, 1, 2));
    assert!(!d.is_single_rate());
    assert_eq!(d.frame_period(), 12);
    let (idx, vals) = d.output_samples(1).unwrap();
    assert_eq!(idx, vec![1, 5, 9]);
    assert_eq!(vals, vec![1.1, 3.5, 9.1]);
    assert!(matches!(
        d.output_samples(2),
        Err(DataError::ChannelOutOfRange { .. })
    ));
    assert_eq!(d.input_samples(0).unwrap().0, vec![0, 3, 6, 9]);
}

/// The one sampling rule: every (period, offset, length) pattern is
/// found again, with or without the period declared, including a
/// record that ends between two samples; each break is named.
#[test]
fn output_sampling_finds_the_pattern_and_names_its_breaks() {
    let nan = f64::NAN;
    for period in 1..6 {
        for offset in 0..period {
            for len in [
                offset + 1,
                3 * period + offset,
                3 * period + offset + period - 1,
            ] {
                let col: Vec<f64> = (0..len)
                    .map(|k| if k % period == offset { k as f64 } else { nan })
                    .collect();
                if col.iter().filter(|v| !v.is_nan()).count() >= 2 {
                    assert_eq!(output_sampling(&col, None), Ok((period, offset)));
                }
                assert_eq!(output_sampling(&col, Some(period)), Ok((period, offset)));
            }
        }
    }
    use SamplingError as S;
    assert_eq!(output_sampling(&[nan, nan], None), Err(S::NoSamples));
    assert_eq!(
        output_sampling(&[1.0, nan, nan], None),
        Err(S::SingleSample)
    );
    assert_eq!(
        output_sampling(&[nan, nan, nan, 1.0, nan, nan, 2.0], Some(3)),
        Err(S::FirstMissing {
            first: 3,
            period: 3
        })
    );
    assert_eq!(
        output_sampling(&[1.0, nan, 2.0, nan, nan, nan, 3.0], None),
        Err(S::MissingAt {
            sample: 4,
            period: 2
        })
    );
    assert_eq!(
        output_sampling(&[1.0, nan, 2.0, 5.0, 3.0], None),
        Err(S::Between {
            sample: 3,
            period: 2
        })
    );
}

#[test]
fn slice_keeps_phase() {
    let d = mr();
    let s = d.slice(2..11).unwrap();
    assert_eq!(s.len(), 9);
    assert_eq!(s.outputs()[1].offset, 3); // absolute 5 → local 3
    assert_eq!(s.inputs()[0].offset, 1); // blocks at 3, 6, 9 → local 1, 4, 7
    let (idx, _) = s.output_samples(1).unwrap();
    assert_eq!(idx, vec![3, 7]);
    assert!(matches!(d.slice(5..5), Err(DataError::InvalidRange { .. })));
    assert!(matches!(
        d.slice(0..13),
        Err(DataError::InvalidRange { .. })
    ));
    // slicing twice = slicing once
    assert_eq!(s.slice(1..5).unwrap(), d.slice(3..7).unwrap());
}

#[test]
fn detrend_removes_mean_and_line() {
    let d = mr();
    let c = d.detrend(Detrend::Constant).unwrap();
    for i in 0..2 {
        let (_, v) = c.output_samples(i).unwrap();
        assert!(v.iter().sum::<f64>().abs() < 1e-12);
    }
    let (_, v) = c.input_samples(0).unwrap();
    assert!(v.iter().sum::<f64>().abs() < 1e-12);
    let u = DMatrix::from_fn(8, 1, |k, _| (k / 2) as f64);
    let y = DMatrix::from_fn(8, 1, |k, _| 3.0 + 0.5 * k as f64);
    let d = Dataset::new(
        1.0,
        u,
        y,
        vec![InputChannel::new("u", 2)],
        default_outputs(1),
    )
    .unwrap();
    let l = d.detrend(Detrend::Linear).unwrap();
    assert!(l.y().iter().all(|v| v.abs() < 1e-12));
    assert!(l.u().iter().all(|v| v.abs() < 1e-12));
}

#[test]
fn csv_is_written_with_empty_slow_cells() {
    let d = mr();
    let mut buf = Vec::new();
    d.to_csv_writer(&mut buf).unwrap();
    let text = String::from_utf8(buf.clone()).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t,fuel [mm3],speed [rpm],lab"));
    assert!(
        lines.next().unwrap().ends_with(','),
        "row 0 has an empty slow cell"
    );
}

#[test]
fn lift_layout_and_errors() {
    let d = mr();
    let l = d.lift(4).unwrap();
    assert_eq!(l.u.shape(), (3, 4));
    assert_eq!(l.y.shape(), (3, 8));
    // channel 1 (lab), row 1, t = 1 is fast sample 5
    assert_eq!(l.y[(1, l.column(1, 1))], d.y()[(5, 1)]);
    assert_eq!(l.u[(2, 3)], d.u()[(11, 0)]);
    assert!(matches!(
        d.lift(5),
        Err(DataError::LengthNotMultiple { len: 12, factor: 5 })
    ));
    assert!(matches!(d.lift(0), Err(DataError::ZeroLiftFactor)));
    let (u, _) = l.unlift().unwrap();
    assert_eq!(&u, d.u());
}

proptest! {
    #[test]
    fn lift_unlift_identity(rows in 1usize..8, n in 1usize..6, p in 1usize..4, seed in 0u64..1000) {
        let x = DMatrix::from_fn(rows * n, p, |k, c| ((k * 31 + c * 7) as u64 ^ seed) as f64 * 0.25);
        let l = lift_signal(&x, n).unwrap();
        prop_assert_eq!(l.shape(), (rows, p * n));
        let back = unlift_signal(&l, n, p).unwrap();
        prop_assert_eq!(&back, &x);
        prop_assert_eq!(lift_signal(&back, n).unwrap(), l);
    }

    #[test]
    fn slice_then_samples_consistent(start in 0usize..12, len in 1usize..12) {
        let d = mr();
        let end = (start + len).min(12);
        prop_assume!(start < end);
        let s = d.slice(start..end).unwrap();
        let (idx, vals) = s.output_samples(1).unwrap();
        for (k, v) in idx.iter().zip(vals) {
            prop_assert_eq!(v, d.y()[(k + start, 1)]);
            prop_assert_eq!((k + start) % 4, 1);
        }
    }
}

#[test]
fn unmeasured_samples_are_interpolated_between_and_held_outside() {
    let nan = f64::NAN;
    let y = interpolate_unmeasured(&[nan, 1.0, nan, nan, 4.0, nan]).unwrap();
    assert_eq!(y, vec![1.0, 1.0, 2.0, 3.0, 4.0, 4.0]);
    assert!(interpolate_unmeasured(&[nan, 2.0, nan]).is_none());
}

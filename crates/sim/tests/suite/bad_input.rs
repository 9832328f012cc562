//! A named error per rejected input.

use crate::common::*;
use lifted_lti::{InputChannel, OutputChannel, StateSpace};
use lifted_sim::{
    Controller, Delays, Error, Excitation, NoiseLevel, NoiseSpec, Plant, SimOptions, Simulator,
    SnrDefinition,
};
use nalgebra::DMatrix;

fn plant2x2() -> Plant {
    let g = StateSpace::new(
        DMatrix::from_row_slice(2, 2, &[0.9, 0.0, 0.0, 0.8]),
        DMatrix::identity(2, 2),
        DMatrix::identity(2, 2),
        DMatrix::zeros(2, 2),
        Some(1.0),
    )
    .unwrap();
    Plant::discrete(&g, &[], &[]).unwrap()
}

#[test]
fn controller_dimension_mismatch() {
    let k = Controller::gain(DMatrix::zeros(3, 2), 1.0).unwrap();
    assert!(matches!(
        Simulator::closed_loop(plant2x2(), k),
        Err(Error::DimensionMismatch {
            expected: 2,
            got: 3,
            ..
        })
    ));
    let k = Controller::gain(DMatrix::zeros(2, 1), 1.0).unwrap();
    assert!(matches!(
        Simulator::closed_loop(plant2x2(), k),
        Err(Error::DimensionMismatch {
            expected: 2,
            got: 1,
            ..
        })
    ));
}

#[test]
fn controller_must_be_discrete_at_a_multiple_of_the_base_period() {
    let cont = tf(&[1.0], &[1.0, 1.0], None);
    assert!(matches!(
        Controller::from_ss(&cont),
        Err(Error::NotDiscrete { .. })
    ));
    // faster than the plant's base period: not an integer multiple ≥ 1
    let k = Controller::gain(DMatrix::zeros(2, 2), 0.5).unwrap();
    assert!(matches!(
        Simulator::closed_loop(plant2x2(), k),
        Err(Error::ControllerPeriod { .. })
    ));
}

#[test]
fn zero_hold_and_zero_sampling_period() {
    assert!(matches!(
        Simulator::open_loop(plant2x2()).with_holds(&[1, 0]),
        Err(Error::ZeroHold { channel: 1 })
    ));
    assert!(matches!(
        Simulator::open_loop(plant2x2())
            .with_inputs(vec![InputChannel::new("a", 0), InputChannel::new("b", 1)]),
        Err(Error::ZeroHold { channel: 0 })
    ));
    assert!(matches!(
        Simulator::open_loop(plant2x2()).with_sampling(&[(0, 0), (1, 0)]),
        Err(Error::ZeroPeriod { channel: 0 })
    ));
    assert!(matches!(
        Simulator::open_loop(plant2x2()).with_outputs(vec![
            OutputChannel::new("a", 1, 0),
            OutputChannel::new("b", 3, 3)
        ]),
        Err(Error::OffsetOutOfRange { channel: 1, .. })
    ));
    assert!(matches!(
        Simulator::open_loop(plant2x2()).with_sampling(&[(1, 0)]),
        Err(Error::DimensionMismatch { .. })
    ));
}

#[test]
fn negative_or_nonfinite_delay() {
    let g = tf(&[1.0], &[2.0, 1.0], None);
    assert!(matches!(
        Plant::continuous(&g, 1.0, &Delays::input(vec![-0.5])),
        Err(Error::NegativeDelay {
            what: "input",
            index: 0,
            ..
        })
    ));
    assert!(matches!(
        Plant::continuous(
            &g,
            1.0,
            &Delays {
                input: vec![],
                output: vec![-1.0]
            }
        ),
        Err(Error::NegativeDelay { what: "output", .. })
    ));
    assert!(matches!(
        Plant::continuous(&g, 1.0, &Delays::input(vec![f64::NAN])),
        Err(Error::NonFinite { .. })
    ));
    assert!(matches!(
        Plant::continuous(&g, 1.0, &Delays::input(vec![1.0, 2.0])),
        Err(Error::DimensionMismatch { .. })
    ));
    assert!(matches!(
        Plant::continuous(&g, 0.0, &Delays::default()),
        Err(Error::InvalidSamplePeriod { .. })
    ));
    assert!(matches!(
        lifted_sim::plants::first_order_with_delay(-1.0),
        Err(Error::NegativeDelay { .. })
    ));
}

#[test]
fn snr_not_positive() {
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let spec = NoiseSpec {
            level: NoiseLevel::Snr {
                ratio: vec![bad],
                definition: SnrDefinition::Variance,
            },
            ..Default::default()
        };
        assert!(
            matches!(
                Simulator::open_loop(plant2x2()).with_noise(spec),
                Err(Error::InvalidSnr { channel: 0, .. })
            ),
            "{bad}"
        );
    }
    let spec = NoiseSpec {
        level: NoiseLevel::Snr {
            ratio: vec![1.0, 2.0, 3.0],
            definition: SnrDefinition::Variance,
        },
        ..Default::default()
    };
    assert!(matches!(
        Simulator::open_loop(plant2x2()).with_noise(spec),
        Err(Error::DimensionMismatch { .. })
    ));
    let spec = NoiseSpec {
        level: NoiseLevel::Std(vec![-1.0]),
        ..Default::default()
    };
    assert!(matches!(
        Simulator::open_loop(plant2x2()).with_noise(spec),
        Err(Error::InvalidNoiseStd { .. })
    ));
    // SNR on an output that is never excited
    let sim = Simulator::open_loop(plant2x2())
        .with_noise(NoiseSpec::white_snr(5.0, 0))
        .unwrap();
    let mut u = DMatrix::zeros(100, 2);
    u.column_mut(0).fill(1.0);
    u[(0, 0)] = 0.0;
    assert!(matches!(
        sim.simulate(&Excitation::input(u)),
        Err(Error::ZeroSignalVariance { channel: 1 })
    ));
}

#[test]
fn unstable_closed_loop_diverges_with_a_named_error() {
    // positive feedback through K = −2 on a stable plant: pole 0.9 + 2 = 2.9
    let k = Controller::gain(DMatrix::from_row_slice(2, 2, &[-2.0, 0.0, 0.0, 0.0]), 1.0).unwrap();
    let sim = Simulator::closed_loop(plant2x2(), k).unwrap();
    let r = Excitation::reference(DMatrix::from_element(200, 2, 1.0));
    match sim.simulate(&r) {
        Err(Error::Diverged { limit, .. }) => assert_eq!(limit, 1e12),
        other => panic!("{other:?}"),
    }
    // a lower limit stops earlier
    let sim = sim
        .with_options(SimOptions {
            divergence_limit: 1e3,
            ..Default::default()
        })
        .unwrap();
    assert!(matches!(sim.simulate(&r), Err(Error::Diverged { sample, .. }) if sample < 10));
}

#[test]
fn bad_excitation() {
    let sim = Simulator::open_loop(plant2x2());
    assert!(matches!(
        sim.simulate(&Excitation::input(DMatrix::zeros(10, 3))),
        Err(Error::DimensionMismatch { .. })
    ));
    assert!(matches!(
        sim.simulate(&Excitation::default()),
        Err(Error::EmptyExcitation)
    ));
    let mut u = DMatrix::zeros(10, 2);
    u[(3, 1)] = f64::NAN;
    assert!(matches!(
        sim.simulate(&Excitation::input(u)),
        Err(Error::NonFinite { what: "r2", .. })
    ));
    let exc = Excitation::both(DMatrix::from_element(10, 2, 1.0), DMatrix::zeros(11, 2));
    let k = Controller::gain(DMatrix::zeros(2, 2), 1.0).unwrap();
    assert!(matches!(
        Simulator::closed_loop(plant2x2(), k)
            .unwrap()
            .simulate(&exc),
        Err(Error::DimensionMismatch { .. })
    ));
    // a nonzero reference in open loop has no meaning
    assert!(matches!(
        sim.simulate(&Excitation::reference(DMatrix::from_element(10, 2, 1.0))),
        Err(Error::Unsupported { .. })
    ));
}

#[test]
fn inferential_model_must_fit() {
    let k = Controller::gain(DMatrix::zeros(2, 2), 1.0).unwrap();
    let sim = Simulator::closed_loop(plant2x2(), k).unwrap();
    let wrong = tf(&[1.0], &[1.0, -0.5], Some(1.0));
    assert!(matches!(
        sim.clone()
            .with_feedback(lifted_sim::Feedback::Inferential(wrong)),
        Err(Error::DimensionMismatch { .. })
    ));
    assert!(matches!(
        Simulator::open_loop(plant2x2()).with_feedback(lifted_sim::Feedback::HoldLast),
        Err(Error::Unsupported { .. })
    ));
}

/// Holds and periods whose common multiple is astronomically large (here
/// 2^40 and 3): a named error before the pattern is tabulated, never an
/// allocation failure.
#[test]
fn pattern_with_a_huge_common_multiple_is_refused() {
    let sim = Simulator::open_loop(plant2x2())
        .with_inputs(vec![
            InputChannel::new("u1", 1 << 40),
            InputChannel::new("u2", 1),
        ])
        .unwrap()
        .with_outputs(vec![
            OutputChannel::new("y1", 3, 0),
            OutputChannel::new("y2", 1, 0),
        ])
        .unwrap();
    let r = sim.simulate(&Excitation::input(DMatrix::zeros(10, 2)));
    assert!(
        matches!(r, Err(Error::PatternTooLong { .. })),
        "{:?}",
        r.err()
    );
}

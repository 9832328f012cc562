//! Output sampling, input holds and the produced data set.

use crate::common::*;
use lifted_lti::{InputChannel, OutputChannel};
use lifted_sim::plants;
use lifted_sim::{Excitation, Feedback, Plant, Simulator};
use nalgebra::DMatrix;

#[test]
fn slow_channel_is_every_fifth_fast_sample() -> TestResult {
    let fx = plants::stirred_tank_5_3_1()?;
    let sim = Simulator::open_loop(fx.discrete_plant()?).with_outputs(vec![
        OutputChannel::new("level", 5, 2),
        OutputChannel::new("temp", 1, 0),
    ])?;
    let n = 1000;
    let out = sim.simulate(&Excitation::input(random_input(n, 2, 1, 1)))?;
    let (idx, vals) = out.data.output_samples(0)?;
    assert_eq!(idx, (0..n).filter(|k| k % 5 == 2).collect::<Vec<_>>());
    for (k, v) in idx.iter().zip(&vals) {
        assert_eq!(*v, out.y[(*k, 0)]);
    }
    for k in 0..n {
        assert_eq!(out.data.y()[(k, 0)].is_nan(), k % 5 != 2);
    }
    assert_eq!(out.data.output_samples(1)?.0.len(), n);
    assert_eq!(out.data.outputs()[0].name, "level");
    Ok(())
}

#[test]
fn holds_are_applied_and_recorded() -> TestResult {
    let fx = plants::stirred_tank_5_3_1()?;
    let sim = Simulator::open_loop(fx.discrete_plant()?).with_inputs(vec![
        InputChannel::new("u1", 3),
        InputChannel::new("u2", 2).with_offset(1),
    ])?;
    let n = 600;
    let r2 = random_input(n, 2, 1, 2); // not held: the simulator holds it
    let out = sim.simulate(&Excitation::input(r2.clone()))?;
    for k in 0..n {
        let s0 = k - k % 3;
        assert_eq!(out.u()[(k, 0)], r2[(s0, 0)]);
        // hold 2 with phase 1: blocks start at odd k; before k = 1 the held value is 0
        let expect = if k == 0 {
            0.0
        } else {
            r2[(k - (k + 1) % 2, 1)]
        };
        assert_eq!(out.u()[(k, 1)], expect, "k {k}");
    }
    assert_eq!(out.data.inputs()[0].hold, 3);
    assert_eq!(out.data.inputs()[1].offset, 1);
    assert_eq!(sim.frame_period(), 6);
    // the hold acts before the plant: same output as simulating the held input directly
    let direct =
        Simulator::open_loop(fx.discrete_plant()?).simulate(&Excitation::input(out.u().clone()))?;
    assert_eq!(direct.y, out.y);
    Ok(())
}

#[test]
fn hold_last_feedback_uses_the_slow_samples() -> TestResult {
    // P loop on a slow output: with hold-last the controller output is constant between samples
    let g = tf(&[0.2], &[1.0, -0.9], Some(1.0));
    let k = lifted_sim::Controller::gain(DMatrix::from_element(1, 1, 0.5), 1.0)?;
    let sim = Simulator::closed_loop(Plant::discrete(&g, &[], &[])?, k)?
        .with_sampling(&[(4, 0)])?
        .with_feedback(Feedback::HoldLast)?;
    let out = sim.simulate(&Excitation::reference(DMatrix::from_element(40, 1, 1.0)))?;
    for k in 0..40 {
        let s = k - k % 4;
        assert!((out.u()[(k, 0)] - 0.5 * (1.0 - out.y[(s, 0)])).abs() < 1e-15);
    }
    Ok(())
}

#[test]
fn dataset_round_trips_through_csv() -> TestResult {
    let fx = plants::stirred_tank_5_3_1()?;
    let sim = Simulator::open_loop(fx.discrete_plant()?).with_sampling(&[(5, 0), (1, 0)])?;
    let out = sim.simulate(&Excitation::input(random_input(100, 2, 1, 3)))?;
    // Written by lifted-lti, read by lifted-data (the front ends' reader).
    let path = std::env::temp_dir().join(format!("lifted-sim-csv-{}.csv", std::process::id()));
    out.data.to_csv_writer(std::fs::File::create(&path)?)?;
    let spec = lifted_data::table::DataSpec {
        inputs: out.data.inputs().iter().map(|c| c.name.clone()).collect(),
        outputs: out.data.outputs().iter().map(|c| c.name.clone()).collect(),
        hold: 1,
        ..Default::default()
    };
    let back = lifted_data::table::load(path.to_str().unwrap_or_default(), &spec)?.data;
    let _ = std::fs::remove_file(&path);
    assert_eq!(back, out.data);
    Ok(())
}

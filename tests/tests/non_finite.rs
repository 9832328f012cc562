//! Property: for every public entry point that takes user numbers, a NaN or
//! an infinity anywhere in its data is rejected with a named error (the
//! message says the value is not finite), never a panic and never a
//! silently wrong result. The position and the value are drawn by proptest.

use lifted_lti::{Dataset, InputChannel, OutputChannel, StateSpace};
use lifted_mpc::{Controller, MpcOptions, StateSpaceMpc};
use lifted_pem::{PemOptions, refine_pem};
use lifted_prbs::{RandomBinaryOptions, random_binary};
use lifted_sim::{Excitation, Plant, Simulator};
use lifted_subspace::{
    Experiment, IvExperiment, IvOptions, OrderSelection, Record, SubspaceOptions, identify,
    iv_identify,
};
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

const N: usize = 120;

fn plant() -> StateSpace {
    StateSpace::new(
        DMatrix::from_row_slice(2, 2, &[1.5, -0.7, 1.0, 0.0]),
        DMatrix::from_row_slice(2, 1, &[1.0, 0.0]),
        DMatrix::from_row_slice(1, 2, &[0.5, 0.3]),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap()
}

/// A valid record: RBS input and the plant's response.
fn record() -> (DMatrix<f64>, DMatrix<f64>) {
    let u = random_binary(
        N,
        &RandomBinaryOptions {
            amplitude: 1.0,
            hold: 1,
            seed: 1,
        },
    )
    .unwrap();
    let u = DMatrix::from_column_slice(N, 1, &u);
    let y = plant().lsim(&u, None, None).unwrap().y;
    (u, y)
}

fn bad_value() -> impl Strategy<Value = f64> {
    prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY)]
}

/// The error is named: its message says what is wrong with the value.
fn named<T, E: std::fmt::Display>(r: Result<T, E>, entry: &str) -> Result<(), TestCaseError> {
    match r {
        Ok(_) => Err(TestCaseError::fail(format!(
            "{entry}: accepted a non-finite value"
        ))),
        Err(e) => {
            let m = e.to_string().to_lowercase();
            prop_assert!(
                m.contains("finite") || m.contains("nan") || m.contains("inf"),
                "{entry}: error does not name the problem: {e}"
            );
            Ok(())
        }
    }
}

fn with(m: &DMatrix<f64>, row: usize, col: usize, v: f64) -> DMatrix<f64> {
    let mut m = m.clone();
    let (r, c) = (row % m.nrows(), col % m.ncols());
    m[(r, c)] = v;
    m
}

fn dataset(u: DMatrix<f64>, y: DMatrix<f64>) -> Result<Dataset, lifted_lti::DataError> {
    Dataset::new(
        1.0,
        u,
        y,
        vec![InputChannel::new("u", 1)],
        vec![OutputChannel::new("y", 1, 0)],
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn state_space_and_simulation(which in 0usize..4, row in 0usize..4, col in 0usize..4, v in bad_value()) {
        let g = plant();
        let mut m = [g.a().clone(), g.b().clone(), g.c().clone(), g.d().clone()];
        m[which] = with(&m[which], row, col, v);
        let [a, b, c, d] = m;
        named(StateSpace::new(a, b, c, d, Some(1.0)), "StateSpace::new")?;
        let (u, _) = record();
        named(g.lsim(&with(&u, row * 31, 0, v), None, None), "StateSpace::lsim")?;
    }

    #[test]
    fn data_sets(row in 0usize..N, v in bad_value(), in_y in any::<bool>()) {
        let (u, y) = record();
        let r = if in_y { dataset(u, with(&y, row, 0, v)) } else { dataset(with(&u, row, 0, v), y) };
        // NaN in an output is an unsampled instant: a NaN at an instant the
        // channel samples is rejected as not finite there.
        named(r, "Dataset::new")?;
    }

    #[test]
    fn subspace_iv_and_pem(row in 0usize..N, v in bad_value(), target in 0usize..3) {
        let (u, y) = record();
        let (mut bu, mut by, mut bf) = (u.clone(), y.clone(), u.clone());
        match target {
            0 => bu = with(&u, row, 0, v),
            1 => by = with(&y, row, 0, v),
            _ => bf = with(&u, row, 0, v),
        }
        let sopts = SubspaceOptions { order: OrderSelection::Fixed(2), past: 5, future: 5, ..Default::default() };
        if target < 2 {
            named(identify(&[Experiment { u: &bu, y: &by }], &sopts), "lifted_subspace::identify")?;
        }
        let iopts = IvOptions { order: OrderSelection::Fixed(2), alpha: 5, ..Default::default() };
        named(
            iv_identify(&[IvExperiment { u: &bu, y: &by, instrument: Some(&bf) }], &iopts),
            "lifted_subspace::iv_identify",
        )?;
        // y may hold NaN for unsampled instants in PEM records: infinities
        // and any non-finite input are errors.
        if target == 0 || (target == 1 && v.is_infinite()) {
            named(
                refine_pem(&plant(), None, &[Record { u: &bu, y: &by, instrument: None }], &[], &PemOptions::default()),
                "lifted_pem::refine_pem",
            )?;
        }
    }

    #[test]
    fn excitation_simulation_and_control(row in 0usize..N, v in bad_value()) {
        named(
            random_binary(10, &RandomBinaryOptions { amplitude: v, hold: 1, seed: 0 }),
            "lifted_prbs::random_binary",
        )?;
        let (u, _) = record();
        let sim = Simulator::open_loop(Plant::discrete(&plant(), &[], &[]).unwrap());
        named(sim.simulate(&Excitation::input(with(&u, row, 0, v))), "lifted_sim::Simulator::simulate")?;
        let mut mpc = StateSpaceMpc::new(&plant(), &MpcOptions::default()).unwrap();
        named(mpc.update(&[Some(0.0)], &DVector::from_element(1, v)), "Controller::update (reference)")?;
        let mut mpc = StateSpaceMpc::new(&plant(), &MpcOptions::default()).unwrap();
        named(mpc.update(&[Some(v)], &DVector::from_element(1, 1.0)), "Controller::update (measured)")?;
        named(lifted_linalg::qr_r(&with(&u, row, 0, v)), "lifted_linalg::qr_r")?;
    }
}

//! Identification on arbitrary small records and options: every route
//! (N4SID/MOESP/CVA, IV, q-Markov Cover, multirate lifted subspace) returns
//! a model or an error naming the problem; never a panic, hang or abort.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use lifted_lti::{Dataset, Identifier, InputChannel, OutputChannel};
use lifted_multirate::{ProcedureOptions, identify_multirate};
use lifted_qmarkov::{QMarkov, QMarkovOptions};
use lifted_subspace::{
    Experiment, IvExperiment, IvOptions, Method, OrderSelection, SubspaceOptions, SystemEstimate,
    identify, iv_identify,
};
use nalgebra::DMatrix;

#[derive(Debug, Arbitrary)]
struct Case {
    route: u8,
    order: u8,
    horizon: u8,
    period: u8,
    stable: bool,
    states: bool,
    inputs: u8,
    outputs: u8,
    /// Samples, read row-major as [u | y]; special values come through.
    values: Vec<f64>,
}

fuzz_target!(|c: Case| {
    let nu = 1 + (c.inputs % 2) as usize;
    let ny = 1 + (c.outputs % 2) as usize;
    let n = (c.values.len() / (nu + ny)).min(400);
    if n == 0 {
        return;
    }
    let u = DMatrix::from_fn(n, nu, |i, j| c.values[i * (nu + ny) + j]);
    let y = DMatrix::from_fn(n, ny, |i, j| c.values[i * (nu + ny) + nu + j]);
    let order = match c.order % 8 {
        0 => OrderSelection::Gap { max: 6 },
        k => OrderSelection::Fixed(k as usize),
    };
    let horizon = 1 + (c.horizon % 12) as usize;
    let method = [Method::N4sid, Method::Moesp, Method::Cva][(c.route % 3) as usize];
    match c.route % 6 {
        0..=2 => {
            let opts = SubspaceOptions {
                method,
                order,
                past: horizon,
                future: horizon,
                enforce_stability: c.stable,
                system: if c.states {
                    SystemEstimate::StateSequence
                } else {
                    SystemEstimate::ShiftInvariance
                },
                ..Default::default()
            };
            let _ = identify(&[Experiment { u: &u, y: &y }], &opts);
        }
        3 => {
            let opts = IvOptions {
                order,
                alpha: horizon,
                enforce_stability: c.stable,
                ..Default::default()
            };
            let _ = iv_identify(
                &[IvExperiment {
                    u: &u,
                    y: &y,
                    instrument: Some(&u),
                }],
                &opts,
            );
        }
        4 => {
            let ch_u = (0..nu).map(|i| InputChannel::new(format!("u{i}"), 1)).collect();
            let ch_y = (0..ny)
                .map(|i| OutputChannel::new(format!("y{i}"), 1, 0))
                .collect();
            if let Ok(d) = Dataset::new(1.0, u, y, ch_u, ch_y) {
                let opts = QMarkovOptions {
                    q: horizon,
                    prbs_order: 2 + (c.period % 5) as u32,
                    order: match order {
                        OrderSelection::Fixed(k) => Some(k),
                        _ => None,
                    },
                    enforce_stability: c.stable,
                    ..Default::default()
                };
                let sets = vec![d; nu];
                let _ = QMarkov::new(opts).identify(&sets);
            }
        }
        _ => {
            let period = 1 + (c.period % 4) as usize;
            let mut y = y;
            for k in 0..n {
                if k % period != 0 {
                    y.row_mut(k).fill(f64::NAN);
                }
            }
            let ch_u = (0..nu).map(|i| InputChannel::new(format!("u{i}"), 1)).collect();
            let ch_y = (0..ny)
                .map(|i| OutputChannel::new(format!("y{i}"), period, 0))
                .collect();
            if let Ok(d) = Dataset::new(1.0, u, y, ch_u, ch_y) {
                let mut opts = ProcedureOptions::default();
                opts.identification.order = order;
                opts.identification.past = horizon;
                opts.identification.future = horizon;
                opts.identification.enforce_stability = c.stable;
                let _ = identify_multirate(&d, None, &opts);
            }
        }
    }
});

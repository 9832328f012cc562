//! Shared helpers: discrete plants simulated with lifted-lti's `lsim` from rest
//! over several periods (the last one is in steady state to rounding).

use lifted_lti::StateSpace;
use lifted_prbs::{InversePrbs, InversePrbsOptions};
use lifted_qmarkov::ChannelRecord;
use nalgebra::{DMatrix, DVector};

/// The held inverse PRBS of order `order`, magnitude `a`, hold `nr`, `periods` periods.
pub fn prbs(order: u32, a: f64, nr: usize, periods: usize) -> Vec<f64> {
    let p = InversePrbs::new(&InversePrbsOptions {
        order,
        amplitude: a,
        hold: nr,
        taps: None,
    })
    .unwrap();
    p.generate(periods * p.period() as usize)
}

/// One experiment per input channel: channel l excited alone by `w`.
pub fn records(g: &StateSpace, w: &[f64]) -> Vec<ChannelRecord> {
    (0..g.n_inputs())
        .map(|l| {
            let mut u = DMatrix::zeros(w.len(), g.n_inputs());
            u.set_column(l, &DVector::from_column_slice(w));
            ChannelRecord {
                input: w.to_vec(),
                output: g.lsim(&u, None, None).unwrap().y,
            }
        })
        .collect()
}

pub fn ss(
    a: &[f64],
    b: &[f64],
    c: &[f64],
    d: &[f64],
    n: usize,
    ni: usize,
    no: usize,
) -> StateSpace {
    StateSpace::new(
        DMatrix::from_row_slice(n, n, a),
        DMatrix::from_row_slice(n, ni, b),
        DMatrix::from_row_slice(no, n, c),
        DMatrix::from_row_slice(no, ni, d),
        Some(0.1),
    )
    .unwrap()
}

/// Sorted pole moduli / real parts for comparison.
pub fn sorted_poles(g: &StateSpace) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = g
        .poles()
        .unwrap()
        .iter()
        .map(|z| (z.re, z.im.abs()))
        .collect();
    p.sort_by(|a, b| b.0.partial_cmp(&a.0).unwrap());
    p
}

/// max_i ‖Ĥ_i − H_i‖_F over the first q Markov parameters, relative to max ‖H_i‖_F.
pub fn markov_error(g: &StateSpace, h: &StateSpace, q: usize) -> f64 {
    let a = g.markov_parameters(q - 1).unwrap();
    let b = h.markov_parameters(q - 1).unwrap();
    let scale = a.iter().map(|m| m.norm()).fold(0.0, f64::max);
    a.iter()
        .zip(&b)
        .map(|(x, y)| (x - y).norm())
        .fold(0.0, f64::max)
        / scale
}

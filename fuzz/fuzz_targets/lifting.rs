//! Multirate lifting of arbitrary records and rate patterns: lifting then
//! inverse lifting returns the inputs (property), or an error; never a
//! panic.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use lifted_lti::{Dataset, InputChannel, OutputChannel};
use lifted_multirate::{MultirateLifting, Ordering};
use nalgebra::DMatrix;

#[derive(Debug, Arbitrary)]
struct Case {
    holds: Vec<u8>,
    periods: Vec<u8>,
    offsets: Vec<u8>,
    time_major: bool,
    len: u16,
    values: Vec<f64>,
}

fuzz_target!(|c: Case| {
    let nu = c.holds.len().clamp(1, 3);
    let ny = c.periods.len().clamp(1, 3);
    let n = (c.len % 600) as usize;
    if n == 0 || c.values.is_empty() {
        return;
    }
    let hold = |i: usize| 1 + (c.holds.get(i).copied().unwrap_or(0) % 6) as usize;
    let period = |i: usize| 1 + (c.periods.get(i).copied().unwrap_or(0) % 6) as usize;
    let offset = |i: usize| c.offsets.get(i).copied().unwrap_or(0) as usize % period(i);
    let v = |k: usize| c.values[k % c.values.len()];
    // inputs held: constant over each hold block
    let u = DMatrix::from_fn(n, nu, |k, j| v((k / hold(j)) * 7 + j));
    let y = DMatrix::from_fn(n, ny, |k, i| {
        if k % period(i) == offset(i) {
            v(k * 3 + i + 1)
        } else {
            f64::NAN
        }
    });
    let ch_u = (0..nu).map(|j| InputChannel::new(format!("u{j}"), hold(j))).collect();
    let ch_y = (0..ny)
        .map(|i| OutputChannel::new(format!("y{i}"), period(i), offset(i)))
        .collect();
    let Ok(d) = Dataset::new(1.0, u, y, ch_u, ch_y) else {
        return;
    };
    let ordering = if c.time_major {
        Ordering::TimeMajor
    } else {
        Ordering::ChannelMajor
    };
    let Ok(l) = MultirateLifting::from_dataset(&d, ordering) else {
        return;
    };
    let Ok(ld) = l.lift_dataset(&d, true) else {
        return;
    };
    let back = l.unlift_inputs(&ld.u).expect("lifted inputs unlift");
    let rows = back.nrows();
    assert_eq!(rows, ld.u.nrows() * l.period());
    let orig = d.u().rows(0, rows);
    for (a, b) in back.iter().zip(orig.iter()) {
        assert!(a == b || (a.is_nan() && b.is_nan()), "unlift(lift(u)) != u");
    }
});

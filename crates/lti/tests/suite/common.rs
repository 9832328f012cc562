//! Shared helpers.
#![allow(dead_code)]

use lifted_lti::{Poly, StateSpace, TransferFunction};
use nalgebra::DMatrix;
use num_complex::Complex64;

pub fn poly(c: &[f64]) -> Poly {
    Poly::new(c.to_vec()).unwrap()
}

pub fn tf(num: &[f64], den: &[f64], ts: Option<f64>) -> TransferFunction {
    TransferFunction::from_coeffs(num, den, ts).unwrap()
}

pub fn mat(r: usize, c: usize, v: &[f64]) -> DMatrix<f64> {
    DMatrix::from_row_slice(r, c, v)
}

/// Max coefficient difference of two SISO TFs after making both denominators monic.
pub fn tf_diff(a: &TransferFunction, b: &TransferFunction) -> f64 {
    let a = a.normalized();
    let b = b.normalized();
    a.num(0, 0)
        .max_abs_diff(b.num(0, 0))
        .max(a.den(0, 0).max_abs_diff(b.den(0, 0)))
}

/// Max |G1 − G2| over a set of complex points, relative to max |G1|.
pub fn freq_diff(g1: &StateSpace, g2: &StateSpace, pts: &[Complex64]) -> f64 {
    let mut num = 0.0f64;
    let mut den = 1e-300f64;
    for &s in pts {
        let a = g1.eval_complex(s).unwrap();
        let b = g2.eval_complex(s).unwrap();
        num = num.max((&a - &b).iter().map(|z| z.norm()).fold(0.0, f64::max));
        den = den.max(a.iter().map(|z| z.norm()).fold(0.0, f64::max));
    }
    num / den
}

pub fn sorted_re(mut v: Vec<Complex64>) -> Vec<Complex64> {
    v.sort_by(|a, b| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im)));
    v
}

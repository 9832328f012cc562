//! Zhu (2000) Table III: continuous engine models (corrected per Z-14)
//! discretised by ZOH at T = 0.0113 s vs the printed discrete TFs and the
//! spec's 5-digit consistency values (A1.5).

use lifted_lti::{C2dOptions, MinrealOptions, StateSpace, TransferFunction};

use crate::common::*;

const T: f64 = 0.0113;

fn engine(k: f64, c2: f64, c1: f64, p1: f64, p2: f64) -> StateSpace {
    let num = poly(&[c2, c1, 1.0]).scale(k);
    let den = &poly(&[1.0 / p1, 1.0]) * &poly(&[1.0 / p2, 1.0]);
    TransferFunction::siso(num, den, None)
        .unwrap()
        .to_ss()
        .unwrap()
}

fn zoh_tf(g: &StateSpace) -> TransferFunction {
    g.c2d(T, &C2dOptions::default())
        .unwrap()
        .to_tf(&MinrealOptions::default())
        .unwrap()
        .normalized()
}

#[test]
fn table3_1150_rpm() {
    let g = engine(114.0, 3.2e-5, -0.0159, 0.348, 15.88);
    let gd = zoh_tf(&g);
    let (num, den) = (gd.num(0, 0), gd.den(0, 0));
    // printed: (0.0198z² − 0.1949z + 0.1562)/(z² − 1.834z + 0.835); bound 3e-3 (A1.5)
    let printed_den = [1.0, -1.834, 0.835];
    for (k, want) in printed_den.iter().enumerate() {
        assert!(
            (den.coeffs()[k] - want).abs() <= 3e-3,
            "den[{k}] = {}",
            den.coeffs()[k]
        );
    }
    assert!((num.coeffs()[0] - 0.0198).abs() <= 3e-3);
    assert!((num.coeffs()[2] - 0.1562).abs() <= 3e-3);
    // erratum Z-15: the printed −0.1949 is wrong; ZOH gives −0.10585
    assert!((num.coeffs()[1] - (-0.1949)).abs() > 0.08);
    // spec 5-digit values (A1.5): (0.02016, −0.10585, 0.15918)/(1, −1.83181, 0.83245); ±5e-6 rounding
    for (got, want) in num.coeffs().iter().zip([0.02016, -0.10585, 0.15918]) {
        assert!((got - want).abs() <= 1e-5, "num {got} vs {want}");
    }
    for (got, want) in den.coeffs().iter().zip([1.0, -1.83181, 0.83245]) {
        assert!((got - want).abs() <= 1e-5, "den {got} vs {want}");
    }
    let mut poles: Vec<f64> = gd.poles().unwrap().iter().map(|p| p.re).collect();
    poles.sort_by(f64::total_cmp);
    assert!(
        (poles[1] - 0.996075).abs() < 1e-6 && (poles[0] - 0.835735).abs() < 1e-6,
        "{poles:?}"
    );
    // DC gain 114 (from state space, not from rounded coefficients: pitfall 8)
    let dc = g.c2d(T, &C2dOptions::default()).unwrap().dc_gain().unwrap()[(0, 0)];
    assert!((dc - 114.0).abs() < 1e-9);
}

#[test]
fn table3_1500_rpm() {
    let g = engine(85.6, 6.4e-5, -0.0147, 0.383, 26.95);
    let gd = zoh_tf(&g);
    let (num, den) = (gd.num(0, 0), gd.den(0, 0));
    // printed: (0.0567z² − 0.1888z + 0.2297)/(z² − 1.732z + 0.7335)
    for (got, want) in num.coeffs().iter().zip([0.0567, -0.1888, 0.2297]) {
        assert!((got - want).abs() <= 3e-3, "num {got} vs {want}");
    }
    for (got, want) in den.coeffs().iter().zip([1.0, -1.732, 0.7335]) {
        assert!((got - want).abs() <= 3e-3, "den {got} vs {want}");
    }
    // spec 5-digit values: (0.05655, −0.18828, 0.22878)/(1, −1.73315, 0.73428)
    for (got, want) in num.coeffs().iter().zip([0.05655, -0.18828, 0.22878]) {
        assert!((got - want).abs() <= 1e-5, "num {got} vs {want}");
    }
    for (got, want) in den.coeffs().iter().zip([1.0, -1.73315, 0.73428]) {
        assert!((got - want).abs() <= 1e-5, "den {got} vs {want}");
    }
    let mut poles: Vec<f64> = gd.poles().unwrap().iter().map(|p| p.re).collect();
    poles.sort_by(f64::total_cmp);
    assert!(
        (poles[1] - 0.995681).abs() < 1e-6 && (poles[0] - 0.737466).abs() < 1e-6,
        "{poles:?}"
    );
    let dc = g.c2d(T, &C2dOptions::default()).unwrap().dc_gain().unwrap()[(0, 0)];
    assert!((dc - 85.6).abs() < 1e-9);
}

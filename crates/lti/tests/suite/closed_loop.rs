//! Ren & Zhu (2009) Tables 2 and 3 (spec A2.2, Table 3 H₂ entries restored
//! by erratum RZ-6) and the recovery formulas (10)–(12).

use lifted_lti::{FeedbackSign, MinrealOptions, TransferFunction};

use crate::common::*;

struct Case {
    k: TransferFunction,
    h1: TransferFunction,
    h2: TransferFunction,
}

fn one() -> TransferFunction {
    tf(&[1.0], &[1.0], None)
}

/// H₁ = GK(1+GK)⁻¹ = feedback(K·G, 1), H₂ = (1+GK)⁻¹G = feedback(G, K).
fn closed_loop(g: &TransferFunction, k: &TransferFunction) -> (TransferFunction, TransferFunction) {
    let gk = g.mul(k).unwrap();
    let h1 = gk.feedback(&one(), FeedbackSign::Negative).unwrap();
    let h2 = g.feedback(k, FeedbackSign::Negative).unwrap();
    (h1, h2)
}

fn check_table(g: &TransferFunction, cases: &[Case]) {
    for c in cases {
        let (h1, h2) = closed_loop(g, &c.k);
        // exact polynomial arithmetic: only rounding of the products remains
        assert!(tf_diff(&h1, &c.h1) < 1e-14, "H1 {h1} vs {}", c.h1);
        assert!(tf_diff(&h2, &c.h2) < 1e-14, "H2 {h2} vs {}", c.h2);
        // Recovery formulas on the true H1, H2, then cancellation of common factors.
        let opts = MinrealOptions { tol: 1e-6 };
        let i_minus_h1 = one().sub(&h1).unwrap();
        let g10 = i_minus_h1
            .inv()
            .unwrap()
            .mul(&h2)
            .unwrap()
            .minreal(&opts)
            .unwrap();
        let g11 = h1
            .mul(&i_minus_h1.inv().unwrap())
            .unwrap()
            .mul(&c.k.inv().unwrap())
            .unwrap()
            .minreal(&opts)
            .unwrap();
        let kh2 = c.k.mul(&h2).unwrap();
        let g12 = h2
            .mul(&one().sub(&kh2).unwrap().inv().unwrap())
            .unwrap()
            .minreal(&opts)
            .unwrap();
        for (name, gr) in [("(10)", &g10), ("(11)", &g11), ("(12)", &g12)] {
            assert_eq!(gr.den(0, 0).degree(), g.den(0, 0).degree(), "{name}: {gr}");
            // residual of the root matching of multiple roots ~ 1e-8
            assert!(tf_diff(gr, g) < 1e-7, "{name}: {gr} vs {g}");
        }
    }
}

#[test]
fn table2_first_order_plant() {
    let g = tf(&[1.0], &[0.3, 1.0], None);
    let cases = [
        Case {
            k: tf(&[0.2], &[1.0], None),
            h1: tf(&[0.2], &[0.3, 1.2], None),
            h2: tf(&[1.0], &[0.3, 1.2], None),
        },
        Case {
            k: tf(&[1.0, 0.5], &[1.0, 1.0], None),
            h1: tf(&[1.0, 0.5], &[0.3, 2.3, 1.5], None),
            h2: tf(&[1.0, 1.0], &[0.3, 2.3, 1.5], None),
        },
        Case {
            k: tf(&[0.2, 5.0], &[1.0, 0.0], None),
            h1: tf(&[0.2, 5.0], &[0.3, 1.2, 5.0], None),
            h2: tf(&[1.0, 0.0], &[0.3, 1.2, 5.0], None),
        },
    ];
    check_table(&g, &cases);
}

#[test]
fn table3_second_order_plant() {
    let g = tf(&[1.0], &[1.0, 1.0, 1.0], None);
    let cases = [
        Case {
            k: tf(&[0.2], &[1.0], None),
            h1: tf(&[0.2], &[1.0, 1.0, 1.2], None),
            h2: tf(&[1.0], &[1.0, 1.0, 1.2], None),
        },
        Case {
            k: tf(&[1.0, 0.5], &[1.0, 1.0], None),
            h1: tf(&[1.0, 0.5], &[1.0, 2.0, 3.0, 1.5], None),
            // restored by erratum RZ-6
            h2: tf(&[1.0, 1.0], &[1.0, 2.0, 3.0, 1.5], None),
        },
        Case {
            k: tf(&[0.5, 0.2], &[1.0, 0.0], None),
            h1: tf(&[0.5, 0.2], &[1.0, 1.0, 1.5, 0.2], None),
            // restored by erratum RZ-6
            h2: tf(&[1.0, 0.0], &[1.0, 1.0, 1.5, 0.2], None),
        },
    ];
    check_table(&g, &cases);
}

/// The SISO TF feedback agrees with the state-space (MIMO) feedback.
#[test]
fn tf_feedback_agrees_with_state_space() {
    let g = tf(&[1.0], &[1.0, 1.0, 1.0], None);
    let k = tf(&[0.5, 0.2], &[1.0, 0.0], None);
    let h = g
        .feedback(&k, FeedbackSign::Negative)
        .unwrap()
        .to_ss()
        .unwrap();
    let hs = g
        .to_ss()
        .unwrap()
        .feedback(&k.to_ss().unwrap(), FeedbackSign::Negative)
        .unwrap();
    let pts: Vec<_> = [0.1, 0.7, 3.0]
        .iter()
        .map(|&w| num_complex::Complex64::new(0.0, w))
        .collect();
    assert!(freq_diff(&h, &hs, &pts) < 1e-13);
    let hp = g
        .feedback(&k, FeedbackSign::Positive)
        .unwrap()
        .to_ss()
        .unwrap();
    let hsp = g
        .to_ss()
        .unwrap()
        .feedback(&k.to_ss().unwrap(), FeedbackSign::Positive)
        .unwrap();
    assert!(freq_diff(&hp, &hsp, &pts) < 1e-13);
}

/// Spec A2.2, last acceptance item: (12) applied to the printed eq. (16)
/// (which is Ĥ₂, erratum RZ-15) with K_PI = (0.2s+5)/s reproduces the printed
/// (17), G = (4.07e-6 s³ + 3.335s² + 1.3e-4 s)/(s³ + 3.336s² − 0.015s − 0.000648),
/// to ±½ unit of the printed last digit.
#[test]
fn eq16_to_eq17_compensator_recovery() {
    let h2 = tf(&[4.071e-6, 3.335, 1.296e-4], &[1.0, 4.003, 16.66], None);
    let k = tf(&[0.2, 5.0], &[1.0, 0.0], None);
    let kh2 = k.mul(&h2).unwrap();
    let g = h2
        .mul(&one().sub(&kh2).unwrap().inv().unwrap())
        .unwrap()
        .minreal(&MinrealOptions { tol: 1e-6 })
        .unwrap()
        .normalized();
    let (num, den) = (g.num(0, 0), g.den(0, 0));
    assert_eq!((num.degree(), den.degree()), (3, 3), "{g}");
    let want_num = [(4.07e-6, 5e-9), (3.335, 5e-4), (1.3e-4, 5e-6), (0.0, 1e-12)];
    let want_den = [(1.0, 0.0), (3.336, 5e-4), (-0.015, 5e-4), (-0.000648, 5e-7)];
    for (k, (w, tol)) in want_num.iter().enumerate() {
        assert!(
            (num.coeff_of_power(3 - k) - w).abs() <= *tol,
            "num s^{}: {g}",
            3 - k
        );
    }
    for (k, (w, tol)) in want_den.iter().enumerate() {
        assert!(
            (den.coeff_of_power(3 - k) - w).abs() <= tol + 1e-15,
            "den s^{}: {g}",
            3 - k
        );
    }
}

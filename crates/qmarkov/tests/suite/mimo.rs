//! Two inputs, two outputs, one experiment per input: the first q Markov parameters
//! are matched with an error that shrinks as the PRBS period m grows.

use super::common::*;
use lifted_lti::{Dataset, Identifier};
use lifted_qmarkov::{QMarkov, QMarkovOptions, RecordMode, identify_records};
use nalgebra::{DMatrix, DVector};

fn plant() -> lifted_lti::StateSpace {
    // Three states, poles 0.9, 0.7 ± 0.2j, two inputs, two outputs, D ≠ 0.
    ss(
        &[0.9, 0.0, 0.0, 0.0, 0.7, 0.2, 0.0, -0.2, 0.7],
        &[1.0, 0.0, 0.5, 1.0, 0.0, 0.8],
        &[0.2, 0.3, 0.0, 0.1, 0.0, 0.4],
        &[0.05, 0.0, 0.0, 0.02],
        3,
        2,
        2,
    )
}

fn identify(order: u32) -> (f64, lifted_lti::StateSpace) {
    let g = plant();
    let recs = records(&g, &prbs(order, 1.0, 1, 3));
    let opts = QMarkovOptions {
        q: 20,
        order: Some(3),
        prbs_order: order,
        record: RecordMode::LastPeriod,
        ..Default::default()
    };
    let id = identify_records(&recs, 0.1, &opts).unwrap();
    (markov_error(&g, &id.model, 20), id.model)
}

#[test]
fn markov_error_shrinks_with_m() {
    let (e8, g8) = identify(8);
    let (e12, g12) = identify(12);
    eprintln!("Markov error m=255: {e8:.3e}, m=4095: {e12:.3e}");
    // Finite-m error of III-23/III-15 is O(1/m): m = 255 vs 4095 (×16).
    // Calibrated on this plant: e8 = 6.5e-3, e12 = 4.2e-4 (ratio 15.6 ≈ 4095/255).
    assert!(e8 < 1.5e-2, "m = 255: {e8}");
    assert!(e12 < 1e-3, "m = 4095: {e12}");
    assert!(e12 < e8 / 8.0, "{e12} vs {e8}");
    let truth = sorted_poles(&plant());
    for (m, g) in [(255.0, g8), (4095.0, g12)] {
        for (a, b) in truth.iter().zip(sorted_poles(&g)) {
            assert!(
                (a.0 - b.0).abs() < 5.0 / m && (a.1 - b.1).abs() < 5.0 / m,
                "m {m}: {truth:?} vs {b:?}"
            );
        }
    }
}

#[test]
fn identifier_trait_on_datasets() {
    let g = plant();
    let w = prbs(9, 0.5, 1, 3);
    let experiments: Vec<Dataset> = (0..2)
        .map(|l| {
            let mut u = DMatrix::zeros(w.len(), 2);
            u.set_column(l, &DVector::from_column_slice(&w));
            let y = g.lsim(&u, None, None).unwrap().y;
            Dataset::single_rate(0.1, u, y).unwrap()
        })
        .collect();
    let qm = QMarkov::new(QMarkovOptions {
        q: 20,
        order: Some(3),
        prbs_order: 9,
        record: RecordMode::LastPeriod,
        ..Default::default()
    });
    assert_eq!(qm.name(), "weighted multirate q-Markov Cover");
    let id = qm.identify(&experiments).unwrap();
    assert_eq!(id.model.ts(), Some(0.1));
    assert_eq!((id.model.n_inputs(), id.model.n_outputs()), (2, 2));
    assert!(markov_error(&g, &id.model, 20) < 2e-2);
    assert_eq!(id.diagnostics.amplitudes, vec![0.5, 0.5]);
    assert_eq!(id.diagnostics.fit.shape(), (2, 2));
    assert!(
        id.diagnostics.fit.iter().all(|&f| f > 95.0),
        "fit {}",
        id.diagnostics.fit
    );
}

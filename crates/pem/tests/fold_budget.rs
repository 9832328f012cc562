//! The refinement check's folds check the memory budget before copying the
//! records (a binary of its own: the budget is process-wide).

use lifted_linalg::budget::MemoryBudget;
use lifted_pem::{Error, PemOptions, cross_validate_refinement};
use lifted_subspace::{Experiment, OrderSelection, SubspaceOptions};
use nalgebra::DMatrix;

#[test]
fn fold_copies_beyond_the_memory_budget_are_refused() {
    let n = 2000;
    let u = DMatrix::from_fn(n, 1, |k, _| ((k * 7919 + k / 3) % 5) as f64 - 2.0);
    let y = DMatrix::from_fn(n, 1, |k, _| (k as f64 * 0.1).sin());
    let exps = [Experiment { u: &u, y: &y }];
    // Six copies of 4000 values (192 kB) against a 100 kB budget.
    MemoryBudget::set_process_default(100_000);
    let opts = SubspaceOptions {
        order: OrderSelection::Fixed(2),
        past: 5,
        future: 5,
        ..Default::default()
    };
    let e = cross_validate_refinement(&exps, &opts, &PemOptions::default(), 6).unwrap_err();
    assert!(
        matches!(
            e,
            Error::Subspace(lifted_subspace::Error::Linalg(
                lifted_linalg::Error::TooLarge { .. }
            ))
        ),
        "{e}"
    );
}

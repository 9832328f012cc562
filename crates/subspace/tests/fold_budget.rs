//! The cross-validation folds check the memory budget before copying the
//! records (a binary of its own: the budget is process-wide).

use lifted_linalg::budget::MemoryBudget;
use lifted_subspace::{
    Error, Experiment, OrderSelection, StructureOptions, SubspaceOptions, select_structure,
};
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
    let too_large = |e: &Error| matches!(e, Error::Linalg(lifted_linalg::Error::TooLarge { .. }));
    let e = select_structure(&exps, &opts, &StructureOptions::default()).unwrap_err();
    assert!(too_large(&e), "{e}");
}

//! Unit tests of the default refinement's decision.

use super::*;

/// `auto_decision` with the default budgets for a stable first-order
/// model on `samples` samples whose refinement is predicted at
/// `per_iteration` and `typical` operations (`capped`: the route can
/// cap the iterations).
fn decide(
    samples: usize,
    per_iteration: f64,
    typical: f64,
    capped: bool,
) -> (bool, String, Option<f64>) {
    let model = StateSpace::new(
        DMatrix::from_element(1, 1, 0.5),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::zeros(1, 1),
        Some(1.0),
    )
    .unwrap();
    let work = Some(PemWorkEstimate {
        per_iteration,
        typical,
        warm_stages: 0,
        method: PemMethod::VariableProjection,
    });
    let case = AutoCase {
        samples,
        work,
        max_work: 1e12,
        marginal: 0.0,
        not_efficient: None,
        capped,
    };
    auto_decision(&crate::Budgets::default(), &model, case)
}

/// Over the default's budget, a route that can cap the iterations
/// refines within it (one iteration at least fitting); one that
/// cannot, or a record whose single iteration is over it, is not
/// refined; under the budget nothing changes.
#[test]
fn over_the_budget_the_iterations_are_capped() {
    let b = crate::Budgets::default();
    let decide = |per_iteration, typical, capped| decide(300_000, per_iteration, typical, capped);
    let (go, why, cap) = decide(1e9, 6e9, true);
    assert!(go && why.contains("iterations stop"), "{why}");
    assert_eq!(cap, Some(b.auto_refine_work));
    let (go, why, cap) = decide(1e9, 6e9, false);
    assert!(
        !go && cap.is_none() && why.starts_with("not refined"),
        "{why}"
    );
    let (go, why, _) = decide(5e9, 6e10, true);
    assert!(!go && why.contains("one iteration"), "{why}");
    let (go, _, cap) = decide(5e8, 3e9, true);
    assert!(go && cap.is_none());
}

/// A record under `auto_refine_samples` is always refined: in full
/// within the budget or where the route cannot cap; else with its
/// iterations stopped at the budget, one iteration at least — never
/// more work than a longer record's refinement (issue 50).
#[test]
fn a_short_record_is_refined_within_the_budget() {
    let b = crate::Budgets::default();
    let decide = |per_iteration, typical, capped| decide(9_000, per_iteration, typical, capped);
    // Within the budget: in full.
    let (go, _, cap) = decide(5e8, 3e9, true);
    assert!(go && cap.is_none());
    // Over it: capped at the budget ...
    let (go, why, cap) = decide(2e9, 1.6e10, true);
    assert!(go && why.contains("iterations stop"), "{why}");
    assert_eq!(cap, Some(b.auto_refine_work));
    // ... or at one iteration when that is more ...
    let (go, _, cap) = decide(6e9, 6e10, true);
    assert!(go);
    assert_eq!(cap, Some(6e9));
    // ... and in full where the route cannot cap.
    let (go, why, cap) = decide(2e9, 1.6e10, false);
    assert!(go && cap.is_none() && why.contains("always below"), "{why}");
}

use super::*;
use serde_json::json;

/// Every field written, by a struct literal the compiler checks for
/// completeness: its keys are [`FIELDS`] (what the Python package
/// mirrors), and it reads back equal.
#[test]
fn the_fields_are_the_typed_keys_and_read_back() {
    let opts = WorkflowOptions::default();
    let d = Diagnostics {
        route: Some("single-rate subspace identification".into()),
        samples: Some(1000),
        base_period: Some(0.5),
        output_periods: Some(vec![1, 3]),
        data: Some(vec!["a.csv".into()]),
        profile: Some([("identify_s".to_string(), 0.25)].into_iter().collect()),
        warnings: vec!["a warning".into()],
        fallbacks: Some(vec![]),
        notes: Some(vec!["a note".into()]),
        horizons: Some(vec![10, 10]),
        order_selection: Some(OrderSelection {
            kind: "singular values".into(),
            values: vec![3.0, 1.0, 0.1],
            order: 2,
            suggested_order: 2,
            rest: Map::new(),
        }),
        order_criterion: Some(OrderCriterion {
            criterion: "Gap".into(),
            values: vec![Some(1.0), None],
            selected: 1,
            rule: None,
            rest: Map::new(),
        }),
        structure_selection: Some(StructureSelection {
            order: Some(2),
            candidates: Some(vec![Candidate {
                order: 2,
                fit: None,
                horizon: Some(10),
                system: None,
                fold_fits: Some(vec![Some(80.0), None]),
                rest: Map::new(),
            }]),
            refined_shortlist: Some(None),
            ..Default::default()
        }),
        compression: Some(Compression::Used {
            used: "Qr".into(),
            rcond: None,
            fallback: None,
        }),
        stabilized: Some(false),
        stability: Some(Stability {
            stable: true,
            marginal: false,
            spectral_radius: Some(0.9),
            integrators: 0,
            rest: Map::new(),
        }),
        integrators: Some(Integrators {
            count: 0,
            tolerance: 0.002,
            derivation: "2/N".into(),
            poles: vec![],
            note: None,
            rest: Map::new(),
        }),
        feedback: Some(Feedback {
            detected: Some(true),
            verdict: Some("u depends on past y".into()),
            note: None,
            rest: Map::new(),
        }),
        kalman_gain_route: None,
        refinement: Some(Refinement {
            method: Some("Levenberg–Marquardt".into()),
            cost: None,
            kept: None,
            initial_cost: Some(2.0),
            final_cost: Some(1.0),
            iterations: Some(3),
            termination: None,
            rest: Map::new(),
        }),
        refinement_judge: Some(RefinementJudge {
            rule: "held-out blocks".into(),
            decided_by: "held-out blocks".into(),
            held_out: None,
            rest: Map::new(),
        }),
        refinement_decision: Some("refined".into()),
        process: Some(Process {
            kind: "P1D".into(),
            outputs: vec![ProcessOutput {
                names: vec!["K".into()],
                parameters: vec![Some(2.0)],
                std: vec![Some(0.1)],
                rest: Map::new(),
            }],
            rest: Map::new(),
        }),
        options: Some(opts.clone()),
        plan: Some(crate::resolved_defaults(
            &opts,
            &crate::DataShape {
                records: 1,
                samples: 1000,
                longest: 1000,
                multirate: false,
                streamed: false,
            },
        )),
        budgets: Some(BudgetsUsed::of(
            &opts.budgets,
            &opts.identification.gain_check,
        )),
        selection_policy: Some(opts.identification.selection),
        details: Map::new(),
        unread: Vec::new(),
    };
    let v = d.to_value();
    let keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    let mut fields: Vec<&str> = FIELDS
        .iter()
        .copied()
        .filter(|f| *f != "kalman_gain_route")
        .collect();
    let mut keys_sorted = keys.clone();
    keys_sorted.sort_unstable();
    fields.sort_unstable();
    assert_eq!(keys_sorted, fields);
    let back = Diagnostics::strict(&v).unwrap();
    assert_eq!(back, d);
    assert_eq!(back.to_value(), v);
    // `null` and absent stay apart where an entry is written as `null`.
    assert_eq!(v["structure_selection"]["refined_shortlist"], Value::Null);
    assert_eq!(
        d.feedback.unwrap().summary().as_deref(),
        Some("closed loop detected: u depends on past y")
    );
}

/// The entries no field names stay by name, and write back unchanged.
#[test]
fn route_entries_are_kept_by_name() {
    let v = json!({
        "route": "multirate lifted subspace",
        "lifting_period": 3,
        "extraction": {"method": "MatrixRoot", "fallback": null},
        "kalman_gain": null,
    });
    let d = Diagnostics::strict(&v).unwrap();
    assert_eq!(d.route.as_deref(), Some("multirate lifted subspace"));
    assert_eq!(d.details["lifting_period"], json!(3));
    assert_eq!(d.details["kalman_gain"], Value::Null);
    assert_eq!(d.to_value(), v);
}

/// An older file's entry of another form: read leniently it is kept
/// untyped and named; read strictly it is refused naming the entry.
#[test]
fn older_entries_are_kept_and_named() {
    let v = json!({
        "warnings": ["kept"],
        "feedback": "closed loop",
        "order_selection": {"values": [1.0]},
    });
    let d = Diagnostics::read(&v);
    assert_eq!(d.warnings, vec!["kept".to_string()]);
    assert!(d.feedback.is_none() && d.order_selection.is_none());
    assert_eq!(d.details["feedback"], json!("closed loop"));
    assert_eq!(d.unread.len(), 2, "{:?}", d.unread);
    assert!(
        d.unread
            .iter()
            .any(|u| u.starts_with("diagnostics.feedback:"))
    );
    assert!(
        d.unread
            .iter()
            .any(|u| u.starts_with("diagnostics.order_selection:"))
    );
    assert_eq!(d.to_value(), v);
    let e = Diagnostics::strict(&v).unwrap_err().to_string();
    assert!(e.starts_with("diagnostics:"), "{e}");
    // No diagnostics at all, and a file whose diagnostics are not an
    // object.
    assert_eq!(Diagnostics::read(&Value::Null), Diagnostics::default());
    let odd = Diagnostics::read(&json!("text"));
    assert_eq!(odd.details["diagnostics"], json!("text"));
    assert_eq!(odd.unread.len(), 1);
    assert!(Diagnostics::strict(&json!([1])).is_err());
}

use super::*;

/// A refinement stopped by its work bound says so (diagnostics and a
/// warning); the default bound lets this small record converge; a
/// bound that is not a positive number is refused. Order 4 on the
/// order-2 plant: at order 2 the subspace model with its checked gain
/// is already at the prediction-error optimum (no iteration to stop),
/// the two extra states take six iterations.
#[test]
fn work_bound_is_named_when_it_stops_the_refinement() {
    let d = tmp("refine-work");
    let (id, _) = single_rate_data(&d);
    let out = p(&d, "m.json");
    let base = [
        "identify",
        "--method",
        "n4sid",
        "--data",
        &id,
        "--inputs",
        "u1",
        "--outputs",
        "y1",
        "--order",
        "4",
        "--refine",
        "pem",
        "--out",
        &out,
    ];
    let warned = |f: &ModelFile| {
        f.diagnostics["warnings"].as_array().is_some_and(|w| {
            w.iter()
                .any(|m| m.as_str().unwrap_or("").contains("work bound"))
        })
    };
    let mut capped = base.to_vec();
    capped.extend(["--refine-max-work", "6e6"]);
    ok(&capped);
    let f = ModelFile::read(&out).unwrap();
    assert!(warned(&f), "{}", f.diagnostics);
    assert!(f.diagnostics["refinement"]["iteration_cap"].is_number());
    ok(&base);
    assert!(!warned(&ModelFile::read(&out).unwrap()));
    let mut zero = base.to_vec();
    zero.extend(["--refine-max-work", "0"]);
    let msg = fails(&zero, 2);
    assert!(msg.contains("--refine-max-work"), "{msg}");
}

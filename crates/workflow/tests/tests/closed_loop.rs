//! Closed-loop records: the IV route keeps D = 0 unless asked, brings an unstable
//! plant back, and the feedback test detects feedback in closed loop only.

use crate::common::*;
use lifted_workflow::{Method, Order, Record, Refine, WorkflowOptions, identify};
use nalgebra::DMatrix;

#[test]
fn the_closed_loop_iv_keeps_d_zero_unless_asked() {
    // The noise reaches u within the sample through the controller's
    // proportional term, so an estimated D takes it: with D free the
    // default refinement made D = −2.7 and the DC gain 5.42 against 6.154
    // (the Python new-user pass, 2026-11-27; the bias did not shrink from
    // 4e4 samples on). D = 0 by default, as PBSID's.
    let [u, y, r] = closed_loop_record(20_000, 0.3, 4);
    let rec = [Record {
        data: dataset(&u, &y),
        instrument: Some(r),
    }];
    let mut o = WorkflowOptions::default();
    o.identification.method = Method::Iv;
    o.identification.order = Order::Fixed(2);
    let fit = identify(&rec, &o).expect("identify");
    let m = &fit.file.model;
    assert!(m.d().iter().all(|&v| v == 0.0), "D = 0 by default");
    let dc = (m.c()
        * (DMatrix::identity(2, 2) - m.a())
            .try_inverse()
            .expect("I − A")
        * m.b())[0];
    // 6.154 the truth; 2 % is several times the spread over seeds at this
    // length (the D-free refinement missed by 12 %).
    assert!((dc / 6.153_846 - 1.0).abs() < 0.02, "DC gain {dc}");
    assert!(
        fit.file.diagnostics["feedthrough"]
            .as_str()
            .is_some_and(|s| s.starts_with("D = 0")),
        "{}",
        fit.file.diagnostics
    );
    o.identification.feedthrough = Some(true);
    let free = identify(&rec, &o).expect("identify with D");
    assert!(free.file.model.d()[0] != 0.0);
}

/// An unstable plant (pole 1.02) held by u = r − 0.5 y, identified by IV
/// with the reference r as instrument over 3000 samples: the output-error
/// regression refused the estimate ("estimated A is unstable") and the
/// route ended in an error; the model now comes back, its (B, D, x₀) from
/// the one-step predictor regression (named in the diagnostics), flagged
/// unstable.
#[test]
fn an_unstable_plant_in_a_loop_comes_back_from_the_iv_route() {
    let (u, y, r) = unstable_loop(3000, 4);
    let mut rec = Record::new(dataset(&u, &y));
    rec.instrument = Some(r.clone());
    let mut o = WorkflowOptions::default();
    o.identification.method = Method::Iv;
    o.identification.order = Order::Fixed(1);
    o.refinement.refine = Refine::None;
    let fit = identify(&[rec], &o).expect("identify");
    let d = &fit.file.diagnostics;
    let a = fit.file.model.a()[(0, 0)];
    assert!((a - 1.02).abs() < 0.01, "{a} {d}");
    assert!(
        d["bd_route"]
            .as_str()
            .is_some_and(|s| s.contains("predictor")),
        "{d}"
    );
    assert_eq!(d["stability"]["stable"], false, "{d}");
    assert!(d["warnings"].to_string().contains("unstable"), "{d}");
}

/// Issue 46: the feedback test says "closed loop" on a PI loop (the
/// controller acts on the noisy output) and warns that N4SID is biased
/// there, naming the consistent methods; on open-loop records (random
/// binary inputs, three fixed seeds) it finds no feedback and warns of
/// none (each input's test is at 1 %, so a false alarm somewhere among
/// these six tests had a 6 % chance; these seeds have none).
#[test]
fn feedback_is_detected_in_closed_loop_only() {
    let [u, y, _] = closed_loop_record(20_000, 0.3, 4);
    let rec = [Record {
        data: dataset(&u, &y),
        instrument: None,
    }];
    let mut o = WorkflowOptions::default();
    o.identification.order = Order::Fixed(2);
    o.refinement.refine = Refine::None;
    let fit = identify(&rec, &o).expect("identify");
    let d = &fit.file.diagnostics;
    assert_eq!(d["feedback"]["detected"], true, "{}", d["feedback"]);
    let warned = d["warnings"].as_array().is_some_and(|w| {
        w.iter().any(|s| {
            s.as_str()
                .is_some_and(|s| s.starts_with("closed loop detected") && s.contains("pbsid"))
        })
    });
    assert!(warned, "{}", d["warnings"]);
    for seed in [1, 2, 3] {
        let (u, y) = record(20_000, 0.1, seed);
        let rec = [Record {
            data: dataset(&u, &y),
            instrument: None,
        }];
        let fit = identify(&rec, &o).expect("identify");
        let d = &fit.file.diagnostics;
        assert_eq!(
            d["feedback"]["detected"], false,
            "seed {seed}: {}",
            d["feedback"]
        );
        assert!(
            d["feedback"]["verdict"]
                .as_str()
                .is_some_and(|v| v.starts_with("no input depends")),
            "{}",
            d["feedback"]
        );
    }
}

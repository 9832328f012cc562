use super::common::*;
use lifted_subspace::*;
use nalgebra::DVector;

#[test]
fn sixth_order_three_inputs_two_outputs_all_methods() {
    let g = random_system(7, &[0.9, -0.5, 0.3], &[(0.8, 0.6)], 3, 2, true);
    assert_eq!(g.order(), 5);
    let g = random_system(7, &[0.9, -0.5], &[(0.8, 0.6), (0.6, 1.9)], 3, 2, true);
    assert_eq!(g.order(), 6);
    let u = rbs(1, 2000, 3);
    let x0 = DVector::from_vec(vec![1.0, -2.0, 0.5, 0.0, 1.0, 3.0]);
    let y = sim(&g, &u, Some(&x0));
    for method in [Method::N4sid, Method::Moesp, Method::Cva] {
        let opts = SubspaceOptions {
            method,
            past: 8,
            future: 8,
            order: OrderSelection::Gap { max: 12 },
            ..Default::default()
        };
        let fit = identify(&[Experiment { u: &u, y: &y }], &opts).unwrap();
        assert_eq!(
            fit.diagnostics.order, 6,
            "{method:?} gap rule {:?}",
            fit.diagnostics.singular_values
        );
        let err = freq_error(&fit.model, &g);
        assert!(err < 1e-8, "{method:?}: frequency response error {err:e}");
        // the estimated initial state reproduces the record exactly,
        // about the returned operating point: y = y₀ + G(u − u₀) + CAᵗx₀
        let op = fit.operating_point.clone().expect("means removed");
        let dev = sim(&fit.model, &op.remove_input(&u).unwrap(), Some(&fit.x0[0]));
        let yhat = op.add_output(&dev).unwrap();
        assert!((yhat - &y).norm() / y.norm() < 1e-8);
    }
}

#[test]
fn two_records_are_merged() {
    let g = random_system(3, &[0.8, 0.4], &[(0.7, 0.9)], 2, 2, false);
    let (u1, u2) = (rbs(5, 300, 2), rbs(6, 250, 2));
    let y1 = sim(&g, &u1, None);
    let y2 = sim(&g, &u2, Some(&DVector::from_vec(vec![1.0, 1.0, -1.0, 0.5])));
    // The records start at rest in these units: x₀ of the first is 0
    // only for the data as given (with the means removed it is the
    // state of the deviation record).
    let opts = SubspaceOptions {
        order: OrderSelection::Fixed(4),
        past: 6,
        future: 6,
        feedthrough: Feedthrough::Zero,
        remove_means: false,
        ..Default::default()
    };
    let fit = identify(
        &[Experiment { u: &u1, y: &y1 }, Experiment { u: &u2, y: &y2 }],
        &opts,
    )
    .unwrap();
    assert!(freq_error(&fit.model, &g) < 1e-8);
    assert_eq!(fit.x0.len(), 2);
    assert!(fit.x0[0].norm() < 1e-8);
    assert!(fit.model.d().norm() == 0.0);
}

#[test]
fn streaming_chunk_size_does_not_change_the_result() {
    let g = random_system(4, &[0.95, 0.5], &[], 1, 1, false);
    let u = rbs(9, 1500, 1);
    let y = sim(&g, &u, None) + white(10, 1500, 1, 0.05);
    let fit = |chunk| {
        let opts = SubspaceOptions {
            order: OrderSelection::Fixed(2),
            chunk_rows: chunk,
            ..Default::default()
        };
        identify(&[Experiment { u: &u, y: &y }], &opts).unwrap()
    };
    let (a, b) = (fit(37), fit(100_000));
    for (x, y) in a
        .diagnostics
        .singular_values
        .iter()
        .zip(&b.diagnostics.singular_values)
    {
        assert!((x - y).abs() < 1e-10 * (1.0 + y.abs()));
    }
    assert!(freq_error(&a.model, &b.model) < 1e-8);
}

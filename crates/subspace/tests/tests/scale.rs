use super::common::*;
use lifted_subspace::*;
use nalgebra::DMatrix;

/// One identification route: (u, y) → model.
type Route = dyn Fn(&DMatrix<f64>, &DMatrix<f64>) -> lifted_lti::StateSpace;

fn poles(m: &lifted_lti::StateSpace) -> Vec<f64> {
    let mut p: Vec<f64> = m
        .poles()
        .unwrap()
        .iter()
        .flat_map(|z| [z.re, z.im.abs()])
        .collect();
    p.sort_by(|a, b| a.total_cmp(b));
    p
}

#[test]
fn every_route_is_invariant_to_the_units_of_u_and_y() {
    let g = random_system(41, &[0.9], &[(0.8, 0.4)], 1, 1, true);
    let u = rbs(41, 2000, 1);
    let y = sim(&g, &u, None) + white(42, 2000, 1, 0.05);
    let scales = [
        (1.0, 1e-7),
        (1e-150, 1.0),
        (1.0, 1e150),
        (1e139, 1e139),
        (1e-200, 1e-200),
        (1e8, 1e-8),
    ];
    let base = SubspaceOptions {
        order: OrderSelection::Fixed(3),
        past: 8,
        future: 8,
        ..Default::default()
    };
    let in_memory = |o: SubspaceOptions| -> Box<Route> {
        Box::new(move |u, y| identify(&[Experiment { u, y }], &o).unwrap().model)
    };
    let cva = SubspaceOptions {
        method: Method::Cva,
        ..base.clone()
    };
    let routes: Vec<(&str, Box<Route>)> = vec![
        ("N4SID", in_memory(base.clone())),
        (
            "MOESP shift invariance, QR",
            in_memory(SubspaceOptions {
                method: Method::Moesp,
                system: SystemEstimate::ShiftInvariance,
                compression: Compression::Qr,
                ..base.clone()
            }),
        ),
        (
            "CVA streaming",
            Box::new(move |u, y| {
                let mut st = StreamingIdentifier::new(1, 1, &cva).unwrap();
                st.push(u, y).unwrap();
                st.finish().unwrap().model
            }),
        ),
        (
            "IV",
            Box::new(|u, y| {
                let o = IvOptions {
                    order: OrderSelection::Fixed(3),
                    alpha: 6,
                    ..Default::default()
                };
                let rec = [IvExperiment {
                    u,
                    y,
                    instrument: None,
                }];
                iv_identify(&rec, &o).unwrap().model
            }),
        ),
    ];
    for (name, route) in &routes {
        let reference = route(&u, &y);
        let p0 = poles(&reference);
        let dc0 = reference.dc_gain().unwrap()[(0, 0)];
        for &(su, sy) in &scales {
            let m = route(&(&u * su), &(&y * sy));
            let p = poles(&m);
            for (a, b) in p.iter().zip(&p0) {
                assert!(
                    (a - b).abs() < 1e-9,
                    "{name} scales ({su:e}, {sy:e}): poles {p:?} vs {p0:?}"
                );
            }
            let dc = m.dc_gain().unwrap()[(0, 0)] * su / sy;
            assert!(
                (dc - dc0).abs() < 1e-9 * dc0.abs().max(1.0),
                "{name} ({su:e}, {sy:e}): DC {dc} vs {dc0}"
            );
        }
    }
}

#[test]
fn diagnostics_are_in_the_units_of_the_data() {
    let g = random_system(43, &[0.9, 0.5], &[], 1, 1, false);
    let u = rbs(43, 1500, 1);
    let y = sim(&g, &u, None) + white(44, 1500, 1, 0.05);
    let opts = SubspaceOptions {
        order: OrderSelection::Fixed(2),
        past: 6,
        future: 6,
        ..Default::default()
    };
    let a = identify(&[Experiment { u: &u, y: &y }], &opts).unwrap();
    let y2 = &y * 1e6;
    let b = identify(&[Experiment { u: &u, y: &y2 }], &opts).unwrap();
    for (s1, s2) in a
        .diagnostics
        .singular_values
        .iter()
        .zip(&b.diagnostics.singular_values)
    {
        assert!((s2 / s1 - 1e6).abs() < 1e-3, "{s1} {s2}");
    }
    let (ra, rb) = (&a.noise.as_ref().unwrap().r, &b.noise.as_ref().unwrap().r);
    assert!((rb[(0, 0)] / ra[(0, 0)] - 1e12).abs() < 1e3);
    let (ka, kb) = (a.kalman_gain.unwrap(), b.kalman_gain.unwrap());
    // K maps innovations (y units) to states: K·C is invariant.
    let kca = &ka * a.model.c();
    let kcb = &kb * b.model.c();
    assert!((kca.trace() - kcb.trace()).abs() < 1e-8, "{kca} {kcb}");
}

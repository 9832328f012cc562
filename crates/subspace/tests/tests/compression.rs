//! The correlation/Cholesky compression against the QR reference, its
//! automatic fallback and the streaming entry point.
use super::common::{random_system, rbs, white};
use lifted_subspace::{
    BdEstimate, Compression, Error, Experiment, InitialState, Method, OrderSelection,
    StreamingIdentifier, SubspaceOptions, compress_hankel, identify,
};
use nalgebra::DMatrix;

/// 2-input 2-output order-4 data with output noise `sd`.
fn data(n: usize, sd: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let g = random_system(11, &[0.7, -0.5], &[(0.92, 0.22)], 2, 2, false);
    let u = rbs(12, n, 2);
    let y = g.lsim(&u, None, None).unwrap().y + white(13, n, 2, sd);
    (u, y)
}

fn opts(method: Method, compression: Compression) -> SubspaceOptions {
    SubspaceOptions {
        method,
        order: OrderSelection::Fixed(4),
        past: 8,
        future: 8,
        compression,
        ..Default::default()
    }
}

fn sorted_poles(m: &lifted_lti::StateSpace) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = m.poles().unwrap().iter().map(|z| (z.re, z.im)).collect();
    p.sort_by(|a, b| a.partial_cmp(b).unwrap());
    p
}

#[test]
fn correlation_equals_the_qr_reference_on_well_conditioned_data() {
    let (u, y) = data(5000, 0.1);
    let e = [Experiment { u: &u, y: &y }];
    for method in [Method::N4sid, Method::Moesp, Method::Cva] {
        let qr = identify(&e, &opts(method, Compression::Qr)).unwrap();
        let co = identify(&e, &opts(method, Compression::Auto)).unwrap();
        assert_eq!(co.diagnostics.compression.used, Compression::Correlation);
        assert!(co.diagnostics.compression.fallback.is_none());
        assert_eq!(qr.diagnostics.compression.used, Compression::Qr);
        // Well conditioned: rcond far above the fallback threshold.
        assert!(
            co.diagnostics.compression.rcond > 1e-6,
            "{}",
            co.diagnostics.compression.rcond
        );
        // Singular values to 1e-8 relative (issue 11 target).
        let s1 = &qr.diagnostics.singular_values;
        let s2 = &co.diagnostics.singular_values;
        for (a, b) in s1.iter().zip(s2) {
            assert!((a - b).abs() <= 1e-8 * a, "{method:?}: {a} vs {b}");
        }
        // Identified poles identical to the QR path to 1e-8.
        for (p, q) in sorted_poles(&qr.model).iter().zip(sorted_poles(&co.model)) {
            assert!(
                (p.0 - q.0).hypot(p.1 - q.1) < 1e-8,
                "{method:?}: {p:?} vs {q:?}"
            );
        }
    }
}

#[test]
fn ill_conditioned_data_fall_back_to_the_qr_and_say_so() {
    // Noise-free outputs: the Hankel rows of [u; y] are linearly
    // dependent (order 4 < rows), H Hᵀ is singular up to rounding.
    let (u, y) = data(3000, 0.0);
    let e = [Experiment { u: &u, y: &y }];
    let fit = identify(&e, &opts(Method::N4sid, Compression::Auto)).unwrap();
    let rep = &fit.diagnostics.compression;
    assert_eq!(rep.requested, Compression::Auto);
    assert_eq!(rep.used, Compression::Qr);
    let why = rep.fallback.as_deref().unwrap_or("");
    assert!(
        why.contains("positive definite") || why.contains("reciprocal condition"),
        "{why}"
    );
    // The QR answer is still exact.
    let g = random_system(11, &[0.7, -0.5], &[(0.92, 0.22)], 2, 2, false);
    let want = sorted_poles(&g);
    for (p, q) in want.iter().zip(sorted_poles(&fit.model)) {
        assert!((p.0 - q.0).hypot(p.1 - q.1) < 1e-6, "{p:?} vs {q:?}");
    }
    // Forcing the correlations reports the named error.
    assert!(matches!(
        compress_hankel(&e, 8, 8, Compression::Correlation, 1),
        Err(Error::IllConditionedCorrelation { .. })
    ));
    // Nearly noise-free (1e-7): definite but too ill conditioned.
    let (u, y) = data(3000, 1e-7);
    let e = [Experiment { u: &u, y: &y }];
    let fit = identify(&e, &opts(Method::N4sid, Compression::Auto)).unwrap();
    assert_eq!(fit.diagnostics.compression.used, Compression::Qr);
    assert!(fit.diagnostics.compression.fallback.is_some());
}

#[test]
fn streaming_equals_in_memory_and_two_threads_equal_one() {
    let (u, y) = data(7000, 0.1);
    let e = [Experiment { u: &u, y: &y }];
    let base = SubspaceOptions {
        initial_state: InitialState::Zero,
        ..opts(Method::N4sid, Compression::Auto)
    };
    let whole = identify(&e, &base).unwrap();
    for (block, threads) in [(1000usize, 1usize), (333, 2), (7000, 2)] {
        let o = SubspaceOptions {
            threads,
            ..base.clone()
        };
        let mut id = StreamingIdentifier::new(2, 2, &o).unwrap();
        let mut s = 0;
        while s < 7000 {
            let len = block.min(7000 - s);
            id.push(&u.rows(s, len).into_owned(), &y.rows(s, len).into_owned())
                .unwrap();
            s += len;
        }
        assert_eq!(id.columns(), 7000 - 16 + 1);
        let fit = id.finish().unwrap();
        assert_eq!(fit.diagnostics.columns, whole.diagnostics.columns);
        for (a, b) in whole
            .diagnostics
            .singular_values
            .iter()
            .zip(&fit.diagnostics.singular_values)
        {
            assert!((a - b).abs() <= 1e-9 * a, "block {block}: {a} vs {b}");
        }
        for (p, q) in sorted_poles(&whole.model)
            .iter()
            .zip(sorted_poles(&fit.model))
        {
            assert!((p.0 - q.0).hypot(p.1 - q.1) < 1e-9);
        }
        assert_eq!(fit.x0.len(), 1);
    }
}

#[test]
fn streaming_records_and_rejections() {
    let (u, y) = data(4000, 0.1);
    let e = [
        Experiment {
            u: &u.rows(0, 2500).into_owned(),
            y: &y.rows(0, 2500).into_owned(),
        },
        Experiment {
            u: &u.rows(2500, 1500).into_owned(),
            y: &y.rows(2500, 1500).into_owned(),
        },
    ];
    let o = SubspaceOptions {
        initial_state: InitialState::Zero,
        ..opts(Method::Moesp, Compression::Qr)
    };
    let merged = identify(&e, &o).unwrap();
    let mut id = StreamingIdentifier::new(2, 2, &o).unwrap();
    for r in &e {
        id.push(r.u, r.y).unwrap();
        id.end_record();
    }
    let fit = id.finish().unwrap();
    assert_eq!(fit.diagnostics.columns, merged.diagnostics.columns);
    assert_eq!(fit.x0.len(), 2);
    for (a, b) in merged
        .diagnostics
        .singular_values
        .iter()
        .zip(&fit.diagnostics.singular_values)
    {
        assert!((a - b).abs() <= 1e-9 * a);
    }
    // Rejected: wrong block shape, NaN, options that need the records,
    // too few samples, ill-conditioned data with Auto.
    let mut id = StreamingIdentifier::new(2, 2, &o).unwrap();
    assert!(matches!(
        id.push(&DMatrix::zeros(5, 1), &DMatrix::zeros(5, 2)),
        Err(Error::DimensionMismatch { .. })
    ));
    let mut bad = y.rows(0, 10).into_owned();
    bad[(3, 1)] = f64::NAN;
    assert!(matches!(
        id.push(&u.rows(0, 10).into_owned(), &bad),
        Err(Error::NonFinite { .. })
    ));
    id.push(&u.rows(0, 20).into_owned(), &y.rows(0, 20).into_owned())
        .unwrap();
    assert!(matches!(id.finish(), Err(Error::HorizonTooLong { .. })));
    let si = SubspaceOptions {
        bd: BdEstimate::OutputError,
        ..o.clone()
    };
    assert!(matches!(
        StreamingIdentifier::new(2, 2, &si),
        Err(Error::InvalidOption { .. })
    ));
    assert!(matches!(
        StreamingIdentifier::new(0, 2, &o),
        Err(Error::DimensionMismatch { .. })
    ));
    let (u0, y0) = data(3000, 0.0);
    let mut id = StreamingIdentifier::new(2, 2, &opts(Method::N4sid, Compression::Auto)).unwrap();
    id.push(&u0, &y0).unwrap();
    assert!(matches!(
        id.finish(),
        Err(Error::IllConditionedCorrelation { .. })
    ));
}

//! Mergeable partial compressions (issue 29): a record compressed in pieces
//! (as on the workers of a cluster), the pieces merged in an arbitrary tree
//! and identified, against the streaming identification of the whole
//! record in one process.

use lifted_lti::StateSpace;
use lifted_subspace::{
    CompressedRecords, CompressionPlan, Error, Method, OrderSelection, OutputErrorStream,
    RecordPiece, StreamingIdentifier, SubspaceModel, SubspaceOptions,
};
use nalgebra::DMatrix;

use crate::common::{freq_error, random_system, rbs, sim, white};

/// A 2×2 order-4 plant, `n` samples with offsets and output noise.
fn record(seed: u64, n: usize) -> (StateSpace, DMatrix<f64>, DMatrix<f64>) {
    let g = random_system(seed, &[0.9, 0.5], &[(0.8, 0.6)], 2, 2, true);
    let u = rbs(seed + 1, n, 2).add_scalar(0.3);
    let y = sim(&g, &u, None) + white(seed + 2, n, 2, 0.05);
    (g, u, y.add_scalar(2.0))
}

fn opts(method: Method) -> SubspaceOptions {
    SubspaceOptions {
        method,
        order: OrderSelection::Fixed(4),
        ..Default::default()
    }
}

/// Both passes of the streaming identifier over `records`, pushed in
/// blocks of `block` rows (the plan's first block is the first push).
fn streamed(
    records: &[(DMatrix<f64>, DMatrix<f64>)],
    o: &SubspaceOptions,
    block: usize,
) -> SubspaceModel {
    let mut sid = StreamingIdentifier::new(2, 2, o).unwrap();
    for (u, y) in records {
        for s in (0..u.nrows()).step_by(block) {
            let len = block.min(u.nrows() - s);
            sid.push(&u.rows(s, len).into_owned(), &y.rows(s, len).into_owned())
                .unwrap();
        }
        sid.end_record();
    }
    let first = sid.finish_subspace().unwrap();
    let mut bd = first.regression().unwrap();
    for (u, y) in records {
        bd.push(u, y).unwrap();
        bd.end_record().unwrap();
    }
    first.finish(bd).unwrap()
}

/// Pieces of rows `cuts[i]..cuts[i+1]`.
fn pieces(
    plan: &CompressionPlan,
    u: &DMatrix<f64>,
    y: &DMatrix<f64>,
    cuts: &[usize],
) -> Vec<RecordPiece> {
    cuts.windows(2)
        .map(|w| {
            let len = w[1] - w[0];
            plan.compress(
                &u.rows(w[0], len).into_owned(),
                &y.rows(w[0], len).into_owned(),
                1,
            )
            .unwrap()
        })
        .collect()
}

/// Merges adjacent pieces in a balanced tree (the order Dask's tree
/// reduction uses), then through the bytes as between processes.
fn tree(mut ps: Vec<RecordPiece>) -> RecordPiece {
    while ps.len() > 1 {
        let mut next = Vec::new();
        let mut it = ps.into_iter();
        while let Some(a) = it.next() {
            match it.next() {
                Some(b) => {
                    let a = RecordPiece::from_bytes(&a.to_bytes().unwrap()).unwrap();
                    next.push(a.append(b).unwrap());
                }
                None => next.push(a),
            }
        }
        ps = next;
    }
    ps.pop().unwrap()
}

/// The identification from the merged records; the regression's second
/// pass visits each record in shards of `shard` rows, its state passed
/// between them as bytes (as from worker to worker).
fn finish(
    c: CompressedRecords,
    o: &SubspaceOptions,
    records: &[(DMatrix<f64>, DMatrix<f64>)],
    shard: usize,
) -> SubspaceModel {
    let c = CompressedRecords::from_bytes(&c.to_bytes().unwrap()).unwrap();
    let first = c.identify(o).unwrap();
    let mut bd = first.regression().unwrap();
    for (u, y) in records {
        for s in (0..u.nrows()).step_by(shard) {
            let len = shard.min(u.nrows() - s);
            bd.push(&u.rows(s, len).into_owned(), &y.rows(s, len).into_owned())
                .unwrap();
            bd = OutputErrorStream::from_bytes(&bd.to_bytes().unwrap()).unwrap();
        }
        bd.end_record().unwrap();
    }
    first.finish(bd).unwrap()
}

fn poles_close(a: &SubspaceModel, b: &SubspaceModel, tol: f64) {
    let mut pa = a.model.poles().unwrap();
    let mut pb = b.model.poles().unwrap();
    let key = |z: &num_complex::Complex64| {
        (z.re * 1e6).round() as i64 * 10_000_000 + (z.im * 1e6).round() as i64
    };
    pa.sort_by_key(key);
    pb.sort_by_key(key);
    for (x, y) in pa.iter().zip(&pb) {
        assert!((x - y).norm() < tol, "poles {pa:?} vs {pb:?}");
    }
}

#[test]
fn merged_pieces_give_the_streamed_model() {
    let (g, u, y) = record(21, 20_000);
    // Uneven pieces, two shorter than s − 1 = 19 samples (a piece that is
    // all head and tail), merged in a tree that is not left to right.
    let cuts = [0, 5000, 5003, 9000, 9010, 14_321, 14_330, 20_000];
    for method in [Method::N4sid, Method::Moesp, Method::Cva] {
        let o = opts(method);
        let whole = streamed(&[(u.clone(), y.clone())], &o, 5000);
        let plan = CompressionPlan::from_first_block(
            &u.rows(0, 5000).into_owned(),
            &y.rows(0, 5000).into_owned(),
            &o,
        )
        .unwrap();
        let piece = tree(pieces(&plan, &u, &y, &cuts));
        assert_eq!(piece.len(), 20_000);
        let merged = finish(piece.close().unwrap(), &o, &[(u.clone(), y.clone())], 3001);
        // Same compression up to the rounding of the summation order; the
        // SVD and the regression on top keep it near 1e-12: 1e-10 leaves
        // two digits of margin and still fails on any missed product.
        poles_close(&merged, &whole, 1e-10);
        let fr = freq_error(&merged.model, &whole.model);
        assert!(
            fr < 1e-10,
            "{method:?}: frequency response differs by {fr:e}"
        );
        let op_m = merged.operating_point.clone().unwrap();
        let op_w = whole.operating_point.clone().unwrap();
        for (a, b) in op_m
            .y0
            .iter()
            .chain(&op_m.u0)
            .zip(op_w.y0.iter().chain(&op_w.u0))
        {
            assert!((a - b).abs() < 1e-10, "operating point {a} vs {b}");
        }
        // And the model is the plant's (0.05 noise on 2e4 samples).
        assert!(freq_error(&merged.model, &g) < 0.05);
    }
}

#[test]
fn records_merge_in_any_order_of_closing() {
    let (_, u1, y1) = record(31, 6000);
    let (_, u2, y2) = record(31, 9000);
    let y2 = y2.add_scalar(0.5);
    let o = opts(Method::N4sid);
    let records = [(u1.clone(), y1.clone()), (u2.clone(), y2.clone())];
    let whole = streamed(&records, &o, 6000);
    let plan = CompressionPlan::from_first_block(&u1, &y1, &o).unwrap();
    let r1 = tree(pieces(&plan, &u1, &y1, &[0, 2500, 6000]))
        .close()
        .unwrap();
    let r2 = tree(pieces(&plan, &u2, &y2, &[0, 10, 4000, 9000]))
        .close()
        .unwrap();
    let c = r1.merge(r2).unwrap();
    assert_eq!(c.records(), &[6000, 9000]);
    let merged = finish(c, &o, &records, 5000);
    poles_close(&merged, &whole, 1e-10);
    assert!(freq_error(&merged.model, &whole.model) < 1e-10);
}

#[test]
fn mismatched_plans_options_and_bytes_are_named_errors() {
    let (_, u, y) = record(41, 3000);
    let o = opts(Method::N4sid);
    let plan = CompressionPlan::from_first_block(&u, &y, &o).unwrap();
    let other = CompressionPlan::from_first_block(&(&u * 100.0), &y, &o).unwrap();
    let a = plan.compress(&u, &y, 1).unwrap();
    let b = other.compress(&u, &y, 1).unwrap();
    assert!(matches!(
        a.clone().append(b),
        Err(Error::InvalidOption { what: "piece", .. })
    ));
    let c = a.clone().close().unwrap();
    let longer = SubspaceOptions {
        past: 12,
        ..o.clone()
    };
    assert!(matches!(
        c.clone().identify(&longer),
        Err(Error::InvalidOption {
            what: "options",
            ..
        })
    ));
    let mut bytes = a.to_bytes().unwrap();
    bytes.truncate(bytes.len() / 2);
    assert!(matches!(
        RecordPiece::from_bytes(&bytes),
        Err(Error::InvalidOption { .. })
    ));
    assert!(CompressedRecords::from_bytes(b"not cbor").is_err());
    // Too few samples for the horizons: the named error of the streaming route.
    let short = plan
        .compress(&u.rows(0, 30).into_owned(), &y.rows(0, 30).into_owned(), 1)
        .unwrap();
    assert!(matches!(
        short.close().unwrap().identify(&o),
        Err(Error::HorizonTooLong { .. })
    ));
    // Wrong channel count and non-finite data.
    assert!(matches!(
        plan.compress(&u.columns(0, 1).into_owned(), &y, 1),
        Err(Error::DimensionMismatch { .. })
    ));
    let mut bad = y.clone();
    bad[(7, 1)] = f64::NAN;
    assert!(matches!(
        plan.compress(&u, &bad, 1),
        Err(Error::NonFinite { .. })
    ));
}

/// The separable steps (issue 26): one compression, every order and
/// method, each fit the model `identify` returns with those options.
#[test]
fn one_compression_serves_every_order_and_method() {
    use lifted_subspace::{CompressedData, Experiment, identify};
    let (_, u, y) = record(51, 4000);
    let ex = [Experiment { u: &u, y: &y }];
    let base = SubspaceOptions::default();
    let data = CompressedData::new(&ex, &base).unwrap();
    assert!(data.operating_point().is_some());
    for method in [Method::N4sid, Method::Moesp, Method::Cva] {
        let sv = data.singular_values(method).unwrap();
        for n in [2, 4, 6] {
            let o = SubspaceOptions {
                method,
                order: OrderSelection::Fixed(n),
                ..base.clone()
            };
            let a = data.identify(&o).unwrap();
            let b = identify(&ex, &o).unwrap();
            // The same computation on the same factor: equal bits.
            assert_eq!(a.model, b.model, "{method:?} order {n}");
            assert_eq!(a.operating_point, b.operating_point);
            assert_eq!(a.diagnostics.singular_values, sv);
        }
    }
    let other = SubspaceOptions { past: 7, ..base };
    assert!(matches!(
        data.identify(&other),
        Err(Error::InvalidOption {
            what: "options",
            ..
        })
    ));
}

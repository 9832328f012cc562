//! Checks of records and options before anything is allocated: shapes,
//! finiteness (split over threads for large records), horizons, orders,
//! instruments, thread counts. [`validate`] is public: the crates above
//! (`lifted-pem`) check experiments with the same rules and errors.

use nalgebra::DMatrix;

use crate::error::{Error, Result, check_data, non_finite_at};
use crate::hankel::HankelLayout;
use crate::model::Experiment;
use crate::options::{OrderSelection, SubspaceOptions};
use crate::order::OrderCriterion;

/// Validates the records; returns (n_u, n_y, total samples).
pub fn validate(experiments: &[Experiment<'_>]) -> Result<(usize, usize, usize)> {
    validate_on(experiments, 1)
}

/// [`validate`] with the finiteness scan split over `threads` threads.
pub(crate) fn validate_on(
    experiments: &[Experiment<'_>],
    threads: usize,
) -> Result<(usize, usize, usize)> {
    let dims = validate_shapes(experiments)?;
    for e in experiments {
        check_data_on("u", e.u, threads)?;
        check_data_on("y", e.y, threads)?;
    }
    Ok(dims)
}

/// The shape checks of [`validate`] without the finiteness scan (for data
/// already scanned, or derived from scanned data by finite operations).
pub(crate) fn validate_shapes(experiments: &[Experiment<'_>]) -> Result<(usize, usize, usize)> {
    let first = experiments.first().ok_or(Error::NoData)?;
    let (nu, ny) = (first.u.ncols(), first.y.ncols());
    if nu == 0 || ny == 0 {
        return Err(Error::DimensionMismatch {
            what: "u, y",
            expected: "at least one input and one output".into(),
            got: format!("{nu} inputs, {ny} outputs"),
        });
    }
    let mut total = 0;
    for e in experiments {
        check_record_shape("experiment (u, y)", "N", e.u, e.y, nu, ny)?;
        total += e.u.nrows();
    }
    Ok((nu, ny, total))
}

/// Entries below which the finiteness scan stays on the calling thread.
const PARALLEL_SCAN_MIN: usize = 1 << 18;

/// [`check_data`] with the scan split into `threads` contiguous ranges of
/// the column-major storage (std scoped threads) for large matrices; the
/// first non-finite entry reported is the same as the sequential scan's.
pub(crate) fn check_data_on(what: &'static str, m: &DMatrix<f64>, threads: usize) -> Result<()> {
    let v = m.as_slice();
    if threads <= 1 || v.len() < PARALLEL_SCAN_MIN {
        return check_data(what, m);
    }
    let per = v.len().div_ceil(threads);
    let hits: Vec<Option<Option<usize>>> = std::thread::scope(|scope| {
        let handles: Vec<_> = v
            .chunks(per)
            .enumerate()
            .skip(1)
            .map(|(i, c)| {
                scope
                    .spawn(move || lifted_linalg::kernels::first_non_finite(c).map(|j| i * per + j))
            })
            .collect();
        let first = lifted_linalg::kernels::first_non_finite(&v[..per.min(v.len())]);
        std::iter::once(Some(first))
            .chain(handles.into_iter().map(|h| h.join().ok()))
            .collect()
    });
    // A range whose thread failed is scanned again here (never skipped).
    let Some(hits) = hits.into_iter().collect::<Option<Vec<Option<usize>>>>() else {
        return check_data(what, m);
    };
    match hits.into_iter().flatten().next() {
        Some(i) => Err(non_finite_at(what, m, i)),
        None => Ok(()),
    }
}

/// [`Error::DimensionMismatch`] for `what` unless `u` is N×`nu` and `y` N×`ny`
/// for some N (named `rows` in the message).
pub(crate) fn check_record_shape(
    what: &'static str,
    rows: &str,
    u: &DMatrix<f64>,
    y: &DMatrix<f64>,
    nu: usize,
    ny: usize,
) -> Result<()> {
    if u.ncols() != nu || y.ncols() != ny || u.nrows() != y.nrows() {
        return Err(Error::DimensionMismatch {
            what,
            expected: format!("{rows}×{nu} and {rows}×{ny}"),
            got: format!(
                "{}x{} and {}x{}",
                u.nrows(),
                u.ncols(),
                y.nrows(),
                y.ncols()
            ),
        });
    }
    Ok(())
}

/// An instrument signal `f` of the shape of its record's input `u`, finite.
pub(crate) fn check_instrument(f: &DMatrix<f64>, u: &DMatrix<f64>) -> Result<()> {
    if f.shape() != u.shape() {
        return Err(Error::DimensionMismatch {
            what: "instrument",
            expected: format!("{}x{}", u.nrows(), u.ncols()),
            got: format!("{}x{}", f.nrows(), f.ncols()),
        });
    }
    check_data("instrument", f)
}

/// [`Error::HorizonTooLong`] when `experiments` give fewer Hankel columns
/// than the k = (p + f)(n_u + n_y) rows of horizons (p, f). Checked before
/// the memory budget ([`check_options`]), so that a horizon both too long
/// for the records and too large for memory is refused for the first
/// reason, which names the records' length. Saturating arithmetic;
/// horizons that [`check_options`] refuses (p = 0, f < 2) pass here.
pub(crate) fn check_length(
    experiments: &[Experiment<'_>],
    past: usize,
    future: usize,
    nu: usize,
    ny: usize,
) -> Result<()> {
    if past == 0 || future < 2 {
        return Ok(());
    }
    let span = past.saturating_add(future);
    let k = span.saturating_mul(nu + ny);
    let columns: usize = experiments
        .iter()
        .map(|e| (e.u.nrows() + 1).saturating_sub(span))
        .sum();
    if columns < k {
        return Err(Error::HorizonTooLong {
            past,
            future,
            n_samples: experiments.iter().map(|e| e.u.nrows()).sum(),
            min_samples: k.saturating_add((span - 1).saturating_mul(experiments.len())),
        });
    }
    Ok(())
}

/// Checks horizons, sample period and a fixed order; returns the Hankel layout.
pub(crate) fn check_options(nu: usize, ny: usize, opts: &SubspaceOptions) -> Result<HankelLayout> {
    let (p, f) = (opts.past, opts.future);
    if p == 0 {
        return Err(Error::InvalidHorizon {
            what: "past",
            value: p,
            reason: "must be at least 1".into(),
        });
    }
    if f < 2 {
        return Err(Error::InvalidHorizon {
            what: "future",
            value: f,
            reason: "must be at least 2 (shift invariance needs two block rows)".into(),
        });
    }
    if !(opts.ts.is_finite() && opts.ts > 0.0) {
        return Err(Error::InvalidOption {
            what: "ts",
            reason: format!("sample period must be positive and finite, got {}", opts.ts),
        });
    }
    if !(opts.marginal_tolerance.is_finite() && opts.marginal_tolerance >= 0.0) {
        return Err(Error::InvalidOption {
            what: "marginal_tolerance",
            reason: format!(
                "must be finite and non-negative, got {}",
                opts.marginal_tolerance
            ),
        });
    }
    crate::budget::check_hankel(p, f, nu, ny, opts.compression, opts.chunk_rows)?;
    let layout = HankelLayout {
        past: p,
        future: f,
        nu,
        ny,
    };
    let max_order = (f - 1) * ny;
    check_order(opts.order, opts.order_criterion, max_order)?;
    Ok(layout)
}

/// A fixed order, or the `max` of a criterion other than the gap rule, must
/// lie in 1..=`max_order` ([`Error::OrderTooLarge`]); the gap rule caps its
/// `max` instead (unchanged behaviour).
pub(crate) fn check_order(
    order: OrderSelection,
    criterion: OrderCriterion,
    max_order: usize,
) -> Result<()> {
    let n = match order {
        OrderSelection::Fixed(n) => n,
        OrderSelection::Gap { max } if criterion != OrderCriterion::Gap => max,
        OrderSelection::Gap { .. } => return Ok(()),
    };
    if n == 0 || n > max_order {
        return Err(Error::OrderTooLarge {
            order: n,
            max: max_order,
        });
    }
    Ok(())
}

/// The candidate orders 1..=cap of the order report: `max` of
/// [`OrderSelection::Gap`] (capped at `max_order` for the gap rule,
/// checked by [`check_order`] otherwise), min(`max_order`, 10) for a fixed
/// order.
pub(crate) fn candidate_orders(order: OrderSelection, max_order: usize) -> usize {
    match order {
        OrderSelection::Gap { max } => max.min(max_order),
        OrderSelection::Fixed(_) => max_order.min(10),
    }
}

/// Threads for the correlation kernel: 0 = all available, else capped at
/// the available parallelism ([`crate::budget::threads`]).
pub(crate) fn thread_count(threads: usize) -> usize {
    crate::budget::threads(threads)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parallel_finiteness_scan_names_the_same_entry() {
        let n = PARALLEL_SCAN_MIN / 2 + 17;
        let mut m = DMatrix::from_fn(n, 3, |i, j| (i as f64 * 0.37 + j as f64).sin());
        assert!(check_data_on("y", &m, 2).is_ok());
        // Several bad entries, in different thread ranges: the first in
        // storage order (column-major) is reported, as by the serial scan.
        for (r, c, v) in [
            (n - 1, 2, f64::NAN),
            (5, 2, f64::INFINITY),
            (n - 3, 1, f64::NAN),
        ] {
            m[(r, c)] = v;
            for threads in [1, 2, 3, 8] {
                let got = check_data_on("y", &m, threads).unwrap_err().to_string();
                let want = check_data("y", &m).unwrap_err().to_string();
                assert_eq!(got, want, "{threads} threads");
            }
        }
        assert!(
            check_data("y", &m)
                .unwrap_err()
                .to_string()
                .contains(&format!("{}", n - 3))
        );
    }
}

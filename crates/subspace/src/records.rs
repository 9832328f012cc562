//! The experiments as the subspace routes take them: owned copies less
//! their means, regression records, and step 1 of [`crate::identify`] (the
//! checks, the data scales and the compressed Hankel factor).

use lifted_lti::OperatingPoint;

use nalgebra::DMatrix;

use crate::checks::{check_options, thread_count, validate, validate_shapes};
use crate::error::{Error, Result};
use crate::estimated::Record;
use crate::hankel::{HankelFactor, HankelLayout, compress};
use crate::model::Experiment;
use crate::numerics::{Scale, pow4_scale_counted};
use crate::options::SubspaceOptions;

/// Records as owned (u, y) pairs.
pub type OwnedRecords = Vec<(DMatrix<f64>, DMatrix<f64>)>;

/// The pooled per-channel means of the records and the records less them.
/// O(N (n_u + n_y)) time and a copy of the data.
pub(crate) fn remove_means(
    experiments: &[Experiment<'_>],
) -> Result<(OperatingPoint, OwnedRecords)> {
    let us: Vec<&DMatrix<f64>> = experiments.iter().map(|e| e.u).collect();
    let ys: Vec<&DMatrix<f64>> = experiments.iter().map(|e| e.y).collect();
    let op = OperatingPoint::means(&us, &ys)?;
    let centered = experiments
        .iter()
        .map(|e| op.to_deviations(e.u, e.y))
        .collect::<lifted_lti::Result<Vec<_>>>()?;
    Ok((op, centered))
}

/// Step 1 of [`crate::identify`] on records already scanned (or centred from
/// scanned ones): the shape and option checks, the horizon against the
/// records (J ≥ k Hankel columns), the data scales and the compressed
/// factor of the scaled data.
pub(crate) fn compressed(
    experiments: &[Experiment<'_>],
    opts: &SubspaceOptions,
) -> Result<(HankelLayout, HankelFactor, Scale)> {
    let (nu, ny, total) = validate_shapes(experiments)?;
    crate::checks::check_length(experiments, opts.past, opts.future, nu, ny)?;
    let layout = check_options(nu, ny, opts)?;
    let (p, f, k) = (layout.past, layout.future, layout.nrows());
    let columns: usize = experiments
        .iter()
        .map(|e| layout.columns(e.u.nrows()))
        .sum();
    if columns < k {
        // J ≥ k columns are needed for a full-rank k×k factor.
        let min_samples = k + (p + f - 1) * experiments.len();
        return Err(Error::HorizonTooLong {
            past: p,
            future: f,
            n_samples: total,
            min_samples,
        });
    }
    let recs: Vec<(&DMatrix<f64>, &DMatrix<f64>)> =
        experiments.iter().map(|e| (e.u, e.y)).collect();
    let (scale, finite) = data_scale(experiments);
    if finite < total * (nu + ny) {
        // A non-finite entry the caller's scan could not see (a centred
        // copy overflowed): the full scan names it.
        validate(experiments)?;
    }
    let factor = compress(
        &recs,
        &layout,
        opts.compression,
        opts.chunk_rows,
        thread_count(opts.threads),
        scale,
        opts.remove_means,
    )?;
    Ok((layout, factor, scale))
}

/// The longest horizon s ≤ `max` (past = future = s, s ≥ 2) for which
/// records of `lengths` samples of `width` = n_u + n_y channels give a
/// block-Hankel data matrix with at least as many columns as rows (J ≥ k,
/// the condition [`crate::identify`] checks before compressing); `None`
/// when not even s = 2 does. For lifted records pass the frame counts and
/// the lifted widths. O(min(max, N) · records) for records of at most N
/// samples (a record gives no column at 2s > N, so `max` may be anything).
pub fn longest_horizon(lengths: &[usize], width: usize, max: usize) -> Option<usize> {
    let top = max.min(lengths.iter().copied().max().unwrap_or(0) / 2);
    (2..=top).rev().find(|&s| {
        let layout = HankelLayout {
            past: s,
            future: s,
            nu: width,
            ny: 0,
        };
        let columns: usize = lengths.iter().map(|&n| layout.columns(n)).sum();
        columns >= layout.nrows()
    })
}

/// The power-of-4 scales of the experiments' inputs and outputs
/// (`numerics::pow4_scale_counted`), and how many of their entries are
/// finite.
pub(crate) fn data_scale(experiments: &[Experiment<'_>]) -> (Scale, usize) {
    let us: Vec<&DMatrix<f64>> = experiments.iter().map(|e| e.u).collect();
    let ys: Vec<&DMatrix<f64>> = experiments.iter().map(|e| e.y).collect();
    let ((u, finite_u), (y, finite_y)) = (pow4_scale_counted(&us), pow4_scale_counted(&ys));
    (Scale { u, y }, finite_u + finite_y)
}

/// The experiments as regression records (no instrument).
pub(crate) fn records_of<'a>(experiments: &[Experiment<'a>]) -> Vec<Record<'a>> {
    experiments
        .iter()
        .map(|e| Record {
            u: e.u,
            y: e.y,
            instrument: None,
        })
        .collect()
}

/// The data records when they are available (in-memory identification),
/// else an error naming the option that needs them (streaming).
pub(crate) fn need_records<'r, 'a>(records: Option<&'r [Record<'a>]>) -> Result<&'r [Record<'a>]> {
    records.ok_or_else(|| Error::InvalidOption {
        what: "system",
        reason: "streaming identification keeps only the compressed data: (B, D) by output-error \
                 regression (BdEstimate::OutputError) needs the records; use BdEstimate::Projection \
                 or Auto"
            .into(),
    })
}

/// Rows per block when a whole record in memory is fed to a block stream
/// ([`crate::PieceStream`], [`crate::ShardScan`]): the streamed route's
/// block, so the streams' working buffers stay in cache instead of
/// growing to the record's size.
pub(crate) const FEED_ROWS: usize = 1 << 16;

/// The (first row, rows) of the blocks of [`FEED_ROWS`] a record of `n`
/// rows is fed in; one empty block when `n` is 0 (so the stream still
/// checks its shape).
pub(crate) fn chunks(n: usize) -> impl Iterator<Item = (usize, usize)> {
    let blocks = n.div_ceil(FEED_ROWS).max(1);
    (0..blocks).map(move |b| {
        let k = b * FEED_ROWS;
        (k, FEED_ROWS.min(n - k))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_longest_horizon_is_the_last_with_as_many_columns_as_rows() {
        // 45 samples of 8 channels: s = 2 gives 42 columns for 32 rows,
        // s = 3 gives 40 for 48.
        assert_eq!(longest_horizon(&[45], 8, 10), Some(2));
        // 2 channels, 1000 samples: horizon 10 fits (981 ≥ 80).
        assert_eq!(longest_horizon(&[1000], 2, 10), Some(10));
        // Columns add over records: two of 30 samples of 8 channels give
        // 2 · 25 = 50 columns for 48 rows at s = 3 (one alone: 25).
        assert_eq!(longest_horizon(&[30, 30], 8, 10), Some(3));
        assert_eq!(longest_horizon(&[30], 8, 10), None);
        assert_eq!(longest_horizon(&[28], 7, 10), None);
        // And it is the condition identify checks.
        let (u, y) = (DMatrix::zeros(45, 5), DMatrix::zeros(45, 3));
        let e = [Experiment { u: &u, y: &y }];
        let three = SubspaceOptions {
            past: 3,
            future: 3,
            ..Default::default()
        };
        assert!(matches!(
            compressed(&e, &three),
            Err(Error::HorizonTooLong { .. })
        ));
    }
}

//! The analysis window: a stage of the default route whose work grows with
//! N beyond the passes over the data runs on the records' last samples
//! when they are longer than its budget, instead of stopping (issue 50:
//! the default's cost grows with N without cliffs).
//!
//! Used by the Kalman-gain check (`crate::gain`): records longer than
//! [`crate::Budgets::gain_check_samples`] have the subspace step's gain
//! checked on their last that many samples (the innovations of the same
//! window), so that its cost stays at that length's and the gain of a
//! record one sample past the budget is checked as the one below it was.
//! The window is the **last** samples — the most recent behaviour of the
//! plant, contiguous so that every filter starts once. (The refinement
//! keeps every sample and caps its iterations instead,
//! `crate::refine::Refines::Capped`; the structure search keeps every
//! sample and fewer horizons, `lifted_subspace::default_horizons`.)
//!
//! Cost: a copy of the window, O(W (n_u + n_y)).

use crate::error::{Context, Result};
use lifted_lti::Dataset;

/// The last `samples` samples of `sets`, taken as the tail of the records
/// one after another (whole later records, then the end of the earliest
/// record that contributes); `sets` itself when they hold no more.
/// Multirate channels keep their sampling instants (`Dataset::slice`).
pub(crate) fn last_samples(sets: &[Dataset], samples: usize) -> Result<Vec<Dataset>> {
    let total: usize = sets.iter().map(Dataset::len).sum();
    if samples >= total {
        return Ok(sets.to_vec());
    }
    let mut left = samples;
    let mut out = Vec::new();
    for d in sets.iter().rev() {
        if left == 0 {
            break;
        }
        let take = left.min(d.len());
        out.push(
            d.slice(d.len() - take..d.len())
                .ctx("the analysis window")?,
        );
        left -= take;
    }
    out.reverse();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use lifted_lti::Dataset;
    use nalgebra::DMatrix;

    fn record(n: usize, first: f64) -> Dataset {
        let u = DMatrix::from_fn(n, 1, |i, _| first + i as f64);
        let y = DMatrix::from_fn(n, 1, |i, _| 2.0 * (first + i as f64));
        Dataset::single_rate(1.0, u, y).unwrap()
    }

    /// The window is the tail of the records taken one after another.
    #[test]
    fn the_window_is_the_records_tail() {
        let sets = vec![record(10, 0.0), record(5, 100.0)];
        let w = last_samples(&sets, 7).unwrap();
        assert_eq!(w.len(), 2);
        assert_eq!(w[0].len(), 2);
        assert_eq!(w[0].u()[(0, 0)], 8.0);
        assert_eq!(w[1].len(), 5);
        assert_eq!(w[1].u()[(0, 0)], 100.0);
        let w = last_samples(&sets, 3).unwrap();
        assert_eq!(w.len(), 1);
        assert_eq!(w[0].u()[(0, 0)], 102.0);
        assert_eq!(last_samples(&sets, 15).unwrap().len(), 2);
        assert_eq!(last_samples(&sets, 99).unwrap()[0].len(), 10);
    }
}

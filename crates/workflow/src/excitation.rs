//! Naming the input that makes a record non-exciting: a subspace
//! identification refuses inputs whose block-Hankel matrix is rank
//! deficient ("u is not persistently exciting: numerical rank r, k
//! needed"), which leaves the user to find the culprit. The commonest one
//! is a column that never moves (a set-point logged as an input, a valve
//! left in manual); [`InputSpread`] keeps each input's range while the
//! records are read (O(N n_u), no copy) and [`named`] turns the refusal
//! into one that names the constant inputs.

use nalgebra::DMatrix;

use crate::error::Error;

/// Smallest and largest finite value of each input over the records.
#[derive(Debug, Clone)]
pub(crate) struct InputSpread {
    lo: Vec<f64>,
    hi: Vec<f64>,
}

impl InputSpread {
    /// No sample yet, `n_u` inputs.
    pub(crate) fn new(n_u: usize) -> Self {
        InputSpread {
            lo: vec![f64::INFINITY; n_u],
            hi: vec![f64::NEG_INFINITY; n_u],
        }
    }

    /// The spread of the inputs `u` (rows of samples) of `records`.
    pub(crate) fn of<'a>(n_u: usize, records: impl IntoIterator<Item = &'a DMatrix<f64>>) -> Self {
        let mut s = InputSpread::new(n_u);
        for u in records {
            s.push(u);
        }
        s
    }

    /// Adds a block of input rows. O(rows · n_u).
    pub(crate) fn push(&mut self, u: &DMatrix<f64>) {
        for (j, col) in u.column_iter().enumerate().take(self.lo.len()) {
            for &v in col.iter().filter(|v| v.is_finite()) {
                self.lo[j] = self.lo[j].min(v);
                self.hi[j] = self.hi[j].max(v);
            }
        }
    }

    /// The inputs (0-based) whose every value is the same, with that value.
    pub(crate) fn constant(&self) -> Vec<(usize, f64)> {
        self.lo
            .iter()
            .zip(&self.hi)
            .enumerate()
            .filter(|(_, (lo, hi))| lo.is_finite() && lo == hi)
            .map(|(j, (lo, _))| (j, *lo))
            .collect()
    }
}

/// `e` itself, or, when it is a subspace identification's refusal of
/// non-exciting inputs and some inputs are constant, an [`Error::Data`]
/// naming them (1-based, in the order of the inputs) with the refusal.
pub(crate) fn named(e: Error, spread: &InputSpread) -> Error {
    let Error::Step { what, source } = &e else {
        return e;
    };
    let refused = matches!(
        source.downcast_ref::<lifted_subspace::Error>(),
        Some(lifted_subspace::Error::NotExciting { what: "u", .. })
    );
    let constant = spread.constant();
    if !refused || constant.is_empty() {
        return e;
    }
    let list: Vec<String> = constant
        .iter()
        .map(|(j, v)| format!("input {} (always {v})", j + 1))
        .collect();
    Error::Data(format!(
        "{what}: {} {} constant over the records: a constant input excites no dynamics, so its effect cannot be identified; remove it from the inputs ({source})",
        list.join(", "),
        if constant.len() == 1 { "is" } else { "are" }
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_constant_inputs_are_found_across_blocks_and_nan_is_skipped() {
        let a = DMatrix::from_row_slice(2, 3, &[1.0, 2.0, 5.0, f64::NAN, 2.0, 5.0]);
        let b = DMatrix::from_row_slice(2, 3, &[3.0, 2.0, 5.0, 1.0, 2.0, 6.0]);
        let s = InputSpread::of(3, [&a, &b]);
        assert_eq!(s.constant(), vec![(1, 2.0)]);
        assert!(InputSpread::new(2).constant().is_empty());
    }

    #[test]
    fn only_a_refusal_of_the_inputs_is_renamed() {
        let s = InputSpread::of(2, [&DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 2.0, 0.0])]);
        let refusal = || Error::Step {
            what: "N4SID identification".into(),
            source: Box::new(lifted_subspace::Error::NotExciting {
                what: "u",
                rank: 20,
                needed: 40,
            }),
        };
        let e = named(refusal(), &s).to_string();
        assert!(
            e.contains("input 2 (always 0) is constant") && e.contains("numerical rank 20"),
            "{e}"
        );
        // No constant input: the refusal as it was.
        let moving = InputSpread::of(1, [&DMatrix::from_row_slice(2, 1, &[1.0, 2.0])]);
        assert_eq!(named(refusal(), &moving).to_string(), refusal().to_string());
        // Another error: as it was.
        let other = Error::Data("x".into());
        assert_eq!(named(other, &s).to_string(), "x");
    }
}

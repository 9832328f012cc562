//! Naming the inputs that make a record non-exciting: a subspace
//! identification refuses inputs whose block-Hankel matrix is rank
//! deficient ("u is not persistently exciting: numerical rank r, k
//! needed"), which leaves the user to find the culprit. The commonest ones
//! are a column that never moves (a set-point logged as an input, a valve
//! left in manual) and columns that move together (two commands tied by a
//! controller, a signal logged twice). After such a refusal (only then:
//! the identification's reading pass is not slowed), [`InputSpread`]
//! gathers each input's range and the inputs' centred Gram matrix from the
//! records (O(N n_u²), no copy; one more pass over a streamed file) and
//! [`named`] turns the refusal into one that names the constant or
//! linearly dependent inputs.

use nalgebra::{DMatrix, DVector};

use crate::error::Error;

/// Smallest and largest finite value of each input over the records, and
/// the sums of the rows (shifted by the first complete row, so that large
/// offsets do not cancel) and of their outer products over the rows where
/// every input is finite.
#[derive(Debug, Clone)]
pub(crate) struct InputSpread {
    lo: Vec<f64>,
    hi: Vec<f64>,
    shift: Option<DVector<f64>>,
    sum: DVector<f64>,
    gram: DMatrix<f64>,
    rows: usize,
}

/// Inputs whose correlation matrix has an eigenvalue below this (relative
/// to 1, its mean eigenvalue) are linearly dependent: a singular value of
/// the scaled, centred inputs below 1e-6 of theirs.
const DEPENDENT: f64 = 1e-12;

impl InputSpread {
    /// No sample yet, `n_u` inputs.
    pub(crate) fn new(n_u: usize) -> Self {
        InputSpread {
            lo: vec![f64::INFINITY; n_u],
            hi: vec![f64::NEG_INFINITY; n_u],
            shift: None,
            sum: DVector::zeros(n_u),
            gram: DMatrix::zeros(n_u, n_u),
            rows: 0,
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

    /// Adds a block of input rows. O(rows · n_u²).
    pub(crate) fn push(&mut self, u: &DMatrix<f64>) {
        let n_u = self.lo.len();
        if u.ncols() != n_u {
            return;
        }
        for (j, col) in u.column_iter().enumerate() {
            for &v in col.iter().filter(|v| v.is_finite()) {
                self.lo[j] = self.lo[j].min(v);
                self.hi[j] = self.hi[j].max(v);
            }
        }
        if u.nrows() == 0 {
            return;
        }
        if u.iter().all(|v| v.is_finite()) {
            // Every row complete (the usual block): column by column.
            let shift = self
                .shift
                .get_or_insert_with(|| DVector::from_fn(n_u, |j, _| u[(0, j)]))
                .clone();
            let d: Vec<Vec<f64>> = (0..n_u)
                .map(|j| u.column(j).iter().map(|v| v - shift[j]).collect())
                .collect();
            for j in 0..n_u {
                self.sum[j] += d[j].iter().sum::<f64>();
                for i in 0..=j {
                    self.gram[(i, j)] += d[i].iter().zip(&d[j]).map(|(a, b)| a * b).sum::<f64>();
                }
            }
            self.rows += u.nrows();
            return;
        }
        let mut d = vec![0.0; n_u];
        for r in 0..u.nrows() {
            if (0..n_u).any(|j| !u[(r, j)].is_finite()) {
                continue;
            }
            let shift = self
                .shift
                .get_or_insert_with(|| DVector::from_fn(n_u, |j, _| u[(r, j)]));
            for j in 0..n_u {
                d[j] = u[(r, j)] - shift[j];
                self.sum[j] += d[j];
            }
            // The upper triangle; mirrored when read.
            for j in 0..n_u {
                for i in 0..=j {
                    self.gram[(i, j)] += d[i] * d[j];
                }
            }
            self.rows += 1;
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

impl InputSpread {
    /// Groups of non-constant inputs (0-based) that are linearly dependent
    /// (a combination of them is constant over the records): one group per
    /// eigenvalue of their correlation matrix below [`DEPENDENT`], the
    /// inputs of weight above 0.1 in its eigenvector. O(n_u³).
    pub(crate) fn dependent(&self) -> Vec<Vec<usize>> {
        let moving: Vec<usize> = (0..self.lo.len())
            .filter(|&j| self.lo[j].is_finite() && self.lo[j] < self.hi[j])
            .collect();
        if moving.len() < 2 || self.rows < 2 {
            return Vec::new();
        }
        let n = self.rows as f64;
        let k = moving.len();
        let cov = DMatrix::from_fn(k, k, |a, b| {
            let (i, j) = (moving[a], moving[b]);
            let g = self.gram[(i.min(j), i.max(j))];
            (g - self.sum[i] * self.sum[j] / n) / n
        });
        let sd: Vec<f64> = (0..k).map(|a| cov[(a, a)].max(0.0).sqrt()).collect();
        if sd.iter().any(|&v| v <= 0.0 || !v.is_finite()) {
            return Vec::new();
        }
        let corr = DMatrix::from_fn(k, k, |a, b| cov[(a, b)] / (sd[a] * sd[b]));
        let eig = corr.symmetric_eigen();
        (0..k)
            .filter(|&i| eig.eigenvalues[i] < DEPENDENT)
            .map(|i| {
                let v = eig.eigenvectors.column(i);
                (0..k)
                    .filter(|&a| v[a].abs() > 0.1)
                    .map(|a| moving[a])
                    .collect()
            })
            .collect()
    }
}

/// Whether `e` is a subspace identification's refusal of non-exciting
/// inputs.
pub(crate) fn refuses_inputs(e: &Error) -> bool {
    let Error::Step { source, .. } = e else {
        return false;
    };
    // A constant or tied input makes the subspace methods' input rows,
    // PBSID/SSARX's past data and the IV method's instrument rows (the
    // inputs in open loop) rank deficient; when no input is, `named`
    // returns the refusal as it is.
    source
        .downcast_ref::<lifted_subspace::Error>()
        .is_some_and(lifted_subspace::Error::refuses_input_excitation)
}

/// `e` itself, or, when it is a subspace identification's refusal of
/// non-exciting inputs and some inputs are constant or tied, the same
/// [`Error::Step`] whose source names them (1-based, in the order of the
/// inputs) and keeps the refusal as its own source, so that a front end
/// still finds the layer below's variant
/// (`lifted_subspace::Error::NotExciting`) down the chain of sources.
pub(crate) fn named(e: Error, spread: &InputSpread) -> Error {
    if !refuses_inputs(&e) {
        return e;
    }
    let constant = spread.constant();
    let text = if constant.is_empty() {
        let groups = spread.dependent();
        if groups.is_empty() {
            return e;
        }
        let list: Vec<String> = groups
            .iter()
            .map(|g| {
                let names: Vec<String> = g.iter().map(|j| (j + 1).to_string()).collect();
                format!("inputs {}", names.join(", "))
            })
            .collect();
        format!(
            "{} move together (a combination of them is constant over the records), so their effects cannot be told apart; keep one of each such group or excite them independently",
            list.join("; ")
        )
    } else {
        let list: Vec<String> = constant
            .iter()
            .map(|(j, v)| format!("input {} (always {v})", j + 1))
            .collect();
        format!(
            "{} {} constant over the records: a constant input excites no dynamics, so its effect cannot be identified; remove it from the inputs",
            list.join(", "),
            if constant.len() == 1 { "is" } else { "are" }
        )
    };
    let Error::Step { what, source } = e else {
        return e;
    };
    Error::Step {
        what,
        source: Box::new(NamedInputs { text, source }),
    }
}

/// A refusal of non-exciting inputs with the inputs that cause it named;
/// the refusal itself stays the source. Displayed as `text (refusal)`.
#[derive(Debug)]
struct NamedInputs {
    /// The inputs and what to do about them.
    text: String,
    /// The layer below's refusal.
    source: Box<dyn std::error::Error + Send + Sync + 'static>,
}

impl std::fmt::Display for NamedInputs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({})", self.text, self.source)
    }
}

impl std::error::Error for NamedInputs {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(self.source.as_ref())
    }
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
    fn inputs_that_move_together_are_grouped() {
        // u2 = 1000 + 2 u1 (an offset that would cancel in raw sums), u3
        // independent, u4 = u3 − u1.
        let u = DMatrix::from_fn(50, 4, |i, j| {
            let a = ((i * 7919) % 13) as f64;
            let b = ((i * 104_729) % 11) as f64;
            match j {
                0 => a,
                1 => 1000.0 + 2.0 * a,
                2 => b,
                _ => b - a,
            }
        });
        let s = InputSpread::of(4, [&u]);
        let mut groups = s.dependent();
        for g in &mut groups {
            g.sort_unstable();
        }
        groups.sort();
        // Two relations among the four: every input is in one of them.
        assert_eq!(groups.len(), 2, "{groups:?}");
        let all: std::collections::BTreeSet<usize> = groups.iter().flatten().copied().collect();
        assert_eq!(all.into_iter().collect::<Vec<_>>(), vec![0, 1, 2, 3]);
        let independent = InputSpread::of(2, [&u.columns(0, 1).into_owned().insert_column(1, 0.0)]);
        assert!(independent.dependent().is_empty());
        let two = InputSpread::of(
            2,
            [&DMatrix::from_fn(50, 2, |i, j| {
                ((i * (j + 3) * 7) % 17) as f64
            })],
        );
        assert!(two.dependent().is_empty());
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
        let named_refusal = named(refusal(), &s);
        let e = named_refusal.to_string();
        assert!(
            e.contains("input 2 (always 0) is constant") && e.contains("numerical rank 20"),
            "{e}"
        );
        // The refusal stays down the chain of sources, variant and fields.
        let Error::Step { source, .. } = &named_refusal else {
            panic!("{named_refusal:?}");
        };
        let below = std::error::Error::source(source.as_ref())
            .and_then(|s| s.downcast_ref::<lifted_subspace::Error>());
        assert!(
            matches!(
                below,
                Some(lifted_subspace::Error::NotExciting {
                    rank: 20,
                    needed: 40,
                    ..
                })
            ),
            "{below:?}"
        );
        // No constant input: the refusal as it was.
        let moving = InputSpread::of(1, [&DMatrix::from_row_slice(2, 1, &[1.0, 2.0])]);
        assert_eq!(named(refusal(), &moving).to_string(), refusal().to_string());
        // Two inputs that move together: named as a group.
        let tied = InputSpread::of(
            2,
            [&DMatrix::from_fn(20, 2, |i, j| {
                (i % 5) as f64 * (j + 1) as f64
            })],
        );
        let e = named(refusal(), &tied).to_string();
        assert!(e.contains("inputs 1, 2 move together"), "{e}");
        // Another error: as it was.
        let other = Error::Data("x".into());
        assert_eq!(named(other, &s).to_string(), "x");
    }
}

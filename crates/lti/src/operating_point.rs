//! Operating points: the input and output offsets (u₀, y₀) about which an
//! identified model describes deviations, y − y₀ = G (u − u₀).
//!
//! Plant records sit at an operating point; identification removes each
//! channel's mean from the estimation record ([`OperatingPoint::means`]) and
//! stores the means with the model, and simulation or validation re-applies
//! them ([`OperatingPoint::to_deviations`], [`OperatingPoint::add_output`]).
//! Unsampled output values (NaN, multirate records) are skipped by the means
//! and stay NaN. Every operation is O(samples × channels).
//!
//! ```
//! use lifted_lti::OperatingPoint;
//! use nalgebra::DMatrix;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let u = DMatrix::from_column_slice(4, 1, &[2.0, 4.0, 2.0, 4.0]);
//! let y = DMatrix::from_column_slice(4, 1, &[-41.0, f64::NAN, -39.0, f64::NAN]);
//! let op = OperatingPoint::means(&[&u], &[&y])?;
//! assert_eq!(op.u0, vec![3.0]);
//! assert_eq!(op.y0, vec![-40.0]);
//! let (du, dy) = op.to_deviations(&u, &y)?;
//! assert_eq!(du[(0, 0)], -1.0);
//! assert!(dy[(1, 0)].is_nan());
//! # Ok(())
//! # }
//! ```

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Input and output offsets (one value per channel).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OperatingPoint {
    /// Input offsets u₀ (one per input).
    pub u0: Vec<f64>,
    /// Output offsets y₀ (one per output).
    pub y0: Vec<f64>,
}

impl OperatingPoint {
    /// An operating point from its offsets.
    ///
    /// Errors: [`Error::NonFiniteScalar`] for a NaN/inf offset.
    pub fn new(u0: Vec<f64>, y0: Vec<f64>) -> Result<Self> {
        for &v in u0.iter().chain(&y0) {
            if !v.is_finite() {
                return Err(Error::NonFiniteScalar {
                    what: "operating point offset",
                    value: v,
                });
            }
        }
        Ok(OperatingPoint { u0, y0 })
    }

    /// The zero operating point of a model with `nu` inputs and `ny` outputs.
    pub fn zero(nu: usize, ny: usize) -> Self {
        OperatingPoint {
            u0: vec![0.0; nu],
            y0: vec![0.0; ny],
        }
    }

    /// The per-channel means over all records (samples pooled), skipping
    /// NaN (unsampled) values. One pass, O(samples × channels).
    ///
    /// Errors: [`Error::DimensionMismatch`] when the records disagree in
    /// their channels or lengths, [`Error::NonFiniteScalar`] for an infinite
    /// value or a NaN input, and when a channel has no sample at all.
    pub fn means(u: &[&DMatrix<f64>], y: &[&DMatrix<f64>]) -> Result<Self> {
        let nu = u.first().map_or(0, |m| m.ncols());
        let ny = y.first().map_or(0, |m| m.ncols());
        if u.len() != y.len() {
            return Err(Error::DimensionMismatch {
                what: "operating point records",
                expected: format!("{} output records", u.len()),
                got: format!("{}", y.len()),
            });
        }
        for (a, b) in u.iter().zip(y) {
            if a.ncols() != nu || b.ncols() != ny || a.nrows() != b.nrows() {
                return Err(Error::DimensionMismatch {
                    what: "operating point records",
                    expected: format!("N×{nu} inputs and N×{ny} outputs"),
                    got: format!(
                        "{}x{} and {}x{}",
                        a.nrows(),
                        a.ncols(),
                        b.nrows(),
                        b.ncols()
                    ),
                });
            }
        }
        let u0 = channel_means(u, nu, false)?;
        let y0 = channel_means(y, ny, true)?;
        Ok(OperatingPoint { u0, y0 })
    }

    /// Checks that the offsets fit a model with `nu` inputs and `ny` outputs.
    ///
    /// Errors: [`Error::DimensionMismatch`].
    pub fn check_dims(&self, nu: usize, ny: usize) -> Result<()> {
        if self.u0.len() != nu || self.y0.len() != ny {
            return Err(Error::DimensionMismatch {
                what: "operating point",
                expected: format!("{nu} input and {ny} output offsets"),
                got: format!("{} and {}", self.u0.len(), self.y0.len()),
            });
        }
        Ok(())
    }

    /// True when every offset is zero.
    pub fn is_zero(&self) -> bool {
        self.u0.iter().chain(&self.y0).all(|&v| v == 0.0)
    }

    /// Deviation variables (u − u₀, y − y₀); NaN outputs stay NaN.
    ///
    /// Errors: [`Error::DimensionMismatch`] when the channels differ from
    /// the offsets.
    pub fn to_deviations(
        &self,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
    ) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
        Ok((self.remove_input(u)?, shift(y, &self.y0, -1.0, "outputs")?))
    }

    /// [`OperatingPoint::to_deviations`] into `du`, `dy` (resized when
    /// their shapes differ, else reused: no allocation from block to block
    /// of a stream). O(rows (n_u + n_y)).
    ///
    /// Errors: [`Error::DimensionMismatch`].
    pub fn to_deviations_into(
        &self,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        du: &mut DMatrix<f64>,
        dy: &mut DMatrix<f64>,
    ) -> Result<()> {
        shift_into(u, &self.u0, -1.0, "inputs", du)?;
        shift_into(y, &self.y0, -1.0, "outputs", dy)
    }

    /// u − u₀.
    ///
    /// Errors: [`Error::DimensionMismatch`].
    pub fn remove_input(&self, u: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        shift(u, &self.u0, -1.0, "inputs")
    }

    /// y + y₀ (a simulated deviation back in plant units).
    ///
    /// Errors: [`Error::DimensionMismatch`].
    pub fn add_output(&self, y: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        shift(y, &self.y0, 1.0, "outputs")
    }
}

fn channel_means(records: &[&DMatrix<f64>], n: usize, skip_nan: bool) -> Result<Vec<f64>> {
    let mut out = Vec::with_capacity(n);
    for c in 0..n {
        // Four independent partial sums (vectorised); a NaN adds nothing
        // when skipped, and any other non-finite value is reported after
        // the pass.
        let (mut sums, mut count, mut bad) = ([0.0f64; 4], 0usize, None);
        for m in records {
            let col = m.column(c);
            let v = col.as_slice();
            let mut chunks = v.chunks_exact(4);
            for q in &mut chunks {
                for (s, &x) in sums.iter_mut().zip(q) {
                    let skip = skip_nan && x.is_nan();
                    *s += if skip { 0.0 } else { x };
                    count += usize::from(!skip);
                }
            }
            for &x in chunks.remainder() {
                if !(skip_nan && x.is_nan()) {
                    sums[0] += x;
                    count += 1;
                }
            }
            let sum: f64 = sums.iter().sum();
            if !sum.is_finite() {
                bad = v
                    .iter()
                    .copied()
                    .find(|x| !(x.is_finite() || skip_nan && x.is_nan()));
                if bad.is_some() {
                    break;
                }
            }
        }
        if let Some(value) = bad {
            return Err(Error::NonFiniteScalar {
                what: "operating point data",
                value,
            });
        }
        if count == 0 {
            return Err(Error::NonFiniteScalar {
                what: "operating point: a channel without any sample",
                value: f64::NAN,
            });
        }
        out.push(sums.iter().sum::<f64>() / count as f64);
    }
    Ok(out)
}

fn shift(m: &DMatrix<f64>, offsets: &[f64], sign: f64, what: &'static str) -> Result<DMatrix<f64>> {
    let mut out = DMatrix::zeros(0, 0);
    shift_into(m, offsets, sign, what, &mut out)?;
    Ok(out)
}

/// `m` with `sign · offsets[c]` added to each column c, into `out`.
fn shift_into(
    m: &DMatrix<f64>,
    offsets: &[f64],
    sign: f64,
    what: &'static str,
    out: &mut DMatrix<f64>,
) -> Result<()> {
    if m.ncols() != offsets.len() {
        return Err(Error::DimensionMismatch {
            what,
            expected: format!("{} channels (operating point)", offsets.len()),
            got: format!("{}", m.ncols()),
        });
    }
    if out.shape() != m.shape() {
        *out = DMatrix::zeros(m.nrows(), m.ncols());
    }
    // Column slices (contiguous: the loops vectorise).
    let rows = m.nrows().max(1);
    let cols = out.as_mut_slice().chunks_exact_mut(rows);
    for ((t, f), &o) in cols.zip(m.as_slice().chunks_exact(rows)).zip(offsets) {
        for (t, v) in t.iter_mut().zip(f) {
            *t = v + sign * o;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn means_skip_nan_outputs_and_round_trip() {
        let u = DMatrix::from_row_slice(3, 2, &[1.0, 10.0, 2.0, 20.0, 3.0, 30.0]);
        let y = DMatrix::from_row_slice(3, 1, &[5.0, f64::NAN, 7.0]);
        let op = OperatingPoint::means(&[&u], &[&y]).unwrap();
        assert_eq!(op.u0, vec![2.0, 20.0]);
        assert_eq!(op.y0, vec![6.0]);
        let (du, dy) = op.to_deviations(&u, &y).unwrap();
        assert_eq!(du[(2, 1)], 10.0);
        assert!(dy[(1, 0)].is_nan());
        let back = op.add_output(&dy).unwrap();
        assert_eq!(back[(2, 0)], 7.0);
    }

    #[test]
    fn rejects_bad_input() {
        let u = DMatrix::from_element(2, 1, 1.0);
        let y = DMatrix::from_element(2, 1, f64::NAN);
        assert!(matches!(
            OperatingPoint::means(&[&u], &[&y]),
            Err(Error::NonFiniteScalar { .. })
        ));
        let y3 = DMatrix::from_element(3, 1, 1.0);
        assert!(matches!(
            OperatingPoint::means(&[&u], &[&y3]),
            Err(Error::DimensionMismatch { .. })
        ));
        let unan = DMatrix::from_element(2, 1, f64::NAN);
        let y2 = DMatrix::from_element(2, 1, 1.0);
        assert!(OperatingPoint::means(&[&unan], &[&y2]).is_err());
        assert!(OperatingPoint::new(vec![f64::INFINITY], vec![]).is_err());
        let op = OperatingPoint::zero(1, 1);
        assert!(op.check_dims(2, 1).is_err());
        assert!(op.remove_input(&DMatrix::zeros(2, 3)).is_err());
    }
}

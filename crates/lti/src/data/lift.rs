//! Lifting (thesis eq. 3.1, the operator L_n): n consecutive fast samples
//! of a signal stacked into one sample of a slow (period nT) signal
//! ([`Dataset::lift`], [`lift_signal`], [`unlift_signal`]). A copy,
//! O(N·(n_u + n_y)).

use nalgebra::DMatrix;

use super::*;

impl Dataset {
    /// Lifts the record by factor n (thesis eq. 3.1, L_n): row j of the
    /// result holds fast samples jn … jn+n−1 of every channel, ordered
    /// [`LiftOrdering::ChannelMajor`]: column c·n + t is channel c at fast
    /// time jn + t. Unsampled output entries stay NaN. Requires N to be a
    /// multiple of n ([`DataError::LengthNotMultiple`]: slice first). O(N(n_u+n_y)).
    pub fn lift(&self, n: usize) -> DataResult<Lifted> {
        Ok(Lifted {
            u: lift_signal(&self.u, n)?,
            y: lift_signal(&self.y, n)?,
            factor: n,
            ordering: LiftOrdering::ChannelMajor,
            n_inputs: self.n_inputs(),
            n_outputs: self.n_outputs(),
        })
    }
}

/// Column ordering of a lifted signal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum LiftOrdering {
    /// Channel-major blocks, time-major inside: column c·n + t holds channel c
    /// at fast time jn + t (t = 0…n−1) in lifted row j. For one channel this
    /// is the thesis' L_n: [x(jn), x(jn+1), …, x(jn+n−1)].
    ChannelMajor,
}

/// A lifted data set ([`Dataset::lift`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Lifted {
    /// Lifted inputs, (N/n)×(n_u·n).
    pub u: DMatrix<f64>,
    /// Lifted outputs, (N/n)×(n_y·n), NaN where unsampled.
    pub y: DMatrix<f64>,
    /// Lifting factor n.
    pub factor: usize,
    /// Column ordering.
    pub ordering: LiftOrdering,
    /// Number of input channels before lifting.
    pub n_inputs: usize,
    /// Number of output channels before lifting.
    pub n_outputs: usize,
}

impl Lifted {
    /// Column of channel `channel` at fast time offset `t` (< factor).
    pub fn column(&self, channel: usize, t: usize) -> usize {
        match self.ordering {
            LiftOrdering::ChannelMajor => channel * self.factor + t,
        }
    }

    /// Inverse lifting: the fast (u, y) signals.
    pub fn unlift(&self) -> DataResult<(DMatrix<f64>, DMatrix<f64>)> {
        Ok((
            unlift_signal(&self.u, self.factor, self.n_inputs)?,
            unlift_signal(&self.y, self.factor, self.n_outputs)?,
        ))
    }
}

/// Lifts an N×p signal by factor n into (N/n)×(p·n), channel-major
/// (see [`LiftOrdering::ChannelMajor`]). O(Np).
pub fn lift_signal(x: &DMatrix<f64>, n: usize) -> DataResult<DMatrix<f64>> {
    if n == 0 {
        return Err(DataError::ZeroLiftFactor);
    }
    let (len, p) = x.shape();
    if len % n != 0 {
        return Err(DataError::LengthNotMultiple { len, factor: n });
    }
    let rows = len / n;
    Ok(DMatrix::from_fn(rows, p * n, |j, col| {
        x[(j * n + col % n, col / n)]
    }))
}

/// Inverse of [`lift_signal`]: (M)×(p·n) → (M·n)×p. O(Mnp).
pub fn unlift_signal(x: &DMatrix<f64>, n: usize, channels: usize) -> DataResult<DMatrix<f64>> {
    if n == 0 {
        return Err(DataError::ZeroLiftFactor);
    }
    if x.ncols() != channels * n {
        return Err(DataError::DimensionMismatch {
            what: "columns of the lifted signal (channels × factor)",
            expected: channels * n,
            got: x.ncols(),
        });
    }
    Ok(DMatrix::from_fn(x.nrows() * n, channels, |k, c| {
        x[(k / n, c * n + k % n)]
    }))
}

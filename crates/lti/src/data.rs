//! Multirate data sets: the experiment record shared by every Lifted crate.
//!
//! A [`Dataset`] lives on the **fast grid** t = kT, k = 0…N−1 (T = `ts`, the
//! base period). Each input channel i is held for `hold` = m_i base periods
//! (the value is constant on the blocks k ∈ [j·m_i + o_i, (j+1)·m_i + o_i),
//! o_i = the channel's hold phase `offset`), and each output channel i is
//! sampled every `period` = J_i base periods, at the instants
//! k ≡ `offset` (mod J_i). Held inputs are stored repeated on the fast grid;
//! outputs are NaN at the instants their channel does not sample. A
//! single-rate data set has all holds and periods equal to 1.
//!
//! Lifting ([`Dataset::lift`], thesis eq. 3.1, the operator L_n) stacks n
//! consecutive fast samples of a signal into one sample of a slow (period nT)
//! signal. [`lift_signal`] / [`unlift_signal`] are its signal-level form.
//!
//! CSV ([`Dataset::to_csv_writer`]): a header row `t,<inputs…>,<outputs…>`
//! (each name optionally followed by ` [unit]`), then one row per fast
//! sample; a slowly sampled output has **empty cells** between its
//! samples. Files are read by `lifted-data` (`lifted_data::table`), the
//! one reader of every front end, with this module's sampling and time
//! rules ([`output_sampling`], [`time_step_within`]).
//!
//! All checks are O(N·(n_u + n_y)); lifting is a copy, O(N·(n_u + n_y)).

use std::fmt;
use std::ops::Range;

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

mod csv_file;
mod lift;

pub use csv_file::{
    SamplingError, TIME_STEP_TOLERANCE, output_sampling, period_from_times, snap_period,
    time_step_within,
};
pub use lift::{LiftOrdering, Lifted, lift_signal, unlift_signal};

/// Errors of the data layer ([`Dataset`], lifting, CSV).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DataError {
    /// The base period is not positive and finite.
    #[error("invalid base period {ts}: must be positive and finite")]
    InvalidSamplePeriod {
        /// The rejected value.
        ts: f64,
    },
    /// The data set has no samples.
    #[error("the data set is empty (0 samples)")]
    Empty,
    /// Two arguments have incompatible dimensions.
    #[error("dimension mismatch for {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// What was being matched.
        what: &'static str,
        /// Expected size.
        expected: usize,
        /// Actual size.
        got: usize,
    },
    /// An input hold m_i is 0.
    #[error("input channel {channel}: hold must be at least 1")]
    ZeroHold {
        /// Input channel index.
        channel: usize,
    },
    /// An output sampling period J_i is 0.
    #[error("output channel {channel}: sampling period must be at least 1")]
    ZeroPeriod {
        /// Output channel index.
        channel: usize,
    },
    /// An offset (output sampling phase or input hold phase) is not below its period.
    #[error("{what} channel {channel}: offset {offset} must be < {period}")]
    OffsetOutOfRange {
        /// "input" or "output".
        what: &'static str,
        /// Channel index.
        channel: usize,
        /// The offset.
        offset: usize,
        /// The period (hold or sampling period).
        period: usize,
    },
    /// An input entry is NaN or infinite.
    #[error("input channel {channel} sample {sample} is not finite ({value})")]
    NonFiniteInput {
        /// Input channel index.
        channel: usize,
        /// Fast-grid sample index.
        sample: usize,
        /// The value.
        value: f64,
    },
    /// An output is not finite at an instant its channel samples.
    #[error("output channel {channel} sample {sample} is sampled but not finite ({value})")]
    MissingSample {
        /// Output channel index.
        channel: usize,
        /// Fast-grid sample index.
        sample: usize,
        /// The value.
        value: f64,
    },
    /// An output is not NaN at an instant its channel does not sample.
    #[error(
        "output channel {channel} has value {value} at sample {sample}, which it does not sample (must be NaN)"
    )]
    UnexpectedSample {
        /// Output channel index.
        channel: usize,
        /// Fast-grid sample index.
        sample: usize,
        /// The value.
        value: f64,
    },
    /// An input changes inside a hold block.
    #[error(
        "input channel {channel} changes at sample {sample} inside a hold block of {hold} samples"
    )]
    HoldViolated {
        /// Input channel index.
        channel: usize,
        /// First fast-grid sample that differs from the block's first value.
        sample: usize,
        /// The hold m_i.
        hold: usize,
    },
    /// A channel index is out of range.
    #[error("{what} channel {index} out of range (have {count})")]
    ChannelOutOfRange {
        /// "input" or "output".
        what: &'static str,
        /// The index.
        index: usize,
        /// Number of channels.
        count: usize,
    },
    /// A sample range is empty or exceeds the record.
    #[error("invalid sample range {start}..{end} for a record of {len} samples")]
    InvalidRange {
        /// Range start.
        start: usize,
        /// Range end (exclusive).
        end: usize,
        /// Record length.
        len: usize,
    },
    /// The lifting factor is 0.
    #[error("lifting factor must be at least 1")]
    ZeroLiftFactor,
    /// The record length is not a multiple of the lifting factor.
    #[error(
        "record length {len} is not a multiple of the lifting factor {factor} (slice the data first)"
    )]
    LengthNotMultiple {
        /// Record length.
        len: usize,
        /// Lifting factor.
        factor: usize,
    },
    /// Too few samples for the requested operation.
    #[error("{what}: need at least {needed} samples, have {got}")]
    TooShort {
        /// Which operation.
        what: &'static str,
        /// Samples needed.
        needed: usize,
        /// Samples available.
        got: usize,
    },
    /// Experiments given together differ in their channel layout.
    #[error("experiment {index} is incompatible with experiment 0: {reason}")]
    IncompatibleExperiments {
        /// Index of the offending experiment.
        index: usize,
        /// What differs.
        reason: String,
    },
    /// No experiment was given.
    #[error("no experiments given")]
    NoExperiments,
    /// CSV: a row has a different number of cells than the header.
    #[error("CSV line {line}: {got} cells, header has {expected}")]
    CsvRaggedRow {
        /// 1-based line number.
        line: u64,
        /// Header width.
        expected: usize,
        /// Cells in the row.
        got: usize,
    },
    /// CSV: an I/O or encoding error.
    #[error("CSV I/O: {reason}")]
    CsvIo {
        /// The underlying message.
        reason: String,
    },
}

/// The scale of a channel: the (population) standard deviation of its
/// finite values, or 1 when it has none or they are all equal. Used to put
/// channels in comparable units (the workflow's channel scaling, the
/// per-output weights of the validation's x₀ and of the PEM cost). O(len).
pub fn channel_scale<'a>(values: impl IntoIterator<Item = &'a f64>) -> f64 {
    let vals: Vec<f64> = values
        .into_iter()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    let n = vals.len().max(1) as f64;
    let mean = match vals.iter().sum::<f64>() / n {
        m if m.is_finite() => m,
        _ => vals.iter().map(|v| v / n).sum::<f64>(),
    };
    let s = (vals.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    if s.is_finite() && s > 0.0 {
        return s;
    }
    // Channels in units near the ends of the double range (|v| ~ 1e160:
    // the squares overflow, or ~1e-170: they underflow) get their scale
    // instead of 1, the deviations divided by the largest first.
    let big = vals.iter().fold(0.0_f64, |m, v| m.max((v - mean).abs()));
    if !(big.is_finite() && big > 0.0) {
        return 1.0;
    }
    let s = big * (vals.iter().map(|v| ((v - mean) / big).powi(2)).sum::<f64>() / n).sqrt();
    if s.is_finite() && s > 0.0 { s } else { 1.0 }
}

/// Result alias of the data layer.
pub type DataResult<T> = std::result::Result<T, DataError>;

/// An input channel: name, unit and hold m_i (in base periods).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct InputChannel {
    /// Channel name (e.g. "u1").
    pub name: String,
    /// Physical unit, if known.
    pub unit: Option<String>,
    /// Hold m_i ≥ 1: the input changes only every `hold` base periods.
    pub hold: usize,
    /// Hold phase, `< hold`: blocks start at k ≡ offset (mod hold). Default 0;
    /// [`Dataset::slice`] adjusts it so that the blocks stay where they were.
    #[serde(default)]
    pub offset: usize,
}

impl InputChannel {
    /// A channel with hold `hold` and phase 0, no unit.
    pub fn new(name: impl Into<String>, hold: usize) -> Self {
        InputChannel {
            name: name.into(),
            unit: None,
            hold,
            offset: 0,
        }
    }

    /// Sets the unit.
    pub fn with_unit(mut self, unit: impl Into<String>) -> Self {
        self.unit = Some(unit.into());
        self
    }

    /// Sets the hold phase (blocks start at k ≡ offset mod hold).
    pub fn with_offset(mut self, offset: usize) -> Self {
        self.offset = offset;
        self
    }

    /// Whether a new hold block starts at fast sample `k`.
    pub fn is_block_start(&self, k: usize) -> bool {
        self.hold > 0 && k % self.hold == self.offset % self.hold
    }
}

/// An output channel: name, unit, sampling period J_i and offset.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct OutputChannel {
    /// Channel name (e.g. "y1").
    pub name: String,
    /// Physical unit, if known.
    pub unit: Option<String>,
    /// Sampling period J_i ≥ 1 in base periods.
    pub period: usize,
    /// Phase: sampled at k ≡ offset (mod period), offset < period.
    pub offset: usize,
}

impl OutputChannel {
    /// A channel sampled every `period` base periods at k ≡ `offset`.
    pub fn new(name: impl Into<String>, period: usize, offset: usize) -> Self {
        OutputChannel {
            name: name.into(),
            unit: None,
            period,
            offset,
        }
    }

    /// Sets the unit.
    pub fn with_unit(mut self, unit: impl Into<String>) -> Self {
        self.unit = Some(unit.into());
        self
    }

    /// Whether the channel samples fast instant `k`.
    pub fn is_sampled(&self, k: usize) -> bool {
        self.period > 0 && k % self.period == self.offset
    }
}

/// How to detrend ([`Dataset::detrend`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Detrend {
    /// Remove the mean of each channel's sampled values (default).
    #[default]
    Constant,
    /// Remove a least-squares straight line in k fitted to the sampled values
    /// (for held inputs: fitted to the block values at the block starts and
    /// subtracted as a held staircase, so holds stay valid).
    Linear,
}

/// A validated multirate experiment record (see the [module docs](self)).
///
/// Fields are private so every value satisfies the invariants checked by
/// [`Dataset::new`]. Equality treats NaN (unsampled) entries as equal.
#[derive(Debug, Clone)]
pub struct Dataset {
    ts: f64,
    u: DMatrix<f64>,
    y: DMatrix<f64>,
    inputs: Vec<InputChannel>,
    outputs: Vec<OutputChannel>,
}

impl PartialEq for Dataset {
    fn eq(&self, o: &Self) -> bool {
        let same = |a: &DMatrix<f64>, b: &DMatrix<f64>| {
            a.shape() == b.shape()
                && a.iter()
                    .zip(b.iter())
                    .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()))
        };
        self.ts == o.ts
            && self.inputs == o.inputs
            && self.outputs == o.outputs
            && same(&self.u, &o.u)
            && same(&self.y, &o.y)
    }
}

fn default_inputs(n: usize) -> Vec<InputChannel> {
    (0..n)
        .map(|i| InputChannel::new(format!("u{}", i + 1), 1))
        .collect()
}

fn default_outputs(n: usize) -> Vec<OutputChannel> {
    (0..n)
        .map(|i| OutputChannel::new(format!("y{}", i + 1), 1, 0))
        .collect()
}

/// [`DataError::OffsetOutOfRange`] unless `offset < period` (the phase of
/// `what` channel `channel`).
fn check_offset(
    what: &'static str,
    channel: usize,
    offset: usize,
    period: usize,
) -> DataResult<()> {
    if offset >= period {
        return Err(DataError::OffsetOutOfRange {
            what,
            channel,
            offset,
            period,
        });
    }
    Ok(())
}

/// Channel `index` of `channels` (`what` is "input" or "output"), or
/// [`DataError::ChannelOutOfRange`].
fn channel<'a, C>(what: &'static str, channels: &'a [C], index: usize) -> DataResult<&'a C> {
    channels.get(index).ok_or(DataError::ChannelOutOfRange {
        what,
        index,
        count: channels.len(),
    })
}

/// The instants k < `col.len()` where `keep(k)` and the values of `col` there.
fn samples_where(
    col: nalgebra::DVectorView<'_, f64>,
    keep: impl Fn(usize) -> bool,
) -> (Vec<usize>, Vec<f64>) {
    let idx: Vec<usize> = (0..col.len()).filter(|&k| keep(k)).collect();
    let vals = idx.iter().map(|&k| col[k]).collect();
    (idx, vals)
}

impl Dataset {
    /// Validates and builds a data set.
    ///
    /// `u` is N×n_u (held values repeated), `y` N×n_y with NaN exactly at the
    /// instants a channel does not sample. Checks: `ts` positive finite; N ≥ 1;
    /// channel counts match the columns; holds and periods ≥ 1, offsets below
    /// them; `u` finite and constant within each hold block; `y` finite exactly
    /// at the sampled instants. O(N(n_u + n_y)).
    pub fn new(
        ts: f64,
        u: DMatrix<f64>,
        y: DMatrix<f64>,
        inputs: Vec<InputChannel>,
        outputs: Vec<OutputChannel>,
    ) -> DataResult<Self> {
        if !(ts.is_finite() && ts > 0.0) {
            return Err(DataError::InvalidSamplePeriod { ts });
        }
        let n = u.nrows();
        if y.nrows() != n {
            return Err(DataError::DimensionMismatch {
                what: "rows of y (= rows of u)",
                expected: n,
                got: y.nrows(),
            });
        }
        if n == 0 {
            return Err(DataError::Empty);
        }
        if inputs.len() != u.ncols() {
            return Err(DataError::DimensionMismatch {
                what: "input channels (= columns of u)",
                expected: u.ncols(),
                got: inputs.len(),
            });
        }
        if outputs.len() != y.ncols() {
            return Err(DataError::DimensionMismatch {
                what: "output channels (= columns of y)",
                expected: y.ncols(),
                got: outputs.len(),
            });
        }
        for (c, ch) in inputs.iter().enumerate() {
            if ch.hold == 0 {
                return Err(DataError::ZeroHold { channel: c });
            }
            check_offset("input", c, ch.offset, ch.hold)?;
            let col = u.column(c);
            if let Some(k) = lifted_linalg::first_non_finite(col.as_slice()) {
                return Err(DataError::NonFiniteInput {
                    channel: c,
                    sample: k,
                    value: col[k],
                });
            }
            if ch.hold == 1 {
                continue;
            }
            // every value is finite here (checked above)
            let mut block_value = f64::NAN;
            for k in 0..n {
                let v = col[k];
                if k == 0 || ch.is_block_start(k) {
                    block_value = v;
                } else if v != block_value {
                    return Err(DataError::HoldViolated {
                        channel: c,
                        sample: k,
                        hold: ch.hold,
                    });
                }
            }
        }
        for (c, ch) in outputs.iter().enumerate() {
            if ch.period == 0 {
                return Err(DataError::ZeroPeriod { channel: c });
            }
            check_offset("output", c, ch.offset, ch.period)?;
            let col = y.column(c);
            if ch.period == 1 {
                if let Some(k) = lifted_linalg::first_non_finite(col.as_slice()) {
                    return Err(DataError::MissingSample {
                        channel: c,
                        sample: k,
                        value: col[k],
                    });
                }
                continue;
            }
            for k in 0..n {
                let v = col[k];
                if ch.is_sampled(k) {
                    if !v.is_finite() {
                        return Err(DataError::MissingSample {
                            channel: c,
                            sample: k,
                            value: v,
                        });
                    }
                } else if !v.is_nan() {
                    return Err(DataError::UnexpectedSample {
                        channel: c,
                        sample: k,
                        value: v,
                    });
                }
            }
        }
        Ok(Dataset {
            ts,
            u,
            y,
            inputs,
            outputs,
        })
    }

    /// A single-rate data set (all holds and periods 1) with channel names
    /// u1…, y1…. `y` must be finite everywhere.
    pub fn single_rate(ts: f64, u: DMatrix<f64>, y: DMatrix<f64>) -> DataResult<Self> {
        let (nu, ny) = (u.ncols(), y.ncols());
        Self::new(ts, u, y, default_inputs(nu), default_outputs(ny))
    }

    /// Builds a multirate data set from **fully sampled** fast signals: the
    /// outputs are masked (set to NaN) off their sampling instants, and the
    /// holds are checked on `u`. Convenient for simulators.
    pub fn from_fast(
        ts: f64,
        u: DMatrix<f64>,
        mut y: DMatrix<f64>,
        inputs: Vec<InputChannel>,
        outputs: Vec<OutputChannel>,
    ) -> DataResult<Self> {
        if outputs.len() == y.ncols() {
            for (c, ch) in outputs.iter().enumerate() {
                if ch.period == 0 {
                    return Err(DataError::ZeroPeriod { channel: c });
                }
                for k in 0..y.nrows() {
                    if !ch.is_sampled(k) {
                        y[(k, c)] = f64::NAN;
                    }
                }
            }
        }
        Self::new(ts, u, y, inputs, outputs)
    }

    /// Base period T in seconds.
    pub fn ts(&self) -> f64 {
        self.ts
    }

    /// Inputs on the fast grid, N×n_u.
    pub fn u(&self) -> &DMatrix<f64> {
        &self.u
    }

    /// Outputs on the fast grid, N×n_y, NaN where not sampled.
    pub fn y(&self) -> &DMatrix<f64> {
        &self.y
    }

    /// Input channel descriptions.
    pub fn inputs(&self) -> &[InputChannel] {
        &self.inputs
    }

    /// Output channel descriptions.
    pub fn outputs(&self) -> &[OutputChannel] {
        &self.outputs
    }

    /// Consumes the data set: (ts, u, y, inputs, outputs).
    pub fn into_parts(
        self,
    ) -> (
        f64,
        DMatrix<f64>,
        DMatrix<f64>,
        Vec<InputChannel>,
        Vec<OutputChannel>,
    ) {
        (self.ts, self.u, self.y, self.inputs, self.outputs)
    }

    /// Number of fast samples N.
    pub fn len(&self) -> usize {
        self.u.nrows()
    }

    /// Always false: a data set has at least one sample.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of input channels n_u.
    pub fn n_inputs(&self) -> usize {
        self.inputs.len()
    }

    /// Number of output channels n_y.
    pub fn n_outputs(&self) -> usize {
        self.outputs.len()
    }

    /// True when every hold and every sampling period is 1.
    pub fn is_single_rate(&self) -> bool {
        self.inputs.iter().all(|c| c.hold == 1) && self.outputs.iter().all(|c| c.period == 1)
    }

    /// Least common multiple of all holds and output periods: the period of
    /// the sampling pattern (the natural lifting factor).
    pub fn frame_period(&self) -> usize {
        self.inputs
            .iter()
            .map(|c| c.hold)
            .chain(self.outputs.iter().map(|c| c.period))
            .fold(1, lcm)
    }

    /// The instants sampled by output `i` and the values there.
    pub fn output_samples(&self, i: usize) -> DataResult<(Vec<usize>, Vec<f64>)> {
        let ch = channel("output", &self.outputs, i)?;
        Ok(samples_where(self.y.column(i), |k| ch.is_sampled(k)))
    }

    /// The block-start instants of input `i` (the first sample counts as a
    /// start even inside a block) and the held values.
    pub fn input_samples(&self, i: usize) -> DataResult<(Vec<usize>, Vec<f64>)> {
        let ch = channel("input", &self.inputs, i)?;
        Ok(samples_where(self.u.column(i), |k| {
            k == 0 || ch.is_block_start(k)
        }))
    }

    /// The samples `range` (fast-grid indices). Offsets are adjusted so that
    /// every channel samples (and every hold block starts) at the same
    /// absolute instants as before: new offset = (offset − start) mod period.
    pub fn slice(&self, range: Range<usize>) -> DataResult<Self> {
        let (start, end) = (range.start, range.end);
        if start >= end || end > self.len() {
            return Err(DataError::InvalidRange {
                start,
                end,
                len: self.len(),
            });
        }
        let rows = end - start;
        let u = self.u.rows(start, rows).into_owned();
        let y = self.y.rows(start, rows).into_owned();
        let shift = |offset: usize, period: usize| (offset + period - start % period) % period;
        let inputs = self
            .inputs
            .iter()
            .map(|c| InputChannel {
                offset: shift(c.offset, c.hold),
                ..c.clone()
            })
            .collect();
        let outputs = self
            .outputs
            .iter()
            .map(|c| OutputChannel {
                offset: shift(c.offset, c.period),
                ..c.clone()
            })
            .collect();
        Ok(Dataset {
            ts: self.ts,
            u,
            y,
            inputs,
            outputs,
        })
    }

    /// Removes the mean (or a straight line, see [`Detrend`]) of each
    /// channel's **sampled** values; unsampled output instants stay NaN and
    /// held inputs stay held. Errors: [`DataError::TooShort`] when a linear
    /// fit has fewer than 2 points on some channel. O(N(n_u + n_y)).
    pub fn detrend(&self, kind: Detrend) -> DataResult<Self> {
        let mut out = self.clone();
        let n = self.len();
        // A channel sampled at every instant (hold 1, period 1) less its
        // mean: the same sum and subtraction as below, on the column slice
        // (no index and value copies; the loop vectorises).
        let full_rate_mean = |col: &mut [f64]| {
            let mean = col.iter().sum::<f64>() / col.len() as f64;
            for v in col.iter_mut() {
                *v -= mean;
            }
        };
        for i in 0..self.n_inputs() {
            if kind == Detrend::Constant && self.inputs[i].hold == 1 && n > 0 {
                full_rate_mean(&mut out.u.as_mut_slice()[i * n..(i + 1) * n]);
                continue;
            }
            let (idx, vals) = self.input_samples(i)?;
            let (a, b) = trend(kind, &idx, &vals)?;
            let mut cur = 0.0;
            for k in 0..self.len() {
                if k == 0 || self.inputs[i].is_block_start(k) {
                    cur = a + b * k as f64;
                }
                out.u[(k, i)] -= cur;
            }
        }
        for i in 0..self.n_outputs() {
            if kind == Detrend::Constant && self.outputs[i].period == 1 && n > 0 {
                full_rate_mean(&mut out.y.as_mut_slice()[i * n..(i + 1) * n]);
                continue;
            }
            let (idx, vals) = self.output_samples(i)?;
            let (a, b) = trend(kind, &idx, &vals)?;
            for &k in &idx {
                out.y[(k, i)] -= a + b * k as f64;
            }
        }
        Ok(out)
    }

    /// The record with constant offsets added to every input and output
    /// channel (e.g. an operating point u₀, y₀ re-applied to a simulated
    /// deviation record); unsampled outputs stay NaN, holds stay valid.
    /// Errors: [`DataError::DimensionMismatch`] for a wrong number of
    /// offsets, [`DataError::NonFiniteInput`] / [`DataError::MissingSample`]
    /// (sample 0) for a non-finite one. O(N(n_u + n_y)).
    pub fn shifted(&self, u_offset: &[f64], y_offset: &[f64]) -> DataResult<Self> {
        if u_offset.len() != self.n_inputs() {
            return Err(DataError::DimensionMismatch {
                what: "input offsets",
                expected: self.n_inputs(),
                got: u_offset.len(),
            });
        }
        if y_offset.len() != self.n_outputs() {
            return Err(DataError::DimensionMismatch {
                what: "output offsets",
                expected: self.n_outputs(),
                got: y_offset.len(),
            });
        }
        if let Some((c, &v)) = u_offset.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(DataError::NonFiniteInput {
                channel: c,
                sample: 0,
                value: v,
            });
        }
        if let Some((c, &v)) = y_offset.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(DataError::MissingSample {
                channel: c,
                sample: 0,
                value: v,
            });
        }
        let mut out = self.clone();
        for (c, &o) in u_offset.iter().enumerate() {
            out.u.column_mut(c).iter_mut().for_each(|v| *v += o);
        }
        for (c, &o) in y_offset.iter().enumerate() {
            out.y.column_mut(c).iter_mut().for_each(|v| *v += o);
        }
        Ok(out)
    }
}

impl fmt::Display for Dataset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "Dataset: {} samples at T = {} s; inputs",
            self.len(),
            self.ts
        )?;
        for c in &self.inputs {
            write!(f, " {}(hold {})", c.name, c.hold)?;
        }
        write!(f, "; outputs")?;
        for c in &self.outputs {
            write!(f, " {}(period {}, offset {})", c.name, c.period, c.offset)?;
        }
        Ok(())
    }
}

fn trend(kind: Detrend, idx: &[usize], vals: &[f64]) -> DataResult<(f64, f64)> {
    let n = vals.len() as f64;
    let mean = vals.iter().sum::<f64>() / n;
    match kind {
        Detrend::Constant => Ok((mean, 0.0)),
        Detrend::Linear => {
            if vals.len() < 2 {
                return Err(DataError::TooShort {
                    what: "linear detrend",
                    needed: 2,
                    got: vals.len(),
                });
            }
            let kmean = idx.iter().map(|&k| k as f64).sum::<f64>() / n;
            let (mut sxy, mut sxx) = (0.0, 0.0);
            for (&k, &v) in idx.iter().zip(vals) {
                let dk = k as f64 - kmean;
                sxy += dk * (v - mean);
                sxx += dk * dk;
            }
            let b = sxy / sxx;
            Ok((mean - b * kmean, b))
        }
    }
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}

fn lcm(a: usize, b: usize) -> usize {
    a / gcd(a, b) * b
}

/// A signal with unmeasured (non-finite) samples filled by linear
/// interpolation between its measured neighbours and held before the
/// first and after the last measured sample (what a user without a
/// multirate tool does with an analyser's record). `None` with fewer than
/// two measured samples. O(N).
pub fn interpolate_unmeasured(y: &[f64]) -> Option<Vec<f64>> {
    let at: Vec<usize> = (0..y.len()).filter(|&t| y[t].is_finite()).collect();
    if at.len() < 2 {
        return None;
    }
    let (first, last) = (at[0], at[at.len() - 1]);
    let mut out = y.to_vec();
    out[..first].fill(y[first]);
    out[last..].fill(y[last]);
    for w in at.windows(2) {
        let (a, b) = (w[0], w[1]);
        for (t, v) in out.iter_mut().enumerate().take(b).skip(a) {
            let s = (t - a) as f64 / (b - a) as f64;
            *v = y[a] * (1.0 - s) + y[b] * s;
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests;

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
//! CSV ([`Dataset::to_csv_writer`], [`Dataset::from_csv_reader`]): a header
//! row `t,<inputs…>,<outputs…>` (each name optionally followed by
//! ` [unit]`), then one row per fast sample; a slowly sampled output has
//! **empty cells** between its samples.
//!
//! All checks are O(N·(n_u + n_y)); lifting is a copy, O(N·(n_u + n_y)).

use std::fmt;
use std::io;
use std::ops::Range;

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

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
    /// CSV: the input is empty or its first row is not a header.
    #[error("CSV has no header row{reason}")]
    CsvMissingHeader {
        /// Detail (empty or ": first row is numeric").
        reason: String,
    },
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
    /// CSV: a cell is neither a number nor empty (empty allowed in output columns only).
    #[error("CSV line {line}, column '{column}': cannot parse '{cell}' as a number")]
    CsvNonNumeric {
        /// 1-based line number.
        line: u64,
        /// Column name.
        column: String,
        /// The cell text.
        cell: String,
    },
    /// CSV: the layout does not match the options or cannot be inferred.
    #[error("CSV layout: {reason}")]
    CsvLayout {
        /// What is wrong.
        reason: String,
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

/// A per-channel list from [`CsvOptions`]: `given` when it has `n` entries
/// ([`DataError::DimensionMismatch`] otherwise), else `default()`.
fn per_channel<T: Clone>(
    what: &'static str,
    given: &Option<Vec<T>>,
    n: usize,
    default: impl FnOnce() -> DataResult<Vec<T>>,
) -> DataResult<Vec<T>> {
    match given {
        Some(v) if v.len() != n => Err(DataError::DimensionMismatch {
            what,
            expected: n,
            got: v.len(),
        }),
        Some(v) => Ok(v.clone()),
        None => default(),
    }
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
        for i in 0..self.n_inputs() {
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

    /// Writes the data set as CSV: header `t,<input names>,<output names>`
    /// (a unit is appended as ` [unit]`), one row per fast sample, t = kT,
    /// values in shortest round-trip form, empty cells where an output is not
    /// sampled. Errors: [`DataError::CsvIo`].
    pub fn to_csv_writer<W: io::Write>(&self, w: W) -> DataResult<()> {
        let mut wr = csv::Writer::from_writer(w);
        let label = |name: &str, unit: &Option<String>| match unit {
            Some(u) => format!("{name} [{u}]"),
            None => name.to_string(),
        };
        let mut header = vec!["t".to_string()];
        header.extend(self.inputs.iter().map(|c| label(&c.name, &c.unit)));
        header.extend(self.outputs.iter().map(|c| label(&c.name, &c.unit)));
        wr.write_record(&header).map_err(csv_io)?;
        let mut row: Vec<String> = Vec::with_capacity(header.len());
        // Times as decimals (0.3, not 0.30000000000000004, at T = 0.1 s):
        // k/f for an integer rate f = 1/T (one division), else k·T snapped.
        let rate = 1.0 / self.ts;
        let whole = rate.round();
        let time = |k: usize| {
            if whole >= 1.0 && (rate - whole).abs() <= 1e-12 * whole {
                k as f64 / whole
            } else {
                snap_period(k as f64 * self.ts)
            }
        };
        for k in 0..self.len() {
            row.clear();
            row.push(format!("{}", time(k)));
            row.extend((0..self.n_inputs()).map(|i| format!("{}", self.u[(k, i)])));
            row.extend((0..self.n_outputs()).map(|i| {
                let v = self.y[(k, i)];
                if v.is_nan() {
                    String::new()
                } else {
                    format!("{v}")
                }
            }));
            wr.write_record(&row).map_err(csv_io)?;
        }
        wr.flush().map_err(|e| DataError::CsvIo {
            reason: e.to_string(),
        })?;
        Ok(())
    }

    /// Reads a data set written by [`Dataset::to_csv_writer`] or any CSV with
    /// a header row (see [`CsvOptions`]). Output periods/offsets are inferred
    /// from the empty-cell pattern unless given; holds default to 1 unless
    /// given. Errors: [`DataError::CsvMissingHeader`], [`DataError::CsvRaggedRow`],
    /// [`DataError::CsvNonNumeric`], [`DataError::CsvLayout`],
    /// [`DataError::CsvIo`], and every [`Dataset::new`] error.
    pub fn from_csv_reader<R: io::Read>(r: R, opts: &CsvOptions) -> DataResult<Self> {
        let mut rd = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(r);
        let mut records = rd.records();
        let header = match records.next() {
            None => {
                return Err(DataError::CsvMissingHeader {
                    reason: String::new(),
                });
            }
            Some(h) => h.map_err(csv_io)?,
        };
        let names: Vec<String> = header.iter().map(str::to_string).collect();
        if names.iter().all(|c| c.is_empty()) {
            return Err(DataError::CsvMissingHeader {
                reason: ": the first row is empty".into(),
            });
        }
        if names
            .iter()
            .any(|c| !c.is_empty() && c.parse::<f64>().is_ok())
        {
            return Err(DataError::CsvMissingHeader {
                reason: ": the first row contains numbers".into(),
            });
        }
        let has_time = match opts.time_column {
            Some(b) => b,
            None => matches!(names[0].to_ascii_lowercase().as_str(), "t" | "time"),
        };
        let first = usize::from(has_time);
        let width = names.len();
        if width < first + opts.n_inputs {
            return Err(DataError::CsvLayout {
                reason: format!(
                    "{} columns, need {} input columns after {} time column(s)",
                    width, opts.n_inputs, first
                ),
            });
        }
        let n_out = width - first - opts.n_inputs;
        // Parse all rows: NaN marks an empty cell.
        let mut cells: Vec<f64> = Vec::new();
        let mut times: Vec<f64> = Vec::new();
        let mut n_rows = 0usize;
        for rec in records {
            let rec = rec.map_err(csv_io)?;
            let line = rec.position().map_or(n_rows as u64 + 2, |p| p.line());
            if rec.len() != width {
                return Err(DataError::CsvRaggedRow {
                    line,
                    expected: width,
                    got: rec.len(),
                });
            }
            for (c, cell) in rec.iter().enumerate() {
                let v = if cell.is_empty() && c >= first + opts.n_inputs {
                    f64::NAN
                } else {
                    match cell.parse::<f64>() {
                        Ok(v) if v.is_finite() => v,
                        _ => {
                            return Err(DataError::CsvNonNumeric {
                                line,
                                column: names[c].clone(),
                                cell: cell.to_string(),
                            });
                        }
                    }
                };
                if c < first {
                    times.push(v);
                } else {
                    cells.push(v);
                }
            }
            n_rows += 1;
        }
        if n_rows == 0 {
            return Err(DataError::Empty);
        }
        let ncols = width - first;
        let all = DMatrix::from_row_slice(n_rows, ncols, &cells);
        let u = all.columns(0, opts.n_inputs).into_owned();
        let y = all.columns(opts.n_inputs, n_out).into_owned();
        let ts = match (opts.ts, has_time) {
            (Some(t), _) => t,
            (None, true) => infer_ts(&times)?,
            (None, false) => {
                return Err(DataError::CsvLayout {
                    reason: "no time column and no ts given".into(),
                });
            }
        };
        let split = |label: &str| -> (String, Option<String>) {
            if let Some(stripped) = label.strip_suffix(']')
                && let Some(pos) = stripped.rfind(" [")
            {
                return (
                    stripped[..pos].to_string(),
                    Some(stripped[pos + 2..].to_string()),
                );
            }
            (label.to_string(), None)
        };
        let holds = per_channel("CsvOptions::holds", &opts.holds, opts.n_inputs, || {
            Ok(vec![1; opts.n_inputs])
        })?;
        let inputs = (0..opts.n_inputs)
            .map(|i| {
                let (name, unit) = split(&names[first + i]);
                InputChannel {
                    name,
                    unit,
                    hold: holds[i],
                    offset: 0,
                }
            })
            .collect();
        let sampling = per_channel("CsvOptions::sampling", &opts.sampling, n_out, || {
            (0..n_out)
                .map(|c| {
                    infer_sampling(c, y.column(c).as_slice(), &names[first + opts.n_inputs + c])
                })
                .collect()
        })?;
        let outputs = (0..n_out)
            .map(|c| {
                let (name, unit) = split(&names[first + opts.n_inputs + c]);
                OutputChannel {
                    name,
                    unit,
                    period: sampling[c].0,
                    offset: sampling[c].1,
                }
            })
            .collect();
        Self::new(ts, u, y, inputs, outputs)
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

/// Options of [`Dataset::from_csv_reader`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CsvOptions {
    /// Number of input columns (after the time column); the remaining columns
    /// are outputs. Default 0.
    pub n_inputs: usize,
    /// Base period; default None: taken from the time column (uniform
    /// spacing required, relative tolerance 1e-9).
    pub ts: Option<f64>,
    /// Whether the first column is time; default None: yes if its header is
    /// `t` or `time` (case-insensitive).
    pub time_column: Option<bool>,
    /// Input holds; default None: all 1.
    pub holds: Option<Vec<usize>>,
    /// (period, offset) per output; default None: inferred from the empty
    /// cells (equally spaced non-empty cells, no sample missing at either end).
    pub sampling: Option<Vec<(usize, usize)>>,
}

impl CsvOptions {
    /// Options for `n_inputs` input columns, everything else inferred.
    pub fn with_inputs(n_inputs: usize) -> Self {
        CsvOptions {
            n_inputs,
            ..Default::default()
        }
    }
}

fn csv_io(e: csv::Error) -> DataError {
    if let csv::ErrorKind::UnequalLengths {
        pos,
        expected_len,
        len,
    } = e.kind()
    {
        return DataError::CsvRaggedRow {
            line: pos.as_ref().map_or(0, |p| p.line()),
            expected: *expected_len as usize,
            got: *len as usize,
        };
    }
    DataError::CsvIo {
        reason: e.to_string(),
    }
}

/// The base period of a uniformly spaced time column from its first and
/// last instants over `rows` rows: (t_last − t₀)/(rows − 1), snapped to the
/// nearest number of 12 significant digits when it lies within 1e-14 of it
/// (relative: rounding of the division, not a different period), so that a column written in decimals (0, 0.1, …, 599.9)
/// gives 0.1 and not 0.09999999999999999 whatever its length. O(1).
pub fn period_from_times(t0: f64, t_last: f64, rows: usize) -> f64 {
    snap_period((t_last - t0) / (rows.max(2) - 1) as f64)
}

/// `ts` snapped to the nearest number of 12 significant digits when it lies
/// within 1e-14 of it (relative): the rounding of a product or quotient of
/// decimal periods (0.1 · 3 = 0.30000000000000004, 0.3 / 3 =
/// 0.09999999999999999) undone, any other period kept. O(1).
pub fn snap_period(ts: f64) -> f64 {
    match format!("{ts:.11e}").parse::<f64>() {
        Ok(snapped) if (snapped - ts).abs() <= 1e-14 * ts.abs() => snapped,
        _ => ts,
    }
}

fn infer_ts(times: &[f64]) -> DataResult<f64> {
    if times.len() < 2 {
        return Err(DataError::CsvLayout {
            reason:
                "cannot infer ts from a time column with fewer than 2 rows (give CsvOptions::ts)"
                    .into(),
        });
    }
    let n = times.len();
    let ts = period_from_times(times[0], times[n - 1], n);
    if !(ts.is_finite() && ts > 0.0) {
        return Err(DataError::InvalidSamplePeriod { ts });
    }
    for k in 2..n {
        if !time_step_within(times[0], times[k - 1], k, times[k]) {
            return Err(DataError::CsvLayout {
                reason: format!(
                    "time column is not uniformly spaced at row {k} (t = {}, {} after the row before, the spacing of the rows so far {}, within {} %)",
                    times[k],
                    times[k] - times[k - 1],
                    (times[k - 1] - times[0]) / (k - 1) as f64,
                    TIME_STEP_TOLERANCE * 100.0
                ),
            });
        }
    }
    Ok(ts)
}

/// How far a row's time step may be from the mean spacing of the rows
/// before it, relative to that spacing (every reader of a time column: the
/// command line's CSV and `.npy` readers, this crate's CSV reader): times
/// rounded as loggers write them (milliseconds at 30 Hz: steps of 0.033
/// and 0.034 s) or stored in single precision pass, a missing, repeated or
/// out-of-order row does not.
pub const TIME_STEP_TOLERANCE: f64 = 0.1;

/// Whether the time `t` of row `rows` (0-based; `rows ≥ 2`) steps from
/// the row before (`t_last`) by the mean spacing of the rows so far
/// (first time `t0`) within [`TIME_STEP_TOLERANCE`]. O(1).
pub fn time_step_within(t0: f64, t_last: f64, rows: usize, t: f64) -> bool {
    let mean = (t_last - t0) / (rows.max(2) - 1) as f64;
    ((t - t_last) - mean).abs() <= TIME_STEP_TOLERANCE * mean.abs()
}

fn infer_sampling(c: usize, col: &[f64], name: &str) -> DataResult<(usize, usize)> {
    output_sampling(col, None).map_err(|e| DataError::CsvLayout {
        reason: format!("output column {c} ('{name}'): {e} (give CsvOptions::sampling)"),
    })
}

/// Why an output column's samples do not follow one period
/// ([`output_sampling`]); sample indices count from 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SamplingError {
    /// Every value is missing.
    #[error("no samples (every value missing)")]
    NoSamples,
    /// One value in a column of several rows: no period to infer.
    #[error("a single sample does not determine the period")]
    SingleSample,
    /// The first value lies a period or more after the start.
    #[error("first sample at {first} but period {period}: a sample is missing at the start")]
    FirstMissing {
        /// Index of the first value.
        first: usize,
        /// The period.
        period: usize,
    },
    /// A sampling instant without a value.
    #[error("no value at sample {sample}, a sampling instant of period {period}")]
    MissingAt {
        /// The instant.
        sample: usize,
        /// The period.
        period: usize,
    },
    /// A value between two sampling instants.
    #[error("a value at sample {sample}, between the sampling instants of period {period}")]
    Between {
        /// The instant.
        sample: usize,
        /// The period.
        period: usize,
    },
}

/// The (period, offset) of an output column whose missing values (NaN)
/// mark the instants it is not sampled: the period `declared`, or the
/// distance from the first value to the next; the offset the first value's
/// index. Every instant k ≡ offset (mod period) must hold a value and no
/// other may; a record may end between two sampling instants (a logger
/// stopped before the analyser's next sample). The one rule of every
/// front end (the CSV and `.npy` readers of the command line, this
/// crate's CSV reader, the Python package). O(rows).
///
/// Errors: [`SamplingError`] naming the first sample that breaks the
/// pattern.
pub fn output_sampling(
    col: &[f64],
    declared: Option<usize>,
) -> Result<(usize, usize), SamplingError> {
    let first = col
        .iter()
        .position(|v| !v.is_nan())
        .ok_or(SamplingError::NoSamples)?;
    let period = match declared {
        Some(p) => p.max(1),
        None => match col[first + 1..].iter().position(|v| !v.is_nan()) {
            Some(gap) => gap + 1,
            None if col.len() == 1 => 1,
            None => return Err(SamplingError::SingleSample),
        },
    };
    if first >= period {
        return Err(SamplingError::FirstMissing { first, period });
    }
    for (k, v) in col.iter().enumerate() {
        let sampled = k % period == first;
        if sampled && v.is_nan() {
            return Err(SamplingError::MissingAt { sample: k, period });
        }
        if !sampled && !v.is_nan() {
            return Err(SamplingError::Between { sample: k, period });
        }
    }
    Ok((period, first))
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_channel_scale_is_its_standard_deviation_or_one() {
        assert_eq!(channel_scale(&[0.0, 4.0]), 2.0);
        // Unsampled (NaN) cells are left out; a constant or empty channel is 1.
        assert_eq!(channel_scale(&[0.0, f64::NAN, 4.0]), 2.0);
        assert_eq!(channel_scale(&[3.5, 3.5]), 1.0);
        assert_eq!(channel_scale(&[]), 1.0);
        // Units near the ends of the double range: the squares overflow
        // (underflow), the scale is still the deviation (it was 1, and a
        // record in units of 1e160 failed in the refinement's SVD).
        for unit in [1e160, 1e-170] {
            let s = channel_scale(&[0.0, 4.0 * unit]);
            assert!((s / (2.0 * unit) - 1.0).abs() < 1e-15, "{unit}: {s}");
        }
    }
    use proptest::prelude::*;

    #[test]
    fn a_decimal_time_column_gives_its_decimal_period() {
        // (599.9 − 0)/5999 is 0.09999999999999999 in binary.
        assert_eq!(period_from_times(0.0, 599.9, 6000), 0.1);
        assert_eq!(period_from_times(0.0, 59.9, 600), 0.1);
        assert_eq!(period_from_times(1.0, 3.5, 6), 0.5);
        // A period that is not a short decimal is kept as computed.
        let third = period_from_times(0.0, 1.0, 4);
        assert_eq!(third, 1.0 / 3.0);
        assert_eq!(snap_period(0.1 * 3.0), 0.3);
        assert_eq!(snap_period(0.3 / 3.0), 0.1);
        // Written times are decimals too, at an integer rate or not.
        for (ts, want) in [(0.1, "0.3,"), (0.08, "0.24,")] {
            let d =
                Dataset::single_rate(ts, DMatrix::zeros(4, 1), DMatrix::zeros(4, 1)).expect("data");
            let mut out = Vec::new();
            d.to_csv_writer(&mut out).expect("csv");
            let text = String::from_utf8(out).expect("utf8");
            assert!(text.contains(&format!("\n{want}")), "{text}");
        }
    }

    fn mr() -> Dataset {
        // 12 samples, input held 3, output 1 fast, output 2 every 4 at offset 1.
        let u = DMatrix::from_fn(12, 1, |k, _| (k / 3) as f64 - 1.5);
        let y = DMatrix::from_fn(12, 2, |k, c| {
            if c == 0 || k % 4 == 1 {
                (k * k) as f64 * 0.1 + c as f64
            } else {
                f64::NAN
            }
        });
        Dataset::new(
            0.5,
            u,
            y,
            vec![InputChannel::new("fuel", 3).with_unit("mm3")],
            vec![
                OutputChannel::new("speed", 1, 0).with_unit("rpm"),
                OutputChannel::new("lab", 4, 1),
            ],
        )
        .unwrap()
    }

    #[test]
    fn validation_errors() {
        let u = DMatrix::from_element(6, 1, 1.0);
        let y = DMatrix::from_element(6, 1, 2.0);
        assert!(matches!(
            Dataset::single_rate(0.0, u.clone(), y.clone()),
            Err(DataError::InvalidSamplePeriod { .. })
        ));
        assert!(matches!(
            Dataset::single_rate(f64::NAN, u.clone(), y.clone()),
            Err(DataError::InvalidSamplePeriod { .. })
        ));
        assert!(matches!(
            Dataset::single_rate(1.0, u.clone(), DMatrix::zeros(5, 1)),
            Err(DataError::DimensionMismatch { .. })
        ));
        assert!(matches!(
            Dataset::single_rate(1.0, DMatrix::zeros(0, 1), DMatrix::zeros(0, 1)),
            Err(DataError::Empty)
        ));
        let mut bad = u.clone();
        bad[(2, 0)] = f64::INFINITY;
        assert!(matches!(
            Dataset::single_rate(1.0, bad, y.clone()),
            Err(DataError::NonFiniteInput { sample: 2, .. })
        ));
        let mut bad = y.clone();
        bad[(3, 0)] = f64::NAN;
        assert!(matches!(
            Dataset::single_rate(1.0, u.clone(), bad),
            Err(DataError::MissingSample { sample: 3, .. })
        ));
        // (u, y) with the given channel layout
        let layout = |inputs, outputs| Dataset::new(1.0, u.clone(), y.clone(), inputs, outputs);
        let out2 = vec![OutputChannel::new("y", 2, 0)];
        assert!(matches!(
            layout(default_inputs(1), out2.clone()),
            Err(DataError::UnexpectedSample { sample: 1, .. })
        ));
        assert!(Dataset::from_fast(1.0, u.clone(), y.clone(), default_inputs(1), out2).is_ok());
        assert!(matches!(
            layout(vec![InputChannel::new("u", 0)], default_outputs(1)),
            Err(DataError::ZeroHold { channel: 0 })
        ));
        assert!(matches!(
            layout(default_inputs(1), vec![OutputChannel::new("y", 0, 0)]),
            Err(DataError::ZeroPeriod { channel: 0 })
        ));
        assert!(matches!(
            layout(default_inputs(1), vec![OutputChannel::new("y", 2, 2)]),
            Err(DataError::OffsetOutOfRange { .. })
        ));
        let steps = DMatrix::from_fn(6, 1, |k, _| k as f64);
        assert!(matches!(
            Dataset::new(
                1.0,
                steps,
                y.clone(),
                vec![InputChannel::new("u", 2)],
                default_outputs(1)
            ),
            Err(DataError::HoldViolated {
                sample: 1,
                hold: 2,
                ..
            })
        ));
        assert!(matches!(
            layout(default_inputs(2), default_outputs(1)),
            Err(DataError::DimensionMismatch { .. })
        ));
    }

    #[test]
    fn accessors_and_samples() {
        let d = mr();
        assert_eq!((d.len(), d.n_inputs(), d.n_outputs()), (12, 1, 2));
        assert!(!d.is_single_rate());
        assert_eq!(d.frame_period(), 12);
        let (idx, vals) = d.output_samples(1).unwrap();
        assert_eq!(idx, vec![1, 5, 9]);
        assert_eq!(vals, vec![1.1, 3.5, 9.1]);
        assert!(matches!(
            d.output_samples(2),
            Err(DataError::ChannelOutOfRange { .. })
        ));
        assert_eq!(d.input_samples(0).unwrap().0, vec![0, 3, 6, 9]);
    }

    /// The one sampling rule: every (period, offset, length) pattern is
    /// found again, with or without the period declared, including a
    /// record that ends between two samples; each break is named.
    #[test]
    fn output_sampling_finds_the_pattern_and_names_its_breaks() {
        let nan = f64::NAN;
        for period in 1..6 {
            for offset in 0..period {
                for len in [
                    offset + 1,
                    3 * period + offset,
                    3 * period + offset + period - 1,
                ] {
                    let col: Vec<f64> = (0..len)
                        .map(|k| if k % period == offset { k as f64 } else { nan })
                        .collect();
                    if col.iter().filter(|v| !v.is_nan()).count() >= 2 {
                        assert_eq!(output_sampling(&col, None), Ok((period, offset)));
                    }
                    assert_eq!(output_sampling(&col, Some(period)), Ok((period, offset)));
                }
            }
        }
        use SamplingError as S;
        assert_eq!(output_sampling(&[nan, nan], None), Err(S::NoSamples));
        assert_eq!(
            output_sampling(&[1.0, nan, nan], None),
            Err(S::SingleSample)
        );
        assert_eq!(
            output_sampling(&[nan, nan, nan, 1.0, nan, nan, 2.0], Some(3)),
            Err(S::FirstMissing {
                first: 3,
                period: 3
            })
        );
        assert_eq!(
            output_sampling(&[1.0, nan, 2.0, nan, nan, nan, 3.0], None),
            Err(S::MissingAt {
                sample: 4,
                period: 2
            })
        );
        assert_eq!(
            output_sampling(&[1.0, nan, 2.0, 5.0, 3.0], None),
            Err(S::Between {
                sample: 3,
                period: 2
            })
        );
    }

    #[test]
    fn slice_keeps_phase() {
        let d = mr();
        let s = d.slice(2..11).unwrap();
        assert_eq!(s.len(), 9);
        assert_eq!(s.outputs()[1].offset, 3); // absolute 5 → local 3
        assert_eq!(s.inputs()[0].offset, 1); // blocks at 3, 6, 9 → local 1, 4, 7
        let (idx, _) = s.output_samples(1).unwrap();
        assert_eq!(idx, vec![3, 7]);
        assert!(matches!(d.slice(5..5), Err(DataError::InvalidRange { .. })));
        assert!(matches!(
            d.slice(0..13),
            Err(DataError::InvalidRange { .. })
        ));
        // slicing twice = slicing once
        assert_eq!(s.slice(1..5).unwrap(), d.slice(3..7).unwrap());
    }

    #[test]
    fn detrend_removes_mean_and_line() {
        let d = mr();
        let c = d.detrend(Detrend::Constant).unwrap();
        for i in 0..2 {
            let (_, v) = c.output_samples(i).unwrap();
            assert!(v.iter().sum::<f64>().abs() < 1e-12);
        }
        let (_, v) = c.input_samples(0).unwrap();
        assert!(v.iter().sum::<f64>().abs() < 1e-12);
        let u = DMatrix::from_fn(8, 1, |k, _| (k / 2) as f64);
        let y = DMatrix::from_fn(8, 1, |k, _| 3.0 + 0.5 * k as f64);
        let d = Dataset::new(
            1.0,
            u,
            y,
            vec![InputChannel::new("u", 2)],
            default_outputs(1),
        )
        .unwrap();
        let l = d.detrend(Detrend::Linear).unwrap();
        assert!(l.y().iter().all(|v| v.abs() < 1e-12));
        assert!(l.u().iter().all(|v| v.abs() < 1e-12));
    }

    #[test]
    fn csv_round_trip_with_slow_column() {
        let d = mr();
        let mut buf = Vec::new();
        d.to_csv_writer(&mut buf).unwrap();
        let text = String::from_utf8(buf.clone()).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("t,fuel [mm3],speed [rpm],lab"));
        assert!(
            lines.next().unwrap().ends_with(','),
            "row 0 has an empty slow cell"
        );
        let opts = CsvOptions {
            holds: Some(vec![3]),
            ..CsvOptions::with_inputs(1)
        };
        let back = Dataset::from_csv_reader(buf.as_slice(), &opts).unwrap();
        assert_eq!(back, d);
        // explicit sampling works too
        let opts2 = CsvOptions {
            sampling: Some(vec![(1, 0), (4, 1)]),
            ..opts
        };
        assert_eq!(Dataset::from_csv_reader(buf.as_slice(), &opts2).unwrap(), d);
    }

    #[test]
    fn csv_errors() {
        let o = CsvOptions::with_inputs(1);
        let r = |s: &str| Dataset::from_csv_reader(s.as_bytes(), &o);
        assert!(matches!(r(""), Err(DataError::CsvMissingHeader { .. })));
        assert!(matches!(
            r("0,1,2\n1,2,3\n"),
            Err(DataError::CsvMissingHeader { .. })
        ));
        assert!(matches!(
            r("t,u,y\n0,1,2\n1,2\n"),
            Err(DataError::CsvRaggedRow {
                line: 3,
                expected: 3,
                got: 2
            })
        ));
        assert!(matches!(
            r("t,u,y\n0,1,2\n1,abc,3\n"),
            Err(DataError::CsvNonNumeric { line: 3, .. })
        ));
        assert!(matches!(
            r("t,u,y\n0,,2\n1,1,3\n"),
            Err(DataError::CsvNonNumeric { .. })
        ));
        assert!(matches!(
            r("t,u,y\n0,1,2\n1,1,\n2,1,4\n3,1,\n4,1,\n5,1,5\n"),
            Err(DataError::CsvLayout { .. })
        ));
        assert!(matches!(
            r("t,u,y\n0,1,2\n1,1,3\n3,1,4\n"),
            Err(DataError::CsvLayout { .. })
        ));
        assert!(matches!(
            r("u,y\n1,2\n1,3\n"),
            Err(DataError::CsvLayout { .. })
        ));
        let ok = Dataset::from_csv_reader(
            "u,y\n1,2\n1,3\n".as_bytes(),
            &CsvOptions {
                ts: Some(0.1),
                ..o.clone()
            },
        )
        .unwrap();
        assert_eq!(ok.len(), 2);
        let slow = r("t,u,y\n0,1,\n1,1,3\n2,1,\n3,1,4\n").unwrap();
        assert_eq!((slow.outputs()[0].period, slow.outputs()[0].offset), (2, 1));
        // The command line's time rule: times rounded as a logger writes
        // them (30 Hz in milliseconds) read, a missing row does not; a
        // record may end between two samples of a slow output.
        let rounded = r("t,u,y\n0,1,1\n0.033,1,2\n0.067,1,3\n0.1,1,4\n0.133,1,5\n").unwrap();
        assert!((rounded.ts() - 0.133 / 4.0).abs() < 1e-3);
        assert!(matches!(
            r("t,u,y\n0,1,1\n0.033,1,2\n0.1,1,3\n0.133,1,4\n"),
            Err(DataError::CsvLayout { .. })
        ));
        let ends_between = r("t,u,y\n0,1,1\n1,1,\n2,1,3\n3,1,\n4,1,5\n5,1,\n").unwrap();
        assert_eq!(ends_between.outputs()[0].period, 2);
    }

    #[test]
    fn lift_layout_and_errors() {
        let d = mr();
        let l = d.lift(4).unwrap();
        assert_eq!(l.u.shape(), (3, 4));
        assert_eq!(l.y.shape(), (3, 8));
        // channel 1 (lab), row 1, t = 1 is fast sample 5
        assert_eq!(l.y[(1, l.column(1, 1))], d.y()[(5, 1)]);
        assert_eq!(l.u[(2, 3)], d.u()[(11, 0)]);
        assert!(matches!(
            d.lift(5),
            Err(DataError::LengthNotMultiple { len: 12, factor: 5 })
        ));
        assert!(matches!(d.lift(0), Err(DataError::ZeroLiftFactor)));
        let (u, _) = l.unlift().unwrap();
        assert_eq!(&u, d.u());
    }

    proptest! {
        #[test]
        fn lift_unlift_identity(rows in 1usize..8, n in 1usize..6, p in 1usize..4, seed in 0u64..1000) {
            let x = DMatrix::from_fn(rows * n, p, |k, c| ((k * 31 + c * 7) as u64 ^ seed) as f64 * 0.25);
            let l = lift_signal(&x, n).unwrap();
            prop_assert_eq!(l.shape(), (rows, p * n));
            let back = unlift_signal(&l, n, p).unwrap();
            prop_assert_eq!(&back, &x);
            prop_assert_eq!(lift_signal(&back, n).unwrap(), l);
        }

        #[test]
        fn slice_then_samples_consistent(start in 0usize..12, len in 1usize..12) {
            let d = mr();
            let end = (start + len).min(12);
            prop_assume!(start < end);
            let s = d.slice(start..end).unwrap();
            let (idx, vals) = s.output_samples(1).unwrap();
            for (k, v) in idx.iter().zip(vals) {
                prop_assert_eq!(v, d.y()[(k + start, 1)]);
                prop_assert_eq!((k + start) % 4, 1);
            }
        }
    }
}

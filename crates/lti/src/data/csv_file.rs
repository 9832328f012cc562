//! CSV writing ([`Dataset::to_csv_writer`]: a header row
//! `t,<inputs…>,<outputs…>`, one row per fast sample, empty cells between a
//! slow output's samples) and the rules every reader of records follows,
//! defined once here: the time column's period ([`period_from_times`],
//! [`time_step_within`], [`TIME_STEP_TOLERANCE`]) and an output's sampling
//! pattern from its empty cells ([`output_sampling`]). Reading is
//! `lifted-data`'s. O(N·(n_u + n_y)).

use std::io;

use super::*;

impl Dataset {
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

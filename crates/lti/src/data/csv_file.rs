//! CSV records ([`Dataset::to_csv_writer`], [`Dataset::from_csv_reader`]):
//! a header row `t,<inputs…>,<outputs…>`, one row per fast sample, empty
//! cells between a slow output's samples; the time column's period and the
//! outputs' sampling patterns inferred once here for every front end
//! ([`infer_ts`], [`output_sampling`], [`TIME_STEP_TOLERANCE`]). O(N·(n_u + n_y)).

use std::io;

use nalgebra::DMatrix;

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

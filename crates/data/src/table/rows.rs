//! The row count and time-column checks shared by the CSV and `.npy`
//! readers.

use super::*;

/// How far a row's time step may be from the mean spacing of the rows
/// before it, relative to that spacing (`lifted_lti`'s rule, shared by
/// every reader of a time column).
pub(crate) use lifted_lti::TIME_STEP_TOLERANCE;

/// Row count and time-column checks shared by the CSV and `.npy` readers.
pub(crate) struct RowCheck {
    pub(super) ts: Option<f64>,
    pub(super) t0: f64,
    pub(super) t_last: f64,
    /// Rows accepted so far.
    pub(crate) rows: usize,
}

impl RowCheck {
    /// Checks for a file whose base period is `ts` (`None`: from the time column).
    pub(crate) fn new(ts: Option<f64>) -> Self {
        RowCheck {
            ts,
            t0: f64::NAN,
            t_last: f64::NAN,
            rows: 0,
        }
    }

    /// Whether the time column is read (no `--ts`).
    pub(crate) fn wants_time(&self) -> bool {
        self.ts.is_none()
    }

    /// Checks time `t` of the next row: its step from the previous row
    /// within [`TIME_STEP_TOLERANCE`] of the mean spacing of the rows
    /// before, so that times rounded as loggers write them (milliseconds
    /// at 30 Hz: steps of 0.033 and 0.034 s) or stored in single precision
    /// pass, while a missing, repeated or out-of-order row does not; `at`
    /// locates the row in messages ("line 7", "row 5").
    #[inline]
    pub(crate) fn time(
        &mut self,
        path: &str,
        at: &dyn Display,
        column: &str,
        t: f64,
    ) -> crate::Result<()> {
        match self.rows {
            0 => self.t0 = t,
            1 => {}
            rows => {
                let mean = (self.t_last - self.t0) / (rows - 1) as f64;
                let step = t - self.t_last;
                if !lifted_lti::time_step_within(self.t0, self.t_last, rows, t) {
                    return Err(input(format!(
                        "{path}: {at}, column '{column}': time {t} is {step} after the row before, not the spacing {mean} of the rows so far (within {} %): a missing, repeated or out-of-order row? give --ts to ignore the time column",
                        TIME_STEP_TOLERANCE * 100.0
                    )));
                }
            }
        }
        self.t_last = t;
        Ok(())
    }

    /// The row count and the base period once every row is read:
    /// `ts`, or from the time column (`has_time`).
    pub(crate) fn finish(&self, path: &str, has_time: bool) -> crate::Result<(usize, f64)> {
        let rows = self.rows;
        if rows == 0 {
            return Err(input(format!("{path}: no data rows after the header")));
        }
        let ts = match self.ts {
            Some(ts) if ts.is_finite() && ts > 0.0 => ts,
            Some(ts) => return Err(input(format!("--ts {ts}: must be positive and finite"))),
            None => {
                if !has_time {
                    return Err(input(format!(
                        "{path}: no time column ('t' or 'time'): give the base period with --ts"
                    )));
                }
                if rows < 2 {
                    return Err(input(format!(
                        "{path}: one row: give the base period with --ts"
                    )));
                }
                let ts = lifted_lti::period_from_times(self.t0, self.t_last, rows);
                if !(ts.is_finite() && ts > 0.0) {
                    return Err(input(format!(
                        "{path}: the time column does not increase: give --ts"
                    )));
                }
                ts
            }
        };
        Ok((rows, ts))
    }
}

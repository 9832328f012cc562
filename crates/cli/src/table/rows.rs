//! The row count and time-column checks shared by the CSV and `.npy`
//! readers.

use super::*;

/// Row count and time-column checks shared by the CSV and `.npy` readers.
pub(crate) struct RowCheck {
    pub(super) ts: Option<f64>,
    pub(super) t0: f64,
    pub(super) t1: f64,
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
            t1: f64::NAN,
            t_last: f64::NAN,
            rows: 0,
        }
    }

    /// Whether the time column is read (no `--ts`).
    pub(crate) fn wants_time(&self) -> bool {
        self.ts.is_none()
    }

    /// Checks time `t` of the next row against the spacing of the first two;
    /// `at` locates the row in messages ("line 7", "row 5").
    #[inline]
    pub(crate) fn time(
        &mut self,
        path: &str,
        at: &dyn Display,
        column: &str,
        t: f64,
    ) -> CliResult<()> {
        match self.rows {
            0 => self.t0 = t,
            1 => self.t1 = t,
            rows => {
                let dt = self.t1 - self.t0;
                let expect = self.t0 + rows as f64 * dt;
                if (t - expect).abs() > 1e-6 * dt.abs().max(1e-300) + 1e-9 * expect.abs() {
                    return Err(input(format!(
                        "{path}: {at}, column '{column}': time {t} breaks the uniform spacing {dt} (expected {expect}); give --ts to ignore the time column"
                    )));
                }
            }
        }
        self.t_last = t;
        Ok(())
    }

    /// The row count and the base period once every row is read:
    /// `ts`, or from the time column (`has_time`).
    pub(crate) fn finish(&self, path: &str, has_time: bool) -> CliResult<(usize, f64)> {
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

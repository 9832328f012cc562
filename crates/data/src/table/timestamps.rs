//! Time stamps in the time column: ISO 8601 dates and times
//! (`2026-11-26T10:00:00.5`, `2026-11-26 10:00:00Z`, `…+01:00`), as data
//! historians and loggers export them, read as seconds after the first
//! row's stamp (the column's spacing is then the base period T, as for a
//! column of seconds).

use std::sync::OnceLock;

use time::format_description::well_known::Iso8601;
use time::{Date, OffsetDateTime, PrimitiveDateTime};

/// Nanoseconds since the Unix epoch of an ISO 8601 date and time (a space
/// may stand for the `T`; without an offset the time is taken as UTC —
/// only differences are used; a date alone is its midnight); `None` for
/// anything else. O(len).
pub(super) fn epoch_nanos(text: &str) -> Option<i128> {
    let text = text.trim();
    // `YYYY-MM-DD hh:mm…`: the space of spreadsheets and SQL for the `T`.
    let owned;
    let text = match text.as_bytes().get(10) {
        Some(b' ') if text.len() > 11 => {
            owned = format!("{}T{}", &text[..10], text[11..].trim_start());
            owned.as_str()
        }
        _ => text,
    };
    if let Ok(t) = OffsetDateTime::parse(text, &Iso8601::PARSING) {
        return Some(t.unix_timestamp_nanos());
    }
    if let Ok(t) = PrimitiveDateTime::parse(text, &Iso8601::PARSING) {
        return Some(t.assume_utc().unix_timestamp_nanos());
    }
    // A date alone (daily samples): its midnight.
    Date::parse(text, &Iso8601::PARSING)
        .ok()
        .map(|d| d.midnight().assume_utc().unix_timestamp_nanos())
}

/// The first stamp of a file's time column, shared by the threads reading
/// it: every stamp is read as seconds after it.
#[derive(Debug, Default)]
pub(super) struct Epoch(OnceLock<i128>);

impl Epoch {
    /// Seconds of the stamp `nanos` after the first stamp seen (0 for the
    /// first).
    pub(super) fn seconds(&self, nanos: i128) -> f64 {
        let first = *self.0.get_or_init(|| nanos);
        (nanos - first) as f64 * 1e-9
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iso_stamps_in_their_usual_forms() {
        let t0 = epoch_nanos("2026-11-26T10:00:00").unwrap();
        assert_eq!(
            epoch_nanos("2026-11-26 10:00:00.5").unwrap() - t0,
            500_000_000
        );
        assert_eq!(
            epoch_nanos(" 2026-11-26T10:00:01Z ").unwrap() - t0,
            1_000_000_000
        );
        // An offset moves the instant: 11:00+01:00 is 10:00 UTC.
        assert_eq!(epoch_nanos("2026-11-26T11:00:00+01:00").unwrap(), t0);
        // Across midnight and a month's end.
        let d = epoch_nanos("2026-12-01T00:00:00").unwrap()
            - epoch_nanos("2026-11-30T23:59:59.9").unwrap();
        assert_eq!(d, 100_000_000);
        assert_eq!(
            epoch_nanos("2026-11-27").unwrap() - epoch_nanos("2026-11-26").unwrap(),
            86_400_000_000_000
        );
        for bad in ["", "0.1", "abc", "2026-13-01T00:00:00", "26.11.2026 10:00"] {
            assert!(epoch_nanos(bad).is_none(), "{bad}");
        }
        let e = Epoch::default();
        assert_eq!(e.seconds(t0), 0.0);
        assert_eq!(e.seconds(t0 + 2_500_000_000), 2.5);
    }
}

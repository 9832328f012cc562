//! Resource limits shared by every entry point that sizes its work by user
//! options (horizons, orders, periods, thread counts).
//!
//! * [`MemoryBudget`]: the bytes one request may allocate. Default: half the
//!   machine's physical memory (`MemTotal` of `/proc/meminfo`; 8 GiB where
//!   that cannot be read), overridden by the environment variable
//!   [`MEMORY_LIMIT_ENV`] (`LIFTED_MEMORY_LIMIT`, bytes) or for the whole
//!   process by [`MemoryBudget::set_process_default`]. A request above it is
//!   [`Error::TooLarge`] before anything is allocated, so that an option such
//!   as a horizon of 100 000 is a message, not an abort of the process.
//! * [`Size`]: checked byte arithmetic (an overflow is "more than any
//!   budget", never a wrapped small number).
//! * [`resolve_threads`]: the one rule for a `threads` option (0 = all
//!   available cores, anything else capped at the available parallelism).
//!
//! # Example
//!
//! ```
//! use lifted_linalg::budget::{MemoryBudget, Size};
//! use lifted_linalg::Error;
//!
//! let budget = MemoryBudget::from_bytes(1 << 30); // 1 GiB
//! // Two k×k matrices of f64 for k = 1000: 16 MB, accepted.
//! budget.check("Hankel factor", Size::matrices(2, 1000, 1000))?;
//! // k = 800 000 (horizon 100 000, four channels): 5.1 TB, refused.
//! let e = budget.check("Hankel factor", Size::matrices(1, 800_000, 800_000)).unwrap_err();
//! assert!(matches!(e, Error::TooLarge { .. }));
//! # Ok::<(), Error>(())
//! ```

use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};
pub use crate::units::format_bytes;

/// Environment variable that overrides the default memory budget (bytes,
/// a plain decimal integer).
pub const MEMORY_LIMIT_ENV: &str = "LIFTED_MEMORY_LIMIT";

/// Budget used when the physical memory cannot be read (8 GiB).
pub const FALLBACK_BUDGET_BYTES: u64 = 8 << 30;

/// Process-wide override set by [`MemoryBudget::set_process_default`]
/// (0 = none).
static PROCESS_DEFAULT: AtomicU64 = AtomicU64::new(0);

/// A number of bytes, or "more than 2⁶⁴" after an overflow ([`Size::OVERFLOW`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct Size(Option<u64>);

impl Size {
    /// A size that overflowed 64-bit arithmetic.
    pub const OVERFLOW: Size = Size(None);
    /// Zero bytes.
    pub const ZERO: Size = Size(Some(0));

    /// `bytes` bytes.
    pub fn bytes(bytes: u64) -> Size {
        Size(Some(bytes))
    }

    /// `count` matrices of `rows`×`cols` f64 entries.
    pub fn matrices(count: usize, rows: usize, cols: usize) -> Size {
        Size::f64s(count).times(rows).times(cols)
    }

    /// `count` f64 (or usize) values.
    pub fn f64s(count: usize) -> Size {
        Size::bytes(8).times(count)
    }

    /// This size times `factor` (checked).
    #[must_use]
    pub fn times(self, factor: usize) -> Size {
        Size(
            self.0
                .and_then(|b| u64::try_from(factor).ok().and_then(|f| b.checked_mul(f))),
        )
    }

    /// The sum of two sizes (checked).
    #[must_use]
    pub fn plus(self, other: Size) -> Size {
        Size(self.0.and_then(|a| other.0.and_then(|b| a.checked_add(b))))
    }

    /// The bytes, `None` after an overflow.
    pub fn get(self) -> Option<u64> {
        self.0
    }
}

/// The largest allocation one request may make (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemoryBudget {
    bytes: u64,
}

impl Default for MemoryBudget {
    /// [`MemoryBudget::set_process_default`] if called, else
    /// `LIFTED_MEMORY_LIMIT` if it holds a positive integer, else half the
    /// physical memory, else [`FALLBACK_BUDGET_BYTES`].
    fn default() -> Self {
        let set = PROCESS_DEFAULT.load(Ordering::Relaxed);
        if set > 0 {
            return MemoryBudget { bytes: set };
        }
        if let Some(b) = std::env::var(MEMORY_LIMIT_ENV)
            .ok()
            .and_then(|s| s.trim().parse::<u64>().ok())
            .filter(|&b| b > 0)
        {
            return MemoryBudget { bytes: b };
        }
        MemoryBudget {
            bytes: physical_memory().map_or(FALLBACK_BUDGET_BYTES, |m| m / 2),
        }
    }
}

impl MemoryBudget {
    /// A budget of `bytes` bytes.
    pub fn from_bytes(bytes: u64) -> Self {
        MemoryBudget { bytes }
    }

    /// Sets the budget [`MemoryBudget::default`] returns in this process
    /// (0 restores the environment / physical-memory rule).
    pub fn set_process_default(bytes: u64) {
        PROCESS_DEFAULT.store(bytes, Ordering::Relaxed);
    }

    /// The budget in bytes.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// [`Error::TooLarge`] naming `what` when `needed` exceeds the budget
    /// (or overflowed).
    pub fn check(&self, what: &'static str, needed: Size) -> Result<()> {
        match needed.get() {
            Some(b) if b <= self.bytes => Ok(()),
            got => Err(Error::TooLarge {
                what,
                needed_bytes: got.unwrap_or(u64::MAX),
                budget_bytes: self.bytes,
            }),
        }
    }
}

/// `MemTotal` of `/proc/meminfo` in bytes (`None` elsewhere or unreadable),
/// read once per process (the machine's memory does not change under it;
/// reading the file took ≈ 25 µs, 1.5 % of a fresh N = 1e4 streamed
/// identification, which asks for it through every default
/// [`MemoryBudget`]).
pub fn physical_memory() -> Option<u64> {
    static TOTAL: std::sync::OnceLock<Option<u64>> = std::sync::OnceLock::new();
    *TOTAL.get_or_init(|| {
        let text = std::fs::read_to_string("/proc/meminfo").ok()?;
        parse_mem_total(&text)
    })
}

/// The `MemTotal:  N kB` line of a `/proc/meminfo` text, in bytes.
fn parse_mem_total(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let mut parts = line["MemTotal:".len()..].split_whitespace();
    let value: u64 = parts.next()?.parse().ok()?;
    let unit = match parts.next() {
        Some("kB") | Some("KB") => 1024,
        None => 1,
        Some(_) => return None,
    };
    value.checked_mul(unit)
}

/// The machine's available parallelism ([`std::thread::available_parallelism`],
/// 1 when unknown), read once per process: on Linux it reads the cgroup
/// quota files (/proc/self/cgroup, cpu.max: a dozen system calls, ≈ 0.05 ms
/// each time, measured with perf as 3 % of a fresh N = 1e4 identification
/// that asked for it several times).
pub fn available_cores() -> usize {
    static CORES: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// Threads to use for a `threads` option: 0 = all available cores, any other
/// count capped at [`std::thread::available_parallelism`] (1 when that is
/// unknown). Every entry point that reads a `threads` option goes through it,
/// so no option value can make a routine spawn more threads than the machine
/// runs at once.
pub fn resolve_threads(requested: usize) -> usize {
    let available = available_cores();
    if requested == 0 {
        available
    } else {
        requested.min(available)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_overflow_to_more_than_any_budget() {
        let s = Size::matrices(1, usize::MAX, 2);
        assert_eq!(s, Size::OVERFLOW);
        assert_eq!(Size::bytes(u64::MAX).plus(Size::bytes(1)), Size::OVERFLOW);
        let e = MemoryBudget::from_bytes(u64::MAX)
            .check("x", s)
            .unwrap_err();
        assert!(matches!(
            e,
            Error::TooLarge {
                needed_bytes: u64::MAX,
                ..
            }
        ));
        assert_eq!(Size::matrices(2, 3, 4).get(), Some(192));
    }

    #[test]
    fn budget_accepts_up_to_its_limit() {
        let b = MemoryBudget::from_bytes(800);
        assert!(b.check("x", Size::f64s(100)).is_ok());
        let e = b.check("Hankel factor", Size::f64s(101)).unwrap_err();
        assert_eq!(
            e,
            Error::TooLarge {
                what: "Hankel factor",
                needed_bytes: 808,
                budget_bytes: 800
            }
        );
        let msg = e.to_string();
        assert!(
            msg.contains("Hankel factor") && msg.contains(MEMORY_LIMIT_ENV),
            "{msg}"
        );
    }

    #[test]
    fn meminfo_is_parsed() {
        let t = "MemTotal:       24542412 kB\nMemFree:  1 kB\n";
        assert_eq!(parse_mem_total(t), Some(24_542_412 * 1024));
        assert_eq!(parse_mem_total("MemFree: 1 kB"), None);
        assert_eq!(parse_mem_total("MemTotal: x kB"), None);
    }

    #[test]
    fn threads_are_capped_at_the_machine() {
        let avail = std::thread::available_parallelism().map_or(1, |n| n.get());
        assert_eq!(available_cores(), avail);
        assert_eq!(resolve_threads(0), avail);
        assert_eq!(resolve_threads(100_000), avail);
        assert_eq!(resolve_threads(1), 1);
    }

    #[test]
    fn bytes_are_formatted() {
        assert_eq!(format_bytes(512), "512 bytes");
        assert_eq!(
            format_bytes(5_120_000_000_000),
            "5.120 TB (5120000000000 bytes)"
        );
    }
}

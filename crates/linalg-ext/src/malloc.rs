//! The C allocator's thresholds for executables that run short
//! identifications (the `lifted` command, the benchmark peers).
//!
//! glibc serves every allocation of 128 KiB or more by a fresh `mmap`, and
//! returns it by `munmap` when freed: each k×k working matrix of a subspace
//! identification (k = 2 s (n_u + n_y); 200 KiB at k = 160) is then new,
//! zero-filled pages, one page fault per 4 KiB, every time it is allocated.
//! [`tune_malloc`] raises the mmap threshold to 4 MiB (and the trim
//! threshold, as glibc does itself when it adapts the mmap threshold, to
//! twice that), so such matrices come from the heap and reuse its pages.
//! Measured on the 1e4-sample 2×2 benchmark record (`peer_lifted
//! --stream`, s = 20, fresh process per run, 10 runs each, interleaved):
//! 2.40–2.56 ms → 2.02–2.08 ms identification; peak RSS of a 1e6-sample
//! streamed run 11.5 → 12.1 MB. Blocks of 4 MiB and more (records, the
//! streamed blocks of long files) stay on `mmap`, so memory that streaming
//! frees still goes back to the system.
//!
//! A process-wide setting: libraries must not call it (the Python module
//! does not); a no-op where the C library is not glibc.

use std::sync::OnceLock;

/// Allocations from this size on are served by `mmap` (bytes).
pub const MMAP_THRESHOLD: usize = 4 << 20;

/// Free memory at the top of the heap above this size is returned to the
/// system (bytes): twice [`MMAP_THRESHOLD`], glibc's own ratio.
pub const TRIM_THRESHOLD: usize = 8 << 20;

/// Sets glibc's mmap and trim thresholds ([`MMAP_THRESHOLD`],
/// [`TRIM_THRESHOLD`]) once per process; returns whether the C library
/// took them (false elsewhere than Linux with glibc). Call it first thing
/// in `main` of an executable, before allocating matrices.
pub fn tune_malloc() -> bool {
    static TOOK: OnceLock<bool> = OnceLock::new();
    *TOOK.get_or_init(set_thresholds)
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn set_thresholds() -> bool {
    let as_int = |v: usize| libc::c_int::try_from(v).unwrap_or(libc::c_int::MAX);
    // SAFETY: mallopt takes two integers and only changes the allocator's
    // parameters; it is safe to call at any time (glibc takes its lock).
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, as_int(MMAP_THRESHOLD)) == 1
            && libc::mallopt(libc::M_TRIM_THRESHOLD, as_int(TRIM_THRESHOLD)) == 1
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn set_thresholds() -> bool {
    false
}

#[cfg(test)]
mod tests {
    #[test]
    fn tuning_is_idempotent_and_allocation_still_works() {
        let first = super::tune_malloc();
        assert_eq!(super::tune_malloc(), first);
        #[cfg(all(target_os = "linux", target_env = "gnu"))]
        assert!(first, "glibc refused the thresholds");
        // Sizes on both sides of the threshold allocate, fill and free.
        for n in [1 << 10, 200 << 10, 8 << 20] {
            let v = vec![1.0f64; n / 8];
            assert_eq!(v.iter().sum::<f64>(), (n / 8) as f64);
        }
    }
}

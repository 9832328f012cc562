//! Overlapping faer's one-time set-up with the caller's work, and keeping
//! faer's high-level solvers from starting a thread pool they do not use.
//!
//! The first faer matrix product above 16³ multiply-adds in a process
//! initialises its x86 kernels' cache parameters by reading the cache
//! description of every CPU from `/sys/devices/system/cpu` (dozens of small
//! files, ≈ 0.5 ms on Linux, measured with perf in the N = 1e4
//! identification). [`warm_up`] does that on a short-lived background
//! thread, so that it runs while the caller reads or compresses data
//! instead of delaying the first decomposition.
//!
//! faer's high-level solvers (SVD, eigenvalues, LU, ...) read faer's global
//! parallelism, whose default asks rayon for its thread count and thereby
//! starts rayon's global pool — on the first small SVD of an
//! identification, whose idle workers then spin on the caller's cores
//! (≈ 0.1 ms of a 1.3 ms N = 1e4 identification on 2 cores, measured).
//! [`pin_parallelism`] sets the same count explicitly, so the pool starts
//! only when some decomposition is large enough to run in parallel.

use std::sync::Once;

/// Starts, once per process, a background thread that performs one 17×17
/// faer product (the size above faer's small-matrix kernel; sequential, so
/// no thread pool is started), which makes faer read its cache parameters
/// there. Returns at once; calling it again
/// costs an atomic load. A thread that cannot be spawned is not an error:
/// the set-up then happens on first use, as without this call.
///
/// It also calls [`pin_parallelism`].
pub fn warm_up() {
    pin_parallelism();
    static STARTED: Once = Once::new();
    STARTED.call_once(|| {
        let _ = std::thread::Builder::new()
            .name("lifted-warm-up".into())
            .spawn(|| {
                // Sequential on purpose: `&a * &a` would take faer's global
                // parallelism and start rayon's thread pool, whose idle
                // workers spin on the caller's cores for a while.
                let a = faer::Mat::<f64>::identity(17, 17);
                let mut p = faer::Mat::<f64>::zeros(17, 17);
                faer::linalg::matmul::matmul(
                    p.as_mut(),
                    faer::Accum::Replace,
                    a.as_ref(),
                    a.as_ref(),
                    1.0,
                    faer::Par::Seq,
                );
                std::hint::black_box(&p);
            });
    });
}

/// Sets faer's global parallelism, once per process, to an explicit rayon
/// thread count — `RAYON_NUM_THREADS` when set to a positive number, else
/// the available parallelism, the count faer's default would obtain from
/// rayon — so that reading it does not start rayon's global pool. Called
/// by [`warm_up`] (so by lifted's identification entry points); a later
/// `faer::set_global_parallelism` by the caller takes precedence.
pub fn pin_parallelism() {
    static PINNED: Once = Once::new();
    PINNED.call_once(|| {
        let from_env = std::env::var("RAYON_NUM_THREADS")
            .ok()
            .and_then(|v| v.trim().parse::<usize>().ok())
            .filter(|&n| n > 0);
        let threads = from_env.unwrap_or_else(crate::budget::available_cores);
        faer::set_global_parallelism(faer::Par::rayon(threads));
    });
}

#[cfg(test)]
mod tests {
    #[test]
    fn warm_up_is_idempotent_and_leaves_results_alone() {
        super::warm_up();
        super::warm_up();
        let a = nalgebra::DMatrix::from_fn(20, 20, |i, j| (i + 2 * j) as f64);
        let r = crate::qr_r(&a).expect("qr");
        assert_eq!(r.shape(), (20, 20));
        // The global parallelism is an explicit count: reading it does
        // not need rayon's pool.
        assert!(matches!(faer::get_global_parallelism(), faer::Par::Rayon(n) if n.get() >= 1));
    }
}

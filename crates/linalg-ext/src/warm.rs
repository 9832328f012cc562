//! Overlapping faer's one-time set-up with the caller's work.
//!
//! The first faer matrix product above 16³ multiply-adds in a process
//! initialises its x86 kernels' cache parameters by reading the cache
//! description of every CPU from `/sys/devices/system/cpu` (dozens of small
//! files, ≈ 0.5 ms on Linux, measured with perf in the N = 1e4
//! identification). [`warm_up`] does that on a short-lived background
//! thread, so that it runs while the caller reads or compresses data
//! instead of delaying the first decomposition.

use std::sync::Once;

/// Starts, once per process, a background thread that performs one 17×17
/// faer product (the size above faer's small-matrix kernel), which makes
/// faer read its cache parameters there. Returns at once; calling it again
/// costs an atomic load. A thread that cannot be spawned is not an error:
/// the set-up then happens on first use, as without this call.
pub fn warm_up() {
    static STARTED: Once = Once::new();
    STARTED.call_once(|| {
        let _ = std::thread::Builder::new()
            .name("lifted-warm-up".into())
            .spawn(|| {
                let a = faer::Mat::<f64>::identity(17, 17);
                std::hint::black_box(&a * &a);
            });
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
    }
}

//! The vector instructions of the hot loops, chosen when the program runs.
//!
//! The workspace builds for the baseline of its target (x86-64: SSE2), so a
//! binary or Python wheel runs on any CPU of the architecture. The loops that
//! decide the speed (the prediction-error sweeps, the modal filters, the
//! simulation and validation loops, the R-factor folds) run inside
//! [`dispatch`], which calls them through a function compiled for AVX2 and
//! FMA when the CPU has both: the closure is inlined there (its one call
//! site), so its loops vectorise four lanes wide and `f64::mul_add` is one
//! instruction instead of a call to the C library's `fma`.
//!
//! Results do not depend on the path taken: Rust neither contracts `a * b + c`
//! into a fused multiply-add nor reorders floating-point sums when it
//! vectorises, and `mul_add` rounds once on every path, so both paths compute
//! the same bits (tested below, and by the workspace's reproductions run on
//! both builds).
//!
//! The hand-written kernels (`fold`, the lagged sums of `lifted-subspace`)
//! take an [`Avx2Fma`] token, which only [`Avx2Fma::detect`] makes: holding
//! one is the proof that the instructions exist, so the soundness of those
//! kernels rests on no check made elsewhere.

/// Proof that this CPU has AVX2 and FMA (x86-64): made only by
/// [`Avx2Fma::detect`]. Copy it into the kernels that use the instructions.
#[derive(Clone, Copy, Debug)]
pub struct Avx2Fma {
    _detected: (),
}

impl Avx2Fma {
    /// The token when the CPU has AVX2 and FMA, `None` otherwise (and on
    /// other architectures). `std`'s detection is cached: one atomic load.
    #[inline]
    pub fn detect() -> Option<Self> {
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
                return Some(Avx2Fma { _detected: () });
            }
        }
        None
    }

    /// Runs `f` inside a function compiled for AVX2 and FMA (see the module
    /// docs).
    #[inline(always)]
    pub fn run<R>(self, f: impl FnOnce() -> R) -> R {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: `self` exists only where `detect` found AVX2 and FMA.
            unsafe { with_avx2_fma(f) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            f()
        }
    }
}

/// Runs `f` compiled for AVX2 and FMA when the CPU has them, as compiled
/// for the baseline otherwise; the same result either way (module docs).
/// Wrap a loop nest, not a single operation: the check is one atomic load
/// and the call is not inlined into the caller. Mark the closure
/// `#[inline(always)]`: a closure that is not inlined into the AVX2
/// function is compiled for the baseline and gains nothing (seen on large
/// closures and on those of generic functions).
///
/// ```
/// let x = [1.0f64, 2.0, 3.0];
/// let s = lifted_linalg::simd::dispatch(
///     #[inline(always)]
///     || x.iter().map(|v| v.mul_add(2.0, 1.0)).sum::<f64>(),
/// );
/// assert_eq!(s, 15.0);
/// ```
#[inline(always)]
pub fn dispatch<R>(f: impl FnOnce() -> R) -> R {
    match Avx2Fma::detect() {
        Some(simd) => simd.run(f),
        None => f(),
    }
}

/// `f()` with AVX2 and FMA enabled for the code inlined into it.
///
/// # Safety
/// The CPU must have AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn with_avx2_fma<R>(f: impl FnOnce() -> R) -> R {
    f()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A loop with fused multiply-adds, a vectorisable sum and a division:
    /// the dispatched path and the baseline path give the same bits.
    #[test]
    fn both_paths_give_the_same_bits() {
        let x: Vec<f64> = (0..1001)
            .map(|i| ((i * 7919) % 1000) as f64 / 37.0 - 11.0)
            .collect();
        let work = |x: &[f64]| -> (f64, Vec<f64>) {
            let y: Vec<f64> = x.iter().map(|v| v.mul_add(1.0 / 3.0, 0.1) / 1.7).collect();
            let mut acc = [0.0; 4];
            for c in y.chunks_exact(4) {
                for i in 0..4 {
                    acc[i] = c[i].mul_add(c[i], acc[i]);
                }
            }
            (acc.iter().sum(), y)
        };
        let plain = work(&x);
        let dispatched = dispatch(|| work(&x));
        assert_eq!(plain.0.to_bits(), dispatched.0.to_bits());
        for (a, b) in plain.1.iter().zip(&dispatched.1) {
            assert_eq!(a.to_bits(), b.to_bits());
        }
        if let Some(simd) = Avx2Fma::detect() {
            let forced = simd.run(|| work(&x));
            assert_eq!(plain.0.to_bits(), forced.0.to_bits());
        }
    }
}

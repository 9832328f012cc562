//! Resource checks of the identification entry points, before anything is
//! allocated: the memory a horizon or order asks for against
//! [`lifted_linalg::budget::MemoryBudget`] ([`lifted_linalg::Error::TooLarge`],
//! wrapped in [`Error::Linalg`]), checked size arithmetic, the thread-count
//! rule, and the parameter-count and work bounds of [`crate::refine_pem`].
//!
//! The estimates count the large buffers of each route, not every small
//! temporary; they err on the large side by a small factor.

use lifted_linalg::budget::{MemoryBudget, Size, resolve_threads};

use crate::error::{Error, Result};
use crate::hankel::Compression;

/// k×k f64 matrices alive at once in the subspace identification (the Gram
/// matrix or R accumulator, the factor L, the weighted projection, the SVD
/// factors and their work space); counted as six.
const HANKEL_SQUARE_MATRICES: usize = 6;

/// Largest QR row block counted for [`Compression::Qr`] (the routes push at
/// most this many samples at a time in memory; a streaming caller's own
/// blocks are bounded by its data).
const QR_BLOCK_ROWS: usize = 1 << 16;

/// Threads for a `threads` option (0 = all cores, else at most the
/// available parallelism): [`lifted_linalg::budget::resolve_threads`].
pub(crate) fn threads(requested: usize) -> usize {
    resolve_threads(requested)
}

/// k = (p + f)(n_u + n_y) Hankel rows, `None` on overflow.
pub(crate) fn hankel_rows(past: usize, future: usize, nu: usize, ny: usize) -> Option<usize> {
    past.checked_add(future)?.checked_mul(nu.checked_add(ny)?)
}

/// Memory of the block-Hankel compression and the projections for horizons
/// (`past`, `future`) and n_u + n_y = `nz` channels: about six k×k
/// matrices, the lagged correlations ((p + f) n_z² values) and, for the QR,
/// one row block of k + 1 columns.
pub(crate) fn hankel_bytes(
    past: usize,
    future: usize,
    nu: usize,
    ny: usize,
    compression: Compression,
    chunk_rows: usize,
) -> Size {
    let Some(k) = hankel_rows(past, future, nu, ny) else {
        return Size::OVERFLOW;
    };
    let nz = nu.saturating_add(ny);
    let span = past.saturating_add(future);
    let mut need = Size::matrices(HANKEL_SQUARE_MATRICES, k, k)
        .plus(Size::f64s(span).times(nz).times(nz))
        .plus(Size::f64s(k).times(4));
    if compression != Compression::Correlation {
        // Qr, and Auto's fallback to it.
        let rows = chunk_rows.clamp(1, QR_BLOCK_ROWS);
        need = need.plus(Size::matrices(1, rows, k.saturating_add(1)));
    }
    need
}

/// [`lifted_linalg::Error::TooLarge`] when the subspace identification
/// with horizons (`past`, `future`) would need more than the memory budget.
/// Called by every subspace entry point before the Hankel layout is used
/// (`identify`, `compress_hankel`, `StreamingIdentifier::new`).
pub(crate) fn check_hankel(
    past: usize,
    future: usize,
    nu: usize,
    ny: usize,
    compression: Compression,
    chunk_rows: usize,
) -> Result<()> {
    let need = hankel_bytes(past, future, nu, ny, compression, chunk_rows);
    Ok(MemoryBudget::default().check(
        "the block-Hankel compression (horizons past + future)",
        need,
    )?)
}

/// Memory of the IV correlations: M (rows_h × rows_z), Z Zᵀ (rows_z²), a
/// column block of each (`block` columns), the QR of Mᵀ and the SVD of R₂₂.
/// `alpha`, `alpha_p` are the future and past horizons, `nz` the
/// instrument's channels.
pub(crate) fn check_iv(
    alpha: usize,
    alpha_p: usize,
    nu: usize,
    ny: usize,
    nz: usize,
    block: usize,
) -> Result<()> {
    let rows_h = nu.checked_add(ny).and_then(|c| c.checked_mul(alpha));
    let rows_z = alpha_p.checked_mul(nz);
    let need = match (rows_h, rows_z) {
        (Some(h), Some(z)) => Size::matrices(3, h, z)
            .plus(Size::matrices(2, z, z))
            .plus(Size::matrices(1, h.saturating_add(z), block))
            .plus(Size::matrices(2, h, h)),
        _ => Size::OVERFLOW,
    };
    Ok(MemoryBudget::default().check(
        "the instrumental-variable correlations (horizons alpha, alpha_p)",
        need,
    )?)
}

/// Largest fraction of the measured output samples that [`crate::refine_pem`]
/// accepts as free parameters (one parameter per two measurements).
pub const PEM_SAMPLES_PER_PARAMETER: usize = 2;

/// The PEM work model: floating-point operations of one Levenberg–Marquardt
/// iteration with `len` parameters (n² of them along the similarity
/// directions), `free` = len − n² directions, `measured` residuals over
/// `samples` time steps of a model with (n, n_u, n_y). Counted: the null
/// space of the n²×len similarity tangent (an SVD, ≈ 4·len·n⁴ + 4·len³/3
/// for the full right basis), the analytic Jacobian (the n × free state
/// sensitivities advanced by the predictor's recursion, ≈ 2·free·n·(n +
/// n_u + n_y) flops per sample, twice with threads), its R-only QR
/// (≈ 2·free²·measured) and a few trial steps' small QRs (free³ each).
pub(crate) fn pem_flops_per_iteration(
    n: usize,
    nu: usize,
    ny: usize,
    len: usize,
    samples: usize,
    measured: usize,
) -> f64 {
    let (n, nu, ny, len) = (n as f64, nu as f64, ny as f64, len as f64);
    let (samples, measured) = (samples as f64, measured as f64);
    let free = (len - n * n).max(0.0);
    let basis = 4.0 * len * n.powi(4) + 4.0 * len.powi(3) / 3.0;
    let jacobian = 2.0 * 2.0 * free * samples * n * (n + nu + ny);
    let qr = 2.0 * free * free * measured + 4.0 * free.powi(3);
    basis + jacobian + qr
}

/// Memory of one PEM iteration: the similarity tangent (len × n²), the
/// null-space basis (len × free) and the SVD's len × len right factor, the
/// Jacobian's R factor and blocks of its rows (counted as measured × free,
/// an upper bound) and the small QRs (free²).
pub(crate) fn check_pem_memory(n: usize, len: usize, measured: usize) -> Result<()> {
    let free = len.saturating_sub(n.saturating_mul(n));
    let need = Size::matrices(1, len, n.saturating_mul(n))
        .plus(Size::matrices(2, len, len))
        .plus(Size::matrices(2, measured, free))
        .plus(Size::matrices(2, free, free));
    Ok(MemoryBudget::default()
        .check("the PEM refinement (Jacobian and local coordinates)", need)?)
}

/// [`Error::TooManyParameters`] when more than one free parameter per
/// [`PEM_SAMPLES_PER_PARAMETER`] measured output samples is asked for.
pub(crate) fn check_pem_parameters(free: usize, measured: usize) -> Result<()> {
    let max = measured / PEM_SAMPLES_PER_PARAMETER;
    if free > max {
        return Err(Error::TooManyParameters {
            what: "the PEM refinement",
            parameters: free,
            measured,
            max,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hankel_rows_are_checked() {
        assert_eq!(hankel_rows(10, 10, 2, 2), Some(80));
        assert_eq!(hankel_rows(usize::MAX, 1, 1, 1), None);
        assert_eq!(hankel_rows(usize::MAX / 2, usize::MAX / 2, 2, 2), None);
    }

    #[test]
    fn hankel_bytes_grow_like_k_squared() {
        let a = hankel_bytes(10, 10, 2, 2, Compression::Correlation, 2048);
        let b = hankel_bytes(20, 20, 2, 2, Compression::Correlation, 2048);
        let (a, b) = (a.get().unwrap() as f64, b.get().unwrap() as f64);
        assert!(b / a > 3.9 && b / a < 4.1, "{a} {b}");
        // horizon 100 000 with four channels: six 800 000² matrices.
        let big = hankel_bytes(100_000, 100_000, 2, 2, Compression::Auto, 2048);
        assert!(big.get().unwrap() > 30_000_000_000_000);
    }

    use crate::{
        Experiment, IvExperiment, IvOptions, OrderSelection, PemOptions, Record,
        StreamingIdentifier, SubspaceOptions, compress_hankel, identify, iv_identify, refine_pem,
    };
    use lifted_lti::StateSpace;
    use nalgebra::DMatrix;

    /// 600 samples of two inputs and two outputs of a second-order system
    /// (deterministic pseudo-random binary inputs, a little output noise).
    fn record() -> (DMatrix<f64>, DMatrix<f64>) {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let n = 600;
        let u = DMatrix::from_fn(n, 2, |_, _| if next() < 0.5 { -1.0 } else { 1.0 });
        let mut y = DMatrix::zeros(n, 2);
        let (mut x1, mut x2) = (0.0, 0.0);
        for k in 0..n {
            y[(k, 0)] = x1 + 0.01 * (next() - 0.5);
            y[(k, 1)] = x2 + 0.01 * (next() - 0.5);
            x1 = 0.8 * x1 + 0.5 * u[(k, 0)];
            x2 = 0.5 * x2 + 0.3 * u[(k, 1)] + 0.2 * u[(k, 0)];
        }
        (u, y)
    }

    fn too_large(e: &Error) -> bool {
        matches!(e, Error::Linalg(lifted_linalg::Error::TooLarge { .. }))
    }

    /// Horizons beyond memory: the streamed entry, which has no record
    /// yet, is refused by the budget (naming the size and the override);
    /// the entries that have the records refuse a horizon that is also
    /// too long for them by their length first (the more direct reason).
    #[test]
    fn horizon_beyond_memory_is_refused_on_every_subspace_entry() {
        let (u, y) = record();
        let exps = [Experiment { u: &u, y: &y }];
        let big = SubspaceOptions {
            order: OrderSelection::Fixed(2),
            past: 100_000,
            future: 100_000,
            ..Default::default()
        };
        let too_long = |e: &Error| matches!(e, Error::HorizonTooLong { n_samples: 600, .. });
        let e = identify(&exps, &big).unwrap_err();
        assert!(too_long(&e), "{e}");
        let e = StreamingIdentifier::new(2, 2, &big).err().unwrap();
        assert!(too_large(&e), "{e}");
        let msg = e.to_string();
        assert!(
            msg.contains("LIFTED_MEMORY_LIMIT") && msg.contains("TB"),
            "{msg}"
        );
        let e = compress_hankel(&exps, 100_000, 100_000, Compression::Auto, 1).unwrap_err();
        assert!(too_long(&e), "{e}");
        // Overflowing horizons: a size error, never a wrapped product.
        let huge = SubspaceOptions {
            past: usize::MAX / 2,
            future: usize::MAX / 2,
            ..big.clone()
        };
        let e = identify(&exps, &huge).unwrap_err();
        assert!(too_long(&e), "{e}");
        let e = StreamingIdentifier::new(2, 2, &huge).err().unwrap();
        assert!(too_large(&e), "{e}");
        // The same record with horizons it supports is identified.
        let fine = SubspaceOptions {
            past: 10,
            future: 10,
            ..big
        };
        assert!(identify(&exps, &fine).is_ok());
        // Thread counts far beyond the machine are capped, not spawned.
        let many = SubspaceOptions {
            threads: 100_000,
            ..fine
        };
        assert!(identify(&exps, &many).is_ok());
    }

    #[test]
    fn iv_horizons_are_checked_before_allocation() {
        let (u, y) = record();
        let exps = [IvExperiment {
            u: &u,
            y: &y,
            instrument: None,
        }];
        for alpha in [1949, 1_000_000, usize::MAX / 4] {
            let opts = IvOptions {
                order: OrderSelection::Fixed(2),
                alpha,
                ..Default::default()
            };
            let e = iv_identify(&exps, &opts).err().unwrap();
            assert!(matches!(e, Error::HorizonTooLong { .. }), "{alpha}: {e}");
        }
        // Known to fit the record: allowed.
        let ok = IvOptions {
            order: OrderSelection::Fixed(2),
            alpha: 8,
            ..Default::default()
        };
        assert!(iv_identify(&exps, &ok).is_ok());
        // Memory beyond any budget on a record long enough for it.
        assert!(check_iv(200_000, 400_000, 2, 2, 2, 512).is_err());
        assert!(check_iv(8, 16, 2, 2, 2, 512).is_ok());
    }

    /// A stable model of order n with 2 inputs and 2 outputs.
    fn model(n: usize) -> StateSpace {
        let a = DMatrix::from_fn(n, n, |i, j| {
            if i == j {
                0.5
            } else if j == i + 1 {
                0.1
            } else {
                0.0
            }
        });
        let b = DMatrix::from_fn(n, 2, |i, j| ((i + j) % 3) as f64 * 0.3 + 0.1);
        let c = DMatrix::from_fn(2, n, |i, j| ((i * 7 + j) % 5) as f64 * 0.2 + 0.1);
        StateSpace::new(a, b, c, DMatrix::zeros(2, 2), Some(1.0)).unwrap()
    }

    #[test]
    fn pem_rejects_more_parameters_than_the_data_support() {
        let (u, y) = record();
        let recs = [Record {
            u: &u,
            y: &y,
            instrument: None,
        }];
        // Order 91: 641 free parameters for 1200 measured samples.
        let e = refine_pem(&model(91), None, &recs, &[], &PemOptions::default()).unwrap_err();
        assert!(
            matches!(
                e,
                Error::TooManyParameters {
                    parameters: 641,
                    measured: 1200,
                    max: 600,
                    ..
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn pem_work_is_bounded() {
        let (u, y) = record();
        let recs = [Record {
            u: &u,
            y: &y,
            instrument: None,
        }];
        // One iteration above the bound: refused before it runs.
        let tiny = PemOptions {
            max_work: 1e3,
            ..Default::default()
        };
        let e = refine_pem(&model(2), None, &recs, &[], &tiny).unwrap_err();
        assert!(matches!(e, Error::TooMuchWork { .. }), "{e}");
        // Room for a few iterations only: capped, and the report says so.
        let m = model(2);
        let per = pem_flops_per_iteration(2, 2, 2, 4 + 4 + 4 + 4 + 4 + 2, 600, 1200);
        // (The joint method books this per-iteration figure.)
        let few = PemOptions {
            max_work: 3.5 * per,
            method: crate::PemMethod::Joint,
            ..Default::default()
        };
        let fit = refine_pem(&m, None, &recs, &[], &few).unwrap();
        assert_eq!(fit.report.iteration_cap, Some(3));
        assert!(fit.report.iterations <= 3);
        // The default bound leaves a small model its iterations.
        let fit = refine_pem(&m, None, &recs, &[], &PemOptions::default()).unwrap();
        assert_eq!(fit.report.iteration_cap, None);
        // A bound that is not positive is an invalid option.
        let bad = PemOptions {
            max_work: f64::NAN,
            ..Default::default()
        };
        assert!(matches!(
            refine_pem(&m, None, &recs, &[], &bad),
            Err(Error::InvalidOption { .. })
        ));
    }

    #[test]
    fn pem_parameters_are_bounded_by_the_samples() {
        assert!(check_pem_parameters(600, 1200).is_ok());
        assert!(matches!(
            check_pem_parameters(601, 1200),
            Err(Error::TooManyParameters { max: 600, .. })
        ));
    }
}

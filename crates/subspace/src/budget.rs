//! Resource checks of the identification entry points, before anything is
//! allocated: the memory a horizon or order asks for against
//! [`lifted_linalg::budget::MemoryBudget`] ([`lifted_linalg::Error::TooLarge`],
//! wrapped in [`Error::Linalg`]), checked size arithmetic, the thread-count
//! rule (the bounds of the prediction-error refinement are `lifted-pem`'s).
//!
//! The estimates count the large buffers of each route, not every small
//! temporary; they err on the large side by a small factor.

use lifted_linalg::budget::{MemoryBudget, Size, resolve_threads};

use crate::error::Result;
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
        Error, Experiment, IvExperiment, IvOptions, OrderSelection, StreamingIdentifier,
        SubspaceOptions, compress_hankel, identify, iv_identify,
    };
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
}

//! The parameter-count, memory and work bounds of [`crate::refine_pem`],
//! checked before anything is formed.

use lifted_linalg::budget::{MemoryBudget, Size};

use crate::error::{Error, Result};

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
    use crate::{PemMethod, PemOptions, refine_pem};
    use lifted_lti::StateSpace;
    use lifted_subspace::Record;
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
            method: PemMethod::Joint,
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

//! The parameter covariance of a state-space model at an estimate (issue
//! 49), as MATLAB gives one to a subspace model: from the Jacobian of the
//! prediction errors at the estimate, one Gauss–Newton step's worth of
//! work (Ljung 1999, §9.3, eq. (9.17): P = λ (JᵀJ)⁻¹ asymptotically for the
//! prediction-error estimate; for another consistent estimate it is the
//! covariance of the prediction-error method started there, the estimate
//! one Gauss–Newton step would reach).
//!
//! The Jacobian is the refinement's own (module [`super::jacobian`]): the
//! residuals along the data-driven local coordinates of the model (A, B,
//! C, free D, K, x₀ per record; the similarity directions taken out, so
//! JᵀJ is regular when the records determine the model), streamed into an
//! R-only QR, JᵀJ never formed. Each output's residuals are divided by
//! their RMS at the estimate (λ = 1 per output: the outputs' innovations
//! taken as uncorrelated with each other), and P_local = (R₁₁ᵀR₁₁)⁻¹
//! M / (M − p) for M measured samples and p local coordinates, from the
//! SVD of R₁₁ (a rank-deficient R₁₁ is refused, naming the rank). With the
//! local basis T (columns: the model's moves along each coordinate) the
//! covariance of θ = [vec A; vec B; vec C; vec D] is T P_local Tᵀ: the
//! initial states and K are nuisance parameters whose uncertainty the
//! marginal covariance of θ includes. Work: one Jacobian pass along the p
//! coordinates, ≈ 2 p N n (n + n_u + n_y) + 2 (p + 1)² M flops, plus the
//! n² × len tangent's null space, ≈ 4 len n⁴ + 4 len³/3 (len = p + n²),
//! all counted by [`covariance_work`] and bounded before anything runs.

use lifted_lti::{SsCovariance, StateSpace};
use nalgebra::DMatrix;

use super::jacobian::jacobian_r;
use super::point::{Point, admissible, residuals};
use super::{PemCost, check_records, masked_d, masked_layout, start_gain};
use crate::error::{Error, Result};
use lifted_subspace::{Feedthrough, Record, estimate_x0};

/// Options of [`state_space_covariance`].
#[derive(Debug, Clone, PartialEq)]
pub struct CovarianceOptions {
    /// The prediction errors whose Jacobian is taken: of the innovations
    /// model with its Kalman gain ([`PemCost::Prediction`], the default),
    /// or the simulation errors ([`PemCost::OutputError`], K = 0).
    pub cost: PemCost,
    /// Which entries of D were estimated (the others fixed: no variance).
    /// Default [`Feedthrough::Free`].
    pub feedthrough: Feedthrough,
    /// Threads of the Jacobian pass (0: the machine's). Default 1.
    pub threads: usize,
    /// Bound on the pass's work (flops of the module docs' count); more
    /// is refused with [`Error::TooMuchWork`] before anything runs.
    /// Default 4e9 (about a second of one core).
    pub max_work: f64,
    /// A model with ρ(A) < 1 + this is taken as it is (an integrator
    /// estimated on the unit circle). Default 1e-6.
    pub marginal_tolerance: f64,
}

impl Default for CovarianceOptions {
    fn default() -> Self {
        CovarianceOptions {
            cost: PemCost::Prediction,
            feedthrough: Feedthrough::Free,
            threads: 1,
            max_work: 4e9,
            marginal_tolerance: 1e-6,
        }
    }
}

/// The covariance of a state-space model's entries and what it rests on.
#[derive(Debug, Clone, PartialEq)]
pub struct StateSpaceUncertainty {
    /// Cov [vec A; vec B; vec C; vec D] ([`SsCovariance`]).
    pub covariance: SsCovariance,
    /// The residuals' mean square per output at the estimate (λ).
    pub noise_variance: Vec<f64>,
    /// Local coordinates (free parameters) of the model with its K and x₀.
    pub parameters: usize,
    /// Measured output samples of the records.
    pub measured: usize,
}

/// The predicted work of [`state_space_covariance`] (flops of the module
/// docs' count) for these sizes: one Jacobian pass along `p` coordinates,
/// and the null space of the n² × (p + n²) similarity tangent (an SVD,
/// ≈ 4 (p + n²) n⁴ + 4 (p + n²)³/3: the larger part at high order — a
/// 600-sample 2 × 2 record at order 48 spent 13 s there while the pass
/// was predicted at 1.3e9 operations).
pub fn covariance_work(
    n: usize,
    nu: usize,
    ny: usize,
    p: usize,
    samples: usize,
    measured: usize,
) -> f64 {
    2.0 * p as f64 * samples as f64 * (n * (n + nu + ny)) as f64
        + 2.0 * ((p + 1) as f64).powi(2) * measured as f64
        + super::work::tangent_basis(n, p + n * n)
}

/// The covariance of `model`'s entries on the estimation `records` (module
/// docs); `kalman_gain` is the innovations model's K for the prediction
/// errors (zero when `None`).
///
/// Errors: [`Error::InvalidOption`] (a continuous model, bad options),
/// [`Error::NoData`], [`Error::DimensionMismatch`], [`Error::NonFinite`],
/// [`Error::TooFewSamples`] (no more measured samples than coordinates),
/// [`Error::TooMuchWork`], [`Error::Unstable`] (A, or the predictor
/// A − KC, unstable: no prediction errors), [`Error::RankDeficient`] when
/// the records do not determine the model (the Jacobian's numerical rank).
pub fn state_space_covariance(
    model: &StateSpace,
    kalman_gain: Option<&DMatrix<f64>>,
    records: &[Record<'_>],
    opts: &CovarianceOptions,
) -> Result<StateSpaceUncertainty> {
    if model.ts().is_none() {
        return Err(Error::InvalidOption {
            what: "model",
            reason: "the covariance needs a discrete-time model".into(),
        });
    }
    if !(opts.max_work > 0.0
        && opts.marginal_tolerance >= 0.0
        && opts.marginal_tolerance.is_finite())
    {
        return Err(Error::InvalidOption {
            what: "CovarianceOptions",
            reason: "max_work > 0 and a finite non-negative marginal tolerance are required".into(),
        });
    }
    let measured = check_records(model, records)?;
    let (n, nu, ny) = (model.order(), model.n_inputs(), model.n_outputs());
    let gain = opts.cost == PemCost::Prediction;
    let (mask, lay) = masked_layout(model, &opts.feedthrough, records.len(), gain)?;
    let p = lay.len() - n * n;
    if measured <= p {
        return Err(Error::TooFewSamples {
            what: "the state-space covariance",
            measured,
            needed: p + 1,
        });
    }
    crate::budget::check_pem_memory(n, lay.len(), measured)?;
    let samples: usize = records.iter().map(|r| r.u.nrows()).sum();
    let work = covariance_work(n, nu, ny, p, samples, measured);
    if work > opts.max_work {
        return Err(Error::TooMuchWork {
            what: "the state-space covariance",
            flops: work,
            limit: opts.max_work,
        });
    }
    let k = start_gain(kalman_gain, gain, n, ny)?;
    let d = masked_d(model.d(), &mask);
    let mut point = Point {
        a: model.a().clone(),
        b: model.b().clone(),
        c: model.c().clone(),
        d,
        k,
        x0: Vec::new(),
    };
    if !admissible(&point, gain, opts.marginal_tolerance) {
        let pred = &point.a - &point.k * &point.c;
        let rho = lifted_linalg::spectral_radius(&point.a)?.max(if gain {
            lifted_linalg::spectral_radius(&pred)?
        } else {
            0.0
        });
        return Err(Error::Unstable {
            spectral_radius: rho,
        });
    }
    point.x0 = estimate_x0(&point.a, &point.b, &point.c, &point.d, records)?;
    // λ per output: the mean square of its residuals at the estimate.
    let mut noise_variance = Vec::with_capacity(ny);
    for o in 0..ny {
        let mut w = vec![0.0; ny];
        w[o] = 1.0;
        let e = residuals(&point, records, &w, gain, measured).ok_or(Error::InvalidOption {
            what: "model",
            reason: "its prediction errors are not finite on the records".into(),
        })?;
        let count = records
            .iter()
            .map(|r| r.y.column(o).iter().filter(|v| !v.is_nan()).count())
            .sum::<usize>()
            .max(1);
        noise_variance.push(e.norm_squared() / count as f64);
    }
    let weights: Vec<f64> = noise_variance
        .iter()
        .map(|v| if *v > 0.0 { 1.0 / v.sqrt() } else { 1.0 })
        .collect();
    let tangent = point.similarity_tangent(&lay);
    let basis =
        lifted_linalg::null_space(&tangent.transpose(), lifted_linalg::RankTolerance::Default)?;
    let np = basis.ncols();
    let threads = lifted_linalg::budget::resolve_threads(opts.threads);
    let raug = jacobian_r(&point, &basis, &lay, records, &weights, gain, threads, 1)?;
    let r11 = raug.view((0, 0), (np, np)).into_owned();
    // P_local = V S⁻² Vᵀ · M / (M − p): its factor S⁻¹ Vᵀ times Tᵀ.
    let svd = lifted_linalg::svd(&r11)?;
    let smax = svd.s.iter().copied().fold(0.0, f64::max);
    let rank = svd.s.iter().filter(|s| **s > smax * 1e-10).count();
    if rank < np {
        return Err(Error::RankDeficient {
            what: "the prediction-error Jacobian at the estimate (its covariance)",
            rank,
            needed: np,
        });
    }
    // T: the model's move (A, B, C, D) along each local coordinate.
    let l = lifted_lti::ss_uncertainty::parameter_count(n, nu, ny);
    let mut t = DMatrix::zeros(l, np);
    for i in 0..np {
        let dir = Point::unpack(&basis.column(i).into_owned(), &lay);
        let col: Vec<f64> = dir
            .a
            .iter()
            .chain(dir.b.iter())
            .chain(dir.c.iter())
            .chain(dir.d.iter())
            .copied()
            .collect();
        t.column_mut(i).copy_from_slice(&col);
    }
    let dof = measured as f64 / (measured - np) as f64;
    let mut factor = svd.v.transpose() * t.transpose();
    for (i, mut row) in factor.row_iter_mut().enumerate() {
        row *= dof.sqrt() / svd.s[i];
    }
    let cov = factor.transpose() * &factor;
    let cov = (&cov + cov.transpose()) * 0.5;
    Ok(StateSpaceUncertainty {
        covariance: SsCovariance::new(n, nu, ny, cov)?,
        noise_variance,
        parameters: np,
        measured,
    })
}

//! The unified subspace engine: N4SID, MOESP and CVA as one weighted SVD
//! (thesis §2.5, Van Overschee & De Moor's unifying theorem).

use lifted_linalg::{RankTolerance, SortOrder, dare, lstsq, pinv, range_basis, svd, sym_eig};
use lifted_lti::StateSpace;
use std::time::Instant;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, check_data, check_exciting};
use crate::hankel::{
    Compression, CompressionReport, HankelFactor, HankelLayout, HankelStream, compress,
};
use crate::order::{
    OrderCriterion, OrderReport, gap_order, gap_values, information_criterion_values,
    simulation_error, svc_values,
};
use crate::regress::{Feedthrough, InitialState, Record, estimate_bd, estimate_x0};

/// The weighting of the unifying theorem (thesis §2.5 table, erratum L-4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Method {
    /// W₁ = I, W₂ = I.
    #[default]
    N4sid,
    /// W₁ = I, W₂ = Π_{U_f⊥}.
    Moesp,
    /// W₁ = [(Y_f/U_f⊥)(Y_f/U_f⊥)ᵀ]^{−1/2}, W₂ = Π_{U_f⊥}; the singular
    /// values are the canonical correlations between future outputs and past
    /// data (both with the future inputs removed).
    Cva,
}

impl Method {
    /// Short name ("N4SID", "MOESP", "CVA").
    pub fn name(self) -> &'static str {
        match self {
            Method::N4sid => "N4SID",
            Method::Moesp => "MOESP",
            Method::Cva => "CVA",
        }
    }
}

/// How (A, C) are obtained from the subspace.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum SystemEstimate {
    /// A, C from the extended observability matrix by shift invariance over
    /// all block rows (MOESP, thesis eqs. 2.19–2.20, erratum L-3).
    ShiftInvariance,
    /// A, C from the least-squares fit [X_{i+1}; Y_{i|i}] = [A B; C D][X_i; U_{i|i}]
    /// of the state sequences X_i = Γ⁺Φ_i, X_{i+1} = Γ₋⁺Φ_{i+1} (N4SID and
    /// CVA, thesis §2.2–2.3), with the feedthrough mask per output row. With
    /// coloured (Box–Jenkins) noise this keeps the deterministic dynamics
    /// when the truncated subspace also carries noise modes.
    #[default]
    StateSequence,
}

/// How the model order is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum OrderSelection {
    /// Use this order.
    Fixed(usize),
    /// Automatic choice among 1 ≤ n ≤ `max` by the options'
    /// `order_criterion` ([`OrderCriterion`]): by default the largest gap
    /// ln(σ_n/σ_{n+1}) (then `max` is capped at the largest admissible
    /// order); Bauer's SVC or SIPPY's AIC/AICc/BIC (then a `max` above the
    /// largest admissible order is an [`Error::OrderTooLarge`]).
    Gap {
        /// Largest order considered.
        max: usize,
    },
}

impl Default for OrderSelection {
    fn default() -> Self {
        OrderSelection::Gap { max: 10 }
    }
}

/// Options of [`identify`]. `Default` gives the values documented per field.
#[derive(Debug, Clone, PartialEq)]
pub struct SubspaceOptions {
    /// Weighting (thesis §2.5). Default [`Method::N4sid`].
    pub method: Method,
    /// Order choice. Default `Gap { max: 10 }`.
    pub order: OrderSelection,
    /// Rule of the automatic order choice, and the criterion whose values
    /// per order are reported in [`Diagnostics::order_selection`]. Default
    /// [`OrderCriterion::Gap`] (singular-value gap; Bauer 2001 SVC and
    /// SIPPY's AIC/AICc/BIC in [`OrderCriterion`]).
    pub order_criterion: OrderCriterion,
    /// Past horizon p (block rows of U_p, Y_p; "i" of thesis §2.3). Default 10.
    pub past: usize,
    /// Future horizon f (block rows of U_f, Y_f). Default 10.
    pub future: usize,
    /// Which entries of D are estimated. Default [`Feedthrough::Free`].
    pub feedthrough: Feedthrough,
    /// Route from the subspace to (A, C). Default [`SystemEstimate::StateSequence`].
    pub system: SystemEstimate,
    /// Initial state per record in the (B, D) regression. Default
    /// [`InitialState::Estimate`].
    pub initial_state: InitialState,
    /// Estimate the noise covariances (Q, R, S) from the state-sequence
    /// residuals (thesis §2.3) and the Kalman gain from the DARE. Default true.
    pub noise_model: bool,
    /// If the shift-invariance estimate of A is unstable, re-estimate it with
    /// the zero-padded shift Γ A = (Γ↑; 0) (guaranteed stable). Default false.
    pub enforce_stability: bool,
    /// Sample period of the returned model (seconds). Default 1.0.
    pub ts: f64,
    /// Time instants per block of the streamed Hankel compression. Default 2048.
    pub chunk_rows: usize,
    /// Compression of the block-Hankel data (module docs of `hankel`):
    /// correlations + Cholesky with automatic QR fallback, or the QR
    /// reference. Default [`Compression::Auto`].
    pub compression: Compression,
    /// Threads for the correlation kernel (contiguous ranges of samples,
    /// std scoped threads); 1 = single-threaded, 0 = all available cores.
    /// Default 1.
    pub threads: usize,
}

impl Default for SubspaceOptions {
    fn default() -> Self {
        SubspaceOptions {
            method: Method::N4sid,
            order: OrderSelection::default(),
            order_criterion: OrderCriterion::Gap,
            past: 10,
            future: 10,
            feedthrough: Feedthrough::Free,
            system: SystemEstimate::StateSequence,
            initial_state: InitialState::Estimate,
            noise_model: true,
            enforce_stability: false,
            ts: 1.0,
            chunk_rows: 2048,
            compression: Compression::Auto,
            threads: 1,
        }
    }
}

/// Noise covariances of x(k+1) = Ax + Bu + w, y = Cx + Du + v.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseCovariances {
    /// E[w wᵀ] (n×n).
    pub q: DMatrix<f64>,
    /// E[v vᵀ] (n_y×n_y).
    pub r: DMatrix<f64>,
    /// E[w vᵀ] (n×n_y).
    pub s: DMatrix<f64>,
}

/// Order-selection data and other diagnostics of an identification.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostics {
    /// Method used.
    pub method: Method,
    /// All singular values of the weighted projection W₁ Φ W₂ (descending;
    /// N4SID's and MOESP's in the units of y, CVA's are canonical
    /// correlations).
    pub singular_values: Vec<f64>,
    /// Order used.
    pub order: usize,
    /// Order suggested by the gap rule (whatever was used).
    pub suggested_order: usize,
    /// The order criterion of the options with its value for every
    /// candidate order and the order it selects (for a fixed order: the
    /// orders up to min((f − 1) n_y, 10)).
    pub order_selection: OrderReport,
    /// Past and future horizons.
    pub horizons: (usize, usize),
    /// Hankel columns J (all records).
    pub columns: usize,
    /// True if A was re-estimated to make it stable.
    pub stabilized: bool,
    /// Why no Kalman gain was returned, if requested but not available.
    pub noise_model_error: Option<String>,
    /// Approximate flop count of the Hankel compression actually run
    /// (QR 2Jk²(1 + k/b), correlations 2 N n_z² s + k³/3).
    pub compression_flops: f64,
    /// Which compression was used, the reciprocal condition of the
    /// correlation matrix and the reason of a fallback to the QR (as
    /// SLICOT's IWARN).
    pub compression: CompressionReport,
    /// Wall time per phase.
    pub profile: Profile,
}

/// Wall time of the phases of an identification, seconds (for
/// `lifted identify --profile`). Reading the data is the caller's.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Profile {
    /// Hankel compression (for [`StreamingIdentifier`]: the final
    /// factorisation only; the accumulation runs inside the pushes, whose
    /// time the caller measures).
    pub compress_s: f64,
    /// Projections, weights and the SVD of the weighted projection.
    pub svd_s: f64,
    /// Order choice, (A, B, C, D), initial states and the noise model.
    pub estimate_s: f64,
}

/// An identified model with its noise model and diagnostics.
#[derive(Debug, Clone, PartialEq)]
pub struct SubspaceModel {
    /// The deterministic model (A, B, C, D) with sample period `ts`.
    pub model: StateSpace,
    /// Kalman (predictor) gain K, x(k+1) = Ax + Bu + K e (n×n_y).
    pub kalman_gain: Option<DMatrix<f64>>,
    /// Innovation-form noise covariances (Q, R, S).
    pub noise: Option<NoiseCovariances>,
    /// Estimated initial state per record.
    pub x0: Vec<DVector<f64>>,
    /// Singular values, orders and other diagnostics.
    pub diagnostics: Diagnostics,
}

/// Removes the row space of `u` from the rows of `m`: m Π_{u⊥}.
pub(crate) fn perp(m: &DMatrix<f64>, u: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    if u.nrows() == 0 {
        return Ok(m.clone());
    }
    let q = range_basis(&u.transpose(), RankTolerance::Default)?;
    Ok(m - (m * &q) * q.transpose())
}

/// The map M of the oblique projection F /_U P = M P,
/// M = (F Π⊥ Pᵀ)(P Π⊥ Pᵀ)⁺.
fn oblique_map(f: &DMatrix<f64>, u: &DMatrix<f64>, p: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let fp = perp(f, u)?;
    let pp = perp(p, u)?;
    let g = &pp * pp.transpose();
    Ok(fp * pp.transpose() * pinv(&g, RankTolerance::Relative(1e-12))?)
}

/// Oblique projection F /_U P = (F Π⊥ Pᵀ)(P Π⊥ Pᵀ)⁺ P.
fn oblique(f: &DMatrix<f64>, u: &DMatrix<f64>, p: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    Ok(oblique_map(f, u, p)? * p)
}

fn rows(m: &DMatrix<f64>, r: std::ops::Range<usize>) -> DMatrix<f64> {
    m.rows(r.start, r.len()).into_owned()
}

fn vstack(parts: &[&DMatrix<f64>]) -> DMatrix<f64> {
    let nr: usize = parts.iter().map(|p| p.nrows()).sum();
    let nc = parts.first().map_or(0, |p| p.ncols());
    let mut out = DMatrix::zeros(nr, nc);
    let mut r = 0;
    for p in parts {
        out.rows_mut(r, p.nrows()).copy_from(p);
        r += p.nrows();
    }
    out
}

/// Spectral radius of a square matrix.
pub(crate) fn spectral_radius(a: &DMatrix<f64>) -> Result<f64> {
    Ok(lifted_linalg::eigenvalues(a)?
        .iter()
        .map(|z| z.norm())
        .fold(0.0, f64::max))
}

/// (A, C) from an extended observability matrix with `ny` rows per block by
/// shift invariance over all block rows (erratum L-3: A = Γ↑⁺ Γ↓), and the
/// stabilised variant A = Γ⁺ [Γ↓; 0] when requested and needed.
pub(crate) fn ac_from_gamma(
    gamma: &DMatrix<f64>,
    ny: usize,
    enforce_stability: bool,
) -> Result<(DMatrix<f64>, DMatrix<f64>, bool)> {
    let (rows_g, n) = gamma.shape();
    let up = gamma.rows(0, rows_g - ny).into_owned();
    let dn = gamma.rows(ny, rows_g - ny).into_owned();
    let mut a = lstsq(&up, &dn)?;
    let c = gamma.rows(0, ny).into_owned();
    let mut stabilized = false;
    if enforce_stability && spectral_radius(&a)? >= 1.0 {
        let mut padded = DMatrix::zeros(rows_g, n);
        padded.rows_mut(0, rows_g - ny).copy_from(&dn);
        a = lstsq(gamma, &padded)?;
        stabilized = true;
    }
    Ok((a, c, stabilized))
}

/// One data record (experiment) for [`identify`]: u (N×n_u), y (N×n_y).
#[derive(Debug, Clone, Copy)]
pub struct Experiment<'a> {
    /// Inputs, one row per sample.
    pub u: &'a DMatrix<f64>,
    /// Outputs, one row per sample.
    pub y: &'a DMatrix<f64>,
}

/// Validates the records; returns (n_u, n_y, total samples).
pub(crate) fn validate(experiments: &[Experiment<'_>]) -> Result<(usize, usize, usize)> {
    let first = experiments.first().ok_or(Error::NoData)?;
    let (nu, ny) = (first.u.ncols(), first.y.ncols());
    if nu == 0 || ny == 0 {
        return Err(Error::DimensionMismatch {
            what: "u, y",
            expected: "at least one input and one output".into(),
            got: format!("{nu} inputs, {ny} outputs"),
        });
    }
    let mut total = 0;
    for e in experiments {
        check_record_shape("experiment (u, y)", "N", e.u, e.y, nu, ny)?;
        check_data("u", e.u)?;
        check_data("y", e.y)?;
        total += e.u.nrows();
    }
    Ok((nu, ny, total))
}

/// [`Error::DimensionMismatch`] for `what` unless `u` is N×`nu` and `y` N×`ny`
/// for some N (named `rows` in the message).
pub(crate) fn check_record_shape(
    what: &'static str,
    rows: &str,
    u: &DMatrix<f64>,
    y: &DMatrix<f64>,
    nu: usize,
    ny: usize,
) -> Result<()> {
    if u.ncols() != nu || y.ncols() != ny || u.nrows() != y.nrows() {
        return Err(Error::DimensionMismatch {
            what,
            expected: format!("{rows}×{nu} and {rows}×{ny}"),
            got: format!(
                "{}x{} and {}x{}",
                u.nrows(),
                u.ncols(),
                y.nrows(),
                y.ncols()
            ),
        });
    }
    Ok(())
}

/// An instrument signal `f` of the shape of its record's input `u`, finite.
pub(crate) fn check_instrument(f: &DMatrix<f64>, u: &DMatrix<f64>) -> Result<()> {
    if f.shape() != u.shape() {
        return Err(Error::DimensionMismatch {
            what: "instrument",
            expected: format!("{}x{}", u.nrows(), u.ncols()),
            got: format!("{}x{}", f.nrows(), f.ncols()),
        });
    }
    check_data("instrument", f)
}

/// Γ = U₁ S₁^{1/2}: the first `n` columns of `u` scaled by the square roots
/// of the singular values `s`.
pub(crate) fn scaled_basis(u: &DMatrix<f64>, s: &[f64], n: usize) -> DMatrix<f64> {
    let mut gamma = u.columns(0, n).into_owned();
    for (j, sv) in s.iter().take(n).enumerate() {
        gamma.column_mut(j).scale_mut(sv.sqrt());
    }
    gamma
}

/// Numerical rank of a lower-triangular Gram factor block.
pub(crate) fn numerical_rank(m: &DMatrix<f64>, rel: f64) -> Result<usize> {
    let s = lifted_linalg::singular_values(m)?;
    let smax = s.iter().cloned().fold(0.0, f64::max);
    Ok(s.iter().filter(|&&v| smax > 0.0 && v > rel * smax).count())
}

/// Checks horizons, sample period and a fixed order; returns the Hankel layout.
fn check_options(nu: usize, ny: usize, opts: &SubspaceOptions) -> Result<HankelLayout> {
    let (p, f) = (opts.past, opts.future);
    if p == 0 {
        return Err(Error::InvalidHorizon {
            what: "past",
            value: p,
            reason: "must be at least 1".into(),
        });
    }
    if f < 2 {
        return Err(Error::InvalidHorizon {
            what: "future",
            value: f,
            reason: "must be at least 2 (shift invariance needs two block rows)".into(),
        });
    }
    if !(opts.ts.is_finite() && opts.ts > 0.0) {
        return Err(Error::InvalidOption {
            what: "ts",
            reason: format!("sample period must be positive and finite, got {}", opts.ts),
        });
    }
    let layout = HankelLayout {
        past: p,
        future: f,
        nu,
        ny,
    };
    let max_order = (f - 1) * ny;
    check_order(opts.order, opts.order_criterion, max_order)?;
    Ok(layout)
}

/// A fixed order, or the `max` of a criterion other than the gap rule, must
/// lie in 1..=`max_order` ([`Error::OrderTooLarge`]); the gap rule caps its
/// `max` instead (unchanged behaviour).
pub(crate) fn check_order(
    order: OrderSelection,
    criterion: OrderCriterion,
    max_order: usize,
) -> Result<()> {
    let n = match order {
        OrderSelection::Fixed(n) => n,
        OrderSelection::Gap { max } if criterion != OrderCriterion::Gap => max,
        OrderSelection::Gap { .. } => return Ok(()),
    };
    if n == 0 || n > max_order {
        return Err(Error::OrderTooLarge {
            order: n,
            max: max_order,
        });
    }
    Ok(())
}

/// The candidate orders 1..=cap of the order report: `max` of
/// [`OrderSelection::Gap`] (capped at `max_order` for the gap rule,
/// checked by [`check_order`] otherwise), min(`max_order`, 10) for a fixed
/// order.
pub(crate) fn candidate_orders(order: OrderSelection, max_order: usize) -> usize {
    match order {
        OrderSelection::Gap { max } => max.min(max_order),
        OrderSelection::Fixed(_) => max_order.min(10),
    }
}

/// Scalars (powers of 4) by which the inputs, outputs and instruments are
/// divided before the identification. The subspace methods are equivariant
/// under such scalings (the projections see row spaces; the weighted
/// singular values scale with the outputs), but their relative rank
/// tolerances and the squared data products are not: without it, outputs
/// 1e-7 times smaller than the inputs changed the N4SID poles and data of
/// magnitude 1e150 overflowed the Gram matrices. Powers of 4 keep the
/// scaling, its square root and its undoing exact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Scale {
    /// Input scale s_u.
    pub u: f64,
    /// Output scale s_y.
    pub y: f64,
}

impl Scale {
    /// No scaling.
    pub(crate) const ONE: Scale = Scale { u: 1.0, y: 1.0 };

    /// Model matrices of the scaled data (B̃, C̃, D̃) in original units:
    /// B = B̃/s_u, C = s_y C̃, D = s_y D̃/s_u (A and the state unchanged).
    pub(crate) fn unscale(
        &self,
        b: DMatrix<f64>,
        c: DMatrix<f64>,
        d: DMatrix<f64>,
    ) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        (b / self.u, c * self.y, d * (self.y / self.u))
    }

    /// The inverse of [`Scale::unscale`].
    pub(crate) fn rescale(
        &self,
        b: &DMatrix<f64>,
        c: &DMatrix<f64>,
        d: &DMatrix<f64>,
    ) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        (b * self.u, c / self.y, d * (self.u / self.y))
    }
}

/// The power of 4 nearest (in ratio) to the RMS of the finite entries of
/// `mats`, computed without overflow (entries divided by the largest one
/// first); 1 when they are all zero. Two passes, O(entries).
pub(crate) fn pow4_scale(mats: &[&DMatrix<f64>]) -> f64 {
    let finite = || mats.iter().flat_map(|m| m.iter()).filter(|v| v.is_finite());
    let big = finite().fold(0.0f64, |a, v| a.max(v.abs()));
    if big <= 0.0 {
        return 1.0;
    }
    let (mut sum, mut count) = (0.0, 0usize);
    for v in finite() {
        let r = v / big;
        sum += r * r;
        count += 1;
    }
    let rms = big * (sum / count as f64).sqrt();
    let k = (rms.log2() / 2.0).round().clamp(-500.0, 500.0) as i32;
    2f64.powi(2 * k)
}

/// Compresses the block-Hankel data [U_f; U_p; Y_p; Y_f] of the records
/// (past/future horizons `past`, `future`) into the k×k factor L with
/// H Hᵀ/J = L Lᵀ, by `compression` (see [`Compression`]) with `threads`
/// threads for the correlation kernel (0 = all cores). This is step 1 of
/// [`identify`], exposed for benchmarks and for reuse of one compression.
///
/// Errors: as [`identify`] for the data and horizons;
/// [`Error::IllConditionedCorrelation`] for [`Compression::Correlation`]
/// when the check fails.
pub fn compress_hankel(
    experiments: &[Experiment<'_>],
    past: usize,
    future: usize,
    compression: Compression,
    threads: usize,
) -> Result<HankelFactor> {
    let (nu, ny, total) = validate(experiments)?;
    let opts = SubspaceOptions {
        past,
        future,
        order: OrderSelection::Gap { max: 1 },
        ..Default::default()
    };
    let layout = check_options(nu, ny, &opts)?;
    let columns: usize = experiments
        .iter()
        .map(|e| layout.columns(e.u.nrows()))
        .sum();
    if columns < layout.nrows() {
        return Err(Error::HorizonTooLong {
            past,
            future,
            n_samples: total,
            min_samples: layout.nrows() + (past + future - 1) * experiments.len(),
        });
    }
    let recs: Vec<(&DMatrix<f64>, &DMatrix<f64>)> =
        experiments.iter().map(|e| (e.u, e.y)).collect();
    compress(
        &recs,
        &layout,
        compression,
        opts.chunk_rows,
        thread_count(threads),
        Scale::ONE,
    )
}

/// Identification from data fed in blocks (e.g. while a CSV file is read):
/// memory O(((n_u + n_y)(p + f))²) whatever the number of samples.
///
/// Each [`push`](Self::push) takes consecutive samples of the current
/// record; [`end_record`](Self::end_record) starts a new record (experiment);
/// [`finish`](Self::finish) identifies the model from the compressed data
/// exactly as [`identify`] would (same factor up to rounding, same steps
/// 2–5) except that the records are gone: (A, B, C, D) come from the state
/// sequences ([`SystemEstimate::StateSequence`], required), no initial
/// state is estimated (`x0` is empty, or zeros per record for
/// [`InitialState::Zero`]), the AIC-type order criteria (which simulate
/// models on the records) are not available, the data scaling (a power
/// of 4 per signal, see [`identify`]) is fixed by the first non-empty block,
/// and [`Compression::Auto`] cannot fall back to
/// the QR after the pass: it returns [`Error::IllConditionedCorrelation`]
/// and the data must be fed again with [`Compression::Qr`].
///
/// # Example
///
/// ```
/// use lifted_lti::StateSpace;
/// use lifted_subspace::{OrderSelection, StreamingIdentifier, SubspaceOptions};
/// use nalgebra::DMatrix;
///
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let g = StateSpace::new(
///     DMatrix::from_element(1, 1, 0.9),
///     DMatrix::from_element(1, 1, 0.5),
///     DMatrix::from_element(1, 1, 1.0),
///     DMatrix::zeros(1, 1),
///     Some(1.0),
/// )?;
/// let u = DMatrix::from_fn(3000, 1, |k, _| if (k * 7919 + k / 3) % 5 < 2 { 1.0 } else { -1.0 });
/// // A little output noise keeps the correlation matrix well conditioned.
/// let mut y = g.lsim(&u, None, None)?.y;
/// for (k, v) in y.iter_mut().enumerate() {
///     *v += 1e-2 * (((k * 104_729) % 1000) as f64 / 500.0 - 1.0);
/// }
/// let opts = SubspaceOptions { order: OrderSelection::Fixed(1), past: 5, future: 5, ..Default::default() };
/// let mut id = StreamingIdentifier::new(1, 1, &opts)?;
/// for s in (0..3000).step_by(700) {
///     let len = 700.min(3000 - s);
///     id.push(&u.rows(s, len).into_owned(), &y.rows(s, len).into_owned())?;
/// }
/// let fit = id.finish()?;
/// assert!((fit.model.poles()?[0].re - 0.9).abs() < 1e-2);
/// # Ok(())
/// # }
/// ```
pub struct StreamingIdentifier {
    layout: HankelLayout,
    opts: SubspaceOptions,
    stream: HankelStream,
    samples: usize,
    records: usize,
    record_open: bool,
    /// Data scaling, fixed by the first non-empty block.
    scale: Option<Scale>,
}

impl StreamingIdentifier {
    /// A streaming identification of a system with `n_inputs` inputs and
    /// `n_outputs` outputs.
    ///
    /// Errors: [`Error::DimensionMismatch`] (no input or output),
    /// [`Error::InvalidHorizon`], [`Error::InvalidOption`] (sample period,
    /// or a [`SystemEstimate`] / `enforce_stability` / AIC-type
    /// [`OrderCriterion`] that needs the records), [`Error::OrderTooLarge`].
    pub fn new(n_inputs: usize, n_outputs: usize, opts: &SubspaceOptions) -> Result<Self> {
        if n_inputs == 0 || n_outputs == 0 {
            return Err(Error::DimensionMismatch {
                what: "u, y",
                expected: "at least one input and one output".into(),
                got: format!("{n_inputs} inputs, {n_outputs} outputs"),
            });
        }
        let layout = check_options(n_inputs, n_outputs, opts)?;
        if opts.system != SystemEstimate::StateSequence || opts.enforce_stability {
            need_records(None)?;
        }
        if opts.order_criterion.needs_models() {
            return Err(Error::InvalidOption {
                what: "order_criterion",
                reason: format!(
                    "{} simulates a model of every order on the records, which streaming does not keep; use OrderCriterion::Svc or Gap",
                    opts.order_criterion.name()
                ),
            });
        }
        let stream = HankelStream::new(
            layout,
            opts.compression,
            opts.chunk_rows,
            thread_count(opts.threads),
        );
        Ok(StreamingIdentifier {
            layout,
            opts: opts.clone(),
            stream,
            samples: 0,
            records: 0,
            record_open: false,
            scale: None,
        })
    }

    /// Appends consecutive samples of the current record: `u` (b×n_u) and
    /// `y` (b×n_y), one row per sample; blocks may have any length.
    ///
    /// Errors: [`Error::DimensionMismatch`], [`Error::NonFinite`].
    pub fn push(&mut self, u: &DMatrix<f64>, y: &DMatrix<f64>) -> Result<()> {
        let (nu, ny) = (self.layout.nu, self.layout.ny);
        check_record_shape("block (u, y)", "b", u, y, nu, ny)?;
        check_data("u", u)?;
        check_data("y", y)?;
        if u.nrows() > 0 && self.scale.is_none() {
            let scale = Scale {
                u: pow4_scale(&[u]),
                y: pow4_scale(&[y]),
            };
            self.stream.set_scale(scale);
            self.scale = Some(scale);
        }
        if u.nrows() > 0 && !self.record_open {
            self.records += 1;
            self.record_open = true;
        }
        self.samples += u.nrows();
        self.stream.push(u, y)
    }

    /// Ends the current record; the next [`push`](Self::push) starts a new
    /// one (its first s − 1 samples only start Hankel columns).
    pub fn end_record(&mut self) {
        self.stream.end_record();
        self.record_open = false;
    }

    /// Hankel columns collected so far.
    pub fn columns(&self) -> usize {
        self.stream.columns()
    }

    /// Identifies the model from the data pushed so far.
    ///
    /// Errors: [`Error::HorizonTooLong`] (fewer Hankel columns than rows),
    /// [`Error::IllConditionedCorrelation`] (correlation route rejected),
    /// and those of [`identify`] after the compression.
    pub fn finish(self) -> Result<SubspaceModel> {
        let k = self.layout.nrows();
        let columns = self.stream.columns();
        if columns < k {
            let (p, f) = (self.layout.past, self.layout.future);
            return Err(Error::HorizonTooLong {
                past: p,
                future: f,
                n_samples: self.samples,
                min_samples: k + (p + f - 1) * self.records.max(1),
            });
        }
        let t0 = Instant::now();
        let factor = self.stream.finish()?;
        let compress_s = t0.elapsed().as_secs_f64();
        let scale = self.scale.unwrap_or(Scale::ONE);
        let mut fit = from_factor(factor, &self.layout, &self.opts, None, scale, compress_s)?;
        if self.opts.initial_state == InitialState::Zero {
            fit.x0 = vec![DVector::zeros(fit.model.order()); self.records.max(1)];
        }
        Ok(fit)
    }
}

/// Identifies a state-space model from one or more records with N4SID,
/// MOESP or CVA (thesis ch. 2, unified by the weights of §2.5).
///
/// Steps: (1) streamed compression of the block-Hankel data
/// [U_f; U_p; Y_p; Y_f] to L with H Hᵀ/J = L Lᵀ ([`Compression`]: lagged
/// correlations + Cholesky, ≈ 2N(n_u+n_y)²(p+f) flops, falling back to the
/// R-only QR, ≈ 2Jk²(1 + k/b) flops; O(k²) memory, k = (p+f)(n_u+n_y)); (2) oblique projection Φ = Y_f /_{U_f} W_p
/// and SVD of W₁ Φ W₂ on the k×k factor (O(k³)); (3) Γ = W₁⁻¹U₁S₁^{1/2},
/// C = first block row, A = Γ↑⁺Γ↓ (all block rows, erratum L-3);
/// (4) (B, D, x₀) by streamed output-error least squares with the
/// feedthrough mask ([`estimate_bd`], O(N n_y (n_u n³ + p²)));
/// (5) optionally Q, R, S from the state sequences X_i = Γ⁺Φ and
/// X_{i+1} = Γ₋⁺Φ₊ and the Kalman gain from the filter DARE.
///
/// Units: u and y are divided by a power of 4 near their RMS before step
/// (1) (exact, O(N) pass) and the model, noise model and singular values
/// are returned in the original units, so neither the magnitude of the data
/// (1e-200 … 1e200) nor the ratio of output to input units changes the
/// result.
///
/// Order: `order_criterion` ([`OrderCriterion`]) chooses the order for
/// [`OrderSelection::Gap`] and is reported for every candidate order in
/// [`Diagnostics::order_selection`]: the gap rule and Bauer's SVC cost
/// O(max) (SVC one more k×k SVD for N4SID/MOESP); AIC/AICc/BIC fit and
/// simulate one model per candidate order (max × step 4 plus
/// O(N n (n + n_u + n_y)) each).
///
/// Errors: [`Error::NoData`], [`Error::DimensionMismatch`],
/// [`Error::NonFinite`], [`Error::InvalidHorizon`],
/// [`Error::HorizonTooLong`], [`Error::OrderTooLarge`] (also for a
/// criterion's `max` beyond (f − 1)n_y, or beyond what the number of
/// samples supports for AIC-type criteria), [`Error::NotExciting`],
/// [`Error::UnstableEstimate`] when the shift-invariance A is so unstable
/// that the (B, D, x₀) output-error regression over the record cannot be
/// computed (raised before it runs; the default state-sequence route
/// returns an unstable model instead and estimates x₀ on the window where
/// C Aᵗ has grown by less than [`crate::MAX_REGRESSOR_GROWTH`]).
/// [`Error::Unstable`] is never returned here (use `enforce_stability`).
pub fn identify(experiments: &[Experiment<'_>], opts: &SubspaceOptions) -> Result<SubspaceModel> {
    let (nu, ny, total) = validate(experiments)?;
    let layout = check_options(nu, ny, opts)?;
    let (p, f, k) = (layout.past, layout.future, layout.nrows());
    let columns: usize = experiments
        .iter()
        .map(|e| layout.columns(e.u.nrows()))
        .sum();
    if columns < k {
        // J ≥ k columns are needed for a full-rank k×k factor.
        let min_samples = k + (p + f - 1) * experiments.len();
        return Err(Error::HorizonTooLong {
            past: p,
            future: f,
            n_samples: total,
            min_samples,
        });
    }
    let recs: Vec<(&DMatrix<f64>, &DMatrix<f64>)> =
        experiments.iter().map(|e| (e.u, e.y)).collect();
    let t0 = Instant::now();
    let us: Vec<&DMatrix<f64>> = experiments.iter().map(|e| e.u).collect();
    let ys: Vec<&DMatrix<f64>> = experiments.iter().map(|e| e.y).collect();
    let scale = Scale {
        u: pow4_scale(&us),
        y: pow4_scale(&ys),
    };
    let factor = compress(
        &recs,
        &layout,
        opts.compression,
        opts.chunk_rows,
        thread_count(opts.threads),
        scale,
    )?;
    let compress_s = t0.elapsed().as_secs_f64();
    let records: Vec<Record<'_>> = experiments
        .iter()
        .map(|e| Record {
            u: e.u,
            y: e.y,
            instrument: None,
        })
        .collect();
    from_factor(factor, &layout, opts, Some(&records), scale, compress_s)
}

/// Threads for the correlation kernel: 0 = all available.
fn thread_count(threads: usize) -> usize {
    if threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        threads
    }
}

/// The data records when they are available (in-memory identification),
/// else an error naming the option that needs them (streaming).
fn need_records<'r, 'a>(records: Option<&'r [Record<'a>]>) -> Result<&'r [Record<'a>]> {
    records.ok_or_else(|| Error::InvalidOption {
        what: "system",
        reason: "streaming identification keeps only the compressed data: (B, D) by output-error \
                 regression (SystemEstimate::ShiftInvariance or enforce_stability) needs the records; \
                 use SystemEstimate::StateSequence"
            .into(),
    })
}

/// CVA's weight W₁ = [(Y_f/U_f⊥)(Y_f/U_f⊥)ᵀ]^{−1/2} and its inverse
/// (eigenvalues floored at 1e-14 λ_max; erratum L-1). O(k³).
fn cva_weights(yf: &DMatrix<f64>, uf: &DMatrix<f64>) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    let yfp = perp(yf, uf)?;
    let e = sym_eig(&(&yfp * yfp.transpose()), SortOrder::Descending)?;
    let lmax = e.values.iter().cloned().fold(0.0, f64::max);
    let floor = (lmax * 1e-14).max(f64::MIN_POSITIVE);
    let mut w1 = DMatrix::zeros(e.values.len(), e.values.len());
    let mut w1i = w1.clone();
    for (i, &lam) in e.values.iter().enumerate() {
        let v = e.vectors.column(i);
        let lam = lam.max(floor);
        w1 += v * v.transpose() / lam.sqrt();
        w1i += v * v.transpose() * lam.sqrt();
    }
    Ok((w1, w1i))
}

/// The weighted subspace of one compressed data set (steps 2–3 of
/// [`identify`]), from which a model of any order is fitted.
struct Subspace<'a> {
    l: &'a DMatrix<f64>,
    layout: HankelLayout,
    /// Oblique projection Φ (scaled data).
    phi: DMatrix<f64>,
    /// Left singular vectors and singular values of W₁ Φ W₂.
    u: DMatrix<f64>,
    s: Vec<f64>,
    /// W₁⁻¹ (CVA only).
    w1_inv: Option<DMatrix<f64>>,
}

impl Subspace<'_> {
    /// Γ = W₁⁻¹ U₁ S₁^{1/2} of order n (scaled data).
    fn gamma(&self, n: usize) -> DMatrix<f64> {
        let gamma = scaled_basis(&self.u, &self.s, n);
        match &self.w1_inv {
            Some(w1i) => w1i * gamma,
            None => gamma,
        }
    }
}

/// A model of one order, in the original units of the data.
struct Fit {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    c: DMatrix<f64>,
    d: DMatrix<f64>,
    x0: Vec<DVector<f64>>,
    stabilized: bool,
    /// Γ of the scaled data (for the noise model).
    gamma: DMatrix<f64>,
}

/// Step 4 of [`identify`] for order n: (A, C) by shift invariance or from
/// the state sequences, (B, D, x₀) by the output-error regression on the
/// records or from the state-sequence regression (then x₀ alone from the
/// records, when present). O(k³) plus O(N n_y (n_u n³ + p²)) for the
/// regressions.
fn fit_order(
    sub: &Subspace<'_>,
    n: usize,
    opts: &SubspaceOptions,
    records: Option<&[Record<'_>]>,
    scale: Scale,
) -> Result<Fit> {
    let (nu, ny) = (sub.layout.nu, sub.layout.ny);
    let gamma = sub.gamma(n);
    // (B, D, x₀) by output-error regression on the records (in memory only),
    // for (A, C) of the scaled data: C in original units first.
    let output_error = |enforce: bool, gamma: DMatrix<f64>| -> Result<Fit> {
        let (a, c, stabilized) = ac_from_gamma(&gamma, ny, enforce)?;
        let c = c * scale.y;
        let bd = estimate_bd(
            &a,
            &c,
            need_records(records)?,
            &opts.feedthrough,
            opts.initial_state,
        )?;
        Ok(Fit {
            a,
            b: bd.b,
            c,
            d: bd.d,
            x0: bd.x0,
            stabilized,
            gamma,
        })
    };
    match opts.system {
        SystemEstimate::ShiftInvariance => output_error(opts.enforce_stability, gamma),
        SystemEstimate::StateSequence => {
            let mask = opts.feedthrough.mask(ny, nu)?;
            let ls = ac_from_states(sub.l, &sub.layout, &gamma, &sub.phi, &mask)?;
            if opts.enforce_stability && spectral_radius(&ls.a)? >= 1.0 {
                return output_error(true, gamma);
            }
            let (b, c, d) = scale.unscale(ls.b, ls.c, ls.d);
            let x0 = match opts.initial_state {
                InitialState::Estimate => match records {
                    Some(r) => estimate_x0(&ls.a, &b, &c, &d, r)?,
                    None => Vec::new(),
                },
                InitialState::Zero => vec![DVector::zeros(n); records.map_or(0, |r| r.len())],
            };
            Ok(Fit {
                a: ls.a,
                b,
                c,
                d,
                x0,
                stabilized: false,
                gamma,
            })
        }
    }
}

/// The values of the options' order criterion for orders 1..=`cap` and, for
/// AIC/AICc/BIC, the model of every order (None where the fit failed).
fn order_values(
    sub: &Subspace<'_>,
    cap: usize,
    opts: &SubspaceOptions,
    records: Option<&[Record<'_>]>,
    scale: Scale,
    columns: usize,
) -> Result<(OrderReport, Vec<Option<Fit>>)> {
    let (nu, ny) = (sub.layout.nu, sub.layout.ny);
    let criterion = opts.order_criterion;
    let mut fits = Vec::new();
    let values = match criterion {
        OrderCriterion::Svc => {
            // Canonical correlations: the CVA singular values.
            let cc = if opts.method == Method::Cva {
                sub.s.clone()
            } else {
                let uf = rows(sub.l, sub.layout.uf());
                let yf = rows(sub.l, sub.layout.yf());
                let (w1, _) = cva_weights(&yf, &uf)?;
                lifted_linalg::singular_values(&(w1 * perp(&sub.phi, &uf)?))?
                    .iter()
                    .cloned()
                    .collect()
            };
            svc_values(&cc, cap, ny, nu, columns)
        }
        c if c.needs_models() => {
            let recs = need_records(records)?;
            let (values, models) = information_criterion_values(
                c,
                cap,
                recs,
                (ny, nu),
                &opts.feedthrough,
                opts.initial_state,
                |n| fit_order(sub, n, opts, records, scale),
                |f: &Fit| simulation_error(&f.a, &f.b, &f.c, &f.d, recs, &f.x0),
            )?;
            fits = models;
            values
        }
        _ => gap_values(&sub.s, cap),
    };
    Ok((OrderReport::new(criterion, values), fits))
}

/// Steps 2–5 of [`identify`] on the compressed data L of the scaled data
/// (records, in original units, only for the output-error (B, D, x₀)
/// regressions and the AIC-type criteria; `None` when streaming).
fn from_factor(
    factor: HankelFactor,
    layout: &HankelLayout,
    opts: &SubspaceOptions,
    records: Option<&[Record<'_>]>,
    scale: Scale,
    compress_s: f64,
) -> Result<SubspaceModel> {
    let t1 = Instant::now();
    let HankelFactor {
        l,
        columns,
        report: compression,
    } = factor;
    let compression_flops = compression.flops;
    let (p, f, nu, ny) = (layout.past, layout.future, layout.nu, layout.ny);
    let layout = *layout;
    let max_order = (f - 1) * ny;
    // Persistent excitation: the input rows [U_f; U_p] must have full rank.
    let nu_rows = (p + f) * nu;
    let luu = l.view((0, 0), (nu_rows, nu_rows)).into_owned();
    check_exciting("u", numerical_rank(&luu, 1e-10)?, nu_rows)?;

    let uf = rows(&l, layout.uf());
    let wp = vstack(&[&rows(&l, layout.up()), &rows(&l, layout.yp())]);
    let yf = rows(&l, layout.yf());
    let phi = oblique(&yf, &uf, &wp)?;
    let (w1_inv, weighted) = match opts.method {
        Method::N4sid => (None, phi.clone()),
        Method::Moesp => (None, perp(&phi, &uf)?),
        Method::Cva => {
            let (w1, w1i) = cva_weights(&yf, &uf)?;
            (Some(w1i), w1 * perp(&phi, &uf)?)
        }
    };
    let dec = svd(&weighted)?;
    let svd_s = t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let sub = Subspace {
        l: &l,
        layout,
        phi,
        u: dec.u,
        s: dec.s.iter().cloned().collect(),
        w1_inv,
    };
    // N4SID's and MOESP's singular values scale with the outputs; CVA's
    // are canonical correlations.
    let sv_unit = if opts.method == Method::Cva {
        1.0
    } else {
        scale.y
    };
    let singular_values: Vec<f64> = sub.s.iter().map(|v| v * sv_unit).collect();
    let cap = candidate_orders(opts.order, max_order);
    let suggested_order = gap_order(&sub.s, cap);
    let (order_selection, mut fits) = order_values(&sub, cap, opts, records, scale, columns)?;
    let n = match opts.order {
        OrderSelection::Fixed(n) => n,
        OrderSelection::Gap { .. } => order_selection.selected,
    };
    if n > sub.s.len() {
        return Err(Error::OrderTooLarge {
            order: n,
            max: sub.s.len(),
        });
    }
    let fit = match fits.get_mut(n - 1).and_then(Option::take) {
        Some(fit) => fit,
        None => fit_order(&sub, n, opts, records, scale)?,
    };

    let mut noise = None;
    let mut kalman_gain = None;
    let mut noise_model_error = None;
    if opts.noise_model {
        let (bs, cs, ds) = scale.rescale(&fit.b, &fit.c, &fit.d);
        match noise_model(&l, &layout, &fit.gamma, &sub.phi, &fit.a, &bs, &cs, &ds) {
            Ok((cov, kg)) => {
                // Back to original units: v and e scale with s_y, w not.
                noise = Some(NoiseCovariances {
                    q: cov.q,
                    r: cov.r * (scale.y * scale.y),
                    s: cov.s * scale.y,
                });
                match kg {
                    Ok(k) => kalman_gain = Some(k / scale.y),
                    Err(e) => noise_model_error = Some(e),
                }
            }
            Err(e) => noise_model_error = Some(e.to_string()),
        }
    }
    let model = StateSpace::new(fit.a, fit.b, fit.c, fit.d, Some(opts.ts))?;
    Ok(SubspaceModel {
        model,
        kalman_gain,
        noise,
        x0: fit.x0,
        diagnostics: Diagnostics {
            method: opts.method,
            singular_values,
            order: n,
            suggested_order,
            order_selection,
            horizons: (p, f),
            columns,
            stabilized: fit.stabilized,
            noise_model_error,
            compression_flops,
            compression,
            profile: Profile {
                compress_s,
                svd_s,
                estimate_s: t2.elapsed().as_secs_f64(),
            },
        },
    })
}

/// The state sequence X(t) = Γ⁺Φ(t) = Γ⁺M W_p(t) (Φ = M W_p, the oblique
/// projection is a fixed linear map M of the past data) at times t and t+1,
/// and the rows u(t), y(t) (thesis §2.2–2.3). W_p(t+1) = [u(t−p+1…t);
/// y(t−p+1…t)] consists of Hankel rows, so both sequences live in the row
/// space of the compressed factor and are consecutive in time.
fn state_sequences(
    l: &DMatrix<f64>,
    lay: &HankelLayout,
    gamma: &DMatrix<f64>,
    _phi: &DMatrix<f64>,
) -> Result<[DMatrix<f64>; 4]> {
    let (nu, ny) = (lay.nu, lay.ny);
    let ufr = lay.uf();
    let yfr = lay.yf();
    let upr = lay.up();
    let ypr = lay.yp();
    let u_i = rows(l, ufr.start..ufr.start + nu);
    let y_i = rows(l, yfr.start..yfr.start + ny);
    let uf = rows(l, ufr.clone());
    let yf = rows(l, yfr.clone());
    let wp = vstack(&[&rows(l, upr.clone()), &rows(l, ypr.clone())]);
    let wp_next = vstack(&[
        &rows(l, upr.start + nu..upr.end),
        &u_i,
        &rows(l, ypr.start + ny..ypr.end),
        &y_i,
    ]);
    let m = oblique_map(&yf, &uf, &wp)?;
    let k = pinv(gamma, RankTolerance::Default)? * m;
    Ok([&k * wp, &k * wp_next, u_i, y_i])
}

/// A and C from the state-sequence regression (thesis §2.3) with the
/// feedthrough mask applied per output row (§4.5).
fn ac_from_states(
    l: &DMatrix<f64>,
    lay: &HankelLayout,
    gamma: &DMatrix<f64>,
    phi: &DMatrix<f64>,
    mask: &DMatrix<bool>,
) -> Result<StateLs> {
    let [x_i, x_ip1, u_i, y_i] = state_sequences(l, lay, gamma, phi)?;
    let n = x_i.nrows();
    let z = vstack(&[&x_i, &u_i]);
    let ab = lstsq(&z.transpose(), &x_ip1.transpose())?.transpose();
    let a = ab.columns(0, n).into_owned();
    let b = ab.columns(n, lay.nu).into_owned();
    let mut c = DMatrix::zeros(lay.ny, n);
    let mut d = DMatrix::zeros(lay.ny, lay.nu);
    for o in 0..lay.ny {
        let allowed: Vec<usize> = (0..lay.nu).filter(|&j| mask[(o, j)]).collect();
        let mut zo = DMatrix::zeros(n + allowed.len(), x_i.ncols());
        zo.rows_mut(0, n).copy_from(&x_i);
        for (t, &j) in allowed.iter().enumerate() {
            zo.row_mut(n + t).copy_from(&u_i.row(j));
        }
        let yo = DMatrix::from_fn(y_i.ncols(), 1, |k, _| y_i[(o, k)]);
        let th = lstsq(&zo.transpose(), &yo)?;
        for s in 0..n {
            c[(o, s)] = th[(s, 0)];
        }
        for (t, &j) in allowed.iter().enumerate() {
            d[(o, j)] = th[(n + t, 0)];
        }
    }
    Ok(StateLs { a, b, c, d })
}

/// (A, B, C, D) of the state-sequence regression.
struct StateLs {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    c: DMatrix<f64>,
    d: DMatrix<f64>,
}

type NoiseResult = (NoiseCovariances, std::result::Result<DMatrix<f64>, String>);

/// Q, R, S from the state sequences (thesis §2.3) and the Kalman gain from
/// the filter DARE X = AXAᵀ − (AXCᵀ + S)(CXCᵀ + R)⁻¹(·)ᵀ + Q.
#[allow(clippy::too_many_arguments)]
fn noise_model(
    l: &DMatrix<f64>,
    lay: &HankelLayout,
    gamma: &DMatrix<f64>,
    phi: &DMatrix<f64>,
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    c: &DMatrix<f64>,
    d: &DMatrix<f64>,
) -> Result<NoiseResult> {
    let [x_i, x_ip1, u_i, y_i] = state_sequences(l, lay, gamma, phi)?;
    let w = x_ip1 - a * &x_i - b * &u_i;
    let v = y_i - c * &x_i - d * &u_i;
    let cov = NoiseCovariances {
        q: &w * w.transpose(),
        r: &v * v.transpose(),
        s: &w * v.transpose(),
    };
    let kg = dare(&a.transpose(), &c.transpose(), &cov.q, &cov.r, Some(&cov.s))
        .map(|sol| sol.k.transpose())
        .map_err(|e| e.to_string());
    Ok((cov, kg))
}

/// [`identify`] behind the common [`lifted_lti::identify::Identifier`]
/// interface: single-rate [`lifted_lti::Dataset`]s (several experiments are
/// merged); the model gets the data's period.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SubspaceIdentifier {
    /// Options (the sample period is taken from the data).
    pub options: SubspaceOptions,
}

impl lifted_lti::identify::Identifier for SubspaceIdentifier {
    type Diagnostics = Diagnostics;
    type Error = Error;

    fn name(&self) -> &'static str {
        self.options.method.name()
    }

    fn identify(
        &self,
        experiments: &[lifted_lti::Dataset],
    ) -> Result<lifted_lti::identify::Identified<Diagnostics>> {
        let layout = lifted_lti::identify::check_experiments(experiments)?;
        if let Some(i) = experiments.iter().position(|e| !e.is_single_rate()) {
            return Err(Error::InvalidOption {
                what: "experiments",
                reason: format!("experiment {i} is multirate; use the multirate crate (lifting)"),
            });
        }
        let recs: Vec<Experiment<'_>> = experiments
            .iter()
            .map(|e| Experiment { u: e.u(), y: e.y() })
            .collect();
        let opts = SubspaceOptions {
            ts: layout.ts,
            ..self.options.clone()
        };
        let fit = identify(&recs, &opts)?;
        Ok(lifted_lti::identify::Identified {
            model: fit.model,
            diagnostics: fit.diagnostics,
        })
    }
}

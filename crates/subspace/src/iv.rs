//! Instrumental-variable subspace identification (thesis ch. 7):
//! open loop with the input as instrument (§7.3), closed loop with the
//! external excitation as instrument (§7.4), and the one-step multirate
//! fast model of §7.5 (eq. 7.27).

use lifted_linalg::{lstsq, qr_r, svd};
use lifted_lti::StateSpace;
use nalgebra::{DMatrix, DVector};

use crate::checks::{candidate_orders, check_instrument, check_order, validate};
use crate::error::{Error, Result, check_data, check_exciting, check_rank};
use crate::estimated::{BdFit, Record};
use crate::estimated::{Feedthrough, InitialState};
use crate::model::Experiment;
use crate::numerics::{Scale, ac_from_gamma, numerical_rank, pow4_scale, scaled_basis};
use crate::options::OrderSelection;
use crate::order::{
    OrderCriterion, OrderReport, gap_values, information_criterion_values, simulation_error,
};
use crate::predictor_regress::predictor_regression;
use crate::regress::{estimate_bd, estimate_bd_iv};
use lifted_linalg::spectral_radius;

/// One record for [`iv_identify`].
#[derive(Debug, Clone, Copy)]
pub struct IvExperiment<'a> {
    /// Plant input u (N×n_u), one row per sample.
    pub u: &'a DMatrix<f64>,
    /// Plant output y (N×n_y).
    pub y: &'a DMatrix<f64>,
    /// Instrument (N×n_u): the external excitation f of a closed loop (at
    /// the plant input or at the set-point; erratum L-17), independent of
    /// the noise. `None` uses u itself (open loop, §7.3).
    pub instrument: Option<&'a DMatrix<f64>>,
}

/// Options of [`iv_identify`].
#[derive(Debug, Clone, PartialEq)]
pub struct IvOptions {
    /// Order choice. Default `Gap { max: 10 }`.
    pub order: OrderSelection,
    /// Rule of the automatic order choice and of
    /// [`IvDiagnostics::order_selection`]. Default [`OrderCriterion::Gap`]
    /// (gap of the singular values of R₂₂); AIC/AICc/BIC (SIPPY) fit and
    /// simulate the IV model of every order; [`OrderCriterion::Svc`] is
    /// not defined for the IV method ([`Error::InvalidOption`]).
    pub order_criterion: OrderCriterion,
    /// α: block rows of the future U_f, Y_f (eq. 7.5; α > n). Default 8.
    pub alpha: usize,
    /// α_p: block rows of the past instrument; must exceed α + n/n_u
    /// (erratum L-16). `None` uses 2α, the reference implementation's choice.
    pub alpha_p: Option<usize>,
    /// Which entries of D are estimated. Default [`Feedthrough::Free`].
    pub feedthrough: Feedthrough,
    /// Initial state in the (B, D) regression. Default [`InitialState::Estimate`].
    pub initial_state: InitialState,
    /// Re-estimate an unstable A with the zero-padded shift. Default false.
    pub enforce_stability: bool,
    /// Return [`Error::Unstable`] instead of an unstable model. Default false.
    pub require_stable: bool,
    /// Sample period of the returned model. Default 1.0.
    pub ts: f64,
}

impl Default for IvOptions {
    fn default() -> Self {
        IvOptions {
            order: OrderSelection::default(),
            order_criterion: OrderCriterion::Gap,
            alpha: 8,
            alpha_p: None,
            feedthrough: Feedthrough::Free,
            initial_state: InitialState::Estimate,
            enforce_stability: false,
            require_stable: false,
            ts: 1.0,
        }
    }
}

/// Diagnostics of an IV identification.
#[derive(Debug, Clone, PartialEq)]
pub struct IvDiagnostics {
    /// Singular values of R₂₂ (eq. 7.22), descending.
    pub singular_values: Vec<f64>,
    /// Order used.
    pub order: usize,
    /// Order of the gap rule.
    pub suggested_order: usize,
    /// The order criterion of the options with its value per candidate
    /// order and the order it selects (the gap rule for
    /// [`iv_multirate_fast`]).
    pub order_selection: OrderReport,
    /// (α, α_p).
    pub horizons: (usize, usize),
    /// Columns J of the Hankel matrices (all records).
    pub columns: usize,
    /// True if A was re-estimated to make it stable.
    pub stabilized: bool,
    /// Singular values of Γ_R (multirate one-step formula only).
    pub gamma_r_singular_values: Vec<f64>,
    /// Why (B, D, x₀) did not come from the output-error regression, when
    /// they did not (an A too unstable for it: the one-step predictor
    /// regression instead, which also moves A); `None` otherwise.
    pub bd_fallback: Option<String>,
}

/// An IV-identified model.
#[derive(Debug, Clone, PartialEq)]
pub struct IvModel {
    /// The deterministic model (A, B, C, D).
    pub model: StateSpace,
    /// Estimated initial state per record.
    pub x0: Vec<DVector<f64>>,
    /// Singular values and orders.
    pub diagnostics: IvDiagnostics,
}

/// The IV subspace: left singular vectors and singular values of R₂₂
/// (scaled data), from which Γ of any order follows.
struct IvSubspace {
    u: DMatrix<f64>,
    s: Vec<f64>,
    columns: usize,
    /// Instrument rows α_p·n_z and future input rows α·n_u (for errors).
    rows_z: usize,
    un: usize,
}

impl IvSubspace {
    /// Γ = U₁ S₁^{1/2} of order n (scaled data).
    fn gamma(&self, n: usize) -> DMatrix<f64> {
        scaled_basis(&self.u, &self.s, n)
    }

    /// Order n must be admissible ((α − 1)n_y) and below the number of
    /// singular values of R₂₂ (instrument length, erratum L-16).
    fn check(&self, n: usize, alpha: usize, ny: usize) -> Result<()> {
        if n == 0 || n > (alpha - 1) * ny {
            return Err(Error::OrderTooLarge {
                order: n,
                max: (alpha - 1) * ny,
            });
        }
        if n > self.s.len() {
            return Err(Error::InstrumentTooShort {
                instrument_rows: self.rows_z,
                needed: self.un + n,
            });
        }
        Ok(())
    }
}

/// The LQ of [U_f Zᵀ; Y_f Zᵀ]/J and the SVD of R₂₂ (eqs. 7.20–7.23), with
/// past instruments Z (α_p block rows) and β = α_p, on the data divided by
/// `scale` (u, y) and `z_scale` (instrument; powers of 4, exact).
/// Cost O(J·α(n_u+n_y)·α_p n_z) for the correlations, memory O(α²).
fn iv_subspace(
    recs: &[(&DMatrix<f64>, &DMatrix<f64>, &DMatrix<f64>)],
    alpha: usize,
    alpha_p: usize,
    scale: Scale,
    z_scale: f64,
) -> Result<IvSubspace> {
    let (u0, y0, z0) = recs[0];
    let (nu, ny, nz) = (u0.ncols(), y0.ncols(), z0.ncols());
    let (iu, iy, iz) = (1.0 / scale.u, 1.0 / scale.y, 1.0 / z_scale);
    const B: usize = 512;
    // The horizons against the records, then the sizes (memory budget,
    // overflow), before anything is allocated.
    let rows_h = alpha.saturating_mul(nu + ny);
    let rows_z = alpha_p.saturating_mul(nz);
    let total: usize = recs.iter().map(|r| r.0.nrows()).sum();
    let span = alpha.saturating_add(alpha_p);
    let lengths: Vec<usize> = recs.iter().map(|r| r.0.nrows()).collect();
    if !iv_fits(&lengths, (nu, ny, nz), alpha, alpha_p) {
        return Err(Error::HorizonTooLong {
            past: alpha_p,
            future: alpha,
            n_samples: total,
            min_samples: rows_z
                .max(rows_h)
                .saturating_add((span - 1).saturating_mul(recs.len())),
        });
    }
    crate::budget::check_iv(alpha, alpha_p, nu, ny, nz, B)?;
    let mut m = DMatrix::zeros(rows_h, rows_z);
    let mut zz = DMatrix::zeros(rows_z, rows_z);
    let mut columns = 0;
    for (u, y, z) in recs {
        let nn = u.nrows();
        let j = (nn + 1).saturating_sub(alpha + alpha_p);
        let mut start = 0;
        while start < j {
            let len = B.min(j - start);
            let mut h = DMatrix::zeros(rows_h, len);
            let mut zc = DMatrix::zeros(rows_z, len);
            for c in 0..len {
                let t = start + c;
                for lag in 0..alpha_p {
                    for q in 0..nz {
                        zc[(lag * nz + q, c)] = z[(t + lag, q)] * iz;
                    }
                }
                let tf = t + alpha_p;
                for lag in 0..alpha {
                    for q in 0..nu {
                        h[(lag * nu + q, c)] = u[(tf + lag, q)] * iu;
                    }
                    for q in 0..ny {
                        h[(alpha * nu + lag * ny + q, c)] = y[(tf + lag, q)] * iy;
                    }
                }
            }
            let zt = zc.transpose();
            m += &h * &zt;
            zz += &zc * &zt;
            start += len;
        }
        columns += j;
    }
    debug_assert_eq!(columns, iv_columns(&lengths, span));
    m /= columns as f64;
    check_exciting(
        crate::error::INSTRUMENT_ROWS,
        numerical_rank(&zz, 1e-10)?,
        rows_z,
    )?;
    let r = qr_r(&m.transpose())?;
    let l = r.transpose();
    let cols_l = l.ncols();
    let un = alpha * nu;
    if cols_l <= un {
        return Err(Error::InstrumentTooShort {
            instrument_rows: rows_z,
            needed: un + 1,
        });
    }
    let r22 = l.view((un, un), (alpha * ny, cols_l - un)).into_owned();
    let dec = svd(&r22)?;
    Ok(IvSubspace {
        u: dec.u,
        s: dec.s.iter().cloned().collect(),
        columns,
        rows_z,
        un,
    })
}

/// Hankel columns of records of `lengths` samples for a span of `span`
/// samples (α + α_p).
fn iv_columns(lengths: &[usize], span: usize) -> usize {
    lengths.iter().map(|&n| (n + 1).saturating_sub(span)).sum()
}

/// Whether records of `lengths` samples with (n_u, n_y, n_z) channels
/// give the IV subspace the columns it needs at (α, α_p): at least as many
/// as the instrument rows α_p n_z and the data rows α (n_u + n_y).
fn iv_fits(
    lengths: &[usize],
    (nu, ny, nz): (usize, usize, usize),
    alpha: usize,
    alpha_p: usize,
) -> bool {
    let rows = alpha_p
        .saturating_mul(nz)
        .max(alpha.saturating_mul(nu + ny));
    iv_columns(lengths, alpha.saturating_add(alpha_p)) >= rows
}

/// The largest α ≤ `max` (at least 2) for which [`iv_identify`] has the
/// Hankel columns it needs on records of `lengths` samples with `nu`
/// inputs, `ny` outputs and `nz` instrument channels, α_p = `alpha_p` or
/// its default 2α; `None` when not even α = 2 fits. A caller with a record
/// too short for the default α uses it instead of a refusal (the workflow
/// also for a multirate record's lifted frames). No α beyond the longest
/// record fits (its span α + α_p leaves no column), so the search starts
/// there: O(min(max, N) · records) whatever `max` a caller asks for.
pub fn iv_longest_alpha(
    lengths: &[usize],
    (nu, ny, nz): (usize, usize, usize),
    max: usize,
    alpha_p: Option<usize>,
) -> Option<usize> {
    let longest = lengths.iter().copied().max().unwrap_or(0);
    (2..=max.min(longest).max(2))
        .rev()
        .find(|&a| iv_fits(lengths, (nu, ny, nz), a, alpha_p.unwrap_or(2 * a)))
}

fn check_horizons(alpha: usize, alpha_p: usize) -> Result<()> {
    if alpha < 2 {
        return Err(Error::InvalidHorizon {
            what: "alpha",
            value: alpha,
            reason: "must be at least 2".into(),
        });
    }
    if alpha_p <= alpha {
        return Err(Error::InvalidHorizon {
            what: "alpha_p",
            value: alpha_p,
            reason: format!("must exceed alpha = {alpha} (erratum L-16)"),
        });
    }
    Ok(())
}

fn check_ts(ts: f64) -> Result<()> {
    if ts.is_finite() && ts > 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidOption {
            what: "ts",
            reason: format!("sample period must be positive and finite, got {ts}"),
        })
    }
}

/// Instrumental-variable subspace identification (thesis §7.3–7.4).
///
/// Instruments: α_p block rows of past instrument samples z(k … k+α_p−1)
/// (the input itself in open loop, the excitation f in closed loop);
/// future U_f, Y_f start at β = α_p. Γ from the SVD of R₂₂ of the LQ of
/// [U_f Zᵀ; Y_f Zᵀ]/J (eq. 7.22), A and C by shift invariance, then (B, D,
/// x₀) by least squares (open loop) or by IV regression with instruments
/// filtered from f (closed loop). Box-Jenkins noise is allowed: nothing is
/// assumed about the noise model beyond its independence of the instrument.
/// u, y and the instrument are each divided by a power of 4 near their RMS
/// first (exact; the results are in the original units).
///
/// Cost O(J α(n_u+n_y) α_p n_z + (α_p n_z)³ + N n_y(n_u n³ + p²)), times
/// the number of candidate orders for the AIC-type criteria; memory
/// independent of N.
///
/// Errors: [`Error::NoData`], [`Error::DimensionMismatch`],
/// [`Error::NonFinite`], [`Error::InvalidHorizon`] (α_p ≤ α, L-16),
/// [`Error::HorizonTooLong`], [`Error::NotExciting`] (instrument),
/// [`Error::InstrumentTooShort`], [`Error::OrderTooLarge`] (also for a
/// criterion's `max` above (α − 1)n_y), [`Error::InvalidOption`]
/// ([`OrderCriterion::Svc`]), [`Error::Unstable`] with `require_stable`,
/// [`Error::UnstableEstimate`] when the estimated A is so unstable that the
/// output-error regression over the record cannot be computed and the
/// one-step predictor regression that then takes its place fails too
/// ((A, C) not detectable). An A too unstable for the output-error
/// regression otherwise gets (B, D, x₀) and a re-estimated A from that
/// predictor regression ([`IvDiagnostics::bd_fallback`] says so).
pub fn iv_identify(experiments: &[IvExperiment<'_>], opts: &IvOptions) -> Result<IvModel> {
    let prep = IvPrepared::new(experiments, opts)?;
    let (nu, ny) = (prep.nu, prep.ny);
    let fit = |n: usize| prep.output_error(n, opts);
    let records = &prep.records;
    let cap = candidate_orders(opts.order, prep.max_order);
    let mut fits = Vec::new();
    let values = if opts.order_criterion.needs_models() {
        prep.sub.check(cap, prep.alpha, ny)?;
        let (values, models) = information_criterion_values(
            opts.order_criterion,
            cap,
            records,
            (ny, nu),
            &opts.feedthrough,
            opts.initial_state,
            fit,
            |(a, c, bd, _)| simulation_error(a, &bd.b, c, &bd.d, records, &bd.x0),
        )?;
        fits = models;
        values
    } else {
        gap_values(&prep.sub.s, cap.min(prep.sub.s.len()))
    };
    let suggested = OrderReport::new(
        OrderCriterion::Gap,
        gap_values(&prep.sub.s, cap.min(prep.sub.s.len())),
    )
    .selected;
    let order_selection = OrderReport::new(opts.order_criterion, values);
    let n = match opts.order {
        OrderSelection::Fixed(n) => n,
        OrderSelection::Gap { .. } => order_selection.selected,
    };
    let ((a, c, bd, stabilized), bd_fallback) = match n
        .checked_sub(1)
        .and_then(|i| fits.get_mut(i))
        .and_then(Option::take)
    {
        Some(fit) => (fit, None),
        None => prep.model(n, opts)?,
    };
    let sv_unit = prep.scale.y * prep.z_scale;
    Ok(IvModel {
        model: StateSpace::new(a, bd.b, c, bd.d, Some(opts.ts))?,
        x0: bd.x0,
        diagnostics: IvDiagnostics {
            singular_values: prep.sub.s.iter().map(|v| v * sv_unit).collect(),
            order: n,
            suggested_order: suggested,
            order_selection,
            horizons: (prep.alpha, prep.alpha_p),
            columns: prep.sub.columns,
            stabilized,
            gamma_r_singular_values: Vec::new(),
            bd_fallback,
        },
    })
}

/// A model of [`IvPrepared::output_error`]: (A, C, (B, D, x₀), A
/// re-estimated to be stable).
type IvFit = (DMatrix<f64>, DMatrix<f64>, BdFit, bool);

/// The checked records and the IV subspace of [`iv_identify`], from which
/// the model of any order follows (the held-out order selection fits every
/// order of a fold from one of these).
pub(crate) struct IvPrepared<'r> {
    sub: IvSubspace,
    scale: Scale,
    z_scale: f64,
    records: Vec<Record<'r>>,
    closed_loop: bool,
    alpha: usize,
    alpha_p: usize,
    nu: usize,
    ny: usize,
    /// (α − 1) n_y.
    pub(crate) max_order: usize,
}

impl<'r> IvPrepared<'r> {
    /// The checks of [`iv_identify`] and the IV subspace (eqs. 7.20–7.23).
    pub(crate) fn new(experiments: &[IvExperiment<'r>], opts: &IvOptions) -> Result<Self> {
        let first = experiments.first().ok_or(Error::NoData)?;
        let (nu, ny) = (first.u.ncols(), first.y.ncols());
        check_ts(opts.ts)?;
        let alpha = opts.alpha;
        let alpha_p = opts.alpha_p.unwrap_or(alpha.saturating_mul(2));
        check_horizons(alpha, alpha_p)?;
        // The (u, y) records are checked as for `identify`; then the instruments.
        let plain: Vec<Experiment<'_>> = experiments
            .iter()
            .map(|e| Experiment { u: e.u, y: e.y })
            .collect();
        validate(&plain)?;
        for e in experiments {
            if let Some(f) = e.instrument {
                check_instrument(f, e.u)?;
            }
        }
        if opts.order_criterion == OrderCriterion::Svc {
            return Err(Error::InvalidOption {
                what: "order_criterion",
                reason: "SVC is defined on canonical correlations, which the IV method does not compute; use Gap, Aic, Aicc or Bic".into(),
            });
        }
        let max_order = (alpha - 1).saturating_mul(ny);
        check_order(opts.order, opts.order_criterion, max_order)?;
        let recs: Vec<_> = experiments
            .iter()
            .map(|e| (e.u, e.y, e.instrument.unwrap_or(e.u)))
            .collect();
        let scale = Scale {
            u: pow4_scale(&recs.iter().map(|r| r.0).collect::<Vec<_>>()),
            y: pow4_scale(&recs.iter().map(|r| r.1).collect::<Vec<_>>()),
        };
        let z_scale = pow4_scale(&recs.iter().map(|r| r.2).collect::<Vec<_>>());
        let sub = iv_subspace(&recs, alpha, alpha_p, scale, z_scale)?;
        let records: Vec<Record<'r>> = experiments
            .iter()
            .map(|e| Record {
                u: e.u,
                y: e.y,
                instrument: e.instrument,
            })
            .collect();
        let closed_loop = experiments.iter().any(|e| e.instrument.is_some());
        Ok(IvPrepared {
            sub,
            scale,
            z_scale,
            records,
            closed_loop,
            alpha,
            alpha_p,
            nu,
            ny,
            max_order,
        })
    }

    /// A and C of order n in original units by shift invariance (C of the
    /// scaled data times s_y); an unstable A is refused with
    /// `require_stable`.
    fn ac(&self, n: usize, opts: &IvOptions) -> Result<(DMatrix<f64>, DMatrix<f64>, bool)> {
        self.sub.check(n, self.alpha, self.ny)?;
        let (a, c, stabilized) =
            ac_from_gamma(&self.sub.gamma(n), self.ny, opts.enforce_stability, 0.0)?;
        let c = c * self.scale.y;
        if opts.require_stable {
            let rho = spectral_radius(&a)?;
            if rho >= 1.0 {
                return Err(Error::Unstable {
                    spectral_radius: rho,
                });
            }
        }
        Ok((a, c, stabilized))
    }

    /// The model of order n with (B, D, x₀) by the output-error regression
    /// (least squares in open loop, IV with instruments filtered from f in
    /// closed loop); an A too unstable for it is
    /// [`Error::UnstableEstimate`], raised before the regression.
    fn output_error(&self, n: usize, opts: &IvOptions) -> Result<IvFit> {
        let (a, c, stabilized) = self.ac(n, opts)?;
        let bd = if self.closed_loop {
            estimate_bd_iv(&a, &c, &self.records, &opts.feedthrough, opts.initial_state)?
        } else {
            estimate_bd(&a, &c, &self.records, &opts.feedthrough, opts.initial_state)?
        };
        Ok((a, c, bd, stabilized))
    }

    /// The model of order n: [`IvPrepared::output_error`], or, when A is
    /// too unstable for the output-error regression over the records,
    /// (A, B, D, x₀) by the one-step predictor regression
    /// ([`predictor_form`]) with the reason, so that the unstable model
    /// comes back (the caller warns) rather than no model.
    pub(crate) fn model(&self, n: usize, opts: &IvOptions) -> Result<(IvFit, Option<String>)> {
        match self.output_error(n, opts) {
            Ok(fit) => Ok((fit, None)),
            Err(
                e @ Error::UnstableEstimate {
                    spectral_radius,
                    samples,
                    growth,
                    ..
                },
            ) => {
                let (a, c, stabilized) = self.ac(n, opts)?;
                let (a, bd) = predictor_form(&a, &c, &self.records, opts).map_err(|_| e)?;
                let why = format!(
                    "the IV estimate of A is unstable (spectral radius {spectral_radius:.6}): an output-error regression over {samples} samples would grow by {growth:.1e}; (B, D, x0) and A = Ã + K C instead by the one-step predictor regression, Ã = A − K₀C with a stabilising observer gain K₀ and C fixed, K re-estimated"
                );
                Ok(((a, c, bd, stabilized), Some(why)))
            }
            Err(e) => Err(e),
        }
    }

    /// The largest order the IV subspace identifies: (α − 1) n_y, at most
    /// the number of singular values of R₂₂.
    pub(crate) fn supported(&self) -> usize {
        self.max_order.min(self.sub.s.len())
    }

    /// The model of order n as a [`StateSpace`] of period `opts.ts`.
    pub(crate) fn state_space(&self, n: usize, opts: &IvOptions) -> Result<StateSpace> {
        let ((a, c, bd, _), _) = self.model(n, opts)?;
        Ok(StateSpace::new(a, bd.b, c, bd.d, Some(opts.ts))?)
    }
}

/// (A, B, D, x₀) of an IV model whose A is too unstable for the
/// output-error regression over the records: with Ã = A − K₀C for the
/// observer gain K₀ of the Riccati equation with unit weights (stable
/// whenever (A, C) is detectable), (B̃, K, D, x₀) by the linear one-step
/// predictor regression (`crate::predictor_regress`, PBSID's step 5: its
/// regressors are filtered by the stable Ã, so they do not grow, and it
/// stays consistent in closed loop), then A = Ã + K C and B = B̃ + K D.
/// A moves from the IV estimate by (K − K₀) C. O(n³) for the Riccati
/// equation, then the regression's O(N (n_y q² + n³ n_z)).
fn predictor_form(
    a: &DMatrix<f64>,
    c: &DMatrix<f64>,
    records: &[Record<'_>],
    opts: &IvOptions,
) -> Result<(DMatrix<f64>, BdFit)> {
    let (n, ny) = (a.nrows(), c.nrows());
    let nu = records.first().map_or(0, |r| r.u.ncols());
    let k0 = lifted_linalg::dare(
        &a.transpose(),
        &c.transpose(),
        &DMatrix::identity(n, n),
        &DMatrix::identity(ny, ny),
        None,
    )?
    .k
    .transpose();
    let a_pred = a - &k0 * c;
    let mask = opts.feedthrough.mask(ny, nu)?;
    let with_x0 = opts.initial_state == InitialState::Estimate;
    let fit = predictor_regression(&a_pred, c, &mask, records, with_x0)?;
    let x0 = if with_x0 {
        fit.x0
    } else {
        vec![nalgebra::DVector::zeros(n); records.len()]
    };
    let offsets = vec![nalgebra::DVector::zeros(ny); records.len()];
    Ok((
        fit.a,
        BdFit {
            b: fit.b,
            d: fit.d,
            x0,
            offsets,
        },
    ))
}

/// Options of [`iv_multirate_fast`].
#[derive(Debug, Clone, PartialEq)]
pub struct MultirateIvOptions {
    /// Order of the fast model. Default `Gap { max: 10 }`.
    pub order: OrderSelection,
    /// α in lifted block rows. Default 6.
    pub alpha: usize,
    /// α_p in lifted block rows; `None` uses 2α (erratum L-16).
    pub alpha_p: Option<usize>,
    /// Which entries of the fast D are estimated. Default [`Feedthrough::Free`].
    pub feedthrough: Feedthrough,
    /// Initial state in the (B, D) regression. Default [`InitialState::Estimate`].
    pub initial_state: InitialState,
    /// Relative singular-value threshold below which Γ_R is declared rank
    /// deficient (eq. 7.27, erratum L-18). Default 1e-6.
    pub rank_tol: f64,
    /// Return [`Error::Unstable`] instead of an unstable fast model. Default false.
    pub require_stable: bool,
    /// Fast sample period T of the returned model. Default 1.0.
    pub ts: f64,
}

impl Default for MultirateIvOptions {
    fn default() -> Self {
        MultirateIvOptions {
            order: OrderSelection::default(),
            alpha: 6,
            alpha_p: None,
            feedthrough: Feedthrough::Free,
            initial_state: InitialState::Estimate,
            rank_tol: 1e-6,
            require_stable: false,
            ts: 1.0,
        }
    }
}

/// The one-step multirate IV method of thesis §7.5: all inputs are updated
/// every T, output o is sampled every `periods[o]`·T (each period divides
/// n = max period; at least one output has period 1). The data are lifted
/// by n with time-interleaved ordering (§7.5: u̲ = [u(kn); u(kn+1); …],
/// y̲ = outputs sampled at kn, then at kn+1, …), the lifted Γ̲ is estimated
/// with the IV method, and the fast A_d follows directly from the rows of
/// the fast-sampled outputs, C₂A_d^t for t = 0 … nα−1, by
/// A_d = Γ_R⁺Γ_L (eq. 7.27). C_d is the first lifted block row; (B_d, D_d,
/// x₀) come from an IV regression at the fast rate on the sampled instants.
///
/// `u` (N×n_u, fast), `y` (N×n_y, NaN or any value at unsampled instants —
/// they are ignored), `f` (N×n_u) the instrument, interleaved like u (§7.5:
/// [u₁; f] when u₁ is open loop and f excites the loop of u₂).
///
/// Errors: as [`iv_identify`]; [`Error::RankDeficient`] when Γ_R has rank
/// below the order, i.e. (C₂, A_d) is not observable from the fast outputs
/// (erratum L-18: use the two-step route of the multirate crate then);
/// [`Error::InvalidOption`] for bad periods.
pub fn iv_multirate_fast(
    u: &DMatrix<f64>,
    y: &DMatrix<f64>,
    f: &DMatrix<f64>,
    periods: &[usize],
    opts: &MultirateIvOptions,
) -> Result<IvModel> {
    let (nn, nu, ny) = (u.nrows(), u.ncols(), y.ncols());
    check_ts(opts.ts)?;
    if periods.len() != ny || y.nrows() != nn || f.shape() != u.shape() || nu == 0 {
        return Err(Error::DimensionMismatch {
            what: "multirate data",
            expected: format!(
                "y N×{} with one period per output, f {nn}x{nu}",
                periods.len()
            ),
            got: format!("y {}x{}, f {}x{}", y.nrows(), ny, f.nrows(), f.ncols()),
        });
    }
    let n_lift = periods.iter().cloned().max().unwrap_or(0);
    if periods.contains(&0) || periods.iter().any(|&p| n_lift % p != 0) || !periods.contains(&1) {
        return Err(Error::InvalidOption {
            what: "periods",
            reason: format!(
                "need positive periods dividing the largest one and at least one fast output, got {periods:?}"
            ),
        });
    }
    check_data("u", u)?;
    check_data("f", f)?;
    let mut y_fast = y.clone();
    for o in 0..ny {
        for t in 0..nn {
            if t.is_multiple_of(periods[o]) {
                if !y[(t, o)].is_finite() {
                    return Err(Error::NonFinite {
                        what: "y",
                        row: t,
                        col: o,
                    });
                }
            } else {
                y_fast[(t, o)] = f64::NAN;
            }
        }
    }
    // Lifting (time-interleaved).
    let kk = nn / n_lift;
    let sampled_at = |r: usize| (0..ny).filter(move |&o| r.is_multiple_of(periods[o]));
    let nyl: usize = (0..n_lift).map(|r| sampled_at(r).count()).sum();
    let ul = DMatrix::from_fn(kk, n_lift * nu, |k, c| u[(k * n_lift + c / nu, c % nu)]);
    let fl = DMatrix::from_fn(kk, n_lift * nu, |k, c| f[(k * n_lift + c / nu, c % nu)]);
    let mut yl = DMatrix::zeros(kk, nyl);
    for k in 0..kk {
        let mut c = 0;
        for r in 0..n_lift {
            for o in sampled_at(r) {
                yl[(k, c)] = y[(k * n_lift + r, o)];
                c += 1;
            }
        }
    }
    let alpha = opts.alpha;
    let alpha_p = opts.alpha_p.unwrap_or(alpha.saturating_mul(2));
    check_horizons(alpha, alpha_p)?;
    check_order(
        opts.order,
        OrderCriterion::Gap,
        (alpha - 1).saturating_mul(nyl),
    )?;
    let scale = Scale {
        u: pow4_scale(&[&ul]),
        y: pow4_scale(&[&yl]),
    };
    let z_scale = pow4_scale(&[&fl]);
    let sub = iv_subspace(&[(&ul, &yl, &fl)], alpha, alpha_p, scale, z_scale)?;
    let cap = candidate_orders(opts.order, (alpha - 1) * nyl).min(sub.s.len());
    let order_selection = OrderReport::new(OrderCriterion::Gap, gap_values(&sub.s, cap));
    let nx = match opts.order {
        OrderSelection::Fixed(n) => n,
        OrderSelection::Gap { .. } => order_selection.selected,
    };
    sub.check(nx, alpha, nyl)?;
    let gamma = sub.gamma(nx);
    // Rows of the fast outputs: C_F A^t, t = b n + r.
    let fast: Vec<usize> = (0..ny).filter(|&o| periods[o] == 1).collect();
    let nf = fast.len();
    let mut offset = vec![0; n_lift];
    for r in 1..n_lift {
        offset[r] = offset[r - 1] + sampled_at(r - 1).count();
    }
    let steps = n_lift * alpha;
    let mut gfast = DMatrix::zeros(steps * nf, nx);
    for t in 0..steps {
        let (b, r) = (t / n_lift, t % n_lift);
        for (i, &o) in fast.iter().enumerate() {
            let pos = sampled_at(r).position(|q| q == o).unwrap_or(0);
            let src = b * nyl + offset[r] + pos;
            gfast.row_mut(t * nf + i).copy_from(&gamma.row(src));
        }
    }
    let g_r = gfast.rows(0, (steps - 1) * nf).into_owned();
    let g_l = gfast.rows(nf, (steps - 1) * nf).into_owned();
    // Γ of the scaled data is Γ/√(s_y s_z) (exact: s_y s_z is a power of 4).
    let gamma_unit = (scale.y * z_scale).sqrt();
    let sv: Vec<f64> = lifted_linalg::singular_values(&g_r)?
        .iter()
        .map(|v| v * gamma_unit)
        .collect();
    check_rank(
        "Γ_R of eq. 7.27 ((C₂, A) not observable; erratum L-18)",
        numerical_rank(&g_r, opts.rank_tol)?,
        nx,
    )?;
    let a = lstsq(&g_r, &g_l)?;
    let c = gamma.rows(0, ny) * scale.y;
    if opts.require_stable {
        let rho = spectral_radius(&a)?;
        if rho >= 1.0 {
            return Err(Error::Unstable {
                spectral_radius: rho,
            });
        }
    }
    let rec = [Record {
        u,
        y: &y_fast,
        instrument: Some(f),
    }];
    let bd = estimate_bd_iv(&a, &c, &rec, &opts.feedthrough, opts.initial_state)?;
    Ok(IvModel {
        model: StateSpace::new(a, bd.b, c, bd.d, Some(opts.ts))?,
        x0: bd.x0,
        diagnostics: IvDiagnostics {
            singular_values: sub.s.iter().map(|v| v * scale.y * z_scale).collect(),
            order: nx,
            suggested_order: order_selection.selected,
            order_selection,
            horizons: (alpha, alpha_p),
            columns: sub.columns,
            stabilized: false,
            gamma_r_singular_values: sv,
            bd_fallback: None,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The search from the longest record gives the α of the search from
    /// any larger bound (every α up to 2e4 tried one by one here), and a
    /// bound of 1e6 or more on records of hundreds of samples returns at
    /// once (the fuzz smoke's input: `--horizon 963001` on a multirate
    /// record, searched once per candidate order).
    #[test]
    fn the_longest_alpha_search_starts_at_the_longest_record() {
        for lengths in [vec![300], vec![100, 40], vec![7], vec![2, 3]] {
            for (widths, alpha_p) in [
                ((2, 2, 2), None),
                ((1, 1, 1), Some(40)),
                ((4, 2, 4), Some(3)),
            ] {
                let brute = (2..=20_000usize)
                    .rev()
                    .find(|&a| iv_fits(&lengths, widths, a, alpha_p.unwrap_or(2 * a)));
                assert_eq!(iv_longest_alpha(&lengths, widths, 20_000, alpha_p), brute);
                assert_eq!(
                    iv_longest_alpha(&lengths, widths, usize::MAX, alpha_p),
                    brute
                );
            }
        }
    }
}

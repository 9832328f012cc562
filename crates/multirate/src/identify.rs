//! Lifted identification with the causality-structured D̄ (thesis §4.5,
//! §5.2), the whole procedure of §4.7, and the closed-loop IV routes of
//! §7.5.
//!
//! * [`identify_lifted`]: the lifted data go through the subspace engine of
//!   `lifted-subspace` (N4SID/MOESP/CVA) with the causal mask of eq. (4.17)
//!   on D̄ ([`MultirateLifting::causal_mask`]); the engine regresses the
//!   estimated state sequences with only the allowed inputs per output row
//!   (the normal equations after thesis eq. 4.20), so the masked entries are
//!   structurally zero (spec pitfall 5).
//! * [`identify_multirate`]: §4.7 steps 1–5 — delay estimate (4.4),
//!   shift d_d = k₁m + k₂n (L-10), lifted identification, extraction
//!   (§4.6, default matrix root + LS for B, L-12), delay re-inserted.
//! * [`identify_lifted_iv`]: the two-step closed-loop route (spec A3.9,
//!   erratum L-18): lifted IV identification with lifted instruments and the
//!   causal mask, then extraction.
//! * [`identify_one_step_iv`]: the one-step fast model of eq. (7.27)
//!   (`lifted_subspace::iv_multirate_fast`), which needs (C₂, A_d)
//!   observable from the fast outputs and reports a rank-deficient Γ_R
//!   otherwise.

use lifted_linalg::spectral_radius;
use lifted_lti::{Dataset, StateSpace};
use lifted_subspace::{
    Experiment, Feedthrough, InitialState, IvExperiment, IvOptions, Method, MultirateIvOptions,
    OrderSelection, SubspaceOptions, SystemEstimate, identify, iv_identify, iv_multirate_fast,
};
use nalgebra::DMatrix;

use crate::delay::{
    DelayInterval, ImpulseEstimate, delay_interval, delay_matrix, lifted_fir_estimate,
    lifted_impulse_response, shift_dataset, shift_split,
};
use crate::error::{Error, Result};
use crate::extract::{ExtractOptions, ExtractionDiagnostics, extract_fast};
use crate::lifting::{LiftedData, MultirateLifting, Ordering, SisoRates};

/// Options of [`identify_lifted`].
#[derive(Debug, Clone, PartialEq)]
pub struct LiftedIdOptions {
    /// Subspace weighting. Default N4SID (the reference implementation's).
    pub method: Method,
    /// Lifted model order. Default `Gap { max: 10 }`.
    pub order: OrderSelection,
    /// Past horizon (lifted block rows). Default 10.
    pub past: usize,
    /// Future horizon (lifted block rows). Default 10.
    pub future: usize,
    /// The fast model is strictly proper (residual delay in (0, 1] or
    /// D = 0): D̄_ij = 0 when input slot time ≥ output time (eq. 4.17).
    /// Otherwise entries with input time = output time are free too.
    /// Default true.
    pub strictly_proper: bool,
    /// Initial-state handling in the (B̄, D̄) regression. Default estimate.
    pub initial_state: InitialState,
    /// Return [`Error::Unstable`] when the lifted A has an eigenvalue of
    /// modulus ≥ 1 (spec A3.9: an unstable estimate is an error, not a
    /// model). Default true.
    pub require_stable: bool,
    /// Route from the lifted subspace to (Ā, C̄). Default
    /// [`SystemEstimate::ShiftInvariance`] (consistent; the state-sequence
    /// route was the default before 2026-11-25).
    pub system: SystemEstimate,
    /// Re-estimate an unstable lifted Ā by the zero-padded shift
    /// (`lifted_subspace::SubspaceOptions::enforce_stability`: Maciejowski's
    /// stabilised shift invariance), so the lifted and extracted fast models
    /// are stable. Default false.
    pub enforce_stability: bool,
}

impl Default for LiftedIdOptions {
    fn default() -> Self {
        LiftedIdOptions {
            method: Method::N4sid,
            order: OrderSelection::Gap { max: 10 },
            past: 10,
            future: 10,
            strictly_proper: true,
            initial_state: InitialState::Estimate,
            require_stable: true,
            system: SystemEstimate::ShiftInvariance,
            enforce_stability: false,
        }
    }
}

/// A lifted model identified from lifted data.
#[derive(Debug, Clone, PartialEq)]
pub struct LiftedFit {
    /// (Ā, B̄, C̄, D̄) at the lifted period JT, D̄ causal.
    pub model: StateSpace,
    /// The causal mask used.
    pub mask: DMatrix<bool>,
    /// Singular values of the subspace step, descending.
    pub singular_values: Vec<f64>,
}

fn check_stable(model: &StateSpace, what: &'static str, require: bool) -> Result<()> {
    if require && model.order() > 0 {
        let r = spectral_radius(model.a())?;
        if r >= 1.0 {
            return Err(Error::Unstable {
                what,
                spectral_radius: r,
            });
        }
    }
    Ok(())
}

/// Identifies the lifted model from lifted data with the causal D̄ (§4.5).
/// Cost: that of `lifted_subspace::identify` on K frames with n̲_u, n̲_y
/// channels. Errors: the subspace crate's (too short, order too large,
/// not exciting), [`Error::Unstable`] with `require_stable`.
pub fn identify_lifted(data: &LiftedData, opts: &LiftedIdOptions) -> Result<LiftedFit> {
    let mask = data.lifting.causal_mask(opts.strictly_proper);
    let sopts = SubspaceOptions {
        method: opts.method,
        order: opts.order,
        past: opts.past,
        future: opts.future,
        feedthrough: Feedthrough::Mask(mask.clone()),
        initial_state: opts.initial_state,
        noise_model: false,
        enforce_stability: opts.enforce_stability,
        system: opts.system,
        ts: data.ts,
        ..Default::default()
    };
    let fit = identify(
        &[Experiment {
            u: &data.u,
            y: &data.y,
        }],
        &sopts,
    )?;
    check_stable(&fit.model, "identified lifted model", opts.require_stable)?;
    Ok(LiftedFit {
        model: fit.model,
        mask,
        singular_values: fit.diagnostics.singular_values,
    })
}

/// How §4.7 treats the time delay.
#[derive(Debug, Clone, PartialEq)]
pub enum DelayHandling {
    /// No shift (the residual delay is known to be ≤ T).
    None,
    /// Shift by a known d_d (base periods).
    Known(i64),
    /// Estimate from a delay experiment (§4.4): lifted impulse response with
    /// `lags` coefficients, significance `sigmas` standard errors.
    Estimate {
        /// Lifted lags searched.
        lags: usize,
        /// Threshold in standard errors (reference: 3).
        sigmas: f64,
    },
}

/// Options of [`identify_multirate`].
#[derive(Debug, Clone, PartialEq)]
pub struct ProcedureOptions {
    /// Delay step. Default [`DelayHandling::None`] (MIMO, Ch. 5).
    pub delay: DelayHandling,
    /// Lifted identification. Default [`LiftedIdOptions::default`].
    pub identification: LiftedIdOptions,
    /// Extraction. Default matrix root + LS for B (L-12).
    pub extraction: ExtractOptions,
    /// Column order of the lifted data. Default channel-major.
    pub ordering: Ordering,
    /// Drop an incomplete last frame instead of failing. Default true.
    pub truncate: bool,
    /// Return [`Error::Unstable`] for an unstable fast model. Default true.
    pub require_stable: bool,
}

impl Default for ProcedureOptions {
    fn default() -> Self {
        ProcedureOptions {
            delay: DelayHandling::None,
            identification: LiftedIdOptions::default(),
            extraction: ExtractOptions::default(),
            ordering: Ordering::ChannelMajor,
            truncate: true,
            require_stable: true,
        }
    }
}

/// The result of the procedure of §4.7.
#[derive(Debug, Clone, PartialEq)]
pub struct MultirateModel {
    /// Fast model at the hold period hT, **without** the estimated delay
    /// (the residual delay lies in [0, 1) base periods).
    pub fast: StateSpace,
    /// Integer delay d_d in base periods (0 without a delay step).
    pub delay: i64,
    /// The delay interval of step 1, when estimated.
    pub delay_interval: Option<DelayInterval>,
    /// (k₁, k₂) with d_d = k₁m + k₂n (input delayed k₁ holds, output
    /// advanced k₂ samples, L-10).
    pub shift: (i64, i64),
    /// The identified lifted model (of the shifted data).
    pub lifted: LiftedFit,
    /// The lifting used.
    pub lifting: MultirateLifting,
    /// Extraction diagnostics.
    pub extraction: ExtractionDiagnostics,
}

impl MultirateModel {
    /// Step 5 of §4.7: the fast model with the delay re-inserted as
    /// z^{−d_d/h} at the hold period hT. Possible only when h divides d_d
    /// (L-10); otherwise [`Error::Unsupported`] — compare at output instants
    /// with the shifts instead.
    pub fn fast_with_delay(&self) -> Result<StateSpace> {
        let h = self.lifting.holds()[0] as i64;
        if self.delay < 0 || self.delay % h != 0 {
            return Err(Error::Unsupported {
                what: "re-inserting the delay",
                reason: format!(
                    "d_d = {} is not a non-negative multiple of the hold {h} (erratum L-10)",
                    self.delay
                ),
            });
        }
        let d = (self.delay / h) as usize;
        Ok(self
            .fast
            .with_io_delays(&vec![d; self.fast.n_inputs()], &[])?)
    }
}

fn siso_rates(data: &Dataset) -> Result<SisoRates> {
    if data.n_inputs() != 1 || data.n_outputs() != 1 {
        return Err(Error::Unsupported {
            what: "delay estimation (§4.4)",
            reason: "SISO data needed (thesis §5.2.2 assumes delays ≤ T for MIMO)".into(),
        });
    }
    SisoRates::new(data.inputs()[0].hold, data.outputs()[0].period)
}

/// Step 1 of §4.7 on a delay experiment (white lifted input): the delay
/// interval [d_d, d_d + 1).
pub fn estimate_delay(data: &Dataset, lags: usize, sigmas: f64) -> Result<DelayInterval> {
    let rates = siso_rates(data)?;
    let l = MultirateLifting::siso(rates)?;
    let ld = l.lift_dataset(data, true)?;
    let est = lifted_impulse_response(&ld.u, &ld.y, lags)?;
    let lm = delay_matrix(&est, sigmas)?;
    delay_interval(&lm, rates)
}

/// The delay interval of one input-output pair of a MIMO record
/// ([`estimate_delays`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PairDelay {
    /// Input channel index.
    pub input: usize,
    /// Output channel index.
    pub output: usize,
    /// The input's hold m (base periods).
    pub hold: usize,
    /// The output's sampling period n (base periods).
    pub period: usize,
    /// d_c ∈ [lower, upper) in base periods, when the pair gave one.
    pub interval: Option<DelayInterval>,
    /// Why the pair gave no interval (no significant lag, inconsistent
    /// bounds, rates not co-prime, …).
    pub failure: Option<String>,
}

/// Thesis §4.4 for every input-output pair of a MIMO record. For pair
/// (y_i, u_j) the record is lifted over the frame of the input's hold m and
/// the output's period n; the lifted impulse response is estimated by
/// joint least squares over `lags` lifted lags ([`crate::lifted_fir_estimate`])
/// with **all inputs of the same hold as regressors** (so neither the other
/// lags nor the other inputs act as noise on the pair; inputs of another
/// hold are left out and do), significance `sigmas` residual standard
/// errors, and the inequalities (4.14) of the pair's m×n block intersected.
/// The inputs should be mutually uncorrelated (independent PRBS/GBN/white
/// lifted inputs). A pair that gives no interval is reported with the
/// reason instead of failing the whole call. Cost per pair O(N L (n n_u)²).
///
/// Errors: [`Error::Unsupported`] for a record without inputs or outputs.
pub fn estimate_delays(data: &Dataset, lags: usize, sigmas: f64) -> Result<Vec<PairDelay>> {
    if data.n_inputs() == 0 || data.n_outputs() == 0 {
        return Err(Error::Unsupported {
            what: "delay estimation",
            reason: "at least one input and one output are needed".into(),
        });
    }
    let mut out = Vec::with_capacity(data.n_inputs() * data.n_outputs());
    for i in 0..data.n_outputs() {
        for j in 0..data.n_inputs() {
            let (hold, period) = (data.inputs()[j].hold, data.outputs()[i].period);
            let (interval, failure) = match pair_delay(data, i, j, lags, sigmas) {
                Ok(iv) => (Some(iv), None),
                Err(e) => (None, Some(e.to_string())),
            };
            out.push(PairDelay {
                input: j,
                output: i,
                hold,
                period,
                interval,
                failure,
            });
        }
    }
    Ok(out)
}

/// The delay interval of pair (y_i, u_j) with the same-hold inputs as
/// joint regressors ([`estimate_delays`]).
fn pair_delay(
    data: &Dataset,
    i: usize,
    j: usize,
    lags: usize,
    sigmas: f64,
) -> Result<DelayInterval> {
    let hold = data.inputs()[j].hold;
    let rates = SisoRates::new(hold, data.outputs()[i].period)?;
    let lifting = MultirateLifting::siso(rates)?;
    // The pair's input first, then the other inputs with the same hold.
    let order: Vec<usize> = std::iter::once(j)
        .chain((0..data.n_inputs()).filter(|&k| k != j && data.inputs()[k].hold == hold))
        .collect();
    let mut lifted_u: Vec<DMatrix<f64>> = Vec::new();
    let mut lifted_y = None;
    for &k in &order {
        let siso = Dataset::new(
            data.ts(),
            data.u().columns(k, 1).into_owned(),
            data.y().columns(i, 1).into_owned(),
            vec![data.inputs()[k].clone()],
            vec![data.outputs()[i].clone()],
        )?;
        let ld = lifting.lift_dataset(&siso, true)?;
        lifted_y.get_or_insert(ld.y);
        lifted_u.push(ld.u);
    }
    let yl = lifted_y.ok_or(Error::Unsupported {
        what: "delay estimation",
        reason: "no input".into(),
    })?;
    let width: usize = lifted_u.iter().map(|m| m.ncols()).sum();
    let mut ul = DMatrix::zeros(yl.nrows(), width);
    let mut c = 0;
    for m in &lifted_u {
        ul.columns_mut(c, m.ncols()).copy_from(m);
        c += m.ncols();
    }
    let est = lifted_fir_estimate(&ul, &yl, lags)?;
    let cols = lifted_u[0].ncols();
    let own = ImpulseEstimate {
        coefficients: est
            .coefficients
            .iter()
            .map(|p| p.columns(0, cols).into_owned())
            .collect(),
        std_error: est.std_error.columns(0, cols).into_owned(),
    };
    let lm = delay_matrix(&own, sigmas)?;
    delay_interval(&lm, rates)
}

/// The procedure of §4.7 as one call (see the [module docs](self)).
/// `delay_experiment` is the record for step 1 (a white lifted input, §4.8
/// experiment 1); `None` uses `data` itself.
///
/// Errors: those of each step; [`Error::Unsupported`] for a delay step on
/// non-SISO data; [`Error::Unstable`] per options.
pub fn identify_multirate(
    data: &Dataset,
    delay_experiment: Option<&Dataset>,
    opts: &ProcedureOptions,
) -> Result<MultirateModel> {
    let (delay, interval) = match &opts.delay {
        DelayHandling::None => (0, None),
        DelayHandling::Known(d) => (*d, None),
        DelayHandling::Estimate { lags, sigmas } => {
            let iv = estimate_delay(delay_experiment.unwrap_or(data), *lags, *sigmas)?;
            (iv.lower, Some(iv))
        }
    };
    let (shifted, shift) = if delay != 0 {
        let rates = siso_rates(data)?;
        let (k1, k2) = shift_split(delay, rates);
        (shift_dataset(data, rates, k1, k2)?, (k1, k2))
    } else {
        (data.clone(), (0, 0))
    };
    let lifting = MultirateLifting::from_dataset(&shifted, opts.ordering)?;
    let ld = lifting.lift_dataset(&shifted, opts.truncate)?;
    let lifted = identify_lifted(&ld, &opts.identification)?;
    let fm = extract_fast(&lifted.model, &lifting, &opts.extraction)?;
    check_stable(&fm.model, "extracted fast model", opts.require_stable)?;
    Ok(MultirateModel {
        fast: fm.model,
        delay,
        delay_interval: interval,
        shift,
        lifted,
        lifting,
        extraction: fm.diagnostics,
    })
}

/// Options of [`identify_lifted_iv`].
#[derive(Debug, Clone, PartialEq)]
pub struct LiftedIvOptions {
    /// Lifted order. Default `Gap { max: 10 }`.
    pub order: OrderSelection,
    /// α (lifted block rows). Default 6 (spec A3.9).
    pub alpha: usize,
    /// α_p; None = 2α (erratum L-16).
    pub alpha_p: Option<usize>,
    /// Strictly proper fast model (causal mask, eq. 4.17). Default true.
    pub strictly_proper: bool,
    /// Extraction options. Default matrix root + LS for B.
    pub extraction: ExtractOptions,
    /// Unstable lifted or fast model is [`Error::Unstable`]. Default true.
    pub require_stable: bool,
    /// Re-estimate an unstable lifted Ā by the zero-padded shift
    /// Ā = Γ⁺[Γ↓; 0] (Maciejowski's stabilised shift invariance, as
    /// `lifted_subspace::IvOptions::enforce_stability`), whose eigenvalues lie
    /// inside the unit circle; the fast model is then extracted from the
    /// stable Ā. Default false (the thesis' estimate).
    pub enforce_stability: bool,
}

impl Default for LiftedIvOptions {
    fn default() -> Self {
        LiftedIvOptions {
            order: OrderSelection::Gap { max: 10 },
            alpha: 6,
            alpha_p: None,
            strictly_proper: true,
            extraction: ExtractOptions::default(),
            require_stable: true,
            enforce_stability: false,
        }
    }
}

/// Result of [`identify_lifted_iv`].
#[derive(Debug, Clone, PartialEq)]
pub struct LiftedIvModel {
    /// Lifted model (IV, causal D̄).
    pub lifted: StateSpace,
    /// Extracted fast model at period hT.
    pub fast: StateSpace,
    /// Extraction diagnostics.
    pub extraction: ExtractionDiagnostics,
    /// Singular values of R₂₂ (IV step).
    pub singular_values: Vec<f64>,
    /// True when the lifted Ā was re-estimated by the zero-padded shift
    /// ([`LiftedIvOptions::enforce_stability`]) because the unconstrained
    /// estimate was unstable.
    pub stabilized: bool,
    /// Why (B̄, D̄) and Ā came from the one-step predictor regression
    /// instead of the IV regression (an Ā too unstable for an output-error
    /// regression over the record: `lifted_subspace::IvDiagnostics::bd_fallback`);
    /// `None` otherwise.
    pub bd_fallback: Option<String>,
}

/// The two-step closed-loop multirate route (spec A3.9, L-18): lift the
/// data and the instrument f (same shape as u: the external excitation of
/// each input channel, e.g. [u₁, f] when u₁ is open loop and f is the
/// set-point dither of u₂'s loop) with `data`'s pattern, identify the lifted
/// model by IV (`lifted_subspace::iv_identify`) with the causal mask, then
/// extract the fast model.
///
/// Accuracy. With lifted instruments Z (α_p past frames of f̲) the IV
/// subspace is that of R₂₂ = Γ̄ X̄ Zᵀ Q₂/J (eq. 7.22): only the part of
/// the lifted state that the instrument explains, and across frames the
/// lifted state carries it only through Ā = A^J. A long lifting period
/// makes Ā small (J = 15 and fast poles 0.85–0.92: ρ(Ā) = 0.29), so some
/// directions of Γ̄ X̄ Zᵀ lie near the finite-sample noise floor of R₂₂:
/// on the 2×2 closed loop of issue 46 (outputs every 3 and 5 samples,
/// slow set-points as f, coloured noise of 9 % of the outputs, 6e4
/// samples) σ₃, σ₄ of R₂₂ were 1.5–2× σ₅ and the fast models 0.20–0.30
/// from the plant in frequency response (six records), against 0.07–0.22
/// on five of six records of a SISO loop lifted by 4 (ρ(Ā) = 0.66; 0.79
/// on the sixth). Such an estimate is a start for a
/// prediction-error refinement on the fast grid (the workflow's route),
/// not an end. An Ā estimated unstable is [`Error::Unstable`] with
/// `require_stable`; without it the model is returned, re-estimated by
/// the zero-padded shift with `enforce_stability`
/// ([`LiftedIvModel::stabilized`]), or with (B̄, D̄) and Ā from the
/// one-step predictor regression when the IV regression over the record
/// cannot be computed ([`LiftedIvModel::bd_fallback`]).
pub fn identify_lifted_iv(
    data: &Dataset,
    instrument: &DMatrix<f64>,
    ordering: Ordering,
    opts: &LiftedIvOptions,
) -> Result<LiftedIvModel> {
    if instrument.shape() != data.u().shape() {
        return Err(Error::DimensionMismatch {
            what: "instrument",
            expected: format!("{}x{}", data.len(), data.n_inputs()),
            got: format!("{}x{}", instrument.nrows(), instrument.ncols()),
        });
    }
    let lifting = MultirateLifting::from_dataset(data, ordering)?;
    let ld = lifting.lift_dataset(data, true)?;
    let keep = ld.u.nrows() * lifting.period();
    let fl = lifting.lift_inputs(&instrument.rows(0, keep).into_owned())?;
    let mask = lifting.causal_mask(opts.strictly_proper);
    let iopts = IvOptions {
        order: opts.order,
        alpha: opts.alpha,
        alpha_p: opts.alpha_p,
        feedthrough: Feedthrough::Mask(mask),
        // checked before the (B̄, D̄) regression, whose regressors explode
        // for an unstable Ā
        require_stable: opts.require_stable,
        enforce_stability: opts.enforce_stability,
        ts: ld.ts,
        ..Default::default()
    };
    let fit = iv_identify(
        &[IvExperiment {
            u: &ld.u,
            y: &ld.y,
            instrument: Some(&fl),
        }],
        &iopts,
    )
    .map_err(|e| match e {
        lifted_subspace::Error::Unstable { spectral_radius } => Error::Unstable {
            what: "identified lifted model",
            spectral_radius,
        },
        other => other.into(),
    })?;
    check_stable(&fit.model, "identified lifted model", opts.require_stable)?;
    let fm = extract_fast(&fit.model, &lifting, &opts.extraction)?;
    check_stable(&fm.model, "extracted fast model", opts.require_stable)?;
    Ok(LiftedIvModel {
        lifted: fit.model,
        fast: fm.model,
        extraction: fm.diagnostics,
        singular_values: fit.diagnostics.singular_values,
        stabilized: fit.diagnostics.stabilized,
        bd_fallback: fit.diagnostics.bd_fallback,
    })
}

/// The one-step route of §7.5 (eq. 7.27) on a data set whose inputs are
/// all held T and whose output periods divide the largest one:
/// `lifted_subspace::iv_multirate_fast` with the data set's periods.
/// Errors: in particular `lifted_subspace::Error::RankDeficient` (wrapped)
/// when (C₂, A_d) is not observable from the fast outputs (L-18).
pub fn identify_one_step_iv(
    data: &Dataset,
    instrument: &DMatrix<f64>,
    opts: &MultirateIvOptions,
) -> Result<lifted_subspace::IvModel> {
    if data.inputs().iter().any(|c| c.hold != 1) {
        return Err(Error::Unsupported {
            what: "one-step multirate IV (7.27)",
            reason: "all inputs must be held one base period".into(),
        });
    }
    let periods: Vec<usize> = data.outputs().iter().map(|c| c.period).collect();
    Ok(iv_multirate_fast(
        data.u(),
        data.y(),
        instrument,
        &periods,
        opts,
    )?)
}

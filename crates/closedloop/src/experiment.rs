//! Data-level pipeline: closed-loop PRBS experiments (spec A2.3), identification
//! of Ĥ₁ / Ĥ₂ with any [`Identifier`] (q-Markov Cover, subspace, …) and recovery
//! of the plant (eqs. 10–12).
//!
//! Each excited channel gets its own experiment (the q-Markov Cover merges
//! separate single-channel experiments into one model, Zhu 2000 eq. III-22):
//! r₁ channel i alone, r₂ channel j alone. For the general set-up the r₁ and r₂
//! experiments are merged into one joint model [Ĥ₁ Ĥ₂] (inputs [r₁; r₂]), whose
//! columns share one state and one denominator.

use lifted_lti::{C2dOptions, Dataset, Identified, Identifier, StateSpace};
use lifted_prbs::{InversePrbs, InversePrbsOptions};
use lifted_sim::{Excitation, Simulator};
use nalgebra::DMatrix;

use crate::error::{Error, Result, dims};
use crate::recover::{self, RecoveryOptions, Setup};

/// Options of [`run_experiment`] (defaults from Ren & Zhu 2009 Table 4 and
/// spec A2.3).
#[derive(Debug, Clone, PartialEq)]
pub struct ExperimentOptions {
    /// PRBS order n, m = 2ⁿ − 1 (eq. 1, Table 4 "PRBS order"). Default 8.
    pub prbs_order: u32,
    /// PRBS magnitude a (eq. 4). Default 1.0 (§4).
    pub amplitude: f64,
    /// Periods 2m of the inverse PRBS simulated from rest; the identifier uses
    /// the last (steady-state) one (Table 4 "signal length" ≈ 10 periods,
    /// erratum RZ-4). Default 10.
    pub periods: usize,
    /// Feedback taps of the m-sequence; `None` (default) uses Table 1.
    pub taps: Option<Vec<u32>>,
}

impl Default for ExperimentOptions {
    fn default() -> Self {
        Self {
            prbs_order: 8,
            amplitude: 1.0,
            periods: 10,
            taps: None,
        }
    }
}

/// Closed-loop experiments: one data set per excited channel. Each data set's
/// inputs are the excitation signals (r₁: n_y columns, r₂: n_u columns, only
/// the excited one nonzero) and its outputs the plant outputs y.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ClosedLoopData {
    /// Experiments exciting r₁ channel i alone (i = 0…n_y−1).
    pub r1: Vec<Dataset>,
    /// Experiments exciting r₂ channel j alone (j = 0…n_u−1).
    pub r2: Vec<Dataset>,
}

impl ClosedLoopData {
    /// The experiments the set-up identifies from, validated: general → the r₁
    /// and r₂ experiments with inputs [r₁; r₂] (zero-padded), controller → the
    /// r₁ experiments, compensator → the r₂ experiments.
    ///
    /// Errors: [`Error::MissingExcitation`] (no or too few experiments for a
    /// needed channel), [`Error::DimensionMismatch`] (inconsistent columns).
    pub fn experiments(&self, setup: Setup) -> Result<Vec<Dataset>> {
        let ny = self
            .r1
            .first()
            .or(self.r2.first())
            .map(Dataset::n_outputs)
            .unwrap_or(0);
        let need = |channel: &'static str,
                    sets: &[Dataset],
                    width: Option<usize>|
         -> Result<usize> {
            let Some(first) = sets.first() else {
                return Err(Error::MissingExcitation {
                    setup,
                    channel,
                    reason: format!("the data hold no {channel} experiment"),
                });
            };
            let n = width.unwrap_or(first.n_inputs());
            if sets.len() != n {
                return Err(Error::MissingExcitation {
                    setup,
                    channel,
                    reason: format!(
                        "{} {channel} experiment(s) for {n} {channel} channel(s): one per channel is needed",
                        sets.len()
                    ),
                });
            }
            for e in sets {
                if e.n_inputs() != n {
                    return Err(dims("excitation columns per experiment", n, e.n_inputs()));
                }
                if e.n_outputs() != ny {
                    return Err(dims("outputs per experiment", ny, e.n_outputs()));
                }
            }
            Ok(n)
        };
        match setup {
            Setup::Controller => {
                need("r1", &self.r1, Some(ny))?;
                Ok(self.r1.clone())
            }
            Setup::Compensator => {
                need("r2", &self.r2, None)?;
                Ok(self.r2.clone())
            }
            Setup::General => {
                need("r1", &self.r1, Some(ny))?;
                let nu = need("r2", &self.r2, None)?;
                let mut out = Vec::with_capacity(ny + nu);
                for e in &self.r1 {
                    out.push(pad(e, 0, ny + nu)?);
                }
                for e in &self.r2 {
                    out.push(pad(e, ny, ny + nu)?);
                }
                Ok(out)
            }
        }
    }
}

/// Places the inputs of `e` at columns `offset…` of a zero matrix with `width`
/// columns.
fn pad(e: &Dataset, offset: usize, width: usize) -> Result<Dataset> {
    let n = e.len();
    let mut u = DMatrix::zeros(n, width);
    u.view_mut((0, offset), (n, e.n_inputs())).copy_from(e.u());
    Ok(Dataset::single_rate(e.ts(), u, e.y().clone())?)
}

/// Runs the closed-loop PRBS experiments the set-up needs on a closed-loop
/// simulator (a whole loop discretised at once, spec A2.3, or plant +
/// discrete controller): an inverse PRBS of order n, generated every sample
/// (n_r = 1), `periods` periods from rest at each needed r₁ / r₂ channel in
/// turn (the general set-up runs both).
///
/// Errors: invalid options, simulation errors. O(periods·2m·n²) per channel.
pub fn run_experiment(
    sim: &Simulator,
    setup: Setup,
    opts: &ExperimentOptions,
) -> Result<ClosedLoopData> {
    if opts.periods == 0 {
        return Err(Error::InvalidArgument {
            what: "periods",
            reason: "at least one period is needed".into(),
        });
    }
    let prbs = InversePrbs::new(&InversePrbsOptions {
        order: opts.prbs_order,
        amplitude: opts.amplitude,
        hold: 1,
        taps: opts.taps.clone(),
    })?;
    let len = opts.periods * prbs.period() as usize;
    let w = prbs.generate(len);
    let (ny, nu) = (sim.n_outputs(), sim.n_inputs());
    let one = |channel: usize, width: usize, at_r1: bool| -> Result<Dataset> {
        let mut r = DMatrix::zeros(len, width);
        r.set_column(channel, &nalgebra::DVector::from_column_slice(&w));
        let exc = if at_r1 {
            Excitation::reference(r.clone())
        } else {
            Excitation::input(r.clone())
        };
        let out = sim.simulate(&exc)?;
        Ok(Dataset::single_rate(sim.ts(), r, out.y)?)
    };
    let mut data = ClosedLoopData::default();
    if setup.needs_r1() {
        for i in 0..ny {
            data.r1.push(one(i, ny, true)?);
        }
    }
    if setup.needs_r2() {
        for j in 0..nu {
            data.r2.push(one(j, nu, false)?);
        }
    }
    Ok(data)
}

/// Where the plant is solved for (Ren & Zhu §4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Approach {
    /// (a): solve eqs. (10)–(12) in discrete time (K discretised by ZOH if it
    /// is continuous), then convert the plant by the inverse ZOH.
    Discrete,
    /// (b): convert the identified closed loop to continuous time first (exact
    /// inverse ZOH), then solve in continuous time (K made continuous by the
    /// inverse ZOH if it is discrete). Default, as in the paper.
    #[default]
    Continuous,
}

/// Options of [`estimate_plant`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PlantOptions {
    /// Approach (a) or (b). Default [`Approach::Continuous`] (b).
    pub approach: Approach,
    /// Minimal realisation of the recovered plant. Default as
    /// [`RecoveryOptions::default`].
    pub recovery: RecoveryOptions,
}

/// A plant recovered from closed-loop data.
#[derive(Debug, Clone, PartialEq)]
pub struct PlantEstimate<D> {
    /// The set-up used.
    pub setup: Setup,
    /// The identified discrete closed loop: [Ĥ₁ Ĥ₂] (general), Ĥ₁
    /// (controller) or Ĥ₂ (compensator).
    pub closed_loop: StateSpace,
    /// The closed loop in the domain where the plant was solved for
    /// (continuous for approach (b)).
    pub closed_loop_solved: StateSpace,
    /// The recovered plant in continuous time (minimal realisation).
    pub plant: StateSpace,
    /// The recovered discrete plant (approach (a) only).
    pub plant_discrete: Option<StateSpace>,
    /// The identifier's diagnostics.
    pub diagnostics: D,
}

/// Identifies the closed loop of `setup` with `identifier` (e.g.
/// `lifted_qmarkov::QMarkov`, or a `lifted-subspace` method) from the
/// experiments of [`ClosedLoopData::experiments`].
///
/// Errors: [`Error::MissingExcitation`], [`Error::Identification`].
pub fn identify_closed_loop<I: Identifier>(
    identifier: &I,
    data: &ClosedLoopData,
    setup: Setup,
) -> Result<Identified<I::Diagnostics>> {
    let exps = data.experiments(setup)?;
    identifier
        .identify(&exps)
        .map_err(|e| Error::Identification {
            method: identifier.name(),
            source: Box::new(e),
        })
}

fn to_domain(k: &StateSpace, ts: Option<f64>) -> Result<StateSpace> {
    Ok(match (k.ts(), ts) {
        (Some(_), None) => k.d2c()?,
        (None, Some(t)) => k.c2d(t, &C2dOptions::default())?,
        _ => k.clone(),
    })
}

/// Recovers the plant from an identified closed loop of `setup` (the model
/// [`identify_closed_loop`] returns; general: inputs [r₁; r₂]).
///
/// Errors: [`Error::InvalidArgument`] (no K for the controller/compensator
/// set-up), the errors of [`recover`](crate::recover), d2c failures.
pub fn recover_plant(
    closed_loop: &StateSpace,
    setup: Setup,
    k: Option<&StateSpace>,
    opts: &PlantOptions,
) -> Result<(StateSpace, StateSpace, Option<StateSpace>)> {
    let h = match opts.approach {
        Approach::Continuous if closed_loop.is_discrete() => closed_loop.d2c()?,
        _ => closed_loop.clone(),
    };
    let g = match setup {
        Setup::General => recover::general_joint(&h, h.n_outputs(), &opts.recovery)?,
        Setup::Controller | Setup::Compensator => {
            let k = to_domain(k.ok_or_else(|| missing_k(setup))?, h.ts())?;
            if setup == Setup::Controller {
                recover::controller(&h, &k, &opts.recovery)?
            } else {
                recover::compensator(&h, &k, &opts.recovery)?
            }
        }
    };
    if g.is_discrete() {
        let gc = g.d2c()?;
        Ok((h, gc, Some(g)))
    } else {
        Ok((h, g, None))
    }
}

fn missing_k(setup: Setup) -> Error {
    Error::InvalidArgument {
        what: "controller",
        reason: format!("the {setup} set-up (eq. {}) needs K", setup.equation()),
    }
}

/// The whole data-level pipeline: identify the closed loop of `setup` from
/// `data` with `identifier`, then recover the plant (eqs. 10–12, approach per
/// `opts`), keeping the identifier's diagnostics.
///
/// Errors: those of [`identify_closed_loop`] and [`recover_plant`].
pub fn estimate_plant<I: Identifier>(
    identifier: &I,
    data: &ClosedLoopData,
    setup: Setup,
    k: Option<&StateSpace>,
    opts: &PlantOptions,
) -> Result<PlantEstimate<I::Diagnostics>> {
    if setup.needs_controller() && k.is_none() {
        return Err(missing_k(setup));
    }
    let id = identify_closed_loop(identifier, data, setup)?;
    let (solved, plant, plant_discrete) = recover_plant(&id.model, setup, k, opts)?;
    Ok(PlantEstimate {
        setup,
        closed_loop: id.model,
        closed_loop_solved: solved,
        plant,
        plant_discrete,
        diagnostics: id.diagnostics,
    })
}

//! The Kalman gain of a single-rate subspace model, checked on its records.
//!
//! The subspace step's K comes from the covariances of the state-sequence
//! residuals through a Riccati equation (`lifted_subspace`'s noise model).
//! On real records that gain can make the one-step predictions worse than
//! the simulation they should correct, on the very data it was estimated
//! from (the CD-player arm: one-step fits 69.6 / 69.5 % where the
//! simulation fits 77.7 / 85.8 %; `benches/results/real-records.md`, "A Kalman gain that
//! predicts"): an observer or MPC built on it would track worse than no
//! correction at all.
//!
//! The gain is therefore checked on the records, for the model's
//! (A, B, C, D) ([`check_kalman_gain`]). Three starts are scored by the
//! one-step prediction error on the records, the predictor started from the
//! state the simulation is fitted from (as `lifted_lti::validate` does, so
//! the cost is the one a validation reports):
//! - the subspace step's gain;
//! - a regression on VARX innovations, as SSARX and PARSIM-K finish
//!   (Jansson 2003; Qin, Lin & Ljung 2005): the innovations ê estimated by
//!   a high-order VARX of the records (order: the identification's past
//!   horizon), with which the innovations form is linear in K and x₀,
//!   y(t) − y_sim(t) − ê(t) = C Aᵗ x₀ + Σ_{j<t} C A^{t−1−j} K ê(j), so K
//!   comes from the output-error regression that gives (B, D, x₀)
//!   ([`crate::estimate_bd`] with ê as the input);
//! - K = 0, the output-error predictor (the simulation).
//!
//! Outputs not measured at an instant (NaN, multirate records) are
//! skipped: the predictor corrects with the outputs measured there (a
//! constant K applied at the measured samples), the costs sum over the
//! measured samples, and the VARX regression, which needs every sample, is
//! not tried.
//!
//! The best start whose predictor A − K C is stable is then refined over
//! K alone (the prediction-error method for the noise model with the
//! deterministic part fixed; every iterate's predictor stable), so the
//! one-step predictor is never worse than the simulation on the records.
//! With every output measured, the one-step errors of a gain are a filter
//! of those of the start, so the cost is first minimised through their
//! covariances by BFGS (module `error_covariance`, no pass over
//! the records per evaluation) and finished on the records by
//! quasi-Newton with BFGS's curvature and the exact gradient
//! ([`GainCheckOptions::covariance_start`]); otherwise, or when that ends
//! no lower than the start, by Levenberg–Marquardt on the records. [`GainCheck`] says what was done, with the
//! costs (the workflow's `diagnostics.kalman_gain_route`).
//!
//! Cost: the VARX least squares O(N (p n_z + n_u)²) (p lowered so that it
//! stays within [`VARX_WORK`]), the regression O(N n_y (n_y n³ + q²)), the
//! starts' predictor runs O(N n²); on the covariance route the
//! covariances O(N n_y² log N), at most 200 BFGS iterations of
//! O(L (n² n_y + n n_y²) + n³ log L) (L lags, independent of N) and at
//! most [`GainCheckOptions::max_iterations`] quasi-Newton iterations of a
//! predictor run and its adjoint, O(N (n² + n n_y + n n_u)) each;
//! otherwise at most [`GainCheckOptions::max_iterations`]
//! Levenberg–Marquardt iterations of O(N (n² + n n_y + n n_u)): a run of
//! the predictor for the trial's cost and, when it is accepted, the exact
//! gradient by the adjoint recursion backwards over that run's errors
//! (`one_step::OneStep::add_adjoint_gradient`); plus, for each R factor of
//! [J | r] folded (at the start, and again only where the factor's model
//! of the cost mispredicts a step: [`GainCheck::factors`]), the forward
//! sensitivities O(N n² n_y²) (their rows' own recursion,
//! `one_step::Sensitivities::Rows`; O(N n² P) for P = n n_y on records
//! with outputs not measured) and the fold O(N n_y P²). Memory
//! O(P² + N n_y).

use lifted_lti::StateSpace;

use crate::error_covariance::{Covariances, bfgs_update, positive_curvature};
use crate::estimated::Record;
use crate::estimated::{Feedthrough, InitialState};
use crate::model::Experiment;
use crate::one_step::{OneStep, Sensitivities};
use crate::regress::{estimate_bd, estimate_x0};
use lifted_linalg::spectral_radius;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// Largest VARX least-squares work (N (p n_z + n_u)² operations) of the
/// innovation estimate: about a second; a record that would need more
/// gets a shorter VARX.
pub const VARX_WORK: f64 = 4e9;

/// When the Levenberg–Marquardt iterations over K stop
/// ([`check_kalman_gain_memo`]). Recorded in the report
/// ([`GainCheck::stop`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct GainCheckOptions {
    /// Stop when an iteration lowers the cost by less than this share of
    /// the cost's own sampling spread, √(2/N_e) of it for N_e measured
    /// output samples (the relative standard deviation of a mean of N_e
    /// squared Gaussian errors). Default 0.01: a decrease of 1 % of what
    /// the records can tell apart. Derivation: the cost is a mean of
    /// squared one-step errors, so two gains whose costs differ by less
    /// than about √(2/N_e) of the cost are indistinguishable on these
    /// records; near the optimum the iterations of this large-residual
    /// problem converge linearly (measured ratios 0.6–0.7 on the peer
    /// records of the studio bench), so the decrease still to come after
    /// the stop is at most a few times the last one, 1–3 % of that
    /// spread: far below what a validation could show (on the studio
    /// bench's 2×2 record at N = 1e5, order 3, the stop comes after 10
    /// iterations instead of 30, the cost 3e-6 above the 30th iterate's,
    /// the one-step fits equal to 1e-4 %). 0 runs to
    /// [`GainCheckOptions::max_iterations`] or until a decrease below
    /// 1e-9 of the cost, the rule of before.
    pub stop_share: f64,
    /// Largest number of iterations (default 30).
    pub max_iterations: usize,
    /// Minimise first on the cost written exactly through the covariances
    /// of the start's one-step errors (module `error_covariance`: BFGS at
    /// no pass over the records), then finish on the records by
    /// quasi-Newton from its minimum; Levenberg–Marquardt from the start
    /// when that route cannot be taken (outputs not measured at some
    /// samples) or ends no lower than the start. Default true: a minimum
    /// of the same cost, reached with a few passes over the records
    /// instead of one Gauss–Newton factor of the N-row Jacobian per
    /// iteration or two, and lower than Levenberg–Marquardt's end on 159
    /// of 366 real-record cells, higher on 19 (`benches/results/studio.md`
    /// and `real-records.md`, session 30); false: the Levenberg–Marquardt
    /// iterations alone, as before.
    pub covariance_start: bool,
    /// Largest work (operations) of the VARX least squares whose
    /// innovations start the check (N (p n_z + n_u)² for N samples, past
    /// p, n_z = n_u + n_y): the longest VARX within it is fitted. Default
    /// [`VARX_WORK`], 4e9: about a second on one core of the benchmark
    /// machine (≈ 4e9 such operations a second measured). Finite, > 0.
    pub varx_work: f64,
    /// Largest work (operations) of the minimisation over K: the
    /// covariance route's Hessian and iterations, or Levenberg–Marquardt's
    /// predictor runs with their sensitivities (three at least); a check
    /// over it keeps the best start. Default [`MINIMISE_WORK`], 8e9: about
    /// two seconds. Finite, > 0.
    pub minimise_work: f64,
}

impl Default for GainCheckOptions {
    fn default() -> Self {
        GainCheckOptions {
            stop_share: 0.01,
            max_iterations: 30,
            covariance_start: true,
            varx_work: VARX_WORK,
            minimise_work: MINIMISE_WORK,
        }
    }
}

impl GainCheckOptions {
    /// `Err` naming the field when `stop_share` is negative or not
    /// finite, or a work budget is not finite and positive.
    pub fn check(&self) -> crate::Result<()> {
        if !(self.stop_share.is_finite() && self.stop_share >= 0.0) {
            return Err(crate::Error::InvalidOption {
                what: "gain check stop_share",
                reason: format!("must be finite and ≥ 0, got {}", self.stop_share),
            });
        }
        for (what, v) in [
            ("gain check varx_work", self.varx_work),
            ("gain check minimise_work", self.minimise_work),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(crate::Error::InvalidOption {
                    what,
                    reason: format!("must be finite and > 0, got {v}"),
                });
            }
        }
        Ok(())
    }

    /// The relative decrease below which the iterations stop on records
    /// of `samples` measured output samples (at least 1e-9).
    fn tolerance(&self, samples: usize) -> f64 {
        (self.stop_share * (2.0 / samples.max(1) as f64).sqrt()).max(1e-9)
    }
}

/// Where the minimisation over K stops: the relative decrease, the
/// iteration count and the work budget ([`GainCheckOptions`]).
#[derive(Debug, Clone, Copy)]
struct Limits {
    tolerance: f64,
    max_iterations: usize,
    work: f64,
}

/// Largest work of the Levenberg–Marquardt iterations over K (predictor
/// runs with their sensitivities and the folding of [J | r] into R,
/// N n_y (n² P + 2 P²) operations each): about two seconds. Records whose
/// three runs would exceed it keep the best start.
pub const MINIMISE_WORK: f64 = 8e9;

/// What [`check_kalman_gain`] did: the gain's route, the one-step costs of
/// the starts and of the gain kept (normalised squared one-step error, mean
/// over the outputs; `None`: no stable predictor or not computed).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GainCheck {
    /// How the gain kept was made.
    pub used: String,
    /// The start of the minimisation (the best of the three).
    pub start: Option<String>,
    /// The subspace step's gain's cost.
    pub riccati_cost: Option<f64>,
    /// The regression on VARX innovations' cost.
    pub regression_cost: Option<f64>,
    /// K = 0's cost (the simulation's).
    pub zero_cost: Option<f64>,
    /// The cost of the gain kept.
    pub final_cost: Option<f64>,
    /// Levenberg–Marquardt iterations.
    pub iterations: usize,
    /// The R factors of [J | r] folded by those iterations (at the start,
    /// then where a step from an earlier iterate's factor failed).
    #[serde(default)]
    pub factors: usize,
    /// BFGS iterations on the covariance form before the iterations on
    /// the records, when that route gave the gain
    /// ([`GainCheckOptions::covariance_start`]; `iterations` are then the
    /// quasi-Newton ones on the records and `factors` 0).
    #[serde(default)]
    pub covariance_iterations: Option<usize>,
    /// The VARX order of the innovation estimate.
    pub varx_order: Option<usize>,
    /// Why a step was not taken (no VARX, no minimisation), if so.
    pub note: Option<String>,
    /// The rule.
    pub rule: String,
    /// When the iterations stopped: the options and the relative decrease
    /// they gave on these records ([`GainCheckOptions`]).
    #[serde(default)]
    pub stop: Option<String>,
}

/// The Kalman gain to keep for `model` on `records` (deviations from the
/// model's operating point, no missing samples) and what was done
/// (module docs). `riccati`: the subspace step's gain; `past`: the
/// identification's past horizon (the VARX order). Three starts — the
/// subspace step's gain, the regression on VARX innovations and K = 0 (the
/// output-error predictor) — are scored by their one-step prediction error
/// on the records, and the best is refined by Levenberg–Marquardt over K,
/// A, B, C, D fixed, every iterate's predictor A − K C stable. Never
/// fails: when nothing can be computed, the subspace step's gain stays and
/// the report says why.
pub fn check_kalman_gain(
    model: &StateSpace,
    riccati: Option<&DMatrix<f64>>,
    records: &[Experiment<'_>],
    past: usize,
) -> (Option<DMatrix<f64>>, GainCheck) {
    check_kalman_gain_memo(
        model,
        riccati,
        records,
        past,
        &GainCheckOptions::default(),
        &mut VarxMemo::default(),
    )
}

/// The VARX innovations of the last [`MEMO_ENTRIES`] records seen by
/// [`check_kalman_gain_memo`], kept for later calls on the same records:
/// they depend on the records, the VARX order and whether u(t) is a
/// regressor, not on the model. A front end that checks the gain of an
/// order again on one record (the studio's order slider moved back)
/// computes them once. The records are known by their sizes and a hash of
/// every sample's bits: the deviations from a model's operating point,
/// whose output offset is estimated with (B, D, x₀), differ between
/// orders, so each order's records are their own entry.
#[derive(Debug, Clone, Default)]
pub struct VarxMemo {
    kept: Vec<KeptInnovations>,
    computed: usize,
    /// The records the innovations are estimated from, when the caller
    /// gave them ([`VarxMemo::set_source`]): their hash and their (u, y),
    /// each centred by its own means.
    source: Option<(u64, Vec<CentredRecord>)>,
}

/// Innovations kept by a [`VarxMemo`]: (records' hash, centred), VARX
/// order, u(t) among the regressors, the innovations per record.
type KeptInnovations = ((u64, bool), usize, bool, Vec<DMatrix<f64>>);

/// A record's (u, y), each column centred by its mean.
type CentredRecord = (DMatrix<f64>, DMatrix<f64>);

/// Records whose VARX innovations a [`VarxMemo`] keeps (the least recently
/// computed dropped first).
pub const MEMO_ENTRIES: usize = 8;

impl VarxMemo {
    /// VARX innovation estimates computed through this memo (a reuse
    /// computes none).
    pub fn computed(&self) -> usize {
        self.computed
    }

    /// The records the VARX innovations are estimated from in the next
    /// checks: `Some(records)`, each centred by its own means (the
    /// identification's records before its operating point is removed,
    /// the same for every model of them, so that every order of a record
    /// shares one innovation estimate); `None`: the records the check is
    /// given, as they are. Records of other lengths than the check's are
    /// not used. O(N (n_u + n_y)) when the records change.
    pub fn set_source(&mut self, records: Option<&[Experiment<'_>]>) {
        let hashed = records.map(|r| (r, records_hash(r)));
        self.set_source_hashed(hashed);
    }

    /// [`VarxMemo::set_source`] with the records' [`records_hash`] given
    /// (a caller that computed it already for its own cache): O(N (n_u +
    /// n_y)) only when the records change. The hash must be that of the
    /// records, or the memo may take another record's innovations.
    pub fn set_source_hashed(&mut self, records: Option<(&[Experiment<'_>], u64)>) {
        let Some((records, hash)) = records else {
            self.source = None;
            return;
        };
        if self.source.as_ref().is_some_and(|(h, _)| *h == hash) {
            return;
        }
        let centred = |m: &DMatrix<f64>| {
            let mut c = m.clone();
            for mut col in c.column_iter_mut() {
                let mean = col.mean();
                col.add_scalar_mut(-mean);
            }
            c
        };
        let copies = records
            .iter()
            .map(|e| (centred(e.u), centred(e.y)))
            .collect();
        self.source = Some((hash, copies));
    }
}

/// The records' sizes and every sample's bits, hashed: O(N (n_u + n_y)).
/// What tells records apart for the caches of front ends (the workflow's
/// compression cache, [`VarxMemo`]). Each column's bits are mixed in four
/// lanes (multiply–rotate, as the lanes of xxHash; about 1 ns a sample
/// where SipHash a value at a time took 5), the lanes and the sizes then
/// hashed by the standard library's SipHash. Not a defence against
/// records made to collide (the caches are a user's own), a check of
/// identity otherwise: any change of a sample's bits changes its lane.
pub fn records_hash(records: &[Experiment<'_>]) -> u64 {
    use std::hash::{Hash, Hasher};
    const PRIME: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for e in records {
        (e.u.nrows(), e.u.ncols(), e.y.ncols()).hash(&mut h);
        let mut lanes = [1u64, 2, 3, 4];
        for column in [e.u.as_slice(), e.y.as_slice()] {
            let mut chunks = column.chunks_exact(4);
            for chunk in &mut chunks {
                for (lane, v) in lanes.iter_mut().zip(chunk) {
                    *lane = (lane.rotate_left(31) ^ v.to_bits()).wrapping_mul(PRIME);
                }
            }
            lanes.hash(&mut h);
            for v in chunks.remainder() {
                v.to_bits().hash(&mut h);
            }
        }
    }
    h.finish()
}

/// [`check_kalman_gain`] with the VARX innovations taken from `memo` when
/// it holds those of the same records, VARX order and regressors (else
/// computed and kept there): the same gain and report bit for bit, the
/// VARX least squares (the check's largest cost on long records) once per
/// record instead of once per call.
pub fn check_kalman_gain_memo(
    model: &StateSpace,
    riccati: Option<&DMatrix<f64>>,
    records: &[Experiment<'_>],
    past: usize,
    opts: &GainCheckOptions,
    memo: &mut VarxMemo,
) -> (Option<DMatrix<f64>>, GainCheck) {
    check_by(model, riccati, records, past, opts, memo, None)
}

/// [`check_kalman_gain_memo`], the sensitivities by `route` when given
/// (else the rows' recursion on records with every output measured, the
/// states' otherwise: [`Sensitivities`]).
fn check_by(
    model: &StateSpace,
    riccati: Option<&DMatrix<f64>>,
    records: &[Experiment<'_>],
    past: usize,
    opts: &GainCheckOptions,
    memo: &mut VarxMemo,
    route: Option<Sensitivities>,
) -> (Option<DMatrix<f64>>, GainCheck) {
    let sets = records;
    let (n, ny) = (model.order(), model.n_outputs());
    let mut report = GainCheck {
        used: starts_name(riccati).into(),
        start: None,
        riccati_cost: None,
        regression_cost: None,
        zero_cost: None,
        final_cost: None,
        iterations: 0,
        factors: 0,
        covariance_iterations: None,
        varx_order: None,
        note: None,
        rule: RULE.into(),
        stop: None,
    };
    // NaN outputs are samples not measured (multirate records): the
    // predictor corrects with the outputs measured at each instant.
    if sets.is_empty()
        || sets
            .iter()
            .any(|d| d.y.iter().any(|v| v.is_infinite()) || d.u.iter().any(|v| !v.is_finite()))
    {
        report.note = Some("no check: records with non-finite values".into());
        return (riccati.cloned(), report);
    }
    let missing = sets.iter().any(|d| d.y.iter().any(|v| v.is_nan()));
    let x0s = match simulation_states(model, sets) {
        Ok(x) => x,
        Err(e) => {
            report.note = Some(format!("no check: {e}"));
            return (riccati.cloned(), report);
        }
    };
    let zero = DMatrix::zeros(n, ny);
    let spread = output_spread(sets, ny);
    // A start's cost ([`prediction_cost`], the same number bit for bit)
    // with its run's errors (the covariance route's reference).
    let runs = ExactRuns::new(model, sets, &x0s, &spread);
    let cost_of = |k: Option<&DMatrix<f64>>| {
        let (_, errors, _) = runs.run_at(&DVector::from_column_slice(k?.as_slice()))?;
        let cost = runs.final_cost(k?, Some(&errors)).ok()?;
        Some((cost, errors))
    };
    let regress = |memo: &mut VarxMemo| {
        if missing {
            Err("the records have output samples not measured".to_string())
        } else {
            regression_gain(model, sets, past, opts.varx_work, memo)
        }
    };
    // The subspace step's and K = 0's costs on a second thread while the
    // regression runs, for long records (the same numbers either way).
    let samples: usize = sets.iter().map(|d| d.u.nrows()).sum();
    let apart = samples >= PARALLEL_SAMPLES
        && std::thread::available_parallelism().map_or(1, |n| n.get()) > 1;
    let (regression, (riccati_cost, zero_cost)) = if apart {
        std::thread::scope(|scope| {
            let others = scope.spawn(|| (cost_of(riccati), cost_of(Some(&zero))));
            let regression = regress(memo);
            let others = others
                .join()
                .unwrap_or_else(|_| (cost_of(riccati), cost_of(Some(&zero))));
            (regression, others)
        })
    } else {
        (regress(memo), (cost_of(riccati), cost_of(Some(&zero))))
    };
    let starts: Vec<(&str, Option<DMatrix<f64>>)> = vec![
        ("state-sequence covariances (Riccati)", riccati.cloned()),
        (
            "regression on VARX innovations",
            regression.as_ref().ok().map(|(k, _)| k.clone()),
        ),
        ("none (K = 0, the output-error predictor)", Some(zero)),
    ];
    let mut runs_of = [riccati_cost, cost_of(starts[1].1.as_ref()), zero_cost];
    let costs: Vec<Option<f64>> = runs_of.iter().map(|r| r.as_ref().map(|r| r.0)).collect();
    report.riccati_cost = costs[0];
    report.regression_cost = costs[1];
    report.zero_cost = costs[2];
    match &regression {
        Ok((_, order)) => report.varx_order = Some(*order),
        Err(e) => report.note = Some(format!("no regression on VARX innovations: {e}")),
    }
    let best = (0..starts.len())
        .filter_map(|i| costs[i].map(|c| (i, c)))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    let Some((i, start_cost)) = best else {
        report.note =
            Some("no gain gives a stable one-step predictor: the subspace step's is kept".into());
        return (riccati.cloned(), report);
    };
    let start = starts[i].1.clone().unwrap_or_else(|| DMatrix::zeros(n, ny));
    report.start = Some(starts[i].0.into());
    let measured: usize = sets
        .iter()
        .map(|d| d.y.iter().filter(|v| !v.is_nan()).count())
        .sum();
    let tolerance = opts.tolerance(measured);
    report.stop = Some(format!(
        "a decrease below {tolerance:.2e} of the cost ({} of its sampling spread √(2/{measured})), or {} iterations",
        opts.stop_share, opts.max_iterations
    ));
    let route = route.unwrap_or(if missing {
        Sensitivities::States
    } else {
        Sensitivities::Rows
    });
    let limits = Limits {
        tolerance,
        max_iterations: opts.max_iterations,
        work: opts.minimise_work,
    };
    if opts.covariance_start
        && !missing
        && let Some((_, base)) = runs_of[i].take()
        && let Some((k, cost, iterations, bfgs)) =
            minimise_from_covariances(&runs, &start, &base, start_cost, limits)
    {
        report.used = format!(
            "prediction-error minimisation over K from {} (BFGS on the covariances of its one-step errors, then quasi-Newton on the records)",
            starts[i].0
        );
        report.final_cost = Some(cost);
        report.iterations = iterations;
        report.covariance_iterations = Some(bfgs);
        return (Some(k), report);
    }
    match minimise(model, &start, sets, &x0s, &spread, limits, route) {
        Ok((k, cost, iterations, factors)) if cost < start_cost => {
            report.used = format!("prediction-error minimisation over K from {}", starts[i].0);
            report.final_cost = Some(cost);
            report.iterations = iterations;
            report.factors = factors;
            (Some(k), report)
        }
        outcome => {
            report.used = starts[i].0.into();
            report.final_cost = Some(start_cost);
            report.note = Some(match outcome {
                Ok(_) => "the minimisation did not decrease the cost".into(),
                Err(e) => format!("no minimisation: {e}"),
            });
            (Some(start), report)
        }
    }
}

/// [`GainCheck::used`] when the subspace step's gain stays unchecked.
fn starts_name(riccati: Option<&DMatrix<f64>>) -> &'static str {
    if riccati.is_some() {
        "state-sequence covariances (Riccati)"
    } else {
        "none"
    }
}

/// [`GainCheck::rule`].
const RULE: &str = "one-step prediction error on the records (normalised squared error, mean over the outputs; the predictor started from the state the simulation is fitted from, as `validate` does): the best of three starts (subspace step, regression on VARX innovations, K = 0), then minimised over K with A, B, C, D fixed and A − K C stable (BFGS on the covariances of the start's one-step errors finished by quasi-Newton on the records, or Levenberg–Marquardt on the records)";

/// Records of at least this many samples have the starts' costs computed
/// on a second thread while the regression runs (below it a thread costs
/// more than it saves).
const PARALLEL_SAMPLES: usize = 20_000;

/// Rows of [J | r] folded into the R factor at a time.
const BLOCK_ROWS: usize = 2048;

/// [`minimise`] keeps a step's factor for the next iteration while its
/// quadratic model predicted the decrease the step gave to within this
/// factor (ratio of actual to predicted decrease in [2/3, 3/2]);
/// otherwise the factor is folded anew at the new iterate. Speed only in
/// intent: a kept factor still gives descent steps from the exact
/// gradient, and every iterate is accepted on the cost, but a factor
/// whose model is off by more than this makes steps too short or too long
/// and the iterations slow (measured on the studio bench's record: at
/// order 2 ratios 1.6–2.0 for 28 iterations without refolding, and a
/// cost 8 % above the optimum after 30; at order 3 ratios 0.26–0.43 and
/// 14 iterations instead of 10).
const MODEL_AGREEMENT: f64 = 1.5;

/// What a step of [`minimise`] is solved with: the R factor of [J | r]
/// at the point where it was last folded (the Gauss–Newton matrix
/// R_Jᵀ R_J of that point) and the exact gradient Jᵀ r at the current
/// point.
struct StepBasis {
    /// R of [J | r] (its first P columns' upper block R_J, the last
    /// column's first P entries q).
    r: DMatrix<f64>,
    /// Jᵀ r at the current iterate (the gradient of ½ ‖r‖²).
    gradient: DVector<f64>,
    /// Whether `r` was folded at the current iterate (then R_Jᵀ q is the
    /// gradient and q is taken as it is).
    fresh: bool,
}

impl StepBasis {
    /// At a point whose factor was just folded: the gradient R_Jᵀ q.
    fn folded(r: DMatrix<f64>, params: usize) -> Self {
        let k = r.nrows().min(params);
        let rj = r.view((0, 0), (k, params));
        let q = r.view((0, params), (k, 1));
        let gradient = rj.transpose() * q;
        StepBasis {
            gradient: gradient.column(0).into_owned(),
            r,
            fresh: true,
        }
    }

    /// R_J, its column norms (Marquardt's scaling D: J's column norms at
    /// the factor's point) and the right-hand side q̃ with R_Jᵀ q̃ = Jᵀ r
    /// (q itself when the factor is fresh), so that the damped problem
    /// [R_J; √λ D] δ ≈ [−q̃; 0] is (R_Jᵀ R_J + λ D²) δ = −Jᵀ r without
    /// forming R_Jᵀ R_J. `None` when a stale R_J is singular or has fewer
    /// rows than parameters (a fresh factor is then needed).
    fn parts(&self, params: usize) -> Option<(DMatrix<f64>, Vec<f64>, DVector<f64>)> {
        let k = self.r.nrows().min(params);
        let rj = self.r.view((0, 0), (k, params)).into_owned();
        let scale: Vec<f64> = (0..params)
            .map(|p| rj.column(p).norm().max(1e-300))
            .collect();
        let q = if self.fresh {
            self.r.view((0, params), (k, 1)).column(0).into_owned()
        } else {
            if k < params || (0..params).any(|p| rj[(p, p)] == 0.0) {
                return None;
            }
            let q = rj.transpose().solve_lower_triangular(&self.gradient)?;
            if !q.iter().all(|v| v.is_finite()) {
                return None;
            }
            q
        };
        Some((rj, scale, q))
    }
}

/// Levenberg–Marquardt on the one-step prediction errors over K from
/// `start` (its predictor stable), the predictor started from `x0s`, with
/// the exact Jacobian from the sensitivity recursions
/// S(t+1) = (A − K C) S(t) + E(ε(t)), ∂ε(t)/∂vec K = −C S(t). The rows
/// of [J | r] are folded block by block into the R factor of their QR
/// (memory O(P²), never JᵀJ), and each step solves the small damped
/// problem [R_J; √λ D] δ = [−q̃; 0] (D: Marquardt's column norms of J).
///
/// The factor is lazy (Jacobian reuse, the idea of the chord and
/// Shamanskii variants of Newton's method; Kelley, *Iterative Methods for
/// Linear and Nonlinear Equations*, 1995): it is folded at the start and
/// again only where the factor's quadratic model mispredicts a step's
/// decrease ([`MODEL_AGREEMENT`]) or a step taken with a factor of an
/// earlier iterate fails. Every iterate gets its exact gradient Jᵀ r by
/// the adjoint recursion backwards over the errors of the run that gave
/// its cost (`OneStep::add_adjoint_gradient`, O(N (n² + n n_y))), and q̃
/// solves R_Jᵀ q̃ = Jᵀ r (so the step is (R_Jᵀ R_J + λ D²) δ = −Jᵀ r with
/// the Gauss–Newton matrix of the factor's point: a descent direction at
/// any λ). Near the optimum J changes little, so the steps are those of
/// Gauss–Newton at a fraction of the cost: the forward sensitivities and
/// the fold of a factor cost O(N n_y (n² n_y + P²)), several times a run
/// with its adjoint. Every trial is accepted only on a lower cost on the
/// records, as before.
///
/// `spread`: [`output_spread`] of `sets` (the outputs' weights);
/// `limits`: the relative decrease below which it stops and the largest
/// number of iterations; `route`: how a factor's sensitivities are
/// computed ([`Sensitivities`]). Returns the gain, its cost
/// ([`prediction_cost`]), the iterations taken and the factors folded.
/// O(N (n² + n n_y + n n_u)) per iteration, plus O(N n_y (n² n_y + P²))
/// per factor (O(N n_y (n² P + P²)) on records with outputs not measured).
fn minimise(
    model: &StateSpace,
    start: &DMatrix<f64>,
    sets: &[Experiment<'_>],
    x0s: &[DVector<f64>],
    spread: &[f64],
    limits: Limits,
    route: Sensitivities,
) -> Result<(DMatrix<f64>, f64, usize, usize), String> {
    let Limits {
        tolerance,
        max_iterations,
        work,
    } = limits;
    let (n, ny) = (model.order(), model.n_outputs());
    if n == 0 {
        return Err("a static model has no gain".into());
    }
    let params = n * ny;
    let rows: usize = sets.iter().map(|d| d.u.nrows() * ny).sum();
    let per_run = rows as f64 * ((n * n * params) as f64 + 2.0 * (params * params) as f64);
    let mut runs_left = (work / per_run).floor() as usize;
    if runs_left < 3 {
        return Err(format!(
            "its predictor runs would cost {per_run:.2e} operations each, more than a third of {work:.0e}"
        ));
    }
    let runs = ExactRuns::new(model, sets, x0s, spread);
    let w = &runs.w;
    let mut theta = DVector::from_column_slice(start.as_slice());
    let gain = |theta: &DVector<f64>| DMatrix::from_column_slice(n, ny, theta.as_slice());
    let predictor = |theta: &DVector<f64>| runs.predictor(theta);
    let run_at = |theta: &DVector<f64>| runs.run_at(theta);
    let gradient_of =
        |errors: &[Vec<f64>], predictor: &OneStep| runs.gradient_of(errors, predictor);
    // The cost and the R factor of [J | r] at θ from one run (the factor
    // `None` when its rows are not finite); None when A − K C is not
    // stable or the cost is not finite. The rows are folded on a second
    // thread while the predictor makes the next ones, when there is one
    // and the records are long ([`Blocks`]: the same blocks in the same
    // order, the same R bit for bit).
    let parallel =
        rows > 4 * BLOCK_ROWS && std::thread::available_parallelism().map_or(1, |n| n.get()) > 1;
    let factor_at = |theta: &DVector<f64>| -> Option<(f64, Option<DMatrix<f64>>)> {
        let predictor = predictor(theta)?;
        let mut cost = 0.0;
        let r = fold_rows(params + 1, parallel, |blocks| {
            for (data, x0) in sets.iter().zip(x0s) {
                predictor.with_sensitivities(route, data.u, data.y, x0, |o, cs, eps| {
                    let (block, at) = blocks.row();
                    for (p, v) in cs.iter().enumerate() {
                        block[(at, p)] = -w[o] * v;
                    }
                    let r = w[o] * eps;
                    block[(at, params)] = r;
                    cost += r * r;
                });
            }
        });
        cost.is_finite().then_some((cost, r))
    };
    let start_at = factor_at(&theta).and_then(|(c, r)| Some((c, r?)));
    let Some((mut cost, r)) = start_at else {
        return Err("the start's predictor is not stable".into());
    };
    let mut basis = StepBasis::folded(r, params);
    let mut factors = 1;
    runs_left -= 1;
    let mut lambda: f64 = 1e-3;
    let mut iterations = 0;
    // The errors of the last accepted trial's run.
    let mut last_errors: Option<Vec<Vec<f64>>> = None;
    while iterations < max_iterations {
        iterations += 1;
        let mut improved = false;
        while lambda < 1e10 && runs_left > 0 {
            // A stale factor that cannot give the step is folded anew here.
            let parts = match basis.parts(params) {
                Some(parts) => parts,
                None if !basis.fresh => {
                    runs_left -= 1;
                    match factor_at(&theta) {
                        Some((_, Some(r))) => {
                            basis = StepBasis::folded(r, params);
                            factors += 1;
                            continue;
                        }
                        _ => break,
                    }
                }
                None => break,
            };
            let (rj, scale, q) = parts;
            let k = rj.nrows();
            let mut aug = DMatrix::zeros(k + params, params);
            aug.rows_mut(0, k).copy_from(&rj);
            for p in 0..params {
                aug[(k + p, p)] = lambda.sqrt() * scale[p];
            }
            let mut rhs = DMatrix::zeros(k + params, 1);
            rhs.view_mut((0, 0), (k, 1)).copy_from(&(-&q));
            let Ok(step) = lifted_linalg::lstsq(&aug, &rhs) else {
                lambda *= 4.0;
                continue;
            };
            let trial = &theta + step.column(0);
            let predicted = q.norm_squared() - (&rj * step.column(0) + &q).norm_squared();
            runs_left -= 1;
            let evaluated = run_at(&trial);
            // Accepted with a further iteration to come: its step basis, the
            // factor kept and the trial's gradient while the factor's
            // quadratic model predicted the decrease to within
            // [`MODEL_AGREEMENT`], else a factor folded at the trial.
            let accepted = match evaluated {
                Some((ct, errors, run)) if ct < cost => {
                    let decrease = (cost - ct) / cost.max(f64::MIN_POSITIVE);
                    let agreement = (cost - ct) / predicted.max(f64::MIN_POSITIVE);
                    let keep = (1.0 / MODEL_AGREEMENT..=MODEL_AGREEMENT).contains(&agreement);
                    // A small decrease ends the iterations only from a
                    // factor that is fresh or whose model predicted it: a
                    // stale factor that mispredicts can make short steps
                    // far from the optimum (it is folded anew instead).
                    let more = decrease > tolerance || !(basis.fresh || keep);
                    let next = if !(more && iterations < max_iterations) {
                        Some(None)
                    } else if keep {
                        gradient_of(&errors, &run).map(|gt| {
                            Some(StepBasis {
                                r: std::mem::take(&mut basis.r),
                                gradient: gt,
                                fresh: false,
                            })
                        })
                    } else {
                        runs_left = runs_left.saturating_sub(1);
                        factors += 1;
                        factor_at(&trial)
                            .and_then(|(_, r)| Some(Some(StepBasis::folded(r?, params))))
                    };
                    next.map(|next| (ct, next, more, errors))
                }
                _ => None,
            };
            match accepted {
                Some((ct, next, more, errors)) => {
                    (theta, cost) = (trial, ct);
                    last_errors = Some(errors);
                    if let Some(next) = next {
                        basis = next;
                    }
                    lambda = (lambda / 3.0).max(1e-12);
                    improved = more;
                    break;
                }
                // A step from a factor of an earlier iterate failed: the
                // factor is folded at this one and the step tried again
                // at the same damping.
                None if !basis.fresh && runs_left > 0 => {
                    runs_left -= 1;
                    match factor_at(&theta) {
                        Some((_, Some(r))) => {
                            basis = StepBasis::folded(r, params);
                            factors += 1;
                        }
                        _ => break,
                    }
                }
                None => lambda *= 4.0,
            }
        }
        if !improved {
            break;
        }
    }
    let k = gain(&theta);
    let cost = runs.final_cost(&k, last_errors.as_deref())?;
    Ok((k, cost, iterations, factors))
}

/// The one-step cost over the records and its gradient at a gain, for the
/// minimisations over K ([`minimise`], [`minimise_from_covariances`]).
struct ExactRuns<'a, 'r> {
    model: &'a StateSpace,
    sets: &'a [Experiment<'r>],
    x0s: &'a [DVector<f64>],
    spread: &'a [f64],
    /// Per-output weights 1/‖y_o − ȳ_o‖ over all records (the cost of
    /// prediction_cost without its division by n_y).
    w: Vec<f64>,
    /// The weights squared.
    w2: Vec<f64>,
}

/// A run's cost ‖r‖², its errors (one row-major block a record) and its
/// predictor.
type Run = (f64, Vec<Vec<f64>>, OneStep);

impl<'a, 'r> ExactRuns<'a, 'r> {
    fn new(
        model: &'a StateSpace,
        sets: &'a [Experiment<'r>],
        x0s: &'a [DVector<f64>],
        spread: &'a [f64],
    ) -> Self {
        let w: Vec<f64> = spread
            .iter()
            .map(|s| if *s > 0.0 { 1.0 / s.sqrt() } else { 0.0 })
            .collect();
        let w2 = w.iter().map(|v| v * v).collect();
        ExactRuns {
            model,
            sets,
            x0s,
            spread,
            w,
            w2,
        }
    }

    /// The predictor at θ = vec K; None when A − K C is not stable.
    fn predictor(&self, theta: &DVector<f64>) -> Option<OneStep> {
        let (n, ny) = (self.model.order(), self.model.n_outputs());
        let k = DMatrix::from_column_slice(n, ny, theta.as_slice());
        let m = self.model.a() - &k * self.model.c();
        let rho = spectral_radius(&m).ok()?;
        (rho < 1.0).then(|| OneStep::new(self.model, &k, &m))
    }

    /// ‖r‖² at θ (the rows' squares summed in the order every run visits
    /// them, so the same number bit for bit) with the run's errors (one
    /// row-major block a record, for the adjoint gradient) and its
    /// predictor; None when A − K C is not stable or the cost is not
    /// finite.
    fn run_at(&self, theta: &DVector<f64>) -> Option<Run> {
        let predictor = self.predictor(theta)?;
        let mut cost = 0.0;
        let mut errors = Vec::with_capacity(self.sets.len());
        for (data, x0) in self.sets.iter().zip(self.x0s) {
            let mut record = Vec::with_capacity(data.y.len());
            predictor.with_errors(data.u, data.y, x0, |eps| {
                for (o, e) in eps.iter().enumerate() {
                    let r = self.w[o] * e;
                    cost += r * r;
                }
                record.extend_from_slice(eps);
            });
            errors.push(record);
        }
        cost.is_finite().then_some((cost, errors, predictor))
    }

    /// The gradient Jᵀ r (½ ∇‖r‖²) of a run by the adjoint recursion over
    /// its errors (`OneStep::add_adjoint_gradient`: one n-state recursion
    /// backwards, no sensitivities); None when it is not finite.
    fn gradient_of(&self, errors: &[Vec<f64>], predictor: &OneStep) -> Option<DVector<f64>> {
        let params = self.model.order() * self.model.n_outputs();
        let mut gradient = vec![0.0; params];
        for (data, eps) in self.sets.iter().zip(errors) {
            predictor.add_adjoint_gradient(data.y, eps, &self.w2, &mut gradient);
        }
        gradient
            .iter()
            .all(|g| g.is_finite())
            .then(|| DVector::from_vec(gradient))
    }

    /// The gain's cost ([`prediction_cost`]) from the errors of the run
    /// that accepted it (the same number: the squares summed in the same
    /// order), else by a run.
    fn final_cost(&self, k: &DMatrix<f64>, errors: Option<&[Vec<f64>]>) -> Result<f64, String> {
        lifted_linalg::simd::dispatch(
            #[inline(always)]
            || match errors {
                Some(errors) => {
                    let mut err = vec![0.0; self.model.n_outputs()];
                    for record in errors {
                        for eps in record.chunks_exact(err.len()) {
                            for (e, v) in err.iter_mut().zip(eps) {
                                *e += v * v;
                            }
                        }
                    }
                    normalised_cost(&err, self.spread)
                }
                None => prediction_cost(self.model, k, self.sets, self.x0s, self.spread),
            },
        )
    }
}

/// The covariance route of the minimisation over K (module
/// `error_covariance`): BFGS on the cost written exactly through the
/// covariances of the start's one-step errors (`base`, a block a record
/// as [`ExactRuns::run_at`] gives them) from the start, then quasi-Newton
/// on the cost over the records from its minimum, with BFGS's curvature
/// and each iterate's exact gradient (adjoint), a trial only where the
/// step predicts more than the relative `tolerance` and accepted only on
/// a lower cost over the records, until a decrease below `tolerance` or
/// `max_iterations`. Returns the gain, its cost ([`prediction_cost`]), the
/// iterations on the records and the covariance form's; `None` when the
/// route cannot be taken (its work beyond [`GainCheckOptions::minimise_work`]) or does not
/// end below `start_cost` (then Levenberg–Marquardt runs as before).
/// Records with every output measured (the errors of a constant K are
/// then a filter of those of the start). O(N n_y² log N) for the
/// covariances, O(L (n² n_y + n n_y²) + n³ log L) per evaluation of the
/// covariance form (L ≤ `error_covariance::MAX_LAGS` lags, and each
/// record's last L errors), O(N (n² + n n_y + n n_u)) per iteration on the
/// records.
fn minimise_from_covariances(
    runs: &ExactRuns<'_, '_>,
    start: &DMatrix<f64>,
    base: &[Vec<f64>],
    start_cost: f64,
    limits: Limits,
) -> Option<(DMatrix<f64>, f64, usize, usize)> {
    let Limits {
        tolerance,
        max_iterations,
        work,
    } = limits;
    let model = runs.model;
    let (n, ny) = (model.order(), model.n_outputs());
    if n == 0 {
        return None;
    }
    // Within the minimisation's work budget: the start's Hessian (P
    // gradients) and the most BFGS iterations, each evaluation with its
    // gradient about three Horner passes over the lags and each record's
    // end (else Levenberg–Marquardt, under the same budget).
    let longest = base.iter().map(|e| e.len() / ny).max().unwrap_or(0);
    let lags = crate::error_covariance::MAX_LAGS.min(longest.saturating_sub(1)) as f64;
    let per_evaluation =
        6.0 * lags * ((n * n * ny + n * ny * ny) as f64) * base.len().max(1) as f64;
    if ((n * ny + COVARIANCE_ITERATIONS) as f64) * per_evaluation > work {
        return None;
    }
    // The start's one-step errors (its predictor is stable), of which
    // every other gain's are a filter: K = K₀ + ΔK has the errors of
    // A − K₀ C with gain ΔK (module `error_covariance`).
    let cov = Covariances::from_errors(base, ny, &runs.w2)?;
    // BFGS from the start: ΔK = 0 on (A − K₀ C, C).
    let shifted = model.a() - start * model.c();
    let min = cov.minimise(
        &shifted,
        model.c(),
        &DMatrix::zeros(n, ny),
        COVARIANCE_ITERATIONS,
    )?;
    let mut theta = DVector::from_column_slice((start + &min.k).as_slice());
    let (mut cost, mut errors, mut predictor) = runs.run_at(&theta)?;
    // (‖r‖² is n_y times the normalised cost.)
    if cost / ny as f64 >= start_cost {
        return None;
    }
    let mut h = min.inverse_hessian;
    // ∇‖r‖² = 2 Jᵀ r.
    let mut g = runs.gradient_of(&errors, &predictor)? * 2.0;
    let mut iterations = 0;
    while iterations < max_iterations {
        // The decrease a quasi-Newton step predicts, ½ gᵀ H g: below the
        // stopping decrease, no trial is run (the covariance form is the
        // cost over the records, so its minimum is one of the cost's, and
        // there a trial step only meets rounding).
        let dir = -(&h * &g);
        let predicted = -0.5 * g.dot(&dir);
        if predicted.is_nan() || predicted <= tolerance * cost {
            break;
        }
        iterations += 1;
        let mut alpha = 1.0;
        let mut accepted = None;
        for _ in 0..4 {
            let trial = &theta + alpha * &dir;
            match runs.run_at(&trial) {
                Some(run) if run.0 < cost => {
                    accepted = Some((trial, run));
                    break;
                }
                _ => alpha *= 0.25,
            }
        }
        let Some((trial, (ct, et, pt))) = accepted else {
            break;
        };
        let decrease = (cost - ct) / cost.max(f64::MIN_POSITIVE);
        (theta, cost, errors, predictor) = (trial.clone(), ct, et, pt);
        if decrease <= tolerance || iterations == max_iterations {
            break;
        }
        let Some(gt) = runs.gradient_of(&errors, &predictor) else {
            break;
        };
        let gt = gt * 2.0;
        let s = alpha * &dir;
        let yv = &gt - &g;
        if let Some(sy) = positive_curvature(&s, &yv) {
            bfgs_update(&mut h, &s, &yv, sy);
        }
        g = gt;
    }
    let k = DMatrix::from_column_slice(n, ny, theta.as_slice());
    let final_cost = runs.final_cost(&k, Some(&errors)).ok()?;
    (final_cost < start_cost).then_some((k, final_cost, iterations, min.iterations))
}

/// Most BFGS iterations on the covariance form (each costs no pass over
/// the records; on the studio bench's record 17–133 reach the minimum, to a
/// decrease below 1e-12 of the cost).
const COVARIANCE_ITERATIONS: usize = 200;

/// Where [`fold_rows`] sends its full blocks: an accumulator here, or the
/// folding thread (blocks out, emptied blocks back).
enum Sink<'a> {
    Here(lifted_linalg::RAccumulator),
    Thread {
        full: std::sync::mpsc::SyncSender<DMatrix<f64>>,
        spent: &'a std::sync::mpsc::Receiver<DMatrix<f64>>,
    },
}

/// Blocks of [`BLOCK_ROWS`] rows filled one row at a time by
/// [`fold_rows`]'s producer.
struct Blocks<'a> {
    block: DMatrix<f64>,
    filled: usize,
    folded: bool,
    sink: Sink<'a>,
}

impl Blocks<'_> {
    /// The block and the index of the next row to fill (a full block is
    /// folded, or sent to the folding thread, first).
    fn row(&mut self) -> (&mut DMatrix<f64>, usize) {
        if self.filled == BLOCK_ROWS {
            match &mut self.sink {
                Sink::Here(acc) => self.folded &= acc.push_rows(&self.block).is_ok(),
                Sink::Thread { full, spent } => {
                    let (r, c) = self.block.shape();
                    let next = spent.try_recv().unwrap_or_else(|_| DMatrix::zeros(r, c));
                    let block = std::mem::replace(&mut self.block, next);
                    self.folded &= full.send(block).is_ok();
                }
            }
            self.filled = 0;
        }
        self.filled += 1;
        (&mut self.block, self.filled - 1)
    }
}

/// The R factor of the QR of the rows (`width` columns) that `produce`
/// writes through [`Blocks::row`], folded block by block into an
/// `RAccumulator`; with `parallel`, the blocks are folded on a second
/// thread while `produce` fills the next (the same blocks pushed in the
/// same order: the same R bit for bit). `None` when a block is not
/// finite or the folding thread fails.
fn fold_rows(
    width: usize,
    parallel: bool,
    produce: impl FnOnce(&mut Blocks<'_>),
) -> Option<DMatrix<f64>> {
    let finish = |mut blocks: Blocks<'_>| -> Option<Option<lifted_linalg::RAccumulator>> {
        let last = blocks.block.rows(0, blocks.filled).into_owned();
        match blocks.sink {
            Sink::Here(mut acc) => {
                blocks.folded &= acc.push_rows(&last).is_ok();
                blocks.folded.then_some(Some(acc))
            }
            Sink::Thread { full, .. } => {
                blocks.folded &= full.send(last).is_ok();
                blocks.folded.then_some(None)
            }
        }
    };
    if !parallel {
        let mut blocks = Blocks {
            block: DMatrix::zeros(BLOCK_ROWS, width),
            filled: 0,
            folded: true,
            sink: Sink::Here(lifted_linalg::RAccumulator::new(width)),
        };
        produce(&mut blocks);
        return finish(blocks).flatten().map(|acc| acc.r());
    }
    let (full, blocks_in) = std::sync::mpsc::sync_channel::<DMatrix<f64>>(2);
    let (spent_out, spent) = std::sync::mpsc::channel::<DMatrix<f64>>();
    std::thread::scope(|scope| {
        let folder = scope.spawn(move || {
            let mut acc = lifted_linalg::RAccumulator::new(width);
            let mut folded = true;
            for block in blocks_in {
                folded &= acc.push_rows(&block).is_ok();
                // (The producer may have finished: a block not taken back
                // is dropped.)
                let _ = spent_out.send(block);
            }
            folded.then(|| acc.r())
        });
        let mut blocks = Blocks {
            block: DMatrix::zeros(BLOCK_ROWS, width),
            filled: 0,
            folded: true,
            sink: Sink::Thread {
                full,
                spent: &spent,
            },
        };
        produce(&mut blocks);
        // (Sending the last block and dropping the sender ends the folding
        // thread's loop.)
        let sent = finish(blocks).is_some();
        let r = folder.join().ok().flatten();
        r.filter(|_| sent)
    })
}

/// K by the output-error regression on VARX innovations (module docs),
/// and the VARX order used.
fn regression_gain(
    model: &StateSpace,
    sets: &[Experiment<'_>],
    past: usize,
    varx_work: f64,
    memo: &mut VarxMemo,
) -> Result<(DMatrix<f64>, usize), String> {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            let (nu, ny) = (model.n_inputs(), model.n_outputs());
            let nz = nu + ny;
            let total: usize = sets.iter().map(|d| d.u.nrows()).sum();
            let cols = |p: usize| (p * nz + nu) as f64;
            // The longest VARX within the work bound with ten samples per
            // regressor in every record.
            let shortest = sets.iter().map(|d| d.u.nrows()).min().unwrap_or(0);
            let order = (1..=past.max(1))
                .rev()
                .find(|&p| {
                    total as f64 * cols(p) * cols(p) <= varx_work
                        && shortest > p + 10 * (p * nz + nu)
                })
                .ok_or_else(|| "the records are too short for a VARX".to_string())?;
            // u(t) among the regressors only for a model with a direct
            // feedthrough: under a controller reacting within the sample it would
            // carry the innovation into the regression.
            let direct = model.d().iter().any(|v| *v != 0.0);
            // The VARX's records: the memo's source when it has the check's
            // shapes (every model of a record then shares its innovations), else
            // the records as given.
            let fits = |c: &[CentredRecord]| {
                c.len() == sets.len()
                    && c.iter()
                        .zip(sets)
                        .all(|((u, y), d)| u.shape() == d.u.shape() && y.shape() == d.y.shape())
            };
            // Keyed by the records' hash and whether they were centred (a record
            // given as it is and the same record centred are different VARX data).
            let (hash, varx_sets): ((u64, bool), Vec<Experiment<'_>>) = match &memo.source {
                Some((h, c)) if fits(c) => (
                    (*h, true),
                    c.iter().map(|(u, y)| Experiment { u, y }).collect(),
                ),
                _ => ((records_hash(sets), false), sets.to_vec()),
            };
            let found = memo
                .kept
                .iter()
                .position(|(h, o, d, _)| (*h, *o, *d) == (hash, order, direct));
            let at = match found {
                Some(at) => at,
                None => {
                    let e = varx_innovations(&varx_sets, order, direct)?;
                    memo.computed += 1;
                    if memo.kept.len() == MEMO_ENTRIES {
                        memo.kept.remove(0);
                    }
                    memo.kept.push((hash, order, direct, e));
                    memo.kept.len() - 1
                }
            };
            let innovations = &memo.kept[at].3;
            let a = model.a();
            let c = model.c();
            let mut targets = Vec::with_capacity(sets.len());
            for (d, e) in sets.iter().zip(innovations) {
                let len = d.u.nrows() - order;
                let u = d.u.rows(order, len).into_owned();
                let y = d.y.rows(order, len).into_owned();
                let sim = model.lsim_outputs(&u, None).map_err(|e| e.to_string())?;
                targets.push(y - sim - e);
            }
            let recs: Vec<Record<'_>> = innovations
                .iter()
                .zip(&targets)
                .map(|(e, r)| Record {
                    u: e,
                    y: r,
                    instrument: None,
                })
                .collect();
            let fit = estimate_bd(a, c, &recs, &Feedthrough::Zero, InitialState::Estimate)
                .map_err(|e| format!("the regression of K failed ({e})"))?;
            Ok((fit.b, order))
        },
    )
}

/// The one-step prediction errors of a VARX of order `p` fitted to all
/// records together by least squares (y(t) on z(t−1) … z(t−p), and u(t)
/// when `direct`): per record, the N − p estimates ê(p) … ê(N−1). The
/// regressor rows are folded block by block into the R factor of [X | Y]
/// (memory O(w²) for w ≤ p n_z + n_u regressors), the coefficients solved
/// from it, and the residuals formed in a second pass.
fn varx_innovations(
    sets: &[Experiment<'_>],
    p: usize,
    direct: bool,
) -> Result<Vec<DMatrix<f64>>, String> {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            let (nu, ny) = (sets[0].u.ncols(), sets[0].y.ncols());
            let nz = nu + ny;
            let nd = if direct { nu } else { 0 };
            let width = p * nz + nd;
            // Rows t0 … t0 + rows − 1 of record d into block rows at … at + rows − 1:
            // row t is [z(t−1) … z(t−p), u(t) | y(t)], filled a column segment at a
            // time (contiguous copies of the column-major records).
            let fill = |d: &Experiment<'_>,
                        t0: usize,
                        rows: usize,
                        block: &mut DMatrix<f64>,
                        at: usize| {
                let (u, y) = (d.u, d.y);
                for lag in 1..=p {
                    let base = (lag - 1) * nz;
                    for j in 0..nu {
                        block
                            .view_mut((at, base + j), (rows, 1))
                            .copy_from(&u.view((t0 - lag, j), (rows, 1)));
                    }
                    for j in 0..ny {
                        block
                            .view_mut((at, base + nu + j), (rows, 1))
                            .copy_from(&y.view((t0 - lag, j), (rows, 1)));
                    }
                }
                for j in 0..nd {
                    block
                        .view_mut((at, p * nz + j), (rows, 1))
                        .copy_from(&u.view((t0, j), (rows, 1)));
                }
                for j in 0..ny {
                    block
                        .view_mut((at, width + j), (rows, 1))
                        .copy_from(&y.view((t0, j), (rows, 1)));
                }
            };
            let mut acc = lifted_linalg::RAccumulator::new(width + ny);
            let mut block = DMatrix::zeros(BLOCK_ROWS, width + ny);
            let mut filled = 0;
            for d in sets {
                let mut t = p;
                while t < d.u.nrows() {
                    if filled == BLOCK_ROWS {
                        acc.push_rows(&block).map_err(|e| e.to_string())?;
                        filled = 0;
                    }
                    let take = (BLOCK_ROWS - filled).min(d.u.nrows() - t);
                    fill(d, t, take, &mut block, filled);
                    filled += take;
                    t += take;
                }
            }
            acc.push_rows(&block.rows(0, filled).into_owned())
                .map_err(|e| e.to_string())?;
            let r = acc.r();
            if r.nrows() < width + ny {
                return Err("the records are too short for the VARX".into());
            }
            let theta = lifted_linalg::lstsq(
                &r.view((0, 0), (width, width)).into_owned(),
                &r.view((0, width), (width, ny)).into_owned(),
            )
            .map_err(|e| format!("the VARX failed ({e})"))?;
            // The residuals block by block: ê = y − [z(t−1) … z(t−p), u(t)] θ.
            let mut out = Vec::with_capacity(sets.len());
            for d in sets {
                let len = d.u.nrows() - p;
                let mut e = DMatrix::zeros(len, ny);
                let mut t = p;
                while t < d.u.nrows() {
                    let take = BLOCK_ROWS.min(d.u.nrows() - t);
                    fill(d, t, take, &mut block, 0);
                    let mut rows = e.view_mut((t - p, 0), (take, ny));
                    rows.copy_from(&block.view((0, width), (take, ny)));
                    rows.gemm(-1.0, &block.view((0, 0), (take, width)), &theta, 1.0);
                    t += take;
                }
                out.push(e);
            }
            Ok(out)
        },
    )
}

/// The initial state of each record that `lifted validate` simulates
/// from: the least-squares x₀ of the simulation error
/// ([`crate::regress::estimate_x0`]); zero for an unstable model, as
/// `validate` does. The one-step predictor starts from it, as in
/// `lifted_lti::validate`, so the cost minimised is the one the
/// validation reports.
fn simulation_states(
    model: &StateSpace,
    sets: &[Experiment<'_>],
) -> Result<Vec<DVector<f64>>, String> {
    let n = model.order();
    let rho = if n == 0 {
        0.0
    } else {
        spectral_radius(model.a()).map_err(|e| e.to_string())?
    };
    if n == 0 || rho >= 1.0 {
        return Ok(vec![DVector::zeros(n); sets.len()]);
    }
    let recs = crate::records::records_of(sets);
    estimate_x0(model.a(), model.b(), model.c(), model.d(), &recs).map_err(|e| e.to_string())
}

/// The one-step prediction error of gain `k` on `sets`, the predictor
/// started from `x0s` (one state per record): per output, the squared
/// error over the records divided by the output's squared deviation from
/// its mean ([`output_spread`] of `sets`: `spread`), averaged over the
/// outputs. `Err` when A − K C is not stable (no predictor) or the
/// prediction fails.
fn prediction_cost(
    model: &StateSpace,
    k: &DMatrix<f64>,
    sets: &[Experiment<'_>],
    x0s: &[DVector<f64>],
    spread: &[f64],
) -> Result<f64, String> {
    let ny = model.n_outputs();
    let m = model.a() - k * model.c();
    let rho = spectral_radius(&m).map_err(|e| e.to_string())?;
    if rho >= 1.0 {
        return Err(format!("A − K C is not stable (spectral radius {rho:.4})"));
    }
    let predictor = OneStep::new(model, k, &m);
    let mut err = vec![0.0; ny];
    for (d, x0) in sets.iter().zip(x0s) {
        predictor.add_squared_errors(d.u, d.y, x0, &mut err);
    }
    normalised_cost(&err, spread)
}

/// [`prediction_cost`] from the outputs' summed squared errors `err`:
/// each divided by its [`output_spread`], averaged over the outputs.
fn normalised_cost(err: &[f64], spread: &[f64]) -> Result<f64, String> {
    let cost = err
        .iter()
        .zip(spread)
        .map(|(e, s)| if *s > 0.0 { e / s } else { 0.0 })
        .sum::<f64>()
        / err.len().max(1) as f64;
    if cost.is_finite() {
        Ok(cost)
    } else {
        Err("the prediction error is not finite".into())
    }
}

/// Per output, the squared deviations of its measured samples from their
/// record's mean, summed over the records (the normalisation of the
/// one-step cost). O(N n_y).
fn output_spread(sets: &[Experiment<'_>], ny: usize) -> Vec<f64> {
    let mut spread = vec![0.0; ny];
    for d in sets {
        // (The means over the measured samples where some are missing.)
        let means: Vec<f64> = if d.y.iter().any(|v| v.is_nan()) {
            measured_means(d.y)
        } else {
            d.y.column_iter().map(|c| c.mean()).collect()
        };
        for (o, s) in spread.iter_mut().enumerate() {
            *s +=
                d.y.column(o)
                    .iter()
                    .filter(|v| !v.is_nan())
                    .map(|v| (v - means[o]).powi(2))
                    .sum::<f64>();
        }
    }
    spread
}

/// The mean of each output over its measured (non-NaN) samples.
fn measured_means(y: &DMatrix<f64>) -> Vec<f64> {
    y.column_iter()
        .map(|col| {
            let (sum, count) = col
                .iter()
                .filter(|v| !v.is_nan())
                .fold((0.0, 0usize), |(s, c), v| (s + v, c + 1));
            if count > 0 { sum / count as f64 } else { 0.0 }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// A 1×2 innovations-form record: x(t+1) = A x + B u + K e,
    /// y = C x + e, A = diag(0.9, 0.6), white u and e (σ_e = 0.2).
    fn record(n: usize, seed: u64) -> (StateSpace, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        let a = DMatrix::from_row_slice(2, 2, &[0.9, 0.0, 0.0, 0.6]);
        let b = DMatrix::from_row_slice(2, 1, &[1.0, 0.5]);
        let c = DMatrix::from_row_slice(2, 2, &[1.0, 0.3, -0.2, 1.0]);
        let k = DMatrix::from_row_slice(2, 2, &[0.5, 0.1, 0.0, 0.4]);
        let g = StateSpace::new(
            a.clone(),
            b.clone(),
            c.clone(),
            DMatrix::zeros(2, 1),
            Some(1.0),
        )
        .unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut draw = || -> f64 { StandardNormal.sample(&mut rng) };
        let u = DMatrix::from_fn(n, 1, |_, _| draw());
        let mut y = DMatrix::zeros(n, 2);
        let mut x = DVector::zeros(2);
        for t in 0..n {
            let e = DVector::from_fn(2, |_, _| 0.2 * draw());
            let yt = &c * &x + &e;
            y.row_mut(t).copy_from(&yt.transpose());
            x = &a * &x + &b * u.row(t).transpose() + &k * &e;
        }
        (g, k, u, y)
    }

    /// From a wrong gain (zero, or one with an unstable predictor), the
    /// check finds the true K of an innovations-form record with the
    /// deterministic part given (within 0.05 at 2e4 samples), and its
    /// one-step cost is the innovation's share of the output variance.
    #[test]
    fn the_checked_gain_is_the_innovations_gain() {
        let (g, k_true, u, y) = record(20_000, 3);
        let exps = [Experiment { u: &u, y: &y }];
        for start in [
            DMatrix::zeros(2, 2),
            DMatrix::from_row_slice(2, 2, &[3.0, 0.0, 0.0, 3.0]),
        ] {
            let (k, report) = check_kalman_gain(&g, Some(&start), &exps, 10);
            let k = k.expect("gain");
            assert!((&k - &k_true).amax() < 0.05, "{k} {report:?}");
            assert!(
                report.used.starts_with("prediction-error minimisation"),
                "{report:?}"
            );
            let final_cost = report.final_cost.expect("cost");
            for c in [
                report.riccati_cost,
                report.regression_cost,
                report.zero_cost,
            ]
            .into_iter()
            .flatten()
            {
                assert!(final_cost <= c + 1e-12, "{report:?}");
            }
            // The VARX regression alone is already close (its cost within
            // 5 % of the final one).
            let reg = report.regression_cost.expect("regression");
            assert!(reg < 1.05 * final_cost, "{report:?}");
        }
    }

    /// The covariance route on a model whose A is unstable (K = 0 has no
    /// predictor; the start's errors are the reference) and on a record
    /// cut in three: each ends at the minimum Levenberg–Marquardt reaches
    /// from the same start, within the stopping rule (a few times its
    /// relative decrease, 7.1e-5 at 4e4 output samples).
    #[test]
    fn the_covariance_route_takes_any_stable_start_and_several_records() {
        let (g, k_true, u, y) = record(20_000, 6);
        let unstable = StateSpace::new(
            DMatrix::from_row_slice(2, 2, &[1.02, 0.0, 0.0, 0.6]),
            g.b().clone(),
            g.c().clone(),
            g.d().clone(),
            Some(1.0),
        )
        .unwrap();
        let cut =
            |m: &DMatrix<f64>, r: std::ops::Range<usize>| m.rows(r.start, r.len()).into_owned();
        let pieces: Vec<(DMatrix<f64>, DMatrix<f64>)> = [0..5000, 5000..12_000, 12_000..20_000]
            .into_iter()
            .map(|r| (cut(&u, r.clone()), cut(&y, r)))
            .collect();
        let whole = [Experiment { u: &u, y: &y }];
        let split: Vec<Experiment<'_>> = pieces.iter().map(|(u, y)| Experiment { u, y }).collect();
        for (model, exps) in [(&unstable, &whole[..]), (&g, &split[..])] {
            let check = |covariance_start| {
                let opts = GainCheckOptions {
                    covariance_start,
                    ..Default::default()
                };
                check_kalman_gain_memo(
                    model,
                    Some(&k_true),
                    exps,
                    10,
                    &opts,
                    &mut VarxMemo::default(),
                )
            };
            let (k, report) = check(true);
            let (k_lm, lm) = check(false);
            assert!(report.covariance_iterations.is_some(), "{report:?}");
            assert_eq!(report.factors, 0, "{report:?}");
            let (cost, cost_lm) = (report.final_cost.unwrap(), lm.final_cost.unwrap());
            assert!(cost <= report.riccati_cost.unwrap(), "{report:?}");
            assert_relative_eq!(cost, cost_lm, max_relative = 3e-4);
            assert!((k.unwrap() - k_lm.unwrap()).amax() < 0.02);
        }
    }

    /// The records' hash: the same bits give the same hash; a change of
    /// one sample's bits (also −0.0 for 0.0), a swap of two samples of
    /// one lane or of two columns, or another cut into records changes it.
    #[test]
    fn the_records_hash_tells_records_apart() {
        let (_, _, u, y) = record(1003, 8);
        let hash = |u: &DMatrix<f64>, y: &DMatrix<f64>| records_hash(&[Experiment { u, y }]);
        let h = hash(&u, &y);
        assert_eq!(h, hash(&u.clone(), &y.clone()));
        let mut changed = y.clone();
        changed[(500, 1)] = f64::from_bits(changed[(500, 1)].to_bits() ^ 1);
        assert_ne!(h, hash(&u, &changed));
        let mut zero = u.clone();
        zero[(7, 0)] = 0.0;
        let mut negative_zero = u.clone();
        negative_zero[(7, 0)] = -0.0;
        assert_ne!(hash(&zero, &y), hash(&negative_zero, &y));
        let mut swapped = y.clone();
        swapped.swap((4, 0), (8, 0));
        assert_ne!(h, hash(&u, &swapped));
        let mut columns = y.clone();
        columns.swap_columns(0, 1);
        assert_ne!(h, hash(&u, &columns));
        let (u1, y1) = (u.rows(0, 500).into_owned(), y.rows(0, 500).into_owned());
        let (u2, y2) = (u.rows(500, 503).into_owned(), y.rows(500, 503).into_owned());
        let two = records_hash(&[Experiment { u: &u1, y: &y1 }, Experiment { u: &u2, y: &y2 }]);
        assert_ne!(h, two);
    }

    /// The over-fitted order-4 model of a record (horizon 10).
    fn over_fitted(exps: &[Experiment<'_>]) -> crate::SubspaceModel {
        crate::identify(
            exps,
            &crate::SubspaceOptions {
                order: crate::OrderSelection::Fixed(4),
                past: 10,
                future: 10,
                ..Default::default()
            },
        )
        .expect("order 4")
    }

    /// The gain by the rows' recursion of the sensitivities (the default
    /// on complete records) is the one by the states' recursion (the route
    /// of before) to 1e-10 of its largest entry, after the same number of
    /// iterations: the true-order model and an over-fitted order-4 model
    /// of the record, under the default stop and run to 30 iterations.
    #[test]
    fn the_rows_route_gives_the_states_gain() {
        let (g, _, u, y) = record(20_000, 5);
        let exps = [Experiment { u: &u, y: &y }];
        let four = over_fitted(&exps);
        for model in [&g, &four.model] {
            // (Levenberg–Marquardt: the sensitivities are its factors'.)
            for opts in [
                GainCheckOptions {
                    covariance_start: false,
                    ..Default::default()
                },
                GainCheckOptions {
                    stop_share: 0.0,
                    covariance_start: false,
                    ..Default::default()
                },
            ] {
                let run = |route| {
                    let mut memo = VarxMemo::default();
                    check_by(model, None, &exps, 10, &opts, &mut memo, route)
                };
                let (states, a) = run(Some(Sensitivities::States));
                let (rows, b) = run(None);
                let (states, rows) = (states.expect("gain"), rows.expect("gain"));
                assert_eq!(a.iterations, b.iterations, "{a:?} {b:?}");
                assert!(b.iterations > 0, "{b:?}");
                assert!(
                    (&states - &rows).amax() <= 1e-10 * states.amax(),
                    "{states} {rows}"
                );
            }
        }
    }

    /// The lazy factor (folded at the start and where a step from an
    /// earlier iterate's factor fails, the gradient exact at every
    /// iterate) reaches the optimum of the iterations that folded it at
    /// every accepted trial (commit 9fb6fc3's gains, iterations and costs,
    /// printed with `{:?}` on this record: the true-order model and the
    /// over-fitted order-4 one, default stop and `stop_share` 0). Run to
    /// convergence (`stop_share` 0) the costs agree to 1e-11 relative
    /// (7e-14 and 1e-12 measured) and the true-order model's gain to 1e-5
    /// (5.8e-7 measured; the over-fitted model's gain has flat directions
    /// and is not compared entry by entry); under the default stop the
    /// cost is within the stopping tolerance (√(2/N_e) times the share, of
    /// the cost) of that optimum, and one factor sufficed for these
    /// well-conditioned problems.
    #[test]
    fn both_routes_reach_the_optimum_of_before() {
        let (g, _, u, y) = record(20_000, 5);
        let exps = [Experiment { u: &u, y: &y }];
        let four = over_fitted(&exps);
        // (iterations, cost, gain) at stop_share 0: the true-order model,
        // then the over-fitted one.
        let converged: [(usize, f64, &[f64]); 2] = [
            (
                4,
                9.603148856515918e-2,
                &[
                    0.5075794899573197,
                    0.006521340483264673,
                    0.10826321741700716,
                    0.4183806977194979,
                ],
            ),
            (
                4,
                9.599734828777039e-2,
                &[
                    0.468193565576175,
                    0.16683033494832022,
                    0.37953521630872517,
                    0.17925880957449006,
                    0.15341459842881996,
                    -0.6927312256668916,
                    0.033917351650080044,
                    0.09982288202564256,
                ],
            ),
        ];
        // Both routes: Levenberg–Marquardt on the records, and BFGS on the
        // covariances finished on the records (no factor).
        let runs = [false, true].into_iter().flat_map(|covariance_start| {
            [&g, &four.model]
                .into_iter()
                .flat_map(move |m| [(m, 0.01, covariance_start), (m, 0.0, covariance_start)])
        });
        let optimum = [converged[0], converged[0], converged[1], converged[1]];
        let optimum = optimum.into_iter().chain(optimum);
        for (i, ((model, share, covariance_start), (_, cost, k))) in runs.zip(optimum).enumerate() {
            let opts = GainCheckOptions {
                stop_share: share,
                covariance_start,
                ..Default::default()
            };
            let (got, report) =
                check_kalman_gain_memo(model, None, &exps, 10, &opts, &mut VarxMemo::default());
            let got = got.expect("gain");
            let final_cost = report.final_cost.expect("cost");
            // (The cost reported is the one a run of the kept gain gives,
            // bit for bit, though it comes from the accepting run's errors.)
            let x0s = simulation_states(model, &exps).expect("x0");
            let spread = output_spread(&exps, 2);
            let run = prediction_cost(model, &got, &exps, &x0s, &spread).expect("cost");
            assert_eq!(final_cost.to_bits(), run.to_bits());
            if covariance_start {
                assert_eq!(report.factors, 0, "{report:?}");
                assert!(report.covariance_iterations.is_some(), "{report:?}");
            } else {
                assert_eq!(report.factors, 1, "{report:?}");
                assert!(report.iterations > 0, "{report:?}");
            }
            if share == 0.0 {
                // Levenberg–Marquardt's last steps from a fresh factor
                // reach the optimum to rounding; the quasi-Newton steps on
                // the records stop at a decrease below 1e-9 of the cost,
                // superlinearly near the optimum: within 1e-8 of it.
                let close = if covariance_start { 1e-8 } else { 1e-11 };
                assert_relative_eq!(final_cost, cost, max_relative = close);
                if i % 4 == 1 {
                    for (a, b) in got.iter().zip(k) {
                        assert!((a - b).abs() <= 1e-5, "{got} vs {k:?}");
                    }
                }
            } else {
                let tolerance = opts.tolerance(2 * u.nrows());
                assert!(final_cost >= cost * (1.0 - 1e-11), "{final_cost} {cost}");
                assert!(
                    final_cost <= cost * (1.0 + tolerance),
                    "{final_cost} {cost} {tolerance}"
                );
            }
        }
    }

    /// The rows folded on a second thread give the R factor of the rows
    /// folded here, bit for bit (several full blocks and a partial one).
    #[test]
    fn the_folding_thread_gives_the_same_factor() {
        let rows = 5 * BLOCK_ROWS + 77;
        let value = |i: usize, j: usize| (((i * 31 + j * 17) % 101) as f64 - 50.3) / 7.0;
        let fold = |parallel| {
            fold_rows(6, parallel, |blocks| {
                for i in 0..rows {
                    let (block, at) = blocks.row();
                    for j in 0..6 {
                        block[(at, j)] = value(i, j);
                    }
                }
            })
            .expect("factor")
        };
        let (here, there) = (fold(false), fold(true));
        let bits = |m: &DMatrix<f64>| m.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&here), bits(&there));
        // A row not finite: no factor either way.
        for parallel in [false, true] {
            let r = fold_rows(2, parallel, |blocks| {
                for i in 0..rows {
                    let (block, at) = blocks.row();
                    block[(at, 0)] = if i == 3 * BLOCK_ROWS { f64::NAN } else { 1.0 };
                    block[(at, 1)] = value(i, 1);
                }
            });
            assert!(r.is_none(), "parallel {parallel}");
        }
    }

    /// Records with output samples not measured (NaN: a multirate
    /// record, the second output every third sample) are checked on the
    /// measured samples: the predictor corrects with the outputs measured
    /// at each instant, the VARX regression is skipped (it needs every
    /// sample), and from K = 0 the minimisation lowers the one-step cost
    /// to that of the true K or below (measured: 0.1346 → 0.1242; the true
    /// K's 0.1246, a constant gain at the measured samples being a
    /// different predictor from the full-rate record's). A non-finite value
    /// other than NaN leaves the gain, with the reason.
    #[test]
    fn missing_outputs_are_skipped_and_infinite_ones_leave_the_gain() {
        let (g, k_true, u, mut y) = record(6000, 4);
        for t in (0..y.nrows()).filter(|t| t % 3 != 0) {
            y[(t, 1)] = f64::NAN;
        }
        let exps = [Experiment { u: &u, y: &y }];
        let (k, report) = check_kalman_gain(&g, None, &exps, 10);
        assert!(k.is_some(), "{report:?}");
        // (The covariance route needs every output: its errors of a
        // constant gain are then a filter of the start's.)
        assert_eq!(report.covariance_iterations, None, "{report:?}");
        assert!(
            report
                .note
                .as_deref()
                .is_some_and(|n| n.contains("not measured")),
            "{report:?}"
        );
        let (zero, last) = (
            report.zero_cost.expect("K = 0"),
            report.final_cost.expect("final"),
        );
        assert!(last < 0.95 * zero, "{report:?}");
        let x0s = simulation_states(&g, &exps).expect("x0");
        let truth =
            prediction_cost(&g, &k_true, &exps, &x0s, &output_spread(&exps, 2)).expect("true K");
        assert!(last <= truth * 1.001, "{last} vs {truth}");
        y[(9, 0)] = f64::INFINITY;
        let exps = [Experiment { u: &u, y: &y }];
        let (k, report) = check_kalman_gain(&g, Some(&k_true), &exps, 10);
        assert_eq!(k, Some(k_true));
        assert!(report.note.expect("note").contains("non-finite"));
    }
}

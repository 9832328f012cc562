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

use crate::model::Experiment;
use crate::one_step::Sensitivities;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

mod minimise;
mod varx;

use minimise::{ExactRuns, minimise, minimise_from_covariances};
use varx::{output_spread, regression_gain, simulation_states};

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
pub(super) struct Limits {
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
pub(super) type KeptInnovations = ((u64, bool), usize, bool, Vec<DMatrix<f64>>);

/// A record's (u, y), each column centred by its mean.
pub(super) type CentredRecord = (DMatrix<f64>, DMatrix<f64>);

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
pub(super) fn check_by(
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
pub(super) fn starts_name(riccati: Option<&DMatrix<f64>>) -> &'static str {
    if riccati.is_some() {
        "state-sequence covariances (Riccati)"
    } else {
        "none"
    }
}

/// [`GainCheck::rule`].
pub(super) const RULE: &str = "one-step prediction error on the records (normalised squared error, mean over the outputs; the predictor started from the state the simulation is fitted from, as `validate` does): the best of three starts (subspace step, regression on VARX innovations, K = 0), then minimised over K with A, B, C, D fixed and A − K C stable (BFGS on the covariances of the start's one-step errors finished by quasi-Newton on the records, or Levenberg–Marquardt on the records)";

/// Records of at least this many samples have the starts' costs computed
/// on a second thread while the regression runs (below it a thread costs
/// more than it saves).
pub(super) const PARALLEL_SAMPLES: usize = 20_000;

/// Rows of [J | r] folded into the R factor at a time.
pub(super) const BLOCK_ROWS: usize = 2048;

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
pub(super) const MODEL_AGREEMENT: f64 = 1.5;

#[cfg(test)]
mod tests;

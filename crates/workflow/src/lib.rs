//! # lifted-workflow
//!
//! The identification workflow shared by every front end of Lifted — the
//! `lifted` command, `lifted studio` and the Python package — so that the
//! same data and the same options give the same model everywhere. The
//! front ends only parse their input into a [`WorkflowOptions`] and records,
//! call this crate, and print.
//!
//! ## Stages
//!
//! A run ([`identify`] on records in memory, [`identify_streamed`] on one
//! record read in blocks) goes through:
//!
//! 1. **Data and preprocessing** ([`DataOptions`]): the offsets removed
//!    (per-channel means, or least-squares lines), stored with the model as
//!    its operating point (u₀, y₀), so the model maps u − u₀ to y − y₀.
//!    Single-rate N4SID/MOESP/CVA remove the means inside the
//!    identification, where the output-error regression of (B, D, x₀) also
//!    estimates the constant offset a response that started at rest keeps.
//!    Every route but the q-Markov Cover (subspace, multirate, PBSID/SSARX,
//!    IV) then works on every channel divided by its standard deviation
//!    over the first 10⁴ rows of the first record, and the model, K, the
//!    operating point and a multirate route's lifted model are brought back
//!    to the data's units, so the model does not depend on the units a
//!    channel is logged in (N4SID's and MOESP's projections weight the
//!    outputs by them); the q-Markov Cover takes the data as they are (its
//!    PRBS amplitudes are in the data's units).
//! 2. **Identification** ([`IdentificationOptions`]): the route the method
//!    and the data call for — single-rate weighted subspace identification
//!    (N4SID, MOESP, CVA: the oblique projection O_f = Y_f /_{U_f} W_p,
//!    the SVD of W₁ O_f W₂ = U S Vᵀ, Γ = U₁ S₁^{1/2}, then (A, C) from the
//!    shift invariance Γ↑ A = Γ↓ and (B, D, x₀) by output-error least
//!    squares; Van Overschee & De Moor 1996, ch. 4), the lifted multirate
//!    route with fast-model extraction (thesis chs. 4–5; records of inputs
//!    held one sample also start from the single-rate model of the record
//!    with its slow outputs interpolated, the start that fits the measured
//!    samples better after the refinement kept: `multirate_start`; their
//!    automatic order is judged on the record's last third, an order whose
//!    start is unstable on the first two thirds by its refinement from the
//!    stabilised start — the flexible arm with its output every third
//!    sample: order 3, fit −0.0 %, before; order 9, 97.3 %), the weighted
//!    q-Markov Cover (Zhu 2000), PBSID/SSARX (Chiuso 2007, Jansson 2003;
//!    on multirate records, where the lifted loop has a direct term, the
//!    direct prediction-error method on the measured samples from the
//!    multirate starts: `multirate_predictor`, consistent under feedback
//!    without an instrument) and IV subspace (thesis ch. 7). Under the default order rule
//!    ([`OrderCriterion::Validation`]) the horizon s, the (A, C) route and
//!    the order n of a single-rate subspace identification not given are
//!    chosen by the simulation fit on held-out data
//!    (`lifted_subspace::select_structure`: up to 2e4 samples, six
//!    blocks each held out once and the structure identified on the other
//!    five; longer records identified on the first two thirds and scored
//!    on the last third; x₀ of each held-out block estimated). When the
//!    model will be refined and the records are short enough for the
//!    refinement's held-out check, the best three orders are compared by
//!    the held-out fit of the model each delivers (its refinement where the
//!    blocks prefer it), so the order is chosen for the model the user gets
//!    (`structure_selection.refined_shortlist`). The single-rate subspace
//!    model's Kalman gain (from the state-sequence covariances through a
//!    Riccati equation) is checked on the records: it, a regression on
//!    VARX innovations and K = 0 are scored by the one-step prediction
//!    error, and the best is refined by Levenberg–Marquardt over K alone
//!    (A, B, C, D fixed, A − K C stable), so that the one-step predictor
//!    never predicts worse than the simulation on the records
//!    (`kalman_gain_route`; records of up to [`GAIN_CHECK_SAMPLES`]
//!    samples, in memory and streamed alike, and the last that many samples
//!    of longer records in memory, `kalman_gain_window`; the single-rate IV route,
//!    which has no noise model of its own, gets its gain the same way from
//!    the regression or K = 0, and so does a multirate model the
//!    refinement gave no gain, from K = 0 on the measured samples; on the
//!    DaISy CD-player arm the Riccati gain's
//!    one-step fit was 64–67 % on the validation half against the
//!    simulation's 72–82 %, now 89 %).
//! 3. **Refinement** ([`RefinementOptions`]): Levenberg–Marquardt on the
//!    one-step prediction error (the innovations form, K free) or on the
//!    simulation error, from exactly the identified model; the refined
//!    model is kept only if its simulation fit is at least as good — on
//!    six held-out blocks for single-rate N4SID/MOESP/CVA records of up to
//!    [`REFINE_CHECK_SAMPLES`] samples when they tell the two apart
//!    (`RefinementOptions::check`: by default a paired t-test or a sign
//!    test of the per-block differences at 95 %, or mean fits more than
//!    [`REFINE_CHECK_MARGIN`] points apart; each block's subspace model and its
//!    refinement fitted to the
//!    other five; closer calls keep the subspace model), else (longer
//!    records, costly checks) on the records. By
//!    default ([`Refine::Auto`]) the prediction-error refinement runs where
//!    it pays: predicted work at most [`AUTO_REFINE_WORK`]
//!    ([`AUTO_REFINE_WORK_JOINT`] on multirate records) or fewer than
//!    [`AUTO_REFINE_SAMPLES`] samples, and a stable estimate; records in
//!    memory over that work — short ones too — are refined with the
//!    iterations stopped at it, one iteration at least
//!    (`refinement_decision` says so), so that the default's cost does
//!    not fall off a cliff at either bound.
//! 4. **Validation** ([`ValidationOptions`]): the spectral radius ρ(A)
//!    always written to the diagnostics (`stability`), an unstable model
//!    carrying a warning that names it; optionally an error instead. The
//!    records are tested for feedback (`diagnostics.feedback`: each
//!    input's Granger test on past innovations — a VARX's errors on
//!    single-rate records, the model's on multirate ones — χ² at 1 %,
//!    [`IdentificationOptions::feedback`]; the VARX on the records before
//!    any model's operating point is removed, so that [`SubspaceCache`]
//!    keeps one test per record for every order); an N4SID/MOESP/CVA model
//!    on a closed loop carries a warning naming the consistent methods.
//!
//! The result, [`Identified`], holds the model file the CLI writes
//! (`lifted_lti::ModelFile`: model, operating point, Kalman gain, the
//! diagnostics JSON with the route, the order and structure selection, the
//! refinement report, the stability and the per-phase profile) and the
//! initial states and singular values the Python package returns.
//!
//! ## Records
//!
//! In memory, a [`Record`] is a `lifted_lti::Dataset` (with the IV
//! instrument columns when used). A record too large for memory is read in
//! blocks from a [`RecordSource`] (the CLI's CSV / `.npy` reader; shards of
//! one record): two passes, O(((m + l) s)² + block) memory whatever its
//! length ([`identify_streamed`], module [`stream`]).
//!
//! ## Example
//!
//! ```
//! use lifted_lti::Dataset;
//! use lifted_workflow::{Order, Record, WorkflowOptions, identify};
//! use nalgebra::DMatrix;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // y(k+1) = 0.8 y(k) + u(k) driven by a ±1 sequence, 400 samples.
//! let n = 400;
//! let u = DMatrix::from_fn(n, 1, |k, _| if (k * 7919) % 13 < 6 { 1.0 } else { -1.0 });
//! let mut y = DMatrix::zeros(n, 1);
//! for k in 1..n {
//!     y[(k, 0)] = 0.8 * y[(k - 1, 0)] + u[(k - 1, 0)];
//! }
//! let mut opts = WorkflowOptions::default();
//! opts.identification.order = Order::Fixed(1);
//! let fit = identify(&[Record::new(Dataset::single_rate(1.0, u, y)?)], &opts)?;
//! let a = fit.file.model.a()[(0, 0)];
//! assert!((a - 0.8).abs() < 1e-6);
//! # Ok(())
//! # }
//! ```

mod cache;
mod covariance;
pub mod diagnostics;
mod error;
mod excitation;
mod feedback;
mod gain;
mod integrators;
mod options;
mod parallel;
mod pipeline;
mod plan;
mod preprocess;
mod refine;
mod routes;
mod selection;
pub mod stream;
mod subspace_options;
mod validate;
mod window;

pub use cache::SubspaceCache;
pub use diagnostics::Diagnostics;
pub use error::{Error, Result};
pub use integrators::INTEGRATOR_TOLERANCE_SCALE;
pub use options::{
    AUTO_REFINE_SAMPLES, AUTO_REFINE_WORK, AUTO_REFINE_WORK_JOINT, BUDGET_NAMES, BdRoute, Budgets,
    COVARIANCE_WORK, DataOptions, Detrend, Estimator, GAIN_CHECK_SAMPLES, IdentificationOptions,
    JUDGE_ITERATIONS, Method, Order, OrderCriterion, REFINE_CHECK_MARGIN, REFINE_CHECK_SAMPLES,
    REFINE_CHECK_WORK, Refine, RefinementOptions, SelectionOptions, ValidationOptions,
    WorkflowOptions,
};
pub use pipeline::{Identified, Record, identify, identify_cached, identify_named};
pub use plan::{DataShape, Plan, Resolved, options_from_plan, resolved_defaults};
pub use preprocess::{ChannelScales, SCALE_ROWS, detrend_sets, deviations};
pub use refine::{
    HeldOutCheck, JUDGE_HELD_OUT, JUDGE_NOT_TOLD_APART, JUDGE_RECORDS, JUDGE_WORSE_ON_RECORDS,
    refine,
};
pub use routes::RouteDetails;
pub use routes::multirate_start::{MULTIRATE_START_SAMPLES, START_INTERPOLATED, START_LIFTED};
pub use stream::{BlockSink, Pass, RecordSource, identify_streamed, streamable};
pub use validate::{
    gain_mismatch, gain_periods, marginal_warning, require_stable, spectral_radius,
    unstable_warning,
};

//! The typed entries of [`super::Diagnostics`]. Each keeps the keys it
//! does not name in `rest`, so an entry reads and writes back unchanged;
//! a field that is always written (`null` where there is no value) is a
//! plain `Option`, one that is written only when it applies is skipped
//! when `None`.

use serde::{Deserialize, Deserializer, Serialize};
use serde_json::{Map, Value};

/// `diagnostics.order_selection`: what the values are (singular values of
/// the weighted data matrix, the Λ diagonal of a cover), the values, the
/// order used and the one the gap suggests.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrderSelection {
    /// What the values are.
    pub kind: String,
    /// The values, largest first.
    pub values: Vec<f64>,
    /// The order used.
    pub order: usize,
    /// The order the largest gap suggests.
    pub suggested_order: usize,
    /// Keys not named above.
    #[serde(flatten)]
    pub rest: Map<String, Value>,
}

/// `diagnostics.order_criterion`: the order rule, its value per order
/// (orders 1, 2, …; `None` where an order was not scored) and the order
/// it selected.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrderCriterion {
    /// The rule (`Gap`, `Svc`, `Aic`, `Aicc`, `Bic`, `Validation`).
    pub criterion: String,
    /// The rule's value for orders 1, 2, ….
    pub values: Vec<Option<f64>>,
    /// The order selected.
    pub selected: usize,
    /// The rule in words, when the held-out selection chose the order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rule: Option<String>,
    /// Keys not named above.
    #[serde(flatten)]
    pub rest: Map<String, Value>,
}

/// `diagnostics.structure_selection`: the held-out choice of order,
/// horizon and (A, C) estimator, with its candidates; or the error that
/// stopped it.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct StructureSelection {
    /// The criterion in words.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub criterion: Option<String>,
    /// The order chosen.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub order: Option<usize>,
    /// The horizon chosen.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub horizon: Option<usize>,
    /// The (A, C) estimator chosen ("shift invariance", "state sequences").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub system: Option<String>,
    /// Held-out blocks.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub folds: Option<usize>,
    /// The held-out fit of the structure chosen (%).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub held_out_fit: Option<f64>,
    /// Every structure scored.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub candidates: Option<Vec<Candidate>>,
    /// The refined shortlist, when it judged the order (`Some(None)`: the
    /// entry written as `null`).
    #[serde(
        default,
        deserialize_with = "written",
        skip_serializing_if = "Option::is_none"
    )]
    pub refined_shortlist: Option<Option<RefinedShortlist>>,
    /// Structures whose model on the whole record was unstable.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unstable_on_whole_record: Option<Vec<Value>>,
    /// Why the selection did not run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Keys not named above.
    #[serde(flatten)]
    pub rest: Map<String, Value>,
}

/// One structure of the held-out selection.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// Its order.
    pub order: usize,
    /// Its held-out fit (%; `None`: not scored).
    #[serde(default)]
    pub fit: Option<f64>,
    /// Its horizon (single-rate routes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub horizon: Option<usize>,
    /// Its (A, C) estimator (single-rate routes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub system: Option<String>,
    /// Its fit on each held-out block (%).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fold_fits: Option<Vec<Option<f64>>>,
    /// Keys not named above.
    #[serde(flatten)]
    pub rest: Map<String, Value>,
}

/// The refined shortlist of an automatic order: the orders whose refined
/// models were scored, and the rule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RefinedShortlist {
    /// The rule in words.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rule: Option<String>,
    /// The order it chose.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub order: Option<usize>,
    /// The orders scored.
    #[serde(default)]
    pub candidates: Vec<ShortlistEntry>,
    /// Keys not named above.
    #[serde(flatten)]
    pub rest: Map<String, Value>,
}

/// One order of the refined shortlist.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShortlistEntry {
    /// The order.
    pub order: usize,
    /// Its score (held-out fit of the model it delivers, %).
    pub score: Option<f64>,
    /// Which model scored it (the subspace model or its refinement), on
    /// the single-rate blocks.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scored_by: Option<String>,
    /// Keys not named above.
    #[serde(flatten)]
    pub rest: Map<String, Value>,
}

/// `diagnostics.compression`: the compression of the data matrices, or a
/// note where the route has none.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Compression {
    /// The compression used.
    Used {
        /// Its name.
        used: String,
        /// The reciprocal condition number met, if measured.
        rcond: Option<f64>,
        /// The compression refused and why, if one was.
        fallback: Option<String>,
    },
    /// Said in words.
    Note(String),
}

/// `diagnostics.stability`: the model's stability.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stability {
    /// ρ(A) < 1.
    pub stable: bool,
    /// A pole on the unit circle within the integrator tolerance.
    pub marginal: bool,
    /// ρ(A).
    pub spectral_radius: Option<f64>,
    /// Poles within the integrator tolerance of z = 1.
    pub integrators: usize,
    /// Keys not named above.
    #[serde(flatten)]
    pub rest: Map<String, Value>,
}

/// `diagnostics.integrators`: poles within the integrator tolerance of
/// z = 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Integrators {
    /// How many.
    pub count: usize,
    /// The tolerance δ.
    pub tolerance: f64,
    /// δ's derivation in words.
    pub derivation: String,
    /// The poles (re, im, |z|).
    #[serde(default)]
    pub poles: Vec<Value>,
    /// A note, when one applies.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// Keys not named above.
    #[serde(flatten)]
    pub rest: Map<String, Value>,
}

/// `diagnostics.feedback`: the feedback test (closed-loop data).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Feedback {
    /// Feedback detected.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detected: Option<bool>,
    /// The verdict in words.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verdict: Option<String>,
    /// Why the test did not run, if so.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    /// Keys not named above (the per-input statistics, the rule).
    #[serde(flatten)]
    pub rest: Map<String, Value>,
}

impl Feedback {
    /// The line the front ends show: the verdict, prefixed by "closed loop
    /// detected" when it was; `None` without a verdict.
    pub fn summary(&self) -> Option<String> {
        let verdict = self.verdict.as_deref()?;
        Some(if self.detected == Some(true) {
            format!("closed loop detected: {verdict}")
        } else {
            verdict.to_string()
        })
    }
}

/// `diagnostics.refinement`: the prediction-error refinement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Refinement {
    /// The method (Levenberg–Marquardt on the prediction or simulation
    /// error).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
    /// The cost minimised.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cost: Option<String>,
    /// Which model was kept (the start or the refined one) and why.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kept: Option<String>,
    /// Its cost at the start and at the end.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial_cost: Option<f64>,
    /// Its cost at the end.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub final_cost: Option<f64>,
    /// Iterations.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iterations: Option<usize>,
    /// Why the iterations stopped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub termination: Option<String>,
    /// Keys not named above.
    #[serde(flatten)]
    pub rest: Map<String, Value>,
}

/// `diagnostics.refinement_judge`: how the refinement was judged.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RefinementJudge {
    /// The rule in words.
    pub rule: String,
    /// What decided ("held-out blocks", "the records").
    pub decided_by: String,
    /// The held-out check's fits, when it ran.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub held_out: Option<Value>,
    /// Keys not named above.
    #[serde(flatten)]
    pub rest: Map<String, Value>,
}

/// `diagnostics.process`: a process model's parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Process {
    /// The model family (e.g. "P1D").
    pub kind: String,
    /// One entry per output.
    pub outputs: Vec<ProcessOutput>,
    /// Keys not named above.
    #[serde(flatten)]
    pub rest: Map<String, Value>,
}

/// One output's process model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProcessOutput {
    /// The parameters' names.
    pub names: Vec<String>,
    /// Their values.
    pub parameters: Vec<Option<f64>>,
    /// Their standard deviations.
    pub std: Vec<Option<f64>>,
    /// Keys not named above.
    #[serde(flatten)]
    pub rest: Map<String, Value>,
}

/// `diagnostics.budgets`: the work budgets in force
/// ([`crate::Budgets`] with the Kalman-gain check's two).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BudgetsUsed {
    /// [`crate::Budgets::auto_refine_work`].
    pub auto_refine_work: f64,
    /// [`crate::Budgets::auto_refine_work_joint`].
    pub auto_refine_work_joint: f64,
    /// [`crate::Budgets::auto_refine_samples`].
    pub auto_refine_samples: usize,
    /// [`crate::Budgets::refine_check_samples`].
    pub refine_check_samples: usize,
    /// [`crate::Budgets::refine_check_work`].
    pub refine_check_work: f64,
    /// [`crate::Budgets::gain_check_samples`].
    pub gain_check_samples: usize,
    /// [`crate::Budgets::covariance_work`] (absent in files written before
    /// it: the default).
    #[serde(default = "default_covariance_work")]
    pub covariance_work: f64,
    /// `lifted_subspace::GainCheckOptions::varx_work`.
    pub gain_check_varx_work: f64,
    /// `lifted_subspace::GainCheckOptions::minimise_work`.
    pub gain_check_minimise_work: f64,
}

fn default_covariance_work() -> f64 {
    crate::options::COVARIANCE_WORK
}

impl BudgetsUsed {
    /// The budgets `b` with the Kalman-gain check's two (`gain`).
    pub fn of(b: &crate::Budgets, gain: &lifted_subspace::GainCheckOptions) -> Self {
        BudgetsUsed {
            auto_refine_work: b.auto_refine_work,
            auto_refine_work_joint: b.auto_refine_work_joint,
            auto_refine_samples: b.auto_refine_samples,
            refine_check_samples: b.refine_check_samples,
            refine_check_work: b.refine_check_work,
            covariance_work: b.covariance_work,
            gain_check_samples: b.gain_check_samples,
            gain_check_varx_work: gain.varx_work,
            gain_check_minimise_work: gain.minimise_work,
        }
    }
}

/// An entry that may be written as `null`: absent → `None` (by
/// `default`), `null` → `Some(None)`.
fn written<'de, D, T>(d: D) -> Result<Option<Option<T>>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    Option::<T>::deserialize(d).map(Some)
}

//! The diagnostics of a model: one [`Diagnostics`] type (serde), written by
//! the workflow into the model file (`ModelFile::diagnostics`, the JSON
//! object every `lifted identify` file has carried) and read as this type
//! by the command line, the studio, the report and the Python package.
//!
//! The entries every front end reads are typed fields: the route, the run
//! facts (samples, periods, wall times), the order selection and the
//! criterion behind it, the held-out structure selection, warnings, the
//! stability and integrators, the feedback test, the Kalman-gain check,
//! the refinement and how it was judged, a process model's parameters, the
//! options, plan, budgets and selection policy the model was made with.
//! What only one route writes (a multirate extraction, a PBSID past
//! selection, a q-Markov cover's Markov error, …) is kept by name in
//! [`Diagnostics::details`], so a file's diagnostics read and write back
//! unchanged.
//!
//! [`Diagnostics::read`] loads the diagnostics of older model files: an
//! entry whose form no longer fits its field is kept untyped in `details`
//! and named in [`Diagnostics::unread`] (the reason from serde), never a
//! refusal of the file; [`Diagnostics::strict`] refuses instead (the
//! workflow's own output, in tests).

mod build;
mod entries;
mod load;

pub(crate) use build::*;
pub use entries::*;

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

use crate::options::{SelectionOptions, WorkflowOptions};
use crate::plan::Plan;

/// The diagnostics of a model (module docs). Every field is optional: a
/// route writes the entries that apply to it; `None` (or an empty list) is
/// "not written", never a default standing in for a value.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Diagnostics {
    /// The route that made the model, in words.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub route: Option<String>,
    /// Samples identified, all records together.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples: Option<usize>,
    /// The base (fast) sampling period, seconds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_period: Option<f64>,
    /// Each output's period in base samples (1: every sample).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output_periods: Option<Vec<usize>>,
    /// The data files read (the command line).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub data: Option<Vec<String>>,
    /// Wall time per phase, seconds (`read_s`, `compress_s`, `svd_s`,
    /// `kalman_gain_s`, `refine_s`, `identify_s`, …).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub profile: Option<std::collections::BTreeMap<String, f64>>,
    /// What the user should know about the model (an unstable or marginal
    /// model, a capped search, a start kept).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// Routes refused and the one used instead.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fallbacks: Option<Vec<String>>,
    /// Notes of the identification (e.g. PBSID's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub notes: Option<Vec<String>>,
    /// The past and future horizons of a subspace identification.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub horizons: Option<Vec<usize>>,
    /// The singular values (or Λ diagonal) the order was read from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub order_selection: Option<OrderSelection>,
    /// The order rule's value per order and the order it selected.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub order_criterion: Option<OrderCriterion>,
    /// The held-out structure selection (order, horizon, estimator).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub structure_selection: Option<StructureSelection>,
    /// The compression of the data matrices (or a note where it did not
    /// apply).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compression: Option<Compression>,
    /// The subspace step stabilised its estimate of A.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stabilized: Option<bool>,
    /// The model's stability, always measured by the validation stage.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stability: Option<Stability>,
    /// Poles within the integrator tolerance of z = 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub integrators: Option<Integrators>,
    /// The feedback test on the records (closed-loop data).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feedback: Option<Feedback>,
    /// The Kalman-gain check.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kalman_gain_route: Option<lifted_subspace::GainCheck>,
    /// The prediction-error refinement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refinement: Option<Refinement>,
    /// How the refinement was judged (held-out blocks or the records).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refinement_judge: Option<RefinementJudge>,
    /// Why the automatic refinement ran or not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refinement_decision: Option<String>,
    /// A process model's parameters with their standard deviations.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub process: Option<Process>,
    /// The options the run was given (`None` fields: left to the route).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub options: Option<WorkflowOptions>,
    /// What the defaults decided on these records, said before the work.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plan: Option<Plan>,
    /// The work budgets in force.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub budgets: Option<BudgetsUsed>,
    /// The selection policy an automatic order was chosen by.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub selection_policy: Option<SelectionOptions>,
    /// The entries only some routes write, by name (module docs).
    #[serde(flatten)]
    pub details: Map<String, Value>,
    /// Entries of an older file whose form did not fit their field: kept
    /// in `details`, named here with the reason (not serialised).
    #[serde(skip)]
    pub unread: Vec<String>,
}

/// The typed fields' names (the keys of [`Diagnostics`] other than
/// `details`), as the Python package mirrors them.
pub const FIELDS: [&str; 27] = [
    "route",
    "samples",
    "base_period",
    "output_periods",
    "data",
    "profile",
    "warnings",
    "fallbacks",
    "notes",
    "horizons",
    "order_selection",
    "order_criterion",
    "structure_selection",
    "compression",
    "stabilized",
    "stability",
    "integrators",
    "feedback",
    "kalman_gain_route",
    "refinement",
    "refinement_judge",
    "refinement_decision",
    "process",
    "options",
    "plan",
    "budgets",
    "selection_policy",
];

impl Diagnostics {
    /// The diagnostics of a model file: older files' entries that no
    /// longer fit their field kept untyped and named in
    /// [`Diagnostics::unread`]. O(size of the JSON).
    pub fn read(v: &Value) -> Diagnostics {
        load::lenient(v)
    }

    /// The diagnostics of a model file's entry `file.diagnostics`.
    pub fn of(file: &lifted_lti::ModelFile) -> Diagnostics {
        Self::read(&file.diagnostics)
    }

    /// As [`Diagnostics::read`], refusing an entry that does not fit its
    /// field (the workflow's own output: tests).
    pub fn strict(v: &Value) -> crate::Result<Diagnostics> {
        load::strict(v)
    }

    /// The JSON object written into the model file.
    pub fn to_value(&self) -> Value {
        serde_json::to_value(self).unwrap_or_else(|_| Value::Object(Map::new()))
    }

    /// The wall time of phase `key` (seconds), if recorded.
    pub fn phase(&self, key: &str) -> Option<f64> {
        self.profile.as_ref()?.get(key).copied()
    }

    /// The method that made the model as the options name it.
    pub fn method(&self) -> Option<crate::Method> {
        self.options.as_ref().map(|o| o.identification.method)
    }
}

#[cfg(test)]
mod tests;

//! String options: one table per option type, read by one conversion
//! ([`Choice`]). The names are exactly the `Literal` aliases of
//! `lifted._types` (a test checks both lists against each other); there are
//! no aliases, and the error message lists the accepted names.

use lifted_lti::C2dMethod;
use lifted_sim::Feedback;
use lifted_subspace::{Method, PbsidVariant, SystemEstimate};
use pyo3::prelude::*;

use crate::errors::arg_error;

/// An option type spelled by a fixed set of names.
pub(crate) trait Choice: Sized + Clone + 'static {
    /// What the option chooses, for messages ("subspace method").
    const WHAT: &'static str;
    /// The names and their values, in the order the docs list them.
    const NAMES: &'static [(&'static str, Self)];

    /// The value named `text` (case-insensitive), or an `ArgumentError`
    /// naming `argument` and listing the names.
    fn parse(text: &str, argument: &str) -> PyResult<Self> {
        let lower = text.to_ascii_lowercase();
        Self::NAMES
            .iter()
            .find(|(n, _)| *n == lower)
            .map(|(_, v)| v.clone())
            .ok_or_else(|| {
                let names: Vec<String> =
                    Self::NAMES.iter().map(|(n, _)| format!("'{n}'")).collect();
                arg_error(
                    argument,
                    format!(
                        "unknown {} '{text}' (expected one of {})",
                        Self::WHAT,
                        names.join(", ")
                    ),
                )
            })
    }
}

impl Choice for Method {
    const WHAT: &'static str = "subspace method";
    const NAMES: &'static [(&'static str, Self)] = &[
        ("n4sid", Method::N4sid),
        ("moesp", Method::Moesp),
        ("cva", Method::Cva),
    ];
}

impl Choice for lifted_workflow::Method {
    const WHAT: &'static str = "identification method";
    const NAMES: &'static [(&'static str, Self)] = &[
        ("n4sid", Self::N4sid),
        ("moesp", Self::Moesp),
        ("cva", Self::Cva),
        ("pbsid", Self::Pbsid),
        ("ssarx", Self::Ssarx),
        ("pbsid_rowwise", Self::PbsidRowwise),
        ("iv", Self::Iv),
        ("arx", Self::Arx),
        ("fir", Self::Fir),
        ("oe", Self::Oe),
        ("armax", Self::Armax),
        ("bj", Self::Bj),
        ("process", Self::Process),
        ("impulse", Self::Impulse),
    ];
}

impl Choice for SystemEstimate {
    const WHAT: &'static str = "system estimate";
    const NAMES: &'static [(&'static str, Self)] = &[
        ("shift", SystemEstimate::ShiftInvariance),
        ("states", SystemEstimate::StateSequence),
    ];
}

impl Choice for PbsidVariant {
    const WHAT: &'static str = "closed-loop subspace variant";
    const NAMES: &'static [(&'static str, Self)] = &[
        ("pbsid", PbsidVariant::Optimized),
        ("pbsid_rowwise", PbsidVariant::RowWise),
        ("ssarx", PbsidVariant::Ssarx),
    ];
}

impl Choice for Feedback {
    const WHAT: &'static str = "feedback";
    const NAMES: &'static [(&'static str, Self)] =
        &[("fast", Feedback::Fast), ("hold_last", Feedback::HoldLast)];
}

/// The c2d methods without their parameters (Tustin's pre-warping
/// frequency is its own argument).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Discretization {
    Zoh,
    Foh,
    Tustin,
}

impl Discretization {
    /// The lifted-lti method, with `prewarp` for Tustin.
    pub(crate) fn method(self, prewarp: Option<f64>) -> C2dMethod {
        match self {
            Discretization::Zoh => C2dMethod::Zoh,
            Discretization::Foh => C2dMethod::Foh,
            Discretization::Tustin => C2dMethod::Tustin { prewarp },
        }
    }
}

impl Choice for Discretization {
    const WHAT: &'static str = "c2d method";
    const NAMES: &'static [(&'static str, Self)] = &[
        ("zoh", Discretization::Zoh),
        ("foh", Discretization::Foh),
        ("tustin", Discretization::Tustin),
    ];
}

/// The two receding-horizon laws of lifted-mpc.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum MpcKind {
    /// State-space MPC (GPC-like), `StateSpaceMpc`.
    Gpc,
    /// Dynamic matrix control on step-response coefficients, `Dmc`.
    Dmc,
}

impl Choice for MpcKind {
    const WHAT: &'static str = "MPC kind";
    const NAMES: &'static [(&'static str, Self)] = &[("gpc", MpcKind::Gpc), ("dmc", MpcKind::Dmc)];
}

impl Choice for lifted_workflow::OrderCriterion {
    const WHAT: &'static str = "order criterion";
    const NAMES: &'static [(&'static str, Self)] = &[
        ("validation", Self::Validation),
        ("gap", Self::Gap),
        ("svc", Self::Svc),
        ("aic", Self::Aic),
        ("aicc", Self::Aicc),
        ("bic", Self::Bic),
    ];
}

impl Choice for lifted_workflow::BdRoute {
    const WHAT: &'static str = "(B, D) route";
    const NAMES: &'static [(&'static str, Self)] = &[
        ("auto", Self::Auto),
        ("output_error", Self::OutputError),
        ("projection", Self::Projection),
    ];
}

impl Choice for lifted_workflow::Detrend {
    const WHAT: &'static str = "detrend";
    const NAMES: &'static [(&'static str, Self)] = &[
        ("none", Self::None),
        ("mean", Self::Mean),
        ("linear", Self::Linear),
    ];
}

impl Choice for lifted_workflow::Refine {
    const WHAT: &'static str = "refinement";
    const NAMES: &'static [(&'static str, Self)] = &[
        ("auto", Self::Auto),
        ("none", Self::None),
        ("pem", Self::Pem),
        ("oe", Self::Oe),
    ];
}

impl Choice for lifted_lti::InitialCondition {
    const WHAT: &'static str = "initial state";
    const NAMES: &'static [(&'static str, Self)] =
        &[("estimate", Self::Estimate), ("zero", Self::Zero)];
}

/// Every option type and its names, for `lifted._lifted._choices()` (the
/// test that keeps the `Literal` aliases in step).
pub(crate) fn all() -> Vec<(&'static str, Vec<&'static str>)> {
    fn names<T: Choice>() -> Vec<&'static str> {
        T::NAMES.iter().map(|(n, _)| *n).collect()
    }
    vec![
        ("SubspaceMethod", names::<Method>()),
        ("IdentifyMethod", names::<lifted_workflow::Method>()),
        ("SystemEstimate", names::<SystemEstimate>()),
        ("PbsidVariant", names::<PbsidVariant>()),
        ("Feedback", names::<Feedback>()),
        ("C2dMethod", names::<Discretization>()),
        ("MpcKind", names::<MpcKind>()),
        ("OrderCriterion", names::<lifted_workflow::OrderCriterion>()),
        ("BdRoute", names::<lifted_workflow::BdRoute>()),
        ("Detrend", names::<lifted_workflow::Detrend>()),
        ("Refine", names::<lifted_workflow::Refine>()),
        ("InitialState", names::<lifted_lti::InitialCondition>()),
    ]
}

impl Choice for lifted_pem::ProcessKind {
    const WHAT: &'static str = "process-model structure";
    const NAMES: &'static [(&'static str, Self)] = &[
        ("p1d", Self::P1D),
        ("p2d", Self::P2D),
        ("p1di", Self::P1DI),
        ("p2dz", Self::P2DZ),
        ("p2du", Self::P2DU),
    ];
}

impl Choice for lifted_pem::Kernel {
    const WHAT: &'static str = "kernel";
    const NAMES: &'static [(&'static str, Self)] = &[("tc", Self::Tc), ("dc", Self::Dc)];
}

impl Choice for lifted_pem::InterSample {
    const WHAT: &'static str = "inter-sample behaviour";
    const NAMES: &'static [(&'static str, Self)] = &[("zoh", Self::Zoh), ("foh", Self::Foh)];
}

impl Choice for lifted_pem::FStructure {
    const WHAT: &'static str = "denominators of OE";
    const NAMES: &'static [(&'static str, Self)] =
        &[("per-input", Self::PerInput), ("common", Self::Common)];
}

impl Choice for lifted_pem::AStructure {
    const WHAT: &'static str = "pattern of A";
    const NAMES: &'static [(&'static str, Self)] =
        &[("full", Self::Full), ("diagonal", Self::Diagonal)];
}

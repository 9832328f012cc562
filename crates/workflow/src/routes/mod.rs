//! The identification routes on records in memory: single-rate
//! N4SID/MOESP/CVA (with the held-out structure selection), multirate
//! lifted subspace, q-Markov Cover, PBSID/SSARX and IV (single-rate and
//! multirate). Each returns the model, its diagnostics entry and what the
//! front ends show besides (initial states, singular values).

pub(crate) mod feedthrough;
pub(crate) mod iv;
pub(crate) mod multirate;
pub(crate) mod multirate_check;
pub(crate) mod multirate_predictor;
pub(crate) mod multirate_start;
pub(crate) mod pbsid;
pub(crate) mod polynomial;
pub(crate) mod process;
pub(crate) mod qmarkov;
pub(crate) mod subspace;

pub(crate) use iv::iv;
pub(crate) use multirate::multirate;
pub(crate) use pbsid::pbsid;
pub(crate) use qmarkov::qmarkov;
pub(crate) use subspace::{SubspaceRoute, subspace};

use lifted_lti::{Dataset, StateSpace};
use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result};

/// What a route gives: the model, the diagnostics entry, the Kalman gain,
/// and what the front ends show besides.
pub(crate) struct RouteFit {
    pub model: StateSpace,
    pub diagnostics: serde_json::Value,
    pub kalman_gain: Option<DMatrix<f64>>,
    pub x0: Vec<DVector<f64>>,
    pub singular_values: Vec<f64>,
    pub order: usize,
    pub suggested_order: usize,
    pub details: RouteDetails,
}

/// What some routes give besides the model, for the front ends that show
/// it (the Python package's result objects): empty on the other routes.
#[derive(Debug, Clone, Default)]
pub struct RouteDetails {
    /// Multirate routes: the lifted model the fast model was extracted
    /// from (before any refinement of the fast model).
    pub lifted: Option<StateSpace>,
    /// Multirate routes: the lifting period (base periods).
    pub lifting_period: Option<usize>,
    /// Multirate routes: the record's channel behind each lifted input and
    /// each lifted output (in the lifted model's column / row order), so
    /// that the lifted model can be put in the data's units.
    pub lifted_channels: Option<(Vec<usize>, Vec<usize>)>,
    /// q-Markov Cover: the Markov parameters estimated from the data,
    /// `H_0 … H_{q−1}`.
    pub markov_data: Vec<DMatrix<f64>>,
    /// q-Markov Cover: the Markov parameters of the identified cover (before
    /// any refinement).
    pub markov_model: Vec<DMatrix<f64>>,
    /// ARX and FIR: the polynomial model, in the data's units (with its
    /// noise covariance and parameter covariance); the model file carries
    /// it too (`ModelFile::polynomial`).
    pub polynomial: Option<lifted_lti::PolyModel>,
}

impl RouteFit {
    pub(crate) fn plain(
        model: StateSpace,
        diagnostics: serde_json::Value,
        sv: &[f64],
        suggested: usize,
    ) -> Self {
        let order = model.order();
        RouteFit {
            model,
            diagnostics,
            kalman_gain: None,
            x0: Vec::new(),
            singular_values: sv.to_vec(),
            order,
            suggested_order: suggested,
            details: RouteDetails::default(),
        }
    }

    pub(crate) fn with_details(mut self, details: RouteDetails) -> Self {
        self.details = details;
        self
    }
}

/// The one record of a route that takes one.
pub(crate) fn single<'a>(sets: &'a [Dataset], what: &str) -> Result<&'a Dataset> {
    match sets {
        [one] => Ok(one),
        _ => Err(Error::Data(format!(
            "{what} takes one data file (got {}); concatenate the records",
            sets.len()
        ))),
    }
}

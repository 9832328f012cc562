//! What the subspace identification takes and returns: records
//! ([`Experiment`]), the model with its noise model and diagnostics
//! ([`SubspaceModel`]).

use lifted_lti::{OperatingPoint, StateSpace};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::hankel::CompressionReport;
use crate::options::Method;
use crate::order::OrderReport;

/// Noise covariances of x(k+1) = Ax + Bu + w, y = Cx + Du + v.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseCovariances {
    /// E[w wᵀ] (n×n).
    pub q: DMatrix<f64>,
    /// E[v vᵀ] (n_y×n_y).
    pub r: DMatrix<f64>,
    /// E[w vᵀ] (n×n_y).
    pub s: DMatrix<f64>,
}

/// Order-selection data and other diagnostics of an identification.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostics {
    /// Method used.
    pub method: Method,
    /// All singular values of the weighted projection W₁ Φ W₂ (descending;
    /// N4SID's and MOESP's in the units of y, CVA's are canonical
    /// correlations).
    pub singular_values: Vec<f64>,
    /// Order used.
    pub order: usize,
    /// Order suggested by the gap rule (whatever was used).
    pub suggested_order: usize,
    /// The order criterion of the options with its value for every
    /// candidate order and the order it selects (for a fixed order: the
    /// orders up to min((f − 1) n_y, 10)).
    pub order_selection: OrderReport,
    /// Past and future horizons.
    pub horizons: (usize, usize),
    /// Hankel columns J (all records).
    pub columns: usize,
    /// True if A was re-estimated to make it stable.
    pub stabilized: bool,
    /// Why no Kalman gain was returned, if requested but not available.
    pub noise_model_error: Option<String>,
    /// Approximate flop count of the Hankel compression actually run
    /// (QR 2Jk²(1 + k/b), correlations 2 N n_z² s + k³/3).
    pub compression_flops: f64,
    /// Which compression was used, the reciprocal condition of the
    /// correlation matrix and the reason of a fallback to the QR (as
    /// SLICOT's IWARN).
    pub compression: CompressionReport,
    /// Wall time per phase.
    pub profile: Profile,
    /// The route that gave (B, D) and x₀.
    pub bd_route: BdRoute,
    /// Every fallback taken on the way to the model (a route refused and
    /// the one used instead), human readable; empty when none.
    pub fallbacks: Vec<String>,
    /// Spectral radius ρ(A) of the returned model (≥ 1: unstable; a
    /// simulation of it diverges and its simulation fit is meaningless).
    pub spectral_radius: f64,
}

/// The route that gave (B, D) and x₀ ([`Diagnostics::bd_route`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum BdRoute {
    /// Output-error least squares over the records ([`BdEstimate::OutputError`](crate::BdEstimate::OutputError)).
    OutputError,
    /// The MOESP projection on the compressed data ([`BdEstimate::Projection`](crate::BdEstimate::Projection)).
    Projection,
    /// The state-sequence regression ([`SystemEstimate::StateSequence`](crate::SystemEstimate::StateSequence)).
    StateSequence,
}

impl BdRoute {
    /// Human-readable name.
    pub fn name(self) -> &'static str {
        match self {
            BdRoute::OutputError => "output-error least squares on the data",
            BdRoute::Projection => "projection on the compressed data",
            BdRoute::StateSequence => "state-sequence regression",
        }
    }
}

/// Wall time of the phases of an identification, seconds (for
/// `lifted identify --profile`). Reading the data is the caller's.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Profile {
    /// Hankel compression (for [`StreamingIdentifier`](crate::StreamingIdentifier): the final
    /// factorisation only; the accumulation runs inside the pushes, whose
    /// time the caller measures).
    pub compress_s: f64,
    /// Projections, weights and the SVD of the weighted projection.
    pub svd_s: f64,
    /// Order choice, (A, B, C, D), initial states and the noise model.
    pub estimate_s: f64,
}

/// An identified model with its noise model and diagnostics.
#[derive(Debug, Clone, PartialEq)]
pub struct SubspaceModel {
    /// The deterministic model (A, B, C, D) with sample period `ts`.
    pub model: StateSpace,
    /// Kalman (predictor) gain K, x(k+1) = Ax + Bu + K e (n×n_y).
    pub kalman_gain: Option<DMatrix<f64>>,
    /// Innovation-form noise covariances (Q, R, S).
    pub noise: Option<NoiseCovariances>,
    /// Estimated initial state per record (of the deviation record when
    /// means were removed; empty when streaming).
    pub x0: Vec<DVector<f64>>,
    /// The means removed from u and y ([`SubspaceOptions::remove_means`](crate::SubspaceOptions::remove_means));
    /// the model maps u − u₀ to y − y₀. `None` when the data were used as
    /// given.
    pub operating_point: Option<OperatingPoint>,
    /// The constant output offset per record estimated with (B, D, x₀)
    /// when means were removed (the deviations of a response that started
    /// at rest keep an O(1/N) constant); already folded into
    /// `operating_point`. Empty on the other routes.
    pub output_offsets: Vec<DVector<f64>>,
    /// Singular values, orders and other diagnostics.
    pub diagnostics: Diagnostics,
}

/// One data record (experiment) for [`identify`](crate::identify): u (N×n_u), y (N×n_y).
#[derive(Debug, Clone, Copy)]
pub struct Experiment<'a> {
    /// Inputs, one row per sample.
    pub u: &'a DMatrix<f64>,
    /// Outputs, one row per sample.
    pub y: &'a DMatrix<f64>,
}

/// `op` with the constant output offsets the (B, D, x₀) regression estimated
/// per record (the O(1/N) constant the deviations of a response that started
/// at rest keep) folded into y₀, weighted by the records' `lengths`; `op`
/// itself without offsets.
pub(crate) fn fold_output_offsets(
    op: &OperatingPoint,
    lengths: &[usize],
    offsets: &[DVector<f64>],
) -> Result<OperatingPoint> {
    let total: usize = lengths.iter().sum();
    let mut y0 = op.y0.clone();
    for (len, c) in lengths.iter().zip(offsets) {
        let w = *len as f64 / total.max(1) as f64;
        for (v, ci) in y0.iter_mut().zip(c.iter()) {
            *v += w * ci;
        }
    }
    Ok(OperatingPoint::new(op.u0.clone(), y0)?)
}

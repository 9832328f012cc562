//! Horizons, weights and constraints shared by [`crate::Dmc`] and [`crate::StateSpaceMpc`].

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// Tuning of a receding-horizon controller (thesis §8.2, objective (8.9)).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MpcOptions {
    /// Prediction horizon h (fast samples). Default 12 (thesis §8.3 table).
    pub prediction_horizon: usize,
    /// Control horizon m ≤ h: moves Δu(t+m … t+h−1) are zero. Default 3 (§8.3).
    pub control_horizon: usize,
    /// Output weight Q per prediction step (p×p, symmetric positive
    /// semidefinite); `None` is the identity (§8.3 "identity matrix").
    pub output_weight: Option<DMatrix<f64>>,
    /// Move weight R per control step (m×m, symmetric positive semidefinite);
    /// `None` is the identity (§8.3).
    pub move_weight: Option<DMatrix<f64>>,
    /// Input, rate and output limits (not in the thesis). Default: none.
    pub constraints: Constraints,
}

impl Default for MpcOptions {
    fn default() -> Self {
        Self {
            prediction_horizon: 12,
            control_horizon: 3,
            output_weight: None,
            move_weight: None,
            constraints: Constraints::default(),
        }
    }
}

/// Limits enforced over the horizon by solving a QP (clarabel). All default to
/// `None` (unconstrained: the closed-form gain K_c of §8.2.1 is used).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Constraints {
    /// Lower input limit u_min (length m) on u(t … t+m−1).
    pub u_min: Option<DVector<f64>>,
    /// Upper input limit u_max (length m).
    pub u_max: Option<DVector<f64>>,
    /// Rate limit |Δu| ≤ du_max (length m, entries ≥ 0).
    pub du_max: Option<DVector<f64>>,
    /// Lower output limit on the predictions ŷ(t+1 … t+h) (length p).
    pub y_min: Option<DVector<f64>>,
    /// Upper output limit on the predictions (length p).
    pub y_max: Option<DVector<f64>>,
}

impl Constraints {
    /// True when no limit is set.
    pub fn is_empty(&self) -> bool {
        self.u_min.is_none()
            && self.u_max.is_none()
            && self.du_max.is_none()
            && self.y_min.is_none()
            && self.y_max.is_none()
    }
}

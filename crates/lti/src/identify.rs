//! The identifier interface shared by every identification crate
//! (q-Markov Cover, subspace, multirate, closed-loop).
//!
//! An [`Identifier`] turns one or more experiments on the same plant
//! ([`Dataset`]s with the same channel layout) into a discrete state-space
//! model at the data's output period, plus method-specific diagnostics
//! (singular values, chosen order, identifiability flags, …).
//! [`check_experiments`] is the common validation every implementation runs
//! first.
//!
//! ```
//! use lifted_lti::data::{DataError, Dataset};
//! use lifted_lti::identify::{check_experiments, Identified, Identifier};
//! use lifted_lti::StateSpace;
//! use nalgebra::DMatrix;
//!
//! /// Fits a static gain y = d·u by least squares.
//! struct StaticGain;
//!
//! impl Identifier for StaticGain {
//!     type Diagnostics = f64; // residual sum of squares
//!     type Error = DataError;
//!     fn name(&self) -> &'static str {
//!         "static gain"
//!     }
//!     fn identify(&self, experiments: &[Dataset]) -> Result<Identified<f64>, DataError> {
//!         let layout = check_experiments(experiments)?;
//!         let (mut suy, mut suu) = (0.0, 0.0);
//!         for e in experiments {
//!             for k in 0..e.len() {
//!                 suy += e.u()[(k, 0)] * e.y()[(k, 0)];
//!                 suu += e.u()[(k, 0)].powi(2);
//!             }
//!         }
//!         let d = suy / suu;
//!         let rss = experiments.iter().map(|e| (0..e.len()).map(|k| (e.y()[(k, 0)] - d * e.u()[(k, 0)]).powi(2)).sum::<f64>()).sum();
//!         let model = StateSpace::gain(DMatrix::from_element(1, 1, d), Some(layout.ts))
//!             .map_err(|_| DataError::InvalidSamplePeriod { ts: layout.ts })?;
//!         Ok(Identified { model, diagnostics: rss })
//!     }
//! }
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let u = DMatrix::from_row_slice(4, 1, &[1.0, -1.0, 2.0, 0.5]);
//! let y = &u * 3.0;
//! let data = Dataset::single_rate(0.1, u, y)?;
//! let id = StaticGain.identify(&[data])?;
//! assert!((id.model.d()[(0, 0)] - 3.0).abs() < 1e-12);
//! # Ok(())
//! # }
//! ```

use crate::data::{DataError, DataResult, Dataset, InputChannel, OutputChannel};
use crate::ss::StateSpace;

/// An identified model and the method's diagnostics.
#[derive(Debug, Clone, PartialEq)]
pub struct Identified<D> {
    /// The identified discrete model (at the data's output period).
    pub model: StateSpace,
    /// Method-specific diagnostics (singular values, order, flags, …).
    pub diagnostics: D,
}

/// A system-identification method.
pub trait Identifier {
    /// Diagnostics returned beside the model.
    type Diagnostics;
    /// The method's error type.
    type Error: std::error::Error + Send + Sync + 'static;
    /// Short name of the method, e.g. "q-Markov Cover".
    fn name(&self) -> &'static str;
    /// Identify a discrete model (at the data's output period) from one or more experiments of the same plant.
    fn identify(
        &self,
        experiments: &[Dataset],
    ) -> Result<Identified<Self::Diagnostics>, Self::Error>;
}

/// The channel layout shared by a set of experiments ([`check_experiments`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ExperimentLayout {
    /// Base period T (equal in all experiments, relative tolerance 1e-9).
    pub ts: f64,
    /// Input channels of experiment 0 (holds equal in all experiments; hold
    /// phases may differ).
    pub inputs: Vec<InputChannel>,
    /// Output channels of experiment 0 (periods equal in all experiments;
    /// offsets may differ).
    pub outputs: Vec<OutputChannel>,
    /// Total number of fast samples over all experiments.
    pub total_samples: usize,
}

/// Checks that experiments can be merged: at least one, same base period,
/// same numbers of inputs and outputs, same holds and output periods.
/// Errors: [`DataError::NoExperiments`], [`DataError::IncompatibleExperiments`]. O(number of channels × experiments).
pub fn check_experiments(experiments: &[Dataset]) -> DataResult<ExperimentLayout> {
    let first = experiments.first().ok_or(DataError::NoExperiments)?;
    for (index, e) in experiments.iter().enumerate().skip(1) {
        let bad = |reason: String| Err(DataError::IncompatibleExperiments { index, reason });
        if (e.ts() - first.ts()).abs() > 1e-9 * first.ts() {
            return bad(format!("base period {} vs {}", e.ts(), first.ts()));
        }
        if e.n_inputs() != first.n_inputs() || e.n_outputs() != first.n_outputs() {
            return bad(format!(
                "{}x{} channels vs {}x{}",
                e.n_outputs(),
                e.n_inputs(),
                first.n_outputs(),
                first.n_inputs()
            ));
        }
        for (i, (a, b)) in e.inputs().iter().zip(first.inputs()).enumerate() {
            if a.hold != b.hold {
                return bad(format!("input {i} hold {} vs {}", a.hold, b.hold));
            }
        }
        for (i, (a, b)) in e.outputs().iter().zip(first.outputs()).enumerate() {
            if a.period != b.period {
                return bad(format!("output {i} period {} vs {}", a.period, b.period));
            }
        }
    }
    Ok(ExperimentLayout {
        ts: first.ts(),
        inputs: first.inputs().to_vec(),
        outputs: first.outputs().to_vec(),
        total_samples: experiments.iter().map(Dataset::len).sum(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    #[test]
    fn experiments_checked() {
        let a = Dataset::single_rate(0.1, DMatrix::zeros(5, 1), DMatrix::zeros(5, 1)).unwrap();
        let b = Dataset::single_rate(0.1, DMatrix::zeros(7, 1), DMatrix::zeros(7, 1)).unwrap();
        let c = Dataset::single_rate(0.2, DMatrix::zeros(7, 1), DMatrix::zeros(7, 1)).unwrap();
        let d = Dataset::single_rate(0.1, DMatrix::zeros(7, 2), DMatrix::zeros(7, 1)).unwrap();
        assert_eq!(
            check_experiments(&[a.clone(), b.clone()])
                .unwrap()
                .total_samples,
            12
        );
        assert!(matches!(
            check_experiments(&[]),
            Err(DataError::NoExperiments)
        ));
        assert!(matches!(
            check_experiments(&[a.clone(), c]),
            Err(DataError::IncompatibleExperiments { index: 1, .. })
        ));
        assert!(matches!(
            check_experiments(&[a, b, d]),
            Err(DataError::IncompatibleExperiments { index: 2, .. })
        ));
    }
}

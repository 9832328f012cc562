//! The common [`Identifier`] interface on [`Dataset`]s.

use lifted_lti::identify::check_experiments;
use lifted_lti::{Dataset, Identified, Identifier};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::identify::{ChannelRecord, Diagnostics, identify_records};
use crate::options::QMarkovOptions;

/// The weighted multirate q-Markov Cover as an [`Identifier`].
///
/// Each [`Dataset`] is one experiment; experiment `l` excites input channel `l`
/// only (the other input columns must be zero), so there are as many experiments as
/// inputs. Every output must be sampled at every base period (no NaN). The
/// model is at the data's base period `ts`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct QMarkov {
    /// The options (q, r, Q, n_r, PRBS, ...).
    pub options: QMarkovOptions,
}

impl QMarkov {
    /// An identifier with these options.
    pub fn new(options: QMarkovOptions) -> Self {
        Self { options }
    }

    /// Converts the experiments into one [`ChannelRecord`] per input channel and
    /// returns them with the base period.
    ///
    /// # Errors
    /// [`Error::Data`] (incompatible experiments), [`Error::ChannelCount`] (not one
    /// experiment per input), [`Error::CrossExcitation`], [`Error::InvalidOption`]
    /// (a declared input hold other than 1 or `n_r`).
    pub fn records(&self, experiments: &[Dataset]) -> Result<(Vec<ChannelRecord>, f64)> {
        if experiments.is_empty() {
            return Err(Error::NoExperiments);
        }
        let layout = check_experiments(experiments)?;
        let nw = layout.inputs.len();
        if experiments.len() != nw {
            return Err(Error::ChannelCount {
                what: "experiments (one per input channel)",
                expected: nw,
                got: experiments.len(),
            });
        }
        for (l, ch) in layout.inputs.iter().enumerate() {
            if ch.hold != 1 && ch.hold != self.options.hold {
                return Err(Error::InvalidOption {
                    what: "hold",
                    reason: format!(
                        "input {l} is declared held {} samples but n_r = {}",
                        ch.hold, self.options.hold
                    ),
                });
            }
        }
        let records = experiments
            .iter()
            .enumerate()
            .map(|(l, e)| {
                let u: &DMatrix<f64> = e.u();
                for j in 0..nw {
                    if j != l && u.column(j).iter().any(|&v| v != 0.0) {
                        return Err(Error::CrossExcitation {
                            experiment: l,
                            channel: j,
                        });
                    }
                }
                Ok(ChannelRecord {
                    input: u.column(l).iter().copied().collect(),
                    output: e.y().clone(),
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok((records, layout.ts))
    }
}

impl Identifier for QMarkov {
    type Diagnostics = Diagnostics;
    type Error = Error;

    fn name(&self) -> &'static str {
        "weighted multirate q-Markov Cover"
    }

    /// See [`identify_records`]; the experiments are converted by
    /// [`QMarkov::records`].
    fn identify(&self, experiments: &[Dataset]) -> Result<Identified<Diagnostics>> {
        let (records, ts) = self.records(experiments)?;
        identify_records(&records, ts, &self.options)
    }
}

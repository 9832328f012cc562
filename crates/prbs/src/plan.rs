//! Multichannel experiment plans (Zhu 2000 §III.D step 2, spec A1.4).
//!
//! The output is a `DMatrix<f64>` with one row per fast sample and one column per
//! channel (the workspace convention).

use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, check_amplitude};
use crate::inverse::{InversePrbs, InversePrbsOptions};
use crate::random::binary_from_rng;

/// How the channels share the experiment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum ChannelScheme {
    /// One channel excited at a time (what the q-Markov Cover needs, Zhu 2000
    /// §III.D step 2): block `l` applies the inverse PRBS `a_l u` to channel `l`
    /// only, the others are 0. Default.
    #[default]
    OneAtATime,
    /// All channels at once with the same inverse PRBS, channel `l` delayed by
    /// `l · d` generation samples, `d = ⌊m / channels⌋`. The mutual shifts stay in
    /// `1 … m−1`, so the zero-lag cross-correlations (normalised by `1/(2m)`) are
    /// `±n_r a_i a_j/m` (eqs. II-6, II-10), never `±n_r a_i a_j`.
    Shifted,
    /// All channels at once, each with an independent random binary sequence of
    /// period `2m` (generation rate), held `n_r`, from its own `ChaCha8Rng` stream
    /// (`seed`, stream `l`); repeated like the PRBS so the response is periodic.
    Independent {
        /// Seed of the `ChaCha8Rng`.
        seed: u64,
    },
}

/// Options of a multichannel plan. Validated by [`ExperimentPlan::new`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PlanOptions {
    /// Order, hold `n_r` and taps of the inverse PRBS (its `amplitude` is ignored:
    /// see `amplitudes`). Default: [`InversePrbsOptions::default`].
    pub prbs: InversePrbsOptions,
    /// Magnitudes `a_l`, one per channel (A1.4, III-13). Default `[1.0]`.
    pub amplitudes: Vec<f64>,
    /// Channel scheme. Default [`ChannelScheme::OneAtATime`].
    pub scheme: ChannelScheme,
    /// Periods `2 n_r m` applied before the recorded ones, so the response reaches its
    /// periodic steady state (Zhu 2000 §III.D step 2, erratum Z-12). Default 1.
    pub settle_periods: usize,
    /// Recorded periods per block (≥ 1). Default 1.
    pub record_periods: usize,
}

impl Default for PlanOptions {
    fn default() -> Self {
        Self {
            prbs: InversePrbsOptions::default(),
            amplitudes: vec![1.0],
            scheme: ChannelScheme::OneAtATime,
            settle_periods: 1,
            record_periods: 1,
        }
    }
}

/// One block of a plan, in fast samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Segment {
    /// Excited channel, or `None` when all channels are excited together.
    pub channel: Option<usize>,
    /// First sample of the block.
    pub start: usize,
    /// Block length (settling plus recorded periods).
    pub len: usize,
    /// First sample of the recorded part (after settling).
    pub record_start: usize,
    /// Length of the recorded part.
    pub record_len: usize,
}

/// A validated multichannel experiment: blocks and the input matrix.
/// Serialised as its [`PlanOptions`] and validated again when loaded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "PlanOptions", into = "PlanOptions")]
pub struct ExperimentPlan {
    options: PlanOptions,
    prbs: InversePrbs,
    segments: Vec<Segment>,
}

impl TryFrom<PlanOptions> for ExperimentPlan {
    type Error = Error;

    fn try_from(options: PlanOptions) -> Result<Self> {
        Self::new(&options)
    }
}

impl From<ExperimentPlan> for PlanOptions {
    fn from(plan: ExperimentPlan) -> Self {
        plan.options
    }
}

impl ExperimentPlan {
    /// Validates `options` and lays out the blocks.
    ///
    /// # Errors
    /// [`Error::EmptyChannelSet`], [`Error::InvalidAmplitude`] (any `a_l`),
    /// [`Error::ZeroLength`] (`record_periods = 0`), [`Error::TooManyChannels`]
    /// (shifted scheme with more channels than `m`), [`Error::TooLong`] (the signal
    /// matrix would exceed [`crate::MAX_SIGNAL_ENTRIES`] entries), and the errors of
    /// [`InversePrbs::new`].
    pub fn new(options: &PlanOptions) -> Result<Self> {
        if options.amplitudes.is_empty() {
            return Err(Error::EmptyChannelSet);
        }
        for &a in &options.amplitudes {
            check_amplitude(a)?;
        }
        if options.record_periods == 0 {
            return Err(Error::ZeroLength {
                what: "record_periods",
            });
        }
        let prbs = InversePrbs::new(&InversePrbsOptions {
            amplitude: 1.0,
            ..options.prbs.clone()
        })?;
        let channels = options.amplitudes.len();
        if options.scheme == ChannelScheme::Shifted && channels as u64 > prbs.m() {
            return Err(Error::TooManyChannels {
                channels,
                half_period: prbs.m() as usize,
            });
        }
        let total = u128::from(prbs.period())
            * (options.settle_periods as u128 + options.record_periods as u128)
            * if options.scheme == ChannelScheme::OneAtATime {
                channels as u128
            } else {
                1
            }
            * channels as u128;
        if total > crate::MAX_SIGNAL_ENTRIES {
            return Err(Error::TooLong {
                samples: total,
                max: crate::MAX_SIGNAL_ENTRIES,
            });
        }
        let period = prbs.period() as usize;
        let block = (options.settle_periods + options.record_periods) * period;
        let record_len = options.record_periods * period;
        let settle = options.settle_periods * period;
        let segments = match options.scheme {
            ChannelScheme::OneAtATime => (0..channels)
                .map(|l| Segment {
                    channel: Some(l),
                    start: l * block,
                    len: block,
                    record_start: l * block + settle,
                    record_len,
                })
                .collect(),
            _ => vec![Segment {
                channel: None,
                start: 0,
                len: block,
                record_start: settle,
                record_len,
            }],
        };
        Ok(Self {
            options: options.clone(),
            prbs,
            segments,
        })
    }

    /// The options of this plan.
    pub fn options(&self) -> &PlanOptions {
        &self.options
    }

    /// Number of channels `n_w`.
    pub fn channels(&self) -> usize {
        self.options.amplitudes.len()
    }

    /// Total number of fast samples.
    pub fn len(&self) -> usize {
        self.segments.last().map_or(0, |s| s.start + s.len)
    }

    /// Whether the plan has no sample (never true for a validated plan).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Fast-rate period `2 n_r m` of the excitation.
    pub fn period(&self) -> usize {
        self.prbs.period() as usize
    }

    /// Shift (generation samples) between consecutive channels in the shifted scheme,
    /// `d = ⌊m / channels⌋`.
    pub fn shift(&self) -> usize {
        (self.prbs.m() as usize) / self.channels()
    }

    /// The blocks.
    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// The unit-amplitude inverse PRBS used by the plan.
    pub fn prbs(&self) -> &InversePrbs {
        &self.prbs
    }

    /// The input matrix: one row per fast sample, one column per channel.
    /// O(len · channels).
    pub fn signal(&self) -> DMatrix<f64> {
        let (len, ch) = (self.len(), self.channels());
        let period = self.period();
        let hold = self.prbs.hold();
        let one = self.prbs.one_period();
        let amps = &self.options.amplitudes;
        let mut out = DMatrix::zeros(len, ch);
        match self.options.scheme {
            ChannelScheme::OneAtATime => {
                for seg in &self.segments {
                    if let Some(l) = seg.channel {
                        for k in 0..seg.len {
                            out[(seg.start + k, l)] = amps[l] * one[k % period];
                        }
                    }
                }
            }
            ChannelScheme::Shifted => {
                let d = self.shift() * hold;
                for (l, &a) in amps.iter().enumerate() {
                    for k in 0..len {
                        // Channel l is delayed by l·d fast samples.
                        let idx = (k + period - (l * d) % period) % period;
                        out[(k, l)] = a * one[idx];
                    }
                }
            }
            ChannelScheme::Independent { seed } => {
                let slow = 2 * self.prbs.m() as usize;
                for (l, &a) in amps.iter().enumerate() {
                    let mut rng = ChaCha8Rng::seed_from_u64(seed);
                    rng.set_stream(l as u64);
                    let seq = binary_from_rng(&mut rng, slow * hold, a, hold);
                    for k in 0..len {
                        out[(k, l)] = seq[k % period];
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod unit {
    use super::*;

    #[test]
    fn default_plan_layout() {
        let plan = ExperimentPlan::new(&PlanOptions::default()).unwrap();
        // Order 8, n_r = 1: one channel, settle 1 + record 1 periods of 510 samples.
        assert_eq!(plan.period(), 510);
        assert_eq!(plan.len(), 1020);
        assert_eq!(plan.segments()[0].record_start, 510);
        assert_eq!(plan.signal().shape(), (1020, 1));
    }
}

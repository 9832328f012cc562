//! The simulator: loop structure, sampling, noise, runs.

use lifted_lti::{Dataset, InputChannel, OutputChannel, StateSpace};
use nalgebra::DMatrix;

use crate::engine::{Block, Engine, FeedbackKind, Record, RunInput, Structure};
use crate::error::{Error, Result};
use crate::model::{Controller, Plant, WholeLoop, check_discrete_at};
use crate::noise::{NoiseGen, NoiseSpec, snr_scale};

/// What the controller sees of the outputs.
// Built once per simulator: the variant size does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Feedback {
    /// Every output at every fast sample (default).
    #[default]
    Fast,
    /// Each output as last sampled (zero-order hold of the slow measurement).
    HoldLast,
    /// Inferential switch (thesis §9.3, Fig. 9.4; spec A3.11): output j is
    /// fed back as measured when its channel samples, and as the prediction
    /// ŷ = P̂u of an **uncorrected** parallel model in between:
    /// v(k) = y(k) if k ≡ offset (mod period), else ŷ(k). P̂ is a discrete
    /// n_y × n_u model at the base period.
    Inferential(StateSpace),
}

/// Simulation options.
#[derive(Debug, Clone, PartialEq)]
pub struct SimOptions {
    /// A run fails with [`Error::Diverged`] as soon as |y| or |u| exceeds
    /// this value or becomes non-finite (unstable loops are reported, never
    /// returned as NaNs). Default 1e12.
    pub divergence_limit: f64,
    /// Which samples an SNR level is measured on. Default
    /// [`SnrSamples::Fast`].
    pub snr_samples: SnrSamples,
}

impl Default for SimOptions {
    fn default() -> Self {
        SimOptions {
            divergence_limit: 1e12,
            snr_samples: SnrSamples::Fast,
        }
    }
}

/// The samples on which the variances of an SNR level are taken (the
/// papers do not say; spec §0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SnrSamples {
    /// Every fast sample of the record (default).
    #[default]
    Fast,
    /// Only the samples at which each output channel is measured (its
    /// period and offset): the SNR an analyst computes from the data set.
    Measured,
}

/// Exogenous signals, one row per fast sample.
///
/// r₁ (N × n_y) is the reference (setpoint) and r₂ (N × n_u) the excitation
/// added at the plant input: u = r₂ + K(r₁ − v) (spec A2.2). In open loop
/// u = r₂. Missing signals are zero.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Excitation {
    /// Reference r₁, N × n_y.
    pub r1: Option<DMatrix<f64>>,
    /// Plant-input excitation r₂, N × n_u.
    pub r2: Option<DMatrix<f64>>,
}

impl Excitation {
    /// Excitation at the plant input only (open-loop input u = r₂).
    pub fn input(r2: DMatrix<f64>) -> Self {
        Excitation {
            r1: None,
            r2: Some(r2),
        }
    }

    /// Excitation at the reference only.
    pub fn reference(r1: DMatrix<f64>) -> Self {
        Excitation {
            r1: Some(r1),
            r2: None,
        }
    }

    /// Both.
    pub fn both(r1: DMatrix<f64>, r2: DMatrix<f64>) -> Self {
        Excitation {
            r1: Some(r1),
            r2: Some(r2),
        }
    }

    /// Number of samples (0 if both are missing).
    pub fn len(&self) -> usize {
        self.r1
            .as_ref()
            .or(self.r2.as_ref())
            .map_or(0, DMatrix::nrows)
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Everything a run produces.
#[derive(Debug, Clone, PartialEq)]
pub struct SimOutput {
    /// The multirate data set: plant input u and the measured outputs at
    /// their sampling instants (NaN elsewhere), with the channel layout.
    pub data: Dataset,
    /// Measured output (plant output + noise) at every fast sample, N × n_y.
    pub y: DMatrix<f64>,
    /// Plant output without the added noise term, N × n_y (in closed loop it
    /// still contains the noise's effect through the feedback).
    pub y_clean: DMatrix<f64>,
    /// The added output noise (after scaling), N × n_y.
    pub noise: DMatrix<f64>,
    /// Per-output scale applied to the generated noise: the SNR factor, 1 with
    /// an absolute level, 0 without noise.
    pub noise_scale: Vec<f64>,
    /// Simulator state after the last sample (layout:
    /// [`Simulator::state_layout`]).
    pub final_state: Vec<f64>,
}

/// Where each part of the simulator state sits in a state vector such as
/// [`SimOutput::final_state`] or a periodic steady state: index ranges, in
/// this order. Parts a set-up does not have are empty ranges.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StateLayout {
    /// The plant's state (the whole loop's state for [`Simulator::whole_loop`]).
    pub plant: std::ops::Range<usize>,
    /// The controller's state.
    pub controller: std::ops::Range<usize>,
    /// The parallel model P̂ of the inferential feedback.
    pub model: std::ops::Range<usize>,
    /// The plant input of the previous sample (what an input hold repeats).
    pub held_inputs: std::ops::Range<usize>,
    /// The fed-back measurement of the previous sample (hold-last feedback).
    pub held_outputs: std::ops::Range<usize>,
    /// The controller output held between executions of a slow controller.
    pub held_controller: std::ops::Range<usize>,
}

impl StateLayout {
    /// Length of the state vector.
    pub fn len(&self) -> usize {
        self.held_controller.end
    }

    /// True for a state-free simulator (static plant, no holds to keep).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl SimOutput {
    /// Plant input at every fast sample, N × n_u (held values repeated;
    /// the same matrix as `data.u()`).
    pub fn u(&self) -> &DMatrix<f64> {
        self.data.u()
    }
}

/// A configured experiment: plant (+ controller, feedback) or a whole
/// closed-loop model, noise, input holds and output sampling.
#[derive(Debug, Clone)]
pub struct Simulator {
    pub(crate) ts: f64,
    pub(crate) ny: usize,
    pub(crate) nu: usize,
    kind: Kind,
    feedback: Feedback,
    noise: Option<NoiseSpec>,
    inputs: Vec<InputChannel>,
    outputs: Vec<OutputChannel>,
    options: SimOptions,
}

#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
enum Kind {
    Plant {
        plant: Plant,
        controller: Option<Controller>,
    },
    Whole(WholeLoop),
}

impl Simulator {
    /// Open loop: u = r₂ (held per input channel), y = Gu + v.
    pub fn open_loop(plant: Plant) -> Self {
        let (ny, nu) = (plant.model().n_outputs(), plant.model().n_inputs());
        Self::build(
            plant.ts(),
            ny,
            nu,
            Kind::Plant {
                plant,
                controller: None,
            },
        )
    }

    /// Plant with a discrete controller: u = r₂ + K(r₁ − v), y = Gu + v
    /// (negative feedback, spec A2.2). The controller runs every sample when
    /// its model is at the base period, every m samples when it is at m·T
    /// (see [`Controller`]).
    /// Errors: controller dimensions (n_u × n_y), [`Error::ControllerPeriod`],
    /// [`Error::ControllerPhase`].
    pub fn closed_loop(plant: Plant, controller: Controller) -> Result<Self> {
        let (ny, nu) = (plant.model().n_outputs(), plant.model().n_inputs());
        let k = controller.model();
        if k.n_inputs() != ny {
            return Err(Error::DimensionMismatch {
                what: "controller inputs (= plant outputs)",
                expected: ny,
                got: k.n_inputs(),
            });
        }
        if k.n_outputs() != nu {
            return Err(Error::DimensionMismatch {
                what: "controller outputs (= plant inputs)",
                expected: nu,
                got: k.n_outputs(),
            });
        }
        crate::model::controller_period(&controller, plant.ts())?;
        Ok(Self::build(
            plant.ts(),
            ny,
            nu,
            Kind::Plant {
                plant,
                controller: Some(controller),
            },
        ))
    }

    /// A closed loop discretised as a whole ([`WholeLoop`]); noise is added
    /// to the measured output (it does not circulate in the loop), holds
    /// must be 1.
    pub fn whole_loop(cl: WholeLoop) -> Self {
        let ts = cl.model().ts().unwrap_or(f64::NAN);
        let (ny, nu) = (cl.n_outputs(), cl.n_inputs());
        Self::build(ts, ny, nu, Kind::Whole(cl))
    }

    fn build(ts: f64, ny: usize, nu: usize, kind: Kind) -> Self {
        Simulator {
            ts,
            ny,
            nu,
            kind,
            feedback: Feedback::Fast,
            noise: None,
            inputs: (0..nu)
                .map(|i| InputChannel::new(format!("u{}", i + 1), 1))
                .collect(),
            outputs: (0..ny)
                .map(|j| OutputChannel::new(format!("y{}", j + 1), 1, 0))
                .collect(),
            options: SimOptions::default(),
        }
    }

    /// Adds output noise (validated now).
    pub fn with_noise(mut self, noise: NoiseSpec) -> Result<Self> {
        NoiseGen::new(&noise, self.ny, self.ts)?;
        self.noise = Some(noise);
        Ok(self)
    }

    /// Sets the feedback mode (closed loop only; P̂ must be n_y × n_u and
    /// discrete at the base period).
    pub fn with_feedback(mut self, feedback: Feedback) -> Result<Self> {
        if let Feedback::Inferential(p) = &feedback {
            if p.n_outputs() != self.ny || p.n_inputs() != self.nu {
                return Err(Error::DimensionMismatch {
                    what: "inferential model size (n_y·n_u)",
                    expected: self.ny * self.nu,
                    got: p.n_outputs() * p.n_inputs(),
                });
            }
            check_discrete_at("inferential model", p, self.ts)?;
        }
        if feedback != Feedback::Fast
            && !matches!(
                self.kind,
                Kind::Plant {
                    controller: Some(_),
                    ..
                }
            )
        {
            return Err(Error::Unsupported {
                what: "a feedback mode needs a plant with a controller",
            });
        }
        self.feedback = feedback;
        Ok(self)
    }

    /// Sets the input channels (names, units, holds m_i ≥ 1 and hold phases).
    pub fn with_inputs(mut self, inputs: Vec<InputChannel>) -> Result<Self> {
        if inputs.len() != self.nu {
            return Err(Error::DimensionMismatch {
                what: "input channels",
                expected: self.nu,
                got: inputs.len(),
            });
        }
        for (channel, c) in inputs.iter().enumerate() {
            if c.hold == 0 {
                return Err(Error::ZeroHold { channel });
            }
            if c.offset >= c.hold {
                return Err(lifted_lti::DataError::OffsetOutOfRange {
                    what: "input",
                    channel,
                    offset: c.offset,
                    period: c.hold,
                }
                .into());
            }
            if c.hold > 1 && matches!(self.kind, Kind::Whole(_)) {
                return Err(Error::Unsupported {
                    what: "input holds with a whole closed-loop model",
                });
            }
        }
        self.inputs = inputs;
        Ok(self)
    }

    /// Sets the holds m_i (phase 0), keeping the names.
    pub fn with_holds(self, holds: &[usize]) -> Result<Self> {
        if holds.len() != self.nu {
            return Err(Error::DimensionMismatch {
                what: "holds",
                expected: self.nu,
                got: holds.len(),
            });
        }
        let inputs = self
            .inputs
            .iter()
            .zip(holds)
            .map(|(c, &h)| InputChannel {
                hold: h,
                offset: 0,
                ..c.clone()
            })
            .collect();
        self.with_inputs(inputs)
    }

    /// Sets the output channels (names, units, period J_i ≥ 1, offset < J_i).
    pub fn with_outputs(mut self, outputs: Vec<OutputChannel>) -> Result<Self> {
        if outputs.len() != self.ny {
            return Err(Error::DimensionMismatch {
                what: "output channels",
                expected: self.ny,
                got: outputs.len(),
            });
        }
        for (channel, c) in outputs.iter().enumerate() {
            if c.period == 0 {
                return Err(Error::ZeroPeriod { channel });
            }
            if c.offset >= c.period {
                return Err(Error::OffsetOutOfRange {
                    channel,
                    offset: c.offset,
                    period: c.period,
                });
            }
        }
        self.outputs = outputs;
        Ok(self)
    }

    /// Sets (period, offset) per output, keeping the names.
    pub fn with_sampling(self, sampling: &[(usize, usize)]) -> Result<Self> {
        if sampling.len() != self.ny {
            return Err(Error::DimensionMismatch {
                what: "output sampling",
                expected: self.ny,
                got: sampling.len(),
            });
        }
        let outputs = self
            .outputs
            .iter()
            .zip(sampling)
            .map(|(c, &(p, o))| OutputChannel {
                period: p,
                offset: o,
                ..c.clone()
            })
            .collect();
        self.with_outputs(outputs)
    }

    /// Sets the options.
    pub fn with_options(mut self, options: SimOptions) -> Result<Self> {
        if options.divergence_limit.is_nan() || options.divergence_limit <= 0.0 {
            return Err(Error::NonFinite {
                what: "divergence_limit",
                value: options.divergence_limit,
            });
        }
        self.options = options;
        Ok(self)
    }

    /// Base period T.
    pub fn ts(&self) -> f64 {
        self.ts
    }

    /// Number of plant inputs n_u.
    pub fn n_inputs(&self) -> usize {
        self.nu
    }

    /// Number of plant outputs n_y.
    pub fn n_outputs(&self) -> usize {
        self.ny
    }

    /// Input channels.
    pub fn inputs(&self) -> &[InputChannel] {
        &self.inputs
    }

    /// Output channels.
    pub fn outputs(&self) -> &[OutputChannel] {
        &self.outputs
    }

    /// Period of the sampling/hold pattern (lcm of holds and output periods).
    pub fn frame_period(&self) -> usize {
        self.inputs
            .iter()
            .map(|c| c.hold)
            .chain(self.outputs.iter().map(|c| c.period))
            .fold(self.controller_rate().0, crate::engine::lcm)
    }

    /// The layout of the simulator state ([`SimOutput::final_state`], the
    /// periodic steady state): plant, controller, parallel model, then the
    /// held input, measurement and controller-output values.
    pub fn state_layout(&self) -> StateLayout {
        let (ng, nk, np) = match &self.kind {
            Kind::Whole(w) => {
                let n = w.model().order();
                return StateLayout {
                    plant: 0..n,
                    controller: n..n,
                    model: n..n,
                    held_inputs: n..n,
                    held_outputs: n..n,
                    held_controller: n..n,
                };
            }
            Kind::Plant { plant, controller } => (
                plant.model().order(),
                controller.as_ref().map_or(0, |k| k.model().order()),
                match &self.feedback {
                    Feedback::Inferential(p) => p.order(),
                    _ => 0,
                },
            ),
        };
        let has_k = matches!(
            self.kind,
            Kind::Plant {
                controller: Some(_),
                ..
            }
        );
        let nkh = if has_k && self.controller_rate().0 > 1 {
            self.nu
        } else {
            0
        };
        let (k0, p0) = (ng, ng + nk);
        let (u0, v0) = (p0 + np, p0 + np + self.nu);
        let h0 = v0 + self.ny;
        StateLayout {
            plant: 0..ng,
            controller: k0..p0,
            model: p0..u0,
            held_inputs: u0..v0,
            held_outputs: v0..h0,
            held_controller: h0..h0 + nkh,
        }
    }

    /// The controller's (period, phase) in base periods; (1, 0) without one.
    fn controller_rate(&self) -> (usize, usize) {
        match &self.kind {
            Kind::Plant {
                controller: Some(k),
                ..
            } => (
                crate::model::controller_period(k, self.ts).unwrap_or(1),
                k.phase(),
            ),
            _ => (1, 0),
        }
    }

    /// The loop as one discrete LTI model [r₁; r₂] → [y; u] at the base
    /// period (noise-free), for the single-rate cases: fast feedback and
    /// unit holds. Open loop: [y; u] from [r₁; r₂] with r₁ unused.
    pub fn lti_model(&self) -> Result<StateSpace> {
        if self.inputs.iter().any(|c| c.hold != 1)
            || self.feedback != Feedback::Fast
            || self.controller_rate().0 != 1
        {
            return Err(Error::Unsupported {
                what: "lti_model of a multirate (periodically time-varying) loop",
            });
        }
        match &self.kind {
            Kind::Whole(w) => Ok(w.model().clone()),
            Kind::Plant { plant, controller } => {
                let k = match controller {
                    Some(c) => c.model().clone(),
                    None => StateSpace::gain(DMatrix::zeros(self.nu, self.ny), Some(self.ts))?,
                };
                crate::model::closed_loop(plant.model(), &k)
            }
        }
    }

    pub(crate) fn engine(&self) -> Result<Engine> {
        let holds: Vec<(usize, usize)> = self.inputs.iter().map(|c| (c.hold, c.offset)).collect();
        let sampling: Vec<(usize, usize)> =
            self.outputs.iter().map(|c| (c.period, c.offset)).collect();
        let limit = self.options.divergence_limit;
        match &self.kind {
            Kind::Whole(w) => Engine::new(
                Structure::Whole {
                    cl: Block::new(w.model()),
                },
                self.ny,
                self.nu,
                &holds,
                &sampling,
                limit,
            ),
            Kind::Plant { plant, controller } => {
                let g = Block::new(plant.model());
                let k = controller.as_ref().map(|c| Block::new(c.model()));
                let (phat, fb) = match &self.feedback {
                    Feedback::Fast => (None, FeedbackKind::Fast),
                    Feedback::HoldLast => (None, FeedbackKind::HoldLast),
                    Feedback::Inferential(p) => (Some(Block::new(p)), FeedbackKind::Inferential),
                };
                Engine::new(
                    Structure::Loop {
                        g,
                        k,
                        phat,
                        feedback: fb,
                        k_rate: self.controller_rate(),
                    },
                    self.ny,
                    self.nu,
                    &holds,
                    &sampling,
                    limit,
                )
            }
        }
    }

    pub(crate) fn check_excitation(&self, exc: &Excitation) -> Result<usize> {
        let n = exc.len();
        if n == 0 {
            return Err(Error::EmptyExcitation);
        }
        check_signal(
            exc.r1.as_ref(),
            self.ny,
            n,
            [
                "columns of r1 (= outputs)",
                "rows of r1 (= rows of r2)",
                "r1",
            ],
        )?;
        check_signal(
            exc.r2.as_ref(),
            self.nu,
            n,
            [
                "columns of r2 (= inputs)",
                "rows of r2 (= rows of r1)",
                "r2",
            ],
        )?;
        if exc.r1.is_some()
            && matches!(
                self.kind,
                Kind::Plant {
                    controller: None,
                    ..
                }
            )
            && exc.r1.as_ref().is_some_and(|r| r.iter().any(|&v| v != 0.0))
        {
            return Err(Error::Unsupported {
                what: "a reference r1 in open loop (use r2 for the input)",
            });
        }
        Ok(n)
    }

    /// Simulates the excitation from zero initial state.
    ///
    /// The loop runs as one affine map per phase of the sampling pattern,
    /// [z(k+1); y(k); u(k)] = M_ph [z(k); r₁(k); r₂(k); noise(k)], built once
    /// by stepping the block-by-block loop on unit vectors (every loop here
    /// is linear, or periodically linear with holds, hold-last or the
    /// inferential switch): one dense product per sample over the stacked
    /// state. The results equal [`Simulator::simulate_reference`] up to
    /// rounding (≈ 1e-15 relative per step).
    ///
    /// With an SNR level, the loop is run twice (linearity): first noise-free
    /// to get the noise-free output y₀, then with the noise scaled per output
    /// channel so that var(y₀)/var(v) (or the std ratio) equals the request
    /// on this record. O(N(n² + nm)) per run, no allocation in the loop.
    ///
    /// Errors: excitation shape/finiteness, [`Error::Diverged`],
    /// [`Error::ZeroSignalVariance`], and the data-set checks.
    pub fn simulate(&self, exc: &Excitation) -> Result<SimOutput> {
        let engine = self.engine()?;
        let z0 = vec![0.0; engine.nz];
        self.run_from(&engine, &z0, exc)
    }

    /// The same simulation stepped block by block (plant, controller,
    /// parallel model, holds and feedback switch evaluated at every sample):
    /// the reference against which [`Simulator::simulate`] is tested and
    /// benchmarked. Same errors; several times slower.
    pub fn simulate_reference(&self, exc: &Excitation) -> Result<SimOutput> {
        let engine = self.engine()?;
        let z0 = vec![0.0; engine.nz];
        self.run_with(&engine, &z0, exc, true)
    }

    /// Simulates from a given simulator state (e.g. a periodic steady state).
    pub(crate) fn run_from(
        &self,
        engine: &Engine,
        z0: &[f64],
        exc: &Excitation,
    ) -> Result<SimOutput> {
        self.run_with(engine, z0, exc, false)
    }

    /// Simulates the excitation from zero initial state into reusable
    /// buffers: the signals of [`Simulator::simulate`] without building the
    /// [`Dataset`] or copying the excitation. Buffers of the right shape are
    /// overwritten in place (no allocation, no page faults on repeated runs
    /// of the same length); others are reallocated. Same method, results and
    /// errors as [`Simulator::simulate`].
    pub fn simulate_into(&self, exc: &Excitation, out: &mut SimSignals) -> Result<()> {
        let engine = self.engine()?;
        let z0 = vec![0.0; engine.nz];
        self.signals_into(&engine, &z0, exc, false, out)
    }

    fn run_with(
        &self,
        engine: &Engine,
        z0: &[f64],
        exc: &Excitation,
        reference: bool,
    ) -> Result<SimOutput> {
        let mut sig = SimSignals::default();
        self.signals_into(engine, z0, exc, reference, &mut sig)?;
        // The measured samples with NaN between them (what
        // `Dataset::from_fast` does), built channel-wise.
        let mut y_data = sig.y.clone();
        for (j, ch) in self.outputs.iter().enumerate() {
            if ch.period > 1 {
                for (k, v) in y_data.column_mut(j).iter_mut().enumerate() {
                    if !ch.is_sampled(k) {
                        *v = f64::NAN;
                    }
                }
            }
        }
        let data = Dataset::new(
            self.ts,
            sig.u,
            y_data,
            self.inputs.clone(),
            self.outputs.clone(),
        )?;
        Ok(SimOutput {
            data,
            y: sig.y,
            y_clean: sig.y_clean,
            noise: sig.noise,
            noise_scale: sig.noise_scale,
            final_state: sig.final_state,
        })
    }

    fn signals_into(
        &self,
        engine: &Engine,
        z0: &[f64],
        exc: &Excitation,
        reference: bool,
        out: &mut SimSignals,
    ) -> Result<()> {
        let n = self.check_excitation(exc)?;
        let (ny, nu) = (self.ny, self.nu);
        let noise_gen = match &self.noise {
            Some(spec) => Some(NoiseGen::new(spec, ny, self.ts)?),
            None => None,
        };
        let shape = |m: &mut DMatrix<f64>, c: usize| {
            if m.shape() != (n, c) {
                *m = DMatrix::zeros(n, c);
            }
        };
        shape(&mut out.u, nu);
        shape(&mut out.y, ny);
        shape(&mut out.y_clean, ny);
        shape(&mut out.noise, ny);
        let empty = || DMatrix::zeros(0, 0);
        let mut rec = Record {
            u: std::mem::replace(&mut out.u, empty()),
            y: std::mem::replace(&mut out.y, empty()),
            y_clean: std::mem::replace(&mut out.y_clean, empty()),
        };
        let result = self.record_into(engine, z0, exc, reference, noise_gen, &mut rec, out);
        out.u = rec.u;
        out.y = rec.y;
        out.y_clean = rec.y_clean;
        result
    }

    /// The loop runs of [`Simulator::signals_into`]: noise (`out.noise`),
    /// the SNR pass, the recorded run.
    #[allow(clippy::too_many_arguments)]
    fn record_into(
        &self,
        engine: &Engine,
        z0: &[f64],
        exc: &Excitation,
        reference: bool,
        noise_gen: Option<NoiseGen>,
        rec: &mut Record,
        out: &mut SimSignals,
    ) -> Result<()> {
        let n = rec.u.nrows();
        let run = |inp: &RunInput<'_>, rec: &mut Record| {
            if reference {
                engine.run_reference(z0, inp, Some(rec))
            } else {
                engine.run(z0, inp, Some(rec))
            }
        };
        let clean = RunInput {
            r1: exc.r1.as_ref(),
            r2: exc.r2.as_ref(),
            noise: None,
            len: n,
        };
        let Some(noise_gen) = noise_gen else {
            out.final_state = run(&clean, rec)?;
            out.noise.fill(0.0);
            out.noise_scale = vec![0.0; self.ny];
            return Ok(());
        };
        noise_gen.generate_into(&mut out.noise);
        let scale = match &noise_gen.snr {
            Some((ratio, def)) => {
                run(&clean, rec)?;
                let sampled: Vec<(usize, usize)> =
                    self.outputs.iter().map(|c| (c.period, c.offset)).collect();
                let window = match self.options.snr_samples {
                    SnrSamples::Fast => None,
                    SnrSamples::Measured => Some(sampled.as_slice()),
                };
                snr_scale(&rec.y_clean, &out.noise, ratio, *def, window)?
            }
            None => vec![1.0; self.ny],
        };
        out.final_state = run(
            &RunInput {
                noise: Some((&out.noise, &scale)),
                ..clean
            },
            rec,
        )?;
        for (j, &a) in scale.iter().enumerate() {
            out.noise.column_mut(j).scale_mut(a);
        }
        out.noise_scale = scale;
        Ok(())
    }
}

/// Reusable buffers of [`Simulator::simulate_into`]: the signals of a
/// [`SimOutput`] without the data set and the excitation copies.
#[derive(Debug, Clone, PartialEq)]
pub struct SimSignals {
    /// Plant input at every fast sample, N × n_u.
    pub u: DMatrix<f64>,
    /// Measured output (plant output + noise), N × n_y.
    pub y: DMatrix<f64>,
    /// Plant output without the added noise term, N × n_y.
    pub y_clean: DMatrix<f64>,
    /// The added output noise (after scaling), N × n_y.
    pub noise: DMatrix<f64>,
    /// Per-output noise scale (SNR factor, 1 for an absolute level, 0
    /// without noise).
    pub noise_scale: Vec<f64>,
    /// Simulator state after the last sample (layout:
    /// [`Simulator::state_layout`]).
    pub final_state: Vec<f64>,
}

impl Default for SimSignals {
    /// Empty buffers (allocated by the first run).
    fn default() -> Self {
        SimSignals {
            u: DMatrix::zeros(0, 0),
            y: DMatrix::zeros(0, 0),
            y_clean: DMatrix::zeros(0, 0),
            noise: DMatrix::zeros(0, 0),
            noise_scale: Vec::new(),
            final_state: Vec::new(),
        }
    }
}

/// Shape and finiteness of one excitation signal; `what` names the column,
/// row and value checks.
fn check_signal(
    r: Option<&DMatrix<f64>>,
    cols: usize,
    rows: usize,
    what: [&'static str; 3],
) -> Result<()> {
    let Some(r) = r else { return Ok(()) };
    if r.ncols() != cols {
        return Err(Error::DimensionMismatch {
            what: what[0],
            expected: cols,
            got: r.ncols(),
        });
    }
    if r.nrows() != rows {
        return Err(Error::DimensionMismatch {
            what: what[1],
            expected: rows,
            got: r.nrows(),
        });
    }
    match lifted_linalg::first_non_finite(r.as_slice()) {
        Some(k) => Err(Error::NonFinite {
            what: what[2],
            value: r.as_slice()[k],
        }),
        None => Ok(()),
    }
}

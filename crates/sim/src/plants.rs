//! Reference plants of the three seed documents, one fixture per section
//! (the stirred-tank models of §2.6.2, §5.3.1 and §7.8.2 differ: erratum
//! L-14, so they are separate fixtures).
//!
//! Every constructor documents its source. Continuous models keep their
//! delays in [`Fixture::delays`] (seconds) and are discretised exactly by
//! [`Fixture::plant`]; discrete models are at [`Fixture::ts`].

use lifted_lti::{SisoTf, StateSpace, TransferFunction};
use nalgebra::DMatrix;

use crate::error::{Error, Result};
use crate::model::{Controller, Delays, Plant, WholeLoop};
use crate::noise::{NoiseLevel, NoiseSpec, SnrDefinition};
use crate::simulator::{Feedback, Simulator};

/// A reference experiment: plant, noise model, controller, suggested sampling.
#[derive(Debug, Clone, PartialEq)]
pub struct Fixture {
    /// Short name.
    pub name: &'static str,
    /// Source section of the seed documents (and the spec section).
    pub source: &'static str,
    /// Base period T (seconds).
    pub ts: f64,
    /// Plant: continuous (delays in [`Fixture::delays`]) or discrete at `ts`.
    pub plant: StateSpace,
    /// Delays of a continuous plant, seconds.
    pub delays: Delays,
    /// Noise model H (n_y × n_e), continuous or discrete at `ts`, if the source gives one.
    pub noise: Option<StateSpace>,
    /// Controller (n_u × n_y): discrete at `ts`, or continuous when the source
    /// discretises the closed loop as a whole (Ren & Zhu).
    pub controller: Option<StateSpace>,
    /// Parallel model P̂ for inferential feedback (thesis Ch. 9).
    pub parallel_model: Option<StateSpace>,
    /// Suggested output sampling periods J_i (1 = fast).
    pub output_periods: Vec<usize>,
    /// Suggested input holds m_i.
    pub input_holds: Vec<usize>,
}

impl Fixture {
    /// The plant at the base period (ZOH with exact delays for continuous plants).
    pub fn discrete_plant(&self) -> Result<Plant> {
        if self.plant.is_discrete() {
            Plant::discrete(&self.plant, &[], &[])
        } else {
            Plant::continuous(&self.plant, self.ts, &self.delays)
        }
    }

    /// A simulator of the fixture without noise: open loop without a
    /// controller; plant + discrete controller (inferential feedback when a
    /// parallel model is given); or the whole continuous loop discretised at
    /// once when the controller is continuous. Sampling and holds as suggested.
    pub fn simulator(&self) -> Result<Simulator> {
        let sim = match &self.controller {
            None => Simulator::open_loop(self.discrete_plant()?),
            Some(k) if k.is_discrete() => {
                let s = Simulator::closed_loop(self.discrete_plant()?, Controller::from_ss(k)?)?;
                match &self.parallel_model {
                    Some(p) => s.with_feedback(Feedback::Inferential(p.clone()))?,
                    None => s,
                }
            }
            Some(k) => {
                if self
                    .delays
                    .input
                    .iter()
                    .chain(&self.delays.output)
                    .any(|&d| d != 0.0)
                {
                    return Err(Error::Unsupported {
                        what: "whole-loop discretisation of a plant with delay",
                    });
                }
                Simulator::whole_loop(WholeLoop::from_continuous(&self.plant, k, self.ts)?)
            }
        };
        let sim = if self.output_periods.iter().any(|&p| p != 1) {
            let s: Vec<(usize, usize)> = self.output_periods.iter().map(|&p| (p, 0)).collect();
            sim.with_sampling(&s)?
        } else {
            sim
        };
        if self.input_holds.iter().any(|&h| h != 1) {
            sim.with_holds(&self.input_holds)
        } else {
            Ok(sim)
        }
    }

    /// The fixture's noise model at an SNR (None if the source gives no noise model).
    pub fn noise_spec(&self, snr: f64, definition: SnrDefinition, seed: u64) -> Option<NoiseSpec> {
        self.noise.as_ref().map(|m| NoiseSpec {
            model: Some(m.clone()),
            level: NoiseLevel::Snr {
                ratio: vec![snr],
                definition,
            },
            seed,
            ..Default::default()
        })
    }
}

fn tf(num: &[f64], den: &[f64], ts: Option<f64>) -> Result<StateSpace> {
    Ok(TransferFunction::from_coeffs(num, den, ts)?.to_ss()?)
}

fn siso(num: &[f64], den: &[f64]) -> Result<SisoTf> {
    Ok(SisoTf::from_coeffs(num, den)?)
}

fn mimo(rows: Vec<Vec<SisoTf>>, ts: Option<f64>) -> Result<StateSpace> {
    Ok(TransferFunction::from_entries(rows, ts)?.to_ss()?)
}

fn zero() -> Result<SisoTf> {
    siso(&[0.0], &[1.0])
}

/// The §2.6.2 / §7.8.2 disturbance model (spec A3.1 stand-in, A3.9):
/// diag-lower [0.11/(1−0.97z⁻¹), 0; −0.02/(1−0.9z⁻¹), 0.04/(1−0.86z⁻¹)],
/// i.e. 0.11z/(z−0.97) etc. (biproper), driven by two white sources.
fn tank_noise_7_8_2(ts: f64) -> Result<StateSpace> {
    mimo(
        vec![
            vec![siso(&[0.11, 0.0], &[1.0, -0.97])?, zero()?],
            vec![
                siso(&[-0.02, 0.0], &[1.0, -0.9])?,
                siso(&[0.04, 0.0], &[1.0, -0.86])?,
            ],
        ],
        Some(ts),
    )
}

/// The 2x2 stirred tank of thesis §2.6.2 (spec A3.1), T = 1 (one sample = 4 s):
/// G₁₁ = 0.1416/(z−0.9868), G₁₂ = 0, G₂₁ = −0.0379/(z−0.913),
/// G₂₂ = 0.0595/(z−0.9048); minimal order 3. The thesis gives no noise
/// model; the spec's stand-in is the §7.8.2 disturbance model.
pub fn stirred_tank_2_6_2() -> Result<Fixture> {
    let ts = 1.0;
    let plant = mimo(
        vec![
            vec![siso(&[0.1416], &[1.0, -0.9868])?, zero()?],
            vec![
                siso(&[-0.0379], &[1.0, -0.913])?,
                siso(&[0.0595], &[1.0, -0.9048])?,
            ],
        ],
        Some(ts),
    )?;
    Ok(Fixture {
        name: "stirred tank (thesis 2.6.2)",
        source: "Li 2001 §2.6.2; spec A3.1 (noise: stand-in from §7.8.2)",
        ts,
        plant,
        delays: Delays::default(),
        noise: Some(tank_noise_7_8_2(ts)?),
        controller: None,
        parallel_model: None,
        output_periods: vec![1, 1],
        input_holds: vec![1, 1],
    })
}

/// The 2x2 stirred tank of thesis §5.3.1 (spec A3.7), T = 1:
/// G₁₁ = 0.1416z⁻¹/(1−0.9868z⁻¹), G₁₂ = −0.03z⁻¹/(1−0.97z⁻¹),
/// G₂₁ = −0.0379z⁻¹/(1−0.9131z⁻¹), G₂₂ = 0.0595z⁻¹/(1−0.9048z⁻¹); noise
/// [0.11z⁻¹/(1−0.97z⁻¹), −0.03z⁻¹/(1−0.95z⁻¹); −0.02z⁻¹/(1−0.92z⁻¹),
/// 0.04z⁻¹/(1−0.88z⁻¹)]·e. y₁ sampled every 5 (J = 5).
pub fn stirred_tank_5_3_1() -> Result<Fixture> {
    let ts = 1.0;
    let plant = mimo(
        vec![
            vec![
                siso(&[0.1416], &[1.0, -0.9868])?,
                siso(&[-0.03], &[1.0, -0.97])?,
            ],
            vec![
                siso(&[-0.0379], &[1.0, -0.9131])?,
                siso(&[0.0595], &[1.0, -0.9048])?,
            ],
        ],
        Some(ts),
    )?;
    let noise = mimo(
        vec![
            vec![
                siso(&[0.11], &[1.0, -0.97])?,
                siso(&[-0.03], &[1.0, -0.95])?,
            ],
            vec![
                siso(&[-0.02], &[1.0, -0.92])?,
                siso(&[0.04], &[1.0, -0.88])?,
            ],
        ],
        Some(ts),
    )?;
    Ok(Fixture {
        name: "stirred tank (thesis 5.3.1)",
        source: "Li 2001 §5.3.1; spec A3.7",
        ts,
        plant,
        delays: Delays::default(),
        noise: Some(noise),
        controller: None,
        parallel_model: None,
        output_periods: vec![5, 1],
        input_holds: vec![1, 1],
    })
}

/// The multirate stirred tank in closed loop of thesis §7.8.2 (spec A3.9):
/// plant as §2.6.2 (G₁₂ = 0, pole 0.913), PI K = 1.5 + 0.1/(1−z⁻¹) =
/// (1.6z − 1.5)/(z − 1) on u₂ → y₂ only (y₁ open loop), disturbance
/// [0.11/(1−0.97z⁻¹), 0; −0.02/(1−0.9z⁻¹), 0.04/(1−0.86z⁻¹)]; y₁ every 5, y₂ every 1.
pub fn stirred_tank_7_8_2() -> Result<Fixture> {
    let ts = 1.0;
    let base = stirred_tank_2_6_2()?;
    let k = TransferFunction::from_entries(
        vec![
            vec![zero()?, zero()?],
            vec![zero()?, siso(&[1.6, -1.5], &[1.0, -1.0])?],
        ],
        Some(ts),
    )?
    .to_ss()?;
    Ok(Fixture {
        name: "stirred tank in closed loop (thesis 7.8.2)",
        source: "Li 2001 §7.8.2; spec A3.9",
        controller: Some(k),
        output_periods: vec![5, 1],
        ..base
    })
}

/// Engine speed of the diesel-engine fixture.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EngineSpeed {
    /// 1150 rpm.
    Rpm1150,
    /// 1500 rpm.
    Rpm1500,
}

/// The Cummins M11 diesel engine, fuel → speed (Zhu 2000 Table III,
/// corrected per erratum Z-14; spec A1.5), T = 0.0113 s:
/// 1150 rpm: 114(3.2e-5 s² − 0.0159 s + 1)/((s/0.348+1)(s/15.88+1));
/// 1500 rpm: 85.6(6.4e-5 s² − 0.0147 s + 1)/((s/0.383+1)(s/26.95+1)).
/// Suggested excitation (Table II): inverse PRBS a = 2, n = 8, held n_r = 10.
pub fn diesel_engine(speed: EngineSpeed) -> Result<Fixture> {
    let (k, b2, b1, p1, p2) = match speed {
        EngineSpeed::Rpm1150 => (114.0, 3.2e-5, -0.0159, 0.348, 15.88),
        EngineSpeed::Rpm1500 => (85.6, 6.4e-5, -0.0147, 0.383, 26.95),
    };
    let den = [1.0 / (p1 * p2), 1.0 / p1 + 1.0 / p2, 1.0];
    Ok(Fixture {
        name: match speed {
            EngineSpeed::Rpm1150 => "diesel engine 1150 rpm",
            EngineSpeed::Rpm1500 => "diesel engine 1500 rpm",
        },
        source: "Zhu 2000 Table III (erratum Z-14); spec A1.5",
        ts: 0.0113,
        plant: tf(&[k * b2, k * b1, k], &den, None)?,
        delays: Delays::default(),
        noise: None,
        controller: None,
        parallel_model: None,
        output_periods: vec![1],
        input_holds: vec![1],
    })
}

/// Ren & Zhu (2009) plants.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RenZhuPlant {
    /// G₁ = 1/(0.3s + 1).
    G1,
    /// G₂ = 1/(s² + s + 1).
    G2,
}

/// Ren & Zhu (2009) controllers (Tables 2–3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RenZhuController {
    /// Open loop (K = 0).
    Open,
    /// P: K = 0.2.
    P,
    /// First order: K = (s + 0.5)/(s + 1).
    FirstOrder,
    /// PI: (0.2s + 5)/s for G₁, (0.5s + 0.2)/s for G₂.
    Pi,
}

/// Ren & Zhu (2009) continuous plant and controller (spec A2.2), T = 5 ms.
/// The simulator discretises the closed loop **as a whole** (spec A2.3).
pub fn ren_zhu(plant: RenZhuPlant, controller: RenZhuController) -> Result<Fixture> {
    let g = match plant {
        RenZhuPlant::G1 => tf(&[1.0], &[0.3, 1.0], None)?,
        RenZhuPlant::G2 => tf(&[1.0], &[1.0, 1.0, 1.0], None)?,
    };
    let k = match (controller, plant) {
        (RenZhuController::Open, _) => None,
        (RenZhuController::P, _) => Some(tf(&[0.2], &[1.0], None)?),
        (RenZhuController::FirstOrder, _) => Some(tf(&[1.0, 0.5], &[1.0, 1.0], None)?),
        (RenZhuController::Pi, RenZhuPlant::G1) => Some(tf(&[0.2, 5.0], &[1.0, 0.0], None)?),
        (RenZhuController::Pi, RenZhuPlant::G2) => Some(tf(&[0.5, 0.2], &[1.0, 0.0], None)?),
    };
    let k = match k {
        Some(k) => Some(k),
        // open loop: whole-loop model with K = 0
        None => Some(StateSpace::gain(DMatrix::zeros(1, 1), None)?),
    };
    Ok(Fixture {
        name: "Ren & Zhu (2009) loop",
        source: "Ren & Zhu 2009 eqs. 9-13, Tables 2-4; spec A2.2, A2.3",
        ts: 0.005,
        plant: g,
        delays: Delays::default(),
        noise: None,
        controller: k,
        parallel_model: None,
        output_periods: vec![1],
        input_holds: vec![1],
    })
}

/// The thesis' §4.3 loss-of-observability example (spec A3.3), T = 1:
/// `A = [[0.9,0,0],[1,0,0],[0,1,0]]`, B = e₁, C = [0 0 0.1], D = 0,
/// TF 0.1/(z³ − 0.9z²) (erratum L-6). Hold 1, output every 3.
pub fn loss_of_observability() -> Result<Fixture> {
    let a = DMatrix::from_row_slice(3, 3, &[0.9, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let b = DMatrix::from_row_slice(3, 1, &[1.0, 0.0, 0.0]);
    let c = DMatrix::from_row_slice(1, 3, &[0.0, 0.0, 0.1]);
    Ok(Fixture {
        name: "loss of observability (thesis 4.3)",
        source: "Li 2001 §4.3 (erratum L-6); spec A3.3",
        ts: 1.0,
        plant: StateSpace::new(a, b, c, DMatrix::zeros(1, 1), Some(1.0))?,
        delays: Delays::default(),
        noise: None,
        controller: None,
        parallel_model: None,
        output_periods: vec![3],
        input_holds: vec![1],
    })
}

/// P_c = e^{−d_c s}/(20s + 1) at T = 1 with hold m = 2 and output every
/// n = 3 (thesis §4.3 Prop. 2 and §4.4 with d_c = 8.5; spec A3.3, A3.4).
/// Errors: negative delay.
pub fn first_order_with_delay(delay: f64) -> Result<Fixture> {
    if delay.is_nan() || delay < 0.0 {
        return Err(Error::NegativeDelay {
            what: "input",
            index: 0,
            value: delay,
        });
    }
    Ok(Fixture {
        name: "first order with delay (thesis 4.3/4.4)",
        source: "Li 2001 §4.3 Prop. 2, §4.4; spec A3.3, A3.4",
        ts: 1.0,
        plant: tf(&[1.0], &[20.0, 1.0], None)?,
        delays: Delays::input(vec![delay]),
        noise: None,
        controller: None,
        parallel_model: None,
        output_periods: vec![3],
        input_holds: vec![2],
    })
}

/// The thesis' §4.8 example (spec A3.6): P_c = e^{−5s}/(20s + 1), noise
/// N = 1/(10s + 1) (ZOH at T), T = 1, hold m = 2, output every n = 3.
pub fn chapter4_example() -> Result<Fixture> {
    Ok(Fixture {
        name: "thesis 4.8 example",
        source: "Li 2001 §4.8; spec A3.6",
        noise: Some(tf(&[1.0], &[10.0, 1.0], None)?),
        ..first_order_with_delay(5.0)?
    })
}

/// The thesis' §7.8.2 SISO closed loop (spec A3.9), T = 1: process
/// 0.5e^{−s}/(5s + 1) (= 0.09063z⁻²/(1 − 0.81873z⁻¹)), controller
/// 0.25/(1 − z⁻¹) = 0.25z/(z − 1), disturbance 1/(3s + 1) (ZOH:
/// 0.28347z⁻¹/(1 − 0.71653z⁻¹)). Excitation: RBS ±1 at the plant input (r₂).
pub fn chapter7_siso() -> Result<Fixture> {
    Ok(Fixture {
        name: "thesis 7.8.2 SISO closed loop",
        source: "Li 2001 §7.8.2; spec A3.9",
        ts: 1.0,
        plant: tf(&[0.5], &[5.0, 1.0], None)?,
        delays: Delays::input(vec![1.0]),
        noise: Some(tf(&[1.0], &[3.0, 1.0], None)?),
        controller: Some(tf(&[0.25, 0.0], &[1.0, -1.0], Some(1.0))?),
        parallel_model: None,
        output_periods: vec![1],
        input_holds: vec![1],
    })
}

/// The thesis' §9.6 dual-rate inferential example (spec A3.11), T = 1:
/// P = 0.13/(z³(z − 0.92)), P̂ = 0.15/(z − 0.9), K = 3 + 0.5/(1 − z⁻¹) =
/// (3.5z − 3)/(z − 1); output sampled every n = 4, inferential switch
/// v(k) = y(k) if k ≡ 0 (mod 4), else P̂u.
pub fn chapter9_dual_rate() -> Result<Fixture> {
    Ok(Fixture {
        name: "thesis 9.6 dual-rate inferential loop",
        source: "Li 2001 §9.3, §9.6; spec A3.11",
        ts: 1.0,
        plant: tf(&[0.13], &[1.0, -0.92, 0.0, 0.0, 0.0], Some(1.0))?,
        delays: Delays::default(),
        noise: None,
        controller: Some(tf(&[3.5, -3.0], &[1.0, -1.0], Some(1.0))?),
        parallel_model: Some(tf(&[0.15], &[1.0, -0.9], Some(1.0))?),
        output_periods: vec![4],
        input_holds: vec![1],
    })
}

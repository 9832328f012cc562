//! Plants, controllers and closed-loop models at the base period.

use lifted_lti::{C2dOptions, StateSpace, TransferFunction};
use nalgebra::DMatrix;

use crate::error::{Error, Result};

/// Relative tolerance used to compare sample periods.
const TS_TOL: f64 = 1e-9;

pub(crate) fn check_ts(ts: f64) -> Result<()> {
    if ts.is_finite() && ts > 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidSamplePeriod { ts })
    }
}

/// Checks that a discrete model runs at `ts`.
pub(crate) fn check_discrete_at(what: &'static str, sys: &StateSpace, ts: f64) -> Result<()> {
    match sys.ts() {
        None => Err(Error::NotDiscrete { what }),
        Some(t) if (t - ts).abs() > TS_TOL * ts => Err(Error::SamplePeriodMismatch {
            what,
            expected: ts,
            got: t,
        }),
        Some(_) => Ok(()),
    }
}

/// Input and output delays of a continuous plant, in **seconds**.
///
/// Any non-negative value is allowed, including non-integer multiples of
/// the base period T: the delay τ = dT + δ is realised exactly under ZOH
/// (modified z-transform, [`lifted_lti::StateSpace::c2d`]), never rounded.
/// Empty vectors mean no delay.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Delays {
    /// One delay per input (seconds), or empty. Default empty.
    pub input: Vec<f64>,
    /// One delay per output (seconds), or empty. Default empty.
    pub output: Vec<f64>,
}

impl Delays {
    /// The same delay on every input.
    pub fn input(delays: Vec<f64>) -> Self {
        Delays {
            input: delays,
            output: Vec::new(),
        }
    }
}

/// A plant discretised at the base period T (ZOH, delays exact).
#[derive(Debug, Clone, PartialEq)]
pub struct Plant {
    model: StateSpace,
}

impl Plant {
    /// A continuous plant with delays, discretised by ZOH at `ts`.
    ///
    /// Input delays act per input; an output delay τ_i on output i is
    /// realised exactly by discretising row i with the input delays
    /// τ_in + τ_i (an LTI output shift equals a shift of every input), and
    /// stacking the rows (the result is exact, not necessarily minimal).
    /// Cost: one ZOH per distinct output delay, O((n + m)³) each.
    ///
    /// Errors: [`Error::NegativeDelay`], non-finite delays, wrong delay
    /// counts, invalid `ts`, a discrete `sys` ([`lifted_lti::Error::NotContinuous`]).
    pub fn continuous(sys: &StateSpace, ts: f64, delays: &Delays) -> Result<Self> {
        check_ts(ts)?;
        let (p, m) = (sys.n_outputs(), sys.n_inputs());
        let din = check_delays("input", &delays.input, m)?;
        let dout = check_delays("output", &delays.output, p)?;
        if sys.is_discrete() {
            return Err(lifted_lti::Error::NotContinuous {
                what: "Plant::continuous",
            }
            .into());
        }
        let all_equal = dout.iter().all(|&d| d == dout[0]);
        if p == 0 || all_equal {
            let shift = dout.first().copied().unwrap_or(0.0);
            let opts = C2dOptions {
                input_delays: Some(din.iter().map(|d| d + shift).collect()),
                ..Default::default()
            };
            return Ok(Plant {
                model: sys.c2d(ts, &opts)?,
            });
        }
        let mut rows = Vec::with_capacity(p);
        for (i, &d) in dout.iter().enumerate() {
            let row = StateSpace::new(
                sys.a().clone(),
                sys.b().clone(),
                sys.c().rows(i, 1).into_owned(),
                sys.d().rows(i, 1).into_owned(),
                None,
            )?;
            let opts = C2dOptions {
                input_delays: Some(din.iter().map(|x| x + d).collect()),
                ..Default::default()
            };
            rows.push(row.c2d(ts, &opts)?);
        }
        Ok(Plant {
            model: stack_outputs(&rows, Some(ts))?,
        })
    }

    /// A continuous transfer-function plant with delays (see [`Plant::continuous`]).
    pub fn continuous_tf(tf: &TransferFunction, ts: f64, delays: &Delays) -> Result<Self> {
        Self::continuous(&tf.to_ss()?, ts, delays)
    }

    /// A discrete plant at the base period, with optional integer input and
    /// output delays in samples (empty slices: none).
    pub fn discrete(
        sys: &StateSpace,
        input_delays: &[usize],
        output_delays: &[usize],
    ) -> Result<Self> {
        if !sys.is_discrete() {
            return Err(Error::NotDiscrete { what: "plant" });
        }
        if input_delays.iter().chain(output_delays).all(|&d| d == 0) {
            return Ok(Plant { model: sys.clone() });
        }
        Ok(Plant {
            model: sys.with_io_delays(input_delays, output_delays)?,
        })
    }

    /// A discrete transfer-function plant (no extra delay).
    pub fn discrete_tf(tf: &TransferFunction) -> Result<Self> {
        Self::discrete(&tf.to_ss()?, &[], &[])
    }

    /// The discrete model at the base period (delays included as states).
    pub fn model(&self) -> &StateSpace {
        &self.model
    }

    /// The base period T.
    pub fn ts(&self) -> f64 {
        self.model.ts().unwrap_or(f64::NAN)
    }
}

fn check_delays(what: &'static str, d: &[f64], n: usize) -> Result<Vec<f64>> {
    if d.is_empty() {
        return Ok(vec![0.0; n]);
    }
    if d.len() != n {
        return Err(Error::DimensionMismatch {
            what: if what == "input" {
                "input delays"
            } else {
                "output delays"
            },
            expected: n,
            got: d.len(),
        });
    }
    for (index, &value) in d.iter().enumerate() {
        if !value.is_finite() {
            return Err(Error::NonFinite {
                what: if what == "input" {
                    "input delay"
                } else {
                    "output delay"
                },
                value,
            });
        }
        if value < 0.0 {
            return Err(Error::NegativeDelay { what, index, value });
        }
    }
    Ok(d.to_vec())
}

/// Stacks models that share their inputs: block-diagonal A and C, stacked B and D.
fn stack_outputs(rows: &[StateSpace], ts: Option<f64>) -> Result<StateSpace> {
    let m = rows.first().map_or(0, StateSpace::n_inputs);
    let n: usize = rows.iter().map(StateSpace::order).sum();
    let p: usize = rows.iter().map(StateSpace::n_outputs).sum();
    let mut a = DMatrix::zeros(n, n);
    let mut b = DMatrix::zeros(n, m);
    let mut c = DMatrix::zeros(p, n);
    let mut d = DMatrix::zeros(p, m);
    let (mut xo, mut yo) = (0, 0);
    for r in rows {
        let (ni, pi) = (r.order(), r.n_outputs());
        a.view_mut((xo, xo), (ni, ni)).copy_from(r.a());
        b.view_mut((xo, 0), (ni, m)).copy_from(r.b());
        c.view_mut((yo, xo), (pi, ni)).copy_from(r.c());
        d.view_mut((yo, 0), (pi, m)).copy_from(r.d());
        xo += ni;
        yo += pi;
    }
    Ok(StateSpace::new(a, b, c, d, ts)?)
}

/// A discrete controller: u_K = K(r₁ − v), where v is the fed-back
/// measurement. K maps n_y error channels to n_u inputs.
///
/// Zero entries of K leave loops open (thesis §7.5: some loops closed,
/// others open), e.g. [`Controller::decentralized`].
///
/// **Execution rate.** A controller whose model runs at the plant's base
/// period T executes every sample. A model at an integer multiple m·T
/// executes every m samples, at k ≡ phase (mod m) ([`Controller::with_phase`],
/// default 0): it reads the measurement then, updates its state once and
/// holds its output until it runs again (the slow digital controller of a
/// multirate loop, e.g. one that acts when a lab analysis arrives). Between
/// executions r₂ and the input holds still act at the base period.
#[derive(Debug, Clone, PartialEq)]
pub struct Controller {
    model: StateSpace,
    phase: usize,
}

impl Controller {
    /// A discrete state-space controller (n_u outputs, n_y inputs).
    pub fn from_ss(sys: &StateSpace) -> Result<Self> {
        if !sys.is_discrete() {
            return Err(Error::NotDiscrete { what: "controller" });
        }
        Ok(Controller {
            model: sys.clone(),
            phase: 0,
        })
    }

    /// A discrete transfer-function controller (n_u × n_y, positive powers of z).
    pub fn from_tf(tf: &TransferFunction) -> Result<Self> {
        if tf.ts().is_none() {
            return Err(Error::NotDiscrete { what: "controller" });
        }
        Self::from_ss(&tf.to_ss()?)
    }

    /// A static gain K (n_u × n_y).
    pub fn gain(k: DMatrix<f64>, ts: f64) -> Result<Self> {
        check_ts(ts)?;
        Ok(Controller {
            model: StateSpace::gain(k, Some(ts))?,
            phase: 0,
        })
    }

    /// A decentralised controller: `loops[i] = (input, output, K_i(z))`
    /// closes input `input` on output `output` with the SISO discrete
    /// transfer function K_i (coefficients in descending powers of z); every
    /// other entry is zero (loops open).
    pub fn decentralized(
        n_inputs: usize,
        n_outputs: usize,
        ts: f64,
        loops: &[(usize, usize, &[f64], &[f64])],
    ) -> Result<Self> {
        check_ts(ts)?;
        let zero = lifted_lti::SisoTf::from_coeffs(&[0.0], &[1.0])?;
        let mut rows = vec![vec![zero; n_outputs]; n_inputs];
        for &(i, j, num, den) in loops {
            if i >= n_inputs {
                return Err(Error::DimensionMismatch {
                    what: "controller loop input index bound",
                    expected: n_inputs,
                    got: i,
                });
            }
            if j >= n_outputs {
                return Err(Error::DimensionMismatch {
                    what: "controller loop output index bound",
                    expected: n_outputs,
                    got: j,
                });
            }
            rows[i][j] = lifted_lti::SisoTf::from_coeffs(num, den)?;
        }
        Self::from_tf(&TransferFunction::from_entries(rows, Some(ts))?)
    }

    /// Sets the sample, modulo the controller's period m (model period /
    /// base period), at which it executes (validated against m when the
    /// loop is built: [`Error::ControllerPhase`]). Default 0.
    pub fn with_phase(mut self, phase: usize) -> Self {
        self.phase = phase;
        self
    }

    /// The controller model.
    pub fn model(&self) -> &StateSpace {
        &self.model
    }

    /// The execution phase ([`Controller::with_phase`]).
    pub fn phase(&self) -> usize {
        self.phase
    }
}

/// The number of base periods `ts` in the controller's period, when it is
/// an integer m ≥ 1 (within the sample-period tolerance).
pub(crate) fn controller_period(k: &Controller, ts: f64) -> Result<usize> {
    let kt = k
        .model
        .ts()
        .ok_or(Error::NotDiscrete { what: "controller" })?;
    let m = (kt / ts).round();
    if !m.is_finite() || m < 1.0 || (kt - m * ts).abs() > TS_TOL * kt {
        return Err(Error::ControllerPeriod {
            controller: kt,
            base: ts,
        });
    }
    let m = m as usize;
    if k.phase >= m {
        return Err(Error::ControllerPhase {
            phase: k.phase,
            period: m,
        });
    }
    Ok(m)
}

/// The closed loop y = G(r₂ + K(r₁ − y)) (negative feedback, spec A2.2) as
/// one state-space model with inputs [r₁; r₂] and outputs [y; u], in the
/// time domain of G and K (both continuous or both discrete at the same
/// period). State [x_G; x_K]. With M = (I + D_K D_G)⁻¹:
/// u = M(−D_K C_G x_G + C_K x_K + D_K r₁ + r₂), y = C_G x_G + D_G u.
/// O((n_G + n_K)³) at most.
///
/// Errors: dimension mismatch (K must be n_u × n_y), domain mismatch,
/// [`Error::AlgebraicLoop`] when I + D_K D_G is singular.
pub fn closed_loop(g: &StateSpace, k: &StateSpace) -> Result<StateSpace> {
    let (p, m) = (g.n_outputs(), g.n_inputs());
    if k.n_inputs() != p {
        return Err(Error::DimensionMismatch {
            what: "controller inputs (= plant outputs)",
            expected: p,
            got: k.n_inputs(),
        });
    }
    if k.n_outputs() != m {
        return Err(Error::DimensionMismatch {
            what: "controller outputs (= plant inputs)",
            expected: m,
            got: k.n_outputs(),
        });
    }
    match (g.ts(), k.ts()) {
        (None, None) => {}
        (Some(a), Some(b)) if (a - b).abs() <= TS_TOL * a => {}
        (Some(a), Some(b)) => {
            return Err(Error::SamplePeriodMismatch {
                what: "controller",
                expected: a,
                got: b,
            });
        }
        _ => {
            return Err(Error::Unsupported {
                what: "closed loop of a continuous and a discrete model",
            });
        }
    }
    let (ng, nk) = (g.order(), k.order());
    let im = DMatrix::<f64>::identity(m, m);
    let mmat = lifted_linalg::inv(&(&im + k.d() * g.d()))
        .map_err(|_| Error::AlgebraicLoop { phase: 0 })?;
    // u = Ux x + Ur r, with x = [xg; xk], r = [r1; r2]
    let mut ux = DMatrix::zeros(m, ng + nk);
    ux.view_mut((0, 0), (m, ng))
        .copy_from(&(-(&mmat * k.d() * g.c())));
    ux.view_mut((0, ng), (m, nk)).copy_from(&(&mmat * k.c()));
    let mut ur = DMatrix::zeros(m, p + m);
    ur.view_mut((0, 0), (m, p)).copy_from(&(&mmat * k.d()));
    ur.view_mut((0, p), (m, m)).copy_from(&mmat);
    // y = Cg xg + Dg u
    let mut cgx = DMatrix::zeros(p, ng + nk);
    cgx.view_mut((0, 0), (p, ng)).copy_from(g.c());
    let yx = &cgx + g.d() * &ux;
    let yr = g.d() * &ur;
    // e = r1 − y
    let mut r1sel = DMatrix::zeros(p, p + m);
    r1sel.view_mut((0, 0), (p, p)).fill_with_identity();
    let ex = -&yx;
    let er = &r1sel - &yr;
    let n = ng + nk;
    let mut a = DMatrix::zeros(n, n);
    let mut b = DMatrix::zeros(n, p + m);
    let bg_ux = g.b() * &ux;
    let bg_ur = g.b() * &ur;
    a.view_mut((0, 0), (ng, n)).copy_from(&bg_ux);
    let agv = a.view((0, 0), (ng, ng)) + g.a();
    a.view_mut((0, 0), (ng, ng)).copy_from(&agv);
    b.view_mut((0, 0), (ng, p + m)).copy_from(&bg_ur);
    let bk_ex = k.b() * &ex;
    let bk_er = k.b() * &er;
    a.view_mut((ng, 0), (nk, n)).copy_from(&bk_ex);
    let akv = a.view((ng, ng), (nk, nk)) + k.a();
    a.view_mut((ng, ng), (nk, nk)).copy_from(&akv);
    b.view_mut((ng, 0), (nk, p + m)).copy_from(&bk_er);
    let mut c = DMatrix::zeros(p + m, n);
    c.view_mut((0, 0), (p, n)).copy_from(&yx);
    c.view_mut((p, 0), (m, n)).copy_from(&ux);
    let mut d = DMatrix::zeros(p + m, p + m);
    d.view_mut((0, 0), (p, p + m)).copy_from(&yr);
    d.view_mut((p, 0), (m, p + m)).copy_from(&ur);
    Ok(StateSpace::new(a, b, c, d, g.ts())?)
}

/// A closed loop discretised **as a whole** (spec A2.3: how Ren & Zhu's
/// results are reproduced): the continuous loop y = G(r₂ + K(r₁ − y)) of a
/// continuous plant and controller is formed in continuous time
/// ([`closed_loop`]) and discretised by ZOH at `ts` (exact for held
/// references). Inputs [r₁; r₂], outputs [y; u].
#[derive(Debug, Clone, PartialEq)]
pub struct WholeLoop {
    model: StateSpace,
    n_y: usize,
    n_u: usize,
}

impl WholeLoop {
    /// From a continuous plant and a continuous controller.
    pub fn from_continuous(g: &StateSpace, k: &StateSpace, ts: f64) -> Result<Self> {
        check_ts(ts)?;
        if g.is_discrete() || k.is_discrete() {
            return Err(Error::Unsupported {
                what: "WholeLoop::from_continuous needs continuous plant and controller",
            });
        }
        let cl = closed_loop(g, k)?;
        Ok(WholeLoop {
            model: cl.c2d(ts, &C2dOptions::default())?,
            n_y: g.n_outputs(),
            n_u: g.n_inputs(),
        })
    }

    /// From a closed-loop model with inputs [r₁ (n_y); r₂ (n_u)] and outputs
    /// [y (n_y); u (n_u)]; continuous models are discretised by ZOH at `ts`.
    pub fn from_model(cl: &StateSpace, n_y: usize, n_u: usize, ts: f64) -> Result<Self> {
        check_ts(ts)?;
        if cl.n_inputs() != n_y + n_u {
            return Err(Error::DimensionMismatch {
                what: "closed-loop inputs (n_y + n_u)",
                expected: n_y + n_u,
                got: cl.n_inputs(),
            });
        }
        if cl.n_outputs() != n_y + n_u {
            return Err(Error::DimensionMismatch {
                what: "closed-loop outputs (n_y + n_u)",
                expected: n_y + n_u,
                got: cl.n_outputs(),
            });
        }
        let model = if cl.is_discrete() {
            check_discrete_at("closed-loop model", cl, ts)?;
            cl.clone()
        } else {
            cl.c2d(ts, &C2dOptions::default())?
        };
        Ok(WholeLoop { model, n_y, n_u })
    }

    /// The discrete closed-loop model ([r₁; r₂] → [y; u]).
    pub fn model(&self) -> &StateSpace {
        &self.model
    }

    /// Number of plant outputs.
    pub fn n_outputs(&self) -> usize {
        self.n_y
    }

    /// Number of plant inputs.
    pub fn n_inputs(&self) -> usize {
        self.n_u
    }
}

/// Discretises a model for use at `ts`: continuous → ZOH, discrete → checked.
pub(crate) fn at_base_period(what: &'static str, sys: &StateSpace, ts: f64) -> Result<StateSpace> {
    if sys.is_discrete() {
        check_discrete_at(what, sys, ts)?;
        Ok(sys.clone())
    } else {
        Ok(sys.c2d(ts, &C2dOptions::default())?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lifted_lti::FeedbackSign;

    #[test]
    fn closed_loop_matches_lti_feedback() {
        // H1 = GK/(1 + GK) from r1 to y, H2 = G/(1 + KG) from r2 to y (spec A2.2)
        let g = TransferFunction::from_coeffs(&[1.0], &[0.3, 1.0], None)
            .unwrap()
            .to_ss()
            .unwrap();
        let k = TransferFunction::from_coeffs(&[0.2, 5.0], &[1.0, 0.0], None)
            .unwrap()
            .to_ss()
            .unwrap();
        let cl = closed_loop(&g, &k).unwrap();
        let one = StateSpace::gain(DMatrix::from_element(1, 1, 1.0), None).unwrap();
        let h1 =
            lifted_lti::feedback(&k.series(&g).unwrap(), &one, FeedbackSign::Negative).unwrap();
        let h2 = lifted_lti::feedback(&g, &k, FeedbackSign::Negative).unwrap();
        for w in [0.1, 1.0, 7.0] {
            let s = num_complex::Complex64::new(0.0, w);
            let f = cl.freqresp(&[w]).unwrap();
            let r1 = h1.freqresp(&[w]).unwrap();
            let r2 = h2.freqresp(&[w]).unwrap();
            assert!((f[0][(0, 0)] - r1[0][(0, 0)]).norm() < 1e-10, "{s}");
            assert!((f[0][(0, 1)] - r2[0][(0, 0)]).norm() < 1e-10);
        }
    }

    #[test]
    fn delays_are_validated() {
        assert!(check_delays("input", &[], 2).unwrap() == vec![0.0, 0.0]);
        assert!(matches!(
            check_delays("input", &[-1.0], 1),
            Err(Error::NegativeDelay { .. })
        ));
        assert!(matches!(
            check_delays("output", &[1.0], 2),
            Err(Error::DimensionMismatch { .. })
        ));
    }
}

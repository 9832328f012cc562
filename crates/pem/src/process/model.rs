//! The process-model structures, their continuous realisations, the exact
//! ZOH and FOH discretisations with a fractional dead time and the fast
//! simulation.

use lifted_lti::{C2dOptions, StateSpace};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// The structure of a process model (MATLAB's `idproc` type names), from
/// one input to the output. Every structure has a static gain K and a dead
/// time θ ≥ 0.
#[allow(clippy::upper_case_acronyms)] // MATLAB's names, kept for recognition
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ProcessKind {
    /// First order plus dead time: K e^{−θs} / (1 + T₁s).
    P1D,
    /// Second order, two real poles: K e^{−θs} / ((1 + T₁s)(1 + T₂s)).
    P2D,
    /// Integrating: K e^{−θs} / (s(1 + T₁s)); K is the slope of the ramp
    /// per unit input.
    P1DI,
    /// Second order with a zero: K (1 + T_z s) e^{−θs} / ((1 + T₁s)(1 + T₂s));
    /// T_z may be negative (an inverse response).
    P2DZ,
    /// Second order, complex or real poles:
    /// K e^{−θs} / (1 + 2ζT_w s + T_w² s²), ζ > 0 (underdamped when ζ < 1).
    P2DU,
}

impl ProcessKind {
    /// Every structure, in declaration order.
    pub const ALL: [ProcessKind; 5] = [
        ProcessKind::P1D,
        ProcessKind::P2D,
        ProcessKind::P1DI,
        ProcessKind::P2DZ,
        ProcessKind::P2DU,
    ];

    /// Names of the physical parameters, in the order of
    /// [`ProcessModel::parameters`].
    pub fn parameter_names(self) -> &'static [&'static str] {
        match self {
            ProcessKind::P1D | ProcessKind::P1DI => &["K", "Tp1", "Td"],
            ProcessKind::P2D => &["K", "Tp1", "Tp2", "Td"],
            ProcessKind::P2DZ => &["K", "Tp1", "Tp2", "Tz", "Td"],
            ProcessKind::P2DU => &["K", "Tw", "Zeta", "Td"],
        }
    }

    /// Number of physical parameters (K, time constants, ζ, T_z, θ).
    pub fn n_parameters(self) -> usize {
        self.parameter_names().len()
    }
}

/// How the input behaves between its samples (MATLAB's `InterSample`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum InterSample {
    /// Zero-order hold: each sample held until the next (default; a
    /// controller's or a DAC's output).
    #[default]
    Zoh,
    /// First-order hold: the input moves linearly from each sample to the
    /// next (a sampled continuous signal, a ramped set-point; MATLAB's
    /// triangle hold). The discrete model then needs the next sample, so a
    /// dead time under one period gives it a direct term.
    Foh,
}

impl InterSample {
    /// Parses `zoh` or `foh` (any case); `what` names the option in the
    /// error.
    ///
    /// Errors: [`Error::InvalidOption`] naming the values there are.
    pub fn parse(s: &str, what: &'static str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "zoh" => Ok(InterSample::Zoh),
            "foh" => Ok(InterSample::Foh),
            other => Err(Error::InvalidOption {
                what,
                reason: format!("unknown inter-sample behaviour {other:?}: zoh or foh"),
            }),
        }
    }
}

/// A continuous-time process model of one input–output pair with dead time,
/// sampled at `ts` (MATLAB's `idproc`). Fields a structure does not use are
/// 0 (see [`ProcessKind`]): `tp1` for every kind but P2DU, `tp2` for P2D and
/// P2DZ, `tw` and `zeta` for P2DU, `tz` for P2DZ.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProcessModel {
    /// The structure.
    pub kind: ProcessKind,
    /// Static gain K (for P1DI the integrator's gain), output units per
    /// input unit.
    pub k: f64,
    /// First time constant T₁ (s), > 0.
    pub tp1: f64,
    /// Second time constant T₂ (s), > 0.
    pub tp2: f64,
    /// Natural period T_w = 1/ω_n (s) of P2DU, > 0.
    pub tw: f64,
    /// Damping ratio ζ of P2DU, > 0.
    pub zeta: f64,
    /// Zero time constant T_z (s) of P2DZ, any sign.
    pub tz: f64,
    /// Dead time θ (s), ≥ 0, any value (not only multiples of `ts`).
    pub theta: f64,
    /// Sample period of the data the model describes (s), > 0.
    pub ts: f64,
    /// How the input moves between samples (default ZOH; files written
    /// before FOH existed read as ZOH).
    #[serde(default)]
    pub intersample: InterSample,
}

impl ProcessModel {
    /// The model of structure `kind` with the physical parameters `p` in the
    /// order of [`ProcessKind::parameter_names`], sample period `ts`.
    ///
    /// Errors: [`Error::DimensionMismatch`] for a wrong count,
    /// [`Error::InvalidOption`] for a non-finite value, a time constant,
    /// ζ or `ts` not positive, or θ < 0.
    pub fn from_parameters(kind: ProcessKind, p: &[f64], ts: f64) -> Result<Self> {
        if p.len() != kind.n_parameters() {
            return Err(Error::DimensionMismatch {
                what: "process-model parameters",
                expected: format!("{} values for {kind:?}", kind.n_parameters()),
                got: format!("{}", p.len()),
            });
        }
        let mut m = ProcessModel {
            kind,
            k: p[0],
            tp1: 0.0,
            tp2: 0.0,
            tw: 0.0,
            zeta: 0.0,
            tz: 0.0,
            theta: p[p.len() - 1],
            ts,
            intersample: InterSample::Zoh,
        };
        match kind {
            ProcessKind::P1D | ProcessKind::P1DI => m.tp1 = p[1],
            ProcessKind::P2D => (m.tp1, m.tp2) = (p[1], p[2]),
            ProcessKind::P2DZ => (m.tp1, m.tp2, m.tz) = (p[1], p[2], p[3]),
            ProcessKind::P2DU => (m.tw, m.zeta) = (p[1], p[2]),
        }
        m.validate()?;
        Ok(m)
    }

    /// The physical parameters in the order of
    /// [`ProcessKind::parameter_names`].
    pub fn parameters(&self) -> Vec<f64> {
        match self.kind {
            ProcessKind::P1D | ProcessKind::P1DI => vec![self.k, self.tp1, self.theta],
            ProcessKind::P2D => vec![self.k, self.tp1, self.tp2, self.theta],
            ProcessKind::P2DZ => vec![self.k, self.tp1, self.tp2, self.tz, self.theta],
            ProcessKind::P2DU => vec![self.k, self.tw, self.zeta, self.theta],
        }
    }

    /// Checks the fields the structure uses ([`ProcessModel::from_parameters`]).
    pub fn validate(&self) -> Result<()> {
        let bad = |reason: String| Error::InvalidOption {
            what: "process model",
            reason,
        };
        let p = self.parameters();
        if let Some(v) = p.iter().find(|v| !v.is_finite()) {
            return Err(bad(format!("non-finite parameter {v}")));
        }
        if !(self.ts.is_finite() && self.ts > 0.0) {
            return Err(bad(format!("sample period must be > 0, got {}", self.ts)));
        }
        if self.theta < 0.0 {
            return Err(bad(format!("dead time must be ≥ 0, got {}", self.theta)));
        }
        let positive: &[(&str, f64)] = match self.kind {
            ProcessKind::P1D | ProcessKind::P1DI => &[("Tp1", self.tp1)],
            ProcessKind::P2D | ProcessKind::P2DZ => &[("Tp1", self.tp1), ("Tp2", self.tp2)],
            ProcessKind::P2DU => &[("Tw", self.tw), ("Zeta", self.zeta)],
        };
        for (name, v) in positive {
            if *v <= 0.0 {
                return Err(bad(format!("{name} must be > 0, got {v}")));
            }
        }
        Ok(())
    }

    /// The delay-free part as a continuous state space (the dead time is
    /// not in it; [`ProcessModel::to_discrete_ss`] realises it exactly).
    ///
    /// Realisations: P1D ẋ = (−x + Ku)/T₁, y = x; P2D, P2DZ and P1DI a chain
    /// ẋ₁ = (−x₁ + Ku)/T₁, ẋ₂ = (x₁ − x₂)/T₂ (P1DI: ẋ₂ = x₁), y = x₂, and
    /// for P2DZ y = x₂ + T_z ẋ₂ = (1 − T_z/T₂)x₂ + (T_z/T₂)x₁; P2DU
    /// T_w ẋ₁ = x₂, T_w ẋ₂ = −x₁ − 2ζx₂ + Ku, y = x₁. Each is well defined
    /// for equal time constants.
    pub fn to_continuous_ss(&self) -> Result<StateSpace> {
        self.validate()?;
        let (a, b, c) = self.realisation();
        Ok(StateSpace::new(a, b, c, DMatrix::zeros(1, 1), None)?)
    }

    fn realisation(&self) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        let k = self.k;
        match self.kind {
            ProcessKind::P1D => {
                let t = self.tp1;
                (
                    DMatrix::from_element(1, 1, -1.0 / t),
                    DMatrix::from_element(1, 1, k / t),
                    DMatrix::from_element(1, 1, 1.0),
                )
            }
            ProcessKind::P2D | ProcessKind::P2DZ => {
                let (t1, t2) = (self.tp1, self.tp2);
                let a = DMatrix::from_row_slice(2, 2, &[-1.0 / t1, 0.0, 1.0 / t2, -1.0 / t2]);
                let b = DMatrix::from_row_slice(2, 1, &[k / t1, 0.0]);
                let c = if self.kind == ProcessKind::P2DZ {
                    let r = self.tz / t2;
                    DMatrix::from_row_slice(1, 2, &[r, 1.0 - r])
                } else {
                    DMatrix::from_row_slice(1, 2, &[0.0, 1.0])
                };
                (a, b, c)
            }
            ProcessKind::P1DI => {
                let t1 = self.tp1;
                (
                    DMatrix::from_row_slice(2, 2, &[-1.0 / t1, 0.0, 1.0, 0.0]),
                    DMatrix::from_row_slice(2, 1, &[k / t1, 0.0]),
                    DMatrix::from_row_slice(1, 2, &[0.0, 1.0]),
                )
            }
            ProcessKind::P2DU => {
                let (tw, z) = (self.tw, self.zeta);
                (
                    DMatrix::from_row_slice(2, 2, &[0.0, 1.0 / tw, -1.0 / tw, -2.0 * z / tw]),
                    DMatrix::from_row_slice(2, 1, &[0.0, k / tw]),
                    DMatrix::from_row_slice(1, 2, &[1.0, 0.0]),
                )
            }
        }
    }

    /// The same model with the input's behaviour between samples `h`.
    pub fn with_intersample(mut self, h: InterSample) -> Self {
        self.intersample = h;
        self
    }

    /// The exact discrete equivalent at `ts`, the whole dead time included
    /// (θ = dT + δ, 0 ≤ δ < T). ZOH: [`lifted_lti::StateSpace::c2d`] with
    /// an input delay (the modified z-transform, one extra state when
    /// δ > 0, and d shift-register states), order n + d + (δ > 0). FOH:
    /// the taps of `foh_taps` (module docs) on a register of the past inputs, order
    /// n + d + 1 (n + 1 when d = 0, with the direct term C G₁).
    pub fn to_discrete_ss(&self) -> Result<StateSpace> {
        if self.intersample == InterSample::Foh {
            self.validate()?;
            return Discrete::new(self)?.to_ss(self.ts);
        }
        Ok(self.to_continuous_ss()?.c2d(
            self.ts,
            &C2dOptions {
                input_delays: Some(vec![self.theta]),
                ..Default::default()
            },
        )?)
    }

    /// The simulated output for the input samples `u` (ZOH, zero initial
    /// state, the dead time as in [`ProcessModel::to_discrete_ss`]).
    /// O(N) for N samples.
    pub fn simulate(&self, u: &[f64]) -> Result<Vec<f64>> {
        self.validate()?;
        let mut out = vec![0.0; u.len()];
        Discrete::new(self)?.add_response(u, 1.0, &mut out);
        Ok(out)
    }
}

/// The first-order-hold taps of a fractional delay δ (0 ≤ δ < T) over one
/// period T: with the input linear between its samples and reaching the
/// plant δ late,
///
/// x(k+1) = Φ x(k) + G₋₁ u(k−1) + G₀ u(k) + G₁ u(k+1),
///
/// G₋₁ = (δ I₀(0,δ) − I₁(0,δ))/T, G₀ = ((T−δ) I₀(0,δ) + I₁(0,δ) + (T+δ) I₀(δ,T)
/// − I₁(δ,T))/T, G₁ = (I₁(δ,T) − δ I₀(δ,T))/T, where I₀(a,b) = ∫ₐᵇ e^{A(T−s)} ds B
/// and I₁(a,b) = ∫ₐᵇ e^{A(T−s)} s ds B (on [0, δ) the input runs from
/// u(k−1) to u(k), on [δ, T) from u(k) to u(k+1)). Both integrals come
/// from the exponential of [[A, B, 0], [0, 0, 1], [0, 0, 0]]·α (Van Loan
/// 1978): its blocks (1,2) and (1,3) are J₀(α) = ∫₀^α e^{Ar} dr B and
/// α J₀(α) − J₁(α), J₁(α) = ∫₀^α e^{Ar} r dr B. δ = 0 gives the triangle
/// hold (Franklin, Powell & Workman, *Digital Control*, §6.3.2): G₋₁ = 0.
/// Returns (Φ, [G₋₁, G₀, G₁]).
fn foh_taps(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    ts: f64,
    delta: f64,
) -> Result<(DMatrix<f64>, [Vec<f64>; 3])> {
    let n = a.nrows();
    let j = |alpha: f64| -> Result<(DMatrix<f64>, DMatrix<f64>, DMatrix<f64>)> {
        let mut m = DMatrix::zeros(n + 2, n + 2);
        m.view_mut((0, 0), (n, n)).copy_from(&(a * alpha));
        m.view_mut((0, n), (n, 1)).copy_from(&(b * alpha));
        m[(n, n + 1)] = alpha;
        let e = lifted_linalg::expm(&m)?;
        let j0 = e.view((0, n), (n, 1)).into_owned();
        let j1 = &j0 * alpha - e.view((0, n + 1), (n, 1));
        Ok((e.view((0, 0), (n, n)).into_owned(), j0, j1))
    };
    // I₀(a,b) = J₀(T−a) − J₀(T−b); I₁(a,b) = T I₀(a,b) − (J₁(T−a) − J₁(T−b)).
    let (phi, j0_t, j1_t) = j(ts)?;
    let (_, j0_d, j1_d) = j(ts - delta)?;
    let i0_early = &j0_t - &j0_d;
    let i1_early = &i0_early * ts - (&j1_t - &j1_d);
    let i0_late = j0_d.clone();
    let i1_late = &i0_late * ts - j1_d;
    let g_prev = (&i0_early * delta - &i1_early) / ts;
    let g_now = (&i0_early * (ts - delta) + &i1_early + &i0_late * (ts + delta) - &i1_late) / ts;
    let g_next = (&i1_late - &i0_late * delta) / ts;
    let col = |g: DMatrix<f64>| g.column(0).iter().copied().collect::<Vec<f64>>();
    Ok((phi, [col(g_prev), col(g_now), col(g_next)]))
}

/// The discrete equivalent without the integer part of the delay (ZOH: the
/// modified z-transform realisation of the fraction δ; FOH: the taps of
/// [`foh_taps`]), and that integer part: what the estimator simulates, an
/// index shift instead of d states.
pub(crate) struct Discrete {
    a: DMatrix<f64>,
    b: Vec<f64>,
    c: Vec<f64>,
    d: f64,
    shift: usize,
    /// FOH: the taps of u(t − shift − 1), u(t − shift), u(t − shift + 1)
    /// (`b` and `d` unused).
    foh: Option<[Vec<f64>; 3]>,
}

impl Discrete {
    pub(crate) fn new(m: &ProcessModel) -> Result<Self> {
        let (a, b, c) = m.realisation();
        let ts = m.ts;
        let mut shift = (m.theta / ts).floor();
        let mut frac = m.theta - shift * ts;
        // the same snapping to the grid as c2d
        if frac <= 1e-12 * ts.max(m.theta) {
            frac = 0.0;
        } else if ts - frac <= 1e-12 * ts.max(m.theta) {
            frac = 0.0;
            shift += 1.0;
        }
        if m.intersample == InterSample::Foh {
            let (phi, taps) = foh_taps(&a, &b, ts, frac)?;
            return Ok(Discrete {
                a: phi,
                b: Vec::new(),
                c: c.row(0).iter().copied().collect(),
                d: 0.0,
                shift: shift as usize,
                foh: Some(taps),
            });
        }
        let cont = StateSpace::new(a, b, c, DMatrix::zeros(1, 1), None)?;
        let dss = cont.c2d(
            ts,
            &C2dOptions {
                input_delays: Some(vec![frac]),
                ..Default::default()
            },
        )?;
        Ok(Discrete {
            a: dss.a().clone(),
            b: dss.b().column(0).iter().copied().collect(),
            c: dss.c().row(0).iter().copied().collect(),
            d: dss.d()[(0, 0)],
            shift: shift as usize,
            foh: None,
        })
    }

    /// out(t) += scale · (response to u)(t), at rest before the record
    /// (the input zero before its first sample: under FOH it ramps from 0
    /// at −T to u(0), and the sample after the last, which reaches no
    /// output of the record, is taken as 0).
    pub(crate) fn add_response(&self, u: &[f64], scale: f64, out: &mut [f64]) {
        if let Some(taps) = &self.foh {
            self.add_foh_response(taps, u, scale, out);
            return;
        }
        let n = self.b.len();
        let mut x = [0.0f64; 4];
        let mut xn = [0.0f64; 4];
        debug_assert!(n <= 4);
        for t in self.shift..u.len().min(out.len()) {
            let v = u[t - self.shift];
            let y = self.d * v + self.c.iter().zip(&x[..n]).map(|(c, x)| c * x).sum::<f64>();
            out[t] += scale * y;
            for (i, (xi, bi)) in xn[..n].iter_mut().zip(&self.b).enumerate() {
                *xi = bi * v
                    + x[..n]
                        .iter()
                        .enumerate()
                        .map(|(j, xj)| self.a[(i, j)] * xj)
                        .sum::<f64>();
            }
            x[..n].copy_from_slice(&xn[..n]);
        }
    }

    fn add_foh_response(&self, taps: &[Vec<f64>; 3], u: &[f64], scale: f64, out: &mut [f64]) {
        let n = self.c.len();
        let mut x = [0.0f64; 4];
        let mut xn = [0.0f64; 4];
        debug_assert!(n <= 4);
        let at = |i: isize| -> f64 {
            usize::try_from(i)
                .ok()
                .and_then(|i| u.get(i))
                .copied()
                .unwrap_or(0.0)
        };
        let shift = self.shift as isize;
        // From the step before the record (t = −1): the input ramps from
        // u(−1) = 0 to u(0) over it, which reaches x(0) through G₁ when
        // the delay is under a period (d = 0); the state-space form starts
        // there too (z(0) = x(0) − G₁u(0) = 0).
        for t in -1..u.len().min(out.len()) as isize {
            if let Ok(k) = usize::try_from(t) {
                out[k] += scale * self.c.iter().zip(&x[..n]).map(|(c, x)| c * x).sum::<f64>();
            }
            let base = t - shift;
            let v = [at(base - 1), at(base), at(base + 1)];
            for (i, xi) in xn[..n].iter_mut().enumerate() {
                *xi = (0..3).map(|k| taps[k][i] * v[k]).sum::<f64>()
                    + x[..n]
                        .iter()
                        .enumerate()
                        .map(|(j, xj)| self.a[(i, j)] * xj)
                        .sum::<f64>();
            }
            x[..n].copy_from_slice(&xn[..n]);
        }
    }

    /// The FOH model as a causal state space: with d = shift ≥ 1 the taps
    /// read u(k−d+1), u(k−d), u(k−d−1) from a register of the last d + 1
    /// inputs (u(k) itself when d = 1); with d = 0 the state
    /// z = x − G₁ u(k) removes the next sample: z(k+1) = Φ z + (Φ G₁ + G₀)
    /// u(k) + G₋₁ u(k−1), y = C z + C G₁ u(k). ZOH models go through
    /// `c2d` instead ([`ProcessModel::to_discrete_ss`]).
    fn to_ss(&self, ts: f64) -> Result<StateSpace> {
        let Some(taps) = &self.foh else {
            return Err(Error::InvalidOption {
                what: "process model",
                reason: "a ZOH model is discretised by c2d".into(),
            });
        };
        let n = self.c.len();
        let vec = |v: &Vec<f64>| DMatrix::from_column_slice(n, 1, v);
        let (g_prev, g_now, g_next) = (vec(&taps[0]), vec(&taps[1]), vec(&taps[2]));
        let c = DMatrix::from_row_slice(1, n, &self.c);
        // Taps by input lag l (u(k − l)) and the direct term.
        let (by_lag, direct): (Vec<DMatrix<f64>>, f64) = if self.shift == 0 {
            let g0 = &self.a * &g_next + g_now;
            ((vec![g0, g_prev]), (&c * &g_next)[(0, 0)])
        } else {
            let d = self.shift;
            let mut lags = vec![DMatrix::zeros(n, 1); d + 2];
            lags[d - 1] = g_next;
            lags[d] = g_now;
            lags[d + 1] = g_prev;
            (lags, 0.0)
        };
        // State [x; u(k−1); …; u(k−L)], L the longest lag.
        let l = by_lag.len() - 1;
        let size = n + l;
        let mut a = DMatrix::zeros(size, size);
        let mut b = DMatrix::zeros(size, 1);
        let mut cc = DMatrix::zeros(1, size);
        a.view_mut((0, 0), (n, n)).copy_from(&self.a);
        b.view_mut((0, 0), (n, 1)).copy_from(&by_lag[0]);
        for (lag, g) in by_lag.iter().enumerate().skip(1) {
            a.view_mut((0, n + lag - 1), (n, 1)).copy_from(g);
        }
        if l > 0 {
            b[(n, 0)] = 1.0;
            for i in 1..l {
                a[(n + i, n + i - 1)] = 1.0;
            }
        }
        cc.view_mut((0, 0), (1, n)).copy_from(&c);
        Ok(StateSpace::new(
            a,
            b,
            cc,
            DMatrix::from_element(1, 1, direct),
            Some(ts),
        )?)
    }
}

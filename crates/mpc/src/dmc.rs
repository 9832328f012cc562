//! Dynamic matrix control in the transfer-function domain (thesis §8.2.1)
//! with the dual-rate inter-sample estimate (corrected per erratum L-19).

use std::collections::VecDeque;

use lifted_lti::StateSpace;
use nalgebra::{DMatrix, DVector};

use crate::controller::{Controller, Predictive, check_update_args, never_sampled};
use crate::error::{Error, Result};
use crate::law::{MoveLaw, Moves, check_horizon_size, check_horizons};
use crate::model::step_coefficients;
use crate::options::MpcOptions;

/// DMC on the step-response coefficients a_i of P_T/Δ (8.6), truncated at N
/// (a_i = a_N for i ≥ N, the "a_i ≈ K_g" of (8.8)).
///
/// * Free response: f̂(t+j|t) = v(t) + Σ_{i=1}^{N} (a_{i+j} − a_i) Δu(t−i).
/// * v(t) = y(t) when the output is sampled, otherwise the minimum-variance
///   inter-sample estimate (L-19 corrected):
///   ŷ(nk+l) = y(nk) + Σ_{i=1}^{N}(a_{i+l} − a_i)Δu(nk−i) + Σ_{i=1}^{l} a_iΔu(nk+l−i).
/// * Moves: ΔU = K_c(r̄ − F̂) or the constrained QP; only Δu(t) is applied.
///
/// MIMO: a_i are p×m; each output channel keeps its own last sample.
/// Cost per update O(h p N m) plus the move law.
#[derive(Debug, Clone)]
pub struct Dmc {
    /// s[i] = a_i, i = 0 … N.
    steps: Vec<DMatrix<f64>>,
    truncation: usize,
    law: MoveLaw,
    /// history[0] = Δu(t−1), history[1] = Δu(t−2), …
    history: VecDeque<DVector<f64>>,
    u_prev: DVector<f64>,
    last: Vec<Option<f64>>,
    since: Vec<usize>,
    estimate: DVector<f64>,
}

impl Dmc {
    /// Builds DMC for the fast model `model` (discrete, strictly proper)
    /// with truncation N ≥ h (`truncation`).
    ///
    /// Errors: model errors, [`Error::InvalidArgument`] when N < h, the
    /// move-law errors of [`MoveLaw::new`].
    pub fn new(model: &StateSpace, truncation: usize, opts: &MpcOptions) -> Result<Self> {
        if truncation < opts.prediction_horizon {
            return Err(Error::InvalidArgument {
                what: "truncation N",
                reason: format!(
                    "N = {truncation} must be at least the prediction horizon {}",
                    opts.prediction_horizon
                ),
            });
        }
        // The truncated step response of DMC stands for the plant only when
        // it settles (an unstable model's response grows past a_N, and the
        // loop diverged without a word).
        let rho = model
            .poles()
            .map_err(|e| Error::InvalidModel {
                what: "model",
                reason: format!("poles: {e}"),
            })?
            .iter()
            .map(|z| z.norm())
            .fold(0.0, f64::max);
        if rho >= 1.0 {
            return Err(Error::InvalidModel {
                what: "model",
                reason: format!(
                    "DMC needs a stable model, whose step response settles within the \
                     truncation N (spectral radius {rho:.6} ≥ 1); use the state-space law \
                     (gpc), which predicts from the model's state"
                ),
            });
        }
        // The truncation sizes the step coefficients (N + 1 p×n_u matrices).
        check_horizon_size(
            truncation,
            opts.control_horizon.min(truncation),
            model.n_outputs(),
            model.n_inputs(),
        )?;
        Self::from_steps(step_coefficients(model, truncation)?, opts)
    }

    /// Builds DMC directly from step-response coefficients a_0 = 0, a_1, …,
    /// a_N (p×m each, e.g. from a plant step test); N = `steps.len() − 1`.
    ///
    /// Errors: empty or inconsistent coefficients, non-zero a_0, N < h, the
    /// move-law errors of [`MoveLaw::new`].
    pub fn from_steps(steps: Vec<DMatrix<f64>>, opts: &MpcOptions) -> Result<Self> {
        let hp = opts.prediction_horizon;
        check_horizons(hp, opts.control_horizon)?;
        let Some(first) = steps.first() else {
            return Err(Error::InvalidArgument {
                what: "step coefficients",
                reason: "empty".into(),
            });
        };
        let (p, m) = first.shape();
        if p == 0 || m == 0 || first.amax() != 0.0 {
            return Err(Error::InvalidArgument {
                what: "step coefficients",
                reason: "a_0 must be a non-empty zero matrix (strictly proper model)".into(),
            });
        }
        for a in &steps {
            if a.shape() != (p, m) {
                return Err(Error::DimensionMismatch {
                    what: "step coefficient rows",
                    expected: p,
                    got: a.nrows(),
                });
            }
            crate::error::check_finite_slice("step coefficients", a.as_slice())?;
        }
        let truncation = steps.len() - 1;
        if truncation < hp {
            return Err(Error::InvalidArgument {
                what: "truncation N",
                reason: format!("N = {truncation} must be at least the prediction horizon {hp}"),
            });
        }
        let law = MoveLaw::new(&steps, opts)?;
        Ok(Self {
            steps,
            truncation,
            law,
            history: VecDeque::new(),
            u_prev: DVector::zeros(m),
            last: vec![None; p],
            since: vec![0; p],
            estimate: DVector::zeros(p),
        })
    }

    /// a_i with truncation (a_i = a_N for i ≥ N).
    pub fn coefficient(&self, i: usize) -> &DMatrix<f64> {
        &self.steps[i.min(self.truncation)]
    }
    /// The move law (dynamic matrix 𝒜, gain K_c, constraints).
    pub fn law(&self) -> &MoveLaw {
        &self.law
    }
    /// The feedback value v(t) used at the last update (measurement or
    /// inter-sample estimate).
    pub fn last_feedback(&self) -> &DVector<f64> {
        &self.estimate
    }

    fn p(&self) -> usize {
        self.steps[0].nrows()
    }
    fn m(&self) -> usize {
        self.steps[0].ncols()
    }

    fn check_output(&self, y: &DVector<f64>) -> Result<()> {
        if y.len() != self.p() {
            return Err(Error::DimensionMismatch {
                what: "output",
                expected: self.p(),
                got: y.len(),
            });
        }
        crate::error::check_finite_slice("output", y.as_slice())
    }

    fn check_past(&self, past: &[DVector<f64>]) -> Result<()> {
        for v in past {
            if v.len() != self.m() {
                return Err(Error::DimensionMismatch {
                    what: "past moves",
                    expected: self.m(),
                    got: v.len(),
                });
            }
            crate::error::check_finite_slice("past moves", v.as_slice())?;
        }
        Ok(())
    }

    /// Free response F̂ (length h p) from the output value `y` at time t and
    /// the past moves `past[i] = Δu(t−1−i)` (missing entries are zero).
    ///
    /// Errors: dimension mismatch, non-finite data.
    pub fn free_response(&self, y: &DVector<f64>, past: &[DVector<f64>]) -> Result<DVector<f64>> {
        self.check_output(y)?;
        self.check_past(past)?;
        Ok(self.free_unchecked(y, past.iter()))
    }

    fn free_unchecked<'a>(
        &self,
        y: &DVector<f64>,
        past: impl Iterator<Item = &'a DVector<f64>> + Clone,
    ) -> DVector<f64> {
        let (p, hp, n) = (self.p(), self.law.prediction_horizon(), self.truncation);
        let mut f = DVector::zeros(hp * p);
        for j in 1..=hp {
            let mut acc = y.clone();
            for (idx, du) in past.clone().take(n).enumerate() {
                let i = idx + 1;
                acc += (self.coefficient(i + j) - self.coefficient(i)) * du;
            }
            f.rows_mut((j - 1) * p, p).copy_from(&acc);
        }
        f
    }

    /// Prediction Ŷ = F̂ + 𝒜ΔU (8.8) for given future moves (length m·n_u).
    ///
    /// Errors: as [`Dmc::free_response`].
    pub fn predict(
        &self,
        y: &DVector<f64>,
        past: &[DVector<f64>],
        future: &DVector<f64>,
    ) -> Result<DVector<f64>> {
        let f = self.free_response(y, past)?;
        let a = self.law.dynamic_matrix();
        if future.len() != a.ncols() {
            return Err(Error::DimensionMismatch {
                what: "future moves",
                expected: a.ncols(),
                got: future.len(),
            });
        }
        Ok(f + a * future)
    }

    /// Inter-sample estimate ŷ(nk+l) from the slow sample y(nk), the moves
    /// before it (`past[i] = Δu(nk−1−i)`) and the moves since
    /// (`since[i] = Δu(nk+i)`, l = since.len()), erratum L-19.
    ///
    /// Errors: dimension mismatch, non-finite data.
    pub fn intersample_estimate(
        &self,
        y_nk: &DVector<f64>,
        past: &[DVector<f64>],
        since: &[DVector<f64>],
    ) -> Result<DVector<f64>> {
        self.check_output(y_nk)?;
        self.check_past(past)?;
        self.check_past(since)?;
        let l = since.len();
        let mut acc = y_nk.clone();
        for (idx, du) in past.iter().take(self.truncation).enumerate() {
            let i = idx + 1;
            acc += (self.coefficient(i + l) - self.coefficient(i)) * du;
        }
        for i in 1..=l {
            acc += self.coefficient(i) * &since[l - i];
        }
        Ok(acc)
    }

    /// Current feedback value per channel (measurement or estimate).
    fn feedback(&self) -> DVector<f64> {
        let p = self.p();
        let mut v = DVector::zeros(p);
        for q in 0..p {
            let l = self.since[q];
            let mut acc = self.last[q].unwrap_or(0.0);
            // moves before the last sample of channel q: history[l + i - 1]
            for i in 1..=self.truncation {
                let Some(du) = self.history.get(l + i - 1) else {
                    break;
                };
                acc += ((self.coefficient(i + l) - self.coefficient(i)).row(q) * du)[0];
            }
            for i in 1..=l {
                if let Some(du) = self.history.get(i - 1) {
                    acc += (self.coefficient(i).row(q) * du)[0];
                }
            }
            v[q] = acc;
        }
        v
    }
}

impl Controller for Dmc {
    fn n_inputs(&self) -> usize {
        self.m()
    }
    fn n_outputs(&self) -> usize {
        self.p()
    }
    fn update(
        &mut self,
        measured: &[Option<f64>],
        reference: &DVector<f64>,
    ) -> Result<DVector<f64>> {
        Ok(self.step_plan(measured, reference, false)?.0)
    }
}

impl Predictive for Dmc {
    fn step_plan(
        &mut self,
        measured: &[Option<f64>],
        reference: &DVector<f64>,
        force_qp: bool,
    ) -> Result<(DVector<f64>, Moves)> {
        check_update_args(self.p(), measured, reference)?;
        for (q, y) in measured.iter().enumerate() {
            match y {
                Some(v) => {
                    self.last[q] = Some(*v);
                    self.since[q] = 0;
                }
                None if self.last[q].is_none() => return Err(never_sampled(q)),
                None => self.since[q] += 1,
            }
        }
        let v = self.feedback();
        let f = self.free_unchecked(&v, self.history.iter());
        self.estimate = v;
        let (du, moves) = self.law.plan(&f, reference, &self.u_prev, force_qp)?;
        self.u_prev += &du;
        self.history.push_front(du);
        let keep = self.truncation + 1 + self.since.iter().copied().max().unwrap_or(0) + 1;
        self.history.truncate(keep);
        Ok((self.u_prev.clone(), moves))
    }
}

//! State-space MPC / GPC for the integrated-white-noise disturbance model
//! (thesis §8.2.2, (8.10)–(8.14), inter-sample sum corrected per L-19).

use lifted_lti::StateSpace;
use nalgebra::{DMatrix, DVector};

use crate::controller::{Controller, Predictive, check_update_args, never_sampled};
use crate::error::Result;
use crate::law::{MoveLaw, Moves, check_horizon_size, check_horizons};
use crate::model::{integrated_model, step_coefficients};
use crate::options::MpcOptions;

/// MPC on the realisation (A_I, B_I, C_I) of P_T/Δ (8.10).
///
/// * Deterministic state x_d is propagated with the applied moves (parallel
///   model); at a sample of output q the bias ŷ_s = y_q − C_{I,q}x_d is reset
///   (8.13); between samples it is held, so
///   ŷ(nk+l) = C_IA_Iˡx_d(nk) + Σ_{i=1}^{l} C_IA_I^{l−i}B_IΔu(nk+i−1) + y(nk) − C_Ix_d(nk).
/// * Prediction (8.14): Ŷ = Γx_d + HΔU + 1⊗ŷ_s with Γ = [C_IA_I; …; C_IA_Iʰ]
///   and H the dynamic matrix of the step coefficients C_IA_I^{i−1}B_I.
/// * Moves as in [`crate::Dmc`].
///
/// Cost per update O(h p (n+m)) plus the move law.
#[derive(Debug, Clone)]
pub struct StateSpaceMpc {
    ai: DMatrix<f64>,
    bi: DMatrix<f64>,
    ci: DMatrix<f64>,
    gamma: DMatrix<f64>,
    law: MoveLaw,
    x: DVector<f64>,
    bias: DVector<f64>,
    measured_once: Vec<bool>,
    u_prev: DVector<f64>,
    estimate: DVector<f64>,
}

impl StateSpaceMpc {
    /// Builds the controller for `model` (discrete, strictly proper), model
    /// state and past input at rest.
    ///
    /// Errors: model errors, horizon/weight/constraint errors of [`MoveLaw::new`].
    pub fn new(model: &StateSpace, opts: &MpcOptions) -> Result<Self> {
        let hp = opts.prediction_horizon;
        check_horizons(hp, opts.control_horizon)?;
        check_horizon_size(
            hp,
            opts.control_horizon,
            model.n_outputs(),
            model.n_inputs(),
        )?;
        let (ai, bi, ci) = integrated_model(model)?;
        let steps = step_coefficients(model, hp)?;
        let law = MoveLaw::new(&steps, opts)?;
        let (p, m) = (ci.nrows(), bi.ncols());
        let nx = ai.nrows();
        let mut gamma = DMatrix::zeros(hp * p, nx);
        let mut cak = &ci * &ai;
        for j in 0..hp {
            gamma.rows_mut(j * p, p).copy_from(&cak);
            cak = &cak * &ai;
        }
        Ok(Self {
            ai,
            bi,
            ci,
            gamma,
            law,
            x: DVector::zeros(nx),
            bias: DVector::zeros(p),
            measured_once: vec![false; p],
            u_prev: DVector::zeros(m),
            estimate: DVector::zeros(p),
        })
    }

    /// Γ of (8.12).
    pub fn gamma(&self) -> &DMatrix<f64> {
        &self.gamma
    }
    /// The move law (H = dynamic matrix, K_c, constraints).
    pub fn law(&self) -> &MoveLaw {
        &self.law
    }
    /// (A_I, B_I, C_I).
    pub fn integrated(&self) -> (&DMatrix<f64>, &DMatrix<f64>, &DMatrix<f64>) {
        (&self.ai, &self.bi, &self.ci)
    }
    /// Current deterministic state x_d(t).
    pub fn state(&self) -> &DVector<f64> {
        &self.x
    }
    /// The feedback value used at the last update.
    pub fn last_feedback(&self) -> &DVector<f64> {
        &self.estimate
    }

    /// Prediction (8.14) from x_d(t), the output value y(t) and future moves.
    ///
    /// Errors: dimension mismatch, non-finite data.
    pub fn predict(
        &self,
        x_d: &DVector<f64>,
        y: &DVector<f64>,
        future: &DVector<f64>,
    ) -> Result<DVector<f64>> {
        let p = self.ci.nrows();
        crate::error::check_vectors(&[
            ("state x_d", x_d, self.x.len()),
            ("output", y, p),
            ("future moves", future, self.law.dynamic_matrix().ncols()),
        ])?;
        let bias = y - &self.ci * x_d;
        let hp = self.law.prediction_horizon();
        let ys = DVector::from_fn(hp * p, |i, _| bias[i % p]);
        Ok(&self.gamma * x_d + self.law.dynamic_matrix() * future + ys)
    }
}

impl Controller for StateSpaceMpc {
    fn n_inputs(&self) -> usize {
        self.bi.ncols()
    }
    fn n_outputs(&self) -> usize {
        self.ci.nrows()
    }
    fn update(
        &mut self,
        measured: &[Option<f64>],
        reference: &DVector<f64>,
    ) -> Result<DVector<f64>> {
        Ok(self.step_plan(measured, reference, false)?.0)
    }
}

impl Predictive for StateSpaceMpc {
    fn step_plan(
        &mut self,
        measured: &[Option<f64>],
        reference: &DVector<f64>,
        force_qp: bool,
    ) -> Result<(DVector<f64>, Moves)> {
        let p = self.ci.nrows();
        check_update_args(p, measured, reference)?;
        let yd = &self.ci * &self.x;
        for (q, y) in measured.iter().enumerate() {
            match y {
                Some(v) => {
                    self.bias[q] = v - yd[q];
                    self.measured_once[q] = true;
                }
                None if !self.measured_once[q] => return Err(never_sampled(q)),
                None => {}
            }
        }
        self.estimate = &yd + &self.bias;
        let hp = self.law.prediction_horizon();
        let f = &self.gamma * &self.x + DVector::from_fn(hp * p, |i, _| self.bias[i % p]);
        let (du, moves) = self.law.plan(&f, reference, &self.u_prev, force_qp)?;
        self.u_prev += &du;
        self.x = &self.ai * &self.x + &self.bi * &du;
        Ok((self.u_prev.clone(), moves))
    }
}

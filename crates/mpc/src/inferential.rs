//! The dual-rate inferential control loop of thesis §9.3 (Fig. 9.4): a fast
//! LTI controller K, an **uncorrected** parallel model ŷ = P̂u, and a periodic
//! switch v(k) = y(k) when k ≡ 0 (mod n), ŷ(k) otherwise.

use lifted_lti::StateSpace;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

use crate::error::{Error, Result};
use crate::lifting::{PeriodicStep, lift_periodic};
use crate::model::{check_model, discrete_ts};

/// The loop P (plant), P̂ (model), K (controller), slow period n. With n = 1
/// it is the fast single-rate loop of Fig. 9.2.
///
/// Closed-loop state ξ = [x_P; x_P̂; x_K], exogenous input w = [r; d]
/// (set-point, output disturbance), output z = [y; u; v].
#[derive(Debug, Clone)]
pub struct DualRateLoop {
    plant: StateSpace,
    model: StateSpace,
    controller: StateSpace,
    n: usize,
}

/// Trajectories of [`DualRateLoop::simulate`] (rows = fast samples).
#[derive(Debug, Clone, PartialEq)]
pub struct DualRateResponse {
    /// Plant output y(k).
    pub y: DMatrix<f64>,
    /// Controller output u(k).
    pub u: DMatrix<f64>,
    /// Switch output v(k) fed back to K.
    pub v: DMatrix<f64>,
}

impl DualRateLoop {
    /// Builds the loop. P and P̂ must be discrete, strictly proper and of the
    /// same size p×m; K must be m×p with the same sample time.
    ///
    /// Errors: [`Error::InvalidModel`], [`Error::DimensionMismatch`], `n = 0`.
    pub fn new(
        plant: &StateSpace,
        model: &StateSpace,
        controller: &StateSpace,
        n: usize,
    ) -> Result<Self> {
        let (p, m) = check_model("plant", plant)?;
        let (pm, mm) = check_model("model", model)?;
        if (pm, mm) != (p, m) {
            return Err(Error::DimensionMismatch {
                what: "model outputs vs plant outputs",
                expected: p,
                got: pm,
            });
        }
        discrete_ts("controller", controller)?;
        if controller.n_inputs() != p || controller.n_outputs() != m {
            return Err(Error::DimensionMismatch {
                what: "controller inputs vs plant outputs",
                expected: p,
                got: controller.n_inputs(),
            });
        }
        crate::error::check_at_least_one("slow period n", n)?;
        Ok(Self {
            plant: plant.clone(),
            model: model.clone(),
            controller: controller.clone(),
            n,
        })
    }

    /// Slow period n.
    pub fn period(&self) -> usize {
        self.n
    }

    /// The closed-loop matrices of one fast step, with (`measured = true`)
    /// or without the slow sample.
    pub fn step_matrices(&self, measured: bool) -> PeriodicStep {
        let (p, m) = (self.plant.n_outputs(), self.plant.n_inputs());
        let (np, nh, nk) = (
            self.plant.order(),
            self.model.order(),
            self.controller.order(),
        );
        let nx = np + nh + nk;
        // e = r − v = Ex ξ + Ew w
        let mut ex = DMatrix::zeros(p, nx);
        let mut ew = DMatrix::zeros(p, 2 * p);
        ew.columns_mut(0, p).fill_with_identity();
        if measured {
            ex.columns_mut(0, np).copy_from(&(-self.plant.c()));
            ew.columns_mut(p, p)
                .copy_from(&(-DMatrix::<f64>::identity(p, p)));
        } else {
            ex.columns_mut(np, nh).copy_from(&(-self.model.c()));
        }
        // u = C_K x_K + D_K e
        let mut ux = DMatrix::zeros(m, nx);
        ux.columns_mut(np + nh, nk).copy_from(self.controller.c());
        ux += self.controller.d() * &ex;
        let uw = self.controller.d() * &ew;
        let mut a = DMatrix::zeros(nx, nx);
        a.view_mut((0, 0), (np, np)).copy_from(self.plant.a());
        a.view_mut((np, np), (nh, nh)).copy_from(self.model.a());
        a.view_mut((np + nh, np + nh), (nk, nk))
            .copy_from(self.controller.a());
        let mut bu = DMatrix::zeros(nx, m);
        bu.rows_mut(0, np).copy_from(self.plant.b());
        bu.rows_mut(np, nh).copy_from(self.model.b());
        let mut be = DMatrix::zeros(nx, p);
        be.rows_mut(np + nh, nk).copy_from(self.controller.b());
        let a_cl = a + &bu * &ux + &be * &ex;
        let b_cl = &bu * &uw + &be * &ew;
        // z = [y; u; v]; y = C_P x_P + d; v = r − e
        let mut c = DMatrix::zeros(2 * p + m, nx);
        let mut d = DMatrix::zeros(2 * p + m, 2 * p);
        c.view_mut((0, 0), (p, np)).copy_from(self.plant.c());
        d.view_mut((0, p), (p, p)).fill_with_identity();
        c.rows_mut(p, m).copy_from(&ux);
        d.rows_mut(p, m).copy_from(&uw);
        c.rows_mut(p + m, p).copy_from(&(-&ex));
        let rv = DMatrix::<f64>::identity(p, 2 * p);
        d.rows_mut(p + m, p).copy_from(&(rv - &ew));
        PeriodicStep {
            a: a_cl,
            b: b_cl,
            c,
            d,
        }
    }

    /// The n phases (phase 0 uses the slow sample).
    pub fn phases(&self) -> Vec<PeriodicStep> {
        (0..self.n).map(|k| self.step_matrices(k == 0)).collect()
    }

    /// Monodromy matrix Φ = A_{n−1}⋯A_0 of the closed loop.
    pub fn monodromy(&self) -> DMatrix<f64> {
        let phases = self.phases();
        let nx = phases[0].a.nrows();
        phases
            .iter()
            .fold(DMatrix::identity(nx, nx), |acc, s| &s.a * acc)
    }

    /// Spectral radius of the monodromy matrix (< 1 ⇔ the periodic loop is
    /// stable). For n = 1 it is the largest |closed-loop pole|.
    ///
    /// Errors: eigenvalue failure.
    pub fn spectral_radius(&self) -> Result<f64> {
        let ev: Vec<Complex64> = lifted_linalg::eigenvalues(&self.monodromy())?;
        Ok(ev.iter().map(|z| z.norm()).fold(0.0, f64::max))
    }

    /// Lifted LTI closed loop from w̲ = [r; d] per sample to z̲ = [y; u; v]
    /// per sample (time-major), period nT.
    ///
    /// Errors: lifting errors.
    pub fn lifted(&self) -> Result<StateSpace> {
        lift_periodic(&self.phases(), self.plant.ts().unwrap_or(1.0))
    }

    /// Simulates from rest with set-point rows `r` and optional output
    /// disturbance rows `d` (p columns each).
    ///
    /// Errors: shape mismatch, non-finite data.
    pub fn simulate(&self, r: &DMatrix<f64>, d: Option<&DMatrix<f64>>) -> Result<DualRateResponse> {
        let (p, m) = (self.plant.n_outputs(), self.plant.n_inputs());
        if r.ncols() != p {
            return Err(Error::DimensionMismatch {
                what: "reference columns",
                expected: p,
                got: r.ncols(),
            });
        }
        crate::error::check_finite_slice("reference", r.as_slice())?;
        if let Some(d) = d {
            if d.shape() != r.shape() {
                return Err(Error::DimensionMismatch {
                    what: "disturbance rows",
                    expected: r.nrows(),
                    got: d.nrows(),
                });
            }
            crate::error::check_finite_slice("disturbance", d.as_slice())?;
        }
        let phases = self.phases();
        let nx = phases[0].a.nrows();
        let mut x = DVector::zeros(nx);
        let steps = r.nrows();
        let mut out = DualRateResponse {
            y: DMatrix::zeros(steps, p),
            u: DMatrix::zeros(steps, m),
            v: DMatrix::zeros(steps, p),
        };
        for k in 0..steps {
            let ph = &phases[k % self.n];
            let mut w = DVector::zeros(2 * p);
            w.rows_mut(0, p).copy_from(&r.row(k).transpose());
            if let Some(d) = d {
                w.rows_mut(p, p).copy_from(&d.row(k).transpose());
            }
            let z = &ph.c * &x + &ph.d * &w;
            out.y.row_mut(k).copy_from(&z.rows(0, p).transpose());
            out.u.row_mut(k).copy_from(&z.rows(p, m).transpose());
            out.v.row_mut(k).copy_from(&z.rows(p + m, p).transpose());
            x = &ph.a * &x + &ph.b * &w;
        }
        Ok(out)
    }
}

//! k-step-ahead prediction with the Kalman predictor of the innovations
//! form x(t+1) = A x + B u + K e, y = C x + D u + e.
//!
//! The one-step predictor x̂(t+1|t) = A x̂ + B u + K (y − C x̂ − D u) runs over
//! the record; ŷ(t|t−k) is C x + D u(t) after propagating x̂(t−k+1|t−k) over
//! k − 1 steps with the inputs only. k = 1 is the one-step predictor,
//! k → ∞ the simulation. For multirate records the correction uses, at each
//! instant, only the outputs measured there (NaN = not sampled): the columns
//! of K of the missing outputs are dropped, an approximation of the
//! time-varying Kalman filter that keeps the steady-state gain.
//!
//! Cost O(N k n (n + n_u)) for horizon k (a state per instant is kept for
//! the window, memory O(N n)).

use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result};
use crate::la;
use crate::ss::StateSpace;

impl StateSpace {
    /// ŷ(t|t−k) for every instant t of the record (N×n_y), from the zero
    /// initial state, with the predictor gain `k_gain` (n×n_y); `y` may
    /// hold NaN at unsampled instants. `horizon` = k ≥ 1.
    ///
    /// Errors: [`Error::NotDiscrete`] for a continuous model,
    /// [`Error::DimensionMismatch`] for wrong shapes, [`Error::Linalg`] for a
    /// non-finite input or gain (infinite outputs too),
    /// [`Error::InvalidArgument`] for k = 0.
    pub fn predict(
        &self,
        k_gain: &DMatrix<f64>,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        horizon: usize,
    ) -> Result<DMatrix<f64>> {
        self.predict_from(k_gain, u, y, horizon, None)
    }

    /// [`StateSpace::predict`] from the initial state `x0` (zero when
    /// `None`): the predictor's state at t = 0 is x₀.
    ///
    /// Errors: those of [`StateSpace::predict`], and
    /// [`Error::DimensionMismatch`] when x₀ does not have n entries or
    /// [`Error::Linalg`] when it is not finite.
    pub fn predict_from(
        &self,
        k_gain: &DMatrix<f64>,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        horizon: usize,
        x0: Option<&DVector<f64>>,
    ) -> Result<DMatrix<f64>> {
        if self.ts().is_none() {
            return Err(Error::NotDiscrete { what: "prediction" });
        }
        if horizon == 0 {
            return Err(Error::InvalidArgument {
                what: "prediction horizon",
                reason: "must be at least 1".into(),
            });
        }
        let (n, nu, ny) = (self.order(), self.n_inputs(), self.n_outputs());
        la::check_cols("u", u, nu)?;
        la::check_cols("y", y, ny)?;
        la::check_finite("u", u)?;
        la::check_finite("Kalman gain", k_gain)?;
        if k_gain.shape() != (n, ny) {
            return Err(Error::DimensionMismatch {
                what: "Kalman gain",
                expected: format!("{n}x{ny}"),
                got: format!("{}x{}", k_gain.nrows(), k_gain.ncols()),
            });
        }
        if u.nrows() != y.nrows() {
            return Err(Error::DimensionMismatch {
                what: "u, y",
                expected: format!("{} rows", u.nrows()),
                got: format!("{}", y.nrows()),
            });
        }
        if y.iter().any(|v| v.is_infinite()) {
            return Err(Error::InvalidArgument {
                what: "y",
                reason: "infinite value (NaN marks an unsampled instant)".into(),
            });
        }
        let (a, b, c, d) = (self.a(), self.b(), self.c(), self.d());
        let len = u.nrows();
        // Allocation-free loops (gemv into preallocated vectors); inputs as
        // columns so that u(t) is a contiguous slice.
        let ut = u.transpose();
        // xp column t = x̂(t|t−1), t = 0 … N−1.
        let mut xp = DMatrix::zeros(n, len);
        let mut x = la::initial_state(x0, n)?;
        let mut next = DVector::zeros(n);
        let mut yhat = DVector::zeros(ny);
        for t in 0..len {
            xp.column_mut(t).copy_from(&x);
            let u_t = ut.column(t);
            next.gemv(1.0, a, &x, 0.0);
            next.gemv(1.0, b, &u_t, 1.0);
            yhat.gemv(1.0, c, &x, 0.0);
            yhat.gemv(1.0, d, &u_t, 1.0);
            for o in 0..ny {
                let yo = y[(t, o)];
                if !yo.is_nan() {
                    next.axpy(yo - yhat[o], &k_gain.column(o), 1.0);
                }
            }
            std::mem::swap(&mut x, &mut next);
        }
        let mut out = DMatrix::zeros(len, ny);
        for t in 0..len {
            let start = (t + 1).saturating_sub(horizon);
            x.copy_from(&xp.column(start));
            for s in start..t {
                next.gemv(1.0, a, &x, 0.0);
                next.gemv(1.0, b, &ut.column(s), 1.0);
                std::mem::swap(&mut x, &mut next);
            }
            yhat.gemv(1.0, c, &x, 0.0);
            yhat.gemv(1.0, d, &ut.column(t), 1.0);
            for o in 0..ny {
                out[(t, o)] = yhat[o];
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model() -> StateSpace {
        StateSpace::new(
            DMatrix::from_element(1, 1, 0.9),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::zeros(1, 1),
            Some(1.0),
        )
        .unwrap()
    }

    #[test]
    fn long_horizon_is_the_simulation_and_one_step_uses_the_data() {
        let g = model();
        let u = DMatrix::from_fn(50, 1, |k, _| ((k * 7) % 5) as f64 - 2.0);
        let sim = g.lsim(&u, None, None).unwrap().y;
        // Disturbed measurement: a constant offset of 1.
        let y = sim.map(|v| v + 1.0);
        let k = DMatrix::from_element(1, 1, 0.5);
        let far = g.predict(&k, &u, &y, 1000).unwrap();
        assert!((far - &sim).abs().max() < 1e-12);
        // One step ahead follows the offset partly: closer to y than sim.
        let one = g.predict(&k, &u, &y, 1).unwrap();
        let e1: f64 = (&one - &y).iter().skip(10).map(|v| v * v).sum();
        let es: f64 = (&sim - &y).iter().skip(10).map(|v| v * v).sum();
        assert!(e1 < 0.5 * es, "{e1} vs {es}");
        // With K = 0 every horizon is the simulation.
        let z = DMatrix::zeros(1, 1);
        assert!((g.predict(&z, &u, &y, 1).unwrap() - &sim).abs().max() < 1e-12);
    }

    #[test]
    fn unsampled_outputs_are_skipped_and_bad_input_rejected() {
        let g = model();
        let u = DMatrix::from_element(10, 1, 1.0);
        let mut y = DMatrix::from_element(10, 1, 2.0);
        for t in (1..10).step_by(2) {
            y[(t, 0)] = f64::NAN;
        }
        let k = DMatrix::from_element(1, 1, 0.5);
        let p = g.predict(&k, &u, &y, 1).unwrap();
        assert!(p.iter().all(|v| v.is_finite()));
        assert!(g.predict(&k, &u, &y, 0).is_err());
        assert!(g.predict(&DMatrix::zeros(2, 1), &u, &y, 1).is_err());
        assert!(g.predict(&k, &u, &DMatrix::zeros(9, 1), 1).is_err());
        let mut yi = y.clone();
        yi[(0, 0)] = f64::INFINITY;
        assert!(g.predict(&k, &u, &yi, 1).is_err());
    }
}

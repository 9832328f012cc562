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
        let mut out = self.predict_horizons(k_gain, u, y, &[horizon], x0)?;
        out.pop().ok_or(Error::InvalidArgument {
            what: "prediction horizon",
            reason: "none given".into(),
        })
    }

    /// [`StateSpace::predict_from`] for several horizons: ŷ(t|t−k) for
    /// each k of `horizons`, the one-step predictor run once for all of
    /// them (the same numbers as one call per horizon, bit for bit).
    /// O(N n (n + n_u + n_y)) for the predictor and O(N k n (n + n_u)) per
    /// horizon k.
    ///
    /// Errors: those of [`StateSpace::predict_from`] (k = 0 among the
    /// horizons).
    pub fn predict_horizons(
        &self,
        k_gain: &DMatrix<f64>,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        horizons: &[usize],
        x0: Option<&DVector<f64>>,
    ) -> Result<Vec<DMatrix<f64>>> {
        if self.ts().is_none() {
            return Err(Error::NotDiscrete { what: "prediction" });
        }
        if horizons.contains(&0) {
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
        let x = la::initial_state(x0, n)?;
        Ok(match n {
            1 => predict_flat::<1>(self, k_gain, u, y, horizons, &x),
            2 => predict_flat::<2>(self, k_gain, u, y, horizons, &x),
            3 | 4 => predict_flat::<4>(self, k_gain, u, y, horizons, &x),
            5..=8 => predict_flat::<8>(self, k_gain, u, y, horizons, &x),
            9..=crate::flat::MAX_FLAT => {
                predict_flat::<{ crate::flat::MAX_FLAT }>(self, k_gain, u, y, horizons, &x)
            }
            _ => predict_gemv(self, k_gain, u, y, horizons, x),
        })
    }
}

/// [`StateSpace::predict_horizons`] (its arguments checked) in flat loops
/// (orders up to N; `crate::flat`): the numbers of [`predict_gemv`] bit
/// for bit.
fn predict_flat<const N: usize>(
    sys: &StateSpace,
    k_gain: &DMatrix<f64>,
    u: &DMatrix<f64>,
    y: &DMatrix<f64>,
    horizons: &[usize],
    x0: &DVector<f64>,
) -> Vec<DMatrix<f64>> {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            use crate::flat::Flat;
            let f = Flat::<N>::new(sys);
            let (_, nu, ny) = f.dims();
            let k = f.columns_of(k_gain);
            let len = u.nrows();
            // Inputs as rows of a transposed copy: u(t) a contiguous slice.
            let ut = u.transpose();
            let input = |t: usize| &ut.as_slice()[t * nu..(t + 1) * nu];
            // xp[t] = x̂(t|t−1), t = 0 … N−1.
            let mut xp = Vec::with_capacity(len);
            let (mut x, mut next) = (f.state(x0), [0.0; N]);
            let mut yhat = vec![0.0; ny];
            for t in 0..len {
                xp.push(x);
                let u_t = input(t);
                f.advance(&x, u_t, &mut next);
                f.output(&x, u_t, &mut yhat);
                for (o, ko) in k.iter().enumerate() {
                    let yo = y[(t, o)];
                    if !yo.is_nan() {
                        Flat::<N>::correct(&mut next, ko, yo - yhat[o]);
                    }
                }
                std::mem::swap(&mut x, &mut next);
            }
            horizons
                .iter()
                .map(|&horizon| {
                    let mut out = DMatrix::zeros(len, ny);
                    for t in 0..len {
                        let start = (t + 1).saturating_sub(horizon);
                        x = xp[start];
                        for s in start..t {
                            f.advance(&x, input(s), &mut next);
                            std::mem::swap(&mut x, &mut next);
                        }
                        f.output(&x, input(t), &mut yhat);
                        for (o, v) in yhat.iter().enumerate() {
                            out[(t, o)] = *v;
                        }
                    }
                    out
                })
                .collect()
        },
    )
}

/// [`StateSpace::predict_horizons`] (its arguments checked) by nalgebra's
/// `gemv` (any order).
fn predict_gemv(
    sys: &StateSpace,
    k_gain: &DMatrix<f64>,
    u: &DMatrix<f64>,
    y: &DMatrix<f64>,
    horizons: &[usize],
    x0: DVector<f64>,
) -> Vec<DMatrix<f64>> {
    let (n, ny) = (sys.order(), sys.n_outputs());
    let (a, b, c, d) = (sys.a(), sys.b(), sys.c(), sys.d());
    let len = u.nrows();
    // Allocation-free loops (gemv into preallocated vectors); inputs as
    // columns so that u(t) is a contiguous slice.
    let ut = u.transpose();
    // xp column t = x̂(t|t−1), t = 0 … N−1.
    let mut xp = DMatrix::zeros(n, len);
    let mut x = x0;
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
    horizons
        .iter()
        .map(|&horizon| {
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
            out
        })
        .collect()
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

    /// The flat loops give the `gemv` loops' predictions bit for bit
    /// (every padded size, outputs not measured, several horizons from
    /// one predictor run), and `predict_from` per horizon the same.
    #[test]
    fn the_flat_prediction_is_the_gemv_one() {
        for (nu, ny) in [(0, 1), (2, 2), (1, 3)] {
            let u = DMatrix::from_fn(200, nu, |t, j| (((t * 5 + j * 3) % 11) as f64 - 5.1) / 5.0);
            let mut y =
                DMatrix::from_fn(200, ny, |t, o| (((t * 3 + o * 7) % 13) as f64 - 6.2) / 6.0);
            y[(17, 0)] = f64::NAN;
            for n in [1, 2, 3, 4, 6, 8, 12, 16] {
                let s = crate::response::tests::wavy(n, nu, ny);
                let k = DMatrix::from_fn(n, ny, |i, o| 0.05 * ((i + 2 * o) % 5) as f64 - 0.1);
                let x0 = DVector::from_fn(n, |i, _| 0.3 - 0.1 * i as f64);
                let horizons = [1, 5, 3];
                let flat = predict_flat::<16>(&s, &k, &u, &y, &horizons, &x0);
                let gemv = predict_gemv(&s, &k, &u, &y, &horizons, x0.clone());
                let bits = |m: &DMatrix<f64>| m.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                for (i, h) in horizons.iter().enumerate() {
                    assert_eq!(bits(&flat[i]), bits(&gemv[i]), "n {n}, ny {ny}, k {h}");
                    let one = s.predict_from(&k, &u, &y, *h, Some(&x0)).unwrap();
                    assert_eq!(bits(&one), bits(&gemv[i]), "n {n}, ny {ny}, k {h}");
                }
            }
        }
    }
}

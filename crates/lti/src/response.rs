//! Time responses: simulation, step, impulse, Markov and covariance parameters.
//!
//! Time series are `DMatrix<f64>` with **one row per sample and one column
//! per channel** (MATLAB/CSV layout).

use nalgebra::{DMatrix, DVector};

use crate::C2dOptions;
use crate::error::{Error, Result, check_ts};
use crate::la;
use crate::ss::StateSpace;

/// Result of [`StateSpace::lsim`].
#[derive(Debug, Clone, PartialEq)]
pub struct SimResult {
    /// Outputs, N×p (row k = y(k)).
    pub y: DMatrix<f64>,
    /// States, N×n (row k = x(k), before the update).
    pub x: DMatrix<f64>,
}

impl StateSpace {
    /// The outputs of [`StateSpace::lsim`] for a discrete model at its
    /// own period, without the state trajectory (the same numbers bit for
    /// bit; memory O(N n_y) instead of O(N (n + n_y))).
    ///
    /// Errors: those of [`StateSpace::lsim`], and
    /// [`Error::NotDiscrete`] for a continuous model.
    pub fn lsim_outputs(
        &self,
        u: &DMatrix<f64>,
        x0: Option<&DVector<f64>>,
    ) -> Result<DMatrix<f64>> {
        if self.ts().is_none() {
            return Err(Error::NotDiscrete {
                what: "lsim_outputs",
            });
        }
        la::check_cols("u", u, self.n_inputs())?;
        la::check_finite("u", u)?;
        let x0 = la::initial_state(x0, self.order())?;
        Ok(simulate_discrete(self, u, x0, false).y)
    }

    /// Simulates N samples of the input `u` (N×m, row k = u(k)) from the
    /// initial state `x0` (zeros when None).
    ///
    /// Discrete models run at their own period (`dt` must be None or equal
    /// `ts`). Continuous models need `dt`: the input is held constant over
    /// each step (ZOH) and the response is exact at the samples. O(N(n² + nm + pn)).
    ///
    /// Errors: shape of `u`/`x0`, non-finite data, missing or wrong `dt`.
    pub fn lsim(
        &self,
        u: &DMatrix<f64>,
        x0: Option<&DVector<f64>>,
        dt: Option<f64>,
    ) -> Result<SimResult> {
        la::check_cols("u", u, self.n_inputs())?;
        la::check_finite("u", u)?;
        let n = self.order();
        let x0 = la::initial_state(x0, n)?;
        let sys = match (self.ts(), dt) {
            (Some(_), None) => std::borrow::Cow::Borrowed(self),
            (Some(t), Some(d)) => {
                if !crate::error::same_domain(Some(t), Some(d)) {
                    return Err(Error::DomainMismatch {
                        what: "lsim dt",
                        left: Some(t),
                        right: Some(d),
                    });
                }
                std::borrow::Cow::Borrowed(self)
            }
            (None, None) => {
                return Err(Error::InvalidArgument {
                    what: "dt",
                    reason: "continuous simulation needs a step dt".into(),
                });
            }
            (None, Some(d)) => {
                check_ts(Some(d))?;
                std::borrow::Cow::Owned(self.c2d(d, &C2dOptions::default())?)
            }
        };
        Ok(simulate_discrete(&sys, u, x0, true))
    }

    /// Step responses: one N×p matrix per input (unit step on that input,
    /// zero initial state). Continuous models are sampled every `dt`.
    pub fn step(&self, n_samples: usize, dt: Option<f64>) -> Result<Vec<DMatrix<f64>>> {
        let m = self.n_inputs();
        (0..m)
            .map(|j| {
                let mut u = DMatrix::zeros(n_samples, m);
                u.column_mut(j).fill(1.0);
                Ok(self.lsim(&u, None, dt)?.y)
            })
            .collect()
    }

    /// Impulse responses, one N×p matrix per input. Discrete: response to a
    /// unit pulse u(0) = 1 (the Markov parameters). Continuous: the impulse
    /// response C e^{A t_k} B sampled at t_k = k·dt (the D δ(t) term omitted).
    pub fn impulse(&self, n_samples: usize, dt: Option<f64>) -> Result<Vec<DMatrix<f64>>> {
        let m = self.n_inputs();
        match self.ts() {
            Some(_) => (0..m)
                .map(|j| {
                    let mut u = DMatrix::zeros(n_samples, m);
                    if n_samples > 0 {
                        u[(0, j)] = 1.0;
                    }
                    Ok(self.lsim(&u, None, dt)?.y)
                })
                .collect(),
            None => {
                let Some(dt) = dt else {
                    return Err(Error::InvalidArgument {
                        what: "dt",
                        reason: "continuous impulse response needs a step dt".into(),
                    });
                };
                check_ts(Some(dt))?;
                let phi = la::expm(&(self.a() * dt))?;
                let mut out = vec![DMatrix::zeros(n_samples, self.n_outputs()); m];
                let mut x = self.b().clone();
                for k in 0..n_samples {
                    let y = self.c() * &x;
                    for (j, o) in out.iter_mut().enumerate() {
                        o.row_mut(k).copy_from(&y.column(j).transpose());
                    }
                    x = &phi * x;
                }
                Ok(out)
            }
        }
    }

    /// Markov parameters H₀ = D, Hᵢ = C Aⁱ⁻¹ B, i = 1…k (k+1 matrices, p×m),
    /// Zhu (2000) eq. (III-3). Discrete models only. O(k n² m).
    pub fn markov_parameters(&self, k: usize) -> Result<Vec<DMatrix<f64>>> {
        if !self.is_discrete() {
            return Err(Error::NotDiscrete {
                what: "markov_parameters",
            });
        }
        let mut out = Vec::with_capacity(k + 1);
        out.push(self.d().clone());
        let mut ab = self.b().clone();
        for _ in 0..k {
            out.push(self.c() * &ab);
            ab = self.a() * ab;
        }
        Ok(out)
    }

    /// Covariance parameters R₀…R_k of the output under white input noise of
    /// covariance `w` (m×m), Zhu (2000) eqs. (III-2), (III-3) (with the
    /// seed's D ↦ B, H ↦ D): X = A X Aᵀ + B W Bᵀ (discrete Lyapunov),
    /// Rᵢ = C Aⁱ X Cᵀ + Hᵢ W Dᵀ. Rᵢ = E[y(k+i) y(k)ᵀ]. Stable discrete
    /// models only. O(n³ + k n² p).
    pub fn covariance_parameters(&self, w: &DMatrix<f64>, k: usize) -> Result<Vec<DMatrix<f64>>> {
        if !self.is_discrete() {
            return Err(Error::NotDiscrete {
                what: "covariance_parameters",
            });
        }
        let m = self.n_inputs();
        la::check_rows("W", w, m)?;
        la::check_cols("W", w, m)?;
        la::check_finite("W", w)?;
        self.require_stable("covariance_parameters")?;
        let x = la::dlyap(self.a(), &(self.b() * w * self.b().transpose()))?;
        let h = self.markov_parameters(k)?;
        let mut out = Vec::with_capacity(k + 1);
        let mut ax = x.clone();
        for hi in h.iter().take(k + 1) {
            out.push(self.c() * &ax * self.c().transpose() + hi * w * self.d().transpose());
            ax = self.a() * ax;
        }
        Ok(out)
    }
}

/// The simulation of `sys` at its period from `x0`; the state trajectory
/// only with `states` (else `x` is N × 0).
fn simulate_discrete(
    sys: &StateSpace,
    u: &DMatrix<f64>,
    x0: DVector<f64>,
    states: bool,
) -> SimResult {
    match sys.order() {
        1 => simulate_flat::<1>(sys, u, &x0, states),
        2 => simulate_flat::<2>(sys, u, &x0, states),
        3 | 4 => simulate_flat::<4>(sys, u, &x0, states),
        5..=8 => simulate_flat::<8>(sys, u, &x0, states),
        9..=crate::flat::MAX_FLAT => {
            simulate_flat::<{ crate::flat::MAX_FLAT }>(sys, u, &x0, states)
        }
        _ => simulate_gemv(sys, u, x0),
    }
}

/// [`simulate_discrete`] in flat loops (orders up to N; `crate::flat`): the
/// numbers of [`simulate_gemv`] bit for bit.
fn simulate_flat<const N: usize>(
    sys: &StateSpace,
    u: &DMatrix<f64>,
    x0: &DVector<f64>,
    states: bool,
) -> SimResult {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            let f = crate::flat::Flat::<N>::new(sys);
            let (n, nu, ny) = f.dims();
            let nsamp = u.nrows();
            let mut y = DMatrix::zeros(nsamp, ny);
            let mut xs = DMatrix::zeros(nsamp, if states { n } else { 0 });
            let (mut x, mut next) = (f.state(x0), [0.0; N]);
            let (mut uk, mut yk) = (vec![0.0; nu], vec![0.0; ny]);
            for k in 0..nsamp {
                for (j, v) in uk.iter_mut().enumerate() {
                    *v = u[(k, j)];
                }
                if states {
                    for (i, xi) in x.iter().take(n).enumerate() {
                        xs[(k, i)] = *xi;
                    }
                }
                f.output(&x, &uk, &mut yk);
                for (i, yi) in yk.iter().enumerate() {
                    y[(k, i)] = *yi;
                }
                f.advance(&x, &uk, &mut next);
                std::mem::swap(&mut x, &mut next);
            }
            SimResult { y, x: xs }
        },
    )
}

/// [`simulate_discrete`] by nalgebra's `gemv` (any order).
fn simulate_gemv(sys: &StateSpace, u: &DMatrix<f64>, x0: DVector<f64>) -> SimResult {
    let nsamp = u.nrows();
    let n = sys.order();
    let mut y = DMatrix::zeros(nsamp, sys.n_outputs());
    let mut xs = DMatrix::zeros(nsamp, n);
    // Allocation-free loop: the products go into preallocated vectors (gemv).
    let (a, b, c, d) = (sys.a(), sys.b(), sys.c(), sys.d());
    let mut x = x0;
    let mut x_next = DVector::zeros(n);
    let mut yk = DVector::zeros(sys.n_outputs());
    let ut = u.transpose();
    for k in 0..nsamp {
        let uk = ut.column(k);
        for (i, xi) in x.iter().enumerate() {
            xs[(k, i)] = *xi;
        }
        yk.gemv(1.0, c, &x, 0.0);
        yk.gemv(1.0, d, &uk, 1.0);
        for (i, yi) in yk.iter().enumerate() {
            y[(k, i)] = *yi;
        }
        x_next.gemv(1.0, a, &x, 0.0);
        x_next.gemv(1.0, b, &uk, 1.0);
        std::mem::swap(&mut x, &mut x_next);
    }
    SimResult { y, x: xs }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn layout_is_one_row_per_sample() {
        let s = StateSpace::new(
            DMatrix::from_element(1, 1, 0.5),
            DMatrix::from_row_slice(1, 2, &[1.0, 2.0]),
            DMatrix::from_row_slice(2, 1, &[1.0, -1.0]),
            DMatrix::zeros(2, 2),
            Some(1.0),
        )
        .unwrap();
        let u = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
        let r = s.lsim(&u, None, None).unwrap();
        assert_eq!(r.y.shape(), (3, 2));
        // x1 = 1, x2 = 0.5 + 2 = 2.5
        assert_eq!(r.y[(1, 0)], 1.0);
        assert_eq!(r.y[(2, 1)], -2.5);
        let st = s.step(4, None).unwrap();
        assert_eq!(st.len(), 2);
        assert_eq!(st[1].shape(), (4, 2));
        let h = s.markov_parameters(2).unwrap();
        assert_eq!(h[2][(0, 1)], 1.0);
    }

    /// A model of order `n` (stable, `nu` inputs, `ny` outputs, D ≠ 0)
    /// with entries that are not round numbers.
    pub(crate) fn wavy(n: usize, nu: usize, ny: usize) -> StateSpace {
        let wave = |i: usize, j: usize, s: usize| (((i * 7 + j * 13 + s) % 17) as f64 - 8.3) / 8.0;
        let raw = DMatrix::from_fn(n, n, |i, j| wave(i, j, 1));
        let a = &raw * (0.9 / raw.norm().max(1.0));
        StateSpace::new(
            a,
            DMatrix::from_fn(n, nu, |i, j| wave(i, j, 2)),
            DMatrix::from_fn(ny, n, |i, j| wave(i, j, 3)),
            DMatrix::from_fn(ny, nu, |i, j| 0.1 * wave(i, j, 4)),
            Some(1.0),
        )
        .unwrap()
    }

    /// The flat loops give the `gemv` loops' outputs and states bit for
    /// bit, for every padded size, with and without inputs, one to three
    /// outputs, from a nonzero initial state.
    #[test]
    fn the_flat_simulation_is_the_gemv_one() {
        for (nu, ny) in [(0, 1), (1, 2), (2, 2), (3, 3)] {
            let u = DMatrix::from_fn(200, nu, |t, j| (((t * 5 + j * 3) % 11) as f64 - 5.1) / 5.0);
            for n in [1, 2, 3, 4, 5, 8, 9, 16] {
                let s = wavy(n, nu, ny);
                let x0 = DVector::from_fn(n, |i, _| 0.3 - 0.1 * i as f64);
                let flat = simulate_discrete(&s, &u, x0.clone(), true);
                let gemv = simulate_gemv(&s, &u, x0.clone());
                let outputs = s.lsim_outputs(&u, Some(&x0)).unwrap();
                let bits = |m: &DMatrix<f64>| m.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&flat.y), bits(&gemv.y), "n {n}, nu {nu}, ny {ny}");
                assert_eq!(bits(&flat.x), bits(&gemv.x), "n {n}, nu {nu}, ny {ny}");
                assert_eq!(bits(&outputs), bits(&gemv.y), "n {n}, nu {nu}, ny {ny}");
            }
        }
    }
}

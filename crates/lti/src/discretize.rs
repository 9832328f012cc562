//! Discretisation (c2d) and its ZOH inverse (d2c).

use nalgebra::DMatrix;

use crate::connect::delay_bank;
use crate::connect::{hcat, vcat};
use crate::error::{Error, Result, check_scalar, check_ts};
use crate::la;
use crate::ss::StateSpace;

/// Discretisation method.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum C2dMethod {
    /// Zero-order hold (exact for piecewise-constant inputs). The default.
    #[default]
    Zoh,
    /// First-order (triangle, non-causal) hold: exact for piecewise-linear inputs.
    Foh,
    /// Bilinear (Tustin) map s = (2/T)(z − 1)/(z + 1), optionally prewarped
    /// so that the response at `prewarp` rad/s is matched exactly.
    Tustin {
        /// Prewarp frequency in rad/s (None: plain Tustin).
        prewarp: Option<f64>,
    },
}

/// Options of [`StateSpace::c2d`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct C2dOptions {
    /// Method; default [`C2dMethod::Zoh`].
    pub method: C2dMethod,
    /// Input delays in seconds, one per input (ZOH only), default none.
    /// Any non-negative value is allowed, including non-integer multiples of
    /// T: τ = dT + δ, 0 ≤ δ < T, is realised exactly (modified z-transform
    /// by state augmentation, see [`StateSpace::c2d`]).
    pub input_delays: Option<Vec<f64>>,
}

impl StateSpace {
    /// Continuous → discrete with sample period `ts`.
    ///
    /// **ZOH**: expm([A B; 0 0]·T) = [Φ Γ; 0 I], (A_d, B_d) = (Φ, Γ),
    /// C, D unchanged. With an input delay τ = dT + δ (0 < δ < T) on input j,
    /// the held input reaches the plant δ late within each period, so
    /// x(k+1) = Φx(k) + Γ₀u(k−d) + Γ₁u(k−d−1) with
    /// Γ₀ = ∫₀^{T−δ} e^{As}ds B, Γ₁ = e^{A(T−δ)}∫₀^{δ} e^{As}ds B
    /// (the modified z-transform with m = 1 − δ/T); u(k−d−1) becomes one
    /// extra state per delayed input, the integer part d a shift register,
    /// and D acts on u(k−d−1) when δ > 0 (y(kT) sees u(kT − τ)).
    /// **FOH**: expm([A B 0; 0 0 I; 0 0 0]·T) = [Φ Γ₁ Γ₂; …],
    /// A_d = Φ, B_d = Γ₁ + (Φ − I)Γ₂, C_d = C, D_d = D + CΓ₂ (scipy's form).
    /// **Tustin**: with W = I − (T'/2)A, A_d = W⁻¹(I + (T'/2)A),
    /// B_d = W⁻¹B T', C_d = C W⁻¹, D_d = D + (T'/2) C W⁻¹ B, where
    /// T' = T, or T' = (2/ω)tan(ωT/2) when prewarped at ω.
    /// Cost: one (n+m)- or (n+2m)-dimensional matrix exponential, O((n+m)³).
    ///
    /// Errors: [`Error::NotContinuous`], invalid `ts`, negative/non-finite
    /// delays or delays with FOH/Tustin ([`Error::InvalidArgument`]),
    /// prewarp frequency not in (0, π/T).
    pub fn c2d(&self, ts: f64, opts: &C2dOptions) -> Result<StateSpace> {
        if self.is_discrete() {
            return Err(Error::NotContinuous { what: "c2d" });
        }
        check_ts(Some(ts))?;
        let mut out = match opts.method {
            C2dMethod::Zoh => self.c2d_zoh(ts, opts.input_delays.as_deref())?,
            C2dMethod::Foh | C2dMethod::Tustin { .. }
                if opts
                    .input_delays
                    .as_ref()
                    .is_some_and(|d| d.iter().any(|&x| x != 0.0)) =>
            {
                return Err(Error::InvalidArgument {
                    what: "input_delays",
                    reason: "input delays are supported with ZOH only".into(),
                });
            }
            C2dMethod::Foh => self.c2d_foh(ts)?,
            C2dMethod::Tustin { prewarp } => self.c2d_tustin(ts, prewarp)?,
        };
        if let Some(n) = self.input_names() {
            out = out.with_input_names(n.to_vec())?;
        }
        if let Some(n) = self.output_names() {
            out = out.with_output_names(n.to_vec())?;
        }
        Ok(out)
    }

    fn c2d_zoh(&self, ts: f64, delays: Option<&[f64]>) -> Result<StateSpace> {
        let (n, m) = (self.order(), self.n_inputs());
        let zero_delay = vec![0.0; m];
        let delays = delays.unwrap_or(&zero_delay);
        if delays.len() != m {
            return Err(Error::DimensionMismatch {
                what: "input_delays",
                expected: format!("{m} entries"),
                got: format!("{}", delays.len()),
            });
        }
        for &tau in delays {
            check_scalar("input delay", tau)?;
            if tau < 0.0 {
                return Err(Error::InvalidArgument {
                    what: "input_delays",
                    reason: format!("delays must be >= 0, got {tau}"),
                });
            }
        }
        let (phi, gam) = zoh_blocks(self.a(), self.b(), ts)?;
        // split every delay into integer samples d and fraction δ ∈ [0, T)
        let mut dint = vec![0usize; m];
        let mut frac = vec![0.0; m];
        for j in 0..m {
            let r = delays[j] / ts;
            let mut d = r.floor();
            let mut f = delays[j] - d * ts;
            // snap to the grid when within rounding of an integer multiple
            if f <= 1e-12 * ts.max(delays[j]) {
                f = 0.0;
            } else if ts - f <= 1e-12 * ts.max(delays[j]) {
                f = 0.0;
                d += 1.0;
            }
            dint[j] = d as usize;
            frac[j] = f;
        }
        let fractional: Vec<usize> = (0..m).filter(|&j| frac[j] > 0.0).collect();
        let nf = fractional.len();
        // Plant part driven by v = u(k-d) (m inputs) with extra states ξ = v(k-1) for fractional channels.
        let mut a = DMatrix::<f64>::zeros(n + nf, n + nf);
        let mut b = DMatrix::<f64>::zeros(n + nf, m);
        let mut c = DMatrix::<f64>::zeros(self.n_outputs(), n + nf);
        let mut d = self.d().clone();
        a.view_mut((0, 0), (n, n)).copy_from(&phi);
        c.view_mut((0, 0), (self.n_outputs(), n))
            .copy_from(self.c());
        for (j, &f) in frac.iter().enumerate() {
            if f == 0.0 {
                b.view_mut((0, j), (n, 1)).copy_from(&gam.column(j));
            }
        }
        for (k, &j) in fractional.iter().enumerate() {
            let delta = frac[j];
            let bj = self.b().columns(j, 1).into_owned();
            let (e0, g0) = zoh_blocks(self.a(), &bj, ts - delta)?; // e^{A(T-δ)}, Γ₀
            let (_, gd) = zoh_blocks(self.a(), &bj, delta)?; // ∫₀^δ e^{As}ds b
            let g1 = &e0 * gd;
            b.view_mut((0, j), (n, 1)).copy_from(&g0);
            a.view_mut((0, n + k), (n, 1)).copy_from(&g1);
            b[(n + k, j)] = 1.0;
            // y(kT) = C x + D u(kT - τ) = C x + D ξ
            for i in 0..self.n_outputs() {
                c[(i, n + k)] = self.d()[(i, j)];
                d[(i, j)] = 0.0;
            }
        }
        let plant = StateSpace::from_parts(a, b, c, d, Some(ts));
        if dint.iter().all(|&x| x == 0) {
            return Ok(plant);
        }
        crate::connect::series(&delay_bank(&dint, Some(ts)), &plant)
    }

    fn c2d_foh(&self, ts: f64) -> Result<StateSpace> {
        let (n, m) = (self.order(), self.n_inputs());
        let mut em = DMatrix::<f64>::zeros(n + 2 * m, n + 2 * m);
        em.view_mut((0, 0), (n, n)).copy_from(&(self.a() * ts));
        em.view_mut((0, n), (n, m)).copy_from(&(self.b() * ts));
        em.view_mut((n, n + m), (m, m))
            .copy_from(&DMatrix::<f64>::identity(m, m));
        let ms = la::expm(&em)?;
        let phi = ms.view((0, 0), (n, n)).into_owned();
        let g1 = ms.view((0, n), (n, m)).into_owned();
        let g2 = ms.view((0, n + m), (n, m)).into_owned();
        let bd = &g1 - &g2 + &phi * &g2;
        let dd = self.d() + self.c() * &g2;
        Ok(StateSpace::from_parts(
            phi,
            bd,
            self.c().clone(),
            dd,
            Some(ts),
        ))
    }

    fn c2d_tustin(&self, ts: f64, prewarp: Option<f64>) -> Result<StateSpace> {
        let n = self.order();
        let t = match prewarp {
            None => ts,
            Some(w) => {
                check_scalar("prewarp", w)?;
                if !(w > 0.0 && w * ts < std::f64::consts::PI) {
                    return Err(Error::InvalidArgument {
                        what: "prewarp",
                        reason: format!("must lie in (0, pi/T), got {w}"),
                    });
                }
                2.0 / w * (w * ts / 2.0).tan()
            }
        };
        let i = DMatrix::<f64>::identity(n, n);
        let w = &i - self.a() * (t / 2.0);
        let ad = la::solve(&w, &(&i + self.a() * (t / 2.0))).map_err(|_| Error::NotInvertible {
            what: "I - (T/2)A",
            reason: "the continuous model has a pole at s = 2/T".into(),
        })?;
        let bd = la::solve(&w, &(self.b() * t))?;
        let cd = la::solve(&w.transpose(), &self.c().transpose())?.transpose();
        let dd = self.d() + &cd * self.b() * (t / 2.0);
        Ok(StateSpace::from_parts(ad, bd, cd, dd, Some(ts)))
    }

    /// Discrete → continuous, inverse of ZOH: logm([A B; 0 I])/T = [A_c B_c; 0 0]
    /// (principal logarithm), C, D unchanged. O((n+m)³).
    ///
    /// Errors: [`Error::NotDiscrete`]; [`Error::NoContinuousEquivalent`]
    /// when an eigenvalue of A (hence of [A B; 0 I]) lies on the closed
    /// negative real axis (a pole at z = 0 or z < 0): no real continuous
    /// model has that ZOH equivalent (pitfall 2 of the spec).
    pub fn d2c(&self) -> Result<StateSpace> {
        let Some(ts) = self.ts() else {
            return Err(Error::NotDiscrete { what: "d2c" });
        };
        let (n, m) = (self.order(), self.n_inputs());
        let top = hcat(self.a(), self.b());
        let bot = hcat(&DMatrix::zeros(m, n), &DMatrix::identity(m, m));
        let big = vcat(&top, &bot);
        let l = la::logm(&big).map_err(|e| match e {
            crate::Error::Linalg(lifted_linalg::Error::NoPrincipalBranch {
                eigenvalue, ..
            }) => Error::NoContinuousEquivalent { eigenvalue },
            other => other,
        })? / ts;
        let a = l.view((0, 0), (n, n)).into_owned();
        let b = l.view((0, n), (n, m)).into_owned();
        let mut out = StateSpace::from_parts(a, b, self.c().clone(), self.d().clone(), None);
        if let Some(nm) = self.input_names() {
            out = out.with_input_names(nm.to_vec())?;
        }
        if let Some(nm) = self.output_names() {
            out = out.with_output_names(nm.to_vec())?;
        }
        Ok(out)
    }
}

/// (e^{At}, ∫₀ᵗ e^{As}ds B) from one exponential of [A B; 0 0]·t.
fn zoh_blocks(a: &DMatrix<f64>, b: &DMatrix<f64>, t: f64) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    let (n, m) = (a.nrows(), b.ncols());
    let em = vcat(&hcat(&(a * t), &(b * t)), &DMatrix::zeros(m, n + m));
    let e = la::expm(&em)?;
    Ok((
        e.view((0, 0), (n, n)).into_owned(),
        e.view((0, n), (n, m)).into_owned(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrator_zoh_and_foh() {
        // 1/s: ZOH → T/(z − 1); FOH → (T/2)(z + 1)/(z − 1)
        let s = StateSpace::new(
            DMatrix::zeros(1, 1),
            DMatrix::identity(1, 1),
            DMatrix::identity(1, 1),
            DMatrix::zeros(1, 1),
            None,
        )
        .unwrap();
        let z = s.c2d(0.5, &C2dOptions::default()).unwrap();
        assert!((z.a()[(0, 0)] - 1.0).abs() < 1e-15 && (z.b()[(0, 0)] - 0.5).abs() < 1e-15);
        let f = s
            .c2d(
                0.5,
                &C2dOptions {
                    method: C2dMethod::Foh,
                    input_delays: None,
                },
            )
            .unwrap();
        let g = f.eval_complex(Complex64::new(0.0, 1.0)).unwrap()[(0, 0)];
        let want = 0.25 * Complex64::new(1.0, 1.0) / Complex64::new(-1.0, 1.0);
        assert!((g - want).norm() < 1e-14);
    }

    use num_complex::Complex64;
}

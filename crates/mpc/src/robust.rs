//! Stability-robustness measures of thesis §9.5 (Prop. 6, Cor. 1, §9.7):
//! β_sr = ‖W₁(I + KP̂)⁻¹K‖∞ and β_dr = ‖W̲₁(I + K̲P̲̂)⁻¹K̲R₁‖∞, and their
//! multiplicative-uncertainty versions.
//!
//! For SISO LTI pieces the lifted response is V·diag(T(e^{j(θ+2πl)/n}))·Vᴴ
//! with V unitary, and R₁ = e₁e₁ᵀ picks one column of it, so
//! β_dr = max_θ √((1/n)Σ_{l<n}|T(e^{j(θ+2πl)/n})|²) (spec A3.11) with
//! T = W₁K/(1+KP̂) (additive) or W₁P̂K/(1+KP̂) (multiplicative). T is
//! evaluated as a closed-loop state space, which is finite at θ = 0 even
//! when K has an integrator (spec pitfall 10).

use lifted_lti::{FeedbackSign, HinfOptions, StateSpace, feedback, series};
use nalgebra::DMatrix;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::lifting::{lift, sigma_max};

/// Uncertainty structure of Prop. 6 (additive) and §9.7 (multiplicative).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Uncertainty {
    /// P = P̂ + ΔW₁: T = W₁K(1+P̂K)⁻¹.
    #[default]
    Additive,
    /// P = (1 + ΔW₁)P̂: T = W₁P̂K(1+P̂K)⁻¹.
    Multiplicative,
}

/// Options of the θ search.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RobustnessOptions {
    /// Number of grid points on θ ∈ (0, π). Default 2000.
    pub grid: usize,
    /// Golden-section tolerance on θ around the best grid points. Default 1e-10.
    pub theta_tol: f64,
}

impl Default for RobustnessOptions {
    fn default() -> Self {
        Self {
            grid: 2000,
            theta_tol: 1e-10,
        }
    }
}

/// A robustness measure and the (lifted) frequency where it is attained.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Beta {
    /// The H∞ norm.
    pub value: f64,
    /// Frequency θ ∈ [0, π] (rad/sample of the lifted system for β_dr, of the
    /// fast system for β_sr).
    pub theta: f64,
}

fn check_siso(what: &'static str, s: &StateSpace) -> Result<()> {
    if !s.is_discrete() {
        return Err(Error::InvalidModel {
            what,
            reason: "must be discrete-time".into(),
        });
    }
    if s.n_inputs() != 1 || s.n_outputs() != 1 {
        return Err(Error::InvalidModel {
            what,
            reason: format!("must be SISO (got {}x{})", s.n_outputs(), s.n_inputs()),
        });
    }
    Ok(())
}

fn spectral_radius(a: &DMatrix<f64>) -> Result<f64> {
    if a.nrows() == 0 {
        return Ok(0.0);
    }
    Ok(lifted_linalg::eigenvalues(a)?
        .iter()
        .map(|z| z.norm())
        .fold(0.0, f64::max))
}

/// The closed-loop product T whose norms are β_sr and β_dr.
///
/// Errors: non-SISO or continuous pieces, [`Error::Unstable`] when K does
/// not stabilise P̂ or W₁ is unstable (Prop. 6 assumes nominal stability).
pub fn robustness_map(
    model: &StateSpace,
    controller: &StateSpace,
    weight: &StateSpace,
    uncertainty: Uncertainty,
) -> Result<StateSpace> {
    check_siso("model P̂", model)?;
    check_siso("controller K", controller)?;
    check_siso("weight W1", weight)?;
    let rho_w = spectral_radius(weight.a())?;
    if rho_w >= 1.0 {
        return Err(Error::Unstable {
            what: "weight W1",
            spectral_radius: rho_w,
        });
    }
    // K(1 + P̂K)⁻¹
    let ks = feedback(controller, model, FeedbackSign::Negative)?;
    let rho = spectral_radius(ks.a())?;
    if rho >= 1.0 {
        return Err(Error::Unstable {
            what: "nominal loop of K and the model",
            spectral_radius: rho,
        });
    }
    let core = match uncertainty {
        Uncertainty::Additive => ks,
        Uncertainty::Multiplicative => series(&ks, model)?,
    };
    Ok(series(&core, weight)?)
}

/// β_sr = ‖T‖∞ (Hamiltonian bisection of `lifted-lti`); `theta` in rad/sample.
///
/// Errors: as [`robustness_map`].
pub fn beta_sr(
    model: &StateSpace,
    controller: &StateSpace,
    weight: &StateSpace,
    uncertainty: Uncertainty,
) -> Result<Beta> {
    let t = robustness_map(model, controller, weight, uncertainty)?;
    let h = t.hinf_norm(&HinfOptions {
        rel_tol: 1e-12,
        ..HinfOptions::default()
    })?;
    Ok(Beta {
        value: h.norm,
        theta: h.peak_frequency * t.ts().unwrap_or(1.0),
    })
}

fn check_opts(n: usize, opts: &RobustnessOptions) -> Result<()> {
    if n == 0 {
        return Err(Error::InvalidArgument {
            what: "slow period n",
            reason: "must be at least 1".into(),
        });
    }
    if opts.grid < 8 || !(opts.theta_tol > 0.0 && opts.theta_tol.is_finite()) {
        return Err(Error::InvalidArgument {
            what: "robustness options",
            reason: "grid >= 8 and theta_tol > 0 required".into(),
        });
    }
    Ok(())
}

/// Maximises f on θ ∈ [0, π]: grid at π(i+½)/grid (never θ = 0, where a
/// lifted integrator is singular), then golden section around the best
/// three grid points.
fn maximise(mut f: impl FnMut(f64) -> Result<f64>, opts: &RobustnessOptions) -> Result<Beta> {
    let pi = std::f64::consts::PI;
    let h = pi / opts.grid as f64;
    let mut vals = Vec::with_capacity(opts.grid);
    for i in 0..opts.grid {
        let th = h * (i as f64 + 0.5);
        vals.push((f(th)?, th));
    }
    let mut order: Vec<usize> = (0..vals.len()).collect();
    order.sort_by(|&a, &b| vals[b].0.total_cmp(&vals[a].0));
    let mut best = Beta {
        value: vals[order[0]].0,
        theta: vals[order[0]].1,
    };
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for &i in order.iter().take(3) {
        let c = vals[i].1;
        let (mut a, mut b) = ((c - h).max(1e-9), (c + h).min(pi));
        let mut x1 = b - g * (b - a);
        let mut x2 = a + g * (b - a);
        let (mut f1, mut f2) = (f(x1)?, f(x2)?);
        while b - a > opts.theta_tol {
            if f1 > f2 {
                b = x2;
                x2 = x1;
                f2 = f1;
                x1 = b - g * (b - a);
                f1 = f(x1)?;
            } else {
                a = x1;
                x1 = x2;
                f1 = f2;
                x2 = a + g * (b - a);
                f2 = f(x2)?;
            }
        }
        for (v, th) in [(f1, x1), (f2, x2)] {
            if v > best.value {
                best = Beta {
                    value: v,
                    theta: th,
                };
            }
        }
    }
    if !best.value.is_finite() {
        return Err(Error::NonFinite {
            what: "robustness measure",
        });
    }
    Ok(best)
}

/// β_dr in closed form (alias formula, spec A3.11):
/// max_θ √((1/n)Σ_{l<n}|T(e^{j(θ+2πl)/n})|²). O(grid · n · order³).
///
/// Errors: as [`robustness_map`], `n = 0`, bad options.
pub fn beta_dr(
    model: &StateSpace,
    controller: &StateSpace,
    weight: &StateSpace,
    uncertainty: Uncertainty,
    n: usize,
    opts: &RobustnessOptions,
) -> Result<Beta> {
    check_opts(n, opts)?;
    let t = robustness_map(model, controller, weight, uncertainty)?;
    maximise(|th| alias_gain(&t, n, th), opts)
}

/// √((1/n)Σ_l |T(e^{j(θ+2πl)/n})|²): σ_max of the lifted T̲(e^{jθ})R₁.
///
/// Errors: evaluation at a pole.
pub fn alias_gain(t: &StateSpace, n: usize, theta: f64) -> Result<f64> {
    let mut acc = 0.0;
    for l in 0..n {
        let w = (theta + 2.0 * std::f64::consts::PI * l as f64) / n as f64;
        let g = t.eval_complex(Complex64::from_polar(1.0, w))?;
        acc += g[(0, 0)].norm_sqr();
    }
    Ok((acc / n as f64).sqrt())
}

/// Lifted response of a discrete system at e^{jθ} (lifted by n).
///
/// Errors: lifting errors, θ at a lifted pole.
pub fn lifted_response(sys: &StateSpace, n: usize, theta: f64) -> Result<DMatrix<Complex64>> {
    Ok(lift(sys, n)?.eval_complex(Complex64::from_polar(1.0, theta))?)
}

/// The lifted pieces W̲₁, K̲, P̲̂ of a β_dr computation.
#[derive(Debug, Clone)]
pub struct LiftedPieces {
    w: StateSpace,
    k: StateSpace,
    p: StateSpace,
    n: usize,
    uncertainty: Uncertainty,
}

impl LiftedPieces {
    /// Lifts the three SISO pieces by n.
    ///
    /// Errors: as [`robustness_map`], lifting errors.
    pub fn new(
        model: &StateSpace,
        controller: &StateSpace,
        weight: &StateSpace,
        uncertainty: Uncertainty,
        n: usize,
    ) -> Result<Self> {
        robustness_map(model, controller, weight, uncertainty)?;
        Ok(Self {
            w: lift(weight, n)?,
            k: lift(controller, n)?,
            p: lift(model, n)?,
            n,
            uncertainty,
        })
    }

    /// M̲(e^{jθ}) = W̲₁(I + K̲P̲̂)⁻¹K̲R₁ (additive) or W̲₁P̲̂(I + K̲P̲̂)⁻¹K̲R₁
    /// (multiplicative), from the lifted state spaces (no alias formula).
    /// With `switch = false` R₁ is replaced by I (the lifted β_sr map).
    ///
    /// Errors: θ at a lifted pole (θ = 0 when K has an integrator), singular
    /// I + K̲P̲̂.
    pub fn response(&self, theta: f64, switch: bool) -> Result<DMatrix<Complex64>> {
        let z = Complex64::from_polar(1.0, theta);
        let w = self.w.eval_complex(z)?;
        let k = self.k.eval_complex(z)?;
        let p = self.p.eval_complex(z)?;
        let n = self.n;
        let i = DMatrix::<Complex64>::identity(n, n);
        let mut rhs = k.clone();
        if switch {
            for c in 1..n {
                rhs.column_mut(c).fill(Complex64::new(0.0, 0.0));
            }
        }
        let sol = (i + &k * &p)
            .lu()
            .solve(&rhs)
            .ok_or(Error::InvalidArgument {
                what: "theta",
                reason: format!("I + K P is singular at theta = {theta}"),
            })?;
        Ok(match self.uncertainty {
            Uncertainty::Additive => w * sol,
            Uncertainty::Multiplicative => w * p * sol,
        })
    }
}

/// β_dr by brute force: σ_max of the lifted M̲(e^{jθ}) built from lifted state
/// spaces, maximised like [`beta_dr`]. O(grid · n³ + n²·order³).
///
/// Errors: as [`LiftedPieces::response`].
pub fn beta_dr_lifted(
    model: &StateSpace,
    controller: &StateSpace,
    weight: &StateSpace,
    uncertainty: Uncertainty,
    n: usize,
    opts: &RobustnessOptions,
) -> Result<Beta> {
    check_opts(n, opts)?;
    let pieces = LiftedPieces::new(model, controller, weight, uncertainty, n)?;
    maximise(|th| sigma_max(&pieces.response(th, true)?), opts)
}

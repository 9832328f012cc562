//! Stability-robustness measures of thesis §9.5 (Prop. 6, Cor. 1, §9.7),
//! SISO and MIMO; the derivation and the MIMO meaning are in [`beta_dr`]'s
//! docs.

use lifted_linalg::spectral_radius;
use lifted_lti::{FeedbackSign, HinfOptions, StateSpace, feedback, series};
use nalgebra::DMatrix;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

use crate::conic::{MinimaxOptions, NormMinimax};
use crate::error::{Error, Result};
use crate::lifting::{lift, sigma_max};
use crate::model::check_discrete;

/// Uncertainty structure of Prop. 6 (additive) and §9.7 (multiplicative).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Uncertainty {
    /// P = P̂ + ΔW₁ (Prop. 6): T = W₁K(I + P̂K)⁻¹, W₁ q×m.
    #[default]
    Additive,
    /// P = (I + ΔW₁)P̂ (§9.7): T = W₁P̂K(I + P̂K)⁻¹, W₁ q×p.
    Multiplicative,
}

/// Options of the θ search.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RobustnessOptions {
    /// Number of grid points on θ ∈ (0, π). Default 2000.
    pub grid: usize,
    /// Golden-section tolerance on θ around the best grid points. Default 1e-10.
    pub theta_tol: f64,
    /// Bound on the work of one β_dr computation in floating-point
    /// operations: (grid + golden-section steps) θ values × n transfer
    /// evaluations of ≈ 10(order + 1)³ + 8 q p (order + 1) each
    /// ([`Error::TooMuchWork`] above it, before any evaluation). Default
    /// 1e10 (seconds).
    #[serde(default = "default_max_work")]
    pub max_work: f64,
}

/// [`RobustnessOptions::max_work`]'s default (also for options serialised
/// before the field existed).
fn default_max_work() -> f64 {
    1e10
}

impl Default for RobustnessOptions {
    fn default() -> Self {
        Self {
            grid: 2000,
            theta_tol: 1e-10,
            max_work: default_max_work(),
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

/// Checks that the p×m model P̂, the m×p controller K and the weight W₁
/// (q×m additive, q×p multiplicative) fit together; returns (p, m).
fn check_pieces(
    model: &StateSpace,
    controller: &StateSpace,
    weight: &StateSpace,
    uncertainty: Uncertainty,
) -> Result<(usize, usize)> {
    check_discrete("model P̂", model)?;
    check_discrete("controller K", controller)?;
    check_discrete("weight W1", weight)?;
    let (p, m) = (model.n_outputs(), model.n_inputs());
    let mismatch = |what, expected, got| Error::DimensionMismatch {
        what,
        expected,
        got,
    };
    if controller.n_inputs() != p {
        return Err(mismatch(
            "controller K inputs vs model outputs",
            p,
            controller.n_inputs(),
        ));
    }
    if controller.n_outputs() != m {
        return Err(mismatch(
            "controller K outputs vs model inputs",
            m,
            controller.n_outputs(),
        ));
    }
    let (what, expected) = match uncertainty {
        Uncertainty::Additive => ("weight W1 inputs vs model inputs (additive)", m),
        Uncertainty::Multiplicative => ("weight W1 inputs vs model outputs (multiplicative)", p),
    };
    if weight.n_inputs() != expected {
        return Err(mismatch(what, expected, weight.n_inputs()));
    }
    Ok((p, m))
}

/// The closed-loop product T whose norms are β_sr and β_dr:
/// W₁K(I + P̂K)⁻¹ (additive) or W₁P̂K(I + P̂K)⁻¹ (multiplicative), MIMO.
/// O(order³).
///
/// Errors: continuous pieces or sizes that do not fit
/// ([`Error::InvalidModel`], [`Error::DimensionMismatch`]),
/// [`Error::Unstable`] when K does not stabilise P̂ or W₁ is unstable
/// (Prop. 6 assumes nominal stability).
pub fn robustness_map(
    model: &StateSpace,
    controller: &StateSpace,
    weight: &StateSpace,
    uncertainty: Uncertainty,
) -> Result<StateSpace> {
    check_pieces(model, controller, weight, uncertainty)?;
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

/// β_sr = ‖T‖∞ = sup_ω σ_max(T(e^{jω})) (Hamiltonian bisection of
/// `lifted-lti`, relative tolerance 1e-12); `theta` in rad/sample. MIMO.
/// O(iterations · order³).
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
    crate::error::check_at_least_one("slow period n", n)?;
    if opts.grid < 8
        || !(opts.theta_tol > 0.0 && opts.theta_tol.is_finite())
        || opts.max_work.is_nan()
        || opts.max_work <= 0.0
    {
        return Err(Error::InvalidArgument {
            what: "robustness options",
            reason: "grid >= 8, theta_tol > 0 and max_work > 0 required".into(),
        });
    }
    // The grid values (θ, f(θ)) and their order.
    lifted_linalg::budget::MemoryBudget::default().check(
        "the theta grid of the robustness measure",
        lifted_linalg::budget::Size::f64s(opts.grid).times(3),
    )?;
    Ok(())
}

/// θ values [`maximise`] evaluates: the grid, then for each of the best
/// three grid points two starts and one golden-section step per factor
/// 1/φ until the bracket 2π/grid is below `theta_tol`.
fn theta_evaluations(opts: &RobustnessOptions) -> f64 {
    let bracket = 2.0 * std::f64::consts::PI / opts.grid as f64;
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let steps = ((opts.theta_tol / bracket).ln() / g.ln()).ceil().max(0.0);
    opts.grid as f64 + 3.0 * (2.0 + steps)
}

/// [`Error::TooMuchWork`] when β_dr at slow period `n` for the map `t`
/// would exceed [`RobustnessOptions::max_work`], and the memory of the
/// n-alias stack against the memory budget.
fn check_alias_work(t: &StateSpace, n: usize, opts: &RobustnessOptions) -> Result<()> {
    let (q, p) = (t.n_outputs(), t.n_inputs());
    let order = (t.order() + 1) as f64;
    let per_eval = 10.0 * order.powi(3) + 8.0 * (q * p) as f64 * order;
    let flops = theta_evaluations(opts) * n as f64 * per_eval;
    if flops > opts.max_work {
        return Err(Error::TooMuchWork {
            what: "beta_dr",
            flops,
            limit: opts.max_work,
            hint: "lower the slow period n or the theta grid, or raise max_work",
        });
    }
    use lifted_linalg::budget::{MemoryBudget, Size};
    // Complex n q × p stack and its real embedding (2nq × 2p).
    let need =
        Size::matrices(2, n, q.saturating_mul(p)).plus(Size::matrices(4, n, q.saturating_mul(p)));
    MemoryBudget::default().check("the beta_dr alias stack (slow period n)", need)?;
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

/// β_dr in closed form (alias formula):
/// max_θ √(λ_max((1/n)Σ_{l<n}T(z_l)ᴴT(z_l))), z_l = e^{j(θ+2πl)/n}; for
/// SISO max_θ √((1/n)Σ_{l<n}|T(z_l)|²) (spec A3.11). n = 1 gives β_sr.
/// θ search: grid plus golden section ([`RobustnessOptions`]).
/// O(grid · n · (order³ + q·p²)).
///
/// Stability-robustness measures of thesis §9.5 (Prop. 6, Cor. 1, §9.7):
/// β_sr = ‖W₁(I + KP̂)⁻¹K‖∞ and β_dr = ‖W̲₁(I + K̲P̲̂)⁻¹K̲R₁‖∞ (9.8), and their
/// multiplicative-uncertainty versions.
///
/// Lifting is an algebra homomorphism on LTI systems, so
/// W̲₁(I + K̲P̲̂)⁻¹K̲ = T̲ with T = W₁K(I + P̂K)⁻¹ (additive) or
/// W₁P̂K(I + P̂K)⁻¹ (multiplicative). For LTI pieces the lifted response is
/// T̲(e^{jθ}) = (V⊗I)·blockdiag(T(z_l))·(V⊗I)ᴴ with z_l = e^{j(θ+2πl)/n} and
/// V_{il} = z_lⁱ/√n unitary, and R₁ = e₁e₁ᵀ⊗I_p keeps the first block
/// column, so T̲R₁ has the singular values of (1/√n)[T(z_0); …; T(z_{n−1})]:
///
/// β_dr = max_θ √(λ_max((1/n)Σ_{l<n} T(z_l)ᴴT(z_l))),  β_sr = ‖T‖∞.
///
/// For SISO this is max_θ √((1/n)Σ_l|T(z_l)|²) (spec A3.11). **MIMO
/// meaning:** all p outputs are sampled together every n fast samples (one
/// slow sampler, Fig. 9.3 with a vector y); Δ is any stable LTI
/// perturbation with ‖Δ‖∞ < 1 (additive P = P̂ + ΔW₁ with Δ p×q and W₁ q×m,
/// or multiplicative P = (I + ΔW₁)P̂ with W₁ q×p), and β_dr < 1 is the
/// small-gain condition of Prop. 6 for it (sufficient, not necessary: the
/// lifted Δ̲ is structured). β_dr is the worst gain over input directions w
/// of the root-mean-square over the n aliases of ‖T(z_l)w‖: the switch lets
/// the perturbation act on the loop only at the slow instants, where the
/// n aliases of a direction add up incoherently. β_sr/√n ≤ β_dr ≤ β_sr
/// (λ_max of a mean is at most the largest λ_max and at least 1/n of it).
///
/// Three routes compute β_dr: [`beta_dr`] (the alias closed form above),
/// [`beta_dr_lifted`] (σ_max of the lifted state-space responses) and
/// [`beta_socp`] (the conic form of (9.8) on a θ grid, solved by clarabel).
/// T is evaluated as a closed-loop state space, which is finite at θ = 0
/// even when K has an integrator (spec pitfall 10).
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
    check_alias_work(&t, n, opts)?;
    maximise(|th| alias_gain(&t, n, th), opts)
}

/// σ_max of the lifted T̲(e^{jθ})R₁ by the alias formula:
/// σ_max((1/√n)[T(z_0); …; T(z_{n−1})]) = √(λ_max((1/n)Σ_l T(z_l)ᴴT(z_l))),
/// z_l = e^{j(θ+2πl)/n}; for one input √((1/n)Σ_l ‖T(z_l)‖₂²).
/// O(n · (order³ + q·p²)).
///
/// Errors: `n = 0`, non-finite θ, evaluation at a pole.
pub fn alias_gain(t: &StateSpace, n: usize, theta: f64) -> Result<f64> {
    crate::error::check_at_least_one("slow period n", n)?;
    crate::error::check_finite_slice("theta", &[theta])?;
    let (q, p) = (t.n_outputs(), t.n_inputs());
    let mut stack = DMatrix::from_element(n * q, p, Complex64::new(0.0, 0.0));
    for l in 0..n {
        let w = (theta + 2.0 * std::f64::consts::PI * l as f64) / n as f64;
        let g = t.eval_complex(Complex64::from_polar(1.0, w))?;
        stack.rows_mut(l * q, q).copy_from(&g);
    }
    let s = if p == 1 {
        stack.iter().map(|z| z.norm_sqr()).sum::<f64>().sqrt()
    } else {
        sigma_max(&stack)?
    };
    Ok(s / (n as f64).sqrt())
}

/// Lifted response of a discrete system at e^{jθ} (lifted by n, time-major).
/// O(n²·order³) for the lifting, O(order³) for the evaluation.
///
/// Errors: lifting errors, θ at a lifted pole.
pub fn lifted_response(sys: &StateSpace, n: usize, theta: f64) -> Result<DMatrix<Complex64>> {
    Ok(lift(sys, n)?.eval_complex(Complex64::from_polar(1.0, theta))?)
}

/// The lifted pieces W̲₁, K̲, P̲̂ of a β_dr computation (time-major lifting,
/// MIMO).
#[derive(Debug, Clone)]
pub struct LiftedPieces {
    w: StateSpace,
    k: StateSpace,
    p: StateSpace,
    outputs: usize,
    uncertainty: Uncertainty,
}

impl LiftedPieces {
    /// Lifts the three pieces (P̂ p×m, K m×p, W₁) by n. O(n²·order³).
    ///
    /// Errors: as [`robustness_map`], lifting errors (`n = 0`).
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
            outputs: model.n_outputs(),
            uncertainty,
        })
    }

    /// M̲(e^{jθ}) = W̲₁(I + K̲P̲̂)⁻¹K̲R₁ (additive, (9.8)) or
    /// W̲₁P̲̂(I + K̲P̲̂)⁻¹K̲R₁ (multiplicative, §9.7), from the lifted state
    /// spaces (no alias formula); R₁ = e₁e₁ᵀ⊗I_p (all outputs sampled at the
    /// slow instants). With `switch = false` R₁ is replaced by I (the lifted
    /// β_sr map). Size nq×np. O(order³ + (nm)³).
    ///
    /// Errors: θ at a lifted pole (θ = 0 when K has an integrator), singular
    /// I + K̲P̲̂.
    pub fn response(&self, theta: f64, switch: bool) -> Result<DMatrix<Complex64>> {
        let z = Complex64::from_polar(1.0, theta);
        let w = self.w.eval_complex(z)?;
        let k = self.k.eval_complex(z)?;
        let p = self.p.eval_complex(z)?;
        let i = DMatrix::<Complex64>::identity(k.nrows(), k.nrows());
        let mut rhs = k.clone();
        if switch {
            for c in self.outputs..rhs.ncols() {
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
/// spaces, maximised like [`beta_dr`]. O(grid · (nm)³ + n²·order³).
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

/// Options of [`beta_socp`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ConicOptions {
    /// Number K of frequencies θ_k = π(k + ½)/K on (0, π) (θ = 0 is left out:
    /// a lifted integrator is singular there). Default 1000: for the §9.6
    /// example the grid maximum is then within 4.1e-7 of the supremum
    /// (n = 1 … 8; the grid error is at most ½·max|f″|·(π/2K)²).
    pub grid: usize,
    /// Tolerances of the SOCP and its cutting planes.
    pub minimax: MinimaxOptions,
}

impl Default for ConicOptions {
    fn default() -> Self {
        Self {
            grid: 1000,
            minimax: MinimaxOptions::default(),
        }
    }
}

/// The conic (SOCP) value of a robustness measure.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ConicBeta {
    /// Optimum t* of the SOCP min t s.t. σ_max(M̲(e^{jθ_k})) ≤ t for all k:
    /// a lower bound of the measure on the grid (equal to it up to the solver
    /// tolerance for one-column maps, i.e. SISO).
    pub value: f64,
    /// max_k σ_max(M̲(e^{jθ_k})) evaluated directly: the grid maximum (the
    /// SOCP's achieved value).
    pub grid_max: f64,
    /// The grid frequency θ_k attaining `grid_max` (rad per lifted sample).
    pub theta: f64,
    /// SOCP solves used (1 for one-column maps).
    pub rounds: usize,
}

/// Robustness measure (9.8) as a convex programme: β = min t subject to
/// σ_max(M̲(e^{jθ_k})) ≤ t on the grid θ_k = π(k + ½)/K, with
/// M̲ = W̲₁(I + K̲P̲̂)⁻¹K̲R₁ from the lifted state spaces
/// ([`LiftedPieces::response`], restricted to its p nonzero columns); n = 1
/// gives β_sr (R₁ = I). For SISO the columns are vectors and each
/// constraint is one second-order cone 𝒬^{1+2n}: one SOCP; MIMO uses SOCP
/// cutting planes ([`NormMinimax`]). The programme has no design variable
/// (the controller is fixed), so its optimum is the grid maximum; it is an
/// evaluation path independent of the alias formula and of the θ search of
/// [`beta_dr`], and the one-variable case of the Prop. 5 programmes
/// ([`crate::prop5`]). O(K · ((nm)³ + n²qp) + SOCP with K·p cones of
/// dimension 1 + 2nq).
///
/// Errors: as [`LiftedPieces::new`], `grid = 0`, bad tolerances,
/// [`Error::Solver`], [`Error::NoConvergence`].
pub fn beta_socp(
    model: &StateSpace,
    controller: &StateSpace,
    weight: &StateSpace,
    uncertainty: Uncertainty,
    n: usize,
    opts: &ConicOptions,
) -> Result<ConicBeta> {
    if opts.grid == 0 {
        return Err(Error::InvalidArgument {
            what: "conic options grid",
            reason: "need at least one frequency".into(),
        });
    }
    opts.minimax.validate()?;
    let pieces = LiftedPieces::new(model, controller, weight, uncertainty, n)?;
    let p = model.n_outputs();
    let thetas = theta_grid(opts.grid);
    let mut mats = Vec::with_capacity(thetas.len());
    for &th in &thetas {
        mats.push(pieces.response(th, true)?.columns(0, p).into_owned());
    }
    let problem = NormMinimax::new(mats, vec![Vec::new(); thetas.len()])?;
    let sol = problem.solve(&opts.minimax)?;
    Ok(ConicBeta {
        value: sol.lower_bound,
        grid_max: sol.value,
        theta: thetas[sol.argmax],
        rounds: sol.rounds,
    })
}

/// θ_k = π(k + ½)/K, k < K.
pub(crate) fn theta_grid(k: usize) -> Vec<f64> {
    (0..k)
        .map(|i| std::f64::consts::PI * (i as f64 + 0.5) / k as f64)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn first_order(a: f64, b: f64) -> StateSpace {
        StateSpace::new(
            DMatrix::from_element(1, 1, a),
            DMatrix::from_element(1, 1, b),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::zeros(1, 1),
            Some(1.0),
        )
        .unwrap()
    }

    #[test]
    fn beta_dr_work_is_bounded() {
        let (p, k) = (first_order(0.9, 0.15), first_order(0.0, 0.5));
        let w = StateSpace::gain(DMatrix::identity(1, 1), Some(1.0)).unwrap();
        let opts = RobustnessOptions {
            grid: 64,
            ..Default::default()
        };
        assert!(beta_dr(&p, &k, &w, Uncertainty::Additive, 4, &opts).is_ok());
        let e = beta_dr(&p, &k, &w, Uncertainty::Additive, 100_000_000, &opts).unwrap_err();
        assert!(matches!(e, Error::TooMuchWork { .. }), "{e}");
        let huge_grid = RobustnessOptions {
            grid: usize::MAX / 2,
            ..Default::default()
        };
        let e = beta_dr(&p, &k, &w, Uncertainty::Additive, 2, &huge_grid).unwrap_err();
        assert!(
            matches!(e, Error::Linalg(lifted_linalg::Error::TooLarge { .. })),
            "{e}"
        );
    }
}

//! Prop. 5 (thesis §9.4) as convex programmes on a frequency grid.

use lifted_lti::StateSpace;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

use crate::conic::{MinimaxOptions, NormMinimax};
use crate::error::{Error, Result};
use crate::lifting::lift;
use crate::model::check_discrete;
use crate::robust::theta_grid;
use lifted_linalg::spectral_radius;

/// Options of [`gamma_sr`], [`gamma_dr`] and [`prop5`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Prop5Options {
    /// FIR length L of Q (taps Q_0 … Q_{L−1}). Default 8 (spec A3.11:
    /// "restrict Q to FIR of length L").
    pub fir_length: usize,
    /// Number K of grid frequencies on (0, π): θ_k = π(k + ½)/K for the
    /// lifted map, ω_k the same points for [`gamma_sr`]. Default 64.
    pub grid: usize,
    /// Tolerances of the SOCP and its cutting planes.
    pub minimax: MinimaxOptions,
}

impl Default for Prop5Options {
    fn default() -> Self {
        Self {
            fir_length: 8,
            grid: 64,
            minimax: MinimaxOptions::default(),
        }
    }
}

/// An optimal FIR Youla parameter and its cost.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelMatching {
    /// Cost max_k σ_max on the grid at `taps`: the achieved value (an
    /// upper bound of γ(L) on the grid).
    pub gamma: f64,
    /// Optimum of the last relaxed SOCP: γ(L) ≥ `lower_bound` (up to the
    /// solver tolerance).
    pub lower_bound: f64,
    /// Q_0 … Q_{L−1}, each m×p.
    pub taps: Vec<DMatrix<f64>>,
    /// SOCP solves used.
    pub rounds: usize,
}

/// γ_sr(L) and γ_dr(L) on consistent grids (see [`prop5`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Prop5Comparison {
    /// Slow period n.
    pub n: usize,
    /// (9.3) on the n·K fast frequencies aliasing onto the θ grid.
    pub single_rate: ModelMatching,
    /// (9.7) on the θ grid.
    pub dual_rate: ModelMatching,
    /// J_sr(Q*_dr/n): the single-rate cost of the shift average of the
    /// dual-rate optimum; γ_sr ≤ `averaged` ≤ γ_dr.
    pub averaged: f64,
}

/// Checks P (p×m) and W₂ (p×q): discrete, same sample time, stable; returns
/// (p, m).
fn check_plant_weight(plant: &StateSpace, w2: &StateSpace) -> Result<(usize, usize)> {
    check_discrete("plant P", plant)?;
    check_discrete("weight W2", w2)?;
    if plant.ts() != w2.ts() {
        return Err(Error::InvalidModel {
            what: "weight W2",
            reason: format!(
                "sample time {:?} differs from the plant's {:?}",
                w2.ts(),
                plant.ts()
            ),
        });
    }
    if w2.n_outputs() != plant.n_outputs() {
        return Err(Error::DimensionMismatch {
            what: "weight W2 outputs vs plant outputs",
            expected: plant.n_outputs(),
            got: w2.n_outputs(),
        });
    }
    for (what, s) in [
        ("plant P (the Youla form (9.2) needs a stable P)", plant),
        ("weight W2", w2),
    ] {
        let rho = spectral_radius(s.a())?;
        if rho >= 1.0 {
            return Err(Error::Unstable {
                what,
                spectral_radius: rho,
            });
        }
    }
    Ok((plant.n_outputs(), plant.n_inputs()))
}

fn check_opts(opts: &Prop5Options, n: usize) -> Result<()> {
    if opts.fir_length == 0 || opts.grid == 0 || n == 0 {
        return Err(Error::InvalidArgument {
            what: "Prop. 5 options",
            reason: format!(
                "fir_length ({}), grid ({}) and n ({n}) must be at least 1",
                opts.fir_length, opts.grid
            ),
        });
    }
    opts.minimax.validate()
}

fn point(w: f64) -> Complex64 {
    Complex64::from_polar(1.0, w)
}

/// The model-matching problem at the frequencies `points`: the dual-rate
/// map (9.7) of the plant lifted by n, or with n = 1 (lifting by 1 is the
/// identity, R₁ = I) the single-rate map (9.3) at fast frequencies.
fn matching_problem(
    plant: &StateSpace,
    w2: &StateSpace,
    n: usize,
    taps: usize,
    points: &[f64],
) -> Result<NormMinimax> {
    let (p, m) = (plant.n_outputs(), plant.n_inputs());
    let pl = lift(plant, n)?;
    let wl = lift(w2, n)?;
    let mut constant = Vec::with_capacity(points.len());
    let mut terms = Vec::with_capacity(points.len());
    for &th in points {
        let z = point(th);
        let pz = pl.eval_complex(z)?;
        let wz = wl.eval_complex(z)?;
        let mut row = Vec::with_capacity(taps * m * p);
        for i in 0..taps {
            let (s, alpha) = (i / n, i % n);
            let shift = -point(-th * s as f64);
            for b in 0..p {
                for a in 0..m {
                    row.push(pz.column(alpha * m + a) * wz.row(b) * shift);
                }
            }
        }
        constant.push(wz);
        terms.push(row);
    }
    NormMinimax::new(constant, terms)
}

/// Decision vector (tap-major, then column-major within a tap) → Q_i.
fn taps_from(x: &DVector<f64>, taps: usize, m: usize, p: usize) -> Vec<DMatrix<f64>> {
    (0..taps)
        .map(|i| DMatrix::from_fn(m, p, |a, b| x[i * m * p + b * m + a]))
        .collect()
}

fn solve(problem: &NormMinimax, opts: &Prop5Options, m: usize, p: usize) -> Result<ModelMatching> {
    let sol = problem.solve(&opts.minimax)?;
    Ok(ModelMatching {
        gamma: sol.value,
        lower_bound: sol.lower_bound,
        taps: taps_from(&sol.x, opts.fir_length, m, p),
        rounds: sol.rounds,
    })
}

/// γ_sr(L) = min over FIR Q of max_k σ_max((I − PQ)W₂)(e^{jω_k}), ω_k =
/// π(k + ½)/K: the single-rate model matching (9.3). An SOCP for SISO
/// (one second-order cone per frequency); SOCP cutting planes when W₂ has
/// several inputs. O(K·L·m·p·q) to set up plus the SOCP with L·m·p + 1
/// variables.
///
/// Errors: [`Error::InvalidModel`] (continuous, different sample times),
/// [`Error::DimensionMismatch`] (W₂ outputs ≠ P outputs),
/// [`Error::Unstable`] (P or W₂), bad options, [`Error::Solver`],
/// [`Error::NoConvergence`].
pub fn gamma_sr(plant: &StateSpace, w2: &StateSpace, opts: &Prop5Options) -> Result<ModelMatching> {
    check_opts(opts, 1)?;
    let (p, m) = check_plant_weight(plant, w2)?;
    let problem = matching_problem(plant, w2, 1, opts.fir_length, &theta_grid(opts.grid))?;
    solve(&problem, opts, m, p)
}

/// γ_dr(L) = min over FIR Q of max_k σ_max((I − P̲Q̲R₁)W̲₂)(e^{jθ_k}): the
/// dual-rate model matching (9.7), lifted by n. The lifted map has n·q
/// columns, so this is a semidefinite constraint per frequency, solved by
/// SOCP cutting planes. O(n²·order³ + K·L·m·p·n²q) to set up plus the
/// cutting-plane rounds.
///
/// Errors: as [`gamma_sr`], `n = 0`.
pub fn gamma_dr(
    plant: &StateSpace,
    w2: &StateSpace,
    n: usize,
    opts: &Prop5Options,
) -> Result<ModelMatching> {
    check_opts(opts, n)?;
    let (p, m) = check_plant_weight(plant, w2)?;
    let problem = matching_problem(plant, w2, n, opts.fir_length, &theta_grid(opts.grid))?;
    solve(&problem, opts, m, p)
}

/// Prop. 5 (thesis §9.4) as convex programmes: the best disturbance
/// rejection of the fast single-rate loop, γ_sr = min_Q ‖(I − PQ)W₂‖∞ (9.3),
/// and of the dual-rate inferential loop, γ_dr = min_Q ‖(I − P̲Q̲R₁)W̲₂‖∞
/// (9.7), over stable LTI Q (Youla parameter of a stable P,
/// K = (I − QP)⁻¹Q (9.2)). Prop. 5: γ_dr ≥ γ_sr.
///
/// Restriction (spec A3.11, optional check): Q is an FIR filter
/// Q(z) = Σ_{i<L} Q_i z^{−i} (Q_i m×p real), and the H∞ norm is taken on the
/// frequency grid θ_k = π(k + ½)/K of the lifted system; the single-rate
/// problem here uses the n·K fast frequencies ω = (θ_k + 2πl)/n that
/// alias onto that grid, where σ_max of the lifted single-rate map equals
/// max_l σ_max((I − PQ)W₂)(e^{jω}). Both costs are affine in the taps inside
/// a spectral norm:
///
/// * single rate, at ω: W₂ − Σ_{i,a,b} Q_i(a, b) e^{−jωi} P_{:,a}(W₂)_{b,:};
/// * dual rate, at θ (time-major lifting, R₁ = e₁e₁ᵀ⊗I_p): Q̲R₁W̲₂ keeps the
///   first block column of Q̲, whose block α is Σ_s Q_{sn+α} z^{−s}, so
///   W̲₂ − Σ_{i,a,b} Q_i(a, b) z^{−⌊i/n⌋} P̲_{:,(i mod n)m+a}(W̲₂)_{b,:}.
///
/// and the minimax is solved by [`NormMinimax`] (SOCP; SOCP cutting planes
/// when the maps have several columns, which is always the case for the
/// lifted dual-rate map: (9.7) is a semidefinite programme, not an SOCP).
///
/// Why the grid inequality is exact: the thesis' step "periodic control
/// offers no advantage" is an average over shifts. The periodic Youla
/// parameter Q₁ with Q̲₁ = Q̲*R₁ averages to the LTI FIR Q*/n (same
/// length), and at every θ the lifted shift is a unitary that commutes with
/// the lifted LTI P and W₂, so σ_max((I − P̲Q̲*R₁)W̲₂) ≥ σ_max of the
/// averaged map pointwise. Hence γ_sr(L) ≤ J_sr(Q*/n) ≤ γ_dr(L) on these
/// grids; [`Prop5Comparison::averaged`] reports the middle term.
///
/// Returns γ_dr(L) on θ_k, γ_sr(L) on the n·K fast frequencies
/// (θ_k + 2πl)/n, and the shift-average certificate J_sr(Q*_dr/n). Cost:
/// [`gamma_dr`] plus [`gamma_sr`] on n·K frequencies.
///
/// Errors: as [`gamma_dr`].
pub fn prop5(
    plant: &StateSpace,
    w2: &StateSpace,
    n: usize,
    opts: &Prop5Options,
) -> Result<Prop5Comparison> {
    check_opts(opts, n)?;
    let (p, m) = check_plant_weight(plant, w2)?;
    let thetas = theta_grid(opts.grid);
    let omegas: Vec<f64> = thetas
        .iter()
        .flat_map(|th| (0..n).map(move |l| (th + 2.0 * std::f64::consts::PI * l as f64) / n as f64))
        .collect();
    let sr_problem = matching_problem(plant, w2, 1, opts.fir_length, &omegas)?;
    let single_rate = solve(&sr_problem, opts, m, p)?;
    let dr_problem = matching_problem(plant, w2, n, opts.fir_length, &thetas)?;
    let dr = dr_problem.solve(&opts.minimax)?;
    let (averaged, _) = sr_problem.eval(&(&dr.x / n as f64))?;
    Ok(Prop5Comparison {
        n,
        single_rate,
        dual_rate: ModelMatching {
            gamma: dr.value,
            lower_bound: dr.lower_bound,
            taps: taps_from(&dr.x, opts.fir_length, m, p),
            rounds: dr.rounds,
        },
        averaged,
    })
}

//! Minimax of spectral norms of affine complex matrix functions by SOCP
//! (clarabel): the engine of [`crate::beta_socp`] and the Prop. 5 programmes.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSolver, IPSolver, SecondOrderConeT, SolverStatus, SupportedConeT,
};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

use crate::complex_svd::{real_embedding, sigma_max};
use crate::error::{Error, Result};

/// Tolerances of [`NormMinimax::solve`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MinimaxOptions {
    /// Relative gap (upper − lower)/upper at which the cutting planes stop.
    /// Default 1e-6: six certified digits, far below the error of a
    /// frequency grid; much smaller gaps can stall the interior point on the
    /// nearly parallel cones of late rounds. One-column problems close it in
    /// the first round, up to the solver tolerance.
    pub gap_tol: f64,
    /// Maximum number of SOCP solves (cutting-plane rounds). Default 60.
    pub max_rounds: usize,
    /// clarabel's absolute/relative gap and feasibility tolerances.
    /// Default 1e-10.
    pub solver_tol: f64,
}

impl Default for MinimaxOptions {
    fn default() -> Self {
        Self {
            gap_tol: 1e-6,
            max_rounds: 60,
            solver_tol: 1e-10,
        }
    }
}

impl MinimaxOptions {
    /// Checks the ranges (positive finite tolerances, at least one round).
    ///
    /// Errors: [`Error::InvalidArgument`].
    pub fn validate(&self) -> Result<()> {
        let ok = |v: f64| v > 0.0 && v.is_finite();
        if !ok(self.gap_tol) || !ok(self.solver_tol) || self.max_rounds == 0 {
            return Err(Error::InvalidArgument {
                what: "minimax options",
                reason: format!(
                    "gap_tol ({}) and solver_tol ({}) must be positive and finite, max_rounds ({}) >= 1",
                    self.gap_tol, self.solver_tol, self.max_rounds
                ),
            });
        }
        Ok(())
    }
}

/// Result of [`NormMinimax::solve`].
#[derive(Debug, Clone, PartialEq)]
pub struct MinimaxSolution {
    /// The minimiser x (length v).
    pub x: DVector<f64>,
    /// max_k σ_max(M_k(x)) at the returned x: an achieved value, hence an
    /// upper bound of γ.
    pub value: f64,
    /// Optimum t* of the last (relaxed) SOCP: γ ≥ `lower_bound` up to the
    /// solver tolerance. Equal to `value` within the solver tolerance for
    /// one-column problems.
    pub lower_bound: f64,
    /// The index k attaining `value`.
    pub argmax: usize,
    /// SOCP solves used.
    pub rounds: usize,
    /// Cones in the last SOCP.
    pub cones: usize,
}

/// The data A_k, B_{k,i} of min_x max_k σ_max(A_k + Σᵢ xᵢ B_{k,i}).
///
/// Minimax of spectral norms of affine complex matrix functions, as a
/// second-order cone programme (SOCP) solved by clarabel.
///
/// Problem (the frequency-gridded form of the H∞ model-matching problems
/// (9.3), (9.7) and of the robustness conditions (9.8)):
///
/// γ = min_{x ∈ ℝᵛ} max_k σ_max(M_k(x)),  M_k(x) = A_k + Σᵢ xᵢ B_{k,i} ∈ ℂ^{r×c}.
///
/// Epigraph form: min t subject to σ_max(M_k(x)) ≤ t for every k. When M_k
/// has one column, σ_max = ‖M_k(x)‖₂ and the constraint is exactly the
/// second-order cone (t, Re M_k(x), Im M_k(x)) ∈ 𝒬^{1+2r}: one SOCP solve
/// gives γ. With c > 1 columns σ_max(M) ≤ t is a linear matrix inequality
/// (‖Mw‖₂ ≤ t for every unit w ∈ ℂᶜ), which finitely many cones cannot
/// represent; clarabel's PSD cone needs a system BLAS/LAPACK (feature
/// `sdp`), so the LMI is approached from outside by cutting planes. The
/// model keeps the cones ‖M_k(x)w‖₂ ≤ t for a finite set of unit vectors w
/// per k (to start: the unit vectors e_j and the top right singular vector
/// of A_k). Each round
///
/// 1. solves the relaxation min t over these cones: its optimum t* is a
///    **lower bound** of γ (fewer constraints), its solution a trial point;
/// 2. takes a level step (the level method of Lemaréchal, Nemirovskii and
///    Nesterov, which avoids the slow, unstable tail of plain Kelley
///    cutting planes): with ℓ = lower + ½(upper − lower), the point nearest
///    the best point so far at which every cone holds with t = ℓ (an SOCP
///    with objective ½‖x − x_best‖²); an empty level set proves γ ≥ ℓ;
/// 3. at each trial point evaluates σ_max(M_k) exactly (an **upper bound**
///    when it improves on the best point) and adds a cone for every right
///    singular vector whose singular value exceeds the model's value there
///    (all of them, so repeated top singular values at the minimax point
///    are caught in one round).
///
/// The rounds stop when (upper − lower)/upper ≤ [`MinimaxOptions::gap_tol`].
/// The data are scaled so that max_k σ_max(A_k) = 1; a level step that
/// stalls is retried once with ℓ = lower + 0.9(upper − lower), then skipped
/// for that round; a relaxation that stalls after the first round keeps the
/// previous lower bound.
///
/// ```
/// use lifted_mpc::{MinimaxOptions, NormMinimax};
/// use nalgebra::DMatrix;
/// use num_complex::Complex64;
/// # fn main() -> Result<(), lifted_mpc::Error> {
/// // min over real x of max(|1 − x|, |0.5j + x|): x = 0.375, value 0.625
/// let c = |re: f64, im: f64| DMatrix::from_element(1, 1, Complex64::new(re, im));
/// let p = NormMinimax::new(vec![c(1.0, 0.0), c(0.0, 0.5)], vec![vec![c(-1.0, 0.0)], vec![c(1.0, 0.0)]])?;
/// let s = p.solve(&MinimaxOptions::default())?;
/// assert!((s.value - 0.625).abs() < 1e-8 && (s.x[0] - 0.375).abs() < 1e-6);
/// # Ok(()) }
/// ```
///
/// Complexity per round: two interior-point solves with v (+1) variables and
/// Σ_cones (1 + 2r) rows (dense rows of length v), plus K singular value
/// decompositions of 2r×2c real embeddings per trial point,
/// O(K(v·r·c + r·c²)). The number of cones grows with the rounds.
#[derive(Debug, Clone)]
pub struct NormMinimax {
    constant: Vec<DMatrix<Complex64>>,
    terms: Vec<Vec<DMatrix<Complex64>>>,
    vars: usize,
}

/// One cone ‖(A_k + Σ xᵢB_{k,i})w‖₂ ≤ t: a = A_k w, b[i] = B_{k,i} w.
struct Cut {
    a: DVector<Complex64>,
    b: Vec<DVector<Complex64>>,
}

impl Cut {
    fn new(
        constant: &DMatrix<Complex64>,
        terms: &[DMatrix<Complex64>],
        w: &DVector<Complex64>,
    ) -> Self {
        Self {
            a: constant * w,
            b: terms.iter().map(|t| t * w).collect(),
        }
    }
}

fn all_finite(m: &DMatrix<Complex64>) -> bool {
    m.iter().all(|z| z.re.is_finite() && z.im.is_finite())
}

/// σ_max(M) and unit right singular vectors w (‖Mw‖₂ = σ_j) of every
/// singular value σ_j > `above` (always at least the top one), from the real
/// embedding; complex multiples of one another are kept once.
fn singular_directions(
    m: &DMatrix<Complex64>,
    above: f64,
) -> Result<(f64, Vec<DVector<Complex64>>)> {
    let c = m.ncols();
    if c == 1 {
        let s = m.column(0).iter().map(|z| z.norm_sqr()).sum::<f64>().sqrt();
        return Ok((s, vec![DVector::from_element(1, Complex64::new(1.0, 0.0))]));
    }
    let svd = lifted_linalg::svd(&real_embedding(m))?;
    let top = svd.s.iter().copied().fold(0.0, f64::max);
    let mut dirs: Vec<DVector<Complex64>> = Vec::new();
    for (j, &sj) in svd.s.iter().enumerate() {
        if j > 0 && sj <= above {
            break;
        }
        let w = DVector::from_fn(c, |i, _| Complex64::new(svd.v[(i, j)], svd.v[(i + c, j)]));
        if !parallel_to_any(&w, &dirs) {
            dirs.push(w);
        }
    }
    Ok((top, dirs))
}

/// |⟨w, u⟩| ≥ 1 − 1e-9 for some unit u in `set`: (nearly) the same complex
/// line (angle below 4.5e-5), whose cone would add degeneracy but no
/// information (the gain along it differs by O(angle²)).
fn parallel_to_any(w: &DVector<Complex64>, set: &[DVector<Complex64>]) -> bool {
    set.iter().any(|u| u.dotc(w).norm() >= 1.0 - 1e-9)
}

/// Runs clarabel on min ½zᵀPz + qᵀz subject to b − Az ∈ cones (P: upper
/// triangle) with gap and feasibility tolerances `tol`; returns the status
/// and the primal solution (a certificate for infeasible statuses).
fn run_clarabel(
    p: &CscMatrix<f64>,
    q: &[f64],
    a: &CscMatrix<f64>,
    b: &[f64],
    cones: &[SupportedConeT<f64>],
    tol: f64,
) -> Result<(SolverStatus, Vec<f64>)> {
    let settings = DefaultSettings {
        verbose: false,
        tol_gap_abs: tol,
        tol_gap_rel: tol,
        tol_feas: tol,
        ..DefaultSettings::default()
    };
    let mut solver =
        DefaultSolver::new(p, q, a, b, cones, settings).map_err(|e| Error::Solver {
            reason: e.to_string(),
        })?;
    solver.solve();
    Ok((solver.solution.status, solver.solution.x.clone()))
}

/// Solves min ½zᵀPz + qᵀz subject to b − Az ∈ cones with clarabel (P = 0
/// for an LP/SOCP, else its upper triangle); maps the solver status to
/// [`Error::Infeasible`] / [`Error::Solver`].
pub(crate) fn solve_conic(
    p: &CscMatrix<f64>,
    q: &[f64],
    a: &CscMatrix<f64>,
    b: &[f64],
    cones: &[SupportedConeT<f64>],
    tol: f64,
) -> Result<Vec<f64>> {
    match run_clarabel(p, q, a, b, cones, tol)? {
        (SolverStatus::Solved | SolverStatus::AlmostSolved, x) => Ok(x),
        (s @ (SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible), _) => {
            Err(Error::Infeasible {
                status: format!("{s:?}"),
            })
        }
        (s, _) => Err(Error::Solver {
            reason: format!("clarabel status {s:?}"),
        }),
    }
}

/// Outcome of a level step.
enum LevelStep {
    /// A point where every cone holds with t = ℓ.
    Point(DVector<f64>),
    /// A strict primal-infeasibility certificate: γ ≥ ℓ.
    Empty,
    /// The interior point stalled or gave only an approximate certificate.
    Failed,
}

impl NormMinimax {
    /// Validates the data: `constant[k]` = A_k (r_k×c_k, both ≥ 1) and
    /// `terms[k][i]` = B_{k,i} of the same shape, the same number v of terms
    /// for every k, every entry finite, and every variable entering some
    /// B_{k,i} ≠ 0 (a variable that enters nothing leaves the SOCP without a
    /// unique solution).
    ///
    /// Errors: [`Error::InvalidArgument`] (no matrices, an unused variable,
    /// an empty matrix), [`Error::DimensionMismatch`], [`Error::NonFinite`].
    pub fn new(
        constant: Vec<DMatrix<Complex64>>,
        terms: Vec<Vec<DMatrix<Complex64>>>,
    ) -> Result<Self> {
        if constant.is_empty() {
            return Err(Error::InvalidArgument {
                what: "minimax constant matrices",
                reason: "need at least one matrix A_k".into(),
            });
        }
        if terms.len() != constant.len() {
            return Err(Error::DimensionMismatch {
                what: "minimax: number of term lists vs constant matrices",
                expected: constant.len(),
                got: terms.len(),
            });
        }
        let vars = terms[0].len();
        let mut used = vec![false; vars];
        for (a, bs) in constant.iter().zip(&terms) {
            if a.nrows() == 0 || a.ncols() == 0 {
                return Err(Error::InvalidArgument {
                    what: "minimax constant matrices",
                    reason: "every A_k needs at least one row and one column".into(),
                });
            }
            if !all_finite(a) {
                return Err(Error::NonFinite {
                    what: "minimax constant matrix A_k",
                });
            }
            if bs.len() != vars {
                return Err(Error::DimensionMismatch {
                    what: "minimax: number of terms B_{k,i}",
                    expected: vars,
                    got: bs.len(),
                });
            }
            for (i, b) in bs.iter().enumerate() {
                if b.shape() != a.shape() {
                    return Err(Error::DimensionMismatch {
                        what: "minimax: rows of B_{k,i} vs A_k",
                        expected: a.nrows(),
                        got: b.nrows(),
                    });
                }
                if !all_finite(b) {
                    return Err(Error::NonFinite {
                        what: "minimax term matrix B_{k,i}",
                    });
                }
                used[i] |= b.iter().any(|z| z.norm_sqr() > 0.0);
            }
        }
        if let Some(i) = used.iter().position(|u| !u) {
            return Err(Error::InvalidArgument {
                what: "minimax variables",
                reason: format!("variable {i} enters no matrix B_(k,{i})"),
            });
        }
        Ok(Self {
            constant,
            terms,
            vars,
        })
    }

    /// Number of variables v.
    pub fn n_vars(&self) -> usize {
        self.vars
    }

    /// Number of matrices K (frequency points).
    pub fn len(&self) -> usize {
        self.constant.len()
    }

    /// Always false (validated in [`NormMinimax::new`]); for clippy's `len`
    /// convention.
    pub fn is_empty(&self) -> bool {
        self.constant.is_empty()
    }

    /// M_k(x) = A_k + Σᵢ xᵢ B_{k,i}.
    fn matrix(&self, k: usize, x: &DVector<f64>) -> DMatrix<Complex64> {
        let mut m = self.constant[k].clone();
        for (xi, b) in x.iter().zip(&self.terms[k]) {
            m += b * Complex64::new(*xi, 0.0);
        }
        m
    }

    /// max_k σ_max(M_k(x)) and the k attaining it. O(K(v·r·c + r·c²)).
    ///
    /// Errors: [`Error::DimensionMismatch`] (x.len() ≠ v),
    /// [`Error::NonFinite`].
    pub fn eval(&self, x: &DVector<f64>) -> Result<(f64, usize)> {
        self.check_x(x)?;
        let mut best = (f64::NEG_INFINITY, 0);
        for k in 0..self.len() {
            let s = sigma_max(&self.matrix(k, x))?;
            if s > best.0 {
                best = (s, k);
            }
        }
        Ok(best)
    }

    fn check_x(&self, x: &DVector<f64>) -> Result<()> {
        if x.len() != self.vars {
            return Err(Error::DimensionMismatch {
                what: "minimax variables x",
                expected: self.vars,
                got: x.len(),
            });
        }
        crate::error::check_finite_slice("minimax variables x", x.as_slice())
    }

    /// Solves the minimax problem by SOCP (one round for one-column
    /// matrices) or SOCP cutting planes stabilised by the level method
    /// (type docs).
    ///
    /// Errors: invalid options, [`Error::Solver`] when clarabel fails,
    /// [`Error::NoConvergence`] when the gap is still open after
    /// `max_rounds` rounds.
    pub fn solve(&self, opts: &MinimaxOptions) -> Result<MinimaxSolution> {
        opts.validate()?;
        // scale the data so that the cost at x = 0 is 1: the interior point works on
        // a well-scaled t whatever the units of the weights
        let mut scale = 0.0f64;
        for a in &self.constant {
            scale = scale.max(sigma_max(a)?);
        }
        if !(scale > 0.0 && scale.is_finite()) {
            return self.solve_scaled(opts);
        }
        let inv = Complex64::new(1.0 / scale, 0.0);
        let scaled = Self {
            constant: self.constant.iter().map(|a| a * inv).collect(),
            terms: self
                .terms
                .iter()
                .map(|bs| bs.iter().map(|b| b * inv).collect())
                .collect(),
            vars: self.vars,
        };
        let mut sol = scaled.solve_scaled(opts)?;
        sol.value *= scale;
        sol.lower_bound *= scale;
        Ok(sol)
    }

    fn solve_scaled(&self, opts: &MinimaxOptions) -> Result<MinimaxSolution> {
        let mut cuts = Cuts {
            list: Vec::new(),
            lines: vec![Vec::new(); self.len()],
        };
        for (k, a) in self.constant.iter().enumerate() {
            let c = a.ncols();
            let mut start: Vec<DVector<Complex64>> = (0..c)
                .map(|j| {
                    DVector::from_fn(c, |i, _| {
                        Complex64::new(if i == j { 1.0 } else { 0.0 }, 0.0)
                    })
                })
                .collect();
            if c > 1 {
                start.extend(singular_directions(a, f64::INFINITY)?.1);
            }
            cuts.add(self, k, start);
        }
        let mut best: Option<MinimaxSolution> = None;
        let mut lower = f64::NEG_INFINITY;
        let done = |b: &MinimaxSolution, lower: f64| {
            b.value - lower <= opts.gap_tol * b.value.abs().max(f64::MIN_POSITIVE)
        };
        for round in 1..=opts.max_rounds {
            let before = (
                cuts.list.len(),
                lower,
                best.as_ref().map_or(f64::INFINITY, |b| b.value),
            );
            // 1. the relaxation min t over the cones: a lower bound and a trial point
            match self.relaxation(&cuts.list, opts.solver_tol) {
                Ok((x, t)) => {
                    lower = lower.max(t);
                    self.visit(&x, t, &mut cuts, &mut best)?;
                }
                // late rounds can be too degenerate for the interior point; the level
                // step below still moves and certifies bounds
                Err(Error::Solver { .. }) if best.is_some() => {}
                Err(e) => return Err(e),
            }
            let Some(b) = best.as_mut() else {
                continue;
            };
            b.lower_bound = lower;
            b.rounds = round;
            if done(b, lower) {
                b.cones = cuts.list.len();
                return Ok(b.clone());
            }
            // 2. level step: the point nearest the best one where the model is at most
            // ℓ = lower + ½(upper − lower); an empty level set proves γ ≥ ℓ. Close to the
            // optimum the level set is thin and the interior point can stall: then retry
            // once with the wider level lower + 0.9(upper − lower).
            let centre = b.x.clone();
            let mut level = lower + 0.5 * (b.value - lower);
            let mut step = self.level_step(&cuts.list, level, &centre, opts.solver_tol)?;
            if let LevelStep::Failed = step {
                level = lower + 0.9 * (b.value - lower);
                step = self.level_step(&cuts.list, level, &centre, opts.solver_tol)?;
            }
            match step {
                LevelStep::Point(x) => self.visit(&x, level, &mut cuts, &mut best)?,
                LevelStep::Empty => lower = lower.max(level),
                // the relaxation's trial point of the next round still moves the bounds
                LevelStep::Failed => {}
            }
            let Some(b) = best.as_mut() else {
                continue;
            };
            b.lower_bound = lower;
            b.rounds = round;
            b.cones = cuts.list.len();
            if done(b, lower) {
                return Ok(b.clone());
            }
            // no new cone and neither bound moved: the next round would repeat this one
            if (cuts.list.len(), lower, b.value) == before {
                return Err(Error::NoConvergence {
                    what: "SOCP cutting planes (stalled: no new cone, no bound moved)",
                    iterations: round,
                    gap: b.value - lower,
                });
            }
        }
        let gap = best.as_ref().map_or(f64::INFINITY, |b| b.value - lower);
        Err(Error::NoConvergence {
            what: "SOCP cutting planes",
            iterations: opts.max_rounds,
            gap,
        })
    }

    /// Evaluates the exact max σ at x (keeping the best point) and adds a
    /// cone for every direction whose gain exceeds `above`.
    fn visit(
        &self,
        x: &DVector<f64>,
        above: f64,
        cuts: &mut Cuts,
        best: &mut Option<MinimaxSolution>,
    ) -> Result<()> {
        if x.iter().any(|xi| !xi.is_finite()) {
            return Err(Error::Solver {
                reason: "clarabel returned a non-finite solution".into(),
            });
        }
        let mut worst = (f64::NEG_INFINITY, 0);
        for k in 0..self.len() {
            let (s, dirs) = singular_directions(&self.matrix(k, x), above)?;
            if s > worst.0 {
                worst = (s, k);
            }
            if s > above {
                cuts.add(self, k, dirs);
            }
        }
        match best {
            Some(b) if b.value <= worst.0 => {}
            _ => {
                *best = Some(MinimaxSolution {
                    x: x.clone(),
                    value: worst.0,
                    lower_bound: f64::NEG_INFINITY,
                    argmax: worst.1,
                    rounds: 0,
                    cones: 0,
                });
            }
        }
        Ok(())
    }

    /// The relaxation min t over z = [x; t] subject to the cones; returns
    /// (x, t*). Errors: [`Error::Solver`] when clarabel does not solve it.
    fn relaxation(&self, cuts: &[Cut], tol: f64) -> Result<(DVector<f64>, f64)> {
        let v = self.vars;
        let (a, b, cones) = self.cone_rows(cuts, None);
        let p = CscMatrix::new_from_triplets(v + 1, v + 1, Vec::new(), Vec::new(), Vec::new());
        let mut q = vec![0.0; v + 1];
        q[v] = 1.0;
        let z = solve_conic(&p, &q, &a, &b, &cones, tol)?;
        Ok((DVector::from_fn(v, |i, _| z[i]), z[v]))
    }

    /// The level projection min ½‖x − centre‖² subject to every cone with
    /// t = ℓ. It needs only a trial point, so a looser tolerance (at least
    /// 1e-8) is enough and keeps the interior point out of trouble on thin
    /// level sets; only a strict infeasibility certificate counts as proof.
    fn level_step(
        &self,
        cuts: &[Cut],
        level: f64,
        centre: &DVector<f64>,
        tol: f64,
    ) -> Result<LevelStep> {
        let v = self.vars;
        let (a, b, cones) = self.cone_rows(cuts, Some(level));
        let p =
            CscMatrix::new_from_triplets(v, v, (0..v).collect(), (0..v).collect(), vec![1.0; v]);
        let q: Vec<f64> = centre.iter().map(|c| -c).collect();
        let (status, z) = run_clarabel(&p, &q, &a, &b, &cones, tol.max(1e-8))?;
        Ok(match status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => {
                LevelStep::Point(DVector::from_fn(v, |i, _| z[i]))
            }
            SolverStatus::PrimalInfeasible => LevelStep::Empty,
            _ => LevelStep::Failed,
        })
    }

    /// Rows b − Az ∈ 𝒬^{1+2r} of the cones ‖(A_k + Σ xᵢB_{k,i})w‖₂ ≤ t, with
    /// z = [x; t] (`level = None`) or z = x and t = ℓ (`level = Some(ℓ)`).
    fn cone_rows(
        &self,
        cuts: &[Cut],
        level: Option<f64>,
    ) -> (CscMatrix<f64>, Vec<f64>, Vec<SupportedConeT<f64>>) {
        let v = self.vars;
        let nz = if level.is_some() { v } else { v + 1 };
        let (mut ai, mut aj, mut av) = (Vec::new(), Vec::new(), Vec::new());
        let mut rhs = Vec::new();
        let mut cones = Vec::with_capacity(cuts.len());
        let mut row = 0;
        for cut in cuts {
            let r = cut.a.len();
            // s₀ = t (a variable) or ℓ (a constant)
            match level {
                Some(l) => rhs.push(l),
                None => {
                    ai.push(row);
                    aj.push(v);
                    av.push(-1.0);
                    rhs.push(0.0);
                }
            }
            row += 1;
            for part in 0..2 {
                for j in 0..r {
                    let pick = |z: Complex64| if part == 0 { z.re } else { z.im };
                    rhs.push(pick(cut.a[j]));
                    for (i, bi) in cut.b.iter().enumerate() {
                        let val = pick(bi[j]);
                        if val != 0.0 {
                            ai.push(row);
                            aj.push(i);
                            av.push(-val);
                        }
                    }
                    row += 1;
                }
            }
            cones.push(SecondOrderConeT(1 + 2 * r));
        }
        (
            CscMatrix::new_from_triplets(row, nz, ai, aj, av),
            rhs,
            cones,
        )
    }
}

/// The cones of the current relaxation and, per k, their unit vectors.
struct Cuts {
    list: Vec<Cut>,
    lines: Vec<Vec<DVector<Complex64>>>,
}

impl Cuts {
    /// Adds a cone per direction not already present for this k.
    fn add(&mut self, problem: &NormMinimax, k: usize, dirs: Vec<DVector<Complex64>>) {
        for w in dirs {
            if !parallel_to_any(&w, &self.lines[k]) {
                self.list
                    .push(Cut::new(&problem.constant[k], &problem.terms[k], &w));
                self.lines[k].push(w);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(re: f64, im: f64) -> Complex64 {
        Complex64::new(re, im)
    }

    #[test]
    fn one_column_is_exact_in_one_round() {
        // min_x max(|1 − x|, |j·0.5 + x|) over real x: |1 − x| = √(x² + 0.25) ⇒ x = 0.375
        let a = vec![
            DMatrix::from_element(1, 1, c(1.0, 0.0)),
            DMatrix::from_element(1, 1, c(0.0, 0.5)),
        ];
        let b = vec![
            vec![DMatrix::from_element(1, 1, c(-1.0, 0.0))],
            vec![DMatrix::from_element(1, 1, c(1.0, 0.0))],
        ];
        let s = NormMinimax::new(a, b)
            .unwrap()
            .solve(&MinimaxOptions::default())
            .unwrap();
        assert_eq!(s.rounds, 1);
        assert!((s.x[0] - 0.375).abs() < 1e-7, "{}", s.x[0]);
        assert!((s.value - 0.625).abs() < 1e-9);
        assert!((s.lower_bound - 0.625).abs() < 1e-8);
    }

    #[test]
    fn matrix_problem_closes_the_gap() {
        // min_x σ_max([[1, x], [x, −1]]) = √(1 + x²) ⇒ 1 at x = 0, from a shifted start
        let a = vec![DMatrix::from_row_slice(
            2,
            2,
            &[c(1.0, 0.0), c(0.3, 0.0), c(0.3, 0.0), c(-1.0, 0.0)],
        )];
        let b = vec![vec![DMatrix::from_row_slice(
            2,
            2,
            &[c(0.0, 0.0), c(1.0, 0.0), c(1.0, 0.0), c(0.0, 0.0)],
        )]];
        let s = NormMinimax::new(a, b)
            .unwrap()
            .solve(&MinimaxOptions::default())
            .unwrap();
        assert!((s.value - 1.0).abs() < 1e-6, "{s:?}");
        assert!(s.lower_bound <= s.value + 1e-9);
        assert!((s.x[0] + 0.3).abs() < 2e-3);
    }

    #[test]
    fn rejects_bad_data() {
        let one = || DMatrix::from_element(1, 1, c(1.0, 0.0));
        let fill = |rows, z| DMatrix::from_element(rows, 1, z);
        assert!(matches!(
            NormMinimax::new(vec![], vec![]),
            Err(Error::InvalidArgument { .. })
        ));
        assert!(matches!(
            NormMinimax::new(vec![one()], vec![vec![one()], vec![one()]]),
            Err(Error::DimensionMismatch { .. })
        ));
        assert!(matches!(
            NormMinimax::new(vec![one()], vec![vec![fill(2, c(1.0, 0.0))]]),
            Err(Error::DimensionMismatch { .. })
        ));
        assert!(matches!(
            NormMinimax::new(vec![fill(1, c(f64::NAN, 0.0))], vec![vec![]]),
            Err(Error::NonFinite { .. })
        ));
        assert!(matches!(
            NormMinimax::new(vec![one()], vec![vec![fill(1, c(0.0, 0.0))]]),
            Err(Error::InvalidArgument { .. })
        ));
        let p = NormMinimax::new(vec![one()], vec![vec![one()]]).unwrap();
        assert!(matches!(
            p.eval(&DVector::zeros(2)),
            Err(Error::DimensionMismatch { .. })
        ));
        assert!(matches!(
            p.eval(&DVector::from_element(1, f64::INFINITY)),
            Err(Error::NonFinite { .. })
        ));
        assert!(matches!(
            p.solve(&MinimaxOptions {
                gap_tol: 0.0,
                ..MinimaxOptions::default()
            }),
            Err(Error::InvalidArgument { .. })
        ));
    }
}

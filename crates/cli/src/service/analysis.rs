//! The analyses a control engineer reaches for, on one model file
//! (`lifted analyze`, `lifted lqr`, `lifted bode --omega`): every number
//! comes from lifted-lti / lifted-linalg, this module only gathers them and
//! says why a quantity is not defined.
//!
//! * **Poles** λ(A); **transmission zeros** (Emami-Naeini & Van Dooren,
//!   [`lifted_lti::StateSpace::zeros`]); **DC gain** G(0) (continuous) or
//!   G(1) (discrete), infinite with a pole at s = 0 / z = 1.
//! * **Stability**: the spectral radius ρ(A) = max |λ| (discrete, stable
//!   when ρ < 1) or the spectral abscissa α(A) = max Re λ (continuous,
//!   stable when α < 0).
//! * **H2 norm** ‖G‖₂ = √trace(C P Cᵀ (+ D Dᵀ)) from the controllability
//!   Gramian P; infinite for a continuous model with D ≠ 0.
//! * **H∞ norm** ‖G‖∞ = sup_ω σ_max(G(jω)) (or G(e^{jωT})) and the peak
//!   frequency, by the Hamiltonian iteration of Bruinsma & Steinbuch
//!   ([`lifted_lti::StateSpace::hinf_norm`]).
//! * **Hankel singular values** σᵢ = √λᵢ(P Q), from the square-root balanced
//!   truncation's SVD ([`lifted_lti::StateSpace::balanced_truncation`]).
//!
//! The Gramians and norms need a stable model: for an unstable one they are
//! reported as not defined, with the pole that prevents them.
//!
//! **LQR** ([`lqr`]): the stabilising solution X of the discrete algebraic
//! Riccati equation X = AᵀXA − AᵀXB(R + BᵀXB)⁻¹BᵀXA + Q and the gain
//! K = (R + BᵀXB)⁻¹BᵀXA of u = −Kx ([`lifted_linalg::dare`], structure-
//! preserving doubling). Continuous models are refused: the library has no
//! continuous Riccati solver (CARE).
//!
//! Cost: O(n³) for each quantity (eigenvalues, Lyapunov equations, each
//! Hamiltonian iteration of the H∞ norm), O(n⁴) worst case for the zeros.

use lifted_linalg::budget::{MemoryBudget, Size};
use lifted_lti::{Error as LtiError, HinfOptions, StateSpace};
use nalgebra::DMatrix;
use num_complex::Complex64;
use serde::Serialize;

use crate::error::{CliResult, Context, input};

/// A complex number in the JSON output.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ComplexValue {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
    /// Modulus |z|.
    pub abs: f64,
}

impl From<Complex64> for ComplexValue {
    fn from(z: Complex64) -> Self {
        ComplexValue {
            re: z.re,
            im: z.im,
            abs: z.norm(),
        }
    }
}

/// Stability of the model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stability {
    /// Whether every pole is inside the stability region (|λ| < 1 discrete,
    /// Re λ < 0 continuous).
    pub stable: bool,
    /// Spectral radius ρ(A) = max |λ| (discrete models; `None` otherwise).
    pub spectral_radius: Option<f64>,
    /// Spectral abscissa α(A) = max Re λ (continuous models; `None` otherwise).
    pub max_real_part: Option<f64>,
}

/// The H∞ norm and where it peaks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HinfValue {
    /// ‖G‖∞ (a lower bound within the relative tolerance 1e-8).
    pub norm: f64,
    /// Peak frequency in rad/s; `None` for a continuous peak at ω → ∞.
    pub peak_frequency: Option<f64>,
}

/// Everything `lifted analyze` prints. A quantity that is not defined is
/// `None` and its reason is in `notes` under the field's name.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Analysis {
    /// Sample period T (`None`: continuous).
    pub ts: Option<f64>,
    /// Number of states n.
    pub order: usize,
    /// Input names.
    pub inputs: Vec<String>,
    /// Output names.
    pub outputs: Vec<String>,
    /// Poles λ(A).
    pub poles: Vec<ComplexValue>,
    /// Transmission zeros.
    pub zeros: Option<Vec<ComplexValue>>,
    /// DC gain, rows per output.
    pub dc_gain: Option<Vec<Vec<f64>>>,
    /// Stability.
    pub stability: Stability,
    /// ‖G‖₂.
    pub h2_norm: Option<f64>,
    /// ‖G‖∞ and the peak frequency.
    pub hinf_norm: Option<HinfValue>,
    /// Hankel singular values, descending.
    pub hankel_singular_values: Option<Vec<f64>>,
    /// Why a quantity is `None`, by field name.
    pub notes: serde_json::Map<String, serde_json::Value>,
}

/// Sorts complex numbers by modulus, then real part, then imaginary part,
/// so the printed lists are stable.
fn sorted(mut v: Vec<Complex64>) -> Vec<ComplexValue> {
    v.sort_by(|a, b| {
        a.norm()
            .total_cmp(&b.norm())
            .then(a.re.total_cmp(&b.re))
            .then(a.im.total_cmp(&b.im))
    });
    v.into_iter().map(ComplexValue::from).collect()
}

/// The reason a Gramian-based quantity is not defined, for the notes.
fn not_defined(e: &LtiError) -> String {
    match e {
        LtiError::Unstable { pole, .. } => format!(
            "not defined: the model is unstable (pole {} is not inside the stability region)",
            show_complex(*pole)
        ),
        LtiError::Infinite { reason, .. } => format!("infinite: {reason}"),
        other => format!("not computed: {other}"),
    }
}

/// `a ± bi` with six significant digits.
pub fn show_complex(z: Complex64) -> String {
    if z.im == 0.0 {
        format!("{:.6}", z.re)
    } else if z.im > 0.0 {
        format!("{:.6} + {:.6}i", z.re, z.im)
    } else {
        format!("{:.6} - {:.6}i", z.re, -z.im)
    }
}

fn rows(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect()
}

/// Poles, zeros, DC gain, stability, H2 and H∞ norms and Hankel singular
/// values of `model` (module docs). Errors only when the poles cannot be
/// computed; every other quantity that fails is `None` with a note.
pub fn analyze(model: &StateSpace) -> CliResult<Analysis> {
    let n = model.order();
    // The largest work arrays: the H∞ iteration's 2n×2n Hamiltonian and its
    // eigenvalue workspace, a few copies of it.
    MemoryBudget::default()
        .check(
            "the analysis of the model (2n×2n Hamiltonian matrices)",
            Size::matrices(8, 2 * n, 2 * n),
        )
        .ctx("analyze")?;
    let (inputs, outputs) = super::models::channel_names(model);
    let raw_poles = model.poles().ctx("poles")?;
    let mut notes = serde_json::Map::new();
    let mut note = |field: &str, text: String| {
        notes.insert(field.into(), serde_json::Value::String(text));
    };
    let stability = Stability {
        stable: model.is_stable(0.0).ctx("stability")?,
        spectral_radius: model
            .is_discrete()
            .then(|| raw_poles.iter().map(|p| p.norm()).fold(0.0, f64::max)),
        max_real_part: (!model.is_discrete()).then(|| {
            raw_poles
                .iter()
                .map(|p| p.re)
                .fold(f64::NEG_INFINITY, f64::max)
        }),
    };
    let zeros = match model.zeros() {
        Ok(z) => Some(sorted(z)),
        Err(e) => {
            note("zeros", format!("not computed: {e}"));
            None
        }
    };
    let dc_gain = match model.dc_gain() {
        Ok(g) => Some(rows(&g)),
        Err(e) => {
            note("dc_gain", not_defined(&e));
            None
        }
    };
    let h2_norm = match model.h2_norm() {
        Ok(v) => Some(v),
        Err(e) => {
            note("h2_norm", not_defined(&e));
            None
        }
    };
    let hinf_norm = match model.hinf_norm(&HinfOptions::default()) {
        Ok(h) => {
            if h.peak_frequency.is_infinite() {
                note(
                    "hinf_norm.peak_frequency",
                    "the peak is at ω → ∞ (the feedthrough D)".into(),
                );
            }
            Some(HinfValue {
                norm: h.norm,
                peak_frequency: h.peak_frequency.is_finite().then_some(h.peak_frequency),
            })
        }
        Err(e) => {
            note("hinf_norm", not_defined(&e));
            None
        }
    };
    // Order 0 keeps no state: the call only computes the Gramians' square
    // roots and the SVD whose singular values are the Hankel ones.
    let hankel_singular_values = match model.balanced_truncation(0) {
        Ok((_, s)) => Some(s),
        Err(e) => {
            note("hankel_singular_values", not_defined(&e));
            None
        }
    };
    Ok(Analysis {
        ts: model.ts(),
        order: model.order(),
        inputs,
        outputs,
        poles: sorted(raw_poles),
        zeros,
        dc_gain,
        stability,
        h2_norm,
        hinf_norm,
        hankel_singular_values,
        notes,
    })
}

/// Result of [`lqr`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Lqr {
    /// Sample period T of the model.
    pub ts: f64,
    /// State feedback gain K (m×n) of u = −Kx, rows per input.
    pub k: Vec<Vec<f64>>,
    /// Stabilising Riccati solution X (n×n).
    pub x: Vec<Vec<f64>>,
    /// Eigenvalues of A − BK (inside the unit circle).
    pub closed_loop_poles: Vec<ComplexValue>,
    /// Open-loop poles λ(A), for comparison.
    pub open_loop_poles: Vec<ComplexValue>,
    /// Relative residual of the Riccati equation at X.
    pub residual: f64,
    /// Doubling iterations used.
    pub iterations: usize,
}

/// A weight matrix from its text: one value `v` (v·I), k values `a,b,…`
/// (diagonal), or k rows of k values separated by `;` (full matrix,
/// symmetrised by the solver). `flag` and `size` name it in messages.
pub fn weight_matrix(flag: &str, text: &str, size: usize) -> CliResult<DMatrix<f64>> {
    let parse_row = |row: &str| -> CliResult<Vec<f64>> {
        row.split(',')
            .map(|c| {
                let c = c.trim();
                c.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| input(format!("{flag}: '{c}' is not a finite number")))
            })
            .collect()
    };
    let rows: Vec<Vec<f64>> = text
        .split(';')
        .filter(|r| !r.trim().is_empty())
        .map(parse_row)
        .collect::<CliResult<_>>()?;
    let shape = || {
        input(format!(
            "{flag}: expected one value (a multiple of I), {size} values (the diagonal) or \
             {size} rows of {size} values separated by ';' (the matrix), for {size} {}",
            if flag == "--r" { "inputs" } else { "states" }
        ))
    };
    match rows.as_slice() {
        [] => Err(shape()),
        [one] if one.len() == 1 => Ok(DMatrix::identity(size, size) * one[0]),
        [diag] if diag.len() == size => Ok(DMatrix::from_diagonal(
            &nalgebra::DVector::from_column_slice(diag),
        )),
        full if full.len() == size && full.iter().all(|r| r.len() == size) => {
            Ok(DMatrix::from_fn(size, size, |i, j| full[i][j]))
        }
        _ => Err(shape()),
    }
}

/// Discrete LQR of `model` with state weight `q` (n×n) and input weight
/// `r` (m×m): the DARE's stabilising solution and gain (module docs).
///
/// Errors: a continuous model (no CARE in the library), Q not positive
/// semi-definite, the solver's errors (R not positive definite, no
/// stabilising solution, e.g. an unstabilisable (A, B)).
pub fn lqr(model: &StateSpace, q: &DMatrix<f64>, r: &DMatrix<f64>) -> CliResult<Lqr> {
    let ts = model.ts().ok_or_else(|| {
        input(
            "lqr: the model is continuous; the library solves the discrete Riccati equation \
             (DARE) only: discretise it first (lifted convert --to discrete --ts T --out md.json)",
        )
    })?;
    let n = model.order();
    // The doubling iteration keeps about a dozen n×n matrices.
    MemoryBudget::default()
        .check(
            "the Riccati iteration (n×n matrices)",
            Size::matrices(12, n, n),
        )
        .ctx("lqr")?;
    let sym = (q + q.transpose()) * 0.5;
    let min_eig = lifted_linalg::sym_eig(&sym, lifted_linalg::SortOrder::Ascending)
        .ctx("--q")?
        .values
        .iter()
        .fold(f64::INFINITY, |a, &b| a.min(b));
    let scale = sym.norm().max(1.0);
    if min_eig < -1e-12 * scale {
        return Err(input(format!(
            "--q: the state weight must be positive semi-definite; its smallest eigenvalue is {min_eig:.6e}"
        )));
    }
    let sol = lifted_linalg::dare(model.a(), model.b(), q, r, None).ctx("lqr (DARE)")?;
    Ok(Lqr {
        ts,
        k: rows(&sol.k),
        x: rows(&sol.x),
        closed_loop_poles: sorted(sol.closed_loop_poles),
        open_loop_poles: sorted(model.poles().ctx("poles")?),
        residual: sol.residual,
        iterations: sol.iterations,
    })
}

/// Nyquist frequency π/T (rad/s) of a discrete model.
pub fn nyquist(ts: f64) -> f64 {
    std::f64::consts::PI / ts
}

/// Checks frequencies given by the user for `bode --omega`: finite,
/// non-negative and, for a discrete model, at most the Nyquist frequency
/// π/T (above it G(e^{jωT}) repeats the response of an alias frequency).
pub fn check_omega(model: &StateSpace, omega: &[f64]) -> CliResult<()> {
    if omega.is_empty() {
        return Err(input("--omega: no frequency given"));
    }
    for &w in omega {
        if !(w.is_finite() && w >= 0.0) {
            return Err(input(format!(
                "--omega: {w} is not a finite non-negative frequency (rad/s)"
            )));
        }
        if let Some(ts) = model.ts()
            && w > nyquist(ts) * (1.0 + 1e-12)
        {
            return Err(input(format!(
                "--omega: {w} rad/s is above the Nyquist frequency π/T = {:.6} rad/s of the \
                 discrete model (T = {ts} s); a discrete model's response there repeats that \
                 of an alias below π/T",
                nyquist(ts)
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// First-order discrete system G(z) = b/(z − a) (A = a, B = 1, C = b, D = 0).
    fn first_order_discrete(a: f64, b: f64) -> StateSpace {
        StateSpace::new(
            DMatrix::from_element(1, 1, a),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, b),
            DMatrix::zeros(1, 1),
            Some(0.1),
        )
        .unwrap()
    }

    #[test]
    fn first_order_discrete_closed_forms() {
        // G(z) = b/(z − a): impulse response b a^{k−1}, k ≥ 1, so
        // ‖G‖₂² = b²/(1 − a²); for 0 < a < 1 the peak of |G(e^{jθ})| =
        // b/|e^{jθ} − a| is at θ = 0: ‖G‖∞ = b/(1 − a) = DC gain; the
        // Hankel singular value of a first-order system is
        // √(P Q) = √(1/(1−a²) · b²/(1−a²)) = b/(1 − a²).
        let (a, b) = (0.8, 0.5);
        let r = analyze(&first_order_discrete(a, b)).unwrap();
        // Tolerances: the Lyapunov solves and eigenvalues are exact to a
        // few ulps for n = 1; the H∞ iteration returns a lower bound within
        // its relative tolerance 1e-8 (HinfOptions::default).
        assert!((r.h2_norm.unwrap() - b / (1.0 - a * a).sqrt()).abs() < 1e-12);
        let h = r.hinf_norm.unwrap();
        assert!((h.norm - b / (1.0 - a)).abs() < 1e-7 * h.norm);
        assert!(h.peak_frequency.unwrap().abs() < 1e-6);
        let hsv = r.hankel_singular_values.unwrap();
        assert!((hsv[0] - b / (1.0 - a * a)).abs() < 1e-12);
        assert!((r.dc_gain.unwrap()[0][0] - b / (1.0 - a)).abs() < 1e-12);
        assert!(r.stability.stable);
        assert!((r.stability.spectral_radius.unwrap() - a).abs() < 1e-15);
        assert!(r.zeros.unwrap().is_empty());
    }

    #[test]
    fn negative_pole_peaks_at_nyquist() {
        // a < 0: |e^{jθ} − a| = |e^{jθ} + |a|| is smallest at θ = π, where
        // it is 1 − |a|, so ‖G‖∞ = b/(1 − |a|) at ω = π/T.
        let (a, b) = (-0.6, 1.0);
        let r = analyze(&first_order_discrete(a, b)).unwrap();
        let h = r.hinf_norm.unwrap();
        assert!(
            (h.norm - b / (1.0 - a.abs())).abs() < 1e-7 * h.norm,
            "{}",
            h.norm
        );
        assert!((h.peak_frequency.unwrap() - nyquist(0.1)).abs() < 1e-6 * nyquist(0.1));
    }

    #[test]
    fn first_order_continuous_closed_forms() {
        // G(s) = k/(s + p): ‖G‖₂ = k/√(2p), ‖G‖∞ = k/p at ω = 0, Hankel
        // singular value k/(2p) (P = 1/(2p), Q = k²/(2p)).
        let (p, k) = (2.0, 3.0);
        let m = StateSpace::new(
            DMatrix::from_element(1, 1, -p),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, k),
            DMatrix::zeros(1, 1),
            None,
        )
        .unwrap();
        let r = analyze(&m).unwrap();
        assert!((r.h2_norm.unwrap() - k / (2.0 * p).sqrt()).abs() < 1e-12);
        assert!((r.hinf_norm.unwrap().norm - k / p).abs() < 1e-7 * k / p);
        assert!((r.hankel_singular_values.unwrap()[0] - k / (2.0 * p)).abs() < 1e-12);
        assert_eq!(r.stability.max_real_part, Some(-p));
        assert_eq!(r.stability.spectral_radius, None);
    }

    #[test]
    fn continuous_with_feedthrough_has_infinite_h2_and_peak_at_infinity() {
        // G(s) = 1 + 1/(s + 1): |G(jω)| = |s + 2|/|s + 1| is largest at ω = 0
        // (2), so the H∞ peak is finite; the H2 norm is infinite (D ≠ 0).
        let m = StateSpace::new(
            DMatrix::from_element(1, 1, -1.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, 1.0),
            None,
        )
        .unwrap();
        let r = analyze(&m).unwrap();
        assert_eq!(r.h2_norm, None);
        assert!(r.notes["h2_norm"].as_str().unwrap().starts_with("infinite"));
        assert!((r.hinf_norm.unwrap().norm - 2.0).abs() < 1e-7);
        // zero of (s + 2)/(s + 1) at −2
        assert!((r.zeros.unwrap()[0].re + 2.0).abs() < 1e-12);
    }

    #[test]
    fn unstable_model_has_no_norms_and_says_why() {
        let r = analyze(&first_order_discrete(1.2, 1.0)).unwrap();
        assert!(!r.stability.stable);
        assert_eq!(r.h2_norm, None);
        assert_eq!(r.hinf_norm, None);
        assert_eq!(r.hankel_singular_values, None);
        for f in ["h2_norm", "hinf_norm", "hankel_singular_values"] {
            let n = r.notes[f].as_str().unwrap();
            assert!(n.contains("unstable") && n.contains("1.2"), "{f}: {n}");
        }
        // the DC gain of b/(z − a) exists off z = 1: b/(1 − a) = −5
        assert!((r.dc_gain.unwrap()[0][0] + 5.0).abs() < 1e-12);
    }

    #[test]
    fn integrator_has_no_dc_gain() {
        let r = analyze(&first_order_discrete(1.0, 1.0)).unwrap();
        assert_eq!(r.dc_gain, None);
        assert!(r.notes["dc_gain"].as_str().unwrap().contains("infinite"));
    }

    #[test]
    fn scalar_lqr_matches_the_closed_form() {
        // Scalar DARE x = a²x − a²b²x²/(r + b²x) + q, i.e.
        // b²x² + (r(1 − a²) − q b²)x − q r = 0, positive root; gain
        // k = a b x/(r + b²x). a = 1.1, b = 1, q = 1, r = 1:
        // x² − 1.21x − 1 = 0 … with r(1 − a²) = −0.21: x² − 1.21 x − 1 = 0.
        let (a, q, r) = (1.1_f64, 1.0_f64, 1.0_f64);
        let bq = r * (1.0 - a * a) - q;
        let x = (-bq + (bq * bq + 4.0 * q * r).sqrt()) / 2.0;
        let k = a * x / (r + x);
        let m = first_order_discrete(a, 1.0);
        let l = lqr(
            &m,
            &DMatrix::from_element(1, 1, q),
            &DMatrix::from_element(1, 1, r),
        )
        .unwrap();
        // The solver verifies a relative residual ≤ 1e-9; the closed form
        // is evaluated in double precision.
        assert!((l.x[0][0] - x).abs() < 1e-9 * x, "{} vs {x}", l.x[0][0]);
        assert!((l.k[0][0] - k).abs() < 1e-9 * k);
        assert!((l.closed_loop_poles[0].re - (a - k)).abs() < 1e-9);
    }

    #[test]
    fn lqr_refuses_continuous_and_indefinite_weights() {
        let c = StateSpace::new(
            DMatrix::from_element(1, 1, -1.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::zeros(1, 1),
            None,
        )
        .unwrap();
        let one = DMatrix::from_element(1, 1, 1.0);
        let e = lqr(&c, &one, &one).unwrap_err().to_string();
        assert!(e.contains("continuous") && e.contains("convert"), "{e}");
        let d = first_order_discrete(0.5, 1.0);
        let e = lqr(&d, &(-one.clone()), &one).unwrap_err().to_string();
        assert!(e.contains("positive semi-definite"), "{e}");
    }

    #[test]
    fn weight_matrix_forms() {
        assert_eq!(
            weight_matrix("--q", "2", 2).unwrap(),
            DMatrix::identity(2, 2) * 2.0
        );
        assert_eq!(
            weight_matrix("--q", "1,3", 2).unwrap(),
            DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 3.0])
        );
        assert_eq!(
            weight_matrix("--q", "1,0.5;0.5,2", 2).unwrap(),
            DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.5, 2.0])
        );
        let e = weight_matrix("--r", "1,2,3", 2).unwrap_err().to_string();
        assert!(e.contains("2 inputs"), "{e}");
        assert!(weight_matrix("--q", "nan", 1).is_err());
    }
}

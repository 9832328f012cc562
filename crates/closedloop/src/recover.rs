//! Model-level recovery of the open-loop plant from identified closed-loop
//! models, Ren & Zhu (2009) eqs. (9)–(12) with the MIMO ordering of erratum RZ-5.
//!
//! Loop (eq. 9, negative feedback): y = G(r₂ + K(r₁ − y)), G is n_y × n_u and
//! K is n_u × n_y, so
//! H₁ = GK(I + GK)⁻¹ (n_y × n_y, from r₁) and H₂ = (I + GK)⁻¹G = G(I + KG)⁻¹
//! (n_y × n_u, from r₂). The three set-ups:
//!
//! | set-up | excitation | recovery |
//! |---|---|---|
//! | general (joint input–output) | r₁ and r₂ | (10) G = (I − Ĥ₁)⁻¹Ĥ₂ |
//! | controller (indirect) | r₁ (r₂ = 0) | (11) G = Ĥ₁(I − Ĥ₁)⁻¹K⁻¹ |
//! | compensator (indirect) | r₂ (r₁ = 0) | (12) G = Ĥ₂(I − KĤ₂)⁻¹ |
//!
//! Two tiers:
//! * state space, MIMO, discrete or continuous ([`general`], [`general_joint`],
//!   [`controller`], [`compensator`]), each followed by a minimal realisation;
//! * exact SISO polynomial arithmetic without cancellation ([`general_tf`],
//!   [`controller_tf`], [`compensator_tf`]): the paper's "approach (b)" on the
//!   continuous models. When both Ĥ share one denominator D (one identified
//!   two-input model), the general set-up gives G = N₂/(D − N₁).

use std::fmt;

use lifted_lti::{FeedbackSign, MinrealOptions, Poly, SisoTf, StateSpace, TransferFunction};
use nalgebra::DMatrix;

use crate::error::{Error, Result, dims};

pub use crate::setup::Setup;

impl fmt::Display for Setup {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Setup::General => "general",
            Setup::Controller => "controller",
            Setup::Compensator => "compensator",
        })
    }
}

/// Options of the state-space recovery.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecoveryOptions {
    /// Minimal realisation applied to the recovered plant; `None` keeps the
    /// full interconnection. Default `Some(MinrealOptions::default())`
    /// (relative tolerance √ε).
    pub minreal: Option<MinrealOptions>,
}

impl Default for RecoveryOptions {
    fn default() -> Self {
        Self {
            minreal: Some(MinrealOptions::default()),
        }
    }
}

fn finish(g: StateSpace, opts: &RecoveryOptions) -> Result<StateSpace> {
    Ok(match &opts.minreal {
        Some(m) => g.minreal(m)?,
        None => g,
    })
}

fn same_domain(what: &'static str, a: &StateSpace, b: &StateSpace) -> Result<()> {
    let ok = match (a.ts(), b.ts()) {
        (None, None) => true,
        (Some(x), Some(y)) => (x - y).abs() <= 1e-9 * x.abs().max(y.abs()),
        _ => false,
    };
    if ok {
        Ok(())
    } else {
        Err(Error::DomainMismatch {
            what,
            left: a.ts(),
            right: b.ts(),
        })
    }
}

fn inv_or(what: &'static str, m: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    // Reject near-singular feedthroughs by the reciprocal condition number.
    let sv = lifted_linalg::singular_values(m).map_err(lifted_lti::Error::from)?;
    let max = sv.iter().copied().fold(0.0, f64::max);
    let min = sv.iter().copied().fold(f64::INFINITY, f64::min);
    if min.is_nan() || min <= 1e-12 * max.max(1.0) {
        return Err(Error::SingularReturnDifference {
            what,
            reason: format!("its feedthrough is singular (smallest singular value {min:.3e})"),
        });
    }
    Ok(lifted_linalg::inv(m).map_err(lifted_lti::Error::from)?)
}

/// The joint closed loop [H₁ H₂] of eq. (9) (inputs [r₁ (n_y); r₂ (n_u)],
/// outputs y) with the loop state [x_G; x_K], not reduced: the form a
/// merged r₁/r₂ identification estimates. G is n_y × n_u, K is n_u × n_y;
/// both continuous or both discrete at the same period.
///
/// Errors: dimension or domain mismatch, algebraic loop (I + D_K D_G
/// singular). O((n_G + n_K)³).
pub fn closed_loop_joint(g: &StateSpace, k: &StateSpace) -> Result<StateSpace> {
    same_domain("closed loop", g, k)?;
    let (p, m) = (g.n_outputs(), g.n_inputs());
    if k.n_inputs() != p || k.n_outputs() != m {
        return Err(dims(
            "controller K (n_u x n_y)",
            format!("{m}x{p}"),
            format!("{}x{}", k.n_outputs(), k.n_inputs()),
        ));
    }
    let cl = lifted_sim::closed_loop(g, k)?;
    Ok(StateSpace::new(
        cl.a().clone(),
        cl.b().clone(),
        cl.c().rows(0, p).into_owned(),
        cl.d().rows(0, p).into_owned(),
        cl.ts(),
    )?)
}

/// The closed-loop transfer matrices of eq. (9) in state space:
/// (H₁, H₂) = (GK(I + GK)⁻¹, (I + GK)⁻¹G), the columns of
/// [`closed_loop_joint`], each reduced to a minimal realisation (default
/// tolerance).
///
/// Errors: as [`closed_loop_joint`]. O((n_G + n_K)³).
pub fn closed_loop(g: &StateSpace, k: &StateSpace) -> Result<(StateSpace, StateSpace)> {
    let joint = closed_loop_joint(g, k)?;
    let p = g.n_outputs();
    let pick = |c0: usize, nc: usize| -> Result<StateSpace> {
        let s = StateSpace::new(
            joint.a().clone(),
            joint.b().columns(c0, nc).into_owned(),
            joint.c().clone(),
            joint.d().columns(c0, nc).into_owned(),
            joint.ts(),
        )?;
        Ok(s.minreal(&MinrealOptions::default())?)
    };
    Ok((pick(0, p)?, pick(p, g.n_inputs())?))
}

/// Eq. (10), general set-up, from a **joint** closed-loop model Ĥ = [Ĥ₁ Ĥ₂]
/// with inputs [r₁ (n_y); r₂ (n_u)] and outputs y (one model, one state, as the
/// q-Markov Cover of merged r₁/r₂ experiments gives it).
///
/// G = (I − Ĥ₁)⁻¹Ĥ₂ is realised without enlarging the state: y = Ĥ₁y + Ĥ₂u
/// closes r₁ = y, so with M = (I − D₁)⁻¹:
/// A_G = A + B₁MC, B_G = B₂ + B₁MD₂, C_G = MC, D_G = MD₂. For SISO its
/// characteristic polynomial is (D − N₁)/(1 − d₁): the paper's G = N₂/(D − N₁).
///
/// Errors: [`Error::DimensionMismatch`] (n_r1 ≠ n_y or no r₂ column),
/// [`Error::SingularReturnDifference`] (I − D₁ singular: no proper inverse).
/// O(n³) with the minimal realisation.
pub fn general_joint(h: &StateSpace, n_r1: usize, opts: &RecoveryOptions) -> Result<StateSpace> {
    let p = h.n_outputs();
    if n_r1 != p {
        return Err(dims("r1 channels of the joint model (= outputs)", p, n_r1));
    }
    if h.n_inputs() <= p {
        return Err(dims(
            "inputs of the joint model [r1; r2]",
            format!("more than {p}"),
            h.n_inputs(),
        ));
    }
    let m = h.n_inputs() - p;
    let b1 = h.b().columns(0, p).into_owned();
    let b2 = h.b().columns(p, m).into_owned();
    let d1 = h.d().columns(0, p).into_owned();
    let d2 = h.d().columns(p, m).into_owned();
    let mm = inv_or("I - H1", &(DMatrix::identity(p, p) - &d1))?;
    let a = h.a() + &b1 * &mm * h.c();
    let b = &b2 + &b1 * &mm * &d2;
    let c = &mm * h.c();
    let d = &mm * &d2;
    finish(StateSpace::new(a, b, c, d, h.ts())?, opts)
}

/// n_y of a square Ĥ₁, or [`Error::DimensionMismatch`].
fn square_h1(h1: &StateSpace) -> Result<usize> {
    let p = h1.n_outputs();
    if h1.n_inputs() != p {
        return Err(dims(
            "H1 (square, n_y x n_y)",
            format!("{p}x{p}"),
            format!("{}x{}", p, h1.n_inputs()),
        ));
    }
    Ok(p)
}

/// Eq. (10), general set-up, from separately identified Ĥ₁ (n_y × n_y) and
/// Ĥ₂ (n_y × n_u): G = (I − Ĥ₁)⁻¹Ĥ₂ (erratum RZ-5 ordering), by stacking them
/// into one joint model (block-diagonal state) and [`general_joint`].
///
/// Errors: dimension/domain mismatch, [`Error::SingularReturnDifference`].
pub fn general(h1: &StateSpace, h2: &StateSpace, opts: &RecoveryOptions) -> Result<StateSpace> {
    same_domain("general set-up (H1, H2)", h1, h2)?;
    let p = square_h1(h1)?;
    if h2.n_outputs() != p {
        return Err(dims("outputs of H2 (= outputs of H1)", p, h2.n_outputs()));
    }
    let (n1, n2, m) = (h1.order(), h2.order(), h2.n_inputs());
    let mut a = DMatrix::zeros(n1 + n2, n1 + n2);
    a.view_mut((0, 0), (n1, n1)).copy_from(h1.a());
    a.view_mut((n1, n1), (n2, n2)).copy_from(h2.a());
    let mut b = DMatrix::zeros(n1 + n2, p + m);
    b.view_mut((0, 0), (n1, p)).copy_from(h1.b());
    b.view_mut((n1, p), (n2, m)).copy_from(h2.b());
    let mut c = DMatrix::zeros(p, n1 + n2);
    c.view_mut((0, 0), (p, n1)).copy_from(h1.c());
    c.view_mut((0, n1), (p, n2)).copy_from(h2.c());
    let mut d = DMatrix::zeros(p, p + m);
    d.view_mut((0, 0), (p, p)).copy_from(h1.d());
    d.view_mut((0, p), (p, m)).copy_from(h2.d());
    general_joint(&StateSpace::new(a, b, c, d, h1.ts())?, p, opts)
}

/// Eq. (11), controller set-up: G = Ĥ₁(I − Ĥ₁)⁻¹K⁻¹, realised as
/// ((I − Ĥ₁)⁻¹ − I)·K⁻¹ (the two factors commute). K must be square with an
/// invertible feedthrough (biproper), e.g. P and PI controllers.
///
/// Errors: [`Error::DimensionMismatch`] (K not n_y × n_y for a square Ĥ₁),
/// [`Error::ControllerNotInvertible`], [`Error::SingularReturnDifference`],
/// domain mismatch. O(n³).
pub fn controller(h1: &StateSpace, k: &StateSpace, opts: &RecoveryOptions) -> Result<StateSpace> {
    same_domain("controller set-up (H1, K)", h1, k)?;
    let p = square_h1(h1)?;
    if k.n_inputs() != p {
        return Err(dims("inputs of K (= outputs of H1)", p, k.n_inputs()));
    }
    if k.n_outputs() != p {
        return Err(Error::ControllerNotInvertible {
            reason: format!("K is {}x{}, not square", k.n_outputs(), k.n_inputs()),
        });
    }
    let kd_sv = lifted_linalg::singular_values(k.d()).map_err(lifted_lti::Error::from)?;
    let kmax = kd_sv.iter().copied().fold(0.0, f64::max);
    let kmin = kd_sv.iter().copied().fold(f64::INFINITY, f64::min);
    if kmin.is_nan() || kmin <= 1e-12 * kmax.max(1.0) {
        return Err(Error::ControllerNotInvertible {
            reason: format!(
                "its feedthrough D_K is singular (smallest singular value {kmin:.3e}): K^-1 is improper"
            ),
        });
    }
    let kinv = k.inverse().map_err(|e| Error::ControllerNotInvertible {
        reason: e.to_string(),
    })?;
    let eye = DMatrix::<f64>::identity(p, p);
    let ret = StateSpace::new(
        h1.a().clone(),
        h1.b().clone(),
        -h1.c(),
        &eye - h1.d(),
        h1.ts(),
    )?;
    inv_or("I - H1", ret.d())?;
    let ri = ret.inverse()?;
    let l = StateSpace::new(
        ri.a().clone(),
        ri.b().clone(),
        ri.c().clone(),
        ri.d() - &eye,
        ri.ts(),
    )?;
    finish(kinv.series(&l)?, opts)
}

/// Eq. (12), compensator set-up: G = Ĥ₂(I − KĤ₂)⁻¹, i.e. positive feedback of
/// K around Ĥ₂ (MIMO-correct ordering: Ĥ₂ is n_y × n_u, K is n_u × n_y).
///
/// Errors: [`Error::DimensionMismatch`], [`Error::SingularReturnDifference`]
/// (I − D_K D_H₂ singular), domain mismatch. O(n³).
pub fn compensator(h2: &StateSpace, k: &StateSpace, opts: &RecoveryOptions) -> Result<StateSpace> {
    same_domain("compensator set-up (H2, K)", h2, k)?;
    let (p, m) = (h2.n_outputs(), h2.n_inputs());
    if k.n_inputs() != p || k.n_outputs() != m {
        return Err(dims(
            "controller K (n_u x n_y)",
            format!("{m}x{p}"),
            format!("{}x{}", k.n_outputs(), k.n_inputs()),
        ));
    }
    inv_or(
        "I - K H2",
        &(DMatrix::<f64>::identity(m, m) - k.d() * h2.d()),
    )?;
    finish(h2.feedback(k, FeedbackSign::Positive)?, opts)
}

/// Exact SISO closed loop of eq. (9) (Tables 2–3): with G = n_G/d_G and
/// K = n_K/d_K, H₁ = n_G n_K/χ and H₂ = n_G d_K/χ, χ = d_G d_K + n_G n_K.
/// No cancellation.
///
/// Errors: [`Error::SingularReturnDifference`] when χ ≡ 0.
pub fn closed_loop_tf(g: &SisoTf, k: &SisoTf) -> Result<(SisoTf, SisoTf)> {
    let chi = &(g.den() * k.den()) + &(g.num() * k.num());
    if chi.is_zero() {
        return Err(Error::SingularReturnDifference {
            what: "I + G K",
            reason: "the characteristic polynomial is identically zero".into(),
        });
    }
    Ok((
        SisoTf::new(g.num() * k.num(), chi.clone())?,
        SisoTf::new(g.num() * k.den(), chi)?,
    ))
}

fn nonzero(p: Poly, what: &'static str, reason: &str) -> Result<Poly> {
    if p.is_zero() {
        Err(Error::SingularReturnDifference {
            what,
            reason: reason.into(),
        })
    } else {
        Ok(p)
    }
}

/// Relative tolerance under which two denominators count as the same shared
/// D in [`general_tf`] (rounding of the characteristic polynomials of one
/// joint model computed column by column).
pub const SHARED_DEN_TOL: f64 = 1e-10;

/// Eq. (10) in exact SISO polynomial arithmetic (approach (b), no
/// cancellation). With Ĥ₁ = N₁/D₁, Ĥ₂ = N₂/D₂: G = N₂/(D − N₁) when
/// D₁ = D₂ = D (one joint identified model; equal to [`SHARED_DEN_TOL`]
/// relative), else N₂D₁/(D₂(D₁ − N₁)).
///
/// Errors: [`Error::SingularReturnDifference`] when Ĥ₁ ≡ 1.
pub fn general_tf(h1: &SisoTf, h2: &SisoTf) -> Result<SisoTf> {
    let ret = nonzero(h1.den() - h1.num(), "I - H1", "H1 is identically 1")?;
    let scale = h1.den().coeffs().iter().fold(0.0f64, |a, c| a.max(c.abs()));
    let shared = h1.den().degree() == h2.den().degree()
        && h1.den().max_abs_diff(h2.den()) <= SHARED_DEN_TOL * scale;
    if shared {
        Ok(SisoTf::new(h2.num().clone(), ret)?)
    } else {
        Ok(SisoTf::new(h2.num() * h1.den(), h2.den() * &ret)?)
    }
}

/// Eq. (11) in exact SISO polynomial arithmetic: G = N₁d_K/((D₁ − N₁)n_K).
/// K⁻¹ may be improper here; only K ≡ 0 is rejected.
///
/// Errors: [`Error::ControllerNotInvertible`], [`Error::SingularReturnDifference`].
pub fn controller_tf(h1: &SisoTf, k: &SisoTf) -> Result<SisoTf> {
    if k.num().is_zero() {
        return Err(Error::ControllerNotInvertible {
            reason: "K is identically zero".into(),
        });
    }
    let ret = nonzero(h1.den() - h1.num(), "I - H1", "H1 is identically 1")?;
    Ok(SisoTf::new(h1.num() * k.den(), &ret * k.num())?)
}

/// Eq. (12) in exact SISO polynomial arithmetic: G = N₂d_K/(D₂d_K − n_K N₂).
///
/// Errors: [`Error::SingularReturnDifference`] when 1 − KĤ₂ ≡ 0.
pub fn compensator_tf(h2: &SisoTf, k: &SisoTf) -> Result<SisoTf> {
    let den = nonzero(
        &(h2.den() * k.den()) - &(k.num() * h2.num()),
        "I - K H2",
        "K H2 is identically 1",
    )?;
    Ok(SisoTf::new(h2.num() * k.den(), den)?)
}

/// The entries of a model's transfer matrix **without** any cancellation:
/// every entry over the full characteristic polynomial det(sI − A) (monic), so
/// the columns of a joint model share one denominator, as the general set-up
/// of approach (b) needs. O(n³) per entry.
pub fn transfer_entries(h: &StateSpace) -> Result<TransferFunction> {
    Ok(h.to_tf(&MinrealOptions { tol: 0.0 })?)
}

/// The SISO entry (i, j) of [`transfer_entries`].
pub fn transfer_entry(h: &StateSpace, i: usize, j: usize) -> Result<SisoTf> {
    if i >= h.n_outputs() || j >= h.n_inputs() {
        return Err(dims(
            "transfer entry index",
            format!("< {}x{}", h.n_outputs(), h.n_inputs()),
            format!("({i}, {j})"),
        ));
    }
    let col = StateSpace::new(
        h.a().clone(),
        h.b().columns(j, 1).into_owned(),
        h.c().rows(i, 1).into_owned(),
        DMatrix::from_element(1, 1, h.d()[(i, j)]),
        h.ts(),
    )?;
    Ok(transfer_entries(&col)?.entry(0, 0).clone())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tf(n: &[f64], d: &[f64]) -> SisoTf {
        SisoTf::from_coeffs(n, d).unwrap()
    }

    #[test]
    fn table2_first_order_controller() {
        let (h1, h2) =
            closed_loop_tf(&tf(&[1.0], &[0.3, 1.0]), &tf(&[1.0, 0.5], &[1.0, 1.0])).unwrap();
        assert_eq!(h1.den().coeffs(), &[0.3, 2.3, 1.5]);
        assert_eq!(h1.num().coeffs(), &[1.0, 0.5]);
        assert_eq!(h2.num().coeffs(), &[1.0, 1.0]);
    }

    #[test]
    fn setups_recover_g_polynomially() {
        let g = tf(&[1.0], &[0.3, 1.0]);
        let k = tf(&[0.2, 5.0], &[1.0, 0.0]);
        let (h1, h2) = closed_loop_tf(&g, &k).unwrap();
        for r in [
            general_tf(&h1, &h2).unwrap(),
            controller_tf(&h1, &k).unwrap(),
            compensator_tf(&h2, &k).unwrap(),
        ] {
            // r = G  ⇔  num_r · d_G = den_r · n_G
            let lhs = r.num() * g.den();
            let rhs = r.den() * g.num();
            assert!(lhs.max_abs_diff(&rhs) < 1e-12, "{lhs} vs {rhs}");
        }
    }

    #[test]
    fn setup_metadata() {
        assert_eq!(Setup::General.equation(), 10);
        assert!(Setup::Controller.needs_r1() && !Setup::Controller.needs_r2());
        assert!(Setup::Compensator.needs_r2() && !Setup::Compensator.needs_r1());
        assert_eq!(Setup::Compensator.to_string(), "compensator");
    }
}

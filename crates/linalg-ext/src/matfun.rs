//! Matrix functions: exponential, principal logarithm, principal p-th root.
//!
//! * [`expm`]: scaling and squaring with a degree-3/5/7/9/13 Padé
//!   approximant chosen from ‖A‖₁ (Higham 2005, "The scaling and squaring
//!   method for the matrix exponential revisited", Alg. 2.3), O(n³).
//! * [`logm`]: complex Schur form (real Schur + `rsf2csf`), then inverse
//!   scaling and squaring on the triangular factor: square roots until
//!   ‖T − I‖₁ ≤ 1/4, then the degree-8 Padé approximant of log(I + X) in
//!   partial fractions (Gauss–Legendre nodes), O((s + 8)·n³/3) for s square
//!   roots (Higham 2001, "Evaluating Padé approximants of the matrix
//!   logarithm"; Al-Mohy & Higham 2012). The diagonal and first
//!   superdiagonal are recomputed from exact scalar formulas.
//! * [`rootm`], [`sqrtm`]: complex Schur form, then Smith's triangular
//!   recurrence for the principal p-th root (Smith 2003, "A Schur algorithm
//!   for computing matrix pth roots"; for p = 2 it is Björck–Hammarling),
//!   O(p·n³/6). [`rootm_primary`] also accepts one simple zero eigenvalue
//!   (mapped to 0: the primary root).
//!
//! For a real A the principal logarithm and roots are real. The complex
//! computation's imaginary residue is checked to be below 1e-9·‖A‖_F before
//! the real part is returned (Pitfall 2 of the reproduction notes).
//!
//! **Branch check.** The principal logarithm/root exists iff no eigenvalue
//! lies on the closed negative real axis ℝ⁻ ∪ {0}. An eigenvalue λ is
//! rejected with [`Error::NoPrincipalBranch`] when
//! |λ| ≤ 1000·n·ε·‖A‖_F (numerically zero), or when Re λ < 0 and
//! |Im λ| ≤ 1e-8·|λ| (argument within 1e-8 rad of ±π).

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::check::square_finite;
use crate::schur::real_schur;
use crate::solve::Lu;
use crate::{Error, Result};

/// An eigenvalue with |λ| ≤ ZERO_EIG_TOL·n·ε·‖A‖_F counts as zero.
const ZERO_EIG_TOL: f64 = 1000.0;

/// Relative angle tolerance of the branch check (radians from ±π).
pub const BRANCH_ANGLE_TOL: f64 = 1e-8;

/// Imaginary residue accepted before taking the real part, relative to ‖A‖_F.
const IMAG_RESIDUE_TOL: f64 = 1e-9;

type CMat = DMatrix<Complex64>;

fn c(re: f64) -> Complex64 {
    Complex64::new(re, 0.0)
}

/// 1-norm (maximum absolute column sum).
fn norm1(a: &DMatrix<f64>) -> f64 {
    a.column_iter()
        .map(|col| col.lp_norm(1))
        .fold(0.0, f64::max)
}

fn norm1_c(a: &CMat) -> f64 {
    a.column_iter()
        .map(|col| col.iter().map(|z| z.norm()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// Matrix exponential e^A (Higham 2005 scaling and squaring, Padé 13),
/// about (6 + ⌈log₂(‖A‖₁/θ₁₃)⌉)·2n³ flops.
///
/// Errors: [`Error::NotSquare`], [`Error::NonFinite`]; [`Error::InvalidArgument`]
/// when e^A overflows.
pub fn expm(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = square_finite("a", a)?;
    if n == 0 {
        return Ok(DMatrix::zeros(0, 0));
    }
    const THETA: [(usize, f64); 4] = [
        (3, 1.495585217958292e-2),
        (5, 2.539_398_330_063_23e-1),
        (7, 9.504178996162932e-1),
        (9, 2.097847961257068e0),
    ];
    const THETA13: f64 = 5.371920351148152;
    let eye = DMatrix::<f64>::identity(n, n);
    let a1 = norm1(a);
    let a2 = a * a;
    for (m, theta) in THETA {
        if a1 <= theta {
            let b = pade_coefficients(m);
            // U = A Σ b_{2k+1} A^{2k}, V = Σ b_{2k} A^{2k}.
            let mut pow = eye.clone();
            let mut u = DMatrix::zeros(n, n);
            let mut v = DMatrix::zeros(n, n);
            for k in 0..=(m / 2) {
                if k > 0 {
                    pow = &pow * &a2;
                }
                u += &pow * b[2 * k + 1];
                v += &pow * b[2 * k];
            }
            let u = a * u;
            return pade_ratio(&u, &v, 0, "a");
        }
    }
    let s = if a1 > THETA13 {
        (a1 / THETA13).log2().ceil().max(0.0) as i32
    } else {
        0
    };
    let scale = 0.5f64.powi(s);
    let a_s = a * scale;
    let a2 = a2 * (scale * scale);
    let a4 = &a2 * &a2;
    let a6 = &a4 * &a2;
    let b = pade_coefficients(13);
    let u_inner = &a6 * (&a6 * b[13] + &a4 * b[11] + &a2 * b[9])
        + &a6 * b[7]
        + &a4 * b[5]
        + &a2 * b[3]
        + &eye * b[1];
    let u = &a_s * u_inner;
    let v = &a6 * (&a6 * b[12] + &a4 * b[10] + &a2 * b[8])
        + &a6 * b[6]
        + &a4 * b[4]
        + &a2 * b[2]
        + &eye * b[0];
    pade_ratio(&u, &v, s, "a")
}

/// Padé numerator coefficients b₀..b_m of e^x (Higham 2005, Table 2.3 proof).
fn pade_coefficients(m: usize) -> Vec<f64> {
    match m {
        3 => vec![120.0, 60.0, 12.0, 1.0],
        5 => vec![30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0],
        7 => vec![
            17297280.0, 8648640.0, 1995840.0, 277200.0, 25200.0, 1512.0, 56.0, 1.0,
        ],
        9 => vec![
            17643225600.0,
            8821612800.0,
            2075673600.0,
            302702400.0,
            30270240.0,
            2162160.0,
            110880.0,
            3960.0,
            90.0,
            1.0,
        ],
        _ => vec![
            64764752532480000.0,
            32382376266240000.0,
            7771770303897600.0,
            1187353796428800.0,
            129060195264000.0,
            10559470521600.0,
            670442572800.0,
            33522128640.0,
            1323241920.0,
            40840800.0,
            960960.0,
            16380.0,
            182.0,
            1.0,
        ],
    }
}

/// r = (V − U)⁻¹(V + U), squared s times.
fn pade_ratio(
    u: &DMatrix<f64>,
    v: &DMatrix<f64>,
    s: i32,
    what: &'static str,
) -> Result<DMatrix<f64>> {
    let p = v + u;
    let q = v - u;
    let mut r = Lu::new(&q).solve(&p);
    for _ in 0..s {
        r = &r * &r;
    }
    if r.iter().any(|x| !x.is_finite()) {
        return Err(Error::InvalidArgument {
            what,
            reason: "the matrix exponential overflows".into(),
        });
    }
    Ok(r)
}

/// Complex Schur form of a square finite real matrix plus the branch check.
struct Prepared {
    u: CMat,
    t: CMat,
    anorm: f64,
}

fn prepare(a: &DMatrix<f64>, what: &'static str) -> Result<Prepared> {
    prepare_with(a, what, false).map(|(p, _)| p)
}

/// [`prepare`]; with `simple_zero`, one numerically zero eigenvalue is
/// allowed (its index in the complex Schur diagonal is returned) — a second
/// one, or a negative real eigenvalue, is still rejected.
fn prepare_with(
    a: &DMatrix<f64>,
    what: &'static str,
    simple_zero: bool,
) -> Result<(Prepared, Option<usize>)> {
    let n = a.nrows();
    let rs = real_schur(a)?;
    let anorm = a.norm();
    let zero_tol = ZERO_EIG_TOL * n as f64 * f64::EPSILON * anorm;
    let mut zeros = 0;
    for lam in rs.eigenvalues() {
        let r = lam.norm();
        let zero = r <= zero_tol;
        if zero && simple_zero && zeros == 0 {
            zeros += 1;
            continue;
        }
        if zero || (lam.re < 0.0 && lam.im.abs() <= BRANCH_ANGLE_TOL * r) {
            return Err(Error::NoPrincipalBranch {
                what,
                eigenvalue: lam,
            });
        }
    }
    let (u, t) = rs.to_complex();
    let zero_at = (0..n).find(|&i| zeros > 0 && t[(i, i)].norm() <= zero_tol);
    Ok((Prepared { u, t, anorm }, zero_at))
}

/// U F Uᴴ with the imaginary residue check; returns the real part.
fn back_transform(p: &Prepared, f: &CMat, scale: f64, what: &'static str) -> Result<DMatrix<f64>> {
    let full = &p.u * f * p.u.adjoint() * c(scale);
    let imag = full.map(|z| z.im).norm();
    let real = full.map(|z| z.re);
    let tol = IMAG_RESIDUE_TOL * p.anorm.max(real.norm());
    if imag.is_nan() || imag > tol {
        return Err(Error::Backend {
            what,
            reason: format!(
                "imaginary residue {imag:e} exceeds {tol:e} (ill-conditioned eigenvalues)"
            ),
        });
    }
    if real.iter().any(|x| !x.is_finite()) {
        return Err(Error::Backend {
            what,
            reason: "non-finite result".into(),
        });
    }
    Ok(real)
}

/// Principal p-th root of a scalar off the closed negative real axis.
fn scalar_root(z: Complex64, p: u32) -> Complex64 {
    Complex64::from_polar(z.norm().powf(1.0 / p as f64), z.arg() / p as f64)
}

/// Principal p-th root of an upper triangular matrix (Smith 2003); the
/// diagonal entry `zero_at`, if any, is a (numerically) zero eigenvalue whose
/// root is taken as exactly 0 (the primary root; the recurrence's
/// denominators stay nonzero because the zero is simple).
fn triangular_root(t: &CMat, p: u32) -> CMat {
    triangular_root_with(t, p, None)
}

fn triangular_root_with(t: &CMat, p: u32, zero_at: Option<usize>) -> CMat {
    let n = t.nrows();
    let p = p as usize;
    // pows[q-1] = U^q for q = 1..p-1.
    let mut pows: Vec<CMat> = vec![CMat::zeros(n, n); p.max(2) - 1];
    for i in 0..n {
        let r = if zero_at == Some(i) {
            c(0.0)
        } else {
            scalar_root(t[(i, i)], p as u32)
        };
        let mut acc = r;
        for pw in pows.iter_mut() {
            pw[(i, i)] = acc;
            acc *= r;
        }
    }
    let mut cq = vec![c(0.0); p + 1];
    let mut dq = vec![c(0.0); p + 1];
    for j in 1..n {
        for i in (0..j).rev() {
            let uii = pows[0][(i, i)];
            let ujj = pows[0][(j, j)];
            cq[1] = c(1.0);
            dq[1] = c(0.0);
            let mut ujj_pow = ujj; // u_jj^{q-1}
            for q in 2..=p {
                // s_q = Σ_{m=i+1}^{j-1} u_im (U^{q-1})_mj
                let prev = &pows[q - 2];
                let mut s = c(0.0);
                for m in (i + 1)..j {
                    s += pows[0][(i, m)] * prev[(m, j)];
                }
                cq[q] = uii * cq[q - 1] + ujj_pow;
                dq[q] = uii * dq[q - 1] + s;
                ujj_pow *= ujj;
            }
            let uij = (t[(i, j)] - dq[p]) / cq[p];
            for q in 1..p {
                pows[q - 1][(i, j)] = cq[q] * uij + dq[q];
            }
        }
    }
    pows.swap_remove(0)
}

/// Principal p-th root X of A (X^p = A, eigenvalues of X with arguments in
/// (−π/p, π/p)), via the complex Schur form and Smith's recurrence,
/// O(10n³ + p·n³/6).
///
/// Errors: [`Error::InvalidArgument`] for p = 0, [`Error::NotSquare`],
/// [`Error::NonFinite`], [`Error::NoPrincipalBranch`] for an eigenvalue on
/// or near ℝ⁻ ∪ {0} (see the module docs for the tolerance),
/// [`Error::Backend`] if the imaginary residue check fails.
pub fn rootm(a: &DMatrix<f64>, p: u32) -> Result<DMatrix<f64>> {
    let n = square_finite("a", a)?;
    if p == 0 {
        return Err(Error::InvalidArgument {
            what: "p",
            reason: "the root order must be at least 1".into(),
        });
    }
    if n == 0 {
        return Ok(DMatrix::zeros(0, 0));
    }
    let prep = prepare(a, "rootm")?;
    if p == 1 {
        return Ok(a.clone());
    }
    let r = triangular_root(&prep.t, p);
    back_transform(&prep, &r, 1.0, "rootm")
}

/// The p-th root of A that is the principal root on every nonzero
/// eigenvalue and maps one **simple** zero eigenvalue to 0: the primary
/// root f(A) for f(z) = z^{1/p} (principal branch, f(0) = 0), the root a
/// lifted model with one lost delay has (e.g. spec A3.3: Ā of (4.10) with
/// eigenvalues 0.729 and 0 has the cube root with eigenvalues 0.9 and 0).
/// Without a zero eigenvalue it equals [`rootm`]. X^p = A holds to rounding
/// plus the size of the discarded eigenvalue (≤ 1000·n·ε·‖A‖_F). Same
/// algorithm and cost as [`rootm`], O(10n³ + p·n³/6).
///
/// Errors: as [`rootm`]; [`Error::NoPrincipalBranch`] for a second zero
/// eigenvalue (a repeated zero has no root of this kind in general) or a
/// negative real one.
///
/// ```
/// use nalgebra::DMatrix;
/// let a = DMatrix::from_row_slice(2, 2, &[0.729, 0.0, 0.9, 0.0]);
/// let x = lifted_linalg::rootm_primary(&a, 3)?;
/// assert!((&x * &x * &x - &a).norm() < 1e-12);
/// assert!(lifted_linalg::rootm(&a, 3).is_err()); // no principal root
/// # Ok::<(), lifted_linalg::Error>(())
/// ```
pub fn rootm_primary(a: &DMatrix<f64>, p: u32) -> Result<DMatrix<f64>> {
    let n = square_finite("a", a)?;
    if p == 0 {
        return Err(Error::InvalidArgument {
            what: "p",
            reason: "the root order must be at least 1".into(),
        });
    }
    if n == 0 {
        return Ok(DMatrix::zeros(0, 0));
    }
    let (prep, zero_at) = prepare_with(a, "rootm_primary", true)?;
    if p == 1 {
        return Ok(a.clone());
    }
    let r = triangular_root_with(&prep.t, p, zero_at);
    back_transform(&prep, &r, 1.0, "rootm_primary")
}

/// Principal square root, `rootm(a, 2)` (Björck–Hammarling on the complex
/// Schur form, O(10n³)).
pub fn sqrtm(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    rootm(a, 2)
}

/// Gauss–Legendre nodes and weights on [0, 1] (Newton on P_m).
fn gauss_legendre01(m: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(m);
    for i in 1..=m {
        let mut x = (std::f64::consts::PI * (i as f64 - 0.25) / (m as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            // Legendre recurrence.
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=m {
                let kf = k as f64;
                let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
                p0 = p1;
                p1 = p2;
            }
            dp = m as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        out.push(((x + 1.0) / 2.0, w / 2.0));
    }
    out
}

/// f[λ₁, λ₂] for f = log, accurate for close arguments (Higham 2008,
/// "Functions of Matrices", eq. (11.28)).
fn log_divided_difference(l1: Complex64, l2: Complex64) -> Complex64 {
    if l1 == l2 {
        return c(1.0) / l1;
    }
    if (l1 - l2).norm() > 0.5 * (l1.norm().min(l2.norm())) {
        return (l2.ln() - l1.ln()) / (l2 - l1);
    }
    let z = (l2 - l1) / (l2 + l1);
    let dl = l2.ln() - l1.ln();
    let unwind = ((dl.im - std::f64::consts::PI) / (2.0 * std::f64::consts::PI)).ceil();
    (c(2.0) * z.atanh() + Complex64::new(0.0, 2.0 * std::f64::consts::PI * unwind)) / (l2 - l1)
}

/// Principal logarithm of an upper triangular matrix with no eigenvalue on
/// ℝ⁻ ∪ {0} (inverse scaling and squaring).
fn triangular_log(t: &CMat) -> CMat {
    let n = t.nrows();
    let eye = CMat::identity(n, n);
    let mut r = t.clone();
    let mut s = 0u32;
    while norm1_c(&(&r - &eye)) > 0.25 && s < 60 {
        r = triangular_root(&r, 2);
        s += 1;
    }
    let mut x = &r - &eye;
    // Accurate diagonal: λ^{1/2^s} − 1 = (λ − 1)/Π_{k=1}^{s}(1 + λ^{1/2^k}).
    for i in 0..n {
        let lam = t[(i, i)];
        if s == 0 {
            x[(i, i)] = lam - c(1.0);
        } else {
            let mut a = lam;
            let mut prod = c(1.0);
            for _ in 0..s {
                a = a.sqrt();
                prod *= c(1.0) + a;
            }
            x[(i, i)] = (lam - c(1.0)) / prod;
        }
    }
    // log(I + X) ≈ Σ w_j X (I + x_j X)⁻¹ (degree-8 Padé, θ₈ ≈ 0.37 > 1/4).
    let mut l = CMat::zeros(n, n);
    for (node, weight) in gauss_legendre01(8) {
        let m = &eye + &x * c(node);
        // X and (I + x_j X) commute; both are upper triangular.
        if let Some(y) = m.solve_upper_triangular(&x) {
            l += y * c(weight);
        }
    }
    l *= c(2f64.powi(s as i32));
    for i in 0..n {
        l[(i, i)] = t[(i, i)].ln();
        if i + 1 < n {
            l[(i, i + 1)] = t[(i, i + 1)] * log_divided_difference(t[(i, i)], t[(i + 1, i + 1)]);
        }
    }
    l
}

/// Principal matrix logarithm (eigenvalues with imaginary parts in (−π, π)),
/// via the complex Schur form and inverse scaling and squaring,
/// O(10n³ + (s + 8)·n³/3).
///
/// Errors: [`Error::NotSquare`], [`Error::NonFinite`],
/// [`Error::NoPrincipalBranch`] for an eigenvalue on or near ℝ⁻ ∪ {0}
/// (tolerance in the module docs), [`Error::Backend`] if the imaginary
/// residue check fails.
pub fn logm(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = square_finite("a", a)?;
    if n == 0 {
        return Ok(DMatrix::zeros(0, 0));
    }
    let prep = prepare(a, "logm")?;
    let l = triangular_log(&prep.t);
    back_transform(&prep, &l, 1.0, "logm")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primary_root_with_a_simple_zero_eigenvalue() {
        // spec A3.3: Ā of (4.10), eigenvalues 0.729 and 0
        let a = DMatrix::from_row_slice(2, 2, &[0.729, 0.0, 0.9, 0.0]);
        let x = rootm_primary(&a, 3).unwrap();
        assert!((&x * &x * &x - &a).norm() < 1e-13);
        let mut ev: Vec<f64> = crate::eigenvalues(&x)
            .unwrap()
            .iter()
            .map(|z| z.re)
            .collect();
        ev.sort_by(f64::total_cmp);
        assert!(ev[0].abs() < 1e-12 && (ev[1] - 0.9).abs() < 1e-12, "{ev:?}");
        // a 5×5 V diag(0, 0.5, 2, 0.3 ± 0.4i) V⁻¹: X = V diag(f(λ)) V⁻¹
        let v = DMatrix::from_fn(5, 5, |i, j| {
            ((i * 7 + j * 3) % 5) as f64 * 0.3 + if i == j { 1.0 } else { 0.0 }
        });
        let mut d = DMatrix::zeros(5, 5);
        d[(1, 1)] = 0.5;
        d[(2, 2)] = 2.0;
        d[(3, 3)] = 0.3;
        d[(3, 4)] = 0.4;
        d[(4, 3)] = -0.4;
        d[(4, 4)] = 0.3;
        let vinv = crate::inv(&v).unwrap();
        let a = &v * &d * &vinv;
        for p in [2u32, 3, 5] {
            let x = rootm_primary(&a, p).unwrap();
            let mut xp = x.clone();
            for _ in 1..p {
                xp = &xp * &x;
            }
            assert!((&xp - &a).norm() < 1e-11 * a.norm(), "p = {p}");
            // x v₀ = 0 for the null vector v₀ = V e₁ (f(0) = 0)
            assert!((&x * v.column(0)).norm() < 1e-10, "p = {p}");
        }
        // no zero eigenvalue: the principal root
        let b = &v * (&d + DMatrix::identity(5, 5) * 0.1) * &vinv;
        assert!((rootm_primary(&b, 3).unwrap() - rootm(&b, 3).unwrap()).norm() < 1e-14);
        // a repeated zero or a negative eigenvalue: no such root
        let two = DMatrix::from_row_slice(3, 3, &[0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5]);
        assert!(matches!(
            rootm_primary(&two, 2),
            Err(Error::NoPrincipalBranch { .. })
        ));
        let neg = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, 0.0, -1.0]);
        assert!(matches!(
            rootm_primary(&neg, 3),
            Err(Error::NoPrincipalBranch { .. })
        ));
        assert!(rootm_primary(&a, 0).is_err());
    }
    use approx::assert_relative_eq;
    use nalgebra::dvector;

    #[test]
    fn gauss_legendre_integrates_polynomials() {
        let gl = gauss_legendre01(8);
        // Exact for degree ≤ 15: ∫₀¹ x^k dx = 1/(k+1).
        for k in 0..16 {
            let q: f64 = gl.iter().map(|(x, w)| w * x.powi(k)).sum();
            assert_relative_eq!(q, 1.0 / (k as f64 + 1.0), epsilon = 1e-14);
        }
    }

    #[test]
    fn expm_diagonal_and_rotation() {
        let a = DMatrix::from_diagonal(&dvector![1.0, -2.0, 0.5]);
        let e = expm(&a).unwrap();
        let want = DMatrix::from_diagonal(&dvector![1f64.exp(), (-2f64).exp(), 0.5f64.exp()]);
        assert_relative_eq!(e, want, max_relative = 1e-14);
        // exp([0 −θ; θ 0]) = rotation by θ, across all Padé degrees.
        for theta in [1e-3, 0.1, 0.6, 1.5, 3.0, 20.0] {
            let a = DMatrix::from_row_slice(2, 2, &[0.0, -theta, theta, 0.0]);
            let e = expm(&a).unwrap();
            let want = DMatrix::from_row_slice(
                2,
                2,
                &[theta.cos(), -theta.sin(), theta.sin(), theta.cos()],
            );
            assert_relative_eq!(e, want, epsilon = 1e-13 * theta.max(1.0));
        }
    }

    #[test]
    fn logm_jordan_block() {
        // log([λ 1; 0 λ]) = [log λ, 1/λ; 0, log λ].
        let lam = 2.5f64;
        let a = DMatrix::from_row_slice(2, 2, &[lam, 1.0, 0.0, lam]);
        let l = logm(&a).unwrap();
        let want = DMatrix::from_row_slice(2, 2, &[lam.ln(), 1.0 / lam, 0.0, lam.ln()]);
        assert_relative_eq!(l, want, epsilon = 1e-14);
    }

    #[test]
    fn roots_of_diagonal() {
        let a = DMatrix::from_diagonal(&dvector![4.0, 9.0, 0.25]);
        assert_relative_eq!(
            sqrtm(&a).unwrap(),
            DMatrix::from_diagonal(&dvector![2.0, 3.0, 0.5]),
            epsilon = 1e-15
        );
        let r = rootm(&a, 3).unwrap();
        assert_relative_eq!(&r * &r * &r, a, epsilon = 1e-14);
    }

    #[test]
    fn negative_axis_is_rejected() {
        let a = DMatrix::from_diagonal(&dvector![1.0, -1.0]);
        assert!(matches!(
            logm(&a),
            Err(Error::NoPrincipalBranch { what: "logm", .. })
        ));
        assert!(matches!(
            sqrtm(&a),
            Err(Error::NoPrincipalBranch { what: "rootm", .. })
        ));
        let singular = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        assert!(matches!(
            logm(&singular),
            Err(Error::NoPrincipalBranch { .. })
        ));
        assert!(matches!(
            rootm(&DMatrix::identity(2, 2), 0),
            Err(Error::InvalidArgument { what: "p", .. })
        ));
    }

    fn random_well_placed(n: usize, seed: u64) -> DMatrix<f64> {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        // I·shift + noise keeps the spectrum in the right half plane; the
        // nonnormal part makes the Schur form non-trivial.
        let shift = 1.0 + n as f64 * 0.3;
        DMatrix::from_fn(n, n, |i, j| {
            rng.random::<f64>() * 2.0 - 1.0 + if i == j { shift } else { 0.0 }
        })
    }

    #[test]
    fn exp_inverts_log_on_random_matrices() {
        for (n, seed) in [(1, 1), (2, 2), (4, 3), (8, 4), (20, 5)] {
            let a = random_well_placed(n, seed);
            let l = logm(&a).unwrap();
            let back = expm(&l).unwrap();
            let tol = 1e-12 * a.norm() * n as f64;
            assert!((&back - &a).norm() <= tol, "n={n}: {}", (&back - &a).norm());
        }
    }

    #[test]
    fn log_of_general_matrix_with_complex_spectrum() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(77);
        // exp of a random matrix with eigenvalue imaginary parts well inside
        // (−π, π): logm must return that matrix (principal branch).
        for n in [2, 5, 10] {
            let x = DMatrix::from_fn(n, n, |_, _| {
                (rng.random::<f64>() * 2.0 - 1.0) * 0.8 / (n as f64).sqrt()
            });
            let a = expm(&x).unwrap();
            let l = logm(&a).unwrap();
            assert!(
                (&l - &x).norm() <= 1e-12 * n as f64,
                "n={n}: {}",
                (&l - &x).norm()
            );
        }
    }

    #[test]
    fn log_of_rotation() {
        // log(R(θ)) = [0 −θ; θ 0] for |θ| < π.
        for theta in [0.1f64, 1.0, 2.5, 3.1] {
            let a = DMatrix::from_row_slice(
                2,
                2,
                &[theta.cos(), -theta.sin(), theta.sin(), theta.cos()],
            );
            let l = logm(&a).unwrap();
            let want = DMatrix::from_row_slice(2, 2, &[0.0, -theta, theta, 0.0]);
            assert_relative_eq!(l, want, epsilon = 1e-13);
            // Principal square root is the rotation by θ/2.
            let h = theta / 2.0;
            let r = sqrtm(&a).unwrap();
            let want = DMatrix::from_row_slice(2, 2, &[h.cos(), -h.sin(), h.sin(), h.cos()]);
            assert_relative_eq!(r, want, epsilon = 1e-13);
        }
        // θ = π (eigenvalues −1): no principal branch.
        let pi = std::f64::consts::PI;
        let a = DMatrix::from_row_slice(2, 2, &[pi.cos(), -pi.sin(), pi.sin(), pi.cos()]);
        assert!(matches!(logm(&a), Err(Error::NoPrincipalBranch { .. })));
        assert!(matches!(rootm(&a, 3), Err(Error::NoPrincipalBranch { .. })));
    }

    #[test]
    fn roots_satisfy_power_identity() {
        for (n, seed) in [(1, 11), (3, 12), (6, 13), (15, 14)] {
            let a = random_well_placed(n, seed);
            for p in [2u32, 3, 5, 7] {
                let r = rootm(&a, p).unwrap();
                let mut pw = DMatrix::identity(n, n);
                for _ in 0..p {
                    pw = &pw * &r;
                }
                let tol = 1e-12 * a.norm() * n as f64;
                assert!(
                    (&pw - &a).norm() <= tol,
                    "n={n} p={p}: {}",
                    (&pw - &a).norm()
                );
                // Principal: eigenvalues of the root have |arg| < π/p.
                let lim = std::f64::consts::PI / p as f64;
                for l in crate::schur::real_schur(&r).unwrap().eigenvalues() {
                    assert!(l.arg().abs() < lim);
                }
            }
        }
    }

    #[test]
    fn root_of_jordan_block() {
        // [λ 1; 0 λ]^{1/p} = [μ, μ/(pλ); 0, μ] with μ = λ^{1/p}.
        let lam = 3.0f64;
        let a = DMatrix::from_row_slice(2, 2, &[lam, 1.0, 0.0, lam]);
        for p in [2u32, 3, 4] {
            let mu = lam.powf(1.0 / p as f64);
            let want = DMatrix::from_row_slice(2, 2, &[mu, mu / (p as f64 * lam), 0.0, mu]);
            assert_relative_eq!(rootm(&a, p).unwrap(), want, epsilon = 1e-14);
        }
    }

    #[test]
    fn empty_and_first_root() {
        assert_eq!(logm(&DMatrix::zeros(0, 0)).unwrap().shape(), (0, 0));
        assert_eq!(expm(&DMatrix::zeros(0, 0)).unwrap().shape(), (0, 0));
        let a = random_well_placed(3, 3);
        assert_eq!(rootm(&a, 1).unwrap(), a);
        assert_relative_eq!(
            expm(&DMatrix::zeros(3, 3)).unwrap(),
            DMatrix::identity(3, 3)
        );
    }

    #[test]
    fn expm_of_large_norm_matrix() {
        // exp(diag(30, −30)) exercises s > 0 squarings.
        let a = DMatrix::from_row_slice(2, 2, &[30.0, 1.0, 0.0, -30.0]);
        let e = expm(&a).unwrap();
        // Closed form: off-diagonal (e^30 − e^−30)/60.
        let want = DMatrix::from_row_slice(
            2,
            2,
            &[
                30f64.exp(),
                (30f64.exp() - (-30f64).exp()) / 60.0,
                0.0,
                (-30f64).exp(),
            ],
        );
        assert_relative_eq!(e, want, max_relative = 1e-13);
        assert!(matches!(
            expm(&DMatrix::from_element(1, 1, 1000.0)),
            Err(Error::InvalidArgument { .. })
        ));
    }

    #[test]
    fn log_recovers_zoh_augmented_matrix() {
        // d2c use: logm(expm([A B; 0 0]·T)) = [A B; 0 0]·T, with the
        // repeated eigenvalue 1 of the input block and slow/fast poles.
        let m = DMatrix::from_row_slice(
            4,
            4,
            &[
                -0.01, 1.0, 0.0, 0.0, -2.0, -0.3, 1.0, 0.5, 0.0, 0.0, -5.0, 1.0, 0.0, 0.0, 0.0, 0.0,
            ],
        );
        for t in [1e-3, 0.1, 0.5] {
            let x = &m * t;
            let l = logm(&expm(&x).unwrap()).unwrap();
            assert!(
                (&l - &x).norm() <= 1e-12 * x.norm().max(1.0),
                "T={t}: {}",
                (&l - &x).norm()
            );
        }
    }
}

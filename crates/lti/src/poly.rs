//! Real polynomials with coefficients in **descending powers** (MATLAB/scipy
//! order): `Poly::new(vec![1.0, -3.0, 2.0])` is s² − 3s + 2.
//!
//! The representation is normalised: leading exact zeros are removed, and the
//! zero polynomial is `[0.0]` (degree 0, [`Poly::is_zero`] true).
//! Arithmetic is exact floating-point arithmetic on coefficients (no
//! cancellation); [`cancel_common_roots`] removes common factors with a
//! tolerance.

use std::fmt;
use std::ops::{Add, Mul, Neg, Sub};

use num_complex::Complex64;

use crate::la;
use crate::{Error, Result};

/// A real polynomial, coefficients in descending powers.
#[derive(Debug, Clone, PartialEq)]
pub struct Poly {
    coeffs: Vec<f64>,
}

impl Poly {
    /// Builds a polynomial from coefficients in descending powers. Leading
    /// zeros are dropped; an empty vector is the zero polynomial.
    ///
    /// Errors: [`Error::NonFiniteScalar`] for NaN/infinite coefficients.
    pub fn new(coeffs: Vec<f64>) -> Result<Self> {
        for &c in &coeffs {
            crate::error::check_scalar("polynomial coefficient", c)?;
        }
        Ok(Self::from_vec(coeffs))
    }

    /// Internal constructor for finite coefficients (normalises leading zeros).
    pub(crate) fn from_vec(mut coeffs: Vec<f64>) -> Self {
        let first = coeffs.iter().position(|&c| c != 0.0);
        match first {
            None => coeffs = vec![0.0],
            Some(k) => {
                coeffs.drain(..k);
            }
        }
        Self { coeffs }
    }

    /// The constant polynomial `c`.
    pub fn constant(c: f64) -> Self {
        Self::from_vec(vec![c])
    }

    /// The zero polynomial.
    pub fn zero() -> Self {
        Self { coeffs: vec![0.0] }
    }

    /// The constant one.
    pub fn one() -> Self {
        Self { coeffs: vec![1.0] }
    }

    /// The monomial `s` (or `z`).
    pub fn s() -> Self {
        Self {
            coeffs: vec![1.0, 0.0],
        }
    }

    /// Monic polynomial with the given roots, Π(x − rᵢ). Complex roots must
    /// come in conjugate pairs; the (rounding-level) imaginary parts of the
    /// product are discarded. O(n²).
    ///
    /// Errors: [`Error::NonFiniteScalar`] for non-finite roots,
    /// [`Error::InvalidArgument`] if the roots are not closed under
    /// conjugation (imaginary part of a coefficient above 1e-8 relative).
    pub fn from_roots(roots: &[Complex64]) -> Result<Self> {
        for r in roots {
            crate::error::check_scalar("root (real part)", r.re)?;
            crate::error::check_scalar("root (imaginary part)", r.im)?;
        }
        let c = complex_from_roots(roots);
        let scale = c.iter().map(|z| z.norm()).fold(1.0, f64::max);
        if c.iter().any(|z| z.im.abs() > 1e-8 * scale) {
            return Err(Error::InvalidArgument {
                what: "roots",
                reason: "complex roots must come in conjugate pairs".into(),
            });
        }
        Ok(Self::from_vec(c.iter().map(|z| z.re).collect()))
    }

    /// Coefficients in descending powers.
    pub fn coeffs(&self) -> &[f64] {
        &self.coeffs
    }

    /// Degree (0 for constants, including the zero polynomial).
    pub fn degree(&self) -> usize {
        self.coeffs.len() - 1
    }

    /// True for the zero polynomial.
    pub fn is_zero(&self) -> bool {
        self.coeffs.len() == 1 && self.coeffs[0] == 0.0
    }

    /// Leading coefficient.
    pub fn leading(&self) -> f64 {
        self.coeffs[0]
    }

    /// Coefficient of x^k (0 beyond the degree).
    pub fn coeff_of_power(&self, k: usize) -> f64 {
        let d = self.degree();
        if k > d { 0.0 } else { self.coeffs[d - k] }
    }

    /// Multiplies every coefficient by `k`.
    pub fn scale(&self, k: f64) -> Self {
        Self::from_vec(self.coeffs.iter().map(|c| c * k).collect())
    }

    /// Divides by the leading coefficient (the zero polynomial is returned unchanged).
    pub fn monic(&self) -> Self {
        if self.is_zero() {
            self.clone()
        } else {
            self.scale(1.0 / self.leading())
        }
    }

    /// Evaluates at a real point (Horner, O(n)).
    pub fn eval(&self, x: f64) -> f64 {
        self.coeffs.iter().fold(0.0, |acc, &c| acc * x + c)
    }

    /// Evaluates at a complex point (Horner, O(n)).
    pub fn eval_complex(&self, x: Complex64) -> Complex64 {
        self.coeffs
            .iter()
            .fold(Complex64::new(0.0, 0.0), |acc, &c| acc * x + c)
    }

    /// Derivative.
    pub fn derivative(&self) -> Self {
        let d = self.degree();
        if d == 0 {
            return Self::zero();
        }
        Self::from_vec(
            self.coeffs[..d]
                .iter()
                .enumerate()
                .map(|(i, &c)| c * (d - i) as f64)
                .collect(),
        )
    }

    /// Roots as eigenvalues of the companion matrix (O(n³)); leading/trailing
    /// structure: exact zero trailing coefficients give exact zero roots.
    ///
    /// Errors: [`Error::InvalidArgument`] for the zero polynomial.
    pub fn roots(&self) -> Result<Vec<Complex64>> {
        if self.is_zero() {
            return Err(Error::InvalidArgument {
                what: "roots",
                reason: "the zero polynomial has no finite set of roots".into(),
            });
        }
        let mut c = self.coeffs.clone();
        let mut zeros = 0;
        while c.len() > 1 && c[c.len() - 1] == 0.0 {
            c.pop();
            zeros += 1;
        }
        let n = c.len() - 1;
        let mut out = vec![Complex64::new(0.0, 0.0); zeros];
        if n == 0 {
            return Ok(out);
        }
        let lead = c[0];
        let mut comp = nalgebra::DMatrix::<f64>::zeros(n, n);
        for j in 0..n {
            comp[(0, j)] = -c[j + 1] / lead;
        }
        for i in 1..n {
            comp[(i, i - 1)] = 1.0;
        }
        out.extend(la::eigenvalues(&comp)?);
        Ok(out)
    }

    /// Polynomial division: returns (quotient, remainder) with
    /// `self = q·d + r`, deg r < deg d.
    ///
    /// Errors: [`Error::ZeroDenominator`] when `d` is zero.
    pub fn div_rem(&self, d: &Poly) -> Result<(Poly, Poly)> {
        if d.is_zero() {
            return Err(Error::ZeroDenominator {
                what: "polynomial division",
            });
        }
        if self.degree() < d.degree() {
            return Ok((Poly::zero(), self.clone()));
        }
        let mut r = self.coeffs.clone();
        let nq = self.degree() - d.degree() + 1;
        let mut q = vec![0.0; nq];
        for i in 0..nq {
            let f = r[i] / d.leading();
            q[i] = f;
            for (j, &dc) in d.coeffs.iter().enumerate() {
                r[i + j] -= f * dc;
            }
        }
        let rem = r[nq..].to_vec();
        Ok((Poly::from_vec(q), Poly::from_vec(rem)))
    }

    /// Raises to a non-negative integer power.
    pub fn powi(&self, k: usize) -> Self {
        (0..k).fold(Poly::one(), |acc, _| &acc * self)
    }

    /// Drops leading coefficients whose magnitude is at most `tol` times the
    /// largest coefficient magnitude (rounding residue after a subtraction).
    pub fn trim_relative(&self, tol: f64) -> Self {
        let m = self.coeffs.iter().fold(0.0f64, |a, c| a.max(c.abs()));
        let first = self.coeffs.iter().position(|c| c.abs() > tol * m);
        match first {
            None => Poly::zero(),
            Some(k) => Poly::from_vec(self.coeffs[k..].to_vec()),
        }
    }

    /// Maximum absolute coefficient difference to another polynomial (aligned
    /// by power).
    pub fn max_abs_diff(&self, other: &Poly) -> f64 {
        let d = self.degree().max(other.degree());
        (0..=d)
            .map(|k| (self.coeff_of_power(k) - other.coeff_of_power(k)).abs())
            .fold(0.0, f64::max)
    }
}

/// Coefficients (descending) of Π(x − rᵢ) in complex arithmetic.
pub(crate) fn complex_from_roots(roots: &[Complex64]) -> Vec<Complex64> {
    let mut c = vec![Complex64::new(1.0, 0.0)];
    for &r in roots {
        let mut next = vec![Complex64::new(0.0, 0.0); c.len() + 1];
        for (i, &ci) in c.iter().enumerate() {
            next[i] += ci;
            next[i + 1] -= ci * r;
        }
        c = next;
    }
    c
}

impl fmt::Display for Poly {
    /// Formats as `1 s^2 - 3 s + 2` using the variable `s`; use
    /// [`Poly::display_with`] for another variable name.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.display_with("s"))
    }
}

impl Poly {
    /// Human-readable form with the given variable name, e.g. `0.0198 z^2 - 0.1949 z + 0.1562`.
    pub fn display_with(&self, var: &str) -> String {
        let d = self.degree();
        let mut out = String::new();
        for (i, &c) in self.coeffs.iter().enumerate() {
            let p = d - i;
            if c == 0.0 && d > 0 {
                continue;
            }
            let mag = format!("{:.6}", c.abs());
            let mag = trim_float(&mag);
            let term = match p {
                0 => mag,
                1 => format!("{mag} {var}"),
                _ => format!("{mag} {var}^{p}"),
            };
            if out.is_empty() {
                if c < 0.0 {
                    out.push('-');
                }
                out.push_str(&term);
            } else {
                out.push_str(if c < 0.0 { " - " } else { " + " });
                out.push_str(&term);
            }
        }
        if out.is_empty() { "0".into() } else { out }
    }
}

fn trim_float(s: &str) -> String {
    if s.contains('.') {
        let t = s.trim_end_matches('0').trim_end_matches('.');
        t.to_string()
    } else {
        s.to_string()
    }
}

impl Add for &Poly {
    type Output = Poly;
    fn add(self, rhs: &Poly) -> Poly {
        let d = self.degree().max(rhs.degree());
        Poly::from_vec(
            (0..=d)
                .rev()
                .map(|k| self.coeff_of_power(k) + rhs.coeff_of_power(k))
                .collect(),
        )
    }
}

impl Sub for &Poly {
    type Output = Poly;
    fn sub(self, rhs: &Poly) -> Poly {
        let d = self.degree().max(rhs.degree());
        Poly::from_vec(
            (0..=d)
                .rev()
                .map(|k| self.coeff_of_power(k) - rhs.coeff_of_power(k))
                .collect(),
        )
    }
}

impl Mul for &Poly {
    type Output = Poly;
    fn mul(self, rhs: &Poly) -> Poly {
        let mut c = vec![0.0; self.coeffs.len() + rhs.coeffs.len() - 1];
        for (i, &a) in self.coeffs.iter().enumerate() {
            for (j, &b) in rhs.coeffs.iter().enumerate() {
                c[i + j] += a * b;
            }
        }
        Poly::from_vec(c)
    }
}

impl Neg for &Poly {
    type Output = Poly;
    fn neg(self) -> Poly {
        self.scale(-1.0)
    }
}

/// Removes common roots of `num` and `den`: roots zᵢ of `num` and pⱼ of `den`
/// with |zᵢ − pⱼ| ≤ tol·max(1, |pⱼ|) are cancelled in pairs (closest pairs
/// first). The gain num.leading/den.leading is kept; the returned denominator
/// is monic. Complex roots are cancelled together with their conjugates so
/// the results stay real (closest pairs are cancelled first, so a
/// complex pair and its conjugate cancel together). O(n³) (root finding) + O(n_z·n_p) matching.
///
/// This is the SISO `minreal` of a transfer function. Errors: the zero
/// denominator ([`Error::ZeroDenominator`]).
pub fn cancel_common_roots(num: &Poly, den: &Poly, tol: f64) -> Result<(Poly, Poly)> {
    crate::error::check_scalar("tol", tol)?;
    if tol < 0.0 {
        return Err(Error::InvalidArgument {
            what: "tol",
            reason: format!("must be >= 0, got {tol}"),
        });
    }
    if den.is_zero() {
        return Err(Error::ZeroDenominator {
            what: "cancel_common_roots",
        });
    }
    if num.is_zero() {
        return Ok((Poly::zero(), Poly::one()));
    }
    let gain = num.leading() / den.leading();
    let mut zs = num.roots()?;
    let mut ps = den.roots()?;
    let mut cancelled = false;
    loop {
        // closest pair
        let mut best: Option<(usize, usize, f64)> = None;
        for (i, z) in zs.iter().enumerate() {
            for (j, p) in ps.iter().enumerate() {
                let d = (z - p).norm() / p.norm().max(1.0);
                if d <= tol && best.is_none_or(|b| d < b.2) {
                    best = Some((i, j, d));
                }
            }
        }
        let Some((i, j, _)) = best else { break };
        // Closest pairs first: a cancelled complex pair's conjugates are
        // the next closest pair, so conjugate symmetry is kept.
        zs.remove(i);
        ps.remove(j);
        cancelled = true;
    }
    if !cancelled {
        return Ok((num.scale(1.0 / den.leading()), den.monic()));
    }
    let n = Poly::from_vec(real_coeffs(&complex_from_roots(&zs))).scale(gain);
    let d = Poly::from_vec(real_coeffs(&complex_from_roots(&ps)));
    Ok((n, d))
}

fn real_coeffs(c: &[Complex64]) -> Vec<f64> {
    c.iter().map(|z| z.re).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    fn p(c: &[f64]) -> Poly {
        Poly::new(c.to_vec()).unwrap()
    }

    #[test]
    fn arithmetic() {
        let a = p(&[1.0, -3.0, 2.0]);
        let b = p(&[1.0, 1.0]);
        assert_eq!((&a * &b).coeffs(), &[1.0, -2.0, -1.0, 2.0]);
        assert_eq!((&a + &b).coeffs(), &[1.0, -2.0, 3.0]);
        assert_eq!((&a - &a).coeffs(), &[0.0]);
        assert!((&a - &a).is_zero());
        assert_eq!(a.eval(3.0), 2.0);
        assert_eq!(a.derivative().coeffs(), &[2.0, -3.0]);
        assert_eq!(p(&[0.0, 0.0, 5.0]).degree(), 0);
        let z = a.eval_complex(Complex64::new(0.0, 1.0));
        assert_abs_diff_eq!(z.re, 1.0);
        assert_abs_diff_eq!(z.im, -3.0);
    }

    #[test]
    fn roots_and_from_roots() {
        let a = p(&[1.0, -3.0, 2.0]);
        let mut r: Vec<f64> = a.roots().unwrap().iter().map(|z| z.re).collect();
        r.sort_by(f64::total_cmp);
        assert_abs_diff_eq!(r[0], 1.0, epsilon = 1e-12);
        assert_abs_diff_eq!(r[1], 2.0, epsilon = 1e-12);
        let q = Poly::from_roots(&[
            Complex64::new(-1.0, 2.0),
            Complex64::new(-1.0, -2.0),
            Complex64::new(0.5, 0.0),
        ])
        .unwrap();
        // (s^2 + 2s + 5)(s - 0.5) = s^3 + 1.5 s^2 + 4 s - 2.5
        assert!(q.max_abs_diff(&p(&[1.0, 1.5, 4.0, -2.5])) < 1e-12);
        assert!(Poly::from_roots(&[Complex64::new(0.0, 1.0)]).is_err());
        assert_eq!(p(&[2.0, 0.0, 0.0]).roots().unwrap().len(), 2);
        assert!(Poly::zero().roots().is_err());
    }

    #[test]
    fn division() {
        let a = p(&[1.0, -2.0, -1.0, 2.0]);
        let (q, r) = a.div_rem(&p(&[1.0, 1.0])).unwrap();
        assert_eq!(q.coeffs(), &[1.0, -3.0, 2.0]);
        assert!(r.is_zero());
        assert!(a.div_rem(&Poly::zero()).is_err());
    }

    #[test]
    fn cancellation() {
        // (s+1)(s+2) / ((s+1)(s+3)) -> 2(s+2)/(s+3) with gain 2
        let num = p(&[1.0, 3.0, 2.0]).scale(2.0);
        let den = p(&[1.0, 4.0, 3.0]);
        let (n, d) = cancel_common_roots(&num, &den, 1e-8).unwrap();
        assert!(n.max_abs_diff(&p(&[2.0, 4.0])) < 1e-12);
        assert!(d.max_abs_diff(&p(&[1.0, 3.0])) < 1e-12);
        assert!(Poly::new(vec![f64::NAN]).is_err());
    }

    #[test]
    fn display() {
        assert_eq!(p(&[1.0, -3.0, 2.5]).display_with("z"), "1 z^2 - 3 z + 2.5");
        assert_eq!(Poly::zero().to_string(), "0");
    }
}

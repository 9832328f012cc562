//! Interconnections of state-space models. All are O((n₁+n₂)²·(m+p)) apart
//! from the small linear solves; the state of the result is [x₁; x₂].

use nalgebra::DMatrix;

use crate::error::{Error, Result, check_domain};
use crate::la;
use crate::ss::StateSpace;
use crate::tf::FeedbackSign;

pub(crate) fn blkdiag(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(a.nrows() + b.nrows(), a.ncols() + b.ncols());
    m.view_mut((0, 0), a.shape()).copy_from(a);
    m.view_mut(a.shape(), b.shape()).copy_from(b);
    m
}

pub(crate) fn vcat(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(a.nrows() + b.nrows(), a.ncols());
    m.view_mut((0, 0), a.shape()).copy_from(a);
    m.view_mut((a.nrows(), 0), b.shape()).copy_from(b);
    m
}

pub(crate) fn hcat(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(a.nrows(), a.ncols() + b.ncols());
    m.view_mut((0, 0), a.shape()).copy_from(a);
    m.view_mut((0, a.ncols()), b.shape()).copy_from(b);
    m
}

fn dims(what: &'static str, expected: usize, got: usize) -> Error {
    Error::DimensionMismatch {
        what,
        expected: format!("{expected}"),
        got: format!("{got}"),
    }
}

/// Series connection u → g1 → g2 → y (transfer function G₂G₁).
///
/// A = [A₁ 0; B₂C₁ A₂], B = [B₁; B₂D₁], C = [D₂C₁ C₂], D = D₂D₁.
/// Errors: domain mismatch, outputs of g1 ≠ inputs of g2.
pub fn series(g1: &StateSpace, g2: &StateSpace) -> Result<StateSpace> {
    check_domain("series", g1.ts(), g2.ts())?;
    if g1.n_outputs() != g2.n_inputs() {
        return Err(dims(
            "series: outputs of g1 vs inputs of g2",
            g1.n_outputs(),
            g2.n_inputs(),
        ));
    }
    let n1 = g1.order();
    let mut a = blkdiag(g1.a(), g2.a());
    a.view_mut((n1, 0), (g2.order(), n1))
        .copy_from(&(g2.b() * g1.c()));
    let b = vcat(g1.b(), &(g2.b() * g1.d()));
    let c = hcat(&(g2.d() * g1.c()), g2.c());
    let d = g2.d() * g1.d();
    Ok(StateSpace::from_parts(a, b, c, d, g1.ts()))
}

/// Parallel connection: same input, outputs added (G₁ + G₂).
pub fn parallel(g1: &StateSpace, g2: &StateSpace) -> Result<StateSpace> {
    check_domain("parallel", g1.ts(), g2.ts())?;
    if g1.n_inputs() != g2.n_inputs() {
        return Err(dims("parallel: inputs", g1.n_inputs(), g2.n_inputs()));
    }
    if g1.n_outputs() != g2.n_outputs() {
        return Err(dims("parallel: outputs", g1.n_outputs(), g2.n_outputs()));
    }
    Ok(StateSpace::from_parts(
        blkdiag(g1.a(), g2.a()),
        vcat(g1.b(), g2.b()),
        hcat(g1.c(), g2.c()),
        g1.d() + g2.d(),
        g1.ts(),
    ))
}

/// Block-diagonal (append) connection: inputs [u₁; u₂], outputs [y₁; y₂].
pub fn append(g1: &StateSpace, g2: &StateSpace) -> Result<StateSpace> {
    check_domain("append", g1.ts(), g2.ts())?;
    Ok(StateSpace::from_parts(
        blkdiag(g1.a(), g2.a()),
        blkdiag(g1.b(), g2.b()),
        blkdiag(g1.c(), g2.c()),
        blkdiag(g1.d(), g2.d()),
        g1.ts(),
    ))
}

/// Feedback loop y = G e, e = u + s·K y with s = −1 (negative) or +1
/// (positive): the closed loop from u to y is G(I − sKG)⁻¹ = (I − sGK)⁻¹G.
/// G is p×m, K must be m×p. MIMO; the algebraic loop is solved with
/// F = (I − s D_G D_K)⁻¹.
///
/// Errors: domain/shape mismatch, [`Error::AlgebraicLoop`] if I − s D_G D_K is singular.
pub fn feedback(g: &StateSpace, k: &StateSpace, sign: FeedbackSign) -> Result<StateSpace> {
    check_domain("feedback", g.ts(), k.ts())?;
    let (p, m) = (g.n_outputs(), g.n_inputs());
    if k.n_inputs() != p {
        return Err(dims(
            "feedback: inputs of K vs outputs of G",
            p,
            k.n_inputs(),
        ));
    }
    if k.n_outputs() != m {
        return Err(dims(
            "feedback: outputs of K vs inputs of G",
            m,
            k.n_outputs(),
        ));
    }
    let s = sign.value();
    let (n1, n2) = (g.order(), k.order());
    let loop_m = DMatrix::<f64>::identity(p, p) - g.d() * k.d() * s;
    let f = la::inv(&loop_m).map_err(|_| Error::AlgebraicLoop)?;
    // y = Cy x + Dy u
    let cy = &f * hcat(g.c(), &(g.d() * k.c() * s));
    let dy = &f * g.d();
    // e = Ce x + De u
    let mut ce = k.d() * &cy * s;
    {
        let mut v = ce.view_mut((0, n1), (m, n2));
        v += k.c() * s;
    }
    let de = k.d() * &dy * s + DMatrix::<f64>::identity(m, m);
    let a = blkdiag(g.a(), k.a()) + vcat(&(g.b() * &ce), &(k.b() * &cy));
    let b = vcat(&(g.b() * &de), &(k.b() * &dy));
    Ok(StateSpace::from_parts(a, b, cy, dy, g.ts()))
}

impl StateSpace {
    /// The inverse system (u ↔ y) of a square model with invertible D:
    /// (A − BD⁻¹C, BD⁻¹, −D⁻¹C, D⁻¹). O(n²m + m³).
    ///
    /// Errors: [`Error::NotInvertible`] when D is not square or singular.
    pub fn inverse(&self) -> Result<StateSpace> {
        if self.n_inputs() != self.n_outputs() {
            return Err(Error::NotInvertible {
                what: "system",
                reason: "D is not square".into(),
            });
        }
        let di = la::inv(self.d()).map_err(|e| Error::NotInvertible {
            what: "system",
            reason: format!("D is singular ({e})"),
        })?;
        let a = self.a() - self.b() * &di * self.c();
        Ok(StateSpace::from_parts(
            a,
            self.b() * &di,
            -(&di * self.c()),
            di,
            self.ts(),
        ))
    }

    /// u → self → other (see [`series`]).
    pub fn series(&self, other: &StateSpace) -> Result<StateSpace> {
        series(self, other)
    }
    /// See [`parallel`].
    pub fn parallel(&self, other: &StateSpace) -> Result<StateSpace> {
        parallel(self, other)
    }
    /// See [`feedback`].
    pub fn feedback(&self, k: &StateSpace, sign: FeedbackSign) -> Result<StateSpace> {
        feedback(self, k, sign)
    }
    /// See [`append`].
    pub fn append(&self, other: &StateSpace) -> Result<StateSpace> {
        append(self, other)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parallel_and_append_shapes() {
        let g = StateSpace::new(
            DMatrix::from_element(1, 1, -1.0),
            DMatrix::identity(1, 1),
            DMatrix::identity(1, 1),
            DMatrix::identity(1, 1),
            None,
        )
        .unwrap();
        let p = parallel(&g, &g).unwrap();
        assert_eq!(p.d()[(0, 0)], 2.0);
        let a = append(&g, &g).unwrap();
        assert_eq!((a.order(), a.n_inputs(), a.n_outputs()), (2, 2, 2));
        assert!(series(&a, &g).is_err());
        let inv = g.inverse().unwrap();
        assert_eq!(inv.a()[(0, 0)], -2.0);
    }
}

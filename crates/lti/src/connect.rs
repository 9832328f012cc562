//! Interconnections of state-space models. All are O((n₁+n₂)²·(m+p)) apart
//! from the small linear solves; the state of the result is [x₁; x₂].

use nalgebra::DMatrix;

use crate::error::{Error, Result, check_domain};
use crate::la;
use crate::ss::StateSpace;

/// Sign of the feedback path in [`crate::feedback`] and
/// [`crate::TransferFunction::feedback`]: `Negative` (the default) gives
/// G(I + KG)⁻¹, `Positive` gives G(I − KG)⁻¹.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FeedbackSign {
    /// u = r − K y.
    #[default]
    Negative,
    /// u = r + K y.
    Positive,
}

impl FeedbackSign {
    /// −1 for negative feedback, +1 for positive.
    pub fn value(self) -> f64 {
        match self {
            FeedbackSign::Negative => -1.0,
            FeedbackSign::Positive => 1.0,
        }
    }
}

impl StateSpace {
    /// Discrete models only: delays input j by `input_delays[j]` samples and
    /// output i by `output_delays[i]` samples (pure z^-d). The delays are
    /// absorbed immediately as extra states (a shift register per delayed
    /// channel), so the result is an ordinary `StateSpace` of order
    /// n + Σ dᵢ. Empty slices mean no delay.
    ///
    /// Errors: [`Error::NotDiscrete`], wrong slice lengths.
    pub fn with_io_delays(&self, input_delays: &[usize], output_delays: &[usize]) -> Result<Self> {
        if !self.is_discrete() {
            return Err(Error::NotDiscrete {
                what: "with_io_delays",
            });
        }
        let m = self.n_inputs();
        let p = self.n_outputs();
        if !input_delays.is_empty() && input_delays.len() != m {
            return Err(Error::DimensionMismatch {
                what: "input_delays",
                expected: format!("{m} entries"),
                got: format!("{}", input_delays.len()),
            });
        }
        if !output_delays.is_empty() && output_delays.len() != p {
            return Err(Error::DimensionMismatch {
                what: "output_delays",
                expected: format!("{p} entries"),
                got: format!("{}", output_delays.len()),
            });
        }
        let mut sys = self.clone();
        if input_delays.iter().any(|&d| d > 0) {
            let pre = delay_bank(input_delays, self.ts);
            sys = crate::connect::series(&pre, &sys)?;
        }
        if output_delays.iter().any(|&d| d > 0) {
            let post = delay_bank(output_delays, self.ts);
            sys = crate::connect::series(&sys, &post)?;
        }
        sys.input_names.clone_from(&self.input_names);
        sys.output_names.clone_from(&self.output_names);
        Ok(sys)
    }
}

/// Diagonal bank of pure delays z^-dᵢ (one shift register per channel).
pub(crate) fn delay_bank(delays: &[usize], ts: Option<f64>) -> StateSpace {
    let k = delays.len();
    let n: usize = delays.iter().sum();
    let mut a = DMatrix::zeros(n, n);
    let mut b = DMatrix::zeros(n, k);
    let mut c = DMatrix::zeros(k, n);
    let mut d = DMatrix::zeros(k, k);
    let mut off = 0;
    for (j, &dj) in delays.iter().enumerate() {
        if dj == 0 {
            d[(j, j)] = 1.0;
            continue;
        }
        b[(off, j)] = 1.0;
        for i in 1..dj {
            a[(off + i, off + i - 1)] = 1.0;
        }
        c[(j, off + dj - 1)] = 1.0;
        off += dj;
    }
    StateSpace::from_parts(a, b, c, d, ts)
}

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

    #[test]
    fn delay_bank_is_a_shift_register() {
        let d = delay_bank(&[0, 2], Some(1.0));
        assert_eq!(d.order(), 2);
        assert_eq!(d.d()[(0, 0)], 1.0);
        let sys = StateSpace::new(
            DMatrix::from_row_slice(2, 2, &[0.5, 1.0, 0.0, 0.25]),
            DMatrix::from_row_slice(2, 1, &[0.0, 1.0]),
            DMatrix::from_row_slice(1, 2, &[1.0, 0.0]),
            DMatrix::zeros(1, 1),
            Some(1.0),
        )
        .unwrap();
        assert!(sys.with_io_delays(&[1, 1], &[]).is_err());
        let c = StateSpace::gain(DMatrix::identity(1, 1), None).unwrap();
        assert!(matches!(
            c.with_io_delays(&[1], &[]),
            Err(Error::NotDiscrete { .. })
        ));
    }
}

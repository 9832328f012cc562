//! Transfer functions: SISO ratios of [`Poly`] and MIMO matrices of them.

use std::fmt;

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::MinrealOptions;
use crate::connect::FeedbackSign;
use crate::error::{Error, Result, check_domain, check_ts};
use crate::poly::{Poly, cancel_common_roots};

/// A SISO rational function num/den (coefficients in descending powers).
#[derive(Debug, Clone, PartialEq)]
pub struct SisoTf {
    num: Poly,
    den: Poly,
}

impl SisoTf {
    /// num/den; errors with [`Error::ZeroDenominator`] when den is zero and
    /// [`Error::NonFiniteScalar`] for non-finite coefficients (e.g. after
    /// scaling a polynomial by NaN).
    pub fn new(num: Poly, den: Poly) -> Result<Self> {
        for &c in num.coeffs().iter().chain(den.coeffs()) {
            crate::error::check_scalar("transfer function coefficient", c)?;
        }
        if den.is_zero() {
            return Err(Error::ZeroDenominator {
                what: "transfer function",
            });
        }
        Ok(Self { num, den })
    }
    /// From coefficient slices (descending powers).
    pub fn from_coeffs(num: &[f64], den: &[f64]) -> Result<Self> {
        Self::new(Poly::new(num.to_vec())?, Poly::new(den.to_vec())?)
    }
    /// Numerator.
    pub fn num(&self) -> &Poly {
        &self.num
    }
    /// Denominator.
    pub fn den(&self) -> &Poly {
        &self.den
    }
    /// deg num ≤ deg den (the zero function is proper).
    pub fn is_proper(&self) -> bool {
        self.num.is_zero() || self.num.degree() <= self.den.degree()
    }
    /// Value at a complex point.
    pub fn eval(&self, s: Complex64) -> Complex64 {
        self.num.eval_complex(s) / self.den.eval_complex(s)
    }
    /// Scales numerator and denominator so the denominator is monic.
    pub fn normalized(&self) -> Self {
        let l = self.den.leading();
        Self {
            num: self.num.scale(1.0 / l),
            den: self.den.scale(1.0 / l),
        }
    }
    fn add(&self, o: &Self) -> Self {
        if self.den == o.den {
            return Self {
                num: &self.num + &o.num,
                den: self.den.clone(),
            };
        }
        Self {
            num: &(&self.num * &o.den) + &(&o.num * &self.den),
            den: &self.den * &o.den,
        }
    }
    fn mul(&self, o: &Self) -> Self {
        Self {
            num: &self.num * &o.num,
            den: &self.den * &o.den,
        }
    }
    fn neg(&self) -> Self {
        Self {
            num: -&self.num,
            den: self.den.clone(),
        }
    }
    /// Common-root cancellation (see [`crate::poly::cancel_common_roots`]).
    pub fn minreal(&self, tol: f64) -> Result<Self> {
        let (num, den) = cancel_common_roots(&self.num, &self.den, tol)?;
        Ok(Self { num, den })
    }
}

/// A p×m matrix of SISO transfer functions in s (`ts == None`) or z
/// (`ts == Some(T)`, positive powers of z).
#[derive(Debug, Clone, PartialEq)]
pub struct TransferFunction {
    rows: usize,
    cols: usize,
    entries: Vec<SisoTf>,
    ts: Option<f64>,
}

impl TransferFunction {
    /// A SISO transfer function num/den.
    ///
    /// Errors: NaN coefficients, zero denominator, invalid `ts`.
    pub fn siso(num: Poly, den: Poly, ts: Option<f64>) -> Result<Self> {
        check_ts(ts)?;
        Ok(Self {
            rows: 1,
            cols: 1,
            entries: vec![SisoTf::new(num, den)?],
            ts,
        })
    }

    /// SISO from coefficient slices (descending powers).
    pub fn from_coeffs(num: &[f64], den: &[f64], ts: Option<f64>) -> Result<Self> {
        Self::siso(Poly::new(num.to_vec())?, Poly::new(den.to_vec())?, ts)
    }

    /// A MIMO transfer matrix from rows of entries (`rows[i][j]`: output i,
    /// input j). All rows must have the same length.
    pub fn from_entries(rows: Vec<Vec<SisoTf>>, ts: Option<f64>) -> Result<Self> {
        check_ts(ts)?;
        let p = rows.len();
        let m = rows.first().map_or(0, Vec::len);
        if rows.iter().any(|r| r.len() != m) {
            return Err(Error::DimensionMismatch {
                what: "transfer function rows",
                expected: format!("{m} entries per row"),
                got: "rows of different lengths".into(),
            });
        }
        Ok(Self {
            rows: p,
            cols: m,
            entries: rows.into_iter().flatten().collect(),
            ts,
        })
    }

    /// A static gain matrix.
    pub fn gain(k: &DMatrix<f64>, ts: Option<f64>) -> Result<Self> {
        crate::la::check_finite("gain", k)?;
        let rows = (0..k.nrows())
            .map(|i| {
                (0..k.ncols())
                    .map(|j| SisoTf {
                        num: Poly::constant(k[(i, j)]),
                        den: Poly::one(),
                    })
                    .collect()
            })
            .collect();
        Self::from_entries(rows, ts)
    }

    pub(crate) fn from_parts(
        rows: usize,
        cols: usize,
        entries: Vec<SisoTf>,
        ts: Option<f64>,
    ) -> Self {
        Self {
            rows,
            cols,
            entries,
            ts,
        }
    }

    /// Number of outputs p.
    pub fn n_outputs(&self) -> usize {
        self.rows
    }
    /// Number of inputs m.
    pub fn n_inputs(&self) -> usize {
        self.cols
    }
    /// Sample period (None: continuous).
    pub fn ts(&self) -> Option<f64> {
        self.ts
    }
    /// Entry (output i, input j), or [`Error::IndexOutOfRange`] (the checked
    /// form of [`TransferFunction::entry`], for indices that come from user
    /// input).
    pub fn get(&self, i: usize, j: usize) -> Result<&SisoTf> {
        if i < self.rows && j < self.cols {
            Ok(&self.entries[i * self.cols + j])
        } else {
            Err(Error::IndexOutOfRange {
                row: i,
                col: j,
                rows: self.rows,
                cols: self.cols,
            })
        }
    }
    /// Entry (output i, input j). Panics if out of range, like slice
    /// indexing; use [`TransferFunction::get`] for indices from user input.
    #[track_caller]
    pub fn entry(&self, i: usize, j: usize) -> &SisoTf {
        assert!(
            i < self.rows && j < self.cols,
            "transfer function index out of range"
        );
        &self.entries[i * self.cols + j]
    }
    /// Numerator of entry (i, j).
    #[track_caller]
    pub fn num(&self, i: usize, j: usize) -> &Poly {
        &self.entry(i, j).num
    }
    /// Denominator of entry (i, j).
    #[track_caller]
    pub fn den(&self, i: usize, j: usize) -> &Poly {
        &self.entry(i, j).den
    }
    /// True when p = m = 1.
    pub fn is_siso(&self) -> bool {
        self.rows == 1 && self.cols == 1
    }

    /// Fails with [`Error::ImproperTransferFunction`] at the first improper entry.
    pub fn check_proper(&self) -> Result<()> {
        for i in 0..self.rows {
            for j in 0..self.cols {
                let e = self.entry(i, j);
                if !e.is_proper() {
                    return Err(Error::ImproperTransferFunction {
                        row: i,
                        col: j,
                        num_degree: e.num.degree(),
                        den_degree: e.den.degree(),
                    });
                }
            }
        }
        Ok(())
    }

    /// Every entry with a monic denominator.
    pub fn normalized(&self) -> Self {
        Self {
            entries: self.entries.iter().map(SisoTf::normalized).collect(),
            ..self.clone()
        }
    }

    /// Value G(s) (or G(z)) at a complex point, p×m (infinite entries at poles).
    ///
    /// Errors: non-finite `s`.
    pub fn eval(&self, s: Complex64) -> Result<DMatrix<Complex64>> {
        crate::error::check_scalar("s (real part)", s.re)?;
        crate::error::check_scalar("s (imaginary part)", s.im)?;
        Ok(DMatrix::from_fn(self.rows, self.cols, |i, j| {
            self.entry(i, j).eval(s)
        }))
    }

    fn same_shape(&self, o: &Self, what: &'static str) -> Result<()> {
        check_domain(what, self.ts, o.ts)?;
        if (self.rows, self.cols) != (o.rows, o.cols) {
            return Err(Error::DimensionMismatch {
                what,
                expected: format!("{}x{}", self.rows, self.cols),
                got: format!("{}x{}", o.rows, o.cols),
            });
        }
        Ok(())
    }

    /// Entry-wise sum (parallel connection). Exact polynomial arithmetic
    /// (no cancellation; equal denominators are kept once).
    pub fn add(&self, o: &Self) -> Result<Self> {
        self.same_shape(o, "add")?;
        Ok(Self {
            entries: self
                .entries
                .iter()
                .zip(&o.entries)
                .map(|(a, b)| a.add(b))
                .collect(),
            ..self.clone()
        })
    }

    /// Entry-wise difference.
    pub fn sub(&self, o: &Self) -> Result<Self> {
        self.add(&o.neg())
    }

    /// Negation.
    pub fn neg(&self) -> Self {
        Self {
            entries: self.entries.iter().map(SisoTf::neg).collect(),
            ..self.clone()
        }
    }

    /// Matrix product self·o (o acts first: the series connection u → o → self).
    pub fn mul(&self, o: &Self) -> Result<Self> {
        check_domain("mul", self.ts, o.ts)?;
        if self.cols != o.rows {
            return Err(Error::DimensionMismatch {
                what: "mul",
                expected: format!("{} rows on the right", self.cols),
                got: format!("{}", o.rows),
            });
        }
        let mut entries = Vec::with_capacity(self.rows * o.cols);
        for i in 0..self.rows {
            for j in 0..o.cols {
                let mut acc = SisoTf {
                    num: Poly::zero(),
                    den: Poly::one(),
                };
                for k in 0..self.cols {
                    let t = self.entry(i, k).mul(o.entry(k, j));
                    acc = if k == 0 { t } else { acc.add(&t) };
                }
                entries.push(acc);
            }
        }
        Ok(Self {
            rows: self.rows,
            cols: o.cols,
            entries,
            ts: self.ts,
        })
    }

    /// SISO reciprocal 1/G. Errors: not SISO, or G ≡ 0.
    pub fn inv(&self) -> Result<Self> {
        let e = self.siso_entry("inv")?;
        if e.num.is_zero() {
            return Err(Error::NotInvertible {
                what: "transfer function",
                reason: "it is identically zero".into(),
            });
        }
        Ok(Self {
            entries: vec![SisoTf {
                num: e.den.clone(),
                den: e.num.clone(),
            }],
            ..self.clone()
        })
    }

    fn siso_entry(&self, what: &'static str) -> Result<&SisoTf> {
        if !self.is_siso() {
            return Err(Error::DimensionMismatch {
                what,
                expected: "a SISO transfer function".into(),
                got: format!("{}x{}", self.rows, self.cols),
            });
        }
        Ok(&self.entries[0])
    }

    /// Closed loop with `k` in the feedback path: G(I ∓ KG)⁻¹ (sign per
    /// [`FeedbackSign`]). SISO: exact polynomial arithmetic,
    /// nG·dK / (dG·dK ± nG·nK), no cancellation. MIMO: through state space
    /// ([`crate::feedback`]) and back (both must be proper).
    ///
    /// ```
    /// use lifted_lti::{C2dOptions, FeedbackSign, HinfOptions, MinrealOptions, TransferFunction};
    /// # fn main() -> Result<(), lifted_lti::Error> {
    /// // Ren & Zhu (2009) Table 2: G = 1/(0.3s+1), K = 0.2 → H₂ = 1/(0.3s+1.2)
    /// let g = TransferFunction::from_coeffs(&[1.0], &[0.3, 1.0], None)?;
    /// let k = TransferFunction::from_coeffs(&[0.2], &[1.0], None)?;
    /// let h2 = g.feedback(&k, FeedbackSign::Negative)?;
    /// assert_eq!(h2.den(0, 0).coeffs(), &[0.3, 1.2]);
    /// // ZOH at 5 ms and back (inverse ZOH) recovers the same model
    /// let sd = h2.to_ss()?.c2d(0.005, &C2dOptions::default())?;
    /// let back = sd.d2c()?.to_tf(&MinrealOptions::default())?.normalized();
    /// assert!((back.den(0, 0).coeffs()[1] - 4.0).abs() < 1e-9);
    /// assert!((sd.hinf_norm(&HinfOptions::default())?.norm - 1.0 / 1.2).abs() < 1e-8);
    /// # Ok(())
    /// # }
    /// ```
    pub fn feedback(&self, k: &Self, sign: FeedbackSign) -> Result<Self> {
        check_domain("feedback", self.ts, k.ts)?;
        if self.is_siso() && k.is_siso() {
            let g = &self.entries[0];
            let kk = &k.entries[0];
            let num = &g.num * &kk.den;
            let loop_ = (&g.num * &kk.num).scale(-sign.value());
            let den = &(&g.den * &kk.den) + &loop_;
            if den.is_zero() {
                return Err(Error::AlgebraicLoop);
            }
            return Ok(Self {
                entries: vec![SisoTf { num, den }],
                ..self.clone()
            });
        }
        let g = self.to_ss()?;
        let kk = k.to_ss()?;
        crate::connect::feedback(&g, &kk, sign)?.to_tf(&MinrealOptions::default())
    }

    /// Cancels common numerator/denominator roots entry by entry with the
    /// relative tolerance `opts.tol` (see [`cancel_common_roots`]); denominators
    /// come back monic.
    pub fn minreal(&self, opts: &MinrealOptions) -> Result<Self> {
        let entries = self
            .entries
            .iter()
            .map(|e| e.minreal(opts.tol))
            .collect::<Result<Vec<_>>>()?;
        Ok(Self {
            entries,
            ..self.clone()
        })
    }

    /// SISO poles (roots of the denominator). For MIMO use `to_ss()?.poles()`.
    pub fn poles(&self) -> Result<Vec<Complex64>> {
        self.siso_entry("poles")?.den.roots()
    }

    /// SISO zeros (roots of the numerator).
    pub fn zeros(&self) -> Result<Vec<Complex64>> {
        let e = self.siso_entry("zeros")?;
        if e.num.is_zero() {
            Ok(vec![])
        } else {
            e.num.roots()
        }
    }

    /// DC gain G(0) (continuous) or G(1) (discrete).
    ///
    /// Errors: [`Error::Infinite`] when a denominator vanishes there.
    pub fn dc_gain(&self) -> Result<DMatrix<f64>> {
        let x = if self.ts.is_some() { 1.0 } else { 0.0 };
        let mut g = DMatrix::zeros(self.rows, self.cols);
        for i in 0..self.rows {
            for j in 0..self.cols {
                let e = self.entry(i, j);
                let d = e.den.eval(x);
                let n = e.num.eval(x);
                if d == 0.0 && n != 0.0 {
                    return Err(Error::Infinite {
                        what: "DC gain",
                        reason: format!("entry ({i}, {j}) has a pole at {x}"),
                    });
                }
                g[(i, j)] = if d == 0.0 { 0.0 } else { n / d };
            }
        }
        Ok(g)
    }
}

impl fmt::Display for TransferFunction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let var = if self.ts.is_some() { "z" } else { "s" };
        for i in 0..self.rows {
            for j in 0..self.cols {
                let e = self.entry(i, j);
                if !self.is_siso() {
                    write!(f, "[{i},{j}]: ")?;
                }
                writeln!(
                    f,
                    "({}) / ({})",
                    e.num.display_with(var),
                    e.den.display_with(var)
                )?;
            }
        }
        match self.ts {
            Some(t) => write!(f, "(discrete, T = {t})"),
            None => write!(f, "(continuous)"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tf(n: &[f64], d: &[f64]) -> TransferFunction {
        TransferFunction::from_coeffs(n, d, None).unwrap()
    }

    #[test]
    fn checked_entry_access() {
        let g = tf(&[1.0], &[1.0, 1.0]);
        assert_eq!(g.get(0, 0).unwrap().den().coeffs(), &[1.0, 1.0]);
        assert!(matches!(
            g.get(0, 1),
            Err(Error::IndexOutOfRange {
                row: 0,
                col: 1,
                rows: 1,
                cols: 1
            })
        ));
        assert!(g.get(3, 0).is_err());
    }

    #[test]
    fn algebra_is_exact() {
        let g = tf(&[1.0], &[1.0, 1.0]);
        let h = tf(&[2.0], &[1.0, 2.0]);
        let s = g.add(&h).unwrap();
        assert_eq!(s.num(0, 0).coeffs(), &[3.0, 4.0]);
        assert_eq!(s.den(0, 0).coeffs(), &[1.0, 3.0, 2.0]);
        let p = g.mul(&h).unwrap();
        assert_eq!(p.num(0, 0).coeffs(), &[2.0]);
        let f = g
            .feedback(&tf(&[3.0], &[1.0]), FeedbackSign::Negative)
            .unwrap();
        assert_eq!(f.den(0, 0).coeffs(), &[1.0, 4.0]);
        let f = g
            .feedback(&tf(&[3.0], &[1.0]), FeedbackSign::Positive)
            .unwrap();
        assert_eq!(f.den(0, 0).coeffs(), &[1.0, -2.0]);
        assert!(g.sub(&g).unwrap().num(0, 0).is_zero());
    }

    #[test]
    fn properness_and_dc_gain() {
        let g = tf(&[1.0, 0.0, 0.0], &[1.0, 1.0]);
        assert!(matches!(
            g.check_proper(),
            Err(Error::ImproperTransferFunction { .. })
        ));
        let i = tf(&[1.0], &[1.0, 0.0]);
        assert!(matches!(i.dc_gain(), Err(Error::Infinite { .. })));
        assert_eq!(tf(&[2.0], &[1.0, 4.0]).dc_gain().unwrap()[(0, 0)], 0.5);
        assert!(tf(&[0.0], &[1.0]).inv().is_err());
    }

    #[test]
    fn mimo_shapes_are_checked() {
        let e = SisoTf::from_coeffs(&[1.0], &[1.0, 1.0]).unwrap();
        let m = TransferFunction::from_entries(vec![vec![e.clone(), e.clone()]], None).unwrap();
        assert_eq!((m.n_outputs(), m.n_inputs()), (1, 2));
        assert!(m.add(&tf(&[1.0], &[1.0])).is_err());
        assert!(m.mul(&m).is_err());
        assert!(
            TransferFunction::from_entries(vec![vec![e.clone()], vec![e.clone(), e]], None)
                .is_err()
        );
        let k = TransferFunction::gain(&DMatrix::from_row_slice(1, 2, &[1.0, 2.0]), None).unwrap();
        assert_eq!(k.num(0, 1).coeffs(), &[2.0]);
    }
}

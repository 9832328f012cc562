//! Conversions of [`PolyModel`] to and from [`StateSpace`] and
//! [`TransferFunction`].
//!
//! The realisation and the formulas are in the [parent module's docs](super#conversions).

use nalgebra::DMatrix;

use super::{PolyModel, Polynomials, conv};
use crate::MinrealOptions;
use crate::convert::charpoly;
use crate::error::{Error, Result};
use crate::la;
use crate::poly::Poly;
use crate::ss::StateSpace;
use crate::tf::{SisoTf, TransferFunction};

/// Relative tolerance below which coefficients computed by
/// [`PolyModel::from_ss`] and [`PolyModel::from_ss_bj`] are taken as zero
/// (trailing coefficients dropped, leading B coefficients counted into the
/// delay nk): |x| ≤ 1e-10 · max(1, largest coefficient of the result).
/// [`PolyModel::from_tf`] drops exact zeros only.
pub const POLY_TRIM_TOL: f64 = 1e-10;

/// q^{−nk} B as one coefficient vector (the zero polynomial for an empty B).
fn delayed(b: &[f64], nk: usize) -> Vec<f64> {
    if b.is_empty() {
        return vec![0.0];
    }
    let mut v = vec![0.0; nk];
    v.extend_from_slice(b);
    v
}

/// One output's row of the coupled observer form ([conversions](super#conversions)).
struct RowForm {
    p: Vec<f64>,
    m: Vec<Vec<f64>>,
    n: Vec<Vec<f64>>,
    ne: Vec<f64>,
}

impl PolyModel {
    /// The rows of the observer form; `noise`: include D and C.
    fn row_forms(&self, noise: bool) -> Vec<RowForm> {
        (0..self.ny)
            .map(|i| {
                let mut fs: Vec<&[f64]> = Vec::new();
                let idx: Vec<usize> = (0..self.nu)
                    .map(|k| {
                        let fk = self.f(i, k);
                        fs.iter().position(|g| *g == fk).unwrap_or_else(|| {
                            fs.push(fk);
                            fs.len() - 1
                        })
                    })
                    .collect();
                let prod = |skip: Option<usize>| {
                    fs.iter()
                        .enumerate()
                        .filter(|(d, _)| Some(*d) != skip)
                        .fold(vec![1.0], |acc, (_, g)| conv(&acc, g))
                };
                let fprod = prod(None);
                let extra: &[f64] = if noise { &self.d[i] } else { &[1.0] };
                let common = conv(extra, &fprod);
                RowForm {
                    p: conv(self.a(i, i), &common),
                    m: (0..self.ny)
                        .map(|j| {
                            if j == i {
                                vec![0.0]
                            } else {
                                conv(self.a(i, j), &common)
                            }
                        })
                        .collect(),
                    n: (0..self.nu)
                        .map(|k| {
                            let others = conv(extra, &prod(Some(idx[k])));
                            conv(&delayed(self.b(i, k), self.nk(i, k)), &others)
                        })
                        .collect(),
                    ne: if noise {
                        conv(&self.c[i], &fprod)
                    } else {
                        vec![1.0]
                    },
                }
            })
            .collect()
    }
}

/// The matrices of the coupled observer form ([conversions](super#conversions)).
struct ObserverForm {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    c: DMatrix<f64>,
    d: DMatrix<f64>,
    /// The innovations gain (zero without the noise rows).
    k: DMatrix<f64>,
}

/// The coefficient of q⁻ˡ of `v` (0 beyond its end).
fn coef(v: &[f64], l: usize) -> f64 {
    v.get(l).copied().unwrap_or(0.0)
}

impl ObserverForm {
    /// All matrices zero: n states, n_y outputs, n_u inputs.
    fn zeros(n: usize, ny: usize, nu: usize) -> Self {
        ObserverForm {
            a: DMatrix::zeros(n, n),
            b: DMatrix::zeros(n, nu),
            c: DMatrix::zeros(ny, n),
            d: DMatrix::zeros(ny, nu),
            k: DMatrix::zeros(n, ny),
        }
    }
}

/// (A, B, C, D, K) of the coupled observer form of `rows` ([conversions](super#conversions)).
/// O(n (n_y (n_y + n_u))) to fill, O(n²) memory.
fn observer_form(rows: &[RowForm], nu: usize) -> ObserverForm {
    let ny = rows.len();
    let deg = |v: &Vec<f64>| v.len().saturating_sub(1);
    let ns: Vec<usize> = rows
        .iter()
        .map(|r| {
            r.m.iter()
                .chain(&r.n)
                .map(deg)
                .chain([deg(&r.p), deg(&r.ne)])
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut off = Vec::with_capacity(ny);
    let mut n = 0;
    for &ni in &ns {
        off.push(n);
        n += ni;
    }
    let ObserverForm {
        mut a,
        mut b,
        mut c,
        mut d,
        mut k,
    } = ObserverForm::zeros(n, ny, nu);
    for (i, r) in rows.iter().enumerate() {
        for (kk, nik) in r.n.iter().enumerate() {
            d[(i, kk)] = coef(nik, 0);
        }
        if ns[i] > 0 {
            c[(i, off[i])] = 1.0;
        }
    }
    for (i, r) in rows.iter().enumerate() {
        for l in 1..=ns[i] {
            let row = off[i] + l - 1;
            if l < ns[i] {
                a[(row, row + 1)] = 1.0;
            }
            for (kk, nik) in r.n.iter().enumerate() {
                b[(row, kk)] += coef(nik, l);
            }
            k[(row, i)] += coef(&r.ne, l);
            for j in 0..ny {
                let g = if j == i {
                    coef(&r.p, l)
                } else {
                    coef(&r.m[j], l)
                };
                if g == 0.0 {
                    continue;
                }
                if ns[j] > 0 {
                    a[(row, off[j])] -= g;
                }
                for kk in 0..nu {
                    b[(row, kk)] -= g * d[(j, kk)];
                }
                k[(row, j)] -= g;
            }
        }
    }
    ObserverForm { a, b, c, d, k }
}

/// One block of the parallel form ([conversions](super#conversions)):
/// part of output `output` with the monic denominator `p`, the input
/// numerators `n` (per input; empty: the input does not enter) and the
/// noise numerator `ne` (empty: no noise; else C_i, monic).
struct Block {
    output: usize,
    p: Vec<f64>,
    n: Vec<Vec<f64>>,
    ne: Vec<f64>,
}

impl PolyModel {
    /// Whether A = I (OE, BJ, FIR and the like: no A polynomial).
    fn identity_a(&self) -> bool {
        (0..self.ny).all(|i| {
            (0..self.ny).all(|j| {
                let a = self.a(i, j);
                let lead = if i == j { 1.0 } else { 0.0 };
                a.first().is_none_or(|v| *v == lead) && a.iter().skip(1).all(|v| *v == 0.0)
            })
        })
    }

    /// The blocks of the parallel form of a model without A (A = I): per
    /// output one block per distinct denominator F_ik (the inputs sharing
    /// it summed) and, with `noise`, D_i carrying C_i (merged with an input
    /// block of the same denominator).
    fn blocks(&self, noise: bool) -> Vec<Block> {
        let mut out: Vec<Block> = Vec::new();
        for i in 0..self.ny {
            let first = out.len();
            let aii = self.a(i, i);
            let find = |p: Vec<f64>, out: &mut Vec<Block>| -> usize {
                match out[first..].iter().position(|b| b.p == p) {
                    Some(at) => first + at,
                    None => {
                        out.push(Block {
                            output: i,
                            p,
                            n: vec![Vec::new(); self.nu],
                            ne: Vec::new(),
                        });
                        out.len() - 1
                    }
                }
            };
            for k in 0..self.nu {
                let b = self.b(i, k);
                if b.iter().all(|v| *v == 0.0) {
                    continue;
                }
                let at = find(conv(aii, self.f(i, k)), &mut out);
                out[at].n[k] = delayed(b, self.nk(i, k));
            }
            if noise {
                let at = find(conv(aii, &self.d[i]), &mut out);
                out[at].ne = self.c[i].clone();
            }
        }
        out
    }
}

/// (A, B, C, D, K) of the parallel form of `blocks` ([conversions](super#conversions)):
/// block b's equation P_b y_b = Σ_k N_bk u_k + N_be e_i in observer form,
/// y_i the sum of its blocks' y_b. O(n²) memory.
fn block_form(blocks: &[Block], ny: usize, nu: usize) -> ObserverForm {
    let deg = |v: &Vec<f64>| v.len().saturating_sub(1);
    let sizes: Vec<usize> = blocks
        .iter()
        .map(|b| {
            b.n.iter()
                .map(deg)
                .chain([deg(&b.p), deg(&b.ne)])
                .max()
                .unwrap_or(0)
        })
        .collect();
    let n: usize = sizes.iter().sum();
    let ObserverForm {
        mut a,
        mut b,
        mut c,
        mut d,
        mut k,
    } = ObserverForm::zeros(n, ny, nu);
    let mut off = 0;
    for (blk, &s) in blocks.iter().zip(&sizes) {
        let i = blk.output;
        let e0 = coef(&blk.ne, 0);
        for (kk, nk) in blk.n.iter().enumerate() {
            d[(i, kk)] += coef(nk, 0);
        }
        if s > 0 {
            c[(i, off)] = 1.0;
        }
        for l in 1..=s {
            let row = off + l - 1;
            if l < s {
                a[(row, row + 1)] = 1.0;
            }
            let pl = coef(&blk.p, l);
            a[(row, off)] -= pl;
            for (kk, nk) in blk.n.iter().enumerate() {
                b[(row, kk)] += coef(nk, l) - pl * coef(nk, 0);
            }
            k[(row, i)] += coef(&blk.ne, l) - pl * e0;
        }
        off += s;
    }
    ObserverForm { a, b, c, d, k }
}

/// num/den (ascending powers of q⁻¹, den monic) as a ratio in z.
fn ratio_to_siso(num: &[f64], den: &[f64]) -> Result<SisoTf> {
    let ln = num.len().saturating_sub(1);
    let ld = den.len().saturating_sub(1);
    let m = ln.max(ld);
    let mut nz = num.to_vec();
    nz.resize(m + 1, 0.0);
    let mut dz = den.to_vec();
    dz.resize(m + 1, 0.0);
    SisoTf::new(Poly::from_vec(nz), Poly::from_vec(dz))
}

/// Drops trailing coefficients with |x| ≤ tol, keeping at least `keep`.
fn trim_trailing(v: &mut Vec<f64>, tol: f64, keep: usize) {
    while v.len() > keep && v.last().is_some_and(|x| x.abs() <= tol) {
        v.pop();
    }
}

/// A proper entry num/den in z as (B, F, nk) in q⁻¹, coefficients with
/// |x| ≤ tol taken as zero (leading B ones counted into nk).
fn siso_to_ratio(e: &SisoTf, tol: f64) -> (Vec<f64>, Vec<f64>, usize) {
    let lead = e.den().leading();
    let mut f: Vec<f64> = e.den().coeffs().iter().map(|x| x / lead).collect();
    f[0] = 1.0;
    trim_trailing(&mut f, tol, 1);
    if e.num().is_zero() {
        return (Vec::new(), f, 0);
    }
    let mut nk = e.den().degree() - e.num().degree();
    let mut b: Vec<f64> = e.num().coeffs().iter().map(|x| x / lead).collect();
    let first = b.iter().position(|x| x.abs() > tol);
    match first {
        None => return (Vec::new(), f, 0),
        Some(s) => {
            b.drain(..s);
            nk += s;
        }
    }
    trim_trailing(&mut b, tol, 1);
    (b, f, nk)
}

/// Rejects a K that is not n × n_y and finite.
fn check_k(ss: &StateSpace, k: &DMatrix<f64>) -> Result<()> {
    if k.shape() != (ss.order(), ss.n_outputs()) {
        return Err(Error::DimensionMismatch {
            what: "Kalman gain",
            expected: format!("{}x{}", ss.order(), ss.n_outputs()),
            got: format!("{}x{}", k.nrows(), k.ncols()),
        });
    }
    la::check_finite("Kalman gain", k)?;
    Ok(())
}

impl PolyModel {
    /// The deterministic part G(q) = A⁻¹ diag(q^{−nk}) B/F as a discrete
    /// [`StateSpace`] (period `ts`, channel names kept), in the coupled
    /// observer form of [the module docs](crate::polymodel#conversions) (minimal for one output with
    /// coprime polynomials). O(n²).
    ///
    /// Errors: none for a valid model (the `Result` is for uniformity).
    pub fn to_ss(&self) -> Result<StateSpace> {
        let f = self.form(false);
        self.named(StateSpace::from_parts(f.a, f.b, f.c, f.d, Some(self.ts)))
    }

    /// The exact innovations form of the whole model: (StateSpace, K) with
    /// x⁺ = A x + B u + K e, y = C x + D u + e (e the model's white noise,
    /// covariance [`PolyModel::noise_variance`]); `StateSpace::predict`
    /// with this K is the model's predictor. O(n²).
    ///
    /// Errors: none for a valid model.
    pub fn to_innovations_ss(&self) -> Result<(StateSpace, DMatrix<f64>)> {
        let f = self.form(true);
        let ss = self.named(StateSpace::from_parts(f.a, f.b, f.c, f.d, Some(self.ts)))?;
        Ok((ss, f.k))
    }

    /// The parallel form without A, else the coupled observer form
    /// ([conversions](super#conversions)).
    fn form(&self, noise: bool) -> ObserverForm {
        if self.identity_a() {
            block_form(&self.blocks(noise), self.ny, self.nu)
        } else {
            observer_form(&self.row_forms(noise), self.nu)
        }
    }

    fn named(&self, mut ss: StateSpace) -> Result<StateSpace> {
        if let Some(n) = &self.input_names {
            ss = ss.with_input_names(n.clone())?;
        }
        if let Some(n) = &self.output_names {
            ss = ss.with_output_names(n.clone())?;
        }
        Ok(ss)
    }

    /// G as a [`TransferFunction`] in positive powers of z (period `ts`),
    /// delays included: entry (i, k) = z^{−nk} B_ik/(A_ii F_ik), the q⁻¹
    /// coefficient vectors padded with zeros to a common length and read as
    /// descending powers of z (no cancellation). With a non-diagonal A,
    /// through [`PolyModel::to_ss`] and [`StateSpace::to_tf`] (per-entry
    /// minimal realisations, default tolerance). O(r²) for a diagonal A.
    ///
    /// Errors: those of [`StateSpace::to_tf`] (non-diagonal A).
    pub fn to_tf(&self) -> Result<TransferFunction> {
        if !self.has_diagonal_a() {
            return self.to_ss()?.to_tf(&MinrealOptions::default());
        }
        let mut rows = Vec::with_capacity(self.ny);
        for i in 0..self.ny {
            let mut row = Vec::with_capacity(self.nu);
            for k in 0..self.nu {
                let num = delayed(self.b(i, k), self.nk(i, k));
                row.push(ratio_to_siso(&num, &conv(self.a(i, i), self.f(i, k)))?);
            }
            rows.push(row);
        }
        TransferFunction::from_entries(rows, Some(self.ts))
    }

    /// The noise model H = A⁻¹ diag(C/D) (n_y × n_y, H(∞) = I) as a
    /// [`TransferFunction`] in z, as [`PolyModel::to_tf`] does for G.
    ///
    /// Errors: those of [`StateSpace::to_tf`] (non-diagonal A).
    pub fn noise_tf(&self) -> Result<TransferFunction> {
        if !self.has_diagonal_a() {
            let (ss, k) = self.to_innovations_ss()?;
            let h = StateSpace::from_parts(
                ss.a().clone(),
                k,
                ss.c().clone(),
                DMatrix::identity(self.ny, self.ny),
                Some(self.ts),
            );
            return h.to_tf(&MinrealOptions::default());
        }
        let mut rows = Vec::with_capacity(self.ny);
        for i in 0..self.ny {
            let mut row = Vec::with_capacity(self.ny);
            for j in 0..self.ny {
                row.push(if i == j {
                    ratio_to_siso(&self.c[i], &conv(self.a(i, i), &self.d[i]))?
                } else {
                    SisoTf::new(Poly::zero(), Poly::one())?
                });
            }
            rows.push(row);
        }
        TransferFunction::from_entries(rows, Some(self.ts))
    }

    /// The output-error model of a discrete transfer function: entry
    /// (i, k) = num/den in z becomes B_ik/F_ik with delay nk = deg den −
    /// deg num (F = den/lead(den), B = num/lead(den), exact trailing zeros
    /// dropped: they are the same polynomial in q⁻¹). A = I, C = D = 1,
    /// Λ = I. Exact. O(r).
    ///
    /// Errors: [`Error::NotDiscrete`], [`Error::ImproperTransferFunction`].
    pub fn from_tf(tf: &TransferFunction) -> Result<Self> {
        Self::from_tf_tol(tf, 0.0)
    }

    fn from_tf_tol(tf: &TransferFunction, tol: f64) -> Result<Self> {
        let ts = tf.ts().ok_or(Error::NotDiscrete {
            what: "PolyModel::from_tf",
        })?;
        tf.check_proper()?;
        let (ny, nu) = (tf.n_outputs(), tf.n_inputs());
        let mut p = Polynomials {
            b: vec![Vec::with_capacity(nu); ny],
            f: Some(vec![Vec::with_capacity(nu); ny]),
            nk: vec![Vec::with_capacity(nu); ny],
            ..Default::default()
        };
        for i in 0..ny {
            for k in 0..nu {
                let (b, f, nk) = siso_to_ratio(tf.get(i, k)?, tol);
                p.b[i].push(b);
                if let Some(fr) = p.f.as_mut() {
                    fr[i].push(f);
                }
                p.nk[i].push(nk);
            }
        }
        Self::new(p, ts)
    }

    /// A polynomial model of a discrete state-space model, exactly (up to
    /// the tolerance of the minimal realisations it starts from).
    ///
    /// * `k = None`: the output-error model of G (H = I): every entry of
    ///   [`StateSpace::to_tf`] (per-entry minimal, default tolerance) as
    ///   B_ik/F_ik with its delay (see [`PolyModel::from_tf`]).
    /// * `k = Some(K)`: the innovations model x⁺ = A x + B u + K e,
    ///   y = C x + D u + e in the ARMAX form A_poly y = B_poly u + C e of
    ///   [the module docs](crate::polymodel#conversions), computed from a
    ///   minimal realisation of (A, `[B K]`, C, `[D I]`) (default
    ///   tolerance). One output: the minimal ARMAX model. Several
    ///   outputs: exact (G and H unchanged) with a full A and a common
    ///   C_i = det(zI − A + KC) per output, not minimal in parameters.
    ///
    /// Coefficients within [`POLY_TRIM_TOL`] of zero are dropped (trailing)
    /// or counted as delay (leading B). Λ = I; names are kept.
    /// O(n_y (n_y + n_u) n³).
    ///
    /// Errors: [`Error::NotDiscrete`], a K not n × n_y
    /// ([`Error::DimensionMismatch`]) or not finite ([`Error::Linalg`]),
    /// eigenvalue failures.
    pub fn from_ss(ss: &StateSpace, k: Option<&DMatrix<f64>>) -> Result<Self> {
        let ts = ss.ts().ok_or(Error::NotDiscrete {
            what: "PolyModel::from_ss",
        })?;
        let m = match k {
            None => Self::from_tf_tol(&ss.to_tf(&MinrealOptions::default())?, POLY_TRIM_TOL)?,
            Some(k) => {
                check_k(ss, k)?;
                armax_form(ss, k, ts)?
            }
        };
        m.with_names_of(ss)
    }

    /// The Box–Jenkins model of a discrete innovations model
    /// (x⁺ = A x + B u + K e, y = C x + D u + e): G per entry as B_ik/F_ik
    /// (as [`PolyModel::from_ss`] with `k = None`) and the diagonal of
    /// H = I + C(zI − A)⁻¹K as C_i/D_i, each from a per-entry minimal
    /// realisation (default tolerance). Exact for one output; for several
    /// outputs only when H is diagonal. O(n_y (n_y + n_u) n³).
    ///
    /// Errors: those of [`PolyModel::from_ss`], and
    /// [`Error::NotRepresentable`] when an off-diagonal entry of H is not
    /// zero.
    pub fn from_ss_bj(ss: &StateSpace, k: &DMatrix<f64>) -> Result<Self> {
        let ts = ss.ts().ok_or(Error::NotDiscrete {
            what: "PolyModel::from_ss_bj",
        })?;
        check_k(ss, k)?;
        let ny = ss.n_outputs();
        let oe = Self::from_tf_tol(&ss.to_tf(&MinrealOptions::default())?, POLY_TRIM_TOL)?;
        let h = StateSpace::from_parts(
            ss.a().clone(),
            k.clone(),
            ss.c().clone(),
            DMatrix::identity(ny, ny),
            Some(ts),
        )
        .to_tf(&MinrealOptions::default())?;
        let mut p = oe.polynomials();
        let (mut cs, mut ds) = (Vec::with_capacity(ny), Vec::with_capacity(ny));
        for i in 0..ny {
            for j in (0..ny).filter(|&j| j != i) {
                let e = h.get(i, j)?;
                let scale = e.den().coeffs().iter().fold(1.0f64, |a, x| a.max(x.abs()));
                if e.num()
                    .coeffs()
                    .iter()
                    .any(|x| x.abs() > POLY_TRIM_TOL * scale)
                {
                    return Err(Error::NotRepresentable {
                        what: "PolyModel::from_ss_bj",
                        reason: format!(
                            "the noise model couples output {j} into output {i} (H is not diagonal)"
                        ),
                    });
                }
            }
            let e = h.get(i, i)?;
            let lead = e.den().leading();
            let nl = e.num().leading() / lead;
            if e.num().degree() != e.den().degree() || (nl - 1.0).abs() > 1e-8 {
                return Err(Error::NotRepresentable {
                    what: "PolyModel::from_ss_bj",
                    reason: format!("H({i}, {i}) at infinity is {nl}, not 1"),
                });
            }
            let tol = POLY_TRIM_TOL
                * e.num()
                    .coeffs()
                    .iter()
                    .chain(e.den().coeffs())
                    .fold(lead.abs(), |a, x| a.max(x.abs()))
                / lead.abs();
            let mut c: Vec<f64> = e.num().coeffs().iter().map(|x| x / lead).collect();
            let mut d: Vec<f64> = e.den().coeffs().iter().map(|x| x / lead).collect();
            c[0] = 1.0;
            d[0] = 1.0;
            trim_trailing(&mut c, tol, 1);
            trim_trailing(&mut d, tol, 1);
            cs.push(c);
            ds.push(d);
        }
        p.c = Some(cs);
        p.d = Some(ds);
        Self::new(p, ts)?.with_names_of(ss)
    }

    fn with_names_of(self, ss: &StateSpace) -> Result<Self> {
        let mut m = self;
        if let Some(n) = ss.input_names() {
            m = m.with_input_names(n.to_vec())?;
        }
        if let Some(n) = ss.output_names() {
            m = m.with_output_names(n.to_vec())?;
        }
        Ok(m)
    }
}

/// The ARMAX form A_poly = c H⁻¹, B_poly = c H⁻¹ G, C = c ([conversions](super#conversions)).
fn armax_form(ss: &StateSpace, k: &DMatrix<f64>, ts: f64) -> Result<PolyModel> {
    let (nu, ny) = (ss.n_inputs(), ss.n_outputs());
    let mut bk = DMatrix::zeros(ss.order(), nu + ny);
    bk.columns_mut(0, nu).copy_from(ss.b());
    bk.columns_mut(nu, ny).copy_from(k);
    let mut dk = DMatrix::zeros(ny, nu + ny);
    dk.columns_mut(0, nu).copy_from(ss.d());
    dk.columns_mut(nu, ny).fill_with_identity();
    let joint = StateSpace::from_parts(ss.a().clone(), bk, ss.c().clone(), dk, Some(ts))
        .minreal(&MinrealOptions::default())?;
    let n = joint.order();
    let cm = joint.c();
    let b = joint.b().columns(0, nu).into_owned();
    let kj = joint.b().columns(nu, ny).into_owned();
    let d = joint.d().columns(0, nu).into_owned();
    let abar = joint.a() - &kj * cm;
    let c = charpoly(&abar)?;
    // c_i adj(zI − Ā) x + s·c as n + 1 coefficients in q⁻¹ (descending in z).
    let entry = |x: &DMatrix<f64>, i: usize, s: f64| -> Result<Vec<f64>> {
        let p = charpoly(&(&abar - x * cm.rows(i, 1)))?;
        let v = &(&p - &c) + &c.scale(s);
        Ok((0..=n).map(|l| v.coeff_of_power(n - l)).collect())
    };
    let bkd = &b - &kj * &d;
    let mut a_rows = Vec::with_capacity(ny);
    let mut b_rows = Vec::with_capacity(ny);
    for i in 0..ny {
        let mut ar = Vec::with_capacity(ny);
        for j in 0..ny {
            // δ_ij c − (det(zI − Ā + K_j C_i) − c)
            let v = entry(&kj.columns(j, 1).into_owned(), i, 0.0)?;
            let mut v: Vec<f64> = v.iter().map(|x| -x).collect();
            if i == j {
                for (l, x) in v.iter_mut().enumerate() {
                    *x += c.coeff_of_power(n - l);
                }
            }
            ar.push(v);
        }
        a_rows.push(ar);
        let br = (0..nu)
            .map(|kk| entry(&bkd.columns(kk, 1).into_owned(), i, d[(i, kk)]))
            .collect::<Result<Vec<_>>>()?;
        b_rows.push(br);
    }
    let mut cpoly: Vec<f64> = (0..=n).map(|l| c.coeff_of_power(n - l)).collect();
    let scale = a_rows
        .iter()
        .flatten()
        .chain(b_rows.iter().flatten())
        .flatten()
        .chain(&cpoly)
        .fold(1.0f64, |acc, x| acc.max(x.abs()));
    let tol = POLY_TRIM_TOL * scale;
    for (i, row) in a_rows.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            v[0] = if i == j { 1.0 } else { 0.0 };
            trim_trailing(v, tol, 1);
        }
    }
    let mut nks = vec![vec![0; nu]; ny];
    for (i, row) in b_rows.iter_mut().enumerate() {
        for (kk, v) in row.iter_mut().enumerate() {
            match v.iter().position(|x| x.abs() > tol) {
                None => v.clear(),
                Some(s) => {
                    v.drain(..s);
                    nks[i][kk] = s;
                    trim_trailing(v, tol, 1);
                }
            }
        }
    }
    cpoly[0] = 1.0;
    trim_trailing(&mut cpoly, tol, 1);
    PolyModel::new(
        Polynomials {
            a: Some(a_rows),
            b: b_rows,
            c: Some(vec![cpoly; ny]),
            nk: nks,
            ..Default::default()
        },
        ts,
    )
}

#[cfg(test)]
pub(crate) mod tests {
    use super::super::PolyFamily;
    use super::super::tests::{coupled_arx, miso_oe, siso_models};
    use super::*;
    use num_complex::Complex64;

    /// Largest difference of two coefficient vectors (shorter padded with zeros).
    pub(crate) fn diff(a: &[f64], b: &[f64]) -> f64 {
        (0..a.len().max(b.len()))
            .map(|l| (a.get(l).unwrap_or(&0.0) - b.get(l).unwrap_or(&0.0)).abs())
            .fold(0.0, f64::max)
    }

    /// Largest coefficient difference of two models of the same shape
    /// (delays must be equal).
    pub(crate) fn model_diff(x: &PolyModel, y: &PolyModel) -> f64 {
        assert_eq!((x.ny, x.nu), (y.ny, y.nu));
        let mut m = 0.0f64;
        for i in 0..x.ny {
            for j in 0..x.ny {
                m = m.max(diff(x.a(i, j), y.a(i, j)));
            }
            for k in 0..x.nu {
                if !x.b(i, k).is_empty() || !y.b(i, k).is_empty() {
                    assert_eq!(x.nk(i, k), y.nk(i, k), "nk({i}, {k})");
                }
                m = m.max(diff(x.b(i, k), y.b(i, k)));
                m = m.max(diff(x.f(i, k), y.f(i, k)));
            }
            m = m.max(diff(&x.c[i], &y.c[i]));
            m = m.max(diff(&x.d[i], &y.d[i]));
        }
        m
    }

    /// Frequency responses of G and H of two models agree.
    fn same_responses(x: &PolyModel, y: &PolyModel, tol: f64) {
        let w: Vec<f64> = (1..40).map(|i| i as f64 * 0.08 / x.ts()).collect();
        for (gx, gy) in [
            (x.freqresp(&w).unwrap(), y.freqresp(&w).unwrap()),
            (x.noise_freqresp(&w).unwrap(), y.noise_freqresp(&w).unwrap()),
        ] {
            for (a, b) in gx.iter().zip(&gy) {
                let d = (a - b).map(Complex64::norm).max();
                assert!(d < tol, "{d}");
            }
        }
    }

    #[test]
    fn observer_form_is_minimal_for_siso_families() {
        let orders: Vec<(usize, usize)> = siso_models()
            .iter()
            .map(|m| {
                (
                    m.to_ss().unwrap().order(),
                    m.to_innovations_ss().unwrap().0.order(),
                )
            })
            .collect();
        // ARX [2 2 1]: 2; ARMAX [2 2 2 2]: 3; OE [2 1 1]: 2 (K = 0);
        // BJ [2 1 1 2 1]: G 2, (G, H) 3; FIR [3 2]: 4; general.
        assert_eq!(orders, vec![(2, 2), (3, 3), (2, 2), (2, 3), (4, 4), (2, 3)]);
        let oe = &siso_models()[2];
        assert_eq!(oe.to_innovations_ss().unwrap().1.amax(), 0.0);
    }

    #[test]
    fn to_tf_includes_delays_in_positive_powers_of_z() {
        // q⁻²(0.5 − 0.2q⁻¹)/(1 − 0.6q⁻¹) = (0.5z − 0.2)/(z³ − 0.6z²)
        let m = PolyModel::oe(&[0.5, -0.2], &[1.0, -0.6], 2, 0.2).unwrap();
        let g = m.to_tf().unwrap();
        assert_eq!(g.num(0, 0).coeffs(), &[0.5, -0.2]);
        assert_eq!(g.den(0, 0).coeffs(), &[1.0, -0.6, 0.0, 0.0]);
        assert_eq!(g.ts(), Some(0.2));
        assert_eq!(PolyModel::from_tf(&g).unwrap(), m);
        // Noise of ARMAX: C/A.
        let am = &siso_models()[1];
        let h = am.noise_tf().unwrap();
        assert_eq!(h.num(0, 0).coeffs(), am.c(0));
        assert_eq!(h.den(0, 0).coeffs(), am.a(0, 0));
        // The tf and the state space agree (every model, coupled included).
        let w = [0.1, 0.7, 2.0];
        let mut all = siso_models();
        all.extend([coupled_arx(), miso_oe()]);
        for m in &all {
            let ts = m.ts();
            let tf = m.to_tf().unwrap();
            let ss = m.to_ss().unwrap();
            for &wi in &w {
                let z = Complex64::from_polar(1.0, wi * ts);
                let d = (tf.eval(z).unwrap() - ss.eval_complex(z).unwrap()).map(Complex64::norm);
                assert!(d.max() < 1e-10, "{}", d.max());
            }
            let nt = m.noise_tf().unwrap();
            let (iss, k) = m.to_innovations_ss().unwrap();
            let hss = StateSpace::new(
                iss.a().clone(),
                k,
                iss.c().clone(),
                DMatrix::identity(m.n_outputs(), m.n_outputs()),
                Some(ts),
            )
            .unwrap();
            for &wi in &w {
                let z = Complex64::from_polar(1.0, wi * ts);
                let d = (nt.eval(z).unwrap() - hss.eval_complex(z).unwrap()).map(Complex64::norm);
                assert!(d.max() < 1e-10, "{}", d.max());
            }
        }
    }

    #[test]
    fn round_trips_through_state_space() {
        let models = siso_models();
        // ARX, ARMAX, FIR: innovations form and back, same polynomials.
        for m in [&models[0], &models[1]] {
            let (ss, k) = m.to_innovations_ss().unwrap();
            let back = PolyModel::from_ss(&ss, Some(&k)).unwrap();
            assert_eq!(back.family(), m.family());
            assert!(model_diff(&back, m) < 1e-9, "{}", model_diff(&back, m));
        }
        // OE and FIR: the deterministic part and back.
        for m in [&models[2], &models[4]] {
            let back = PolyModel::from_ss(&m.to_ss().unwrap(), None).unwrap();
            assert_eq!(back.family(), m.family());
            assert!(model_diff(&back, m) < 1e-9, "{}", model_diff(&back, m));
        }
        // BJ: structurally through from_ss_bj; as ARMAX (A = FD) through from_ss.
        let bj = &models[3];
        let (ss, k) = bj.to_innovations_ss().unwrap();
        let back = PolyModel::from_ss_bj(&ss, &k).unwrap();
        assert_eq!(back.family(), PolyFamily::Bj);
        assert!(model_diff(&back, bj) < 1e-9, "{}", model_diff(&back, bj));
        let armax = PolyModel::from_ss(&ss, Some(&k)).unwrap();
        assert_eq!(armax.family(), PolyFamily::Armax);
        assert!(diff(armax.a(0, 0), &conv(bj.f(0, 0), bj.d(0))) < 1e-9);
        same_responses(&armax, bj, 1e-9);
        // The general model through the ARMAX form.
        let g = &models[5];
        let (ss, k) = g.to_innovations_ss().unwrap();
        same_responses(&PolyModel::from_ss(&ss, Some(&k)).unwrap(), g, 1e-9);
        // Coupled two-output ARX.
        let m = coupled_arx();
        let (ss, k) = m.to_innovations_ss().unwrap();
        let back = PolyModel::from_ss(&ss, Some(&k)).unwrap();
        assert_eq!(back.family(), PolyFamily::Arx);
        assert!(model_diff(&back, &m) < 1e-9, "{}", model_diff(&back, &m));
        // MISO OE with different F and delays.
        let m = miso_oe();
        let back = PolyModel::from_ss(&m.to_ss().unwrap(), None).unwrap();
        assert!(model_diff(&back, &m) < 1e-9, "{}", model_diff(&back, &m));
        assert_eq!(back.nk(0, 1), 3);
    }

    #[test]
    fn mimo_output_error_form_keeps_g() {
        // The coupled ARX's G = A⁻¹B as one B/F per entry (H = I).
        let m = coupled_arx();
        let oe = PolyModel::from_ss(&m.to_ss().unwrap(), None).unwrap();
        assert_eq!(oe.family(), PolyFamily::Oe);
        let w: Vec<f64> = (1..30).map(|i| i as f64 * 0.2).collect();
        let (g, g0) = (oe.freqresp(&w).unwrap(), m.freqresp(&w).unwrap());
        for (a, b) in g.iter().zip(&g0) {
            assert!((a - b).map(Complex64::norm).max() < 1e-9);
        }
        // The delays show as nk: G21 = 0.5 q⁻² (…) starts at q⁻².
        assert_eq!(oe.nk(1, 0), 2);
    }

    #[test]
    fn mimo_armax_form_is_exact() {
        // Two outputs with a coupled noise (K full): G and H survive.
        let ss = StateSpace::new(
            DMatrix::from_row_slice(3, 3, &[0.5, 0.2, 0.0, -0.1, 0.6, 0.1, 0.0, 0.3, -0.4]),
            DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.5, 1.0, 0.0, -0.5]),
            DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.5, 0.0, 1.0, 0.0]),
            DMatrix::from_row_slice(2, 2, &[0.0, 0.1, 0.0, 0.0]),
            Some(1.0),
        )
        .unwrap();
        let k = DMatrix::from_row_slice(3, 2, &[0.3, 0.1, 0.0, 0.2, -0.1, 0.05]);
        let m = PolyModel::from_ss(&ss, Some(&k)).unwrap();
        let w: Vec<f64> = (1..30).map(|i| i as f64 * 0.1).collect();
        let g = m.freqresp(&w).unwrap();
        let h = m.noise_freqresp(&w).unwrap();
        let hss = StateSpace::new(
            ss.a().clone(),
            k.clone(),
            ss.c().clone(),
            DMatrix::identity(2, 2),
            Some(1.0),
        )
        .unwrap();
        let g0 = ss.freqresp(&w).unwrap();
        let h0 = hss.freqresp(&w).unwrap();
        for t in 0..w.len() {
            assert!((&g[t] - &g0[t]).map(Complex64::norm).max() < 1e-9);
            assert!((&h[t] - &h0[t]).map(Complex64::norm).max() < 1e-9);
        }
        // Not representable as BJ: H couples the outputs.
        assert!(matches!(
            PolyModel::from_ss_bj(&ss, &k),
            Err(Error::NotRepresentable { .. })
        ));
    }

    #[test]
    fn conversions_reject_bad_input() {
        let ct = TransferFunction::from_coeffs(&[1.0], &[1.0, 1.0], None).unwrap();
        assert!(matches!(
            PolyModel::from_tf(&ct),
            Err(Error::NotDiscrete { .. })
        ));
        let improper =
            TransferFunction::from_coeffs(&[1.0, 0.0, 1.0], &[1.0, 0.5], Some(1.0)).unwrap();
        assert!(matches!(
            PolyModel::from_tf(&improper),
            Err(Error::ImproperTransferFunction { .. })
        ));
        let (ss, _) = siso_models()[1].to_innovations_ss().unwrap();
        assert!(matches!(
            PolyModel::from_ss(&ss, Some(&DMatrix::zeros(2, 1))),
            Err(Error::DimensionMismatch { .. })
        ));
        let css = StateSpace::new(
            DMatrix::from_element(1, 1, -1.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::zeros(1, 1),
            None,
        )
        .unwrap();
        assert!(matches!(
            PolyModel::from_ss(&css, None),
            Err(Error::NotDiscrete { .. })
        ));
    }
}

//! Polynomial input–output models (MATLAB's `idpoly`): ARX, ARMAX, OE,
//! Box–Jenkins, FIR and the general family, in discrete time.
//!
//! # The model
//!
//! Ljung (1999), *System Identification*, §4.2, eq. (4.33), with one input
//! delay per input–output pair and MATLAB's multi-output convention:
//!
//! ```text
//!   Σ_j A_ij(q) y_j(t) = Σ_k B_ik(q)/F_ik(q) u_k(t − nk_ik) + C_i(q)/D_i(q) e_i(t),   i = 1 … n_y
//! ```
//!
//! where e is white with covariance Λ ([`PolyModel::noise_variance`]).
//! Every polynomial is in the delay operator q⁻¹ with its coefficients in
//! **ascending powers of q⁻¹** (MATLAB's `idpoly` order), so `[1.0, -1.5,
//! 0.7]` is 1 − 1.5 q⁻¹ + 0.7 q⁻². This is the *opposite* of [`crate::Poly`],
//! whose coefficients are in descending powers of z; [`PolyModel::to_tf`]
//! converts (the same vector, padded with zeros, read as descending powers
//! of z).
//!
//! * A is an n_y × n_y matrix of polynomials: the diagonal entries are monic
//!   (leading coefficient exactly 1), the off-diagonal entries have leading
//!   coefficient exactly 0 (so A(0) = I and the model is causal). Single
//!   output models and every family but ARX usually have a diagonal A.
//! * B and F are n_y × n_u; F is monic. B's first coefficient multiplies
//!   q^{−nk}: B_ik(q) q^{−nk_ik} = b₀ q^{−nk} + b₁ q^{−nk−1} + …; the delay
//!   is stored in [`PolyModel::nk`], never as leading zeros (MATLAB stores
//!   the zeros). An empty B is the zero polynomial.
//! * C and D are one monic polynomial per output.
//!
//! Orders follow MATLAB ([`PolyOrders`]): `na`, `nc`, `nd`, `nf` are
//! degrees (numbers of free coefficients after the fixed leading one), `nb`
//! is the number of B coefficients, `nk` the delay in samples. The families
//! ([`PolyFamily`]) are ARX `[na nb nk]`, ARMAX `[na nb nc nk]`, OE
//! `[nb nf nk]`, BJ `[nb nc nd nf nk]`, FIR `[nb nk]`.
//!
//! # The predictor
//!
//! With H = A⁻¹ diag(C/D) and G = A⁻¹ (B/F) q^{−nk}, the one-step-ahead
//! predictor is ŷ(t|t−1) = (I − H⁻¹) y(t) + H⁻¹ G u(t) (Ljung 1999,
//! eq. (4.35) for a single output:
//! ŷ = [1 − D A / C] y + [D B / (C F)] u), so the prediction errors are
//!
//! ```text
//!   ε_i(t) = D_i(q)/C_i(q) · [ Σ_j A_ij(q) y_j(t) − Σ_k B_ik(q)/F_ik(q) u_k(t − nk_ik) ].
//! ```
//!
//! [`PolyModel::prediction_errors`] and [`PolyModel::predict_one_step`]
//! filter this directly; [`PolyModel::predict`] runs the Kalman predictor
//! of the exact innovations form [`PolyModel::to_innovations_ss`]
//! (x⁺ = A x + B u + K e, y = C x + D u + e) for any horizon.
//!
//! # Conversions
//!
//! ## To state space: the parallel form (no A)
//!
//! Without an A polynomial (OE, BJ, FIR; A = I) output i is the sum of one
//! block per distinct F_ik — F y_b = Σ_{k: F_ik = F} q^{−nk} B_ik u_k —
//! and, for the innovations form, the block D_i y_b = C_i e_i (merged
//! with an input block whose F equals D_i), each in observer canonical
//! form (below, with P = F or D) and the outputs summed. The state
//! dimension is that of the coupled form's common denominator, but no
//! product of the denominators is ever formed: the roots of a product of
//! several polynomials with clustered roots are not determined by its
//! rounded coefficients (a seven-input BJ model, each F with roots near
//! 0.9–0.95 and D = (1 − 0.9q⁻¹)², had spectral radius 1.06 and a
//! simulation off by 1e56 through the product, 0.95 and 6e-15 in parallel).
//!
//! ## To state space: the coupled observer form (with A)
//!
//! Output i's equation is multiplied by P̄_i = D_i · Π F_ik (the product
//! over the *distinct* F_ik of the row, D_i only with the noise), giving
//! polynomial equations
//!
//! ```text
//!   P_i y_i + Σ_{j≠i} M_ij y_j = Σ_k N_ik u_k + N_ie e_i,
//!   P_i = A_ii P̄_i,  M_ij = A_ij P̄_i,  N_ik = q^{−nk} B_ik P̄_i / F_ik,  N_ie = C_i Π F_ik,
//! ```
//!
//! each realised in observer canonical form with n_i = max degree states
//! (`p[l]` the coefficient of q^{−l}), the y_j substituted:
//!
//! ```text
//!   y_i(t)       = x_{i,1}(t) + Σ_k N_ik[0] u_k(t) + e_i(t)
//!   x_{i,l}(t+1) = x_{i,l+1}(t) − P_i[l] y_i(t) − Σ_j M_ij[l] y_j(t) + Σ_k N_ik[l] u_k(t) + N_ie[l] e_i(t)
//! ```
//!
//! Since A(0) = I and C(0) = D(0) = F(0) = 1 this is
//! exactly the innovations form x⁺ = A x + B u + K e, y = C x + D u + e.
//! For one output it is minimal when the polynomials are coprime: order
//! max(na, nb + nk − 1, nc) for ARMAX, max(nf, nb + nk − 1) for OE
//! (K = 0) and max(nf, nb + nk − 1) + max(nd, nc) for BJ (their
//! parallel form above). The
//! deterministic part [`PolyModel::to_ss`] leaves D and C out (order
//! max(na, nb + nk − 1) for ARX, max(nf, nb + nk − 1) for OE and BJ).
//!
//! ## From state space
//!
//! With Ā = A − KC and c(z) = det(zI − Ā), the innovations model has
//! H⁻¹ = I − C(zI − Ā)⁻¹K and H⁻¹G = C(zI − Ā)⁻¹(B − KD) + D, so
//!
//! ```text
//!   A_poly = c · H⁻¹,   B_poly = c · H⁻¹ G,   C_i = c,   D_i = F_ik = 1
//! ```
//!
//! are polynomial matrices (A_poly(0) = I) and A_poly y = B_poly u + c e
//! is the same model, exactly, for any number of outputs. Entries use
//! cᵢ adj(zI − Ā) x = det(zI − Ā + x cᵢ) − det(zI − Ā) (characteristic
//! polynomials from eigenvalues). The realisation is first made minimal
//! ([`crate::StateSpace::minreal`] of (A, `[B K]`, C, `[D I]`), default
//! tolerance), so for one output
//! this is the ARMAX model with A = det(zI − A_ss), B the numerators of G
//! over it and C = det(zI − A_ss + K C_ss): minimal and unique. For several
//! outputs it is exact but not minimal in parameters (every output gets the
//! common C = c, and A is a full polynomial matrix of degree n).
//!
//! # Map
//!
//! | function | what | cost (N samples, n states, r = total number of coefficients) |
//! |---|---|---|
//! | [`PolyModel::arx`], [`PolyModel::armax`], [`PolyModel::oe`], [`PolyModel::bj`], [`PolyModel::fir`] | SISO constructors | O(r) |
//! | [`PolyModel::new`] ([`Polynomials`]), [`PolyModel::from_orders`] | general MIMO model; the zero-parameter template of a structure | O(r) |
//! | [`PolyModel::parameters`], [`PolyModel::with_parameters`], [`PolyModel::with_covariance`], [`PolyModel::std`] | free parameters (order below) and their covariance | O(r), O(r²) |
//! | [`PolyModel::to_ss`], [`PolyModel::to_innovations_ss`] | G, and the innovations form (G, H, K), coupled observer form | O(n²) |
//! | [`PolyModel::to_tf`], [`PolyModel::noise_tf`] | G and H as [`crate::TransferFunction`]s in z | O(r²) (diagonal A) |
//! | [`PolyModel::from_tf`], [`PolyModel::from_ss`], [`PolyModel::from_ss_bj`] | OE from a transfer function; ARMAX-form or OE from state space; BJ from state space | O(r), O(n_y (n_y + n_u) n³) |
//! | [`PolyModel::simulate`] | y = G u + H e by difference equations | O(N r) |
//! | [`PolyModel::prediction_errors`], [`PolyModel::predict_one_step`], [`PolyModel::predict`] | ε(t), ŷ(t\|t−1) by filtering; ŷ(t\|t−k) by the Kalman predictor | O(N r); O(N k n (n + n_u)) |
//! | [`PolyModel::freqresp`], [`PolyModel::noise_freqresp`] | G(e^{jωT}), H(e^{jωT}) | O(len (n_y³ + r)) |
//! | [`PolyModel::is_stable`], [`PolyModel::noise_is_stable`], [`PolyModel::predictor_is_stable`] | roots of A and F; A and D; C and F | O(n³) |
//! | [`PolyModel::freqresp_std`] ([`FreqStd`], [`normal_quantile`]) | standard deviations of |G| and arg G from the parameter covariance (first-order propagation) | O(p · len(ω) · (n_y³ + r)) |
//! | [`PolyModel::present`] | the polynomials with each coefficient's standard deviation | O(r) |
//!
//! # Free parameters
//!
//! [`PolyModel::parameters`] lists every coefficient that is not fixed by
//! the structure (the leading 1 of A_ii, C, D, F and the leading 0 of
//! A_ij, i ≠ j, are fixed), output by output and, within output i, in
//! MATLAB's order a, b, c, d, f:
//!
//! ```text
//!   A_i1[1..], …, A_iny[1..], B_i1[..], …, B_inu[..], C_i[1..], D_i[1..], F_i1[1..], …, F_inu[1..]
//! ```
//!
//! For a single output this is MATLAB's `getpvec` order
//! `[a₁ … a_na, b₀ … b_{nb−1}, c₁ … c_nc, d₁ … d_nd, f₁ … f_nf]`. An
//! optional covariance of these parameters travels with the model
//! ([`PolyModel::covariance`], serde included).
//!
//! # Example
//!
//! ```
//! use lifted_lti::PolyModel;
//! use nalgebra::DMatrix;
//!
//! # fn main() -> Result<(), lifted_lti::Error> {
//! // ARMAX: (1 − 1.5q⁻¹ + 0.7q⁻²) y = q⁻¹(1 + 0.5q⁻¹) u + (1 − 0.2q⁻¹) e
//! let m = PolyModel::armax(&[1.0, -1.5, 0.7], &[1.0, 0.5], &[1.0, -0.2], 1, 1.0)?;
//! assert_eq!(m.parameters(), vec![-1.5, 0.7, 1.0, 0.5, -0.2]);
//! let u = DMatrix::from_fn(200, 1, |t, _| ((t * 7 % 11) as f64 - 5.0) / 5.0);
//! let e = DMatrix::from_fn(200, 1, |t, _| ((t * 5 % 13) as f64 - 6.0) / 60.0);
//! let y = m.simulate(&u, Some(&e))?;
//! // The polynomial predictor and the Kalman predictor of the
//! // innovations form agree; their errors are the noise e.
//! let direct = m.predict_one_step(&u, &y)?;
//! let kalman = m.predict(&u, &y, 1)?;
//! assert!((&direct - &kalman).abs().max() < 1e-10);
//! assert!((&y - &direct - &e).abs().max() < 1e-10);
//! // Back from the innovations state-space form: the same polynomials.
//! let (ss, k) = m.to_innovations_ss()?;
//! let back = PolyModel::from_ss(&ss, Some(&k))?;
//! assert_eq!(back.orders(), m.orders());
//! assert!(back.parameters().iter().zip(m.parameters()).all(|(a, b)| (a - b).abs() < 1e-9));
//! # Ok(())
//! # }
//! ```
//!
//! Long file: the polynomial model type is one serde type whose families
//! (ARX, ARMAX, OE, BJ, FIR), orders, checks and presentation are one
//! validation; conversion, prediction, simulation and uncertainty are in the
//! child modules.

mod convert;
mod predict;
mod repr;
mod simulate;
pub(crate) mod uncertainty;

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, check_ts};

pub use convert::POLY_TRIM_TOL;
pub use uncertainty::{FreqStd, normal_quantile, student_t_quantile};

/// A discrete-time polynomial model (MATLAB's `idpoly`; see the
/// [module docs](crate::polymodel) for the equation, the coefficient order and the
/// parameter order).
///
/// The fields are private so every model is valid: finite coefficients,
/// consistent shapes, monic diagonal of A and monic C, D, F, zero leading
/// coefficient off the diagonal of A, positive finite `ts`, a symmetric
/// finite noise covariance Λ with non-negative diagonal, and a parameter
/// covariance (if any) of the size of the parameter vector.
///
/// JSON (serde): `{"ts": T, "a": [[[1, -0.5]]], "b": [[[1, 0.5]]],
/// "c": [[1]], "d": [[1]], "f": [[[1]]], "nk": [[1]],
/// "noise_variance": [[1]], "covariance"?: [[…]], "input_names"?,
/// "output_names"?}`: `a` is n_y rows of n_y polynomials, `b`, `f`, `nk`
/// n_y rows of n_u, `c`, `d` one polynomial per output, each polynomial in
/// ascending powers of q⁻¹. On reading, `a`, `c`, `d`, `f` and
/// `noise_variance` may be left out (identity, ones, identity).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "repr::PolyRepr", into = "repr::PolyRepr")]
pub struct PolyModel {
    ny: usize,
    nu: usize,
    /// n_y × n_y, row-major.
    a: Vec<Vec<f64>>,
    /// n_y × n_u, row-major.
    b: Vec<Vec<f64>>,
    /// n_y.
    c: Vec<Vec<f64>>,
    /// n_y.
    d: Vec<Vec<f64>>,
    /// n_y × n_u, row-major.
    f: Vec<Vec<f64>>,
    /// n_y × n_u, row-major.
    nk: Vec<usize>,
    ts: f64,
    noise_variance: DMatrix<f64>,
    covariance: Option<DMatrix<f64>>,
    input_names: Option<Vec<String>>,
    output_names: Option<Vec<String>>,
}

/// The polynomials of a model, for [`PolyModel::new`]: nested vectors,
/// `x[i][j]` the entry of output i and input (or output, for A) j, each
/// polynomial in ascending powers of q⁻¹. `None` gives the trivial
/// polynomial (A = I, C = D = F = 1).
///
/// ```
/// use lifted_lti::{PolyFamily, PolyModel, Polynomials};
/// # fn main() -> Result<(), lifted_lti::Error> {
/// // Two outputs, one input, coupled ARX: A12 = 0.2 q⁻¹.
/// let p = Polynomials {
///     a: Some(vec![
///         vec![vec![1.0, -0.5], vec![0.0, 0.2]],
///         vec![vec![0.0], vec![1.0, -0.3]],
///     ]),
///     b: vec![vec![vec![1.0]], vec![vec![0.5, 0.25]]],
///     nk: vec![vec![1], vec![2]],
///     ..Default::default()
/// };
/// let m = PolyModel::new(p, 0.1)?;
/// assert_eq!(m.family(), PolyFamily::Arx);
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Polynomials {
    /// A, n_y × n_y (None: the identity). Diagonal monic, off-diagonal
    /// starting with 0.
    pub a: Option<Vec<Vec<Vec<f64>>>>,
    /// B, n_y × n_u, the first coefficient multiplying q^{−nk} (empty: zero).
    /// Its number of rows is the number of outputs.
    pub b: Vec<Vec<Vec<f64>>>,
    /// C, one monic polynomial per output (None: ones).
    pub c: Option<Vec<Vec<f64>>>,
    /// D, one monic polynomial per output (None: ones).
    pub d: Option<Vec<Vec<f64>>>,
    /// F, n_y × n_u, monic (None: ones).
    pub f: Option<Vec<Vec<Vec<f64>>>>,
    /// Input delays in samples, n_y × n_u.
    pub nk: Vec<Vec<usize>>,
}

/// The structure of a polynomial model, MATLAB's orders: `na[i][j]`,
/// `nc[i]`, `nd[i]`, `nf[i][k]` are degrees (numbers of free coefficients),
/// `nb[i][k]` the number of B coefficients, `nk[i][k]` the delays.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PolyOrders {
    /// Degrees of A, n_y × n_y.
    pub na: Vec<Vec<usize>>,
    /// Numbers of coefficients of B, n_y × n_u.
    pub nb: Vec<Vec<usize>>,
    /// Degrees of C, one per output.
    pub nc: Vec<usize>,
    /// Degrees of D, one per output.
    pub nd: Vec<usize>,
    /// Degrees of F, n_y × n_u.
    pub nf: Vec<Vec<usize>>,
    /// Delays in samples, n_y × n_u.
    pub nk: Vec<Vec<usize>>,
}

impl PolyOrders {
    /// The orders of a single-input single-output model
    /// (MATLAB's `[na nb nc nd nf nk]`).
    pub fn siso(na: usize, nb: usize, nc: usize, nd: usize, nf: usize, nk: usize) -> Self {
        Self {
            na: vec![vec![na]],
            nb: vec![vec![nb]],
            nc: vec![nc],
            nd: vec![nd],
            nf: vec![vec![nf]],
            nk: vec![vec![nk]],
        }
    }

    /// Number of free parameters: Σ na + Σ nb + Σ nc + Σ nd + Σ nf.
    pub fn n_parameters(&self) -> usize {
        let sum2 = |m: &Vec<Vec<usize>>| m.iter().flatten().sum::<usize>();
        sum2(&self.na)
            + sum2(&self.nb)
            + self.nc.iter().sum::<usize>()
            + self.nd.iter().sum::<usize>()
            + sum2(&self.nf)
    }

    /// The family of this structure (see [`PolyFamily`]).
    pub fn family(&self) -> PolyFamily {
        let any2 = |m: &Vec<Vec<usize>>| m.iter().flatten().any(|&n| n > 0);
        let has_a = any2(&self.na);
        let has_c = self.nc.iter().any(|&n| n > 0);
        let has_d = self.nd.iter().any(|&n| n > 0);
        let has_f = any2(&self.nf);
        match (has_a, has_c, has_d, has_f) {
            (false, false, false, false) => PolyFamily::Fir,
            (true, false, false, false) => PolyFamily::Arx,
            (true, true, false, false) => PolyFamily::Armax,
            (false, false, false, true) => PolyFamily::Oe,
            (false, _, _, _) => PolyFamily::Bj,
            _ => PolyFamily::General,
        }
    }
}

/// The family of a polynomial structure, from which polynomials have a
/// nonzero degree.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PolyFamily {
    /// A y = B u + e (`[na nb nk]`, na > 0).
    Arx,
    /// A y = B u + C e (`[na nb nc nk]`, na, nc > 0).
    Armax,
    /// y = B/F u + e (`[nb nf nk]`, nf > 0).
    Oe,
    /// y = B/F u + C/D e (`[nb nc nd nf nk]`, nc or nd > 0, no A).
    Bj,
    /// y = B u + e (`[nb nk]`: every other polynomial trivial).
    Fir,
    /// Any other combination (A together with D or F).
    General,
}

/// Leading coefficient required of polynomial `which` at (i, j).
fn check_poly(which: &'static str, i: usize, j: usize, p: &[f64], lead: Option<f64>) -> Result<()> {
    if let Some((index, &value)) = p.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(Error::NonFiniteCoefficient {
            which,
            row: i,
            col: j,
            index,
            value,
        });
    }
    if let Some(expected) = lead
        && p.first() != Some(&expected)
    {
        return Err(Error::NonMonicPolynomial {
            which,
            row: i,
            col: j,
            expected,
            got: p.first().copied(),
        });
    }
    Ok(())
}

/// `m` as `rows` rows of `cols` entries, or [`Error::DimensionMismatch`].
fn check_grid<T>(what: &'static str, m: &[Vec<T>], rows: usize, cols: usize) -> Result<()> {
    let bad = m.len() != rows || m.iter().any(|r| r.len() != cols);
    if bad {
        return Err(Error::DimensionMismatch {
            what,
            expected: format!("{rows} rows of {cols} entries"),
            got: format!(
                "{} rows of {:?} entries",
                m.len(),
                m.iter().map(Vec::len).collect::<Vec<_>>()
            ),
        });
    }
    Ok(())
}

fn check_len<T>(what: &'static str, v: &[T], n: usize) -> Result<()> {
    if v.len() != n {
        return Err(Error::DimensionMismatch {
            what,
            expected: format!("{n} entries (one per output)"),
            got: format!("{}", v.len()),
        });
    }
    Ok(())
}

/// A square symmetric finite matrix with a non-negative diagonal
/// (symmetric within 1e-8 of its largest entry), symmetrised.
fn check_covariance(what: &'static str, m: &DMatrix<f64>, n: usize) -> Result<DMatrix<f64>> {
    if m.shape() != (n, n) {
        return Err(Error::DimensionMismatch {
            what,
            expected: format!("{n}x{n}"),
            got: format!("{}x{}", m.nrows(), m.ncols()),
        });
    }
    if let Some(&value) = m.iter().find(|v| !v.is_finite()) {
        return Err(Error::NonFiniteScalar { what, value });
    }
    let scale = m.amax();
    if (m - m.transpose()).amax() > 1e-8 * scale {
        return Err(Error::InvalidArgument {
            what,
            reason: "not symmetric".into(),
        });
    }
    if let Some(i) = (0..n).find(|&i| m[(i, i)] < 0.0) {
        return Err(Error::InvalidArgument {
            what,
            reason: format!("negative variance {} at ({i}, {i})", m[(i, i)]),
        });
    }
    Ok((m + m.transpose()) * 0.5)
}

impl PolyModel {
    /// Validates and builds a model from its polynomials (see
    /// [`Polynomials`]) with sample period `ts` seconds; Λ = I, no
    /// parameter covariance. O(r).
    ///
    /// Errors: [`Error::DimensionMismatch`] for inconsistent shapes (B with
    /// no rows, rows of B, nk, A, F of the wrong length, C or D not one per
    /// output), [`Error::NonFiniteCoefficient`],
    /// [`Error::NonMonicPolynomial`] (leading coefficient of A_ii, C, D, F
    /// not exactly 1, of A_ij, i ≠ j, not exactly 0, or an empty one of
    /// those), [`Error::InvalidSamplePeriod`].
    pub fn new(p: Polynomials, ts: f64) -> Result<Self> {
        check_ts(Some(ts))?;
        let ny = p.b.len();
        if ny == 0 {
            return Err(Error::DimensionMismatch {
                what: "B",
                expected: "at least one output (row)".into(),
                got: "no rows".into(),
            });
        }
        let nu = p.b[0].len();
        check_grid("B", &p.b, ny, nu)?;
        check_grid("nk", &p.nk, ny, nu)?;
        let a = match p.a {
            Some(a) => {
                check_grid("A", &a, ny, ny)?;
                a
            }
            None => (0..ny)
                .map(|i| {
                    (0..ny)
                        .map(|j| vec![if i == j { 1.0 } else { 0.0 }])
                        .collect()
                })
                .collect(),
        };
        let f = match p.f {
            Some(f) => {
                check_grid("F", &f, ny, nu)?;
                f
            }
            None => vec![vec![vec![1.0]; nu]; ny],
        };
        let c = p.c.unwrap_or_else(|| vec![vec![1.0]; ny]);
        let d = p.d.unwrap_or_else(|| vec![vec![1.0]; ny]);
        check_len("C", &c, ny)?;
        check_len("D", &d, ny)?;
        for (i, row) in a.iter().enumerate() {
            for (j, aij) in row.iter().enumerate() {
                let lead = if i == j { 1.0 } else { 0.0 };
                check_poly("A", i, j, aij, Some(lead))?;
            }
        }
        for (i, (brow, frow)) in p.b.iter().zip(&f).enumerate() {
            for (k, (bik, fik)) in brow.iter().zip(frow).enumerate() {
                check_poly("B", i, k, bik, None)?;
                check_poly("F", i, k, fik, Some(1.0))?;
            }
        }
        for (i, (ci, di)) in c.iter().zip(&d).enumerate() {
            check_poly("C", i, 0, ci, Some(1.0))?;
            check_poly("D", i, 0, di, Some(1.0))?;
        }
        Ok(Self {
            ny,
            nu,
            a: a.into_iter().flatten().collect(),
            b: p.b.into_iter().flatten().collect(),
            c,
            d,
            f: f.into_iter().flatten().collect(),
            nk: p.nk.into_iter().flatten().collect(),
            ts,
            noise_variance: DMatrix::identity(ny, ny),
            covariance: None,
            input_names: None,
            output_names: None,
        })
    }

    /// The model of structure `orders` with every free parameter zero
    /// (A = I, B = 0, C = D = F = 1 with the given degrees): the template an
    /// estimator fills with [`PolyModel::with_parameters`]. O(r).
    ///
    /// Errors: inconsistent shapes ([`Error::DimensionMismatch`]), invalid
    /// `ts`.
    pub fn from_orders(orders: &PolyOrders, ts: f64) -> Result<Self> {
        let ny = orders.nb.len();
        let nu = orders.nb.first().map_or(0, Vec::len);
        check_grid("na", &orders.na, ny, ny)?;
        check_grid("nf", &orders.nf, ny, nu)?;
        check_len("nc", &orders.nc, ny)?;
        check_len("nd", &orders.nd, ny)?;
        let monic = |n: usize, lead: f64| {
            let mut v = vec![0.0; n + 1];
            v[0] = lead;
            v
        };
        let p = Polynomials {
            a: Some(
                (0..ny)
                    .map(|i| {
                        (0..ny)
                            .map(|j| monic(orders.na[i][j], if i == j { 1.0 } else { 0.0 }))
                            .collect()
                    })
                    .collect(),
            ),
            b: orders
                .nb
                .iter()
                .map(|r| r.iter().map(|&n| vec![0.0; n]).collect())
                .collect(),
            c: Some(orders.nc.iter().map(|&n| monic(n, 1.0)).collect()),
            d: Some(orders.nd.iter().map(|&n| monic(n, 1.0)).collect()),
            f: Some(
                orders
                    .nf
                    .iter()
                    .map(|r| r.iter().map(|&n| monic(n, 1.0)).collect())
                    .collect(),
            ),
            nk: orders.nk.clone(),
        };
        Self::new(p, ts)
    }

    fn siso(
        a: &[f64],
        b: &[f64],
        c: &[f64],
        d: &[f64],
        f: &[f64],
        nk: usize,
        ts: f64,
    ) -> Result<Self> {
        Self::new(
            Polynomials {
                a: Some(vec![vec![a.to_vec()]]),
                b: vec![vec![b.to_vec()]],
                c: Some(vec![c.to_vec()]),
                d: Some(vec![d.to_vec()]),
                f: Some(vec![vec![f.to_vec()]]),
                nk: vec![vec![nk]],
            },
            ts,
        )
    }

    /// SISO ARX: A(q) y(t) = B(q) u(t − nk) + e(t); `a` monic
    /// (`[1, a₁, …, a_na]`), `b = [b₀, …, b_{nb−1}]`.
    ///
    /// Errors: those of [`PolyModel::new`].
    pub fn arx(a: &[f64], b: &[f64], nk: usize, ts: f64) -> Result<Self> {
        Self::siso(a, b, &[1.0], &[1.0], &[1.0], nk, ts)
    }

    /// SISO ARMAX: A(q) y(t) = B(q) u(t − nk) + C(q) e(t); `a`, `c` monic.
    ///
    /// Errors: those of [`PolyModel::new`].
    pub fn armax(a: &[f64], b: &[f64], c: &[f64], nk: usize, ts: f64) -> Result<Self> {
        Self::siso(a, b, c, &[1.0], &[1.0], nk, ts)
    }

    /// SISO output error: y(t) = B(q)/F(q) u(t − nk) + e(t); `f` monic.
    ///
    /// Errors: those of [`PolyModel::new`].
    pub fn oe(b: &[f64], f: &[f64], nk: usize, ts: f64) -> Result<Self> {
        Self::siso(&[1.0], b, &[1.0], &[1.0], f, nk, ts)
    }

    /// SISO Box–Jenkins: y(t) = B(q)/F(q) u(t − nk) + C(q)/D(q) e(t);
    /// `c`, `d`, `f` monic.
    ///
    /// Errors: those of [`PolyModel::new`].
    pub fn bj(b: &[f64], c: &[f64], d: &[f64], f: &[f64], nk: usize, ts: f64) -> Result<Self> {
        Self::siso(&[1.0], b, c, d, f, nk, ts)
    }

    /// SISO finite impulse response: y(t) = B(q) u(t − nk) + e(t).
    ///
    /// Errors: those of [`PolyModel::new`].
    pub fn fir(b: &[f64], nk: usize, ts: f64) -> Result<Self> {
        Self::siso(&[1.0], b, &[1.0], &[1.0], &[1.0], nk, ts)
    }

    /// Sets the noise covariance Λ (n_y × n_y, symmetric within 1e-8 of its
    /// largest entry, then symmetrised; non-negative diagonal).
    ///
    /// Errors: [`Error::DimensionMismatch`], [`Error::NonFiniteScalar`],
    /// [`Error::InvalidArgument`] (not symmetric, negative variance).
    pub fn with_noise_variance(mut self, lambda: &DMatrix<f64>) -> Result<Self> {
        self.noise_variance = check_covariance("noise variance", lambda, self.ny)?;
        Ok(self)
    }

    /// Attaches the covariance of [`PolyModel::parameters`]
    /// (n_par × n_par, checked as in [`PolyModel::with_noise_variance`]).
    ///
    /// Errors: those of [`PolyModel::with_noise_variance`].
    pub fn with_covariance(mut self, cov: &DMatrix<f64>) -> Result<Self> {
        let n = self.n_parameters();
        self.covariance = Some(check_covariance("parameter covariance", cov, n)?);
        Ok(self)
    }

    /// Removes the parameter covariance.
    pub fn without_covariance(mut self) -> Self {
        self.covariance = None;
        self
    }

    /// Attaches input names (one per input).
    ///
    /// Errors: [`Error::DimensionMismatch`].
    pub fn with_input_names(mut self, names: Vec<String>) -> Result<Self> {
        if names.len() != self.nu {
            return Err(Error::DimensionMismatch {
                what: "input names",
                expected: format!("{} names", self.nu),
                got: format!("{} names", names.len()),
            });
        }
        self.input_names = Some(names);
        Ok(self)
    }

    /// Attaches output names (one per output).
    ///
    /// Errors: [`Error::DimensionMismatch`].
    pub fn with_output_names(mut self, names: Vec<String>) -> Result<Self> {
        if names.len() != self.ny {
            return Err(Error::DimensionMismatch {
                what: "output names",
                expected: format!("{} names", self.ny),
                got: format!("{} names", names.len()),
            });
        }
        self.output_names = Some(names);
        Ok(self)
    }

    /// Number of outputs n_y.
    pub fn n_outputs(&self) -> usize {
        self.ny
    }
    /// Number of inputs n_u.
    pub fn n_inputs(&self) -> usize {
        self.nu
    }
    /// Sample period in seconds.
    pub fn ts(&self) -> f64 {
        self.ts
    }
    /// A_ij, ascending powers of q⁻¹. Panics if out of range (like slice
    /// indexing).
    #[track_caller]
    pub fn a(&self, i: usize, j: usize) -> &[f64] {
        assert!(i < self.ny && j < self.ny, "A index out of range");
        &self.a[i * self.ny + j]
    }
    /// B_ik: the coefficients of q^{−nk}, q^{−nk−1}, …. Panics if out of range.
    #[track_caller]
    pub fn b(&self, i: usize, k: usize) -> &[f64] {
        assert!(i < self.ny && k < self.nu, "B index out of range");
        &self.b[i * self.nu + k]
    }
    /// C_i, ascending powers of q⁻¹. Panics if out of range.
    #[track_caller]
    pub fn c(&self, i: usize) -> &[f64] {
        &self.c[i]
    }
    /// D_i, ascending powers of q⁻¹. Panics if out of range.
    #[track_caller]
    pub fn d(&self, i: usize) -> &[f64] {
        &self.d[i]
    }
    /// F_ik, ascending powers of q⁻¹. Panics if out of range.
    #[track_caller]
    pub fn f(&self, i: usize, k: usize) -> &[f64] {
        assert!(i < self.ny && k < self.nu, "F index out of range");
        &self.f[i * self.nu + k]
    }
    /// Input delay nk_ik in samples. Panics if out of range.
    #[track_caller]
    pub fn nk(&self, i: usize, k: usize) -> usize {
        assert!(i < self.ny && k < self.nu, "nk index out of range");
        self.nk[i * self.nu + k]
    }
    /// Noise covariance Λ (n_y × n_y; the identity unless set).
    pub fn noise_variance(&self) -> &DMatrix<f64> {
        &self.noise_variance
    }
    /// Covariance of [`PolyModel::parameters`], if attached.
    pub fn covariance(&self) -> Option<&DMatrix<f64>> {
        self.covariance.as_ref()
    }
    /// Standard deviations of the parameters (square roots of the
    /// covariance diagonal), if a covariance is attached. O(n_par).
    pub fn std(&self) -> Option<Vec<f64>> {
        self.covariance
            .as_ref()
            .map(|c| c.diagonal().iter().map(|v| v.sqrt()).collect())
    }
    /// Input names, if set.
    pub fn input_names(&self) -> Option<&[String]> {
        self.input_names.as_deref()
    }
    /// Output names, if set.
    pub fn output_names(&self) -> Option<&[String]> {
        self.output_names.as_deref()
    }
    /// True when every off-diagonal entry of A is zero (always for one output).
    pub fn has_diagonal_a(&self) -> bool {
        (0..self.ny).all(|i| (0..self.ny).all(|j| i == j || self.a(i, j).iter().all(|&v| v == 0.0)))
    }

    /// The orders (MATLAB's `na nb nc nd nf nk`). O(n_y (n_y + n_u)).
    pub fn orders(&self) -> PolyOrders {
        let grid = |v: &[Vec<f64>], cols: usize, off: usize| -> Vec<Vec<usize>> {
            v.chunks(cols.max(1))
                .take(self.ny)
                .map(|r| r.iter().map(|p| p.len() - off).collect())
                .collect()
        };
        let na = grid(&self.a, self.ny, 1);
        let (nb, nf, nk) = if self.nu == 0 {
            (
                vec![vec![]; self.ny],
                vec![vec![]; self.ny],
                vec![vec![]; self.ny],
            )
        } else {
            (
                grid(&self.b, self.nu, 0),
                grid(&self.f, self.nu, 1),
                self.nk.chunks(self.nu).map(<[usize]>::to_vec).collect(),
            )
        };
        PolyOrders {
            na,
            nb,
            nc: self.c.iter().map(|p| p.len() - 1).collect(),
            nd: self.d.iter().map(|p| p.len() - 1).collect(),
            nf,
            nk,
        }
    }

    /// The family of the model's structure ([`PolyOrders::family`]).
    pub fn family(&self) -> PolyFamily {
        self.orders().family()
    }

    /// The polynomials as nested vectors (the inverse of [`PolyModel::new`]).
    pub fn polynomials(&self) -> Polynomials {
        let rows = |v: &[Vec<f64>], cols: usize| -> Vec<Vec<Vec<f64>>> {
            (0..self.ny)
                .map(|i| v[i * cols..(i + 1) * cols].to_vec())
                .collect()
        };
        Polynomials {
            a: Some(rows(&self.a, self.ny)),
            b: rows(&self.b, self.nu),
            c: Some(self.c.clone()),
            d: Some(self.d.clone()),
            f: Some(rows(&self.f, self.nu)),
            nk: (0..self.ny)
                .map(|i| self.nk[i * self.nu..(i + 1) * self.nu].to_vec())
                .collect(),
        }
    }

    /// The free coefficients, in the order of the module docs:
    /// blocks of (polynomial, number of fixed leading coefficients).
    fn free_blocks(&self) -> Vec<(&[f64], usize)> {
        let mut out = Vec::new();
        for i in 0..self.ny {
            out.extend((0..self.ny).map(|j| (self.a(i, j), 1)));
            out.extend((0..self.nu).map(|k| (self.b(i, k), 0)));
            out.push((&self.c[i][..], 1));
            out.push((&self.d[i][..], 1));
            out.extend((0..self.nu).map(|k| (self.f(i, k), 1)));
        }
        out
    }

    /// Number of free parameters (the length of [`PolyModel::parameters`]).
    pub fn n_parameters(&self) -> usize {
        self.free_blocks().iter().map(|(p, s)| p.len() - s).sum()
    }

    /// The free parameters in the documented order ([module docs](crate::polymodel#free-parameters): per
    /// output, a, b, c, d, f). O(r).
    pub fn parameters(&self) -> Vec<f64> {
        self.free_blocks()
            .into_iter()
            .flat_map(|(p, s)| p[s..].iter().copied())
            .collect()
    }

    /// The same structure with the free parameters `theta` (the order of
    /// [`PolyModel::parameters`]). The parameter covariance is dropped (it
    /// belonged to the old values); Λ, names and `ts` are kept. O(r).
    ///
    /// Errors: [`Error::ParameterCount`] for a wrong length,
    /// [`Error::NonFiniteCoefficient`] for a NaN/infinite entry.
    pub fn with_parameters(&self, theta: &[f64]) -> Result<Self> {
        let n = self.n_parameters();
        if theta.len() != n {
            return Err(Error::ParameterCount {
                expected: n,
                got: theta.len(),
            });
        }
        let mut out = self.clone();
        out.covariance = None;
        let (ny, nu) = (self.ny, self.nu);
        let mut rest = theta;
        let mut fill = |which: &'static str, i: usize, j: usize, p: &mut Vec<f64>, skip: usize| {
            let m = p.len() - skip;
            let (head, tail) = rest.split_at(m);
            p[skip..].copy_from_slice(head);
            rest = tail;
            check_poly(which, i, j, p, None)
        };
        for i in 0..ny {
            for j in 0..ny {
                fill("A", i, j, &mut out.a[i * ny + j], 1)?;
            }
            for k in 0..nu {
                fill("B", i, k, &mut out.b[i * nu + k], 0)?;
            }
            fill("C", i, 0, &mut out.c[i], 1)?;
            fill("D", i, 0, &mut out.d[i], 1)?;
            for k in 0..nu {
                fill("F", i, k, &mut out.f[i * nu + k], 1)?;
            }
        }
        Ok(out)
    }
}

/// `1 - 1.5 q^-1 + 0.7 q^-2` (ascending powers, up to 6 decimals; the
/// zero polynomial for an empty slice).
/// `p` in powers of q⁻¹; the coefficients from `fixed` on followed by
/// "(±σ)" when their standard deviations `std` are given.
fn display_q(p: &[f64], std: Option<&[f64]>, fixed: usize) -> String {
    let mut out = String::new();
    for (l, &c) in p.iter().enumerate() {
        let sd = std.and_then(|s| l.checked_sub(fixed).and_then(|i| s.get(i)));
        if c == 0.0 && sd.is_none() && !(out.is_empty() && l + 1 == p.len()) {
            continue;
        }
        let mag = format!("{:.6}", c.abs());
        let mut mag = mag.trim_end_matches('0').trim_end_matches('.').to_string();
        if let Some(sd) = sd {
            mag = format!("{mag} (±{})", significant(*sd));
        }
        let term = match l {
            0 => mag,
            1 => format!("{mag} q^-1"),
            _ => format!("{mag} q^-{l}"),
        };
        if out.is_empty() {
            out = if c < 0.0 { format!("-{term}") } else { term };
        } else {
            out.push_str(if c < 0.0 { " - " } else { " + " });
            out.push_str(&term);
        }
    }
    if out.is_empty() { "0".into() } else { out }
}

/// A standard deviation to two significant digits.
fn significant(v: f64) -> String {
    if !(v.is_finite() && v > 0.0) {
        return format!("{v}");
    }
    let digits = (1 - v.log10().floor() as i32).max(0) as usize;
    format!("{v:.digits$}")
}

impl PolyModel {
    /// The model as [`Display`](std::fmt::Display) writes it, each free
    /// coefficient followed by its standard deviation "(±σ)" when the model
    /// carries a parameter covariance (MATLAB's `present`). O(r).
    pub fn present(&self) -> String {
        self.render(self.std().as_deref())
    }

    fn render(&self, std: Option<&[f64]>) -> String {
        use std::fmt::Write;
        let family = match self.family() {
            PolyFamily::Arx => "ARX",
            PolyFamily::Armax => "ARMAX",
            PolyFamily::Oe => "OE",
            PolyFamily::Bj => "BJ",
            PolyFamily::Fir => "FIR",
            PolyFamily::General => "general",
        };
        let mut f = format!(
            "discrete-time polynomial model ({family}, T = {}), {} output(s), {} input(s)",
            self.ts, self.ny, self.nu
        );
        let mimo = self.ny > 1 || self.nu > 1;
        let idx2 = |i: usize, j: usize| {
            if mimo {
                format!("{}{}", i + 1, j + 1)
            } else {
                String::new()
            }
        };
        let idx1 = |i: usize| {
            if self.ny > 1 {
                format!("{}", i + 1)
            } else {
                String::new()
            }
        };
        let trivial = |p: &[f64], one: f64| p.len() == 1 && p[0] == one;
        // The standard deviations of the next polynomial's free
        // coefficients (parameters() order).
        let mut at = 0usize;
        let mut take = |free: usize| {
            let s = std.map(|s| &s[at.min(s.len())..(at + free).min(s.len())]);
            at += free;
            s
        };
        for i in 0..self.ny {
            for j in 0..self.ny {
                let a = self.a(i, j);
                let sd = take(a.len() - 1);
                if !trivial(a, if i == j { 1.0 } else { 0.0 }) {
                    let _ = write!(f, "\nA{}(q) = {}", idx2(i, j), display_q(a, sd, 1));
                }
            }
            for k in 0..self.nu {
                let delay = match self.nk(i, k) {
                    0 => String::new(),
                    1 => "q^-1 ".into(),
                    n => format!("q^-{n} "),
                };
                let b = self.b(i, k);
                let sd = take(b.len());
                if b.len() > 1 {
                    let _ = write!(f, "\nB{}(q) = {delay}({})", idx2(i, k), display_q(b, sd, 0));
                } else {
                    let _ = write!(f, "\nB{}(q) = {delay}{}", idx2(i, k), display_q(b, sd, 0));
                }
            }
            for (name, p) in [("C", &self.c[i]), ("D", &self.d[i])] {
                let sd = take(p.len() - 1);
                if !trivial(p, 1.0) {
                    let _ = write!(f, "\n{name}{}(q) = {}", idx1(i), display_q(p, sd, 1));
                }
            }
            for k in 0..self.nu {
                let p = self.f(i, k);
                let sd = take(p.len() - 1);
                if !trivial(p, 1.0) {
                    let _ = write!(f, "\nF{}(q) = {}", idx2(i, k), display_q(p, sd, 1));
                }
            }
        }
        f
    }
}

impl std::fmt::Display for PolyModel {
    /// The family, `ts` and every non-trivial polynomial, one a line:
    /// `A(q) = 1 - 1.5 q^-1`, `B(q) = q^-1 (1 + 0.5 q^-1)`, with indices
    /// (`A12`, `B21`, `C2`) when there are several channels
    /// ([`PolyModel::present`] adds the standard deviations).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.render(None))
    }
}

/// Coefficients of the product of two polynomials (any common variable). O(len a · len b).
pub(crate) fn conv(a: &[f64], b: &[f64]) -> Vec<f64> {
    if a.is_empty() || b.is_empty() {
        return Vec::new();
    }
    let mut c = vec![0.0; a.len() + b.len() - 1];
    for (i, &x) in a.iter().enumerate() {
        for (j, &y) in b.iter().enumerate() {
            c[i + j] += x * y;
        }
    }
    c
}

#[cfg(test)]
pub(crate) mod tests;

/// Seeded sweep over random stable structures of every family: the
/// identities of the module hold beyond the hand-picked models.
#[cfg(test)]
#[path = "sweep_tests.rs"]
mod sweep;

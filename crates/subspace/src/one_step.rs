//! The one-step predictor of a model in innovations form with a gain K,
//! run over a record in flat loops (the Kalman-gain check's cost and its
//! Levenberg–Marquardt iterations, [`crate::gain_check`]):
//!
//! ε(t) = y(t) − C x̂(t) − D u(t),  x̂(t+1) = A x̂(t) + B u(t) + K ε(t),
//!
//! an output not measured at t (NaN) giving no error and no correction,
//! and with it, when asked, the sensitivities of the errors to vec K:
//! S(t+1) = (A − K C) S(t) + E(ε(t)), ∂ε(t)/∂vec K = −C S(t), where E(ε)
//! puts ε_o(t) at state i of column o·n + i (at an instant where output o
//! is not measured, its row of C and column of K take no part: the
//! iteration matrix is A − Σ K_o C_o over the measured outputs).
//!
//! The matrices are kept as column-major slices and every product is a
//! loop over columns (the sums in the order of nalgebra's `gemv`, the
//! first column's product first): the same numbers as the nalgebra
//! products of before for orders up to 5, without the per-call overhead
//! of dynamic-size products, which dominated at 2 × 4 × 8 per sample.
//! O(n (n + n_u + n_y)) per sample for the errors, O(n² P + n_y n P) more
//! with the sensitivities (P = n n_y parameters), O(n² + n n_y) for the
//! gradient of the weighted squared errors by the adjoint recursion
//! backwards over a run's errors ([`OneStep::add_adjoint_gradient`]), when
//! the gradient alone is wanted.

use lifted_lti::StateSpace;
use nalgebra::{DMatrix, DVector};

/// Runs `$call` with `$f` bound to the padded fixed-size kernel of
/// `$p`'s order (sizes 1, 2, 4, 8, 16: an order pads up to the next), or
/// `$general` above 16: the one dispatch of every run of this module,
/// compiled for AVX2/FMA where the CPU has them (`lifted_linalg::simd`; the
/// kernels' methods are inlined into it).
macro_rules! by_padded_order {
    ($p:expr, $f:ident => $call:expr, _ => $general:expr) => {
        lifted_linalg::simd::dispatch(
            #[inline(always)]
            || match $p.n {
                1 => {
                    let $f = Fixed::<1>::new($p);
                    $call
                }
                2 => {
                    let $f = Fixed::<2>::new($p);
                    $call
                }
                3 | 4 => {
                    let $f = Fixed::<4>::new($p);
                    $call
                }
                5..=8 => {
                    let $f = Fixed::<8>::new($p);
                    $call
                }
                9..=16 => {
                    let $f = Fixed::<16>::new($p);
                    $call
                }
                _ => $general,
            },
        )
    };
}

/// `out = M x` for a column-major `rows × x.len()` matrix `m`: the first
/// column's product, then each further column's added in turn (nalgebra's
/// `gemv` order); zero when `x` is empty.
#[inline(always)]
fn matvec(out: &mut [f64], m: &[f64], x: &[f64]) {
    let rows = out.len();
    let Some((&x0, rest)) = x.split_first() else {
        out.fill(0.0);
        return;
    };
    for (o, v) in out.iter_mut().zip(&m[..rows]) {
        *o = v * x0;
    }
    for (j, &xj) in rest.iter().enumerate() {
        let col = &m[(j + 1) * rows..(j + 2) * rows];
        for (o, v) in out.iter_mut().zip(col) {
            *o += v * xj;
        }
    }
}

/// (A, B, C, D), a gain K and A − K C as column-major slices.
pub(crate) struct OneStep {
    n: usize,
    nu: usize,
    ny: usize,
    a: Vec<f64>,
    b: Vec<f64>,
    c: Vec<f64>,
    d: Vec<f64>,
    k: Vec<f64>,
    m: Vec<f64>,
}

/// How [`OneStep::sensitivities_by`] computes the rows C S(t) of the
/// sensitivities.
///
/// * `States`: the n × P states S(t+1) = (A − K C) S(t) + E(ε(t)), then
///   C S(t); O(n² P + n_y n P) per sample, P = n n_y. Any record (at an
///   instant where an output is not measured the iteration matrix
///   changes, module docs).
/// * `Rows`: the rows themselves. With every output measured, the columns
///   of S for K's column o are Z_o(t) e_i, Z_o(t+1) = M Z_o(t) + ε_o(t) I
///   (M = A − K C, Z_o(0) = 0), so Z_o(t) = Σ_{j<t} ε_o(j) M^{t−1−j} is a
///   polynomial in M and commutes with it: row r of C Z_o(t),
///   w_{o,r}(t)ᵀ = c_rᵀ Z_o(t), follows
///   w_{o,r}(t+1) = Mᵀ w_{o,r}(t) + ε_o(t) c_r,
///   n_y² recursions of n states, O(n² n_y²) per sample: n/n_y times less
///   than `States` and no product by C. The same rows in exact
///   arithmetic; in floating point they differ by rounding (the sums are
///   taken in another order), checked to 1e-12 in the tests, and the
///   Kalman-gain check's gain with them to 1e-10 (`gain_check` tests).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Sensitivities {
    /// The states S(t), then C S(t).
    States,
    /// The rows' own recursion (every output measured).
    Rows,
}

/// Per-sample work buffers of [`OneStep`]'s runs.
struct Buffers {
    ut: Vec<f64>,
    cx: Vec<f64>,
    du: Vec<f64>,
    eps: Vec<f64>,
    ax: Vec<f64>,
    bu: Vec<f64>,
    ke: Vec<f64>,
}

impl Buffers {
    fn new(n: usize, nu: usize, ny: usize) -> Self {
        Buffers {
            ut: vec![0.0; nu],
            cx: vec![0.0; ny],
            du: vec![0.0; ny],
            eps: vec![0.0; ny],
            ax: vec![0.0; n],
            bu: vec![0.0; n],
            ke: vec![0.0; n],
        }
    }
}

impl OneStep {
    /// The predictor of `model` with gain `k` (n × n_y) and its A − K C.
    pub(crate) fn new(model: &StateSpace, k: &DMatrix<f64>, m: &DMatrix<f64>) -> Self {
        OneStep {
            n: model.order(),
            nu: model.n_inputs(),
            ny: model.n_outputs(),
            a: model.a().as_slice().to_vec(),
            b: model.b().as_slice().to_vec(),
            c: model.c().as_slice().to_vec(),
            d: model.d().as_slice().to_vec(),
            k: k.as_slice().to_vec(),
            m: m.as_slice().to_vec(),
        }
    }

    /// The errors ε(t) of sample `t`, in `buf.eps` (0 where y is NaN), and
    /// the state advanced to x̂(t+1) in `x`.
    #[inline(always)]
    fn step(&self, u: &DMatrix<f64>, y: &DMatrix<f64>, t: usize, x: &mut [f64], buf: &mut Buffers) {
        for (j, v) in buf.ut.iter_mut().enumerate() {
            *v = u[(t, j)];
        }
        matvec(&mut buf.cx, &self.c, x);
        matvec(&mut buf.du, &self.d, &buf.ut);
        for o in 0..self.ny {
            let yo = y[(t, o)];
            buf.eps[o] = if yo.is_nan() {
                0.0
            } else {
                yo - buf.cx[o] - buf.du[o]
            };
        }
        matvec(&mut buf.ax, &self.a, x);
        matvec(&mut buf.bu, &self.b, &buf.ut);
        matvec(&mut buf.ke, &self.k, &buf.eps);
        for (i, xi) in x.iter_mut().enumerate() {
            *xi = buf.ax[i] + buf.bu[i] + buf.ke[i];
        }
    }

    /// Per output, the sum of the squared one-step errors over the record
    /// (u, y) from x̂(0) = `x0`, added to `err`. O(N n (n + n_u + n_y)).
    pub(crate) fn add_squared_errors(
        &self,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        x0: &DVector<f64>,
        err: &mut [f64],
    ) {
        self.with_errors(u, y, x0, |eps| {
            for (e, v) in err.iter_mut().zip(eps) {
                *e += v * v;
            }
        });
    }

    /// Runs the predictor over the record (u, y) from `x0`, calling
    /// `visit(ε(t))` for every sample (0 where an output is not measured).
    /// O(N n (n + n_u + n_y)).
    pub(crate) fn with_errors(
        &self,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        x0: &DVector<f64>,
        visit: impl FnMut(&[f64]),
    ) {
        by_padded_order!(self, f => f.errors(u, y, x0, visit), _ => {
            self.errors_any_order(u, y, x0, visit)
        })
    }

    /// [`OneStep::add_squared_errors`]'s run for any order: `visit(ε(t))`
    /// for every sample.
    fn errors_any_order(
        &self,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        x0: &DVector<f64>,
        mut visit: impl FnMut(&[f64]),
    ) {
        let mut buf = Buffers::new(self.n, self.nu, self.ny);
        let mut x = x0.as_slice().to_vec();
        for t in 0..u.nrows() {
            self.step(u, y, t, &mut x, &mut buf);
            visit(&buf.eps);
        }
    }

    /// Adds to `grad` (P = n n_y entries, vec K column-major) the gradient
    /// Jᵀ r of the weighted one-step errors r_o(t) = w_o ε_o(t) of a run
    /// (J = ∂r/∂vec K; `w2`: the weights squared), by the adjoint
    /// (reverse-mode) recursion backwards over the run's errors `eps`
    /// (row-major, n_y a sample, 0 where an output is not measured, as
    /// [`OneStep::with_errors`] gives them; `y`: the record, for its
    /// pattern of measured samples):
    /// a(t) = M_tᵀ a(t+1) − C_tᵀ W² ε(t), a(N) = 0, and
    /// ∂(½ ‖r‖²)/∂K_io = Σ_t a_i(t+1) ε_o(t),
    /// where M_t = A − K_t C_t is the predictor's matrix at t (outputs not
    /// measured at t take no part in it: their rows of C and columns of K
    /// are left out, as [`OneStep::with_errors`] does). The same gradient
    /// as the forward sensitivities' Σ_t (C S(t))ᵀ W² ε(t) in exact
    /// arithmetic (checked to 1e-10 in the tests). O(N (n² + n n_y)), one
    /// n-state recursion instead of the forward route's n_y² (rows) or
    /// n n_y (states).
    pub(crate) fn add_adjoint_gradient(
        &self,
        y: &DMatrix<f64>,
        eps: &[f64],
        w2: &[f64],
        grad: &mut [f64],
    ) {
        by_padded_order!(self, f => f.adjoint(y, eps, w2, grad), _ => {
            self.adjoint_any_order(y, eps, w2, grad)
        })
    }

    /// [`OneStep::add_adjoint_gradient`] for any order.
    fn adjoint_any_order(&self, y: &DMatrix<f64>, eps: &[f64], w2: &[f64], grad: &mut [f64]) {
        let (n, ny) = (self.n, self.ny);
        let mut a = vec![0.0; n];
        let mut next = vec![0.0; n];
        for t in (0..eps.len() / ny).rev() {
            let e = &eps[t * ny..(t + 1) * ny];
            for (o, eo) in e.iter().enumerate() {
                for (g, ai) in grad[o * n..(o + 1) * n].iter_mut().zip(&a) {
                    *g += ai * eo;
                }
            }
            for (j, v) in next.iter_mut().enumerate() {
                *v = self.m[j * n..(j + 1) * n]
                    .iter()
                    .zip(&a)
                    .map(|(m, ai)| m * ai)
                    .sum();
            }
            for (o, eo) in e.iter().enumerate() {
                let s = if y[(t, o)].is_nan() {
                    // M_t = M + K_o C_o: output o's correction taken back.
                    -self.k[o * n..(o + 1) * n]
                        .iter()
                        .zip(&a)
                        .map(|(k, ai)| k * ai)
                        .sum::<f64>()
                } else {
                    w2[o] * eo
                };
                for (j, v) in next.iter_mut().enumerate() {
                    *v -= self.c[o + j * ny] * s;
                }
            }
            std::mem::swap(&mut a, &mut next);
        }
    }

    /// Runs the predictor over the record (u, y) from `x0` with the
    /// sensitivities (module docs), calling `row(o, grad, eps)` for every
    /// measured output sample with ∂ε_o(t)/∂vec K's negative,
    /// (C S(t)) row o (P = n n_y entries), and ε_o(t), by `route`
    /// ([`Sensitivities`]; the rows' recursion only on a record with every
    /// output measured, and up to order 16: the states' otherwise).
    /// O(N n² n_y²) by the rows, O(N (n² P + n_y n P)) by the states.
    pub(crate) fn with_sensitivities(
        &self,
        route: Sensitivities,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        x0: &DVector<f64>,
        row: impl FnMut(usize, &[f64], f64),
    ) {
        let route = match route {
            Sensitivities::Rows if y.iter().any(|v| v.is_nan()) => Sensitivities::States,
            r => r,
        };
        match route {
            Sensitivities::Rows => by_padded_order!(
                self,
                f => f.row_sensitivities(u, y, x0, row),
                _ => self.any_order(u, y, x0, row)
            ),
            Sensitivities::States => by_padded_order!(
                self,
                f => f.sensitivities(u, y, x0, row),
                _ => self.any_order(u, y, x0, row)
            ),
        }
    }

    /// [`OneStep::with_sensitivities`] for any order (slices of length n).
    fn any_order(
        &self,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        x0: &DVector<f64>,
        mut row: impl FnMut(usize, &[f64], f64),
    ) {
        let (n, ny) = (self.n, self.ny);
        let params = n * ny;
        let mut buf = Buffers::new(n, self.nu, ny);
        let mut x = x0.as_slice().to_vec();
        // S (n × P), C S (n_y × P, one row gathered per output) and the
        // next S, column-major.
        let mut sens = vec![0.0; n * params];
        let mut next = vec![0.0; n * params];
        let mut cs = vec![0.0; ny * params];
        let mut grad = vec![0.0; params];
        for t in 0..u.nrows() {
            for p in 0..params {
                let col = &sens[p * n..(p + 1) * n];
                matvec(&mut cs[p * ny..(p + 1) * ny], &self.c, col);
                matvec(&mut next[p * n..(p + 1) * n], &self.m, col);
            }
            self.step(u, y, t, &mut x, &mut buf);
            for o in 0..ny {
                if y[(t, o)].is_nan() {
                    // No error and no correction from output o at t: its
                    // −K_o C_o S term of (A − K C) S is taken back.
                    for p in 0..params {
                        let v = cs[o + p * ny];
                        let col = &mut next[p * n..(p + 1) * n];
                        for (i, e) in col.iter_mut().enumerate() {
                            *e += self.k[i + o * n] * v;
                        }
                    }
                    continue;
                }
                for (p, g) in grad.iter_mut().enumerate() {
                    *g = cs[o + p * ny];
                }
                row(o, &grad, buf.eps[o]);
            }
            // E(ε(t)): entry K_io (column o·n + i of vec K) adds ε_o(t)
            // to state i.
            for o in 0..ny {
                for i in 0..n {
                    next[i + (o * n + i) * n] += buf.eps[o];
                }
            }
            std::mem::swap(&mut sens, &mut next);
        }
    }
}

/// A [`OneStep`] with its state-space columns held in arrays of `N ≥ n`
/// entries (zero beyond n): loops of a length known to the compiler,
/// unrolled and vectorised. The padding adds exact zeros after each sum,
/// so the numbers are those of [`OneStep`]'s general loops (the same
/// order of operations; checked bit for bit in the tests).
struct Fixed<'a, const N: usize> {
    general: &'a OneStep,
    /// Columns of A, of A − K C (N of each, zero beyond n), of B and of K.
    a: Vec<[f64; N]>,
    m: Vec<[f64; N]>,
    b: Vec<[f64; N]>,
    k: Vec<[f64; N]>,
    /// Rows of C.
    c: Vec<[f64; N]>,
    /// Rows of A − K C (the columns of its transpose), n of them.
    mt: Vec<[f64; N]>,
}

/// `out = Σ_j cols[j] x[j]`, the first column's product first.
#[inline(always)]
fn combine<const N: usize>(out: &mut [f64; N], cols: &[[f64; N]], x: &[f64]) {
    match (cols.split_first(), x.split_first()) {
        (Some((c0, cols)), Some((x0, x))) => {
            for i in 0..N {
                out[i] = c0[i] * x0;
            }
            for (c, xj) in cols.iter().zip(x) {
                for i in 0..N {
                    out[i] += c[i] * xj;
                }
            }
        }
        _ => *out = [0.0; N],
    }
}

/// The dot product `Σ_i r[i] x[i]`, in order.
#[inline(always)]
fn dot<const N: usize>(r: &[f64; N], x: &[f64; N]) -> f64 {
    let mut v = r[0] * x[0];
    for i in 1..N {
        v += r[i] * x[i];
    }
    v
}

impl<'a, const N: usize> Fixed<'a, N> {
    fn new(g: &'a OneStep) -> Self {
        let n = g.n;
        let columns = |m: &[f64], count: usize| -> Vec<[f64; N]> {
            (0..count)
                .map(|j| {
                    let mut c = [0.0; N];
                    c[..n].copy_from_slice(&m[j * n..(j + 1) * n]);
                    c
                })
                .collect()
        };
        let square = |m: &[f64]| -> Vec<[f64; N]> {
            let mut cols = columns(m, n);
            cols.resize(N, [0.0; N]);
            cols
        };
        Fixed {
            general: g,
            a: square(&g.a),
            m: square(&g.m),
            b: columns(&g.b, g.nu),
            k: columns(&g.k, g.ny),
            c: (0..g.ny)
                .map(|o| {
                    let mut r = [0.0; N];
                    for (i, v) in r.iter_mut().take(n).enumerate() {
                        *v = g.c[o + i * g.ny];
                    }
                    r
                })
                .collect(),
            mt: (0..n)
                .map(|k| {
                    let mut r = [0.0; N];
                    for (i, v) in r.iter_mut().take(n).enumerate() {
                        *v = g.m[k + i * n];
                    }
                    r
                })
                .collect(),
        }
    }

    /// [`OneStep::step`]: the errors of sample `t` in `eps` (0 where y is
    /// NaN) and x advanced to x̂(t+1).
    #[inline(always)]
    fn step(
        &self,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        t: usize,
        x: &mut [f64; N],
        ut: &mut [f64],
        eps: &mut [f64],
    ) {
        let g = self.general;
        for (j, v) in ut.iter_mut().enumerate() {
            *v = u[(t, j)];
        }
        for (o, e) in eps.iter_mut().enumerate() {
            let yo = y[(t, o)];
            let cx = dot(&self.c[o], x);
            let du = match ut.split_first() {
                Some((u0, rest)) => {
                    let mut v = g.d[o] * u0;
                    for (j, uj) in rest.iter().enumerate() {
                        v += g.d[o + (j + 1) * g.ny] * uj;
                    }
                    v
                }
                None => 0.0,
            };
            *e = if yo.is_nan() { 0.0 } else { yo - cx - du };
        }
        let (mut ax, mut bu, mut ke) = ([0.0; N], [0.0; N], [0.0; N]);
        combine(&mut ax, &self.a, x);
        combine(&mut bu, &self.b, ut);
        combine(&mut ke, &self.k, eps);
        for i in 0..N {
            x[i] = ax[i] + bu[i] + ke[i];
        }
    }

    #[inline(always)]
    fn start(&self, x0: &DVector<f64>) -> [f64; N] {
        let mut x = [0.0; N];
        x[..self.general.n].copy_from_slice(x0.as_slice());
        x
    }

    /// [`OneStep::add_squared_errors`]: `visit(ε(t))` for every sample.
    #[inline(always)]
    fn errors(
        &self,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        x0: &DVector<f64>,
        mut visit: impl FnMut(&[f64]),
    ) {
        let g = self.general;
        let (mut ut, mut eps) = (vec![0.0; g.nu], vec![0.0; g.ny]);
        let mut x = self.start(x0);
        for t in 0..u.nrows() {
            self.step(u, y, t, &mut x, &mut ut, &mut eps);
            visit(&eps);
        }
    }

    /// [`OneStep::with_sensitivities`].
    #[inline(always)]
    fn sensitivities(
        &self,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        x0: &DVector<f64>,
        mut row: impl FnMut(usize, &[f64], f64),
    ) {
        let g = self.general;
        let (n, ny) = (g.n, g.ny);
        let params = n * ny;
        let (mut ut, mut eps) = (vec![0.0; g.nu], vec![0.0; ny]);
        let mut x = self.start(x0);
        let mut sens = vec![[0.0; N]; params];
        let mut next = vec![[0.0; N]; params];
        let mut cs = vec![vec![0.0; params]; ny];
        for t in 0..u.nrows() {
            for (p, s) in sens.iter().enumerate() {
                for (o, co) in self.c.iter().enumerate() {
                    cs[o][p] = dot(co, s);
                }
                combine(&mut next[p], &self.m, s);
            }
            self.step(u, y, t, &mut x, &mut ut, &mut eps);
            for o in 0..ny {
                if y[(t, o)].is_nan() {
                    // Output o takes no part at t (as in `any_order`).
                    for (out, v) in next.iter_mut().zip(&cs[o]) {
                        for (e, ki) in out.iter_mut().zip(&self.k[o]) {
                            *e += ki * v;
                        }
                    }
                    continue;
                }
                row(o, &cs[o], eps[o]);
            }
            for (o, e) in eps.iter().enumerate() {
                for i in 0..n {
                    next[o * n + i][i] += e;
                }
            }
            std::mem::swap(&mut sens, &mut next);
        }
    }

    /// [`OneStep::add_adjoint_gradient`].
    #[inline(always)]
    fn adjoint(&self, y: &DMatrix<f64>, eps: &[f64], w2: &[f64], grad: &mut [f64]) {
        let (n, ny) = (self.general.n, self.general.ny);
        let mut a = [0.0; N];
        for t in (0..eps.len() / ny).rev() {
            let e = &eps[t * ny..(t + 1) * ny];
            for (o, eo) in e.iter().enumerate() {
                for (g, ai) in grad[o * n..(o + 1) * n].iter_mut().zip(&a) {
                    *g += ai * eo;
                }
            }
            let mut next = [0.0; N];
            combine(&mut next, &self.mt, &a[..n]);
            for (o, eo) in e.iter().enumerate() {
                let s = if y[(t, o)].is_nan() {
                    // M_t = M + K_o C_o: output o's correction taken back.
                    -dot(&self.k[o], &a)
                } else {
                    w2[o] * eo
                };
                for (v, ci) in next.iter_mut().zip(&self.c[o]) {
                    *v -= ci * s;
                }
            }
            a = next;
        }
    }

    /// [`OneStep::with_sensitivities`] by the rows' recursion
    /// ([`Sensitivities::Rows`]; every output measured).
    /// O(N n² n_y²).
    #[inline(always)]
    fn row_sensitivities(
        &self,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        x0: &DVector<f64>,
        mut row: impl FnMut(usize, &[f64], f64),
    ) {
        let g = self.general;
        let (n, ny) = (g.n, g.ny);
        let (mut ut, mut eps) = (vec![0.0; g.nu], vec![0.0; ny]);
        let mut x = self.start(x0);
        // w[o n_y + r]: row r of C Z_o(t) ([`Sensitivities::Rows`]).
        let mut w = vec![[0.0; N]; ny * ny];
        let mut grad = vec![0.0; n * ny];
        for t in 0..u.nrows() {
            self.step(u, y, t, &mut x, &mut ut, &mut eps);
            for (r, e) in eps.iter().enumerate() {
                for (o, g) in grad.chunks_exact_mut(n).enumerate() {
                    g.copy_from_slice(&w[o * ny + r][..n]);
                }
                row(r, &grad, *e);
            }
            for (o, e) in eps.iter().enumerate() {
                for (wr, cr) in w[o * ny..(o + 1) * ny].iter_mut().zip(&self.c) {
                    let mut next = [0.0; N];
                    combine(&mut next, &self.mt, &wr[..n]);
                    for i in 0..N {
                        next[i] += e * cr[i];
                    }
                    *wr = next;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// A 2-state, 1-input, 2-output model with D and a stable predictor.
    fn model() -> (StateSpace, DMatrix<f64>) {
        let a = DMatrix::from_row_slice(2, 2, &[0.9, 0.1, -0.05, 0.7]);
        let b = DMatrix::from_row_slice(2, 1, &[1.0, 0.5]);
        let c = DMatrix::from_row_slice(2, 2, &[1.0, 0.3, -0.2, 1.0]);
        let d = DMatrix::from_row_slice(2, 1, &[0.1, 0.0]);
        let k = DMatrix::from_row_slice(2, 2, &[0.4, 0.1, 0.0, 0.3]);
        (StateSpace::new(a, b, c, d, Some(1.0)).expect("model"), k)
    }

    fn record() -> (DMatrix<f64>, DMatrix<f64>) {
        let u = DMatrix::from_fn(50, 1, |t, _| ((t * 7 % 11) as f64 - 5.0) / 5.0);
        let mut y = DMatrix::from_fn(50, 2, |t, o| ((t * 3 + o * 5) % 13) as f64 / 6.0 - 1.0);
        y[(7, 1)] = f64::NAN;
        y[(20, 0)] = f64::NAN;
        (u, y)
    }

    /// A run of the sensitivities, given the row visitor.
    type SensitivityRun<'a> = &'a dyn Fn(&mut dyn FnMut(usize, &[f64], f64));
    /// A run of the errors, given the error visitor.
    type ErrorRun<'a> = &'a dyn Fn(&mut dyn FnMut(&[f64]));

    /// The padded kernel gives the general one's numbers bit for bit.
    #[test]
    fn the_padded_kernel_is_the_general_one() {
        let (g, k) = model();
        let (u, y) = record();
        let x0 = DVector::from_column_slice(&[0.2, -0.1]);
        let m = g.a() - &k * g.c();
        let p = OneStep::new(&g, &k, &m);
        let collect = |run: SensitivityRun<'_>| {
            let mut rows = Vec::new();
            run(&mut |o, cs, e| rows.push((o, cs.to_vec(), e)));
            rows
        };
        let errors = |run: ErrorRun<'_>| {
            let mut all = Vec::new();
            run(&mut |e| all.extend(e.iter().map(|v| v.to_bits())));
            all
        };
        let general = errors(&|f| p.errors_any_order(&u, &y, &x0, f));
        assert_eq!(
            errors(&|f| Fixed::<2>::new(&p).errors(&u, &y, &x0, f)),
            general
        );
        assert_eq!(
            errors(&|f| Fixed::<8>::new(&p).errors(&u, &y, &x0, f)),
            general
        );
        let general = collect(&|f| p.any_order(&u, &y, &x0, f));
        for padded in [
            collect(&|f| Fixed::<2>::new(&p).sensitivities(&u, &y, &x0, f)),
            collect(&|f| Fixed::<4>::new(&p).sensitivities(&u, &y, &x0, f)),
            collect(&|f| Fixed::<16>::new(&p).sensitivities(&u, &y, &x0, f)),
        ] {
            assert_eq!(padded.len(), general.len());
            for (a, b) in padded.iter().zip(&general) {
                assert_eq!(a.0, b.0);
                assert_eq!(a.2.to_bits(), b.2.to_bits());
                for (x, y) in a.1.iter().zip(&b.1) {
                    assert_eq!(x.to_bits(), y.to_bits());
                }
            }
        }
    }

    /// The errors are those of `StateSpace::predict_from` on a record
    /// without missing samples, and the sensitivities those of central
    /// differences of the cost in each entry of K, by both routes on a
    /// complete record and by the states' with a sample not measured.
    #[test]
    fn errors_and_sensitivities_match_their_definitions() {
        let (g, k) = model();
        let (u, y) = record();
        let x0 = DVector::from_column_slice(&[0.2, -0.1]);
        let m = g.a() - &k * g.c();
        let full = y.map(|v| if v.is_nan() { 0.3 } else { v });
        let mut err = vec![0.0; 2];
        OneStep::new(&g, &k, &m).add_squared_errors(&u, &full, &x0, &mut err);
        let want = &full
            - g.predict_from(&k, &u, &full, 1, Some(&x0))
                .expect("predict");
        for (got, col) in err.iter().zip(want.column_iter()) {
            let e: f64 = col.iter().map(|v| v * v).sum();
            assert_relative_eq!(*got, e, max_relative = 1e-12);
        }
        // Gradient of ½Σε² in vec K: Σ ε ∂ε/∂K = −Σ ε (C S) row.
        let mut missing = full.clone();
        missing[(3, 0)] = f64::NAN;
        for (y, route) in [
            (&full, Sensitivities::Rows),
            (&full, Sensitivities::States),
            (&missing, Sensitivities::States),
        ] {
            let cost = |k: &DMatrix<f64>| {
                let m = g.a() - k * g.c();
                let mut e = vec![0.0; 2];
                OneStep::new(&g, k, &m).add_squared_errors(&u, y, &x0, &mut e);
                0.5 * (e[0] + e[1])
            };
            let mut grad = [0.0; 4];
            OneStep::new(&g, &k, &m).with_sensitivities(route, &u, y, &x0, |_, cs, eps| {
                for (g, v) in grad.iter_mut().zip(cs) {
                    *g -= eps * v;
                }
            });
            for (p, g) in grad.iter().enumerate() {
                let h = 1e-6;
                let (mut up, mut down) = (k.clone(), k.clone());
                up.as_mut_slice()[p] += h;
                down.as_mut_slice()[p] -= h;
                let numeric = (cost(&up) - cost(&down)) / (2.0 * h);
                assert_relative_eq!(*g, numeric, max_relative = 1e-6, epsilon = 1e-9);
            }
        }
    }

    /// A stable model of order `n` with 2 inputs and `ny` outputs, D ≠ 0,
    /// and a gain whose predictor is stable (A = 0.5 Q-like rotation
    /// blocks and a small K).
    fn model_of(n: usize, ny: usize) -> (StateSpace, DMatrix<f64>) {
        let wave = |i: usize, j: usize, s: usize| (((i * 7 + j * 13 + s) % 17) as f64 - 8.0) / 8.0;
        let raw = DMatrix::from_fn(n, n, |i, j| wave(i, j, 1));
        let a = &raw * (0.9 / raw.norm().max(1.0));
        let b = DMatrix::from_fn(n, 2, |i, j| wave(i, j, 2));
        let c = DMatrix::from_fn(ny, n, |i, j| wave(i, j, 3));
        let d = DMatrix::from_fn(ny, 2, |i, j| 0.1 * wave(i, j, 4));
        let k = DMatrix::from_fn(n, ny, |i, j| 0.05 * wave(i, j, 5));
        (StateSpace::new(a, b, c, d, Some(1.0)).expect("model"), k)
    }

    /// The adjoint gradient is the forward sensitivities' gradient
    /// Σ_t (C S(t))ᵀ W² ε(t) (rows negated as `with_sensitivities` gives
    /// them) to 1e-10 of its largest entry, on records with every output
    /// measured and with outputs missing at some instants (the states'
    /// route), for orders on every padded kernel and beyond them, one to
    /// three outputs.
    #[test]
    fn the_adjoint_gives_the_forward_gradient() {
        let u = DMatrix::from_fn(300, 2, |t, j| (((t * 7 + j * 3) % 11) as f64 - 5.0) / 5.0);
        for ny in 1..=3 {
            for missing in [false, true] {
                let mut y =
                    DMatrix::from_fn(300, ny, |t, o| ((t * 3 + o * 5) % 13) as f64 / 6.0 - 1.0);
                if missing {
                    for t in (5..300).step_by(7) {
                        y[(t, t % ny)] = f64::NAN;
                    }
                }
                let w2: Vec<f64> = (0..ny).map(|o| 0.5 + o as f64).collect();
                for n in [1, 2, 3, 4, 5, 8, 11, 16, 17] {
                    let (g, k) = model_of(n, ny);
                    let m = g.a() - &k * g.c();
                    let p = OneStep::new(&g, &k, &m);
                    let x0 = DVector::from_fn(n, |i, _| 0.1 * i as f64);
                    let mut forward = vec![0.0; n * ny];
                    p.with_sensitivities(Sensitivities::Rows, &u, &y, &x0, |o, cs, e| {
                        for (f, v) in forward.iter_mut().zip(cs) {
                            *f -= w2[o] * v * e;
                        }
                    });
                    let mut eps = Vec::new();
                    p.with_errors(&u, &y, &x0, |e| eps.extend_from_slice(e));
                    let mut adjoint = vec![0.0; n * ny];
                    p.add_adjoint_gradient(&y, &eps, &w2, &mut adjoint);
                    let scale = forward.iter().fold(0.0f64, |s, v| s.max(v.abs()));
                    assert!(scale > 0.0);
                    for (a, f) in adjoint.iter().zip(&forward) {
                        assert!(
                            (a - f).abs() <= 1e-10 * scale,
                            "n {n} ny {ny} missing {missing}: {adjoint:?} vs {forward:?}"
                        );
                    }
                }
            }
        }
    }

    /// The rows' recursion gives the states' rows to rounding (1e-12 of
    /// the largest row entry) and the same errors bit for bit, for orders
    /// on every padded kernel and beyond them (order 17 takes the states'
    /// route either way), with one, two and three outputs.
    #[test]
    fn the_rows_recursion_gives_the_states_rows() {
        let u = DMatrix::from_fn(300, 2, |t, j| (((t * 7 + j * 3) % 11) as f64 - 5.0) / 5.0);
        for ny in 1..=3 {
            let y = DMatrix::from_fn(300, ny, |t, o| ((t * 3 + o * 5) % 13) as f64 / 6.0 - 1.0);
            for n in [1, 2, 3, 4, 5, 8, 11, 16, 17] {
                let (g, k) = model_of(n, ny);
                let m = g.a() - &k * g.c();
                let p = OneStep::new(&g, &k, &m);
                let x0 = DVector::from_fn(n, |i, _| 0.1 * i as f64);
                let collect = |route| {
                    let mut rows = Vec::new();
                    p.with_sensitivities(route, &u, &y, &x0, |o, cs, e| {
                        rows.push((o, cs.to_vec(), e))
                    });
                    rows
                };
                let (rows, states) = (collect(Sensitivities::Rows), collect(Sensitivities::States));
                assert_eq!(rows.len(), states.len());
                let scale = states
                    .iter()
                    .flat_map(|r| r.1.iter())
                    .fold(0.0f64, |s, v| s.max(v.abs()));
                assert!(scale > 0.0);
                for (a, b) in rows.iter().zip(&states) {
                    assert_eq!(a.0, b.0);
                    assert_eq!(a.2.to_bits(), b.2.to_bits());
                    for (x, z) in a.1.iter().zip(&b.1) {
                        assert!((x - z).abs() <= 1e-12 * scale, "n {n}, ny {ny}: {x} vs {z}");
                    }
                }
            }
        }
    }
}

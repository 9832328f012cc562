//! The state-space recursions of simulation and prediction in flat loops.
//!
//! x(t+1) = A x(t) + B u(t), y(t) = C x(t) + D u(t) run sample by sample,
//! each product as a loop over the columns of the matrix with the state in
//! an array of `N ≥ n` entries (a length known to the compiler: unrolled and
//! vectorised), instead of nalgebra's `gemv` on dynamic vectors, whose
//! per-call overhead dominated simulations and predictions of 1e5 samples
//! (four products per sample of a few states each).
//!
//! The sums are those of `gemv` in its order: `y.gemv(1, M, x, 0)` is
//! y = M₀ x₀, then y ← Mⱼ xⱼ + y for j = 1, 2, …, and `y.gemv(1, M, x, 1)`
//! adds Mⱼ xⱼ to y column by column; the correction `x.axpy(e, k, 1)` is
//! x ← e k + x. Only the first n entries of a state are ever read (the
//! columns are n long, the sums run over n columns), so the padding takes
//! no part, and every number is the `gemv` loop's bit for bit (tests in
//! `response` and `predict` against the nalgebra loops kept for orders
//! above [`MAX_FLAT`]).
//!
//! O(n (n + n_u) + n_y (n + n_u)) per sample.

use nalgebra::{DMatrix, DVector};

use crate::ss::StateSpace;

/// The largest order run in flat loops (orders 1–16; the others by
/// nalgebra's `gemv`).
pub(crate) const MAX_FLAT: usize = 16;

/// (A, B, C, D) as columns: A's and B's in arrays of N (zero beyond n),
/// C's and D's as column-major slices.
pub(crate) struct Flat<const N: usize> {
    n: usize,
    nu: usize,
    ny: usize,
    a: Vec<[f64; N]>,
    b: Vec<[f64; N]>,
    c: Vec<f64>,
    d: Vec<f64>,
}

/// `out ← Σⱼ cols[j] x[j]` (the first product, then each further one added
/// in turn: `gemv` with β = 0) when `fresh`, else `out ← out + Σⱼ …` added
/// column by column (`gemv` with β = 1). An empty sum leaves `out` as it is
/// (β = 1) or zero (β = 0).
#[inline(always)]
fn columns_times<const N: usize>(out: &mut [f64; N], cols: &[[f64; N]], x: &[f64], fresh: bool) {
    let mut terms = cols.iter().zip(x);
    if fresh {
        match terms.next() {
            Some((c, &x0)) => {
                for i in 0..N {
                    out[i] = c[i] * x0;
                }
            }
            None => *out = [0.0; N],
        }
    }
    for (c, &xj) in terms {
        for i in 0..N {
            out[i] += c[i] * xj;
        }
    }
}

/// `out ← M x` (β = 0) or `out ← out + M x` (β = 1) for a column-major
/// `out.len() × x.len()` slice `m`, in `gemv`'s order.
#[inline(always)]
fn slice_times(out: &mut [f64], m: &[f64], x: &[f64], fresh: bool) {
    let rows = out.len();
    let mut terms = x.iter().enumerate();
    if fresh {
        match terms.next() {
            Some((_, &x0)) => {
                for (o, v) in out.iter_mut().zip(&m[..rows]) {
                    *o = v * x0;
                }
            }
            None => out.fill(0.0),
        }
    }
    for (j, &xj) in terms {
        for (o, v) in out.iter_mut().zip(&m[j * rows..(j + 1) * rows]) {
            *o += v * xj;
        }
    }
}

impl<const N: usize> Flat<N> {
    /// The columns of `sys` (order at most N).
    pub(crate) fn new(sys: &StateSpace) -> Self {
        let (n, nu, ny) = (sys.order(), sys.n_inputs(), sys.n_outputs());
        debug_assert!(n <= N);
        let columns = |m: &DMatrix<f64>| -> Vec<[f64; N]> {
            m.column_iter()
                .map(|col| {
                    let mut c = [0.0; N];
                    for (ci, v) in c.iter_mut().zip(col.iter()) {
                        *ci = *v;
                    }
                    c
                })
                .collect()
        };
        Flat {
            n,
            nu,
            ny,
            a: columns(sys.a()),
            b: columns(sys.b()),
            c: sys.c().as_slice().to_vec(),
            d: sys.d().as_slice().to_vec(),
        }
    }

    /// A state array holding `x` (n entries).
    pub(crate) fn state(&self, x: &DVector<f64>) -> [f64; N] {
        let mut s = [0.0; N];
        s[..self.n].copy_from_slice(x.as_slice());
        s
    }

    /// `next ← A x + B u` (`next.gemv(1, A, x, 0); next.gemv(1, B, u, 1)`).
    #[inline(always)]
    pub(crate) fn advance(&self, x: &[f64; N], u: &[f64], next: &mut [f64; N]) {
        columns_times(next, &self.a, &x[..self.n], true);
        columns_times(next, &self.b, u, false);
    }

    /// `y ← C x + D u` (`y.gemv(1, C, x, 0); y.gemv(1, D, u, 1)`).
    #[inline(always)]
    pub(crate) fn output(&self, x: &[f64; N], u: &[f64], y: &mut [f64]) {
        slice_times(y, &self.c, &x[..self.n], true);
        slice_times(y, &self.d, u, false);
    }

    /// `next ← e k + next` for the column `k` (`next.axpy(e, k, 1)`).
    #[inline(always)]
    pub(crate) fn correct(next: &mut [f64; N], k: &[f64; N], e: f64) {
        for i in 0..N {
            next[i] += e * k[i];
        }
    }

    /// The columns of an n × m matrix `k` in arrays of N.
    pub(crate) fn columns_of(&self, k: &DMatrix<f64>) -> Vec<[f64; N]> {
        k.column_iter()
            .map(|col| {
                let mut c = [0.0; N];
                for (ci, v) in c.iter_mut().zip(col.iter()).take(self.n) {
                    *ci = *v;
                }
                c
            })
            .collect()
    }

    /// The state's order, inputs and outputs.
    pub(crate) fn dims(&self) -> (usize, usize, usize) {
        (self.n, self.nu, self.ny)
    }
}

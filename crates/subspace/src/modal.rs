//! The output-error (B, D, x₀) regression of [`crate::estimate_bd`] in modal
//! coordinates: one short row per sample instead of n_y long ones.
//!
//! With A = V Λ V⁻¹ (Λ real block diagonal: 1×1 blocks λ for real
//! eigenvalues, 2×2 blocks [[a, b], [−b, a]] for a ± ib) the state
//! sensitivities Z̃_j(t+1) = Λ Z̃_j(t) + u_j(t) I of the modal
//! parameters B̃ = V⁻¹B are block diagonal, so each input needs only n
//! scalar filters (w(t+1) = λ w(t) + u_j(t) per real mode, the real and
//! imaginary parts of the complex filter per pair) instead of the n×n
//! recursion, and the free response C Aᵗ x₀ = C̃ Λᵗ x̃₀ needs n more
//! signals per record. Every regressor of output o is then a fixed linear
//! combination of the sample's *base row*
//!
//! z(t) = [w (n n_u) | u(t) (n_u) | Λᵗ signals (n) | 1 | y(t) (n_y)],
//!
//! the regressor row of output o (parameters in the original coordinates,
//! target last) being z(t) T_o with T_o = S_o M⁻¹ (S_o: the modal
//! coefficients from C̃ = C V; M⁻¹ = V⁻¹ on the B and x₀ blocks). With
//! Z = Q R_z (R-only QR of the base rows, one accumulator per record and
//! per pattern of sampled outputs), Σ_t Σ_o T_oᵀ z zᵀ T_o = Σ_o (R_z T_o)ᵀ
//! (R_z T_o): the R factor of the stacked R_z T_o is that of the full
//! regression, exactly, without forming a normal matrix.
//!
//! Cost per sample: 2 n n_u flops of filtering and one QR row of
//! q = n n_u + n_u + n + 1 + n_y columns (≈ 2q² flops), against n_u n³
//! flops and n_y rows of p + 1 ≈ n n_u + n_y n_u + n + n_y + 1 columns
//! for the direct route (2×2, order 4: 17-wide rows once per sample
//! against two 19-wide rows). The route is taken only when V is well
//! conditioned ([`MAX_MODAL_CONDITION`]); a defective or nearly defective
//! A keeps the direct recursion.
//!
//! Long file: the modal form, its filters (time-major and per mode), the
//! jumps of a filter state over a range and the scan share the mode layout
//! and its SIMD dispatch; they are one kernel family.

use lifted_linalg::RAccumulator;
use nalgebra::DMatrix;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::estimated::{DataScale, Params, Record};

/// Largest 2-norm condition number of the (column-normalised) eigenvector
/// matrix V for which the modal route is used: the change of coordinates
/// can amplify rounding by up to κ(V)² in the regression, so 1e4 bounds the
/// loss at about 8 digits in the worst case and keeps near-repeated or
/// nearly defective modes on the direct route.
pub(crate) const MAX_MODAL_CONDITION: f64 = 1e4;

/// Most distinct patterns of sampled outputs per record the modal route
/// keeps an accumulator for (multirate records have a few; beyond it the
/// direct route is used).
const MAX_PATTERNS: usize = 16;

/// Samples per chunk of [`ModalForm::jump`]: the power tables stay in L1
/// and their rounding (about C ulps) far below the data's.
const JUMP: usize = 64;

/// Most outputs of the modal route (a pattern is a 64-bit mask).
pub(crate) const MAX_OUTPUTS: usize = 64;

/// Rows per block folded into a pattern's R factor (not a multiple of 512:
/// the columns of the block, BLOCK·8 bytes apart, would then share cache
/// sets while a row is written across them).
const BLOCK: usize = 1000;

/// Below this magnitude the free-response signals Λᵗ (1 at t = 0) are set
/// to zero: their rows carry no information on x₀ any more (an entry below
/// 1e-30 of the first row's moves the Gram matrix by far less than double
/// rounding, 14 orders of magnitude below it), and the later rows are then
/// reduced without the x₀ columns ([`PatternAcc::narrow`]). For the
/// slowest mode |λ| that happens after ln(1e-30)/ln|λ| samples: 660 at
/// 0.9, 6 900 at 0.99, 69 000 at 0.999.
const NEGLIGIBLE: f64 = 1e-30;

/// One diagonal block of Λ.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
enum Mode {
    /// A real eigenvalue λ (one state).
    Real(f64),
    /// A complex pair a ± ib, block [[a, b], [−b, a]] (two states).
    Pair(f64, f64),
}

/// Real modal form A = V Λ V⁻¹.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(crate) struct ModalForm {
    modes: Vec<Mode>,
    v: DMatrix<f64>,
    v_inv: DMatrix<f64>,
}

impl ModalForm {
    /// The real modal form of `a`, or `None` when the eigenvector matrix is
    /// singular or worse conditioned than [`MAX_MODAL_CONDITION`] (or the
    /// eigen-decomposition fails, or does not reproduce A to 1e-10).
    /// O(25n³).
    pub(crate) fn of(a: &DMatrix<f64>) -> Option<Self> {
        let n = a.nrows();
        if n == 0 {
            return None;
        }
        let e = lifted_linalg::eig(a).ok()?;
        let mut v = DMatrix::zeros(n, n);
        let mut modes = Vec::with_capacity(n);
        let mut i = 0;
        while i < n {
            let lam = e.values[i];
            let col = e.vectors.column(i);
            if lam.im == 0.0 {
                // Rotate the phase so that the largest entry is real.
                let k = (0..n)
                    .max_by(|&x, &y| col[x].norm().total_cmp(&col[y].norm()))
                    .unwrap_or(0);
                let ph = col[k].conj() / (col[k].norm() * col.norm());
                for r in 0..n {
                    v[(r, i)] = (col[r] * ph).re;
                }
                modes.push(Mode::Real(lam.re));
                i += 1;
            } else {
                // A pair is adjacent; take the member with b > 0.
                if i + 1 >= n {
                    return None;
                }
                let (lam, col) = if lam.im > 0.0 {
                    (lam, col)
                } else {
                    (e.values[i + 1], e.vectors.column(i + 1))
                };
                // Any complex multiple of the eigenvector gives a real
                // pair (Re, Im) with A [Re Im] = [Re Im] [[a, b], [−b, a]];
                // the phase that makes the two orthogonal conditions V best.
                let (xx, yy, xy) = col.iter().fold((0.0, 0.0, 0.0), |(p, q, r), z| {
                    (p + z.re * z.re, q + z.im * z.im, r + z.re * z.im)
                });
                let phi = 0.5 * (-2.0 * xy).atan2(xx - yy);
                let rot = Complex64::from_polar(1.0, phi);
                let nrm = (xx + yy).sqrt();
                if nrm.is_nan() || nrm <= 0.0 {
                    return None;
                }
                for r in 0..n {
                    let z = col[r] * rot / nrm;
                    v[(r, i)] = z.re;
                    v[(r, i + 1)] = z.im;
                }
                modes.push(Mode::Pair(lam.re, lam.im));
                i += 2;
            }
        }
        let sv = lifted_linalg::singular_values(&v).ok()?;
        let (smax, smin) = (sv[0], sv[sv.len() - 1]);
        if smin.is_nan() || smin <= 0.0 || smax / smin > MAX_MODAL_CONDITION {
            return None;
        }
        let v_inv = lifted_linalg::inv(&v).ok()?;
        let form = ModalForm { modes, v, v_inv };
        // A V = V Λ to rounding (a mis-paired or inaccurate decomposition
        // falls back to the direct route).
        let resid = (a * &form.v - &form.v * form.lambda()).norm();
        if resid.is_nan() || resid > 1e-10 * (a.norm() + 1.0) {
            return None;
        }
        Some(form)
    }

    /// Λ as a matrix.
    fn lambda(&self) -> DMatrix<f64> {
        let n = self.v.nrows();
        let mut l = DMatrix::zeros(n, n);
        let mut i = 0;
        for m in &self.modes {
            match *m {
                Mode::Real(x) => {
                    l[(i, i)] = x;
                    i += 1;
                }
                Mode::Pair(a, b) => {
                    l[(i, i)] = a;
                    l[(i, i + 1)] = b;
                    l[(i + 1, i)] = -b;
                    l[(i + 1, i + 1)] = a;
                    i += 2;
                }
            }
        }
        l
    }

    /// Advances n modal filters `w` by one sample with input `u`
    /// (w ← Λ w + u for real modes; the pair form p' = ap − bq + u,
    /// q' = aq + bp, the real and imaginary parts of the complex filter).
    /// Always inlined, so that inside `simd::dispatch` the fused
    /// multiply-adds are instructions (a call of its own, compiled for the
    /// baseline x86-64, makes each `mul_add` a library call).
    #[inline(always)]
    fn step(&self, w: &mut [f64], u: f64) {
        let mut i = 0;
        for m in &self.modes {
            match *m {
                Mode::Real(l) => {
                    w[i] = l.mul_add(w[i], u);
                    i += 1;
                }
                Mode::Pair(a, b) => {
                    let (p, q) = (w[i], w[i + 1]);
                    w[i] = a.mul_add(p, (-b).mul_add(q, u));
                    w[i + 1] = a.mul_add(q, b * p);
                    i += 2;
                }
            }
        }
    }

    /// Runs the modal filters of every input (`w`: n per input, as
    /// [`FilterState::w`]) over the instants `ts` of `u` (each sample times
    /// `iu`): at each instant the operations of [`step`](Self::step), so
    /// the numbers are those of the sample-by-sample run (bit for bit but
    /// for the sign of a zero on the vector path, module `lanes`); the
    /// filters of an instant are independent, so their chains overlap in
    /// the pipeline. With `out = (block, stride, row)`, the value of filter
    /// c (c = j·n + i) *before* instant k of the stretch is written to
    /// `block[c * stride + row + k]` (the base rows' column-major block).
    /// O(n · n_u · ts.len()).
    fn run(
        &self,
        w: &mut [f64],
        u: &DMatrix<f64>,
        iu: f64,
        ts: std::ops::Range<usize>,
        out: Option<(&mut [f64], usize, usize)>,
    ) {
        // The filters of all inputs in vector lanes where they fit (the
        // same values: module `lanes`).
        if let (Some(simd), Some(lanes)) = (
            lifted_linalg::simd::Avx2Fma::detect(),
            lanes::Lanes::of(&self.modes, u.ncols()),
        ) {
            lanes.run(simd, w, u, iu, ts, out);
            return;
        }
        self.run_scalar(w, u, iu, ts, out);
    }

    /// [`run`](Self::run) one input and mode at a time (more filters than
    /// the vector lanes hold, or no AVX2).
    fn run_scalar(
        &self,
        w: &mut [f64],
        u: &DMatrix<f64>,
        iu: f64,
        ts: std::ops::Range<usize>,
        out: Option<(&mut [f64], usize, usize)>,
    ) {
        lifted_linalg::simd::dispatch(
            #[inline(always)]
            || {
                let n = w.len() / u.ncols().max(1);
                // The modes as flat lists: (state index, λ) and (index, a, b).
                let mut reals = Vec::with_capacity(n);
                let mut pairs = Vec::with_capacity(n / 2);
                let mut i = 0;
                for m in &self.modes {
                    match *m {
                        Mode::Real(l) => {
                            reals.push((i, l));
                            i += 1;
                        }
                        Mode::Pair(a, b) => {
                            pairs.push((i, a, b));
                            i += 2;
                        }
                    }
                }
                let rows = u.nrows();
                let us = u.as_slice();
                let mut out = out;
                for (k, t) in ts.enumerate() {
                    for (j, wj) in w.chunks_exact_mut(n).enumerate() {
                        let v = us[j * rows + t] * iu;
                        if let Some((blk, stride, row)) = out.as_mut() {
                            let at = |c: usize| (j * n + c) * *stride + *row + k;
                            for (c, x) in wj.iter().enumerate() {
                                blk[at(c)] = *x;
                            }
                        }
                        for &(i, l) in &reals {
                            wj[i] = l.mul_add(wj[i], v);
                        }
                        for &(i, a, b) in &pairs {
                            let (p, q) = (wj[i], wj[i + 1]);
                            wj[i] = a.mul_add(p, (-b).mul_add(q, v));
                            wj[i + 1] = a.mul_add(q, b * p);
                        }
                    }
                }
            },
        )
    }

    /// Advances the modal filters of every input (`w`: n per input) over
    /// the instants `ts` of `u` (each sample times `iu`) to their values at
    /// `ts.end`, without the values in between: per chunk of [`JUMP`]
    /// samples, w ← λ^C w + iu Σ_k λ^(C−1−k) u_k for a real mode and
    /// z ← μ^C z + iu Σ_k μ^(C−1−k) u_k for a pair (z = p + iq, μ = a + ib:
    /// the pair's step p' = ap − bq + v, q' = aq + bp is z' = μz + v), the
    /// sums dot products with a table of C powers (vectorised, no chain
    /// through the samples), the chunks chained; the samples after the last
    /// whole chunk stepped one by one. The values of the sample-by-sample
    /// recursion up to rounding (the powers to about C ulps). About
    /// 2 n n_u flops per sample, at vector speed.
    fn jump(&self, w: &mut [f64], u: &DMatrix<f64>, iu: f64, ts: std::ops::Range<usize>) {
        lifted_linalg::simd::dispatch(
            #[inline(always)]
            || {
                let n: usize = self
                    .modes
                    .iter()
                    .map(|m| if matches!(m, Mode::Real(_)) { 1 } else { 2 })
                    .sum();
                let rows = u.nrows();
                let whole = ts.len() / JUMP * JUMP;
                let mut i = 0;
                for m in &self.modes {
                    match *m {
                        Mode::Real(l) => {
                            // tab[k] = λ^(C−1−k); then pw = λ^C.
                            let mut tab = [0.0; JUMP];
                            let mut pw = 1.0;
                            for t in tab.iter_mut().rev() {
                                *t = pw;
                                pw *= l;
                            }
                            for (j, wj) in w.chunks_exact_mut(n).enumerate() {
                                let col = &u.as_slice()[j * rows + ts.start..j * rows + ts.end];
                                let mut x = wj[i];
                                for c in col[..whole].chunks_exact(JUMP) {
                                    x = pw.mul_add(x, iu * lifted_linalg::dot(&tab, c));
                                }
                                for &v in &col[whole..] {
                                    x = l.mul_add(x, v * iu);
                                }
                                wj[i] = x;
                            }
                            i += 1;
                        }
                        Mode::Pair(a, b) => {
                            // re + i·im = μ^(C−1−k); then (pr, pi) = μ^C.
                            let (mut re, mut im) = ([0.0; JUMP], [0.0; JUMP]);
                            let (mut pr, mut pi) = (1.0f64, 0.0f64);
                            for (r, m) in re.iter_mut().rev().zip(im.iter_mut().rev()) {
                                (*r, *m) = (pr, pi);
                                (pr, pi) = (a * pr - b * pi, a * pi + b * pr);
                            }
                            for (j, wj) in w.chunks_exact_mut(n).enumerate() {
                                let col = &u.as_slice()[j * rows + ts.start..j * rows + ts.end];
                                let (mut p, mut q) = (wj[i], wj[i + 1]);
                                for c in col[..whole].chunks_exact(JUMP) {
                                    let sr = iu * lifted_linalg::dot(&re, c);
                                    let si = iu * lifted_linalg::dot(&im, c);
                                    (p, q) = (pr * p - pi * q + sr, pr * q + pi * p + si);
                                }
                                for &v in &col[whole..] {
                                    (p, q) = (
                                        a.mul_add(p, (-b).mul_add(q, v * iu)),
                                        a.mul_add(q, b * p),
                                    );
                                }
                                wj[i] = p;
                                wj[i + 1] = q;
                            }
                            i += 2;
                        }
                    }
                }
            },
        )
    }

    /// Writes into `s` (rows `base..base + n`, parameter columns
    /// `col..col + n`) the coefficients of the n modal parameters on the
    /// base signals of one filter bank for the output row `ct` of C̃:
    /// real mode i: c̃_i w_i; pair (i, i+1) with signals (p, q):
    /// θ̃_i ← c̃_i p − c̃_{i+1} q, θ̃_{i+1} ← c̃_{i+1} p + c̃_i q.
    fn coefficients(&self, ct: &[f64], s: &mut DMatrix<f64>, base: usize, col: usize) {
        let mut i = 0;
        for m in &self.modes {
            match m {
                Mode::Real(_) => {
                    s[(base + i, col + i)] = ct[i];
                    i += 1;
                }
                Mode::Pair(..) => {
                    let (c0, c1) = (ct[i], ct[i + 1]);
                    s[(base + i, col + i)] = c0;
                    s[(base + i + 1, col + i)] = -c1;
                    s[(base + i, col + i + 1)] = c1;
                    s[(base + i + 1, col + i + 1)] = c0;
                    i += 2;
                }
            }
        }
    }
}

/// Layout of the base row z(t).
#[derive(Clone, Serialize, Deserialize)]
pub(crate) struct Layout {
    n: usize,
    nu: usize,
    ny: usize,
    /// Start of the free-response signals (if x₀ is estimated).
    x0: Option<usize>,
    /// Column of the constant 1 (if offsets are estimated).
    one: Option<usize>,
    /// Start of the outputs.
    y: usize,
    /// Width q.
    width: usize,
}

impl Layout {
    pub(crate) fn of(p: &Params) -> Self {
        let (n, nu, ny) = (p.n, p.nu, p.ny);
        let mut q = n * nu + nu;
        let x0 = p.x0_offset.map(|_| {
            q += n;
            q - n
        });
        let one = p.c_offset.map(|_| {
            q += 1;
            q - 1
        });
        let y = q;
        Layout {
            n,
            nu,
            ny,
            x0,
            one,
            y,
            width: q + ny,
        }
    }
}

/// T_o of output `o` in record `e`: (width)×(p + 1), mapping the base row
/// to the regressor row of o in the original coordinates, target last.
fn row_map(
    form: &ModalForm,
    ct: &DMatrix<f64>,
    p: &Params,
    lay: &Layout,
    o: usize,
    e: usize,
) -> DMatrix<f64> {
    let (n, nu) = (lay.n, lay.nu);
    let np = p.total;
    let mut s = DMatrix::zeros(lay.width, np + 1);
    let crow: Vec<f64> = ct.row(o).iter().copied().collect();
    for j in 0..nu {
        form.coefficients(&crow, &mut s, j * n, j * n);
        if let Some(k) = p.d_index[(o, j)] {
            s[(n * nu + j, k)] = 1.0;
        }
    }
    if let (Some(base), Some(off)) = (lay.x0, p.x0_offset) {
        form.coefficients(&crow, &mut s, base, off + e * n);
    }
    if let (Some(one), Some(off)) = (lay.one, p.c_offset) {
        s[(one, off + e * p.ny + o)] = 1.0;
    }
    s[(lay.y + o, np)] = 1.0;
    // M⁻¹ on the parameter blocks in modal coordinates: θ̃ = V⁻¹θ.
    let mut blocks: Vec<usize> = (0..nu).map(|j| j * n).collect();
    if let Some(off) = p.x0_offset {
        blocks.push(off + e * n);
    }
    for c0 in blocks {
        let cols = s.columns(c0, n) * &form.v_inv;
        s.columns_mut(c0, n).copy_from(&cols);
    }
    s
}

/// R factors of base rows per pattern of sampled outputs (bit mask).
pub(crate) type Patterns = Vec<(u64, RAccumulator)>;

/// One pattern of sampled outputs: its base rows and their R factor.
struct PatternAcc {
    mask: u64,
    block: DMatrix<f64>,
    used: usize,
    acc: RAccumulator,
    /// The rows after the free response has died out (x₀ columns zero),
    /// without those columns: R-only QR of q − n columns instead of q,
    /// (1 − n/q)² of the flops (2×2, order 4: 13 of 17 columns, 58 %).
    /// Folded into `acc` by [`PatternAcc::finish`].
    narrow: Option<Box<PatternAcc>>,
}

impl PatternAcc {
    fn new(mask: u64, width: usize) -> Self {
        PatternAcc {
            mask,
            block: DMatrix::zeros(BLOCK, width),
            used: 0,
            acc: RAccumulator::new(width),
            narrow: None,
        }
    }

    fn flush(&mut self) -> Result<()> {
        if self.used == BLOCK {
            // The block is scratch from here on: folded in place.
            self.acc.fold_rows(&mut self.block)?;
        } else if self.used > 0 {
            self.acc
                .push_rows(&self.block.rows(0, self.used).into_owned())?;
        }
        self.used = 0;
        Ok(())
    }

    /// Flushes both blocks and folds the narrow rows' R factor into `acc`
    /// with zero x₀ columns (the n columns from `x0`): R of all the rows,
    /// exactly (the rows of [R_wide; R_narrow with zeros] span the same
    /// Gram matrix). O(q³) once.
    fn finish(&mut self, x0: Option<usize>, n: usize) -> Result<()> {
        self.flush()?;
        let (Some(mut narrow), Some(x0)) = (self.narrow.take(), x0) else {
            return Ok(());
        };
        narrow.flush()?;
        let rn = narrow.acc.r();
        // Rows the factor of all the rows has: min(rows, q). The narrow
        // factor has at most q − n; when fewer than n rows came before the
        // free response died out, zero rows make up the difference (the
        // consumers read a q-row R once there were q rows; the x₀ columns
        // are then rank deficient, as on the direct route).
        let width = self.acc.ncols();
        let want = (self.acc.rows_seen() + narrow.acc.rows_seen()).min(width);
        if rn.nrows() > 0 {
            let full = DMatrix::from_fn(rn.nrows(), width, |i, j| {
                if j < x0 {
                    rn[(i, j)]
                } else if j < x0 + n {
                    0.0
                } else {
                    rn[(i, j - n)]
                }
            });
            self.acc.push_rows(&full)?;
        }
        // R has min(rows pushed, q) rows (no copy of it to count them).
        let have = self.acc.rows_seen().min(width);
        if have < want {
            self.acc.push_rows(&DMatrix::zeros(want - have, width))?;
        }
        Ok(())
    }
}

/// Bit mask of the sampled (non-NaN) outputs of row `t`.
fn pattern(y: &DMatrix<f64>, t: usize) -> u64 {
    (0..y.ncols()).fold(
        0u64,
        |m, o| {
            if y[(t, o)].is_nan() { m } else { m | (1 << o) }
        },
    )
}

/// Records shorter than this many samples per thread are scanned on the
/// calling thread.
const PARALLEL_MIN_SAMPLES: usize = 20_000;

/// Ranges per thread of a parallel scan: the threads take the ranges in
/// turn as they finish, so a thread slowed by other work (a reading
/// thread beside the scan) takes fewer instead of holding up the others.
const RANGES_PER_THREAD: usize = 4;

/// Shortest range of a parallel scan (its filter start and R factor cost
/// a fixed O(q³)).
const MIN_RANGE: usize = 4096;

/// The number of ranges a scan of `len` samples on `threads` threads is
/// cut into (1: one scan on the calling thread).
fn ranges(len: usize, threads: usize) -> usize {
    if threads <= 1 || len < threads * PARALLEL_MIN_SAMPLES {
        return 1;
    }
    (threads * RANGES_PER_THREAD)
        .min(len / MIN_RANGE)
        .max(threads)
}

/// Folds the regression rows of all records into `acc` (p + 1 columns,
/// the R factor of the direct route's [Φ | y] up to rounding) through the
/// modal base rows; returns the number of sampled output entries, or
/// `None` (with `acc` partly filled) when a record has more than
/// [`MAX_PATTERNS`] patterns of sampled outputs. `c` is the C of the data
/// divided by `scale`; at most [`MAX_OUTPUTS`] outputs.
///
/// With `threads` > 1 a long record is cut into that many consecutive
/// ranges: a serial pass runs the filter recursions alone (O(N n n_u)) to
/// give each range its starting filter states — the same numbers the
/// single scan would hold there — and the ranges' base rows are reduced to
/// R factors on their own threads, then stacked (R of [R₁; R₂] is the R of
/// all rows). The result depends on `threads` through rounding only.
pub(crate) fn accumulate(
    form: &ModalForm,
    c: &DMatrix<f64>,
    p: &Params,
    records: &[Record<'_>],
    scale: DataScale,
    acc: &mut RAccumulator,
    threads: usize,
) -> Result<Option<usize>> {
    let lay = Layout::of(p);
    let ny = lay.ny;
    let inv = (1.0 / scale.io.u, 1.0 / scale.io.y);
    let ct = c * &form.v;
    let mut rows_total = 0;
    for (e, rec) in records.iter().enumerate() {
        let maps: Vec<DMatrix<f64>> = (0..ny).map(|o| row_map(form, &ct, p, &lay, o, e)).collect();
        let len = rec.u.nrows();
        let parts = ranges(len, threads);
        let per = len.div_ceil(parts);
        let start = FilterState::initial(form, &lay);
        let scans: Vec<Result<Option<Scan>>> = if parts == 1 {
            vec![scan(form, &lay, rec, inv, 0..len, &mut start.clone())]
        } else {
            scan_parallel(form, &lay, rec, inv, &start, (per, parts), threads)
                .into_iter()
                .map(|(sc, _)| sc)
                .collect()
        };
        // Merge the ranges' patterns (in range order).
        let mut pats: Vec<(u64, RAccumulator)> = Vec::new();
        for sc in scans {
            let Some(sc) = sc? else {
                return Ok(None);
            };
            rows_total += sc.rows;
            if !merge_patterns(&mut pats, sc, MAX_PATTERNS)? {
                return Ok(None);
            }
        }
        fold_patterns(&pats, &maps, acc)?;
    }
    Ok(Some(rows_total))
}

/// The `parts` ranges `i·per .. (i + 1)·per` of `rec` (`cut` = (per,
/// parts)) scanned on `threads` threads (the calling thread one of them),
/// each thread taking the next range not yet taken as it finishes one:
/// the starting filter states first ([`FilterState::at`], the filters
/// alone at vector speed), then the scans. The results come in range
/// order, each with the filter state at the end of its range, whichever
/// thread scanned it (so they do not depend on the timing); a range whose
/// thread failed is scanned again here.
fn scan_parallel(
    form: &ModalForm,
    lay: &Layout,
    rec: &Record<'_>,
    inv: (f64, f64),
    start: &FilterState,
    cut: (usize, usize),
    threads: usize,
) -> Vec<(Result<Option<Scan>>, FilterState)> {
    let (per, parts) = cut;
    let len = rec.u.nrows();
    let range = |i: usize| (i * per).min(len)..((i + 1) * per).min(len);
    let starts = FilterState::at(start.clone(), form, rec, inv.0, per, parts);
    let run = |i: usize| {
        let mut st = starts[i].clone();
        (scan(form, lay, rec, inv, range(i), &mut st), st)
    };
    let next = std::sync::atomic::AtomicUsize::new(0);
    let work = || {
        let mut done = Vec::new();
        loop {
            let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            if i >= parts {
                return done;
            }
            done.push((i, run(i)));
        }
    };
    let mut slots: Vec<Option<(Result<Option<Scan>>, FilterState)>> =
        (0..parts).map(|_| None).collect();
    std::thread::scope(|scope| {
        let helpers: Vec<_> = (1..threads.min(parts)).map(|_| scope.spawn(work)).collect();
        let mine = work();
        for (i, r) in helpers
            .into_iter()
            .filter_map(|h| h.join().ok())
            .flatten()
            .chain(mine)
        {
            slots[i] = Some(r);
        }
    });
    slots
        .into_iter()
        .enumerate()
        .map(|(i, r)| r.unwrap_or_else(|| run(i)))
        .collect()
}

/// Adds the patterns of `sc` to `pats` (R factors of equal masks stacked);
/// false when that would make more than `max` patterns.
fn merge_patterns(pats: &mut Vec<(u64, RAccumulator)>, sc: Scan, max: usize) -> Result<bool> {
    for pa in sc.patterns {
        match pats.iter().position(|(m, _)| *m == pa.mask) {
            Some(k) => pats[k].1.push_rows(&pa.acc.r())?,
            None if pats.len() == max => return Ok(false),
            None => pats.push((pa.mask, pa.acc)),
        }
    }
    Ok(true)
}

/// Folds each pattern's R factor of base rows into `acc` through the row
/// maps T_o of its sampled outputs: R_z T_o stacked, the R factor of the
/// full regression rows of the record.
fn fold_patterns(
    pats: &[(u64, RAccumulator)],
    maps: &[DMatrix<f64>],
    acc: &mut RAccumulator,
) -> Result<()> {
    for (mask, pa) in pats {
        let rz = pa.r();
        for (o, map) in maps.iter().enumerate() {
            if mask & (1 << o) != 0 {
                acc.push_rows(&(&rz * map))?;
            }
        }
    }
    Ok(())
}

/// Most patterns of sampled outputs per record the streamed regression
/// keeps (it cannot restart on the direct route once data have passed).
pub(crate) const MAX_STREAM_PATTERNS: usize = 64;

/// The modal regression of [`accumulate`] fed in blocks of consecutive
/// samples (a second pass over a file): the filter states carry over from
/// block to block, so the rows are those of one scan of the record. Memory
/// O(patterns · BLOCK · q), independent of the record length.
#[derive(Clone, Serialize, Deserialize)]
pub(crate) struct ModalStream {
    form: ModalForm,
    lay: Layout,
    /// C̃ = C V of the scaled data.
    ct: DMatrix<f64>,
    inv: (f64, f64),
    state: FilterState,
    pats: Vec<(u64, RAccumulator)>,
    record: usize,
    rows: usize,
    threads: usize,
}

impl ModalStream {
    /// A stream for `form` with C of the data divided by `scale` (`c`);
    /// blocks of at least 2 × 20 000 samples are scanned on up to `threads`
    /// threads (as [`accumulate`] splits a record).
    pub(crate) fn new(
        form: ModalForm,
        c: &DMatrix<f64>,
        p: &Params,
        scale: DataScale,
        threads: usize,
    ) -> Self {
        let lay = Layout::of(p);
        let ct = c * &form.v;
        let state = FilterState::initial(&form, &lay);
        ModalStream {
            form,
            lay,
            ct,
            inv: (1.0 / scale.io.u, 1.0 / scale.io.y),
            state,
            pats: Vec::new(),
            record: 0,
            rows: 0,
            threads: threads.max(1),
        }
    }

    /// Scans the next samples of the current record; false when the
    /// record has more than [`MAX_STREAM_PATTERNS`] sampling patterns.
    pub(crate) fn push(&mut self, u: &DMatrix<f64>, y: &DMatrix<f64>) -> Result<bool> {
        let rec = Record {
            u,
            y,
            instrument: None,
        };
        let len = u.nrows();
        let parts = ranges(len, self.threads);
        if parts == 1 {
            let Some(sc) = scan(
                &self.form,
                &self.lay,
                &rec,
                self.inv,
                0..len,
                &mut self.state,
            )?
            else {
                return Ok(false);
            };
            self.rows += sc.rows;
            return merge_patterns(&mut self.pats, sc, MAX_STREAM_PATTERNS);
        }
        // The block's ranges from their starting states (a serial pass of
        // the filters), scanned on their own threads; the last range's
        // scan leaves the state at the end of the block.
        let per = len.div_ceil(parts);
        let mut end_state = None;
        for (sc, st) in scan_parallel(
            &self.form,
            &self.lay,
            &rec,
            self.inv,
            &self.state,
            (per, parts),
            self.threads,
        ) {
            let Some(sc) = sc? else {
                return Ok(false);
            };
            self.rows += sc.rows;
            if !merge_patterns(&mut self.pats, sc, MAX_STREAM_PATTERNS)? {
                return Ok(false);
            }
            end_state = Some(st);
        }
        if let Some(st) = end_state {
            self.state = st;
        }
        Ok(true)
    }

    /// Ends the current record: folds its patterns into `acc` and starts
    /// the next record from rest.
    pub(crate) fn end_record(&mut self, p: &Params, acc: &mut RAccumulator) -> Result<()> {
        let maps: Vec<DMatrix<f64>> = (0..self.lay.ny)
            .map(|o| row_map(&self.form, &self.ct, p, &self.lay, o, self.record))
            .collect();
        fold_patterns(&self.pats, &maps, acc)?;
        self.pats.clear();
        self.state = FilterState::initial(&self.form, &self.lay);
        self.record += 1;
        Ok(())
    }

    /// Sampled output entries seen so far.
    pub(crate) fn rows(&self) -> usize {
        self.rows
    }

    /// Samples after which the filters have forgotten their state to
    /// below [`NEGLIGIBLE`] of it (and the free response is gone):
    /// ⌈ln NEGLIGIBLE / ln ρ⌉ for the largest mode modulus ρ (each modal
    /// block scales its state by exactly |λ| per sample). `None` when
    /// ρ ≥ 1: the state is never forgotten.
    pub(crate) fn memory(&self) -> Option<usize> {
        let rho = self
            .form
            .modes
            .iter()
            .map(|m| match *m {
                Mode::Real(l) => l.abs(),
                Mode::Pair(a, b) => a.hypot(b),
            })
            .fold(0.0, f64::max);
        if rho == 0.0 {
            return Some(1);
        }
        let steps = (NEGLIGIBLE.ln() / rho.ln()).ceil();
        (rho < 1.0 && steps.is_finite() && steps < 1e15).then_some(steps as usize + 1)
    }

    /// Advances the filter states over the inputs of the next samples
    /// without making rows (2 n n_u flops per sample): the state at the
    /// start of a later shard.
    pub(crate) fn advance(&mut self, u: &DMatrix<f64>) {
        let rec = Record {
            u,
            y: u,
            instrument: None,
        };
        let mut t = 0;
        while t < u.nrows() && self.state.fr_live {
            self.state.step(&self.form, &rec, self.inv.0, t);
            t += 1;
        }
        if t < u.nrows() {
            self.state.run(&self.form, &rec, self.inv.0, t..u.nrows());
        }
    }

    /// A copy of the stream at its state with no rows: push a shard's
    /// blocks to it, then [`into_piece`](Self::into_piece).
    pub(crate) fn scanner(&self) -> ModalStream {
        ModalStream {
            pats: Vec::new(),
            rows: 0,
            ..self.clone()
        }
    }

    /// The pattern R factors and rows pushed to a [`scanner`](Self::scanner).
    pub(crate) fn into_piece(self) -> (Patterns, usize) {
        (self.pats, self.rows)
    }

    /// Adds pattern R factors scanned apart to the current record's; false
    /// beyond [`MAX_STREAM_PATTERNS`] patterns.
    pub(crate) fn absorb(&mut self, pats: Patterns, rows: usize) -> Result<bool> {
        self.rows += rows;
        let patterns = pats
            .into_iter()
            .map(|(mask, acc)| PatternAcc {
                mask,
                block: DMatrix::zeros(0, 0),
                used: 0,
                acc,
                narrow: None,
            })
            .collect();
        merge_patterns(
            &mut self.pats,
            Scan { patterns, rows: 0 },
            MAX_STREAM_PATTERNS,
        )
    }

    /// Whether the sizes are those of `p` (a state decoded from bytes).
    pub(crate) fn fits(&self, p: &Params) -> bool {
        let lay = Layout::of(p);
        let n = p.n;
        let blocks: usize = self
            .form
            .modes
            .iter()
            .map(|m| if matches!(m, Mode::Real(_)) { 1 } else { 2 })
            .sum();
        lay.width == self.lay.width
            && (self.lay.x0, self.lay.one, self.lay.y) == (lay.x0, lay.one, lay.y)
            && blocks == n
            && self.form.v.shape() == (n, n)
            && self.form.v_inv.shape() == (n, n)
            && self.ct.shape() == (p.ny, n)
            && self.state.w.len() == n * p.nu
            && self.state.fr.len() == n
            && self
                .pats
                .iter()
                .all(|(_, acc)| acc.ncols() == lay.width && acc.is_consistent())
    }
}

/// The filter states at the start of a range of instants: the input
/// filters' outputs w (n per input) and the free response Λᵗ (x₀ columns)
/// with whether it is still above [`NEGLIGIBLE`].
#[derive(Clone, Serialize, Deserialize)]
struct FilterState {
    w: Vec<f64>,
    fr: Vec<f64>,
    fr_live: bool,
}

impl FilterState {
    /// The state at t = 0.
    fn initial(form: &ModalForm, lay: &Layout) -> Self {
        // Free response Λᵗ (first column of each block: (1) or (1, 0)).
        let mut fr = vec![0.0; lay.n];
        let mut i = 0;
        for m in &form.modes {
            fr[i] = 1.0;
            i += if matches!(m, Mode::Real(_)) { 1 } else { 2 };
        }
        FilterState {
            w: vec![0.0; lay.n * lay.nu],
            fr,
            fr_live: lay.x0.is_some(),
        }
    }

    /// Advances by the input row `t` of `rec` (inputs times `iu`): the
    /// same operations as the scan, so the states are bit for bit those
    /// the scan holds at the next instant. Inlined into its callers (see
    /// [`ModalForm::step`]).
    #[inline(always)]
    fn step(&mut self, form: &ModalForm, rec: &Record<'_>, iu: f64, t: usize) {
        let n = self.fr.len();
        for (j, wj) in self.w.chunks_exact_mut(n).enumerate() {
            form.step(wj, rec.u[(t, j)] * iu);
        }
        if self.fr_live {
            form.step(&mut self.fr, 0.0);
            if self.fr.iter().all(|v| v.abs() < NEGLIGIBLE) {
                self.fr.fill(0.0);
                self.fr_live = false;
            }
        }
    }

    /// Advances over the instants `ts` once the free response is gone
    /// (`fr_live` false): each filter over the stretch at once, the
    /// numbers of [`step`](Self::step) at every instant.
    fn run(&mut self, form: &ModalForm, rec: &Record<'_>, iu: f64, ts: std::ops::Range<usize>) {
        debug_assert!(!self.fr_live);
        form.run(&mut self.w, rec.u, iu, ts, None);
    }

    /// Advances to `ts.end` without the values in between, once the free
    /// response is gone: [`ModalForm::jump`] (the recursion's values up to
    /// rounding).
    fn jump(&mut self, form: &ModalForm, rec: &Record<'_>, iu: f64, ts: std::ops::Range<usize>) {
        debug_assert!(!self.fr_live);
        form.jump(&mut self.w, rec.u, iu, ts);
    }

    /// The states at t = 0, per, 2·per, … (`parts` of them) of a scan of
    /// `rec` that starts from `st`: the recursions step by step while the
    /// free response lives, then [`FilterState::jump`] (so the later
    /// ranges start from the single scan's states up to rounding).
    fn at(
        mut st: FilterState,
        form: &ModalForm,
        rec: &Record<'_>,
        iu: f64,
        per: usize,
        parts: usize,
    ) -> Vec<FilterState> {
        let mut out = vec![st.clone()];
        let end = (per * (parts - 1)).min(rec.u.nrows());
        let mut t = 0;
        while t < end {
            let next = ((t / per + 1) * per).min(end);
            if st.fr_live {
                st.step(form, rec, iu, t);
                t += 1;
            } else {
                st.jump(form, rec, iu, t..next);
                t = next;
            }
            if t % per == 0 {
                out.push(st.clone());
            }
        }
        out
    }
}

/// The patterns of one range of instants and its sampled output entries.
struct Scan {
    patterns: Vec<PatternAcc>,
    rows: usize,
}

/// The base rows of the instants `range` of `rec` (inputs times `inv.0`,
/// outputs times `inv.1`) from the filter state at its start, reduced per
/// sampling pattern to R factors; `None` beyond [`MAX_PATTERNS`] patterns.
fn scan(
    form: &ModalForm,
    lay: &Layout,
    rec: &Record<'_>,
    inv: (f64, f64),
    range: std::ops::Range<usize>,
    st: &mut FilterState,
) -> Result<Option<Scan>> {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            let (iu, iy) = inv;
            let (n, nu, ny) = (lay.n, lay.nu, lay.ny);
            let mut pats: Vec<PatternAcc> = Vec::new();
            let mut rows = 0;
            let mut t = range.start;
            while t < range.end {
                if !st.fr_live {
                    // Once the free response is gone (or not estimated): runs of
                    // instants with one sampling pattern, column by column.
                    let mask = pattern(rec.y, t);
                    let mut end = t + 1;
                    while end < range.end && pattern(rec.y, end) == mask {
                        end += 1;
                    }
                    if mask == 0 {
                        st.run(form, rec, iu, t..end);
                        t = end;
                        continue;
                    }
                    let Some((pa, shift)) = accumulator(&mut pats, mask, lay, lay.x0.is_some())
                    else {
                        return Ok(None);
                    };
                    while t < end {
                        let len = (end - t).min(BLOCK - pa.used);
                        fill_rows(form, lay, rec, inv, st, pa, shift, t..t + len);
                        pa.used += len;
                        if pa.used == BLOCK {
                            pa.flush()?;
                        }
                        rows += mask.count_ones() as usize * len;
                        t += len;
                    }
                    continue;
                }
                let mask = pattern(rec.y, t);
                if mask != 0 {
                    // Once the free response has died out the row's x₀ columns are
                    // zero: it goes to the narrow accumulator without them (the
                    // columns after them shift left by n).
                    let narrow = lay.x0.is_some() && !st.fr_live;
                    let Some((pa, shift)) = accumulator(&mut pats, mask, lay, narrow) else {
                        return Ok(None);
                    };
                    // Row `used` of the column-major block: entry (row, col) at
                    // col·BLOCK + row.
                    let row = pa.used;
                    let blk = pa.block.as_mut_slice();
                    let mut put = |col: usize, v: f64| blk[col * BLOCK + row] = v;
                    for (col, &v) in st.w.iter().enumerate() {
                        put(col, v);
                    }
                    for j in 0..nu {
                        put(n * nu + j, rec.u[(t, j)] * iu);
                    }
                    if let (Some(x0), 0) = (lay.x0, shift) {
                        for (i, &v) in st.fr.iter().enumerate() {
                            put(x0 + i, v);
                        }
                    }
                    if let Some(one) = lay.one {
                        put(one - shift, 1.0);
                    }
                    for o in 0..ny {
                        let v = rec.y[(t, o)];
                        put(lay.y - shift + o, if v.is_nan() { 0.0 } else { v * iy });
                    }
                    pa.used += 1;
                    if pa.used == BLOCK {
                        pa.flush()?;
                    }
                    rows += mask.count_ones() as usize;
                }
                st.step(form, rec, iu, t);
                t += 1;
            }
            for pa in &mut pats {
                pa.finish(lay.x0, n)?;
            }
            Ok(Some(Scan {
                patterns: pats,
                rows,
            }))
        },
    )
}

/// The accumulator of sampling pattern `mask` in `pats` (a new one for a
/// new pattern; `None` beyond [`MAX_PATTERNS`]): its rows' block, or with
/// `narrow` (the free response gone) its narrow block without the n x₀
/// columns, and the columns' shift (0 or n).
fn accumulator<'p>(
    pats: &'p mut Vec<PatternAcc>,
    mask: u64,
    lay: &Layout,
    narrow: bool,
) -> Option<(&'p mut PatternAcc, usize)> {
    let k = match pats.iter().position(|pa| pa.mask == mask) {
        Some(k) => k,
        None if pats.len() == MAX_PATTERNS => return None,
        None => {
            pats.push(PatternAcc::new(mask, lay.width));
            pats.len() - 1
        }
    };
    let n = lay.n;
    Some(if narrow {
        (
            &mut **pats[k]
                .narrow
                .get_or_insert_with(|| Box::new(PatternAcc::new(mask, lay.width - n))),
            n,
        )
    } else {
        (&mut pats[k], 0)
    })
}

/// The base rows of the instants `ts` (one sampling pattern, the free
/// response gone) written into `pa`'s block from its row `pa.used` on,
/// column by column: the filter columns by [`ModalForm::run`], the inputs,
/// the constant and the outputs (NaN, not sampled, as 0) by plain loops;
/// `shift`: the x₀ columns left out (the narrow block). The filter state
/// ends at `ts.end`. The same numbers as the row-by-row scan.
#[allow(clippy::too_many_arguments)]
fn fill_rows(
    form: &ModalForm,
    lay: &Layout,
    rec: &Record<'_>,
    inv: (f64, f64),
    st: &mut FilterState,
    pa: &mut PatternAcc,
    shift: usize,
    ts: std::ops::Range<usize>,
) {
    let (iu, iy) = inv;
    let (n, row, len) = (lay.n, pa.used, ts.len());
    let blk = pa.block.as_mut_slice();
    // Column j of `m` over the instants `ts`.
    fn column<'m>(m: &'m DMatrix<f64>, j: usize, ts: &std::ops::Range<usize>) -> &'m [f64] {
        let at = j * m.nrows();
        &m.as_slice()[at + ts.start..at + ts.end]
    }
    form.run(
        &mut st.w,
        rec.u,
        iu,
        ts.clone(),
        Some((&mut *blk, BLOCK, row)),
    );
    let at = |c: usize| c * BLOCK + row..c * BLOCK + row + len;
    for j in 0..lay.nu {
        for (o, &v) in blk[at(n * lay.nu + j)]
            .iter_mut()
            .zip(column(rec.u, j, &ts))
        {
            *o = v * iu;
        }
    }
    if let Some(one) = lay.one {
        blk[at(one - shift)].fill(1.0);
    }
    for o in 0..lay.ny {
        for (d, &v) in blk[at(lay.y - shift + o)]
            .iter_mut()
            .zip(column(rec.y, o, &ts))
        {
            *d = if v.is_nan() { 0.0 } else { v * iy };
        }
    }
}

mod lanes;

#[cfg(test)]
mod tests;

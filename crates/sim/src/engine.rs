//! The allocation-free inner loop: small dense blocks on slices.

use lifted_linalg::dot;
use lifted_lti::StateSpace;
use nalgebra::DMatrix;

use crate::error::{Error, Result};

/// A discrete (A, B, C, D) stored row-major in flat vectors for the inner
/// loop. Each row product is a dot product with four independent partial
/// sums, and rows are independent, so the CPU overlaps them.
#[derive(Debug, Clone)]
pub(crate) struct Block {
    pub n: usize,
    pub m: usize,
    pub p: usize,
    a: Vec<f64>,
    b: Vec<f64>,
    c: Vec<f64>,
    d: Vec<f64>,
    pub has_d: bool,
}

fn row_major(m: &DMatrix<f64>) -> Vec<f64> {
    let (r, c) = m.shape();
    let mut v = Vec::with_capacity(r * c);
    for i in 0..r {
        for j in 0..c {
            v.push(m[(i, j)]);
        }
    }
    v
}

impl Block {
    pub fn new(ss: &StateSpace) -> Self {
        let d = row_major(ss.d());
        Block {
            n: ss.order(),
            m: ss.n_inputs(),
            p: ss.n_outputs(),
            a: row_major(ss.a()),
            b: row_major(ss.b()),
            c: row_major(ss.c()),
            has_d: d.iter().any(|&x| x != 0.0),
            d,
        }
    }

    /// D entry (i, j).
    #[inline(always)]
    pub fn d_at(&self, i: usize, j: usize) -> f64 {
        self.d[i * self.m + j]
    }

    /// y = C x.
    #[inline(always)]
    pub fn cx(&self, x: &[f64], y: &mut [f64]) {
        let n = self.n;
        if n == 0 {
            y[..self.p].fill(0.0);
            return;
        }
        for (yi, row) in y[..self.p].iter_mut().zip(self.c.chunks_exact(n)) {
            *yi = dot(row, x);
        }
    }

    /// y += D u.
    #[inline(always)]
    pub fn add_du(&self, u: &[f64], y: &mut [f64]) {
        if !self.has_d {
            return;
        }
        for (yi, row) in y[..self.p].iter_mut().zip(self.d.chunks_exact(self.m)) {
            *yi += dot(row, u);
        }
    }

    /// (D u)_i.
    #[inline(always)]
    pub fn du_row(&self, i: usize, u: &[f64]) -> f64 {
        dot(&self.d[i * self.m..(i + 1) * self.m], u)
    }

    /// xn = A x + B u.
    #[inline(always)]
    pub fn update(&self, x: &[f64], u: &[f64], xn: &mut [f64]) {
        let (n, m) = (self.n, self.m);
        if n == 0 {
            return;
        }
        if m == 0 {
            for (xi, ar) in xn[..n].iter_mut().zip(self.a.chunks_exact(n)) {
                *xi = dot(ar, x);
            }
            return;
        }
        for ((xi, ar), br) in xn[..n]
            .iter_mut()
            .zip(self.a.chunks_exact(n))
            .zip(self.b.chunks_exact(m))
        {
            *xi = dot(ar, x) + dot(br, u);
        }
    }
}

/// How the controller sees the outputs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FeedbackKind {
    Fast,
    HoldLast,
    Inferential,
}

/// The loop structure compiled to blocks (built once per run; size is irrelevant).
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
pub(crate) enum Structure {
    Loop {
        g: Block,
        k: Option<Block>,
        phat: Option<Block>,
        feedback: FeedbackKind,
    },
    Whole {
        cl: Block,
    },
}

/// A compiled simulator: structure, sampling pattern, per-phase solves.
#[derive(Debug, Clone)]
pub(crate) struct Engine {
    pub structure: Structure,
    pub ny: usize,
    pub nu: usize,
    pub frame: usize,
    /// frame × nu: whether input i starts a hold block at this phase.
    start_mask: Vec<bool>,
    /// frame × ny: whether output j is sampled at this phase.
    sample_mask: Vec<bool>,
    /// Per phase: (I + S_h D_K D_v)⁻¹ row-major, when it is not the identity.
    solve: Vec<Option<Vec<f64>>>,
    pub limit: f64,
    // state layout
    pub nz: usize,
    off_k: usize,
    off_p: usize,
    off_u: usize,
    /// The per-phase matrices of the fast path (None: reference path).
    fused: Option<Fused>,
}

/// Inputs of one run.
pub(crate) struct RunInput<'a> {
    pub r1: Option<&'a DMatrix<f64>>,
    pub r2: Option<&'a DMatrix<f64>>,
    /// Raw noise (N × ny) and its per-channel scale.
    pub noise: Option<(&'a DMatrix<f64>, &'a [f64])>,
    pub len: usize,
}

/// Recorded signals of one run (column-major N × channels).
pub(crate) struct Record {
    pub u: DMatrix<f64>,
    pub y: DMatrix<f64>,
    pub y_clean: DMatrix<f64>,
}

impl Engine {
    pub fn new(
        structure: Structure,
        ny: usize,
        nu: usize,
        holds: &[(usize, usize)],
        sampling: &[(usize, usize)],
        limit: f64,
    ) -> Result<Self> {
        let frame = holds
            .iter()
            .map(|h| h.0)
            .chain(sampling.iter().map(|s| s.0))
            .fold(1, lcm);
        let mut start_mask = vec![false; frame * nu];
        let mut sample_mask = vec![false; frame * ny];
        for ph in 0..frame {
            for (i, &(h, o)) in holds.iter().enumerate() {
                start_mask[ph * nu + i] = ph % h == o;
            }
            for (j, &(p, o)) in sampling.iter().enumerate() {
                sample_mask[ph * ny + j] = ph % p == o;
            }
        }
        let (nz, off_k, off_p, off_u) = match &structure {
            Structure::Loop { g, k, phat, .. } => {
                let nk = k.as_ref().map_or(0, |b| b.n);
                let np = phat.as_ref().map_or(0, |b| b.n);
                let off_k = g.n;
                let off_p = off_k + nk;
                let off_u = off_p + np;
                let off_v = off_u + nu;
                (off_v + ny, off_k, off_p, off_u)
            }
            Structure::Whole { cl } => (cl.n, cl.n, cl.n, cl.n),
        };
        let mut solve = vec![None; frame];
        if let Structure::Loop {
            g,
            k: Some(kb),
            phat,
            feedback,
        } = &structure
        {
            for (ph, slot) in solve.iter_mut().enumerate() {
                // F = I + S_h D_K D_v
                let mut f = DMatrix::<f64>::identity(nu, nu);
                let mut nonzero = false;
                for i in 0..nu {
                    if !start_mask[ph * nu + i] {
                        continue;
                    }
                    for c in 0..nu {
                        let mut s = 0.0;
                        for j in 0..ny {
                            let sampled = sample_mask[ph * ny + j];
                            let dv = match feedback {
                                FeedbackKind::Fast => g.d_at(j, c),
                                FeedbackKind::HoldLast => {
                                    if sampled {
                                        g.d_at(j, c)
                                    } else {
                                        0.0
                                    }
                                }
                                FeedbackKind::Inferential => {
                                    if sampled {
                                        g.d_at(j, c)
                                    } else {
                                        phat.as_ref().map_or(0.0, |p| p.d_at(j, c))
                                    }
                                }
                            };
                            s += kb.d_at(i, j) * dv;
                        }
                        if s != 0.0 {
                            nonzero = true;
                            f[(i, c)] += s;
                        }
                    }
                }
                if nonzero {
                    let finv =
                        lifted_linalg::inv(&f).map_err(|_| Error::AlgebraicLoop { phase: ph })?;
                    *slot = Some(row_major(&finv));
                }
            }
        }
        let mut engine = Engine {
            structure,
            ny,
            nu,
            frame,
            start_mask,
            sample_mask,
            solve,
            limit,
            nz,
            off_k,
            off_p,
            off_u,
            fused: None,
        };
        engine.fused = engine.build_fused();
        Ok(engine)
    }

    /// One step of the loop at phase `ph` (the reference arithmetic):
    /// from state `z` and the inputs of this sample, writes the next state
    /// to `zn`, the plant output without the added noise term to `s.yc` and
    /// the plant input to `s.u`.
    #[allow(clippy::too_many_arguments)]
    fn step_ref(
        &self,
        ph: usize,
        z: &[f64],
        r1: &[f64],
        r2: &[f64],
        nse: &[f64],
        s: &mut Scratch,
        zn: &mut [f64],
    ) {
        let (ny, nu) = (self.ny, self.nu);
        match &self.structure {
            Structure::Loop {
                g,
                k: kb,
                phat,
                feedback,
            } => {
                let (xg, rest) = z.split_at(g.n);
                let (xk, rest) = rest.split_at(self.off_p - self.off_k);
                let (xp, rest) = rest.split_at(self.off_u - self.off_p);
                let (uprev, vheld) = rest.split_at(nu);
                let yg = &mut s.yc;
                g.cx(xg, yg);
                if let Some(p) = phat {
                    p.cx(xp, &mut s.yp);
                }
                let smask = &self.sample_mask[ph * ny..(ph + 1) * ny];
                for j in 0..ny {
                    let vf = match feedback {
                        FeedbackKind::Fast => yg[j] + nse[j],
                        FeedbackKind::HoldLast => {
                            if smask[j] {
                                yg[j] + nse[j]
                            } else {
                                vheld[j]
                            }
                        }
                        FeedbackKind::Inferential => {
                            if smask[j] {
                                yg[j] + nse[j]
                            } else {
                                s.yp[j]
                            }
                        }
                    };
                    s.efree[j] = r1[j] - vf;
                }
                if let Some(kb) = kb {
                    kb.cx(xk, &mut s.yk);
                    kb.add_du(&s.efree, &mut s.yk);
                }
                let hmask = &self.start_mask[ph * nu..(ph + 1) * nu];
                for i in 0..nu {
                    s.a[i] = if hmask[i] {
                        r2[i] + if kb.is_some() { s.yk[i] } else { 0.0 }
                    } else {
                        uprev[i]
                    };
                }
                let u = &mut s.u;
                match &self.solve[ph] {
                    Some(minv) => {
                        for (i, ui) in u.iter_mut().enumerate() {
                            *ui = minv[i * nu..(i + 1) * nu]
                                .iter()
                                .zip(&s.a)
                                .map(|(m, a)| m * a)
                                .sum();
                        }
                    }
                    None => u.copy_from_slice(&s.a),
                }
                // y = Cg x + Dg u ; v
                g.add_du(u, yg);
                for j in 0..ny {
                    let ym = yg[j] + nse[j];
                    s.v[j] = match feedback {
                        FeedbackKind::Fast => ym,
                        FeedbackKind::HoldLast => {
                            if smask[j] {
                                ym
                            } else {
                                vheld[j]
                            }
                        }
                        FeedbackKind::Inferential => {
                            if smask[j] {
                                ym
                            } else {
                                s.yp[j]
                                    + phat
                                        .as_ref()
                                        .map_or(0.0, |p| if p.has_d { p.du_row(j, u) } else { 0.0 })
                            }
                        }
                    };
                    s.efree[j] = r1[j] - s.v[j];
                }
                let (xgn, rest) = zn.split_at_mut(g.n);
                let (xkn, rest) = rest.split_at_mut(self.off_p - self.off_k);
                let (xpn, rest) = rest.split_at_mut(self.off_u - self.off_p);
                let (un, vn) = rest.split_at_mut(nu);
                g.update(xg, u, xgn);
                if let Some(kb) = kb {
                    kb.update(xk, &s.efree, xkn);
                }
                if let Some(p) = phat {
                    p.update(xp, u, xpn);
                }
                un.copy_from_slice(u);
                vn.copy_from_slice(&s.v);
            }
            Structure::Whole { cl } => {
                s.rin[..ny].copy_from_slice(r1);
                s.rin[ny..].copy_from_slice(r2);
                cl.cx(z, &mut s.out);
                cl.add_du(&s.rin, &mut s.out);
                cl.update(z, &s.rin, zn);
                s.yc.copy_from_slice(&s.out[..ny]);
                s.u.copy_from_slice(&s.out[ny..]);
            }
        }
    }

    /// Runs `inp.len` steps from state `z0` (length nz), returning the final
    /// state; records the signals when `rec` is given (its matrices must be
    /// len × channels). Uses the fused per-phase matrices when they were
    /// built (see [`Fused`]), else [`Engine::run_reference`].
    pub fn run(
        &self,
        z0: &[f64],
        inp: &RunInput<'_>,
        rec: Option<&mut Record>,
    ) -> Result<Vec<f64>> {
        match &self.fused {
            Some(f) => match f.rows {
                4 => self.run_fused::<4>(f, z0, inp, rec),
                8 => self.run_fused::<8>(f, z0, inp, rec),
                12 => self.run_fused::<12>(f, z0, inp, rec),
                16 => self.run_fused::<16>(f, z0, inp, rec),
                20 => self.run_fused::<20>(f, z0, inp, rec),
                24 => self.run_fused::<24>(f, z0, inp, rec),
                28 => self.run_fused::<28>(f, z0, inp, rec),
                32 => self.run_fused::<32>(f, z0, inp, rec),
                _ => self.run_fused::<0>(f, z0, inp, rec),
            },
            None => self.run_reference(z0, inp, rec),
        }
    }

    /// The reference path: the loop stepped block by block (plant,
    /// controller, parallel model, holds, feedback switch) at every sample.
    /// O(len · (n² + nm)) with no allocation in the loop.
    pub fn run_reference(
        &self,
        z0: &[f64],
        inp: &RunInput<'_>,
        mut rec: Option<&mut Record>,
    ) -> Result<Vec<f64>> {
        let (ny, nu, len) = (self.ny, self.nu, inp.len);
        let mut z = z0.to_vec();
        let mut zn = vec![0.0; self.nz];
        let mut s = Scratch::new(ny, nu);
        let mut nse = vec![0.0; ny];
        let mut r1 = vec![0.0; ny];
        let mut r2 = vec![0.0; nu];
        let r1s = inp.r1.map(|m| m.as_slice());
        let r2s = inp.r2.map(|m| m.as_slice());
        let noise = inp.noise.map(|(m, s)| (m.as_slice(), s));
        let limit = self.limit;
        let mut ph = 0usize;
        for k in 0..len {
            if let Some(src) = r1s {
                for (j, r) in r1.iter_mut().enumerate() {
                    *r = src[j * len + k];
                }
            }
            if let Some(src) = r2s {
                for (i, r) in r2.iter_mut().enumerate() {
                    *r = src[i * len + k];
                }
            }
            if let Some((src, scale)) = noise {
                for (j, e) in nse.iter_mut().enumerate() {
                    *e = scale[j] * src[j * len + k];
                }
            }
            self.step_ref(ph, &z, &r1, &r2, &nse, &mut s, &mut zn);
            if let Some(rec) = rec.as_deref_mut() {
                record(rec, k, len, &s.yc, &s.u, &nse);
            }
            check(k, &s.yc, &s.u, limit)?;
            std::mem::swap(&mut z, &mut zn);
            ph += 1;
            if ph == self.frame {
                ph = 0;
            }
        }
        Ok(z)
    }

    /// Builds the fused per-phase matrices by stepping the reference loop
    /// on unit vectors (the step is linear in state and inputs). None when
    /// they would take more than [`FUSED_MAX_ENTRIES`] numbers.
    fn build_fused(&self) -> Option<Fused> {
        let (nz, ny, nu) = (self.nz, self.ny, self.nu);
        let nw = nz + ny + nu + ny;
        let nout = nz + ny + nu;
        let rows = nout.div_ceil(4) * 4;
        if self.frame.saturating_mul(rows).saturating_mul(nw) > FUSED_MAX_ENTRIES {
            return None;
        }
        // full matrices, column-major rows × nw per phase
        let mut full = vec![0.0; self.frame * rows * nw];
        let mut s = Scratch::new(ny, nu);
        let mut w = vec![0.0; nw];
        let mut zn = vec![0.0; nz];
        for ph in 0..self.frame {
            for c in 0..nw {
                w.fill(0.0);
                w[c] = 1.0;
                let (z, rest) = w.split_at(nz);
                let (r1, rest) = rest.split_at(ny);
                let (r2, nse) = rest.split_at(nu);
                self.step_ref(ph, z, r1, r2, nse, &mut s, &mut zn);
                let col = &mut full[(ph * nw + c) * rows..(ph * nw + c + 1) * rows];
                col[..nz].copy_from_slice(&zn);
                col[nz..nz + ny].copy_from_slice(&s.yc);
                col[nz + ny..nout].copy_from_slice(&s.u);
            }
        }
        let used = |c: usize| {
            (0..self.frame).any(|ph| {
                full[(ph * nw + c) * rows..(ph * nw + c + 1) * rows]
                    .iter()
                    .any(|&x| x != 0.0)
            })
        };
        // Column order: the dynamic states first (plant, controller,
        // parallel model), then the inputs of the step with each held input
        // next to its excitation (u_prev,i, r2_i), so that a held and a
        // directly applied input sum in the same order.
        let n_dyn = match &self.structure {
            Structure::Loop { .. } => self.off_u,
            Structure::Whole { .. } => nz,
        };
        let (o_r1, o_r2, o_n) = (nz, nz + ny, nz + ny + nu);
        let mut order: Vec<usize> = (0..n_dyn).collect();
        if n_dyn < nz {
            for i in 0..nu {
                order.push(self.off_u + i);
                order.push(o_r2 + i);
            }
            for j in 0..ny {
                order.push(self.off_u + nu + j);
            }
        } else {
            order.extend(o_r2..o_r2 + nu);
        }
        order.extend(o_r1..o_r1 + ny);
        order.extend(o_n..o_n + ny);
        let mut cols = Vec::new();
        let mut split = 0;
        for &c in &order {
            if used(c) {
                cols.push(c);
                if c < n_dyn {
                    split += 1;
                }
            }
        }
        let nc = cols.len();
        let mut mats = vec![0.0; self.frame * nc * rows];
        for ph in 0..self.frame {
            for (ci, &c) in cols.iter().enumerate() {
                mats[(ph * nc + ci) * rows..(ph * nc + ci + 1) * rows]
                    .copy_from_slice(&full[(ph * nw + c) * rows..(ph * nw + c + 1) * rows]);
            }
        }
        Some(Fused {
            rows,
            cols,
            split,
            mats,
        })
    }

    /// The fused loop: per sample one product of the phase's matrix with the
    /// stacked vector w = [z; r₁; r₂; noise] (active columns only), column
    /// by column into `R` accumulators (`R` = 0: run-time row count).
    fn run_fused<const R: usize>(
        &self,
        f: &Fused,
        z0: &[f64],
        inp: &RunInput<'_>,
        mut rec: Option<&mut Record>,
    ) -> Result<Vec<f64>> {
        let (nz, ny, nu, len) = (self.nz, self.ny, self.nu, inp.len);
        let rows = f.rows;
        let nc = f.cols.len();
        let nw = nz + 2 * ny + nu;
        let mut w = vec![0.0; nw];
        w[..nz].copy_from_slice(z0);
        let mut out = vec![0.0; rows];
        let mut acc_dyn = vec![0.0; if R > 0 { 0 } else { rows }];
        let mut nse = vec![0.0; ny];
        let r1s = inp.r1.map(|m| m.as_slice());
        let r2s = inp.r2.map(|m| m.as_slice());
        let noise = inp.noise.map(|(m, s)| (m.as_slice(), s));
        let limit = self.limit;
        let (o_r1, o_r2, o_n) = (nz, nz + ny, nz + ny + nu);
        let (cols_a, cols_b) = f.cols.split_at(f.split);
        let mut ph = 0usize;
        for k in 0..len {
            if let Some(src) = r1s {
                for j in 0..ny {
                    w[o_r1 + j] = src[j * len + k];
                }
            }
            if let Some(src) = r2s {
                for i in 0..nu {
                    w[o_r2 + i] = src[i * len + k];
                }
            }
            if let Some((src, scale)) = noise {
                for j in 0..ny {
                    let e = scale[j] * src[j * len + k];
                    nse[j] = e;
                    w[o_n + j] = e;
                }
            }
            let m = &f.mats[ph * nc * rows..(ph + 1) * nc * rows];
            let (ma, mb) = m.split_at(f.split * rows);
            if R > 0 {
                // two partial sums over the state columns (halves the
                // dependent chain), one over the inputs
                let mut acc_a = [0.0f64; R];
                let mut acc_a2 = [0.0f64; R];
                let mut acc_b = [0.0f64; R];
                let mut pairs = ma.chunks_exact(2 * R).zip(cols_a.chunks_exact(2));
                for (col, c) in pairs.by_ref() {
                    let (m0, m1) = col.split_at(R);
                    axpy(&mut acc_a, m0, w[c[0]]);
                    axpy(&mut acc_a2, m1, w[c[1]]);
                }
                if let Some(&c) = cols_a.get(cols_a.len() / 2 * 2) {
                    axpy(&mut acc_a, &ma[(cols_a.len() - 1) * R..], w[c]);
                }
                for (col, &c) in mb.chunks_exact(R).zip(cols_b) {
                    axpy(&mut acc_b, col, w[c]);
                }
                for r in 0..R {
                    out[r] = (acc_a[r] + acc_a2[r]) + acc_b[r];
                }
            } else {
                out.fill(0.0);
                acc_dyn.fill(0.0);
                let acc_b = &mut acc_dyn;
                for (col, &c) in ma.chunks_exact(rows).zip(cols_a) {
                    let x = w[c];
                    for (a, m) in out.iter_mut().zip(col) {
                        *a += m * x;
                    }
                }
                for (col, &c) in mb.chunks_exact(rows).zip(cols_b) {
                    let x = w[c];
                    for (a, m) in acc_b.iter_mut().zip(col) {
                        *a += m * x;
                    }
                }
                for (o, b) in out.iter_mut().zip(acc_b.iter()) {
                    *o += b;
                }
            }
            let yc = &out[nz..nz + ny];
            let u = &out[nz + ny..nz + ny + nu];
            if let Some(rec) = rec.as_deref_mut() {
                record(rec, k, len, yc, u, &nse);
            }
            if !yc.iter().chain(u).all(|v| v.abs() <= limit) {
                check(k, yc, u, limit)?;
            }
            w[..nz].copy_from_slice(&out[..nz]);
            ph += 1;
            if ph == self.frame {
                ph = 0;
            }
        }
        Ok(w[..nz].to_vec())
    }
}

/// acc += x · col[..R] on a fixed-size block (vectorised; `col` has at
/// least R entries by construction).
#[inline(always)]
fn axpy<const R: usize>(acc: &mut [f64; R], col: &[f64], x: f64) {
    if let Some(col) = col.first_chunk::<R>() {
        for r in 0..R {
            acc[r] += col[r] * x;
        }
    }
}

/// Most numbers the fused per-phase matrices may take (frame · rows ·
/// columns); beyond it the reference path runs (128 MiB).
const FUSED_MAX_ENTRIES: usize = 1 << 24;

/// The loop compiled to one affine map per phase of the sampling pattern:
/// [z(k+1); y_clean(k); u(k)] = M_ph [z(k); r₁(k); r₂(k); noise(k)].
/// Columns that are zero in every phase are dropped; rows are padded to a
/// multiple of 4. The dynamic-state columns (`cols[..split]`) and the input
/// columns are summed separately and added last.
#[derive(Debug, Clone)]
pub(crate) struct Fused {
    rows: usize,
    cols: Vec<usize>,
    split: usize,
    /// frame × (cols.len() × rows), column-major per phase.
    mats: Vec<f64>,
}

/// Per-step work space of the reference step.
struct Scratch {
    yc: Vec<f64>,
    yp: Vec<f64>,
    yk: Vec<f64>,
    efree: Vec<f64>,
    a: Vec<f64>,
    u: Vec<f64>,
    v: Vec<f64>,
    rin: Vec<f64>,
    out: Vec<f64>,
}

impl Scratch {
    fn new(ny: usize, nu: usize) -> Self {
        Scratch {
            yc: vec![0.0; ny],
            yp: vec![0.0; ny],
            yk: vec![0.0; nu],
            efree: vec![0.0; ny],
            a: vec![0.0; nu],
            u: vec![0.0; nu],
            v: vec![0.0; ny],
            rin: vec![0.0; ny + nu],
            out: vec![0.0; ny + nu],
        }
    }
}

/// Writes sample k of u, y_clean and y = y_clean + noise.
#[inline(always)]
fn record(rec: &mut Record, k: usize, len: usize, yc: &[f64], u: &[f64], nse: &[f64]) {
    let us = rec.u.as_mut_slice();
    for (i, &ui) in u.iter().enumerate() {
        us[i * len + k] = ui;
    }
    let ycs = rec.y_clean.as_mut_slice();
    for (j, &y) in yc.iter().enumerate() {
        ycs[j * len + k] = y;
    }
    let ys = rec.y.as_mut_slice();
    for (j, (&y, &e)) in yc.iter().zip(nse).enumerate() {
        ys[j * len + k] = y + e;
    }
}

#[inline(always)]
fn check(k: usize, y: &[f64], u: &[f64], limit: f64) -> Result<()> {
    for &v in y {
        if v.is_nan() || v.abs() > limit {
            return Err(Error::Diverged {
                sample: k,
                signal: "y",
                value: v,
                limit,
            });
        }
    }
    for &v in u {
        if v.is_nan() || v.abs() > limit {
            return Err(Error::Diverged {
                sample: k,
                signal: "u",
                value: v,
                limit,
            });
        }
    }
    Ok(())
}

pub(crate) fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}

pub(crate) fn lcm(a: usize, b: usize) -> usize {
    if a == 0 || b == 0 {
        a.max(b)
    } else {
        a / gcd(a, b) * b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_products_match_nalgebra() {
        let a = DMatrix::from_fn(3, 3, |i, j| (i * 3 + j) as f64 * 0.1 - 0.4);
        let b = DMatrix::from_fn(3, 2, |i, j| (i + 2 * j) as f64 - 1.0);
        let c = DMatrix::from_fn(2, 3, |i, j| (i as f64 - j as f64) * 0.3);
        let d = DMatrix::from_fn(2, 2, |i, j| if i == j { 0.5 } else { 0.0 });
        let ss = StateSpace::new(a.clone(), b.clone(), c.clone(), d.clone(), Some(1.0)).unwrap();
        let blk = Block::new(&ss);
        let x = [0.3, -1.0, 2.0];
        let u = [1.5, -0.5];
        let (xv, uv) = (
            nalgebra::DVector::from_column_slice(&x),
            nalgebra::DVector::from_column_slice(&u),
        );
        let mut y = [0.0; 2];
        blk.cx(&x, &mut y);
        blk.add_du(&u, &mut y);
        let yr = &c * &xv + &d * &uv;
        let mut xn = [0.0; 3];
        blk.update(&x, &u, &mut xn);
        let xr = &a * &xv + &b * &uv;
        for i in 0..2 {
            assert!((y[i] - yr[i]).abs() < 1e-14);
            assert!((blk.du_row(i, &u) - (&d * &uv)[i]).abs() < 1e-15);
        }
        for i in 0..3 {
            assert!((xn[i] - xr[i]).abs() < 1e-14);
        }
    }

    #[test]
    fn fused_matrices_are_built_and_match_the_reference_step() {
        // plant 2 states, PI controller, holds (2, 3) and sampling (3, 1):
        // frame 6, the fast path must be active (else the fast-path tests
        // would compare the reference with itself)
        let g = StateSpace::new(
            DMatrix::from_row_slice(2, 2, &[0.9, 0.1, 0.0, 0.7]),
            DMatrix::from_row_slice(2, 2, &[1.0, 0.2, 0.0, 0.5]),
            DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.3, 1.0]),
            DMatrix::zeros(2, 2),
            Some(1.0),
        )
        .unwrap();
        let k = StateSpace::new(
            DMatrix::identity(2, 2),
            DMatrix::identity(2, 2) * 0.1,
            DMatrix::identity(2, 2),
            DMatrix::identity(2, 2) * 0.5,
            Some(1.0),
        )
        .unwrap();
        let e = Engine::new(
            Structure::Loop {
                g: Block::new(&g),
                k: Some(Block::new(&k)),
                phat: None,
                feedback: FeedbackKind::HoldLast,
            },
            2,
            2,
            &[(2, 0), (3, 1)],
            &[(3, 1), (1, 0)],
            1e12,
        )
        .unwrap();
        assert_eq!(e.frame, 6);
        assert!(e.fused.is_some());
        let n = 50;
        let r = DMatrix::from_fn(n, 2, |i, j| ((i * 7 + j * 3) % 5) as f64 - 2.0);
        let inp = RunInput {
            r1: Some(&r),
            r2: Some(&r),
            noise: None,
            len: n,
        };
        let z0: Vec<f64> = (0..e.nz).map(|i| i as f64 * 0.1).collect();
        let (a, b) = (
            e.run(&z0, &inp, None).unwrap(),
            e.run_reference(&z0, &inp, None).unwrap(),
        );
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 1e-12 * y.abs().max(1.0), "{x} vs {y}");
        }
    }

    #[test]
    fn lcm_of_patterns() {
        assert_eq!(lcm(4, 6), 12);
        assert_eq!(lcm(1, 5), 5);
        assert_eq!([2usize, 3, 4].iter().fold(1, |a, &b| lcm(a, b)), 12);
    }
}

//! The allocation-free inner loop: small dense blocks on slices.
//!
//! Long file: the loop structure compiled to blocks (plant, controller,
//! inferential predictor; fast, hold-last and inferential feedback; a
//! controller executed at its own period), its general and fused runs and
//! the fixed-size step kernels all work on the one `Block` layout, and are
//! kept together so that a change to the layout is made in one place.

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
        /// Controller execution (period, phase) in base periods: it runs at
        /// k ≡ phase (mod period); in between its state is frozen and its
        /// output held.
        k_rate: (usize, usize),
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
    /// frame: whether the controller runs at this phase.
    k_exec: Vec<bool>,
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
        let k_rate = match &structure {
            Structure::Loop { k_rate, .. } => *k_rate,
            Structure::Whole { .. } => (1, 0),
        };
        let frame = holds
            .iter()
            .map(|h| h.0)
            .chain(sampling.iter().map(|s| s.0))
            .fold(k_rate.0, lcm);
        if frame > crate::MAX_PATTERN_PERIOD {
            return Err(Error::PatternTooLong {
                frame: frame as u64,
                max: crate::MAX_PATTERN_PERIOD,
            });
        }
        let k_exec: Vec<bool> = (0..frame).map(|ph| ph % k_rate.0 == k_rate.1).collect();
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
                // the held controller output, when it does not run every sample
                let nkh = if k.is_some() && k_rate.0 > 1 { nu } else { 0 };
                (off_v + ny + nkh, off_k, off_p, off_u)
            }
            Structure::Whole { cl } => (cl.n, cl.n, cl.n, cl.n),
        };
        let mut solve = vec![None; frame];
        if let Structure::Loop {
            g,
            k: Some(kb),
            phat,
            feedback,
            ..
        } = &structure
        {
            for (ph, slot) in solve.iter_mut().enumerate() {
                if !k_exec[ph] {
                    // the held controller output does not feed through
                    continue;
                }
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
            k_exec,
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
                ..
            } => {
                let exec = self.k_exec[ph];
                let (xg, rest) = z.split_at(g.n);
                let (xk, rest) = rest.split_at(self.off_p - self.off_k);
                let (xp, rest) = rest.split_at(self.off_u - self.off_p);
                let (uprev, rest) = rest.split_at(nu);
                let (vheld, khold) = rest.split_at(ny);
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
                    if exec {
                        kb.cx(xk, &mut s.yk);
                        kb.add_du(&s.efree, &mut s.yk);
                    } else {
                        s.yk.copy_from_slice(khold);
                    }
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
                let (un, rest) = rest.split_at_mut(nu);
                let (vn, khn) = rest.split_at_mut(ny);
                g.update(xg, u, xgn);
                if let Some(kb) = kb {
                    if exec {
                        if !khn.is_empty() {
                            // the output it ran with, for the samples until it runs again
                            kb.cx(xk, khn);
                            kb.add_du(&s.efree, khn);
                        }
                        kb.update(xk, &s.efree, xkn);
                    } else {
                        xkn.copy_from_slice(xk);
                        khn.copy_from_slice(khold);
                    }
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
            Some(f) => {
                let plan = Plan::new(self, f, inp);
                let p = &plan;
                match plan.rows {
                    4 => self.run_fused::<4>(f, p, z0, inp, rec),
                    8 => self.run_fused::<8>(f, p, z0, inp, rec),
                    12 => self.run_fused::<12>(f, p, z0, inp, rec),
                    16 => self.run_fused::<16>(f, p, z0, inp, rec),
                    20 => self.run_fused::<20>(f, p, z0, inp, rec),
                    24 => self.run_fused::<24>(f, p, z0, inp, rec),
                    28 => self.run_fused::<28>(f, p, z0, inp, rec),
                    32 => self.run_fused::<32>(f, p, z0, inp, rec),
                    _ => self.run_fused::<0>(f, p, z0, inp, rec),
                }
            }
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
            // held values: outputs v, then the held controller output
            order.extend(self.off_u + nu..nz);
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

    /// The fused loop, a block of [`BLOCK`] samples at a time: per sample
    /// the next row [z_live(k+1); y_clean(k); u(k)] = M_ph [z_live(k);
    /// inputs(k)] is one product of the phase's compacted matrix (see
    /// [`Plan`]) with its active columns (`R` accumulators per partial sum,
    /// fused multiply-adds; `R` = 0: run-time row count), the inputs read
    /// straight from the excitation and noise columns; then the block's
    /// outputs are checked against the divergence limit and written to the
    /// record channel by channel. The states no column reads are left out
    /// of the recursion and computed once, for the final state, by a full
    /// step of the last sample. O(len · rows · active columns) flops,
    /// O(BLOCK · rows + frame · rows · columns) memory.
    fn run_fused<const R: usize>(
        &self,
        f: &Fused,
        plan: &Plan<'_>,
        z0: &[f64],
        inp: &RunInput<'_>,
        mut rec: Option<&mut Record>,
    ) -> Result<Vec<f64>> {
        lifted_linalg::simd::dispatch(
            #[inline(always)]
            || {
                let (nz, ny, nu, len) = (self.nz, self.ny, self.nu, inp.len);
                let rows = if R > 0 { R } else { plan.rows };
                let (nl, nk) = (plan.live.len(), plan.nk);
                let (cols_a, srcs) = (&plan.cols_a[..], &plan.srcs[..]);
                // row 0: the state entering the block; row b + 1: sample b's result
                let mut hist = vec![0.0; (BLOCK + 1) * rows];
                for (h, &c) in hist.iter_mut().zip(&plan.live) {
                    *h = z0[c];
                }
                let mut acc = vec![0.0; if R > 0 { 0 } else { 2 * rows }];
                // per-row divergence limit: outputs only (∞ for states and padding)
                let mut lim = vec![f64::INFINITY; rows];
                lim[nl..nl + ny + nu].fill(self.limit);
                // the live state entering the last sample (for the final full step)
                let mut last = vec![0.0; nl];
                let mut ph = 0usize;
                let mut k0 = 0usize;
                while k0 < len {
                    let nb = BLOCK.min(len - k0);
                    for b in 0..nb {
                        let m = &plan.mats[ph * nk * rows..(ph + 1) * nk * rows];
                        let (done, next) = hist.split_at_mut((b + 1) * rows);
                        let prev = &done[b * rows..];
                        if R > 0 {
                            step_fixed::<R>(m, cols_a, srcs, k0 + b, prev, &mut next[..R]);
                        } else {
                            let next = &mut next[..rows];
                            step_dyn(m, rows, cols_a, srcs, k0 + b, prev, &mut acc, next);
                        }
                        ph += 1;
                        if ph == self.frame {
                            ph = 0;
                        }
                    }
                    let outs = || hist[rows..(nb + 1) * rows].chunks_exact(rows);
                    if !within::<R>(outs(), &lim) {
                        for (b, row) in outs().enumerate() {
                            check(
                                k0 + b,
                                &row[nl..nl + ny],
                                &row[nl + ny..nl + ny + nu],
                                self.limit,
                            )?;
                        }
                    }
                    if let Some(rec) = rec.as_deref_mut() {
                        for j in 0..ny {
                            let dst = &mut rec.y_clean.as_mut_slice()[j * len + k0..][..nb];
                            for (d, row) in dst.iter_mut().zip(outs()) {
                                *d = row[nl + j];
                            }
                            let dst = &mut rec.y.as_mut_slice()[j * len + k0..][..nb];
                            for (d, row) in dst.iter_mut().zip(outs()) {
                                *d = row[nl + j];
                            }
                            if let Some((m, s)) = inp.noise {
                                let src = &m.as_slice()[j * len + k0..][..nb];
                                for (d, &e) in dst.iter_mut().zip(src) {
                                    *d += s[j] * e;
                                }
                            }
                        }
                        for i in 0..nu {
                            let dst = &mut rec.u.as_mut_slice()[i * len + k0..][..nb];
                            for (d, row) in dst.iter_mut().zip(outs()) {
                                *d = row[nl + ny + i];
                            }
                        }
                    }
                    if k0 + nb == len {
                        last.copy_from_slice(&hist[(nb - 1) * rows..(nb - 1) * rows + nl]);
                    }
                    hist.copy_within(nb * rows..nb * rows + nl, 0);
                    k0 += nb;
                }
                let mut z = z0.to_vec();
                if len > 0 && nl < nz {
                    // the states left out of the recursion: one full step of the
                    // last sample (their own columns are zero, so their values
                    // before it do not matter)
                    let mut zl = vec![0.0; nz];
                    for (&c, &v) in plan.live.iter().zip(&last) {
                        zl[c] = v;
                    }
                    let ph_last = (len - 1) % self.frame;
                    let full = self.full_step(f, ph_last, &zl, inp, len - 1);
                    z.copy_from_slice(&full[..nz]);
                }
                for (&c, &v) in plan.live.iter().zip(&hist) {
                    z[c] = v;
                }
                Ok(z)
            },
        )
    }

    /// One step of the full fused map (every row) at phase `ph` from state
    /// `z` and the inputs of sample `k` (absent inputs are zero). O(rows ·
    /// columns); used once per run.
    fn full_step(&self, f: &Fused, ph: usize, z: &[f64], inp: &RunInput<'_>, k: usize) -> Vec<f64> {
        let (nz, ny, nu, len) = (self.nz, self.ny, self.nu, inp.len);
        let nc = f.cols.len();
        let m = &f.mats[ph * nc * f.rows..(ph + 1) * nc * f.rows];
        let mut out = vec![0.0; f.rows];
        for (col, &c) in m.chunks_exact(f.rows).zip(&f.cols) {
            let x = if c < nz {
                z[c]
            } else if c < nz + ny {
                inp.r1.map_or(0.0, |r| r.as_slice()[(c - nz) * len + k])
            } else if c < nz + ny + nu {
                inp.r2
                    .map_or(0.0, |r| r.as_slice()[(c - nz - ny) * len + k])
            } else {
                let j = c - nz - ny - nu;
                inp.noise
                    .map_or(0.0, |(n, s)| s[j] * n.as_slice()[j * len + k])
            };
            for (o, mc) in out.iter_mut().zip(col) {
                *o = mc.mul_add(x, *o);
            }
        }
        out
    }
}

/// The fused map compacted for one run: the live states (those some column
/// reads: dynamic states and held values in use) first, then y_clean and u,
/// rows padded to a multiple of 4; absent inputs dropped and the noise
/// scale folded into the noise columns.
pub(crate) struct Plan<'a> {
    rows: usize,
    /// z indices of the live states, in order (compact row i ↔ z index).
    live: Vec<usize>,
    /// Compact rows of the state columns.
    cols_a: Vec<usize>,
    /// Input columns (held values at compact rows, or signal columns).
    srcs: Vec<Src<'a>>,
    /// Columns per phase (states + inputs).
    nk: usize,
    /// frame × (nk × rows), column-major per phase.
    mats: Vec<f64>,
}

impl<'a> Plan<'a> {
    fn new(e: &Engine, f: &Fused, inp: &RunInput<'a>) -> Self {
        let (nz, ny, nu, len) = (e.nz, e.ny, e.nu, inp.len);
        let (o_r1, o_r2, o_n) = (nz, nz + ny, nz + ny + nu);
        let mut is_live = vec![false; nz];
        for &c in f.cols.iter().filter(|&&c| c < nz) {
            is_live[c] = true;
        }
        let live: Vec<usize> = (0..nz).filter(|&c| is_live[c]).collect();
        let mut pos = vec![usize::MAX; nz];
        for (i, &c) in live.iter().enumerate() {
            pos[c] = i;
        }
        let nl = live.len();
        let rows = (nl + ny + nu).div_ceil(4).max(1) * 4;
        // full-map row of each compact row
        let rmap: Vec<usize> = live.iter().copied().chain(nz..nz + ny + nu).collect();
        let cols_a: Vec<usize> = f.cols[..f.split].iter().map(|&c| pos[c]).collect();
        let mut keep = Vec::with_capacity(f.cols.len());
        let mut srcs = Vec::with_capacity(f.cols.len());
        for (ci, &c) in f.cols.iter().enumerate().skip(f.split) {
            let (src, scale) = if c < nz {
                (Some(Src::Held(pos[c])), 1.0)
            } else if c < o_r2 {
                (column(inp.r1, c - o_r1, len).map(Src::Col), 1.0)
            } else if c < o_n {
                (column(inp.r2, c - o_r2, len).map(Src::Col), 1.0)
            } else {
                let j = c - o_n;
                match inp.noise {
                    Some((m, s)) => (column(Some(m), j, len).map(Src::Col), s[j]),
                    None => (None, 0.0),
                }
            };
            if let Some(src) = src {
                keep.push((ci, scale));
                srcs.push(src);
            }
        }
        let nk = f.split + keep.len();
        let nc = f.cols.len();
        let mut mats = vec![0.0; e.frame * nk * rows];
        let cols = (0..f.split).map(|ci| (ci, 1.0)).chain(keep.iter().copied());
        for (k, (ci, scale)) in cols.enumerate() {
            for ph in 0..e.frame {
                let src = &f.mats[(ph * nc + ci) * f.rows..(ph * nc + ci + 1) * f.rows];
                let dst = &mut mats[(ph * nk + k) * rows..(ph * nk + k + 1) * rows];
                for (d, &r) in dst.iter_mut().zip(&rmap) {
                    *d = src[r] * scale;
                }
            }
        }
        Plan {
            rows,
            live,
            cols_a,
            srcs,
            nk,
            mats,
        }
    }
}

/// Channel `j` of a column-major signal with `len` rows, from its first sample.
fn column(m: Option<&DMatrix<f64>>, j: usize, len: usize) -> Option<&[f64]> {
    m.map(|m| &m.as_slice()[j * len..(j + 1) * len])
}

/// Samples per block of the fused loop (the block's results stay in L1).
const BLOCK: usize = 64;

/// Where an input column of a fused step reads its value at sample k.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Src<'a> {
    /// A held value of the state: `prev[p]`.
    Held(usize),
    /// A signal column: `col[k]`.
    Col(&'a [f64]),
}

impl Src<'_> {
    #[inline(always)]
    fn at(&self, prev: &[f64], k: usize) -> f64 {
        match *self {
            Src::Held(p) => prev[p],
            Src::Col(c) => c[k],
        }
    }
}

/// Whether every entry of the rows is within its row's limit (NaN is not),
/// without branches (vectorised with a compile-time row count).
fn within<'a, const R: usize>(rows: impl Iterator<Item = &'a [f64]>, lim: &[f64]) -> bool {
    let mut ok = true;
    if let Some(lim) = lim.first_chunk::<R>().filter(|_| R > 0) {
        for row in rows {
            if let Some(row) = row.first_chunk::<R>() {
                for r in 0..R {
                    ok &= row[r].abs() <= lim[r];
                }
            }
        }
    } else {
        for row in rows {
            for (v, l) in row.iter().zip(lim) {
                ok &= v.abs() <= *l;
            }
        }
    }
    ok
}

/// A constant affine map [x(k+1); y(k)] = M [x(k); w(k)] compiled for the
/// fused step: `m` column-major `rows` × (states + inputs), rows padded to
/// a multiple of 4 with zero rows. Used for the noise filter.
#[derive(Debug, Clone)]
pub(crate) struct StepMap {
    pub rows: usize,
    pub states: usize,
    inputs: usize,
    m: Vec<f64>,
    cols_a: Vec<usize>,
}

impl StepMap {
    /// From the map's columns (each `states + outputs` long, states first).
    pub fn new(states: usize, inputs: usize, cols: &[Vec<f64>]) -> Self {
        let out = cols.first().map_or(0, |c| c.len());
        let rows = out.div_ceil(4).max(1) * 4;
        let mut m = vec![0.0; rows * (states + inputs)];
        for (dst, src) in m.chunks_exact_mut(rows).zip(cols) {
            dst[..src.len()].copy_from_slice(src);
        }
        StepMap {
            rows,
            states,
            inputs,
            m,
            cols_a: (0..states).collect(),
        }
    }

    /// Runs `nb` steps: row b + 1 of `hist` (rows wide) gets the result of
    /// row b's state and sample b of the inputs, stored input by input in
    /// `w` (input i at `w[i · stride + b]`). O(nb · rows · (states + inputs)).
    pub fn run(&self, hist: &mut [f64], w: &[f64], stride: usize, nb: usize, acc: &mut Vec<f64>) {
        lifted_linalg::simd::dispatch(
            #[inline(always)]
            || self.run_any(hist, w, stride, nb, acc),
        )
    }

    /// [`run`](Self::run)'s steps (inlined there).
    #[inline(always)]
    fn run_any(&self, hist: &mut [f64], w: &[f64], stride: usize, nb: usize, acc: &mut Vec<f64>) {
        let srcs: Vec<Src<'_>> = (0..self.inputs)
            .map(|i| Src::Col(&w[i * stride..]))
            .collect();
        match self.rows {
            4 => self.run_fixed::<4>(hist, &srcs, nb),
            8 => self.run_fixed::<8>(hist, &srcs, nb),
            12 => self.run_fixed::<12>(hist, &srcs, nb),
            16 => self.run_fixed::<16>(hist, &srcs, nb),
            rows => {
                acc.resize(2 * rows, 0.0);
                for b in 0..nb {
                    let (done, next) = hist.split_at_mut((b + 1) * rows);
                    let next = &mut next[..rows];
                    let prev = &done[b * rows..];
                    step_dyn(&self.m, rows, &self.cols_a, &srcs, b, prev, acc, next);
                }
            }
        }
    }

    /// The steps with the previous row kept in registers: the state columns
    /// are visited with compile-time indices (`states` ≤ R, the map's rows
    /// start with the state), so the sample-to-sample chain is a lane
    /// broadcast and the FMAs, not a store and a reload.
    #[inline(always)]
    fn run_fixed<const R: usize>(&self, hist: &mut [f64], srcs: &[Src<'_>], nb: usize) {
        let ns = self.states;
        let (ma, mb) = self.m.split_at(ns * R);
        let mut x = [0.0f64; R];
        if let Some(h) = hist.first_chunk::<R>() {
            x = *h;
        }
        for b in 0..nb {
            let mut acc_b = [0.0f64; R];
            for (col, src) in mb.chunks_exact(R).zip(srcs) {
                axpy(&mut acc_b, col, src.at(&x, b));
            }
            let mut acc_a = [0.0f64; R];
            for c in 0..R {
                if c < ns {
                    axpy(&mut acc_a, &ma[c * R..], x[c]);
                }
            }
            for r in 0..R {
                x[r] = acc_a[r] + acc_b[r];
            }
            if let Some(row) = hist[(b + 1) * R..].first_chunk_mut::<R>() {
                *row = x;
            }
        }
    }
}

/// One fused step with a compile-time row count: `next` = M [prev; inputs]
/// over the active columns (state columns `cols_a` read from `prev`, input
/// columns from `srcs` at sample `k`). The state columns go to two partial
/// sums (halving the dependent chain from one sample to the next), the
/// inputs to a third that does not wait for the state.
#[inline(always)]
fn step_fixed<const R: usize>(
    m: &[f64],
    cols_a: &[usize],
    srcs: &[Src<'_>],
    k: usize,
    prev: &[f64],
    next: &mut [f64],
) {
    let (ma, mb) = m.split_at(cols_a.len() * R);
    let mut acc_b = [0.0f64; R];
    for (col, src) in mb.chunks_exact(R).zip(srcs) {
        axpy(&mut acc_b, col, src.at(prev, k));
    }
    let mut acc_a = [0.0f64; R];
    let mut acc_a2 = [0.0f64; R];
    let mut pairs = ma.chunks_exact(2 * R).zip(cols_a.chunks_exact(2));
    for (col, c) in pairs.by_ref() {
        let (m0, m1) = col.split_at(R);
        axpy(&mut acc_a, m0, prev[c[0]]);
        axpy(&mut acc_a2, m1, prev[c[1]]);
    }
    if cols_a.len() % 2 == 1 {
        let last = cols_a.len() - 1;
        axpy(&mut acc_a, &ma[last * R..], prev[cols_a[last]]);
    }
    if let Some(next) = next.first_chunk_mut::<R>() {
        for r in 0..R {
            next[r] = (acc_a[r] + acc_a2[r]) + acc_b[r];
        }
    }
}

/// [`step_fixed`] with the row count known at run time (`acc`: 2 · rows
/// scratch numbers).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn step_dyn(
    m: &[f64],
    rows: usize,
    cols_a: &[usize],
    srcs: &[Src<'_>],
    k: usize,
    prev: &[f64],
    acc: &mut [f64],
    next: &mut [f64],
) {
    let (ma, mb) = m.split_at(cols_a.len() * rows);
    let (acc_a, acc_b) = acc.split_at_mut(rows);
    acc_a.fill(0.0);
    acc_b.fill(0.0);
    for (col, &c) in ma.chunks_exact(rows).zip(cols_a) {
        let x = prev[c];
        for (a, m) in acc_a.iter_mut().zip(col) {
            *a = m.mul_add(x, *a);
        }
    }
    for (col, src) in mb.chunks_exact(rows).zip(srcs) {
        let x = src.at(prev, k);
        for (a, m) in acc_b.iter_mut().zip(col) {
            *a = m.mul_add(x, *a);
        }
    }
    for ((n, a), b) in next.iter_mut().zip(acc_a.iter()).zip(acc_b.iter()) {
        *n = a + b;
    }
}

/// acc += x · col[..R] on a fixed-size block (vectorised fused multiply-adds;
/// `col` has at least R entries by construction).
#[inline(always)]
fn axpy<const R: usize>(acc: &mut [f64; R], col: &[f64], x: f64) {
    if let Some(col) = col.first_chunk::<R>() {
        for r in 0..R {
            acc[r] = col[r].mul_add(x, acc[r]);
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

/// Least common multiple, saturating at `usize::MAX` (a pattern that long
/// is refused by [`Engine::new`]).
pub(crate) fn lcm(a: usize, b: usize) -> usize {
    if a == 0 || b == 0 {
        a.max(b)
    } else {
        (a / gcd(a, b)).saturating_mul(b)
    }
}

#[cfg(test)]
mod tests;

//! The allocation-free inner loop: small dense blocks on slices.

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

/// Dot product with four partial sums (no dependent chain longer than ⌈n/4⌉).
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut s = [0.0f64; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        s[0] += x[0] * y[0];
        s[1] += x[1] * y[1];
        s[2] += x[2] * y[2];
        s[3] += x[3] * y[3];
    }
    for (k, (x, y)) in ra.iter().zip(rb).enumerate() {
        s[k] += x * y;
    }
    (s[0] + s[2]) + (s[1] + s[3])
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
        Ok(Engine {
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
        })
    }

    /// Runs `inp.len` steps from state `z0` (length nz), returning the final
    /// state; records the signals when `rec` is given (its matrices must be
    /// len × channels). O(len · (n² + nm)) with no allocation in the loop.
    pub fn run(
        &self,
        z0: &[f64],
        inp: &RunInput<'_>,
        mut rec: Option<&mut Record>,
    ) -> Result<Vec<f64>> {
        let (ny, nu, len) = (self.ny, self.nu, inp.len);
        let mut z = z0.to_vec();
        let mut zn = vec![0.0; self.nz];
        let mut yg = vec![0.0; ny];
        let mut yp = vec![0.0; ny];
        let mut yk = vec![0.0; nu];
        let mut efree = vec![0.0; ny];
        let mut a = vec![0.0; nu];
        let mut u = vec![0.0; nu];
        let mut v = vec![0.0; ny];
        let mut nse = vec![0.0; ny];
        let mut r1 = vec![0.0; ny];
        let mut r2 = vec![0.0; nu];
        let mut rin = vec![0.0; ny + nu];
        let mut out = vec![0.0; ny + nu];
        let r1s = inp.r1.map(|m| m.as_slice());
        let r2s = inp.r2.map(|m| m.as_slice());
        let noise = inp.noise.map(|(m, s)| (m.as_slice(), s));
        let limit = self.limit;
        let mut ph = 0usize;
        for k in 0..len {
            if let Some(s) = r1s {
                for (j, r) in r1.iter_mut().enumerate() {
                    *r = s[j * len + k];
                }
            }
            if let Some(s) = r2s {
                for (i, r) in r2.iter_mut().enumerate() {
                    *r = s[i * len + k];
                }
            }
            if let Some((s, scale)) = noise {
                for (j, e) in nse.iter_mut().enumerate() {
                    *e = scale[j] * s[j * len + k];
                }
            }
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
                    g.cx(xg, &mut yg);
                    if let Some(p) = phat {
                        p.cx(xp, &mut yp);
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
                                    yp[j]
                                }
                            }
                        };
                        efree[j] = r1[j] - vf;
                    }
                    if let Some(kb) = kb {
                        kb.cx(xk, &mut yk);
                        kb.add_du(&efree, &mut yk);
                    }
                    let hmask = &self.start_mask[ph * nu..(ph + 1) * nu];
                    for i in 0..nu {
                        a[i] = if hmask[i] {
                            r2[i] + if kb.is_some() { yk[i] } else { 0.0 }
                        } else {
                            uprev[i]
                        };
                    }
                    match &self.solve[ph] {
                        Some(minv) => {
                            for (i, ui) in u.iter_mut().enumerate() {
                                *ui = minv[i * nu..(i + 1) * nu]
                                    .iter()
                                    .zip(&a)
                                    .map(|(m, a)| m * a)
                                    .sum();
                            }
                        }
                        None => u.copy_from_slice(&a),
                    }
                    // y = Cg x + Dg u ; v
                    g.add_du(&u, &mut yg);
                    for j in 0..ny {
                        let ym = yg[j] + nse[j];
                        v[j] = match feedback {
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
                                    yp[j]
                                        + phat.as_ref().map_or(0.0, |p| {
                                            if p.has_d { p.du_row(j, &u) } else { 0.0 }
                                        })
                                }
                            }
                        };
                        efree[j] = r1[j] - v[j];
                    }
                    let (xgn, rest) = zn.split_at_mut(g.n);
                    let (xkn, rest) = rest.split_at_mut(self.off_p - self.off_k);
                    let (xpn, rest) = rest.split_at_mut(self.off_u - self.off_p);
                    let (un, vn) = rest.split_at_mut(nu);
                    g.update(xg, &u, xgn);
                    if let Some(kb) = kb {
                        kb.update(xk, &efree, xkn);
                    }
                    if let Some(p) = phat {
                        p.update(xp, &u, xpn);
                    }
                    un.copy_from_slice(&u);
                    vn.copy_from_slice(&v);
                    if let Some(rec) = rec.as_deref_mut() {
                        let (us, ys, ycs) = (
                            rec.u.as_mut_slice(),
                            rec.y.as_mut_slice(),
                            rec.y_clean.as_mut_slice(),
                        );
                        for i in 0..nu {
                            us[i * len + k] = u[i];
                        }
                        for j in 0..ny {
                            ycs[j * len + k] = yg[j];
                            ys[j * len + k] = yg[j] + nse[j];
                        }
                    }
                    check(k, &yg, &u, limit)?;
                }
                Structure::Whole { cl } => {
                    rin[..ny].copy_from_slice(&r1);
                    rin[ny..].copy_from_slice(&r2);
                    cl.cx(&z, &mut out);
                    cl.add_du(&rin, &mut out);
                    cl.update(&z, &rin, &mut zn);
                    if let Some(rec) = rec.as_deref_mut() {
                        let (us, ys, ycs) = (
                            rec.u.as_mut_slice(),
                            rec.y.as_mut_slice(),
                            rec.y_clean.as_mut_slice(),
                        );
                        for i in 0..nu {
                            us[i * len + k] = out[ny + i];
                        }
                        for j in 0..ny {
                            ycs[j * len + k] = out[j];
                            ys[j * len + k] = out[j] + nse[j];
                        }
                    }
                    check(k, &out[..ny], &out[ny..], limit)?;
                }
            }
            std::mem::swap(&mut z, &mut zn);
            ph += 1;
            if ph == self.frame {
                ph = 0;
            }
        }
        Ok(z)
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
    fn lcm_of_patterns() {
        assert_eq!(lcm(4, 6), 12);
        assert_eq!(lcm(1, 5), 5);
        assert_eq!([2usize, 3, 4].iter().fold(1, |a, &b| lcm(a, b)), 12);
    }
}

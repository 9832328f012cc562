//! The analytic Jacobian: state sensitivities along the local-coordinate directions, streamed as rows of [J | e] into an R-only QR, records split over threads.

use nalgebra::DMatrix;

use super::point::{Layout, Point, predictor_step};
use crate::error::{Error, Result};
use lifted_subspace::Record;

/// Rows of [J | e] gathered before each push into the R-only QR (memory
/// O(p²) for p local coordinates).
fn block_rows(np: usize) -> usize {
    (8 * (np + 1)).max(256)
}

/// The per-direction perturbations of the model along the local-coordinate
/// basis, arranged for the sensitivity recursion.
struct Directions {
    n: usize,
    nu: usize,
    ny: usize,
    /// Directions (columns of the basis).
    np: usize,
    /// [δA_i δB_i δK_i]: per column of z = [x̂; u; e] an n × np block,
    /// state-major (entry r·np + i: state r, direction i).
    m: Vec<f64>,
    /// [δC_i δD_i]: per column of [x̂; u] an n_y × np block, output-major.
    mc: Vec<f64>,
    /// δx₀ per record: n × np, state-major.
    s0: Vec<Vec<f64>>,
    /// Per column of `m`: the directions [lo, hi) outside which it is
    /// zero (directions of a few blocks of θ force few columns).
    m_span: Vec<(usize, usize)>,
    /// The same for `mc`.
    mc_span: Vec<(usize, usize)>,
}

/// Per block of `cols` rows × np blocks (row-major): the directions
/// [lo, hi) outside which it is zero.
fn spans(m: &[f64], rows: usize, np: usize, cols: usize) -> Vec<(usize, usize)> {
    (0..cols)
        .map(|col| {
            let block = &m[col * rows * np..(col + 1) * rows * np];
            let nz = |i: &usize| (0..rows).any(|r| block[r * np + i] != 0.0);
            match (0..np).find(nz) {
                Some(lo) => (lo, (0..np).rev().find(nz).map_or(lo, |hi| hi + 1)),
                None => (0, 0),
            }
        })
        .collect()
}

impl Directions {
    fn new(basis: &DMatrix<f64>, lay: &Layout) -> Directions {
        let (n, nu, ny, np) = (lay.n, lay.nu, lay.ny, basis.ncols());
        let (mz, mcz) = (n + nu + ny, n + nu);
        let mut m = vec![0.0; n * np * mz];
        let mut mc = vec![0.0; ny * np * mcz];
        let mut s0 = vec![vec![0.0; n * np]; lay.records];
        for i in 0..np {
            let dir = Point::unpack(&basis.column(i).into_owned(), lay);
            for col in 0..mz {
                for r in 0..n {
                    m[col * n * np + r * np + i] = if col < n {
                        dir.a[(r, col)]
                    } else if col < n + nu {
                        dir.b[(r, col - n)]
                    } else {
                        dir.k[(r, col - n - nu)]
                    };
                }
            }
            for col in 0..mcz {
                for o in 0..ny {
                    mc[col * ny * np + o * np + i] = if col < n {
                        dir.c[(o, col)]
                    } else {
                        dir.d[(o, col - n)]
                    };
                }
            }
            for (s, x) in s0.iter_mut().zip(&dir.x0) {
                for (r, &v) in x.iter().enumerate() {
                    s[r * np + i] = v;
                }
            }
        }
        let m_span = spans(&m, n, np, mz);
        let mc_span = spans(&mc, ny, np, mcz);
        Directions {
            n,
            nu,
            ny,
            np,
            m,
            mc,
            s0,
            m_span,
            mc_span,
        }
    }
}

/// Samples per block of the Hessian subsample ([`jacobian_r`]'s `stride`).
pub(super) const HESSIAN_BLOCK: usize = 256;

/// Rows of [J | e] in a row-major block, folded into an R-only QR when
/// full, and the sums Jᵀe, eᵀe of all rows offered (also those left out
/// of the QR by a Hessian subsample).
struct RowSink {
    width: usize,
    cap: usize,
    rows: usize,
    buf: Vec<f64>,
    acc: lifted_linalg::RAccumulator,
    /// [Jᵀe; eᵀe] over every row.
    grad: Vec<f64>,
}

impl RowSink {
    fn new(width: usize) -> RowSink {
        let cap = block_rows(width);
        RowSink {
            width,
            cap,
            rows: 0,
            buf: vec![0.0; cap * width],
            acc: lifted_linalg::RAccumulator::new(width),
            grad: vec![0.0; width],
        }
    }

    fn flush(&mut self) -> Result<()> {
        lifted_linalg::simd::dispatch(
            #[inline(always)]
            || {
                if self.rows > 0 {
                    let block = DMatrix::from_row_slice(
                        self.rows,
                        self.width,
                        &self.buf[..self.rows * self.width],
                    );
                    self.acc.push_rows(&block)?;
                    self.rows = 0;
                }
                Ok(())
            },
        )
    }

    /// Room for `k` more rows; returns the first new row's index.
    fn reserve(&mut self, k: usize) -> Result<usize> {
        if self.rows + k > self.cap {
            self.flush()?;
        }
        let at = self.rows;
        self.rows += k;
        Ok(at)
    }

    fn finish(mut self) -> Result<(DMatrix<f64>, Vec<f64>)> {
        self.flush()?;
        Ok((self.acc.r(), self.grad))
    }
}

/// Runs the predictor and the sensitivity recursion over samples
/// `range` of `rec` from state `x` and sensitivities `s` (n × width,
/// column-major; the first `dirs.np` columns are forced, any further ones
/// — transition columns — are not), leaving the end values in `x` and
/// `s`. With a `sink` (width = np) the weighted rows [J | e] of the
/// measured samples are pushed into it. O(len · width · n (n + n_u + n_y)).
#[allow(clippy::too_many_arguments)]
fn sweep(
    p: &Point,
    dirs: &Directions,
    rec: &Record<'_>,
    range: std::ops::Range<usize>,
    weights: &[f64],
    gain: bool,
    x: &mut [f64],
    s: &mut Vec<f64>,
    mut sink: Option<&mut RowSink>,
    stride: usize,
) -> Result<()> {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            let (n, nu, ny, np) = (dirs.n, dirs.nu, dirs.ny, dirs.np);
            let width = s.len() / n.max(1);
            let (mz, mcz) = (n + nu + ny, n + nu);
            let (a, c, k) = (p.a.as_slice(), p.c.as_slice(), p.k.as_slice());
            let mut z = vec![0.0; mz];
            let mut meas = vec![false; ny];
            let mut next = vec![0.0; n];
            let mut f = vec![0.0; n * np];
            let mut g = vec![0.0; ny * np];
            let mut de = vec![0.0; ny * width];
            let mut sn = vec![0.0; s.len()];
            for t in range {
                predictor_step(p, gain, rec, t, x, &mut z, &mut meas, &mut next);
                let nmeas = meas.iter().filter(|&&m| m).count();
                // z holds the pre-step state x̂(t); the forcing terms use it.
                // Every operation below is an axpy over the directions (state-
                // and output-major layouts), so it vectorises.
                f.fill(0.0);
                for (col, &zc) in z.iter().enumerate() {
                    let (lo, hi) = dirs.m_span[col];
                    if zc != 0.0 && hi > lo {
                        let at = col * n * np;
                        for r in 0..n {
                            let row = at + r * np;
                            for (fi, mi) in f[r * np + lo..r * np + hi]
                                .iter_mut()
                                .zip(&dirs.m[row + lo..row + hi])
                            {
                                *fi += mi * zc;
                            }
                        }
                    }
                }
                g.fill(0.0);
                for (col, &zc) in z[..mcz].iter().enumerate() {
                    let (lo, hi) = dirs.mc_span[col];
                    if zc != 0.0 && hi > lo {
                        let at = col * ny * np;
                        for o in 0..ny {
                            let row = at + o * np;
                            for (gi, mi) in g[o * np + lo..o * np + hi]
                                .iter_mut()
                                .zip(&dirs.mc[row + lo..row + hi])
                            {
                                *gi += mi * zc;
                            }
                        }
                    }
                }
                // δe = −(C s + δC x̂ + δD u) on the measured outputs (n_y × width).
                for o in 0..ny {
                    let out = &mut de[o * width..(o + 1) * width];
                    if !meas[o] {
                        out.fill(0.0);
                        continue;
                    }
                    out[..np].copy_from_slice(&g[o * np..(o + 1) * np]);
                    out[np..].fill(0.0);
                    for j in 0..n {
                        let coj = c[o + j * ny];
                        if coj != 0.0 {
                            for (dv, sv) in out.iter_mut().zip(&s[j * width..(j + 1) * width]) {
                                *dv += coj * sv;
                            }
                        }
                    }
                    for dv in out.iter_mut() {
                        *dv = -*dv;
                    }
                }
                // s(t+1) = A s + forcing + K δe (n × width).
                for r in 0..n {
                    let out = &mut sn[r * width..(r + 1) * width];
                    out[..np].copy_from_slice(&f[r * np..(r + 1) * np]);
                    out[np..].fill(0.0);
                    for j in 0..n {
                        let arj = a[r + j * n];
                        if arj != 0.0 {
                            for (ov, sv) in out.iter_mut().zip(&s[j * width..(j + 1) * width]) {
                                *ov += arj * sv;
                            }
                        }
                    }
                    if gain {
                        for o in 0..ny {
                            let kro = k[r + o * n];
                            if kro != 0.0 && meas[o] {
                                for (ov, dv) in out.iter_mut().zip(&de[o * width..(o + 1) * width])
                                {
                                    *ov += kro * dv;
                                }
                            }
                        }
                    }
                }
                if let Some(sk) = sink.as_deref_mut()
                    && nmeas > 0
                {
                    // Hessian subsample: the head of the record (its transient)
                    // whole, then one block in `stride`, scaled by √stride.
                    let (keep, scale) = if stride <= 1 || t < stride * HESSIAN_BLOCK {
                        (true, 1.0)
                    } else {
                        (
                            (t / HESSIAN_BLOCK).is_multiple_of(stride),
                            (stride as f64).sqrt(),
                        )
                    };
                    let at = sk.reserve(nmeas)?;
                    let w = sk.width;
                    let mut row = at;
                    for o in 0..ny {
                        if meas[o] {
                            let wo = weights[o];
                            let dst = &mut sk.buf[row * w..(row + 1) * w];
                            for (dv, sv) in dst[..np].iter_mut().zip(&de[o * width..o * width + np])
                            {
                                *dv = wo * sv;
                            }
                            dst[np] = wo * z[n + nu + o];
                            if stride > 1 {
                                let (buf, grad) = (&mut sk.buf, &mut sk.grad);
                                let dst = &mut buf[row * w..(row + 1) * w];
                                let e = dst[np];
                                for (gv, rv) in grad.iter_mut().zip(dst.iter()) {
                                    *gv += rv * e;
                                }
                                if keep {
                                    dst.iter_mut().for_each(|v| *v *= scale);
                                }
                            }
                            row += 1;
                        }
                    }
                    if !keep {
                        // Offered to the gradient only: give the rows back.
                        sk.rows -= nmeas;
                    }
                }
                std::mem::swap(s, &mut sn);
            }
            Ok(())
        },
    )
}

/// `work(j)` for every job, in job order, the jobs split into `threads`
/// contiguous chunks run on std scoped threads.
fn run_parallel(
    threads: usize,
    jobs: Vec<usize>,
    work: &(dyn Fn(usize) -> Result<Vec<f64>> + Sync),
) -> Result<Vec<Vec<f64>>> {
    if threads <= 1 || jobs.len() <= 1 {
        return jobs.into_iter().map(work).collect();
    }
    let per = jobs.len().div_ceil(threads);
    std::thread::scope(|scope| {
        let handles: Vec<_> = jobs
            .chunks(per)
            .map(|chunk| scope.spawn(move || chunk.iter().map(|&j| work(j)).collect::<Vec<_>>()))
            .collect();
        let mut out = Vec::with_capacity(jobs.len());
        for h in handles {
            let part = h.join().map_err(|_| Error::InvalidOption {
                what: "threads",
                reason: "a Jacobian thread panicked".into(),
            })?;
            for v in part {
                out.push(v?);
            }
        }
        Ok(out)
    })
}

/// Smallest range of samples given to a thread.
pub(super) const MIN_RANGE: usize = 2048;

/// R of the QR of [J | e] ((p+1) × (p+1), zero rows appended when fewer
/// rows were seen), J = ∂e/∂β the analytic Jacobian of the scaled
/// residuals along the columns of `basis` (module docs), with each record
/// split over `threads` ranges. With `stride` > 1 the QR takes a Hessian
/// subsample: the first `stride` × [`HESSIAN_BLOCK`] samples of each
/// record (their transient) whole, then one block of [`HESSIAN_BLOCK`]
/// samples in `stride`, scaled by √stride (so R₁₁ᵀR₁₁ estimates JᵀJ
/// without bias); the last column is then r̃ with R₁₁ᵀr̃ = Jᵀe summed over
/// every row, and ρ² = eᵀe − ‖r̃‖². Blocks are chosen by absolute sample
/// index, so the thread count still changes the result by rounding only.
#[allow(clippy::too_many_arguments)]
pub(super) fn jacobian_r(
    p: &Point,
    basis: &DMatrix<f64>,
    lay: &Layout,
    records: &[Record<'_>],
    weights: &[f64],
    gain: bool,
    threads: usize,
    stride: usize,
) -> Result<DMatrix<f64>> {
    let (n, nu, ny) = (p.a.nrows(), p.b.ncols(), p.c.nrows());
    let dirs = Directions::new(basis, lay);
    let np = dirs.np;
    // Ranges: (record, range), contiguous per record.
    struct Range {
        r: usize,
        span: std::ops::Range<usize>,
        x: Vec<f64>,
        s: Vec<f64>,
    }
    let mut ranges: Vec<Range> = Vec::new();
    let mut z = vec![0.0; n + nu + ny];
    let mut meas = vec![false; ny];
    let mut next = vec![0.0; n];
    for (r, rec) in records.iter().enumerate() {
        let len = rec.u.nrows();
        let parts = threads.min(len / MIN_RANGE).max(1);
        let per = len.div_ceil(parts);
        // Serial predictor pass: x̂ at each range start.
        let mut x = p.x0[r].as_slice().to_vec();
        for i in 0..parts {
            let span = i * per..((i + 1) * per).min(len);
            ranges.push(Range {
                r,
                span: span.clone(),
                x: x.clone(),
                s: if i == 0 {
                    dirs.s0[r].clone()
                } else {
                    Vec::new()
                },
            });
            if i + 1 < parts {
                for t in span {
                    predictor_step(p, gain, rec, t, &mut x, &mut z, &mut meas, &mut next);
                }
            }
        }
    }
    // Parallel pass 1: each range that is followed by another one in its
    // record gives its end sensitivities from a zero start and its
    // transition matrix; they chain serially into the starts.
    let chained: Vec<usize> = (0..ranges.len())
        .filter(|&i| i + 1 < ranges.len() && ranges[i + 1].r == ranges[i].r)
        .collect();
    if !chained.is_empty() {
        let ends = {
            let ranges = &ranges;
            let dirs = &dirs;
            run_parallel(threads, chained.clone(), &|i: usize| {
                let rg = &ranges[i];
                // n × (np + n), state-major: the last n columns start
                // as the identity and carry the transition Ψ.
                let w = np + n;
                let mut s = vec![0.0; n * w];
                for j in 0..n {
                    s[j * w + np + j] = 1.0;
                }
                let mut x = rg.x.clone();
                sweep(
                    p,
                    dirs,
                    &records[rg.r],
                    rg.span.clone(),
                    weights,
                    gain,
                    &mut x,
                    &mut s,
                    None,
                    1,
                )?;
                Ok(s)
            })?
        };
        for (&i, end) in chained.iter().zip(ends) {
            // s_next = S_part + Ψ s_start (state-major, rows of np + n).
            let start = &ranges[i].s;
            let w = np + n;
            let mut s = vec![0.0; n * np];
            for r in 0..n {
                let out = &mut s[r * np..(r + 1) * np];
                out.copy_from_slice(&end[r * w..r * w + np]);
                for j in 0..n {
                    let psi = end[r * w + np + j];
                    for (ov, sv) in out.iter_mut().zip(&start[j * np..(j + 1) * np]) {
                        *ov += psi * sv;
                    }
                }
            }
            ranges[i + 1].s = s;
        }
    }
    // Parallel pass 2: the rows of [J | e] of each range into its own R.
    let rs = {
        let ranges = &ranges;
        let dirs = &dirs;
        run_parallel(threads, (0..ranges.len()).collect(), &|i: usize| {
            let rg = &ranges[i];
            let mut sink = RowSink::new(np + 1);
            let (mut x, mut s) = (rg.x.clone(), rg.s.clone());
            sweep(
                p,
                dirs,
                &records[rg.r],
                rg.span.clone(),
                weights,
                gain,
                &mut x,
                &mut s,
                Some(&mut sink),
                stride,
            )?;
            let (r, grad) = sink.finish()?;
            let mut out = r.as_slice().to_vec();
            out.extend(grad);
            Ok(out)
        })?
    };
    let mut acc = lifted_linalg::RAccumulator::new(np + 1);
    let mut grad = vec![0.0; np + 1];
    for r in rs {
        let (r, g) = r.split_at(r.len() - (np + 1));
        for (gv, v) in grad.iter_mut().zip(g) {
            *gv += v;
        }
        let rows = r.len() / (np + 1);
        acc.push_rows(&DMatrix::from_column_slice(rows, np + 1, r))?;
    }
    let r = acc.r();
    let mut out = DMatrix::zeros(np + 1, np + 1);
    out.view_mut((0, 0), (r.nrows(), np + 1)).copy_from(&r);
    if stride > 1 {
        // R₁₁ from the subsample; r̃ with R₁₁ᵀ r̃ = Jᵀe over all rows (the
        // Gauss–Newton model ½‖R₁₁δ + r̃‖² has the exact gradient), and
        // ρ² = eᵀe − ‖r̃‖².
        let r11 = out.view((0, 0), (np, np)).upper_triangle();
        let g = nalgebra::DVector::from_column_slice(&grad[..np]);
        let rt = r11
            .transpose()
            .solve_lower_triangular(&g)
            .filter(|v| v.iter().all(|x| x.is_finite()))
            .ok_or(Error::InvalidOption {
                what: "PEM Hessian subsample",
                reason: "its triangular factor is singular".into(),
            })?;
        out.view_mut((0, np), (np, 1)).copy_from(&rt);
        out[(np, np)] = (grad[np] - rt.norm_squared()).max(0.0).sqrt();
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::point::{admissible, output_weights, residuals};
    use super::*;
    use lifted_linalg::spectral_radius;
    use nalgebra::DVector;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// ∂e/∂β along the columns of `basis` by central differences (the
    /// Jacobian used before the analytic one; the reference here).
    fn jacobian_fd(
        theta: &DVector<f64>,
        basis: &DMatrix<f64>,
        lay: &Layout,
        e: &DVector<f64>,
        cost_of: &dyn Fn(&Point) -> Option<DVector<f64>>,
    ) -> DMatrix<f64> {
        let h = 1e-6 * (1.0 + theta.amax());
        let mut jac = DMatrix::zeros(e.len(), basis.ncols());
        for c in 0..basis.ncols() {
            let dir = basis.column(c);
            let plus = cost_of(&Point::unpack(&(theta + dir * h), lay)).unwrap();
            let minus = cost_of(&Point::unpack(&(theta - dir * h), lay)).unwrap();
            jac.column_mut(c).copy_from(&((plus - minus) / (2.0 * h)));
        }
        jac
    }

    /// A random stable model (n = 3, 2 × 2), a small gain with A − KC
    /// stable, random x₀ per record and random records (`nan_every`:
    /// output 0 measured every that many samples).
    fn setup(
        seed: u64,
        gain: bool,
        len: usize,
        nan_every: usize,
    ) -> (Point, Layout, Vec<DMatrix<f64>>, Vec<DMatrix<f64>>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut r = |s: f64| s * (2.0 * rng.random::<f64>() - 1.0);
        let (n, nu, ny) = (3, 2, 2);
        let mut a = DMatrix::from_fn(n, n, |_, _| r(1.0));
        let rho = spectral_radius(&a).unwrap();
        a *= 0.8 / rho;
        let p = Point {
            a,
            b: DMatrix::from_fn(n, nu, |_, _| r(1.0)),
            c: DMatrix::from_fn(ny, n, |_, _| r(1.0)),
            // D(0, 1) is not free in the layout below.
            d: DMatrix::from_fn(ny, nu, |o, j| if (o, j) == (0, 1) { 0.0 } else { r(0.5) }),
            k: if gain {
                DMatrix::from_fn(n, ny, |_, _| r(0.05))
            } else {
                DMatrix::zeros(n, ny)
            },
            x0: (0..2).map(|_| DVector::from_fn(n, |_, _| r(1.0))).collect(),
        };
        assert!(admissible(&p, gain, 0.0));
        let us: Vec<_> = (0..2)
            .map(|_| DMatrix::from_fn(len, nu, |_, _| r(1.0)))
            .collect();
        let ys: Vec<_> = (0..2)
            .map(|_| {
                DMatrix::from_fn(len, ny, |t, o| {
                    if o == 0 && nan_every > 1 && t % nan_every != 0 {
                        f64::NAN
                    } else {
                        r(2.0)
                    }
                })
            })
            .collect();
        let lay = Layout {
            n,
            nu,
            ny,
            records: 2,
            gain,
            d_free: vec![(0, 0), (1, 0), (1, 1)],
        };
        (p, lay, us, ys)
    }

    fn records<'a>(us: &'a [DMatrix<f64>], ys: &'a [DMatrix<f64>]) -> Vec<Record<'a>> {
        us.iter()
            .zip(ys)
            .map(|(u, y)| Record {
                u,
                y,
                instrument: None,
            })
            .collect()
    }

    /// (Jᵀe, JᵀJ) from the analytic R of [J | e].
    fn normal_terms(raug: &DMatrix<f64>) -> (DVector<f64>, DMatrix<f64>) {
        let np = raug.ncols() - 1;
        let r11 = raug.view((0, 0), (np, np));
        let rv = raug.view((0, np), (np, 1));
        (
            (r11.transpose() * rv).column(0).into_owned(),
            r11.transpose() * r11,
        )
    }

    fn rel(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
        (a - b).norm() / b.norm()
    }

    #[test]
    fn analytic_gradient_matches_central_differences() {
        for (gain, nan_every, seed) in [(false, 1, 1), (true, 1, 2), (false, 5, 3), (true, 5, 4)] {
            let (p, lay, us, ys) = setup(seed, gain, 400, nan_every);
            let recs = records(&us, &ys);
            let weights = output_weights(&recs, lay.ny);
            let total = recs
                .iter()
                .map(|r| r.y.iter().filter(|v| !v.is_nan()).count())
                .sum();
            let cost_of = |q: &Point| residuals(q, &recs, &weights, gain, total);
            let theta = p.pack(&lay);
            let basis = lifted_linalg::null_space(
                &p.similarity_tangent(&lay).transpose(),
                lifted_linalg::RankTolerance::Default,
            )
            .unwrap();
            let e = cost_of(&p).unwrap();
            let jfd = jacobian_fd(&theta, &basis, &lay, &e, &cost_of);
            let raug = jacobian_r(&p, &basis, &lay, &recs, &weights, gain, 1, 1).unwrap();
            let (g, h) = normal_terms(&raug);
            let gfd = jfd.transpose() * &e;
            let hfd = jfd.transpose() * &jfd;
            let (eg, eh) = (
                rel(
                    &DMatrix::from_column_slice(g.len(), 1, g.as_slice()),
                    &DMatrix::from_column_slice(gfd.len(), 1, gfd.as_slice()),
                ),
                rel(&h, &hfd),
            );
            assert!(
                eg < 1e-6 && eh < 1e-6,
                "gain {gain}, NaN every {nan_every}: gradient {eg:.1e}, JᵀJ {eh:.1e}"
            );
            // ‖e‖² = ‖r‖² + ρ² (the last diagonal entry of R).
            let np = basis.ncols();
            let ee = raug.view((0, np), (np + 1, 1)).norm_squared();
            assert!((ee - e.norm_squared()).abs() < 1e-10 * e.norm_squared());
        }
    }

    #[test]
    fn thread_count_changes_the_jacobian_by_rounding_only() {
        for (gain, nan_every) in [(true, 5), (false, 1)] {
            let (p, lay, us, ys) = setup(9, gain, 3 * MIN_RANGE + 17, nan_every);
            let recs = records(&us, &ys);
            let weights = output_weights(&recs, lay.ny);
            let basis = lifted_linalg::null_space(
                &p.similarity_tangent(&lay).transpose(),
                lifted_linalg::RankTolerance::Default,
            )
            .unwrap();
            let one = jacobian_r(&p, &basis, &lay, &recs, &weights, gain, 1, 1).unwrap();
            let (g1, h1) = normal_terms(&one);
            for threads in [2, 3, 4] {
                let many = jacobian_r(&p, &basis, &lay, &recs, &weights, gain, threads, 1).unwrap();
                let (g, h) = normal_terms(&many);
                let eg = (&g - &g1).norm() / g1.norm();
                let eh = rel(&h, &h1);
                assert!(
                    eg < 1e-9 && eh < 1e-11,
                    "{threads} threads: {eg:.1e} {eh:.1e}"
                );
            }
        }
    }

    /// With a Hessian subsample the gradient R₁₁ᵀr̃ is still the exact Jᵀe
    /// (to rounding), R₁₁ᵀR₁₁ estimates JᵀJ (a third of the rows after
    /// the head, scaled by 3: within 25 % in norm on these white-noise
    /// records, where the spread of such an estimate is a few per cent),
    /// and the thread count changes it by rounding only (blocks chosen by
    /// absolute sample index).
    #[test]
    fn hessian_subsample_keeps_the_exact_gradient() {
        for (gain, nan_every) in [(true, 1), (false, 5)] {
            let (p, lay, us, ys) = setup(21, gain, 3 * MIN_RANGE + 4000, nan_every);
            let recs = records(&us, &ys);
            let weights = output_weights(&recs, lay.ny);
            let basis = lifted_linalg::null_space(
                &p.similarity_tangent(&lay).transpose(),
                lifted_linalg::RankTolerance::Default,
            )
            .unwrap();
            let exact = jacobian_r(&p, &basis, &lay, &recs, &weights, gain, 1, 1).unwrap();
            let (g, h) = normal_terms(&exact);
            let sub = jacobian_r(&p, &basis, &lay, &recs, &weights, gain, 1, 3).unwrap();
            let (gs, hs) = normal_terms(&sub);
            let eg = (&gs - &g).norm() / g.norm();
            let eh = rel(&hs, &h);
            assert!(eg < 1e-10, "gradient {eg:.1e}");
            assert!(eh < 0.25 && eh > 0.0, "JᵀJ {eh:.1e}");
            let many = jacobian_r(&p, &basis, &lay, &recs, &weights, gain, 3, 3).unwrap();
            let (gm, hm) = normal_terms(&many);
            assert!((&gm - &gs).norm() / gs.norm() < 1e-9);
            assert!(rel(&hm, &hs) < 1e-11);
        }
    }
}

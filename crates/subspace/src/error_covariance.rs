//! The one-step prediction cost of a Kalman gain from the covariances of
//! a reference predictor's errors: the Kalman-gain check's cheap first
//! phase ([`crate::gain_check`]).
//!
//! With A, B, C, D fixed and every predictor started from one state, the
//! one-step errors of a gain K are a filter of those of any reference
//! gain K₀ whose predictor is stable (the simulation's for K₀ = 0): the
//! difference of the two predictors' states, d(t), follows
//! d(t+1) = M d(t) + ΔK e(t), d(0) = 0, with M = A − K C, ΔK = K − K₀
//! and e the reference's errors, and ε(t) = e(t) − C d(t). Written with
//! A₀ = A − K₀ C, M = A₀ − ΔK C: the gain ΔK on the model (A₀, C) with
//! the simulation errors e, the form used below (K₀ = 0, A₀ = A). So
//! ε = Σ_{i≥0} h_i e(t−i) with h_0 = I, h_i = −C M^{i−1} K (the inverse
//! noise filter H⁻¹ of the innovations form), and the cost
//! Σ_t ε(t)ᵀ W² ε(t) is a quadratic form in the error covariances
//! R(τ) = Σ_t e(t) e(t−τ)ᵀ:
//!
//! J(K) = Σ_{i,j} tr(h_iᵀ W² h_j R(i−j))
//!      = tr(W² R₀) + tr(Kᵀ X K R₀) − 2 tr(W² C Z₁) + 2 tr(X M Z₁ Kᵀ),
//!
//! X = Σ_j M^{jᵀ} Cᵀ W² C M^j (the Stein equation X = Mᵀ X M + Cᵀ W² C,
//! solved by doubling), Z₁ = Σ_{τ≥1} M^{τ−1} K R(τ)ᵀ (Horner's scheme),
//! using that M^{τᵀ} commutes with the sum in X. That is the cost of the
//! records continued by zeros; the cost over the records is it less each
//! record's d(N)ᵀ X d(N), the predictor's free response after the last
//! sample, with d(N) = Σ_j M^j K e(N−1−j) from the record's last L errors
//! (Horner again). So J is the one-step cost over the records exactly, up
//! to the lags cut at L (where M^L is below rounding, or all of them on
//! records shorter than [`MAX_LAGS`]) and rounding. The gradient comes by
//! the reverse of the same steps (the adjoint Stein equation
//! Y = M Y Mᵀ + S and Horner's schemes backwards), so an evaluation with
//! its gradient costs O(L (n² n_y + n n_y²) + n³ log L) a record's end
//! and the lags, independent of the records' length: the records are read
//! once, for R(τ) by FFT (O(N n_y² log N)).
//!
//! [`Covariances::minimise`] runs BFGS on this cost from the start's
//! Hessian (forward differences of the gradient: the costs are
//! ill-conditioned, and a scaled identity took 95–133 iterations where this
//! takes 4–27); the gain check then finishes on the records with the BFGS
//! curvature and the exact gradient (a predictor run and its adjoint, a
//! trial only where a step predicts more than the stopping decrease),
//! instead of folding Gauss–Newton factors of the N-row Jacobian, whose
//! quadratic model mispredicts large-residual problems such as an
//! under-modelled order.

use lifted_linalg::fft::{Transforms, fast_length};
use lifted_linalg::spectral_radius;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex;

/// Most lags of R(τ) kept: M's memory beyond it is cut (the cost then
/// approximates more coarsely; the exact phase corrects it). 4096 lags
/// hold a predictor pole of modulus 0.99 to 1e-18 of its start.
pub(crate) const MAX_LAGS: usize = 4096;

/// The lags used at a predictor of spectral radius `rho`: those over
/// which ρ^τ falls below 1e-15 (the terms beyond are rounding), plus a
/// margin for a non-normal M, at most `available`.
fn lags_for(rho: f64, available: usize) -> usize {
    let memory = if rho <= 1e-3 {
        8.0
    } else {
        (1e-15f64.ln() / rho.ln()).ceil() + 16.0
    };
    (memory.min(available as f64) as usize)
        .max(1)
        .min(available)
}

/// The simulation errors' covariances R(τ), τ = 0 … L, summed over the
/// records, and the outputs' weights W² (the gain check's normalisation).
pub(crate) struct Covariances {
    /// R(τ)ᵀ, τ = 0 … L (n_y × n_y each).
    rt: Vec<DMatrix<f64>>,
    /// W² (diagonal).
    w2: Vec<f64>,
    /// Each record's last L + 1 errors, the latest first (row-major, n_y
    /// a sample): the predictor's state after the last sample, d(N), for
    /// the end correction.
    tails: Vec<Vec<f64>>,
}

/// What [`Covariances::minimise`] gives: the gain, the inverse Hessian of
/// the last BFGS update (P × P, vec K column-major) and the iterations.
pub(crate) struct Minimum {
    pub k: DMatrix<f64>,
    pub inverse_hessian: DMatrix<f64>,
    pub iterations: usize,
}

impl Covariances {
    /// From the simulation errors of each record (row-major, n_y a sample,
    /// as `OneStep::with_errors` gives them) and the weights W². `None`
    /// when a record is empty or not finite. O(N n_y² log N) by FFT
    /// ([`add_covariances`]).
    pub(crate) fn from_errors(errors: &[Vec<f64>], ny: usize, w2: &[f64]) -> Option<Self> {
        lifted_linalg::simd::dispatch(
            #[inline(always)]
            || {
                let longest = errors.iter().map(|e| e.len() / ny.max(1)).max()?;
                if ny == 0 || longest < 2 {
                    return None;
                }
                let lags = MAX_LAGS.min(longest - 1);
                let mut r = vec![DMatrix::zeros(ny, ny); lags + 1];
                for e in errors {
                    if e.len() < ny {
                        continue;
                    }
                    if e.iter().any(|v| !v.is_finite()) {
                        return None;
                    }
                    add_covariances(e, ny, &mut r).ok()?;
                }
                // R(0) is symmetric in exact arithmetic.
                let r0 = (&r[0] + r[0].transpose()) * 0.5;
                r[0] = r0;
                let tails = errors
                    .iter()
                    .filter(|e| e.len() >= ny)
                    .map(|e| {
                        e.chunks_exact(ny)
                            .rev()
                            .take(lags + 1)
                            .flatten()
                            .copied()
                            .collect()
                    })
                    .collect();
                Some(Covariances {
                    rt: r.iter().map(|m| m.transpose()).collect(),
                    w2: w2.to_vec(),
                    tails,
                })
            },
        )
    }

    /// J(K) (module docs) and, with `gradient`, ∂J/∂vec K; `None` when
    /// A − K C is not stable or a number is not finite.
    /// O(L (n² n_y + n n_y²) + n³ log L).
    pub(crate) fn cost(
        &self,
        a: &DMatrix<f64>,
        c: &DMatrix<f64>,
        k: &DMatrix<f64>,
        gradient: bool,
    ) -> Option<(f64, Option<DVector<f64>>)> {
        lifted_linalg::simd::dispatch(
            #[inline(always)]
            || {
                let (n, ny) = (a.nrows(), c.nrows());
                let m = a - k * c;
                let rho = spectral_radius(&m).ok()?;
                if rho.is_nan() || rho >= 1.0 {
                    return None;
                }
                let lags = lags_for(rho, self.rt.len() - 1);
                let w2 = DMatrix::from_diagonal(&DVector::from_column_slice(&self.w2));
                let w2c = &w2 * c;
                let q = c.transpose() * &w2c;
                let x = stein(&m.transpose(), &q)?;
                let r0 = &self.rt[0];
                // Horner: Z_τ = M Z_{τ+1} + K R_τᵀ, Z_L = K R_Lᵀ, every Z_τ kept
                // for the gradient (block τ − 1 of `z`, column-major n × n_y).
                let nny = n * ny;
                let mut z = vec![0.0; lags * nny];
                let (ms, ks) = (m.as_slice(), k.as_slice());
                for tau in (1..=lags).rev() {
                    let (lo, hi) = z.split_at_mut(tau * nny);
                    let zt = &mut lo[(tau - 1) * nny..];
                    let rt = self.rt[tau].as_slice();
                    for (col, zc) in zt.chunks_exact_mut(n).enumerate() {
                        zc.fill(0.0);
                        for (l, kl) in ks.chunks_exact(n).enumerate() {
                            axpy(zc, kl, rt[l + col * ny]);
                        }
                        if tau < lags {
                            let next = &hi[col * n..(col + 1) * n];
                            for (ml, v) in ms.chunks_exact(n).zip(next) {
                                axpy(zc, ml, *v);
                            }
                        }
                    }
                }
                let z1 = DMatrix::from_column_slice(n, ny, &z[..nny]);
                let xk = &x * k;
                let mz1 = &m * &z1;
                // The end correction: each record's d(N) = Σ_j M^j K e(N−1−j) by
                // Horner from its oldest kept error (every D_j kept for the
                // gradient), and its free response d(N)ᵀ X d(N) taken off.
                let ends: Vec<(Vec<f64>, usize)> = self
                    .tails
                    .iter()
                    .map(|tail| end_states(ms, ks, tail, n, ny, lags))
                    .collect();
                let mut end = 0.0;
                for (d, _) in &ends {
                    let dn = DVector::from_column_slice(&d[..n]);
                    end += dn.dot(&(&x * &dn));
                }
                let cost = (&w2 * r0.transpose()).trace() + (k.transpose() * &xk * r0).trace()
                    - 2.0 * (&w2c * &z1).trace()
                    + 2.0 * (&x * &mz1 * k.transpose()).trace()
                    - end;
                if !cost.is_finite() {
                    return None;
                }
                if !gradient {
                    return Some((cost, None));
                }
                // Reverse of the steps above (module docs).
                let kz = &mz1 * k.transpose();
                let mut s = k * r0 * k.transpose() + &kz + kz.transpose();
                for (d, _) in &ends {
                    let dn = DVector::from_column_slice(&d[..n]);
                    s -= &dn * dn.transpose();
                }
                let y = stein(&m, &s)?;
                let bt = -2.0 * w2c.transpose() + 2.0 * m.transpose() * &xk;
                let mut gk = 2.0 * &xk * r0 + 2.0 * &x * &mz1;
                let mut gm = 2.0 * &x * &m * &y + 2.0 * &xk * z1.transpose();
                // Horner backwards: Ẑ_1 = Bᵀ, Ẑ_{τ+1} = Mᵀ Ẑ_τ; ∂K += Ẑ_τ R_τ,
                // ∂M += Ẑ_τ Z_{τ+1}ᵀ.
                let mut zhat = bt.as_slice().to_vec();
                let mut spare = vec![0.0; nny];
                let (gks, gms) = (gk.as_mut_slice(), gm.as_mut_slice());
                for tau in 1..=lags {
                    let rt = self.rt[tau].as_slice();
                    for (col, gc) in gks.chunks_exact_mut(n).enumerate() {
                        for (l, zl) in zhat.chunks_exact(n).enumerate() {
                            axpy(gc, zl, rt[col + l * ny]);
                        }
                    }
                    if tau < lags {
                        let next = &z[tau * nny..(tau + 1) * nny];
                        for (col, gc) in gms.chunks_exact_mut(n).enumerate() {
                            for (o, zo) in zhat.chunks_exact(n).enumerate() {
                                axpy(gc, zo, next[col + o * n]);
                            }
                        }
                        for (sp, zo) in spare.chunks_exact_mut(n).zip(zhat.chunks_exact(n)) {
                            mul_transpose(sp, ms, zo);
                        }
                        std::mem::swap(&mut zhat, &mut spare);
                    }
                }
                // The end correction backwards: â_0 = −2 X d(N), â_{j+1} = Mᵀ â_j;
                // ∂K += â_j e(N−1−j)ᵀ, ∂M += â_j D_{j+1}ᵀ.
                for ((d, kept), tail) in ends.iter().zip(&self.tails) {
                    let dn = DVector::from_column_slice(&d[..n]);
                    let mut ahat = (&x * &dn * -2.0).as_slice().to_vec();
                    let mut next = vec![0.0; n];
                    for j in 0..*kept {
                        let e = &tail[j * ny..(j + 1) * ny];
                        for (o, gc) in gks.chunks_exact_mut(n).enumerate() {
                            axpy(gc, &ahat, e[o]);
                        }
                        if j + 1 < *kept {
                            let dj = &d[(j + 1) * n..(j + 2) * n];
                            for (col, gc) in gms.chunks_exact_mut(n).enumerate() {
                                axpy(gc, &ahat, dj[col]);
                            }
                            mul_transpose(&mut next, ms, &ahat);
                            std::mem::swap(&mut ahat, &mut next);
                        }
                    }
                }
                let g = gk - gm * c.transpose();
                debug_assert_eq!(g.shape(), (n, ny));
                g.iter()
                    .all(|v| v.is_finite())
                    .then(|| (cost, Some(DVector::from_column_slice(g.as_slice()))))
            },
        )
    }

    /// The inverse of the Hessian at θ by forward differences of the
    /// gradient `eval` gives (step 1e-6 of max(|θ_p|, 1e-3)), symmetrised,
    /// its eigenvalues floored at 1e-10 of the largest; `None` when a
    /// step's predictor is not stable or the Hessian has no positive
    /// eigenvalue.
    fn start_curvature(
        &self,
        eval: &impl Fn(&DVector<f64>) -> Option<(f64, DVector<f64>)>,
        theta: &DVector<f64>,
        g: &DVector<f64>,
    ) -> Option<DMatrix<f64>> {
        let p = theta.len();
        let mut hess = DMatrix::zeros(p, p);
        for j in 0..p {
            let step = 1e-6 * theta[j].abs().max(1e-3);
            let mut t = theta.clone();
            t[j] += step;
            let (_, gj) = eval(&t)?;
            hess.set_column(j, &((gj - g) / step));
        }
        let sym = (&hess + hess.transpose()) * 0.5;
        let eig = sym.symmetric_eigen();
        let top = eig.eigenvalues.max();
        if !(top > 0.0 && top.is_finite()) {
            return None;
        }
        let inv = eig.eigenvalues.map(|l| 1.0 / l.max(1e-10 * top));
        Some(&eig.eigenvectors * DMatrix::from_diagonal(&inv) * eig.eigenvectors.transpose())
    }

    /// BFGS on J from `start` (A − K C stable there), every trial's
    /// predictor stable (an unstable trial is a failed one), until an
    /// iteration lowers J by less than 1e-12 of it (rounding: J is exact,
    /// so its minimum is the check's) or `max_iterations`. (A stop on
    /// BFGS's own estimate of the decrease to come, ½ gᵀ H g, was tried
    /// and dropped: on the long, narrow valleys of short real records it
    /// stopped 50 % above the minimum.) `None` when J cannot be evaluated
    /// at the start.
    pub(crate) fn minimise(
        &self,
        a: &DMatrix<f64>,
        c: &DMatrix<f64>,
        start: &DMatrix<f64>,
        max_iterations: usize,
    ) -> Option<Minimum> {
        let (n, ny) = start.shape();
        let p = n * ny;
        let gain = |theta: &DVector<f64>| DMatrix::from_column_slice(n, ny, theta.as_slice());
        let eval = |theta: &DVector<f64>| {
            self.cost(a, c, &gain(theta), true)
                .and_then(|(f, g)| Some((f, g?)))
        };
        let mut theta = DVector::from_column_slice(start.as_slice());
        let (mut f, mut g) = eval(&theta)?;
        // The start's inverse Hessian from forward differences of the
        // gradient (P gradients), its eigenvalues floored at 1e-10 of the
        // largest: BFGS then starts with the curvature it would otherwise
        // learn over many steps (the check's costs are ill-conditioned).
        let (mut h, mut scaled) = match self.start_curvature(&eval, &theta, &g) {
            Some(h) => (h, true),
            None => (DMatrix::<f64>::identity(p, p), false),
        };
        let mut iterations = 0;
        while iterations < max_iterations {
            iterations += 1;
            let mut dir = -(&h * &g);
            let mut slope = g.dot(&dir);
            if slope.is_nan() || slope >= 0.0 {
                // Not a descent direction: steepest descent, curvature anew.
                h = DMatrix::identity(p, p);
                scaled = false;
                dir = -g.clone();
                slope = -g.norm_squared();
                if slope == 0.0 {
                    break;
                }
            }
            // Backtracking (Armijo) line search from the full step.
            let mut alpha = 1.0;
            let mut found = None;
            for _ in 0..60 {
                let trial = &theta + alpha * &dir;
                if let Some((ft, gt)) = eval(&trial)
                    && ft <= f + 1e-4 * alpha * slope
                {
                    found = Some((trial, ft, gt));
                    break;
                }
                alpha *= 0.5;
            }
            let Some((trial, ft, gt)) = found else {
                break;
            };
            let s = &trial - &theta;
            let yv = &gt - &g;
            if let Some(sy) = positive_curvature(&s, &yv) {
                if !scaled {
                    h = DMatrix::identity(p, p) * (sy / yv.norm_squared());
                    scaled = true;
                }
                bfgs_update(&mut h, &s, &yv, sy);
            }
            let decrease = f - ft;
            (theta, f, g) = (trial, ft, gt);
            if decrease <= 1e-12 * f.abs() {
                break;
            }
        }
        Some(Minimum {
            k: gain(&theta),
            inverse_hessian: h,
            iterations,
        })
    }
}

/// Adds to `r` (R(τ), τ = 0 … r.len() − 1) the lagged products of one
/// record's errors `e` (row-major, n_y a sample): R_ab(τ) += Σ_t e_a(t)
/// e_b(t − τ). By FFT of the record zero-padded to m ≥ N + L points
/// ([`fast_length`]; the circular sums are then the linear ones): two real channels a
/// transform (z = x + i y, X_k = (Z_k + conj Z_{m−k})/2, Y_k = (Z_k −
/// conj Z_{m−k})/(2i)), and two real correlations an inverse transform
/// (their spectra are Hermitian: IFFT(P + i Q) = p + i q). ⌈n_y/2⌉ +
/// ⌈n_y(n_y+1)/4⌉ transforms, O(n_y² m log m).
fn add_covariances(e: &[f64], ny: usize, r: &mut [DMatrix<f64>]) -> lifted_linalg::Result<()> {
    let n = e.len() / ny;
    let lags = r.len() - 1;
    let m = fast_length(n + lags);
    let mut fft = Transforms::new(m);
    let zero = Complex::new(0.0, 0.0);
    // The transforms of the channel pairs (x + i y).
    let mut packed: Vec<Vec<Complex<f64>>> = Vec::with_capacity(ny.div_ceil(2));
    for first in (0..ny).step_by(2) {
        let second = (first + 1 < ny).then_some(first + 1);
        let mut z = vec![zero; m];
        for (t, zt) in z.iter_mut().take(n).enumerate() {
            let im = second.map_or(0.0, |b| e[t * ny + b]);
            *zt = Complex::new(e[t * ny + first], im);
        }
        fft.forward(&mut z)?;
        packed.push(z);
    }
    // Channel c's spectrum at k: X_k = (Z_k + conj Z_{m−k})/2 for the
    // first of its pair, Y_k = (Z_k − conj Z_{m−k})/(2i) for the second.
    let spectrum_at = |k: usize, out: &mut [Complex<f64>]| {
        for (p, z) in packed.iter().enumerate() {
            let (x, y) = lifted_linalg::fft::split_packed(z, k);
            out[2 * p] = x;
            if 2 * p + 1 < ny {
                out[2 * p + 1] = y;
            }
        }
    };
    let mut z = vec![zero; m];
    let mut at = vec![zero; ny];
    let pairs: Vec<(usize, usize)> = (0..ny).flat_map(|a| (a..ny).map(move |b| (a, b))).collect();
    let scale = 1.0 / m as f64;
    for two in pairs.chunks(2) {
        let (a, b) = two[0];
        let other = two.get(1).copied();
        for (k, zk) in z.iter_mut().enumerate() {
            spectrum_at(k, &mut at);
            let p = at[a] * at[b].conj();
            let q = other.map_or(zero, |(c, d)| at[c] * at[d].conj());
            *zk = p + Complex::new(-q.im, q.re);
        }
        fft.inverse(&mut z)?;
        let mut put = |(a, b): (usize, usize), part: fn(&Complex<f64>) -> f64| {
            for (tau, rt) in r.iter_mut().enumerate() {
                rt[(a, b)] += part(&z[tau]) * scale;
                if a != b {
                    rt[(b, a)] += part(&z[(m - tau) % m]) * scale;
                }
            }
        };
        put((a, b), |c| c.re);
        if let Some(pair) = other {
            put(pair, |c| c.im);
        }
    }
    Ok(())
}

/// A record's end states D_j = M D_{j+1} + K e(N−1−j), j = J … 0
/// (D_{J+1} = 0; J + 1 = the errors kept, at most `lags` + 1), so that
/// D_0 = d(N), the state difference after the last sample: D_j in
/// entries j n … (j + 1) n of the first element, J + 1 the second. `ms`,
/// `ks`: M and K column-major; `tail`: the errors, the latest first.
fn end_states(
    ms: &[f64],
    ks: &[f64],
    tail: &[f64],
    n: usize,
    ny: usize,
    lags: usize,
) -> (Vec<f64>, usize) {
    let kept = (tail.len() / ny).min(lags + 1);
    let mut d = vec![0.0; kept * n];
    for j in (0..kept).rev() {
        let (lo, hi) = d.split_at_mut((j + 1) * n);
        let dj = &mut lo[j * n..];
        let e = &tail[j * ny..(j + 1) * ny];
        for (kl, v) in ks.chunks_exact(n).zip(e) {
            axpy(dj, kl, *v);
        }
        if j + 1 < kept {
            for (ml, v) in ms.chunks_exact(n).zip(&hi[..n]) {
                axpy(dj, ml, *v);
            }
        }
    }
    (d, kept)
}

/// out ← Mᵀ x for M column-major with columns of `x.len()` entries (one
/// dot product a column).
#[inline(always)]
fn mul_transpose(out: &mut [f64], m: &[f64], x: &[f64]) {
    for (v, column) in out.iter_mut().zip(m.chunks_exact(x.len())) {
        *v = column.iter().zip(x).map(|(a, b)| a * b).sum();
    }
}

/// sᵀy when it is positive beyond rounding (sᵀy > 1e-12 ‖s‖ ‖y‖): the
/// curvature along the step s (gradient change y) that a BFGS update
/// needs, else `None`.
pub(crate) fn positive_curvature(s: &DVector<f64>, y: &DVector<f64>) -> Option<f64> {
    let sy = s.dot(y);
    (sy > 1e-12 * s.norm() * y.norm()).then_some(sy)
}

/// BFGS's update of the inverse Hessian, H ← (I − ρ s yᵀ) H (I − ρ y sᵀ)
/// + ρ s sᵀ with ρ = 1/sᵀy (`sy`, from [`positive_curvature`]).
pub(crate) fn bfgs_update(h: &mut DMatrix<f64>, s: &DVector<f64>, y: &DVector<f64>, sy: f64) {
    let rho = 1.0 / sy;
    let hy = &*h * y;
    let yhy = y.dot(&hy);
    *h += (s * s.transpose()) * (rho * (1.0 + rho * yhy))
        - (&hy * s.transpose() + s * hy.transpose()) * rho;
}

/// y ← y + a x (slices of one length).
#[inline(always)]
fn axpy(y: &mut [f64], x: &[f64], a: f64) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}

/// X = Σ_j F^j G F^{jᵀ} for `f` stable (X = F X Fᵀ + G), by doubling:
/// X ← X + F_k X F_kᵀ, F_k ← F_k², until F_k's contribution is below
/// rounding (at most 64 squarings). `None` when it does not converge.
/// With F = Mᵀ it is the Stein equation X = Mᵀ X M + G.
fn stein(f: &DMatrix<f64>, g: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let mut x = g.clone();
    let mut fk = f.clone();
    for _ in 0..64 {
        let add = &fk * &x * fk.transpose();
        let small = add.norm() <= 1e-17 * x.norm();
        x += add;
        if small {
            return x.iter().all(|v| v.is_finite()).then_some(x);
        }
        fk = &fk * &fk;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// A 3-state, 2-output (A, C), a gain K with A − K C stable, and
    /// coloured errors e(t) of `n` samples (row-major).
    fn setup(n: usize) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>, Vec<f64>) {
        let a = DMatrix::from_row_slice(3, 3, &[0.8, 0.2, 0.0, -0.2, 0.8, 0.1, 0.0, 0.0, 0.5]);
        let c = DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.5, 0.0, 1.0, -0.3]);
        let k = DMatrix::from_row_slice(3, 2, &[0.3, 0.1, -0.1, 0.2, 0.05, 0.1]);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut e = Vec::with_capacity(2 * n);
        let (mut s0, mut s1) = (0.0, 0.0);
        for _ in 0..n {
            let v0: f64 = StandardNormal.sample(&mut rng);
            let v1: f64 = StandardNormal.sample(&mut rng);
            s0 = 0.7 * s0 + v0;
            s1 = -0.4 * s1 + v1 + 0.3 * v0;
            e.push(s0);
            e.push(s1);
        }
        (a, c, k, e)
    }

    /// Σ_t ε(t)ᵀ W² ε(t) over the record, by the recursion
    /// d(t+1) = M d(t) + K e(t).
    fn direct(a: &DMatrix<f64>, c: &DMatrix<f64>, k: &DMatrix<f64>, e: &[f64], w2: &[f64]) -> f64 {
        let (n, ny) = (a.nrows(), c.nrows());
        let m = a - k * c;
        let mut d = DVector::zeros(n);
        let mut cost = 0.0;
        for et in e.chunks_exact(ny) {
            let et = DVector::from_column_slice(et);
            let eps = &et - c * &d;
            cost += eps.iter().zip(w2).map(|(v, w)| w * v * v).sum::<f64>();
            d = &m * &d + k * &et;
        }
        cost
    }

    /// The cost and its gradient against the recursion and finite
    /// differences for random shapes (orders 1–6, 1–3 outputs, 1–3
    /// records of 2–400 samples, A − K C of spectral radius up to 0.97),
    /// seeded.
    #[test]
    fn the_cost_holds_for_random_shapes() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(30);
        let mut normal = || -> f64 { StandardNormal.sample(&mut rng) };
        for case in 0..60 {
            let n = 1 + case % 6;
            let ny = 1 + (case / 6) % 3;
            let records = 1 + case % 3;
            let a = DMatrix::from_fn(n, n, |_, _| normal());
            let c = DMatrix::from_fn(ny, n, |_, _| normal());
            let k = DMatrix::from_fn(n, ny, |_, _| 0.3 * normal());
            // Scale A so that A − K C has the radius drawn.
            let radius = 0.2 + 0.77 * ((case * 7919) % 100) as f64 / 100.0;
            let m = &a - &k * &c;
            let rho = spectral_radius(&m).unwrap().max(1e-6);
            let a = (m * (radius / rho)) + &k * &c;
            let errors: Vec<Vec<f64>> = (0..records)
                .map(|r| {
                    let len = 2 + (case * 37 + r * 101) % 399;
                    (0..len * ny).map(|_| normal()).collect()
                })
                .collect();
            let w2: Vec<f64> = (0..ny).map(|o| 0.5 + o as f64).collect();
            let cov = Covariances::from_errors(&errors, ny, &w2).unwrap();
            let (j, g) = cov.cost(&a, &c, &k, true).unwrap();
            let want: f64 = errors.iter().map(|e| direct(&a, &c, &k, e, &w2)).sum();
            assert_relative_eq!(j, want, max_relative = 1e-9);
            let g = g.unwrap();
            let scale = g.amax().max(want);
            for p in 0..n * ny {
                let h = 1e-6;
                let (mut kp, mut km) = (k.clone(), k.clone());
                kp[p] += h;
                km[p] -= h;
                let fd = (errors
                    .iter()
                    .map(|e| direct(&a, &c, &kp, e, &w2))
                    .sum::<f64>()
                    - errors
                        .iter()
                        .map(|e| direct(&a, &c, &km, e, &w2))
                        .sum::<f64>())
                    / (2.0 * h);
                assert!(
                    (g[p] - fd).abs() <= 1e-5 * scale,
                    "case {case} (n {n}, n_y {ny}): {} against {fd}",
                    g[p]
                );
            }
        }
    }

    #[test]
    fn the_cost_is_the_filtered_errors_sum() {
        // (A short record too: every lag kept, the end correction then
        // the whole difference.)
        for n in [25, 3000] {
            let (a, c, k, e) = setup(n);
            let w2 = [0.7, 1.3];
            let cov = Covariances::from_errors(std::slice::from_ref(&e), 2, &w2).unwrap();
            let (j, _) = cov.cost(&a, &c, &k, false).unwrap();
            assert_relative_eq!(j, direct(&a, &c, &k, &e, &w2), max_relative = 1e-11);
        }
        let (a, c, _, e) = setup(3000);
        let w2 = [0.7, 1.3];
        let cov = Covariances::from_errors(std::slice::from_ref(&e), 2, &w2).unwrap();
        // K = 0: the errors' own weighted sum.
        let zero = DMatrix::zeros(3, 2);
        let (j0, _) = cov.cost(&a, &c, &zero, false).unwrap();
        assert_relative_eq!(j0, direct(&a, &c, &zero, &e, &w2), max_relative = 1e-12);
    }

    /// R(τ) by the packed transforms equals the direct lagged sums, for
    /// an odd number of channels (one transform holds a single channel)
    /// and records of several lengths.
    #[test]
    fn the_covariances_are_the_lagged_sums() {
        let ny = 3;
        let records: Vec<Vec<f64>> = [40usize, 7, 13]
            .iter()
            .map(|&n| {
                (0..n * ny)
                    .map(|i| ((i * 37 + n) % 23) as f64 * 0.25 - 2.5)
                    .collect()
            })
            .collect();
        let cov = Covariances::from_errors(&records, ny, &[1.0; 3]).unwrap();
        assert_eq!(cov.rt.len(), 40);
        for (tau, rt) in cov.rt.iter().enumerate() {
            for a in 0..ny {
                for b in 0..ny {
                    let mut want = 0.0;
                    for e in &records {
                        let n = e.len() / ny;
                        for t in tau..n {
                            want += e[t * ny + a] * e[(t - tau) * ny + b];
                        }
                    }
                    // rt holds R(τ)ᵀ.
                    assert!((rt[(b, a)] - want).abs() < 1e-10, "τ {tau} ({a}, {b})");
                }
            }
        }
    }

    #[test]
    fn the_gradient_is_the_cost_s_derivative() {
        let (a, c, k, e) = setup(2000);
        let w2 = [0.7, 1.3];
        let cov = Covariances::from_errors(std::slice::from_ref(&e), 2, &w2).unwrap();
        let (_, g) = cov.cost(&a, &c, &k, true).unwrap();
        let g = g.unwrap();
        for p in 0..6 {
            let h = 1e-6;
            let mut kp = k.clone();
            kp[p] += h;
            let mut km = k.clone();
            km[p] -= h;
            let fd = (cov.cost(&a, &c, &kp, false).unwrap().0
                - cov.cost(&a, &c, &km, false).unwrap().0)
                / (2.0 * h);
            assert_relative_eq!(g[p], fd, max_relative = 1e-6, epsilon = 1e-6);
        }
    }

    #[test]
    fn bfgs_reaches_a_stationary_point_below_the_start() {
        let (a, c, k, e) = setup(5000);
        let w2 = [1.0, 1.0];
        let cov = Covariances::from_errors(std::slice::from_ref(&e), 2, &w2).unwrap();
        let start = cov.cost(&a, &c, &k, false).unwrap().0;
        let min = cov.minimise(&a, &c, &k, 200).unwrap();
        let (end, g) = cov.cost(&a, &c, &min.k, true).unwrap();
        assert!(end < start);
        assert!(g.unwrap().amax() < 1e-6 * end, "gradient at the end");
        // Records split in two: the sum of their covariances.
        let halves = vec![e[..5000].to_vec(), e[5000..].to_vec()];
        let split = Covariances::from_errors(&halves, 2, &w2).unwrap();
        let whole = direct(&a, &c, &k, &e[..5000], &w2) + direct(&a, &c, &k, &e[5000..], &w2);
        assert_relative_eq!(
            split.cost(&a, &c, &k, false).unwrap().0,
            whole,
            max_relative = 1e-11
        );
    }

    #[test]
    fn an_unstable_predictor_has_no_cost() {
        let (a, c, _, e) = setup(500);
        let cov = Covariances::from_errors(std::slice::from_ref(&e), 2, &[1.0, 1.0]).unwrap();
        let k = DMatrix::from_row_slice(3, 2, &[-3.0, 0.0, 0.0, -3.0, 0.0, 0.0]);
        assert!(cov.cost(&a, &c, &k, true).is_none());
    }
}
